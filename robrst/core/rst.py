"""The RST controller ``S u = T yr - R y``: polynomials, closed loop, discretisation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.base.errors import DegreeError, SpecError
from robrst.core.plant import as_plant, is_control_system
from robrst.core.sampled import sampled_plant

if TYPE_CHECKING:
    import control

    from robrst.core.plant import Plant

__all__ = ["RSTController", "closed_loop", "ClosedLoop", "DiscreteController", "discretize",
           "tustin_polynomials", "closed_loop_control", "CLOSED_LOOP_NAMES", "as_controller",
           "inverse_tustin", "feedback_part", "COMMON_ROOT_RTOL"]

#: roots of R and S this close (relative) are one common factor of the law (a 2-DOF
#: controller's reference model: R' = R Am_ref, S' = S Am_ref)
COMMON_ROOT_RTOL = 1e-5

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

    @classmethod
    def from_control(cls, sys: control.TransferFunction | control.StateSpace) -> RSTController:
        """The RST controller of a python-control ``TransferFunction`` or ``StateSpace``.

        Parameters
        ----------
        sys : control.TransferFunction or control.StateSpace
            One output; one input (``K``) or two (``yr, y``); continuous or discrete.

        Returns
        -------
        RSTController

        * one input and one output, ``K``: the one-degree-of-freedom law
          ``u = K (yr - y)``, i.e. ``R = T = num K``, ``S = den K``;
        * one output and two inputs ``[yr, y]`` (what :meth:`to_tf` and :meth:`to_ss`
          return): ``u = [T/S, -R/S] [yr; y]``.

        A discrete system (``dt > 0``) is read as the Tustin controller at ``fs = 1/dt``
        and returned as the continuous controller whose Tustin image it is (exact inverse
        of the bilinear map, :func:`inverse_tustin`); design and certify it with
        ``specs.sample_rate_hz = 1/dt`` and :func:`discretize` gives the same law back.

        Raises
        ------
        SpecError
            Another shape (MIMO), ``dt = True``, an improper law, a discrete pole at
            ``z = -1`` (no continuous pre-image).

        Examples
        --------
        >>> import control
        >>> K = RSTController.from_control(control.tf([2.0, 1.0], [1.0, 0.0]))   # PI
        >>> K.R.tolist(), K.S.tolist(), K.T.tolist()
        ([2.0, 1.0], [1.0, 0.0], [2.0, 1.0])
        """
        import control

        if not is_control_system(sys):
            raise SpecError(f"controller: expected an RSTController or a python-control"
                            f" TransferFunction or StateSpace, got {type(sys).__name__}")
        shape = (sys.noutputs, sys.ninputs)
        if shape not in ((1, 1), (1, 2)):
            raise SpecError(f"controller: a python-control system of {sys.ninputs} input(s)"
                            f" and {sys.noutputs} output(s); expected K (1 x 1: u = K (yr - y))"
                            " or [T/S, -R/S] (1 x 2, inputs yr, y)")
        if sys.dt is True:
            raise SpecError("controller: discrete system with an unspecified sampling period"
                            " (dt = True); give dt in seconds")
        if isinstance(sys, control.StateSpace):
            A, B, C, D = (np.asarray(x, float) for x in (sys.A, sys.B, sys.C, sys.D))
            pairs = [lti.ss_to_poly(A, B[:, [j]], C, float(D[0, j])) if A.size
                     else (np.array([D[0, j]]), np.array([1.0])) for j in range(shape[1])]
        else:
            pairs = [(poly.trim(sys.num[0][j]), poly.trim(sys.den[0][j]))
                     for j in range(shape[1])]
        if shape == (1, 1):
            (N, S), = pairs
            T, R = N, N
        else:
            (NT, DT), (NR, DR) = pairs
            if len(DT) == len(DR) and np.allclose(DT / DT[0], DR / DR[0], rtol=1e-12, atol=0):
                S, T, R = DT, NT * DT[0] / DT[0], -NR * DT[0] / DR[0]
            else:
                S, T, R = poly.pmul(DT, DR), poly.pmul(NT, DR), -poly.pmul(NR, DT)
        if sys.dt not in (0, None):
            R, S, T = inverse_tustin((R, S, T), 1.0 / float(sys.dt))
        return cls(R, S, T)

    def to_control(self, sample_rate_hz: float | None = None) -> control.StateSpace:
        """The law ``u = [T/S, -R/S] [yr; y]`` as a python-control ``StateSpace``.

        Parameters
        ----------
        sample_rate_hz : float, optional
            Without it the continuous law; with it the Tustin controller, ``dt = 1/fs``.

        Returns
        -------
        control.StateSpace
            :meth:`to_ss` (the well-conditioned realisation), inputs ``yr, y``.
        """
        return self.to_ss(sample_rate_hz)

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
    plant : Plant or control.TransferFunction or control.StateSpace
        ``B/A`` (continuous, or the w-plane plant of a sampled loop; a python-control
        system: :func:`~robrst.core.plant.as_plant`).
    ctrl : RSTController or control.TransferFunction or control.StateSpace
        The controller (a python-control system: :func:`as_controller`).

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
    plant, ctrl = as_plant(plant), as_controller(ctrl)
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
    ctrl = as_controller(ctrl)
    (Ac, Bc, Cc, Dc), sc = _scaled_realisation(ctrl)
    Ad, Bd, Cd, Dd, _ = sig.cont2discrete((Ac, Bc, Cc, Dc), sc.w0 / sample_rate_hz,
                                          method="bilinear")
    return DiscreteController(A=Ad, B=Bd, C=Cd, D=Dd, sample_rate_hz=float(sample_rate_hz),
                              method=method)


def as_controller(obj: object, what: str = "controller") -> RSTController:
    """``obj`` as an :class:`RSTController`.

    Parameters
    ----------
    obj : RSTController or control.TransferFunction or control.StateSpace
        Itself, or a python-control system through :meth:`RSTController.from_control`.
    what : str
        Named in the error (the argument's name).

    Returns
    -------
    RSTController

    Raises
    ------
    SpecError
        Anything else, naming ``what`` and the type.
    """
    if isinstance(obj, RSTController):
        return obj
    if is_control_system(obj):
        return RSTController.from_control(obj)
    raise SpecError(f"{what}: expected an RSTController or a python-control TransferFunction"
                    f" or StateSpace, got {type(obj).__name__}")


def inverse_tustin(polys: tuple, sample_rate_hz: float) -> tuple:
    """Polynomials in z (highest power first) of a Tustin controller mapped back to s.

    ``z = (1 + s/2fs)/(1 - s/2fs)``: each ``c(z)`` of a common degree ``n`` (the largest)
    becomes ``(1 - p)^n c((1 + p)/(1 - p))`` with ``p = s/(2 fs)``, the same factor for
    every polynomial, so ratios are exact; then ``p`` is unscaled.

    Parameters
    ----------
    polys : sequence of array_like
        ``(R, S, T)`` in z (the second is the denominator).
    sample_rate_hz : float
        The Tustin rate [Hz].

    Returns
    -------
    tuple of numpy.ndarray
        The polynomials in s, in the same order.

    Raises
    ------
    SpecError
        The first polynomial (or the denominator, the second) loses its leading term: a
        pole at ``z = -1``, which no continuous controller has.
    """
    from math import comb

    _check_rate(sample_rate_hz)
    cs = [np.asarray(poly.trim(c), float) for c in polys]
    n = max(len(c) for c in cs) - 1
    out = []
    for c in cs:
        a = np.concatenate([np.zeros(n + 1 - len(c)), c])[::-1]   # a[k] z^k
        q = np.zeros(n + 1)                                     # ascending powers of p
        for k, ak in enumerate(a):
            plus = [float(comb(k, i)) for i in range(k + 1)]
            minus = [comb(n - k, i) * (-1.0) ** i for i in range(n - k + 1)]
            q += ak * np.convolve(plus, minus)
        out.append((q / (2.0 * float(sample_rate_hz)) ** np.arange(n + 1))[::-1])
    S = poly.trim(out[1])
    if len(S) < n + 1 and n > 0:
        raise SpecError("controller: a discrete pole at z = -1 (Nyquist) has no continuous"
                        " pre-image under Tustin; it cannot be represented")
    return tuple(poly.trim(c) if np.any(c) else np.zeros(1) for c in out)


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
    ctrl = as_controller(ctrl)
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


def feedback_part(ctrl: RSTController) -> RSTController:
    """The feedback law ``R/S`` of ``ctrl`` with the factors ``R`` and ``S`` share divided out.

    A two-degree-of-freedom controller (``T_mode = "reference_model"``) carries its
    reference model in both ``R`` and ``S`` (the law is ``[T/S, -R/S]``); the loop gain
    ``P R/S`` does not depend on it.  Common roots (matched within
    :data:`COMMON_ROOT_RTOL`, relative, in the scaled variable: a repeated root comes out of
    ``numpy.roots`` perturbed by about ``sqrt(eps)``) are divided out of ``R`` and ``S``
    when the division is exact to 1e-10 relative.

    Parameters
    ----------
    ctrl : RSTController or control.TransferFunction or control.StateSpace

    Returns
    -------
    RSTController
        ``R0, S0`` (``S0`` led as ``S`` is) and ``T = R0``: the feedback law alone (the
        reference path ``T/S`` is the whole law's); ``ctrl`` itself when ``R`` and ``S``
        share no root.
    """
    ctrl = as_controller(ctrl)
    R, S = poly.trim(ctrl.R), poly.trim(ctrl.S)
    # exact roots at s = 0 (the integrator) stay exact: stripped here, put back below
    zR = len(R) - 1 - int(np.flatnonzero(R)[-1])
    zS = len(S) - 1 - int(np.flatnonzero(S)[-1])
    R, S = R[:len(R) - zR], S[:len(S) - zS]
    if len(R) < 2 or len(S) < 2:
        return ctrl
    sc = poly.Scaling.natural(S, R)
    rr, rs = list(np.roots(sc.apply(R))), list(np.roots(sc.apply(S)))
    common = []
    for z in list(rr):
        d = [abs(z - w) / max(abs(z), 1e-300) for w in rs]
        if d and min(d) <= COMMON_ROOT_RTOL:
            w = rs.pop(int(np.argmin(d)))
            rr.remove(z)
            common.append(0.5 * (z + w))
    if not common:
        return ctrl
    F = np.real(np.poly(common))
    Rs, remR = np.polydiv(sc.apply(R), F)
    Ss, remS = np.polydiv(sc.apply(S), F)
    if max(np.max(np.abs(remR)) / np.max(np.abs(sc.apply(R))),
           np.max(np.abs(remS)) / np.max(np.abs(sc.apply(S)))) > 1e-10:
        return ctrl           # not an exact common factor after all: keep the law as it is
    S0 = sc.undo(Ss)
    R0 = sc.undo(Rs) * (ctrl.S[0] / S0[0])     # S0 led as S is (the constant of the division)
    S0 = S0 * (ctrl.S[0] / S0[0])
    R0, S0 = np.concatenate([R0, np.zeros(zR)]), np.concatenate([S0, np.zeros(zS)])
    return RSTController(R0, S0, R0)


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
                        delay_samples: int = 0,
                        w_plane: bool = False) -> dict[str, control.StateSpace]:
    """Every closed-loop transfer function as a python-control ``StateSpace``.

    Parameters
    ----------
    plant : Plant or control.TransferFunction or control.StateSpace
        Continuous plant ``B/A`` (a discrete python-control plant: its continuous
        pre-image, :meth:`~robrst.core.plant.Plant.from_control`, and by default its rate
        and delay).
    ctrl : RSTController or control.TransferFunction or control.StateSpace
        The controller.
    sample_rate_hz : float, optional
        Without it, the continuous loop.  With it, the sampled loop (ZOH plant, Tustin
        controller, ``delay_samples`` of computation delay) as discrete systems with
        ``dt = 1/fs``: the bilinear images of :func:`robrst.core.sampled.sampled_plant`'s
        exact loop, so their poles and frequency responses are the sampled loop's.
    delay_samples : int
        Whole samples of computation delay (needs ``sample_rate_hz``).
    w_plane : bool
        With a rate: the sampled loop in the w-plane (Tustin's ``z = (1 + w/2fs)/(1 -
        w/2fs)``) as *continuous* systems: the same stability, the same peaks and margins,
        at the warped frequency ``nu = 2 fs tan(omega / 2 fs)``.  python-control's
        continuous ``stability_margins`` on this ``L`` gives the sampled loop's margins
        exactly (its discrete ``stability_margins`` is unreliable on loops sampled fast
        relative to their dynamics: see the python-control guide in ``docs/``).

    Returns
    -------
    dict
        ``L`` (loop gain ``P K``, ``K = R/S``: close it with ``control.feedback(L)``),
        ``S`` (sensitivity), ``T`` (complementary), ``U`` (``K S``, V/µm), ``Sd`` (input
        disturbance to output, µm/V) and ``Tr`` (reference to output).  Each is SISO,
        built from robrst's closed-loop polynomials in a balanced scaled realisation.
        ``L, S, T, U, Sd`` are those of the feedback law (:func:`feedback_part`: a 2-DOF
        controller's reference model, common to ``R`` and ``S``, divided out; minimal
        realisations, on which python-control's ``stability_margins`` works in discrete
        time too); ``Tr`` is the whole law's.

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
    plant, ctrl = as_plant(plant), as_controller(ctrl)
    if sample_rate_hz is None and "sample_rate_hz" in plant.meta:   # a discrete plant given
        sample_rate_hz = plant.meta["sample_rate_hz"]
        delay_samples = delay_samples or plant.meta.get("delay_samples", 0)
    fs = sample_rate_hz
    k = int(delay_samples)
    if fs is None:
        if k:
            raise SpecError("delay_samples needs a sample rate")
        loop_plant = plant
    else:
        _check_rate(fs)
        loop_plant = sampled_plant(plant, fs, k)
    fb = feedback_part(ctrl)
    cl = closed_loop(loop_plant, fb)
    nums = dict(cl.nums)
    if k:   # the disturbance enters behind the delay: Sd = P_d S_d, not P_d z^-k S_d
        undelayed = sampled_plant(plant, fs, 0).B
        nums["Sd"] = poly.pprod(undelayed, fb.S, poly.from_roots([-2.0 * fs] * k)
                                / (2.0 * fs) ** k)
    if w_plane and fs is None:
        raise SpecError("w_plane needs a sample rate (the sampled loop's w-plane)")
    rate = None if w_plane else fs
    out = {"L": _ss_of(poly.pmul(loop_plant.B, fb.R), poly.pmul(loop_plant.A, fb.S), rate)}
    out.update({name: _ss_of(nums[name], cl.Delta, rate) for name in CLOSED_LOOP_NAMES[1:5]})
    full = cl if fb is ctrl else closed_loop(loop_plant, ctrl)
    out["Tr"] = _ss_of(full.nums["Tr"], full.Delta, rate)
    return out
