"""Polynomial helpers (numpy order: highest power first) with frequency scaling.

The paper's plant has coefficients from 1 to 1e10 and closed-loop polynomials reach
1e24.  Every algorithm in robrst works in the scaled Laplace variable ``p = s / w0``
where these spans shrink to a few decades; :func:`to_scaled` and :func:`from_scaled`
move coefficient vectors between the two.
"""

from dataclasses import dataclass

import numpy as np

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
]


def as_poly(c, name="polynomial"):
    """Return ``c`` as a 1-D float array of finite coefficients, leading zeros trimmed."""
    a = np.atleast_1d(np.asarray(c, dtype=float))
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-D list of coefficients")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: coefficients must be finite, got {a.tolist()}")
    return trim(a)


def trim(c):
    """Drop leading zeros (keep at least one coefficient)."""
    c = np.asarray(c, dtype=float)
    if c.size and c[0] != 0.0:
        return c.copy()
    nz = np.flatnonzero(c != 0.0)
    return c[nz[0]:].copy() if nz.size else np.zeros(1)


def degree(c):
    """Degree of a trimmed coefficient vector (0 for constants)."""
    return len(trim(c)) - 1


def padd(a, b):
    """Sum of two polynomials."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < len(b):
        a, b = b, a
    out = a.copy()
    out[len(a) - len(b):] += b
    return trim(out)


def pmul(a, b):
    """Product of two polynomials."""
    return trim(np.convolve(np.asarray(a, float), np.asarray(b, float)))


def pprod(*polys):
    """Product of any number of polynomials (1 for none)."""
    out = np.ones(1)
    for p in polys:
        out = pmul(out, p)
    return out


def to_scaled(c, w0):
    """Coefficients of ``P(w0 * p)`` in ``p`` (no normalisation).

    Parameters
    ----------
    c : array_like
        Coefficients in ``s``, highest power first.
    w0 : float
        Frequency scale [rad/s]; ``s = w0 * p``.
    """
    c = np.asarray(c, dtype=float)
    d = len(c) - 1
    return c * float(w0) ** np.arange(d, -1, -1)


def from_scaled(c, w0):
    """Inverse of :func:`to_scaled`: coefficients in ``s`` of ``Q(s / w0)``."""
    c = np.asarray(c, dtype=float)
    d = len(c) - 1
    return c / float(w0) ** np.arange(d, -1, -1)


def conv_generic(a, b):
    """Coefficients of the product of two polynomials given as sequences of any ring elements.

    Uses only ``+`` and ``*``, so the entries may be floats or CasADi symbols (the twin's
    symbolic model and the numeric family share one thermal law through it).  Returns a list.
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
    def natural(cls, *polys):
        """The scaling at the geometric mean of the polynomials' root moduli."""
        return cls(natural_scale(*polys))

    def apply(self, c):
        """Coefficients of ``c(w0 p)`` in ``p``."""
        return to_scaled(c, self.w0)

    def undo(self, c):
        """Coefficients in ``s`` of ``c(s / w0)``."""
        return from_scaled(c, self.w0)

    def normalize(self, c, degree=None):
        """``c(w0 p) / w0**degree`` (``degree`` defaults to ``len(c) - 1``)."""
        c = np.asarray(c, dtype=float)
        n = len(c) - 1 if degree is None else degree
        return to_scaled(c, self.w0) / float(self.w0) ** n

    def denormalize(self, c, degree=None):
        """Inverse of :meth:`normalize`: coefficients in ``s``."""
        c = np.asarray(c, dtype=float)
        n = len(c) - 1 if degree is None else degree
        return from_scaled(c, self.w0) * float(self.w0) ** n

    def freq(self, w):
        """Physical frequency [rad/s] -> scaled frequency (complex values allowed)."""
        return np.asarray(w) / self.w0

    def unfreq(self, nu):
        """Scaled frequency -> physical frequency [rad/s] (complex values allowed)."""
        return np.asarray(nu) * self.w0


def monic(c):
    """Divide by the leading coefficient."""
    c = trim(c)
    return c / c[0]


def eval_jw(c, w):
    """Evaluate a polynomial at ``s = j*w`` (vectorised in ``w``).

    One frequency (a root polish calls this many times): Horner's rule in Python complex
    arithmetic, the same operations as ``numpy.polyval`` without its array overhead.
    """
    if np.ndim(w) == 0:
        s, out = 1j * float(w), 0j
        for a in np.asarray(c, float).tolist():
            out = out * s + a
        return np.complex128(out)
    return np.polyval(np.asarray(c, float), 1j * np.asarray(w, float))


def natural_scale(*polys):
    """A frequency scale [rad/s]: geometric mean of the moduli of the non-zero roots.

    Computed in closed form, without an eigenvalue problem: a polynomial of degree
    ``n`` with ``k`` trailing zero coefficients has ``n - k`` non-zero roots whose
    product has modulus ``|c[n-k] / c[0]|``.  Returns 1.0 when no polynomial has a
    non-zero root.
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


def from_roots(roots):
    """Real monic polynomial with the given roots (conjugates must be listed)."""
    c = np.atleast_1d(np.poly(np.asarray(roots, dtype=complex)))   # no roots: [1.0]
    if np.max(np.abs(c.imag)) > 1e-9 * max(1.0, np.max(np.abs(c.real))):
        raise ValueError("roots do not form conjugate pairs; polynomial is not real")
    return c.real.copy()


def roots_many(polys):
    """``numpy.roots`` of each polynomial, the eigenvalue problems of equal degree in one
    batched LAPACK call (the same companion matrix and routine per polynomial as
    ``numpy.roots``: identical roots).

    Parameters
    ----------
    polys : sequence of array_like

    Returns
    -------
    list of ndarray
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


def rel_coef_error(a, b):
    """Largest coefficient-wise error relative to the largest coefficient of ``b``.

    Both polynomials are compared in the scaled variable chosen by
    :func:`natural_scale` on ``b``, so that a 1e24-size constant term does not
    hide errors in the small leading coefficients.
    """
    a, b = trim(a), trim(b)
    n = max(len(a), len(b))
    a = np.concatenate([np.zeros(n - len(a)), a])
    b = np.concatenate([np.zeros(n - len(b)), b])
    w0 = natural_scale(b)
    sa, sb = to_scaled(a, w0), to_scaled(b, w0)
    return float(np.max(np.abs(sa - sb)) / np.max(np.abs(sb)))
