"""Noise floor, excitation levels and the diagnosis's findings.

* :func:`noise_estimate` (and :func:`noise_levels`) — sensor-noise std per record and
  output: from period-to-period differences of periodic records (``var(y_{p+1} - y_p) /
  2``, the true floor even where the plant still has modes), else from the residual
  spectrum in the bands the record's input does not excite
  (:func:`robrst.diagnose._signals.noise_sigma`); a record whose input excites every band
  has no floor of its own (0: its noise cannot be told from a model error there).
* :func:`period_noise` — the period differences' level: the median over blocks of their
  mean square (a transient at a record's start — a play or a creep that has not reached
  its steady state — or a burst does not raise it; stationary noise is measured to 0.2 %).
* :func:`level_groups` — records grouped by excitation level (input RMS within
  ``level_tol`` of :class:`~robrst.diagnose.options.LevelOptions`), and which of them share an excitation shape (input spectrum), so a
  gap can be compared across amplitudes without comparing steps with sines.
* :func:`amplitude_finding` — ``amplitude_dependent``: a linear model is fitted on the
  lowest level and its gap compared across levels (a linear plant gives the same
  relative gap at every level).
* :func:`unmodelled_finding` — ``unmodelled_dynamics``: a linear model of higher order
  (vector fitting on the training records) explains the gap that neither the library
  nor a re-fit of the model's own order explains; the band where it departs from the
  re-fitted model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal

import robrst.diagnose._signals as signals
from robrst.diagnose.options import OPTIONS

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.identify.modal import ModalModel

__all__ = ["NoiseEstimate", "noise_estimate", "noise_levels", "period_noise", "level_groups", "comparable", "amplitude_finding",
           "unmodelled_finding"]

_LV = OPTIONS.levels


@dataclass(frozen=True, eq=False)
class NoiseEstimate:
    """Noise std per record and output, and how it was found.

    Parameters
    ----------
    levels : numpy.ndarray
        ``(records, m)`` [µm]; 0 for a record whose input excites every band.
    method : str
        ``"period_differences"``, ``"spectrum"``, ``"undetermined"`` or several joined by
        ``+``.
    undetermined : tuple of int
        The records whose input excites every band.
    upper : numpy.ndarray
        ``levels`` with the undetermined ones from the whole residual spectrum: an upper
        bound (the weight of priors and the threshold of time windows need a level).
    """

    levels: np.ndarray
    method: str
    undetermined: tuple
    upper: np.ndarray


def noise_estimate(records: Sequence[Dataset], residuals: Sequence[np.ndarray],
                   fs: float) -> NoiseEstimate:
    """Noise std per record and output (see the module doc).

    Parameters
    ----------
    records : sequence of Dataset
        The records (periodic ones use period-to-period differences).
    residuals : sequence of numpy.ndarray
        Their residuals (the others use the residual's spectrum where their input does not
        excite it).
    fs : float
        Sampling rate [Hz].

    Returns
    -------
    NoiseEstimate
    """
    out, upper, methods, undetermined = [], [], set(), []
    for i, (d, r) in enumerate(zip(records, residuals)):
        if d.period and d.periods >= 2:
            lv = period_noise(d)
            out.append(lv)
            upper.append(lv)
            methods.add("period_differences")
            continue
        R = np.asarray(r, float).reshape(d.n, -1)
        lv = np.array([signals.noise_sigma(c, fs, d.U) for c in R.T])
        if np.all(np.isfinite(lv)):
            methods.add("spectrum")
            out.append(lv)
            upper.append(lv)
            continue
        methods.add("undetermined")
        undetermined.append(i)
        whole = np.array([signals.noise_sigma(c, fs) for c in R.T])
        out.append(np.where(np.isfinite(lv), lv, 0.0))
        upper.append(np.where(np.isfinite(lv), lv, whole))
    return NoiseEstimate(np.array(out), "+".join(sorted(methods)), tuple(undetermined),
                         np.array(upper))


def period_noise(d: Dataset) -> np.ndarray:
    """Noise std per output [µm] of a periodic record from its period-to-period differences.

    ``var(y_{p+1} - y_p) / 2`` measured block by block (``period_blocks`` per period, of at
    least ``min_block`` samples): the median of the blocks' mean squares, so a transient
    that a part of the record holds (the record does not start in steady state) does not
    count as noise.

    Parameters
    ----------
    d : Dataset
        A record of at least two whole periods.

    Returns
    -------
    numpy.ndarray
        ``(m,)``.
    """
    opts = OPTIONS.noise
    Yp = d.Y[:d.periods * d.period].reshape(d.periods, d.period, -1)
    D2 = np.diff(Yp, axis=0) ** 2                            # (periods - 1, P, m)
    nb = int(max(1, min(opts.period_blocks, d.period // opts.min_block)))
    edges = np.linspace(0, d.period, nb + 1).astype(int)
    ms = np.array([D2[:, a:b].mean(axis=(0, 1)) for a, b in zip(edges[:-1], edges[1:])])
    return np.sqrt(np.median(ms, axis=0) / 2)


def noise_levels(records: Sequence[Dataset], residuals: Sequence[np.ndarray],
                 fs: float) -> tuple[np.ndarray, str]:
    """Noise std per record and output ``(records, m)`` [µm] and the method used
    (:func:`noise_estimate`'s ``levels`` and ``method``).

    Parameters
    ----------
    records : sequence of Dataset
        The records.
    residuals : sequence of numpy.ndarray
        Their residuals.
    fs : float
        Sampling rate [Hz].

    Returns
    -------
    levels : numpy.ndarray
    method : str
    """
    est = noise_estimate(records, residuals, fs)
    return est.levels, est.method


def floor_of(records, sigmas):
    """Noise floor in NRMSE units of a set of records given their noise std per output."""
    num = sum(d.n * float(np.sum(s ** 2)) for d, s in zip(records, sigmas))
    den = sum(float(np.sum((d.Y - d.Y.mean(axis=0)) ** 2)) for d in records)
    return math.sqrt(num / den) if den > 0 else math.inf


def _signature(d, bands=_LV.shape_bands):
    """Band shares of the input spectrum, holding fraction and crest factor."""
    U = d.U - d.U.mean(axis=0)
    f, P = signal.welch(U, fs=d.fs, nperseg=min(4096, max(64, d.n // 4)), axis=0)
    P = P.sum(axis=1)
    edges = np.geomspace(max(f[1], d.fs / d.n), d.fs / 2, bands + 1)
    share = np.array([P[(f >= a) & (f < b)].sum() for a, b in zip(edges[:-1], edges[1:])])
    dU = np.abs(np.diff(d.U, axis=0)).max(axis=1)
    hold = float(np.mean(dU <= 1e-9 * max(float(np.ptp(d.U)), 1e-300)))
    rms = float(np.sqrt(np.mean(U ** 2)))
    crest = float(np.max(np.abs(U)) / rms) if rms > 0 else 0.0
    return share / max(share.sum(), 1e-300), hold, crest


def comparable(a: Dataset, b: Dataset) -> bool:
    """Do two records share an excitation shape (input spectrum, holding, crest factor)?

    Band shares within a factor 2 where either holds more than 1 % of the power, the
    fraction of samples holding the input within 0.1, crest factors within 35 %.

    Parameters
    ----------
    a, b : Dataset
        The records.

    Returns
    -------
    bool
    """
    (sa, ha, ca), (sb, hb, cb) = _signature(a), _signature(b)
    big = (sa > _LV.shape_share) | (sb > _LV.shape_share)
    spectrum = np.all(np.abs(np.log10((sa[big] + 1e-4) / (sb[big] + 1e-4))) < _LV.shape_tol)
    return bool(spectrum and abs(ha - hb) < _LV.hold_tol
                and abs(ca - cb) <= _LV.crest_tol * max(ca, cb))


def level_groups(records: Sequence[Dataset]) -> list[tuple[float, list[int]]]:
    """Indices of records grouped by level (increasing).

    Parameters
    ----------
    records : sequence of Dataset
        The records.

    Returns
    -------
    list of (float, list of int)
        ``(mean level [V rms], indices)`` per group.
    """
    order = np.argsort([d.level for d in records])
    groups = []
    for i in order:
        lv = records[i].level
        if groups and lv <= groups[-1][0] * (1 + _LV.level_tol):
            groups[-1][1].append(int(i))
        else:
            groups.append([lv, [int(i)]])
    return [(float(np.mean([records[i].level for i in g])), g) for _, g in groups]


def gaps_per_level(records, residuals, groups):
    return [signals.nrmse([records[i] for i in g], [residuals[i] for i in g]) for _, g in groups]


def amplitude_finding(records: Sequence[Dataset], base_res: Sequence[np.ndarray],
                      refit_res: Sequence[np.ndarray] | None, sigmas: np.ndarray,
                      n_train: int) -> tuple[dict | None, list]:
    """``amplitude_dependent`` finding (or None) and the per-level table.

    Only records sharing the excitation shape of the lowest level are compared.

    Parameters
    ----------
    records : sequence of Dataset
        Training records first, then test records.
    base_res : sequence of numpy.ndarray
        Residuals of the model under diagnosis.
    refit_res : sequence of numpy.ndarray or None
        Residuals of a linear model fitted on the lowest training level (None when no
        level has training records).
    sigmas : numpy.ndarray
        Noise level per record.
    n_train : int
        How many of ``records`` are training records.

    Returns
    -------
    finding : dict or None
    table : list of dict
        Per level group: ``level_V``, ``records``, ``split``, ``gap``, ``noise_floor``.
    """
    groups = level_groups(records)
    table = [{"level_V": lv, "records": [records[i].source or f"record{i}" for i in g],
              "split": ["train" if i < n_train else "test" for i in g],
              "gap": signals.nrmse([records[i] for i in g], [base_res[i] for i in g]),
              "noise_floor": floor_of([records[i] for i in g], [sigmas[i] for i in g])}
             for lv, g in groups]
    ratio_min = OPTIONS.records.level_ratio
    if len(groups) < 2 or groups[-1][0] < ratio_min * groups[0][0]:
        return None, table
    ref = records[groups[0][1][0]]
    same = [(lv, [i for i in g if comparable(records[i], ref)]) for lv, g in groups]
    same = [(lv, g) for lv, g in same if g]
    if len(same) < 2 or same[-1][0] < ratio_min * same[0][0]:
        return None, table
    res = refit_res if refit_res is not None else base_res
    gaps = gaps_per_level(records, res, same)
    floors = [floor_of([records[i] for i in g], [sigmas[i] for i in g]) for _, g in same]
    base = gaps_per_level(records, base_res, same)
    ratio = gaps[-1] / gaps[0] if gaps[0] > 0 else math.inf
    big = max(gaps[-1], gaps[0])
    if not (ratio >= _LV.amplitude_ratio or ratio <= 1 / _LV.amplitude_ratio) or \
            big < _LV.floor_ratio * max(floors):
        return None, table
    lo, hi = same[0][0], same[-1][0]
    return {"kind": "amplitude_dependent",
            "message": (f"the gap changes with the excitation level: {gaps[0]:.3g} at"
                        f" {lo:.3g} V rms, {gaps[-1]:.3g} at {hi:.3g} V rms ({ratio:.2f}x for"
                        f" {hi / lo:.2f}x the level) with a linear model fitted on the lowest"
                        " level: the plant is not linear"),
            "levels_V": [lv for lv, _ in same], "level_ratio": hi / lo,
            "gap_per_level": gaps, "gap_ratio": ratio, "model_gap_per_level": base,
            "model_gap_ratio": base[-1] / base[0] if base[0] > 0 else None,
            "noise_floor_per_level": floors,
            "linear_fitted_on": "lowest training level" if refit_res is not None
            else "(the model under diagnosis)"}, table


def _hz(freqs):
    """Frequencies [Hz] as a short list, each once as printed (``"616, 1.6e+03"``;
    ``"none"``)."""
    return ", ".join(dict.fromkeys(f"{f:.3g}" for f in sorted(freqs))) or "none"


def unmodelled_finding(high: ModalModel, refit: ModalModel, fs: float, gap_high: float,
                       gap_refit: float, gap_before: float, floor: float,
                       inputs: Sequence[np.ndarray] = ()) -> dict | None:
    """``unmodelled_dynamics`` finding from a higher-order linear fit, or None.

    The finding needs the higher order to remove at least half of the excess gap the
    re-fit leaves; its band is where the two models' outputs differ on the training
    ``inputs`` (the response difference times the inputs' amplitude spectrum) by more
    than a fifth of their largest difference — where the data see the missing dynamics,
    not where the response is largest; its extra modes are the higher order's poles
    (pairs and real ones) 5 % away from every re-fitted pole.

    Parameters
    ----------
    high : ModalModel
        The higher-order fit (continuous time).
    refit : ModalModel
        The user's order re-fitted.
    fs : float
        Sampling rate [Hz].
    gap_high, gap_refit, gap_before : float
        Held-out gaps of the two fits and of the model as given.
    floor : float
        The noise floor.
    inputs : sequence of numpy.ndarray
        The training inputs.

    Returns
    -------
    dict or None
        ``{"kind": "unmodelled_dynamics", "message", "band_hz", "order", "model_order",
        "extra_modes_hz", "gap_after", "gap_refit", "gap_before"}``.
    """
    ex = lambda g: math.sqrt(max(g * g - floor * floor, 0.0))  # noqa: E731
    v = OPTIONS.verdict
    if not ex(gap_high) <= v.unmodelled_share * ex(gap_refit):
        return None
    f = np.geomspace(fs / 1e5, 0.49 * fs, 800)
    w = 2 * np.pi * f
    d = np.abs(high.freqresp(w) - refit.freqresp(w)).max(axis=(1, 2))
    if len(inputs):
        fu, pu = signals.residual_psd(list(inputs), fs)         # the inputs' spectrum
        d = d * np.sqrt(np.interp(f, fu[1:], pu[1:]))
    sel = f[d >= v.unmodelled_band * d.max()]
    extra = []
    for p in high.poles:
        if p != 0 and np.min(np.abs(refit.poles - p) / abs(p)) > v.unmodelled_pole_tol:
            extra.append(float(abs(p) / (2 * np.pi)))
    if high.order <= refit.order:
        # the model's own order, fitted from the data: its dynamics are wrong, not short
        own = [float(abs(p) / (2 * np.pi)) for p in refit.poles if p != 0]
        message = (f"a linear model of the model's own order ({refit.order}) fitted from the"
                   f" data alone brings the held-out gap from {gap_refit:.3g} to"
                   f" {gap_high:.3g}: the model's linear dynamics are wrong around"
                   f" {sel.min():.3g}–{sel.max():.3g} Hz, not short of an order (the data's"
                   f" modes at {_hz(extra)} Hz, the model's re-fit at {_hz(own)} Hz: a re-fit"
                   " from the model does not move that far; identify the model from these"
                   " records)")
    else:
        message = (f"a linear model of order {high.order} (the model has {refit.order})"
                   f" brings the held-out gap from {gap_refit:.3g} to {gap_high:.3g}:"
                   f" linear dynamics missing from the model around"
                   f" {sel.min():.3g}–{sel.max():.3g} Hz")
    return {"kind": "unmodelled_dynamics",
            "message": message,
            "band_hz": [float(sel.min()), float(sel.max())], "order": int(high.order),
            "model_order": int(refit.order), "extra_modes_hz": sorted(extra),
            "gap_after": gap_high, "gap_refit": gap_refit, "gap_before": gap_before}
