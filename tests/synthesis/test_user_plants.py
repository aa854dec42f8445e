"""Synthesis on users' plants (issue 15): always an answer, every degree, moving resonances.

Every certified result here is also re-checked independently: the closed-loop poles of
every family model from ``numpy.roots`` and |S|, |T|, |U| on a dense grid.
"""

from dataclasses import replace

import numpy as np
import pytest

from robrst.design import run_problem
from robrst.core.rst import closed_loop
from robrst.problem.files import load_problem
from robrst.synthesis.synthesizer import Synthesizer
from synthesis_cases import piezo_stage, two_resonance_stage

W = np.logspace(-1, 6, 40_001)


def independent_check(problem, ctrl, tol=2e-3):
    """Stable and within the peak specs on every family model (numpy roots, dense grid)."""
    sp = problem.specs
    for m in problem.family.sweep(9):
        cl = closed_loop(m, ctrl)
        assert np.max(np.roots(cl.Delta).real) < 0, m.label
        for name, bound in (("S", sp.Ms_max), ("T", sp.Mt_max), ("U", sp.Mu_max)):
            N, D = cl.tf(name)
            peak = np.max(np.abs(np.polyval(N, 1j * W) / np.polyval(D, 1j * W)))
            assert peak <= bound * (1 + tol), (m.label, name, peak, bound)


@pytest.fixture(scope="module")
def stage_results():
    """The stage solved at an extra degree by one Synthesizer, on first use."""
    syn, cache = Synthesizer(), {}

    def solve(extra):
        if extra not in cache:
            cache[extra] = syn.solve(piezo_stage(900.0, extra))
        return cache[extra]

    return solve, syn


@pytest.mark.parametrize("extra", [0, 1, pytest.param(2, marks=pytest.mark.slow),
                                   pytest.param(3, marks=pytest.mark.slow)])
def test_piezo_stage_certifies_at_every_extra_degree(stage_results, extra):
    """The issue's 2nd-order stage (900 Hz, zeta 0.02, 20-40 °C, Ms 2, Mt 1.3, Mu 100)."""
    res = stage_results[0](extra)
    assert res.status == "certified" and res.certificate.certified
    independent_check(piezo_stage(900.0, extra), res.controller)


@pytest.mark.slow
def test_one_synthesizer_builds_few_programs(stage_results):
    solve, syn = stage_results
    assert all(solve(e).certified for e in range(4))
    # one program per structure (degree, phase, capacity, IPOPT options): 12 before the
    # linearised rows (damping floors, reference-step samples) and the bolder start's soft
    # phase with every coefficient free; 20 measured with them; 21 measured once every
    # bounded problem carries the default specs (overshoot, damping floor, |B S/Delta|);
    # 23 once a feasible point at IPOPT's iteration limit is kept (its exchange goes on
    # to two more capacities; the four answers and the CPU unchanged, 2026-12-01)
    assert syn.built <= 23


@pytest.mark.slow
def test_more_degrees_never_give_a_worse_certified_objective():
    """With the homotopy every degree starts from the one below: ki(d+1) >= ki(d)."""
    syn, prev = Synthesizer(), None
    for extra in range(3):
        res = syn.solve(piezo_stage(900.0, extra, solver='homotopy = "always"'))
        assert res.certified
        ki = abs(res.integral_gain)
        if prev is not None:
            assert ki >= prev * (1 - 1e-6), (extra, ki, prev)
        prev = ki


@pytest.mark.slow
def test_two_resonance_stage_certifies():
    """4th order, resonances at 400 and 1400 Hz: the pole placement alone cannot do it."""
    pr = two_resonance_stage()
    res = run_problem(pr)
    assert res.certified and res.synthesis.placement == "free"
    assert any("fixed nominal poles" in n for n in res.synthesis.notes)   # it tried first
    independent_check(pr, res.controller)
    assert abs(res.integral_gain) > 200.0          # better than the plain integrator 200/s


@pytest.mark.slow
@pytest.mark.parametrize("per_K", [-0.01, -0.02])
def test_resonance_moving_a_few_percent_per_kelvin(per_K):
    """The resonance moves 20-40 % over the family; the certificate holds on all of it."""
    pr = piezo_stage(900.0, 1, res_per_K=per_K)
    res = run_problem(pr)
    assert res.certified
    f = [np.max(np.abs(np.roots(m.A).imag)) / (2 * np.pi) for m in pr.family.models]
    assert max(f) / min(f) > 1.2
    independent_check(pr, res.controller)


def test_uncertifiable_problem_answers_with_the_best_controller(tmp_path):
    """Ms <= 1.05 on the stage: no controller can; the answer is the best one, exit 1."""
    from robrst.cli import main

    pr = piezo_stage(900.0, 0, solver='placement = "fixed"')
    pr = replace(pr, specs=replace(pr.specs, Ms_max=1.05))
    res = run_problem(pr)
    assert res.status == "not_certified" and res.controller is not None
    assert res.best_achievable.startswith("best achievable: model ")
    assert res.as_dict()["solver"]["binding"]
    f = tmp_path / "tight.toml"
    f.write_text('[plant]\nB = [3197.7]\nA = [1.0, 226.2, 31977.0]\n[poles]\nwn = 35.8\n'
                 'zeta = 1.0\n[specs]\nMs_max = 1.05\n[solver]\nmethod = "nlp"\n'
                 'placement = "fixed"\n')
    assert main(["design", str(f), "--quiet"]) == 1


@pytest.mark.slow
def test_synthesizer_reuses_its_programs_across_variants():
    """Variants of the continuous robust problem: same optimum as separate designs, one build."""
    base = load_problem("paper_robust_continuous")
    base = replace(base, solver=replace(base.solver, compare_with=None))
    syn, prev = Synthesizer(), None
    for Ms in (2.0, 1.9):
        pr = replace(base, specs=replace(base.specs, Ms_max=Ms))
        res = syn.solve(pr, warm=prev)
        alone = run_problem(pr, multistart=False)     # the same local run (no global phase)
        assert res.certified and alone.certified
        assert res.integral_gain == pytest.approx(alone.integral_gain, rel=1e-5)
        prev = res
    assert syn.built <= 3


SLOW_POLES = """[plant]
B = [3.0]
A = [1.0, 310.0, 3000.0]
[poles]
wn = 100.0
zeta = 0.9
[controller]
extra_degree = 1
[specs]
Ms_max = 1.6
Mt_max = 1.2
Mu_max = 20000.0
sample_rate_hz = 50000.0
delay_samples = 1
[solver]
method = "nlp"
objective = "max_integral_gain"
"""


@pytest.mark.slow
def test_a_certified_answer_is_never_worse_than_a_certified_start(tmp_path):
    """1e-3 µm/V, real poles at 10 and 300 rad/s, 50 kHz with one sample of delay. The
    boldest start (a PI, integral gain ~4e4) met the specs; its hard phase stopped at the
    iteration limit and a later start's hard phase (integral gain 168) was returned. The
    hand-made PI 3965 (s + 11.94)/s meets every spec (checked below with python-control):
    the answer must do at least as well, and is re-checked the same way."""
    import control
    from pcloop import loop_figures, zoh_plant

    from robrst.controller.export import export_controller

    f = tmp_path / "slow.toml"
    f.write_text(SLOW_POLES)
    problem = load_problem(f)
    plant = problem.family.models[0]
    fs, k = 50000.0, 1
    dt = zoh_plant(plant, fs, k).dt
    pi = control.c2d(control.tf([3965.0, 3965.0 * 11.94], [1.0, 0.0]), 1.0 / fs, "tustin")
    ref = loop_figures(plant, control.tf(pi.num[0][0], pi.den[0][0], dt), fs, k)
    assert ref["spectral_radius"] < 1 and ref["Ms"] <= 1.6 and ref["Mt"] <= 1.2
    assert ref["Mu"] <= 20000.0
    res = run_problem(problem)
    assert res.certified and res.integral_gain >= 3965.0 * 11.94
    exp = export_controller(res, fs, k, (0.0, 150.0))
    mine = loop_figures(plant, control.tf(list(exp.digital.R_z), list(exp.digital.S_z), dt),
                        fs, k)
    assert mine["spectral_radius"] < 1
    for key, bound in (("Ms", 1.6), ("Mt", 1.2), ("Mu", 20000.0)):
        assert mine[key] <= bound * (1 + 2e-3), (key, mine[key])
    independent_check(problem, res.controller)


SPREAD_POLES = """[plant]
B = [1e12]
A = [1.0, 101010.0, 101010000.0, 1e9]
[poles]
wn = 50.0
zeta = 0.9
[controller]
extra_degree = 1
[specs]
Ms_max = 1.8
Mt_max = 1.3
Mu_max = 0.05
[solver]
method = "nlp"
objective = "max_integral_gain"
"""


@pytest.mark.slow
def test_a_pi_zero_on_the_slowest_plant_pole_is_a_start(tmp_path):
    """Real poles at 10, 1e3 and 1e5 rad/s, 1000 µm/V, |U| <= 0.05: the PI 0.4 (0.1 s + 1)/s
    (its zero on the 10 rad/s pole) meets every spec with integral gain 0.4 (checked below
    on the same grid); without that start the answer was a certified 0.065, and with the
    global phase's search alone 0.0164 (the PI is one of its seeds)."""
    f = tmp_path / "spread.toml"
    f.write_text(SPREAD_POLES)
    problem = load_problem(f)
    from robrst.core.rst import RSTController

    independent_check(problem, RSTController(R=[0.04, 0.4], S=[1.0, 0.0], T=[0.4]))
    res = run_problem(problem)
    assert res.certified and res.integral_gain >= 0.2
    independent_check(problem, res.controller)
