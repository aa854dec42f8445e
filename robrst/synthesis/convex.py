"""Convex nominal sensitivity shaping (cvxpy): the Youla-parametrised second path.

With ``Am`` fixed, ``A0 S + B0 R = Am`` is affine in the free coefficients and the
nominal closed-loop denominator is the constant ``Am``, so ``|A0 S(jw)| <= g |Am(jw)|``
(and the same for T and U) are second-order-cone constraints.  Minimising ``g``
shapes the nominal sensitivity; the result also initialises the NLP.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING

import cvxpy as cp
import numpy as np

from robrst.core import poly
from robrst.certificate.proof import certify_problem
from robrst.base.errors import SolverError, SpecError
from robrst.synthesis._nlp import conv_matrix, jw_matrices, scale_plant
from robrst.synthesis.parametrize import Parametrization, TrackingRule, frequency_grid
from robrst.synthesis.outcome import SynthesisResult, best_achievable

if TYPE_CHECKING:
    from robrst.problem.records import Problem
    from robrst.synthesis.analytic import AnalyticDesign

__all__ = ["convex_synthesis", "solve_convex"]


def solve_convex(problem: Problem, Am: np.ndarray, param: Parametrization, nu: np.ndarray,
                 objective: str | None = None, soft: bool = False) -> tuple[np.ndarray, float]:
    """Solve the SOCP; return the scaled decision vector ``[S' (non-leading), R']`` and g.

    With ``soft`` the spec bounds are scaled by a variable ``t`` that is minimised (the
    worst normalised spec violation on the nominal grid, systune's soft goals): always
    feasible when the Diophantine equation is, so an answer exists when the hard specs
    cannot be met.

    Parameters
    ----------
    problem : Problem
        The problem (nominal model, specs, objective).
    Am : numpy.ndarray
        The fixed closed-loop polynomial (in s).
    param : Parametrization
        Degrees, fixed factors and scaling of the decision vector.
    nu : numpy.ndarray
        Scaled frequency grid.
    objective : str, optional
        Overrides ``problem.solver.objective`` (the NLP initialiser uses ``"feasibility"``).
    soft : bool
        Minimise the worst ratio of peak to bound instead (objective ignored).

    Returns
    -------
    x : numpy.ndarray
        The scaled decision vector.
    g : float
        The optimal value (the worst ``|S|`` of ``min_Ms``, ``t`` of the soft program).

    Raises
    ------
    SpecError
        An objective the convex method does not support.
    SolverError
        The program is infeasible, ends without a solution, or the solver fails.
    """
    Sf_s, Rf_s, ks, kr = param.Sf, param.Rf, param.ks, param.kr
    ref = problem.family.reference_model
    a0, b0 = scale_plant(ref, param.scaling)
    Am_s = param.scaling.normalize(Am)
    xs, xr = cp.Variable(ks), cp.Variable(kr + 1)
    CS = conv_matrix(Sf_s, ks + 1)
    CR = conv_matrix(Rf_s, kr + 1)
    S = CS[:, 1:] @ xs + CS[:, 0]
    R = CR @ xr
    AS_M = conv_matrix(a0, CS.shape[0])
    BR_M = conv_matrix(b0, CR.shape[0])
    AR_M = conv_matrix(a0, CR.shape[0])
    deg = len(Am_s) - 1

    def pad(M):
        return np.vstack([np.zeros((deg + 1 - M.shape[0], M.shape[1])), M])

    AS_M, BR_M, AR_M = pad(AS_M), pad(BR_M), pad(AR_M)
    cons = [(AS_M @ S + BR_M @ R)[1:] == Am_s[1:]]
    g = cp.Variable()
    Vr, Vi = jw_matrices(nu, deg)
    amag = np.abs(np.polyval(Am_s, 1j * nu))
    sp = problem.specs
    t = cp.Variable(nonneg=True) if soft else 1.0
    Vr, Vi = Vr / amag[:, None], Vi / amag[:, None]  # each cone divided by |Am(j nu)|
    for M, vec, bound in ((AS_M, S, None), (BR_M, R, sp.Mt_max), (AR_M, R, sp.Mu_max)):
        if M is AS_M:
            lim = g
        elif bound is None:
            continue
        else:
            lim = bound * t
        re, im = Vr @ (M @ vec), Vi @ (M @ vec)
        cons.append(cp.norm(cp.vstack([re, im]), 2, axis=0) <= lim)
    if sp.Ms_max is not None:
        cons.append(g <= sp.Ms_max * t)
    objective = objective or problem.solver.objective
    if objective not in ("min_Ms", "feasibility"):
        raise SpecError(f"{problem.path}: [solver.objective] the convex method supports min_Ms"
                        f" or feasibility, got {objective!r}")
    goal = t if soft else (g if objective == "min_Ms" else 0)
    prob = cp.Problem(cp.Minimize(goal), cons)
    with warnings.catch_warnings():
        # cvxpy warns "Solution may be inaccurate": the status is judged below, and every
        # controller is certified independently of the solver
        warnings.simplefilter("ignore", UserWarning)
        try:
            prob.solve(solver=cp.CLARABEL)
        except cp.error.SolverError as exc:
            raise SolverError(f"{problem.path}: convex solver failed ({exc})") from None
    found = prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and g.value is not None and \
        xr.value is not None and (ks == 0 or xs.value is not None)
    if not found and prob.status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise SolverError(f"{problem.path}: convex program {prob.status}; specs cannot be met"
                          " on the nominal model with this Am")
    if not found:
        raise SolverError(f"{problem.path}: convex program ended {prob.status} without a"
                          " solution")
    return np.concatenate([np.zeros(0) if ks == 0 else xs.value, xr.value]), float(g.value)


def convex_synthesis(problem: Problem, start: AnalyticDesign,
                     progress: Callable[[str], None] | None = None) -> SynthesisResult:
    """The ``method = "convex"`` path: nominal-model SOCP with the fixed Am, certified.

    Parameters
    ----------
    problem : Problem
        The problem.
    start : AnalyticDesign
        The analytic design (its ``Am`` is kept).
    progress : callable, optional
        Called with one line of text per solve.

    Returns
    -------
    SynthesisResult

    Raises
    ------
    SpecError
        ``free_poles`` (the convex method needs a fixed Am) or an unsupported objective.
    """
    say = progress or (lambda m: None)
    if problem.solver.free_poles:
        raise SpecError(f"{problem.path}: [solver.free_poles] the convex method needs a fixed Am")
    Am = start.Am
    sc = poly.Scaling.natural(Am)
    param = Parametrization.of(problem.controller, problem.family.reference_model, sc)
    nu = sc.freq(frequency_grid(problem.family, Am, problem.solver.n_freq))
    notes = ()
    tracking = TrackingRule(problem.controller.T_mode, problem.controller.T_zeros,
                            problem.family.reference_model.B)
    try:
        x, g = solve_convex(problem, Am, param, nu)
        say(f"convex (SOCP, CLARABEL): grid min |S| peak bound {g:.6g}")
    except SolverError as exc:      # the hard specs cannot be met: the best that can
        try:
            x, g = solve_convex(problem, Am, param, nu, soft=True)
            notes = (f"{exc}; the worst ratio of peak to bound was minimised instead",)
        except SolverError as soft_exc:   # no convex answer at all: the analytic design
            x, g = None, None
            notes = (f"{exc}; the soft program failed too ({soft_exc}): the analytic design"
                     " (the start) is returned",)
        say(f"convex: {notes[0]}")
    ctrl = start.controller if x is None else param.controller(x, tracking)
    cert = certify_problem(problem, ctrl)
    return SynthesisResult(controller=ctrl, Am=Am, certificate=cert,
                           status="certified" if cert.certified else "not_certified",
                           objective=problem.solver.objective, w0=sc.w0,
                           name="cvxpy-clarabel", grid_peak_S=g,
                           best_achievable=best_achievable(cert), notes=notes)
