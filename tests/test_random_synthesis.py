"""Random problems: every one a simple controller solves must certify (>= 95 %), and every
problem gets an answer (a controller and a status; never only a raw solver status).

``GENERATOR`` is the problem generator: :func:`random_synthesis.local_problem` here; the
reliability suite's generator plugs in the same way (``gen(rng) -> Problem``).  The
default run takes a few problems; ``pytest -m large`` runs the sample whose table is in
the README ("Synthesis on random problems").
"""

import pytest

from random_synthesis import evaluate, local_problem, table

GENERATOR = local_problem
LARGE_N, LARGE_SEED = 100, 7


def test_a_few_random_problems_certify_and_answer():
    cases = evaluate(GENERATOR, 6, seed=3, only_solvable=False, indices=(0, 3, 4, 5))
    assert cases
    assert all(c.answer for c in cases), [c for c in cases if not c.answer]
    solvable = [c for c in cases if c.known]
    assert all(c.status == "certified" for c in solvable), solvable


@pytest.mark.large
def test_random_sample_certifies_95_percent():
    cases = evaluate(GENERATOR, LARGE_N, seed=LARGE_SEED, only_solvable=False)
    print("\n".join(table(cases)))
    assert all(c.answer for c in cases), [c for c in cases if not c.answer]
    solvable = [c for c in cases if c.known]
    rate = sum(c.status == "certified" for c in solvable) / len(solvable)
    assert rate >= 0.95, (rate, [c for c in solvable if c.status != "certified"])
