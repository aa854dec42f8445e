"""Infeasible or not found: a proof that no linear controller meets the specs, or what the
best controller found misses and what to try.

**The proof** is the pointwise relaxation of the controller set.  Whatever linear
controller runs the loop, at a frequency ``w`` its complementary sensitivity is some
complex number ``t = T(jw)``, and every frequency-domain spec asks ``t`` to lie in two discs
(:mod:`robrst.synthesis.discs`): ``|1 - t| <= r_S(w)`` and ``|t| <= r_T(w)``.  When
``r_S(w) + r_T(w) < 1`` the discs do not meet: no complex number, hence no controller,
meets the specs at that frequency.  Integral action adds ``t = 1`` at 0 Hz, which needs
``r_T(0) >= 1`` (``Mt_max >= 1`` and ``Mu_max |D(0)| >= 1``).  A failing frequency is a
proof by itself: it is evaluated on the exact frequency response of the model's loop (the
continuous loop, and the sampled loop up to Nyquist through
:func:`robrst.core.sampled.sampled_plant`), with a margin far above rounding.  The test
runs on a dense grid, the band ends of every spec and the frequencies where the discs
change (band edges and corners, checked on both sides), and names the contiguous band of
failing frequencies with its ends refined by bisection.  A grid on which the discs meet
everywhere proves nothing: then the answer is "not found".

**Reference steps** have two proofs.  Causality: in the sampled loop the output cannot move
before the first input the controller computes has passed the loop's dead time
(``delay_samples`` samples, one more through the hold of a strictly proper plant), so the
output is 0 at every sample before it, outside the 2 % band of a step that the loop
tracks (integral action: the final value is the reference).  A ``settling_time_max_s``
below that dead time is met by no controller at all (:class:`StepInfeasibility`).  And a
loop that tracks the step holds the plant's input at ``step_um / D(0)`` in the end (every
robrst controller has ``T(0) = R(0)``, so with the integral action the output settles at
the reference): a ``step_u_max_V`` below that on some family member is met by none.

**A decay floor** has one proof: the creep of a parametric family
(:mod:`robrst.core.family`) multiplies the plant by the lag-lead ``(tau s + 1 + kappa) /
(tau s + 1)``, whose strength ``kappa`` grows from 0 at the reference temperature.  As
``kappa`` tends to 0 the pole and the zero meet at ``-1/tau`` and every closed loop
``(tau s + 1) A S + (tau s + 1 + kappa) B R`` tends to ``(tau s + 1)(A S + B R)``: its roots
move continuously, so one of them tends to ``-1/tau`` whatever the controller (in the
sampled loop to ``exp(-h/tau)``, the same decay).  Where the interval holds temperatures of
strength 0 and temperatures of positive strength, a ``decay_min`` above ``1/tau`` is met by
no controller (:class:`RegionInfeasibility`).

**An unstable plant** has one more proof: whatever controller stabilises it, the peak of
``|U| = |K / (1 + P K)|`` is at least ``1 / sigma_min``, the least Hankel singular value of
the mirror image of the plant's unstable part (Glover 1986; the largest additive
perturbation one controller tolerates, :func:`robrst.core.lti.least_control_peak`).  A
``Mu_max`` below it on some family member, in the continuous loop or in the sampled
loop's w-plane (whose unstable poles are the sampled plant's poles outside the unit
circle), is met by no controller (:class:`ControlInfeasibility`).

**Not found**: the best controller's worst violation, for a pole region the mode below
the floor (its frequency, model and the damping reached), and a suggestion (one more
controller degree; the loosest value of the violated spec this order reached).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.synthesis.discs import expressed_specs, integrators_of, loop_plants, spec_discs

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.problem.records import Problem

__all__ = ["Infeasibility", "StepInfeasibility", "RegionInfeasibility", "ControlInfeasibility",
           "FeasibilityVerdict", "prove_infeasible", "prove_step_infeasible",
           "prove_region_infeasible", "prove_control_infeasible",
           "feasibility_verdict", "PROOF_MARGIN", "PROOF_POINTS"]

PROOF_MARGIN = 1e-9      # the discs must miss by this much (relative to 1): far above rounding
PROOF_POINTS = 3000      # log-spaced frequencies per loop (plus edges and resonance points)
SPEC_NAMES = {"Ms_max": "|S|", "Msd_max": "|B S/Delta|", "Mt_max": "|T|",
              "T_resonance_max": "|T| in the resonance band", "Mu_max": "|U|",
              "Mu_hf_max": "|U| above the corner"}


@dataclass(frozen=True)
class Infeasibility:
    """A proof that no linear controller meets the specs: a model, a loop and a band.

    Parameters
    ----------
    model : str
        The model's label.
    temperature_C : float
        Its temperature [°C].
    loop : {"continuous", "sampled"}
        Which loop.
    band_hz : (float, float)
        The contiguous failing frequencies found [Hz]; both ends fail (``(0, 0)``: the
        integral action at 0 Hz; an upper end ``inf``: failing up to the last frequency
        checked, ``checked_to_hz``).
    specs : tuple of str
        The spec keys whose discs do not meet there.
    worst_hz : float
        Where the discs miss most [Hz].
    worst_sum : float
        ``r_S + r_T`` there (``< 1``; for 0 Hz, ``r_T(0)``).
    points : int
        Failing frequencies checked in the band.
    checked_to_hz : float
        The highest frequency checked [Hz].
    reason : str
        The proof in one sentence.
    """

    model: str
    temperature_C: float
    loop: str
    band_hz: tuple
    specs: tuple
    worst_hz: float
    worst_sum: float
    points: int
    checked_to_hz: float
    reason: str

    def as_dict(self) -> dict:
        """The entry of ``feasibility.proofs`` in the design JSON.

        Returns
        -------
        dict
        """
        return {"model": self.model, "temperature_C": self.temperature_C, "loop": self.loop,
                "band_hz": [float(b) for b in self.band_hz], "specs": list(self.specs),
                "worst_hz": self.worst_hz, "worst_sum": self.worst_sum, "points": self.points,
                "checked_to_hz": self.checked_to_hz, "reason": self.reason,
                "kind": "frequency"}


@dataclass(frozen=True)
class StepInfeasibility:
    """A proof that no controller meets a reference-step spec: the sampled loop's dead time
    (causality), or the voltage that holds the step.

    Parameters
    ----------
    model : str
        The label of the model: the first family member for the dead time (every model's),
        the member of least static gain for the voltage.
    temperature_C : float
        Its temperature [°C].
    loop : str
        ``"sampled"`` (the dead time), ``"continuous"`` (the voltage: the sampled loop's
        static gain is the same).
    spec : str
        The spec key (``"settling_time_max_s"`` or ``"step_u_max_V"``).
    bound : float
        Its value [s or V].
    least : float
        What every controller reaches at least: the loop's dead time [s], or the
        voltage that holds the step [V].
    dead_samples : int
        Samples at which the output is still 0 (``delay_samples``, plus one through the
        hold of a strictly proper plant; 0 for the voltage).
    reason : str
        The proof in one sentence.
    """

    model: str
    temperature_C: float
    loop: str
    spec: str
    bound: float
    least: float
    dead_samples: int
    reason: str

    def as_dict(self) -> dict:
        """The entry of ``feasibility.proofs`` in the design JSON (``kind`` ``"step"``;
        the frequency proofs' entries have ``kind`` ``"frequency"``).

        Returns
        -------
        dict
        """
        return {"kind": "step", "model": self.model, "temperature_C": self.temperature_C,
                "loop": self.loop, "specs": [self.spec], "bound": self.bound,
                "least": self.least, "dead_samples": self.dead_samples, "reason": self.reason}


@dataclass(frozen=True)
class RegionInfeasibility:
    """A proof that no controller meets a decay floor: a closed-loop root that a vanishing
    creep pair holds at ``-1/tau`` whatever the controller (module docstring).

    Parameters
    ----------
    model : str
        The label of the limit model (the temperature where the creep strength is 0).
    temperature_C : float
        That temperature [°C].
    loop : str
        ``"both"``: the continuous and the sampled loop alike.
    spec : str
        ``"decay_min"``.
    bound : float
        Its value [rad/s].
    limit : float
        The decay rate some closed-loop root approaches at temperatures of small creep,
        whatever the controller: ``1/tau`` [rad/s].
    reason : str
        The proof in one sentence.
    """

    model: str
    temperature_C: float
    loop: str
    spec: str
    bound: float
    limit: float
    reason: str

    def as_dict(self) -> dict:
        """The entry of ``feasibility.proofs`` in the design JSON (``kind`` ``"region"``).

        Returns
        -------
        dict
        """
        return {"kind": "region", "model": self.model, "temperature_C": self.temperature_C,
                "loop": self.loop, "specs": [self.spec], "bound": self.bound,
                "limit": self.limit, "reason": self.reason}


@dataclass(frozen=True)
class ControlInfeasibility:
    """A proof that no controller meets ``Mu_max`` on an unstable plant: every controller
    that stabilises it has a larger ``|U|`` peak (module docstring).

    Parameters
    ----------
    model : str
        The model's label.
    temperature_C : float
        Its temperature [°C].
    loop : {"continuous", "sampled"}
        Which loop.
    spec : str
        ``"Mu_max"``.
    bound : float
        Its value [V/µm].
    least : float
        The least ``|U|`` peak of every stabilising controller [V/µm].
    unstable_poles : int
        The plant's poles in the open right half-plane (of the w-plane for the sampled
        loop).
    reason : str
        The proof in one sentence.
    """

    model: str
    temperature_C: float
    loop: str
    spec: str
    bound: float
    least: float
    unstable_poles: int
    reason: str

    def as_dict(self) -> dict:
        """The entry of ``feasibility.proofs`` in the design JSON (``kind``
        ``"unstable_plant"``).

        Returns
        -------
        dict
        """
        return {"kind": "unstable_plant", "model": self.model,
                "temperature_C": self.temperature_C, "loop": self.loop, "specs": [self.spec],
                "bound": self.bound, "least": self.least,
                "unstable_poles": self.unstable_poles, "reason": self.reason}


@dataclass(frozen=True)
class FeasibilityVerdict:
    """Why a design is not certified: infeasible (with proofs) or not found (with advice).

    Parameters
    ----------
    status : {"infeasible", "not_found"}
        ``"infeasible"``: no linear controller meets the specs (``proofs``);
        ``"not_found"``: no proof, and this design does not meet them.
    proofs : tuple of Infeasibility, StepInfeasibility, RegionInfeasibility or ControlInfeasibility
        The step specs no controller meets (:func:`prove_step_infeasible`), a decay floor
        (:func:`prove_region_infeasible`), ``Mu_max`` on an unstable plant
        (:func:`prove_control_infeasible`), then one per model and loop where the discs do
        not meet (at most the worst band each).
    checked : str
        What the test covered (models, loops, frequencies, specs).
    expressed : tuple of str
        The spec keys the test expresses.
    not_expressed : tuple of str
        Given specs it cannot express (a "not found" may still be infeasible through them).
    misses : str
        What the best controller found misses (its worst violation).
    mode : str
        For a pole region: the mode below the floor and the best damping found.
    suggestion : str
        What to try.
    wall_time_s : float
        Time spent [s].
    note : str
        What the pipeline did about it (e.g. skipped the synthesis).
    """

    status: str
    proofs: tuple = field(default=())
    checked: str = ""
    expressed: tuple = ()
    not_expressed: tuple = ()
    misses: str = ""
    mode: str = ""
    suggestion: str = ""
    wall_time_s: float = 0.0
    note: str = ""

    def as_dict(self) -> dict:
        """The ``feasibility`` object of the design JSON.

        Returns
        -------
        dict
        """
        return {"status": self.status, "proofs": [p.as_dict() for p in self.proofs],
                "checked": self.checked, "expressed": list(self.expressed),
                "not_expressed": list(self.not_expressed), "misses": self.misses,
                "mode": self.mode, "suggestion": self.suggestion,
                "wall_time_s": self.wall_time_s, "note": self.note, "lines": self.lines()}

    def lines(self) -> list[str]:
        """The lines of the text summary.

        Returns
        -------
        list of str
        """
        if self.status == "infeasible":
            p = self.proofs[0]
            out = [f"infeasible: no linear controller meets these specs: {p.reason}"]
            if len(self.proofs) > 1:
                more = sorted({f"{q.model} ({q.loop})" for q in self.proofs[1:]})
                out.append(f"  (also on {len(self.proofs) - 1} more model loops: "
                           + ", ".join(more[:6]) + (" ..." if len(more) > 6 else "") + ")")
            if self.note:
                out.append(f"  {self.note}")
            return out
        out = [f"not found: no proof that the specs are infeasible ({self.checked});"
               " this order did not reach them"]
        for part in (self.misses, self.mode, self.suggestion):
            if part:
                out.append("  " + part)
        return out


def _grid(lp, sp, n):
    """Physical frequencies [rad/s] for the test of ``lp``: log-spaced over its roots'
    range (far beyond on both sides), dense at lightly damped poles, every spec's band
    edges on both sides, Nyquist for a sampled loop."""
    m = lp.model
    r = np.abs(np.concatenate([m.poles(), m.zeros()]))
    r = r[(r > 0) & np.isfinite(r)]
    lo, hi = (r.min(), r.max()) if len(r) else (1.0, 1.0)
    lo, hi = lo / 1e3, hi * 1e4
    top = min(hi, lp.nyquist_rad_s)
    pts = [np.geomspace(lo, top, n)]
    for p in m.poles():
        wr = abs(p)
        if wr > 0 and p.imag > 0 and -p.real / wr < 0.1:
            h = max(-p.real / wr, 1e-5)
            pts.append(wr * (1 + h * np.linspace(-20, 20, 81)))
    for e in (2 * np.pi * f for f in _edges_hz(sp)):
        pts.append([e, e * (1 - 1e-12), e * (1 + 1e-12)])
    w = np.concatenate(pts)
    w = w[(w > 0) & (w <= top)]
    if lp.fs is not None:
        w = np.append(w, lp.nyquist_rad_s)
    return np.unique(w)


def _sums(lp, w, sp):
    d = spec_discs(lp, w, sp)
    with np.errstate(invalid="ignore"):
        s = d.r_S + d.r_T
    return np.where(np.isnan(s), np.inf, s), d


def _refine(lp, sp, w_fail, w_pass):
    """The failing end of ``[w_fail, w_pass]`` moved by bisection towards the passing one
    (every point kept fails); not within 1e-9 of the passing point (a spec edge: the grid
    holds both sides, and rounding decides nothing there)."""
    for _ in range(40):
        if abs(w_pass - w_fail) <= 1e-9 * max(abs(w_fail), abs(w_pass)):
            break
        mid = np.sqrt(w_fail * w_pass) if w_fail > 0 and w_pass > 0 else 0.5 * (w_fail + w_pass)
        if not min(w_fail, w_pass) < mid < max(w_fail, w_pass):
            break
        s, _ = _sums(lp, [mid], sp)
        if s[0] < 1 - PROOF_MARGIN:
            w_fail = mid
        else:
            w_pass = mid
    return w_fail


def _hz(w):
    return float(w) / (2 * np.pi)


def _edge_hz(w, sp):
    """``w`` [rad/s] in Hz, the spec's own number when ``w`` is one of its band edges."""
    f = _hz(w)
    for e in _edges_hz(sp):
        if abs(f - e) <= 1e-12 * e:
            return float(e)
    return f


def _edges_hz(sp):
    out = []
    if sp.T_resonance_max is not None:
        out += list(sp.resonance_band_hz)
    if sp.Mu_hf_max is not None:
        out.append(sp.Mu_hf_above_hz)
    return out


def _loop_proofs(lp, sp, n, integral):
    """The proofs on one loop: integral action at 0 Hz, then the worst failing band."""
    out = []
    where = f"model {lp.label} ({lp.temperature_C:g} °C, {lp.loop} loop)"
    if integral:
        d0 = spec_discs(lp, [0.0], sp)
        r0 = float(d0.r_T[0])
        if r0 < 1 - PROOF_MARGIN:
            keys = tuple(k for k in d0.active(0) if k in d0.T_terms)
            what = " and ".join(f"{k} = {getattr(sp, k):g}" for k in keys)
            dc = abs(lp.dc()[0])
            out.append(Infeasibility(
                lp.label, lp.temperature_C, lp.loop, (0.0, 0.0), keys, 0.0, r0, 1, 0.0,
                f"{where}: integral action makes T(0) = 1, but at 0 Hz"
                f" {what} {'allows' if len(keys) == 1 else 'allow'} |T| <="
                f" {r0:.4g} (|D(0)| = {dc:.4g} µm/V)"))
    w = _grid(lp, sp, n)
    s, d = _sums(lp, w, sp)
    fail = s < 1 - PROOF_MARGIN
    if not fail.any():
        return out
    # contiguous runs of failing points; the worst run is named
    idx = np.flatnonzero(fail)
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    run = min(runs, key=lambda r: s[r].min())
    i0, i1 = run[0], run[-1]
    k = run[np.argmin(s[run])]
    lo = w[i0] if i0 == 0 else _refine(lp, sp, w[i0], w[i0 - 1])
    top_checked = w[-1]
    if i1 == len(w) - 1:
        hi = np.inf if lp.fs is None else w[i1]
    else:
        hi = _refine(lp, sp, w[i1], w[i1 + 1])
    keys = d.active(k)
    radii = ", ".join(f"{SPEC_NAMES[key]} <= {v:.4g}"
                      for key in keys for v in [(d.S_terms | d.T_terms)[key][k]])
    band = (f"{_hz(lo):.6g} Hz and above (checked to {_hz(top_checked):.6g} Hz)"
            if not np.isfinite(hi) else
            f"{_hz(lo):.6g} .. {_hz(hi):.6g} Hz" if hi > lo else f"{_hz(lo):.6g} Hz")
    reason = (f"{where}, {band}: at {_hz(w[k]):.6g} Hz, |D| = {abs(d.D[k]):.4g} µm/V and"
              f" {radii} leave discs |1 - T| <= {d.r_S[k]:.4g} and |T| <= {d.r_T[k]:.4g} that"
              f" do not meet (radii sum {s[k]:.4g} < 1)")
    out.append(Infeasibility(lp.label, lp.temperature_C, lp.loop,
                             (_edge_hz(lo, sp), _edge_hz(hi, sp)), keys, _hz(w[k]),
                             float(s[k]), len(run), _hz(top_checked), reason))
    return out


CONTROL_MARGIN = 1e-6     # Mu_max must be below the least |U| by this much (relative)


def prove_control_infeasible(problem: Problem, models: list | None = None
                             ) -> tuple[ControlInfeasibility, ...]:
    """Every model loop of an unstable plant on which ``Mu_max`` lies below the least
    ``|U|`` peak of every stabilising controller (module docstring), beyond the
    certificate's tolerance ``solver.cert_tol``.

    Parameters
    ----------
    problem : Problem
        The problem (family, ``Mu_max``, sample rate).
    models : list of Plant, optional
        The models (default: the family's members, then the certificate's temperature
        sweep, as :func:`prove_infeasible`).

    Returns
    -------
    tuple of ControlInfeasibility
        Empty for stable plants, plants with a pole on the imaginary axis, or no
        ``Mu_max``; the largest least peak first.
    """
    bound = problem.specs.Mu_max
    if bound is None or not np.isfinite(bound):
        return ()
    sets = [models] if models is not None else [None]
    if models is None and problem.solver.cert_temperatures > 1:
        sets.append(problem.family.sweep(problem.solver.cert_temperatures))
    for ms in sets:
        out = []
        for lp, least in _control_floors(problem, ms):
            # beyond the certificate's tolerance: a |U| peak within it is accepted
            if not bound * (1.0 + problem.solver.cert_tol) < least * (1.0 - CONTROL_MARGIN):
                continue
            n_u = int(np.sum(np.roots(lp.plant.A).real > 0))
            where = f"model {lp.label} ({lp.temperature_C:g} °C, {lp.loop} loop)"
            poles = f"{n_u} unstable pole{'s' if n_u > 1 else ''}"
            why = (f"every controller that stabilises it has |U| >= {least:.6g} V/µm at some"
                   " frequency (1 / the least Hankel singular value of its unstable part's"
                   f" mirror image, Glover 1986), above Mu_max = {bound:g}"
                   if np.isfinite(least) else
                   "one of them is cancelled by a zero: no controller stabilises the loop")
            out.append(ControlInfeasibility(
                lp.label, lp.temperature_C, lp.loop, "Mu_max", float(bound), least, n_u,
                f"{where}: the plant has {poles}, and {why}"))
        if out:
            return tuple(sorted(out, key=lambda p: -p.least))
    return ()


def prove_infeasible(problem: Problem, models: list | None = None,
                     n: int = PROOF_POINTS) -> tuple[Infeasibility, ...]:
    """Every model loop on which the frequency-domain specs are provably infeasible.

    Parameters
    ----------
    problem : Problem
        The problem (family, specs, sample rate; integral action from ``S_fixed``).
    models : list of Plant, optional
        The models (default: the family's members, then, if none fails, the certificate's
        temperature sweep: a model anywhere in the interval must meet the specs too).
    n : int
        Log-spaced test frequencies per loop.

    Returns
    -------
    tuple of Infeasibility
        Empty when no frequency of any loop fails (which proves nothing).

    Examples
    --------
    ``Ms_max + Mt_max < 1`` fails wherever the plant responds at all:

    >>> from robrst import PlantFamily, Problem, Specs, paper_plant
    >>> pr = Problem("x", PlantFamily(models=(paper_plant().with_label("p", 28.0),)),
    ...              specs=Specs(Ms_max=0.6, Mt_max=0.3))
    >>> prove_infeasible(pr)[0].specs
    ('Mt_max',)
    """
    sp = problem.specs
    integral = integrators_of(problem) >= 1
    sets = [models] if models is not None else [None]
    if models is None and problem.solver.cert_temperatures > 1:
        sets.append(problem.family.sweep(problem.solver.cert_temperatures))
    for ms in sets:
        out = []
        for lp in loop_plants(problem, ms):
            out += _loop_proofs(lp, sp, n, integral)
        if out:
            return tuple(sorted(out, key=lambda p: p.worst_sum))
    return ()


def prove_step_infeasible(problem: Problem) -> tuple[StepInfeasibility, ...]:
    """The reference-step specs that no controller meets, by causality (module docstring).

    The sampled loop's output is 0 at the samples ``0 .. n - 1``, ``n`` the loop's dead
    samples (``delay_samples``, plus one when every model is strictly proper: the hold's
    first sample), whatever the controller; with integral action (the final value is the
    reference, not 0) they are outside the 2 % band, so the settling time, counted to the
    first sample back in the band, is at least ``n / fs``.  A ``settling_time_max_s``
    below that (beyond the certificate's tolerance ``solver.cert_tol``) is infeasible.
    The continuous loop has no dead time: nothing is proved there.

    The voltage of a reference step ``step_um`` settles at ``step_um T(0) / (R(0) D(0))``
    (integral action: ``S(0) = 0``), ``step_um / D(0)`` for robrst's controllers
    (``T(0) = R(0)``: the loop tracks the step), so its peak is at least that on every
    model; a ``step_u_max_V`` below it on the member of least ``|D(0)|`` is infeasible.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    tuple of StepInfeasibility
        Empty when nothing is proved.

    Examples
    --------
    A 20 µs settling time behind one sample of delay at 25 kHz (a dead time of 80 µs):

    >>> from dataclasses import replace
    >>> from robrst import load_problem
    >>> p = load_problem("paper_robust")
    >>> p = replace(p, specs=replace(p.specs, sample_rate_hz=25000.0, delay_samples=1,
    ...                              settling_time_max_s=2e-5))
    >>> prove_step_infeasible(p)[0].least
    8e-05
    """
    sp = problem.specs
    if integrators_of(problem) < 1:
        return ()
    models = problem.family.models
    slack = (1.0 + problem.solver.cert_tol) * (1.0 + PROOF_MARGIN)
    out = []
    ts = sp.settling_time_max_s
    if ts is not None and sp.sampled:
        proper = all(len(np.trim_zeros(np.asarray(m.B, float), "f"))
                     < len(np.asarray(m.A, float)) for m in models)
        dead = int(sp.delay_samples) + (1 if proper else 0)
        least = dead / sp.sample_rate_hz
        if ts * slack < least:
            m = models[0]
            why = (f"every model, sampled loop at {sp.sample_rate_hz:g} Hz: the output is 0 at"
                   f" the first {dead} samples (delay_samples = {sp.delay_samples}"
                   + (", plus the hold's sample of a strictly proper plant" if proper else "")
                   + ") whatever the controller, outside the 2 % band of the step the integral"
                   f" action tracks, so no loop settles before {least:.4g} s;"
                   f" settling_time_max_s = {ts:g} s")
            out.append(StepInfeasibility(m.label, m.temperature_C, "sampled",
                                         "settling_time_max_s", ts, least, dead, why))
    u_max = sp.step_u_max_V
    if u_max is not None:
        dc = [abs(float(np.polyval(m.B, 0.0) / np.polyval(m.A, 0.0))) for m in models]
        k = int(np.argmin(dc))
        if np.isfinite(dc[k]) and dc[k] > 0:
            least = sp.step_um / dc[k]
            if u_max * slack < least:
                m = models[k]
                why = (f"model {m.label} ({m.temperature_C:g} °C): a loop that tracks a"
                       f" {sp.step_um:g} µm step holds the input at step_um / |D(0)| ="
                       f" {sp.step_um:g} / {dc[k]:.4g} = {least:.4g} V in the end (|D(0)| ="
                       f" {dc[k]:.4g} µm/V, the family's least static gain), so its peak is"
                       f" at least that; step_u_max_V = {u_max:g} V")
                out.append(StepInfeasibility(m.label, m.temperature_C, "continuous",
                                             "step_u_max_V", u_max, least, 0, why))
    return tuple(out)


def prove_region_infeasible(problem: Problem) -> tuple[RegionInfeasibility, ...]:
    """A ``decay_min`` that no controller meets on a family whose creep vanishes inside its
    temperature interval (module docstring).

    The creep strength ``kappa(T)``
    (:meth:`~robrst.core.thermal.ThermalCoefficients.creep_strength`) is continuous in
    ``T``; when it is 0 somewhere in the interval and positive somewhere
    else, it takes values arbitrarily close to 0 with the creep pair present, and there
    some closed-loop root decays at nearly ``1/tau``.  A ``decay_min`` above ``1/tau``
    (beyond the certificate's tolerance ``solver.cert_tol``) is infeasible.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    tuple of RegionInfeasibility
        Empty when nothing is proved (no decay floor, an explicit family, no creep, or a
        creep strength that stays away from 0).

    Examples
    --------
    The paper's robust problem: creep from 0 at 28 °C with a 0.5 s time constant.

    >>> from dataclasses import replace
    >>> from robrst import load_problem
    >>> p = load_problem("paper_robust")
    >>> p = replace(p, specs=replace(p.specs, decay_min=3.0))
    >>> prove_region_infeasible(p)[0].limit
    2.0
    """
    sigma = problem.specs.decay_min
    c = problem.family.thermal
    if not sigma or c is None or c.creep_per_K == 0.0 or not c.creep_tau_s > 0:
        return ()
    lo, hi = problem.family.range_C
    temps = [lo, hi] + ([c.reference_C] if lo < c.reference_C < hi else [])
    kappa = {T: c.creep_strength(T) for T in temps}
    zero = [T for T, k in kappa.items() if k == 0.0]
    if not zero or max(kappa.values()) <= 0.0:
        return ()
    T0 = min(zero, key=lambda T: abs(T - c.reference_C))
    limit = 1.0 / c.creep_tau_s
    if not sigma * (1.0 - problem.solver.cert_tol) > limit * (1.0 + PROOF_MARGIN):
        return ()
    why = (f"the family's creep lag-lead (tau s + 1 + kappa)/(tau s + 1), tau = "
           f"{c.creep_tau_s:g} s, vanishes at {T0:g} °C (kappa = 0) and is present beside it"
           " in the interval: as kappa tends to 0 its pole and zero meet at -1/tau, so some"
           f" closed-loop root tends to -{limit:.4g} rad/s whatever the controller (in the"
           f" sampled loop as well); decay_min = {sigma:g} rad/s")
    return (RegionInfeasibility(f"T{T0:g}C", float(T0), "both", "decay_min", float(sigma),
                                float(limit), why),)


def feasibility_verdict(problem: Problem, cert: Certificate, controller: object = None,
                        models: list | None = None) -> FeasibilityVerdict:
    """Infeasible (with proofs) or not found (what the best design misses, what to try).

    Parameters
    ----------
    problem : Problem
        The problem.
    cert : Certificate
        The best design's certificate (its violations say what it misses).
    controller : RSTController, optional
        The best design (unused for now; kept for the suggestion of a lag or a degree).
    models : list of Plant, optional
        The models the proof is tried on (default: members, then the sweep).

    Returns
    -------
    FeasibilityVerdict
    """
    t0 = time.perf_counter()
    sp = problem.specs
    given, lost = expressed_specs(sp)
    proofs = (prove_step_infeasible(problem) + prove_region_infeasible(problem)
              + prove_control_infeasible(problem, models)
              + tuple(prove_infeasible(problem, models)))
    n_models = len(problem.family.models)
    loops = "continuous and sampled loops" if sp.sampled else "continuous loop"
    checked = (f"the discs of {', '.join(given) or 'no peak spec'} meet at every frequency"
               f" tested ({PROOF_POINTS}+ per loop, band edges and Nyquist included) on every"
               f" model ({n_models} members and the temperature sweep, {loops}); a passing"
               " grid proves nothing")
    if proofs:
        step = tuple(q.spec for q in proofs if isinstance(
            q, (StepInfeasibility, RegionInfeasibility, ControlInfeasibility)))
        return FeasibilityVerdict("infeasible", proofs=proofs, checked=checked,
                                  expressed=given + step,
                                  not_expressed=tuple(k for k in lost if k not in step),
                                  wall_time_s=time.perf_counter() - t0)
    misses, mode, suggestion = _not_found(problem, cert, lost)
    return FeasibilityVerdict("not_found", checked=checked, expressed=given,
                              not_expressed=lost, misses=misses, mode=mode,
                              suggestion=suggestion, wall_time_s=time.perf_counter() - t0)


def _not_found(problem, cert, lost):
    """``(misses, mode, suggestion)`` from the best design's certificate."""
    viol = [v for v in cert.violations]
    if not viol:
        return "", "", ""
    worst = max(viol, key=lambda v: v.ratio)
    misses = "the best controller found: " + worst.describe()
    unstable = any(v.quantity == "spectral_abscissa" for v in viol)
    region = [v for v in viol if v.kind == "below"]
    mode = ""
    tips = []
    extra = problem.controller.extra_degree
    tips.append(f"extra_degree = {extra + 1} (one more controller degree)")
    if region:
        damp = [v for v in region if v.quantity == "closed-loop damping"]
        dec = [v for v in region if v.quantity != "closed-loop damping"]
        if damp:
            v = min(damp, key=lambda v: v.value)
            at = ("" if v.freq_rad_s is None else
                  f"the mode at {v.freq_rad_s / (2 * np.pi):.4g} Hz of ")
            loop = " (sampled loop)" if v.loop == "sampled" else ""
            mode = (f"pole region: {at}model {v.label} ({v.temperature_C:g} °C){loop} stays at"
                    f" damping {v.value:.4g} < {v.bound:.4g}: the best damping found"
                    + (" (an unstable mode)" if v.value <= 0 else ""))
            if v.value > 0:
                tips.append(f"damping_min <= {v.value:.3g} (what this order reached)")
        if dec:
            v = min(dec, key=lambda v: v.value)
            mode = (mode + "; " if mode else "pole region: ") + (
                f"model {v.label} ({v.temperature_C:g} °C) keeps a pole decaying at"
                f" {v.value:.4g} < {v.bound:.4g} rad/s") + _creep_note(problem, v.value)
            if v.value > 0:
                tips.append(f"decay_min <= {v.value:.3g} rad/s")
    peak = {}
    for v in viol:
        if v.kind == "exceeds" and v.quantity in _SPEC_OF:
            key = _SPEC_OF[v.quantity]
            peak[key] = max(peak.get(key, 0.0), v.value)
    for key, val in peak.items() if not unstable else ():     # an unstable loop's peaks
        tips.append(f"{key} = {val:.4g} (what this design reaches)")   # are no spec values
    out = "try " + "; or ".join(tips[:4])
    floors = [least for _, least in _control_floors(problem)] if "Mu_max" in peak else []
    if floors:
        out += (f"; every controller that stabilises the unstable plant has |U| >="
                f" {max(floors):.4g} V/µm somewhere (Glover 1986): no Mu_max below it")
    if lost:
        out += ("; the proof cannot express " + ", ".join(lost) + ": the specs may still be"
                " infeasible through them")
    return misses, mode, out


def _control_floors(problem, models=None):
    """``(loop plant, least |U| peak of every stabilising controller)`` of each loop of
    ``models`` (default the family's members) whose plant is unstable
    (:func:`robrst.core.lti.least_control_peak`)."""
    from robrst.core.lti import least_control_peak

    for lp in loop_plants(problem, models):
        least = least_control_peak(lp.plant.B, lp.plant.A)
        if least is not None:
            yield lp, least


def _creep_note(problem, decay):
    """Where a slow closed-loop pole sits at the family's creep pair (within 10 % of its
    pole ``-1/tau``): that pair, a pole and a zero a few per cent apart that a controller
    barely moves (no proof: its strength stays away from 0; see
    :func:`prove_region_infeasible`)."""
    c = problem.family.thermal
    if c is None or not c.creep_tau_s > 0 or (c.creep_per_K == 0.0 and c.creep_at_ref == 0.0):
        return ""
    rate = 1.0 / c.creep_tau_s
    if not abs(decay - rate) <= 0.1 * rate:
        return ""
    lo, hi = problem.family.range_C
    kappa = min(c.creep_strength(T) for T in (lo, hi))
    return (f": the family's creep lag-lead, pole at -{rate:.4g} rad/s and zero at"
            f" -{(1.0 + kappa) * rate:.4g} rad/s where it is weakest (kappa = {kappa:.3g}),"
            " a pair a controller barely moves")


_SPEC_OF = {"|S| peak": "Ms_max", "|T| peak": "Mt_max", "|U| peak": "Mu_max",
            "|T| in resonance band": "T_resonance_max", "|U| above corner": "Mu_hf_max",
            "|B S/Delta| peak": "Msd_max", "|B T/Delta| peak": "Mry_max"}
