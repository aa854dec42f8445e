"""Exact peak gain of a SISO rational transfer function ``N(s)/D(s)``.

The peak ``max_w |G(jw)|`` (the H-infinity norm when D is Hurwitz, the L-infinity
norm otherwise) is computed with the Bruinsma–Steinbuch bisection on the imaginary
eigenvalues of a Hamiltonian matrix, in the scaled variable ``p = s / w0``, then the
peak frequency is polished by a bounded local maximisation.  This is exact up to the
relative tolerance ``rtol``, not a grid maximum.
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize_scalar

from robrst import poly

__all__ = ["Peak", "peak_gain", "scaled_realization", "mag2_poly"]


@dataclass(frozen=True)
class Peak:
    """Exact peak ``value`` of ``|G(jw)|`` at ``freq_rad_s`` (inf if at w = inf)."""

    value: float
    freq_rad_s: float


def scaled_realization(N, D, w0):
    """Balanced controllable-form realisation of ``N/D`` in ``p = s / w0``.

    Returns ``(A, B, C, d)`` with ``G(w0 * p) = C (pI - A)^-1 B + d``.
    """
    Ns = poly.to_scaled(poly.trim(N), w0)
    Ds = poly.to_scaled(poly.trim(D), w0)
    Ns, Ds = Ns / Ds[0], Ds / Ds[0]
    n = len(Ds) - 1
    if len(Ns) > n + 1:
        raise ValueError("improper transfer function: deg N > deg D")
    Nf = np.concatenate([np.zeros(n + 1 - len(Ns)), Ns])
    d = Nf[0]
    rem = Nf[1:] - d * Ds[1:]
    A = np.zeros((n, n))
    A[0, :] = -Ds[1:]
    A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = rem.reshape(1, n)
    if n:
        _, (sc, perm) = sla.matrix_balance(A, permute=False, separate=True)
        A = A * (1 / sc)[:, None] * sc[None, :]
        B = B / sc[:, None]
        C = C * sc[None, :]
    return A, B, C, float(d)


def _gain(N, D, w):
    return np.abs(poly.eval_jw(N, w) / poly.eval_jw(D, w))


def mag2_poly(c):
    """Polynomial ``q`` in ``x = w**2`` with ``|c(jw)|**2 == q(w**2)``."""
    c = np.asarray(c, dtype=float)
    d = len(c) - 1
    cm = c * (-1.0) ** np.arange(d, -1, -1)  # c(-s)
    e = np.polymul(c, cm)  # even polynomial in s, degree 2d
    ev = e[::2]  # coefficients of s^(2d), s^(2d-2), ..., s^0
    k = np.arange(d, -1, -1)
    return ev * (-1.0) ** k  # s^(2k) = (-x)^k


def peak_gain(N, D, rtol=1e-10, w0=None, max_iter=60):
    """Exact peak of ``|N(jw)/D(jw)|`` over ``w >= 0``.

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s (rad/s), ``deg N <= deg D``; D without
        roots on the imaginary axis.
    rtol : float
        Relative accuracy of the peak value.
    w0 : float, optional
        Frequency scale; default: geometric mean of the roots of D.

    Returns
    -------
    Peak
    """
    N, D = poly.trim(N), poly.trim(D)
    w0 = float(w0 or poly.natural_scale(D))
    A, B, C, d = scaled_realization(N, D, w0)
    n = A.shape[0]
    # candidate lower bounds: w = 0, w = inf, the pole frequencies
    lam = np.linalg.eigvals(A) if n else np.zeros(0)
    cand = [0.0] + [abs(l) for l in lam if abs(l) > 0] + [abs(l.imag) for l in lam]
    mags = np.abs(lam[np.abs(lam) > 0]) if n else np.ones(1)
    lo, hi = (np.min(mags), np.max(mags)) if mags.size else (1.0, 1.0)
    cand += list(np.geomspace(lo / 100, hi * 100, 64))  # cheap start: a coarse log grid
    Ns, Ds = poly.to_scaled(N, w0), poly.to_scaled(D, w0)
    vals = _gain(Ns, Ds, np.array(cand))
    i = int(np.argmax(vals))
    g_lb, w_pk = float(vals[i]), float(cand[i])
    if abs(d) >= g_lb:
        g_lb, w_pk = abs(d), np.inf
    if n == 0 or g_lb == 0.0:
        return Peak(g_lb, w_pk * w0 if np.isfinite(w_pk) else np.inf)
    for _ in range(max_iter):
        g = (1 + 2 * rtol) * g_lb
        R = d * d - g * g
        H = np.block([
            [A - B @ C * (d / R), -g * (B @ B.T) / R],
            [g * (C.T @ C) / (d * d - g * g), -A.T + C.T @ B.T * (d / R)],
        ])
        ev = np.linalg.eigvals(H)
        on_axis = ev[np.abs(ev.real) <= 1e-7 * np.maximum(1.0, np.abs(ev))]
        ws = np.unique(np.round(np.abs(on_axis.imag), 12))
        ws = ws[ws > 0] if ws.size > 1 else ws
        if ws.size == 0:
            break
        if ws.size == 1:
            mids = ws
        else:
            mids = np.sqrt(ws[:-1] * ws[1:]) if ws[0] > 0 else 0.5 * (ws[:-1] + ws[1:])
            mids = np.concatenate([mids, ws])
        vals = _gain(Ns, Ds, mids)
        j = int(np.argmax(vals))
        if vals[j] <= g_lb * (1 + rtol):
            break
        g_lb, w_pk = float(vals[j]), float(mids[j])
    if np.isfinite(w_pk) and w_pk > 0:
        lo, hi = w_pk / 1.05, w_pk * 1.05
        res = minimize_scalar(
            lambda lw: -_gain(Ns, Ds, np.exp(lw)), bounds=(np.log(lo), np.log(hi)),
            method="bounded", options={"xatol": 1e-12},
        )
        if -res.fun > g_lb:
            g_lb, w_pk = float(-res.fun), float(np.exp(res.x))
    return Peak(g_lb, w_pk * w0 if np.isfinite(w_pk) else np.inf)
