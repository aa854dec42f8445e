"""With a sample rate, every warning of a design is the sampled loop's (the loop that ships),
the continuous loop's figure said beside it (fourth round: ``warnings_continuous_b_plain.json``
warned "overshoots 32.4 %" and ``|B S/Delta|`` 3.578, the continuous loop's figures, where the
20 kHz loop overshoots 34.5 % and has 3.31).

Truth by python-control (``loopcheck.sampled``: ZOH plant, Tustin controller, the
discrete reference step at the samples, ``|B S/Delta|`` on a dense unit-circle grid), and
the ZOH plant's own peak on the same grid.
"""

import numpy as np
import pytest

import loopcheck
import pcloop
from robrst.controller.artefact import load_design


@pytest.fixture(scope="module")
def result(repro_dir):
    return load_design(repro_dir / "turn4" / "warnings_continuous_b_plain.json")


def test_the_warnings_are_the_sampled_loops(result):
    sp = result.problem.specs
    fs = sp.sample_rate_hz
    figs = [(m, loopcheck.sampled(m, result.controller, fs)) for m in result.problem.family.models]
    over = max(f.overshoot_pct for _, f in figs)
    m_sd, f_sd = max(figs, key=lambda mf: mf[1].Msd / pcloop.unit_circle_max(
        lambda z, m=mf[0]: pcloop.resp(control_tf(m, fs), z)))
    ol = pcloop.unit_circle_max(lambda z: pcloop.resp(control_tf(m_sd, fs), z))
    assert round(over, 1) == 34.5 and round(f_sd.Msd, 2) == 3.31      # the truth
    warnings = result.assessment.warnings
    (w_over,) = [w for w in warnings if "overshoots" in w]
    (w_sd,) = [w for w in warnings if "|B S/Delta|" in w]
    assert f"overshoots {over:.3g} % in the 20000 Hz loop that ships" in w_over
    assert "continuous loop 32.4 %" in w_over
    assert f"|B S/Delta| {f_sd.Msd:.4g} µm/V in the 20000 Hz loop that ships" in w_sd
    assert f"on model {m_sd.label}" in w_sd and f"open loop's {ol:.4g}" in w_sd
    assert "continuous loop 3.578" in w_sd
    for rec, (m, f) in zip(result.assessment.models, figs):
        assert rec.sampled.Msd == pytest.approx(f.Msd, rel=1e-6)
        assert rec.sampled.overshoot_pct == pytest.approx(f.overshoot_pct, abs=1e-4)


def control_tf(m, fs):
    import control

    return control.tf(pcloop.zoh_plant(m, fs))
