"""One variant's problem: the base problem document with the variant's values.

Key-path parameters (``specs.Mu_max``, ``family.parametric.gain_per_K``) are set in the base
problem's TOML document, which :func:`robrst.problem.files.parse_problem` validates again, so a value
out of range is the same one-line error as in a problem file.  Plant factors act on the
parsed family: coefficient factors ``A<i>``/``B<i>`` first, then ``gain``, ``resonance`` and
``damping`` (times the ageing law) through the thermal law's relative-change kernel
(:func:`robrst.core.thermal.thermal_polynomials` at one kelvin), on the nominal model of a
parametric family (the per-kelvin laws then generate the temperatures) or on every model of
an explicit family; ``temperature_C`` keeps the single model at that temperature.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from robrst.base.errors import SpecError
from robrst.core.family import PlantFamily, explicit_family, parametric_family
from robrst.core.plant import Plant
from robrst.problem.files import FAMILY_TABLES, parse_problem
from robrst.studies.sweep.files import COEF, PLANT_PARAMS, problem_field
from robrst.core.thermal import modal_form, thermal_polynomials

if TYPE_CHECKING:
    from pathlib import Path

    from robrst.problem.records import Problem
    from robrst.studies.sweep.files import Ageing, Param

__all__ = ["set_key", "apply_overrides", "split_values", "variant_problem", "transform_plant",
           "transform_family", "merge_documents", "check_plant_params"]


def set_key(doc: dict, path: Sequence[str], value: Any) -> None:
    """Set ``doc[a][b][...] = value`` for the key path ``(a, b, ...)`` (tables created).

    Parameters
    ----------
    doc : dict
        The document, changed in place.
    path : sequence of str
        The key path.
    value : object
        The value set.

    Examples
    --------
    >>> from robrst.studies.sweep.model import set_key
    >>> doc = {}
    >>> set_key(doc, ("specs", "Mu_max"), 120.0)
    >>> doc
    {'specs': {'Mu_max': 120.0}}
    """
    node = doc
    for part in path[:-1]:
        node = node.setdefault(part, {})
    node[path[-1]] = value


def apply_overrides(doc: dict, overrides: Iterable[tuple[Sequence[str], Any]]) -> dict:
    """A deep copy of ``doc`` with the ``(key path, value)`` pairs set.

    Parameters
    ----------
    doc : dict
        A problem document (not changed).
    overrides : iterable of (key path, value)
        The pairs to set.

    Returns
    -------
    dict
    """
    out = copy.deepcopy(doc)
    for path, value in overrides:
        set_key(out, path, copy.deepcopy(value))
    return out


def merge_documents(base: dict, doc: dict) -> dict:
    """``base`` with the top-level tables of ``doc`` replacing its own (a fleet member).

    Parameters
    ----------
    base : dict
        The base problem's document (not changed).
    doc : dict
        A fleet member's document.

    Returns
    -------
    dict
        A new document (a member's ``[plant]`` or ``[[family.models]]`` also drops the
        base problem's family tables it would contradict).
    """
    out = copy.deepcopy(base)
    out.update(copy.deepcopy(doc))
    return out


def split_values(values: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """``(key-path values, plant-factor values)`` of one variant's ``{name: value}``.

    Parameters
    ----------
    values : dict
        ``{parameter name: value}`` of one variant.

    Returns
    -------
    keys : dict
        Values of problem-file key paths (``specs.Mu_max``).
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


def transform_plant(plant: Plant, plant_values: dict[str, float], ageing: Ageing) -> Plant:
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
                     ageing: Ageing) -> PlantFamily:
    """The family of a variant (see the module docstring).

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


def check_plant_params(params: Sequence[Param], family: PlantFamily, path: str | Path) -> None:
    """Refuse plant factors the base family cannot take (one line naming the parameter).

    Parameters
    ----------
    params : sequence of Param
        The sweep's parameters.
    family : PlantFamily
        The base problem's family.
    path : str or pathlib.Path
        The sweep file, named in errors.

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


def variant_problem(base: Problem, doc: dict, path: str | Path, values: dict[str, float],
                    ageing: Ageing) -> Problem:
    """The :class:`~robrst.problem.records.Problem` of one variant.

    Parameters
    ----------
    base : Problem
        The base problem (reused when no key-path value changes the document).
    doc : dict
        The base problem's document (``[set]`` applied).
    path : str or pathlib.Path
        The base problem file (named in errors).
    values : dict
        ``{parameter name: value}``.
    ageing : Ageing
        The rates per year of ``age_years``.

    Returns
    -------
    Problem

    Raises
    ------
    SpecError
        A variant the problem file's rules or the plant factors refuse.
    """
    keys, plant = split_values(values)
    problem = base
    if keys:
        d = copy.deepcopy(doc)
        for name, v in keys.items():
            field = problem_field(name)
            set_key(d, tuple(name.split(".")), int(v) if field.type == "int" else float(v))
        problem = parse_problem(d, path)
        if not any(name.split(".")[0] in FAMILY_TABLES for name in keys):
            # the base's family, unchanged: its memo (the models at the certificate's
            # temperatures, their sampled plants) serves every variant of a worker
            problem = replace(problem, family=base.family)
    if plant:
        problem = replace(problem, family=transform_family(problem.family, plant, ageing))
    return problem
