"""Multi-axis maths core against python-control and SLICOT: realisations, the sampled plant,
the exact sigma_max peak, the closed loop."""

import control
import numpy as np
import pytest

from mimo_stages import random_stage, refined_max, sigma_grid
from robrst.base.errors import SpecError
from robrst.core.mimo import MimoFamily, MimoPlant, combination, sampled_mimo
from robrst.core.mimo_loop import MimoController, mimo_loop
from robrst.core.rst import RSTController
from robrst.core.sigma import sigma_peak

SEEDS = range(6)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("m", [2, 3])
def test_transfer_matrix_realisation_matches_python_control(seed, m):
    g, = random_stage(seed, m)
    P = MimoPlant.from_control(g)
    w = np.geomspace(10.0, 1e5, 50)
    ref = np.moveaxis(g(1j * w), -1, 0)
    assert np.max(np.abs(P.freqresp(w) - ref)) <= 1e-9 * np.max(np.abs(ref))


@pytest.mark.parametrize("seed", SEEDS)
def test_modal_response_at_many_frequencies_matches_python_control(seed):
    """The response from one kept decomposition (the search's candidates' own frequencies)
    against python-control's transfer matrix; and with a defective ``A`` (a Jordan block:
    no well-conditioned eigenvectors) against python-control's state space."""
    g, = random_stage(seed, 3)
    r = MimoPlant.from_control(g).modal_response()
    assert r.lam is not None
    w = np.random.default_rng(seed).uniform(10.0, 1e5, 37)
    ref = np.moveaxis(g(1j * w), -1, 0)
    assert np.max(np.abs(r(w) - ref)) <= 1e-9 * np.max(np.abs(ref))
    A = np.array([[-300.0, 1.0, 0.0], [0.0, -300.0, 1.0], [0.0, 0.0, -300.0]])
    B = np.array([[0.0, 1.0], [0.0, 0.0], [300.0 ** 3, 0.0]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    D = np.array([[0.0, 0.1], [0.0, 0.0]])
    jordan = MimoPlant(A, B, C, D).modal_response()
    assert jordan.lam is None          # solves: the eigenvectors are (nearly) parallel
    ref = np.moveaxis(control.ss(A, B, C, D)(1j * w), -1, 0)
    assert np.max(np.abs(jordan(w) - ref)) <= 1e-9 * np.max(np.abs(ref))


@pytest.mark.parametrize("seed", SEEDS)
def test_sigma_peak_agrees_with_slicot_and_a_dense_grid(seed):
    """The exact peak against SLICOT ab13dd (python-control linfnorm) and a refined grid."""
    g, = random_stage(seed, 2 + seed % 2)
    P = MimoPlant.from_control(g)
    pk = sigma_peak(P.A, P.B, P.C, P.D)
    ref, _ = control.linfnorm(control.ss(g), tol=1e-12)
    grid, _ = refined_max(g, 10.0, 1e5)
    assert abs(pk.value - ref) <= 1e-8 * ref
    assert grid <= pk.value * (1 + 1e-9)
    assert abs(pk.value - grid) <= 1e-6 * pk.value


@pytest.mark.parametrize("seed", SEEDS)
def test_band_peak_and_its_ends(seed):
    """A band below, across and above the resonances: the exact band peak is at least the
    grid maximum inside the band, within 1e-6, and the band ends count."""
    g, = random_stage(seed, 2)
    P = MimoPlant.from_control(g)
    for band in ((100.0, 1500.0), (2000.0, 9000.0), (15000.0, 40000.0)):
        pk = sigma_peak(P.A, P.B, P.C, P.D, band=band)
        grid, _ = refined_max(g, *band)
        ends = sigma_grid(g, np.array(band)).max()
        assert grid <= pk.value * (1 + 1e-9) and ends <= pk.value * (1 + 1e-9)
        assert abs(pk.value - max(grid, ends)) <= 1e-6 * pk.value
        assert band[0] <= pk.freq_rad_s <= band[1]


def test_sampled_plant_is_zoh_through_tustin():
    """The w-plane plant at nu = 2 fs tan(w T / 2) equals python-control's ZOH model at
    z = exp(j w T), with a delay of one sample too."""
    g, = random_stage(3, 3)
    fs = 20000.0
    P = MimoPlant.from_control(g)
    for delay in (0, 1):
        Pw = sampled_mimo(P, fs, delay)
        gd = control.c2d(control.ss(g), 1 / fs, "zoh")
        w = np.geomspace(10.0, 0.99 * np.pi * fs, 40)
        z = np.exp(1j * w / fs)
        ref = np.moveaxis(gd(z), -1, 0) * (z ** -delay)[:, None, None]
        got = Pw.freqresp(2 * fs * np.tan(w / (2 * fs)))
        assert np.max(np.abs(got - ref)) <= 1e-8 * np.max(np.abs(ref))


def _python_control_loop(g, axes, W):
    """``K = W diag(R_i / S_i)`` and the output sensitivity, by python-control."""
    m = len(axes)
    num = [[list(axes[j].R) if i == j else [0.0] for j in range(m)] for i in range(m)]
    den = [[list(axes[j].S) if i == j else [1.0] for j in range(m)] for i in range(m)]
    K = control.ss([], [], [], W) * control.ss(control.tf(num, den))
    I = control.ss([], [], [], np.eye(m))
    return K, control.feedback(I, g * K), control.feedback(g * K, I)


@pytest.mark.parametrize("seed", SEEDS)
def test_closed_loop_against_python_control_feedback(seed):
    g, = random_stage(seed, 3)
    rng = np.random.default_rng(seed)
    axes = [RSTController([rng.uniform(200, 800), 2 * np.pi * 50 * 400], [1.0, 2 * np.pi * 2000,
                                                                           0.0],
                          [1.0]) for _ in range(3)]
    W = np.eye(3) + 0.1 * rng.normal(size=(3, 3))
    P = MimoPlant.from_control(g)
    lp = mimo_loop(P, MimoController(axes, W))
    Kc, So, To = _python_control_loop(control.ss(g), axes, W)
    w = np.geomspace(1.0, 1e5, 60)
    for name, ref in (("S", So), ("T", To)):
        R = np.moveaxis(ref(1j * w), -1, 0)
        assert np.max(np.abs(lp.freqresp(name, w) - R)) <= 1e-8 * max(1.0, np.max(np.abs(R)))
    pc = np.sort(np.linalg.eigvals(So.A).real)[-1]
    assert (lp.spectral_abscissa < 0) == (pc < 0)
    assert abs(lp.spectral_abscissa - pc) <= 1e-6 * max(1.0, abs(pc))


def test_family_between_members_is_the_convex_combination():
    a, b = (MimoPlant.from_control(x) for x in random_stage(2, 2, spread=0.05))
    fam = MimoFamily((a.with_label("a", 20.0), b.with_label("b", 40.0)))
    mid = fam.at(25.0)
    w = np.geomspace(100.0, 1e5, 30)
    assert np.allclose(mid.freqresp(w), 0.75 * a.freqresp(w) + 0.25 * b.freqresp(w),
                       rtol=1e-10, atol=1e-14)
    assert fam.at(40.0) is fam.models[1]
    with pytest.raises(SpecError, match="outside"):
        fam.at(50.0)
    assert combination(a, b, 0.0).n_states == a.n_states + b.n_states


def test_refusals():
    """Non-square loops, unstable or ill-shaped decouplers, families of mixed sizes."""
    g3 = MimoPlant(-np.eye(2), np.ones((2, 3)), np.eye(2), np.zeros((2, 3)))
    K = MimoController([RSTController([1.0], [1.0, 0.0], [1.0])] * 2)
    with pytest.raises(SpecError, match="inputs"):
        mimo_loop(g3, K)
    with pytest.raises(SpecError, match="unstable"):
        MimoController([RSTController([1.0], [1.0, 0.0], [1.0])] * 2,
                       decoupler_ss=([[1.0]], [[1.0, 0.0]], [[1.0], [0.0]], np.eye(2)))
    with pytest.raises(SpecError, match="columns"):
        MimoController([RSTController([1.0], [1.0, 0.0], [1.0])] * 2, np.eye(3))
    g2 = MimoPlant(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2)), "a", 1.0)
    with pytest.raises(SpecError, match="every model"):
        MimoFamily((g2, g3.with_label("b", 2.0)))
    with pytest.raises(SpecError, match="inconsistent"):
        MimoPlant(np.eye(2), np.ones((3, 1)), np.ones((1, 2)), [[0.0]])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_modes_below_a_frequency_are_removed(seed):
    """The truncated model against the partial-fraction sum of the kept modes, computed
    independently from numpy's eigenvectors of the unscaled A (python-control stage plus
    two slow modes: a real pole and a lightly damped pair)."""
    g, = random_stage(seed, 3)
    G = control.ss(g)
    rng = np.random.default_rng(seed)
    slow = control.ss(control.tf([[[rng.uniform(0.5, 2.0)] for _ in range(3)]
                                  for _ in range(3)], [[[1.0, 0.4]] * 3] * 3))
    pair = control.ss(control.tf([[[1.0]] * 3] * 3, [[[1.0, 0.2, 4.0]] * 3] * 3))
    full = control.parallel(control.parallel(G, slow), pair)
    P = MimoPlant.from_control(full, "p")
    fast = P.without_modes_below(2 * np.pi * 1.0)          # 1 Hz
    lam, V = np.linalg.eig(full.A)
    keep = np.abs(lam) >= 2 * np.pi
    CV, WB = full.C @ V, np.linalg.solve(V, full.B)
    w = np.geomspace(0.01, 1e5, 300)
    ref = np.array([(CV[:, keep] / (1j * x - lam[keep])) @ WB[keep] + full.D for x in w])
    got = fast.freqresp(w)
    assert fast.n_states == int(keep.sum()) == P.n_states - int((~keep).sum())
    assert np.max(np.abs(got - ref)) <= 1e-8 * np.max(np.abs(ref))
    assert len(fast.meta["removed_poles"]) == int((~keep).sum())
    assert P.without_modes_below(1e-3) is P                # nothing below: unchanged
