"""Hard step responses and their exact figures, computed without robrst.

Generators (seeded): loops whose reference step response has a late extremum of
``|y - 1|`` just above or just below the 2 % band edge (``edge_*``: a brief exit, or a
near miss, between grid points), or two maxima of nearly equal height (``twin_*``), for a
continuous loop (``N/D`` in s, rad/s) and a sampled one (``N/D`` in the bilinear variable
of robrst's sampled loops: the samples are those of ``N/D`` at ``w = 2 fs (z - 1)/(z +
1)``).  Each is a modal sum (poles, residues) whose one amplitude is tuned by root finding
on its closed form; the polynomials built from it (rounded) are the loops under test.

:class:`Exact` gives the figures of the polynomials themselves: partial fractions in
mpmath at 40 digits (the roots of ``D`` and the residues), every extremum of the response
located between the points of a dense float sampling (a sign change of ``y'``) and solved
for in mpmath; the last exit from the band is the root of ``|y - 1| - 0.02`` after the
last extremum outside it (``y`` is monotone between extrema).  Sampled: every sample from
the modal form in floats, the ones that decide (within ``1e-9`` of the largest, or of the
band edge) again in mpmath.
"""

import mpmath as mp
import numpy as np
from scipy.optimize import brentq

BAND = 0.02
DPS = 40


def _poly_from_modes(f, poles, res, first):
    """``D`` and ``N`` (real, descending) with ``N/D = f + sum res_j first(p) / (p - p_j)``
    (``first``: the factor ``s`` of a step response, ``z - 1`` of a sampled one)."""
    D = np.real(np.poly(poles))
    N = f * D
    for j, r in enumerate(res):
        N = np.polyadd(N, r * np.polymul(first, np.poly(np.delete(poles, j))))
    return np.real(N), D


def _bilinear_poly(P, fs):
    """``P(z) (1 - w/2fs)**n`` with ``z = (1 + w/2fs)/(1 - w/2fs)``, descending in ``w``."""
    n = len(P) - 1
    a, b = np.array([1 / (2 * fs), 1.0]), np.array([-1 / (2 * fs), 1.0])
    out = np.zeros(n + 1)
    for k, c in enumerate(P):
        term = np.array([c])
        for _ in range(n - k):
            term = np.polymul(term, a)
        for _ in range(k):
            term = np.polymul(term, b)
        out = np.polyadd(out, term)
    return np.real(out)


def _y_modes(t, poles, res, f=1.0):
    """Closed form ``f + sum res_j exp(p_j t)`` (or ``z_j**k``)."""
    return f + np.real(np.exp(np.multiply.outer(np.asarray(t, float), poles)) @ res)


def _max_near(fun, lo, hi, n=4001):
    """Largest value of ``fun`` on ``[lo, hi]`` (dense, then a golden refinement)."""
    t = np.linspace(lo, hi, n)
    v = fun(t)
    i = int(np.argmax(v))
    a, b = t[max(i - 1, 0)], t[min(i + 1, n - 1)]
    g = (np.sqrt(5) - 1) / 2
    for _ in range(80):
        c, d = b - g * (b - a), a + g * (b - a)
        if fun(c) > fun(d):
            b = d
        else:
            a = c
    return max(float(fun((a + b) / 2)), float(v[i]))


def _oscillation(rng, sampled):
    """Poles of a fast real mode and a lightly damped pair (scaled: the pair's frequency
    is 1 rad per unit, or ``theta`` rad per sample)."""
    zeta = rng.uniform(0.03, 0.08)
    if sampled:
        theta = rng.uniform(0.015, 0.04)
        lr = zeta * theta / np.sqrt(1 - zeta ** 2)
        return np.array([rng.uniform(0.2, 0.6), np.exp(-lr + 1j * theta),
                         np.exp(-lr - 1j * theta)]), theta, lr
    return np.array([-rng.uniform(8, 30), -zeta + 1j, -zeta - 1j]), 1.0, zeta


def edge(seed, delta, fs=None):
    """A loop whose ``m``-th extremum of ``|y - 1|`` (``m`` = 2 or 3, after the fast mode
    has died) is ``0.02 (1 + delta)``: its last exit from the band, brief, or a near miss.

    Returns
    -------
    N, D : ndarray
        In s (rad/s) or in the bilinear variable of the sample rate ``fs``.
    """
    rng = np.random.default_rng(seed)
    sampled = fs is not None
    poles, w, _ = _oscillation(rng, sampled)
    phi = rng.uniform(-np.pi, np.pi)
    m = int(rng.integers(2, 4))

    def res(b):
        rp = 0.5 * b * np.exp(1j * phi)
        return np.array([-1 - b * np.cos(phi), rp, np.conj(rp)])

    tm = (m * np.pi - phi) / w
    if sampled:
        win = np.arange(max(int(tm - 0.6 / w), 1), int(tm + 0.6 / w))
        ext = lambda b: np.max(np.abs(_y_modes(win, np.log(poles), res(b)) - 1))
    else:
        while tm < 24 / -poles[0].real:
            tm += np.pi
        ext = lambda b: _max_near(lambda t: np.abs(_y_modes(t, poles, res(b)) - 1), tm - 1, tm + 1)
    b = brentq(lambda b: ext(b) - BAND * (1 + delta), 0.005, 5.0, xtol=1e-15)
    (N,), D = _finish(poles, [res(b)], fs, rng)
    return N, D


def twin(seed, eps, fs=None):
    """Two numerators over one denominator whose responses have their two first
    oscillation maxima ``eps`` apart (the second higher for ``eps > 0``; ``-eps`` for the
    second numerator); a slow real mode lifts the second maximum to the first.

    Returns
    -------
    (N1, N2), D : ndarray
    """
    rng = np.random.default_rng(seed)
    sampled = fs is not None
    poles, w, lr = _oscillation(rng, sampled)
    slow = np.exp(-rng.uniform(2, 4) * lr) if sampled else -rng.uniform(2, 4) * lr
    poles = np.append(poles, slow)
    rs = [_twin_residues(rng, poles, w, e, sampled) for e in (eps, -eps)]
    return _finish(poles, rs, fs, rng)


def _twin_residues(rng, poles, w, eps, sampled):
    """Residues (fast, pair, slow) whose two first oscillation maxima are ``eps`` apart."""
    b, phi = rng.uniform(0.1, 0.3), rng.uniform(-np.pi, np.pi)

    def res(c):
        rp = 0.5 * b * np.exp(1j * phi)
        return np.array([-1 - b * np.cos(phi) - c, rp, np.conj(rp), c])

    t1 = (2 * np.pi - phi) / w
    while not sampled and t1 < 24 / -poles[0].real:
        t1 += 2 * np.pi
    if sampled:
        wins = [np.arange(int(t1 + j * 2 * np.pi / w - 0.6 / w),
                          int(t1 + j * 2 * np.pi / w + 0.6 / w)) for j in (0, 1)]

        def top(c, j):
            return np.max(_y_modes(wins[j][wins[j] > 0], np.log(poles), res(c)))
    else:
        def top(c, j):
            return _max_near(lambda t: _y_modes(t, poles, res(c)),
                             t1 + 2 * np.pi * j - 1.5, t1 + 2 * np.pi * j + 1.5)
    return res(brentq(lambda c: top(c, 1) - top(c, 0) - eps, -1.0, 0.0, xtol=1e-16))


def _finish(poles, residues, fs, rng):
    """The numerators (one per set of residues) and the denominator of modal step
    responses: scaled to a random power of 2 rad/s (exactly), or mapped to the bilinear
    variable of ``fs``."""
    if fs is not None:
        pairs = [_poly_from_modes(1.0, poles, res, [1.0, -1.0]) for res in residues]
        return [_bilinear_poly(N, fs) for N, _ in pairs], _bilinear_poly(pairs[0][1], fs)
    pairs = [_poly_from_modes(1.0, poles, res, [1.0, 0.0]) for res in residues]
    D = pairs[0][1]
    scale = (2.0 ** int(rng.integers(7, 12))) ** np.arange(len(D))   # N(s/W)/D(s/W) W**n
    return [np.concatenate([np.zeros(len(D) - len(N)), N]) * scale for N, _ in pairs], D * scale


class Exact:
    """Exact step-response figures of ``N/D`` (continuous), or of its sampled loop at
    ``fs`` (``N/D`` in the bilinear variable), from partial fractions in mpmath.

    Parameters
    ----------
    N, D : array_like
        Descending coefficients, ``deg N <= deg D``, simple stable roots of ``D``.
    fs : float, optional
    """

    def __init__(self, N, D, fs=None):
        with mp.workdps(DPS):
            n, d = [mp.mpf(float(c)) for c in N], [mp.mpf(float(c)) for c in D]
            n = [mp.mpf(0)] * (len(d) - len(n)) + n
            lam = mp.polyroots(d[::-1], maxsteps=400, extraprec=400, asc=True)
            dd = [c * (len(d) - 1 - i) for i, c in enumerate(d[:-1])]
            self.direct = n[0] / d[0]
            rem = [a - self.direct * b for a, b in zip(n, d)][1:]   # N - direct D
            rho = [mp.polyval(rem[::-1], l, asc=True) / mp.polyval(dd[::-1], l, asc=True)
                   for l in lam]
            self.final = n[-1] / d[-1]
        self.fs, self.lam, self.rho = fs, lam, rho
        if fs is not None:           # y[k] = direct + sum c_j (1 - p_j**k): the bilinear map
            with mp.workdps(DPS):
                p = [(2 * fs + l) / (2 * fs - l) for l in lam]
                c = [r / (2 * fs - l) * (1 + q) / (1 - q) for r, l, q in zip(rho, lam, p)]
                base = self.direct + sum(r / (2 * fs - l) for r, l in zip(rho, lam))
            self.p, self.c, self.base = p, c, base
        self.fl = np.array([complex(v) for v in (self.p if fs is not None else lam)])
        self.fr = np.array([complex(v) for v in (self.c if fs is not None else rho)])

    # ----------------------------------------------------------------- continuous
    def _y(self, t):
        """``y(t)`` in mpmath."""
        return mp.re(self.direct + sum(r * (mp.exp(l * t) - 1) / l
                                       for r, l in zip(self.rho, self.lam)))

    def _dy(self, t):
        return mp.re(sum(r * mp.exp(l * t) for r, l in zip(self.rho, self.lam)))

    def _times(self):
        lam = self.fl
        fast, slow = np.max(np.abs(lam)), np.min(-lam.real)
        t_fast = np.linspace(0, 30 / fast, 20001)
        t_slow = np.arange(30 / fast, 40 / slow, 0.02 / np.min(np.abs(lam)))
        return np.concatenate([t_fast, t_slow[1:]])

    def _extrema(self):
        """Every extremum of ``y`` (mpmath time and value), in time order."""
        t = self._times()
        d = np.real(np.exp(np.multiply.outer(t, self.fl)) @ self.fr)
        out = []
        with mp.workdps(DPS):
            for i in np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0):
                s = mp.findroot(self._dy, (mp.mpf(t[i]), mp.mpf(t[i + 1])), solver="anderson")
                out.append((s, self._y(s)))
        return out

    def peak(self, sign=1.0):
        """The largest ``sign * y`` over ``t >= 0``."""
        if self.fs is not None:
            return self._sampled_peak(sign)
        with mp.workdps(DPS):
            vals = [sign * v for _, v in self._extrema()] + [sign * self._y(0), sign * self.final]
            return float(max(vals))

    def settling(self):
        """The last time ``|y - final| > 2 % |final|`` (s), or the first sample back in
        the band (s, sampled)."""
        if self.fs is not None:
            return self._sampled_settling()
        with mp.workdps(DPS):
            f, tol = self.final, BAND * abs(self.final)
            ext = [(mp.mpf(0), self._y(0))] + self._extrema()
            out = [i for i, (_, v) in enumerate(ext) if abs(v - f) > tol]
            if not out:
                return 0.0
            i = out[-1]
            a = ext[i][0]
            b = ext[i + 1][0] if i + 1 < len(ext) else a + 40 / min(-mp.re(l) for l in self.lam)
            g = lambda s: abs(self._y(s) - f) - tol
            return float(mp.findroot(g, (a, b), solver="anderson"))

    # ------------------------------------------------------------------ sampled
    def _samples(self):
        n = int(40 / np.min(-np.log(np.abs(self.fl))))
        k = np.arange(n)
        return k, float(mp.re(self.base)) + np.real((1 - np.power.outer(self.fl, k)).T @ self.fr)

    def _sample(self, k):
        with mp.workdps(DPS):
            return mp.re(self.base + sum(c * (1 - p ** int(k)) for c, p in zip(self.c, self.p)))

    def _sampled_peak(self, sign):
        k, y = self._samples()
        sy = sign * y
        near = k[sy >= sy.max() - 1e-9 * max(1.0, abs(sy.max()))]
        with mp.workdps(DPS):
            return float(max(sign * self._sample(j) for j in near))

    def _sampled_settling(self):
        k, y = self._samples()
        f, tol = float(self.final), BAND * abs(float(self.final))
        dev = np.abs(y - f) - tol
        with mp.workdps(DPS):
            exact = {int(j): abs(self._sample(j) - self.final) - BAND * abs(self.final) > 0
                     for j in k[np.abs(dev) < 1e-9]}
        out = [int(j) for j in k if exact.get(int(j), dev[j] > 0)]
        return (out[-1] + 1) / self.fs if out else 0.0
