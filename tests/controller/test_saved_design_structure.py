"""A saved design is checked against its problem's structure, and every command reads a
``.json`` argument as JSON (fourth reliability round, ``tests/repro/turn4/``).

* ``a_good.json`` edited to ``S(0) = 12345`` (no integrator) was certified by ``certify`` and
  ``export`` with ``integral_gain`` 31,263.96 (``R(0)/S[-2]``, as if ``S(0)`` were 0): now not
  certified, the reason named, the integral gain 0 (its definition ``lim s R/S``);
* its first 5000 bytes were "invalid TOML" for ``export`` and "not valid JSON" for
  ``certify``: "not valid JSON" for every command;
* ``certify D.json --problem OTHER`` printed the saved design's multi-start line under
  OTHER's name;
* ``check --update`` wrote "96 figures" and the next ``check`` read "98 figures".

Independent checks: the integral gain as the limit of ``s R(s)/S(s)`` in 60-digit mpmath.
"""

import json

import mpmath
import numpy as np
import pytest

from robrst.certificate._structure import structure_violations
from robrst.cli import main
from robrst.controller.artefact import load_design
from robrst.core import poly
from robrst.core.rst import RSTController, as_controller
from robrst.problem.records import ControllerStructure
from robrst.synthesis.parametrize import integral_gain


@pytest.fixture(scope="module")
def good(repro_dir):
    return repro_dir / "turn4" / "a_good.json"


def _edited(good, tmp_path, S0=12345.0):
    doc = json.loads(good.read_text())
    doc["controller"]["S"][-1] = S0
    path = tmp_path / "D_S_noint.json"
    path.write_text(json.dumps(doc))
    return path


def _limit_s_R_over_S(ctrl, s=mpmath.mpf("1e-40")):
    """``s R(s)/S(s)`` at a tiny ``s`` in 60-digit arithmetic: the limit at 0."""
    def horner(c):
        out = mpmath.mpf(0)
        for a in c:
            out = out * s + mpmath.mpf(float(a))
        return out

    with mpmath.workdps(60):
        return float(s * horner(ctrl.R) / horner(ctrl.S))


def test_integral_gain_is_the_limit_of_s_R_over_S(good, tmp_path):
    res = load_design(good)
    assert res.certified
    truth = _limit_s_R_over_S(res.controller)
    assert res.integral_gain == pytest.approx(truth, rel=1e-12)
    assert res.as_dict()["integral_gain"] == pytest.approx(truth, rel=1e-12)
    bad = load_design(_edited(good, tmp_path))
    assert _limit_s_R_over_S(bad.controller) == pytest.approx(0.0, abs=1e-20)
    assert bad.integral_gain == 0.0 and bad.as_dict()["integral_gain"] == 0.0


@pytest.mark.slow
def test_a_controller_without_the_integrator_is_not_certified(good, tmp_path, capsys):
    path = _edited(good, tmp_path)
    res = load_design(path)
    assert not res.certified
    kinds = [v.kind for v in res.certificate.violations]
    assert "structure" in kinds
    why = next(v.describe() for v in res.certificate.violations if v.kind == "structure")
    assert "S lacks the integrator s" in why and "12345" in why and "S_fixed" in why
    # the peaks are still the saved controller's: only the structure fails
    assert all(k == "structure" for k in kinds)
    assert main(["certify", str(path), "--quiet"]) == 1
    out, err = capsys.readouterr()
    assert "integral gain 0 " in out and "lacks the integrator" in err
    assert main(["export", str(path), "--quiet", "--out", str(tmp_path / "x.json")]) == 1
    exported = json.loads((tmp_path / "x.json").read_text())
    assert exported["certificate"]["certified"] is False
    capsys.readouterr()


def test_a_truncated_design_is_not_valid_json_for_every_command(good, tmp_path, capsys):
    path = tmp_path / "D_truncated.json"
    path.write_bytes(good.read_bytes()[:4000])
    for cmd in (["export", str(path)], ["certify", str(path)], ["design", str(path)],
                ["check", str(path), "--golden", str(tmp_path / "g.toml"), "--update"],
                ["report", str(path), "--out", str(tmp_path / "r")]):
        assert main(cmd) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "not valid JSON" in err[0] and "TOML" not in err[0], (cmd, err)


def test_certify_on_another_problem_drops_the_saved_problems_records(good, repro_dir,
                                                                    capsys):
    other = repro_dir / "turn4" / "a_ms2.0.toml"
    assert main(["certify", str(good), "--problem", str(other), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["problem"] == "a_ms2.0" and "starts" not in d and "analytic_check" not in d
    assert d["solver"]["designed_on"] == "a_good"
    assert main(["certify", str(good), "--problem", str(other)]) == 0
    out = capsys.readouterr().out
    assert "multi-start" not in out and "IPOPT" not in out
    # on its own problem the saved records are kept
    assert main(["certify", str(good)]) == 0
    assert "multi-start: 3 starts" in capsys.readouterr().out


def test_check_update_and_check_count_the_same_figures(good, tmp_path, capsys):
    golden = tmp_path / "g.toml"
    assert main(["check", str(good), "--golden", str(golden), "--update", "--quiet"]) == 0
    wrote = capsys.readouterr().out
    assert main(["check", str(good), "--golden", str(golden), "--quiet"]) == 0
    read = capsys.readouterr().out
    n_w = int(wrote.split(": ", 1)[1].split()[0])
    n_r = int(read.split("(", 1)[1].split()[0])
    assert n_w == n_r == 98, (wrote, read)
    for text in (wrote, read):       # and what the figures are
        assert "96 model figures over 8 models, certified = true and the objective" in text


def test_structure_violations_find_each_missing_factor():
    """The roll-off and R_fixed too; a factor present within rounding is present."""
    wc = 2 * np.pi * 5000.0
    st = ControllerStructure(S_fixed=(1.0, 0.0), R_fixed=(1.0, 300.0), roll_off_order=2,
                             roll_off_hz=5000.0)
    Sp = np.array([1.0, 4000.0, 2e7])
    S = np.convolve(st.S_total, Sp)
    R = np.convolve([1.0, 300.0], [2.0, 5e3])
    ok = RSTController(R, S, [1.0])
    assert structure_violations(st, ok) == []
    no_roll = RSTController(R, np.convolve([1.0, 0.0], np.convolve([1 / wc, 1.0], Sp)), [1.0])
    (v,) = structure_violations(st, no_roll)
    assert v.kind == "structure" and "not divisible" in v.quantity and "roll-off" in v.quantity
    no_rfix = RSTController(np.convolve([1.0, 301.0], [2.0, 5e3]), S, [1.0])
    (v,) = structure_violations(st, no_rfix)
    assert "R is not divisible" in v.quantity and "R_fixed" in v.quantity
    no_int = RSTController(R, S + np.r_[np.zeros(len(S) - 1), 1e-3 * abs(S).max()], [1.0])
    assert [v.quantity.split(":")[1].strip()[:16] for v in
            structure_violations(st, no_int)] == ["S lacks the inte"]


def test_an_integrator_within_rounding_is_an_integrator(good):
    """A controller read back from a discrete python-control transfer function has
    S(0) = -4e-16, not 0: the rounding of an integrator (its gain is the limit computed from
    the exact controller), not a missing one."""
    import control

    ctrl = load_design(good).controller
    back = as_controller(control.tf(ctrl.to_control(25000.0)))
    assert back.S[-1] != 0.0 and poly.origin_roots(back.S) == 1
    assert structure_violations(ControllerStructure(), back) == []
    assert integral_gain(back) == pytest.approx(integral_gain(ctrl), rel=1e-6)
    assert poly.origin_roots([1.0, 3.0, 1e-6]) == 0 and poly.origin_roots([1.0, 0.0, 0.0]) == 2
