"""The scenario counts against the published formulas, recomputed independently.

* Campi & Garatti (2008), Theorem 1 (convex programs, d decision variables): the solution of
  N scenarios violates more than epsilon with probability at most
  beta = sum_{i<d} C(N, i) eps^i (1 - eps)^(N - i).  Checked against the closed form for
  d = 1 ((1 - eps)^N), the exact binomial sum in mpmath, and the explicit sufficient
  count N >= (2 / eps) (ln(1 / beta) + d) that follows from it (Campi & Garatti 2008,
  Sec. 5; Calafiore 2010).
* Campi, Garatti & Ramponi (2018), Theorem 1 (non-convex, a-posteriori): epsilon(k) =
  1 - t(k), t(k) the root in (0, 1) of beta/N sum_{i=k}^{N-1} C(i, k) t^(i-k) = C(N, k)
  t^(N-k).  Recomputed with mpmath's root finder at 50 digits.
"""

import math

import mpmath
import numpy as np
import pytest

from robrst.synthesis.scenario import (convex_confidence, convex_scenario_count,
                                       nonconvex_epsilon, scenario_count)


def _mp_convex_beta(N, d, eps):
    eps = mpmath.mpf(eps)
    return sum(mpmath.binomial(N, i) * eps ** i * (1 - eps) ** (N - i) for i in range(d))


def _mp_epsilon(k, N, beta):
    """epsilon(k) by bisection on t in (0, 1) at 60 digits (f > 0 near 0, f(1) < 0)."""
    with mpmath.workdps(60):
        beta = mpmath.mpf(beta)
        coef = [mpmath.binomial(i, k) for i in range(k, N)]
        cN = mpmath.binomial(N, k)

        def f(t):
            return beta / N * sum(c * t ** j for j, c in enumerate(coef)) - cN * t ** (N - k)

        lo, hi = mpmath.mpf(0), mpmath.mpf(1)
        for _ in range(200):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if f(mid) > 0 else (lo, mid)
        return 1 - (lo + hi) / 2


@pytest.mark.parametrize("eps, beta", [(0.05, 0.01), (0.01, 1e-6), (0.1, 0.05)])
def test_convex_count_of_one_variable_is_the_closed_form(eps, beta):
    """d = 1: beta = (1 - eps)^N, so N = ceil(ln beta / ln(1 - eps))."""
    assert convex_scenario_count(eps, beta, 1) == math.ceil(math.log(beta) / math.log(1 - eps))


@pytest.mark.parametrize("eps, beta, d", [(0.05, 0.01, 12), (0.05, 1e-3, 5), (0.02, 0.01, 20)])
def test_convex_count_is_the_smallest_N_of_the_binomial_tail(eps, beta, d):
    N = convex_scenario_count(eps, beta, d)
    assert float(_mp_convex_beta(N, d, eps)) <= beta < float(_mp_convex_beta(N - 1, d, eps))
    assert convex_confidence(N, d, eps) == pytest.approx(float(_mp_convex_beta(N, d, eps)),
                                                          rel=1e-9)
    # the explicit sufficient count of the literature is an upper bound on the exact one
    assert N <= 2 / eps * (math.log(1 / beta) + d)


@pytest.mark.parametrize("k, N, beta", [(0, 50, 0.01), (3, 120, 0.01), (12, 200, 1e-3),
                                        (5, 550, 0.01), (40, 300, 0.05)])
def test_nonconvex_epsilon_solves_the_published_equation(k, N, beta):
    assert nonconvex_epsilon(k, N, beta) == pytest.approx(float(_mp_epsilon(k, N, beta)),
                                                          rel=1e-9, abs=1e-12)


def test_nonconvex_epsilon_grows_with_k_and_is_one_at_N():
    eps = [nonconvex_epsilon(k, 300, 0.01) for k in range(0, 60, 5)]
    assert all(a < b for a, b in zip(eps, eps[1:]))
    assert nonconvex_epsilon(300, 300, 0.01) == 1.0


@pytest.mark.parametrize("eps, beta, d", [pytest.param(0.05, 0.01, 12, marks=pytest.mark.slow),
                                          pytest.param(0.05, 0.01, 4, marks=pytest.mark.slow),
                                          (0.1, 0.001, 8)])
def test_scenario_count_is_the_smallest_N_meeting_the_target_at_d(eps, beta, d):
    N = scenario_count(eps, beta, d)
    assert float(_mp_epsilon(d, N, beta)) <= eps < float(_mp_epsilon(d, N - 1, beta))
    # the non-convex a-posteriori count at k = d needs more draws than the convex a-priori
    assert N >= convex_scenario_count(eps, beta, d)


def _fleet(n, k, d, target=0.95, confidence=0.99):
    from robrst.synthesis.scenario import ActuatorCheck, FleetDesign

    checks = tuple(ActuatorCheck(index=i, ratio=0.9, certified=True) for i in range(n))
    return FleetDesign(method="scenario", names=("gain",), values=np.ones((n, 1)),
                       n_scenarios=n, decision_variables=d, yield_target=target,
                       confidence=confidence, support=tuple(range(k)), checks=checks,
                       rounds=3, nominal_integral_gain=1.0, integral_gain=0.9,
                       wall_time_s=1.0)


@pytest.mark.parametrize("n, k, d", [(152, 7, 6), (294, 9, 4), (200, 6, 13)])
def test_a_missed_target_states_the_draws_it_needs_at_its_k(n, k, d):
    """The guarantee at the compression set's size k misses the target: the draws stated
    are the smallest N whose epsilon(k) (mpmath, 60 digits) meets it; the summary says so."""
    from robrst.report.text import fleet_summary

    f = _fleet(n, k, d)
    assert f.target_met is False
    N = f.scenarios_for_target
    eps, beta = 0.05, 0.01
    assert float(_mp_epsilon(k, N, beta)) <= eps < float(_mp_epsilon(k, N - 1, beta))
    assert N > n and f.as_dict()["scenarios_for_target"] == N
    text = fleet_summary(f)
    assert f"the target needs N = {N} drawn actuators for a compression set of k = {k}" in text


def test_a_met_target_states_no_draws():
    f = _fleet(600, 3, 4)
    assert f.target_met is True and f.scenarios_for_target is None
    assert f.as_dict()["scenarios_for_target"] is None
