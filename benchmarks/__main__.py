"""``python -m benchmarks [--tiny] [--only NAME ...] [--out DIR]``: run, print, write reports."""

import argparse
import importlib
import sys
import time
from pathlib import Path

from benchmarks.harness import write_reports

BENCHES = ("analytic", "synthesis", "global", "variants", "scaling", "peaks", "twin", "diagnosis",
           "sweep", "userflow")


def available():
    """Benchmark modules present in this checkout (in report order)."""
    out = []
    for name in BENCHES:
        try:
            out.append((name, importlib.import_module(f"benchmarks.bench_{name}")))
        except ModuleNotFoundError as exc:
            if exc.name != f"benchmarks.bench_{name}":
                raise
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    ap.add_argument("--tiny", action="store_true", help="smoke sizes (what the tests run)")
    ap.add_argument("--only", nargs="+", choices=BENCHES, help="run only these")
    ap.add_argument("--out", type=Path, default=Path(__file__).parents[1] / "reports",
                    help="folder for benchmarks.md and benchmarks.json (default reports/)")
    args = ap.parse_args(argv)
    results = []
    for name, mod in available():
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        print(f"[{name}] running ...", file=sys.stderr, flush=True)
        r = mod.run(tiny=args.tiny)
        print(f"[{name}] {time.perf_counter() - t0:.1f} s: {r.headline}"
              f" -> goal {'met' if r.met else 'NOT met'}", file=sys.stderr, flush=True)
        results.append(r)
    md = write_reports(results, args.out, "tiny" if args.tiny else "full")
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
