"""Robust synthesis: CasADi/IPOPT (exact derivatives) vs scipy SLSQP (finite differences).

On ``paper_robust_continuous`` (the continuous-loop problem: the baseline has no sampled
loop).  The baseline is the code a python-control user would write for the same problem:
the same decision vector and start (the analytic design), the same frequency grid
and models, |S|, |T|, |U| and the resonance-band |T| evaluated with python-control
transfer functions, the Diophantine equality on scaled coefficients, stability as a
spectral-abscissa constraint, ``scipy.optimize.minimize(method="SLSQP")`` with
finite-difference gradients.  Both results go through the same exact certificate.
"""

import os
import subprocess
import sys
import tomllib

import control
import numpy as np
from scipy.optimize import minimize

from benchmarks.harness import BenchResult, alternate, median_ratio
from robrst.core import poly
from robrst.certificate.proof import certify_problem
from robrst.design import analytic_design
from robrst.problem.records import PoleSpec
from robrst.base.resources import builtin_problem
from robrst.problem.files import parse_problem
from robrst.synthesis import robust
from robrst.synthesis.analytic import characteristic_polynomial
from robrst.synthesis.context import BOUND_MARGIN, Context
from robrst.synthesis.parametrize import (Parametrization, TrackingRule, frequency_grid,
                                          integral_gain)

PROBLEM = builtin_problem("paper_robust_continuous")


def first_setup(problem, placement=None):
    """``(context, setup, x0)`` of the problem's first program (analytic start)."""
    start = analytic_design(problem)
    ctx = Context.of(problem, start)
    setup = ctx.setup(list(problem.family.models), ctx.nu, placement or ctx.default_placement())
    return ctx, setup, ctx.full(ctx.param.vector(start.controller), setup)


def load(tiny, n_models=None, n_freq=None):
    """``paper_robust_continuous.toml`` without the comparison; optionally fewer models/freqs."""
    data = tomllib.loads(PROBLEM.read_text())
    data["solver"].pop("compare_with", None)
    if tiny:
        data["family"]["temperatures_C"] = [28.0, 45.0]
        data["solver"]["n_freq"] = 20
        data["solver"]["cert_temperatures"] = 5
    if n_models is not None:
        data["family"]["temperatures_C"] = list(np.linspace(28.0, 45.0, n_models))
    if n_freq is not None:
        data["solver"]["n_freq"] = int(n_freq)
    return parse_problem(data, str(PROBLEM))


def robrst_solve(problem):
    """The robrst path: NLP + certification loop (what ``robrst design`` runs)."""
    res = robust.robust_synthesis(problem, analytic_design(problem))
    return res.controller, res.certificate, res.solver_dict()


def slsqp_solve(problem, maxiter=300):
    """The baseline: SLSQP with finite differences on python-control frequency responses."""
    so, sp = problem.solver, problem.specs
    start = analytic_design(problem)
    Am0 = start.Am
    sc = poly.Scaling.natural(Am0)
    w0 = sc.w0
    ref = problem.family.reference_model
    param = Parametrization.of(problem.controller, ref, sc)
    tb = TrackingRule(problem.controller.T_mode, problem.controller.T_zeros, ref.B)
    wn0 = min(max(problem.poles.wn, so.wn_bounds[0]), so.wn_bounds[1])
    x0 = np.concatenate([param.vector(start.controller), [wn0 / w0, problem.poles.zeta]])
    nu = frequency_grid(problem.family, Am0, so.n_freq)
    band = np.geomspace(*(2 * np.pi * np.asarray(sp.resonance_band_hz)), 25)
    models = problem.family.models
    plants = [control.tf(m.B, m.A) for m in models]
    nc = len(x0) - 2

    def ctrl_of(x):
        return param.controller(x[:nc], tb)

    def ineq(x):
        c = ctrl_of(x)
        K = control.tf(c.R, c.S)
        out = []
        for P in plants:
            L = P * K
            S = control.feedback(1, L)
            T = control.feedback(L, 1)
            U = control.feedback(K, P)
            for tf_, bound, w in ((S, sp.Ms_max, nu), (T, sp.Mt_max, nu),
                                  (U, sp.Mu_max, nu), (T, sp.T_resonance_max, band)):
                mag = np.abs(tf_(1j * w))
                out.append(1.0 - mag / (bound * BOUND_MARGIN))  # the same bounds
            Delta = np.polyadd(np.polymul(P.den[0][0], c.S), np.polymul(P.num[0][0], c.R))
            out.append([-np.max(np.roots(Delta).real) / w0])
        return np.concatenate(out)

    def eq(x):
        c = ctrl_of(x)
        wn, zeta = x[nc] * w0, x[nc + 1]
        Am = _am(problem, wn, zeta, len(Am0) - 1)
        D = np.polyadd(np.polymul(ref.A, c.S), np.polymul(ref.B, c.R))
        return (sc.normalize(D) - sc.normalize(Am))[1:]

    def f(x):
        c = ctrl_of(x)
        return -np.log(c.R[-1] / c.S[-2])

    bounds = [(None, None)] * nc + [tuple(b / w0 for b in so.wn_bounds), tuple(so.zeta_bounds)]
    res = minimize(f, x0, method="SLSQP", bounds=bounds, options={"maxiter": maxiter},
                   constraints=[{"type": "ineq", "fun": ineq}, {"type": "eq", "fun": eq}])
    ctrl = ctrl_of(res.x)
    cert = certify_problem(problem, ctrl)
    return ctrl, cert, {"success": bool(res.success), "message": res.message, "nit": res.nit,
                        "nfev": res.nfev}


def _am(problem, wn, zeta, degree):
    p = problem.poles
    spec = PoleSpec(wn=wn, zeta=zeta, aux_factor=p.aux_factor, dominant_real=p.dominant_real)
    return characteristic_polynomial(spec, degree)[0]


def _ki(ctrl):
    return integral_gain(ctrl)


def cli_time(repeats, name="paper_robust"):
    """Median CPU time (user + system) of ``robrst design NAME`` in a fresh process.

    Measured as an installed robrst runs: Python's bytecode cache on (a machine that sets
    ``PYTHONDONTWRITEBYTECODE`` would otherwise compile every module on every run, 0.05 s
    here; pip compiles them at install), after one run that is not counted.
    """
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    cmd = [sys.executable, "-m", "robrst", "design", name, "--quiet"]
    subprocess.run(cmd, check=False, capture_output=True, env=env)
    times = []
    for _ in range(repeats):
        before = os.times()
        subprocess.run(cmd, check=False, capture_output=True, env=env)
        after = os.times()
        times.append((after.children_user - before.children_user)
                     + (after.children_system - before.children_system))
    return float(np.median(times))


def run(tiny=False, repeats=3):
    problem = load(tiny)
    repeats = 1 if tiny else repeats
    times, out = alternate({"robrst": lambda: robrst_solve(problem),
                            "slsqp": lambda: slsqp_solve(problem, 20 if tiny else 300)}, repeats)
    ratio = median_ratio(times, "slsqp", "robrst")
    (c_r, cert_r, _), (c_b, cert_b, info_b) = out["robrst"], out["slsqp"]
    t_cli = cli_time(1 if tiny else 9)
    t_cli_c = t_cli if tiny else cli_time(9, "paper_robust_continuous")
    ki_r, ki_b = _ki(c_r), _ki(c_b)
    figures = {"ratio_median": ratio, "t_robrst_s": times["robrst"], "t_slsqp_s": times["slsqp"],
               "certified_robrst": cert_r.certified, "certified_slsqp": cert_b.certified,
               "integral_gain_robrst": ki_r, "integral_gain_slsqp": ki_b,
               "slsqp": {k: (str(v) if k == "message" else v) for k, v in info_b.items()},
               "cli_cpu_s": t_cli, "cli_cpu_continuous_s": t_cli_c}
    equal = cert_r.certified and cert_b.certified and ki_b <= ki_r * (1 + 1e-3)
    head = (f"{ratio:.1f}× faster (IPOPT {np.median(times['robrst']):.2f} s vs SLSQP"
            f" {np.median(times['slsqp']):.2f} s; certified {cert_r.certified}/{cert_b.certified},"
            f" integral gain {ki_r:.4g} vs {ki_b:.4g}); CLI CPU: paper_robust {t_cli:.2f} s,"
            f" paper_robust_continuous {t_cli_c:.2f} s")
    return BenchResult(
        name="robust synthesis (paper_robust_continuous)",
        robrst_path="CasADi/IPOPT, exact derivatives",
        baseline="scipy SLSQP, finite differences, python-control",
        goal="≥ 30× faster at equal certified specs; CLI ≤ 0.7 s CPU", headline=head,
        met=bool(ratio >= 30 and equal and t_cli <= 0.7), figures=figures)
