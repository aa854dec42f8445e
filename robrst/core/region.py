"""The closed-loop pole region: damping and decay of poles, and the polynomials that test it.

A pole region in the sense of MATLAB's ``TuningGoal.Poles``: every pole ``p`` of a loop
damped at least ``zeta_min`` (``-Re p >= zeta_min |p|``, the sector of half-angle
``acos(zeta_min)`` around the negative real axis) and decaying at least ``sigma``
(``Re p <= -sigma``).  A sampled loop's poles are those of its discrete loop, mapped
back to ``s`` by ``s = fs ln z`` (``z`` from the bilinear loop variable ``w`` of
:mod:`robrst.core.sampled`: ``z = (1 + w/2fs)/(1 - w/2fs)``).

Both conditions are Hurwitz conditions on polynomials built from the closed-loop
polynomial ``D``, *linear* maps of its coefficients for the decay and a quadratic one for
the damping, which the certificate proves between temperatures (guardian map,
:func:`robrst.core.interval.parameter_crossing`) and the synthesis imposes for the decay
(Routh rows of the shifted or disc-mapped polynomial):

* decay, continuous loop: ``D(p - sigma)`` Hurwitz (:func:`shift_matrix`);
* decay, sampled loop: every ``|z| < exp(-sigma / fs)``, i.e. ``D`` composed with the
  Möbius map that sends the left half-plane onto that disc, Hurwitz (:func:`disc_matrix`);
* damping: the roots of ``D`` lie in the sector exactly when ``P(p) = D(e^{j phi} p)``
  with ``phi = asin(zeta_min)`` is Hurwitz; ``P`` has complex coefficients, and
  ``E = P conj(P) = Re(P)^2 + Im(P)^2`` (coefficient-wise real and imaginary parts,
  products as polynomials) is a real polynomial of twice the degree, Hurwitz exactly
  when ``P`` is (:func:`sector_polynomial`, :func:`rotation`).

The sector of the sampled loop has no polynomial test in ``w`` (its image is bounded by
logarithmic spirals): the certificate checks the mapped roots, and the synthesis
linearises the roots near the floor (:mod:`robrst.synthesis._polerows`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["s_poles", "damping_of", "least_damping", "least_decay", "shift_matrix",
           "disc_matrix", "rotation", "sector_polynomial", "boundary_distance"]


def s_poles(roots: ArrayLike, fs: float | None = None) -> np.ndarray:
    """The poles in ``s`` [rad/s]: ``roots`` themselves, or for a sampled loop (``fs``) the
    loop-variable roots ``w`` mapped by ``s = fs ln z``, ``z = (1 + w/2fs)/(1 - w/2fs)``
    (a pole at ``z = 0`` is infinitely fast: ``-inf``).

    Parameters
    ----------
    roots : array_like
        Roots [rad/s] of the closed-loop polynomial (continuous), or in ``w`` (sampled).
    fs : float, optional

    Returns
    -------
    ndarray of complex
    """
    r = np.asarray(roots, complex)
    if fs is None:
        return r
    h = 2.0 * float(fs)
    with np.errstate(all="ignore"):
        z = (h + r) / (h - r)
        out = float(fs) * np.log(z)
    return np.where(np.abs(z) == 0, -np.inf + 0j, out)


def damping_of(p: ArrayLike) -> np.ndarray:
    """``-Re p / |p|`` of each pole (1 for a pole at infinity or at the origin).

    Parameters
    ----------
    p : array_like
        Poles [rad/s].

    Returns
    -------
    numpy.ndarray
    """
    p = np.asarray(p, complex)
    w = np.abs(p)
    ok = (w > 0) & np.isfinite(w)
    with np.errstate(all="ignore"):
        return np.where(ok, -p.real / np.where(ok, w, 1.0), 1.0)


def least_damping(p: ArrayLike) -> float:
    """The least damping of the poles ``p`` (1.0 for none).

    Parameters
    ----------
    p : array_like
        Poles [rad/s].

    Returns
    -------
    float
    """
    d = damping_of(p)
    return float(np.min(d)) if d.size else 1.0


def least_decay(p: ArrayLike) -> float:
    """The least decay rate ``-Re p`` of the poles ``p`` [rad/s] (``inf`` for none).

    Parameters
    ----------
    p : array_like
        Poles [rad/s].

    Returns
    -------
    float
    """
    p = np.asarray(p, complex)
    return float(np.min(-p.real)) if p.size else np.inf


def shift_matrix(deg: int, a: float) -> np.ndarray:
    """Matrix ``M`` with ``M @ c`` the coefficients of ``c(p - a)`` (``len(c) == deg + 1``).

    ``c(p - a)`` Hurwitz is ``Re p < -a`` for every root of ``c`` (with ``a = sigma``).

    Parameters
    ----------
    deg : int
        Degree of ``c``.
    a : float
        The shift.

    Returns
    -------
    numpy.ndarray
        ``(deg + 1, deg + 1)``.
    """
    M = np.zeros((deg + 1, deg + 1))
    for j in range(deg + 1):          # column j: the monomial p**(deg - j)
        col = np.ones(1)
        for _ in range(deg - j):
            col = np.convolve(col, [1.0, -a])
        M[j:, j] = col
    return M


def disc_matrix(deg: int, sigma: float, fs: float, w0: float = 1.0) -> np.ndarray:
    """Matrix ``M``: ``M @ c`` Hurwitz exactly when every root ``w`` of ``c`` (the loop
    variable of a sampled loop, scaled by ``w0``) has ``|z| < exp(-sigma/fs)``.

    The Möbius map ``w = c2 ((r + 1) q + c2 (r - 1)) / ((r - 1) q + c2 (r + 1))`` with
    ``c2 = 2 fs / w0`` and ``r = exp(-sigma/fs)`` sends the left half ``q``-plane onto that
    disc's image; ``M @ c`` are the coefficients of ``c(w(q)) ((r - 1) q + c2 (r + 1))^deg``.

    Parameters
    ----------
    deg : int
    sigma : float
        Decay rate [rad/s].
    fs : float
        Sample rate [Hz].
    w0 : float
        Scale of the loop variable.

    Returns
    -------
    ndarray
    """
    c2 = 2.0 * fs / w0
    r = float(np.exp(-sigma / fs))
    num = np.array([c2 * (r + 1.0), c2 * c2 * (r - 1.0)])     # c2 ((r+1) q + c2 (r-1))
    den = np.array([r - 1.0, c2 * (r + 1.0)])
    M = np.zeros((deg + 1, deg + 1))
    for j in range(deg + 1):          # c_j w^(deg - j) -> num^(deg-j) den^j
        col = np.ones(1)
        for _ in range(deg - j):
            col = np.convolve(col, num)
        for _ in range(j):
            col = np.convolve(col, den)
        M[deg + 1 - len(col):, j] = col
    return M / max(1.0, np.max(np.abs(M)))


def rotation(deg: int, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """``(cos, sin)`` vectors: ``D(e^{j phi} p)`` has coefficients ``c * (cos + j sin)``
    for ``D = c`` of degree ``deg`` and ``phi = asin(zeta)``.

    Parameters
    ----------
    deg : int
        Degree of ``D``.
    zeta : float
        The damping of the sector's edge.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
    """
    phi = float(np.arcsin(min(max(zeta, 0.0), 1.0)))
    k = np.arange(deg, -1, -1) * phi
    return np.cos(k), np.sin(k)


def sector_polynomial(c: ArrayLike, zeta: float) -> np.ndarray:
    """``E = Re(P)^2 + Im(P)^2`` with ``P(p) = c(e^{j phi} p)``, ``phi = asin(zeta)``:
    Hurwitz exactly when every root of ``c`` is damped more than ``zeta``.

    Parameters
    ----------
    c : array_like
        Real polynomial (highest power first).
    zeta : float

    Returns
    -------
    ndarray
        Degree ``2 deg c``.
    """
    c = np.asarray(c, float)
    cs, sn = rotation(len(c) - 1, zeta)
    re, im = c * cs, c * sn
    return np.convolve(re, re) + np.convolve(im, im)


def boundary_distance(c: ArrayLike, size: ArrayLike, roots: ArrayLike, zeta: float | None = None,
                      sigma: float | None = None, n_grid: int = 200) -> float:
    """Relative distance of ``c`` from a polynomial with a root on the region's boundary.

    ``min |c(b)| / sum_k size_k |b|^k`` over the boundary points ``b``: the ray of damping
    ``zeta`` (``b = x e^{j (pi - acos zeta)}``, ``x > 0``) and the line ``Re b = -sigma``,
    on a log grid over the roots' span plus the roots' own moduli.  Rounding while
    forming ``c`` perturbs coefficient ``k`` by at most ``n eps size_k``; when the distance
    exceeds that, no perturbation the float computation stands for moves a root across the
    boundary (zero exclusion), so the count of roots inside the region is resolved (as
    :func:`robrst.core.interval.distance_to_instability` does for the imaginary axis).

    Parameters
    ----------
    c, size : array_like
        The polynomial and the coefficient sizes of the terms that form it.
    roots : array_like
        Its roots (for the grid's span).
    zeta, sigma : float, optional
        The damping ray and the decay line (``None``: not part of the region).
    n_grid : int
        Points of the log grid.

    Returns
    -------
    float
    """
    c = np.trim_zeros(np.asarray(c, float), "f")
    size = np.asarray(size, float)[-len(c):] if len(size) >= len(c) else np.concatenate(
        [np.zeros(len(c) - len(size)), size])
    r = np.abs(np.asarray(roots, complex))
    r = r[(r > 0) & np.isfinite(r)]
    lo, hi = (r.min() / 100, r.max() * 100) if r.size else (1e-3, 1e3)
    x = np.concatenate([np.geomspace(lo, hi, n_grid), r])
    pts = []
    if zeta is not None:
        th = np.pi - np.arccos(min(max(zeta, 0.0), 1.0))
        pts.append(x * np.exp(1j * th))
    if sigma is not None:
        pts.append(-sigma + 1j * np.concatenate([[0.0], x]))
    if not pts:
        return np.inf
    b = np.concatenate(pts)
    w0 = float(np.exp(np.mean(np.log(r)))) if r.size else 1.0
    k = np.arange(len(c) - 1, -1, -1)
    cs, ss = c * w0 ** k, size * w0 ** k          # c(w0 q), size(w0 q): O(1) values
    q = b / w0
    with np.errstate(all="ignore"):
        num = np.abs(np.polyval(cs, q))
        den = np.polyval(ss, np.abs(q))
        d = num / den
    d = d[np.isfinite(d)]
    return float(np.min(d)) if d.size else 0.0
