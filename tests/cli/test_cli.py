"""The CLI contract: table, --json with the documented fields, one-line errors."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from robrst.cli import main
from robrst.base.errors import SpecError
from robrst.design.candidate import LOCAL_RUN_NOTE

MODEL_KEYS = {"label", "temperature_C", "A", "B", "stable", "closed_loop_poles", "Ms",
              "Ms_freq_rad_s", "Mt", "Mu", "gain_margin", "phase_margin_deg",
              "modulus_margin", "delay_margin_s"}


def test_design_json_contract(problems_dir, capsys):
    rc = main(["design", str(problems_dir / "paper.toml"), "--json"])
    out = capsys.readouterr()
    assert rc == 0
    d = json.loads(out.out)  # exactly one JSON object
    assert {"problem", "method", "controller", "target_char_poly", "specs", "models",
            "certified", "solver"} <= set(d)
    assert set(d["controller"]) == {"R", "S", "T"}
    assert set(d["specs"]) >= {"Ms_max", "Mt_max", "Mu_max", "stable_controller"}
    # every certified spec is in the contract (the band bound was missing)
    assert d["specs"]["T_resonance_max"] == 1.0 and d["specs"]["resonance_band_hz"] == [560.0, 680.0]
    assert d["specs"]["stable_controller"] is False
    assert d["certified"] is True
    for m in d["models"]:
        assert MODEL_KEYS <= set(m)
        assert m["stable"] is True
    # S has the integrator; static gain of the tracking loop is 1
    assert d["controller"]["S"][-1] == 0.0
    assert out.err == ""  # --json is quiet


def test_design_table(problems_dir, capsys):
    assert main(["design", str(problems_dir / "paper.toml")]) == 0
    out = capsys.readouterr().out
    assert "Ms" in out and "T28C" in out and "certified: True" in out


def test_errors_are_one_line_without_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[plant]\nname = "paper"\n[poles]\nwn = 600.0\nzeta = 1.0\nwobble = 1\n')
    r = subprocess.run([sys.executable, "-m", "robrst", "design", str(bad)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert "bad.toml: [poles.wobble] unknown key" in lines[0]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper_robust_continuous", "repro:relaxed_band_reported_infeasible.toml"])
def test_design_json_stdout_is_only_json_from_a_real_process(name, repro_dir):
    """IPOPT prints from C straight to file descriptor 1: only a real process shows whether
    anything but the JSON object reaches stdout (an NLP design, and one IPOPT struggles with)."""
    target = str(repro_dir / name[6:]) if name.startswith("repro:") else name
    r = subprocess.run([sys.executable, "-m", "robrst", "design", target, "--json"],
                       capture_output=True, text=True)
    assert r.returncode in (0, 1), r.stderr
    d = json.loads(r.stdout)                      # the whole of stdout is one JSON object
    assert d["solver"]["name"] == "ipopt" and r.returncode == (0 if d["certified"] else 1)


def test_closed_output_pipe_is_one_line_not_a_traceback():
    """`robrst design ... --json | head`: the reader leaves early; one line, exit 2."""
    p = subprocess.Popen([sys.executable, "-m", "robrst", "design", "paper", "--json"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait() == 2
    assert err.strip().splitlines() == [
        "robrst: error: the output was closed before robrst finished writing it"]


def test_a_continuous_design_does_not_import_scipy(tmp_path):
    """scipy.linalg costs about 0.3 s CPU to import (it pulls numpy's lazy submodules in);
    a design without a sampled loop or time-domain specs never needs it, so the command
    must not pay for it (the import is deferred to the kernels that use it).  The default
    overshoot bound is a time-domain spec (its step figures need scipy): switched off here;
    and the local run (``--starts 0``): the global phase's answer has closed-loop poles
    damped below 0.46, whose overshoot the assessment then computes (scipy)."""
    src = (Path(__file__).resolve().parents[2] / "problems" / "paper_robust_continuous.toml")
    text = src.read_text("utf-8").replace("[specs]\n", "[specs]\novershoot_max_pct = false\n")
    text = text.replace('compare_with = "paper.toml"', f'compare_with = "{src.parent / "paper.toml"}"')
    f = tmp_path / "continuous.toml"
    f.write_text(text, "utf-8")
    code = ("import sys\nfrom robrst.cli import main\n"
            f"rc = main(['design', {str(f)!r}, '--json', '--starts', '0'])\n"
            "print([m for m in sys.modules if m.split('.')[0] == 'scipy'], file=sys.stderr)\n"
            "sys.exit(rc)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["certified"] is True
    assert r.stderr.strip().splitlines()[-1] == "[]"
    # a local run's answer says it is one (the global phase is the default)
    assert LOCAL_RUN_NOTE in json.loads(r.stdout)["solver"]["notes"]


def test_numpy_warnings_never_print_raw(monkeypatch, capsys):
    """An overflow inside a command that answers (exit 0/1) is one ``robrst: note:`` line,
    not numpy's two-line warning; a command that fails prints only its error line."""
    import numpy as np

    import robrst.cli._check

    def overflowing(args, code=1):
        np.float64(1e308) * np.float64(10.0)    # RuntimeWarning: overflow
        return code

    monkeypatch.setattr(robrst.cli._check, "run_check", overflowing)
    assert main(["check", "paper", "--golden", "g.toml"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("robrst: note: 1 floating-point warning"), err

    def failing(args):
        overflowing(args)
        raise SpecError("x.toml: [a] bad")

    monkeypatch.setattr(robrst.cli._check, "run_check", failing)
    assert main(["check", "paper", "--golden", "g.toml"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == ["robrst: error: x.toml: [a] bad"]


def test_negative_numbers_in_exponent_form_are_values(tmp_path, capsys):
    """`export --u-range -1e9 1e9`: argparse took -1e9 for an option ("expected 2
    arguments"); -1000000000 worked."""
    out = tmp_path / "c.json"
    assert main(["export", "paper", "--fs", "20000", "--u-range", "-1e9", "1e9", "--out",
                 str(out), "--quiet"]) == 0
    aw = json.loads(out.read_text())["anti_windup"]
    assert (aw["u_min"], aw["u_max"]) == (-1e9, 1e9)
    capsys.readouterr()
