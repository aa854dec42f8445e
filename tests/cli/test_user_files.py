"""Users' own problem and sweep files through the CLI: what used to fail late, crash or
mislead — every variant invalid, negative-gain trade-off fronts, families of mixed degree,
unwritable or foreign output folders, a sampled loop that alone is unstable."""

import json
import os

import numpy as np
import pytest

from robrst.cli import main
from robrst.studies.sweep.summary import front_values, pareto_front

FIRST_ORDER = """[problem]
name = "p1_first_order"
[plant]
B = [1000.0]
A = [1.0, 2000.0]
temperature_C = 25.0
[poles]
wn = 800.0
zeta = 0.9
[specs]
Ms_max = 2.0
Mt_max = 1.3
Mu_max = 50.0
[solver]
method = "analytic"
"""


@pytest.fixture()
def first_order(tmp_path):
    f = tmp_path / "p1.toml"
    f.write_text(FIRST_ORDER)
    return f


def _sweep(tmp_path, problem, lo, hi, n=4):
    f = tmp_path / "sw.toml"
    f.write_text(f'[sweep]\nkind = "analysis"\nproblem = "{problem.name}"\nn = {n}\n'
                 f'[[param]]\nname = "gain"\ndist = "uniform"\nlo = {lo}\nhi = {hi}\n')
    return f


def test_a_sweep_whose_every_variant_is_invalid_still_reports(tmp_path, first_order, capsys):
    """Gain factors -2..-1: every variant is an `invalid` row; exit 1 with the report (it
    ended in an Arrow error on an empty selection, exit 2, no report)."""
    out = tmp_path / "out"
    assert main(["sweep", str(_sweep(tmp_path, first_order, -2.0, -1.0)), "--out", str(out),
                 "--workers", "0", "--quiet"]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["statuses"] == {"invalid": 4} and s["yield_ci95"][0] == 0.0
    assert (out / "report" / "report.md").is_file()
    assert "computation failed" not in capsys.readouterr().err


@pytest.mark.slow
def test_sweep_report_folder_is_checked_before_any_work(tmp_path, first_order, capsys):
    """A file of the user's in OUT/report: refused at once, results untouched (it used to
    recompute and rewrite the results, then fail, suggesting a --force sweep did not have);
    --force writes the report files beside it."""
    sweep = _sweep(tmp_path, first_order, 0.9, 1.1)
    out = tmp_path / "out"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0", "--quiet"]) == 0
    (out / "report" / "mine.txt").write_text("keep me\n")
    before = (out / "results.parquet").stat().st_mtime_ns
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0", "--restart",
                 "--quiet"]) == 2
    assert "mine.txt" in capsys.readouterr().err
    assert (out / "results.parquet").stat().st_mtime_ns == before
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0", "--quiet",
                 "--force"]) == 0
    assert (out / "report" / "mine.txt").read_text() == "keep me\n"


def test_negative_gain_front_ranks_the_integral_gain_by_magnitude():
    """Designs of a negative-gain plant (Ms, integral gain): the front is (1.27, -2586) and
    (1.96, -3213); (2.29, -338) is dominated by both (the signed ranking kept it)."""
    ms = np.array([1.27, 1.57, 1.96, 2.29])
    ki = np.array([-2586.0, -2516.0, -3213.0, -338.0])
    assert pareto_front(ms, front_values("integral_gain", ki)) == [0, 2]
    assert np.array_equal(front_values("Mu", ki), ki)


def test_explicit_family_of_mixed_degrees_is_refused_at_load(tmp_path, capsys):
    """One model with an extra pole: refused when the file is read, naming the model (it
    failed after the design had started, naming neither file nor key)."""
    f = tmp_path / "mixed.toml"
    f.write_text('[plant]\nname = "paper"\n[family]\nreference_C = 25.0\n'
                 '[[family.models]]\ntemperature_C = 20.0\nB = [1.0e4]\nA = [1.0, 300.0, 1.0e5]\n'
                 '[[family.models]]\ntemperature_C = 30.0\nB = [1.0e4]\n'
                 'A = [1.0, 3000.0, 1.0e6, 1.0e8]\n[poles]\nwn = 300.0\nzeta = 1.0\n')
    assert main(["design", str(f), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "[family.models.1]" in err and str(f) in err


def test_a_sampled_loop_that_alone_is_unstable_is_named_so(tmp_path, capsys):
    """Analytic design, two samples of delay at 100 kHz: the continuous loop is stable, the
    sampled one is not; best_achievable says which (it said only "unstable")."""
    f = tmp_path / "q10.toml"
    f.write_text('[plant]\nB = [48022521322.448364]\n'
                 'A = [1.0, 1533.097214951819, 191422951.28000835, 240112606612.24182]\n'
                 'temperature_C = 25.0\n[controller]\nextra_degree = 1\nT_mode = "cancel_aux"\n'
                 '[poles]\nwn = 500.0\nzeta = 1.0\ndominant_real = [-600.0]\n'
                 '[specs]\nMs_max = 2.0\nMt_max = 1.3\nMu_max = 100.0\n'
                 'sample_rate_hz = 100000.0\ndelay_samples = 2\n[solver]\nmethod = "analytic"\n')
    assert main(["design", str(f), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    worst = max(d["certificate"]["models"], key=lambda m: m["spectral_abscissa_sampled"])
    assert worst["spectral_abscissa"] < 0 < worst["spectral_abscissa_sampled"]
    assert "unstable in the sampled loop" in d["best_achievable"]


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="no /proc (Linux only)")
def test_unwritable_outputs_are_one_clear_line(first_order, capsys):
    """/proc takes no files: the output path is named, exit 2 (it was "computation failed
    ... please report it", naming the problem file)."""
    for argv, path in ((["export", str(first_order), "--fs", "10000", "--out",
                         "/proc/robrst_x.json"], "/proc/robrst_x.json"),
                       (["report", str(first_order), "--out", "/proc/robrst_rep", "--quiet"],
                        "/proc/robrst_rep")):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith(f"robrst: error: {path}:")
        assert "computation failed" not in err[-1]
