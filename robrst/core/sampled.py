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

__all__ = ["sampled_plant", "warp", "unwarp"]

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


def _binomial(k, sign):
    """Coefficients of ``(sign * q + 1)**k`` (highest power first)."""
    return np.array([comb(k, j) * sign ** (k - j) for j in range(k + 1)], float)


def _w_plane(dss):
    """State space of ``P_d((1 + q)/(1 - q))`` in the scaled variable, from the ZOH model.

    With ``q = p h / 2``: ``Aw = (2/h)(I + Ad)^-1 (Ad - I)`` where ``Ad - I = A Gamma``
    is computed without cancellation; ``P_w(p) = Cw (pI - Aw)^-1 Bw + dw``.
    """
    n = dss.A.shape[0]
    h = dss.h
    Ipad = np.eye(n) + dss.Ad
    AG = dss.A @ dss.Gamma                                   # Ad - I, accurately
    Aw = (2.0 / h) * np.linalg.solve(Ipad, AG)
    Bw1 = (2.0 / h) * np.linalg.solve(Ipad, dss.Bd)
    Bw = Bw1 - (h / 2.0) * (Aw @ Bw1)
    dw = float(dss.d - (h / 2.0) * (dss.C @ Bw1).item())
    return Aw, Bw, dss.C, dw


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
    transmission zeros of the w-plane state space, the gain matched at one point.  No
    polynomial in ``z`` is ever expanded (its roots cluster at ``z = 1``).
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
    Aw, Bw, Cw, dw = _w_plane(dss)
    zeros = lti.transmission_zeros(Aw, Bw, Cw, dw)
    p0 = _GAIN_POINT
    val = (Cw @ np.linalg.solve(p0 * np.eye(len(lam)) - Aw, Bw)).item() + dw
    gain = val * np.prod(p0 - poles) / np.prod(p0 - zeros)
    B = (gain.real * w0 ** (len(poles) - len(zeros))) * poly.from_roots(w0 * zeros)
    A = poly.from_roots(w0 * poles)
    k = int(delay_samples)
    if k:   # z**-k = ((1 - q)/(1 + q))**k with q = s / (2 fs)
        B = np.convolve(B, poly.from_scaled(_binomial(k, -1.0), 2.0 * fs))
        A = np.convolve(A, poly.from_scaled(_binomial(k, 1.0), 2.0 * fs))
    return Plant(poly.trim(B), poly.trim(A), label=f"{plant.label}@{fs:g}Hz",
                 temperature_C=plant.temperature_C,
                 meta={"fs_hz": fs, "delay_samples": k, "continuous_label": plant.label})
