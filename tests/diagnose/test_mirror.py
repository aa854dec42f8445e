"""The measured fine-steering mirror, end to end with robrst's commands
(``benchmarks.mirror --quick``: 2 realizations per training level, 1 held out), on the
project's compact copy of those realizations (``tests/realdata/fsm_quick``, float32; the
full set is not needed), so it runs in any clone.

Published reference (README of the data): the order-28 linear model fitted on 100 mV
misses 32.71 % at 300 mV.  The issue's goal: name the amplitude-dependent cause and bring
the 300 mV held-out error under 10 % with the effect fitted on 100 + 200 mV only.
"""

import json

from benchmarks.mirror import QUICK_DATA, run

DATA = QUICK_DATA


def test_mirror_cause_named_and_held_out_error_under_ten_percent(tmp_path):
    s = run(DATA, tmp_path / "mirror", quick=True)
    assert 0.28 < s["linear_100mV_at_300mV"] < 0.38           # published 32.71 %
    assert s["cause"] == "hysteresis", s["reason"]
    assert s["with_effect_at_300mV"] < 0.10
    assert s["with_effect_at_300mV"] < 0.5 * s["linear_refit_100_200mV_at_300mV"]
    assert s["gap_ratio_over_levels"] > 3.0 and abs(s["level_ratio"] - 3.0) < 0.05
    d = json.loads((tmp_path / "mirror" / "diagnosis.json").read_text())
    assert d["data"]["inputs"] == 3 and d["data"]["outputs"] == 3
    assert d["skipped"].keys() >= {"thermal_drift", "thermal_dynamics"}   # no temperature
    assert (tmp_path / "mirror" / "mirror.md").read_text().count("|") > 10
