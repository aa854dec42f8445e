"""The global phase: what a default design costs (every process counted) and what it reaches.

* **Cost.** ``robrst design paper_robust`` in a fresh process, its import floor
  (``python -c "import numpy, scipy.linalg, casadi"``) and the same design with
  ``--starts 0`` (no global phase), alternating; CPU is user + system of the child process
  *and of every process it waited for* (``resource.getrusage(RUSAGE_CHILDREN)``: a design
  that ran workers is charged for them).
* **The screen's kernel.** A sampled loop's reference step at its first samples
  (``robrst.synthesis._screen.first_samples``: blocks of powers, one matrix product per
  candidate and model) against the same sum over every power (``cumprod`` of every sample,
  then the weighted sum: the implementation before 2026-12-04), alternating, CPU time.
* **The polish over the poles' derivatives.** The Lagrangian's Hessian and the constraints'
  Jacobian a ``MappedTemplate`` hands IPOPT (the chain rule through the coefficient
  program's own derivatives, ``RunOptions.chained_derivatives``) against CasADi's
  derivatives of the composed program (the default), at ``paper_robust``'s map and structure,
  alternating, CPU time; and their largest relative difference.
* **Quality.** On the stages of ``tests/global_references.json`` (each with the best
  certified integral gain an independent differential evolution found, its CPU and its
  controller; ``tests/global_reference.py``) the default design's certified integral gain
  as a share of that reference, and its CPU.
"""

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.harness import BenchResult, alternate, median_ratio

FLOOR = "numpy, scipy.linalg, casadi"
REFERENCES = Path(__file__).resolve().parents[1] / "tests" / "global_references.json"


def child_cpu(cmd, env=None):
    """CPU [s] of ``cmd`` run to completion and of every process it waited for."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=False, capture_output=True, env=env)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def cli_costs(repeats):
    """Median CPU of the floor, ``design paper_robust`` and ``--starts 0``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    cmds = {"floor": [sys.executable, "-c", f"import {FLOOR}"],
            "default": [sys.executable, "-m", "robrst", "design", "paper_robust", "--quiet"],
            "starts0": [sys.executable, "-m", "robrst", "design", "paper_robust", "--quiet",
                        "--starts", "0"]}
    for cmd in cmds.values():
        child_cpu(cmd, env)                      # bytecode cache warm
    times = {k: [] for k in cmds}
    for _ in range(repeats):
        for k, cmd in cmds.items():
            times[k].append(child_cpu(cmd, env))
    return times


def quality(tiny=False):
    """Per reference stage: ``(name, reference, robrst, share, cpu)``."""
    from robrst.design import run_problem
    from robrst.problem.files import parse_problem

    if not REFERENCES.exists():     # no reference optima recorded yet: cost only
        return []
    refs = json.loads(REFERENCES.read_text())
    out = []
    for name, ref in list(refs.items())[:1 if tiny else None]:
        p = parse_problem(ref["problem"], f"<{name}>")
        t = time.process_time()
        r = run_problem(p, analyses=False)
        cpu = time.process_time() - t
        ki = r.integral_gain if r.certified else 0.0
        out.append((name, ref["integral_gain"], ki, ki / ref["integral_gain"], cpu,
                    ref.get("cpu_s")))
    return out


def first_samples_kernel(repeats, calls=20, seed=20261204):
    """CPU [s] per call of the screen's first-samples kernel and of every power summed
    (60 candidates, 8 models, 6 modes), alternating; and their largest difference."""
    from robrst.synthesis._screen import PEAK_SAMPLES, first_samples

    rng = np.random.default_rng(seed)
    shape = (60, 8, 6)
    z = rng.uniform(0.2, 0.999, shape) * np.exp(1j * rng.uniform(-np.pi, np.pi, shape))
    c = rng.normal(size=shape) + 1j * rng.normal(size=shape)

    def every_power():
        zk = np.empty(shape + (PEAK_SAMPLES,), complex)
        zk[..., 0] = 1.0
        zk[..., 1:] = z[..., None]
        np.cumprod(zk, axis=-1, out=zk)
        return np.matmul(c[..., None, :], zk)[..., 0, :].real

    fns = {"blocks": lambda: [first_samples(c, z) for _ in range(calls)][-1],
           "every_power": lambda: [every_power() for _ in range(calls)][-1]}
    times, outs = alternate(fns, repeats, time.process_time)
    diff = float(np.max(np.abs(outs["blocks"] - outs["every_power"])))
    return {k: [t / calls for t in v] for k, v in times.items()}, diff


def pole_program_derivatives(repeats, calls=20, seed=20261207):
    """CPU [s] per call of the chained and the composed Hessian + Jacobian of the program
    over the poles (``paper_robust``'s map and structure), alternating; and their largest
    relative difference."""
    from robrst.base.resources import builtin_problem
    from robrst.design import analytic_design
    from robrst.problem.files import load_problem
    from robrst.problem.records import with_defaults
    from robrst.synthesis.attempts import program_models
    from robrst.synthesis.context import Context, ipopt_options
    from robrst.synthesis.search import PoleSpace
    from robrst.synthesis.template import MappedTemplate, Structure, Template

    p = with_defaults(load_problem(builtin_problem("paper_robust")))
    ctx = Context.of(p, analytic_design(p))
    setup = ctx.setup(program_models(p), ctx.nu, "free")
    sp = PoleSpace.of(ctx, setup)
    # the structure of most of paper_robust's polishes over the poles (546 peak slots, the
    # Routh rows of 16 closed loops, two controller polynomials, 24 linear rows)
    st = Structure(nx=setup.n_x, placement="free", deg_eq=0, n_dom_real=0,
                   groups=((setup.n_x - 1, 4), (setup.n_x, 12)), slots=546, ctrl_deg=4,
                   ctrl_count=2, ipopt=tuple(sorted(ipopt_options(p.solver).items())), lin=24)
    base = Template(st)
    lo, hi = np.zeros(sp.dim), np.ones(sp.dim)
    # chained, and the default: CasADi's derivatives through the composed graph
    mapped = MappedTemplate(base, sp, lo, hi, {}, chained=True)
    plain = MappedTemplate(base, sp, lo, hi, {})
    hess, jac = (mapped.solver.get_function(k) for k in ("nlp_hess_l", "nlp_jac_g"))
    hess0, jac0 = (plain.solver.get_function(k) for k in ("nlp_hess_l", "nlp_jac_g"))
    rng = np.random.default_rng(seed)
    values = {k: rng.uniform(0.5, 1.5, size=shape) for k, (_, shape) in base.layout.items()}
    x = np.concatenate([rng.uniform(0.1, 0.9, sp.dim), rng.uniform(0.5, 2, st.n_var - st.nx)])
    args = (x, base.pack(values), 1.0, rng.normal(size=base.n_g))

    def chained():
        for _ in range(calls):
            out = (hess(*args), jac(*args[:2])[1])
        return out

    def through():
        for _ in range(calls):
            out = (hess0(*args), jac0(*args[:2])[1])
        return out

    times, outs = alternate({"chained": chained, "composed": through}, repeats,
                            time.process_time)
    diff = max(float(np.max(np.abs(np.array(a) - np.array(b))) / np.max(np.abs(np.array(b))))
               for a, b in zip(outs["chained"], outs["composed"]))
    return {k: [t / calls for t in v] for k, v in times.items()}, diff


def run(tiny=False, repeats=5):
    times = cli_costs(1 if tiny else repeats)
    med = {k: float(np.median(v)) for k, v in times.items()}
    ratio = float(np.median(np.asarray(times["default"]) / np.asarray(times["floor"])))
    kernel, kernel_diff = first_samples_kernel(3 if tiny else 15)
    speedup = median_ratio(kernel, "every_power", "blocks")
    derivs, derivs_diff = pole_program_derivatives(3 if tiny else 15)
    derivs_speedup = median_ratio(derivs, "composed", "chained")
    rows = quality(tiny)
    worst = min((r[3] for r in rows), default=np.nan)
    table = ["| stage | reference (DE) | default design | share | design CPU [s] |"
             " reference CPU [s] |", "|---|---|---|---|---|---|"]
    table += [f"| {n} | {ref:.6g} | {ki:.6g} | {100 * sh:.1f} % | {cpu:.1f} | {rc} |"
              for n, ref, ki, sh, cpu, rc in rows]
    table += ["", f"The screen's first samples (60 candidates x 8 models x 6 modes):"
              f" {1e3 * np.median(kernel['blocks']):.2f} ms per call in blocks against"
              f" {1e3 * np.median(kernel['every_power']):.2f} ms over every power"
              f" ({speedup:.1f}x, largest difference {kernel_diff:.1e}).",
              "", f"The program over the poles' Hessian and Jacobian (paper_robust's map"
              f" and structure): {1e3 * np.median(derivs['chained']):.2f} ms per call by"
              f" the chain rule against {1e3 * np.median(derivs['composed']):.2f} ms through"
              f" the composed program ({derivs_speedup:.1f}x, largest relative difference"
              f" {derivs_diff:.1e})."]
    head = (f"design paper_robust {med['default']:.2f} s CPU (children counted) ="
            f" {ratio:.2f}x its import floor ({med['floor']:.2f} s), --starts 0"
            f" {med['starts0']:.2f} s; " + (
                f"default designs reach {100 * worst:.1f} % or more of an independent"
                f" search's certified optimum on {len(rows)} stages" if rows else
                "no reference optima recorded (tests/global_references.json)"))
    return BenchResult(
        name="global phase (cost and optimum)",
        robrst_path="CMA-ES global phase, polished by IPOPT, certified",
        baseline="import floor; differential evolution with a dense-grid feasibility test",
        goal="paper_robust <= 2x its import floor; >= 95 % of the reference optimum",
        headline=head, met=bool(ratio <= 2.0 and (not rows or worst >= 0.95)),
        figures={"cpu_s": times, "median_cpu_s": med, "floor_ratio": ratio,
                 "quality": rows, "load_average": os.getloadavg(),
                 "first_samples_cpu_s": kernel, "first_samples_speedup": speedup,
                 "pole_derivatives_cpu_s": derivs, "pole_derivatives_speedup": derivs_speedup},
        table=tuple(table))
