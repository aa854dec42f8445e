"""``robrst simulate``: a scenario's datasets (CSV), figure (PNG) and a short report in one
folder, written like every robrst report folder (:func:`robrst.report.doc.write_folder`:
atomically, never over a folder robrst did not write unless ``force``)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np

from robrst.data.dataset import save_dataset
from robrst.base.fileio import jsonable
from robrst.report.doc import Doc, write_folder
from robrst.report._figure import drawing

if TYPE_CHECKING:
    from pathlib import Path
    from robrst.studies.scenarios import ScenarioResult

__all__ = ["write_scenario", "DRAWABLE"]

DRAWABLE = 1e300     # matplotlib's tick locator overflows on spans near the largest float


def write_scenario(res: ScenarioResult, out_dir: str | Path, force: bool = False) -> Path:
    """Write every dataset of ``res`` (a ScenarioResult), ``<name>.png`` and
    ``report.md``/``report.html`` (the claim and the metrics) into ``out_dir``.

    Parameters
    ----------
    res : ScenarioResult
        The scenario's datasets, claim and metrics.
    out_dir : str or pathlib.Path
        A new folder or an earlier robrst folder.
    force : bool
        Write the files into a folder robrst did not write (touching nothing else).

    Returns
    -------
    pathlib.Path
        The folder.

    Raises
    ------
    OutputError
        A folder robrst did not write (without ``force``), or one the system refuses.
    """
    figure = f"{res.name}.png"
    metrics = json.dumps(jsonable(res.metrics), indent=2, allow_nan=False)
    notes = tuple(("p", f"**Warning:** {n}") for n in res.notes)
    doc = Doc(title=f"Simulation {res.name}", blocks=(
        ("p", res.claim), *notes, ("img", figure, f"{res.name}: {res.claim}"),
        ("h2", "Metrics"), ("pre", metrics),
        ("p", "Datasets: " + ", ".join(sorted(f"{k}.csv" for k in res.datasets)) + ".")))

    def render(tmp):
        for k, d in res.datasets.items():
            save_dataset(d, tmp / f"{k}.csv")
        with drawing(tmp / figure, (8, 5), dpi=110, tight=False) as (fig, ax):
            for label, (x, y, xl, yl) in res.curves.items():
                x, y = np.asarray(x, float), np.asarray(y, float)
                with np.errstate(invalid="ignore"):     # what is finite (and drawable)
                    ok = np.isfinite(x) & (np.abs(y) <= DRAWABLE)
                ax.plot(np.where(ok, x, np.nan), np.where(ok, y, np.nan), label=label, lw=1)
                ax.set_xlabel(xl)
                ax.set_ylabel(yl)
            ax.set_title(f"{res.name}: {res.claim}", fontsize=10)
            ax.legend(fontsize=8)

    return write_folder(out_dir, doc, {}, render, force=force)
