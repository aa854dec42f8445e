"""Regenerate the committed sweep examples: ``python -m robrst.report.sweep_examples [OUT]``.

Runs the built-in sweeps ``paper_montecarlo`` (1,000 variants) and ``paper_tradeoff``
(16 robust designs) on a local Dask cluster, in ``sweeps/NAME`` (computed again: robrst's
earlier results there are discarded),
and writes their report folders to ``OUT/NAME`` (``OUT`` defaults to ``reports``).  About
1–2 minutes on two cores.
"""

from __future__ import annotations

import sys
from pathlib import Path

from robrst.report.sweep import write_sweep_report
from robrst.studies.sweep import run_sweep

__all__ = ["write_sweep_examples", "SWEEP_EXAMPLES"]

SWEEP_EXAMPLES = ("paper_montecarlo", "paper_tradeoff")


def write_sweep_examples(out: str | Path = "reports", work: str | Path = "sweeps",
                         workers: int | None = None) -> list[Path]:
    """Run the example sweeps and write their report folders under ``out``; return the paths.

    Parameters
    ----------
    out : str or pathlib.Path
        The parent of the report folders (``paper_montecarlo``, ``paper_tradeoff``).
    work : str or pathlib.Path
        The parent of the sweeps' own output folders.
    workers : int, optional
        Dask workers (default: one per core).

    Returns
    -------
    list of pathlib.Path
    """
    paths = []
    for name in SWEEP_EXAMPLES:
        # computed again, never resumed: the fingerprint holds the robrst version, not the
        # code, and a committed example is the current code's (robrst's own files only)
        result = run_sweep(name, Path(work) / name, workers=workers, restart=True)
        paths.append(write_sweep_report(result, Path(out) / name))
    return paths


if __name__ == "__main__":
    for p in write_sweep_examples(sys.argv[1] if len(sys.argv) > 1 else "reports"):
        print(p)
