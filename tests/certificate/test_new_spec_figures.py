"""The certificate's figures of the newer specs against an independent computation.

``Msd`` (|B S/Delta|), ``Mry`` (|B T/Delta|), the least damping and decay of the closed-loop
poles (the sampled loop's mapped to s by fs ln z) and the reference-step overshoot, on
every checked model of the ringing stage (tests/repro/certified_ringing_stage.toml) and
both loops, against :mod:`loopcheck` (python-control in state space, ZOH and Tustin by
``control.c2d``, dense grids of the unscaled polynomials).  Then the verdicts: a floor
above what a controller achieves is a violation of kind ``below``, named in the ratios;
the pole-region statement says what was proved.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import loopcheck
from robrst.certificate.proof import certify_problem
from robrst.core.rst import RSTController
from robrst.design import analytic_design
from robrst.problem.files import load_problem

STAGE = Path(__file__).resolve().parents[1] / "repro" / "certified_ringing_stage.toml"
# the ringing controller (Ms_max 2.01) and a well damped one
RINGING = RSTController(R=np.array([146.515, 19535.0, 3.60808e9]),
                        S=np.array([1.0, 84095.6, 0.0]), T=np.array([3.60808e9]))


@pytest.fixture(scope="module")
def stage():
    p = load_problem(STAGE)
    return replace(p, specs=replace(p.specs, Msd_max=50.0, Mry_max=50.0, decay_min=5.0,
                                    overshoot_max_pct=100.0))


@pytest.mark.parametrize("which", [pytest.param("ringing", marks=pytest.mark.slow), "analytic"])
def test_figures_match_python_control(stage, which):
    ctrl = RINGING if which == "ringing" else analytic_design(stage).controller
    cert = certify_problem(stage, ctrl)
    assert len(cert.models) >= 35
    for rec in cert.models[::4]:
        m = stage.family.at(rec.temperature_C)
        c = loopcheck.continuous(m, ctrl)
        s = loopcheck.sampled(m, ctrl, stage.specs.sample_rate_hz, stage.specs.delay_samples)
        for got, ref in ((rec.continuous, c), (rec.sampled, s)):
            assert got.damping == pytest.approx(ref.damping, rel=1e-7, abs=1e-12)
            assert got.decay_rad_s == pytest.approx(ref.decay, rel=1e-7)
            for k in ("Msd", "Mry"):         # exact peaks: never below the grid, attained
                v, g = getattr(got, k), getattr(ref, k)
                assert g <= v * (1 + 1e-9) and v <= g * (1 + 1e-6), (k, v, g)
        # the step: proved upper bounds, the continuous grid within its resolution
        assert rec.continuous.step.overshoot_pct >= c.overshoot_pct - 1e-6
        assert rec.continuous.step.overshoot_pct <= c.overshoot_pct + 0.2
        assert rec.sampled.step.overshoot_pct == pytest.approx(s.overshoot_pct, abs=1e-6)


def test_lower_bounds_are_violations_named_in_the_ratios(stage):
    p = replace(stage, specs=replace(stage.specs, damping_min=0.05, decay_min=200.0))
    cert = certify_problem(p, RINGING)
    assert not cert.certified
    kinds = {(v.quantity, v.loop) for v in cert.violations if v.kind == "below"}
    assert ("closed-loop damping", "continuous") in kinds
    assert ("closed-loop decay rate [rad/s]", "continuous") in kinds
    worst = min(loopcheck.continuous(p.family.at(T), RINGING).damping for T in (15.0, 45.0))
    r = cert.ratios()
    assert r["damping"] >= 0.05 / worst * (1 - 1e-6) and r["damping"] > 1
    assert r["decay_rad_s"] > 1
    for v in cert.violations:
        if v.kind == "below":
            assert v.value < v.bound and v.ratio > 1
            assert "<" in v.describe()


def test_default_floor_is_the_plant_damping_share(stage):
    p = replace(stage, specs=replace(stage.specs, damping_min=None))
    floor, source = p.specs.damping_floor(p.family)
    zeta = min(loopcheck.plant_damping(m) for m in p.family.models)
    assert source == "default" and floor == pytest.approx(min(0.1, zeta), rel=1e-12)
    cert = certify_problem(p, RINGING)
    region = cert.interval.pole_region
    assert region.damping_source == "default"
    assert region.damping_min == pytest.approx(floor)
    assert "damping >=" in region.statement
    off = replace(stage, specs=replace(stage.specs, damping_min=0.0))
    assert off.specs.damping_floor(off.family) == (None, "specs")
    region = certify_problem(off, RINGING).interval.pole_region
    assert region is None or region.damping_min is None


@pytest.mark.slow
def test_region_proof_between_temperatures_against_a_dense_sweep(stage):
    """When the certificate proves the pole region between its points, a dense sweep of
    401 temperatures (python-control) finds every pole in the region too."""
    p = replace(stage, specs=replace(stage.specs, damping_min=0.009, decay_min=40.0))
    cert = certify_problem(p, RINGING)
    proof = cert.interval.pole_region_proof
    assert proof is not None and proof.proved
    assert cert.interval.pole_region.proved_between_points
    for T in np.linspace(15.0, 45.0, 401):
        c = loopcheck.continuous(p.family.at(T), RINGING, horizon_s=1e-3, n_t=11)
        assert c.damping >= 0.009 * (1 - 1e-3) and c.decay >= 40.0 * (1 - 1e-3), T
