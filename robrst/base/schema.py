"""Neutral schema validation for robrst's TOML files (problems, twins, sweeps).

A schema is a dict mapping each key to a :class:`Field` (a value), a nested dict (a
table) or an :class:`ArrayOf` (an array of tables).  :func:`validate` checks a parsed
document against it: unknown keys are rejected with the closest valid key, every value
is type- and range-checked, defaults are filled in, and every error is a
:class:`~robrst.base.errors.SpecError` naming the file and the key path.  The module knows
nothing about control: each file format declares its own schema and builds its own
typed records from the validated tables.
"""

import difflib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from robrst.base.errors import SpecError
from robrst.base.fileio import read_utf8

__all__ = ["Field", "ArrayOf", "validate", "key_error", "load_toml", "markdown_rows",
           "MAX_LIST", "MAX_MAGNITUDE"]

MAX_LIST = 10_000   # longest list of numbers any robrst file may hold
MAX_MAGNITUDE = 1e100   # any number in a robrst file: 0 or 1e-100 <= |x| <= 1e100
SHORT_TABLE = 8         # an unknown key of a table this small lists its keys
TYPE_NAMES = {"number": "number", "numbers": "list of numbers", "int": "int", "str": "str",
              "bool": "bool"}


@dataclass(frozen=True)
class Field:
    """One key of a schema.

    Parameters
    ----------
    type : {"number", "numbers", "int", "str", "bool"}
        ``number`` is a finite float (integers accepted), ``numbers`` a list of them.
    default : object
        Value when the key is absent (ignored when ``required``).
    doc : str
        One line for the file-format reference.
    required : bool
        The key must be present.
    choices : tuple of str
        Allowed values of a ``str`` field.
    lo, hi : float, optional
        Inclusive range of a number/int (of every element of a list).
    positive : bool
        Strictly greater than zero.
    length : int, optional
        Exact length of a list.
    allow_off : bool
        ``false`` is also accepted (and returned as ``False``): a default switched off.
    """

    type: str
    default: object = None
    doc: str = ""
    required: bool = False
    choices: tuple = ()
    lo: float = None
    hi: float = None
    positive: bool = False
    length: int = None
    allow_off: bool = False

    def describe(self) -> str:
        """The accepted values in words (for error messages).

        Returns
        -------
        str
            E.g. ``"number >= 1e-06 and <= 1e+09"`` or ``"one of auto, fixed, free"``.
        """
        what = TYPE_NAMES[self.type]
        if self.choices:
            return "one of " + ", ".join(self.choices)
        rng = []
        if self.positive:
            rng.append("> 0")
        if self.lo is not None:
            rng.append(f">= {self.lo:g}")
        if self.hi is not None:
            rng.append(f"<= {self.hi:g}")
        if self.length is not None:
            what += f" of length {self.length}"
        return what + (f" {' and '.join(rng)}" if rng else "") + (
            " (or false: off)" if self.allow_off else "")


@dataclass(frozen=True)
class ArrayOf:
    """An array of tables (``[[key]]``), each validated against ``table``.

    Parameters
    ----------
    table : dict
        The schema of one table of the array.
    doc : str
        One line for the file-format reference.
    max_items : int
        Largest number of tables accepted.
    """

    table: dict
    doc: str = ""
    max_items: int = 1000


def key_error(path: str | Path, key: tuple, msg: str) -> SpecError:
    """A :class:`SpecError` ``"FILE: [a.b.c] msg"`` naming the file and the key path.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    key : tuple of str
        The key path (empty: the top level).
    msg : str
        What was expected, got what.

    Returns
    -------
    SpecError
        The exception, for the caller to raise.
    """
    where = ".".join(str(k) for k in key) if key else "(top level)"
    return SpecError(f"{path}: [{where}] {msg}")


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _finite_float(v):
    """``float(v)`` of a number, ``None`` when it is not finite (an integer beyond the
    range of a float, e.g. a 400-digit integer literal, included)."""
    try:
        f = float(v)
    except OverflowError:
        return None
    return f if math.isfinite(f) else None


def _shown(v):
    """A value for a message: long integers abbreviated."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10**20:
        return f"an integer of {len(str(abs(v)))} digits"
    if isinstance(v, list) and any(isinstance(x, int) and abs(x) >= 10**20 for x in v
                                   if not isinstance(x, bool)):
        return "[" + ", ".join(_shown(x) if isinstance(x, int) else repr(x) for x in v) + "]"
    return repr(v)


def _check_range(path, key, field, v):
    bad = ((field.positive and not v > 0) or (field.lo is not None and v < field.lo)
           or (field.hi is not None and v > field.hi))
    if bad:
        raise key_error(path, key, f"expected {field.describe()}, got {_shown(v)}")
    if v != 0 and not 1.0 / MAX_MAGNITUDE <= abs(v) <= MAX_MAGNITUDE:
        raise key_error(path, key, f"expected 0 or {1 / MAX_MAGNITUDE:g} <= |value| <="
                        f" {MAX_MAGNITUDE:g}, got {_shown(v)}")


def _check_value(path, key, field, value):
    t = field.type
    if field.allow_off and value is False:
        return False
    if t == "number":
        if not _is_number(value) or _finite_float(value) is None:
            raise key_error(path, key, f"expected a finite number, got {_shown(value)}")
        value = float(value)
        _check_range(path, key, field, value)
        return value
    if t == "numbers":
        if not isinstance(value, list) or not all(_is_number(v) for v in value):
            raise key_error(path, key, f"expected a list of numbers, got {_shown(value)}")
        if not all(_finite_float(v) is not None for v in value):
            raise key_error(path, key, f"numbers must be finite, got {_shown(value)}")
        if len(value) > MAX_LIST:
            raise key_error(path, key, f"at most {MAX_LIST} numbers, got {len(value)}")
        if field.length is not None and len(value) != field.length:
            raise key_error(path, key, f"expected {field.length} numbers, got {value!r}")
        for v in value:
            _check_range(path, key, field, v)
        return tuple(float(v) for v in value)
    if t == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise key_error(path, key, f"expected an integer, got {_shown(value)}")
        _check_range(path, key, field, value)
        return value
    if t == "bool":
        if not isinstance(value, bool):
            raise key_error(path, key, f"expected true or false, got {value!r}")
        return value
    if t == "str":
        if not isinstance(value, str):
            raise key_error(path, key, f"expected a string, got {value!r}")
        if field.choices and value not in field.choices:
            raise key_error(path, key, f"expected one of {', '.join(field.choices)}, got {value!r}")
        return value
    raise ValueError(f"schema: unknown field type {t!r}")


def _default(field):
    d = field.default
    return tuple(d) if isinstance(d, (list, tuple)) else d


def validate(path: str | Path, data: dict, schema: dict, key: tuple = ()) -> dict:
    """Validate ``data`` (a parsed TOML table) against ``schema``; fill defaults.

    Parameters
    ----------
    path : str or pathlib.Path
        The file, named in every error.
    data : dict
        The parsed table.
    schema : dict
        Key -> :class:`Field`, nested dict (sub-table) or :class:`ArrayOf`.
    key : tuple of str
        Key path of ``data`` inside the document (for messages).

    Returns
    -------
    dict
        Every key of the schema: validated values (lists become tuples), defaults for
        absent keys, ``None`` for absent sub-tables and arrays of tables.

    Raises
    ------
    SpecError
        Naming the file, the key path and what was expected.
    """
    if not isinstance(data, dict):
        raise key_error(path, key, f"expected a table, got {data!r}")
    for k in data:
        if k not in schema:
            close = difflib.get_close_matches(k, list(schema), n=1, cutoff=0.5)
            if close:          # the nearest key is enough: the file's reference lists the rest
                hint = f"; did you mean '{close[0]}'?"
            elif len(schema) <= SHORT_TABLE:
                hint = f"; expected one of {', '.join(schema)}"
            else:
                hint = (f"; no key of this {'table' if key else 'file'} is close (its"
                        f" {len(schema)} keys are in the file's reference)")
            raise key_error(path, key + (k,), f"unknown key{hint}")
    out = {}
    for k, spec in schema.items():
        if isinstance(spec, dict):
            out[k] = validate(path, data[k], spec, key + (k,)) if k in data else None
        elif isinstance(spec, ArrayOf):
            if k not in data:
                out[k] = None
                continue
            items = data[k]
            if not isinstance(items, list) or not all(isinstance(d, dict) for d in items):
                raise key_error(path, key + (k,), "expected an array of tables [[...]]")
            if len(items) > spec.max_items:
                raise key_error(path, key + (k,), f"at most {spec.max_items} tables, got {len(items)}")
            out[k] = tuple(validate(path, d, spec.table, key + (k, str(i)))
                           for i, d in enumerate(items))
        elif k in data:
            out[k] = _check_value(path, key + (k,), spec, data[k])
        elif spec.required:
            raise key_error(path, key + (k,), f"missing required key ({spec.doc})")
        else:
            out[k] = _default(spec)
    return out


def load_toml(path: str | Path, what: str = "file") -> dict:
    """Read and parse a UTF-8 TOML file; every failure is a one-line :class:`SpecError`.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    what : str
        What the file is ("problem file", "twin file"), for messages.

    Returns
    -------
    dict
        The parsed document (not validated).

    Raises
    ------
    SpecError
        A missing, unreadable or non-UTF-8 file, invalid TOML, or an empty document.
    """
    path = Path(path)
    text = read_utf8(path, what, "TOML", SpecError)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: invalid TOML ({exc})") from None
    if not doc:
        raise SpecError(f"{path}: empty {what}; expected TOML tables (see docs/reference/)")
    return doc


def markdown_rows(schema: dict, prefix: str = "") -> list[str]:
    """The file-format reference as Markdown rows ``| table | key | type | required | default | meaning |``.

    Parameters
    ----------
    schema : dict
        Key -> :class:`Field`, nested dict or :class:`ArrayOf`.
    prefix : str
        Table path of ``schema`` followed by a dot (``"family.models[]."``); ``""`` at
        the top level.

    Returns
    -------
    list of str
        One row per key, nested tables after their parent's keys.
    """
    rows = []
    for key, spec in schema.items():
        if isinstance(spec, dict):
            rows.extend(markdown_rows(spec, f"{prefix}{key}."))
        elif isinstance(spec, ArrayOf):
            rows.extend(markdown_rows(spec.table, f"{prefix}{key}[]."))
        else:
            default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
            accepted = spec.describe()
            doc = spec.doc if accepted == TYPE_NAMES[spec.type] else f"{spec.doc} ({accepted})"
            rows.append(f"| `{prefix[:-1]}` | `{key}` | {TYPE_NAMES[spec.type]}"
                        f" | {'yes' if spec.required else 'no'} | {default!r}"
                        f" | {doc.replace('|', chr(92) + '|')} |")
    return rows
