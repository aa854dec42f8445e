"""Step-response figures proved between the points of the grid: extremes and settling time.

The grid of :mod:`robrst.stepgrid` holds exact states at its points; between two points a
response is bounded, not sampled.  On an interval ``[a, a + h]`` of a continuous loop
``y(t) = C x(t) + d``, ``x' = A x + B``, so ``y'' = C A x'`` and ``x'(a + s) = e^{A s}
x'(a)``: with ``w(s) = y''(a + s)`` (which dies out, ``A`` being Hurwitz)

    ``w(s)**2 = -int_s^inf 2 w w' <= 2 ||w||_2 ||w'||_2``,

and ``||w||_2**2 = v^T G1 v``, ``||w'||_2**2 = v^T G2 v`` for ``v = x'(a)`` and the
observability Gramians ``G1, G2`` of ``(A, C A)`` and ``(A, C A**2)``
(:func:`gramians`).  So ``|y''| <= M = sqrt(2) (v^T G1 v v^T G2 v)**(1/4)`` at every time
after ``a``, and ``y`` is within ``M h**2 / 8`` of the chord between its end values, and
below ``y(a) + y'(a) s + M s**2 / 2`` and ``y(a + h) - y'(a + h) (h - s) + M (h - s)**2 /
2`` (:func:`interval_max` takes the least of the three bounds of the largest value).  A
sampled loop is the same with differences: ``x[k + 1] - x[k] = Ad**j (x[1] - x[0])``,
second differences bounded by the discrete Gramians of ``(Ad, C (Ad - I))`` and ``(Ad, C
(Ad - I)**2)`` (``s[j]**2 <= 2 ||s||_2 ||s[j + 1] - s[j]||_2``), and only the samples of
an interval count.  The bounds are output energies: a slow mode that ``y`` hardly sees
(a creep pair that the reference path cancels) hardly weighs in them, whatever the state.

:class:`StepBounds` proves the figures from these bounds: every interval whose bound could
reach past the answer found so far (a larger value; an exit from the band after the last
point found outside) is cut (:meth:`robrst.stepgrid.StepResponses.subdivide`, exact
states at the cuts), each piece with its own, much smaller bound, until none is left or
for ``LEVELS`` levels.  An extreme is the least upper bound so proved (within
``RESOLUTION`` of the largest value found), a settling time the first point back in the
band after the last point found outside (the sample after it, sampled); what the levels
could not decide is taken on the conservative side and marked unresolved.
"""

import numpy as np

__all__ = ["StepBounds", "Curvature", "gramians", "interval_max", "SETTLING_BAND",
           "EXTREME_SUB", "SETTLING_SUB", "REFINE_SUB", "LEVELS", "RESOLUTION"]

SETTLING_BAND = 0.02
EXTREME_SUB = 64       # first cut of an interval that may hold an extreme
SETTLING_SUB = 256     # first cut of an interval that may hold the last exit from the band
REFINE_SUB = 16        # further cuts
LEVELS = 6             # levels of cuts before a figure is left unresolved
MAX_PIECES = 100_000   # pieces of one level beyond which the cuts stop (unresolved)
RESOLUTION = 1e-8      # an extreme is proved to this fraction of the response's largest |y|
_TAIL = 1e-20          # Smith's doubling stops at ||Phi**m||_F**2 below this
_CHECK = 8             # grid points between two evaluations of the curvature bound


def gramians(A, rates, U):
    """Gramians ``G = int_0^inf e^{A^T t} u^T u e^{A t} dt`` of the rows ``u`` of ``U`` for
    stacked Hurwitz ``A``, by Smith's doubling on the Cayley transform ``(c - A)^{-1} (c +
    A)`` (``c`` the geometric mean of the extreme eigenvalue moduli ``rates``).

    Parameters
    ----------
    A : ndarray
        Shape ``(K, n, n)``.
    rates : ndarray
        Shape ``(K, n)``: the moduli of the eigenvalues of each ``A``.
    U : ndarray
        Shape ``(K, q, n)``.

    Returns
    -------
    G : ndarray
        Shape ``(K, q, n, n)``.
    slack : ndarray
        Shape ``(K, q)``: ``v^T G_exact v <= max(v^T G v, 0) + slack |v|**2`` covers the
        truncated doubling (``G_exact - G = Phi_m^T G_exact Phi_m``, ``Phi_m`` the last
        power) and the rounding of the sums and of the form (first order: ``4 n eps``
        times the norms of the terms, ``sum (1 + |Phi_i|_F**2) |G|_F``); ``inf`` where the
        doubling did not converge (``A`` not Hurwitz).
    """
    K, n = A.shape[0], A.shape[-1]
    c = np.sqrt(rates.min(axis=1) * rates.max(axis=1))[:, None, None]
    eye = np.eye(n)
    with np.errstate(all="ignore"):
        R = np.linalg.inv(c * eye - A)
        Phi = R @ (c * eye + A)
        W = U @ R
        G = 2 * c[:, None] * W[..., :, None] * W[..., None, :]    # Stein: Phi^T G Phi - G = -Q
        terms = np.ones(K)                # sum of (1 + |Phi_i|_F**2) over the doublings
        for _ in range(64):
            f2 = (Phi * Phi).sum(axis=(1, 2))
            if not np.any(f2 > _TAIL):   # (nan: diverged, left to ``ok``)
                break
            terms += 1 + f2
            G = G + np.swapaxes(Phi, 1, 2)[:, None] @ G @ Phi[:, None]
            Phi = Phi @ Phi
        rel = f2 / (1 - f2) + 4 * n * np.finfo(float).eps * terms
        slack = np.sqrt((G * G).sum(axis=(2, 3))) * rel[:, None]
    ok = f2 < 0.5
    return np.where(ok[:, None, None, None], G, 0.0), np.where(ok[:, None], slack, np.inf)


class Curvature:
    """Bounds of ``|y''|`` (continuous) or of the second differences (sampled) of each
    output of the loops of ``r``, valid at every time after the state they start from.

    Parameters
    ----------
    r : StepResponses
    """

    def __init__(self, r):
        n = r.A.shape[-1]
        D = r.A - np.eye(n) if r.discrete else r.A
        U1 = r.C @ D
        U = np.stack([U1, U1 @ D], axis=2).reshape(len(r.A), -1, n)   # per row: u1, u2
        if r.discrete:       # the discrete Gramians from the bilinear variable's Lyapunov
            ch = (2 / r.h_sample)[:, None, None]
            U = U @ (ch * np.eye(n) - r.generator) / np.sqrt(2 * ch)
        self.G, self.slack = gramians(r.generator, r.rates, U)

    def sup(self, ks, rows, V):
        """The bound of output ``rows[j]`` of loop ``ks[j]`` from its velocities ``V[j]``
        (:meth:`robrst.stepgrid.StepResponses.velocity`), shape ``(J, n, N)``: ``(J, N)``."""
        q = 2 * np.asarray(rows)
        v2 = (V * V).sum(axis=1)
        g = [np.maximum((V * (self.G[ks, q + i] @ V)).sum(axis=1), 0.0)
             + self.slack[ks, q + i][:, None] * v2 for i in (0, 1)]
        with np.errstate(invalid="ignore"):
            M = np.sqrt(2.0) * np.sqrt(np.sqrt(g[0] * g[1]))
        return np.where(np.isfinite(self.slack[ks, q] + self.slack[ks, q + 1])[:, None], M,
                        np.inf)


def interval_max(ya, yb, da, db, M, h, discrete):
    """Upper bound of ``y`` on intervals of length ``h`` from its end values ``ya, yb``,
    slopes ``da, db`` (``y'``; sampled: ``y[k + 1] - y[k]``) and curvature bound ``M``
    (sampled: only the samples, ``h`` of them after the first).

    Returns
    -------
    ndarray
        The least of the chord bound and the two one-sided Taylor bounds.
    """
    with np.errstate(invalid="ignore"):
        hi = np.maximum(ya, yb)
        if discrete:
            inner = h > 1
            chord = hi + np.where(inner, M * h * h / 8, 0.0)
            left = np.maximum(ya, ya + h * da + M * h * (h - 1) / 2)
            right = np.maximum(yb, yb - h * db + M * h * (h + 1) / 2)
            return np.where(inner, np.minimum(chord, np.minimum(left, right)), hi)
        chord = hi + M * h * h / 8
        left = np.maximum(ya, ya + h * da + M * h * h / 2)
        right = np.maximum(yb, yb - h * db + M * h * h / 2)
        return np.minimum(chord, np.minimum(left, right))


class StepBounds:
    """Extremes and settling times of the loops of ``r``, proved between the grid points.

    Parameters
    ----------
    r : StepResponses
    """

    def __init__(self, r):
        self.r = r
        self.curv = Curvature(r)
        self.all = np.arange(len(r.length))
        self.dY = r.slopes(self.all, r.X)
        self.h = np.diff(r.t, axis=1)
        L = r.t.shape[1]
        self.valid = np.arange(L - 1)[None, :] < r.length[:, None] - 1
        with np.errstate(over="ignore"):
            self.h2 = self.h * self.h / 8                 # the chord bound per unit curvature
        if r.discrete:
            self.h2[self.h <= 1] = 0.0
        self.V = r.velocity(self.all, r.X[:, :, ::_CHECK])
        self.M = {}         # per output row: the curvature bound on each grid interval
        # no bound without a Hurwitz matrix: nothing is proved for such a loop
        self.bad = ~np.isfinite(self.curv.slack).all(axis=1)

    def _grid_curvature(self, row):
        """The curvature bound of output ``row`` on each grid interval: the one at the last
        checkpoint before it (a bound holds at every later time)."""
        if row not in self.M:
            Mc = self.curv.sup(self.all, np.full(len(self.all), row), self.V)
            self.M[row] = np.repeat(Mc, _CHECK, axis=1)[:, :self.h.shape[1]]
        return self.M[row]

    def _curvature_at(self, k, idx, rows):
        """The curvature bound of outputs ``rows`` of loops ``k`` at grid points ``idx``."""
        V = self.r.velocity(k, self.r.X[k, :, idx][:, :, None])
        return self.curv.sup(k, rows, V)[:, 0]

    def extremes(self, requests):
        """Largest ``sign * y`` of output ``row`` of each loop, for several ``(row, sign)``.

        Parameters
        ----------
        requests : sequence of (int, array_like)
            ``(row, sign)``: ``sign`` is ``+1`` or ``-1``, one per loop (or one for all).

        Returns
        -------
        list of (ndarray, ndarray, ndarray, ndarray)
            Per request, each of shape ``(K,)``: the proved upper bound of ``sign * y``,
            when its largest sample is (scaled time or samples; the vertex of a parabola
            through it and its neighbours, continuous), that sample (a lower bound) and
            whether the bound is within ``RESOLUTION`` (else it is the conservative one).
        """
        r = self.r
        K, Q = len(self.all), len(requests)
        rows = np.array([row for row, _ in requests])
        signs = np.empty((Q, K))
        for q, (_, sg) in enumerate(requests):
            signs[q] = sg
        sY = signs[:, :, None] * r.Y[:, rows].transpose(1, 0, 2)      # (Q, K, L)
        sD = signs[:, :, None] * self.dY[:, rows].transpose(1, 0, 2)
        i = np.argmax(sY, axis=2)
        qq, kk = np.arange(Q)[:, None], self.all[None, :]
        best, when = sY[qq, kk, i], r.t[kk, i]
        tol = RESOLUTION * np.abs(r.Y[:, rows]).max(axis=2).T
        # the chord bounds first (checkpoint curvatures), then the candidates' own bounds
        chord = np.maximum(sY[..., :-1], sY[..., 1:]) + np.stack(
            [self._grid_curvature(row) for row in rows]) * self.h2
        chord = np.where(self.valid, chord, -np.inf)
        cand = (chord > (best + tol)[..., None]) & ~self.bad[:, None]
        upper = np.maximum(best, np.where(cand, -np.inf, chord).max(axis=2))
        q, k, idx = np.nonzero(cand)
        m = self._curvature_at(k, idx, rows[q])
        U = interval_max(sY[q, k, idx], sY[q, k, idx + 1], sD[q, k, idx], sD[q, k, idx + 1], m,
                         self.h[k, idx], r.discrete)
        o = U > (best + tol)[q, k]
        np.maximum.at(upper, (q[~o], k[~o]), U[~o])
        q, k, idx = q[o], k[o], idx[o]
        iv, Uo, m = r.intervals(k, idx), U[o], m[o]
        for level in range(LEVELS):
            if not len(q) or len(q) * EXTREME_SUB > MAX_PIECES:
                break
            n = np.full(len(q), EXTREME_SUB if level == 0 else REFINE_SUB)
            t, X, count = r.subdivide(iv, n)
            sg = signs[q, k][:, None]
            y, d = sg * r.outputs(k, X, rows[q]), sg * r.slopes(k, X, rows[q])
            self._improve(best, when, q, k, t, y)
            # (a curvature bound from a point holds after it)
            Us = interval_max(y[:, :-1], y[:, 1:], d[:, :-1], d[:, 1:], m[:, None],
                              np.diff(t, axis=1), r.discrete)
            Us = np.where(np.arange(t.shape[1] - 1)[None, :] < count[:, None], Us, -np.inf)
            o = Us > (best + tol)[q, k][:, None]
            np.maximum.at(upper, (q, k), np.where(o, -np.inf, Us).max(axis=1))
            j, p = np.nonzero(o)
            iv, Uo, q, k, m = r.pieces(iv, n, t, X, j, p), Us[j, p], q[j], k[j], m[j]
        resolved = np.ones((Q, K), dtype=bool)
        np.maximum.at(upper, (q, k), Uo)                  # undecided: the conservative side
        resolved[q, k] = False
        upper[:, self.bad], resolved[:, self.bad] = np.inf, False
        return list(zip(upper, when, best, resolved))

    def _improve(self, best, when, q, k, t, y):
        """Raise ``best`` (and ``when``) of requests ``q`` of loops ``k`` by the largest of
        the values ``y`` at times ``t`` of each refined interval."""
        J = np.arange(len(q))
        p = np.argmax(y, axis=1)
        v, tv = y[J, p], t[J, p]
        if not self.r.discrete:                    # vertex of the parabola
            pm, pp = np.maximum(p - 1, 0), np.minimum(p + 1, y.shape[1] - 1)
            a, c = y[J, pm], y[J, pp]
            den = a - 2 * v + c
            vert = (p > 0) & (p < y.shape[1] - 1) & (den < 0)
            sden = np.where(vert, den, -1.0)
            tv = np.where(vert, tv + 0.5 * (a - c) / sden * (t[J, pp] - t[J, p]), tv)
        better = np.flatnonzero(v > best[q, k])
        if len(better):
            order = better[np.lexsort((-v[better], k[better], q[better]))]
            _, first = np.unique(q[order] * len(self.all) + k[order], return_index=True)
            sel = order[first]                         # the largest of each (q, k)
            best[q[sel], k[sel]], when[q[sel], k[sel]] = v[sel], tv[sel]

    def settling(self, row, final):
        """Last time ``|y - final| > 2 % |final|`` of output ``row`` of each loop: the first
        point back in the band after the last point found outside (0 if never).

        Parameters
        ----------
        row : int
        final : array_like
            Shape ``(K,)``: the final values.

        Returns
        -------
        upper, lower : ndarray
            Shape ``(K,)`` (scaled time or samples): the settling time proved (never
            early) and the last time found outside the band (never late).
        resolved : ndarray
            Shape ``(K,)``: false where ``LEVELS`` levels of cuts did not decide whether
            the response leaves the band again (``upper`` is then the end of the latest
            undecided piece).
        """
        r = self.r
        K, L = r.t.shape
        final = np.asarray(final, float)
        tol = SETTLING_BAND * np.abs(final)
        e, D = r.Y[:, row] - final[:, None], self.dY[:, row]
        out = np.abs(e) > tol[:, None]
        last = L - 1 - np.argmax(out[:, ::-1], axis=1)   # (the padding repeats the last point)
        some = out[self.all, last]
        last = np.where(some, last, -1)
        lower = np.where(some, r.t[self.all, np.maximum(last, 0)], -np.inf)
        upper = np.where(some, lower, 0.0)                # out at the end: the end
        col = np.arange(L - 1)[None, :]
        cross = self.valid & (col == last[:, None]) & ~self.bad[:, None]   # from the last
        # point found outside
        if r.discrete:                                    # one sample on: back in there
            one = cross & (self.h <= 1)
            upper = np.where(one.any(axis=1), r.t[self.all, np.minimum(last + 1, L - 1)], upper)
            cross &= ~one
        ae = np.abs(e)                # the chord bounds first, then the candidates' own
        cand = (np.maximum(ae[:, :-1], ae[:, 1:]) + self._grid_curvature(row) * self.h2
                > tol[:, None]) & self.valid & (col > last[:, None]) & ~self.bad[:, None]
        k, idx = np.nonzero(cand)
        m = self._curvature_at(k, idx, np.full(len(k), row))
        Ud = self._band_excess(e[k, idx], D[k, idx], m, self.h[k, idx], tol[k], e[k, idx + 1],
                               D[k, idx + 1])
        k, idx, m = k[Ud > 0], idx[Ud > 0], m[Ud > 0]
        kc, ic = np.nonzero(cross)
        k, idx = np.concatenate([kc, k]), np.concatenate([ic, idx])
        m = np.concatenate([self._curvature_at(kc, ic, np.full(len(kc), row)), m])
        iv, crossing = r.intervals(k, idx), np.arange(len(k)) < len(kc)
        for _ in range(LEVELS):
            if not len(k) or len(k) * SETTLING_SUB > MAX_PIECES:
                break
            # the piece of the last exit to 1/SETTLING_SUB of its segment's step (sampled:
            # to the sample), the others to decide
            n = np.where(crossing, SETTLING_SUB if r.discrete
                         else np.maximum(SETTLING_SUB // iv.div, 2), REFINE_SUB)
            t, X, count = r.subdivide(iv, n)
            e = r.outputs(k, X, np.full(len(k), row)) - final[k][:, None]
            d = r.slopes(k, X, np.full(len(k), row))
            np.maximum.at(lower, k, np.where(np.abs(e) > tol[k][:, None], t, -np.inf).max(axis=1))
            h = np.diff(t, axis=1)
            Ud = self._band_excess(e[:, :-1], d[:, :-1], m[:, None], h, tol[k][:, None],
                                   e[:, 1:], d[:, 1:])
            t0, at = t[:, :-1], lower[k][:, None]
            keep = (np.arange(h.shape[1])[None, :] < count[:, None]) & (t0 >= at)
            cross = keep & (t0 == at)             # from the last point found outside
            done = cross & ((h <= 1) if r.discrete else (iv.div * n >= SETTLING_SUB)[:, None])
            j, p = np.nonzero(done)
            upper[k[j]] = t[j, p + 1]
            j, p = np.nonzero((cross & ~done) | (keep & ~cross & (Ud > 0)))
            crossing = cross[j, p]
            iv, k, m = r.pieces(iv, n, t, X, j, p), k[j], m[j]
        resolved = np.ones(K, dtype=bool)
        np.maximum.at(upper, k, iv.t0 + iv.h)             # undecided: the conservative side
        resolved[k] = False
        upper[self.bad], resolved[self.bad] = np.inf, False
        return upper, np.maximum(lower, 0.0), resolved

    def _band_excess(self, e, D, M, h, tol, eb, Db):
        """Upper bound of ``|y - final| - tol`` on intervals from the deviations ``e, eb``
        and slopes ``D, Db`` at their ends."""
        up = interval_max(e, eb, D, Db, M, h, self.r.discrete)
        down = interval_max(-e, -eb, -D, -Db, M, h, self.r.discrete)
        return np.maximum(up, down) - tol
