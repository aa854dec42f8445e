"""What a certified controller does that the specs did not bound: the warnings of a design.

A certificate proves the bounds the problem lists, nothing else.  A careful engineer also
looks at what was left unbounded; :func:`assess` computes it on every family member
(continuous loop, and the sampled loop when the specs name a rate) and says so:

* **damping**: a closed-loop pole less damped than the plant's own least damped
  resonance (the default floor, :meth:`robrst.problem.records.Specs.damping_floor`, allows
  ``DEFAULT_DAMPING_SHARE`` of it; below the plant's own it is still worth a line);
* **reference overshoot**: a reference step overshooting more than
  ``DEFAULT_OVERSHOOT_WARN_PCT`` when no ``overshoot_max_pct`` is given (the exact step
  figures of the certificate, :func:`robrst.certificate.steps.check_many`), computed when
  some closed-loop pole of the loop is damped below ``OVERSHOOT_GATE`` (a second-order
  mode damped more overshoots less than 20 %; plant zeros could add some: a loop whose
  poles are all better damped is not stepped, which keeps a continuous design free of the
  step kernel's SciPy);
* **input disturbances**: the peak of ``|B S / Delta|`` above the open loop's ``|B / A|``
  (the controller amplifies input disturbances somewhere) when neither ``Msd_max`` nor
  ``Msd_rel_max`` bounds it.

With a sample rate every warning is the **sampled loop's** (the loop that ships: ZOH
plant, Tustin controller), the continuous loop's figure said beside it.

Each warning names the model, the figure, the comparison and the key to set.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly, region
from robrst.core.peaks import peak_gains_many
from robrst.core.rst import closed_loop
from robrst.certificate.steps import check_many
from robrst.problem.records import (DEFAULT_OVERSHOOT_WARN_PCT, RESONANT_DAMPING, default_notes,
                                   plant_damping)

if TYPE_CHECKING:
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem

__all__ = ["Assessment", "ModelAssessment", "LoopAssessment", "assess", "OVERSHOOT_GATE"]

OVERSHOOT_GATE = 0.46   # a second-order mode damped 0.46 overshoots 19.8 %


@dataclass(frozen=True)
class LoopAssessment:
    """One loop's unbounded figures on one family member.

    Parameters
    ----------
    damping : float
        Least damping of the loop's closed-loop poles (the sampled loop's mapped to s by
        ``fs ln z``).
    overshoot_pct : float or None
        Reference-step overshoot [%] (at the samples for the sampled loop; ``None``: not
        stepped, see ``OVERSHOOT_GATE``).
    Msd : float, optional
        Peak of ``|B S / Delta|`` [µm/V] (the sampled loop's: the input disturbance held by
        the ZOH to the sampled output, up to Nyquist).
    open_loop_Msd : float, optional
        The plant's own peak [µm/V] (the ZOH plant's for the sampled loop; ``inf`` when
        not stable).
    """

    damping: float
    overshoot_pct: float | None = None
    Msd: float | None = None
    open_loop_Msd: float | None = None


@dataclass(frozen=True)
class ModelAssessment:
    """One family member's unbounded figures.

    Parameters
    ----------
    label : str
        The model.
    temperature_C : float
        Its temperature [°C].
    plant_damping : float
        Least damping of the plant's complex poles (1: none).
    Msd : float
        Peak of ``|B S / Delta|`` [µm/V].
    open_loop_Msd : float
        Peak of ``|B / A|`` [µm/V] (``inf`` for a plant that is not stable).
    continuous : LoopAssessment
        The continuous loop's damping and overshoot.
    sampled : LoopAssessment, optional
        The sampled loop's (with a sampling rate).
    """

    label: str
    temperature_C: float
    plant_damping: float
    Msd: float
    open_loop_Msd: float
    continuous: LoopAssessment
    sampled: LoopAssessment | None = None

    def loop(self, loop: str = "continuous") -> LoopAssessment | None:
        """The figures of ``loop``.

        Parameters
        ----------
        loop : {"continuous", "sampled"}
            Which loop.

        Returns
        -------
        LoopAssessment or None
        """
        return self.continuous if loop == "continuous" else self.sampled


@dataclass(frozen=True)
class Assessment:
    """The figures :func:`assess` computed and the warnings they earn.

    Parameters
    ----------
    models : tuple of ModelAssessment
        One per family member.
    warnings : tuple of str
        What the specs left unbounded and a careful engineer would want to know.
    notes : tuple of str
        The defaults applied (the damping floor).
    damping_floor : float, optional
        The damping floor the certificate checked.
    damping_source : str, optional
        ``"specs"`` or ``"default"``.
    extra : dict
        Room for further figures.
    """

    models: tuple
    warnings: tuple = ()
    notes: tuple = ()
    damping_floor: float = None
    damping_source: str = None
    extra: dict = field(default_factory=dict)


def _overshoots(plants, loops, ctrl, specs, fs=None):
    """Reference-step overshoot [%] of each loop (stable ones), computed together."""
    if not loops:
        return []
    return [float(rec["overshoot_pct"]) for rec, _ in
            check_many(plants, ctrl, loops, specs, 1e-3, fs)]


def _least_damping(D, fs=None):
    return region.least_damping(region.s_poles(np.roots(poly.trim(D)), fs))


def _sampled(problem, m):
    sp = problem.specs
    return problem.family.sampled(m, sp.sample_rate_hz, sp.delay_samples)


def assess(problem: Problem, ctrl: RSTController) -> Assessment:
    """The warnings of ``ctrl`` on ``problem``'s family members (module docstring).

    Parameters
    ----------
    problem : Problem
    ctrl : RSTController
        The final controller (with its reference path).

    Returns
    -------
    Assessment
    """
    sp = problem.specs
    fam = problem.family
    floor, source = problem.damping_floor.value, problem.damping_floor.source
    zp_all = plant_damping(fam)
    loops = [closed_loop(m, ctrl) for m in fam.models]
    pks = peak_gains_many([([cl.nums["Sd"]], cl.Delta, []) for cl in loops]
                          + [([m.B], m.A, []) for m in fam.models
                             if np.all(np.roots(m.A).real < 0)])
    stable_ol = [bool(np.all(np.roots(m.A).real < 0)) for m in fam.models]
    ol = iter(pks[len(loops):])
    stable = [bool(np.all(np.roots(poly.trim(cl.Delta)).real < 0))
              and _least_damping(cl.Delta) < OVERSHOOT_GATE for cl in loops]
    want = sp.overshoot_max_pct is None    # else the certificate has the step figures
    steps = _overshoots([m for m, ok in zip(fam.models, stable) if ok and want],
                        [cl for cl, ok in zip(loops, stable) if ok and want], ctrl, sp)
    sampled = {}
    if sp.sampled:
        ps = [_sampled(problem, m) for m in fam.models]
        cls = [closed_loop(p, ctrl) for p in ps]
        ok = [bool(np.all(np.abs(np.roots(poly.trim(c.Delta))) > 0)
                   and np.all(np.roots(poly.trim(c.Delta)).real < 0))
              and _least_damping(c.Delta, sp.sample_rate_hz) < OVERSHOOT_GATE for c in cls]
        st_s = iter(_overshoots([p for p, k in zip(ps, ok) if k and want],
                                [c for c, k in zip(cls, ok) if k and want], ctrl, sp,
                                sp.sample_rate_hz))
        ol_ok = [bool(np.all(np.roots(p.A).real < 0)) for p in ps]
        pk_s = peak_gains_many([([c.nums["Sd"]], c.Delta, []) for c in cls]
                               + [([p.B], p.A, []) for p, k in zip(ps, ol_ok) if k])
        ol_s = iter(pk_s[len(cls):])
        sampled = {i: (_least_damping(c.Delta, sp.sample_rate_hz),
                       next(st_s) if k and want else None, float(pk_s[i][0].value),
                       float(next(ol_s)[0].value) if ol_ok[i] else np.inf)
                   for i, (c, k) in enumerate(zip(cls, ok))}
    steps = iter(steps)
    out = []
    for i, (m, cl, pk, st) in enumerate(zip(fam.models, loops, pks, stable_ol)):
        p = np.roots(m.A)
        cplx = p[np.abs(p.imag) > 1e-9 * np.abs(p)]
        cont = LoopAssessment(damping=_least_damping(cl.Delta),
                              overshoot_pct=next(steps) if stable[i] and want else None,
                              Msd=float(pk[0].value),
                              open_loop_Msd=float(next(ol)[0].value) if st else np.inf)
        out.append(ModelAssessment(
            label=m.label, temperature_C=m.temperature_C,
            plant_damping=region.least_damping(cplx), Msd=cont.Msd,
            open_loop_Msd=cont.open_loop_Msd, continuous=cont,
            sampled=LoopAssessment(*sampled[i]) if sp.sampled else None))
    return Assessment(models=tuple(out), warnings=tuple(_warnings(problem, out, floor, source)),
                      notes=tuple(_notes(sp, floor, source, zp_all)), damping_floor=floor,
                      damping_source=source)


def _notes(specs, floor, source, zp):
    if specs.resolved:
        out = default_notes(specs)
        if source == "default" and not floor:
            out.append("no default damping floor (a family member has an unstable resonance)")
        return out
    if source == "default" and floor:
        return [f"default damping floor {floor:.4g} on every closed-loop pole (min(0.1, 0.9 x the"
                f" plant's least damping {zp:.4g}); set [specs] damping_min to choose it,"
                " damping_min = 0 for none"]
    if source == "default":
        return ["no default damping floor (a family member has an unstable resonance)"]
    return []


def _worst(models, loop):
    vals = [(lp.overshoot_pct, m) for m in models if (lp := m.loop(loop)) is not None
            and lp.overshoot_pct is not None and np.isfinite(lp.overshoot_pct)]
    return max(vals, key=lambda v: v[0]) if vals else (None, None)


def _warnings(problem, models, floor, source):
    """The warnings, each on the loop that ships: the sampled loop when the specs name a
    rate (the continuous loop's figure said beside it), else the continuous loop."""
    sp = problem.specs
    samp = bool(sp.sampled)
    shipped = f" in the {sp.sample_rate_hz:g} Hz loop that ships" if samp else ""
    out = []

    def shipped_loop(m):
        return m.sampled if samp and m.sampled is not None else m.continuous

    def damping(m):
        return shipped_loop(m).damping

    low = [m for m in models if m.plant_damping < RESONANT_DAMPING   # a resonance to ring
           and damping(m) < m.plant_damping * (1 - 1e-3)]
    if low and not (source == "specs" and floor):
        m = min(low, key=lambda m: damping(m) / m.plant_damping)
        also = f" (continuous loop {m.continuous.damping:.3g})" if samp else ""
        out.append(f"closed-loop damping {damping(m):.3g}{shipped}{also} on model {m.label}"
                   f" ({m.temperature_C:g} °C) is below the plant's own {m.plant_damping:.3g}:"
                   " a resonance rings longer than open loop (set [specs] damping_min, or try"
                   " extra_degree + 1 to let the controller damp it)")
    if sp.overshoot_max_pct is None:
        v, m = _worst(models, "sampled" if samp else "continuous")
        vc, mc = _worst(models, "continuous")
        if v is not None and v > DEFAULT_OVERSHOOT_WARN_PCT:
            also = (f" (continuous loop {vc:.3g} % on {mc.label})" if samp and vc is not None
                    else "")
            out.append(f"a reference step overshoots {v:.3g} %{shipped}{also} on model {m.label}"
                       f" ({m.temperature_C:g} °C), above {DEFAULT_OVERSHOOT_WARN_PCT:g} %"
                       " (no overshoot_max_pct given: set it, a damping_min, or T_mode ="
                       " \"reference_model\")")
    if sp.Msd_max is None and sp.Msd_rel_max is None:
        def pair(m):
            lp = shipped_loop(m)
            return lp.Msd, lp.open_loop_Msd

        worse = [m for m in models if np.isfinite(pair(m)[1])
                 and pair(m)[0] > pair(m)[1] * (1 + 1e-3)]
        if worse:
            m = max(worse, key=lambda m: pair(m)[0] / pair(m)[1])
            v, ol = pair(m)
            also = f" (continuous loop {m.Msd:.4g})" if samp else ""
            out.append(f"input-disturbance peak |B S/Delta| {v:.4g} µm/V{shipped}{also} on model"
                       f" {m.label} ({m.temperature_C:g} °C) exceeds the open loop's {ol:.4g}"
                       " µm/V: the controller amplifies input disturbances near that frequency"
                       " (set [specs] Msd_max)")
    return out
