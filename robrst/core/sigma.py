"""Exact peak of the largest singular value of a state space, globally or over a band.

For ``G(s) = C (sI - A)^-1 B + D`` (any number of inputs and outputs) the peak
``sup_w sigma_max(G(jw))`` (the H-infinity norm when ``A`` is Hurwitz, the L-infinity
norm otherwise), over all ``w >= 0`` or over a closed band ``[w_lo, w_hi]``, is computed
by the level-set (bisection-free) algorithm of Boyd, Balakrishnan, Bruinsma and Steinbuch,
in the scaled time of :func:`natural_scale` (``A / w0``: the eigenvalues O(1)):

1. **Candidates.**  ``sigma_max`` at the band ends (``w = 0`` when the band starts
   there), at the limit ``w = inf`` (``sigma_max(D)``) when the band reaches it, and at
   the imaginary parts and moduli of the poles inside the band; the best is a guaranteed
   lower bound ``g``.
2. **Level-set verification.**  ``gamma = g (1 + 2 rtol)`` is a singular value of
   ``G(jw)`` exactly when ``jw`` is an eigenvalue of the Hamiltonian::

       H = [[A - B R^-1 D' C,   -gamma B R^-1 B'       ],
            [gamma C' S^-1 C,   -A' + C' D R^-1 B'     ]],
       R = D'D - gamma^2 I,  S = DD' - gamma^2 I.

   Between two consecutive such frequencies (or a frequency and a band end)
   ``sigma_max - gamma`` keeps its sign, so ``sigma_max`` evaluated at every interval's
   midpoint says whether any frequency lies above ``gamma``; ``g`` is raised to the best
   value (refined by a golden-section search) until none does.  Eigenvalues are accepted
   as imaginary loosely (real part up to :data:`LOOSE` of the modulus, as the SISO kernel
   :mod:`robrst.core.peaks` does): a spurious crossing only costs an evaluation, a missed
   one could lose a peak.

On return the supremum lies in ``[value, value (1 + 2 rtol)]`` and ``value`` is attained
at ``freq_rad_s``.  One Hamiltonian of size ``2n`` per verification, usually one to three.
The SISO peaks of :mod:`robrst.core.peaks` work on polynomials; this kernel works on the
state space that a multi-axis loop of high order needs (its polynomials would not fit in
double precision).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.core._levelbatch import LOOSE
from robrst.core.peaks import Peak

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["frequency_response", "sigma_peak", "sigma_max", "natural_scale", "Peak", "LOOSE"]

_GOLDEN = 0.5 * (3.0 - np.sqrt(5.0))
_POLISH = 24        # golden-section steps that refine the best midpoint


def natural_scale(A: ArrayLike) -> float:
    """A frequency scale [rad/s]: the geometric mean of the non-zero eigenvalue moduli of ``A``.

    Parameters
    ----------
    A : array_like
        ``(n, n)``.

    Returns
    -------
    float
        1.0 when ``A`` is empty or nilpotent.
    """
    A = np.asarray(A, float)
    if A.size == 0:
        return 1.0
    mag = np.abs(np.linalg.eigvals(A))
    mag = mag[mag > 1e-300]
    return float(np.exp(np.mean(np.log(mag)))) if mag.size else 1.0


def sigma_max(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
              w: ArrayLike) -> np.ndarray:
    """``sigma_max(G(jw))`` at the frequencies ``w`` [rad/s] (``inf``: ``sigma_max(D)``).

    Parameters
    ----------
    A, B, C, D : array_like
        The state space, in the frequency unit of ``w``.
    w : array_like
        Frequencies.

    Returns
    -------
    numpy.ndarray
        One value per frequency (``inf`` at an eigenvalue of ``A`` on the axis).
    """
    A, B, C, D = (np.atleast_2d(np.asarray(x, float)) for x in (A, B, C, D))
    return _sv(A, B, C, D, np.atleast_1d(np.asarray(w, float)))


def frequency_response(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
                       w: ArrayLike) -> np.ndarray:
    """``G(jw) = C (jwI - A)^-1 B + D`` at the frequencies ``w`` [rad/s] (``inf``: ``D``).

    Parameters
    ----------
    A, B, C, D : array_like
        The state space, in the frequency unit of ``w``.
    w : array_like
        Frequencies.

    Returns
    -------
    numpy.ndarray
        ``(len(w), outputs, inputs)``, complex (``inf`` entries at an eigenvalue of ``A`` on
        the axis).
    """
    A, B, C, D = (np.atleast_2d(np.asarray(x, float)) for x in (A, B, C, D))
    return _response(A, B, C, D, np.atleast_1d(np.asarray(w, float)))


def _response(A, B, C, D, nu):
    n = A.shape[0]
    out = np.empty((nu.size,) + D.shape, complex)
    eye = np.eye(n)
    for i, v in enumerate(nu):
        if not np.isfinite(v) or not n:
            out[i] = D
            continue
        try:
            out[i] = C @ np.linalg.solve(1j * v * eye - A, B) + D
        except np.linalg.LinAlgError:
            out[i] = np.inf
    return out


def _sv(A, B, C, D, nu):
    G = _response(A, B, C, D, nu)
    if not G[0].size:
        return np.zeros(nu.size)
    out = np.full(nu.size, np.inf)
    ok = np.all(np.isfinite(G), axis=(1, 2))
    if np.any(ok):
        out[ok] = np.linalg.svd(G[ok], compute_uv=False)[:, 0]
    out[np.isnan(out)] = np.inf
    return out


def sigma_peak(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
               band: tuple[float, float] | None = None, rtol: float = 1e-10,
               max_iter: int = 40, w0: float | None = None) -> Peak:
    """Exact peak of ``sigma_max(C (jwI - A)^-1 B + D)`` over ``w >= 0`` or a band.

    Parameters
    ----------
    A, B, C, D : array_like
        ``(n, n)``, ``(n, k)``, ``(m, n)``, ``(m, k)``; time in seconds (frequencies in
        rad/s).
    band : (float, float), optional
        ``(w_lo, w_hi)`` [rad/s], ``0 <= w_lo <= w_hi`` (``w_hi = inf``: the limit at
        infinity included); default every ``w >= 0``.
    rtol : float
        Relative accuracy: the supremum lies in ``[value, value (1 + 2 rtol)]``.
    max_iter : int
        Cap on the level-set verifications; a peak not settled within it has
        ``verified = False`` (``value`` is then a lower bound).
    w0 : float, optional
        The frequency scale of the computation (default :func:`natural_scale` of ``A``).

    Returns
    -------
    Peak
        ``value`` and ``freq_rad_s`` (``inf``: the limit at infinite frequency);
        ``value = inf`` at an eigenvalue of ``A`` on the imaginary axis inside the band.

    Raises
    ------
    ValueError
        Inconsistent shapes, or a band that is not ``0 <= lo <= hi``.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.sigma import sigma_peak
    >>> A = np.array([[0.0, 1.0], [-1.0, -0.2]])          # 1 / (s^2 + 0.2 s + 1)
    >>> pk = sigma_peak(A, [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    >>> round(pk.value, 6), round(pk.freq_rad_s, 5)
    (5.025189, 0.98995)
    """
    A, B, C, D = (np.atleast_2d(np.asarray(x, float)) for x in (A, B, C, D))
    n = A.shape[0] if A.size else 0
    if A.size == 0:
        A = np.zeros((0, 0))
        B = np.zeros((0, D.shape[1]))
        C = np.zeros((D.shape[0], 0))
    if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n or \
            D.shape != (C.shape[0], B.shape[1]):
        raise ValueError(f"sigma_peak: inconsistent shapes A {A.shape}, B {B.shape},"
                         f" C {C.shape}, D {D.shape}")
    lo, hi = (0.0, np.inf) if band is None else (float(band[0]), float(band[1]))
    if not 0.0 <= lo <= hi:
        raise ValueError(f"sigma_peak: band must satisfy 0 <= lo <= hi, got {band}")
    if not (B.size and C.size) or n == 0:
        v = float(np.linalg.norm(D, 2)) if D.size else 0.0
        return Peak(v, lo if np.isfinite(lo) else np.inf)
    sc = float(w0) if w0 else natural_scale(A)
    As, Bs = A / sc, B / sc
    lo_s, hi_s = lo / sc, hi / sc
    lam = np.linalg.eigvals(As)
    on_axis = np.abs(lam.real) <= 1e-13 * np.maximum(np.abs(lam), 1.0)
    inside = on_axis & (np.abs(lam.imag) >= lo_s) & (np.abs(lam.imag) <= hi_s)
    if np.any(inside):
        return Peak(np.inf, float(np.abs(lam[inside][0].imag)) * sc)
    cand = [lo_s] + ([hi_s] if np.isfinite(hi_s) else [np.inf])
    for x in np.concatenate([np.abs(lam.imag), np.abs(lam)]):
        if lo_s < x < hi_s:
            cand.append(float(x))
    cand = np.unique(np.asarray(cand, float))
    vals = _sv(As, Bs, C, D, cand)
    k = int(np.argmax(vals))
    g, nu_pk = float(vals[k]), float(cand[k])
    if np.isfinite(nu_pk) and 0 < len(cand):
        g, nu_pk = _polish(As, Bs, C, D, cand, k, g, nu_pk, lo_s, hi_s)
    verified = False
    for _ in range(max_iter):
        if g == 0.0:
            verified = True
            break
        gamma = g * (1.0 + 2.0 * rtol)
        cross = _crossings(As, Bs, C, D, gamma, lo_s, hi_s)
        pts = np.unique(np.concatenate([[lo_s], cross, [hi_s] if np.isfinite(hi_s) else []]))
        mids = _midpoints(pts, hi_s)
        if not mids.size:
            verified = True
            break
        mv = _sv(As, Bs, C, D, mids)
        j = int(np.argmax(mv))
        if not mv[j] > gamma:
            verified = True
            break
        grid = np.concatenate([pts, mids])
        order = np.argsort(grid)
        grid = grid[order]
        kk = int(np.searchsorted(grid, mids[j]))
        g, nu_pk = _polish(As, Bs, C, D, grid, kk, float(mv[j]), float(mids[j]), lo_s, hi_s)
    return Peak(g, nu_pk * sc if np.isfinite(nu_pk) else np.inf, verified)


def _hamiltonian(A, B, C, D, gamma):
    """The Hamiltonian whose imaginary eigenvalues ``j nu`` are the frequencies where
    ``gamma`` is a singular value of ``G(j nu)`` (module docstring)."""
    k, m = B.shape[1], C.shape[0]
    R = D.T @ D - gamma ** 2 * np.eye(k)
    S = D @ D.T - gamma ** 2 * np.eye(m)
    RiDt = np.linalg.solve(R, D.T)
    RiBt = np.linalg.solve(R, B.T)
    H11 = A - B @ (RiDt @ C)
    H12 = -gamma * (B @ RiBt)
    H21 = gamma * (C.T @ np.linalg.solve(S, C))
    H22 = -A.T + C.T @ (D @ RiBt)
    return np.block([[H11, H12], [H21, H22]])


def _crossings(A, B, C, D, gamma, lo, hi):
    """Frequencies in ``(lo, hi)`` where ``gamma`` may be a singular value (loose)."""
    sd = np.linalg.svd(D, compute_uv=False) if D.size else np.zeros(0)
    if sd.size and np.min(np.abs(sd - gamma)) <= 1e-12 * gamma:
        gamma = gamma * (1.0 + 1e-9)     # R or S singular: a hair above (a finite band)
    ev = np.linalg.eigvals(_hamiltonian(A, B, C, D, gamma))
    ok = np.abs(ev.real) <= LOOSE * np.abs(ev)
    nu = np.abs(ev[ok].imag)
    nu = nu[(nu > lo) & (nu < hi)]
    return np.unique(nu)


def _midpoints(pts, hi):
    """A point inside every interval between consecutive ``pts`` (geometric mean when
    both ends are positive), and beyond the last one when the band is unbounded."""
    out = []
    for a, b in zip(pts[:-1], pts[1:]):
        if b > a:
            out.append(np.sqrt(a * b) if a > 0 else 0.5 * b)
    if not np.isfinite(hi):
        last = pts[-1]
        out.append(2.0 * last if last > 0 else 1.0)
    return np.asarray(out, float)


def _polish(A, B, C, D, grid, k, g, nu, lo, hi):
    """Golden-section refinement of a maximum found at ``grid[k]`` (between its
    neighbours, in log frequency when positive); returns the better ``(value, nu)``."""
    a = grid[k - 1] if k > 0 else lo
    b = grid[k + 1] if k + 1 < len(grid) else (hi if np.isfinite(hi) else 2.0 * nu + 1.0)
    if not np.isfinite(b):
        b = 2.0 * nu + 1.0
    a, b = max(a, lo), min(b, hi)
    if not (np.isfinite(nu) and b > a):
        return g, nu
    logs = a > 0
    f = (lambda t: np.exp(t)) if logs else (lambda t: t)
    x0, x3 = (np.log(a), np.log(b)) if logs else (a, b)
    x1 = x0 + _GOLDEN * (x3 - x0)
    x2 = x3 - _GOLDEN * (x3 - x0)
    v1, v2 = _sv(A, B, C, D, np.array([f(x1), f(x2)]))
    for _ in range(_POLISH):
        if v1 >= v2:
            x3, x2, v2 = x2, x1, v1
            x1 = x0 + _GOLDEN * (x3 - x0)
            v1 = _sv(A, B, C, D, np.array([f(x1)]))[0]
        else:
            x0, x1, v1 = x1, x2, v2
            x2 = x3 - _GOLDEN * (x3 - x0)
            v2 = _sv(A, B, C, D, np.array([f(x2)]))[0]
    for v, x in ((v1, x1), (v2, x2)):
        if v > g:
            g, nu = float(v), float(f(x))
    return g, nu
