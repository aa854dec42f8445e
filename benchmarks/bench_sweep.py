"""Sweeps: throughput per worker, speed-up on 2 Dask workers, per-variant CPU cost, and the
extrapolation to 10,000 and 1,000,000 variants.

* **Analysis** (paper_montecarlo's controller and spread, ``n`` variants): the in-process run
  (``workers=0``, the baseline: the loop a user would write) and the same sweep on a running
  2-process local cluster alternate; the speed-up is the median of the per-repeat ratios of
  the *compute* time (wall time after the context and the cluster are ready).  The
  end-to-end time with a fresh local cluster (``workers=2``: start-up included) is reported
  once.  CPU per variant (process time of each variant, mean and median over variants) is
  measured alone first, in this process before any cluster exists (the variant's own
  cost), then in the 2 busy workers (on a 2-core machine whose cores share caches, ~10 %
  more) and in this process next to an idle cluster (its scheduler runs here).
* **Design** (a grid of 11 ``specs.Mu_max``, one robust NLP design each, in process, each
  one local solve: ``multistart = false``, the engine's cost without the global phase): the
  CPU per design of paper_robust (the sampled 2-DOF design: synthesis, certificate of both
  loops, tracking and the step responses of every model) and of paper_robust_continuous
  (the problem of the shipped trade-off sweep ``paper_tradeoff``).  A worker's first
  design also builds the NLP programs (once per worker and structure; the variants after
  it reuse them): the cost per design is the mean over the designs after the first, and
  the first one's excess is a start-up of each worker.
* **Extrapolation**: ``start-up + n * cpu / (N * efficiency)`` with the measured CPU per
  variant, start-up (for designs, with the build of the first) and engine efficiency (the
  share of the workers' wall time spent inside variants: what the engine loses to
  scheduling, transfer, writing and the tail), i.e. for workers that each have a core to
  themselves.  On a shared machine the measured speed-up also loses what other processes
  take (``cpu_share_*``: CPU / wall inside the variants).
"""

import logging
import os
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks.harness import BenchResult
from robrst.studies.sweep import load_sweep, parse_sweep, run_sweep

# the engine's cost per design: one local solve each ([set.solver] multistart = false; the
# default design's global phase, 20-40 s of CPU per design, is measured by bench_global)
DESIGN = {"sweep": {"name": "bench_design", "kind": "design", "problem": "paper_robust"},
          "set": {"solver": {"multistart": False}},
          "param": [{"name": "specs.Mu_max", "dist": "grid", "lo": 120.0, "hi": 200.0,
                     "steps": 11}]}
DESIGN_CONTINUOUS = {"sweep": {**DESIGN["sweep"], "problem": "paper_robust_continuous"},
                     "set": DESIGN["set"], "param": DESIGN["param"]}
TINY_ANALYSIS = {"sweep": {"name": "bench_analysis_tiny", "kind": "analysis", "problem": "paper",
                           "n": 10, "chunk_size": 5},
                 "param": [{"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.05}]}
TINY_DESIGN = {"sweep": {"name": "bench_design_tiny", "kind": "design", "problem": "paper"},
               "param": [{"name": "poles.wn", "dist": "grid", "values": [500.0, 700.0]}]}


def _compute_s(res):
    return res.summary["wall_s"] - res.summary["startup_s"]


def _cpu(res):
    c = np.array([v for v in res.table.column("cpu_s").to_pylist() if v is not None])
    return float(np.median(c)), float(np.mean(c))


def _design_cpu(res):
    """CPU of an in-process design sweep: its first design (which builds the NLP programs)
    and the mean and median of the others (the cost per design)."""
    c = res.table.column("cpu_s").to_pylist()      # in process: in the order they ran
    rest = np.array([v for v in c[1:] if v is not None]) if len(c) > 1 else np.array(c[:1])
    return c[0], float(np.mean(rest)), float(np.median(rest))


def _cluster(tiny):
    from distributed import LocalCluster

    return LocalCluster(n_workers=2, threads_per_worker=1, processes=not tiny,
                        dashboard_address=None, silence_logs=logging.ERROR)


def _extrapolate(kind, cpu, startup, eff, workers=(2, 8, 32, 128)):
    rows = []
    for n in (10_000, 1_000_000):
        cells = [_fmt_s(startup + n * cpu / (w * eff)) for w in workers]
        rows.append(f"| {n:,} | {kind} | " + " | ".join(cells) + " |")
    return rows


def _fmt_s(t):
    return f"{t:.0f} s" if t < 120 else (f"{t / 60:.0f} min" if t < 7200 else f"{t / 3600:.1f} h")


def _sum(res, col):
    return float(sum(v for v in res.table.column(col).to_pylist() if v is not None))


def _engine_efficiency(res):
    """Share of the workers' time spent inside variants (wall): 1 - the engine's overhead."""
    return _sum(res, "seconds") / (res.summary["workers"] * _compute_s(res))


def _cpu_share(res):
    """CPU time / wall time inside the variants: below 1, other processes took the cores."""
    return _sum(res, "cpu_s") / _sum(res, "seconds")


def run(tiny=False, repeats=5):
    n = 10 if tiny else 200
    sweep = parse_sweep(TINY_ANALYSIS) if tiny else replace(load_sweep("paper_montecarlo"), n=n)
    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    alone = run_sweep(sweep, tmp / "alone", workers=0)     # before any cluster exists
    cluster = _cluster(tiny)
    seq, par = [], []
    try:
        for r in range(1 if tiny else repeats):     # alternating, same process
            seq.append(run_sweep(sweep, tmp / f"seq{r}", workers=0))
            par.append(run_sweep(sweep, tmp / f"par{r}", scheduler=cluster.scheduler_address))
    finally:
        cluster.close()
    ratios = [_compute_s(a) / _compute_s(b) for a, b in zip(seq, par)]
    speedup = float(np.median(ratios))
    fresh = par[-1] if tiny else run_sweep(sweep, tmp / "fresh", workers=2)
    cpu_med, cpu_mean = _cpu(alone)
    cpu_med_busy, cpu_mean_busy = _cpu(seq[-1])
    cpu_workers = float(np.median([b.summary["cpu_s_per_variant"] for b in par]))
    rate_seq = n / float(np.median([_compute_s(a) for a in seq]))
    rate_par = n / float(np.median([_compute_s(b) for b in par]))
    design = run_sweep(parse_sweep(TINY_DESIGN if tiny else DESIGN), tmp / "design", workers=0)
    dcpu_med, dcpu_mean = _cpu(design)
    dfirst, dcpu, dcpu_rest_med = _design_cpu(design)
    dcert = design.summary["certified"]
    cont = None if tiny else run_sweep(parse_sweep(DESIGN_CONTINUOUS), tmp / "design_c",
                                       workers=0)
    ccpu_med, ccpu_mean = (dcpu_med, dcpu_mean) if tiny else _cpu(cont)
    cfirst, ccpu, ccpu_rest_med = (dfirst, dcpu, dcpu_rest_med) if tiny else _design_cpu(cont)
    eng = float(np.median([_engine_efficiency(b) for b in par]))
    startup = fresh.summary["startup_s"]
    what = ("paper (tiny)", "paper, analytic (tiny)") if tiny else (
        "paper_montecarlo: certificate on 7 family models + 12-point sweep, margins",
        "paper_robust NLP")
    table = [f"Analysis ({what[0]}): {cpu_mean:.3f} s CPU per variant alone (median"
             f" {cpu_med:.3f} s), {cpu_workers:.3f} s in each of 2 busy workers,"
             f" {cpu_mean_busy:.3f} s in process next to an idle cluster; design ({what[1]}):"
             f" {dcpu:.3f} s CPU per design after a worker's first (median {dcpu_rest_med:.3f}"
             f" s; the first, which builds the NLP programs: {dfirst:.2f} s in this process"
             " after the analysis sweeps;"
             " paper_robust_continuous, the trade-off sweep's problem:"
             f" {ccpu:.3f} s, first {cfirst:.2f} s); engine efficiency {eng:.2f} (share of"
             " the workers' time inside variants); time = start-up + n × CPU / (workers ×"
             " efficiency) with the CPU per variant of a busy worker, each worker on its own"
             f" core; start-up {startup:.1f} s (context + local cluster), for designs"
             f" {startup + dfirst - dcpu:.1f} s (with each worker's first design's build).",
             "", "| variants | kind | 2 workers | 8 workers | 32 workers | 128 workers |",
             "|---|---|---|---|---|---|"]
    table += _extrapolate("analysis", cpu_workers, startup, eng)   # busy workers
    table += _extrapolate("design", dcpu, startup + dfirst - dcpu, eng)
    head = (f"analysis: {cpu_mean * 1e3:.0f} ms CPU/variant alone (median {cpu_med * 1e3:.0f}"
            f" ms; {cpu_workers * 1e3:.0f} ms in each of 2 busy workers),"
            f" {rate_seq:.1f} variants/s on 1"
            f" worker, {rate_par / 2:.1f}/s per worker on 2; speed-up {speedup:.2f}× on {n}"
            f" variants (workers inside variants {eng:.0%} of the time)"
            f"; end-to-end with cluster start {fresh.summary['wall_s']:.1f} s"
            f"; design: {dcpu:.3f} s CPU/design after a worker's first (sampled 2-DOF"
            f" paper_robust; the first, which builds the programs, {dfirst:.2f} s),"
            f" {ccpu:.3f} s (paper_robust_continuous)")
    return BenchResult(
        name="sweeps on Dask", robrst_path="run_sweep: chunks on a 2-process local cluster",
        baseline="the same sweep in one process (workers=0)",
        goal="≥ 1.8× on 2 workers (200 variants); ≤ 0.15 s CPU/analysis, ≤ 0.2 s CPU/design",
        headline=head, met=bool(speedup >= 1.8 and cpu_mean <= 0.15 and dcpu <= 0.2),
        figures={"n": n, "speedup": speedup, "ratios": ratios,
                 "compute_s_sequential": [_compute_s(a) for a in seq],
                 "compute_s_2_workers": [_compute_s(b) for b in par],
                 "variants_per_s_1_worker": rate_seq, "variants_per_s_per_worker_2": rate_par / 2,
                 "cpu_s_per_variant_median": cpu_med, "cpu_s_per_variant_mean": cpu_mean,
                 "cpu_s_per_variant_median_next_to_cluster": cpu_med_busy,
                 "cpu_s_per_variant_mean_next_to_cluster": cpu_mean_busy,
                 "cpu_s_per_variant_workers_median": cpu_workers,
                 "cpu_s_per_variant_2_workers": [b.summary["cpu_s_per_variant"] for b in par],
                 "engine_efficiency_2_workers": [_engine_efficiency(b) for b in par],
                 "cpu_share_2_workers": [_cpu_share(b) for b in par],
                 "cpu_share_sequential": [_cpu_share(a) for a in seq],
                 "load_average_1min_end": os.getloadavg()[0],
                 "end_to_end_s_fresh_cluster": fresh.summary["wall_s"], "startup_s": startup,
                 "design_cpu_s_median": dcpu_med, "design_cpu_s_mean": dcpu_mean,
                 "design_cpu_s_first": dfirst, "design_cpu_s_mean_after_first": dcpu,
                 "design_cpu_s_median_after_first": dcpu_rest_med,
                 "design_continuous_cpu_s_first": cfirst,
                 "design_continuous_cpu_s_mean_after_first": ccpu,
                 "design_continuous_cpu_s_median_after_first": ccpu_rest_med,
                 "designs_certified": dcert, "designs": design.summary["done"],
                 "design_continuous_cpu_s_median": ccpu_med,
                 "design_continuous_cpu_s_mean": ccpu_mean,
                 "designs_continuous_certified": None if tiny else cont.summary["certified"]},
        table=tuple(table))
