"""Seeded random coupled multi-axis stages for the multi-axis tests (python-control objects).

A stage of ``m`` axes: ``G(s) = (I + C) diag(g_j(s))``, ``g_j = k_j w_j^2 / (s^2 + 2 z_j w_j s
+ w_j^2)`` (one resonance per stack, 300-3,000 Hz, damping 0.01-0.05, 0.05-0.2 µm/V) and the
coupling ``C`` off the diagonal, ``|C_ij|`` in 1-30 % with a random sign: the transfer
matrix python-control builds, independent of robrst's realisations.
"""

import control
import numpy as np


def random_stage(seed, m, spread=0.0):
    """``(tf, models)``: the stage's python-control transfer matrix and, with ``spread``,
    a second model whose resonances sit ``spread`` higher (a family of two)."""
    return (stage_tf(seed, m), stage_tf(seed, m, 1.0 + spread)) if spread else (
        stage_tf(seed, m),)


def stage_tf(seed, m, scale=1.0, gains=None):
    """The transfer matrix of stage ``seed`` with every resonance times ``scale`` and
    actuator ``j``'s gain times ``gains[j]`` (built entry by entry)."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(300.0, 3000.0, m)
    z = rng.uniform(0.01, 0.05, m)
    k = rng.uniform(0.05, 0.2, m)
    C = rng.uniform(0.01, 0.30, (m, m)) * rng.choice([-1.0, 1.0], (m, m))
    np.fill_diagonal(C, 0.0)
    M = np.eye(m) + C

    g = np.ones(m) if gains is None else np.asarray(gains, float)
    w = 2 * np.pi * f * scale
    num = [[[M[i, j] * k[j] * g[j] * w[j] ** 2] for j in range(m)] for i in range(m)]
    den = [[[1.0, 2 * z[j] * w[j], w[j] ** 2] for j in range(m)] for i in range(m)]
    return control.tf(num, den)


def sigma_grid(sys, w):
    """``sigma_max`` of a python-control system's response on ``w`` [rad/s] (continuous) or
    angles ``w * dt`` (discrete)."""
    resp = control.frequency_response(sys, w)
    H = np.moveaxis(np.atleast_3d(resp.complex if hasattr(resp, "complex") else resp.fresp),
                    -1, 0)
    H = H.reshape(len(w), sys.noutputs, sys.ninputs)
    return np.linalg.svd(H, compute_uv=False)[:, 0]


def refined_max(sys, w0, w1, n=6000, keep=8, rounds=5):
    """The maximum of ``sigma_max`` over ``[w0, w1]``: a log grid of ``n`` points, then
    zooms around its ``keep`` largest local maxima (the independent reference of an exact
    peak: a grid, whatever computed the peak)."""
    w = np.geomspace(w0, w1, n)
    s = sigma_grid(sys, w)
    inner = np.flatnonzero((s[1:-1] >= s[:-2]) & (s[1:-1] >= s[2:])) + 1
    cand = sorted(set(inner[np.argsort(-s[inner])][:keep].tolist()) | {0, n - 1})
    best = max((s[i], w[i]) for i in cand)
    for i in cand:
        lo, hi = w[max(i - 1, 0)], w[min(i + 1, n - 1)]
        for _ in range(rounds):
            ww = np.linspace(lo, hi, 201)
            ss = sigma_grid(sys, ww)
            j = int(np.argmax(ss))
            best = max(best, (ss[j], ww[j]))
            lo, hi = ww[max(j - 1, 0)], ww[min(j + 1, 200)]
    return best
