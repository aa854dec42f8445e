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

from robrst.problem.files import FAMILY_TABLES, parse_problem
from robrst.problem.spread import (check_plant_params, split_plant_values, transform_family,
                                   transform_plant)
from robrst.studies.sweep.files import problem_field

if TYPE_CHECKING:
    from pathlib import Path

    from robrst.problem.records import Problem
    from robrst.studies.sweep.files import Ageing

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
    >>> from robrst.studies.sweep._model import set_key
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
    return split_plant_values(values)


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
