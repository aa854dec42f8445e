"""Per-model checks of the certificate: exact peaks, stability, sampled loop, hooks.

:func:`check_model` recomputes every figure of one closed loop from the polynomials:
exact global peaks of ``|S|, |T|, |U|`` (:func:`robrst.core.peaks.peak_gain`), the exact
frequency-limited peaks (``|T|`` over the resonance band, ``|U|`` above a corner), the
spectral abscissa and whether double precision resolves that verdict
(:func:`robrst.core.interval.distance_to_instability`), and the reference-step figures
(:mod:`robrst.certificate.steps`).  :func:`check_all` adds the exact sampled loop and the
caller's extra checks; :func:`margins` lists the ``{figure: (value, limit)}`` pairs that
:mod:`robrst.certificate.proof` refines over the temperature interval.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.certificate import steps as timespec
from robrst.core.analysis import spectral_abscissa_many
from robrst.core.peaks import peak_gain, peak_gains_many
from robrst.core.interval import distance_to_instability_many
from robrst.problem.records import PEAK_SPECS
from robrst.core.rst import closed_loop
from robrst.core.sampled import sampled_plant, unwarp, warp

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.family import PlantFamily
    from robrst.core.plant import Plant
    from robrst.core.rst import RSTController
    from robrst.problem.records import Specs

__all__ = ["Violation", "check_model", "check_all", "check_all_many", "margins", "band_peak",
           "BOUNDED", "FIGURE_OF", "JUMPS", "SAMPLED_KEYS", "RESOLVE_FACTOR"]

RESOLVE_FACTOR = 64.0  # stability resolved when the distance to instability > this x n eps

@dataclass(frozen=True)
class Violation:
    """One failed check: model, temperature, quantity, value, bound, frequency.

    Parameters
    ----------
    label : str
        The model's label.
    temperature_C : float
        Its temperature [°C].
    quantity : str
        What failed (``"|S| peak"``, ``"overshoot_pct"``, ``"spectral_abscissa"``, ...; for
        ``unresolved``, why it could not be decided).
    value : float
        The figure found.
    bound : float
        Its bound.
    freq_rad_s : float or None
        Where (physical frequency [rad/s]), when a frequency applies.
    loop : {"continuous", "sampled"}
        Which loop.
    kind : {"exceeds", "crossing", "unresolved"}
        ``value > bound``; a closed-loop root reaches the imaginary axis between two checked
        temperatures; or the check could not be decided (nothing is certified then).
    """

    label: str
    temperature_C: float
    quantity: str
    value: float
    bound: float
    freq_rad_s: float
    loop: str = "continuous"     # or "sampled"
    kind: str = "exceeds"

    def describe(self) -> str:
        """One line: ``"model T45C (45 °C): |S| peak = 2.31 > 2 at 612 Hz"``.

        Returns
        -------
        str
        """
        at = "" if self.freq_rad_s is None else f" at {self.freq_rad_s / (2 * np.pi):.4g} Hz"
        loop = " in the sampled loop" if self.loop == "sampled" else ""
        if self.kind != "exceeds":
            return f"model {self.label} ({self.temperature_C:g} °C){loop}: {self.quantity}{at}"
        return (f"model {self.label} ({self.temperature_C:g} °C): {self.quantity}{loop} ="
                f" {self.value:.4g} > {self.bound:.4g}{at}")



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
    """Spectral abscissa and distance to instability of each loop (``(inf, None)`` for a
    sampled loop that lost degree: a pole at ``z = -1``), batched."""
    found = spectral_abscissa_many([lp.cl.Delta for lp in loops])
    jobs = {}
    for k, (lp, (sa, roots)) in enumerate(zip(loops, found)):
        if lp.fs is not None and len(lp.cl.Delta) < lp.plant.n + len(poly.trim(lp.ctrl.S)):
            found[k] = (np.inf, None)
        else:
            jobs[k] = ([(lp.plant.A, lp.ctrl.S), (lp.plant.B, lp.ctrl.R)], lp.cl.Delta, roots)
    rhos = dict(zip(jobs, distance_to_instability_many(list(jobs.values()))))
    return [(sa, rhos.get(k)) for k, (sa, _) in enumerate(found)]


def check_model(plant: Plant, ctrl: RSTController, specs: Specs, rtol: float,
                fs: float | None = None) -> tuple[dict, list[Violation]]:
    """Exact peaks and stability of one model; returns (record, violations).

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
    record : dict
        The model's figures (``Ms``, ``Mt``, ``Mu``, frequencies, ``stable``,
        ``spectral_abscissa``, ``distance_to_instability``, step figures, ...).
    violations : list of Violation
    """
    return _check_loops([(plant, fs)], ctrl, specs, rtol)[0]


def _check_loops(loops, ctrl, specs, rtol):
    """:func:`check_model` of each ``(plant, fs)``, the peak computations of all batched
    (:func:`robrst.core.peaks.peak_gains_many`: the same figures as one loop at a time)."""
    loops = [_Loop(plant, ctrl, specs, fs) for plant, fs in loops]
    for lp, (sa, rho) in zip(loops, _stability(loops)):
        lp.sa, lp.rho = sa, rho
    pks = peak_gains_many([(lp.nums, lp.cl.Delta, lp.bands) for lp in loops])
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
        self.sa = self.rho = None      # set by _stability
        self.nums = [cl.nums[k] for k in PEAK_SPECS]
        self.bands = bands = []        # frequency-limited peaks, computed with the global ones
        if specs.T_resonance_max is not None:
            lo, hi = (2 * np.pi * f for f in specs.resonance_band_hz)
            if fs is not None:
                lo, hi = (warp(min(lo, 0.999 * np.pi * fs), fs),
                          warp(min(hi, 0.999 * np.pi * fs), fs))
            bands.append((list(PEAK_SPECS).index("T"), (float(lo), float(hi))))
        if specs.Mu_hf_max is not None:   # |U| above a corner frequency (up to inf / Nyquist)
            lo = 2 * np.pi * specs.Mu_hf_above_hz
            lo = lo if fs is None else warp(min(lo, 0.999 * np.pi * fs), fs)
            bands.append((list(PEAK_SPECS).index("U"), (float(lo), np.inf)))

    def phys(self, w):
        """Physical frequency [rad/s] of a loop frequency (unwarped for a sampled loop)."""
        return w if self.fs is None else float(unwarp(w, self.fs))

    def finish(self, pks, specs, rtol, step=None):
        """The record and violations from the peaks ``pks`` (globals, then bands) and the
        reference-step figures ``step`` (``(record, failed)`` or ``None``)."""
        plant, cl, sa, rho, fs = self.plant, self.cl, self.sa, self.rho, self.fs
        loop = "continuous" if fs is None else "sampled"
        rec = {"label": plant.label, "temperature_C": plant.temperature_C,
               "spectral_abscissa": sa, "stable": bool(sa < 0), "distance_to_instability": rho,
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
        band_pks = iter(pks[len(PEAK_SPECS):])
        for name, pk in zip(PEAK_SPECS, pks):
            # a sampled peak at nu = inf is at Nyquist (unwarp(inf) = pi fs)
            freq = (self.phys(float(pk.freq_rad_s))
                    if fs is not None or np.isfinite(pk.freq_rad_s) else None)
            rec[f"M{name.lower()}"] = pk.value
            rec[f"M{name.lower()}_freq_rad_s"] = freq
            bound = specs.peak_bound(name)
            if bound is not None and pk.value > bound * (1 + rtol):
                add(f"|{name}| peak", pk.value, bound, freq)
            elif bound is not None and not pk.verified:
                add(f"|{name}| peak not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, bound, freq, kind="unresolved")
        if specs.T_resonance_max is not None:
            pk = next(band_pks)
            rec["Mt_resonance_band"] = pk.value
            rec["Mt_resonance_band_freq_rad_s"] = self.phys(pk.freq_rad_s)
            if pk.value > specs.T_resonance_max * (1 + rtol):
                add("|T| in resonance band", pk.value, specs.T_resonance_max,
                    self.phys(pk.freq_rad_s))
            elif not pk.verified:
                add("|T| band peak not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, specs.T_resonance_max, kind="unresolved")
        if specs.Mu_hf_max is not None:
            pk = next(band_pks)
            rec["Mu_hf"] = pk.value
            if pk.value > specs.Mu_hf_max * (1 + rtol):
                add("|U| above corner", pk.value, specs.Mu_hf_max, self.phys(pk.freq_rad_s))
            elif not pk.verified:
                add("|U| above corner not verified: the closed-loop poles span more than 12"
                    " decades", pk.value, specs.Mu_hf_max, kind="unresolved")
        if step is not None:   # reference-step specs (robrst.certificate.steps)
            t_rec, failed = step
            rec.update(t_rec)
            for q, v, b, kind in failed:
                add(q, v, b, kind=kind)
        return rec, viol


SAMPLED_KEYS = ("spectral_abscissa", "stable", "Ms", "Ms_freq_rad_s", "Mt", "Mt_freq_rad_s",
                "Mu", "Mu_freq_rad_s", "Mt_resonance_band", "distance_to_instability", "Mu_hf",
                *timespec.KEYS)
BOUNDED = (("Ms", "Ms_max"), ("Mt", "Mt_max"), ("Mu", "Mu_max"),
           ("Mt_resonance_band", "T_resonance_max"), ("Mu_hf", "Mu_hf_max"),
           ("overshoot_pct", "overshoot_max_pct"), ("settling_time_s", "settling_time_max_s"),
           ("step_u_peak_V", "step_u_max_V"))
FIGURE_OF = {"|S| peak": "Ms", "|T| peak": "Mt", "|U| peak": "Mu",   # violation -> record
             "|T| in resonance band": "Mt_resonance_band", "|U| above corner": "Mu_hf"}
JUMPS = ("settling_time_s", "settling_time_s_sampled")   # piecewise continuous figures


def _sampled_loop(plant, specs, family):
    """``(sampled-loop plant, fs)`` of ``plant`` (from ``family``'s memo when given)."""
    fs, k = specs.sample_rate_hz, specs.delay_samples
    return (sampled_plant(plant, fs, k) if family is None else family.sampled(plant, fs, k)), fs


def _suffixed(plant, rec, viol):
    """A sampled loop's record (keys suffixed ``_sampled``) and violations (naming the
    continuous model)."""
    viol = [replace(v, label=plant.label) for v in viol]
    return {f"{key}_sampled": rec[key] for key in SAMPLED_KEYS if key in rec}, viol


def check_sampled(plant, ctrl, specs, rtol, family=None):
    """:func:`check_model` of the sampled loop of ``plant`` (its sampled plant from
    ``family``'s memo when given); figures suffixed ``_sampled``."""
    ps, fs = _sampled_loop(plant, specs, family)
    return _suffixed(plant, *check_model(ps, ctrl, specs, rtol, fs=fs))


def check_all(m: Plant, ctrl: RSTController, specs: Specs, rtol: float,
              checks: Sequence[Callable], family: PlantFamily | None = None) -> tuple[dict, list[Violation]]:
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
    record : dict
        Continuous figures, the sampled ones suffixed ``_sampled``, the hooks' figures.
    violations : list of Violation
    """
    return check_all_many([m], ctrl, specs, rtol, checks, family)[0]


def check_all_many(models: Sequence[Plant], ctrl: RSTController, specs: Specs, rtol: float,
                   checks: Sequence[Callable],
                   family: PlantFamily | None = None) -> list[tuple[dict, list[Violation]]]:
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
    list of (record, violations)
        One per model, in order.
    """
    loops = [(m, None) for m in models]
    if specs.sampled:
        loops += [_sampled_loop(m, specs, family) for m in models]
    done = _check_loops(loops, ctrl, specs, rtol)
    out = []
    for i, m in enumerate(models):
        rec, v = done[i]
        if specs.sampled:
            rec_s, v_s = _suffixed(m, *done[len(models) + i])
            rec.update(rec_s)
            v = v + v_s
        for check in checks:
            rec_x, v_x = check(m, ctrl, specs, rtol)
            margins = {**rec.get("margins", {}), **rec_x.pop("margins", {})}
            rec.update(rec_x)
            if margins:
                rec["margins"] = margins
            v = v + list(v_x)
        out.append((rec, v))
    return out


def margins(rec: dict, specs: Specs, rtol: float) -> dict[str, tuple[float, float]]:
    """``{figure: (value, limit)}`` of a record: what the refinement watches.

    Parameters
    ----------
    rec : dict
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
