"""The default design of seeded stages against an independent search (default specs on).

On seeded stages of ``tests/stages_global.py`` (2nd and 4th order, sampled loops with
delay, the default overshoot, damping-floor and ``|B S/Delta|`` specs) the default design
(``run_problem``, as the command line runs it) is judged by ``tests/global_reference.py``:
feasibility on dense grids of the *unscaled* polynomials of every family member, continuous
and sampled loops, reference steps by ``lfilter`` (numpy and SciPy only, nothing of
robrst's numerical code), with the certificate's own tolerance (``solver.cert_tol``).

1. The design, written in the reference's factored parametrisation (integral gain,
   controller pole pairs, zeros of ``R``), passes that check: robrst's certificate is not
   the only judge of its answer.
2. Differential evolution over that parametrisation, its population seeded with the
   design, finds no certified controller more than 5 % above it.  This is a necessary
   condition of the issue's "95 % of the best an independent global search finds", not a
   proof of it: differential evolution from random points alone reaches far less on these
   stages (stage 201, 38,528 evaluations, 15 min CPU: 112,115 against the design's
   371,068), so the search is started at the design and asked to beat it.
"""

import numpy as np
import pytest

import global_reference as gr
from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.problem.records import with_defaults
from stages_global import stage_doc

SHARE = 0.95


def _judged(seed, order, popsize, maxiter):
    p = with_defaults(parse_problem(stage_doc(seed, order=order), f"<stage {seed}>"))
    res = run_problem(p, analyses=False)
    assert res.certified, seed
    # a controller pole on the strip's edge counts within the program's 2 % slack
    # (``robrst.synthesis.context.CTRL_POLE_SLACK``): stage 102's answer has two lags there
    # (-54.60 and -54.38 rad/s, the edge at -54.49), as the edge runs place them
    shift, top = gr.strip(p)
    st = gr.setting(p, 0.98 * shift, top)
    st.rtol = p.solver.cert_tol
    R, S = np.asarray(res.controller.R, float), np.asarray(res.controller.S, float)
    v0 = gr.parameters(st, R, S)
    assert v0 is not None, (seed, np.roots(R), np.roots(S))
    back_R, back_S = gr.controller(st, v0)
    np.testing.assert_allclose(back_R, R, rtol=1e-9)
    np.testing.assert_allclose(back_S, S, rtol=1e-9, atol=1e-12 * np.max(np.abs(S)))
    viol = gr.violation(st, R, S)
    x, _ = gr.search(st, seed=seed, popsize=popsize, maxiter=maxiter, x0=v0)
    best = gr.certified_best(p, st, x) if x[0] > v0[0] + np.log10(1.0 / SHARE) else None
    return res.integral_gain, viol, best


@pytest.mark.slow
@pytest.mark.parametrize("seed,order,popsize,maxiter",
                         [(12, 2, 10, 60), (102, 4, 8, 40)])
def test_no_independent_search_from_the_design_beats_it_by_5_percent(seed, order, popsize,
                                                                     maxiter):
    """Measured on stages 201-205 with larger searches (population 15, 100-150
    generations, 19,328 evaluations on the 2nd-order stages): none improved on its design
    by any amount (stage 203: 3,224,398 both)."""
    ki, viol, best = _judged(seed, order, popsize, maxiter)
    print(f"\nstage {seed}: design {ki:.6g}, reference violation {viol:.3g},"
          f" search {'nothing better' if best is None else f'{best[0]:.6g}'}")
    assert viol == 0.0
    assert best is None or ki >= SHARE * best[0]
