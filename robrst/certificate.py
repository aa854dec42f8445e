"""Independent certificate of a controller on a plant family.

For every model of the family *and* a dense sweep of interpolated temperatures, the
exact peaks of |S|, |T|, |U| (Hamiltonian bisection, :mod:`robrst.hinf`) and the
closed-loop spectral abscissa are recomputed from the polynomials alone — nothing
from the optimiser is trusted.  A controller is certified when every model is
stable and every peak is within its bound (relative tolerance ``rtol``).

When the specs name a sampling rate, every model is also checked in its sampled
loop (ZOH plant, Tustin controller, ``delay_samples`` of delay) through the exact
bilinear equivalence of :mod:`robrst.sampled`; those figures carry the suffix
``_sampled`` in each record, with physical frequencies (up to Nyquist).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize_scalar

from robrst import poly, timespec
from robrst.analysis import spectral_abscissa
from robrst.hinf import peak_gain
from robrst.problem import PEAK_SPECS, Problem
from robrst.rst import RSTController, closed_loop
from robrst.sampled import sampled_plant, unwarp, warp

__all__ = ["Violation", "Certificate", "certify", "certify_problem", "check_model", "band_peak"]


@dataclass(frozen=True)
class Violation:
    """One failed check: model, temperature, quantity, value, bound, frequency."""

    label: str
    temperature_C: float
    quantity: str
    value: float
    bound: float
    freq_rad_s: float
    loop: str = "continuous"     # or "sampled"

    def describe(self):
        at = "" if self.freq_rad_s is None else f" at {self.freq_rad_s / (2 * np.pi):.4g} Hz"
        loop = " in the sampled loop" if self.loop == "sampled" else ""
        return (f"model {self.label} ({self.temperature_C:g} °C): {self.quantity}{loop} ="
                f" {self.value:.4g} > {self.bound:.4g}{at}")


@dataclass(frozen=True, eq=False)
class Certificate:
    """Per-model exact peaks, spectral abscissae, and every violation found."""

    certified: bool
    models: tuple
    violations: tuple
    rtol: float

    def worst(self, key):
        """Largest ``key`` over the models (``None`` if no record has it)."""
        vals = [m[key] for m in self.models if key in m]
        return max(vals) if vals else None

    def as_dict(self):
        return {"certified": self.certified, "rtol": self.rtol, "models": list(self.models),
                "violations": [v.__dict__ for v in self.violations]}


def band_peak(N, D, w_lo, w_hi, n=400):
    """Peak of ``|N/D|`` over ``[w_lo, w_hi]`` rad/s: log grid, then local refinement."""
    sc = poly.Scaling.natural(D)
    w0 = sc.w0
    Ns, Ds = sc.apply(N), sc.apply(D)
    f = lambda lw: np.abs(poly.eval_jw(Ns, np.exp(lw) / w0) / poly.eval_jw(Ds, np.exp(lw) / w0))  # noqa: E731
    lw = np.linspace(np.log(w_lo), np.log(w_hi), n)
    g = f(lw)
    i = int(np.argmax(g))
    a, b = lw[max(i - 1, 0)], lw[min(i + 1, n - 1)]
    if b > a:
        r = minimize_scalar(lambda x: -f(x), bounds=(a, b), method="bounded",
                            options={"xatol": 1e-12})
        if -r.fun > g[i]:
            return float(-r.fun), float(np.exp(r.x))
    return float(g[i]), float(np.exp(lw[i]))


def check_model(plant, ctrl, specs, rtol, fs=None):
    """Exact peaks and stability of one model; returns (record, violations).

    With ``fs`` the plant is a sampled-loop plant (:func:`robrst.sampled.sampled_plant`):
    reported frequencies are mapped back to physical ones, the resonance band is
    warped, and a closed-loop polynomial that lost degree (a pole at ``z = -1``)
    counts as unstable.
    """
    cl = closed_loop(plant, ctrl)
    sa, _ = spectral_abscissa(cl.Delta)
    if fs is not None and len(cl.Delta) < plant.n + len(poly.trim(ctrl.S)):
        sa = np.inf
    loop = "continuous" if fs is None else "sampled"
    phys = (lambda w: w) if fs is None else (lambda w: float(unwarp(w, fs)))  # noqa: E731
    rec = {"label": plant.label, "temperature_C": plant.temperature_C,
           "spectral_abscissa": sa, "stable": bool(sa < 0)}
    viol = []
    if sa >= 0:
        viol.append(Violation(plant.label, plant.temperature_C, "spectral_abscissa", sa, 0.0,
                              None, loop))
    for name in PEAK_SPECS:
        pk = peak_gain(cl.nums[name], cl.Delta)
        # a sampled peak at nu = inf is at Nyquist (unwarp(inf) = pi fs)
        freq = phys(float(pk.freq_rad_s)) if fs is not None or np.isfinite(pk.freq_rad_s) else None
        rec[f"M{name.lower()}"] = pk.value
        rec[f"M{name.lower()}_freq_rad_s"] = freq
        bound = specs.peak_bound(name)
        if bound is not None and pk.value > bound * (1 + rtol):
            viol.append(Violation(plant.label, plant.temperature_C, f"|{name}| peak", pk.value,
                                  bound, freq, loop))
    if specs.T_resonance_max is not None:
        lo, hi = (2 * np.pi * f for f in specs.resonance_band_hz)
        if fs is not None:
            lo, hi = warp(min(lo, 0.999 * np.pi * fs), fs), warp(min(hi, 0.999 * np.pi * fs), fs)
        val, w = band_peak(cl.nums["T"], cl.Delta, lo, hi)
        rec["Mt_resonance_band"] = val
        if val > specs.T_resonance_max * (1 + rtol):
            viol.append(Violation(plant.label, plant.temperature_C, "|T| in resonance band", val,
                                  specs.T_resonance_max, phys(w), loop))
    if specs.Mu_hf_max is not None:   # |U| above a corner frequency (up to inf / Nyquist)
        lo = 2 * np.pi * specs.Mu_hf_above_hz
        lo = lo if fs is None else warp(min(lo, 0.999 * np.pi * fs), fs)
        val, w = band_peak(cl.nums["U"], cl.Delta, lo, lo * 1e6)
        rec["Mu_hf"] = val = max(val, abs(poly.trim(cl.nums["U"])[0] / cl.Delta[0])
                                 if len(poly.trim(cl.nums["U"])) == len(cl.Delta) else 0.0)
        if val > specs.Mu_hf_max * (1 + rtol):
            viol.append(Violation(plant.label, plant.temperature_C, "|U| above corner", val,
                                  specs.Mu_hf_max, phys(w), loop))
    if specs.time_domain and sa < 0:   # reference-step specs (robrst.timespec)
        t_rec, failed = timespec.check(plant, ctrl, cl, specs, rtol, fs)
        rec.update(t_rec)
        viol += [Violation(plant.label, plant.temperature_C, q, v, b, None, loop) for q, v, b in failed]
    return rec, viol


SAMPLED_KEYS = ("spectral_abscissa", "stable", "Ms", "Ms_freq_rad_s", "Mt", "Mt_freq_rad_s",
                "Mu", "Mu_freq_rad_s", "Mt_resonance_band", "Mu_hf", *timespec.KEYS)


def _check_sampled(plant, ctrl, specs, rtol):
    fs, k = specs.sample_rate_hz, specs.delay_samples
    rec, viol = check_model(sampled_plant(plant, fs, k), ctrl, specs, rtol, fs=fs)
    viol = [replace(v, label=plant.label) for v in viol]   # name the continuous model
    return {f"{key}_sampled": rec[key] for key in SAMPLED_KEYS if key in rec}, viol


def certify(family, ctrl, specs, n_sweep=35, rtol=1e-3):
    """Certify ``ctrl`` on every family model and on ``n_sweep`` interpolated temperatures.

    Returns
    -------
    Certificate
    """
    models = list(family.models)
    known = {m.temperature_C for m in models}
    if len(family.models) > 1 and n_sweep > 0:
        models += [m for m in family.sweep(n_sweep) if m.temperature_C not in known]
    recs, viols = [], []
    for m in sorted(models, key=lambda m: m.temperature_C):
        rec, v = check_model(m, ctrl, specs, rtol)
        if specs.sampled:
            rec_s, v_s = _check_sampled(m, ctrl, specs, rtol)
            rec.update(rec_s)
            v = v + v_s
        rec["family_member"] = m.temperature_C in known
        recs.append(rec)
        viols.extend(v)
    return Certificate(certified=not viols, models=tuple(recs), violations=tuple(viols), rtol=rtol)


def certify_problem(problem: Problem, ctrl: RSTController) -> Certificate:
    """Certify ``ctrl`` on ``problem``'s family and specs with its solver options.

    The one entry point every stage uses (design, synthesis rounds, comparison): exact
    peaks and closed-loop stability on every family model and on
    ``problem.solver.cert_temperatures`` interpolated temperatures, and the sampled
    loop when the specs name a sampling rate.

    Parameters
    ----------
    problem : Problem
    ctrl : RSTController

    Returns
    -------
    Certificate
        ``certified`` is true when nothing is violated (relative tolerance
        ``problem.solver.cert_tol``); ``violations`` names every failed check.

    Examples
    --------
    >>> from robrst import certify_problem, load_problem, pole_placement
    >>> problem = load_problem("paper")
    >>> ctrl = pole_placement(problem.family.reference_model, problem.poles,
    ...                       problem.controller).controller
    >>> certify_problem(problem, ctrl).certified
    True
    """
    so = problem.solver
    return certify(problem.family, ctrl, problem.specs, n_sweep=so.cert_temperatures,
                   rtol=so.cert_tol)
