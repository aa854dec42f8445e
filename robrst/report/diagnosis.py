"""``robrst diagnose ... --report DIR``: the gap-diagnosis report folder.

Figures (``matplotlib.figure.Figure`` objects, no global matplotlib state): measured vs
simulated output (model under diagnosis and the final model) on the test record with
the largest gap, the residual with the localised time windows shaded, the residual
spectrum against the noise floor with the gap band, the held-out gap of every
candidate, and the gap per record against its excitation level (model and final
model, with the noise floor).  ``diagnosis.json`` is the ``--json`` result.
"""


from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose.summary import summary_text
from robrst.base.fileio import json_text
from robrst.report.doc import Doc, write_folder
from robrst.report._figure import drawing

if TYPE_CHECKING:
    from pathlib import Path
    from robrst.diagnose.result import Diagnosis, RecordGap, TestGap

__all__ = ["diagnosis_doc", "write_diagnosis_report", "FIGURES", "levels_figure"]

FIGURES = ("output.png", "residual.png", "spectrum.png", "effects.png", "levels.png")


def _form(form):
    return {"dynamic": " (level-dependent)", "prandtl_ishlinskii": " (Prandtl–Ishlinskii)"}.get(
        form, "")


def _first(a):
    a = np.asarray(a)
    return a if a.ndim == 1 else a[:, 0]


def _output_fig(diag, path):
    tr = diag.traces
    k = diag.traces.focus
    d = tr.records[k]
    y, r = _first(d.Y), _first(tr.base_residuals[k])
    n = min(d.n, d.period if d.period else d.n)
    with drawing(path, (10, 4)) as (fig, ax):
        ax.plot(d.t[:n], y[:n], color="k", lw=1, label="measured")
        ax.plot(d.t[:n], (y - r)[:n], color="tab:blue", lw=1, label="model under diagnosis")
        fit = tr.fit_residuals
        key = "final" if "final" in fit else (diag.cause if diag.cause in fit else None)
        if key:
            rr = _first(fit[key][k - len(diag.data.train)])
            ax.plot(d.t[:n], (y - rr)[:n], color="tab:orange", lw=1, ls="--",
                    label=f"final model ({' + '.join(diag.causes) or diag.cause})")
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("displacement y [µm]" + (" (output 1)" if d.n_out > 1 else ""))
        ax.set_title(f"measured vs simulated: {tr.names[k]}" + (" (one period)" if d.period else ""))
        ax.legend(fontsize=8)


def _residual_fig(diag, path):
    tr = diag.traces
    k = diag.traces.focus
    d, r, name = tr.records[k], np.asarray(tr.base_residuals[k]), tr.names[k]
    r = r if r.ndim == 1 else np.sqrt(np.mean(r ** 2, axis=1))
    with drawing(path, (10, 3.6)) as (fig, ax):
        ax.plot(d.t, r, color="tab:blue", lw=0.8,
                label="residual y - y_model" + (" (rms over outputs)" if d.n_out > 1 else ""))
        first = True
        for w in diag.where.time_windows:
            if w.file == name:
                ax.axvspan(w.start_s, w.end_s, color="tab:red", alpha=0.15,
                           label="gap window (> 3× noise)" if first else None)
                first = False
        s = diag.data.noise_sigma_um
        ax.axhline(3 * s, color="gray", ls=":", lw=1, label="±3× noise σ")
        ax.axhline(-3 * s, color="gray", ls=":", lw=1)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("residual [µm]")
        ax.set_title(f"residual of the simulation model: {name}")
        ax.legend(fontsize=8)


def _spectrum_fig(diag, path):
    tr = diag.traces
    f, P = tr.psd_f, tr.psd
    with drawing(path, (8, 4)) as (fig, ax):
        ax.loglog(f[1:], P[1:], color="tab:blue", lw=1, label="residual PSD")
        ax.axhline(tr.noise_psd, color="k", ls="--", lw=1, label="noise floor (white)")
        band = diag.where.frequency_band_hz
        if band:
            ax.axvspan(max(band[0], f[1]), max(band[1], f[1]), color="tab:red", alpha=0.15,
                       label=f"gap band {band[0]:.3g}–{band[1]:.3g} Hz")
        for fd in diag.findings:
            if fd.kind == "unmodelled_dynamics":
                lo, hi = fd.details["band_hz"]
                ax.axvspan(lo, hi, color="tab:green", alpha=0.15,
                           label=f"unmodelled dynamics {lo:.3g}–{hi:.3g} Hz")
        ax.set_xlabel("frequency f [Hz] (log)")
        ax.set_ylabel("PSD [µm²/Hz]")
        ax.set_title("residual spectrum against the noise floor (all records)")
        ax.legend(fontsize=8)


def _effects_fig(diag, path):
    rows = [(e.name + (" (dyn.)" if e.form == "dynamic" else ""), e.gap_before, e.gap_after)
            for e in diag.effects]
    if diag.linear_refit:
        rows.append(("linear re-fit", diag.linear_refit.gap_before, diag.linear_refit.gap_after))
    if diag.final:
        rows.append(("final: " + " + ".join(diag.final.effects), diag.gap_before,
                     diag.final.gap_after))
    with drawing(path, (9, 4)) as (fig, ax):
        if rows:
            x = np.arange(len(rows))
            ax.bar(x - 0.2, [r[1] for r in rows], 0.4, color="tab:gray", label="before")
            ax.bar(x + 0.2, [r[2] for r in rows], 0.4, color="tab:orange", label="after")
            ax.set_xticks(x, [r[0] for r in rows], rotation=20, fontsize=8)
            ax.set_yscale("log")
        ax.axhline(diag.noise_floor, color="k", ls="--", lw=1, label="noise floor")
        ax.set_ylabel("held-out NRMSE [-] (log)")
        ax.set_title(f"held-out gap per candidate (cause: {diag.cause})")
        ax.legend(fontsize=8)


def levels_figure(path: str | Path, per_record: Sequence[RecordGap],
                  final_per_record: Sequence[TestGap] | None = None,
                  title: str = "gap per record against its level") -> None:
    """Draw the gap (NRMSE) per record against its excitation level into the PNG ``path``.

    Parameters
    ----------
    path : str or pathlib.Path
        The PNG file.
    per_record : sequence of RecordGap
        Per record under the model diagnosed (:attr:`Diagnosis.per_record`).
    final_per_record : sequence of TestGap, optional
        Per test record under the final model (:attr:`FinalFit.gap_per_record`).
    title : str
        The figure's title.
    """
    with drawing(path, (8, 4)) as (fig, ax):
        for split, marker in (("train", "o"), ("test", "s")):
            rows = [r for r in per_record if r.split == split]
            if rows:
                ax.scatter([r.level_V for r in rows], [r.gap for r in rows], marker=marker,
                           color="tab:blue", label=f"model under diagnosis ({split})")
                ax.scatter([r.level_V for r in rows], [r.noise_floor for r in rows],
                           marker="_", color="k", s=200,
                           label="noise floor" if split == "train" else None)
        if final_per_record:
            lv = {r.file: r.level_V for r in per_record}
            ax.scatter([lv[r.file] for r in final_per_record], [r.gap for r in final_per_record],
                       marker="s", color="tab:orange", label="final model (test)")
        ax.set_yscale("log")
        ax.set_xlabel("excitation level: input rms [V]")
        ax.set_ylabel("NRMSE [-] (log)")
        ax.set_title(title)
        ax.legend(fontsize=8)


def _levels_fig(diag, path):
    levels_figure(path, diag.per_record, diag.final.gap_per_record if diag.final else None)


def _fmt(v, fmt):
    """A figure of the report's tables (``—`` where there is none)."""
    return "—" if v is None or not math.isfinite(v) else format(v, fmt)


def diagnosis_doc(diag: Diagnosis) -> Doc:
    """The report document of a diagnosis (no I/O).

    Parameters
    ----------
    diag : Diagnosis
        The diagnosis.

    Returns
    -------
    Doc
    """
    scores = diag.effects + ((replace(diag.linear_refit, name="linear re-fit"),)
                             if diag.linear_refit else ())
    rows = tuple((e.name + _form(e.form), e.method or "fit", _fmt(e.gap_before, ".4g"),
                  _fmt(e.gap_after, ".4g"), f"{100 * e.shrink:.1f} %",
                  ", ".join(f"{k}={v:.4g}" for k, v in list(e.params.items())[:8]
                            if v is not None and math.isfinite(v)))
                 for e in scores)
    credit = tuple((s.name + _form(s.form), _fmt(s.gap_after, ".4g"), _fmt(s.gap_without, ".4g"),
                    "—" if _fmt(s.credit, "") == "—" else f"{100 * s.credit:.0f} %")
                   for s in diag.selected)
    credit += tuple((f"{n.name} (not a cause)", f"{n.gap_with:.4g}",
                     f"{n.gap_without:.4g}", "nothing") for n in diag.not_causes)
    blocks = [("p", f"Cause: **{diag.cause}** — {diag.reason}."),
              ("pre", summary_text(diag)),
              ("h2", "Held-out gap per candidate (each alone)"),
              ("table", ("candidate", "scored by", "gap before", "gap after", "shrink",
                         "fitted parameters"), rows)]
    if credit:
        blocks += [("h2", "Credit of each effect named: the joint fit without it"),
                   ("table", ("effect", "held-out gap with it", "without it",
                              "share of the excess it removes"), credit)]
    blocks += [("h2", "Figures"),
              ("img", "output.png", "Measured and simulated output on the test record with the"
                                    " largest gap"),
              ("img", "residual.png", "Residual of the simulation model with the localised gap"
                                      " windows shaded"),
              ("img", "spectrum.png", "Residual spectrum (Welch) against the white-noise floor;"
                                      " shaded: the band holding 95 % of the excess"),
              ("img", "effects.png", "Held-out NRMSE before and after each candidate alone, the"
                                     " linear re-fit and the final model"),
              ("img", "levels.png", "Gap per record against its excitation level (input rms)")]
    return Doc(title="robrst gap diagnosis", blocks=tuple(blocks))


def write_diagnosis_report(diag: Diagnosis, out_dir: str | Path,
                           progress: Callable[[str], None] | None = None,
                           force: bool = False) -> Path:
    """Write the diagnosis report folder (see :func:`robrst.report.doc.write_folder`).

    Parameters
    ----------
    diag : Diagnosis
        The diagnosis.
    out_dir : str or pathlib.Path
        A new folder or an earlier robrst report.
    progress : callable, optional
        Called with one line of text per stage.
    force : bool
        Write into a folder robrst did not write (only the report's files).

    Returns
    -------
    pathlib.Path
        The folder.

    Raises
    ------
    OutputError
        A folder robrst did not write (without ``force``), or one the system refuses.
    """
    say = progress or (lambda m: None)

    def draw(tmp):
        for name, fn in zip(FIGURES, (_output_fig, _residual_fig, _spectrum_fig, _effects_fig,
                                      _levels_fig)):
            say(f"drawing {name}")
            fn(diag, tmp / name)

    text = json_text(diag.as_dict(), indent=1) + "\n"
    return write_folder(out_dir, diagnosis_doc(diag), {"diagnosis.json": text}, draw,
                        force=force)
