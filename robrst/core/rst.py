"""The RST controller ``S u = T yr - R y``: polynomials, closed loop, discretisation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.base.errors import DegreeError, SpecError
from robrst.core.sampled import sampled_plant

if TYPE_CHECKING:
    import control

    from robrst.core.plant import Plant

__all__ = ["RSTController", "closed_loop", "ClosedLoop", "DiscreteController", "discretize",
           "tustin_polynomials", "closed_loop_control", "CLOSED_LOOP_NAMES"]

#: the closed-loop transfer functions of :func:`closed_loop_control` (``L`` = loop gain)
CLOSED_LOOP_NAMES = ("L", "S", "T", "U", "Sd", "Tr")


@dataclass(frozen=True, eq=False)
class RSTController:
    """Polynomials R, S, T in s [rad/s], highest power first.

    The control law is ``S(s) u = T(s) yr - R(s) y``; ``u`` [V], ``y``, ``yr`` [µm].
    Causality requires ``deg R <= deg S`` and ``deg T <= deg S``.

    Parameters
    ----------
    R, S, T : array_like
        Coefficients in s, highest power first (stored as trimmed float arrays).

    Attributes
    ----------
    has_integrator : bool
        ``S(0) == 0`` exactly (zero static error to steps).

    Raises
    ------
    DegreeError
        For an improper controller (``deg R`` or ``deg T`` above ``deg S``).

    Examples
    --------
    >>> from robrst.core.rst import RSTController
    >>> bool(RSTController([2.0], [1.0, 0.0], [2.0]).has_integrator)
    True
    """

    R: np.ndarray
    S: np.ndarray
    T: np.ndarray

    def __post_init__(self):
        R, S, T = (poly.as_poly(getattr(self, k), k) for k in "RST")
        if len(R) > len(S) or len(T) > len(S):
            raise DegreeError(
                f"RST controller is improper: deg R = {len(R) - 1}, deg T = {len(T) - 1}"
                f" must not exceed deg S = {len(S) - 1}"
            )
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "S", S)
        object.__setattr__(self, "T", T)

    @property
    def has_integrator(self):
        """True when S(0) == 0 exactly (zero static error to steps)."""
        return self.S[-1] == 0.0

    def as_dict(self) -> dict[str, list[float]]:
        """The polynomials as lists (the ``controller`` object of the JSON).

        Returns
        -------
        dict
            ``{"R": [...], "S": [...], "T": [...]}``, highest power first.
        """
        return {k: getattr(self, k).tolist() for k in "RST"}

    def to_tf(self, sample_rate_hz: float | None = None) -> control.TransferFunction:
        """The law ``u = [T/S, -R/S] [yr; y]`` as a 1x2 ``control.TransferFunction``.

        Continuous (the coefficients in s, as stored) or, with ``sample_rate_hz``, the
        Tustin controller (``dt = 1/fs``) from :func:`tustin_polynomials`: the arrays
        ``T_z, -R_z`` over ``S_z`` read as polynomials in z.  Inputs ``yr, y``, output ``u``.
        Expanded polynomials in z lose digits when many roots sit near z = 1 (high sample
        rates); :meth:`to_ss` is the well-conditioned form.

        Parameters
        ----------
        sample_rate_hz : float, optional
            Sampling rate [Hz] of the Tustin controller (``None``: continuous).

        Returns
        -------
        control.TransferFunction
        """
        import control

        if sample_rate_hz is None:
            num, den, dt = (self.T, -self.R), self.S, 0
        else:
            R_z, S_z, T_z = tustin_polynomials(self, sample_rate_hz)
            num, den, dt = (T_z, -R_z), S_z, 1.0 / float(sample_rate_hz)
        return control.tf([[list(num[0]), list(num[1])]], [[list(den), list(den)]], dt,
                          inputs=["yr", "y"], outputs=["u"])

    def to_ss(self, sample_rate_hz: float | None = None) -> control.StateSpace:
        """The law as a 1x2 ``control.StateSpace`` (inputs ``yr, y``, output ``u``).

        The realisation of :func:`discretize` (one shared ``1/S``, scaled time), in
        physical time, continuous or, with ``sample_rate_hz``, Tustin with ``dt = 1/fs``.
        Well conditioned where the coefficients in s are not.

        Parameters
        ----------
        sample_rate_hz : float, optional
            Sampling rate [Hz] of the Tustin controller (``None``: continuous).

        Returns
        -------
        control.StateSpace
        """
        import control

        kw = dict(inputs=["yr", "y"], outputs=["u"])
        if sample_rate_hz is not None:
            dc = discretize(self, sample_rate_hz)
            return control.ss(dc.A, dc.B, dc.C, dc.D, 1.0 / dc.sample_rate_hz, **kw)
        (A, B, C, D), sc = _scaled_realisation(self)
        return control.ss(sc.w0 * A, sc.w0 * B, C, D, **kw)


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """Numerators of the closed-loop transfer functions over ``Delta``.

    ``S = AS/Delta`` (sensitivity), ``T = BR/Delta`` (complementary sensitivity),
    ``U = AR/Delta`` (input sensitivity, V/µm), ``Sd = BS/Delta`` (input disturbance
    to output, µm/V) and ``Tr = BT/Delta`` (reference to output).

    Parameters
    ----------
    Delta : numpy.ndarray
        The closed-loop polynomial ``A S + B R``, highest power first.
    nums : dict
        ``{"S", "T", "U", "Sd", "Tr"}`` -> numerator coefficients.
    """

    Delta: np.ndarray
    nums: dict

    def tf(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """One closed-loop transfer function as ``(numerator, Delta)``.

        Parameters
        ----------
        name : {"S", "T", "U", "Sd", "Tr"}
            Which transfer function.

        Returns
        -------
        N, D : numpy.ndarray
            Coefficients in s, highest power first.
        """
        return self.nums[name], self.Delta


def closed_loop(plant: Plant, ctrl: RSTController) -> ClosedLoop:
    """Closed-loop polynomials of ``plant`` under ``ctrl``.

    Parameters
    ----------
    plant : Plant
        ``B/A`` (continuous, or the w-plane plant of a sampled loop).
    ctrl : RSTController
        The controller.

    Returns
    -------
    ClosedLoop

    Examples
    --------
    >>> from robrst.core.plant import Plant
    >>> from robrst.core.rst import RSTController, closed_loop
    >>> cl = closed_loop(Plant([1.0], [1.0, 1.0]), RSTController([2.0], [1.0, 0.0], [2.0]))
    >>> cl.Delta.tolist()                      # s (s + 1) + 2
    [1.0, 1.0, 2.0]
    """
    A, B = plant.A, plant.B
    AS = poly.pmul(A, ctrl.S)
    BR = poly.pmul(B, ctrl.R)
    Delta = poly.padd(AS, BR)
    nums = {
        "S": AS,
        "T": BR,
        "U": poly.pmul(A, ctrl.R),
        "Sd": poly.pmul(B, ctrl.S),
        "Tr": poly.pmul(B, ctrl.T),
    }
    return ClosedLoop(Delta=Delta, nums=nums)


@dataclass(frozen=True, eq=False)
class DiscreteController:
    """``xc+ = A xc + B [yr, y]``, ``u = C xc + D [yr, y]`` at ``sample_rate_hz``.

    Parameters
    ----------
    A, B, C, D : numpy.ndarray
        The discrete realisation (two inputs ``yr, y``, one output ``u``; scaled states).
    sample_rate_hz : float
        Sampling rate [Hz].
    method : str
        The discretisation rule (``"tustin"``).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    sample_rate_hz: float
    method: str


def discretize(ctrl: RSTController, sample_rate_hz: float,
               method: str = "tustin") -> DiscreteController:
    """Discretise ``ctrl`` at ``sample_rate_hz`` [Hz] with the bilinear (Tustin) rule.

    ``u = (T yr - R y) / S`` is realised as one two-input state space in the scaled
    time ``tau = w0 t`` (:func:`robrst.core.lti.companion` of ``1/S``, O(1) coefficients
    whatever the size of R, S, T in s), then mapped by the bilinear transform.

    Parameters
    ----------
    ctrl : RSTController
        The continuous controller.
    sample_rate_hz : float
        Sampling rate [Hz].
    method : str
        ``"tustin"`` (the only rule provided).

    Returns
    -------
    DiscreteController

    Raises
    ------
    SpecError
        For another method, or a rate that is not a finite number > 0.
    """
    import scipy.signal as sig

    if method != "tustin":
        raise SpecError(f"discretisation method {method!r}: only 'tustin' is provided")
    _check_rate(sample_rate_hz)
    (Ac, Bc, Cc, Dc), sc = _scaled_realisation(ctrl)
    Ad, Bd, Cd, Dd, _ = sig.cont2discrete((Ac, Bc, Cc, Dc), sc.w0 / sample_rate_hz,
                                          method="bilinear")
    return DiscreteController(A=Ad, B=Bd, C=Cd, D=Dd, sample_rate_hz=float(sample_rate_hz),
                              method=method)


def _check_rate(sample_rate_hz):
    if not (np.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise SpecError(f"sampling rate must be a finite number > 0 Hz, got {sample_rate_hz}")


def _scaled_realisation(ctrl):
    """Two-input realisation ``(A, B, C, D)`` of ``[T/S, -R/S]`` in scaled time, and the scaling."""
    sc = poly.Scaling.natural(ctrl.S, ctrl.R)
    S = poly.trim(ctrl.S)
    deg = len(S) - 1
    Ss, Ts, Rs = (sc.normalize(np.concatenate([np.zeros(deg + 1 - len(poly.trim(c))),
                                                 poly.trim(c)]), deg)
                  for c in (S, ctrl.T, ctrl.R))
    # one realisation of 1/S; the two inputs enter through the numerators T and -R
    A, Bu, _, _ = lti.companion([1.0], Ss, poly.Scaling(1.0), balance=False)
    rows = []
    for num in (Ts, -Rs):
        _, c, d = lti.companion_parts(Ss / Ss[0], num / Ss[0])
        rows.append((np.asarray(c, float), d))
    # dual (observable) form: x' = A^T x + [c_T, c_R]^T e, u = Bu^T x + [d_T, d_R] e
    Ac = A.T
    Bc = np.column_stack([rows[0][0], rows[1][0]])
    Cc = Bu.T
    Dc = np.array([[rows[0][1], rows[1][1]]])
    return (Ac, Bc, Cc, Dc), sc


def tustin_polynomials(ctrl: RSTController,
                       sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Direct-form coefficients of the Tustin controller, ascending powers of ``q^-1``.

    ``S(q^-1) u(t) = T(q^-1) yr(t) - R(q^-1) y(t)`` with ``S_z[0] = 1``: the exact
    substitution ``s = 2 fs (1 - q^-1)/(1 + q^-1)`` times ``(1 + q^-1)^deg S``, done in
    the scaled variable ``p = s/w0`` (``w0`` of :meth:`robrst.core.poly.Scaling.natural`) so
    no power of ``2 fs`` larger than ``(2 fs/w0)^deg S`` appears.  Each coefficient is
    exact to a few ulps of the largest term that forms it.  The direct form itself is
    ill conditioned when poles sit close to ``z = 1`` (slow poles, fast sampling): run
    :mod:`robrst.controller.digital`'s sections, not these coefficients.

    Parameters
    ----------
    ctrl : RSTController
        The continuous controller.
    sample_rate_hz : float
        Sampling rate [Hz].

    Returns
    -------
    R_z, S_z, T_z : numpy.ndarray
        Each of length ``deg S + 1``.

    Raises
    ------
    SpecError
        For a rate that is not a finite number > 0, or a controller pole at
        ``s = 2 fs`` (its Tustin image is at ``z = infinity``).

    Examples
    --------
    >>> R_z, S_z, T_z = tustin_polynomials(RSTController([2.0], [1.0, 0.0], [2.0]), 0.5)
    >>> S_z.tolist(), R_z.tolist()          # integrator 2/s at fs = 0.5 Hz: 1 - q^-1
    ([1.0, -1.0], [2.0, 2.0])
    """
    from math import comb

    _check_rate(sample_rate_hz)
    sc = poly.Scaling.natural(ctrl.S, ctrl.R)
    n = len(ctrl.S) - 1
    c = 2.0 * float(sample_rate_hz) / sc.w0          # 2/h in the scaled variable
    out = []
    for P in (ctrl.R, ctrl.S, ctrl.T):
        a = sc.normalize(np.concatenate([np.zeros(n + 1 - len(P)), P]), n)[::-1]  # a[j] p^j
        z = np.zeros(n + 1)
        for j, aj in enumerate(a):
            minus = [comb(j, i) * (-1.0) ** i for i in range(j + 1)]
            plus = [float(comb(n - j, i)) for i in range(n - j + 1)]
            z += aj * c ** j * np.convolve(minus, plus)
        out.append(z)
    R_z, S_z, T_z = out
    lead = S_z[0]
    if lead == 0.0:
        raise SpecError(f"controller has a pole at s = 2 fs = {2 * sample_rate_hz:g} rad/s:"
                        " its Tustin image has a pole at z = infinity")
    return R_z / lead, S_z / lead, T_z / lead


def _ss_of(N, D, sample_rate_hz=None):
    """``N/D`` as a physical-time ``control.StateSpace`` (balanced scaled realisation)."""
    import control
    import scipy.signal as sig

    sc = poly.Scaling.natural(D)
    A, B, C, d = lti.companion(N, D, sc)
    if sample_rate_hz is None:
        return control.ss(sc.w0 * A, sc.w0 * B, C, d)
    Ad, Bd, Cd, Dd, _ = sig.cont2discrete((A, B, C, np.array([[d]])), sc.w0 / sample_rate_hz,
                                          method="bilinear")
    return control.ss(Ad, Bd, Cd, Dd, 1.0 / float(sample_rate_hz))


def closed_loop_control(plant: Plant, ctrl: RSTController, sample_rate_hz: float | None = None,
                        delay_samples: int = 0) -> dict[str, control.StateSpace]:
    """Every closed-loop transfer function as a python-control ``StateSpace``.

    Parameters
    ----------
    plant : Plant
        Continuous plant ``B/A``.
    ctrl : RSTController
        The controller.
    sample_rate_hz : float, optional
        Without it, the continuous loop.  With it, the sampled loop (ZOH plant, Tustin
        controller, ``delay_samples`` of computation delay) as discrete systems with
        ``dt = 1/fs``: the bilinear images of :func:`robrst.core.sampled.sampled_plant`'s
        exact loop, so their poles and frequency responses are the sampled loop's.
    delay_samples : int
        Whole samples of computation delay (needs ``sample_rate_hz``).

    Returns
    -------
    dict
        ``L`` (loop gain ``P K``, ``K = R/S``: close it with ``control.feedback(L)``),
        ``S`` (sensitivity), ``T`` (complementary), ``U`` (``K S``, V/µm), ``Sd`` (input
        disturbance to output, µm/V) and ``Tr`` (reference to output).  Each is SISO,
        built from robrst's closed-loop polynomials in a balanced scaled realisation.

    Raises
    ------
    SpecError
        A delay without a sample rate, or a rate that is not a finite number > 0.

    Examples
    --------
    >>> import control
    >>> from robrst import paper_plant, pole_placement, PoleSpec
    >>> ctrl = pole_placement(paper_plant(), PoleSpec(wn=600.0, zeta=1.0)).controller
    >>> cl = closed_loop_control(paper_plant(), ctrl)
    >>> round(float(control.dcgain(cl["Tr"])), 9)
    1.0
    """
    fs = sample_rate_hz
    k = int(delay_samples)
    if fs is None:
        if k:
            raise SpecError("delay_samples needs a sample rate")
        loop_plant = plant
    else:
        _check_rate(fs)
        loop_plant = sampled_plant(plant, fs, k)
    cl = closed_loop(loop_plant, ctrl)
    nums = dict(cl.nums)
    if k:   # the disturbance enters behind the delay: Sd = P_d S_d, not P_d z^-k S_d
        undelayed = sampled_plant(plant, fs, 0).B
        nums["Sd"] = poly.pprod(undelayed, ctrl.S, poly.from_roots([-2.0 * fs] * k)
                                / (2.0 * fs) ** k)
    out = {"L": _ss_of(poly.pmul(loop_plant.B, ctrl.R), poly.pmul(loop_plant.A, ctrl.S), fs)}
    out.update({name: _ss_of(nums[name], cl.Delta, fs) for name in CLOSED_LOOP_NAMES[1:]})
    return out
