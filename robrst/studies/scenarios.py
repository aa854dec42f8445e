"""The paper's experiments on the twin (Fig. 2, 3, 4/5, 7, 8): datasets, figures, numbers.

Each scenario returns a :class:`ScenarioResult` whose ``metrics`` turn the paper's
qualitative claim into numbers, with its datasets (the project's data format,
decimated for the slow thermal experiments) and the curves of its figure
(:func:`robrst.report.scenario.write_scenario` writes both).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.data.dataset import Dataset
from robrst.design import analytic_design, run_problem
from robrst.base.errors import SpecError
from robrst.core.rst import discretize
from robrst.problem.files import load_problem
from robrst.twin.config import run_samples
from robrst.twin.model import build_model
from robrst.twin.simulate import Simulator, simulate

if TYPE_CHECKING:
    from robrst.core.rst import RSTController
    from robrst.twin.config import TwinConfig

__all__ = ["SCENARIOS", "ScenarioResult", "run_scenario", "controllers", "twin_step_responses",
           "loop_width", "divergence_notes", "DIVERGED_UM"]


@dataclass(frozen=True, eq=False)
class ScenarioResult:
    """One experiment of the paper on the twin: its claim, numbers and data.

    Parameters
    ----------
    name : str
        The scenario (``"fig2"``, ...).
    claim : str
        What the paper claims, in one sentence.
    metrics : dict
        The numbers that test the claim.
    datasets : dict
        Name -> :class:`~robrst.data.dataset.Dataset` of the simulated records.
    curves : dict
        Name -> ``(x, y, xlabel, ylabel)`` for the figure.
    notes : tuple of str
        What the numbers do not say by themselves (an output that diverges:
        :func:`divergence_notes`).
    """

    name: str
    claim: str
    metrics: dict
    datasets: dict = field(default_factory=dict)   # name -> Dataset
    curves: dict = field(default_factory=dict)     # name -> (x, y, xlabel, ylabel) for the figure
    notes: tuple = ()


DIVERGED_UM = 1e6     # an output beyond a metre is no stage's: the simulation diverged


def divergence_notes(datasets: dict) -> tuple[str, ...]:
    """One line per dataset whose output diverges: not finite, or beyond ``DIVERGED_UM``.

    Parameters
    ----------
    datasets : dict
        Name -> :class:`~robrst.data.dataset.Dataset`.

    Returns
    -------
    tuple of str
        When it leaves the range and why it may (an unstable open loop, a closed loop that
        is not stable); empty when every output stays finite and in range.
    """
    out = []
    for name, d in datasets.items():
        y = np.asarray(d.y, float).reshape(len(d.t), -1)
        with np.errstate(invalid="ignore"):
            bad = ~(np.abs(y) <= DIVERGED_UM).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            out.append(f"{name}: the output diverges (|y| beyond {DIVERGED_UM:g} µm, or not"
                       f" finite, from t = {float(d.t[i]):.4g} s on): the twin's plant is"
                       " unstable in open loop, or the closed loop is not stable; the metrics"
                       " that need it are not numbers and the figure draws the finite part")
    return tuple(out)


def _ds(r, step=1, label=""):
    s = slice(None, None, step)
    return Dataset(t=r.t[s], u=r.u_cmd[s], y=r.y[s], temp=r.temp[s],
                   yr=None if r.yr is None else r.yr[s], comments=(label,), source="twin")


def _temp_profile(cfg, up_s, hold_s, down_s, T0=28.0, T1=45.0, T2=28.0):
    run_samples(cfg, up_s + hold_s + down_s, "the temperature profile")
    fs = cfg.sample_rate_hz
    n = [int(round(x * fs)) for x in (up_s, hold_s, down_s)]
    return np.concatenate([np.linspace(T0, T1, n[0]), np.full(n[1], T1), np.linspace(T1, T2, n[2])])


def fig2(cfg, ctrls, fast=False):
    fs = cfg.sample_rate_hz
    T = _temp_profile(cfg, *((30, 10, 30) if fast else (240, 60, 240)))
    metrics, ds, curves = {}, {}, {}
    sim = Simulator(build_model(cfg))
    dec = max(1, int(fs / 100))
    for V in (0.0, 50.0, 100.0):
        r = simulate(cfg, T, u=np.full(T.size, V), simulator=sim)
        y0 = np.mean(r.y_true[: int(fs * 0.5)])
        drift = r.y_true - y0
        n_up = int(np.argmax(T))
        q = max(1, n_up // 5)
        with np.errstate(invalid="ignore", over="ignore"):    # a diverging output: nan
            early = (drift[q] - drift[0]) / (T[q] - T[0])
            late = (drift[n_up] - drift[n_up - q]) / (T[n_up] - T[n_up - q])
        # hysteresis vs temperature: drift gap between heating and cooling at mid temperature
        Tm = 0.5 * (T.min() + T.max())
        i_up = int(np.argmin(np.abs(T[:n_up] - Tm)))
        i_dn = n_up + int(np.argmin(np.abs(T[n_up:] - Tm)))
        with np.errstate(invalid="ignore", over="ignore"):
            metrics[f"{V:g}V"] = {"drift_at_max_um": float(drift[n_up]),
                                  "slope_ratio_late_early": float(late / early) if early else None,
                                  "hysteresis_gap_um": float(drift[i_dn] - drift[i_up])}
        ds[f"fig2_{V:g}V"] = _ds(r, dec, f"Fig. 2: temperature ramp at {V:g} V")
        curves[f"{V:g} V"] = (r.temp[::dec], drift[::dec], "temperature [°C]", "drift [µm]")
    return ScenarioResult("fig2", "temperature drifts the output until saturation, with"
                          " hysteresis versus temperature", metrics, ds, curves)


def loop_width(u: np.ndarray, y: np.ndarray) -> float:
    """Max vertical gap between the two branches of a y(u) loop, relative to the stroke.

    Parameters
    ----------
    u : numpy.ndarray
        The input over one cycle (up, then down).
    y : numpy.ndarray
        The output.

    Returns
    -------
    float
        The loop width as a fraction of ``ptp(y)``.
    """
    grid = np.linspace(np.min(u) + 0.05 * np.ptp(u), np.max(u) - 0.05 * np.ptp(u), 50)
    du = np.gradient(u)
    up, dn = du > 0, du < 0
    yu = np.interp(grid, u[up][np.argsort(u[up])], y[up][np.argsort(u[up])])
    yd = np.interp(grid, u[dn][np.argsort(u[dn])], y[dn][np.argsort(u[dn])])
    return float(np.max(np.abs(yd - yu)) / np.ptp(y))


def fig3(cfg, ctrls, fast=False):
    fs = cfg.sample_rate_hz
    metrics, ds, curves = {"loop_width": {}, "creep": {}}, {}, {}
    sim = Simulator(build_model(cfg))
    for T in (28.0, 45.0):
        for f in (0.1, 1.0, 10.0, 50.0):
            n_per = int(round(fs / f))
            cycles = 2
            n = n_per * cycles
            t = np.arange(n) / fs
            u = 75.0 - 75.0 * np.cos(2 * np.pi * f * t)
            r = simulate(cfg, np.full(n, T), u=u, simulator=sim)
            last = slice(n_per, n)
            w = loop_width(r.u_applied[last], r.y_true[last])
            metrics["loop_width"][f"{T:g}C_{f:g}Hz"] = w
            dec = max(1, n_per // 2000)
            ds[f"fig3_loop_{T:g}C_{f:g}Hz"] = _ds(r, dec, f"Fig. 3a: loop {f:g} Hz at {T:g} °C")
            curves[f"{f:g} Hz, {T:g} °C"] = (r.u_applied[last][::dec], r.y_true[last][::dec],
                                            "voltage [V]", "displacement [µm]")
        dur = 20.0 if fast else 100.0
        n = run_samples(cfg, dur, "the creep run")
        r = simulate(cfg, np.full(n, T), u=np.full(n, 100.0), simulator=sim)
        i1 = int(1.0 * fs)
        metrics["creep"][f"{T:g}C"] = float((r.y_true[-1] - r.y_true[i1]) / r.y_true[i1])
        ds[f"fig3_creep_{T:g}C"] = _ds(r, int(fs / 200), f"Fig. 3b: creep after 100 V at {T:g} °C")
    lw = metrics["loop_width"]
    metrics["width_change_between_temperatures"] = max(
        abs(lw[f"45C_{f:g}Hz"] / lw[f"28C_{f:g}Hz"] - 1) for f in (0.1, 1.0, 10.0, 50.0))
    metrics["creep_growth_45_vs_28"] = metrics["creep"]["45C"] / metrics["creep"]["28C"] - 1
    return ScenarioResult("fig3", "hysteresis barely changes with temperature; creep grows",
                          metrics, ds, curves)


def _harmonic(cfg, sim, freqs, T, amp, offset, closed=False, dctrl=None):
    fs, out = cfg.sample_rate_hz, []
    for f in freqs:
        n_per = max(int(round(fs / f)), 20)
        n = n_per * max(4, int(np.ceil(0.05 * f)) + 3)
        t = np.arange(n) / fs
        s = offset + amp * np.sin(2 * np.pi * f * t)
        kw = {"yr": s, "dctrl": dctrl} if closed else {"u": s}
        r = simulate(cfg, np.full(n, T), simulator=sim, **kw)
        last = slice(n - 2 * n_per, n)
        X = np.column_stack([np.sin(2 * np.pi * f * t[last]), np.cos(2 * np.pi * f * t[last]),
                             np.ones(2 * n_per)])
        c = np.linalg.lstsq(X, r.y_true[last], rcond=None)[0]
        out.append(np.hypot(c[0], c[1]) / amp)
    return np.array(out)


def fig45(cfg, ctrls, fast=False):
    fs = cfg.sample_rate_hz
    D = cfg.linear_plant
    n = int(0.06 * fs)
    t = np.arange(n) / fs
    metrics, ds, curves = {}, {}, {}
    freqs = np.geomspace(50, 1500, 8 if fast else 16)
    lin = cfg.with_effects(off=("noise", "quantization"))
    steps = {}
    sim = Simulator(build_model(lin))
    for T in (28.0, 45.0):
        u = np.where(t >= 0.005, 10.0, 0.0)
        r = simulate(lin, np.full(n, T), u=u, simulator=sim)
        steps[T] = r.y_true
        ds[f"fig4_step_{T:g}C"] = _ds(r, 1, f"Fig. 4a: 10 V step at {T:g} °C")
        curves[f"step {T:g} °C"] = (t, r.y_true, "time [s]", "displacement [µm]")
        mag = _harmonic(lin, sim, freqs, T, 5.0, 75.0)
        metrics[f"harmonic_{T:g}C"] = dict(zip([f"{f:.4g}" for f in freqs], mag.tolist()))
    import control   # python-control: independent reference response of D(s)

    ymod = control.forced_response(control.tf(D.B, D.A), t, np.where(t >= 0.005, 10.0, 0.0)).outputs
    final = ymod[-1]
    metrics["step_difference_between_temperatures"] = float(np.max(np.abs(steps[45.0] - steps[28.0])) / final)
    metrics["model_vs_twin_nrmse_28C"] = float(np.sqrt(np.mean((steps[28.0] - ymod) ** 2)) / np.ptp(ymod))
    metrics["overshoot_28C"] = float(np.max(steps[28.0]) / steps[28.0][-1] - 1)
    curves["identified D(s)"] = (t, ymod, "time [s]", "displacement [µm]")
    return ScenarioResult("fig45", "temperature barely changes the fast dynamics; D(s) matches",
                          metrics, ds, curves)


def controllers() -> dict[str, RSTController]:
    """The analytic (built-in ``paper``) and robust (``paper_robust``) controllers, by name.

    Returns
    -------
    dict
        ``{"analytic": RSTController, "robust": RSTController}``.
    """
    a = analytic_design(load_problem("paper")).controller
    r = run_problem(load_problem("paper_robust")).controller
    return {"analytic": a, "robust": r}


def fig7(cfg, ctrls, fast=False):
    fs = cfg.sample_rate_hz
    T = np.concatenate([np.full(int(0.5 * fs), 28.0),
                        _temp_profile(cfg, *((20, 5, 20) if fast else (120, 30, 120)),
                                      T2=30.0)])
    yr = np.full(T.size, 20.0)
    metrics, ds, curves = {}, {}, {}
    dec = int(fs / 200)
    for name, c in ctrls.items():
        r = simulate(cfg, T, yr=yr, dctrl=discretize(c, fs))
        after = slice(int(0.2 * fs), None)
        metrics[name] = {"max_deviation_um": float(np.max(np.abs(r.y_true[after] - 20.0)))}
        ds[f"fig7_{name}"] = _ds(r, dec, f"Fig. 7: closed loop ({name}), 20 µm, 28->45->30 °C")
        curves[name] = (r.t[::dec], r.y_true[::dec], "time [s]", "displacement [µm]")
    u0 = 20.0 / 0.668
    r = simulate(cfg, T, u=np.full(T.size, u0))
    metrics["open_loop_drift_um"] = float(np.max(np.abs(r.y_true[int(0.2 * fs):] - r.y_true[int(0.2 * fs)])))
    curves["open loop"] = (r.t[::dec], r.y_true[::dec], "time [s]", "displacement [µm]")
    return ScenarioResult("fig7", "closed loop holds 20 µm through 28->45->30 °C", metrics, ds, curves)


def fig8(cfg, ctrls, fast=False):
    fs = cfg.sample_rate_hz
    n = int(0.05 * fs)
    t = np.arange(n) / fs
    yr = np.where(t >= 0.005, 10.0, 0.0)
    metrics, ds, curves = {}, {}, {}
    freqs = np.geomspace(100, 1500, 6 if fast else 12)
    for name, c in ctrls.items():
        dc = discretize(c, fs)
        sim = Simulator(build_model(cfg), dc)
        for T in (28.0, 45.0):
            r = simulate(cfg, np.full(n, T), yr=yr, dctrl=dc, simulator=sim)
            tail = r.y_true[-int(0.005 * fs):]
            m = {"overshoot": float(np.max(r.y_true) / 10.0 - 1),
                 "static_error_um": float(abs(np.mean(tail) - 10.0)),
                 "max_T_gain_100_1500Hz": float(np.max(_harmonic(cfg, sim, freqs, T, 1.0, 10.0, True, dc)))}
            metrics[f"{name}_{T:g}C"] = m
            ds[f"fig8_{name}_{T:g}C"] = _ds(r, 1, f"Fig. 8: 10 µm step ({name}) at {T:g} °C")
            curves[f"{name} {T:g} °C"] = (t, r.y_true, "time [s]", "displacement [µm]")
    return ScenarioResult("fig8", "oscillation removed, static error ~ 0, at both temperatures",
                          metrics, ds, curves)


SCENARIOS = {"fig2": fig2, "fig3": fig3, "fig45": fig45, "fig7": fig7, "fig8": fig8}


def run_scenario(name: str, cfg: TwinConfig, fast: bool = False,
                 ctrls: dict[str, RSTController] | None = None) -> ScenarioResult:
    """Run one of the paper's experiments on the twin ``cfg``.

    Parameters
    ----------
    name : {"fig2", "fig3", "fig45", "fig7", "fig8"}
        The experiment.
    cfg : TwinConfig
        The twin.
    fast : bool
        Shorter thermal ramps and sweeps.
    ctrls : dict, optional
        Controllers by name for the closed-loop scenarios (default :func:`controllers`).

    Returns
    -------
    ScenarioResult

    Raises
    ------
    SpecError
        For an unknown scenario name.
    """
    if name not in SCENARIOS:
        raise SpecError(f"unknown scenario {name!r}; expected one of {', '.join(SCENARIOS)}")
    needs = name in ("fig7", "fig8")
    res = SCENARIOS[name](cfg, (ctrls or controllers()) if needs else None, fast)
    notes = divergence_notes(res.datasets)
    return replace(res, notes=res.notes + notes) if notes else res


def twin_step_responses(cfg: TwinConfig, ctrl: RSTController, temperatures: Sequence[float],
                        t_end: float, step_um: float = 10.0) -> dict[str, tuple]:
    """Reference steps of ``step_um`` on the twin with ``ctrl`` (Tustin at the twin's rate).

    Parameters
    ----------
    cfg : TwinConfig
        The twin (its sampling rate is the controller's).
    ctrl : RSTController
        The controller in s.
    temperatures : sequence of float
        Constant temperatures [°C], one response each.
    t_end : float
        Duration [s].
    step_um : float
        Reference step [µm].

    Returns
    -------
    dict
        ``label -> (t [s], y / step_um)`` per temperature.
    """
    dc = discretize(ctrl, cfg.sample_rate_hz)
    sim = Simulator(build_model(cfg), dc)
    n = run_samples(cfg, t_end, "the step response")
    out = {}
    for T in temperatures:
        r = simulate(cfg, np.full(n, T), yr=np.full(n, step_um), dctrl=dc, seed=0, simulator=sim)
        out[f"twin, {T:g} °C"] = (r.t, r.y / step_um)
    return out
