"""Joint fits: effects and the linear part's corrections, by bounded least squares.

A candidate model is ``y = L_theta(v)``, ``v = Chain_z(u)``: effect parameters ``z``
(:mod:`robrst.diagnose.effects`) and linear corrections ``theta``
(:mod:`robrst.diagnose.linear`), fitted together on the training records by
``scipy.optimize.least_squares`` (trust-region reflective, bounds) with the exact
Jacobian.  ``theta`` carries Gaussian priors, so it moves only as far as the data
demand (regularised toward the user's model).  The *dynamic* form of hysteresis lets
the linear corrections vary linearly with the record's excitation level (the
describing function of a hysteretic stiffness: resonances soften and gains change with
amplitude); it needs periodic records at two or more levels.

A constant output offset per output (``offset``: a sensor zero or bias, in µm) can be
fitted with any candidate; it enters the output linearly, without a prior.

Periodic records are fitted in steady state on their period average (weight: the
number of periods), the effects warmed up on one extra period.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from robrst.diagnose.effects import Chain
from robrst.diagnose.linear import parameter_std

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.diagnose.linear import LinearPart

__all__ = ["Prepared", "prepare", "Fitted", "fit_model", "level_factor"]

SLOPE_KINDS = ("dlog_freq", "dlog_damping", "input_gain", "gain", "mode_gain")


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
        The fitted parameters ``[z, theta (joint), slopes, offsets]``.
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
    """

    name: str
    effects: tuple
    form: str
    chain: Chain
    lin: object
    x: np.ndarray
    std: np.ndarray
    joint: bool
    slopes: tuple          # indices into theta that vary with level (dynamic form)
    level_ref: float
    n_eval: int
    train_cost: float
    theta_fixed: np.ndarray = None
    n_offset: int = 0      # constant output offsets fitted (one per output, or none)

    def parts(self, x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Effect parameters, linear corrections and level slopes (not the offsets).

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
                x[nz + nt:nz + nt + len(self.slopes)])

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
        return x[x.size - self.n_offset:]

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
            th[list(self.slopes)] += s * level_factor(level, self.level_ref)
        return th

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
        z, _, _ = self.parts(x)
        U, T = p.U, p.temp
        if p.warm:
            U, T = np.vstack([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
        V, _ = self.chain.run(z, U, T, jac=False, warm=p.warm)
        Y = self.lin.simulate(self.theta_at(p.level, x), V, p.periodic)
        return Y + self.output_offset(x)[None, :] if self.n_offset else Y

    def predict(self, d: Dataset, reference_C: float) -> np.ndarray:
        """Simulated outputs ``(N, m)`` of record ``d`` (steady state when periodic).

        Parameters
        ----------
        d : Dataset
            The record.
        reference_C : float
            The temperature of a record without one [°C].

        Returns
        -------
        numpy.ndarray
        """
        return self.predict_prepared(prepare(d, reference_C, for_fit=False))

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
        if self.n_offset:
            sfx = (lambda j: f"_y{j + 1}") if self.n_offset > 1 else (lambda j: "")
            off, sd = self.output_offset(), self.std[self.x.size - self.n_offset:]
            out["output_offset"] = ({f"offset_um{sfx(j)}": float(v) for j, v in enumerate(off)},
                                    {f"offset_um{sfx(j)}": float(d) for j, d in enumerate(sd)})
        return out

    def linear_change(self) -> tuple[dict, dict]:
        """Linear corrections (and level slopes) by name, with 1-sigma.

        Returns
        -------
        values, sigmas : dict
            Fixed corrections have sigma NaN; slopes are named ``<name>_per_level``.
        """
        nz = self.chain.size
        out, sd = {}, {}
        if self.joint:
            for i, n in enumerate(self.lin.names):
                out[n], sd[n] = float(self.x[nz + i]), float(self.std[nz + i])
        elif np.any(self.parts()[1]):
            for n, v in zip(self.lin.names, self.parts()[1]):
                out[n], sd[n] = float(v), float("nan")
        for k, i in enumerate(self.slopes):
            n = f"{self.lin.names[i]}_per_level"
            j = nz + (self.lin.size if self.joint else 0) + k
            out[n], sd[n] = float(self.x[j]), float(self.std[j])
        return out, sd


def fit_model(name: str, effects: Sequence[str], train: Sequence[Prepared], lin: LinearPart,
              chain: Chain, noise_sigma: float, joint: bool = True, dynamic: bool = False,
              start: dict | None = None, theta: np.ndarray | None = None, max_nfev: int = 40,
              ftol: float = 1e-10, offset: bool = False) -> Fitted:
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
        Let the linear corrections vary with the excitation level (dynamic hysteresis).
    start : dict, optional
        Starting values by parameter name (from an earlier fit).
    theta : array, optional
        Fixed linear corrections when not ``joint``.
    max_nfev, ftol : int, float
        Stopping rules of the least-squares solver.
    offset : bool
        Fit a constant output offset per output too (parameters ``offset_um``, ...).

    Returns
    -------
    Fitted
    """
    slopes = tuple(i for i, (k, _) in enumerate(lin.kinds) if k in SLOPE_KINDS) if dynamic else ()
    level_ref = min(p.level for p in train)
    nz, nt, ns = chain.size, lin.size if joint else 0, len(slopes)
    no = train[0].Y.shape[1] if offset else 0
    lo = np.concatenate([chain.lower, lin.lower if joint else [], np.full(ns, -5.0),
                         np.full(no, -np.inf)])
    hi = np.concatenate([chain.upper, lin.upper if joint else [], np.full(ns, 5.0),
                         np.full(no, np.inf)])
    if joint and "hysteresis" in chain.effects:      # its gain is the linear gain: pin that
        for i, (kind, _) in enumerate(lin.kinds):
            if kind in ("gain", "input_gain"):
                lo[nz + i], hi[nz + i] = -1e-12, 1e-12
    sd = np.concatenate([lin.prior_sd if joint else [], lin.prior_sd[list(slopes)]])
    x0 = np.concatenate([chain.z0, np.zeros(nt + ns + no)])
    names = (list(chain.names) + (list(lin.names) if joint else []) + [f"slope{i}" for i in slopes]
             + [f"offset{j}" for j in range(no)])
    for i, n in enumerate(names):
        if start and n in start:
            x0[i] = np.clip(start[n], lo[i], hi[i])
    scale = np.sqrt(sum(p.weight ** 2 * float(np.sum((p.Y - p.Y.mean(0)) ** 2)) for p in train))
    scale = scale or 1.0
    prior_w = noise_sigma / scale / sd
    fixed = np.zeros(lin.size) if theta is None else np.asarray(theta, float)
    proto = Fitted(name, tuple(effects), "dynamic" if dynamic else "input", chain, lin, x0,
                   np.zeros_like(x0), joint, slopes, level_ref, 0, 0.0, fixed, no)

    def fun(x):
        r = [(proto.predict_prepared(p, x) - p.Y).ravel() * (p.weight / scale) for p in train]
        r.append(prior_w * x[nz:nz + nt + ns])
        out = np.concatenate(r)
        return np.where(np.isfinite(out), out, 1e3)

    def jac(x):
        z = x[:nz]
        rows = []
        for p in train:
            U, T = p.U, p.temp
            if p.warm:
                U, T = np.vstack([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
            V, dV = chain.run(z, U, T, jac=True, warm=p.warm)
            th = proto.theta_at(p.level, x)
            _, JL = lin.simulate_jac(th, V, p.periodic)
            N, m = p.Y.shape
            J = np.zeros((N, m, x.size))
            for j, dv in enumerate(dV):
                for c in np.flatnonzero(np.any(dv != 0, axis=0)):
                    J[:, :, c] += lin.simulate_input(th, dv[:, c], j, p.periodic)
            if joint:
                J[:, :, nz:nz + nt] = JL
            if slopes:
                J[:, :, nz + nt:nz + nt + ns] = (JL[:, :, list(slopes)]
                                                 * level_factor(p.level, level_ref))
            for j in range(no):
                J[:, j, nz + nt + ns + j] = 1.0
            rows.append(J.reshape(N * m, -1) * (p.weight / scale))
        prior = np.zeros((nt + ns, x.size))
        prior[:, nz:nz + nt + ns] = np.diag(prior_w)
        rows.append(prior)
        return np.vstack(rows)

    if x0.size == 0:
        res = optimize.OptimizeResult(x=x0, cost=0.5 * float(np.sum(fun(x0) ** 2)), nfev=1,
                                      jac=np.zeros((1, 0)), fun=fun(x0))
    else:
        # trial points may overflow (an effect driven far out): the optimiser
        # rejects them; their floating-point warnings only reach the user
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            res = optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf",
                                         x_scale="jac", ftol=ftol, xtol=1e-10, gtol=1e-10,
                                         max_nfev=max_nfev)
    std = parameter_std(res.jac, res.cost, res.fun.size) if x0.size else np.zeros(0)
    return Fitted(name, tuple(effects), proto.form, chain, lin, res.x, std, joint, slopes,
                  level_ref, int(res.nfev), 2 * float(res.cost), fixed, no)
