"""Regression tests on the margins of your own designs: golden files and ``assert_margins``.

A golden file is TOML written by ``robrst check PROBLEM --golden FILE --update`` (or
:func:`write_golden`): per model of the family the design's figures (``Ms``, ``Mt``,
``Mu``, the gain margins, the phase margin, the modulus and delay margins and, for a
sampled problem, the sampled peaks), the design's ``certified`` and its objective, each
with its tolerance.  Checking compares a new design with it and lists every figure that
got *worse* beyond its tolerance; improvements never fail.  Which way is worse:

==============================================  ===============================================
figure                                          worse when
==============================================  ===============================================
``Ms``, ``Mt``, ``Mu``, ``Msd``, ``*_sampled``  ``current > value (1 + rtol) + atol``
``modulus_margin``, ``delay_margin_s``          ``current < value (1 - rtol) - atol``
``phase_margin_deg``                            ``|current| < |value| (1 - rtol) - atol``
``gain_margin*`` (every gain margin)            ``|ln current| < |ln value| (1 - rtol) - atol``
``certified``                                   ``true`` became ``false``
``integral_gain`` (objective, its magnitude)    ``current < value (1 - rtol) - atol``
``worst_Ms`` (objective ``min_Ms``)             ``current > value (1 + rtol) + atol``
==============================================  ===============================================

Figures are read by name from ``DesignResult.as_dict()["models"]`` (and the certificate's
family-member records for ``*_sampled``); fields added later are ignored until a golden
names them.  ``null``/missing margins are infinite (``inf`` in the golden).

A multi-axis design (a ``[mimo]`` problem, :func:`robrst.design.mimo.design_mimo`) records
per family member the certificate's peaks, larger being worse: the largest singular values
``sigma_S``, ``sigma_T``, ``sigma_U``, ``sigma_Sd`` (and ``sigma_Ti``), the worst axis's
``axis_S`` and ``axis_T``, the largest off-diagonal ``crosstalk``, each also as
``*_sampled`` for the sampled loop; its objective is the least integral gain over the axes
(``integral_gain``: what the joint program maximises).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from robrst import __version__
from robrst.base.errors import OutputError, SpecError
from robrst.base.fileio import atomic_write_text, check_file_target, peek_text
from robrst.base.schema import load_toml

if TYPE_CHECKING:
    from robrst.design import DesignResult
    from robrst.design.mimo import MimoDesignResult
    from robrst.problem.records import Problem

__all__ = ["Worse", "golden_figures", "write_golden", "check_golden_target", "read_golden",
           "compare_golden", "assert_margins", "check_golden_fits", "count_figures",
           "figures_line", "MARKER", "DEFAULT_TOL"]

MARKER = "# robrst margins golden"
FORMAT = 1
PEAKS = ("Ms", "Mt", "Mu", "Msd")
SAMPLED = ("Ms_sampled", "Mt_sampled", "Mu_sampled")
MIMO_PEAKS = ("sigma_S", "sigma_T", "sigma_U", "sigma_Sd", "sigma_Ti", "axis_S", "axis_T",
              "crosstalk")
DEFAULT_TOL = {"rtol": 1e-4, "phase_atol_deg": 1e-2}
OBJECTIVES = {"integral_gain": "smaller", "worst_Ms": "larger"}   # name -> which way is worse
_GAIN = re.compile(r"^gain_margins?(_[a-z]+)?$")


def direction(name):
    """Which way figure ``name`` gets worse: ``larger``, ``smaller``, ``abs``, ``log`` or None."""
    if name in PEAKS or name in SAMPLED or name.removesuffix("_sampled") in MIMO_PEAKS:
        return "larger"
    if name in ("modulus_margin", "delay_margin_s"):
        return "smaller"
    if name == "phase_margin_deg":
        return "abs"
    if _GAIN.match(name) and not name.endswith(("_freq", "_rad_s", "_hz")):
        return "log"
    return None


@dataclass(frozen=True)
class Worse:
    """One figure that got worse: where, what, the golden and current values, the tolerance.

    Parameters
    ----------
    model : str
        The model's label (``""`` for a design-level figure).
    figure : str
        The figure (``Ms``, ``gain_margin``, ``certified``, ``model`` for a missing model,
        ...).
    golden : object
        The golden value.
    current : object
        The design's value.
    tolerance : str
        The tolerance, in words (``"rtol 0.0001"``).
    """

    model: str
    figure: str
    golden: float | bool | None
    current: float | bool | None
    tolerance: str

    def describe(self) -> str:
        """One line for the report: ``"<model> <figure>: <current> is worse than golden ..."``.

        Returns
        -------
        str
        """
        f = lambda v: v if isinstance(v, (bool, str)) else f"{v:.6g}"   # noqa: E731
        where = f"{self.model} " if self.model else ""
        return (f"{where}{self.figure}: {f(self.current)} is worse than golden"
                f" {f(self.golden)} ({self.tolerance})")


def _num(v):
    return math.inf if v is None else float(v)


def _as_dict(result):
    return result if isinstance(result, dict) else result.as_dict()


def _objective(result, d):
    kind = getattr(getattr(getattr(result, "problem", None), "solver", None), "objective", None)
    if kind == "min_Ms":
        return "worst_Ms", max(m["Ms"] for m in d["certificate"]["models"])
    if kind == "feasibility":
        return None, None
    ki = d.get("integral_gain")      # the objective is its magnitude (a negative one too)
    return "integral_gain", None if ki is None else abs(ki)


def golden_figures(result: DesignResult | MimoDesignResult | dict) -> dict:
    """The figures of ``result`` (a DesignResult or its ``as_dict()``) a golden records.

    Parameters
    ----------
    result : DesignResult, MimoDesignResult or dict
        A design (one loop or multi-axis) or its JSON.

    Returns
    -------
    dict
        ``{"problem", "certified", "objective": (name, value), "models": {label:
        {"temperature_C": T, figure: value, ...}}}``.
    """
    d = _as_dict(result)
    if d.get("kind") == "mimo":
        return _mimo_figures(d)
    sampled = {m["label"]: m for m in d.get("certificate", {}).get("models", [])
               if m.get("family_member", True)}
    models = {}
    for m in d["models"]:
        figs = {k: v for k, v in m.items()
                if direction(k) and (v is None or isinstance(v, (int, float)))
                and not isinstance(v, bool)}
        rec = sampled.get(m["label"], {})
        figs.update({k: rec[k] for k in SAMPLED if k in rec})
        models[m["label"]] = {"temperature_C": m.get("temperature_C"), **figs}
    return {"problem": d["problem"], "certified": bool(d["certified"]),
            "objective": _objective(result, d), "models": models}


def _sampled_figure(name):
    """A figure of the sampled loop (``Ms_sampled``, ``sigma_S_sampled``, ...)."""
    return name in SAMPLED or name.endswith("_sampled")


def _mimo_figures(d):
    """:func:`golden_figures` of a multi-axis design's JSON: every family member's peaks
    (an axis-wise figure: its worst axis), both loops; the least axis's integral gain."""
    models = {}
    for m in d["certificate"]["models"]:
        if not m.get("member", True):
            continue
        figs = {}
        for loop in ("continuous", "sampled"):
            rec = m.get(loop) or {}
            for f in MIMO_PEAKS:
                v = rec.get(f)
                if v is None:
                    continue
                val = max(p["value"] for p in v) if isinstance(v, list) else v["value"]
                figs[f if loop == "continuous" else f"{f}_sampled"] = val
        models[m["label"]] = {"temperature_C": None, **figs}
    gains = [abs(k) for k in d.get("integral_gains") or []]
    return {"problem": d["problem"], "certified": bool(d["certified"]),
            "objective": ("integral_gain", min(gains) if gains else None), "models": models}


def _unchecked(way, value):
    """A golden value that checks nothing: a peak (larger is worse) of inf."""
    return way == "larger" and math.isinf(_num(value))


def _tol(name, rtol, phase_atol):
    return {"atol": float(phase_atol)} if direction(name) == "abs" else {"rtol": float(rtol)}


def check_golden_target(path: str | Path) -> Path:
    """The golden file ``path`` may be written: a new file, or a robrst golden (checked
    before a design, so a file in the way fails at once).

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OutputError
        ``path`` exists and is not a robrst golden, or cannot be written.
    """
    path = check_file_target(path)
    if (path.exists() or path.is_symlink()) and (
            path.is_dir() or not (peek_text(path) or "").startswith(MARKER)):
        raise OutputError(f"{path}: exists and is not a robrst golden (it does not start with"
                          f" {MARKER!r}); refusing to overwrite it")
    return path


def write_golden(result: DesignResult | dict, path: str | Path, rtol: float = DEFAULT_TOL["rtol"],
                 phase_atol_deg: float = DEFAULT_TOL["phase_atol_deg"]) -> Path:
    """Write the golden of ``result`` to ``path`` (atomically; only over a robrst golden).

    Parameters
    ----------
    result : DesignResult or dict
        A design or its JSON.
    path : str or pathlib.Path
        The golden file.
    rtol : float
        Relative tolerance written for every figure but the phase margin.
    phase_atol_deg : float
        Absolute tolerance of the phase margin [°].

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    OutputError
        ``path`` exists and is not a robrst golden (nothing is overwritten).
    """
    path = check_golden_target(path)
    import tomlkit   # noqa: PLC0415  (only writing a golden needs it: no command's start pays)

    from robrst.base.tomlwrite import document, inline, plain   # noqa: PLC0415

    g = golden_figures(result)
    doc = document([
        f"{MARKER[2:]} for problem {json.dumps(g['problem'])}, written by robrst {__version__}.",
        "`robrst check PROBLEM --golden THIS_FILE` fails on every figure worse than its",
        "value beyond its tolerance (peaks: larger; margins: smaller; phase margin:",
        "smaller |pm|; gain margins: closer to 1; inf = infinite).  Edit tolerances",
        "freely; delete a figure to stop checking it."])
    doc["golden"] = plain({"format": FORMAT, "problem": g["problem"],
                           "robrst_version": __version__})
    design = tomlkit.table()
    design["certified"] = bool(g["certified"])
    name, value = g["objective"]
    if (name is not None and value is not None
            and not _unchecked(OBJECTIVES[name], value)):
        design["objective"] = inline({"name": name, "value": _num(value), "rtol": float(rtol)})
    doc["design"] = design
    models = tomlkit.table(True)       # a super-table: only [models."label"] headers
    for label, figs in g["models"].items():
        table = tomlkit.table()
        if figs.get("temperature_C") is not None:
            table["temperature_C"] = plain(_num(figs["temperature_C"]))
        for k, v in figs.items():
            if k == "temperature_C":
                continue
            if _unchecked(direction(k), v):     # a peak of inf: nothing can be worse
                table.add(tomlkit.comment(f"{k} = inf checks nothing (no value is larger):"
                                          " not written"))
            else:
                table[k] = inline({"value": _num(v), **_tol(k, rtol, phase_atol_deg)})
        models[plain(str(label))] = table
    if g["models"]:
        doc["models"] = models
    atomic_write_text(path, tomlkit.dumps(doc))
    return path


def _bad(path, where, what):
    return SpecError(f"{path}: [{where}] {what}")


def _float(v):
    """``float(v)`` of a TOML number (``None`` for anything else, or an integer beyond the
    range of a float)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        return float(v)
    except OverflowError:
        return None


def _shown(v):
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10**20:
        return f"an integer of {len(str(abs(v)))} digits"
    return repr(v)


def _figure(path, where, v, objective=None):
    """A validated ``{value, rtol, atol}`` entry (``objective``: its name, for the
    objective's entry)."""
    if not isinstance(v, dict) or "value" not in v:
        raise _bad(path, where, "expected { value = number, rtol = number | atol = number }")
    unknown = set(v) - {"value", "rtol", "atol"}
    if unknown:
        raise _bad(path, where, f"unknown key(s) {sorted(unknown)}; expected value, rtol, atol")
    val = _float(v["value"])
    if val is None or math.isnan(val):
        raise _bad(path, where, f"value must be a number (inf allowed), got {_shown(v['value'])}")
    name = where.rsplit(".", 1)[-1]
    way = direction(name) if where.startswith("models.") else OBJECTIVES.get(objective)
    if way == "log" and not val > 0:
        raise _bad(path, where, f"a gain margin is a factor > 0 (inf allowed), got {val!r}")
    if way in ("larger", "smaller") and not val >= 0:
        raise _bad(path, where, f"a peak or margin is >= 0 (inf allowed), got {val!r}")
    if way == "larger" and math.isinf(val):
        raise _bad(path, where, "value = inf checks nothing (no value is larger than inf);"
                   " expected a finite number >= 0 (delete the figure to stop checking it)")
    tol = {}
    for k in ("rtol", "atol"):
        t = _float(v.get(k, 0.0))
        if t is None or not 0 <= t < math.inf:
            raise _bad(path, f"{where}.{k}", f"must be a finite number >= 0, got"
                       f" {_shown(v.get(k))}")
        tol[k] = t
    return float(val), tol["rtol"], tol["atol"]


def read_golden(path: str | Path) -> dict:
    """Parse and validate a golden file; errors name the file and the key.

    Parameters
    ----------
    path : str or pathlib.Path
        The golden file.

    Returns
    -------
    dict
        ``{"problem", "certified", "objective": (name, value, rtol, atol) or None,
        "models": {label: {figure: (value, rtol, atol)}}, "path"}``.

    Raises
    ------
    SpecError
        Naming the file and the key: unknown keys and tables, wrong types, a gain
        margin <= 0 or a negative peak or margin, a golden that checks nothing.
    """
    path = Path(path)
    if not path.exists():
        raise SpecError(f"{path}: golden file not found (write one with --update)")
    data = load_toml(path, "golden file")
    unknown = set(data) - {"golden", "design", "models"}
    if unknown:
        raise _bad(path, sorted(unknown)[0], "unknown table; expected golden, design, models")
    head = data.get("golden")
    if not isinstance(head, dict) or isinstance(head.get("format"), bool) \
            or head.get("format") != FORMAT or not isinstance(head.get("problem"), str):
        raise _bad(path, "golden", f"expected format = {FORMAT} and problem = \"NAME\"")
    _known(path, "golden", head, ("format", "problem", "robrst_version"))   # version: a note
    design = data.get("design", {})
    if not isinstance(design, dict):
        raise _bad(path, "design", "expected a table with certified and objective")
    _known(path, "design", design, ("certified", "objective"))
    if not isinstance(design.get("certified", False), bool):
        raise _bad(path, "design.certified", "expected true or false")
    obj = design.get("objective")
    if obj is not None:
        if not isinstance(obj, dict) or not isinstance(obj.get("name"), str) \
                or obj["name"] not in OBJECTIVES:
            raise _bad(path, "design.objective", f"expected {{ name = one of {sorted(OBJECTIVES)},"
                       " value = number, rtol = number }")
        obj = (obj["name"], *_figure(path, "design.objective",
                                     {k: v for k, v in obj.items() if k != "name"}, obj["name"]))
    models = data.get("models", {})
    if not isinstance(models, dict):
        raise _bad(path, "models", "expected a table of models")
    out, temps = {}, {}
    for label, figs in models.items():
        if not isinstance(figs, dict):
            raise _bad(path, f"models.{label}", "expected a table of figures")
        out[label] = {}
        for k, v in figs.items():
            if k == "temperature_C":
                if _float(v) is None or not math.isfinite(_float(v)):
                    raise _bad(path, f"models.{label}.{k}", f"expected a number, got {_shown(v)}")
                temps[label] = _float(v)
                continue
            if direction(k) is None:
                raise _bad(path, f"models.{label}.{k}", "not a margin figure robrst checks")
            out[label][k] = _figure(path, f"models.{label}.{k}", v)
    g = {"problem": head["problem"], "certified": design.get("certified", False),
         "objective": obj, "models": out, "path": str(path), "temperatures_C": temps}
    if not count_figures(g):
        raise SpecError(f"{path}: the golden checks nothing (no model figure, no objective and"
                        " certified = false); write one with --update")
    return g


def _known(path, table, d, keys):
    unknown = sorted(set(d) - set(keys))
    if unknown:
        raise _bad(path, f"{table}.{unknown[0]}", f"unknown key; expected {', '.join(keys)}")


def count_figures(golden: dict) -> int:
    """How many figures :func:`compare_golden` checks (``certified = true`` and the
    objective count as one each).

    Parameters
    ----------
    golden : dict
        As :func:`read_golden` returns it.

    Returns
    -------
    int
    """
    return (sum(len(m) for m in golden["models"].values()) + bool(golden["certified"])
            + (golden["objective"] is not None))


def figures_line(golden: dict) -> str:
    """How many figures a golden checks, and what they are, in words: the count of
    :func:`count_figures` (``robrst check --update`` and ``robrst check`` print the same).

    Parameters
    ----------
    golden : dict
        As :func:`read_golden` returns it.

    Returns
    -------
    str
        ``"98 figures: 96 model figures over 8 models, certified = true and the objective
        integral_gain"``.
    """
    n_models = sum(len(m) for m in golden["models"].values())
    parts = [f"{n_models} model figures over {len(golden['models'])} models"]
    if golden["certified"]:
        parts.append("certified = true")
    if golden["objective"] is not None:
        parts.append(f"the objective {golden['objective'][0]}")
    tail = ", ".join(parts[:-1]) + " and " + parts[-1] if len(parts) > 1 else parts[0]
    return f"{count_figures(golden)} figures: {tail}"


def check_golden_fits(golden: dict, problem: Problem) -> None:
    """Refuse, before any design, a golden of another problem or objective, or with sampled
    figures for a continuous problem.

    Parameters
    ----------
    golden : dict
        As :func:`read_golden` returns it.
    problem : Problem
        The problem about to be designed.

    Raises
    ------
    SpecError
        Naming the golden file and the key.
    """
    path = golden.get("path", "golden")
    if golden["problem"] != problem.name:
        raise SpecError(f"{path}: [golden.problem] golden is for problem {golden['problem']!r},"
                        f" not {problem.name!r}")
    kind = getattr(problem.solver, "objective", "max_integral_gain")   # multi-axis: the gain
    want = {"min_Ms": "worst_Ms", "feasibility": None}.get(kind, "integral_gain")
    if golden["objective"] is not None and golden["objective"][0] != want:
        raise _bad(path, "design.objective", f"golden objective {golden['objective'][0]!r}, the"
                   f" problem's objective is {kind!r} ({'no figure' if want is None else want})")
    family = getattr(problem, "family", None)       # a multi-axis problem: no temperatures
    at = {m.label: getattr(m, "temperature_C", None) for m in getattr(family, "models", ())}
    for label, T in golden.get("temperatures_C", {}).items():
        if at.get(label) is not None and abs(at[label] - T) > 1e-9 * max(1.0, abs(T)):
            raise _bad(path, f"models.{label}.temperature_C", f"the golden's model {label} is at"
                       f" {T:g} °C, the problem's at {at[label]:g} °C: a golden of another"
                       " family (write it again with --update)")
    if problem.specs.sample_rate_hz is None:
        for label, figs in golden["models"].items():
            for k in figs:
                if _sampled_figure(k):
                    raise _bad(path, f"models.{label}.{k}", "a sampled-loop figure, but the"
                               " problem has no [specs] sample_rate_hz")


def _worse(name, cur, val, rtol, atol):
    """True when ``cur`` is worse than ``val`` beyond the tolerance (see the module table)."""
    way = OBJECTIVES.get(name) or direction(name)
    c, g = _num(cur), val
    if way == "larger":
        return c > g * (1 + rtol) + atol
    if way == "smaller":
        return c < g * (1 - rtol) - atol
    if way == "abs":
        return abs(c) < abs(g) * (1 - rtol) - atol
    lg = lambda x: math.inf if x in (0.0, math.inf) else abs(math.log(x))   # noqa: E731
    return lg(c) < lg(g) * (1 - rtol) - atol


def _tol_text(rtol, atol):
    return ", ".join(t for t in (f"rtol {rtol:g}" if rtol else "", f"atol {atol:g}" if atol else "")
                     if t) or "no tolerance"


def compare_golden(result: DesignResult | dict, golden: str | Path | dict) -> list[Worse]:
    """Every figure of ``result`` worse than ``golden`` (a path or :func:`read_golden`'s dict).

    Parameters
    ----------
    result : DesignResult or dict
        A design or its JSON.
    golden : str, pathlib.Path or dict
        The golden file, or its parsed form.

    Returns
    -------
    list of Worse
        Empty when nothing got worse.  A model of the golden missing from the design is
        one entry (figure ``model``).

    Raises
    ------
    SpecError
        A malformed golden, a golden of another problem or objective, or a figure the
        design does not have.
    """
    g = read_golden(golden) if isinstance(golden, (str, Path)) else golden
    path = g.get("path", "golden")
    cur = golden_figures(result)
    if g["problem"] != cur["problem"]:
        raise SpecError(f"{path}: [golden.problem] golden is for problem {g['problem']!r},"
                        f" the design is {cur['problem']!r}")
    out = []
    if g["certified"] and not cur["certified"]:
        out.append(Worse("", "certified", True, False, "must stay certified"))
    if g["objective"] is not None:
        name, val, rtol, atol = g["objective"]
        cname, cval = cur["objective"]
        if cname != name:
            raise _bad(path, "design.objective", f"golden objective {name!r}, the design"
                       f" optimises {cname!r}")
        if _worse(name, cval, val, rtol, atol):
            out.append(Worse("", name, val, _num(cval), _tol_text(rtol, atol)))
    for label, figs in g["models"].items():
        have = cur["models"].get(label)
        if have is None:
            out.append(Worse(label, "model", "present", "missing", "every golden model"))
            continue
        for k, (val, rtol, atol) in figs.items():
            if k not in have:
                raise _bad(path, f"models.{label}.{k}", "not a figure of this design")
            if _worse(k, have[k], val, rtol, atol):
                out.append(Worse(label, k, val, _num(have[k]), _tol_text(rtol, atol)))
    return out


def assert_margins(result: DesignResult | dict, golden: str | Path, update: bool = False) -> None:
    """Fail (``AssertionError``) when a margin of ``result`` got worse than ``golden``.

    Parameters
    ----------
    result : DesignResult or dict
        A design (:func:`robrst.run_problem`) or its ``as_dict()``.
    golden : str or Path
        The golden file (see the module documentation for its format and the rules).
    update : bool
        Write (or rewrite) the golden from ``result`` instead of checking.

    Returns
    -------
    None

    Raises
    ------
    AssertionError
        One line per figure that got worse.
    SpecError
        A malformed golden (names the file and the key), or one of another problem.

    Examples
    --------
    >>> import tempfile, robrst
    >>> from robrst.testing import assert_margins
    >>> result = robrst.run_problem(robrst.load_problem("paper"))
    >>> golden = tempfile.mkdtemp() + "/paper_margins.toml"
    >>> assert_margins(result, golden, update=True)     # once, then commit the file
    >>> assert_margins(result, golden)                  # in your test suite
    """
    if update:
        write_golden(result, golden)
        return
    worse = compare_golden(result, golden)
    if worse:
        raise AssertionError(f"{len(worse)} figure(s) worse than {golden}:\n"
                             + "\n".join(w.describe() for w in worse))
