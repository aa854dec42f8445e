"""Batches of robust syntheses that share their built programs.

The robust program is one parametric CasADi/IPOPT solver per *structure* (controller
degrees, how many models and constraint slots, which constraint families: see
:class:`~robrst.synthesis.template.Structure`); plants, grids, bounds and phases are
parameters.  A :class:`Synthesizer` keeps the built solvers, so every variant of a
problem with the same structure — another family, other bounds, another temperature
law — reuses them, and a previous result can warm-start the next variant.
"""

from __future__ import annotations

from collections.abc import Callable

from robrst.problem.records import Problem
from robrst.synthesis.analytic import pole_placement
from robrst.synthesis.outcome import SynthesisResult
from robrst.synthesis.robust import robust_synthesis
from robrst.base.threads import one_blas_thread

__all__ = ["Synthesizer"]


class Synthesizer:
    """Robust synthesis of many problems of one structure, each program built once.

    Parameters
    ----------
    progress : callable, optional
        Called with one line of text per solve (default: silent).

    Attributes
    ----------
    templates : dict
        The built solvers, by structure (shared by every :meth:`solve`; also accepted
        by :func:`robrst.design.run_problem` for the whole design pipeline).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from robrst import load_problem
    >>> from robrst.synthesis.synthesizer import Synthesizer
    >>> problem = load_problem("paper_robust_continuous")
    >>> syn = Synthesizer()
    >>> first = syn.solve(problem)
    >>> warmer = replace(problem, family=problem.family)          # e.g. another family
    >>> second = syn.solve(warmer, warm=first)
    >>> first.status, second.status, syn.built >= 1
    ('certified', 'certified', True)
    """

    def __init__(self, progress: Callable[[str], None] | None = None) -> None:
        self.templates = {}
        self.progress = progress

    @property
    def built(self) -> int:
        """How many solvers have been built so far."""
        return len(self.templates)

    def solve(self, problem: Problem, warm: SynthesisResult | None = None,
              progress: Callable[[str], None] | None = None) -> SynthesisResult:
        """Synthesise and certify ``problem`` (``solver.method`` is not consulted).

        Parameters
        ----------
        problem : Problem
        warm : SynthesisResult, optional
            A previous result of the same controller structure: the preferred start.
        progress : callable, optional
            Overrides the synthesizer's progress callback for this solve.

        Returns
        -------
        SynthesisResult
            ``status`` is ``"certified"`` or ``"not_certified"`` (with
            ``best_achievable``); never a bare solver status.
        """
        with one_blas_thread(problem.needs_scipy):
            start = pole_placement(problem.family.reference_model, problem.poles,
                                   problem.controller)
            return robust_synthesis(problem, start, progress or self.progress, self.templates,
                                    warm)
