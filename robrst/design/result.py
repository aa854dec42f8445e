"""The design's records: :class:`DesignResult` and its typed parts.

A :class:`DesignResult` carries the problem, the controller, the synthesis record, the
certificate and the analyses of one design (:func:`robrst.design.run_problem`); the JSON
contract of ``robrst design --json`` is written from it in one place
(:mod:`robrst.design.contract`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from robrst.design.achieved import (AnalyticCheck, Comparison, ControllerFactors,
                                    SolverSummary, SpecRow, StartsSummary, controller_factors,
                                    solver_summary, spec_rows, starts_summary)
from robrst.synthesis.parametrize import integral_gain
from robrst.synthesis.robust import best_achievable

if TYPE_CHECKING:
    from robrst.certificate.assessment import Assessment
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.design.tolerance import SpreadTolerance
    from robrst.problem.records import Problem
    from robrst.synthesis.analytic import AnalyticDesign
    from robrst.synthesis.bound import ObjectiveBound
    from robrst.synthesis.feasibility import FeasibilityVerdict
    from robrst.synthesis.multistart import MultiStart
    from robrst.synthesis.outcome import SynthesisResult
    from robrst.synthesis.scenario import FleetDesign
    from robrst.synthesis.tracking import Tracking

__all__ = ["DesignResult", "SKIPPED"]

#: what the pipeline did about a proof that no linear controller meets the specs
SKIPPED = ("the synthesis was skipped (no controller meets the specs: the proof above); the"
           " controller is the analytic start")


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
    objective_bound : ObjectiveBound, optional
        What any linear controller could reach on the family, and this design's share
        (:func:`robrst.synthesis.bound.objective_bound`; with the analyses).
    feasibility : FeasibilityVerdict, optional
        A design that is not certified: infeasible (a proof) or not found (what it misses,
        what to try) (:func:`robrst.synthesis.feasibility.feasibility_verdict`).
    tolerance : SpreadTolerance, optional
        A certified design without a ``[spread]``: how far the static gain and the
        resonance may move before a spec fails (:func:`robrst.design.tolerance.spread_tolerance`;
        with the analyses).

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
    specs_achieved : tuple of SpecRow
        Every bounded spec, its worst achieved value, slack and where it binds.
    controller_factored : ControllerFactors
        R, S and T factored.
    solver_summary : SolverSummary
        The solver's objective, binding constraints and notes.
    starts_summary : StartsSummary or None
        What the multi-start found.
    """

    problem: Problem
    method: str
    controller: RSTController
    target_char_poly: np.ndarray | None
    analyses: tuple
    certificate: Certificate
    synthesis: AnalyticDesign | SynthesisResult
    analytic_check: AnalyticCheck | None = None
    comparison: Comparison | None = None
    tracking: Tracking | None = None
    fleet: FleetDesign | None = None
    assessment: Assessment | None = None
    starts: MultiStart | None = None
    objective_bound: ObjectiveBound | None = None
    feasibility: FeasibilityVerdict | None = None
    tolerance: SpreadTolerance | None = None

    @property
    def best_achievable(self):
        """What an uncertified design achieves (its worst violation), or ``None``.

        When no linear controller meets the specs (``feasibility`` holds the proof and the
        synthesis was skipped) the line says that the figure is the analytic start's: its
        worst violation is not what binds (the proof, ``feasibility``, names that).
        """
        line = best_achievable(self.certificate)
        fv = self.feasibility
        if line is None or fv is None or fv.status != "infeasible" or fv.note != SKIPPED:
            return line
        return line + " (the analytic start, returned because no linear controller meets the specs)"

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

    @cached_property
    def specs_achieved(self) -> tuple[SpecRow, ...]:
        """Every bounded spec with its worst achieved value, slack and where it binds
        (:func:`robrst.design.achieved.spec_rows`)."""
        return spec_rows(self.problem, self.certificate)

    @cached_property
    def controller_factored(self) -> ControllerFactors:
        """R, S and T factored (:func:`robrst.design.achieved.controller_factors`)."""
        return controller_factors(self.controller)

    @cached_property
    def solver_summary(self) -> SolverSummary:
        """The solver's objective, binding constraints and notes."""
        return solver_summary(self.synthesis, self.specs_achieved)

    @cached_property
    def starts_summary(self) -> StartsSummary | None:
        """What the multi-start found (``None``: no multi-start)."""
        return None if self.starts is None else starts_summary(self.starts)

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
        """The ``solver`` object of the JSON contract (:func:`robrst.design.contract.solver_json`).

        Returns
        -------
        dict
        """
        from robrst.design.contract import solver_json

        return solver_json(self.synthesis)

    def as_dict(self) -> dict:
        """The public JSON contract of ``robrst design --json`` (fields are only added):
        :func:`robrst.design.contract.design_json`.

        Returns
        -------
        dict
            See the documentation's command-line reference (``robrst design``).
        """
        from robrst.design.contract import design_json

        return design_json(self)
