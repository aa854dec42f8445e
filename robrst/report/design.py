"""``robrst report PROBLEM.toml``: the design report folder.

Pipeline: problem -> :func:`robrst.design.run_problem` -> figures + document ->
:func:`robrst.report.doc.write_folder` (atomic).  Contents: summary, margins table
per temperature, certificate, analytic-vs-robust comparison, Bode of S/T/U with the
bounds and certified peaks, Nyquist with the modulus circle, step responses (linear,
and on the digital twin when the problem's plant is the twin's), and ``result.json``
(the same JSON as ``robrst design --json``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path

from robrst.design import DesignResult
from robrst.design.contract import design_json
from robrst.design.tolerance import FRAGILE
from robrst.studies.design_curves import DesignCurves, design_curves
from robrst.base.fileio import json_text
import robrst.report._design_figures as figs
from robrst.report.doc import Doc, write_folder
from robrst.report.text import sampled_summary, spec_rows

__all__ = ["design_doc", "write_design_report", "FIGURES"]

FIGURES = ("bode.png", "nyquist.png", "step.png")


def _f(x, spec=".3f"):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "∞"
    return format(x, spec)


def _margins_rows(result):
    rows = []
    for a in result.analyses:
        m, pk = a.margins, a.peaks
        dm = None if m.delay_margin_s is None else m.delay_margin_s * 1e6
        rows.append((a.label, _f(a.temperature_C, ".1f"), "yes" if a.stable else "NO",
                     _f(pk["S"].value), _f(pk["T"].value), _f(pk["U"].value, ".1f"),
                     _f(m.gain_margin, ".2f"), _f(m.phase_margin_deg, ".1f"),
                     _f(m.modulus_margin), _f(dm, ".1f")))
    return rows


def design_doc(result: DesignResult, twin: bool = False) -> Doc:
    """The report document of a design result (no I/O).

    Parameters
    ----------
    result : DesignResult
        The design.
    twin : bool
        The step figure also shows the digital twin (its caption says so).

    Returns
    -------
    Doc
    """
    p, cert = result.problem, result.certificate
    rows = spec_rows(result)
    worst = {k: cert.worst_model(k) for k in ("Ms", "Mt", "Mu")}
    c = result.controller
    sampled = sampled_summary(result)
    blocks = [
        ("p", f"Problem `{p.name}`, method **{result.method}**, certified:"
              f" **{str(bool(result.certified)).lower()}**."),
        ("pre", "\n".join(f"{k}(s) = " + " ".join(f"{v:.6g}" for v in getattr(c, k))
                          for k in "RST")),
        ("h2", "Specs"),
        ("p", "Worst over every checked model and temperature; slack = room left"
              " (`(default)`: a spec robrst adds, each switched off by its key)."
              if rows else "No spec bounded."),
    ]
    if rows:
        blocks.append(("table", ("spec", "bound", "achieved", "slack", "where", "note"), tuple(rows)))
    blocks += [
        ("h2", "Margins per temperature"),
        ("table", ("model", "T [°C]", "stable", "Ms", "Mt", "Mu [V/µm]", "GM", "PM [°]", "MM",
                   "DM [µs]"), tuple(_margins_rows(result))),
        ("h2", "Certificate"),
        ("p", f"{len(cert.models)} models checked (family and a dense temperature sweep) with"
              f" exact peaks (relative tolerance {cert.rtol:g}); {len(cert.violations)}"
              " violations. Worst cases: "
              + "; ".join(f"{k} = {worst[k].value(k):.4g} at {worst[k].temperature_C:.1f} °C"
                          for k in worst)
              + f"; largest closed-loop spectral abscissa"
                f" {cert.worst('spectral_abscissa'):.4g} rad/s."
              + (f" Sampled loop, same models: {sampled.split(': ', 1)[1]}."
                 if sampled else "")),
    ]
    if cert.violations:
        blocks.append(("table", ("model", "quantity", "value", "bound", "ω [rad/s]"),
                       tuple((v.label, v.quantity, _f(v.value, ".4g"), _f(v.bound, ".4g"),
                              _f(v.freq_rad_s, ".4g")) for v in cert.violations[:20])))
    if result.analytic_check is not None:
        ac = result.analytic_check
        blocks.append(("p", f"Analytic check: max relative coefficient error"
                            f" {ac.max_rel_coef_error:.2e} → {'passed' if ac.passed else 'FAILED'}."))
    tol = result.tolerance
    if tol is not None:
        def met(x, at):
            return f"{x:.4g}" + (" (the span's end)" if at is None else "")
        blocks += [("h2", "The next actuator off the line"),
                   ("p", "How far each plant factor may move alone with every spec still met"
                         f" ({tol.statement})." + (
                             f" **Fragile to the next actuator: a factor within 1 ± {FRAGILE:g}"
                             " fails a spec; state the actuators' spread ([spread]) to design"
                             " for them.**" if tol.warning else "")),
                   ("table", ("factor", "met down to", "fails below", "met up to",
                              "fails above"),
                    tuple((f.factor, met(f.low, f.below_at), f.below or "—",
                           met(f.high, f.above_at), f.above or "—") for f in tol.factors))]
    if result.comparison is not None:
        blocks += [("h2", "Analytic pole placement vs this design (worst case over the family)"),
                   ("pre", result.comparison.table)]
    blocks += [
        ("h2", "Figures"),
        ("img", "bode.png", "Bode magnitude of S, T and U per temperature; dashed: spec bounds;"
                            " ×: certified peaks (frequency in Hz, log axis)"),
        ("img", "nyquist.png", "Nyquist plot of L = BR/(AS) per temperature with the modulus-margin"
                               " circles around -1"),
        ("img", "step.png", "Step responses at the extreme temperatures: 1 µm reference and 1 V"
                            " input disturbance" + ("; dashed: digital twin (20 kHz Tustin"
                                                    " controller, every effect on, 10 µm step / 10)"
                                                    if twin else "")),
    ]
    return Doc(title=f"robrst design report: {p.name}", blocks=tuple(blocks))


def write_design_report(result: DesignResult, out_dir: str | os.PathLike,
                        progress: Callable[[str], None] | None = None,
                        force: bool = False, curves: DesignCurves | None = None) -> Path:
    """Write the report folder of ``result``.

    Parameters
    ----------
    result : DesignResult
        The design.
    out_dir : str or pathlib.Path
        A new folder or an earlier robrst report (replaced atomically); any other
        existing folder is refused unless ``force`` (see :func:`robrst.report.doc.write_folder`).
    progress : callable, optional
        Called with one line of text per stage.
    force : bool
        Write into a folder robrst did not write (only the report's files).
    curves : DesignCurves, optional
        The curves to draw (:func:`robrst.studies.design_curves.design_curves`; computed
        here when not given, with the digital twin's steps for the paper's plant).

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
    >>> from robrst import load_problem, run_problem, write_design_report
    >>> out = write_design_report(run_problem(load_problem("paper")),
    ...                           tempfile.mkdtemp() + "/paper")
    >>> sorted(p.name for p in out.glob("*.png"))
    ['bode.png', 'nyquist.png', 'step.png']
    """
    say = progress or (lambda m: None)
    if curves is None:
        twin = result.problem.plant_name == "paper"
        if twin:
            say("simulating the digital twin for step.png")
        curves = design_curves(result, twin=twin)
    doc = design_doc(result, twin=bool(curves.twin))

    def draw(tmp):
        say("drawing bode.png")
        figs.bode_figure(result, curves, tmp / "bode.png")
        say("drawing nyquist.png")
        figs.nyquist_figure(result, curves, tmp / "nyquist.png")
        say("drawing step.png")
        figs.step_figure(result, curves, tmp / "step.png")

    text = json_text(design_json(result), indent=1) + "\n"
    return write_folder(out_dir, doc, {"result.json": text}, draw, force=force)
