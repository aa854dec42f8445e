"""Helpers shared by the commands: progress lines, JSON output."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import sys

from robrst.base.fileio import json_text

__all__ = ["progress_printer", "print_json"]


def progress_printer(quiet: bool) -> Callable[[str], None]:
    """A progress callback printing to stderr, or a silent one.

    Parameters
    ----------
    quiet : bool
        Print nothing.

    Returns
    -------
    callable
        ``progress(message)``.
    """
    if quiet:
        return lambda msg: None
    return lambda msg: print(msg, file=sys.stderr, flush=True)


def print_json(obj: Any, indent: int | None = None) -> None:
    """Print exactly one JSON object on stdout (robrst's contract).

    Parameters
    ----------
    obj : object
        The object (see :func:`robrst.base.fileio.jsonable`).
    indent : int, optional
        Indentation (``None``: one line).
    """
    print(json_text(obj, indent=indent))
