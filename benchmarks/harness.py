"""Alternating timing, median ratios, and the benchmark report (Markdown + JSON)."""

import json
import platform
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from robrst.base.fileio import atomic_write_text

__all__ = ["BenchResult", "alternate", "median_ratio", "render_markdown", "write_reports"]


@dataclass(frozen=True)
class BenchResult:
    """One benchmark: what ran, the headline figure, whether its goal was met."""

    name: str
    robrst_path: str
    baseline: str
    goal: str
    headline: str
    met: bool
    figures: dict = field(default_factory=dict)   # raw numbers (JSON)
    table: tuple = ()                             # extra Markdown lines (e.g. a scaling table)


def alternate(fns, repeats, clock=time.perf_counter):
    """Run the callables of ``fns`` (name -> f) round-robin ``repeats`` times.

    Returns ``(times, outputs)``: per name the list of times [s] by ``clock`` (wall time
    by default; ``time.process_time`` for CPU time, steadier on a shared machine) and the
    last return value.  Alternation spreads machine noise evenly over the contenders.
    """
    times = {k: [] for k in fns}
    outputs = {}
    for _ in range(repeats):
        for k, f in fns.items():
            t0 = clock()
            outputs[k] = f()
            times[k].append(clock() - t0)
    return times, outputs


def median_ratio(times, slow, fast):
    """Median over repeats of ``t_slow / t_fast`` (paired by repeat)."""
    return float(np.median(np.asarray(times[slow]) / np.asarray(times[fast])))


def render_markdown(results, meta):
    """The Markdown report: one summary table, then each benchmark's detail lines."""
    lines = ["# robrst benchmarks", "",
             f"Machine: {meta['machine']}; Python {meta['python']}; mode: {meta['mode']};"
             f" {meta['date']}.", "",
             "Ratios are medians of per-repeat ratios, robrst and baseline alternating in"
             " the same process.", "",
             "| benchmark | robrst path | baseline | goal | result | met |",
             "|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r.name} | {r.robrst_path} | {r.baseline} | {r.goal} | {r.headline}"
                     f" | {'yes' if r.met else '**no**'} |")
    for r in results:
        if r.table:
            lines += ["", f"## {r.name}", "", *r.table]
    return "\n".join(lines) + "\n"


def write_reports(results, out_dir, mode):
    """Write ``benchmarks.md`` and ``benchmarks.json`` atomically into ``out_dir``."""
    meta = {"machine": f"{platform.machine()} {platform.system()}",
            "python": platform.python_version(), "mode": mode,
            "date": time.strftime("%Y-%m-%d")}
    md = render_markdown(results, meta)
    raw = {"meta": meta, "results": [asdict(r) for r in results]}
    atomic_write_text(out_dir / "benchmarks.md", md)
    atomic_write_text(out_dir / "benchmarks.json", json.dumps(raw, indent=2, default=float))
    return md
