"""The twin's effects beyond the paper's actuator: each switchable (off by default) and
each against an independent computation.

Static maps and operators are written out here in numpy (dead zone, polynomial, play
operators, an asymmetric rate limiter) and the linear part is python-control's exact ZOH;
the cubic stiffness is integrated by SciPy's ``solve_ivp`` on a state-space realisation
of D(s) (the twin advances its own realisation by RK4).
"""

import control
import numpy as np
import pytest
from scipy import integrate, signal

from robrst.base.errors import SpecError
from robrst.core.plant import paper_plant
from robrst.twin import default_twin, parse_twin, simulate

FS = 20000.0
NEW = ("input_nonlinearity", "output_nonlinearity", "stiffness_nonlinearity", "pi_hysteresis")


def _zoh(u):
    p = paper_plant()
    sysd = control.c2d(control.tf(p.B, p.A), 1 / FS, "zoh")
    return np.ravel(control.forced_response(sysd, U=u).outputs)


def _u(n=4000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    return 60 + 50 * np.sin(2 * np.pi * 7 * t) + 8 * np.sin(2 * np.pi * rng.uniform(30, 60) * t)


def _close(y, ref, rel=2e-5):
    np.testing.assert_allclose(y, ref, rtol=0, atol=rel * np.max(np.abs(ref)))


def test_new_effects_are_off_in_the_paper_twin_and_switch_on():
    tw = default_twin()
    assert not any(tw.enabled(e) for e in NEW)
    u = _u()
    base = simulate(tw.with_effects(only=[]), np.full(u.size, 28.0), u=u).y_true
    for e in NEW:
        y = simulate(tw.with_effects(only=[e]), np.full(u.size, 28.0), u=u).y
        assert np.max(np.abs(y - base)) > 1e-3 * np.max(np.abs(base)), e


def test_input_map_dead_zone_and_polynomial():
    d, c, a2, a3 = 6.0, 55.0, 1e-3, -2e-5
    cfg = default_twin().with_effects(only=["input_nonlinearity"], input_nonlinearity={
        "dead_zone_V": d, "center_V": c, "quadratic_per_V": a2, "cubic_per_V2": a3})
    u = _u()
    e = u - c
    v = c + np.sign(e) * np.maximum(np.abs(e) - d, 0.0) + a2 * e ** 2 + a3 * e ** 3
    r = simulate(cfg, np.full(u.size, 28.0), u=u)
    _close(r.y_true, _zoh(v - v[0]) + _zoh(np.full(u.size, v[0])))


def test_sensor_map_acts_on_the_measured_output_only():
    c, a2, a3 = 30.0, 2e-3, -1e-5
    cfg = default_twin().with_effects(only=["output_nonlinearity"], output_nonlinearity={
        "center_um": c, "quadratic_per_um": a2, "cubic_per_um2": a3})
    r = simulate(cfg, np.full(4000, 28.0), u=_u())
    e = r.y_true - c
    np.testing.assert_allclose(r.y, r.y_true + a2 * e ** 2 + a3 * e ** 3, rtol=1e-12, atol=1e-12)
    _close(r.y_true, _zoh(_u()))


def _plays(u, thresholds, weights):
    p, out = np.zeros(len(thresholds)), np.empty_like(u)
    for i, x in enumerate(u):
        p = np.minimum(np.maximum(p, x - np.asarray(thresholds)), x + np.asarray(thresholds))
        out[i] = x + float(np.dot(weights, p - x))
    return out


def test_prandtl_ishlinskii_plays_from_a_virgin_memory():
    thr, w = (4.0, 12.0, 25.0), (0.1, 0.07, 0.05)
    cfg = default_twin().with_effects(only=["pi_hysteresis"], pi_hysteresis={
        "thresholds_V": thr, "weights": w})
    u = _u()
    r = simulate(cfg, np.full(u.size, 28.0), u=u)
    _close(r.y_true, _zoh(_plays(u, thr, w)))


def test_asymmetric_slew_rate():
    up, down = 2.0e4, 5.0e3
    cfg = default_twin().with_effects(only=["slew"], slew={"V_per_s": up, "V_per_s_down": down})
    u = np.repeat([10.0, 100.0, 20.0, 90.0], 1000)
    v, y = np.empty_like(u), u[0]
    for i, x in enumerate(u):
        y += min(max(x - y, -down / FS), up / FS)
        v[i] = y
    r = simulate(cfg, np.full(u.size, 28.0), u=u)
    np.testing.assert_allclose(r.u_applied, v, rtol=0, atol=1e-9)
    _close(r.y_true, _zoh(v - u[0]) + _zoh(np.full(u.size, u[0])))


def test_cubic_stiffness_against_an_ode_solver():
    k3 = 3e-6
    cfg = default_twin().with_effects(only=["stiffness_nonlinearity"],
                                      stiffness_nonlinearity={"cubic_per_um2": k3})
    n = 1500
    u = np.repeat([80.0, 150.0, 40.0], n // 3)
    p = paper_plant()
    A, B, C, D = signal.tf2ss(p.B, p.A)
    g = p.dc_gain

    def f(t, x):
        k = min(int(t * FS), n - 1)
        y = float((C @ x)[0])
        return A @ x + B[:, 0] * (u[k] - k3 * y ** 3 / g)

    sol = integrate.solve_ivp(f, (0, n / FS), np.zeros(A.shape[0]), t_eval=np.arange(n) / FS,
                              rtol=1e-10, atol=1e-12, max_step=0.25 / FS)
    ref = (C @ sol.y)[0]
    r = simulate(cfg, np.full(n, 28.0), u=u)
    _close(r.y_true, ref, rel=1e-4)
    assert np.max(np.abs(r.y_true - _zoh(u))) > 0.01 * np.max(np.abs(ref))  # it stiffens


def test_play_weights_must_match_thresholds():
    with pytest.raises(SpecError, match="one weight per threshold"):
        parse_twin({"pi_hysteresis": {"thresholds_V": [1.0, 2.0], "weights": [0.1]}}, "t.toml")
