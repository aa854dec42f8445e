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

import warnings
from math import comb

import numpy as np
from scipy import signal

from robrst import poly
from robrst.errors import SpecError
from robrst.plant import Plant

__all__ = ["sampled_plant", "warp", "unwarp"]


def warp(w, fs):
    """Physical frequency ``w`` [rad/s] (below Nyquist) -> the loop variable ``nu``."""
    return 2.0 * fs * np.tan(np.asarray(w, float) / (2.0 * fs))


def unwarp(nu, fs):
    """Loop variable ``nu`` -> physical frequency [rad/s] (``inf`` -> Nyquist ``pi fs``)."""
    return 2.0 * fs * np.arctan(np.asarray(nu, float) / (2.0 * fs))


def _zoh(plant, fs):
    """Exact ZOH discretisation ``(Nd, Dd)`` in z, both of length ``n + 1`` (scaled time)."""
    n = plant.n
    w0 = poly.natural_scale(plant.A)
    a = poly.to_scaled(plant.A, w0) / w0 ** n
    b = poly.to_scaled(np.concatenate([np.zeros(n + 1 - len(plant.B)), plant.B]), w0) / w0 ** n
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", signal.BadCoefficients)
        ss = signal.tf2ss(b, a)
        Ad, Bd, Cd, Dd, _ = signal.cont2discrete(ss, w0 / fs, method="zoh")
        Nd, Dd_ = signal.ss2tf(Ad, Bd, Cd, Dd)
    Nd = np.asarray(Nd, float).ravel()
    return np.concatenate([np.zeros(n + 1 - len(Nd)), Nd]), np.asarray(Dd_, float)


def _binomial(k, sign):
    """Coefficients of ``(sign * q + 1)**k`` (highest power first)."""
    return np.array([comb(k, j) * sign ** (k - j) for j in range(k + 1)], float)


def _bilinear(c):
    """``sum_i c_i z**i`` (degree n, highest first) times ``(1 - q)**n`` at ``z = (1+q)/(1-q)``."""
    n = len(c) - 1
    out = np.zeros(n + 1)
    for k, ck in enumerate(c):
        i = n - k                                   # power of z
        out += ck * np.convolve(_binomial(i, 1.0), _binomial(n - i, -1.0))
    return out


def sampled_plant(plant, fs, delay_samples=0):
    """The plant ``P_w(s)`` of the sampled loop (see the module docstring).

    Parameters
    ----------
    plant : Plant
        Continuous plant (``B/A`` in s).
    fs : float
        Sampling rate [Hz].
    delay_samples : int
        Whole samples of computation delay between measurement and actuation.

    Returns
    -------
    Plant
        Biproper in general; label ``"<label>@<fs> Hz"``, same temperature, and
        ``meta`` ``{"fs_hz", "delay_samples", "continuous_label"}``.
    """
    if not fs > 0:
        raise SpecError(f"sampling rate must be > 0 Hz, got {fs}")
    if int(delay_samples) != delay_samples or delay_samples < 0:
        raise SpecError(f"delay_samples must be a whole number >= 0, got {delay_samples}")
    Nd, Dd = _zoh(plant, fs)
    Nq, Dq = _bilinear(Nd), _bilinear(Dd)           # polynomials in q = s / (2 fs)
    k = int(delay_samples)
    Nq = np.convolve(Nq, _binomial(k, -1.0))        # (1 - q)**k
    Dq = np.convolve(Dq, _binomial(k, 1.0))         # (1 + q)**k
    B, A = poly.from_scaled(Nq, 2.0 * fs), poly.from_scaled(Dq, 2.0 * fs)
    return Plant(poly.trim(B), poly.trim(A), label=f"{plant.label}@{fs:g}Hz",
                 temperature_C=plant.temperature_C,
                 meta={"fs_hz": float(fs), "delay_samples": k, "continuous_label": plant.label})
