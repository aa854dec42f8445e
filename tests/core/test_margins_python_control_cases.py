"""python-control's own margin test cases, run on robrst's margins.

Source of every case and reference value below: python-control 0.10.2,
``control/tests/margin_test.py`` (BSD-3-Clause; fixtures ``tsys`` and ``tsys_zmore``,
``test_mag_phase_omega``, ``test_phase_crossover_frequencies``,
``test_stability_margins_discrete``), copied with their tolerances.  Each loop ``L`` is
closed by unit feedback (``R = S = T = 1``) and analysed by :func:`robrst.core.analysis.analyze`;
the discrete cases through robrst's sampled loop (``sampled_plant``, a w-plane loop whose
frequencies unwarp to physical ones).  robrst is also compared with python-control
computing the same loop now (``control.stability_margins``).

Intended differences (``docs/guide/margins.md``):

* robrst reports two gain margins, ``gain_margin`` (the smallest factor > 1) and
  ``gain_margin_lower`` (the largest factor < 1); python-control's single ``gm`` is the
  one closer to 1 in log (compared as such here);
* robrst's modulus margin is ``1 / max|S|`` over every frequency, the limits at 0 and
  infinity included (exact); python-control's ``sm`` is the smallest ``|1 + L|`` at an
  interior stationary point (``inf`` when there is none, e.g. ``3 (10 + s)/(2 + s)``,
  where ``|1 + L|`` falls monotonically to 4 at infinity: robrst 4);
* ``w = inf`` counts as a phase crossover for a biproper continuous loop with
  ``L(inf) < 0`` (python-control's continuous polynomial method sees finite roots only;
  its discrete one counts Nyquist, ``z = -1``, which is ``w = inf`` of the w-plane);
* ``phase_crossover_rad_s`` lists the crossings of the negative real axis only
  (python-control's ``phase_crossover_frequencies`` lists every real-axis crossing, with
  ``w = 0`` at infinite gain for an integrator);
* no margins of frequency-response data (robrst's loops are rational).
"""

import math

import control
import numpy as np
import pytest

from robrst.core.analysis import analyze, loop_value
from robrst.core.plant import Plant
from robrst.core.rst import RSTController
from robrst.core.sampled import sampled_plant, unwarp

inf, nan = math.inf, math.nan
s = control.TransferFunction.s
UNIT = RSTController(R=[1.0], S=[1.0], T=[1.0])


def _nd(sys):
    tf = control.tf(sys)
    return np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)


# ---- margin_test.py, fixture tsys: (system, stability_margins(sys), ..., returnall)
TSYS = {
    "tf_1": (control.tf([1, 2], [1, 2, 3]), (inf, inf, inf, nan, nan, nan)),
    "tf_2": (control.tf([1], [1, 2, 3, 4]), (2., inf, 0.4170, 1.7321, nan, 1.6620)),
    "ss": (control.ss([[1., 4.], [3., 2.]], [[1.], [-4.]], [[1., 0.]], [[0.]]),
           (inf, 147.0743, inf, nan, 2.5483, nan)),
    "resonant": ((8.75 * (4 * s**2 + 0.4 * s + 1)) / ((100 * s + 1) * (s**2 + 0.22 * s + 1))
                 / (s**2 / 10.**2 + 2 * 0.04 * s / 10. + 1),
                 (2.2716, 97.5941, 0.5591, 10.0053, 0.0850, 9.9918)),
    "first_order": (1 / (1 + s), (inf, inf, inf, nan, nan, nan)),
    "lead": (3 * (10 + s) / (2 + s), (inf, inf, inf, nan, nan, nan)),
    "rhp_zero": (0.01 * (10 - s) / (2 + s) / (1 + s), (300.0, inf, 0.9917, 5.6569, nan, 2.3171)),
}

# ---- margin_test.py, fixture tsys_zmoresystems ("A note on the Gain and Phase Margin
# Concepts", Bavafi-Toosi, J. Control Syst. Eng. 2015) and test_zmore_margin:
# margin(sys * K) = (gm, pm, wpc, wgc)
ZSYS = {
    "typem1": s / (s + 1),
    "type0": 1 / (s + 1)**3,
    "type1": (s + 0.1) / s / (s + 1),
    "type2": (s + 0.1) / s**2 / (s + 1),
    "type3": (s + 0.1) * (s + 0.1) / s**3 / (s + 1),
    "example21": 0.002 * (s + 0.02) * (s + 0.05) * (s + 5) * (s + 10) / (
        (s - 0.0005) * (s + 0.0001) * (s + 0.01) * (s + 0.2) * (s + 1) * (s + 100)**2),
}
ZMORE = [
    ("typem1", 2.0, 1.5e-3, (inf, -120.0007, nan, 0.5774)),
    ("type0", 0.8, 1.5e-3, (10.0014, inf, 1.7322, nan)),
    ("type0", 2.0, 1e-2, (4.000, 67.6058, 1.7322, 0.7663)),
    ("type1", 1.0, 1e-4, (inf, 144.9032, nan, 0.3162)),
    ("type2", 1.0, 1e-4, (inf, 44.4594, nan, 0.7907)),
    ("type3", 1.0, 1.5e-3, (0.0626, 37.1748, 0.1119, 0.7951)),
    ("example21", 1.0, 1e-2, (0.0100, -14.5640, 0, 0.0022)),
    ("example21", 1000.0, 1e-2, (0.1793, 22.5215, 0.0243, 0.0630)),
    ("example21", 5000.0, 1.5e-3, (4.5596, 21.2101, 0.4385, 0.1868)),
]
# test_zmore_stability_margins: stability_margins(example21, returnall=True), rtol = atol = 1e-3
EXAMPLE21_ALL = ([0.01, 179.2931, 2.2798e+4, 1.5946e+07, 7.2477e+08], [-14.5640], [0.2496],
                 [0, 0.0243, 0.4385, 6.8640, 84.9323], [0.0022], [0.0022])


def _robrst(num, den):
    """robrst's margins of the unit-feedback loop ``num/den`` in python-control's shape:
    ``(gm, pm, sm, wpc, wgc, wms)`` and the lists ``(gms, pms, wpcs, wgcs)``."""
    a = analyze(Plant(num, den), UNIT)
    m = a.margins
    wp = np.array(m.phase_crossover_rad_s)
    gms = np.array([1.0 / abs(loop_value(num, den, w)) for w in wp])
    wg = np.array(m.gain_crossover_rad_s)
    pms = np.array([np.degrees(np.angle(loop_value(num, den, w))) % 360.0 - 180.0 for w in wg])
    ours = [g for g in (m.gain_margin, m.gain_margin_lower) if g is not None]
    gm = min(ours, key=lambda g: abs(math.log(g))) if ours else inf
    wpc = float(wp[np.argmin(np.abs(gms - gm))]) if ours else nan
    pm = m.phase_margin_deg if m.phase_margin_deg is not None else inf
    wgc = float(wg[np.argmin(np.abs(pms - pm))]) if wg.size else nan
    return (gm, pm, m.modulus_margin, wpc, wgc, a.peaks["S"].freq_rad_s), (gms, pms, wp, wg)


@pytest.mark.parametrize("name", sorted(TSYS))
def test_tsys_cases(name):
    sys, ref = TSYS[name]
    num, den = _nd(sys)
    (gm, pm, sm, wpc, wgc, _), (gms, pms, wp, wg) = _robrst(num, den)
    # python-control's reference values (atol 1.5e-2 in margin_test.py), sm excepted
    np.testing.assert_allclose([gm, pm, wpc, wgc], np.array(ref)[[0, 1, 3, 4]], atol=1.5e-2)
    # and python-control now, every crossover
    pc = control.stability_margins(sys, returnall=True)
    np.testing.assert_allclose(np.sort(wp), np.sort(pc[3]), rtol=1e-7)
    np.testing.assert_allclose(np.sort(gms), np.sort(pc[0]), rtol=1e-7)
    np.testing.assert_allclose(np.sort(wg), np.sort(pc[4]), rtol=1e-7)
    np.testing.assert_allclose(np.sort(pms), np.sort(pc[1]), rtol=1e-7, atol=1e-9)
    # modulus margin: exact, never above python-control's smallest |1 + L|
    assert sm <= (np.min(pc[2]) if len(pc[2]) else inf) * (1 + 1e-9)
    if ref[2] != inf:
        assert sm == pytest.approx(ref[2], abs=1.5e-2)


def test_lead_modulus_margin_is_the_limit_at_infinity():
    """Intended difference: |1 + L| of 3 (10 + s)/(2 + s) falls from 16 to 4 at w = inf;
    python-control reports sm = inf (no interior minimum), robrst 1/max|S| = 4."""
    num, den = _nd(TSYS["lead"][0])
    assert _robrst(num, den)[0][2] == pytest.approx(4.0, rel=1e-12)


@pytest.mark.parametrize("name, K, atol, ref", ZMORE)
def test_zmore_margin_cases(name, K, atol, ref):
    sys = ZSYS[name] * K
    num, den = _nd(sys)
    gm, pm, _, wpc, wgc, _ = _robrst(num, den)[0]
    np.testing.assert_allclose([gm, pm, wpc, wgc], ref, atol=atol)
    np.testing.assert_allclose([gm, pm, wpc, wgc], control.margin(sys), rtol=1e-6, atol=1e-9)


def test_example21_every_crossover_and_both_gain_margins():
    """example21, K = 1: python-control's gm 0.01 at w = 0 (L(0) = -100: the loop goes
    unstable when the gain falls to 0.01); robrst's lower gain margin is that 0.01, its
    upper one 179.4 (the phase crossover at 0.0243 rad/s)."""
    num, den = _nd(ZSYS["example21"])
    (gm, pm, sm, wpc, wgc, wms), (gms, pms, wp, wg) = _robrst(num, den)
    ref = EXAMPLE21_ALL
    np.testing.assert_allclose(gms, ref[0], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(pms, ref[1], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose([sm], ref[2], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(wp, ref[3], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(wg, ref[4], rtol=1e-3, atol=1e-3)
    a = analyze(Plant(num, den), UNIT).margins
    assert a.gain_margin_lower == pytest.approx(0.01, rel=1e-9)
    assert a.gain_margin == pytest.approx(179.406, rel=1e-5)
    assert wp[0] == 0.0 and gm == pytest.approx(0.01, rel=1e-9)


def test_unstable_first_order_lower_gain_margin():
    """2/(s - 1) under unit feedback: stable for gains above 0.5 only (closed-loop pole
    1 - 2k): gain_margin_lower 0.5 (was None, 'may shrink to 0'), no upper margin."""
    a = analyze(Plant([2.0], [1.0, -1.0]), UNIT)
    assert a.stable
    assert a.margins.gain_margin_lower == pytest.approx(0.5, rel=1e-15)
    assert a.margins.gain_margin is None and a.margins.phase_crossover_rad_s == (0.0,)
    for k, stable in ((0.49, False), (0.51, True)):
        assert (np.roots([1.0, -1.0 + 2.0 * k])[0].real < 0) == stable


def test_biproper_loop_crosses_at_infinity():
    """Intended difference: L = -0.5 (s - 3)/(s + 1) has L(inf) = -0.5: a closed-loop
    pole passes through infinity when the gain reaches 2 (1 + k L(inf) = 0)."""
    num, den = np.array([-0.5, 1.5]), np.array([1.0, 1.0])
    a = analyze(Plant(num, den), UNIT).margins
    assert math.inf in a.phase_crossover_rad_s
    assert a.gain_margin == pytest.approx(2.0, rel=1e-15)
    for k, stable in ((1.99, True), (2.01, False)):      # (s + 1) + k (-0.5 s + 1.5)
        lead, const = 1.0 - 0.5 * k, 1.0 + 1.5 * k
        assert (-const / lead < 0) == stable


def test_mag_phase_omega_case():
    """margin_test.py test_mag_phase_omega (gh-58): 15/(s^3 + 6 s^2 + 11 s + 6)."""
    sys = control.tf(15, [1, 6, 11, 6])
    gm, pm, _, wpc, wgc, _ = _robrst(*_nd(sys))[0]
    out = control.stability_margins(sys)
    np.testing.assert_allclose([gm, pm, wpc, wgc], np.array(out)[[0, 1, 3, 4]], rtol=1e-7)


@pytest.mark.parametrize("tfargs, omega_ref, gain_ref", [
    (([1], [1, 2, 3, 4]), [1.7325, 0.], [-0.5, 0.25]),
    (([1], [1, 1]), [0.], [1.]),
    (([2], [1, 3, 3, 1]), [1.732, 0.], [-0.25, 2.]),
    (([200.0], [1.0, 21.0, 20.0, 0.0]), [4.47213595, 0], [-0.47619048, inf]),
])
def test_phase_crossover_frequencies_cases(tfargs, omega_ref, gain_ref):
    """margin_test.py test_phase_crossover_frequencies (continuous cases): robrst lists the
    crossings of the negative real axis with finite L, python-control every real one."""
    num, den = (np.asarray(x, float) for x in tfargs)
    wp = analyze(Plant(num, den), UNIT).margins.phase_crossover_rad_s
    keep = [w for w, g in zip(omega_ref, gain_ref) if g < 0 and math.isfinite(g)]
    np.testing.assert_allclose(sorted(wp), sorted(keep), atol=1.5e-3)
    for w, g in zip(omega_ref, gain_ref):
        if g < 0:
            assert loop_value(num, den, w).real == pytest.approx(g, abs=1.5e-3)


@pytest.mark.parametrize("cnum, cden, dt, ref, rtol", [
    ([2], [1, 3, 2, 0], 1e-2,                                          # gh-465
     [2.955761, 32.398492, 0.429535, 1.403725, 0.749367, 0.923898], 1e-5),
    ([2], [1, 3, 3, 1], .1,                                            # 2/(s+1)**3
     [3.4927, 65.4212, 0.5763, 1.6283, 0.76625, 1.2019], 1e-4),
    ([1.1 * 4 * np.pi**2], [1, 2 * 0.2 * 2 * np.pi, 4 * np.pi**2], .05,    # gh-523 a
     [2.3842, 18.161, 0.26953, 11.712, 8.7478, 9.1504], 1e-4),
    ([5e4], [1., 101., 10101., 10100., 10000.], 1e-3,                  # gh-523 b
     [18.8766, 26.3564, 0.406841, 9.76358, 2.32933, 2.55986], 1e-5),
])
def test_stability_margins_discrete_cases(cnum, cden, dt, ref, rtol):
    """margin_test.py test_stability_margins_discrete: TransferFunction(cnum, cden).sample(dt)
    (ZOH), margins of the discrete loop; robrst's sampled loop (w-plane) gives the same
    margins, its frequencies unwarped to physical ones."""
    fs = 1.0 / dt
    pw = sampled_plant(Plant(cnum, cden), fs)
    (gm, pm, sm, wpc, wgc, wms), _ = _robrst(pw.B, pw.A)
    got = [gm, pm, sm, float(unwarp(wpc, fs)), float(unwarp(wgc, fs)), float(unwarp(wms, fs))]
    np.testing.assert_allclose(got, ref, rtol=rtol)
