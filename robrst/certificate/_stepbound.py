"""Step-response figures proved between the points of the grid: extremes and settling time.

The grid of :mod:`robrst.certificate._stepgrid` holds exact states at its points; between two points a
response is bounded, not sampled (:mod:`robrst.certificate._stepcurvature`: a bound of ``|y''|``, or of
the second differences of a sampled loop, at every time after a state, from output
energies; and the largest value on an interval from its ends and that bound).

:class:`StepBounds` proves the figures from these bounds: every interval whose bound could
reach past the answer found so far (a larger value; an exit from the band after the last
point found outside) is cut (:meth:`robrst.certificate._stepgrid.StepResponses.subdivide`, exact
states at the cuts), each piece with its own, much smaller bound, until none is left or
for ``LEVELS`` levels.  A continuous interval is cut in ``EXTREME_SUB`` (then
``REFINE_SUB``) pieces; a sampled one in strides of a power of 2 samples small enough for
every piece's bound to decide.  An extreme is the least upper bound so proved (within
``RESOLUTION`` of the largest ``|y|``), a settling time the first point back in the band
after the last point found outside (the sample after it, sampled; continuous, to
``1/SETTLING_SUB`` of a grid step); what the levels could not decide is taken on the
conservative side and marked unresolved.
"""

import numpy as np

from robrst.certificate._stepcurvature import Curvature, interval_max

__all__ = ["StepBounds", "SETTLING_BAND", "EXTREME_SUB", "SETTLING_SUB", "REFINE_SUB",
           "LEVELS", "MAX_PIECES", "RESOLUTION", "MAX_MORE"]

SETTLING_BAND = 0.02
EXTREME_SUB = 64       # first cut of an interval that may hold an extreme
SETTLING_SUB = 256     # first cut of an interval that may hold the last exit from the band
REFINE_SUB = 16        # further cuts
LEVELS = 6             # levels of cuts before a figure is left unresolved
MAX_PIECES = 100_000   # pieces of one level beyond which the cuts stop (unresolved)
RESOLUTION = 5e-9      # an extreme is proved to this fraction of the response's largest |y|
MAX_MORE = 48.0        # most e-folds a grid is extended by for the response after it
_CHECK = 8             # grid points between two evaluations of the curvature bound


def _starts(first):
    """The points of :meth:`robrst.certificate._stepgrid.StepResponses.subdivide` (interval starts
    ``first``) that begin a piece: every point but the last of each interval."""
    last = np.zeros(first[-1], dtype=bool)
    last[first[1:] - 1] = True
    return np.flatnonzero(~last)


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
        self.final, self.after = self.tail()
        # per loop: the e-folds more its grid needs for a figure the tail left undecided
        self.more = np.zeros(len(self.all))

    def tail(self):
        """The final value of every output of every loop and a bound of ``|y - final|`` at
        every time after the grid's last point: what the response does once the grid stops.

        From the last state's deviation ``x - x_inf`` from the steady state (``D x_inf + B
        = 0``, ``D = A``, or ``Ad - I`` sampled), the Gramian bound of
        :class:`robrst.certificate._stepcurvature.Curvature` (``first = 0``): a proof,
        whatever the slow modes' residues, with a first-order rounding slack (the solve
        for ``x_inf``: its residual's correction, twice; the sums of ``C x + d``).

        Returns
        -------
        final, after : ndarray
            Shape ``(K, r)``: ``C x_inf + d`` and the bound (``inf`` for a loop whose
            matrix is not Hurwitz).
        """
        r = self.r
        K, n = r.A.shape[0], r.A.shape[-1]
        D = r.A - np.eye(n) if r.discrete else r.A
        eps = np.finfo(float).eps
        with np.errstate(all="ignore"):
            x_inf = np.linalg.solve(D, -r.B)                        # (K, n, 1)
            fix = np.linalg.solve(D, D @ x_inf + r.B)               # its error, first order
            last = r.X[self.all, :, r.length - 1][:, :, None]       # (K, n, 1)
            bound = Curvature(r, first=0).sup_all(last - x_inf)[..., 0]      # (K, r)
            final = (r.C @ x_inf)[..., 0] + r.d
            aC = np.abs(r.C)
            slack = (2 * (aC @ np.abs(fix))[..., 0]
                     + 4 * n * eps * ((aC @ (np.abs(x_inf) + np.abs(last)))[..., 0]
                                      + np.abs(r.d)))
            after = bound + slack
        after = np.where(np.isfinite(after), after, np.inf)
        after[self.bad] = np.inf
        return final, after

    def _grid_curvature(self, row):
        """The curvature bound of output ``row`` on each grid interval: the one at the last
        checkpoint before it (a bound holds at every later time)."""
        if not self.M:                       # every output at once
            Mc = self.curv.sup_all(self.V)
            self.M.update(enumerate(np.repeat(Mc, _CHECK, axis=2)[:, :, :self.h.shape[1]]
                                    .transpose(1, 0, 2)))
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
            ``(row, sign)``: ``sign`` is ``+1`` or ``-1`` (or ``0``: the largest ``|y|``),
            one per loop (or one for all).

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
        absolute = signs == 0
        sgn = np.where(absolute, 1.0, signs)[:, :, None]
        sV = sgn * r.Y[:, rows].transpose(1, 0, 2)                    # (Q, K, L), signed
        sD = sgn * self.dY[:, rows].transpose(1, 0, 2)
        sY = np.where(absolute[:, :, None], np.abs(sV), sV)          # what is maximised
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
        U = self._upper(sV[q, k, idx], sV[q, k, idx + 1], sD[q, k, idx], sD[q, k, idx + 1], m,
                        self.h[k, idx], absolute[q, k])
        o = U > (best + tol)[q, k]
        np.maximum.at(upper, (q[~o], k[~o]), U[~o])
        q, k, idx = q[o], k[o], idx[o]
        iv, Uo, m = r.intervals(k, idx), U[o], m[o]
        hi = np.maximum(sY[q, k, idx], sY[q, k, idx + 1])
        for level in range(LEVELS):
            if not len(q):
                break
            cut = self._cuts(iv, EXTREME_SUB if level == 0 else REFINE_SUB,
                             best[q, k] + tol[q, k] - hi, m)
            if self._pieces(iv, cut) > MAX_PIECES:
                break
            pts = r.subdivide(iv, cut, rows[q])
            t, first = pts.t, pts.first
            own = np.repeat(np.arange(len(q)), np.diff(first))     # the interval of each point
            ab = absolute[q, k]
            sg = np.where(ab, 1.0, signs[q, k])[own]
            v, d = sg * pts.y, sg * pts.dy
            y = np.where(ab[own], np.abs(v), v)
            self._improve(best, when, q, k, t, y, first)
            a = _starts(first)                   # the pieces: from each point but the last
            j = own[a]
            # (a curvature bound from a point holds after it)
            Us = self._upper(v[a], v[a + 1], d[a], d[a + 1], m[j], t[a + 1] - t[a], ab[j])
            o = Us > (best + tol)[q[j], k[j]]
            np.maximum.at(upper, (q[j[~o]], k[j[~o]]), Us[~o])
            a, j = a[o], j[o]
            iv, Uo, q, k, m = r.pieces(iv, pts, a, j), Us[o], q[j], k[j], m[j]
            hi = np.maximum(y[a], y[a + 1])
        resolved = np.ones((Q, K), dtype=bool)
        np.maximum.at(upper, (q, k), Uo)                  # undecided: the conservative side
        resolved[q, k] = False
        # after the grid: the response tends to its final value (a lower bound of the
        # supremum, approached at the end) and stays within the tail bound of it
        fin = sgn[..., 0] * self.final[:, rows].T
        fin = np.where(absolute, np.abs(fin), fin)
        top = fin + self.after[:, rows].T
        end = r.t[self.all, r.length - 1]
        rises = fin > best
        best = np.where(rises, fin, best)
        when = np.where(rises, end[None, :], when)
        beyond = top > upper
        upper = np.maximum(upper, top)
        short = beyond & (upper > best + tol) & ~self.bad[None, :]
        resolved &= ~short
        self._need(short, self.after[:, rows].T, best + tol - fin)
        upper[:, self.bad], resolved[:, self.bad] = np.inf, False
        return list(zip(upper, when, best, resolved))

    def _need(self, short, after, room):
        """Record in :attr:`more` the e-folds of the slowest mode that would bring the tail
        bound ``after`` below ``room`` where ``short`` (shape ``(Q, K)``): ``ln(after /
        room)`` and one more."""
        with np.errstate(divide="ignore", invalid="ignore"):
            need = np.where(short, np.log(after / np.maximum(room, 1e-300)) + 1.0, 0.0)
        need = np.where(np.isfinite(need), need, MAX_MORE)
        self.more = np.maximum(self.more, need.max(axis=0))

    def _upper(self, ya, yb, da, db, M, h, absolute):
        """:func:`robrst.certificate._stepcurvature.interval_max` of ``y``, or of ``|y|`` where
        ``absolute``."""
        U = interval_max(ya, yb, da, db, M, h, self.r.discrete)
        if absolute.any():
            low = interval_max(-ya, -yb, -da, -db, M, h, self.r.discrete)
            U = np.where(absolute, np.maximum(U, low), U)
        return U

    def _improve(self, best, when, q, k, t, y, first):
        """Raise ``best`` (and ``when``) of requests ``q`` of loops ``k`` by the largest of
        the values ``y`` at times ``t`` of each refined interval (its points from
        ``first``)."""
        top = np.maximum.reduceat(y, first[:-1])
        own = np.repeat(np.arange(len(q)), np.diff(first))
        hit = np.flatnonzero(y == top[own])
        _, at = np.unique(own[hit], return_index=True)
        p = hit[at]                                # the first largest point of each
        v, tv = y[p], t[p]
        if not self.r.discrete:                    # vertex of the parabola
            inner = (p > first[:-1]) & (p < first[1:] - 1)
            pm, pp = np.where(inner, p - 1, p), np.where(inner, p + 1, p)
            a, c = y[pm], y[pp]
            den = a - 2 * v + c
            vert = inner & (den < 0)
            sden = np.where(vert, den, -1.0)
            tv = np.where(vert, tv + 0.5 * (a - c) / sden * (t[pp] - t[p]), tv)
        better = np.flatnonzero(v > best[q, k])
        if len(better):
            order = better[np.lexsort((-v[better], k[better], q[better]))]
            _, one = np.unique(q[order] * len(self.all) + k[order], return_index=True)
            sel = order[one]                           # the largest of each (q, k)
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
        gap = tol[k] - np.maximum(np.abs(e[k, idx]), np.abs(e[k, idx + 1]))
        for _ in range(LEVELS):
            if not len(k):
                break
            # the piece of the last exit to 1/SETTLING_SUB of its segment's step (sampled:
            # to the sample), the others to decide
            cut = np.where(crossing, self._exit_cuts(iv), self._cuts(iv, REFINE_SUB, gap, m))
            if self._pieces(iv, cut) > MAX_PIECES:
                break
            pts = r.subdivide(iv, cut, np.full(len(k), row))
            t, first, d = pts.t, pts.first, pts.dy
            own = np.repeat(np.arange(len(k)), np.diff(first))
            kp = k[own]
            e = pts.y - final[kp]
            out = np.abs(e) > tol[kp]
            np.maximum.at(lower, kp[out], t[out])
            a = _starts(first)
            j = own[a]
            h = t[a + 1] - t[a]
            Ud = self._band_excess(e[a], d[a], m[j], h, tol[k[j]], e[a + 1], d[a + 1])
            keep = t[a] >= lower[k[j]]
            cross = keep & (t[a] == lower[k[j]])  # from the last point found outside
            fine = (h <= 1) if r.discrete else \
                (SETTLING_SUB * h <= r.seg_h[iv.seg[j]] * (1 + 1e-9))
            done = cross & fine
            upper[k[j[done]]] = t[a[done] + 1]
            o = (cross & ~done) | (keep & ~cross & (Ud > 0))
            a, j = a[o], j[o]
            crossing = cross[o]
            gap = tol[k[j]] - np.maximum(np.abs(e[a]), np.abs(e[a + 1]))
            iv, k, m = r.pieces(iv, pts, a, j), k[j], m[j]
        resolved = np.ones(K, dtype=bool)
        np.maximum.at(upper, k, iv.t0 + iv.h)             # undecided: the conservative side
        resolved[k] = False
        # after the grid: back in the band for good unless the tail bound could leave it
        room = tol - np.abs(self.final[:, row] - final)
        leaves = self.after[:, row] > room
        upper[leaves], resolved[leaves] = np.inf, False
        self._need(leaves[None, :] & ~self.bad[None, :], self.after[None, :, row], room[None, :])
        upper[self.bad], resolved[self.bad] = np.inf, False
        return upper, np.maximum(lower, 0.0), resolved

    def _cuts(self, iv, n, gap, M):
        """How :meth:`robrst.certificate._stepgrid.StepResponses.subdivide` cuts intervals ``iv``:
        continuous, in ``n`` pieces; sampled, in the largest strides of a power of 2 whose
        chord bound (curvature bound ``M``) is below ``gap`` (at least 2 pieces)."""
        if not self.r.discrete:
            return np.full(len(iv.h), n)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.sqrt(8 * np.maximum(gap, 0) / M)
        s = np.clip(np.where(np.isnan(s), 1.0, s), 1.0, iv.h / 2)
        return (2 ** np.floor(np.log2(s))).astype(np.int64)

    def _pieces(self, iv, cut):
        """How many pieces the cuts ``cut`` of intervals ``iv`` make."""
        return int(np.ceil(iv.h / cut).sum()) if self.r.discrete else int(np.sum(cut))

    def _exit_cuts(self, iv):
        """The cuts of an interval from the last point found outside the band: continuous,
        to ``1/SETTLING_SUB`` of its segment's step; sampled, ``SETTLING_SUB`` strides at
        most (a power of 2; 1 once short enough)."""
        if not self.r.discrete:
            return np.maximum(np.rint(SETTLING_SUB * iv.h / self.r.seg_h[iv.seg]), 2)
        s = np.maximum(iv.h / SETTLING_SUB, 1.0)
        return (2 ** np.floor(np.log2(s))).astype(np.int64)

    def _band_excess(self, e, D, M, h, tol, eb, Db):
        """Upper bound of ``|y - final| - tol`` on intervals from the deviations ``e, eb``
        and slopes ``D, Db`` at their ends."""
        up = interval_max(e, eb, D, Db, M, h, self.r.discrete)
        down = interval_max(-e, -eb, -D, -Db, M, h, self.r.discrete)
        return np.maximum(up, down) - tol
