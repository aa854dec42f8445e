"""State-space kernels of robrst: the one realisation and the one ZOH discretisation.

The modal (partial-fraction) form of the identified models has its own exact ZOH,
:func:`zoh_modal` (mode by mode, no realisation needed).

Every part of robrst that needs a state-space form of ``N(s)/D(s)`` (exact peaks, the
sampled loop, the twin, the diagnosis's linear simulation) takes it from here, in the
scaled variable ``p = s / w0`` (:class:`robrst.core.poly.Scaling`) where the coefficients are
O(1).  The zero-order-hold discretisation is exact (a matrix exponential), never an
expansion of a polynomial in ``z``, whose roots cluster at ``z = 1`` and are lost to
cancellation at high sampling rates.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from robrst.core import poly

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["companion_parts", "companion", "companion_monic", "companion_outputs",
           "companion_outputs_many", "DiscreteSS",
           "zoh", "zoh_matrices", "zoh_modal", "d2c_modal", "modal_polynomials",
           "transmission_zeros", "ss_to_poly", "d2c", "split_modes", "least_control_peak"]


def companion_parts(a: Sequence[Any], b: Sequence[Any]) -> tuple[list, list, Any]:
    """The controllable canonical form of ``b/a`` as plain sequences.

    For monic ``a`` (length ``n + 1``) and ``len(b) <= n + 1`` (highest power first),
    ``b/a = C (pI - A)^-1 B + d`` with ``A``'s first row ``-a[1:]``, ones on the
    subdiagonal, ``B = e1``.  Only ``+``, ``-`` and ``*`` are used, so the coefficients
    may be floats or CasADi symbols.

    Parameters
    ----------
    a : sequence
        The monic denominator, highest power first.
    b : sequence
        The numerator, at most as long as ``a``.

    Returns
    -------
    first_row : list
        ``-a[1:]``, the first row of ``A``.
    c_row : list
        The ``n`` entries of ``C``.
    d : object
        The feedthrough.
    """
    a, b = list(a), list(b)
    n = len(a) - 1
    b = [0.0] * (n + 1 - len(b)) + b
    d = b[0]
    return [-x for x in a[1:]], [b[k] - d * a[k] for k in range(1, n + 1)], d


def companion(N: ArrayLike, D: ArrayLike, scaling: poly.Scaling | None = None,
              balance: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Balanced controllable-form realisation of ``N/D`` in the scaled variable.

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s, ``deg N <= deg D``.
    scaling : Scaling, optional
        Default: :meth:`robrst.core.poly.Scaling.natural` of ``D``.
    balance : bool
        Diagonal similarity (LAPACK ``gebal``) to equalise row and column norms.

    Returns
    -------
    A, B, C : numpy.ndarray
        Of shapes ``(n, n)``, ``(n, 1)``, ``(1, n)``.
    d : float
        With ``N(w0 p)/D(w0 p) = C (pI - A)^-1 B + d``.
    """
    N, D = poly.trim(N), poly.trim(D)
    sc = scaling or poly.Scaling.natural(D)
    Ns, Ds = sc.apply(N), sc.apply(D)
    return companion_monic(Ns / Ds[0], Ds / Ds[0], balance)


def companion_monic(ns: ArrayLike, ds: ArrayLike,
                    balance: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """:func:`companion` of ``ns/ds`` given in the scaled variable with ``ds`` monic.

    Parameters
    ----------
    ns : array_like
        Numerator in the scaled variable, at most as long as ``ds``.
    ds : array_like
        Monic denominator in the scaled variable.
    balance : bool
        Balance the realisation (LAPACK ``gebal``).

    Returns
    -------
    A, B, C : numpy.ndarray
        The realisation.
    d : float
        The feedthrough.

    Raises
    ------
    ValueError
        When ``deg ns > deg ds``.
    """
    n = len(ds) - 1
    if len(ns) > n + 1:
        raise ValueError("improper transfer function: deg N > deg D")
    # companion_parts' arithmetic on arrays (the same products and differences, element
    # by element: identical values), without a round trip through Python lists
    ds = np.asarray(ds, float)
    b = np.zeros(n + 1)
    b[n + 1 - len(ns):] = ns
    d = b[0]
    A = np.eye(n, k=-1)
    if n:
        A[0, :] = -ds[1:]
    B = np.zeros((n, 1))
    if n:
        B[0, 0] = 1.0
    C = (b[1:] - d * ds[1:]).reshape(1, n)
    if n and balance:
        A, B, C = _balanced(A, B, C)
    return A, B, C, float(d)


def _balanced(A, B, C):
    """``A, B, C`` under the diagonal similarity (LAPACK ``gebal``, no permutation) that
    balances ``A``; stacks ``(..., n, n)``, ``(..., n, 1)``, ``(..., r, n)`` slice by slice."""
    from scipy.linalg.lapack import dgebal   # scipy.linalg only where used: 0.3 s to import

    sc = np.empty(A.shape[:-1])
    for i in np.ndindex(A.shape[:-2]):
        sc[i] = dgebal(A[i], scale=1, permute=0)[3]
    return (A * (1 / sc)[..., :, None] * sc[..., None, :], B / sc[..., :, None],
            C * sc[..., None, :])


def companion_outputs(Ns: Sequence[ArrayLike], D: ArrayLike,
                      scaling: poly.Scaling) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                      np.ndarray]:
    """:func:`companion` of several numerators over one ``D``: one ``A, B``, one balancing,
    a row of ``C`` and an entry of ``d`` per numerator (the same matrices as one call each).

    Parameters
    ----------
    Ns : sequence of array_like
        Numerators in s, each of degree at most ``deg D``.
    D : array_like
        The common denominator in s.
    scaling : Scaling
        The frequency scaling of the realisation.

    Returns
    -------
    A, B, C, d : numpy.ndarray
        ``C`` of shape ``(len(Ns), n)``, ``d`` of length ``len(Ns)``.
    """
    return tuple(x[0] for x in companion_outputs_many([Ns], [D], [scaling]))


def companion_outputs_many(Ns: Sequence[Sequence[ArrayLike]], Ds: Sequence[ArrayLike],
                           scalings: Sequence[poly.Scaling]) -> tuple[np.ndarray, np.ndarray,
                                                                     np.ndarray, np.ndarray]:
    """:func:`companion_outputs` of several loops of one degree, stacked.

    Parameters
    ----------
    Ns : sequence of sequences of array_like
        Per loop, its numerators in s (the same number for every loop).
    Ds : sequence of array_like
        Per loop, its denominator in s; all of one degree ``n`` once trimmed.
    scalings : sequence of Scaling
        Per loop, its scaling.

    Returns
    -------
    A, B, C, d : numpy.ndarray
        Shapes ``(K, n, n)``, ``(K, n, 1)``, ``(K, r, n)``, ``(K, r)`` for ``K`` loops of
        ``r`` numerators; slice ``k`` is :func:`companion_outputs` of loop ``k``.

    Raises
    ------
    ValueError
        When a numerator's degree exceeds its denominator's.
    """
    den = np.stack([sc.apply(poly.trim(D)) for D, sc in zip(Ds, scalings)])
    K, n = den.shape[0], den.shape[1] - 1
    r = len(Ns[0])
    num = np.zeros((K, r, n + 1))
    for k, (loop, sc) in enumerate(zip(Ns, scalings)):
        for i, N in enumerate(loop):
            b = sc.apply(poly.trim(N)) / den[k, 0]
            if len(b) > n + 1:
                raise ValueError("improper transfer function: deg N > deg D")
            num[k, i, n + 1 - len(b):] = b
    a = den / den[:, :1]                        # monic (what companion_parts reads)
    A = np.zeros((K, n, n))
    A[:, 0, :] = -a[:, 1:]
    A[:, 1:, :-1] = np.eye(n - 1) if n else 0.0
    B = np.zeros((K, n, 1))
    B[:, :1, 0] = 1.0
    d = num[:, :, 0].copy()
    C = num[:, :, 1:] - d[:, :, None] * a[:, None, 1:]
    if n:
        A, B, C = _balanced(A, B, C)
    return A, B, C, d


@dataclass(frozen=True, eq=False)
class DiscreteSS:
    """Exact ZOH discretisation ``x+ = Ad x + Bd u``, ``y = C x + d u`` (scaled states).

    ``A`` is the continuous scaled matrix, ``h = w0 / fs`` the scaled sampling period,
    ``Gamma = int_0^h exp(A t) dt`` (so ``Ad - I = A Gamma`` without cancellation).

    Attributes
    ----------
    Ad, Bd, C : numpy.ndarray
        The discrete realisation.
    d : float
        The feedthrough.
    A : numpy.ndarray
        The continuous matrix in scaled time.
    Gamma : numpy.ndarray
        ``int_0^h exp(A t) dt``.
    h : float
        The scaled sampling period ``w0 / fs``.
    scaling : Scaling
        The frequency scaling of the states.
    poles : numpy.ndarray
        The discrete poles (eigenvalues of ``Ad``).
    """

    Ad: np.ndarray
    Bd: np.ndarray
    C: np.ndarray
    d: float
    A: np.ndarray
    Gamma: np.ndarray
    h: float
    scaling: poly.Scaling

    @property
    def poles(self):
        """Discrete poles (eigenvalues of ``Ad``)."""
        return np.linalg.eigvals(self.Ad)


def zoh(N: ArrayLike, D: ArrayLike, sample_rate_hz: float,
        scaling: poly.Scaling | None = None) -> DiscreteSS:
    """Exact zero-order-hold discretisation of ``N(s)/D(s)`` at ``sample_rate_hz``.

    One matrix exponential of the augmented matrix ``[[A h, I h, B h], [0, 0, 0]]`` in
    scaled time gives ``Ad``, ``Gamma`` and ``Bd`` at once.

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s, ``deg N <= deg D``.
    sample_rate_hz : float
        The sampling rate [Hz].
    scaling : Scaling, optional
        Default: :meth:`robrst.core.poly.Scaling.natural` of ``D``.

    Returns
    -------
    DiscreteSS
    """
    sc = scaling or poly.Scaling.natural(D)
    A, B, C, d = companion(N, D, sc)
    h = sc.w0 / float(sample_rate_hz)
    Ad, Gamma, Bd = zoh_matrices(A, B, h)
    return DiscreteSS(Ad=Ad, Bd=Bd, C=C, d=d, A=A, Gamma=Gamma, h=h, scaling=sc)


def zoh_matrices(A: np.ndarray, B: np.ndarray, h: float | np.ndarray,
                 gamma: bool = True) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """``(Ad, Gamma, Bd)`` of ``x' = A x + B u`` held over a step ``h`` (same time unit).

    ``Ad = exp(A h)``, ``Gamma = int_0^h exp(A t) dt``, ``Bd = Gamma B``, from one matrix
    exponential of ``[[A h, I h, B h], [0, 0, 0]]``; with ``gamma=False`` ``Gamma`` is
    ``None`` and the exponential is the smaller ``[[A h, B h], [0, 0]]``.  Stacks too:
    ``A`` of shape ``(..., n, n)``, ``B`` ``(..., n, k)`` and ``h`` a scalar or of shape
    ``(...)`` give stacked results, slice by slice the same as one call each.  ``B`` may
    have several columns (several inputs, each held over the step).

    Parameters
    ----------
    A : numpy.ndarray
        ``(..., n, n)``.
    B : numpy.ndarray
        ``(..., n, k)``, usually ``k = 1``.
    h : float or numpy.ndarray
        The step, in the time unit of ``A``.
    gamma : bool
        Also return ``Gamma``.

    Returns
    -------
    Ad : numpy.ndarray
    Gamma : numpy.ndarray or None
    Bd : numpy.ndarray
    """
    from scipy.linalg import expm   # scipy.linalg only where used: 0.3 s to import

    n, m = A.shape[-1], B.shape[-1]
    k = 2 * n + m if gamma else n + m
    h = np.asarray(h, float)[..., None, None]
    M = np.zeros(A.shape[:-2] + (k, k))
    M[..., :n, :n] = A * h
    if gamma:
        M[..., :n, n:2 * n] = np.eye(n) * h
    M[..., :n, k - m:] = B * h
    E = expm(M)
    return E[..., :n, :n], (E[..., :n, n:2 * n] if gamma else None), E[..., :n, k - m:]


def zoh_modal(poles: ArrayLike, residues: ArrayLike,
              sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of a modal (partial-fraction) model at ``sample_rate_hz``.

    A mode ``R / (s - p)`` becomes ``R (e^{pT} - 1) / p / (z - e^{pT})`` (``R T`` at
    ``p = 0``); the feedthrough is unchanged.

    Parameters
    ----------
    poles : array_like
        Continuous poles [rad/s], length ``n``.
    residues : array_like
        Residue matrices, shape ``(n, outputs, inputs)``.
    sample_rate_hz : float
        The sampling rate [Hz].

    Returns
    -------
    z_poles : numpy.ndarray
        ``e^{pT}``.
    residues : numpy.ndarray
        The discrete residues, shape of ``residues``.
    """
    T = 1.0 / float(sample_rate_hz)
    p = np.asarray(poles, complex)
    pt = p * T
    small = np.abs(pt) < 1e-8
    factor = np.where(small, T * (1 + pt / 2), np.expm1(pt) / np.where(small, 1.0, p))
    return np.exp(pt), np.asarray(residues, complex) * factor[:, None, None]


def d2c_modal(zpoles: ArrayLike, residues: ArrayLike,
              sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact inverse of :func:`zoh_modal`: continuous poles and residues of a sampled modal model.

    ``z = e^{pT}`` gives ``p = log(z) / T`` (real for a real positive ``z``) and the
    residue ``R = Rd p / (z - 1)`` (``Rd / T`` at ``z = 1``).  The caller refuses poles on
    the negative real axis (no real continuous counterpart).

    Parameters
    ----------
    zpoles : array_like
        Discrete poles.
    residues : array_like
        Discrete residue matrices, shape ``(n, outputs, inputs)``.
    sample_rate_hz : float
        The sampling rate [Hz].

    Returns
    -------
    poles : numpy.ndarray
        Continuous poles [rad/s].
    residues : numpy.ndarray
        Continuous residues.
    """
    fs = float(sample_rate_hz)
    z = np.asarray(zpoles, complex)
    s = fs * np.log(z)
    s = np.where(np.abs(z.imag) == 0, s.real + 0j, s)
    at_one = np.abs(z - 1) < 1e-12
    factor = np.where(at_one, fs, s / np.where(at_one, 1.0, z - 1))
    return s, np.asarray(residues, complex) * factor[:, None, None]


def modal_polynomials(poles: np.ndarray, residues: np.ndarray,
                      d: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``B(s), A(s)`` (highest power first) of one channel in modal form.

    ``G(s) = sum_i r_i/(s - p_i) (+ the conjugate term of every stored member of a pair,
    Im p_i > 0) + d``.  Expanded in the scaled variable ``s / w0`` (``w0`` the geometric
    mean of the pole magnitudes) so the coefficients keep their precision, then unscaled;
    the rounding residue of the partial-fraction sum (leading numerator terms below 1e-13
    of the largest, in the scaled variable) is dropped before unscaling.

    Parameters
    ----------
    poles : array_like
        Stored poles [rad/s] (real, or the member with positive imaginary part).
    residues : array_like
        One residue per stored pole.
    d : float
        Feedthrough.

    Returns
    -------
    B, A : ndarray
        ``A`` monic.  Non-finite when the unscaled coefficients overflow float64 (the
        caller decides: an order too high for expanded polynomials).
    """
    p = np.asarray(poles, complex).ravel()
    r = np.asarray(residues, complex).ravel()
    pair = np.imag(p) > 0
    allp = np.concatenate([p, np.conj(p[pair])])
    mags = np.abs(allp[np.abs(allp) > 0])
    w0 = float(np.exp(np.mean(np.log(mags)))) if mags.size else 1.0
    ps = allp / w0
    res = np.concatenate([r, np.conj(r[pair])]) / w0
    A = np.poly(ps).real
    B = np.zeros(len(A) - 1, complex)
    for k, rk in enumerate(res):
        B += rk * np.poly(np.delete(ps, k))
    B = np.concatenate([[0.0], B.real]) + float(d) * A
    B = np.trim_zeros(np.where(np.abs(B) > 1e-13 * np.max(np.abs(B)), B, 0.0), "f")
    n = len(A) - 1
    with np.errstate(over="ignore", invalid="ignore"):
        A = A * w0 ** np.arange(0, n + 1)
        B = B * w0 ** np.arange(n + 1 - len(B), n + 1)
    return (B if B.size else np.zeros(1)), A


def transmission_zeros(A: np.ndarray, B: np.ndarray, C: np.ndarray, d: float,
                       scale: float = 1.0) -> np.ndarray:
    """Finite transmission zeros of a SISO state space (generalised eigenvalues).

    The system matrix ``[[A / scale, B / scale], [C, d]]`` is balanced (LAPACK ``gebal`` on
    the square system matrix: a diagonal scaling of the states with the input and output,
    which leaves the zeros unchanged) before the QZ algorithm; ``scale`` is a frequency
    (in the unit of ``A``) near which the zeros are expected, so that they are O(1) in the
    pencil.  Without the balancing, zeros far above the poles of a realisation whose
    states span decades (a pole near ``s = 0`` next to O(1) poles) are lost.

    Parameters
    ----------
    A, B, C, d : array_like
        Real or complex SISO state space.
    scale : float
        Frequency unit of the pencil (default 1: the unit of ``A``).

    Returns
    -------
    ndarray
        The finite zeros (complex), in the unit of ``A``.
    """
    from scipy.linalg import eigvals
    from scipy.linalg.lapack import dgebal, zgebal

    A = np.atleast_2d(A)
    n = A.shape[0]
    g = float(scale)
    M = np.block([[A / g, np.reshape(B, (n, 1)) / g],
                  [np.reshape(C, (1, n)), np.array([[d]])]])
    bal = zgebal if np.iscomplexobj(M) else dgebal
    sc = bal(M, scale=1, permute=0)[3].real
    M = M * (1 / sc)[:, None] * sc[None, :]
    E = np.zeros_like(M)
    E[:n, :n] = np.eye(n)
    alpha, beta = eigvals(M, E, homogeneous_eigvals=True)
    scale_ab = np.maximum(np.abs(alpha), 1.0)
    finite = np.abs(beta) > 1e-12 * scale_ab
    return alpha[finite] / beta[finite] * g


# an irregular point of the scaled plane where the gain is matched
_GAIN_POINT = 0.4127 + 0.9111j


def ss_to_poly(A: ArrayLike, B: ArrayLike, C: ArrayLike,
               d: float | ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """``C (sI - A)^-1 B + d`` as polynomials ``(N, D)`` in s, highest power first.

    Poles are the eigenvalues of ``A``, zeros its transmission zeros, both computed in
    the scaled time of the natural scale of the poles (so entries spanning decades do not
    matter); the gain is matched at one point of the scaled plane.  No polynomial is
    expanded until the end.

    Parameters
    ----------
    A, B, C : array_like
        A SISO state space.
    d : float or array_like
        The feedthrough (its first element is used).

    Returns
    -------
    N, D : numpy.ndarray
        Numerator (leading zeros trimmed) and monic denominator.
    """
    A, B = np.atleast_2d(np.asarray(A, float)), np.asarray(B, float).reshape(-1, 1)
    C, d = np.asarray(C, float).reshape(1, -1), float(np.asarray(d, float).ravel()[0])
    n = A.shape[0]
    if n == 0:
        return np.array([d]), np.ones(1)
    lam = np.linalg.eigvals(A)
    nz = np.abs(lam[lam != 0])
    w0 = float(np.exp(np.mean(np.log(nz)))) if nz.size else 1.0
    As, Bs = A / w0, B / w0                     # C (pI - As)^-1 Bs + d with s = w0 p
    poles = lam / w0
    zeros = transmission_zeros(As, Bs, C, d)
    p0 = _GAIN_POINT
    val = (C @ np.linalg.solve(p0 * np.eye(n) - As, Bs)).item() + d
    gain = (val * np.prod(p0 - poles) / np.prod(p0 - zeros)).real
    N = gain * w0 ** (len(poles) - len(zeros)) * (poly.from_roots(w0 * zeros) if zeros.size
                                                   else np.ones(1))
    return poly.trim(N), poly.from_roots(w0 * poles)


def d2c(Ad: ArrayLike, Bd: ArrayLike, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Continuous ``(A, B)`` whose zero-order hold at period ``dt`` is ``(Ad, Bd)``.

    The inverse of :func:`zoh`: the principal matrix logarithm of ``[[Ad, Bd], [0, 1]]``.

    Parameters
    ----------
    Ad : array_like
        ``(n, n)``.
    Bd : array_like
        ``(n, 1)`` (or ``n`` entries).
    dt : float
        The sampling period [s].

    Returns
    -------
    A, B : numpy.ndarray
        The continuous pair.

    Raises
    ------
    ValueError
        When an eigenvalue of ``Ad`` is zero or real negative (no real continuous
        pre-image, named), or the logarithm is not real.
    """
    Ad, Bd = np.atleast_2d(np.asarray(Ad, float)), np.asarray(Bd, float).reshape(-1, 1)
    n = Ad.shape[0]
    for z in np.linalg.eigvals(Ad):
        if abs(z) < 1e-12 or (abs(z.imag) <= 1e-12 * abs(z) and z.real < 0):
            raise ValueError(f"discrete pole z = {complex(z):.6g} has no continuous"
                             " zero-order-hold pre-image (zero or negative real)")
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = Ad, Bd
    M[n, n] = 1.0
    from scipy.linalg import logm

    L = logm(M)
    if np.max(np.abs(L.imag)) > 1e-9 * max(1.0, np.max(np.abs(L.real))):
        raise ValueError("the discrete model has no real continuous zero-order-hold pre-image")
    L = L.real / float(dt)
    return L[:n, :n], L[:n, n:]


def split_modes(A: ArrayLike, B: ArrayLike, C: ArrayLike,
                drop: Callable[[float, float], bool]) -> tuple[np.ndarray, np.ndarray,
                                                               np.ndarray, int]:
    """The part of ``C (sI - A)^-1 B`` whose modes ``drop`` does not select, decoupled
    from the modes it selects (the additive split ``G = G_drop + G_kept``).

    An ordered real Schur form puts the selected modes first, ``T = [[T11, T12], [0,
    T22]]``; the Sylvester equation ``T11 X - X T22 = -T12`` decouples the two blocks, and
    the kept part is ``(T22, B2, C1 X + C2)``.  Orthogonal transformations and one
    Sylvester solve: no polynomial, no eigenvector basis.

    Parameters
    ----------
    A, B, C : array_like
        A state space (``(n, n)``, ``(n, m)``, ``(p, n)``), best in a scaled time.
    drop : callable
        ``drop(re, im) -> bool`` for each eigenvalue of ``A`` (scipy's ``schur`` sort).

    Returns
    -------
    A2, B2, C2 : numpy.ndarray
        The kept modes' realisation.
    n_dropped : int
        How many modes were split off.

    Examples
    --------
    ``1/((s + 1)(s - 2))`` without its stable mode is ``(1/3)/(s - 2)``:

    >>> import numpy as np
    >>> from robrst.core.lti import split_modes
    >>> A = np.array([[1.0, 2.0], [1.0, 0.0]]); B = np.array([[1.0], [0.0]])
    >>> C = np.array([[0.0, 1.0]])
    >>> A2, B2, C2, k = split_modes(A, B, C, lambda re, im: re < 0)
    >>> round(float(A2[0, 0]), 12), round(float((C2 @ B2)[0, 0]), 12), k
    (2.0, 0.333333333333, 1)
    """
    import scipy.linalg as sla

    A = np.atleast_2d(np.asarray(A, float))
    B, C = np.asarray(B, float), np.asarray(C, float)
    T, Q, k = sla.schur(A, output="real", sort=drop)
    T11, T12, T22 = T[:k, :k], T[:k, k:], T[k:, k:]
    X = sla.solve_sylvester(T11, -T22, -T12)         # T11 X - X T22 = -T12
    QB, CQ = Q.T @ B, C @ Q
    return T22, QB[k:], CQ[:, :k] @ X + CQ[:, k:], int(k)


HANKEL_RTOL = 1e-12    # a Hankel singular value this small (relative to |B| |C|) is zero


def least_control_peak(N: ArrayLike, D: ArrayLike, axis_rtol: float = 1e-9) -> float | None:
    """The least peak of ``|K / (1 + P K)|`` (robrst's ``|U|``) over every controller ``K``
    that stabilises the unstable plant ``P = N/D``: ``1 / sigma_min``, the least Hankel
    singular value of the mirror image ``P_u(-s)`` of the plant's unstable part
    (Glover 1986, "Robust stabilization of linear multivariable systems: relations to
    approximation", Int. J. Control 43: the largest additive perturbation one controller
    tolerates; Zhou, Doyle and Glover 1996, Sec. 17.2 (optimal additive robust
    stabilisation)).

    The unstable part comes from :func:`split_modes` on the balanced companion form in the
    natural scale (Hankel singular values do not change with the time scale), its Gramians
    from two Lyapunov equations.

    Parameters
    ----------
    N, D : array_like
        The plant's numerator and denominator (highest power first), in s or in a
        sampled loop's w-plane.
    axis_rtol : float
        A pole this close (relative to its modulus, or to the scale at 0) to the imaginary
        axis counts as on it.

    Returns
    -------
    float or None
        ``None`` when the plant has no pole in the open right half-plane, or one on the
        imaginary axis (the theorem needs none there); ``inf`` when an unstable mode is
        not seen by the input or the output (cancelled by a zero: a Hankel singular value
        below ``HANKEL_RTOL`` of the realisation's size), which no controller stabilises.

    Examples
    --------
    ``b/(s - a)``: ``2 a / |b|`` (a constant gain ``2 a / b`` reaches it):

    >>> from robrst.core.lti import least_control_peak
    >>> round(least_control_peak([3.0], [1.0, -5.0]), 12)
    3.333333333333
    """
    D = poly.trim(D)
    if len(D) < 2:
        return None
    sc = poly.Scaling.natural(D)
    lam = np.roots(sc.apply(D))          # numpy only: a stable plant needs no scipy
    if np.any(np.abs(lam.real) <= axis_rtol * np.maximum(np.abs(lam), 1.0)):
        return None
    if not np.any(lam.real > 0):
        return None
    import scipy.linalg as sla     # here only: 0.3 s to import, and stable plants end above

    A, B, C, _ = companion(N, D, sc)
    Au, Bu, Cu, _ = split_modes(A, B, C, lambda re, im: re < 0)
    Am, Cm = -Au, -Cu                # P_u(-s) = -Cu (sI + Au)^-1 Bu: stable
    P = sla.solve_continuous_lyapunov(Am, -Bu @ Bu.T)
    Qg = sla.solve_continuous_lyapunov(Am.T, -Cm.T @ Cm)
    hsv = np.sqrt(np.abs(np.linalg.eigvals(P @ Qg).real))
    least = float(hsv.min())
    # a mode the input or the output does not see (an unstable pole cancelled by a zero)
    # has a Hankel value at rounding level: no controller stabilises the loop
    floor = HANKEL_RTOL * float(np.linalg.norm(B) * np.linalg.norm(C))
    return float(np.inf) if least <= floor else 1.0 / least
