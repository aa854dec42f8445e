"""Exact step responses of many loops at once: the numerical kernel of :mod:`robrst.timespec`.

:class:`StepResponses` takes the stacked realisations of ``K`` loops of one degree (one
``A, B`` per loop, a row of ``C`` and an entry of ``d`` per output, from
:func:`robrst.lti.companion_outputs_many`) and computes their step responses on grids
that follow each loop's own modes (:func:`segments`).  The numerical stages are stacked
numpy or LAPACK calls for the ``K`` loops: eigenvalues, zero-order-hold steps
(:func:`robrst.lti.zoh_matrices`; the sampled loop's strides by powers), propagation by
repeated doubling (:mod:`robrst.doubling`: ``x[k + m] = Phi**m x[k] + S_m``),
and the refinements of the extremes and of the settling time between grid points; a
single loop is the case ``K = 1``.  Each loop's grid, steps and refinements are those it
would have alone, and so are its figures (to the rounding of a matrix product).

The grids of the loops differ in length; the stacked arrays are padded by repeating
each loop's last point (a repeated last point changes neither a first ``argmax`` nor a
last exit from a band, which is all that is read from them).
"""

import math

import numpy as np

from robrst import lti
from robrst.doubling import power, propagate

__all__ = ["StepResponses", "segments", "bilinear", "SETTLING_BAND", "POINTS_PER_RAD",
           "DECAY", "MAX_POINTS"]

SETTLING_BAND = 0.02
POINTS_PER_RAD = 4.0       # grid points per radian of the fastest live mode
DECAY = 16.0               # a mode is dead after exp(-16) of its initial size
MAX_POINTS = 400_000
EXTREME_SUB = 64           # sub-steps of an interval around a largest sample
SETTLING_SUB = 256         # sub-steps of the interval of the last exit from the band


def bilinear(A, B, C, d, h):
    """Discrete ``(Ad, Bd, Cd, dd)`` with ``G_d(z) = G(2/h (z - 1)/(z + 1))``, stacked.

    Parameters
    ----------
    A, B, C, d : ndarray
        Shapes ``(K, n, n)``, ``(K, n, 1)``, ``(K, r, n)``, ``(K, r)`` (scaled; one row of
        ``C`` and one ``d`` per output).
    h : ndarray
        Shape ``(K,)``: each loop's step in its scaled time.

    Returns
    -------
    Ad, Bd, Cd, dd
        Of the shapes of ``A, B, C, d``.
    """
    n = A.shape[-1]
    h = np.asarray(h, float)[:, None, None]
    M = np.eye(n) - A * (h / 2)
    Ad = np.linalg.solve(M, np.eye(n) + A * (h / 2))
    Bd = np.linalg.solve(M, B) * h
    Cd = np.swapaxes(np.linalg.solve(np.swapaxes(M, 1, 2), np.swapaxes(C, 1, 2)), 1, 2)
    return Ad, Bd, Cd, d + (C @ Bd)[..., 0] / 2


def segments(decay, speed, unit=None):
    """``[(t_end, step), ...]``: per stretch of time, a step resolving every live mode.

    Parameters
    ----------
    decay, speed : ndarray
        Each mode's decay rate and ``|log|`` rate (per time unit); a mode is live until
        ``DECAY / decay``.
    unit : float, optional
        With ``unit`` (discrete time) steps are whole multiples of it.

    Returns
    -------
    list of (float, float)
    """
    life = (DECAY / np.maximum(decay, 1e-300)).tolist()
    speed = speed.tolist()               # a handful of modes: plain floats
    merged = []
    for t in sorted(set(life)):          # merge ends within a factor 4 (fewer segments)
        if merged and t < 4 * merged[-1]:
            merged[-1] = t
        else:
            merged.append(t)
    out, t0 = [], 0.0
    for t1 in merged:
        alive = t0 * (1 + 1e-12)
        fast = max(v for life_i, v in zip(life, speed) if life_i > alive)
        h = min(1.0 / (POINTS_PER_RAD * fast), (t1 - t0) / 16)
        if unit is not None:
            h = max(1.0, float(math.floor(h)))
            t1 = float(math.ceil(t1))
        out.append((t1, h))
        t0 = t1
    total = sum((t1 - ta) / h for (t1, h), ta in zip(out, [0.0] + [t for t, _ in out[:-1]]))
    if total > MAX_POINTS:             # keep the cost bounded: coarser, uniformly
        f = total / MAX_POINTS
        out = [(t1, h * f if unit is None else float(math.ceil(h * f))) for t1, h in out]
    return out


class StepResponses:
    """Exact step responses of ``K`` loops on mode-adapted grids, refinable between points.

    Continuous: scaled time, steps by the exact ZOH of :mod:`robrst.lti`; discrete
    (``h_sample``): samples of the bilinear map of the same realisation, strides of whole
    samples.  After construction ``t`` ``(K, L)`` holds the grids and ``Y`` ``(K, r, L)``
    the outputs (padded, see the module doc), ``length`` ``(K,)`` the true lengths.

    Parameters
    ----------
    A, B, C, d : ndarray
        Stacked scaled realisations, shapes ``(K, n, n)``, ``(K, n, 1)``, ``(K, r, n)``,
        ``(K, r)``.
    h_sample : array_like, optional
        Shape ``(K,)``: each loop's sampling period in its scaled time (discrete loops).
    """

    def __init__(self, A, B, C, d, h_sample=None):
        self.discrete = h_sample is not None
        if self.discrete:
            A, B, C, d = bilinear(A, B, C, d, h_sample)
            logz = np.log(np.linalg.eigvals(A).astype(complex))
            segs = [segments(-lz.real, np.abs(lz), unit=1) for lz in logz]
        else:
            lam = np.linalg.eigvals(A)
            segs = [segments(-lm.real, np.abs(lm)) for lm in lam]
        self.A, self.B, self.C, self.d = A, B, C, d
        K, n = A.shape[0], A.shape[-1]
        # the segments of all loops in one table: loop, steps, step, start time, first
        # point; the segments of each rank (first, second, ... of their loop)
        seg, ranks, lengths = [], [], []
        for k, sk in enumerate(segs):
            t0, p = 0.0, 0
            for j, (t1, h) in enumerate(sk):
                m = max(1, math.ceil((t1 - t0) / h))
                if not self.discrete:
                    h = (t1 - t0) / m
                if j == len(ranks):
                    ranks.append([])
                ranks[j].append(len(seg))
                seg.append((k, m, h, t0, p))
                t0, p = t0 + m * h, p + m
            lengths.append(p + 1)
        self.seg_k, seg_m, self.seg_h, seg_t0, self.seg_p = (np.array(c) for c in zip(*seg))
        self.length, L = np.array(lengths), max(lengths)
        self.seg_of = np.zeros((K, L - 1), dtype=int)    # the segment of each interval
        Phi, G = self._steps(self.seg_k, self.seg_h)
        X, x = np.zeros((K, n, L)), np.zeros((K, n))
        for sj in ranks:                                  # the j-th segments of all loops
            ks = self.seg_k[sj]
            Xj = propagate(Phi[sj], G[sj], x[ks], int(seg_m[sj].max()))
            for i, s in enumerate(sj):
                k, m, p = seg[s][0], seg[s][1], seg[s][4]
                X[k, :, p + 1:p + 1 + m] = Xj[i, :, 1:m + 1]
                self.seg_of[k, p:p + m] = s
            x[ks] = Xj[np.arange(len(sj)), :, seg_m[sj]]
        for k, n_k in enumerate(lengths):                 # pad: repeat the last point
            if n_k < L:
                X[k, :, n_k:] = X[k, :, n_k - 1:n_k]
        col = np.minimum(np.arange(L)[None, :], self.length[:, None] - 1)
        s = self.seg_of[np.arange(K)[:, None], np.maximum(col - 1, 0)]
        self.t = seg_t0[s] + self.seg_h[s] * (col - self.seg_p[s])
        self.X, self.Y = X, C @ X + d[:, :, None]     # one row of Y per numerator
        self.sub = {}    # per number of sub-steps: each segment's sub-step matrices, if known

    def _steps(self, ks, hs):
        """Stacked ``(Phi, G)`` of one step ``hs[i]`` of loop ``ks[i]`` (scaled time, or
        whole samples)."""
        if self.discrete:
            return power(self.A, self.B[:, :, 0], np.asarray(hs).astype(np.int64), ks)
        P, _, S = lti.zoh_matrices(self.A[ks], self.B[ks], hs, gamma=False)
        return P, S[..., 0]

    def _fine(self, ks, idx, rows, n_sub):
        """Times and outputs ``rows`` of loops ``ks`` on their intervals ``[t[i], t[i+1]]``
        (``i`` from ``idx``) at ``n_sub`` times the resolution (discrete: every sample; a
        one-sample interval is its two grid points), padded by repeating the last point:
        arrays ``(J, N + 1)`` and the number of points of each interval.  The sub-steps
        of a segment are computed once."""
        s = self.seg_of[ks, idx]
        h = self.seg_h[s]
        x0 = self.X[ks, :, idx]
        if self.discrete:
            n = np.maximum(np.rint(h).astype(int), 1)
            N = int(n.max())
            cols = np.minimum(np.arange(N + 1)[None, :], n[:, None])
            y = np.empty(cols.shape)
            if N > 1:
                X = propagate(self.A[ks], self.B[ks, :, 0], x0, N)
                y = np.take_along_axis(self._output(ks, rows, X), cols, axis=1)
            one = n == 1
            if one.any():
                y[one] = self.Y[ks[one], rows if np.ndim(rows) == 0 else rows[one]][
                    np.arange(one.sum())[:, None], idx[one][:, None] + cols[one]]
            return self.t[ks, idx][:, None] + cols, y, n + 1
        if n_sub not in self.sub:
            S = len(self.seg_h)
            self.sub[n_sub] = (np.empty((S,) + self.A.shape[1:]), np.empty((S, self.A.shape[-1])),
                               np.zeros(S, dtype=bool))
        Phi, G, known = self.sub[n_sub]
        todo = sorted({v for v in s.tolist() if not known[v]})
        if todo:                           # the sub-steps of the segments not met yet
            Phi[todo], G[todo] = self._steps(self.seg_k[todo], self.seg_h[todo] / n_sub)
            known[todo] = True
        t = self.t[ks, idx][:, None] + (h / n_sub)[:, None] * np.arange(n_sub + 1)
        y = self._output(ks, rows, propagate(Phi[s], G[s], x0, n_sub))
        return t, y, np.full(len(ks), n_sub + 1)

    def _output(self, ks, rows, X):
        """Outputs ``rows`` of loops ``ks`` along their states ``X`` ``(J, n, N)``."""
        return (self.C[ks, rows][:, None, :] @ X)[:, 0, :] + self.d[ks, rows][:, None]

    def extremes(self, requests):
        """Largest ``sign * y`` of output ``row`` of each loop and its time (refined
        between the grid points), for several ``(row, sign)`` at once.

        Parameters
        ----------
        requests : sequence of (int, array_like)
            ``(row, sign)``: ``sign`` is ``+1`` or ``-1``, one per loop (or one for all).

        Returns
        -------
        list of (ndarray, ndarray)
            Per request, ``sign * y`` at its largest and when (scaled time or samples),
            each of shape ``(K,)``.
        """
        K = self.Y.shape[0]
        rows = np.array([row for row, _ in requests])
        signs = np.empty((len(requests), K))
        for q, (_, sg) in enumerate(requests):
            signs[q] = sg
        sY = signs[:, :, None] * self.Y[:, rows].transpose(1, 0, 2)      # (Q, K, L)
        i = np.argmax(sY, axis=2)
        qq, kk = np.arange(len(requests))[:, None], np.arange(K)[None, :]
        best, tbest = sY[qq, kk, i], self.t[kk, i]
        j = np.array([i - 1, i])                                      # (2, Q, K): both sides
        jp, jq, jk = np.nonzero((j >= 0) & (j < self.length - 1))
        if len(jk):
            t, y, npts = self._fine(jk, j[jp, jq, jk], rows[jq], EXTREME_SUB)
            sy = signs[jq, jk][:, None] * y
            J = np.arange(len(jk))
            k = np.argmax(sy, axis=1)
            v, tk = sy[J, k], t[J, k]
            if not self.discrete:          # vertex of the parabola
                km, kp = np.maximum(k - 1, 0), np.minimum(k + 1, npts - 1)
                a, b, c = sy[J, km], v, sy[J, kp]
                den = a - 2 * b + c
                vert = (k > 0) & (k < npts - 1) & (den < 0)
                sden = np.where(vert, den, -1.0)
                v = np.where(vert, np.maximum(v, b - (a - c) ** 2 / (8 * sden)), v)
                tk = np.where(vert, tk + 0.5 * (a - c) / sden * (t[J, kp] - t[J, k]), tk)
            for p in (0, 1):               # the left interval first, as one loop alone
                sel = np.flatnonzero(jp == p)
                better = sel[v[sel] > best[jq[sel], jk[sel]]]
                best[jq[better], jk[better]] = v[better]
                tbest[jq[better], jk[better]] = tk[better]
        return list(zip(best, tbest))

    def settling(self, row, final):
        """Last time ``|y - final| > 2 % |final|`` of output ``row`` of each loop (0 if
        never; the first time back in).

        Parameters
        ----------
        row : int
        final : array_like
            Shape ``(K,)``: the final values.

        Returns
        -------
        ndarray
            Shape ``(K,)`` (scaled time or samples).
        """
        final = np.asarray(final, float)
        tol = SETTLING_BAND * np.abs(final)
        out = np.abs(self.Y[:, row] - final[:, None]) > tol[:, None]
        last = out.shape[1] - 1 - np.argmax(out[:, ::-1], axis=1)   # (the padding repeats
        ar = np.arange(len(last))                                  # the last point)
        some = out[ar, last]
        res = np.where(some, self.t[ar, last], 0.0)     # out at the end: the end
        ks = np.flatnonzero(some & (last < self.length - 1))
        if len(ks):
            t, y, npts = self._fine(ks, last[ks], row, SETTLING_SUB)
            o = np.abs(y - final[ks, None]) > tol[ks, None]
            k = y.shape[1] - 1 - np.argmax(o[:, ::-1], axis=1)
            res[ks] = t[np.arange(len(ks)), np.minimum(k + 1, npts - 1)]
        return res
