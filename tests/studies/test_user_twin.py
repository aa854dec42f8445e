"""The twin of a user's stage (not the paper's): its linear part against python-control when
every effect is off; the exported controller (its C code, compiled with the twin) in closed
loop against python-control's sampled loop; twin files whose plant is a problem file;
scenario files (steps, ramps, multisines, temperature) and their validation.  Truth:
python-control's ``c2d`` (ZOH) and ``forced_response`` (tests/stages.py's stage)."""

import json
from dataclasses import replace

import control
import numpy as np
import pytest
from stages import FS, stage_tf

import robrst
from robrst import ControllerStructure, PlantFamily, PoleSpec, Problem, Specs
from robrst.cli import main
from robrst.studies.closedloop import controller_of_c_file, controller_of_design, run_closed_loop
from robrst.studies.twins import load_twin, twin_of_design
from robrst.studies.user_scenario import parse_scenario, scenario_signals
from robrst.twin.compiled import compiler

HAVE_CC = compiler() is not None
STAGE = robrst.Plant.from_control(stage_tf(), label="stage", temperature_C=20.0)


def _design(delay=0):
    problem = Problem("stage", PlantFamily(models=(STAGE,)), poles=PoleSpec(wn=1000.0, zeta=1.0),
                      controller=ControllerStructure(extra_degree=1),
                      specs=Specs(Ms_max=3.0, sample_rate_hz=FS, delay_samples=delay))
    return robrst.run_problem(problem)


@pytest.fixture(scope="module")
def design():
    return _design()


def _pc_loop(ctrl, plant, fs, yr, delay=0):
    """y of the sampled loop from python-control only: ZOH plant (c2d), the controller's
    Tustin state space (RSTController.to_ss), the delay as z^-k, feedback."""
    Pd = control.c2d(control.ss(plant.to_tf()), 1.0 / fs)
    if delay:
        Pd = Pd * control.tf([1.0], [1.0] + [0.0] * delay, 1.0 / fs)
    K = ctrl.to_ss(fs)
    KT = control.ss(K.A, K.B[:, :1], K.C, K.D[:, :1], Pd.dt)
    KR = -control.ss(K.A, K.B[:, 1:], K.C, K.D[:, 1:], Pd.dt)
    t = np.arange(len(yr)) / fs
    return np.ravel(control.forced_response(control.feedback(Pd, KR) * KT, t, yr).outputs)


REF = np.concatenate([np.zeros(20), np.full(1500, 1.0), np.full(1500, 0.4)])


def test_linear_twin_of_a_python_control_plant_is_its_zoh_response():
    """Every effect off: the twin's open-loop response is python-control's ZOH response of
    the plant (the linear step is the exact ZOH now, not RK4), to 1e-12 of the peak."""
    twin = replace(robrst.default_twin().with_effects(only=[]).with_plant(stage_tf()),
                   sample_rate_hz=FS)
    u = np.random.default_rng(3).normal(0, 10.0, 4000)
    r = robrst.simulate(twin, np.full(u.size, 20.0), u=u)
    Pd = control.c2d(control.ss(stage_tf()), 1.0 / FS)
    y = np.ravel(control.forced_response(Pd, np.arange(u.size) / FS, u).outputs)
    assert np.max(np.abs(r.y_true - y)) <= 1e-12 * np.max(np.abs(y))
    assert np.array_equal(r.y, r.y_true)                      # no noise: it is off


@pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
@pytest.mark.parametrize("delay", [0, 1])
def test_exported_controller_in_the_twin_matches_python_controls_sampled_loop(delay):
    """The exported C (sections, float64), compiled with the twin, in closed loop: within
    1e-9 of python-control's loop (another realisation: to_ss; measured ~1e-12)."""
    result = _design(delay)
    lc = controller_of_design(result)
    twin = twin_of_design(result)
    r = run_closed_loop(twin, lc, REF, np.full(REF.size, 20.0))
    y_pc = _pc_loop(result.controller, STAGE, FS, REF, delay)
    assert r.meta["compiled"] and r.meta["delay_samples"] == delay
    assert np.max(np.abs(r.y - y_pc)) <= 1e-9 * np.max(np.abs(y_pc))
    assert abs(r.y[-1] - 0.4) < 1e-6                              # integral action


@pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
def test_float32_the_c_file_and_the_python_fallback(design, tmp_path, monkeypatch):
    lc = controller_of_design(design)
    twin = twin_of_design(design)
    T = np.full(REF.size, 20.0)
    y64 = run_closed_loop(twin, lc, REF, T).y
    y32 = run_closed_loop(twin, lc, REF, T, precision="float32").y
    err = np.max(np.abs(y32 - y64)) / np.max(np.abs(y64))
    assert 0 < err <= 1e-5                                        # float32 arithmetic, bounded
    for name, text in lc.files.items():                           # the files export writes
        (tmp_path / name).write_text(text)
    cf = controller_of_c_file(tmp_path / "ctrl.c")
    assert (cf.prefix, cf.sample_rate_hz, cf.delay_samples) == ("robrst_ctrl", FS, 0)
    assert np.array_equal(run_closed_loop(twin, cf, REF, T).y, y64)       # bit for bit
    monkeypatch.setenv("ROBRST_NO_COMPILE", "1")                 # Python step, same operations
    r = run_closed_loop(twin, lc, REF, T)
    assert not r.meta["compiled"] and np.array_equal(r.y, y64)
    with pytest.raises(robrst.SpecError, match="needs a C compiler"):
        run_closed_loop(twin, cf, REF, T)


def test_twin_file_with_a_problem_file_as_plant(tmp_path):
    """plant = a problem file: its reference model, temperature, rate and per-kelvin law;
    only the effects whose tables the twin file has are on."""
    p = tmp_path / "stage.toml"
    p.write_text(f"[plant]\nB = {STAGE.B.tolist()}\nA = {STAGE.A.tolist()}\n"
                 "temperature_C = 22.0\n[family]\ntemperatures_C = [22.0, 40.0]\n"
                 "[family.parametric]\nresonance_per_K = -0.0005\n[poles]\nwn = 1.0\n"
                 "zeta = 1.0\n[specs]\nsample_rate_hz = 10000.0\n")
    tw = tmp_path / "twin.toml"
    tw.write_text('[twin]\nplant = "stage.toml"\n[noise]\nsigma_um = 0.01\n')
    cfg = load_twin(tw)
    assert [k for k in cfg.effects if cfg.enabled(k)] == ["noise"]
    assert cfg.reference_C == 22.0 and cfg.sample_rate_hz == 10000.0
    assert cfg.effects["thermal_dynamics"]["resonance_per_K"] == -0.0005
    assert np.array_equal(cfg.linear_plant.A, STAGE.A)
    tw.write_text('[twin]\nplant = "missing.toml"\n')
    with pytest.raises(robrst.SpecError, match=r"twin.toml: \[twin.plant\] .*missing.toml"):
        load_twin(tw)
    tw.write_text('[twin]\nplant = "stage.toml"\nsample_rate_hz = 5000.0\n')
    assert load_twin(tw).sample_rate_hz == 5000.0


GOOD = '[scenario]\nduration_s = 0.1\n[[steps]]\nat_s = 0.01\nto = 1.0\n'


@pytest.mark.parametrize("text,key", [
    (GOOD + "wobble = 1\n", "[steps.0.wobble]"),
    ("[scenario]\n[[steps]]\nat_s = 0.0\nto = 1.0\n", "[scenario.duration_s]"),
    (GOOD.replace("0.01", "0.5"), "[steps.0.at_s]"),
    (GOOD + "[[ramps]]\nfrom_s = 0.0\nto_s = 0.05\nto = 2.0\n", "[ramps]"),
    (GOOD + "[[ramps]]\nfrom_s = 0.05\nto_s = 0.04\nto = 2.0\n", "[ramps.0]"),
    (GOOD + "[[multisines]]\namplitude = 1.0\nf_lo_hz = 10.0\nf_hi_hz = 1.0\n",
     "[multisines.0.f_hi_hz]"),
    (GOOD + "[temperature]\ntimes_s = [0.0, 0.0]\nvalues_C = [20.0, 30.0]\n",
     "[temperature.times_s]"),
    (GOOD + "[temperature]\ntimes_s = [0.0]\n", "[temperature]"),
    (GOOD.replace("[scenario]\n", '[scenario]\nprecision = "float16"\n'),
     "[scenario.precision]"),
])
def test_bad_scenario_files_name_the_key(tmp_path, capsys, text, key):
    path = tmp_path / "s.toml"
    path.write_text(text)
    assert main(["simulate", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and key in err[0], err
    assert not (tmp_path / "o").exists()


def test_scenario_signals_by_hand():
    sc = parse_scenario({"scenario": {"duration_s": 1.0, "initial": 0.5},
                         "steps": [{"at_s": 0.2, "to": 1.0}],
                         "ramps": [{"from_s": 0.4, "to_s": 0.6, "to": 3.0}],
                         "temperature": {"times_s": [0.0, 1.0], "values_C": [20.0, 30.0]}})
    t, s, T = scenario_signals(sc, 10.0, 25.0)
    assert t.size == 11 and np.allclose(s, [0.5, 0.5, 1, 1, 1, 2, 3, 3, 3, 3, 3])
    assert np.allclose(T, 20 + 10 * t)
    sc = parse_scenario({"scenario": {"duration_s": 1.0},
                         "multisines": [{"amplitude": 2.0, "f_lo_hz": 1.0, "f_hi_hz": 4.0}]})
    _, s, T = scenario_signals(sc, 1000.0, 25.0)
    assert abs(np.max(np.abs(s)) - 2.0) < 1e-12 and np.all(T == 25.0)
    with pytest.raises(robrst.SpecError, match=r"\[multisines.0.f_hi_hz\].*Nyquist"):
        scenario_signals(sc, 6.0, 25.0)


@pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
def test_simulate_a_scenario_file_with_a_saved_design(design, tmp_path, capsys):
    saved = tmp_path / "DESIGN.json"
    saved.write_text(json.dumps(design.as_dict()))
    sc = tmp_path / "steps.toml"
    sc.write_text('[scenario]\nduration_s = 0.2\ncontroller = "DESIGN.json"\n'
                  '[[steps]]\nat_s = 0.01\nto = 1.0\n[[steps]]\nat_s = 0.1\nto = 0.4\n')
    assert main(["simulate", str(sc), "--out", str(tmp_path / "o"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    m = d["metrics"]
    assert m["closed_loop"] and m["effects_on"] == [] and m["compiled"]
    assert [s["to"] for s in m["steps"]] == [1.0, 0.4]
    assert all(abs(s["final_error"]) < 1e-3 for s in m["steps"])
    assert {p.name for p in (tmp_path / "o").iterdir()} >= {"steps.csv", "steps.png",
                                                             "report.md"}
    data = robrst.load_dataset(tmp_path / "o" / "steps.csv")
    y_pc = _pc_loop(design.controller, STAGE, FS, data.yr)
    assert np.max(np.abs(data.y - y_pc)) <= 1e-8 * np.max(np.abs(y_pc))  # CSV's 9 digits


@pytest.mark.parametrize("args,words", [
    (["simulate", "{sc}", "--controller", "{tmp}/nope.json"], "problem file not found"),
    (["simulate", "{sc}", "--controller", "{tmp}/nope.c"], "C controller not found"),
    (["simulate", "fig2", "--controller", "{tmp}/nope.json"], "fig2 runs no controller"),
    (["simulate", "fig2", "--precision", "float32"], "fig2 runs no controller"),
    (["simulate", "{tmp}/none.toml"], "unknown scenario"),
    (["certify", "{tmp}/nope.json"], "saved design not found"),
    (["certify", "{tmp}/nope.json", "--family-only"], "needs --problem"),
])
def test_bad_simulate_and_certify_arguments_are_one_line(tmp_path, capsys, args, words):
    sc = tmp_path / "s.toml"
    sc.write_text(GOOD)
    args = [a.format(sc=sc, tmp=tmp_path) for a in args]
    assert main(args + ["--out", str(tmp_path / "o")] if args[0] == "simulate" else args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("robrst: error:") and words in err[0], err
    assert not (tmp_path / "o").exists()
