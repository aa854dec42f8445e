"""The nuisance terms of a record that does not start at rest: offset and free response.

A measured record is a window on an actuator that was running before it: its output is
``y[k] = (G u)[k] + c + f[k]`` with ``(G u)`` the response from rest to the record's own
input, ``c`` a constant output offset (a sensor zero, a bias the input does not explain)
and ``f`` the free response of the state the record starts in — a sum of the model's own
modes, ``f[k] = sum_p Re(beta_p a_p^k)`` for sampled poles ``a_p``.  Both are per record
and per output, and both enter linearly: :func:`free_columns` builds their regressors,
:func:`fit_free` estimates them from a residual by least squares.  Vector fitting
eliminates them from its equations (``robrst.identify.vf``), and the identification scores
and reports its models with them (``robrst.identify.identification``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.data.dataset import Dataset
    from robrst.identify.modal import DiscreteModel

__all__ = ["free_columns", "fit_free", "record_starts", "RecordStart", "SIGNIFICANT_SIGMAS"]

SIGNIFICANT_SIGMAS = 5.0   # terms lowering the residual by more than 5 sigma of chi-square


def free_columns(zpoles: ArrayLike, n: int) -> np.ndarray:
    """Regressors ``(n, 1 + n_basis)``: a constant, then ``a^k`` per sampled pole.

    A complex pole (stored member, ``Im a > 0``) gives two real columns, ``Re a^k`` and
    ``Im a^k``; a real pole one.  ``k = 0 .. n - 1``.

    Parameters
    ----------
    zpoles : array_like
        Sampled poles (stored members: ``Im >= 0``).
    n : int
        Number of samples.

    Returns
    -------
    numpy.ndarray
        The regressors, shape ``(n, 1 + n_basis)``.
    """
    a = np.atleast_1d(np.asarray(zpoles, complex))
    k = np.arange(n, dtype=float)[:, None]
    pair = a.imag > 0
    # a^k = |a|^k e^{j k arg a}; a pole at the origin gives 1, 0, 0, ...
    P = np.exp(k * np.log(np.maximum(np.abs(a), 1e-300))) * np.exp(1j * k * np.angle(a))
    out = np.empty((n, 1 + a.size + int(pair.sum())))
    out[:, 0] = 1.0
    c = 1
    for p, is_pair in enumerate(pair):
        out[:, c] = P[:, p].real
        if is_pair:
            out[:, c + 1] = P[:, p].imag
        c += 1 + int(is_pair)
    return out


def fit_free(E: np.ndarray, zpoles: ArrayLike,
             fit: slice | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares offset and free response of a residual ``E`` (N or N x m).

    Parameters
    ----------
    E : ndarray
        Measured minus simulated-from-rest output, one column per output.
    zpoles : array_like
        The sampled model's poles (stored members: ``Im >= 0``).
    fit : slice, optional
        Samples the terms are estimated on (default: all); they are then extended over
        the whole record.

    Returns
    -------
    offset : ndarray (m,)
        The constant output offset ``c`` [µm].
    free : ndarray (N, m)
        The free response ``f`` over the record [µm] (offset not included).
    """
    E = np.asarray(E, float).reshape(len(E), -1)
    C = free_columns(zpoles, E.shape[0])
    rows = slice(None) if fit is None else fit
    Cf = C[rows]
    scale = np.linalg.norm(Cf, axis=0)
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(Cf / scale, E[rows], rcond=None)[0] / scale[:, None]
    return theta[0].copy(), C[:, 1:] @ theta[1:]


@dataclass(frozen=True)
class RecordStart:
    """Per record: the estimated output offset and the largest free-response magnitude.

    Parameters
    ----------
    name : str
        The record's name.
    offset_um : tuple of float
        The constant output offset per output [µm].
    initial_um : tuple of float
        ``max_k |f[k]|`` per output [µm], the size of the transient of the state the
        record started in (0 for a record starting at rest).
    scale_um : tuple of float
        The output's RMS variation per output [µm], the yardstick of :meth:`notes`.
    significant : bool
        The terms reduce the record's residual beyond what noise explains
        (:func:`record_starts`); otherwise the record is taken to start at rest with no
        offset.
    """

    name: str
    offset_um: tuple
    initial_um: tuple
    scale_um: tuple
    significant: bool = True

    def notes(self, share: float) -> list[str]:
        """Lines for a significant offset or start away from rest above ``share`` of the
        output's RMS variation.

        Parameters
        ----------
        share : float
            The threshold as a fraction of ``scale_um`` (e.g. 0.01).

        Returns
        -------
        list of str
            One line per output and term above it (none when not ``significant``).
        """
        if not self.significant:
            return []
        out = []
        for j, (c, f, s) in enumerate(zip(self.offset_um, self.initial_um, self.scale_um)):
            col = "y" if len(self.scale_um) == 1 else f"y{j + 1}"
            if abs(c) > share * s:
                out.append(f"{self.name}: column {col} has a constant offset of {c:.4g} µm the"
                           " input does not explain (estimated and removed)")
            if f > share * s:
                out.append(f"{self.name}: does not start at rest: the initial state's free"
                           f" response reaches {f:.4g} µm in column {col} (estimated and"
                           " removed)")
        return out

    def as_dict(self) -> dict:
        """The ``records`` entry of the identification JSON.

        Returns
        -------
        dict
            ``record, offset_um, initial_um, from_rest``.
        """
        return {"record": self.name, "offset_um": [float(x) for x in self.offset_um],
                "initial_um": [float(x) for x in self.initial_um],
                "from_rest": not self.significant}


def record_starts(dmodel: DiscreteModel, records: Sequence[Dataset], rest_model: DiscreteModel,
                  sigmas: float = SIGNIFICANT_SIGMAS) -> list[RecordStart]:
    """:class:`RecordStart` of each non-periodic record.

    Parameters
    ----------
    dmodel : DiscreteModel
        The sampled model fitted with the nuisance terms; they are estimated under it on
        each whole record.
    records : list of Dataset
        The records it was fitted on (periodic ones are skipped).
    rest_model : DiscreteModel
        The model of the same order fitted with every record starting at rest.
    sigmas : float
        The terms are ``significant`` when, on some output, the residual energy of
        ``rest_model`` from rest exceeds that of ``dmodel`` with them by more than
        ``q + sigmas sqrt(2 q)`` noise variances (``q`` terms: chi-square's mean plus
        ``sigmas`` standard deviations, if the record did start at rest with no offset);
        the noise variance is the residual per sample left with them, pooled; and when the
        from-rest fit misses the record's start (its first 10 %) more than the rest of it
        (:func:`_head_excess`): a linear model of a nonlinear actuator (the twin's
        hysteresis, creep) is missed everywhere, which the terms would otherwise absorb.
        A record whose terms are not significant is reported with offset and start 0.

    Returns
    -------
    list of RecordStart
    """
    rows = []
    for d in records:
        if d.period and d.periods >= 1:
            continue
        E = d.Y - dmodel.response(d.U)
        c, f = fit_free(E, dmodel.zpoles)
        r0 = d.Y - rest_model.response(d.U)
        rows.append((d, c, f, np.sum(r0 ** 2, axis=0), np.sum((E - c - f) ** 2, axis=0),
                     _head_excess(r0, sigmas)))
    if not rows:
        return []
    q = free_columns(dmodel.zpoles, 1).shape[1]
    dof = sum(max(d.n - q, 1) for d, *_ in rows)
    var = np.sum([r[4] for r in rows], axis=0) / dof
    limit = (q + sigmas * np.sqrt(2.0 * q)) * var
    out = []
    for d, c, f, e0, e1, head in rows:
        significant = bool(np.any((e0 - e1 > limit) & head))
        # a record taken to start at rest was fitted so: its terms are reported as 0 (their
        # estimates under a model with slow modes can be any size, cancelling each other)
        offset, initial = _split(c, f) if significant else (0.0 * c, 0.0 * c)
        out.append(RecordStart(d.source or "record", tuple(offset.tolist()),
                               tuple(initial.tolist()), tuple(np.std(d.Y, axis=0).tolist()),
                               significant))
    return out


HEAD = 0.1          # a start away from rest shows in the record's first 10 %
HEAD_MIN = 50       # samples


def _head_excess(r0, sigmas):
    """Per output: does the from-rest fit miss the record's start more than the rest of it?

    A state the record starts in (or an offset) shows first where the from-rest model
    predicts rest: in the record's head the residual per sample exceeds the record's mean
    square by more than noise would (chi-square: ``n_h + sigmas sqrt(2 n_h)`` mean squares).
    A model that misses the actuator elsewhere (a nonlinear one: hysteresis, creep) leaves
    a residual that the nuisance terms reduce too, but not one concentrated at the start:
    such a record started at rest.
    """
    n = r0.shape[0]
    nh = min(n, max(int(np.ceil(HEAD * n)), HEAD_MIN))
    mean_sq = np.mean(r0 ** 2, axis=0)
    head = np.sum(r0[:nh] ** 2, axis=0)
    return head > (nh + sigmas * np.sqrt(2.0 * nh)) * mean_sq


def _split(c, f):
    """``(offset, initial)`` reported per output: the estimated offset and the largest free
    response, unless they cancel (a slow mode's free response over the record looks like
    an offset: their split is then not determined, only their sum ``n = c + f``): then the
    sum's mean and its largest departure from it."""
    n = c[None, :] + f
    size = np.max(np.abs(n), axis=0)
    fmax = np.max(np.abs(f), axis=0)
    cancel = (np.abs(c) > 10 * size) & (fmax > 10 * size)
    offset = np.where(cancel, np.mean(n, axis=0), c)
    initial = np.where(cancel, np.max(np.abs(n - np.mean(n, axis=0)), axis=0), fmax)
    return offset, initial
