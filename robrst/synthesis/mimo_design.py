"""The multi-axis design pipeline: per-axis starts, the joint robust program, the certificate.

:func:`design_mimo` takes a :class:`~robrst.problem.mimo.MimoProblem` to a
:class:`MimoDesignResult`:

1. **Decoupler** (``static``: :func:`robrst.synthesis.mimo_start.static_decoupler` of the
   reference model; ``given``; ``none``).
2. **Per-axis designs** (the start): each axis designed alone on its diagonal channel
   ``(G W)_ii`` over every model and loop of the family (:func:`design_axes`): a rolled-off
   integral law scanned to the largest stable gain that meets the bounds; with method
   ``per_axis`` (and for the comparison below) the same program in its 1 x 1 form then
   maximises each axis's integral gain.
3. **The joint program** (method ``nlp``, :mod:`robrst.synthesis.mimo_program`): every
   axis, the coupling and every model at once.  Rounds: solve on the grid; check the
   models exactly (:func:`robrst.certificate.mimo.check_models`); a violated figure's
   frequency joins the grid, an unstable candidate is pulled back towards the last
   stable controller (halving the step) and the unstable poles' frequencies join the
   grid; then the full certificate, whose violated points between models join the program
   as further models.
4. **Always an answer**: the best certified controller, else the best found, with its
   certificate and the binding figure (the largest ratio to its bound) named.
5. **The comparison**: the per-axis designs certified on the whole loop, and (``compare``)
   the three loops designed one by one on ``G_ii`` ignoring the coupling (no decoupler),
   on the same certificate.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.certificate.mimo import MimoCertificate, certify_mimo, check_models
from robrst.core.mimo import MimoFamily, MimoPlant, combination
from robrst.core.mimo_loop import MimoController
from robrst.problem.mimo import MimoProblem, MimoSolverOptions, MimoSpecs
from robrst.synthesis.mimo_program import (NYQUIST_FLOOR, PROGRAM_FIGURES, AxisParam, GridRows,
                                           MimoProgram)
from robrst.synthesis.mimo_start import (LoopPlant, axis_plant, design_scale, loop_plants,
                                         nu_of, program_grid, start_gain, static_decoupler)

__all__ = ["MimoRound", "MimoDesignResult", "design_mimo", "design_axes", "decoupler_of",
           "per_axis_controller"]



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


@dataclass(frozen=True, eq=False)
class MimoDesignResult:
    """What :func:`design_mimo` returns (always an answer).

    Parameters
    ----------
    problem : MimoProblem
    controller : MimoController
        The answer: the best certified controller, else the best found.
    certificate : MimoCertificate
        Its certificate over the whole family.
    binding : dict
        The figure with the largest ratio to its bound: ``figure, ratio, model, loop``.
    rounds : tuple of MimoRound
    start : MimoController
        The per-axis designs with the decoupler (the program's start).
    comparisons : dict
        ``{name: {"controller", "certificate", "note"}}``: the per-axis start and (with
        ``compare``) the per-axis designs that ignore the coupling.
    w_design : float
        The start's crossover [rad/s].
    seconds : float
        Wall time.

    Attributes
    ----------
    certified : bool
    """

    problem: MimoProblem
    controller: MimoController
    certificate: MimoCertificate
    binding: dict
    rounds: tuple
    start: MimoController
    comparisons: dict = field(default_factory=dict)
    w_design: float = 0.0
    seconds: float = 0.0

    @property
    def certified(self) -> bool:
        return self.certificate.certified

    def integral_gains(self) -> list[float]:
        """Every axis's integral gain ``lim s R_i/S_i`` [V/(µm s)] (before the decoupler).

        Returns
        -------
        list of float
        """
        out = []
        for c in self.controller.axes:
            S = np.trim_zeros(c.S, "b")
            out.append(float(c.R[-1] / S[-1]) if len(S) < len(c.S) else 0.0)
        return out

    def as_dict(self) -> dict:
        """The design as one JSON-ready object.

        Returns
        -------
        dict
            ``kind = "mimo"``, ``problem``, ``certified``, ``controller``, ``certificate``,
            ``binding``, ``integral_gains``, ``rounds``, ``comparisons`` (their certified
            flag, ratios and violations), ``seconds``.
        """
        p = self.problem
        return {
            "kind": "mimo", "problem": p.name, "certified": self.certified,
            "axes": list(p.axes), "parameter": p.family.parameter, "unit": p.family.unit,
            "models": [m.label for m in p.family.models],
            "values": [m.value for m in p.family.models],
            "specs": p.specs.as_dict(), "method": p.solver.method,
            "controller": self.controller.as_dict(),
            "integral_gains": self.integral_gains(),
            "w_design_rad_s": self.w_design,
            "binding": self.binding,
            "certificate": self.certificate.as_dict(),
            "rounds": [r.__dict__ for r in self.rounds],
            "comparisons": {k: {"certified": v["certificate"].certified,
                                "note": v["note"],
                                "ratios": v["certificate"].ratios(),
                                "controller": v["controller"].as_dict(),
                                "violations": [x.as_dict() for x in
                                               v["certificate"].violations[:20]],
                                "members": [m.as_dict() for m in v["certificate"].members()]}
                            for k, v in self.comparisons.items()},
            "seconds": self.seconds,
        }


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


def _controller(axes: Sequence[AxisParam], x: np.ndarray, W, T_mode: str,
                names: Sequence[str]) -> MimoController:
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
    return _controller(axes, np.concatenate(xs), W, T_mode, names)


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

    def add(self, k, freqs):
        ws = [self.w[k]]
        for f in freqs:
            if f is None or not np.isfinite(f) or f <= 0:
                continue
            top = np.pi * self.loops[k].fs * 0.9995 if self.loops[k].fs else np.inf
            ws.append(np.minimum(f * np.array([0.99, 0.996, 0.999, 1.0, 1.001, 1.004, 1.01]),
                                 top))
        self.w[k] = np.unique(np.concatenate(ws))

    @property
    def size(self):
        return int(sum(len(w) for w in self.w))


GRID_MARGIN = 0.02      # the program holds the bounds 2 % tighter than the certificate
EXCHANGES = 4           # row exchanges within one round (points violated but not selected)


def _objective(axes, x, signs):
    """The least of the axes' log integral gains (what the hard phase maximises)."""
    offs = np.cumsum([0] + [a.n_x for a in axes])
    ks = [signs[i] * a.integral_gain(x[offs[i]:offs[i + 1]]) for i, a in enumerate(axes)]
    return float(np.log(min(ks))) if min(ks) > 0 else -np.inf


def _rounds(name, models, specs, axes, W, T_mode, names, x0, signs, so, progress,
            w_design, rounds_out, extra_models=()):
    """The program's rounds on ``models`` (module docstring, step 3); returns the best
    decision vector found, whether its models check out, and its violations."""
    ctrl_of = lambda x: _controller(axes, x, W, T_mode, names)   # noqa: E731
    bounds = {f: b / (1 + GRID_MARGIN) for f, b in specs.bounded.items()
              if f in PROGRAM_FIGURES}
    xt_bound = specs.bounded.get("crosstalk") if T_mode == "feedback" else None
    xt_bound = None if xt_bound is None else xt_bound / (1 + GRID_MARGIN)
    band = specs.crosstalk_band_rad_s
    allm = list(models) + list(extra_models)
    loops = loop_plants(allm, specs)
    # with a rate the sampled loops (the one that runs) get the full grid, the continuous
    # loops fewer log-spaced points (their resonances all the same); both gain the points
    # where the exact check finds a peak
    grid = _Grid(loops, [program_grid(allm[lp.model], lp.fs, w_design, so.n_freq)
                         if lp.fs or not specs.sampled else
                         program_grid(allm[lp.model], None, w_design, max(10, so.n_freq // 4))
                         for lp in loops])
    ipopt = {"max_iter": so.max_iter, "tol": so.ipopt_tol, "print_level": 0, "sb": "yes",
             "acceptable_tol": 1e-5, "acceptable_iter": 5}
    # the validation grid: every candidate is evaluated there (numerically, cheap) and the
    # points it exceeds the bounds at join the program's grid before the exact check
    dense = []
    for lp in loops:
        w = program_grid(allm[lp.model], lp.fs, w_design, 4 * so.n_freq, dense=True)
        nu = nu_of(w, lp.fs)
        dense.append((w, GridRows(axes, nu, lp.plant.freqresp(nu), _w_response(W, nu),
                                  bounds or {"sigma_S": 1e6}, xt_bound,
                                  (w >= band[0]) & (w <= band[1]))))

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
    stable, recs, viols = check(x)
    best = (x, stable, viols) if stable else None
    feasible = x if stable and not viols else None
    for r in range(so.max_rounds):
        t0 = time.perf_counter()
        nu, G, Wr, xt = grid.arrays(W, band)
        rows = GridRows(axes, nu, G, Wr, bounds or {"sigma_S": 1e6}, xt_bound, xt)
        if viols and feasible is not None:
            # the last candidate missed a peak between points (now on the grid): solve again
            # from the last controller the exact check passed
            x, stable, viols = feasible, True, []
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
            limit = 1.0 if phase == "hard" else sol["t"]
            hp = rows.halfplane(cand)
            out = [("nyquist", int(k)) for k in np.flatnonzero(hp < 0.999 * NYQUIST_FLOOR)]
            miss = misses(cand, limit)
            if rows.worst(cand) <= limit * (1 + 1e-6) and not out and not miss:
                break
            if miss:          # new points: the rows of a grown grid
                for k, fr in miss.items():
                    grid.add(k, fr)
                nu, G, Wr, xt = grid.arrays(W, band)
                old_rows = rows
                rows = GridRows(axes, nu, G, Wr, bounds or {"sigma_S": 1e6}, xt_bound, xt)
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
                 f" iterations, {len(rows.rows)} rows, {rows.K} points), t = {sol['t']:.4g}, {'stable' if c_stable else 'UNSTABLE'},"
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
                axis: AxisParam, so: MimoSolverOptions, names: Sequence[str], T_mode: str, progress: Callable[[str], None],
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
            x, _, _ = _rounds(nm, chan, one, [axis], np.eye(1), T_mode, [nm], x, [sign], so,
                              progress, w_design, rounds_out)
        xs.append(x)
        signs.append(sign)
    return xs, signs


def _binding(cert: MimoCertificate) -> dict:
    """The figure with the largest ratio to its bound (or the first violation's)."""
    best = None
    for rec in cert.models:
        for loop in ("continuous", "sampled"):
            lf = rec.loop(loop)
            if lf is None:
                continue
            if not lf.stable:
                return {"figure": "stability", "ratio": np.inf, "model": rec.label,
                        "loop": loop}
            for fig, b in cert.bounds.items():
                v = lf.value(fig)
                if v is not None and (best is None or v / b > best["ratio"]):
                    best = {"figure": fig, "ratio": v / b, "model": rec.label, "loop": loop}
    if best is None and cert.violations:
        v = cert.violations[0]
        best = {"figure": v.quantity, "ratio": v.ratio, "model": v.label, "loop": v.loop}
    return best or {}


def design_mimo(problem: MimoProblem, progress: Callable[[str], None] | None = None,
                compare: bool = True) -> MimoDesignResult:
    """Design and certify a decentralised multi-axis controller (module docstring).

    Parameters
    ----------
    problem : MimoProblem
    progress : callable, optional
        Receives progress lines.
    compare : bool
        Also design the axes one by one ignoring the coupling (no decoupler) and certify
        them on the same family and specs.

    Returns
    -------
    MimoDesignResult
        Always an answer (module docstring, step 4).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoFamily, MimoPlant
    >>> from robrst.problem.mimo import MimoProblem, MimoSpecs, MimoSolverOptions
    >>> G = MimoPlant(-100.0 * np.eye(2), 100.0 * np.eye(2), [[1.0, 0.2], [0.1, 1.0]],
    ...               np.zeros((2, 2)))
    >>> pr = MimoProblem("stage", MimoFamily((G,)), specs=MimoSpecs(sigma_S_max=2.0),
    ...                  solver=MimoSolverOptions(max_rounds=2))
    >>> design_mimo(pr, compare=False).certified
    True
    """
    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    st, specs, so = problem.structure, problem.specs, problem.solver
    fam = problem.family
    names = problem.axes
    W = decoupler_of(problem)
    w_design = design_scale(fam.reference_model, specs, so.bandwidth_hz)
    axis = AxisParam.of(w_design, st.extra_degree, st.relative_degree, st.roll_off_order,
                        st.roll_off_hz)
    rounds = []
    models = list(fam.models)
    say(f"designing {problem.name}: {fam.n_out} axes, {len(models)} model(s) over"
        f" {fam.parameter}, crossover scale {w_design / (2 * np.pi):.4g} Hz")
    # the start: each axis alone on (G W)_ii, its integral-gain scan (the per-axis method:
    # the program's rounds too)
    xs, signs = design_axes(models, W, specs, axis, so, names, st.T_mode, say, w_design,
                            rounds, optimize=so.method == "per_axis")
    axes = [axis] * len(names)
    start = per_axis_controller(axes, xs, W, st.T_mode, names)
    comparisons = {"per_axis_start": {"controller": start, "note":
                                      "each axis designed alone on (G W)_ii with the"
                                      " decoupler; the joint program's start"}}
    best_ctrl = start
    if so.method == "nlp":
        x0 = np.concatenate(xs)
        recs, viols = check_models(models, start, specs, so.cert_tol)
        shrink = 1.0
        while not all(r.continuous.stable and (r.sampled is None or r.sampled.stable)
                      for r in recs) and shrink > 1e-3:
            shrink *= 0.5       # the coupling destabilises the per-axis start: less gain
            x0 = np.concatenate([np.concatenate([x[:axis.d], shrink * x[axis.d:]])
                                 for x in xs])
            recs, viols = check_models(models, per_axis_controller(
                axes, [x0[i * axis.n_x:(i + 1) * axis.n_x] for i in range(len(xs))], W,
                st.T_mode, names), specs, so.cert_tol)
        extra = []
        for attempt in range(3):
            x, _, _ = _rounds("joint", models, specs, axes, W, st.T_mode, names, x0, signs,
                              so, say, w_design, rounds, extra)
            ctrl = _controller(axes, x, W, st.T_mode, names)
            say("certifying the joint design over the whole family")
            cert = certify_mimo(fam, ctrl, specs, so.cert_tol, so.cert_points)
            best_ctrl = ctrl
            if cert.certified:
                break
            bad = [v for v in cert.violations if v.kind in ("exceeds", "unstable")
                   and v.value_param is not None
                   and not any(v.label == m.label for m in models)]
            new = []
            for v in bad:
                plant = fam.at(v.value_param)
                if not any(plant.value == e.value for e in extra):
                    new.append(plant)
            if not new:
                break
            say(f"  {len(new)} point(s) between models violated: added to the program")
            extra += new[:4]
            x0 = x
        certificate = cert
    else:
        say("certifying the per-axis designs over the whole family")
        certificate = certify_mimo(fam, start, specs, so.cert_tol, so.cert_points)
    if so.method == "nlp":
        say("certifying the per-axis start over the whole family")
        comparisons["per_axis_start"]["certificate"] = certify_mimo(
            fam, start, specs, so.cert_tol, so.cert_points)
        if not certificate.certified and comparisons["per_axis_start"]["certificate"].certified:
            best_ctrl, certificate = start, comparisons["per_axis_start"]["certificate"]
    else:
        comparisons["per_axis_start"]["certificate"] = certificate
    if compare and fam.n_out > 1:
        say("designing the axes one by one on G_ii, ignoring the coupling (no decoupler)")
        ident = np.eye(fam.n_out)
        xs2, _ = design_axes(models, ident, specs, axis, replace(so, max_rounds=min(
            so.max_rounds, 3)), names, st.T_mode, say, w_design, rounds)
        naive = per_axis_controller(axes, xs2, ident, st.T_mode, names)
        say("certifying them on the coupled plant")
        comparisons["ignoring_coupling"] = {
            "controller": naive, "certificate": certify_mimo(fam, naive, specs, so.cert_tol,
                                                             so.cert_points),
            "note": "each axis designed alone on G_ii (no decoupler), the coupling ignored"}
    return MimoDesignResult(problem=problem, controller=best_ctrl, certificate=certificate,
                            binding=_binding(certificate), rounds=tuple(rounds), start=start,
                            comparisons=comparisons, w_design=w_design,
                            seconds=time.perf_counter() - t0)
