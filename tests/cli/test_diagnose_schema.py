"""The published JSON Schema of ``robrst diagnose --json`` (docs/reference/diagnose.schema.json).

The schema declares the contract's fields in the order robrst writes them
(:meth:`robrst.diagnose.Diagnosis.as_dict`, then ``model_files`` and ``written_by``), and
real outputs validate against it: the command line's file with ``--model-out`` on a hidden
hysteresis, and the diagnoses of cases that fill the optional sections (sensor faults, an
alternative, an unmodelled-dynamics finding, a null case). A broken output does not.
"""

import json
from pathlib import Path

import jsonschema
import pytest

from diagnosis_cases import make
from robrst.cli import main
from robrst.data.dataset import save_dataset
from robrst.diagnose import diagnose
from robrst.diagnose.validation import make_case

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = json.loads((ROOT / "docs" / "reference" / "diagnose.schema.json").read_text("utf-8"))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)
TAIL = ("model_files", "written_by")


def errors(doc):
    return [f"{'/'.join(map(str, e.path))}: {e.message[:200]}" for e in VALIDATOR.iter_errors(doc)]


@pytest.fixture(scope="module")
def cli_doc(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("diag")
    train, test, _ = make_case("hysteresis", 2)
    names = []
    for i, d in enumerate(train + test):
        names.append(str(save_dataset(d, tmp / f"r{i}.csv")))
    out = tmp / "diag.json"
    assert main(["diagnose", "--train", *names[:len(train)], "--test", *names[len(train):],
                 "--model-out", str(tmp / "models"), "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text("utf-8"))


def test_the_schema_declares_the_contract_in_its_order(cli_doc):
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert list(SCHEMA["properties"]) == list(cli_doc)
    assert SCHEMA["required"] == [k for k in cli_doc if k not in TAIL]


def test_the_command_line_file_validates(cli_doc):
    assert cli_doc["cause"] == "hysteresis" and cli_doc["model_files"]
    assert errors(cli_doc) == []


@pytest.mark.parametrize("kind,name,seed,section", [
    ("twin", "none", 1, "gap"),
    ("hard", "hysteresis_outliers", 0, "sensor"),
    ("hard", "duffing_levels", 1, "alternatives"),
    ("hard", "second_resonance", 0, "findings"),
])
def test_the_optional_sections_validate(kind, name, seed, section):
    if kind == "twin":
        train, test, _ = make_case(name, seed)
        doc = diagnose(train, test).as_dict()
    else:
        train, test, model, _ = make(name, seed)
        doc = diagnose(train, test, plant=model).as_dict()
    assert doc[section], section          # the section this case fills
    assert errors(doc) == []


def test_a_broken_output_does_not_validate(cli_doc):
    bad = json.loads(json.dumps(cli_doc))
    bad["cause"] = 3
    del bad["gap"]["before"]
    bad["selected"][0]["params"]["A"] = "large"
    bad["where"]["frequency_band_hz"] = [1.0]
    found = errors(bad)
    assert len(found) == 4, found
