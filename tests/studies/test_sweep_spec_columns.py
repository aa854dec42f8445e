"""A spec's sweep column comes from its row of the spec table (robrst.problem.specs).

A sweep whose problem sets ``Msd_rel_max`` (through the sweep file's ``[set]``) has the
``Msd_rel`` column in its results, its statistics in the summary, its bound in the
summary's ``specs`` and its histogram in the report; the column is the certificate's worst
``Msd_rel`` over both loops of each variant, checked here against an independent computation
(dense grids of the unscaled polynomials).  A sweep whose problem does not set it has none of
that (the results of existing sweeps are unchanged).
"""

import numpy as np
import pytest

import loopcheck
from robrst.certificate.proof import certify_problem
from robrst.report.sweep import write_sweep_report
from robrst.studies.sweep import parse_sweep
from robrst.studies.sweep.engine import run_sweep
from robrst.studies.sweep._evaluate import problem_of


def sweep(tmp_path, rel=None):
    doc = {"sweep": {"kind": "analysis", "problem": "paper", "n": 4, "seed": 3},
           "param": [{"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.1}]}
    if rel is not None:
        doc["set"] = {"specs": {"Msd_rel_max": rel}}
    return run_sweep(parse_sweep(doc), tmp_path / ("rel" if rel else "plain"), workers=0)


@pytest.mark.slow
def test_the_column_of_a_bounded_relative_spec(tmp_path):
    res = sweep(tmp_path, rel=0.5)
    table = res.table
    assert "Msd_rel" in table.column_names
    assert res.summary["specs"]["Msd_rel_max"] == 0.5
    assert "Msd_rel" in res.summary["figures"]
    ctx = res.context
    for row in table.to_pylist():
        values = {k: row[k] for k in ctx.names}
        problem = problem_of(ctx, row["index"], values)
        cert = certify_problem(problem, ctx.controller)
        worst = max(cert.worst("Msd_rel"), cert.worst("Msd_rel", "sampled") or 0.0)
        assert row["Msd_rel"] == worst
        m = problem.family.models[0]                     # independent: one family member
        ratio = loopcheck.continuous(m, ctx.controller).Msd / loopcheck._peak(m.B, m.A)
        assert ratio <= row["Msd_rel"] * (1 + 1e-6)
    folder = write_sweep_report(res, tmp_path / "report")
    assert (folder / "histograms.png").is_file()


def test_no_column_without_the_spec(tmp_path):
    res = sweep(tmp_path)
    assert "Msd_rel" not in res.table.column_names
    assert "Msd_rel" not in res.summary["figures"]
    assert list(res.summary["specs"]) == ["Ms_max", "Mt_max", "Mu_max", "T_resonance_max"]


@pytest.mark.parametrize("rel", [0.5])
def test_the_bound_is_certified_per_variant(tmp_path, rel):
    res = sweep(tmp_path, rel=rel)
    rows = res.table.to_pylist()
    assert all(r["certified"] == (r["worst_ratio"] <= 1 + 1e-3) for r in rows)
    assert all(np.isfinite(r["Msd_rel"]) and r["Msd_rel"] < rel for r in rows)
