"""Synthesis scaling: NLP solve time vs (number of models × number of frequencies)."""

import time

import numpy as np

from benchmarks.bench_synthesis import load
from benchmarks.harness import BenchResult
from robrst import poly
from robrst.synthesis import robust
from robrst.synthesis.nlp import build_and_solve

SIZES = ((1, 50), (2, 125), (4, 250), (8, 500), (16, 1000), (32, 2000))
TINY_SIZES = ((1, 20), (2, 40))


def nlp_time(n_models, n_freq):
    """Wall time of one NLP build + IPOPT solve (first round) and its iteration count."""
    problem = load(False, n_models=n_models, n_freq=n_freq)
    so = problem.solver
    ctrl0, info0 = robust._initial(problem)
    Am0 = info0["Am"]
    w0 = poly.natural_scale(Am0)
    wn0 = min(max(problem.poles.wn, so["wn_bounds"][0]), so["wn_bounds"][1])
    x0 = np.concatenate([robust.initial_point(problem, w0, ctrl0), [wn0 / w0, problem.poles.zeta]])
    nu = robust._grid(problem, Am0, n_freq)
    setup = robust._setup(problem, w0, list(problem.family.models), nu, None, so["objective"])
    ipopt = {"max_iter": so["max_iter"], "tol": so["ipopt_tol"], "print_level": 0, "sb": "yes",
             "mu_strategy": "monotone", "nlp_scaling_method": "none"}
    t0 = time.perf_counter()
    _, stats, *_ = build_and_solve(setup, x0, ipopt)
    return time.perf_counter() - t0, int(stats["iter_count"]), stats["return_status"]


def run(tiny=False):
    rows, sizes = [], TINY_SIZES if tiny else SIZES
    for m, f in sizes:
        t, it, status = nlp_time(m, f)
        rows.append({"models": m, "freqs": f, "product": m * f, "time_s": t, "iterations": it,
                     "status": status, "time_per_iter_s": t / max(it, 1)})
    prod = np.array([r["product"] for r in rows], float)
    per_it = np.array([r["time_per_iter_s"] for r in rows])
    tot = np.array([r["time_s"] for r in rows])
    # growth exponent over the upper half of the sizes (constant overheads dominate below)
    k = max(2, len(rows) // 2)
    slope_it = float(np.polyfit(np.log(prod[-k:]), np.log(per_it[-k:]), 1)[0])
    slope_tot = float(np.polyfit(np.log(prod[-k:]), np.log(tot[-k:]), 1)[0])
    table = ["| models | freqs | models×freqs | IPOPT iterations | solve [s] | per iteration [ms] |",
             "|---|---|---|---|---|---|"]
    table += [f"| {r['models']} | {r['freqs']} | {r['product']} | {r['iterations']} |"
              f" {r['time_s']:.3f} | {1e3 * r['time_per_iter_s']:.2f} |" for r in rows]
    table += ["", f"Log-log growth exponent over the larger sizes: per iteration {slope_it:.2f},"
              f" total {slope_tot:.2f} (1 = linear)."]
    ok = all(r["status"] in robust.OK_STATUS for r in rows)
    return BenchResult(
        name="synthesis scaling", robrst_path="NLP build + IPOPT solve",
        baseline="—", goal="growth ≤ linear in models × frequencies",
        headline=f"exponent {slope_it:.2f} per iteration, {slope_tot:.2f} total",
        met=bool(ok and slope_it <= 1.1), figures={"rows": rows, "exponent_per_iteration": slope_it,
                                                   "exponent_total": slope_tot},
        table=tuple(table))
