"""An independent global search for the robust RST problem (test helper).

Differential evolution (``scipy.optimize.differential_evolution``, seeded) over the
*factored controller* — the integral gain, the controller's poles as pairs ``(w, zeta)``
(and a real one), the zeros of ``R`` as pairs with any damping sign and a real zero of
either sign — a different method over a different parametrisation than robrst's global
phase (CMA-ES over the nominal closed-loop poles).  Feasibility is judged here, on the
*unscaled* polynomials, with numpy and scipy only (nothing from robrst's numerical code):

* continuous loop of every family member: ``Delta = A S + B R``, its roots (stability,
  least damping), ``|S|, |T|, |U|, |B S/Delta|`` on a dense log grid plus the resonant
  frequencies of the lightly damped roots, the reference step ``B T/Delta`` (``T = R(0)``)
  by ``scipy.signal.lfilter`` of its ZOH discretisation at a fine step (exact at the
  samples);
* sampled loop (when the problem names a rate): the plant through
  ``scipy.signal.cont2discrete`` (ZOH) behind ``z^-k``, the controller by substituting
  ``s = 2 fs (z - 1)/(z + 1)``; roots in ``z`` mapped to ``s = fs ln z``; peaks on a dense
  unit-circle grid; the discrete reference step by ``lfilter``;
* the controller's poles within the strip the problem defines (``ctrl_shift``,
  ``ctrl_max``: the robust program's own rows, stated by the caller).

The default constraints (overshoot, damping floor, ``|B S/Delta|`` against the open loop)
are included when the problem's specs carry them.  The best point is then certified by
robrst's certificate (the feasibility test of record) and, to be sure the number is not the
certificate's own, checked again by python-control (``loopcheck``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution
from scipy.signal import cont2discrete, lfilter, tf2ss

GRID = np.geomspace(1.0, 1e7, 2500)
CIRCLE = np.concatenate([np.geomspace(1e-5, np.pi, 2000), [np.pi]])
STEPS = 3000


@dataclass
class Model:
    A: np.ndarray
    B: np.ndarray
    ol_peak: float
    Ad: np.ndarray = None      # sampled: ZOH plant (with the delay) in z
    Bd: np.ndarray = None
    ol_peak_d: float = None


@dataclass
class Setting:
    """What the search needs of a problem (read from a resolved robrst Problem)."""

    models: list
    ks: int                    # degree of S' (S = s S')
    kr: int                    # degree of R
    bounds: dict               # "S", "T", "U" peak bounds (None: unbounded)
    msd_rel: float | None
    overshoot: float | None    # fraction
    floor: float | None        # damping floor
    fs: float | None
    ctrl_shift: float          # controller poles at Re s <= -ctrl_shift [rad/s]
    ctrl_max: float            # ... and >= -ctrl_max
    w_ref: float               # a frequency scale of the parametrisation [rad/s]
    rtol: float = 0.0          # a figure within this of its bound passes (the certificate's
    #                            own tolerance, solver.cert_tol, for a search judged as it)


def _peak_grid(N, D):
    """The open loop's peak on the grid and at its own poles' frequencies (a lightly damped
    resonance peaks between the grid's points: 0.6 % low at damping 0.006)."""
    w = np.concatenate([GRID, np.abs(np.roots(D).imag)])
    v = np.abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w))
    return float(np.max(v))


def _peak_circle(N, D):
    """The sampled open loop's peak on the unit circle's grid and at its poles' angles."""
    p = np.roots(D)
    z = np.exp(1j * np.concatenate([CIRCLE, np.abs(np.angle(p[np.abs(p) > 0]))]))
    return float(np.max(np.abs(np.polyval(N, z) / np.polyval(D, z))))


def _zoh(A, B, fs, delay):
    """The ZOH plant in z (highest power first), behind ``delay`` samples (time-scaled)."""
    w = abs(A[-1]) ** (1.0 / (len(A) - 1))
    n = len(A) - 1
    k = w ** -np.arange(n + 1)
    num = np.concatenate([np.zeros(n + 1 - len(B)), B]) * k
    den = A * k
    bd, ad, _ = cont2discrete((num, den), w / fs, method="zoh")
    bd = np.trim_zeros(np.atleast_1d(np.squeeze(bd)), "f")
    ad = np.concatenate([ad, np.zeros(delay)])
    return ad, bd


def setting(problem, ctrl_shift, ctrl_max):
    """The :class:`Setting` of a resolved robrst ``problem`` (its family members)."""
    sp = problem.specs
    models = []
    for m in problem.family.models:
        A, B = np.asarray(m.A, float), np.asarray(m.B, float)
        mod = Model(A=A, B=B, ol_peak=_peak_grid(B, A))
        if sp.sample_rate_hz:
            ad, bd = _zoh(A, B, sp.sample_rate_hz, sp.delay_samples)
            mod.Ad, mod.Bd = ad, bd
            mod.ol_peak_d = _peak_circle(bd, ad)
        models.append(mod)
    ref = problem.family.reference_model
    n = len(ref.A) - 1
    extra = problem.controller.extra_degree
    ks = n - 1 + extra           # S = s S', deg S = n + extra (no fixed factors beyond s)
    kr = n + extra - problem.controller.controller_relative_degree
    p = np.roots(ref.A)
    return Setting(models=models, ks=ks, kr=kr,
                   bounds={"S": sp.Ms_max, "T": sp.Mt_max, "U": sp.Mu_max},
                   msd_rel=sp.Msd_rel_max, overshoot=(None if sp.overshoot_max_pct is None
                                                      else sp.overshoot_max_pct / 100),
                   floor=sp.damping_min or None, fs=sp.sample_rate_hz,
                   ctrl_shift=ctrl_shift, ctrl_max=ctrl_max,
                   w_ref=float(np.max(np.abs(p))))


def dimension(st):
    return 1 + st.ks + st.kr


def controller(st, v):
    """``(R, S)`` (s, highest power first) of the parameter vector ``v``."""
    i, w = 1, st.w_ref
    Sp = np.ones(1)
    for _ in range(st.ks // 2):      # a pair, or two real poles (damping above 1)
        wn, z = 10 ** v[i] * w, 10 ** v[i + 1]
        Sp = np.polymul(Sp, [1.0, 2 * z * wn, wn * wn])
        i += 2
    if st.ks % 2:
        Sp = np.polymul(Sp, [1.0, 10 ** v[i] * w])
        i += 1
    Rp = np.ones(1)
    for _ in range(st.kr // 2):
        wn, z = 10 ** v[i] * w, v[i + 1]
        Rp = np.polymul(Rp, [1.0 / wn ** 2, 2 * z / wn, 1.0])
        i += 2
    if st.kr % 2:
        Rp = np.polymul(Rp, [np.sinh(v[i]) / w, 1.0])
        i += 1
    ki = 10 ** v[0]
    R = ki * Sp[-1] * Rp
    S = np.concatenate([Sp, [0.0]])
    return R, S


def bounds_of(st):
    """The search box of :func:`controller`'s parameters."""
    out = [(-2.0, 8.0)]
    lo, hi = np.log10(st.ctrl_shift / st.w_ref), np.log10(st.ctrl_max / st.w_ref)
    for _ in range(st.ks // 2):     # damping 0.05 .. 300: real poles up to 3.6e5 apart
        out += [(lo, hi), (np.log10(0.05), np.log10(300.0))]
    if st.ks % 2:
        out += [(lo, hi)]
    for _ in range(st.kr // 2):
        out += [(-3.0, 3.0), (-1.5, 1.5)]
    if st.kr % 2:
        out += [(-12.0, 12.0)]
    return out


def parameters(st, R, S):
    """The parameters of :func:`controller` for a controller ``(R, S)`` of its structure
    (``S = s S'``; ``R``'s zeros as pairs and one real zero), ``None`` when it has no such
    form (a pair of ``R``'s zeros real, or a parameter outside :func:`bounds_of`)."""
    R, S = np.asarray(R, float), np.asarray(S, float)
    Sp = S[:-1] / S[0]
    q = np.roots(Sp)
    v = [0.0]
    w = st.w_ref
    real = sorted(r.real for r in q if r.imag == 0)
    quads = [(abs(r) ** 2, -2 * r.real) for r in q if r.imag > 0]
    while len(real) >= 2 and len(quads) < st.ks // 2:
        a, b = real.pop(0), real.pop(-1)        # the fastest with the slowest
        quads.append((a * b, -(a + b)))
    for a0, a1 in quads:
        wn = np.sqrt(a0)
        v += [np.log10(wn / w), np.log10(a1 / (2 * wn))]
    if st.ks % 2:
        v.append(np.log10(-real.pop() / w))
    z = np.roots(R)
    zc = [r for r in z if r.imag > 0]
    zr = [r.real for r in z if r.imag == 0]
    if len(zc) != st.kr // 2 or len(zr) != st.kr % 2:
        return None
    for r in zc:
        wn = abs(r)
        v += [np.log10(wn / w), -r.real / wn]
    if st.kr % 2:
        v.append(float(np.arcsinh(-w / zr[0])))
    v[0] = np.log10(R[-1] / Sp[-1])
    lo, hi = np.array(bounds_of(st)).T
    v = np.array(v, float)
    return v if np.all((v >= lo) & (v <= hi)) else None


def _tustin(c, fs, deg):
    """``c(2 fs (z - 1)/(z + 1)) (z + 1)^deg`` in z, highest power first."""
    c = np.concatenate([np.zeros(deg + 1 - len(c)), c])
    out = np.zeros(deg + 1)
    for k, ck in enumerate(c):           # ck s^(deg - k)
        p = deg - k
        term = np.ones(1)
        for _ in range(p):
            term = np.polymul(term, [2 * fs, -2 * fs])
        for _ in range(deg - p):
            term = np.polymul(term, [1.0, 1.0])
        out = np.polyadd(out, ck * term)
    return out


def _damping(s):
    s = s[np.isfinite(s) & (np.abs(s) > 0)]
    return float(np.min(-s.real / np.abs(s))) if s.size else 1.0


def _step_over(num, den, h, n):
    """Overshoot (fraction) of the discrete step of ``num/den`` over ``n`` samples."""
    y = lfilter(num, den, np.ones(n))
    final = np.polyval(num, 1.0) / np.polyval(den, 1.0)
    if not np.all(np.isfinite(y)) or final == 0:
        return np.inf
    return float(np.max(y) / final - 1.0)


def _continuous_over(N, D, roots, h, n):
    """Overshoot (fraction) of the step of ``N/D`` at ``n`` instants ``k h``: exact ZOH
    samples of a state-space realisation in time scaled by the fastest root (the unscaled
    transfer function's coefficients span 1e20 and more on a 4th-order stage; its ZOH
    transfer function overflowed to an overshoot of 1.8e6 on a loop that overshoots
    15 %)."""
    w = float(np.max(np.abs(roots)))
    nd, nn = len(D) - 1, len(N) - 1
    Dx = D * w ** np.arange(nd, -1, -1.0)
    Nx = N * w ** np.arange(nn, -1, -1.0)
    Nx, Dx = Nx / Dx[0], Dx / Dx[0]
    a, b, c, d = tf2ss(Nx, Dx)
    ad, bd, cd, dd, _ = cont2discrete((a, b, c, d), h * w, method="zoh")
    x = np.zeros(ad.shape[0])
    y = np.empty(n)
    for k in range(n):
        y[k] = (cd @ x + dd[:, 0])[0]
        x = ad @ x + bd[:, 0]
    final = np.polyval(N, 0.0) / np.polyval(D, 0.0)
    if not np.all(np.isfinite(y)) or final == 0:
        return np.inf
    return float(np.max(y) / final - 1.0)


def violation(st, R, S, steps=True):
    """The summed relative excess of every constraint (0: feasible), judged here."""
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(S))):
        return 1e3                # a parameter vector beyond double precision
    v = 0.0
    q = np.roots(S[:-1]) if len(S) > 2 else np.zeros(0)
    if q.size:
        v += max(0.0, (q.real.max() + st.ctrl_shift) / st.ctrl_shift - st.rtol)
        v += max(0.0, (-st.ctrl_max - q.real.min()) / st.ctrl_max - st.rtol)
    T = np.array([R[-1]])
    for m in st.models:
        D = np.polyadd(np.polymul(m.A, S), np.polymul(m.B, R))
        if not np.all(np.isfinite(D)):
            return 1e3
        p = np.roots(D)
        if np.max(p.real) >= 0:
            return 10.0 + v + np.max(p.real) / st.w_ref
        if st.floor:
            v += max(0.0, st.floor / _damping(p) - 1.0 - st.rtol)
        low = p[(-p.real / np.abs(p) < 0.3) & (p.imag > 0)]
        w = np.concatenate([GRID, np.abs(low.imag)])
        s = 1j * w
        d = np.abs(np.polyval(D, s))
        a, b, r, sv = (np.polyval(c, s) for c in (m.A, m.B, R, S))
        for key, num in (("S", a * sv), ("T", b * r), ("U", a * r)):
            if st.bounds[key]:
                v += max(0.0, np.max(np.abs(num) / d) / st.bounds[key] - 1.0 - st.rtol)
        if st.msd_rel:
            v += max(0.0, np.max(np.abs(b * sv) / d) / (st.msd_rel * m.ol_peak) - 1.0 - st.rtol)
        if steps and st.overshoot is not None and v == 0:
            sig = np.min(-p.real)
            horizon = min(12.0 / sig, 1e3)
            over = _continuous_over(np.polymul(m.B, T), D, p, horizon / STEPS, STEPS)
            v += max(0.0, over - st.overshoot - st.rtol)
        if st.fs:
            v += _sampled(st, m, R, S, T, steps and v == 0)
    return v


def _sampled(st, m, R, S, T, steps):
    fs = st.fs
    deg = len(S) - 1
    Rz, Sz, Tz = _tustin(R, fs, deg), _tustin(S, fs, deg), _tustin(T, fs, deg)
    D = np.polyadd(np.polymul(m.Ad, Sz), np.polymul(m.Bd, Rz))
    if not np.all(np.isfinite(D)):
        return 10.0
    z = np.roots(D)
    if z.size == 0 or np.max(np.abs(z)) >= 1.0:
        return 10.0
    v = 0.0
    if st.floor:
        with np.errstate(divide="ignore"):
            v += max(0.0, st.floor / _damping(fs * np.log(z.astype(complex))) - 1.0 - st.rtol)
    zz = np.exp(1j * CIRCLE)
    d = np.abs(np.polyval(D, zz))
    a, b, r, sv = (np.polyval(c, zz) for c in (m.Ad, m.Bd, Rz, Sz))
    for key, num in (("S", a * sv), ("T", b * r), ("U", a * r)):
        if st.bounds[key]:
            v += max(0.0, np.max(np.abs(num) / d) / st.bounds[key] - 1.0 - st.rtol)
    if st.msd_rel:
        v += max(0.0, np.max(np.abs(b * sv) / d) / (st.msd_rel * m.ol_peak_d) - 1.0 - st.rtol)
    if steps and st.overshoot is not None and v == 0:
        n = int(min(20000, 12.0 / max(np.min(-np.log(np.abs(z))), 1e-9)))
        v += max(0.0, _step_over(np.polymul(m.Bd, Tz), D, 1 / fs, max(n, 50)) - st.overshoot - st.rtol)
    return v


def search(st, seed=0, popsize=15, maxiter=300, x0=None):
    """Differential evolution: the best feasible integral gain's parameters (or the least
    violating), and the evaluations spent."""
    count = [0]

    def cost(v):
        count[0] += 1
        R, S = controller(st, v)
        viol = violation(st, R, S, steps=False)
        if viol == 0:
            viol = violation(st, R, S, steps=True)
        return -v[0] + (1e3 * (1.0 + viol) if viol > 0 else 0.0)

    de = differential_evolution(cost, bounds_of(st), seed=seed, popsize=popsize,
                                maxiter=maxiter, tol=1e-12, polish=False, x0=x0,
                                init="sobol")
    return de.x, count[0]


def strip(problem):
    """The controller-pole strip ``(ctrl_shift, ctrl_max)`` [rad/s] of the robust program
    (its definition of the problem: no controller pole slower than a tenth of the slowest
    dominant pole, none faster than 30 times the fastest start root)."""
    from robrst.design import analytic_design
    from robrst.synthesis.context import Context

    ctx = Context.of(problem, analytic_design(problem))
    return ctx.ctrl_shift * ctx.w0, ctx.ctrl_max * ctx.w0


def certified_best(problem, st, v, steps=200, shrink=0.002):
    """The search's best point, its integral gain lowered until robrst's certificate (with
    the time-domain figures) holds: ``(ki, R, S)`` or ``None``."""
    from robrst.certificate.proof import certify_problem
    from robrst.core.rst import RSTController
    from robrst.design import with_time_domain

    v = np.array(v, float)
    for _ in range(steps):
        R, S = controller(st, v)
        ctrl = RSTController(R=R, S=S, T=np.array([R[-1]]))
        cert = certify_problem(problem, ctrl)
        if problem.specs.time_domain:
            cert = with_time_domain(problem, cert, ctrl)
        if cert.certified:
            return 10 ** v[0], R, S
        v[0] -= shrink
    return None
