"""A sweep's report folder (``DIR/report``) and its plain-text summary.

Contents: the yield (with its 95 % interval), the statuses, the spread of every figure, the
worst variants with their parameters, and figures — ``histograms.png`` and
``sensitivity.png`` (analysis), ``front.png`` (design: the trade-off and its Pareto front),
``fleet.png`` (fleet), ``worst_bode.png`` (all kinds: the worst variant evaluated).
Written by :func:`robrst.report.doc.write_folder` (atomic, marker, never over a folder robrst
did not write).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path

from robrst.base.fileio import json_text
import robrst.report._sweep_figures as figs
from robrst.report.doc import Doc, write_folder
from robrst.studies.sweep.curves import worst_case_curves, worst_ok_row
from robrst.studies.sweep.engine import SweepResult

__all__ = ["sweep_doc", "write_sweep_report", "sweep_text", "figure_files"]


def _f(x, spec=".4g"):
    if x is None:
        return "–"
    if isinstance(x, float) and not math.isfinite(x):
        return "∞"
    return format(x, spec)


def figure_files(result: SweepResult) -> list[tuple[str, str]]:
    """The figures the report of ``result`` holds (``(file, caption)``).

    Parameters
    ----------
    result : SweepResult
        The sweep.

    Returns
    -------
    list of (str, str)
    """
    kind = result.sweep.kind
    out = []
    if result.summary["done"] == 0:
        return out
    if kind == "analysis":
        out += [("histograms.png", "Worst case of every variant evaluated over its temperatures"
                 " (its family and the certificate's sweep); dashed: the specs"),
                ("sensitivity.png", "Worst figure/bound of every variant against each varied"
                 " parameter (> 1: a spec violated)")]
    elif kind == "design":
        out.append(("front.png", "Trade-off: the maximised figure against the first parameter"
                    " and the Pareto front of the certified designs"))
    else:
        out.append(("fleet.png", "Each fleet member's design: worst figure/bound and integral"
                    " gain"))
    if not result.context.mimo and worst_ok_row(result) is not None:
        out.append(("worst_bode.png", "|S|, |T| and |U| of the worst variant evaluated, per"
                    " temperature; dashed: the specs"))
    return out


def _worst_table(s):
    figs = ("sigma_S", "sigma_T", "sigma_U") if "axes" in s else ("Ms", "Mt", "Mu")
    rows = []
    for w in s["worst"]:
        params = ", ".join(f"{k}={v:.4g}" for k, v in w["params"].items())
        rows.append((w.get("file", w["index"]), w["status"], _f(w["worst_ratio"]),
                     *(_f(w.get(k)) for k in figs),
                     w["violation"] or w["message"] or "", params))
    return ("variant", "status", "figure/bound", *figs, "worst violation or error",
            "parameters"), tuple(rows)


def sweep_doc(result: SweepResult) -> Doc:
    """The report document of a sweep result (no I/O).

    Parameters
    ----------
    result : SweepResult
        The sweep.

    Returns
    -------
    Doc
    """
    s = result.summary
    y = s["yield"]
    lo, hi = s["yield_ci95"]
    blocks = [
        ("p", f"Sweep `{s['sweep']}` ({s['kind']}, base problem `{s['problem']}`):"
              f" {s['done']} of {s['n']} variants evaluated"
              f"{'' if s['complete'] else ' (incomplete: run again to resume)'};"
              f" **{s['certified']} certified**"
              + ("" if y is None else f", yield **{y:.4f}** (95 % interval {lo:.4f}–{hi:.4f})")
              + f". {s['workers']} workers, {s['wall_s']:.1f} s wall,"
                f" {_f(s['cpu_s_per_variant'], '.3g')} s CPU per variant."),
        ("table", ("status", "variants"), tuple(sorted(s["statuses"].items()))),
    ]
    env = s.get("envelope")
    if env and env["rows"]:
        blocks.append(("p", f"Monotone envelope: {env['rows']} of {s['done']} variants keep"
                            " the better design of a variant whose bounds are all at least"
                            " as tight, certified on their own problem (their own design"
                            " reached less): "
                       + ", ".join(f"{i} ← {j}" for i, j in env["design_of"].items()) + "."))
    blocks += [
        ("h2", "Spread of the figures"),
        ("table", ("figure", "min", "5 %", "median", "95 %", "max"),
         tuple((k, *(_f(v[q]) for q in ("min", "p05", "median", "p95", "max")))
               for k, v in s["figures"].items())),
        ("h2", "Worst variants"),
        ("table", *_worst_table(s)),
    ]
    if "controller" in s:
        c = s["controller"]
        axes = c["axes"] if "axes" in c else [{"name": "", **c}]
        blocks.append(("pre", "\n".join(
            f"{k}{'_' + a['name'] if a['name'] else ''}(s) = "
            + " ".join(f"{v:.6g}" for v in a[k]) for a in axes for k in "RST")))
    if "front" in s:
        f = s["front"]
        blocks += [("h2", f"Pareto front ({f['x']} minimised, {f['y']} maximised)"),
                   ("table", ("variant", "parameters", f["x"], f["y"]),
                    tuple((p.get("file", p["index"]),
                           ", ".join(f"{k}={v:.4g}" for k, v in p["params"].items()),
                           _f(p[f["x"]]), _f(p[f["y"]])) for p in f["points"]))]
    figures = figure_files(result)
    if figures:
        blocks.append(("h2", "Figures"))
        blocks += [("img", f, cap) for f, cap in figures]
    return Doc(title=f"robrst sweep report: {s['sweep']}", blocks=tuple(blocks))


def write_sweep_report(result: SweepResult, out_dir: str | os.PathLike | None = None,
                       progress: Callable[[str], None] | None = None,
                       force: bool = False) -> Path:
    """Write the report folder of a sweep (default ``result.out / "report"``).

    The folder holds ``report.md``, ``report.html``, the figures and a copy of
    ``summary.json``.

    Parameters
    ----------
    result : SweepResult
        The sweep.
    out_dir : str or pathlib.Path, optional
        The report folder (default ``result.out / "report"``).
    progress : callable, optional
        Called with one line of text per stage.
    force : bool
        Write into an existing folder robrst did not write (only the report's files).

    Returns
    -------
    pathlib.Path
        The folder.

    Raises
    ------
    OutputError
        A folder robrst did not write (without ``force``), or one the system refuses.

    Examples
    --------
    >>> import tempfile
    >>> from robrst import run_sweep, write_sweep_report
    >>> from robrst.studies.sweep import parse_sweep
    >>> sweep = parse_sweep({"sweep": {"kind": "analysis", "problem": "paper", "n": 8},
    ...                      "param": [{"name": "gain", "dist": "normal", "mean": 1.0,
    ...                                 "std": 0.1}]})
    >>> result = run_sweep(sweep, tempfile.mkdtemp() + "/mc", workers=0)
    >>> sorted(p.name for p in write_sweep_report(result).glob("*.png"))
    ['histograms.png', 'sensitivity.png', 'worst_bode.png']
    """
    say = progress or (lambda m: None)
    doc = sweep_doc(result)
    draw_fn = {"histograms.png": figs.histograms_figure,
               "sensitivity.png": figs.sensitivity_figure, "front.png": figs.front_figure,
               "fleet.png": figs.fleet_figure}

    def draw(tmp):
        for name, _ in figure_files(result):
            say(f"drawing {name}")
            if name == "worst_bode.png":       # the curves computed by the studies layer
                figs.worst_bode_figure(worst_case_curves(result), tmp / name)
            else:
                draw_fn[name](result, tmp / name)

    extra = {"summary.json": json_text(result.summary, indent=1) + "\n"}
    return write_folder(out_dir or Path(result.out) / "report", doc, extra, draw, force=force)


def sweep_text(summary: dict) -> str:
    """A few lines for the terminal: counts, yield, figures, the worst variants.

    Parameters
    ----------
    summary : dict
        The sweep's ``summary.json`` object.

    Returns
    -------
    str
    """
    s = summary
    lines = [f"sweep {s['sweep']} ({s['kind']}): {s['done']}/{s['n']} variants"
             f"{'' if s['complete'] else ' (incomplete: run again to resume)'},"
             f" {'in this process' if s.get('executor') == 'in_process' else str(s['workers']) + ' workers'},"
             f" {s['wall_s']:.1f} s"]
    if s["yield"] is not None:
        lo, hi = s["yield_ci95"]
        lines.append(f"certified: {s['certified']} of {s['done']}, yield {s['yield']:.4f}"
                     f" (95 % interval {lo:.4f}..{hi:.4f}); failed: {s['failed']}")
    if s.get("unstable"):
        lines.append(f"unstable: {s['unstable']} of {s['done']} (a loop unstable on some model:"
                     " no peaks or margins for it, figure/bound inf)")
    for k in ("Ms", "Mt", "Mu", "Mt_band", "sigma_S", "sigma_T", "sigma_U", "crosstalk",
              "bandwidth_hz", "integral_gain"):
        if k in s["figures"]:
            v = s["figures"][k]
            tail = (f"range {_f(v['min'])}..{_f(v['max'])}" if k in ("integral_gain",
                                                                      "bandwidth_hz")
                    else f"95 % {_f(v['p95'])}, worst {_f(v['max'])}")   # the gain: no worst
            lines.append(f"  {k:<14} median {_f(v['median'])}, {tail}")
    for w in s["worst"][:5]:
        who = w.get("file", f"#{w['index']}")
        lines.append(f"  worst {who}: {w['status']}, figure/bound {_f(w['worst_ratio'])}:"
                     f" {w['violation'] or w['message'] or 'certified'}")
    return "\n".join(lines)
