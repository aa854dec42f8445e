"""Robust NLP: analytic check, certificate independence, infeasibility, family stability."""

from dataclasses import replace

import control
import numpy as np
import pytest

from robrst.core import poly
from robrst.certificate.proof import certify_problem
from robrst.design import analytic_design, run_problem, with_time_domain
from robrst.design.candidate import LOCAL_RUN_NOTE
from robrst.core.rst import RSTController, closed_loop
from robrst.problem.files import load_problem
from robrst.synthesis.outcome import worst_violation

NOMINAL_NLP = """
[plant]
name = "paper"
[poles]
wn = {wn}
zeta = {zeta}
[controller]
extra_degree = 0
[solver]
method = "nlp"
objective = "feasibility"
"""


@pytest.mark.parametrize("wn,zeta", [(600.0, 1.0), (1000.0, 0.7), (2500.0, 0.9)])
def test_nlp_reproduces_sylvester_solution(tmp_path, wn, zeta):
    f = tmp_path / "nominal.toml"
    f.write_text(NOMINAL_NLP.format(wn=wn, zeta=zeta))
    pr = load_problem(f)
    res = run_problem(pr)
    ref = analytic_design(pr).controller
    assert res.analytic_check.kind == "sylvester_coefficients"
    assert res.analytic_check.passed and res.analytic_check.max_rel_coef_error <= 1e-8
    # and independently of the reported number
    assert poly.rel_coef_error(res.controller.R, ref.R) <= 1e-8
    assert poly.rel_coef_error(res.controller.S, ref.S) <= 1e-8


def test_paper_robust_is_certified_and_meets_every_spec(robust_result):
    """The main job: the 20 kHz sampled loop, roll-off, |U| above 2 kHz, step-response specs."""
    r = robust_result
    assert r.certified
    assert r.controller.S[-1] == 0.0  # integrator: zero static error
    assert len(r.controller.R) < len(r.controller.S)   # strictly proper: roll-off
    sp = r.problem.specs
    assert sp.sampled and sp.time_domain and sp.Mu_hf_max is not None
    for m in r.certificate.models:
        for loop in ("continuous", "sampled"):
            v = lambda k: m.value(k, loop)                  # noqa: E731
            assert v("stable") and v("spectral_abscissa") < 0
            assert v("Ms") <= sp.Ms_max * (1 + 1e-3)
            assert v("Mt") <= sp.Mt_max * (1 + 1e-3)
            assert v("Mu") <= sp.Mu_max * (1 + 1e-3)
            assert v("Mt_resonance_band") <= 1.0 * (1 + 1e-3)
            assert v("Mu_hf") <= sp.Mu_hf_max * (1 + 1e-3)
            assert v("overshoot_pct") <= sp.overshoot_max_pct * (1 + 1e-3)
            assert v("settling_time_s") <= sp.settling_time_max_s
            assert v("step_u_peak_V") <= sp.step_u_max_V
    temps = [m.temperature_C for m in r.certificate.models]
    assert min(temps) == 28.0 and max(temps) == 45.0 and len(temps) >= 30
    # the global phase ran: the answer is not called a local run's
    assert r.starts is not None and LOCAL_RUN_NOTE not in r.synthesis.notes


def test_certificate_independent_recomputation(robust_result):
    """Recompute every certified peak on a dense grid + local refinement."""
    from scipy.optimize import minimize_scalar

    r = robust_result
    fam = r.problem.family
    w = np.logspace(-1, 7, 100_001)
    for rec in r.certificate.models[::4]:
        plant = fam.at(rec.temperature_C)
        cl = closed_loop(plant, r.controller)
        for name, key in (("S", "Ms"), ("T", "Mt"), ("U", "Mu")):
            N, D = cl.tf(name)
            g = np.abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w))
            i = int(np.argmax(g))
            lw = np.log(w[i])
            f = lambda x: -abs(np.polyval(N, 1j * np.exp(x)) / np.polyval(D, 1j * np.exp(x)))  # noqa: E731
            ref = max(g[i], -minimize_scalar(f, bounds=(lw - 0.01, lw + 0.01), method="bounded",
                                             options={"xatol": 1e-12}).fun)
            if rec.value(f"{key}_freq_rad_s") is None:  # peak at infinity: |N/D|(inf)
                ref = max(ref, abs(N[0] / D[0]) if len(N) == len(D) else 0.0)
            assert rec.value(key) == pytest.approx(ref, rel=1e-6)
        # stability from the companion eigenvalues, not np.roots
        Dn = cl.Delta / cl.Delta[0]
        w0 = poly.natural_scale(Dn)
        C = np.diag(np.ones(len(Dn) - 2), -1)
        Ds = poly.to_scaled(Dn, w0)
        C[0, :] = -(Ds / Ds[0])[1:]
        assert np.max(np.linalg.eigvals(C).real) * w0 == pytest.approx(rec.continuous.spectral_abscissa,
                                                                       rel=1e-6, abs=1e-9)


@pytest.mark.slow
def test_two_dof_spectral_abscissae_are_those_of_the_whole_loops(robust_result):
    """The 2-DOF controller's R and S carry the reference model: every closed-loop
    polynomial gained its roots.  The certificate's abscissae (the feedback's, joined by
    the reference model's) are those of the whole loops, continuous and sampled, from
    companion eigenvalues of the 2-DOF controller's closed-loop polynomial."""
    r = robust_result
    fam, sp = r.problem.family, r.problem.specs
    assert r.tracking is not None and len(r.tracking.Am_ref) >= 3
    for rec in r.certificate.models[::3]:
        plant = fam.at(rec.temperature_C)
        for pl, loop in ((plant, "continuous"),
                         (fam.sampled(plant, sp.sample_rate_hz, sp.delay_samples), "sampled")):
            Dn = closed_loop(pl, r.controller).Delta
            Dn = Dn / Dn[0]
            w0 = poly.natural_scale(Dn)
            Ds = poly.to_scaled(Dn, w0)
            C = np.diag(np.ones(len(Dn) - 2), -1)
            C[0, :] = -(Ds / Ds[0])[1:]
            assert np.max(np.linalg.eigvals(C).real) * w0 == pytest.approx(
                rec.value("spectral_abscissa", loop), rel=1e-6, abs=1e-9), (rec.temperature_C, loop)
    # a factor slower than every loop pole (-0.5 rad/s): each abscissa becomes its root,
    # given as the factor or found in each closed-loop polynomial
    f = np.array([1.0, 0.5])
    c = r.controller
    slow = RSTController(R=poly.pmul(c.R, f), S=poly.pmul(c.S, f), T=poly.pmul(c.T, f))
    for cert in (with_time_domain(r.problem, r.certificate, slow, factor=f),
                 with_time_domain(r.problem, r.certificate, slow)):
        for rec in cert.models:
            for loop in ("continuous", "sampled"):
                assert rec.value("spectral_abscissa", loop) == pytest.approx(-0.5, rel=1e-9)


def test_robust_beats_analytic_on_integral_gain(robust_result):
    rows = robust_result.comparison.rows
    rob = rows["robust"]
    ana = rows["analytic (paper.toml)"]
    assert rob["certified"]
    assert rob["integral_gain"] > 1.5 * ana["integral_gain"]
    assert rob["worst_Ms"] <= 2.0 * (1 + 1e-3)


def _variant(tmp_path, problems_dir, name, **repl):
    text = (problems_dir / "paper_robust_continuous.toml").read_text().replace(
        'compare_with = "paper.toml"', "")
    for a, b in repl.items():
        text = text.replace(a, b)
    f = tmp_path / name
    f.write_text(text)
    return load_problem(f)


def test_a_priori_infeasible_specs_still_give_the_best_controller(tmp_path, problems_dir):
    """|T(0)| = 1 > Mt_max: provably infeasible; the synthesis is skipped, the answer is the
    analytic start (a controller, not_certified), the proof in ``feasibility`` and what the
    controller achieves in best_achievable."""
    pr = _variant(tmp_path, problems_dir, "tight_t.toml", **{"Mt_max = 1.3": "Mt_max = 0.5"})
    res = run_problem(replace(pr, solver=replace(pr.solver, placement="fixed", max_iter=100)))
    assert res.status == "not_certified" and not res.certified
    assert res.feasibility.status == "infeasible"
    reason = res.feasibility.proofs[0].reason
    assert "model T28C" in reason and "T(0) = 1" in reason and "Mt_max = 0.5" in reason
    assert len({p.model for p in res.feasibility.proofs}) == len(pr.family.models)
    assert res.best_achievable.startswith("best achievable: model ")
    worst = worst_violation(res.certificate)
    assert res.best_achievable == ("best achievable: " + worst.describe()
                                   + " (the analytic start, returned because no linear"
                                   " controller meets the specs)")
    # the controller reported is the analytic start, certified independently here
    start_ctrl = analytic_design(pr).controller
    for a, b in ((res.controller.R, start_ctrl.R), (res.controller.S, start_ctrl.S)):
        assert np.allclose(a, b, rtol=1e-9, atol=0)
    start = worst_violation(certify_problem(pr, start_ctrl))
    assert start.quantity == "|T| peak" and start.value / start.bound > 3.2
    d = res.as_dict()
    assert d["status"] == "not_certified" and d["best_achievable"] == res.best_achievable
    assert d["feasibility"]["status"] == "infeasible"


@pytest.mark.slow
def test_unreachable_specs_give_the_best_controller_and_the_binding_constraints(tmp_path,
                                                                              problems_dir):
    """Mu_max = 1.6 V/µm cannot be met: exit 1, the best controller, binding constraints named."""
    text = (problems_dir / "paper_robust_continuous.toml").read_text().replace(
        'compare_with = "paper.toml"', "")
    text = text.replace("Mu_max = 150.0", "Mu_max = 1.6").replace("n_freq = 120", "n_freq = 40")
    text = text.replace("[solver]", '[solver]\nmax_iter = 150\nplacement = "fixed"')
    f = tmp_path / "tight_u.toml"
    f.write_text(text)
    res = run_problem(load_problem(f))
    assert res.status == "not_certified"
    worst = max(res.certificate.violations, key=lambda v: v.value / v.bound)
    assert worst.quantity == "|U| peak" and worst.value > 1.6
    assert res.best_achievable == "best achievable: " + worst.describe()
    assert any("|U| peak" in b for b in res.as_dict()["solver"]["binding"])


SHAPING = """
[plant]
name = "paper"
[poles]
wn = 1000.0
zeta = 0.9
[controller]
extra_degree = 2
[specs]
Mt_max = 1.3
Mu_max = 150.0
[solver]
method = "{method}"
objective = "min_Ms"
n_freq = 150
"""


def test_convex_and_nlp_agree_on_nominal_shaping(tmp_path):
    res = {}
    for method in ("convex", "nlp"):
        f = tmp_path / f"{method}.toml"
        f.write_text(SHAPING.format(method=method))
        res[method] = run_problem(load_problem(f))
        assert res[method].analytic_check.passed
    ms = {k: r.certificate.models[0].continuous.Ms for k, r in res.items()}
    # two different solvers (SOCP interior point vs IPOPT) on the same grid: same optimum
    assert ms["nlp"] == pytest.approx(ms["convex"], rel=2e-3)
    # both improve on the analytic design with the same Am
    ref = analytic_design(res["nlp"].problem).controller
    from robrst.core.analysis import analyze
    assert ms["nlp"] < analyze(res["nlp"].problem.family.reference_model, ref).peaks["S"].value


def test_convex_initializer_reaches_the_same_optimum(tmp_path, problems_dir):
    """Fixed poles: IPOPT from the SOCP start and from the Sylvester start agree."""
    text = (problems_dir / "paper_robust_continuous.toml").read_text()
    text = text.replace("free_poles = true", "free_poles = false")
    text = text.replace('compare_with = "paper.toml"', "")
    res = {}
    for init in ("analytic", "convex"):
        f = tmp_path / f"{init}.toml"
        f.write_text(text.replace("[solver]", f'[solver]\ninit = "{init}"'))
        # the local program from each start (the global phase, on by default, would
        # answer from its own candidates whatever the start)
        res[init] = run_problem(load_problem(f), multistart=False)
        assert res[init].certified and res[init].analytic_check.passed
        assert LOCAL_RUN_NOTE in res[init].synthesis.notes      # and it says so
    ki = {k: r.integral_gain for k, r in res.items()}
    assert ki["convex"] == pytest.approx(ki["analytic"], rel=1e-6)
    assert poly.rel_coef_error(res["convex"].controller.R, res["analytic"].controller.R) <= 1e-5


def test_convex_answers_when_the_specs_cannot_be_met(tmp_path):
    """Ms, Mt <= 1 and Mu <= 50 cannot be met with this Am: the convex method answers with
    the controller of least worst peak/bound ratio, certified for what it achieves."""
    f = tmp_path / "tight.toml"
    f.write_text(SHAPING.format(method="convex").replace("Mu_max = 150.0", "Mu_max = 50.0")
                 .replace("Mt_max = 1.3", "Ms_max = 1.0\nMt_max = 1.0"))
    res = run_problem(load_problem(f))
    assert res.status == "not_certified" and not res.certified
    assert res.synthesis.notes and "minimised instead" in res.synthesis.notes[0]
    assert res.best_achievable.startswith("best achievable: ")
    m = res.problem.family.reference_model
    P = control.tf(list(m.B), list(m.A))
    w = np.geomspace(1.0, 1e6, 40000)

    def worst_ratio(ctrl):           # independent: python-control's nominal loop
        C = control.tf(list(ctrl.R), list(ctrl.S))
        mag = lambda sys: np.abs(sys(1j * w))  # noqa: E731
        S, T, U = (mag(control.feedback(1, P * C)), mag(control.feedback(P * C, 1)),
                   mag(control.feedback(C, P)))
        return max(S.max() / 1.0, T.max() / 1.0, U.max() / 50.0)

    ratio = worst_ratio(res.controller)
    assert ratio > 1.0                                    # the specs are indeed not met ...
    cert_ratio = max(v.value / v.bound for v in res.certificate.violations)
    assert ratio == pytest.approx(cert_ratio, rel=2e-3)   # ... by what the certificate says
    assert ratio < worst_ratio(analytic_design(res.problem).controller)  # better than the start


def test_convex_answers_when_the_solver_has_no_solution(tmp_path, monkeypatch):
    """CLARABEL stops without a solution (numerical trouble) in both the hard and the soft
    program: the answer is the analytic design (the start), certified for what it achieves,
    with the solver's status in the notes, never a raw solver error."""
    import cvxpy as cp

    def stalls(self, *args, **kwargs):
        self._status = cp.SOLVER_ERROR if hasattr(cp, "SOLVER_ERROR") else "solver_error"

    monkeypatch.setattr(cp.Problem, "solve", stalls)
    monkeypatch.setattr(cp.Problem, "status", property(lambda self: self._status))
    f = tmp_path / "stall.toml"
    f.write_text(SHAPING.format(method="convex"))
    res = run_problem(load_problem(f))
    start = analytic_design(res.problem).controller
    for k in "RST":
        assert np.array_equal(getattr(res.controller, k), getattr(start, k))
    assert "soft program failed too" in res.synthesis.notes[0]
    assert "without a solution" in res.synthesis.notes[0]
    assert res.status in ("certified", "not_certified")


def test_convex_uses_an_inaccurate_optimum_and_certifies_it(tmp_path, monkeypatch):
    """``optimal_inaccurate`` still carries a solution: it is used (no cvxpy warning
    reaches the user) and the independent certificate judges it."""
    import warnings

    import cvxpy as cp

    real = cp.Problem.solve

    def inaccurate(self, *args, **kwargs):
        out = real(self, *args, **kwargs)
        warnings.warn("Solution may be inaccurate.", UserWarning)
        self._status = cp.OPTIMAL_INACCURATE
        return out

    monkeypatch.setattr(cp.Problem, "solve", inaccurate)
    f = tmp_path / "inaccurate.toml"
    f.write_text(SHAPING.format(method="convex"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        res = run_problem(load_problem(f))
    assert not res.synthesis.notes                    # the hard program's answer was used
    assert res.certified and res.analytic_check.passed


def test_the_notes_say_each_thing_once():
    """A run's notes as the design prints them: a note two solves added is given once, and
    the linearised rows' worst ratios of several solves (a polish and its back-offs) are
    one note that keeps every ratio, in order, at the place of the first."""
    from robrst.synthesis.attempts import merged_notes

    def lin(r):
        return ("linearised rows (reference-step samples, damping floors): the worst is"
                f" {r} x its bound after the rounds (the certificate decides)")

    budget = "iteration budget (2500) spent: refinement stopped"
    got = merged_notes(["start", lin("10.6"), budget, lin("3.92"), budget, lin("11"), "end"])
    assert got == ("start",
                   "linearised rows (reference-step samples, damping floors): the worst is"
                   " 10.6, 3.92, 11 x its bound after the rounds of 3 solves (the certificate"
                   " decides)", budget, "end")
    assert merged_notes([lin("1.25"), budget]) == (lin("1.25"), budget)
    assert merged_notes([]) == ()
