"""What any linear controller could reach on the family: the estimate of the objective.

For a stable loop plant ``D`` every stabilising controller is ``K = Q / (1 - D Q)`` with
``Q`` stable (Youla–Kučera), and the closed loop is affine in ``Q``: ``T = D Q``,
``S = 1 - D Q``, ``U = Q``, ``D S``.  Every frequency-domain spec robrst imposes is a pair
of discs for ``T(jw)`` (:mod:`robrst.synthesis.discs`), integral action is ``T(0) = 1`` and
the integral gain is ``ki = lim s K = 1 / (D(0) S'(0))``, the reciprocal of a linear
function of ``Q``.  A controller that meets the specs on every model meets them on each
model and each loop (continuous and sampled), so what one model's loop allows bounds the
family, and the tightest model is the estimate.

Two facts settle most problems without a program (docs: "Synthesis background"):

* **Room at 0 Hz.**  When ``T(0) = 1`` lies strictly inside the ``|T|`` disc at 0 Hz on
  every loop (``Mt_max > 1`` and ``Mu_max |D(0)| > 1``), any controller that meets the
  specs with some margin still meets them after a slow lag ``(s + a)/(s + b)`` (``a`` far
  below its bandwidth), which multiplies its integral gain by ``a/b``: the integral gain
  has no finite supremum.  The same slack lets a slow enough integral action bring the
  worst ``|S|`` as close to 1 as wanted: ``min_Ms`` has the infimum 1 unless
  ``Msd_max`` forces the loop to act at a resonance.
* **No room** (``r_T(0) < 1``): integral action itself is impossible
  (:mod:`robrst.synthesis.feasibility` states it as a proof).

Otherwise (``T(0)`` pinned on the disc's edge; ``Msd_max`` below the plant's peak; the
``feasibility`` objective) each loop gets a second-order-cone program, ``Q`` a combination
of stable basis functions (:class:`YoulaBasis`) and the discs imposed on a frequency grid
(by constraint exchange):

* ``max_integral_gain``: minimise ``S'(0)`` (``S'(0) <= 0`` reachable: unbounded);
* ``min_Ms``: minimise ``gamma`` with ``|S| <= gamma`` on the grid;
* ``feasibility``: whether a ``Q`` of the basis meets the discs on the grid.

What the estimate is and is not: the grid relaxes a program (the specs hold only at the
grid points: the value moves in the estimate's safe direction), the finite basis
restricts it (the value moves the other way: the true optimum may lie beyond).  When a
certified design is given, its own ``Q`` (its complementary sensitivity on each loop)
joins the basis, so the estimate is never on the wrong side of that design.  Specs the
discs cannot express (pole region, reference path, time-domain specs, a stable
controller) and the controller's order are left out: they can only make the true optimum
worse.  Unstable loop plants (an integrator, an unstable mode) get no estimate.

The programs are solved by Clarabel (an interior-point conic solver; cvxpy's default for
these cones) called directly: importing and canonicalising through cvxpy would cost more
than the programs themselves.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core.peaks import peak_gain
from robrst.core.rst import closed_loop
from robrst.synthesis.discs import (LoopPlant, expressed_specs, integrators_of, loop_grid,
                                    loop_plants, spec_discs)

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem, Specs

__all__ = ["YoulaBasis", "LoopBound", "ObjectiveBound", "LagWitness", "youla_bound",
           "objective_bound", "lag_witness", "dc_room", "DEFAULT_BASIS", "GRID_PER_DECADE", "MIN_WIDEN",
           "PINNED"]

GRID_PER_DECADE = 30       # grid frequencies per decade over the basis range
GRID_BELOW = 1e3           # the grid reaches this factor below the slowest basis pole ...
GRID_ABOVE = 10.0          # ... and this factor above the fastest (a few points there)
MIN_WIDEN = 1e-6           # every bound widened at least this much: the programs keep an
#                            interior (T(0) = 1 on the edge of a disc leaves none)
PINNED = 1e-6              # r_T(0) within this of 1: T(0) = 1 is on the disc's edge
EXCHANGE_TOL = 1e-7        # a grid point violated by more than this (relative) joins
EXCHANGE_ROUNDS = 12
SV_CUT = 1e-9              # directions the grid rows see less than this (relative) are dropped
# Clarabel's settings tried in turn when a solve stalls numerically (its own row
# equilibration on top of the orthonormal basis, then the other direct solver: on a
# degenerate program, T(0) = 1 on the edge of the |T| disc, one stalled where the other did not)
CLARABEL_RETRIES = ({}, {"equilibrate_enable": False}, {"direct_solve_method": "faer"})


@dataclass(frozen=True)
class YoulaBasis:
    """The stable functions ``Q`` is a combination of (in the loop variable ``s``).

    The constant 1; a real pole ``a / (s + a)`` at ``per_decade`` frequencies per decade
    over the loop's range; with ``pair_damping`` also a damped pair
    ``(w^2, w s) / (s^2 + 2 zeta w s + w^2)`` at each of them; in a sampled loop the
    delays ``z^-k = ((1 - s/(2 fs)) / (1 + s/(2 fs)))^k``, ``k = 1 .. fir_taps``.

    Parameters
    ----------
    per_decade : float
        Pole frequencies per decade.
    pair_damping : float, optional
        Damping of the pairs (``None``: real poles only).
    fir_taps : int
        Delays of the sampled loop.
    span : float
        The range reaches this factor beyond the plant's slowest and fastest root (and
        beyond the frequency up to which the ``|T|`` disc still allows 1 %).
    """

    per_decade: float = 12.0
    pair_damping: float = None
    fir_taps: int = 2
    span: float = 30.0

    def functions(self, lp: LoopPlant, specs: Specs,
                  region: tuple | None = None) -> tuple[tuple[str, float], ...]:
        """The basis of ``lp``'s program as ``(kind, parameter)`` pairs, in order:
        ``("constant", 1)``, ``("real", a)`` for ``a / (s + a)``, ``("pair_w2", w)`` and
        ``("pair_ws", w)`` for ``(w^2, w s) / (s^2 + 2 zeta w s + w^2)``, ``("delay", k)`` for
        ``((1 - s/(2 fs)) / (1 + s/(2 fs)))^k`` (``s`` the loop variable).

        Parameters
        ----------
        lp : LoopPlant
            The loop.
        specs : Specs
            The bounds (the range reaches where the ``|T|`` disc allows 1 %).
        region : (float or None, float or None), optional
            A pole region (its decay rate raises the slowest pole).

        Returns
        -------
        tuple of (str, float)
        """
        lo, hi = _span(lp, specs, self, region)
        out = [("constant", 1.0)]
        n = max(2, int(np.ceil(self.per_decade * np.log10(hi / lo))) + 1)
        for a in np.geomspace(lo, hi, n):
            out.append(("real", float(a)))
            if self.pair_damping:
                out += [("pair_w2", float(a)), ("pair_ws", float(a))]
        if lp.fs is not None:
            out += [("delay", float(k)) for k in range(1, self.fir_taps + 1)]
        return tuple(out)

    def describe(self, size: int, design: bool) -> str:
        """One phrase, e.g. ``"55 functions: real poles 12/decade, 2 delays (sampled loop)"``.

        Parameters
        ----------
        size : int
            The number of functions of one loop's basis.
        design : bool
            The design's own ``Q`` is in it.

        Returns
        -------
        str
        """
        out = f"{size} functions: real poles {self.per_decade:g}/decade"
        if self.pair_damping:
            out += f" and pairs damped {self.pair_damping:g}"
        if self.fir_taps:
            out += f", {self.fir_taps} delays (sampled loop)"
        if design:
            out += ", the design's own Q"
        return out


DEFAULT_BASIS = YoulaBasis()


@dataclass(frozen=True)
class LoopBound:
    """The program (or the fact) of one model's loop.

    Parameters
    ----------
    model : str
        The model's label.
    temperature_C : float
        Its temperature [°C].
    loop : {"continuous", "sampled"}
        Which loop.
    status : str
        ``"bounded"`` (a finite value), ``"unbounded"`` (``S'(0) <= 0`` reachable),
        ``"infeasible_on_grid"`` (no ``Q`` of the basis meets the discs on the grid: not a
        proof), ``"feasible_on_grid"`` (objective ``feasibility``), ``"no_estimate"``
        (an unstable loop plant), ``"not_applicable"`` or ``"failed"`` (the solver did not
        converge).
    value : float, optional
        ``|ki|`` [V/(µm s)] (``max_integral_gain``) or the least worst ``Ms``
        (``min_Ms``).
    grid_points : int
        Frequencies of the grid.
    basis_size : int
        Functions in the basis.
    solver_status : str
        Clarabel's status (or how the value was found).
    rounds : int
        Constraint-exchange rounds.
    q : tuple of float
        The combination found (``feasible_on_grid`` and ``bounded``), in the order of
        :meth:`YoulaBasis.functions` (the design's own ``Q`` last when it joined).
    """

    model: str
    temperature_C: float
    loop: str
    status: str
    value: float = None
    grid_points: int = 0
    basis_size: int = 0
    solver_status: str = ""
    rounds: int = 0
    q: tuple = ()

    def as_dict(self) -> dict:
        """The ``per_loop`` entry of the JSON.

        Returns
        -------
        dict
        """
        return {"model": self.model, "temperature_C": self.temperature_C, "loop": self.loop,
                "status": self.status, "value": self.value, "grid_points": self.grid_points,
                "basis_size": self.basis_size, "solver_status": self.solver_status}


@dataclass(frozen=True)
class ObjectiveBound:
    """What any linear controller could reach on the family, and this design's share of it.

    Parameters
    ----------
    objective : {"max_integral_gain", "min_Ms", "feasibility"}
        The problem's objective.
    status : str
        ``"bounded"`` (a finite estimate in ``value``), ``"unbounded"`` (no finite
        supremum: ``reason`` says why), ``"infeasible"`` (integral action cannot meet the
        ``|T|`` disc at 0 Hz: proved), ``"infeasible_on_grid"`` / ``"feasible_on_grid"``
        (the programs' verdict; not a proof), ``"no_estimate"`` (no stable loop plant) or
        ``"not_applicable"`` (no single integrator to maximise the gain of).
    value : float, optional
        ``max_integral_gain``: the estimated supremum of ``|ki|`` [V/(µm s)] over linear
        controllers meeting the expressed specs on the family; ``min_Ms``: the estimated
        infimum of their worst ``Ms``.
    exact : bool
        ``value`` is a fact, not a program's estimate (the ``min_Ms`` infimum 1).
    reason : str
        Why this status, in words (the room at 0 Hz, the model that pins ``T(0)``, ...).
    model, temperature_C, loop : optional
        The loop whose program gave ``value``.
    grid_points : int
        Frequencies per loop (the most of any program; 0 when no program ran).
    basis : str
        The basis, in words (empty when no program ran).
    specs : tuple of str
        The spec keys the estimate imposes.
    left_out : tuple of str
        Given specs it cannot express.
    design_value : float, optional
        The certified design's ``|ki|`` or worst ``Ms``.
    fraction : float, optional
        ``max_integral_gain``: ``design_value / value``; ``min_Ms``: ``value /
        design_value`` (1: the design reaches the estimate).
    includes_design : bool
        The design's own ``Q`` is in the programs' basis.
    per_loop : tuple of LoopBound
        The programs run.
    wall_time_s : float
        Time spent [s].
    note : str
        What the estimate is and is not.
    """

    objective: str
    status: str
    value: float = None
    exact: bool = False
    reason: str = ""
    model: str = None
    temperature_C: float = None
    loop: str = None
    grid_points: int = 0
    basis: str = ""
    specs: tuple = ()
    left_out: tuple = ()
    design_value: float = None
    fraction: float = None
    includes_design: bool = False
    per_loop: tuple = field(default=())
    wall_time_s: float = 0.0
    note: str = ""

    def as_dict(self) -> dict:
        """The ``objective_bound`` object of the design JSON.

        Returns
        -------
        dict
        """
        return {"objective": self.objective, "status": self.status, "value": self.value,
                "exact": self.exact, "reason": self.reason, "model": self.model,
                "temperature_C": self.temperature_C, "loop": self.loop,
                "grid_points": self.grid_points, "basis": self.basis,
                "specs": list(self.specs), "left_out": list(self.left_out),
                "design_value": self.design_value, "fraction": self.fraction,
                "includes_design": self.includes_design,
                "per_loop": [b.as_dict() for b in self.per_loop],
                "wall_time_s": self.wall_time_s, "note": self.note, "line": self.describe()}

    def describe(self) -> str:
        """One line for the text summary.

        Returns
        -------
        str
        """
        specs = ", ".join(self.specs) or "no spec"
        how = ""
        if self.model is not None:
            how = (f" (model {self.model}, {self.temperature_C:g} °C, {self.loop} loop; grid"
                   f" {self.grid_points} points, basis {self.basis})")
        if self.status == "bounded" and self.objective == "max_integral_gain":
            out = (f"bound: any linear controller meeting {specs} has |integral gain| <="
                   f" {self.value:.4g} V/(µm s) on this family{how}")
            if self.fraction is not None:
                out += f"; this design reaches {100 * self.fraction:.1f} %"
            return out
        if self.status == "bounded" and self.objective == "min_Ms":
            rel = "has" if not self.exact else "can reach"
            out = (f"bound: any linear controller meeting {specs} {rel} a worst Ms"
                   f" {'>=' if not self.exact else 'as close to'} {self.value:.4g}"
                   f" on this family{how}")
            if self.exact:
                out += f" as wanted ({self.reason})"
            if self.design_value is not None and self.value:
                out += (f"; this design's {self.design_value:.4g} is"
                        f" {100 * (self.design_value / self.value - 1):.1f} % above")
            speed = {"settling_time_max_s", "decay_min"} & set(self.left_out)
            if self.exact and not speed:   # the infimum 1: the specs reward a slow loop
                out += ("; these specs ask nothing of the loop's speed, so min_Ms rewards a"
                        " loop that barely acts: settling_time_max_s, decay_min or an Msd_max"
                        " below the plant's peak ask for it")
            return out
        if self.status == "unbounded":
            out = f"bound: no finite estimate of the integral gain: {self.reason}"
            if self.left_out and self.design_value is None:
                out += f" (for the specs it expresses; left out: {', '.join(self.left_out)})"
            if self.design_value is not None:
                out += (f"; this design's {self.design_value:.4g} V/(µm s) is set by its"
                        " structure (its order; the robust program keeps the controller's"
                        " poles off the origin, which excludes such a lag)"
                        + (f" and by the specs the estimate leaves out"
                           f" ({', '.join(self.left_out)})" if self.left_out else ""))
            return out
        if self.status == "infeasible":
            return f"bound: none: {self.reason}"
        if self.status == "infeasible_on_grid":
            return (f"bound: no Q of the basis meets {specs} on the grid{how} (evidence, not a"
                    " proof of infeasibility)")
        if self.status == "feasible_on_grid":
            return (f"bound: on every model a Q of the basis meets {specs} on the grid (not a"
                    " proof that one controller of this order meets them on the family)")
        return f"bound: {self.reason}"


def dc_room(lp: LoopPlant, specs: Specs, rtol: float = 0.0) -> float:
    """The radius of the ``|T|`` disc at 0 Hz: integral action (``T(0) = 1``) needs ``>= 1``.

    Parameters
    ----------
    lp : LoopPlant
        The loop.
    specs : Specs
        The bounds.
    rtol : float
        Widening of the bounds.

    Returns
    -------
    float
        ``min(Mt_max, Mu_max |D(0)|, ...)`` of the specs that apply at 0 Hz (``inf``: none).
    """
    return float(spec_discs(lp, [0.0], specs, rtol).r_T[0])


def _range(lp, specs, basis):
    """The loop variable's range ``(lo, hi)`` [rad/s] the basis covers."""
    m = lp.plant
    r = np.abs(np.concatenate([m.poles(), m.zeros()]))
    r = r[(r > 0) & np.isfinite(r)]
    if lp.fs is not None:      # the sampled loop's delay poles sit at 2 fs: not a scale
        r = r[r < 1.9 * lp.fs]
    rmin, rmax = (r.min(), r.max()) if len(r) else (1.0, 1.0)
    # where the |T| disc still allows 1 % (|U| bound times |D|): the controller's reach
    probe = np.geomspace(rmax, rmax * 1e4, 41)
    if lp.fs is not None:
        probe = probe[probe < lp.nyquist_rad_s]
    reach = rmax
    if len(probe):
        ok = probe[spec_discs(lp, probe, specs).r_T >= 0.01]
        if len(ok):
            reach = max(reach, ok.max())
    hi = reach * basis.span
    if lp.fs is not None:
        hi = min(hi, 4.0 * lp.fs)    # beyond, a pole of the loop variable is a constant
    return rmin / basis.span, hi


def _span(lp, specs, basis, region=None):
    """The basis's pole range ``(lo, hi)`` (a decay rate raises ``lo``)."""
    lo, hi = _range(lp, specs, basis)
    if region is not None and region[1]:
        lo = max(lo, 1.01 * region[1])         # the basis's real poles decay fast enough
        hi = max(hi, 10 * lo)
    return lo, hi


def _grid(lp, specs, lo, hi, per_decade):
    """Physical grid [rad/s]: ``per_decade`` per decade over the basis range, a few points
    beyond it, dense points at lightly damped poles, band edges; a sampled loop also a
    linear stretch up to Nyquist."""
    w_lo, w_hi = lo, (hi if lp.fs is None else lp.nyquist_rad_s)
    edges = []
    if specs.T_resonance_max is not None:
        edges += [2 * np.pi * f for f in specs.resonance_band_hz]
    if specs.Mu_hf_max is not None:
        edges.append(2 * np.pi * specs.Mu_hf_above_hz)
    tail = max(4, int(per_decade / 2))          # points per decade beyond the range
    edges += list(np.geomspace(lo / GRID_BELOW, lo, int(tail * np.log10(GRID_BELOW)) + 1))
    if lp.fs is None:
        edges += list(np.geomspace(hi, hi * GRID_ABOVE, int(tail * np.log10(GRID_ABOVE)) + 1))
    else:
        edges += list(np.linspace(0.5, 1.0, 40) * lp.nyquist_rad_s)
    n = max(2, int(np.ceil(per_decade * np.log10(max(w_hi / w_lo, 10.0)))))
    return loop_grid(lp, n, w_lo, w_hi, edges)


def _evaluate(funcs, p, fs, zeta):
    """The basis functions ``funcs`` (:meth:`YoulaBasis.functions`; pairs damped ``zeta``)
    and their derivatives at points ``p`` of the loop variable (complex; ``inf`` is the
    limit): two arrays ``(len(p), len(funcs))``, the derivative ``nan`` at ``inf``."""
    p = np.atleast_1d(np.asarray(p, complex))
    fin = np.isfinite(p)
    s = np.where(fin, p, 0.0)
    vals, ders = [], []
    for kind, a in funcs:
        if kind == "constant":
            v, d, v_inf = np.ones(len(s), complex), np.zeros(len(s), complex), 1.0
        elif kind == "real":
            v, d, v_inf = a / (s + a), -a / (s + a) ** 2, 0.0
        elif kind in ("pair_w2", "pair_ws"):
            z = zeta
            den = s * s + 2 * z * a * s + a * a
            dden = 2 * s + 2 * z * a
            num, dnum = (a * a, 0.0) if kind == "pair_w2" else (a * s, a)
            v, d, v_inf = num / den, dnum / den - num * dden / den ** 2, 0.0
        else:                                    # a delay z^-k of the sampled loop
            k = int(a)
            q = s / (2 * fs)
            g = (1 - q) / (1 + q)
            v, d, v_inf = g ** k, k * g ** (k - 1) * (-1.0 / (fs * (1 + q) ** 2)), (-1.0) ** k
        v, d = np.asarray(v, complex), np.asarray(d, complex)
        v[~fin], d[~fin] = v_inf, np.nan
        vals.append(v)
        ders.append(d)
    return np.array(vals).T, np.array(ders).T


def _interpolation(lp, funcs, zeta, region, ncols):
    """Rows ``(M, rhs)`` of ``Q(p) = 0, Q'(p) = 1/res`` at every plant pole outside the
    region (real and imaginary parts); ``None`` for a repeated one (not handled)."""
    from robrst.core.region import damping_of, s_poles

    floor, decay = region
    P = lp.plant.poles()
    ps = s_poles(P, lp.fs)
    bad = np.zeros(len(P), bool)
    if floor:
        bad |= damping_of(ps) < floor
    if decay:
        bad |= -ps.real < decay
    bad &= P.imag >= 0                       # one of each conjugate pair
    rows, rhs = [], []
    dA = np.polyder(lp.plant.A)
    for p in P[bad]:
        if np.min(np.abs(np.delete(P, np.argmin(np.abs(P - p))) - p)) < 1e-9 * max(abs(p), 1):
            return None
        res = np.polyval(lp.plant.B, p) / np.polyval(dA, p)
        val, der = _evaluate(funcs, p, lp.fs, zeta)
        v, d = np.zeros(ncols, complex), np.zeros(ncols, complex)
        v[:val.shape[1]], d[:der.shape[1]] = val[0], der[0]
        for row, t in ((v, 0.0), (d, 1.0 / res)):
            rows.append(row.real)
            rhs.append(complex(t).real)
            if p.imag > 0:
                rows.append(row.imag)
                rhs.append(complex(t).imag)
    return np.array(rows).reshape(-1, ncols), np.array(rhs)


def _design_column(lp, ctrl, nu):
    """The design's own ``T`` on ``lp`` at ``j nu``, ``T(0)`` and ``T'(0)``; ``None`` when its
    loop is not stable (its ``Q`` is then no Youla parameter)."""
    cl = closed_loop(lp.plant, ctrl)
    Delta, N = poly.trim(cl.Delta), poly.trim(cl.nums["T"])
    if len(Delta) < 2 or np.max(np.roots(Delta).real) >= 0:
        return None
    fin = np.isfinite(nu)
    col = np.empty(len(nu), complex)
    col[fin] = poly.eval_jw(N, nu[fin]) / poly.eval_jw(Delta, nu[fin])
    col[~fin] = N[0] / Delta[0] if len(N) == len(Delta) else 0.0
    d0, d1 = Delta[-1], Delta[-2]
    n0, n1 = N[-1], (N[-2] if len(N) > 1 else 0.0)
    return col, float(n0 / d0), float((n1 * d0 - n0 * d1) / (d0 * d0))


def youla_bound(lp: LoopPlant, specs: Specs, objective: str = "max_integral_gain",
                integrators: int = 1, grid_per_decade: float = GRID_PER_DECADE,
                basis: YoulaBasis = DEFAULT_BASIS, controller: RSTController | None = None,
                rtol: float = 0.0, exchange: bool = False,
                region: tuple | None = None) -> LoopBound:
    """The Youla program of one loop (see the module docstring).

    Parameters
    ----------
    lp : LoopPlant
        The loop (:func:`robrst.synthesis.discs.loop_plants`).
    specs : Specs
        The bounds (the ones :func:`robrst.synthesis.discs.expressed_specs` lists are
        imposed).
    objective : {"max_integral_gain", "min_Ms", "feasibility"}
        What is optimised.
    integrators : int
        Integrators the controller must have (1: ``T(0) = 1``; 0: none; more: the integral
        gain is infinite and ``max_integral_gain`` is not applicable).
    grid_per_decade : float
        Grid frequencies per decade over the basis range, at least twice the basis's
        (plus points at lightly damped poles, band edges, beyond the range and, for the
        sampled loop, up to Nyquist).
    basis : YoulaBasis
        The functions ``Q`` combines.
    controller : RSTController, optional
        A design whose own ``Q`` joins the basis (when its loop is stable).
    rtol : float
        The bounds are widened by ``1 + max(rtol, MIN_WIDEN)`` (the certificate's
        tolerance: a certified design meets the widened discs).
    exchange : bool
        Impose the grid by constraint exchange (the same optimum, fewer rows per solve).
    region : (float or None, float or None), optional
        A pole region ``(damping floor, decay rate [rad/s])`` every closed-loop pole must
        meet: the basis keeps its poles inside it, and every plant pole outside it (a
        sampled loop: mapped by ``fs ln z``) is moved, ``Q(p) = 0`` and
        ``Q'(p) = 1/res_p D`` (``T``, ``S``, ``U`` and ``D S`` without that pole).  A
        restriction of the region's controllers (their ``Q`` need only have poles inside
        it), so only evidence either way.

    Returns
    -------
    LoopBound

    Examples
    --------
    A first-order plant ``1/(s + 1)`` with ``|T| <= 1`` and ``|U| <= 2``: no controller has
    an integral gain above ``pi / (2 asin(1/2)) = 3`` (the docs derive it):

    >>> from robrst.core.plant import Plant
    >>> from robrst.problem.records import Specs
    >>> from robrst.synthesis.discs import LoopPlant
    >>> p = Plant([1.0], [1.0, 1.0])
    >>> b = youla_bound(LoopPlant(p, p), Specs(Mt_max=1.0, Mu_max=2.0))
    >>> b.status, abs(b.value / 3.0 - 1) < 0.02
    ('bounded', True)
    """
    base = dict(model=lp.label, temperature_C=lp.temperature_C, loop=lp.loop)
    if not lp.stable:
        return LoopBound(status="no_estimate", solver_status="unstable loop plant", **base)
    if objective == "max_integral_gain" and integrators != 1:
        return LoopBound(status="not_applicable", **base)
    lo, hi = _span(lp, specs, basis, region)
    # a grid no denser than the basis leaves directions the rows barely see (the
    # interior-point solver then stalls): at least two points per basis pole
    w = _grid(lp, specs, lo, hi, max(grid_per_decade, 2 * basis.per_decade))
    d = spec_discs(lp, w, specs, max(rtol, MIN_WIDEN))
    funcs = basis.functions(lp, specs, region)
    zeta = basis.pair_damping
    jnu = np.full(len(d.nu), np.inf, complex)
    fin = np.isfinite(d.nu)
    jnu[fin] = 1j * d.nu[fin]
    F, _ = _evaluate(funcs, jnu, lp.fs, zeta)
    at0, dat0 = _evaluate(funcs, 0.0, lp.fs, zeta)
    f0, df0 = at0[0].real, dat0[0].real
    D0, dD0 = lp.dc()
    Psi = d.D[:, None] * F                      # T of each basis function
    psi0 = D0 * f0
    dpsi0 = dD0 * f0 + D0 * df0
    if controller is not None:
        got = _design_column(lp, controller, d.nu)
        if got is not None:
            Psi = np.column_stack([Psi, got[0]])
            psi0 = np.append(psi0, got[1])
            dpsi0 = np.append(dpsi0, got[2])
    interp = None
    if region is not None:
        interp = _interpolation(lp, funcs, zeta, region, Psi.shape[1])
        if interp is None:
            return LoopBound(status="no_estimate", solver_status="a multiple plant pole"
                             " outside the pole region", grid_points=len(w), **base)
    prog = _Program(Psi, psi0, dpsi0, d, objective, integrators >= 1, interp)
    status, value, st, rounds, x = prog.solve(exchange)
    if status == "failed":          # an interior-point stall: once more the other way
        status, value, st, more, x = prog.solve(not exchange)
        rounds += more
    if value is not None and objective == "max_integral_gain":
        value = 1.0 / (abs(D0) * value)          # |ki| = 1 / (|D(0)| S'(0))
    q = () if x is None else tuple(float(v) for v in x[:Psi.shape[1]])
    return LoopBound(status=status, value=value, grid_points=len(w),
                     basis_size=Psi.shape[1], solver_status=st, rounds=rounds, q=q, **base)


class _Program:
    """The conic program of one loop on its grid, solved on a growing subset of the grid
    points (constraint exchange): ``T = Psi q`` with ``|T| <= r_T`` and ``|1 - T| <= r_S``
    (``<= gamma`` for ``min_Ms``, ``Msd_max`` kept apart), ``T(0) = 1``."""

    def __init__(self, Psi, psi0, dpsi0, d, objective, integral, interp=None):
        self.Psi, self.d, self.objective, self.integral = Psi, d, objective, integral
        self.interp = interp
        self.K = Psi.shape[1]
        self.gamma = objective == "min_Ms"
        self.n = self.K + int(self.gamma)
        c = np.zeros(self.n)
        if objective == "max_integral_gain":
            c[:self.K] = -dpsi0                  # S'(0) = -T'(0)
        elif self.gamma:
            c[self.K] = 1.0
        self.c = c
        self.psi0 = psi0
        rS = d.S_terms.get("Msd_max") if self.gamma else d.r_S
        self.rS = np.full(len(d.nu), np.inf) if rS is None else rS
        self.rT = d.r_T

    def violation(self, x):
        """Relative violation of each grid point's discs at ``x``."""
        T = self.Psi @ x[:self.K]
        with np.errstate(invalid="ignore", divide="ignore"):
            v = np.where(np.isfinite(self.rT), np.abs(T) / self.rT - 1, -np.inf)
            v = np.fmax(v, np.where(np.isfinite(self.rS), np.abs(1 - T) / self.rS - 1,
                                    -np.inf))
            if self.gamma:
                v = np.fmax(v, np.abs(1 - T) / max(x[self.K], 1e-300) - 1)
        return np.nan_to_num(v, nan=np.inf, neginf=-1.0)

    def solve(self, exchange):
        """``(status, value, solver status, rounds, x)`` on the whole grid."""
        N = len(self.d.nu)
        if not exchange:
            out = self._solve(np.arange(N))
            return out[0], out[1], out[2], 1, out[3]
        active = np.zeros(N, bool)
        active[::4] = True
        active[-1] = True
        out = None
        for k in range(1, EXCHANGE_ROUNDS + 1):
            out = self._solve(np.flatnonzero(active))
            if out[3] is None:
                return out[0], out[1], out[2], k, None
            v = self.violation(out[3])
            bad = (v > EXCHANGE_TOL) & ~active
            if not bad.any():
                return out[0], out[1], out[2], k, out[3]
            # the worst points and every local maximum of the violation
            loc = np.zeros(N, bool)
            loc[1:-1] = (v[1:-1] >= v[:-2]) & (v[1:-1] >= v[2:])
            loc[[0, -1]] = True
            active |= bad & loc
            worst = np.argsort(-np.where(bad, v, -np.inf))[:20]
            active[worst[bad[worst]]] = True
        out = self._solve(np.arange(N))
        return out[0], out[1], out[2], EXCHANGE_ROUNDS + 1, out[3]

    def _solve(self, idx):
        """Clarabel on the grid points ``idx``: ``(status, value, solver status, x)``."""
        import clarabel
        from scipy import sparse

        K, n = self.K, self.n
        Psi = self.Psi[idx]
        rows, b, cones = [], [], []

        def soc(M, a, gamma=False):
            m = len(a)
            blk = np.zeros((3 * m, n))
            rhs = np.zeros(3 * m)
            if gamma:
                blk[0::3, K] = -1.0
            else:
                rhs[0::3] = 1.0
            blk[1::3, :K] = -M.real
            blk[2::3, :K] = -M.imag
            rhs[1::3] = a.real
            rhs[2::3] = a.imag
            rows.append(blk)
            b.append(rhs)
            cones.extend([clarabel.SecondOrderConeT(3)] * m)

        eq = []
        if self.integral:
            r = np.zeros(n)
            r[:K] = self.psi0
            eq.append(r)
        eq_rhs = [1.0] if self.integral else []
        if self.interp is not None:              # the pole region's interpolation
            for row, t in zip(*self.interp):
                r = np.zeros(n)
                r[:K] = row
                eq.append(r)
                eq_rhs.append(t)
        rT, rS = self.rT[idx], self.rS[idx]
        for i in np.flatnonzero(rT == 0):       # T must vanish there
            for part in (Psi[i].real, Psi[i].imag):
                r = np.zeros(n)
                r[:K] = part
                eq.append(r)
        if self.gamma:
            soc(-Psi, np.ones(len(Psi), complex), gamma=True)
        iS = np.flatnonzero(np.isfinite(rS))
        if np.any(rS[iS] <= 0):
            return "infeasible_on_grid", None, "a |S| disc of radius 0", None
        if len(iS):
            soc(-Psi[iS] / rS[iS, None], 1.0 / rS[iS])
        iT = np.flatnonzero(np.isfinite(rT) & (rT > 0))
        if len(iT):
            soc(Psi[iT] / rT[iT, None], np.zeros(len(iT), complex))
        A_soc = np.vstack(rows) if rows else np.zeros((0, n))
        b_soc = np.concatenate(b) if b else np.zeros(0)
        A_eq = np.array(eq).reshape(-1, n)
        b_eq = np.zeros(len(A_eq))
        b_eq[:len(eq_rhs)] = eq_rhs
        # an orthonormal basis of what the rows see, x = V y: the basis functions are far
        # from orthogonal (neighbouring poles); directions no row, no objective and no
        # equality sees are dropped
        full = np.vstack([A_eq, A_soc])
        M = np.vstack([full, self.c / (np.max(np.abs(self.c)) or 1.0)])
        M = M / np.maximum(np.max(np.abs(M), axis=1, keepdims=True), 1e-300)
        _, sv, Vt = np.linalg.svd(M, full_matrices=False)
        keep = sv > sv[0] * SV_CUT
        V = Vt[keep].T / sv[keep]
        cs = self.c @ V
        cs = cs / (np.max(np.abs(cs)) or 1.0)
        A = sparse.csc_matrix(full @ V)
        cone_list = ([clarabel.ZeroConeT(len(A_eq))] if len(A_eq) else []) + cones
        P = sparse.csc_matrix((V.shape[1], V.shape[1]))
        for retry in CLARABEL_RETRIES:     # a numerical stall: the same program set up anew
            settings = clarabel.DefaultSettings()
            settings.verbose = False
            settings.max_iter = 200
            try:
                for k, v in retry.items():
                    setattr(settings, k, v)
                sol = clarabel.DefaultSolver(P, cs, A, np.concatenate([b_eq, b_soc]),
                                             cone_list, settings).solve()
            except Exception:     # noqa: BLE001 — a setting this Clarabel build lacks
                if not retry:
                    raise
                continue
            st = str(sol.status).split(".")[-1]
            if st not in ("NumericalError", "InsufficientProgress", "MaxIterations"):
                break
        if st in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
            return "infeasible_on_grid", None, st, None
        if st in ("DualInfeasible", "AlmostDualInfeasible"):
            return "unbounded", None, st, None
        if st not in ("Solved", "AlmostSolved"):
            return "failed", None, st, None
        x = V @ np.asarray(sol.x)
        if self.objective == "max_integral_gain":
            slope = float(self.c @ x)
            return ("bounded", slope, st, x) if slope > 0 else ("unbounded", None, st, x)
        if self.gamma:
            return "bounded", float(x[K]), st, x
        return "feasible_on_grid", None, st, x


def objective_bound(problem: Problem, controller: RSTController | None = None,
                    certified: bool = False, grid_per_decade: float = GRID_PER_DECADE,
                    basis: YoulaBasis = DEFAULT_BASIS, models: list | None = None,
                    design_value: float | None = None,
                    region: tuple | None = None) -> ObjectiveBound:
    """The estimate of the problem's objective on the whole family (module docstring).

    Parameters
    ----------
    problem : Problem
        The problem (family, specs, objective, sample rate, integrators of ``S_fixed``).
    controller : RSTController, optional
        The design; with ``certified`` its own ``Q`` joins every program's basis (so the
        estimate is never on the wrong side of it) and its figure is compared.
    certified : bool
        The design is certified (only then is it a feasible point of the programs).
    grid_per_decade : float
        The programs' grid density.
    basis : YoulaBasis
        The programs' basis.
    models : list of Plant, optional
        The models (default: the family's members).
    design_value : float, optional
        The design's figure (``|ki|`` or worst ``Ms``); default: ``|ki|`` of a certified
        ``controller`` for ``max_integral_gain``.
    region : (float or None, float or None), optional
        With the ``feasibility`` objective: every program also keeps the closed-loop poles
        in this pole region (:func:`youla_bound`).

    Returns
    -------
    ObjectiveBound

    Examples
    --------
    >>> from robrst import load_problem
    >>> b = objective_bound(load_problem("paper_robust"))
    >>> b.status, b.exact
    ('unbounded', False)
    """
    from robrst.base.threads import one_blas_thread
    from robrst.synthesis.parametrize import integral_gain

    t0 = time.perf_counter()
    sp, obj = problem.specs, problem.solver.objective
    given, lost = expressed_specs(sp)
    nint = integrators_of(problem)
    with_design = controller is not None and certified
    rtol = problem.solver.cert_tol if with_design else 0.0
    if design_value is None and with_design and obj == "max_integral_gain":
        ki = integral_gain(controller)
        design_value = abs(ki) if np.isfinite(ki) else None
    common = dict(objective=obj, specs=given, left_out=lost, design_value=design_value,
                  includes_design=with_design)

    def done(**kw):
        kw.setdefault("note", _note(lost))
        return ObjectiveBound(wall_time_s=time.perf_counter() - t0, **common, **kw)

    if obj == "max_integral_gain" and nint != 1:
        return done(status="not_applicable", reason="no integral gain to maximise: the"
                    f" controller's fixed factor has {nint} integrators")
    loops = loop_plants(problem, models)
    stable = [lp for lp in loops if lp.stable]
    if not stable:
        return done(status="no_estimate", reason="no estimate for an unstable plant or one"
                    " with an integrator (every loop plant of the family)")
    skipped = [lp for lp in loops if not lp.stable]
    # T(0) = 1 (integral action) against the |T| disc at 0 Hz: on every loop, stable or not
    all_rooms = [dc_room(lp, sp) for lp in loops] if nint >= 1 else [np.inf] * len(loops)
    rooms = [r for r, lp in zip(all_rooms, loops) if lp.stable]
    low = [(r, lp) for r, lp in zip(all_rooms, loops) if r < 1 - PINNED]
    if low:
        r, lp = min(low, key=lambda t: t[0])
        return done(status="infeasible", model=lp.label, temperature_C=lp.temperature_C,
                    loop=lp.loop, reason=f"integral action needs |T(0)| = 1, and at 0 Hz the"
                    f" specs allow |T| <= {r:.4g} on model {lp.label} ({lp.temperature_C:g}"
                    f" °C, {lp.loop} loop)")
    pinned = [lp for r, lp in zip(rooms, stable) if r <= 1 + PINNED]
    progs = []
    if obj == "max_integral_gain":
        if not any(r <= 1 + PINNED for r in all_rooms):
            return done(status="unbounded", reason=_room_reason(sp, loops, all_rooms))
        progs = pinned
    elif obj == "min_Ms":
        progs = [lp for lp in stable if lp in pinned or _msd_binds(lp, sp)]
        if not progs and not skipped:
            why = ("a slow enough integral action" if nint else "no controller (Q = 0)")
            return done(status="bounded", value=1.0, exact=True, reason=why +
                        " keeps |S| within any margin of 1, and no Msd_max below the plant's"
                        " peak asks the loop to act" if nint else
                        why + " gives |S| = 1 and no Msd_max asks the loop to act")
    else:
        progs = stable
    if not progs:        # min_Ms: the fact above holds on the stable loops only
        return done(status="bounded", value=1.0, reason="on the stable loop plants a slow"
                    " integral action keeps |S| within any margin of 1 (no estimate on the"
                    " unstable ones: "
                    + ", ".join(sorted({f"{lp.label} ({lp.loop})" for lp in skipped})) + ")")
    if obj == "max_integral_gain":
        # T(0) = 1 on the edge of the disc: the specs as written (any widening, the
        # certificate's tolerance included, leaves room and no finite supremum), so the
        # design (certified within that tolerance) is no feasible point of the programs
        with_design, rtol = False, 0.0
        common["includes_design"] = False
    with one_blas_thread():
        runs = tuple(youla_bound(lp, sp, obj, nint, grid_per_decade, basis,
                                 controller if with_design else None, rtol,
                                 region=region if obj == "feasibility" else None)
                     for lp in progs)
    size = max((r.basis_size for r in runs), default=0)
    common.update(per_loop=runs, basis=basis.describe(size, with_design),
                  grid_points=max((r.grid_points for r in runs), default=0))
    failed = [r for r in runs if r.status == "failed"]
    bad = [r for r in runs if r.status == "infeasible_on_grid"]
    if bad:
        r = bad[0]
        return done(status="infeasible_on_grid", model=r.model, temperature_C=r.temperature_C,
                    loop=r.loop, reason=f"no Q of the basis meets the specs on the grid of"
                    f" model {r.model} ({r.loop} loop)")
    if failed and len(failed) == len(runs):
        return done(status="no_estimate", reason="the programs did not converge ("
                    + ", ".join(sorted({r.solver_status for r in failed})) + ")")
    if obj == "feasibility":
        return done(status="feasible_on_grid", reason="every model's program is feasible")
    fin = [r for r in runs if r.status == "bounded"]
    if obj == "max_integral_gain" and not fin:
        return done(status="unbounded", reason="the programs reach S'(0) <= 0 on every model"
                    " that pins T(0) (a second integrator meets the specs on the grid)")
    pick = (min if obj == "max_integral_gain" else max)(fin, key=lambda r: r.value)
    value = pick.value if obj == "max_integral_gain" else max(pick.value, 1.0)
    frac = None
    if design_value is not None and value:
        frac = design_value / value if obj == "max_integral_gain" else value / design_value
    if obj == "max_integral_gain":
        tol = problem.solver.cert_tol
        reason = (f"T(0) = 1 sits on the edge of the |T| disc at 0 Hz (model {pick.model}):"
                  " the value holds for the specs as written; the certificate's tolerance"
                  f" ({tol:g}) leaves room at 0 Hz, within which the gain is unbounded")
        if design_value is not None and design_value > value:
            reason += ("; this design exceeds the value by using that tolerance at 0 Hz")
    else:
        reason = ("Msd_max makes the loop act at the plant's resonance"
                  if any(_msd_binds(lp, sp) for lp in progs) else "T(0) = 1 is pinned at 0 Hz")
    if failed:
        reason += (f"; {len(failed)} of {len(runs)} programs did not converge and are left"
                   " out")
    return done(status="bounded", value=value, model=pick.model,
                temperature_C=pick.temperature_C, loop=pick.loop, fraction=frac,
                reason=reason)


def _msd_binds(lp, specs):
    """``Msd_max`` lies below the loop plant's peak gain: the loop must act somewhere."""
    if specs.Msd_max is None:
        return False
    pk = peak_gain(lp.plant.B, lp.plant.A)
    return bool(specs.Msd_max < pk.value)


def _room_reason(specs, loops, rooms):
    """Why the integral gain has no finite supremum, with the numbers."""
    k = int(np.argmin(rooms))
    lp = loops[k]
    parts = []
    if specs.Mt_max is not None:
        parts.append(f"Mt_max {specs.Mt_max:g} > 1")
    if specs.Mu_max is not None:
        mu = min(specs.Mu_max * abs(m.dc()[0]) for m in loops)
        parts.append(f"Mu_max |D(0)| >= {mu:.4g} > 1")
    radius = "no |T| bound at 0 Hz" if not np.isfinite(rooms[k]) else (
        f"least |T| radius {rooms[k]:.4g} at 0 Hz, model {lp.label}, {lp.loop} loop")
    return (f"at 0 Hz the specs leave room around T(0) = 1 on every model"
            f" ({', '.join(parts + [radius])}), so any controller meeting them with some"
            " margin still meets them after a slow lag (s + a)/(s + b), which multiplies its"
            " integral gain by a/b without limit")


def _note(lost):
    out = ("an estimate over every linear controller: a frequency-grid relaxation with Q in a"
           " finite basis (the true optimum may lie beyond a program's value)")
    if lost:
        out += f"; left out: {', '.join(lost)} (they can only make the true optimum worse)"
    return out


@dataclass(frozen=True, eq=False)
class LagWitness:
    """A design times a slow lag ``(s + a)/(s + b)``: ``a/b`` times its integral gain.

    Parameters
    ----------
    controller : RSTController
        ``R (s + a)``, ``S (s + b)``, ``T (s + b)`` (the reference path unchanged).
    a_rad_s, b_rad_s : float
        The lag's zero and pole [rad/s].
    factor : float
        ``a / b``: the integral gain's factor.
    certificate : Certificate
        Its certificate on the problem's family and specs without the time-domain ones
        (what the estimate expresses, the pole region and stability included).

    Attributes
    ----------
    certified : bool
        The certificate holds.
    """

    controller: RSTController
    a_rad_s: float
    b_rad_s: float
    factor: float
    certificate: Certificate

    @property
    def certified(self):
        """The certificate holds."""
        return bool(self.certificate.certified)


def lag_witness(problem: Problem, controller: RSTController, factor: float = 10.0,
                tries: int = 4) -> LagWitness:
    """A constructive check of "no finite estimate": the design with a slow lag, certified.

    ``a`` starts at ``10^-2 |ki D(0)|`` (a hundredth of the integral action's crossover) and
    is divided by 10 until the lagged design certifies (at most ``tries`` times); the
    certificate is :func:`robrst.certificate.proof.certify` on the family and the specs
    without their time-domain part.

    Parameters
    ----------
    problem : Problem
        The problem.
    controller : RSTController
        A design with one integrator.
    factor : float
        ``a / b``.
    tries : int
        Zeros ``a`` tried.

    Returns
    -------
    LagWitness
        The first certified one, else the last tried.

    Examples
    --------
    >>> from robrst import load_problem, run_problem
    >>> p = load_problem("paper")
    >>> w = lag_witness(p, run_problem(p).controller)
    >>> w.certified, w.factor
    (True, 10.0)
    """
    from robrst.certificate.proof import certify
    from robrst.core.rst import RSTController
    from robrst.synthesis.parametrize import integral_gain

    ki = integral_gain(controller)
    d0 = min(abs(m.dc_gain) for m in problem.family.models)
    a = abs(ki) * d0 * 1e-2
    specs = problem.specs.without_time_domain()
    out = None
    for _ in range(tries):
        b = a / factor
        lag = RSTController(np.polymul(controller.R, [1.0, a]),
                            np.polymul(controller.S, [1.0, b]),
                            np.polymul(controller.T, [1.0, b]))
        cert = certify(problem.family, lag, specs, n_sweep=problem.solver.cert_temperatures,
                       rtol=problem.solver.cert_tol)
        out = LagWitness(lag, float(a), float(b), float(factor), cert)
        if cert.certified:
            return out
        a /= 10.0
    return out
