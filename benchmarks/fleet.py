"""A fleet design end to end: design, verification on fresh draws, the price of yield.

``python -m benchmarks.fleet PROBLEM [--out DIR] [--n 1000] [--workers 2]
[--targets 0.5 0.8 0.9 0.95] [--tradeoff-n 200] [--scaling RESULT_JSON]``

1. ``robrst design PROBLEM --json`` (the fleet design; its ``fleet`` object states N, the
   compression set and the guarantee) -> ``DIR/result.json``;
2. the verification: an analysis sweep of ``n`` *fresh* actuators (another seed) of the
   problem's spread on the designed controller (:func:`robrst.studies.fleet.verify_fleet`,
   Dask) -> ``DIR/verification/`` and ``DIR/fleet.json``;
3. the price of yield: the same fleet design for each yield target (N from the scenario
   bound at the target) and the nominal design (no spread), each verified on
   ``tradeoff-n`` fresh draws -> ``DIR/fleet.json`` ``tradeoff``;
4. the report (``robrst.report._fleet``: draws the records, computes nothing) -> ``DIR``.
"""

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

from robrst.base.fileio import atomic_write_text, json_text
from robrst.design import run_problem
from robrst.problem.files import load_problem
from robrst.studies.fleet import FRESH_SEED_OFFSET, verification_toml, verify_fleet


def _design(problem, out, say):
    t0 = time.perf_counter()
    result = run_problem(problem, progress=say)
    wall = time.perf_counter() - t0
    d = result.as_dict()
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "result.json", json_text(d))
    return result, d, wall


def run(path, out, n=1000, workers=2, targets=(), tradeoff_n=200, say=print, reuse=False):
    """Design, verify and (with ``targets``) trade off; returns the records written."""
    out = Path(out)
    problem = load_problem(path)
    if reuse and (out / "result.json").is_file():      # a design of an earlier run
        d = json.loads((out / "result.json").read_text(encoding="utf-8"))
        wall = d["fleet"]["wall_time_s"]
        say(f"reusing {out / 'result.json'}")
    else:
        say(f"designing {problem.name} for its spread")
        _, d, wall = _design(problem, out, say)
    fleet = d["fleet"]
    say(f"fleet design: {wall:.1f} s, {fleet['scenarios']} actuators, guarantee"
        f" {fleet['guaranteed_yield']}; verifying on {n} fresh draws")
    t0 = time.perf_counter()
    ver = verify_fleet(problem, out / "result.json", out / "verification", n=n,
                       workers=workers, guaranteed_yield=fleet["guaranteed_yield"],
                       restart=True)
    say(f"verified: {ver.certified}/{ver.n} certify ({time.perf_counter() - t0:.1f} s)")
    atomic_write_text(out / "verification.toml", verification_toml(
        problem.name, problem.spread, n, problem.spread.seed + FRESH_SEED_OFFSET))
    nominal = replace(problem, spread=None)
    t0 = time.perf_counter()
    nom = run_problem(nominal)
    nominal_wall = time.perf_counter() - t0
    records = {"problem": problem.name, "design": d, "design_wall_s": wall,
               "nominal_design_wall_s": nominal_wall,
               "nominal_integral_gain": nom.integral_gain,
               "verification": {**ver.as_dict(), "sweep": "verification"}, "tradeoff": []}
    if targets:        # the design above is the trade-off's point at its own target
        records["tradeoff"].append({"yield_target": problem.spread.yield_target,
                                    "integral_gain": d["integral_gain"],
                                    "scenarios": fleet["scenarios"],
                                    "compression_size": fleet["compression_size"],
                                    "guaranteed_yield": fleet["guaranteed_yield"],
                                    "measured_yield": ver.measured_yield,
                                    "yield_ci95": list(ver.yield_ci95), "n": ver.n,
                                    "design_wall_s": wall})
    for target in targets:
        if target == problem.spread.yield_target:
            continue
        say(f"price of yield: target {target}")
        p = replace(problem, spread=replace(problem.spread, yield_target=float(target),
                                            scenarios=None))
        sub = out / "tradeoff" / f"yield_{target:g}"
        r, _, w = _design(p, sub, say)
        v = verify_fleet(problem, sub / "result.json", sub / "verification", n=tradeoff_n,
                         workers=workers, guaranteed_yield=r.fleet.guaranteed_yield,
                         restart=True)
        records["tradeoff"].append({"yield_target": float(target),
                                    "integral_gain": r.integral_gain,
                                    "scenarios": r.fleet.n_scenarios,
                                    "compression_size": len(r.fleet.compression),
                                    "guaranteed_yield": r.fleet.guaranteed_yield,
                                    "measured_yield": v.measured_yield,
                                    "yield_ci95": list(v.yield_ci95), "n": v.n,
                                    "design_wall_s": w})
    if targets:
        sub = out / "tradeoff" / "nominal"
        sub.mkdir(parents=True, exist_ok=True)
        atomic_write_text(sub / "result.json", json_text(nom.as_dict()))
        v = verify_fleet(problem, sub / "result.json", sub / "verification", n=tradeoff_n,
                         workers=workers, restart=True)
        records["tradeoff"].append({"yield_target": None, "integral_gain": nom.integral_gain,
                                    "scenarios": 0, "compression_size": 0,
                                    "guaranteed_yield": None,
                                    "measured_yield": v.measured_yield,
                                    "yield_ci95": list(v.yield_ci95), "n": v.n,
                                    "design_wall_s": nominal_wall})
    atomic_write_text(out / "fleet.json", json_text(records))
    from robrst.report._fleet import write_fleet_report

    write_fleet_report(records, out)
    return records


def scaling(path, result_path, n=200, repeats=3, say=print):
    """Verification speed-up on 2 Dask workers against 1: the same fresh draws, runs
    alternating (1, 2, 1, 2, ...), compute time (wall after the cluster is up); the
    median of the per-repeat ratios."""
    import tempfile

    import numpy as np

    from robrst.studies.fleet import FRESH_SEED_OFFSET, fleet_sweep
    from robrst.studies.sweep import run_sweep

    problem = load_problem(path)
    sp = problem.spread
    sweep = fleet_sweep(problem.path, result_path, sp, n, sp.seed + FRESH_SEED_OFFSET)
    times = {1: [], 2: []}
    for r in range(repeats):
        for w in (1, 2):
            with tempfile.TemporaryDirectory() as tmp:
                res = run_sweep(sweep, Path(tmp) / "v", workers=w)
            s = res.summary
            times[w].append(s["wall_s"] - s["startup_s"])
            say(f"repeat {r}: {w} worker(s): {times[w][-1]:.1f} s compute"
                f" ({s['certified']}/{s['done']} certified)")
    ratio = float(np.median(np.array(times[1]) / np.array(times[2])))
    return {"n": n, "repeats": repeats, "compute_s": times, "speedup_2_workers": ratio}


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m benchmarks.fleet", description=__doc__)
    ap.add_argument("problem")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--targets", type=float, nargs="*", default=())
    ap.add_argument("--tradeoff-n", type=int, default=200)
    ap.add_argument("--reuse", action="store_true", help="reuse OUT/result.json (the design"
                    " of an earlier run) instead of designing again")
    ap.add_argument("--scaling", type=Path, default=None, metavar="RESULT_JSON",
                    help="only measure the verification's speed-up on 2 workers for this"
                    " design result (alternating runs of --n draws)")
    a = ap.parse_args(argv)

    def say(msg):
        print(msg, file=sys.stderr, flush=True)

    if a.scaling is not None:
        out = scaling(a.problem, a.scaling, a.n, say=say)
        a.out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(a.out / "scaling.json", json_text(out))
        say(f"speed-up on 2 workers: {out['speedup_2_workers']:.2f}x")
        return 0
    run(a.problem, a.out, a.n, a.workers, a.targets, a.tradeoff_n, say, a.reuse)
    return 0


if __name__ == "__main__":
    sys.exit(main())
