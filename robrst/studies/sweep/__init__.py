"""Sweeps: Monte Carlo analyses, design trade-offs and fleets, on Dask (experiments layer).

``load_sweep`` reads a sweep file (:mod:`robrst.studies.sweep.files`), ``run_sweep`` runs it
(:mod:`robrst.studies.sweep.engine`) and returns a ``SweepResult``; the report folder is drawn by
:func:`robrst.report.sweep.write_sweep_report`.  Dask is imported only when a cluster is used.
"""

from robrst.studies.sweep.engine import Progress, SweepResult, run_sweep
from robrst.studies.sweep.files import Sweep, load_sweep, parse_sweep

__all__ = ["Sweep", "load_sweep", "parse_sweep", "run_sweep", "SweepResult", "Progress"]
