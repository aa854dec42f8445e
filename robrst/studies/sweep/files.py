"""Sweep files (TOML) -> a validated, frozen :class:`Sweep`.

A sweep file names a base problem file and one kind of sweep:

* ``analysis`` — one fixed controller (the base problem's design, or a result file written
  by ``robrst design --json``) certified on every plant variant;
* ``design`` — one design per variant (e.g. a grid of spec bounds: the trade-off front);
* ``fleet`` — one design per problem or model file in a folder.

Variants are described by ``[[param]]`` tables: a distribution (``normal``, ``uniform``,
``lognormal``, seeded) or a ``grid``.  A parameter is either a number of the problem file,
named by its key path (``specs.Mu_max``, ``family.parametric.gain_per_K``), or one of the
plant factors of :data:`PLANT_PARAMS` (manufacturing spread, ageing, temperature) and the
coefficient factors ``A1``, ``B0``, ...  Every key is declared in :data:`SWEEP_SCHEMA`
(validated by :mod:`robrst.base.schema`, like problem files): errors name the file and the key.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from robrst.base import resources
from robrst.base.errors import SpecError
from robrst.base.schema import ArrayOf, Field, key_error, load_toml, markdown_rows, validate
from robrst.problem.files import SCHEMA as PROBLEM_SCHEMA
from robrst.problem.mimo_files import MIMO_SCHEMA, is_mimo_file
from robrst.problem.spread import (COEF, DIST_KEYS, DISTS, PLANT_PARAMS, Ageing, Param,
                                   check_truncation)
from robrst.studies.sweep._mimo import MIMO_FRONT_FIGURES, MIMO_PLANT_PARAMS, is_mimo_plant_param
from robrst.studies.sweep._variants import grid_values

__all__ = ["Param", "Ageing", "Sweep", "SWEEP_SCHEMA", "PLANT_PARAMS", "KINDS", "DISTS",
           "FIGURES", "problem_field", "load_sweep", "parse_sweep", "resolve_sweep_path",
           "sweep_schema_markdown"]

KINDS = ("analysis", "design", "fleet")
FIGURES = ("Ms", "Mt", "Mu", "Mt_band", "modulus_margin", "gain_margin", "phase_margin_deg",
           "delay_margin_s", "integral_gain", "worst_ratio")
MAX_VARIANTS = 10_000_000
_FRONT = tuple(dict.fromkeys(FIGURES + MIMO_FRONT_FIGURES))

SWEEP_SCHEMA = {
    "sweep": {
        "name": Field("str", None, "sweep name (default: file stem)"),
        "description": Field("str", "", "free text"),
        "kind": Field("str", None, "analysis | design | fleet", required=True, choices=KINDS),
        "problem": Field("str", None, "base problem: a built-in name, or a path relative to"
                         " the sweep file (fleet: optional)"),
        "seed": Field("int", 0, "seed of the random draws (numpy.random.default_rng)", lo=0),
        "n": Field("int", None, "random draws, repeated at every grid point (default 1)",
                   lo=1, hi=MAX_VARIANTS),
        "chunk_size": Field("int", None, "variants per task (default: analysis 10, design 2,"
                            " fleet 1)", lo=1, hi=100_000),
        "worst": Field("int", 10, "worst variants listed in summary.json", lo=0, hi=1000),
    },
    "analysis": {
        "controller": Field("str", "design", "'design' (the base problem's design) or a result"
                            " JSON file of robrst design --json, relative to the sweep file"),
        "margins": Field("bool", True, "gain, phase and delay margins at the family's"
                         " temperatures (about 3 ms each)"),
    },
    "design": {
        "front_x": Field("str", None, "figure minimised on the trade-off front (default Mu;"
                         " multi-axis: sigma_U)", choices=_FRONT),
        "front_y": Field("str", None, "figure maximised on the trade-off front (default"
                         " integral_gain)", choices=_FRONT),
    },
    "fleet": {
        "folder": Field("str", None, "folder of problem or model files, relative to the sweep"
                        " file; their tables replace the base problem's", required=True),
        "pattern": Field("str", "*.toml", "file-name pattern"),
    },
    "ageing": {
        "gain_per_year": Field("number", 0.0, "relative static-gain change per year of age"),
        "resonance_per_year": Field("number", 0.0, "relative natural-frequency change per year"),
        "damping_per_year": Field("number", 0.0, "relative damping change per year"),
    },
    "param": ArrayOf({
        "name": Field("str", None, "a problem-file key path (specs.Mu_max) or a plant factor"
                      " (gain, resonance, damping, age_years, temperature_C, A1, B0, ...)",
                      required=True),
        "dist": Field("str", None, "normal | uniform | lognormal | grid", required=True,
                      choices=DISTS),
        "mean": Field("number", None, "normal: mean"),
        "std": Field("number", None, "normal: standard deviation", positive=True),
        "median": Field("number", None, "lognormal: median", positive=True),
        "sigma": Field("number", None, "lognormal: standard deviation of the logarithm",
                       positive=True),
        "lo": Field("number", None, "uniform, grid: lower end; normal, lognormal: truncation"),
        "hi": Field("number", None, "uniform, grid: upper end; normal, lognormal: truncation"),
        "steps": Field("int", None, "grid: this many values from lo to hi", lo=1, hi=100_000),
        "log": Field("bool", False, "grid: logarithmic spacing"),
        "values": Field("numbers", None, "grid: explicit values"),
        "note": Field("str", "", "where the spread comes from"),
    }, doc="one varied parameter", max_items=64),
}
_DIST_KEYS = DIST_KEYS


@dataclass(frozen=True, eq=False)
class Sweep:
    """A validated sweep file (every key is in the sweep-file reference).

    Parameters
    ----------
    name : str
        The sweep's name (default the file stem).
    kind : {"analysis", "design", "fleet"}
        What a variant is.
    path : str
        The sweep file.
    problem : str, optional
        The resolved base problem file (``None`` for a fleet of complete problem files).
    description : str
        Free text.
    seed : int
        Seed of the random draws.
    n : int, optional
        Random draws, repeated at every grid point.
    chunk_size : int
        Variants per task.
    worst : int
        Worst variants listed in ``summary.json``.
    params : tuple of Param
        The varied parameters, in file order.
    overrides : tuple
        ``(key path, value)`` pairs of ``[set]``, applied to the base problem document
        before the variants.
    ageing : Ageing
        The rates per year of ``age_years``.
    controller : str
        Analysis: ``"design"`` (the base problem's) or a result JSON file.
    margins : bool
        Analysis: compute gain, phase and delay margins.
    front : tuple of str
        Design: the figures ``(x minimised, y maximised)`` of the trade-off front.
    folder : str, optional
        Fleet: the folder of problem or model files.
    pattern : str
        Fleet: the file-name pattern.
    mimo : bool
        The base problem is a multi-axis file (``[mimo]``,
        :mod:`robrst.studies.sweep._mimo`).

    Attributes
    ----------
    grid : tuple of Param
        The grid parameters (cartesian product).
    draws : int
        Random draws per grid point (``n`` or 1).
    """

    name: str
    kind: str
    path: str
    problem: str = None
    description: str = ""
    seed: int = 0
    n: int = None
    chunk_size: int = 25
    worst: int = 10
    params: tuple = ()
    overrides: tuple = ()
    ageing: Ageing = Ageing()
    controller: str = "design"
    margins: bool = True
    front: tuple = ("Mu", "integral_gain")
    folder: str = None
    pattern: str = "*.toml"
    mimo: bool = False

    @property
    def grid(self):
        """The grid parameters (cartesian product)."""
        return tuple(p for p in self.params if not p.random)

    @property
    def draws(self):
        """Random draws per grid point."""
        return self.n or 1


def sweep_schema_markdown() -> list[str]:
    """The sweep-file reference as Markdown table rows (rendered in the documentation).

    Returns
    -------
    list of str
        The rows of :data:`SWEEP_SCHEMA` and one for ``set.*``.
    """
    return markdown_rows(SWEEP_SCHEMA) + [
        "| `set.*` | any problem-file key | as in the problem file | no | – | set in the base"
        " problem before the variants (`[set.solver] cert_temperatures = 12`); checked like a"
        " problem file |"]


def problem_field(name: str, schema: dict = PROBLEM_SCHEMA) -> Field | None:
    """The problem-file :class:`Field` a key path names, or ``None``.

    Parameters
    ----------
    name : str
        A key path (``"specs.Mu_max"``).
    schema : dict
        The problem files' schema (multi-axis files: ``MIMO_SCHEMA``).

    Returns
    -------
    Field or None
        The field when the path names a number or integer of the problem file.
    """
    node = schema
    for part in name.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node if isinstance(node, Field) and node.type in ("number", "int") else None


def _param(path, i, p, mimo=False):
    key = ("param", str(i))
    name, dist = p["name"], p["dist"]
    if mimo:
        field = problem_field(name, MIMO_SCHEMA)
        if field is None and not is_mimo_plant_param(name):
            raise key_error(path, key + ("name",), f"unknown parameter {name!r} of a"
                            " multi-axis sweep: expected a number of the problem file by its"
                            " key path (e.g. mimo.specs.sigma_S_max) or one of "
                            + ", ".join(MIMO_PLANT_PARAMS))
        m = None
    else:
        field = problem_field(name)
        m = COEF.match(name)
    if field is None and not mimo and name not in PLANT_PARAMS and not m:
        raise key_error(path, key + ("name",), f"unknown parameter {name!r}: expected a number"
                        " of the problem file by its key path (e.g. specs.Mu_max,"
                        " family.parametric.gain_per_K) or one of "
                        + ", ".join(PLANT_PARAMS) + ", A<i>, B<i>")
    if m and m.group(1) == "A" and int(m.group(2)) == 0:
        raise key_error(path, key + ("name",), "A0 is the leading coefficient of the monic A")
    given = {k for k in ("mean", "std", "median", "sigma", "lo", "hi", "steps", "values")
             if p[k] is not None} | ({"log"} if p["log"] else set())
    need, allowed = _DIST_KEYS[dist]
    for k in sorted(need - given):
        raise key_error(path, key + (k,), f"missing: dist = '{dist}' needs "
                        + " and ".join(sorted(need)))
    for k in sorted(given - need - allowed):
        raise key_error(path, key + (k,), f"not used by dist = '{dist}'")
    lo, hi = p["lo"], p["hi"]
    if lo is not None and hi is not None and not lo < hi:
        raise key_error(path, key, f"expected lo < hi, got lo = {lo:g}, hi = {hi:g}")
    values = None
    if dist == "grid":
        values = grid_values(path, key, p)
        if field is not None and field.type == "int" and any(v != round(v) for v in values):
            raise key_error(path, key + ("values",), f"{name} takes integers")
        if field is not None:   # every grid value must be valid in the problem file
            for v in values:
                validate(path, {"values": v if field.type == "number" else int(v)},
                         {"values": field}, key)
    elif field is not None and field.type == "int":
        raise key_error(path, key + ("dist",), f"{name} is an integer: use dist = 'grid'")
    if dist == "lognormal" and lo is not None and not lo > 0:
        raise key_error(path, key + ("lo",), "lognormal truncation needs lo > 0")
    if dist in ("normal", "lognormal") and (lo is not None or hi is not None):
        check_truncation(path, key, dist, p)
    return Param(name=name, dist=dist, mean=p["mean"], std=p["std"], median=p["median"],
                 sigma=p["sigma"], lo=lo, hi=hi, values=values, note=p["note"])


def _overrides(path, data, schema, key=("set",)):
    """Check a partial problem document (``[set]``) key by key; return (key path, value) pairs."""
    if not isinstance(data, dict):
        raise key_error(path, key, f"expected a table, got {data!r}")
    out = []
    for k, v in data.items():
        if k not in schema:
            validate(path, {k: v}, schema, key)   # raises "unknown key; did you mean ..."
        spec = schema[k]
        if isinstance(spec, dict):
            out += _overrides(path, v, spec, key + (k,))
        else:
            value = validate(path, {k: v}, {k: spec}, key)[k]
            if isinstance(spec, ArrayOf):
                value = [dict(d) for d in v]   # the raw tables: parse_problem validates again
            elif isinstance(value, tuple):
                value = list(value)
            out.append((key[1:] + (k,), value))
    return out


def _resolve_base(path, name, key=("sweep", "problem")):
    from robrst.problem.files import resolve_problem_path

    local = Path(path).parent / name
    if local.is_file():
        return str(local)
    try:
        return str(resolve_problem_path(name))
    except SpecError as exc:
        raise key_error(path, key, str(exc)) from None


def parse_sweep(data: dict, path: str | Path = "<sweep>") -> Sweep:
    """Validate a parsed sweep document and build the :class:`Sweep`.

    Parameters
    ----------
    data : dict
        The parsed TOML document.
    path : str or pathlib.Path
        The file, named in errors; relative paths in the document are relative to it.

    Returns
    -------
    Sweep

    Raises
    ------
    SpecError
        Naming the file and the key path of the first problem found.

    Examples
    --------
    >>> from robrst.studies.sweep import parse_sweep
    >>> sw = parse_sweep({"sweep": {"kind": "analysis", "problem": "paper", "n": 10},
    ...                   "param": [{"name": "gain", "dist": "uniform", "lo": 0.9, "hi": 1.1}]})
    >>> sw.kind, sw.draws, sw.params[0].random
    ('analysis', 10, True)
    """
    data = dict(data)
    raw_set = data.pop("set", {})
    v = validate(path, data, SWEEP_SCHEMA)
    sw = v["sweep"]
    if sw is None:
        raise key_error(path, ("sweep",), "missing required table [sweep]")
    kind = sw["kind"]
    for tab in ("analysis", "design", "fleet"):
        if v[tab] is not None and tab != kind:
            raise key_error(path, (tab,), f"only for kind = '{tab}' (this sweep is '{kind}')")
    if kind != "fleet" and sw["problem"] is None:
        raise key_error(path, ("sweep", "problem"), f"missing: a {kind} sweep needs a base problem")
    base = None if sw["problem"] is None else _resolve_base(path, sw["problem"])
    mimo = base is not None and is_mimo_file(base)
    if mimo and kind == "fleet":
        raise key_error(path, ("sweep", "kind"), "a fleet of multi-axis problems is not"
                        " supported: sweep their parameters (kind = 'design' or 'analysis')")
    overrides = _overrides(path, raw_set, MIMO_SCHEMA if mimo else PROBLEM_SCHEMA)
    params = tuple(_param(path, i, p, mimo) for i, p in enumerate(v["param"] or ()))
    names = [p.name for p in params]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise key_error(path, ("param", str(i), "name"), f"parameter {n!r} given twice")
    ageing = Ageing(**(v["ageing"] or {}))
    if "age_years" in names and ageing == Ageing():
        raise key_error(path, ("param", str(names.index("age_years")), "name"), "age_years acts"
                        " through the [ageing] rates per year (gain_per_year, resonance_per_year,"
                        " damping_per_year): give them, else it changes nothing")
    if kind == "fleet" and v["fleet"] is None:
        raise key_error(path, ("fleet",), "missing: a fleet sweep needs a [fleet] table with"
                        " folder = the folder of its problem or model files")
    if kind == "fleet" and params:
        raise key_error(path, ("param",), "a fleet sweep varies files, not parameters")
    if kind != "fleet" and not params:
        raise key_error(path, ("param",), f"a {kind} sweep needs at least one [[param]] table"
                        " (what varies between the variants)")
    if sw["n"] is not None and not any(p.random for p in params) and sw["n"] > 1:
        raise key_error(path, ("sweep", "n"), "only random parameters (normal, uniform,"
                        " lognormal) are drawn n times; a grid needs no n")
    total = sw["n"] or 1
    for p in params:
        total *= 1 if p.random else len(p.values)
    if total > MAX_VARIANTS:
        raise key_error(path, ("sweep",), f"{total} variants; at most {MAX_VARIANTS}")
    an, de, fl = v["analysis"] or {}, v["design"] or {}, v["fleet"] or {}
    front = _front(path, de, mimo)
    chunk = sw["chunk_size"] or {"analysis": 10, "design": 2, "fleet": 1}[kind]
    return Sweep(
        name=sw["name"] or Path(str(path)).stem, kind=kind, path=str(path),
        problem=base,
        description=sw["description"], seed=sw["seed"], n=sw["n"], chunk_size=chunk,
        worst=sw["worst"], params=params, overrides=tuple(overrides),
        ageing=ageing, controller=an.get("controller", "design"),
        margins=an.get("margins", True),
        front=front, folder=fl.get("folder"), pattern=fl.get("pattern", "*.toml"), mimo=mimo)


def _front(path, de, mimo):
    """The trade-off front's figures, the defaults by kind of problem, each checked."""
    front = (de.get("front_x") or ("sigma_U" if mimo else "Mu"),
             de.get("front_y") or "integral_gain")
    allowed = MIMO_FRONT_FIGURES if mimo else FIGURES
    for k, f in zip(("front_x", "front_y"), front):
        if f not in allowed:
            raise key_error(path, ("design", k), f"{f!r} is no figure of a"
                            f" {'multi-axis' if mimo else 'single-axis'} sweep: expected one"
                            f" of {', '.join(allowed)}")
    return front


def resolve_sweep_path(name_or_path: str | os.PathLike) -> Path:
    """A sweep file's path: an existing file, or a built-in sweep by name.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A file, or a built-in sweep's name.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    SpecError
        Neither a file nor a built-in sweep (the message lists the built-ins).
    """
    found = resources.find_file(name_or_path, "sweep")
    if found is not None:
        return found
    raise SpecError(f"{name_or_path}: sweep file not found (built-in sweeps:"
                    f" {', '.join(resources.sweep_names())})")


def load_sweep(path: str | os.PathLike) -> Sweep:
    """Read and validate a sweep file (or a built-in sweep by name).

    Parameters
    ----------
    path : str or Path
        A sweep file (TOML), or the name of a built-in sweep (``"paper_montecarlo"``).

    Returns
    -------
    Sweep

    Raises
    ------
    SpecError
        Naming the file and the key path of the first problem found.

    Examples
    --------
    >>> from robrst import load_sweep
    >>> sweep = load_sweep("paper_montecarlo")
    >>> sweep.kind, sweep.n
    ('analysis', 1000)
    """
    path = resolve_sweep_path(path)
    return parse_sweep(load_toml(path, "sweep file"), path)
