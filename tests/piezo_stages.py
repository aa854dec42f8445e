"""Seeded random piezo stages (test helper): 2nd- and 4th-order, 300-3,000 Hz, damping
0.005-0.05, 0-2 samples of delay, a parametric family over 15-45 °C.

:func:`stage_doc` returns a problem document (a dict that is valid TOML input of
:func:`robrst.problem.files.parse_problem`) with the specs of the issue's numbers:
``Msd_max`` at ``msd_factor`` times the open loop's largest ``|B/A|`` peak over the family,
a damping floor at ``damping_share`` of the plant's own least damping, an overshoot bound,
``Ms_max`` and ``Mu_max``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["stage_doc", "open_loop_peak"]


def _mode(fr_hz, zeta, k):
    w = 2 * np.pi * fr_hz
    return np.array([k * w * w]), np.array([1.0, 2 * zeta * w, w * w])


def open_loop_peak(B, A):
    """max |B(jw)/A(jw)| on a dense grid around the modes (the resonance peaks)."""
    w = np.geomspace(1.0, 1e6, 400_001)
    return float(np.max(np.abs(np.polyval(B, 1j * w) / np.polyval(A, 1j * w))))


def stage_doc(seed, order=None, msd_factor=1.1, damping_share=0.9, overshoot_pct=10.0,
              extra_degree=1):
    """The problem document of stage ``seed`` (module docstring).

    Returns
    -------
    dict
    """
    rng = np.random.default_rng(seed)
    order = order or int(rng.choice([2, 4]))
    f1 = float(10 ** rng.uniform(np.log10(300), np.log10(3000)))
    z1 = float(10 ** rng.uniform(np.log10(0.005), np.log10(0.05)))
    k1 = float(rng.uniform(0.1, 1.0))
    B, A = _mode(f1, z1, k1)
    zs = [z1]
    if order == 4:
        f2 = f1 * float(rng.uniform(2.0, 4.0))
        z2 = float(10 ** rng.uniform(np.log10(0.005), np.log10(0.05)))
        B2, A2 = _mode(f2, z2, k1 * float(rng.uniform(0.05, 0.3)))
        B = np.polyadd(np.polymul(B, A2), np.polymul(B2, A))
        A = np.polymul(A, A2)
        zs.append(z2)
    fmax = f1 * (4.0 if order == 4 else 1.0)
    fs = float(min(50_000.0, max(10_000.0, 10 * fmax)))
    delay = int(rng.integers(0, 3))
    res_per_K = float(-rng.uniform(0.0005, 0.002))
    # the family's least damping (the damping law is not used: constant damping)
    peak = max(open_loop_peak(B, _at(A, res_per_K, T)) for T in (15.0, 45.0))
    zeta_min = min(zs)
    wn = 2 * np.pi * f1 / 8
    return {
        "problem": {"name": f"stage{seed}_{order}th"},
        "plant": {"B": B.tolist(), "A": A.tolist(), "temperature_C": 25.0},
        "family": {"temperatures_C": [15.0, 25.0, 35.0, 45.0],
                   "parametric": {"resonance_per_K": res_per_K}},
        "controller": {"extra_degree": extra_degree},
        "poles": {"wn": wn, "zeta": 1.0},
        "specs": {"Ms_max": 2.0, "Mu_max": 150.0, "Msd_max": msd_factor * peak,
                  "damping_min": damping_share * zeta_min, "overshoot_max_pct": overshoot_pct,
                  "sample_rate_hz": fs, "delay_samples": delay},
    }


def _at(A, res_per_K, T, ref=25.0):
    """``A`` with every pole scaled by ``1 + res_per_K (T - ref)`` (the resonance law)."""
    f = 1.0 + res_per_K * (T - ref)
    return np.real(np.poly(np.roots(A) * f))
