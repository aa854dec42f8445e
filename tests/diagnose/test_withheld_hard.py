"""Harder withheld cases (tests/diagnosis_cases.py): several effects at once, closed-loop
records, a wrong linear model, other sampling rates, short and noisy records, effects
outside the library, and the wider library's cases (sensor curvature, Duffing, a
Prandtl-Ishlinskii hysteresis at separate levels, an asymmetric rate limit, two coupled
channels, sensor outliers and dropouts, periodic records shaped like the mirror's).  The
expected answers are stated in the cases, before the run."""

import pytest

from diagnosis_cases import CASES

# parameters the answer must recover when several effects are on (truth in the cases)
RECOVERED = {"hysteresis+creep": ("creep", "per_decade", 0.02, 0.1),
             "creep+thermal_drift": ("thermal_drift", "lag_s", 3.0, 0.3)}


@pytest.fixture(scope="module")
def results():
    return {}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
def test_hard_case_gets_its_stated_answer(name, withheld):
    d, _, case = withheld("hard", name, 0)
    assert d.cause in case.accept, (name, d.reason)
    assert set(case.must_name) <= set(d.causes), (name, d.reason)
    if case.only:                         # nothing else named
        assert set(d.causes) == set(case.must_name), (name, d.reason)
    if d.cause == "cannot_tell":
        for phrase in case.reason_has:
            assert phrase in d.reason, (name, d.reason)
    if d.cause not in ("none", "cannot_tell"):
        assert d.final is not None or d.cause == "linear"
    if case.finding:
        found = [f.details for f in d.findings if f.kind == case.finding]
        assert found, (name, d.reason)
        if case.band_hz:
            lo, hi = found[0]["band_hz"]
            assert lo <= case.band_hz <= hi
            assert min(abs(f - case.band_hz) for f in found[0]["extra_modes_hz"]) < 0.05 * case.band_hz
    if name in RECOVERED:
        effect, key, true, rel = RECOVERED[name]
        got = next(s.params[key] for s in d.selected if s.name == effect)
        assert got == pytest.approx(true, rel=rel), d.selected
    if d.cause == "cannot_tell" and d.best_partial:
        assert d.best_partial.gap_after < d.gap_before


@pytest.mark.slow
@pytest.mark.parametrize("seed", [7001, 7002])
def test_creep_and_drift_on_fresh_seeds_name_nothing_else(seed, withheld):
    """Fresh seeds of the creep + thermal drift case (stated before the run: creep and
    thermal drift, nothing else).  Before: seed 7002 named input nonlinearity third (the
    joint fit of creep and drift stuck where creep had stretched to stand in for the drift,
    and again from the screen on top of creep), seed 7001 an output offset of 0.15 nm (the
    removal's fit stopped at the fits' budget at 2.7x the floor, converged at 1.09x)."""
    d, _, _ = withheld("hard", "creep+thermal_drift", seed)
    assert set(d.causes) == {"creep", "thermal_drift"}, d.reason
    assert d.final is not None and d.final.gap_after < 2.0 * d.noise_floor, d.reason


@pytest.mark.slow
def test_an_offset_only_the_held_out_records_want_is_not_named(withheld):
    """The rate-dependent hysteresis (outside the library) on fresh seed 7007 (stated
    before the run: hysteresis or cannot_tell): it named an output offset of 3.1 µm beside
    hysteresis (held out 0.12 -> 0.065, training only 0.058 -> 0.051), an effect outside
    the truth with 92 % of the gap removed.  A sensor zero is in the training records
    alike: without their need of it, it is not named."""
    d, _, case = withheld("hard", "rate_dependent_hysteresis", 7007)
    assert d.cause in case.accept, d.reason
    assert "output_offset" not in d.causes, d.reason
