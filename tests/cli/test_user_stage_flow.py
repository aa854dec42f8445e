"""A user's stage that is not the paper's, end to end through the command line, each step
reading the previous step's file and nothing designed twice: records -> identify ->
design (DESIGN.json) -> export C -> the exported C in closed loop with the twin of the
identified stage -> check (golden margins) -> certify on a drawn stage -> a sweep of drawn
stages.  The twin run is checked against python-control's sampled loop (c2d plant, the
controller's to_ss, feedback) and the records against the truth of tests/stages.py."""

import json

import control
import numpy as np
import pytest
from stages import FS, stage_params, write_records

import robrst
from robrst.cli import main
from robrst.twin.compiled import compiler

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler")


def _no_design(monkeypatch):
    import robrst.design as design
    import robrst.design._pipeline  # noqa: F401  (the module patched below)
    import robrst.synthesis.robust as robust

    def boom(*a, **k):
        raise AssertionError("designed again")

    monkeypatch.setattr(design, "run_problem", boom)
    monkeypatch.setattr(design._pipeline, "design_single", boom)
    monkeypatch.setattr(design._pipeline, "fleet_design", boom)
    monkeypatch.setattr(robust, "robust_synthesis", boom)


@pytest.mark.slow
def test_records_to_hardware_on_a_users_stage(tmp_path, capsys, monkeypatch):
    recs = write_records(tmp_path)
    stage = tmp_path / "stage.toml"
    assert main(["identify", "--train", *map(str, recs[1]), "--validate", *map(str, recs[2]),
                 "--out", str(stage), "--quiet"]) == 0
    capsys.readouterr()
    # design: the file identify wrote, as it is (its starting design)
    assert main(["design", str(stage), "--json", "--quiet"]) == 0
    saved = tmp_path / "DESIGN.json"
    saved.write_text(capsys.readouterr().out)              # robrst design ... > DESIGN.json
    d = json.loads(saved.read_text())
    assert d["certified"] and d["specs"]["sample_rate_hz"] == FS
    k, w, z = stage_params(20.0)
    A = d["artefact"]["problem_document"]["plant"]["A"]
    assert abs(np.sqrt(A[2]) / w - 1) < 1e-3                  # the identified resonance
    _no_design(monkeypatch)                                    # from here on: never again
    assert main(["export", str(saved), "--format", "c", "--out", str(tmp_path / "ctrl"),
                 "--u-range", "-150", "150", "--quiet"]) == 0
    (tmp_path / "twin.toml").write_text('[twin]\nplant = "stage.toml"\n')
    (tmp_path / "run.toml").write_text(
        '[scenario]\nduration_s = 0.2\ncontroller = "ctrl.c"\ntwin = "twin.toml"\n'
        '[[steps]]\nat_s = 0.01\nto = 1.0\n[[steps]]\nat_s = 0.1\nto = 0.4\n'
        '[temperature]\ntimes_s = [0.0, 0.2]\nvalues_C = [20.0, 40.0]\n')
    capsys.readouterr()
    assert main(["simulate", str(tmp_path / "run.toml"), "--out", str(tmp_path / "sim"),
                 "--json"]) == 0
    m = json.loads(capsys.readouterr().out)["metrics"]
    assert m["closed_loop"] and m["compiled"] and m["effects_on"] == []
    assert all(s["overshoot_pct"] < 2.0 and abs(s["final_error"]) < 1e-3 for s in m["steps"])
    # the run against python-control's sampled loop of the identified nominal stage (the
    # twin file switches no effect on: thermal dynamics too is off)
    design = robrst.load_design(saved)
    plant = design.problem.family.reference_model
    data = robrst.load_dataset(tmp_path / "sim" / "run.csv")
    Pd = control.c2d(control.ss(plant.to_tf()), 1 / FS)
    K = design.controller.to_ss(FS)
    KT = control.ss(K.A, K.B[:, :1], K.C, K.D[:, :1], Pd.dt)
    KR = -control.ss(K.A, K.B[:, 1:], K.C, K.D[:, 1:], Pd.dt)
    y = np.ravel(control.forced_response(control.feedback(Pd, KR) * KT,
                                         np.arange(data.n) / FS, data.yr).outputs)
    assert np.max(np.abs(data.y - y)) <= 1e-8 * np.max(np.abs(y))   # the CSV's 9 digits
    # golden margins of the saved design
    golden = tmp_path / "golden.toml"
    assert main(["check", str(saved), "--golden", str(golden), "--update", "--quiet"]) == 0
    assert main(["check", str(saved), "--golden", str(golden), "--quiet"]) == 0
    # the saved controller on a drawn stage (identify's model file of other records) and
    # a sweep of drawn stages analysing it
    other = tmp_path / "other.toml"
    assert main(["identify", "--train", *map(str, recs[2]), "--out", str(other), "--modal",
                 "--quiet"]) == 0
    capsys.readouterr()
    rc = main(["certify", str(saved), "--problem", str(other), "--family-only", "--json",
               "--quiet"])
    c = json.loads(capsys.readouterr().out)
    assert rc == (0 if c["certified"] else 1) and c["problem"] == "other"
    (tmp_path / "sw.toml").write_text(
        '[sweep]\nkind = "analysis"\nproblem = "stage.toml"\nn = 6\n[analysis]\n'
        'controller = "DESIGN.json"\n[set.solver]\ncert_temperatures = 6\n'
        '[[param]]\nname = "gain"\ndist = "normal"\nmean = 1.0\nstd = 0.05\n')
    rc = main(["sweep", str(tmp_path / "sw.toml"), "--out", str(tmp_path / "sweep"),
               "--workers", "2", "--json", "--quiet"])
    s = json.loads(capsys.readouterr().out)
    assert s["done"] == 6 and s["executor"] == "in_process" and rc in (0, 1)
