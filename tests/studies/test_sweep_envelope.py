"""The monotone envelope of a design sweep over bounds: a variant keeps the better design of a
variant whose bounds are all at least as tight, certified on its own problem; never the
other way, never across other parameters."""

import control
import numpy as np
import pyarrow as pa
import pytest

from robrst.core.rst import RSTController
from robrst.problem.records import with_defaults
from robrst.studies.sweep import run_sweep
from robrst.studies.sweep.envelope import ENVELOPE_COLUMN, bound_directions, dominates, \
    monotone_envelope
from robrst.studies.sweep._evaluate import design_row, problem_of
from robrst.certificate.proof import certify_problem
from robrst.synthesis.analytic import pole_placement


def test_bound_directions_and_dominance():
    d = bound_directions(("specs.Ms_max", "specs.damping_min", "poles.wn", "specs.sample_rate_hz"))
    assert d == (1, -1, 0, 0)
    assert dominates(np.array([1.5, 0.3, 600.0, 1e4]), np.array([2.0, 0.2, 600.0, 1e4]), d)
    assert dominates(np.array([2.0, 0.2, 600.0, 1e4]), np.array([2.0, 0.2, 600.0, 1e4]), d)
    assert not dominates(np.array([1.5, 0.1, 600.0, 1e4]), np.array([2.0, 0.2, 600.0, 1e4]), d)
    assert not dominates(np.array([1.5, 0.3, 500.0, 1e4]), np.array([2.0, 0.2, 600.0, 1e4]), d)


def _slow(problem):
    """A certified but poorer controller of the paper's problem: its analytic design with
    the loop gain lowered 10 %."""
    c = pole_placement(problem.family.reference_model, problem.poles,
                       problem.controller).controller
    return RSTController(0.9 * np.asarray(c.R), c.S, 0.9 * np.asarray(c.T))


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("env")
    f = tmp / "d.toml"
    f.write_text('[sweep]\nkind = "design"\nproblem = "paper"\n[[param]]\nname ='
                 ' "specs.Mu_max"\ndist = "grid"\nvalues = [40.0, 150.0]\n')
    res = run_sweep(f, tmp / "o", workers=0)
    assert res.table.column(ENVELOPE_COLUMN).to_pylist() == [None, None]   # equal designs
    return res


def _with(res, j, ctrl):
    """The sweep's table with variant ``j``'s row holding ``ctrl`` (certified on its problem)."""
    ctx = res.context
    rows = res.table.drop_columns([ENVELOPE_COLUMN]).to_pylist()
    raw = problem_of(ctx, j, {"specs.Mu_max": rows[j]["specs.Mu_max"]})
    row = design_row(raw, ctrl, certify_problem(with_defaults(raw), ctrl))
    rows[j] = {**rows[j], **{k: v for k, v in row.items() if k in rows[j]}}
    return pa.Table.from_pylist(rows, schema=res.table.drop_columns([ENVELOPE_COLUMN]).schema)


def test_a_looser_variant_keeps_the_tighter_better_design(swept):
    ctx = swept.context
    slow = _slow(ctx.base)
    table = _with(swept, 1, slow)               # the looser variant's own design is poorer
    rows = table.to_pylist()
    assert rows[1]["certified"] and rows[1]["integral_gain"] < rows[0]["integral_gain"]
    out = monotone_envelope(ctx, table).to_pylist()
    assert out[1][ENVELOPE_COLUMN] == 0 and out[0][ENVELOPE_COLUMN] is None
    assert out[1]["R"] == rows[0]["R"] and out[1]["S"] == rows[0]["S"]
    assert out[1]["integral_gain"] == pytest.approx(rows[0]["integral_gain"], rel=1e-12)
    assert out[1]["certified"] and "its own design certified objective" in out[1]["message"]
    # independently: python-control's loops of every family model of the looser problem
    p = with_defaults(problem_of(ctx, 1, {"specs.Mu_max": 150.0}))
    r = out[1]
    K = control.tf(r["R"], r["S"])
    w = np.geomspace(1.0, 1e6, 20000)
    for m in p.family.models:
        G = control.tf(m.B, m.A)
        S = control.feedback(1, G * K)
        assert np.all(S.poles().real < 0)
        ms = np.abs(S(1j * w)).max()
        assert ms <= p.specs.Ms_max * (1 + 1e-3)
        U = control.feedback(K, G)
        assert np.abs(U(1j * w)).max() <= 150.0 * (1 + 1e-3)


def test_a_tighter_variant_never_takes_a_looser_design(swept):
    ctx = swept.context
    table = _with(swept, 0, _slow(ctx.base))    # the tighter variant's own design is poorer
    out = monotone_envelope(ctx, table).to_pylist()
    assert [r[ENVELOPE_COLUMN] for r in out] == [None, None]
    assert out[0]["R"] == table.to_pylist()[0]["R"]


def test_an_unfinished_sweep_has_no_envelope(swept):
    table = _with(swept, 1, _slow(swept.context.base))
    out = monotone_envelope(swept.context, table, complete=False).to_pylist()
    assert [r[ENVELOPE_COLUMN] for r in out] == [None, None]
