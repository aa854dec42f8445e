"""Gap measurement and localisation: the classical system-identification checks.

All functions take a list of records (:class:`~robrst.data.dataset.Dataset`) and, where
needed, the matching list of residuals ``r = y - y_model`` [µm].

* :func:`nrmse` — ``||r|| / ||y - mean(y)||`` pooled over the records.
* :func:`noise_sigma` — sensor-noise standard deviation from the residual spectrum
  above 60 % of Nyquist, where no actuator dynamics or model error live (median
  Welch estimate, robust to spectral lines).
* :func:`time_windows`, :func:`frequency_band`, :func:`frf_departure`,
  :func:`regime` — where the gap lies in time, frequency and operating regime.
* :func:`whiteness`, :func:`cross_correlation` — residual tests with a
  Bonferroni-corrected 99 % bound.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal, stats

from robrst.diagnose.options import OPTIONS

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.identify.modal import DiscreteModel

__all__ = ["nrmse", "noise_sigma", "excited_bins", "time_windows", "frequency_band", "frf_departure", "regime",
           "whiteness", "cross_correlation", "residual_psd"]

_NOISE = OPTIONS.noise


def nrmse(records: Sequence[Dataset], residuals: Sequence[np.ndarray]) -> float:
    """Pooled normalised RMS error ``sqrt(sum r^2) / sqrt(sum (y - mean y)^2)``.

    Pooled over records and outputs (each output about its own mean).

    Parameters
    ----------
    records : sequence of Dataset
        The records.
    residuals : sequence of numpy.ndarray
        Their residuals, ``(N, m)`` or ``N``.

    Returns
    -------
    float
        ``inf`` when the outputs do not vary.
    """
    num = sum(float(np.sum(np.asarray(r) ** 2)) for r in residuals)
    den = sum(float(np.sum((d.Y - d.Y.mean(axis=0)) ** 2)) for d in records)
    return float(np.sqrt(num / den)) if den > 0 else float("inf")


def _cols(r):
    """A residual as (N, m)."""
    r = np.asarray(r, float)
    return r.reshape(r.shape[0], -1)


def _nperseg(n, cap):
    return int(max(16, min(cap, 2 ** int(np.floor(np.log2(max(n // 8, 16)))))))


def excited_bins(u: np.ndarray, fs: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies of a Welch estimate and which bins the input excites.

    A bin is excited when the input's power there (summed over the inputs, about their
    means) exceeds ``excited_rel`` of its largest bin
    (:class:`~robrst.diagnose.options.NoiseOptions`): a multisine's band is, steps' and
    sines' upper bands are not.

    Parameters
    ----------
    u : numpy.ndarray
        Inputs ``(N,)`` or ``(N, k)``.
    fs : float
        Sampling rate [Hz].
    nperseg : int
        Welch's segment length.

    Returns
    -------
    f : numpy.ndarray
        Frequencies [Hz].
    excited : numpy.ndarray of bool
    """
    U = _cols(u)
    f, P = signal.welch(U - U.mean(axis=0), fs=fs, nperseg=nperseg, axis=0)
    P = P.sum(axis=1)
    top = float(P.max()) if P.size else 0.0
    return f, (P > _NOISE.excited_rel * top) if top > 0 else np.zeros(f.size, bool)


def noise_sigma(r: np.ndarray, fs: float, u: np.ndarray | None = None) -> float:
    """Noise std [µm] of a 1-D residual from its spectrum in the upper 70 % of the band.

    The one-sided PSD of white noise of std sigma is ``2 sigma^2 / fs``.  The level is
    the smallest of the median levels of four sub-bands (30–45, 45–60, 60–75, 75–95 %
    of Nyquist) of a median-averaged Welch estimate: a plant mode or model error in one
    sub-band does not raise the floor.  With the record's input ``u``, the bins it excites
    (:func:`excited_bins`) never count: a sub-band counts on its other bins, when at least
    ``min_unexcited`` of them are left, and the level is NaN when no sub-band does (every
    band of the record is excited: its noise cannot be told from a model error there).
    For periodic records the period-to-period differences are better
    (:func:`robrst.diagnose._findings.noise_levels`).

    Parameters
    ----------
    r : numpy.ndarray
        A residual.
    fs : float
        Sampling rate [Hz].
    u : numpy.ndarray, optional
        The record's input(s).

    Returns
    -------
    float
        NaN when ``u`` excites every sub-band.
    """
    r = np.asarray(r, float)
    nper = _nperseg(r.size, 1024)
    f, P = signal.welch(r - r.mean(), fs=fs, nperseg=nper, average="median")
    free = np.ones(f.size, bool) if u is None else ~excited_bins(u, fs, nper)[1]
    levels = []
    for a, b in _NOISE.bands:
        band = (f >= a * fs / 2) & (f <= b * fs / 2)
        if not np.any(band):
            continue
        use = band & free
        if use.sum() >= max(1, _NOISE.min_unexcited * band.sum()):
            levels.append(float(np.median(P[use])))
    if not levels:
        return float("nan") if u is not None else float(np.sqrt(np.var(r)))
    return float(np.sqrt(min(levels) * fs / 2))


def time_windows(records: Sequence[Dataset], residuals: Sequence[np.ndarray], sigma: float,
                 names: Sequence[str], max_windows: int = _NOISE.max_windows,
                 factor: float = _NOISE.window_factor) -> tuple[list[dict], float]:
    """Intervals where the moving RMS of the residual exceeds ``factor`` x noise.

    Parameters
    ----------
    records : sequence of Dataset
        The records.
    residuals : sequence of numpy.ndarray
        Their residuals.
    sigma : float
        The noise level [µm].
    names : sequence of str
        The records' names.
    max_windows : int
        At most this many windows.
    factor : float
        The threshold in noise levels.

    Returns
    -------
    windows : list of dict
        ``{"file", "start_s", "end_s", "rms_um"}``, strongest first.
    share : float
        The fraction of the residual energy they hold.
    """
    out, held, total = [], 0.0, 0.0
    for d, r, name in zip(records, residuals, names):
        R = _cols(r)
        r = np.sqrt(np.mean(R ** 2, axis=1))
        n = r.size
        w = max(16, n // 200)
        c = np.concatenate([[0.0], np.cumsum(r ** 2)])
        half = w // 2
        lo = np.clip(np.arange(n) - half, 0, n)
        hi = np.clip(np.arange(n) + half + 1, 0, n)
        rms = np.sqrt((c[hi] - c[lo]) / (hi - lo))
        hot = rms > factor * sigma
        total += float(c[-1])
        if not hot.any():
            continue
        edges = np.flatnonzero(np.diff(np.concatenate([[0], hot.astype(int), [0]])))
        segs = list(zip(edges[::2], edges[1::2]))
        merged = [list(segs[0])]
        for a, b in segs[1:]:
            if a - merged[-1][1] <= w:
                merged[-1][1] = b
            else:
                merged.append([a, b])
        for a, b in merged:
            e = float(c[b] - c[a])
            held += e
            out.append({"file": name, "start_s": float(d.t[a]), "end_s": float(d.t[b - 1]),
                        "rms_um": float(np.sqrt(e / max(b - a, 1))), "_e": e})
    out.sort(key=lambda x: -x["_e"])
    out = out[:max_windows]
    for x in out:
        del x["_e"]
    return out, (held / total if total > 0 else 0.0)


def residual_psd(residuals: Sequence[np.ndarray], fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Pooled Welch PSD [µm²/Hz] of the residuals (mean averaging).

    Parameters
    ----------
    residuals : sequence of numpy.ndarray
        The residuals.
    fs : float
        Sampling rate [Hz].

    Returns
    -------
    f, P : numpy.ndarray
        Frequencies [Hz] and the PSD.
    """
    n = min(len(r) for r in residuals)
    nper = _nperseg(n, 8192)
    acc, wsum, f = 0.0, 0.0, None
    for r in residuals:
        R = _cols(r)
        f, P = signal.welch(R - R.mean(axis=0), fs=fs, nperseg=nper, axis=0)
        acc, wsum = acc + P.mean(axis=1) * R.shape[0], wsum + R.shape[0]
    return f, acc / wsum


def frequency_band(residuals: Sequence[np.ndarray], fs: float, sigma: float,
                   factor: float = _NOISE.band_factor
                   ) -> tuple[list[float] | None, np.ndarray, np.ndarray, float]:
    """Band [Hz] holding 95 % of the residual energy that exceeds the noise floor.

    Parameters
    ----------
    residuals : sequence of numpy.ndarray
        The residuals.
    fs : float
        Sampling rate [Hz].
    sigma : float
        The noise level [µm].
    factor : float
        A bin counts when it exceeds ``factor`` x the white-noise level ``2 sigma^2 / fs``.

    Returns
    -------
    band : list of float or None
        ``[lo, hi]``; ``None`` when no bin exceeds the threshold.
    f, P : numpy.ndarray
        The residual spectrum.
    noise_level : float
        The white-noise level.
    """
    f, P = residual_psd(residuals, fs)
    level = 2 * sigma ** 2 / fs
    excess = np.where(P > factor * level, P - level, 0.0)
    if excess.sum() <= 0:
        return None, f, P, level
    cum = np.cumsum(excess) / excess.sum()
    q_lo, q_hi = _NOISE.band_quantiles
    lo = f[int(np.searchsorted(cum, q_lo))]
    hi = f[min(int(np.searchsorted(cum, q_hi)), len(f) - 1)]
    return [float(lo), float(hi)], f, P, level


def _segments(X, nper):
    """Spectra ``(segments, nper // 2 + 1, channels)`` of Welch's segments of ``X`` (N, c):
    half-overlapping, each detrended by its mean and Hann-windowed (``signal.csd``'s; its
    density scaling, common to every spectrum, is left out: H1 and the coherence are ratios).
    """
    win = signal.get_window("hann", nper)
    S = np.lib.stride_tricks.sliding_window_view(np.asarray(X, float), nper, axis=0)[::nper // 2]
    S = S - S.mean(axis=2, keepdims=True)                  # (segments, c, nper)
    return np.moveaxis(np.fft.rfft(S * win, axis=2), 1, 2)


def frf_departure(records: Sequence[Dataset], dmodel: DiscreteModel, fs: float,
                  max_coh: float = _NOISE.max_coherence) -> dict:
    """Where the nonparametric FRF (H1, with coherence) departs from the model's.

    ``dmodel`` is compared at ``z = exp(j 2 pi f / fs)``.  With several inputs H1 is the
    matrix ``S_yu S_uu^-1`` and the coherence the multiple coherence of each output.  The
    relative error ``|H1 - Hm| / max(|Hm|)`` of each channel is compared, bin by bin,
    with 3x its standard error ``sqrt((1 - g2) / (2 n_avg g2))`` on bins with
    coherence > 0.5.

    Parameters
    ----------
    records : sequence of Dataset
        The records.
    dmodel : DiscreteModel
        The sampled model.
    fs : float
        Sampling rate [Hz].
    max_coh : float
        Coherence is capped here (its standard error would vanish).

    Returns
    -------
    dict
        ``{"band_hz": [lo, hi] or None, "max_rel_error": x, "bins": n}``.
    """
    n = min(d.n for d in records)
    nper = _nperseg(n, 4096)
    Suu = Suy = Syy = 0.0
    f = np.fft.rfftfreq(nper, 1.0 / fs)
    for d in records:       # each signal's segments transformed once (Welch's segments)
        FU, FY = _segments(d.U, nper), _segments(d.Y, nper)     # (segments, F, k / m)
        Suu = Suu + np.einsum("sfi,sfj->fij", FU.conj(), FU) / len(FU)
        Suy = Suy + np.einsum("sfi,sfl->fil", FU.conj(), FY) / len(FU)
        Syy = Syy + np.mean(np.abs(FY) ** 2, axis=0)         # (F, k, k), (F, k, m), (F, m)
    n_avg = sum(max(1, 2 * d.n // nper - 1) for d in records)
    tr = np.real(np.trace(Suu, axis1=1, axis2=2))
    ok = tr > 1e-12 * np.max(tr)
    H1 = np.zeros((f.size,) + Suy.shape[2:] + Suy.shape[1:2], complex)   # (F, m, k)
    g2 = np.zeros((f.size, Suy.shape[2]))
    for i in np.flatnonzero(ok):
        try:
            X = np.linalg.solve(Suu[i].T, Suy[i]).T        # S_yu S_uu^-1 (m x k)
        except np.linalg.LinAlgError:
            ok[i] = False
            continue
        H1[i] = X
        g2[i] = np.real(np.einsum("mk,km->m", X, Suy[i])) / np.maximum(Syy[i], 1e-300)
    g2 = np.clip(g2, 0, max_coh)
    Hm = dmodel.transfer(np.exp(2j * np.pi * f / fs))
    peak = np.maximum(np.max(np.abs(Hm), axis=0), 1e-300)          # (m, k)
    rel = np.abs(H1 - Hm) / peak[None]
    se = np.sqrt((1 - g2) / (2 * n_avg * np.maximum(g2, 1e-12)))[:, :, None] * (
        np.abs(Hm) / peak[None] + 1e-3)
    use = (ok & (f > 0))[:, None, None] & (g2 > _NOISE.min_coherence)[:, :, None]
    bad = use & (rel > _NOISE.frf_sigmas * se + 1e-3)
    if not bad.any():
        return {"band_hz": None, "max_rel_error": float(np.max(rel[use])) if use.any() else None,
                "bins": 0}
    fb = f[np.any(bad, axis=(1, 2))]
    return {"band_hz": [float(fb.min()), float(fb.max())], "max_rel_error": float(np.max(rel[bad])),
            "bins": int(np.any(bad, axis=(1, 2)).sum())}


def _few_values(x, most):
    """The distinct values of ``x`` (sorted) when there are at most ``most``, else None.

    Without sorting ``x``: the distinct values of every k-th sample, then one check that
    ``x`` holds no other (a full ``np.unique`` only when it does and the sample was few).
    """
    probe = np.unique(x[::max(1, x.size // 4096)])
    if probe.size > most:
        return None
    idx = np.minimum(np.searchsorted(probe, x), probe.size - 1)
    if np.array_equal(probe[idx], x):
        return probe
    vals = np.unique(x)
    return vals if vals.size <= most else None


def eta2(r, x, bins=_NOISE.regime_bins):
    """Correlation ratio: share of the variance of ``r`` explained by bins of ``x``.

    Nonparametric (catches residuals that appear only at the extremes of ``x`` or
    flip sign with it); quantile bins, or the distinct values when there are few.
    """
    vals = _few_values(x, bins)
    if vals is not None:
        idx = np.searchsorted(vals, x)
    else:
        edges = np.unique(np.quantile(x, np.linspace(0, 1, bins + 1)[1:-1]))
        idx = np.searchsorted(edges, x)
    tot = float(np.sum((r - r.mean()) ** 2))
    if tot <= 0:
        return 0.0
    cnt = np.bincount(idx)
    mean = np.bincount(idx, weights=r) / np.maximum(cnt, 1)
    return float(np.sum(cnt * (mean - r.mean()) ** 2) / tot)


def regime(records: Sequence[Dataset], residuals: Sequence[np.ndarray],
           reference_C: float) -> dict:
    """How much of the residual each operating-regime variable explains (``eta2``).

    ``temperature`` (T - reference), ``temperature_x_amplitude`` ((T - ref) u),
    ``amplitude`` (u), ``direction`` (sign of du/dt while moving) and
    ``time_since_step`` (log time since the last step, signed by that step).

    Parameters
    ----------
    records : sequence of Dataset
        The records.
    residuals : sequence of numpy.ndarray
        Their residuals.
    reference_C : float
        The model's temperature [°C].

    Returns
    -------
    dict
        Each variable's share (``None``: not excited), ``dominant`` (the largest) and
        ``measure``.
    """
    cols = {k: [] for k in ("temperature", "temperature_x_amplitude", "amplitude", "direction",
                            "time_since_step")}
    for d in records:
        dT = d.temp_or(reference_C) - reference_C
        u = d.U.sum(axis=1)
        k = max(1, int(round(d.fs * 1e-3)))
        du = np.convolve(np.diff(u, prepend=u[0]), np.ones(k) / k, mode="same")
        moving = np.abs(du) > 1e-3 * max(np.ptp(u), 1e-12) / k
        jump = np.abs(np.diff(u, prepend=u[0])) > 0.1 * max(np.ptp(u), 1e-12)
        last = np.maximum.accumulate(np.where(jump, np.arange(d.n), 0))
        sgn = np.sign(np.diff(u, prepend=u[0]))[last]
        since = np.log10(1.0 + (d.t - d.t[last]) / max(d.t[1] - d.t[0], 1e-12))
        cols["temperature"].append(dT)
        cols["temperature_x_amplitude"].append(dT * (u - u.mean()))
        cols["amplitude"].append(u)
        cols["direction"].append(np.where(moving, np.sign(du), 0.0))
        cols["time_since_step"].append(np.where(jump.any(), sgn * since, 0.0))
    R = np.concatenate([_cols(r) for r in residuals])
    out = {}
    for k, v in cols.items():
        x = np.concatenate(v)
        out[k] = float(np.mean([eta2(r, x) for r in R.T])) if np.ptp(x) > 1e-9 else None
    valid = {k: v for k, v in out.items() if v is not None}
    out["dominant"] = max(valid, key=valid.get) if valid else None
    out["measure"] = "eta2"
    return out


def _bound(n, m):
    return float(stats.norm.ppf(1 - _NOISE.test_level / 2 / m) / np.sqrt(n))


def whiteness(residuals: Sequence[np.ndarray], max_lag: int = _NOISE.max_lag) -> dict:
    """Autocorrelation test of the residual at lags 1..max_lag (99 %, Bonferroni).

    Parameters
    ----------
    residuals : sequence of numpy.ndarray
        The residuals.
    max_lag : int
        The largest lag.

    Returns
    -------
    dict
        ``max_abs_autocorr``, ``bound``, ``passed``.
    """
    acc, n = np.zeros(max_lag + 1), 0
    for r in (c for res in residuals for c in _cols(res).T):
        r = r - r.mean()
        acc += np.array([np.dot(r[:r.size - k], r[k:]) for k in range(max_lag + 1)])
        n += r.size
    rho = acc[1:] / acc[0] if acc[0] > 0 else np.zeros(max_lag)
    b = _bound(n, max_lag)
    return {"max_abs_autocorr": float(np.max(np.abs(rho))), "bound": b,
            "passed": bool(np.max(np.abs(rho)) <= b)}


def cross_correlation(records: Sequence[Dataset], residuals: Sequence[np.ndarray],
                      max_lag: int = _NOISE.max_lag) -> dict:
    """Residual-input cross-correlation test at lags 0..max_lag (input leading).

    Pooled over every (input, output) pair of every record.

    Parameters
    ----------
    records : sequence of Dataset
        The records.
    residuals : sequence of numpy.ndarray
        Their residuals.
    max_lag : int
        The largest lag.

    Returns
    -------
    dict
        ``max_abs_crosscorr``, ``bound``, ``passed``.
    """
    num, ruu, rrr, n = np.zeros(max_lag + 1), 0.0, 0.0, 0
    pairs = [(u, r) for d, res in zip(records, residuals) for u in d.U.T for r in _cols(res).T]
    for u, r in pairs:
        u, r = u - u.mean(), r - r.mean()
        num += np.array([np.dot(u[:u.size - k], r[k:]) for k in range(max_lag + 1)])
        ruu, rrr, n = ruu + float(u @ u), rrr + float(r @ r), n + r.size
    rho = num / np.sqrt(ruu * rrr) if ruu > 0 and rrr > 0 else np.zeros(max_lag + 1)
    b = _bound(n, max_lag + 1)
    return {"max_abs_crosscorr": float(np.max(np.abs(rho))), "bound": b,
            "passed": bool(np.max(np.abs(rho)) <= b)}
