"""The JSON contract of ``robrst design --json``, written from the records in one place.

:func:`design_json` is the object ``robrst design --json`` prints (and ``certify``,
``export``, ``check`` save): its fields are only ever added, never renamed
(docs: *Command line*, ``docs/reference/design.schema.json``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from robrst.base.errors import SpecError
from robrst.certificate.figures import figure_key
from robrst.design.achieved import SPEC_ROW_FIELDS
from robrst.problem.specs import SPEC_TABLE

if TYPE_CHECKING:
    from robrst.certificate.assessment import Assessment, ModelAssessment
    from robrst.certificate.figures import LoopFigures, ModelRecord
    from robrst.certificate.proof import Certificate
    from robrst.certificate.statement import IntervalProof, IntervalRecord
    from robrst.core.analysis import Analysis
    from robrst.core.plant import Plant
    from robrst.core.rst import RSTController
    from robrst.design.achieved import AnalyticCheck, Comparison, ControllerFactors
    from robrst.design.tolerance import SpreadTolerance
    from robrst.problem.records import Problem, Specs
    from robrst.synthesis.analytic import AnalyticDesign
    from robrst.synthesis.bound import ObjectiveBound
    from robrst.synthesis.feasibility import FeasibilityVerdict
    from robrst.synthesis.multistart import MultiStart
    from robrst.synthesis.outcome import SynthesisResult
    from robrst.synthesis.scenario import FleetDesign
    from robrst.synthesis.tracking import Tracking

__all__ = ["design_json", "certificate_json", "interval_json", "proof_json",
           "model_record_json", "loop_items",
           "analysis_json", "assessment_json", "assessment_model_json", "specs_json",
           "solver_json", "factors_json", "artefact_record", "SPECS_DEFAULT_FIELDS",
           "ARTEFACT_FORMAT", "DESIGN_FIELDS", "OPTIONAL_FIELDS", "CERTIFICATE_FIELDS",
           "INTERVAL_FIELDS", "SWEEP_INTERVAL_FIELDS", "POLE_REGION_FIELDS",
           "VIOLATION_FIELDS", "SPEC_ROW_FIELDS", "ANALYTIC_CHECK_FIELDS", "ANALYSIS_PEAKS",
           "MARGIN_FIELDS", "LOOP_FIELDS", "OPTIONAL_LOOP_FIGURES"]

ARTEFACT_FORMAT = "robrst-design-1"

# The contract's field names and order, declared once (fields are only ever added: at the end
# of an object, or where an optional field has always been published)
DESIGN_FIELDS = ("problem", "method", "status", "controller", "target_char_poly", "specs",
                 "temperature_range_C", "models", "certified", "certificate", "solver",
                 "integral_gain", "best_achievable", "specs_achieved", "controller_factored",
                 "method_reason", "assessment", "starts", "tracking", "analytic_check",
                 "comparison", "artefact", "fleet", "objective_bound", "feasibility",
                 "tolerance")
# the specs object's fields after the table's keys (robrst.problem.specs)
SPECS_DEFAULT_FIELDS = ("defaults", "defaults_off")
OPTIONAL_FIELDS = ("assessment", "starts", "tracking", "analytic_check", "comparison", "fleet",
                   "objective_bound", "feasibility", "tolerance")
CERTIFICATE_FIELDS = ("ratios", "certified", "rtol", "controller", "models", "violations",
                      "interval", "interval_proof", "interval_resolution_C")
INTERVAL_FIELDS = ("range_C", "stability", "peaks", "points", "max_spacing_C", "min_spacing_C",
                   "refine_ratio", "sampled", "order_change_C", "guardian", "statement",
                   "pole_region_proof", "pole_region", "time_domain", "actuators")
SWEEP_INTERVAL_FIELDS = ("points", "max_spacing_C", "min_spacing_C", "refine_ratio", "sampled",
                         "order_change_C", "statement")     # given with several models
POLE_REGION_FIELDS = ("damping_min", "damping_source", "decay_min", "proved_between_points",
                      "statement")
VIOLATION_FIELDS = ("label", "temperature_C", "quantity", "value", "bound", "freq_rad_s",
                    "loop", "kind")
ANALYTIC_CHECK_FIELDS = ("kind", "max_rel_coef_error", "passed")
# a family model's figures in ``models``: (published figure, peak of) and the margins
ANALYSIS_PEAKS = (("Ms", "S"), ("Mt", "T"), ("Mu", "U"), ("Msd", "Sd"))
MARGIN_FIELDS = ("gain_margin", "gain_margin_lower", "phase_margin_deg", "modulus_margin",
                 "delay_margin_s")
# a checked loop's figures in ``certificate.models``, per loop (the step figures follow)
LOOP_FIELDS = {
    "continuous": ("spectral_abscissa", "stable", "distance_to_instability",
                   "closed_loop_degree", "Ms", "Ms_freq_rad_s", "Mt", "Mt_freq_rad_s", "Mu",
                   "Mu_freq_rad_s", "Mt_resonance_band", "Mt_resonance_band_freq_rad_s",
                   "Mu_hf", "Msd", "Msd_freq_rad_s", "Mry", "Mry_freq_rad_s", "Msd_rel",
                   "open_loop_peak", "damping", "decay_rad_s"),
    "sampled": ("spectral_abscissa", "stable", "Ms", "Ms_freq_rad_s", "Mt", "Mt_freq_rad_s",
                "Mu", "Mu_freq_rad_s", "Mt_resonance_band", "distance_to_instability",
                "Mu_hf", "Msd", "Msd_freq_rad_s", "Mry", "Mry_freq_rad_s", "Msd_rel",
                "open_loop_peak", "damping", "decay_rad_s"),
}
# published only when computed: field -> the figure whose presence decides
OPTIONAL_LOOP_FIGURES = {
    "Mt_resonance_band": "Mt_resonance_band",
    "Mt_resonance_band_freq_rad_s": "Mt_resonance_band", "Mu_hf": "Mu_hf", "Msd": "Msd",
    "Msd_freq_rad_s": "Msd", "Mry": "Mry", "Mry_freq_rad_s": "Mry", "Msd_rel": "Msd_rel",
    "open_loop_peak": "Msd_rel", "damping": "damping", "decay_rad_s": "decay_rad_s"}


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
    analytic_check, comparison, tracking, fleet, assessment, starts, objective_bound, feasibility, tolerance
        Its optional parts (``None`` when absent).
    certified, status, integral_gain, best_achievable
        Its verdict and figures.
    specs_achieved, controller_factored
        What it achieves (:mod:`robrst.design.achieved`).
    """

    problem: Problem
    method: str
    controller: RSTController
    target_char_poly: np.ndarray | None
    analyses: tuple
    certificate: Certificate
    synthesis: AnalyticDesign | SynthesisResult
    analytic_check: AnalyticCheck | None
    comparison: Comparison | None
    tracking: Tracking | None
    fleet: FleetDesign | None
    assessment: Assessment | None
    starts: MultiStart | None
    objective_bound: ObjectiveBound | None
    feasibility: FeasibilityVerdict | None
    tolerance: SpreadTolerance | None
    certified: bool
    status: str
    integral_gain: float
    best_achievable: str | None
    specs_achieved: tuple
    controller_factored: ControllerFactors


def _json_value(row, v):
    if row.field.type == "bool":
        return bool(v)
    return list(v) if isinstance(v, tuple) else v


def specs_json(specs: Specs) -> dict:
    """The ``specs`` object of the design JSON, from the spec table
    (:data:`robrst.problem.specs.SPEC_TABLE`: each row's ``published`` rule, in table
    order): the keys published always first, then the sampled loop's, then the others;
    then ``defaults`` (:data:`SPECS_DEFAULT_FIELDS`: the keys whose value is a default,
    :func:`robrst.problem.records.with_defaults`, and those the problem switched off).

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
    defaults, off = SPECS_DEFAULT_FIELDS
    out[defaults] = list(specs.defaults)      # the keys above whose value is a default
    out[off] = list(specs.off)                # defaults the problem switched off
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


def _solver_with_slack(result):
    """:func:`solver_json` with ``binding_slack`` beside ``binding`` (a synthesised design:
    :attr:`robrst.design.achieved.SolverSummary.binding_slack`)."""
    out = solver_json(result.synthesis)
    slack = result.solver_summary.binding_slack
    if slack:
        out["binding_slack"] = [None if v is None else float(v) for v in slack]
    return out


def design_json(result: DesignRecord) -> dict:
    """The public JSON contract of ``robrst design --json`` (fields are only added).

    The fields in the order of :data:`DESIGN_FIELDS` (those of
    :data:`OPTIONAL_FIELDS` only when the design has them), each written from its record.

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
    writers = {
        "problem": lambda: p.name,
        "method": lambda: result.method,
        "status": lambda: result.status,
        "controller": lambda: result.controller.as_dict(),
        "target_char_poly": lambda: None if result.target_char_poly is None
        else np.asarray(result.target_char_poly).tolist(),
        "specs": lambda: specs_json(p.specs),
        "temperature_range_C": lambda: list(p.family.range_C),
        "models": lambda: [analysis_json(a, m) for a, m in zip(result.analyses,
                                                               p.family.models)],
        "certified": lambda: bool(result.certified),
        "certificate": lambda: certificate_json(result.certificate),
        "solver": lambda: _solver_with_slack(result),
        "integral_gain": lambda: result.integral_gain,
        "best_achievable": lambda: result.best_achievable,
        "specs_achieved": lambda: [dict(zip(SPEC_ROW_FIELDS, (getattr(r, k) for k in
                                                               SPEC_ROW_FIELDS)))
                                   for r in result.specs_achieved],
        "controller_factored": lambda: factors_json(result.controller_factored),
        "method_reason": lambda: p.solver.method_reason,
        "assessment": lambda: assessment_json(result.assessment),
        "starts": lambda: result.starts.as_dict(),
        "tracking": lambda: result.tracking.as_dict(),
        "analytic_check": lambda: {k: getattr(result.analytic_check, k)
                                   for k in ANALYTIC_CHECK_FIELDS},
        "comparison": lambda: {"rows": result.comparison.rows,
                               "table": result.comparison.table},
        "artefact": lambda: artefact_record(p),      # what robrst.load_design reads back
        "fleet": lambda: result.fleet.as_dict(),
        "objective_bound": lambda: result.objective_bound.as_dict(),
        "feasibility": lambda: result.feasibility.as_dict(),
        "tolerance": lambda: result.tolerance.as_dict(),
    }
    return {k: writers[k]() for k in DESIGN_FIELDS
            if k not in OPTIONAL_FIELDS or getattr(result, k) is not None}


def certificate_json(cert: Certificate) -> dict:
    """The ``certificate`` object of the design JSON (fields are only added).

    Parameters
    ----------
    cert : Certificate
        The certificate.

    Returns
    -------
    dict
        :data:`CERTIFICATE_FIELDS` (``controller`` only with ``controller_damping_min``);
        ``models`` in their published form (:func:`model_record_json`).
    """
    writers = {
        "ratios": cert.ratios,
        "certified": lambda: cert.certified,
        "rtol": lambda: cert.rtol,
        "controller": lambda: {"damping": cert.controller.damping,
                               "damping_min": cert.controller.damping_min,
                               "poles_rad_s": [list(p) for p in cert.controller.poles_rad_s]},
        "models": lambda: [model_record_json(m) for m in cert.models],
        "violations": lambda: [{k: getattr(v, k) for k in VIOLATION_FIELDS}
                               for v in cert.violations],
        "interval": lambda: interval_json(cert.interval),
        "interval_proof": lambda: cert.interval.stability,
        "interval_resolution_C": lambda: cert.interval.max_spacing_C,
    }
    return {k: writers[k]() for k in CERTIFICATE_FIELDS
            if k != "controller" or cert.controller is not None}


def interval_json(rec: IntervalRecord) -> dict:
    """The certificate's ``interval`` object: :data:`INTERVAL_FIELDS` (those of a sweep,
    from ``points`` to ``statement``, only with several models; the proofs and the pole
    region's statement only when made).

    Parameters
    ----------
    rec : IntervalRecord
        The record.

    Returns
    -------
    dict
    """
    out = {}
    for k in INTERVAL_FIELDS:
        v = getattr(rec, k)
        if k in SWEEP_INTERVAL_FIELDS and rec.points is None or (
                k not in SWEEP_INTERVAL_FIELDS and k not in ("range_C", "stability", "peaks")
                and v is None):
            continue
        if k in ("guardian", "pole_region_proof"):
            v = proof_json(v)
        elif k == "pole_region":
            v = {f: getattr(v, f) for f in POLE_REGION_FIELDS}
        elif k == "range_C":
            v = list(v)
        elif k == "order_change_C":
            v = [list(o) for o in v]
        out[k] = v
    return out


def proof_json(proof: IntervalProof) -> dict:
    """An interval proof: ``proved``, its ``parts`` (when attempted) and why it was
    ``skipped``.

    Parameters
    ----------
    proof : IntervalProof
        The proof.

    Returns
    -------
    dict
    """
    out = {"proved": proof.proved}
    if proof.parts is not None:
        out["parts"] = [_segment_json(p) for p in proof.parts]
    if proof.skipped is not None:
        out["skipped"] = proof.skipped
    return out


def _segment_json(p):
    out = {"range_C": list(p.range_C)}
    if p.test is not None:
        out["test"] = p.test
    out["proved"] = p.proved
    if p.nodes is not None:
        out["nodes"], out["candidate_C"] = p.nodes, p.candidate_C
    return out


def loop_items(lf: LoopFigures, loop: str = "continuous",
               steps: bool = True) -> list[tuple[str, object]]:
    """``(published name, value)`` pairs of one loop's figures, in the published order.

    The continuous loop lists its stability first, then the peaks; the sampled loop its
    abscissa and peaks first (the order the JSON contract has always had), without the
    closed-loop degree and the band peak's frequency
    (:data:`LOOP_FIELDS`).  Band peaks and the figures of the newer specs only when
    computed; ``steps=False`` leaves the step figures out.

    Parameters
    ----------
    lf : LoopFigures
        The loop's figures.
    loop : {"continuous", "sampled"}
        Which loop this is (its names' suffix and order).
    steps : bool
        Include the step figures.

    Returns
    -------
    list of (str, object)
    """
    names = [k for k in LOOP_FIELDS[loop]
             if k not in OPTIONAL_LOOP_FIGURES
             or getattr(lf, OPTIONAL_LOOP_FIGURES[k]) is not None]
    out = [(figure_key(k, loop), getattr(lf, k)) for k in names]
    if steps and lf.step is not None:
        out += [(figure_key(k, loop), v) for k, v in lf.step.items()]
    return out


def model_record_json(rec: ModelRecord) -> dict:
    """One checked model of the certificate (``certificate.models[i]``), published.

    Parameters
    ----------
    rec : ModelRecord
        The record.

    Returns
    -------
    dict
        ``label, temperature_C``, the continuous then the sampled loop's figures
        (:func:`loop_items`), the hooks' figures and margins, ``family_member``,
        ``actuator`` (a further actuator) and, for step figures checked after the sweep,
        those last.
    """
    late = rec.steps_checked_after
    d = {"label": rec.label, "temperature_C": rec.temperature_C}
    for loop, lf in rec.loops():
        d.update(loop_items(lf, loop, steps=not late))
    d.update(rec.extra)
    if rec.margins:
        d["margins"] = rec.margins
    if rec.family_member is not None:
        d["family_member"] = rec.family_member
    if rec.actuator:
        d["actuator"] = rec.actuator
    if late:
        for loop, lf in rec.loops():
            if lf.step is not None:
                d.update((figure_key(k, loop), v) for k, v in lf.step.items())
    return d


def analysis_json(analysis: Analysis, plant: Plant) -> dict:
    """The ``models`` record of the design JSON (infinite frequencies as ``None``).

    Parameters
    ----------
    analysis : Analysis
        The analysis of one family model.
    plant : Plant
        The analysed plant (its ``A`` and ``B`` are written).

    Returns
    -------
    dict
        ``label, temperature_C, A, B, stable, closed_loop_poles, spectral_abscissa``,
        the peaks ``Ms, Mt, Mu, Msd`` with their frequencies and the margins.
    """
    pk, m = analysis.peaks, analysis.margins
    out = {"label": analysis.label, "temperature_C": analysis.temperature_C,
           "A": plant.A.tolist(), "B": plant.B.tolist(), "stable": bool(analysis.stable),
           "closed_loop_poles": [[float(z.real), float(z.imag)] for z in analysis.poles],
           "spectral_abscissa": float(analysis.spectral_abscissa)}
    for fig, name in ANALYSIS_PEAKS:
        out[fig] = pk[name].value
        out[fig + "_freq_rad_s"] = _finite(pk[name].freq_rad_s)
    out.update((k, getattr(m, k)) for k in MARGIN_FIELDS)
    return out


def assessment_json(assessment: Assessment) -> dict:
    """The ``assessment`` object of the design JSON.

    Parameters
    ----------
    assessment : Assessment
        What the specs left unbounded.

    Returns
    -------
    dict
        ``warnings, notes, damping_floor, damping_source, models`` (one per family member:
        ``label, temperature_C``, the continuous loop's damping and overshoot, the plant's
        damping, ``Msd`` and the open loop's, then the sampled loop's).
    """
    return {"warnings": list(assessment.warnings), "notes": list(assessment.notes),
            "damping_floor": assessment.damping_floor,
            "damping_source": assessment.damping_source,
            "models": [assessment_model_json(m) for m in assessment.models]}


def assessment_model_json(m: ModelAssessment) -> dict:
    """One family member of the ``assessment`` (the sampled loop's figures ``None`` without
    a sampling rate).

    Parameters
    ----------
    m : ModelAssessment
        The member's figures.

    Returns
    -------
    dict
    """
    out = {"label": m.label, "temperature_C": m.temperature_C,
           "damping": m.continuous.damping, "plant_damping": m.plant_damping,
           "overshoot_pct": m.continuous.overshoot_pct, "Msd": m.Msd,
           "open_loop_Msd": m.open_loop_Msd}
    out["damping_sampled"] = None if m.sampled is None else m.sampled.damping
    out["overshoot_pct_sampled"] = None if m.sampled is None else m.sampled.overshoot_pct
    out["Msd_sampled"] = None if m.sampled is None else m.sampled.Msd
    out["open_loop_Msd_sampled"] = None if m.sampled is None else m.sampled.open_loop_Msd
    return out


def factors_json(f: ControllerFactors) -> dict:
    """The ``controller_factored`` object: ``w0_rad_s`` and per polynomial ``gain,
    integrators, real, pairs, scaled``.

    Parameters
    ----------
    f : ControllerFactors
        The factored controller.

    Returns
    -------
    dict
    """
    out = {"w0_rad_s": f.w0_rad_s}
    for k in "RST":
        pf = getattr(f, k)
        out[k] = {"gain": pf.gain, "integrators": pf.integrators, "real": list(pf.real),
                  "pairs": [list(p) for p in pf.pairs], "scaled": list(pf.scaled)}
    return out


def _finite(x):
    return None if x is None or not np.isfinite(x) else float(x)


