"""What the synthesis returns: solves (status, point, objective, multipliers, binding
constraints), certification rounds, and the synthesised controller with its certificate."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core.sampled import unwarp
from robrst.synthesis.parametrize import integral_gain

if TYPE_CHECKING:
    from robrst.certificate.models import Violation
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController

__all__ = ["OK_STATUS", "LIMIT_FEASIBLE", "FEASIBLE_TOL", "Binding", "SolveResult", "Round",
           "SynthesisResult", "worst_violation", "best_achievable"]

# IPOPT's iteration limit on a point that meets every row of its program (within
# FEASIBLE_TOL): a polish still climbing when its budget ends keeps what it reached (the
# certificate judges it as any other point), where that point was discarded before
LIMIT_FEASIBLE = "Feasible_At_Iteration_Limit"
FEASIBLE_TOL = 1e-8
NEAR_BOUND = 1e-3      # ... and its binding rows are those within this (relative) of a bound
OK_STATUS = ("Solve_Succeeded", "Solved_To_Acceptable_Level", LIMIT_FEASIBLE)


@dataclass(frozen=True)
class Binding:
    """A constraint of the NLP named for the user: kind, model, temperature, frequency.

    Parameters
    ----------
    kind : str
        ``"S"``, ``"T"``, ``"U"``, ``"Tband"``, ``"Uhf"``, ``"Sd"``, ``"Ry"`` (a peak bound
        on the grid), ``"routh"`` (stability, or decay with a pole region), ``"sector"``
        (a root at a damping floor), ``"controller_sector"``, ``"time"`` (a
        reference-step sample), ``"positivity"``, ``"gamma"`` or ``"controller_routh"``.
    model : str
        The model's label.
    temperature_C : float
        Its temperature [°C].
    freq_rad_s : float
        The physical frequency [rad/s] (``None`` where none applies).
    multiplier : float
        IPOPT's ``lam_g`` (scaled by the constraint's size).
    violation : float
        How far the constraint is from holding.
    time_s : float, optional
        A reference-step sample's time [s].
    """

    kind: str
    model: str
    temperature_C: float
    freq_rad_s: float
    multiplier: float
    violation: float
    time_s: float = None     # a reference-step sample's time

    def describe(self) -> str:
        """One line, e.g. ``"|S| peak, model T45C (45 °C) at 612 Hz"``.

        Returns
        -------
        str
        """
        what = {"S": "|S| peak", "T": "|T| peak", "U": "|U| peak", "Tband": "|T| in the band",
                "Uhf": "|U| above the high-frequency corner",
                "Sd": "|B S/Delta| peak (input disturbance)",
                "Ry": "|B T/Delta| peak (reference to output)",
                "routh": "closed-loop stability or decay (Routh)",
                "sector": "closed-loop damping floor (a root at the floor)",
                "controller_sector": "controller pole damping floor",
                "time": "reference step (time samples)",
                "controller_routh": "controller poles (stability / integral-gain shift)",
                "positivity": "sign of the integral gain"}.get(self.kind, self.kind)
        who = "" if self.model is None else f" of model {self.model} ({self.temperature_C:g} °C)"
        at = "" if self.freq_rad_s is None else f" at {self.freq_rad_s / (2 * np.pi):.4g} Hz"
        if self.time_s is not None:
            at = f" at t = {self.time_s * 1e3:.4g} ms"
        return f"{what}{who}{at}"


@dataclass(frozen=True, eq=False)
class SolveResult:
    """One IPOPT solve: status, point, objective, iterations, constraints and multipliers.

    Parameters
    ----------
    status : str
        IPOPT's return status, or :data:`LIMIT_FEASIBLE`: the iteration limit on a point
        that meets every row (a success: its point is used and certified, its multipliers
        are not those of an optimum).
    x : numpy.ndarray
        The point.
    objective : float
        The objective there.
    iterations : int
        IPOPT iterations.
    g, lbg, ubg : numpy.ndarray
        Constraint values and bounds.
    lam_g : numpy.ndarray
        IPOPT's multipliers.
    labels : tuple
        ``labels[i]`` is ``(kind, model label, temperature, scaled frequency or index)``
        of constraint ``g[i]``.
    w0 : float
        The frequency scale [rad/s].
    exchange : ExchangeInfo, optional
        How the constraint exchange went, when solved by it.
    rates : dict, optional
        Model label -> sample rate [Hz] of sampled-loop models.
    lam_x : numpy.ndarray, optional
        IPOPT's multipliers of the variable bounds (CasADi's sign convention: the
        Lagrangian is ``f + lam_g' g + lam_x' x``).
    lbx, ubx : numpy.ndarray, optional
        The variable bounds of the solve.
    params : dict, optional
        The program's parameter blocks (:meth:`robrst.synthesis.template.Template.pack`'s
        input): with ``x``, ``lam_g`` and ``lam_x`` they let the optimality (KKT) conditions
        be checked independently of CasADi and IPOPT.

    Attributes
    ----------
    success : bool
        IPOPT reports success.
    """

    status: str
    x: np.ndarray
    objective: float
    iterations: int
    g: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    lam_g: np.ndarray
    labels: tuple
    w0: float
    exchange: ExchangeInfo | None = None   # noqa: F821  (exchange imports this module)
    rates: dict = None       # model label -> sample rate [Hz] of sampled-loop models
    lam_x: np.ndarray = None
    lbx: np.ndarray = None
    ubx: np.ndarray = None
    params: dict = None      # the program's parameter blocks (Template.pack's input)

    @property
    def success(self):
        return self.status in OK_STATUS

    def violations(self) -> np.ndarray:
        """How far each constraint is from holding (0 where it holds).

        Returns
        -------
        numpy.ndarray
        """
        return np.maximum(np.maximum(self.lbg - self.g, self.g - self.ubg), 0.0)

    def _binding_at(self, i, v):
        kind, label, T, where = self.labels[i]
        if kind == "time":       # a reference-step sample at scaled time ``where``
            return Binding(kind=kind, model=label, temperature_C=T, freq_rad_s=None,
                           multiplier=float(self.lam_g[i]), violation=float(v[i]),
                           time_s=float(where) / self.w0)
        freq = float(where) * self.w0 if isinstance(where, float) else None
        fs = (self.rates or {}).get(label)
        if freq is not None and fs:      # the loop variable of a sampled model -> physical
            freq = float(unwarp(freq, fs))
        return Binding(kind=kind, model=label, temperature_C=T, freq_rad_s=freq,
                       multiplier=float(self.lam_g[i]), violation=float(v[i]))

    def binding(self, count: int = 3) -> tuple[Binding, ...]:
        """The inequality constraints that bind, strongest first (by ``|multiplier|``).

        The Diophantine equality is structural and never named, nor a polish's objective
        floor (a row of the program, not a spec); multipliers below 1e-4
        of the largest are an interior point's inactive constraints, not binding ones.
        When IPOPT ended on an infeasible point, the violated constraints come first.

        Parameters
        ----------
        count : int
            At most this many.

        Returns
        -------
        tuple of Binding
        """
        v = self.violations()
        ineq = np.array([lab[0] not in ("diophantine", "unused", "objective_floor")
                         for lab in self.labels], bool)
        order = []
        bad = np.flatnonzero(ineq & (v > 1e-6))
        order += list(bad[np.argsort(-v[bad])])
        lam = np.abs(self.lam_g)
        big = lam.max(initial=0.0, where=ineq) * 1e-4   # an interior point's inactive rows
        act = np.flatnonzero(ineq & (lam > big))         # carry mu / slack, not zero
        if self.status == LIMIT_FEASIBLE:   # no optimum: only the rows the point sits on
            with np.errstate(invalid="ignore"):
                slack = np.minimum(self.g - self.lbg, self.ubg - self.g)
            act = act[slack[act] <= NEAR_BOUND * np.maximum(1.0, np.abs(self.g[act]))]
        order += [i for i in act[np.argsort(-lam[act])] if i not in order]
        out, seen = [], set()
        for i in order:
            b = self._binding_at(i, v)
            key = (b.kind, b.model)
            if key not in seen:
                seen.add(key)
                out.append(b)
            if len(out) == count:
                break
        return tuple(out)


@dataclass(frozen=True)
class Round:
    """One certification round: the NLP's outcome and what the certificate found.

    Parameters
    ----------
    round : int
        The round's number.
    status : str
        IPOPT's status.
    iterations : int
        IPOPT iterations.
    models : int
        Models in the program.
    frequencies : int
        Grid frequencies per model.
    violations : int
        Violations the certificate found.
    exchange_rounds : int, optional
        Constraint-exchange rounds.
    active_points : int, optional
        Grid points imposed at the end.
    grid_points : int, optional
        Grid points in all.
    phase : {"soft", "hard"}
        The worst normalised spec ratio minimised, or the objective optimised.
    placement : {"fixed", "dominant", "free"}, optional
        The nominal pole placement.
    start : str, optional
        The start point's name.
    gamma : float, optional
        Soft phase: the worst normalised spec ratio reached on the grid.
    stability_models : int, optional
        Models whose closed-loop stability rows were imposed.
    """

    round: int
    status: str
    iterations: int
    models: int
    frequencies: int
    violations: int
    exchange_rounds: int = None
    active_points: int = None
    grid_points: int = None
    phase: str = "hard"        # "soft" (worst normalised spec ratio) or "hard" (objective)
    placement: str = None      # "fixed", "dominant" or "free"
    start: str = None          # the start point's name
    gamma: float = None        # soft phase: worst normalised spec ratio reached on the grid
    stability_models: int = None   # models whose closed-loop stability rows were imposed

    def as_dict(self) -> dict:
        """The ``rounds`` entry of the design JSON (``None`` fields left out).

        Returns
        -------
        dict
        """
        d = {k: getattr(self, k) for k in ("round", "status", "iterations", "models",
                                           "frequencies", "violations", "phase", "placement",
                                           "start", "gamma")}
        if self.exchange_rounds is not None:
            d.update(exchange_rounds=self.exchange_rounds, active_points=self.active_points,
                     grid_points=self.grid_points, stability_models=self.stability_models)
        return d


@dataclass(frozen=True, eq=False)
class SynthesisResult:
    """A synthesised controller with its certificate and how the solver got there.

    Parameters
    ----------
    controller : RSTController
        The controller.
    Am : numpy.ndarray
        Its nominal characteristic polynomial.
    certificate : Certificate
        Its certificate.
    status : {"certified", "not_certified"}
        ``"not_certified"``: the best controller found, certified for what it achieves
        (``best_achievable`` says how far from the specs).
    objective : str
        The objective optimised.
    w0 : float
        The frequency scale [rad/s].
    rounds : tuple of Round
        The certification rounds.
    solve : SolveResult, optional
        The solve the controller came from (its ``binding()`` names the limiting
        constraints).
    wall_time_s : float, optional
        Wall time [s].
    wn_rad_s, zeta : float, optional
        The dominant pair reached.
    name : str
        The solver's name.
    grid_peak_S : float, optional
        The worst ``|S|`` on the grid.
    placement : str, optional
        The nominal pole placement it was solved with.
    phase : {"hard", "soft", "start"}
        The objective's optimum, the soft-goal point (the specs' worst normalised ratio
        minimised) or a start that met the specs.
    best_achievable : str, optional
        One line on what an uncertified controller achieves.
    notes : tuple of str
        What the pipeline had to do (fallbacks, relaxations).
    search : GlobalSearch, optional
        The global phase's record (:mod:`robrst.synthesis.search`).
    tried : tuple
        What the global phase tried: ``(name, status, objective, integral gain, worst
        ratio, placement, note)`` per candidate (as screened, polished) and the problem's
        own placement (``note``: why a certified one has no objective, or ``None``).

    Attributes
    ----------
    integral_gain : float
        ``lim s R/S`` of the controller [V/(µm s)].
    certified : bool
        The certificate holds.
    """

    controller: RSTController
    Am: np.ndarray
    certificate: Certificate
    status: str
    objective: str
    w0: float
    rounds: tuple = ()
    solve: SolveResult | None = None
    wall_time_s: float = None
    wn_rad_s: float = None
    zeta: float = None
    name: str = "ipopt"
    grid_peak_S: float = None
    placement: str = None
    phase: str = "hard"
    best_achievable: str = None
    notes: tuple = ()
    search: GlobalSearch | None = None   # noqa: F821  (search imports this module)
    tried: tuple = ()

    @property
    def integral_gain(self):
        """``lim s R/S`` of the controller [V/(µm s)]."""
        return integral_gain(self.controller)

    @property
    def certified(self):
        """True when the certificate holds."""
        return self.status == "certified"

    def solver_dict(self) -> dict:
        """The ``solver`` object of the design JSON (fields are only added).

        Returns
        -------
        dict
        """
        if self.name != "ipopt":
            return {"name": self.name, "status": self.status, "w0_rad_s": self.w0,
                    "grid_peak_S": self.grid_peak_S,
                    "integral_gain": integral_gain(self.controller)}
        d = {"name": "ipopt", "w0_rad_s": self.w0,
             "status": None if self.solve is None else self.solve.status,
             "rounds": [r.as_dict() for r in self.rounds],
             "iterations": sum(r.iterations for r in self.rounds), "objective": self.objective,
             "integral_gain": integral_gain(self.controller), "wall_time_s": self.wall_time_s,
             "binding": [] if self.solve is None else [b.describe() for b in self.solve.binding()],
             "placement": self.placement, "phase": self.phase, "synthesis_status": self.status,
             "best_achievable": self.best_achievable, "notes": list(self.notes)}
        if self.wn_rad_s is not None:
            d["wn_rad_s"], d["zeta"] = self.wn_rad_s, self.zeta
        if self.search is not None:
            d["global_search"] = self.search.as_dict()
        return d


def worst_violation(cert: Certificate) -> Violation | None:
    """The certificate's violation with the largest ratio to its bound (``None``: none).

    Parameters
    ----------
    cert : Certificate
        A certificate.

    Returns
    -------
    Violation or None
    """
    if not cert.violations:
        return None
    return max(cert.violations, key=lambda v: v.ratio)


def best_achievable(cert: Certificate) -> str | None:
    """One line on what an uncertified controller achieves (``None`` when certified).

    Parameters
    ----------
    cert : Certificate
        A certificate.

    Returns
    -------
    str or None
        ``"best achievable: model T45C (45 °C): |S| peak = 2.31 > 2 at 612 Hz"``.
    """
    v = worst_violation(cert)
    if v is None:
        return None
    if v.quantity == "spectral_abscissa":
        loop = " in the sampled loop" if v.loop == "sampled" else ""
        return (f"best achievable: unstable{loop} on model {v.label} ({v.temperature_C:g} °C),"
                f" spectral abscissa {v.value:.4g} rad/s"
                + (" (of the loop in the bilinear variable)" if loop else ""))
    return "best achievable: " + v.describe()
