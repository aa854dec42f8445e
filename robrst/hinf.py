"""Exact peak gain of a SISO rational transfer function ``N(s)/D(s)``, globally.

The peak ``sup_w |G(jw)|`` (the H-infinity norm when D is Hurwitz, the L-infinity
norm otherwise), over all ``w >= 0`` or over a band ``[w_lo, w_hi]``, is computed in
the scaled variable ``p = s / w0`` (:class:`robrst.poly.Scaling`) from the two even
polynomials of ``x = nu**2``::

    |N(j nu)|^2 = qN(x),   |D(j nu)|^2 = qD(x).

1. **Candidates.**  Every local maximum of ``|G|^2 = qN/qD`` is a positive real root of
   the stationarity polynomial ``qN' qD - qN qD'``; ``|G|`` is evaluated (complex Horner,
   not through ``qN/qD``) at all of them, at ``w = 0`` and ``w = inf`` (``|N/D|`` limits)
   or at the band edges.  The largest value is a guaranteed lower bound ``g``.
2. **Level-set verification** (Bruinsma–Steinbuch, on the polynomial of the Hamiltonian's
   imaginary eigenvalues): the frequencies where ``|G| = g (1 + 2 rtol)`` are the positive
   real roots of ``qN - g^2 (1 + 2 rtol)^2 qD``.  Between two consecutive crossings (or a
   crossing and a band edge) ``|G|`` is on one side of the level; ``|G|`` is evaluated at
   every geometric midpoint and crossing, and ``g`` raised to the best value, until no
   interval lies above the level.  Roots are accepted as real loosely (imaginary part up to
   5 % of the modulus): a spurious crossing only costs an evaluation, a missed one could
   lose a peak.

On return the supremum lies in ``[value, value (1 + 2 rtol)]``: no frequency has a larger
gain (the verification found none at that level), and ``value`` is attained at
``freq_rad_s``.  The peak frequency is polished by Newton steps on the stationarity
polynomial.  An ``n``-th order ``D`` costs one eigenvalue problem of size ``2n - 1`` and
usually one Hamiltonian of size ``2n``.  :func:`peak_gains` computes the peaks of several
numerators over one denominator (the certificate's S, T and U) with the same arithmetic,
their eigenvalue problems batched.
"""

from dataclasses import dataclass

import numpy as np

from robrst import lti, poly

__all__ = ["Peak", "peak_gain", "peak_gains", "mag2_poly"]

LOOSE = 0.05   # roots with |Im x| <= LOOSE |x| are treated as real (candidates only)
MAX_SPREAD = 1e12   # pole-magnitude ratio beyond which float64 eigenvalues cannot verify


@dataclass(frozen=True)
class Peak:
    """Exact peak ``value`` of ``|G(jw)|`` at ``freq_rad_s`` (inf if at w = inf).

    ``verified`` is false when the poles of ``D`` span more than ``MAX_SPREAD`` (12
    decades): double-precision eigenvalues then cannot prove that no higher peak exists,
    and ``value`` is the best of the level-set iteration and a dense scan (a lower bound).
    """

    value: float
    freq_rad_s: float
    verified: bool = True


def mag2_poly(c):
    """Polynomial ``q`` in ``x = w**2`` with ``|c(jw)|**2 == q(w**2)`` (length ``len(c)``)."""
    c = np.asarray(c, dtype=float)
    d = len(c) - 1
    sign = (-1.0) ** np.arange(d, -1, -1)
    e = np.convolve(c, c * sign)          # c(s) c(-s), even, degree 2d
    return e[::2] * sign                  # s^(2k) = (-x)^k


def _companion_matrix(c):
    """Companion matrix of ``c`` (leading zeros dropped; ``None`` below degree 1)."""
    nz = np.flatnonzero(c)
    if nz.size == 0:
        return None
    c = c[nz[0]:]
    n = len(c) - 1
    if n < 1:
        return None
    M = np.zeros((n, n))
    M[0, :] = -c[1:] / c[0]
    M.flat[n::n + 1] = 1.0
    return M


def _roots(c):
    """Roots of ``c`` (leading zeros dropped) from its companion matrix."""
    M = _companion_matrix(c)
    return np.zeros(0, complex) if M is None else np.linalg.eigvals(M)


def _eigvals_many(mats):
    """Eigenvalues of each matrix (``None``: none), equal shapes in one batched call
    (the same LAPACK routine per matrix as one call each: identical values)."""
    out = [np.zeros(0, complex)] * len(mats)
    groups = {}
    for i, M in enumerate(mats):
        if M is not None:
            groups.setdefault(M.shape, []).append(i)
    for idx in groups.values():
        ev = np.linalg.eigvals(np.stack([mats[i] for i in idx]))
        for i, e in zip(idx, ev):
            out[i] = e
    return out


def _positive_real(r):
    keep = (np.abs(r.imag) <= LOOSE * np.abs(r)) & (r.real > 0)
    return np.sqrt(r.real[keep])


def _gain(NDs, nu):
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


def _spread(c):
    """Ratio of the largest to the smallest non-zero root modulus of ``c``, estimated
    from its Newton polygon (within a factor of about ``4 deg c``)."""
    a = np.abs(c)
    nz = np.flatnonzero(a)
    a = a[nz[0]:nz[-1] + 1]
    n = len(a) - 1
    if n < 1:
        return 1.0
    k = 1.0 / np.arange(1, n + 1)
    big = np.max((a[1:] / a[0]) ** k)
    return float(big * np.max((a[-2::-1] / a[-1]) ** k))


def _horner(c, x):
    out = 0.0
    for a in c:
        out = out * x + a
    return out


def _hamiltonian(A, B, C, d, g):
    """Hamiltonian whose imaginary eigenvalues ``j nu`` are the frequencies where |G| = g."""
    n = A.shape[0]
    R = d * d - g * g
    H = np.empty((2 * n, 2 * n))
    H[:n, :n] = A - (d / R) * (B @ C)
    H[:n, n:] = (-g / R) * (B @ B.T)
    H[n:, :n] = (g / R) * (C.T @ C)
    H[n:, n:] = -H[:n, :n].T
    return H


def _polish(P, NDs, nu, g):
    """Newton on the stationarity polynomial ``P`` in ``x = nu^2`` near ``nu``.

    Returns the polished point unless it is lower than the start (beyond rounding).
    """
    P = P.tolist()
    dP = [a * k for a, k in zip(P, range(len(P) - 1, 0, -1))]
    x0 = x = nu * nu
    for _ in range(12):
        den = _horner(dP, x)
        if den == 0:
            return g, nu
        step = _horner(P, x) / den
        x = x - step
        if not (x0 / 1.2 < x < x0 * 1.2):
            return g, nu
        if abs(step) <= 1e-15 * x:
            break
    nup = float(np.sqrt(x))
    gp = float(_gain(NDs, [nup])[0])
    return (gp, nup) if gp >= g * (1 - 1e-13) else (g, nu)


def _prepare(N, D):
    """Trimmed ``N, D`` with common factors ``s^k`` cancelled."""
    N, D = poly.trim(N), poly.trim(D)
    if not np.any(D):
        raise ValueError("peak_gain: the denominator is identically zero")
    while len(N) > 1 and len(D) > 1 and N[-1] == 0.0 and D[-1] == 0.0:
        N, D = N[:-1], D[:-1]
    return N, D


def peak_gain(N, D, rtol=1e-10, scaling=None, max_iter=60, band=None):
    """Exact peak of ``|N(jw)/D(jw)|`` over ``w >= 0`` (or over a band).

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s (rad/s), highest power first.
    rtol : float
        Relative accuracy: the supremum lies in ``[value, value (1 + 2 rtol)]``.
    scaling : Scaling, optional
        Frequency scaling; default: at the geometric mean of the root moduli of D.
    max_iter : int
        Cap on the level-set verifications (each raises the value by ``> rtol``).
    band : (float, float), optional
        ``(w_lo, w_hi)`` [rad/s]: the frequency-limited peak over that closed band
        (``w_hi = inf``: everything above ``w_lo``, the limit at infinity included).

    Returns
    -------
    Peak
        ``value`` (``inf`` for ``deg N > deg D`` or a pole on the imaginary axis) and the
        frequency where it is attained (``inf``: the limit at infinite frequency).

    Examples
    --------
    >>> from robrst.hinf import peak_gain
    >>> pk = peak_gain([1.0], [1.0, 0.2, 1.0])          # 1 / (s^2 + 0.2 s + 1)
    >>> round(pk.value, 6), round(pk.freq_rad_s, 6)
    (5.025189, 0.989949)
    >>> round(peak_gain([1.0], [1.0, 0.2, 1.0], band=(2.0, 3.0)).value, 6)   # at the edge 2 rad/s
    0.330409
    """
    N, D = _prepare(N, D)
    if len(N) > len(D):
        return Peak(np.inf, np.inf)
    with np.errstate(all="ignore"):   # inf at a pole on the axis is a valid answer
        return _peak(N, D, rtol, scaling, max_iter, band)


def _peak(N, D, rtol, scaling, max_iter, band):
    if not np.any(N):
        return Peak(0.0, 0.0 if band is None else float(band[0]))
    return _run([_Level(N, D, scaling or poly.Scaling.natural(D), band)], rtol, max_iter)[0]


class _Level:
    """One peak computation in the scaled variable (module docstring): candidates from
    the stationarity polynomial, then level-set verifications until none lies above."""

    def __init__(self, N, D, sc, band):
        self.w0 = sc.w0
        self.A, self.B, self.C, self.d = lti.companion(N, D, sc, balance=False)  # LAPACK
        Ns, Ds = sc.apply(N), sc.apply(D)                                      # balances H
        n = len(Ds) - 1
        self.NDs = NDs = np.zeros((2, n + 1))
        NDs[0, n + 1 - len(Ns):] = Ns / Ds[0]
        NDs[1] = Ds / Ds[0]
        if band is None:
            self.lo, self.hi, self.edges = 0.0, np.inf, np.array([0.0])
        else:
            lo, hi = (float(b) / sc.w0 for b in band)
            if not 0 <= lo <= hi:
                raise ValueError(f"peak_gain: band must satisfy 0 <= lo <= hi, got {band}")
            self.lo, self.hi = lo, hi
            self.edges = np.array([lo, hi]) if np.isfinite(hi) else np.array([lo])
        self.n, self.done = n, False
        if n:
            qN, qD = mag2_poly(NDs[0]), mag2_poly(NDs[1])
            self.P = np.convolve(np.polyder(qN), qD) - np.convolve(qN, np.polyder(qD))
            self.verified = _spread(NDs[1]) <= MAX_SPREAD

    def stationary(self):
        """Companion matrix whose eigenvalues are the stationary points (x = nu**2)."""
        return _companion_matrix(self.P) if self.n else None

    def start(self, roots):
        """The best candidate among the stationary points, edges and the limit at inf."""
        if self.n == 0:
            self.g, self.w_pk, self.done = float(_gain(self.NDs, self.edges[:1])[0]), \
                float(self.edges[0]), True
            return
        lo, hi = self.lo, self.hi
        nu = np.concatenate([self.edges, _positive_real(roots)])
        nu = nu[(nu >= lo) & (nu <= hi)]
        vals = _gain(self.NDs, nu)
        i = int(np.argmax(vals))
        self.g, self.w_pk = float(vals[i]), float(nu[i])
        if hi == np.inf and abs(self.d) >= self.g:
            self.g, self.w_pk = abs(self.d), np.inf
        self._polish()

    def _polish(self):
        if 0 < self.w_pk < np.inf:
            g2, w2 = _polish(self.P, self.NDs, self.w_pk, self.g)
            if self.lo <= w2 <= self.hi:
                self.g, self.w_pk = g2, w2

    def level(self, rtol):
        """The Hamiltonian of the next verification (``None``: nothing left to verify)."""
        if self.done or not np.isfinite(self.g) or self.g == 0.0:
            self.done = True
            return None
        return _hamiltonian(self.A, self.B, self.C, self.d, self.g * (1 + 2 * rtol))

    def step(self, ev, rtol):
        """Evaluate between the level's crossings (eigenvalues ``ev``); done when none is
        above the level, else the value is raised to the best point found."""
        lo, hi = self.lo, self.hi
        keep = (np.abs(ev.real) <= LOOSE * np.abs(ev)) & (ev.imag > 0)
        ws = ev.imag[keep]
        ws = np.sort(np.concatenate([self.edges, ws[(ws > lo) & (ws < hi)]]))
        mids = np.where(ws[:-1] > 0, np.sqrt(ws[:-1] * ws[1:]), 0.5 * (ws[:-1] + ws[1:]))
        cand = np.concatenate([mids, ws, [2.0 * ws[-1] + 1.0] if hi == np.inf else []])
        v = _gain(self.NDs, cand)
        j = int(np.argmax(v))
        if not v[j] > self.g * (1 + rtol):
            self.done = True
            return
        self.g, self.w_pk = float(v[j]), float(cand[j])
        self._polish()

    def result(self):
        g, w_pk = self.g, self.w_pk
        if self.n and not self.verified:   # beyond what the eigenvalues resolve: a scan too
            g, w_pk = _scan(self.NDs, np.abs(_roots(self.NDs[1])), self.lo, self.hi, g, w_pk)
        return Peak(g, w_pk * self.w0 if np.isfinite(w_pk) else np.inf, bool(self.verified)
                    if self.n else True)


def _run(levels, rtol, max_iter):
    """Drive the peak computations ``levels`` together, their eigenvalue problems batched."""
    for lv, roots in zip(levels, _eigvals_many([lv.stationary() for lv in levels])):
        lv.start(roots)
    for _ in range(max_iter):
        live = [(lv, lv.level(rtol)) for lv in levels]
        live = [(lv, H) for lv, H in live if H is not None]
        if not live:
            break
        for (lv, _), ev in zip(live, _eigvals_many([H for _, H in live])):
            lv.step(ev, rtol)
    for lv in levels:
        if not lv.done:
            lv.verified = False      # max_iter verifications did not settle it
    return [lv.result() for lv in levels]


def peak_gains(Ns, D, rtol=1e-10, max_iter=60):
    """Global peaks of ``|N/D|`` for each numerator of ``Ns`` over the one denominator ``D``.

    The same figures as :func:`peak_gain` of each (same arithmetic), with the scaling of
    ``D`` shared and the eigenvalue problems of all numerators solved in batched calls.

    Returns
    -------
    list of Peak
    """
    D0 = poly.trim(D)
    if not np.any(D0):
        raise ValueError("peak_gain: the denominator is identically zero")
    sc, out, levels = poly.Scaling.natural(D0), {}, {}
    for i, N in enumerate(Ns):
        Ni, Di = _prepare(N, D0)
        if len(Ni) > len(Di):
            out[i] = Peak(np.inf, np.inf)
        elif not np.any(Ni):
            out[i] = Peak(0.0, 0.0)
        elif len(Di) != len(D0):      # a common factor s**k cancelled: its own scaling
            out[i] = peak_gain(Ni, Di, rtol=rtol, max_iter=max_iter)
        else:
            levels[i] = _Level(Ni, Di, sc, None)
    with np.errstate(all="ignore"):
        out.update(zip(levels, _run(list(levels.values()), rtol, max_iter)))
    return [out[i] for i in range(len(Ns))]


def _scan(NDs, mags, lo, hi, g, w_pk, per_decade=50):
    """Best of ``(g, w_pk)`` and a dense log scan of the poles' span, refined locally."""
    pos = mags[mags > 0]
    a = max(pos.min() / 1e3 if pos.size else 1e-3, lo if lo > 0 else 0.0)
    b = min(pos.max() * 1e3 if pos.size else 1e3, hi)
    if not b > a > 0:
        return g, w_pk
    t = np.linspace(np.log(a), np.log(b), int(per_decade * np.log10(b / a)) + 2)
    v = _gain(NDs, np.exp(t))
    for j in np.argsort(v)[::-1][:4]:
        ta, tb = t[max(j - 1, 0)], t[min(j + 1, len(t) - 1)]
        for _ in range(6):
            tt = np.linspace(ta, tb, 33)
            vv = _gain(NDs, np.exp(tt))
            k = int(np.argmax(vv))
            if vv[k] > g:
                g, w_pk = float(vv[k]), float(np.exp(tt[k]))
            ta, tb = tt[max(k - 1, 0)], tt[min(k + 1, 32)]
    return g, w_pk
