"""Fresh seeds of the withheld suite (cases the suite's tests never drew), each answer
stated before the run, and the building block each one exposed.

Run blind (every hidden twin effect and every hard case, seeds 8101-8106): four answers
named an effect outside the truth with confidence —

* ``saturation`` 8105 and 8106 named ``input_nonlinearity``: the lower limit (12.8 V and
  6.2 V) lies below every training input (19.4 V and 15.0 V) and only a held-out record
  reaches it. The fit left the limit at the training records' edge (a limit that clips
  nothing has no gradient), where it clipped the held-out inputs below it: held-out gap
  0.037 and 0.016, against 0.0048 and 0.0019 with the limit out of the records' way
  (8109, of the next fresh seeds, ended it just inside them: the first test below).
  Seed 0 (not a seed the suite's tests draw, run beside them) was the same, and once the
  limit left the records' way it came back ``cannot_tell``: a tie of saturation (held out
  0.031, its test sine 6 V below the lower limit) and a static output curve (0.044), which
  leaves 240x the floor on the training records where saturation reaches it. A slot is
  now tied only when neither the held-out nor the training records settle it;
* ``gain_change`` 8103 named ``creep`` (69 % of the gap): hysteresis explains the
  training records to their noise floor (0.00039) but not the held-out ones (0.42, their
  gain is 20 % higher); creep explains the held-out ones better (0.26) and the training
  ones to 0.19. The two sets disagree, and no candidate explains why;
* ``creep+thermal_drift`` seed 1 (run beside the suite's seed 0) named a third cause, a
  static input map of 1e-5/V: without it the set's fit was the selection's earlier step,
  cached, from the screens' starts (0.0019, five times the floor); from the answer's own
  creep and lag the two reach 0.00039 (floor 0.00039). The removal that decides the
  credit is now fitted from the answer's values too, the better on training kept;
* ``duffing_levels`` 8102 named ``output_nonlinearity``: the stiffening resonance was
  screened fourth, 11 % behind the static output curve, and only three candidates were
  fitted; fitted, it reaches the floor (0.00084 against 0.0096). On the next fresh seeds
  (8107-8110) ``hysteresis+creep`` 8107 and 8110 named hysteresis alone (103x and 33x the
  floor left): creep on top of it screened at 10x the held-out gap before (its growth
  with temperature linearised and carried to the held-out ramps) while removing 87 % of
  the training gap, and was never fitted. A candidate whose screen explains the training
  records significantly is now fitted when the first ones do not explain them.
"""

import numpy as np
import pytest

from robrst.diagnose.estimate import fit_effects
from robrst.diagnose.validation import make_case


def test_a_limit_the_training_records_do_not_need_leaves_their_way():
    """Saturation 8109 (fresh seed 8107-8110 batch): the lower limit (4.3 V) lies below
    every input, training (from 15.0 V) and held out (from 4.45 V). The fit ended it at
    15.042 V, clipping the lowest training samples by the noise's size (its 1-sigma
    0.0074 V), and the held-out sine below it: 0.060 held out against the floor's 0.0002.
    Kept only where it lowers the sum of squares by more than a parameter's price
    (``ln(n) sigma^2``), it leaves the records' way (1-sigma inf); the upper limit, which
    clips every record, stays (to 0.01 V)."""
    train, test, truth = make_case("saturation", 8109)
    est = fit_effects(train, ["saturation"], joint=True)
    lowest = min(float(d.U.min()) for d in train)
    assert est.params["u_min_V"] < lowest - 50.0 and not np.isfinite(est.std["u_min_V"])
    assert est.params["u_max_V"] == pytest.approx(truth["params"]["u_max"], abs=0.01)
    assert np.isfinite(est.std["u_max_V"])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 8105, 8106])
def test_a_saturation_limit_reached_only_by_held_out_inputs_is_saturation(seed, withheld):
    """Stated before the run: ``saturation`` (nothing else); the upper limit recovered to
    1 %, the lower one not determined by the data (no training input reaches it) and out of
    the training records' way."""
    d, truth, _ = withheld("twin", "saturation", seed)
    assert d.cause == "saturation" and d.causes == ("saturation",), d.reason
    sat = next(s for s in d.selected if s.name == "saturation")
    assert sat.params["u_max_V"] == pytest.approx(truth["params"]["u_max"], rel=0.01)
    train_min = min(r["u_range_V"][0] for r in truth["records"][:2])
    assert sat.params["u_min_V"] < train_min - 50.0
    assert not np.isfinite(sat.params_std["u_min_V"])


@pytest.mark.slow
def test_records_that_disagree_between_sessions_are_not_explained_by_creep(withheld):
    """``gain_change`` 8103 (hysteresis; the test session's gain 20 % higher). Stated
    before the run: hysteresis or ``cannot_tell`` (it was ``creep``), the reason naming
    the disagreement."""
    d, _, case = withheld("hard", "gain_change", 8103)
    assert d.cause in case.accept, d.reason
    assert "creep" not in d.causes
    if d.cause == "cannot_tell":
        assert "explains the training records to their noise floor" in d.reason, d.reason


@pytest.mark.slow
def test_a_stiffening_resonance_screened_fourth_is_fitted(withheld):
    """``duffing_levels`` 8102: stated before the run, ``stiffness_nonlinearity`` and
    nothing else, near the floor (it was ``output_nonlinearity``, 11.7x the floor)."""
    d, _, _ = withheld("hard", "duffing_levels", 8102)
    assert d.causes == ("stiffness_nonlinearity",), d.reason
    assert d.final.gap_after < 1.5 * d.noise_floor, d.reason
    assert any(e.startswith("fitted beyond the screen's first") for e in d.selection)


@pytest.mark.slow
def test_creep_and_drift_seed_1_name_nothing_else(withheld):
    """Stated before the run: exactly creep and thermal drift, near the floor."""
    d, _, _ = withheld("hard", "creep+thermal_drift", 1)
    assert set(d.causes) == {"creep", "thermal_drift"}, d.reason
    assert d.final.gap_after < 1.5 * d.noise_floor, d.reason


@pytest.mark.slow
@pytest.mark.parametrize("seed", [8107, 8110])
def test_creep_screened_badly_held_out_is_fitted_on_top_of_hysteresis(seed, withheld):
    """Stated before the run: hysteresis and creep, near the floor (it was hysteresis
    alone, 103x and 33x the floor left)."""
    d, _, _ = withheld("hard", "hysteresis+creep", seed)
    assert set(d.causes) == {"hysteresis", "creep"}, d.reason
    assert d.final.gap_after < 1.5 * d.noise_floor, d.reason
