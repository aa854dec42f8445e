"""The objective line states the global phase's spread in the objective's own terms: a
``min_Ms`` design's certified optima are worst Ms values (1 .. 1.502), never the
larger-is-better objective the starts are ranked by (-1.502 .. -1)."""

from types import SimpleNamespace

from robrst.design.achieved import SpecRow, StartsSummary
from robrst.report.text import objective_line


def _result(objective, best, worst, ms=None, ki=None):
    rows = () if ms is None else (SpecRow("Ms_max", 2.0, ms, 1 - ms / 2.0, "T40C", 40.0,
                                          "sampled", False, "specs"),)
    starts = StartsSummary(starts=9, certified=8, best=best, worst=worst,
                           winner="global run 2", search_method="CMA-ES", evaluations=20939,
                           dimension=6)
    return SimpleNamespace(solver_summary=SimpleNamespace(objective=objective),
                           specs_achieved=rows, starts_summary=starts, integral_gain=ki)


def test_min_Ms_spread_is_printed_as_worst_Ms():
    line = objective_line(_result("min_Ms", best=-1.0, worst=-1.502, ms=1.0))
    assert "objective: min_Ms -> worst Ms 1;" in line
    assert "8 certified, worst Ms 1 .. 1.502," in line
    assert "-1" not in line


def test_integral_gain_spread_is_printed_worst_first():
    line = objective_line(_result("max_integral_gain", best=636429.0, worst=751.8, ki=636429.0))
    assert "integral gain 636,429 V/(µm s)" in line
    assert "optima 751.8 .. 636,429," in line
