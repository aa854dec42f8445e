"""Sweeps over multi-axis variants: a ``[mimo]`` base problem, its spec bounds by key path and
its actuators' gains and resonances as plant factors.  Every row's singular-value peak is
checked against python-control's own loop on a dense grid, the variant's plant built entry
by entry as a transfer matrix (not by the sweep's state-space scaling)."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pyarrow.parquet as pq
import pytest

from mimo_stages import refined_max, stage_tf
from robrst import run_sweep, write_sweep_report
from robrst.base.errors import SpecError
from robrst.core.mimo_loop import MimoController
from robrst.studies.sweep import load_sweep

SAVED = Path(__file__).resolve().parents[1] / "data" / "mimo_stage_design.json"
FS = 20000.0
SEED = 1          # the stage of the saved design (tests/cli/test_check_mimo.py)


def _problem(path, sigma_S_max=2.0, solver=""):
    """A one-model two-axis problem file of the stage (state space of python-control)."""
    s = control.ss(stage_tf(SEED, 2))
    lines = ['[problem]\nname = "stage_xy"\n\n[mimo]\naxes = ["x", "y"]\n', "[[mimo.models]]"]
    lines += [f"{k} = {json.dumps(np.asarray(getattr(s, k)).tolist())}" for k in "ABCD"]
    lines.append(f"value = 20.0\n\n[mimo.specs]\nsigma_S_max = {sigma_S_max}\n"
                 f"sample_rate_hz = {FS}\n\n[mimo.solver]\nmax_rounds = 2\nn_freq = 40\n"
                 + solver)
    path.write_text("\n".join(lines))
    return path


def _sigma_S(g, ctrl):
    """python-control's peak of sigma_max(S), S = (I + G W diag(R_i/S_i))^-1."""
    m = g.noutputs
    num = [[list(ctrl.axes[j].R) if i == j else [0.0] for j in range(m)] for i in range(m)]
    den = [[list(ctrl.axes[j].S) if i == j else [1.0] for j in range(m)] for i in range(m)]
    K = control.ss([], [], [], ctrl.decoupler) * control.ss(control.tf(num, den))
    S = control.feedback(control.ss([], [], [], np.eye(m)), control.ss(g) * K)
    assert np.all(np.real(S.poles()) < 0)
    return refined_max(S, 1.0, 2 * np.pi * 1e5)[0]


def _analysis_sweep(tmp_path, extra=""):
    _problem(tmp_path / "stage.toml")
    shutil.copy(SAVED, tmp_path / "design.json")
    path = tmp_path / "spread.toml"
    path.write_text('[sweep]\nkind = "analysis"\nproblem = "stage.toml"\nn = 3\nseed = 5\n\n'
                    '[analysis]\ncontroller = "design.json"\n\n'
                    '[[param]]\nname = "gain_1"\ndist = "uniform"\nlo = 0.8\nhi = 1.25\n\n'
                    '[[param]]\nname = "resonance"\ndist = "uniform"\nlo = 0.95\nhi = 1.05\n'
                    + extra)
    return path


def test_an_analysis_sweep_over_actuator_gains_and_resonances(tmp_path):
    sweep = load_sweep(_analysis_sweep(tmp_path))
    assert sweep.mimo
    res = run_sweep(sweep, tmp_path / "out", workers=0)
    rows = pq.read_table(tmp_path / "out" / "results.parquet").to_pylist()
    assert len(rows) == 3 and all(r["status"] == "ok" for r in rows)
    ctrl = MimoController.from_dict(json.loads(SAVED.read_text())["controller"])
    for r in rows:
        g = stage_tf(SEED, 2, scale=r["resonance"], gains=[r["gain_1"], 1.0])
        ref = _sigma_S(g, ctrl)
        assert r["sigma_S"] == pytest.approx(ref, rel=1e-6), (r, ref)
        assert r["sigma_S_sampled"] is not None and r["bandwidth_hz"] > 0
        assert r["certified"] == (r["worst_ratio"] <= 1.0 + 1e-3)
        if not r["certified"]:
            assert "sigma_S" in r["violation"]
        assert r["integral_gain"] == pytest.approx(min(json.loads(SAVED.read_text())[
            "integral_gains"], key=abs), rel=1e-9)
    s = res.summary
    assert s["axes"] == ["x", "y"] and s["specs"]["sigma_S_max"] == 2.0
    assert {"sigma_S", "crosstalk", "bandwidth_hz", "worst_ratio"} <= set(s["figures"])
    assert s["controller"]["axes"][0]["name"] == "x"
    assert "sigma_S" in s["worst"][0]
    report = sorted(p.name for p in write_sweep_report(res).glob("*.png"))
    assert report == ["histograms.png", "sensitivity.png"]


def test_bad_multi_axis_sweeps_name_the_key(tmp_path):
    path = _analysis_sweep(tmp_path)
    text = path.read_text()
    cases = [
        (text.replace('name = "gain_1"', 'name = "gain_3"'), "gain_1 .. gain_2"),
        (text.replace('name = "gain_1"', 'name = "damping"'), "[param.0.name]"),
        (text.replace('name = "gain_1"', 'name = "specs.Ms_max"'), "mimo.specs.sigma_S_max"),
        (text.replace('kind = "analysis"', 'kind = "fleet"').replace(
            '[analysis]\ncontroller = "design.json"\n', '[fleet]\nfolder = "."\n'),
         "[sweep.kind]"),
        (text.replace("lo = 0.8", "lo = -0.1"), "positive"),
        (text + '\n[set.mimo.specs]\nsigma_S_max = -1.0\n', "[set.mimo.specs.sigma_S_max]"),
    ]
    for i, (bad, needle) in enumerate(cases):
        p = tmp_path / f"bad{i}.toml"
        p.write_text(bad)
        with pytest.raises(SpecError) as exc:
            run_sweep(load_sweep(p), tmp_path / f"o{i}", workers=0)
        assert needle in str(exc.value) and str(p) in str(exc.value), (needle, exc.value)
    p = tmp_path / "front.toml"
    p.write_text(text.replace('kind = "analysis"', 'kind = "design"').replace(
        '[analysis]\ncontroller = "design.json"\n', '[design]\nfront_x = "Ms"\n'))
    with pytest.raises(SpecError, match=r"\[design\.front_x\].*sigma_U"):
        load_sweep(p)
    proc = subprocess.run([sys.executable, "-m", "robrst", "sweep", str(tmp_path / "bad0.toml"),
                           "--out", str(tmp_path / "cli")], capture_output=True, text=True)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


@pytest.mark.slow
def test_a_design_sweep_over_the_sigma_S_bound(tmp_path):
    """One joint design per bound; each row's controller certified on its own bound by
    python-control's loop, and a looser bound never answers less."""
    _problem(tmp_path / "stage.toml")
    path = tmp_path / "front.toml"
    path.write_text('[sweep]\nkind = "design"\nproblem = "stage.toml"\n\n[[param]]\n'
                    'name = "mimo.specs.sigma_S_max"\ndist = "grid"\nvalues = [1.6, 2.0]\n')
    res = run_sweep(load_sweep(path), tmp_path / "out", workers=0)
    rows = sorted(pq.read_table(tmp_path / "out" / "results.parquet").to_pylist(),
                  key=lambda r: r["mimo.specs.sigma_S_max"])
    assert [r["certified"] for r in rows] == [True, True], rows
    g = stage_tf(SEED, 2)
    for r in rows:
        ctrl = MimoController.from_dict(json.loads(r["controller"]))
        ref = _sigma_S(g, ctrl)
        assert r["sigma_S"] == pytest.approx(ref, rel=1e-6)
        assert ref <= r["mimo.specs.sigma_S_max"] * (1 + 1e-3)
    assert abs(rows[1]["integral_gain"]) >= abs(rows[0]["integral_gain"]) * 0.99
    front = res.summary["front"]
    assert (front["x"], front["y"]) == ("sigma_U", "integral_gain") and front["points"]
    assert (write_sweep_report(res) / "front.png").is_file()
