"""Digital twin: linear round trip, each effect's signature, discrete RST loop, compiled = VM."""

import control
import numpy as np
import pytest

from robrst.core.analysis import step_response
from robrst.core.family import ThermalCoefficients, parametric_family
from robrst.core.plant import paper_plant
from robrst.core.rst import closed_loop
from robrst.studies.scenarios import loop_width
from robrst.core.rst import discretize
from robrst.twin import default_twin, simulate

FS = 20000.0


def _multisine(n, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    f = rng.uniform(5, 2000, size=8)
    ph = rng.uniform(0, 2 * np.pi, size=8)
    return 75 + 5 * np.sum(np.sin(2 * np.pi * f[:, None] * t + ph[:, None]), axis=0)


def _zoh(plant, u):
    sysd = control.c2d(control.tf(plant.B, plant.A), 1 / FS, "zoh")
    return control.forced_response(sysd, U=u).outputs


@pytest.mark.parametrize("seed", [0, 1])
def test_linear_part_reproduces_D_exactly(seed):
    cfg = default_twin().with_effects(only=[])
    u = _multisine(4000, seed)
    r = simulate(cfg, np.full(u.size, 28.0), u=u - u[0])
    y_ref = _zoh(paper_plant(), u - u[0])
    # RK4 (4 substeps) against the exact ZOH discretisation
    np.testing.assert_allclose(r.y_true, y_ref, rtol=0, atol=2e-5 * np.max(np.abs(y_ref)))
    np.testing.assert_array_equal(r.y, r.y_true)  # no noise, no quantisation


def test_thermal_dynamics_follow_the_plant_family():
    cfg = default_twin().with_effects(only=["thermal_dynamics"])
    td = cfg.effects["thermal_dynamics"]
    fam = parametric_family(paper_plant(), [28.0, 45.0], ThermalCoefficients(
        28.0, td["gain_per_K"], td["resonance_per_K"], td["damping_per_K"]))
    u = _multisine(4000, 3) - 75
    r = simulate(cfg, np.full(u.size, 45.0), u=u)
    y_ref = _zoh(fam.at(45.0), u)
    np.testing.assert_allclose(r.y_true, y_ref, rtol=0, atol=2e-5 * np.max(np.abs(y_ref)))
    assert np.max(np.abs(y_ref - _zoh(paper_plant(), u))) > 1e-3 * np.max(np.abs(y_ref))


def _loop(cfg, amp, f=0.1, T=28.0, offset=75.0):
    n_per = int(FS / f)
    t = np.arange(2 * n_per) / FS
    u = offset - amp * np.cos(2 * np.pi * f * t)
    r = simulate(cfg, np.full(t.size, T), u=u)
    return loop_width(r.u_applied[n_per:], r.y_true[n_per:]), r


def test_hysteresis_signature_full_range_and_small_amplitude():
    cfg = default_twin().with_effects(only=["hysteresis"])
    w_full, r = _loop(cfg, 75.0)
    w_small, _ = _loop(cfg, 5.0, offset=0.0)  # minor loop of a relaxed actuator
    assert 0.10 <= w_full <= 0.18          # 10-15 % of stroke at full range (tolerance 3 %)
    assert 0.005 < w_small < 0.05          # a few % at small amplitude
    # mean slope over the third full-range cycle (as hysteresis_gain defines it) keeps D(0)
    n_per = int(FS)
    t = np.arange(3 * n_per) / FS
    r = simulate(cfg, np.full(t.size, 28.0), u=75 - 75 * np.cos(2 * np.pi * t))
    slope = np.ptp(r.y_true[2 * n_per:]) / 150.0
    assert slope == pytest.approx(paper_plant().dc_gain, rel=5e-3)
    assert _loop(default_twin().with_effects(only=[]), 75.0)[0] < 0.005  # no loop without it


def test_creep_log_law_and_growth_with_temperature():
    cfg = default_twin().with_effects(only=["creep"])
    per = {}
    for T in (28.0, 45.0):
        n = int(100 * FS)
        r = simulate(cfg, np.full(n, T), u=np.full(n, 100.0))
        t = r.t[1:]
        y = r.y_true[1:]
        sel = (t >= 1.0) & (t <= 100.0)
        slope = np.polyfit(np.log10(t[sel]), y[sel], 1)[0]
        per[T] = slope / y[np.searchsorted(t, 1.0)]
        resid = y[sel] - np.polyval(np.polyfit(np.log10(t[sel]), y[sel], 1), np.log10(t[sel]))
        assert np.max(np.abs(resid)) < 0.1 * slope   # a log law, not an exponential
    assert per[28.0] == pytest.approx(0.01, rel=0.25)  # ~1 %/decade
    assert per[45.0] / per[28.0] > 1.5                 # creep grows with temperature


@pytest.mark.slow
def test_thermal_drift_saturates_with_hysteresis_vs_temperature():
    cfg = default_twin().with_effects(only=["thermal_drift"])
    up = np.linspace(28, 45, int(240 * FS))
    T = np.concatenate([up, np.full(int(60 * FS), 45.0), up[::-1]])
    r = simulate(cfg, T, u=np.zeros(T.size))
    y = r.y_true
    n = up.size
    s1 = (y[n // 2] - y[n // 4]) / (n // 4)
    s2 = (y[n - 1] - y[3 * n // 4]) / (n // 4)
    assert 1.0 < np.max(y) < 6.0                      # a few µm over 28 -> 45 °C
    assert s2 < 0.3 * s1                              # saturation while still heating
    i_up, i_dn = n // 2, T.size - n // 2
    assert abs(y[i_dn] - y[i_up]) > 0.3               # hysteresis: branches apart at 36.5 °C


def test_delay_saturation_slew():
    base = default_twin()
    u = np.concatenate([np.zeros(10), np.full(200, 200.0)])
    T = np.full(u.size, 28.0)
    r = simulate(base.with_effects(only=["delay"], delay={"seconds": 3 / FS}), T, u=u)
    np.testing.assert_array_equal(r.u_applied[13:], 200.0)
    np.testing.assert_array_equal(r.u_applied[:13], 0.0)
    r = simulate(base.with_effects(only=["saturation"]), T, u=u)
    assert np.max(r.u_applied) == 150.0
    r = simulate(base.with_effects(only=["slew"]), T, u=u)
    assert np.max(np.diff(r.u_applied)) == pytest.approx(6e4 / FS, rel=1e-12)


def test_noise_is_seeded_and_quantised():
    cfg = default_twin().with_effects(only=["noise", "quantization"])
    T, u = np.full(5000, 28.0), np.zeros(5000)
    a, b = simulate(cfg, T, u=u, seed=7), simulate(cfg, T, u=u, seed=7)
    np.testing.assert_array_equal(a.y, b.y)
    assert np.std(a.y) == pytest.approx(0.005, rel=0.1)
    q = a.y / 0.0015
    np.testing.assert_allclose(q, np.round(q), atol=1e-9)
    assert not np.array_equal(a.y, simulate(cfg, T, u=u, seed=8).y)


def test_discrete_rst_loop_matches_continuous_design(designs):
    ctrl = designs("paper").controller              # the analytic design (shared fixture)
    cfg = default_twin().with_effects(only=[])
    n = int(0.03 * FS)
    r = simulate(cfg, np.full(n, 28.0), yr=np.full(n, 10.0), dctrl=discretize(ctrl, FS))
    cl = closed_loop(paper_plant(), ctrl)
    y_c = 10.0 * step_response(cl.nums["Tr"], cl.Delta, r.t)
    # Tustin at 20 kHz, ZOH plant: error of the order of the sampling lag (half a sample)
    assert np.max(np.abs(r.y_true - y_c)) < 0.02 * 10.0
    assert abs(r.y_true[-1] - 10.0) < 1e-3


def test_compiled_and_vm_paths_agree(monkeypatch):
    cfg = default_twin()
    u, T = _multisine(3000, 5), np.linspace(28, 30, 3000)
    a = simulate(cfg, T, u=u)
    monkeypatch.setenv("ROBRST_NO_COMPILE", "1")
    b = simulate(cfg, T, u=u)
    assert a.meta["compiled"] and not b.meta["compiled"]
    np.testing.assert_allclose(a.y_true, b.y_true, rtol=1e-12, atol=1e-12)


def test_hysteresis_sector_brackets_the_mean_slope():
    """The Bouc-Wen map's input-gain sector over a cycle: its slopes bracket the cycle's
    mean slope (1 once normalised by ``hysteresis_gain``), ``nominal (1 -+ delta)`` are the
    slopes, a wider loop (larger ``B``) a wider sector, and no loop no sector."""
    from robrst.base.errors import SpecError
    from robrst.twin.model import hysteresis_gain, hysteresis_sector

    deltas = []
    for B in (0.002, 0.0045, 0.009):
        g = hysteresis_gain(0.45, B, B, 0.0, 150.0)
        sec = hysteresis_sector(0.45, B, B, g, 0.0, 150.0)
        lo, hi = sec.slopes
        assert lo < 1.0 < hi
        assert sec.nominal * (1 - sec.delta) == pytest.approx(lo, rel=1e-12)
        assert sec.nominal * (1 + sec.delta) == pytest.approx(hi, rel=1e-12)
        deltas.append(sec.delta)
    assert deltas == sorted(deltas) and 0.05 < deltas[1] < 0.5
    assert hysteresis_sector(0.45, 0.0, 0.0, 1.0, 0.0, 150.0).delta == pytest.approx(0.0,
                                                                                    abs=1e-9)
    with pytest.raises(SpecError, match="lo < hi"):
        hysteresis_sector(0.45, 0.0045, 0.0045, 1.0, 10.0, 10.0)


def test_an_unusable_cache_still_runs_the_compiled_loop(tmp_path, monkeypatch):
    """ROBRST_CACHE a file, or a damaged library in the cache: the loop is built in a
    temporary folder and loaded from there (it ended in 'File exists' / an OSError); the
    numbers are the virtual machine's."""
    import casadi as ca

    from robrst.twin.compiled import Loop, compile_loop, compiler

    x, p, th = ca.SX.sym("x", 2), ca.SX.sym("p", 3), ca.SX.sym("th", 1)
    step = ca.Function("fz_step", [x, p, th], [ca.vertcat(0.5 * x[0] + p[0], x[0] - th * x[1]),
                                                ca.vertcat(x[0] + p[1], x[1] * p[2])])
    P = np.vstack([np.sin(np.arange(50.0)), np.cos(np.arange(50.0)), np.ones(50)])
    want, _ = Loop(step)(P, np.zeros(2), np.array([0.3]))

    def check(cache):
        monkeypatch.setenv("ROBRST_CACHE", str(cache))
        loop = compile_loop(step)
        assert loop.is_compiled == (compiler() is not None)
        got, _ = loop(P, np.zeros(2), np.array([0.3]))
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)

    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    check(blocker)
    assert blocker.read_text() == "not a folder"
    good = tmp_path / "good"
    check(good)                                   # cached there (and loaded from there)
    damaged = tmp_path / "damaged"                # the same names, damaged, never loaded
    damaged.mkdir()
    for so in good.glob("*.so"):
        (damaged / so.name).write_text("damaged")
    check(damaged)
