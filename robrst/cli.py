"""Command-line interface: ``robrst design | simulate | diagnose | report``.

A thin layer: parse arguments, call the pipeline, print.  Every robrst error becomes
one line on stderr and exit code 2 (1 for an uncertified design).
"""

import argparse
import json
import math
import sys

from robrst import cli_convert, cli_identify
from robrst.errors import RobrstError

__all__ = ["main"]


def _fmt(x, spec):
    if x is None:
        return "inf"
    if isinstance(x, float) and not math.isfinite(x):
        return "inf"
    return format(x, spec)


def margins_table(d):
    """Human-readable margins table of a design's JSON dict."""
    head = (f"{'model':<8}{'T[°C]':>7}{'stable':>8}{'Ms':>8}{'Mt':>8}{'Mu[V/µm]':>10}"
            f"{'GM':>8}{'PM[°]':>8}{'MM':>7}{'DM[µs]':>9}")
    lines = [head, "-" * len(head)]
    for m in d["models"]:
        dm = None if m["delay_margin_s"] is None else m["delay_margin_s"] * 1e6
        lines.append(
            f"{m['label']:<8}{m['temperature_C']:>7.1f}{str(m['stable']):>8}{m['Ms']:>8.3f}"
            f"{m['Mt']:>8.3f}{m['Mu']:>10.2f}{_fmt(m['gain_margin'], '.2f'):>8}"
            f"{_fmt(m['phase_margin_deg'], '.1f'):>8}{m['modulus_margin']:>7.3f}"
            f"{_fmt(dm, '.1f'):>9}"
        )
    return "\n".join(lines)


def _summary(d):
    from robrst.design import sampled_summary

    out = [f"problem {d['problem']}  method {d['method']}  certified: {d['certified']}"]
    c = d["controller"]
    for k in "RST":
        out.append(f"  {k}(s) = " + " ".join(f"{v:.6g}" for v in c[k]))
    out.append(margins_table(d))
    cert = d["certificate"]
    out.append(f"certificate: {len(cert['models'])} models checked (family + temperature sweep),"
               f" {len(cert['violations'])} violations")
    line = sampled_summary(d)
    if line:
        out.append(line)
    if "analytic_check" in d:
        ac = d["analytic_check"]
        out.append(f"analytic check: max rel. coefficient error {ac['max_rel_coef_error']:.2e}"
                   f" -> {'passed' if ac['passed'] else 'FAILED'}")
    if d.get("comparison"):
        out.append(d["comparison"]["table"])
    return "\n".join(out)


def cmd_design(args):
    from robrst.design import run_problem
    from robrst.spec import load_problem

    quiet = args.quiet or args.json
    say = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    result = run_problem(load_problem(args.problem), progress=say)
    d = result.as_dict()
    if args.json:
        print(json.dumps(d, allow_nan=False, default=_json_default))
    else:
        print(_summary(d))
    if not result.certified:
        for v in result.certificate.violations[:5]:
            print(f"robrst: not certified: {v.describe()}", file=sys.stderr)
        return 1
    return 0


def cmd_simulate(args):
    from robrst.twin.config import default_twin, load_twin
    from robrst.twin.scenarios import run_scenario

    quiet = args.quiet or args.json
    say = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    cfg = load_twin(args.twin) if args.twin else default_twin()
    out = args.out or f"reports/simulate/{args.scenario}"
    say(f"simulating {args.scenario} on twin {cfg.name} ({cfg.fs_hz:g} Hz) -> {out}")
    res = run_scenario(args.scenario, cfg, out_dir=out, fast=args.fast)
    d = {"scenario": res.name, "claim": res.claim, "metrics": res.metrics, "out": str(out),
         "datasets": sorted(f"{k}.csv" for k in res.datasets), "figure": f"{res.name}.png"}
    if args.json:
        print(json.dumps(d, allow_nan=False, default=_json_default))
    else:
        print(f"{res.name}: {res.claim}")
        print(json.dumps(res.metrics, indent=2, default=_json_default))
        print(f"wrote {len(res.datasets)} datasets and {res.name}.png to {out}")
    return 0


def cmd_report(args):
    from robrst.design import run_problem
    from robrst.report.design import write_design_report
    from robrst.spec import load_problem

    say = (lambda m: None) if args.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    problem = load_problem(args.problem)
    out = args.out or f"reports/{problem.name}"
    say(f"designing {problem.name} ({problem.solver['method']})")
    result = run_problem(problem, progress=say)
    path = write_design_report(result, out, progress=say)
    print(f"wrote {path}/report.md, report.html, result.json and figures"
          f" (certified: {result.certified})")
    return 0 if result.certified else 1


def cmd_diagnose(args):
    from robrst.dataset import load_dataset
    from robrst.diagnose import diagnose
    from robrst.diagnose.summary import summary_text
    from robrst.fileio import atomic_write_text

    to_stdout = args.json == "-"
    quiet = args.quiet or to_stdout
    say = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    train = [load_dataset(f) for f in args.train]
    test = [load_dataset(f) for f in args.test]
    plant, ref = None, None
    if args.model:
        from robrst.spec import load_problem

        fam = load_problem(args.model).family
        plant, ref = fam.reference_model, fam.reference_model.temperature_C
    diag = diagnose(train, test, plant=plant, reference_C=ref, progress=say)
    d = diag.as_dict()
    text = json.dumps(d, allow_nan=False, default=_json_default, indent=1)
    if args.report:
        from robrst.report.diagnosis import write_diagnosis_report

        out = write_diagnosis_report(diag, args.report, progress=say)
        say(f"wrote the diagnosis report to {out}")
    if to_stdout:
        print(text)
    else:
        if args.json:
            atomic_write_text(args.json, text + "\n")
            say(f"wrote {args.json}")
        print(summary_text(diag))
    return 0


def _json_default(x):
    import numpy as np

    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def build_parser():
    p = argparse.ArgumentParser(prog="robrst", description="Robust RST control of piezo actuators")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("design", help="design and certify an RST controller from a problem file")
    d.add_argument("problem", help="problem file (TOML)")
    d.add_argument("--json", action="store_true", help="print exactly one JSON object")
    d.add_argument("--quiet", action="store_true", help="no progress lines")
    d.set_defaults(func=cmd_design)
    s = sub.add_parser("simulate", help="run one of the paper's experiments on the digital twin")
    s.add_argument("scenario", help="fig2 | fig3 | fig45 | fig7 | fig8")
    s.add_argument("--twin", help="twin file (TOML); default: the built-in paper twin")
    s.add_argument("--out", help="output folder (default reports/simulate/SCENARIO)")
    s.add_argument("--fast", action="store_true", help="shorter thermal ramps and sweeps")
    s.add_argument("--json", action="store_true", help="print exactly one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress lines")
    s.set_defaults(func=cmd_simulate)
    g = sub.add_parser("diagnose", help="where a simulation model misses measured data, and why")
    g.add_argument("--train", nargs="+", required=True, metavar="FILE",
                   help="training records (CSV: t,u,y,temp[,yr]); effects are fitted on them")
    g.add_argument("--test", nargs="+", required=True, metavar="FILE",
                   help="held-out records; every reported gap is measured on them")
    g.add_argument("--model", metavar="PROBLEM.toml",
                   help="problem file whose nominal plant is the simulation model"
                        " (default: the paper's D(s))")
    g.add_argument("--json", metavar="OUT.json", help="write the result as JSON ('-' = stdout)")
    g.add_argument("--report", metavar="DIR", help="write a report folder (md, html, figures)")
    g.add_argument("--quiet", action="store_true", help="no progress lines")
    g.set_defaults(func=cmd_diagnose)
    r = sub.add_parser("report", help="design, certify and write a report folder (md, html, PNG)")
    r.add_argument("problem", help="problem file (TOML)")
    r.add_argument("--out", help="output folder (default reports/PROBLEM_NAME)")
    r.add_argument("--quiet", action="store_true", help="no progress lines")
    r.set_defaults(func=cmd_report)
    for command in (cli_identify, cli_convert):
        command.add_parser(sub)
    return p


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except RobrstError as exc:
        print(f"robrst: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("robrst: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
