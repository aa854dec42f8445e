"""Running the digital controller in float64 or float32, and what that costs.

Two effects separate an implementation from the exact Tustin loop the certificate covers:

* **coefficient rounding** — the sections' coefficients stored in the target precision
  are another controller ``K + dK``.  On the sampled loop ``1 + L' = (1 + L)(1 + S dL)``
  with ``dL = P dK``, so when ``mu = sup |P S dK|`` over the unit circle is below 1 the
  implemented loop is stable exactly when the certified one is (same poles on the unit
  circle: an integrator is ``F = 0``, exact in any precision; Nyquist's argument) and
  ``|S'| <= |S| / (1 - mu)``, ``|T'| <= (|T| + mu) / (1 - mu)``.  ``mu`` is computed on
  a dense grid (log-spaced in ``tan(theta/2)``, plus Nyquist) for every model given
  (the export passes every model its certificate checked);
* **arithmetic rounding** — measured by simulating a reference step on the exact ZOH
  plant with the controller's arithmetic in the target precision, against the same
  sections in extended precision (``numpy.longdouble``: 80-bit on x86-64 Linux; where it is
  only float64 the float64 figure reads 0).

:func:`run_loop` is the reference implementation of the step the C and Python writers
emit (same operations in the same order), so the compiled code can be checked against it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.core.analysis import spectral_abscissa
from robrst.controller.digital import DigitalController, Section, exact_response
from robrst.base.errors import SpecError
from robrst.core.plant import Plant
from robrst.core.rst import closed_loop
from robrst.core.sampled import sampled_plant

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.rst import RSTController

__all__ = ["rounded", "controller_step", "run_loop", "run_direct_form", "SampledLoop",
           "sampled_loop", "loop_perturbation", "implementation_report", "frequency_grid",
           "PRECISIONS", "RealisationFigures"]

PRECISIONS = {"float64": np.float64, "float32": np.float32}


@dataclass(frozen=True)
class RealisationFigures:
    """What one realisation of the controller in one precision costs against the exact loop.

    Parameters
    ----------
    form : str
        ``"sections"`` (the second-order sections robrst writes) or ``"direct_form"`` (the
        expanded ``R_z, S_z, T_z``, for comparison).
    precision : str
        ``"float64"`` or ``"float32"``.
    mu_y, mu_yr : float
        The coefficient rounding's ``sup |P S dK|`` over the unit circle (worst over the
        loops), from the measured output and from the reference.
    stable_guaranteed : bool
        Every exact loop stable, ``mu_y < 1`` and the same poles on and outside the unit
        circle as the exact controller (the integrator exactly at ``z = 1``).
    step_error_y, step_error_u : float or None
        The simulated 1 µm step's largest output and command errors relative to their
        peaks, against the sections in extended precision (``None`` when the first loop is
        unstable or is a biproper plant without delay).

    Attributes
    ----------
    key : str
        ``form_precision``, the JSON's name (``"sections_float32"``).
    """

    form: str
    precision: str
    mu_y: float
    mu_yr: float
    stable_guaranteed: bool
    step_error_y: float | None = None
    step_error_u: float | None = None

    @property
    def key(self) -> str:
        return f"{self.form}_{self.precision}"

    def as_dict(self) -> dict:
        """The figures as the export JSON holds them under :attr:`key`.

        Returns
        -------
        dict
            ``mu_y, mu_yr, stable_guaranteed, step_error_y, step_error_u``.
        """
        return {"mu_y": self.mu_y, "mu_yr": self.mu_yr,
                "stable_guaranteed": self.stable_guaranteed,
                "step_error_y": self.step_error_y, "step_error_u": self.step_error_u}


def rounded(dc: DigitalController, dtype: type) -> DigitalController:
    """``dc`` with every coefficient rounded to ``dtype`` (stored back as float64).

    Parameters
    ----------
    dc : DigitalController
        The controller.
    dtype : type
        ``numpy.float32`` or ``numpy.float64``.

    Returns
    -------
    DigitalController
        The sections, feedthrough and direct form rounded; the anti-windup poles kept.
    """
    r = lambda a: np.asarray(a, float).astype(dtype).astype(float)   # noqa: E731
    secs = tuple(Section(r(s.F), r(s.G), r(s.H), r(s.J), r(s.L), s.pole_rad_s)
                 for s in dc.sections)
    return DigitalController(ctrl=dc.ctrl, sample_rate_hz=dc.sample_rate_hz, w0=dc.w0,
                             sections=secs, D=r(dc.D), R_z=r(dc.R_z), S_z=r(dc.S_z),
                             T_z=r(dc.T_z), aw_poles_z=dc.aw_poles_z,
                             aw_method=dc.aw_method)


def frequency_grid(n: int = 4000) -> np.ndarray:
    """``theta`` in (0, pi] dense near 0 and near Nyquist (log-spaced in tan and cot).

    Parameters
    ----------
    n : int
        About the number of points.

    Returns
    -------
    numpy.ndarray
        Increasing angles [rad per sample], ending at ``pi``.
    """
    lo = 2.0 * np.arctan(np.geomspace(1e-7, 1.0, n // 2))
    hi = np.pi - 2.0 * np.arctan(np.geomspace(1.0, 1e-7, n // 2))
    return np.unique(np.concatenate([lo, hi[1:], [np.pi]]))


@dataclass(frozen=True, eq=False)
class SampledLoop:
    """The exact sampled loop of one model on the grid of :func:`frequency_grid`.

    Parameters
    ----------
    plant : Plant
        The continuous model.
    theta : numpy.ndarray
        The grid [rad per sample].
    P : numpy.ndarray
        The ZOH plant with the delay at ``z = exp(j theta)``.
    K : numpy.ndarray
        ``[T/S, -R/S]`` (Tustin) at the same points, shape ``(len(theta), 2)``.
    poles_z : numpy.ndarray
        The closed-loop poles (a lost degree of the characteristic polynomial is a pole
        at ``z = -1``).

    Attributes
    ----------
    spectral_radius : float
        Largest closed-loop pole modulus.
    """

    plant: Plant
    theta: np.ndarray
    P: np.ndarray
    K: np.ndarray
    poles_z: np.ndarray

    @property
    def spectral_radius(self):
        return float(np.max(np.abs(self.poles_z))) if self.poles_z.size else 0.0


def sampled_loop(ctrl: RSTController, plant: Plant, sample_rate_hz: float,
                 delay_samples: int = 0) -> SampledLoop:
    """:class:`SampledLoop` of ``ctrl`` (in s, Tustin at ``sample_rate_hz``) on ``plant``.

    Parameters
    ----------
    ctrl : RSTController
        The controller in s.
    plant : Plant
        The continuous model.
    sample_rate_hz : float
        Sampling rate [Hz].
    delay_samples : int
        Whole samples of computation delay.

    Returns
    -------
    SampledLoop
    """
    fs = float(sample_rate_hz)
    theta = frequency_grid()
    th = theta[:-1]                                         # theta[-1] = pi (Nyquist)
    pw = sampled_plant(plant, fs, delay_samples)
    sc = poly.Scaling.natural(pw.A)
    p = 1j * 2.0 * fs * np.tan(th / 2.0) / sc.w0
    P = np.polyval(sc.apply(pw.B), p) / np.polyval(sc.apply(pw.A), p)
    P = np.append(P, pw.B[0] if len(pw.B) == len(pw.A) else 0.0)
    K = np.vstack([exact_response(ctrl, th, fs), _nyquist(ctrl)])
    cl = closed_loop(pw, ctrl)
    _, s = spectral_abscissa(cl.Delta)
    q = s / (2.0 * fs)
    z = (1.0 + q) / (1.0 - q)
    if len(cl.Delta) < pw.n + len(ctrl.S):                 # degree lost: pole at z = -1
        z = np.append(z, -1.0)
    return SampledLoop(plant=plant, theta=theta, P=P, K=K, poles_z=z)


def loop_perturbation(loop: SampledLoop, implemented: DigitalController) -> dict[str, float]:
    """``sup |P S dK|`` per channel on ``loop`` (``dK``: ``implemented`` minus exact).

    Parameters
    ----------
    loop : SampledLoop
        The exact loop.
    implemented : DigitalController
        Anything with ``freqresp(theta)`` returning ``[K_yr, K_y]`` (e.g. a rounded
        controller).

    Returns
    -------
    dict
        ``mu_y`` (feedback channel: the small-gain figure of the module doc) and
        ``mu_yr`` (feedforward channel: an absolute error on ``|Tr|``); ``inf`` when
        the implemented response is not finite.
    """
    with np.errstate(all="ignore"):
        dK = implemented.freqresp(loop.theta) - loop.K
        PS = loop.P / (1.0 - loop.P * loop.K[:, 1])
        mu = [np.abs(PS * dK[:, i]) for i in (1, 0)]
    # a NaN (overflowed coefficients) is no bound at all
    return {k: float(np.max(m)) if np.all(np.isfinite(m)) else np.inf
            for k, m in zip(("mu_y", "mu_yr"), mu)}


def _nyquist(ctrl):
    """``[T/S, -R/S]`` at ``s = inf`` (``z = -1``)."""
    n = len(ctrl.S)
    lead = lambda P: P[0] / ctrl.S[0] if len(P) == n else 0.0   # noqa: E731
    return np.array([lead(ctrl.T), -lead(ctrl.R)], complex)


def controller_step(dc: DigitalController, dtype: type = np.float64,
                    u_range: tuple[float, float] | None = None) -> Callable[[float, float], float]:
    """A step function ``f(yr, y) -> u`` with the controller's state inside (reference).

    The operations and their order are those of the generated C and Python code:
    section outputs inner to outer, ``u``, saturation, then every state incremented.

    Parameters
    ----------
    dc : DigitalController
        The controller.
    dtype : type
        Arithmetic of the step (``float``/``numpy.float64``, ``numpy.float32``,
        ``numpy.longdouble``).
    u_range : (float, float), optional
        Saturation limits [V] (``None``: none).

    Returns
    -------
    callable
        ``step(yr, y) -> u`` [µm, µm -> V], saturated; the state starts at rest.
    """
    t = float if dtype in (float, np.float64) else dtype
    secs = [([[t(x) for x in row] for row in s.F], [[t(x) for x in row] for row in s.G],
             [t(x) for x in s.H.ravel()], [t(x) for x in s.J], [t(x) for x in s.L])
            for s in dc.sections]
    X = [[t(0.0)] * len(s[2]) for s in secs]
    d0, d1 = t(dc.D[0]), t(dc.D[1])
    lo, hi = (t(-np.inf), t(np.inf)) if u_range is None else (t(u_range[0]), t(u_range[1]))

    def step(yr, y):
        yr, y = t(yr), t(y)
        w = t(0.0)
        V = []
        for (F, G, H, J, L), x in zip(secs, X):
            v = (w, yr, y)
            wk = t(0.0)
            for hi_, xi in zip(H, x):
                wk = wk + hi_ * xi
            w = wk + J[0] * w + J[1] * yr + J[2] * y
            V.append(v)
        u = w + d0 * yr + d1 * y
        us = lo if u < lo else (hi if u > hi else u)
        du = us - u
        for (F, G, H, J, L), x, v in zip(secs, X, V):
            inc = []
            for i in range(len(x)):
                acc = t(0.0)
                for fij, xj in zip(F[i], x):
                    acc = acc + fij * xj
                inc.append(acc + G[i][0] * v[0] + G[i][1] * v[1] + G[i][2] * v[2] + L[i] * du)
            for i in range(len(x)):
                x[i] = x[i] + inc[i]
        return us

    return step


def _plant_loop(plant, fs, yr, delay_samples, control):
    """Run ``control(yr_k, y_k) -> u_k`` on the exact ZOH model of ``plant`` (float64)."""
    if len(plant.B) == len(plant.A) and delay_samples == 0:
        raise SpecError("simulating the sampled loop needs a strictly proper plant or a delay"
                        " (a biproper plant without delay is an algebraic loop)")
    z = lti.zoh(plant.B, plant.A, fs)
    x = np.zeros(z.Ad.shape[0])
    C, Bd = z.C.ravel(), z.Bd.ravel()
    pending = [0.0] * delay_samples
    y_out, u_out = np.empty(len(yr)), np.empty(len(yr))
    for k, r in enumerate(yr):
        y = float(C @ x) + (z.d * pending[0] if delay_samples else 0.0)
        u = float(control(r, y))
        pending.append(u)
        ua = pending.pop(0)
        x = z.Ad @ x + Bd * ua
        y_out[k], u_out[k] = y, u
    return y_out, u_out


def run_loop(dc: DigitalController, plant: Plant, yr: ArrayLike, delay_samples: int = 0,
             dtype: type = np.float64,
             u_range: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Closed loop of the sections (arithmetic in ``dtype``) and the exact ZOH ``plant``.

    Parameters
    ----------
    dc : DigitalController
        The controller.
    plant : Plant
        The continuous model (simulated by its exact ZOH in float64).
    yr : array_like
        The reference per sample [µm].
    delay_samples : int
        Whole samples of computation delay.
    dtype : type
        Arithmetic of the controller.
    u_range : (float, float), optional
        Saturation limits [V].

    Returns
    -------
    y, u : numpy.ndarray
        Measured output [µm] and commanded (saturated) voltage [V] per sample.

    Raises
    ------
    SpecError
        For a biproper plant without delay (an algebraic loop).
    """
    return _plant_loop(plant, dc.sample_rate_hz, np.asarray(yr, float), int(delay_samples),
                       controller_step(dc, dtype, u_range))


def run_direct_form(dc: DigitalController, plant: Plant, yr: ArrayLike, delay_samples: int = 0,
                    dtype: type = np.float64) -> tuple[np.ndarray, np.ndarray]:
    """The same loop with the direct form ``S_z u = T_z yr - R_z y`` in ``dtype`` (comparison).

    Parameters
    ----------
    dc : DigitalController
        The controller (its ``R_z, S_z, T_z``).
    plant : Plant
        The continuous model.
    yr : array_like
        The reference per sample [µm].
    delay_samples : int
        Whole samples of computation delay.
    dtype : type
        Arithmetic of the controller.

    Returns
    -------
    y, u : numpy.ndarray
        Measured output [µm] and command [V] per sample (no saturation).

    Raises
    ------
    SpecError
        For a biproper plant without delay (an algebraic loop).
    """
    t = dtype
    R, S, T = (np.asarray(c, float).astype(t) for c in (dc.R_z, dc.S_z, dc.T_z))
    n = len(S)
    hist = {k: [t(0.0)] * n for k in ("u", "yr", "y")}

    def step(yr, y):
        hist["yr"] = [t(yr)] + hist["yr"][:-1]
        hist["y"] = [t(y)] + hist["y"][:-1]
        acc = t(0.0)
        for i in range(n):
            acc = acc + T[i] * hist["yr"][i] - R[i] * hist["y"][i]
        for i in range(1, n):
            acc = acc - S[i] * hist["u"][i - 1]
        hist["u"] = [acc] + hist["u"][:-1]
        return acc

    return _plant_loop(plant, dc.sample_rate_hz, np.asarray(yr, float), int(delay_samples), step)


def _step_error(reference, runner, n):
    """Largest output and command errors of ``runner`` on a 1 µm step, relative to peaks."""
    y_ref, u_ref = reference
    y, u = runner(np.ones(n))
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(u))):
        return np.inf, np.inf
    return (float(np.max(np.abs(y - y_ref)) / np.max(np.abs(y_ref))),
            float(np.max(np.abs(u - u_ref)) / np.max(np.abs(u_ref))))


def _unstable_poles(dc):
    """Number of poles of the sections outside the unit circle (-1: not finite)."""
    A = dc.state_space()[0]
    if not np.all(np.isfinite(A)):
        return -1
    return int(np.sum(np.abs(np.linalg.eigvals(A)) > 1.0)) if A.size else 0


def implementation_report(dc: DigitalController, loops: Sequence[SampledLoop],
                          delay_samples: int = 0, n_steps: int = 1000
                          ) -> tuple[RealisationFigures, ...]:
    """Float64 and float32 sections (and, for comparison, the direct form) vs the exact loop.

    Parameters
    ----------
    dc : DigitalController
        The controller.
    loops : sequence of SampledLoop
        The models' exact sampled loops (the first one is also simulated).
    delay_samples : int
        Whole samples of computation delay.
    n_steps : int
        Length of the simulated 1 µm reference step [samples].

    Returns
    -------
    tuple of RealisationFigures
        The sections in float64 and float32, then the direct form in float64 and float32.
    """
    with np.errstate(all="ignore"):
        return _report(dc, loops, int(delay_samples), n_steps)


def _report(dc, loops, k, n_steps):
    plant = loops[0].plant
    reference = None
    if loops[0].spectral_radius < 1.0:
        try:
            reference = run_loop(dc, plant, np.ones(n_steps), k, np.longdouble)
        except SpecError:
            pass
    n_unstable = _unstable_poles(dc)
    exact_stable = all(lp.spectral_radius < 1.0 for lp in loops)
    out = []
    for form in ("sections", "direct_form"):
        for name, dt in PRECISIONS.items():
            impl = rounded(dc, dt)
            if form == "sections":
                resp = impl
                same = _unstable_poles(impl) == n_unstable   # integrators: F = 0 exactly
                runner = lambda r, impl=impl, dt=dt: run_loop(impl, plant, r, k, dt)  # noqa: E731
            else:
                resp = _DirectForm(impl)
                same = not dc.ctrl.has_integrator or math.fsum(impl.S_z) == 0.0
                runner = lambda r, impl=impl, dt=dt: run_direct_form(impl, plant, r, k, dt)  # noqa: E731
            figs = [loop_perturbation(lp, resp) for lp in loops]
            mu_y, mu_yr = max(f["mu_y"] for f in figs), max(f["mu_yr"] for f in figs)
            err_y = err_u = None
            if reference is not None:
                err_y, err_u = _step_error(reference, runner, n_steps)
            out.append(RealisationFigures(form, name, mu_y, mu_yr,
                                          bool(exact_stable and mu_y < 1.0 and same),
                                          err_y, err_u))
    return tuple(out)


class _DirectForm:
    """Frequency response of the direct-form coefficients ``R_z, S_z, T_z`` of ``dc``."""

    def __init__(self, dc):
        self.dc = dc

    def freqresp(self, theta):
        q = np.exp(-1j * np.asarray(theta, float))
        S = np.polyval(self.dc.S_z[::-1], q)
        return np.column_stack([np.polyval(self.dc.T_z[::-1], q) / S,
                                -np.polyval(self.dc.R_z[::-1], q) / S])
