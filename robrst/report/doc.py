"""One document, two renderings: Markdown and self-contained-folder HTML.

A report is a list of blocks — ``("h2", text)``, ``("p", text)``,
``("table", header, rows)``, ``("img", file, caption)``, ``("pre", text)`` — rendered
to ``report.md`` and ``report.html`` with the same content; figures are PNG files
beside them.  :func:`write_folder` writes the whole folder atomically: it is built
in a temporary sibling and swapped in, so a failure never leaves half a report.
"""

from __future__ import annotations

import html
import os
import shutil
import socket
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from robrst.base.errors import OutputError
from robrst.base.fileio import (atomic_write_bytes, check_folder_target, output_lock,
                                owner_alive, owner_tag, peek_text, signals_deferred,
                                umask_mode)

__all__ = ["Doc", "to_markdown", "to_html", "write_folder", "check_report_target", "MARKER"]

_CSS = ("body{font-family:system-ui,sans-serif;max-width:60em;margin:2em auto;padding:0 1em;"
        "color:#222}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
        "padding:.25em .6em;text-align:right}th{background:#eee}img{max-width:100%}"
        "pre{background:#f6f6f6;padding:.8em;overflow-x:auto}figcaption{color:#555}")


@dataclass(frozen=True)
class Doc:
    """A titled list of blocks (see the module docstring).

    Parameters
    ----------
    title : str
        The document's title.
    blocks : tuple
        ``("h2", text)``, ``("p", text)``, ``("table", header, rows)``,
        ``("img", file, caption)``, ``("pre", text)``.
    """

    title: str
    blocks: tuple

    def images(self) -> list[str]:
        """The image files the document references, in order.

        Returns
        -------
        list of str
        """
        return [b[1] for b in self.blocks if b[0] == "img"]


def _text(x):
    return "" if x is None else str(x)


def _cell(x):
    """A Markdown table cell: a ``|`` in the text (``|T| peak``) escaped."""
    return _text(x).replace("|", "\\|")


def to_markdown(doc: Doc) -> str:
    """The document as Markdown (``report.md``).

    Parameters
    ----------
    doc : Doc
        The document.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        For an unknown block kind.
    """
    out = [f"# {doc.title}", ""]
    for b in doc.blocks:
        kind = b[0]
        if kind == "h2":
            out += [f"## {b[1]}", ""]
        elif kind == "p":
            out += [b[1], ""]
        elif kind == "pre":
            out += ["```", b[1], "```", ""]
        elif kind == "img":
            out += [f"![{b[2]}]({b[1]})", "", f"*{b[2]}*", ""]
        elif kind == "table":
            out.append("| " + " | ".join(b[1]) + " |")
            out.append("|" + "---|" * len(b[1]))
            out += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in b[2]]
            out.append("")
        else:
            raise ValueError(f"unknown block kind {kind!r}")
    return "\n".join(out)


def to_html(doc: Doc) -> str:
    """The document as a self-contained HTML page (``report.html``; images beside it).

    Parameters
    ----------
    doc : Doc
        The document.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        For an unknown block kind.
    """
    e = html.escape
    out = ["<!DOCTYPE html>", "<html lang=\"en\"><head><meta charset=\"utf-8\">",
           f"<title>{e(doc.title)}</title><style>{_CSS}</style></head><body>",
           f"<h1>{e(doc.title)}</h1>"]
    for b in doc.blocks:
        kind = b[0]
        if kind == "h2":
            out.append(f"<h2>{e(b[1])}</h2>")
        elif kind == "p":
            out.append(f"<p>{e(b[1])}</p>")
        elif kind == "pre":
            out.append(f"<pre>{e(b[1])}</pre>")
        elif kind == "img":
            out.append(f"<figure><img src=\"{e(b[1])}\" alt=\"{e(b[2])}\">"
                       f"<figcaption>{e(b[2])}</figcaption></figure>")
        elif kind == "table":
            out.append("<table><tr>" + "".join(f"<th>{e(h)}</th>" for h in b[1]) + "</tr>")
            out += ["<tr>" + "".join(f"<td>{e(_text(c))}</td>" for c in row) + "</tr>"
                    for row in b[2]]
            out.append("</table>")
        else:
            raise ValueError(f"unknown block kind {kind!r}")
    out.append("</body></html>")
    return "\n".join(out)


MARKER = ".robrst-report"
PARTIAL = ".robrst-partial"     # in a report folder being built: "PID HOST" of its writer
LOCK_WAIT_S = 120.0             # a second writer of one folder waits for the first's swap


def check_report_target(out: str | Path, force: bool = False, option: str = "--out",
                        can_force: bool = True) -> str:
    """Refuse report folders whose replacement could lose what robrst did not write.

    Called before any work by the commands, and again when writing.

    Parameters
    ----------
    out : str or pathlib.Path
        The report folder.
    force : bool
        The user allows writing into a folder robrst did not write.
    option : str
        The command's flag for the folder, named in the messages.
    can_force : bool
        Whether the command offers ``--force`` (named in the messages).

    Returns
    -------
    str
        How the folder will be written: ``"new"``, ``"replace"`` (an earlier robrst
        report) or ``"merge"`` (``force``).

    Raises
    ------
    OutputError
        The current folder or one of its parents, a file, or a folder robrst did not
        write (without ``force``).
    """
    hint = f"choose another {option}" + (", or --force to write the report files into it"
                                         " (nothing else is touched)" if can_force else "")
    out = Path(out)
    check_folder_target(out)             # no symbolic-link loop, no file above it
    resolved = out.resolve()
    cwd = Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise OutputError(f"{out}: refusing to write a report over the current folder or one"
                          f" of its parents; give a new folder name with {option}")
    if resolved.exists() and not resolved.is_dir():
        raise OutputError(f"{out}: is a file; expected a report folder")
    check_folder_target(out)             # no file above it, a writable folder
    if not resolved.is_dir() or not any(resolved.iterdir()):
        return "new"
    marker = resolved / MARKER
    if not marker.is_file():
        if force:
            return "merge"
        raise OutputError(f"{out}: folder exists and is not a robrst report (no {MARKER});"
                          f" refusing to replace it; {hint}")
    ours = set(marker.read_text(encoding="utf-8", errors="replace").split()) | {MARKER}
    extra = sorted(p.name for p in resolved.iterdir() if p.name not in ours)
    if extra:
        if force:
            return "merge"
        raise OutputError(f"{out}: the report folder holds files robrst did not write"
                          f" ({', '.join(extra[:5])}); refusing to replace it; {hint}")
    return "replace"


def write_folder(out_dir: str | Path, doc: Doc, extra_files: dict[str, str],
                 render_figures: Callable[[Path], None], force: bool = False) -> Path:
    """Write ``report.md``, ``report.html``, ``extra_files`` and the figures.

    A new folder, or an earlier robrst report (recognised by its ``.robrst-report``
    marker, listing the files robrst wrote), is replaced atomically: the report is built
    in a temporary sibling and swapped in, so a failure never leaves half a report.  A
    folder robrst did not write is refused (:class:`~robrst.base.errors.OutputError`) unless
    ``force``, which writes the report files into it one by one, atomically, and touches
    nothing else.  A symbolic link to a folder stays a link: the folder it names is written.

    One writer at a time (:func:`robrst.base.fileio.output_lock`): a second run writing
    the same folder waits for the first's swap (up to :data:`LOCK_WAIT_S`), then replaces
    its report.  The temporary folder is removed on any exception (the command line turns
    SIGTERM into one, as Ctrl-C); one left by a killed process is removed by the next
    writer of the folder.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        The report folder.
    doc : Doc
        The document.
    extra_files : dict
        File name -> text (e.g. the JSON result).
    render_figures : callable
        ``render_figures(tmp_dir)`` draws every image the document references into
        ``tmp_dir``.
    force : bool
        Write into a folder robrst did not write.

    Returns
    -------
    pathlib.Path
        The folder, as given.

    Raises
    ------
    OutputError
        See :func:`check_report_target`; also a folder the system refuses.
    RuntimeError
        When ``render_figures`` did not draw every image the document references.
    """
    given = out = Path(out_dir)
    check_report_target(out, force)
    if out.is_symlink():              # a link to a report folder: the folder it names is written
        out = Path(os.path.realpath(out))
    tmp = None
    try:
        # the folder and its name together: a signal between them (a SIGTERM the moment the
        # folder appears, seen under load) left it behind, unnamed, never removed
        with signals_deferred():
            try:
                out.parent.mkdir(parents=True, exist_ok=True)
                tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
            except OSError as exc:
                raise OutputError(f"{out}: cannot write here ({exc.strerror or exc})") from None
        (tmp / PARTIAL).write_text(owner_tag() + "\n", encoding="utf-8")
        tmp.chmod(umask_mode(0o777))
        render_figures(tmp)
        missing = [f for f in doc.images() if not (tmp / f).is_file()]
        if missing:
            raise RuntimeError(f"report figures not drawn: {missing}")
        texts = {"report.md": to_markdown(doc) + "\n", "report.html": to_html(doc) + "\n",
                 **extra_files}
        for name, text in texts.items():
            (tmp / name).write_text(text, encoding="utf-8")
        names = sorted(p.name for p in tmp.iterdir() if p.name != PARTIAL)
        (tmp / MARKER).write_text("\n".join(names) + "\n", encoding="utf-8")
        for p in tmp.iterdir():
            p.chmod(umask_mode())
        # one writer at a time: another run writing the same folder finishes its swap first
        with output_lock(out, wait_s=LOCK_WAIT_S, what="report folder"):
            _remove_stale(out)
            mode = check_report_target(given, force)     # again: the folder may have changed
            (tmp / PARTIAL).unlink()
            if mode == "merge":
                for p in sorted(tmp.iterdir()):
                    atomic_write_bytes(out / p.name, p.read_bytes())
                shutil.rmtree(tmp)
                return given
            with signals_deferred():     # the earlier report or the new one, never neither
                old = None
                if mode == "replace":
                    old = out.with_name(f".{out.name}.old.{os.getpid()}")
                    os.replace(out, old)
                os.replace(tmp, out)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        raise
    return given


def _remove_stale(out):
    """Remove what an earlier writer of ``out`` left when it was killed (SIGKILL, power
    loss): its temporary siblings ``.NAME.XXXXXXXX`` (marked :data:`PARTIAL` with the
    owner's process, which no longer runs) and ``.NAME.old.PID`` of a process that no
    longer runs.  Called with the folder's lock held; nothing else is touched."""
    for p in out.parent.glob(f".{out.name}.*"):
        if not p.is_dir() or p.is_symlink():
            continue
        mark = p / PARTIAL
        if mark.is_file():
            if not owner_alive(peek_text(mark) or ""):
                shutil.rmtree(p, ignore_errors=True)
            continue
        tail = p.name[len(out.name) + 2:]
        if tail.startswith("old.") and tail[4:].isdigit() and (p / MARKER).is_file() \
                and not owner_alive(f"{tail[4:]} {socket.gethostname()}"):
            shutil.rmtree(p, ignore_errors=True)
