"""Helpers shared by the commands: progress lines, JSON output."""

import sys

from robrst.base.fileio import json_text

__all__ = ["progress_printer", "print_json"]


def progress_printer(quiet):
    """A progress callback printing to stderr, or a silent one."""
    if quiet:
        return lambda msg: None
    return lambda msg: print(msg, file=sys.stderr, flush=True)


def print_json(obj, indent=None):
    """Print exactly one JSON object on stdout (robrst's contract)."""
    print(json_text(obj, indent=indent))
