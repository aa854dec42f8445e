"""Seeded piezo stages for the global-phase tests (test helper): problem documents of
robrst problem files, 2nd- and 4th-order, 300-3,000 Hz, damping 0.005-0.05, sampled loops
with 0-2 samples of delay, bounds on |S|, |T|, |U| and the default specs."""

import numpy as np

from robrst.problem.files import parse_problem


def _pair(f_hz, zeta):
    w = 2 * np.pi * f_hz
    return np.array([1.0, 2 * zeta * w, w * w]), w


def stage_doc(seed, order=2, ms=2.0, delay=None, edge_runs=None):
    """A seeded stage's problem document (``[specs] Ms_max = ms``; ``edge_runs``: the
    ``[solver]`` key when given, else its default)."""
    rng = np.random.default_rng(seed)
    f1 = float(np.exp(rng.uniform(np.log(300.0), np.log(3000.0))))
    z1 = float(np.exp(rng.uniform(np.log(0.005), np.log(0.05))))
    gain = float(rng.uniform(0.05, 0.2))            # µm/V
    A, w = _pair(f1, z1)
    poles = [w]
    if order == 4:
        f2 = f1 * float(rng.uniform(2.5, 4.0))
        A2, w2 = _pair(f2, float(np.exp(rng.uniform(np.log(0.005), np.log(0.05)))))
        A = np.polymul(A, A2)
        poles.append(w2)
    B = [gain * A[-1]]
    fs = float(rng.choice([10000.0, 20000.0, 25000.0]))
    fs = max(fs, 8 * max(poles) / (2 * np.pi))
    k = int(rng.integers(0, 3)) if delay is None else delay
    return {"problem": {"name": f"stage{seed}"},
            "plant": {"B": B, "A": [float(a) for a in A], "temperature_C": 25.0},
            "family": {"temperatures_C": [15.0, 25.0, 35.0, 45.0],
                       "parametric": {"resonance_per_K": -float(rng.uniform(1e-4, 5e-4)),
                                      "gain_per_K": float(rng.uniform(0.0, 1e-3))}},
            "controller": {"extra_degree": 1},
            "poles": {"wn": float(w / 5), "zeta": 1.0},
            "specs": {"Ms_max": ms, "Mt_max": 1.3, "Mu_max": float(rng.uniform(80, 250)),
                      "sample_rate_hz": fs, "delay_samples": k},
            "solver": {"method": "nlp", "objective": "max_integral_gain",
                       **({} if edge_runs is None else {"edge_runs": edge_runs})}}


def stage(seed, **kw):
    return parse_problem(stage_doc(seed, **kw), f"<stage {seed}>")
