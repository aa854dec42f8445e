"""The wider effect library: round trips, the exact screen, sensor faults.

Round trips: noise-free records of the twin (or of python-control for the two-channel
cross-coupling) with known parameters; :func:`robrst.diagnose.estimate.fit_effects`
recovers them.  The screen's held-out gaps are checked against an explicit least-squares
solve on the stacked columns; the sensor-fault detector against spikes and dropouts put
in by hand.
"""

from dataclasses import replace

import control
import numpy as np
import pytest

from robrst.core.plant import paper_plant
from robrst.data.dataset import Dataset
from robrst.diagnose._effects import pi_thresholds, summary
from robrst.diagnose.estimate import fit_effects
from robrst.diagnose._sensor import find_faults, repair
from robrst.identify.modal import ModalModel
from robrst.twin.config import default_twin
from robrst.twin.simulate import simulate

FS = 5000.0


def _steps(n, seed, lo, hi, hold=400):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(lo, hi, n // hold + 1), hold)[:n]
    u[:hold] = lo
    return u


def _twin(effect, over, lo=5.0, hi=145.0, n=30000, seeds=(5, 6)):
    cfg = replace(default_twin().with_effects(only=[effect], **{effect: over}), sample_rate_hz=FS)
    out = []
    for s in seeds:
        u = _steps(n, s, lo, hi)
        r = simulate(cfg, np.full(n, 28.0), u=u)
        out.append(Dataset(t=np.arange(n) / FS, u=u, y=r.y, temp=np.full(n, 28.0)))
    return out


@pytest.mark.parametrize("effect,over,names,kw", [
    pytest.param("input_nonlinearity",
                 {"dead_zone_V": 8.0, "center_V": 0.0, "quadratic_per_V": 1e-3},
                 {"dead_zone_V": 8.0, "center_V": 0.0, "quadratic_per_V": 1e-3},
                 {"lo": -70, "hi": 70}, marks=pytest.mark.slow),
    ("output_nonlinearity", {"center_um": 40.0, "quadratic_per_um": 2e-3, "cubic_per_um2": -1e-5},
     {}, {}),
    ("slew", {"V_per_s": 2e4, "V_per_s_down": 8e3}, {"V_per_s": 2e4, "V_per_s_down": 8e3}, {}),
    pytest.param("stiffness_nonlinearity", {"cubic_per_um2": 3e-6}, {"cubic_per_um2": 3e-6},
                 {}, marks=pytest.mark.slow),
])
def test_round_trip(effect, over, names, kw):
    recs = _twin(effect, over, **kw)
    # the sensor map's linear term about the training mean is a gain: fitted jointly
    fit = fit_effects(recs, [effect], paper_plant(), 28.0, max_nfev=80,
                      joint=effect == "output_nonlinearity")
    for k, v in names.items():
        # a centre of 0 V is met to 1e-3 V (the twin integrates by RK4, the fit is exact ZOH)
        assert fit.params[k] == pytest.approx(v, rel=1e-3, abs=1e-3 if k == "center_V" else 0), k
    if effect == "output_nonlinearity":
        # the fitted map (gain g, then the polynomial about the training mean c0, and the
        # offset) is the true sensor map y + a (y - 40)^2 + b (y - 40)^3 over the records'
        # range, to 1e-3 µm
        p, g = fit.params, fit.linear_change["gain"]
        y = np.linspace(min(r.y.min() for r in recs), max(r.y.max() for r in recs), 200)
        e = (1 + g) * y - p["center_um"]
        got = (1 + g) * y + p["quadratic_per_um"] * e ** 2 + p["cubic_per_um2"] * e ** 3 \
            + p["offset_um"]
        true = y + 2e-3 * (y - 40.0) ** 2 - 1e-5 * (y - 40.0) ** 3
        assert np.max(np.abs(got - true)) < 1e-3
    assert fit.gap < 1e-3 * fit.gap_linear or fit.gap < 1e-5


def test_prandtl_ishlinskii_round_trip_on_the_grid_thresholds():
    recs0 = _twin("pi_hysteresis", {})
    thr = pi_thresholds(summary(recs0))
    w = tuple(0.04 * (1 + 0.5 * np.sin(i)) for i in range(len(thr)))
    recs = _twin("pi_hysteresis", {"thresholds_V": thr, "weights": w})
    fit = fit_effects(recs, ["pi_hysteresis"], paper_plant(), 28.0, max_nfev=40)
    got = [fit.params[f"weight_{i + 1}"] for i in range(len(thr))]
    np.testing.assert_allclose(got, w, rtol=0, atol=1e-4)


@pytest.mark.slow
def test_cross_coupling_round_trip_two_channels():
    """Two stages simulated by python-control, input 2 driving stage 1 at 15 %, output 1
    leaking into output 2 at -8 %; the model is diagonal."""
    w1, w2 = 2 * np.pi * 420.0, 2 * np.pi * 690.0
    g1 = control.tf([0.5 * w1 * w1], [1, 2 * 0.03 * w1, w1 * w1])
    g2 = control.tf([0.3 * w2 * w2], [1, 2 * 0.02 * w2, w2 * w2])
    d1, d2 = control.c2d(g1, 1 / FS, "zoh"), control.c2d(g2, 1 / FS, "zoh")
    recs = []
    for s in (1, 2):
        U = np.column_stack([_steps(20000, s, -50, 50), _steps(20000, 10 + s, -50, 50, 300)])
        y1 = np.ravel(control.forced_response(d1, U=U[:, 0] + 0.15 * U[:, 1]).outputs)
        y2 = np.ravel(control.forced_response(d2, U=U[:, 1]).outputs) - 0.08 * y1
        recs.append(Dataset(t=np.arange(20000) / FS, u=U, y=np.column_stack([y1, y2])))
    poles, res = [], []
    for j, (g, w) in enumerate(((g1, w1), (g2, w2))):
        den = np.ravel(g.den[0][0])
        p = [r for r in np.roots(den) if r.imag > 0][0]
        R = np.zeros((2, 2), complex)
        R[j, j] = np.ravel(g.num[0][0])[-1] / np.polyval(np.polyder(den), p)
        poles.append(p)
        res.append(R)
    model = ModalModel(np.array(poles), np.array(res), np.zeros((2, 2)))
    fit = fit_effects(recs, ["cross_coupling"], model, max_nfev=40)
    assert fit.params["u2_into_u1"] == pytest.approx(0.15, abs=1e-6)
    assert fit.params["y1_into_y2"] == pytest.approx(-0.08, abs=1e-6)
    assert abs(fit.params["u1_into_u2"]) < 1e-6 and abs(fit.params["y2_into_y1"]) < 1e-6


def test_screen_gaps_are_exact_least_squares():
    """The Gram-based screen of a candidate equals an explicit least-squares fit of the
    same columns (numpy lstsq on the stacked training columns, scored on the test ones)."""
    from robrst.diagnose._diagnosis import diagnose

    recs = _twin("output_nonlinearity", {"center_um": 40.0, "quadratic_per_um": 2e-3},
                 seeds=(5, 6, 7))
    rng = np.random.default_rng(0)
    recs = [replace(d, y=d.y + 0.01 * rng.standard_normal(d.n)) for d in recs]
    d = diagnose(recs[:2], recs[2:], effects=("output_nonlinearity", "creep"))
    got = next(s.gap for s in d.screen if s.name == "output_nonlinearity")
    # the same model by hand: y = y0 + J dtheta + a0 + a2 E^2 + a3 E^3 (E about the
    # training mean, scaled by the half range), ridge of the corrections' priors
    from robrst.diagnose.linear import LinearPart
    lin = LinearPart(paper_plant(), FS)
    Yall = np.concatenate([r.y for r in recs[:2]])
    c0, h = Yall.mean(), 0.5 * np.ptp(Yall)

    def cols(r):
        y0, J = lin.simulate_jac(np.zeros(lin.size), r.u[:, None])
        E = (y0[:, 0] - c0) / h
        return np.column_stack([J[:, 0, :], np.ones(r.n), E ** 2, E ** 3]), r.y - y0[:, 0]

    A = [cols(r) for r in recs[:2]]
    X = np.vstack([a for a, _ in A])
    b = np.concatenate([r for _, r in A])
    # the priors' ridge on the corrections (noise std from the diagnosis)
    sig = d.data.noise_sigma_um
    ridge = np.concatenate([(sig / lin.prior_sd) ** 2, np.zeros(3)])
    beta = np.linalg.solve(X.T @ X + np.diag(ridge) + 1e-9 * np.diag(np.diag(X.T @ X)),
                           X.T @ b)
    T = [cols(r) for r in recs[2:]]
    res = np.concatenate([r - a @ beta for a, r in T])
    den = sum(float(np.sum((r.y - r.y.mean()) ** 2)) for r in recs[2:])
    assert got == pytest.approx(np.sqrt(np.sum(res ** 2) / den), rel=1e-6)


def test_sensor_faults_found_exactly_and_ringing_left_alone():
    rng = np.random.default_rng(3)
    n = 20000
    t = np.arange(n) / FS
    model = 40 + 30 * np.sin(2 * np.pi * 3 * t)
    ring = 0.3 * np.exp(-((t - 1.0) % 0.5) * 20) * np.sin(2 * np.pi * 616 * t)   # model error
    y = model + ring + 0.01 * rng.standard_normal(n)
    clean = find_faults("r", y, model)
    assert clean.outliers.size == 0 and clean.dropouts == ()
    spikes = rng.choice(np.arange(100, n - 100), 20, replace=False)
    y2 = y.copy()
    y2[spikes] += rng.choice([-1, 1], 20) * rng.uniform(1, 5, 20)
    y2[5000:5050] = 0.0                                  # a 10 ms dropout to zero
    f = find_faults("r", y2, model)
    assert set(spikes) <= set(f.outliers) and len(f.outliers) <= len(spikes) + 2
    assert f.dropouts == ((5000, 5050),) or f.dropouts[0][0] in (4999, 5000)
    fixed, rep = repair([Dataset(t=t, u=np.ones(n), y=y2, source="r")], [model[:, None]], FS)
    assert rep["outliers"] >= 20 and rep["dropouts"] == 1
    # the repaired samples carry the model plus the neighbours' residual, not the fault
    assert np.max(np.abs(fixed[0].y - y)[spikes]) < 0.2
