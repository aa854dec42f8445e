"""The published JSON Schema of ``robrst design --json`` (docs/reference/design.schema.json).

The schema declares the contract's fields in the order the contract module declares them
(:mod:`robrst.design.contract`), and real outputs of the command line validate against it:
a certified design, a design that is not certified, a sampled two-degree-of-freedom design
with time-domain specs, a saved design certified again (``certify --json``) and the committed
reports' result files.  A broken output does not.
"""

import json
from dataclasses import fields
from pathlib import Path

import jsonschema
import pytest

from robrst.cli import main
from robrst.design.achieved import SPEC_ROW_FIELDS
from robrst.design.contract import (ANALYTIC_CHECK_FIELDS, CERTIFICATE_FIELDS, DESIGN_FIELDS,
                                    OPTIONAL_FIELDS, SPECS_DEFAULT_FIELDS, VIOLATION_FIELDS)
from robrst.problem.records import Specs
from robrst.problem.specs import SPEC_TABLE

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = json.loads((ROOT / "docs" / "reference" / "design.schema.json").read_text("utf-8"))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)
NOT_CERTIFIED = """
[problem]
name = "tight"
[plant]
name = "paper"
[controller]
S_fixed = [1.0, 0.0]
extra_degree = 1
[poles]
wn = 600.0
zeta = 1.0
[specs]
Ms_max = 1.2
Mt_max = 1.3
[solver]
method = "analytic"
"""


def errors(doc):
    return [f"{'/'.join(map(str, e.path))}: {e.message[:200]}" for e in VALIDATOR.iter_errors(doc)]


def run_json(capsys, *args, code=0):
    assert main([*args, "--json", "--quiet"]) == code
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == ("certified" if code == 0 else "not_certified")
    return doc


def test_the_schema_declares_the_contract_in_its_order():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert list(SCHEMA["properties"]) == list(DESIGN_FIELDS)
    assert SCHEMA["required"] == [k for k in DESIGN_FIELDS if k not in OPTIONAL_FIELDS]
    props = SCHEMA["properties"]
    assert list(props["certificate"]["properties"]) == list(CERTIFICATE_FIELDS)
    cert = props["certificate"]["properties"]
    assert list(cert["violations"]["items"]["properties"]) == list(VIOLATION_FIELDS)
    assert list(props["specs_achieved"]["items"]["properties"]) == list(SPEC_ROW_FIELDS)
    assert list(props["analytic_check"]["properties"]) == list(ANALYTIC_CHECK_FIELDS)
    published = [s.key for s in SPEC_TABLE if s.published != "never"]
    assert list(props["specs"]["properties"]) == published + list(SPECS_DEFAULT_FIELDS)
    assert set(published) <= {f.name for f in fields(Specs)}


@pytest.mark.slow
def test_real_outputs_validate(capsys, tmp_path):
    """A certified, a not-certified and a sampled 2-DOF design, and certify of a saved one."""
    certified = run_json(capsys, "design", "paper")
    f = tmp_path / "tight.toml"
    f.write_text(NOT_CERTIFIED)
    failed = run_json(capsys, "design", str(f), code=1)
    sampled = run_json(capsys, "design", "paper_robust", "--method", "analytic", code=1)
    saved = tmp_path / "DESIGN.json"
    saved.write_text(json.dumps(certified))
    again = run_json(capsys, "certify", str(saved))
    assert failed["status"] == "not_certified" and failed["certificate"]["violations"]
    assert "Ms_sampled" in sampled["certificate"]["models"][0] and "tracking" in sampled
    for doc in (certified, failed, sampled, again):
        assert errors(doc) == []
        keys = [k for k in doc if k in DESIGN_FIELDS]      # the declared order, kept
        assert keys == [k for k in DESIGN_FIELDS if k in doc]


@pytest.mark.parametrize("path", sorted(p.relative_to(ROOT).as_posix() for p in
                                        (ROOT / "reports").rglob("result.json")))
def test_the_committed_reports_validate(path):
    assert errors(json.loads((ROOT / path).read_text("utf-8"))) == []


def test_a_broken_output_does_not_validate(capsys):
    doc = run_json(capsys, "design", "paper")
    for broken in ({**doc, "status": "ok"}, {k: v for k, v in doc.items() if k != "certificate"},
                   {**doc, "specs_achieved": [{"spec": "Ms_max"}]}):
        assert errors(broken)
