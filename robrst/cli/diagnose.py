"""``robrst diagnose``: where a simulation model misses measured data, and why."""

from robrst.cli.common import progress_printer
from robrst.fileio import atomic_write_text, check_file_target, check_folder_target, json_text

__all__ = ["add_parsers", "run_diagnose"]


def add_parsers(sub):
    """Register ``diagnose``."""
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
    g.add_argument("--force", action="store_true",
                   help="write the report into an existing folder that is not a robrst report")
    g.add_argument("--quiet", action="store_true", help="no progress lines")
    g.set_defaults(func=run_diagnose)


def run_diagnose(args):
    """Load the records, diagnose, write JSON/report, print the summary."""
    from robrst.dataset import load_dataset
    from robrst.diagnose import diagnose
    from robrst.diagnose.summary import summary_text
    from robrst.spec import load_problem

    to_stdout = args.json == "-"
    if args.json and not to_stdout:
        check_file_target(args.json)              # bad targets fail before the work
    if args.report:
        check_folder_target(args.report)
    say = progress_printer(args.quiet or to_stdout)
    train = [load_dataset(f) for f in args.train]
    test = [load_dataset(f) for f in args.test]
    plant, ref = None, None
    if args.model:
        fam = load_problem(args.model).family
        plant, ref = fam.reference_model, fam.reference_model.temperature_C
    diag = diagnose(train, test, plant=plant, reference_C=ref, progress=say)
    text = json_text(diag.as_dict(), indent=1)
    if args.report:
        from robrst.report.diagnosis import write_diagnosis_report

        out = write_diagnosis_report(diag, args.report, progress=say, force=args.force)
        say(f"wrote the diagnosis report to {out}")
    if to_stdout:
        print(text)
    else:
        if args.json:
            atomic_write_text(args.json, text + "\n")
            say(f"wrote {args.json}")
        print(summary_text(diag))
    return 0
