"""A back-off that runs away never replaces the polish it started from.

A polish that ends just outside the specs is solved again with its bounds tightened by the
miss (the back-off).  From there IPOPT can run away: on the seeded 4th-order stage 722 at
``Ms_max`` 2.5 (default settings otherwise) the best candidate of the search (global run 6,
screened at 1,036 k) polishes to 1,096 k, 0.8 % outside the specs, and its back-off ends
at an unstable loop.  When the back-off's end was kept, the walk back from it found nothing
above the candidate, the basin was lost and the design answered 1,062,286, 2.3 % below the
tighter problem's 1,087,790 at ``Ms_max`` 2.25 (measured 2026-12-07).  The nearest of the
polish's end and its back-offs is kept: walked back from the 0.8 % miss, 1,089,437.

Truth stated before the change: at 2.5 the answer is at least 99 % of the answer at 2.25
(a looser bound never answers worse, issue 40's monotone property).
"""

import pytest

from robrst.certificate.proof import certify_problem
from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.problem.records import with_defaults

from stages_global import stage_doc

TOL = 0.01


def _design(ms):
    doc = stage_doc(722, order=4, ms=ms)
    problem = parse_problem(doc, f"<stage 722, Ms {ms}>")
    return problem, run_problem(problem, analyses=False)


@pytest.mark.slow
def test_a_looser_bound_keeps_the_basin_a_runaway_back_off_would_lose():
    _, tight = _design(2.25)
    loose_problem, loose = _design(2.5)
    assert tight.certified and loose.certified
    assert loose.integral_gain >= (1.0 - TOL) * tight.integral_gain, (
        loose.integral_gain, tight.integral_gain)
    # the tighter design is a controller of the looser problem too: the looser answer is
    # not far below it (robrst's certificate on the looser problem)
    assert certify_problem(with_defaults(loose_problem), tight.controller).certified
