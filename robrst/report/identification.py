"""``robrst identify ... --report DIR``: the identification report folder.

Figures (``matplotlib.figure.Figure`` objects): the identified model's frequency
response per channel over a nonparametric estimate from the records (H1, Welch), the
held-out NRMSE of every candidate order, and measured vs simulated output on a record.
``identified.json`` is the ``--json`` result.
"""


from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from robrst.base.fileio import json_text
from robrst.identify.curves import IdentificationCurves, identification_curves
from robrst.report.doc import Doc, write_folder
from robrst.report._figure import drawing

if TYPE_CHECKING:
    from pathlib import Path
    from robrst.data.dataset import Dataset
    from robrst.identify.identification import Identified

__all__ = ["write_identification_report", "identification_doc", "FIGURES"]

FIGURES = ("frf.png", "orders.png", "output.png")


def _frf_fig(ident, curves, path):
    m = ident.models[0]
    f, H, fm, G = curves.f_h1, curves.h1, curves.f_model, curves.model
    size = (3.2 * m.n_in + 1, 2.4 * m.n_out + 1)
    with drawing(path, size, m.n_out, m.n_in, squeeze=False) as (fig, axes):
        for i in range(m.n_out):
            for j in range(m.n_in):
                ax = axes[i, j]
                ax.loglog(f[1:], np.abs(H[1:, i, j]), color="0.6", lw=0.8, label="H1 (records)")
                ax.loglog(fm, np.abs(G[:, i, j]), color="tab:blue", lw=1.2,
                          label=f"identified, order {ident.order}")
                ax.set_title(f"y{i + 1} from u{j + 1}", fontsize=9)
                if i == m.n_out - 1:
                    ax.set_xlabel("f [Hz]")
                if j == 0:
                    ax.set_ylabel("|G| [µm/V]")
        axes[0, 0].legend(fontsize=7)


def _orders_fig(ident, path):
    s = [x for x in ident.scores if np.isfinite(x.heldout_nrmse)]
    with drawing(path, (8, 3.8)) as (fig, ax):
        if s:
            ax.semilogy([x.order for x in s], [x.heldout_nrmse for x in s], "o-", color="tab:blue",
                        label="held-out")
            ax.semilogy([x.order for x in s], [x.train_nrmse for x in s], ".--", color="tab:gray",
                        label="fit records")
        ax.axvline(ident.order, color="tab:orange", ls=":", label=f"chosen: {ident.order}")
        ax.set_xlabel("order (number of poles)")
        ax.set_ylabel("NRMSE [-] (log)")
        ax.set_title("order selection on held-out records")
        ax.legend(fontsize=8)


def _output_fig(curves, path):
    with drawing(path, (10, 3.8)) as (fig, ax):
        ax.plot(curves.t, curves.measured, color="k", lw=1, label="measured (output 1)")
        ax.plot(curves.t, curves.simulated, color="tab:blue", lw=1, ls="--",
                label="identified model")
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("y [µm]")
        ax.set_title(f"measured vs simulated: {curves.source}")
        ax.legend(fontsize=8)


def identification_doc(ident: Identified) -> Doc:
    """The report document of an identification (no I/O).

    Parameters
    ----------
    ident : Identified
        The identification result.

    Returns
    -------
    Doc
    """
    rows = tuple((o.order, f"{o.train_nrmse:.4g}" if math.isfinite(o.train_nrmse) else "",
                  f"{o.heldout_nrmse:.4g}" if math.isfinite(o.heldout_nrmse) else "", o.note)
                 for o in ident.scores)
    m = ident.models[0]
    poles = ", ".join(f"{abs(p) / (2 * np.pi):.4g} Hz" for p in sorted(m.poles, key=abs))
    blocks = [("p", f"Order **{ident.order}** ({m.n_out} output(s) x {m.n_in} input(s),"
                    f" {len(ident.models)} temperature(s)); held-out NRMSE"
                    f" {ident.heldout_nrmse:.4g} on {', '.join(ident.heldout)}."),
              ("p", f"Pole magnitudes: {poles}."),
              *([("p", "Records: " + "; ".join(ident.notes) + ".")] if ident.notes else []),
              ("table", ("order", "fit NRMSE", "held-out NRMSE", "note"), rows),
              ("img", "frf.png", "Frequency response of the identified model over the H1"
                                 " estimate of the records"),
              ("img", "orders.png", "Held-out NRMSE per candidate order"),
              ("img", "output.png", "Measured and simulated output (last record)")]
    return Doc(title="robrst identification", blocks=tuple(blocks))


def write_identification_report(ident: Identified, records: Sequence[Dataset],
                                out_dir: str | Path,
                                progress: Callable[[str], None] | None = None,
                                curves: IdentificationCurves | None = None) -> Path:
    """Write the identification report folder; returns its path.

    Parameters
    ----------
    ident : Identified
        The identification result.
    records : sequence of Dataset
        The records drawn against the model.
    out_dir : str or pathlib.Path
        A new folder or an earlier robrst report.
    progress : callable, optional
        Called with one line of text per stage.
    curves : IdentificationCurves, optional
        The curves to draw (:func:`robrst.identify.curves.identification_curves`; computed
        when not given).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OutputError
        A folder robrst did not write, or one the system refuses.
    """
    say = progress or (lambda m: None)
    if curves is None:
        curves = identification_curves(ident, records)

    def draw(tmp):
        say("drawing the identification figures")
        _frf_fig(ident, curves, tmp / "frf.png")
        _orders_fig(ident, tmp / "orders.png")
        _output_fig(curves, tmp / "output.png")

    text = json_text(ident.as_dict(), indent=1) + "\n"
    return write_folder(out_dir, identification_doc(ident), {"identified.json": text}, draw)
