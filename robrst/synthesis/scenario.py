"""The fleet design's scenario theory and records: drawn actuators, a stated yield.

A problem with a ``[spread]`` (:class:`robrst.problem.spread.Spread`) is designed for the
actuators a factory ships, not for the one identified.  Two methods:

**Scenario design** (``method = "scenario"``).  ``N`` actuators are drawn from the spread
(each with its own temperature family: plant factors and per-kelvin laws), and the
controller must certify on every one of them — the *scenario constraint* of actuator
``i`` is the certificate (:func:`robrst.certificate.proof.certify`, every spec of the
problem, continuous and sampled loop, time-domain specs included) on its family over the
whole temperature interval.  The program sees only the actuators that bind: a
**constraint exchange over actuators** (:func:`robrst.design.fleet.scenario_design`) designs for the nominal
actuator, checks all ``N`` (first their family members in one batched call,
:func:`robrst.certificate.models.check_all_many`, then the full certificate on each),
hands the ``ADD_PER_ROUND`` most violated to the program as further family models
(``Problem.scenarios``; inside, the existing grid-point and stability-row exchange and
the certificate's temperature refinement work on them as on the nominal family), and
designs again from the previous controller, until every drawn actuator certifies.  When
the program cannot meet the actuators just added together with the others, the most
violated of them is *discarded* and the previous controller stands.

*The guarantee.*  The program is non-convex, so the classical bound of Campi and Garatti
(2008) does not apply as such.  The bound used is the a-posteriori one of the general
scenario theory of Campi, Garatti and Ramponi (2018), Theorem 1: for a decision that
satisfies all ``N`` scenario constraints and is reproduced from a *compression set* of
``k`` of them, the probability that a fresh actuator violates the constraint exceeds
``epsilon(k)`` with probability at most ``beta`` over the draws, where ``epsilon(N) = 1``
and, for ``k < N``, ``epsilon(k) = 1 - t(k)`` with ``t(k)`` the root in (0, 1) of

    beta/N * sum_{i=k}^{N-1} C(i, k) t^(i-k) - C(N, k) t^(N-k) = 0

(:func:`nonconvex_epsilon`).  The compression set is the set of actuators the exchange
handed to the program, with those it discarded and any the final controller violates:
each round adds the worst violators over *all* ``N`` (ties by index), so run on that set
alone the same rounds add (and discard) the same actuators — the worst over all are the
worst over any subset that holds them — and end at the same controller; and a fresh
actuator the controller violates would change the set.  This needs the design of one
round to be a deterministic function of its inputs (it is: seeded draws, deterministic
IPOPT).  ``N`` is chosen a priori as the smallest with ``epsilon(d) <= 1 - yield`` for
``d`` decision variables (:func:`scenario_count`), so the target holds whenever the
compression set has at most ``d`` actuators; the guarantee reported is
``1 - epsilon(k)`` for the ``k`` actually found.
For reference, the a-priori count of the convex case, ``N`` with
``sum_{i<d} C(N, i) eps^i (1 - eps)^(N-i) <= beta`` (Campi and Garatti 2008, Theorem 1),
is reported beside it (:func:`convex_scenario_count`); it is *not* claimed here.

**Worst case over a box** (``method = "box"``).  The parameter box (uniform parameters:
their range; normal and lognormal: ``box_sigmas`` standard deviations, within their
truncation) is represented by its centre and its ``2^k`` corners, each an actuator with
its temperature family, and the same exchange designs until every one certifies.  This
is a deterministic statement about those actuators (every temperature of each, by the
certificate).  Along the box's *gain* edges the closed-loop polynomial is affine in the
parameter, and the interval certificate of :mod:`robrst.core.interval` proves stability
on them exactly (:func:`gain_edges`, at every family member, both loops); elsewhere
between corners it is no proof — a resonance or damping factor moves every coefficient
non-linearly.  The Monte Carlo verification on fresh draws states what it is worth.

References
----------
M. C. Campi and S. Garatti, "The exact feasibility of randomized solutions of uncertain
convex programs", SIAM J. Optim. 19(3):1211-1230, 2008.

M. C. Campi, S. Garatti and F. A. Ramponi, "A general scenario theory for nonconvex
optimization and decision making", IEEE Trans. Automat. Control 63(12):4067-4078, 2018.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.certificate.models import check_all_many
from robrst.certificate.proof import certify
from robrst.core.interval import segment_crossing
from robrst.core.rst import closed_loop
from robrst.base.threads import one_blas_thread

if TYPE_CHECKING:
    from robrst.core.family import PlantFamily
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem

__all__ = ["FleetDesign", "ActuatorCheck", "scenario_count", "gain_edges",
           "convex_scenario_count", "convex_confidence", "nonconvex_epsilon",
           "check_actuators", "ADD_PER_ROUND", "MAX_ROUNDS"]

ADD_PER_ROUND = 3     # the most violated actuators handed to the program per round
MAX_ROUNDS = 12       # exchange rounds over actuators (then the best controller, stated)


def _log_binom(n, k):
    return math.lgamma(n + 1) - math.lgamma(k + 1) - math.lgamma(n - k + 1)


def convex_confidence(N: int, d: int, epsilon: float) -> float:
    """``beta`` of the convex scenario program (Campi and Garatti 2008, Theorem 1).

    Parameters
    ----------
    N : int
        Scenarios.
    d : int
        Decision variables.
    epsilon : float
        Violation probability.

    Returns
    -------
    float
        ``sum_{i=0}^{d-1} C(N, i) epsilon^i (1 - epsilon)^(N-i)``: the probability over the
        draws that the solution violates more than ``epsilon``.
    """
    from scipy.stats import binom

    return float(binom.cdf(d - 1, N, epsilon))


def convex_scenario_count(epsilon: float, beta: float, d: int) -> int:
    """Smallest ``N`` with :func:`convex_confidence` ``(N, d, epsilon) <= beta``.

    Parameters
    ----------
    epsilon : float
        Violation probability (``1 -`` the yield).
    beta : float
        ``1 -`` the confidence.
    d : int
        Decision variables.

    Returns
    -------
    int
    """
    lo, hi = d, d
    while convex_confidence(hi, d, epsilon) > beta:
        lo, hi = hi, 2 * hi
    while lo < hi:                       # the tail decreases with N: bisection
        mid = (lo + hi) // 2
        if convex_confidence(mid, d, epsilon) <= beta:
            hi = mid
        else:
            lo = mid + 1
    return int(hi)


def nonconvex_epsilon(k: int, N: int, beta: float) -> float:
    """``epsilon(k)`` of Campi, Garatti and Ramponi (2018), Theorem 1 (module docstring).

    Parameters
    ----------
    k : int
        Size of the compression set (support scenarios), ``0 <= k <= N``.
    N : int
        Scenarios.
    beta : float
        Confidence parameter (the guarantee holds with probability ``>= 1 - beta``).

    Returns
    -------
    float
        ``epsilon(k) = 1 - t(k)``; 1 for ``k = N``.

    Raises
    ------
    ValueError
        ``k`` outside ``0..N``.
    """
    from scipy.optimize import brentq

    if not 0 <= k <= N:
        raise ValueError(f"expected 0 <= k <= N, got k = {k}, N = {N}")
    if k == N:
        return 1.0
    i = np.arange(k, N)
    lc = np.array([_log_binom(int(j), k) for j in i])
    lbeta, lnk = math.log(beta / N), _log_binom(N, k)

    def f(logt):                          # the defining equation, in logarithms
        left = lbeta + np.logaddexp.reduce(lc + (i - k) * logt)
        return left - (lnk + (N - k) * logt)

    # f is positive near t = 0 (left ~ beta/N, right ~ 0) and negative at t = 1
    logt = brentq(f, -745.0 / max(N - k, 1), 0.0, xtol=1e-15, rtol=1e-13)
    return float(-math.expm1(logt))


def scenario_count(epsilon: float, beta: float, d: int) -> int:
    """Smallest ``N`` with ``nonconvex_epsilon(d, N, beta) <= epsilon``.

    Parameters
    ----------
    epsilon : float
        Violation probability (``1 -`` the yield target).
    beta : float
        ``1 -`` the confidence.
    d : int
        Decision variables (the compression sizes the target must cover).

    Returns
    -------
    int
        Enough draws for the target when the compression set has at most ``d`` actuators.
    """
    lo, hi = d + 1, 2 * (d + 1)
    while nonconvex_epsilon(d, hi, beta) > epsilon:
        lo, hi = hi, 2 * hi
    while lo < hi:
        mid = (lo + hi) // 2
        if nonconvex_epsilon(d, mid, beta) <= epsilon:
            hi = mid
        else:
            lo = mid + 1
    return int(hi)


@dataclass(frozen=True)
class ActuatorCheck:
    """One drawn actuator checked.

    Parameters
    ----------
    index : int
        The actuator (row of the drawn values).
    ratio : float
        Its worst figure/bound (``inf``: unstable).
    certified : bool
        Every spec holds.
    violation : str, optional
        The worst violation.
    stage : str
        ``"members"`` (its family members) or ``"certificate"`` (its whole interval).
    """

    index: int
    ratio: float
    certified: bool
    violation: str = None
    stage: str = "certificate"


@dataclass(frozen=True, eq=False)
class FleetDesign:
    """What a fleet design did and what it guarantees (``robrst design --json``: ``fleet``).

    Parameters
    ----------
    method : str
        ``"scenario"`` or ``"box"``.
    names : tuple of str
        The spread's parameters.
    values : numpy.ndarray
        The drawn parameters, one row per actuator (columns ``names``).
    n_scenarios : int
        Actuators designed for.
    decision_variables : int
        The program's decision variables ``d``.
    yield_target, confidence : float
        The spread's target and confidence.
    support : tuple of int
        The actuators the exchange handed to the program.
    checks : tuple of ActuatorCheck
        Every actuator's final check.
    rounds : int
        Exchange rounds.
    nominal_integral_gain, integral_gain : float
        The first round's (nominal) and the final controller's integral gain.
    wall_time_s : float
        The fleet design's wall time.
    seed : int
        The draws' seed.
    n_convex : int, optional
        The convex a-priori count, for reference.
    discarded : tuple of int
        Actuators the program could not meet with the others.
    design_time_s, check_time_s : float
        Time in the rounds' designs and in the actuator checks.
    edges : dict, optional
        A box's gain edges (:func:`gain_edges`).

    Attributes
    ----------
    violated : tuple of int
        Drawn actuators the final controller does not certify on.
    compression : tuple of int
        The compression set (program, discarded, violated).
    epsilon : float or None
        ``epsilon(k)`` of the compression set (``None`` for a box).
    guaranteed_yield : float or None
        ``1 - epsilon(k)``.
    target_met : bool or None
        The guaranteed yield reaches the target (``None`` for a box).
    scenarios_for_target : int or None
        When the target is not met: the draws at which a compression set of the same size
        would meet it (``None`` otherwise).
    bound_statement : str or None
        The scenario bound the guarantee comes from.
    integral_gain_ratio : float or None
        The integral gain over the nominal design's.
    """

    method: str
    names: tuple
    values: np.ndarray
    n_scenarios: int
    decision_variables: int
    yield_target: float
    confidence: float
    support: tuple
    checks: tuple
    rounds: int
    nominal_integral_gain: float
    integral_gain: float
    wall_time_s: float
    seed: int = 0
    n_convex: int = None
    discarded: tuple = ()
    design_time_s: float = 0.0
    check_time_s: float = 0.0
    edges: dict = None

    @property
    def violated(self):
        """Drawn actuators the final controller does not certify on."""
        return tuple(c.index for c in self.checks if not c.certified)

    @property
    def compression(self):
        """The compression set: the actuators handed to the program, those discarded and
        any the final controller violates."""
        return tuple(sorted(set(self.support) | set(self.discarded) | set(self.violated)))

    @property
    def epsilon(self):
        """``epsilon(k)`` of the compression set's size ``k`` (``None`` for a box)."""
        if self.method != "scenario":
            return None
        return nonconvex_epsilon(len(self.compression), self.n_scenarios,
                                 1.0 - self.confidence)

    @property
    def guaranteed_yield(self):
        """``1 - epsilon(k)``: the yield guaranteed with probability ``confidence``."""
        e = self.epsilon
        return None if e is None else 1.0 - e

    @property
    def target_met(self):
        """The guaranteed yield reaches the target (``None`` for a box)."""
        g = self.guaranteed_yield
        return None if g is None else bool(g >= self.yield_target - 1e-12)

    @property
    def scenarios_for_target(self):
        """When the guarantee misses the target: the smallest ``N`` at which a compression
        set of the same size ``k`` meets it (:func:`scenario_count` at ``k``), else
        ``None``.  What a design with that many draws guarantees depends on its own ``k``
        (more actuators can need more of them in the program)."""
        if self.target_met is not False:
            return None
        return scenario_count(1.0 - self.yield_target, 1.0 - self.confidence,
                              len(self.compression))

    @property
    def bound_statement(self):
        """The scenario bound the guarantee comes from, in words (``None`` for a box)."""
        if self.method != "scenario":
            return None
        return ("Campi, Garatti & Ramponi (2018), Theorem 1: a-posteriori, compression size"
                f" k = {len(self.compression)}, N = {self.n_scenarios},"
                f" beta = {1.0 - self.confidence:g}")

    @property
    def integral_gain_ratio(self):
        """The fleet controller's integral gain over the nominal design's."""
        return abs(self.integral_gain) / abs(self.nominal_integral_gain) \
            if self.nominal_integral_gain else None

    def worst(self, count: int = 10) -> list[ActuatorCheck]:
        """The worst actuators.

        Parameters
        ----------
        count : int
            How many.

        Returns
        -------
        list of ActuatorCheck
            Largest figure/bound first.
        """
        return sorted(self.checks, key=lambda c: (-c.ratio, c.index))[:count]

    def as_dict(self) -> dict:
        """The ``fleet`` object of the JSON contract (fields are only added).

        Returns
        -------
        dict
        """
        return {
            "method": self.method, "scenarios": self.n_scenarios, "seed": self.seed,
            "parameters": list(self.names),
            "decision_variables": self.decision_variables,
            "yield_target": self.yield_target, "confidence": self.confidence,
            "support": list(self.support), "discarded": list(self.discarded),
            "violated": list(self.violated), "compression_size": len(self.compression),
            "rounds": self.rounds,
            "epsilon": self.epsilon, "guaranteed_yield": self.guaranteed_yield,
            "target_met": self.target_met, "bound": self.bound_statement,
            "scenarios_for_target": self.scenarios_for_target,
            "n_convex_a_priori": self.n_convex,
            "nominal_integral_gain": self.nominal_integral_gain,
            "integral_gain": self.integral_gain,
            "integral_gain_ratio": self.integral_gain_ratio,
            "wall_time_s": self.wall_time_s, "design_time_s": self.design_time_s,
            "check_time_s": self.check_time_s, "edges": self.edges,
            "worst": [{"index": c.index, "ratio": c.ratio, "violation": c.violation,
                       "parameters": dict(zip(self.names, map(float, self.values[c.index])))}
                      for c in self.worst() if c.ratio > 0],
        }


def _ratio(violations):
    """Worst ratio of violations (:attr:`~robrst.certificate.models.Violation.ratio`:
    ``value / bound``, ``bound / value`` for a lower bound; ``inf``: a crossing or an
    unstable loop)."""
    worst, text = 0.0, None
    for v in violations:
        # an unresolved figure by its proved bound (value); a crossing or an instability
        # (bound 0, or no finite value) is infinitely bad
        finite = v.value is not None and np.isfinite(v.value)
        if v.kind == "unresolved":
            r = v.value / v.bound if finite and v.bound and v.bound > 0 else np.inf
        else:
            r = v.ratio if finite else np.inf
        if text is None or r > worst:
            worst, text = r, v.describe()
    return worst, text


def check_actuators(problem: Problem, ctrl: RSTController, families: Sequence[PlantFamily],
                    full: bool = True) -> list[ActuatorCheck]:
    """Check ``ctrl`` on every actuator of ``families`` against every spec of ``problem``.

    First the family members of every actuator, all loops in one batched call
    (:func:`robrst.certificate.models.check_all_many`); when ``full``, the certificate
    over each actuator's whole temperature interval
    (:func:`robrst.certificate.proof.certify`, ``spread.cert_temperatures``) on those the
    members do not already fail.

    Parameters
    ----------
    problem : Problem
        Its specs, solver options and spread.
    ctrl : RSTController
        The controller.
    families : sequence of PlantFamily
        The actuators.
    full : bool
        Also the whole-interval certificate.

    Returns
    -------
    list of ActuatorCheck
    """
    sp, so = problem.specs, problem.solver
    n_T = problem.spread.cert_temperatures if problem.spread and \
        problem.spread.cert_temperatures else so.cert_temperatures
    models = [m for f in families for m in f.models]
    with one_blas_thread(problem.needs_scipy):
        found = check_all_many(models, ctrl, sp, so.cert_tol, ())
        out, at = [], 0
        for i, f in enumerate(families):
            viols = [v for _, vs in found[at:at + len(f.models)] for v in vs]
            at += len(f.models)
            if viols or not full:
                r, text = _ratio(viols)
                out.append(ActuatorCheck(i, r, not viols, text, "members"))
                continue
            cert = certify(f, ctrl, sp, n_sweep=n_T, rtol=so.cert_tol)
            ratios = cert.ratios()
            r = max(ratios.values(), default=0.0)
            stable = all(rec.stable for rec in cert.models)   # every loop checked
            text = _ratio(cert.violations)[1]
            out.append(ActuatorCheck(i, r if stable else np.inf, cert.certified, text))
    return out


def gain_edges(problem: Problem, ctrl: RSTController, names: Sequence[str],
               values: np.ndarray, families: Sequence[PlantFamily]) -> dict | None:
    """Closed-loop stability along the box's gain edges, proved exactly.

    The static-gain factor multiplies the plant's numerator, so along an edge of the box
    on which only ``gain`` varies the closed-loop polynomial ``A S + g B R`` of each
    temperature (and, the zero-order hold being linear in the plant, of its sampled loop)
    is the segment between the edge's end polynomials:
    :func:`robrst.core.interval.segment_crossing` proves that no root crosses the
    imaginary axis on it.  Checked at every family member of the edge's actuators.

    Parameters
    ----------
    problem : Problem
        Its specs (the sampled loop).
    ctrl : RSTController
        The controller.
    names : sequence of str
        The box's parameters.
    values : numpy.ndarray
        The box's points (centre and corners), one row each.
    families : sequence of PlantFamily
        Their actuators.

    Returns
    -------
    dict or None
        ``None`` without a ``gain`` parameter, else
        ``edges`` tested, ``segments`` (edges x temperatures x loops), ``crossings`` (a
        list of ``(edge ends, temperature, loop)``) and ``proved`` (no crossing).
    """
    if "gain" not in names:
        return None
    g = names.index("gain")
    values = np.asarray(values, float)
    others = np.delete(values, g, axis=1)
    sp = problem.specs
    edges, crossings, segments = 0, [], 0
    for i in range(len(values)):
        for j in range(i + 1, len(values)):
            if values[i, g] == values[j, g] or not np.array_equal(others[i], others[j]):
                continue
            edges += 1
            for a, b in zip(families[i].models, families[j].models):
                loops = [(a, b, "continuous")]
                if sp.sampled:
                    loops.append(tuple(problem.family.sampled(m, sp.sample_rate_hz,
                                                              sp.delay_samples)
                                       for m in (a, b)) + ("sampled",))
                for pa, pb, loop in loops:
                    segments += 1
                    cr = segment_crossing(closed_loop(pa, ctrl).Delta,
                                          closed_loop(pb, ctrl).Delta)
                    if cr.crossing:
                        crossings.append(([i, j], a.temperature_C, loop))
    return {"edges": edges, "segments": segments, "crossings": crossings,
            "proved": edges > 0 and not crossings}
