"""Joint fits: effects and the linear part's corrections, by bounded least squares.

A candidate model is ``y = L_theta(v)``, ``v = Chain_z(u)``: effect parameters ``z``
(:mod:`robrst.diagnose._effects`) and linear corrections ``theta``
(:mod:`robrst.diagnose.linear`), fitted together on the training records by
``scipy.optimize.least_squares`` (trust-region reflective, bounds) with the exact
Jacobian.  ``theta`` carries Gaussian priors, so it moves only as far as the data
demand (regularised toward the user's model).  The *dynamic* form of hysteresis lets
the linear corrections vary linearly with the record's excitation level (the
describing function of a hysteretic stiffness: resonances soften and gains change with
amplitude); it needs periodic records at two or more levels.

Output-side blocks (:class:`Post`), each linear in its parameters and without a prior,
can be fitted with any candidate: a constant output offset per output (``offset``: a
sensor zero or bias, in µm), the sensor's static curvature (``curvature``: quadratic
and cubic terms of each output about its training mean), and channel cross-coupling of a
MIMO model (``mixing``: ``v_j += sum_k c_jk u_k`` on the input side and ``y_i += sum_l
d_il y_l`` on the output side, off-diagonal only)::

    u -> Chain -> input mixing -> L_theta -> output mixing -> sensor curvature -> + offset

Periodic records are fitted in steady state on their period average (weight: the
number of periods), the effects warmed up on one extra period.  Records are simulated
whole; the residual of a long record enters the fit on every k-th sample (at most
``fit_rows`` rows per record, weighted by sqrt(k)): the cost of each solver step then does
not grow with the record.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from robrst.diagnose._effects import Chain
from robrst.diagnose.linear import parameter_std
from robrst.diagnose.options import OPTIONS

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.diagnose.linear import LinearPart

__all__ = ["Prepared", "prepare", "Fitted", "fit_model", "fit_by_level", "model_jacobian",
           "level_map_of", "level_factor", "slope_basis", "compressed", "Pooled", "pool_periodic"]

SLOPE_KINDS = ("dlog_freq", "dlog_damping", "input_gain", "gain", "mode_gain")
_FIT = OPTIONS.fit


@dataclass(frozen=True, eq=False)
class Prepared:
    """A record ready for fitting or scoring (arrays in samples x channels).

    Parameters
    ----------
    name : str
        The record's name.
    U : numpy.ndarray
        Inputs ``(N, k)`` [V].
    Y : numpy.ndarray
        Outputs ``(N, m)`` [µm].
    temp : numpy.ndarray
        Temperature per sample [°C].
    periodic : bool
        One steady-state period (period-averaged).
    warm : int
        Warm-up samples prepended for the effects (periodic).
    weight : float
        Weight of the record in the fit (the periods averaged).
    level : float
        Excitation level [V rms].
    """

    name: str
    U: np.ndarray
    Y: np.ndarray
    temp: np.ndarray
    periodic: bool
    warm: int             # warm-up samples prepended for the effects (periodic)
    weight: float
    level: float          # excitation level [V rms]


def prepare(d: Dataset, reference_C: float, for_fit: bool = True) -> Prepared:
    """Prepared record of ``d``; a periodic record is period-averaged when ``for_fit``.

    Parameters
    ----------
    d : Dataset
        The record.
    reference_C : float
        The temperature of a record without one [°C].
    for_fit : bool
        Average a periodic record's periods (fitting); else keep the whole record
        (scoring).

    Returns
    -------
    Prepared
    """
    temp = d.temp_or(reference_C)
    if d.period and d.periods >= 1:
        P, k = d.period, d.periods
        if for_fit:
            U, Y = d.U[:P], d.Y.reshape(k, P, -1).mean(axis=0)
            T, w = temp.reshape(k, P).mean(axis=0), float(np.sqrt(k))
        else:
            U, Y, T, w = d.U, d.Y, temp, 1.0
        return Prepared(d.source, U, Y, T, True, P, w, d.level)
    return Prepared(d.source, d.U, d.Y, temp, False, 0, 1.0, d.level)


@dataclass(frozen=True, eq=False)
class Pooled:
    """Periodic records of one linear model pooled into as many records as it has inputs.

    For a linear model ``H`` on the DFT grid the training cost of ``R`` periodic records is
    ``sum_r ||Y_r - H U_r||^2``; per frequency it depends on the records only through
    ``S = sum_r U_r U_r^H`` (``k x k``) and ``T = sum_r Y_r U_r^H`` (``m x k``).  With ``S =
    L L^H`` (``L = V Lambda^(1/2)`` from ``S``'s eigendecomposition) and ``Y~ = T V
    Lambda^(-1/2)``, the ``k`` records whose spectra are ``L``'s and ``Y~``'s columns have
    ``sum_c ||Y~_c - H L_c||^2 = sum_r ||Y_r - H U_r||^2 - constant`` for every ``H``: the
    same minimiser, gradient and ``J^T J``, from ``k`` records instead of ``R`` (a mirror
    level: 6 records of 3 inputs -> 3; every level of a linear re-fit: 18 -> 3).  The
    records' weights are folded in (the pooled ones weigh 1).

    Parameters
    ----------
    records : list of Prepared
        The pooled records (and the records that could not be pooled, as they were).
    constant : float
        ``sum_r w_r^2 ||Y_r||^2 - sum_c ||Y~_c||^2``: what the pooled cost lacks.
    rows : int
        The residual rows of the original records.
    """

    records: list
    constant: float
    rows: int


def pool_periodic(train: Sequence[Prepared], by_level: bool = False) -> Pooled:
    """Pool periodic records that one linear model simulates (see :class:`Pooled`).

    Records are grouped by length (and by level with ``by_level``: the dynamic form's model
    changes with it); a group is pooled when it holds more records than inputs.  A record
    that is not periodic, or too long for a fit's rows (:data:`~robrst.diagnose.options`
    ``fit_rows``: its residual is subsampled), stays as it is.

    Parameters
    ----------
    train : sequence of Prepared
        The training records.
    by_level : bool
        Records of different excitation levels are not pooled together.

    Returns
    -------
    Pooled

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.diagnose.fit import Prepared, pool_periodic
    >>> rng = np.random.default_rng(0)
    >>> recs = [Prepared("r", rng.normal(size=(64, 1)), rng.normal(size=(64, 1)), np.zeros(64),
    ...                  True, 64, 1.0, 1.0) for _ in range(4)]
    >>> pooled = pool_periodic(recs)
    >>> len(pooled.records), pooled.rows
    (1, 256)
    """
    groups = {}
    kept = []
    for p in train:
        if p.periodic and len(p.Y) <= _FIT.fit_rows:
            groups.setdefault((len(p.Y), p.level if by_level else None), []).append(p)
        else:
            kept.append(p)
    out, constant = [], 0.0
    for (n, _), g in groups.items():
        k = g[0].U.shape[1]
        if len(g) <= k:
            out += g
            continue
        Uf = np.stack([np.fft.rfft(p.U * p.weight, axis=0) for p in g], axis=2)   # (F, k, R)
        Yf = np.stack([np.fft.rfft(p.Y * p.weight, axis=0) for p in g], axis=2)   # (F, m, R)
        S = Uf @ np.conj(np.swapaxes(Uf, 1, 2))
        T = Yf @ np.conj(np.swapaxes(Uf, 1, 2))
        real = [0] + ([n // 2] if n % 2 == 0 else [])   # DC and Nyquist: real spectra
        S[real], T[real] = S[real].real, T[real].real
        lam, V = np.linalg.eigh(S)
        for b in real:                    # real eigenvectors there (irfft keeps real parts)
            lam[b], V[b] = np.linalg.eigh(S[b].real)
        top = np.max(lam, axis=1, keepdims=True)
        live = lam > 1e-12 * np.maximum(top, 1e-300)
        root = np.sqrt(np.where(live, lam, 0.0))
        L = V * root[:, None, :]
        Yt = (T @ V) * np.where(live, 1.0 / np.where(live, root, 1.0), 0.0)[:, None, :]
        ref = g[0]
        for c in range(k):
            u = np.fft.irfft(L[:, :, c], n=n, axis=0)
            y = np.fft.irfft(Yt[:, :, c], n=n, axis=0)
            out.append(Prepared(f"{ref.name} (pooled {c + 1} of {k})", u, y,
                                np.mean([p.temp for p in g], axis=0), True, ref.warm, 1.0,
                                float(np.mean([p.level for p in g]))))
            constant -= float(np.sum(y * y))
        constant += float(sum(p.weight ** 2 * np.sum(p.Y * p.Y) for p in g))
    return Pooled(out + kept, max(constant, 0.0), int(sum(p.Y.size for p in train)))


def slope_basis(f: float, knots: Sequence[float] = ()) -> np.ndarray:
    """The piecewise-linear level basis at level factor ``f``: ``[f, max(f - k, 0), ...]``.

    Parameters
    ----------
    f : float
        The level factor.
    knots : sequence of float
        Interior knots (level factors).

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    >>> from robrst.diagnose.fit import slope_basis
    >>> slope_basis(2.0, (1.0,)).tolist()
    [2.0, 1.0]
    """
    return np.array([f] + [max(f - k, 0.0) for k in knots], float)


def level_factor(level: float, reference: float) -> float:
    """Excitation-level coordinate of the dynamic form: ``(a - a_ref) / a_ref``.

    Parameters
    ----------
    level : float
        The record's level [V rms].
    reference : float
        The reference level [V rms].

    Returns
    -------
    float
        0 when ``reference <= 0``.
    """
    return (level - reference) / reference if reference > 0 else 0.0


@dataclass(frozen=True)
class Post:
    """Output-side blocks of a fit and their layout (see the module doc).

    Parameters
    ----------
    m, k : int
        Outputs and inputs.
    offset, curvature, mixing : bool
        The blocks fitted: a constant per output, the sensor's quadratic and cubic terms
        per output, the channels' cross-coupling.
    center, scale : tuple of float
        The training outputs' mean and half range per output (the sensor map's centre,
        and the scale of its bounds).
    """

    m: int
    k: int
    offset: bool = False
    curvature: bool = False
    mixing: bool = False
    center: tuple = ()
    scale: tuple = ()

    def sizes(self):
        m, k = self.m, self.k
        return {"offset": m if self.offset else 0, "curvature": 2 * m if self.curvature else 0,
                "mix_in": k * (k - 1) if self.mixing else 0,
                "mix_out": m * (m - 1) if self.mixing else 0}

    @property
    def size(self):
        return sum(self.sizes().values())

    def slices(self, start):
        out, i = {}, start
        for key, n in self.sizes().items():
            out[key] = slice(i, i + n)
            i += n
        return out

    def pairs(self, n):
        """Off-diagonal (row, column) pairs of an n x n mixing matrix, row-major."""
        return [(i, j) for i in range(n) for j in range(n) if i != j]

    def names(self):
        m, k = self.m, self.k
        sy = (lambda j: f"_y{j + 1}") if m > 1 else (lambda j: "")
        out = [f"offset{j}" for j in range(m)] if self.offset else []
        if self.curvature:
            out += [f"quadratic{j}" for j in range(m)] + [f"cubic{j}" for j in range(m)]
        if self.mixing:
            out += [f"mix_u{j + 1}_u{i + 1}" for j, i in self.pairs(k)]
            out += [f"mix_y{j + 1}_y{i + 1}" for j, i in self.pairs(m)]
        del sy
        return out

    def bounds(self):
        lo, hi = [], []
        if self.offset:
            lo += [-np.inf] * self.m
            hi += [np.inf] * self.m
        if self.curvature:
            sc = np.asarray(self.scale, float)
            lo += list(-2.0 / sc) + list(-4.0 / sc ** 2)
            hi += list(2.0 / sc) + list(4.0 / sc ** 2)
        if self.mixing:
            n = self.k * (self.k - 1) + self.m * (self.m - 1)
            lo += [-1.0] * n
            hi += [1.0] * n
        return np.array(lo, float), np.array(hi, float)

    def matrices(self, x, start):
        """Input and output mixing matrices ``(k, k)``, ``(m, m)`` (zero diagonal)."""
        sl = self.slices(start)
        Ci, Co = np.zeros((self.k, self.k)), np.zeros((self.m, self.m))
        if self.mixing:
            for (i, j), v in zip(self.pairs(self.k), x[sl["mix_in"]]):
                Ci[i, j] = v
            for (i, j), v in zip(self.pairs(self.m), x[sl["mix_out"]]):
                Co[i, j] = v
        return Ci, Co


def make_post(train, offset=False, curvature=False, mixing=False):
    """The :class:`Post` of a fit on prepared records ``train`` (None when empty)."""
    if not (offset or curvature or mixing):
        return None
    Y = np.concatenate([p.Y for p in train])
    U = train[0].U
    return Post(m=Y.shape[1], k=U.shape[1], offset=offset, curvature=curvature,
                mixing=mixing and (U.shape[1] > 1 or Y.shape[1] > 1),
                center=tuple(float(c) for c in Y.mean(axis=0)),
                scale=tuple(float(max(0.5 * c, 1e-12)) for c in np.ptp(Y, axis=0)))


@dataclass(frozen=True, eq=False)
class Fitted:
    """A fitted candidate: effects, linear corrections (and level slopes), predictor.

    Parameters
    ----------
    name : str
        The candidate's name.
    effects : tuple of str
        The effects fitted.
    form : str
        ``"input"`` or ``"dynamic"``.
    chain : Chain
        The effects' chain.
    lin : LinearPart
        The linear corrections' model.
    x : numpy.ndarray
        The fitted parameters ``[z, theta (joint), slopes, output blocks]``.
    std : numpy.ndarray
        Their 1-sigma.
    joint : bool
        The linear corrections were fitted.
    slopes : tuple of int
        Indices into ``theta`` that vary with level (dynamic form).
    level_ref : float
        The reference level [V rms].
    n_eval : int
        Model evaluations.
    train_cost : float
        The final least-squares cost.
    theta_fixed : numpy.ndarray, optional
        Fixed linear corrections when not ``joint``.
    n_offset : int
        Constant output offsets fitted (one per output, or none).
    post : Post, optional
        The output-side blocks fitted (offset, sensor curvature, cross-coupling).
    level_knots : tuple of float
        Interior knots of the level coordinate (level factors of the training levels
        between the lowest and the highest): a correction that varies with the level is
        piecewise linear in the level factor ``f``, ``s f + sum_k h_k max(f - f_k, 0)``
        (:func:`slope_basis`; none: a line).  The slopes' parameters are ``s`` for every
        slope index, then ``h_k`` likewise per knot.

    Attributes
    ----------
    n_slope : int
        Number of level parameters (slopes times the basis functions).
    """

    name: str
    effects: tuple
    form: str
    chain: Chain
    lin: LinearPart
    x: np.ndarray
    std: np.ndarray
    joint: bool
    slopes: tuple          # indices into theta that vary with level (dynamic form)
    level_ref: float
    n_eval: int
    train_cost: float
    theta_fixed: np.ndarray = None
    n_offset: int = 0      # constant output offsets fitted (one per output, or none)
    post: Post = None      # output-side blocks (offset, curvature, mixing)
    level_knots: tuple = ()  # interior knots of the level factor (piecewise-linear levels)

    @property
    def n_slope(self) -> int:
        """Number of level parameters (slope indices times the basis functions)."""
        return len(self.slopes) * (1 + len(self.level_knots))

    def slope_names(self) -> list:
        """Names of the level parameters, in their order.

        Returns
        -------
        list of str
            ``slope{i}``, then ``slope{i}_above{k}`` per interior knot ``k``.
        """
        out = [f"slope{i}" for i in self.slopes]
        for k in range(len(self.level_knots)):
            out += [f"slope{i}_above{k + 1}" for i in self.slopes]
        return out

    def slope_prior_sd(self) -> np.ndarray:
        """Prior standard deviation of every level parameter (that of its correction).

        Returns
        -------
        numpy.ndarray
        """
        return np.tile(self.lin.prior_sd[list(self.slopes)], 1 + len(self.level_knots))

    @property
    def _post_start(self):
        return self.chain.size + (self.lin.size if self.joint else 0) + self.n_slope

    def parts(self, x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Effect parameters, linear corrections and level slopes (not the output blocks).

        Parameters
        ----------
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        z, theta, slopes : numpy.ndarray
        """
        x = self.x if x is None else x
        nz, nt = self.chain.size, self.lin.size if self.joint else 0
        fixed = self.theta_fixed if self.theta_fixed is not None else np.zeros(self.lin.size)
        return (x[:nz], (x[nz:nz + nt] if self.joint else fixed),
                x[nz + nt:nz + nt + self.n_slope])

    def block(self, key: str, x: np.ndarray | None = None) -> np.ndarray:
        """Parameters of output block ``key``; empty when not fitted.

        Parameters
        ----------
        key : {"offset", "curvature", "mix_in", "mix_out"}
            The block.
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        x = self.x if x is None else x
        if self.post is None:
            return np.zeros(0)
        return x[self.post.slices(self._post_start)[key]]

    def output_offset(self, x: np.ndarray | None = None) -> np.ndarray:
        """The fitted constant output offsets ``(m,)`` [µm] (zeros when not fitted).

        Parameters
        ----------
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        x = self.x if x is None else x
        if not self.n_offset:
            return np.zeros(1)
        return self.block("offset", x)

    def theta_at(self, level: float, x: np.ndarray | None = None) -> np.ndarray:
        """The linear corrections at an excitation level (dynamic form: with the slopes).

        Parameters
        ----------
        level : float
            The level [V rms].
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        _, th, s = self.parts(x)
        th = th.copy()
        if self.slopes:
            b = slope_basis(level_factor(level, self.level_ref), self.level_knots)
            th[list(self.slopes)] += b @ s.reshape(b.size, len(self.slopes))
        return th

    def effective_input(self, p: Prepared, x: np.ndarray | None = None,
                        jac: bool = False) -> tuple[np.ndarray, list | None]:
        """Effective inputs ``(N, k)`` of a prepared record (chain, then input mixing).

        Parameters
        ----------
        p : Prepared
            The record.
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).
        jac : bool
            Also the chain's Jacobians.

        Returns
        -------
        V : numpy.ndarray
        dV : list of numpy.ndarray or None
            Per input ``(N, n_z)``.
        """
        z = self.parts(x)[0]
        U, T = p.U, p.temp
        if p.warm:
            U, T = np.vstack([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
        V, dV = self.chain.run(z, U, T, jac=jac, warm=p.warm)
        if self.post is not None and self.post.mixing:
            Ci, _ = self.post.matrices(self.x if x is None else x, self._post_start)
            V = V + V @ Ci.T
            if jac:
                dV = [dV[j] + sum(Ci[j, i] * dV[i] for i in range(len(dV)) if i != j)
                      for j in range(len(dV))]
        return V, dV

    def linear_output(self, p: Prepared, V: np.ndarray,
                      x: np.ndarray | None = None) -> np.ndarray:
        """Outputs ``(N, m)`` of the linear part for effective inputs ``V``.

        Parameters
        ----------
        p : Prepared
            The record (its level and whether it is periodic).
        V : numpy.ndarray
            Effective inputs ``(N, k)``.
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        return self.lin.simulate(self.theta_at(p.level, x), V, p.periodic)

    def output_side(self, Y: np.ndarray, x: np.ndarray | None = None) -> np.ndarray:
        """Output mixing, sensor curvature and offset applied to the linear outputs ``Y``.

        Parameters
        ----------
        Y : numpy.ndarray
            The linear part's outputs ``(N, m)``.
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        if self.post is None:
            return Y
        x = self.x if x is None else x
        if self.post.mixing:
            _, Co = self.post.matrices(x, self._post_start)
            Y = Y + Y @ Co.T
        if self.post.curvature:
            a = self.block("curvature", x)
            m = Y.shape[1]
            E = Y - np.asarray(self.post.center)[None, :]
            Y = Y + a[None, :m] * E ** 2 + a[None, m:] * E ** 3
        if self.post.offset:
            Y = Y + self.block("offset", x)[None, :]
        return Y

    def predict_prepared(self, p: Prepared, x: np.ndarray | None = None) -> np.ndarray:
        """Simulated outputs ``(N, m)`` of a prepared record.

        Parameters
        ----------
        p : Prepared
            The record.
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        V, _ = self.effective_input(p, x)
        return self.output_side(self.linear_output(p, V, x), x)

    def params(self) -> dict:
        """Reported effect parameters and 1-sigma (delta method): ``{effect: (values, sds)}``.

        Returns
        -------
        dict
            Values and sigmas as dicts keyed by parameter name (``output_offset`` too,
            when fitted).
        """
        z = self.parts()[0]
        out = self.chain.report(z, self.std[:self.chain.size])
        if self.post is None:
            return out
        m, k = self.post.m, self.post.k
        sfx = (lambda j: f"_y{j + 1}") if m > 1 else (lambda j: "")
        sl = self.post.slices(self._post_start)
        x, sd = self.x, self.std
        if self.post.offset:
            out["output_offset"] = (
                {f"offset_um{sfx(j)}": float(v) for j, v in enumerate(x[sl["offset"]])},
                {f"offset_um{sfx(j)}": float(d) for j, d in enumerate(sd[sl["offset"]])})
        if self.post.curvature:
            a, s = x[sl["curvature"]], sd[sl["curvature"]]
            vals, sds = {}, {}
            for j in range(m):
                vals[f"center_um{sfx(j)}"], sds[f"center_um{sfx(j)}"] = self.post.center[j], 0.0
                vals[f"quadratic_per_um{sfx(j)}"] = float(a[j])
                sds[f"quadratic_per_um{sfx(j)}"] = float(s[j])
                vals[f"cubic_per_um2{sfx(j)}"] = float(a[m + j])
                sds[f"cubic_per_um2{sfx(j)}"] = float(s[m + j])
            out["output_nonlinearity"] = (vals, sds)
        if self.post.mixing:
            vals, sds = {}, {}
            for (i, j), v, d in zip(self.post.pairs(k), x[sl["mix_in"]], sd[sl["mix_in"]]):
                vals[f"u{j + 1}_into_u{i + 1}"], sds[f"u{j + 1}_into_u{i + 1}"] = float(v), float(d)
            for (i, j), v, d in zip(self.post.pairs(m), x[sl["mix_out"]], sd[sl["mix_out"]]):
                vals[f"y{j + 1}_into_y{i + 1}"], sds[f"y{j + 1}_into_y{i + 1}"] = float(v), float(d)
            out["cross_coupling"] = (vals, sds)
        return out

    def linear_change(self) -> tuple[dict, dict]:
        """Linear corrections (and level slopes) by name, with 1-sigma.

        Returns
        -------
        values, sigmas : dict
            Fixed corrections have sigma NaN; slopes are named ``<name>_per_level`` (and a
            change of slope above an interior level ``<name>_per_level_above<k>``).
        """
        nz = self.chain.size
        out, sd = {}, {}
        if self.joint:
            for i, n in enumerate(self.lin.names):
                out[n], sd[n] = float(self.x[nz + i]), float(self.std[nz + i])
        elif np.any(self.parts()[1]):
            for n, v in zip(self.lin.names, self.parts()[1]):
                out[n], sd[n] = float(v), float("nan")
        j0 = nz + (self.lin.size if self.joint else 0)
        for b in range(1 + len(self.level_knots)):
            for k, i in enumerate(self.slopes):
                n = f"{self.lin.names[i]}_per_level" + (f"_above{b}" if b else "")
                j = j0 + b * len(self.slopes) + k
                out[n], sd[n] = float(self.x[j]), float(self.std[j])
        return out, sd


def _post_jacobian(fit, x, J, Y):
    """Fill the output blocks' columns of ``J`` ``(N, m, n_x)`` and carry the others through
    output mixing and curvature; ``Y`` are the linear part's outputs (before the blocks)."""
    post = fit.post
    sl = post.slices(fit._post_start)
    first = fit._post_start
    if post.mixing:
        _, Co = post.matrices(x, fit._post_start)
        J[:, :, :first] += np.einsum("nlc,il->nic", J[:, :, :first], Co)
        for c, (i, j) in zip(range(sl["mix_out"].start, sl["mix_out"].stop), post.pairs(post.m)):
            J[:, i, c] = Y[:, j]
        J[:, :, sl["mix_in"]] += np.einsum("nlc,il->nic", J[:, :, sl["mix_in"]], Co)
        Y = Y + Y @ Co.T
    if post.curvature:
        a = x[sl["curvature"]]
        m = post.m
        E = Y - np.asarray(post.center)[None, :]
        f = 1.0 + 2 * a[None, :m] * E + 3 * a[None, m:] * E ** 2
        keep = [c for c in range(J.shape[2]) if not sl["curvature"].start <= c < sl["curvature"].stop
                and not sl["offset"].start <= c < sl["offset"].stop]
        J[:, :, keep] *= f[:, :, None]
        for j in range(m):
            J[:, j, sl["curvature"].start + j] = E[:, j] ** 2
            J[:, j, sl["curvature"].start + m + j] = E[:, j] ** 3
    if post.offset:
        for j in range(post.m):
            J[:, j, sl["offset"].start + j] = 1.0


def model_jacobian(fit: Fitted, p: Prepared, x: np.ndarray | None = None,
                   level_columns: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """A candidate's outputs on a record and their derivatives with respect to its parameters.

    Exact for the chain (compiled sensitivities, closed forms), the gains and the output
    blocks; forward differences for the modes.  The linear part is the fitted one before a
    polish of the residues.

    Parameters
    ----------
    fit : Fitted
        The candidate.
    p : Prepared
        The record.
    x : numpy.ndarray, optional
        A parameter vector (default the fitted one).
    level_columns : bool
        Write the level slopes' columns (each its mode's column times the record's level
        basis value); without, they stay zero for a caller that scales them itself.

    Returns
    -------
    Y : numpy.ndarray
        Outputs ``(N, m)``.
    J : numpy.ndarray
        ``dY / dx`` ``(N, m, n_x)``.
    """
    x = fit.x if x is None else np.asarray(x, float)
    lin, chain = fit.lin, fit.chain
    nz, nt, ns = chain.size, lin.size if fit.joint else 0, fit.n_slope
    V, dV = fit.effective_input(p, x, jac=True)
    th = fit.theta_at(p.level, x)
    Y0, JL = lin.simulate_jac(th, V, p.periodic)
    N, m = Y0.shape
    J = np.zeros((N, m, x.size))
    for j, dv in enumerate(dV):
        for c in np.flatnonzero(np.any(dv != 0, axis=0)):
            J[:, :, c] += lin.simulate_input(th, dv[:, c], j, p.periodic)
    if fit.joint:
        J[:, :, nz:nz + nt] = JL
    if fit.slopes and level_columns:
        b = slope_basis(level_factor(p.level, fit.level_ref), fit.level_knots)
        k, c0 = len(fit.slopes), nz + nt
        Js = JL[:, :, list(fit.slopes)]
        for q, v in enumerate(b):       # in place: a zero knot term stays the zeros it is
            if v:
                np.multiply(Js, v, out=J[:, :, c0 + q * k:c0 + (q + 1) * k])
    post = fit.post
    if post is not None:
        if post.mixing:
            U, T = p.U, p.temp
            if p.warm:
                U, T = np.vstack([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
            V0, _ = chain.run(x[:nz], U, T, jac=False, warm=p.warm)
            sl = post.slices(nz + nt + ns)["mix_in"]
            for c, (i, j) in zip(range(sl.start, sl.stop), post.pairs(post.k)):
                J[:, :, c] = lin.simulate_input(th, V0[:, j], i, p.periodic)
        _post_jacobian(fit, x, J, Y0)
    return fit.output_side(Y0, x), J


def level_map_of(fit: Fitted, p: Prepared
                 ) -> tuple[np.ndarray, dict[int, tuple[int, float]], np.ndarray] | None:
    """How a fit's level slopes stand on a record, in :func:`model_jacobian`'s layout.

    A slope's Jacobian column is its mode's column times the record's level basis value,
    so every column of the Jacobian is ``M @`` the columns of ``keep``.

    Parameters
    ----------
    fit : Fitted
        The fit (its linear part joint with the effects, for the modes' columns to be in
        its Jacobian).
    p : Prepared
        The record (its level).

    Returns
    -------
    tuple or None
        ``(keep, slopes, M)``: the other parameters' indices, ``{slope index: (its mode's
        index, the basis value)}`` and ``M`` ``(x.size, keep.size)``; ``None`` for a fit
        without slopes or not joint.
    """
    if not (fit.joint and fit.slopes):
        return None
    nz, nt, k = fit.chain.size, fit.lin.size, len(fit.slopes)
    b = slope_basis(level_factor(p.level, fit.level_ref), fit.level_knots)
    slopes = {nz + nt + q * k + j: (nz + i, float(v)) for q, v in enumerate(b)
              for j, i in enumerate(fit.slopes)}
    keep = np.array([c for c in range(fit.x.size) if c not in slopes], int)
    pos = {c: n for n, c in enumerate(keep)}
    M = np.zeros((fit.x.size, keep.size))
    M[keep, np.arange(keep.size)] = 1.0
    for c, (src, v) in slopes.items():
        M[c, pos[src]] = v
    return keep, slopes, M


def fit_model(name: str, effects: Sequence[str], train: Sequence[Prepared], lin: LinearPart,
              chain: Chain, noise_sigma: float, joint: bool = True, dynamic: bool = False,
              start: dict | None = None, theta: np.ndarray | None = None, max_nfev: int = 40,
              ftol: float = 1e-10, offset: bool = False, curvature: bool = False,
              mixing: bool = False, pinned: Sequence[int] = (),
              prior_center: np.ndarray | None = None, prior_scale: float = 1.0) -> Fitted:
    """Fit ``effects`` (+ linear corrections if ``joint``) on prepared training records.

    Parameters
    ----------
    name : str
        Candidate name (reports).
    effects : tuple of str
        Input-side effects (the ``chain`` holds them).
    train : list of Prepared
        The prepared training records.
    lin : LinearPart
        The linear corrections' model.
    chain : Chain
        The effects' chain.
    noise_sigma : float
        Noise std per sample [µm] (weight of the priors on the linear corrections).
    joint : bool
        Fit the linear corrections too (else they stay at ``theta``, default 0).
    dynamic : bool
        Let the linear corrections vary with the excitation level (amplitude-dependent
        dynamics).
    start : dict, optional
        Starting values by parameter name (from an earlier fit).
    theta : array, optional
        Fixed linear corrections when not ``joint``.
    max_nfev, ftol : int, float
        Stopping rules of the least-squares solver.
    offset : bool
        Fit a constant output offset per output too (parameters ``offset_um``, ...).
    curvature : bool
        Fit the sensor's quadratic and cubic curvature per output
        (``output_nonlinearity``).
    mixing : bool
        Fit the channels' cross-coupling (``cross_coupling``; several inputs or outputs).
    pinned : tuple of int
        Linear corrections held at zero (and their level slopes): modes the training
        records do not excite (:func:`robrst.diagnose.linear.unexcited`).
    prior_center : numpy.ndarray, optional
        Centre of the linear corrections' priors (default the user's model, zeros; only
        with ``joint`` and without ``dynamic``).
    prior_scale : float
        Multiplies the priors' standard deviations.

    Returns
    -------
    Fitted
    """
    slopes = tuple(i for i, (k, _) in enumerate(lin.kinds) if k in SLOPE_KINDS) if dynamic else ()
    level_ref = min(p.level for p in train)
    nz, nt, ns = chain.size, lin.size if joint else 0, len(slopes)
    post = make_post(train, offset, curvature, mixing)
    no = post.sizes()["offset"] if post else 0
    plo, phi = post.bounds() if post else (np.zeros(0), np.zeros(0))
    lo = np.concatenate([chain.lower, lin.lower if joint else [], np.full(ns, -_FIT.slope_bound), plo])
    hi = np.concatenate([chain.upper, lin.upper if joint else [], np.full(ns, _FIT.slope_bound), phi])
    for i in (pinned if joint else ()):
        lo[nz + i], hi[nz + i] = -1e-12, 1e-12
        if i in slopes:
            k = nz + nt + slopes.index(i)
            lo[k], hi[k] = -1e-12, 1e-12
    if joint and "hysteresis" in chain.effects:      # its gain is the linear gain: pin that
        for i, (kind, _) in enumerate(lin.kinds):
            if kind in ("gain", "input_gain"):
                lo[nz + i], hi[nz + i] = -1e-12, 1e-12
    sd = np.concatenate([lin.prior_sd if joint else [], lin.prior_sd[list(slopes)]])
    x0 = np.concatenate([chain.z0, np.zeros(nt + ns + (post.size if post else 0))])
    names = (list(chain.names) + (list(lin.names) if joint else []) + [f"slope{i}" for i in slopes]
             + (post.names() if post else []))
    for i, n in enumerate(names):
        if start and n in start:
            x0[i] = np.clip(start[n], lo[i], hi[i])
    scale = np.sqrt(sum(p.weight ** 2 * float(np.sum((p.Y - p.Y.mean(0)) ** 2)) for p in train))
    scale = scale or 1.0
    prior_w = noise_sigma / scale / (sd * prior_scale)
    center = np.zeros(nt + ns)
    if prior_center is not None and joint and not dynamic:
        center[:nt] = prior_center
    fixed = np.zeros(lin.size) if theta is None else np.asarray(theta, float)
    proto = Fitted(name, tuple(effects), "dynamic" if dynamic else "input", chain, lin, x0,
                   np.zeros_like(x0), joint, slopes, level_ref, 0, 0.0, fixed, no, post)

    # a linear model alone on periodic records: their sufficient statistics (Pooled)
    pooled = pool_periodic(train, by_level=bool(slopes)) if (
        chain.size == 0 and post is None and joint) else None
    rows_of = train if pooled is None else pooled.records
    # residual rows: every k-th sample of a long record (the simulation runs over all of it),
    # weighted by sqrt(k) so the priors keep their weight
    strides = [max(1, -(-len(p.Y) // _FIT.fit_rows)) for p in rows_of]

    def residual(x):
        r = [(proto.predict_prepared(p, x) - p.Y)[::k].ravel() * (p.weight * np.sqrt(k) / scale)
             for p, k in zip(rows_of, strides)]
        r.append(prior_w * (x[nz:nz + nt + ns] - center))
        out = np.concatenate(r)
        return np.where(np.isfinite(out), out, 1e3)

    def blocks(x):
        """The Jacobian's rows, a record at a time (as the residual: a trial point the
        solver rejects gets zeros): ``(rows, residual rows they stand for, transform of those
        residual rows)``.  A periodic record fitted whole by the linear part alone gives its
        rows as the real and imaginary parts of their spectra, weighted so that the inner
        products are the time rows' (Parseval): no transform back per column."""
        for p, k in zip(rows_of, strides):
            c = p.weight * np.sqrt(k) / scale
            if p.periodic and k == 1 and proto.chain.size == 0 and post is None and joint:
                J = spectral_jacobian(proto, p, x)
                J *= c
                yield np.nan_to_num(J, copy=False, nan=0.0, posinf=0.0, neginf=0.0), p.Y.size, (
                    lambda rr, n=len(p.Y): parseval_rows(
                        np.fft.rfft(rr.reshape(n, -1), axis=0), n))
                continue
            J = model_jacobian(proto, p, x)[1][::k]
            J = J.reshape(-1, J.shape[2]) * c
            yield np.where(np.isfinite(J), J, 0.0), J.shape[0], None
        prior = np.zeros((nt + ns, x.size))
        prior[:, nz:nz + nt + ns] = np.diag(prior_w)
        yield prior, nt + ns, None

    if x0.size == 0:
        r0 = residual(x0)
        res = optimize.OptimizeResult(x=x0, cost=0.5 * float(np.sum(r0 ** 2)), nfev=1,
                                      jac=np.zeros((1, 0)), fun=r0)
        n_rows = r0.size
    else:
        # trial points may overflow (an effect driven far out): the optimiser
        # rejects them; their floating-point warnings only reach the user
        # a parameter held by a box of zero width (pinned, or not determined by the
        # records) leaves the solver's variables: inside the trust-region reflective
        # method a box that narrow cuts every step that touches it to nothing
        free = hi - lo > _FIT.held_width
        x0 = np.clip(x0, lo, hi)
        fun, jac, n_rows = compressed(residual, blocks, x0.size)

        def whole(xf):
            x = x0.copy()
            x[free] = xf
            return x

        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            res = optimize.least_squares(
                lambda xf: fun(whole(xf)), x0[free],
                jac=lambda xf, *_: jac(whole(xf))[:, free],
                bounds=(lo[free], hi[free]), method="trf", x_scale="jac", ftol=ftol,
                xtol=1e-10, gtol=1e-10, max_nfev=max_nfev)
        res.x = whole(res.x)
        res.x, res.cost, released = _released_limits(chain, res.x, float(res.cost), free,
                                                     residual)
        if released or not free.all():   # the 1-sigma as before: every parameter's column
            res.jac = jac(res.x)
        n_rows = n_rows()
    cost = float(res.cost)
    if pooled is not None:        # the cost and the rows of the records themselves
        cost += 0.5 * pooled.constant / scale ** 2
        n_rows = pooled.rows + nt + ns
    std = parameter_std(res.jac, cost, n_rows) if x0.size else np.zeros(0)
    return Fitted(name, tuple(effects), proto.form, chain, lin, res.x, std, joint, slopes,
                  level_ref, int(res.nfev), 2 * cost, fixed, no, post)


def _released_limits(chain, x, cost, free, residual):
    """``(x, cost, released)``: every saturation limit the training records do not need
    moved out of their way.

    A limit that clips no training input has no gradient, and the fit leaves it at their
    edge (or, clipping a few samples by the noise's size, just inside); there it clips
    held-out inputs beyond them that no record tested. A limit is kept where it lowers
    the sum of squares by more than the Bayesian information criterion's price of a
    parameter, ``ln(n) sigma^2`` (``n`` residual rows, ``sigma^2 = SS / n``), and else
    moved to the far end of its bounds (:meth:`Chain.limits`), the others held."""
    released = []
    for i, far in chain.limits():
        if not free[i] or x[i] == far:
            continue
        trial = x.copy()
        trial[i] = far
        r = residual(trial)
        c = 0.5 * float(r @ r)
        if 2.0 * (c - cost) <= np.log(r.size) * 2.0 * cost / r.size:
            x, cost = trial, c
            released.append(i)
    return x, cost, released


def parseval_rows(S: np.ndarray, n: int) -> np.ndarray:
    """Real rows of a real signal's spectrum whose inner products are the signal's.

    ``S`` is ``rfft`` of ``n`` samples along axis 0 (any trailing axes); with ``w = 1`` at
    DC (and at Nyquist for an even ``n``) and ``w = 2`` elsewhere, ``sum_t a_t b_t =
    sum_k (w_k / n) Re(A_k conj(B_k))``: the rows are ``sqrt(w_k / n) (Re S_k, Im S_k)``,
    flattened over the trailing axes but the last when ``S`` has three.

    Parameters
    ----------
    S : numpy.ndarray
        ``(F, ...)`` complex.
    n : int
        The signal's length.

    Returns
    -------
    numpy.ndarray
        ``(2 F prod(middle axes), last)`` for a 3-D ``S``, else ``(2 F prod(rest),)``.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.diagnose.fit import parseval_rows
    >>> x = np.arange(6.0)
    >>> r = parseval_rows(np.fft.rfft(x), 6)
    >>> round(float(r @ r), 9), float(x @ x)
    (55.0, 55.0)
    """
    F = S.shape[0]
    w = np.full(F, 2.0)
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0
    w = np.sqrt(w / n).reshape((F,) + (1,) * (S.ndim - 1))
    R = np.empty((2,) + S.shape)            # the real rows, then the imaginary ones: one array
    np.multiply(S.real, w, out=R[0])
    np.multiply(S.imag, w, out=R[1])
    return R.reshape(-1, R.shape[-1]) if S.ndim == 3 else R.ravel()


def spectral_jacobian(fit: Fitted, p: Prepared, x: np.ndarray) -> np.ndarray:
    """The Jacobian of a linear-only joint fit on a periodic record as Parseval rows
    (:func:`parseval_rows` of its spectrum): ``model_jacobian``'s inner products without
    transforming a column back.

    Parameters
    ----------
    fit : Fitted
        A joint fit without effects or output blocks.
    p : Prepared
        A periodic record.
    x : numpy.ndarray
        The parameters.

    Returns
    -------
    numpy.ndarray
        ``(2 F m, n_x)``.
    """
    th = fit.theta_at(p.level, x)
    _, JL = fit.lin.simulate_jac(th, p.U, True, spectral=True)          # (F, m, size)
    if not fit.slopes:
        return parseval_rows(JL, len(p.U))
    b = slope_basis(level_factor(p.level, fit.level_ref), fit.level_knots)
    k, size = len(fit.slopes), JL.shape[2]
    J = np.empty(JL.shape[:2] + (size + k * len(b),), complex)
    J[:, :, :size] = JL
    for q, v in enumerate(b):
        np.multiply(JL[:, :, list(fit.slopes)], v, out=J[:, :, size + q * k:size + (q + 1) * k])
    return parseval_rows(J, len(p.U))


def compressed(residual: Callable[[np.ndarray], np.ndarray],
               blocks: Callable[[np.ndarray], Iterable[np.ndarray]],
               n: int) -> tuple[Callable, Callable, Callable]:
    """A least-squares problem of many rows handed to ``scipy.optimize.least_squares`` on
    ``n + 1`` rows that give its trust-region solver exactly the same cost, gradient and
    ``J^T J`` (so the same steps, up to rounding).

    ``fun(x)`` returns ``(||r(x)||, 0, ..., 0)``; ``jac(x)`` a square root ``K`` of the
    Gram matrix of ``[J r]`` (``K^T K = [J r]^T [J r]``, accumulated a block of rows at a
    time, never stacked; columns scaled to unit norm before the symmetric eigendecomposition
    that gives ``K``; when that scaled Gram matrix is ill-conditioned — its smallest
    eigenvalue below ``1e-9`` of its largest, where squaring loses the small directions —
    ``K`` is the triangular factor of the blocks' QR decomposition instead) turned by a
    Householder reflection ``H`` that maps its last column ``w`` (``||w|| = ||r||``) onto
    ``||r|| e_1``: then ``M = H K[:, :n]`` has ``M^T M = J^T J`` and ``M^T fun(x) = K^T w =
    J^T r``, and its column norms are ``J``'s (``x_scale``).
    The solver's work per step then no longer grows with the records (an SVD of the
    whole Jacobian per iteration was most of a mirror diagnosis).

    Parameters
    ----------
    residual : callable
        ``x -> r`` (the full residual vector).
    blocks : callable
        ``x -> iterable of (rows of the Jacobian, how many of r's rows they stand for, a
        transform of those rows or None)``, in the order of ``r``'s rows (an orthogonal
        transform, e.g. a record's spectrum: the rows and the residual transformed alike
        keep every inner product).
    n : int
        Number of parameters.

    Returns
    -------
    fun, jac : callable
        For ``least_squares``.
    rows : callable
        ``() -> the number of rows of r`` (the degrees of freedom of ``parameter_std``).
    """
    last = {}

    def fun(x):
        r = residual(x)
        last["x"], last["r"] = np.array(x, float), r
        v = np.zeros(n + 1)
        v[0] = float(np.linalg.norm(r))
        return v

    def jac(x, *_):
        x = np.asarray(x, float)
        r = last["r"] if "x" in last and np.array_equal(last["x"], x) else residual(x)
        G, pos, kept = np.zeros((n + 1, n + 1)), 0, []
        for B, rows, transform in blocks(x):       # [B t]^T [B t] by parts: no copy of B
            rr = r[pos:pos + rows]
            pos += rows
            t = rr if transform is None else transform(rr)
            Bt = B.T @ t
            G[:n, :n] += B.T @ B
            G[:n, n] += Bt
            G[n, :n] += Bt
            G[n, n] += t @ t
            kept.append((B, t))
        d = np.sqrt(np.maximum(np.diag(G), 0.0))
        d[d == 0] = 1.0
        lam, V = np.linalg.eigh(G / d[:, None] / d[None, :])
        live = lam[lam > 0]
        if live.size == lam.size and live.min() >= 1e-9 * live.max():
            K = (np.sqrt(lam)[:, None] * V.T) * d[None, :]
        else:                   # squaring would lose the small directions: QR of the blocks
            K = None
            for B, t in kept:
                A = np.column_stack([B, t])
                K = np.linalg.qr(A if K is None else np.vstack([K, A]), mode="r")
            K = np.vstack([K, np.zeros((n + 1 - K.shape[0], n + 1))])
        w, M = K[:, n], K[:, :n]
        u = w.copy()
        u[0] -= np.linalg.norm(w)
        uu = float(u @ u)
        return M - np.outer(u, (2.0 / uu) * (u @ M)) if uu > 0 else M

    return fun, jac, lambda: int(last["r"].size)


def fit_by_level(name: str, train: Sequence[Prepared], lin: LinearPart, chain: Chain,
                 noise_sigma: float, start: dict | None = None, max_nfev: int = _FIT.level_nfev,
                 tol: float = OPTIONS.levels.level_tol, pinned: Sequence[int] = ()) -> Fitted:
    """Amplitude-dependent dynamics by one linear re-fit per excitation level.

    The training records are grouped by level (within ``tol``); the linear corrections are
    re-fitted on each group (started at ``start``) and regressed on the level factor
    ``f = (a - a_ref) / a_ref`` (``a_ref`` the lowest level): ``theta(a) = theta_0 + f s``.
    With two levels this is the joint fit of the dynamic form exactly (two levels fix a
    line), at the cost of two linear re-fits.  Falls back to the joint fit with fewer than
    two levels.

    Parameters
    ----------
    name : str
        Candidate name.
    train : sequence of Prepared
        The training records.
    lin : LinearPart
        The linear corrections' model (with per-mode gains).
    chain : Chain
        An empty chain (effects fall back to the joint fit).
    noise_sigma : float
        Noise std per sample [µm] (weight of the priors).
    start : dict, optional
        Starting values by name (the linear re-fit's).
    max_nfev : int
        Evaluations of each per-level fit.
    tol : float
        Records within this relative level share a level.
    pinned : sequence of int
        Linear corrections held at zero (modes the records do not excite).

    Returns
    -------
    Fitted
        Dynamic form (``form == "dynamic"``), every correction with a level slope;
        ``n_eval`` is the longest per-level fit's.
    """
    order = sorted(train, key=lambda p: p.level)
    groups = []
    for p in order:
        if groups and p.level <= groups[-1][0].level * (1 + tol):
            groups[-1].append(p)
        else:
            groups.append([p])
    if len(groups) < 2 or chain.size:
        return fit_model(name, chain.effects, train, lin, chain, noise_sigma, joint=True,
                         dynamic=True, start=start, max_nfev=max_nfev, pinned=pinned)
    level_ref = min(p.level for p in train)
    F = np.array([level_factor(np.mean([p.level for p in g]), level_ref) for g in groups])
    # level by level, each from the one below: the change between levels is what the
    # records demand, its prior that of a slope (sd per unit of level factor), so a
    # correction the records barely determine does not wander between levels and
    # become a spurious slope
    fits = [fit_model(name, (), groups[0], lin, chain, noise_sigma, joint=True, start=start,
                      max_nfev=max_nfev, pinned=pinned)]
    for g, df in zip(groups[1:], np.diff(F)):
        prev = fits[-1].x[:lin.size]
        fits.append(fit_model(name, (), g, lin, chain, noise_sigma, joint=True,
                              start=dict(zip(lin.names, prev)), max_nfev=max_nfev,
                              pinned=pinned, prior_center=prev, prior_scale=float(df)))
    # piecewise linear through the levels: a knot at every interior level, so each
    # training level gets its own fit exactly and a level beyond them the nearest segment's
    knots = tuple(float(f) for f in F[1:-1])
    W = np.array([sum(p.weight ** 2 * p.Y.size for p in g) for g in groups], float)
    TH = np.array([f.x[:lin.size] for f in fits])
    A = np.column_stack([np.ones_like(F)] + [np.array([slope_basis(f, knots)[b] for f in F])
                                             for b in range(1 + len(knots))])
    M = np.linalg.pinv(A * np.sqrt(W)[:, None]) * np.sqrt(W)[None, :]     # coef = M @ TH
    coef = M @ TH
    slopes = tuple(i for i, (k, _) in enumerate(lin.kinds) if k in SLOPE_KINDS)
    x = np.concatenate([coef[0]] + [coef[1 + b][list(slopes)] for b in range(1 + len(knots))])
    sd = np.array([f.std[:lin.size] for f in fits])                # independent level fits
    var = np.sum(np.where(M[:, :, None] != 0, M[:, :, None] ** 2 * sd[None] ** 2, 0.0), axis=1)
    std = np.concatenate([np.sqrt(var[0])] + [np.sqrt(var[1 + b])[list(slopes)]
                                              for b in range(1 + len(knots))])
    return Fitted(name, (), "dynamic", chain, lin, x, std, True, slopes, level_ref,
                  int(max(f.n_eval for f in fits)), float(sum(f.train_cost for f in fits)),
                  np.zeros(lin.size), 0, None, knots)
