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


def run(tiny=False, repeats=5):
    times = cli_costs(1 if tiny else repeats)
    med = {k: float(np.median(v)) for k, v in times.items()}
    ratio = float(np.median(np.asarray(times["default"]) / np.asarray(times["floor"])))
    kernel, kernel_diff = first_samples_kernel(3 if tiny else 15)
    speedup = median_ratio(kernel, "every_power", "blocks")
    rows = quality(tiny)
    worst = min((r[3] for r in rows), default=np.nan)
    table = ["| stage | reference (DE) | default design | share | design CPU [s] |"
             " reference CPU [s] |", "|---|---|---|---|---|---|"]
    table += [f"| {n} | {ref:.6g} | {ki:.6g} | {100 * sh:.1f} % | {cpu:.1f} | {rc} |"
              for n, ref, ki, sh, cpu, rc in rows]
    table += ["", f"The screen's first samples (60 candidates x 8 models x 6 modes):"
              f" {1e3 * np.median(kernel['blocks']):.2f} ms per call in blocks against"
              f" {1e3 * np.median(kernel['every_power']):.2f} ms over every power"
              f" ({speedup:.1f}x, largest difference {kernel_diff:.1e})."]
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
                 "first_samples_cpu_s": kernel, "first_samples_speedup": speedup},
        table=tuple(table))
