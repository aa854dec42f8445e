"""Every benchmark runs once at a tiny size so none can rot (timings are not asserted)."""

import json

import pytest

from benchmarks.__main__ import available, main


# the tiny runs that design with the NLP or diagnose (4-130 s each) run with -m slow
SLOW = {"global", "synthesis", "userflow", "peaks", "variants", "diagnosis", "sweep"}


@pytest.mark.parametrize("name,mod", [
    pytest.param(n, m, id=n, marks=[pytest.mark.slow] if n in SLOW else [])
    for n, m in available()])
def test_benchmark_runs_tiny(name, mod):
    r = mod.run(tiny=True)
    assert r.name and r.headline and isinstance(r.met, bool)
    json.dumps(r.figures, default=float)  # raw figures are JSON-serialisable


def test_benchmark_cli_writes_reports(tmp_path, capsys):
    assert main(["--tiny", "--only", "analytic", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "benchmarks.md").read_text()
    raw = json.loads((tmp_path / "benchmarks.json").read_text())
    assert "| analytic pole placement |" in md
    assert raw["meta"]["mode"] == "tiny" and raw["results"][0]["name"] == "analytic pole placement"
    assert "analytic pole placement" in capsys.readouterr().out
