"""A fleet design verified on fresh actuators: the sweep engine's Monte Carlo, on Dask.

:func:`verify_fleet` draws ``n`` *fresh* actuators from the design problem's own spread (a
seed other than the design's: none of the drawn scenarios is reused), certifies the
designed controller on each with the sweep engine (an ``analysis`` sweep of the spread's
parameters, :func:`robrst.studies.sweep.run_sweep`: every spec, continuous and sampled,
over each actuator's temperature interval) and returns a :class:`FleetVerification`: the
measured yield with its 95 % Wilson interval next to the a-priori guarantee, and the worst
actuators found.  :func:`fleet_sweep` is the sweep record it runs (a sweep file could say
the same: ``kind = "analysis"``, ``controller = "result.json"`` and the spread as
``[[param]]`` tables).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from robrst.base.errors import SpecError
from robrst.studies.sweep.engine import run_sweep
from robrst.studies.sweep.files import Sweep

if TYPE_CHECKING:
    from robrst.problem.records import Problem
    from robrst.problem.spread import Spread

__all__ = ["FleetVerification", "fleet_sweep", "verify_fleet", "yield_interval",
           "verification_toml", "FRESH_SEED_OFFSET"]

FRESH_SEED_OFFSET = 1_000_003   # fresh draws: the design's seed plus this (never the same)


def yield_interval(certified: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a yield (:func:`scipy.stats.binomtest`'s ``proportion_ci``).

    Parameters
    ----------
    certified : int
        Actuators certified.
    n : int
        Actuators checked.
    confidence : float
        Confidence level of the interval.

    Returns
    -------
    (float, float)
    """
    from scipy.stats import binomtest

    ci = binomtest(int(certified), int(n)).proportion_ci(confidence, method="wilson")
    return float(ci.low), float(ci.high)


@dataclass(frozen=True)
class FleetVerification:
    """The measured yield of a fleet design on fresh draws, and the guarantee beside it.

    Parameters
    ----------
    problem : str
        The problem's name.
    n : int
        Fresh actuators checked.
    seed : int
        Their seed.
    certified, unstable : int
        How many certify; how many have an unstable loop.
    yield_ci95 : (float, float)
        Wilson interval of the measured yield.
    guaranteed_yield : float or None
        The design's a-priori statement, beside it.
    yield_target, confidence : float
        The spread's.
    worst : tuple of dict
        The worst actuators found (the sweep summary's rows).
    workers : int
        Dask workers.
    wall_s : float
        The sweep's wall time.
    out : str
        The sweep's output folder.

    Attributes
    ----------
    measured_yield : float or None
        ``certified / n``.
    """

    problem: str
    n: int
    seed: int
    certified: int
    unstable: int
    yield_ci95: tuple
    guaranteed_yield: float
    yield_target: float
    confidence: float
    worst: tuple
    workers: int
    wall_s: float
    out: str

    @property
    def measured_yield(self):
        return self.certified / self.n if self.n else None

    def as_dict(self) -> dict:
        """The record as a JSON-able dict.

        Returns
        -------
        dict
        """
        return {"problem": self.problem, "n": self.n, "seed": self.seed,
                "certified": self.certified, "measured_yield": self.measured_yield,
                "yield_ci95": list(self.yield_ci95), "unstable": self.unstable,
                "guaranteed_yield": self.guaranteed_yield, "yield_target": self.yield_target,
                "confidence": self.confidence, "worst": list(self.worst),
                "workers": self.workers, "wall_s": self.wall_s, "sweep": self.out}


def fleet_sweep(problem_path: str | os.PathLike, result_path: str | os.PathLike,
                spread: Spread, n: int, seed: int, name: str = "fleet_verification",
                chunk_size: int = 10, worst: int = 10) -> Sweep:
    """The analysis sweep that certifies a result file's controller on ``n`` actuators of
    ``spread`` drawn with ``seed`` (each certificate at ``spread.cert_temperatures``).

    Parameters
    ----------
    problem_path : str or Path
        The design problem file.
    result_path : str or Path
        Its result file (``robrst design --json``).
    spread : Spread
        The actuators' spread.
    n, seed : int
        Actuators and their seed.
    name : str
        The sweep's name.
    chunk_size, worst : int
        Variants per task; worst variants listed.

    Returns
    -------
    Sweep
    """
    overrides = ()
    if spread.cert_temperatures:
        overrides = ((("solver", "cert_temperatures"), spread.cert_temperatures),)
    result_path = Path(result_path).resolve()
    return Sweep(name=name, kind="analysis", path=str(result_path.parent / f"{name}.toml"),
                 problem=str(problem_path), seed=int(seed), n=int(n), chunk_size=chunk_size,
                 worst=worst, params=tuple(spread.params), overrides=overrides,
                 ageing=spread.ageing, controller=str(result_path), margins=False)


def verify_fleet(problem: Problem, result_path: str | os.PathLike, out: str | os.PathLike,
                 n: int = 1000, seed: int | None = None, workers: int | None = None,
                 progress: Callable | None = None, guaranteed_yield: float | None = None,
                 restart: bool = False) -> FleetVerification:
    """Certify a fleet design's controller on ``n`` fresh actuators (module docstring).

    Parameters
    ----------
    problem : Problem
        The design problem (with its ``spread``), loaded from a file.
    result_path : str or Path
        The design's result file (``robrst design --json``).
    out : str or Path
        The sweep's output folder (resumed if it holds the same sweep).
    n : int
        Fresh actuators.
    seed : int, optional
        Their seed (default: the design's seed plus ``FRESH_SEED_OFFSET``).
    workers : int, optional
        Dask workers (``0``: in this process).
    progress : callable, optional
        The sweep engine's progress callback.
    guaranteed_yield : float, optional
        The design's guarantee, reported beside the measured yield.
    restart : bool
        Discard earlier results in ``out`` (robrst's own files only).

    Returns
    -------
    FleetVerification

    Raises
    ------
    SpecError
        A problem without spread, or one not read from a file.
    """
    spread = problem.spread
    if spread is None:
        raise SpecError(f"{problem.path}: no [spread]: nothing to verify a fleet design on")
    if not Path(str(problem.path)).is_file():
        raise SpecError(f"{problem.path}: the fleet verification needs the problem file")
    seed = spread.seed + FRESH_SEED_OFFSET if seed is None else int(seed)
    if seed == spread.seed:
        raise SpecError(f"seed {seed}: the design's own draws; fresh actuators need another seed")
    sweep = fleet_sweep(problem.path, result_path, spread, n, seed,
                        name=f"{problem.name}_verification")
    res = run_sweep(sweep, out, workers=workers, progress=progress, restart=restart)
    s = res.summary
    stable = [r for r in res.table.column("stable").to_pylist()]
    unstable = sum(1 for v in stable if v is False)
    return FleetVerification(problem=problem.name, n=s["done"], seed=seed,
                             certified=s["certified"],
                             unstable=unstable, yield_ci95=yield_interval(s["certified"], s["done"]),
                             guaranteed_yield=guaranteed_yield, yield_target=spread.yield_target,
                             confidence=spread.confidence, worst=tuple(s["worst"]),
                             workers=s["workers"], wall_s=s["wall_s"], out=os.fspath(out))


def verification_toml(problem: str, spread: Spread, n: int, seed: int,
                      controller: str = "result.json") -> str:
    """The sweep file of :func:`fleet_sweep` as TOML text (``robrst sweep FILE`` runs the
    same verification).

    Parameters
    ----------
    problem : str
        A built-in problem's name, or a path relative to the sweep file.
    spread : Spread
        The actuators' spread.
    n, seed : int
        Actuators and their seed.
    controller : str
        The result file, relative to the sweep file.

    Returns
    -------
    str
    """
    def num(x):
        return repr(float(x))

    lines = ["# The fleet design's controller certified on fresh actuators of its spread",
             "[sweep]", f'name = "{Path(str(problem)).stem}_verification"',
             'kind = "analysis"', f'problem = "{problem}"', f"seed = {int(seed)}",
             f"n = {int(n)}", "", "[analysis]", f'controller = "{controller}"',
             "margins = false", ""]
    if spread.cert_temperatures:
        lines += ["[set.solver]", f"cert_temperatures = {int(spread.cert_temperatures)}", ""]
    for p in spread.params:
        lines += ["[[param]]", f'name = "{p.name}"', f'dist = "{p.dist}"']
        for k in ("mean", "std", "median", "sigma", "lo", "hi"):
            if getattr(p, k) is not None:
                lines.append(f"{k} = {num(getattr(p, k))}")
        if p.note:
            lines.append(f"note = {json.dumps(p.note, ensure_ascii=False)}")
        lines.append("")
    return "\n".join(lines)
