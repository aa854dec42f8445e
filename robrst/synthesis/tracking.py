"""Tracking, the T in RST: a two-degree-of-freedom design for a stated reference model.

The feedback ``R/S`` is designed for robustness; the reference path is designed here,
after it, for the nominal model (its sampled loop when the specs name a sampling rate:
that is the loop that runs).  With the nominal closed-loop polynomial
``Delta = A S + B R`` factored into its *well-damped* part ``Delta_wd`` (real roots and
pairs with damping ``>= T_cancel_damping``) and the rest ``Delta_bad`` (lightly damped
modes, e.g. resonances a robust low-gain loop leaves in place — cancelling those would
not survive a shift of the resonance with temperature), and a reference model
``Am_ref`` (a pair ``(reference_wn, reference_zeta)`` and real poles at
``-2 reference_wn`` up to the degree properness needs),

    T' = c Delta_wd,   R' = R Am_ref,   S' = S Am_ref,

so that ``y/yr = B T' / (Delta Am_ref) = c B / (Delta_bad Am_ref)`` at the nominal
model: the reference model, the plant's zeros and the lightly damped modes only, unit
static gain (``c``).  ``Am_ref`` is a common factor of ``R'`` and ``S'`` (the feedback
``R'/S' = R/S`` is unchanged, so every frequency-domain figure and the certificate's
stability carry over); the control law ``S' u = T' yr - R' y`` contains the reference
filter, so every tool that takes an RST controller (closed loop, discretisation, twin)
tracks through it without knowing about it.  The voltage ``u/yr = c A / (Delta_bad
Am_ref)`` carries the plant's resonances as zeros: the reference never excites them.

:func:`design_tracking` chooses the reference model's bandwidth: the stated
``reference_wn`` if the time-domain specs hold on every family model, else the first
of ``0.7, 0.5, 0.35, 0.25`` times it that does; when none does, it cancels one more
nominal closed-loop pair (the best damped of those kept, never one damped below
``CANCEL_FLOOR``) and tries again (the time-domain certificate has the last word).
:func:`tracking_candidates` yields these reference paths in that order, for a caller
that checks them on more models (:func:`robrst.design.run_problem`: every model of the
certificate, whose step figures it keeps).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core.analysis import spectral_abscissa_many
from robrst.core.rst import RSTController, closed_loop
from robrst.certificate.completion import first_tracked, with_time_domain
from robrst.certificate.steps import check_many

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.core.plant import Plant
    from robrst.problem.records import Problem

__all__ = ["Tracking", "two_dof", "design_tracking", "tracking_candidates", "reference_model",
           "cancel_thresholds", "centred_factor", "meets_time_specs", "time_spec_ratio", "with_steps",
           "CANCEL_FLOOR",
           "CENTRE_POINTS"]

SLOWER = (1.0, 0.7, 0.5, 0.35, 0.25)
CENTRE_POINTS = 9    # grid points of each of the two passes of centred_factor
CANCEL_FLOOR = 0.2   # never cancel a closed-loop factor less damped than this (resonances)


@dataclass(frozen=True, eq=False)
class Tracking:
    """The 2-DOF reference path: ``Am_ref``, the cancelled ``Delta_wd``, gain ``c``.

    Parameters
    ----------
    reference_wn : float
        Reference model bandwidth [rad/s].
    reference_zeta : float
        Reference model damping.
    Am_ref : numpy.ndarray
        The reference model's denominator.
    Delta_wd : numpy.ndarray
        The nominal closed-loop factors T cancels.
    Delta_bad : numpy.ndarray
        The factors it keeps.
    gain : float
        ``c`` of ``T' = c Delta_wd``.
    """

    reference_wn: float
    reference_zeta: float
    Am_ref: np.ndarray
    Delta_wd: np.ndarray
    Delta_bad: np.ndarray
    gain: float

    def as_dict(self) -> dict:
        """The ``tracking`` object of the design JSON.

        Returns
        -------
        dict
            ``reference_wn_rad_s, reference_zeta, reference_den, cancelled, kept``.
        """
        return {"reference_wn_rad_s": self.reference_wn, "reference_zeta": self.reference_zeta,
                "reference_den": self.Am_ref.tolist(), "cancelled": self.Delta_wd.tolist(),
                "kept": self.Delta_bad.tolist()}


def _split(Delta, min_damping):
    """``(Delta_wd, Delta_bad)``: roots with damping ``>= min_damping`` and the rest."""
    sc = poly.Scaling.natural(Delta)
    r = sc.unfreq(np.roots(sc.apply(poly.trim(Delta))))
    r = r[np.argsort(r.imag)]
    damp = -r.real / np.maximum(np.abs(r), 1e-300)
    good = (damp >= min_damping) & (r.real < 0)
    wd, bad = r[good], r[~good]
    return poly.from_roots(wd) if wd.size else np.ones(1), \
        poly.from_roots(bad) if bad.size else np.ones(1)


def reference_model(wn: float, zeta: float, degree: int) -> np.ndarray:
    """``Am_ref``: the pair ``(wn, zeta)`` and ``degree - 2`` real poles at ``-2 wn``.

    Parameters
    ----------
    wn : float
        Bandwidth [rad/s].
    zeta : float
        Damping.
    degree : int
        Degree of ``Am_ref`` (at least 2).

    Returns
    -------
    numpy.ndarray
        Monic, highest power first.

    Examples
    --------
    >>> from robrst.synthesis.tracking import reference_model
    >>> reference_model(1.0, 1.0, 3).tolist()        # (s + 1)^2 (s + 2)
    [1.0, 4.0, 5.0, 2.0]
    """
    pair = [1.0, 2 * zeta * wn, wn * wn]
    den = np.asarray(pair, float)
    for _ in range(max(degree, 2) - 2):
        den = np.convolve(den, [1.0, 2.0 * wn])
    return den


def two_dof(plant: Plant, ctrl: RSTController, wn: float, zeta: float,
            min_damping: float = 0.5) -> tuple[RSTController, Tracking]:
    """The 2-DOF controller for the reference model ``(wn, zeta)`` on ``plant``.

    Parameters
    ----------
    plant : Plant
        The nominal model.
    ctrl : RSTController
        The feedback design (its T is ignored).
    wn, zeta : float
        Reference model bandwidth [rad/s] and damping.
    min_damping : float
        Nominal closed-loop factors at least this damped are cancelled by T.

    Returns
    -------
    (RSTController, Tracking)
    """
    Delta = poly.trim(poly.padd(poly.pmul(plant.A, ctrl.S), poly.pmul(plant.B, ctrl.R)))
    wd, bad = _split(Delta / Delta[0], min_damping)
    deg_s, deg_wd = len(poly.trim(ctrl.S)) - 1, len(wd) - 1
    # proper T (deg wd <= deg S + deg Am_ref) and no voltage jump (one more)
    degree = max(2, deg_wd - deg_s + 1)
    am = reference_model(wn, zeta, degree)
    # unit static gain of y/yr = B c Delta_wd / (Delta Am_ref) at s = 0, with Delta as it is:
    # the sampled loop's w-plane plant is not monic (normalising Delta left a static error
    # of 1/Delta[0], 0.2-0.9 % on identified stages)
    c = Delta[-1] * am[-1] / (plant.B[-1] * wd[-1])
    # exact zeros of S (integrators) stay exact zeros in the product
    out = RSTController(R=poly.pmul(ctrl.R, am), S=poly.pmul(ctrl.S, am), T=c * wd)
    return out, Tracking(reference_wn=float(wn), reference_zeta=float(zeta), Am_ref=am,
                         Delta_wd=wd, Delta_bad=bad, gain=float(c))


def _loops(problem):
    """The program's loops by kind: ``[(plants, fs), ...]``, every family model of every
    actuator (and its sampled loop's plant when the specs name a sampling rate)."""
    sp = problem.specs
    models = [m for f in problem.families for m in f.models]
    kinds = [(models, None)]
    if sp.sampled:
        kinds.append(([problem.family.sampled(m, sp.sample_rate_hz, sp.delay_samples)
                       for m in models], sp.sample_rate_hz))
    return kinds


def _step_checks(problem, ctrl, kinds):
    """Per kind of :func:`_loops`, :func:`robrst.certificate.steps.check_many`'s
    ``(record, failed)`` of each loop (the loops of one kind computed together), or
    ``None`` for a kind with an unstable loop."""
    for plants, fs in kinds:
        cls = [closed_loop(pl, ctrl) for pl in plants]
        if any(sa >= 0 for sa, _ in spectral_abscissa_many([cl.Delta for cl in cls])):
            yield None
        else:
            yield check_many(plants, ctrl, cls, problem.specs, problem.solver.cert_tol, fs)


def _worst_time_ratio(problem, ctrl, kinds):
    """The largest time-domain figure/bound over the loops ``kinds`` (:func:`_loops`),
    ``inf`` for an unstable loop (a figure not resolved between grid points counts by its
    proved upper bound, which the record holds)."""
    sp = problem.specs
    bounds = [(k, b) for k, b in (("overshoot_pct", sp.overshoot_max_pct),
                                  ("settling_time_s", sp.settling_time_max_s),
                                  ("step_u_peak_V", sp.step_u_max_V)) if b is not None]
    worst = 0.0
    for checked in _step_checks(problem, ctrl, kinds):
        if checked is None:
            return np.inf
        for rec, _ in checked:
            worst = max([worst, *(rec[k] / b if b > 0 else (np.inf if rec[k] > 0 else 0.0)
                                  for k, b in bounds)])
    return worst


def _meets(problem, ctrl):
    """Every family model's loop (and sampled loop), of every actuator, is stable and meets
    the time-domain specs."""
    return all(checked is not None and not any(failed for _, failed in checked)
               for checked in _step_checks(problem, ctrl, _loops(problem)))


def meets_time_specs(problem: Problem, ctrl: RSTController) -> bool:
    """The controller meets the time-domain specs on every family model (both loops), its
    reference path as the problem designs it (:func:`design_tracking` with a reference
    model, else the controller's own ``T``).

    Parameters
    ----------
    problem : Problem
    ctrl : RSTController
        The feedback (its ``T`` used unless ``T_mode = "reference_model"``).

    Returns
    -------
    bool
        True also when the problem has no time-domain spec.
    """
    if not problem.specs.time_domain:
        return True
    if problem.controller.T_mode == "reference_model":
        ctrl = design_tracking(problem, ctrl)[0]
    return _meets(problem, ctrl)


def with_steps(problem: Problem, ctrl: RSTController,
               cert: Certificate) -> tuple[RSTController, Tracking | None, Certificate]:
    """The feedback ``ctrl`` and its certificate ``cert`` completed as a design completes
    them: with ``T_mode = "reference_model"`` the first reference path whose loops on every
    model of ``cert`` meet the time-domain specs
    (:func:`robrst.certificate.completion.first_tracked`), else the time-domain figures of
    ``ctrl`` itself on every model of ``cert`` (the interval's sweep and refinement points
    too; a figure the step grid cannot resolve below its bound fails).

    Parameters
    ----------
    problem : Problem
    ctrl : RSTController
        The feedback.
    cert : Certificate
        Its frequency-domain certificate.

    Returns
    -------
    (RSTController, Tracking or None, Certificate)
        The controller (with its reference path), the path's record, the certificate.
    """
    if problem.controller.T_mode == "reference_model":
        return first_tracked(problem, ctrl, cert, tracking_candidates(problem, ctrl))
    if problem.specs.time_domain:
        return ctrl, None, with_time_domain(problem, cert, ctrl)
    return ctrl, None, cert


def time_spec_ratio(problem: Problem, ctrl: RSTController) -> float:
    """The largest time-domain figure over its bound on every family model (both loops),
    the reference path as :func:`meets_time_specs` takes it.

    Parameters
    ----------
    problem : Problem
    ctrl : RSTController
        The feedback.

    Returns
    -------
    float
        At most 1 when the specs are met (0 without a time-domain spec), ``inf`` for an
        unstable loop.
    """
    if not problem.specs.time_domain:
        return 0.0
    if problem.controller.T_mode == "reference_model":
        ctrl = design_tracking(problem, ctrl)[0]
    return _worst_time_ratio(problem, ctrl, _loops(problem))


def centred_factor(problem: Problem, ctrl: RSTController, min_damping: float) -> float:
    """The reference bandwidth factor (of ``controller.reference_wn``) with the most room
    on the time-domain specs over every actuator the program holds.

    A reference path designed for the fleet must hold on actuators the program never
    saw: the fastest factor that meets the specs on the program's actuators (the
    nominal rule) sits on a bound — a faster actuator overshoots, a slower one settles
    late.  This factor minimises the largest time-domain figure/bound over every family
    model of every actuator in ``problem.families`` (both loops): a grid of
    :data:`CENTRE_POINTS` factors geometric over ``[SLOWER[-1], 1]``, then the same number
    between the best point's neighbours.

    Parameters
    ----------
    problem : Problem
        The problem (its ``scenarios``: the actuators the program holds).
    ctrl : RSTController
        The feedback design.
    min_damping : float
        Nominal closed-loop factors at least this damped are cancelled by T.

    Returns
    -------
    float
        The factor in ``[SLOWER[-1], 1]``.
    """
    c = problem.controller
    ref = _loop_plant(problem)
    kinds = _loops(problem)
    seen = {}

    def cost(f):
        if f not in seen:
            out, _ = two_dof(ref, ctrl, c.reference_wn * f, c.reference_zeta, min_damping)
            seen[f] = _worst_time_ratio(problem, out, kinds)
        return seen[f]

    grid = np.geomspace(SLOWER[-1], 1.0, CENTRE_POINTS)
    for _ in range(2):
        costs = [cost(float(f)) for f in grid]
        i = int(np.argmin(costs))
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        grid = np.geomspace(lo, hi, CENTRE_POINTS)
    return min(seen, key=lambda f: (seen[f], -f))


def _loop_plant(problem):
    """The nominal model of the loop that runs (its sampled loop's plant when sampled)."""
    sp = problem.specs
    ref = problem.family.reference_model
    if sp.sampled:
        ref = problem.family.sampled(ref, sp.sample_rate_hz, sp.delay_samples)
    return ref


def design_tracking(problem: Problem, ctrl: RSTController) -> tuple[RSTController, Tracking]:
    """The problem's 2-DOF controller (``T_mode = "reference_model"``), see the module doc:
    the first of :func:`tracking_candidates` whose loops on every family model meet the
    time-domain specs, else the first.

    Parameters
    ----------
    problem : Problem
        The problem.
    ctrl : RSTController
        The feedback design.

    Returns
    -------
    (RSTController, Tracking)
    """
    first = None
    for out in tracking_candidates(problem, ctrl):
        first = first or out
        if not problem.specs.time_domain or _meets(problem, out[0]):
            return out
    return first


def tracking_candidates(problem: Problem,
                        ctrl: RSTController) -> Iterator[tuple[RSTController, Tracking]]:
    """The 2-DOF controllers of the feedback ``ctrl`` to try, in order (module doc): each
    cancellation threshold, each reference bandwidth from the stated one down.

    Parameters
    ----------
    problem : Problem
        The problem.
    ctrl : RSTController
        The feedback design.

    Yields
    ------
    (RSTController, Tracking)
    """
    c = problem.controller
    ref = _loop_plant(problem)   # the loop that runs: cancel its closed-loop factors
    fleet = problem.spread is not None and problem.specs.time_domain
    for damping in cancel_thresholds(ref, ctrl, c.T_cancel_damping):
        factors = SLOWER
        if fleet:
            best = centred_factor(problem, ctrl, damping)
            factors = (best, *(f for f in SLOWER if f < best))
        for f in factors:
            yield two_dof(ref, ctrl, c.reference_wn * f, c.reference_zeta, damping)


def cancel_thresholds(plant: Plant, ctrl: RSTController, preferred: float) -> tuple[float, ...]:
    """Damping thresholds to try: ``preferred``, then each kept pair's own damping down to
    :data:`CANCEL_FLOOR` (one more factor cancelled each time, best damped first).

    A nominal closed-loop pair just below ``preferred`` (e.g. damping 0.49 at 0.5) left in
    the reference path gives ~12 % overshoot; cancelling it is robust when its damping is
    well above a resonance's, and the time-domain certificate has the last word.

    Parameters
    ----------
    plant : Plant
        The nominal model (or its sampled loop's plant).
    ctrl : RSTController
        The feedback design.
    preferred : float
        ``controller.T_cancel_damping``.

    Returns
    -------
    tuple of float
    """
    Delta = poly.padd(poly.pmul(plant.A, ctrl.S), poly.pmul(plant.B, ctrl.R))
    sc = poly.Scaling.natural(Delta)
    r = sc.unfreq(np.roots(sc.apply(poly.trim(Delta))))
    damp = -r.real / np.maximum(np.abs(r), 1e-300)
    kept = np.unique(np.round(damp[(damp < preferred) & (damp >= CANCEL_FLOOR) & (r.real < 0)], 12))
    return (preferred, *sorted((float(d) * (1 - 1e-9) for d in kept), reverse=True))
