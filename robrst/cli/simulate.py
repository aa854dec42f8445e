"""``robrst simulate``: the paper's experiments on the digital twin."""

from __future__ import annotations

from typing import TYPE_CHECKING

from robrst.cli.common import print_json, progress_printer
from robrst.base.errors import SpecError
from robrst.base.fileio import json_text

if TYPE_CHECKING:
    import argparse

__all__ = ["add_parsers", "run_simulate"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``simulate``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    s = sub.add_parser("simulate", help="run one of the paper's experiments on the digital twin")
    s.add_argument("scenario", help="fig2 | fig3 | fig45 | fig7 | fig8")
    s.add_argument("--twin", help="twin file (TOML); default: the built-in paper twin")
    s.add_argument("--out", help="output folder (default reports/simulate/SCENARIO)")
    s.add_argument("--fast", action="store_true", help="shorter thermal ramps and sweeps")
    s.add_argument("--json", action="store_true", help="print exactly one JSON object")
    s.add_argument("--force", action="store_true",
                   help="write into an existing folder robrst did not write (nothing else in"
                        " it is touched)")
    s.add_argument("--quiet", action="store_true", help="no progress lines")
    s.set_defaults(func=run_simulate)


def run_simulate(args: argparse.Namespace) -> int:
    """Run the scenario, write its datasets and figure, print its metrics.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.

    Raises
    ------
    SpecError
        An unknown scenario name.
    """
    from robrst.studies.scenarios import SCENARIOS, run_scenario
    from robrst.report.doc import check_report_target
    from robrst.report.scenario import write_scenario

    if args.scenario not in SCENARIOS:    # before any progress line: one line, exit 2
        raise SpecError(f"unknown scenario {args.scenario!r}; expected one of"
                        f" {', '.join(SCENARIOS)}")
    from robrst.twin.config import default_twin, load_twin

    say = progress_printer(args.quiet or args.json)
    cfg = load_twin(args.twin) if args.twin else default_twin()
    out = args.out or f"reports/simulate/{args.scenario}"
    check_report_target(out, args.force)          # a bad target fails before the simulation
    say(f"simulating {args.scenario} on twin {cfg.name} ({cfg.sample_rate_hz:g} Hz) -> {out}")
    res = run_scenario(args.scenario, cfg, fast=args.fast)
    write_scenario(res, out, force=args.force)
    d = {"scenario": res.name, "claim": res.claim, "metrics": res.metrics, "out": str(out),
         "datasets": sorted(f"{k}.csv" for k in res.datasets), "figure": f"{res.name}.png"}
    if args.json:
        print_json(d)
    else:
        print(f"{res.name}: {res.claim}")
        print(json_text(res.metrics, indent=2))
        print(f"wrote {len(res.datasets)} datasets and {res.name}.png to {out}")
    return 0
