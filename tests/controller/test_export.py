"""``robrst export``: the exported law gives exactly the certified sampled loop.

Independent reference (tests/pcloop.py): python-control's ZOH ``c2d`` of the time-scaled
plant, the exported ``R_z, S_z`` as discrete transfer functions, ``control.feedback`` for
the closed-loop poles, peaks on a 20 000-point unit-circle grid with local refinement.
"""

import json
import subprocess
import sys

import control
import numpy as np
import pytest
from pcloop import feedback_law, loop_figures, zoh_plant

from robrst.cli import main
from robrst.design import run_problem
from robrst.controller.export import export_controller
from robrst.controller.python_code import python_module
from robrst.core.family import PlantFamily
from robrst.controller.implementation import run_loop, sampled_loop
from robrst.core.plant import Plant
from robrst.problem.records import ControllerStructure, PoleSpec, Problem, Specs

FS = 20000.0
SHIPPED = {"paper": FS, "paper_robust": None}   # a rate where the problem names none


def _check_against_python_control(exp, problem):
    """Peaks of every family member and the spectral radius over all certified models.

    The sections' state space must reproduce the certificate to 1e-6 (peaks) and 1e-8
    (radius); the direct form ``R_z/S_z`` within the error its own coefficients imply
    (its ``mu`` of ``realisation("direct_form", "float64")``, the bound of
    ``robrst.controller.implementation``; its spectral radius within ``1e-6 + mu``): near-clustered poles by
    ``z = 1`` make it the weaker one.
    """
    d = exp.as_dict()
    fs, k = d["sample_rate_hz"], d["delay_samples"]
    recs = {m.temperature_C: m for m in exp.certificate.models}
    mu = exp.realisation("direct_form", "float64").mu_y
    slack = {"sections": 1e-6, "direct": 1e-6 + 4 * mu * d["certificate"]["Ms_sampled"]}
    for m in problem.family.models:
        dt = zoh_plant(m, fs, k).dt
        rec = recs[m.temperature_C]
        for form, tol in slack.items():
            f = loop_figures(m, feedback_law(exp, dt, form), fs, k)
            for key in ("Ms", "Mt", "Mu"):
                assert f[key] == pytest.approx(rec.value(key, "sampled"), rel=tol), \
                    (m.label, form, key)
            assert (f["spectral_radius"] < 1) == rec.sampled.stable
    # the radius: robrst's per-model sampled loops give the max; python-control checks the
    # family members and the model attaining it (each to 1e-8, the direct form to 1e-6)
    models = [problem.family.at(T) for T in recs] if len(recs) > 1 else problem.family.models
    radii = [sampled_loop(exp.digital.ctrl, m, fs, k).spectral_radius for m in models]
    assert max(radii) == d["certificate"]["spectral_radius"]
    worst = models[int(np.argmax(radii))]
    for m in list(problem.family.models) + [worst]:
        P = zoh_plant(m, fs, k)
        mine = radii[[x.temperature_C for x in models].index(m.temperature_C)]
        # the direct form's own coefficient rounding moves its loop by mu (small-gain
        # figure of robrst.controller.implementation): its poles are compared within that, the sections'
        # to 1e-8
        for form, tol in (("sections", 1e-8), ("direct", 1e-6 + mu)):
            poles = control.feedback(P, feedback_law(exp, P.dt, form)).poles()
            assert np.max(np.abs(poles)) == pytest.approx(mine, abs=tol), (m.label, form)


@pytest.mark.parametrize("name", list(SHIPPED))
def test_exported_law_gives_the_certified_sampled_loop(exports, designs, name):
    exp = exports(name)
    problem = designs(name).problem
    _check_against_python_control(exp, problem)
    d = exp.as_dict()
    assert d["S_z"][0] == 1.0 and len(d["R_z"]) == len(d["S_z"]) == len(d["T_z"])
    worst = max(m.sampled.Ms for m in exp.certificate.models)
    assert d["certificate"]["Ms_sampled"] == worst


def test_a_design_without_rate_is_certified_on_its_sampled_loop_at_fs(designs):
    """paper names no rate: exported at 5 kHz its sampled loop breaks Ms <= 2, at 2 kHz it
    is unstable; the certificate says so, and python-control agrees on exactly that loop."""
    result = designs("paper")
    assert result.certified and not result.problem.specs.sampled
    exps = {fs: export_controller(result, fs) for fs in (5000.0, 2000.0)}
    for fs, exp in exps.items():
        cert = exp.as_dict()["certificate"]
        assert not exp.certified and any("in the sampled loop" in v for v in cert["violations"])
        P = zoh_plant(result.problem.family.models[0], fs)
        poles = control.feedback(P, feedback_law(exp, P.dt, "sections")).poles()
        assert np.max(np.abs(poles)) == pytest.approx(cert["spectral_radius"], abs=1e-8)
        assert (cert["spectral_radius"] < 1) == (fs == 5000.0)
    _check_against_python_control(exps[5000.0], result.problem)


def _random_problem(seed):
    """A random stable plant (2-4 poles, 0-1 zero), pole placement, random rate and delay."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 5))
    poles = list(-10 ** rng.uniform(1, 3, n - 2 * (n // 3)))
    for _ in range(n // 3):
        w, z = 10 ** rng.uniform(1.5, 3), rng.uniform(0.02, 0.5)
        poles += [complex(-z * w, w * np.sqrt(1 - z * z)), complex(-z * w, -w * np.sqrt(1 - z * z))]
    zeros = list(-10 ** rng.uniform(1, 3, int(rng.integers(0, 2))))
    plant = Plant.from_zpk(zeros, poles, 10 ** rng.uniform(0, 4), label="rand",
                           temperature_C=25.0)
    wn = 0.5 * float(np.min(np.abs(poles)))
    fs = float(10 ** rng.uniform(1.5, 2.5)) * max(float(np.max(np.abs(poles))), 10 * wn) / 6.28
    k = int(rng.integers(0, 2))
    return Problem(f"random{seed}", PlantFamily(models=(plant,)),
                   poles=PoleSpec(wn=wn, zeta=0.8), controller=ControllerStructure(extra_degree=1),
                   specs=Specs(sample_rate_hz=fs, delay_samples=k))


@pytest.mark.parametrize("seed", range(4))
def test_random_plants(seed):
    problem = _random_problem(seed)
    exp = export_controller(run_problem(problem))
    assert exp.certificate is not None and exp.digital.sample_rate_hz == problem.specs.sample_rate_hz
    _check_against_python_control(exp, problem)
    assert exp.realisation("sections", "float64").mu_y < 1e-9


@pytest.mark.parametrize("R_fixed,extra", [((1e-4, 1.0), 1), ((1e-4, 1.0), 0)])
def test_roll_off_controllers(R_fixed, extra):
    """A roll-off in R (R_fixed); with extra_degree 0 the controller is biproper (deg R = deg S)."""
    problem = Problem("rolloff", PlantFamily(models=(Plant([107.0, 1.498e6, 6.527e9],
                                                           [1.0, 693.0, 1.5027342e7, 9.765e9],
                                                           temperature_C=28.0),)),
                      poles=PoleSpec(wn=600.0, zeta=1.0),
                      controller=ControllerStructure(R_fixed=R_fixed, extra_degree=extra),
                      specs=Specs(sample_rate_hz=FS))
    exp = export_controller(run_problem(problem))
    ctrl = exp.digital.ctrl
    assert (len(ctrl.R) == len(ctrl.S)) == (extra == 0)
    _check_against_python_control(exp, problem)


@pytest.mark.parametrize("name", list(SHIPPED))
def test_implementations_against_the_exact_loop(exports, name):
    """The stated bounds: float64 sections ~1e-13, float32 sections within 1e-5 (mu and a
    simulated step), the direct form in float32 loses the integrator and is 100x worse."""
    exp = exports(name)
    f64, f32 = exp.realisation("sections", "float64"), exp.realisation("sections", "float32")
    assert f64.stable_guaranteed and f64.mu_y < 1e-12 and f64.step_error_y < 1e-12
    assert f32.stable_guaranteed and f32.mu_y < 1e-5
    assert f32.step_error_y < 1e-5 and f32.step_error_u < 1e-4
    assert exp.recommended == "sections_float32"
    d32 = exp.realisation("direct_form", "float32")
    assert not d32.stable_guaranteed and d32.step_error_y > 100 * f32.step_error_y
    bounds = exports(name).implementation_dict()["sections_float32"]
    cert = exports(name).as_dict()["certificate"]
    assert cert["Ms_sampled"] <= bounds["Ms_sampled_bound"] <= cert["Ms_sampled"] * (1 + 2e-5)


def test_python_module_runs_the_same_step(exports, designs):
    exp = exports("paper_robust")
    ns = {}
    exec(compile(python_module(exp), "<generated>", "exec"), ns)   # noqa: S102
    ctrl = ns["Controller"]()
    yr = np.concatenate([np.zeros(10), np.full(400, 20.0)])
    plant = designs("paper_robust").problem.family.models[0]
    y_ref, u_ref = run_loop(exp.digital, plant, yr, u_range=exp.u_range)
    u = [ctrl.step(r, y) for r, y in zip(yr, y_ref)]
    assert np.array_equal(u, u_ref)          # same operations, same order: bit for bit
    assert ns["S_Z"][0] == 1.0 and ns["U_MAX"] == 150.0


def test_cli_json_contract(capsys):
    rc = main(["export", "paper", "--fs", "20000"])
    out = capsys.readouterr()
    assert rc == 0 and out.err == ""
    d = json.loads(out.out)
    assert {"problem", "sample_rate_hz", "delay_samples", "discretisation", "R_z", "S_z", "T_z",
            "law", "sections", "certificate", "implementation"} <= set(d)
    assert d["discretisation"] == "tustin" and d["S_z"][0] == 1.0 and d["delay_samples"] == 0
    assert d["law"] == "S(q^-1) u(t) = T(q^-1) yr(t) - R(q^-1) y(t)"
    assert {"certified", "Ms_sampled", "Mt_sampled", "Mu_sampled", "spectral_radius"} \
        <= set(d["certificate"])
    assert sum(s["order"] for s in d["sections"]) == len(d["S_z"]) - 1 == d["n_states"]


def test_cli_rate_override_redesigns_a_sampled_problem(tmp_path, capsys):
    f = tmp_path / "p.toml"
    f.write_text('[plant]\nname = "paper"\n[poles]\nwn = 600.0\nzeta = 1.0\n'
                 '[controller]\nextra_degree = 1\n[specs]\nsample_rate_hz = 20000.0\n')
    assert main(["export", str(f), "--fs", "10000", "--delay-samples", "1"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["sample_rate_hz"] == 10000.0 and d["delay_samples"] == 1
    problem = Problem("p", PlantFamily(models=(Plant([1.0], [1.0, 1.0], temperature_C=28.0),)))
    assert problem.specs.sample_rate_hz is None


@pytest.mark.parametrize("args,msg", [
    (["export", "paper"], "names no sampling rate"),
    (["export", "paper", "--fs", "-5"], "sampling rate"),
    (["export", "paper", "--fs", "20000", "--delay-samples", "-1"], "--delay-samples"),
    (["export", "paper", "--fs", "20000", "--u-range", "150", "0"], "amplifier range"),
    (["export", "paper", "--fs", "20000", "--format", "c", "--prefix", "1bad"], "C prefix"),
])
def test_cli_errors(args, msg, capsys):
    assert main(args) == 2
    out = capsys.readouterr()
    assert out.out == "" and out.err.startswith("robrst: error:") and msg in out.err
    assert len(out.err.strip().splitlines()) == 1


def test_cli_error_is_one_line_without_traceback():
    r = subprocess.run([sys.executable, "-m", "robrst", "export", "paper", "--format", "xml"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "--format" in r.stderr


def test_cli_never_overwrites_a_file_it_did_not_write(tmp_path, capsys):
    mine = tmp_path / "ctrl.h"
    mine.write_text("/* my own header */\n")
    assert main(["export", "paper", "--fs", "20000", "--format", "c",
                 "--out", str(tmp_path / "ctrl")]) == 2
    assert mine.read_text() == "/* my own header */\n" and not (tmp_path / "ctrl.c").exists()
    assert "not written by robrst" in capsys.readouterr().err
    mine.unlink()
    for _ in range(2):     # its own files it rewrites
        assert main(["export", "paper", "--fs", "20000", "--format", "c", "--quiet",
                     "--out", str(tmp_path / "ctrl.c")]) == 0
    assert "robrst_ctrl_step" in (tmp_path / "ctrl.c").read_text()
