"""The twin's symbolic CasADi model: one discrete step, shared by simulation and fitting.

Signal chain (eq. 2 of the paper, ``y = D_T(s) (v + u_c + u_T)``)::

    u_cmd -> delay -> input map -> saturation -> slew -> Bouc–Wen (v = g_h (u_a - h))
          -> Prandtl–Ishlinskii plays -> creep bank (u_c)
    T_amb -> thermal lag (T_s) -> Bouc–Wen in temperature (u_T)
    v + u_c + u_T -> D_T(s) [gain, resonance, damping at T_s; cubic stiffness] -> y
          -> sensor map -> noise -> quantisation

The step maps ``(state, [u_cmd, T_amb, noise], theta) -> (state+, [y_meas, y_true, u_a])``.
``theta`` holds every continuous parameter (so identification can free any of them);
structure (delay length, creep time constants, which effects exist) is fixed at build
time.  The linear part is exact: the zero-order-hold discretisation of ``D(s)`` (a
balanced realisation in scaled time, :func:`robrst.core.lti.zoh`) when
``thermal_dynamics`` is off; with it on, ``D_T`` changes with the stack temperature and is
a controllable-canonical realisation in the scaled time ``p = w0 t`` (O(1) coefficients)
advanced by RK4 with the input held over the sample.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from robrst.base.errors import SpecError
from robrst.core import lti, poly
from robrst.core.thermal import ThermalCoefficients, modal_form, thermal_polynomials
from robrst.twin.config import MAX_SUBSTEPS, RK4_STEP, min_sample_rate_hz

if TYPE_CHECKING:
    from robrst.core.plant import Plant
    from robrst.twin.config import TwinConfig

__all__ = ["TwinModel", "build_model", "hysteresis_gain", "hysteresis_sector", "GainSector",
           "creep_taus", "substeps"]

N_SUB = 4  # RK4 substeps per sample for the linear dynamics (error ~1e-6 of the peak)


def substeps(w0: float, dt: float) -> int:
    """RK4 substeps per sample: ``N_SUB`` at the paper's 20 kHz, more at slower rates.

    Keeps the scaled RK4 step ``w0 dt / n`` at or below 0.05 (the paper plant's
    response matches the exact ZOH solution to ~1e-6 of its peak), so accuracy does
    not degrade when data are sampled slower than 20 kHz.

    Parameters
    ----------
    w0 : float
        The plant's frequency scale [rad/s].
    dt : float
        The sampling period [s].

    Returns
    -------
    int
    """
    return max(N_SUB, int(np.ceil(w0 * dt / RK4_STEP)))


@dataclass(frozen=True, eq=False)
class TwinModel:
    """A built step function with its parameter vector and state layout.

    Parameters
    ----------
    config : TwinConfig
        The twin it was built from.
    step : casadi.Function
        ``(x, p, theta) -> (x_next, out)``.
    output : casadi.Function
        ``(x, p, theta) -> y_meas`` at this sample (strictly proper plants).
    theta_names : tuple of str
        The parameters of ``theta`` (``"effect.parameter"``).
    theta0 : numpy.ndarray
        Their values in ``config``.
    n_state : int
        Size of the state.
    slices : dict
        Name -> slice into the state.
    n_delay : int
        Samples of transport delay.
    w0 : float
        The plant's frequency scale [rad/s].
    dc_gain : float
        The nominal static gain [µm/V].
    strictly_proper : bool
        The plant has no feedthrough.
    resonant : bool
        The plant has a resonant pair (the thermal law's resonance and damping factors act
        on it).
    """

    config: TwinConfig
    step: ca.Function          # (x, p, theta) -> (x_next, out)
    output: ca.Function        # (x, p, theta) -> y_meas at this sample (strictly proper plants)
    theta_names: tuple
    theta0: np.ndarray
    n_state: int
    slices: dict               # name -> slice into the state
    n_delay: int
    w0: float
    dc_gain: float
    strictly_proper: bool
    resonant: bool = True

    def check_temperatures(self, temp: np.ndarray) -> None:
        """Refuse a run whose ambient temperatures ``temp`` [°C] take the twin's per-kelvin
        laws out of physics: a gain changing sign, a resonance or damping <= 0, a negative
        creep.  The stack's lagged temperature stays within the ambient range and the laws
        are affine in it, so the range's two ends decide.

        Parameters
        ----------
        temp : numpy.ndarray
            The run's ambient temperature per sample [°C].

        Raises
        ------
        SpecError
            Naming the twin file, the table and the temperature.
        """
        cfg = self.config
        lo, hi = float(np.min(temp)), float(np.max(temp))
        where = f"twin {cfg.path}: at the run's temperatures {lo:g}..{hi:g} °C"
        if cfg.enabled("thermal_dynamics"):
            td = cfg.effects["thermal_dynamics"]
            law = ThermalCoefficients(reference_C=cfg.reference_C, gain_per_K=td["gain_per_K"],
                                      resonance_per_K=td["resonance_per_K"],
                                      damping_per_K=td["damping_per_K"])
            for T in (lo, hi):
                law.check(T, self.resonant, who=f"{where}, [thermal_dynamics]")
        if cfg.enabled("creep"):
            factor = 1.0 + cfg.effects["creep"]["per_K"] * max(hi - cfg.reference_C, 0.0)
            if factor < 0:
                raise SpecError(f"{where}, [creep] per_K makes the creep negative at {hi:g} °C"
                                f" (1 + per_K dT = {factor:.3g}); expected >= 0")


def creep_taus(c: dict) -> np.ndarray:
    """Time constants of the creep cells [s], log-spaced from tau_min to tau_max.

    Parameters
    ----------
    c : dict
        The ``creep`` effect's parameters.

    Returns
    -------
    numpy.ndarray
    """
    decades = np.log10(c["tau_max_s"] / c["tau_min_s"])
    n = int(round(decades * c["cells_per_decade"])) + 1
    return np.geomspace(c["tau_min_s"], c["tau_max_s"], n)


def _bouc_wen_cycle(A, B, G, lo, hi, n):
    """``u`` and ``u - h`` over the last of three triangle cycles ``lo..hi`` (periodic by
    then), the Bouc–Wen state driven from 0 as the twin's step drives it."""
    u = np.concatenate([np.linspace(lo, hi, n), np.linspace(hi, lo, n)] * 3)
    du = np.diff(u, prepend=u[0])
    h, hs = 0.0, np.empty_like(u)
    for k, d in enumerate(du):
        h = h + A * d - B * abs(d) * h - G * d * abs(h)
        hs[k] = h
    last = slice(4 * n, 6 * n)
    return u[last], (u - hs)[last]


def hysteresis_gain(A: float, B: float, G: float, lo: float, hi: float, n: int = 4000) -> float:
    """``g_h`` making the mean slope of ``g_h (u - h)`` over a ``lo..hi`` cycle equal 1.

    The Bouc–Wen state ``h`` is driven through three triangle cycles (the last is
    periodic); the secant slope of ``u - h`` between the cycle's extremes is measured
    and inverted, so ``D(0)`` keeps its identified value on average.

    Parameters
    ----------
    A, B, G : float
        Bouc–Wen ``A``, ``beta`` [1/V] and ``gamma`` [1/V].
    lo, hi : float
        The voltage cycle [V].
    n : int
        Samples per triangle.

    Returns
    -------
    float
    """
    _, v = _bouc_wen_cycle(A, B, G, lo, hi, n)
    slope = (np.max(v) - np.min(v)) / (hi - lo)
    return float(1.0 / slope)


@dataclass(frozen=True)
class GainSector:
    """A hysteresis as an input-gain sector: its incremental slopes over a voltage cycle.

    The map ``v = g (u - h)`` changes ``v`` by ``dv = kappa(t) du`` with ``kappa`` between
    the least and largest slope of the periodic cycle.  With ``kappa = nominal (1 +
    Delta(t))``, ``|Delta| <= delta``, the loop's increments (``du/dt``, ``dv/dt``, ``dy/dt``:
    differentiation commutes with the linear plant and controller) close through ``G
    nominal (I + Delta) K``: the multi-axis problem's ``input_gain_deviation = delta`` on a
    model whose gain carries ``nominal`` certifies them (small gain, a time-varying
    ``Delta``).

    Parameters
    ----------
    nominal : float
        The slopes' centre: the gain the design model should carry.
    delta : float
        Their half-width relative to ``nominal`` (``inf`` when a slope is not positive:
        no sector).
    slopes : tuple of float
        The least and largest slope ``dv/du``.
    range_V : tuple of float
        The cycle.
    """

    nominal: float
    delta: float
    slopes: tuple
    range_V: tuple

    def as_dict(self) -> dict:
        """``{"nominal", "delta", "slopes", "range_V"}`` (``delta`` None for no sector).

        Returns
        -------
        dict
        """
        return {"nominal": self.nominal,
                "delta": self.delta if np.isfinite(self.delta) else None,
                "slopes": list(self.slopes), "range_V": list(self.range_V)}


def hysteresis_sector(A: float, B: float, G: float, gain: float, lo: float, hi: float,
                      n: int = 4000) -> GainSector:
    """The input-gain sector of the Bouc–Wen map ``v = gain (u - h)`` over a ``lo..hi``
    cycle (:class:`GainSector`): the incremental slopes of the periodic cycle, ``n``
    samples per branch (a slope changes by ``(B + |G|) |h| dh``-order between samples).

    Parameters
    ----------
    A, B, G : float
        Bouc–Wen ``A``, ``beta`` [1/V] and ``gamma`` [1/V].
    gain : float
        The map's gain ``g`` (the twin's ``bw_gain``, a diagnosis's ``gain``).
    lo, hi : float
        The voltage cycle [V] (the records' range).
    n : int
        Samples per branch.

    Returns
    -------
    GainSector

    Raises
    ------
    SpecError
        A cycle with ``lo >= hi``.

    Examples
    --------
    >>> from robrst.twin.model import hysteresis_sector
    >>> s = hysteresis_sector(0.3, 0.0, 0.0, 2.0, 0.0, 100.0)   # no loop: h = 0.3 u
    >>> round(s.nominal, 9), round(s.delta, 9)
    (1.4, 0.0)
    """
    if not hi > lo:
        raise SpecError(f"hysteresis_sector: expected lo < hi, got {lo}, {hi}")
    u, v = _bouc_wen_cycle(A, B, G, lo, hi, n)
    du, dv = np.diff(u), np.diff(v)
    k = np.abs(du) > 0
    slope = gain * dv[k] / du[k]
    s_lo, s_hi = float(np.min(slope)), float(np.max(slope))
    nominal = 0.5 * (s_lo + s_hi)
    delta = (s_hi - s_lo) / (s_hi + s_lo) if s_lo > 0 else np.inf
    return GainSector(nominal, float(delta), (s_lo, s_hi), (float(lo), float(hi)))


def _exact_step(plant, dt, xl, wtot):
    """Exact ZOH step of ``D(s)`` (no thermal change: the linear part is time-invariant);
    returns (next state, output at this sample).  The input is held over the sample, as a
    DAC holds it: the twin's linear part is then exactly the sampled plant a controller
    sees (:func:`robrst.core.lti.zoh`, balanced scaled realisation)."""
    z = lti.zoh(plant.B, plant.A, 1.0 / dt)
    y_true = ca.mtimes(ca.DM(z.C), xl) + float(z.d) * wtot
    return ca.mtimes(ca.DM(z.Ad), xl) + ca.DM(z.Bd) * wtot, y_true


def _linear_step(plant, w0, dt, xl, wtot, dT_lin, P, cubic=None):
    """RK4 step of ``D_T`` in scaled time; returns (next state, output at this sample).

    ``D_T`` comes from the thermal law of :mod:`robrst.core.thermal` with symbolic
    coefficients, realised in controllable form (:func:`robrst.core.lti.companion_parts`)
    in the scaled time ``p = w0 t``.  ``cubic`` (symbolic, per µm²): a Duffing-type
    stiffness ``k (y + cubic y^3)``, i.e. the input reduced by ``cubic y^3 / D(0)`` inside
    the integration (the output ``y`` of the state at every RK4 stage).
    """
    n = plant.n
    b, a = thermal_polynomials(modal_form(plant), dT_lin, P["gain_per_K"],
                               P["resonance_per_K"], P["damping_per_K"])
    a_s = [c * w0 ** -k for k, c in enumerate(a)]               # a_k / w0^k: monic, O(1)
    b_s = [c * w0 ** -(k + n + 1 - len(b)) for k, c in enumerate(b)]
    row, c_row, dfeed = lti.companion_parts(a_s, b_s)
    A_c = ca.vertcat(ca.horzcat(*row),
                     ca.horzcat(ca.DM.eye(n - 1), ca.DM.zeros(n - 1, 1))) if n > 1 else ca.horzcat(*row)
    B_c = ca.DM.zeros(n, 1)
    B_c[0] = 1.0
    C = ca.horzcat(*c_row)

    def f(xl):
        if cubic is None:
            return w0 * (ca.mtimes(A_c, xl) + B_c * wtot)
        y = ca.mtimes(C, xl) + dfeed * wtot
        return w0 * (ca.mtimes(A_c, xl) + B_c * (wtot - cubic * y ** 3 / plant.dc_gain))

    y_true = ca.mtimes(C, xl) + dfeed * wtot   # output at this sample (before the update)
    n_sub = substeps(w0, dt)
    if n_sub > MAX_SUBSTEPS:
        raise SpecError(f"the twin runs at {1 / dt:.6g} Hz, but its plant (natural scale"
                        f" {w0:.4g} rad/s) needs at least {min_sample_rate_hz(w0):.4g} Hz"
                        f" ({n_sub} RK4 substeps per sample, at most {MAX_SUBSTEPS})")
    hsub = dt / n_sub
    for _ in range(n_sub):
        k1 = f(xl)
        k2 = f(xl + hsub / 2 * k1)
        k3 = f(xl + hsub / 2 * k2)
        k4 = f(xl + hsub * k3)
        xl = xl + hsub / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return xl, y_true


# parameters of the effects beyond the paper's actuator (theta after reference_C)
EXTRA_THETA = ("slew_down_V_per_s", "in_dead_zone_V", "in_center_V", "in_quadratic", "in_cubic",
               "out_center_um", "out_quadratic", "out_cubic", "stiff_cubic")


def _extra_theta(eff):
    """Values of :data:`EXTRA_THETA` (zeros for effects a config does not carry)."""
    slew = eff["slew"]
    down = slew.get("V_per_s_down")
    vals = [slew["V_per_s"] if down is None else down]
    i, o, k = (eff.get(e, {}) for e in ("input_nonlinearity", "output_nonlinearity",
                                         "stiffness_nonlinearity"))
    vals += [i.get("dead_zone_V", 0.0), i.get("center_V", 0.0), i.get("quadratic_per_V", 0.0),
             i.get("cubic_per_V2", 0.0), o.get("center_um", 0.0), o.get("quadratic_per_um", 0.0),
             o.get("cubic_per_um2", 0.0), k.get("cubic_per_um2", 0.0)]
    return vals


def _input_map(u, P):
    """Static input map: a dead zone of half width ``d`` about ``c``, plus a polynomial."""
    e = u - P["in_center_V"]
    d = P["in_dead_zone_V"]
    return (P["in_center_V"] + ca.fmax(e - d, 0) + ca.fmin(e + d, 0)
            + P["in_quadratic"] * e ** 2 + P["in_cubic"] * e ** 3)


def build_model(config: TwinConfig, plant: Plant | None = None, linear: bool = True) -> TwinModel:
    """Build the symbolic step of the twin described by ``config``.

    Parameters
    ----------
    config : TwinConfig
        The twin.
    plant : Plant, optional
        Replaces the config's named nominal model, e.g. the nominal plant of a problem
        file in a gap diagnosis.
    linear : bool
        ``False``: the step stops before ``D_T(s)``: its outputs are the effective input
        ``v + u_c + u_T`` [V] instead of displacements (for input-referred effects whose
        linear part is simulated exactly elsewhere; needs thermal_dynamics off).

    Returns
    -------
    TwinModel

    Raises
    ------
    ValueError
        ``linear=False`` with thermal_dynamics on.
    """
    eff = config.effects
    on = {k: bool(v["enabled"]) for k, v in eff.items()}
    plant = config.linear_plant if plant is None else plant
    n = plant.n
    w0 = poly.natural_scale(plant.A)
    dt = config.dt
    taus = creep_taus(eff["creep"]) if on["creep"] else np.zeros(0)
    nd = int(round(eff["delay"]["seconds"] * config.sample_rate_hz)) if on["delay"] else 0
    h = eff["hysteresis"]
    gh = hysteresis_gain(h["A"], h["B"], h["Gamma"], *h["slope_range_V"]) if on["hysteresis"] else 1.0
    pi = eff.get("pi_hysteresis", {"enabled": False, "thresholds_V": (), "weights": ()})
    n_pi = len(pi["thresholds_V"]) if on.get("pi_hysteresis") else 0
    names = ("gain_per_K", "resonance_per_K", "damping_per_K", "bw_A", "bw_B", "bw_Gamma", "bw_gain",
             "creep_per_decade", "creep_per_K", "drift_lag_s", "drift_A", "drift_B",
             "drift_Gamma", "drift_V_per_K", "u_min", "u_max", "slew_V_per_s", "noise_um",
             "quant_um", "reference_C") + EXTRA_THETA + tuple(f"pi_w{i + 1}" for i in range(n_pi))
    td, dr = eff["thermal_dynamics"], eff["thermal_drift"]
    theta0 = np.array([td["gain_per_K"], td["resonance_per_K"], td["damping_per_K"], h["A"], h["B"],
                       h["Gamma"], gh, eff["creep"]["per_decade"], eff["creep"]["per_K"],
                       dr["lag_s"], dr["A"], dr["B"], dr["Gamma"], dr["gain_V_per_K"],
                       eff["saturation"]["u_min"], eff["saturation"]["u_max"],
                       eff["slew"]["V_per_s"], eff["noise"]["sigma_um"],
                       eff["quantization"]["step_um"], config.reference_C,
                       *_extra_theta(eff), *pi["weights"][:n_pi]])
    th = ca.SX.sym("theta", len(names))
    P = dict(zip(names, ca.vertsplit(th)))
    if not linear and on["thermal_dynamics"]:
        raise ValueError("linear=False needs thermal_dynamics off (it changes D_T)")
    sizes = {"lin": n if linear else 0, "h": 1, "u_prev": 1, "creep": len(taus), "T_s": 1, "z_T": 1, "delay": nd,
             "plays": n_pi}
    slices, k = {}, 0
    for key, m in sizes.items():
        slices[key] = slice(k, k + m)
        k += m
    x = ca.SX.sym("x", k)
    p = ca.SX.sym("p", 3)
    u_cmd, T_amb, noise = p[0], p[1], p[2]
    xs = {key: x[s] for key, s in slices.items()}
    # thermal lag and drift (Bouc–Wen in temperature)
    if on["thermal_drift"] or on["thermal_dynamics"] or on["creep"]:
        a_lag = ca.exp(-dt / P["drift_lag_s"]) if on["thermal_drift"] else 0.0
        T_s = xs["T_s"] + (1 - a_lag) * (T_amb - xs["T_s"])
    else:
        T_s = T_amb
    dTs = T_s - xs["T_s"]
    if on["thermal_drift"]:
        z = xs["z_T"]
        z_next = z + P["drift_A"] * dTs - P["drift_B"] * ca.fabs(dTs) * z - P["drift_Gamma"] * dTs * ca.fabs(z)
        u_T = P["drift_V_per_K"] * z_next
    else:
        z_next, u_T = xs["z_T"], 0.0
    # drive: delay, saturation, slew
    if nd:
        u_del = xs["delay"][nd - 1]
        delay_next = ca.vertcat(u_cmd, xs["delay"][:nd - 1])
    else:
        u_del, delay_next = u_cmd, xs["delay"]
    if on.get("input_nonlinearity"):
        u_del = _input_map(u_del, P)
    u_s = ca.fmin(ca.fmax(u_del, P["u_min"]), P["u_max"]) if on["saturation"] else u_del
    u_prev = xs["u_prev"]
    if on["slew"]:
        lim, lim_down = P["slew_V_per_s"] * dt, P["slew_down_V_per_s"] * dt
        u_a = u_prev + ca.fmin(ca.fmax(u_s - u_prev, -lim_down), lim)
    else:
        u_a = u_s
    # hysteresis (Hammerstein: Bouc–Wen on the applied voltage)
    if on["hysteresis"]:
        du, hh = u_a - u_prev, xs["h"]
        h_next = hh + P["bw_A"] * du - P["bw_B"] * ca.fabs(du) * hh - P["bw_Gamma"] * du * ca.fabs(hh)
        v = P["bw_gain"] * (u_a - h_next)
    else:
        h_next, v = xs["h"], u_a
    # Prandtl–Ishlinskii: play operators (memory at 0 V at rest), weighted
    if n_pi:
        r = ca.DM(pi["thresholds_V"][:n_pi])
        plays_next = ca.fmin(ca.fmax(xs["plays"], v - r), v + r)
        w = ca.vertcat(*[P[f"pi_w{i + 1}"] for i in range(n_pi)])
        v = v + ca.dot(w, plays_next - v)
    else:
        plays_next = xs["plays"]
    # creep: bank of first-order cells, strength growing with the stack temperature
    dT = T_s - P["reference_C"]
    if len(taus):
        a_c = np.exp(-dt / taus)
        c = xs["creep"]
        c_next = ca.DM(a_c) * c + ca.DM(1 - a_c) * v
        per_cell = P["creep_per_decade"] / eff["creep"]["cells_per_decade"]
        kappa = per_cell * (1 + P["creep_per_K"] * ca.fmax(dT, 0))
        u_c = kappa * ca.sum1(c_next)
    else:
        c_next, u_c = xs["creep"], 0.0
    wtot = v + u_c + u_T
    cubic = P["stiff_cubic"] if on.get("stiffness_nonlinearity") else None
    if linear and not on["thermal_dynamics"] and cubic is None:
        xl, y_true = _exact_step(plant, dt, xs["lin"], wtot)
    elif linear:
        xl, y_true = _linear_step(plant, w0, dt, xs["lin"], wtot,
                                  dT if on["thermal_dynamics"] else 0.0, P, cubic)
    else:
        xl, y_true = xs["lin"], wtot
    y_s = y_true
    if on.get("output_nonlinearity"):
        e = y_true - P["out_center_um"]
        y_s = y_true + P["out_quadratic"] * e ** 2 + P["out_cubic"] * e ** 3
    y_n = y_s + (P["noise_um"] * noise if on["noise"] else 0.0)
    if on["quantization"]:
        y_n = P["quant_um"] * ca.floor(y_n / P["quant_um"] + 0.5)
    x_next = ca.vertcat(xl, h_next, u_a, c_next, T_s, z_next, delay_next, plays_next)
    out = ca.vertcat(y_n, y_true, u_a)
    step = ca.Function("twin_step", [x, p, th], [x_next, out], ["x", "p", "theta"], ["x_next", "y"])
    output = ca.Function("twin_output", [x, p, th], [y_n], ["x", "p", "theta"], ["y_meas"])
    return TwinModel(config=config, step=step, output=output, theta_names=names, theta0=theta0,
                     n_state=k, slices=slices, n_delay=nd, w0=w0, dc_gain=float(plant.dc_gain),
                     strictly_proper=plant.m < plant.n,
                     resonant=bool(modal_form(plant).pairs))
