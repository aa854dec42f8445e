"""Sampled loop (ZOH plant, Tustin controller, delay) as an exact continuous-variable loop."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from robrst import poly
from robrst.design import run_problem
from robrst.errors import SpecError
from robrst.hinf import peak_gain
from robrst.plant import paper_plant
from robrst.rst import closed_loop
from robrst.sampled import sampled_plant, unwarp, warp
from robrst.spec import load_problem
from robrst.twin.discrete import discrete_margins, discretize

ROOT = Path(__file__).parents[1]
FS = 20000.0


@pytest.fixture(scope="module")
def controllers():
    out = {}
    for name in ("paper", "paper_robust"):
        out[name] = run_problem(load_problem(ROOT / "problems" / f"{name}.toml")).controller
    return out


def _discrete_closed_loop_poles(plant, ctrl, fs, delay):
    """Eigenvalues of the sampled loop from state space: ZOH plant, Tustin controller, delay."""
    n = plant.n
    w0 = poly.natural_scale(plant.A)
    a = poly.to_scaled(plant.A, w0) / w0 ** n
    b = poly.to_scaled(np.concatenate([np.zeros(n + 1 - len(plant.B)), plant.B]), w0) / w0 ** n
    with warnings.catch_warnings():   # the zero-padded numerator is intended
        warnings.simplefilter("ignore", signal.BadCoefficients)
        ss = signal.tf2ss(b, a)
    Ap, Bp, Cp, Dp, _ = signal.cont2discrete(ss, w0 / fs, method="zoh")
    dc = discretize(ctrl, fs)
    Ac, Bcy, Cc, Dcy = dc.A, dc.B[:, 1:2], dc.C, dc.D[:, 1:2]
    nc = Ac.shape[0]
    # states: plant x, controller xc, then `delay` shift registers of u
    N = n + nc + delay
    M = np.zeros((N, N))
    u_row = np.zeros((1, N))                      # u = Cc xc + Dcy Cp x
    u_row[:, :n] = Dcy @ Cp
    u_row[:, n:n + nc] = Cc
    applied = u_row if delay == 0 else np.eye(N)[n + nc + delay - 1:n + nc + delay]
    M[:n] = Bp @ applied
    M[:n, :n] += Ap
    M[n:n + nc, :n] = Bcy @ Cp
    M[n:n + nc, n:n + nc] = Ac
    if delay:
        M[n + nc] = u_row
        for i in range(1, delay):
            M[n + nc + i, n + nc + i - 1] = 1.0
    return np.linalg.eigvals(M)


def test_warp_round_trip():
    w = np.array([0.0, 1.0, 1e3, 6e4])
    np.testing.assert_allclose(unwarp(warp(w, FS), FS), w, rtol=1e-13, atol=1e-12)
    assert float(unwarp(np.inf, FS)) == pytest.approx(np.pi * FS, rel=1e-15)


@pytest.mark.parametrize("delay", [0, 1, 2])
@pytest.mark.parametrize("name", ["paper", "paper_robust"])
def test_sampled_peak_matches_state_space_frequency_response(controllers, name, delay):
    """Exact Ms of the warped loop vs a dense grid of the ZOH/Tustin state-space loop."""
    ctrl = controllers[name]
    for plant in (paper_plant(), load_problem(ROOT / "problems" / "paper_robust.toml").family.at(45.0)):
        cl = closed_loop(sampled_plant(plant, FS, delay), ctrl)
        exact = peak_gain(cl.nums["S"], cl.Delta).value
        grid = discrete_margins(plant, ctrl, FS, delay_samples=delay, n_grid=20000)["Ms_discrete"]
        assert exact >= grid * (1 - 1e-9)
        assert exact <= grid * (1 + 1e-4)


@pytest.mark.parametrize("delay", [0, 1])
def test_sampled_closed_loop_poles_map_to_the_discrete_ones(controllers, delay):
    plant, ctrl = paper_plant(), controllers["paper"]
    z = _discrete_closed_loop_poles(plant, ctrl, FS, delay)
    q = 2 * FS * (z - 1) / (z + 1)
    cl = closed_loop(sampled_plant(plant, FS, delay), ctrl)
    roots = np.roots(cl.Delta)
    assert len(roots) == len(q)
    for r in roots:   # every warped root has a discrete partner (relative 1e-6)
        assert np.min(np.abs(q - r)) <= 1e-6 * max(abs(r), 1.0)
    assert (np.max(np.abs(z)) < 1) == (np.max(roots.real) < 0)


def test_sampled_problem_is_certified_and_agrees_with_independent_grid():
    res = run_problem(load_problem(ROOT / "problems" / "paper_robust_sampled.toml"))
    assert res.certified
    sp = res.problem.specs
    recs = res.certificate.models
    assert all(m["stable_sampled"] and m["spectral_abscissa_sampled"] < 0 for m in recs)
    for m in recs:
        assert m["Ms_sampled"] <= sp["Ms_max"] * (1 + 1e-3)
        assert m["Mt_sampled"] <= sp["Mt_max"] * (1 + 1e-3)
        assert m["Mu_sampled"] <= sp["Mu_max"] * (1 + 1e-3)
        assert m["Mt_resonance_band_sampled"] <= sp["T_resonance_max"] * (1 + 1e-3)
    for T in (28.0, 45.0):
        rec = next(m for m in recs if m["temperature_C"] == T)
        dm = discrete_margins(res.problem.family.at(T), res.controller, FS, n_grid=20000)
        np.testing.assert_allclose(rec["Ms_sampled"], dm["Ms_discrete"], rtol=1e-4)
    # the continuous-only robust design violates nothing continuous but is worse sampled
    base = run_problem(load_problem(ROOT / "problems" / "paper_robust.toml"))
    dm = discrete_margins(paper_plant(), base.controller, FS, n_grid=20000)
    assert dm["Ms_discrete"] > max(m["Ms_sampled"] for m in recs) + 0.1


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
