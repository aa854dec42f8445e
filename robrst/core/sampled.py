"""The sampled loop as an exact continuous-variable loop (ZOH plant, Tustin controller).

A controller ``K(s)`` implemented by the bilinear (Tustin) rule at ``fs`` is
``K_d(z) = K(2 fs (z - 1)/(z + 1))``; the plant seen through a zero-order hold is
``P_d(z)`` (exact ZOH), possibly behind ``k`` samples of computation delay
``z**-k``.  Substituting ``z = (1 + s/(2 fs)) / (1 - s/(2 fs))`` everywhere gives a
loop in the variable ``s`` with the *same* controller ``K(s)`` and the plant

    P_w(s) = P_d(z(s)) * ((1 - s/(2 fs)) / (1 + s/(2 fs)))**k.

This is exact, not an approximation: the bilinear map sends the unit disk onto the
left half-plane, so the sampled loop is stable iff ``P_w``'s loop is Hurwitz (with
full degree: a lost leading coefficient is a pole at ``z = -1``), and
``|S_d(e^{j w / fs})| = |S_w(j nu)|`` with ``nu = 2 fs tan(w / (2 fs))``.  Every
peak, stability and margin computation of the continuous loop therefore applies to
the sampled loop unchanged, including the exact Hamiltonian peaks.
"""

from __future__ import annotations

from math import comb
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.base.errors import SpecError
from robrst.core.plant import Plant

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["sampled_plant", "warp", "unwarp", "warp_band", "w_plane_matrices"]

# an irregular point of the scaled plane where the gain of P_w is matched
_GAIN_POINT = 0.3719 + 0.8537j


def warp(w: ArrayLike, sample_rate_hz: float) -> np.ndarray:
    """Physical frequency ``w`` [rad/s] (below Nyquist) -> the loop variable ``nu``.

    Parameters
    ----------
    w : array_like
        Frequencies [rad/s], below ``pi fs``.
    sample_rate_hz : float
        Sampling rate ``fs`` [Hz].

    Returns
    -------
    numpy.ndarray
        ``nu = 2 fs tan(w / (2 fs))``.
    """
    fs = float(sample_rate_hz)
    return 2.0 * fs * np.tan(np.asarray(w, float) / (2.0 * fs))


def unwarp(nu: ArrayLike, sample_rate_hz: float) -> np.ndarray:
    """Loop variable ``nu`` -> physical frequency [rad/s] (``inf`` -> Nyquist ``pi fs``).

    Parameters
    ----------
    nu : array_like
        Frequencies of the w-plane loop.
    sample_rate_hz : float
        Sampling rate ``fs`` [Hz].

    Returns
    -------
    numpy.ndarray
        ``w = 2 fs arctan(nu / (2 fs))``.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.sampled import unwarp, warp
    >>> float(unwarp(warp(1000.0, 20000.0), 20000.0))
    1000.0
    """
    fs = float(sample_rate_hz)
    return 2.0 * fs * np.arctan(np.asarray(nu, float) / (2.0 * fs))


def warp_band(w_lo: float, w_hi: float, sample_rate_hz: float) -> tuple[float, float]:
    """The loop-variable interval of the physical band ``[w_lo, w_hi]`` [rad/s].

    The sampled loop's response at ``e^{j w / fs}`` is ``2 pi fs``-periodic and even in
    ``w``: a band reaching above Nyquist folds onto ``[0, pi fs]``; the folded interval
    is then warped, its ends exactly (Nyquist itself is ``nu = inf``, not a point just
    below it).

    Parameters
    ----------
    w_lo, w_hi : float
        Band ends [rad/s], ``0 <= w_lo <= w_hi`` (``w_hi`` may be ``inf``).
    sample_rate_hz : float

    Returns
    -------
    (float, float)
        ``(nu_lo, nu_hi)`` in the loop variable; ``nu_hi = inf`` when the band contains
        Nyquist (or an odd multiple of it).

    Examples
    --------
    >>> warp_band(10.0, 20.0, 100.0)[1] == float(warp(20.0, 100.0))
    True
    >>> lo, hi = warp_band(100.0, 400.0, 100.0)   # Nyquist (314.16 rad/s) inside the band
    >>> round(lo, 4), hi
    (109.2605, inf)
    """
    fs = float(sample_rate_hz)
    nyq = np.pi * fs
    lo, hi = float(w_lo), float(w_hi)
    if not hi - lo < 2.0 * nyq:
        return 0.0, np.inf

    def fold(w):
        r = np.fmod(w, 2.0 * nyq)
        return 2.0 * nyq - r if r > nyq else r

    a, b = sorted((fold(lo), fold(hi)))
    m = np.ceil(lo / nyq)                 # the first multiple of Nyquist in [lo, hi]
    if m * nyq <= hi:
        if m % 2 == 1 or (m + 1) * nyq <= hi:
            b = nyq
        if m % 2 == 0 or (m + 1) * nyq <= hi:
            a = 0.0
    nu_lo = 0.0 if a == 0.0 else (np.inf if a >= nyq else float(warp(a, fs)))
    nu_hi = np.inf if b >= nyq else float(warp(b, fs))
    return nu_lo, nu_hi


def _binomial(k, sign):
    """Coefficients of ``(sign * q + 1)**k`` (highest power first)."""
    return np.array([comb(k, j) * sign ** (k - j) for j in range(k + 1)], float)


def _w_plane(dss):
    """State space of ``P_d((1 + q)/(1 - q))`` in the scaled variable, from the ZOH model
    (:func:`w_plane_matrices` of one input and one output)."""
    Aw, Bw, Cw, Dw = w_plane_matrices(dss.A, dss.Gamma, dss.Ad, dss.Bd, dss.C,
                                      np.array([[dss.d]]), dss.h)
    return Aw, Bw, Cw, float(Dw[0, 0])


def w_plane_matrices(A: np.ndarray, Gamma: np.ndarray, Ad: np.ndarray, Bd: np.ndarray,
                     C: np.ndarray, D: np.ndarray,
                     h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The w-plane state space of a ZOH-sampled system (any number of inputs and outputs).

    With ``q = p h / 2``, ``P_d((1 + q)/(1 - q)) = Cw (pI - Aw)^-1 Bw + Dw`` where
    ``Aw = (2/h)(I + Ad)^-1 (Ad - I)``, ``Ad - I = A Gamma`` computed without
    cancellation (:func:`robrst.core.lti.zoh_matrices` gives ``Ad, Gamma, Bd``).

    Parameters
    ----------
    A : numpy.ndarray
        ``(n, n)``: the continuous matrix, in the time unit of ``h``.
    Gamma : numpy.ndarray
        ``(n, n)``: ``int_0^h exp(A t) dt``.
    Ad, Bd : numpy.ndarray
        ``(n, n)``, ``(n, k)``: the ZOH model.
    C, D : numpy.ndarray
        ``(m, n)``, ``(m, k)``.
    h : float
        The sampling period in the time unit of ``A``.

    Returns
    -------
    Aw, Bw, Cw, Dw : numpy.ndarray
        The w-plane realisation (``Cw = C``), in the frequency unit of ``A``.
    """
    n = A.shape[0]
    Ipad = np.eye(n) + Ad
    AG = A @ Gamma                                           # Ad - I, accurately
    Aw = (2.0 / h) * np.linalg.solve(Ipad, AG)
    Bw1 = (2.0 / h) * np.linalg.solve(Ipad, Bd)
    Bw = Bw1 - (h / 2.0) * (Aw @ Bw1)
    Dw = np.asarray(D, float) - (h / 2.0) * (C @ Bw1)
    return Aw, Bw, C, Dw


# physical frequencies (fractions of the sampling rate, rad/sample) where the polynomials of
# the sampled plant are compared with its exact state space (besides s = 0)
_CHECK_THETA = (1.3e-3, 1.7e-2, 0.19, 0.83, 1.9, 2.87)


def _w_polynomials(w_ss: tuple, poles: np.ndarray, h: float,
                   w0: float) -> tuple[np.ndarray, np.ndarray]:
    """``(B, A)`` in s of the w-plane state space ``w_ss`` (scaled variable, poles known).

    The zeros are the transmission zeros of the balanced system matrix in two frequency
    units: the unit of ``q = s / (2 fs)`` (where the sampling zeros are O(1) whatever
    the spread of the poles: a pole near ``s = 0`` beside O(1) poles) and the plant's
    natural unit; the gain is matched at one point of the scaled plane.  Of the two,
    the one closer to the exact state space at ``s = 0`` and on the unit circle
    (:data:`_CHECK_THETA`) is kept.
    """
    Aw, Bw, Cw, dw = w_ss
    n = len(poles)
    eye = np.eye(n)

    def exact(p):
        return (Cw @ np.linalg.solve(p * eye - Aw, Bw)).item() + dw

    pts = [1j * (2.0 / h) * np.tan(th / 2.0) for th in _CHECK_THETA]
    if np.all(poles != 0):
        pts.append(0.0)
    ref = np.array([exact(p) for p in pts])
    p0 = _GAIN_POINT
    val = exact(p0)
    best = None
    for unit in (2.0 / h, 1.0):
        zeros = lti.transmission_zeros(Aw, Bw, Cw, dw, scale=unit)
        gain = (val * np.prod(p0 - poles) / np.prod(p0 - zeros)).real
        got = np.array([gain * np.prod(p - zeros) / np.prod(p - poles) for p in pts])
        with np.errstate(all="ignore"):
            err = np.max(np.abs(got - ref) / np.abs(ref)) if len(pts) else 0.0
        err = err if np.isfinite(err) else np.inf
        if best is None or err < best[0]:
            best = (err, zeros, gain)
    _, zeros, gain = best
    B = (gain * w0 ** (n - len(zeros))) * poly.from_roots(w0 * zeros)
    return B, poly.from_roots(w0 * poles)


def sampled_plant(plant: Plant, sample_rate_hz: float, delay_samples: int = 0) -> Plant:
    """The plant ``P_w(s)`` of the sampled loop (see the module docstring).

    Parameters
    ----------
    plant : Plant
        Continuous plant (``B/A`` in s).
    sample_rate_hz : float
        Sampling rate [Hz].
    delay_samples : int
        Whole samples of computation delay between measurement and actuation.

    Returns
    -------
    Plant
        Biproper in general; label ``"<label>@<fs> Hz"``, same temperature, and
        ``meta`` ``{"fs_hz", "delay_samples", "continuous_label"}``.

    Raises
    ------
    SpecError
        For a rate that is not > 0 or a delay that is not a whole number >= 0.

    Notes
    -----
    Built from the exact state-space ZOH model (:func:`robrst.core.lti.zoh`): the poles are
    the exact images ``2 fs tanh(p / (2 fs))`` of the continuous poles, the zeros the
    transmission zeros of the balanced w-plane system matrix (in the unit of
    ``s / (2 fs)``, where the sampling zeros are O(1): exact for a pole near ``s = 0``
    beside faster ones, a near-integrator, as for one at 0), the gain matched at one
    point; of two frequency units for the zeros, the one that reproduces the state space
    at ``s = 0`` and on the unit circle is kept.  No polynomial in ``z`` is ever
    expanded (its roots cluster at ``z = 1``).
    """
    fs = float(sample_rate_hz)
    if not fs > 0:
        raise SpecError(f"sampling rate must be > 0 Hz, got {sample_rate_hz}")
    if int(delay_samples) != delay_samples or delay_samples < 0:
        raise SpecError(f"delay_samples must be a whole number >= 0, got {delay_samples}")
    dss = lti.zoh(plant.B, plant.A, fs)
    w0, h = dss.scaling.w0, dss.h
    # poles: exact images 2/h tanh(lambda h / 2) of the continuous poles (scaled)
    lam = np.linalg.eigvals(dss.A)
    poles = (2.0 / h) * np.tanh(lam * h / 2.0)
    B, A = _w_polynomials(_w_plane(dss), poles, h, w0)
    k = int(delay_samples)
    if k:   # z**-k = ((1 - q)/(1 + q))**k with q = s / (2 fs)
        B = np.convolve(B, poly.from_scaled(_binomial(k, -1.0), 2.0 * fs))
        A = np.convolve(A, poly.from_scaled(_binomial(k, 1.0), 2.0 * fs))
    return Plant(poly.trim(B), poly.trim(A), label=f"{plant.label}@{fs:g}Hz",
                 temperature_C=plant.temperature_C,
                 meta={"fs_hz": fs, "delay_samples": k, "continuous_label": plant.label})
