"""TOML that robrst writes (tomlkit): every file reads back by ``tomllib`` to the same values.

The checks are round trips through Python's own TOML reader (``tomllib``), independent of
the writer: hostile strings (quotes, backslashes, control characters, DEL, non-BMP
characters, an undecodable file-name byte), numbers at the ends of float64, nested arrays;
and the files of ``robrst identify`` and the margin goldens of ``robrst check``.
"""

import math
import tomllib

import numpy as np
import pytest
import tomlkit

from robrst.base.tomlwrite import comment_text, document, inline, plain
from robrst.identify.identification import Identified
from robrst.identify.modal import ModalModel
from robrst.identify.modelfile import model_text, problem_text, starting_wn
from robrst.identify._thermal import ThermalLaw
from robrst.testing import MARKER, read_golden, write_golden

HOSTILE = ['a"b', "back\\slash", "tab\there", "new\nline", "cr\rlf", "\x00\x01\x1f\x7f",
           "é µm °C", "emoji 😀", "'single'", '"""triple"""', "[not.a.table]", "# not a comment",
           "", " "]
NUMBERS = [0.0, -0.0, 1.0, 0.1 + 0.2, 1e-300, 5e-324, 1.7976931348623157e308, -2.5e-7,
           123456789.123456789, math.inf, -math.inf]


def _same(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return a == b and math.copysign(1, a) == math.copysign(1, b)
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and a == b


def test_hostile_strings_numbers_and_keys_round_trip():
    doc = document(["header with \x01 and a\nline break", *HOSTILE])
    data = {"strings": {f"k{i}": s for i, s in enumerate(HOSTILE)},
            "keys": {s or "empty": i for i, s in enumerate(HOSTILE)},
            "numbers": {"list": NUMBERS, "np": np.array(NUMBERS), "i": np.int64(-7),
                        "matrix": np.arange(6.0).reshape(2, 3), "flag": np.bool_(True)},
            "figures": {"Ms": inline({"value": np.float64(1.5), "rtol": 1e-4}),
                        "odd": inline({"value": -math.inf, "atol": 0.01})}}
    for k, v in plain({k: v for k, v in data.items() if k != "figures"}).items():
        doc[k] = v
    figures = tomlkit.table()
    for k, v in data["figures"].items():
        figures[k] = v
    doc["figures"] = figures
    text = tomlkit.dumps(doc)
    back = tomllib.loads(text)
    assert _same(back["strings"], {f"k{i}": s for i, s in enumerate(HOSTILE)})
    assert _same(back["keys"], {s or "empty": i for i, s in enumerate(HOSTILE)})
    assert _same(back["numbers"]["list"], NUMBERS) and _same(back["numbers"]["np"], NUMBERS)
    assert back["numbers"]["matrix"] == [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]
    assert back["numbers"]["i"] == -7 and back["numbers"]["flag"] is True
    assert back["figures"] == {"Ms": {"value": 1.5, "rtol": 1e-4},
                               "odd": {"value": -math.inf, "atol": 0.01}}
    assert "Ms = { value = 1.5, rtol = 0.0001 }" in text        # readable inline tables
    assert text.startswith("# header with \\x01 and a\\nline break\n")


def test_an_undecodable_file_name_byte_becomes_the_replacement_character():
    doc = document(["from r\udcff.csv"])
    doc["problem"] = plain({"name": "stage\udcff"})
    text = tomlkit.dumps(doc)
    text.encode("utf-8")                                  # a UTF-8 file can hold it
    assert tomllib.loads(text)["problem"]["name"] == "stage\ufffd"
    assert comment_text("r\udcff\n") == "r\ufffd\\n"


def test_plain_refuses_what_toml_cannot_hold():
    with pytest.raises(TypeError, match="NoneType"):
        plain({"x": None})


def _identified(temperatures, law=None):
    """Two-pole modal models (a real pole and a complex pair), one per temperature."""
    models = []
    for i, T in enumerate(temperatures):
        poles = np.array([-650.0 - i, -21.0 + 3872.9j])
        res = np.array([[[363.5 + 0j]], [[-128.3 - 213.7j]]]) * (1 + 0.01 * i)
        models.append(ModalModel(poles, res, np.zeros((1, 1)), temperature_C=T))
    return Identified(models=tuple(models), order=3, feedthrough=False, fs=20000.0, scores=(),
                      heldout=('held"out\n',), train=("r1",), heldout_nrmse=1e-4,
                      thermal=law)


STD = {"gain_per_K": 1e-5, "resonance_per_K": 2e-6, "damping_per_K": 3e-4}
LAWS = {"none": None,
        "holds": ThermalLaw(reference_C=28.0, gain_per_K=0.0015, resonance_per_K=-1e-4,
                            damping_per_K=0.005, std=STD, consistent=True,
                            temperatures_C=(28.0, 45.0)),
        "fails": ThermalLaw(reference_C=28.0, std=STD, consistent=False,
                            note='residual 7 sigma at 45 °C\n"odd"')}


@pytest.mark.parametrize("temperatures,law", [((None,), "none"), ((28.0, 45.0), "none"),
                                              ((28.0, 45.0), "holds"), ((28.0, 45.0), "fails")])
def test_identified_problem_file_round_trips(temperatures, law):
    ident = _identified(temperatures, LAWS[law])
    name = 'q"uote\\ \t\x7f\udcff'
    text = problem_text(ident, ['a"b\\c', "line\nbreak"], name)
    data = tomllib.loads(text)
    assert text.startswith("# written by robrst identify (problem file)\n")
    assert data["problem"]["name"] == 'q"uote\\ \t\x7f\ufffd'
    plants = [m.channel(0, 0) for m in ident.models]
    # the expanded polynomials, independently: residues over poles by numpy
    family = data.get("family", {}).get("models", [])
    for m, got in [(ident.models[0], data["plant"]), *zip(ident.models, family)]:
        A = np.real(np.poly([m.poles[0], m.poles[1], np.conj(m.poles[1])]))
        assert np.allclose(got["A"], A, rtol=1e-12)
    assert data["plant"]["B"] == plants[0].B.tolist() and data["plant"]["A"] == plants[0].A.tolist()
    if law == "holds":
        fam = data["family"]
        assert fam["temperatures_C"] == [28.0, 45.0] and "models" not in fam
        assert fam["parametric"] == {"gain_per_K": 0.0015, "resonance_per_K": -1e-4,
                                     "damping_per_K": 0.005}
        assert "damping_per_K = 0.005 # +/- 0.0003 (1 sigma)" in text
    elif len(temperatures) > 1:
        fam = data["family"]
        assert fam["reference_C"] == 28.0
        assert [f["temperature_C"] for f in fam["models"]] == [28.0, 45.0]
        assert [f["B"] for f in fam["models"]] == [p.B.tolist() for p in plants]
        assert ("# explicit models (robrst's thermal law does not hold: residual 7 sigma"
                in text) == (law == "fails")
    else:
        assert "family" not in data and "temperature_C" not in data["plant"]
    _check_starting_design(data, text, ident)


def _check_starting_design(data, text, ident):
    wn = starting_wn([m.channel(0, 0) for m in ident.models], ident.fs)
    assert data["poles"] == {"wn": wn, "zeta": 1.0}
    assert data["controller"] == {"T_mode": "reference_model", "reference_wn": wn}
    # |U| bounded from the largest identified static gain k: 10 / k (Mu_reason says why)
    k = max(abs(float(p.B[-1] / p.A[-1])) for p in (m.channel(0, 0) for m in ident.models))
    mu = float(f"{10.0 / k:.3g}")
    assert data["specs"] == {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": mu,
                             "Mu_reason": data["specs"]["Mu_reason"],
                             "overshoot_max_pct": 2.0, "sample_rate_hz": 20000.0}
    assert f"k = {k:.3g} um/V the identified static gain" in data["specs"]["Mu_reason"]
    assert data["solver"] == {"method": "nlp"}
    assert f"wn = {wn!r} # dominant natural frequency [rad/s]" in text
    assert "# A starting design, chosen by robrst identify" in text


@pytest.mark.parametrize("law", ["none", "holds", "fails"])
def test_identified_model_file_round_trips(law):
    ident = _identified((28.0, 45.0), LAWS[law])
    text = model_text(ident, ["r1"])
    data = tomllib.loads(text)
    _check_starting_design(data, text, ident)
    assert ("# per-kelvin laws fitted to these models" in text) == (law != "none")
    assert {k: data["model"][k] for k in ("format", "inputs", "outputs", "order", "fs_hz")} == {
        "format": "robrst-modal-1", "inputs": 1, "outputs": 1, "order": 3, "fs_hz": 20000.0}
    for m, at in zip(ident.models, data["model"]["at"]):
        assert at["temperature_C"] == m.temperature_C
        assert at["poles_re"] == m.poles.real.tolist() and at["poles_im"] == m.poles.imag.tolist()
        assert at["residues_re"] == m.residues.real.tolist()
        assert at["residues_im"] == m.residues.imag.tolist()
        assert at["D"] == [[0.0]]


def test_golden_with_hostile_labels_round_trips(tmp_path):
    """Model labels and the problem name are keys and strings of the golden: any text."""
    labels = ['T"28', "back\\slash", "new\nline", "😀", "a.b", "plain"]
    d = {"problem": 'p"\\\n', "certified": True, "certificate": {"models": []},
         "models": [{"label": lab, "temperature_C": 28.0 + i, "Ms": 1.5 + i, "Mu": None,
                     "phase_margin_deg": -70.25, "gain_margin": math.inf}
                    for i, lab in enumerate(labels)]}
    path = write_golden(d, tmp_path / "g.toml", rtol=2e-4, phase_atol_deg=0.05)
    text = path.read_text(encoding="utf-8")
    assert text.startswith(MARKER)
    raw = tomllib.loads(text)
    assert raw["golden"]["problem"] == 'p"\\\n' and raw["design"]["certified"] is True
    assert list(raw["models"]) == labels
    for i, lab in enumerate(labels):
        m = raw["models"][lab]
        assert m["temperature_C"] == 28.0 + i
        assert m["Ms"] == {"value": 1.5 + i, "rtol": 2e-4}
        assert "Mu" not in m          # a peak of inf checks nothing: a comment, not a figure
        assert m["phase_margin_deg"] == {"value": -70.25, "atol": 0.05}
    assert text.count("# Mu = inf checks nothing") == len(labels)
    assert set(read_golden(path)["models"]) == set(labels)
