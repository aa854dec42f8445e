"""Exact peak gain of a SISO rational transfer function ``N(s)/D(s)``, globally.

The peak ``sup_w |G(jw)|`` (the H-infinity norm when D is Hurwitz, the L-infinity
norm otherwise), over all ``w >= 0`` or over a band ``[w_lo, w_hi]``, is computed in
the scaled variable ``p = s / w0`` (:class:`robrst.core.poly.Scaling`) from the two even
polynomials of ``x = nu**2``::

    |N(j nu)|^2 = qN(x),   |D(j nu)|^2 = qD(x).

1. **Candidates.**  Every local maximum of ``|G|^2 = qN/qD`` is a positive real root of
   the stationarity polynomial ``qN' qD - qN qD'``; ``|G|`` is evaluated (complex Horner,
   not through ``qN/qD``) at all of them, at ``w = 0`` and ``w = inf`` (``|N/D|`` limits)
   or at the band edges.  The largest value is a guaranteed lower bound ``g``.
2. **Level-set verification** (Bruinsma–Steinbuch): the frequencies where
   ``|G| = g (1 + 2 rtol)`` (the positive real roots of ``qN - g^2 (1 + 2 rtol)^2 qD``)
   are the imaginary eigenvalues of the realisation's Hamiltonian at that level
   (:mod:`robrst.core._levelset`).  Between two consecutive crossings (or a
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

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core._levelset import Level, Peak, mag2_poly, run_levels

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["Peak", "peak_gain", "peak_gains", "peak_gains_many", "mag2_poly"]


def _prepare(N, D):
    """Trimmed ``N, D`` with common factors ``s^k`` cancelled."""
    N, D = poly.trim(N), poly.trim(D)
    if not D.any():
        raise ValueError("peak_gain: the denominator is identically zero")
    while len(N) > 1 and len(D) > 1 and N[-1] == 0.0 and D[-1] == 0.0:
        N, D = N[:-1], D[:-1]
    return N, D


def peak_gain(N: ArrayLike, D: ArrayLike, rtol: float = 1e-10, scaling: poly.Scaling | None = None,
              max_iter: int = 60, band: tuple[float, float] | None = None) -> Peak:
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
    >>> from robrst.core.peaks import peak_gain
    >>> pk = peak_gain([1.0], [1.0, 0.2, 1.0])          # 1 / (s^2 + 0.2 s + 1)
    >>> round(pk.value, 6), round(pk.freq_rad_s, 6)
    (5.025189, 0.989949)
    >>> round(peak_gain([1.0], [1.0, 0.2, 1.0], band=(2.0, 3.0)).value, 6)   # at the edge 2 rad/s
    0.330409
    """
    N, D = _prepare(N, D)
    if len(N) > len(D):
        return Peak(np.inf, np.inf)
    if not np.any(N):
        return Peak(0.0, 0.0 if band is None else float(band[0]))
    with np.errstate(all="ignore"):   # inf at a pole on the axis is a valid answer
        lv = Level(N, D, scaling or poly.Scaling.natural(D), band)
        return run_levels([lv], rtol, max_iter)[0]


def peak_gains(Ns: Sequence[ArrayLike], D: ArrayLike, rtol: float = 1e-10, max_iter: int = 60,
               bands: Sequence[tuple[int, tuple[float, float]]] = ()) -> list[Peak]:
    """Global peaks of ``|N/D|`` for each numerator of ``Ns`` over the one denominator ``D``,
    then the band peaks asked for.

    The same figures as :func:`peak_gain` of each (same arithmetic), with the scaling of
    ``D`` shared and the eigenvalue problems of all numerators solved in batched calls.

    Parameters
    ----------
    Ns : sequence of array_like
        Numerators in s, highest power first.
    D : array_like
        The common denominator in s.
    rtol, max_iter : float, int
        As :func:`peak_gain`.
    bands : sequence of (int, (float, float))
        ``(i, (w_lo, w_hi))``: the peak of numerator ``i`` over that band [rad/s]; the
        global peak when it lies in the band (the supremum over a subset that contains
        the global maximiser), else from the global computation's stationary points and
        its own level-set verification.

    Returns
    -------
    list of Peak
        ``len(Ns)`` global peaks, then one per band.
    """
    return peak_gains_many([(Ns, D, bands)], rtol, max_iter)[0]


def peak_gains_many(jobs: Sequence[tuple], rtol: float = 1e-10,
                    max_iter: int = 60) -> list[list[Peak]]:
    """:func:`peak_gains` of several ``(Ns, D, bands)`` jobs (e.g. the closed loops of a
    family's models), the eigenvalue problems of all of them batched.

    Every job's figures are those :func:`peak_gains` gives it alone: each peak computation
    runs its own iteration, only the LAPACK calls on equal-sized matrices are stacked.

    Parameters
    ----------
    jobs : sequence of (Ns, D, bands)
        As the arguments of :func:`peak_gains`.
    rtol, max_iter : float, int
        As :func:`peak_gain`.

    Returns
    -------
    list of list of Peak
        One list per job, as :func:`peak_gains` returns it.
    """
    plans = [_Plan(Ns, D, bands, rtol, max_iter) for Ns, D, bands in jobs]
    with np.errstate(all="ignore"):
        levels = [lv for pl in plans for lv in pl.levels.values()]
        done = iter(run_levels(levels, rtol, max_iter))
        for pl in plans:
            pl.out.update((i, next(done)) for i in pl.levels)
        todo = [pl.band_levels() for pl in plans]
        done = iter(run_levels([lv for t in todo for lv in t.values()], rtol, max_iter))
        return [pl.result({k: next(done) for k in t}) for pl, t in zip(plans, todo)]


class _Plan:
    """One :func:`peak_gains` job: its levels, the peaks found without them, its bands."""

    def __init__(self, Ns, D, bands, rtol, max_iter):
        D0 = poly.trim(D)
        if not D0.any():
            raise ValueError("peak_gain: the denominator is identically zero")
        self.Ns, self.D0, self.bands = Ns, D0, list(bands)
        self.rtol, self.max_iter = rtol, max_iter
        sc, self.out, self.levels = poly.Scaling.natural(D0), {}, {}
        self.res = [None] * len(self.bands)     # band peaks, filled by band_levels/result
        for i, N in enumerate(Ns):
            Ni, Di = _prepare(N, D0)
            if len(Ni) > len(Di):
                self.out[i] = Peak(np.inf, np.inf)
            elif not Ni.any():
                self.out[i] = Peak(0.0, 0.0)
            elif len(Di) != len(D0):      # a common factor s**k cancelled: its own scaling
                self.out[i] = peak_gain(Ni, Di, rtol=rtol, max_iter=max_iter)
            else:
                self.levels[i] = Level(Ni, Di, sc, None,
                                       like=next(iter(self.levels.values()), None))

    def band_levels(self):
        """The band peaks not settled by the global ones: ``{k: Level}`` (band ``k``)."""
        glob, todo = self.out, {}
        for k, (i, band) in enumerate(self.bands):
            if band[0] <= glob[i].freq_rad_s <= band[1]:
                self.res[k] = glob[i]
            elif i in self.levels:
                todo[k] = self.levels[i].banded(band)
            else:
                self.res[k] = peak_gain(self.Ns[i], self.D0, rtol=self.rtol,
                                        max_iter=self.max_iter, band=band)
        return todo

    def result(self, band_peaks):
        """Global peaks, then band peaks (``band_peaks``: those of :meth:`band_levels`)."""
        for k, pk in band_peaks.items():
            self.res[k] = pk
        return [self.out[i] for i in range(len(self.Ns))] + self.res
