"""The joint multi-axis design: what it certifies holds under python-control's own loop.

Seeded random coupled stages (resonances 300-3,000 Hz, coupling 1-30 %): every certified
design is closed again by python-control (``feedback`` on the unscaled transfer matrices;
the sampled loop from ``c2d`` ZOH and Tustin) at every model the certificate checked (the
members and the points between them), and each bound is checked on a dense singular-value
grid, with the closed-loop poles.
"""

import control
import numpy as np
import pytest

from mimo_stages import random_stage, refined_max, sigma_grid
from robrst.base.errors import SpecError
from robrst.core.mimo import MimoFamily, MimoPlant
from robrst.problem.mimo import MimoProblem, MimoSolverOptions, MimoSpecs, MimoStructure
from robrst.design.mimo import design_mimo

FS = 20000.0


def _pc_S(g, ctrl, fs=None):
    m = g.noutputs
    axes, W = ctrl.axes, ctrl.decoupler
    num = [[list(axes[j].R) if i == j else [0.0] for j in range(m)] for i in range(m)]
    den = [[list(axes[j].S) if i == j else [1.0] for j in range(m)] for i in range(m)]
    K = control.ss([], [], [], W) * control.ss(control.tf(num, den))
    G = control.ss(g)
    if fs is not None:
        G, K = control.c2d(G, 1 / fs, "zoh"), control.c2d(K, 1 / fs, "tustin")
    I = control.ss([], [], [], np.eye(m), G.dt)
    return control.feedback(I, G * K), control.feedback(G * K, I)


def _check_independently(models_tf, values, result, fs):
    """Every checked model of the certificate: stable and within its bounds (python-control)."""
    specs = result.problem.specs
    rtol = result.problem.solver.cert_tol
    ctrl = result.controller
    for rec in result.certificate.models:
        v = rec.value
        i = int(np.clip(np.searchsorted(values, v) - 1, 0, len(values) - 2)) \
            if len(values) > 1 else 0
        if len(values) > 1:
            lam = (v - values[i]) / (values[i + 1] - values[i])
            g = control.parallel((1 - lam) * control.ss(models_tf[i]),
                                 lam * control.ss(models_tf[i + 1]))
        else:
            g = models_tf[0]
        for loop, rate in (("continuous", None), ("sampled", fs)):
            S, T = _pc_S(g, ctrl, rate)
            p = S.poles()
            assert np.all(np.abs(p) < 1) if rate else np.all(p.real < 0), (rec.label, loop)
            hi = 0.99999 * np.pi * rate if rate else 1e6
            ends = np.array([0.0, np.pi * rate]) if rate else np.array([0.0])
            for sysd, bound in ((S, specs.sigma_S_max), (T, specs.sigma_T_max)):
                if bound is None:
                    continue
                worst = max(refined_max(sysd, 0.5, hi)[0], sigma_grid(sysd, ends).max())
                assert worst <= bound * (1 + rtol), (rec.label, loop, worst, bound)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 3])
def test_certified_design_holds_on_python_controls_loop(seed):
    ga, gb = random_stage(seed, 2, spread=0.04)
    a = MimoPlant.from_control(ga, "cold", 20.0)
    b = MimoPlant.from_control(gb, "hot", 40.0)
    problem = MimoProblem(
        f"stage{seed}", MimoFamily((a, b)), MimoStructure(extra_degree=1),
        MimoSpecs(sigma_S_max=2.0, sigma_T_max=1.5, sample_rate_hz=FS),
        MimoSolverOptions(max_rounds=3, n_freq=60))
    result = design_mimo(problem, compare=False)
    assert result.certified, [v.describe() for v in result.certificate.violations]
    _check_independently([ga, gb], np.array([20.0, 40.0]), result, FS)
    # the answer improved on its start (the joint program did something)
    assert min(result.integral_gains()) > 0


@pytest.mark.slow
def test_certified_three_axis_design_holds_on_python_controls_loop():
    g, = random_stage(12, 3)
    P = MimoPlant.from_control(g, "stage", 20.0)
    problem = MimoProblem("stage3", MimoFamily((P,)), MimoStructure(extra_degree=1),
                          MimoSpecs(sigma_S_max=2.0, crosstalk_max=0.2,
                                    crosstalk_band_hz=(0.0, 20.0), sample_rate_hz=FS),
                          MimoSolverOptions(max_rounds=3, n_freq=60))
    result = design_mimo(problem, compare=True)
    assert result.certified, [v.describe() for v in result.certificate.violations]
    _check_independently([g], np.array([20.0]), result, FS)
    assert "ignoring_coupling" in result.comparisons


@pytest.mark.slow
def test_the_program_sees_a_peak_at_nyquist():
    """Seeded three-axis stage 4: the joint program's candidates had a real closed-loop
    pole of the sampled loop's w-plane far out (a z-plane pole within 1e-4 of -1), so
    their sigma_S peaked at Nyquist only (from the per-axis start 3.0 > 2 there; from the
    global phase's best 11.4, and 1.08 at 0.9995 of Nyquist, the grid's last point): the
    exact check refused them, the points it added were capped at 0.9995 of Nyquist, and
    four rounds (3,331 rows, 126 s CPU) went by.
    The program's validation grid and its added points now reach 1 - 1e-8 of Nyquist: no
    round's candidate is refused, and the answer holds on python-control's loops up to
    Nyquist itself."""
    ga, gb = random_stage(4, 3, spread=0.04)
    a = MimoPlant.from_control(ga, "cold", 20.0)
    b = MimoPlant.from_control(gb, "hot", 40.0)
    problem = MimoProblem("stage4", MimoFamily((a, b)), MimoStructure(extra_degree=1),
                          MimoSpecs(sigma_S_max=2.0, sigma_T_max=1.5, sample_rate_hz=FS),
                          MimoSolverOptions())
    result = design_mimo(problem, compare=False)
    assert result.certified, [v.describe() for v in result.certificate.violations]
    joint = [r for r in result.rounds if r.name == "joint"]
    assert joint and all(r.violations == 0 and r.stable for r in joint), joint
    _check_independently([ga, gb], np.array([20.0, 40.0]), result, FS)


@pytest.mark.slow
def test_an_answer_even_when_the_specs_cannot_be_met():
    """sigma_max(T) <= 0.9 is out of reach of any controller with integral action
    (T(0) = I, so sigma_max(T) >= 1): the best controller found, not certified, its
    binding figure named.  (sigma_max(S) <= 1.05 alone is reachable by a slow loop: a
    design certified at 1.0296 was confirmed by python-control's loop.)"""
    g, = random_stage(1, 2)
    P = MimoPlant.from_control(g, "stage", 20.0)
    problem = MimoProblem("tight", MimoFamily((P,)), MimoStructure(extra_degree=1),
                          MimoSpecs(sigma_S_max=2.0, sigma_T_max=0.9, sample_rate_hz=FS),
                          MimoSolverOptions(max_rounds=2, n_freq=40))
    result = design_mimo(problem, compare=False)
    assert not result.certified
    assert result.binding.figure in ("sigma_T", "stability")
    assert result.controller.n_axes == 2
    assert result.as_dict()["certified"] is False
    S, T = _pc_S(g, result.controller)          # independent: T(0) is the identity
    assert np.allclose(sigma_grid(T, np.array([1e-3])), 1.0, atol=1e-3)


def _one_axis_sector(bound, delta=0.3):
    """``(g, delta, result)``: one axis, a lightly damped 712 Hz resonance, a sector of
    half-width ``delta`` and ``sector_S_max = bound``, designed."""
    g = control.tf([2e7], [1, 300, 2e7])
    problem = MimoProblem("one axis", MimoFamily((MimoPlant.from_control(g, "cold", 20.0),)),
                          specs=MimoSpecs(sigma_S_max=2.0, input_gain_deviation=delta,
                                          sector_S_max=bound, sample_rate_hz=FS))
    return g, delta, design_mimo(problem, compare=False)


def test_with_nothing_certified_the_answer_is_the_least_violating_tried():
    """A sector performance bound no controller meets (one axis, a lightly damped
    resonance, ``sector_S_max = 1`` under a 30 % input-gain sector: ``S`` tends to 1 at
    high frequency and peaks above it): nothing certifies.  The answer was once the joint
    program's last point, outside the sector's own stability bound (``sigma_max(T_i)``
    4.4 > 1 / delta); it is the least violating controller tried.  Checked with
    python-control: the answer's loop is stable and its ``sigma_max(T_i)`` on a dense grid
    stays below 1 / delta, so the sector's small-gain stability holds for it."""
    g, delta, result = _one_axis_sector(1.0)
    assert not result.certified
    assert result.binding.figure == "sector_S"
    assert np.isfinite(result.binding.ratio)
    ctrl = result.controller
    num, den = [[list(ctrl.axes[0].R)]], [[list(ctrl.axes[0].S)]]
    K = control.ss([], [], [], ctrl.decoupler) * control.ss(control.tf(num, den))
    Ti = control.feedback(K * control.ss(g), control.ss([], [], [], np.eye(1)))
    assert np.all(np.real(control.poles(Ti)) < 0)
    assert refined_max(Ti, 0.5, 1e6)[0] < 1 / delta


def _gains_check(g, ctrl, delta, bound, n=5):
    """python-control's loops with constant input gains in the sector (every corner of
    ``[1 - delta, 1 + delta]^m`` and ``n`` seeded draws): stable, and ``sigma_max(S)`` on a
    dense grid (continuous loop) within the sector bound.  Constant gains are a special
    case of the deviations the sector figures cover, so this can only refute them."""
    m = g.ninputs
    rng = np.random.default_rng(7)
    corners = np.array(np.meshgrid(*[[1 - delta, 1 + delta]] * m)).reshape(m, -1).T
    worst = 0.0
    for k in np.vstack([corners, rng.uniform(1 - delta, 1 + delta, (n, m))]):
        S, _ = _pc_S(control.ss(g) * control.ss([], [], [], np.diag(k)), ctrl)
        assert np.all(np.real(S.poles()) < 0), k
        worst = max(worst, refined_max(S, 0.5, 1e6)[0])
    assert worst <= bound * 1.001, (worst, bound)
    return worst


def test_the_program_holds_a_sector_bound():
    """``sector_S_max`` targeted by the joint program (its scaled small-gain rows, the
    scalings program variables): one axis, a lightly damped resonance, a 30 % sector.
    Before the rows, ``sector_S <= 3`` did not certify (the answer: 5.96); now 2 does, and
    python-control's loops at gains across the sector stay within it."""
    g, delta, result = _one_axis_sector(2.0)
    assert result.certified, [v.describe() for v in result.certificate.violations]
    assert result.binding.figure == "sector_S" and result.binding.ratio > 0.9
    _gains_check(g, result.controller, delta, 2.0)


@pytest.mark.slow
def test_a_coupled_stage_meets_its_sector_bound():
    """Two coupled axes over two models, a 20 % sector per input and ``sector_S_max =
    2.5``: certified (sector_S binding), and python-control's loops with the input gains
    at the sector's corners and between them stay within the bound."""
    ga, gb = random_stage(0, 2, spread=0.04)
    problem = MimoProblem(
        "stage0", MimoFamily((MimoPlant.from_control(ga, "cold", 20.0),
                              MimoPlant.from_control(gb, "hot", 40.0))),
        MimoStructure(extra_degree=1),
        MimoSpecs(sigma_S_max=2.0, input_gain_deviation=0.2, sector_S_max=2.5,
                  sample_rate_hz=FS),
        MimoSolverOptions(max_rounds=4, n_freq=60))
    result = design_mimo(problem, compare=False)
    assert result.certified, [v.describe() for v in result.certificate.violations]
    assert result.binding.figure == "sector_S"
    for gm in (ga, gb):
        _gains_check(gm, result.controller, 0.2, 2.5)


def test_refusals():
    g = MimoPlant(-np.eye(2), np.ones((2, 3)), np.eye(2), np.zeros((2, 3)), "wide", 1.0)
    with pytest.raises(SpecError, match="square"):
        MimoProblem("wide", MimoFamily((g,)))
    sq = MimoPlant(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2)), "sq", 1.0)
    with pytest.raises(SpecError, match="unstable"):
        MimoProblem("bad", MimoFamily((sq,)), MimoStructure(
            decoupler="given", decoupler_ss=((1.0,), ((1.0, 0.0),), ((1.0,), (0.0,)),
                                             np.eye(2))))
    with pytest.raises(SpecError, match="2 x 2"):
        MimoProblem("badW", MimoFamily((sq,)), MimoStructure(decoupler="given", W=np.eye(3)))


def test_a_hysteresis_as_its_sector_designed_and_closed_through_bouc_wen():
    """A hysteresis enters the design as what it is: the Bouc-Wen map's input-gain sector
    over 0-150 V (``hysteresis_sector``: delta 0.19 around 1.06) is the problem's
    ``input_gain_deviation`` on the model times its centre; the certified controller,
    discretised by python-control (Tustin) and closed in numpy through the Bouc-Wen
    recursion in front of the ZOH plant, settles on every reference step (integral action:
    the error at each step's end below 1e-6 µm) and stays bounded, as on the linear plant."""
    from robrst.twin.model import hysteresis_gain, hysteresis_sector

    A, B, G = 0.45, 0.0045, 0.0045
    g_h = hysteresis_gain(A, B, G, 0.0, 150.0)
    sec = hysteresis_sector(A, B, G, g_h, 0.0, 150.0)
    assert 0.1 < sec.delta < 0.3
    g = control.tf([2e7], [1, 300, 2e7])
    problem = MimoProblem("hysteresis", MimoFamily((MimoPlant.from_control(
        sec.nominal * g, "nominal", 20.0),)), specs=MimoSpecs(
        sigma_S_max=2.0, input_gain_deviation=sec.delta, sample_rate_hz=FS))
    result = design_mimo(problem, compare=False)
    assert result.certified
    ax = result.controller.axes[0]
    K = control.ss(control.c2d(control.tf(list(ax.R), list(ax.S)), 1 / FS, "tustin"))
    P = control.ss(control.c2d(control.ss(g), 1 / FS, "zoh"))
    Ak, Bk, Ck, Dk = (np.asarray(m, float) for m in (K.A, K.B, K.C, K.D))
    Ap, Bp, Cp = (np.asarray(m, float) for m in (P.A, P.B, P.C))
    levels, n = (30.0, 60.0, 110.0, 45.0, 90.0), 2000
    for hysteresis in (False, True):
        xk, xp, h, u_prev, ends, peak = np.zeros(len(Ak)), np.zeros(len(Ap)), 0.0, 0.0, [], 0.0
        for i, r in enumerate(np.repeat(levels, n)):
            y = float((Cp @ xp)[0])
            e = r - y
            u = float((Ck @ xk)[0] + Dk[0, 0] * e)
            xk = Ak @ xk + Bk[:, 0] * e
            if hysteresis:
                d = u - u_prev
                h = h + A * d - B * abs(d) * h - G * d * abs(h)
                v = g_h * (u - h)
            else:
                v = sec.nominal * u
            u_prev, xp, peak = u, Ap @ xp + Bp[:, 0] * v, max(peak, abs(y))
            if i % n == n - 1:
                ends.append(abs(e))
        assert max(ends) < 1e-6 and peak < 1.5 * max(levels), (hysteresis, ends, peak)


def test_a_joint_design_below_its_certified_start_is_not_the_answer(monkeypatch):
    """The joint program is local: where it ends (or stops at its iteration limit) can be
    certified with smaller integral gains than the per-axis start it came from.  Made so
    here (the program returns the start with every feedback gain at 0.3 of it): the answer
    is the certified start, and the comparison says why."""
    import robrst.design.mimo as mimo_design

    def weak(name, models, specs, axes, W, T_mode, names, x0, signs, *rest, **kw):
        out, k = [], 0
        for a in axes:
            x = np.array(x0[k:k + a.n_x], float)
            x[a.d:] *= 0.3
            out.append(x)
            k += a.n_x
        return np.concatenate(out), True, []

    monkeypatch.setattr(mimo_design, "program_rounds", weak)
    G = MimoPlant(-100.0 * np.eye(2), 100.0 * np.eye(2), [[1.0, 0.2], [0.1, 1.0]],
                  np.zeros((2, 2)))
    pr = MimoProblem("stage", MimoFamily((G,)), specs=MimoSpecs(sigma_S_max=2.0),
                     solver=MimoSolverOptions(max_rounds=2))
    result = design_mimo(pr, compare=False)
    assert result.certified
    start = [float(c.R[-1] / np.trim_zeros(c.S, "b")[-1]) for c in result.start.axes]
    ratio = np.array(result.integral_gains()) / np.array(start)
    # the start itself or backed off (here at 0.9: the start peaks just above Ms 2), never
    # the joint design's 0.3
    assert ratio == pytest.approx(np.full(2, ratio[0]), rel=1e-12)
    assert min(abs(ratio[0] - f) for f in (1.0,) + mimo_design.BACK_OFF) < 1e-12
    assert "larger integral gains than the joint design's" in \
        result.comparisons["per_axis_start"].note
