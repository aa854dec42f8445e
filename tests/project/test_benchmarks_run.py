"""Every benchmark runs once at a tiny size so none can rot (timings are not asserted)."""

import json

import pytest

from benchmarks.__main__ import available, main


@pytest.mark.parametrize("name,mod", available(), ids=[n for n, _ in available()])
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
