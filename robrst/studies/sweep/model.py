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

import copy
from dataclasses import replace

from robrst.problem.files import FAMILY_TABLES, parse_problem
from robrst.problem.spread import (check_plant_params, split_plant_values, transform_family,
                                   transform_plant)
from robrst.studies.sweep.files import problem_field

__all__ = ["set_key", "apply_overrides", "split_values", "variant_problem", "transform_plant",
           "transform_family", "merge_documents", "check_plant_params"]


def set_key(doc, path, value):
    """Set ``doc[a][b]... = value`` for the key path ``(a, b, ...)`` (tables created)."""
    node = doc
    for part in path[:-1]:
        node = node.setdefault(part, {})
    node[path[-1]] = value


def apply_overrides(doc, overrides):
    """A deep copy of ``doc`` with the ``(key path, value)`` pairs set."""
    out = copy.deepcopy(doc)
    for path, value in overrides:
        set_key(out, path, copy.deepcopy(value))
    return out


def merge_documents(base, doc):
    """``base`` with the top-level tables of ``doc`` replacing its own (a fleet member)."""
    out = copy.deepcopy(base)
    out.update(copy.deepcopy(doc))
    return out


def split_values(values):
    """``(key-path values, plant-factor values)`` of one variant's ``{name: value}``."""
    return split_plant_values(values)


def variant_problem(base, doc, path, values, ageing):
    """The :class:`~robrst.problem.records.Problem` of one variant.

    Parameters
    ----------
    base : Problem
        The base problem (reused when no key-path value changes the document).
    doc : dict
        The base problem's document (``[set]`` applied).
    path : str
        The base problem file (named in errors).
    values : dict
        ``{parameter name: value}``.
    ageing : Ageing

    Returns
    -------
    Problem
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
