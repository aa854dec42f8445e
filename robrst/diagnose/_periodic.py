"""Periodic records recognised from the data: an input that repeats, with no ``period_samples``.

A multisine written as a plain ``t, u, y`` file (two identical periods, no ``#
period_samples`` line) is still periodic: simulated from rest it starts with a transient
the steady state does not have, and without its periods the noise floor comes from the
residual's spectrum, where the excitation may reach Nyquist.  :func:`find_period` finds the
shortest period ``P`` that divides the record into whole periods (at least two) in which
every input repeats — to ``repeat_rtol`` of its RMS (a measured input's own noise) plus
two steps of its quantisation (when that is finer than the tolerance) — and the temperature too (or is not
measured).  :func:`with_periods` marks such records periodic (``Dataset.period``): the
diagnosis then simulates them in steady state and takes the noise floor from the
period-to-period differences, and says so (finding ``periodic_records``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose.options import OPTIONS

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset

__all__ = ["find_period", "with_periods", "quantum"]


def quantum(x: np.ndarray) -> float:
    """The quantisation step of a signal: its smallest positive difference between distinct
    values (of a sample of at most 4096 of them), 0 for a constant.

    Parameters
    ----------
    x : numpy.ndarray
        The signal.

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.diagnose._periodic import quantum
    >>> round(quantum(np.round(np.sin(np.arange(1000) / 7), 3)), 12)
    0.001
    """
    v = np.unique(np.asarray(x, float)[::max(1, np.size(x) // 4096)])
    d = np.diff(v)
    d = d[d > 0]
    return float(d.min()) if d.size else 0.0


def _divisors(n, least):
    """Divisors ``P`` of ``n`` with ``P >= least`` and ``n // P >= 2``, increasing."""
    small = [p for p in range(1, int(np.sqrt(n)) + 1) if n % p == 0]
    every = sorted(set(small) | {n // p for p in small})
    return [p for p in every if p >= least and n // p >= 2]


def _repeats(x, P, tol):
    """Does ``x`` (N, c) repeat every ``P`` samples to ``tol`` per column (RMS of the
    differences) and to ``10 tol`` sample by sample?"""
    head = x[P:P + 1024] - x[:min(1024, len(x) - P)]    # most candidates fail here
    if np.any(np.sqrt(np.mean(head * head, axis=0)) > 3 * tol):
        return False
    D = x[P:] - x[:-P]
    rms = np.sqrt(np.mean(D * D, axis=0))
    return bool(np.all(rms <= tol) and np.all(np.max(np.abs(D), axis=0) <= 10 * tol))


def find_period(d: Dataset) -> int:
    """The shortest period (samples) every input of ``d`` repeats with, or 0.

    Parameters
    ----------
    d : Dataset
        The record (its declared ``period`` is returned as it is).

    Returns
    -------
    int
        ``P`` dividing the record into at least two whole periods of at least
        ``min_period`` samples, in which every input repeats (and the temperature, when
        measured); 0 when there is none or the input does not move.
    """
    if d.period:
        return int(d.period)
    opts = OPTIONS.records
    U = d.U
    level = np.sqrt(np.mean((U - U.mean(axis=0)) ** 2, axis=0))
    if not np.any(level > opts.excited_ptp):
        return 0
    # the quantisation counts only when it is fine (the few levels of a staircase input are
    # not its quantisation)
    q = np.array([quantum(c) for c in U.T])
    q = np.where(q <= opts.repeat_rtol * level, q, 0.0)
    tol_u = opts.repeat_rtol * level + 2 * q
    T = None if d.temp is None else np.asarray(d.temp, float)[:, None]
    for P in _divisors(d.n, opts.min_period):
        if not _repeats(U, P, tol_u):
            continue
        if T is not None and np.ptp(T) > 0 and not _repeats(
                T, P, max(opts.repeat_temp_K, 2 * quantum(T[:, 0]))):
            continue
        return P
    return 0


def with_periods(records: Sequence[Dataset]) -> tuple[list, list]:
    """The records, those whose input repeats marked periodic, and what was found.

    Parameters
    ----------
    records : sequence of Dataset
        The records.

    Returns
    -------
    list of Dataset
        The records (unchanged ones are the same objects).
    list of dict
        ``{"file", "period_samples", "periods"}`` per record found periodic here (none
        for a record that declared its period).
    """
    out, found = [], []
    for d in records:
        P = 0 if d.period else find_period(d)
        if P:
            d = replace(d, period=P)
            found.append({"file": d.source or "record", "period_samples": P,
                          "periods": d.n // P})
        out.append(d)
    return out, found
