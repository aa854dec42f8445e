"""``Mu_max`` on an unstable plant (``robrst.core.lti.least_control_peak``,
``robrst.synthesis.feasibility.prove_control_infeasible``): every controller that stabilises
``P`` has a ``|U| = |K/(1 + P K)|`` peak of at least ``1 / sigma_min``, the least Hankel
singular value of the mirror image of the plant's unstable part (Glover 1986).

Checked independently: the closed forms ``2 a / |b|`` for ``b / (s - a)`` (a constant gain
reaches it: the bound is the infimum, not below it), ``1 / (residue / (2 a))`` for a
plant with a stable and an unstable pole, ``(p^2 - 1) / |b_d|`` for the sampled loop of
``b / (s - a)`` (``p = exp(a / fs)``, ``b_d = b (p - 1) / a``: the ZOH plant
``b_d / (z - p)``), python-control's Hankel singular values of ``P(-s)`` for a plant whose
poles are all unstable; and the design pipeline names such a ``Mu_max`` infeasible at once,
never one above the bound.
"""

import control
import numpy as np
import pytest

from robrst.core.lti import least_control_peak
from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.synthesis.feasibility import prove_control_infeasible


@pytest.mark.parametrize("a, b", [(5.0, 3.0), (1e4, 1e8), (0.3, -2.0)])
def test_a_first_order_unstable_plant_needs_2a_over_b(a, b):
    least = least_control_peak([b], [1.0, -a])
    assert least == pytest.approx(2 * a / abs(b), rel=1e-10)
    # the constant gain k = 2a/b reaches it: |k (s - a)/(s + a)| = 2a/|b| on the axis
    w = np.logspace(np.log10(a) - 4, np.log10(a) + 4, 2001)
    s, k = 1j * w, 2 * a / b
    ks = k / (1 + k * b / (s - a))
    assert np.max(np.abs(ks)) == pytest.approx(2 * a / abs(b), rel=1e-9)


def test_a_stable_and_an_unstable_pole():
    # 1/((s + 10)(s - 1)): unstable part (1/11)/(s - 1), Hankel singular value 1/22
    assert least_control_peak([1.0], np.polymul([1.0, 10.0], [1.0, -1.0])) == \
        pytest.approx(22.0, rel=1e-10)


@pytest.mark.parametrize("num, den", [([2000.0], [1.0, -150.0, 1e4]),
                                      ([1.0, 3.0], [1.0, -2.0, 5.0, -4.0])])
def test_every_pole_unstable_matches_python_control(num, den):
    assert np.all(np.roots(den).real > 0)
    mirror = control.tf(np.array(num) * (-1.0) ** np.arange(len(num) - 1, -1, -1),
                        np.array(den) * (-1.0) ** np.arange(len(den) - 1, -1, -1))
    hsv = control.hankel_singular_values(control.ss(mirror))
    assert least_control_peak(num, den) == pytest.approx(1 / np.min(hsv), rel=1e-8)


@pytest.mark.parametrize("den", [[1.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0], [1.0, 3.0, 2.0]])
def test_stable_plants_and_poles_on_the_axis_give_no_bound(den):
    assert least_control_peak([1.0], den) is None


def _doc(mu, fs=None, a=50.0, b=400.0):
    specs = {"Ms_max": 2.5, "Mu_max": mu}
    if fs:
        specs["sample_rate_hz"] = fs
    return {"problem": {"name": "unstable"},
            "plant": {"B": [b], "A": [1.0, -a], "temperature_C": 25.0},
            "controller": {"extra_degree": 1},
            "poles": {"wn": 4 * a, "zeta": 0.9},
            "specs": specs,
            "solver": {"method": "nlp", "objective": "max_integral_gain"}}


def test_the_sampled_loop_has_its_own_closed_form():
    a, b, fs = 50.0, 400.0, 1000.0
    p = np.exp(a / fs)
    bd = b * (p - 1) / a
    least = (p * p - 1) / abs(bd)              # the ZOH plant bd / (z - p)
    cont = 2 * a / b
    assert least > cont
    mu = 0.5 * (least + cont)                  # between: the sampled loop alone fails
    proofs = prove_control_infeasible(parse_problem(_doc(mu, fs), "<u>"))
    assert [q.loop for q in proofs] == ["sampled"]
    assert proofs[0].least == pytest.approx(least, rel=1e-9)
    assert proofs[0].unstable_poles == 1


def test_the_pipeline_names_it_infeasible_and_never_above_the_bound():
    a, b = 50.0, 400.0
    res = run_problem(parse_problem(_doc(0.9 * 2 * a / b), "<u>"), analyses=False)
    assert not res.certified and res.feasibility.status == "infeasible"
    kinds = [q["kind"] for q in res.feasibility.as_dict()["proofs"]]
    assert kinds == ["unstable_plant"]
    assert "Glover 1986" in res.feasibility.lines()[0]
    assert prove_control_infeasible(parse_problem(_doc(1.01 * 2 * a / b), "<u>")) == ()


def test_not_found_on_an_unstable_plant_states_the_floor():
    """Above the floor there is no proof; a design missing ``Mu_max`` is told the floor."""
    from robrst.certificate.proof import certify_problem
    from robrst.design import analytic_design
    from robrst.synthesis.feasibility import feasibility_verdict

    a, b = 50.0, 400.0
    least = 2 * a / b
    p = parse_problem(_doc(1.5 * least), "<u>")
    ctrl = analytic_design(p).controller
    cert = certify_problem(p, ctrl)
    assert any(v.quantity.startswith("|U|") for v in cert.violations), cert.violations
    verdict = feasibility_verdict(p, cert, ctrl)
    assert verdict.status == "not_found"
    assert f"has |U| >= {least:.4g} V/µm somewhere (Glover 1986)" in verdict.suggestion


def test_an_unstable_pole_cancelled_by_a_zero_is_no_controller_at_all():
    # (s - 1)/((s - 1)(s + 2)): the unstable mode is unobservable, its Hankel value 0
    assert least_control_peak([1.0, -1.0], [1.0, 1.0, -2.0]) == np.inf
    doc = _doc(50.0)
    doc["plant"] = {"B": [1.0, -1.0], "A": [1.0, 1.0, -2.0], "temperature_C": 25.0}
    proofs = prove_control_infeasible(parse_problem(doc, "<u>"))
    assert proofs and "no controller stabilises the loop" in proofs[0].reason
