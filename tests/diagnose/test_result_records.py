"""The diagnosis is a record to its edge: every JSON section a typed field, the JSON written
from them in one place (:meth:`Diagnosis.as_dict`).

Checked on a seeded withheld case: no field of the result records is annotated ``dict``,
``object`` or ``Any``; the JSON is plain (it dumps with ``allow_nan=False``); and its
sections hold what the records hold, read field by field here (not through ``as_dict``).
"""

import dataclasses
import json
import math

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
