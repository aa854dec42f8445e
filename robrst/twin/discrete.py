"""The RST controller in discrete time (Tustin) and what discretisation does to margins.

``u = (T yr - R y) / S`` is realised as one two-input state-space system in the
scaled time ``tau = w0 t`` (O(1) coefficients whatever the size of R, S, T in s),
then discretised with the bilinear (Tustin) transform at the sampling period.  The
loop margins of the sampled loop (ZOH plant, transport delay, Tustin controller) are
computed on a dense frequency grid up to Nyquist and reported next to the
continuous ones.
"""

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import signal

from robrst import poly
from robrst.analysis import analyze
from robrst.errors import SpecError

__all__ = ["DiscreteController", "discretize", "discrete_margins"]


@dataclass(frozen=True, eq=False)
class DiscreteController:
    """``xc+ = A xc + B [yr, y]``, ``u = C xc + D [yr, y]`` at ``fs`` [Hz]."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    fs: float
    method: str


def _tf2ss(num, den):
    with warnings.catch_warnings():  # zero-padded numerators are intended, not ill-conditioned
        warnings.simplefilter("ignore", signal.BadCoefficients)
        return signal.tf2ss(num, den)


def _scaled_miso(ctrl, w0):
    S = poly.trim(ctrl.S)
    deg = len(S) - 1
    pad = lambda c: np.concatenate([np.zeros(deg + 1 - len(poly.trim(c))), poly.trim(c)])  # noqa: E731
    Ss, Ts, Rs = (poly.to_scaled(pad(c), w0) / w0 ** deg for c in (S, ctrl.T, ctrl.R))
    lead = Ss[0]
    # SIMO [T; -R]/S, then its dual is the MISO u = [T, -R]/S [yr; y]
    A, B, C, D = _tf2ss(np.vstack([Ts, -Rs]) / lead, Ss / lead)
    return A.T, C.T, B.T, D.T


def discretize(ctrl, fs, method="tustin"):
    """Discretise an :class:`~robrst.rst.RSTController` at ``fs`` [Hz] (Tustin)."""
    if method != "tustin":
        raise SpecError(f"discretisation method {method!r}: only 'tustin' is provided")
    if fs <= 0:
        raise SpecError(f"sampling rate must be > 0, got {fs}")
    w0 = poly.natural_scale(ctrl.S, ctrl.R)
    A, B, C, D = _scaled_miso(ctrl, w0)
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, D), w0 / fs, method="bilinear")
    return DiscreteController(A=Ad, B=Bd, C=Cd, D=Dd, fs=float(fs), method=method)


def _freq_controller(dc, w):
    z = np.exp(1j * w / dc.fs)
    n = dc.A.shape[0]
    out = np.empty((len(w), 2), complex)
    for i, zi in enumerate(z):
        out[i] = (dc.C @ np.linalg.solve(zi * np.eye(n) - dc.A, dc.B) + dc.D).ravel()
    return out


def discrete_margins(plant, ctrl, fs, delay_samples=0, n_grid=4000):
    """Ms and modulus margin of the sampled loop vs the continuous design.

    Plant: exact ZOH discretisation (scaled) times ``z**-delay_samples``; controller:
    :func:`discretize`.  Evaluated on ``n_grid`` log-spaced frequencies up to Nyquist.

    Returns
    -------
    dict
        ``Ms_continuous``, ``Ms_discrete``, ``modulus_margin_*``, ``delay_samples``,
        ``fs_hz``, ``method``.
    """
    dc = discretize(ctrl, fs)
    w0 = poly.natural_scale(plant.A)
    n = plant.n
    a = poly.to_scaled(plant.A, w0) / w0 ** n
    b = poly.to_scaled(np.concatenate([np.zeros(n + 1 - len(plant.B)), plant.B]), w0) / w0 ** n
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete(_tf2ss(b, a), w0 / fs, method="zoh")
    w = np.geomspace(1e-2, np.pi * fs * (1 - 1e-6), n_grid)
    z = np.exp(1j * w / fs)
    P = np.array([(Cd @ np.linalg.solve(zi * np.eye(n) - Ad, Bd) + Dd).item() for zi in z])
    P = P * z ** (-delay_samples)
    K = _freq_controller(dc, w)
    L = -P * K[:, 1]                     # u = ... - (R/S) y: loop gain P R/S
    Sd = np.abs(1.0 / (1.0 + L))
    Ms_c = analyze(plant, ctrl).peaks["S"].value
    return {"fs_hz": float(fs), "method": dc.method, "delay_samples": int(delay_samples),
            "Ms_continuous": float(Ms_c), "Ms_discrete": float(np.max(Sd)),
            "modulus_margin_continuous": float(1 / Ms_c),
            "modulus_margin_discrete": float(1 / np.max(Sd)),
            "peak_freq_hz_discrete": float(w[np.argmax(Sd)] / (2 * np.pi))}
