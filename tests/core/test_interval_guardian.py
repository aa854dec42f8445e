"""The guardian-map proof of stability over a temperature interval
(:func:`robrst.core.interval.parameter_crossing`) against the Hurwitz condition of a cubic
worked by hand and numpy's roots."""

import numpy as np

from robrst.core.interval import parameter_crossing

A, B = 28.0, 45.0


def _cubic(top):
    """``e(T) s^3 + 1.5 s^2 + 1.5 s + 1`` with ``e`` from 0 (at ``A``) to ``top`` (at ``B``):
    Hurwitz while ``1.5 * 1.5 > e``; the largest coefficient changes along the interval."""
    def delta(T):
        return np.array([top * (T - A) / (B - A) + 1e-9, 1.5, 1.5, 1.0])
    return delta


def test_a_leading_coefficient_that_vanishes_at_an_end_is_proved():
    """The guardian of coefficients linear in T is a polynomial in T only under one
    normalisation for every T: normalised at each T by its largest coefficient it was not,
    and the interpolation never validated (64 nodes, no proof) although the loop is stable."""
    delta = _cubic(2.0)
    for T in np.linspace(A + 1e-6, B, 50):
        assert np.all(np.roots(delta(T)).real < 0)
    pr = parameter_crossing(delta, A, B, 1)
    assert pr.proved and pr.nodes < 10


def test_the_crossing_is_found_where_the_hurwitz_condition_fails():
    delta = _cubic(3.0)
    pr = parameter_crossing(delta, A, B, 1)
    cross = A + 2.25 / 3.0 * (B - A)               # e(T) = 1.5 * 1.5
    assert not pr.proved and abs(pr.candidate_T - cross) < 1e-6
    assert np.any(np.roots(delta(cross + 0.1)).real > 0)
    assert np.all(np.roots(delta(cross - 0.1)).real < 0)
