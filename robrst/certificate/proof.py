"""Independent certificate of a controller on a plant family, over the whole temperature interval.

Nothing from the optimiser is trusted: every figure is recomputed from the polynomials.

* **Per model** (:func:`check_model`): exact global peaks of ``|S|, |T|, |U|`` and the exact
  frequency-limited peak of ``|T|`` over the resonance band (:func:`robrst.core.peaks.peak_gain`),
  the closed-loop spectral abscissa, and whether double precision resolves that stability
  verdict at all (:func:`robrst.core.interval.distance_to_instability`).  With a sampling rate
  the same on the exact sampled loop (:mod:`robrst.core.sampled`; physical frequencies up to
  Nyquist, the band warped).  One :class:`~robrst.certificate.figures.ModelRecord` per model
  holds both loops' :class:`~robrst.certificate.figures.LoopFigures`.
* **Over the interval** (:func:`certify`): the family members and ``n_sweep`` evenly
  spaced temperatures, then

  - explicit families: between neighbouring members the closed-loop polynomial is a
    segment; :func:`robrst.core.interval.segment_crossing` proves that no closed-loop root
    crosses the imaginary axis anywhere on it (``stability: "segment_crossing"``, exact;
    ``"refined_sweep"`` when a segment cannot be tested: an unstable member);
  - every family: adaptive refinement (``"refined_sweep"``): an interval between two
    checked temperatures is halved while any figure (spectral abscissa, every bounded
    peak, continuous and sampled) changes across it by more than half its margin to the
    bound at either end (the continuous spectral abscissa only when no interval proof
    covers stability: the proofs below run first); an interval still unresolved at the
    resolution floor is a violation (``kind: "unresolved"``).  Where no interval proof
    holds, stability too comes from this refinement: a sweep with a stated resolution,
    not a proof for excursions narrower than it.

A controller is certified when no checked figure exceeds its bound (relative tolerance
``rtol``), every verdict is resolved in double precision, and the interval checks pass.
The record ``interval`` says what was proved and at what resolution.

Further per-model checks (e.g. time-domain specs) plug in through ``checks``: callables
``check(plant, ctrl, specs, rtol) -> (record, violations)`` run on every model checked
(family members, sweep and refinement points); its record's figures land in the model
record's ``extra``.  A check may put ``{name: (value, limit)}`` pairs in
``record["margins"]`` to have its figures refined like the others.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core.interval import parameter_crossing, segment_crossing
from robrst.certificate.figures import LOOPS, ModelRecord, figure_key, parse_key
from robrst.certificate.statement import (Bound, ControllerPoles, IntervalProof, IntervalRecord,
                                          PoleRegionStatement, SegmentProof)
from robrst.certificate.models import (BOUNDED, FIGURE_OF, JUMPS, LOWER_BOUNDED, RESOLVE_FACTOR,
                                       Violation, band_peak, check_all, check_all_many,
                                       check_model, margins)
from robrst.core import poly, region
from robrst.certificate._structure import structure_violations
from robrst.problem.records import Problem
from robrst.core.rst import RSTController, as_controller, closed_loop
from robrst.core.thermal import modal_form
from robrst.base.errors import SpecError
from robrst.base.threads import one_blas_thread

if TYPE_CHECKING:
    from robrst.core.family import PlantFamily
    from robrst.problem.records import Specs

__all__ = ["Violation", "Certificate", "certify", "certify_problem", "certify_families",
           "actuator_of", "check_model", "band_peak", "REFINE_RATIO", "RESOLVE_FACTOR"]

REFINE_RATIO = 0.5     # halve an interval when a figure moves by more than this x its margin
MIN_WIDTH = 1.0 / 4096  # resolution floor, as a fraction of the temperature range


@dataclass(frozen=True, eq=False)
class Certificate:
    """Per-model exact figures, every violation found, and what the interval checks proved.

    Parameters
    ----------
    certified : bool
        No checked figure exceeds its bound beyond ``rtol`` (or falls below a lower bound),
        every stability and pole-region verdict is resolved in double precision and the
        interval checks pass.
    models : tuple of ModelRecord
        One typed record per checked model (family members, sweep and refinement points),
        in temperature order: its continuous and sampled loops' figures
        (:class:`~robrst.certificate.figures.ModelRecord`).
    violations : tuple of Violation
        Every violation found.
    rtol : float
        Relative tolerance on the bounds.
    interval : IntervalRecord
        What was proved between the checked temperatures and at what resolution (fields
        in the documentation's *What a certificate proves*; ``pole_region`` with a
        damping or decay bound).
    bounds : tuple of Bound
        Every bound checked (lower bounds: ``damping``, ``decay_rad_s``).
    controller : ControllerPoles or None
        The controller's own poles and their least damping (with
        ``controller_damping_min``).
    """

    certified: bool
    models: tuple
    violations: tuple
    rtol: float
    interval: IntervalRecord
    bounds: tuple = ()
    controller: ControllerPoles | None = None

    def bound(self, figure: str) -> Bound | None:
        """The bound checked on ``figure`` (``None``: none).

        Parameters
        ----------
        figure : str
            A figure (``"Ms"``, ``"damping"``, ...).

        Returns
        -------
        Bound or None
        """
        return next((b for b in self.bounds if b.figure == figure), None)

    def worst(self, key: str, loop: str | None = None) -> float | None:
        """Largest figure ``key`` over the models (``None`` if no record has it).

        Parameters
        ----------
        key : str
            A figure (``"Ms"``, ``"spectral_abscissa"``, ``"overshoot_pct"``, a hook's
            figure); a published name (``"Ms_sampled"``) names its loop too.
        loop : str, optional
            ``"continuous"`` (default) or ``"sampled"``.

        Returns
        -------
        float or None
        """
        name, where = parse_key(key) if loop is None else (key, loop)
        vals = [v for m in self.models if (v := m.value(name, where)) is not None]
        return max(vals) if vals else None

    def worst_model(self, key: str, loop: str = "continuous") -> ModelRecord | None:
        """The model record where figure ``key`` of ``loop`` is largest.

        Parameters
        ----------
        key : str
            A figure (``"Ms"``, ...).
        loop : str
            ``"continuous"`` or ``"sampled"``.

        Returns
        -------
        ModelRecord or None
            ``None`` when no record has the figure.
        """
        recs = [m for m in self.models if m.value(key, loop) is not None]
        return max(recs, key=lambda m: m.value(key, loop)) if recs else None

    def ratios(self) -> dict[str, float]:
        """Worst ``value / bound`` over the checked models, for every bound checked.

        Keys are the record figures (``"Ms"``, ``"Mt_resonance_band"``, ``"Ms_sampled"``,
        ``"overshoot_pct"``, ...; a check hook's ``margins`` by their names), plus the
        quantity of any other violated bound.  A bound of 0 gives 0 when met, ``inf``
        when not.  Above 1 means violated (beyond ``rtol``).

        Returns
        -------
        dict
            ``{figure: worst ratio}``.
        """
        def ratio(v, b):
            return v / b if b > 0 else (0.0 if v <= 0 else np.inf)

        def lower(v, b):          # a lower bound: bound / value
            return b / v if v > 0 else np.inf

        out = {}
        for bd in self.bounds:
            r = lower if bd.lower else ratio
            for loop in LOOPS:
                vals = [v for m in self.models if (v := m.value(bd.figure, loop)) is not None]
                if vals:
                    out[figure_key(bd.figure, loop)] = max(r(float(v), bd.value) for v in vals)
        for m in self.models:
            for k, (v, lim) in m.margins.items():
                out[k] = max(out.get(k, -np.inf), ratio(v, lim))
        for v in self.violations:
            if v.kind in ("exceeds", "below") and v.bound and v.bound > 0 and np.isfinite(v.value):
                k = figure_key(FIGURE_OF.get(v.quantity, v.quantity), v.loop)
                if k not in out:
                    out[k] = max(out.get(k, -np.inf), v.ratio)
        return out


def _unresolved(ra, rb, specs, rtol, ignore=()):
    """The first figure that moves by more than REFINE_RATIO x its margin across [a, b]."""
    ma, mb = margins(ra, specs, rtol), margins(rb, specs, rtol)
    for k in sorted(ma.keys() & mb.keys() - set(ignore)):
        (va, lim), (vb, _) = ma[k], mb[k]
        room = min(lim - va, lim - vb)
        if room > 0 and abs(va - vb) > REFINE_RATIO * room:
            return k
    return None


def _segments(family, ctrl, recs):
    """Exact crossing test between neighbouring members of an explicit family.

    Returns the crossings found (violations) and whether every segment was tested
    (continuous stability is proved over the whole interval when, besides, none crosses).
    """
    viols, tested = [], True
    ms = family.models
    for a, b in zip(ms[:-1], ms[1:]):
        ra, rb = recs[a.temperature_C], recs[b.temperature_C]
        if not (ra.continuous.stable and rb.continuous.stable) or a.n != b.n or a.m != b.m:
            tested = False
            continue   # an unstable end is already a violation; degrees differ: no segment
        cr = segment_crossing(closed_loop(a, ctrl).Delta, closed_loop(b, ctrl).Delta)
        if cr.crossing:
            T = a.temperature_C + cr.lam * (b.temperature_C - a.temperature_C)
            viols.append(Violation(f"T{T:.6g}C", T, f"closed-loop root crosses the imaginary"
                                   f" axis ({cr.kind}) between {a.temperature_C:g} and"
                                   f" {b.temperature_C:g} °C (at {T:.6g} °C)", 0.0, 0.0,
                                   None if cr.kind == "infinity" else cr.freq_rad_s,
                                   kind="crossing"))
    return viols, tested


def _guardian(family, ctrl, specs, rtol, checks, recs, viols):
    """Parametric families: the guardian-map proof on each side of the reference (where
    the creep law has its kink); a candidate crossing is checked and refined around."""
    if not all(r.continuous.stable for r in recs.values()):
        return IntervalProof(False, parts=(), skipped="a checked model is unstable")
    lo, hi = family.range_C
    ref = family.thermal.reference_C
    c = family.thermal
    k = len(modal_form(family.reference_model).pairs)
    deg_T = max(2 * k, 2 if (c.creep_per_K or c.creep_at_ref) else 1)
    parts, out = [p for p in ((lo, min(ref, hi)), (max(ref, lo), hi)) if p[1] > p[0]], []
    for a, b in parts:
        pr = parameter_crossing(lambda T: closed_loop(family.at(T), ctrl).Delta, a, b, deg_T)
        out.append(SegmentProof(range_C=(a, b), proved=pr.proved, nodes=pr.nodes,
                                candidate_C=pr.candidate_T))
        if pr.candidate_T is not None:   # check the candidate and its neighbours
            for T in (pr.candidate_T, pr.candidate_T - 1e-6 * (b - a),
                      pr.candidate_T + 1e-6 * (b - a)):
                if a <= T <= b and T not in recs:
                    rec, v = check_all(family.at(T), ctrl, specs, rtol, checks, family)
                    recs[T] = replace(rec, family_member=False)
                    viols.extend(v)
    return IntervalProof(all(p.proved for p in out), parts=tuple(out))


def _refine(family, ctrl, specs, rtol, checks, recs, viols, budget, orders, ignore=()):
    """Halve unresolved intervals (see the module docstring); returns unresolved violations.

    Figures in ``ignore`` are not watched (the continuous spectral abscissa once an
    interval proof has established stability everywhere).

    An interval at the resolution floor across which the closed-loop degree changes (the
    family's order drops at one temperature, e.g. a creep pair that cancels exactly at the
    reference) is not a violation: its figures jump by construction.  It is appended to
    ``orders`` and reported in the certificate's ``interval`` record.

    The points are checked generation by generation (the midpoints of every interval to
    halve in one batch, :func:`robrst.certificate.models.check_all_many`), then the halving is
    replayed depth first: violations, unresolved intervals and ``orders`` come in the
    order of checking one point at a time.
    """
    lo, hi = family.range_C
    floor = MIN_WIDTH * (hi - lo)
    temps = sorted(recs)
    found, walked, level, left = {}, set(), list(zip(temps[:-1], temps[1:])), budget
    while level and left > 0:
        todo = []
        for a, b in level:
            if _decide(recs, a, b, specs, rtol, ignore, floor)[0] == "split":
                todo.append((a, b, *_split(a, b, recs, floor, walked)))
        todo, level = todo[:left], []
        done = check_all_many([family.at(m) for _, _, m, _ in todo], ctrl, specs, rtol,
                              checks, family)
        for (a, b, m, low), (rec, v) in zip(todo, done):
            recs[m], found[m] = replace(rec, family_member=False), v
            if low is not None and _degree(rec) == _degree(recs[low]):
                walked.add(m)   # the lower order persists beyond the probe: halve from here on
            level += [(a, m), (m, b)]
        left -= len(todo)
    stack, out, walked, seen = list(zip(temps[:-1], temps[1:])), [], set(), set()
    while stack:
        a, b = stack.pop()
        what, key = _decide(recs, a, b, specs, rtol, ignore, floor)
        if what == "order":
            orders.append([a, b])   # the model order changes (e.g. a cancelled creep pair)
            continue
        m, low = _split(a, b, recs, floor, walked) if what == "split" else (None, None)
        if what == "unresolved" or budget <= 0 or m not in found:
            if what != "resolved":
                out.append(Violation(f"T{a:g}C", a, f"{key} changes too fast between {a:g}"
                                     f" and {b:g} °C to be resolved by the sweep (resolution"
                                     f" {floor:.3g} °C)", 0.0, 0.0, None, kind="unresolved"))
            continue
        viols.extend(found[m])
        seen.add(m)
        budget -= 1
        if low is not None and _degree(recs[m]) == _degree(recs[low]):
            walked.add(m)
        stack += [(a, m), (m, b)]
    for m in sorted(found.keys() - seen):   # checked in a batch, not reached depth first
        viols.extend(found[m])
    return out


def _degree(rec):
    """The degree of a record's continuous closed-loop polynomial."""
    return rec.continuous.closed_loop_degree


def _decide(recs, a, b, specs, rtol, ignore, floor):
    """What to do with ``[a, b]``: ``("resolved", None)``, ``("order", key)`` (the model
    order changes at the floor), ``("unresolved", key)`` (at the floor) or ``("split",
    key)``."""
    key = _unresolved(recs[a], recs[b], specs, rtol, ignore)
    if key is None:
        return "resolved", None
    if b - a <= floor and _degree(recs[a]) != _degree(recs[b]):
        return "order", key
    if b - a <= floor:   # a settling time jumps (a ripple leaves the band): both sides hold
        key = _unresolved(recs[a], recs[b], specs, rtol, (*ignore, *JUMPS))
        return ("resolved", None) if key is None else ("unresolved", key)
    return "split", key


def _statement(explicit, tested, proved):
    """What the interval checks established, in words."""
    if explicit and tested:
        head = ("closed-loop stability proved for every temperature of the interval (exact"
                " zero-crossing test of the interpolated closed-loop polynomial); " if proved
                else "closed-loop stability decided by the exact zero-crossing test of the"
                " interpolated closed-loop polynomial: a root reaches the imaginary axis"
                " between members (see the violations); ")
    elif proved:
        head = ("continuous closed-loop stability proved for every temperature of the interval"
                " (no zero of the Hurwitz guardian a_n H_(n-1) along the thermal law); ")
    else:
        head = "closed-loop stability and "
    return head + ("peaks checked on a sweep refined until no figure changes by more than"
                   f" {REFINE_RATIO:g} x its margin between neighbouring points")


def _split(a, b, recs, floor, walked):
    """Where to check next on ``[a, b]`` and the lower-order end probed (or ``None``).

    The midpoint; or, when the closed-loop degree differs at the ends, a point
    ``floor / 2`` from the lower-order end: a degree drops at a single temperature (a
    creep pair cancelling at the reference), and one check there isolates it where
    halving would need ``log2(width / floor)`` checks.
    """
    da, db = (_degree(recs[t]) for t in (a, b))
    if da is None or db is None or da == db or b - a <= floor:
        return 0.5 * (a + b), None
    low = a if da < db else b
    if low in walked:
        return 0.5 * (a + b), None
    return (a + 0.5 * floor if low == a else b - 0.5 * floor), low


REGION_WIDE = 3.0      # no interval proof of the pole region when every pole is this far inside
_REGION_FIGURES = ("damping", "decay_rad_s")     # the continuous loop's, by published name


def resolved_specs(specs, family):
    """``specs`` with the damping floor resolved on ``family`` (the default floor when
    ``damping_min`` is not given, :meth:`robrst.problem.records.Specs.damping_floor`; 0:
    none) and its source."""
    floor, source = specs.damping_floor(family)
    return replace(specs, damping_min=floor or 0.0), source


def _region_polys(specs):
    """The region tests of a continuous closed-loop polynomial ``D``: ``(name, f,
    degree factor)`` with ``f(D)`` Hurwitz exactly when every root of ``D`` meets the
    bound (:mod:`robrst.core.region`)."""
    out = []
    if specs.decay_min:
        sigma = specs.decay_min

        def shifted(D):
            return region.shift_matrix(len(D) - 1, sigma) @ D
        out.append(("decay", shifted, 1))
    if specs.damping_min:
        zeta = specs.damping_min * (1 - 1e-12)
        out.append(("damping", lambda D: region.sector_polynomial(D, zeta), 2))
    return out


def _region_interval(family, ctrl, specs, rtol, checks, recs, viols):
    """The pole region of the continuous loop between checked temperatures: no root of the
    closed-loop polynomial crosses the region's boundary (guardian map of the shifted and
    of the rotated polynomials, :func:`robrst.core.interval.parameter_crossing`) on each
    side of a parametric family's reference, or along each segment between members of an
    explicit family (linear interpolation of the closed-loop polynomial).  A candidate
    crossing is checked (and refined around)."""
    tests = _region_polys(specs)
    if not tests or len(family.models) < 2:
        return None
    if not all(r.continuous.stable for r in recs.values()):
        return IntervalProof(False, parts=None, skipped="a checked model is unstable")
    wide = [(specs.damping_min, "damping"), (specs.decay_min, "decay_rad_s")]
    if all(not b or min(r.continuous.value(k) for r in recs.values()) >= REGION_WIDE * b
           for b, k in wide):
        # every checked pole far inside the region: the refinement, which halves an
        # interval whose figure moves by half its margin, decides (no proof needed there)
        return IntervalProof(False, parts=None, skipped=f"every checked pole beyond"
                             f" {REGION_WIDE:g} x its bound: refined sweep")
    explicit = family.thermal is None
    if explicit:
        ms = family.models
        parts = [(a.temperature_C, b.temperature_C,
                  (closed_loop(a, ctrl).Delta, closed_loop(b, ctrl).Delta)) for a, b in
                 zip(ms[:-1], ms[1:])]
        deg_T = 1
    else:
        lo, hi = family.range_C
        ref = family.thermal.reference_C
        c = family.thermal
        k = len(modal_form(family.reference_model).pairs)
        deg_T = max(2 * k, 2 if (c.creep_per_K or c.creep_at_ref) else 1)
        parts = [(a, b, None) for a, b in ((lo, min(ref, hi)), (max(ref, lo), hi)) if b > a]
    out = []
    for a, b, ends in parts:
        for name, f, factor in tests:
            if ends is None:
                def at(T, f=f):
                    return _positive(f(poly.trim(closed_loop(family.at(T), ctrl).Delta)))
                pr = parameter_crossing(at, a, b, factor * deg_T)
            else:
                Da, Db = (poly.trim(D) for D in ends)
                if len(Da) != len(Db):
                    out.append(SegmentProof(range_C=(a, b), proved=False, test=name))
                    continue

                def at(lam, f=f, Da=Da, Db=Db):
                    return _positive(f((1 - lam) * Da + lam * Db))
                pr = parameter_crossing(at, 0.0, 1.0, factor)
            cand = pr.candidate_T
            if cand is not None and ends is not None:
                cand = a + cand * (b - a)
            out.append(SegmentProof(range_C=(a, b), proved=pr.proved, test=name,
                                    nodes=pr.nodes, candidate_C=cand))
            if cand is not None:   # check the candidate and its neighbours
                for T in (cand, cand - 1e-6 * (b - a), cand + 1e-6 * (b - a)):
                    if a <= T <= b and T not in recs:
                        rec, v = check_all(family.at(T), ctrl, specs, rtol, checks, family)
                        recs[T] = replace(rec, family_member=False)
                        viols.extend(v)
    return IntervalProof(all(p.proved for p in out), parts=tuple(out))


def _positive(c):
    """``c`` with a positive leading coefficient."""
    return c if c[0] > 0 else -c


def _controller_poles(ctrl, specs, rtol):
    """The controller's own poles (roots of ``S`` other than its integrators): least
    damping, and the violation of ``controller_damping_min``."""
    S = poly.trim(ctrl.S)
    nz = np.flatnonzero(S)
    Q = S[:nz[-1] + 1] if nz.size else S
    roots = np.roots(Q) if len(Q) > 1 else np.zeros(0, complex)
    zeta = region.least_damping(roots)
    rec = ControllerPoles(damping=zeta, damping_min=specs.controller_damping_min,
                          poles_rad_s=tuple((float(r.real), float(r.imag)) for r in roots))
    viol = []
    b = specs.controller_damping_min
    if b and zeta < b * (1 - rtol):
        k = int(np.argmin(region.damping_of(roots)))
        viol.append(Violation("controller", float("nan"), "controller pole damping", zeta, b,
                              abs(float(roots[k].imag)) or None, kind="below"))
    return rec, viol


def _number(v):
    """``v`` as a float, NaN when it is none (text, a list)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def certify(family: PlantFamily, ctrl: RSTController, specs: Specs, n_sweep: int = 35,
            rtol: float = 1e-3, checks: Sequence[Callable] = (),
            max_refine: int | None = None) -> Certificate:
    """Certify ``ctrl`` on ``family`` over its whole temperature interval (module docstring).

    Parameters
    ----------
    family : PlantFamily
        The models the controller must hold on.
    ctrl : RSTController
        The controller.
    specs : Specs
        The bounds checked.
    n_sweep : int
        Evenly spaced temperatures checked besides the family members.
    rtol : float
        Relative tolerance on the peak bounds.
    checks : sequence of callables
        Extra per-model checks ``check(plant, ctrl, specs, rtol) -> (record, violations)``.
    max_refine : int, optional
        Cap on refinement points (default ``max(4 n_sweep, 64)``).

    Returns
    -------
    Certificate

    Raises
    ------
    SpecError
        The controller's coefficients overflow the closed-loop polynomial ``A S + B R``
        of a family model (no finite loop exists to certify), or a bound is not a finite
        number (NaN bounds nothing).
    """
    ctrl = as_controller(ctrl)      # a python-control system too
    with np.errstate(over="ignore", invalid="ignore"):
        finite = all(np.all(np.isfinite(closed_loop(m, ctrl).Delta)) for m in family.models)
    if not finite:
        big = max(float(np.max(np.abs(getattr(ctrl, k)))) for k in "RST")
        raise SpecError(f"the controller's coefficients (up to {big:.3g}) overflow the"
                        " closed-loop polynomial A S + B R: no finite loop to certify")
    for _, key in BOUNDED + LOWER_BOUNDED:      # a NaN bound bounds nothing: no proof of it
        v = getattr(specs, key)
        if v is not None and not isinstance(v, bool) and not np.isfinite(_number(v)):
            raise SpecError(f"[specs.{key}] = {v!r}: a bound must be a finite number")
    specs, damping_source = resolved_specs(specs, family)
    known = {m.temperature_C for m in family.models}
    models = list(family.models)
    if len(models) > 1 and n_sweep > 0:
        models += [m for m in family.sweep(n_sweep) if m.temperature_C not in known]
    recs, viols = {}, []
    for m, (rec, v) in zip(models, check_all_many(models, ctrl, specs, rtol, checks, family)):
        recs[m.temperature_C] = replace(rec, family_member=m.temperature_C in known)
        viols.extend(v)
    lo, hi = family.range_C
    interval = IntervalRecord(range_C=(lo, hi), stability="single_model", peaks="single_model")
    if len(family.models) > 1:
        explicit = family.thermal is None
        proof, tested = None, False
        if explicit:
            crossings, tested = _segments(family, ctrl, recs)
            viols += crossings
            proved = tested and not crossings
        else:
            proof = _guardian(family, ctrl, specs, rtol, checks, recs, viols)
            proved = proof.proved
        region_proof = _region_interval(family, ctrl, specs, rtol, checks, recs, viols)
        budget = max(4 * n_sweep, 64) if max_refine is None else max_refine
        orders = []
        # stability proved for every temperature: the refinement need not chase the
        # continuous spectral abscissa (it still watches every bounded figure and the
        # sampled loop, whose stability no proof covers); likewise the pole region
        ignore = ("spectral_abscissa",) if proved else ()
        if region_proof is not None and region_proof.proved:
            ignore += _REGION_FIGURES
        viols += _refine(family, ctrl, specs, rtol, checks, recs, viols, budget, orders,
                         ignore=ignore)
        temps = np.array(sorted(recs))
        interval = IntervalRecord(
            range_C=(lo, hi),
            stability=("segment_crossing" if explicit and tested else
                       "guardian_map" if proved else "refined_sweep"),
            peaks="refined_sweep", points=int(len(temps)),
            max_spacing_C=float(np.max(np.diff(temps))),
            min_spacing_C=float(np.min(np.diff(temps))), refine_ratio=REFINE_RATIO,
            sampled="refined_sweep" if specs.sampled else None,
            order_change_C=tuple(tuple(o) for o in sorted(orders)), guardian=proof,
            statement=_statement(explicit, tested, proved), pole_region_proof=region_proof)
    if specs.damping_min or specs.decay_min:
        interval = replace(interval, pole_region=_region_statement(specs, damping_source,
                                                                   interval))
    ctrl_rec = None
    if specs.controller_damping_min is not None:
        ctrl_rec, v = _controller_poles(ctrl, specs, rtol)
        viols += v
    recs_sorted = tuple(recs[T] for T in sorted(recs))
    bounds = tuple(Bound(key, getattr(specs, attr)) for key, attr in BOUNDED
                   if getattr(specs, attr) is not None)
    bounds += tuple(Bound(key, getattr(specs, attr), lower=True) for key, attr in LOWER_BOUNDED
                    if getattr(specs, attr))
    return Certificate(certified=not viols, models=recs_sorted, violations=tuple(viols),
                       rtol=rtol, interval=interval, bounds=bounds, controller=ctrl_rec)


def _region_statement(specs, source, interval):
    """What the certificate established about the closed-loop pole region."""
    proof = interval.pole_region_proof
    parts = []
    if specs.damping_min:
        parts.append(f"damping >= {specs.damping_min:.4g}"
                     + (" (the default floor)" if source == "default" else ""))
    if specs.decay_min:
        parts.append(f"decay rate -Re(p) >= {specs.decay_min:.4g} rad/s")
    what = " and ".join(parts)
    pts = ("at every checked temperature (family members, sweep and refinement points),"
           " from the roots of the closed-loop polynomial (a root within its rounding error"
           " of the boundary is 'unresolved')")
    if proof is None:
        between = "a single model" if interval.points is None else "no proof between points"
    elif proof.proved:
        between = ("proved between them for the continuous loop: no closed-loop root crosses"
                   " the region's boundary (guardian map of the shifted and the rotated"
                   " closed-loop polynomials along the thermal law or the interpolation)")
    else:
        between = ("between them a refined sweep (the guardian-map proof did not hold or"
                   " could not be validated)")
    samp = ("; the sampled loop's poles (mapped to s by fs ln z) on the refined sweep"
            if specs.sampled else "")
    return PoleRegionStatement(
        damping_min=specs.damping_min or None, damping_source=source,
        decay_min=specs.decay_min, proved_between_points=bool(proof and proof.proved),
        statement=f"every closed-loop pole: {what}, {pts}; {between}{samp}")


ACTUATOR = "actuator"   # the published record key (and label prefix) of a further actuator


def actuator_of(label: str) -> tuple[int, str]:
    """``(index, model label)`` of a violation's label.

    Parameters
    ----------
    label : str
        A violation's model label: ``"actuator3/T45C"`` is model ``T45C`` of further
        actuator 3 (:func:`certify_families`); a plain label is actuator 0's.

    Returns
    -------
    (int, str)
        The actuator's index and the model's own label.
    """
    head, sep, tail = str(label).partition("/")
    if sep and head.startswith(ACTUATOR) and head[len(ACTUATOR):].isdigit():
        return int(head[len(ACTUATOR):]), tail
    return 0, label


def certify_families(families: Sequence[PlantFamily], ctrl: RSTController, specs: Specs,
                     n_sweep: int = 35, rtol: float = 1e-3, checks: Sequence[Callable] = (),
                     max_refine: int | None = None) -> Certificate:
    """:func:`certify` on every family of ``families`` (several actuators), merged.

    The first family is the nominal actuator: with one family this is :func:`certify`
    itself.  The records of further actuator ``k`` carry ``actuator = k`` (published as
    ``"actuator": k``) and its
    violations the label ``"actuator<k>/<model>"`` (:func:`actuator_of`); the merged
    certificate holds when every actuator's does, and its ``interval`` is the nominal
    actuator's with ``"actuators"``, the number of families.

    Parameters
    ----------
    families : sequence of PlantFamily
        The nominal actuator's family first, then the further actuators'.
    ctrl : RSTController
        The controller.
    specs : Specs
        The specs checked.
    n_sweep, rtol, checks, max_refine
        As for :func:`certify` (each family).

    Returns
    -------
    Certificate
    """
    certs = [certify(f, ctrl, specs, n_sweep, rtol, checks, max_refine) for f in families]
    if len(certs) == 1:
        return certs[0]
    models, viols = list(certs[0].models), list(certs[0].violations)
    for k, c in enumerate(certs[1:], start=1):
        models += [replace(rec, actuator=k) for rec in c.models]
        viols += [replace(v, label=f"{ACTUATOR}{k}/{v.label}") for v in c.violations
                  if v.label != "controller"]   # the controller's own poles: listed once
    return replace(certs[0], certified=all(c.certified for c in certs), models=tuple(models),
                   violations=tuple(viols),
                   interval=replace(certs[0].interval, actuators=len(certs)))


def certify_problem(problem: Problem, ctrl: RSTController) -> Certificate:
    """Certify ``ctrl`` on ``problem``'s family and specs with its solver options.

    The one entry point every stage uses (design, synthesis rounds, comparison): exact
    peaks and closed-loop stability on every family model, on
    ``problem.solver.cert_temperatures`` interpolated temperatures and on the refinement
    points between them, the interval proofs, and the sampled loop when the specs name a
    sampling rate.

    Parameters
    ----------
    problem : Problem
        The problem (its family, specs and ``solver.cert_temperatures``, ``cert_tol``).
    ctrl : RSTController
        The controller.

    Returns
    -------
    Certificate
        ``certified`` is true when nothing is violated or unresolved (relative tolerance
        ``problem.solver.cert_tol``) and the controller has the problem's fixed factors
        (:func:`robrst.certificate._structure.structure_violations`: the integrator of
        ``S_fixed``, the roll-off, ``R_fixed``; a controller read back from a file need
        not); ``violations`` names every failed check and ``interval`` what was proved
        over the temperature interval.

    Examples
    --------
    >>> from robrst import certify_problem, load_problem, pole_placement
    >>> problem = load_problem("paper")
    >>> ctrl = pole_placement(problem.family.reference_model, problem.poles,
    ...                       problem.controller).controller
    >>> certify_problem(problem, ctrl).certified
    True
    """
    from robrst.problem.records import with_defaults

    problem = with_defaults(problem)
    so = problem.solver
    with one_blas_thread(problem.needs_scipy):
        cert = certify(problem.family, ctrl, problem.specs, n_sweep=so.cert_temperatures,
                       rtol=so.cert_tol)
    lacks = structure_violations(problem.controller, as_controller(ctrl))
    if not lacks:
        return cert
    return replace(cert, certified=False, violations=tuple(lacks) + cert.violations)
