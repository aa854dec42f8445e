"""The level-set kernel of :mod:`robrst.core.peaks`: one peak computation in the scaled variable.

:class:`Level` holds one numerator over a denominator (realisation, stationarity polynomial
of ``|G|^2``, band); :func:`run_levels` drives several together: the stationary points as
candidates, then level-set verifications (the Hamiltonian's imaginary eigenvalues at the
current value ``(1 + 2 rtol)``) until no interval lies above, the levels of one state
dimension advanced together (:mod:`robrst.core._levelbatch`, each stage one stacked
computation; a lone level in scalars, the same steps).  :mod:`robrst.core.peaks` is the public
entry (module docstring there).
"""

from __future__ import annotations

import copy
import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti
from robrst.core._levelbatch import LOOSE, Batch, One, derivative, gain

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["Peak", "Level", "run_levels", "mag2_poly", "LOOSE", "MAX_SPREAD"]

MAX_SPREAD = 1e12   # pole-magnitude ratio beyond which float64 eigenvalues cannot verify


@dataclass(frozen=True)
class Peak:
    """Exact peak ``value`` of ``|G(jw)|`` at ``freq_rad_s`` (inf if at w = inf).

    Parameters
    ----------
    value : float
        The peak gain (``inf`` for an improper ``G`` or a pole on the imaginary axis).
    freq_rad_s : float
        Where it is attained [rad/s] (``inf``: the limit at infinite frequency).
    verified : bool
        False when the poles of ``D`` span more than ``MAX_SPREAD`` (12 decades):
        double-precision eigenvalues then cannot prove that no higher peak exists, and
        ``value`` is the best of the level-set iteration and a dense scan (a lower bound).
    """

    value: float
    freq_rad_s: float
    verified: bool = True


def mag2_poly(c: ArrayLike) -> np.ndarray:
    """Polynomial ``q`` in ``x = w**2`` with ``|c(jw)|**2 == q(w**2)`` (length ``len(c)``).

    Parameters
    ----------
    c : array_like
        Real coefficients in s, highest power first.

    Returns
    -------
    numpy.ndarray
        Coefficients of ``q`` in ``x``, highest power first.

    Examples
    --------
    >>> from robrst.core.peaks import mag2_poly
    >>> mag2_poly([1.0, 2.0]).tolist()          # |jw + 2|^2 = w^2 + 4
    [1.0, 4.0]
    """
    c = np.asarray(c, dtype=float)
    sign = _signs(len(c))
    e = np.convolve(c, c * sign)          # c(s) c(-s), even, degree 2d
    return e[::2] * sign                  # s^(2k) = (-x)^k


@functools.lru_cache(maxsize=64)
def _signs(length):
    """``(-1) ** [d, ..., 1, 0]`` for ``d = length - 1`` (read-only: shared)."""
    s = (-1.0) ** np.arange(length - 1, -1, -1)
    s.flags.writeable = False
    return s


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
    if len(mats) == 1:               # one problem (a single peak): no batching to do
        return [np.zeros(0, complex) if mats[0] is None else np.linalg.eigvals(mats[0])]
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


class Level:
    """One peak computation in the scaled variable (module docstring): candidates from
    the stationarity polynomial, then level-set verifications until none lies above."""

    def __init__(self, N, D, sc, band, like=None):
        """``like``: a level of the same ``D`` and scaling whose denominator parts (scaled
        ``D``, ``|D|^2`` and its derivative, the spread test) are reused."""
        self.w0 = sc.w0
        if like is None:
            Ds = sc.apply(D)
            self.lead, ds, n = Ds[0], Ds / Ds[0], len(Ds) - 1
        else:
            self.lead, ds, n = like.lead, like.NDs[1], like.n
        Ns = sc.apply(N)
        self.NDs = NDs = np.zeros((2, n + 1))
        NDs[0, n + 1 - len(Ns):] = Ns / self.lead
        NDs[1] = ds
        # unbalanced: LAPACK balances the Hamiltonian itself.  ``A, B`` depend on the
        # denominator alone: ``like``'s (never written to), ``C = ns[1:] - d ds[1:]``
        if like is None:
            self.A, self.B, self.C, self.d = lti.companion_monic(NDs[0], NDs[1], balance=False)
        else:
            self.A, self.B, self.d = like.A, like.B, float(NDs[0, 0])
            self.C = (NDs[0, 1:] - self.d * ds[1:]).reshape(1, n)
        self._set_band(band)
        self.n, self.roots = n, None
        if n:
            qN = mag2_poly(NDs[0])
            if like is None:
                self.qD = mag2_poly(NDs[1])
                self.dqD = derivative(self.qD)
                self.resolvable = _spread(NDs[1]) <= MAX_SPREAD
            else:
                self.qD, self.dqD, self.resolvable = like.qD, like.dqD, like.resolvable
            self.P = np.convolve(derivative(qN), self.qD) - np.convolve(qN, self.dqD)
            self.verified = self.resolvable

    def _set_band(self, band):
        self.done = False
        if band is None:
            self.lo, self.hi, self.edges = 0.0, np.inf, np.array([0.0])
            return
        lo, hi = (float(b) / self.w0 for b in band)
        if not 0 <= lo <= hi:
            raise ValueError(f"peak_gain: band must satisfy 0 <= lo <= hi, got {band}")
        self.lo, self.hi = lo, hi
        self.edges = np.array([lo, hi]) if np.isfinite(hi) else np.array([lo])

    def banded(self, band):
        """The same numerator over ``band`` [rad/s]: realisation, stationarity polynomial
        and its roots (stationary points) shared, candidates and verification its own."""
        other = copy.copy(self)
        other._set_band(band)
        if self.n:
            other.verified = self.resolvable
        return other

    def stationary(self):
        """Companion matrix whose eigenvalues are the stationary points (x = nu**2)."""
        return _companion_matrix(self.P) if self.n else None

    def start_constant(self):
        """A constant ``N/D`` (``n = 0``): its value, at the band's lower edge."""
        self.g, self.w_pk, self.done = float(gain(self.NDs, self.edges[:1])[0]), \
            float(self.edges[0]), True

    def result(self):
        g, w_pk = self.g, self.w_pk
        if self.n and not self.verified:   # beyond what the eigenvalues resolve: a scan too
            g, w_pk = _scan(self.NDs, np.abs(_roots(self.NDs[1])), self.lo, self.hi, g, w_pk)
        return Peak(g, w_pk * self.w0 if np.isfinite(w_pk) else np.inf, bool(self.verified)
                    if self.n else True)


def run_levels(levels, rtol, max_iter):
    """Drive the peak computations ``levels`` together (stationary points computed unless
    a level has them from the level it was banded from), those of one state dimension
    as one :class:`robrst.core._levelbatch.Batch`."""
    new = [lv for lv in levels if lv.n and lv.roots is None]
    for lv, roots in zip(new, _eigvals_many([lv.stationary() for lv in new])):
        lv.roots = roots
    groups = {}
    for lv in levels:
        if lv.n == 0:
            lv.start_constant()
        else:
            groups.setdefault(lv.n, []).append(lv)
    for group in groups.values():
        b = Batch(group) if len(group) > 1 else One(group[0])
        b.start()
        for _ in range(max_iter):
            rows = b.live()
            if not rows.size:
                break
            b.step(rows, np.linalg.eigvals(b.levels(rows, rtol)), rtol)
        for lv, (g, w, done) in zip(group, b.results()):
            lv.g, lv.w_pk, lv.done = g, w, done
            if not done:
                lv.verified = False      # max_iter verifications did not settle it
    return [lv.result() for lv in levels]


def _scan(NDs, mags, lo, hi, g, w_pk, per_decade=50):
    """Best of ``(g, w_pk)`` and a dense log scan of the poles' span, refined locally."""
    pos = mags[mags > 0]
    a = max(pos.min() / 1e3 if pos.size else 1e-3, lo if lo > 0 else 0.0)
    b = min(pos.max() * 1e3 if pos.size else 1e3, hi)
    if not b > a > 0:
        return g, w_pk
    t = np.linspace(np.log(a), np.log(b), int(per_decade * np.log10(b / a)) + 2)
    v = gain(NDs, np.exp(t))
    for j in np.argsort(v)[::-1][:4]:
        ta, tb = t[max(j - 1, 0)], t[min(j + 1, len(t) - 1)]
        for _ in range(6):
            tt = np.linspace(ta, tb, 33)
            vv = gain(NDs, np.exp(tt))
            k = int(np.argmax(vv))
            if vv[k] > g:
                g, w_pk = float(vv[k]), float(np.exp(tt[k]))
            ta, tb = tt[max(k - 1, 0)], tt[min(k + 1, 32)]
    return g, w_pk
