"""The multi-axis text summary is drawn from the design's records: every member's row holds
the certificate's figures (read from its loop records here, formatted alike), the sector's
worst figures, the binding figure and each comparison's verdict, and nothing is
recomputed."""

import control
import numpy as np
import pytest

from robrst.core.mimo import MimoFamily, MimoPlant
from robrst.design.mimo import LOCAL_RUN_NOTE, design_mimo
from robrst.problem.mimo import MimoProblem, MimoSpecs
from robrst.report.mimo import mimo_summary
from robrst.report.text import fmt


@pytest.fixture(scope="module")
def one_axis():
    g = control.tf([2e7], [1, 300, 2e7])
    fam = MimoFamily((MimoPlant.from_control(g, "cold", 20.0),))
    problem = MimoProblem("one axis", fam, specs=MimoSpecs(
        sigma_S_max=2.0, input_gain_deviation=0.3, sector_S_max=2.0, sample_rate_hz=20000.0))
    return design_mimo(problem, compare=True)


def test_the_summary_draws_the_records(one_axis):
    r = one_axis
    text = mimo_summary(r)
    lines = text.splitlines()
    assert lines[0].startswith("one axis: 1 axes, 1 model(s), sampled at 20000 Hz")
    assert lines[0].endswith("certified: " + ("yes" if r.certified else "NO"))
    for rec in (m for m in r.certificate.models if m.member):
        for loop in ("continuous", "sampled"):
            lf = rec.loop(loop)
            row = next(x for x in lines if x.startswith(f"| {rec.label} | {loop} |"))
            cells = [c.strip() for c in row.strip("|").split("|")]
            assert cells[2] == ("yes" if lf.stable else "**no**")
            assert cells[3] == fmt(lf.peaks["sigma_S"].value, ".4g")
            assert float(cells[3]) == pytest.approx(lf.peaks["sigma_S"].value, rel=1e-3)
            assert cells[8] == ", ".join(f"{b:.4g}" for b in lf.bandwidth_hz)
    cert = r.certificate
    sector = next(x for x in lines if x.startswith("input gains within ±0.3 of nominal"))
    worst = [max(m.loop(lp).peaks["sector_S"].value for m in cert.models
                 if m.loop(lp) is not None) for lp in ("continuous", "sampled")]
    assert f"sector_S {fmt(worst[0], '.4g')} continuous, {fmt(worst[1], '.4g')} sampled" \
        " (bound 2)" in sector
    b = r.binding
    where = f"{b.figure} at {fmt(b.ratio, '.4g')} of its bound ({b.model}, {b.loop} loop)"
    if b.ratio >= 0.99:
        assert f"binding: {where}" in text
    else:
        assert f"nearest its bound: {where}; no bound binds" in text
    for name, c in r.comparisons.items():
        line = next(x for x in lines if x.startswith(f"{name} ("))
        assert ("NOT certified" not in line) == c.certificate.certified
    # the notes, drawn as the design states them, just above the time
    assert r.notes == (LOCAL_RUN_NOTE,)        # the default: the joint program alone
    assert lines[-1 - len(r.notes):-1] == [f"note: {n}" for n in r.notes]
    assert r.as_dict()["notes"] == [LOCAL_RUN_NOTE]
    assert lines[-1] == f"{r.seconds:.1f} s"
    # the integral gains as the controller has them (lim s R/S)
    ki = [float(a.R[-1] / a.S[-2]) for a in r.controller.axes]
    assert np.allclose(r.integral_gains(), ki, rtol=1e-9)


def test_a_figure_with_room_left_is_not_called_binding(one_axis):
    """A design whose nearest figure sits 8.5 % below its bound (a per-axis start that the
    joint program did not improve on) is limited by no bound: the summary says so instead
    of calling that figure binding; within 1 % (the single loop's ``BINDS``) it binds."""
    from dataclasses import replace as swap
    from robrst.design.mimo import Binding
    loose = mimo_summary(swap(one_axis, binding=Binding("sigma_S", 0.9146, "h", "continuous")))
    assert ("nearest its bound: sigma_S at 0.9146 of its bound (h, continuous loop); no bound"
            " binds (8.54 % slack)") in loose
    assert "binding: sigma_S" not in loose
    tight = mimo_summary(swap(one_axis, binding=Binding("sigma_S", 0.995, "h", "sampled")))
    assert "binding: sigma_S at 0.995 of its bound (h, sampled loop)" in tight
    over = mimo_summary(swap(one_axis, binding=Binding("sigma_S", 1.2, "h", "sampled")))
    assert "binding: sigma_S at 1.2 of its bound (h, sampled loop)" in over


@pytest.mark.parametrize("violation, objective, said", [
    (0.3, 1.0, "none of its 77 candidates met the specs on its screen"),
    (0.0, -1.0, "its best of 77 candidates screened below the per-axis start"),
])
def test_a_global_phase_that_is_not_used_says_why(monkeypatch, violation, objective, said):
    """With ``multistart`` the design says why the search's best did not start the
    program (its screen refused every candidate, or its best screened below the start),
    and never calls the answer a design without the global phase."""
    import robrst.design.mimo as mimo_design
    from robrst.problem.mimo import MimoSolverOptions
    from robrst.synthesis.mimo_search import MimoSearch

    def search(*args, **kwargs):
        return MimoSearch(x=np.zeros(1), objective=objective, violation=violation,
                          start_objective=0.0, evaluations=77, runs=(), space=None)

    monkeypatch.setattr(mimo_design, "search_mimo", search)
    g = control.tf([2e7], [1, 300, 2e7])
    fam = MimoFamily((MimoPlant.from_control(g, "cold", 20.0),))
    r = design_mimo(MimoProblem("one axis", fam, specs=MimoSpecs(
        sigma_S_max=2.0, sample_rate_hz=20000.0), solver=MimoSolverOptions(multistart=True)),
        compare=False)
    assert len(r.notes) == 1 and said in r.notes[0] and LOCAL_RUN_NOTE not in r.notes
    assert "global_search" not in r.comparisons
    assert f"note: {r.notes[0]}" in mimo_summary(r)
