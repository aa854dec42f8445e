"""A problem built or changed in Python is checked as its problem file would be.

Found by changing one field of a shipped problem's records at a time: ``Specs(Ms_max=nan)``
certified (a NaN bound bounds nothing), a negative ``Ms_max`` or ``cert_tol`` ran to a
silent "not certified", a reversed band or a text value ended in a raw ``ValueError`` or
``TypeError`` deep in a kernel, an unknown method or objective ran as the default.  Each
now ends in robrst's ``SpecError`` naming the table and key, before any work."""

import dataclasses
import numpy as np
import pytest

from robrst import SpecError, load_problem, run_problem
from robrst.problem.documents import check_problem

CASES = [
    ("specs", dict(Ms_max=float("nan")), "specs.Ms_max"),
    ("specs", dict(Ms_max=-1.0), "specs.Ms_max"),
    ("specs", dict(Ms_max="x"), "specs.Ms_max"),
    ("specs", dict(resonance_band_hz=(800.0, 500.0), T_resonance_max=1.0),
     "specs.resonance_band_hz"),
    ("specs", dict(sample_rate_hz="fast"), "specs.sample_rate_hz"),
    ("specs", dict(damping_min=2.0), "specs.damping_min"),
    ("poles", dict(zeta=float("nan")), "poles.zeta"),
    ("controller", dict(extra_degree=1.5), "controller.extra_degree"),
    ("controller", dict(S_fixed=()), "controller.S_fixed"),
    ("solver", dict(method="foo"), "solver.method"),
    ("solver", dict(objective="foo"), "solver.objective"),
    ("solver", dict(cert_tol=-1.0), "solver.cert_tol"),
    ("solver", dict(cert_temperatures=-3), "solver.cert_temperatures"),
]


@pytest.fixture(scope="module")
def paper():
    return load_problem("paper")


@pytest.mark.parametrize("table,change,key", CASES, ids=[c[2] + "=" + repr(list(c[1].values())[0])
                                                        for c in CASES])
def test_a_bad_record_value_is_refused_naming_its_key(paper, table, change, key):
    bad = dataclasses.replace(paper, **{table: dataclasses.replace(getattr(paper, table),
                                                                    **change)})
    with pytest.raises(SpecError, match=rf"paper.toml \(changed in Python\): \[{key}\]"):
        run_problem(bad, analyses=False)


def test_good_problems_pass_and_keep_their_answer(paper):
    for name in ("paper", "paper_robust", "paper_robust_continuous", "paper_robust_fleet"):
        check_problem(load_problem(name))
    changed = dataclasses.replace(paper, specs=dataclasses.replace(paper.specs, Ms_max=1.9))
    res = run_problem(changed, analyses=False)
    # the bound is stated and holds: |S| = |A S / (A S + B R)| of the unscaled polynomials
    # on a dense grid (numpy only), at or below it
    assert res.certified and res.problem.specs.Ms_max == 1.9
    plant, c = paper.family.reference_model, res.controller
    s = 1j * np.logspace(0, 6, 200_001)
    AS = np.polyval(plant.A, s) * np.polyval(c.S, s)
    sens = np.abs(AS / (AS + np.polyval(plant.B, s) * np.polyval(c.R, s)))
    assert 1.0 < sens.max() <= 1.9 * (1 + 1e-3)


@pytest.mark.parametrize("key", ["Ms_max", "Mu_max", "damping_min"])
def test_a_certificate_of_a_nan_bound_is_refused(paper, key):
    """The certificate itself (certify_problem, also called without run_problem): a NaN
    bound compares false with every figure, so nothing could be violated; it is an error."""
    from robrst import certify_problem, pole_placement

    ctrl = pole_placement(paper.family.reference_model, paper.poles,
                          paper.controller).controller
    bad = dataclasses.replace(paper, specs=dataclasses.replace(paper.specs,
                                                               **{key: float("nan")}))
    with pytest.raises(SpecError, match=rf"\[specs.{key}\] = nan"):
        certify_problem(bad, ctrl)
    assert certify_problem(paper, ctrl).certified


def test_a_family_beyond_the_file_format_is_not_refused_but_its_specs_are_checked():
    """A 14th-order plant at 10-30 Mrad/s: its expanded denominator reaches 8e101, beyond a
    problem file's 1e100 (a format limit, not the plant's): check_problem passes it, and
    still names a NaN bound of its specs."""
    from robrst import Plant, PlantFamily, PoleSpec, Problem, Specs

    A = np.poly(-np.linspace(1e7, 3e7, 14))
    assert np.abs(A).max() > 1e100
    plant = Plant([A[-1]], A, temperature_C=28.0).with_label("n", 28.0)
    pr = Problem("big", PlantFamily(models=(plant,)), poles=PoleSpec(wn=1e6, zeta=1.0),
                 specs=Specs(Ms_max=2.0))
    check_problem(pr)
    with pytest.raises(SpecError, match=r"<python>: \[specs.Ms_max\] expected a finite"):
        check_problem(dataclasses.replace(pr, specs=Specs(Ms_max=float("nan"))))
