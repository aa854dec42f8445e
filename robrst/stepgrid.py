"""Exact step responses of many loops at once: the numerical kernel of :mod:`robrst.timespec`.

:class:`StepResponses` takes the stacked realisations of ``K`` loops of one degree (one
``A, B`` per loop, a row of ``C`` and an entry of ``d`` per output, from
:func:`robrst.lti.companion_outputs_many`) and computes their step responses on grids
that follow each loop's own modes (:func:`segments`).  The numerical stages are stacked
numpy or LAPACK calls for the ``K`` loops: eigenvalues, zero-order-hold steps
(:func:`robrst.lti.zoh_matrices`; the sampled loop's strides by powers) and propagation
by repeated doubling (:mod:`robrst.doubling`: ``x[k + m] = Phi**m x[k] + S_m``);
a single loop is the case ``K = 1``.  :meth:`StepResponses.subdivide` gives the exact
states inside any set of grid intervals (or of their sub-intervals): what
:mod:`robrst.stepbound` refines wherever its bounds cannot exclude an extreme or an exit
from the settling band.  Each loop's grid and steps are those it would have alone.

The grids of the loops differ in length; the stacked arrays are padded by repeating
each loop's last point (a repeated last point changes neither a first ``argmax`` nor a
last exit from a band, which is all that is read from them).
"""

import math
from dataclasses import dataclass

import numpy as np

from robrst import lti
from robrst.doubling import power, power_all, propagate, propagate_shared

__all__ = ["StepResponses", "Intervals", "segments", "bilinear", "POINTS_PER_RAD", "DECAY",
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


@dataclass(frozen=True)
class Intervals:
    """Intervals ``[t0, t0 + h]`` of loops ``k`` with the states at both ends.

    ``seg`` is each interval's segment of the grid and ``div`` how many times finer than
    the segment's step it is (continuous loops: the sub-steps that cut it in ``n`` are
    ``seg_h / (div n)``).
    """

    k: np.ndarray
    seg: np.ndarray
    t0: np.ndarray
    h: np.ndarray
    xa: np.ndarray
    xb: np.ndarray
    div: np.ndarray


class StepResponses:
    """Exact step responses of ``K`` loops on mode-adapted grids, refinable between points.

    Continuous: scaled time, steps by the exact ZOH of :mod:`robrst.lti`; discrete
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
    """

    def __init__(self, A, B, C, d, h_sample=None):
        self.discrete = h_sample is not None
        self.generator = A
        if self.discrete:
            self.h_sample = np.asarray(h_sample, float)
            A, B, C, d = bilinear(A, B, C, d, self.h_sample)
            z = np.linalg.eigvals(A).astype(complex)
            logz = np.log(z)
            segs = [segments(-lz.real, np.abs(lz), unit=1) for lz in logz]
            self.rates = np.abs(2 / self.h_sample[:, None] * (z - 1) / (z + 1))
        else:
            lam = np.linalg.eigvals(A)
            segs = [segments(-lm.real, np.abs(lm)) for lm in lam]
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
                         self.X[ks, :, idx + 1], np.ones(len(ks), dtype=np.int64))

    def subdivide(self, iv, n):
        """Exact states at the points that cut each of the intervals ``iv`` in ``n[j]``
        pieces (continuous: equal sub-steps; discrete: strides of ``ceil(h / n)`` samples,
        the last one shorter).  The intervals cut alike share the matrix products of their
        loop.

        Parameters
        ----------
        iv : Intervals
        n : ndarray
            Shape ``(J,)``: the pieces of each interval (continuous: powers of 2).

        Returns
        -------
        t, X : ndarray
            Shapes ``(J, N + 1)`` and ``(J, n_x, N + 1)``: the points of each interval, its
            ends included, padded by repeating its end.
        count : ndarray
            Shape ``(J,)``: the pieces of each interval (``n``, or fewer sampled).
        """
        J = len(iv.k)
        if self.discrete:                      # one matrix per loop and stride
            m = np.rint(iv.h).astype(np.int64)
            step = -(-m // n)
            count = -(-m // step)
            key = step * len(self.A) + iv.k
        else:                                  # one per segment and sub-step
            count = np.asarray(n, dtype=np.int64)
            key = iv.div * count * len(self.seg_h) + iv.seg
        N = int(count.max())
        pos = np.minimum(np.arange(N + 1)[None, :], count[:, None])
        t = iv.t0[:, None] + (np.minimum(pos * step[:, None], m[:, None]) if self.discrete
                              else (iv.h / count)[:, None] * pos)
        X = np.empty((J, iv.xa.shape[1], N + 1))
        size = np.ceil(np.log2(count) / 2)       # propagations by size (within 4 times)
        for c in np.unique(size).tolist():
            j = np.flatnonzero(size == c)
            Nc = int(count[j].max())
            keys, grp = np.unique(key[j], return_inverse=True)
            P, S = self._matrices(keys)
            X[j, :, :Nc + 1] = propagate_shared(P, S, grp.ravel(), iv.xa[j], Nc)
        if self.discrete:                      # the end exact (a stride may pass it)
            X[np.arange(J), :, count] = iv.xb
        end = np.arange(N + 1)[None, :] > count[:, None]
        if end.any():                          # padding
            X = np.where(end[:, None, :], X[np.arange(J), :, count][:, :, None], X)
        return t, X, count

    def _matrices(self, keys):
        """``(Phi, G)`` of the sub-steps ``keys`` of :meth:`subdivide`."""
        if self.discrete:
            K = len(self.A)
            P, S = zip(*(self._stride(int(v)) for v in (keys // K).tolist()))
            return np.stack(P)[np.arange(len(keys)), keys % K], \
                np.stack(S)[np.arange(len(keys)), keys % K]
        nseg = len(self.seg_h)
        div, seg = keys // nseg, keys % nseg     # (keys sorted: by subdivision first)
        P, S = zip(*(self._sub_steps(seg[div == v], int(v)) for v in np.unique(div).tolist()))
        return np.concatenate(P), np.concatenate(S)

    def _stride(self, s):
        """``(Ad**s, sum_{i<s} Ad**i Bd)`` of every loop (discrete), computed once."""
        if s not in self.strides:
            self.strides[s] = power_all(self.A, self.B[:, :, 0], s)
        return self.strides[s]

    def pieces(self, iv, n, t, X, j, p):
        """The pieces ``p`` of intervals ``j`` of ``iv`` cut in ``n`` by :meth:`subdivide`
        (its ``t`` and ``X``).

        Returns
        -------
        Intervals
        """
        return Intervals(iv.k[j], iv.seg[j], t[j, p], t[j, p + 1] - t[j, p], X[j, :, p],
                         X[j, :, p + 1], iv.div[j] * np.asarray(n)[j])

    def outputs(self, ks, X, rows=None):
        """Outputs of loops ``ks`` at their states ``X`` ``(J, n, N)``: every row
        ``(J, r, N)``, or row ``rows[j]`` of loop ``ks[j]`` ``(J, N)``."""
        if rows is None:
            return self.C[ks] @ X + self.d[ks][:, :, None]
        return (self.C[ks, rows][:, None, :] @ X)[:, 0, :] + self.d[ks, rows][:, None]

    def slopes(self, ks, X, rows=None):
        """``y'`` (continuous) or ``y[k + 1] - y[k]`` (discrete) of loops ``ks`` at their
        states ``X`` ``(J, n, N)``, rows as in :meth:`outputs`."""
        if rows is None:
            return self.CV[ks] @ X + self.CV0[ks][:, :, None]
        return (self.CV[ks, rows][:, None, :] @ X)[:, 0, :] + self.CV0[ks, rows][:, None]

    def velocity(self, ks, X):
        """``x' = A x + B`` (continuous) or ``x[k + 1] - x[k]`` (discrete) of loops ``ks`` at
        their states ``X`` ``(J, n, N)``."""
        V = self.A[ks] @ X + self.B[ks]
        return V - X if self.discrete else V
