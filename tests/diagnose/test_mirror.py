"""The measured fine-steering mirror end to end with robrst's own commands and defaults
(``benchmarks.mirror --quick`` on the compact copy: one realization per level).

Identify a linear model on 100 mV, then diagnose with training on 100 + 200 mV and the
300 mV record held out: the cause must be amplitude-dependent (the published order-28
linear model fitted on 100 mV misses 300 mV by 32.71 %) and the 300 mV held-out error
under 10 %.  With training on 100 mV only, the answer must say that the gap grows with the
level, name the candidates and ask for a second training level.
"""

import json

import pytest

from benchmarks.mirror import AMPLITUDE_CAUSES, run
from mirror_data import mirror_data_dir

DATA = mirror_data_dir()
pytestmark = pytest.mark.skipif(DATA is None, reason="no mirror data in this checkout")


@pytest.fixture(scope="module")
def mirror(tmp_path_factory):
    out = tmp_path_factory.mktemp("mirror")
    return run(DATA, out, quick=True), out


@pytest.mark.slow
def test_two_levels_name_the_amplitude_dependence_under_ten_percent(mirror):
    s, out = mirror
    head = next(r for r in s["splits"] if r["train_mV"] == [100, 200])
    assert 0.28 < head["gap_before"] < 0.38                      # published 32.71 %
    assert head["cause"] in AMPLITUDE_CAUSES, head["reason"]
    assert head["gap_after"] < 0.10
    assert head["gap_after"] < 0.5 * head["linear_refit"]
    assert head["gap_ratio"] > 3.0 and abs(head["level_ratio"] - 3.0) < 0.05
    d = json.loads((out / "100+200_to_300.json").read_text())
    assert d["data"]["inputs"] == 3 and d["data"]["outputs"] == 3
    assert d["skipped"].keys() >= {"thermal_drift", "thermal_dynamics"}   # no temperature
    assert (out / "mirror.md").read_text().count("|") > 10


@pytest.mark.slow
def test_one_level_says_the_gap_grows_and_asks_for_a_second_level(mirror):
    s, _ = mirror
    one = next(r for r in s["splits"] if r["train_mV"] == [100])
    assert one["cause"] != "linear"
    assert one["ok"], one["reason"]
    assert "second training level" in one["reason"] and "candidates:" in one["reason"]
