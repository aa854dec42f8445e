"""Diagnoses of the withheld cases, computed once per session: the tests of the stated
answers (test_withheld*.py) and of the confident-wrong rate (test_confident_wrong.py) share
them."""

import pytest

from diagnosis_cases import make
from robrst.diagnose import diagnose
from robrst.diagnose.validation import make_case


@pytest.fixture(scope="session")
def withheld():
    """``get(kind, name, seed) -> (Diagnosis, truth, case)``; ``kind`` is ``"twin"`` (one
    hidden twin effect, :func:`robrst.diagnose.validation.make_case`) or ``"hard"``
    (:mod:`diagnosis_cases`)."""
    cache = {}

    def get(kind, name, seed):
        key = (kind, name, seed)
        if key not in cache:
            if kind == "twin":
                train, test, truth = make_case(name, seed)
                cache[key] = (diagnose(train, test), truth, None)
            else:
                train, test, model, case = make(name, seed)
                cache[key] = (diagnose(train, test, plant=model), None, case)
        return cache[key]

    return get
