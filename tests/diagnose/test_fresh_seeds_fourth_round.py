"""Fresh seeds of the withheld suite (cases the suite's tests never drew), each answer
stated before the run, and the building block each one exposed.

Run blind (every hidden twin effect and every hard case, seeds 8101-8106): four answers
named an effect outside the truth with confidence —

* ``saturation`` 8105 and 8106 named ``input_nonlinearity``: the lower limit (12.8 V and
  6.2 V) lies below every training input (19.4 V and 15.0 V) and only a held-out record
  reaches it. The fit left the limit at the training records' edge (a limit that clips
  nothing has no gradient), where it clipped the held-out inputs below it: held-out gap
  0.037 and 0.016, against 0.0048 and 0.0019 with the limit out of the records' way;
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
  fitted; fitted, it reaches the floor (0.00084 against 0.0096).
"""

import numpy as np
import pytest

from robrst.data.dataset import Dataset
from robrst.diagnose._effects import Chain, summary


def _chain(U):
    t = np.arange(U.shape[0]) / 5000.0
    rec = Dataset(t=t, u=U, y=np.zeros(U.shape[0]), temp=np.full(U.shape[0], 28.0))
    return Chain(("saturation",), U.shape[1], 5000.0, 28.0, summary([rec]))


def test_a_limit_no_record_reaches_leaves_their_way():
    """``Chain.release_unreached``: a limit at or beyond the records' extreme goes to the
    far end of its bounds; a limit inside them stays; the records' inputs are unchanged
    by either (nothing is clipped)."""
    U = np.column_stack([np.linspace(15.0, 148.0, 400), np.linspace(-20.0, 80.0, 400)])
    ch = _chain(U)
    lo, hi = ch.lower.copy(), ch.upper.copy()
    z = np.array([15.0, 105.0, -25.0, 80.0])      # input 1: lower at the edge; 2: both out
    out = ch.release_unreached(z, [U])
    assert out[0] == lo[0] and out[1] == 105.0
    assert out[2] == lo[2] and out[3] == hi[3]
    assert lo[0] < 15.0 - 100.0 and hi[3] > 80.0 + 90.0       # a span beyond the records
    z_in = np.array([16.0, 140.0, -19.0, 79.0])   # every limit clips a few samples: kept
    assert np.array_equal(ch.release_unreached(z_in, [U]), z_in)
    assert np.array_equal(z, [15.0, 105.0, -25.0, 80.0])        # a copy


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
