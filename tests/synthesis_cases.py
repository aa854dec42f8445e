"""Problems of users' stages for the synthesis tests (not the paper's plant).

``piezo_stage``: 2nd-order piezo stage, 0.1 µm/V, resonance ``f`` Hz with damping 0.02,
family 20-40 °C, Ms <= 2, Mt <= 1.3, Mu <= 100 V/µm (issue 15).  ``two_resonance_stage``:
4th order, two resonances, same specs (a plain integral controller 200/s meets them).
"""

import tomllib

import numpy as np

from robrst.problem.files import parse_problem

SPECS = "[specs]\nMs_max = 2.0\nMt_max = 1.3\nMu_max = 100.0\n"


def _family(res_per_K):
    return ("[family]\ntemperatures_C = [20.0, 25.0, 30.0, 35.0, 40.0]\n[family.parametric]\n"
            f"gain_per_K = 0.0015\nresonance_per_K = {res_per_K}\ndamping_per_K = 0.005\n")


def _problem(B, A, wn, extra, res_per_K, solver, name):
    text = (f"[plant]\nB = {[float(b) for b in B]}\nA = {[float(a) for a in A]}\n"
            f"temperature_C = 20.0\n{_family(res_per_K)}[controller]\nextra_degree = {extra}\n"
            f"[poles]\nwn = {wn}\nzeta = 1.0\n{SPECS}[solver]\nmethod = \"nlp\"\n"
            f"objective = \"max_integral_gain\"\n{solver}")
    return parse_problem(tomllib.loads(text), name)


def piezo_stage(f_hz=900.0, extra=0, res_per_K=-0.0001, solver=""):
    """The issue's 2nd-order stage with its resonance at ``f_hz``."""
    w = 2 * np.pi * f_hz
    return _problem([0.1 * w * w], [1.0, 2 * 0.02 * w, w * w], w / 5, extra, res_per_K, solver,
                    f"stage_{f_hz:g}Hz_e{extra}.toml")


def two_resonance_stage(f1=400.0, f2=1400.0, extra=0, res_per_K=-0.0001, solver=""):
    """A 4th-order stage with resonances at ``f1`` and ``f2`` Hz (damping 0.02), 0.1 µm/V."""
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    A = np.polymul([1, 2 * 0.02 * w1, w1 * w1], [1, 2 * 0.02 * w2, w2 * w2])
    return _problem([0.1 * A[-1]], A, w1 / 5, extra, res_per_K, solver,
                    f"two_resonance_e{extra}.toml")
