"""Screening: every candidate scored by an exact linear least-squares fit, before any
nonlinear fit.

Around the linear re-fit ``theta_L`` each candidate adds *columns*: outputs of the exact
linear part (:class:`~robrst.diagnose.linear.LinearPart` at ``theta_L``) for basis signals
of the input, or output-side signals.  A candidate's screening model is

    y = y_L + J_L dtheta + X_e beta

(``J_L`` the linear corrections' Jacobian at ``theta_L``, regularised by their priors),
fitted on the training records and scored on the held-out records.  Every column is
computed once per record (simulated over the whole record); the training and held-out
Gram matrices ``X^T X``, ``X^T r``, ``r^T r`` are accumulated once on every k-th sample
(at most :data:`SCREEN_SAMPLES` rows per record), so any set of candidates is fitted
exactly by a small linear solve, without another pass over the data.  The held-out records
need no column of the input side: a candidate's coefficients (fitted on the training
records) combine its basis signals into one signal per input, and one pass of the linear
part over that signal gives its held-out prediction exactly (the linear part is linear) —
one pass per candidate scored instead of one per column.  Columns per candidate:

* ``output_offset``: one constant per output
* ``output_nonlinearity``: ``(y_L - c)^2``, ``(y_L - c)^3`` per output (sensor curvature)
* ``cross_coupling``: ``L_i(u_j)`` (input mixing) and ``y_L,l`` on output ``i`` (output)
* ``input_nonlinearity``: ``L((u - c)^2)``, ``L((u - c)^3)``, hinges ``L(max(u - k, 0))`` at
  quantiles of ``u`` (dead zones, any static map)
* ``saturation``: one or two hinges at extreme quantiles (the best pair)
* ``slew``: ``L(slew_r(u) - u)`` rising and falling, the best rate ``r``
* ``hysteresis``: ``L(play_r(u) - u)`` for the play thresholds (a Prandtl–Ishlinskii
  operator), or Bouc–Wen's output and derivatives about three points: the better option
  tells the form to fit first
* ``creep``: ``L(S(u))``, ``L(dT+ S(u))`` (the creep cells' sum)
* ``thermal_drift``: ``L(lag_tau(T) - T_0)``, the best lag ``tau``
* ``thermal_dynamics``: ``dT J_L`` of the gain, the resonances and their damping
* ``delay``: ``L(u(t - d) - u(t))`` with ``d`` by exact search
* ``stiffness_nonlinearity``: ``L(y_L^3) / D(0)`` (first order in the cubic stiffness)
* ``amplitude_dependent_dynamics``: ``f J_L``, ``f`` the record's level factor (periodic
  records, >= 2 levels; the residues' slopes are fitted after)

The screen is exact for the candidates linear in their parameters (offset, sensor
curvature, cross-coupling, input maps with these knots, Prandtl–Ishlinskii with these
thresholds, creep) and first order for the others; a candidate that passes is then
fitted by its own nonlinear model (:mod:`robrst.diagnose.select`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal

from robrst.diagnose.effects import SPECS, creep_cells, pi_thresholds
from robrst.diagnose.fit import level_factor, model_jacobian
from robrst.diagnose.stages import cached_stage

if TYPE_CHECKING:
    from robrst.diagnose.fit import Fitted

__all__ = ["Screen", "ScreenFit", "HeldOut", "build_screen", "SCREEN_SAMPLES"]

SCREEN_SAMPLES = 100_000      # Gram rows per record (every k-th sample of the whole record)
SAT_HIGH = (0.8, 0.9, 0.95, 0.98, 0.995)
SAT_LOW = (0.005, 0.02, 0.05, 0.1, 0.2)
DRIFT_LAGS_S = (0.3, 1.0, 3.0, 10.0, 30.0, 100.0)
SLEW_FRACTIONS = (0.3, 0.1, 0.03, 0.01)   # slew rates / fastest input step
BW_B_REL = (0.3, 1.0, 3.0)    # Bouc–Wen's B x peak-to-peak input at the screen's points
BW_RATIOS = (1.0,)            # ... and Gamma / B (its derivative is a column)
DZ_WIDTHS = (0.01, 0.03, 0.06)   # dead-zone half widths screened / peak-to-peak input
BATCH = 16                    # input-side columns simulated together
RIDGE = 1e-9                  # relative ridge on the (normalised) effect columns


@dataclass(frozen=True, eq=False)
class HeldOut:
    """A held-out record of a screen: what scores any candidate on it by one prediction.

    Parameters
    ----------
    rows : slice
        The screened samples.
    r : numpy.ndarray
        The base's residual on them ``(Ns, m)``.
    direct : dict
        ``{column: (Ns, m) values}``: the columns computed without the linear part (the
        base's Jacobian, output-side columns).
    signals : dict
        ``{column: (input, (N,) basis signal)}``: the input-side columns' signals.
    lin : LinearPart
        The linear part the input-side signals go through.
    theta : numpy.ndarray
        Its corrections on this record.
    periodic : bool
        Steady state (else from rest).
    """

    rows: slice
    r: np.ndarray
    direct: dict
    signals: dict
    lin: object
    theta: np.ndarray
    periodic: bool

    def residual_ss(self, cols: Sequence[int], beta: np.ndarray) -> float:
        """Sum of squares of the residual left by the columns ``cols`` with ``beta``.

        Parameters
        ----------
        cols : sequence of int
            Column indices.
        beta : numpy.ndarray
            Their coefficients.

        Returns
        -------
        float
        """
        pred = np.zeros_like(self.r)
        V = {}
        for c, b in zip(cols, beta):
            if c in self.direct:
                pred += b * self.direct[c]
            elif c in self.signals:
                j, x = self.signals[c]
                V[j] = V.get(j, 0.0) + b * x
        if V:
            js = sorted(V)
            Y = self.lin.simulate_inputs(self.theta, np.column_stack([V[j] for j in js]), js,
                                         self.periodic)
            pred += Y.sum(axis=2)[self.rows]
        return float(np.sum((self.r - pred) ** 2))


@dataclass(frozen=True)
class ScreenFit:
    """A screened candidate (or the base alone): held-out and training gaps, coefficients.

    Parameters
    ----------
    keys : tuple of str
        The candidate (empty: the base alone).
    gap, train_gap : float
        Held-out and training NRMSE on the screened samples.
    beta : dict
        The solved coefficients by column name.
    options : dict
        ``{candidate: the option used}``.
    """

    keys: tuple
    gap: float               # held-out NRMSE (on the screened samples)
    train_gap: float
    beta: dict               # column name -> coefficient
    options: dict = field(default_factory=dict)   # candidate -> the option chosen


class Screen:
    """Columns, Gram matrices and exact solves for the candidates (see the module doc).

    ``groups[key]`` is a list of *options*, each a list of column indices; a candidate with
    several options (saturation knots, slew rates, drift lags) uses the one that fits the
    training records best.  ``base`` holds the base columns (the linear corrections, or the
    fitted candidate screened upon), always in.  The Gram matrices are kept per *block*: the
    base alone (key ``""``) and the base with each candidate's columns, so a candidate is
    screened alone on the base (one block), never two candidates together.

    Parameters
    ----------
    names : list of str
        Column names (``candidate:column``).
    groups : dict
        ``{candidate: [option columns, ...]}``.
    base : list of int
        The base columns.
    blocks : dict
        ``{candidate or "": (column indices, {"train": Gram}, {"train": X^T r})}``.
    c, den : dict
        Per split (``train``, ``test``): ``r^T r`` and the NRMSE denominator.
    ridge : tuple of numpy.ndarray
        Ridge weights and centres per column (the linear corrections' priors).
    starts : dict, optional
        ``{candidate: [start values per option]}``.
    fixed : sequence of int
        Base columns held (pinned corrections).
    held_out : sequence of HeldOut
        The held-out records, each scored by one prediction per candidate.
    """

    def __init__(self, names: list, groups: dict, base: list, blocks: dict, c: dict,
                 den: dict, ridge: tuple, starts: dict | None = None,
                 fixed: Sequence[int] = (), held_out: Sequence[HeldOut] = ()) -> None:
        self.names = names
        self.held_out = list(held_out)     # the held-out records (scored by prediction)
        self.fixed = set(fixed)            # base columns held (pinned corrections)
        self.starts = starts or {}         # candidate -> per option: start values by name
        self.groups = groups
        self.base = base
        self.blocks = blocks               # key -> (idx, {"train": Gram}, {"train": X^T r})
        self.c, self.den = c, den          # per split: r^T r and the NRMSE denominator
        self.ridge = ridge                 # (diag, centre) on the base columns
        self._cache = {}
        self._choice = {}

    def keys(self) -> list:
        """The candidates screened.

        Returns
        -------
        list of str
        """
        return [k for k, opts in self.groups.items() if opts and any(opts)]

    def _solve(self, key, cols, test=True):
        cols = [c for c in cols if c not in self.fixed]
        idx, G, b = self.blocks[key]
        pos = np.searchsorted(idx, np.asarray(cols, int))
        A = G["train"][np.ix_(pos, pos)].copy()
        rhs = b["train"][pos].copy()
        d, centre = self.ridge
        cc = np.asarray(cols, int)
        dd = d[cc]
        A[np.diag_indices_from(A)] += dd + RIDGE * np.maximum(np.diag(A), 1e-300)
        rhs += dd * centre[cc]
        s = np.sqrt(np.maximum(np.diag(A), 1e-300))
        beta = np.linalg.lstsq(A / s[:, None] / s[None, :], rhs / s, rcond=1e-12)[0] / s
        ss = self.c["train"] - 2 * beta @ b["train"][pos] + beta @ G["train"][np.ix_(
            pos, pos)] @ beta
        gaps = {"train": float(np.sqrt(max(ss, 0.0) / self.den["train"]))}
        if test:
            ss = sum(h.residual_ss(cols, beta) for h in self.held_out)
            gaps["test"] = float(np.sqrt(ss / self.den["test"])) if self.den["test"] > 0 \
                else 0.0
        return beta, gaps

    def option(self, key: str) -> int:
        """Index of the option of ``key`` that fits the training records best (alone).

        Parameters
        ----------
        key : str
            The candidate.

        Returns
        -------
        int
        """
        if key not in self._choice:
            opts = self.groups[key]
            best = min(range(len(opts)), key=lambda i: self._solve(
                key, list(self.base) + list(opts[i]), test=False)[1]["train"])
            self._choice[key] = best
        return self._choice[key]

    def start(self, key: str) -> dict:
        """Starting values (effect parameters by name) of the option ``key`` uses.

        Parameters
        ----------
        key : str
            The candidate.

        Returns
        -------
        dict
        """
        opts = self.starts.get(key)
        return dict(opts[self.option(key)]) if opts else {}

    def fit(self, keys: Sequence[str]) -> ScreenFit:
        """One candidate (``keys`` = ``(key,)``) or the base alone (``()``), solved exactly.

        Parameters
        ----------
        keys : sequence of str
            At most one candidate.

        Returns
        -------
        ScreenFit

        Raises
        ------
        ValueError
            More than one candidate.
        """
        keys = tuple(sorted(set(keys)))
        if len(keys) > 1:
            raise ValueError("a screen scores one candidate at a time on its base")
        if keys not in self._cache:
            cols, opts = list(self.base), {}
            for k in keys:
                i = self.option(k)
                opts[k] = i
                cols += [c for c in self.groups[k][i] if c not in cols]
            beta, gaps = self._solve(keys[0] if keys else "", cols)
            self._cache[keys] = ScreenFit(keys, gaps["test"], gaps["train"],
                                          {self.names[c]: float(v) for c, v in zip(cols, beta)},
                                          opts)
        return self._cache[keys]

    def before(self) -> tuple:
        """Gaps of the base prediction itself on the screened samples (no column).

        Returns
        -------
        held_out, training : float
        """
        return (float(np.sqrt(self.c["test"] / self.den["test"])),
                float(np.sqrt(self.c["train"] / self.den["train"])))


def _fit_names(fit):
    """Names of a fitted candidate's parameters (chain, linear corrections, slopes, blocks)."""
    names = list(fit.chain.names) + (list(fit.lin.names) if fit.joint else [])
    names += [f"slope{i}" for i in fit.slopes]
    return names + (fit.post.names() if fit.post is not None else [])


def _play_columns(cache, U, temp, thresholds, fs, ref, warm):
    """``play_r(u) - u`` per threshold ``(N, n)`` for one input (memory at 0 V at rest)."""
    st = cached_stage(cache, "pi_hysteresis", fs, ref, thresholds_V=tuple(thresholds))
    _, d = st.run(U, temp, np.zeros(len(thresholds)))
    return d[warm:]


def _bw_starts(stats, n_in=1):
    """Bouc–Wen points the screen linearises about: ``z = (A, log10 B, Gamma/B, gain)``
    (symmetric loops only for several inputs: the columns grow with the inputs)."""
    b_max = SPECS["hysteresis"].bounds(stats)[1][1]
    out = []
    for b_rel in BW_B_REL:
        for ratio in (BW_RATIOS if n_in == 1 else BW_RATIOS[-1:]):
            out.append(np.array([0.4, min(np.log10(b_rel / stats["u_ptp"]), b_max - 0.05),
                                 ratio, 1.0]))
    return out


def _bw_columns(cache, U, temp, z0, fs, ref, warm):
    """Bouc–Wen at ``z0``: ``v - u`` and ``dv/d(A, log10 B, Gamma/B)``, ``(N, 4)``."""
    st = cached_stage(cache, "hysteresis", fs, ref)
    sp = SPECS["hysteresis"]
    v, dv = st.run(U, temp, sp.twin(z0))
    D = dv @ sp.dtwin(z0)
    return np.column_stack([v - U, D[:, :3]])[warm:]


def _slew_columns(cache, U, temp, rate, fs, ref, warm):
    """``slew(u) - u`` limited rising only and falling only, ``(N, 2)``."""
    st = cached_stage(cache, "slew", fs, ref)
    big = 1e6 * rate
    up, _ = st.run(U, temp, np.array([rate, big]))
    dn, _ = st.run(U, temp, np.array([big, rate]))
    return np.column_stack([up - U, dn - U])[warm:]


def build_screen(setup: "Setup", theta: np.ndarray | None, delays: Sequence[int] | None = None,
                 level_ref: float | None = None, dynamic_model: bool = False,
                 say: Callable[[str], None] | None = None, stages: dict | None = None,
                 base_fit: Fitted | None = None) -> Screen:
    """The :class:`Screen` of every candidate in ``setup.effects`` around ``theta``.

    Parameters
    ----------
    setup : Setup
        The diagnosis's shared state (:class:`robrst.diagnose.select.Setup`).
    theta : array
        The linear re-fit's corrections (``theta_L``).
    delays : tuple of int, optional
        Whole-sample delay per input (from the exact search).
    level_ref : float, optional
        Reference level of the amplitude-dependent dynamics (the lowest training level).
    dynamic_model : bool
        Screen the amplitude-dependent dynamics.
    say : callable, optional
        Progress lines.
    stages : dict, optional
        Compiled effect stages already built in this diagnosis (filled as needed).
    base_fit : Fitted, optional
        Screen on top of this fitted candidate instead of the linear part at ``theta``: its
        prediction is the base, its parameters' Jacobian the base columns (the linear
        corrections regularised by their priors), and the candidates' columns go through
        its linear part.

    Returns
    -------
    Screen
    """
    lin = setup.lin
    stages = {} if stages is None else stages
    k, fs, ref = lin.model.n_in, setup.fs, setup.ref
    stats = setup.stats
    tried = set(setup.effects)
    U_all = np.concatenate([p.U for p in setup.train])
    knots = [stats["knots"]] * k
    sat_hi = [np.quantile(U_all[:, j], SAT_HIGH) for j in range(k)]
    sat_lo = [np.quantile(U_all[:, j], SAT_LOW) for j in range(k)]
    centre_u = [0.5 * (U_all[:, j].min() + U_all[:, j].max()) for j in range(k)]
    half_u = [max(0.5 * np.ptp(U_all[:, j]), 1e-12) for j in range(k)]
    Y_all = np.concatenate([p.Y for p in setup.train])
    centre_y = Y_all.mean(axis=0)
    half_y = np.maximum(0.5 * np.ptp(Y_all, axis=0), 1e-12)
    rates = stats["rate_max"] * np.asarray(SLEW_FRACTIONS)
    cells = creep_cells(fs) if "creep" in tried else None
    duration = max(len(p.U) for p in setup.train) / fs
    lags = [t for t in DRIFT_LAGS_S if t <= 2 * duration] or [DRIFT_LAGS_S[0]]
    thresholds = pi_thresholds(stats)
    m = lin.model.n_out
    names, groups = [], {}

    def add(key, name, opt=0):
        groups.setdefault(key, [])
        while len(groups[key]) <= opt:
            groups[key].append([])
        groups[key][opt].append(len(names))
        names.append(f"{key}:{name}")

    base = []
    if base_fit is None:
        for i, n in enumerate(lin.names):
            base.append(len(names))
            names.append(f"linear:{n}")
    else:
        bnames = _fit_names(base_fit)
        theta = base_fit.parts()[1]
        lin = base_fit.lin
        for n in bnames:
            base.append(len(names))
            names.append(f"base:{n}")
    kinds = lin.kinds
    # column layout (the same for every record)
    if "output_offset" in tried:
        for j in range(m):
            add("output_offset", f"y{j + 1}")
    if "output_nonlinearity" in tried:
        for j in range(m):               # the map's constant is the offset's column
            groups.setdefault("output_nonlinearity", [[]])[0].append(
                names.index(f"output_offset:y{j + 1}") if "output_offset" in tried
                else len(names))
            if "output_offset" not in tried:
                names.append(f"output_nonlinearity:constant_y{j + 1}")
            add("output_nonlinearity", f"quadratic_y{j + 1}")
            add("output_nonlinearity", f"cubic_y{j + 1}")
    if "cross_coupling" in tried and (k > 1 or m > 1):
        for i in range(k):
            for j in range(k):
                if i != j:
                    add("cross_coupling", f"u{j + 1}_into_u{i + 1}")
        for i in range(m):
            for j in range(m):
                if i != j:
                    add("cross_coupling", f"y{j + 1}_into_y{i + 1}")
    dz_grid = []
    if "input_nonlinearity" in tried:
        for j in range(k):
            for n in ("quadratic", "cubic") + tuple(f"hinge{q}" for q in range(
                    len(knots[j]))):
                add("input_nonlinearity", f"{n}_u{j + 1}")
        if k == 1:                  # dead zones about each knot, three widths: one option each
            shared = list(groups["input_nonlinearity"][0])
            for kn in knots[0]:
                for wd in DZ_WIDTHS:
                    dz_grid.append((float(kn), float(wd * stats["u_ptp"])))
                    groups["input_nonlinearity"].append(shared + [len(names)])
                    names.append(f"input_nonlinearity:dz{len(dz_grid) - 1}_u1")
    if "saturation" in tried:
        hinge = {}
        for j in range(k):
            for h in SAT_HIGH:
                hinge[("high", h, j)] = len(names)
                names.append(f"saturation:high{h}_u{j + 1}")
            for lo in SAT_LOW:
                hinge[("low", lo, j)] = len(names)
                names.append(f"saturation:low{lo}_u{j + 1}")
        opts = [(h, None) for h in SAT_HIGH] + [(None, lo) for lo in SAT_LOW] + [
            (h, lo) for h in SAT_HIGH for lo in SAT_LOW]
        groups["saturation"] = [
            [hinge[("high", h, j)] for j in range(k) if h is not None]
            + [hinge[("low", lo, j)] for j in range(k) if lo is not None] for h, lo in opts]
    if "slew" in tried and np.any(rates > 0):
        for o, r in enumerate(rates):
            for j in range(k):
                add("slew", f"rise{r:.4g}_u{j + 1}", o)
                add("slew", f"fall{r:.4g}_u{j + 1}", o)
    if "hysteresis" in tried:
        plays = []
        for j in range(k):
            for i, r in enumerate(thresholds):
                plays.append(len(names))
                names.append(f"hysteresis:play{i + 1}_u{j + 1}")
        bw_z = _bw_starts(stats, k)
        groups["hysteresis"] = [list(plays)]          # option 0: Prandtl–Ishlinskii
        for o, z0 in enumerate(bw_z):                 # then Bouc–Wen about each point
            cols = []
            for j in range(k):
                for n in ("v", "A", "logB", "ratio"):
                    cols.append(len(names))
                    names.append(f"hysteresis:bw{o}_{n}_u{j + 1}")
            groups["hysteresis"].append(cols)
    if "creep" in tried:
        for j in range(k):
            add("creep", f"cells_u{j + 1}")
            add("creep", f"cells_dT_u{j + 1}")
    if "thermal_drift" in tried:
        for o, tau in enumerate(lags):
            for j in range(k):
                add("thermal_drift", f"lag{tau:g}_u{j + 1}", o)
    if "thermal_dynamics" in tried:
        for n in ("gain", "resonance", "damping"):
            add("thermal_dynamics", n)
    d_in = tuple(delays or (0,) * k)
    if "delay" in tried and any(d_in):
        for j in range(k):
            if d_in[j]:
                add("delay", f"u{j + 1}_{d_in[j]}")
    if "stiffness_nonlinearity" in tried and (k, m) == (1, 1):
        add("stiffness_nonlinearity", "cubic")
    if dynamic_model:
        for i, n in enumerate(lin.names):
            add("amplitude_dependent_dynamics", f"{n}_per_level")
    sfx = (lambda j: f"_u{j + 1}") if k > 1 else (lambda j: "")
    starts = {}
    if "hysteresis" in groups:
        starts["hysteresis"] = [{"form": "prandtl_ishlinskii"}] + [
            {"form": "input", **{f"{n}{sfx(j)}": float(v) for j in range(k) for n, v in zip(
                SPECS["hysteresis"].names, z0)}} for z0 in bw_z]
    if "slew" in groups:
        starts["slew"] = [{f"{n}{sfx(j)}": float(np.log10(r_)) for j in range(k)
                           for n in SPECS["slew"].names} for r_ in rates]
    if "thermal_drift" in groups:
        starts["thermal_drift"] = [{f"lag_s{sfx(j)}": float(np.log10(t)) for j in range(k)}
                                   for t in lags]
    if dz_grid:
        starts["input_nonlinearity"] = [{}] + [{"center_V": c, "dead_zone_V": d}
                                                for c, d in dz_grid]
    if "saturation" in groups:
        starts["saturation"] = []
        for h, lo in opts:
            st = {}
            for j in range(k):
                if h is not None:
                    st[f"u_max_V{sfx(j)}"] = float(sat_hi[j][SAT_HIGH.index(h)])
                if lo is not None:
                    st[f"u_min_V{sfx(j)}"] = float(sat_lo[j][SAT_LOW.index(lo)])
            starts["saturation"].append(st)
    P = len(names)
    sd = np.zeros(P)
    centre = np.zeros(P)
    fixed = []
    if base_fit is None:
        sd[base] = (setup.noise_sigma / lin.prior_sd) ** 2
        centre[base] = -np.asarray(theta, float)
        fixed = [base[i] for i in setup.pinned]
    elif base_fit.joint:
        nz, nt, ns = base_fit.chain.size, lin.size, len(base_fit.slopes)
        idx = np.asarray(base, int)
        sd[idx[nz:nz + nt]] = (setup.noise_sigma / lin.prior_sd) ** 2
        centre[idx[nz:nz + nt]] = -base_fit.x[nz:nz + nt]
        sd[idx[nz + nt:nz + nt + ns]] = (setup.noise_sigma / lin.prior_sd[list(base_fit.slopes)]) ** 2
        centre[idx[nz + nt:nz + nt + ns]] = -base_fit.x[nz + nt:nz + nt + ns]
        pin = setup.pinned_modal if base_fit.form == "dynamic" else setup.pinned
        fixed = [int(idx[nz + i]) for i in pin] + [
            int(idx[nz + nt + base_fit.slopes.index(i)]) for i in pin if i in base_fit.slopes]
    keys = [""] + [g for g, opts in groups.items() if opts and any(opts)]
    blk = {}
    for g in keys:
        idx = np.array(sorted(set(base) | {c for o in (groups.get(g) or []) for c in o}), int)
        blk[g] = (idx, {"train": np.zeros((idx.size, idx.size))}, {"train": np.zeros(idx.size)})
    c = {s: 0.0 for s in ("train", "test")}
    den = {s: 0.0 for s in ("train", "test")}
    index = {n: i for i, n in enumerate(names)}

    def record(p, split):
        N = len(p.U)
        R = slice(None, None, max(1, -(-N // SCREEN_SAMPLES)))   # rows of the Gram
        Ns = len(range(N)[R])
        w = p.weight if split == "train" else 1.0
        U, T = p.U, p.temp
        warm = p.warm
        Uw, Tw = (np.vstack([U[-warm:], U]), np.concatenate([T[-warm:], T])) if warm else (U, T)
        if base_fit is None:
            th = theta
            yL, JL = lin.simulate_jac(th, U, p.periodic)
            X = np.zeros((P, Ns, m))
            X[base] = np.moveaxis(JL[R], 2, 0)
        else:
            th = base_fit.theta_at(p.level)
            yL = base_fit.predict_prepared(p)
            Jb = model_jacobian(base_fit, p)[1]
            nz = base_fit.chain.size
            JL = (Jb[:, :, nz:nz + lin.size] if base_fit.joint
                  else lin.simulate_jac(th, base_fit.effective_input(p)[0], p.periodic)[1])
            X = np.zeros((P, Ns, m))
            X[base] = np.moveaxis(Jb[R], 2, 0)
        r = (p.Y - yL)[R]

        def col(name):
            return index[name]

        inputs, sigs = [], []          # input-side basis signals (simulated in one batch)

        def inp(name, j, x):
            inputs.append(j)
            sigs.append((col(name), x))

        if "output_offset" in tried:
            for j in range(m):
                X[col(f"output_offset:y{j + 1}"), :, j] = 1.0
        if "output_nonlinearity" in tried:
            if "output_offset" not in tried:
                for j in range(m):
                    X[col(f"output_nonlinearity:constant_y{j + 1}"), :, j] = 1.0
            E = ((yL - centre_y[None, :]) / half_y[None, :])[R]
            for j in range(m):
                X[col(f"output_nonlinearity:quadratic_y{j + 1}"), :, j] = E[:, j] ** 2
                X[col(f"output_nonlinearity:cubic_y{j + 1}"), :, j] = E[:, j] ** 3
        if "cross_coupling" in groups:
            for i in range(k):
                for j in range(k):
                    if i != j:
                        inp(f"cross_coupling:u{j + 1}_into_u{i + 1}", i, U[:, j])
            for i in range(m):
                for j in range(m):
                    if i != j:
                        X[col(f"cross_coupling:y{j + 1}_into_y{i + 1}"), :, i] = yL[R, j]
        if "input_nonlinearity" in tried:
            for j in range(k):
                e = (U[:, j] - centre_u[j]) / half_u[j]
                s = f"_u{j + 1}"
                inp("input_nonlinearity:quadratic" + s, j, e ** 2)
                inp("input_nonlinearity:cubic" + s, j, e ** 3)
                for q, kn in enumerate(knots[j]):
                    inp(f"input_nonlinearity:hinge{q}" + s, j, np.maximum(U[:, j] - kn, 0.0))
            for o, (cz, dz) in enumerate(dz_grid):
                e = U[:, 0] - cz
                inp(f"input_nonlinearity:dz{o}_u1", 0,
                    np.maximum(e - dz, 0.0) + np.minimum(e + dz, 0.0) - e)
        if "saturation" in tried:
            for j in range(k):
                for h, kn in zip(SAT_HIGH, sat_hi[j]):
                    inp(f"saturation:high{h}_u{j + 1}", j, np.maximum(U[:, j] - kn, 0.0))
                for lo, kn in zip(SAT_LOW, sat_lo[j]):
                    inp(f"saturation:low{lo}_u{j + 1}", j, np.minimum(U[:, j] - kn, 0.0))
        if "slew" in groups:
            for r_ in rates:
                for j in range(k):
                    Xs = _slew_columns(stages, Uw[:, j], Tw, r_, fs, ref, warm)
                    inp(f"slew:rise{r_:.4g}_u{j + 1}", j, Xs[:, 0])
                    inp(f"slew:fall{r_:.4g}_u{j + 1}", j, Xs[:, 1])
        if "hysteresis" in tried:
            for j in range(k):
                Xp = _play_columns(stages, Uw[:, j], Tw, thresholds, fs, ref, warm)
                for i in range(len(thresholds)):
                    inp(f"hysteresis:play{i + 1}_u{j + 1}", j, Xp[:, i])
                for o, z0 in enumerate(bw_z):
                    Xb = _bw_columns(stages, Uw[:, j], Tw, z0, fs, ref, warm)
                    for i, n in enumerate(("v", "A", "logB", "ratio")):
                        inp(f"hysteresis:bw{o}_{n}_u{j + 1}", j, Xb[:, i])
        if "creep" in tried:
            a, per = cells
            acc = np.zeros((len(Uw), k))
            for ai in a:
                acc += signal.lfilter([1 - ai], [1.0, -ai], Uw, axis=0)
            acc = acc[warm:] / per
            dTp = np.maximum(T - ref, 0.0)
            for j in range(k):
                inp(f"creep:cells_u{j + 1}", j, acc[:, j])
                inp(f"creep:cells_dT_u{j + 1}", j, acc[:, j] * dTp)
        if "thermal_drift" in tried:
            for tau in lags:
                al = np.exp(-1.0 / (fs * tau))
                Ts = signal.lfilter([1 - al], [1.0, -al], Tw, zi=[al * Tw[0]])[0][warm:]
                for j in range(k):
                    inp(f"thermal_drift:lag{tau:g}_u{j + 1}", j, Ts - Tw[0])
        if "thermal_dynamics" in tried:
            dT = (T - ref)[R, None]
            pairs = [i for i, (kind, q) in enumerate(kinds)
                     if kind == "dlog_freq" and lin.model.poles[q].imag > 0]
            damp = [i for i, (kind, _) in enumerate(kinds) if kind == "dlog_damping"]
            gi = [i for i, (kind, _) in enumerate(kinds) if kind in ("gain", "input_gain")]
            X[col("thermal_dynamics:gain")] = dT * JL[R][:, :, gi].sum(axis=2)
            if pairs:
                X[col("thermal_dynamics:resonance")] = dT * JL[R][:, :, pairs].sum(axis=2)
            if damp:
                X[col("thermal_dynamics:damping")] = dT * JL[R][:, :, damp].sum(axis=2)
        if "delay" in groups:
            for j in range(k):
                d = d_in[j]
                if d:
                    x = (np.roll(U[:, j], d) if p.periodic
                         else np.concatenate([np.full(d, U[0, j]), U[:-d, j]]))
                    inp(f"delay:u{j + 1}_{d}", j, x - U[:, j])
        if "stiffness_nonlinearity" in groups:
            inp("stiffness_nonlinearity:cubic", 0, -(yL[:, 0] / half_y[0]) ** 3)
        if dynamic_model:
            f = level_factor(p.level, level_ref)
            for i, n in enumerate(lin.names):
                X[col(f"amplitude_dependent_dynamics:{n}_per_level")] = f * JL[R, :, i]
        if split == "test":      # scored by prediction: the input side stays signals
            sig = {ci: (j, x) for (ci, x), j in zip(sigs, inputs)}
            direct = {ci: X[ci] for ci in range(P) if ci not in sig and np.any(X[ci])}
            held_out.append(HeldOut(R, r, direct, sig, lin, th, p.periodic))
            c[split] += float(np.sum(r * r))
            den[split] += float(np.sum((p.Y[R] - p.Y.mean(axis=0)) ** 2))
            return
        for a in range(0, len(sigs), BATCH):       # input-side columns, a batch at a time
            part = sigs[a:a + BATCH]
            Yin = lin.simulate_inputs(th, np.column_stack([x for _, x in part]),
                                      inputs[a:a + BATCH], p.periodic)
            for (ci, _), cc in zip(part, range(Yin.shape[2])):
                X[ci] = Yin[R, :, cc]
        Xf = X.reshape(P, Ns * m)
        if w != 1.0:
            Xf *= w
        rf = r.reshape(-1) * w
        Xb = Xf[base]
        Gbb = Xb @ Xb.T
        for idx, Gb, bb in blk.values():
            nb = len(base)
            Xg = Xf[idx[nb:]]                  # the block: the base, then the candidate's
            Gbg = Xb @ Xg.T
            Gb[split] += np.block([[Gbb, Gbg], [Gbg.T, Xg @ Xg.T]])
            bb[split] += np.concatenate([Xb @ rf, Xg @ rf])
        c[split] += float(rf @ rf)
        den[split] += float(np.sum((w * (p.Y[R] - p.Y.mean(axis=0))) ** 2))

    held_out = []
    for p in setup.train:
        record(p, "train")
    for p in setup.test:
        record(p, "test")
    # the training ridge: priors of the linear corrections (in the Gram's units)
    scale = 1.0
    ridge = (sd * scale, centre)
    if say:
        say(f"screened {len([g for g in groups if groups[g] and any(groups[g])])} candidate(s)"
            f" on {P} exact columns")
    return Screen(names, groups, base, blk, c, den, ridge, starts, fixed, held_out)
