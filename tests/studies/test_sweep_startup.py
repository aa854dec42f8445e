"""Sweeps that feel instant: the first chunks run in the driver and a local cluster starts
only when the rest of the work pays its start-up; an unstable variant is reported as
unstable (no peaks or margins of an unstable loop); the progress bar on long runs only;
closing a cluster logs nothing."""

import io
import logging

import numpy as np
import pytest

from robrst.cli._sweep import progress_bar
from robrst.report.sweep import sweep_text
from robrst.studies.sweep import parse_sweep, run_sweep
from robrst.studies.sweep._cluster import quiet_shutdown
from robrst.studies.sweep.engine import MARGIN_S, STARTUP_S, Progress, cluster_pays


def _gain_sweep(values):
    return parse_sweep({"sweep": {"kind": "analysis", "problem": "paper"},
                        "param": [{"name": "gain", "dist": "grid", "values": values}]})


def test_an_unstable_variant_has_no_peaks_and_says_so(tmp_path):
    """The paper's controller on a stage 40x as stiff in gain: its loop is unstable
    (closed-loop roots: numpy, independently); the row has no Ms (it used to list the
    |S| peak of an unstable loop), stable is false, the worst violation is the instability."""
    import robrst

    res = run_sweep(_gain_sweep([1.0, 40.0]), tmp_path / "o", workers=0)
    ok, bad = res.table.to_pylist()
    ctrl = robrst.run_problem(robrst.load_problem("paper")).controller
    p = robrst.paper_plant()
    Delta = np.polyadd(np.polymul(p.A, ctrl.S), np.polymul(40.0 * p.B, ctrl.R))
    assert np.max(np.roots(Delta).real) > 0 and not bad["stable"] and ok["stable"]
    for k in ("Ms", "Mt", "Mu", "Mt_band", "modulus_margin", "gain_margin",
              "phase_margin_deg", "delay_margin_s", "Ms_temperature_C"):
        assert bad[k] is None, k
    assert ok["Ms"] == pytest.approx(1.481, abs=1e-3)
    assert "spectral_abscissa" in bad["violation"] and bad["worst_ratio"] == np.inf
    s = res.summary
    assert s["unstable"] == 1 and s["figures"]["Ms"]["max"] == ok["Ms"]
    assert "unstable: 1 of 2" in sweep_text(s)


def test_a_small_sweep_on_two_workers_stays_in_this_process(tmp_path):
    res = run_sweep(_gain_sweep([0.9, 1.0, 1.1]), tmp_path / "o", workers=2)
    s = res.summary
    assert s["executor"] == "in_process" and s["workers"] == 1 and s["done"] == 3
    assert s["estimated_in_process_s"] < 12.0 and res.complete


def test_when_a_cluster_pays():
    """Remaining work R [s] in this process, w workers: a cluster starting in up to
    STARTUP_S + MARGIN_S finishes within MARGIN_S of this process exactly when it is chosen."""
    limit = (STARTUP_S + MARGIN_S) * 2
    assert not cluster_pays(limit - 0.1, 2) and cluster_pays(limit + 0.1, 2)
    assert not cluster_pays(1e6, 1)
    for R in (limit + 0.1, 30.0, 300.0):
        assert STARTUP_S + MARGIN_S + R / 2 <= R + MARGIN_S


def _p(done, total, t):
    return Progress(done, total, 0, 0, t, 2)


def test_progress_bar_on_long_runs_only_and_plain_lines_without_a_terminal():
    out = io.StringIO()
    bar = progress_bar("s", out, tty=False)
    for k in range(0, 101):
        bar(_p(k, 100, 0.1 * k))               # 2 s reached at k = 20
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue() and 8 <= len(lines) <= 9 and lines[-1].startswith("s [")
    out = io.StringIO()
    bar = progress_bar("s", out, tty=True)
    for k in range(0, 11):
        bar(_p(k, 10, 0.1 * k))                # a 1 s run: no bar at all
    assert out.getvalue() == ""


def test_closing_a_cluster_logs_nothing(capsys):
    handler = logging.StreamHandler()
    log = logging.getLogger("distributed.comm")
    log.addHandler(handler)
    try:
        with quiet_shutdown():
            log.error("CommClosedError: in <TCP (closed) ...>: Stream is closed")
        assert capsys.readouterr().err == ""
        log.error("after")                      # restored
        assert "after" in capsys.readouterr().err
    finally:
        log.removeHandler(handler)
