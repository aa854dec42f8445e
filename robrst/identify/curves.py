"""The curves an identification report draws, computed from the identification and its records.

:func:`identification_curves` gives the H1 estimate of the records' frequency response, the
identified model's response on a log grid and its simulated output on the last record
(with the record's offset and initial state): the report
(:mod:`robrst.report.identification`) draws the record, it computes nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.identify.identification import simulate_record

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.identify.identification import Identified

__all__ = ["IdentificationCurves", "identification_curves", "h1_estimate"]


@dataclass(frozen=True, eq=False)
class IdentificationCurves:
    """What the identification report draws.

    Parameters
    ----------
    f_h1 : numpy.ndarray
        The H1 estimate's frequencies [Hz] (the first, 0 Hz, is not drawn).
    h1 : numpy.ndarray
        ``(frequency, output, input)``: the records' H1 estimate (``nan`` where singular).
    f_model : numpy.ndarray
        The model's frequencies [Hz].
    model : numpy.ndarray
        ``(frequency, output, input)``: the identified model's (first temperature) response.
    t : numpy.ndarray
        The last record's time [s] (one period, or at most 4000 samples).
    measured, simulated : numpy.ndarray
        Its output 1 [µm], measured and simulated by the identified model.
    source : str
        The record's source.
    """

    f_h1: np.ndarray
    h1: np.ndarray
    f_model: np.ndarray
    model: np.ndarray
    t: np.ndarray
    measured: np.ndarray
    simulated: np.ndarray
    source: str


def h1_estimate(records: Sequence[Dataset], fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Welch's H1 estimate ``Suy Suu^-1`` of the records' frequency response, averaged.

    Parameters
    ----------
    records : sequence of Dataset
        The records (their means removed).
    fs : float
        Their sampling rate [Hz].

    Returns
    -------
    f : numpy.ndarray
        Frequencies [Hz].
    H : numpy.ndarray
        ``(frequency, output, input)`` (``nan`` where ``Suu`` is singular, and at 0 Hz).
    """
    from scipy import signal

    n = min(d.n for d in records)
    nper = int(min(4096, 2 ** int(np.log2(max(n // 4, 64)))))
    Suu = Suy = 0.0
    for d in records:
        U, Y = d.U - d.U.mean(axis=0), d.Y - d.Y.mean(axis=0)
        f, a = signal.csd(U[:, :, None], U[:, None, :], fs=fs, nperseg=nper, axis=0)
        _, b = signal.csd(U[:, :, None], Y[:, None, :], fs=fs, nperseg=nper, axis=0)
        Suu, Suy = Suu + a, Suy + b
    H = np.full((f.size, Suy.shape[2], Suy.shape[1]), np.nan, complex)
    for i in range(1, f.size):
        try:
            H[i] = np.linalg.solve(Suu[i].T, Suy[i]).T
        except np.linalg.LinAlgError:
            pass
    return f, H


def identification_curves(ident: Identified, records: Sequence[Dataset]) -> IdentificationCurves:
    """The curves of the identification report.

    Parameters
    ----------
    ident : Identified
        The identification.
    records : sequence of Dataset
        The records drawn against the model (the last one is simulated).

    Returns
    -------
    IdentificationCurves
    """
    m = ident.models[0]
    f, H = h1_estimate(records, ident.fs)
    fm = np.geomspace(max(f[1], 1e-3), ident.fs / 2, 600)
    d = records[-1]
    Yh = simulate_record(m.discretise(ident.fs), d, free=True)   # offset and initial state
    n = d.period or min(d.n, 4000)
    return IdentificationCurves(f_h1=f, h1=H, f_model=fm, model=m.freqresp(2 * np.pi * fm),
                                t=d.t[:n], measured=d.Y[:n, 0], simulated=Yh[:n, 0],
                                source=d.source or "record")
