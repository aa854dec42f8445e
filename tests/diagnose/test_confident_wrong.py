"""The confident-wrong rate is zero: on the whole withheld suite (every hidden twin effect
on two seeds, every hard case), no effect outside the truth is named while the answer
claims to remove half of the gap or more (shrink >= 0.5).

The truth of a case is the set of names that are not wrong for it (``validation.ANSWER`` of
the hidden twin effect; ``Case.truths`` of a hard case: e.g. a play operator is a
hysteresis, a sensor drift has no library cause).  The answer's shrink is that of its
held-out gap (``1 - after / before``).
"""

import pytest

from diagnosis_cases import CASES as HARD
from robrst.diagnose.validation import ANSWER, CASES

RUNS = [("twin", c, s) for c in CASES for s in (1, 2)] + [("hard", n, 0) for n in HARD]
DECLINED = ("none", "linear", "cannot_tell")


def _confidently_wrong(d, truth):
    named = set(d.causes) | ({d.cause} if d.cause not in DECLINED else set())
    after = d.gap_after()
    shrink = 1 - after / d.gap_before if after is not None and d.gap_before > 0 else 0.0
    return sorted(named - truth) if shrink >= 0.5 else []


def _truth(kind, name, case):
    if kind == "twin":
        return set() if name == "none" else {ANSWER[name]}
    return case.truths


@pytest.mark.slow
@pytest.mark.parametrize("kind,name,seed", RUNS)
def test_no_effect_outside_the_truth_is_named_with_confidence(kind, name, seed, withheld):
    d, _, case = withheld(kind, name, seed)
    wrong = _confidently_wrong(d, _truth(kind, name, case))
    assert not wrong, (name, seed, d.cause, d.causes, d.reason)


@pytest.mark.slow
def test_confident_wrong_rate_over_the_suite_is_zero(withheld):
    bad = []
    for kind, name, seed in RUNS:
        d, _, case = withheld(kind, name, seed)
        w = _confidently_wrong(d, _truth(kind, name, case))
        if w:
            bad.append((name, seed, w))
    assert bad == [], f"{len(bad)} of {len(RUNS)} confidently wrong: {bad}"
