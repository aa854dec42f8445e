"""Exact peak gain of a SISO rational transfer function ``N(s)/D(s)``.

The peak ``max_w |G(jw)|`` (the H-infinity norm when D is Hurwitz, the L-infinity
norm otherwise) is computed with the Bruinsma–Steinbuch bisection on the imaginary
eigenvalues of a Hamiltonian matrix, in the scaled variable ``p = s / w0``, then the
peak frequency is polished by Newton steps on the stationarity condition of
``|G|^2`` (a polynomial in ``w^2``).  This is exact up to the
relative tolerance ``rtol``, not a grid maximum.
"""

from dataclasses import dataclass

import numpy as np

from robrst import lti, poly

__all__ = ["Peak", "peak_gain", "mag2_poly"]


@dataclass(frozen=True)
class Peak:
    """Exact peak ``value`` of ``|G(jw)|`` at ``freq_rad_s`` (inf if at w = inf)."""

    value: float
    freq_rad_s: float


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


def _hamiltonian(A, B, C, d, g):
    """Hamiltonian whose imaginary eigenvalues are the frequencies where |G| = g."""
    n = A.shape[0]
    R = d * d - g * g
    H = np.empty((2 * n, 2 * n))
    H[:n, :n] = A - (d / R) * (B @ C)
    H[:n, n:] = (-g / R) * (B @ B.T)
    H[n:, :n] = (g / R) * (C.T @ C)
    H[n:, n:] = -H[:n, :n].T
    return H


def _polish(Ns, Ds, w, g):
    """Newton on the stationarity condition of ``|G|^2`` in ``x = w^2`` near ``w``.

    ``|G(jw)|^2 = qN(x) / qD(x)`` is stationary where ``qN' qD - qN qD' = 0``;
    a few Newton steps from the bisection's ``w`` reach that root.  Returns the
    polished point unless it is lower than the start (beyond rounding), in which
    case Newton left the peak and the start is kept.
    """
    qN, qD = mag2_poly(Ns), mag2_poly(Ds)
    P = np.polysub(np.polymul(np.polyder(qN), qD), np.polymul(qN, np.polyder(qD)))
    dP = np.polyder(P)
    x0 = x = w * w
    for _ in range(12):
        step = np.polyval(P, x) / np.polyval(dP, x)
        x = x - step
        if not (x0 / 1.2 < x < x0 * 1.2):
            return g, w
        if abs(step) <= 1e-15 * x:
            break
    wp = float(np.sqrt(x))
    gp = float(_gain(Ns, Ds, wp))
    return (gp, wp) if gp >= g * (1 - 1e-13) else (g, w)


def peak_gain(N, D, rtol=1e-10, scaling=None, max_iter=60):
    """Exact peak of ``|N(jw)/D(jw)|`` over ``w >= 0``.

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s (rad/s), ``deg N <= deg D``; D without
        roots on the imaginary axis.
    rtol : float
        Relative accuracy of the peak value.
    scaling : Scaling, optional
        Frequency scaling; default: at the geometric mean of the root moduli of D.

    Returns
    -------
    Peak
    """
    N, D = poly.trim(N), poly.trim(D)
    sc = scaling or poly.Scaling.natural(D)
    w0 = sc.w0
    A, B, C, d = lti.companion(N, D, sc)
    n = A.shape[0]
    Ns, Ds = sc.apply(N), sc.apply(D)
    # candidate lower bounds: w = 0, the pole frequencies, a coarse log grid
    lam = np.linalg.eigvals(A) if n else np.zeros(0)
    mags = np.abs(lam)
    nzm = mags[mags > 0]
    lo, hi = (nzm.min(), nzm.max()) if nzm.size else (1.0, 1.0)
    cand = np.concatenate([[0.0], nzm, np.abs(lam.imag), np.geomspace(lo / 100, hi * 100, 64)])
    vals = _gain(Ns, Ds, cand)
    i = int(np.argmax(vals))
    g_lb, w_pk = float(vals[i]), float(cand[i])
    if abs(d) >= g_lb:
        g_lb, w_pk = abs(d), np.inf
    if n == 0 or g_lb == 0.0:
        return Peak(g_lb, w_pk * w0 if np.isfinite(w_pk) else np.inf)
    for _ in range(max_iter):
        ev = np.linalg.eigvals(_hamiltonian(A, B, C, d, (1 + 2 * rtol) * g_lb))
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
        g_lb, w_pk = _polish(Ns, Ds, w_pk, g_lb)
    return Peak(g_lb, w_pk * w0 if np.isfinite(w_pk) else np.inf)
