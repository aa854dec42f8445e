"""The README is a front page whose commands, problem file and Python tour work as written."""

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", README, re.S)


def test_quick_start_has_exactly_two_commands():
    qs = README.split("## Quick start", 1)[1].split("##", 1)[0]
    cmds = re.findall(r"```bash\n(.*?)```", qs, re.S)[0].strip().splitlines()
    assert len(cmds) == 2 and "robrst design" in cmds[0] and "pytest" in cmds[1]
    assert cmds == ["python3 -m pip install . && robrst design paper_robust",
                    'python3 -m pip install -e ".[test]" && python3 -m pytest -q']


def test_the_readme_is_a_front_page():
    """Under 200 lines, one figure, and every relative link points at a file of the checkout."""
    lines = README.splitlines()
    assert len(lines) < 200, len(lines)
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README)
    assert len(images) == 1 and (ROOT / images[0]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    targets = [t.split("#")[0] for t in re.findall(r"\]\(([^)]+)\)", README)
               if not t.startswith(("http://", "https://"))]
    assert targets and [t for t in targets if not (ROOT / t).exists()] == []


@pytest.mark.slow
def test_the_python_tour_runs(tmp_path, monkeypatch):
    """The README's one Python block: about 20 lines, and it does what its comments say."""
    (code,) = blocks("python")
    assert len(code.strip().splitlines()) <= 22
    monkeypatch.chdir(tmp_path)
    ns = {}
    exec(compile(code, "README.md", "exec"), ns)  # noqa: S102
    assert ns["a"].stable and ns["d"].cond < 1e3
    assert ns["result"].certified and ns["exported"].certified
    assert ns["exported"].digital.S_z[0] == 1.0          # ascending powers of q^-1, monic
    assert (ns["folder"] / "report.html").is_file() and (ns["folder"] / "bode.png").is_file()


def stage_problem():
    (text,) = blocks("toml")
    assert text == (ROOT / "docs" / "examples" / "my_stage.toml").read_text(encoding="utf-8")
    from robrst.problem.files import parse_problem
    return parse_problem(tomllib.loads(text), "my_stage.toml")


@pytest.mark.slow
def test_the_stage_file_designs_and_certifies():
    """The annotated stage of "Your own stage" certifies with the figures the README states,
    re-checked independently: the integral gain from the controller's coefficients, Ms of
    every family model on a dense grid of the unscaled polynomials, and the sampled loop
    through python-control (ZOH plant, Tustin controller) on a dense unit-circle grid."""
    import control

    from robrst.design import run_problem

    problem = stage_problem()
    res = run_problem(problem)
    assert res.certified and res.status == "certified"
    R, S = res.controller.R, res.controller.S
    assert S[-1] == 0.0 and round(R[-1] / S[-2]) == 1572431      # "integral gain 1,572,431"
    w = np.logspace(0, 6, 200_001)
    fs = problem.specs.sample_rate_hz
    z = np.exp(1j * np.linspace(1e-6, np.pi, 100_001))
    Kd = control.c2d(control.tf(R, S), 1 / fs, "tustin")
    ms, ms_sampled = [], []
    for m in problem.family.models:
        L = np.polyval(m.B, 1j * w) * np.polyval(R, 1j * w) / (
            np.polyval(m.A, 1j * w) * np.polyval(S, 1j * w))
        ms.append(np.max(np.abs(1 / (1 + L))))
        Pd = control.c2d(control.tf(m.B, m.A), 1 / fs, "zoh")
        Ld = (Pd * Kd)(z)
        ms_sampled.append(np.max(np.abs(1 / (1 + Ld))))
    assert round(max(ms), 2) == 1.24 and round(max(ms_sampled), 2) == 1.70   # as stated
    assert max(ms) <= problem.specs.Ms_max and max(ms_sampled) <= problem.specs.Ms_max
