"""Margins and exact peaks, cross-checked against python-control and dense grids."""

import control
import numpy as np
import pytest

from robrst.core import poly
from robrst.core.analysis import analyze, crossovers, sensitivity, step_response
from robrst.core.peaks import peak_gain
from robrst.core.plant import Plant, paper_plant
from robrst.core.rst import RSTController, closed_loop
from robrst.problem.records import ControllerStructure, PoleSpec
from robrst.synthesis.analytic import pole_placement


def design(plant, poles, S_fixed=(1.0, 0.0), R_fixed=(1.0,), extra_degree=0, t_mode="paper",
           t_zeros=()):
    """Pole placement with the structure given as keywords; returns (controller, design)."""
    d = pole_placement(plant, poles, ControllerStructure(tuple(S_fixed), tuple(R_fixed),
                                                         extra_degree, t_mode, tuple(t_zeros)))
    return d.controller, d


DESIGNS = [(600.0, 1.0, 1), (1000.0, 0.9, 1), (1000.0, 0.9, 0), (2500.0, 0.9, 1), (3000.0, 0.7, 1)]


def _dense_peak(N, D, w):
    g = np.abs(poly.eval_jw(N, w) / poly.eval_jw(D, w))
    i = int(np.argmax(g))
    return g[i], w[i]


@pytest.mark.parametrize("wn,zeta,extra", DESIGNS)
def test_exact_peaks_dominate_dense_grid_and_match_refined_maximum(wn, zeta, extra):
    p = paper_plant()
    ctrl, _ = design(p, PoleSpec(wn=wn, zeta=zeta), extra_degree=extra)
    cl = closed_loop(p, ctrl)
    w = np.logspace(0, 8, 200_001)
    for name in ("S", "T", "U", "Sd"):
        N, D = cl.tf(name)
        pk = peak_gain(N, D)
        g, wg = _dense_peak(N, D, w)
        assert pk.value >= g * (1 - 1e-12)
        if pk.freq_rad_s == 0.0:
            assert pk.value == pytest.approx(abs(N[-1] / D[-1]), rel=1e-12)
            assert g <= pk.value * (1 + 1e-12)
        elif np.isfinite(pk.freq_rad_s):
            # refine the grid maximum locally (golden section on log w) — independent path
            from scipy.optimize import minimize_scalar
            f = lambda lw: -abs(np.polyval(N, 1j * np.exp(lw)) / np.polyval(D, 1j * np.exp(lw)))  # noqa: E731
            r = minimize_scalar(f, bounds=(np.log(wg) - 1e-3, np.log(wg) + 1e-3),
                                method="bounded", options={"xatol": 1e-12})
            assert pk.value == pytest.approx(-r.fun, rel=1e-6)
        else:
            assert pk.value == pytest.approx(abs(N[0] / D[0]) if len(N) == len(D) else 0.0, rel=1e-12)


@pytest.mark.parametrize("wn,zeta,extra", DESIGNS)
def test_margins_agree_with_python_control(wn, zeta, extra):
    p = paper_plant()
    ctrl, _ = design(p, PoleSpec(wn=wn, zeta=zeta), extra_degree=extra)
    a = analyze(p, ctrl)
    L = control.tf(np.polymul(p.B, ctrl.R), np.polymul(p.A, ctrl.S))
    gm, pm, sm, wpc, wgc, wms = control.stability_margins(L, returnall=True)
    np.testing.assert_allclose(np.sort(a.margins.gain_crossover_rad_s), np.sort(wgc), rtol=1e-8)
    # python-control's phase margin: the crossover's (arg L mod 360) - 180 smallest in
    # magnitude, signed (negative where arg L lies in (0, 180), e.g. near the resonance)
    gm1, pm1, *_ = control.stability_margins(L)
    assert a.margins.phase_margin_deg == pytest.approx(pm1, rel=1e-8)
    assert a.margins.phase_margin_deg == pytest.approx(min(pm, key=abs), rel=1e-8)
    upper, lower = [g for g in gm if g > 1], [g for g in gm if g < 1]
    if upper:
        assert a.margins.gain_margin == pytest.approx(min(upper), rel=1e-8)
    else:
        assert a.margins.gain_margin is None
    if lower:
        assert a.margins.gain_margin_lower == pytest.approx(max(lower), rel=1e-8)
    else:
        assert a.margins.gain_margin_lower is None
    # python-control's single gm is the one of the two closer to 1 in log
    ours = [g for g in (a.margins.gain_margin, a.margins.gain_margin_lower) if g is not None]
    if ours:
        assert min(ours, key=lambda g: abs(np.log(g))) == pytest.approx(gm1, rel=1e-8)
    # modulus margin: exact, so at least python-control's grid-based stability margin
    assert a.margins.modulus_margin <= np.min(sm) * (1 + 1e-9)


def test_delay_margin_brings_loop_to_instability():
    """A delay just above the margin destabilises the loop (Padé check), just below does not."""
    p = paper_plant()
    ctrl, _ = design(p, PoleSpec(wn=1000.0, zeta=0.9), extra_degree=1)
    dm = analyze(p, ctrl).margins.delay_margin_s
    wc = analyze(p, ctrl).margins.gain_crossover_rad_s
    L = lambda w, tau: (np.polyval(np.polymul(p.B, ctrl.R), 1j * w)  # noqa: E731
                        / np.polyval(np.polymul(p.A, ctrl.S), 1j * w) * np.exp(-1j * w * tau))
    # at tau = DM the loop passes through -1 at one of the crossovers
    assert min(abs(L(w, dm) + 1) for w in wc) == pytest.approx(0.0, abs=1e-9)
    assert min(abs(L(w, 0.9 * dm) + 1) for w in wc) > 1e-3


def test_crossovers_of_simple_loop_are_exact():
    # L = 4/(s (s + 1)): |L| = 1 at w^2 = (sqrt(65) - 1)/2 ; no phase crossover
    wg, wp = crossovers([4.0], [1.0, 1.0, 0.0])
    assert wg[0] == pytest.approx(np.sqrt((np.sqrt(65) - 1) / 2), rel=1e-12)
    assert wp.size == 0
    # L = 1/(s+1)^3: phase crossover at w = sqrt(3), |L| = 1/8
    wg, wp = crossovers([1.0], [1.0, 3.0, 3.0, 1.0])
    assert wp[0] == pytest.approx(np.sqrt(3.0), rel=1e-12)


def test_peak_of_known_second_order_system():
    # |G| peak of wn^2/(s^2 + 2 z wn s + wn^2) = 1/(2 z sqrt(1 - z^2)) at wn sqrt(1 - 2 z^2)
    for wn, z in ((1.0, 0.1), (3873.0, 0.0054), (1e6, 0.3)):
        pk = peak_gain([wn**2], [1.0, 2 * z * wn, wn**2])
        assert pk.value == pytest.approx(1 / (2 * z * np.sqrt(1 - z * z)), rel=1e-9)
        assert pk.freq_rad_s == pytest.approx(wn * np.sqrt(1 - 2 * z * z), rel=1e-10)


def test_paper_plant_peak_against_slycot():
    pytest.importorskip("slycot")
    p = paper_plant()
    assert peak_gain(p.B, p.A).value == pytest.approx(control.linfnorm(p.to_tf())[0], rel=1e-9)


def test_closed_loop_static_behaviour_and_step():
    p = paper_plant()
    ctrl, info = design(p, PoleSpec(wn=600.0, zeta=1.0), extra_degree=1)
    cl = closed_loop(p, ctrl)
    # zero static error: S(0) = 0 and Tr(0) = 1
    assert abs(np.polyval(cl.nums["S"], 0.0)) == 0.0
    assert np.polyval(cl.nums["Tr"], 0.0) / np.polyval(cl.Delta, 0.0) == pytest.approx(1.0, rel=1e-12)
    t = np.linspace(0, 0.05, 2001)
    y = step_response(*cl.tf("Tr"), t)
    # compare with python-control on the same (here well-scaled enough) system
    ref = control.forced_response(control.tf(*cl.tf("Tr")), t, np.ones_like(t)).outputs
    np.testing.assert_allclose(y, ref, atol=1e-6)
    assert y[-1] == pytest.approx(1.0, abs=1e-4)
    # 616 Hz resonance removed: |T| < 1 around it
    f = np.linspace(560, 680, 121)
    assert np.max(np.abs(sensitivity(p, ctrl, "T", 2 * np.pi * f))) < 1.0


def test_plant_round_trips():
    p = paper_plant()
    q = Plant.from_tf(p.to_tf())
    np.testing.assert_allclose(q.A, p.A, rtol=1e-15)
    np.testing.assert_allclose(q.B, p.B, rtol=1e-15)
    z = Plant.from_zpk(p.zeros(), p.poles(), p.B[0])
    np.testing.assert_allclose(z.A, p.A, rtol=1e-12)
    np.testing.assert_allclose(z.B, p.B, rtol=1e-12)
    assert p.dc_gain == pytest.approx(0.668, abs=5e-4)
    assert np.max(np.abs(p.poles().imag)) / (2 * np.pi) == pytest.approx(616.4, abs=0.1)


@pytest.mark.parametrize("wn,zeta,extra", [(1000.0, 0.9, 1), (2500.0, 0.9, 1)])
def test_slicot_on_raw_coefficients_misses_the_peak_robrst_finds(wn, zeta, extra):
    """The README's claim: SLICOT's ab13dd (via control.linfnorm) on the *unscaled* |S|
    returns ~1.0 where the true peak (dense grid + refinement, independent of robrst) is
    1.29 / 1.87; robrst's scaled Hamiltonian peak matches the true one."""
    pytest.importorskip("slycot")
    from scipy.optimize import minimize_scalar

    p = paper_plant()
    ctrl, _ = design(p, PoleSpec(wn=wn, zeta=zeta), extra_degree=extra)
    N, D = closed_loop(p, ctrl).tf("S")
    w = np.logspace(0, 6, 200_001)
    g, wg = _dense_peak(N, D, w)
    f = lambda lw: -abs(np.polyval(N, 1j * np.exp(lw)) / np.polyval(D, 1j * np.exp(lw)))  # noqa: E731
    true = max(g, -minimize_scalar(f, bounds=(np.log(wg) - 1e-3, np.log(wg) + 1e-3),
                                   method="bounded", options={"xatol": 1e-12}).fun)
    assert peak_gain(N, D).value == pytest.approx(true, rel=1e-9)
    with np.errstate(all="ignore"):
        slicot = control.linfnorm(control.tf(N, D))[0]
    assert slicot < 0.9 * true


@pytest.mark.parametrize("k", [0.5 / 0.997, 1.0, 3.0])
def test_lower_gain_margin_of_a_conditionally_stable_loop(k):
    """L = k (s+1)^2 / s^3 is stable exactly for k > 1/2 (Routh on s^3 + k s^2 + 2k s + k):
    the loop tolerates no gain reduction below 1/(2k) and any increase.  At k = 0.5/0.997 it
    goes unstable at 0.997x gain: robrst must not report only an upward margin."""
    from robrst.core.analysis import margins

    p = Plant([1.0, 2.0, 1.0], [1.0, 0.0, 0.0, 0.0])
    ctrl = RSTController(R=[k], S=[1.0], T=[k])
    a = analyze(p, ctrl)
    assert a.stable
    assert a.margins.gain_margin_lower == pytest.approx(0.5 / k, rel=1e-9)
    assert a.margins.gain_margin is None
    gm, pm, *_ = control.stability_margins(control.tf([k, 2 * k, k], [1, 0, 0, 0]))
    assert gm == pytest.approx(0.5 / k, rel=1e-9)              # python-control's gm: the lower one
    assert a.margins.phase_margin_deg == pytest.approx(pm, rel=1e-9)
    m = margins(p, ctrl, a.peaks["S"].value)
    assert m == a.margins


def test_bracketed_root_matches_brentq():
    """The crossover polish's root finder against scipy's brentq (an independent code)."""
    from scipy.optimize import brentq

    from robrst.core.analysis import bracketed_root

    rng = np.random.default_rng(5)
    funcs = [lambda x: np.log(x) - 1.0, lambda x: x ** 3 - 2.0, lambda x: np.tan(x) - x,
             lambda x: np.exp(-x) - 1e-3 * x, lambda x: (x - 1.7) ** 3,   # triple root
             lambda x: np.sign(x - 2.5) * np.sqrt(abs(x - 2.5))]
    brackets = [(1.0, 5.0), (0.5, 3.0), (4.0, 4.6), (0.0, 10.0), (0.0, 3.0), (0.0, 7.0)]
    for f, (a, b) in zip(funcs, brackets):
        for _ in range(5):
            lo, hi = a + rng.uniform(0, 0.05) * (b - a), b - rng.uniform(0, 0.05) * (b - a)
            ref = brentq(f, lo, hi, xtol=1e-14, maxiter=1000)
            got = bracketed_root(f, lo, hi, f(lo), f(hi), xtol=1e-14)
            assert got == pytest.approx(ref, abs=1e-12), (lo, hi)
