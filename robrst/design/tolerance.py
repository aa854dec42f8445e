"""How far the next actuator may differ: a certified design checked on moved plants.

A certificate proves the stated specs on the stated family; it says nothing about the next
actuator off the line, whose static gain and resonance differ from the identified one by
a few per cent (PZT stacks of one type: d33 within about +-10 %).  A design that meets
every bound with nothing to spare — what an optimum does — may fail them all on that
actuator.  :func:`spread_tolerance` states it: for each plant factor (the static gain, the
natural frequency of every complex pole pair: :data:`robrst.problem.spread.PLANT_PARAMS`)
the furthest factors below and above 1 at which the controller still meets every spec,
and what fails next.

How it is checked: the family moved by the factor
(:func:`robrst.problem.spread.transform_family`, as a ``[spread]`` moves it) and the
controller checked on its members, every loop, by the certificate's own checks of each
member (:func:`robrst.synthesis.scenario.check_actuators` without the whole-interval
refinement); the factors tried are the span's end, then a bisection in ``log`` of the
distance to 1 between :data:`SMALLEST` and the span.  It is a measurement at the factors
tried, not a proof between them nor between the family's temperatures; a yield over a
stated spread is a fleet design's job (``[spread]``, :mod:`robrst.design.fleet`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.problem.spread import transform_family
from robrst.synthesis.scenario import check_actuators

if TYPE_CHECKING:
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem

__all__ = ["FactorTolerance", "SpreadTolerance", "spread_tolerance", "FACTORS", "SPAN",
           "SMALLEST", "BISECTIONS", "FRAGILE"]

FACTORS = ("gain", "resonance")   # the plant factors checked
SPAN = 0.2            # each checked up to 1 +- this (a spread's usual truncation)
SMALLEST = 1e-3       # ... and down to 1 +- this (below: "less than 0.1 %")
BISECTIONS = 5        # bisections in log of the distance between them (a ratio of 1.18)
FRAGILE = 0.02        # a factor within 1 +- this that fails: the output says so


@dataclass(frozen=True)
class FactorTolerance:
    """One plant factor's tolerance (module docstring).

    Parameters
    ----------
    factor : str
        ``"gain"`` or ``"resonance"``.
    low, high : float
        The furthest factors below and above 1 found to meet every spec (1.0: none tried
        that does).
    below_at, above_at : float or None
        The nearest factors beyond them that fail (``None``: the span's end met every
        spec).
    below, above : str or None
        What fails there (the worst violation).
    """

    factor: str
    low: float
    high: float
    below_at: float | None = None
    above_at: float | None = None
    below: str | None = None
    above: str | None = None

    @property
    def margin(self) -> float:
        """The smaller relative distance to 1 that meets every spec."""
        return min(1.0 - self.low, self.high - 1.0)

    def as_dict(self) -> dict:
        """The JSON form (fields are only added).

        Returns
        -------
        dict
            ``factor, low, high, below_at, above_at, below, above``.
        """
        return {"factor": self.factor, "low": self.low, "high": self.high,
                "below_at": self.below_at, "above_at": self.above_at,
                "below": self.below, "above": self.above}

    def line(self) -> str:
        """One line of text: the range and what fails beyond it.

        Returns
        -------
        str
        """
        def side(x, at, why, sign):
            if at is None:
                return f"{sign}{SPAN:.0%} met (the span's end)"
            d = abs(x - 1.0)
            met = f"{sign}{d:.2%} met, " if d > 0 else ""
            return f"{met}fails at x{at:.4g} ({why})"
        return (f"{self.factor}: {side(self.low, self.below_at, self.below, '-')}; "
                f"{side(self.high, self.above_at, self.above, '+')}")


@dataclass(frozen=True)
class SpreadTolerance:
    """How far the static gain and the resonance may move (module docstring).

    Parameters
    ----------
    factors : tuple of FactorTolerance
        One per plant factor that applies (a plant without a complex pole pair has no
        resonance factor).
    checks : int
        Moved families checked.
    statement : str
        What the figures are and are not.
    warning : str or None
        A factor within ``1 +- FRAGILE`` fails a spec: the design is fragile to the next
        actuator.
    """

    factors: tuple
    checks: int
    statement: str
    warning: str | None = None

    def as_dict(self) -> dict:
        """The JSON form (fields are only added).

        Returns
        -------
        dict
            ``factors, checks, span, statement, warning``.
        """
        return {"factors": [f.as_dict() for f in self.factors], "checks": self.checks,
                "span": SPAN, "statement": self.statement, "warning": self.warning}


def spread_tolerance(problem: Problem, ctrl: RSTController) -> SpreadTolerance | None:
    """The static-gain and resonance factors the design ``ctrl`` tolerates on ``problem``.

    Parameters
    ----------
    problem : Problem
        The problem (its family, specs with their defaults resolved, solver options).
    ctrl : RSTController
        The design.

    Returns
    -------
    SpreadTolerance or None
        ``None`` when the design does not meet the specs on its own family's members (or
        they cannot be checked).

    Examples
    --------
    >>> from robrst import load_problem, run_problem
    >>> from robrst.problem.records import with_defaults
    >>> p = with_defaults(load_problem("paper"))
    >>> tol = spread_tolerance(p, run_problem(p, analyses=False).controller)
    >>> [f.factor for f in tol.factors]
    ['gain', 'resonance']
    """
    count = [0]

    def check(name, k):
        """Every spec met with the factor ``name`` at ``k`` (``None``: the family as
        stated), and the worst violation."""
        count[0] += 1
        try:
            fam = problem.family if name is None else \
                transform_family(problem.family, {name: float(k)})
            c = check_actuators(problem, ctrl, [fam], full=False)[0]
        except (SpecError, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
            # a family the factor makes invalid (a thermal law out of its domain) or a
            # loop that cannot be evaluated: no actuator there meets the specs
            return False, f"not checked: {exc}"
        return c.certified, c.violation

    if not check(None, 1.0)[0]:
        return None
    out = []
    for name in FACTORS:
        if name != "gain" and _unmoved(problem, name):
            continue
        low, below_at, below = _side(check, name, -1.0)
        high, above_at, above = _side(check, name, 1.0)
        out.append(FactorTolerance(name, low, high, below_at, above_at, below, above))
    fragile = [f for f in out if f.margin < FRAGILE]
    warning = None
    if fragile:
        warning = ("fragile to the next actuator: " + "; ".join(f.line() for f in fragile)
                   + ". Actuators of one type differ by several per cent: state their"
                   " spread ([spread]) to design for them")
    statement = (f"each factor alone, the family's members moved (static gain: the"
                 f" numerator; resonance: every complex pole pair's natural frequency) and"
                 f" checked by the certificate's checks of every member and loop, at 1 +-"
                 f" {SPAN:g}, then by bisection down to 1 +- {SMALLEST:g}: measured at"
                 f" the factors tried, not proved between them nor between temperatures")
    return SpreadTolerance(tuple(out), count[0], statement, warning)


def _unmoved(problem, name):
    """The family is the same with the factor moved (no complex pole pair to move)."""
    try:
        fam = transform_family(problem.family, {name: 1.0 + SPAN})
    except SpecError:        # moved out of its laws' domain: it moves
        return False
    return all(np.allclose(a.A, b.A) and np.allclose(a.B, b.B)
               for a, b in zip(fam.models, problem.family.models))


def _side(check, name, sign):
    """The furthest factor on one side that meets the specs, the nearest beyond it that
    fails and what fails there (module docstring: the span's end, then a bisection in
    ``log`` of the distance)."""
    ok, why = check(name, 1.0 + sign * SPAN)
    if ok:
        return 1.0 + sign * SPAN, None, None
    bad, bad_why = SPAN, why
    ok, why = check(name, 1.0 + sign * SMALLEST)
    if not ok:
        return 1.0, 1.0 + sign * SMALLEST, why
    good = SMALLEST
    for _ in range(BISECTIONS):
        mid = float(np.sqrt(good * bad))
        ok, why = check(name, 1.0 + sign * mid)
        if ok:
            good = mid
        else:
            bad, bad_why = mid, why
    return 1.0 + sign * good, 1.0 + sign * bad, bad_why
