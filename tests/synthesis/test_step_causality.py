"""A settling time below the sampled loop's dead time is infeasible, by causality; a step
voltage below what holds the step (``step_um / D(0)``) too.

The fact the proof rests on is checked independently of robrst: python-control's ZOH model
of the plant behind ``z^-d`` in an RST loop with a Tustin controller (here the analytic
design's) answers a reference step with exactly 0 at the samples ``0 .. d`` and a nonzero
value at sample ``d + 1``; robrst's certificate then never reports a sampled settling time
below ``(d + 1) / fs``.  The proof fires only below that dead time (beyond the
certificate's tolerance), names it, and the design answers "infeasible" at once instead of
"not found" after a synthesis (9 s CPU on the reproducer's stage, which asked 50 µs behind
80 µs of dead time).

The voltage: python-control's step of ``u = A T / Delta`` (continuous loop, unscaled
polynomials) ends at ``1 / D(0)`` per µm, so its peak is at least that, and the
certificate's ``step_u_peak_V`` is never below ``step_um / |D(0)|``.

Reproducer: ``tests/repro/settling_below_dead_time.toml``.
"""

import json
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import control
import numpy as np
import pytest

from robrst.certificate.completion import with_time_domain
from robrst.certificate.proof import certify_problem
from robrst.design import analytic_design, run_problem
from robrst.problem.files import load_problem
from robrst.problem.records import with_defaults
from robrst.synthesis.feasibility import prove_step_infeasible

REPRO = Path(__file__).resolve().parents[1] / "repro" / "settling_below_dead_time.toml"


def _problem(**specs):
    p = load_problem(REPRO)
    return replace(p, specs=replace(p.specs, **specs))


@pytest.mark.parametrize("delay", [0, 1, 2])
def test_the_sampled_output_is_zero_until_the_dead_time_whatever_the_controller(delay):
    """python-control: ZOH plant behind z^-d, Tustin controller, the step's first samples."""
    p = _problem(delay_samples=delay)
    fs = p.specs.sample_rate_hz
    ctrl = analytic_design(p).controller
    m = p.family.models[0]
    G = control.c2d(control.tf(m.B, m.A), 1 / fs, "zoh")
    G = G * control.tf([1.0], [1.0] + [0.0] * delay, 1 / fs)
    R = control.c2d(control.tf(ctrl.R, ctrl.S), 1 / fs, "tustin")
    T = control.c2d(control.tf(ctrl.T, ctrl.S), 1 / fs, "tustin")
    np.testing.assert_allclose(R.den[0][0], T.den[0][0])           # one S(z)
    gn, gd = G.num[0][0], G.den[0][0]
    # y / r = G T / (S + G R) = gn T(z) / (gd S(z) + gn R(z)) (no cancelled integrator)
    num = np.polymul(gn, T.num[0][0])
    den = np.polyadd(np.polymul(gd, R.den[0][0]), np.polymul(gn, R.num[0][0]))
    loop = control.tf(num, den, 1 / fs)
    k = np.arange(delay + 40)
    y = control.forced_response(loop, T=k / fs, U=np.ones(k.size)).outputs
    final = np.polyval(num, 1.0) / np.polyval(den, 1.0)
    assert abs(final - 1.0) < 1e-6                     # the loop tracks the step
    assert np.all(np.abs(y[:delay + 1]) <= 1e-12)       # 0 at the dead samples
    assert abs(y[delay + 1]) > 1e-6
    if delay == 2:     # the analytic design does not hold the loop behind two samples
        return
    # robrst's certificate: the sampled settling time is never below the dead time
    pd = with_defaults(replace(p, specs=replace(p.specs, settling_time_max_s=1.0)))
    cert = with_time_domain(pd, certify_problem(pd, ctrl), ctrl)
    settle = [mc.sampled.value("settling_time_s") for mc in cert.models
              if mc.sampled is not None and mc.sampled.step is not None]
    assert settle and min(settle) >= (delay + 1) / fs * (1 - 1e-12)


def test_the_proof_fires_below_the_dead_time_only():
    p = _problem(delay_samples=1)
    dead = 2 / p.specs.sample_rate_hz
    tol = p.solver.cert_tol
    proof = prove_step_infeasible(replace(p, specs=replace(p.specs, settling_time_max_s=0.9 * dead)))
    assert len(proof) == 1 and proof[0].dead_samples == 2
    assert proof[0].least == pytest.approx(dead, rel=1e-15)
    assert proof[0].as_dict()["kind"] == "step"
    assert "8e-05 s" in proof[0].reason and "delay_samples = 1" in proof[0].reason
    # at the dead time, or within the certificate's tolerance below it: nothing proved
    for ts in (dead, dead / (1 + 0.5 * tol), 10 * dead):
        assert prove_step_infeasible(replace(p, specs=replace(p.specs,
                                                              settling_time_max_s=ts))) == ()
    # the continuous loop alone has no dead time
    cont = replace(p.specs, settling_time_max_s=0.1 * dead, sample_rate_hz=None,
                   delay_samples=0)
    assert prove_step_infeasible(replace(p, specs=cont)) == ()
    # without integral action the final value may be 0: nothing proved
    no_int = replace(p, specs=replace(p.specs, settling_time_max_s=0.1 * dead),
                     controller=replace(p.controller, S_fixed=(1.0,)))
    assert prove_step_infeasible(no_int) == ()


def test_a_design_with_a_settling_time_below_the_dead_time_is_named_infeasible_at_once():
    """Through the command line (the JSON contract: ``kind`` on every proof); the answer
    was "not found" after a 9 s synthesis."""
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "robrst", "design", str(REPRO), "--json"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 1, out.stderr
    d = json.loads(out.stdout)
    f = d["feasibility"]
    assert f["status"] == "infeasible"
    assert f["proofs"][0]["kind"] == "step"
    assert f["proofs"][0]["specs"] == ["settling_time_max_s"]
    assert f["proofs"][0]["least"] == pytest.approx(2 / 25000.0)
    assert "settling_time_max_s" in f["expressed"]
    assert "synthesis was skipped" in f["note"]
    assert time.perf_counter() - t0 < 30.0
    # a frequency proof's entry says its kind too
    r = run_problem(_problem(settling_time_max_s=None, Mt_max=0.5), analyses=False)
    assert r.feasibility.status == "infeasible"
    assert r.feasibility.as_dict()["proofs"][0]["kind"] == "frequency"


def test_the_step_voltage_ends_at_step_um_over_the_static_gain():
    """python-control: the voltage's step ends at ``1 / D(0)`` per µm on every member; the
    certificate's step voltage peak is at least ``step_um / |D(0)|``."""
    p = _problem(settling_time_max_s=None, step_u_max_V=1e6, step_um=3.0)
    ctrl = analytic_design(p).controller
    pd = with_defaults(p)
    cert = with_time_domain(pd, certify_problem(pd, ctrl), ctrl)
    checked = 0
    for m in p.family.models:
        delta = np.polyadd(np.polymul(m.A, ctrl.S), np.polymul(m.B, ctrl.R))
        u = control.tf(np.polymul(m.A, ctrl.T), delta)
        dc = np.polyval(m.B, 0.0) / np.polyval(m.A, 0.0)
        assert float(np.real(control.dcgain(u))) == pytest.approx(1.0 / dc, rel=1e-9)
        fig = [mc for mc in cert.models if mc.label == m.label][0].continuous
        if fig.step is not None:
            assert fig.value("step_u_peak_V") >= 3.0 / abs(dc) * (1 - 1e-12)
            checked += 1
    assert checked


def test_a_step_voltage_below_what_holds_the_step_is_infeasible():
    p = _problem(settling_time_max_s=None, step_um=2.0)
    dc = [abs(np.polyval(m.B, 0.0) / np.polyval(m.A, 0.0)) for m in p.family.models]
    least = 2.0 / min(dc)
    low = replace(p, specs=replace(p.specs, step_u_max_V=0.9 * least))
    proof = prove_step_infeasible(low)
    assert len(proof) == 1 and proof[0].spec == "step_u_max_V"
    assert proof[0].least == pytest.approx(least, rel=1e-12)
    assert proof[0].model == p.family.models[int(np.argmin(dc))].label
    for u in (least, least / (1 + 0.5 * p.solver.cert_tol), 3 * least):
        assert prove_step_infeasible(replace(p, specs=replace(p.specs, step_u_max_V=u))) == ()
    r = run_problem(low, analyses=False)
    assert not r.certified and r.feasibility.status == "infeasible"
    assert r.feasibility.proofs[0].spec == "step_u_max_V"
