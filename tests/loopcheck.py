"""Independent figures of a closed loop for the pole-region, disturbance and step specs (test
helper): python-control in state space on time-scaled polynomials, dense frequency grids of
the *unscaled* polynomials, ``numpy.polymul`` for the products; nothing from robrst's
numerical code.

* continuous loop: ``Delta = A S + B R``; poles as eigenvalues of python-control's state
  space of ``1/Delta`` (time-scaled, so the coefficients are O(1)), least damping and
  decay; peaks of ``|B S/Delta|`` and ``|B T/Delta|`` on a dense log grid with local
  refinement; the reference step ``B T/Delta`` by ``control.step_response`` on a dense time
  grid: overshoot [%] and 2 % settling time;
* sampled loop: the plant through ``control.c2d`` (ZOH) behind ``z**-k``, the controller
  through ``control.c2d(..., "tustin")``, both in a scaled time (``pcloop.zoh_plant``);
  closed-loop poles ``z`` mapped to ``s = fs ln z``, the discrete reference step at the
  samples, and ``|B S/Delta|`` on a dense unit-circle grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
from scipy.optimize import minimize_scalar

import pcloop


@dataclass
class LoopFigures:
    damping: float
    decay: float
    Msd: float
    Mry: float
    Ms: float
    overshoot_pct: float
    settling_s: float
    u_peak: float = None


def _trim(c):
    c = np.atleast_1d(np.asarray(c, float))
    nz = np.flatnonzero(c)
    return c[nz[0]:] if nz.size else np.zeros(1)


def _scaled(c, w):
    """Coefficients of ``c(w p)`` (highest power first), normalised to max 1."""
    c = _trim(c)
    out = c * w ** np.arange(len(c) - 1, -1, -1)
    return out / np.max(np.abs(out))


def _peak(N, D, w_lo=1e-3, w_hi=1e8, n=200_001):
    """max |N(jw)/D(jw)| on a dense log grid of the unscaled polynomials, refined."""
    w = np.geomspace(w_lo, w_hi, n)
    g = np.abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w))
    i = int(np.argmax(g))
    lo, hi = w[max(i - 1, 0)], w[min(i + 1, n - 1)]
    r = minimize_scalar(lambda x: -abs(np.polyval(N, 1j * x) / np.polyval(D, 1j * x)),
                        bounds=(lo, hi), method="bounded", options={"xatol": 1e-12 * hi})
    return max(float(g[i]), -float(r.fun))


def _damping(p):
    p = np.asarray(p, complex)
    w = np.abs(p)
    d = np.where(w > 0, -p.real / np.where(w > 0, w, 1.0), 1.0)
    return float(np.min(d)) if d.size else 1.0


def _step_figures(t, y, final):
    over = 100.0 * max(0.0, (np.max(y) - final) / abs(final))
    out = np.flatnonzero(np.abs(y - final) > 0.02 * abs(final))
    settle = float(t[out[-1] + 1]) if out.size and out[-1] + 1 < len(t) else (
        float(t[-1]) if out.size else 0.0)
    return over, settle


def continuous(plant, ctrl, horizon_s=None, n_t=40_001):
    """:class:`LoopFigures` of the continuous loop of ``plant`` (``B``, ``A``) and ``ctrl``."""
    A, B = _trim(plant.A), _trim(plant.B)
    R, S, T = _trim(ctrl.R), _trim(ctrl.S), _trim(ctrl.T)
    D = np.polyadd(np.polymul(A, S), np.polymul(B, R))
    r0 = np.abs(np.roots(D))
    w = float(np.exp(np.mean(np.log(r0[r0 > 0]))))
    sysD = control.ss(control.tf([1.0], _scaled(D, w)))
    poles = np.linalg.eigvals(sysD.A) * w
    damping, decay = _damping(poles), float(np.min(-poles.real))
    Msd = _peak(np.polymul(B, S), D)
    Mry = _peak(np.polymul(B, T), D)
    Ms = _peak(np.polymul(A, S), D)
    # reference step in scaled time tau = w t
    Ny, Dn = np.polymul(B, T), D
    Ny_s, Dn_s = _scaled_pair(Ny, Dn, w)      # the same tf in p = s/w: O(1) coefficients
    sysy = control.ss(control.tf(Ny_s, Dn_s))
    if horizon_s is None:
        horizon_s = min(40.0 / max(decay, 1e-9), 2000.0 / w * 1e3)
    t = np.linspace(0.0, horizon_s * w, n_t)
    resp = control.step_response(sysy, T=t)
    y = np.asarray(resp.outputs).ravel()
    final = float(np.polyval(Ny, 0.0) / np.polyval(Dn, 0.0))
    over, settle = _step_figures(t / w, y, final)
    return LoopFigures(damping=damping, decay=decay, Msd=Msd, Mry=Mry, Ms=Ms,
                       overshoot_pct=over, settling_s=settle)


def _scaled_pair(N, D, w):
    """``N(w p), D(w p)`` with a common normalisation (the ratio unchanged)."""
    N, D = _trim(N), _trim(D)
    n = len(D) - 1
    Ns = np.concatenate([np.zeros(len(D) - len(N)), N]) * w ** np.arange(n, -1, -1)
    Ds = D * w ** np.arange(n, -1, -1)
    sc = np.max(np.abs(Ds))
    return Ns / sc, Ds / sc


def sampled(plant, ctrl, fs, delay=0, n_samples=None):
    """:class:`LoopFigures` of the sampled loop (ZOH plant, Tustin controller, ``delay``
    samples): poles mapped to s by ``fs ln z``, the reference step at the samples."""
    w0 = pcloop.time_scale(plant)
    h = w0 / fs
    Pd = control.tf(pcloop.zoh_plant(plant, fs, delay))
    degS = len(_trim(ctrl.S)) - 1

    # controller polynomials in the scaled variable p = s / w0: c(w0 p) / w0^degS
    def scaled(c):
        c = np.concatenate([np.zeros(degS + 1 - len(_trim(c))), _trim(c)])
        return c * w0 ** np.arange(degS, -1, -1) / w0 ** degS

    Kd = control.c2d(control.tf(scaled(ctrl.R), scaled(ctrl.S)), h, "tustin")
    KTd = control.c2d(control.tf(scaled(ctrl.T), scaled(ctrl.S)), h, "tustin")
    Bz, Az = np.asarray(Pd.num[0][0], float), np.asarray(Pd.den[0][0], float)
    Rz, Sz = np.asarray(Kd.num[0][0], float), np.asarray(Kd.den[0][0], float)
    Tz, Sz2 = np.asarray(KTd.num[0][0], float), np.asarray(KTd.den[0][0], float)
    Tz = Tz * (Sz[0] / Sz2[0])   # the same denominator, normalised alike
    D = np.polyadd(np.polymul(Az, Sz), np.polymul(Bz, Rz))
    z = np.roots(D)
    with np.errstate(divide="ignore"):
        s = fs * np.log(z.astype(complex))
    s = s[np.isfinite(s)]
    damping = _damping(s)
    decay = float(np.min(-s.real)) if s.size else np.inf
    Ny = np.polymul(Bz, Tz)
    sysy = control.tf(Ny, D, h)
    n = n_samples or int(min(200_000, max(2000, 40.0 / max(decay, 1e-9) * fs)))
    resp = control.step_response(sysy, T=np.arange(n) * h)
    y = np.asarray(resp.outputs).ravel()
    final = float(np.polyval(Ny, 1.0) / np.polyval(D, 1.0))
    over, settle = _step_figures(np.arange(n) / fs, y, final)
    Msd = pcloop.unit_circle_max(lambda zz: np.polyval(np.polymul(Bz, Sz), zz) / np.polyval(D, zz))
    Mry = pcloop.unit_circle_max(lambda zz: np.polyval(Ny, zz) / np.polyval(D, zz))
    Ms = pcloop.unit_circle_max(lambda zz: np.polyval(np.polymul(Az, Sz), zz) / np.polyval(D, zz))
    return LoopFigures(damping=damping, decay=decay, Msd=Msd, Mry=Mry, Ms=Ms,
                       overshoot_pct=over, settling_s=settle)


def plant_damping(plant):
    """Least damping of the plant's complex poles (1 when none)."""
    p = np.roots(_trim(plant.A))
    p = p[np.abs(p.imag) > 1e-9 * np.abs(p)]
    return _damping(p)
