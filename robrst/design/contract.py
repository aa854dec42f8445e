"""The JSON contract of ``robrst design --json``, written from the records in one place.

:func:`design_json` is the object ``robrst design --json`` prints (and ``certify``,
``export``, ``check`` save): its fields are only ever added, never renamed
(docs: *Command line*, ``docs/reference/design.schema.json``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from robrst.base.errors import SpecError
from robrst.core import poly
from robrst.problem.specs import SPEC_TABLE, bound_specs

if TYPE_CHECKING:
    from robrst.certificate.assessment import Assessment
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem, Specs
    from robrst.synthesis.analytic import AnalyticDesign
    from robrst.synthesis.multistart import MultiStart
    from robrst.synthesis.outcome import SynthesisResult
    from robrst.synthesis.scenario import FleetDesign
    from robrst.synthesis.tracking import Tracking

__all__ = ["design_json", "specs_json", "solver_json", "spec_rows", "controller_factors", "artefact_record",
           "ARTEFACT_FORMAT", "SPEC_FIGURES", "BINDING_SLACK"]

ARTEFACT_FORMAT = "robrst-design-1"


def artefact_record(problem: Problem) -> dict:
    """The ``artefact`` object of a design's JSON.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    dict
        ``format``, the problem document
        (:func:`robrst.problem.documents.problem_document`; ``None`` with a ``note`` for a
        problem no file can state) and the versions it was made with
        (:func:`robrst.base.versions.versions`).
    """
    from robrst.base.versions import versions
    from robrst.problem.documents import problem_document

    try:
        doc, note = problem_document(problem), None
    except SpecError as exc:       # a problem built in code that no file can state
        doc, note = None, str(exc)
    out = {"format": ARTEFACT_FORMAT, "problem_document": doc, "versions": versions()}
    if note:
        out["note"] = note
    return out

class DesignRecord(Protocol):
    """What the contract reads of a design (:class:`robrst.design.result.DesignResult`
    sits above this module and is one).

    Attributes
    ----------
    problem, method, controller, target_char_poly, analyses, certificate, synthesis
        The design's parts (see :class:`~robrst.design.result.DesignResult`).
    analytic_check, comparison, tracking, fleet, assessment, starts
        Its optional parts (``None`` when absent).
    certified, status, integral_gain, best_achievable
        Its verdict and figures.
    """

    problem: Problem
    method: str
    controller: RSTController
    target_char_poly: np.ndarray | None
    analyses: tuple
    certificate: Certificate
    synthesis: AnalyticDesign | SynthesisResult
    analytic_check: object
    comparison: object
    tracking: Tracking | None
    fleet: FleetDesign | None
    assessment: Assessment | None
    starts: MultiStart | None
    certified: bool
    status: str
    integral_gain: float
    best_achievable: str | None


def _json_value(row, v):
    if row.field.type == "bool":
        return bool(v)
    return list(v) if isinstance(v, tuple) else v


def specs_json(specs: Specs) -> dict:
    """The ``specs`` object of the design JSON, from the spec table
    (:data:`robrst.problem.specs.SPEC_TABLE`: each row's ``published`` rule, in table
    order): the keys published always first, then the sampled loop's, then the others.

    Parameters
    ----------
    specs : Specs
        The problem's specs.

    Returns
    -------
    dict
    """
    out = {}
    for row in SPEC_TABLE:
        if row.published == "always":
            out[row.key] = _json_value(row, getattr(specs, row.key))
    if specs.sampled:
        out.update((row.key, _json_value(row, getattr(specs, row.key))) for row in SPEC_TABLE
                   if row.published == "sampled")
    for row in SPEC_TABLE:
        v = getattr(specs, row.key)
        if (row.published == "given" and v is not None
                or row.published == "with" and getattr(specs, row.with_key) is not None
                or row.published == "time_domain" and specs.time_domain):
            out[row.key] = _json_value(row, v)
    return out


def solver_json(synthesis: AnalyticDesign | SynthesisResult) -> dict:
    """The ``solver`` object of the design JSON.

    Parameters
    ----------
    synthesis : AnalyticDesign or SynthesisResult
        The design's synthesis record.

    Returns
    -------
    dict
        The Sylvester solve's conditioning and residual (the analytic design), or
        :meth:`robrst.synthesis.outcome.SynthesisResult.solver_dict`.
    """
    from robrst.synthesis.analytic import AnalyticDesign

    s = synthesis
    if isinstance(s, AnalyticDesign):
        return {"name": "sylvester", "status": s.status, "w0_rad_s": s.w0, "cond": s.cond,
                "cond_unscaled": s.cond_unscaled, "residual": s.residual}
    return s.solver_dict()


def design_json(result: DesignRecord) -> dict:
    """The public JSON contract of ``robrst design --json`` (fields are only added).

    Parameters
    ----------
    result : DesignResult
        The design.

    Returns
    -------
    dict
        See the documentation's command-line reference (``robrst design``) and
        ``docs/reference/design.schema.json``.
    """
    p = result.problem
    sp = p.specs
    models = [a.as_dict(m) for a, m in zip(result.analyses, p.family.models)]
    specs = specs_json(sp)
    out = {
        "problem": p.name,
        "method": result.method,
        "status": result.status,
        "controller": result.controller.as_dict(),
        "target_char_poly": None if result.target_char_poly is None
        else np.asarray(result.target_char_poly).tolist(),
        "specs": specs,
        "temperature_range_C": list(p.family.range_C),
        "models": models,
        "certified": bool(result.certified),
        "certificate": result.certificate.as_dict(),
        "solver": solver_json(result.synthesis),
        "integral_gain": result.integral_gain,
        "best_achievable": result.best_achievable,
        "specs_achieved": spec_rows(p, result.certificate),
        "controller_factored": controller_factors(result.controller),
    }
    out["method_reason"] = p.solver.method_reason
    if result.assessment is not None:
        out["assessment"] = result.assessment.as_dict()
    if result.starts is not None:
        out["starts"] = result.starts.as_dict()
    if result.tracking is not None:
        out["tracking"] = result.tracking.as_dict()
    if result.analytic_check is not None:
        out["analytic_check"] = result.analytic_check.as_dict()
    if result.comparison is not None:
        out["comparison"] = result.comparison.as_dict()
    out["artefact"] = artefact_record(p)   # what robrst.load_design reads back
    if result.fleet is not None:
        out["fleet"] = result.fleet.as_dict()
    return out


# spec key -> (certificate figure, is a lower bound): every bound on a loop's figures
SPEC_FIGURES = tuple((row.key, row.figure, row.lower) for row in bound_specs())
BINDING_SLACK = 0.01     # a spec within 1 % of its bound is reported as binding


def spec_rows(problem: Problem, cert: Certificate) -> list[dict]:
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
    list of dict
        ``spec, bound, achieved, slack, model, temperature_C, loop, binding, source``.
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
        out.append({"spec": key, "bound": bound, "achieved": float(v),
                    "slack": float(1 - ratio), "model": m.label,
                    "temperature_C": m.temperature_C, "loop": loop,
                    "binding": bool(1 - ratio <= BINDING_SLACK),
                    "source": source if key == "damping_min" else "specs"})
    if cert.controller is not None and sp.controller_damping_min:
        v, b = cert.controller["damping"], sp.controller_damping_min
        out.append({"spec": "controller_damping_min", "bound": b, "achieved": v,
                    "slack": 1 - b / v if v > 0 else -np.inf, "model": "controller",
                    "temperature_C": None, "loop": None,
                    "binding": bool(v > 0 and 1 - b / v <= BINDING_SLACK), "source": "specs"})
    return out


def controller_factors(ctrl: RSTController) -> dict:
    """R, S and T as gain, real roots and damped pairs, and their coefficients in the
    scaled variable ``x = s / w0`` (``w0`` the geometric mean of the root moduli of S and R):
    ``{"w0_rad_s": w0, "R": {...}, "S": {...}, "T": {...}}`` with per polynomial ``gain``
    (leading coefficient), ``real`` (roots [rad/s]), ``pairs`` (``[wn rad/s, zeta]``),
    ``integrators`` (roots at 0) and ``scaled`` (coefficients of ``x``, highest first, all
    divided by ``w0**deg S``: ``R/S`` unchanged, ``S`` monic with O(1) coefficients).

    Parameters
    ----------
    ctrl : RSTController
        The controller.

    Returns
    -------
    dict
    """
    polys = {k: poly.trim(getattr(ctrl, k)) for k in "RST"}
    sc = poly.Scaling.natural(polys["S"], polys["R"])
    out = {"w0_rad_s": float(sc.w0)}
    for k, c in polys.items():
        nz = np.flatnonzero(c)
        zeros_at_0 = len(c) - 1 - int(nz[-1]) if nz.size else 0
        core = c[:len(c) - zeros_at_0] if zeros_at_0 else c
        r = np.roots(core) if len(core) > 1 else np.zeros(0, complex)
        real = sorted(float(x.real) for x in r if abs(x.imag) <= 1e-9 * max(abs(x), 1e-300))
        pairs = sorted([float(abs(x)), float(-x.real / abs(x))] for x in r
                       if x.imag > 1e-9 * max(abs(x), 1e-300))
        out[k] = {"gain": float(c[0]), "integrators": int(zeros_at_0), "real": real,
                  "pairs": pairs, "scaled": sc.normalize(c, len(polys["S"]) - 1).tolist()}
    return out
