"""The RST controller ``S u = T yr - R y``: polynomials, closed loop, discretisation."""

from dataclasses import dataclass

import numpy as np

from robrst import lti, poly
from robrst.errors import DegreeError, SpecError

__all__ = ["RSTController", "closed_loop", "ClosedLoop", "DiscreteController", "discretize"]


@dataclass(frozen=True, eq=False)
class RSTController:
    """Polynomials R, S, T in s [rad/s], highest power first.

    The control law is ``S(s) u = T(s) yr - R(s) y``; ``u`` [V], ``y``, ``yr`` [µm].
    Causality requires ``deg R <= deg S`` and ``deg T <= deg S``.
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

    def as_dict(self):
        return {k: getattr(self, k).tolist() for k in "RST"}


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """Numerators of the four closed-loop transfer functions over ``Delta``.

    ``S = AS/Delta`` (sensitivity), ``T = BR/Delta`` (complementary sensitivity),
    ``U = AR/Delta`` (input sensitivity, V/µm), ``Sd = BS/Delta`` (input disturbance
    to output, µm/V) and ``Tr = BT/Delta`` (reference to output).
    """

    Delta: np.ndarray
    nums: dict

    def tf(self, name):
        return self.nums[name], self.Delta


def closed_loop(plant, ctrl):
    """Closed-loop polynomials of ``plant`` under ``ctrl``."""
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
    """``xc+ = A xc + B [yr, y]``, ``u = C xc + D [yr, y]`` at ``sample_rate_hz``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    sample_rate_hz: float
    method: str


def discretize(ctrl, sample_rate_hz, method="tustin"):
    """Discretise ``ctrl`` at ``sample_rate_hz`` [Hz] with the bilinear (Tustin) rule.

    ``u = (T yr - R y) / S`` is realised as one two-input state space in the scaled
    time ``tau = w0 t`` (:func:`robrst.lti.companion` of ``1/S``, O(1) coefficients
    whatever the size of R, S, T in s), then mapped by the bilinear transform.

    Returns
    -------
    DiscreteController
    """
    import scipy.signal as sig

    if method != "tustin":
        raise SpecError(f"discretisation method {method!r}: only 'tustin' is provided")
    if not sample_rate_hz > 0:
        raise SpecError(f"sampling rate must be > 0, got {sample_rate_hz}")
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
    Ad, Bd, Cd, Dd, _ = sig.cont2discrete((Ac, Bc, Cc, Dc), sc.w0 / sample_rate_hz,
                                          method="bilinear")
    return DiscreteController(A=Ad, B=Bd, C=Cd, D=Dd, sample_rate_hz=float(sample_rate_hz),
                              method=method)
