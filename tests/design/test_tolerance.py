"""How far the next actuator may differ (robrst.design.tolerance), against a closed form.

The loop of ``b / (s + a)`` with the integral law ``K / s`` is ``s^2 + a s + k K b`` for a
static-gain factor ``k``: damping ``zeta = a / (2 sqrt(k K b))`` and, below ``1/sqrt 2``,
``|T|`` peaks at ``1 / (2 zeta sqrt(1 - zeta^2))`` (a textbook second-order loop).  With only
``Mt_max`` bounded, the largest tolerated gain factor ``k*`` solves that peak = ``Mt_max``;
a smaller gain only damps the loop more.  The reported range must bracket ``k*`` within
the bisection's resolution, computed here from the formula, not from robrst's figures
(with the certificate's own tolerance: a peak within ``cert_tol`` of its bound meets it).
"""

import numpy as np

from robrst.core.rst import RSTController
from robrst.design.tolerance import (BISECTIONS, FRAGILE, SMALLEST, SPAN, spread_tolerance)
from robrst.problem.files import parse_problem
from robrst.problem.records import with_defaults

A, B, K = 1.0, 1.0, 1.0            # nominal damping 0.5: |T| peak 1.1547


def _problem(mt_max):
    doc = {"problem": {"name": "integral"},
           "plant": {"B": [B], "A": [1.0, A]},
           "controller": {"S_fixed": [1.0, 0.0]},
           "poles": {"wn": 1.0, "zeta": 1.0},
           "specs": {"Mt_max": mt_max, "overshoot_max_pct": False, "Msd_rel_max": False,
                     "damping_min": 0.0},
           "solver": {"method": "analytic"}}
    return with_defaults(parse_problem(doc, "<integral>"))


def _k_star(problem):
    """The gain factor at which the |T| peak reaches Mt_max (closed form)."""
    mt_max = problem.specs.Mt_max * (1.0 + problem.solver.cert_tol)
    zeta2 = (1.0 - np.sqrt(1.0 - 1.0 / mt_max ** 2)) / 2.0
    return A * A / (4.0 * zeta2 * K * B)


CTRL = RSTController(R=[K], S=[1.0, 0.0], T=[K])
RESOLUTION = (SPAN / SMALLEST) ** (0.5 ** BISECTIONS)   # the log bisection's last ratio


def test_the_gain_range_brackets_the_closed_form():
    p = _problem(1.2)
    tol = spread_tolerance(p, CTRL)
    k_star = _k_star(p)                           # 1.1190
    assert [f.factor for f in tol.factors] == ["gain"]   # no complex pole pair to move
    g = tol.factors[0]
    assert g.low == 1.0 - SPAN and g.below_at is None       # less gain: more damping
    assert g.high <= k_star <= g.above_at
    assert (g.above_at - 1.0) / (g.high - 1.0) <= RESOLUTION * (1 + 1e-12)
    assert "|T|" in g.above
    assert tol.warning is None


def test_a_design_at_its_bound_is_named_fragile():
    mt = 1.1547005 * 1.005                        # 0.5 % above the nominal peak
    p = _problem(mt)
    k_star = _k_star(p)
    assert 1.0 < k_star < 1.0 + FRAGILE
    tol = spread_tolerance(p, CTRL)
    g = tol.factors[0]
    assert g.high <= k_star <= g.above_at
    assert tol.warning is not None and "gain" in tol.warning and "[spread]" in tol.warning


def test_a_design_that_misses_its_own_specs_has_none():
    assert spread_tolerance(_problem(1.1), CTRL) is None


def test_a_family_the_factor_makes_invalid_fails_there(monkeypatch):
    """A factor whose family cannot be built (a thermal law out of its domain) counts as
    failing, and says why, instead of stopping the design."""
    import robrst.design.tolerance as tolerance
    from robrst.base.errors import SpecError

    real = tolerance.transform_family

    def partial(family, values):
        if values.get("gain", 1.0) < 0.9:
            raise SpecError("family: gain factor out of the law's domain")
        return real(family, values)

    monkeypatch.setattr(tolerance, "transform_family", partial)
    g = spread_tolerance(_problem(1.2), CTRL).factors[0]
    assert 0.9 <= g.low < 1.0 and g.below_at < 0.9
    assert g.below.startswith("not checked: family: gain factor")
