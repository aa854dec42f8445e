"""A decay floor above ``1/tau`` on a family whose creep vanishes in its interval is met by
no controller (:func:`robrst.synthesis.feasibility.prove_region_infeasible`).

The fact the proof rests on is checked independently of robrst: the paper's D(s), written
here, times the creep lag-lead ``(tau s + 1 + kappa)/(tau s + 1)`` with a small ``kappa``,
in a loop with controllers that have nothing to do with the creep (the analytic design,
and random perturbations of its R and S): ``numpy.roots`` of ``A S + B R`` on the unscaled
polynomials finds a root within ``O(kappa)`` of ``-1/tau``, and python-control's ZOH loop
with the Tustin controller a root within as little of ``exp(-h/tau)``.  The proof then
answers at once (the analytic start reported, "infeasible") where the synthesis ran 40 s
to "not found" (a mutated `paper_robust.toml` with `decay_min = 3`), and stays silent
where it proves nothing.
"""

import time
from dataclasses import replace

import control
import numpy as np
import pytest

from robrst.design import analytic_design, run_problem
from robrst.problem.files import load_problem, parse_problem
from robrst.synthesis.feasibility import prove_region_infeasible

TAU = 0.5
B_PAPER = [107.0, 107.0 * 1.4e4, 107.0 * 6.1e7]
A_PAPER = np.polymul([1.0, 651.0], [1.0, 42.0, 1.5e7])


def _with_decay(sigma, **family):
    p = load_problem("paper_robust")
    p = replace(p, specs=replace(p.specs, decay_min=sigma))
    if family:
        fam = p.family
        from robrst.core.family import parametric_family
        c = replace(fam.thermal, **family)
        p = replace(p, family=parametric_family(fam.nominal, list(fam.temperatures), c))
    return p


@pytest.mark.filterwarnings("ignore::scipy.linalg.LinAlgWarning")
@pytest.mark.parametrize("kappa", [1e-4, 1e-6])
def test_a_vanishing_creep_pair_holds_a_closed_loop_root_whatever_the_controller(kappa):
    ctrl = analytic_design(load_problem("paper_robust")).controller
    R0, S0 = np.asarray(ctrl.R, float), np.asarray(ctrl.S, float)
    B = np.polymul(B_PAPER, [TAU, 1.0 + kappa])
    A = np.polymul(A_PAPER, [TAU, 1.0])
    rng = np.random.default_rng(7)
    for trial in range(6):
        jitter = 1.0 if trial == 0 else 1.0 + 0.3 * rng.standard_normal()
        R = R0 * jitter * (1.0 + 0.05 * rng.standard_normal(R0.size) * (trial > 0))
        S = S0 * (1.0 + 0.05 * rng.standard_normal(S0.size) * (trial > 0))
        S[-1] = 0.0                                   # keep the integrator
        roots = np.roots(np.polyadd(np.polymul(A, S), np.polymul(B, R)))
        near = np.min(np.abs(roots + 1.0 / TAU))
        assert near < 50 * kappa / TAU, (trial, near)
    # the sampled loop: ZOH plant, Tustin controller (python-control)
    h = 1.0 / 20000.0
    G = control.c2d(control.tf(B, A), h, "zoh")
    K = control.c2d(control.tf(R0, S0), h, "tustin")
    gn, gd = G.num[0][0], G.den[0][0]
    kn, kd = K.num[0][0], K.den[0][0]
    z = np.roots(np.polyadd(np.polymul(gd, kd), np.polymul(gn, kn)))
    decay = -np.log(np.abs(z)) / h
    # (the z-plane roots sit within 1e-4 of 1 with coefficients up to 1e20: 1 % resolved)
    assert np.min(np.abs(decay - 1.0 / TAU)) < 0.01 / TAU + 100 * kappa / TAU


def test_a_decay_floor_above_the_creep_rate_is_infeasible_at_once():
    p = _with_decay(3.0)
    proofs = prove_region_infeasible(p)
    assert len(proofs) == 1
    d = proofs[0].as_dict()
    assert d["kind"] == "region" and d["specs"] == ["decay_min"]
    assert d["limit"] == pytest.approx(1.0 / TAU) and d["temperature_C"] == 28.0
    t = time.process_time()
    res = run_problem(p)
    assert time.process_time() - t < 20.0
    assert not res.certified and res.feasibility.status == "infeasible"
    assert "decay_min" in res.feasibility.expressed
    assert res.feasibility.proofs[0].reason.startswith("the family's creep lag-lead")
    # the certificate of the controller reported agrees: a root decays at about 1/tau
    lows = [v for v in res.certificate.violations if v.quantity.startswith("closed-loop decay")]
    assert lows and min(v.value for v in lows) == pytest.approx(1.0 / TAU, rel=1e-2)


@pytest.mark.parametrize("case", ["below_the_rate", "creep_never_zero", "reference_below",
                                  "no_creep", "explicit"])
def test_the_proof_is_silent_where_it_proves_nothing(case):
    if case == "below_the_rate":
        p = _with_decay(1.9)
    elif case == "creep_never_zero":          # kappa >= 0.01 everywhere
        p = _with_decay(3.0, creep_at_ref=0.01)
    elif case == "reference_below":           # kappa(28 °C) = 0.004 x 8 K > 0
        p = _with_decay(3.0, reference_C=20.0)
    elif case == "no_creep":
        p = _with_decay(3.0, creep_per_K=0.0)
    else:
        doc = {"plant": {"B": [1.0], "A": [1.0, 2.0, 1.0], "temperature_C": 20.0},
               "family": {"reference_C": 20.0, "models": [
                   {"temperature_C": 20.0, "B": [1.0], "A": [1.0, 2.0, 1.0]},
                   {"temperature_C": 30.0, "B": [1.1], "A": [1.0, 2.0, 1.0]}]},
               "poles": {"wn": 1.0, "zeta": 1.0}, "controller": {"extra_degree": 1},
               "specs": {"Ms_max": 2.0, "decay_min": 100.0},
               "solver": {"method": "nlp"}}
        p = parse_problem(doc, "<explicit>")
    assert prove_region_infeasible(p) == ()


def test_a_slow_pole_at_a_creep_pair_that_never_vanishes_is_named():
    """Strength 0.01 everywhere: no proof; the "not found" of a controller whose slow pole
    sits at the pair (the analytic design of the vanishing family: a root at the zero,
    -2.02 rad/s, on every member) names the creep pair."""
    from robrst.certificate.proof import certify_problem
    from robrst.problem.records import with_defaults
    from robrst.synthesis.feasibility import feasibility_verdict

    ctrl = analytic_design(_with_decay(3.0)).controller
    p = with_defaults(_with_decay(3.0, creep_at_ref=0.01))
    verdict = feasibility_verdict(p, certify_problem(p, ctrl), ctrl)
    assert verdict.status == "not_found"
    assert "decaying at 2.02 < 3 rad/s" in verdict.mode
    assert "creep lag-lead, pole at -2 rad/s and zero at -2.02 rad/s" in verdict.mode
