"""Independent certificate of a controller on a plant family, over the whole temperature interval.

Nothing from the optimiser is trusted: every figure is recomputed from the polynomials.

* **Per model** (:func:`check_model`): exact global peaks of ``|S|, |T|, |U|`` and the exact
  frequency-limited peak of ``|T|`` over the resonance band (:func:`robrst.hinf.peak_gain`),
  the closed-loop spectral abscissa, and whether double precision resolves that stability
  verdict at all (:func:`robrst.interval.distance_to_instability`).  With a sampling rate
  the same on the exact sampled loop (:mod:`robrst.sampled`; figures suffixed ``_sampled``,
  physical frequencies up to Nyquist, the band warped).
* **Over the interval** (:func:`certify`): the family members and ``n_sweep`` evenly
  spaced temperatures, then

  - explicit families: between neighbouring members the closed-loop polynomial is a
    segment; :func:`robrst.interval.segment_crossing` proves that no closed-loop root
    crosses the imaginary axis anywhere on it (``stability: "segment_crossing"``, exact);
  - every family: adaptive refinement (``"refined_sweep"``): an interval between two
    checked temperatures is halved while any figure (spectral abscissa, every bounded
    peak, continuous and sampled) changes across it by more than half its margin to the
    bound at either end; an interval still unresolved at the resolution floor is a
    violation (``kind: "unresolved"``).  Parametric families get their stability from this
    refinement; it is a sweep with a stated resolution, not a proof for excursions
    narrower than it.

A controller is certified when no checked figure exceeds its bound (relative tolerance
``rtol``), every verdict is resolved in double precision, and the interval checks pass.
The record ``interval`` says what was proved and at what resolution.

Further per-model checks (e.g. time-domain specs) plug in through ``checks``: callables
``check(plant, ctrl, specs, rtol) -> (record, violations)`` run on every model checked
(family members, sweep and refinement points).  A check may put ``{name: (value,
limit)}`` pairs in ``record["margins"]`` to have its figures refined like the others.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from robrst import poly
from robrst.analysis import spectral_abscissa
from robrst.hinf import peak_gain
from robrst.interval import distance_to_instability, segment_crossing
from robrst.problem import PEAK_SPECS, Problem
from robrst.rst import RSTController, closed_loop
from robrst.sampled import sampled_plant, unwarp, warp

__all__ = ["Violation", "Certificate", "certify", "certify_problem", "check_model", "band_peak",
           "REFINE_RATIO", "RESOLVE_FACTOR"]

REFINE_RATIO = 0.5     # halve an interval when a figure moves by more than this x its margin
RESOLVE_FACTOR = 64.0  # stability resolved when the distance to instability > this x n eps
MIN_WIDTH = 1.0 / 4096  # resolution floor, as a fraction of the temperature range


@dataclass(frozen=True)
class Violation:
    """One failed check: model, temperature, quantity, value, bound, frequency.

    ``kind`` is ``"exceeds"`` (``value > bound``), ``"crossing"`` (a closed-loop root
    reaches the imaginary axis between two checked temperatures) or ``"unresolved"`` (the
    check could not be decided: ``quantity`` says why; nothing is certified then).
    """

    label: str
    temperature_C: float
    quantity: str
    value: float
    bound: float
    freq_rad_s: float
    loop: str = "continuous"     # or "sampled"
    kind: str = "exceeds"

    def describe(self):
        at = "" if self.freq_rad_s is None else f" at {self.freq_rad_s / (2 * np.pi):.4g} Hz"
        loop = " in the sampled loop" if self.loop == "sampled" else ""
        if self.kind != "exceeds":
            return f"model {self.label} ({self.temperature_C:g} °C){loop}: {self.quantity}{at}"
        return (f"model {self.label} ({self.temperature_C:g} °C): {self.quantity}{loop} ="
                f" {self.value:.4g} > {self.bound:.4g}{at}")


@dataclass(frozen=True, eq=False)
class Certificate:
    """Per-model exact figures, every violation found, and what the interval checks proved."""

    certified: bool
    models: tuple
    violations: tuple
    rtol: float
    interval: dict = field(default_factory=dict)

    def worst(self, key):
        """Largest ``key`` over the models (``None`` if no record has it)."""
        vals = [m[key] for m in self.models if key in m and m[key] is not None]
        return max(vals) if vals else None

    def as_dict(self):
        return {"certified": self.certified, "rtol": self.rtol, "models": list(self.models),
                "violations": [v.__dict__ for v in self.violations],
                "interval": self.interval,
                "interval_proof": self.interval.get("stability"),
                "interval_resolution_C": self.interval.get("max_spacing_C")}


def band_peak(N, D, w_lo, w_hi):
    """Exact peak of ``|N/D|`` over ``[w_lo, w_hi]`` rad/s: ``(value, frequency)``."""
    pk = peak_gain(N, D, band=(w_lo, w_hi))
    return pk.value, pk.freq_rad_s


def _stability(plant, ctrl, cl, fs):
    sa, roots = spectral_abscissa(cl.Delta)
    if fs is not None and len(cl.Delta) < plant.n + len(poly.trim(ctrl.S)):
        return np.inf, None       # a pole at z = -1 (lost degree)
    rho = distance_to_instability([(plant.A, ctrl.S), (plant.B, ctrl.R)], cl.Delta, roots)
    return sa, rho


def check_model(plant, ctrl, specs, rtol, fs=None):
    """Exact peaks and stability of one model; returns (record, violations).

    With ``fs`` the plant is a sampled-loop plant (:func:`robrst.sampled.sampled_plant`):
    reported frequencies are mapped back to physical ones, the resonance band is
    warped, and a closed-loop polynomial that lost degree (a pole at ``z = -1``)
    counts as unstable.
    """
    cl = closed_loop(plant, ctrl)
    sa, rho = _stability(plant, ctrl, cl, fs)
    loop = "continuous" if fs is None else "sampled"
    phys = (lambda w: w) if fs is None else (lambda w: float(unwarp(w, fs)))  # noqa: E731
    rec = {"label": plant.label, "temperature_C": plant.temperature_C,
           "spectral_abscissa": sa, "stable": bool(sa < 0), "distance_to_instability": rho,
           "closed_loop_degree": len(poly.trim(cl.Delta)) - 1}
    viol = []

    def add(quantity, value, bound, freq=None, kind="exceeds"):
        viol.append(Violation(plant.label, plant.temperature_C, quantity, value, bound, freq,
                              loop, kind))

    if sa >= 0:
        add("spectral_abscissa", sa, 0.0)
    elif rho is not None and not rho > RESOLVE_FACTOR * len(cl.Delta) * np.finfo(float).eps:
        add(f"stability not resolved in double precision: A S + B R is within {rho:.2g}"
            " (relative) of a polynomial with a root on the imaginary axis (cancellation in"
            " the closed-loop coefficients)", rho, RESOLVE_FACTOR, kind="unresolved")
    for name in PEAK_SPECS:
        pk = peak_gain(cl.nums[name], cl.Delta)
        # a sampled peak at nu = inf is at Nyquist (unwarp(inf) = pi fs)
        freq = phys(float(pk.freq_rad_s)) if fs is not None or np.isfinite(pk.freq_rad_s) else None
        rec[f"M{name.lower()}"] = pk.value
        rec[f"M{name.lower()}_freq_rad_s"] = freq
        bound = specs.peak_bound(name)
        if bound is not None and pk.value > bound * (1 + rtol):
            add(f"|{name}| peak", pk.value, bound, freq)
        elif bound is not None and not pk.verified:
            add(f"|{name}| peak not verified: the closed-loop poles span more than 12 decades",
                pk.value, bound, freq, kind="unresolved")
    if specs.T_resonance_max is not None:
        lo, hi = (2 * np.pi * f for f in specs.resonance_band_hz)
        if fs is not None:
            lo, hi = warp(min(lo, 0.999 * np.pi * fs), fs), warp(min(hi, 0.999 * np.pi * fs), fs)
        pk = peak_gain(cl.nums["T"], cl.Delta, band=(float(lo), float(hi)))
        rec["Mt_resonance_band"] = pk.value
        rec["Mt_resonance_band_freq_rad_s"] = phys(pk.freq_rad_s)
        if pk.value > specs.T_resonance_max * (1 + rtol):
            add("|T| in resonance band", pk.value, specs.T_resonance_max, phys(pk.freq_rad_s))
        elif not pk.verified:
            add("|T| band peak not verified: the closed-loop poles span more than 12 decades",
                pk.value, specs.T_resonance_max, kind="unresolved")
    return rec, viol


SAMPLED_KEYS = ("spectral_abscissa", "stable", "Ms", "Ms_freq_rad_s", "Mt", "Mt_freq_rad_s",
                "Mu", "Mu_freq_rad_s", "Mt_resonance_band", "distance_to_instability")
BOUNDED = (("Ms", "Ms_max"), ("Mt", "Mt_max"), ("Mu", "Mu_max"),
           ("Mt_resonance_band", "T_resonance_max"))


def _check_sampled(plant, ctrl, specs, rtol):
    fs, k = specs.sample_rate_hz, specs.delay_samples
    rec, viol = check_model(sampled_plant(plant, fs, k), ctrl, specs, rtol, fs=fs)
    viol = [replace(v, label=plant.label) for v in viol]   # name the continuous model
    return {f"{key}_sampled": rec[key] for key in SAMPLED_KEYS if key in rec}, viol


def _check_all(m, ctrl, specs, rtol, checks):
    """Every per-model check on model ``m``: continuous, sampled, then the hooks."""
    rec, v = check_model(m, ctrl, specs, rtol)
    if specs.sampled:
        rec_s, v_s = _check_sampled(m, ctrl, specs, rtol)
        rec.update(rec_s)
        v = v + v_s
    for check in checks:
        rec_x, v_x = check(m, ctrl, specs, rtol)
        margins = {**rec.get("margins", {}), **rec_x.pop("margins", {})}
        rec.update(rec_x)
        if margins:
            rec["margins"] = margins
        v = v + list(v_x)
    return rec, v


def _margins(rec, specs, rtol):
    """``{figure: (value, limit)}`` of a record: what the refinement watches."""
    out = {}
    for suffix in ("", "_sampled"):
        sa = rec.get("spectral_abscissa" + suffix)
        if sa is not None and np.isfinite(sa):
            out["spectral_abscissa" + suffix] = (sa, 0.0)
        for key, attr in BOUNDED:
            b, v = getattr(specs, attr), rec.get(key + suffix)
            if b is not None and v is not None and np.isfinite(v):
                out[key + suffix] = (v, b * (1 + rtol))
    out.update(rec.get("margins", {}))
    return out


def _unresolved(ra, rb, specs, rtol):
    """The first figure that moves by more than REFINE_RATIO x its margin across [a, b]."""
    ma, mb = _margins(ra, specs, rtol), _margins(rb, specs, rtol)
    for k in ma.keys() & mb.keys():
        (va, lim), (vb, _) = ma[k], mb[k]
        room = min(lim - va, lim - vb)
        if room > 0 and abs(va - vb) > REFINE_RATIO * room:
            return k
    return None


def _segments(family, ctrl, recs):
    """Exact crossing test between neighbouring members of an explicit family."""
    viols = []
    ms = family.models
    for a, b in zip(ms[:-1], ms[1:]):
        ra, rb = recs[a.temperature_C], recs[b.temperature_C]
        if not (ra["stable"] and rb["stable"]) or a.n != b.n or a.m != b.m:
            continue   # an unstable end is already a violation; degrees differ: no segment
        cr = segment_crossing(closed_loop(a, ctrl).Delta, closed_loop(b, ctrl).Delta)
        if cr.crossing:
            T = a.temperature_C + cr.lam * (b.temperature_C - a.temperature_C)
            viols.append(Violation(f"T{T:.6g}C", T, f"closed-loop root crosses the imaginary"
                                   f" axis ({cr.kind}) between {a.temperature_C:g} and"
                                   f" {b.temperature_C:g} °C (at {T:.6g} °C)", 0.0, 0.0,
                                   None if cr.kind == "infinity" else cr.freq_rad_s,
                                   kind="crossing"))
    return viols


def _refine(family, ctrl, specs, rtol, checks, recs, viols, budget, orders):
    """Halve unresolved intervals (see the module docstring); returns unresolved violations.

    An interval at the resolution floor across which the closed-loop degree changes (the
    family's order drops at one temperature, e.g. a creep pair that cancels exactly at the
    reference) is not a violation: its figures jump by construction.  It is appended to
    ``orders`` and reported in the certificate's ``interval`` record.
    """
    lo, hi = family.range_C
    floor = MIN_WIDTH * (hi - lo)
    temps = sorted(recs)
    stack = list(zip(temps[:-1], temps[1:]))
    out = []
    while stack:
        a, b = stack.pop()
        key = _unresolved(recs[a], recs[b], specs, rtol)
        if key is None:
            continue
        if b - a <= floor and recs[a].get("closed_loop_degree") != recs[b].get(
                "closed_loop_degree"):
            orders.append([a, b])   # the model order changes (e.g. a cancelled creep pair)
            continue
        if b - a <= floor or budget <= 0:
            out.append(Violation(f"T{a:g}C", a, f"{key} changes too fast between {a:g} and"
                                 f" {b:g} °C to be resolved by the sweep (resolution"
                                 f" {floor:.3g} °C)", 0.0, 0.0, None, kind="unresolved"))
            continue
        m = 0.5 * (a + b)
        recs[m], v = _check_all(family.at(m), ctrl, specs, rtol, checks)
        recs[m]["family_member"] = False
        viols.extend(v)
        budget -= 1
        stack += [(a, m), (m, b)]
    return out


def certify(family, ctrl, specs, n_sweep=35, rtol=1e-3, checks=(), max_refine=None):
    """Certify ``ctrl`` on ``family`` over its whole temperature interval (module docstring).

    Parameters
    ----------
    family : PlantFamily
    ctrl : RSTController
    specs : Specs
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
    """
    known = {m.temperature_C for m in family.models}
    models = list(family.models)
    if len(models) > 1 and n_sweep > 0:
        models += [m for m in family.sweep(n_sweep) if m.temperature_C not in known]
    recs, viols = {}, []
    for m in models:
        recs[m.temperature_C], v = _check_all(m, ctrl, specs, rtol, checks)
        recs[m.temperature_C]["family_member"] = m.temperature_C in known
        viols.extend(v)
    lo, hi = family.range_C
    interval = {"range_C": [lo, hi], "stability": "single_model", "peaks": "single_model"}
    if len(family.models) > 1:
        explicit = family.thermal is None
        if explicit:
            viols += _segments(family, ctrl, recs)
        budget = max(4 * n_sweep, 64) if max_refine is None else max_refine
        orders = []
        viols += _refine(family, ctrl, specs, rtol, checks, recs, viols, budget, orders)
        temps = np.array(sorted(recs))
        interval = {
            "range_C": [lo, hi],
            "stability": "segment_crossing" if explicit else "refined_sweep",
            "peaks": "refined_sweep",
            "points": int(len(temps)),
            "max_spacing_C": float(np.max(np.diff(temps))),
            "min_spacing_C": float(np.min(np.diff(temps))),
            "refine_ratio": REFINE_RATIO,
            "sampled": "refined_sweep" if specs.sampled else None,
            "order_change_C": sorted(orders),
            "statement": (
                ("closed-loop stability proved for every temperature of the interval (exact"
                 " zero-crossing test of the interpolated closed-loop polynomial); "
                 if explicit else
                 "closed-loop stability and ") +
                "peaks checked on a sweep refined until no figure changes by more than"
                f" {REFINE_RATIO:g} x its margin between neighbouring points"),
        }
    recs_sorted = tuple(recs[T] for T in sorted(recs))
    return Certificate(certified=not viols, models=recs_sorted, violations=tuple(viols),
                       rtol=rtol, interval=interval)


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
    ctrl : RSTController

    Returns
    -------
    Certificate
        ``certified`` is true when nothing is violated or unresolved (relative tolerance
        ``problem.solver.cert_tol``); ``violations`` names every failed check and
        ``interval`` what was proved over the temperature interval.

    Examples
    --------
    >>> from robrst import certify_problem, load_problem, pole_placement
    >>> problem = load_problem("paper")
    >>> ctrl = pole_placement(problem.family.reference_model, problem.poles,
    ...                       problem.controller).controller
    >>> certify_problem(problem, ctrl).certified
    True
    """
    so = problem.solver
    return certify(problem.family, ctrl, problem.specs, n_sweep=so.cert_temperatures,
                   rtol=so.cert_tol)
