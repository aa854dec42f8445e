"""The summary of a sweep's results: yield, statistics, worst variants, trade-off front.

``summary.json`` (a public contract: fields are only added) holds ``kind, n, done,
certified, yield, workers, wall_s, worst`` and more (docs/guide/sweeps.md, "Output folder").  The yield is the
share of the *finished* variants that are certified (a failed variant counts as not
certified), with its 95 % Wilson score interval.  The worst variants are the failed ones
first, then by ``worst_ratio`` (largest figure/bound over the specs), with their parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from robrst.problem.specs import spec_columns
from robrst.studies.sweep._evaluate import spec_figure_columns
from robrst.studies.sweep.envelope import ENVELOPE_COLUMN
from robrst.studies.sweep._mimo import MIMO_STAT_FIGURES, MIMO_WORST_KEYS

if TYPE_CHECKING:
    import pyarrow as pa
    from numpy.typing import ArrayLike

    from robrst.studies.sweep._evaluate import SweepContext

__all__ = ["wilson_interval", "pareto_front", "front_values", "figure_stats", "worst_rows",
           "summarise", "STAT_FIGURES", "WORST_KEYS", "FRONT_KEYS", "MIMO_FRONT_KEYS"]

STAT_FIGURES = (*(row.column for row in spec_columns()), "modulus_margin", "gain_margin",
                "phase_margin_deg", "delay_margin_s", "spectral_abscissa", "integral_gain",
                "worst_ratio", "seconds", "cpu_s")


def wilson_interval(k: int, n: int,
                    confidence_level: float = 0.95) -> tuple[float | None, float | None]:
    """Wilson score interval of a proportion ``k/n`` (``(None, None)`` for n = 0).

    A thin wrapper of ``scipy.stats.binomtest(k, n).proportion_ci(confidence_level,
    method="wilson")`` (SciPy's own interval: the hand-written formula this replaced agreed
    with it to 2.3e-16 over every ``k`` of ``n`` = 1 … 200 and larger ``n``, ``k = 0`` and
    ``k = n`` included), that also answers ``n = 0``.  ``scipy.stats`` is imported on the
    first call: it costs a command's start ≈ 0.3 s, and only a sweep's summary needs it.

    Parameters
    ----------
    k : int
        Successes, ``0 <= k <= n``.
    n : int
        Trials.
    confidence_level : float
        The interval's confidence (default 95 %).

    Returns
    -------
    (float, float) or (None, None)
        The interval, within [0, 1] (exactly 0 for ``k = 0``, 1 for ``k = n``).

    Examples
    --------
    >>> from robrst.studies.sweep.summary import wilson_interval
    >>> [round(x, 4) for x in wilson_interval(34, 1000)]
    [0.0244, 0.0471]
    >>> wilson_interval(0, 0)
    (None, None)
    """
    if n == 0:
        return None, None
    from scipy.stats import binomtest   # noqa: PLC0415  (lazy: see above)

    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence_level,
                                                method="wilson")
    return float(ci.low), float(ci.high)


def pareto_front(x: ArrayLike, y: ArrayLike) -> list[int]:
    """Indices of the points not dominated when minimising ``x`` and maximising ``y``.

    A point is dominated when another is at least as good in both figures and strictly
    better in one; equal points do not dominate each other, so ties are all on the front.
    Points with a non-finite coordinate are left out.

    Parameters
    ----------
    x : array_like
        The figure minimised.
    y : array_like
        The figure maximised.

    Returns
    -------
    list of int
        Ordered by increasing ``x`` (then by index).

    Examples
    --------
    >>> from robrst.studies.sweep.summary import pareto_front
    >>> pareto_front([1.0, 2.0, 2.0, 3.0], [1.0, 3.0, 2.0, 3.0])
    [0, 1]
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
    order = ok[np.lexsort((ok, -y[ok], x[ok]))]      # x up, y down, index up
    front, best = [], -np.inf       # best: the largest y at a strictly smaller x
    start = 0
    while start < order.size:
        stop = start
        while stop < order.size and x[order[stop]] == x[order[start]]:
            stop += 1
        top = y[order[start]]        # the largest y at this x
        if top > best:
            front += [int(i) for i in order[start:stop] if y[i] == top]
            best = top
        start = stop
    return front


def front_values(name: str, values: ArrayLike) -> np.ndarray:
    """Figure ``name`` as the trade-off front ranks it: the integral gain by its magnitude
    (robrst maximises ``|ki|``: a plant of negative static gain has a negative one), any
    other figure as it is.

    Parameters
    ----------
    name : str
        The figure's column name.
    values : array_like
        Its values.

    Returns
    -------
    numpy.ndarray
    """
    v = np.asarray(values, float)
    return np.abs(v) if name == "integral_gain" else v


def _col(table, name):
    return np.array([np.nan if v is None else v for v in table.column(name).to_pylist()],
                    dtype=float)


def figure_stats(table: pa.Table, names: Sequence[str] = STAT_FIGURES) -> dict[str, dict]:
    """min, 5 %, median, 95 %, max of every figure over the variants evaluated.

    Parameters
    ----------
    table : pyarrow.Table
        The finished rows.
    names : sequence of str
        The figures' columns.

    Returns
    -------
    dict
        ``{figure: {"min", "p05", "median", "p95", "max"}}`` for the figures with finite
        values.
    """
    out = {}
    for name in names:
        if name not in table.column_names:
            continue
        v = _col(table, name)
        v = v[~np.isnan(v)]
        if v.size == 0:
            continue
        q = np.quantile(v, [0.0, 0.05, 0.5, 0.95, 1.0], method="inverted_cdf")   # data points
        out[name] = dict(zip(("min", "p05", "median", "p95", "max"), (float(x) for x in q)))
    return out


def _record(row, names, extra):
    rec = {"index": row["index"], "params": {k: row[k] for k in names}}
    if "file" in row:
        rec["file"] = row["file"]
    rec.update({k: row.get(k) for k in extra})
    return rec


WORST_KEYS = ("status", "certified", "worst_ratio", "Ms", "Ms_temperature_C", "Mt", "Mu",
              "Mt_band", "gain_margin", "phase_margin_deg", "delay_margin_s",
              "spectral_abscissa", "integral_gain", "violation", "message")


#: what a point of the trade-off front holds besides its two figures
FRONT_KEYS = ("Ms", "Mt", "Mu", "integral_gain")
MIMO_FRONT_KEYS = ("sigma_S", "sigma_T", "sigma_U", "crosstalk", "integral_gain")


def worst_rows(table: pa.Table, count: int) -> list[int]:
    """Row indices (in ``table``) of the ``count`` worst variants: failed first, then by ratio.

    Parameters
    ----------
    table : pyarrow.Table
        The finished rows.
    count : int
        How many.

    Returns
    -------
    list of int
    """
    if table.num_rows == 0 or count == 0:
        return []
    failed = np.array([s != "ok" for s in table.column("status").to_pylist()])
    ratio = np.nan_to_num(_col(table, "worst_ratio"), nan=np.inf, posinf=np.inf)
    index = _col(table, "index")
    order = np.lexsort((index, -ratio, ~failed))
    return [int(i) for i in order[:count]]


def summarise(context: SweepContext, table: pa.Table, n: int, workers: int, wall_s: float,
              complete: bool) -> dict:
    """The summary of ``table`` (the finished rows).

    Parameters
    ----------
    context : SweepContext
        The sweep's context.
    table : pyarrow.Table
        The finished rows.
    n : int
        Variants in the sweep.
    workers : int
        Workers of this run.
    wall_s : float
        Wall time of this run [s].
    complete : bool
        Every variant is finished.

    Returns
    -------
    dict
        The ``summary.json`` object (fields are only added).
    """
    sw = context.sweep
    done = table.num_rows
    statuses = table.column("status").to_pylist()
    certified = sum(bool(c) for c in table.column("certified").to_pylist())
    lo, hi = wilson_interval(certified, done)
    counts = {s: statuses.count(s) for s in sorted(set(statuses))}
    unstable = sum(s is False for s in table.column("stable").to_pylist()) if done else 0
    cpu = float(np.nansum(_col(table, "cpu_s"))) if done else 0.0
    rows = table.to_pylist() if done <= 200_000 else None
    mimo = context.mimo
    worst = []
    if rows is not None:
        worst = [_record(rows[i], context.names, MIMO_WORST_KEYS if mimo else WORST_KEYS)
                 for i in worst_rows(table, sw.worst)]
    out = {"sweep": sw.name, "kind": sw.kind,
           "problem": None if context.base is None else context.base.name, "n": n, "done": done,
           "complete": bool(complete), "certified": certified,
           "yield": certified / done if done else None, "yield_ci95": [lo, hi],
           "failed": done - counts.get("ok", 0), "statuses": counts, "workers": workers,
           "wall_s": wall_s, "cpu_s": cpu, "cpu_s_per_variant": cpu / done if done else None,
           "chunk_size": sw.chunk_size, "seed": sw.seed, "params": list(context.names),
           "fingerprint": context.fingerprint,
           "figures": figure_stats(table, MIMO_STAT_FIGURES if mimo else STAT_FIGURES + tuple(
               spec_figure_columns(None if context.base is None else context.base.specs))),
           "worst": worst,
           "results": "results.parquet", "report": "report", "unstable": unstable}
    if context.controller is not None:
        out["controller"] = context.controller.as_dict()
    if mimo:
        fam = context.base.family
        out["specs"] = context.base.specs.as_dict()
        out.update(axes=list(context.base.axes), parameter=fam.parameter, unit=fam.unit,
                   parameter_range=list(fam.range))
        if fam.parameter == "temperature_C":
            out["temperature_range_C"] = list(fam.range)
    elif context.base is not None:
        sp = context.base.specs
        # the bound of every spec with a sweep column (robrst.problem.specs)
        out["specs"] = {row.key: getattr(sp, row.key) for row in spec_columns(sp)}
        out["temperature_range_C"] = list(context.base.family.range_C)
    if ENVELOPE_COLUMN in table.column_names:
        kept = [(r["index"], r[ENVELOPE_COLUMN]) for r in rows or ()
                if r[ENVELOPE_COLUMN] is not None]
        out["envelope"] = {"rows": len(kept), "design_of": {str(i): j for i, j in kept}}
    if sw.kind != "analysis" and rows is not None:
        x, y = sw.front
        ok = [i for i, r in enumerate(rows) if r["certified"]]
        xs = [_finite(rows[i][x]) for i in ok]
        ys = front_values(y, [_finite(rows[i][y]) for i in ok])
        out["front"] = {"x": x, "y": y, "y_ranked": "magnitude" if y == "integral_gain"
                        else "value", "points": [
            _record(rows[ok[j]], context.names,
                    tuple(dict.fromkeys((x, y) + (MIMO_FRONT_KEYS if mimo else FRONT_KEYS))))
            for j in pareto_front(xs, ys)]}
    return out


def _finite(v):
    return np.nan if v is None else float(v)
