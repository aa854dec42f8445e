"""``--json FILE`` of identify and diagnose: never over a file robrst did not write (the
training data itself, a note, the model just written), always over its own JSON."""

import json

import numpy as np
import pytest

from robrst.cli import main


@pytest.fixture()
def record(tmp_path):
    """A first-order step record (2000/(s + 2000) µm/V at 20 kHz, exact ZOH samples)."""
    fs, rng = 20000.0, np.random.default_rng(1)
    u = np.repeat(rng.uniform(0.0, 10.0, 20), 100)
    a = np.exp(-2000.0 / fs)
    y = np.zeros_like(u)
    for k in range(1, len(u)):
        y[k] = a * y[k - 1] + (1.0 - a) * u[k - 1]
    f = tmp_path / "data.csv"
    np.savetxt(f, np.c_[np.arange(len(u)) / fs, u, y], delimiter=",", header="t,u,y",
               comments="")
    return f


def _run(argv, capsys):
    rc = main(argv)
    return rc, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("command", ["identify", "diagnose"])
def test_json_never_replaces_a_users_file(tmp_path, record, capsys, command):
    note = tmp_path / "notes.txt"
    note.write_text("my notes\n")
    other = tmp_path / "other.json"
    other.write_text('{"mine": 1}\n')                 # a JSON object robrst did not write
    before = {p: p.read_bytes() for p in (record, note, other)}
    for target in (record, note, other):
        argv = ([command, "--train", str(record), "--json", str(target), "--quiet"]
                + (["--out", str(tmp_path / "m.toml")] if command == "identify" else
                   ["--test", str(record)]))
        rc, err = _run(argv, capsys)
        assert rc == 2 and len(err) == 1, err
        assert str(target) in err[0] and "not written by robrst" in err[0]
    assert {p: p.read_bytes() for p in before} == before
    assert not (tmp_path / "m.toml").exists()      # refused before any work or write


def test_identify_json_is_not_its_own_model_file(tmp_path, record, capsys):
    model = tmp_path / "m.toml"
    rc, err = _run(["identify", "--train", str(record), "--out", str(model), "--json",
                    str(model), "--quiet"], capsys)
    assert rc == 2 and len(err) == 1 and "separate --json" in err[0]
    assert not model.exists()


def test_robrst_replaces_its_own_json(tmp_path, record, capsys):
    res = tmp_path / "res.json"
    argv = ["identify", "--train", str(record), "--out", str(tmp_path / "m.toml"),
            "--json", str(res), "--quiet"]
    assert main(argv) == 0 and main(argv) == 0     # the second run replaces the first's
    doc = json.loads(res.read_text())
    assert doc["written_by"] == "robrst identify" and doc["order"] == 1
    assert main(["diagnose", "--train", str(record), "--test", str(record), "--json", str(res),
                 "--quiet"]) == 0
    assert json.loads(res.read_text())["written_by"] == "robrst diagnose"
    capsys.readouterr()
