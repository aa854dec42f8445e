"""The one thermal law of the actuator's linear dynamics.

The paper reports that temperature barely changes the fast dynamics; robrst models the
change with three relative coefficients per kelvin around a reference temperature: the
static gain, the natural frequency and the damping of every complex pole pair of the
nominal model (real poles stay).  :func:`thermal_polynomials` states that law once,
with plain arithmetic, so the numeric plant family (:mod:`robrst.family`) and the
symbolic CasADi twin (:mod:`robrst.twin.model`) are generated from the same definition.
"""

from dataclasses import dataclass

import numpy as np

from robrst import poly

__all__ = ["ThermalCoefficients", "ModalForm", "modal_form", "thermal_polynomials"]


@dataclass(frozen=True)
class ThermalCoefficients:
    """Relative change per kelvin of each part of the model, around ``reference_C``.

    ``creep_per_K`` is the creep strength ``kappa`` (fractional extra static
    displacement reached with time constant ``creep_tau_s``) gained per kelvin above
    the reference; ``creep_at_ref`` its value at the reference.
    """

    reference_C: float
    gain_per_K: float = 0.0
    resonance_per_K: float = 0.0
    damping_per_K: float = 0.0
    creep_per_K: float = 0.0
    creep_at_ref: float = 0.0
    creep_tau_s: float = 1.0


@dataclass(frozen=True, eq=False)
class ModalForm:
    """A nominal plant ``B/A`` with ``A`` split into real poles and complex pairs.

    ``pairs`` holds ``(wn, zeta)`` of every complex pair: ``s^2 + 2 zeta wn s + wn^2``.
    """

    B: np.ndarray
    real_poles: tuple
    pairs: tuple


def modal_form(plant):
    """Factor the denominator of ``plant`` into real poles and ``(wn, zeta)`` pairs."""
    roots = np.roots(plant.A)
    real, pairs, used = [], [], set()
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
        pairs.append((float(abs(z)), float(-z.real / abs(z))))
    return ModalForm(B=np.asarray(plant.B, float), real_poles=tuple(real), pairs=tuple(pairs))


def thermal_polynomials(form, dT, gain_per_K, resonance_per_K, damping_per_K):
    """Numerator and monic denominator ``dT`` kelvin away from the reference.

    Static gain scales by ``1 + gain_per_K dT``; every pair's natural frequency by
    ``1 + resonance_per_K dT`` and its damping by ``1 + damping_per_K dT``.  The
    arguments may be floats or CasADi symbols.

    Returns
    -------
    B, A : list
        Coefficients, highest power first.
    """
    A = [1.0]
    for p in form.real_poles:
        A = poly.conv_generic(A, [1.0, -p])
    for wn, zeta in form.pairs:
        w = wn * (1 + resonance_per_K * dT)
        z = zeta * (1 + damping_per_K * dT)
        A = poly.conv_generic(A, [1.0, 2 * z * w, w * w])
    g = 1 + gain_per_K * dT
    return [b * g for b in form.B], A
