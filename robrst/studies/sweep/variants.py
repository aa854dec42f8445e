"""The variants of a sweep: a table of parameter values, and its chunks.

Random parameters are drawn by inverse CDF from one ``numpy.random.default_rng(seed)``
matrix of uniform numbers (``n`` rows, one column per random parameter, in file order), so
variant ``i`` depends only on the seed and ``i``; the same ``n`` draws are repeated at every
point of the grid (common random numbers), the grid being the cartesian product of the grid
parameters (the first one varying slowest).  Chunks are fixed index ranges of
``chunk_size`` variants: the unit of work, of writing and of resuming.
"""

from dataclasses import dataclass

import numpy as np

from robrst.base.schema import key_error
from robrst.problem.spread import DRAW_BLOCK, draw, draw_rows

__all__ = ["VariantTable", "Chunk", "variant_table", "chunks", "draw", "grid_values",
           "DRAW_BLOCK"]



@dataclass(frozen=True, eq=False)
class VariantTable:
    """Parameter ``values`` (``n`` x ``len(names)``), or ``labels`` for a fleet."""

    names: tuple
    values: np.ndarray
    labels: tuple = ()

    @property
    def n(self):
        return len(self.labels) if self.labels else int(self.values.shape[0])

    def row(self, i):
        """``{name: value}`` of variant ``i``."""
        return {k: float(v) for k, v in zip(self.names, self.values[i])}


@dataclass(frozen=True)
class Chunk:
    """Variants ``start <= i < stop``, chunk number ``index``."""

    index: int
    start: int
    stop: int

    def __len__(self):
        return self.stop - self.start


def variant_table(sweep, labels=()):
    """Every variant of ``sweep`` (``labels``: the fleet's file names).

    Returns
    -------
    VariantTable
    """
    names = tuple(p.name for p in sweep.params)
    if sweep.kind == "fleet":
        return VariantTable(names=(), values=np.zeros((len(labels), 0)), labels=tuple(labels))
    rand = [p for p in sweep.params if p.random]
    grid = sweep.grid
    if grid:
        mesh = np.meshgrid(*[np.asarray(p.values) for p in grid], indexing="ij")
        points = np.column_stack([m.ravel() for m in mesh])
    else:
        points = np.zeros((1, 0))
    g, r = points.shape[0], sweep.draws
    values = np.empty((g * r, len(names)))
    cube = values.reshape(g, r, len(names))     # a view: grid point, draw, parameter
    cols = [j for j, p in enumerate(sweep.params) if p.random]
    # the draws written in place (blocks of rows: no n x k temporaries beside the table;
    # 10 million variants: 160 MB, not 700)
    draw_rows(rand, r, sweep.seed, out=cube[0], cols=cols)
    for col in cols:            # the same draws at every grid point
        cube[1:, :, col] = cube[0, :, col]
    for gi, col in enumerate(j for j, p in enumerate(sweep.params) if not p.random):
        cube[:, :, col] = points[:, gi][:, None]
    return VariantTable(names=names, values=values)


def chunks(n, size):
    """The chunks of ``n`` variants, ``size`` per chunk (the last one shorter)."""
    return [Chunk(k, s, min(s + size, n)) for k, s in enumerate(range(0, n, size))]


def grid_values(path, key, p):
    """The values of a grid ``[[param]]`` table ``p`` (validated keys; errors name
    ``path`` and the key path ``key``)."""
    if p["values"] is not None:
        if any(p[k] is not None for k in ("lo", "hi", "steps")) or p["log"]:
            raise key_error(path, key + ("values",), "give either 'values' or lo, hi and steps")
        if not p["values"]:
            raise key_error(path, key + ("values",), "expected at least one value")
        return tuple(p["values"])
    for k in ("lo", "hi", "steps"):
        if p[k] is None:
            raise key_error(path, key + (k,), "missing: dist = 'grid' needs 'values', or lo,"
                            " hi and steps")
    if p["log"] and not p["lo"] > 0:
        raise key_error(path, key + ("lo",), "a log grid needs lo > 0")
    space = np.geomspace if p["log"] else np.linspace
    return tuple(float(v) for v in space(p["lo"], p["hi"], p["steps"]))
