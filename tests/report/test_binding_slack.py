"""A constraint the optimiser's multipliers call binding, and the room the certificate leaves.

The binding constraints are the program's: its grid constraints sit a margin inside the
specs, and a backed-off polish tightens them further (by 4.8 % on a two-resonance stage
whose answer had Mt 1.242 against 1.3, while "|T| peak" was listed as binding).  Each
constraint now carries the certificate's slack of the spec it bounds, and the summary says
when that slack is above the 1 % that the spec table calls binding.  The slack of the
shipped design's |T| constraint is checked against python-control's sampled loops.
"""

import copy
import json
from dataclasses import replace

import numpy as np

import pytest

import robrst.synthesis.robust as robust
from pcloop import feedback_law, loop_figures, zoh_plant
from robrst.controller.export import export_controller
from robrst.design import run_problem
from robrst.problem.files import load_problem
from robrst.report.text import design_summary


@pytest.fixture(scope="module")
def robust_result():
    """``paper_robust``'s design as its polish left it (636,429, without the strip's-edge
    runs): the answer polished again is a point its walk back found, with no solve whose
    multipliers name binding constraints (the summary then has no such line)."""
    mp = pytest.MonkeyPatch()
    mp.setattr(robust, "POLISH", replace(robust.POLISH, again=0))
    p = load_problem("paper_robust")
    try:
        res = run_problem(replace(p, solver=replace(p.solver, edge_runs=False)))
    finally:
        mp.undo()
    assert res.synthesis.solve is not None
    return res


def test_the_binding_peak_carries_the_slack_python_control_finds(robust_result):
    so = robust_result.solver_summary
    assert len(so.binding_slack) == len(so.binding)
    kinds = [b.kind for b in robust_result.synthesis.solve.binding()]
    assert "T" in kinds, kinds
    slack = so.binding_slack[kinds.index("T")]
    problem, exported = robust_result.problem, export_controller(robust_result, None)
    fs = problem.specs.sample_rate_hz
    worst = 0.0
    for T in np.linspace(*problem.family.range_C, 18):
        m = problem.family.at(T)
        K = feedback_law(exported, zoh_plant(m, fs).dt, "sections")
        worst = max(worst, loop_figures(m, K, fs, problem.specs.delay_samples)["Mt"])
    assert abs(slack - (1 - worst / problem.specs.Mt_max)) < 2e-4, (slack, worst)
    stability = kinds.index("controller_routh")
    assert so.binding_slack[stability] is None       # bounds no single spec


def test_the_summary_says_when_the_certificate_leaves_room(robust_result):
    line = next(x for x in design_summary(robust_result).splitlines()
                if x.startswith("binding constraints"))
    assert "held in the program" not in line         # every slack within 1 %
    roomy = copy.copy(robust_result)
    so = robust_result.solver_summary
    roomy.__dict__["solver_summary"] = replace(
        so, binding_slack=(0.045,) + tuple(so.binding_slack[1:]))
    line = next(x for x in design_summary(roomy).splitlines()
                if x.startswith("binding constraints"))
    first, *rest = line.split("; ")
    assert first.endswith(f"{so.binding[0]} (held in the program: the certificate leaves"
                          " 4.5 % slack)"), first
    assert not any("held in the program" in r for r in rest), rest


def test_the_json_has_the_slack_beside_each_binding_constraint(robust_result):
    solver = json.loads(json.dumps(robust_result.as_dict()))["solver"]
    assert len(solver["binding_slack"]) == len(solver["binding"])
    assert solver["binding_slack"] == [None if v is None else float(v)
                                       for v in robust_result.solver_summary.binding_slack]
