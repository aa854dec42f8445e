"""Stability of a closed loop along a segment of plants, and how far rounding moves its roots.

Between two family members an explicit family interpolates coefficient by coefficient, so
the closed-loop polynomial is a *segment* ``Delta(lam) = (1 - lam) Da + lam Db``,
``lam`` in [0, 1].  If both ends are Hurwitz, a root leaves the left half-plane somewhere
on the segment exactly when (a) ``Da(jw) + lam E(jw) = 0`` for some ``w >= 0`` and ``lam``
in [0, 1], with ``E = Db - Da``, or (b) the leading coefficient vanishes (a root through
infinity).  (a) needs ``Da(jw) conj(E(jw))`` real: its imaginary part is an odd polynomial
in ``w``, whose real roots are the only candidate frequencies; ``lam`` follows in closed
form.  :func:`segment_crossing` performs this test (the "zero-crossing test" of the
closed-loop polynomial along the interpolation), in the scaled variable.

:func:`distance_to_instability` measures how far (relative to the terms that form it)
``A S + B R`` is from a polynomial with a root on the imaginary axis: when that is below
the rounding error of forming it, no double-precision computation resolves stability.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["SegmentCrossing", "segment_crossing", "distance_to_instability",
           "distance_to_instability_many", "hurwitz_guardian", "ParameterProof",
           "parameter_crossing"]

@dataclass(frozen=True)
class SegmentCrossing:
    """Result of :func:`segment_crossing`.

    Parameters
    ----------
    crossing : bool
        A root reaches the imaginary axis (or infinity) on the segment.
    lam : float, optional
        Where on the segment, in [0, 1] (``None``: no crossing).
    freq_rad_s : float, optional
        The crossing frequency [rad/s] (``inf`` for a degree drop; ``None``: none).
    kind : {"axis", "infinity"}, optional
        A root on the imaginary axis, or through infinity (the leading coefficient
        vanishes).
    """

    crossing: bool
    lam: float = None
    freq_rad_s: float = None
    kind: str = None


def _pad(a, n):
    return np.concatenate([np.zeros(n - len(a)), a])


def segment_crossing(Da: ArrayLike, Db: ArrayLike, tol: float = 1e-9) -> SegmentCrossing:
    """Does a root of ``(1 - lam) Da + lam Db`` reach the imaginary axis for ``lam`` in [0, 1]?

    Parameters
    ----------
    Da, Db : array_like
        Closed-loop polynomials at the segment's ends (highest power first).
    tol : float
        A candidate counts when ``lam`` lies in ``[-tol, 1 + tol]`` and
        ``|Da(jw) + lam E(jw)|`` vanishes to ``1e-6`` of the terms' size (conservative:
        a touching root counts as a crossing).

    Returns
    -------
    SegmentCrossing
        ``crossing=False`` when no root reaches the axis or infinity.
    """
    Da, Db = poly.trim(Da), poly.trim(Db)
    n = max(len(Da), len(Db))
    Da, Db = _pad(Da, n), _pad(Db, n)
    if Da[0] * Db[0] <= 0:     # linear in lam: the leading coefficient vanishes inside
        lam = Da[0] / (Da[0] - Db[0]) if Da[0] != Db[0] else 0.0
        return SegmentCrossing(True, float(lam), np.inf, "infinity")
    sc = poly.Scaling.natural(Da, Db)
    a, e = sc.apply(Da), sc.apply(Db - Da)
    big = max(np.max(np.abs(a)), 1e-300)
    a, e = a / big, e / big
    if not np.any(e):
        return SegmentCrossing(False)
    # F(s) = Da(s) E(-s); Im F(jw) = sum over odd k of f_k (-1)^((k-1)/2) w^k
    F = np.convolve(a, e * (-1.0) ** np.arange(n - 1, -1, -1))
    k = np.arange(len(F) - 1, -1, -1)
    r = np.where(k % 2 == 1, F * (-1.0) ** ((k - 1) // 2), 0.0)
    nz = np.flatnonzero(r)
    ws = [0.0]
    if nz.size and len(r) - nz[0] > 1:
        roots = np.roots(r[nz[0]:])
        ok = (np.abs(roots.imag) <= 0.05 * np.abs(roots)) & (roots.real > 0)
        ws += sorted(roots.real[ok])
    for w in ws:
        s = 1j * w
        av, ev = np.polyval(a, s), np.polyval(e, s)
        den = abs(ev) ** 2
        if den == 0:
            continue
        lam = -(av * np.conj(ev)).real / den
        if -tol <= lam <= 1 + tol:
            size = np.polyval(np.abs(a), w) + lam * np.polyval(np.abs(e), w)
            if abs(av + lam * ev) <= 1e-6 * size:
                return SegmentCrossing(True, float(min(max(lam, 0.0), 1.0)), float(w * sc.w0),
                                       "axis")
    return SegmentCrossing(False)


def distance_to_instability(parts: Sequence[tuple[ArrayLike, ArrayLike]], Delta: ArrayLike,
                            roots: ArrayLike, n_grid: int = 400) -> float:
    """Relative distance of ``Delta`` from a polynomial with a root on the imaginary axis.

    ``min_w |Delta(jw)| / sum_k size_k w^k`` with ``size`` the coefficient-wise
    ``sum |a| * |b|`` of the products forming ``Delta``.  Rounding while forming
    ``Delta`` perturbs coefficient ``k`` by at most ``n eps size_k``; when the distance
    exceeds that, every polynomial the float computation could stand for has the same
    number of right-half-plane roots (zero exclusion), so a Hurwitz verdict on the computed
    ``Delta`` holds for the exact one.  Evaluated on a log grid over the roots' span plus
    their imaginary parts, refined around the minimum.

    Parameters
    ----------
    parts : sequence of (array_like, array_like)
        The products whose sum is ``Delta`` (e.g. ``(A, S)`` and ``(B, R)``).
    Delta : array_like
        The closed-loop polynomial, highest power first.
    roots : array_like
        Roots of ``Delta`` [rad/s] (for the grid's span).
    n_grid : int
        Points of the log grid before the refinement.

    Returns
    -------
    float
        The relative distance (NaN when no grid point is finite).
    """
    return distance_to_instability_many([(parts, Delta, roots)], n_grid)[0]


def distance_to_instability_many(jobs: Sequence[tuple], n_grid: int = 400) -> list[float]:
    """:func:`distance_to_instability` of each ``(parts, Delta, roots)``, the polynomial
    evaluations of jobs of equal size vectorised (the same Horner steps per point:
    identical values).

    Parameters
    ----------
    jobs : sequence of (parts, Delta, roots)
        The arguments of :func:`distance_to_instability`, one tuple per polynomial.
    n_grid : int
        Points of the log grid before the refinement.

    Returns
    -------
    list of float
        One distance per job, in order.
    """
    out, groups = [None] * len(jobs), {}
    for i, (parts, Delta, roots) in enumerate(jobs):
        prods = [np.convolve(np.abs(poly.trim(a)), np.abs(poly.trim(b))) for a, b in parts]
        Delta = poly.trim(Delta)
        n = max([len(Delta)] + [len(c) for c in prods])
        size = np.zeros(n)
        for c in prods:
            size[n - len(c):] += c
        sc = poly.Scaling.natural(Delta)
        ds, ss = sc.apply(_pad(Delta, n)), sc.apply(size)
        roots = np.asarray(roots, complex)
        mags = np.abs(roots) / sc.w0
        mags = mags[mags > 0]
        lo, hi = (mags.min() / 100, mags.max() * 100) if mags.size else (1e-3, 1e3)
        groups.setdefault((n, len(roots)), []).append((i, ds, ss, lo, hi,
                                                       np.abs(roots.imag) / sc.w0))
    with np.errstate(all="ignore"):
        for items in groups.values():
            ds, ss = (np.array([it[k] for it in items]) for k in (1, 2))
            grid = np.geomspace([it[3] for it in items], [it[4] for it in items], n_grid,
                                axis=1)
            w = np.hstack([np.zeros((len(items), 1)), grid, [it[5] for it in items]])
            r = _rho(ds, ss, w)
            best, j = _nanmin(r)
            wj = w[np.arange(len(items)), j]
            fine = np.flatnonzero((j > 0) & (wj > 0))
            if fine.size:
                t = np.geomspace(wj[fine] / 1.05, wj[fine] * 1.05, 201, axis=1)
                best[fine] = np.fmin(best[fine], _nanmin(_rho(ds[fine], ss[fine], t))[0])
            for (i, *_), v in zip(items, best):
                out[i] = float(v)
    return out


def _nanmin(r):
    """Row minima of ``r`` ignoring NaN (NaN for an all-NaN row) and their indices."""
    ok = ~np.isnan(r)
    j = np.argmin(np.where(ok, r, np.inf), axis=1)
    v = r[np.arange(len(r)), j]
    return np.where(ok.any(axis=1), v, np.nan), j


def _rho(ds, ss, x):
    """``|ds(j x)| / ss(x)`` row by row (Horner, as ``numpy.polyval``)."""
    y, z = np.zeros(x.shape, complex), np.zeros(x.shape)
    for k in range(ds.shape[1]):
        y = y * (1j * x) + ds[:, k:k + 1]
        z = z * x + ss[:, k:k + 1]
    return np.abs(y) / z


def _chebyshev_interpolant(g):
    """Chebyshev coefficients of the polynomial of degree ``N - 1`` through ``g`` at the
    ``N`` first-kind nodes ``cos(pi (k + 1/2) / N)``: the discrete cosine transform
    (``c_j = (2 / N) sum_k g_k cos(pi j (k + 1/2) / N)``, ``c_0`` halved), exact where a
    least-squares fit solves an ``N x N`` system."""
    N = len(g)
    k = np.arange(N)
    c = (2.0 / N) * (np.cos(np.pi * np.outer(k, k + 0.5) / N) @ g)
    c[0] *= 0.5
    return c


def hurwitz_guardian(c: ArrayLike) -> float:
    """``a_n * H_{n-1}`` of ``c`` (highest power first, ``c[0] > 0``): zero exactly when
    a root lies on the imaginary axis (the guardian map of Hurwitz stability).

    ``H_{n-1}`` is the leading ``(n-1)``-th principal minor of the Hurwitz matrix.

    Parameters
    ----------
    c : array_like
        Polynomial coefficients, highest power first.

    Returns
    -------
    float
        The guardian's value.

    Examples
    --------
    >>> from robrst.core.interval import hurwitz_guardian
    >>> hurwitz_guardian([1.0, 0.0, 4.0])       # roots +-2j: on the axis
    0.0
    >>> hurwitz_guardian([1.0, 3.0, 2.0]) > 0   # roots -1, -2
    True
    """
    c = np.asarray(c, float)
    n = len(c) - 1
    if n < 1:
        return float(c[0])
    m = n - 1
    if not m:
        return float(c[-1])
    k = 2 * np.arange(m)[None, :] - np.arange(m)[:, None] + 1   # h_ij = a_(2j - i + 1)
    H = np.where((k >= 0) & (k <= n), c[np.clip(k, 0, n)], 0.0)
    return float(c[-1] * np.linalg.det(H))


@dataclass(frozen=True)
class ParameterProof:
    """Result of :func:`parameter_crossing`.

    Parameters
    ----------
    proved : bool
        No root reaches the imaginary axis on ``[a, b]``.
    candidate_T : float, optional
        When not proved: a root of the guardian inside, or a temperature where the
        degree or the sign of the leading coefficient changes (``None`` when the
        interpolation could not be validated).
    nodes : int
        Chebyshev nodes used.
    """

    proved: bool
    candidate_T: float = None
    nodes: int = 0


def parameter_crossing(delta_at: Callable[[float], ArrayLike], a: float, b: float, deg_T: int,
                       max_doublings: int = 3) -> ParameterProof:
    """Prove that ``delta_at(T)`` keeps its roots off the imaginary axis for ``T`` in [a, b].

    ``delta_at(T)`` must be a polynomial in ``s`` (degree ``n``, constant, positive leading
    coefficient) whose coefficients are polynomials in ``T`` of degree ``<= deg_T``.  The guardian
    ``a_n(T) H_{n-1}(T)`` (:func:`hurwitz_guardian`, in a fixed frequency scaling) is then
    a polynomial in ``T`` of degree ``<= n deg_T``: it is interpolated at Chebyshev nodes inside ``(a, b)``
    (never at the ends), the interpolant is validated at the midpoints between nodes
    (relative ``1e-7`` of its size; nodes are doubled otherwise) and its real roots in
    ``[a, b]`` are the only temperatures where a root can cross.  No root: proved (if
    ``delta_at`` is Hurwitz anywhere on ``[a, b]``, it is Hurwitz on all of it).

    Parameters
    ----------
    delta_at : callable
        Maps a temperature ``T`` to the closed-loop polynomial (in s, highest power first).
    a, b : float
        The interval [°C].
    deg_T : int
        Degree in ``T`` of the coefficients.
    max_doublings : int
        How often the nodes may be doubled before giving up.

    Returns
    -------
    ParameterProof
    """
    mid = delta_at(0.5 * (a + b))
    sc = poly.Scaling.natural(mid)
    # one normalisation for every T: the guardian of coefficients polynomial in T is a
    # polynomial in T (normalised at each T by its largest coefficient, it is not when
    # that coefficient varies with T: a leading coefficient that vanishes at an end)
    norm = float(np.max(np.abs(sc.apply(poly.trim(mid)))))
    n_s = len(poly.trim(mid))
    N = (n_s - 1) * int(deg_T) + 1
    for _ in range(max_doublings + 1):
        k = np.arange(N)
        x = np.cos(np.pi * (k + 0.5) / N)                    # Chebyshev nodes in (-1, 1)
        xm = np.cos(np.pi * (k[:-1] + 1.0) / N)              # midpoints between nodes
        g = []
        for t in np.concatenate([x, xm]):
            d = poly.trim(delta_at(0.5 * (a + b) + 0.5 * (b - a) * t))
            if len(d) != n_s or d[0] <= 0:
                return ParameterProof(False, float(0.5 * (a + b) + 0.5 * (b - a) * t), N)
            ds = sc.apply(d)
            g.append(hurwitz_guardian(ds / norm))
        g = np.array(g)
        coef = _chebyshev_interpolant(g[:N])
        fit = np.polynomial.chebyshev.chebval(xm, coef)
        size = np.max(np.abs(g))
        if size > 0 and np.max(np.abs(fit - g[N:])) <= 1e-7 * size:
            break
        N = 2 * N
    else:
        return ParameterProof(False, None, N)
    r = np.polynomial.chebyshev.chebroots(coef) if N > 1 else np.zeros(0)
    inside = r[(np.abs(r.imag) <= 1e-6) & (np.abs(r.real) <= 1 + 1e-9)].real
    if inside.size:
        return ParameterProof(False, float(0.5 * (a + b) + 0.5 * (b - a) * inside.min()), N)
    return ParameterProof(True, None, N)
