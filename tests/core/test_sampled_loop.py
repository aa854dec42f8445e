"""Sampled loop (ZOH plant, Tustin controller, delay) as an exact continuous-variable loop.

The independent reference is python-control's discrete loop: ``control.c2d`` of the
plant (ZOH) and of the controller (Tustin), both in a time-scaled variable so their
coefficients are O(1), closed with ``control.feedback``; peaks on a dense unit-circle
grid with local refinement.
"""

import control
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from robrst.base.errors import SpecError
from robrst.core.peaks import peak_gain
from robrst.core.plant import paper_plant
from robrst.core.rst import closed_loop
from robrst.core.sampled import sampled_plant, unwarp, warp
from robrst.problem.files import load_problem

FS = 20000.0


def _scaled_tf(num, den, w0, dt=None):
    """``num(w0 p)/den(w0 p)`` with O(1) coefficients (numerator padded to deg den)."""
    n = len(den) - 1
    num = np.concatenate([np.zeros(n + 1 - len(num)), num])
    k = w0 ** -np.arange(n + 1)            # c_k / w0^k, highest power first
    args = (num * k, den * k) if dt is None else (num * k, den * k, dt)
    return control.tf(*args)


def python_control_loop(plant, ctrl, fs, delay):
    """(discrete loop gain L(z) = P_d z^-k K_d, closed-loop poles) from python-control."""
    w0 = float(np.sqrt(abs(plant.A[-1])) ** (2 / plant.n)) or 1.0   # any O(1) time scale
    h = w0 / fs
    Pd = control.c2d(control.ss(_scaled_tf(plant.B, plant.A, w0)), h, "zoh")
    Kd = control.c2d(control.ss(_scaled_tf(ctrl.R, ctrl.S, w0)), h, "tustin")
    if delay:
        Pd = Pd * control.tf([1.0], [1.0] + [0.0] * delay, h)
    L = Pd * Kd
    poles = control.feedback(Pd, Kd).poles()
    return L, poles


def unit_circle_peak(L, fs, n=20000):
    """max |1/(1 + L)| over the unit circle: dense grid plus local refinement."""
    h = L.dt
    w = np.linspace(1e-6, np.pi, n)
    f = lambda x: abs(1.0 / (1.0 + complex(L(np.exp(1j * x)))))  # noqa: E731
    g = np.abs(1.0 / (1.0 + L(np.exp(1j * w)).ravel()))
    i = int(np.argmax(g))
    r = minimize_scalar(lambda x: -f(x), bounds=(w[max(i - 1, 0)], w[min(i + 1, n - 1)]),
                        method="bounded", options={"xatol": 1e-12})
    assert h > 0
    return max(g[i], -r.fun)


def test_warp_round_trip():
    w = np.array([0.0, 1.0, 1e3, 6e4])
    np.testing.assert_allclose(unwarp(warp(w, FS), FS), w, rtol=1e-13, atol=1e-12)
    assert float(unwarp(np.inf, FS)) == pytest.approx(np.pi * FS, rel=1e-15)


@pytest.mark.parametrize("delay", [0, 1, 2])
@pytest.mark.parametrize("name", [     # the robust design takes 10-20 s: -m slow
    "paper", pytest.param("paper_robust_continuous", marks=pytest.mark.slow)])
def test_sampled_peak_matches_python_control_discrete_loop(designs, name, delay):
    """Exact Ms of the warped loop vs python-control's discrete loop on the unit circle."""
    ctrl = designs(name).controller
    for plant in (paper_plant(), load_problem("paper_robust").family.at(45.0)):
        cl = closed_loop(sampled_plant(plant, FS, delay), ctrl)
        exact = peak_gain(cl.nums["S"], cl.Delta).value
        L, _ = python_control_loop(plant, ctrl, FS, delay)
        ref = unit_circle_peak(L, FS)
        assert exact == pytest.approx(ref, rel=1e-6)


@pytest.mark.parametrize("delay", [0, 1])
def test_sampled_closed_loop_poles_map_to_the_discrete_ones(designs, delay):
    plant, ctrl = paper_plant(), designs("paper").controller
    _, z = python_control_loop(plant, ctrl, FS, delay)
    q = 2 * FS * (z - 1) / (z + 1)
    cl = closed_loop(sampled_plant(plant, FS, delay), ctrl)
    roots = np.roots(cl.Delta)
    assert len(roots) == len(q)
    for r in roots:   # every warped root has a discrete partner (relative 1e-6)
        assert np.min(np.abs(q - r)) <= 1e-6 * max(abs(r), 1.0)
    assert (np.max(np.abs(z)) < 1) == (np.max(roots.real) < 0)


def test_sampled_problem_is_certified_and_agrees_with_python_control(designs):
    res = designs("paper_robust")
    assert res.certified
    sp = res.problem.specs
    recs = res.certificate.models
    assert all(m.sampled.stable and m.sampled.spectral_abscissa < 0 for m in recs)
    for m in recs:
        assert m.sampled.Ms <= sp.Ms_max * (1 + 1e-3)
        assert m.sampled.Mt <= sp.Mt_max * (1 + 1e-3)
        assert m.sampled.Mu <= sp.Mu_max * (1 + 1e-3)
        assert m.sampled.Mt_resonance_band <= sp.T_resonance_max * (1 + 1e-3)
    for T in (28.0, 45.0):
        rec = next(m for m in recs if m.temperature_C == T)
        L, poles = python_control_loop(res.problem.family.at(T), res.controller, FS, 0)
        assert rec.sampled.Ms == pytest.approx(unit_circle_peak(L, FS), rel=1e-6)
        assert np.max(np.abs(poles)) < 1


@pytest.mark.slow      # the continuous-only robust design: 10-20 s
def test_only_the_sampled_design_rolls_off_at_nyquist(designs):
    """The continuous-only robust design does not roll off: once sampled it spends a
    sizeable share of the amplifier's bound at Nyquist, |U| = |K_d / (1 + L)| at z = -1
    (its continuous certificate never sees that frequency; an earlier answer went beyond
    the bound), where the sampled design's K_d(-1) = 0."""
    sp = designs("paper_robust").problem.specs
    for name, bad in (("paper_robust_continuous", True), ("paper_robust", False)):
        ctrl = designs(name).controller
        L, _ = python_control_loop(paper_plant(), ctrl, FS, 0)
        w0 = float(np.sqrt(abs(paper_plant().A[-1])) ** (2 / 3))
        Kd = control.c2d(control.ss(_scaled_tf(ctrl.R, ctrl.S, w0)), w0 / FS, "tustin")
        u_nyq = abs(complex(Kd(-1.0)) / (1 + complex(L(-1.0))))
        assert (u_nyq > 0.1 * sp.Mu_max) == bad
        if not bad:
            assert u_nyq <= 1e-6 * sp.Mu_max     # roll-off: strictly proper K -> K_d(-1) = 0


@pytest.mark.parametrize("edit,key", [
    ("sample_rate_hz = -5.0", "sample_rate_hz"),
    ("delay_samples = 1", "delay_samples"),
])
def test_bad_sampling_specs_name_the_key(tmp_path, edit, key):
    f = tmp_path / "p.toml"
    f.write_text(f'[plant]\nname = "paper"\n[poles]\nwn = 600.0\nzeta = 1.0\n[specs]\n{edit}\n')
    with pytest.raises(SpecError, match=key):
        load_problem(f)


def test_sampled_plant_rejects_bad_arguments():
    with pytest.raises(SpecError, match="sampling rate"):
        sampled_plant(paper_plant(), 0.0)
    with pytest.raises(SpecError, match="delay_samples"):
        sampled_plant(paper_plant(), FS, -1)


def test_family_memo_is_per_family_and_matches_the_plain_computation():
    """``PlantFamily.at`` and ``.sampled`` compute once per temperature / model; a family
    made by ``dataclasses.replace`` or unpickled starts with its own, empty memo."""
    import dataclasses
    import pickle

    fam = load_problem("paper_robust").family
    m = fam.at(31.5)
    assert fam.at(31.5) is m
    ps = fam.sampled(m, FS, 1)
    assert fam.sampled(m, FS, 1) is ps
    ref = sampled_plant(m, FS, 1)            # the plain computation, bit for bit
    assert np.array_equal(ps.B, ref.B) and np.array_equal(ps.A, ref.A)
    assert fam.sampled(m, FS, 0) is not ps   # another delay: another plant
    other = dataclasses.replace(fam, thermal=dataclasses.replace(fam.thermal, gain_per_K=0.01))
    assert other.memo == {} and other.at(31.5) is not m
    assert not np.allclose(other.at(31.5).B, m.B)
    assert pickle.loads(pickle.dumps(fam)).memo == {}
