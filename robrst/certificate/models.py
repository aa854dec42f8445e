"""Per-model checks of the certificate: exact peaks, stability, sampled loop, hooks.

:func:`check_model` recomputes every figure of one closed loop from the polynomials:
exact global peaks of ``|S|, |T|, |U|`` (:func:`robrst.core.peaks.peak_gain`), the exact
frequency-limited peaks (``|T|`` over the resonance band, ``|U|`` above a corner), the
spectral abscissa and whether double precision resolves that verdict
(:func:`robrst.core.interval.distance_to_instability`), and the reference-step figures
(:mod:`robrst.certificate.steps`), as one :class:`~robrst.certificate.figures.LoopFigures`.
:func:`check_all` adds the exact sampled loop and the caller's extra checks into one
:class:`~robrst.certificate.figures.ModelRecord`; :func:`margins` lists the ``{figure:
(value, limit)}`` pairs (by published name) that :mod:`robrst.certificate.proof` refines
over the temperature interval.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.certificate import steps as timespec
from robrst.certificate.figures import LOOPS, LoopFigures, ModelRecord, StepFigures, figure_key
from robrst.core.analysis import spectral_abscissa_many
from robrst.core.peaks import peak_gain, peak_gains_many
from robrst.core.interval import distance_to_instability_many
from robrst.core import region
from robrst.problem.specs import (EXTRA_PEAK_SPECS, PEAK_SPECS, RELATIVE_PEAK_SPECS,
                                  bound_specs, spec)
from robrst.core.rst import closed_loop
from robrst.core.sampled import sampled_plant, unwarp, warp_band

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.family import PlantFamily
    from robrst.core.plant import Plant
    from robrst.core.rst import RSTController
    from robrst.problem.records import Specs

__all__ = ["Violation", "check_model", "check_all", "check_all_many", "margins", "band_peak",
           "BOUNDED", "LOWER_BOUNDED", "FIGURE_OF", "JUMPS", "RESOLVE_FACTOR"]

RESOLVE_FACTOR = 64.0  # stability resolved when the distance to instability > this x n eps
# a pole-region verdict needs the zero-exclusion test only near the boundary: a root this far
# inside (damping, relative decay) moves across it only for a relative root error of ~0.05,
# far beyond what rounding does even to a 10-fold root cluster (eps**(1/10) ~ 0.03)
RESOLVED_DAMPING = 0.05
RESOLVED_DECAY = 0.05

@dataclass(frozen=True)
class Violation:
    """One failed check: model, temperature, quantity, value, bound, frequency.

    Parameters
    ----------
    label : str
        The model's label.
    temperature_C : float
        Its temperature [°C] (``nan`` for the controller's own poles).
    quantity : str
        What failed (``"|S| peak"``, ``"overshoot_pct"``, ``"spectral_abscissa"``,
        ``"closed-loop damping"``, ...; for ``unresolved``, why it could not be decided).
    value : float
        The figure found.
    bound : float
        Its bound.
    freq_rad_s : float or None
        Where (physical frequency [rad/s]), when a frequency applies.
    loop : {"continuous", "sampled"}
        Which loop.
    kind : {"exceeds", "below", "crossing", "unresolved", "structure"}
        ``value > bound``; ``value < bound`` (a lower bound: the pole region's damping and
        decay); a closed-loop root reaches the imaginary axis, or a pole-region boundary,
        between two checked temperatures; the check could not be decided (nothing is
        certified then); or the controller lacks a fixed factor of the problem (label
        ``"controller"``, :mod:`robrst.certificate._structure`).
    """

    label: str
    temperature_C: float
    quantity: str
    value: float
    bound: float
    freq_rad_s: float
    loop: str = "continuous"     # or "sampled"
    kind: str = "exceeds"

    @property
    def ratio(self) -> float:
        """How far beyond its bound: ``value / bound`` (``bound / value`` for a lower bound,
        ``> 1`` when violated); ``inf`` for a crossing, an unresolved check or a bound 0.

        Returns
        -------
        float
        """
        if self.kind == "exceeds" and self.bound:
            return self.value / self.bound
        if self.kind == "below" and self.bound:
            return self.bound / self.value if self.value > 0 else np.inf
        return np.inf

    def describe(self) -> str:
        """One line: ``"model T45C (45 °C): |S| peak = 2.31 > 2 at 612 Hz"`` (``<`` for a
        lower bound).

        Returns
        -------
        str
        """
        at = "" if self.freq_rad_s is None else f" at {self.freq_rad_s / (2 * np.pi):.4g} Hz"
        loop = " in the sampled loop" if self.loop == "sampled" else ""
        if self.kind == "structure":
            return self.quantity
        if self.kind not in ("exceeds", "below"):
            return f"model {self.label} ({self.temperature_C:g} °C){loop}: {self.quantity}{at}"
        rel = ">" if self.kind == "exceeds" else "<"
        d = 4            # enough digits to tell the value from its bound
        while d < 17 and f"{self.value:.{d}g}" == f"{self.bound:.{d}g}":
            d += 1
        return (f"model {self.label} ({self.temperature_C:g} °C): {self.quantity}{loop} ="
                f" {self.value:.{d}g} {rel} {self.bound:.{d}g}{at}")



def band_peak(N: ArrayLike, D: ArrayLike, w_lo: float, w_hi: float) -> tuple[float, float]:
    """Exact peak of ``|N/D|`` over ``[w_lo, w_hi]`` rad/s: ``(value, frequency)``.

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s, highest power first.
    w_lo, w_hi : float
        The band [rad/s] (``w_hi`` may be ``inf``).

    Returns
    -------
    value : float
        The peak gain.
    frequency : float
        Where it is attained [rad/s].
    """
    pk = peak_gain(N, D, band=(w_lo, w_hi))
    return pk.value, pk.freq_rad_s


def _stability(loops):
    """Spectral abscissa, distance to instability and closed-loop roots of each loop
    (``(inf, None, None)`` for a sampled loop that lost degree: a pole at ``z = -1``),
    batched."""
    found = spectral_abscissa_many([lp.cl.Delta for lp in loops])
    jobs = {}
    for k, (lp, (sa, roots)) in enumerate(zip(loops, found)):
        if lp.fs is not None and len(lp.cl.Delta) < lp.plant.n + len(poly.trim(lp.ctrl.S)):
            found[k] = (np.inf, None)
        else:
            jobs[k] = ([(lp.plant.A, lp.ctrl.S), (lp.plant.B, lp.ctrl.R)], lp.cl.Delta, roots)
    rhos = dict(zip(jobs, distance_to_instability_many(list(jobs.values()))))
    return [(sa, rhos.get(k), roots) for k, (sa, roots) in enumerate(found)]


def check_model(plant: Plant, ctrl: RSTController, specs: Specs, rtol: float,
                fs: float | None = None) -> tuple[LoopFigures, list[Violation]]:
    """Exact peaks and stability of one closed loop.

    With ``fs`` the plant is a sampled-loop plant (:func:`robrst.core.sampled.sampled_plant`):
    reported frequencies are mapped back to physical ones, the resonance band is
    warped, and a closed-loop polynomial that lost degree (a pole at ``z = -1``)
    counts as unstable.

    Parameters
    ----------
    plant : Plant
        The model (or its sampled-loop plant).
    ctrl : RSTController
        The controller.
    specs : Specs
        The bounds checked.
    rtol : float
        Relative tolerance on the bounds.
    fs : float, optional
        The sampling rate when ``plant`` is a sampled-loop plant [Hz].

    Returns
    -------
    figures : LoopFigures
        The loop's figures (peaks and frequencies, stability, band peaks, step figures,
        the pole region's damping and decay when checked).
    violations : list of Violation
    """
    return _check_loops([(plant, fs)], ctrl, specs, rtol)[0]


def _check_loops(loops, ctrl, specs, rtol):
    """:func:`check_model` of each ``(plant, fs)``, the peak computations of all batched
    (:func:`robrst.core.peaks.peak_gains_many`: the same figures as one loop at a time)."""
    loops = [_Loop(plant, ctrl, specs, fs) for plant, fs in loops]
    for lp, (sa, rho, roots) in zip(loops, _stability(loops)):
        lp.sa, lp.rho, lp.roots = sa, rho, roots
    # the loops' peaks, and the open-loop peaks |B/A| a relative bound needs, in one batch
    opens = [k for k, lp in enumerate(loops) if lp.relative]
    pks = peak_gains_many([(lp.nums, lp.cl.Delta, lp.bands) for lp in loops]
                          + [loops[k].open_loop_job() for k in opens])
    for k, pk in zip(opens, pks[len(loops):]):
        loops[k].open_pk = pk[0]
    steps = _steps(loops, ctrl, specs, rtol)
    return [lp.finish(pk, specs, rtol, st) for lp, pk, st in zip(loops, pks, steps)]


def _steps(loops, ctrl, specs, rtol):
    """Reference-step figures ``(record, failed)`` of every stable loop when the specs
    have time-domain bounds (:func:`robrst.certificate.steps.check_many`, one call per sample
    rate), else ``None``."""
    out, groups = [None] * len(loops), {}
    if specs.time_domain:
        for k, lp in enumerate(loops):
            if lp.sa < 0:
                groups.setdefault(lp.fs, []).append(k)
    for fs, ks in groups.items():
        done = timespec.check_many([loops[k].plant for k in ks], ctrl,
                                   [loops[k].cl for k in ks], specs, rtol, fs)
        for k, step in zip(ks, done):
            out[k] = step
    return out


class _Loop:
    """One model's closed loop in :func:`_check_loops`: stability first, then its peak
    job (``nums``, ``bands``), then :meth:`finish` with the peaks and step figures."""

    def __init__(self, plant, ctrl, specs, fs):
        self.plant, self.ctrl, self.fs = plant, ctrl, fs
        self.cl = cl = closed_loop(plant, ctrl)
        self.sa = self.rho = self.roots = None      # set by _stability
        # further transfer functions whose peak a spec bounds (absolutely or relative to
        # the open loop's own peak |B/A|, robrst.problem.specs)
        self.relative = [k for k in EXTRA_PEAK_SPECS if specs.relative_peak_bound(k) is not None]
        self.extra = [k for k in EXTRA_PEAK_SPECS if specs.extra_peak_bound(k) is not None
                      or k in self.relative]
        self.open_pk = None          # the open loop's peak (set by _check_loops)
        self.nums = [cl.nums[k] for k in PEAK_SPECS] + [cl.nums[k] for k in self.extra]
        self.bands = bands = []        # frequency-limited peaks, computed with the global ones
        if specs.T_resonance_max is not None:
            lo, hi = (2 * np.pi * f for f in specs.resonance_band_hz)
            if fs is not None:        # folded above Nyquist; Nyquist itself is nu = inf
                lo, hi = warp_band(lo, hi, fs)
            bands.append((list(PEAK_SPECS).index("T"), (float(lo), float(hi))))
        if specs.Mu_hf_max is not None:   # |U| above a corner frequency (up to inf / Nyquist)
            lo = 2 * np.pi * specs.Mu_hf_above_hz
            if fs is not None:        # up to Nyquist (nu = inf) included
                lo = warp_band(min(lo, np.pi * fs), np.pi * fs, fs)[0]
            bands.append((list(PEAK_SPECS).index("U"), (float(lo), np.inf)))

    def open_loop_job(self):
        """The peak job of the plant's own ``|B/A|`` (``inf`` for a pole on the axis)."""
        return ([self.plant.B], self.plant.A, [])

    def phys(self, w):
        """Physical frequency [rad/s] of a loop frequency (unwarped for a sampled loop)."""
        return w if self.fs is None else float(unwarp(w, self.fs))

    def finish(self, pks, specs, rtol, step=None):
        """The record and violations from the peaks ``pks`` (globals, then bands) and the
        reference-step figures ``step`` (``(record, failed)`` or ``None``)."""
        plant, cl, sa, rho, fs = self.plant, self.cl, self.sa, self.rho, self.fs
        loop = "continuous" if fs is None else "sampled"
        fig = {"spectral_abscissa": sa, "stable": bool(sa < 0), "distance_to_instability": rho,
               "closed_loop_degree": len(poly.trim(cl.Delta)) - 1}
        viol = []

        def add(quantity, value, bound, freq=None, kind="exceeds"):
            viol.append(Violation(plant.label, plant.temperature_C, quantity, value, bound,
                                  freq, loop, kind))

        if sa >= 0:
            add("spectral_abscissa", sa, 0.0)
        elif rho is not None and not rho > RESOLVE_FACTOR * len(cl.Delta) * np.finfo(float).eps:
            add(f"stability not resolved in double precision: A S + B R is within {rho:.2g}"
                " (relative) of a polynomial with a root on the imaginary axis (cancellation"
                " in the closed-loop coefficients)", rho, RESOLVE_FACTOR, kind="unresolved")
        band_pks = iter(pks[len(PEAK_SPECS) + len(self.extra):])
        for name, pk in zip(self.extra, pks[len(PEAK_SPECS):]):    # B S/Delta, B T/Delta
            freq = (self.phys(float(pk.freq_rad_s))
                    if fs is not None or np.isfinite(pk.freq_rad_s) else None)
            row = spec(EXTRA_PEAK_SPECS[name])
            fig[row.figure], fig[row.figure + "_freq_rad_s"] = pk.value, freq
            bound = specs.extra_peak_bound(name)
            if bound is not None and pk.value > bound * (1 + rtol):
                add(row.label, pk.value, bound, freq)
            elif bound is not None and not pk.verified:
                add(f"{row.label} not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, bound, freq, kind="unresolved")
            if name in self.relative:
                self.relative_figures(name, pk, freq, fig, specs, rtol, add)
        if (specs.damping_min or specs.decay_min) and self.roots is not None:
            fig.update(self.region(specs, rtol, add))
        for name, pk in zip(PEAK_SPECS, pks):
            # a sampled peak at nu = inf is at Nyquist (unwarp(inf) = pi fs)
            freq = (self.phys(float(pk.freq_rad_s))
                    if fs is not None or np.isfinite(pk.freq_rad_s) else None)
            fig[f"M{name.lower()}"] = pk.value
            fig[f"M{name.lower()}_freq_rad_s"] = freq
            bound = specs.peak_bound(name)
            if bound is not None and pk.value > bound * (1 + rtol):
                add(f"|{name}| peak", pk.value, bound, freq)
            elif bound is not None and not pk.verified:
                add(f"|{name}| peak not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, bound, freq, kind="unresolved")
        if specs.T_resonance_max is not None:
            pk = next(band_pks)
            fig["Mt_resonance_band"] = pk.value
            fig["Mt_resonance_band_freq_rad_s"] = self.phys(pk.freq_rad_s)
            if pk.value > specs.T_resonance_max * (1 + rtol):
                add("|T| in resonance band", pk.value, specs.T_resonance_max,
                    self.phys(pk.freq_rad_s))
            elif not pk.verified:
                add("|T| band peak not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, specs.T_resonance_max, kind="unresolved")
        if specs.Mu_hf_max is not None:
            pk = next(band_pks)
            fig["Mu_hf"] = pk.value
            if pk.value > specs.Mu_hf_max * (1 + rtol):
                add("|U| above corner", pk.value, specs.Mu_hf_max, self.phys(pk.freq_rad_s))
            elif not pk.verified:
                add("|U| above corner not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, specs.Mu_hf_max, kind="unresolved")
        if step is not None:   # reference-step specs (robrst.certificate.steps)
            t_rec, failed = step
            fig["step"] = StepFigures(**t_rec)
            for q, v, b, kind in failed:
                add(q, v, b, kind=kind)
        return LoopFigures(**fig), viol

    def relative_figures(self, name, pk, freq, fig, specs, rtol, add):
        """The peak ``pk`` of ``name`` over the open loop's own peak (``Msd_rel``), its
        bound checked; an unverified peak (either) leaves it unresolved."""
        key = RELATIVE_PEAK_SPECS[name]
        row, bound = spec(key), getattr(specs, key)
        ol = self.open_pk
        open_peak = np.inf if ol is None else float(ol.value)
        ratio = float(pk.value) / open_peak if open_peak > 0 else np.inf
        fig[row.figure], fig["open_loop_peak"] = ratio, open_peak
        verified = pk.verified and (ol is None or ol.verified)
        if ratio > bound * (1 + rtol):
            add(row.label, ratio, bound, freq)
        elif not verified:
            add(f"{row.label} not verified: the poles span more than 12 decades", ratio,
                bound, freq, kind="unresolved")

    def region(self, specs, rtol, add):
        """The pole-region figures ``{"damping": .., "decay_rad_s": ..}`` of this loop (its
        roots mapped to s), violations and unresolved verdicts through ``add``.

        A verdict that the region holds is unresolved when double precision cannot tell:
        the closed-loop polynomial lies within its rounding error (``RESOLVE_FACTOR n
        eps``, relative to the products forming it) of one with a root on the region's
        boundary (:func:`robrst.core.region.boundary_distance`).  The sampled loop's
        region (its boundary has no polynomial form in the loop variable) is decided from
        its mapped roots alone; a loop whose roots are all ``RESOLVED_DAMPING`` above the
        floor (and ``RESOLVED_DECAY`` beyond the decay) is resolved without the test.
        """
        p, fs = self.plant, self.fs
        roots = np.asarray(self.roots, complex)
        s = region.s_poles(roots, fs)
        out = {"damping": region.least_damping(s), "decay_rad_s": region.least_decay(s)}
        floor, sigma = specs.damping_min, specs.decay_min
        lows = []
        for name, lim, what in (("damping", floor, "closed-loop damping"),
                                ("decay_rad_s", sigma, "closed-loop decay rate [rad/s]")):
            if not lim:
                continue
            vals = region.damping_of(s) if name == "damping" else -s.real
            k = int(np.argmin(vals))
            if vals[k] < lim * (1 - rtol):
                add(what, float(vals[k]), lim, abs(float(s[k].imag)) or None, kind="below")
                lows.append(name)
        if len(lows) == sum(bool(b) for b in (floor, sigma)) or fs is not None:
            return out
        zmin, dmin = out["damping"], out["decay_rad_s"]
        if (not floor or zmin >= floor + RESOLVED_DAMPING) and (
                not sigma or dmin >= sigma * (1 + RESOLVED_DECAY)):
            return out     # far inside: rounding cannot move a root across the boundary
        size = np.polyadd(np.convolve(np.abs(p.A), np.abs(self.ctrl.S)),
                          np.convolve(np.abs(p.B), np.abs(self.ctrl.R)))
        D = poly.trim(self.cl.Delta)
        rho = region.boundary_distance(D, size, roots, None if "damping" in lows else
                                       (floor or None), None if "decay_rad_s" in lows else
                                       (sigma or None))
        if not rho > RESOLVE_FACTOR * len(D) * np.finfo(float).eps:
            add(f"pole region not resolved in double precision: A S + B R is within {rho:.2g}"
                " (relative) of a polynomial with a root on the region's boundary", rho,
                RESOLVE_FACTOR, kind="unresolved")
        return out


# (figure, spec key) of every bound on a loop's figures (robrst.problem.specs), figure <= bound
BOUNDED = tuple((s.figure, s.key) for s in bound_specs("upper"))
LOWER_BOUNDED = tuple((s.figure, s.key) for s in bound_specs("lower"))   # figure >= bound
FIGURE_OF = {s.label: s.figure for s in bound_specs()}    # violation quantity -> figure
JUMPS = tuple(figure_key("settling_time_s", loop) for loop in LOOPS)   # piecewise continuous


def _sampled_loop(plant, specs, family):
    """``(sampled-loop plant, fs)`` of ``plant`` (from ``family``'s memo when given)."""
    fs, k = specs.sample_rate_hz, specs.delay_samples
    return (sampled_plant(plant, fs, k) if family is None else family.sampled(plant, fs, k)), fs


def _named(plant, viol):
    """A sampled loop's violations, naming the continuous model."""
    return [replace(v, label=plant.label) for v in viol]


def check_all(m: Plant, ctrl: RSTController, specs: Specs, rtol: float,
              checks: Sequence[Callable],
              family: PlantFamily | None = None) -> tuple[ModelRecord, list[Violation]]:
    """Every per-model check on model ``m`` (of ``family``, whose memo then holds its
    sampled plant): continuous, sampled, then the hooks.

    Parameters
    ----------
    m : Plant
        The model.
    ctrl : RSTController
        The controller.
    specs : Specs
        The bounds checked.
    rtol : float
        Relative tolerance on the bounds.
    checks : sequence of callable
        Extra checks ``check(plant, ctrl, specs, rtol) -> (record, violations)``.
    family : PlantFamily, optional
        The family ``m`` belongs to.

    Returns
    -------
    record : ModelRecord
        The continuous and sampled loops' figures and the hooks' figures.
    violations : list of Violation
    """
    return check_all_many([m], ctrl, specs, rtol, checks, family)[0]


def check_all_many(models: Sequence[Plant], ctrl: RSTController, specs: Specs, rtol: float,
                   checks: Sequence[Callable],
                   family: PlantFamily | None = None) -> list[tuple[ModelRecord, list[Violation]]]:
    """:func:`check_all` of each model, the peak computations of all their loops
    (continuous and sampled) batched: the same records as one model at a time.

    Parameters
    ----------
    models : sequence of Plant
        The models.
    ctrl : RSTController
        The controller.
    specs : Specs
        The bounds checked.
    rtol : float
        Relative tolerance on the bounds.
    checks : sequence of callable
        Extra checks ``check(plant, ctrl, specs, rtol) -> (record, violations)``.
    family : PlantFamily, optional
        The family the models belong to.

    Returns
    -------
    list of (ModelRecord, list of Violation)
        One per model, in order.
    """
    loops = [(m, None) for m in models]
    if specs.sampled:
        loops += [_sampled_loop(m, specs, family) for m in models]
    done = _check_loops(loops, ctrl, specs, rtol)
    out = []
    for i, m in enumerate(models):
        figs, v = done[i]
        sampled = None
        if specs.sampled:
            sampled, v_s = done[len(models) + i]
            v = v + _named(m, v_s)
        extra, marg = {}, {}
        for check in checks:
            rec_x, v_x = check(m, ctrl, specs, rtol)
            rec_x = dict(rec_x)
            marg.update(rec_x.pop("margins", {}))
            extra.update(rec_x)
            v = v + list(v_x)
        out.append((ModelRecord(label=m.label, temperature_C=m.temperature_C, continuous=figs,
                                sampled=sampled, extra=extra, margins=marg), v))
    return out


def margins(rec: ModelRecord, specs: Specs, rtol: float) -> dict[str, tuple[float, float]]:
    """``{figure: (value, limit)}`` of a record: what the refinement watches.

    Figures by their published names (:func:`robrst.certificate.figures.figure_key`):
    the spectral abscissa of every loop, every bounded figure, then the hooks' margins.

    Parameters
    ----------
    rec : ModelRecord
        A model's record.
    specs : Specs
        The bounds.
    rtol : float
        Relative tolerance on the bounds (the limits include it).

    Returns
    -------
    dict
        The spectral abscissae (limit 0) and every bounded figure, continuous and sampled,
        and the hooks' ``margins``.
    """
    out = {}
    for loop in LOOPS:
        lf = rec.loop(loop)
        if lf is None:
            continue
        sa = lf.spectral_abscissa
        if sa is not None and np.isfinite(sa):
            out[figure_key("spectral_abscissa", loop)] = (sa, 0.0)
        for key, attr in BOUNDED:
            b, v = getattr(specs, attr), lf.value(key)
            if b is not None and v is not None and np.isfinite(v):
                out[figure_key(key, loop)] = (v, b * (1 + rtol))
        for key, attr in LOWER_BOUNDED:   # a lower bound: (-value, -limit), the same test
            b, v = getattr(specs, attr), lf.value(key)
            if b and v is not None and np.isfinite(v):
                out[figure_key(key, loop)] = (-v, -b * (1 - rtol))
    out.update(rec.margins)
    return out
