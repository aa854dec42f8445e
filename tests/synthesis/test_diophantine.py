"""Diophantine solve: identity to <= 1e-9, degrees, T, coprimality errors."""

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from robrst.core import poly
from robrst.base.errors import CoprimeError, DegreeError, SpecError
from robrst.core.plant import Plant, paper_plant
from robrst.problem.records import ControllerStructure, PoleSpec
from robrst.synthesis.analytic import (characteristic_polynomial, pole_placement,
                                       solve_diophantine)


def design(plant, poles, S_fixed=(1.0, 0.0), R_fixed=(1.0,), extra_degree=0, t_mode="paper",
           t_zeros=()):
    """Pole placement with the structure given as keywords; returns (controller, design)."""
    d = pole_placement(plant, poles, ControllerStructure(tuple(S_fixed), tuple(R_fixed),
                                                         extra_degree, t_mode, tuple(t_zeros)))
    return d.controller, d


RTOL = 1e-9


def identity_error(plant, ctrl, Am):
    lhs = poly.padd(poly.pmul(plant.A, ctrl.S), poly.pmul(plant.B, ctrl.R))
    return poly.rel_coef_error(lhs, Am)


def test_paper_plant_identity_and_degrees():
    p = paper_plant()
    ctrl, info = design(p, PoleSpec(wn=600.0, zeta=1.0))
    # paper eq. (13): deg R = deg S = n = 3, deg Am = 2n, beta0 = 0, S monic
    assert len(ctrl.R) - 1 == 3 and len(ctrl.S) - 1 == 3
    assert len(info.Am) - 1 == 6
    assert ctrl.S[-1] == 0.0 and ctrl.S[0] == 1.0
    assert identity_error(p, ctrl, info.Am) <= RTOL
    assert info.residual <= RTOL
    # scaling makes the solve well conditioned; the raw Sylvester matrix is not
    assert info.cond < 1e3 < 1e12 < info.cond_unscaled


def test_identity_checked_by_independent_polynomial_arithmetic():
    """Expand A S + B R with numpy.polynomial (ascending order) and compare in s."""
    p = paper_plant()
    ctrl, info = design(p, PoleSpec(wn=1000.0, zeta=0.8), extra_degree=1)
    P = np.polynomial.Polynomial
    lhs = P(p.A[::-1]) * P(ctrl.S[::-1]) + P(p.B[::-1]) * P(ctrl.R[::-1])
    Am = info.Am[::-1]
    np.testing.assert_allclose(lhs.coef, Am, rtol=1e-9, atol=0)


def test_tracking_modes_give_unit_static_gain():
    p = paper_plant()
    # cancel_aux needs deg Am_aux <= deg S: two extra dominant real poles
    spec = PoleSpec(wn=600.0, zeta=1.0, dominant_real=(-800.0, -900.0))
    for mode, zeros in (("paper", ()), ("paper", (-2e4,)), ("static", ()), ("cancel_aux", ())):
        ctrl, info = design(p, spec, extra_degree=1, t_mode=mode, t_zeros=zeros)
        Am = info.Am
        gain = p.B[-1] * ctrl.T[-1] / Am[-1]
        assert gain == pytest.approx(1.0, rel=1e-12)
        assert ctrl.T[-1] == pytest.approx(ctrl.R[-1], rel=1e-12)  # T(0) = R(0), paper
    ctrl, info = design(p, spec, extra_degree=1, t_mode="cancel_aux")
    np.testing.assert_allclose(ctrl.T / ctrl.T[0], info.Am_aux, rtol=1e-12)
    with pytest.raises(DegreeError, match="improper"):
        design(p, PoleSpec(wn=600.0, zeta=1.0), extra_degree=1, t_mode="cancel_aux")


def test_fixed_factors_are_kept():
    p = paper_plant()
    Rf = [1 / 3e4, 1.0]  # roll-off zero at -3e4 rad/s in R
    ctrl, info = design(p, PoleSpec(wn=600.0, zeta=1.0), R_fixed=Rf)
    assert np.polyval(ctrl.R, -3e4) == pytest.approx(0.0, abs=1e-9 * np.max(np.abs(ctrl.R)) * 3e4 ** 4)
    assert identity_error(p, ctrl, info.Am) <= RTOL


@st.composite
def coprime_plants(draw):
    """Random coprime plants: roots within 3 decades of a centre anywhere in 1..1e6 rad/s."""
    n = draw(st.integers(1, 6))
    m = draw(st.integers(0, n))
    centre = 10 ** draw(st.floats(0.0, 6.0))

    def roots(k):
        out = []
        while len(out) < k:
            r = centre * 10 ** draw(st.floats(-1.5, 1.5))
            if k - len(out) >= 2 and draw(st.booleans()):
                z = draw(st.floats(0.05, 0.95))
                wd = r * np.sqrt(1 - z * z)
                out += [complex(-z * r, wd), complex(-z * r, -wd)]
            else:
                out.append(complex(-r if draw(st.booleans()) else r, 0.0))
        return out

    poles, zeros = roots(n), roots(m)
    for z in zeros:
        for q in poles:
            assume(abs(z - q) > 1e-3 * abs(q))
    plant = Plant.from_zpk(zeros, poles, 10 ** draw(st.floats(-4.0, 4.0)))
    coefs = np.abs(np.concatenate([plant.A, plant.B]))
    assume(coefs.max() / coefs[coefs > 0].min() >= 1e8)  # >= 8 decades, as the paper's
    return plant, centre


@settings(max_examples=150, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(pc=coprime_plants(), dec=st.floats(-1.0, 1.0), zeta=st.floats(0.3, 1.5),
       extra=st.integers(0, 2))
def test_random_coprime_plants_identity(pc, dec, zeta, extra):
    plant, centre = pc
    ctrl, info = design(plant, PoleSpec(wn=centre * 10 ** dec, zeta=zeta), extra_degree=extra)
    assert info.residual <= RTOL
    # recomputed independently with numpy.polynomial in p = s / w0, w0 = |Am(0)|^(1/deg),
    # relative to the size of the terms |A||S| + |B||R| (backward error)
    Am = info.Am
    w0 = abs(Am[-1]) ** (1.0 / (len(Am) - 1))
    P = np.polynomial.Polynomial

    def sc(c):
        return P(np.asarray(c)[::-1] * w0 ** np.arange(len(c)))

    a, b, r, s = (sc(c) for c in (plant.A, plant.B, ctrl.R, ctrl.S))
    lhs = (a * s + b * r).coef
    size = (P(np.abs(a.coef)) * P(np.abs(s.coef)) + P(np.abs(b.coef)) * P(np.abs(r.coef))).coef
    err = np.abs(lhs - sc(Am).coef[: len(lhs)])
    assert np.max(err) / np.max(size) <= RTOL
    assert ctrl.S[-1] == 0.0
    assert len(ctrl.R) <= len(ctrl.S)


def test_common_root_is_named():
    A = poly.pmul([1.0, 651.0], [1.0, 42.0, 1.5e7])
    B = 2.0 * np.array([1.0, 651.0 * (1 + 1e-9)])  # zero within 1e-9 of the pole at -651
    with pytest.raises(CoprimeError, match=r"share the root s = -651"):
        design(Plant(B, A), PoleSpec(wn=600.0, zeta=1.0))
    # a zero at the origin cancels the integrator of S
    with pytest.raises(CoprimeError, match=r"share the root s = 0"):
        design(Plant([1.0, 0.0], A), PoleSpec(wn=600.0, zeta=1.0))


def test_degree_errors():
    p = paper_plant()
    with pytest.raises(DegreeError, match="too low"):
        solve_diophantine(p.A, p.B, poly.from_roots([-1.0, -2.0, -3.0]))
    with pytest.raises(DegreeError, match="dominant poles exceed"):
        characteristic_polynomial(PoleSpec(wn=1.0, zeta=0.5, dominant_real=(-1, -2)), 3)


def test_pole_spec_errors():
    with pytest.raises(SpecError, match="open left half-plane"):
        PoleSpec(dominant_roots=(1 + 1j, 1 - 1j)).dominant()
    with pytest.raises(SpecError, match="10x faster"):
        characteristic_polynomial(PoleSpec(wn=100.0, zeta=0.7, aux_factor=3.0), 4)
    with pytest.raises(SpecError, match="10x faster"):
        characteristic_polynomial(PoleSpec(wn=100.0, zeta=0.7, aux_roots=(-500.0, -2000.0)), 4)


def test_ill_conditioned_random_plant_is_refused_with_the_keys_to_change():
    """Found by the random search: a near-double zero pair of B (relative spacing 4e-5) and a
    degree-13 closed loop at wn = 1000 make the scaled Sylvester matrix singular to working
    precision (cond 2.2e15): robrst refuses, naming the cause and the keys, instead of
    returning a controller it cannot vouch for."""
    B = [1.0e1, 9.68377223e2, 9.68377223e4, -1.03162278e7, -9.68377223e8, -9.68377223e10,
         3.16227766e11]
    A = [1.0, 4.43765867e1, 9.71882934e3, -5.72341325e4, -4.43765867e4, -9.71882934e6,
         5.62341325e7]
    with pytest.raises(CoprimeError, match=r"too ill-conditioned.*\[poles\] wn"):
        design(Plant(B, A), PoleSpec(wn=1000.0, zeta=1.5), extra_degree=0)
