"""Problem files of the fourth reliability round (``tests/repro/turn4/``): a spec that can
never bind and a truncation with no probability are refused in one line; an unknown key's
line names the nearest key, not all of them."""

import pytest

from robrst.problem.files import SCHEMA
from robrst.base.errors import SpecError
from robrst.cli import main
from robrst.problem.files import load_problem


def test_an_overshoot_bound_above_100_pct_is_refused(repro_dir, capsys):
    path = repro_dir / "turn4" / "bad_overshoot150.toml"
    assert main(["design", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"robrst: error: {path}: [specs.overshoot_max_pct] expected number >= 0"
                   " and <= 100 (or false: off), got 150.0"]


def test_an_unknown_key_names_the_nearest_key_only(repro_dir, tmp_path):
    text = (repro_dir / "turn4" / "bad_overshoot150.toml").read_text()
    bad = tmp_path / "p.toml"
    bad.write_text(text.replace("overshoot_max_pct = 150.0", "overshot_max_pct = 50.0"))
    with pytest.raises(SpecError) as e:
        load_problem(bad)
    msg = str(e.value)
    assert msg == (f"{bad}: [specs.overshot_max_pct] unknown key; did you mean"
                   " 'overshoot_max_pct'?")
    bad.write_text(text.replace("overshoot_max_pct = 150.0", "zzzqqq = 1.0"))
    n = len(SCHEMA["specs"])
    with pytest.raises(SpecError, match=rf"no key of this table is close \(its {n} keys are in"
                       r" the file's reference\)$"):
        load_problem(bad)
    bad.write_text(text.replace("[poles]", "[poles]\nqqqq = 1"))
    with pytest.raises(SpecError, match=r"\[poles.qqqq\] unknown key; expected one of wn, zeta,"):
        load_problem(bad)


def test_a_spread_truncated_where_it_has_no_mass_is_refused(repro_dir, capsys):
    """spread_truncation_no_mass.toml: normal(1, 0.01) truncated to [5, 6] was designed and
    certified with every actuator at gain 6.0; refused as sweep files already were."""
    path = repro_dir / "turn4" / "spread_truncation_no_mass.toml"
    assert main(["design", str(path), "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    (line,) = err.strip().splitlines()
    assert f"{path}: [spread.param.0] the normal (mean 1, std 0.01) has probability 0 in" \
           " [5, 6]" in line and "every draw" in line
