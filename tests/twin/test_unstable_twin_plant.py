"""A twin whose plant is unstable in open loop (fourth round,
``tests/repro/turn4/twin_plant_unstable/``: ``robrst simulate fig2 --fast --twin tw.toml``
ended in "computation failed (ValueError: arange ...)" from matplotlib's tick locator
while drawing the diverging open-loop response): now an answer that says the output
diverges and when, metrics that need it are null, the figure draws the finite part."""

import json
import shutil

from robrst.cli import main


def test_a_diverging_open_loop_is_said_and_drawn_where_finite(repro_dir, tmp_path, capsys,
                                                               monkeypatch):
    for name in ("tw.toml", "u.toml"):
        shutil.copy(repro_dir / "turn4" / "twin_plant_unstable" / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "fig2", "--fast", "--quiet", "--twin", "tw.toml", "--out", "sim",
                 "--json"]) == 0
    out, err = capsys.readouterr()
    d = json.loads(out)
    assert err == ""
    diverged = [n for n in d["notes"] if "the output diverges" in n]
    assert {n.split(":")[0] for n in diverged} == {"fig2_50V", "fig2_100V"}   # 0 V stays at rest
    # the open loop 500/(s - 50) grows as exp(50 t): beyond 1e6 µm within a second
    for n in diverged:
        t = float(n.split("from t = ")[1].split(" s")[0])
        assert 0 < t < 1.0
    assert d["metrics"]["50V"]["drift_at_max_um"] is None
    assert d["metrics"]["0V"]["drift_at_max_um"] == 0.0
    png = (tmp_path / "sim" / "fig2.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 1000
    report = (tmp_path / "sim" / "report.md").read_text()
    assert "**Warning:** fig2_50V: the output diverges" in report
