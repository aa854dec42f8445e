"""The curves a sweep report draws, computed from the sweep's records.

:func:`worst_case_curves` gives the frequency responses ``|S|, |T|, |U|`` of the worst
variant's loops at every temperature of its family (and, for an analysis, of the base
family), with the bounds and the title it is drawn with: the report
(:func:`robrst.report._sweep_figures.worst_bode_figure`) draws the record, it computes
nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core.analysis import sensitivity
from robrst.core.rst import RSTController
from robrst.problem.specs import PEAK_SPECS
from robrst.studies.sweep._evaluate import problem_of
from robrst.studies.sweep.summary import worst_rows

if TYPE_CHECKING:
    import pyarrow as pa

    from robrst.problem.records import Specs
    from robrst.studies.sweep.engine import SweepResult

__all__ = ["ModelCurves", "WorstCaseCurves", "worst_case_curves", "worst_ok_row", "ok_rows",
           "FREQ_HZ"]

FREQ_HZ = np.logspace(0, 4.7, 1200)   # 1 Hz .. 50 kHz


@dataclass(frozen=True, eq=False)
class ModelCurves:
    """The closed-loop responses of one model.

    Parameters
    ----------
    temperature_C : float
        The model's temperature [°C].
    responses : tuple of numpy.ndarray
        The complex responses of ``S, T, U`` (the order of
        :data:`robrst.problem.specs.PEAK_SPECS`) on the curves' frequencies.
    """

    temperature_C: float
    responses: tuple


@dataclass(frozen=True, eq=False)
class WorstCaseCurves:
    """The worst variant's frequency responses, as the report draws them.

    Parameters
    ----------
    freq_hz : numpy.ndarray
        The frequencies [Hz].
    models : tuple of ModelCurves
        The worst variant's family.
    base : tuple of ModelCurves
        The base family (an analysis sweep; else empty).
    specs : Specs
        The worst variant's specs (its bounds are drawn).
    what : str
        The variant: ``"variant 12"`` or ``"file a.json"``.
    worst_ratio : float
        Its worst figure / bound.
    """

    freq_hz: np.ndarray
    models: tuple
    base: tuple
    specs: Specs
    what: str
    worst_ratio: float


def ok_rows(table: pa.Table) -> pa.Table:
    """The rows of the variants evaluated (status ``"ok"``).

    Parameters
    ----------
    table : pyarrow.Table
        A sweep's results.

    Returns
    -------
    pyarrow.Table
    """
    import pyarrow as pa

    keep = [i for i, s in enumerate(table.column("status").to_pylist()) if s == "ok"]
    return table.take(pa.array(keep, type=pa.int64()))   # typed: an empty list has no type


def worst_ok_row(result: SweepResult) -> dict | None:
    """The row of the worst variant evaluated (``None`` when none was).

    Parameters
    ----------
    result : SweepResult
        The sweep.

    Returns
    -------
    dict or None
        Its row of ``results.parquet``.
    """
    t = ok_rows(result.table)
    rows = worst_rows(t, 1)
    return t.slice(rows[0], 1).to_pylist()[0] if rows else None


def _curves(models, ctrl, w):
    return tuple(ModelCurves(m.temperature_C, tuple(sensitivity(m, ctrl, name, w)
                                                    for name in PEAK_SPECS))
                 for m in models)


def worst_case_curves(result: SweepResult, freq_hz: np.ndarray = FREQ_HZ) -> WorstCaseCurves:
    """The frequency responses of the worst variant (:func:`worst_ok_row`).

    Parameters
    ----------
    result : SweepResult
        The sweep (at least one variant evaluated).
    freq_hz : numpy.ndarray
        The frequencies [Hz].

    Returns
    -------
    WorstCaseCurves
    """
    row = worst_ok_row(result)
    ctx = result.context
    values = {k: row[k] for k in ctx.names}
    problem = problem_of(ctx, row["index"], values)
    ctrl = (ctx.controller if ctx.controller is not None
            else RSTController(row["R"], row["S"], row["T"]))
    base = ctx.base.family.models if ctx.base is not None and ctx.sweep.kind == "analysis" else ()
    w = 2 * np.pi * np.asarray(freq_hz, float)
    what = f"file {row['file']}" if "file" in row else f"variant {row['index']}"
    return WorstCaseCurves(freq_hz=np.asarray(freq_hz, float),
                           models=_curves(problem.family.models, ctrl, w),
                           base=_curves(base, ctrl, w), specs=problem.specs, what=what,
                           worst_ratio=row["worst_ratio"])
