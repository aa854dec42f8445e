"""``robrst diagnose ... --report DIR``: the gap-diagnosis report folder.

Figures: measured vs simulated output (model under diagnosis and model + winning
effect) on a test record, the residual with the localised time windows shaded, the
residual spectrum against the noise floor with the gap band, and the held-out gap
before/after for every candidate.  ``diagnosis.json`` is the ``--json`` result.
"""

import numpy as np

from robrst.diagnose.summary import summary_text
from robrst.fileio import json_text
from robrst.report.doc import Doc, write_folder
from robrst.report.figure import drawing

__all__ = ["diagnosis_doc", "write_diagnosis_report", "FIGURES"]

FIGURES = ("output.png", "residual.png", "spectrum.png", "effects.png")


def _focus(diag):
    """Index (into the records) of the test record with the largest base residual."""
    tr = diag.traces
    n_train = len(diag.data["train"])
    res = tr["base_residuals"][n_train:]
    return n_train + int(np.argmax([np.sum(r ** 2) for r in res]))


def _output_fig(diag, path):
    tr = diag.traces
    k = _focus(diag)
    d = tr["records"][k]
    r = tr["base_residuals"][k]
    with drawing(path, (10, 4)) as (fig, ax):
        ax.plot(d.t, d.y, color="k", lw=1, label="measured")
        ax.plot(d.t, d.y - r, color="tab:blue", lw=1, label="simulation model")
        name = diag.cause if diag.cause in tr.get("fit_residuals", {}) else None
        if name:
            rr = tr["fit_residuals"][name][k - len(diag.data["train"])]
            ax.plot(d.t, d.y - rr, color="tab:orange", lw=1, ls="--", label=f"model + {name}")
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("displacement y [µm]")
        ax.set_title(f"measured vs simulated: {tr['names'][k]}")
        ax.legend(fontsize=8)


def _residual_fig(diag, path):
    tr = diag.traces
    k = _focus(diag)
    d, r, name = tr["records"][k], tr["base_residuals"][k], tr["names"][k]
    with drawing(path, (10, 3.6)) as (fig, ax):
        ax.plot(d.t, r, color="tab:blue", lw=0.8, label="residual y - y_model")
        first = True
        for w in diag.where["time_windows"]:
            if w["file"] == name:
                ax.axvspan(w["start_s"], w["end_s"], color="tab:red", alpha=0.15,
                           label="gap window (> 3× noise)" if first else None)
                first = False
        s = diag.data["noise_sigma_um"]
        ax.axhline(3 * s, color="gray", ls=":", lw=1, label="±3× noise σ")
        ax.axhline(-3 * s, color="gray", ls=":", lw=1)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("residual [µm]")
        ax.set_title(f"residual of the simulation model: {name}")
        ax.legend(fontsize=8)


def _spectrum_fig(diag, path):
    tr = diag.traces
    f, P = tr["psd_f"], tr["psd"]
    with drawing(path, (8, 4)) as (fig, ax):
        ax.loglog(f[1:], P[1:], color="tab:blue", lw=1, label="residual PSD")
        ax.axhline(tr["noise_psd"], color="k", ls="--", lw=1, label="noise floor (white)")
        band = diag.where["frequency_band_hz"]
        if band:
            ax.axvspan(max(band[0], f[1]), max(band[1], f[1]), color="tab:red", alpha=0.15,
                       label=f"gap band {band[0]:.3g}–{band[1]:.3g} Hz")
        ax.set_xlabel("frequency f [Hz] (log)")
        ax.set_ylabel("PSD [µm²/Hz]")
        ax.set_title("residual spectrum against the noise floor (all records)")
        ax.legend(fontsize=8)


def _effects_fig(diag, path):
    rows = list(diag.effects) + ([diag.linear_refit] if diag.linear_refit else [])
    with drawing(path, (8, 4)) as (fig, ax):
        if rows:
            x = np.arange(len(rows))
            ax.bar(x - 0.2, [e.gap_before for e in rows], 0.4, color="tab:gray", label="before")
            ax.bar(x + 0.2, [e.gap_after for e in rows], 0.4, color="tab:orange", label="after")
            ax.set_xticks(x, [e.name if e is not diag.linear_refit else "linear re-fit" for e in rows],
                          rotation=20)
            ax.set_yscale("log")
        ax.axhline(diag.noise_floor, color="k", ls="--", lw=1, label="noise floor")
        ax.set_ylabel("held-out NRMSE [-] (log)")
        ax.set_title(f"held-out gap before/after each candidate (cause: {diag.cause})")
        ax.legend(fontsize=8)


def diagnosis_doc(diag):
    """The report document of a diagnosis (no I/O)."""
    d = diag.as_dict()
    rows = tuple((e["name"], f"{e['gap_before']:.4g}", f"{e['gap_after']:.4g}",
                  f"{100 * e['shrink']:.1f} %",
                  ", ".join(f"{k}={v:.4g}" for k, v in e["params"].items()))
                 for e in d["effects"] + ([dict(d["linear_refit"], name="linear re-fit")]
                                          if d["linear_refit"] else []))
    blocks = [("p", f"Cause: **{d['cause']}** — {d['reason']}."),
              ("pre", summary_text(diag)),
              ("h2", "Held-out gap per candidate"),
              ("table", ("candidate", "gap before", "gap after", "shrink", "fitted parameters"),
               rows),
              ("h2", "Figures"),
              ("img", "output.png", "Measured and simulated output on the test record with the"
                                    " largest gap"),
              ("img", "residual.png", "Residual of the simulation model with the localised gap"
                                      " windows shaded"),
              ("img", "spectrum.png", "Residual spectrum (Welch) against the white-noise floor;"
                                      " shaded: the band holding 95 % of the excess"),
              ("img", "effects.png", "Held-out NRMSE before and after adding each effect, and"
                                     " for a plain linear re-fit")]
    return Doc(title="robrst gap diagnosis", blocks=tuple(blocks))


def write_diagnosis_report(diag, out_dir, progress=None, force=False):
    """Write the diagnosis report folder (see :func:`robrst.report.doc.write_folder`); returns its path."""
    say = progress or (lambda m: None)

    def draw(tmp):
        for name, fn in zip(FIGURES, (_output_fig, _residual_fig, _spectrum_fig, _effects_fig)):
            say(f"drawing {name}")
            fn(diag, tmp / name)

    text = json_text(diag.as_dict(), indent=1) + "\n"
    return write_folder(out_dir, diagnosis_doc(diag), {"diagnosis.json": text}, draw, force=force)
