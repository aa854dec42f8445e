"""A controller to beat (``run_problem(..., incumbent=...)``, ``robrst design --incumbent``):
with the global phase it is certified as given and polished first, so the answer is never
below an incumbent that meets the specs; one of another structure or method is refused.

The answers are checked independently of robrst's objective and certificate: the integral
gain from the polynomials' coefficients, |S| and |U| on a dense grid of the unscaled loop
(within the certificate's stated relative tolerance on the bounds, ``[solver] cert_tol``).
"""

import json
import tomllib

import numpy as np
import pytest

from robrst.base.errors import SpecError
from robrst.cli import main
from robrst.core.rst import RSTController
from robrst.design import run_problem
from robrst.problem.files import load_problem, parse_problem

RTOL = 1e-3        # the certificate's relative tolerance on the bounds (cert_tol's default)

DOC = ('[plant]\nB = [2.0]\nA = [1.0, 3.0, 2.0]\n[poles]\nwn = 2.0\nzeta = 0.8\n'
       '[controller]\nextra_degree = 1\n[specs]\nMs_max = {ms}\nMu_max = 20.0\n'
       '[solver]\nmethod = "nlp"\nobjective = "max_integral_gain"\n')


def _problem(ms):
    return parse_problem(tomllib.loads(DOC.format(ms=ms)), f"<Ms {ms}>")


def _gain(c):
    """lim s K(s) = R(0) / (S/s)(0) from the coefficients."""
    return c.R[-1] / c.S[-2]


def _peaks(c, w=np.logspace(-3, 4, 200_001)):
    s = 1j * w
    a, b = np.polyval([1.0, 3.0, 2.0], s), 2.0
    d = a * np.polyval(c.S, s) + b * np.polyval(c.R, s)
    assert np.all(np.roots(np.polyadd(np.polymul([1.0, 3.0, 2.0], c.S), 2.0 * c.R)).real < 0)
    return np.max(np.abs(a * np.polyval(c.S, s) / d)), np.max(np.abs(a * np.polyval(c.R, s) / d))


def test_a_looser_bound_from_the_tighter_answer_is_never_below_it():
    tight = run_problem(_problem(1.4), analyses=False)
    assert tight.certified
    loose = run_problem(_problem(2.0), analyses=False, incumbent=tight)
    assert loose.certified
    assert _gain(loose.controller) >= _gain(tight.controller) * (1 - 1e-9)
    Ms, Mu = _peaks(loose.controller)
    assert Ms <= 2.0 * (1 + RTOL) and Mu <= 20.0 * (1 + RTOL)
    names = [t[0] for t in loose.synthesis.tried]
    assert "the incumbent, as given" in names


def test_an_incumbent_outside_the_specs_only_starts_the_search():
    free = run_problem(_problem(2.0), analyses=False)
    bad = RSTController(R=free.controller.R * 40.0, S=free.controller.S, T=free.controller.T)
    res = run_problem(_problem(2.0), analyses=False, incumbent=bad)
    assert res.certified
    assert res.controller is not bad and not np.allclose(res.controller.R, bad.R)
    assert any("does not meet the specs as given" in n for n in res.synthesis.notes)


def test_an_incumbent_of_another_structure_or_method_is_refused():
    other = RSTController(R=[1.0, 2.0, 3.0, 4.0, 5.0], S=[1.0, 1.0, 1.0, 1.0, 0.0], T=[5.0])
    with pytest.raises(SpecError, match="incumbent: not a controller of this problem"):
        run_problem(_problem(2.0), analyses=False, incumbent=other)
    fixed = _problem(2.0)
    from dataclasses import replace

    analytic = replace(fixed, solver=replace(fixed.solver, method="analytic"))
    with pytest.raises(SpecError, match="incumbent: the robust program"):
        run_problem(analytic, analyses=False, incumbent=other)


def test_the_command_line_takes_a_saved_design_and_refuses_a_bad_file(tmp_path, capsys):
    saved = tmp_path / "tight.json"
    assert main(["design", "paper", "--json", "--quiet"]) == 0
    saved.write_text(capsys.readouterr().out)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["design", "paper_robust", "--incumbent", str(bad), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.json" in err[0] and "Traceback" not in err[0]
    # the paper's analytic design is another structure than paper_robust's: refused, one line
    assert main(["design", "paper_robust", "--incumbent", str(saved), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "incumbent" in err[0]
    assert json.loads(saved.read_text())["controller"]["R"]


@pytest.mark.slow
def test_the_known_better_controller_as_incumbent_is_kept_or_beaten():
    """``paper_robust_continuous`` from the controller of ``test_known_better.py`` (3.65x its
    default answer): the answer is certified, at or above it, and meets |S|, |T|, |U| and
    the resonance band's |T| on a dense grid at nine temperatures."""
    from test_known_better import KNOWN, KNOWN_GAIN, _peaks as peaks
    from robrst.problem.records import with_defaults

    p = with_defaults(load_problem("paper_robust_continuous"))
    res = run_problem(p, analyses=False, incumbent=KNOWN)
    assert res.certified and _gain(res.controller) >= KNOWN_GAIN * (1 - 1e-9)
    sp = p.specs
    w = np.logspace(-1, 6, 200_001)
    lo, hi = (2 * np.pi * f for f in sp.resonance_band_hz)
    band = (w >= lo) & (w <= hi)
    for temp in np.linspace(*p.family.range_C, 9):
        S, T, U = peaks(p.family.at(float(temp)), res.controller, w)
        assert S.max() <= sp.Ms_max * (1 + RTOL) and T.max() <= sp.Mt_max * (1 + RTOL)
        assert U.max() <= sp.Mu_max * (1 + RTOL)
        assert T[band].max() <= sp.T_resonance_max * (1 + RTOL)


@pytest.mark.parametrize("starts", [0, 2])
def test_the_homotopys_lower_degree_runs_without_it(starts):
    """An incumbent of the problem's degree is no start of the homotopy's lower degree:
    ``bound_scan`` handing each answer on stopped with "initial controller has the wrong
    degrees" where a design fell back to ``extra_degree - 1`` (2026-12-04)."""
    doc = DOC.format(ms=2.0) + f'homotopy = "always"\nstarts = {starts}\n'
    problem = parse_problem(tomllib.loads(doc), "<homotopy>")
    given = run_problem(_problem(1.4), analyses=False)
    res = run_problem(problem, analyses=False, incumbent=given)
    assert res.certified
    assert _gain(res.controller) >= _gain(given.controller) * (1 - 1e-9)
    Ms, Mu = _peaks(res.controller)
    assert Ms <= 2.0 * (1 + RTOL) and Mu <= 20.0 * (1 + RTOL)
