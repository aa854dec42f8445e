"""The README's Python snippets run as written."""

import re
from pathlib import Path

import pytest


def test_readme_python_snippets_run(monkeypatch):
    root = Path(__file__).parents[2]
    monkeypatch.chdir(root)
    blocks = re.findall(r"```python\n(.*?)```", (root / "README.md").read_text(), re.S)
    assert blocks
    checked = set()
    for code in blocks:
        ns = {}
        exec(compile(code, "README.md", "exec"), ns)  # noqa: S102
        if "result" in ns:
            assert ns["result"].certified and ns["a"].stable
            assert ns["d"].cond < 1e3
            assert (ns["folder"] / "report.html").is_file()
            assert (ns["folder"] / "bode.png").is_file()
            assert ns["diag"].cause == "hysteresis" and ns["diag"].winner.shrink > 0.99
            checked.add("api")
        if "est" in ns:           # fit_effects on twin records: the hidden values recovered
            for k, v in ns["truth"]["params"].items():
                assert ns["est"].params[k] == pytest.approx(v, rel=1e-2), k
            checked.add("fit_effects")
    assert checked == {"api", "fit_effects"}


def test_quick_start_has_exactly_two_commands():
    text = (Path(__file__).parents[2] / "README.md").read_text()
    qs = text.split("## Quick start", 1)[1].split("##", 1)[0]
    cmds = re.findall(r"```bash\n(.*?)```", qs, re.S)[0].strip().splitlines()
    assert len(cmds) == 2 and "robrst design" in cmds[0] and "pytest" in cmds[1]


def test_readme_problem_file_reference_matches_schema():
    from robrst.problem.files import schema_markdown

    lines = (Path(__file__).parents[2] / "README.md").read_text().splitlines()
    hdr = lines.index("| table | key | type | required | default | meaning |")
    table = []
    for line in lines[hdr + 2:]:
        if not line.startswith("|"):
            break
        table.append(line)
    assert table == schema_markdown()
