"""Robust synthesis driver: initial point, NLP/convex solve, certification loop.

``robust_design(problem)`` starts from the analytic pole-placement solution, solves
the CasADi NLP (:mod:`robrst.synthesis.nlp`) on every family model, certifies the
result with exact peaks on a dense temperature sweep (:mod:`robrst.certify`), adds
the offending frequencies and temperatures and solves again until certified.
"""

import time

import numpy as np

from robrst import poly
from robrst.certify import certify
from robrst.errors import InfeasibleError, SolverError
from robrst.rst import RSTController
from robrst.sampled import sampled_plant, warp
from robrst.synthesis import analytic
from robrst.synthesis.exchange import solve_exchange
from robrst.synthesis.nlp import NLPSetup, build_and_solve, scale_plant

__all__ = ["robust_design", "first_round", "initial_point", "controller_from_x", "analytic_check"]

BOUND_MARGIN = 0.9995  # grid constraints just inside the specs (half the certificate tolerance)
OK_STATUS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def _degrees(problem):
    c = problem.controller
    ref = problem.family.reference_model
    Sf, Rf = poly.trim(c["S_fixed"]), poly.trim(c["R_fixed"])
    deg_am = analytic.closed_loop_degree(ref.n, ref.m, Sf, Rf, c["extra_degree"])
    deg_s = deg_am - ref.n
    ks = deg_s - (len(Sf) - 1)
    kr = deg_s - (len(Rf) - 1)  # R as high as S: the extra degrees become free parameters
    return Sf, Rf, ks, kr, deg_s


def initial_point(problem, w0, ctrl0):
    """Scaled decision vector of a known controller (e.g. the analytic design)."""
    Sf, Rf, ks, kr, deg_s = _degrees(problem)
    Ss = poly.to_scaled(np.concatenate([np.zeros(deg_s + 1 - len(ctrl0.S)), ctrl0.S]), w0) / w0 ** deg_s
    Rs = poly.to_scaled(np.concatenate([np.zeros(deg_s + 1 - len(ctrl0.R)), ctrl0.R]), w0) / w0 ** deg_s
    Sfs, Rfs = _scaled_factor(Sf, w0), _scaled_factor(Rf, w0)
    sp, rem = np.polydiv(Ss, Sfs)
    rp, rem2 = np.polydiv(Rs, Rfs)
    if np.max(np.abs(rem)) > 1e-8 or np.max(np.abs(rem2)) > 1e-8 * max(1, np.max(np.abs(Rs))):
        raise SolverError("initial controller does not contain the fixed factors")
    sp = sp / sp[0]
    rp = np.concatenate([np.zeros(kr + 1 - len(rp)), rp])
    return np.concatenate([sp[1:], rp])


def _scaled_factor(F, w0):
    F = poly.trim(F)
    Fs = poly.to_scaled(F, w0)
    return Fs / Fs[0]


def controller_from_x(problem, w0, x, T_builder):
    """Unscaled RST controller from the scaled decision vector."""
    Sf, Rf, ks, kr, deg_s = _degrees(problem)
    sp = np.concatenate([[1.0], x[:ks]])
    rp = x[ks:ks + kr + 1]
    Ss = np.polymul(_scaled_factor(Sf, w0), sp)
    Rs = np.polymul(_scaled_factor(Rf, w0), rp)
    S = poly.from_scaled(Ss, w0) * w0 ** deg_s
    R = poly.trim(poly.from_scaled(Rs, w0) * w0 ** deg_s)
    S[-1] = 0.0  # the integrator is structural (exact zero, not 1e-300)
    return RSTController(R=R, S=S, T=T_builder(R))


def _grid(problem, Am, n_freq):
    roots = [np.abs(np.roots(Am))]
    for m in problem.family.models:
        roots.append(np.abs(m.poles()))
        if m.m:
            roots.append(np.abs(m.zeros()))
    r = np.concatenate(roots)
    r = r[r > 0]
    lo, hi = r.min() / 30.0, r.max() * 30.0
    extra = [np.max(np.abs(m.poles().imag)) for m in problem.family.models]
    far = [hi * 1e2, hi * 1e4]  # the high-frequency limits of |S|, |U| (peaks at infinity)
    return np.unique(np.concatenate([np.geomspace(lo, hi, n_freq), extra, far]))


def _setup(problem, w0, models, nu, Am_s, obj):
    Sf, Rf, ks, kr, _ = _degrees(problem)
    sp, so = problem.specs, problem.solver
    bounds = {"S": sp["Ms_max"], "T": sp["Mt_max"], "U": sp["Mu_max"],
              "Tband": sp["T_resonance_max"]}
    bounds = {k: (None if v is None else v * BOUND_MARGIN) for k, v in bounds.items()}
    band = np.zeros(0)
    if sp["resonance_band_hz"] is not None:
        lo, hi = (2 * np.pi * f / w0 for f in sp["resonance_band_hz"])
        band = np.geomspace(lo, hi, 25)
    pb, domr = None, ()
    if so["free_poles"]:
        pb = (tuple(v / w0 for v in so["wn_bounds"]), tuple(so["zeta_bounds"]))
        domr = tuple(r / w0 for r in problem.poles.dominant_real)
    ref_T = problem.family.reference_model.temperature_C
    ref = [m.temperature_C for m in models].index(ref_T)
    bands = [band] * len(models)
    if sp["sample_rate_hz"]:   # the sampled loops too (exact bilinear equivalent plants)
        fs = sp["sample_rate_hz"]
        models = list(models) + [sampled_plant(m, fs, sp["delay_samples"]) for m in models]
        bands += [warp(np.minimum(band * w0, 0.999 * np.pi * fs), fs) / w0] * (len(models) // 2)
    ms = tuple((m.label, m.temperature_C, *scale_plant(m, w0)) for m in models)
    return NLPSetup(w0=w0, models=ms, ref=ref, Sf=_scaled_factor(Sf, w0),
                    Rf=_scaled_factor(Rf, w0), ks=ks, kr=kr, nu=nu / w0, nu_band=band,
                    bounds=bounds, objective=obj, Am_fixed=None if so["free_poles"] else Am_s,
                    pole_bounds=pb, aux_factor=problem.poles.aux_factor, n_dom_real=domr,
                    stable_controller=sp["stable_controller"], bands=tuple(bands))


def _binding(labels, g, lbg, ubg):
    viol = np.maximum(lbg - g, g - ubg)
    i = int(np.argmax(viol))
    kind, label, T, where = labels[i]
    return i, kind, label, T, where, float(viol[i])


def analytic_check(problem, ctrl, Am):
    """Compare a synthesised controller with the Sylvester solution for the same Am.

    With no free degree (``extra_degree = 0``) the Diophantine solution is unique
    and the NLP must reproduce it coefficient by coefficient.  With free degrees
    the check is the Diophantine residual at the nominal model.
    """
    ref = problem.family.reference_model
    c = problem.controller
    if c["extra_degree"] == 0:
        sol = analytic.solve_diophantine(ref.A, ref.B, Am, c["S_fixed"], c["R_fixed"])
        err = max(poly.rel_coef_error(ctrl.R, sol.R), poly.rel_coef_error(ctrl.S, sol.S))
        kind = "sylvester_coefficients"
    else:
        err = analytic.diophantine_residual(ref.A, ref.B, ctrl.R, ctrl.S, Am)
        kind = "diophantine_residual"
    return {"kind": kind, "max_rel_coef_error": float(err), "passed": bool(err <= 1e-8)}


def robust_design(problem, say=lambda m: None):
    """Solve the problem's NLP (or convex program) and certify; see module docstring.

    Returns
    -------
    (RSTController, Am, solver_info, extra)
        ``extra`` holds ``analytic_check``, ``comparison`` and the final ``certificate``.
    """
    so = problem.solver
    _a_priori(problem)
    ctrl0, info0 = _initial(problem)
    Am0 = info0["Am"]
    w0 = poly.natural_scale(Am0)
    ref = problem.family.reference_model
    T_builder = _t_builder(problem)
    if so["method"] == "convex":
        from robrst.synthesis.convex import convex_design

        return convex_design(problem, ctrl0, info0, say)
    x0 = _start(problem, w0, ctrl0, Am0)
    Am_s = poly.to_scaled(Am0, w0) / w0 ** (len(Am0) - 1)
    nu = _grid(problem, Am0, so["n_freq"])
    models = list(problem.family.models)
    ipopt = _ipopt_options(so)
    t_start, rounds, total_iter = time.perf_counter(), [], 0
    for rnd in range(1, so["max_rounds"] + 1):
        setup = _setup(problem, w0, models, nu, Am_s, so["objective"])
        x, stats, labels, g, lbg, ubg, exch = _solve(setup, x0, ipopt, so["exchange"])
        status = stats["return_status"]
        total_iter += stats.get("iter_count", 0)
        if status not in OK_STATUS:  # second chance: IPOPT's adaptive barrier update
            say(f"round {rnd}: IPOPT {status}; retrying with the adaptive barrier strategy")
            x, stats, labels, g, lbg, ubg, exch = _solve(
                setup, x0, {**ipopt, "mu_strategy": "adaptive"}, so["exchange"])
            status = stats["return_status"]
            total_iter += stats.get("iter_count", 0)
        if status not in OK_STATUS:
            i, kind, label, T, where, v = _binding(labels, g, lbg, ubg)
            what = kind if label is None else f"{kind} of model {label} ({T:g} °C)"
            at = f" at {where * w0 / (2 * np.pi):.4g} Hz" if isinstance(where, float) else ""
            msg = (f"{problem.path}: IPOPT did not converge ({status}) in round {rnd};"
                   f" binding constraint: {what}{at} (violation {v:.3g})")
            if "nfeasib" in status or "Restoration" in status:
                raise InfeasibleError(msg, binding={"kind": kind, "model": label,
                                                    "temperature_C": T})
            raise SolverError(msg)
        ctrl = controller_from_x(problem, w0, x, T_builder)
        cert = certify(problem.family, ctrl, problem.specs, n_sweep=so["cert_temperatures"],
                       rtol=so["cert_tol"])
        rounds.append({"round": rnd, "status": status, "iterations": stats.get("iter_count"),
                       "models": len(models), "frequencies": int(len(nu)),
                       "violations": len(cert.violations), **exch})
        say(f"round {rnd}: IPOPT {status} in {stats.get('iter_count')} it, {len(models)} models"
            f" x {len(nu)} freqs{_exchange_note(exch)} -> {len(cert.violations)} certificate"
            " violations")
        if cert.certified:
            break
        x0 = x
        known = {m.temperature_C for m in models}
        for v in cert.violations:
            if v.freq_rad_s is not None:
                w = v.freq_rad_s
                if v.loop == "sampled":   # the NLP grid lives in the loop variable
                    fs = problem.specs["sample_rate_hz"]
                    w = float(warp(min(w, 0.9999 * np.pi * fs), fs))
                nu = np.unique(np.concatenate([nu, [w * f for f in (0.98, 1.0, 1.02)]]))
            elif v.quantity.endswith("peak"):  # peak at infinity: push the grid further out
                nu = np.unique(np.concatenate([nu, [nu.max() * 100.0]]))
            if v.temperature_C not in known:
                models.append(problem.family.at(v.temperature_C))
                known.add(v.temperature_C)
        models.sort(key=lambda m: m.temperature_C)
    else:
        worst = max(cert.violations, key=lambda v: v.value / max(v.bound, 1e-300))
        raise SolverError(f"{problem.path}: not certified after {so['max_rounds']} rounds;"
                          f" worst: {worst.describe()}")
    Am = _final_am(problem, Am0, ctrl, ref)
    solver = {"name": "ipopt", "w0_rad_s": w0, "status": status, "rounds": rounds,
              "iterations": total_iter, "objective": so["objective"],
              "integral_gain": _integral_gain(ctrl), "wall_time_s": time.perf_counter() - t_start}
    if so["free_poles"]:
        solver["wn_rad_s"], solver["zeta"] = float(x[-2 - (so["objective"] == "min_Ms")] * w0), \
            float(x[-1 - (so["objective"] == "min_Ms")])
    extra = {"analytic_check": analytic_check(problem, ctrl, Am),
             "comparison": comparison(problem, ctrl, cert), "certificate": cert}
    return ctrl, Am, solver, extra


def _solve(setup, x0, ipopt, exchange):
    """One NLP on the round's grid: by constraint exchange, or every grid point at once."""
    if not exchange:
        return (*build_and_solve(setup, x0, ipopt), {})
    *out, info = solve_exchange(setup, x0, ipopt)
    return (*out, {"exchange_rounds": info.rounds, "active_points": info.active_points,
                   "grid_points": info.grid_points})


def _exchange_note(exch):
    if not exch:
        return ""
    return (f" (exchange: {exch['active_points']}/{exch['grid_points']} grid points active,"
            f" {exch['exchange_rounds']} rounds)")


def _ipopt_options(so):
    return {"max_iter": so["max_iter"], "tol": so["ipopt_tol"], "print_level": 0,
            "sb": "yes", "mu_strategy": "monotone", "nlp_scaling_method": "none"}


def first_round(problem):
    """The NLP of the first round of :func:`robust_design`: ``(setup, x0, ipopt_options)``.

    For benchmarks and tests that time or compare one solve on the problem's grid.
    """
    so = problem.solver
    ctrl0, info0 = _initial(problem)
    Am0 = info0["Am"]
    w0 = poly.natural_scale(Am0)
    x0 = _start(problem, w0, ctrl0, Am0)
    Am_s = poly.to_scaled(Am0, w0) / w0 ** (len(Am0) - 1)
    setup = _setup(problem, w0, list(problem.family.models), _grid(problem, Am0, so["n_freq"]),
                   Am_s, so["objective"])
    return setup, x0, _ipopt_options(so)


def _start(problem, w0, ctrl0, Am0):
    """Scaled NLP start: the analytic design, or the nominal convex (SOCP) solution,
    extended by ``(wn, zeta)`` (free poles) and ``gamma`` (``min_Ms``)."""
    so = problem.solver
    if so["init"] == "analytic":
        x0 = initial_point(problem, w0, ctrl0)
    else:
        from robrst.synthesis.convex import solve_convex

        Sf, Rf, ks, kr, _ = _degrees(problem)
        nu = _grid(problem, Am0, so["n_freq"]) / w0
        x0, _ = solve_convex(problem, Am0, w0, nu,
                             (_scaled_factor(Sf, w0), _scaled_factor(Rf, w0), ks, kr),
                             "feasibility")
    if so["free_poles"]:
        wn0 = min(max(problem.poles.wn, so["wn_bounds"][0]), so["wn_bounds"][1])
        x0 = np.concatenate([x0, [wn0 / w0, problem.poles.zeta]])
    if so["objective"] == "min_Ms":
        x0 = np.concatenate([x0, [2.0]])
    return x0


def _a_priori(problem):
    """Specs no controller with an integrator can meet: |T(0)| = 1, |U(0)| = 1/|D(0)|."""
    sp = problem.specs
    for m in problem.family.models:
        checks = (("T", sp["Mt_max"], 1.0), ("U", sp["Mu_max"], abs(1.0 / m.dc_gain)))
        for name, bound, at_zero in checks:
            if bound is not None and at_zero > bound:
                raise InfeasibleError(
                    f"{problem.path}: specs infeasible; binding constraint: {name} of model"
                    f" {m.label} ({m.temperature_C:g} °C) at 0 Hz: |{name}(0)| = {at_zero:.4g}"
                    f" > {bound:.4g} for any controller with an integrator",
                    binding={"kind": name, "model": m.label, "temperature_C": m.temperature_C})


def _initial(problem):
    from robrst.design import analytic_design

    return analytic_design(problem)


def _t_builder(problem):
    c = problem.controller
    ref = problem.family.reference_model

    def build(R):
        Am0 = np.array([R[-1] * ref.B[-1]])  # T(0) = R(0): unit static gain
        if c["T_mode"] == "static":
            return analytic.tracking_polynomial("static", R, ref.B, Am0, np.ones(1))
        return analytic.tracking_polynomial("paper", R, ref.B, Am0, np.ones(1), c["T_zeros"])

    return build


def _final_am(problem, Am0, ctrl, ref):
    """The target Am: fixed, or (free poles) the nominal closed-loop polynomial reached."""
    if not problem.solver["free_poles"]:
        return Am0
    return poly.monic(poly.padd(poly.pmul(ref.A, ctrl.S), poly.pmul(ref.B, ctrl.R)))


def _integral_gain(ctrl):
    """``lim_{s->0} s R/S`` [V/(µm s)]: the low-frequency disturbance-rejection gain."""
    Sq = poly.trim(ctrl.S)[:-1]
    return float(ctrl.R[-1] / Sq[-1])


def comparison(problem, ctrl, cert=None):
    """Worst-case margins over the family sweep: this controller vs ``compare_with``.

    ``cert`` is this controller's certificate when already computed.
    """
    from robrst.design import analytic_design
    from robrst.spec import load_problem

    other = problem.solver.get("compare_with")
    if not other:
        return None
    from pathlib import Path

    path = Path(problem.path).parent / other
    base = load_problem(path)
    ctrl_a, _ = analytic_design(base)
    rows = {}
    for name, c, known in (("robust", ctrl, cert), (f"analytic ({path.name})", ctrl_a, None)):
        cert = known or certify(problem.family, c, problem.specs,
                                n_sweep=problem.solver["cert_temperatures"],
                                rtol=problem.solver["cert_tol"])
        rows[name] = {"worst_Ms": cert.worst("Ms"), "worst_Mt": cert.worst("Mt"),
                      "worst_Mu": cert.worst("Mu"), "min_modulus_margin": 1 / cert.worst("Ms"),
                      "max_spectral_abscissa": cert.worst("spectral_abscissa"),
                      "integral_gain": _integral_gain(c), "certified": cert.certified}
        if problem.specs["sample_rate_hz"]:
            rows[name].update({f"worst_{k}_sampled": cert.worst(f"{k}_sampled")
                               for k in ("Ms", "Mt", "Mu")})
    keys = list(next(iter(rows.values())))
    names = list(rows)
    w = max(len(n) for n in names) + 2
    lines = ["worst case over the family (28..45 °C sweep):",
             f"{'':<22}" + "".join(f"{n:>{w}}" for n in names)]
    for k in keys:
        lines.append(f"{k:<22}" + "".join(
            f"{(str(rows[n][k]) if isinstance(rows[n][k], bool) else format(rows[n][k], '.4g')):>{w}}"
            for n in names))
    return {"rows": rows, "table": "\n".join(lines)}
