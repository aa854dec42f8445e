"""Which default specs a bounded problem gets depends on its plant: |B S/Delta| <= the open
loop's peak only where there is a resonance to ring (a first-order plant's peak is its static
gain, which integral action below the plant's pole exceeds without ringing)."""

from robrst.problem.files import parse_problem
from robrst.problem.records import with_defaults

SPECS = {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": 50.0}


def _doc(B, A):
    return {"problem": {"name": "p"}, "plant": {"B": B, "A": A, "temperature_C": 25.0},
            "poles": {"wn": 800.0, "zeta": 0.9}, "specs": dict(SPECS),
            "solver": {"method": "analytic"}}


def test_first_order_plant_has_no_relative_disturbance_default():
    sp = with_defaults(parse_problem(_doc([1000.0], [1.0, 2000.0]), "<p1>")).specs
    assert "Msd_rel_max" not in sp.defaults and sp.Msd_rel_max is None
    assert "overshoot_max_pct" in sp.defaults


def test_resonant_plant_has_it():
    # 1e6 / (s^2 + 2 * 0.05 * 1000 s + 1000^2): damping 0.05
    sp = with_defaults(parse_problem(_doc([1e6], [1.0, 100.0, 1e6]), "<p2>")).specs
    assert "Msd_rel_max" in sp.defaults and sp.Msd_rel_max == 1.0


def test_well_damped_pair_has_no_resonance():
    # damping 0.8 > 1/sqrt(2): |B/A| has no peak above its static gain
    sp = with_defaults(parse_problem(_doc([1e6], [1.0, 1600.0, 1e6]), "<p3>")).specs
    assert "Msd_rel_max" not in sp.defaults
