"""The multi-axis export: the design's certificate travels with it as a record, and the JSON
summarises it; a comparison controller carries none.

On a seeded 2x2 stage designed for its sampled loop: the exported record's certificate is
the design's (``certified`` read from it), the JSON's ``certificate`` object holds the
certificate's verdict, ratios, sampled sigma(S) and described violations; the generated
Python module says the same verdict; a controller that is not the design's answer exports
with ``certified = None`` and a note. The exported step runs the law at rest (zero in, zero
out) and stays within the amplifier range.
"""

import json

import numpy as np
import pytest

from mimo_stages import random_stage
from robrst.controller.mimo_export import export_mimo, mimo_python_module
from robrst.core.mimo import MimoFamily, MimoPlant
from robrst.design.mimo import design_mimo
from robrst.problem.mimo import MimoProblem, MimoSolverOptions, MimoSpecs, MimoStructure

FS = 20000.0
pytestmark = pytest.mark.slow          # one multi-axis design (about a minute)


@pytest.fixture(scope="module")
def result():
    ga, gb = random_stage(3, 2, spread=0.04)
    problem = MimoProblem(
        "stage3", MimoFamily((MimoPlant.from_control(ga, "cold", 20.0),
                              MimoPlant.from_control(gb, "hot", 40.0))),
        MimoStructure(extra_degree=1), MimoSpecs(sigma_S_max=2.0, sigma_T_max=1.5,
                                                 sample_rate_hz=FS),
        MimoSolverOptions(max_rounds=2, n_freq=40))
    return design_mimo(problem, compare=False)


def test_the_certificate_travels_as_a_record(result):
    exp = export_mimo(result)
    cert = result.certificate
    assert exp.certificate is cert and exp.certified is bool(cert.certified)
    doc = json.loads(json.dumps(exp.as_dict()))
    c = doc["certificate"]
    assert c["certified"] == cert.certified
    assert c["worst_sigma_S_sampled"] == pytest.approx(
        max(m.loop("sampled").value("sigma_S") for m in cert.models))
    assert c["ratios"] == json.loads(json.dumps(cert.ratios()))
    assert len(c["violations"]) == min(20, len(cert.violations))
    assert f"Certified: {cert.certified}." in mimo_python_module(exp)


def test_a_comparison_controller_carries_no_certificate(result):
    exp = export_mimo(result, controller=result.controller)
    assert exp.certificate is None and exp.certified is None
    assert exp.as_dict()["certificate"]["certified"] is None
    step = exp.stepper()
    assert np.allclose(step(np.zeros(2), np.zeros(2)), 0.0)
    lo, hi = exp.u_range
    u = step(np.ones(2), np.zeros(2))
    assert np.all((lo <= u) & (u <= hi))
