"""Random design problems and an independent checker of robrst's certificates.

Used by the reliability suite (``tests/reliability.py``, ``tests/synthesis/test_random_problems.py``) and
``python -m tests.random_problems`` (a seeded batch with counts).

Generator
---------
:func:`random_case` (seeded, ``numpy.random.default_rng(seed)``) and
:func:`draw_case` (any :class:`Chooser`, e.g. one backed by hypothesis) build a problem
document (a dict that is valid TOML and valid input of :func:`robrst.problem.files.parse_problem`):
plant orders 1–6, lightly damped resonances, right-half-plane zeros, integrating plants,
near-integrators (a pole at 1e-9 .. 1e-4 of the others), near-cancellations (a zero within
1e-7 .. 1e-3 of a pole), negative gains, single models, explicit and parametric
temperature families, sampled loops from 1 to 100 kHz with 0 or 1 sample of delay and |T|
bands that reach Nyquist or fold over it, every method, objective and ``T_mode``,
roll-off factors in ``S_fixed``.  The specs are set around what the analytic design at
the problem's own poles achieves (measured by the checker below), so a known controller
meets them when ``RandomCase.baseline_ok`` is true.

Checker
-------
:func:`check` re-derives every figure a certificate claims without robrst's numerical
code (no ``robrst.core.peaks``, ``robrst.core.poly``, ``robrst.core.sampled``, ``robrst.certificate.proof``,
``robrst.core.family``):

* models at any temperature from the problem document itself (explicit families:
  coefficient-wise linear interpolation; parametric: the documented thermal law, from the
  roots of the nominal ``A``), on a dense temperature grid;
* stability from the roots of the unscaled closed-loop polynomial ``A S + B R`` (own
  scaling), decided by an exact Routh test in rational arithmetic when the roots are
  within 1e-6 of the imaginary axis;
* peaks of ``|S|, |T|, |U|`` and the band peak of ``|T|`` on a dense log grid of the
  *unscaled* polynomials plus local refinement of every grid maximum, evaluated in
  60-digit mpmath where float64 cannot resolve the value;
* sampled loops through python-control: ``c2d`` (ZOH) of a time-scaled plant, Tustin
  controller, ``z**-k`` delay, ``feedback`` poles for stability and a dense unit-circle
  grid with refinement for the peaks; every peak, Nyquist and the band ends (the band
  folded into ``[0, pi fs]``) then evaluated with a 60-digit ZOH (:class:`ExactZOH`), exact
  for near-integrators.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import tomlkit

from robrst.base.tomlwrite import plain

__all__ = ["Chooser", "NumpyChooser", "RandomCase", "random_case", "draw_case", "to_toml",
           "Figures", "figures", "check", "Discrepancy", "model_at", "ExactZOH", "fold_band"]

# --------------------------------------------------------------------------- generator


class Chooser:
    """Source of random choices: ``uniform``, ``loguniform``, ``integer``, ``coin``, ``pick``."""

    def uniform(self, lo, hi):  # pragma: no cover - interface
        raise NotImplementedError

    def integer(self, lo, hi):  # pragma: no cover - interface
        raise NotImplementedError

    def loguniform(self, lo, hi):
        return float(10.0 ** self.uniform(math.log10(lo), math.log10(hi)))

    def coin(self, p):
        return self.uniform(0.0, 1.0) < p

    def pick(self, options, weights=None):
        if weights is None:
            return options[self.integer(0, len(options) - 1)]
        u, acc = self.uniform(0.0, float(sum(weights))), 0.0
        for o, w in zip(options, weights):
            acc += w
            if u < acc:
                return o
        return options[-1]


class NumpyChooser(Chooser):
    """Choices from ``numpy.random.default_rng(seed)``."""

    def __init__(self, seed):
        self.rng = np.random.default_rng(seed)

    def uniform(self, lo, hi):
        return float(self.rng.uniform(lo, hi))

    def integer(self, lo, hi):
        return int(self.rng.integers(lo, hi + 1))


@dataclass(frozen=True)
class RandomCase:
    """A random problem: the document, what was drawn, and how the analytic design fares.

    ``baseline`` holds the checker's worst-case figures of the analytic design at the
    problem's poles (``None`` if that design fails); ``baseline_ok`` is true when it meets
    every spec of the document (so a simple known controller solves the problem).
    """

    seed: object
    data: dict
    kind: dict
    baseline: object = None
    baseline_ok: bool = False

    def problem(self):
        from robrst.problem.files import parse_problem

        return parse_problem(self.data, f"<random {self.seed}>")

    def toml(self):
        return to_toml(self.data)


def _pair(wn, zeta):
    return [1.0, 2.0 * zeta * wn, wn * wn]


def _poly_from(real_roots, pairs):
    p = np.ones(1)
    for r in real_roots:
        p = np.convolve(p, [1.0, -r])
    for wn, z in pairs:
        p = np.convolve(p, _pair(wn, z))
    return p


def _plant_parts(ch, kind, fs=None):
    """Poles, zeros and gain of a random plant (rad/s), as roots and (wn, zeta) pairs."""
    n = ch.integer(1, 6)
    wp = ch.loguniform(10.0, 3e4)
    if fs is not None:
        wp = min(wp, 2 * math.pi * fs / 300.0)
    n_pairs = ch.integer(0, n // 2)
    if n_pairs:
        kind["resonances"] = n_pairs
    pairs = [(wp * ch.loguniform(0.3, 10.0), ch.loguniform(0.005, 0.3)) for _ in range(n_pairs)]
    reals = [-wp * ch.loguniform(0.03, 10.0) for _ in range(n - 2 * n_pairs)]
    if reals and ch.coin(0.15):
        reals[0] = 0.0
        kind["integrating"] = True
    m = ch.integer(0, n - 1) if not ch.coin(0.05) else n
    z_reals, z_pairs = [], []
    k = m
    if k >= 2 and pairs and ch.coin(0.5):       # anti-resonance below a resonance (piezo)
        wn, z = pairs[0]
        z_pairs.append((wn * ch.uniform(0.5, 0.95), z * ch.uniform(0.5, 2.0)))
        k -= 2
    for _ in range(k):
        if ch.coin(0.15):
            z_reals.append(wp * ch.loguniform(3.0, 30.0))
            kind["rhp_zero"] = True
        else:
            z_reals.append(-wp * ch.loguniform(0.1, 30.0))
    return pairs, reals, z_pairs, z_reals, wp


def _near_classes(ch, kind, reals, pairs, z_pairs, z_reals):
    """In place: a near-integrator (a real pole moved to ``-|p|`` times 1e-9 .. 1e-4, beside
    the others: the exact ZOH and the peaks across 9+ decades) and a near-cancellation (a
    zero within 1e-7 .. 1e-3 relative of a real pole), each now and then."""
    free = [i for i, r in enumerate(reals) if r != 0]
    if free and ch.coin(0.15):
        i = free[ch.integer(0, len(free) - 1)]
        reals[i] = -abs(reals[i]) * ch.loguniform(1e-9, 1e-4)
        kind["near_integrator"] = True
    n, m = len(reals) + 2 * len(pairs), len(z_reals) + 2 * len(z_pairs)
    if free and m + 1 < n and ch.coin(0.08):
        p = reals[free[ch.integer(0, len(free) - 1)]]
        z_reals.append(p * (1.0 + ch.pick([-1.0, 1.0]) * ch.loguniform(1e-7, 1e-3)))
        kind["near_cancellation"] = True


def _coeffs(pairs, reals, z_pairs, z_reals, dc_target, sign):
    A = _poly_from(reals, pairs)
    B0 = _poly_from(z_reals, z_pairs)
    # gain: |P| = dc_target at a low frequency (w = 1e-3 * smallest non-zero pole)
    mags = [abs(r) for r in reals if r != 0] + [wn for wn, _ in pairs]
    w = 1e-3 * min(mags) if mags else 1.0
    mag = abs(np.polyval(B0, 1j * w) / np.polyval(A, 1j * w))
    return [float(v) for v in sign * dc_target / mag * B0], [float(v) for v in A]


def _thermal_roots(pairs, reals, z_pairs, z_reals, dT, law):
    g = 1.0 + law["gain_per_K"] * dT
    pr = [(wn * (1 + law["resonance_per_K"] * dT), z * (1 + law["damping_per_K"] * dT))
          for wn, z in pairs]
    return pr, reals, z_pairs, z_reals, g


def draw_case(ch, seed=None, method=None):
    """A random problem document from the choices of ``ch`` (see the module docstring).

    Parameters
    ----------
    ch : Chooser
    seed : object
        Recorded in the case (and in the problem's path).
    method : str, optional
        Force ``solver.method`` (``analytic``, ``nlp``, ``convex``).

    Returns
    -------
    RandomCase
    """
    kind = {}
    sampled = ch.coin(0.3)
    fs = ch.loguniform(1e3, 1e5) if sampled else None
    pairs, reals, z_pairs, z_reals, wp = _plant_parts(ch, kind, fs)
    # the classes added later draw from a stream of their own, so every other choice of a
    # seed stays what it was
    extra = NumpyChooser([seed, 35]) if isinstance(seed, (int, np.integer)) else ch
    _near_classes(extra, kind, reals, pairs, z_pairs, z_reals)
    n = len(reals) + 2 * len(pairs)
    dc = ch.loguniform(0.01, 10.0)
    sign = -1.0 if ch.coin(0.1) else 1.0
    if sign < 0:
        kind["negative_gain"] = True
    B, A = _coeffs(pairs, reals, z_pairs, z_reals, dc, sign)
    T0 = round(ch.uniform(0.0, 40.0), 2)
    data = {"problem": {"name": f"random_{seed}", "description": "random problem"},
            "plant": {"B": B, "A": A, "temperature_C": T0}}
    fam = ch.pick(["single", "explicit", "parametric"], [0.3, 0.35, 0.35])
    kind["family"] = fam
    law = {"gain_per_K": ch.uniform(-0.005, 0.005), "resonance_per_K": ch.uniform(-0.002, 0.002),
           "damping_per_K": ch.uniform(-0.01, 0.01)}
    span = ch.uniform(5.0, 40.0)
    if fam == "explicit":
        k = ch.integer(2, 5)
        temps = sorted({round(T0 + span * ch.uniform(-0.5, 0.5), 2) for _ in range(k)} | {T0})
        models = []
        for T in temps:
            pr, rr, zp, zr, g = _thermal_roots(pairs, reals, z_pairs, z_reals, T - T0, law)
            Bt, At = _coeffs(pr, rr, zp, zr, dc * g, sign)
            models.append({"temperature_C": T, "B": Bt, "A": At})
        data["family"] = {"reference_C": T0, "models": models}
    elif fam == "parametric":
        k = ch.integer(2, 6)
        temps = sorted({round(T0 + span * ch.uniform(-0.5, 0.5), 2) for _ in range(k)} | {T0})
        par = dict(law)
        if ch.coin(0.5):
            par.update(creep_per_K=ch.uniform(0.0, 0.005), creep_at_ref=ch.uniform(0.0, 0.02),
                       creep_tau_s=ch.loguniform(0.05, 2.0))
            kind["creep"] = True
        data["family"] = {"reference_C": T0, "temperatures_C": temps, "parametric": par}
    # closed-loop poles below the plant's scale (and below any RHP zero)
    wn = wp * ch.loguniform(0.03, 0.5)
    rhp = [z for z in z_reals if z > 0]
    if rhp:
        wn = min(wn, min(rhp) / 5.0)
    poles = {"wn": wn, "zeta": ch.uniform(0.6, 1.0), "aux_factor": ch.uniform(10.0, 30.0)}
    T_mode = ch.pick(["paper", "static", "cancel_aux"], [0.5, 0.3, 0.2])
    if T_mode == "cancel_aux" and n > 2:
        poles["dominant_real"] = [-wn * ch.uniform(1.2, 3.0) for _ in range(n - 2)]
    ctrl = {"extra_degree": ch.pick([0, 1, 2], [0.5, 0.3, 0.2]), "T_mode": T_mode}
    if ch.coin(0.15):     # a roll-off pole in S, written in the natural non-monic form
        tau = 1.0 / (wn * poles["aux_factor"] * ch.uniform(1.5, 5.0))
        ctrl["S_fixed"] = [tau, 1.0, 0.0]
        kind["rolloff"] = True
    data["poles"], data["controller"] = poles, ctrl
    specs = {}
    if sampled:
        specs["sample_rate_hz"] = fs
        if ch.coin(0.2):
            specs["delay_samples"] = 1
    res = [wn_ for wn_, _ in pairs]
    if res and ch.coin(0.5):
        w_r = res[0] / (2 * math.pi)
        specs["resonance_band_hz"] = [0.7 * w_r, 1.3 * w_r]
    if sampled and extra.coin(0.35):       # a |T| band that reaches Nyquist (or folds over it)
        nyq = fs / 2.0
        specs["resonance_band_hz"] = [nyq * extra.uniform(0.3, 0.95), nyq * extra.uniform(1.0, 1.3)]
        kind["band_to_nyquist"] = True
    data["specs"] = specs
    method = method or ch.pick(["analytic", "nlp", "convex"], [0.45, 0.45, 0.1])
    solver = {"method": method, "cert_temperatures": ch.integer(3, 12), "max_rounds": 4}
    if method != "analytic":
        solver["objective"] = ch.pick(["max_integral_gain", "min_Ms", "feasibility"])
        if method == "nlp" and ch.coin(0.2):
            solver["free_poles"] = True
            solver["wn_bounds"] = [0.5 * wn, 2.0 * wn]
            solver["zeta_bounds"] = [0.5, 1.0]
    data["solver"] = solver
    kind.update(order=n, method=method, T_mode=T_mode, sampled=sampled)
    base = _baseline(data)
    factors = {}
    if base is not None:
        for key, fig in (("Ms_max", "Ms"), ("Mt_max", "Mt"), ("Mu_max", "Mu")):
            if ch.coin(0.6) and math.isfinite(base.worst[fig]):
                factors[key] = _factor(ch)
                specs[key] = max(1.0 if key == "Ms_max" else 1e-12,
                                 base.worst[fig] * factors[key])
        if "resonance_band_hz" in specs and math.isfinite(base.worst["Mt_band"]):
            factors["T_resonance_max"] = _factor(ch)
            specs["T_resonance_max"] = base.worst["Mt_band"] * factors["T_resonance_max"]
    if "resonance_band_hz" in specs and "T_resonance_max" not in specs:
        del specs["resonance_band_hz"]
    if not specs.get("Ms_max") and not specs.get("Mt_max") and not specs.get("Mu_max"):
        specs["Ms_max"] = 2.0
    ok = base is not None and base.stable and not _violations(base, specs)
    return RandomCase(seed=seed, data=data, kind=kind, baseline=base, baseline_ok=ok)


def _factor(ch):
    """Spec bound / what the analytic design achieves: mostly met, sometimes not."""
    return ch.uniform(1.02, 1.5) if ch.coin(0.85) else ch.uniform(0.85, 1.0)


def random_case(seed, method=None):
    """The random problem of ``seed`` (``numpy.random.default_rng(seed)``)."""
    return draw_case(NumpyChooser(seed), seed=seed, method=method)


def _baseline(data):
    """Checker figures of the analytic design at the document's poles (None on failure)."""
    from robrst.base.errors import RobrstError
    from robrst.problem.files import parse_problem
    from robrst.synthesis.analytic import pole_placement

    try:
        specs = {k: v for k, v in data["specs"].items() if k in ("sample_rate_hz", "delay_samples")}
        problem = parse_problem({**data, "specs": specs, "solver": {"method": "analytic"}},
                                "<baseline>")
        ctrl = pole_placement(problem.family.reference_model, problem.poles,
                              problem.controller).controller
    except (RobrstError, ValueError, np.linalg.LinAlgError):
        return None
    return figures(data, ctrl, n_temps=17, n_grid=4000)


def to_toml(d):
    """A TOML text of a problem document (tables, arrays of tables, numbers, strings, lists)."""
    return tomlkit.dumps(plain(d))


# --------------------------------------------------------------------------- checker

_MP_DPS = 60


def _pairs_of(A):
    """Real roots and (wn, zeta) pairs of a real polynomial, from numpy's roots."""
    r = np.roots(A)
    reals = sorted(float(x.real) for x in r if x.imag == 0)
    pairs = [(float(abs(x)), float(-x.real / abs(x))) for x in r if x.imag > 0]
    return reals, pairs


def model_at(data, T):
    """``(B, A)`` of the problem document's model at ``T`` [°C], built independently.

    Explicit families: coefficient-wise linear interpolation between neighbours (``A``
    monic).  Parametric: static gain, natural frequency and damping of every complex pole
    pair scaled per kelvin, creep ``(tau s + 1 + kappa)/(tau s + 1)`` with ``kappa`` growing
    above the reference.  A single model: the plant.
    """
    pl = data["plant"]
    B, A = np.asarray(pl["B"], float), np.asarray(pl["A"], float)
    B, A = B / A[0], A / A[0]
    fam = data.get("family")
    if not fam:
        return B, A
    if "models" in fam:
        ms = sorted(fam["models"], key=lambda m: m["temperature_C"])
        ts = [m["temperature_C"] for m in ms]
        i = max(0, min(int(np.searchsorted(ts, T, side="right")) - 1, len(ts) - 2))
        if len(ms) == 1:
            i = 0
        a = ms[i]
        Ba, Aa = np.asarray(a["B"], float), np.asarray(a["A"], float)
        Ba, Aa = Ba / Aa[0], Aa / Aa[0]
        if len(ms) == 1 or T == ts[i]:
            return Ba, Aa
        b = ms[i + 1]
        Bb, Ab = np.asarray(b["B"], float), np.asarray(b["A"], float)
        Bb, Ab = Bb / Ab[0], Ab / Ab[0]
        lam = (T - ts[i]) / (ts[i + 1] - ts[i])
        nb = max(len(Ba), len(Bb))
        Ba, Bb = (np.concatenate([np.zeros(nb - len(x)), x]) for x in (Ba, Bb))
        return (1 - lam) * Ba + lam * Bb, (1 - lam) * Aa + lam * Ab
    par = fam.get("parametric", {})
    ref = fam.get("reference_C", pl.get("temperature_C", 28.0))
    dT = T - ref
    reals, pairs = _pairs_of(A)
    At = np.ones(1)
    for r in reals:
        At = np.convolve(At, [1.0, -r])
    for wn, z in pairs:
        w = wn * (1 + par.get("resonance_per_K", 0.0) * dT)
        zz = z * (1 + par.get("damping_per_K", 0.0) * dT)
        At = np.convolve(At, [1.0, 2 * zz * w, w * w])
    Bt = B * (1 + par.get("gain_per_K", 0.0) * dT)
    if dT == 0 and par.get("creep_at_ref", 0.0) == 0:
        return B, A
    kappa = par.get("creep_at_ref", 0.0) + par.get("creep_per_K", 0.0) * max(dT, 0.0)
    if kappa > 0:
        tau = par.get("creep_tau_s", 1.0)
        Bt, At = np.convolve(Bt, [tau, 1.0 + kappa]), np.convolve(At, [tau, 1.0])
    return Bt, At


def _temperatures(data, n_temps):
    fam = data.get("family")
    pl = data["plant"]
    if not fam:
        return [pl.get("temperature_C", 28.0)]
    if "models" in fam:
        ts = sorted(m["temperature_C"] for m in fam["models"])
    else:
        ts = sorted(fam["temperatures_C"])
    if len(ts) == 1:
        return ts
    dense = np.linspace(ts[0], ts[-1], n_temps)
    return sorted(set(ts) | {float(t) for t in dense})


def _mul(a, b):
    return np.convolve(np.asarray(a, float), np.asarray(b, float))


def _add(a, b):
    n = max(len(a), len(b))
    out = np.zeros(n)
    out[n - len(a):] += a
    out[n - len(b):] += b
    return out


def _strip(c):
    c = np.asarray(c, float)
    nz = np.flatnonzero(c)
    return c[nz[0]:] if nz.size else np.zeros(1)


def _routh_stable(c):
    """Exact Routh test (rational arithmetic) of the float coefficients ``c``."""
    c = [Fraction(float(x)) for x in _strip(c)]
    if c[0] < 0:
        c = [-x for x in c]
    if any(x <= 0 for x in c):
        return False
    r0, r1 = c[0::2], c[1::2]
    first = [r0[0]]
    while r1:
        if r1[0] <= 0:
            return False
        first.append(r1[0])
        nxt = [(r1[0] * (r0[i + 1] if i + 1 < len(r0) else 0)
                - r0[0] * (r1[i + 1] if i + 1 < len(r1) else 0)) / r1[0]
               for i in range(max(len(r0) - 1, 0))]
        while nxt and nxt[-1] == 0:
            nxt.pop()
        r0, r1 = r1, nxt
    return len(first) == len(c)


def _roots_scaled(c):
    c = _strip(c)
    n = len(c) - 1
    if n < 1:
        return np.zeros(0, complex)
    nz = np.flatnonzero(c)
    k = n - nz[-1]
    m = n - k
    w0 = abs(c[m] / c[0]) ** (1.0 / m) if m > 0 else 1.0
    cs = c * w0 ** -np.arange(n + 1)
    r = np.roots(cs / np.max(np.abs(cs)))
    return r * w0


def stability(Delta):
    """``(stable, spectral abscissa)`` of ``Delta`` (roots; exact Routh near the axis)."""
    r = _roots_scaled(Delta)
    if r.size == 0:
        return True, -np.inf
    sa = float(np.max(r.real))
    big = float(np.max(np.abs(r)))
    if abs(sa) > 1e-6 * max(big, 1e-300):
        return sa < 0, sa
    return _routh_stable(Delta), sa


def _mp_horner(c, s, mpmath):
    """``c`` (highest power first) at ``s`` in mpmath, by Horner's scheme."""
    acc = mpmath.mpc(0)
    for x in c:
        acc = acc * s + mpmath.mpf(float(x))
    return acc


def _mp_abs_ratio(N, D, w):
    import mpmath

    with mpmath.workdps(_MP_DPS):
        s = mpmath.mpc(0, mpmath.mpf(float(w)))
        num, den = (_mp_horner(c, s, mpmath) for c in (N, D))
        if den == 0:
            return math.inf
        return float(abs(num / den))


def _eval_cond(c, w):
    """Condition of evaluating polynomial ``c`` at ``jw``: sum |c_k| w^k / |c(jw)|."""
    c = np.asarray(c, float)
    k = np.arange(len(c) - 1, -1, -1)
    aw = np.abs(np.asarray(w, float))[..., None]
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        tot = np.sum(np.abs(c) * aw ** k, axis=-1)
        val = np.abs(np.polyval(c, 1j * np.asarray(w, float)))
        return tot / val


def _gain(N, D, w):
    """|N/D|(jw); above 1 rad/s through the reversed polynomials in 1/(jw) (no overflow of
    w**n at high frequency, where a tiny leading coefficient puts a root)."""
    N, D = np.asarray(N, float), np.asarray(D, float)
    n = max(len(N), len(D))
    Np, Dp = np.pad(N, (n - len(N), 0)), np.pad(D, (n - len(D), 0))
    w = np.asarray(w, float)
    out = np.empty(w.shape)
    low = np.abs(w) <= 1.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        out[low] = np.abs(np.polyval(Np, 1j * w[low]) / np.polyval(Dp, 1j * w[low]))
        z = 1.0 / (1j * w[~low])
        out[~low] = np.abs(np.polyval(Np[::-1], z) / np.polyval(Dp[::-1], z))
    return out


def _accurate_gain(N, D, w):
    """|N/D|(jw), in mpmath when float64 evaluation loses more than 6 digits."""
    g = float(_gain(N, D, np.array([w]))[0])
    cond = max(float(_eval_cond(N, np.array([w]))[0]), float(_eval_cond(D, np.array([w]))[0]))
    if not math.isfinite(g) or not cond < 1e10:
        return _mp_abs_ratio(N, D, w)
    return g


def local_maxima(N, D, n_grid=20000, k=8):
    """Frequencies [rad/s] of the ``k`` largest local maxima of |N/D| on a dense log grid."""
    N, D = _strip(N), _strip(D)
    roots = np.concatenate([_roots_scaled(D), _roots_scaled(N)])
    mags = np.abs(roots)
    mags = mags[mags > 0]
    lo = (mags.min() if mags.size else 1.0) * 1e-4
    hi = (mags.max() if mags.size else 1.0) * 1e4
    w = np.unique(np.concatenate([np.geomspace(lo, hi, n_grid), mags,
                                  np.abs(roots.imag[roots.imag != 0])]))
    g = _gain(N, D, w)
    inner = np.flatnonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1
    return w[sorted(inner, key=lambda i: -g[i])[:k]]


def dense_peak(N, D, band=None, n_grid=20000, n_refine=8):
    """max |N(jw)/D(jw)| on a dense log grid of the unscaled polynomials, refined locally.

    ``band = (lo, hi)`` [rad/s] restricts the search (edges included).  Returns
    ``(value, w)`` (``w = inf`` for the limit at infinity).  A lower bound of the true
    supremum that converges to it; values are re-evaluated in mpmath where float64 loses
    more than 6 digits.
    """
    N, D = _strip(N), _strip(D)
    roots = np.concatenate([_roots_scaled(D), _roots_scaled(N)])
    mags = np.abs(roots)
    mags = mags[mags > 0]
    if band is None:
        lo = (mags.min() if mags.size else 1.0) * 1e-4
        hi = (mags.max() if mags.size else 1.0) * 1e4
        extra = np.concatenate([mags, np.abs(roots.imag[roots.imag != 0])])
    else:
        lo, hi = band
        extra = np.concatenate([mags, np.abs(roots.imag)])
        extra = extra[(extra >= lo) & (extra <= hi)]
    lw = np.concatenate([np.linspace(np.log(lo), np.log(hi), n_grid),
                         np.log(extra[extra > 0])])
    lw = np.unique(lw[(lw >= np.log(lo)) & (lw <= np.log(hi))])
    g = _gain(N, D, np.exp(lw))
    g = np.where(np.isfinite(g), g, np.inf)
    cands = []
    if band is None:
        cands.append((_accurate_gain(N, D, 0.0) if D[-1] != 0 else math.inf, 0.0))
        if len(N) == len(D):
            cands.append((abs(N[0] / D[0]), math.inf))
    # local maxima of the grid, best first
    inner = np.flatnonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1
    idx = list(inner) + [0, len(g) - 1]
    idx = sorted(set(idx), key=lambda i: -g[i])[:n_refine]
    for i in idx:
        if not np.isfinite(g[i]):
            cands.append((math.inf, float(np.exp(lw[i]))))
            continue
        a, b = lw[max(i - 1, 0)], lw[min(i + 1, len(lw) - 1)]
        x = _zoom(lambda t: _gain(N, D, np.exp(t)), a, b, lw[i])
        cands.append((_accurate_gain(N, D, math.exp(x)), math.exp(x)))
        cands.append((_accurate_gain(N, D, math.exp(lw[i])), math.exp(lw[i])))
    return max(cands, key=lambda t: t[0])


def _zoom(f, a, b, x, n=65, levels=7):
    """Argmax of a vectorised ``f`` on [a, b] by repeated grids around the best point."""
    for _ in range(levels):
        if not b > a:
            break
        t = np.linspace(a, b, n)
        v = f(t)
        v = np.where(np.isfinite(v), v, -np.inf)
        j = int(np.argmax(v))
        x = t[j]
        a, b = t[max(j - 1, 0)], t[min(j + 1, n - 1)]
    return float(x)


# --------------------------------------------------------------------------- sampled loop

def _scaled_tf(num, den, w0, dt=None):
    import control

    n = len(den) - 1
    num = np.concatenate([np.zeros(n + 1 - len(num)), num])
    k = w0 ** -np.arange(n + 1)
    args = (num * k, den * k) if dt is None else (num * k, den * k, dt)
    return control.tf(*args)


def _time_scale(A):
    nz = np.flatnonzero(A)
    n = len(A) - 1
    m = n - (n - nz[-1])
    return abs(A[m] / A[0]) ** (1.0 / m) if m > 0 else 1.0


def sampled_figures(B, A, ctrl, fs, delay, band=None, n_grid=20000):
    """Stability and peaks of the sampled loop through python-control.

    ZOH plant (``control.c2d`` of the time-scaled plant), Tustin controller, ``z**-delay``;
    closed-loop poles from ``control.feedback``; ``|S|, |T|, |U|`` on a dense unit-circle
    grid with refinement, each peak then evaluated in extended precision (:class:`ExactZOH`)
    at the point found and at Nyquist.  The band (rad/s) is folded into ``[0, pi fs]``
    (:func:`fold_band`: above Nyquist the sampled response repeats) and its ends and
    Nyquist are evaluated exactly.  Returns a dict (frequencies in rad/s).
    """
    import control

    w0 = _time_scale(np.asarray(A, float))
    h = w0 / fs
    Pd = control.c2d(control.ss(_scaled_tf(B, A, w0)), h, "zoh")
    K = control.c2d(control.ss(_scaled_tf(ctrl.R, ctrl.S, w0)), h, "tustin")
    if delay:
        Pd = Pd * control.tf([1.0], [1.0] + [0.0] * delay, h)
    L = Pd * K
    poles = control.feedback(Pd, K).poles()
    stable = bool(np.max(np.abs(poles)) < 1.0) if len(poles) else True
    Ld, Kd = control.ss(L), control.ss(K)

    def resp(sys, th):
        z = np.exp(1j * np.atleast_1d(np.asarray(th, float)))
        n = sys.A.shape[0]
        if n == 0:
            return np.full(z.shape, complex(sys.D[0, 0]))
        M = z[:, None, None] * np.eye(n) - sys.A[None, :, :]
        x = np.linalg.solve(M, np.broadcast_to(sys.B, (len(z), n, 1)))
        return (sys.C @ x)[:, 0, 0] + sys.D[0, 0]

    funcs = {"Ms": lambda th: np.abs(1.0 / (1.0 + resp(Ld, th))),
             "Mt": lambda th: np.abs(resp(Ld, th) / (1.0 + resp(Ld, th))),
             "Mu": lambda th: np.abs(resp(Kd, th) / (1.0 + resp(Ld, th)))}
    out = {"stable": stable, "max_abs_pole": float(np.max(np.abs(poles))) if len(poles) else 0.0}
    lam = np.abs(np.concatenate([np.roots(A), np.roots(ctrl.S)]))
    lam = lam[lam > 0]
    lo = max(min(float(lam.min()) / fs / 100.0, 1e-3), 1e-12) if lam.size else 1e-9
    th = np.geomspace(lo, np.pi, n_grid)
    at = {}
    for key, f in funcs.items():
        out[key], at[key] = _circle_peak(f, th, where=True)
    if band is not None:
        lo, hi = fold_band(band, fs)          # folded above Nyquist, both ends exact
        out["Mt_band"], at["Mt_band"] = _circle_peak(funcs["Mt"], np.linspace(lo, hi, 4000),
                                                     where=True)
        at["Mt_band_ends"] = (lo, hi)
    # each peak re-evaluated in extended precision where python-control found it, and at
    # Nyquist and the band ends: the 60-digit ZOH (ExactZOH: exact for a pole near s = 0
    # beside fast ones) and the Tustin controller in mpmath
    exact = _ExactLoop(B, A, ctrl, fs, delay)
    for key in ("Ms", "Mt", "Mu"):
        out[key] = exact.figure(key, [at[key], np.pi])
    if band is not None:
        out["Mt_band"] = exact.figure("Mt", [at["Mt_band"], *at["Mt_band_ends"]])
    out["exact_points"] = exact.count
    return out


class _ExactLoop:
    """|S|, |T|, |U| of the sampled loop at given points of the unit circle in mpmath."""

    def __init__(self, B, A, ctrl, fs, delay):
        self.zoh = ExactZOH(B, A, fs)
        self.R, self.S, self.fs, self.delay = ctrl.R, ctrl.S, float(fs), int(delay)
        self.count = 0

    def _K(self, th):
        import mpmath

        mp = mpmath
        with mp.workdps(_MP_DPS):
            R = [mp.mpf(float(x)) for x in _strip(self.R)]
            S = [mp.mpf(float(x)) for x in _strip(self.S)]
            if th >= np.pi:                        # z = -1: nu = inf, the limit of R/S
                if len(R) < len(S):
                    return 0j
                return complex(R[0] / S[0])
            nu = mp.mpc(0, 2 * self.fs * mp.tan(mp.mpf(float(th)) / 2))
            return complex(_mp_horner(R, nu, mp) / _mp_horner(S, nu, mp))

    def figure(self, key, thetas):
        best = -math.inf
        for th in thetas:
            self.count += 1
            P = complex(self.zoh.at([th])[0]) * complex(np.exp(-1j * th * self.delay))
            K = self._K(th)
            L = P * K
            val = {"Ms": 1 / (1 + L), "Mt": L / (1 + L), "Mu": K / (1 + L)}[key]
            best = max(best, abs(val))
        return best


class ExactZOH:
    """The ZOH model of ``B/A`` at ``fs`` in extended precision (independent of robrst and
    python-control): the controllable form built from the float coefficients (exact in
    mpmath), one matrix exponential of the augmented matrix ``[[A T, B T], [0, 0]]`` at
    ``dps`` digits, and ``P_d(z) = C (zI - Ad)^-1 Bd + d``.  Exact for every pole location
    (a pole near ``s = 0`` beside fast ones included) up to ``dps`` digits.

    :meth:`at` evaluates ``P_d(e^{j theta})``; ``theta = pi`` is ``z = -1`` exactly.
    """

    def __init__(self, B, A, fs, dps=_MP_DPS):
        import mpmath

        self.mp, self.dps = mpmath, dps
        with mpmath.workdps(dps):
            A = [mpmath.mpf(float(x)) for x in A]
            B = [mpmath.mpf(float(x)) for x in B]
            A, B = [x / A[0] for x in A], [x / A[0] for x in B]
            n = self.n = len(A) - 1
            B = [mpmath.mpf(0)] * (n + 1 - len(B)) + B
            self.d = B[0]
            self.C = mpmath.matrix([[B[k] - self.d * A[k] for k in range(1, n + 1)]])
            T = 1 / mpmath.mpf(float(fs))
            M = mpmath.zeros(n + 1, n + 1)
            for j in range(n):
                M[0, j] = -A[j + 1] * T
            for i in range(1, n):
                M[i, i - 1] = T
            M[0, n] = T
            E = mpmath.expm(M)
            self.Ad, self.Bd = E[:n, :n], E[:n, n]

    def at(self, theta):
        """``P_d(e^{j theta})`` (complex) for each ``theta`` [rad/sample] in ``[0, pi]``."""
        mp = self.mp
        out = []
        with mp.workdps(self.dps):
            for th in np.atleast_1d(np.asarray(theta, float)):
                z = mp.mpf(-1) if th >= np.pi else mp.exp(mp.mpc(0, mp.mpf(float(th))))
                x = mp.lu_solve(z * mp.eye(self.n) - self.Ad, self.Bd)
                out.append(complex((self.C * x)[0] + self.d))
        return np.array(out)


def fold_band(band, fs):
    """The physical band ``(lo, hi)`` [rad/s] as ``(theta_lo, theta_hi)`` [rad/sample] of
    the sampled loop, folded into ``[0, pi]`` (the response is 2 pi periodic and even)."""
    a, b = band[0] / fs, band[1] / fs
    if b - a >= 2 * np.pi:
        return 0.0, np.pi
    fold = lambda t: 2 * np.pi - math.fmod(t, 2 * np.pi) if math.fmod(t, 2 * np.pi) > np.pi \
        else math.fmod(t, 2 * np.pi)   # noqa: E731
    lo, hi = sorted((fold(a), fold(b)))
    ks = range(math.ceil(a / np.pi), math.floor(b / np.pi) + 1)
    if any(k % 2 for k in ks):
        hi = np.pi
    if any(k % 2 == 0 for k in ks):
        lo = 0.0
    return lo, hi


def _circle_peak(f, th, n_refine=6, where=False):
    """max of ``f`` on the grid ``th``, every leading local maximum refined (with
    ``where``: ``(max, argmax)``)."""
    g = f(th)
    inner = np.flatnonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1
    idx = sorted(set(inner) | {0, len(g) - 1}, key=lambda i: -g[i])[:n_refine]
    j = int(np.argmax(g))
    best, arg = float(g[j]), float(th[j])
    for i in idx:
        a, b = th[max(i - 1, 0)], th[min(i + 1, len(th) - 1)]
        x = _zoom(f, a, b, th[i])
        v = float(f(np.array([x]))[0])
        if v > best:
            best, arg = v, float(x)
    return (best, arg) if where else best


# --------------------------------------------------------------------------- figures, check

@dataclass(frozen=True)
class Figures:
    """The checker's figures of a controller on a problem document.

    ``per_T`` maps each checked temperature to its figures; ``worst`` the worst case
    (``Ms, Mt, Mu, Mt_band`` and their ``*_sampled`` versions, ``sa``); ``stable`` is true
    when every checked model (and sampled loop) is stable.
    """

    per_T: dict
    worst: dict
    stable: bool
    unstable_at: tuple = field(default=())


def _continuous(B, A, ctrl, band, n_grid):
    S, R = np.asarray(ctrl.S, float), np.asarray(ctrl.R, float)
    AS, BR = _mul(A, S), _mul(B, R)
    Delta = _strip(_add(AS, BR))
    st, sa = stability(Delta)
    out = {"stable": st, "sa": sa}
    out["Ms"] = dense_peak(AS, Delta, n_grid=n_grid)[0]
    out["Mt"] = dense_peak(BR, Delta, n_grid=n_grid)[0]
    out["Mu"] = dense_peak(_mul(A, R), Delta, n_grid=n_grid)[0]
    if band is not None:
        out["Mt_band"] = dense_peak(BR, Delta, band=band, n_grid=max(n_grid // 5, 400))[0]
    return out


def figures(data, ctrl, n_temps=65, n_grid=20000, n_stab=257):
    """Worst-case figures of ``ctrl`` on the document's family, computed independently.

    Peaks on ``n_temps`` temperatures (family members included); stability (continuous)
    on ``n_stab`` temperatures.
    """
    sp = data.get("specs", {})
    band = None
    if sp.get("resonance_band_hz"):
        band = tuple(2 * math.pi * f for f in sp["resonance_band_hz"])
    fs, delay = sp.get("sample_rate_hz"), sp.get("delay_samples", 0)
    per_T, unstable = {}, []
    for T in _temperatures(data, n_temps):
        B, A = model_at(data, T)
        rec = _continuous(B, A, ctrl, band, n_grid)
        if fs:
            s = sampled_figures(B, A, ctrl, fs, delay, band=band, n_grid=n_grid)
            rec.update({f"{k}_sampled": v for k, v in s.items()})
        per_T[T] = rec
        if not rec["stable"] or (fs and not rec["stable_sampled"]):
            unstable.append(T)
    for T in _temperatures(data, n_stab):
        if T in per_T:
            continue
        B, A = model_at(data, T)
        st, sa = stability(_strip(_add(_mul(A, ctrl.S), _mul(B, ctrl.R))))
        per_T[T] = {"stable": st, "sa": sa}
        if not st:
            unstable.append(T)
    keys = ["Ms", "Mt", "Mu", "Mt_band", "sa"]
    keys += [f"{k}_sampled" for k in ("Ms", "Mt", "Mu", "Mt_band")] if fs else []
    worst = {k: max((r[k] for r in per_T.values() if k in r), default=-math.inf) for k in keys}
    worst.setdefault("Mt_band", -math.inf)
    return Figures(per_T=per_T, worst=worst, stable=not unstable, unstable_at=tuple(unstable))


_SPEC_FIG = (("Ms_max", "Ms"), ("Mt_max", "Mt"), ("Mu_max", "Mu"), ("T_resonance_max", "Mt_band"))


def _violations(fig, specs, rtol=0.0):
    bad = []
    for key, name in _SPEC_FIG:
        b = specs.get(key)
        if b is None:
            continue
        for suffix in ("", "_sampled"):
            v = fig.worst.get(name + suffix)
            if v is not None and v > b * (1 + rtol):
                bad.append((key + suffix, v, b))
    return bad


@dataclass(frozen=True)
class Discrepancy:
    """A certificate claim the checker refutes."""

    what: str
    detail: str


def check(data, result, n_temps=33, n_grid=20000, figure_rtol=1e-6):
    """Re-check a design result independently; returns a list of :class:`Discrepancy`.

    For ``certified: true``: every checked model (continuous and sampled) must be stable
    and every peak within its bound (the certificate's relative tolerance plus
    ``1e-9``).  For any certificate: each exact peak it reports at a family member must
    not be below the checker's (a lower bound of the true supremum) by more than
    ``figure_rtol``.
    """
    d = result.as_dict() if hasattr(result, "as_dict") else result
    ctrl = result.controller
    fig = figures(data, ctrl, n_temps=n_temps, n_grid=n_grid)
    out = []
    cert = d["certificate"]
    rtol = cert["rtol"]
    if d["certified"]:
        if not fig.stable:
            out.append(Discrepancy("unstable", f"certified, but unstable at {fig.unstable_at[:5]} °C"))
        for key, v, b in _violations(fig, data.get("specs", {}), rtol + 1e-9):
            out.append(Discrepancy("peak", f"certified, but {key}: checker {v:.10g} > bound {b:.10g}"))
    for rec in cert["models"]:
        T = rec["temperature_C"]
        ref = fig.per_T.get(T)
        if ref is None or not rec.get("stable") or not ref.get("stable"):
            continue
        for k in ("Ms", "Mt", "Mu"):
            if k in rec and k in ref and rec[k] is not None and math.isfinite(ref[k]):
                if rec[k] < ref[k] * (1 - figure_rtol):
                    out.append(Discrepancy("figure", f"{k} at {T} °C: certificate {rec[k]:.10g}"
                                                     f" < checker {ref[k]:.10g}"))
    return out


if __name__ == "__main__":   # a seeded batch: python -m tests.random_problems N
    import sys
    import time

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    t0 = time.perf_counter()
    counts = {"baseline_ok": 0}
    for seed in range(n):
        c = random_case(seed)
        counts["baseline_ok"] += c.baseline_ok
        print(seed, c.kind, "baseline_ok" if c.baseline_ok else "")
    print(counts, f"{time.perf_counter() - t0:.1f} s")
