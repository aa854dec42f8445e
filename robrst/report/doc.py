"""One document, two renderings: Markdown and self-contained-folder HTML.

A report is a list of blocks — ``("h2", text)``, ``("p", text)``,
``("table", header, rows)``, ``("img", file, caption)``, ``("pre", text)`` — rendered
to ``report.md`` and ``report.html`` with the same content; figures are PNG files
beside them.  :func:`write_folder` writes the whole folder atomically: it is built
in a temporary sibling and swapped in, so a failure never leaves half a report.
"""

import html
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Doc", "to_markdown", "to_html", "write_folder"]

_CSS = ("body{font-family:system-ui,sans-serif;max-width:60em;margin:2em auto;padding:0 1em;"
        "color:#222}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
        "padding:.25em .6em;text-align:right}th{background:#eee}img{max-width:100%}"
        "pre{background:#f6f6f6;padding:.8em;overflow-x:auto}figcaption{color:#555}")


@dataclass(frozen=True)
class Doc:
    """A titled list of blocks (see the module docstring)."""

    title: str
    blocks: tuple

    def images(self):
        return [b[1] for b in self.blocks if b[0] == "img"]


def _cell(x):
    return "" if x is None else str(x)


def to_markdown(doc):
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


def to_html(doc):
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
            out += ["<tr>" + "".join(f"<td>{e(_cell(c))}</td>" for c in row) + "</tr>"
                    for row in b[2]]
            out.append("</table>")
        else:
            raise ValueError(f"unknown block kind {kind!r}")
    out.append("</body></html>")
    return "\n".join(out)


def write_folder(out_dir, doc, extra_files, render_figures):
    """Write ``report.md``, ``report.html``, ``extra_files`` and the figures atomically.

    ``render_figures(tmp_dir)`` draws every image the document references into
    ``tmp_dir``; ``extra_files`` maps file names to text (e.g. the JSON result).
    """
    out = Path(out_dir)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    tmp.chmod(0o755)
    try:
        render_figures(tmp)
        missing = [f for f in doc.images() if not (tmp / f).is_file()]
        if missing:
            raise RuntimeError(f"report figures not drawn: {missing}")
        (tmp / "report.md").write_text(to_markdown(doc) + "\n")
        (tmp / "report.html").write_text(to_html(doc) + "\n")
        for name, text in extra_files.items():
            (tmp / name).write_text(text)
        old = None
        if out.exists():
            old = out.with_name(f".{out.name}.old.{os.getpid()}")
            os.replace(out, old)
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out
