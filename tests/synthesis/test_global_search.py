"""The global phase's parts, each against an independent computation: the batched roots
and Routh test, the pole space (the nominal closed-loop poles it names are the poles of
``A S + B R`` on the unscaled polynomials), the screen's figures (a dense grid of the
unscaled loop, python-control's step), the CMA-ES on functions whose minimum is known."""

import numpy as np
import pytest

from robrst.design import analytic_design
from robrst.problem.files import parse_problem
from robrst.problem.records import with_defaults
from robrst.synthesis.attempts import program_models
from robrst.synthesis._cmaes import CMAES
from robrst.synthesis.context import Context
from robrst.synthesis._screen import Screen, batch_roots, routh_columns
from robrst.synthesis.search import PoleSpace, SearchOptions, global_search, move_inside
from robrst.synthesis._timesamples import time_specs

W = 2 * np.pi * 1300.0
DOC = {"problem": {"name": "g"},
       "plant": {"B": [0.05 * W * W], "A": [1.0, 2 * 0.015 * W, W * W], "temperature_C": 25.0},
       "family": {"temperatures_C": [15.0, 32.5, 50.0],
                  "parametric": {"resonance_per_K": -0.0002}},
       "controller": {"extra_degree": 1},
       "poles": {"wn": 1633.6, "zeta": 1.0},
       "specs": {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": 200.0},
       "solver": {"method": "nlp"}}


def _setup(doc=DOC):
    p = with_defaults(parse_problem(doc, "<g>"))
    start = analytic_design(p)
    ctx = Context.of(p, start)
    return p, ctx, ctx.setup(program_models(p), ctx.nu, "free"), start


def test_batch_roots_and_routh_agree_with_numpy():
    rng = np.random.default_rng(3)
    C = rng.normal(size=(40, 6))
    C[:, 0] = np.abs(C[:, 0]) + 0.1
    r = batch_roots(C)
    for c, mine in zip(C, r):
        ref = np.roots(c)
        assert np.allclose(np.sort_complex(mine), np.sort_complex(ref), atol=1e-8)
    hurwitz = np.all(routh_columns(C) > 0, axis=1)
    assert np.array_equal(hurwitz, np.array([np.all(np.roots(c).real < 0) for c in C]))
    assert np.isinf(batch_roots(np.array([[0.0, 1.0, 2.0]]))).all()   # a lost degree


def test_pole_space_places_the_nominal_poles():
    """Every point of the box names a controller whose nominal closed loop, computed on the
    unscaled polynomials, has exactly the poles the point says; ``point`` inverts it."""
    p, ctx, setup, _ = _setup()
    sp = PoleSpace.of(ctx, setup)
    assert sp.dim == setup.n_x == 6 and sp.n_youla == 1
    th = np.random.default_rng(0).uniform(size=(5, sp.dim))
    X = sp.controllers(th)
    am = sp.poles(th)
    ref = p.family.reference_model
    for x, a, t in zip(X, am, th):
        c = ctx.controller(x)
        D = np.polyadd(np.polymul(ref.A, c.S), np.polymul(ref.B, c.R))
        want = np.sort_complex(np.roots(a) * ctx.w0)
        got = np.sort_complex(np.roots(D))
        assert np.allclose(got, want, rtol=1e-6)
        back = sp.point(x)
        assert back is not None
        assert np.allclose(sp.controllers(back[None])[0], x, rtol=1e-6, atol=1e-9)


def _dense_worst(p, ctx, setup, x):
    """The worst peak ratio on a dense grid of the unscaled continuous loops (the screen's
    bounds: the program's, with its margin)."""
    c = ctx.controller(x)
    w = np.geomspace(1.0, 1e7, 200_000)
    s = 1j * w
    worst = 0.0
    for m in p.family.models:
        D = np.polyval(np.polyadd(np.polymul(m.A, c.S), np.polymul(m.B, c.R)), s)
        for key, N in (("S", np.polymul(m.A, c.S)), ("T", np.polymul(m.B, c.R)),
                       ("U", np.polymul(m.A, c.R))):
            worst = max(worst, np.max(np.abs(np.polyval(N, s) / D)) / setup.bounds[key])
    return worst


def test_screen_figures_against_a_dense_grid_and_python_control():
    """The screen's worst peak ratio is at most the dense grid's and close to it; its
    stability verdict is that of the roots; its overshoot that of python-control."""
    import control

    p, ctx, setup, start = _setup()
    cont = [m for m in setup.models if True][: len(p.family.models)]
    setup_c = ctx.setup(program_models(p), ctx.nu, "free")
    scr = Screen(setup_c, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup_c)
    base = sp.point(ctx.param.vector(start.controller))
    th = np.clip(base + 0.05 * np.random.default_rng(1).standard_normal((12, sp.dim)), 0, 1)
    X = sp.controllers(th)
    f = scr.rate(X)
    assert len(cont) == 3
    for k in range(len(X)):
        c = ctx.controller(X[k])
        stable = all(np.all(np.roots(np.polyadd(np.polymul(m.A, c.S), np.polymul(m.B, c.R))).real
                            < 0) for m in p.family.models)
        if not stable:
            continue
        dense = _dense_worst(p, ctx, setup_c, X[k])
        assert f.worst[k] <= dense * (1 + 1e-9) or f.worst[k] > 1.0   # sampled loops count too
        if f.examined[k] and np.isfinite(f.overshoot[k]):
            over = 0.0
            for m in p.family.models:
                D = np.polyadd(np.polymul(m.A, c.S), np.polymul(m.B, c.R))
                sysy = control.tf(np.polymul(m.B, [c.R[-1]]), D)
                t = np.linspace(0, 40.0 / np.min(-np.roots(D).real), 40001)
                y = np.asarray(control.step_response(sysy, T=t).outputs).ravel()
                over = max(over, y.max() / y[-1] - 1.0)
            assert f.overshoot[k] == pytest.approx(over, abs=0.02)


@pytest.mark.parametrize("spread", [0.02, 0.1, 0.3])
def test_rating_only_the_first_places_ranks_them_as_the_full_rating(spread):
    """``rate(X, top=mu)`` skips the roots and steps of candidates that cannot reach the
    first ``mu`` places: those places (what the CMA-ES recombines) are those of the full
    rating, in the same order; a skipped candidate's violation is at most its full one and
    ranks after place ``mu``."""
    p, ctx, setup, start = _setup()
    scr = Screen(setup, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup)
    base = sp.point(ctx.param.vector(start.controller))
    rng = np.random.default_rng(11)
    skipped = 0
    for lam in (14, 28, 56):
        th = np.clip(base + spread * rng.standard_normal((lam, sp.dim)), 0, 1)
        X = sp.controllers(th)
        full, lazy = scr.rate(X), scr.rate(X, top=lam // 2)
        mu = lam // 2
        assert np.array_equal(full.order()[:mu], lazy.order()[:mu])
        assert np.all(lazy.violation <= full.violation)
        assert np.array_equal(lazy.objective, full.objective)
        gone = full.examined & ~lazy.examined
        skipped += int(gone.sum())
        assert not np.isin(np.flatnonzero(gone), full.order()[:mu]).any()
        same = lazy.examined
        assert np.array_equal(lazy.violation[same], full.violation[same])
    if spread >= 0.1:
        assert skipped > 0          # the wide populations: some candidates were skipped


def test_cmaes_finds_known_minima():
    """A shifted ellipsoid and Rosenbrock's function in the unit box (minimum known)."""
    for fun, opt in ((lambda x: np.sum(np.arange(1, 6) ** 2 * (x - 0.3) ** 2, axis=1),
                      np.full(5, 0.3)),
                     (lambda x: np.sum(100 * (0.5 * x[:, 1:] - (0.5 * x[:, :-1]) ** 2) ** 2
                                       + (1 - 0.5 * x[:, :-1]) ** 2, axis=1) + 0.0,
                      np.full(4, 2.0))):
        es = CMAES(np.full(len(opt), 0.5), 0.3, np.random.default_rng(7), 12)
        best = np.inf
        for _ in range(600):
            X = es.ask()
            v = fun(X)
            best = min(best, v.min())
            es.tell(X, np.argsort(v))
        if opt[0] <= 1.0:
            assert np.allclose(es.mean, opt, atol=1e-3)
        else:          # Rosenbrock's minimum (x = 2 in the box's units) is outside: a face
            assert best < fun(np.full((1, len(opt)), 0.5))[0]


def _ridge_generations(active, seed, d=8, width=0.02, limit=300):
    """Generations until a feasible sample reaches ``x0 > 0.95`` on a narrow ridge: maximise
    ``x0`` subject to ``|x_i - x0| <= width`` (the optimum: every coordinate 1), ranked by
    Deb's rules as the search ranks its populations."""
    es = CMAES(np.full(d, 0.2), 0.1, np.random.default_rng(seed), 12, active)
    for g in range(limit):
        X = es.ask()
        viol = np.sum(np.maximum(np.abs(X[:, 1:] - X[:, :1]) - width, 0.0), axis=1)
        es.tell(X, np.lexsort((-X[:, 0], viol)))
        assert np.all(np.linalg.eigvalsh(es.C) > 0)       # negative weights keep C definite
        if np.any(X[viol == 0, 0] > 0.95):
            return g
    return limit


def test_active_update_climbs_a_constraint_ridge_faster():
    """The active covariance update (negative weights for the worse half) against the plain
    rank-mu update on a ridge made by constraints: the infeasible samples teach the
    distribution the constraints' normals.  Measured: median 86 against 112 generations
    over ten seeds."""
    plain = np.median([_ridge_generations(False, s) for s in range(10)])
    active = np.median([_ridge_generations(True, s) for s in range(10)])
    assert active <= 0.85 * plain, (active, plain)


def test_search_is_seeded_and_reports():
    p, ctx, setup, start = _setup()
    scr = Screen(setup, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup)
    one = SearchOptions(seed=5, restarts=1)
    runs = [global_search(scr, sp, [("analytic", ctx.param.vector(start.controller))],
                          options=one) for _ in range(2)]
    a, b = (r.candidates[0] for r in runs)
    assert np.array_equal(a.xc, b.xc) and a.objective == b.objective
    d = runs[0].as_dict()
    assert d["method"] == "CMA-ES" and d["evaluations"] > 0 and d["candidates"]
    stopped = global_search(scr, sp, [], options=SearchOptions(seed=5), stop=lambda: True)
    assert stopped.stopped and stopped.evaluations == 0


@pytest.mark.slow
def test_screen_overshoot_of_the_sampled_loop_against_python_control():
    """With a sampling rate, the screen's overshoot covers the sampled loop at its samples:
    python-control's discrete loop (ZOH plant behind a sample of delay, Tustin controller)
    simulated sample by sample. The sampled loop overshoots more than the continuous one
    on some of these candidates, so the figure cannot come from the continuous models alone
    (the screen samples each step at 120 instants: it may miss the peak by a little)."""
    import control

    fs, k = 20000.0, 1
    doc = {**DOC, "specs": {**DOC["specs"], "sample_rate_hz": fs, "delay_samples": k}}
    p, ctx, setup, start = _setup(doc)
    scr = Screen(setup, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup)
    found = global_search(scr, sp, [("analytic", ctx.param.vector(start.controller))],
                          options=SearchOptions(seed=5, restarts=1))
    base = found.candidates[0].theta      # near the specs: the steps are examined
    th = np.clip(base + 0.02 * np.random.default_rng(2).standard_normal((16, sp.dim)), 0, 1)
    X = sp.controllers(th)
    f = scr.rate(X)
    z = control.tf([1.0, 0.0], [1.0], 1.0 / fs)
    checked = above = 0
    for i in range(len(X)):
        if not (f.examined[i] and np.isfinite(f.overshoot[i])):
            continue
        c = ctx.controller(X[i])
        over_c = over_d = 0.0
        for m in p.family.models:
            D = np.polyadd(np.polymul(m.A, c.S), np.polymul(m.B, c.R))
            horizon = 40.0 / np.min(-np.roots(D).real)
            t = np.linspace(0, horizon, 8001)
            cl = control.tf(np.polymul(m.B, [c.R[-1]]), D)
            y = np.asarray(control.step_response(cl, T=t).outputs).ravel()
            # over the final value (the loop's gain at 0 Hz), not the last sample: a sampled
            # loop may ring longer than the continuous loop's horizon
            over_c = max(over_c, y.max() / float(np.real(cl.dcgain())) - 1.0)
            Pd = control.c2d(control.tf(list(m.B), list(m.A)), 1.0 / fs, "zoh") * (1 / z) ** k
            Kr = control.c2d(control.tf(list(c.R), list(c.S)), 1.0 / fs, "tustin")
            Kt = control.c2d(control.tf([c.R[-1]], list(c.S)), 1.0 / fs, "tustin")
            loop = control.minreal(Kt * control.feedback(Pd, Kr), verbose=False)
            n = int(np.ceil(horizon * fs))
            yd = np.asarray(control.step_response(loop, T=np.arange(n) / fs).outputs).ravel()
            over_d = max(over_d, yd.max() / float(np.real(loop.dcgain())) - 1.0)
        assert f.overshoot[i] == pytest.approx(max(over_c, over_d), abs=0.01)
        checked += 1
        above += over_d > over_c + 0.002
    print(f"checked {checked}, sampled above continuous {above}")
    assert checked >= 4 and above >= 2


@pytest.mark.slow
def test_move_inside_brings_a_boundary_candidate_inside_the_specs():
    """A candidate the search leaves on the boundary of the specs, moved inside a screen
    3 % tighter (peaks and reference step): on a dense grid of the unscaled loops its worst
    peak is then inside the tightened specs, and so is python-control's overshoot, its
    integral gain close to the candidate's (the narrow run stops by a run's rules once
    inside: 1.08x the candidate's 4.20 M; stopped 10 generations after it got inside, it
    kept 61-77 %)."""
    from dataclasses import replace

    import control

    p, ctx, setup, start = _setup()
    ctx = replace(ctx, free_margin=1.0)
    setup = ctx.setup(program_models(p), ctx.nu, "free")
    ts = time_specs(p, ctx.w0)
    scr = Screen(setup, ts)
    sp = PoleSpace.of(ctx, setup)
    found = global_search(scr, sp, [("analytic", ctx.param.vector(start.controller))],
                          options=SearchOptions(seed=5, restarts=1))
    cand = found.candidates[0]
    tight = Screen(replace(ctx, free_margin=0.97).setup(program_models(p), ctx.nu, "free"),
                   replace(ts, overshoot=0.97 * ts.overshoot))
    assert cand.violation == 0 and tight.rate(cand.xc[None]).violation[0] > 0
    moved = move_inside(tight, sp, cand)
    assert moved is not None and moved.violation == 0
    assert _dense_worst(p, ctx, setup, moved.xc) < 0.97 * 1.002
    c = ctx.controller(moved.xc)
    for m in p.family.models:
        D = np.polyadd(np.polymul(m.A, c.S), np.polymul(m.B, c.R))
        t = np.linspace(0, 40.0 / np.min(-np.roots(D).real), 20001)
        y = np.asarray(control.step_response(control.tf(np.polymul(m.B, [c.R[-1]]), D),
                                             T=t).outputs).ravel()
        assert y.max() / y[-1] - 1.0 < 0.97 * ts.overshoot + 0.003
    ki = [abs(ctx.controller(x).R[-1] / ctx.controller(x).S[-2]) for x in (cand.xc, moved.xc)]
    assert ki[1] > 0.8 * ki[0]


def test_screen_sees_the_sampled_loops_high_frequency_control_effort():
    """The high-frequency |U| band of a sampled loop rises to Nyquist: the screen's grid
    there is as dense as below (it had three points between the corner and Nyquist, and
    paper_robust's screened candidates were refused by the certificate at 1.7-3.6 % above
    the 50 V/um bound). Against the certificate's exact peaks (Hamiltonian level sets, its
    own code) on one model, for candidates without a lightly damped closed-loop root (whose
    sharp peaks the screen finds from the roots): the screen's ratio is at most the
    certificate's, within 1 %."""
    from dataclasses import replace as _replace

    from robrst.certificate.proof import certify_problem

    doc = {**DOC, "family": {"temperatures_C": [25.0]},
           "specs": {**DOC["specs"], "sample_rate_hz": 20000.0, "Mu_hf_max": 50.0,
                     "Mu_hf_above_hz": 2000.0, "Mu_max": 1e4}}
    p, ctx, setup, start = _setup(doc)
    only = _replace(setup, bounds={k: (v if k == "Uhf" else None)
                                   for k, v in setup.bounds.items()}, model_bounds=None)
    scr = Screen(only)
    sp = PoleSpace.of(ctx, setup)
    base = sp.point(ctx.param.vector(start.controller))
    th = np.clip(base + 0.05 * np.random.default_rng(3).standard_normal((20, sp.dim)), 0, 1)
    X = sp.controllers(th)
    got = scr.peaks(X) * setup.bounds["Uhf"] / 50.0      # the ratio to the spec itself
    damping = Screen(setup).rate(X).damping
    checked = 0
    for k in range(len(X)):
        if not damping[k] >= 0.3:     # sharp resonances: the screen's modal check's
            continue
        r = certify_problem(p, ctx.controller(X[k])).ratios()
        exact = max(r.get("Mu_hf", 0.0), r.get("Mu_hf_sampled", 0.0))
        if not np.isfinite(exact) or "Ms" not in r:
            continue
        assert got[k] <= exact * (1 + 1e-6)
        assert got[k] >= 0.99 * exact, (k, got[k], exact)
        checked += 1
    assert checked >= 5


def test_a_polishs_objective_floor_is_the_integral_gain_of_the_unscaled_controller():
    """The polish keeps its start's integral gain by one linear row of the scaled program
    (``R(0) >= floor (S/s^k)(0)``): on controllers around the start, the row holds exactly
    where the unscaled controller's integral gain (``lim s R/S`` of its polynomials) is at
    least the floor's share of the start's."""
    from robrst.synthesis.attempts import Run
    from robrst.synthesis._nlp import objective_rows
    from robrst.synthesis.parametrize import integral_gain

    p, ctx, setup, start = _setup()
    x0 = ctx.param.vector(start.controller)
    r0, q0, q0c = objective_rows(setup)
    run = Run(p, lambda m: None, {})
    run.floor = 0.9 * float(r0 @ x0) / float(q0 @ x0 + q0c)
    row = run.floor_row(setup)
    assert row is not None and row.A.shape == (1, x0.size)
    ki0 = integral_gain(ctx.controller(x0))
    rng = np.random.default_rng(7)
    sides = set()
    for _ in range(200):
        x = x0 * (1 + 0.1 * rng.standard_normal(x0.size))
        if not float(q0 @ x + q0c) > 0:
            continue
        holds = float(row.A[0] @ x + row.c[0]) <= 0
        ki = integral_gain(ctx.controller(x))
        if abs(ki / (0.9 * ki0) - 1) < 1e-9:
            continue
        assert holds == (ki >= 0.9 * ki0), (ki, ki0)
        sides.add(holds)
    assert sides == {True, False}
    run.floor = None
    assert run.floor_row(setup) is None


@pytest.mark.slow
def test_each_run_has_its_own_random_stream():
    """A run's samples do not depend on the runs before it: the second run's best point is
    the same whether the first run started from the problem's design or from a random
    mean (it shared one stream with the first run, whose length moved every later sample)."""
    p, ctx, setup, start = _setup()
    scr = Screen(setup, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup)
    named = global_search(scr, sp, [("analytic", ctx.param.vector(start.controller))],
                          options=SearchOptions(seed=5, restarts=2))
    blind = global_search(scr, sp, [], options=SearchOptions(seed=5, restarts=2))

    def second(res):
        return next(c for c in res.candidates if c.name.startswith("global run 2"))
    assert np.array_equal(second(named).theta, second(blind).theta)
    first = [next(c for c in r.candidates if c.name.startswith("global run 1"))
             for r in (named, blind)]
    assert not np.array_equal(first[0].theta, first[1].theta)


def test_quadratic_powers_equal_the_exponential_on_the_step_grid():
    """The screened steps' modes on their quadratic time grid (two running products)
    against numpy's complex exponential at every instant: stable modes over six decades
    of rate, real, complex and conjugate, to 1e-10 relative; a mode whose rate is not
    finite is not finite either."""
    from robrst.synthesis._screen import STEP_POINTS, quadratic_powers

    rng = np.random.default_rng(8)
    K, M, n = 30, 6, 7
    re = -np.exp(rng.uniform(-4.0, 3.0, (K, M, n)))
    im = np.exp(rng.uniform(-4.0, 4.0, (K, M, n))) * rng.choice([-1.0, 0.0, 1.0], (K, M, n))
    rate = re + 1j * im
    t_end = np.minimum(10.0 / np.min(-rate.real, axis=2), 1e4)
    tau = t_end[..., None] * np.linspace(0.0, 1.0, STEP_POINTS) ** 2
    ref = np.exp(rate[..., None] * tau[..., None, :])
    got = quadratic_powers(rate, t_end)
    assert got.shape == ref.shape
    assert np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-300)) < 1e-10
    bad = rate.copy()
    bad[0, 0, 0], bad[1, 2, 3] = -np.inf, np.nan
    with np.errstate(all="ignore"):
        out = quadratic_powers(bad, t_end)
    assert not np.isfinite(out[0, 0, 0]).all() and not np.isfinite(out[1, 2, 3]).any()


def test_first_samples_equal_the_powers_sample_by_sample():
    """The screened sampled steps' first samples (blocks of powers, one matrix product)
    against the modal sum taken power by power with numpy: modes from slow to near
    Nyquist (``|z|`` up to 0.999, angles up to pi), real and complex weights, to 1e-12 of
    the weights' size; a mode that is not finite makes its samples after the first (``z^0 =
    1``) not finite."""
    from robrst.synthesis._screen import PEAK_SAMPLES, first_samples

    rng = np.random.default_rng(11)
    K, M, n = 20, 5, 6
    z = rng.uniform(0.2, 0.999, (K, M, n)) * np.exp(1j * rng.uniform(-np.pi, np.pi, (K, M, n)))
    z[:, :, 0] = z[:, :, 0].real            # a real mode in every loop
    c = rng.normal(size=(K, M, n)) + 1j * rng.normal(size=(K, M, n))
    k = np.arange(PEAK_SAMPLES)
    ref = np.stack([np.sum(c * z ** j, axis=2).real for j in k], axis=-1)
    got = first_samples(c, z)
    assert got.shape == (K, M, PEAK_SAMPLES)
    assert np.max(np.abs(got - ref)) < 1e-12 * np.max(np.abs(c)) * n
    z[0, 0, 1] = np.nan
    with np.errstate(all="ignore"):
        assert not np.isfinite(first_samples(c, z)[0, 0, 1:]).any()


def test_the_symbolic_pole_map_places_the_nominal_poles():
    """``PoleSpace.symbolic`` (the CasADi map the polish over the poles solves through),
    evaluated at points of the box, names controllers whose nominal closed loop on the
    unscaled polynomials has the poles the point says, on a 2nd-order stage (one Youla
    degree) and a 4th-order one (several pairs)."""
    import casadi as ca

    from stages_global import stage_doc

    for doc in (DOC, stage_doc(32, order=4)):
        p, ctx, setup, _ = _setup(doc)
        sp = PoleSpace.of(ctx, setup)
        T = ca.MX.sym("theta", sp.dim)
        fn = ca.Function("map", [T], [sp.symbolic(T)])
        th = np.random.default_rng(4).uniform(0.2, 0.8, size=(4, sp.dim))
        am = sp.poles(th)
        ref = p.family.reference_model
        for t, a in zip(th, am):
            x = np.array(fn(t)).ravel()
            assert np.allclose(x, sp.controllers(t[None])[0], rtol=1e-9, atol=1e-12)  # Youla too
            c = ctx.controller(x)
            D = np.polyadd(np.polymul(ref.A, c.S), np.polymul(ref.B, c.R))
            want = np.sort_complex(np.roots(a) * ctx.w0)
            got = np.sort_complex(np.roots(D))
            assert np.allclose(got, want, rtol=1e-6), (got, want)


@pytest.mark.parametrize("chained", [False, True])
def test_a_solve_over_the_poles_stays_in_its_box_and_meets_the_specs(chained):
    """The program solved over the poles (``MappedTemplates``, with CasADi's derivatives
    and with the chained ones) from a candidate of a short search (within the specs on
    the screen):
    the answer is the controller of a point inside the box, its nominal poles those of the
    point on the unscaled polynomials, and its peaks on a dense grid of the unscaled loops
    within the program's bounds; its integral gain is not below the start's."""
    from robrst.synthesis._nlp import objective_rows
    from robrst.synthesis.exchange import Phase, solve_exchange
    from robrst.synthesis.template import MappedTemplates

    p, ctx, setup, start = _setup()
    sp = PoleSpace.of(ctx, setup)
    found = global_search(Screen(setup), sp, [("analytic", ctx.param.vector(start.controller))],
                          options=SearchOptions(seed=5, restarts=1, generations=100))
    cand = found.candidates[0]
    assert cand.violation == 0
    th0 = cand.theta
    x0 = np.concatenate([sp.controllers(th0[None])[0], [1.0]])
    lo, hi = np.clip(th0 - 0.03, 0, 1), np.clip(th0 + 0.03, 0, 1)
    maps = MappedTemplates({}, sp, lo, hi, chained=chained)
    res = solve_exchange(setup, x0, ctx.ipopt, Phase("hard"), maps, exact=True)
    assert res.success, res.status
    th = maps.memo[res.x[:-1].tobytes()]
    assert np.all(th >= lo - 1e-7) and np.all(th <= hi + 1e-7)    # IPOPT relaxes bounds by 1e-8
    c = ctx.controller(res.x)
    ref = p.family.reference_model
    D = np.polyadd(np.polymul(ref.A, c.S), np.polymul(ref.B, c.R))
    assert np.allclose(np.sort_complex(np.roots(D)),
                       np.sort_complex(np.roots(sp.poles(th[None])[0]) * ctx.w0), rtol=1e-6)
    assert _dense_worst(p, ctx, setup, res.x) < 1.0 + 1e-3
    r0, q0, q0c = objective_rows(setup)
    gain = lambda x: float(r0 @ x[:-1]) / float(q0 @ x[:-1] + q0c)   # noqa: E731
    assert gain(res.x) >= gain(x0) * (1 - 1e-9)


def test_edge_space_puts_controller_poles_at_the_strip_edge():
    """Every controller of the edge space has one (two: a double) root of ``S`` at the
    controller-pole strip's edge, on the unscaled ``S`` the design reports."""
    from robrst.synthesis.search import EDGE_INSIDE, EdgeSpace

    p, ctx, setup, _ = _setup()
    scr = Screen(setup, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup)
    shift = setup.ctrl_shift
    assert shift > 0
    edge = -shift * ctx.w0 * (1 + EDGE_INSIDE)           # rad/s
    th = np.random.default_rng(4).uniform(size=(6, sp.dim))
    for roots in (1, 2):
        es = EdgeSpace.of(sp, scr.Lq, scr.q, shift, roots)
        assert es is not None and es.dim == sp.dim
        X = es.controllers(th)
        for x in X:
            r = np.roots(np.asarray(ctx.controller(x).S, float))
            near = np.abs(r - edge) / abs(edge)
            # a simple root to the last digits; a double one splits by the square root
            # of the coefficients' rounding (the controller's other coefficients are
            # 1e5 times larger here)
            assert np.sum(near < (1e-6 if roots == 1 else 1e-2)) >= roots, (roots, r)
    # more roots than the free polynomial has: no space
    assert EdgeSpace.of(sp, scr.Lq, scr.q, shift, scr.Lq.shape[0]) is None


def test_edge_runs_are_on_unless_a_file_turns_them_off():
    """``[solver] edge_runs``: true by default (since 2026-12-07), ``false`` is kept."""
    assert parse_problem(DOC, "<g>").solver.edge_runs
    off = {**DOC, "solver": {**DOC.get("solver", {}), "edge_runs": False}}
    assert not parse_problem(off, "<g>").solver.edge_runs


def test_edge_runs_join_the_search_only_when_asked():
    p, ctx, setup, start = _setup()
    scr = Screen(setup, time_specs(p, ctx.w0))
    sp = PoleSpace.of(ctx, setup)
    opts = SearchOptions(seed=5, restarts=1, generations=30)
    plain = global_search(scr, sp, [], options=opts)
    edged = global_search(scr, sp, [], options=SearchOptions(
        seed=5, restarts=1, generations=30, edge_roots=(1, 2)))
    assert plain.runs == 1 and edged.runs == 1 + 2 * min(2, scr.Lq.shape[0] - 1)
    assert any("strip's edge" in c.name for c in edged.candidates)
    assert not any("strip's edge" in c.name for c in plain.candidates)
    # a candidate's outcomes carry its name before their first comma (the basins polished
    # again are told apart by it)
    assert not any(", " in c.name for c in edged.candidates + plain.candidates)
    # the first run is the same run either way (its own random stream)
    first = [next(c for c in r.candidates if c.name.startswith("global run 1")).theta
             for r in (plain, edged)]
    assert np.array_equal(*first)


def test_the_program_over_the_poles_has_the_composed_programs_derivatives():
    """The derivatives a :class:`MappedTemplate` hands IPOPT (the chain rule through the
    coefficient program's own: gradient, constraint Jacobian, Lagrangian Hessian) equal
    CasADi's derivatives of the composed program ``program(m(theta), rest)``, at random
    points, parameters and multipliers."""
    import casadi as ca

    from robrst.synthesis.context import ipopt_options
    from robrst.synthesis.template import MappedTemplate, Structure, Template

    p, ctx, setup, _ = _setup()
    sp = PoleSpace.of(ctx, setup)
    st = Structure(nx=setup.n_x, placement="free", deg_eq=0, n_dom_real=0,
                   groups=((setup.n_x + 1, 3),), slots=7, ctrl_deg=2,
                   ipopt=tuple(sorted(ipopt_options(p.solver).items())), lin=2)
    base = Template(st)
    mt = MappedTemplate(base, sp, np.zeros(sp.dim), np.ones(sp.dim), {}, chained=True)
    T, rest = ca.MX.sym("t", sp.dim), ca.MX.sym("r", st.n_var - st.nx)
    P, lf, lg = ca.MX.sym("p", base.n_p), ca.MX.sym("lf"), ca.MX.sym("lg", base.n_g)
    X = ca.vertcat(T, rest)
    f, g = base.program(ca.vertcat(sp.symbolic(T), rest), P)
    ref = ca.Function("ref", [X, P, lf, lg], [ca.gradient(f, X), ca.jacobian(g, X),
                                              ca.hessian(lf * f + ca.dot(lg, g), X)[0]])
    rng = np.random.default_rng(11)
    for _ in range(3):
        values = {k: rng.uniform(0.5, 1.5, size=shape) for k, (_, shape) in base.layout.items()}
        values["rho"] = np.array([rng.uniform()])
        x = np.concatenate([rng.uniform(0.1, 0.9, sp.dim), rng.uniform(0.5, 2, st.n_var - st.nx)])
        pv, lam_f, lam_g = base.pack(values), rng.normal(), rng.normal(size=base.n_g)
        grad_r, jac_r, hess_r = (np.array(v) for v in ref(x, pv, lam_f, lam_g))
        grad = np.array(mt.solver.get_function("nlp_grad_f")(x, pv)[1]).ravel()
        jac = np.array(mt.solver.get_function("nlp_jac_g")(x, pv)[1])
        hess = np.array(ca.triu2symm(mt.solver.get_function("nlp_hess_l")(x, pv, lam_f, lam_g)))
        for got, want in ((grad, grad_r.ravel()), (jac, jac_r), (hess, hess_r)):
            assert np.all(np.isfinite(want))
            assert np.allclose(got, want, rtol=1e-8, atol=1e-9 * np.max(np.abs(want)))
