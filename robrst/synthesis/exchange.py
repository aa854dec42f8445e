"""Exchange method for the grid constraints of the robust program (semi-infinite programming).

A peak bound ``|N(j nu)| <= M |Delta(j nu)|`` on a frequency grid of every model
is a large set of constraints of which only a few are active at the optimum: the
points next to each peak.  The exchange method solves the program on an *active
subset* of grid points, evaluates every grid point numerically at the solution
(a matrix-vector product per block) and, while any violates its bound (beyond
``VIOLATED``, far below the bound margins and the certificate's tolerance), adds the local
maxima that violate — or nearly reach — their bound and solves again from the previous
solution.  Once no grid point is violated the point is final: the constraints left out
hold there and have zero multipliers, so a KKT point of the subset is one of the whole
grid (no further round for a near-active point that does not bind).  The active set only
grows, so the loop ends; the final point satisfies every grid constraint and is a (local)
optimum of the full-grid program.  The closed-loop stability rows are exchanged the same
way (:mod:`robrst.synthesis.stability`).

The program itself is one parametric solver per structure
(:class:`~robrst.synthesis.template.Template`, cached in ``templates``): an exchange
round only changes the parameters, it never rebuilds the CasADi graph.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.certificate.proof import band_peak
from robrst.core.peaks import peak_gain
from robrst.synthesis._nlp import (controller_conditions, grid_blocks, local_maxima,
                                  objective_rows)
from robrst.synthesis.outcome import FEASIBLE_TOL, LIMIT_FEASIBLE, SolveResult
from robrst.synthesis.stability import (ROUTH_MIN, initial_stability, joined, routh_margins,
                                        stability_rows)
from robrst.synthesis.template import Structure, Template

if TYPE_CHECKING:
    from robrst.synthesis._nlp import GridBlock, NLPSetup
    from robrst.synthesis._timesamples import TimeRows

__all__ = ["ExchangeInfo", "Phase", "solve_exchange", "solve_program", "local_maxima",
           "effective_ratios"]
NEAR_ACTIVE = 0.02      # local maxima within 2 % below the bound join the active set
VIOLATED = 1e-6         # a grid point is violated beyond this (relative; IPOPT's own is 1e-9)
COARSE_POINTS = 3       # evenly spaced starting points per block (plus local maxima)
NEIGHBOURS_NEAR = 0.8   # local maxima above this share of their bound start with neighbours


@dataclass(frozen=True)
class Phase:
    """What is solved: the soft goals or the objective.

    Parameters
    ----------
    kind : {"hard", "soft", "time"}
        ``"soft"``: minimise the worst normalised spec ratio ``gamma`` (systune's soft
        goals); ``"hard"``: the problem's objective with every spec a constraint;
        ``"time"``: minimise the worst normalised ratio of the reference-step samples
        alone, every other spec a constraint (the restoration step of
        :mod:`robrst.synthesis._timesamples`).
    gamma_floor : float
        The soft phase stops minimising below this ``gamma``.
    """

    kind: str = "hard"
    gamma_floor: float = 0.0


@dataclass(frozen=True)
class ExchangeInfo:
    """How the exchange went: rounds, IPOPT iterations, active and total grid points.

    Parameters
    ----------
    rounds : int
        Exchange rounds.
    iterations : int
        IPOPT iterations summed over the rounds.
    active_points : int
        Grid points imposed at the end.
    grid_points : int
        Grid points in all.
    max_grid_ratio : float
        Max over every grid point of ``|N| / (limit |Delta|)`` at the result.
    stability_models : int
        Models whose closed-loop stability rows were imposed (-1: not recorded).
    """

    rounds: int
    iterations: int
    active_points: int
    grid_points: int
    max_grid_ratio: float   # max over every grid point of |N| / (limit |Delta|) at the result
    stability_models: int = -1   # models whose closed-loop stability rows were imposed


def _limits(setup, blocks, phase):
    """Per block ``(m, scaled)``: the constraint is ``|N| <= m (gamma if scaled else 1) |D|``."""
    out = []
    for b in blocks:
        if phase.kind == "soft":
            out.append((b.bound, True))
        elif phase.kind == "time":
            out.append((b.bound, False))
        elif setup.objective == "min_Ms" and b.key == "S":
            out.append((1.0, True))
        else:
            out.append((b.bound, False))
    return out


def effective_ratios(blocks: Sequence[GridBlock], limits: Sequence[tuple[float, bool]],
                     x: np.ndarray, gamma: float) -> list[np.ndarray]:
    """Per block, ``|N| / (limit |Delta|)`` at every grid point.

    Parameters
    ----------
    blocks : sequence of GridBlock
        The constraints.
    limits : sequence of (float, bool)
        Per block its limit and whether it scales with ``gamma``.
    x : numpy.ndarray
        The decision vector.
    gamma : float
        The soft phase's scale.

    Returns
    -------
    list of numpy.ndarray
    """
    return [b.ratio(x) * b.bound / (m * (gamma if sc else 1.0)) for b, (m, sc) in zip(blocks, limits)]


def _capacity(n, lo=32):
    """Constraint slots for ``n`` active points: steps of 1.5x (32, 48, 72, ... 364, 546),
    so a few builds serve every round and variant while an IPOPT iteration, whose cost
    grows with the slots (unused ones included), wastes a quarter of them on average."""
    c = lo
    while c < n:
        c = int(c * 1.5)
    return c


def _structure(setup, phase, n_slots, ipopt, rows, routh, lin=None):
    ctrl = _ctrl(setup, phase)
    deg_eq = len(setup.Am_fixed) - 1 if setup.placement == "fixed" else (
        0 if setup.placement == "free" else rows[setup.ref][0])
    return Structure(nx=setup.n_x, placement=setup.placement, deg_eq=deg_eq,
                     n_dom_real=len(setup.n_dom_real),
                     groups=_group_caps([rows[j] for j in routh]),
                     slots=_capacity(n_slots), ipopt=tuple(sorted(ipopt.items())),
                     ctrl_deg=-1 if ctrl is None else ctrl[2] - 1,
                     ctrl_count=1 if ctrl is None else ctrl[3],
                     lin=0 if lin is None or not len(lin.c) else _capacity(len(lin.c), 24))


def _ctrl(setup, phase):
    """``(M, m, len, count)`` of the controller-pole conditions of this phase, or ``None``."""
    shift = setup.ctrl_shift if (phase.kind == "hard" and
                                 setup.objective == "max_integral_gain") else None
    out = controller_conditions(setup, shift, setup.stable_controller,
                                bounded=setup.placement == "free")
    if out is None:
        return None
    count = int(shift is not None or setup.stable_controller) + int(
        setup.placement == "free" and setup.ctrl_max is not None)
    return out[0], out[1], out[0].shape[0] // count, count


def _group_caps(groups):
    degs = {}
    for deg, *_ in groups:
        degs[deg] = degs.get(deg, 0) + 1
    return tuple((d, -(-n // 4) * 4) for d, n in sorted(degs.items()))


def _values(setup, st, blocks, limits, active, rows, routh, phase, x_ref, lin=None):
    """Parameters, constraint bounds and labels of one solve."""
    nx, K = st.nx, st.slots
    v = {k: np.zeros((K, nx)) for k in ("NR", "NI", "DR", "DI")}
    v.update({k: np.zeros(K) for k in ("nr", "ni", "dr", "di", "m2", "sg")})
    v["w"], v["dr"] = np.ones(K), np.ones(K)      # unused slots: 0 / 1
    v["rho"] = [0.0 if setup.placement == "free" else 1.0]
    lbg, ubg, labels = [], [], []
    ref_deg, D0m, D0c = rows[setup.ref]
    if st.placement != "free":
        v["D0m"], v["D0c"] = D0m[1:], D0c[1:]
        if st.placement == "fixed":
            v["Am"] = setup.Am_fixed[1:]
        else:
            v["aux"], v["domr"] = [setup.aux_factor], list(setup.n_dom_real)
        lbg += [0.0] * st.deg_eq
        ubg += [0.0] * st.deg_eq
        labels += [("diophantine", None, None, i) for i in range(st.deg_eq)]
    i = 0
    for b, (m, sc), idx in zip(blocks, limits, active):
        n = len(idx)
        sl = slice(i, i + n)
        v["NR"][sl], v["nr"][sl], v["NI"][sl], v["ni"][sl] = (a[idx] for a in b.N)
        v["DR"][sl], v["dr"][sl], v["DI"][sl], v["di"][sl] = (a[idx] for a in b.D)
        v["w"][sl], v["m2"][sl], v["sg"][sl] = b.w[idx], m * m, float(sc)
        labels += [(b.key, b.label, b.temperature_C, float(nu)) for nu in b.nu[idx]]
        i += n
    lbg += [-np.inf] * K
    ubg += [0.0] * i + [np.inf] * (K - i)
    labels += [("unused", None, None, None)] * (K - i)
    for gi, (deg, cap) in enumerate(st.groups):
        mine = [(j, rows[j]) for j in routh if rows[j][0] == deg]
        Dm = np.zeros((cap * (deg + 1), nx))
        Dc = np.tile(np.poly(-np.ones(deg)), cap)          # (p + 1)^deg: unused, Hurwitz
        for k, (j, (_, m_, c_)) in enumerate(mine):
            Dm[k * (deg + 1):(k + 1) * (deg + 1)] = m_
            Dc[k * (deg + 1):(k + 1) * (deg + 1)] = c_
            label, T = setup.models[j][:2]
            labels += [("routh", label, T, r) for r in range(deg + 1)]
        labels += [("unused", None, None, None)] * ((cap - len(mine)) * (deg + 1))
        v[f"Dm{gi}"], v[f"Dc{gi}"] = Dm, Dc
        used = len(mine) * (deg + 1)
        lbg += [ROUTH_MIN] * used + [-np.inf] * (cap * (deg + 1) - used)
        ubg += [np.inf] * (cap * (deg + 1))
    r0, q0, q0c = objective_rows(setup)
    v.update(r0=r0, q0=q0, q0c=[q0c], xref=np.asarray(x_ref, float)[:nx])
    hard_ki = phase.kind == "hard" and setup.objective == "max_integral_gain"
    lbg += [1e-12, 1e-12] if hard_ki else [-np.inf, -np.inf]
    scaled = phase.kind in ("soft", "time")      # rows scale with gamma
    ubg += [np.inf, np.inf]
    labels += [("positivity", None, None, 0), ("positivity", None, None, 1)]
    if st.ctrl_deg >= 0:
        M, m, _, _ = _ctrl(setup, phase)
        v["Cm"], v["Cc"] = M, m
        lbg += [ROUTH_MIN] * len(m)
        ubg += [np.inf] * len(m)
        labels += [("controller_routh", None, None, r) for r in range(len(m))]
    if st.lin:
        n = len(lin.c)
        Lm, Lg, Lc = np.zeros((st.lin, nx)), np.zeros(st.lin), np.zeros(st.lin)
        Lm[:n], Lg[:n], Lc[:n] = lin.A, (lin.g if scaled else 0.0), (
            lin.c if scaled else lin.c + lin.g)   # hard: gamma is 1
        v["Lm"], v["Lg"], v["Lc"] = Lm, Lg, Lc
        lbg += [-np.inf] * st.lin
        ubg += [0.0] * n + [np.inf] * (st.lin - n)
        labels += list(lin.labels) + [("unused", None, None, None)] * (st.lin - n)
    # a small proximal term fixes the directions the objective and the active
    # constraints leave free (the Youla parameter's null directions), relative to |x_ref|
    reg = {"soft": 1e-4, "max_integral_gain": 1e-10, "min_Ms": 1e-10, "feasibility": 1e-2}[
        "soft" if scaled else setup.objective]
    reg /= 1.0 + float(np.dot(v["xref"], v["xref"]))
    v["coef"] = {"soft": [1.0, 0.0, reg], "max_integral_gain": [0.0, 1.0, reg],
                 "min_Ms": [1.0, 0.0, reg], "feasibility": [0.0, 0.0, reg]}[
        "soft" if scaled else setup.objective]
    return v, np.array(lbg), np.array(ubg), tuple(labels)


def _var_bounds(setup, st, phase, box=None):
    n = st.n_var
    lbx, ubx = -np.inf * np.ones(n), np.inf * np.ones(n)
    if box is not None:                     # a trust region on the controller coefficients
        c, r = box
        lbx[:st.nx], ubx[:st.nx] = c - r, c + r
    if setup.placement == "dominant":
        (wl, wh), (zl, zh) = setup.pole_bounds
        lbx[st.nx:st.nx + 2] = [wl, zl]
        ubx[st.nx:st.nx + 2] = [wh, zh]
    if phase.kind in ("soft", "time"):
        lbx[-1] = phase.gamma_floor
    elif setup.objective == "min_Ms":
        lbx[-1] = 0.0
        if setup.bounds.get("S") is not None:
            ubx[-1] = setup.bounds["S"]
    else:
        lbx[-1] = ubx[-1] = 1.0
    return lbx, ubx


def solve_program(setup: NLPSetup, x0: np.ndarray, ipopt: dict, phase: Phase = Phase(),
                  blocks: Sequence[GridBlock] | None = None, active: Sequence | None = None,
                  templates: dict | None = None, x_ref: np.ndarray | None = None,
                  box: tuple[np.ndarray, np.ndarray] | None = None,
                  routh: Sequence[int] | None = None, rows: list | None = None,
                  lin: TimeRows | None = None) -> SolveResult:
    """Solve the program on the ``active`` grid points of ``blocks`` (default: all).

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    x0 : numpy.ndarray
        The full variable vector ``[xc, (wn, zeta), gamma]``.
    ipopt : dict
        IPOPT options.
    phase : Phase
        Soft goals or the objective.
    blocks : sequence of GridBlock, optional
        The grid constraints (default :func:`~robrst.synthesis._nlp.grid_blocks` at
        ``x_ref``).
    active : sequence, optional
        Per block, the indices of its grid points imposed (default: all).
    templates : dict, optional
        Built solvers by structure (default: a fresh one).
    x_ref : numpy.ndarray, optional
        The point whose ``|Delta|^2`` weights the constraints (default ``x0``).
    box : (numpy.ndarray, numpy.ndarray), optional
        ``(center, radius)`` bounds the controller coefficients (a trust region).
    routh : sequence of int, optional
        The models whose closed-loop stability rows are imposed (default: every model).
    rows : list, optional
        Those rows, if the caller has them
        (:func:`~robrst.synthesis.stability.stability_rows`).
    lin : TimeRows, optional
        Linear rows (:class:`~robrst.synthesis._timesamples.TimeRows`: the reference-step
        samples and the roots near a damping floor).

    Returns
    -------
    SolveResult
    """
    x0 = np.asarray(x0, float)
    blocks = grid_blocks(setup, x0) if blocks is None else blocks
    if active is None:
        active = [np.arange(len(b.nu)) for b in blocks]
    limits = _limits(setup, blocks, phase)
    rows = stability_rows(setup) if rows is None else rows
    routh = tuple(range(len(rows))) if routh is None else tuple(routh)
    st = _structure(setup, phase, sum(len(a) for a in active), ipopt, rows, routh, lin)
    cache = {} if templates is None else templates
    if st not in cache:
        cache[st] = Template(st)
    tpl = cache[st]
    v, lbg, ubg, labels = _values(setup, st, blocks, limits, active, rows, routh, phase,
                                  x0 if x_ref is None else x_ref, lin)
    lbx, ubx = _var_bounds(setup, st, phase, box)
    x0 = np.clip(x0, lbx, ubx)
    out = tpl.solve(v, x0, lbx, ubx, lbg, ubg)
    res = SolveResult(status=out["status"], x=out["x"], objective=out["f"],
                      iterations=out["iterations"], g=out["g"], lbg=lbg, ubg=ubg,
                      lam_g=out["lam_g"], labels=labels, w0=setup.w0, rates=dict(setup.rates),
                      lam_x=out["lam_x"], lbx=lbx, ubx=ubx, params=v)
    if res.status == "Maximum_Iterations_Exceeded" and np.isfinite(res.objective) and np.all(
            np.isfinite(res.g)) and res.violations().max(initial=0.0) <= FEASIBLE_TOL:
        res = replace(res, status=LIMIT_FEASIBLE)   # a point that meets every row: used
    return res


def _initial_active(ratios, coarse_points, neighbours=True):
    """Per block: ``coarse_points`` evenly spaced points, the local maxima at the start and
    (placed poles: ``neighbours``) the neighbours of those above ``NEIGHBOURS_NEAR`` (a
    binding peak moves by a grid point or so on the way to the optimum)."""
    active = []
    for r in ratios:
        n = len(r)
        coarse = np.unique(np.linspace(0, n - 1, min(n, coarse_points)).round().astype(int))
        peaks = local_maxima(r)
        hot = peaks[r[peaks] > (NEIGHBOURS_NEAR if neighbours else np.inf)]
        near = np.clip(np.concatenate([hot - 1, hot + 1]), 0, max(n - 1, 0))
        active.append(np.union1d(np.union1d(coarse, peaks), near))
    return active


def _exact_peak(b, x):
    """Exact peak ``(value, scaled frequency)`` of block ``b``'s ratio at ``x``."""
    N, D = b.polys(x)
    if b.key == "Tband":
        return band_peak(N, D, b.nu[0], b.nu[-1])
    if b.key == "Uhf":
        return band_peak(N, D, b.nu[0], b.nu[0] * 1e6)
    pk = peak_gain(N, D)
    return pk.value, pk.freq_rad_s


def _exact_growth(blocks, limits, active, x, gamma):
    """Add every block's exact peak frequency where it is near or above its limit."""
    added = 0
    for k, (b, (m, sc)) in enumerate(zip(blocks, limits)):
        try:
            val, nu = _exact_peak(b, x)
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            continue
        if not np.isfinite(nu) or nu <= 0 or val / (m * (gamma if sc else 1.0)) <= 1.0 - NEAR_ACTIVE:
            continue
        if np.min(np.abs(b.nu - nu)) <= 1e-9 * nu:
            continue
        keep = b.nu[active[k]]
        blocks[k] = b.with_points([nu])
        active[k] = np.union1d(np.searchsorted(blocks[k].nu, keep),
                               np.searchsorted(blocks[k].nu, [nu]))
        added += 1
    return added


def solve_exchange(setup: NLPSetup, x0: np.ndarray, ipopt: dict, phase: Phase = Phase(),
                   templates: dict | None = None, max_rounds: int = 50,
                   coarse_points: int = COARSE_POINTS, exact: bool = False,
                   box: tuple[np.ndarray, np.ndarray] | None = None,
                   stability: Sequence[int] | None = None,
                   lin: TimeRows | None = None) -> SolveResult:
    """Solve the program of ``setup`` on its whole grid by constraint exchange.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    x0 : numpy.ndarray
        Starting point ``[xc, (wn, zeta), gamma]``; its closed-loop ``|Delta|^2``
        weights every grid constraint.
    ipopt : dict
        IPOPT options.
    phase : Phase
        Soft goals or the objective.
    templates : dict, optional
        Built solvers by structure, shared between calls.
    max_rounds : int
        Safety cap on exchange rounds.
    coarse_points : int
        Evenly spaced grid points per block in the first active set, next to the
        local maxima of each constraint at ``x0``.
    exact : bool
        Once the grid holds, also add each block's *exact* peak frequency
        (:func:`robrst.core.peaks.peak_gain`, the certificate's band peak) when it is near
        or above its bound, and solve again: the semi-infinite program's own
        exchange, for loops whose resonances fall between grid points.
    box : (ndarray, ndarray), optional
        Trust region ``|xc - center| <= radius`` on the controller coefficients.
    stability : sequence of int, optional
        The models whose stability rows the first round carries (others join when a
        round's result violates them; :mod:`robrst.synthesis.stability`).  Default: every
        model for freely placed poles, else ``initial_stability``.
    lin : TimeRows, optional
        Linear rows imposed in every round (the reference-step samples).

    Returns
    -------
    SolveResult
        The last subproblem's result with ``iterations`` summed over the rounds and
        ``exchange`` an :class:`ExchangeInfo`.  A later round that fails from the previous
        round's optimum (with a warm and with IPOPT's default barrier) is solved again
        from ``x0``.  A subproblem that fails is returned at
        once (it is a relaxation of the full-grid program) unless it ends where a
        stability row it left out does not hold: the program is then solved again with
        every row from the first round.
    """
    rows = stability_rows(setup)
    if stability is not None:
        first = tuple(sorted(set(int(j) for j in stability)))
    elif setup.placement == "free":
        first = tuple(range(len(rows)))
    else:
        first = initial_stability(rows, x0)
    res = _exchange(setup, x0, ipopt, phase, templates, max_rounds, coarse_points, exact, box,
                    rows, first, lin)
    partial = res.exchange.stability_models < len(rows)
    if not res.success and partial and np.any(~(routh_margins(rows, res.x) >= ROUTH_MIN)):
        # it failed where a row left out does not hold: every row from the first round
        again = _exchange(setup, x0, ipopt, phase, templates, max_rounds, coarse_points, exact,
                          box, rows, tuple(range(len(rows))), lin)
        res = replace(again, iterations=again.iterations + res.iterations)
    return res


def _exchange(setup, x0, ipopt, phase, templates, max_rounds, coarse_points, exact, box, rows,
              routh, lin=None):
    """The rounds of :func:`solve_exchange` from the stability rows of models ``routh``."""
    x0 = np.asarray(x0, float)
    blocks = list(grid_blocks(setup, x0))
    limits = _limits(setup, blocks, phase)
    total = sum(len(b.nu) for b in blocks)
    active = _initial_active(effective_ratios(blocks, limits, x0, x0[-1]), coarse_points,
                             setup.placement != "free")
    templates = {} if templates is None else templates
    x, iters, worst = x0, 0, np.inf
    for rnd in range(1, max_rounds + 1):
        # later rounds start at the previous optimum: a small initial barrier keeps them there
        opts = ipopt if rnd == 1 else {**ipopt, "mu_init": min(ipopt.get("mu_init", 0.1), 1e-4)}
        res = solve_program(setup, x, opts, phase, blocks, active, templates, x_ref=x0, box=box,
                            routh=routh, rows=rows, lin=lin)
        if not res.success and rnd > 1:      # the warm barrier failed: IPOPT's default one
            # (a start far inside gets its warm barrier from the caller: not this one too)
            cold = {k: v for k, v in ipopt.items() if k != "mu_init"}
            res = solve_program(setup, x, cold, phase, blocks, active, templates, x_ref=x0,
                                box=box, routh=routh, rows=rows, lin=lin)
            if not res.success:   # from the exchange's own start: the previous optimum
                # sits outside the rows just added, and IPOPT's restoration from there can
                # end at a local minimum of the infeasibility (a polish's start meets them)
                res = solve_program(setup, x0, cold, phase, blocks, active, templates,
                                    x_ref=x0, box=box, routh=routh, rows=rows, lin=lin)
        x = res.x
        iters += res.iterations
        ratios = effective_ratios(blocks, limits, x, x[-1])
        worst = max((float(r.max()) for r in ratios), default=0.0)
        if not res.success:
            break
        added = 0
        if worst > 1.0 + VIOLATED:      # else every grid point holds: the point is final
            for k, r in enumerate(ratios):
                peaks = local_maxima(r)
                new = np.setdiff1d(peaks[r[peaks] > 1.0 - NEAR_ACTIVE], active[k])
                added += new.size
                active[k] = np.union1d(active[k], new)
        grown = joined(rows, routh, x)          # the stability rows left out that x violates
        added, routh = added + len(grown) - len(routh), grown
        if added == 0 and exact:
            added = _exact_growth(blocks, limits, active, x, x[-1])
        if added == 0:
            break
    info = ExchangeInfo(rounds=rnd, iterations=iters,
                        active_points=int(sum(a.size for a in active)),
                        grid_points=max(total, sum(len(b.nu) for b in blocks)),
                        max_grid_ratio=worst, stability_models=len(routh))
    return replace(res, iterations=iters, exchange=info)
