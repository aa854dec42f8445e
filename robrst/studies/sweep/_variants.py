"""The variants of a sweep: a table of parameter values, and its chunks.

Random parameters are drawn by inverse CDF from one ``numpy.random.default_rng(seed)``
matrix of uniform numbers (``n`` rows, one column per random parameter, in file order), so
variant ``i`` depends only on the seed and ``i``; the same ``n`` draws are repeated at every
point of the grid (common random numbers), the grid being the cartesian product of the grid
parameters (the first one varying slowest).  Chunks are fixed index ranges of
``chunk_size`` variants: the unit of work, of writing and of resuming.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from robrst.base.schema import key_error
from robrst.problem.spread import DRAW_BLOCK, draw, draw_rows

if TYPE_CHECKING:
    from pathlib import Path

__all__ = ["VariantTable", "Chunk", "variant_table", "chunks", "draw", "grid_values",
           "DRAW_BLOCK"]



@dataclass(frozen=True, eq=False)
class VariantTable:
    """Parameter ``values`` (``n`` x ``len(names)``), or ``labels`` for a fleet.

    Parameters
    ----------
    names : tuple of str
        The varied parameters, in file order.
    values : numpy.ndarray
        One row per variant.
    labels : tuple of str
        A fleet's member files (no parameters).

    Attributes
    ----------
    n : int
        Number of variants.
    """

    names: tuple
    values: np.ndarray
    labels: tuple = ()

    @property
    def n(self):
        return len(self.labels) if self.labels else int(self.values.shape[0])

    def row(self, i: int) -> dict[str, float]:
        """``{name: value}`` of variant ``i``.

        Parameters
        ----------
        i : int
            The variant's index.

        Returns
        -------
        dict
        """
        return {k: float(v) for k, v in zip(self.names, self.values[i])}


@dataclass(frozen=True)
class Chunk:
    """Variants ``start <= i < stop``, chunk number ``index``.

    Parameters
    ----------
    index : int
        The chunk's number (names its part file).
    start, stop : int
        The variants it holds.
    """

    index: int
    start: int
    stop: int

    def __len__(self):
        return self.stop - self.start


def variant_table(sweep: Any, labels: Sequence[str] = ()) -> VariantTable:
    """Every variant of ``sweep`` (``labels``: the fleet's file names).

    Random draws are ``numpy.random.default_rng(seed).random((n, k))`` mapped by the
    inverse CDF (drawn in blocks, the same numbers as one draw), repeated at every grid
    point (the grid's first parameter varies slowest).

    Parameters
    ----------
    sweep : robrst.studies.sweep.files.Sweep
        The validated sweep.
    labels : sequence of str
        A fleet's member files.

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


def chunks(n: int, size: int) -> list[Chunk]:
    """The chunks of ``n`` variants, ``size`` per chunk (the last one shorter).

    Parameters
    ----------
    n : int
        Variants.
    size : int
        Variants per chunk.

    Returns
    -------
    list of Chunk

    Examples
    --------
    >>> from robrst.studies.sweep._variants import chunks
    >>> [(c.start, c.stop) for c in chunks(5, 2)]
    [(0, 2), (2, 4), (4, 5)]
    """
    return [Chunk(k, s, min(s + size, n)) for k, s in enumerate(range(0, n, size))]


def grid_values(path: str | Path, key: tuple, p: dict) -> tuple[float, ...]:
    """The values of a grid ``[[param]]`` table ``p``.

    Parameters
    ----------
    path : str or pathlib.Path
        The sweep file, named in errors.
    key : tuple of str
        The table's key path, named in errors.
    p : dict
        The validated table (``values``, or ``lo``, ``hi``, ``steps``, ``log``).

    Returns
    -------
    tuple of float

    Raises
    ------
    SpecError
        Both or neither of ``values`` and ``lo, hi, steps``, no value, or a log grid with
        ``lo <= 0``.
    """
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
