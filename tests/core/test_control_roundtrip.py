"""python-control round trip: plants in, controller and closed loops out, figures agree.

python-control is the independent party: its ``stability_margins``, ``step_response``,
``feedback`` and ``c2d`` run on the objects robrst returns (or hands in) and must give
robrst's figures.
"""


import control
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from robrst.core import poly
from robrst.core.analysis import analyze, step_response
from robrst.design import run_problem
from robrst.base.errors import SpecError
from robrst.core.family import PlantFamily
from robrst.controller.implementation import run_loop
from robrst.core.plant import Plant, paper_plant
from robrst.problem.records import ControllerStructure, PoleSpec, Problem, Specs
from robrst.core.rst import closed_loop, closed_loop_control, feedback_part

FS = 20000.0


def random_plant(seed):
    rng = np.random.default_rng(seed)
    poles = list(-10 ** rng.uniform(1, 4, 2))
    w, z = 10 ** rng.uniform(2, 4), rng.uniform(0.005, 0.3)
    poles += [complex(-z * w, w * np.sqrt(1 - z * z)), complex(-z * w, -w * np.sqrt(1 - z * z))]
    zeros = list(-10 ** rng.uniform(1, 4, int(rng.integers(0, 3))))
    return Plant.from_zpk(zeros, poles, 10 ** rng.uniform(0, 10), temperature_C=28.0)


@pytest.mark.parametrize("seed", range(4))
def test_continuous_plants_round_trip(seed):
    plant = paper_plant() if seed == 0 else random_plant(seed)
    for sys in (plant.to_tf(), control.ss(plant.to_tf())):
        back = Plant.from_control(sys)
        assert poly.rel_coef_error(back.A, plant.A) < 1e-10
        assert poly.rel_coef_error(back.B, plant.B) < 1e-9


@pytest.mark.parametrize("seed,delay", [(0, 0), (1, 0), (2, 1), (3, 2)])
def test_discrete_plants_are_zoh_models(seed, delay):
    """A discrete plant is the ZOH model of the continuous plant robrst returns (d2c)."""
    plant = paper_plant() if seed == 0 else random_plant(seed)
    Pd = control.c2d(control.ss(plant.to_tf()), 1 / FS, "zoh")
    if delay:
        Pd = Pd * control.tf([1.0], [1.0] + [0.0] * delay, 1 / FS)
    for sys in (Pd, control.tf(Pd)):
        back = Plant.from_control(sys, temperature_C=28.0)
        assert back.meta["sample_rate_hz"] == FS and back.meta["delay_samples"] == delay
        assert poly.rel_coef_error(back.A, plant.A) < 1e-8
        assert poly.rel_coef_error(back.B, plant.B) < 1e-7


def test_bad_python_control_plants_are_refused():
    with pytest.raises(SpecError, match="SISO"):
        Plant.from_control(control.ss(np.eye(2) * -1, np.eye(2), np.eye(2), np.zeros((2, 2))))
    with pytest.raises(SpecError, match="unspecified sampling period"):
        Plant.from_control(control.tf([1.0], [1.0, -0.5], True))
    with pytest.raises(SpecError, match="no continuous zero-order-hold pre-image"):
        Plant.from_control(control.tf([1.0], [1.0, 0.5], 0.01))        # pole at z = -0.5
    with pytest.raises(SpecError, match="expected a control"):
        Plant.from_control([1.0, 2.0])


def test_a_problem_built_from_a_discrete_plant_certifies_that_plant(designs):
    """Design on the d2c plant with the specs of its meta; python-control closes the loop
    with the *given* discrete model and the exported sections: the certificate's Ms."""
    from pcloop import unit_circle_max

    from robrst.controller.export import export_controller

    Pd = control.c2d(control.ss(paper_plant().to_tf()), 1 / FS, "zoh") \
        * control.tf([1.0], [1.0, 0.0], 1 / FS)
    plant = Plant.from_control(Pd, label="bench", temperature_C=28.0)
    problem = Problem("from_discrete", PlantFamily(models=(plant,)),
                      poles=PoleSpec(wn=600.0, zeta=1.0),
                      controller=ControllerStructure(extra_degree=1),
                      specs=Specs(sample_rate_hz=plant.meta["sample_rate_hz"],
                                  delay_samples=plant.meta["delay_samples"]))
    exp = export_controller(run_problem(problem))
    K = -exp.digital.to_ss()[0, 1]
    K = control.ss(K.A, K.B, K.C, K.D, Pd.dt)
    Ptf = control.tf(Pd)
    L = lambda z: np.ravel(Ptf(z)) * np.ravel(K(z))                       # noqa: E731
    ms = unit_circle_max(lambda z: 1 / (1 + L(z)))
    assert ms == pytest.approx(exp.certificate.models[0].sampled.Ms, rel=1e-6)
    assert np.max(np.abs(control.feedback(Pd, K).poles())) < 1 and exp.certified


@pytest.fixture(scope="module")
def loops(designs):
    out = {}
    for name in ("paper", "paper_robust"):
        r = designs(name)
        m = r.problem.family.reference_model
        out[name] = (r, m, closed_loop_control(m, r.controller),
                     closed_loop_control(m, r.controller, FS))
    return out


@pytest.mark.parametrize("name", ["paper", "paper_robust"])
def test_python_control_margins_on_the_returned_loop(loops, name):
    r, m, cl, _ = loops[name]
    a = analyze(m, r.controller)
    wgc = control.stability_margins(cl["L"], returnall=True)[4]
    np.testing.assert_allclose(np.sort(wgc), a.margins.gain_crossover_rad_s, rtol=1e-7)
    gm, pm, sm, *_ = control.stability_margins(cl["L"])
    # the phase margin of the crossover closest to -1 (robrst: either sign, python-control: signed)
    assert abs(pm) == pytest.approx(abs(a.margins.phase_margin_deg), abs=1e-6)
    if a.margins.gain_margin is None:      # no phase crossover: robrst null, python-control inf
        # python-control may count w = 0 (the integrator: |L| infinite, no phase there) as
        # a phase crossover; every crossover at a positive frequency counts
        gms, wpc = control.stability_margins(cl["L"], returnall=True)[0:4:3]
        assert all(w == 0 for w in np.atleast_1d(wpc)), (gms, wpc)
        assert not a.margins.phase_crossover_rad_s
    else:
        # python-control answers the margin nearest 1 on a log scale, up or down; robrst
        # states both (gain_margin > 1, gain_margin_lower < 1: a conditionally stable loop,
        # as a paper_robust design tried on 2026-12-07, a lag at 15 rad/s: 20.98 / 0.061)
        gms = control.stability_margins(cl["L"], returnall=True)[0]
        both = [g for g in (a.margins.gain_margin, a.margins.gain_margin_lower) if g]
        for g in both:
            assert np.min(np.abs(np.asarray(gms) / g - 1)) < 1e-7, (gms, g)
        assert gm == pytest.approx(min(both, key=lambda g: abs(np.log(g))), rel=1e-7)
    assert sm == pytest.approx(a.margins.modulus_margin, rel=1e-7)   # |S| peak at finite w


@pytest.mark.parametrize("name", ["paper", pytest.param("paper_robust", marks=pytest.mark.slow)])
def test_python_control_feedback_and_step_on_the_returned_objects(loops, name):
    r, m, cl, cld = loops[name]
    ctrl = r.controller
    cp = closed_loop(m, ctrl)
    # feedback(L) closes the same loop: same characteristic polynomial (roots cluster); L is
    # the feedback law's (a 2-DOF controller's common reference-model factor divided out)
    poles = control.feedback(cl["L"]).poles()
    fb = closed_loop(m, feedback_part(ctrl))
    assert poly.rel_coef_error(np.real(np.poly(poles)), poly.monic(fb.Delta)) < 1e-9
    # the controller objects: python-control's own closing equals robrst's Tr
    P = control.ss(m.to_tf())
    K = ctrl.to_ss()
    Tr = control.feedback(P, -K[0, 1]) * K[0, 0]
    t = np.linspace(0, 0.02, 400)
    ref = step_response(cp.nums["Tr"], cp.Delta, t)
    for sys in (cl["Tr"], Tr):
        y = np.ravel(control.step_response(sys, T=t).outputs)
        assert np.max(np.abs(y - ref)) < 1e-9 * np.max(np.abs(ref))
    # discrete: the sampled loop's step (sections on the exact ZOH model) and its peak
    n = 400
    y_d = np.ravel(control.step_response(cld["Tr"], T=np.arange(n) / FS).outputs)
    from robrst.controller.digital import digital_controller

    y_sec, _ = run_loop(digital_controller(ctrl, FS), m, np.ones(n))
    assert np.max(np.abs(y_d - y_sec)) < 1e-9 * np.max(np.abs(y_sec))
    # the sampled |S| peak against python-control's own L(z) on a dense grid, refined locally
    # (python-control 0.10.2's discrete stability_margins() is unreliable on these 20 kHz
    # loops: tests/core/test_control_objects.py; the w-plane loop gives the margins exactly)
    L = cld["L"]
    w = np.linspace(1e-3, np.pi * FS * (1 - 1e-12), 400_001)
    gap = np.abs(1 + L(np.exp(1j * w / FS)))
    k = int(np.argmin(gap))
    best = minimize_scalar(lambda x: abs(1 + L(np.exp(1j * x / FS))),
                           bounds=(w[max(k - 1, 0)], w[min(k + 1, w.size - 1)]),
                           method="bounded", options={"xatol": 1e-9})
    assert 1 / best.fun == pytest.approx(analyze_sampled_ms(m, ctrl), rel=1e-9)


def analyze_sampled_ms(plant, ctrl):
    from robrst.core.peaks import peak_gain
    from robrst.core.sampled import sampled_plant

    c = closed_loop(sampled_plant(plant, FS), ctrl)
    return peak_gain(c.nums["S"], c.Delta).value


def test_controller_objects_agree_with_each_other(loops):
    r, m, _, _ = loops["paper_robust"]
    ctrl = r.controller
    w = np.geomspace(1, 6e4, 50)
    # reference: the stored polynomials in s at s (continuous) or at Tustin's s(z) (sampled)
    # the expanded z-polynomials of to_tf(fs) have nine roots near z = 1 at 20 kHz: 3.7e-5
    # to 1.7e-4 relative error at 1 rad/s (as the design changes); the state space stays at
    # rounding level
    for a, b, tol_tf in ((ctrl.to_tf(), ctrl.to_ss(), 1e-10), (ctrl.to_tf(FS), ctrl.to_ss(FS), 1e-3)):
        x = 1j * w if a.dt == 0 else np.exp(1j * w / FS)
        s = x if a.dt == 0 else 2 * FS * (x - 1) / (x + 1)
        ref = np.array([[np.polyval(ctrl.T, v), -np.polyval(ctrl.R, v)] for v in s])
        ref /= np.array([np.polyval(ctrl.S, v) for v in s])[:, None]
        fa = np.array([np.asarray(a(v)).ravel() for v in x])
        fb = np.array([np.asarray(b(v)).ravel() for v in x])
        # relative to the value, or to a millionth of its column's peak where the
        # controller has rolled off (|T/S| ~ 1e-6 at the top of the band: rounding of
        # the realisation is absolute there)
        scale = np.maximum(np.abs(ref), 1e-6 * np.max(np.abs(ref), axis=0))
        assert np.max(np.abs(fb - ref) / scale) < 1e-10
        assert np.max(np.abs(fa - ref) / np.abs(ref)) < tol_tf
        assert a.input_labels == ["yr", "y"] and b.output_labels == ["u"]
    assert ctrl.to_tf(FS).dt == 1 / FS
