"""Output files: atomic writes with the user's umask, and robrst's JSON text.

Every report, dataset and JSON file robrst writes goes through these helpers: the
content is written to a temporary file in the target folder, flushed, given the
permissions a plain ``open(path, "w")`` would give (the user's umask), and renamed
over the target (``os.replace`` is atomic on POSIX and Windows).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from robrst.base.errors import OutputError

__all__ = ["atomic_write_bytes", "atomic_write_text", "json_text", "jsonable", "umask_mode",
           "check_file_target", "check_folder_target", "check_json_target", "read_utf8",
           "WRITTEN_BY"]

WRITTEN_BY = "written_by"   # the key of a JSON file robrst wrote: "robrst <command>"


def umask_mode(mode: int = 0o666) -> int:
    """``mode`` with the process's umask applied (what ``open`` would create).

    Parameters
    ----------
    mode : int
        Permission bits before the umask.

    Returns
    -------
    int
        ``mode & ~umask``.
    """
    mask = os.umask(0)
    os.umask(mask)
    return mode & ~mask


def read_utf8(path: Path, what: str, kind: str, error: type[Exception]) -> str:
    """The text of a UTF-8 file (BOM dropped); every failure is one ``error`` naming ``path``.

    Parameters
    ----------
    path : pathlib.Path
        The file to read.
    what : str
        What the file is, for messages ("problem file", "data file").
    kind : str
        Its format, for the folder message ("TOML", "CSV").
    error : type
        The robrst exception to raise (``SpecError``, ``DataError``): for a folder, a
        missing or unreadable file, UTF-16 text and a byte that is not UTF-8 (with its line).

    Returns
    -------
    str
        The decoded text without a leading byte-order mark.
    """
    try:
        raw = path.read_bytes()
    except IsADirectoryError:
        raise error(f"{path}: is a folder, expected a {what} ({kind})") from None
    except FileNotFoundError:
        raise error(f"{path}: {what} not found") from None
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} ({exc.strerror})") from None
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise error(f"{path}: {what} is UTF-16; save it as UTF-8")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise error(f"{path}: line {line}: not valid UTF-8 (byte 0x{raw[exc.start]:02x});"
                    f" save the {what} as UTF-8") from None
    return text.removeprefix("\ufeff")


def _check_parents(path):
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputError(f"{path}: {parent} is a file, not a folder")
    # the nearest existing folder must take new entries (the file or its missing folders)
    near = next((p for p in (path.parent, *path.parent.parents) if p.is_dir()), None)
    if near is not None and not os.access(near, os.W_OK | os.X_OK):
        raise OutputError(f"{path}: the folder {near} is not writable")


def check_file_target(path: str | Path) -> Path:
    """Refuse an output file name that cannot be written: a folder, or a path under a file.

    Commands call it before any work, so a mistyped output fails at once.

    Parameters
    ----------
    path : str or pathlib.Path
        The output file name.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.

    Raises
    ------
    OutputError
        Naming the path and what was expected.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path}: is a folder; expected a file name")
    _check_parents(path)
    return path


def check_json_target(path: str | Path, other_outputs: Iterable[str | Path | None] = ()) -> Path:
    """Refuse a ``--json`` output file robrst may not write: what :func:`check_file_target`
    refuses, one of ``other_outputs`` (the command's other output files), and an existing
    file that is not a JSON object robrst wrote (its ``"written_by"`` starts ``robrst``).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``--json`` file name.
    other_outputs : iterable of str or pathlib.Path
        The other files the same command writes (``None`` entries are ignored).

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.

    Raises
    ------
    OutputError
        Naming the path and what was expected.
    """
    path = check_file_target(path)
    for other in other_outputs:
        if other is not None and Path(other).resolve() == path.resolve():
            raise OutputError(f"{path}: the command writes another output there ({other});"
                              " expected a separate --json file")
    if path.exists() or path.is_symlink():
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError):
            doc = None
        if not (isinstance(doc, dict) and str(doc.get(WRITTEN_BY, "")).startswith("robrst")):
            raise OutputError(f"{path}: exists and was not written by robrst; not overwriting"
                              " it (choose another --json file)")
    return path


def check_folder_target(path: str | Path) -> Path:
    """Refuse an output folder that cannot be created: an existing file, or a path under a file.

    Parameters
    ----------
    path : str or pathlib.Path
        The output folder.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.

    Raises
    ------
    OutputError
        Naming the path and what was expected.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"{path}: is a file; expected a folder")
    _check_parents(path)
    return path


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; create the parent folder if needed (a
    symbolic link is kept: the file it names is replaced).

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write (checked by :func:`check_file_target`).
    data : bytes
        The content.

    Returns
    -------
    pathlib.Path
        The file written (the link's target for a symbolic link).

    Raises
    ------
    OutputError
        Naming ``path`` when the system refuses the folder or the file.
    """
    path = check_file_target(path)
    if path.is_symlink():           # a link stays a link: the file it names is replaced
        path = Path(os.path.realpath(path))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise OutputError(f"{path}: cannot write here ({exc.strerror or exc})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, umask_mode())
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise OutputError(f"{path}: cannot write here ({exc.strerror or exc})") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically (:func:`atomic_write_bytes`).

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    text : str
        The content, encoded as UTF-8.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    return atomic_write_bytes(path, text.encode("utf-8"))


def jsonable(x: Any) -> Any:
    """``x`` with numpy scalars/arrays as Python values and non-finite floats as ``None``.

    JSON has no ``inf``/``nan``; robrst's contract writes ``null`` for an infinite
    margin or gain.

    Parameters
    ----------
    x : object
        Dicts, lists, tuples, numpy arrays and scalars are converted recursively (dict
        keys become strings); anything else is returned as it is.

    Returns
    -------
    object
        A value ``json.dumps`` accepts with ``allow_nan=False``.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.base.fileio import jsonable
    >>> jsonable({"gm": np.inf, "poles": np.array([-1.0, -2.0]), 1: np.int64(3)})
    {'gm': None, 'poles': [-1.0, -2.0], '1': 3}
    """
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x


def json_text(obj: Any, indent: int | None = None) -> str:
    """robrst's JSON text of ``obj`` (see :func:`jsonable`).

    Parameters
    ----------
    obj : object
        What to write.
    indent : int, optional
        Indentation of ``json.dumps`` (``None``: one line).

    Returns
    -------
    str
        Strict JSON (no ``NaN`` or ``Infinity``).
    """
    return json.dumps(jsonable(obj), allow_nan=False, indent=indent)
