"""Monotone answers: loosening a bound never returns a worse certified objective.

With default settings (``run_problem`` as the command line runs it: global phase, default
specs) ``Ms_max`` is scanned from 1.5 to 2.5 on seeded stages (every certified answer's
controller poles inside the program's strip, by numpy's roots): the certified integral gain
never decreases by more than 1 % as the bound loosens, and no design made for a tighter
bound certifies on a looser problem (robrst's certificate with the time-domain figures,
and the independent python-control check of its figures) with an objective more than 1 %
above that problem's own answer.
"""


import numpy as np
import pytest

from robrst.certificate.proof import certify_problem
from robrst.certificate.completion import with_time_domain
from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.problem.records import with_defaults

from stages_global import stage_doc

VALUES = (1.5, 1.75, 2.0, 2.25, 2.5)
TOL = 0.01


def _slowest_controller_pole(ctrl):
    """|Re| of the controller's slowest pole, its integrators aside (numpy's roots)."""
    S = np.trim_zeros(np.asarray(ctrl.S, float), "b")
    return float(-np.max(np.roots(S).real))


def _scan(doc):
    out = []
    for v in VALUES:
        d = {**doc, "specs": {**doc["specs"], "Ms_max": v}}
        p = parse_problem(d, f"<Ms {v}>")
        r = run_problem(p, analyses=False)
        if r.certified:     # the program's strip: 0.1 x the slowest dominant pole
            edge = 0.1 * float(np.min(np.abs(p.poles.dominant())))
            assert _slowest_controller_pole(r.controller) >= 0.98 * edge, (v, edge)
        out.append((v, p, r, r.integral_gain if r.certified else None))
    return out


def _on(problem, ctrl):
    p = with_defaults(problem)
    cert = certify_problem(p, ctrl)
    return with_time_domain(p, cert, ctrl) if p.specs.time_domain else cert


@pytest.fixture(scope="module")
def scans():
    """The scans of the seeded stages, each computed once for the module's two tests."""
    done = {}

    def of(seed, order):
        if (seed, order) not in done:
            done[seed, order] = _scan(stage_doc(seed, order=order))
        return done[seed, order]
    return of


COLLAPSE = 0.9     # the weaker property that holds: never 10 % below a tighter answer


@pytest.mark.slow
@pytest.mark.parametrize("seed,order", [(11, 2), (12, 2)])
def test_a_looser_bound_never_collapses(scans, seed, order):
    """The weaker property the global phase now has: loosening Ms_max never returns less
    than 90 % of a tighter bound's certified answer (before the screen checked the sampled
    loops' steps and refused candidates were moved inside the specs, stage 11 at Ms 2.25
    answered 16,574 against 473,458 at 2.0: 29x below; before each run's best was
    polished, 627 k at Ms 2.0 against 773 k at 1.75)."""
    scan = scans(seed, order)
    best = None
    for v, _, _, ki in scan:
        assert ki is not None, v
        if best is not None:
            assert ki >= COLLAPSE * best, (v, ki, best)
        best = ki if best is None else max(best, ki)


@pytest.mark.slow
@pytest.mark.parametrize("seed,order", [
    (11, 2), (12, 2), (13, 4), (102, 4), (204, 4)])
def test_ms_scan_is_monotone(scans, seed, order):
    """Stage 102 (4th order): at Ms_max 2.25 a polish ended at IPOPT's acceptable level with
    a controller pole at 28 rad/s, half the strip's edge, and won with 298 k against 231 k at
    2.5 (certified there too); counted only inside the strip, 224 k.  Stage 204 (4th order,
    blind until the polishes that end outside the specs were walked back): 217 k / 406 k /
    406 k / 501 k / 473 k before, 217 k / 473 k / 532 k / 585 k / 589 k since, 300 k / 510 k
    / 537 k / 565 k / 584 k once a refused candidate is moved inside on a screen with the
    refusal's frequencies.  Stage 11 (2nd order): 753 k / 828 k / 818 k / 828 k / 828 k
    (1.2 % lost at 2.0: the best candidate's polish ended certified with a controller pole
    10 % outside the strip, its gain not counted) until such a polish is walked back inside
    the strip: 825 k at 2.0.  Stage 13 (4th order): 115 k / 200 k / 270 k / 262 k / 201 k
    while which basin the restarts found still moved with the bound (at 2.5 the search
    reached the upper one in 5 of 20 seeded runs); 132 k / 218 k / 270 k / 276 k / 283 k
    once a polish that gains nothing from the screen's boundary runs again from inside the
    specs and a refused candidate is moved inside (measured 2026-12-03); 132 k / 223 k /
    270 k / 302 k / 283 k once the answer was polished again from where its polish ended
    (2026-12-04: 2.25 gained, 2.5 did not; an expected failure), 132 k / 218 k / 270 k /
    305 k / 304 k since that re-polish starts on the grid its answer's polish reached
    (monotone within 1 % again).  Stage 204 since then: 357 k / 510 k / 565 k / 575 k."""
    scan = scans(seed, order)
    print(f"\nstage {seed}: " + ", ".join(f"{v}: {ki}" for v, _, _, ki in scan))
    best = None
    for v, p, r, ki in scan:
        if best is not None:
            assert ki is not None and ki >= best * (1 - TOL), (v, ki, best)
        if ki is not None:
            best = ki if best is None else max(best, ki)
    for i, (_, _, r_t, ki_t) in enumerate(scan):     # a tighter design on a looser problem
        if ki_t is None:
            continue
        for _, p_l, _, ki_l in scan[i + 1:]:
            if ki_t > ki_l * (1 + TOL):
                assert not _on(p_l, r_t.controller).certified, (ki_t, ki_l)
