"""Output files: atomic writes with the user's umask, and robrst's JSON text.

Every report, dataset and JSON file robrst writes goes through these helpers: the
content is written to a temporary file in the target folder, flushed, given the
permissions a plain ``open(path, "w")`` would give (the user's umask), and renamed
over the target (``os.replace`` is atomic on POSIX and Windows).
"""

from __future__ import annotations

import errno
import json
import math
import os
import signal
import socket
import stat
import tempfile
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:     # pragma: no cover - not POSIX: no advisory locks
    fcntl = None

import numpy as np

from robrst.base.errors import OutputError

__all__ = ["atomic_write_bytes", "atomic_write_text", "json_text", "jsonable", "umask_mode",
           "check_file_target", "check_folder_target", "check_json_target", "read_utf8",
           "read_input_bytes", "check_input_file", "peek_text", "output_lock", "owner_tag",
           "owner_alive", "signals_deferred", "WRITTEN_BY", "MAX_TOML_BYTES", "MAX_TEXT_BYTES"]

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


# the largest input robrst reads into memory: a TOML file (problem, twin, sweep, golden,
# model) and any other text (a CSV record of ~25 million rows); /dev/zero or a runaway
# file is refused instead of filling the memory
MAX_TOML_BYTES = 16 * 2**20
MAX_TEXT_BYTES = 2**30


def check_input_file(path: str | os.PathLike, what: str, error: type[Exception],
                     kind: str | None = None) -> os.stat_result:
    """Refuse an input that is not a regular file, before opening it.

    A FIFO would block the read until a writer appears (``robrst design fifo`` hung), a
    device such as ``/dev/zero`` never ends, a folder or a symbolic-link loop has no
    content.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages ("problem file", "data file").
    error : type
        The robrst exception to raise.
    kind : str, optional
        Its format ("TOML", "CSV"), named when the path is a folder.

    Returns
    -------
    os.stat_result

    Raises
    ------
    Exception
        ``error``, naming ``path``: not found, a broken link, a symbolic-link loop, a
        folder, a FIFO, a device or a socket.
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if path.is_symlink():
            raise error(f"{path}: is a broken symbolic link; expected a {what}") from None
        raise error(f"{path}: {what} not found") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise error(f"{path}: is a symbolic-link loop; expected a {what}") from None
        raise error(f"{path}: cannot read the {what} ({exc.strerror})") from None
    if stat.S_ISDIR(st.st_mode):
        raise error(f"{path}: is a folder, expected a {what}" + (f" ({kind})" if kind else ""))
    if not stat.S_ISREG(st.st_mode):
        kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else
                "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise error(f"{path}: is {kind}, not a regular file; expected a {what}")
    return st


def read_input_bytes(path: str | os.PathLike, what: str, error: type[Exception],
                     limit: int = MAX_TEXT_BYTES, kind: str | None = None) -> bytes:
    """The bytes of a regular input file of at most ``limit`` bytes (one bounded,
    non-blocking read); every failure is one ``error`` naming ``path``.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages.
    error : type
        The robrst exception to raise.
    limit : int
        Largest size [bytes].
    kind : str, optional
        Its format, named when the path is a folder.

    Returns
    -------
    bytes

    Raises
    ------
    Exception
        ``error``: what :func:`check_input_file` refuses, an unreadable file, a file
        larger than ``limit``.
    """
    path = Path(path)
    check_input_file(path, what, error, kind)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            raw = fh.read(limit + 1)
    except IsADirectoryError:
        raise error(f"{path}: is a folder, expected a {what}") from None
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    if len(raw) > limit:
        raise error(f"{path}: larger than {limit / 2**20:g} MiB; expected a {what} of at most"
                    " that size")
    return raw


def read_utf8(path: Path, what: str, kind: str, error: type[Exception],
              limit: int | None = None) -> str:
    """The text of a UTF-8 file (BOM dropped); every failure is one ``error`` naming ``path``.

    A regular file only (no FIFO or device), read in one bounded read.

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
        missing or unreadable file, a FIFO, a device, a file above ``limit``, UTF-16 text
        and a byte that is not UTF-8 (with its line).
    limit : int, optional
        Largest size [bytes]; default :data:`MAX_TOML_BYTES` for TOML, else
        :data:`MAX_TEXT_BYTES`.

    Returns
    -------
    str
        The decoded text without a leading byte-order mark.
    """
    if limit is None:
        limit = MAX_TOML_BYTES if kind == "TOML" else MAX_TEXT_BYTES
    raw = read_input_bytes(path, what, error, limit, kind)
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise error(f"{path}: {what} is UTF-16; save it as UTF-8")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise error(f"{path}: line {line}: not valid UTF-8 (byte 0x{raw[exc.start]:02x});"
                    f" save the {what} as UTF-8") from None
    return text.removeprefix("\ufeff")


def peek_text(path: str | os.PathLike, limit: int = 2**20) -> str | None:
    """The text (UTF-8, undecodable bytes replaced) of an existing regular file of at most
    ``limit`` bytes, else ``None``: for deciding whether robrst wrote an output it is about
    to replace (a FIFO, a device or a huge file there is not robrst's).

    Parameters
    ----------
    path : str or Path
    limit : int
        Largest size read [bytes].

    Returns
    -------
    str or None
    """
    try:
        st = os.stat(path)
    except OSError:
        return None
    if not stat.S_ISREG(st.st_mode) or st.st_size > limit:
        return None
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            return fh.read(limit).decode("utf-8", errors="replace")
    except OSError:
        return None


def _check_links(path, expected):
    """Refuse a path that is, or lies under, a symbolic-link loop (or a broken link)."""
    for p in reversed((path, *path.parents)):      # the outermost offending part first
        try:
            os.stat(p)
        except FileNotFoundError:
            if p.is_symlink():
                raise OutputError(f"{path}: {'it' if p == path else p} is a broken symbolic"
                                  f" link; expected {expected}") from None
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise OutputError(f"{path}: {'it' if p == path else p} is a symbolic-link"
                                  f" loop; expected {expected}") from None


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
    _check_links(path, "a file name")
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
            doc = json.loads(peek_text(path, 64 * 2**20) or "")
        except ValueError:
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
    _check_links(path, "a folder")
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


def owner_tag() -> str:
    """``"PID HOST"``: who made a temporary file or folder (see :func:`owner_alive`).

    Returns
    -------
    str
    """
    return f"{os.getpid()} {socket.gethostname()}"


def owner_alive(tag: str) -> bool:
    """Whether the process of an :func:`owner_tag` may still run (``True`` when unsure:
    another host, an unreadable tag).

    Parameters
    ----------
    tag : str

    Returns
    -------
    bool
    """
    try:
        pid, host = tag.split()[:2]
        pid = int(pid)
    except (AttributeError, ValueError):
        return True
    if host != socket.gethostname():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


@contextmanager
def signals_deferred() -> Iterator[None]:
    """SIGINT and SIGTERM held back (delivered when the block ends) for steps that must not
    stop half-way, such as swapping a report folder: a Ctrl-C between its two renames
    would leave the earlier report renamed away.  A no-op outside the main thread or
    without ``pthread_sigmask``.

    Yields
    ------
    None
    """
    if not hasattr(signal, "pthread_sigmask") or \
            threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _acquire(lock, path, deadline, what, option, held):
    """Flock ``lock``; its descriptor is appended to ``held`` before any signal can stop the
    caller (see :func:`output_lock`)."""
    while True:
        with signals_deferred():          # no descriptor or file left half-made by a signal
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd = os.open(lock, os.O_RDWR | os.O_CREAT, umask_mode())
            except OSError as exc:
                raise OutputError(f"{path}: cannot write here ({exc.strerror or exc})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                fd = None
            if fd is not None:
                try:     # the holder before may have removed the file between open and lock
                    same = os.fstat(fd).st_ino == os.stat(lock).st_ino
                except OSError:
                    same = False
                if same:
                    held.append(fd)
                    os.ftruncate(fd, 0)
                    os.write(fd, (owner_tag() + "\n").encode())
                    return
                os.close(fd)
                continue
        if time.monotonic() >= deadline:
            raise OutputError(f"{path}: another robrst run is writing this {what} now;"
                              f" wait for it to finish or choose another {option}")
        time.sleep(0.05)


@contextmanager
def output_lock(path: str | os.PathLike, wait_s: float = 0.0, what: str = "output folder",
                option: str = "--out") -> Iterator[None]:
    """One robrst writer at a time for the output ``path`` (an advisory lock).

    The lock is the file ``.NAME.lock`` beside ``path`` (``flock``, released when the
    process ends however it ends, removed on release).  A second writer waits up to
    ``wait_s`` seconds, then gets an :class:`~robrst.base.errors.OutputError` naming the
    path and ``option``.

    Parameters
    ----------
    path : str or Path
        The output file or folder.
    wait_s : float
        How long to wait for another writer to finish.
    what, option : str
        For the message.

    Yields
    ------
    None
        While the lock is held.

    Raises
    ------
    OutputError
        Another writer holds the lock beyond ``wait_s``, or the folder cannot hold the
        lock file.
    """
    path = Path(path)
    if fcntl is None:       # pragma: no cover
        yield
        return
    lock = path.parent / f".{path.name}.lock"
    held = []
    try:
        _acquire(lock, path, time.monotonic() + float(wait_s), what, option, held)
        yield
    finally:
        if held:
            with signals_deferred():
                try:
                    os.unlink(lock)
                except OSError:
                    pass
                os.close(held[0])


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
