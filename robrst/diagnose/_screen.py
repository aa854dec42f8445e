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
(at most ``samples`` rows per record, :class:`~robrst.diagnose.options.ScreenOptions`), so any set of candidates is fitted
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
fitted by its own nonlinear model (:mod:`robrst.diagnose._select`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal

from robrst.diagnose._effects import SPECS, creep_cells, creep_per_K_free, pi_thresholds
from robrst.diagnose.fit import level_factor, level_map_of, model_jacobian
from robrst.diagnose.options import OPTIONS
from robrst.diagnose._stages import cached_stage

if TYPE_CHECKING:
    from robrst.diagnose.fit import Fitted, Prepared
    from robrst.diagnose.linear import LinearPart

__all__ = ["Screen", "ScreenFit", "HeldOut", "ScreenGrid", "ColumnLayout", "RecordColumns",
           "GramAccumulator", "build_screen"]

_SCR = OPTIONS.screen


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
    lin: LinearPart
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
        A[np.diag_indices_from(A)] += dd + _SCR.ridge * np.maximum(np.diag(A), 1e-300)
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


# --- the screen's builder, in phases ------------------------------------------------------
#
#   ScreenGrid        the data's scales and the grids of the options (knots, limits, rates,
#                     lags, thresholds, Bouc–Wen points)
#   ColumnLayout      every column's name, the candidates' options (groups) and their starts
#   _priors           the base columns' ridge (the linear corrections' priors) and pins
#   RecordColumns     one record: the base prediction, its Jacobian, every candidate's column
#   GramAccumulator   the training Gram blocks and the held-out records; the Screen


def _fit_names(fit):
    """Names of a fitted candidate's parameters (chain, linear corrections, slopes, blocks)."""
    names = list(fit.chain.names) + (list(fit.lin.names) if fit.joint else [])
    names += list(fit.slope_names()) if hasattr(fit, "slope_names") else []
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
    for b_rel in _SCR.bw_b_rel:
        for ratio in (_SCR.bw_ratios if n_in == 1 else _SCR.bw_ratios[-1:]):
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


@dataclass(frozen=True, eq=False)
class ScreenGrid:
    """Phase 1: the training data's scales and the options' grids that every column needs.

    Parameters
    ----------
    tried : frozenset of str
        The candidates screened.
    n_in, n_out : int
        Inputs and outputs.
    fs, ref : float
        Sampling rate [Hz] and the model's temperature [°C].
    stats : dict
        Scales of the training data (:func:`robrst.diagnose._effects.summary`).
    knots : list of tuple
        Knots of the static input map's hinges, per input.
    sat_hi, sat_lo : list of numpy.ndarray
        Saturation limits screened (input quantiles), per input.
    centre_u, half_u : list of float
        Centre and half range of each training input.
    centre_y, half_y : numpy.ndarray
        Mean and half range of each training output.
    rates : numpy.ndarray
        Slew rates screened [V/s].
    cells : tuple or None
        The creep cells (poles, cells per decade) when creep is screened.
    lags : list of float
        Thermal-drift lags screened [s].
    thresholds : tuple of float
        Play thresholds of the Prandtl–Ishlinskii columns [V].
    creep_per_K : bool
        The records determine creep's growth with temperature (its column is screened).
    """

    tried: frozenset
    n_in: int
    n_out: int
    fs: float
    ref: float
    stats: dict
    knots: list
    sat_hi: list
    sat_lo: list
    centre_u: list
    half_u: list
    centre_y: np.ndarray
    half_y: np.ndarray
    rates: np.ndarray
    cells: tuple
    lags: list
    thresholds: tuple
    creep_per_K: bool = True

    @classmethod
    def of(cls, setup: Setup) -> ScreenGrid:      # noqa: F821  (candidates.Setup: it imports this module)
        """The grid of ``setup``'s training records and candidates.

        Parameters
        ----------
        setup : Setup
            The diagnosis's shared state.

        Returns
        -------
        ScreenGrid
        """
        lin = setup.lin
        k, stats = lin.model.n_in, setup.stats
        tried = frozenset(setup.effects)
        U_all = np.concatenate([p.U for p in setup.train])
        Y_all = np.concatenate([p.Y for p in setup.train])
        duration = max(len(p.U) for p in setup.train) / setup.fs
        lags = [t for t in _SCR.drift_lags_s if t <= 2 * duration] or [_SCR.drift_lags_s[0]]
        return cls(tried=tried, n_in=k, n_out=lin.model.n_out, fs=setup.fs, ref=setup.ref,
                   stats=stats, knots=[stats["knots"]] * k,
                   sat_hi=[np.quantile(U_all[:, j], _SCR.sat_high) for j in range(k)],
                   sat_lo=[np.quantile(U_all[:, j], _SCR.sat_low) for j in range(k)],
                   centre_u=[0.5 * (U_all[:, j].min() + U_all[:, j].max()) for j in range(k)],
                   half_u=[max(0.5 * np.ptp(U_all[:, j]), 1e-12) for j in range(k)],
                   centre_y=Y_all.mean(axis=0),
                   half_y=np.maximum(0.5 * np.ptp(Y_all, axis=0), 1e-12),
                   rates=stats["rate_max"] * np.asarray(_SCR.slew_fractions),
                   cells=creep_cells(setup.fs) if "creep" in tried else None,
                   lags=lags, thresholds=pi_thresholds(stats),
                   creep_per_K=creep_per_K_free(stats, setup.ref))


class ColumnLayout:
    """Phase 2: the columns' names, the candidates' options and their starting values.

    The layout is the same for every record.  ``names[i]`` is column ``i``
    (``candidate:column``; the base's ``linear:<correction>`` or ``base:<parameter>``),
    ``groups[candidate]`` its options (lists of column indices: saturation knots, slew
    rates, drift lags, hysteresis forms), ``base`` the base columns, ``starts[candidate]``
    the starting values of each option's nonlinear fit.

    Parameters
    ----------
    grid : ScreenGrid
        The data's scales and grids.
    lin : LinearPart
        The linear part of the base.
    delays : sequence of int
        Whole-sample delay per input.
    dynamic_model : bool
        Lay out the amplitude-dependent dynamics.
    base_fit : Fitted, optional
        The fitted candidate screened upon (its parameters are the base columns).

    Attributes
    ----------
    names : list of str
    groups : dict
    base : list of int
    starts : dict
    index : dict
        Column index by name.
    dz_grid : list of (float, float)
        Dead zones screened: (centre, half width) [V].
    sat_options : list of (float or None, float or None)
        Saturation options: (upper quantile, lower quantile).
    bw_points : list of numpy.ndarray
        Bouc–Wen points of the hysteresis options.
    delays : tuple of int
        Whole-sample delay per input.
    """

    def __init__(self, grid: ScreenGrid, lin: object, delays: Sequence[int],
                 dynamic_model: bool, base_fit: Fitted | None = None) -> None:
        self.grid = grid
        self.names, self.groups, self.base = [], {}, []
        self.dz_grid, self.sat_options, self.bw_points = [], [], []
        self.delays = tuple(delays)
        if base_fit is None:
            for n in lin.names:
                self.base.append(len(self.names))
                self.names.append(f"linear:{n}")
        else:
            for n in _fit_names(base_fit):
                self.base.append(len(self.names))
                self.names.append(f"base:{n}")
        self._output_side()
        self._coupling()
        self._input_map()
        self._saturation()
        self._slew()
        self._hysteresis()
        self._creep()
        self._drift()
        self._thermal_dynamics()
        self._delay()
        self._stiffness()
        if dynamic_model:
            for n in lin.names:
                self._add("amplitude_dependent_dynamics", f"{n}_per_level")
        self.starts = self._starts()
        self.index = {n: i for i, n in enumerate(self.names)}

    @property
    def size(self) -> int:
        """Number of columns."""
        return len(self.names)

    def screened(self) -> list:
        """The candidates with at least one column.

        Returns
        -------
        list of str
        """
        return [g for g, opts in self.groups.items() if opts and any(opts)]

    def _add(self, key, name, opt=0):
        self.groups.setdefault(key, [])
        while len(self.groups[key]) <= opt:
            self.groups[key].append([])
        self.groups[key][opt].append(len(self.names))
        self.names.append(f"{key}:{name}")

    def _output_side(self):
        """A constant per output; the sensor map's square and cube (its constant shared)."""
        tried, m = self.grid.tried, self.grid.n_out
        if "output_offset" in tried:
            for j in range(m):
                self._add("output_offset", f"y{j + 1}")
        if "output_nonlinearity" in tried:
            for j in range(m):               # the map's constant is the offset's column
                self.groups.setdefault("output_nonlinearity", [[]])[0].append(
                    self.names.index(f"output_offset:y{j + 1}") if "output_offset" in tried
                    else len(self.names))
                if "output_offset" not in tried:
                    self.names.append(f"output_nonlinearity:constant_y{j + 1}")
                self._add("output_nonlinearity", f"quadratic_y{j + 1}")
                self._add("output_nonlinearity", f"cubic_y{j + 1}")

    def _coupling(self):
        """Input mixing and output mixing (several inputs or outputs)."""
        k, m = self.grid.n_in, self.grid.n_out
        if "cross_coupling" in self.grid.tried and (k > 1 or m > 1):
            for i in range(k):
                for j in range(k):
                    if i != j:
                        self._add("cross_coupling", f"u{j + 1}_into_u{i + 1}")
            for i in range(m):
                for j in range(m):
                    if i != j:
                        self._add("cross_coupling", f"y{j + 1}_into_y{i + 1}")

    def _input_map(self):
        """Square, cube and hinges per input; one input: a dead zone about each knot (options)."""
        g = self.grid
        if "input_nonlinearity" not in g.tried:
            return
        for j in range(g.n_in):
            for n in ("quadratic", "cubic") + tuple(f"hinge{q}" for q in range(
                    len(g.knots[j]))):
                self._add("input_nonlinearity", f"{n}_u{j + 1}")
        if g.n_in == 1:             # dead zones about each knot, three widths: one option each
            shared = list(self.groups["input_nonlinearity"][0])
            for kn in g.knots[0]:
                for wd in _SCR.dz_widths:
                    self.dz_grid.append((float(kn), float(wd * g.stats["u_ptp"])))
                    self.groups["input_nonlinearity"].append(shared + [len(self.names)])
                    self.names.append(f"input_nonlinearity:dz{len(self.dz_grid) - 1}_u1")

    def _saturation(self):
        """A hinge per limit screened; an option per upper, lower and pair of limits."""
        g = self.grid
        if "saturation" not in g.tried:
            return
        hinge = {}
        for j in range(g.n_in):
            for h in _SCR.sat_high:
                hinge[("high", h, j)] = len(self.names)
                self.names.append(f"saturation:high{h}_u{j + 1}")
            for lo in _SCR.sat_low:
                hinge[("low", lo, j)] = len(self.names)
                self.names.append(f"saturation:low{lo}_u{j + 1}")
        self.sat_options = [(h, None) for h in _SCR.sat_high] + [
            (None, lo) for lo in _SCR.sat_low] + [
            (h, lo) for h in _SCR.sat_high for lo in _SCR.sat_low]
        self.groups["saturation"] = [
            [hinge[("high", h, j)] for j in range(g.n_in) if h is not None]
            + [hinge[("low", lo, j)] for j in range(g.n_in) if lo is not None]
            for h, lo in self.sat_options]

    def _slew(self):
        """Rising and falling limits per rate screened (an option per rate)."""
        g = self.grid
        if "slew" in g.tried and np.any(g.rates > 0):
            for o, r in enumerate(g.rates):
                for j in range(g.n_in):
                    self._add("slew", f"rise{r:.4g}_u{j + 1}", o)
                    self._add("slew", f"fall{r:.4g}_u{j + 1}", o)

    def _hysteresis(self):
        """Option 0: the play operators (Prandtl–Ishlinskii); then Bouc–Wen about each point."""
        g = self.grid
        if "hysteresis" not in g.tried:
            return
        plays = []
        for j in range(g.n_in):
            for i, _ in enumerate(g.thresholds):
                plays.append(len(self.names))
                self.names.append(f"hysteresis:play{i + 1}_u{j + 1}")
        self.bw_points = _bw_starts(g.stats, g.n_in)
        self.groups["hysteresis"] = [list(plays)]
        for o, _ in enumerate(self.bw_points):
            cols = []
            for j in range(g.n_in):
                for n in ("v", "A", "logB", "ratio"):
                    cols.append(len(self.names))
                    self.names.append(f"hysteresis:bw{o}_{n}_u{j + 1}")
            self.groups["hysteresis"].append(cols)

    def _creep(self):
        """The creep cells' sum and its growth with temperature, per input."""
        if "creep" in self.grid.tried:
            for j in range(self.grid.n_in):
                self._add("creep", f"cells_u{j + 1}")
                if self.grid.creep_per_K:
                    self._add("creep", f"cells_dT_u{j + 1}")

    def _drift(self):
        """The lagged temperature per input, an option per lag."""
        if "thermal_drift" in self.grid.tried:
            for o, tau in enumerate(self.grid.lags):
                for j in range(self.grid.n_in):
                    self._add("thermal_drift", f"lag{tau:g}_u{j + 1}", o)

    def _thermal_dynamics(self):
        """Gain, resonances and damping times the temperature change."""
        if "thermal_dynamics" in self.grid.tried:
            for n in ("gain", "resonance", "damping"):
                self._add("thermal_dynamics", n)

    def _delay(self):
        """The delayed input's difference, per delayed input."""
        d_in = self.delays
        if "delay" in self.grid.tried and any(d_in):
            for j in range(self.grid.n_in):
                if d_in[j]:
                    self._add("delay", f"u{j + 1}_{d_in[j]}")

    def _stiffness(self):
        """The cubed output fed back (one input and output)."""
        if "stiffness_nonlinearity" in self.grid.tried and (self.grid.n_in,
                                                            self.grid.n_out) == (1, 1):
            self._add("stiffness_nonlinearity", "cubic")

    def _starts(self):
        """Starting values of each option's nonlinear fit, by candidate."""
        g, k = self.grid, self.grid.n_in
        sfx = (lambda j: f"_u{j + 1}") if k > 1 else (lambda j: "")
        starts = {}
        if "hysteresis" in self.groups:
            starts["hysteresis"] = [{"form": "prandtl_ishlinskii"}] + [
                {"form": "input", **{f"{n}{sfx(j)}": float(v) for j in range(k) for n, v in zip(
                    SPECS["hysteresis"].names, z0)}} for z0 in self.bw_points]
        if "slew" in self.groups:
            starts["slew"] = [{f"{n}{sfx(j)}": float(np.log10(r_)) for j in range(k)
                               for n in SPECS["slew"].names} for r_ in g.rates]
        if "thermal_drift" in self.groups:
            starts["thermal_drift"] = [{f"lag_s{sfx(j)}": float(np.log10(t)) for j in range(k)}
                                       for t in g.lags]
        if self.dz_grid:
            starts["input_nonlinearity"] = [{}] + [{"center_V": c, "dead_zone_V": d}
                                                    for c, d in self.dz_grid]
        if "saturation" in self.groups:
            starts["saturation"] = []
            for h, lo in self.sat_options:
                st = {}
                for j in range(k):
                    if h is not None:
                        st[f"u_max_V{sfx(j)}"] = float(g.sat_hi[j][_SCR.sat_high.index(h)])
                    if lo is not None:
                        st[f"u_min_V{sfx(j)}"] = float(g.sat_lo[j][_SCR.sat_low.index(lo)])
                starts["saturation"].append(st)
        return starts


def _priors(setup, layout, lin, theta, base_fit):
    """Phase 3: the base columns' ridge weights and centres (the linear corrections' priors,
    in the Gram's units) and the base columns held (pinned corrections)."""
    P, base = layout.size, layout.base
    sd = np.zeros(P)
    centre = np.zeros(P)
    fixed = []
    if base_fit is None:
        sd[base] = (setup.noise_sigma / lin.prior_sd) ** 2
        centre[base] = -np.asarray(theta, float)
        fixed = [base[i] for i in setup.pinned]
    elif base_fit.joint:
        nz, nt, ns = base_fit.chain.size, lin.size, base_fit.n_slope
        idx = np.asarray(base, int)
        sd[idx[nz:nz + nt]] = (setup.noise_sigma / lin.prior_sd) ** 2
        centre[idx[nz:nz + nt]] = -base_fit.x[nz:nz + nt]
        sd[idx[nz + nt:nz + nt + ns]] = (setup.noise_sigma / base_fit.slope_prior_sd()) ** 2
        centre[idx[nz + nt:nz + nt + ns]] = -base_fit.x[nz + nt:nz + nt + ns]
        pin = setup.pinned_modal if base_fit.form == "dynamic" else setup.pinned
        nsl = len(base_fit.slopes)
        fixed = [int(idx[nz + i]) for i in pin] + [
            int(idx[nz + nt + b * nsl + base_fit.slopes.index(i)]) for i in pin
            if i in base_fit.slopes for b in range(ns // max(nsl, 1))]
    return (sd, centre), fixed


@dataclass(frozen=True, eq=False)
class Columns:
    """One record's columns (:meth:`RecordColumns.of`).

    Parameters
    ----------
    rows : slice
        The screened samples.
    r : numpy.ndarray
        The base's residual on them ``(Ns, m)``.
    X : numpy.ndarray
        ``(P, Ns, m)``: the columns computed without the linear part (the rest zero).
    signals : list
        ``[(column, basis signal (N,))]``: the input-side columns' signals ...
    inputs : list of int
        ... and the input each drives.
    theta : numpy.ndarray
        The base's linear corrections on this record.
    base_map : tuple, optional
        ``(keep, M)`` when the base's level slopes are its modes' columns scaled by the
        record's level basis: the base's columns are ``M @ X[keep]`` (so its Gram products
        are those of ``keep``, mapped by ``M``).
    """

    rows: slice
    r: np.ndarray
    X: np.ndarray
    signals: list
    inputs: list
    theta: np.ndarray
    base_map: tuple[np.ndarray, np.ndarray] | None = None


class _Signals:
    """A record's input-side basis signals, in column order, and the input each drives."""

    def __init__(self, index):
        self.index, self.signals, self.inputs = index, [], []

    def add(self, name, j, x):
        self.inputs.append(j)
        self.signals.append((self.index[name], x))


class RecordColumns:
    """Phase 4: one record's base prediction, its Jacobian and every candidate's columns.

    Output-side columns and the base's Jacobian are computed directly; input-side columns
    are basis signals of the input (their outputs through the linear part are simulated
    later, a batch at a time, or not at all for a held-out record).

    Parameters
    ----------
    grid : ScreenGrid
        The data's scales and grids.
    layout : ColumnLayout
        The columns.
    lin : LinearPart
        The linear part of the base.
    theta : numpy.ndarray or None
        Its corrections (without ``base_fit``).
    base_fit : Fitted, optional
        The fitted candidate screened upon.
    level_ref : float, optional
        Reference level of the amplitude-dependent dynamics.
    dynamic_model : bool
        Columns of the amplitude-dependent dynamics.
    stages : dict
        Compiled effect stages of the diagnosis.
    """

    def __init__(self, grid: ScreenGrid, layout: ColumnLayout, lin: object,
                 theta: np.ndarray | None, base_fit: Fitted | None, level_ref: float | None,
                 dynamic_model: bool, stages: dict) -> None:
        self.grid, self.layout, self.lin = grid, layout, lin
        self.theta, self.base_fit = theta, base_fit
        self.level_ref, self.dynamic_model, self.stages = level_ref, dynamic_model, stages
        self._scratch = None

    def of(self, p: Prepared, scratch: bool = False) -> Columns:
        """The columns of record ``p``.

        Parameters
        ----------
        p : Prepared
            The record.
        scratch : bool
            Write them into this object's one scratch array (reused by the next record
            asked for with ``scratch``: for a record whose columns are used at once, as a
            training record's Gram products are).

        Returns
        -------
        Columns
        """
        N = len(p.U)
        R = slice(None, None, max(1, -(-N // _SCR.samples)))   # rows of the Gram
        Ns = len(range(N)[R])
        shape = (self.layout.size, Ns, self.grid.n_out)
        if not scratch:
            X = np.zeros(shape)
        else:                   # one array for every such record: no new pages each time
            if self._scratch is None or self._scratch.shape != shape:
                self._scratch = np.zeros(shape)
            X = self._scratch
            X.fill(0.0)
        th, yL, JL, base_map = self._base(p, R, X)
        sig = _Signals(self.layout.index)
        self._output_side(X, yL, R)
        self._coupling(p, X, yL, R, sig)
        self._input_map(p, sig)
        self._saturation(p, sig)
        self._sequential(p, sig)
        self._creep(p, sig)
        self._drift(p, sig)
        self._thermal_dynamics(p, X, JL, R)
        self._delay(p, sig)
        self._stiffness(yL, sig)
        if self.dynamic_model:
            f = level_factor(p.level, self.level_ref)
            for i, n in enumerate(self.lin.names):
                X[self._col(f"amplitude_dependent_dynamics:{n}_per_level")] = f * JL[R, :, i]
        return Columns(R, (p.Y - yL)[R], X, sig.signals, sig.inputs, th, base_map)

    def _col(self, name):
        return self.layout.index[name]

    def _warm(self, p):
        """Inputs and temperature with the warm-up period prepended (periodic records)."""
        U, T, warm = p.U, p.temp, p.warm
        if warm:
            return np.vstack([U[-warm:], U]), np.concatenate([T[-warm:], T])
        return U, T

    def _base(self, p, R, X):
        """The base's corrections, prediction and Jacobian (its columns filled in ``X``)."""
        base, lin, base_fit = self.layout.base, self.lin, self.base_fit
        if base_fit is None:
            th = self.theta
            yL, JL = lin.simulate_jac(th, p.U, p.periodic)
            X[base] = np.moveaxis(JL[R], 2, 0)
        else:
            th = base_fit.theta_at(p.level)
            yL = base_fit.predict_prepared(p)
            level_map = level_map_of(base_fit, p)
            plain = (level_map is not None and base_fit.chain.size == 0
                     and base_fit.post is None)
            if plain:       # the level-dependent linear part alone: its kept columns are the
                # linear part's Jacobian (model_jacobian's, without its copy of every column)
                JL = Jb = lin.simulate_jac(th, base_fit.effective_input(p)[0], p.periodic)[1]
            else:
                Jb = model_jacobian(base_fit, p, level_columns=level_map is None)[1]
                nz = base_fit.chain.size
                if base_fit.joint:
                    JL = Jb[:, :, nz:nz + lin.size]
                elif self.dynamic_model or "thermal_dynamics" in self.grid.tried:
                    JL = lin.simulate_jac(th, base_fit.effective_input(p)[0], p.periodic)[1]
                else:
                    JL = None   # no column of this screen uses the linear part's Jacobian
            if level_map is None:
                X[base] = np.moveaxis(Jb[R], 2, 0)
                return th, yL, JL, None
            keep, slopes, M = level_map
            col = np.asarray(base)                  # the base's parameters' columns
            X[col[keep]] = np.moveaxis(Jb[R] if plain else Jb[R][:, :, keep], 2, 0)
            for c, (src, v) in slopes.items():      # a slope column: its mode's column scaled
                np.multiply(X[col[src]], v, out=X[col[c]])
            return th, yL, JL, (col[keep], M)
        return th, yL, JL, None

    def _output_side(self, X, yL, R):
        g = self.grid
        if "output_offset" in g.tried:
            for j in range(g.n_out):
                X[self._col(f"output_offset:y{j + 1}"), :, j] = 1.0
        if "output_nonlinearity" in g.tried:
            if "output_offset" not in g.tried:
                for j in range(g.n_out):
                    X[self._col(f"output_nonlinearity:constant_y{j + 1}"), :, j] = 1.0
            E = ((yL - g.centre_y[None, :]) / g.half_y[None, :])[R]
            for j in range(g.n_out):
                X[self._col(f"output_nonlinearity:quadratic_y{j + 1}"), :, j] = E[:, j] ** 2
                X[self._col(f"output_nonlinearity:cubic_y{j + 1}"), :, j] = E[:, j] ** 3

    def _coupling(self, p, X, yL, R, sig):
        k, m = self.grid.n_in, self.grid.n_out
        if "cross_coupling" in self.layout.groups:
            for i in range(k):
                for j in range(k):
                    if i != j:
                        sig.add(f"cross_coupling:u{j + 1}_into_u{i + 1}", i, p.U[:, j])
            for i in range(m):
                for j in range(m):
                    if i != j:
                        X[self._col(f"cross_coupling:y{j + 1}_into_y{i + 1}"), :, i] = yL[R, j]

    def _input_map(self, p, sig):
        g, U = self.grid, p.U
        if "input_nonlinearity" not in g.tried:
            return
        for j in range(g.n_in):
            e = (U[:, j] - g.centre_u[j]) / g.half_u[j]
            s = f"_u{j + 1}"
            sig.add("input_nonlinearity:quadratic" + s, j, e ** 2)
            sig.add("input_nonlinearity:cubic" + s, j, e ** 3)
            for q, kn in enumerate(g.knots[j]):
                sig.add(f"input_nonlinearity:hinge{q}" + s, j, np.maximum(U[:, j] - kn, 0.0))
        for o, (cz, dz) in enumerate(self.layout.dz_grid):
            e = U[:, 0] - cz
            sig.add(f"input_nonlinearity:dz{o}_u1", 0,
                      np.maximum(e - dz, 0.0) + np.minimum(e + dz, 0.0) - e)

    def _saturation(self, p, sig):
        g, U = self.grid, p.U
        if "saturation" in g.tried:
            for j in range(g.n_in):
                for h, kn in zip(_SCR.sat_high, g.sat_hi[j]):
                    sig.add(f"saturation:high{h}_u{j + 1}", j, np.maximum(U[:, j] - kn, 0.0))
                for lo, kn in zip(_SCR.sat_low, g.sat_lo[j]):
                    sig.add(f"saturation:low{lo}_u{j + 1}", j, np.minimum(U[:, j] - kn, 0.0))

    def _sequential(self, p, sig):
        """Slew limits and hysteresis: the twin's compiled stages on the warmed-up input."""
        g, st, warm = self.grid, self.stages, p.warm
        Uw, Tw = self._warm(p)
        if "slew" in self.layout.groups:
            for r_ in g.rates:
                for j in range(g.n_in):
                    Xs = _slew_columns(st, Uw[:, j], Tw, r_, g.fs, g.ref, warm)
                    sig.add(f"slew:rise{r_:.4g}_u{j + 1}", j, Xs[:, 0])
                    sig.add(f"slew:fall{r_:.4g}_u{j + 1}", j, Xs[:, 1])
        if "hysteresis" in g.tried:
            for j in range(g.n_in):
                Xp = _play_columns(st, Uw[:, j], Tw, g.thresholds, g.fs, g.ref, warm)
                for i in range(len(g.thresholds)):
                    sig.add(f"hysteresis:play{i + 1}_u{j + 1}", j, Xp[:, i])
                for o, z0 in enumerate(self.layout.bw_points):
                    Xb = _bw_columns(st, Uw[:, j], Tw, z0, g.fs, g.ref, warm)
                    for i, n in enumerate(("v", "A", "logB", "ratio")):
                        sig.add(f"hysteresis:bw{o}_{n}_u{j + 1}", j, Xb[:, i])

    def _creep(self, p, sig):
        g = self.grid
        if "creep" not in g.tried:
            return
        Uw, _ = self._warm(p)
        a, per = g.cells
        acc = np.zeros((len(Uw), g.n_in))
        for ai in a:
            acc += signal.lfilter([1 - ai], [1.0, -ai], Uw, axis=0)
        acc = acc[p.warm:] / per
        dTp = np.maximum(p.temp - g.ref, 0.0)
        for j in range(g.n_in):
            sig.add(f"creep:cells_u{j + 1}", j, acc[:, j])
            if g.creep_per_K:
                sig.add(f"creep:cells_dT_u{j + 1}", j, acc[:, j] * dTp)

    def _drift(self, p, sig):
        g = self.grid
        if "thermal_drift" not in g.tried:
            return
        _, Tw = self._warm(p)
        for tau in g.lags:
            al = np.exp(-1.0 / (g.fs * tau))
            Ts = signal.lfilter([1 - al], [1.0, -al], Tw, zi=[al * Tw[0]])[0][p.warm:]
            for j in range(g.n_in):
                sig.add(f"thermal_drift:lag{tau:g}_u{j + 1}", j, Ts - Tw[0])

    def _thermal_dynamics(self, p, X, JL, R):
        if "thermal_dynamics" not in self.grid.tried:
            return
        lin = self.lin
        kinds = lin.kinds
        dT = (p.temp - self.grid.ref)[R, None]
        pairs = [i for i, (kind, q) in enumerate(kinds)
                 if kind == "dlog_freq" and lin.model.poles[q].imag > 0]
        damp = [i for i, (kind, _) in enumerate(kinds) if kind == "dlog_damping"]
        gi = [i for i, (kind, _) in enumerate(kinds) if kind in ("gain", "input_gain")]
        X[self._col("thermal_dynamics:gain")] = dT * JL[R][:, :, gi].sum(axis=2)
        if pairs:
            X[self._col("thermal_dynamics:resonance")] = dT * JL[R][:, :, pairs].sum(axis=2)
        if damp:
            X[self._col("thermal_dynamics:damping")] = dT * JL[R][:, :, damp].sum(axis=2)

    def _delay(self, p, sig):
        if "delay" not in self.layout.groups:
            return
        U = p.U
        for j in range(self.grid.n_in):
            d = self.layout.delays[j]
            if d:
                x = (np.roll(U[:, j], d) if p.periodic
                     else np.concatenate([np.full(d, U[0, j]), U[:-d, j]]))
                sig.add(f"delay:u{j + 1}_{d}", j, x - U[:, j])

    def _stiffness(self, yL, sig):
        if "stiffness_nonlinearity" in self.layout.groups:
            sig.add("stiffness_nonlinearity:cubic", 0, -(yL[:, 0] / self.grid.half_y[0]) ** 3)


class GramAccumulator:
    """Phase 5: the training Gram matrices per block and the held-out records.

    A block is the base alone (key ``""``) or the base with one candidate's columns; the
    training records add ``X^T X``, ``X^T r`` (their input-side columns simulated a batch
    at a time), the held-out records are kept as :class:`HeldOut` (scored by prediction).

    Parameters
    ----------
    layout : ColumnLayout
        The columns.
    lin : LinearPart
        The linear part the input-side signals go through.
    """

    def __init__(self, layout: ColumnLayout, lin: object) -> None:
        self.layout, self.lin = layout, lin
        base, groups = layout.base, layout.groups
        keys = [""] + layout.screened()
        self.blocks = {}
        for g in keys:
            idx = np.array(sorted(set(base) | {c for o in (groups.get(g) or []) for c in o}),
                           int)
            self.blocks[g] = (idx, {"train": np.zeros((idx.size, idx.size))},
                              {"train": np.zeros(idx.size)})
        self.c = {s: 0.0 for s in ("train", "test")}
        self.den = {s: 0.0 for s in ("train", "test")}
        self.held_out = []

    def add_test(self, p: Prepared, cols: Columns) -> None:
        """Keep a held-out record (scored later by one prediction per candidate).

        Parameters
        ----------
        p : Prepared
            The record.
        cols : Columns
            Its columns.
        """
        R, r, X = cols.rows, cols.r, cols.X
        sig = {ci: (j, x) for (ci, x), j in zip(cols.signals, cols.inputs)}
        direct = {ci: X[ci] for ci in range(self.layout.size) if ci not in sig and np.any(X[ci])}
        self.held_out.append(HeldOut(R, r, direct, sig, self.lin, cols.theta, p.periodic))
        self.c["test"] += float(np.sum(r * r))
        self.den["test"] += float(np.sum((p.Y[R] - p.Y.mean(axis=0)) ** 2))

    def add_train(self, p: Prepared, cols: Columns) -> None:
        """Add a training record to every block's Gram matrix.

        Parameters
        ----------
        p : Prepared
            The record.
        cols : Columns
            Its columns (the input-side ones simulated here, a batch at a time).
        """
        R, r, X = cols.rows, cols.r, cols.X
        sigs, inputs = cols.signals, cols.inputs
        for a in range(0, len(sigs), _SCR.batch):       # input-side columns, a batch at a time
            part = sigs[a:a + _SCR.batch]
            Yin = self.lin.simulate_inputs(cols.theta, np.column_stack([x for _, x in part]),
                                           inputs[a:a + _SCR.batch], p.periodic)
            for (ci, _), cc in zip(part, range(Yin.shape[2])):
                X[ci] = Yin[R, :, cc]
        P, Ns, m = X.shape
        w = p.weight
        Xf = X.reshape(P, Ns * m)
        if w != 1.0:
            Xf *= w
        rf = r.reshape(-1) * w
        base, M = self.layout.base, None
        if cols.base_map is None:
            Xb = Xf[base]
        else:       # the base's slope columns are its modes' columns scaled: M @ X[keep]
            keep, M = cols.base_map
            Xb = Xf[keep]
        Gbb, br = Xb @ Xb.T, Xb @ rf
        if M is not None:
            Gbb, br = M @ Gbb @ M.T, M @ br
        nb = len(base)
        for idx, Gb, bb in self.blocks.values():
            Xg = Xf[idx[nb:]]                  # the block: the base, then the candidate's
            Gbg = Xb @ Xg.T if M is None else M @ (Xb @ Xg.T)
            Gb["train"] += np.block([[Gbb, Gbg], [Gbg.T, Xg @ Xg.T]])
            bb["train"] += np.concatenate([br, Xg @ rf])
        self.c["train"] += float(rf @ rf)
        self.den["train"] += float(np.sum((w * (p.Y[R] - p.Y.mean(axis=0))) ** 2))


def build_screen(setup: Setup, theta: np.ndarray | None,  # noqa: F821  (candidates.Setup)
                 delays: Sequence[int] | None = None,
                 level_ref: float | None = None, dynamic_model: bool = False,
                 say: Callable[[str], None] | None = None, stages: dict | None = None,
                 base_fit: Fitted | None = None) -> Screen:
    """The :class:`Screen` of every candidate in ``setup.effects`` around ``theta``.

    Built in phases: the grid of the data (:class:`ScreenGrid`), the column layout
    (:class:`ColumnLayout`), the base's priors, every record's columns
    (:class:`RecordColumns`) accumulated into the training Gram blocks and the held-out
    records (:class:`GramAccumulator`).

    Parameters
    ----------
    setup : Setup
        The diagnosis's shared state (:class:`robrst.diagnose._select.Setup`).
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
    stages = {} if stages is None else stages
    grid = ScreenGrid.of(setup)
    lin = setup.lin if base_fit is None else base_fit.lin
    layout = ColumnLayout(grid, lin, tuple(delays or (0,) * grid.n_in), dynamic_model,
                          base_fit)
    ridge, fixed = _priors(setup, layout, lin, theta, base_fit)
    columns = RecordColumns(grid, layout, lin, theta, base_fit, level_ref, dynamic_model,
                            stages)
    acc = GramAccumulator(layout, lin)
    for p in setup.train:
        acc.add_train(p, columns.of(p, scratch=True))
    for p in setup.test:
        acc.add_test(p, columns.of(p))
    if say:
        say(f"screened {len(layout.screened())} candidate(s) on {layout.size} exact columns")
    return Screen(layout.names, layout.groups, layout.base, acc.blocks, acc.c, acc.den, ridge,
                  layout.starts, fixed, acc.held_out)
