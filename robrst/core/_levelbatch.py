"""The batched iteration of the level-set kernel (:mod:`robrst.core._levelset`): every level of
one state dimension advanced together, each stage one stacked numpy or LAPACK call.

Each level keeps its own candidates, acceptance and polish (the rules of
:mod:`robrst.core._levelset`, module docstring of :mod:`robrst.core.peaks`); only the arithmetic is
laid out in arrays, rows padded where levels have fewer candidates (a padded entry is
never a candidate).  The Hamiltonians and their eigenvalues are those of one level at a
time, bit for bit; the gains are the same formulas (powers of ``j nu`` times the
coefficients, Horner's rule where the powers would overflow) evaluated in stacked
products.
"""

import numpy as np

__all__ = ["LOOSE", "gain", "gains", "hamiltonians", "newton", "derivative", "Batch",
           "One"]

LOOSE = 0.05   # roots with |Im x| <= LOOSE |x| are treated as real (candidates only)
_NEWTON = 12   # Newton steps of the polish
_SCALAR_ROWS = 4   # up to this many rows, the polish steps in Python floats (fewer calls)


def gain(NDs, nu):
    """``|N/D|(j nu)`` for the stacked scaled pair ``NDs = [Ns; Ds]`` (rows of powers).

    Powers of ``j nu`` times the coefficients (one matrix product); Horner's rule where
    the powers would overflow.
    """
    nu = np.asarray(nu, float)
    n = NDs.shape[1] - 1
    if nu.size and np.max(nu) < 1e300 ** (1.0 / max(n, 1)):
        y = ((1j * nu)[:, None] ** np.arange(n, -1, -1)) @ NDs.T
        g = np.abs(y[:, 0] / y[:, 1])
    else:
        s = 1j * nu
        y = np.zeros((2, s.size), complex)
        for k in range(n + 1):
            y = y * s + NDs[:, k:k + 1]
        g = np.abs(y[0] / y[1])
    g[np.isnan(g)] = 0.0
    return g


def derivative(P):
    """Coefficients of the derivative of each polynomial (the last axis), as
    ``numpy.polyder`` forms them (the same products), without its dispatch."""
    return P[..., :-1] * np.arange(P.shape[-1] - 1, 0, -1)


def _powers(NDs, x):
    """``|N/D|(j x)`` by powers for stacked pairs ``NDs`` ``(K, 2, n + 1)`` at ``x``
    ``(K, m)`` (NaN: 0, as :func:`gain`)."""
    n = NDs.shape[2] - 1
    y = ((1j * x)[..., None] ** np.arange(n, -1, -1)) @ NDs.transpose(0, 2, 1)
    g = np.abs(y[..., 0] / y[..., 1])
    g[np.isnan(g)] = 0.0
    return g


def gains(NDs, nu, valid):
    """:func:`gain` of each stacked pair ``NDs`` ``(K, 2, n + 1)`` at its row of ``nu``
    ``(K, M)`` where ``valid``; ``-inf`` at the other entries.  The figures are those of
    :func:`gain` of each row alone, bit for bit (a row with one candidate is a product of
    its own shape: BLAS takes another kernel for one row than for several)."""
    K, M = nu.shape
    n = NDs.shape[2] - 1
    out = np.full((K, M), -np.inf)
    if K == 1:                                        # one row: gain() itself
        if valid[0].any():
            out[0, valid[0]] = gain(NDs[0], nu[0, valid[0]])
        return out
    x = np.where(valid, nu, 1.0)
    count = valid.sum(axis=1)
    big = ~(np.max(np.where(valid, x, 0.0), axis=1) < 1e300 ** (1.0 / max(n, 1)))
    k = np.flatnonzero(~big & (count == 1))
    if k.size:
        col = np.argmax(valid[k], axis=1)
        out[k, col] = _powers(NDs[k], x[k, col][:, None])[:, 0]
    k = np.flatnonzero(~big & (count > 1))
    if k.size:
        out[k] = np.where(valid[k], _powers(NDs[k], x[k]), -np.inf)
    for k in np.flatnonzero(big & (count > 0)):        # Horner's rule (rare)
        out[k, valid[k]] = gain(NDs[k], nu[k, valid[k]])
    return out


def hamiltonians(A, B, C, d, g):
    """Stacked Hamiltonians whose imaginary eigenvalues ``j nu`` are the frequencies where
    ``|G| = g``: ``A`` ``(K, n, n)``, ``B`` ``(K, n, 1)``, ``C`` ``(K, 1, n)``, ``d, g``
    ``(K,)``."""
    K, n = A.shape[0], A.shape[1]
    R = d * d - g * g
    H = np.empty((K, 2 * n, 2 * n))
    H[:, :n, :n] = A - (d / R)[:, None, None] * (B @ C)
    H[:, :n, n:] = (-g / R)[:, None, None] * (B @ B.transpose(0, 2, 1))
    H[:, n:, :n] = (g / R)[:, None, None] * (C.transpose(0, 2, 1) @ C)
    H[:, n:, n:] = -H[:, :n, :n].transpose(0, 2, 1)
    return H


def _horner(c, x):
    """Rows of ``c`` ``(K, L)`` at ``x`` ``(K,)``."""
    out = np.zeros_like(x)
    for k in range(c.shape[1]):
        out = out * x + c[:, k]
    return out


def newton(P, dP, x0):
    """Newton steps (at most ``_NEWTON``) on each row of ``P`` (derivative ``dP``) from
    ``x0``; a row fails on a zero derivative or a step leaving ``(x0 / 1.2, 1.2 x0)``.

    Returns
    -------
    x : ndarray
    fail : ndarray of bool
    """
    if len(x0) <= _SCALAR_ROWS:      # a few rows: the same steps in Python floats
        out = [_newton_one(p, d, a) for p, d, a in zip(P.tolist(), dP.tolist(), x0.tolist())]
        return np.array([x for x, _ in out]), np.array([f for _, f in out], dtype=bool)
    x = x0.copy()
    going = np.ones(x0.size, dtype=bool)
    fail = np.zeros(x0.size, dtype=bool)
    for _ in range(_NEWTON):
        i = np.flatnonzero(going)
        if not i.size:
            break
        den = _horner(dP[i], x[i])
        zero = den == 0
        fail[i[zero]], going[i[zero]] = True, False
        i, den = i[~zero], den[~zero]
        with np.errstate(all="ignore"):
            step = _horner(P[i], x[i]) / den
        xn = x[i] - step
        x[i] = xn
        out = ~((x0[i] / 1.2 < xn) & (xn < x0[i] * 1.2))
        fail[i[out]], going[i[out]] = True, False
        small = ~out & (np.abs(step) <= 1e-15 * xn)
        going[i[small]] = False
    return x, fail


def _newton_one(P, dP, x0):
    """:func:`newton` of one row (lists of floats)."""
    x = x0
    for _ in range(_NEWTON):
        den = 0.0
        for a in dP:
            den = den * x + a
        if den == 0:
            return x, True
        num = 0.0
        for a in P:
            num = num * x + a
        step = num / den
        x = x - step
        if not (x0 / 1.2 < x < x0 * 1.2):
            return x, True
        if abs(step) <= 1e-15 * x:
            break
    return x, False


class Batch:
    """Levels of one state dimension ``n >= 1``, stacked: realisations, stationarity
    polynomials, bands and the current value ``g`` at ``w``.

    Parameters
    ----------
    levels : sequence of Level
        Their ``NDs``, ``A, B, C, d``, ``P``, ``lo, hi`` and ``roots`` (the stationary
        points) are read.
    """

    def __init__(self, levels):
        self.NDs = np.stack([lv.NDs for lv in levels])
        self.A = np.stack([lv.A for lv in levels])
        self.B = np.stack([lv.B for lv in levels])
        self.C = np.stack([lv.C for lv in levels])
        self.d = np.array([lv.d for lv in levels])
        self.P = np.stack([lv.P for lv in levels])
        self.dP = derivative(self.P)
        self.lo = np.array([lv.lo for lv in levels])
        self.hi = np.array([lv.hi for lv in levels])
        K = len(levels)
        self.edges = np.full((K, 2), np.nan)
        for k, lv in enumerate(levels):
            self.edges[k, :len(lv.edges)] = lv.edges
        R = max(len(lv.roots) for lv in levels)
        self.roots = np.full((K, R), np.nan, complex)
        for k, lv in enumerate(levels):
            self.roots[k, :len(lv.roots)] = lv.roots
        self.g, self.w = np.zeros(K), np.zeros(K)
        self.done = np.zeros(K, dtype=bool)

    def start(self):
        """The best candidate of each level among its stationary points, band edges and
        the limit at infinity, polished."""
        r = self.roots
        with np.errstate(invalid="ignore"):
            real = (np.abs(r.imag) <= LOOSE * np.abs(r)) & (r.real > 0)
            nu = np.concatenate([self.edges, np.sqrt(np.where(real, r.real, 1.0))], axis=1)
            valid = np.concatenate([~np.isnan(self.edges), real], axis=1)
            valid &= (nu >= self.lo[:, None]) & (nu <= self.hi[:, None])
        v = gains(self.NDs, nu, valid)
        i = np.argmax(v, axis=1)
        rows = np.arange(len(i))
        self.g, self.w = v[rows, i], nu[rows, i]
        top = (self.hi == np.inf) & (np.abs(self.d) >= self.g)
        self.g = np.where(top, np.abs(self.d), self.g)
        self.w = np.where(top, np.inf, self.w)
        self._polish(np.ones(len(i), dtype=bool))

    def live(self):
        """Rows still to verify (a zero or non-finite value is done)."""
        self.done |= ~np.isfinite(self.g) | (self.g == 0.0)
        return np.flatnonzero(~self.done)

    def levels(self, rows, rtol):
        """The Hamiltonians of the next verification of ``rows``."""
        return hamiltonians(self.A[rows], self.B[rows], self.C[rows], self.d[rows],
                            self.g[rows] * (1 + 2 * rtol))

    def step(self, rows, ev, rtol):
        """Evaluate between the crossings (eigenvalues ``ev`` ``(J, 2n)`` of ``rows``); a
        row is done when none lies above its level, else raised to the best point."""
        lo, hi = self.lo[rows, None], self.hi[rows, None]
        with np.errstate(invalid="ignore"):
            keep = (np.abs(ev.real) <= LOOSE * np.abs(ev)) & (ev.imag > 0)
            ws = np.where(keep & (ev.imag > lo) & (ev.imag < hi), ev.imag, np.nan)
            ws = np.sort(np.concatenate([self.edges[rows], ws], axis=1), axis=1)  # nan last
            ok = ~np.isnan(ws)
            pair = ok[:, :-1] & ok[:, 1:]
            a, b = ws[:, :-1], ws[:, 1:]
            mids = np.where(a > 0, np.sqrt(a * b), 0.5 * (a + b))
        last = ws[np.arange(len(rows)), ok.sum(axis=1) - 1]
        tail = (2.0 * last + 1.0)[:, None]
        cand = np.concatenate([mids, ws, tail], axis=1)
        valid = np.concatenate([pair, ok, np.isinf(hi)], axis=1)
        v = gains(self.NDs[rows], cand, valid)
        j = np.argmax(v, axis=1)
        best = v[np.arange(len(rows)), j]
        up = best > self.g[rows] * (1 + rtol)
        self.done[rows[~up]] = True
        up_rows = rows[up]
        self.g[up_rows], self.w[up_rows] = best[up], cand[np.flatnonzero(up), j[up]]
        mask = np.zeros(len(self.g), dtype=bool)
        mask[up_rows] = True
        self._polish(mask)

    def _polish(self, rows):
        """Newton on the stationarity polynomial in ``x = w**2`` from each row of ``rows``
        (a mask) with ``0 < w < inf``; a polished point is kept unless lower than the start
        (beyond rounding) or outside the band."""
        run = rows & (self.w > 0) & (self.w < np.inf)
        idx = np.flatnonzero(run)
        if not idx.size:
            return
        x, fail = newton(self.P[idx], self.dP[idx], self.w[idx] * self.w[idx])
        i = np.flatnonzero(~fail)
        if not i.size:
            return
        nup = np.sqrt(x[i])
        gp = gains(self.NDs[idx[i]], nup[:, None], np.ones((i.size, 1), dtype=bool))[:, 0]
        k = idx[i]
        take = (gp >= self.g[k] * (1 - 1e-13)) & (self.lo[k] <= nup) & (nup <= self.hi[k])
        self.g[k[take]], self.w[k[take]] = gp[take], nup[take]

    def results(self):
        """Per level ``(g, w, done)``."""
        return list(zip(self.g.tolist(), self.w.tolist(), self.done.tolist()))


class One:
    """One level alone, with :class:`Batch`'s interface and steps (bit for bit), in
    scalars: a fraction of the calls of a stack of one (a single peak, or a lone level of
    its dimension)."""

    def __init__(self, lv):
        self.lv = lv
        self.P, self.dP = lv.P.tolist(), derivative(lv.P).tolist()
        self.g, self.w, self.done = 0.0, 0.0, False

    def start(self):
        """As :meth:`Batch.start`."""
        lv = self.lv
        r = lv.roots
        keep = (np.abs(r.imag) <= LOOSE * np.abs(r)) & (r.real > 0)
        nu = np.concatenate([lv.edges, np.sqrt(r.real[keep])])
        nu = nu[(nu >= lv.lo) & (nu <= lv.hi)]
        vals = gain(lv.NDs, nu)
        i = int(np.argmax(vals))
        self.g, self.w = float(vals[i]), float(nu[i])
        if lv.hi == np.inf and abs(lv.d) >= self.g:
            self.g, self.w = abs(lv.d), np.inf
        self._polish()

    def live(self):
        """As :meth:`Batch.live`."""
        self.done = self.done or not np.isfinite(self.g) or self.g == 0.0
        return np.zeros(0 if self.done else 1, dtype=int)

    def levels(self, rows, rtol):
        """As :meth:`Batch.levels`."""
        lv = self.lv
        return hamiltonians(lv.A[None], lv.B[None], lv.C[None], np.array([lv.d]),
                            np.array([self.g * (1 + 2 * rtol)]))

    def step(self, rows, ev, rtol):
        """As :meth:`Batch.step`."""
        lv, ev = self.lv, ev[0]
        keep = (np.abs(ev.real) <= LOOSE * np.abs(ev)) & (ev.imag > 0)
        ws = ev.imag[keep]
        ws = np.sort(np.concatenate([lv.edges, ws[(ws > lv.lo) & (ws < lv.hi)]]))
        mids = np.where(ws[:-1] > 0, np.sqrt(ws[:-1] * ws[1:]), 0.5 * (ws[:-1] + ws[1:]))
        cand = np.concatenate([mids, ws, [2.0 * ws[-1] + 1.0] if lv.hi == np.inf else []])
        v = gain(lv.NDs, cand)
        j = int(np.argmax(v))
        if not v[j] > self.g * (1 + rtol):
            self.done = True
            return
        self.g, self.w = float(v[j]), float(cand[j])
        self._polish()

    def _polish(self):
        lv = self.lv
        if not 0 < self.w < np.inf:
            return
        x, fail = _newton_one(self.P, self.dP, self.w * self.w)
        if fail:
            return
        nup = float(np.sqrt(x))
        gp = float(gain(lv.NDs, [nup])[0])
        if gp >= self.g * (1 - 1e-13) and lv.lo <= nup <= lv.hi:
            self.g, self.w = gp, nup

    def results(self):
        """As :meth:`Batch.results`."""
        return [(self.g, self.w, self.done)]
