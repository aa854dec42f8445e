"""The compressed least-squares problem (``robrst.diagnose.fit.compressed``) takes the same
steps as the full one: on a random exponential-fit problem with bounds, scipy's trust-region
solver on the ``n + 1`` compressed rows ends where it ends on the full rows (same point, cost
and evaluations), and the compressed Jacobian keeps ``J^T J``, ``J^T r`` and the column
norms (checked against the full Jacobian with numpy)."""

import numpy as np
import pytest
from scipy import optimize

from robrst.diagnose.fit import compressed


def _problem(seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4, 3000)
    truth = np.array([1.5, -0.7, 0.3, 2.0])
    y = truth[0] * np.exp(truth[1] * t) + truth[2] * np.sin(truth[3] * t)
    y = y + 0.01 * rng.standard_normal(t.size)

    def residual(x):
        return x[0] * np.exp(x[1] * t) + x[2] * np.sin(x[3] * t) - y

    def full_jac(x):
        return np.column_stack([np.exp(x[1] * t), x[0] * t * np.exp(x[1] * t),
                                np.sin(x[3] * t), x[2] * t * np.cos(x[3] * t)])

    def blocks(x):
        J = full_jac(x)
        for a in range(0, t.size, 700):          # uneven blocks, as records are
            yield J[a:a + 700], J[a:a + 700].shape[0], None

    return residual, full_jac, blocks


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compressed_rows_take_the_full_problems_steps(seed):
    residual, full_jac, blocks = _problem(seed)
    x0 = np.array([1.0, -0.3, 0.1, 1.7])
    bounds = (np.array([0.0, -2.0, -1.0, 1.0]), np.array([3.0, 0.0, 1.0, 3.0]))
    kw = dict(bounds=bounds, method="trf", x_scale="jac", ftol=1e-8, xtol=1e-10, gtol=1e-10,
              max_nfev=50)
    a = optimize.least_squares(residual, x0, jac=full_jac, **kw)
    fun, jac, rows = compressed(residual, blocks, 4)
    b = optimize.least_squares(fun, x0, jac=jac, **kw)
    assert b.x == pytest.approx(a.x, rel=1e-6, abs=1e-8)
    assert b.cost == pytest.approx(a.cost, rel=1e-8)
    assert abs(b.nfev - a.nfev) <= 1 and rows() == 3000     # the last step: rounding
    # the compressed Jacobian's invariants, against numpy on the full one
    x = a.x
    J, r = full_jac(x), residual(x)
    v, M = fun(x), jac(x)
    assert M.T @ M == pytest.approx(J.T @ J, rel=1e-10)
    assert M.T @ v == pytest.approx(J.T @ r, rel=1e-8, abs=1e-10)
    assert np.linalg.norm(M, axis=0) == pytest.approx(np.linalg.norm(J, axis=0), rel=1e-12)
    assert np.linalg.norm(v) == pytest.approx(np.linalg.norm(r), rel=1e-14)


def test_spectral_rows_keep_the_time_rows_inner_products():
    """A periodic record's Jacobian as Parseval rows of its spectrum: the same Gram matrix
    and the same product with the residual as the time rows (numpy on both)."""
    from robrst.core.plant import paper_plant
    from robrst.diagnose._effects import Chain
    from robrst.diagnose.fit import Fitted, Prepared, model_jacobian, parseval_rows, \
        spectral_jacobian
    from robrst.diagnose.linear import LinearPart

    fs, n = 5000.0, 2048
    rng = np.random.default_rng(3)
    u = 60 + 20 * np.sin(2 * np.pi * np.arange(n)[:, None] * np.array([3, 17, 40]) / n).sum(1)
    lin = LinearPart(paper_plant(), fs)
    p = Prepared("x", u[:, None], rng.standard_normal((n, 1)), np.full(n, 28.0), True, 0, 1.0,
                 1.0)
    ch = Chain((), 1, fs, 28.0, {"u_ptp": 40.0, "knots": ()})
    x = 0.03 * rng.standard_normal(lin.size)
    fit = Fitted("lin", (), "input", ch, lin, x, np.zeros_like(x), True, (), 1.0, 0, 0.0)
    J = model_jacobian(fit, p, x)[1].reshape(n, -1)
    S = spectral_jacobian(fit, p, x)
    assert S.T @ S == pytest.approx(J.T @ J, rel=1e-9, abs=1e-9 * np.abs(J.T @ J).max())
    r = rng.standard_normal(n)
    rs = parseval_rows(np.fft.rfft(r[:, None], axis=0), n)
    assert S.T @ rs == pytest.approx(J.T @ r, rel=1e-9, abs=1e-9 * np.abs(J.T @ r).max())


def test_the_residues_rows_reduced_to_their_triangular_factor_solve_alike():
    """``reduced_rows`` (the residues' level slopes solve each record's rows as the
    triangular factor of ``[C, y]``): for every coefficient matrix the sum of squares moves
    by one constant, and the stacked least squares of records in Kronecker form (``C (b^T
    kron I)``, a ridge below) has the solution numpy's ``lstsq`` gives on the full rows."""
    from robrst.diagnose._polish import reduced_rows

    rng = np.random.default_rng(7)
    C, y = rng.standard_normal((900, 12)), rng.standard_normal((900, 3))
    R, z = reduced_rows(C, y)
    assert R.shape == (12, 12) and z.shape == (12, 3) and np.allclose(np.tril(R, -1), 0.0)
    gaps = [np.sum((C @ X - y) ** 2) - np.sum((R @ X - z) ** 2)
            for X in rng.standard_normal((5, 12, 3))]
    assert np.ptp(gaps) <= 1e-9 * np.sum(y ** 2)
    small = rng.standard_normal((10, 12))          # no more rows than columns: as it is
    assert reduced_rows(small, y[:10])[0] is small
    full, red = [], []
    for b in ([1.0, 0.0], [1.0, 0.5], [1.0, 1.0]):
        Ci, yi = rng.standard_normal((700, 12)), rng.standard_normal((700, 3))
        full.append((np.hstack([Ci * v for v in b]), yi))
        Ri, zi = reduced_rows(Ci, yi)
        red.append((np.hstack([Ri * v for v in b]), zi))
    ridge = (np.diag(np.full(24, 0.1)), np.zeros((24, 3)))
    A, B = (np.vstack([m[k] for m in full] + [ridge[k]]) for k in (0, 1))
    Ar, Br = (np.vstack([m[k] for m in red] + [ridge[k]]) for k in (0, 1))
    assert Ar.shape[0] == 3 * 12 + 24 < A.shape[0]
    X = np.linalg.lstsq(A, B, rcond=None)[0]
    assert np.allclose(np.linalg.lstsq(Ar, Br, rcond=None)[0], X, rtol=1e-10, atol=1e-12)


def test_a_level_slopes_columns_are_its_modes_columns_scaled():
    """On top of a level-dependent fit the screen keeps only the base's other columns: a
    slope's column is its mode's column times the record's level basis value, so the base's
    Gram products are those of the kept columns mapped by ``M``. Checked against the
    columns :func:`model_jacobian` writes itself, on records at three levels."""
    from robrst.core.plant import Plant
    from robrst.data.dataset import Dataset
    from robrst.diagnose._effects import Chain, summary
    from robrst.diagnose.fit import fit_by_level, level_map_of, model_jacobian, prepare
    from robrst.diagnose.linear import LinearPart
    from robrst.identify.modal import ModalModel

    fs = 5000.0
    model = ModalModel.from_plant(Plant([4.0e6], [1.0, 120.0, 4.0e6], label="m"))
    rng = np.random.default_rng(7)
    recs = []
    for i, amp in enumerate((1.0, 2.0, 4.0)):
        n = 4000
        u = amp * np.repeat(rng.uniform(-1, 1, n // 40), 40)
        y = np.convolve(u, np.exp(-np.arange(200) / 30.0) / 30.0)[:n] * (1 + 0.05 * amp)
        recs.append(Dataset(t=np.arange(n) / fs, u=u, y=y + 1e-4 * rng.standard_normal(n),
                            source=f"r{i}"))
    train = [prepare(d, 28.0) for d in recs]
    lin = LinearPart(model, fs, modal_gains=True)
    chain = Chain((), 1, fs, 28.0, summary(recs))
    fit = fit_by_level("amplitude_dependent_dynamics", train, lin, chain, 1e-4, max_nfev=3)
    assert fit.slopes
    for p in [prepare(d, 28.0, for_fit=False) for d in recs]:
        _, J = model_jacobian(fit, p)
        _, J0 = model_jacobian(fit, p, level_columns=False)
        keep, slopes, M = level_map_of(fit, p)
        assert set(keep) | set(slopes) == set(range(fit.x.size))
        X = J.reshape(-1, J.shape[2]).T                   # (columns, rows)
        Xk = J0.reshape(-1, J0.shape[2]).T[keep]
        assert np.allclose(M @ Xk, X, rtol=1e-12, atol=1e-12 * np.abs(X).max())
        G, Gm = X @ X.T, M @ (Xk @ Xk.T) @ M.T
        assert np.allclose(Gm, G, rtol=1e-10, atol=1e-12 * np.abs(G).max())


@pytest.mark.parametrize("modal_gains", [False, True])
def test_the_pole_moves_columns_equal_the_moved_models(modal_gains):
    """The periodic Jacobian's move columns (a mode's frequency or damping moved by the
    step, every other residue re-mapped over the one moved pole; a mode's gain: its term
    scaled; the modes' terms applied to the input's spectrum first, each move's change
    formed directly) equal the finite difference of the whole model's outputs
    (:meth:`LinearPart.simulate`: every pole and residue mapped afresh). Two inputs, two
    outputs, two resonances and a real pole, away from zero corrections."""
    from robrst.diagnose.linear import LinearPart
    from robrst.diagnose.options import OPTIONS
    from robrst.identify.modal import ModalModel

    poles = np.array([-15.0 + 1j * 2 * np.pi * 400.0, -40.0 + 1j * 2 * np.pi * 900.0, -300.0])
    R = np.array([[[300.0, 120.0], [80.0, 250.0]], [[-150.0, 400.0], [200.0, -90.0]],
                  [[50.0, 20.0], [10.0, 60.0]]], complex)
    lin = LinearPart(ModalModel(poles, R, np.diag([0.01, 0.02])), 5000.0,
                     modal_gains=modal_gains)
    rng = np.random.default_rng(3)
    theta = rng.uniform(-0.05, 0.05, lin.size)
    V = rng.standard_normal((512, 2))
    h = OPTIONS.linear.fd_step
    Y0, J = lin.simulate_jac(theta, V, periodic=True)
    moves = list(lin.moves)
    assert {lin.kinds[i][0] for i in moves} == (
        {"dlog_freq", "dlog_damping", "mode_gain"} if modal_gains
        else {"dlog_freq", "dlog_damping"})
    for i in moves:
        th = theta.copy()
        th[i] += h
        fd = (lin.simulate(th, V, True) - Y0) / h
        assert np.allclose(J[:, :, i], fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max()), \
            lin.names[i]
