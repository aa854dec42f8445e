"""Performance under the input-gain sector: the certificate's small-gain bounds on the peaks
of ``S``, ``T`` and ``K S`` for every input gain in ``[1 - delta, 1 + delta]``.

Checked independently with python-control on seeded coupled stages: the bound recomputed
from dense-grid singular-value peaks of the unscaled loop (``S``, ``T``, ``K S``, ``S G``,
``K S G``), and the loops python-control closes through ``G (I + Delta)`` for constant gains
in the sector (every corner of the per-input gains, random per-input gains, and full
matrices ``Delta`` of norm ``delta``): stable, and every peak at or below the bound.
"""

import control
import numpy as np
import pytest

from mimo_stages import random_stage, refined_max
from robrst.base.errors import SpecError
from robrst.certificate.mimo import certify_mimo
from robrst.core.mimo import MimoFamily, MimoPlant
from robrst.core.mimo_loop import MimoController
from robrst.core.rst import RSTController
from robrst.problem.mimo import MimoSpecs


def _controller(g, seed):
    """An integral law rolled off at 2 kHz behind the static inverse (crossover 5-15 Hz)."""
    rng = np.random.default_rng(seed)
    W = np.linalg.inv(np.real(control.dcgain(g)))
    wc, wr = 2 * np.pi * rng.uniform(5.0, 15.0), 2 * np.pi * 2000.0
    axes = [RSTController([wc * wr], [1.0, wr, 0.0], [wc * wr]) for _ in range(g.noutputs)]
    return MimoController(axes, W), axes, W


def _pc_K(axes, W):
    m = len(axes)
    num = [[list(axes[j].R) if i == j else [0.0] for j in range(m)] for i in range(m)]
    den = [[list(axes[j].S) if i == j else [1.0] for j in range(m)] for i in range(m)]
    return control.ss([], [], [], W) * control.ss(control.tf(num, den))


def _peak(sys):
    return max(refined_max(sys, 0.5, 1e6)[0],
               float(np.linalg.svd(np.atleast_2d(control.dcgain(sys)), compute_uv=False)[0]))


def _loops(G, K):
    m = G.noutputs
    I = control.ss([], [], [], np.eye(m))
    S = control.feedback(I, G * K)
    return {"S": S, "T": control.feedback(G * K, I), "U": control.feedback(K, G)}


@pytest.mark.parametrize("seed,m", [(2, 2), pytest.param(11, 3, marks=pytest.mark.slow)])
def test_sector_bounds_hold_for_every_gain_python_control_closes(seed, m):
    g, = random_stage(seed, m)
    ctrl, axes, W = _controller(g, seed)
    G, K = control.ss(g), _pc_K(axes, W)
    Ti = control.feedback(K * G, control.ss([], [], [], np.eye(m)))
    ti = _peak(Ti)
    delta = 0.6 / ti                   # inside the small-gain sector, from python-control
    cert = certify_mimo(MimoFamily((MimoPlant.from_control(g, "stage", 20.0),)), ctrl,
                        MimoSpecs(input_gain_deviation=delta))
    pk = cert.models[0].continuous.peaks
    # the bound recomputed from python-control's peaks of the unscaled loop
    nom = _loops(G, K)
    s, t, u = (_peak(nom[k]) for k in "STU")
    sd = _peak(control.feedback(G, K))
    cross = sd * u * delta / (1 - delta * ti)
    for fig, ref in (("S", s + cross), ("T", t + cross), ("U", u / (1 - delta * ti))):
        assert pk[f"sector_{fig}"].value == pytest.approx(ref, rel=1e-6), fig
        assert pk[f"sector_{fig}"].verified
    # constant gains in the sector: corners, random per-input gains, full matrices
    rng = np.random.default_rng(seed)
    deltas = [np.diag(c) for c in np.array(np.meshgrid(*[[-delta, delta]] * m)).reshape(m, -1).T]
    deltas += [np.diag(rng.uniform(-delta, delta, m)) for _ in range(3)]
    for _ in range(3):
        M = rng.normal(size=(m, m))
        deltas.append(delta * M / np.linalg.svd(M, compute_uv=False)[0])
    worst = dict.fromkeys("STU", 0.0)
    for D in deltas:
        lp = _loops(G * control.ss([], [], [], np.eye(m) + D), K)
        assert np.all(lp["S"].poles().real < 0)
        for k in "STU":
            v = _peak(lp[k])
            worst[k] = max(worst[k], v)
            assert v <= pk[f"sector_{k}"].value * (1 + 1e-6), (k, v, pk[f"sector_{k}"].value)
    assert worst["S"] > s * (1 + 1e-3)      # not vacuous: the gains move the peak


def test_a_sector_bound_is_certified_and_refused():
    """A ``sector_S_max`` makes the certificate tighten the product bound by the scaled
    small-gain test: never above it, never below what python-control's loops through
    constant gains in the sector reach; certified just above, refused just below."""
    g, = random_stage(2, 2)
    ctrl, axes, W = _controller(g, 2)
    fam = MimoFamily((MimoPlant.from_control(g, "stage", 20.0),))
    delta = 0.2
    base = certify_mimo(fam, ctrl, MimoSpecs(input_gain_deviation=delta))
    product = base.worst("sector_S")
    assert product > base.worst("sigma_S")
    asked = certify_mimo(fam, ctrl, MimoSpecs(input_gain_deviation=delta, sector_S_max=1e9))
    v = asked.worst("sector_S")
    assert v <= product
    m = g.noutputs
    G, K = control.ss(g), _pc_K(axes, W)
    for c in np.array(np.meshgrid(*[[-delta, delta]] * m)).reshape(m, -1).T:
        lp = _loops(G * control.ss([], [], [], np.eye(m) + np.diag(c)), K)
        assert _peak(lp["S"]) <= v * (1 + 1e-6)
    assert certify_mimo(fam, ctrl, MimoSpecs(input_gain_deviation=delta,
                                             sector_S_max=1.01 * v)).certified
    bad = certify_mimo(fam, ctrl, MimoSpecs(input_gain_deviation=delta, sector_S_max=0.99 * v))
    assert not bad.certified and [x.quantity for x in bad.violations] == ["sector_S"]


def test_a_sector_bound_needs_the_sector():
    with pytest.raises(SpecError, match="sector_S_max.*input_gain_deviation"):
        MimoSpecs(sector_S_max=2.0)
