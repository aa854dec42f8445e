"""The paper's experiments on the twin: each qualitative claim as a number."""

import json

import numpy as np
import pytest

from robrst.cli import main
from robrst.data.dataset import load_dataset
from robrst.twin import default_twin
from robrst.design import analytic_design
from robrst.problem.files import load_problem
from robrst.studies.scenarios import controllers, run_scenario


@pytest.fixture(scope="module")
def ctrls(designs):
    """:func:`controllers`' two controllers, the robust one from the session's design of
    paper_robust (shared with the other test files) rather than a design of its own."""
    return {"analytic": analytic_design(load_problem("paper")).controller,
            "robust": designs("paper_robust").controller}


@pytest.mark.slow
def test_the_scenarios_controllers_are_the_shipped_designs(ctrls):
    """controllers() (what robrst simulate fig7/fig8 run) designs the fixture's two."""
    got = controllers()
    for name in ("analytic", "robust"):
        for k in "RST":
            np.testing.assert_allclose(getattr(got[name], k), getattr(ctrls[name], k),
                                       rtol=1e-9, err_msg=f"{name} {k}")


def test_fig2_drift_saturates_and_is_hysteretic():
    m = run_scenario("fig2", default_twin(), fast=True).metrics
    for v in m.values():
        assert 1.0 < v["drift_at_max_um"] < 10.0        # several µm
        assert abs(v["hysteresis_gap_um"]) > 0.3
    assert m["100V"]["drift_at_max_um"] > m["0V"]["drift_at_max_um"]  # gain grows with T


def test_fig3_hysteresis_stable_creep_grows():
    m = run_scenario("fig3", default_twin(), fast=True).metrics
    assert m["width_change_between_temperatures"] < 0.10
    assert m["creep_growth_45_vs_28"] > 0.50
    assert m["loop_width"]["28C_50Hz"] > m["loop_width"]["28C_0.1Hz"]  # rate dependent


def test_fig45_dynamics_barely_change():
    m = run_scenario("fig45", default_twin(), fast=True).metrics
    assert m["step_difference_between_temperatures"] < 0.10
    assert m["overshoot_28C"] > 0.1                      # the badly damped resonance rings


def test_fig7_closed_loop_rejects_thermal_drift(ctrls):
    m = run_scenario("fig7", default_twin(), fast=True, ctrls=ctrls).metrics
    assert m["open_loop_drift_um"] > 1.0
    for name in ("analytic", "robust"):
        assert m[name]["max_deviation_um"] < 0.05


def test_fig8_oscillation_removed_static_error_small(ctrls):
    m = run_scenario("fig8", default_twin(), fast=True, ctrls=ctrls).metrics
    a28, a45 = m["analytic_28C"], m["analytic_45C"]
    assert a28["max_T_gain_100_1500Hz"] < 1.0 and a45["max_T_gain_100_1500Hz"] < 1.0
    assert a28["overshoot"] < 0.05 and a45["static_error_um"] < 0.2
    for T in ("28C", "45C"):   # the robust design (paper_robust) rejects the creep better
        assert m[f"robust_{T}"]["static_error_um"] < 0.6 * m[f"analytic_{T}"]["static_error_um"]
        assert m[f"robust_{T}"]["static_error_um"] < 0.1


def test_cli_simulate_writes_datasets_and_figure(tmp_path, capsys):
    assert main(["simulate", "fig3", "--fast", "--out", str(tmp_path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["scenario"] == "fig3" and d["datasets"]
    for f in d["datasets"]:
        ds = load_dataset(tmp_path / f)
        assert ds.n > 10 and np.all(np.isfinite(ds.y))
    png = (tmp_path / "fig3.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 1000


def test_cli_simulate_unknown_scenario(capsys):
    assert main(["simulate", "fig9", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "unknown scenario 'fig9'" in err and "Traceback" not in err
