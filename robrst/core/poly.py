"""Polynomial helpers (numpy order: highest power first) with frequency scaling.

The paper's plant has coefficients from 1 to 1e10 and closed-loop polynomials reach
1e24.  Every algorithm in robrst works in the scaled Laplace variable ``p = s / w0``
where these spans shrink to a few decades; :func:`to_scaled` and :func:`from_scaled`
move coefficient vectors between the two.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = [
    "Scaling",
    "conv_generic",
    "as_poly",
    "trim",
    "degree",
    "padd",
    "pmul",
    "pprod",
    "to_scaled",
    "from_scaled",
    "monic",
    "eval_jw",
    "natural_scale",
    "from_roots",
    "roots_many",
    "rel_coef_error",
    "origin_roots",
    "ORIGIN_RTOL",
]

ORIGIN_RTOL = 1e-12   # a root within this fraction of the other roots' scale of s = 0 is at 0


def as_poly(c: ArrayLike, name: str = "polynomial") -> np.ndarray:
    """Return ``c`` as a 1-D float array of finite coefficients, leading zeros trimmed.

    Parameters
    ----------
    c : array_like
        Coefficients, highest power first.
    name : str
        What the polynomial is, for the error message.

    Returns
    -------
    numpy.ndarray
        A new float array (at least one coefficient).

    Raises
    ------
    ValueError
        For an empty or multi-dimensional input, or a coefficient that is not finite.

    Examples
    --------
    >>> from robrst.core.poly import as_poly
    >>> as_poly([0, 0, 1, 2]).tolist()
    [1.0, 2.0]
    """
    a = np.atleast_1d(np.asarray(c, dtype=float))
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-D list of coefficients")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: coefficients must be finite, got {a.tolist()}")
    return trim(a)


def trim(c: ArrayLike) -> np.ndarray:
    """Drop leading zeros (keep at least one coefficient).

    Parameters
    ----------
    c : array_like
        Coefficients, highest power first.

    Returns
    -------
    numpy.ndarray
        A new float array; ``[0.0]`` for the zero polynomial.
    """
    c = np.asarray(c, dtype=float)
    if c.size and c[0] != 0.0:
        return c.copy()
    nz = np.flatnonzero(c != 0.0)
    return c[nz[0]:].copy() if nz.size else np.zeros(1)


def degree(c: ArrayLike) -> int:
    """Degree of a trimmed coefficient vector (0 for constants).

    Parameters
    ----------
    c : array_like
        Coefficients, highest power first.

    Returns
    -------
    int
    """
    return len(trim(c)) - 1


def padd(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Sum of two polynomials.

    Parameters
    ----------
    a, b : array_like
        Coefficients, highest power first (any lengths).

    Returns
    -------
    numpy.ndarray
        The coefficients of ``a + b``, leading zeros trimmed.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < len(b):
        a, b = b, a
    out = a.copy()
    out[len(a) - len(b):] += b
    return trim(out)


def pmul(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Product of two polynomials.

    Parameters
    ----------
    a, b : array_like
        Coefficients, highest power first.

    Returns
    -------
    numpy.ndarray
        The coefficients of ``a * b``, leading zeros trimmed.
    """
    return trim(np.convolve(np.asarray(a, float), np.asarray(b, float)))


def pprod(*polys: ArrayLike) -> np.ndarray:
    """Product of any number of polynomials (1 for none).

    Parameters
    ----------
    *polys : array_like
        Coefficients, highest power first.

    Returns
    -------
    numpy.ndarray
        The coefficients of the product; ``[1.0]`` when no polynomial is given.
    """
    out = np.ones(1)
    for p in polys:
        out = pmul(out, p)
    return out


def to_scaled(c: ArrayLike, w0: float) -> np.ndarray:
    """Coefficients of ``P(w0 * p)`` in ``p`` (no normalisation).

    Parameters
    ----------
    c : array_like
        Coefficients in ``s``, highest power first.
    w0 : float
        Frequency scale [rad/s]; ``s = w0 * p``.

    Returns
    -------
    numpy.ndarray
        ``c[k] * w0**(n - k)`` for a polynomial of length ``n + 1``.
    """
    c = np.asarray(c, dtype=float)
    d = len(c) - 1
    return c * float(w0) ** np.arange(d, -1, -1)


def from_scaled(c: ArrayLike, w0: float) -> np.ndarray:
    """Inverse of :func:`to_scaled`: coefficients in ``s`` of ``Q(s / w0)``.

    Parameters
    ----------
    c : array_like
        Coefficients in ``p``, highest power first.
    w0 : float
        Frequency scale [rad/s].

    Returns
    -------
    numpy.ndarray
    """
    c = np.asarray(c, dtype=float)
    d = len(c) - 1
    return c / float(w0) ** np.arange(d, -1, -1)


def conv_generic(a: Sequence[Any], b: Sequence[Any]) -> list:
    """Coefficients of the product of two polynomials given as sequences of any ring elements.

    Uses only ``+`` and ``*``, so the entries may be floats or CasADi symbols (the twin's
    symbolic model and the numeric family share one thermal law through it).

    Parameters
    ----------
    a, b : sequence
        Coefficients, highest power first (floats, CasADi symbols, ...).

    Returns
    -------
    list
        The ``len(a) + len(b) - 1`` coefficients of the product.
    """
    a, b = list(a), list(b)
    out = [0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] = out[i + j] + x * y
    return out


@dataclass(frozen=True)
class Scaling:
    """The frequency scaling ``s = w0 p`` that every algorithm of robrst works in.

    Coefficients from 1 to 1e10 (closed loops: 1e24) become O(1) in the scaled variable
    ``p``.  :meth:`normalize` maps a polynomial ``c(s)`` of (nominal) degree ``n`` to
    ``c(w0 p) / w0**n`` (monic stays monic; ratios of polynomials of equal nominal degree
    are unchanged); :meth:`denormalize` undoes it.  :meth:`apply`/:meth:`undo` are the
    plain substitution ``c(w0 p)`` and its inverse; :meth:`freq`/:meth:`unfreq` map
    frequencies.

    Parameters
    ----------
    w0 : float
        The frequency scale [rad/s].

    Examples
    --------
    >>> sc = Scaling(10.0)
    >>> sc.normalize([1.0, 20.0, 300.0]).tolist()
    [1.0, 2.0, 3.0]
    >>> sc.denormalize(sc.normalize([2.0, 5.0])).tolist()
    [2.0, 5.0]
    """

    w0: float

    @classmethod
    def natural(cls, *polys: ArrayLike) -> Scaling:
        """The scaling at the geometric mean of the polynomials' root moduli.

        Parameters
        ----------
        *polys : array_like
            Coefficients, highest power first (see :func:`natural_scale`).

        Returns
        -------
        Scaling
        """
        return cls(natural_scale(*polys))

    def apply(self, c: ArrayLike) -> np.ndarray:
        """Coefficients of ``c(w0 p)`` in ``p``.

        Parameters
        ----------
        c : array_like
            Coefficients in ``s``, highest power first.

        Returns
        -------
        numpy.ndarray
        """
        return to_scaled(c, self.w0)

    def undo(self, c: ArrayLike) -> np.ndarray:
        """Coefficients in ``s`` of ``c(s / w0)``.

        Parameters
        ----------
        c : array_like
            Coefficients in ``p``, highest power first.

        Returns
        -------
        numpy.ndarray
        """
        return from_scaled(c, self.w0)

    def normalize(self, c: ArrayLike, degree: int | None = None) -> np.ndarray:
        """``c(w0 p) / w0**degree`` (``degree`` defaults to ``len(c) - 1``).

        Parameters
        ----------
        c : array_like
            Coefficients in ``s``, highest power first.
        degree : int, optional
            The nominal degree (of the larger polynomial of a ratio).

        Returns
        -------
        numpy.ndarray
        """
        c = np.asarray(c, dtype=float)
        n = len(c) - 1 if degree is None else degree
        return to_scaled(c, self.w0) / float(self.w0) ** n

    def denormalize(self, c: ArrayLike, degree: int | None = None) -> np.ndarray:
        """Inverse of :meth:`normalize`: coefficients in ``s``.

        Parameters
        ----------
        c : array_like
            Normalised coefficients in ``p``, highest power first.
        degree : int, optional
            The nominal degree used by :meth:`normalize`.

        Returns
        -------
        numpy.ndarray
        """
        c = np.asarray(c, dtype=float)
        n = len(c) - 1 if degree is None else degree
        return from_scaled(c, self.w0) * float(self.w0) ** n

    def freq(self, w: ArrayLike) -> np.ndarray:
        """Physical frequency [rad/s] -> scaled frequency (complex values allowed).

        Parameters
        ----------
        w : array_like
            Frequencies [rad/s] (or complex points of the s-plane).

        Returns
        -------
        numpy.ndarray
            ``w / w0``.
        """
        return np.asarray(w) / self.w0

    def unfreq(self, nu: ArrayLike) -> np.ndarray:
        """Scaled frequency -> physical frequency [rad/s] (complex values allowed).

        Parameters
        ----------
        nu : array_like
            Scaled frequencies (or points of the p-plane).

        Returns
        -------
        numpy.ndarray
            ``nu * w0``.
        """
        return np.asarray(nu) * self.w0


def monic(c: ArrayLike) -> np.ndarray:
    """Divide by the leading coefficient.

    Parameters
    ----------
    c : array_like
        Coefficients, highest power first (leading zeros are trimmed first).

    Returns
    -------
    numpy.ndarray
        The monic polynomial.
    """
    c = trim(c)
    return c / c[0]


def eval_jw(c: ArrayLike, w: float | ArrayLike) -> np.complex128 | np.ndarray:
    """Evaluate a polynomial at ``s = j*w`` (vectorised in ``w``).

    One frequency (a root polish calls this many times): Horner's rule in Python complex
    arithmetic, the same operations as ``numpy.polyval`` without its array overhead.

    Parameters
    ----------
    c : array_like
        Coefficients in ``s``, highest power first.
    w : float or array_like
        Frequency or frequencies [rad/s].

    Returns
    -------
    numpy.complex128 or numpy.ndarray
        ``c(jw)``: a scalar for a scalar ``w``, else an array of ``w``'s shape.

    Examples
    --------
    >>> from robrst.core.poly import eval_jw
    >>> complex(eval_jw([1.0, 0.0, 4.0], 2.0))
    0j
    """
    if np.ndim(w) == 0:
        s, out = 1j * float(w), 0j
        for a in np.asarray(c, float).tolist():
            out = out * s + a
        return np.complex128(out)
    return np.polyval(np.asarray(c, float), 1j * np.asarray(w, float))


def natural_scale(*polys: ArrayLike) -> float:
    """A frequency scale [rad/s]: geometric mean of the moduli of the non-zero roots.

    Computed in closed form, without an eigenvalue problem: a polynomial of degree
    ``n`` with ``k`` trailing zero coefficients has ``n - k`` non-zero roots whose
    product has modulus ``|c[n-k] / c[0]|``.

    Parameters
    ----------
    *polys : array_like
        Coefficients, highest power first.

    Returns
    -------
    float
        The scale; 1.0 when no polynomial has a non-zero root.

    Examples
    --------
    >>> from robrst.core.poly import natural_scale
    >>> round(natural_scale([1.0, 101.0, 100.0]), 12)     # roots -1 and -100
    10.0
    """
    log_sum, count = 0.0, 0
    for p in polys:
        p = trim(p)
        nz = np.flatnonzero(p)
        if nz.size == 0:
            continue
        k = len(p) - 1 - nz[-1]          # roots at zero
        n = len(p) - 1 - k
        if n > 0:
            log_sum += float(np.log(abs(p[n] / p[0])))
            count += n
    return float(np.exp(log_sum / count)) if count else 1.0


def from_roots(roots: ArrayLike) -> np.ndarray:
    """Real monic polynomial with the given roots (conjugates must be listed).

    Parameters
    ----------
    roots : array_like
        Real and complex roots; every complex root with its conjugate.

    Returns
    -------
    numpy.ndarray
        The real coefficients, highest power first (``[1.0]`` for no roots).

    Raises
    ------
    ValueError
        When the roots do not form conjugate pairs.
    """
    c = np.atleast_1d(np.poly(np.asarray(roots, dtype=complex)))   # no roots: [1.0]
    if np.max(np.abs(c.imag)) > 1e-9 * max(1.0, np.max(np.abs(c.real))):
        raise ValueError("roots do not form conjugate pairs; polynomial is not real")
    return c.real.copy()


def roots_many(polys: Sequence[ArrayLike]) -> list[np.ndarray]:
    """``numpy.roots`` of each polynomial, the eigenvalue problems of equal degree in one
    batched LAPACK call (the same companion matrix and routine per polynomial as
    ``numpy.roots``: identical roots).

    Parameters
    ----------
    polys : sequence of array_like
        Coefficients, highest power first.

    Returns
    -------
    list of numpy.ndarray
        The roots of each polynomial, in the order given.
    """
    out, groups = [None] * len(polys), {}
    for i, c in enumerate(polys):
        c = np.atleast_1d(np.asarray(c))
        nz = np.flatnonzero(c)
        if nz.size == 0:
            out[i] = np.array([])
            continue
        c, zeros = c[nz[0]:nz[-1] + 1], len(c) - nz[-1] - 1
        if len(c) < 2:
            out[i] = np.zeros(zeros)
            continue
        M = np.diag(np.ones(len(c) - 2, c.dtype), -1)
        M[0, :] = -c[1:] / c[0]
        groups.setdefault(M.shape, []).append((i, M, zeros))
    for items in groups.values():
        ev = np.linalg.eigvals(np.stack([M for _, M, _ in items]))
        for (i, _, zeros), r in zip(items, ev):
            out[i] = np.hstack((r, np.zeros(zeros, r.dtype)))
    return out


def rel_coef_error(a: ArrayLike, b: ArrayLike) -> float:
    """Largest coefficient-wise error relative to the largest coefficient of ``b``.

    Both polynomials are compared in the scaled variable chosen by
    :func:`natural_scale` on ``b``, so that a 1e24-size constant term does not
    hide errors in the small leading coefficients.

    Parameters
    ----------
    a : array_like
        The polynomial checked.
    b : array_like
        The reference polynomial.

    Returns
    -------
    float
        ``max |a - b| / max |b|`` in the scaled variable.
    """
    a, b = trim(a), trim(b)
    n = max(len(a), len(b))
    a = np.concatenate([np.zeros(n - len(a)), a])
    b = np.concatenate([np.zeros(n - len(b)), b])
    w0 = natural_scale(b)
    sa, sb = to_scaled(a, w0), to_scaled(b, w0)
    return float(np.max(np.abs(sa - sb)) / np.max(np.abs(sb)))


def origin_roots(c: ArrayLike, rtol: float = ORIGIN_RTOL) -> int:
    """How many roots of ``c`` lie at ``s = 0`` (an integrator's, in a controller's ``S``).

    A trailing coefficient is zero when it is exactly zero, or when the root it makes is
    below ``rtol`` times the next root: ``|c[-1] / c[-2]| <= rtol |c[-2] / c[-3]|`` (the
    two smallest root moduli, read from the Newton polygon of the last coefficients).
    That is what rounding does to a polynomial with a root at 0 (a controller read back
    from a discrete python-control system: ``S(0) = -4e-16``); a deliberate ``S(0) != 0``
    leaves a root far larger.  A polynomial of degree one has no other root to compare
    with: only an exact zero counts.

    Parameters
    ----------
    c : array_like
        Coefficients, highest power first.
    rtol : float
        How much smaller than the next root a root counts as 0.

    Returns
    -------
    int
        The number of roots at ``s = 0`` (0 for a constant).

    Examples
    --------
    >>> from robrst.core.poly import origin_roots
    >>> origin_roots([1.0, 3.0, 0.0]), origin_roots([1.0, 3.0, 1e-3]), origin_roots([1.0, 3.0, 1e-16])
    (1, 0, 1)
    """
    c = trim(c)
    k = 0
    while k < len(c) - 1:
        head = c[:len(c) - k]
        if head[-1] != 0:
            if len(head) < 3 or head[-2] == 0 or head[-3] == 0:
                break
            if not abs(head[-1] / head[-2]) <= rtol * abs(head[-2] / head[-3]):
                break
        k += 1
    return k
