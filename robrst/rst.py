"""The RST controller ``S u = T yr - R y`` and its closed-loop polynomials."""

from dataclasses import dataclass

import numpy as np

from robrst import poly
from robrst.errors import DegreeError

__all__ = ["RSTController", "closed_loop"]


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
