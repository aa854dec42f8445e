"""Design for the fleet: the yield measured on fresh actuators, independently of the design.

A small resonant stage (continuous loop, two temperatures) is designed for its spread over
a few drawn actuators.  The yield is then measured on *fresh* actuators (another seed)
without robrst's kernels: each actuator's models are built by hand from its drawn factors
and the per-kelvin law, the loop closed in python-control (state space: the closed-loop
poles are the eigenvalues of its A matrix), and |S| and |T| taken on a dense frequency
grid, every 2 K over the interval.  The nominal design (the spread dropped) on the
same actuators collapses: that is the test that fails when the spread is not designed for.
"""

from dataclasses import replace

import control
import numpy as np
import pytest

from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.problem.spread import draw_rows

DOC = {
    "problem": {"name": "tiny_fleet"},
    "plant": {"B": [10000.0], "A": [1.0, 60.0, 10000.0], "temperature_C": 20.0},
    "family": {"temperatures_C": [20.0, 40.0], "parametric": {"gain_per_K": 0.002}},
    "poles": {"wn": 30.0, "zeta": 1.0},
    "specs": {"Ms_max": 1.6, "Mt_max": 1.3},
    "solver": {"method": "nlp", "objective": "max_integral_gain", "n_freq": 60,
               "cert_temperatures": 5},
    "spread": {"yield": 0.9, "confidence": 0.9, "seed": 7, "scenarios": 12, "param": [
        {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.1, "lo": 0.7, "hi": 1.3},
        {"name": "resonance", "dist": "normal", "mean": 1.0, "std": 0.03},
        {"name": "damping", "dist": "lognormal", "median": 1.0, "sigma": 0.3}]},
}
FRESH_SEED = 123_457      # not the design's seed (7)
W = np.geomspace(1e-2, 1e5, 8_000)


def _plant(gain, resonance, damping, T):
    """The drawn actuator at ``T`` by hand: B = 1e4 g (1 + 0.002 dT), the pair's wn and
    zeta scaled (wn = 100, zeta = 0.3 nominal)."""
    wn, zeta = 100.0 * resonance, 0.3 * damping
    b = 10000.0 * gain * (1 + 0.002 * (T - 20.0))
    return control.tf([b], [1.0, 2 * zeta * wn, wn * wn])


def _certifies(ctrl, row, rtol=1e-3):
    """Stable and |S| <= 1.6, |T| <= 1.3 (within rtol) every 2 K over 20..40 °C."""
    K = control.tf(ctrl.R, ctrl.S)
    for T in np.arange(20.0, 40.5, 2.0):
        L = _plant(*row, T) * K
        cl = control.ss(control.feedback(L, 1))
        if np.max(np.linalg.eigvals(cl.A).real) >= 0:
            return False
        l = np.asarray(L(1j * W)).ravel()
        if np.max(np.abs(1 / (1 + l))) > 1.6 * (1 + rtol) or \
                np.max(np.abs(l / (1 + l))) > 1.3 * (1 + rtol):
            return False
    return True


@pytest.fixture(scope="module")
def designs():
    problem = parse_problem(DOC, "tiny_fleet.toml")
    fleet = run_problem(problem)
    nominal = run_problem(replace(problem, spread=None))
    return problem, fleet, nominal


def test_fleet_design_certifies_on_every_drawn_actuator(designs):
    problem, fleet, nominal = designs
    f = fleet.fleet
    assert f.n_scenarios == 12 and f.seed == 7
    assert not f.violated and fleet.certified
    # the drawn actuators are the spread's own draws of seed 7, checked independently
    rows = draw_rows(problem.spread.params, 12, 7)
    np.testing.assert_array_equal(f.values, rows)
    assert all(_certifies(fleet.controller, r) for r in rows)
    # the guarantee is the published a-posteriori bound at the compression size found
    from robrst.synthesis.scenario import nonconvex_epsilon

    assert f.epsilon == nonconvex_epsilon(len(f.compression), 12, 0.1)
    d = fleet.as_dict()["fleet"]
    assert d["compression_size"] == len(f.compression) and d["guaranteed_yield"] == 1 - f.epsilon


@pytest.mark.slow
def test_yield_on_fresh_actuators_is_at_least_the_nominal_designs(designs):
    """python-control on 40 fresh actuators: the fleet design certifies on >= 90 % of them,
    and on at least as many as the nominal design (spread dropped).  On this tiny stage the
    nominal design's multi-start (its best start, a neighbouring problem's answer) already
    certifies on 37 of the 40; the collapse without the spread is measured on the 800 Hz
    stage (benchmarks/fleet.py, reports/stage800_fleet: 66 of 300 nominal, 999 of 1,000
    fleet)."""
    problem, fleet, nominal = designs
    rows = draw_rows(problem.spread.params, 40, FRESH_SEED)
    fleet_yield = np.mean([_certifies(fleet.controller, r) for r in rows])
    nominal_yield = np.mean([_certifies(nominal.controller, r) for r in rows])
    assert fleet_yield >= 0.9, fleet_yield
    assert fleet_yield >= nominal_yield, (fleet_yield, nominal_yield)


STAGE = {
    "problem": {"name": "stage800_small_fleet"},
    "plant": {"B": [5053237.453357752], "A": [1.0, 100.53096491487338, 25266187.26678876],
              "temperature_C": 25.0},
    "family": {"temperatures_C": [15.0, 45.0], "parametric": {"resonance_per_K": -0.001}},
    "poles": {"wn": 600.0, "zeta": 1.0},
    "specs": {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": 150.0},
    "solver": {"method": "nlp", "objective": "max_integral_gain", "n_freq": 80,
               "cert_temperatures": 7},
    "spread": {"yield": 0.9, "confidence": 0.9, "seed": 8, "scenarios": 20, "param": [
        {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.05},
        {"name": "resonance", "dist": "normal", "mean": 1.0, "std": 0.02},
        {"name": "damping", "dist": "lognormal", "median": 1.0, "sigma": 0.4}]},
}
W_STAGE = np.geomspace(1.0, 1e6, 20_000)


def _loop_meets(L, k, w, ms, mt, mu, rtol):
    """The loop ``L`` (python-control) is stable (state-space poles) and within
    ``|S| <= ms``, ``|T| <= mt``, ``|K S| <= mu`` (relative ``rtol``) on the grid ``w``,
    ``k`` the controller's response there."""
    cl = control.ss(control.feedback(L, 1))
    if np.max(np.linalg.eigvals(cl.A).real) >= 0:
        return False
    l = np.asarray(L(1j * w)).ravel()
    return bool(np.max(np.abs(1 / (1 + l))) <= ms * (1 + rtol)
                and np.max(np.abs(l / (1 + l))) <= mt * (1 + rtol)
                and np.max(np.abs(k / (1 + l))) <= mu * (1 + rtol))


def _stage_certifies(ctrl, row, rtol=1e-3):
    """The 800 Hz stage's drawn actuator by hand (static gain 0.2 g µm/V, resonance
    2 pi 800 r (1 - 0.001 (T - 25)) rad/s, damping 0.01 d), every 2.5 K over 15..45 °C:
    stable (state space) and |S| <= 2, |T| <= 1.3, |K S| <= 150 on a dense grid."""
    g, r, d = row
    K = control.tf(ctrl.R, ctrl.S)
    k = np.asarray(K(1j * W_STAGE)).ravel()
    for T in np.arange(15.0, 45.5, 2.5):
        wn = 2 * np.pi * 800.0 * r * (1 - 0.001 * (T - 25.0))
        L = control.tf([0.2 * g * wn * wn], [1.0, 2 * 0.01 * d * wn, wn * wn]) * K
        if not _loop_meets(L, k, W_STAGE, 2.0, 1.3, 150.0, rtol):
            return False
    return True


@pytest.mark.slow
def test_yield_collapses_when_the_spread_is_dropped():
    """The 800 Hz stage (gain 5 %, resonance 2 %, damping lognormal 0.4; continuous loop,
    15 and 45 °C), designed for its spread over 20 drawn actuators and with the spread
    dropped (the nominal design, multi-start included), both judged by python-control on
    the same 60 fresh actuators: the fleet design certifies on >= 80 % (measured 51 of
    60), the nominal design on at least 15 points fewer (measured 36 of 60; its single
    start, 12 of 60)."""
    problem = parse_problem(STAGE, "stage800_small_fleet.toml")
    fleet = run_problem(problem, analyses=False)
    nominal = run_problem(replace(problem, spread=None), analyses=False)
    # an actuator the final controller violates is one the program discarded (it counts in
    # the guarantee): never a silent violation
    assert fleet.fleet.n_scenarios == 20
    assert set(fleet.fleet.violated) <= set(fleet.fleet.discarded)
    rows = draw_rows(problem.spread.params, 60, FRESH_SEED)
    fleet_yield = np.mean([_stage_certifies(fleet.controller, r) for r in rows])
    nominal_yield = np.mean([_stage_certifies(nominal.controller, r) for r in rows])
    assert fleet_yield >= 0.8, fleet_yield
    assert nominal_yield <= fleet_yield - 0.15, (nominal_yield, fleet_yield)


def test_result_json_is_a_controller_a_sweep_file_analyses(designs, tmp_path):
    """`robrst design --json` of a fleet problem: its `fleet` object, and its controller
    analysed by a sweep file (`controller = "result.json"`) on fresh draws of the spread:
    the sweep's yield equals the python-control count on the same actuators."""
    import json

    from robrst.base.fileio import json_text
    from robrst.studies.sweep import parse_sweep, run_sweep

    problem, fleet, _ = designs
    d = fleet.as_dict()
    for key in ("scenarios", "decision_variables", "compression_size", "guaranteed_yield",
                "bound", "integral_gain_ratio", "worst"):
        assert key in d["fleet"]
    (tmp_path / "result.json").write_text(json_text(d))
    (tmp_path / "tiny.toml").write_text(_toml(DOC))
    sweep = parse_sweep({"sweep": {"kind": "analysis", "problem": "tiny.toml", "n": 12,
                                   "seed": FRESH_SEED},
                         "analysis": {"controller": "result.json", "margins": False},
                         "param": [dict(p) for p in DOC["spread"]["param"]]},
                        str(tmp_path / "verify.toml"))
    res = run_sweep(sweep, tmp_path / "out", workers=0)
    rows = draw_rows(problem.spread.params, 12, FRESH_SEED)
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["done"] == 12
    assert res.summary["certified"] == sum(_certifies(fleet.controller, r) for r in rows)


@pytest.mark.slow
def test_box_design_certifies_on_every_corner():
    """method = "box": the centre and the 4 corners of gain x resonance (2 sigma) are
    actuators the design certifies on, checked with python-control."""
    doc = {**DOC, "spread": {"method": "box", "box_sigmas": 2.0, "param": [
        {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.1, "lo": 0.7, "hi": 1.3},
        {"name": "resonance", "dist": "normal", "mean": 1.0, "std": 0.03}]}}
    problem = parse_problem(doc, "box.toml")
    res = run_problem(problem)
    f = res.fleet
    assert f.method == "box" and f.n_scenarios == 5 and f.guaranteed_yield is None
    assert not f.violated and res.certified
    corners = [(1.0, 1.0), (0.8, 0.94), (1.2, 0.94), (0.8, 1.06), (1.2, 1.06)]
    np.testing.assert_allclose(f.values, corners)
    assert all(_certifies(res.controller, (g, r, 1.0)) for g, r in corners)
    # stability along the two gain edges, proved (segments at both temperatures); checked
    # here on a dense gain grid with python-control
    assert f.edges == {"edges": 2, "segments": 4, "crossings": [], "proved": True}
    K = control.tf(res.controller.R, res.controller.S)
    for r in (0.94, 1.06):
        for T in (20.0, 40.0):
            for g in np.linspace(0.8, 1.2, 41):
                cl = control.ss(control.feedback(_plant(g, r, 1.0, T) * K, 1))
                assert np.max(np.linalg.eigvals(cl.A).real) < 0


def _toml(doc):
    """A minimal TOML writer for the test document (tables, arrays of tables, lists)."""
    def val(v):
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    out = []

    def table(name, t):
        scalars = {k: v for k, v in t.items() if not isinstance(v, dict)
                   and not (isinstance(v, list) and v and isinstance(v[0], dict))}
        out.append(f"[{name}]")
        out.extend(f"{k} = {val(v)}" for k, v in scalars.items())
        for k, v in t.items():
            if isinstance(v, dict):
                table(f"{name}.{k}", v)
            elif isinstance(v, list) and v and isinstance(v[0], dict):
                for item in v:
                    out.append(f"[[{name}.{k}]]")
                    out.extend(f"{a} = {val(b)}" for a, b in item.items())

    for name, t in doc.items():
        table(name, t)
    return "\n".join(out) + "\n"


@pytest.mark.large
@pytest.mark.parametrize("name, least", [("stage800_fleet", 0.95), ("paper_robust_fleet", 0.95)])
def test_shipped_fleet_designs_on_1000_fresh_draws(tmp_path, name, least):
    """The shipped fleet problems, designed and verified on 1,000 fresh actuators on Dask
    (about 15 minutes each on 2 cores): the stage reaches its 95 % target with no unstable
    loop; so does paper_robust_fleet (996 of 1,000 measured)."""
    from benchmarks.fleet import run

    rec = run(name, tmp_path / name, n=1000, workers=2, say=lambda m: None)
    v = rec["verification"]
    assert v["n"] == 1000 and v["measured_yield"] >= least and v["unstable"] == 0


STAGE900 = {
    "problem": {"name": "stage900_fleet"},
    "plant": {"B": [3.1978e6], "A": [1.0, 226.19, 3.1978e7], "temperature_C": 20.0},
    "family": {"temperatures_C": [20.0, 30.0, 40.0],
               "parametric": {"gain_per_K": 0.0015, "resonance_per_K": -0.0001,
                              "damping_per_K": 0.005}},
    "controller": {"extra_degree": 1},
    "poles": {"wn": 1130.0, "zeta": 1.0},
    "specs": {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": 100.0},
    "solver": {"method": "nlp", "objective": "max_integral_gain", "n_freq": 80,
               "cert_temperatures": 9},
    "spread": {"yield": 0.9, "confidence": 0.9, "seed": 3, "scenarios": 30, "param": [
        {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.05},
        {"name": "resonance", "dist": "uniform", "lo": 0.97, "hi": 1.03}]},
}


@pytest.mark.slow
def test_fleet_rounds_search_globally():
    """Every round of the exchange over actuators runs the global phase: a 900 Hz stage's
    fleet design keeps most of its nominal optimum (2.44 M against 2.50 M), where rounds
    that were local runs from the fixed-pole start ended at 5,691, 440x below.  Every
    drawn actuator's models are checked in python-control (state-space poles, dense-grid
    |S|, |T|, |K S|)."""
    problem = parse_problem(STAGE900, "stage900_fleet.toml")
    fleet = run_problem(problem, analyses=False)
    nominal = run_problem(replace(problem, spread=None), analyses=False)
    assert fleet.certified and not fleet.fleet.violated
    assert fleet.integral_gain >= 0.5 * nominal.integral_gain, (fleet.integral_gain,
                                                                nominal.integral_gain)
    K = control.tf(fleet.controller.R, fleet.controller.S)
    w = np.geomspace(1.0, 1e6, 20_000)
    k = np.asarray(K(1j * w)).ravel()
    sp = problem.spread
    for fam in sp.actuators(problem.family, sp.draws(sp.scenarios)):
        for m in fam.models:
            assert _loop_meets(control.tf(m.B, m.A) * K, k, w, 2.0, 1.3, 100.0, 1e-3), m.label
