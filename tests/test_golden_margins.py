"""Regression on margins: no shipped problem may get worse than tests/golden/margins.toml.

Regenerate (after a deliberate improvement) with
``ROBRST_REGEN_GOLDEN=1 python -m pytest tests/test_golden_margins.py``.
"""

import os
import tomllib
from pathlib import Path

import pytest

from robrst.design import run_problem
from robrst.spec import load_problem

GOLDEN = Path(__file__).parent / "golden" / "margins.toml"
ROOT = Path(__file__).parents[1]
# worse-is-larger quantities and worse-is-smaller quantities
UPPER = ("Ms", "Mt", "Mu")
LOWER = ("modulus_margin", "phase_margin_deg", "delay_margin_s")


def _current():
    out = {}
    for f in sorted((ROOT / "problems").glob("paper*.toml")):
        d = run_problem(load_problem(f)).as_dict()
        out[f.name] = {m["label"]: {k: m[k] for k in UPPER + LOWER} for m in d["models"]}
        out[f.name]["_certified"] = d["certified"]
    return out


def _write(cur):
    lines = ["# Golden margins of every shipped problem (generated; see tests/test_golden_margins.py).",
             "# A margin may improve; getting worse than these by more than the tolerances fails.",
             "[tolerance]", "rtol = 1e-4      # Ms, Mt, Mu, modulus and delay margins (IPOPT results differ in late digits across versions)",
             "atol_deg = 1e-2  # phase margin", ""]
    for prob, models in cur.items():
        lines.append(f'["{prob}"]')
        lines.append(f"certified = {str(models['_certified']).lower()}")
        for lab, vals in models.items():
            if lab == "_certified":
                continue
            body = ", ".join(f"{k} = {('inf' if v is None else repr(float(v)))}" for k, v in vals.items())
            lines.append(f'"{lab}" = {{ {body} }}')
        lines.append("")
    GOLDEN.write_text("\n".join(lines))


@pytest.fixture(scope="module")
def current():
    return _current()


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
        for lab, g in models.items():
            c = cur[lab]
            for k in UPPER:
                assert c[k] <= g[k] * (1 + tol["rtol"]), f"{prob} {lab}: {k} worse ({c[k]} > {g[k]})"
            for k in ("modulus_margin", "delay_margin_s"):
                v = float("inf") if c[k] is None else c[k]
                assert v >= g[k] * (1 - tol["rtol"]), f"{prob} {lab}: {k} worse ({v} < {g[k]})"
            assert c["phase_margin_deg"] >= g["phase_margin_deg"] - tol["atol_deg"]
