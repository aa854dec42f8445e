"""Multi-axis problem files: model files of robrst identify as they are, state spaces,
transfer matrices; one-line errors naming the file and the key; the command line."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robrst.base.errors import SpecError
from robrst.problem.mimo_files import is_mimo_file, load_mimo_problem, mimo_schema_markdown

ROOT = Path(__file__).resolve().parents[2]

MODEL = """# written by robrst identify (model file)
[model]
format = "robrst-modal-1"
inputs = 2
outputs = 2
source = "robrst identify"

[[model.at]]
poles_re = [-60.0, -90.0]
poles_im = [6000.0, 9000.0]
residues_re = [[[0.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]]]
residues_im = [[[-300.0, -30.0], [-20.0, -50.0]], [[-20.0, -40.0], [-30.0, -450.0]]]
D = [[0.0, 0.0], [0.0, 0.0]]
"""

PROBLEM = """[problem]
name = "stage"

[mimo]
parameter = "level"
unit = "mV"
axes = ["x", "y"]

[[mimo.models]]
file = "m100.toml"
value = 100.0

[[mimo.models]]
A = [[-600.0, 0.0], [0.0, -700.0]]
B = [[600.0, 0.0], [0.0, 700.0]]
C = [[0.1, 0.01], [0.02, 0.1]]
D = [[0.0, 0.0], [0.0, 0.0]]
value = 200.0

[[mimo.models]]
num = [[[60.0], [6.0]], [[14.0], [70.0]]]
den = [1.0, 650.0]
value = 300.0

[mimo.specs]
sigma_S_max = 2.0
sample_rate_hz = 10000.0
{extra}
"""


def _write(tmp_path, extra="", model=MODEL):
    (tmp_path / "m100.toml").write_text(model)
    p = tmp_path / "stage.toml"
    p.write_text(PROBLEM.format(extra=extra))
    return p


def test_models_of_every_kind(tmp_path):
    p = _write(tmp_path)
    assert is_mimo_file(p)
    pr = load_mimo_problem(p)
    fam = pr.family
    assert [m.value for m in fam.models] == [100.0, 200.0, 300.0]
    assert pr.axes == ("x", "y") and fam.unit == "mV" and fam.parameter == "level"
    # the model file's modal form: G(s) = sum R/(s - p) + conj
    w = np.array([10.0, 5000.0])
    p1, p2 = -60 + 6000j, -90 + 9000j
    R1 = np.array([[-300j, -30j], [-20j, -50j]])
    R2 = np.array([[-20j, -40j], [-30j, -450j]])
    ref = [R1 / (1j * x - p1) + R1.conj() / (1j * x - p1.conjugate()) + R2 / (1j * x - p2)
           + R2.conj() / (1j * x - p2.conjugate()) for x in w]
    assert np.allclose(fam.models[0].freqresp(w), ref, rtol=1e-12)
    # transfer matrix with one common denominator
    g3 = fam.models[2].freqresp([0.0])[0].real
    assert np.allclose(g3, [[60 / 650, 6 / 650], [14 / 650, 70 / 650]], rtol=1e-12)


@pytest.mark.parametrize("extra,key", [
    ("[mimo.solver]\nmethdo = 'nlp'", "mimo.solver.methdo"),
    ("[mimo.controller]\ndecoupler = 'given'", "mimo.controller"),
    ("[mimo.controller]\ndecoupler = 'given'\nW = [[1.0, 0.0], [0.0]]", "mimo.controller.W"),
    ("[mimo.specs.x]", "mimo.specs.x"),
])
def test_bad_keys_are_named(tmp_path, extra, key):
    p = _write(tmp_path, extra.replace("[mimo.specs.x]", "").replace("[mimo.specs]", "")
               if False else "")
    text = p.read_text()
    if extra.startswith("[mimo.specs.x]"):
        text = text.replace("sample_rate_hz = 10000.0", "sample_rate_hz = 10000.0\nx = 1")
        key = "mimo.specs.x"
    else:
        text += "\n" + extra + "\n"
    p.write_text(text)
    with pytest.raises(SpecError) as e:
        load_mimo_problem(p)
    assert str(p) in str(e.value) and f"[{key}" in str(e.value)


def test_non_square_plant_is_refused(tmp_path):
    bad = MODEL.replace("inputs = 2", "inputs = 3").replace(
        "[[0.0, 0.0], [0.0, 0.0]]", "[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]").replace(
        "[[-300.0, -30.0], [-20.0, -50.0]]", "[[-300.0, -30.0, 1.0], [-20.0, -50.0, 1.0]]").replace(
        "[[-20.0, -40.0], [-30.0, -450.0]]", "[[-20.0, -40.0, 1.0], [-30.0, -450.0, 1.0]]")
    p = _write(tmp_path, model=bad)
    text = p.read_text()
    start = text.index("[[mimo.models]]\nA")
    end = text.index("[mimo.specs]")
    p.write_text(text[:start] + text[end:])
    with pytest.raises(SpecError, match="square"):
        load_mimo_problem(p)


def test_missing_model_file_named(tmp_path):
    p = _write(tmp_path)
    (tmp_path / "m100.toml").unlink()
    with pytest.raises(SpecError, match=r"\[mimo.models.0.file\].*not found"):
        load_mimo_problem(p)


def test_reference_rows_list_every_key():
    rows = "\n".join(mimo_schema_markdown())
    for key in ("sigma_S_max", "crosstalk_band_hz", "decoupler_hz", "`A`", "`num`", "`W`",
                "`axes`", "input_gain_deviation"):
        assert key in rows


def _cli(*args, cwd=None):
    env = {"PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", "robrst", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=600)


def test_cli_error_is_one_line_exit_2(tmp_path):
    p = _write(tmp_path, "[mimo.controller]\nextra_degree = -1")
    r = _cli("design", p)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "mimo.controller.extra_degree" in r.stderr


@pytest.mark.slow
def test_cli_design_json(tmp_path):
    p = _write(tmp_path, "[mimo.solver]\nmax_rounds = 2\nn_freq = 40")
    r = _cli("design", p, "--json", "--quiet")
    d = json.loads(r.stdout)
    assert d["kind"] == "mimo" and r.returncode == (0 if d["certified"] else 1)
    assert set(d["certificate"]) >= {"certified", "models", "violations", "interval"}


def test_modes_below_a_frequency_are_dropped_from_every_model(tmp_path):
    """``drop_modes_below_hz = 104`` (653 rad/s): the 600 rad/s mode of the state space and
    the 650 rad/s transfer matrix go, the 700 rad/s mode and the resonances stay."""
    (tmp_path / "m100.toml").write_text(MODEL)
    p = tmp_path / "stage.toml"
    p.write_text(PROBLEM.format(extra="").replace('unit = "mV"\n',
                                                  'unit = "mV"\ndrop_modes_below_hz = 104.0\n'))
    fam = load_mimo_problem(p).family
    assert [m.n_states for m in fam.models] == [8, 1, 0]     # residues of rank 2
    w = np.array([0.0, 100.0, 1e4])
    C, B = np.array([[0.1, 0.01], [0.02, 0.1]]), np.array([[600.0, 0.0], [0.0, 700.0]])
    ref = [np.outer(C[:, 1], B[1]) / (1j * x + 700.0) for x in w]
    assert np.allclose(fam.models[1].freqresp(w), ref, rtol=1e-12, atol=1e-15)
    assert np.allclose(fam.models[2].freqresp(w), 0.0)
