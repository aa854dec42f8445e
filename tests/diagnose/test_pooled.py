"""Periodic records pooled into their sufficient statistics (``robrst.diagnose.fit.pool_periodic``).

Stated before the run: for any linear model, the squared error of the pooled records plus
the pool's constant equals the squared error of the records themselves — checked with an
independent simulator (python-control: the model as a discrete state space, ZOH, run for
enough periods that the transient has died, the last period kept), for the model the
records came from and for two other models; and a linear re-fit (``fit_model``) on pooled
records ends where it ends on the records themselves (same corrections, cost and
1-sigma), with fewer records in the fit.
"""

import control
import numpy as np
import pytest
from scipy.linalg import block_diag

import robrst.diagnose.fit as fitmod
from robrst.diagnose._effects import Chain
from robrst.diagnose.fit import Prepared, fit_model, pool_periodic
from robrst.diagnose.linear import LinearPart
from robrst.identify.modal import ModalModel

FS = 2000.0
N = 400


def _model(seed, shift=1.0):
    """Two inputs, two outputs, two well-damped resonances (continuous time, modal)."""
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * np.array([120.0, 310.0]) * shift
    z = np.array([0.2, 0.15])
    poles = -z * w + 1j * w * np.sqrt(1 - z ** 2)
    R = (rng.normal(size=(2, 2, 2)) + 1j * rng.normal(size=(2, 2, 2))) * 300.0
    return ModalModel(poles, R, np.zeros((2, 2)))


def _ss(model):
    """The model as a real continuous state space (python-control), from its poles and
    residues: a 2-state block per mode and input, ``xi' = p xi + u_j``, ``y += 2 Re(R xi)``."""
    n_in = model.residues.shape[2]
    blocks_A, blocks_B, blocks_C = [], [], []
    for p, r in zip(model.poles, model.residues):
        for j in range(n_in):
            blocks_A.append(np.array([[p.real, -p.imag], [p.imag, p.real]]))
            b = np.zeros((2, n_in))
            b[0, j] = 1.0
            blocks_B.append(b)
            blocks_C.append(np.column_stack([2 * r.real[:, j], -2 * r.imag[:, j]]))
    return control.ss(block_diag(*blocks_A), np.vstack(blocks_B), np.hstack(blocks_C),
                      model.D)


def _steady(sysd, U, periods=12):
    """The last period of the discrete system driven by ``periods`` repeats of ``U``."""
    u = np.tile(U, (periods, 1)).T
    t = np.arange(u.shape[1]) / FS
    y = control.forced_response(sysd, T=t, U=u).outputs
    return np.asarray(y).T[-len(U):]


def _records(seed, n=7):
    rng = np.random.default_rng(seed)
    sysd = control.c2d(_ss(_model(0)), 1 / FS, "zoh")
    out = []
    for i in range(n):
        f = np.fft.rfft(rng.normal(size=(N, 2)), axis=0)
        f[N // 8:] = 0.0                        # a band-limited multisine-like input
        f[0] = 0.3
        U = np.fft.irfft(f, n=N, axis=0)
        Y = _steady(sysd, U) + 0.05 * rng.normal(size=(N, 2))
        out.append(Prepared(f"r{i}", U, Y, np.zeros(N), True, N, 1.0 + 0.2 * i, 1.0))
    return out


@pytest.mark.parametrize("shift", [1.0, 1.07, 0.9])
def test_pooled_error_plus_constant_is_the_records_error(shift):
    recs = _records(1)
    pooled = pool_periodic(recs)
    assert len(pooled.records) == 2 and pooled.rows == 7 * N * 2
    sysd = control.c2d(_ss(_model(0, shift)), 1 / FS, "zoh")
    err = sum(p.weight ** 2 * np.sum((p.Y - _steady(sysd, p.U)) ** 2) for p in recs)
    err_pooled = sum(np.sum((p.Y - _steady(sysd, p.U)) ** 2) for p in pooled.records)
    assert err_pooled + pooled.constant == pytest.approx(err, rel=1e-9)


def test_pooled_fit_equals_the_fit_on_the_records(monkeypatch):
    recs = _records(2)
    lin = LinearPart(_model(0, 1.03), FS)
    chain = Chain((), 2, FS, 28.0, {})
    a = fit_model("linear", (), recs, lin, chain, 0.05, max_nfev=30)
    monkeypatch.setattr(fitmod, "pool_periodic", lambda train, by_level=False: fitmod.Pooled(
        list(train), 0.0, int(sum(p.Y.size for p in train))))
    b = fit_model("linear", (), recs, lin, chain, 0.05, max_nfev=30)
    assert a.x == pytest.approx(b.x, rel=1e-6, abs=1e-9)
    assert a.train_cost == pytest.approx(b.train_cost, rel=1e-8)
    assert a.std == pytest.approx(b.std, rel=1e-5)


def test_records_not_pooled():
    recs = _records(3, n=2)                       # as many records as inputs: kept
    assert pool_periodic(recs).records == recs
    rest = [Prepared("x", r.U, r.Y, r.temp, False, 0, 1.0, 1.0) for r in _records(4)]
    assert pool_periodic(rest).records == rest    # from rest: kept
    levels = [Prepared(r.name, r.U, r.Y, r.temp, True, N, 1.0, 1.0 + (i % 2))
              for i, r in enumerate(_records(5, n=8))]
    assert len(pool_periodic(levels, by_level=True).records) == 4   # two levels, two each
