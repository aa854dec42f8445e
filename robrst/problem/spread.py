"""Manufacturing spread: the distributions, their seeded draws and the actuators they make.

The one owner of what a sweep file's ``[[param]]`` tables and a problem file's
``[spread]`` table share:

* :class:`Param` — one varied parameter: ``normal`` (mean, std), ``lognormal`` (median,
  sigma of the logarithm), ``uniform`` (lo, hi), the first two optionally truncated to
  ``[lo, hi]`` (drawn exactly, by inverse CDF), or a ``grid`` of values (sweeps only);
* :func:`draw` (inverse CDF) and :func:`draw_rows` — ``n`` rows of draws from one
  ``numpy.random.default_rng(seed)`` matrix of uniform numbers (one column per random
  parameter, in order, drawn in blocks of :data:`DRAW_BLOCK` rows), so draw ``i`` depends
  only on the seed and ``i``;
* the plant factors (:data:`PLANT_PARAMS`: ``gain``, ``resonance``, ``damping``,
  ``age_years``, ``temperature_C``; coefficient factors ``A<i>``, ``B<i>``) and the
  family they make (:func:`transform_plant`, :func:`transform_family`), through the
  thermal law's relative-change kernel (:func:`robrst.core.thermal.thermal_polynomials`
  at one kelvin);
* :func:`actuator_family` — the temperature family of one drawn actuator: its per-kelvin
  laws (``family.parametric.*``) and its plant factors;
* :class:`Spread` — a problem file's ``[spread]``: the parameters, a yield target with
  its confidence, the seed of the scenario draws and the design method (``scenario`` or
  the worst case over a parameter ``box``).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from robrst.base.errors import SpecError
from robrst.base.schema import key_error
from robrst.core.family import PlantFamily, explicit_family, parametric_family
from robrst.core.plant import Plant
from robrst.core.thermal import modal_form, thermal_polynomials

__all__ = ["Param", "Ageing", "Spread", "DISTS", "RANDOM_DISTS", "DIST_KEYS", "PLANT_PARAMS",
           "THERMAL_KEYS", "COEF", "DRAW_BLOCK", "SPREAD_METHODS", "draw", "draw_rows",
           "transform_plant", "transform_family", "actuator_family", "check_plant_params",
           "split_plant_values", "check_truncation", "MIN_TRUNCATED_MASS"]

DISTS = ("normal", "uniform", "lognormal", "grid")
RANDOM_DISTS = DISTS[:3]
SPREAD_METHODS = ("scenario", "box")
# keys each distribution needs / accepts (besides name, dist, note)
DIST_KEYS = {"normal": ({"mean", "std"}, {"lo", "hi"}),
             "uniform": ({"lo", "hi"}, set()),
             "lognormal": ({"median", "sigma"}, {"lo", "hi"}),
             "grid": (set(), {"lo", "hi", "steps", "log", "values"})}
PLANT_PARAMS = {
    "gain": "static-gain factor of the nominal model (1 = nominal)",
    "resonance": "natural-frequency factor of every complex pole pair (1 = nominal)",
    "damping": "damping factor of every complex pole pair (1 = nominal)",
    "age_years": "age [years]: scales gain, resonance and damping by the [ageing] rates",
    "temperature_C": "one temperature [°C]: the variant is the single model there",
}
#: the per-kelvin laws a spread may vary: key path -> field of ThermalCoefficients
THERMAL_KEYS = {f"family.parametric.{k}": k for k in
                ("gain_per_K", "resonance_per_K", "damping_per_K", "creep_per_K",
                 "creep_at_ref")}
COEF = re.compile(r"^([AB])(\d+)$")
DRAW_BLOCK = 1 << 18     # rows of random numbers drawn at a time


@dataclass(frozen=True)
class Param:
    """One varied parameter: a seeded distribution or a grid of values.

    Parameters
    ----------
    name : str
        A problem-file key path (``specs.Mu_max``) or a plant factor (``gain``,
        ``resonance``, ``damping``, ``age_years``, ``temperature_C``, ``A1``, ``B0``, ...).
    dist : {"normal", "uniform", "lognormal", "grid"}
        The distribution.
    mean, std : float, optional
        Normal: mean and standard deviation.
    median, sigma : float, optional
        Lognormal: median and standard deviation of the logarithm.
    lo, hi : float, optional
        Uniform and grid: the ends; normal and lognormal: truncation.
    values : tuple of float, optional
        Grid: the values (or ``lo``, ``hi`` and ``steps`` expanded).
    note : str
        Where the spread comes from.

    Attributes
    ----------
    random : bool
        True for a distribution, False for a grid.
    """

    name: str
    dist: str
    mean: float = None
    std: float = None
    median: float = None
    sigma: float = None
    lo: float = None
    hi: float = None
    values: tuple = None
    note: str = ""

    @property
    def random(self):
        """True for a distribution, False for a grid."""
        return self.dist != "grid"


@dataclass(frozen=True)
class Ageing:
    """Relative change per year of age of the static gain, natural frequency and damping.

    Parameters
    ----------
    gain_per_year : float
        Relative static-gain change per year.
    resonance_per_year : float
        Relative natural-frequency change per year.
    damping_per_year : float
        Relative damping change per year.
    """

    gain_per_year: float = 0.0
    resonance_per_year: float = 0.0
    damping_per_year: float = 0.0


def draw(param: Param, u: np.ndarray) -> np.ndarray:
    """Values of a random ``param`` for uniform numbers ``u`` in [0, 1) (inverse CDF).

    A truncated normal or lognormal is drawn exactly (the CDF is mapped onto ``[lo, hi]``).

    Parameters
    ----------
    param : Param
        A distribution (not a grid).
    u : numpy.ndarray
        Uniform numbers in [0, 1).

    Returns
    -------
    numpy.ndarray
        The parameter's values, shape of ``u``.
    """
    from scipy.special import ndtr, ndtri

    u = np.asarray(u, float)
    if param.dist == "uniform":
        return param.lo + (param.hi - param.lo) * u
    if param.dist == "normal":
        loc, scale, tr = param.mean, param.std, (lambda x: x)
    else:
        loc, scale, tr = np.log(param.median), param.sigma, np.log
    a = 0.0 if param.lo is None else float(ndtr((tr(param.lo) - loc) / scale))
    b = 1.0 if param.hi is None else float(ndtr((tr(param.hi) - loc) / scale))
    x = loc + scale * ndtri(a + (b - a) * u)
    if param.dist == "lognormal":
        x = np.exp(x)
    lo = -np.inf if param.lo is None else param.lo
    hi = np.inf if param.hi is None else param.hi
    return np.clip(x, lo, hi)   # rounding at the truncation points only


def draw_rows(params: Sequence[Param], n: int, seed: int, out: np.ndarray | None = None,
              cols: Sequence[int] | None = None) -> np.ndarray:
    """``n`` draws of the random ``params`` from ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    params : sequence of Param
        Random parameters, in the order of the uniform matrix's columns.
    n : int
        Rows (draws).
    seed : int
    out : ndarray, optional
        ``n`` x ``m`` array written in place (default: a new ``n`` x ``len(params)`` one).
    cols : sequence of int, optional
        The column of ``out`` of each parameter (default ``0, 1, ...``).

    Returns
    -------
    ndarray
        ``out``.  Row ``i`` depends only on ``seed`` and ``i``: the uniform numbers are
        drawn in blocks of :data:`DRAW_BLOCK` rows, the same numbers as one
        ``rng.random((n, len(params)))`` call, with no ``n`` x ``k`` temporaries.
    """
    params = tuple(params)
    out = np.empty((n, len(params))) if out is None else out
    cols = range(len(params)) if cols is None else cols
    rng = np.random.default_rng(seed)
    for start in range(0, n if params else 0, DRAW_BLOCK):
        stop = min(start + DRAW_BLOCK, n)
        u = rng.random((stop - start, len(params)))
        for j, (col, p) in enumerate(zip(cols, params)):
            out[start:stop, col] = draw(p, u[:, j])
    return out


def _param_box(param, sigmas=3.0):
    """``(lo, hi)`` of a random ``param``: its support, cut at ``sigmas`` standard
    deviations (normal) or ``sigmas`` sigmas of the logarithm (lognormal), within its
    truncation."""
    if param.dist == "uniform":
        return float(param.lo), float(param.hi)
    if param.dist == "normal":
        lo, hi = param.mean - sigmas * param.std, param.mean + sigmas * param.std
    else:
        lo, hi = param.median * np.exp(-sigmas * param.sigma), \
            param.median * np.exp(sigmas * param.sigma)
    if param.lo is not None:
        lo = max(lo, param.lo)
    if param.hi is not None:
        hi = min(hi, param.hi)
    return float(lo), float(hi)


def split_plant_values(values: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """``(key-path values, plant-factor values)`` of one variant's ``{name: value}``.

    Parameters
    ----------
    values : dict
        ``{parameter name: value}``.

    Returns
    -------
    keys : dict
        Values of problem-file key paths (``specs.Mu_max``, the per-kelvin laws).
    plant : dict
        Values of plant factors (``gain``, ``resonance``, ``A1``, ``temperature_C``, ...).
    """
    plant = {k: v for k, v in values.items() if k in PLANT_PARAMS or COEF.match(k)}
    keys = {k: v for k, v in values.items() if k not in plant}
    return keys, plant


def _factors(plant_values, ageing):
    age = plant_values.get("age_years", 0.0)
    return (plant_values.get("gain", 1.0) * (1.0 + ageing.gain_per_year * age),
            plant_values.get("resonance", 1.0) * (1.0 + ageing.resonance_per_year * age),
            plant_values.get("damping", 1.0) * (1.0 + ageing.damping_per_year * age))


def transform_plant(plant: Plant, plant_values: dict[str, float],
                    ageing: Ageing = Ageing()) -> Plant:
    """``plant`` with the coefficient, gain, resonance and damping factors of a variant.

    Parameters
    ----------
    plant : Plant
        A model of the base family.
    plant_values : dict
        The variant's plant factors (``gain``, ``resonance``, ``damping``, ``age_years``,
        ``A1``, ``B0``, ...).
    ageing : Ageing
        The rates per year of ``age_years``.

    Returns
    -------
    Plant

    Raises
    ------
    SpecError
        A factor that is not > 0, or a coefficient index the model does not have.
    """
    B, A = plant.B.copy(), plant.A.copy()
    for k, v in plant_values.items():
        m = COEF.match(k)
        if m:
            c = A if m.group(1) == "A" else B
            i = int(m.group(2))
            if i >= len(c):
                raise SpecError(f"parameter {k}: the model has {len(c)} coefficients in"
                                f" {m.group(1)} (indices 0..{len(c) - 1})")
            c[i] *= v
    g, r, z = _factors(plant_values, ageing)
    if not (g > 0 and r > 0 and z > 0):
        raise SpecError(f"plant factors must be > 0: gain {g:.4g}, resonance {r:.4g},"
                        f" damping {z:.4g}")
    out = Plant(B, A, label=plant.label, temperature_C=plant.temperature_C, meta=plant.meta)
    if (g, r, z) != (1.0, 1.0, 1.0):
        Bt, At = thermal_polynomials(modal_form(out), 1.0, g - 1.0, r - 1.0, z - 1.0)
        out = Plant(np.asarray(Bt, float), np.asarray(At, float), label=plant.label,
                    temperature_C=plant.temperature_C, meta=plant.meta)
    return out


def transform_family(family: PlantFamily, plant_values: dict[str, float],
                     ageing: Ageing = Ageing()) -> PlantFamily:
    """The family of a variant (``temperature_C`` keeps the single model at that
    temperature).

    Parameters
    ----------
    family : PlantFamily
        The base problem's family.
    plant_values : dict
        The variant's plant factors (``temperature_C`` picks one model).
    ageing : Ageing
        The rates per year of ``age_years``.

    Returns
    -------
    PlantFamily
        Parametric families: the factors act on the nominal model and the per-kelvin laws
        generate the temperatures; explicit ones: the factors act on every model.
    """
    temps = [m.temperature_C for m in family.models]
    T = plant_values.get("temperature_C")
    if family.thermal is not None:
        nominal = transform_plant(family.nominal, plant_values, ageing)
        return parametric_family(nominal, [T] if T is not None else temps, family.thermal)
    models = [transform_plant(m, plant_values, ageing) for m in family.models]
    if len(models) == 1:
        fam = PlantFamily(models=tuple(models), reference=0)
    else:
        fam = explicit_family(models, family.reference_model.temperature_C)
    return fam if T is None else PlantFamily(models=(fam.at(T),), reference=0)


def actuator_family(family: PlantFamily, values: dict[str, float],
                    ageing: Ageing = Ageing()) -> PlantFamily:
    """The temperature family of one actuator drawn from a spread.

    Parameters
    ----------
    family : PlantFamily
        The nominal actuator's family.
    values : dict
        ``{parameter name: value}``: per-kelvin laws (:data:`THERMAL_KEYS`) and plant
        factors (:data:`PLANT_PARAMS`, ``A<i>``, ``B<i>``).
    ageing : Ageing

    Returns
    -------
    PlantFamily
        The per-kelvin laws replaced first (the family regenerated at the same
        temperatures), then the plant factors (:func:`transform_family`).

    Raises
    ------
    SpecError
        A name that is neither, a per-kelvin law on a family without one, a model the
        factors or the laws make invalid.
    """
    keys, plant = split_plant_values(values)
    laws = {}
    for k, v in keys.items():
        if k not in THERMAL_KEYS:
            raise SpecError(f"spread: parameter {k!r} is neither a per-kelvin law"
                            f" ({', '.join(THERMAL_KEYS)}) nor a plant factor")
        laws[THERMAL_KEYS[k]] = float(v)
    if laws:
        if family.thermal is None:
            raise SpecError("spread: per-kelvin laws need a parametric family")
        family = parametric_family(family.nominal, [m.temperature_C for m in family.models],
                                   replace(family.thermal, **laws))
    return transform_family(family, plant, ageing) if plant else family


def check_plant_params(params: Sequence[Param], family: PlantFamily,
                       path: str | os.PathLike) -> None:
    """Refuse plant factors the base family cannot take (one line naming the parameter).

    Parameters
    ----------
    params : sequence of Param
        The sweep's or spread's parameters.
    family : PlantFamily
        The base problem's family.
    path : str or pathlib.Path
        The sweep or problem file, named in errors.

    Raises
    ------
    SpecError
        ``resonance`` or ``damping`` without a complex pole pair, a per-kelvin law on a
        family without one, a coefficient index out of range, a temperature outside a
        family without a law.
    """
    nominal = family.nominal if family.thermal is not None else family.reference_model
    for p in params:
        name = p.name
        m = COEF.match(name)
        if m:
            c = nominal.A if m.group(1) == "A" else nominal.B
            if int(m.group(2)) >= len(c):
                raise SpecError(f"{path}: parameter {name}: the base model has {len(c)}"
                                f" coefficients in {m.group(1)} (indices 0..{len(c) - 1})")
        if name in ("resonance", "damping") and not modal_form(nominal).pairs:
            raise SpecError(f"{path}: parameter {name}: the base model has no complex pole pair")
        if name.startswith("family.parametric.") and family.thermal is None:
            raise SpecError(f"{path}: parameter {name}: the base problem's family is not"
                            " parametric (it has no per-kelvin laws)")
        if name == "temperature_C" and family.thermal is None:
            lo, hi = family.range_C
            ends = p.values if not p.random else (p.lo, p.hi)
            if any(t is None or not lo <= t <= hi for t in ends):
                raise SpecError(f"{path}: parameter temperature_C: the base family has no"
                                f" per-kelvin law; its temperatures must lie in [{lo:g}, {hi:g}]"
                                " °C (a random temperature needs lo and hi there)")


@dataclass(frozen=True)
class Spread:
    """A problem file's ``[spread]``: the actuators a factory ships, and the yield asked.

    Parameters
    ----------
    params : tuple of Param
        Random parameters (normal, lognormal, uniform; truncation ``lo``/``hi``).
    yield_target : float
        Share of the actuators the controller must certify on (e.g. 0.95).
    confidence : float
        Confidence ``1 - beta`` of the scenario guarantee (e.g. 0.99).
    seed : int
        Seed of the scenario draws (:func:`draw_rows`).
    method : str
        ``"scenario"`` (a design over drawn actuators, with a probabilistic guarantee)
        or ``"box"`` (the worst case over the parameter box: its corners and centre).
    scenarios : int or None
        Number of drawn actuators (default: from the scenario bound).
    box_sigmas : float
        Box half-width of a normal / lognormal parameter, in standard deviations.
    cert_temperatures : int or None
        Temperatures of the certificate on each drawn actuator (default: the solver's).
    ageing : Ageing
    """

    params: tuple
    yield_target: float = 0.95
    confidence: float = 0.99
    seed: int = 0
    method: str = "scenario"
    scenarios: int = None
    box_sigmas: float = 3.0
    cert_temperatures: int = None
    ageing: Ageing = Ageing()

    @property
    def names(self):
        return tuple(p.name for p in self.params)

    def draws(self, n: int, seed: int | None = None) -> np.ndarray:
        """The parameters of ``n`` drawn actuators (:func:`draw_rows`).

        Parameters
        ----------
        n : int
            Actuators.
        seed : int, optional
            Default: the spread's.

        Returns
        -------
        numpy.ndarray
            ``n`` x ``len(params)``.
        """
        return draw_rows(self.params, n, self.seed if seed is None else seed)

    def actuators(self, family: PlantFamily, values: np.ndarray) -> tuple[PlantFamily, ...]:
        """The temperature family of every actuator (:func:`actuator_family`).

        Parameters
        ----------
        family : PlantFamily
            The nominal actuator's.
        values : numpy.ndarray
            One row of parameter values per actuator (columns ``names``).

        Returns
        -------
        tuple of PlantFamily
        """
        return tuple(actuator_family(family, dict(zip(self.names, (float(v) for v in row))),
                                     self.ageing) for row in values)

    def corners(self) -> np.ndarray:
        """The parameter box's centre and corners.

        Returns
        -------
        numpy.ndarray
            ``(2^k + 1)`` x ``k`` values: the centre first, then the corners (parameter
            ``j`` at its upper end when bit ``j`` of the corner's index is set).
        """
        box = [_param_box(p, self.box_sigmas) for p in self.params]
        centre = [0.5 * (lo + hi) if p.dist == "uniform" else
                  (p.mean if p.dist == "normal" else p.median)
                  for p, (lo, hi) in zip(self.params, box)]
        k = len(box)
        grid = np.array([[box[j][(i >> j) & 1] for j in range(k)] for i in range(2 ** k)])
        return np.vstack([np.clip(centre, [b[0] for b in box], [b[1] for b in box]), grid])


MIN_TRUNCATED_MASS = 1e-9   # a truncated normal keeps at least this share of its probability


def check_truncation(path: str, key: tuple, dist: str, p: dict) -> None:
    """Refuse a truncation ``[lo, hi]`` that holds (almost) none of the distribution's
    probability: every draw would land on an end (drawn by the inverse CDF, whose
    resolution is that of ``CDF(hi) - CDF(lo)`` in double precision).

    Parameters
    ----------
    path : str
        The file (named in the error).
    key : tuple of str
        The parameter's table (``("spread", "param", "0")``).
    dist : {"normal", "lognormal"}
        The distribution.
    p : dict
        The table: ``mean, std`` or ``median, sigma``, and ``lo``, ``hi`` (``None``: open).

    Raises
    ------
    SpecError
        Naming the file and the table: the truncation holds less than
        ``MIN_TRUNCATED_MASS`` of the probability.
    """
    from scipy.special import ndtr

    if dist == "normal":
        loc, scale, tr, what = p["mean"], p["std"], (lambda x: x), (
            f"normal (mean {p['mean']:g}, std {p['std']:g})")
    else:
        loc, scale, tr, what = math.log(p["median"]), p["sigma"], math.log, (
            f"lognormal (median {p['median']:g}, sigma {p['sigma']:g})")
    za = -math.inf if p["lo"] is None else (tr(p["lo"]) - loc) / scale
    zb = math.inf if p["hi"] is None else (tr(p["hi"]) - loc) / scale
    drawn = float(ndtr(zb)) - float(ndtr(za))         # what the inverse-CDF draw resolves
    if not drawn > MIN_TRUNCATED_MASS:
        mass = float(ndtr(-za) - ndtr(-zb)) if za > 0 else float(ndtr(zb) - ndtr(za))
        where = (f"lo is {za:.3g} std above" if za > 0 else f"hi is {-zb:.3g} std below")
        if dist == "lognormal":
            where = where.replace("std", "sigma (in log)")
        rng = f"[{'-inf' if p['lo'] is None else format(p['lo'], 'g')}, " \
              f"{'inf' if p['hi'] is None else format(p['hi'], 'g')}]"
        raise key_error(path, key, f"the {what} has probability {mass:.3g} in {rng}"
                        f" ({where} the {'mean' if dist == 'normal' else 'median'}): every"
                        f" draw (variant, actuator) would get the same end value; widen lo, hi"
                        f" or move the"
                        f" {'mean' if dist == 'normal' else 'median'} into them (at least"
                        f" {MIN_TRUNCATED_MASS:g} of the probability)")
