"""The joint multi-axis program's rows (:class:`robrst.synthesis.mimo_program.GridRows`).

Their Jacobian, the sector's scalings included, against central finite differences; the
sector's rows against the small-gain matrix assembled from the closed loop's blocks at each
frequency (``K = W diag(R / S)``, ``S = (I + G K)^-1``: numpy on the plant's response and
the controller's polynomials, not the rows' ``L P^-1 Q + E`` form).
"""

import numpy as np
import pytest

from mimo_stages import stage_tf
from robrst.core.mimo import MimoPlant
from robrst.synthesis.mimo_program import AxisParam, GridRows, Sector

DELTA = 0.25
GAMMA = {"sector_S": 3.0, "sector_T": 2.5, "sector_U": 40.0}


def _rows(m=2, seed=4):
    P = MimoPlant.from_control(stage_tf(seed, m), "stage", 20.0)
    w0 = 2 * np.pi * 60.0
    axes = [AxisParam.of(w0, 1) for _ in range(m)]
    nu = np.geomspace(1.0, 2e5, 60)
    G = P.freqresp(nu)
    rng = np.random.default_rng(seed)
    Wd = np.eye(m) + 0.1 * rng.standard_normal((m, m))
    W = np.broadcast_to(Wd, (len(nu), m, m)).astype(complex)
    sec = Sector(DELTA, dict(GAMMA), np.repeat([0, 1], len(nu) // 2))
    rows = GridRows(axes, nu, G, W, {"sigma_S": 2.0, "sigma_Ti": 4.0}, 0.2, nu < 300.0, sec)
    x = np.concatenate([a.start(0.4) for a in axes])
    x = x * (1.0 + 0.05 * rng.standard_normal(x.size))
    rows.set_scaling(x)
    return rows, x, G, Wd, nu


def test_rows_jacobian_matches_finite_differences():
    rows, x, *_ = _rows()
    rows.set_reference(x)
    rows.select(None)
    assert rows.nd == 3 * 2 * 2          # three figures, two loops, two inputs
    z = np.concatenate([x, rows.log_scales + 0.1])
    g, J = rows.evaluate(z)
    assert J.shape == (len(rows.rows), rows.nx + rows.nd)
    Jfd = np.zeros_like(J)
    for i in range(z.size):
        h = 1e-6 * max(abs(z[i]), 1e-3)
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        Jfd[:, i] = (rows.evaluate(zp)[0] - rows.evaluate(zm)[0]) / (2 * h)
    scale = np.abs(Jfd).max(axis=1, keepdims=True) + 1e-12
    err = np.abs(J - Jfd) / scale
    sector = np.array([r[0].startswith("sector") for r in rows.rows])
    assert sector.sum() == 3 * 60
    # central differences are good to ~1e-6 of a row's scale, 1e-3 where a column's
    # coefficient is tiny (the existing rows as much as the sector's)
    assert np.max(err) < 2e-3, np.max(err)
    assert np.median(err[sector]) < 1e-5 and np.max(err[sector]) < 1e-3
    # the log D columns move only the sector's rows of their own loop
    assert np.all(J[~sector, rows.nx:] == 0)


def test_sector_rows_are_the_scaled_small_gain_matrix():
    rows, x, G, Wd, nu = _rows()
    m = 2
    ratios = rows.ratios(x)
    K = np.zeros((len(nu), m, m), complex)
    for i, a in enumerate(rows.axes):
        R, S = a.polynomials(x[rows.offsets[i]:rows.offsets[i + 1]])
        K[:, :, i] = Wd[None, :, i] * (np.polyval(R, 1j * nu) / np.polyval(S, 1j * nu))[:, None]
    I = np.eye(m)
    So = np.linalg.inv(I + G @ K)
    Ti, U, Sd, T = K @ So @ G, K @ So, So @ G, G @ K @ So
    bottom = {"sector_S": (Sd, So), "sector_T": (-Sd, T), "sector_U": (Ti, U)}
    for f, (Ew, Ev) in bottom.items():
        D = rows.scales[f][np.repeat([0, 1], len(nu) // 2)]           # (K, m)
        N = np.block([[DELTA * D[:, :, None] * Ti / D[:, None, :], DELTA * D[:, :, None] * U],
                      [Ew / D[:, None, :] / GAMMA[f], Ev / GAMMA[f]]])
        ref = np.linalg.svd(N, compute_uv=False)[:, 0]
        assert ratios[f] == pytest.approx(ref, rel=1e-9), f


def test_scaling_lowers_the_largest_value():
    """The scaling found at a point is no worse than none (D = I) and than the blocks'
    balance, loop by loop."""
    rows, x, *_ = _rows()
    found = rows.ratios(x)
    seg = rows.sector.segments
    rows.set_scaling(scales={f: np.ones_like(v) for f, v in rows.scales.items()})
    plain = rows.ratios(x)
    for f in GAMMA:
        for s in (0, 1):
            assert found[f][seg == s].max() <= plain[f][seg == s].max() * (1 + 1e-9)
