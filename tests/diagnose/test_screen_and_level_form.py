"""The screen's held-out scores, the level form's log gains and the FRF/eta2 building
blocks, each against an independent computation (python-control, scipy, numpy)."""

import control
import numpy as np
import pytest
from scipy import signal

from robrst.data.dataset import Dataset
import robrst.diagnose._signals as signals
from robrst.diagnose._effects import summary
from robrst.diagnose.fit import prepare
from robrst.diagnose.linear import LinearPart
from robrst.diagnose._screen import build_screen
from robrst.diagnose.candidates import Setup
from robrst.identify.modal import ModalModel

FS = 5000.0


def _mimo(feedthrough=(0.01, 0.02)):
    poles = np.array([-15.0 + 1j * 2 * np.pi * 400.0, -40.0 + 1j * 2 * np.pi * 900.0, -300.0])
    R = np.array([[[300.0, 120.0], [80.0, 250.0]], [[-150.0, 400.0], [200.0, -90.0]],
                  [[50.0, 20.0], [10.0, 60.0]]], complex)
    return ModalModel(poles, R, np.diag(feedthrough))


def _frf(model, f):
    sys = model.to_control()
    return np.asarray(sys(1j * 2 * np.pi * f))         # python-control, (m, k)


def test_log_gains_make_the_level_extrapolation_independent_of_the_free_split():
    """Mode gains +c and input gains -c leave every level's model unchanged (no
    feedthrough: the records cannot tell the two apart), so a slope that moves along that
    split extrapolates to the same model (python-control FRFs)."""
    lin = LinearPart(_mimo((0.0, 0.0)), FS, modal_gains=True)
    rng = np.random.default_rng(4)
    theta0 = 0.02 * rng.standard_normal(lin.size)
    slope = 0.05 * rng.standard_normal(lin.size)
    split = np.array([1.0 if k == "mode_gain" else -1.0 if k == "input_gain" else 0.0
                      for k, _ in lin.kinds])
    for f in (0.0, 1.0, 2.0):                      # fitted levels 0, 1; extrapolated 2
        a = lin.continuous(theta0 + f * slope)
        b = lin.continuous(theta0 + 0.4 * split + f * (slope + 0.3 * split))
        for fr in (10.0, 400.0, 650.0, 900.0, 2000.0):
            assert np.allclose(_frf(a, fr), _frf(b, fr), rtol=1e-10, atol=1e-12)
    # with 1 + t factors the same split does change the extrapolation (the reason for logs)
    plain = (1 + 0.4 + 2 * 0.3) * (1 - 0.4 - 2 * 0.3)
    assert abs(plain - 1.0) > 0.5


def test_eta2_with_few_values_matches_the_definition_on_a_long_record():
    rng = np.random.default_rng(1)
    x = rng.integers(-1, 2, 50_000).astype(float)          # three values
    x[-1] = 7.0                                            # one more, only at the end
    r = 0.3 * x + rng.standard_normal(x.size)
    vals = np.unique(x)
    cnt = np.array([np.sum(x == v) for v in vals])
    means = np.array([r[x == v].mean() for v in vals])
    between = float(np.sum(cnt * (means - r.mean()) ** 2))
    assert signals.eta2(r, x) == pytest.approx(between / np.sum((r - r.mean()) ** 2), rel=1e-10)


def test_frf_departure_is_welchs_h1():
    """H1 = S_yu S_uu^-1 from scipy.signal.csd, against the departure's largest error."""
    rng = np.random.default_rng(2)
    model = _mimo()
    n = 20_000
    u = rng.standard_normal((n, 2))
    dsys = control.c2d(model.to_control(), 1 / FS, method="zoh")
    y = np.asarray(control.forced_response(dsys, U=u.T).outputs).T
    y = 1.05 * y + 1e-3 * rng.standard_normal(y.shape)          # a 5 % gain error
    d = Dataset(t=np.arange(n) / FS, u=u, y=y)
    out = signals.frf_departure([d], model.discretise(FS), FS)
    nper = 2048
    U, Y = u - u.mean(0), y - y.mean(0)
    f, Suu = signal.csd(U[:, :, None], U[:, None, :], fs=FS, nperseg=nper, axis=0)
    _, Suy = signal.csd(U[:, :, None], Y[:, None, :], fs=FS, nperseg=nper, axis=0)
    _, Syy = signal.csd(Y, Y, fs=FS, nperseg=nper, axis=0)
    H1 = np.array([np.linalg.solve(Suu[i].T, Suy[i]).T for i in range(1, f.size)])
    g2 = np.real(np.einsum("fmk,fkm->fm", H1, Suy[1:])) / Syy[1:].real
    Hm = model.discretise(FS).transfer(np.exp(2j * np.pi * f[1:] / FS))
    rel = np.abs(H1 - Hm) / np.max(np.abs(Hm), axis=0)[None]
    use = np.broadcast_to((g2 > 0.5)[:, :, None], rel.shape)
    assert out["band_hz"] is not None
    assert out["max_rel_error"] <= np.max(rel[use]) * (1 + 1e-9)
    assert out["max_rel_error"] >= 0.5 * np.max(rel[use])


@pytest.mark.slow
def test_held_out_screen_scores_equal_explicit_columns():
    """A candidate's held-out gap from one prediction per record equals the gap of the same
    coefficients applied to every column simulated on its own (python-control)."""
    model = _mimo()
    dsys = control.c2d(model.to_control(), 1 / FS, method="zoh")

    def rec(seed, n=6000):
        g = np.random.default_rng(seed)
        u = np.repeat(g.uniform(-1, 1, (n // 50, 2)), 50, axis=0)
        v = u + 0.2 * np.maximum(u - 0.3, 0.0)          # a static input nonlinearity
        y = np.asarray(control.forced_response(dsys, U=v.T).outputs).T
        return Dataset(t=np.arange(n) / FS, u=u, y=y + 1e-4 * g.standard_normal(y.shape),
                       source=f"r{seed}")

    train, test = [rec(1), rec(2)], [rec(3)]
    lin = LinearPart(model, FS)
    prep = [prepare(d, 28.0) for d in train]
    full = [prepare(d, 28.0, for_fit=False) for d in test]
    setup = Setup(fs=FS, ref=28.0, train=prep, train_full=prep, test=full, test_records=test,
                  train_records=train, lin=lin, lin_modal=lin, stats=summary(train),
                  noise_sigma=1e-4, plant=None, effects=("input_nonlinearity", "saturation"),
                  dynamic=False, delays=(0, 0), saturation=[], floor=1e-4, gap_before=1.0,
                  gap_before_train=1.0)
    screen = build_screen(setup, np.zeros(lin.size))
    th = np.zeros(lin.size)
    for key in ("input_nonlinearity", "saturation"):
        fit = screen.fit((key,))
        p = full[0]
        yL, JL = lin.simulate_jac(th, p.U)
        pred = yL.copy()
        for name, b in fit.beta.items():
            kind, col = name.split(":", 1)
            if kind == "linear":
                pred += b * JL[:, :, lin.names.index(col)]
                continue
            j = int(col.rsplit("_u", 1)[1]) - 1
            x = _basis(setup, screen, key, col, p.U[:, j], j)
            resp = np.zeros((len(x), 2))
            resp[:, :] = np.asarray(control.forced_response(
                dsys[:, j], U=x).outputs).T
            pred += b * resp
        gap = np.sqrt(np.sum((p.Y - pred) ** 2) / np.sum((p.Y - p.Y.mean(0)) ** 2))
        assert fit.gap == pytest.approx(gap, rel=1e-6)


def _basis(setup, screen, key, col, u, j):
    """The basis signal of a screen column, rebuilt from its definition."""
    from robrst.diagnose.options import OPTIONS
    U_all = np.concatenate([p.U for p in setup.train])
    if col.startswith("high"):
        q = float(col[4:].split("_")[0])
        return np.maximum(u - np.quantile(U_all[:, j], q), 0.0)
    if col.startswith("low"):
        q = float(col[3:].split("_")[0])
        return np.minimum(u - np.quantile(U_all[:, j], q), 0.0)
    centre = 0.5 * (U_all[:, j].min() + U_all[:, j].max())
    half = max(0.5 * np.ptp(U_all[:, j]), 1e-12)
    e = (u - centre) / half
    if col.startswith("quadratic"):
        return e ** 2
    if col.startswith("cubic"):
        return e ** 3
    if col.startswith("hinge"):
        q = int(col[5:].split("_")[0])
        return np.maximum(u - setup.stats["knots"][q], 0.0)
    raise AssertionError(f"unexpected column {col} ({OPTIONS.screen.sat_high},"
                         f" {OPTIONS.screen.sat_low})")
