"""Harder withheld-effect cases for the gap diagnosis, each with its expected answer.

Every case is built from one seed: records whose truth the diagnosis is not told, the
model handed to it, and the answer stated *before* running it:

``accept``
    the verdicts that are right (``cause`` of the diagnosis);
``must_name``
    effects the answer must list (``extra["causes"]``; several effects at once);
``finding``
    a finding kind that must be present (e.g. ``unmodelled_dynamics``).

Kinds of case: several effects at once, closed-loop records, a slightly wrong linear
model (gain -8 %, resonance +3 %) with and without an effect, other sampling rates,
short and noisy records, and effects outside the library (dead zone, backlash,
rate-dependent hysteresis, sensor-side drift, a second resonance).  Out-of-library
cases accept ``cannot_tell`` (with a partial explanation) or the library effect that
is the same mechanism (backlash is a hysteresis); never ``none`` or ``linear``.

The records are made by the twin (sensor noise and quantisation always on) or, for
the out-of-library operators, by the twin with no effect driven by the operator's
output, so the noise is the twin's; the diagnosis sees the commanded ``u``.
"""

from dataclasses import dataclass, replace

import numpy as np
from scipy import signal

from robrst.diagnose.validation import excitation
from robrst.core.plant import Plant, paper_plant
from robrst.twin.config import default_twin
from robrst.twin.simulate import simulate


@dataclass(frozen=True)
class Case:
    name: str
    accept: tuple
    must_name: tuple = ()
    finding: str = ""
    band_hz: float = None       # a frequency the finding's band must contain
    note: str = ""


CASES = {c.name: c for c in (
    Case("hysteresis+creep", ("hysteresis", "creep"), ("hysteresis", "creep"),
         note="both effects on; each fitted alone absorbs part of the other"),
    Case("creep+thermal_drift", ("creep", "thermal_drift"), ("creep", "thermal_drift"),
         note="temperature ramps; drift lag 3 s, creep growing with temperature"),
    Case("closed_loop_hysteresis", ("hysteresis",),
         note="records from the RST loop (u is the controller's output)"),
    Case("mismatch_hysteresis", ("hysteresis",), ("hysteresis",),
         note="user's model: gain -8 %, resonance +3 %"),
    Case("mismatch_creep", ("creep",), ("creep",), note="user's model: gain -8 %, resonance +3 %"),
    Case("mismatch_only", ("linear",), note="no effect: only the linear model is wrong"),
    Case("small_to_large_hysteresis", ("hysteresis",),
         note="trained on 0-40 V, tested on 0-150 V: the loop widens with amplitude"),
    Case("hysteresis_2kHz", ("hysteresis",), note="sampled at 2 kHz"),
    Case("creep_20kHz", ("creep",), note="sampled at 20 kHz"),
    Case("short_hysteresis", ("hysteresis",), note="records of 0.6 s"),
    Case("noisy_creep", ("creep",), note="sensor noise 60 nm (3-12x the usual)"),
    Case("dead_zone", ("cannot_tell",), note="bipolar drive, dead zone of +-8 V: not in the"
         " library"),
    Case("backlash", ("hysteresis", "cannot_tell"), note="play operator of 10 V width: a"
         " hysteresis"),
    Case("rate_dependent_hysteresis", ("hysteresis", "cannot_tell"),
         note="loop width growing with the input rate (Bouc-Wen on a lagged input)"),
    Case("sensor_drift", ("cannot_tell",),
         note="slow drift added at the sensor, unrelated to u and temperature"),
    Case("second_resonance", ("linear", "cannot_tell"), finding="unmodelled_dynamics",
         band_hz=1400.0, note="an extra mode at 1.4 kHz (the model has one at 616 Hz): the"
         " linear model is wrong, and the finding must name the band of the missing mode"),
)}


def mismatched_model():
    """The paper's D(s) with gain -8 % and resonance +3 % (the model handed over)."""
    p = paper_plant()
    roots = np.roots(p.A)
    k = np.abs(roots) > 2 * np.pi * 300
    roots[k] *= 1.03
    A = np.real(np.poly(roots))
    gain = 0.92 * (p.B[-1] / p.A[-1]) / (p.B[-1] / A[-1])
    return Plant(np.asarray(p.B) * gain, A)


def _twin(effects, fs, sigma, **over):
    over = {**over, "noise": {"sigma_um": sigma}}
    return replace(default_twin().with_effects(only=["noise", "quantization", *effects], **over),
                   sample_rate_hz=float(fs))


def _play(u, width):
    out, y = np.empty_like(u), u[0]
    for i, v in enumerate(u):
        y = min(max(y, v - width / 2), v + width / 2)
        out[i] = y
    return out


def _bouc_wen(u, A=0.45, B=0.0045, G=0.0045):
    z, out = 0.0, np.empty_like(u)
    du = np.diff(u, prepend=u[0])
    for i, d in enumerate(du):
        z += A * d - B * abs(d) * z - G * d * abs(z)
        out[i] = z
    return out


def _operator(name, u, fs):
    if name == "dead_zone":
        return np.sign(u) * np.maximum(np.abs(u) - 8.0, 0.0)
    if name == "backlash":
        return _play(u, 10.0)
    if name == "rate_dependent_hysteresis":
        a = np.exp(-1.0 / (fs * 2e-3))                 # 2 ms lag: loops widen with rate
        ul = signal.lfilter([1 - a], [1, -a], u, zi=[a * u[0]])[0]
        return u - _bouc_wen(ul)
    return u


def make(name, seed=0, fs=5000.0, duration_s=6.0):
    """``(train, test, model, case)`` of hard case ``name`` (see the module doc)."""
    case = CASES[name]
    rng = np.random.default_rng(seed)
    fs = {"hysteresis_2kHz": 2000.0, "creep_20kHz": 20000.0}.get(name, fs)
    duration_s = 0.6 if name == "short_hysteresis" else duration_s
    sigma = 0.06 if name == "noisy_creep" else float(rng.uniform(0.005, 0.015))
    effects, over = [], {}
    if "hysteresis" in name and name != "rate_dependent_hysteresis":
        effects.append("hysteresis")
    if "creep" in name:
        effects.append("creep")
        over["creep"] = {"per_decade": 0.02, "per_K": 0.05}
    if "thermal_drift" in name:
        effects.append("thermal_drift")
        over["thermal_drift"] = {"lag_s": 3.0, "gain_V_per_K": 0.9, "B": 0.1}
    cfg = _twin(effects, fs, sigma, **over)
    n = int(duration_s * fs)
    t = np.arange(n) / fs
    ramps = name == "creep+thermal_drift"
    bipolar = name == "dead_zone"
    kinds = ["steps", "multisine", "triangle", "steps"] if duration_s > 1 else ["multisine"] * 4
    dctrl = _controller(fs) if name.startswith("closed_loop") else None
    records = []
    for i, kind in enumerate(kinds):
        lo, hi = float(rng.uniform(0, 15)), float(rng.uniform(100, 150))
        if name == "small_to_large_hysteresis" and i < 2:
            hi = lo + 40.0
        if bipolar:
            lo, hi = -hi / 2, hi / 2
        u = excitation(kind, n, fs, lo, hi, rng)
        if ramps:
            a, b = (30.0, 44.0) if i % 2 == 0 else (43.0, 29.0)
            temp = a + (b - a) * np.clip(t / (0.7 * t[-1]), 0, 1)
        else:
            temp = np.full(n, float(rng.uniform(28, 40)))
        s = int(rng.integers(2 ** 31))
        if dctrl is not None:
            yr = np.interp(u, [lo, hi], [5.0, 60.0])      # a reference of 5-60 µm
            r = simulate(cfg, temp, yr=yr, dctrl=dctrl, seed=s)
            d = r.to_dataset()
        else:
            r = simulate(cfg, temp, u=_operator(name, u, fs), seed=s)
            d = replace(r.to_dataset(), u=u)
        if name == "sensor_drift":
            w = rng.uniform(0.05, 0.15)
            d = replace(d, y=d.y + 0.4 * np.sin(2 * np.pi * w * t + rng.uniform(0, 6.3))
                        + 0.3 * t / t[-1])
        if name == "second_resonance":
            d = replace(d, y=d.y + _second_mode(u, fs))
        records.append(replace(d, source=f"{name}-{seed}-{'train' if i < 2 else 'test'}{i % 2}"))
    model = mismatched_model() if name.startswith("mismatch") else paper_plant()
    return records[:2], records[2:], model, case


def _second_mode(u, fs, f0=1400.0, zeta=0.02, share=0.15):
    """Output of an extra lightly damped mode, ``share`` of D(0) static gain, exact ZOH."""
    w = 2 * np.pi * f0
    p = paper_plant()
    k = share * p.B[-1] / p.A[-1]
    sysd = signal.cont2discrete(([k * w * w], [1, 2 * zeta * w, w * w]), 1 / fs, method="zoh")
    return signal.lfilter(np.ravel(sysd[0]), sysd[1], u - u[0]) + k * u[0]


def _controller(fs):
    from robrst.design import analytic_design
    from robrst.core.rst import discretize
    from robrst.problem.files import load_problem

    return discretize(analytic_design(load_problem("paper")).controller, fs)
