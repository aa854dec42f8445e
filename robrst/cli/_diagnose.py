"""``robrst diagnose``: where a simulation model misses measured data, and why."""

from __future__ import annotations

from typing import TYPE_CHECKING

from robrst.cli._common import progress_printer
from robrst.base.fileio import WRITTEN_BY, atomic_write_text, check_json_target, json_text

if TYPE_CHECKING:
    import argparse

__all__ = ["add_parsers", "run_diagnose"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``diagnose``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    g = sub.add_parser("diagnose", help="where a simulation model misses measured data, and why")
    g.add_argument("--train", nargs="+", required=True, metavar="FILE",
                   help="training records (CSV: t,u,y,temp[,yr]); effects are fitted on them")
    g.add_argument("--test", nargs="+", required=True, metavar="FILE",
                   help="held-out records; every reported gap is measured on them")
    g.add_argument("--model", metavar="MODEL.toml",
                   help="the simulation model: a problem file (its nominal plant) or a model"
                        " file from `robrst identify` (default: the paper's D(s))")
    g.add_argument("--json", metavar="OUT.json", help="write the result as JSON ('-' = stdout)")
    g.add_argument("--report", metavar="DIR", help="write a report folder (md, html, figures)")
    g.add_argument("--model-out", metavar="DIR",
                   help="write the answer's fitted linear model as model files (robrst-modal-1:"
                        " one per excitation level for amplitude-dependent dynamics; read by"
                        " design for one input and output, by a twin file's plant, by"
                        " diagnose --model)")
    g.add_argument("--force", action="store_true",
                   help="write the report into an existing folder that is not a robrst report")
    g.add_argument("--quiet", action="store_true", help="no progress lines")
    g.set_defaults(func=run_diagnose)


def run_diagnose(args: argparse.Namespace) -> int:
    """Load the records, diagnose, write JSON/report, print the summary.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 for any verdict.

    Raises
    ------
    SpecError
        ``--model-out`` names a file, not a folder.
    """
    from robrst.data.dataset import load_dataset
    from robrst.diagnose import diagnose
    from robrst.diagnose.summary import summary_text
    from robrst.report.doc import check_report_target

    to_stdout = args.json == "-"
    if args.json and not to_stdout:
        check_json_target(args.json)              # bad targets fail before the work
    if args.report:
        check_report_target(args.report, args.force, option="--report")
    if args.model_out:
        from robrst.diagnose.modelout import check_model_out

        check_model_out(args.model_out)          # a foreign file in the way: before the work
    say = progress_printer(args.quiet or to_stdout)
    train = [load_dataset(f) for f in args.train]
    test = [load_dataset(f) for f in args.test]
    plant, ref = None, None
    if args.model:
        plant, ref = _model(args.model)
    diag = diagnose(train, test, plant=plant, reference_C=ref, progress=say)
    extra = {}
    if args.model_out:
        from robrst.diagnose.modelout import write_models

        files = write_models(diag, args.model_out)
        extra["model_files"] = files
        for f in files:
            say(f"wrote {f['file']}")
    text = json_text({**diag.as_dict(), **extra, WRITTEN_BY: "robrst diagnose"}, indent=1)
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


def _model(path):
    """(plant, reference °C): a problem file's nominal plant, or a model file's model.

    A problem file (a built-in problem's name, or one from ``robrst identify`` with no
    ``[poles]`` yet) keeps its :class:`~robrst.core.plant.Plant`
    (so the JSON reports the changes of its coefficients); a model file from
    ``robrst identify`` gives the modal model at its reference temperature (the first one
    when it states none).
    """
    from pathlib import Path

    from robrst.studies.linear_model import load_linear_model, problem_family
    from robrst.identify.modelfile import read_model_data

    if not Path(path).is_file() or "model" not in read_model_data(path):
        fam = problem_family(path)
        return fam.reference_model, fam.reference_model.temperature_C
    models, ref = load_linear_model(path)
    if ref is None:
        return models[0], None
    return min(models, key=lambda m: abs((m.temperature_C or ref) - ref)), ref
