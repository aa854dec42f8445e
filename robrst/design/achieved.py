"""What a design achieves, as records the contract and the renderers read.

:func:`spec_rows` lists every bounded spec with its worst achieved value over the
certificate's models (both loops), its slack and where it binds (:class:`SpecRow`);
:func:`controller_factors` factors R, S and T (:class:`ControllerFactors`);
:func:`solver_summary` and :func:`starts_summary` say what the solver and the multi-start
found.  :class:`~robrst.design.result.DesignResult` offers them as attributes; the JSON
contract (:mod:`robrst.design.contract`) and the text and report renderers
(:mod:`robrst.report`) write them as they are.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.problem.specs import bound_specs

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem

__all__ = ["AnalyticCheck", "Comparison", "SpecRow", "PolyFactors", "ControllerFactors",
           "SolverSummary", "StartsSummary",
           "spec_rows", "controller_factors", "solver_summary", "starts_summary",
           "SPEC_FIGURES", "SPEC_ROW_FIELDS", "BINDING_SLACK", "BINDING_SPECS"]

SPEC_ROW_FIELDS = ("spec", "bound", "achieved", "slack", "model", "temperature_C", "loop",
                   "binding", "source")


@dataclass(frozen=True)
class AnalyticCheck:
    """A synthesised controller against the closed-form Diophantine solution.

    Parameters
    ----------
    kind : {"sylvester_coefficients", "diophantine_residual"}
        No free degree: the solution is unique and must be reproduced coefficient by
        coefficient; else the Diophantine residual at the nominal model.
    max_rel_coef_error : float
        The largest relative error found.
    passed : bool
        ``max_rel_coef_error <= 1e-8``.
    """

    kind: str
    max_rel_coef_error: float
    passed: bool



@dataclass(frozen=True)
class Comparison:
    """Worst-case figures over the family for this design and an analytic one.

    Parameters
    ----------
    rows : dict
        Figure -> ``{"this": value, "analytic": value}``.
    table : str
        The comparison as printed.
    range_C : tuple of float
        The family's temperature range [°C].
    """

    rows: dict
    table: str
    range_C: tuple



@dataclass(frozen=True)
class SpecRow:
    """One bounded spec and what the design achieves (the JSON's ``specs_achieved[i]``).

    Parameters
    ----------
    spec : str
        The key (``"Ms_max"``, ``"damping_min"``, ...).
    bound : float
        Its bound (the resolved damping floor for ``damping_min``).
    achieved : float
        The worst value over the certificate's models and loops.
    slack : float
        ``1 - achieved/bound`` (``1 - bound/achieved`` for a lower bound): the room left.
    model : str
        Where it is attained (``"controller"`` for the controller's own poles).
    temperature_C : float or None
        At what temperature.
    loop : {"continuous", "sampled"} or None
        In which loop.
    binding : bool
        Slack below ``BINDING_SLACK``.
    source : {"specs", "default"}
        Given, or the default damping floor.
    """

    spec: str
    bound: float
    achieved: float
    slack: float
    model: str
    temperature_C: float | None
    loop: str | None
    binding: bool
    source: str


@dataclass(frozen=True)
class PolyFactors:
    """One polynomial of the controller, factored.

    Parameters
    ----------
    gain : float
        Its leading coefficient.
    integrators : int
        Its roots at 0.
    real : tuple of float
        Its real roots [rad/s], sorted.
    pairs : tuple of (float, float)
        Its damped pairs ``(wn [rad/s], zeta)``, sorted.
    scaled : tuple of float
        Its coefficients in ``x = s / w0``, highest first, all divided by ``w0**deg S``
        (``R/S`` unchanged, ``S`` monic with O(1) coefficients).
    """

    gain: float
    integrators: int
    real: tuple
    pairs: tuple
    scaled: tuple


@dataclass(frozen=True)
class ControllerFactors:
    """R, S and T factored, with the scale of their coefficients.

    Parameters
    ----------
    w0_rad_s : float
        The geometric mean of the root moduli of S and R [rad/s].
    R, S, T : PolyFactors
        The polynomials.
    """

    w0_rad_s: float
    R: PolyFactors
    S: PolyFactors
    T: PolyFactors


@dataclass(frozen=True)
class SolverSummary:
    """What the solver reports beside its controller.

    Parameters
    ----------
    objective : str or None
        The objective it optimised (``None``: none, the analytic design).
    binding : tuple of str
        The constraints with the largest multipliers, named by model, temperature and
        frequency.
    notes : tuple of str
        What the pipeline had to do (fallbacks, relaxations).
    binding_slack : tuple of (float or None)
        Beside each of ``binding``: the certificate's slack of the spec that constraint
        bounds (its worst over every model and loop, :attr:`SpecRow.slack`); ``None``
        where the constraint bounds no single spec (stability, the controller's poles, a
        reference-step sample); empty when the record does not say (a design saved before
        the field).  Above ``BINDING_SLACK`` the constraint held in the program, whose
        bound was tighter than the spec (the grid constraints' margin, a backed-off
        polish), not in the certificate.
    """

    objective: str | None = None
    binding: tuple = ()
    notes: tuple = ()
    binding_slack: tuple = ()


@dataclass(frozen=True)
class StartsSummary:
    """What a multi-start found.

    Parameters
    ----------
    starts : int
        How many starts ran (the problem as asked included).
    certified : int
        How many certified.
    best, worst : float or None
        The best and worst certified objectives.
    winner : str
        The start whose answer was kept.
    search_method : str or None
        The global phase's method (``None``: a multi-start without it).
    evaluations : int or None
        Candidates the global phase screened.
    dimension : int or None
        The dimension of its search space.
    """

    starts: int
    certified: int
    best: float | None
    worst: float | None
    winner: str
    search_method: str | None = None
    evaluations: int | None = None
    dimension: int | None = None


# spec key -> (certificate figure, is a lower bound): every bound on a loop's figures
SPEC_FIGURES = tuple((row.key, row.figure, row.lower) for row in bound_specs())
BINDING_SLACK = 0.01     # a spec within 1 % of its bound is reported as binding


def spec_rows(problem: Problem, cert: Certificate) -> tuple[SpecRow, ...]:
    """Each bounded spec with its worst achieved value over the certificate's models (both
    loops), the slack ``1 - value/bound`` (``1 - bound/value`` for a lower bound), where it
    is attained and whether it binds (slack below ``BINDING_SLACK``).

    Parameters
    ----------
    problem : Problem
        The problem (its specs and the default damping floor on its family).
    cert : Certificate
        The design's certificate.

    Returns
    -------
    tuple of SpecRow
    """
    sp = problem.specs
    floor, source = problem.damping_floor.value, problem.damping_floor.source
    out = []
    for key, fig, lower in SPEC_FIGURES:
        bound = floor if key == "damping_min" else getattr(sp, key)
        if not bound:
            continue
        best = None
        for loop in ("continuous", "sampled"):
            recs = [(m.value(fig, loop), m) for m in cert.models if m.value(fig, loop) is not None]
            if not recs:
                continue
            v, m = (min if lower else max)(recs, key=lambda r: r[0])
            ratio = bound / v if lower else v / bound
            if best is None or ratio > best[0]:
                best = (ratio, v, m, loop)
        if best is None:
            continue
        ratio, v, m, loop = best
        out.append(SpecRow(*(
            key, bound, float(v), float(1 - ratio), m.label, m.temperature_C, loop,
            bool(1 - ratio <= BINDING_SLACK),
            "default" if key in sp.defaults else source if key == "damping_min" else "specs")))
    if cert.controller is not None and sp.controller_damping_min:
        v, b = cert.controller.damping, sp.controller_damping_min
        out.append(SpecRow(*(
            "controller_damping_min", b, v, 1 - b / v if v > 0 else -np.inf, "controller",
            None, None, bool(v > 0 and 1 - b / v <= BINDING_SLACK), "specs")))
    return tuple(out)



def controller_factors(ctrl: RSTController) -> ControllerFactors:
    """R, S and T as gain, real roots and damped pairs, and their coefficients in the
    scaled variable ``x = s / w0`` (``w0`` the geometric mean of the root moduli of S and R):
    :class:`ControllerFactors`.

    Parameters
    ----------
    ctrl : RSTController
        The controller.

    Returns
    -------
    ControllerFactors
    """
    polys = {k: poly.trim(getattr(ctrl, k)) for k in "RST"}
    sc = poly.Scaling.natural(polys["S"], polys["R"])
    out = {}
    for k, c in polys.items():
        nz = np.flatnonzero(c)
        zeros_at_0 = len(c) - 1 - int(nz[-1]) if nz.size else 0
        core = c[:len(c) - zeros_at_0] if zeros_at_0 else c
        r = np.roots(core) if len(core) > 1 else np.zeros(0, complex)
        real = sorted(float(x.real) for x in r if abs(x.imag) <= 1e-9 * max(abs(x), 1e-300))
        pairs = sorted([float(abs(x)), float(-x.real / abs(x))] for x in r
                       if x.imag > 1e-9 * max(abs(x), 1e-300))
        out[k] = PolyFactors(gain=float(c[0]), integrators=int(zeros_at_0), real=tuple(real),
                             pairs=tuple(tuple(p) for p in pairs),
                             scaled=tuple(sc.normalize(c, len(polys["S"]) - 1).tolist()))
    return ControllerFactors(w0_rad_s=float(sc.w0), **out)


# the program's constraint kind (robrst.synthesis.outcome.Binding) -> the spec it bounds
BINDING_SPECS = {"S": ("Ms_max",), "T": ("Mt_max",), "U": ("Mu_max",),
                 "Tband": ("T_resonance_max",), "Uhf": ("Mu_hf_max",),
                 "Sd": ("Msd_max", "Msd_rel_max"), "Ry": ("Mry_max",),
                 "sector": ("damping_min",), "controller_sector": ("controller_damping_min",)}


def solver_summary(synthesis: object, rows: tuple = ()) -> SolverSummary:
    """The solver's objective, binding constraints and notes.

    Parameters
    ----------
    synthesis : AnalyticDesign, SynthesisResult or a saved design's solver record
        The design's synthesis record (a saved record: read from its ``solver_dict()``).
    rows : tuple of SpecRow
        The design's :func:`spec_rows`: each binding constraint's certified slack
        (:attr:`SolverSummary.binding_slack`).

    Returns
    -------
    SolverSummary
    """
    from robrst.synthesis.analytic import AnalyticDesign
    from robrst.synthesis.outcome import SynthesisResult

    if isinstance(synthesis, AnalyticDesign):
        return SolverSummary()
    if isinstance(synthesis, SynthesisResult):
        if synthesis.name != "ipopt":
            return SolverSummary()
        found = () if synthesis.solve is None else synthesis.solve.binding()
        slack = {r.spec: r.slack for r in rows}
        return SolverSummary(
            objective=synthesis.objective, binding=tuple(b.describe() for b in found),
            notes=tuple(synthesis.notes),
            binding_slack=tuple(min((slack[k] for k in BINDING_SPECS.get(b.kind, ())
                                     if k in slack), default=None) for b in found))
    d = synthesis.solver_dict()         # a saved design's record, as it was written
    return SolverSummary(objective=d.get("objective"), binding=tuple(d.get("binding") or ()),
                         notes=tuple(d.get("notes") or ()),
                         binding_slack=tuple(d.get("binding_slack") or ()))


def starts_summary(starts: object) -> StartsSummary:
    """What a multi-start found.

    Parameters
    ----------
    starts : MultiStart or a saved design's record of it
        The multi-start (a saved record: read from its ``as_dict()``).

    Returns
    -------
    StartsSummary
    """

    d = starts.as_dict()          # a MultiStart's, or a saved record's as it was written
    spread, n, winner = d["spread"], len(d["starts"]), d["winner"]
    gs = d.get("global_search") or {}
    return StartsSummary(starts=n, certified=int(spread.get("certified", 0)),
                         best=spread.get("best"), worst=spread.get("worst"), winner=winner,
                         search_method=gs.get("method"), evaluations=gs.get("evaluations"),
                         dimension=gs.get("dimension"))
