"""The effect library: augment the simulation model with one effect, fit only that effect.

Every candidate keeps the simulation model's linear dynamics and adds exactly one
effect, with the twin's parametrisation (:mod:`robrst.twin.model`) so a diagnosis and
the twin speak the same language:

``hysteresis``        Bouc–Wen on the drive voltage (A, B, Gamma, gain)
``creep``             first-order cell bank, log law in time, growing per K
``thermal_drift``     lagged, hysteretic input-referred drift in temperature
``thermal_dynamics``  gain, resonance and damping linear in temperature
``delay``             whole-sample transport delay
``saturation``        amplifier limits

The four dynamic effects run on the compiled twin step (parameters are a runtime
vector, so one compiled loop serves the whole fit; for the input-referred ones the
step stops at the effective input and the linear part is the exact ZOH filter) and
are fitted by bounded nonlinear least squares; delay and saturation are fitted by exact search on the
linear simulation.  Each fit reports its parameters with 1-sigma uncertainties from
the Gauss–Newton covariance (``inf`` when the data do not determine a parameter).
"""

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize

from robrst.diagnose.linear import LinearSim, levenberg_marquardt, param_std, refit_linear
from robrst.twin.config import default_twin
from robrst.twin.model import build_model
from robrst.twin.simulate import Simulator, rest_state

__all__ = ["EFFECTS", "EffectFit", "fit_effect", "fit_linear"]

EFFECTS = ("hysteresis", "creep", "thermal_drift", "thermal_dynamics", "delay", "saturation")


@dataclass(frozen=True, eq=False)
class EffectFit:
    """One fitted candidate: parameters, their 1-sigma, and a predictor for new records."""

    name: str
    params: dict
    std: dict
    n_eval: int
    predict: object = field(repr=False)   # Dataset -> simulated y [µm]


@dataclass(frozen=True)
class _Dyn:
    """A dynamic effect: free parameters z (bounds, initial guess) and z -> theta."""

    names: tuple          # reported parameter names
    lower: tuple
    upper: tuple
    init: object          # (data summary dict) -> z0
    theta: object         # z -> {theta name: value}
    phys: object          # z -> reported values (same order as names)


def _hyst_theta(z):
    A, lb, r, g = z
    return {"bw_A": A, "bw_B": 10 ** lb, "bw_Gamma": r * 10 ** lb, "bw_gain": g}


def _drift_theta(z):
    ll, lb, r, g = z
    return {"drift_lag_s": 10 ** ll, "drift_A": 1.0, "drift_B": 10 ** lb,
            "drift_Gamma": r * 10 ** lb, "drift_V_per_K": g}


_DYNAMIC = {
    "hysteresis": _Dyn(
        names=("A", "B_per_V", "Gamma_per_V", "gain"),
        lower=(0.0, -5.0, -1.0, 0.2), upper=(0.95, 0.0, 1.0, 5.0),
        init=lambda s: (0.3, np.log10(1.0 / max(s["u_ptp"], 1e-3)), 1.0, 1.2),
        theta=_hyst_theta,
        phys=lambda z: (z[0], 10 ** z[1], z[2] * 10 ** z[1], z[3])),
    "creep": _Dyn(
        names=("per_decade", "per_K"), lower=(-0.3, -1.0), upper=(0.3, 2.0),
        init=lambda s: (0.0, 0.0),
        theta=lambda z: {"creep_per_decade": z[0], "creep_per_K": z[1]},
        phys=lambda z: (z[0], z[1])),
    "thermal_drift": _Dyn(
        names=("lag_s", "B_per_K", "Gamma_per_K", "gain_V_per_K"),
        lower=(-1.0, -3.0, -1.0, -20.0), upper=(3.0, 1.0, 1.0, 20.0),
        init=lambda s: (np.log10(np.clip(s["duration_s"] / 10, 0.2, 100.0)), -1.0, 1.0, 0.0),
        theta=_drift_theta,
        phys=lambda z: (10 ** z[0], 10 ** z[1], z[2] * 10 ** z[1], z[3])),
    "thermal_dynamics": _Dyn(
        names=("gain_per_K", "resonance_per_K", "damping_per_K"),
        lower=(-0.05, -0.01, -0.2), upper=(0.05, 0.01, 0.2),
        init=lambda s: (0.0, 0.0, 0.0),
        theta=lambda z: {"gain_per_K": z[0], "resonance_per_K": z[1], "damping_per_K": z[2]},
        phys=lambda z: tuple(z)),
}


def summary(records):
    """Scales of the training data used for initial guesses."""
    u = np.concatenate([d.u for d in records])
    return {"u_ptp": float(np.ptp(u)), "u_min": float(np.min(u)), "u_max": float(np.max(u)),
            "duration_s": float(max(d.t[-1] - d.t[0] for d in records))}


def _scale(records):
    return float(np.sqrt(sum(np.sum((d.y - d.y.mean()) ** 2) for d in records))) or 1.0


def _phys_std(dyn, z, zstd):
    """Delta-method 1-sigma of the reported parameters."""
    z = np.asarray(z, float)
    p0 = np.asarray(dyn.phys(z), float)
    G = np.zeros((len(p0), len(z)))
    for j in range(len(z)):
        h = 1e-6 * max(1.0, abs(z[j]))
        zj = z.copy()
        zj[j] += h
        G[:, j] = (np.asarray(dyn.phys(zj), float) - p0) / h
    with np.errstate(invalid="ignore"):
        out = np.sqrt(np.nansum((G * np.where(np.isfinite(zstd), zstd, 0.0)) ** 2, axis=1))
    inf = ~np.isfinite(zstd)
    out[(np.abs(G[:, inf]) > 0).any(axis=1)] = np.inf
    return out


def _central_jac(fun, z, lo, hi, rel=1e-5):
    """Central-difference Jacobian (one-sided at a bound): accurate enough to tell an
    undetermined direction (collinear columns) from a merely weak one."""
    cols = []
    for j in range(len(z)):
        h = rel * max(1.0, abs(z[j]))
        a, b = z.copy(), z.copy()
        a[j], b[j] = max(z[j] - h, lo[j]), min(z[j] + h, hi[j])
        cols.append((fun(b) - fun(a)) / (b[j] - a[j]))
    return np.column_stack(cols)


def _fit_dynamic(name, records, plant, fs, reference_C, max_nfev):
    dyn = _DYNAMIC[name]
    cfg = replace(default_twin().with_effects(only=[name]), sample_rate_hz=float(fs),
                  reference_C=float(reference_C), name=f"diagnose_{name}")
    input_referred = name != "thermal_dynamics"
    model = build_model(cfg, plant=plant, linear=not input_referred)
    sim = Simulator(model)
    lin = LinearSim.of(plant, fs) if input_referred else None
    index = {k: i for i, k in enumerate(model.theta_names)}

    def theta_of(z):
        th = model.theta0.copy()
        for k, v in dyn.theta(z).items():
            th[index[k]] = v
        return th

    def run(ds, z):
        P = np.vstack([ds.u, ds.temp, np.zeros(ds.n)])
        Y, _ = sim.run(P, rest_state(model, ds.u[0], ds.temp[0]), theta_of(z))
        return lin(Y[1]) if input_referred else Y[1]

    scale = _scale(records)

    def resid(z):
        r = np.concatenate([run(d, z) - d.y for d in records]) / scale
        return np.where(np.isfinite(r), r, 1e3)

    lo, hi = np.array(dyn.lower), np.array(dyn.upper)
    z0 = np.clip(np.array(dyn.init(summary(records)), float), lo, hi)
    res = levenberg_marquardt(resid, z0, lo, hi, max_iter=max(2, max_nfev // (len(z0) + 1)))
    zstd = param_std(optimize.OptimizeResult(jac=_central_jac(resid, res.x, lo, hi), cost=res.cost),
                rtol=1e-6)
    phys = dyn.phys(res.x)
    pstd = _phys_std(dyn, res.x, zstd)
    z = res.x.copy()
    return EffectFit(name=name, params=dict(zip(dyn.names, map(float, phys))),
                     std=dict(zip(dyn.names, map(float, pstd))), n_eval=int(res.nfev),
                     predict=lambda ds: run(ds, z))


def _shift(yb, u0, step, d):
    """Exact linear response to ``u`` delayed by ``d`` samples (delay line holding ``u0``).

    ``yb`` and ``step`` are the undelayed responses to ``u`` and to ones, from rest.
    """
    if d == 0:
        return yb
    out = np.empty_like(yb)
    out[d:] = yb[:-d] + u0 * (step[d:] - step[:-d])
    out[:d] = u0 * step[:d]
    return out


def _fit_delay(records, lin, fs):
    dmax = int(max(1, min(round(5e-3 * fs), 200)))
    pre = [(lin(d.u), lin(np.ones(d.n))) for d in records]
    costs = [sum(float(np.sum((_shift(yb, d.u[0], st, k) - d.y) ** 2))
                 for d, (yb, st) in zip(records, pre)) for k in range(dmax + 1)]
    k = int(np.argmin(costs))
    return EffectFit(name="delay", params={"seconds": k / fs, "samples": float(k)},
                     std={"seconds": 0.5 / fs, "samples": 0.5}, n_eval=dmax + 1,
                     predict=lambda ds: _shift(lin(ds.u), ds.u[0], lin(np.ones(ds.n)), k))


def _fit_saturation(records, lin):
    u_all = np.concatenate([d.u for d in records])
    lo_u, hi_u = float(np.min(u_all)), float(np.max(u_all))
    span = max(hi_u - lo_u, 1e-9)

    def cost(lo, hi):
        return sum(float(np.sum((lin(np.clip(d.u, lo, hi)) - d.y) ** 2)) for d in records)

    n = 0
    best_lo, best_hi = lo_u - 1e-6 * span, hi_u + 1e-6 * span
    for which in ("hi", "lo"):
        qs = np.linspace(0.5, 1.0, 17) if which == "hi" else np.linspace(0.5, 0.0, 17)
        cands = np.quantile(u_all, qs)
        vals = []
        for c in cands:
            vals.append(cost(best_lo, c) if which == "hi" else cost(c, best_hi))
            n += 1
        j = int(np.argmin(vals))
        a, b = cands[max(j - 1, 0)], cands[min(j + 1, len(cands) - 1)]
        f = (lambda c: cost(best_lo, c)) if which == "hi" else (lambda c: cost(c, best_hi))
        r = optimize.minimize_scalar(f, bounds=(min(a, b), max(a, b)), method="bounded",
                                     options={"xatol": 1e-4 * span})
        n += int(r.nfev)
        pick = float(r.x) if r.fun <= vals[j] else float(cands[j])
        if which == "hi":
            best_hi = pick if pick < hi_u else hi_u
        else:
            best_lo = pick if pick > lo_u else lo_u
    # 1-sigma from a central-difference Jacobian of the residual in the two limits
    h = 5e-3 * span

    def res(lo, hi):
        return np.concatenate([lin(np.clip(d.u, lo, hi)) - d.y for d in records])

    r0 = res(best_lo, best_hi)
    J = np.column_stack([(res(best_lo + h, best_hi) - res(best_lo - h, best_hi)) / (2 * h),
                         (res(best_lo, best_hi + h) - res(best_lo, best_hi - h)) / (2 * h)])
    ls = optimize.OptimizeResult(jac=J, cost=0.5 * float(r0 @ r0))
    std = param_std(ls)
    std = np.where(np.linalg.norm(J, axis=0) == 0, np.inf, std)
    lo_f, hi_f = best_lo, best_hi
    return EffectFit(name="saturation", params={"u_min_V": lo_f, "u_max_V": hi_f},
                     std={"u_min_V": float(std[0]), "u_max_V": float(std[1])}, n_eval=n + 4,
                     predict=lambda ds: lin(np.clip(ds.u, lo_f, hi_f)))


def fit_effect(name, records, plant, fs, reference_C=28.0, max_nfev=120):
    """Fit the simulation model ``plant`` augmented with effect ``name`` on ``records``.

    Parameters
    ----------
    name : str
        One of :data:`EFFECTS`.
    records : list of Dataset
        Training records (same sampling rate ``fs``), each simulated from rest.
    plant : Plant
        The simulation model's linear dynamics (kept fixed).
    reference_C : float
        Temperature [°C] at which ``plant`` holds.

    Returns
    -------
    EffectFit
    """
    if name in _DYNAMIC:
        return _fit_dynamic(name, records, plant, fs, reference_C, max_nfev)
    lin = LinearSim.of(plant, fs)
    if name == "delay":
        return _fit_delay(records, lin, fs)
    if name == "saturation":
        return _fit_saturation(records, lin)
    raise ValueError(f"unknown effect {name!r}; expected one of {EFFECTS}")


def fit_linear(records, plant, fs):
    """The plain linear re-fit (same degrees) as an :class:`EffectFit` named ``linear``."""
    fit = refit_linear(plant, [(d.u, d.y) for d in records], fs)
    lin = LinearSim.of(fit.plant, fs)
    return EffectFit(name="linear", params={f"rel_{k}": v for k, v in fit.rel_change.items()},
                     std={f"rel_{k}": v for k, v in fit.std.items()}, n_eval=fit.n_eval,
                     predict=lambda ds: lin(ds.u))
