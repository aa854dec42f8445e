"""A :class:`~robrst.problem.records.Problem` as a problem document (the parsed TOML).

:func:`problem_document` is the inverse of :func:`robrst.problem.files.parse_problem`:
``parse_problem(problem_document(p))`` is ``p`` again (the same plant coefficients, bit for
bit: floats travel as their shortest round-trip text), whether ``p`` came from a file or
was built in Python.  A saved design carries it (``robrst design --json``'s ``artefact``),
so the problem can be rebuilt without the file it came from.
"""

from dataclasses import fields

import numpy as np

from robrst.base.errors import SpecError
from robrst.problem.records import ControllerStructure, Problem, SolverOptions, Specs

__all__ = ["problem_document", "check_problem"]


def _value(v):
    """A record value as TOML-able data (tuples as lists, numpy scalars as Python's)."""
    if isinstance(v, (tuple, list, np.ndarray)):
        return [_value(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _table(record, cls):
    """The fields of ``record`` that are set (``None`` is a key's absence)."""
    return {f.name: _value(getattr(record, f.name)) for f in fields(cls)
            if getattr(record, f.name) is not None}


def _specs(sp):
    """The ``[specs]`` table as the user stated it: defaults left out (they apply again when
    read), a default switched off written ``false``."""
    out = {k: v for k, v in _table(sp, Specs).items()
           if k not in ("off", "defaults", "resolved") and k not in sp.defaults}
    for k in sp.off:
        if k != "damping_min":
            out[k] = False
    return out


def _plant(plant):
    return {"B": [float(c) for c in plant.B], "A": [float(c) for c in plant.A]}


def _reals(name, values):
    out = []
    for v in values:
        c = complex(v)
        if c.imag != 0.0:
            raise SpecError(f"problem document: [poles] {name} must be real roots, got {v}")
        out.append(c.real)
    return out


def _poles(p):
    out = {}
    if p.wn is not None:
        out["wn"] = float(p.wn)
    if p.zeta is not None:
        out["zeta"] = float(p.zeta)
    if p.dominant_real:
        out["dominant_real"] = [float(x) for x in p.dominant_real]
    if p.dominant_roots is not None:
        roots = [complex(r) for r in p.dominant_roots]
        out["dominant_roots_re"] = [r.real for r in roots]
        out["dominant_roots_im"] = [r.imag for r in roots]
    out["aux_factor"] = float(p.aux_factor)
    if p.aux_roots is not None:
        out["aux_roots"] = _reals("aux_roots", p.aux_roots)
    return out


def problem_document(problem: Problem) -> dict:
    """The problem document of ``problem`` (what its problem file would parse to).

    Parameters
    ----------
    problem : Problem
        From a file or built in Python.

    Returns
    -------
    dict
        Tables ``problem``, ``plant`` and/or ``family``, ``poles``, ``controller``,
        ``specs``, ``solver``; keys as in the problem-file reference, unset values left out.
        A parametric family is its nominal plant, temperatures and per-kelvin law; an
        explicit one its models; a built-in plant keeps its name.

    Raises
    ------
    SpecError
        A problem no problem file can state (complex auxiliary roots).

    Examples
    --------
    >>> from robrst import load_problem
    >>> from robrst.problem.files import parse_problem
    >>> p = load_problem("paper_robust")
    >>> doc = problem_document(p)
    >>> problem_document(parse_problem(doc)) == doc
    True
    """
    fam = problem.family
    doc = {"problem": {"name": problem.name}}
    if problem.description:
        doc["problem"]["description"] = problem.description
    ref = fam.reference_model
    if fam.thermal is not None:
        nominal = fam.nominal
        plant = ({"name": problem.plant_name} if problem.plant_name else _plant(nominal))
        plant["temperature_C"] = float(nominal.temperature_C if nominal.temperature_C is not None
                                       else fam.thermal.reference_C)
        c = fam.thermal
        doc["plant"] = plant
        doc["family"] = {"reference_C": float(c.reference_C),
                         "temperatures_C": [float(T) for T in fam.temperatures],
                         "parametric": {k: float(getattr(c, k)) for k in (
                             "gain_per_K", "resonance_per_K", "damping_per_K", "creep_per_K",
                             "creep_at_ref", "creep_tau_s")}}
    elif len(fam.models) > 1:
        doc["family"] = {"reference_C": float(ref.temperature_C),
                         "models": [{"temperature_C": float(m.temperature_C), **_plant(m)}
                                    for m in fam.models]}
    else:
        plant = {"name": problem.plant_name} if problem.plant_name else _plant(ref)
        plant["temperature_C"] = float(ref.temperature_C)
        doc["plant"] = plant
    doc["poles"] = _poles(problem.poles)
    doc["controller"] = _table(problem.controller, ControllerStructure)
    doc["specs"] = _specs(problem.specs)
    # who chose the method is no key of the file: the document names the method that ran
    doc["solver"] = {k: v for k, v in _table(problem.solver, SolverOptions).items()
                     if k != "method_source"}
    return doc


def check_problem(problem: Problem) -> None:
    """Refuse a problem built or changed in Python that its problem file could not state:
    every value is checked by the file's own validation (the round trip
    ``parse_problem(problem_document(problem))``), so a Python user gets the file's errors,
    naming the table and key (``Specs(Ms_max=nan)`` would otherwise bound nothing).

    A problem no file can state (a plant without a temperature, complex auxiliary roots)
    is not checked this way; its records are used as they are.  The plant family is not
    judged by the file's format limits (coefficients within 1e+-100): it was checked when
    its objects were built.

    Parameters
    ----------
    problem : Problem

    Raises
    ------
    SpecError
        ``<python>: [table.key] expected ...``, as the problem file's error (a problem
        read from a file and changed since: ``FILE (changed in Python): [table.key] ...``).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from robrst import load_problem
    >>> p = load_problem("paper")
    >>> check_problem(p)
    >>> check_problem(replace(p, path="<python>", specs=replace(p.specs, Ms_max=0.5)))
    Traceback (most recent call last):
    ...
    robrst.base.errors.SpecError: <python>: [specs.Ms_max] expected number >= 1, got 0.5
    """
    from robrst.base.schema import validate
    from robrst.problem.files import SCHEMA, parse_problem

    try:
        doc = problem_document(problem)
    except (SpecError, TypeError, ValueError, AttributeError):
        return
    where = problem.path if str(problem.path).startswith("<") else \
        f"{problem.path} (changed in Python)"
    try:
        parse_problem(doc, where, compare=False)
    except SpecError as exc:
        # the plant family came in as objects, checked when they were built; the file's
        # format limits (coefficients within 1e+-100, expanded polynomials) are not theirs:
        # the other tables are still checked, value by value
        if not str(exc).startswith(tuple(f"{where}: [{t}" for t in _FAMILY_TABLES)):
            raise
        validate(where, {k: v for k, v in doc.items() if k not in _FAMILY_TABLES},
                 {k: v for k, v in SCHEMA.items() if k not in _FAMILY_TABLES})


_FAMILY_TABLES = ("plant", "family", "model")
