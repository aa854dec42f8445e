"""``robrst.core.sigma.frequency_response`` and ``sigma_max`` against python-control's
evaluation of the same state space (``StateSpace.__call__``), on seeded random stable
systems."""

import control
import numpy as np
import pytest

from robrst.core.sigma import frequency_response, sigma_max


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_frequency_response_matches_python_control(seed):
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(6, 6))
    A = M - (np.linalg.eigvals(M).real.max() + 0.5) * np.eye(6)      # stable, seeded
    sys = control.ss(A, rng.normal(size=(6, 2)), rng.normal(size=(3, 6)),
                     rng.normal(size=(3, 2)))
    w = np.concatenate([[0.0], np.geomspace(1e-2, 1e3, 40)])
    H = frequency_response(sys.A, sys.B, sys.C, sys.D, np.append(w, np.inf))
    assert H.shape == (w.size + 1, 3, 2)
    for i, wi in enumerate(w):
        ref = np.asarray(sys(1j * wi))
        assert np.allclose(H[i], ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    assert np.array_equal(H[-1], sys.D)          # the limit at infinite frequency
    sv = sigma_max(sys.A, sys.B, sys.C, sys.D, w)
    ref = [np.linalg.svd(np.asarray(sys(1j * wi)), compute_uv=False)[0] for wi in w]
    assert np.allclose(sv, ref, rtol=1e-9)


def test_a_pole_on_the_axis_gives_infinite_values():
    A = np.array([[0.0, 1.0], [-4.0, 0.0]])           # poles at +-2j
    B, C, D = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))
    sv = sigma_max(A, B, C, D, [1.0, 2.0])
    assert np.isfinite(sv[0]) and np.isinf(sv[1])
