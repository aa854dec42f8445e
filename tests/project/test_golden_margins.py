"""Regression on margins: no shipped problem may get worse than tests/golden/margins.toml.

Regenerate (after a deliberate improvement) with
``ROBRST_REGEN_GOLDEN=1 python -m pytest tests/project/test_golden_margins.py``.

The objective (integral gain) is checked too, with a tolerance that survives IPOPT
versions: the optimum may move in late digits, never by more than ``rtol_objective``.
The golden integral gain is a floor, not a point: a search may find a better optimum (its
path moves with the floating-point kernels the CPU selects), and a design that gains more
than the tolerance may spend margins on it, within the bounds its specs state and its
certificate proves, never beyond them.
"""

import os
import tomllib
from pathlib import Path

import pytest

from robrst.base.resources import problem_names
from robrst.problem.files import load_problem
from robrst.problem.records import Specs

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
        out[key]["_problem"] = load_problem(name)
    return out


def _write(cur):
    lines = ["# Golden margins of every shipped problem (generated; see tests/project/test_golden_margins.py).",
             "# A margin may improve; getting worse than these by more than the tolerances fails.",
             "[tolerance]", "rtol = 1e-4      # Ms, Mt, Mu, modulus and delay margins (IPOPT results differ in late digits across versions)",
             "atol_deg = 1e-2  # phase margin",
             "rtol_objective = 1e-4  # integral gain of synthesised designs (maximised): a floor", ""]
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


def _within_specs(prob, cur):
    """A design that beats the golden objective: its margins are held to its specs only.

    The continuous loop's peaks are what the specs bound (to the certificate's relative
    tolerance) when the problem has no sample rate; a sampled problem's specs bound the
    sampled loop, which its certificate proves.
    """
    specs: Specs = cur["_problem"].specs
    cert_tol = cur["_problem"].solver.cert_tol
    if specs.sample_rate_hz is not None:
        return
    for lab, c in cur.items():
        if lab.startswith("_"):
            continue
        for k, bound in (("Ms", specs.Ms_max), ("Mt", specs.Mt_max), ("Mu", specs.Mu_max)):
            if bound is not None:
                assert c[k] <= bound * (1 + cert_tol), f"{prob} {lab}: {k} {c[k]} above its spec {bound}"


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
        certified = models.pop("certified")
        assert cur["_certified"] or not certified, f"{prob} lost its certificate"
        gain = models.pop("integral_gain")
        # every shipped design maximises the integral gain (the analytic one reproduces it)
        assert cur["_integral_gain"] >= gain * (1 - tol["rtol_objective"]), \
            f"{prob}: integral gain worse ({cur['_integral_gain']} < {gain})"
        if cur["_integral_gain"] > gain * (1 + tol["rtol_objective"]):
            _within_specs(prob, cur)
            continue
        for lab, g in models.items():
            c = cur[lab]
            for k in UPPER:
                assert c[k] <= g[k] * (1 + tol["rtol"]), f"{prob} {lab}: {k} worse ({c[k]} > {g[k]})"
            for k in ("modulus_margin", "delay_margin_s"):
                v = float("inf") if c[k] is None else c[k]
                assert v >= g[k] * (1 - tol["rtol"]), f"{prob} {lab}: {k} worse ({v} < {g[k]})"
            # signed as python-control signs it: its magnitude is the margin
            assert abs(c["phase_margin_deg"]) >= abs(g["phase_margin_deg"]) - tol["atol_deg"]
