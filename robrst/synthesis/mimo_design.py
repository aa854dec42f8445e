"""The multi-axis synthesis: per-axis designs, the decoupler, the joint program's rounds.

The pieces :func:`robrst.design.mimo.design_mimo` assembles (that module's docstring
gives the whole pipeline):

* :func:`decoupler_of`: the problem's decoupler (``static``:
  :func:`robrst.synthesis.mimo_start.static_decoupler` of the reference model; ``given``;
  ``none``);
* :func:`design_axes`: each axis designed alone on its diagonal channel ``(G W)_ii`` over
  every model and loop of the family: a rolled-off integral law scanned to the largest
  stable gain that meets the bounds; with ``optimize`` the program in its 1 x 1 form then
  maximises each axis's integral gain;
* :func:`program_rounds`: the joint program (:mod:`robrst.synthesis.mimo_program`), every
  axis, the coupling and every model at once.  Rounds: solve on the grid; check the models
  exactly (:func:`robrst.certificate.mimo.check_models`); a violated figure's frequency
  joins the grid, an unstable candidate is pulled back towards the last stable controller
  (halving the step) and the unstable poles' frequencies join the grid;
* :func:`per_axis_controller`, :func:`controller_of`: decision vectors -> controller.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from robrst.certificate.mimo import check_models
from robrst.core.mimo import MimoPlant
from robrst.core.mimo_loop import MimoController
from robrst.problem.mimo import MimoProblem, MimoSolverOptions, MimoSpecs
from robrst.synthesis.mimo_program import (NYQUIST_FLOOR, PROGRAM_FIGURES, SECTOR_FIGURES,
                                           AxisParam, GridRows, MimoProgram, Sector)
from robrst.synthesis.mimo_start import (NYQUIST_EDGE, axis_plant, loop_plants,
                                         nu_of, program_grid, start_gain, static_decoupler)

__all__ = ["MimoRound", "design_axes", "decoupler_of", "per_axis_controller", "controller_of",
           "program_rounds"]



@dataclass(frozen=True)
class MimoRound:
    """One solve of the program and what the exact check said.

    Parameters
    ----------
    name : str
        Which design (``"axis1"``, ..., ``"joint"``).
    phase : {"soft", "hard"}
    status : str
        IPOPT's return status.
    iterations : int
    t : float
        The worst normalised grid figure of the candidate.
    stable : bool
        Every checked loop stable (after any pull-back).
    violations : int
        Violated bounds at the models (exact peaks).
    points : int
        Grid points of the solve.
    seconds : float
    """

    name: str
    phase: str
    status: str
    iterations: int
    t: float
    stable: bool
    violations: int
    points: int
    seconds: float


def decoupler_of(problem: MimoProblem) -> MimoController:
    """An identity-axis controller carrying only the problem's decoupler (its ``W``).

    Parameters
    ----------
    problem : MimoProblem

    Returns
    -------
    numpy.ndarray or tuple
        The static ``W`` (``none``: the identity), or the dynamic ``(A, B, C, D)``.
    """
    st = problem.structure
    m = problem.family.n_out
    if st.decoupler == "none":
        return np.eye(m)
    if st.decoupler == "static":
        return static_decoupler(problem.family.reference_model, st.decoupler_hz)
    return st.W if st.W is not None else st.decoupler_ss


def controller_of(axes: Sequence[AxisParam], x: np.ndarray, W: np.ndarray | tuple,
                  T_mode: str, names: Sequence[str]) -> MimoController:
    """The controller of the joint decision vector (every axis's, stacked) and a decoupler.

    Parameters
    ----------
    axes : sequence of AxisParam
    x : numpy.ndarray
        The axes' decision vectors, concatenated.
    W : numpy.ndarray or tuple
        Static decoupler, or a dynamic one ``(A, B, C, D)``.
    T_mode : str
    names : sequence of str

    Returns
    -------
    MimoController
    """
    offs = np.cumsum([0] + [a.n_x for a in axes])
    laws = [a.controller(x[offs[i]:offs[i + 1]], T_mode) for i, a in enumerate(axes)]
    if isinstance(W, tuple):
        return MimoController(laws, decoupler_ss=W, names=tuple(names))
    return MimoController(laws, np.asarray(W, float), names=tuple(names))


def per_axis_controller(axes: Sequence[AxisParam], xs: Sequence[np.ndarray],
                        W: np.ndarray | tuple,
                        T_mode: str, names: Sequence[str]) -> MimoController:
    """The controller of per-axis decision vectors and a decoupler.

    Parameters
    ----------
    axes : sequence of AxisParam
    xs : sequence of numpy.ndarray
        One decision vector per axis.
    W : numpy.ndarray or tuple
        Static decoupler, or a dynamic one ``(A, B, C, D)``.
    T_mode : str
    names : sequence of str

    Returns
    -------
    MimoController
    """
    return controller_of(axes, np.concatenate(xs), W, T_mode, names)


def _w_response(W, nu):
    """``(K, k, m)``: the decoupler's response at loop frequencies ``nu``."""
    if isinstance(W, tuple):
        return MimoPlant(*W, label="decoupler").freqresp(nu)
    return np.broadcast_to(np.asarray(W, float), (len(nu),) + np.shape(W)).astype(complex)


@dataclass
class _Grid:
    """The program's points: per loop, its physical frequencies (grown by the rounds)."""

    loops: list
    w: list

    def arrays(self, W, band):
        nus, Gs, Ws, xt = [], [], [], []
        for lp, w in zip(self.loops, self.w):
            nu = nu_of(w, lp.fs)
            nus.append(nu)
            Gs.append(lp.plant.freqresp(nu))
            Ws.append(_w_response(W, nu))
            xt.append((w >= band[0]) & (w <= band[1]))
        return (np.concatenate(nus), np.concatenate(Gs), np.concatenate(Ws),
                np.concatenate(xt))

    def segments(self):
        """``(K,)``: the loop of every point of :meth:`arrays`."""
        return np.repeat(np.arange(len(self.w)), [len(w) for w in self.w])

    def add(self, k, freqs):
        ws = [self.w[k]]
        for f in freqs:
            if f is None or not np.isfinite(f) or f <= 0:
                continue
            top = np.pi * self.loops[k].fs * NYQUIST_EDGE if self.loops[k].fs else np.inf
            ws.append(np.minimum(f * np.array([0.99, 0.996, 0.999, 1.0, 1.001, 1.004, 1.01]),
                                 top))
        self.w[k] = np.unique(np.concatenate(ws))

    @property
    def size(self):
        return int(sum(len(w) for w in self.w))


GRID_MARGIN = 0.02      # the program holds the bounds 2 % tighter than the certificate
EXCHANGES = 4           # row exchanges within one round (points violated but not selected)
SECTOR_LOW = 1e-5       # with sector rows, a point this far below the crossover scale


def _objective(axes, x, signs):
    """The least of the axes' log integral gains (what the hard phase maximises)."""
    offs = np.cumsum([0] + [a.n_x for a in axes])
    ks = [signs[i] * a.integral_gain(x[offs[i]:offs[i + 1]]) for i, a in enumerate(axes)]
    return float(np.log(min(ks))) if min(ks) > 0 else -np.inf


def program_rounds(name: str, models: Sequence[MimoPlant], specs: MimoSpecs,
                   axes: Sequence[AxisParam], W: np.ndarray | tuple, T_mode: str,
                   names: Sequence[str], x0: np.ndarray, signs: Sequence[float],
                   so: MimoSolverOptions, progress: Callable[[str], None], w_design: float,
                   rounds_out: list, extra_models: Sequence[MimoPlant] = ()
                   ) -> tuple[np.ndarray, bool, list]:
    """The program's rounds on ``models`` (module docstring, step 3).

    Parameters
    ----------
    name : str
        The design's name in the rounds' records.
    models : sequence of MimoPlant
    specs : MimoSpecs
    axes : sequence of AxisParam
    W : numpy.ndarray or tuple
        The decoupler.
    T_mode : str
    names : sequence of str
        The axes' names.
    x0 : numpy.ndarray
        The start (every axis's decision vector, stacked).
    signs : sequence of float
        Every axis's integral-gain sign.
    so : MimoSolverOptions
    progress : callable
        Receives progress lines.
    w_design : float
        The crossover scale [rad/s].
    rounds_out : list
        Receives a :class:`MimoRound` per solve.
    extra_models : sequence of MimoPlant
        Further models (points between members the certificate found violated).

    Returns
    -------
    x : numpy.ndarray
        The best decision vector found.
    ok : bool
        Whether its models check out.
    violations : list
        Its violations at the models.
    """
    ctrl_of = lambda x: controller_of(axes, x, W, T_mode, names)   # noqa: E731
    bounds = {f: b / (1 + GRID_MARGIN) for f, b in specs.bounded.items()
              if f in PROGRAM_FIGURES}
    xt_bound = specs.bounded.get("crosstalk") if T_mode == "feedback" else None
    xt_bound = None if xt_bound is None else xt_bound / (1 + GRID_MARGIN)
    band = specs.crosstalk_band_rad_s
    # the sector's figures: the scaled small-gain rows (one scaling per loop and figure,
    # program variables started at each round; the validation grid takes the program's)
    sector = {f: b / (1 + GRID_MARGIN) for f, b in specs.bounded.items()
              if f in SECTOR_FIGURES}
    delta = specs.input_gain_deviation
    allm = list(models) + list(extra_models)
    loops = loop_plants(allm, specs)

    def grid_rows():
        nu, G, Wr, xt = grid.arrays(W, band)
        sec = Sector(delta, sector, grid.segments()) if sector and delta else None
        return GridRows(axes, nu, G, Wr, bounds or {"sigma_S": 1e6}, xt_bound, xt, sec)

    # with a rate the sampled loops (the one that runs) get the full grid, the continuous
    # loops fewer log-spaced points (their resonances all the same); both gain the points
    # where the exact check finds a peak
    grid = _Grid(loops, [program_grid(allm[lp.model], lp.fs, w_design, so.n_freq)
                         if lp.fs or not specs.sampled else
                         program_grid(allm[lp.model], None, w_design, max(10, so.n_freq // 4))
                         for lp in loops])
    if sector:
        # the sector's rows hold delta Ti and delta U, flat below the crossover at their
        # values at 0 (T_i(0) = I with integral action): a point far below it
        grid.w = [np.unique(np.concatenate([[SECTOR_LOW * w_design], w])) for w in grid.w]
    ipopt = {"max_iter": so.max_iter, "tol": so.ipopt_tol, "print_level": 0, "sb": "yes",
             "acceptable_tol": 1e-5, "acceptable_iter": 5}
    # the validation grid: every candidate is evaluated there (numerically, cheap) and the
    # points it exceeds the bounds at join the program's grid before the exact check
    dense = []
    for lp in loops:
        w = program_grid(allm[lp.model], lp.fs, w_design, 4 * so.n_freq, dense=True)
        if sector:
            w = np.concatenate([[SECTOR_LOW * w_design], w])
        nu = nu_of(w, lp.fs)
        sec = Sector(delta, sector, np.zeros(len(nu), int)) if sector and delta else None
        dense.append((w, GridRows(axes, nu, lp.plant.freqresp(nu), _w_response(W, nu),
                                  bounds or {"sigma_S": 1e6}, xt_bound,
                                  (w >= band[0]) & (w <= band[1]), sec)))

    def share(rows):
        """The validation grid's sector scalings: the program's, loop by loop."""
        for k, (_, dr) in enumerate(dense):
            dr.set_scaling(scales={f: v[k:k + 1] for f, v in rows.scales.items()})

    def misses(x, limit):
        """Validation points above ``limit`` (local maxima, a few per loop) or out of the
        half-plane: ``{loop index: frequencies}``."""
        out = {}
        for k, (w, dr) in enumerate(dense):
            r = dr.ratios(x)
            worst = np.max(np.stack([v.reshape(dr.K, -1).max(1) for v in r.values()]), 0)
            hp = dr.halfplane(x)
            bad = np.flatnonzero((worst > limit * (1 + 0.25 * GRID_MARGIN))
                                 | (hp < 0.5 * NYQUIST_FLOOR))
            if bad.size:
                order = bad[np.argsort(-worst[bad])][:8]
                out[k] = list(w[order])
        return out

    def check(x):
        recs, viols = check_models(allm, ctrl_of(x), specs, so.cert_tol)
        stable = all(r.continuous.stable and (r.sampled is None or r.sampled.stable)
                     for r in recs)
        return stable, recs, viols

    x = np.asarray(x0, float)
    again = None            # the feasible point a round was last restarted from
    stable, recs, viols = check(x)
    best = (x, stable, viols) if stable else None
    feasible = x if stable and not viols else None
    for r in range(so.max_rounds):
        t0 = time.perf_counter()
        rows = grid_rows()
        nu = rows.nu
        if viols and feasible is not None and not (stable and again is feasible):
            # the last candidate missed a peak between points (now on the grid): solve again
            # from the last controller the exact check passed; but once only: a hard round
            # from it that ended outside the specs again goes on from where it ended (the
            # soft phase), or every round repeats the same failed solve with more rows
            x, stable, viols = feasible, True, []
            again = feasible
        rows.set_scaling(x)
        share(rows)
        t_start = rows.worst(x)
        phase = "hard" if t_start <= 1.0 + 2 * GRID_MARGIN else "soft"
        if stable:
            rows.set_reference(x)
            for _, dr in dense:
                dr.set_reference(x)
        rows.select(x)
        cand, sol = x, None
        for _ in range(EXCHANGES):
            sol = MimoProgram(rows, ipopt).solve(cand, max(t_start, 1.0) * 1.001, signs,
                                                 phase)
            if np.all(np.isfinite(sol["x"])):
                cand = sol["x"]
            share(rows)                               # the solve's sector scalings
            limit = 1.0 if phase == "hard" else sol["t"]
            hp = rows.halfplane(cand)
            out = [("nyquist", int(k)) for k in np.flatnonzero(hp < 0.999 * NYQUIST_FLOOR)]
            miss = misses(cand, limit)
            if rows.worst(cand) <= limit * (1 + 1e-6) and not out and not miss:
                break
            if miss:          # new points: the rows of a grown grid
                for k, fr in miss.items():
                    grid.add(k, fr)
                old_rows = rows
                rows = grid_rows()
                nu = rows.nu
                rows.set_scaling(scales=old_rows.scales)
                if old_rows.d0 is not None:
                    rows.set_reference(x)
                rows.select(cand, floor=0.3)
            else:
                rows.select(cand, floor=0.9 * limit, keep=list(rows.rows) + out)
        c_stable, c_recs, c_viols = check(cand)
        if not c_stable:
            # pull back towards the last stable controller; the unstable poles'
            # frequencies join the grid
            for f, k in _unstable_frequencies(c_recs, allm, ctrl_of(cand), specs):
                grid.add(k, [f])
            theta = 0.5
            while theta > 1e-3:
                trial = x + theta * (cand - x)
                c_stable, c_recs, c_viols = check(trial)
                if c_stable:
                    cand = trial
                    break
                theta *= 0.5
            if not c_stable:
                cand, c_stable, c_viols = x, stable, viols
        for v in c_viols:
            k = _loop_index(loops, allm, v)
            if k is not None:
                grid.add(k, [v.freq_rad_s])
        rounds_out.append(MimoRound(name, phase, sol["status"], sol["iterations"],
                                    float(sol["t"]), bool(c_stable), len(c_viols),
                                    len(nu), time.perf_counter() - t0))
        progress(f"  {name} round {r + 1}: {phase} {sol['status']} ({sol['iterations']}"
                 f" iterations, {len(rows.rows)} rows, {rows.K} points), t = {sol['t']:.4g},"
                 f" {'stable' if c_stable else 'UNSTABLE'},"
                 f" {len(c_viols)} violation(s)" + ("" if not c_viols else
                                                    " (worst " + max(c_viols, key=lambda v: v.ratio
                                                                     ).describe() + ")"))
        moved = not np.array_equal(cand, x)
        x, stable, viols = cand, c_stable, c_viols
        if stable and (best is None or _better(axes, x, viols, best, signs)):
            best = (x, stable, viols)
        if stable and not viols and (feasible is None or _objective(axes, x, signs) >=
                                     _objective(axes, feasible, signs)):
            feasible = x
        if stable and not viols and phase == "hard":
            break
        if not moved and not viols:
            break
    if best is None:
        best = (x, stable, viols)
    return best


def _better(axes, x, viols, best, signs):
    """``x`` beats ``best``: fewer violations, then a larger objective."""
    bx, _, bv = best
    if bool(viols) != bool(bv):
        return not viols
    if viols:
        return max(v.ratio for v in viols if np.isfinite(v.ratio)) < max(
            [v.ratio for v in bv if np.isfinite(v.ratio)] or [np.inf]) if any(
            np.isfinite(v.ratio) for v in viols) else False
    return _objective(axes, x, signs) > _objective(axes, bx, signs)


def _loop_index(loops, models, v):
    """The loop of a violation (its model's label and loop)."""
    for k, lp in enumerate(loops):
        if models[lp.model].label == v.label and lp.loop == v.loop:
            return k
    return None


def _unstable_frequencies(recs, models, ctrl, specs):
    """``(frequency, loop index)`` of the least stable closed-loop poles of every
    unstable loop (physical rad/s)."""
    from robrst.core.mimo import sampled_mimo
    from robrst.core.mimo_loop import mimo_loop
    from robrst.core.sampled import unwarp

    out = []
    k = 0
    for rec, mdl in zip(recs, models):
        for loop in ("continuous", "sampled"):
            lf = rec.loop(loop)
            if lf is None:
                continue
            if not lf.stable:
                plant = mdl if loop == "continuous" else sampled_mimo(
                    mdl, specs.sample_rate_hz, specs.delay_samples)
                p = mimo_loop(plant, ctrl).poles
                bad = p[p.real >= 0]
                for z in bad[:6]:
                    f = abs(z.imag) or abs(z.real)
                    if loop == "sampled":
                        f = float(unwarp(f, specs.sample_rate_hz))
                    out.append((f, k))
            k += 1
    return out


def design_axes(models: Sequence[MimoPlant], W: np.ndarray | tuple, specs: MimoSpecs,
                axis: AxisParam, so: MimoSolverOptions, names: Sequence[str], T_mode: str,
                progress: Callable[[str], None],
                w_design: float, rounds_out: list,
                optimize: bool = True) -> tuple[list[np.ndarray], list[float]]:
    """Every axis designed alone on its diagonal channel ``(G W)_ii`` over the models.

    Parameters
    ----------
    models : sequence of MimoPlant
        Continuous models.
    W : numpy.ndarray
        The static decoupler (the identity: each axis on ``G_ii``, the coupling ignored).
    specs : MimoSpecs
        The problem's specs (the sigma bounds of ``S`` and ``T`` apply to each axis's
        loop; the rate and delay).
    axis : AxisParam
        The structure of every axis.
    so : MimoSolverOptions
    names : sequence of str
    T_mode : str
    progress : callable
    w_design : float
    rounds_out : list
        Receives the rounds.
    optimize : bool
        Run the program's rounds on each axis (``False``: the integral-gain scan only).

    Returns
    -------
    xs : list of numpy.ndarray
        One decision vector per axis.
    signs : list of float
        Each axis's integral-gain sign.
    """
    one = MimoSpecs(sigma_S_max=specs.sigma_S_max, sigma_T_max=specs.sigma_T_max,
                    sample_rate_hz=specs.sample_rate_hz, delay_samples=specs.delay_samples)
    if not one.bounded:
        one = MimoSpecs(sigma_S_max=2.0, sample_rate_hz=specs.sample_rate_hz,
                        delay_samples=specs.delay_samples)
    Wm = W if not isinstance(W, tuple) else np.real(MimoPlant(*W).freqresp([0.0])[0])
    xs, signs = [], []
    for i, nm in enumerate(names):
        chan = [axis_plant(mdl, Wm, i) for mdl in models]
        loops = loop_plants(chan, one)
        grids = [program_grid(chan[lp.model], lp.fs, w_design, max(40, so.n_freq // 2))
                 for lp in loops]
        gain, sign = start_gain(loops, axis, one.bounded, grids)
        if gain == 0.0:
            gain = sign * 1e-4 / max(abs(chan[0].freqresp([w_design])[0][0, 0]), 1e-300)
        x = axis.start(gain)
        progress(f"  {nm}: integral-gain scan, scaled gain {gain:.4g}")
        if optimize:
            x, _, _ = program_rounds(nm, chan, one, [axis], np.eye(1), T_mode, [nm], x, [sign], so,
                              progress, w_design, rounds_out)
        xs.append(x)
        signs.append(sign)
    return xs, signs
