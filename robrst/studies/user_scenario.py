"""A user's scenario on the twin: steps, ramps, multisines and a temperature profile,
open loop or in closed loop with a saved design or an exported C controller.

A scenario file (TOML, every key validated by :mod:`robrst.base.schema`; errors name the
file and the key)::

    [scenario]
    name = "steps"               # default: the file stem
    duration_s = 0.3             # required
    controller = "DESIGN.json"   # closed loop: a saved design, a problem file, or ctrl.c
                                 # of robrst export --format c; none: open loop
    twin = "twin.toml"           # default: the controller's plant, every effect off
    precision = "float64"        # the controller's arithmetic (float32 | float64)
    seed = 0                     # sensor noise
    initial = 0.0                # the signal before the first event

    [[steps]]                    # the signal jumps to `to` at `at_s`
    at_s = 0.01
    to = 1.0                     # µm in closed loop (a reference), V in open loop

    [[ramps]]                    # linear from the level at from_s to `to` at to_s
    from_s = 0.1
    to_s = 0.2
    to = 0.5

    [[multisines]]               # added over [from_s, to_s): `lines` log-spaced sines,
    from_s = 0.2                 # Schroeder phases, peak `amplitude`
    amplitude = 0.05
    f_lo_hz = 10.0
    f_hi_hz = 1000.0

    [temperature]                # piecewise linear, constant outside; default: the twin's
    times_s = [0.0, 0.3]         # reference temperature
    values_C = [20.0, 40.0]

The signal is the piecewise-linear profile of the steps and ramps plus the multisines.
:func:`run_user_scenario` returns a :class:`~robrst.studies.scenarios.ScenarioResult`
(datasets, figure curves, metrics: per step its overshoot, 2 % settling time and final
error; the RMS error, the command's range), written like the paper's scenarios.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from robrst.base.errors import SpecError
from robrst.base.schema import ArrayOf, Field, key_error, load_toml, markdown_rows, validate
from robrst.data.dataset import Dataset
from robrst.studies.scenarios import ScenarioResult, divergence_notes
from robrst.twin.simulate import simulate

__all__ = ["SCENARIO_SCHEMA", "UserScenario", "load_scenario", "parse_scenario",
           "scenario_signals", "run_user_scenario", "step_metrics", "MAX_SAMPLES",
           "scenario_schema_markdown"]

MAX_SAMPLES = 10_000_000      # a run's samples: beyond, the arrays outgrow memory
TEMP = dict(lo=-60.0, hi=200.0)

SCENARIO_SCHEMA = {
    "scenario": {
        "name": Field("str", None, "scenario name (default: file stem)"),
        "description": Field("str", "", "free text"),
        "duration_s": Field("number", None, "length of the run [s]", required=True,
                            positive=True, hi=1e6),
        "controller": Field("str", None, "closed loop: a saved design (robrst design --json),"
                            " a problem file (designed) or the C of robrst export --format c"
                            " (relative to this file); none: open loop"),
        "twin": Field("str", None, "twin file (relative to this file); default: the"
                      " controller's plant with every effect off"),
        "precision": Field("str", "float64", "the controller's arithmetic",
                           choices=("float64", "float32")),
        "seed": Field("int", 0, "seed of the sensor noise", lo=0),
        "initial": Field("number", 0.0, "the signal before the first event (µm closed loop,"
                         " V open loop)"),
    },
    "steps": ArrayOf({
        "at_s": Field("number", None, "time of the step [s]", required=True, lo=0.0),
        "to": Field("number", None, "level after the step (µm closed loop, V open loop)",
                    required=True),
    }, "steps of the reference (closed loop) or of the voltage (open loop)"),
    "ramps": ArrayOf({
        "from_s": Field("number", None, "start [s]", required=True, lo=0.0),
        "to_s": Field("number", None, "end [s]", required=True, lo=0.0),
        "to": Field("number", None, "level at the end", required=True),
    }, "linear ramps from the level at from_s"),
    "multisines": ArrayOf({
        "from_s": Field("number", 0.0, "start [s]", lo=0.0),
        "to_s": Field("number", None, "end [s] (default: the end of the run)", lo=0.0),
        "amplitude": Field("number", None, "peak of the multisine", required=True,
                           positive=True),
        "f_lo_hz": Field("number", None, "lowest line [Hz]", required=True, positive=True),
        "f_hi_hz": Field("number", None, "highest line [Hz] (below Nyquist)", required=True,
                         positive=True),
        "lines": Field("int", 10, "number of sines, log-spaced", lo=1, hi=1000),
    }, "multisines added to the signal"),
    "temperature": {
        "times_s": Field("numbers", None, "breakpoints [s], increasing", lo=0.0),
        "values_C": Field("numbers", None, "temperature at each breakpoint [°C]", **TEMP),
    },
}


def scenario_schema_markdown() -> list:
    """The scenario-file reference as Markdown table rows.

    Returns
    -------
    list of str
    """
    return markdown_rows(SCENARIO_SCHEMA)


@dataclass(frozen=True)
class UserScenario:
    """A validated scenario file (see the module docstring).

    Attributes
    ----------
    name : str
    duration_s : float
    controller, twin : str or None
        As the file names them (:meth:`resolve` gives the paths).
    precision : str
    seed : int
    initial : float
    steps : tuple of (at_s, to)
    ramps : tuple of (from_s, to_s, to)
    multisines : tuple of (from_s, to_s, amplitude, f_lo_hz, f_hi_hz, lines)
    temperature : tuple or None
        ``(times_s, values_C)``.
    description : str
    path : str
        The scenario file.
    """

    name: str
    duration_s: float
    controller: str = None
    twin: str = None
    precision: str = "float64"
    seed: int = 0
    initial: float = 0.0
    steps: tuple = ()
    ramps: tuple = ()
    multisines: tuple = ()
    temperature: tuple = None       # ((times...), (values...)) or None
    description: str = ""
    path: str = "<scenario>"

    @property
    def closed_loop(self):
        """True when the scenario names a controller."""
        return self.controller is not None

    def resolve(self, name: str | None) -> Path | None:
        """A path of this scenario (``controller``, ``twin``) relative to its file.

        Parameters
        ----------
        name : str or None

        Returns
        -------
        Path or None
        """
        if name is None:
            return None
        p = Path(name)
        if p.is_absolute() or str(self.path).startswith("<"):
            return p
        near = Path(self.path).parent / p
        return near if near.exists() or not p.exists() else p


def parse_scenario(data: dict, path: str = "<scenario>") -> UserScenario:
    """Validate a parsed scenario document; see :func:`load_scenario`.

    Parameters
    ----------
    data : dict
        The parsed TOML.
    path : str
        Named in every error.

    Returns
    -------
    UserScenario

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    v = validate(path, data, SCENARIO_SCHEMA)
    sc = v["scenario"]
    if sc is None:
        raise key_error(path, ("scenario",), "missing required table [scenario]")
    dur = sc["duration_s"]
    steps = tuple(sorted(((s["at_s"], s["to"]) for s in v["steps"] or ()), key=lambda s: s[0]))
    ramps = tuple(sorted(((r["from_s"], r["to_s"], r["to"]) for r in v["ramps"] or ()),
                         key=lambda r: r[0]))
    for i, s in enumerate(v["steps"] or ()):
        if s["at_s"] > dur:
            raise key_error(path, ("steps", str(i), "at_s"), f"{s['at_s']:g} s is after the end"
                            f" of the run (duration_s = {dur:g})")
    for i, r in enumerate(v["ramps"] or ()):
        if not r["from_s"] < r["to_s"] <= dur:
            raise key_error(path, ("ramps", str(i)), f"expected from_s < to_s <= duration_s"
                            f" ({dur:g}), got [{r['from_s']:g}, {r['to_s']:g}]")
    events = sorted([(a, a) for a, _ in steps] + [(a, b) for a, b, _ in ramps])
    for (a0, b0), (a1, b1) in zip(events[:-1], events[1:]):
        if a1 < b0 or (a1 == a0 and b1 == b0):
            raise key_error(path, ("ramps",) if b0 > a0 or b1 > a1 else ("steps",),
                            f"events overlap at {a1:g} s (a step inside a ramp, two ramps at"
                            " once or two steps at the same time)")
    ms = []
    for i, m in enumerate(v["multisines"] or ()):
        to = dur if m["to_s"] is None else m["to_s"]
        if not m["from_s"] < to <= dur:
            raise key_error(path, ("multisines", str(i)), f"expected from_s < to_s <= duration_s"
                            f" ({dur:g}), got [{m['from_s']:g}, {to:g}]")
        if not m["f_lo_hz"] <= m["f_hi_hz"]:
            raise key_error(path, ("multisines", str(i), "f_hi_hz"), "must be >= f_lo_hz")
        ms.append((m["from_s"], to, m["amplitude"], m["f_lo_hz"], m["f_hi_hz"], m["lines"]))
    temp = None
    t = v["temperature"]
    if t is not None:
        if t["times_s"] is None or t["values_C"] is None:
            raise key_error(path, ("temperature",), "give times_s and values_C together")
        if not t["times_s"] or len(t["times_s"]) != len(t["values_C"]):
            raise key_error(path, ("temperature", "values_C"), "expected one value per"
                            f" breakpoint of times_s ({len(t['times_s'])})")
        if np.any(np.diff(t["times_s"]) <= 0):
            raise key_error(path, ("temperature", "times_s"), "expected increasing times")
        temp = (tuple(t["times_s"]), tuple(t["values_C"]))
    return UserScenario(name=sc["name"] or Path(str(path)).stem, duration_s=dur,
                        controller=sc["controller"], twin=sc["twin"],
                        precision=sc["precision"], seed=sc["seed"], initial=sc["initial"],
                        steps=steps, ramps=ramps, multisines=tuple(ms), temperature=temp,
                        description=sc["description"], path=str(path))


def load_scenario(path: str | os.PathLike) -> UserScenario:
    """Read and validate a scenario file (errors name the file and the key).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    UserScenario
    """
    return parse_scenario(load_toml(path, "scenario file"), str(path))


def _multisine(t, t0, t1, amp, f_lo, f_hi, lines):
    f = np.geomspace(f_lo, f_hi, lines)
    k = np.arange(1, lines + 1)
    phase = -np.pi * k * (k - 1) / lines                       # Schroeder: low crest factor
    on = (t >= t0) & (t < t1)
    tau = t[on] - t0
    x = np.sum(np.sin(2 * np.pi * f[:, None] * tau[None, :] + phase[:, None]), axis=0)
    out = np.zeros_like(t)
    peak = np.max(np.abs(x)) if x.size else 0.0
    out[on] = amp * x / peak if peak > 0 else 0.0
    return out


def scenario_signals(sc: UserScenario, sample_rate_hz: float, reference_C: float) -> tuple:
    """``(t, signal, temperature)`` of ``sc`` sampled at ``sample_rate_hz``.

    Parameters
    ----------
    sc : UserScenario
    sample_rate_hz : float
    reference_C : float
        The temperature of a scenario that states none.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray)

    Raises
    ------
    SpecError
        Too many samples (:data:`MAX_SAMPLES`), or a multisine line beyond Nyquist (naming
        the key).
    """
    fs = float(sample_rate_hz)
    n = int(np.floor(sc.duration_s * fs + 1e-9)) + 1
    if n > MAX_SAMPLES:
        raise key_error(sc.path, ("scenario", "duration_s"), f"{n} samples at {fs:g} Hz;"
                        f" at most {MAX_SAMPLES} (shorten the run)")
    t = np.arange(n) / fs
    level = np.full(n, float(sc.initial))
    events = sorted([(a, a, to) for a, to in sc.steps] + list(sc.ramps))
    current = float(sc.initial)
    for a, b, to in events:
        if b == a:
            level[t >= a] = to
        else:
            ramp = (t >= a) & (t < b)
            level[ramp] = current + (to - current) * (t[ramp] - a) / (b - a)
            level[t >= b] = to
        current = to
    for i, (t0, t1, amp, f_lo, f_hi, lines) in enumerate(sc.multisines):
        if f_hi >= fs / 2:
            raise key_error(sc.path, ("multisines", str(i), "f_hi_hz"), f"{f_hi:g} Hz is not"
                            f" below Nyquist ({fs / 2:g} Hz at {fs:g} Hz)")
        level = level + _multisine(t, t0, t1, amp, f_lo, f_hi, lines)
    if sc.temperature is None:
        temp = np.full(n, float(reference_C))
    else:
        temp = np.interp(t, *sc.temperature)
    return t, level, temp


def step_metrics(t: np.ndarray, y: np.ndarray, yr: np.ndarray, steps: tuple,
                 events: tuple = (), band: float = 0.02) -> list:
    """Per reference step: overshoot, settling time and final error.

    Parameters
    ----------
    t, y, yr : numpy.ndarray
        Time [s], output and reference [µm].
    steps : tuple of (at_s, to)
    events : tuple of float
        Other events' start times: a step's segment ends at the next event.
    band : float
        The settling band, relative to the step's size.

    Returns
    -------
    list of dict
        ``at_s, to, overshoot_pct`` (of the step's size), ``settling_time_s`` (``None``:
        not settled in its segment), ``final_error`` [µm].
    """
    out = []
    starts = sorted({a for a, _ in steps} | {float(e) for e in events})
    for a, to in steps:
        nxt = next((e for e in starts if e > a), t[-1] + 1.0)
        seg = (t >= a) & (t < nxt)
        if not np.any(seg):
            continue
        i0 = np.flatnonzero(t < a)
        before = float(yr[i0[-1]]) if i0.size else float(yr[0])
        size = to - before
        ys, ts = y[seg], t[seg]
        if size == 0:
            continue
        over = float(max(0.0, np.max((ys - to) * np.sign(size))) / abs(size) * 100.0)
        outside = np.flatnonzero(np.abs(ys - to) > band * abs(size))
        settle = None if outside.size and outside[-1] == ys.size - 1 else (
            0.0 if not outside.size else float(ts[outside[-1] + 1] - a))
        out.append({"at_s": float(a), "to": float(to), "overshoot_pct": over,
                    "settling_time_s": settle, "final_error": float(ys[-1] - to)})
    return out


def run_user_scenario(sc: UserScenario, twin: object, controller: object = None,
                      progress: object = None) -> ScenarioResult:
    """Run a user scenario on ``twin``.

    Parameters
    ----------
    sc : UserScenario
    twin : TwinConfig
        At the controller's sampling rate for a closed loop.
    controller : LoopController, optional
        The closed loop's controller (:mod:`robrst.studies.closedloop`); required when
        ``sc.controller`` names one.
    progress : callable, optional

    Returns
    -------
    ScenarioResult

    Raises
    ------
    SpecError
        A closed-loop scenario without its controller.
    """
    from robrst.studies.closedloop import run_closed_loop

    say = progress or (lambda m: None)
    t, sig, temp = scenario_signals(sc, twin.sample_rate_hz, twin.reference_C)
    if sc.closed_loop:
        if controller is None:
            raise SpecError(f"{sc.path}: [scenario.controller] names a controller; none given")
        say(f"closed loop: {controller.source} ({sc.precision}) on twin {twin.name}"
            f" ({twin.sample_rate_hz:g} Hz), {t.size} samples")
        r = run_closed_loop(twin, controller, sig, temp, sc.precision, sc.seed)
    else:
        say(f"open loop on twin {twin.name} ({twin.sample_rate_hz:g} Hz), {t.size} samples")
        r = simulate(twin, temp, u=sig, seed=sc.seed)
    metrics = {"samples": int(t.size), "sample_rate_hz": float(twin.sample_rate_hz),
               "closed_loop": sc.closed_loop, "effects_on": r.meta["effects_on"],
               "compiled": r.meta["compiled"],
               "u_range_V": [float(np.min(r.u_applied)), float(np.max(r.u_applied))],
               "y_range_um": [float(np.min(r.y_true)), float(np.max(r.y_true))]}
    curves = {}
    dec = max(1, t.size // 20000)
    if sc.closed_loop:
        err = r.y_true - sig
        metrics.update(precision=sc.precision, controller=r.meta["controller"],
                       rms_error_um=float(np.sqrt(np.mean(err ** 2))),
                       max_abs_error_um=float(np.max(np.abs(err))),
                       steps=step_metrics(t, r.y_true, sig, sc.steps,
                                          [r_[0] for r_ in sc.ramps]
                                          + [m[0] for m in sc.multisines]))
        curves["reference"] = (t[::dec], sig[::dec], "time [s]", "displacement [µm]")
    curves["twin output"] = (t[::dec], r.y_true[::dec], "time [s]",
                             "displacement [µm]")
    ds = Dataset(t=r.t, u=r.u_cmd, y=r.y, temp=r.temp, yr=r.yr,
                 comments=(f"robrst simulate {sc.name}: {sc.description or 'user scenario'}",),
                 source="twin")
    claim = (f"{'closed loop' if sc.closed_loop else 'open loop'} on twin {twin.name}"
             + (f" with {r.meta['controller']} ({sc.precision})" if sc.closed_loop else ""))
    return ScenarioResult(sc.name, claim, metrics, {sc.name: ds}, curves,
                          notes=divergence_notes({sc.name: ds}))
