"""A sweep's output folder: per-chunk Parquet parts, ``results.parquet``, ``summary.json``.

Layout of ``DIR``::

    .robrst-sweep       marker: which sweep wrote the folder (fingerprint), JSON
    chunks/part-000012.parquet   one file per finished chunk (written atomically)
    results.parquet     every finished variant, one row each, ordered by index
    summary.json        the summary (see robrst.studies.sweep.summary)
    report/             figures and report.md / report.html (robrst.report.sweep)

A folder robrst did not write (no marker, not empty) is refused; a folder of the same sweep
(same fingerprint) is resumed: finished chunks are kept and only the others run.  A
different sweep in the folder is refused unless ``restart``, which deletes only the files
listed above.  Nothing else in ``DIR`` is ever touched.
"""

from __future__ import annotations

import io
import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from robrst.base.errors import OutputError
from robrst.base.fileio import atomic_write_bytes, atomic_write_text, json_text

if TYPE_CHECKING:
    import pyarrow as pa

    from robrst.studies.sweep._evaluate import SweepContext
    from robrst.studies.sweep._variants import Chunk, VariantTable

__all__ = ["MARKER", "arrow_schema", "rows_table", "prepare_folder", "write_part",
           "done_chunks", "checked_chunks", "read_results", "write_results", "previous_runs",
           "write_summary", "PART"]

MARKER = ".robrst-sweep"
PART = re.compile(r"^part-(\d{6,})\.parquet$")


def arrow_schema(context: SweepContext) -> pa.Schema:
    """The columns of ``results.parquet`` for ``context`` (same for every chunk).

    Parameters
    ----------
    context : SweepContext
        The sweep's context (its parameter names and kind).

    Returns
    -------
    pyarrow.Schema
    """
    import pyarrow as pa

    fields = [pa.field("index", pa.int64()), pa.field("chunk", pa.int64())]
    if context.sweep.kind == "fleet":
        fields.append(pa.field("file", pa.string()))
    fields += [pa.field(n, pa.float64()) for n in context.names]
    fields += [pa.field(k, getattr(pa, t)()) for k, t in context.figure_columns().items()]
    fields += [pa.field(k, pa.list_(pa.float64()) if t == "list" else getattr(pa, t)())
               for k, t in context.controller_columns().items()]
    return pa.schema(fields)


def rows_table(rows: Sequence[dict], chunk: Chunk, context: SweepContext,
               table: VariantTable) -> pa.Table:
    """An Arrow table of one chunk's ``rows`` with the variants' parameters from ``table``.

    Parameters
    ----------
    rows : sequence of dict
        The chunk's rows, one per variant.
    chunk : Chunk
        The chunk.
    context : SweepContext
        The sweep's context.
    table : VariantTable
        The variants' parameter values.

    Returns
    -------
    pyarrow.Table
        With the schema of :func:`arrow_schema`.
    """
    import pyarrow as pa

    schema = arrow_schema(context)
    idx = [r["index"] for r in rows]
    cols = {"index": idx, "chunk": [chunk] * len(rows)}
    if context.sweep.kind == "fleet":
        cols["file"] = [table.labels[i] for i in idx]
    for j, name in enumerate(context.names):
        cols[name] = [float(table.values[i, j]) for i in idx]
    for f in schema:
        if f.name not in cols:
            cols[f.name] = [_plain(r.get(f.name)) for r in rows]
    return pa.Table.from_pydict(cols, schema=schema)


def _plain(x):
    if hasattr(x, "item"):      # numpy scalar
        return x.item()
    return x


def _check_target(out):
    resolved = out.resolve()
    for parent in resolved.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputError(f"{out}: {parent} is a file, not a folder")
    if resolved.exists() and not resolved.is_dir():
        raise OutputError(f"{out}: is a file; expected a sweep output folder")


def _own_files(out):
    files = [out / n for n in ("results.parquet", "summary.json")]
    chunks = out / "chunks"
    if chunks.is_dir():
        files += [p for p in chunks.iterdir() if PART.match(p.name)]
    return files


def prepare_folder(out: Path, meta: dict, restart: bool = False) -> bool:
    """Create or reopen the output folder of the sweep described by ``meta``.

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    meta : dict
        Written to the marker; ``meta["fingerprint"]`` identifies the sweep.
    restart : bool
        Discard robrst's earlier results in the folder (its own files only).

    Returns
    -------
    bool
        True when earlier results of the same sweep are kept (a resume).

    Raises
    ------
    OutputError
        The folder is not a robrst sweep folder, or holds a different sweep.
    """
    out = Path(out)
    _check_target(out)
    marker = out / MARKER
    if out.is_dir() and any(out.iterdir()) and not marker.is_file():
        raise OutputError(f"{out}: folder exists and is not a robrst sweep folder (no {MARKER});"
                          " refusing to write into it; choose another --out")
    resume = False
    if marker.is_file():
        try:
            old = json.loads(marker.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            raise OutputError(f"{out}/{MARKER}: unreadable marker; choose another --out") from None
        same = old.get("fingerprint") == meta["fingerprint"]
        if not same and not restart:
            raise OutputError(f"{out}: holds the results of a different sweep ({old.get('sweep')},"
                              " or the sweep file, base problem, its designed controller or"
                              " robrst changed since); choose another --out, or --restart to"
                              " discard robrst's results there")
        if restart:
            for p in _own_files(out):
                p.unlink(missing_ok=True)
        resume = same and not restart
    (out / "chunks").mkdir(parents=True, exist_ok=True)
    atomic_write_text(marker, json_text(meta, indent=1) + "\n")
    return resume


def write_part(out: Path, chunk: Chunk, table: pa.Table) -> None:
    """Write one chunk's rows atomically to ``chunks/part-NNNNNN.parquet``.

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    chunk : Chunk
        The chunk (its number names the file).
    table : pyarrow.Table
        Its rows.
    """
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(table, buf)
    atomic_write_bytes(Path(out) / "chunks" / f"part-{chunk:06d}.parquet", buf.getvalue())


def done_chunks(out: Path, chunk_list: Sequence[Chunk], schema: pa.Schema | None = None) -> set[int]:
    """Indices of the chunks whose part file holds exactly that chunk's variants.

    A part file counts only when its ``index`` column is the chunk's indices, in order (and
    its ``chunk`` column the chunk's number): a part copied over from another chunk, or
    from another sweep, is computed again (see :func:`checked_chunks`).

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    chunk_list : sequence of Chunk
        The sweep's chunks.
    schema : pyarrow.Schema, optional
        The columns a part must have.

    Returns
    -------
    set of int
    """
    return checked_chunks(out, chunk_list, schema)[0]


def checked_chunks(out: Path, chunk_list: Sequence[Chunk],
                   schema: pa.Schema | None = None) -> tuple[set[int], set[int]]:
    """``(done, foreign)``: sets of chunk indices.

    ``done``: the part file holds exactly the chunk's variants (see :func:`done_chunks`) and,
    when ``schema`` is given, has these columns; ``foreign``: a part file exists but holds
    other variants or columns, or cannot be read — the chunk is computed again and its part
    file replaced.

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    chunk_list : sequence of Chunk
        The sweep's chunks.
    schema : pyarrow.Schema, optional
        The columns a part must have.

    Returns
    -------
    done, foreign : set of int
    """
    import pyarrow.parquet as pq

    done, foreign = set(), set()
    folder = Path(out) / "chunks"
    for c in chunk_list:
        p = folder / f"part-{c.index:06d}.parquet"
        if not p.is_file():
            continue
        try:
            found = pq.read_schema(p)
            cols = [k for k in ("index", "chunk") if k in found.names]
            same = schema is None or found.remove_metadata().equals(schema)
            t = pq.read_table(p, columns=cols) if "index" in cols and same else None
        except (OSError, ValueError):
            t = None            # a damaged part: computed again
        if t is not None and _holds(t, c):
            done.add(c.index)
        else:
            foreign.add(c.index)
    return done, foreign


def _holds(table, c):
    """Whether ``table`` (columns ``index`` and maybe ``chunk``) holds exactly chunk ``c``."""
    if table.column("index").to_pylist() != list(range(c.start, c.stop)):
        return False
    return ("chunk" not in table.column_names
            or all(k == c.index for k in table.column("chunk").to_pylist()))


def read_results(out: Path, chunk_list: Sequence[Chunk], schema: pa.Schema) -> pa.Table:
    """Every finished chunk's rows, ordered by variant index (an Arrow table).

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    chunk_list : sequence of Chunk
        The sweep's chunks.
    schema : pyarrow.Schema
        The results' columns.

    Returns
    -------
    pyarrow.Table
        Empty (with ``schema``) when no chunk is finished.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    folder = Path(out) / "chunks"
    parts = [pq.read_table(folder / f"part-{c.index:06d}.parquet", schema=schema)
             for c in chunk_list if (folder / f"part-{c.index:06d}.parquet").is_file()]
    return pa.concat_tables(parts) if parts else schema.empty_table()


def write_results(out: Path, table: pa.Table) -> None:
    """Write ``results.parquet`` atomically.

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    table : pyarrow.Table
        Every finished variant's row.
    """
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(table, buf)
    atomic_write_bytes(Path(out) / "results.parquet", buf.getvalue())


def previous_runs(out: Path) -> list[dict]:
    """The ``runs`` of the folder's earlier ``summary.json`` (``[]`` if none or unreadable).

    Parameters
    ----------
    out : pathlib.Path
        The output folder.

    Returns
    -------
    list of dict
    """
    try:
        runs = json.loads((Path(out) / "summary.json").read_text(encoding="utf-8"))["runs"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    return [r for r in runs if isinstance(r, dict) and {"workers", "wall_s", "startup_s",
                                                         "computed"} <= set(r)]


def write_summary(out: Path, summary: dict) -> None:
    """Write ``summary.json`` atomically (non-finite numbers as null).

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    summary : dict
        The summary.
    """
    atomic_write_text(Path(out) / "summary.json", json_text(summary, indent=1) + "\n")
