"""Sensor faults in the records: isolated outliers and dropouts, found and set aside.

A sensor that spikes or drops out for a few milliseconds raises every noise estimate
(a spike is broadband; the period-to-period differences and the residual spectrum both
see it) and can hide a clear effect.  Before the diagnosis, each record's residual
``r = y - y_model`` (the model under diagnosis) is tested:

* **outliers** — samples where ``e = r - (r[k-1] + r[k+1]) / 2`` (what the neighbours do
  not predict) exceeds ``outlier_z`` robust standard deviations of ``e`` (1.4826 x its
  median absolute deviation) *and* ``isolation`` times ``|e|`` two to four samples either
  side: a spike stands alone, while a model error (a ringing resonance, the residual of a
  delay or a rate limit at a step) spreads over its neighbours;
* **dropouts** — runs of at least ``min_run`` identical readings (a held or zeroed
  sensor) whose residual departs from the residual around them by more than
  ``outlier_z`` robust standard deviations (the constants:
  :class:`~robrst.diagnose.options.SensorOptions`).

Flagged samples are replaced by the model's output plus the residual interpolated
linearly across them: the gap, the noise floor and every fit then see the plant, not
the sensor fault, and the flagged share is reported (:func:`repair`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose.options import OPTIONS

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset

__all__ = ["SensorFaults", "find_faults", "repair"]

_S = OPTIONS.sensor


@dataclass(frozen=True)
class SensorFaults:
    """Faults found in one record: flagged samples and their kind.

    Parameters
    ----------
    name : str
        The record.
    outliers : numpy.ndarray
        Sample indices of the outliers.
    dropouts : tuple
        ``((start, stop), ...)`` sample ranges of the dropouts.
    n : int
        Samples of the record.

    Attributes
    ----------
    mask : numpy.ndarray
        Every flagged sample.
    count : int
        How many.
    """

    name: str
    outliers: np.ndarray     # sample indices
    dropouts: tuple          # ((start, stop), ...) sample ranges
    n: int

    @property
    def mask(self) -> np.ndarray:
        """Every flagged sample (boolean, one per sample)."""
        m = np.zeros(self.n, bool)
        m[self.outliers] = True
        for a, b in self.dropouts:
            m[a:b] = True
        return m

    @property
    def count(self) -> int:
        """How many samples are flagged."""
        return int(self.mask.sum())


def _runs(y, min_run):
    """(start, stop) of runs of at least ``min_run`` identical values of ``y``."""
    same = np.concatenate([[False], y[1:] == y[:-1]])
    edges = np.flatnonzero(np.diff(np.concatenate([[0], same.astype(int), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2]):
        a -= 1                               # the run starts one sample before the repeats
        if b - a >= min_run:
            out.append((int(a), int(b)))
    return out


def find_faults(name: str, y: np.ndarray, y_model: np.ndarray) -> SensorFaults:
    """Outliers and dropouts of one output channel (see the module doc).

    Parameters
    ----------
    name : str
        The record.
    y, y_model : numpy.ndarray
        Measured and simulated outputs ``(N,)``.

    Returns
    -------
    SensorFaults
    """
    y = np.asarray(y, float)
    r = y - y_model
    n = r.size
    e = r.copy()
    e[1:-1] -= 0.5 * (r[:-2] + r[2:])
    if n >= 3:      # the ends: one-sided second differences, scaled as the interior's (a
        # residual that slopes at a record's end is no outlier; a first difference said so)
        e[0], e[-1] = 0.5 * (r[0] - 2 * r[1] + r[2]), 0.5 * (r[-1] - 2 * r[-2] + r[-3])
    else:
        e[0], e[-1] = r[0] - r[1], r[-1] - r[-2]
    s = 1.4826 * float(np.median(np.abs(e - np.median(e))))
    if not s > 0:
        return SensorFaults(name, np.zeros(0, int), (), n)
    a = np.abs(e)
    pad = np.concatenate([np.zeros(4), a, np.zeros(4)])
    near = np.max([pad[4 + j:4 + j + n] for j in (-4, -3, -2, 2, 3, 4)], axis=0)
    big = (a > _S.outlier_z * s) & (a > _S.isolation * near)
    drops = []
    for a, b in _runs(y, _S.min_run):
        L = b - a
        around = np.concatenate([r[max(0, a - L):a], r[b:b + L]])
        if around.size and abs(np.median(r[a:b]) - np.median(around)) > _S.outlier_z * s:
            drops.append((a, b))
            big[a:b] = False
    return SensorFaults(name, np.flatnonzero(big), tuple(drops), n)


def repair(records: Sequence[Dataset], models: Sequence[np.ndarray],
           fs: float) -> tuple[list, dict | None]:
    """Records with outliers and dropouts set aside, and what was found.

    Parameters
    ----------
    records : list of Dataset
    models : list of array
        The model's outputs ``(N, m)`` per record (the model under diagnosis).
    fs : float
        Sampling rate [Hz] (for the report's times).

    Returns
    -------
    list of Dataset, dict or None
        The records (flagged samples replaced by the model plus the residual interpolated
        across them; unchanged records are the same objects) and the ``sensor`` report:
        ``{"outliers", "dropouts", "samples", "share", "records": [{file, outliers,
        dropouts_s: [[start, end]], ...}]}``, or None when nothing was found.
    """
    out, rows, n_out, n_drop, n_all, n_flag = [], [], 0, 0, 0, 0
    for d, ym in zip(records, models):
        Y = d.Y.copy()
        ym = np.asarray(ym, float).reshape(d.n, -1)
        mask = np.zeros(d.n, bool)
        found = []
        for j in range(Y.shape[1]):
            f = find_faults(d.source, Y[:, j], ym[:, j])
            found.append(f)
            mask |= f.mask
        n_all += d.n
        if not mask.any() or mask.mean() > _S.max_share:
            out.append(d)
            continue
        good = np.flatnonzero(~mask)
        R = Y - ym
        for j in range(Y.shape[1]):
            R[mask, j] = np.interp(np.flatnonzero(mask), good, R[good, j])
        Y = ym + R
        y = Y[:, 0] if d.y.ndim == 1 else Y
        out.append(replace(d, y=y))
        no = int(sum(f.outliers.size for f in found))
        drops = sorted({ab for f in found for ab in f.dropouts})
        n_out, n_drop, n_flag = n_out + no, n_drop + len(drops), n_flag + int(mask.sum())
        rows.append({"file": d.source or "record", "outliers": no, "dropouts": len(drops),
                     "dropouts_s": [[a / fs, b / fs] for a, b in drops],
                     "flagged": int(mask.sum())})
    if not rows:
        return out, None
    return out, {"outliers": n_out, "dropouts": n_drop, "samples": n_flag,
                 "share": n_flag / max(n_all, 1), "records": rows}
