"""Per-variant synthesis cost: a batch of variants of one problem through one Synthesizer.

The robust program is one parametric CasADi solver per structure
(:class:`robrst.synthesis.synthesizer.Synthesizer`); variants of a problem reuse it, and each variant can
warm-start from the previous result.  Two batches: nearly identical variants (the
family's static-gain law alone, 0.10 … 0.20 %/K) and variants that really differ (every
thermal law scaled by its own factor in 0.7 … 1.3, seeded): the saving of reuse and warm
start is stated for both, the second being what a ±30 % Monte Carlo sweep sees.  Three ways of running the same batch, alternating:
``cold`` (a new Synthesizer per variant: every program built again), ``reused`` (one
Synthesizer: programs built once) and ``warm`` (one Synthesizer, each variant started from
the previous design).  CPU time per variant includes the exact certificate (both loops on
35 temperatures for ``paper_robust``), which does not depend on the synthesis path.
"""

import time
from dataclasses import replace

import numpy as np

from benchmarks.harness import BenchResult
from robrst.certificate.proof import certify_problem
from robrst.core.family import parametric_family
from robrst.problem.files import load_problem
from robrst.synthesis.synthesizer import Synthesizer

GOAL_S = 0.15


THERMAL = ("gain_per_K", "resonance_per_K", "damping_per_K", "creep_per_K")


def variants(name, n):
    """Nearly identical variants: the static-gain law alone, 0.10 … 0.20 %/K."""
    p = load_problem(name)
    p = replace(p, solver=replace(p.solver, compare_with=None))
    th = p.family.thermal
    return [replace(p, family=parametric_family(p.family.nominal, p.family.temperatures,
                                                replace(th, gain_per_K=float(g))))
            for g in np.linspace(0.001, 0.002, n)]


def differing_variants(name, n, seed=31):
    """Variants that really differ: every thermal law (gain, resonance, damping, creep)
    scaled by its own factor drawn uniformly in 0.7 … 1.3 (seeded), as a Monte Carlo
    sweep of ±30 % on the laws draws them."""
    p = load_problem(name)
    p = replace(p, solver=replace(p.solver, compare_with=None))
    th = p.family.thermal
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        law = replace(th, **{k: float(getattr(th, k) * rng.uniform(0.7, 1.3)) for k in THERMAL})
        out.append(replace(p, family=parametric_family(p.family.nominal, p.family.temperatures,
                                                       law)))
    return out


def batch(problems, mode):
    """CPU seconds per variant and the integral gains, for ``mode`` cold | reused | warm."""
    syn, prev, times, gains, certified = Synthesizer(), None, [], [], []
    for p in problems:
        if mode == "cold":
            syn = Synthesizer()
        t0 = time.process_time()
        r = syn.solve(p, warm=prev if mode == "warm" else None)
        times.append(time.process_time() - t0)
        gains.append(r.integral_gain)
        certified.append(r.certified)
        prev = r
    return times, gains, certified


def certificate_time(problem, ctrl, repeats=3):
    t = []
    for _ in range(repeats):
        t0 = time.process_time()
        certify_problem(problem, ctrl)
        t.append(time.process_time() - t0)
    return float(np.median(t))


def _measure(probs):
    res = {mode: batch(probs, mode) for mode in ("cold", "reused", "warm")}
    med = {m: float(np.median(v[0][1:] if len(v[0]) > 1 else v[0])) for m, v in res.items()}
    same = all(np.allclose(res["warm"][1], res[m][1], rtol=1e-4) for m in ("cold", "reused"))
    return res, med, bool(same)


def run(tiny=False):
    n = 2 if tiny else 6
    rows, figures = [], {}
    for name in (("paper_robust_continuous",) if tiny else ("paper_robust_continuous",
                                                             "paper_robust")):
        for kind, make in (("nearly identical (gain law 0.10-0.20 %/K)", variants),
                           ("±30 % on every thermal law", differing_variants)):
            probs = make(name, n)
            res, med, same = _measure(probs)
            r = Synthesizer().solve(probs[0])
            t_cert = certificate_time(replace(probs[0],
                                              specs=probs[0].specs.without_time_domain()),
                                      r.controller)
            key = name if make is variants else f"{name} ±30 %"
            figures[key] = {"median_cpu_s": med, "certificate_cpu_s": t_cert,
                            "same_optimum": same, "saving": med["cold"] / med["warm"],
                            "all_certified": all(all(v[2]) for v in res.values())}
            rows.append(f"| {name} | {kind} | {med['cold']:.3f} | {med['reused']:.3f} |"
                        f" {med['warm']:.3f} | {med['cold'] / med['warm']:.2f}× |"
                        f" {t_cert:.3f} | {med['warm'] - t_cert:.3f} | {same} |")
    table = ["| problem | variants | cold [s] | programs reused [s] | reused + warm start [s] |"
             " saving (cold / warm) | of which certificate [s] | synthesis alone (warm) [s] |"
             " same optimum |", "|---|---|---|---|---|---|---|---|---|", *rows]
    main = figures.get("paper_robust", figures["paper_robust_continuous"])
    head = "; ".join(f"{k}: {v['median_cpu_s']['warm']:.3f} s per variant warm"
                     f" ({v['median_cpu_s']['cold']:.3f} s cold: {v['saving']:.2f}× saved,"
                     f" certificate {v['certificate_cpu_s']:.3f} s)" for k, v in figures.items())
    return BenchResult(
        name="per-variant synthesis", robrst_path="Synthesizer: programs built once, warm start",
        baseline="a new Synthesizer per variant (cold)",
        goal=f"≤ {GOAL_S} s CPU per variant of paper_robust", headline=head,
        met=bool(main["median_cpu_s"]["warm"] <= GOAL_S and main["all_certified"]),
        figures=figures, table=tuple(table))
