"""A scan of Ms_max: the certified objective never decreases as the bound loosens, and no
design of a looser bound certifies on a tighter one with a better objective (more than 1 %).

Over seeded random piezo stages (:mod:`piezo_stages`), by :func:`robrst.studies.scan.bound_scan`.
Each kept controller is checked independently: its |S| peak (python-control, dense grids of
the unscaled polynomials, continuous and sampled loop, :mod:`loopcheck`) at the family's
temperatures is within its own bound.  "Certifies on a tighter bound" is the certificate's
verdict (:func:`robrst.certificate.proof.certify_problem`).
"""

from dataclasses import replace

import numpy as np
import pytest

import loopcheck
import piezo_stages
from robrst.certificate.proof import certify_problem
from robrst.problem.files import parse_problem
from robrst.studies.scan import bound_scan


def _check_scan(problem, values):
    points = bound_scan(problem, "Ms_max", values)
    objs = [pt.objective for pt in points]
    assert all(o is not None for o in objs), objs
    assert all(b >= a * (1 - 1e-12) for a, b in zip(objs, objs[1:])), objs
    sp = problem.specs
    for pt in points:
        for m in problem.family.models:
            c = loopcheck.continuous(m, pt.result.controller, horizon_s=1e-3, n_t=11)
            s = loopcheck.sampled(m, pt.result.controller, sp.sample_rate_hz, sp.delay_samples,
                                  n_samples=10)
            assert c.Ms <= pt.value * (1 + 1e-3) and s.Ms <= pt.value * (1 + 1e-3)
    for i, pi in enumerate(points):
        tighter = replace(problem, specs=replace(sp, Ms_max=pi.value))
        for pj in points[i + 1:]:
            if pj.objective > pi.objective * 1.01:
                assert not certify_problem(tighter, pj.result.controller).certified, (
                    pi.value, pj.value, pi.objective, pj.objective)
    return points


@pytest.mark.slow
def test_ms_scan_is_monotone_on_a_random_stage():
    doc = piezo_stages.stage_doc(11, order=2)
    p = parse_problem(doc, "<stage11>")
    _check_scan(p, np.linspace(1.5, 2.5, 5))


@pytest.mark.large
@pytest.mark.parametrize("seed", [21, 22, 23, 24])
def test_ms_scan_is_monotone_eleven_values(seed):
    doc = piezo_stages.stage_doc(seed)
    p = parse_problem(doc, f"<stage{seed}>")
    _check_scan(p, np.linspace(1.5, 2.5, 11))
