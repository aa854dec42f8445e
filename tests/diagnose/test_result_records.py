"""The diagnosis is a record to its edge: every JSON section a typed field, the JSON written
from them in one place (:meth:`Diagnosis.as_dict`).

Checked on a seeded withheld case: no field of the result records is annotated ``dict``,
``object`` or ``Any``; the JSON is plain (it dumps with ``allow_nan=False``); and its
sections hold what the records hold, read field by field here (not through ``as_dict``).
"""

import dataclasses
import json
import math

import numpy as np
import pytest

import robrst.diagnose.result as result
from robrst.diagnose import diagnose
from robrst.diagnose.validation import make_case


@pytest.fixture(scope="module")
def diag():
    train, test, _ = make_case("hysteresis", 1)
    return diagnose(train, test)


def test_no_section_is_an_untyped_dict():
    for name in result.__all__:
        cls = getattr(result, name)
        if not dataclasses.is_dataclass(cls):
            continue
        for f in dataclasses.fields(cls):
            head = str(f.type).split("[")[0].split("|")[0].strip()
            assert head not in ("dict", "object", "Any", "list"), f"{name}.{f.name}: {f.type}"


def _same(a, b):
    return (a is None and b is None) or (b is None and not math.isfinite(a)) or a == b


def test_the_json_holds_what_the_records_hold(diag):
    d = diag.as_dict()
    json.dumps(d, allow_nan=False)
    assert d["cause"] == diag.cause == "hysteresis"
    assert [r["file"] for r in d["gap"]["per_record"]] == [r.file for r in diag.per_record]
    assert [r["gap"] for r in d["gap"]["per_record"]] == [r.gap for r in diag.per_record]
    w = diag.where
    assert d["where"]["frequency_band_hz"] == list(w.frequency_band_hz)
    assert d["where"]["time_windows_energy_fraction"] == w.energy_fraction
    assert [x["start_s"] for x in d["where"]["time_windows"]] == [x.start_s for x in w.time_windows]
    assert d["where"]["regime"]["dominant"] == w.regime.dominant
    for k, v in w.regime.shares.items():
        assert _same(v, d["where"]["regime"][k])
    t = diag.tests
    assert d["tests"]["whiteness"] == {"max_abs_autocorr": t.whiteness.value,
                                       "bound": t.whiteness.bound, "passed": t.whiteness.passed}
    assert d["tests"]["cross_correlation"]["max_abs_crosscorr"] == t.cross_correlation.value
    (sel,) = diag.selected
    js = d["selected"][0]
    assert (js["name"], js["form"], js["gap_after"]) == (sel.name, sel.form, sel.gap_after)
    for k, v in sel.params.items():
        assert _same(v, js["params"][k])
    sector = sel.input_gain_sector
    assert js["input_gain_sector"]["slopes"] == list(sector.slopes)
    assert d["final"]["effects"] == list(diag.final.effects)
    assert d["final"]["gap_per_record"] == [{"file": g.file, "gap": g.gap}
                                            for g in diag.final.gap_per_record]
    assert d["data"]["train"] == list(diag.data.train)
    assert d["model"]["B"] == list(diag.model.B)
    assert d["screen"] == [{"name": s.name, "gap": s.gap} for s in diag.screen]
    assert d["selection"] == list(diag.selection)
    assert d["findings"] == [{"kind": f.kind, "message": f.message, **f.details}
                             for f in diag.findings]


def test_the_report_draws_the_test_record_with_the_largest_residual(diag):
    tr = diag.traces
    n_train = len(diag.data.train)
    energy = [float(np.sum(np.asarray(r) ** 2)) for r in tr.base_residuals]
    assert tr.focus >= n_train
    assert energy[tr.focus] == max(energy[n_train:])


def test_the_report_folder_holds_the_records(diag, tmp_path):
    """``--report``: the figures are PNG files, ``diagnosis.json`` is the JSON, and the
    document's candidate table lists every candidate's gaps as the records hold them."""
    from robrst.report.diagnosis import FIGURES, diagnosis_doc, write_diagnosis_report

    out = write_diagnosis_report(diag, tmp_path / "rep")
    for name in FIGURES:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    doc = json.loads((out / "diagnosis.json").read_text("utf-8"))
    want = diag.as_dict()
    assert {k: v for k, v in doc.items() if k != "seconds"} == \
        {k: v for k, v in want.items() if k != "seconds"}
    table = next(b for b in diagnosis_doc(diag).blocks if b[0] == "table")
    rows = {r[0]: r for r in table[2]}
    for e in diag.effects:
        row = next(r for name, r in rows.items() if name.startswith(e.name))
        assert row[2] == f"{e.gap_before:.4g}" and row[3] == f"{e.gap_after:.4g}"
    assert "report.md" in {p.name for p in out.iterdir()}
