"""One declaration per spec: every list of specs in the package is the spec table's.

The table (:mod:`robrst.problem.specs`) against the records it describes (the fields of
``Specs``, in order), the problem-file schema, the certificate's bound tables, the
program's blocks, the multi-start's scaled bounds, the design JSON's ``specs`` and the
sweep's columns — each compared with the literal list it replaced (as it stood before the
table; a new spec appears in all of them or in none).
"""

from dataclasses import fields, replace

import pytest

from robrst.certificate.figures import LoopFigures
from robrst.certificate.models import BOUNDED, FIGURE_OF, LOWER_BOUNDED
from robrst.design.achieved import SPEC_FIGURES
from robrst.design.contract import specs_json
from robrst.problem.files import SCHEMA, load_problem
from robrst.problem.records import Specs
from robrst.problem.specs import (EXTRA_PEAK_SPECS, PEAK_SPECS, RELATIVE_PEAK_SPECS, SPEC_TABLE,
                                  spec_columns)
from robrst.synthesis.multistart import PEAK_BOUNDS
from robrst.synthesis._nlp import PEAK_KEYS


def test_the_table_is_the_specs_record():
    # then the record's bookkeeping of the default specs (robrst.problem.records.with_defaults)
    assert [s.key for s in SPEC_TABLE] + ["off", "defaults", "resolved"] == [
        f.name for f in fields(Specs)]
    assert list(SCHEMA["specs"]) == [s.key for s in SPEC_TABLE]
    for s in SPEC_TABLE:       # the record's default is the schema's
        assert getattr(Specs(), s.key) == s.field.default or (
            s.field.default is None and getattr(Specs(), s.key) is None), s.key


def test_every_bounded_figure_is_a_loop_figure_and_every_block_a_program_block():
    names = {f.name for f in fields(LoopFigures)} | {"overshoot_pct", "settling_time_s",
                                                      "step_u_peak_V"}
    for s in SPEC_TABLE:
        if s.bound is not None and s.loops:
            assert s.figure in names, s.key
        assert s.program is None or s.program in PEAK_KEYS, s.key
        assert s.label or s.bound is None, s.key


def test_the_derived_tables_equal_the_lists_they_replaced():
    old_bounded = (("Ms", "Ms_max"), ("Mt", "Mt_max"), ("Mu", "Mu_max"),
                   ("Mt_resonance_band", "T_resonance_max"), ("Mu_hf", "Mu_hf_max"),
                   ("overshoot_pct", "overshoot_max_pct"),
                   ("settling_time_s", "settling_time_max_s"),
                   ("step_u_peak_V", "step_u_max_V"), ("Msd", "Msd_max"), ("Mry", "Mry_max"))
    assert BOUNDED == old_bounded + (("Msd_rel", "Msd_rel_max"),)
    assert LOWER_BOUNDED == (("damping", "damping_min"), ("decay_rad_s", "decay_min"))
    old_figure_of = {"|S| peak": "Ms", "|T| peak": "Mt", "|U| peak": "Mu",
                     "|T| in resonance band": "Mt_resonance_band", "|U| above corner": "Mu_hf",
                     "|B S/Delta| peak": "Msd", "|B T/Delta| peak": "Mry",
                     "closed-loop damping": "damping",
                     "closed-loop decay rate [rad/s]": "decay_rad_s"}
    assert old_figure_of.items() <= FIGURE_OF.items()
    assert PEAK_SPECS == {"S": "Ms_max", "T": "Mt_max", "U": "Mu_max"}
    assert EXTRA_PEAK_SPECS == {"Sd": "Msd_max", "Tr": "Mry_max"}
    assert RELATIVE_PEAK_SPECS == {"Sd": "Msd_rel_max"}
    assert PEAK_BOUNDS == ("Ms_max", "Mt_max", "Mu_max", "T_resonance_max", "Mu_hf_max",
                           "Msd_max", "Mry_max", "Msd_rel_max")
    assert {k for k, _, _ in SPEC_FIGURES} == {k for _, k in BOUNDED + LOWER_BOUNDED}
    assert [r.column for r in spec_columns()] == ["Ms", "Mt", "Mu", "Mt_band"]
    assert [r.column for r in spec_columns(Specs(Msd_rel_max=1.0))][-1] == "Msd_rel"


@pytest.mark.parametrize("changes", [{}, {"Ms_max": None}, {"Msd_max": 3.0, "decay_min": 2.0},
                                     {"controller_damping_min": 0.0},
                                     {"damping_min": 0.0}, {"Msd_rel_max": 1.0}])
def test_bounded_is_any_bound_of_the_table(changes):
    sp = replace(Specs(), **changes)
    keys = ("Ms_max", "Mt_max", "Mu_max", "T_resonance_max", "Mu_hf_max", "Msd_max",
            "Mry_max", "Msd_rel_max", "decay_min", "controller_damping_min")
    expected = (any(getattr(sp, k) is not None for k in keys) or sp.time_domain
                or bool(sp.damping_min))
    assert sp.bounded == expected


def test_the_json_specs_of_the_shipped_problems():
    """The ``specs`` object as the hand-written contract built it (its order included)."""
    sp = load_problem("paper_robust").specs
    assert list(specs_json(sp).items()) == [
        ("Ms_max", 2.0), ("Mt_max", 1.3), ("Mu_max", 150.0), ("stable_controller", False),
        ("sample_rate_hz", 20000.0), ("delay_samples", 0), ("T_resonance_max", 1.0),
        ("resonance_band_hz", [560.0, 680.0]), ("Mu_hf_max", 50.0), ("Mu_hf_above_hz", 2000.0),
        ("overshoot_max_pct", 0.2), ("settling_time_max_s", 0.01), ("step_um", 10.0),
        ("step_u_max_V", 150.0), ("defaults", []), ("defaults_off", [])]
    sp = replace(Specs(), Msd_max=1.0, Mry_max=2.0, damping_min=0.0, Msd_rel_max=0.9)
    assert list(specs_json(sp)) == ["Ms_max", "Mt_max", "Mu_max", "stable_controller",
                                    "Msd_max", "Mry_max", "Msd_rel_max", "damping_min",
                                    "defaults", "defaults_off"]


def test_the_problem_carries_its_resolved_damping_floor():
    p = load_problem("paper")
    assert (p.damping_floor.value, p.damping_floor.source) == p.specs.damping_floor(p.family)
    assert p.damping_floor is p.damping_floor          # resolved once
    q = replace(p, specs=replace(p.specs, damping_min=0.2))
    assert (q.damping_floor.value, q.damping_floor.source) == (0.2, "specs")
