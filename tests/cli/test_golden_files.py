"""Golden files users edit by hand: every mistake refused before the design, naming the file
and the key; ``check --update`` exits as ``design`` does (1 when not certified)."""

import re

import pytest

from robrst.cli import main
from robrst.base.errors import SpecError
from robrst.testing import compare_golden, read_golden

HEAD = '[golden]\nformat = 1\nproblem = "paper"\nrobrst_version = "0.1.0"\n'
DESIGN = ('[design]\ncertified = true\n'
          'objective = { name = "integral_gain", value = 432.5, rtol = 0.0001 }\n')
MODEL = ('[models."T28C"]\ntemperature_C = 28.0\nMs = { value = 1.48, rtol = 0.0001 }\n'
         'gain_margin = { value = 3.08, rtol = 0.0001 }\n'
         'gain_margin_lower = { value = inf, rtol = 0.0001 }\n')
GOOD = HEAD + DESIGN + MODEL


def sub(text, old, new):
    assert old in text, old
    return text.replace(old, new, 1)


BAD = {
    "golden_unknown_key": (sub(GOOD, "format = 1\n", "format = 1\nfoo = 3\n"), "[golden.foo]"),
    "design_typo": (sub(GOOD, "certified = true", "certifed = true"), "[design.certifed]"),
    "models_under_design": (HEAD + DESIGN + "models = 3\n", "[design.models]"),
    "gm_negative": (sub(GOOD, "gain_margin = { value = 3.08", "gain_margin = { value = -3.0"),
                    "[models.T28C.gain_margin]"),
    "gm_lower_negative": (sub(GOOD, "gain_margin_lower = { value = inf",
                              "gain_margin_lower = { value = -0.5"),
                          "[models.T28C.gain_margin_lower]"),
    "peak_negative": (sub(GOOD, "Ms = { value = 1.48", "Ms = { value = -1.48"), "[models.T28C.Ms]"),
    "temperature_str": (sub(GOOD, "temperature_C = 28.0", 'temperature_C = "hot"'),
                        "[models.T28C.temperature_C]"),
    "sampled_for_continuous": (sub(GOOD, "Ms = {", "Ms_sampled = { value = 1.5 }\nMs = {"),
                               "[models.T28C.Ms_sampled]"),
    "objective_other": (sub(GOOD, '"integral_gain"', '"worst_Ms"'), "[design.objective]"),
    "other_problem": (sub(GOOD, 'problem = "paper"', 'problem = "paper_robust"'),
                      "[golden.problem]"),
    "checks_nothing": (HEAD + "[design]\ncertified = false\n", "checks nothing"),
}


@pytest.mark.parametrize("name", list(BAD))
def test_a_bad_golden_is_refused_before_the_design(tmp_path, capsys, monkeypatch, name):
    text, key = BAD[name]
    path = tmp_path / "g.toml"
    path.write_text(text)

    def no_design(*a, **k):
        raise AssertionError("designed before refusing the golden")

    import robrst.design

    monkeypatch.setattr(robrst.design, "run_problem", no_design)     # every command's design
    assert main(["check", "paper", "--golden", str(path), "--quiet"]) == 2
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert out.out == "" and len(lines) == 1 and lines[0].startswith("robrst: error:")
    assert str(path) in lines[0] and key in lines[0], lines[0]
    assert path.read_text() == text


def test_the_good_golden_parses_and_counts_its_figures(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(GOOD)
    g = read_golden(path)
    assert g["path"] == str(path) and len(g["models"]["T28C"]) == 3


def test_compare_errors_name_the_golden_file(tmp_path, designs):
    path = tmp_path / "g.toml"
    path.write_text(sub(GOOD, "Ms = {", "Ms_sampled = { value = 1.5 }\nMs = {"))
    with pytest.raises(SpecError, match=re.escape(f"{path}: [models.T28C.Ms_sampled]")):
        compare_golden(designs("paper"), path)


def test_update_exits_1_when_the_design_is_not_certified(tmp_path, capsys, problems_dir):
    prob = tmp_path / "tight.toml"
    prob.write_text(re.sub(r"^Ms_max = 2.0", "Ms_max = 1.01", (problems_dir / "paper.toml")
                           .read_text(), flags=re.M))
    golden = tmp_path / "g.toml"
    assert main(["check", str(prob), "--golden", str(golden), "--update", "--quiet"]) == 1
    assert "certified: False" in capsys.readouterr().out and golden.exists()
    assert main(["check", str(prob), "--golden", str(golden), "--quiet"]) == 0
