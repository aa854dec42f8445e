"""Robust synthesis driver: NLP solve and certification loop.

:func:`robust_synthesis` starts from the analytic pole-placement design, solves the
CasADi NLP (:mod:`robrst.synthesis.nlp`, by constraint exchange) on every family
model, certifies the result with exact peaks on a dense temperature sweep
(:mod:`robrst.certificate`), adds the offending frequencies and temperatures and solves
again until certified.
"""

import time

import numpy as np

from robrst import poly
from robrst.certificate import certify_problem
from robrst.errors import InfeasibleError, SolverError
from robrst.sampled import sampled_plant, warp
from robrst.synthesis.exchange import solve_exchange
from robrst.synthesis.nlp import NLPSetup, build_and_solve, scale_plant
from robrst.synthesis.outcome import Round, SynthesisResult
from robrst.synthesis.parametrize import Parametrization, TrackingRule, frequency_grid

__all__ = ["robust_synthesis", "first_round", "a_priori_check", "BOUND_MARGIN"]

BOUND_MARGIN = 0.9995  # grid constraints just inside the specs (half the certificate tolerance)


def _setup(problem, param, models, nu, Am_s):
    sp, so = problem.specs, problem.solver
    sc = param.scaling
    w0 = sc.w0
    bounds = {"S": sp.Ms_max, "T": sp.Mt_max, "U": sp.Mu_max, "Tband": sp.T_resonance_max}
    bounds = {k: (None if v is None else v * BOUND_MARGIN) for k, v in bounds.items()}
    band = np.zeros(0)
    if sp.resonance_band_hz is not None:
        lo, hi = (2 * np.pi * f / w0 for f in sp.resonance_band_hz)
        band = np.geomspace(lo, hi, 25)
    pb, domr = None, ()
    if so.free_poles:
        pb = (tuple(v / w0 for v in so.wn_bounds), tuple(so.zeta_bounds))
        domr = tuple(r / w0 for r in problem.poles.dominant_real)
    ref_T = problem.family.reference_model.temperature_C
    ref = [m.temperature_C for m in models].index(ref_T)
    bands = [band] * len(models)
    rates = ()
    if sp.sampled:   # the sampled loops too (exact bilinear equivalent plants)
        fs = sp.sample_rate_hz
        sampled = [sampled_plant(m, fs, sp.delay_samples) for m in models]
        rates = tuple((m.label, fs) for m in sampled)
        models = list(models) + sampled
        bands += [warp(np.minimum(band * w0, 0.999 * np.pi * fs), fs) / w0] * (len(models) // 2)
    ms = tuple((m.label, m.temperature_C, *scale_plant(m, sc)) for m in models)
    return NLPSetup(w0=w0, models=ms, ref=ref, Sf=param.Sf, Rf=param.Rf, ks=param.ks,
                    kr=param.kr, nu=nu / w0, nu_band=band, bounds=bounds, objective=so.objective,
                    Am_fixed=None if so.free_poles else Am_s, pole_bounds=pb,
                    aux_factor=problem.poles.aux_factor, n_dom_real=domr,
                    stable_controller=sp.stable_controller, bands=tuple(bands), rates=rates)


def _ipopt_options(so):
    return {"max_iter": so.max_iter, "tol": so.ipopt_tol, "print_level": 0,
            "sb": "yes", "mu_strategy": "monotone", "nlp_scaling_method": "none"}


def _solve(setup, x0, ipopt, exchange):
    """One NLP on the round's grid: by constraint exchange, or every grid point at once."""
    return solve_exchange(setup, x0, ipopt) if exchange else build_and_solve(setup, x0, ipopt)


def a_priori_check(problem):
    """Specs no controller with an integrator can meet: ``|T(0)| = 1``, ``|U(0)| = 1/|D(0)|``.

    Raises
    ------
    InfeasibleError
        Naming the binding spec, model and temperature.
    """
    sp = problem.specs
    for m in problem.family.models:
        checks = (("T", sp.Mt_max, 1.0), ("U", sp.Mu_max, abs(1.0 / m.dc_gain)))
        for name, bound, at_zero in checks:
            if bound is not None and at_zero > bound:
                raise InfeasibleError(
                    f"{problem.path}: specs infeasible; binding constraint: {name} of model"
                    f" {m.label} ({m.temperature_C:g} °C) at 0 Hz: |{name}(0)| = {at_zero:.4g}"
                    f" > {bound:.4g} for any controller with an integrator",
                    binding={"kind": name, "model": m.label, "temperature_C": m.temperature_C})


def _start(problem, param, start, Am0, nu):
    """Scaled NLP start: the analytic design, or the nominal convex (SOCP) solution,
    extended by ``(wn, zeta)`` (free poles) and ``gamma`` (``min_Ms``)."""
    from robrst.synthesis.convex import solve_convex   # cvxpy: imported only when asked for

    so = problem.solver
    if so.init == "analytic":
        x0 = param.vector(start.controller)
    else:
        x0, _ = solve_convex(problem, Am0, param, nu / param.scaling.w0, "feasibility")
    if so.free_poles:
        wn0 = min(max(problem.poles.wn, so.wn_bounds[0]), so.wn_bounds[1])
        x0 = np.concatenate([x0, [wn0 / param.scaling.w0, problem.poles.zeta]])
    if so.objective == "min_Ms":
        x0 = np.concatenate([x0, [2.0]])
    return x0


def first_round(problem, start):
    """The NLP of the first round of :func:`robust_synthesis`: ``(setup, x0, ipopt_options)``.

    ``start`` is the analytic design (:func:`robrst.synthesis.analytic.pole_placement`).
    For benchmarks and tests that time or compare one solve on the problem's grid.
    """
    so = problem.solver
    sc = poly.Scaling.natural(start.Am)
    param = Parametrization.of(problem.controller, problem.family.reference_model, sc)
    nu = frequency_grid(problem.family, start.Am, so.n_freq)
    x0 = _start(problem, param, start, start.Am, nu)
    setup = _setup(problem, param, list(problem.family.models), nu, sc.normalize(start.Am))
    return setup, x0, _ipopt_options(so)


def _failure(problem, res, rnd):
    b = res.binding(1)
    viol = float(np.max(res.violations())) if res.g.size else 0.0
    if b and b[0].violation > 1e-6:
        why = f"binding constraint: {b[0].describe()} (violation {b[0].violation:.3g})"
    elif b:
        why = (f"no constraint is violated by more than {viol:.2g} (a numerical failure);"
               f" largest multiplier: {b[0].describe()}")
    else:
        why = "no constraint named"
    msg = f"{problem.path}: IPOPT did not converge ({res.status}) in round {rnd}; {why}"
    if ("nfeasib" in res.status or "Restoration" in res.status) and b:
        return InfeasibleError(msg, binding={"kind": b[0].kind, "model": b[0].model,
                                             "temperature_C": b[0].temperature_C})
    return SolverError(msg)


def _refine(problem, cert, models, nu):
    """Add the certificate's offending frequencies and temperatures to the NLP."""
    known = {m.temperature_C for m in models}
    for v in cert.violations:
        if v.freq_rad_s is not None:
            w = v.freq_rad_s
            if v.loop == "sampled":   # the NLP grid lives in the loop variable
                fs = problem.specs.sample_rate_hz
                w = float(warp(min(w, 0.9999 * np.pi * fs), fs))
            nu = np.unique(np.concatenate([nu, [w * f for f in (0.98, 1.0, 1.02)]]))
        elif v.quantity.endswith("peak"):  # peak at infinity: push the grid further out
            nu = np.unique(np.concatenate([nu, [nu.max() * 100.0]]))
        if v.temperature_C not in known:
            models.append(problem.family.at(v.temperature_C))
            known.add(v.temperature_C)
    models.sort(key=lambda m: m.temperature_C)
    return models, nu


def robust_synthesis(problem, start, progress=None):
    """Solve the problem's NLP and certify; see the module docstring.

    Parameters
    ----------
    problem : Problem
    start : AnalyticDesign
        The analytic design at the problem's poles (start point, fixed ``Am``).
    progress : callable, optional
        Called with one line of text per round.

    Returns
    -------
    SynthesisResult

    Raises
    ------
    InfeasibleError, SolverError
        Naming the binding constraint (model, temperature, quantity, frequency).
    """
    say = progress or (lambda m: None)
    so = problem.solver
    a_priori_check(problem)
    t_start = time.perf_counter()
    setup, x0, ipopt = first_round(problem, start)
    param = Parametrization.of(problem.controller, problem.family.reference_model,
                               poly.Scaling(setup.w0))
    tracking = TrackingRule(problem.controller.T_mode, problem.controller.T_zeros,
                            problem.family.reference_model.B)
    nu, models, rounds = setup.nu * setup.w0, list(problem.family.models), []
    for rnd in range(1, so.max_rounds + 1):
        setup = _setup(problem, param, models, nu, setup.Am_fixed)
        res = _solve(setup, x0, ipopt, so.exchange)
        if not res.success:  # second chance: IPOPT's adaptive barrier update
            say(f"round {rnd}: IPOPT {res.status}; retrying with the adaptive barrier strategy")
            res = _solve(setup, x0, {**ipopt, "mu_strategy": "adaptive"}, so.exchange)
        if not res.success:
            raise _failure(problem, res, rnd)
        ctrl = param.controller(res.x, tracking)
        cert = certify_problem(problem, ctrl)
        ex = res.exchange
        rounds.append(Round(round=rnd, status=res.status, iterations=res.iterations,
                            models=len(models), frequencies=int(len(nu)),
                            violations=len(cert.violations),
                            **({} if ex is None else {"exchange_rounds": ex.rounds,
                                                      "active_points": ex.active_points,
                                                      "grid_points": ex.grid_points})))
        note = ("" if ex is None else f" (exchange: {ex.active_points}/{ex.grid_points} grid"
                f" points active, {ex.rounds} rounds)")
        say(f"round {rnd}: IPOPT {res.status} in {res.iterations} it, {len(models)} models"
            f" x {len(nu)} freqs{note} -> {len(cert.violations)} certificate violations")
        if cert.certified:
            break
        x0 = res.x
        models, nu = _refine(problem, cert, models, nu)
    else:
        worst = max(cert.violations, key=lambda v: v.value / max(v.bound, 1e-300))
        raise SolverError(f"{problem.path}: not certified after {so.max_rounds} rounds;"
                          f" worst: {worst.describe()}")
    ref = problem.family.reference_model
    Am, wn, zeta = start.Am, None, None
    if so.free_poles:   # the nominal closed-loop polynomial reached
        Am = poly.monic(poly.padd(poly.pmul(ref.A, ctrl.S), poly.pmul(ref.B, ctrl.R)))
        k = param.n_x
        wn, zeta = float(res.x[k] * setup.w0), float(res.x[k + 1])
    return SynthesisResult(controller=ctrl, Am=Am, certificate=cert, status="certified",
                           objective=so.objective, w0=setup.w0, rounds=tuple(rounds), solve=res,
                           wall_time_s=time.perf_counter() - t_start, wn_rad_s=wn, zeta=zeta)
