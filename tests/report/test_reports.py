"""Report folders: regenerated into a temporary folder, every figure a valid PNG that the
Markdown and HTML reference; the committed examples are not stale."""

import json
import struct

import numpy as np
import pytest

from robrst.cli import main
from robrst.report.doc import Doc, to_html, to_markdown, write_folder
from robrst.report.examples import write_examples

PNG_SIG = b"\x89PNG\r\n\x1a\n"


def _check_png(path):
    data = path.read_bytes()
    assert data[:8] == PNG_SIG and data[12:16] == b"IHDR", path
    w, h = struct.unpack(">II", data[16:24])
    assert w >= 300 and h >= 200 and len(data) > 5000, path


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    out = tmp_path_factory.mktemp("reports")
    return out, write_examples(out)


@pytest.mark.slow
def test_every_figure_is_a_referenced_valid_png(fresh):
    _, paths = fresh
    assert [p.name for p in paths] == ["paper", "paper_robust", "diagnosis_twin"]
    for folder in paths:
        md = (folder / "report.md").read_text()
        html = (folder / "report.html").read_text()
        pngs = sorted(p.name for p in folder.glob("*.png"))
        assert len(pngs) >= 3
        for name in pngs:
            _check_png(folder / name)
            assert f"]({name})" in md and f'src="{name}"' in html
        assert not list(folder.parent.glob(f".{folder.name}.*"))  # no temporary leftovers


@pytest.mark.slow
def test_committed_reports_match_regenerated(fresh, root):
    _, paths = fresh
    for folder in paths:
        committed = root / "reports" / folder.name
        assert sorted(p.name for p in committed.iterdir()) == sorted(p.name for p in folder.iterdir())
    for name in ("paper", "paper_robust"):
        new = json.loads((paths[0].parent / name / "result.json").read_text())
        old = json.loads((root / "reports" / name / "result.json").read_text())
        for a, b in zip(new["models"], old["models"]):
            for k in ("Ms", "Mt", "Mu", "spectral_abscissa"):
                assert a[k] == pytest.approx(b[k], rel=1e-6), (name, k)
    new = json.loads((paths[2] / "diagnosis.json").read_text())
    old = json.loads((root / "reports" / "diagnosis_twin" / "diagnosis.json").read_text())
    assert new["cause"] == old["cause"]
    np.testing.assert_allclose(new["gap"]["before"], old["gap"]["before"], rtol=1e-9)


def test_markdown_and_html_carry_the_same_content():
    doc = Doc("t", (("h2", "A & B"), ("p", "x < y"), ("table", ("a", "b"), ((1, None),)),
                    ("img", "f.png", "cap"), ("pre", "code")))
    md, html = to_markdown(doc), to_html(doc)
    assert "## A & B" in md and "<h2>A &amp; B</h2>" in html
    assert "| 1 |  |" in md and "<td>1</td><td></td>" in html
    assert "![cap](f.png)" in md and '<img src="f.png" alt="cap">' in html


def test_failed_report_leaves_previous_folder_intact(tmp_path):
    out = tmp_path / "r"
    write_folder(out, Doc("t", (("p", "one"),)), {}, lambda d: None)
    assert "one" in (out / "report.md").read_text()

    def boom(d):
        raise RuntimeError("figure failed")

    with pytest.raises(RuntimeError):
        write_folder(out, Doc("t", (("p", "two"),)), {}, boom)
    assert "one" in (out / "report.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]


def test_cli_report_quiet(tmp_path, problems_dir, capsys):
    assert main(["report", str(problems_dir / "paper.toml"), "--out", str(tmp_path / "p"),
                 "--quiet"]) == 0
    io = capsys.readouterr()
    assert io.err == "" and "wrote" in io.out
    for f in ("report.md", "report.html", "result.json", "bode.png", "nyquist.png", "step.png"):
        assert (tmp_path / "p" / f).is_file()


def test_the_report_tables_every_spec_the_design_states(tmp_path, problems_dir):
    """The report's spec table has one row per spec of the design's JSON
    (``specs_achieved``: the defaults robrst adds included), its bound and achieved value
    as the command line prints them, and the same rows in Markdown and HTML."""
    out = tmp_path / "p"
    assert main(["report", str(problems_dir / "paper.toml"), "--out",
                 str(out), "--quiet"]) in (0, 1)
    rows = json.loads((out / "result.json").read_text())["specs_achieved"]
    md, html = (out / "report.md").read_text(), (out / "report.html").read_text()
    table = md.split("## Specs", 1)[1].split("\n## ", 1)[0]
    lines = [line for line in table.splitlines() if line.startswith("| ")][1:]
    assert len(lines) == len(rows) >= 3
    for line, row in zip(lines, rows):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[0].split(" (default)")[0] == row["spec"]
        assert float(cells[1]) == pytest.approx(row["bound"], rel=5e-4)
        assert float(cells[2]) == pytest.approx(row["achieved"], rel=5e-4)
        assert (cells[5] == "BINDS") == bool(row["binding"]) or "tolerance" in cells[5]
        assert f"<td>{cells[0]}</td>" in html
