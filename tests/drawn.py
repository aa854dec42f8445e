"""The figures a report module draws, kept for the tests to read (test helper)."""

from contextlib import contextmanager
from pathlib import Path

import pytest


@contextmanager
def drawn(module):
    """While the block runs, every figure ``module`` draws (its ``drawing`` patched), by file
    name: yields the dict the figures are added to."""
    figures, real = {}, module.drawing

    @contextmanager
    def keep(path, *args, **kw):
        with real(path, *args, **kw) as (fig, axes):
            figures[Path(path).name] = fig
            yield fig, axes

    mp = pytest.MonkeyPatch()
    mp.setattr(module, "drawing", keep)
    try:
        yield figures
    finally:
        mp.undo()
