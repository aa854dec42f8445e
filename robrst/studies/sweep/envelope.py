"""The monotone envelope of a design sweep over bounds.

Each variant of a design sweep is designed on its own, and a design is a search of a
non-convex program: a variant whose bounds are looser may end at a worse certified
objective than a tighter one, although the tighter variant's controller meets the looser
bounds too.  A trade-off front drawn from such rows is not a front.

:func:`monotone_envelope` closes that gap when every variant is finished: for each variant
``v`` it looks at the certified variants ``u`` that *dominate* it — every swept spec bound
of ``u`` at least as tight as ``v``'s (an upper bound no larger, a lower bound no smaller,
:data:`robrst.problem.specs.SPEC_TABLE` gives the direction) and every other swept
parameter equal — and whose certified objective is better than ``v``'s.  The best of them
(then the next, :data:`ENVELOPE_TRIES` at most) is certified on ``v``'s own problem (:func:`robrst.certificate.proof.certify_problem`, the
default specs resolved, the time-domain figures completed as the design's certificate is);
when it certifies there, ``v``'s row becomes that controller's row on ``v``'s problem, its
column ``design_of`` names ``u`` and its message what ``v``'s own design reached.  So, over
the rows of one sweep:

* loosening any swept bound never returns a worse certified objective;
* every row's controller is certified on that row's problem (never taken on trust).

The chunk parts keep every variant's own design; only ``results.parquet`` (and the summary
and report drawn from it) hold the envelope, computed again from the parts on every run, so
a resumed sweep gives the same table.  Sweeps over plant parameters only, random parameters
(no two variants share the other values), fleets and multi-axis sweeps are left as they are.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import RobrstError
from robrst.certificate.completion import with_time_domain
from robrst.certificate.proof import certify_problem
from robrst.core.rst import RSTController
from robrst.problem.records import with_defaults
from robrst.problem.specs import SPECS_BY_KEY
from robrst.studies.sweep._evaluate import design_row, problem_of
from robrst.synthesis.objective import objective

if TYPE_CHECKING:
    import pyarrow as pa

    from robrst.studies.sweep._evaluate import SweepContext

__all__ = ["monotone_envelope", "bound_directions", "dominates", "ENVELOPE_COLUMN",
           "ENVELOPE_TRIES"]

#: the column of ``results.parquet`` naming the variant whose design a row holds
ENVELOPE_COLUMN = "design_of"
#: dominating designs certified on a variant at most (the best first): a tighter design
#: meets a looser variant's bounds, so the first almost always certifies there
ENVELOPE_TRIES = 3


def bound_directions(names: tuple) -> tuple:
    """Each swept parameter's role: ``+1`` an upper spec bound (smaller is tighter), ``-1`` a
    lower one (larger is tighter), ``0`` anything else (must be equal to compare).

    Parameters
    ----------
    names : tuple of str
        The sweep's parameter names (``"specs.Ms_max"``, ``"gain"``, ...).

    Returns
    -------
    tuple of int
    """
    out = []
    for n in names:
        row = SPECS_BY_KEY.get(n[len("specs."):]) if n.startswith("specs.") else None
        out.append(0 if row is None or row.bound is None else
                   (1 if row.bound == "upper" else -1))
    return tuple(out)


def dominates(u: np.ndarray, v: np.ndarray, directions: tuple) -> bool:
    """Variant ``u``'s swept values are at least as tight as ``v``'s (every bound) and equal
    elsewhere.

    Parameters
    ----------
    u, v : numpy.ndarray
        The two variants' parameter values, in the sweep's order.
    directions : tuple of int
        :func:`bound_directions` of the parameters.

    Returns
    -------
    bool
    """
    for a, b, d in zip(u, v, directions):
        if d == 0 and a != b or d * (a - b) > 0:
            return False
    return True


def _objectives(context, table):
    """Each row's certified objective from its columns (``None``: not certified, or an
    objective that does not order the rows)."""
    obj = context.base.solver.objective
    cert = table.column("certified").to_pylist()
    if obj == "max_integral_gain":
        vals = table.column("integral_gain").to_pylist()
        return [abs(v) if c and v is not None and np.isfinite(v) else None
                for c, v in zip(cert, vals)]
    if obj == "min_Ms":
        return [-v if c and v is not None else None
                for c, v in zip(cert, table.column("Ms").to_pylist())]
    return [None] * table.num_rows


def monotone_envelope(context: SweepContext, table: pa.Table,
                      complete: bool = True) -> pa.Table:
    """``table`` (every finished row, ordered by index) with the envelope of the module
    docstring, and the column :data:`ENVELOPE_COLUMN` (``None``: the variant's own design).

    Parameters
    ----------
    context : SweepContext
        The sweep's context (the base problem, the parameter names).
    table : pyarrow.Table
        The rows of ``results.parquet``.
    complete : bool
        Every variant is finished (else only the column is added: a row may still be
        dominated by one to come).

    Returns
    -------
    pyarrow.Table
        The same rows, with the dominated variants' rows replaced where a dominating
        design certifies on them.
    """
    import pyarrow as pa

    if ENVELOPE_COLUMN in table.column_names:
        table = table.drop_columns([ENVELOPE_COLUMN])
    n = table.num_rows
    keep = pa.array([None] * n, pa.int64())
    directions = bound_directions(context.names)
    if (not complete or context.sweep.kind != "design" or context.mimo
            or context.base is None or n < 2 or not any(directions)):
        return table.append_column(ENVELOPE_COLUMN, keep)
    values = np.column_stack([np.asarray(table.column(k).to_pylist(), float)
                              for k in context.names])
    index = table.column("index").to_pylist()
    objs = _objectives(context, table)
    rows = table.to_pylist()
    source = [None] * n
    for j in range(n):
        better = sorted((i for i in range(n) if i != j and objs[i] is not None
                         and (objs[j] is None or objs[i] > objs[j])
                         and dominates(values[i], values[j], directions)),
                        key=lambda i: -objs[i])
        if not better:
            continue
        try:          # variant j's problem, once for every design tried on it
            raw = problem_of(context, index[j],
                             dict(zip(context.names, (float(x) for x in values[j]))))
            problem = with_defaults(raw)
        except RobrstError:       # a variant that cannot be set up keeps its own row
            continue
        for i in better[:ENVELOPE_TRIES]:
            r = rows[i]
            ctrl = RSTController(r["R"], r["S"], r["T"])
            try:
                cert = certify_problem(problem, ctrl)
                if problem.specs.time_domain and problem.controller.T_mode != "reference_model":
                    cert = with_time_domain(problem, cert, ctrl)
            except RobrstError:
                continue
            got = objective(problem, ctrl, cert)
            if got is None or (objs[j] is not None and got <= objs[j]):
                continue
            own = ("not certified" if objs[j] is None else
                   f"certified objective {objs[j]:.6g}")
            new = design_row(raw, ctrl, cert)
            new.update(status="ok", seconds=rows[j]["seconds"], cpu_s=rows[j]["cpu_s"],
                       message=f"the design of variant {index[i]} (bounds at least as tight),"
                               f" certified on this variant: its own design {own}")
            rows[j] = {**rows[j], **{k: v for k, v in new.items() if k in rows[j]}}
            source[j] = index[i]
            break
    out = pa.Table.from_pylist(rows, schema=table.schema)
    return out.append_column(ENVELOPE_COLUMN, pa.array(source, pa.int64()))
