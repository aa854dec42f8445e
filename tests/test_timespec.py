"""Time-domain specs: exact step responses against closed forms and python-control.

The independent references: the closed-form step response of a second-order system,
and python-control's ``step_response`` of the same loops built from transfer functions
(continuous: ``feedback``; sampled: ``c2d`` ZOH plant, Tustin controller), in a scaled
time ``p = s / w0`` so python-control sees O(1) coefficients.
"""

import control
import numpy as np
import pytest

from robrst import poly
from robrst.rst import closed_loop, discretize
from robrst.sampled import sampled_plant
from robrst.timespec import step_metrics

FS = 20000.0


@pytest.mark.parametrize("zeta", [0.2, 0.5, 0.8])
def test_second_order_overshoot_peak_time_and_settling_are_exact(zeta):
    wn = 700.0
    m = step_metrics([wn * wn], [1.0, 2 * zeta * wn, wn * wn])
    wd = wn * np.sqrt(1 - zeta ** 2)
    assert m.overshoot_pct == pytest.approx(100 * np.exp(-np.pi * zeta / np.sqrt(1 - zeta ** 2)),
                                            rel=1e-7)
    assert m.peak_time_s == pytest.approx(np.pi / wd, rel=1e-6)
    t = np.linspace(0, 20 / (zeta * wn), 2_000_001)          # closed form, dense
    y = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    ts = t[np.flatnonzero(np.abs(y - 1) > 0.02)[-1]]
    assert ts <= m.settling_time_s <= ts + 2e-3 / wn           # refined, never early


def _scaled(num, den, w0):
    """``num(w0 p), den(w0 p)`` as a python-control tf (coefficients divided alike)."""
    n, d = poly.to_scaled(poly.trim(num), w0), poly.to_scaled(poly.trim(den), w0)
    return control.tf(n / d[0], d / d[0])


def _loops(plant, ctrl):
    """python-control's y/r and u/r of the RST loop ``S u = T r - R y`` (scaled time)."""
    w0 = poly.natural_scale(closed_loop(plant, ctrl).Delta)
    P, K = _scaled(plant.B, plant.A, w0), _scaled(ctrl.R, ctrl.S, w0)
    F = _scaled(ctrl.T, ctrl.S, w0)
    return control.minreal(F * control.feedback(P, K), verbose=False), \
        control.minreal(F * control.feedback(1, P * K), verbose=False), w0


def _metrics(t, y, final=1.0):
    """Overshoot [%] over ``final`` (1: the integrator) and the 2 % settling time."""
    over = 100 * max(0.0, (np.max(y) - final) / final)
    out = np.flatnonzero(np.abs(y - final) > 0.02 * abs(final))
    return over, (t[out[-1] + 1] if out.size else 0.0)


@pytest.mark.parametrize("T", [28.0, 45.0])
def test_continuous_loop_against_python_control(designs, T):
    res = designs("paper_robust")
    plant, ctrl = res.problem.family.at(T), res.controller
    Gy, Gu, w0 = _loops(plant, ctrl)
    t = np.linspace(0, 0.02, 40_001)                 # 20 ms: settled (but for the creep)
    _, y = control.step_response(Gy, T=t * w0)
    _, u = control.step_response(Gu, T=t * w0)
    cl = closed_loop(plant, ctrl)
    my = step_metrics(cl.nums["Tr"], cl.Delta)
    mu = step_metrics(poly.pmul(plant.A, ctrl.T), cl.Delta)
    over, ts = _metrics(t, y)
    assert my.overshoot_pct == pytest.approx(over, abs=2e-4)
    assert my.settling_time_s == pytest.approx(ts, abs=2 * (t[1] - t[0]))
    assert mu.max_abs == pytest.approx(np.max(np.abs(u)), rel=1e-4)
    rec = next(m for m in res.certificate.models if m["temperature_C"] == T)
    assert rec["overshoot_pct"] == pytest.approx(my.overshoot_pct, rel=1e-9, abs=1e-12)
    assert rec["step_u_peak_V"] == pytest.approx(mu.max_abs * res.problem.specs.step_um, rel=1e-9)


def _sampled_steps(plant, ctrl, n):
    """python-control's sampled loop (ZOH plant, Tustin controller): y and u of a unit step."""
    w0 = poly.natural_scale(plant.A)
    h = w0 / FS
    Pd = control.c2d(control.ss(_scaled(plant.B, plant.A, w0)), h, "zoh")
    Kd = control.c2d(control.ss(_scaled(ctrl.R, ctrl.S, w0)), h, "tustin")
    Fd = control.c2d(control.ss(_scaled(ctrl.T, ctrl.S, w0)), h, "tustin")
    _, y = control.step_response(Fd * control.feedback(Pd, Kd), T=np.arange(n) * h)
    _, u = control.step_response(Fd * control.feedback(1, Pd * Kd), T=np.arange(n) * h)
    return np.ravel(y), np.ravel(u)


@pytest.mark.parametrize("T", [28.0, 45.0])
def test_sampled_loop_against_python_control(designs, T):
    """ZOH plant, Tustin controller (reference and feedback paths), at the samples."""
    res = designs("paper_robust")
    plant, ctrl = res.problem.family.at(T), res.controller
    n = 4000                                          # 0.2 s
    y, u = _sampled_steps(plant, ctrl, n)
    pw = sampled_plant(plant, FS)
    cl = closed_loop(pw, ctrl)
    my = step_metrics(cl.nums["Tr"], cl.Delta, FS)
    mu = step_metrics(poly.pmul(pw.A, ctrl.T), cl.Delta, FS)
    over, ts = _metrics(np.arange(n) / FS, np.ravel(y))
    assert my.overshoot_pct == pytest.approx(over, abs=1e-6)
    assert my.settling_time_s == pytest.approx(ts, abs=1e-12)
    assert mu.max_abs == pytest.approx(np.max(np.abs(u)), rel=1e-6)


def test_exported_controller_rolls_off_at_nyquist(designs):
    """The discretised controller (what a DSP runs): |u/y| at Nyquist is zero."""
    res = designs("paper_robust")
    dc = discretize(res.controller, FS)
    zI = -np.eye(dc.A.shape[0])                       # z = -1
    K = dc.C @ np.linalg.solve(zI - dc.A, dc.B) + dc.D
    k_dc = abs(res.controller.R[-1] / res.controller.S[-2]) / 1.0   # ~ integral gain scale
    assert abs(K[0, 1]) <= 1e-9 * k_dc                # feedback path y -> u
    assert abs(K[0, 0]) <= 1e-9 * k_dc                # reference path r -> u
    assert len(res.controller.R) < len(res.controller.S)


def test_relaxing_the_band_bound_keeps_the_time_domain_specs():
    """|T| <= 1.2 over the band instead of 1.0: the robust loop leaves a nominal closed-loop
    pair damped 0.488 (< T_cancel_damping = 0.5) that would overshoot 12 %; the reference
    path then cancels it too, so relaxing a spec never loses the certificate nor the gain.
    Checked on python-control's sampled loop (ZOH plant, Tustin controller) at 28 and 45 °C."""
    from dataclasses import replace

    from robrst.design import run_problem
    from robrst.spec import load_problem

    base = load_problem("paper_robust")
    res = run_problem(replace(base, specs=replace(base.specs, T_resonance_max=1.2)))
    assert res.certified and res.integral_gain >= 751.8 * (1 - 1e-3)
    sp = res.problem.specs
    for T in (28.0, 45.0):
        plant, ctrl = res.problem.family.at(T), res.controller
        n = 4000
        y, _ = _sampled_steps(plant, ctrl, n)
        over, ts = _metrics(np.arange(n) / FS, np.ravel(y))
        assert over <= sp.overshoot_max_pct * (1 + 1e-3)
        assert ts <= sp.settling_time_max_s * (1 + 1e-3)
