"""``robrst simulate``: the paper's experiments or a user's scenario on the digital twin,
open loop or in closed loop with a saved design or an exported C controller."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from robrst.cli._common import print_json, progress_printer
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
    s = sub.add_parser("simulate", help="run one of the paper's experiments, or a scenario"
                                        " file (steps, ramps, multisines, temperature), on the"
                                        " digital twin")
    s.add_argument("scenario", help="fig2 | fig3 | fig45 | fig7 | fig8, or a scenario file"
                                    " (TOML)")
    s.add_argument("--twin", help="twin file (TOML); default: the built-in paper twin (a"
                                  " scenario file with a saved design: its plant, every effect"
                                  " off)")
    s.add_argument("--controller", metavar="FILE",
                   help="closed loop: a saved design (DESIGN.json), a problem file (designed)"
                        " or the C of robrst export --format c (ctrl.c); fig7/fig8: replaces"
                        " the robust design")
    s.add_argument("--precision", choices=("float64", "float32"),
                   help="the controller's arithmetic (default the scenario file's, float64)")
    s.add_argument("--out", help="output folder (default reports/simulate/SCENARIO)")
    s.add_argument("--fast", action="store_true", help="shorter thermal ramps and sweeps")
    s.add_argument("--json", action="store_true", help="print exactly one JSON object")
    s.add_argument("--force", action="store_true",
                   help="write into an existing folder robrst did not write (nothing else in"
                        " it is touched)")
    s.add_argument("--quiet", action="store_true", help="no progress lines")
    s.set_defaults(func=run_simulate)


def _design(arg, say):
    """The design result of ``--controller`` (saved: read back; a problem file: designed)."""
    from robrst.cli._common import design_result

    return design_result(arg, say)


def _is_c(path):
    return Path(path).suffix in (".c", ".h")


def _user(args, say):
    """Load a scenario file, its twin and its controller."""
    from robrst.studies.closedloop import controller_of_c_file, controller_of_design
    from robrst.studies.twins import load_twin, twin_of_design
    from robrst.studies.user_scenario import load_scenario

    from dataclasses import replace

    sc = load_scenario(args.scenario)
    ctrl_arg = args.controller or (str(sc.resolve(sc.controller)) if sc.controller else None)
    twin_arg = args.twin or (str(sc.resolve(sc.twin)) if sc.twin else None)
    sc = replace(sc, precision=args.precision or sc.precision, controller=ctrl_arg)
    if ctrl_arg is None:
        cfg = load_twin(twin_arg) if twin_arg else _paper_twin()
        return sc, cfg, None
    if _is_c(ctrl_arg):
        lc = controller_of_c_file(ctrl_arg)
        if twin_arg is None:
            raise SpecError(f"{ctrl_arg}: a C controller holds no plant; give the twin"
                            " (--twin or [scenario] twin)")
        return sc, load_twin(twin_arg, lc.sample_rate_hz), lc
    result = _design(ctrl_arg, say)
    if twin_arg is None:
        cfg = twin_of_design(result)
    else:
        cfg = load_twin(twin_arg, result.problem.specs.sample_rate_hz)
    sat = cfg.effects["saturation"]
    rng = (sat["u_min"], sat["u_max"]) if cfg.enabled("saturation") else None
    return sc, cfg, controller_of_design(result, cfg.sample_rate_hz, None, rng)


def _paper_twin():
    from robrst.twin.config import default_twin

    return default_twin()


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
        An unknown scenario (neither a paper's figure nor a scenario file), or
        ``--controller``/``--precision`` for a figure that runs no controller.
    """
    from robrst.studies.scenarios import SCENARIOS, run_scenario
    from robrst.report.doc import check_report_target
    from robrst.report.scenario import write_scenario

    user = args.scenario not in SCENARIOS
    if user and not Path(args.scenario).is_file():   # before any progress line: one line
        raise SpecError(f"unknown scenario {args.scenario!r}; expected one of"
                        f" {', '.join(SCENARIOS)}, or a scenario file")
    say = progress_printer(args.quiet or args.json)
    if user:
        from robrst.studies.user_scenario import load_scenario, run_user_scenario

        name = load_scenario(args.scenario).name        # a bad file fails before the work
        out = args.out or f"reports/simulate/{name}"
        check_report_target(out, args.force)
        sc, cfg, lc = _user(args, say)
        res = run_user_scenario(sc, cfg, lc, progress=say)
    else:
        from robrst.studies.twins import load_twin
        from robrst.twin.config import default_twin

        if args.precision and args.scenario not in ("fig7", "fig8"):
            raise SpecError(f"--precision: {args.scenario} runs no controller")
        cfg = load_twin(args.twin) if args.twin else default_twin()
        out = args.out or f"reports/simulate/{args.scenario}"
        check_report_target(out, args.force)      # a bad target fails before the simulation
        ctrls = None
        if args.controller is not None:
            if args.scenario not in ("fig7", "fig8"):
                raise SpecError(f"--controller: {args.scenario} runs no controller (fig7 and"
                                " fig8 do)")
            if _is_c(args.controller):
                raise SpecError("--controller: fig7 and fig8 take a saved design or a problem"
                                " file (a C controller runs in a scenario file)")
            from robrst.design import analytic_design
            from robrst.problem.files import load_problem

            result = _design(args.controller, say)
            ctrls = {"analytic": analytic_design(load_problem("paper")).controller,
                     result.problem.name: result.controller}
        say(f"simulating {args.scenario} on twin {cfg.name} ({cfg.sample_rate_hz:g} Hz) -> {out}")
        res = run_scenario(args.scenario, cfg, fast=args.fast, ctrls=ctrls)
    write_scenario(res, out, force=args.force)
    d = {"scenario": res.name, "claim": res.claim, "notes": list(res.notes),
         "metrics": res.metrics, "out": str(out),
         "datasets": sorted(f"{k}.csv" for k in res.datasets), "figure": f"{res.name}.png"}
    if args.json:
        print_json(d)
    else:
        print(f"{res.name}: {res.claim}")
        for n in res.notes:
            print(f"WARNING: {n}")
        print(json_text(res.metrics, indent=2))
        print(f"wrote {len(res.datasets)} datasets and {res.name}.png to {out}")
    return 0
