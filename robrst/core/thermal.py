"""The one thermal law of the actuator's linear dynamics.

The paper reports that temperature barely changes the fast dynamics; robrst models the
change with three relative coefficients per kelvin around a reference temperature: the
numerator's gain (the static gain times ``wn^2`` of every resonant pair), the natural
frequency and the damping of every complex pole pair of the nominal model (real poles
stay).  :func:`thermal_polynomials` states that law once,
with plain arithmetic, so the numeric plant family (:mod:`robrst.core.family`) and the
symbolic CasADi twin (:mod:`robrst.twin.model`) are generated from the same definition.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from robrst.base.errors import SpecError
from robrst.core import poly

if TYPE_CHECKING:
    from robrst.core.plant import Plant

__all__ = ["ThermalCoefficients", "ModalForm", "modal_form", "thermal_polynomials",
           "ZETA_NOT_RESONANT", "GAIN_SPAN"]

#: the static-gain factor ``1 + gain_per_K dT`` a law may reach at any of its temperatures
GAIN_SPAN = (1e-6, 1e6)


@dataclass(frozen=True)
class ThermalCoefficients:
    """Relative change per kelvin of each part of the model, around ``reference_C``.

    ``creep_per_K`` is the creep strength ``kappa`` (fractional extra static
    displacement reached with time constant ``creep_tau_s``) gained per kelvin above
    the reference; ``creep_at_ref`` its value at the reference.

    Parameters
    ----------
    reference_C : float
        The temperature of the nominal model [°C].
    gain_per_K : float
        Relative change of the numerator per kelvin.
    resonance_per_K : float
        Relative change of every resonant pair's natural frequency per kelvin.
    damping_per_K : float
        Relative change of every resonant pair's damping per kelvin.
    creep_per_K : float
        Creep strength gained per kelvin above the reference.
    creep_at_ref : float
        Creep strength at the reference temperature.
    creep_tau_s : float
        Time constant of the creep lag-lead [s].
    """

    reference_C: float
    gain_per_K: float = 0.0
    resonance_per_K: float = 0.0
    damping_per_K: float = 0.0
    creep_per_K: float = 0.0
    creep_at_ref: float = 0.0
    creep_tau_s: float = 1.0

    def creep_strength(self, T: float) -> float:
        """The creep strength ``kappa`` at ``T`` [°C]: ``creep_at_ref`` plus ``creep_per_K``
        per kelvin above the reference (none gained below it).

        Parameters
        ----------
        T : float
            Temperature [°C].

        Returns
        -------
        float

        Examples
        --------
        >>> ThermalCoefficients(reference_C=28.0, creep_per_K=0.004).creep_strength(45.0)
        0.068
        """
        return self.creep_at_ref + self.creep_per_K * max(float(T) - self.reference_C, 0.0)

    def check(self, T: float, resonant: bool = True, who: str = "family") -> None:
        """Refuse a law that leaves physics at ``T`` [°C]: a static-gain factor
        ``1 + gain_per_K dT`` outside :data:`GAIN_SPAN`, a resonance or a damping factor
        ``<= 0`` (when the model has a resonant pair), or a negative creep strength.

        The factors are affine in ``T``: checking the ends of a temperature interval
        checks all of it.

        Parameters
        ----------
        T : float
            Temperature [°C].
        resonant : bool
            The nominal model has a resonant pair (else the resonance and damping
            factors act on nothing).
        who : str
            What the error names first (the family, a twin file's table).

        Raises
        ------
        SpecError
            The law at ``T`` is not a physical model.

        Examples
        --------
        >>> ThermalCoefficients(reference_C=28.0, gain_per_K=-0.1).check(45.0)
        Traceback (most recent call last):
        ...
        robrst.base.errors.SpecError: family: gain factor 1 + gain_per_K dT = -0.7 at 45.0 °C; expected within [1e-06, 1e+06]
        """
        dT = float(T) - self.reference_C
        gain = 1.0 + self.gain_per_K * dT
        if not GAIN_SPAN[0] <= gain <= GAIN_SPAN[1]:
            raise SpecError(f"{who}: gain factor 1 + gain_per_K dT = {gain:.3g} at {T} °C;"
                            f" expected within [{GAIN_SPAN[0]:g}, {GAIN_SPAN[1]:g}]")
        if resonant and not (1 + self.resonance_per_K * dT > 0 and 1 + self.damping_per_K * dT > 0):
            raise SpecError(f"{who}: resonance or damping <= 0 at {T} °C")
        kappa = self.creep_strength(T)
        if kappa < 0:
            raise SpecError(f"{who}: creep strength {kappa:.3g} < 0 at {T} °C")


#: a complex pair damped at least this much is no resonance (e.g. a repeated real pole,
#: which ``np.roots`` returns as a pair split by rounding): the thermal law leaves it as it is
ZETA_NOT_RESONANT = 0.999


@dataclass(frozen=True, eq=False)
class ModalForm:
    """A nominal plant ``B/A`` with ``A`` split into real poles and complex pairs.

    Parameters
    ----------
    B : numpy.ndarray
        The numerator, highest power first.
    real_poles : tuple of float
        The real poles [rad/s].
    pairs : tuple of (float, float)
        ``(wn, zeta)`` of every resonant pair: ``s^2 + 2 zeta wn s + wn^2``.
    fixed : tuple of (float, float)
        ``(wn, zeta)`` of pairs damped ``>= ZETA_NOT_RESONANT`` (kept unchanged, like
        the real poles).
    """

    B: np.ndarray
    real_poles: tuple
    pairs: tuple
    fixed: tuple = ()


def modal_form(plant: Plant) -> ModalForm:
    """Factor the denominator of ``plant`` into real poles, resonant ``(wn, zeta)`` pairs
    and (near-)critically damped pairs (see :class:`ModalForm`).

    Parameters
    ----------
    plant : Plant
        The nominal model.

    Returns
    -------
    ModalForm
    """
    roots = np.roots(plant.A)
    real, pairs, fixed, used = [], [], [], set()
    for i, z in enumerate(roots):
        if i in used:
            continue
        if z.imag == 0:
            used.add(i)
            real.append(float(z.real))
            continue
        dist = np.abs(roots - np.conj(z))
        dist[list(used | {i})] = np.inf
        j = int(np.argmin(dist))
        used.update((i, j))
        wn, zeta = float(abs(z)), float(-z.real / abs(z))
        (fixed if zeta >= ZETA_NOT_RESONANT else pairs).append((wn, zeta))
    return ModalForm(B=np.asarray(plant.B, float), real_poles=tuple(real), pairs=tuple(pairs),
                     fixed=tuple(fixed))


def thermal_polynomials(form: ModalForm, dT: Any, gain_per_K: Any, resonance_per_K: Any,
                        damping_per_K: Any) -> tuple[list, list]:
    """Numerator and monic denominator ``dT`` kelvin away from the reference.

    The numerator scales by ``1 + gain_per_K dT``; every resonant pair's natural frequency
    by ``1 + resonance_per_K dT`` and its damping by ``1 + damping_per_K dT`` (real poles
    and pairs damped ``>= ZETA_NOT_RESONANT`` stay).  A pair's static gain ``1/wn^2``
    moves with its frequency: the static gain changes by ``1 + gain_per_K dT`` times
    ``(1 + resonance_per_K dT)^-2`` per resonant pair.

    Parameters
    ----------
    form : ModalForm
        The nominal model's factors.
    dT : float or casadi.SX
        Temperature minus the reference [K].
    gain_per_K, resonance_per_K, damping_per_K : float or casadi.SX
        The relative coefficients per kelvin (floats or CasADi symbols).

    Returns
    -------
    B, A : list
        Coefficients, highest power first.

    Examples
    --------
    >>> from robrst.core.plant import Plant
    >>> from robrst.core.thermal import modal_form, thermal_polynomials
    >>> form = modal_form(Plant([4.0], [1.0, 0.4, 4.0]))       # wn 2, zeta 0.1
    >>> B, A = thermal_polynomials(form, 10.0, 0.01, 0.0, 0.0)  # +10 K, gain +1 %/K
    >>> [round(float(b), 9) for b in B], [round(float(a), 9) for a in A]
    ([4.4], [1.0, 0.4, 4.0])
    """
    A = [1.0]
    for p in form.real_poles:
        A = poly.conv_generic(A, [1.0, -p])
    for wn, zeta in form.fixed:
        A = poly.conv_generic(A, [1.0, 2 * zeta * wn, wn * wn])
    for wn, zeta in form.pairs:
        w = wn * (1 + resonance_per_K * dT)
        z = zeta * (1 + damping_per_K * dT)
        A = poly.conv_generic(A, [1.0, 2 * z * w, w * w])
    g = 1 + gain_per_K * dT
    return [b * g for b in form.B], A
