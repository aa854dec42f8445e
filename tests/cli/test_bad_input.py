"""Bad input: every malformed file, key, value, column, path or argument is refused cleanly.

Each variant runs one command line through :func:`robrst.cli.main` in this process and
checks robrst's contract for bad input (README "Errors and exit codes"):

* exit code 2 (never 1, which means "designed but not certified");
* exactly one line on stderr, starting ``robrst: error:``, naming the file (or the
  argument) and the key or column, and saying what was expected;
* no traceback, nothing on stdout;
* no file or folder created, changed or deleted (every byte under the working folder is
  compared before and after).

A few variants also run as a real subprocess (``python -m robrst``).
"""

import json
import subprocess
import sys

import pytest
from bad_inputs import DIR, VARIANTS

from robrst.cli import LAST_RESORT, main

# ---------------------------------------------------------------------------- harness


def materialise(root, files):
    for name, content in files.items():
        p = root / name
        if content is DIR:
            p.mkdir(parents=True, exist_ok=True)
            continue
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, str):
            p.write_text(content, encoding="utf-8")
        else:
            p.write_bytes(content)


def snapshot(root):
    """Every file's bytes and every folder under ``root``."""
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(root.rglob("*"))}


def check_refused(code, out, err, variant, before, after):
    assert code == 2, f"exit {code}; stderr: {err!r}"
    assert "Traceback" not in err and "Traceback" not in out
    assert out == "", f"stdout: {out!r}"
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"stderr has {len(lines)} lines: {err!r}"
    line = lines[0]
    assert line.startswith("robrst: error: ")
    assert LAST_RESORT not in line, f"the last-resort line was reached: {line!r}"
    for s in variant.expect:
        assert s in line, f"{s!r} not in {line!r}"
    assert after == before, "files created, changed or deleted"


def test_at_least_90_variants():
    assert len(VARIANTS) >= 90
    assert len({v.id for v in VARIANTS}) == len(VARIANTS)


@pytest.mark.parametrize("variant", VARIANTS, ids=[v.id for v in VARIANTS])
def test_bad_input_refused(variant, tmp_path, monkeypatch, capsys):
    materialise(tmp_path, variant.files)
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    try:
        code = main(list(variant.argv))
    except SystemExit as exc:          # argparse errors
        code = exc.code
    out, err = capsys.readouterr()
    check_refused(code, out, err, variant, before, snapshot(tmp_path))


SUBPROCESS = ("latin1_degree_comment", "n_freq_1e9", "twin_is_folder", "csv_y_identically_zero")


@pytest.mark.parametrize("vid", SUBPROCESS)
def test_bad_input_refused_in_a_process(vid, tmp_path):
    variant = next(v for v in VARIANTS if v.id == vid)
    materialise(tmp_path, variant.files)
    before = snapshot(tmp_path)
    r = subprocess.run([sys.executable, "-m", "robrst", *variant.argv], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    check_refused(r.returncode, r.stdout, r.stderr, variant, before, snapshot(tmp_path))


def test_double_integrator_json_is_valid(tmp_path):
    """S_fixed = s^2: the integral gain is infinite; ``--json`` still prints valid JSON (null).

    Run in a process so that anything IPOPT prints on file descriptor 1 would be caught.
    """
    (tmp_path / "p.toml").write_text(
        '[plant]\nB = [1.0]\nA = [1.0, 1.0]\n[poles]\nwn = 1.0\nzeta = 0.8\n'
        '[controller]\nS_fixed = [1.0, 0.0, 0.0]\n[specs]\nMs_max = 3.0\n'
        '[solver]\nmethod = "nlp"\nobjective = "feasibility"\n')
    r = subprocess.run([sys.executable, "-m", "robrst", "design", "p.toml", "--json"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert r.returncode in (0, 1) and "Traceback" not in r.stderr
    d = json.loads(r.stdout, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert d["integral_gain"] is None
    assert d["controller"]["S"][-2:] == [0.0, 0.0]
