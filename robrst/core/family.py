"""Temperature-indexed plant families.

A family is a tuple of plants at increasing temperatures [°C] plus a rule to build
the model at any temperature in range:

* **parametric** — from a nominal model and per-kelvin coefficients: static gain,
  natural frequency and damping of every complex pole pair of A, and a creep
  (low-frequency lag–lead) factor ``(tau s + 1 + kappa)/(tau s + 1)`` whose
  strength ``kappa`` grows with temperature (the paper: fast dynamics barely change,
  creep grows);
* **explicit** — coefficients given per temperature, interpolated linearly
  coefficient by coefficient between neighbours (A stays monic).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from numbers import Real

import numpy as np

from robrst.core import poly
from robrst.base.errors import SpecError
from robrst.core.plant import Plant, as_plant
from robrst.core.sampled import sampled_plant
from robrst.core.thermal import GAIN_SPAN, ThermalCoefficients, modal_form, thermal_polynomials

__all__ = ["ThermalCoefficients", "PlantFamily", "parametric_family", "explicit_family",
           "GAIN_SPAN"]

MEMO_MAX = 4096           # models kept by a family's memo; beyond, it starts again (memory)


def _thermal_model(nominal, c, T):
    """The model at ``T`` [°C]: the thermal law of :mod:`robrst.core.thermal` plus creep."""
    dT = float(T) - c.reference_C
    if dT == 0.0 and c.creep_at_ref == 0.0:
        return nominal.with_label(f"T{T:g}C", float(T))
    form = modal_form(nominal)
    c.check(T, resonant=bool(form.pairs))
    B, A = (np.asarray(x, float) for x in
            thermal_polynomials(form, dT, c.gain_per_K, c.resonance_per_K, c.damping_per_K))
    kappa = c.creep_strength(T)
    if kappa > 0:
        tau = c.creep_tau_s
        B = poly.pmul(B, [tau, 1.0 + kappa])
        A = poly.pmul(A, [tau, 1.0])
    return Plant(B, A, label=f"T{T:g}C", temperature_C=float(T))


@dataclass(frozen=True, eq=False)
class PlantFamily:
    """Plants indexed by temperature; ``models[i].temperature_C`` increasing.

    Use :meth:`at` for any temperature in range (computed once per temperature: a design
    certifies the same temperatures several times) and :meth:`sampled` for a model's
    sampled-loop plant (once per model).

    Parameters
    ----------
    models : tuple of Plant
        The members, at strictly increasing temperatures.
    reference : int
        Index of the nominal model (where the Diophantine equation is imposed).
    thermal : ThermalCoefficients, optional
        The per-kelvin law of a parametric family (``None``: explicit, interpolated
        coefficient by coefficient between members).
    nominal : Plant, optional
        The model the law starts from (parametric families).

    Attributes
    ----------
    memo : dict
        Models and sampled plants already computed (not compared, not pickled; at most
        ``MEMO_MAX`` entries).
    temperatures : numpy.ndarray
        The members' temperatures [°C].
    reference_model : Plant
        ``models[reference]``.
    range_C : tuple of float
        ``(lowest, highest)`` temperature [°C].

    Raises
    ------
    SpecError
        No models, a model without temperature, or temperatures that do not increase.
    """

    models: tuple
    reference: int = 0
    thermal: ThermalCoefficients = None
    nominal: Plant = None
    memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __getstate__(self):          # a pickled family (a sweep's context) leaves its memo
        return {k: v for k, v in self.__dict__.items() if k != "memo"}

    def __setstate__(self, state):
        self.__dict__.update(state, memo={})

    def __post_init__(self):
        object.__setattr__(self, "models", tuple(as_plant(m, "family model")
                                                 for m in self.models))
        temps = [m.temperature_C for m in self.models]
        if not self.models or any(t is None for t in temps):
            raise SpecError("family: every model needs a temperature_C")
        if np.any(np.diff(temps) <= 0):
            raise SpecError(f"family: temperatures must increase strictly, got {temps}")

    @property
    def temperatures(self):
        return np.array([m.temperature_C for m in self.models])

    @property
    def reference_model(self):
        return self.models[self.reference]

    @property
    def range_C(self):
        return float(self.temperatures[0]), float(self.temperatures[-1])

    def at(self, T: float) -> Plant:
        """The model at temperature ``T`` [°C] (within the family's range).

        Parameters
        ----------
        T : float
            Temperature [°C]; a real number is memoised, anything else (a CasADi symbol)
            computed each time.

        Returns
        -------
        Plant
            Labelled ``"T<T>C"``.
        """
        if not isinstance(T, Real):
            return self._at(T)
        key = ("at", T)
        if key not in self.memo:
            self._room()
            self.memo[key] = self._at(T)
        return self.memo[key]

    def sampled(self, plant: Plant, sample_rate_hz: float, delay_samples: int = 0) -> Plant:
        """:func:`robrst.core.sampled.sampled_plant` of ``plant`` (a model of this family: a member
        or one from :meth:`at`), computed once per plant object.

        Parameters
        ----------
        plant : Plant
            A model of this family.
        sample_rate_hz : float
            Sampling rate [Hz].
        delay_samples : int
            Whole samples of computation delay.

        Returns
        -------
        Plant
            The plant ``P_w(s)`` of the exact sampled loop.
        """
        key = ("sampled", id(plant), sample_rate_hz, delay_samples)
        try:
            hit = self.memo.get(key)
        except TypeError:          # unhashable arguments: sampled_plant judges them
            return sampled_plant(plant, sample_rate_hz, delay_samples)
        if hit is None or hit[0] is not plant:
            self._room()
            hit = self.memo[key] = (plant, sampled_plant(plant, sample_rate_hz, delay_samples))
        return hit[1]

    def _room(self):
        """Make room for one more memo entry (empty the memo when it is full)."""
        if len(self.memo) >= MEMO_MAX:
            self.memo.clear()

    def _at(self, T):
        lo, hi = self.range_C
        if not lo - 1e-9 <= T <= hi + 1e-9:
            raise SpecError(f"family: temperature {T} °C outside the range [{lo}, {hi}] °C")
        if self.thermal is not None:
            return _thermal_model(self.nominal, self.thermal, T)
        temps = self.temperatures
        i = int(np.clip(np.searchsorted(temps, T) - 1, 0, len(temps) - 2)) if len(temps) > 1 else 0
        if len(temps) == 1 or T == temps[i]:
            return self.models[i].with_label(f"T{T:g}C", float(T))
        a, b = self.models[i], self.models[i + 1]
        if a.n != b.n or a.m != b.m:
            raise SpecError(
                f"family: cannot interpolate between {a.temperature_C} and {b.temperature_C} °C:"
                " models of different degrees"
            )
        lam = (T - temps[i]) / (temps[i + 1] - temps[i])
        return Plant((1 - lam) * a.B + lam * b.B, (1 - lam) * a.A + lam * b.A,
                     label=f"T{T:g}C", temperature_C=float(T))

    def sweep(self, n: int) -> list[Plant]:
        """``n`` models evenly spaced in temperature over the whole range.

        Parameters
        ----------
        n : int
            Number of temperatures (the range's ends included).

        Returns
        -------
        list of Plant
        """
        return [self.at(T) for T in np.linspace(*self.range_C, n)]


def parametric_family(nominal: Plant, temperatures: Iterable[float],
                      coeffs: ThermalCoefficients) -> PlantFamily:
    """Family generated from ``nominal`` (valid at ``coeffs.reference_C``).

    Parameters
    ----------
    nominal : Plant
        The model at the reference temperature.
    temperatures : iterable of float
        The members' temperatures [°C] (sorted here).
    coeffs : ThermalCoefficients
        The per-kelvin law and the creep.

    Returns
    -------
    PlantFamily
        Its reference is the member nearest ``coeffs.reference_C``.

    Raises
    ------
    SpecError
        When the law leaves its domain at a member's temperature (gain factor outside
        ``GAIN_SPAN``, resonance or damping <= 0, negative creep).

    Examples
    --------
    >>> from robrst.core.family import ThermalCoefficients, parametric_family
    >>> from robrst.core.plant import paper_plant
    >>> fam = parametric_family(paper_plant(), [28.0, 45.0],
    ...                         ThermalCoefficients(reference_C=28.0, gain_per_K=0.0015))
    >>> round(float(fam.at(45.0).dc_gain / fam.at(28.0).dc_gain), 4)     # 1 + 17 K x 0.15 %
    1.0255
    """
    temps = sorted(float(t) for t in temperatures)
    nominal = as_plant(nominal, "nominal")
    models = tuple(_thermal_model(nominal, coeffs, T) for T in temps)
    ref = int(np.argmin(np.abs(np.array(temps) - coeffs.reference_C)))
    return PlantFamily(models=models, reference=ref, thermal=coeffs, nominal=nominal)


def explicit_family(models: Iterable[Plant], reference_C: float) -> PlantFamily:
    """Family from explicit models; the reference is the one closest to ``reference_C``.

    Parameters
    ----------
    models : iterable of Plant (or python-control systems with a temperature)
        Models with their temperatures (sorted here); between two of them the family
        interpolates coefficient by coefficient.
    reference_C : float
        Temperature of the nominal model [°C].

    Returns
    -------
    PlantFamily
    """
    models = tuple(sorted((as_plant(m, "family model") for m in models),
                          key=lambda m: m.temperature_C))
    temps = np.array([m.temperature_C for m in models])
    return PlantFamily(models=models, reference=int(np.argmin(np.abs(temps - reference_C))))
