"""A controller robrst certifies on ``paper_robust_continuous`` at an integral gain 3.65x its
default answer (found on 2026-12-04 by a polish whose derivatives differed from today's only
by rounding, which took another path; docs/background/synthesis.md).  It is checked here
independently (numpy on a dense grid of the unscaled polynomials, python-control's step),
and the default design reaches 95 % of it (an expected failure until the answer was polished
again from where its polish ended)."""

import numpy as np
import pytest

import loopcheck
from robrst.certificate.proof import certify_problem
from robrst.core.rst import RSTController
from robrst.problem.files import load_problem
from robrst.problem.records import with_defaults

# highest power first in s, as the design file stores them (`robrst design
# paper_robust_continuous --json` with that polish)
KNOWN = RSTController(
    R=[110.5292094171933, 409113.3589669232, 2252082670.440874, 6263099790874.278,
       9361599258958724.0, 6.790736094000793e+18],
    S=[1.0, 4896.498287488794, 105230495.76407486, 3312604929.7704544,
       213729411783.09113, 0.0],
    T=[6.790736094000793e+18])
KNOWN_GAIN = KNOWN.R[-1] / KNOWN.S[-2]          # lim s K(s): S = s S'


def _peaks(plant, c, w):
    """|S|, |T|, |U| of the unscaled loop at the frequencies ``w`` [rad/s]."""
    s = 1j * w
    a, b = np.polyval(plant.A, s), np.polyval(plant.B, s)
    r, sc = np.polyval(c.R, s), np.polyval(c.S, s)
    d = a * sc + b * r
    return np.abs(a * sc / d), np.abs(b * r / d), np.abs(a * r / d)


def test_the_known_controller_meets_every_spec_on_a_dense_grid():
    p = with_defaults(load_problem("paper_robust_continuous"))
    sp = p.specs
    assert KNOWN_GAIN == pytest.approx(31_772_586, rel=1e-6)
    w = np.logspace(-1, 6, 400_001)
    lo, hi = (2 * np.pi * f for f in sp.resonance_band_hz)
    band = (w >= lo) & (w <= hi)
    t_lo, t_hi = p.family.range_C
    for temp in np.linspace(t_lo, t_hi, 9):
        m = p.family.at(float(temp))
        S, T, U = _peaks(m, KNOWN, w)
        assert S.max() <= sp.Ms_max and T.max() <= sp.Mt_max and U.max() <= sp.Mu_max, temp
        assert T[band].max() <= sp.T_resonance_max, temp
        f = loopcheck.continuous(m, KNOWN)
        assert f.decay > 0 and f.damping >= sp.damping_min, (temp, f)
        assert f.overshoot_pct <= sp.overshoot_max_pct, (temp, f)
    assert certify_problem(p, KNOWN).certified


@pytest.mark.slow
def test_the_default_design_reaches_the_known_controller(designs):
    """An expected failure until 2026-12-04 (8,703,486: 27 %); since the answer is polished
    again from where its polish ended, 255,123,464 (8x); 307,515,384 since it starts on the
    grid its polish reached.  The integral gain from the
    coefficients of the answer's feedback law."""
    c = designs("paper_robust_continuous").synthesis.controller
    assert c.R[-1] / c.S[-2] >= 0.95 * KNOWN_GAIN
