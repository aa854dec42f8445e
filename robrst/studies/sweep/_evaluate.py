"""What a worker does: build its state once, then evaluate chunks of variants.

:class:`SweepContext` is everything a worker needs (the sweep, the base problem and its
document, the fixed controller of an analysis, a fleet's documents); it is built once by the
driver and shipped once to every worker.  :func:`build_state` turns it into the worker's
:class:`WorkerState` — the one place where per-worker set-up happens (today: the designer,
``run_problem`` with one dict of built NLP solvers per worker, so every design variant of
the same structure reuses the program compiled for the first).
:func:`evaluate_chunk` then returns one row per variant; a variant that fails is a row with
its status and message, never an exception.

Row figures are worst cases over the variant's family and the certificate's temperature
sweep (``Ms``, ``Mt``, ``Mu``, ``Mt_band``, ``spectral_abscissa``; ``modulus_margin = 1/Ms``;
none of a loop that is unstable on some model: its peaks and margins are no figures of it,
``stable`` is false and ``violation`` names the instability),
from :func:`robrst.certificate.proof.certify_problem`; gain, phase and delay margins are the smallest
over the family's models (:func:`robrst.core.analysis.margins`).  ``worst_ratio`` is the largest
figure/bound over the specs and every violation the certificate found (> 1 + cert_tol:
violated; ``inf``: unstable).
"""

from __future__ import annotations

import json
import threading
import time
import warnings
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core.analysis import margins as loop_margins
from robrst.certificate.mimo import certify_mimo_problem
from robrst.certificate.proof import certify_problem
from robrst.base.errors import InfeasibleError, RobrstError, SolverError, SpecError
from robrst.problem.files import parse_problem
from robrst.problem.specs import LOOPS, spec_columns
from robrst.problem.mimo_files import MIMO_SCHEMA
from robrst.studies.sweep.files import problem_field
from robrst.studies.sweep._mimo import MIMO_COLUMNS, mimo_figures, mimo_variant
from robrst.studies.sweep._model import merge_documents, variant_problem
from robrst.synthesis.parametrize import integral_gain
from robrst.base.threads import one_blas_thread

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.design import DesignResult
    from robrst.problem.records import Problem, Specs
    from collections.abc import Callable
    from robrst.core.mimo_loop import MimoController
    from robrst.core.rst import RSTController
    from robrst.studies.sweep.files import Sweep

__all__ = ["SweepContext", "WorkerState", "build_state", "evaluate_chunk", "evaluate_variant",
           "problem_of", "fleet_problem", "FIGURE_COLUMNS", "CONTROLLER_COLUMNS",
           "spec_figure_columns", "status_of", "design_row",
           "failed_row", "design_cause"]

# column -> arrow type name; the same columns for every kind
FIGURE_COLUMNS = {
    "status": "string", "message": "string", "certified": "bool_", "stable": "bool_",
    "worst_ratio": "float64",
    # the worst figure of every spec with a column (robrst.problem.specs), Ms with its place
    **{k: "float64" for row in spec_columns()
       for k in ((row.column, "Ms_temperature_C") if row.column == "Ms" else (row.column,))},
    "modulus_margin": "float64",
    "gain_margin": "float64", "phase_margin_deg": "float64", "delay_margin_s": "float64",
    "spectral_abscissa": "float64", "Ms_sampled": "float64", "Mt_sampled": "float64",
    "Mu_sampled": "float64", "integral_gain": "float64", "violations": "int64",
    "violation": "string", "seconds": "float64", "cpu_s": "float64",
}
CONTROLLER_COLUMNS = ("R", "S", "T")   # design and fleet rows: the variant's controller


@dataclass(frozen=True, eq=False)
class SweepContext:
    """What every worker needs, built once by the driver (see the module docstring).

    Parameters
    ----------
    sweep : Sweep
        The sweep.
    names : tuple of str
        The varied parameters, in file order.
    base : Problem, optional
        The base problem (after ``[set]``; ``None`` for a fleet without one).
    doc : dict, optional
        The base problem's document (variants are set in it and parsed again).
    controller : RSTController, optional
        The controller an analysis certifies on every variant.
    fleet : tuple
        ``(label, document or None, error or None)`` per fleet file.
    fingerprint : str
        What the output folder's results were computed from (resume check).
    """

    sweep: Sweep
    names: tuple = ()
    base: Problem | None = None
    doc: dict = None
    controller: RSTController | MimoController | None = None
    fleet: tuple = ()
    fingerprint: str = ""

    @property
    def mimo(self) -> bool:
        """The base problem is a multi-axis problem (:mod:`robrst.studies.sweep._mimo`)."""
        return self.sweep.mimo

    def figure_columns(self) -> dict[str, str]:
        """The figure columns of this sweep's rows, with their arrow types.

        Returns
        -------
        dict
            :data:`FIGURE_COLUMNS` and the columns of the specs only this sweep's problem
            bounds; a multi-axis sweep's :data:`robrst.studies.sweep._mimo.MIMO_COLUMNS`.
        """
        if self.mimo:
            return dict(MIMO_COLUMNS)
        return {**FIGURE_COLUMNS,
                **spec_figure_columns(None if self.base is None else self.base.specs)}

    def controller_columns(self) -> dict[str, str]:
        """The controller columns of a design or fleet row (none for an analysis).

        Returns
        -------
        dict
            ``R, S, T`` (lists of floats); a multi-axis design's ``controller`` (JSON text
            of :meth:`robrst.core.mimo_loop.MimoController.as_dict`).
        """
        if self.sweep.kind == "analysis":
            return {}
        if self.mimo:
            return {"controller": "string"}
        return {k: "list" for k in CONTROLLER_COLUMNS}


@dataclass(frozen=True, eq=False)
class WorkerState:
    """A worker's state, built once by :func:`build_state`.

    Parameters
    ----------
    context : SweepContext
        What every variant needs.
    designer : Synthesizer, optional
        The designer of design and fleet sweeps (its built programs shared by the
        variants).
    lock : threading.Lock
        Serialises the variants of one worker's threads.
    templates : dict
        Built NLP solvers, shared by the variants.
    """

    context: SweepContext
    designer: Callable[..., DesignResult] | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)
    templates: dict = field(default_factory=dict)   # built NLP solvers, shared by the variants


def build_state(context: SweepContext) -> WorkerState:
    """The per-worker state of ``context`` (run once per worker process).

    Parameters
    ----------
    context : SweepContext
        What every variant needs.

    Returns
    -------
    WorkerState
    """
    designer = None
    if context.mimo:
        from robrst.design.mimo import design_mimo

        designer = design_mimo if context.sweep.kind == "design" else None
        return WorkerState(context=context, designer=designer)
    if context.sweep.kind in ("design", "fleet"):
        from robrst.design import run_problem

        designer = run_problem
    base = context.base
    if base is None or base.needs_scipy:   # the variants will load it: once, here
        import scipy.linalg  # noqa: F401
    return WorkerState(context=context, designer=designer)


def status_of(exc: BaseException) -> str:
    """The row status of an exception: infeasible, solver_failed, invalid or error.

    Parameters
    ----------
    exc : BaseException
        What ended a variant.

    Returns
    -------
    str
    """
    if isinstance(exc, InfeasibleError):
        return "infeasible"
    if isinstance(exc, SolverError):
        return "solver_failed"
    if isinstance(exc, RobrstError):
        return "invalid"
    return "error"


def _figures(problem, ctrl, cert, member_margins):
    recs = cert.models
    worst_ms = max(recs, key=lambda r: r.continuous.Ms) if recs else None
    cont = all(r.continuous.stable for r in recs)
    samp = all(r.sampled is None or r.sampled.stable for r in recs)
    stable = cont and samp
    # every bound the certificate checked (peaks, band peaks, sampled loop, time-domain specs,
    # |U| above a corner, violated hook bounds): one source, Certificate.ratios()
    ratios = cert.ratios()
    worst = max(ratios.values()) if ratios else 0.0
    viol = max(cert.violations, key=lambda v: v.value / max(abs(v.bound), 1e-300),
               default=None)
    gm, pm, dm = member_margins if cont else (None, None, None)
    # the peaks and margins of an unstable loop are no figures of it: none are reported
    c = (lambda q: cert.worst(q)) if cont else (lambda q: None)     # noqa: E731
    s = (lambda q: cert.worst(q, "sampled")) if samp else (lambda q: None)     # noqa: E731
    ms = c("Ms")
    return {"certified": bool(cert.certified), "stable": bool(stable),
            "worst_ratio": worst if stable else np.inf,
            **{row.column: c(row.figure) for row in spec_columns()},
            **{row.column: _worst_of_loops(cert, row.figure, cont, samp)
               for row in spec_columns(problem.specs) if not row.always_column},
            "Ms_temperature_C": worst_ms.temperature_C if cont and worst_ms else None,
            "modulus_margin": None if not ms else 1.0 / ms, "gain_margin": gm,
            "phase_margin_deg": pm, "delay_margin_s": dm,
            "spectral_abscissa": cert.worst("spectral_abscissa"),
            "Ms_sampled": s("Ms"), "Mt_sampled": s("Mt"),
            "Mu_sampled": s("Mu"), "integral_gain": integral_gain(ctrl),
            "violations": len(cert.violations),
            "violation": None if viol is None else viol.describe()}


def _worst_of_loops(cert, figure, cont, samp):
    """The worst ``figure`` over both loops (``None``: an unstable loop, or not computed)."""
    if not (cont and samp):
        return None
    vals = [v for loop in LOOPS if (v := cert.worst(figure, loop)) is not None]
    return max(vals) if vals else None


def spec_figure_columns(specs: Specs | None) -> dict[str, str]:
    """The columns of the specs that only a sweep whose problem bounds them has
    (``Msd_rel``: :func:`robrst.problem.specs.spec_columns`), with their arrow types.

    Parameters
    ----------
    specs : Specs or None
        The sweep problem's specs.

    Returns
    -------
    dict
    """
    return {row.column: "float64" for row in spec_columns(specs) if not row.always_column}


def _inf(x):
    return np.inf if x is None else float(x)


def _smallest(ms):
    """Smallest gain, phase and delay margins over the models (``inf``: none is finite)."""
    if not ms:
        return None, None, None
    return (min(_inf(m.gain_margin) for m in ms),
            min((_inf(m.phase_margin_deg) for m in ms), key=abs),   # signed, smallest |.|
            min(_inf(m.delay_margin_s) for m in ms))


def _member_margins(problem, ctrl, cert):
    """Margins of every family model's loop (``Ms`` from ``cert``'s record of the model)."""
    ms = {r.temperature_C: r.continuous.Ms for r in cert.models}
    return [loop_margins(m, ctrl, ms.get(m.temperature_C, cert.worst("Ms")))
            for m in problem.family.models]


def _mimo_analysis_row(state, values):
    ctx = state.context
    problem = problem_of(ctx, None, values)
    return mimo_figures(certify_mimo_problem(problem, ctx.controller), ctx.controller)


def _mimo_design_row(state, problem):
    result = state.designer(problem, compare=False)
    row = mimo_figures(result.certificate, result.controller)
    row["controller"] = json.dumps(result.controller.as_dict())
    if not result.certified:
        b = result.binding
        row["message"] = (f"not certified: binding {b.figure} at {b.ratio:.4g} x its"
                          f" bound on model {b.model} ({b.loop} loop)" if b else None)
    return row


def _analysis_row(state, values):
    ctx = state.context
    problem = problem_of(ctx, None, values)
    cert = certify_problem(problem, ctx.controller)
    mm = _member_margins(problem, ctx.controller, cert) if ctx.sweep.margins else ()
    return _figures(problem, ctx.controller, cert, _smallest(mm))


def _design_row(state, problem):
    with state.lock:   # a cached solver is not re-entrant: one design at a time per worker
        # no analyses (exact peaks to 1e-10): the row's figures are the certificate's.  The
        # design is robrst design's, global phase included ([solver] multistart, in this
        # process): a trade-off front of local optima understated the CLI's answers 50x
        result = state.designer(problem, templates=state.templates, analyses=False)
    row = design_row(problem, result.controller, result.certificate)
    if not result.certified:
        row["message"] = design_cause(result)
    return row


def design_row(problem: Problem, ctrl: RSTController, cert: Certificate) -> dict:
    """The figures and controller columns of a design row: ``ctrl`` with its certificate
    ``cert`` on ``problem`` (margins of every family model).

    Parameters
    ----------
    problem : Problem
        The variant's problem.
    ctrl : RSTController
        The controller.
    cert : Certificate
        Its certificate on ``problem``.

    Returns
    -------
    dict
        The row's figure columns and ``R, S, T``.
    """
    row = _figures(problem, ctrl, cert, _smallest(_member_margins(problem, ctrl, cert)))
    row.update({k: getattr(ctrl, k).tolist() for k in CONTROLLER_COLUMNS})
    return row


def design_cause(result: DesignResult) -> str | None:
    """Why a design is not certified: the synthesis's proof of infeasibility if it found
    one, else what the best controller achieves (its binding constraint).

    Parameters
    ----------
    result : DesignResult
        A design that is not certified.

    Returns
    -------
    str or None
        One line.
    """
    verdict = result.feasibility
    if verdict is not None and verdict.status == "infeasible":
        return f"infeasible: {verdict.proofs[0].reason} ({verdict.note})"
    syn = result.synthesis
    notes = getattr(syn, "notes", ())
    proof = [n for n in notes if "infeasible" in n]
    if proof:
        return proof[0]
    return getattr(syn, "best_achievable", None) or result.best_achievable


def problem_of(context: SweepContext, index: int, values: dict[str, float]) -> Problem:
    """The problem of variant ``index`` (``values``: {name: value}; a fleet's file ``index``).

    Parameters
    ----------
    context : SweepContext
        What every variant needs.
    index : int
        The variant's index.
    values : dict
        ``{parameter name: value}`` of the variant.

    Returns
    -------
    Problem

    Raises
    ------
    SpecError
        A variant the problem file's rules refuse, or an invalid fleet file.
    """
    if context.sweep.kind == "fleet":
        return fleet_problem(context, index)
    if context.mimo:
        return mimo_variant(context.base, context.doc, context.sweep.problem, values,
                            _int_keys(context.names))
    return variant_problem(context.base, context.doc, context.base.path, values,
                           context.sweep.ageing)


def _int_keys(names):
    """The key paths among ``names`` that a multi-axis problem file takes as integers."""
    return tuple(n for n in names if (f := problem_field(n, MIMO_SCHEMA)) is not None
                 and f.type == "int")


def fleet_problem(ctx: SweepContext, index: int) -> Problem:
    """The problem of fleet file ``index`` (its tables over the base problem's, if any).

    Parameters
    ----------
    ctx : SweepContext
        What every variant needs.
    index : int
        The fleet file's index.

    Returns
    -------
    Problem
        Without ``compare_with``.

    Raises
    ------
    SpecError
        The file's error, as read by the driver.
    """
    label, doc, error = ctx.fleet[index]
    if error is not None:
        raise SpecError(error)
    if ctx.doc is not None:
        doc = merge_documents(ctx.doc, doc)
    problem = parse_problem(doc, label)
    return replace(problem, solver=replace(problem.solver, compare_with=None))


def evaluate_variant(state: WorkerState, index: int, values: dict[str, float]) -> dict:
    """One row: ``values`` ({name: value}) of variant ``index`` evaluated, errors captured.

    Parameters
    ----------
    state : WorkerState
        The worker's state.
    index : int
        The variant's index.
    values : dict
        ``{parameter name: value}``.

    Returns
    -------
    dict
        The row of ``results.parquet`` (status ``ok`` or the failure's status).
    """
    ctx = state.context
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        kind = ctx.sweep.kind
        if ctx.mimo:
            row = (_mimo_analysis_row(state, values) if kind == "analysis" else
                   _mimo_design_row(state, problem_of(ctx, index, values)))
        elif kind == "analysis":
            row = _analysis_row(state, values)
        else:
            row = _design_row(state, problem_of(ctx, index, values))
        row.setdefault("message", None)
        row["status"] = "ok"
    except Exception as exc:   # noqa: BLE001 — a failing variant is a row, never a lost sweep
        row = failed_row(status_of(exc), exc)
    row.update(seconds=time.perf_counter() - t0, cpu_s=time.process_time() - c0)
    return row


def failed_row(status: str, exc: BaseException) -> dict:
    """The row of a variant that could not be evaluated (``certified`` false).

    Parameters
    ----------
    status : str
        ``invalid``, ``infeasible``, ``solver_failed``, ``error`` or ``worker_lost``.
    exc : BaseException
        Its message is the row's.

    Returns
    -------
    dict
    """
    msg = str(exc) if isinstance(exc, RobrstError) else f"{type(exc).__name__}: {exc}"
    return {"status": status, "message": msg, "certified": False, "stable": None,
            "worst_ratio": np.inf}


def evaluate_chunk(state: WorkerState, indices: np.ndarray, values: np.ndarray) -> list[dict]:
    """Rows of the variants ``indices`` (``values``: one row of parameter values each).

    Parameters
    ----------
    state : WorkerState
        The worker's state.
    indices : numpy.ndarray
        The variants' indices.
    values : numpy.ndarray
        One row of parameter values per variant.

    Returns
    -------
    list of dict
        One row per variant, in order, with its ``index``.
    """
    names = state.context.names
    rows = []
    # one BLAS thread: the matrices are small, extra threads only spin (measured: same
    # wall time, twice the CPU) and take the core another worker needs.  A variant far
    # outside the usual (poles at 1e-90 rad/s) overflows or divides by zero on the way to
    # its row (a failed or uncertified one); numpy's RuntimeWarnings about it are not the
    # user's business and would leak into the output of `robrst sweep --json`
    with one_blas_thread(), np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for i, vals in zip(indices, values):
            row = evaluate_variant(state, int(i), dict(zip(names, (float(v) for v in vals))))
            row["index"] = int(i)
            rows.append(row)
    return rows
