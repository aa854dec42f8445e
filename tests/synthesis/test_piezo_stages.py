"""The issue's numbers on seeded random piezo stages (:mod:`piezo_stages`): 2nd- and
4th-order, 300-3,000 Hz, damping 0.005-0.05, 0-2 samples of delay, 15-45 °C, with
``Msd_max`` (1.1 x the open loop's peak), a damping floor (0.9 x the plant's own) and
``overshoot_max_pct = 10``: every one certifies, and python-control on the unscaled loop
(:mod:`loopcheck`, 13 temperatures, continuous and sampled loop) finds the reference step
within its spec, the damping above the floor and |B S/Delta| within its bound.
"""

import numpy as np
import pytest

import loopcheck
import piezo_stages
from robrst.design import run_problem
from robrst.problem.files import parse_problem


def _check(seed, order, multistart):
    p = parse_problem(piezo_stages.stage_doc(seed, order), f"<stage{seed}>")
    res = run_problem(p, multistart=multistart)
    assert res.certified, (seed, res.best_achievable)
    sp = p.specs
    for T in np.linspace(15.0, 45.0, 13):
        m = p.family.at(T)
        c = loopcheck.continuous(m, res.controller)
        s = loopcheck.sampled(m, res.controller, sp.sample_rate_hz, sp.delay_samples)
        for f, tol in ((c, 0.05), (s, 1e-6)):
            assert f.damping >= sp.damping_min * (1 - 1e-3), (seed, T, f.damping)
            assert f.Msd <= sp.Msd_max * (1 + 1e-3), (seed, T, f.Msd)
            assert f.overshoot_pct <= sp.overshoot_max_pct * (1 + 1e-3) + tol, (seed, T)
    return res


@pytest.mark.slow
@pytest.mark.parametrize("seed,order", [(1, 2), (2, 4)])
def test_piezo_stages_certify_and_meet_their_specs(seed, order):
    """The default path (the global phase): the local run alone from the problem's poles
    leaves stage 1 at 20.6 % overshoot against its 10 %."""
    _check(seed, order, multistart=None)


@pytest.mark.large
@pytest.mark.parametrize("seed", range(3, 13))
def test_piezo_stages_certify_large(seed):
    _check(seed, None, multistart=True)
