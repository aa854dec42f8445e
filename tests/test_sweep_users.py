"""Sweeps as users run them: resuming over a tampered folder, fleets of every file kind,
ties on the trade-off front, and inputs that must be one clear line (never a traceback)."""

import shutil

import numpy as np
import pyarrow.parquet as pq
from sweep_files import columns_equal, fast_file, load_json

from robrst.cli import main
from robrst.sweep import run_sweep


def test_a_part_copied_over_another_chunk_is_computed_again(tmp_path, capsys):
    """Same row count, other variants: resume must not take it for chunk 2's rows."""
    path = fast_file(tmp_path, n=12, chunk=3)
    full = run_sweep(path, tmp_path / "full", workers=0)
    out = tmp_path / "o"
    run_sweep(path, out, workers=0)
    chunks = out / "chunks"
    shutil.copyfile(chunks / "part-000000.parquet", chunks / "part-000002.parquet")
    (chunks / "part-000003.parquet").write_bytes(b"not parquet")      # damaged
    assert main(["sweep", str(path), "--out", str(out), "--workers", "0"]) == 0
    err = capsys.readouterr().err
    assert "part-000002.parquet, part-000003.parquet" in err and "computing them again" in err
    table = pq.read_table(out / "results.parquet")
    assert table.column("index").to_pylist() == list(range(12))
    columns_equal(table, full.table)
    s = load_json(out / "summary.json")
    assert s["complete"] and s["recomputed_chunks"] == [2, 3] and s["resumed_chunks"] == 2
    assert np.array_equal(pq.read_table(chunks / "part-000002.parquet").column("index"),
                          [6, 7, 8])
