"""Figures without global state: a ``matplotlib.figure.Figure`` drawn under ``rc_context``.

Nothing here selects a backend or changes ``rcParams``: a user's matplotlib session is
left exactly as it was.  Every PNG robrst writes goes through :func:`drawing`.
"""

from __future__ import annotations

import io
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import matplotlib
from matplotlib.figure import Figure

from robrst.base.fileio import atomic_write_bytes

if TYPE_CHECKING:
    from pathlib import Path
    import numpy as np

__all__ = ["drawing", "STYLE", "colors"]

STYLE = {"font.size": 10, "axes.grid": True, "grid.alpha": 0.3}


@contextmanager
def drawing(path: str | Path, figsize: tuple[float, float], nrows: int = 1, ncols: int = 1,
            dpi: int = 90, tight: bool = True, **subplot_kw: Any) -> Iterator[tuple]:
    """Draw a figure and write it to ``path`` as PNG (atomically).

    Parameters
    ----------
    path : str or pathlib.Path
        The PNG file.
    figsize : (float, float)
        Width and height [inch].
    nrows, ncols : int
        The subplot grid.
    dpi : int
        Resolution of the PNG.
    tight : bool
        Lay the figure out tightly before saving.
    **subplot_kw
        Passed to ``Figure.subplots`` (e.g. ``sharex=True``).

    Yields
    ------
    (matplotlib.figure.Figure, axes)
        On leaving the block the figure is laid out and saved; no global matplotlib
        state is touched.
    """
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=figsize)
        axes = fig.subplots(nrows, ncols, **subplot_kw)
        yield fig, axes
        if tight:
            fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight" if not tight else None)
    atomic_write_bytes(path, buf.getvalue())


def colors(n: int, cmap: str = "coolwarm") -> np.ndarray:
    """``n`` colours spread over a colormap (at least two).

    Parameters
    ----------
    n : int
        How many colours.
    cmap : str
        A matplotlib colormap name.

    Returns
    -------
    numpy.ndarray
        RGBA rows.
    """
    import numpy as np

    return matplotlib.colormaps[cmap](np.linspace(0, 1, max(n, 2)))
