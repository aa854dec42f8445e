"""Multi-axis problem files (TOML, a ``[mimo]`` table) -> :class:`~robrst.problem.mimo.MimoProblem`.

A file with a top-level ``[mimo]`` table is a multi-axis problem::

    [problem]
    name = "mirror"

    [mimo]
    parameter = "level"               # or "temperature_C"
    unit = "mV"
    axes = ["y1", "y2", "y3"]

    [[mimo.models]]                   # a model file of robrst identify, as written
    file = "mirror_100mV.toml"        # (relative to this file)
    value = 100.0                     # its level (a temperature: from the file)
    [[mimo.models]]
    A = [[...]]                       # or a state space (B, C, D) ...
    value = 200.0
    [[mimo.models]]
    num = [[[...]]]                   # ... or a transfer matrix (den: one polynomial or
    den = [[[...]]]                   # one per entry), polynomials highest power first
    value = 300.0

    [mimo.controller]                 # decoupler, degrees, roll-off, T_mode
    [mimo.specs]                      # sigma_S_max, crosstalk_max, sample_rate_hz, ...
    [mimo.solver]                     # method, rounds, grid

Every key is declared in :data:`MIMO_SCHEMA` (validated by :mod:`robrst.base.schema`:
unknown keys rejected with the closest valid one); matrices (``A, B, C, D, num, den, W``)
are checked here, each error naming the file and the key.  A model file holding several
``[[model.at]]`` (one per temperature) gives one model each, at its temperature.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from robrst.base.errors import SpecError
from robrst.base.modelformat import read_model_table
from robrst.base.schema import ArrayOf, Field, key_error, load_toml, markdown_rows, validate
from robrst.core.mimo import PARAMETERS, MimoFamily, MimoPlant
from robrst.problem.mimo import (DECOUPLERS, MIMO_METHODS, MIMO_SPECS, MIMO_T_MODES,
                                 MimoProblem, MimoSolverOptions, MimoSpecs, MimoStructure)

__all__ = ["MIMO_SCHEMA", "MATRIX_KEYS", "is_mimo_document", "is_mimo_file", "parse_mimo",
           "load_mimo_problem", "mimo_schema_markdown"]

#: the matrix keys (checked here, not by the schema) and what each is
MATRIX_KEYS = {
    ("mimo", "models"): {"A": "state matrix (n x n) [rad/s]", "B": "input matrix (n x inputs)",
                         "C": "output matrix (outputs x n)",
                         "D": "feedthrough (outputs x inputs) [µm/V]",
                         "num": "numerators, outputs x inputs polynomials in s",
                         "den": "denominators: outputs x inputs polynomials, or one common"},
    ("mimo", "controller"): {"W": "static decoupler (inputs x axes), decoupler = 'given'"},
}
#: list keys checked here: ``[mimo] axes``, the axes' names (one per output)

_SPEC_FIELDS = {r.key: Field("number", None, f"bound: {r.label}"
                             + (f" [{r.unit}]" if r.unit else ""), positive=True)
                for r in MIMO_SPECS}
_SPEC_FIELDS["input_gain_deviation"] = Field(
    "number", None, "delta: the loop stays stable for input gains anywhere in [1 - delta,"
    " 1 + delta] (a sector; hysteresis and creep as a gain deviation)", positive=True,
    hi=0.999)

MIMO_SCHEMA = {
    "problem": {
        "name": Field("str", None, "problem name (default: file stem)"),
        "description": Field("str", "", "free text"),
    },
    "mimo": {
        "parameter": Field("str", "temperature_C", "what the models run over",
                           choices=tuple(PARAMETERS)),
        "unit": Field("str", None, "the parameter's unit (default °C for temperatures)"),
        "reference": Field("number", None, "the nominal model's parameter value (default"
                           " the first)"),
        "drop_modes_below_hz": Field("number", None, "remove every model's modes slower than"
                                     " this [Hz] (below the records' lowest excited line"
                                     " they are not identified)", positive=True, hi=1e9),
        "models": ArrayOf({
            "file": Field("str", None, "a model file of robrst identify (relative to this"
                          " file)"),
            "value": Field("number", None, "the model's parameter value (a model file's"
                           " temperature when not given)"),
            "label": Field("str", None, "the model's name (default from the file or value)"),
        }, doc="one model (or a model file's models)", max_items=100),
        "controller": {
            "decoupler": Field("str", "static", "none | static | given", choices=DECOUPLERS),
            "decoupler_hz": Field("number", 0.0, "where the static decoupler inverts the"
                                  " reference model [Hz]", lo=0.0, hi=1e9),
            "extra_degree": Field("int", 1, "degree of S_i' beyond the integrator, per axis",
                                  lo=0, hi=12),
            "relative_degree": Field("int", 0, "deg R_i <= deg S_i - this", lo=0, hi=4),
            "roll_off_order": Field("int", 0, "fixed roll-off (s/wr + 1)^order in every S_i",
                                    lo=0, hi=6),
            "roll_off_hz": Field("number", None, "its corner [Hz]", positive=True, hi=1e9),
            "T_mode": Field("str", "feedback", "feedback (T = R) | static (T = R(0))",
                            choices=MIMO_T_MODES),
        },
        "specs": {
            **_SPEC_FIELDS,
            "crosstalk_band_hz": Field("numbers", None, "[lo, hi] band of crosstalk_max [Hz]",
                                       length=2, lo=0.0, hi=1e9),
            "sample_rate_hz": Field("number", None, "also certify and design the sampled loop"
                                    " (ZOH plant, Tustin controller) at this rate [Hz]",
                                    positive=True, hi=1e9),
            "delay_samples": Field("int", 0, "computation delay of the sampled loop", lo=0,
                                   hi=100),
        },
        "solver": {
            "method": Field("str", "nlp", "nlp (the joint program) | per_axis (each axis"
                            " alone)", choices=MIMO_METHODS),
            "bandwidth_hz": Field("number", None, "crossover of the per-axis start designs"
                                  " [Hz]", positive=True, hi=1e9),
            "n_freq": Field("int", 80, "log-spaced grid points per loop", lo=10, hi=5000),
            "max_rounds": Field("int", 5, "certification rounds per design", lo=1, hi=50),
            "cert_points": Field("int", 2, "checked points inside each segment between"
                                 " models", lo=0, hi=100),
            "cert_tol": Field("number", 1e-3, "relative tolerance on certified bounds",
                              positive=True, hi=0.1),
            "max_iter": Field("int", 300, "IPOPT iterations per solve", lo=1, hi=100000),
            "ipopt_tol": Field("number", 1e-6, "IPOPT tolerance", positive=True, hi=1e-2),
            "multistart": Field("bool", False, "nlp: also run the global phase (a population"
                                " search over every axis's law; 1-9x the CPU)"),
        },
    },
}


def mimo_schema_markdown() -> list[str]:
    """The ``[mimo]`` reference as Markdown rows (the matrix keys included).

    Returns
    -------
    list of str
    """
    rows = markdown_rows(MIMO_SCHEMA)
    rows.append("| `mimo` | `axes` | list of str | no | [] | the axes' names (one per output) |")
    for (tab, sub), keys in MATRIX_KEYS.items():
        where = f"{tab}.{sub}" + ("[]" if sub == "models" else "")
        rows += [f"| `{where}` | `{k}` | matrix | no | None | {doc} |" for k, doc in keys.items()]
    return rows


def is_mimo_document(data: object) -> bool:
    """Whether a parsed TOML document is a multi-axis problem (it has ``[mimo]``).

    Parameters
    ----------
    data : object

    Returns
    -------
    bool
    """
    return isinstance(data, dict) and isinstance(data.get("mimo"), dict)


def is_mimo_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a TOML file with a top-level ``[mimo]`` table (unreadable or
    invalid files: ``False``, their reader reports them).

    Parameters
    ----------
    path : str or PathLike

    Returns
    -------
    bool
    """
    p = Path(path)
    if p.suffix.lower() != ".toml" or not p.is_file():
        return False
    try:
        return is_mimo_document(load_toml(p, "problem file"))
    except SpecError:
        return False


def _matrix(path, key, value, depth=2):
    """A rectangular matrix of finite numbers (``depth`` 3: a matrix of polynomials)."""
    def bad(why):
        return key_error(path, key, f"expected {why}")

    if depth == 2:
        if not isinstance(value, list) or not value or not all(
                isinstance(r, list) for r in value):
            raise bad("a matrix: a list of rows (lists of numbers)")
        n = len(value[0])
        for r in value:
            if len(r) != n or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                      for v in r):
                raise bad(f"a matrix of numbers with rows of equal length ({n})")
        a = np.array(value, float)
        if not np.all(np.isfinite(a)) or np.any((a != 0) & ((np.abs(a) > 1e100)
                                                            | (np.abs(a) < 1e-100))):
            raise bad("finite numbers, 0 or 1e-100 <= |x| <= 1e100")
        return a
    if not isinstance(value, list) or not value or not all(isinstance(r, list) for r in value):
        raise bad("a matrix of polynomials: rows of lists of numbers")
    out = []
    for i, row in enumerate(value):
        if len(row) != len(value[0]):
            raise bad("rows of equal length")
        out.append([_matrix(path, key + (str(i), str(j)), [p], 2)[0] for j, p in
                    enumerate(row)])
    return out


def _models(path, entries, parameter):
    """The models of ``[[mimo.models]]``."""
    out = []
    base = Path(str(path)).parent
    for n, raw in enumerate(entries):
        key = ("mimo", "models", str(n))
        mats = {k: raw.pop(k) for k in list(raw) if k in MATRIX_KEYS[("mimo", "models")]}
        t = validate(path, raw, MIMO_SCHEMA["mimo"]["models"].table, key)
        kinds = [k for k, present in (("file", t["file"] is not None),
                                      ("state space", "A" in mats or "C" in mats),
                                      ("transfer matrix", "num" in mats)) if present]
        if len(kinds) != 1:
            raise key_error(path, key, "give exactly one of: file | A, B, C, D | num, den"
                            + (f" (got {', '.join(kinds)})" if kinds else ""))
        value, label = t["value"], t["label"]
        try:
            if t["file"] is not None:
                out += _model_file(path, key, base / t["file"], value, label, parameter)
                continue
            if kinds[0] == "state space":
                for k in "ABCD":
                    if k not in mats:
                        raise key_error(path, key + (k,), "missing (a state space needs A, B,"
                                        " C and D)")
                A, B, C, D = (_matrix(path, key + (k,), mats[k]) for k in "ABCD")
                plant = MimoPlant(A, B, C, D, label or _label(parameter, value, n), value)
            else:
                if "den" not in mats:
                    raise key_error(path, key + ("den",), "missing (with num)")
                num = _matrix(path, key + ("num",), mats["num"], 3)
                den_raw = mats["den"]
                if isinstance(den_raw, list) and den_raw and not isinstance(den_raw[0], list):
                    den = _matrix(path, key + ("den",), [den_raw])[0]
                else:
                    den = _matrix(path, key + ("den",), den_raw, 3)
                plant = MimoPlant.from_transfer_matrix(num, den, label or
                                                       _label(parameter, value, n), value)
        except SpecError as exc:
            if str(exc).startswith(str(path)):
                raise
            raise key_error(path, key, str(exc)) from None
        out.append(plant)
    return out


def _label(parameter, value, n):
    if value is None:
        return f"model{n + 1}"
    return f"{'T' if parameter == 'temperature_C' else 'L'}{value:g}"


def _model_file(path, key, target, value, label, parameter):
    """The models of a model file of ``robrst identify``."""
    if not target.is_file():
        raise key_error(path, key + ("file",), f"{target}: "
                        + ("is a folder" if target.is_dir() else "not found")
                        + "; expected a model file of robrst identify (relative to this file)")
    data = load_toml(target, "model file")
    table = read_model_table(target, data, design_tables=True)
    ats = table.at
    if value is not None and len(ats) > 1:
        raise key_error(path, key + ("value",), f"{target.name} holds {len(ats)} models (one per"
                        " temperature); a value applies to one model")
    out = []
    for i, at in enumerate(ats):
        v = value if value is not None else (at.temperature_C if parameter == "temperature_C"
                                             else None)
        if v is None and len(ats) > 1:
            raise key_error(path, key + ("value",), f"{target.name}: its models carry no"
                            f" {parameter}; give one file per model with its value")
        lab = label or (target.stem if len(ats) == 1 else f"{target.stem}_T{v:g}")
        out.append(MimoPlant.from_modal(at.poles, at.residues, at.D, lab, v))
    return out


def parse_mimo(data: dict, path: str | Path = "<problem>") -> MimoProblem:
    """Validate a parsed multi-axis document and build the problem.

    Parameters
    ----------
    data : dict
        The parsed TOML document (with ``[mimo]``).
    path : str or pathlib.Path
        Where it came from (named in every error; model files are relative to it).

    Returns
    -------
    MimoProblem

    Raises
    ------
    SpecError
        Naming the file and the key of the first problem found.
    """
    if not isinstance(data, dict):
        raise key_error(path, (), "expected a TOML document")
    data = dict(data)
    mimo = dict(data.get("mimo") or {})
    entries = [dict(e) if isinstance(e, dict) else e for e in (mimo.pop("models", None) or [])]
    ctrl_raw = dict(mimo.get("controller") or {}) if isinstance(mimo.get("controller"), dict) \
        else mimo.get("controller")
    W_raw = ctrl_raw.pop("W", None) if isinstance(ctrl_raw, dict) else None
    axes = mimo.pop("axes", ())
    if not isinstance(axes, list) or not all(isinstance(a, str) and a for a in axes):
        if axes != ():
            raise key_error(path, ("mimo", "axes"), "expected a list of names (strings)")
    if isinstance(ctrl_raw, dict):
        mimo["controller"] = ctrl_raw
    data["mimo"] = mimo
    v = validate(path, data, MIMO_SCHEMA)
    m = v["mimo"]
    if not entries:
        raise key_error(path, ("mimo", "models"), "expected at least one [[mimo.models]]")
    if not all(isinstance(e, dict) for e in entries):
        raise key_error(path, ("mimo", "models"), "expected an array of tables [[mimo.models]]")
    parameter = m["parameter"]
    models = _models(path, entries, parameter)
    if m["drop_modes_below_hz"] is not None:
        models = [mdl.without_modes_below(2 * np.pi * m["drop_modes_below_hz"])
                  for mdl in models]
    unit = m["unit"] if m["unit"] is not None else PARAMETERS[parameter]
    ref = 0
    if m["reference"] is not None:
        vals = [mdl.value for mdl in models]
        if m["reference"] not in vals:
            raise key_error(path, ("mimo", "reference"), f"{m['reference']:g} is not a model's"
                            f" value ({', '.join(f'{x:g}' for x in vals if x is not None)})")
        ref = sorted(vals).index(m["reference"])
    try:
        family = MimoFamily(tuple(models), parameter, unit, ref)
    except SpecError as exc:
        raise key_error(path, ("mimo", "models"), str(exc)) from None
    c = m["controller"] or validate(path, {}, MIMO_SCHEMA["mimo"]["controller"])
    s = m["specs"] or validate(path, {}, MIMO_SCHEMA["mimo"]["specs"])
    so = m["solver"] or validate(path, {}, MIMO_SCHEMA["mimo"]["solver"])
    W = None if W_raw is None else _matrix(path, ("mimo", "controller", "W"), W_raw)
    try:
        structure = MimoStructure(W=W, axes=tuple(axes), **c)
    except SpecError as exc:
        raise key_error(path, ("mimo", "controller"), str(exc)) from None
    try:
        specs = MimoSpecs(**s)
    except SpecError as exc:
        raise key_error(path, ("mimo", "specs"), str(exc)) from None
    meta = v["problem"] or {}
    name = meta.get("name") or Path(str(path)).stem
    try:
        return MimoProblem(name, family, structure, specs, MimoSolverOptions(**so),
                           path=str(path), description=meta.get("description", ""))
    except SpecError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise key_error(path, ("mimo",), str(exc)) from None


def load_mimo_problem(path: str | os.PathLike) -> MimoProblem:
    """Read and validate a multi-axis problem file.

    Parameters
    ----------
    path : str or PathLike

    Returns
    -------
    MimoProblem

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    path = Path(path)
    data = load_toml(path, "problem file")
    if not is_mimo_document(data):
        raise SpecError(f"{path}: not a multi-axis problem (no [mimo] table)")
    return parse_mimo(data, path)
