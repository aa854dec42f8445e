"""Exact step responses of many loops at once: the numerical kernel of :mod:`robrst.certificate.steps`.

:class:`StepResponses` takes the stacked realisations of ``K`` loops of one degree (one
``A, B`` per loop, a row of ``C`` and an entry of ``d`` per output, from
:func:`robrst.core.lti.companion_outputs_many`) and computes their step responses on grids
that follow each loop's own modes (:func:`segments`).  The numerical stages are stacked
numpy or LAPACK calls for the ``K`` loops: eigenvalues, zero-order-hold steps
(:func:`robrst.core.lti.zoh_matrices`; the sampled loop's strides by powers) and propagation
by repeated doubling (:mod:`robrst.certificate._doubling`: ``x[k + m] = Phi**m x[k] + S_m``);
a single loop is the case ``K = 1``.  :meth:`StepResponses.subdivide` gives the exact
states inside any set of grid intervals (or of their sub-intervals): what
:mod:`robrst.certificate._stepbound` refines wherever its bounds cannot exclude an extreme or an exit
from the settling band.  Each loop's grid and steps are those it would have alone.

The grids of the loops differ in length; the stacked arrays are padded by repeating
each loop's last point (a repeated last point changes neither a first ``argmax`` nor a
last exit from a band, which is all that is read from them).
"""

import math
from dataclasses import dataclass

import numpy as np

from robrst.core import lti
from robrst.certificate._doubling import power, power_all, propagate

__all__ = ["StepResponses", "Intervals", "Points", "segments", "bilinear", "POINTS_PER_RAD", "DECAY",
           "MAX_POINTS"]

POINTS_PER_RAD = 4.0       # grid points per radian of the fastest live mode
DECAY = 16.0               # a mode is dead after exp(-16) of its initial size
MAX_POINTS = 400_000


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


def segments(decay, speed, unit=None, folds=DECAY):
    """``[(t_end, step), ...]``: per stretch of time, a step resolving every live mode.

    Parameters
    ----------
    decay, speed : ndarray
        Each mode's decay rate and ``|log|`` rate (per time unit); a mode is live until
        ``folds / decay``.
    unit : float, optional
        With ``unit`` (discrete time) steps are whole multiples of it.
    folds : float
        The e-folds a mode lives (``DECAY``; more where the response after the grid must
        be smaller, :meth:`robrst.certificate._stepbound.StepBounds.tail`).

    Returns
    -------
    list of (float, float)
    """
    life = (folds / np.maximum(decay, 1e-300)).tolist()
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


@dataclass(frozen=True)
class Intervals:
    """Intervals ``[t0, t0 + h]`` of loops ``k`` (in segments ``seg`` of their grids) with
    the states at both ends."""

    k: np.ndarray
    seg: np.ndarray
    t0: np.ndarray
    h: np.ndarray
    xa: np.ndarray
    xb: np.ndarray


class Points:
    """The points that cut intervals (:meth:`StepResponses.subdivide`): ``t``, ``y``, ``dy``
    of every interval in turn (shape ``(P,)``), ``first`` (shape ``(J + 1,)``) where each
    interval's points begin; their states are kept by propagation (:meth:`x`)."""

    def __init__(self, t, y, dy, first, parts, where):
        self.t, self.y, self.dy, self.first = t, y, dy, first
        self.parts, self.where = parts, where

    def x(self, a, j):
        """The states at points ``a`` of intervals ``j``: shape ``(len(a), n)``."""
        out = np.empty((len(a), self.parts[0].shape[1]))
        c, row = self.where[:, j]
        for i, Xc in enumerate(self.parts):
            sel = np.flatnonzero(c == i)
            out[sel] = Xc[row[sel], :, a[sel] - self.first[j[sel]]]
        return out


class StepResponses:
    """Exact step responses of ``K`` loops on mode-adapted grids, refinable between points.

    Continuous: scaled time, steps by the exact ZOH of :mod:`robrst.core.lti`; discrete
    (``h_sample``): samples of the bilinear map of the same realisation, strides of whole
    samples.  After construction ``t`` ``(K, L)`` holds the grids, ``X`` ``(K, n, L)`` the
    states and ``Y`` ``(K, r, L)`` the outputs (padded, see the module doc), ``length``
    ``(K,)`` the true lengths.  ``generator`` is the continuous matrix (the loop's ``A``;
    for a sampled loop the one in the bilinear variable, whose map the samples follow) and
    ``rates`` the moduli of its eigenvalues.

    Parameters
    ----------
    A, B, C, d : ndarray
        Stacked scaled realisations, shapes ``(K, n, n)``, ``(K, n, 1)``, ``(K, r, n)``,
        ``(K, r)``.
    h_sample : array_like, optional
        Shape ``(K,)``: each loop's sampling period in its scaled time (discrete loops).
    folds : array_like, optional
        Shape ``(K,)``: the e-folds each loop's modes live on its grid (default ``DECAY``).
    """

    def __init__(self, A, B, C, d, h_sample=None, folds=None):
        self.discrete = h_sample is not None
        self.generator = A
        folds = np.full(A.shape[0], DECAY) if folds is None else np.asarray(folds, float)
        if self.discrete:
            self.h_sample = np.asarray(h_sample, float)
            A, B, C, d = bilinear(A, B, C, d, self.h_sample)
            z = np.linalg.eigvals(A).astype(complex)
            logz = np.log(z)
            segs = [segments(-lz.real, np.abs(lz), unit=1, folds=f)
                    for lz, f in zip(logz, folds.tolist())]
            self.rates = np.abs(2 / self.h_sample[:, None] * (z - 1) / (z + 1))
        else:
            lam = np.linalg.eigvals(A)
            segs = [segments(-lm.real, np.abs(lm), folds=f) for lm, f in zip(lam, folds.tolist())]
            self.rates = np.abs(lam)
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
        # y' = C x' (continuous) or y[k+1] - y[k] (discrete) = CV x + CV0
        D = A - np.eye(n) if self.discrete else A
        self.CV, self.CV0 = C @ D, (C @ B)[..., 0]
        self.sub = {}    # per subdivision of the segments: their sub-step matrices, if known
        self.strides = {}    # per stride (discrete): its matrices for every loop

    def _steps(self, ks, hs):
        """Stacked ``(Phi, G)`` of one step ``hs[i]`` of loop ``ks[i]`` (scaled time, or
        whole samples)."""
        if self.discrete:
            return power(self.A, self.B[:, :, 0], np.asarray(hs).astype(np.int64), ks)
        P, _, S = lti.zoh_matrices(self.A[ks], self.B[ks], hs, gamma=False)
        return P, S[..., 0]

    def _sub_steps(self, seg, div):
        """``(Phi, G)`` of the steps ``seg_h / div`` of segments ``seg`` (continuous),
        computed once per segment and subdivision."""
        if div not in self.sub:
            S = len(self.seg_h)
            self.sub[div] = (np.empty((S,) + self.A.shape[1:]), np.empty((S, self.A.shape[-1])),
                             np.zeros(S, dtype=bool))
        Phi, G, known = self.sub[div]
        todo = np.unique(seg[~known[seg]])
        if len(todo):                      # the sub-steps of the segments not met yet
            Phi[todo], G[todo] = self._steps(self.seg_k[todo], self.seg_h[todo] / div)
            known[todo] = True
        return Phi[seg], G[seg]

    def intervals(self, ks, idx):
        """The grid intervals ``[t[k, i], t[k, i + 1]]`` of loops ``ks`` (``i`` from ``idx``).

        Returns
        -------
        Intervals
        """
        return Intervals(ks, self.seg_of[ks, idx], self.t[ks, idx],
                         self.t[ks, idx + 1] - self.t[ks, idx], self.X[ks, :, idx],
                         self.X[ks, :, idx + 1])

    def subdivide(self, iv, cut, rows):
        """Exact states, outputs and slopes at the points that cut each of the intervals
        ``iv``: continuous, in ``cut[j]`` equal pieces (a power of 2 of its segment's step);
        discrete, in strides of ``cut[j]`` samples (a power of 2; the last piece shorter).
        The intervals cut alike share their step matrices.

        Parameters
        ----------
        iv : Intervals
        cut, rows : ndarray
            Shape ``(J,)``: how to cut each interval, and its output row.

        Returns
        -------
        Points
        """
        J = len(iv.k)
        cut = np.asarray(cut, dtype=np.int64)
        if self.discrete:                      # one matrix per loop and stride
            m = np.rint(iv.h).astype(np.int64)
            count = -(-m // cut)
            key = cut * len(self.A) + iv.k
        else:                                  # one per segment and sub-step
            count = cut
            div = np.rint(self.seg_h[iv.seg] / iv.h * cut).astype(np.int64)
            key = div * len(self.seg_h) + iv.seg
        first = np.concatenate([[0], np.cumsum(count + 1)])
        own = np.repeat(np.arange(J), count + 1)
        pos = np.arange(first[-1]) - first[own]
        t = iv.t0[own] + (np.minimum(pos * cut[own], m[own]) if self.discrete
                          else (iv.h / count)[own] * pos)
        y, dy = np.empty(first[-1]), np.empty(first[-1])
        size = np.ceil(np.log2(count) / 2)       # propagations by size (within 4 times)
        parts, where = [], np.empty((2, J), dtype=np.int64)
        for c in np.unique(size).tolist():
            j = np.flatnonzero(size == c)
            Nc = int(count[j].max())
            keys, grp = np.unique(key[j], return_inverse=True)
            P, S = self._matrices(keys)
            grp = grp.ravel()
            Xc = propagate(P[grp], S[grp], iv.xa[j], Nc)
            if self.discrete:                  # the end exact (a stride may pass it)
                Xc[np.arange(len(j)), :, count[j]] = iv.xb[j]
            valid = np.arange(Nc + 1)[None, :] <= count[j][:, None]
            dest = (first[j][:, None] + np.arange(Nc + 1)[None, :])[valid]
            kr = (iv.k[j], rows[j])
            y[dest] = ((self.C[kr][:, None, :] @ Xc)[:, 0] + self.d[kr][:, None])[valid]
            dy[dest] = ((self.CV[kr][:, None, :] @ Xc)[:, 0] + self.CV0[kr][:, None])[valid]
            where[0, j], where[1, j] = len(parts), np.arange(len(j))
            parts.append(Xc)
        return Points(t, y, dy, first, parts, where)

    def _matrices(self, keys):
        """``(Phi, G)`` of the sub-steps ``keys`` of :meth:`subdivide`."""
        if self.discrete:
            K = len(self.A)
            stride, k = keys // K, keys % K
            P, S = np.empty((len(keys),) + self.A.shape[1:]), np.empty((len(keys), self.A.shape[1]))
            for v in np.unique(stride).tolist():
                sel = np.flatnonzero(stride == v)
                Pv, Sv = self._stride(v)
                P[sel], S[sel] = Pv[k[sel]], Sv[k[sel]]
            return P, S
        nseg = len(self.seg_h)
        div, seg = keys // nseg, keys % nseg     # (keys sorted: by subdivision first)
        P, S = zip(*(self._sub_steps(seg[div == v], int(v)) for v in np.unique(div).tolist()))
        return np.concatenate(P), np.concatenate(S)

    def _stride(self, s):
        """``(Ad**s, sum_{i<s} Ad**i Bd)`` of every loop (discrete), computed once; a power
        of 2 by squaring the half."""
        if s not in self.strides:
            if s > 1 and s & (s - 1) == 0:
                P, S = self._stride(s // 2)
                self.strides[s] = (P @ P, (P @ S[..., None])[..., 0] + S)
            else:
                self.strides[s] = power_all(self.A, self.B[:, :, 0], s)
        return self.strides[s]

    @staticmethod
    def pieces(iv, pts, a, j):
        """The pieces from points ``a`` of ``pts`` (:meth:`subdivide`) to the next ones, of
        intervals ``j`` of ``iv``.

        Returns
        -------
        Intervals
        """
        t = pts.t
        return Intervals(iv.k[j], iv.seg[j], t[a], t[a + 1] - t[a], pts.x(a, j), pts.x(a + 1, j))

    def outputs(self, ks, X, rows=None):
        """Outputs of loops ``ks`` at their states: every row at ``X`` ``(J, n, N)``,
        ``(J, r, N)``; or row ``rows[p]`` of loop ``ks[p]`` at ``X[p]`` ``(P, n)``, ``(P,)``."""
        if rows is None:
            return self.C[ks] @ X + self.d[ks][:, :, None]
        return (self.C[ks, rows] * X).sum(axis=1) + self.d[ks, rows]

    def slopes(self, ks, X, rows=None):
        """``y'`` (continuous) or ``y[k + 1] - y[k]`` (discrete) of loops ``ks`` at their
        states, as :meth:`outputs`."""
        if rows is None:
            return self.CV[ks] @ X + self.CV0[ks][:, :, None]
        return (self.CV[ks, rows] * X).sum(axis=1) + self.CV0[ks, rows]

    def velocity(self, ks, X):
        """``x' = A x + B`` (continuous) or ``x[k + 1] - x[k]`` (discrete) of loops ``ks`` at
        their states ``X`` ``(J, n, N)``."""
        V = self.A[ks] @ X + self.B[ks]
        return V - X if self.discrete else V
