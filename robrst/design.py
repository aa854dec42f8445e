"""The design pipeline: problem -> synthesis -> certificate -> analysis -> result.

:func:`run_problem` runs the method the problem asks for (analytic pole placement, the
robust NLP or the convex program), certifies the controller on the whole family
(:mod:`robrst.certificate.proof`), analyses every family model, checks a synthesised controller
against the closed-form Diophantine solution and compares it with an analytic design.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.certificate import steps as timespec
from robrst.core.analysis import analyze_many, spectral_abscissa_many
from robrst.certificate.proof import Violation, certify, certify_problem
from robrst.base.errors import CoprimeError, SpecError
from robrst.certificate.models import BOUNDED
from robrst.problem.records import Problem
from robrst.core.rst import closed_loop
from robrst.synthesis import analytic
from robrst.synthesis.parametrize import integral_gain
from robrst.synthesis.robust import best_achievable
from robrst.base.threads import one_blas_thread

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import PoleSpec
    from robrst.synthesis.analytic import AnalyticDesign

__all__ = ["DesignResult", "AnalyticCheck", "Comparison", "run_problem", "analytic_design",
           "analytic_check", "comparison", "with_time_domain", "artefact_record",
           "ARTEFACT_FORMAT"]

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

    def as_dict(self) -> dict:
        """The ``analytic_check`` object of the design JSON.

        Returns
        -------
        dict
            ``kind, max_rel_coef_error, passed``.
        """
        return {"kind": self.kind, "max_rel_coef_error": self.max_rel_coef_error,
                "passed": self.passed}


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

    def as_dict(self) -> dict:
        """The ``comparison`` object of the design JSON.

        Returns
        -------
        dict
            ``rows, table``.
        """
        return {"rows": self.rows, "table": self.table}


@dataclass(frozen=True, eq=False)
class DesignResult:
    """A certified (or explicitly uncertified) design and everything reported about it.

    Parameters
    ----------
    problem : Problem
        The problem designed.
    method : str
        ``solver.method``.
    controller : RSTController
        The controller (the 2-DOF controller with ``T_mode = "reference_model"``; then
        ``synthesis.controller`` is the feedback).
    target_char_poly : numpy.ndarray
        The nominal characteristic polynomial aimed at.
    analyses : tuple of Analysis
        One :class:`~robrst.core.analysis.Analysis` per family model (none when
        :func:`run_problem` was asked for none).
    certificate : Certificate
        The certificate over the whole temperature interval.
    synthesis : AnalyticDesign or SynthesisResult
        The stage's own record.
    analytic_check : AnalyticCheck, optional
        The synthesised controller against the Sylvester solution.
    comparison : Comparison, optional
        The comparison with ``compare_with``'s analytic design.
    tracking : Tracking, optional
        The 2-DOF reference path (``T_mode = "reference_model"``).
    fleet : FleetDesign, optional
        The :class:`~robrst.synthesis.scenario.FleetDesign` of a problem with a
        ``[spread]`` (then ``problem.scenarios`` are the drawn actuators the program held
        on).

    Attributes
    ----------
    best_achievable : str or None
        What an uncertified design achieves (its worst violation).
    certified : bool
        The certificate holds over the whole family and sweep (a fleet design: and on
        every actuator drawn for it).
    status : str
        ``"certified"`` or ``"not_certified"``.
    integral_gain : float
        ``lim s R/S`` [V/(µm s)] of the controller.
    """

    problem: object
    method: str
    controller: object
    target_char_poly: object
    analyses: tuple
    certificate: object
    synthesis: object
    analytic_check: AnalyticCheck = None
    comparison: Comparison = None
    tracking: object = None
    fleet: object = None

    @property
    def best_achievable(self):
        """What an uncertified design achieves (its worst violation), or ``None``."""
        return best_achievable(self.certificate)

    @property
    def certified(self):
        """True when the certificate holds over the whole family and sweep (a fleet
        design: and on every actuator drawn for it)."""
        return self.certificate.certified and (self.fleet is None or not self.fleet.violated)

    @property
    def status(self):
        """``"certified"`` or ``"not_certified"``."""
        return "certified" if self.certified else "not_certified"

    @property
    def integral_gain(self):
        """``lim s R/S`` [V/(µm s)] of the controller."""
        return integral_gain(self.controller)

    def loops(self, sampled: bool = True) -> dict:
        """Every family model's closed loop as python-control systems, by model label.

        Parameters
        ----------
        sampled : bool
            The sampled loop (the problem's rate and delay, ``dt = 1/fs``) when the problem
            names a rate; ``False``: the continuous one.

        Returns
        -------
        dict
            ``{label: {"L", "S", "T", "U", "Sd", "Tr"}}`` of
            :func:`robrst.core.rst.closed_loop_control`.  The controller itself:
            ``self.controller.to_control(fs)``.
        """
        from robrst.core.rst import closed_loop_control

        sp = self.problem.specs
        fs = sp.sample_rate_hz if sampled and sp.sampled else None
        return {m.label: closed_loop_control(m, self.controller, fs,
                                             sp.delay_samples if fs else 0)
                for m in self.problem.family.models}

    def solver_dict(self) -> dict:
        """The ``solver`` object of the JSON contract.

        Returns
        -------
        dict
        """
        s = self.synthesis
        if isinstance(s, analytic.AnalyticDesign):
            return {"name": "sylvester", "status": s.status, "w0_rad_s": s.w0, "cond": s.cond,
                    "cond_unscaled": s.cond_unscaled, "residual": s.residual}
        return s.solver_dict()

    def as_dict(self) -> dict:
        """The public JSON contract of ``robrst design --json`` (fields are only added).

        Returns
        -------
        dict
            See the documentation's command-line reference (``robrst design``).
        """
        p = self.problem
        sp = p.specs
        models = [a.as_dict(m) for a, m in zip(self.analyses, p.family.models)]
        specs = {"Ms_max": sp.Ms_max, "Mt_max": sp.Mt_max, "Mu_max": sp.Mu_max,
                 "stable_controller": bool(sp.stable_controller)}
        if sp.sampled:
            specs.update(sample_rate_hz=sp.sample_rate_hz, delay_samples=sp.delay_samples)
        out = {
            "problem": p.name,
            "method": self.method,
            "status": self.status,
            "controller": self.controller.as_dict(),
            "target_char_poly": None if self.target_char_poly is None
            else np.asarray(self.target_char_poly).tolist(),
            "specs": specs,
            "temperature_range_C": list(p.family.range_C),
            "models": models,
            "certified": bool(self.certified),
            "certificate": self.certificate.as_dict(),
            "solver": self.solver_dict(),
            "integral_gain": self.integral_gain,
            "best_achievable": self.best_achievable,
        }
        if sp.T_resonance_max is not None:
            specs.update(T_resonance_max=sp.T_resonance_max,
                         resonance_band_hz=list(sp.resonance_band_hz))
        if sp.Mu_hf_max is not None:
            specs.update(Mu_hf_max=sp.Mu_hf_max, Mu_hf_above_hz=sp.Mu_hf_above_hz)
        if sp.time_domain:
            specs.update(overshoot_max_pct=sp.overshoot_max_pct,
                         settling_time_max_s=sp.settling_time_max_s, step_um=sp.step_um,
                         step_u_max_V=sp.step_u_max_V)
        if self.tracking is not None:
            out["tracking"] = self.tracking.as_dict()
        if self.analytic_check is not None:
            out["analytic_check"] = self.analytic_check.as_dict()
        if self.comparison is not None:
            out["comparison"] = self.comparison.as_dict()
        out["artefact"] = artefact_record(p)   # what robrst.load_design reads back
        if self.fleet is not None:
            out["fleet"] = self.fleet.as_dict()
        return out


def analytic_design(problem: Problem, poles: PoleSpec | None = None) -> AnalyticDesign:
    """Pole placement on the reference model of ``problem`` (the paper's method).

    Parameters
    ----------
    problem : Problem
        The problem (its reference model and controller structure).
    poles : PoleSpec, optional
        Other poles than the problem's.

    Returns
    -------
    AnalyticDesign

    Raises
    ------
    SpecError, CoprimeError
        The message starts with the problem file's path (when it has one).
    """
    try:
        return analytic.pole_placement(problem.family.reference_model, poles or problem.poles,
                                       problem.controller)
    except (SpecError, CoprimeError) as exc:     # DegreeError is a SpecError
        if problem.path and not str(problem.path).startswith("<") and str(problem.path) not in str(exc):
            exc.args = (f"{problem.path}: {exc}",) + exc.args[1:]
        raise


def with_time_domain(problem: Problem, cert: Certificate, ctrl: RSTController,
                     factor: ArrayLike | None = None) -> Certificate:
    """``cert`` (of the feedback ``R/S``) completed by the time-domain specs of ``ctrl``.

    The frequency-domain records of a certificate depend on ``R/S`` only, so a
    controller whose reference path changed (:mod:`robrst.synthesis.tracking`) keeps
    them; the reference-step figures (:mod:`robrst.certificate.steps`) are computed on every
    model of the certificate (family and sweep, and the sampled loop) and added.
    Spectral abscissae include the roots the new controller adds (its reference filter):
    those of ``factor`` when given (a polynomial that ``ctrl``'s ``R`` and ``S`` have
    beyond the certificate's controller, so every closed-loop polynomial gained exactly
    it), else those of each new closed-loop polynomial.

    Parameters
    ----------
    problem : Problem
        The problem.
    cert : Certificate
        The feedback's certificate.
    ctrl : RSTController
        The controller with its reference path.
    factor : array_like, optional
        The common factor of ``R`` and ``S`` the reference path added.

    Returns
    -------
    Certificate
    """
    sp = problem.specs
    recs = [dict(rec) for rec in cert.models]
    fams = problem.families      # a record of a further actuator names it (certify_families)
    models = [fams[rec.get("actuator", 0)].at(rec["temperature_C"]) for rec in recs]
    labels = [m.label if not rec.get("actuator") else f"actuator{rec['actuator']}/{m.label}"
              for m, rec in zip(models, recs)]
    kinds = [(models, None, "")]
    if sp.sampled:
        kinds.append(([problem.family.sampled(m, sp.sample_rate_hz, sp.delay_samples)
                       for m in models], sp.sample_rate_hz, "_sampled"))
    found = [[] for _ in recs]            # per model, the failed specs of each loop
    added = None if factor is None else spectral_abscissa_many([factor])[0][0]
    for plants, fs, suffix in kinds:      # every model's loop of one kind at once
        cls = [closed_loop(plant, ctrl) for plant in plants]
        sas = [added] * len(recs) if factor is not None else [
            sa for sa, _ in spectral_abscissa_many([cl.Delta for cl in cls])]
        for rec, sa in zip(recs, sas):
            rec["spectral_abscissa" + suffix] = max(rec["spectral_abscissa" + suffix], sa)
        if not sp.time_domain:
            continue
        ks = [k for k, rec in enumerate(recs) if rec[f"stable{suffix}"]]
        checked = timespec.check_many([plants[k] for k in ks], ctrl, [cls[k] for k in ks],
                                      sp, cert.rtol, fs)
        for k, (t_rec, failed) in zip(ks, checked):
            recs[k].update({q + suffix: v for q, v in t_rec.items()})
            found[k] += [Violation(labels[k], models[k].temperature_C, q, v, b, None,
                                   "sampled" if fs else "continuous", kind)
                         for q, v, b, kind in failed]
    viols = list(cert.violations) + [v for f in found for v in f]
    bounds = {**cert.bounds, **{key: getattr(sp, attr) for key, attr in BOUNDED
                                if getattr(sp, attr) is not None}}
    return replace(cert, certified=not viols, models=tuple(recs), violations=tuple(viols),
                   interval={**cert.interval, "time_domain": "checked points"}, bounds=bounds)


def analytic_check(problem: Problem, ctrl: RSTController, Am: ArrayLike) -> AnalyticCheck:
    """Compare a synthesised controller with the Sylvester solution for the same ``Am``.

    With no free degree (``extra_degree = 0``) the Diophantine solution is unique and
    the synthesis must reproduce it coefficient by coefficient; with free degrees the
    check is the Diophantine residual at the nominal model.

    Parameters
    ----------
    problem : Problem
        The problem.
    ctrl : RSTController
        The synthesised controller.
    Am : array_like
        Its nominal characteristic polynomial.

    Returns
    -------
    AnalyticCheck
    """
    ref = problem.family.reference_model
    c = problem.controller
    if c.extra_degree == 0:
        sol = analytic.solve_diophantine(ref.A, ref.B, Am, c.S_fixed, c.R_fixed)
        err = max(poly.rel_coef_error(ctrl.R, sol.R), poly.rel_coef_error(ctrl.S, sol.S))
        kind = "sylvester_coefficients"
    else:
        err = analytic.diophantine_residual(ref.A, ref.B, ctrl.R, ctrl.S, Am)
        kind = "diophantine_residual"
    return AnalyticCheck(kind=kind, max_rel_coef_error=float(err), passed=bool(err <= 1e-8))


def _worst(cert, ctrl, sampled):
    row = {"worst_Ms": cert.worst("Ms"), "worst_Mt": cert.worst("Mt"),
           "worst_Mu": cert.worst("Mu"), "min_modulus_margin": 1 / cert.worst("Ms"),
           "max_spectral_abscissa": cert.worst("spectral_abscissa"),
           "integral_gain": integral_gain(ctrl), "certified": cert.certified}
    if sampled:
        row.update({f"worst_{k}_sampled": cert.worst(f"{k}_sampled") for k in ("Ms", "Mt", "Mu")})
    return row


def comparison(problem: Problem, ctrl: RSTController, cert: Certificate) -> Comparison | None:
    """Worst-case margins over the family: this controller vs ``compare_with``'s analytic design.

    This controller's figures come from its certificate (reused, not recomputed); the
    analytic design's are computed on the family members only (both loops), which is
    what the comparison shows — a certificate of the analytic design is not the point.

    Parameters
    ----------
    problem : Problem
        The problem (its ``compare_with``).
    ctrl : RSTController
        This controller.
    cert : Certificate
        This controller's certificate.

    Returns
    -------
    Comparison or None
        ``None`` when the problem names no ``compare_with`` file.
    """
    from robrst.problem.files import load_problem

    other = problem.solver.compare_with
    if not other:
        return None
    path = Path(problem.path).parent / other
    ctrl_a = analytic_design(load_problem(path)).controller
    # the members only: no sweep, no refinement (an interval whose figures change too fast
    # between members is unresolved, so "certified" stays a conservative verdict)
    cert_a = certify(problem.family, ctrl_a, problem.specs, n_sweep=0,
                     rtol=problem.solver.cert_tol, max_refine=0)
    rows = {"robust": _worst(cert, ctrl, problem.specs.sampled),
            f"analytic ({path.name})": _worst(cert_a, ctrl_a, problem.specs.sampled)}
    lo, hi = problem.family.range_C
    names = list(rows)
    w = max(len(n) for n in names) + 2
    lines = [f"worst case over the family ({lo:g}..{hi:g} °C; robust: certificate sweep,"
             " analytic: family members):",
             f"{'':<22}" + "".join(f"{n:>{w}}" for n in names)]
    for k in rows["robust"]:
        lines.append(f"{k:<22}" + "".join(
            f"{(str(rows[n][k]) if isinstance(rows[n][k], bool) else format(rows[n][k], '.4g')):>{w}}"
            for n in names))
    return Comparison(rows=rows, table="\n".join(lines), range_C=(lo, hi))


def run_problem(problem: Problem, progress: Callable[[str], None] | None = None,
                templates: dict | None = None, analyses: bool = True) -> DesignResult:
    """Run the design the problem asks for, certify it, analyse every family model.

    A synthesis always ends with a controller: when the specs cannot be met the result
    is the best controller found, ``status == "not_certified"``, with
    :attr:`DesignResult.best_achievable` and the binding constraints.

    Parameters
    ----------
    problem : Problem
        The problem (a problem file read by :func:`robrst.load_problem`, or built in code).
    progress : callable, optional
        Called with one line of text per stage (certification rounds included).
    templates : dict, optional
        Built NLP solvers by structure, shared between designs of the same structure
        (see :class:`robrst.synthesis.synthesizer.Synthesizer`).
    analyses : bool
        Analyse every family model (exact peaks to 1e-10, margins); off: none (a sweep
        reads the certificate's figures and computes only the margins).

    Returns
    -------
    DesignResult

    Raises
    ------
    SpecError, CoprimeError, DegreeError
        Ill-posed problems (the message names the cause and the key to change).

    Examples
    --------
    >>> from robrst import load_problem, run_problem
    >>> result = run_problem(load_problem("paper"))
    >>> result.certified, result.status
    (True, 'certified')
    """
    with one_blas_thread(problem.needs_scipy):
        if problem.spread is not None:
            return _fleet(problem, progress, templates, analyses)
        return _design(problem, progress, templates, analyses)


def _fleet(problem, progress, templates, analyse):
    """A design for the problem's spread (:mod:`robrst.synthesis.scenario`)."""
    from robrst.synthesis.scenario import scenario_design

    templates = {} if templates is None else templates

    say = progress or (lambda msg: None)

    def one(p, warm):
        return _design(p, lambda msg: say("  " + msg), templates, False, warm, compare=False)

    result, fleet = scenario_design(problem, one, progress)
    comp = comparison(result.problem, result.controller, result.certificate)
    analyses = analyze_many(problem.family.models, result.controller) if analyse else ()
    return replace(result, analyses=analyses, comparison=comp, fleet=fleet)


def _design(problem, progress, templates, analyse, warm=None, compare=True):
    """:func:`run_problem` (its BLAS limited by the caller)."""
    from robrst.synthesis.robust import robust_synthesis

    say = progress or (lambda msg: None)
    method = problem.solver.method
    start = analytic_design(problem)
    two_dof = problem.controller.T_mode == "reference_model"
    if method == "analytic":
        say(f"analytic pole placement: cond(scaled Sylvester) = {start.cond:.3g}"
            f" (unscaled {start.cond_unscaled:.3g})")
        stage, check = start, None
        ctrl, trk = _tracking(problem, start.controller) if two_dof else (start.controller, None)
        cert = certify_problem(problem, ctrl)
    else:
        if method == "nlp":
            stage = robust_synthesis(problem, start, say, templates, warm)
        else:
            from robrst.synthesis.convex import convex_synthesis   # cvxpy: only for this method

            stage = convex_synthesis(problem, start, say)
        check = analytic_check(problem, stage.controller, stage.Am)
        ctrl, trk, cert = stage.controller, None, stage.certificate
        if two_dof:
            ctrl, trk, cert = _tracked(problem, ctrl, cert)
        elif problem.specs.time_domain:
            cert = with_time_domain(problem, cert, ctrl)
    comp = None if method == "analytic" or not compare else comparison(problem, ctrl, cert)
    analyses = analyze_many(problem.family.models, ctrl) if analyse else ()
    return DesignResult(problem=problem, method=method, controller=ctrl,
                        target_char_poly=stage.Am, analyses=analyses, certificate=cert,
                        synthesis=stage, analytic_check=check, comparison=comp, tracking=trk)


def _tracking(problem, ctrl):
    from robrst.synthesis.tracking import design_tracking

    return design_tracking(problem, ctrl)


def _tracked(problem, ctrl, cert):
    """The 2-DOF controller of the feedback ``ctrl`` with ``cert`` completed by its
    time-domain figures: the first reference path
    (:func:`robrst.synthesis.tracking.tracking_candidates`) whose loops on every model of
    the certificate are stable and meet the time-domain specs, else the first one.

    Returns
    -------
    (RSTController, Tracking, Certificate)
    """
    from robrst.synthesis.tracking import tracking_candidates

    first = None
    for out, trk in tracking_candidates(problem, ctrl):
        done = with_time_domain(problem, cert, out, factor=trk.Am_ref)
        first = first or (out, trk, done)
        stable = all(r["stable"] and r.get("stable_sampled", True) for r in done.models)
        if not problem.specs.time_domain or (
                stable and len(done.violations) == len(cert.violations)):
            return out, trk, done
    return first
