"""Figures without global state: a ``matplotlib.figure.Figure`` drawn under ``rc_context``.

Nothing here selects a backend or changes ``rcParams``: a user's matplotlib session is
left exactly as it was.  Every PNG robrst writes goes through :func:`drawing`.
"""

import io
from contextlib import contextmanager

import matplotlib
from matplotlib.figure import Figure

from robrst.base.fileio import atomic_write_bytes

__all__ = ["drawing", "STYLE", "colors"]

STYLE = {"font.size": 10, "axes.grid": True, "grid.alpha": 0.3}


@contextmanager
def drawing(path, figsize, nrows=1, ncols=1, dpi=90, tight=True, **subplot_kw):
    """Draw a figure and write it to ``path`` as PNG (atomically).

    Yields ``(fig, axes)``; on leaving the block the figure is laid out and saved.
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


def colors(n, cmap="coolwarm"):
    """``n`` colours spread over a colormap (at least two)."""
    import numpy as np

    return matplotlib.colormaps[cmap](np.linspace(0, 1, max(n, 2)))
