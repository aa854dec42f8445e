"""TOML that robrst writes (golden files, identified problem and model files), by tomlkit.

robrst's files are built as :mod:`tomlkit` documents, which quote and escape every string
and key as TOML requires and keep the comments robrst writes for the reader.  What this
module adds is what a document needs before it reaches tomlkit:

* :func:`plain` turns numpy numbers and arrays into Python ones and replaces an
  undecodable byte of a file name (a lone surrogate, which no UTF-8 file can hold) by U+FFFD;
* :func:`comment_text` makes any text safe on one ``#`` comment line (TOML forbids control
  characters there).

Every file written this way is read back by :mod:`tomllib` to the same values (tests:
``tests/base/test_tomlwrite.py`` and the writers' round-trip tests).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import tomlkit

__all__ = ["plain", "comment_text", "document", "inline"]


def _text(s: str) -> str:
    return "".join("\uFFFD" if 0xD800 <= ord(ch) <= 0xDFFF else ch for ch in s)


def plain(value: Any) -> Any:
    """``value`` with numpy numbers and arrays as Python ones, strings UTF-8-safe.

    Parameters
    ----------
    value : object
        A number, bool, string, numpy scalar or array, or a (nested) list, tuple or
        mapping of them.

    Returns
    -------
    object
        The same value as ``bool``, ``int``, ``float``, ``str``, ``list`` or ``dict``
        (mapping keys made UTF-8-safe too); lone surrogates become U+FFFD.

    Raises
    ------
    TypeError
        For a value TOML cannot hold (``None``, an object).

    Examples
    --------
    >>> import numpy as np
    >>> plain({"B": np.array([1.0, 2.5]), "n": np.int64(3), "name": "a\\udcff"})
    {'B': [1.0, 2.5], 'n': 3, 'name': 'a�'}
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, str):
        return _text(value)
    if isinstance(value, np.ndarray):
        return [plain(v) for v in value.tolist()]
    if isinstance(value, Mapping):
        return {_text(str(k)): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    raise TypeError(f"a TOML value cannot be {type(value).__name__}: {value!r}")


def comment_text(text: str) -> str:
    """``text`` safe on one ``#`` comment line.

    Control characters are shown as Python escapes (a line break as a backslash and
    ``n``), undecodable bytes of a file name as U+FFFD.

    Parameters
    ----------
    text : str
        Any text (a record's file name, a problem name).

    Returns
    -------
    str
        Printable text without line breaks.

    Examples
    --------
    >>> comment_text("a\\nb")
    'a\\\\nb'
    """
    return "".join("\uFFFD" if 0xD800 <= ord(ch) <= 0xDFFF else
                   ch if ord(ch) >= 0x20 and ord(ch) != 0x7F else repr(ch)[1:-1]
                   for ch in str(text))


def document(header: Iterable[str] = ()) -> tomlkit.TOMLDocument:
    """A new tomlkit document that starts with the comment lines ``header``.

    Parameters
    ----------
    header : iterable of str
        Comment lines, without the ``#`` (each made safe by :func:`comment_text`).

    Returns
    -------
    tomlkit.TOMLDocument
        Add tables to it; ``tomlkit.dumps`` writes it.

    Examples
    --------
    >>> import tomlkit
    >>> doc = document(["written by an example"])
    >>> doc["plant"] = plain({"B": [1.0], "A": [1.0, 2.0]})
    >>> print(tomlkit.dumps(doc))
    # written by an example
    <BLANKLINE>
    [plant]
    B = [1.0]
    A = [1.0, 2.0]
    <BLANKLINE>
    """
    doc = tomlkit.document()
    lines = list(header)
    for line in lines:
        doc.add(tomlkit.comment(comment_text(line)))
    if lines:
        doc.add(tomlkit.nl())
    return doc


def inline(mapping: Mapping[str, Any]) -> tomlkit.items.InlineTable:
    """An inline table, spaced inside its braces as people write it: ``{ a = 1, b = 2 }``.

    Parameters
    ----------
    mapping : mapping
        Keys and values (values through :func:`plain`).

    Returns
    -------
    tomlkit.items.InlineTable

    Examples
    --------
    >>> import tomlkit
    >>> tomlkit.dumps({"Ms": inline({"value": 1.5, "rtol": 1e-4})})
    'Ms = { value = 1.5, rtol = 0.0001 }\\n'
    """
    table = tomlkit.inline_table()
    items = [(k, tomlkit.item(v)) for k, v in plain(dict(mapping)).items()]
    if items:
        items[0][1].trivia.indent = " "
        items[-1][1].trivia.trail = " "
    for k, v in items:
        table.append(k, v)
    return table
