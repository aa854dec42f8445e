"""``robrst check`` on a multi-axis design: its golden records every family member's
singular-value peaks, axis peaks and crosstalk (both loops) and the least integral gain;
a regression fails naming the model and the figure.  The recorded peaks are checked
against python-control's own loop on a dense singular-value grid (not against the code
that computed them)."""

import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import control
import numpy as np
import pytest

from mimo_stages import random_stage, refined_max, sigma_grid
from robrst.testing import compare_golden, golden_figures, read_golden, write_golden

SAVED = Path(__file__).resolve().parents[1] / "data" / "mimo_stage_design.json"
FS = 20000.0


def _saved():
    return json.loads(SAVED.read_text())


def test_golden_figures_of_a_saved_multi_axis_design():
    d = _saved()
    g = golden_figures(d)
    members = [m for m in d["certificate"]["models"] if m["member"]]
    assert set(g["models"]) == {m["label"] for m in members}
    assert len(members) < len(d["certificate"]["models"])     # points between: not recorded
    for m in members:
        figs = g["models"][m["label"]]
        for loop, suffix in (("continuous", ""), ("sampled", "_sampled")):
            rec = m[loop]
            assert figs["sigma_S" + suffix] == rec["sigma_S"]["value"]
            assert figs["axis_S" + suffix] == max(p["value"] for p in rec["axis_S"])
            assert figs["crosstalk" + suffix] == rec["crosstalk"]["value"]
    assert g["objective"] == ("integral_gain", min(abs(k) for k in d["integral_gains"]))
    assert g["certified"] is True


def test_multi_axis_golden_round_trip_and_regressions(tmp_path):
    d = _saved()
    path = write_golden(d, tmp_path / "g.toml")
    data = tomllib.loads(path.read_text())
    assert data["design"]["objective"]["name"] == "integral_gain"
    assert compare_golden(d, path) == []
    label = d["certificate"]["models"][0]["label"]

    def scaled(figure, loop, factor):
        out = json.loads(json.dumps(d))
        out["certificate"]["models"][0][loop][figure]["value"] *= factor
        return out

    worse = compare_golden(scaled("sigma_S", "sampled", 1.01), path)
    assert [(w.model, w.figure) for w in worse] == [(label, "sigma_S_sampled")]
    worse = compare_golden(scaled("crosstalk", "continuous", 1.01), path)
    assert [(w.model, w.figure) for w in worse] == [(label, "crosstalk")]
    assert compare_golden(scaled("sigma_S", "continuous", 0.99), path) == []   # better
    weaker = json.loads(json.dumps(d))
    weaker["integral_gains"] = [0.98 * k for k in d["integral_gains"]]
    assert [w.figure for w in compare_golden(weaker, path)] == ["integral_gain"]
    assert read_golden(path)["models"][label]["axis_T"][1] == 1e-4     # the default rtol


def _problem_text(models):
    """A two-axis problem file of python-control state spaces (values 20 and 40)."""
    lines = ['[problem]\nname = "stage_xy"\n\n[mimo]\nparameter = "temperature_C"\n'
             'unit = "°C"\naxes = ["x", "y"]\n']
    for g, v in zip(models, (20.0, 40.0)):
        s = control.ss(g)
        lines.append("[[mimo.models]]")
        for key in "ABCD":
            lines.append(f"{key} = {json.dumps(np.asarray(getattr(s, key)).tolist())}")
        lines.append(f"value = {v}\n")
    lines.append(f"[mimo.specs]\nsigma_S_max = 2.0\nsample_rate_hz = {FS}\n")
    lines.append("[mimo.solver]\nmax_rounds = 2\nn_freq = 40\n")
    return "\n".join(lines)


def _loop_S(g, ctrl):
    """python-control's ``S = (I + G K)^-1`` of the continuous loop (decoupler ``W``)."""
    m = g.noutputs
    axes, W = ctrl.axes, ctrl.decoupler
    num = [[list(axes[j].R) if i == j else [0.0] for j in range(m)] for i in range(m)]
    den = [[list(axes[j].S) if i == j else [1.0] for j in range(m)] for i in range(m)]
    K = control.ss([], [], [], W) * control.ss(control.tf(num, den))
    return control.feedback(control.ss([], [], [], np.eye(m)), control.ss(g) * K)


@pytest.mark.slow
def test_check_command_on_a_multi_axis_problem(tmp_path):
    from robrst.design.mimo import design_mimo
    from robrst.problem.mimo_files import load_mimo_problem

    models = random_stage(1, 2, spread=0.04)
    prob = tmp_path / "stage_xy.toml"
    prob.write_text(_problem_text(models))
    result = design_mimo(load_mimo_problem(prob), compare=False)
    golden = write_golden(result, tmp_path / "golden.toml")
    g = read_golden(golden)
    # the recorded sigma_S of each member against python-control's dense grid
    for (label, figs), model in zip(g["models"].items(), models):
        S = _loop_S(model, result.controller)
        pc = max(refined_max(S, 0.5, 1e6)[0], sigma_grid(S, np.array([0.0])).max())
        assert math.isclose(figs["sigma_S"][0], pc, rel_tol=1e-6), (label, figs["sigma_S"], pc)
    run = lambda *a: subprocess.run([sys.executable, "-m", "robrst", "check", str(prob),  # noqa
                                     "--golden", str(golden), "--quiet", *a],
                                    capture_output=True, text=True, timeout=900)
    ok = run()
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "no figure worse" in ok.stdout
    text = golden.read_text()
    label = next(iter(g["models"]))
    val = g["models"][label]["sigma_S"][0]
    golden.write_text(text.replace(f"sigma_S = {{ value = {val!r}",
                                   f"sigma_S = {{ value = {0.9 * val!r}", 1))
    bad = run()
    assert bad.returncode == 1 and f"{label} sigma_S:" in bad.stdout, bad.stdout
