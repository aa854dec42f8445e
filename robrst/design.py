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
from robrst.certificate.proof import ACTUATOR, Violation, actuator_of, certify, certify_problem
from robrst.base.errors import CoprimeError, SpecError
from robrst.certificate.figures import StepFigures
from robrst.certificate.models import BOUNDED
from robrst.problem.records import Problem
from robrst.core.rst import closed_loop
from robrst.synthesis import analytic
from robrst.synthesis.parametrize import integral_gain
from robrst.synthesis.robust import best_achievable
from robrst.base.interrupt import offer, stop_pool, worker_signals
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
    assessment : Assessment, optional
        What the specs left unbounded and its warnings
        (:class:`~robrst.certificate.assessment.Assessment`; with the analyses).
    starts : MultiStart, optional
        Every start of a multi-start design (:class:`~robrst.synthesis.multistart.MultiStart`).

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
    assessment: object = None
    starts: object = None

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
            "specs_achieved": spec_rows(p, self.certificate),
            "controller_factored": controller_factors(self.controller),
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
        for key in ("Msd_max", "Mry_max", "damping_min", "decay_min", "controller_damping_min"):
            if getattr(sp, key) is not None:
                specs[key] = getattr(sp, key)
        out["method_reason"] = p.solver.method_reason
        if self.assessment is not None:
            out["assessment"] = self.assessment.as_dict()
        if self.starts is not None:
            out["starts"] = self.starts.as_dict()
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


# spec key -> (certificate figure, is a lower bound)
SPEC_FIGURES = (("Ms_max", "Ms", False), ("Mt_max", "Mt", False), ("Mu_max", "Mu", False),
                ("T_resonance_max", "Mt_resonance_band", False), ("Mu_hf_max", "Mu_hf", False),
                ("Msd_max", "Msd", False), ("Mry_max", "Mry", False),
                ("overshoot_max_pct", "overshoot_pct", False),
                ("settling_time_max_s", "settling_time_s", False),
                ("step_u_max_V", "step_u_peak_V", False), ("damping_min", "damping", True),
                ("decay_min", "decay_rad_s", True))
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
    floor, source = sp.damping_floor(problem.family)
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
    recs = list(cert.models)
    fams = problem.families      # a record of a further actuator names it (certify_families)
    acts = [rec.actuator or actuator_of(rec.label)[0] for rec in recs]
    models = [fams[k].at(rec.temperature_C) for k, rec in zip(acts, recs)]
    labels = [m.label if not k else f"{ACTUATOR}{k}/{m.label}" for m, k in zip(models, acts)]
    kinds = [(models, None, "continuous")]
    if sp.sampled:
        kinds.append(([fams[k].sampled(m, sp.sample_rate_hz, sp.delay_samples)
                       for k, m in zip(acts, models)], sp.sample_rate_hz, "sampled"))
    found = [[] for _ in recs]            # per model, the failed specs of each loop
    added = None if factor is None else spectral_abscissa_many([factor])[0][0]
    for plants, fs, loop in kinds:        # every model's loop of one kind at once
        cls = [closed_loop(plant, ctrl) for plant in plants]
        sas = [added] * len(recs) if factor is not None else [
            sa for sa, _ in spectral_abscissa_many([cl.Delta for cl in cls])]
        figs = [rec.loop(loop) for rec in recs]
        figs = [replace(f, spectral_abscissa=max(f.spectral_abscissa, sa))
                for f, sa in zip(figs, sas)]
        if sp.time_domain:
            ks = [k for k, f in enumerate(figs) if f.stable]
            checked = timespec.check_many([plants[k] for k in ks], ctrl, [cls[k] for k in ks],
                                          sp, cert.rtol, fs)
            for k, (t_rec, failed) in zip(ks, checked):
                figs[k] = replace(figs[k], step=StepFigures(**t_rec))
                found[k] += [Violation(labels[k], models[k].temperature_C, q, v, b, None,
                                       loop, kind) for q, v, b, kind in failed]
        recs = [replace(rec, **{loop: f}) for rec, f in zip(recs, figs)]
    if sp.time_domain:   # figures the certificate did not have are published after it
        recs = [rec if rec.steps_checked_after or old.continuous.step is not None
                or (old.sampled is not None and old.sampled.step is not None)
                else replace(rec, steps_checked_after=True)
                for rec, old in zip(recs, cert.models)]
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
        row.update({f"worst_{k}_sampled": cert.worst(k, loop="sampled") for k in ("Ms", "Mt", "Mu")})
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
                templates: dict | None = None, analyses: bool = True,
                multistart: bool | None = None) -> DesignResult:
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
        Analyse every family model (exact peaks to 1e-10, margins) and assess what the
        specs left unbounded (:func:`robrst.certificate.assessment.assess`: damping,
        overshoot, input disturbances); off: none (a sweep reads the certificate's figures
        and computes only the margins).
    multistart : bool, optional
        The robust program (``method = "nlp"``) also runs from the diverse starts of
        :mod:`robrst.synthesis.multistart` on 2 processes and keeps the best certified
        answer (default: ``problem.solver.multistart``; sweeps pass ``False``). A problem
        with a ``[spread]`` is designed for the fleet (:mod:`robrst.synthesis.scenario`),
        its rounds warm-started from one another and never multi-started.

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
    if multistart is None:
        multistart = problem.solver.multistart
    with one_blas_thread(problem.needs_scipy):
        if problem.spread is not None:
            return _fleet(problem, progress, templates, analyses)
        return _design(problem, progress, templates, analyses, multistart)


def _fleet(problem, progress, templates, analyse):
    """A design for the problem's spread (:mod:`robrst.synthesis.scenario`): every round
    one design warm-started from the previous round's, without comparison or multi-start."""
    from robrst.synthesis.scenario import scenario_design

    templates = {} if templates is None else templates

    say = progress or (lambda msg: None)

    def one(p, warm):
        return _design(p, lambda msg: say("  " + msg), templates, False, False, warm,
                       compare=False)

    result, fleet = scenario_design(problem, one, progress)
    comp = comparison(result.problem, result.controller, result.certificate)
    analyses = analyze_many(problem.family.models, result.controller) if analyse else ()
    assessment = None
    if analyse:
        from robrst.certificate.assessment import assess

        assessment = assess(result.problem, result.controller)
    return replace(result, analyses=analyses, comparison=comp, fleet=fleet,
                   assessment=assessment)


def _design(problem, progress, templates, analyse, multistart, warm=None, compare=True):
    """:func:`run_problem` (its BLAS limited by the caller)."""
    say = progress or (lambda msg: None)
    method = problem.solver.method
    start = analytic_design(problem)          # an ill-posed problem fails before any line
    say(f"method {problem.solver.method_reason}")
    two_dof = problem.controller.T_mode == "reference_model"
    starts = None
    if method == "analytic":
        say(f"analytic pole placement: cond(scaled Sylvester) = {start.cond:.3g}"
            f" (unscaled {start.cond_unscaled:.3g})")
        stage, check = start, None
        ctrl, trk = _tracking(problem, start.controller) if two_dof else (start.controller, None)
        cert = certify_problem(problem, ctrl)
    else:
        if method == "nlp" and multistart and problem.solver.starts > 0:
            from robrst.synthesis.multistart import plans

            (stage, ctrl, trk, cert), starts = _multistart(
                problem, plans(problem, problem.solver.starts), start, say, templates)
        else:
            stage, ctrl, trk, cert = _candidate(problem, problem, False, start, say, templates,
                                                warm=warm)
            _offer(problem, ctrl, cert)
        check = analytic_check(problem, stage.controller, stage.Am)
    comp = None if method == "analytic" or not compare else comparison(problem, ctrl, cert)
    analyses = analyze_many(problem.family.models, ctrl) if analyse else ()
    assessment = None
    if analyse:
        from robrst.certificate.assessment import assess

        assessment = assess(problem, ctrl)
    return DesignResult(problem=problem, method=method, controller=ctrl,
                        target_char_poly=stage.Am, analyses=analyses, certificate=cert,
                        synthesis=stage, analytic_check=check, comparison=comp, tracking=trk,
                        assessment=assessment, starts=starts)


def _candidate(problem, original, recheck, start=None, say=None, templates=None, budget=None,
               warm=None):
    """One synthesis of ``problem`` judged on ``original`` (the same problem, or a
    neighbouring one whose answer is certified on ``original`` when ``recheck``):
    ``(stage, controller, tracking, certificate)`` with the reference path and the
    time-domain figures completed; ``warm`` a previous design's synthesis record, the
    robust synthesis's preferred start (a fleet design's rounds)."""
    from robrst.synthesis.robust import robust_synthesis

    start = start if start is not None else analytic_design(problem)
    if problem.solver.method == "convex":
        from robrst.synthesis.convex import convex_synthesis   # cvxpy: only for this method

        stage = convex_synthesis(problem, start, say)
    else:
        stage = robust_synthesis(problem, start, say, templates, warm=warm, budget=budget)
    ctrl, trk, cert = stage.controller, None, stage.certificate
    if recheck:
        from robrst.synthesis.attempts import frequency_certificate

        cert = frequency_certificate(original, ctrl)
    if original.controller.T_mode == "reference_model":
        ctrl, trk, cert = _tracked(original, ctrl, cert)
    elif original.specs.time_domain:
        cert = with_time_domain(original, cert, ctrl)
    return stage, ctrl, trk, cert


def _objective(problem, ctrl, cert):
    """The certified objective (larger is better; ``None`` when not certified)."""
    if not cert.certified:
        return None
    obj = problem.solver.objective
    if obj == "max_integral_gain":
        ki = integral_gain(ctrl)
        return abs(ki) if np.isfinite(ki) else None
    if obj == "min_Ms":
        return -cert.worst("Ms")
    return 0.0


def _offer(problem, ctrl, cert):
    """Offer a certified candidate as the answer of a run a signal stops
    (:func:`robrst.base.interrupt.offer`)."""
    obj = _objective(problem, ctrl, cert)
    if obj is not None:
        offer(obj, (problem, ctrl, cert))


def _worst_ratio(cert):
    r = [v.ratio for v in cert.violations]
    return max(r) if r else 0.0


def _run_start(plan, original, budget=None):
    """A multi-start run in a worker process: its candidate, or the error."""
    import time

    t0 = time.perf_counter()
    problem = plan.problem
    if budget is not None:    # every IPOPT call within the budget too
        problem = replace(problem, solver=replace(problem.solver, max_iter=min(
            problem.solver.max_iter, int(budget))))
    try:
        with one_blas_thread(problem.needs_scipy):
            return _candidate(problem, original, plan.recheck, budget=budget), None, \
                time.perf_counter() - t0
    except Exception as exc:      # noqa: BLE001 — a failed start is an outcome, not a crash
        return None, f"{type(exc).__name__}: {exc}", time.perf_counter() - t0


MULTISTART_WORKERS = 2
MIN_START_BUDGET = 100     # IPOPT iterations an extra start may spend at least


def _multistart(problem, plans, start, say, templates):
    """The design as asked, then the ``plans`` on ``MULTISTART_WORKERS`` processes, each
    with the first run's IPOPT iterations as its budget (at least ``MIN_START_BUDGET``);
    the best certified objective wins (else the smallest worst violation).

    Returns
    -------
    ((stage, controller, tracking, certificate), MultiStart)
    """
    import time
    from concurrent.futures import ProcessPoolExecutor
    import multiprocessing

    from robrst.synthesis.multistart import MultiStart, StartOutcome, StartPlan

    t0 = time.perf_counter()
    say(f"multi-start: the problem as asked and {len(plans)} other starts on"
        f" {MULTISTART_WORKERS} processes")
    runs = [StartPlan("as asked", problem)] + list(plans)
    results = [None] * len(runs)
    t1 = time.perf_counter()
    results[0] = (_candidate(problem, problem, False, start, say, templates), None,
                  time.perf_counter() - t1)
    _offer(problem, results[0][0][1], results[0][0][3])
    first = results[0][0][0]
    budget = max(MIN_START_BUDGET, sum(r.iterations for r in getattr(first, "rounds", ())))
    try:
        ctx = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(MULTISTART_WORKERS, mp_context=ctx,
                                 initializer=worker_signals) as pool:
            try:
                futs = [pool.submit(_run_start, p, problem, budget) for p in runs[1:]]
                for k, f in enumerate(futs, 1):
                    results[k] = f.result()
                    if results[k][0] is not None:
                        _offer(problem, results[k][0][1], results[k][0][3])
            except KeyboardInterrupt:      # a signal: the workers stop now, not at their end
                stop_pool(pool)
                raise
    except (OSError, ValueError, ImportError) as exc:   # no processes here: one at a time
        say(f"multi-start: no worker processes ({exc}); running the starts in turn")
        for k, p in enumerate(runs):
            if results[k] is None:
                results[k] = _run_start(p, problem, budget)
    outcomes, best, best_key = [], None, None
    for k, (p, (cand, err, wall)) in enumerate(zip(runs, results)):
        if cand is None:
            outcomes.append(StartOutcome(p.name, "failed", wall_time_s=wall, note=err))
            continue
        stage, ctrl, trk, cert = cand
        obj = _objective(problem, ctrl, cert)
        outcomes.append(StartOutcome(
            p.name, "certified" if cert.certified else "not_certified", objective=obj,
            integral_gain=integral_gain(ctrl), worst_ratio=_worst_ratio(cert),
            placement=getattr(stage, "placement", None), wall_time_s=wall))
        key = (1, obj, -k) if obj is not None else (0, -_worst_ratio(cert), -k)
        if best_key is None or key > best_key:
            best, best_key = (k, cand), key
        say(f"multi-start: {p.name}: {outcomes[-1].status}"
            + (f", objective {obj:.6g}" if obj is not None else ""))
    k, cand = best
    ms = MultiStart(outcomes=tuple(outcomes), winner=runs[k].name,
                    objective=problem.solver.objective, workers=MULTISTART_WORKERS,
                    wall_time_s=time.perf_counter() - t0)
    return cand, ms


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
        stable = all(r.stable for r in done.models)
        if not problem.specs.time_domain or (
                stable and len(done.violations) == len(cert.violations)):
            return out, trk, done
    return first
