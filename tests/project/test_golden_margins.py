"""Regression on margins: no shipped problem may get worse than tests/golden/margins.toml.

Regenerate (after a deliberate improvement) with
``ROBRST_REGEN_GOLDEN=1 python -m pytest tests/project/test_golden_margins.py``.

The objective (integral gain) is checked too, with a tolerance that survives IPOPT
versions: the optimum may move in late digits, never by more than ``rtol_objective``.
"""

import os
import tomllib
from pathlib import Path

import pytest

from robrst.base.resources import problem_names
from robrst.problem.files import load_problem

GOLDEN = Path(__file__).parents[1] / "golden" / "margins.toml"
# worse-is-larger quantities and worse-is-smaller quantities
UPPER = ("Ms", "Mt", "Mu")
LOWER = ("modulus_margin", "phase_margin_deg", "delay_margin_s")


def _current(designs):
    out = {}
    for name in problem_names():
        if load_problem(name).spread is not None:
            continue     # fleet designs (minutes each): tests/synthesis/test_fleet_design.py
        d = designs(name).as_dict()
        key = f"{name}.toml"
        out[key] = {m["label"]: {k: m[k] for k in UPPER + LOWER} for m in d["models"]}
        out[key]["_certified"] = d["certified"]
        out[key]["_integral_gain"] = d["integral_gain"]
    return out


def _write(cur):
    lines = ["# Golden margins of every shipped problem (generated; see tests/project/test_golden_margins.py).",
             "# A margin may improve; getting worse than these by more than the tolerances fails.",
             "[tolerance]", "rtol = 1e-4      # Ms, Mt, Mu, modulus and delay margins (IPOPT results differ in late digits across versions)",
             "atol_deg = 1e-2  # phase margin",
             "rtol_objective = 1e-4  # integral gain of synthesised designs (maximised)", ""]
    for prob, models in cur.items():
        lines.append(f'["{prob}"]')
        lines.append(f"certified = {str(models['_certified']).lower()}")
        lines.append(f"integral_gain = {models['_integral_gain']!r}")
        for lab, vals in models.items():
            if lab.startswith("_"):
                continue
            body = ", ".join(f"{k} = {('inf' if v is None else repr(float(v)))}" for k, v in vals.items())
            lines.append(f'"{lab}" = {{ {body} }}')
        lines.append("")
    GOLDEN.write_text("\n".join(lines))


@pytest.fixture(scope="module")
def current(designs):
    return _current(designs)


def test_margins_not_worse_than_golden(current):
    if os.environ.get("ROBRST_REGEN_GOLDEN"):
        _write(current)
    golden = tomllib.loads(GOLDEN.read_text())
    tol = golden.pop("tolerance")
    assert set(golden) == set(current), "every shipped paper problem has golden margins"
    for prob, models in golden.items():
        cur = current[prob]
        assert cur["_certified"] or not models.pop("certified"), f"{prob} lost its certificate"
        models.pop("certified", None)
        gain = models.pop("integral_gain")
        # every shipped design maximises the integral gain (the analytic one reproduces it)
        assert cur["_integral_gain"] >= gain * (1 - tol["rtol_objective"]), \
            f"{prob}: integral gain worse ({cur['_integral_gain']} < {gain})"
        for lab, g in models.items():
            c = cur[lab]
            for k in UPPER:
                assert c[k] <= g[k] * (1 + tol["rtol"]), f"{prob} {lab}: {k} worse ({c[k]} > {g[k]})"
            for k in ("modulus_margin", "delay_margin_s"):
                v = float("inf") if c[k] is None else c[k]
                assert v >= g[k] * (1 - tol["rtol"]), f"{prob} {lab}: {k} worse ({v} < {g[k]})"
            # signed as python-control signs it: its magnitude is the margin
            assert abs(c["phase_margin_deg"]) >= abs(g["phase_margin_deg"]) - tol["atol_deg"]
