"""Gap diagnosis building blocks, each checked against an independent computation."""

import json
from dataclasses import replace

import control
import numpy as np
import pytest

from robrst.cli import main
from robrst.data.dataset import Dataset, save_dataset
from robrst.diagnose import diagnose
import robrst.diagnose._signals as signals
from robrst.diagnose.estimate import fit_effects
from robrst.diagnose.linear import LinearSim, refit_linear
from robrst.base.errors import DataError
from robrst.core.plant import Plant, paper_plant
from robrst.twin.config import default_twin
from robrst.twin.simulate import simulate

FS = 5000.0

def _ds(u, y, temp=None, fs=FS, name=""):
    n = len(u)
    temp = np.full(n, 28.0) if temp is None else temp
    return Dataset(t=np.arange(n) / fs, u=np.asarray(u, float), y=np.asarray(y, float),
                   temp=np.asarray(temp, float), source=name)


def _steps(n, seed, lo=0.0, hi=150.0, hold=400):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(lo, hi, n // hold + 1), hold)[:n]
    u[:hold] = 0.0
    return u


def test_linear_sim_matches_python_control_zoh():
    plant = paper_plant()
    u = _steps(6000, 0)
    sysd = control.c2d(control.ss(plant.to_tf()), 1 / FS, method="zoh")
    ref = control.forced_response(sysd, U=u).outputs
    got = LinearSim.of(plant, FS)(u)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-7 * np.max(np.abs(ref)))


def test_linear_refit_round_trip():
    plant = paper_plant()
    true = Plant(plant.B * 1.07, np.asarray(plant.A) * [1, 1.04, 0.97, 1.01])
    u = _steps(20000, 1)
    y = LinearSim.of(true, FS)(u)
    fit = refit_linear(plant, [(u, y)], FS)
    np.testing.assert_allclose(fit.plant.A, true.A, rtol=1e-6)
    np.testing.assert_allclose(fit.plant.B, true.B, rtol=1e-6)
    # the re-fit keeps the user's zeros: a common gain and per-mode frequency/damping changes
    assert fit.rel_change["gain"] == pytest.approx(0.07, abs=1e-6)
    # the JSON contract's coefficient keys stay: b0.. of B, a1.. of monic A (true changes)
    for i, r in enumerate((0.07, 0.07, 0.07)):
        assert fit.rel_change[f"b{i}"] == pytest.approx(r, abs=1e-5)
    for i, r in enumerate((0.04, -0.03, 0.01), start=1):
        assert fit.rel_change[f"a{i}"] == pytest.approx(r, abs=1e-5)


def test_noise_sigma_recovers_white_noise_under_low_frequency_error():
    rng = np.random.default_rng(2)
    t = np.arange(200000) / FS
    for sigma in (0.003, 0.02):
        r = sigma * rng.standard_normal(t.size) + 0.5 * np.sin(2 * np.pi * 3 * t) + 0.05 * t
        assert signals.noise_sigma(r, FS) == pytest.approx(sigma, rel=0.05)


def test_nrmse_pools_records_by_energy():
    a = _ds(np.ones(4), [1.0, 2.0, 3.0, 4.0])
    b = _ds(np.ones(4), [0.0, 0.0, 2.0, 2.0])
    ra, rb = np.array([0.1, 0, 0, 0]), np.array([0, 0.2, 0, 0])
    expected = np.sqrt((0.01 + 0.04) / (5.0 + 4.0))  # sum of squared deviations: 5 and 4
    assert signals.nrmse([a, b], [ra, rb]) == pytest.approx(expected, rel=1e-12)


def test_time_windows_and_band_localise_a_burst():
    rng = np.random.default_rng(3)
    n = 50000
    t = np.arange(n) / FS
    r = 0.01 * rng.standard_normal(n)
    burst = (t >= 4.0) & (t < 6.0)
    r[burst] += 0.3 * np.sin(2 * np.pi * 40 * t[burst])
    d = _ds(np.zeros(n), r)
    wins, frac = signals.time_windows([d], [r], 0.01, ["rec"])
    assert len(wins) == 1 and frac > 0.95
    assert wins[0]["start_s"] == pytest.approx(4.0, abs=0.15)
    assert wins[0]["end_s"] == pytest.approx(6.0, abs=0.15)
    band, *_ = signals.frequency_band([r], FS, 0.01)
    assert band[0] <= 40.0 <= band[1] and band[1] - band[0] < 20.0
    quiet, _ = signals.time_windows([d], [0.01 * rng.standard_normal(n)], 0.01, ["rec"])
    assert quiet == []


def test_whiteness_and_cross_correlation_tests():
    rng = np.random.default_rng(4)
    n = 40000
    u = rng.standard_normal(n)
    d = _ds(u, np.zeros(n))
    white = rng.standard_normal(n)
    assert signals.whiteness([white])["passed"]
    assert signals.cross_correlation([d], [white])["passed"]
    coloured = np.convolve(white, np.ones(20) / 20, mode="same")
    assert not signals.whiteness([coloured])["passed"]
    leaked = white + 0.2 * np.roll(u, 3)
    assert not signals.cross_correlation([d], [leaked])["passed"]


def test_eta2_matches_definition():
    x = np.array([0, 0, 1, 1, 2, 2], float)
    r = np.array([1.0, 3.0, 5.0, 5.0, 0.0, 0.0])
    means = np.array([2.0, 5.0, 0.0])
    between = 2 * np.sum((means - r.mean()) ** 2)
    assert signals.eta2(r, x) == pytest.approx(between / np.sum((r - r.mean()) ** 2), rel=1e-12)


def _twin_records(effect, over, seeds=(5, 6), temps=((28, 44), (40, 30))):
    """Steps with the temperature going a -> b -> a (a reversal makes B and Gamma distinct)."""
    cfg = replace(default_twin().with_effects(only=[effect], **{effect: over}), sample_rate_hz=FS)
    out = []
    for s, (a, b) in zip(seeds, temps):
        u = _steps(30000, s, lo=5.0, hi=145.0)
        temp = a + (b - a) * (1 - np.abs(np.linspace(-1, 1, u.size)))
        r = simulate(cfg, temp, u=u)
        out.append(_ds(u, r.y_true, temp))
    return out


@pytest.mark.parametrize("effect,over,tol", [
    ("hysteresis", {"A": 0.35, "B": 0.004, "Gamma": 0.003}, 1e-4),
    ("creep", {"per_decade": 0.015, "per_K": 0.08}, 1e-4),
    ("thermal_drift", {"lag_s": 2.0, "B": 0.15, "Gamma": 0.1, "gain_V_per_K": 0.7}, 1e-3),
    ("thermal_dynamics", {"gain_per_K": 0.002, "resonance_per_K": -0.0003,
                          "damping_per_K": 0.02}, 1e-3),
])
def test_effect_fit_round_trip(effect, over, tol):
    """Noise-free twin data with known parameters: the fit recovers them."""
    recs = _twin_records(effect, over)
    fit = fit_effects(recs, [effect], paper_plant(), 28.0, max_nfev=80)
    names = {"hysteresis": {"A": "A", "B": "B_per_V", "Gamma": "Gamma_per_V"},
             "creep": {"per_decade": "per_decade", "per_K": "per_K"},
             "thermal_drift": {"lag_s": "lag_s", "B": "B_per_K", "Gamma": "Gamma_per_K",
                               "gain_V_per_K": "gain_V_per_K"},
             "thermal_dynamics": {k: k for k in over}}[effect]
    for k, v in over.items():
        assert fit.params[names[k]] == pytest.approx(v, rel=tol), k


def test_undetermined_parameters_get_infinite_uncertainty():
    """One-way temperature ramps only determine B + Gamma of the drift: say so."""
    over = {"lag_s": 2.0, "B": 0.15, "Gamma": 0.1, "gain_V_per_K": 0.7}
    cfg = replace(default_twin().with_effects(only=["thermal_drift"], thermal_drift=over), sample_rate_hz=FS)
    u = _steps(30000, 5, lo=5.0, hi=145.0)
    temp = np.linspace(28.0, 44.0, u.size)
    rec = _ds(u, simulate(cfg, temp, u=u).y_true, temp)
    fit = fit_effects([rec], ["thermal_drift"], paper_plant(), 28.0)
    s = fit.params["B_per_K"] + fit.params["Gamma_per_K"]
    assert s == pytest.approx(0.25, rel=1e-3)
    assert fit.std["B_per_K"] == np.inf and fit.std["Gamma_per_K"] == np.inf
    assert fit.params["lag_s"] == pytest.approx(2.0, rel=1e-3) and np.isfinite(fit.std["lag_s"])


def test_delay_and_saturation_fits_are_exact():
    plant = paper_plant()
    lin = LinearSim.of(plant, FS)
    u = _steps(30000, 7, lo=-20.0, hi=170.0)
    d = 3
    ud = np.concatenate([np.full(d, u[0]), u[:-d]])
    fit = fit_effects([_ds(u, lin(ud))], ["delay"], plant)
    assert fit.params["samples"] == d and fit.params["seconds"] == pytest.approx(d / FS, rel=1e-12)
    sat = fit_effects([_ds(u, lin(np.clip(u, 0.0, 150.0)))], ["saturation"], plant)
    assert sat.params["u_min_V"] == pytest.approx(0.0, abs=0.05)
    assert sat.params["u_max_V"] == pytest.approx(150.0, abs=0.05)


def test_bad_inputs_give_clear_errors_or_cannot_tell():
    u = _steps(4000, 8)
    y = LinearSim.of(paper_plant(), FS)(u)
    good = _ds(u, y, name="a.csv")
    with pytest.raises(DataError, match="b.csv: sampled at 2500 Hz but a.csv at 5000 Hz"):
        diagnose([good], [_ds(u, y, fs=2500.0, name="b.csv")])
    with pytest.raises(DataError, match="c.csv: too short"):
        diagnose([good], [_ds(u[:100], y[:100], name="c.csv")])
    still = _ds(np.full(4000, 50.0), np.full(4000, 33.0), name="still.csv")
    res = diagnose([still], [good])
    assert res.cause == "cannot_tell" and "no excitation" in res.reason


def test_cli_diagnose_json_and_errors(tmp_path, capsys):
    cfg = replace(default_twin().with_effects(only=["delay", "noise"], delay={"seconds": 0.0008}),
                  sample_rate_hz=FS)
    files = []
    for s in (11, 12, 13):
        u = _steps(15000, s)
        files.append(save_dataset(simulate(cfg, np.full(u.size, 30.0), u=u, seed=s).to_dataset(),
                                  tmp_path / f"r{s}.csv"))
    out = tmp_path / "d.json"
    assert main(["diagnose", "--train", str(files[0]), str(files[1]), "--test", str(files[2]),
                 "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert d["cause"] == "delay" and d["effects"][0]["params"]["samples"] == 4
    assert set(d) >= {"cause", "gap", "effects", "where"}
    assert set(d["gap"]) >= {"metric", "before", "noise_floor"} and d["gap"]["metric"] == "nrmse"
    assert set(d["where"]) >= {"time_windows", "frequency_band_hz", "regime"}
    for e in d["effects"]:
        assert e["shrink"] == pytest.approx(1 - e["gap_after"] / e["gap_before"], rel=1e-12)
    capsys.readouterr()
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u\n0,0\n0.001,1\n")           # temp is optional, y is not
    assert main(["diagnose", "--train", str(bad), "--test", str(files[2])]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.csv: line 1: missing column(s) y" in err[0]


def test_fit_effects_names_bad_requests():
    u = _steps(4000, 8)
    rec = _ds(u, LinearSim.of(paper_plant(), FS)(u), name="a.csv")
    with pytest.raises(DataError, match="unknown effect.*'backlash'"):
        fit_effects([rec], ["backlash"])
    with pytest.raises(DataError, match="thermal_dynamics is fitted alone"):
        fit_effects([rec], ["thermal_dynamics", "creep"])
    with pytest.raises(DataError, match="a.csv: too short"):
        fit_effects([_ds(u[:100], u[:100], name="a.csv")], ["creep"])


@pytest.mark.slow
def test_fit_effects_joint_recovers_effect_and_model_error():
    """Creep on a plant whose gain is 6 % above the user's model: fitted jointly, both found."""
    plant = paper_plant()
    cfg = replace(default_twin().with_effects(only=["creep"], creep={"per_decade": 0.02}),
                  sample_rate_hz=FS)
    recs = []
    for s in (11, 12):
        u = _steps(30000, s, lo=5.0, hi=145.0)
        y = simulate(cfg, np.full(u.size, 28.0), u=u).y_true * 1.06
        recs.append(_ds(u, y))
    alone = fit_effects(recs, ["creep"], plant)
    joint = fit_effects(recs, ["creep"], plant, joint=True)
    assert joint.params["per_decade"] == pytest.approx(0.02, rel=2e-3)
    assert joint.linear_change["gain"] == pytest.approx(0.06, rel=2e-2)
    assert joint.gap < 0.05 * alone.gap and joint.gap < 1e-3
    # creep's growth with temperature is held (one temperature): held, not boxed, the fit
    # converges in a few steps whatever the rounding (it took 567 evaluations boxed)
    assert joint.n_eval < 30
