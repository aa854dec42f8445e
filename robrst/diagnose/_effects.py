"""The effect library: the twin's effects as fittable, chainable stages on the input side.

The fittable set is derived from the twin's own list (:data:`robrst.twin.config.EFFECTS`
minus the sensor effects): ``thermal_dynamics`` (gain, resonance and damping per K),
``hysteresis`` (Bouc–Wen), ``creep`` (cell bank, log law, growing per K),
``thermal_drift`` (lagged, hysteretic input-referred drift), ``delay``, ``saturation``,
``slew``.  Every effect but ``thermal_dynamics`` acts on the input side (per input),
in the twin's order::

    u -> delay -> saturation -> slew -> hysteresis -> creep (+) -> + thermal drift -> v

and the linear part maps the effective input ``v`` to the output.  :class:`Chain` runs a
set of effects on a record and returns ``v`` with its Jacobian with respect to the
internal parameters ``z`` (exact: compiled twin steps with sensitivities, and closed
forms for creep, saturation and delay; forward differences only for a parameter
upstream of slew or hysteresis, and for where the hysteresis memory rested before the
record, :data:`MEMORY`).  ``thermal_dynamics`` changes the linear part with
temperature and is handled by :mod:`robrst.diagnose._thermal`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal

from robrst.diagnose.options import OPTIONS
from robrst.diagnose._stages import cached_stage
from robrst.twin.config import EFFECTS as TWIN_EFFECTS
from robrst.twin.config import default_twin
from robrst.twin.model import creep_taus

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset

__all__ = ["EFFECTS", "SENSOR_EFFECTS", "INPUT_EFFECTS", "Chain", "SPECS", "summary",
           "creep_heating", "creep_per_K_free"]

SENSOR_EFFECTS = ("noise", "quantization")      # properties of the measurement, not causes
FORMS = {"pi_hysteresis": "hysteresis"}          # a twin effect that is a form of another
# the twin's effects (less the sensor's, forms under their effect), then the ones a twin of
# one input and output cannot show and the level-dependent linear form
EFFECTS = tuple(e for e in TWIN_EFFECTS if e not in SENSOR_EFFECTS and e not in FORMS) + (
    "cross_coupling", "amplitude_dependent_dynamics")
# the static input map acts after the sequential stages (its closed-form derivatives then
# need no re-run of them); the twin puts it on the drive, the same map when alone
ORDER = ("delay", "saturation", "slew", "hysteresis", "pi_hysteresis", "input_nonlinearity",
         "creep", "thermal_drift")
INPUT_EFFECTS = ORDER
THERMAL = ("thermal_drift", "thermal_dynamics")  # need a varying temperature
LN10 = np.log(10.0)
_EFF = OPTIONS.effects


@dataclass(frozen=True)
class Spec:
    """Internal parameters z of one effect (per input): bounds, start, twin values, report."""

    names: tuple
    bounds: Callable[[dict], tuple]        # summary -> (lower, upper)
    init: Callable[[dict], tuple]          # summary -> z0
    twin: Callable[[np.ndarray], tuple]    # z -> values of the stage's free twin parameters
    dtwin: Callable[[np.ndarray], np.ndarray]   # z -> d twin / d z (n_free x n_z)
    report: Callable[[np.ndarray], tuple]  # z -> reported values (same order as names)


def _hyst_twin(z):
    A, lb, r, g = z[:4]
    return np.array([A, 10 ** lb, r * 10 ** lb, g])


def _hyst_d(z):
    """d twin / d z, ``(4, len(z))`` (the memory's column, when ``z`` has it, is 0)."""
    A, lb, r, g = z[:4]
    b = 10 ** lb
    D = np.zeros((4, len(z)))
    D[:, :4] = [[1, 0, 0, 0], [0, LN10 * b, 0, 0], [0, r * LN10 * b, b, 0], [0, 0, 0, 1.0]]
    return D


# the hysteresis memory (Bouc–Wen or the plays) of a record at rest before it, at this
# fraction of the record's first input: 0 at 0 V (the twin's rest state), 1 at the first
# input (a record taken where the actuator had settled); not a property of the actuator.
# Started at 0.5: from a bound the trust-region steps that cross it shrink to nothing
MEMORY = "memory_rest_fraction"


def _drift_twin(z):
    ll, lb, r, g = z
    return np.array([10 ** ll, 10 ** lb, r * 10 ** lb, g])


def _drift_d(z):
    ll, lb, r, g = z
    b = 10 ** lb
    return np.array([[LN10 * 10 ** ll, 0, 0, 0], [0, LN10 * b, 0, 0], [0, r * LN10 * b, b, 0],
                     [0, 0, 0, 1.0]])


def _b_max(s):
    """Upper bound of log10 B [1/V] of Bouc–Wen: 30 / peak-to-peak, and the discrete update
    ``h+ = h (1 - (B +- Gamma) |du|) + A du`` a contraction for the largest step of the data
    (``(B + |Gamma|) |du| <= 2 bw_step_max`` with ``|Gamma| <= B``; the first step is from the
    memory's 0 V to the first sample).  Beyond it the loop and its sensitivities diverge: a
    fit of a smooth noise-free sine overflowed into NaN."""
    return np.log10(min(30.0 / s["u_ptp"], _EFF.bw_step_max / max(s["du_max"], 1e-12)))


SPECS = {
    "hysteresis": Spec(
        names=("A", "B_per_V", "Gamma_per_V", "gain", MEMORY),
        bounds=lambda s: ((0.0, min(np.log10(1e-4 / s["u_ptp"]), _b_max(s) - 1.0), -1.0, 0.2,
                           0.0),
                          (0.95, _b_max(s), 1.0, 5.0, 1.0)),
        init=lambda s: (0.3, min(np.log10(1.0 / s["u_ptp"]), _b_max(s) - 0.3), 1.0, 1.2, 0.5),
        twin=_hyst_twin, dtwin=_hyst_d,
        report=lambda z: (z[0], 10 ** z[1], z[2] * 10 ** z[1], z[3], z[4])),
    "thermal_drift": Spec(
        names=("lag_s", "B_per_K", "Gamma_per_K", "gain_V_per_K"),
        bounds=lambda s: ((-1.0, -3.0, -1.0, -20.0 * s["u_scale"]),
                          (3.0, 1.0, 1.0, 20.0 * s["u_scale"])),
        init=lambda s: (np.log10(np.clip(s["duration_s"] / 10, 0.2, 100.0)), -1.0, 1.0, 0.0),
        twin=_drift_twin, dtwin=_drift_d,
        report=lambda z: (10 ** z[0], 10 ** z[1], z[2] * 10 ** z[1], z[3])),
    "slew": Spec(
        names=("V_per_s", "V_per_s_down"),
        bounds=lambda s: ((np.log10(s["u_ptp"] * 0.1),) * 2, (np.log10(s["rate_max"] * 10),) * 2),
        init=lambda s: (np.log10(0.5 * s["rate_max"]),) * 2,
        twin=lambda z: 10.0 ** np.asarray(z, float),
        dtwin=lambda z: np.diag(LN10 * 10.0 ** np.asarray(z, float)),
        report=lambda z: (10 ** z[0], 10 ** z[1])),
    "creep": Spec(
        names=("per_decade", "per_K"),
        # creep goes on in the direction of the step (>= 0); its growth with temperature
        # keeps it >= 0 over the records' temperatures (Chain sets the lower bound of
        # per_K, or holds it at 0 when they do not vary above the reference)
        # (started inside the bound: at it, the trust region crawls along it)
        bounds=lambda s: ((0.0, -1.0), (0.3, 2.0)), init=lambda s: (0.01, 0.0),
        twin=lambda z: np.asarray(z, float), dtwin=lambda z: np.eye(2),
        report=lambda z: (z[0], z[1])),
    "saturation": Spec(
        names=("u_min_V", "u_max_V"),
        bounds=lambda s: ((s["u_min"] - s["u_ptp"], s["u_max"] - 0.5 * s["u_ptp"]),
                          (s["u_min"] + 0.5 * s["u_ptp"], s["u_max"] + s["u_ptp"])),
        # a limit not started inside the records starts at the far end of its bounds: one
        # at their edge would clip held-out data beyond them that the records never tested
        init=lambda s: (s["u_min"] - s["u_ptp"], s["u_max"] + s["u_ptp"]),
        twin=lambda z: np.asarray(z, float), dtwin=lambda z: np.eye(2),
        report=lambda z: (z[0], z[1])),
}


def _pi_spec(stats):
    n = len(_EFF.pi_fractions)
    return Spec(names=tuple(f"weight_{i + 1}" for i in range(n)) + (MEMORY,),
                bounds=lambda s: ((-3.0,) * n + (0.0,), (3.0,) * n + (1.0,)),
                init=lambda s: (0.0,) * n + (0.5,),
                twin=lambda z: np.asarray(z[:n], float), dtwin=lambda z: np.eye(n, len(z)),
                report=lambda z: tuple(z))


def pi_thresholds(stats):
    """Play thresholds [V] of the Prandtl–Ishlinskii candidate: fractions of the input's
    peak-to-peak range (``pi_fractions`` of :class:`~robrst.diagnose.options.EffectOptions`)."""
    return tuple(float(f * stats["u_ptp"]) for f in _EFF.pi_fractions)


def _map_spec(stats):
    """Static input map: a dead zone about a centre, a polynomial, hinges at the knots."""
    n = len(stats["knots"])
    p = stats["u_ptp"]
    return Spec(names=("dead_zone_V", "center_V", "quadratic_per_V", "cubic_per_V2") + tuple(
                f"slope_change_at_{k:.4g}V" for k in stats["knots"]),
                bounds=lambda s: ((0.0, s["u_min"], -0.5 / p, -1.0 / p ** 2) + (-2.0,) * n,
                                  (0.5 * p, s["u_max"], 0.5 / p, 1.0 / p ** 2) + (2.0,) * n),
                # a dead zone starts open (at its bound 0 the solver stalled on the first step)
                init=lambda s: (0.02 * p, 0.5 * (s["u_min"] + s["u_max"]), 0.0, 0.0) + (0.0,) * n,
                twin=lambda z: np.asarray(z, float), dtwin=lambda z: np.eye(len(z)),
                report=lambda z: tuple(z))


def spec(effect, stats):
    """The :class:`Spec` of an input-side effect (the play weights and the input map's
    hinges depend on the data)."""
    if effect == "pi_hysteresis":
        return _pi_spec(stats)
    if effect == "input_nonlinearity":
        return _map_spec(stats)
    return SPECS[effect]


def _knots(U):
    """Distinct knots strictly inside the data: quantiles (``knot_quantiles``), at least 1 % of
    the range apart (a hinge at the edge of the data is not determined by it)."""
    lo, hi = float(U.min()), float(U.max())
    gap = 0.01 * max(hi - lo, 1e-12)
    out = []
    for v in np.quantile(U, _EFF.knot_quantiles):
        if lo + gap < v < hi - gap and (not out or v > out[-1] + gap):
            out.append(float(v))
    return tuple(out)


def summary(records: Sequence[Dataset]) -> dict:
    """Scales of the training data (per all inputs) for bounds and starting values.

    Parameters
    ----------
    records : sequence of Dataset
        The training records.

    Returns
    -------
    dict
        ``u_ptp``, ``du_max`` (the largest step, from 0 V to the first sample
        included), ``knots`` (of the static input map), ``u_min``, ``u_max``,
        ``u_scale``, ``rate_max`` [V/s], ``duration_s``, ``temp_min`` and ``temp_max``
        [°C] (None when no record has a temperature), ``memory_shows`` (a record that is
        not periodic starts away from 0 V: where its hysteresis memory rested shows).
    """
    U = np.concatenate([d.U for d in records])
    ptp = float(max(np.ptp(U), 1e-9))
    steps = [float(np.max(np.abs(np.diff(d.U, axis=0)))) if d.n > 1 else 0.0 for d in records]
    rate = max(du * d.fs for du, d in zip(steps, records))
    # the hysteresis memory starts at 0 V: its first step is to the first sample
    first = max(float(np.max(np.abs(d.U[0]))) for d in records)
    return {"u_ptp": ptp, "du_max": max(max(steps), first),
            "knots": _knots(U), "u_min": float(U.min()), "u_max": float(U.max()),
            "u_scale": max(float(np.max(np.abs(U))), ptp) / 150.0,
            "rate_max": max(rate, ptp), "duration_s": float(max(d.t[-1] - d.t[0] for d in records)),
            "temp_min": min((float(np.min(d.temp)) for d in records if d.temp is not None),
                            default=None),
            "temp_max": max((float(np.max(d.temp)) for d in records if d.temp is not None),
                            default=None),
            "memory_shows": any(not (d.period and d.periods >= 1)
                                and float(np.max(np.abs(d.U[0]))) > 1e-9 * ptp for d in records)}


def creep_heating(stats: dict, reference_C: float) -> tuple[float, float]:
    """The range of ``max(T - reference, 0)`` over the training records [K]: creep's growth
    with temperature acts on it.

    Parameters
    ----------
    stats : dict
        :func:`summary` of the training records.
    reference_C : float
        The model's temperature [°C].

    Returns
    -------
    (float, float)
        Its least and largest value (records without a temperature are at the reference).
    """
    if stats.get("temp_min") is None:
        return 0.0, 0.0
    return max(stats["temp_min"] - reference_C, 0.0), max(stats["temp_max"] - reference_C, 0.0)


def creep_per_K_free(stats: dict, reference_C: float) -> bool:
    """Do the training records determine creep's growth with temperature (``per_K``)?

    Only the product ``per_decade (1 + per_K dT)`` shows when ``dT = max(T - reference,
    0)`` does not vary over the records (every record at one temperature, or below the
    reference): ``per_K`` is then held at 0 and ``per_decade`` is the creep at their
    temperature.

    Parameters
    ----------
    stats : dict
        :func:`summary` of the training records.
    reference_C : float
        The model's temperature [°C].

    Returns
    -------
    bool
    """
    lo, hi = creep_heating(stats, reference_C)
    return hi - lo >= OPTIONS.records.temp_excited_K


def creep_cells(fs):
    c = default_twin().effects["creep"]
    taus = creep_taus(c)
    return np.exp(-1.0 / (fs * taus)), float(c["cells_per_decade"])


def _shift(x, d, x0):
    if d == 0:
        return x
    return np.concatenate([np.full((d,) + x.shape[1:], x0), x[:-d]])


class Chain:
    """A set of input-side effects with per-input parameters ``z`` (see the module doc).

    Parameters
    ----------
    effects : iterable of str
        The effects (kept in the chain's fixed order).
    n_in : int
        Number of inputs.
    fs : float
        Sampling rate [Hz].
    reference_C : float
        The model's temperature [°C].
    stats : dict
        :func:`summary` of the training data (bounds and starting values).
    delays : sequence of int, optional
        The whole-sample delay per input (fitted by search, not in ``z``).
    cache : dict, optional
        Compiled stages shared by the chains of one diagnosis.

    Attributes
    ----------
    size : int
        Length of ``z``.
    """

    def __init__(self, effects: Iterable[str], n_in: int, fs: float, reference_C: float,
                 stats: dict, delays: Sequence[int] | None = None,
                 cache: dict | None = None) -> None:
        self.effects = tuple(e for e in ORDER if e in effects)
        self.n_in, self.fs, self.ref = n_in, float(fs), float(reference_C)
        self.stats = stats
        self.delays = (tuple(delays) if delays is not None and "delay" in self.effects
                       else (0,) * n_in)
        self.blocks, lo, hi, z0, names = [], [], [], [], []
        for e in self.effects:
            if e == "delay":
                continue
            sp = spec(e, stats)
            b_lo, b_hi = sp.bounds(stats)
            for j in range(n_in):
                start = len(lo)
                lo += list(b_lo)
                hi += list(b_hi)
                z0 += list(np.clip(sp.init(stats), b_lo, b_hi))
                suffix = f"_u{j + 1}" if n_in > 1 else ""
                names += [f"{n}{suffix}" for n in sp.names]
                self.blocks.append((e, j, slice(start, len(lo))))
        self.lower, self.upper = np.array(lo, float), np.array(hi, float)
        self.z0 = np.array(z0, float)
        self.names = tuple(names)
        self.creep_per_K = "creep" in self.effects and creep_per_K_free(stats, reference_C)
        if "creep" in self.effects:
            heat = creep_heating(stats, reference_C)[1]
            for j in range(n_in):
                k = self._block("creep", j).start + 1
                if self.creep_per_K:        # kappa = 1 + per_K dT stays > 0 on the records
                    self.lower[k] = max(self.lower[k], -0.95 / max(heat, 1e-12))
                else:                       # not determined by the records: held at 0
                    self.lower[k], self.upper[k] = -1e-12, 1e-12
                self.z0[k] = np.clip(self.z0[k], self.lower[k], self.upper[k])
        if not stats.get("memory_shows", True):    # periodic records (warmed up on a period)
            for (e, j, sl) in self.blocks:          # or from 0 V: where it rested does not show
                if e in ("hysteresis", "pi_hysteresis"):
                    k = sl.stop - 1
                    self.lower[k], self.upper[k], self.z0[k] = -1e-12, 1e-12, 0.0
        self.stages = {e: cached_stage(cache, e, fs, reference_C) for e in self.effects
                       if e in ("slew", "hysteresis", "thermal_drift")}
        if "pi_hysteresis" in self.effects:
            self.stages["pi_hysteresis"] = cached_stage(cache, "pi_hysteresis", fs, reference_C,
                                                        thresholds_V=pi_thresholds(stats))
        self.cells = creep_cells(fs) if "creep" in self.effects else None

    @property
    def size(self):
        return self.z0.size

    def _block(self, e, j):
        return next(s for (name, jj, s) in self.blocks if name == e and jj == j)

    def limits(self) -> list[tuple[int, float]]:
        """The saturation limits: ``(index in z, the far end of its bounds)`` per limit.

        A limit is moved to its far end when the records do not need it
        (:func:`robrst.diagnose.fit.fit_model`): out of their way it clips only what lies a
        span of the inputs beyond them.

        Returns
        -------
        list of (int, float)
        """
        out = []
        for (e, _, sl) in self.blocks:
            if e == "saturation":
                out += [(sl.start, float(self.lower[sl.start])),
                        (sl.start + 1, float(self.upper[sl.start + 1]))]
        return out

    def start_saturation(self, limits: Sequence[tuple[float, float]]) -> None:
        """Start the saturation limits at ``limits`` (one ``(lo, hi)`` per input), in bounds.

        Parameters
        ----------
        limits : sequence of (float, float)
            Per input [V].
        """
        if "saturation" in self.effects:
            for j, (lo, hi) in enumerate(limits):
                sl = self._block("saturation", j)
                self.z0[sl] = np.clip([lo, hi], self.lower[sl], self.upper[sl])

    def _input(self, z, u, temp, j, jac):
        """Effective input of channel j and d/dz of its own parameters (N, n_z)."""
        n = u.size
        x = _shift(u, self.delays[j], u[0])
        dx = np.zeros((n, self.size)) if jac else None
        fd_cols = []                                   # upstream of a sequential stage
        for e in self.effects:
            if e == "delay":
                continue
            sl = self._block(e, j)
            zz = z[sl]
            if e == "saturation":
                lo, hi = zz
                inside = (x >= lo) & (x <= hi)
                if jac:
                    dx *= inside[:, None]
                    dx[:, sl.start] = x < lo
                    dx[:, sl.start + 1] = x > hi
                x = np.clip(x, lo, hi)
            elif e == "input_nonlinearity":
                d, c, a2, a3 = zz[:4]
                h = zz[4:]
                knots = np.asarray(self.stats["knots"])
                ee = x - c
                out = (np.abs(ee) > d)
                above = x[:, None] > knots[None, :]
                if jac:
                    dx *= (out + 2 * a2 * ee + 3 * a3 * ee ** 2 + above @ h)[:, None]
                    dx[:, sl.start] = -np.sign(ee) * out
                    dx[:, sl.start + 1] = 1.0 - out - 2 * a2 * ee - 3 * a3 * ee ** 2
                    dx[:, sl.start + 2] = ee ** 2
                    dx[:, sl.start + 3] = ee ** 3
                    dx[:, sl.start + 4:sl.stop] = np.maximum(x[:, None] - knots[None, :], 0.0)
                x = (c + np.maximum(ee - d, 0.0) + np.minimum(ee + d, 0.0) + a2 * ee ** 2
                     + a3 * ee ** 3 + np.maximum(x[:, None] - knots[None, :], 0.0) @ h)
            elif e in ("slew", "hysteresis", "pi_hysteresis"):
                st = self.stages[e]
                sp = spec(e, self.stats)
                memory = e != "slew"
                out, dout = st.run(x, temp, sp.twin(zz), memory_V=zz[-1] * x[0] if memory else 0.0)
                if jac:
                    if np.any(dx):
                        fd_cols += [c for c in range(self.size) if np.any(dx[:, c])]
                    dx[:] = 0.0
                    dx[:, sl] = dout @ sp.dtwin(zz)
                    if memory and x[0] and self.upper[sl.stop - 1] > self.lower[sl.stop - 1]:
                        dx[:, sl.stop - 1] = self._memory_column(st, sp, zz, x, temp, out)
                x = out
            elif e == "creep":
                a, per = self.cells
                Ts = self._stack_temp(z, temp, j)
                kappa_unit = (1.0 + zz[1] * np.maximum(Ts - self.ref, 0.0)) / per
                X = np.column_stack([x, dx]) if jac else x[:, None]
                acc = np.zeros_like(X)
                for ai in a:
                    acc += signal.lfilter([1 - ai], [1.0, -ai], X, axis=0)
                creep = zz[0] * kappa_unit[:, None] * acc
                if jac:
                    dx = dx + creep[:, 1:]
                    dx[:, sl.start] = kappa_unit * acc[:, 0]
                    dx[:, sl.start + 1] = (zz[0] * np.maximum(Ts - self.ref, 0.0) / per
                                           * acc[:, 0]) if self.creep_per_K else 0.0
                x = x + creep[:, 0]
            elif e == "thermal_drift":
                st = self.stages[e]
                out, dout = st.run(np.zeros(n), temp, SPECS[e].twin(zz))
                if jac:
                    dx[:, sl] = dout @ SPECS[e].dtwin(zz)
                x = x + out
        return x, dx, sorted(set(fd_cols))

    @staticmethod
    def _memory_column(st, sp, zz, x, temp, out):
        """d out / d (the memory's rest fraction) by a one-sided difference inside [0, 1]
        (at 1 the first step vanishes: ``|du|`` has its corner there)."""
        h = 1e-4 if zz[-1] <= 0.5 else -1e-4
        shifted, _ = st.run(x, temp, sp.twin(zz), memory_V=(zz[-1] + h) * x[0])
        return (shifted - out) / h

    def _stack_temp(self, z, temp, j):
        if "thermal_drift" not in self.effects:
            return temp
        lag = 10 ** z[self._block("thermal_drift", j)][0]
        a = np.exp(-1.0 / (self.fs * lag))
        return signal.lfilter([1 - a], [1.0, -a], temp, zi=[a * temp[0]])[0]

    def run(self, z: np.ndarray, U: np.ndarray, temp: np.ndarray, jac: bool = True,
            warm: int = 0) -> tuple[np.ndarray, list | None]:
        """Effective inputs ``(N, k)`` and their Jacobians (list per input of (N, n_z)).

        Parameters
        ----------
        z : numpy.ndarray
            The effects' parameters.
        U : numpy.ndarray
            Commanded inputs ``(N + warm, k)`` [V].
        temp : numpy.ndarray
            Temperature per sample [°C].
        jac : bool
            Also compute the Jacobians.
        warm : int
            Samples at the start that are a warm-up (dropped from the outputs).

        Returns
        -------
        V : numpy.ndarray
            ``(N, k)`` [V].
        dV : list of numpy.ndarray or None
        """
        z = np.asarray(z, float)
        V, dV = [], []
        for j in range(U.shape[1]):
            x, dx, fd = self._input(z, U[:, j], temp, j, jac)
            if jac:
                for c in fd:
                    h = 1e-6 * max(1.0, abs(z[c]))
                    zc = z.copy()
                    zc[c] += h
                    dx[:, c] = (self._input(zc, U[:, j], temp, j, False)[0] - x) / h
                dV.append(dx[warm:])
            V.append(x[warm:])
        return np.column_stack(V), (dV if jac else None)

    def report(self, z: np.ndarray, std: np.ndarray | None = None) -> dict:
        """Reported parameter values and 1-sigma (delta method) by effect, then name.

        Parameters
        ----------
        z : numpy.ndarray
            The effects' parameters.
        std : numpy.ndarray, optional
            Their 1-sigma.

        Returns
        -------
        dict
            ``{effect: (values, sigmas)}`` with dicts keyed by parameter name.
        """
        out = {e: ({}, {}) for e in self.effects}
        for (e, j, sl) in self.blocks:
            vals, sds = out[e]
            sp = spec(e, self.stats)
            zz = np.asarray(z[sl], float)
            rep = np.asarray(sp.report(zz), float)
            suffix = f"_u{j + 1}" if self.n_in > 1 else ""
            G = np.zeros((rep.size, zz.size))
            for c in range(zz.size):
                h = 1e-7 * max(1.0, abs(zz[c]))
                zc = zz.copy()
                zc[c] += h
                G[:, c] = (np.asarray(sp.report(zc), float) - rep) / h
            s = np.zeros(rep.size) if std is None else np.asarray(std[sl], float)
            with np.errstate(invalid="ignore"):
                sd = np.sqrt(np.nansum((G * np.where(np.isfinite(s), s, 0.0)) ** 2, axis=1))
            sd[(np.abs(G[:, ~np.isfinite(s)]) > 0).any(axis=1)] = np.inf
            for name, v, d in zip(sp.names, rep, sd):
                vals[f"{name}{suffix}"] = float(v)
                sds[f"{name}{suffix}"] = float(d)
        if "creep" in self.effects and not self.creep_per_K:
            vals, sds = out["creep"]
            t = self.stats.get("temp_min")
            for j in range(self.n_in):
                suffix = f"_u{j + 1}" if self.n_in > 1 else ""
                sds[f"per_K{suffix}"] = np.inf          # not determined by the records
                vals[f"per_decade_at_C{suffix}"] = float(self.ref if t is None
                                                          else max(t, self.ref))
                sds[f"per_decade_at_C{suffix}"] = 0.0
        if "delay" in self.effects:
            vals, sds = out["delay"]
            for j, d in enumerate(self.delays):
                suffix = f"_u{j + 1}" if self.n_in > 1 else ""
                vals[f"seconds{suffix}"], sds[f"seconds{suffix}"] = d / self.fs, 0.5 / self.fs
                vals[f"samples{suffix}"], sds[f"samples{suffix}"] = float(d), 0.5
        return out
