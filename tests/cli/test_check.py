"""``robrst check`` and ``robrst.testing.assert_margins``: users' regression tests on margins."""

import re
import subprocess
import sys
import tomllib

import pytest

from robrst.cli import main
from robrst.base.errors import OutputError, SpecError
from robrst.testing import MARKER, assert_margins, compare_golden, read_golden, write_golden


@pytest.fixture
def golden(tmp_path, capsys):
    path = tmp_path / "paper_margins.toml"
    assert main(["check", "paper", "--golden", str(path), "--update", "--quiet"]) == 0
    assert "wrote" in capsys.readouterr().out
    return path


def test_update_writes_a_readable_golden_that_passes(golden, capsys, designs):
    text = golden.read_text()
    assert text.startswith(MARKER)
    data = tomllib.loads(text)
    assert data["golden"]["problem"] == "paper" and data["design"]["certified"] is True
    t28 = data["models"]["T28C"]
    assert {"Ms", "Mt", "Mu", "gain_margin", "phase_margin_deg", "modulus_margin",
            "delay_margin_s"} <= set(t28)
    model = designs("paper").as_dict()["models"][0]
    assert t28["Ms"]["value"] == model["Ms"] and t28["Ms"]["rtol"] == 1e-4
    assert t28["phase_margin_deg"]["atol"] == 1e-2
    assert data["design"]["objective"]["name"] == "integral_gain"
    assert main(["check", "paper", "--golden", str(golden), "--quiet"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and "no figure worse" in out[0]


def _scale(path, figure, factor):
    """Multiply ``figure``'s golden value by ``factor`` in the file (a text edit, as a user would)."""
    text = path.read_text()
    new, n = re.subn(rf"^{figure} = {{ value = ([^,]+),",
                     lambda m: f"{figure} = {{ value = {float(m.group(1)) * factor!r},", text,
                     flags=re.M)
    assert n == 1
    path.write_text(new)


@pytest.mark.parametrize("figure,factor", [
    ("Ms", 1 / 1.01), ("Mu", 1 / 1.01),                        # a peak 1 % larger than golden
    ("modulus_margin", 1.01), ("delay_margin_s", 1.01), ("phase_margin_deg", 1.01),
    ("gain_margin", 1.01),                                     # margins 1 % smaller
])
def test_a_one_percent_regression_exits_1_naming_the_figure(golden, capsys, figure, factor):
    _scale(golden, figure, factor)
    assert main(["check", "paper", "--golden", str(golden), "--quiet"]) == 1
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 2 and lines[0].startswith(f"T28C {figure}:") and "worse" in lines[0]
    assert lines[1].startswith("robrst check: 1 of")


def test_improvements_and_tolerances_pass(golden):
    _scale(golden, "Ms", 1.01)                                 # the design is 1 % better
    _scale(golden, "modulus_margin", 1 / 1.01)
    assert main(["check", "paper", "--golden", str(golden), "--quiet"]) == 0
    _scale(golden, "Mt", 1 / (1 + 5e-5))                       # worse by 5e-5 < rtol 1e-4
    assert main(["check", "paper", "--golden", str(golden), "--quiet"]) == 0


def test_objective_and_certificate_regressions(golden, designs, capsys):
    text = golden.read_text()
    gain = designs("paper").integral_gain
    golden.write_text(text.replace(f"value = {gain!r}, rtol", f"value = {gain * 1.01!r}, rtol"))
    assert main(["check", "paper", "--golden", str(golden), "--quiet"]) == 1
    assert "integral_gain:" in capsys.readouterr().out
    d = designs("paper").as_dict()
    d["certified"] = False
    worse = compare_golden(d, golden)
    assert [w.figure for w in worse] == ["certified", "integral_gain"]
    d["models"] = []
    assert any(w.figure == "model" and w.model == "T28C" for w in compare_golden(d, golden))


@pytest.mark.parametrize("text,msg", [
    ("this is [not toml", "invalid TOML"),
    ('[design]\ncertified = true\n', "[golden]"),
    ('[golden]\nformat = 1\nproblem = "paper"\n[models.T28C]\nMs = { value = "big" }\n',
     "models.T28C.Ms] value must be a number"),
    ('[golden]\nformat = 1\nproblem = "paper"\n[models.T28C]\nMs = { value = 1.0, rtol = -1 }\n',
     "models.T28C.Ms.rtol]"),
    ('[golden]\nformat = 1\nproblem = "paper"\n[models.T28C]\nwobble = { value = 1.0 }\n',
     "not a margin figure"),
    ('[golden]\nformat = 1\nproblem = "paper"\n[models.T28C]\nMs = { value = 1.0, tol = 1 }\n',
     "unknown key"),
    ('[golden]\nformat = 1\nproblem = "paper"\n[design]\nobjective = { name = "speed", value = 1 }\n',
     "design.objective"),
    ('[golden]\nformat = 1\nproblem = "paper"\n[extra]\n', "unknown table"),
])
def test_a_malformed_golden_exits_2_with_one_line(tmp_path, capsys, text, msg):
    path = tmp_path / "g.toml"
    path.write_text(text)
    assert main(["check", "paper", "--golden", str(path)]) == 2
    out = capsys.readouterr()
    assert out.out == "" and len(out.err.strip().splitlines()) == 1
    assert out.err.startswith("robrst: error:") and str(path) in out.err and msg in out.err


def test_other_errors_exit_2(tmp_path, golden, capsys):
    text = golden.read_text().replace('problem = "paper"', 'problem = "other"')
    other = tmp_path / "other.toml"
    other.write_text(text)
    assert main(["check", "paper", "--golden", str(other)]) == 2
    assert "is for problem 'other'" in capsys.readouterr().err
    r = subprocess.run([sys.executable, "-m", "robrst", "check", "paper", "--golden",
                        str(tmp_path / "none.toml"), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "not found" in r.stderr


def test_update_never_overwrites_a_file_it_did_not_write(tmp_path, designs):
    mine = tmp_path / "notes.toml"
    mine.write_text("my = 1\n")
    with pytest.raises(OutputError, match="not a robrst golden"):
        write_golden(designs("paper"), mine)
    assert mine.read_text() == "my = 1\n"


def test_update_refuses_a_file_in_the_way_before_designing(tmp_path, monkeypatch, capsys):
    """`check --update` onto a file robrst did not write: refused before the design (it
    designed paper_robust for a minute, then refused)."""
    import robrst.cli._check as cli_check

    def boom(*a, **k):
        raise AssertionError("designed before refusing")

    monkeypatch.setattr(cli_check, "design_result", boom)
    mine = tmp_path / "notes.toml"
    mine.write_text("my = 1\n")
    assert main(["check", "paper_robust", "--golden", str(mine), "--update", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a robrst golden" in err[0] and str(mine) in err[0], err
    assert mine.read_text() == "my = 1\n"


def test_assert_margins_for_pytest(tmp_path, designs):
    result = designs("paper_robust")
    path = tmp_path / "robust.toml"
    assert_margins(result, path, update=True)
    assert_margins(result, path)
    g = read_golden(path)
    gm = result.as_dict()["models"][0]["gain_margin"]
    assert g["models"]["T28C"]["gain_margin"][0] == (float("inf") if gm is None else gm)
    assert len(g["models"]) == len(result.problem.family.models)
    _scale_all = path.read_text().replace("Ms = { value = ", "Ms = { value = 0.9 * ")
    path.write_text(re.sub(r"0\.9 \* ([0-9.e+-]+)", lambda m: repr(0.9 * float(m.group(1))),
                           _scale_all))
    with pytest.raises(AssertionError) as err:
        assert_margins(result, path)
    assert str(err.value).count(" Ms: ") == len(result.problem.family.models)
    with pytest.raises(SpecError, match="for problem"):
        assert_margins(designs("paper"), path)


def test_sampled_problems_record_the_sampled_peaks(tmp_path, designs):
    path = write_golden(designs("paper_robust"), tmp_path / "s.toml")
    figs = read_golden(path)["models"]["T45C"]
    assert {"Ms_sampled", "Mt_sampled", "Mu_sampled"} <= set(figs)
    assert compare_golden(designs("paper_robust"), path) == []


def test_infinite_margins(tmp_path, designs):
    """``null`` margins are infinite: written as inf; a finite one later is worse."""
    d = designs("paper").as_dict()
    d["models"][0]["gain_margin"] = None
    path = write_golden(d, tmp_path / "inf.toml")
    assert "gain_margin = { value = inf" in path.read_text()
    assert compare_golden(d, path) == []
    d["models"][0]["gain_margin"] = 40.0
    assert [w.figure for w in compare_golden(d, path)] == ["gain_margin"]
