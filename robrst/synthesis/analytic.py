"""Analytic RST pole placement (the paper's method, section 3).

Solves the Diophantine equation ``A S + B R = Am`` with ``S = Sf * S'`` and
``R = Rf * R'`` (fixed factors ``Sf`` — at least the integrator ``s`` — and ``Rf``)
through the Sylvester matrix, in the scaled variable ``p = s / w0``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.base.errors import CoprimeError, DegreeError, SpecError
from robrst.core.plant import Plant, as_plant
from robrst.problem.records import AUX_MIN_FACTOR, ControllerStructure, PoleSpec
from robrst.core.rst import RSTController

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = [
    "characteristic_polynomial",
    "DiophantineSolution",
    "solve_diophantine",
    "diophantine_residual",
    "tracking_polynomial",
    "AnalyticDesign",
    "pole_placement",
    "closed_loop_degree",
]

COPRIME_RTOL = 1e-6


def characteristic_polynomial(spec: PoleSpec,
                              degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(Am, Am_dom, Am_aux)`` of total ``degree`` from a :class:`PoleSpec`.

    Parameters
    ----------
    spec : PoleSpec
        The dominant poles and the auxiliary rule.
    degree : int
        ``deg Am`` (:func:`closed_loop_degree`).

    Returns
    -------
    Am, Am_dom, Am_aux : numpy.ndarray
        Monic polynomials in s, ``Am = Am_dom * Am_aux``.

    Raises
    ------
    DegreeError
        More dominant (or explicit auxiliary) roots than the degree allows, or too few
        explicit auxiliary roots.
    SpecError
        Auxiliary roots that are unstable or less than ``AUX_MIN_FACTOR`` times faster
        than the dominant ones.

    Examples
    --------
    >>> from robrst.problem.records import PoleSpec
    >>> from robrst.synthesis.analytic import characteristic_polynomial
    >>> Am, Am_dom, Am_aux = characteristic_polynomial(PoleSpec(wn=1.0, zeta=1.0), 3)
    >>> Am_dom.tolist(), Am_aux.tolist()              # aux pole at 10x the dominant
    ([1.0, 2.0, 1.0], [1.0, 10.0])
    """
    dom = spec.dominant()
    n_aux = degree - len(dom)
    if n_aux < 0:
        raise DegreeError(
            f"poles: {len(dom)} dominant poles exceed the closed-loop degree {degree}"
        )
    fastest = float(np.max(np.abs(dom)))
    if spec.aux_roots is not None:
        aux = np.asarray(spec.aux_roots, dtype=complex)
        if len(aux) != n_aux:
            raise DegreeError(
                f"poles.aux_roots: closed-loop degree {degree} needs {n_aux} auxiliary roots,"
                f" got {len(aux)}"
            )
    else:
        if spec.aux_factor < AUX_MIN_FACTOR:
            raise SpecError(
                f"poles.aux_factor = {spec.aux_factor}: auxiliary poles must be at least"
                f" {AUX_MIN_FACTOR:g}x faster than the dominant ones"
            )
        aux = np.full(n_aux, -spec.aux_factor * fastest, dtype=complex)
    if np.any(aux.real >= 0):
        raise SpecError(f"poles: auxiliary roots must be stable, got {aux.tolist()}")
    if n_aux and np.min(np.abs(aux)) < AUX_MIN_FACTOR * fastest * (1 - 1e-12):
        raise SpecError(
            f"poles.aux_roots: auxiliary poles must be >= {AUX_MIN_FACTOR:g}x faster than"
            f" the fastest dominant pole ({fastest:.4g} rad/s)"
        )
    Am_dom = poly.from_roots(dom)
    Am_aux = poly.from_roots(aux) if n_aux else np.ones(1)
    return poly.pmul(Am_dom, Am_aux), Am_dom, Am_aux


@dataclass(frozen=True, eq=False)
class DiophantineSolution:
    """Result of :func:`solve_diophantine`.

    Parameters
    ----------
    R, S : numpy.ndarray
        The solution in s (fixed factors included), highest power first.
    w0 : float
        The frequency scale of the solve [rad/s].
    cond : float
        The 2-norm condition number of the scaled, column-equilibrated Sylvester matrix
        actually solved.
    residual : float
        The relative coefficient error of ``A S + B R - Am`` (see
        :func:`robrst.core.poly.rel_coef_error`).
    raw_system : tuple
        ``(Ap, Bp, ks)`` in s, for :attr:`cond_unscaled`.

    Attributes
    ----------
    cond_unscaled : float
        The condition number of the same system written in s (what a naive solve would
        face), computed on first use.
    """

    R: np.ndarray
    S: np.ndarray
    w0: float
    cond: float
    residual: float
    raw_system: tuple = field(default=(), repr=False)  # (Ap, Bp, ks) in s, for cond_unscaled

    @cached_property
    def cond_unscaled(self):
        """2-norm condition number of the raw Sylvester matrix (computed on first use)."""
        return float(np.linalg.cond(_sylvester(*self.raw_system)))


def _check_coprime(Ap, Bp):
    if len(Ap) == 1 or len(Bp) == 1:   # a non-zero constant shares no root with anything
        return
    ra, rb = np.roots(Ap), np.roots(Bp)
    for a in ra:
        for b in rb:
            if abs(a - b) <= COPRIME_RTOL * max(1.0, abs(a), abs(b)):
                raise CoprimeError(
                    f"A*Sf and B*Rf share the root s = {complex(a):.6g} (within relative"
                    f" {COPRIME_RTOL:g}); the Diophantine equation has no unique solution"
                    " — cancel the common factor or change the fixed factors",
                    root=complex(a),
                )


def _sylvester(Ap, Bp, ks):
    """Square Sylvester matrix for the unknowns [S' (non-leading), R'].

    Column of ``c * p**j`` holds ``c`` in the rows of the powers ``deg c + j .. j``
    (row ``i`` is the power ``N - 1 - i``, ``N = deg Ap + ks``).
    """
    na, nb = len(Ap) - 1, len(Bp) - 1
    N = na + ks
    M = np.zeros((N, N))
    for col, j in enumerate(range(ks - 1, -1, -1)):
        M[N - 1 - na - j:N - j, col] = Ap
    for col, j in enumerate(range(na - 1, -1, -1), start=ks):
        M[N - 1 - nb - j:N - j, col] = Bp
    return M


def _solve_refined(M, b, steps=2):
    """``M x = b`` by LU (LAPACK gesv) with ``steps`` of iterative refinement.

    Refinement is residual-driven (each step a solve with the same matrix: the same
    factors, cheap at these sizes); it restores a small backward error on the
    equilibrated system.
    """
    if M.size == 0:
        return np.zeros(0)
    try:   # LAPACK gesv: getrf, then getrs
        x = np.linalg.solve(M, b)
    except np.linalg.LinAlgError:
        raise CoprimeError("the scaled Sylvester matrix is exactly singular:"
                           " A*Sf and B*Rf are not coprime") from None
    for _ in range(steps):
        x = x + np.linalg.solve(M, b - M @ x)
    return x


def diophantine_residual(A: ArrayLike, B: ArrayLike, R: ArrayLike, S: ArrayLike, Am: ArrayLike,
                         w0: float | None = None) -> float:
    """Relative coefficient error of ``A S + B R = Am``, in the scaled variable.

    Each coefficient's error is divided by the size of the terms that produce it,
    ``max_k (|A| * |S| + |B| * |R|)_k`` (coefficient-wise products of moduli),
    after scaling ``s = w0 p`` with ``w0`` the natural scale of ``Am`` (or the given
    ``w0``).  When the target is reached without cancellation this equals the error
    relative to ``Am``'s coefficients; when ``Am`` results from cancelling much larger terms
    (poles moved by decades) it measures what floating point can deliver.

    Parameters
    ----------
    A, B : array_like
        The plant polynomials.
    R, S : array_like
        The controller polynomials.
    Am : array_like
        The target characteristic polynomial.
    w0 : float, optional
        The scale [rad/s] (default the natural scale of ``Am``).

    Returns
    -------
    float
    """
    sc = poly.Scaling.natural(Am) if w0 is None else poly.Scaling(w0)
    a, b, r, s_, am = (sc.apply(poly.trim(c)) for c in (A, B, R, S, Am))
    AS, BR = np.convolve(a, s_), np.convolve(b, r)
    n = max(len(AS), len(BR), len(am))
    lhs, size = np.zeros(n), np.zeros(n)
    lhs[n - len(AS):] += AS
    lhs[n - len(BR):] += BR
    lhs[n - len(am):] -= am
    size[n - len(AS):] += np.convolve(np.abs(a), np.abs(s_))
    size[n - len(BR):] += np.convolve(np.abs(b), np.abs(r))
    return float(np.max(np.abs(lhs)) / np.max(size))


def solve_diophantine(A: ArrayLike, B: ArrayLike, Am: ArrayLike, S_fixed: ArrayLike = (1.0, 0.0),
                      R_fixed: ArrayLike = (1.0,)) -> DiophantineSolution:
    """Solve ``A Sf S' + B Rf R' = Am`` for monic ``S'`` and ``R'`` of degree ``deg(A Sf) - 1``.

    Parameters
    ----------
    A, B : array_like
        Plant polynomials (A monic).
    Am : array_like
        Monic target characteristic polynomial, ``deg Am >= deg(A Sf) + deg(B Rf)``.
    S_fixed, R_fixed : array_like
        Fixed factors of S (default ``s``: the integrator) and R.

    Returns
    -------
    DiophantineSolution
        Full ``R = Rf R'`` and ``S = Sf S'`` in s.

    Raises
    ------
    CoprimeError
        If ``A Sf`` and ``B Rf`` share a root (the message names it).
    DegreeError
        If the degrees admit no unique proper solution.
    """
    A, B, Am = poly.monic(A), poly.trim(B), poly.monic(Am)
    Sf, Rf = poly.trim(S_fixed), poly.trim(R_fixed)
    Ap = poly.monic(poly.pmul(A, Sf))
    Bp = poly.pmul(B, Rf) / poly.trim(Sf)[0]
    na, nb = len(Ap) - 1, len(Bp) - 1
    ks = len(Am) - 1 - na
    if ks < 0 or nb > ks:
        raise DegreeError(
            f"closed-loop degree {len(Am) - 1} is too low: with deg(A*Sf) = {na} and"
            f" deg(B*Rf) = {nb} it must be at least {na + nb}"
        )
    if na - 1 + len(Rf) - 1 > ks + len(Sf) - 1:
        raise DegreeError(
            f"controller would be improper: deg R = {na - 1 + len(Rf) - 1} > deg S ="
            f" {ks + len(Sf) - 1}; raise the closed-loop degree"
        )
    _check_coprime(Ap, Bp)
    sc = poly.Scaling.natural(Am)  # the closed-loop time scale
    w0 = sc.w0
    sa, sb, sm = sc.normalize(Ap, na), sc.normalize(Bp, na), sc.normalize(Am, na + ks)
    M = _sylvester(sa, sb, ks)
    rhs = (sm - np.concatenate([sa, np.zeros(ks)]))[1:]  # both monic: leading terms cancel
    # two-sided equilibration of the scaled matrix (powers of 2: exact)
    rowscale = 2.0 ** np.round(np.log2(np.max(np.abs(M), axis=1)))
    Mr = M / rowscale[:, None]
    colscale = 2.0 ** np.round(np.log2(np.max(np.abs(Mr), axis=0)))
    Ms = Mr / colscale
    sv = np.linalg.svd(Ms, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else (1.0 if not sv.size else np.inf)
    if not np.isfinite(cond) or cond > 1e15:
        raise CoprimeError(   # coprime (checked above): the cause is conditioning
            f"the pole-placement (Diophantine) system is too ill-conditioned for double"
            f" precision (cond of the scaled Sylvester matrix = {cond:.3g}); A*Sf and B*Rf"
            f" share no root, the requested closed-loop poles are too far from the plant's"
            f" (closed-loop scale {w0:.3g} rad/s, degree {na + ks}): move [poles] wn,"
            f" aux_factor or dominant_real towards the plant's poles, or lower"
            f" [controller] extra_degree"
        )
    x = _solve_refined(Ms, rhs / rowscale) / colscale
    Ss = np.concatenate([[1.0], x[:ks]])
    Rs = x[ks:]
    S1, R1 = sc.denormalize(Ss, ks), sc.denormalize(Rs, ks)
    # A Sf S1 / Sf0 + B Rf R1 / Sf0 = Ap S1 + Bp R1 = Am  (Sf need not be monic)
    S = poly.pmul(Sf, S1) / Sf[0]
    R = poly.trim(poly.pmul(Rf, R1) / Sf[0])
    res = diophantine_residual(A, B, R, S, Am, w0=w0)
    return DiophantineSolution(R=R, S=S, w0=w0, cond=cond, residual=res, raw_system=(Ap, Bp, ks))


def closed_loop_degree(n: int, m: int, S_fixed: ArrayLike = (1.0, 0.0), R_fixed: ArrayLike = (1.0,),
                       extra_degree: int = 0, relative_degree: int = 0) -> int:
    """Degree of ``Am`` for plant degrees ``n >= m`` and the fixed factors.

    With ``Sf = s`` and ``Rf = 1`` this is the paper's ``2n`` (``deg S = deg R = n``);
    ``extra_degree`` raises ``deg S`` (and so ``deg Am``) further, and so does
    ``relative_degree`` (``deg R <= deg S - relative_degree``: roll-off).

    Parameters
    ----------
    n, m : int
        ``deg A`` and ``deg B``.
    S_fixed, R_fixed : array_like
        Fixed factors of S and R.
    extra_degree : int
        Degrees of S above the minimum.
    relative_degree : int
        Required ``deg S - deg R``.

    Returns
    -------
    int

    Examples
    --------
    >>> from robrst.synthesis.analytic import closed_loop_degree
    >>> closed_loop_degree(3, 2), closed_loop_degree(3, 2, extra_degree=1)
    (6, 7)
    """
    dSf, dRf = len(poly.trim(S_fixed)) - 1, len(poly.trim(R_fixed)) - 1
    ks = max(n - 1 + dRf + int(relative_degree), m + dRf) + int(extra_degree)
    return n + dSf + ks


def tracking_polynomial(mode: str, R: ArrayLike, B: ArrayLike, Am: ArrayLike, Am_aux: ArrayLike,
                        zeros: Sequence[float] = ()) -> np.ndarray:
    """The feed-forward polynomial T (all three modes give unit static gain from yr to y).

    Parameters
    ----------
    mode : {"paper", "static", "cancel_aux"}
        ``"paper"``: ``T = Bm_aux`` with zeros at ``zeros`` [rad/s] and ``T(0) = R(0)``;
        ``"static"``: ``T = Am(0)/B(0)`` (a constant);
        ``"cancel_aux"``: ``T = Am_aux * Am(0) / (Am_aux(0) B(0))`` (the tracking model
        keeps only the dominant poles).
    R : array_like
        The feedback polynomial.
    B : array_like
        The plant's numerator.
    Am : array_like
        The characteristic polynomial.
    Am_aux : array_like
        Its auxiliary factor.
    zeros : sequence of float
        Zeros of ``Bm_aux`` (``"paper"``).

    Returns
    -------
    numpy.ndarray
        T in s, highest power first.

    Raises
    ------
    SpecError
        An unknown mode, or ``B(0) = 0`` (no unit static gain is possible).
    """
    B0 = B[-1]
    if B0 == 0:
        raise SpecError("tracking: B(0) = 0, no unit static gain is possible")
    if mode == "static":
        return np.array([Am[-1] / B0])
    if mode == "cancel_aux":
        return Am_aux * (Am[-1] / (Am_aux[-1] * B0))
    if mode == "paper":
        Bm = poly.from_roots(zeros) if len(zeros) else np.ones(1)
        return Bm * (R[-1] / Bm[-1])
    raise SpecError(f"controller.T: unknown mode {mode!r}; expected paper, static or cancel_aux")


@dataclass(frozen=True, eq=False)
class AnalyticDesign:
    """Result of :func:`pole_placement`.

    Parameters
    ----------
    controller : RSTController
        The controller.
    Am, Am_dom, Am_aux : numpy.ndarray
        The characteristic polynomial and its dominant and auxiliary factors.
    w0 : float
        The scale of the solve [rad/s].
    cond : float
        The condition number of the scaled Sylvester matrix actually solved.
    residual : float
        The relative error of ``A S + B R = Am`` (:func:`diophantine_residual`).
    solution : DiophantineSolution, optional
        The solve behind it.

    Attributes
    ----------
    cond_unscaled : float
        The condition number of the same system written in s (computed on first use).
    status : str
        Always ``"solved"``: failures raise instead of returning.
    """

    controller: RSTController
    Am: np.ndarray
    Am_dom: np.ndarray
    Am_aux: np.ndarray
    w0: float
    cond: float
    residual: float
    solution: DiophantineSolution = field(repr=False, default=None)

    @property
    def cond_unscaled(self):
        """Condition number of the unscaled Sylvester matrix (computed on first use)."""
        return self.solution.cond_unscaled

    @property
    def status(self):
        """Always ``"solved"``: failures raise instead of returning."""
        return "solved"


def pole_placement(plant: Plant, poles: PoleSpec,
                   structure: ControllerStructure = ControllerStructure()) -> AnalyticDesign:
    """Analytic pole-placement design for ``plant`` (the paper's method).

    Parameters
    ----------
    plant : Plant
        The nominal model.
    poles : PoleSpec
        Closed-loop poles ``Am = Am_dom * Am_aux``.
    structure : ControllerStructure
        Fixed factors of S and R, extra degrees, and the T rule.

    Returns
    -------
    AnalyticDesign

    Raises
    ------
    CoprimeError, DegreeError, SpecError
        The message names the cause and the key to change.

    Examples
    --------
    >>> from robrst import paper_plant, PoleSpec, ControllerStructure, pole_placement
    >>> d = pole_placement(paper_plant(), PoleSpec(wn=600.0, zeta=1.0),
    ...                    ControllerStructure(extra_degree=1))
    >>> float(d.controller.S[-1]), d.cond < 1e3      # integrator in S; well conditioned
    (0.0, True)
    """
    plant = as_plant(plant)          # a python-control system too
    Sf, Rf = poly.trim(structure.S_total), poly.trim(structure.R_fixed)
    degree = closed_loop_degree(plant.n, plant.m, Sf, Rf, structure.extra_degree,
                                structure.controller_relative_degree)
    Am, Am_dom, Am_aux = characteristic_polynomial(poles, degree)
    sol = solve_diophantine(plant.A, plant.B, Am, Sf, Rf)
    mode = "static" if structure.T_mode == "reference_model" else structure.T_mode
    T = tracking_polynomial(mode, sol.R, plant.B, Am, Am_aux, structure.T_zeros)
    if len(T) > len(sol.S):
        n_dom = len(Am_dom) - 1
        raise DegreeError(
            f"[controller.T_mode] = {structure.T_mode!r} gives deg T = {len(T) - 1} > deg S ="
            f" {len(sol.S) - 1} (an improper controller): T = Am_aux keeps every auxiliary pole,"
            f" which needs at least deg A = {plant.n} dominant poles (now {n_dom}); add"
            " [poles.dominant_real] poles or use T_mode 'paper' or 'static'")
    ctrl = RSTController(R=sol.R, S=sol.S, T=T)
    return AnalyticDesign(controller=ctrl, Am=Am, Am_dom=Am_dom, Am_aux=Am_aux, w0=sol.w0,
                          cond=sol.cond, residual=sol.residual, solution=sol)
