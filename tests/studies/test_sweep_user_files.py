"""Sweeps as users run them: resuming over a tampered folder, fleets of every file kind,
ties on the trade-off front, and inputs that must be one clear line (never a traceback)."""

import shutil

import numpy as np
import pytest
import pyarrow.parquet as pq
from sweep_files import columns_equal, fast_file, load_json

from robrst.cli import main
from robrst.studies.sweep import run_sweep


@pytest.mark.slow
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


CTRL_C = """
[sweep]
kind = "analysis"
problem = "paper"
n = 100000
chunk_size = 20

[[param]]
name = "gain"
dist = "normal"
mean = 1.0
std = 0.05
"""


@pytest.mark.slow
def test_ctrl_c_on_a_local_cluster_is_one_line_and_exit_130(tmp_path):
    """Ctrl-C reaches the whole process group (driver and worker processes): the workers
    must not print tracebacks; the driver closes the cluster and says one line."""
    import os
    import signal
    import subprocess
    import sys
    import time

    import pytest

    path = tmp_path / "ctrl_c.toml"
    path.write_text(CTRL_C, encoding="utf-8")
    out = tmp_path / "o"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen(
        [sys.executable, "-m", "robrst", "sweep", str(path), "--out", str(out), "--workers",
         "2", "--cluster", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
        start_new_session=True,     # its own process group, as a terminal's foreground job
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        t0 = time.monotonic()
        while time.monotonic() - t0 < 60 and proc.poll() is None:
            if (out / "chunks").is_dir() and len(list((out / "chunks").iterdir())) >= 2:
                break                            # the workers are computing
            time.sleep(0.2)
        if proc.poll() is not None:
            pytest.skip("the sweep ended before it could be interrupted")
        os.killpg(proc.pid, signal.SIGINT)       # what Ctrl-C in a terminal does
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    lines = err.decode().strip().splitlines()
    assert proc.returncode == 130 and lines == ["robrst: interrupted"], lines[:20]
    assert not load_json(out / "summary.json")["complete"]


def _modal_text(model, inputs=1, outputs=1):
    """A model file as ``robrst identify --modal`` writes it (one temperature)."""
    def mat(a):
        return repr(np.asarray(a, float).tolist())

    R = np.tile(model.residues, (1, outputs, inputs))
    D = np.tile(model.D, (outputs, inputs))
    return ('[model]\nformat = "robrst-modal-1"\n'
            f"inputs = {inputs}\noutputs = {outputs}\norder = 3\nfs_hz = 20000.0\n"
            'source = "robrst identify"\n\n[[model.at]]\ntemperature_C = 28.0\n'
            f"poles_re = {mat(model.poles.real)}\npoles_im = {mat(model.poles.imag)}\n"
            f"residues_re = {mat(R.real)}\nresidues_im = {mat(R.imag)}\nD = {mat(D)}\n")


def test_fleet_members_of_every_kind(tmp_path):
    """A model file of identify --modal is designed like the problem file of the same plant;
    a member's compare_with is dropped like the base problem's; a folder or a broken link
    named like a member is an invalid row naming it; a MIMO model file says what is taken."""
    from robrst.identify.modal import ModalModel
    from robrst.core.plant import Plant

    plant = Plant([107.0, 1.4e6, 6.527e9], [1.0, 693.0, 15027342.0, 9765000000.0],
                  temperature_C=28.0)
    modal = ModalModel.from_plant(plant)
    expanded = modal.channel(0, 0)
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    (fleet / "a_plant.toml").write_text(f"[plant]\nB = {expanded.B.tolist()!r}\n"
                                        f"A = {expanded.A.tolist()!r}\ntemperature_C = 28.0\n")
    (fleet / "b_modal.toml").write_text(_modal_text(modal))
    (fleet / "c_compare.toml").write_text('[plant]\nname = "paper"\n'
                                          '[solver]\ncompare_with = "elsewhere.toml"\n')
    (fleet / "d_folder.toml").mkdir()
    (fleet / "e_link.toml").symlink_to(tmp_path / "gone.toml")
    (fleet / "f_mimo.toml").write_text(_modal_text(modal, inputs=2, outputs=2))
    path = tmp_path / "f.toml"
    path.write_text('[sweep]\nkind = "fleet"\nproblem = "paper"\n[fleet]\nfolder = "fleet"\n')
    res = run_sweep(path, tmp_path / "o", workers=0)
    rows = {r["file"]: r for r in res.table.to_pylist()}
    assert list(rows) == ["a_plant.toml", "b_modal.toml", "c_compare.toml", "d_folder.toml",
                          "e_link.toml", "f_mimo.toml"]
    for name in ("a_plant.toml", "b_modal.toml", "c_compare.toml"):
        assert rows[name]["status"] == "ok" and rows[name]["certified"], rows[name]
    for k in "RST":
        np.testing.assert_allclose(rows["b_modal.toml"][k], rows["a_plant.toml"][k],
                                   rtol=1e-9)
    for name, expected in (("d_folder.toml", "is a folder"),
                           ("e_link.toml", "broken symbolic link"),
                           ("f_mimo.toml", ("2 inputs and 2 outputs; a fleet member needs"
                                            " one input and one output"))):
        assert rows[name]["status"] == "invalid" and name in rows[name]["message"]
        assert expected in rows[name]["message"], rows[name]["message"]


def test_pareto_front_keeps_tied_points():
    """Non-dominated: no other point at least as good in both figures and strictly better in
    one. Identical points, and points tied in one figure only where the other also ties,
    are all on the front."""
    from robrst.studies.sweep.summary import pareto_front

    assert pareto_front([1.0, 1.0, 1.0], [5.0, 5.0, 5.0]) == [0, 1, 2]
    x = [2.0, 1.0, 1.0, 2.0, 3.0, 1.0, 2.0, np.inf]
    y = [7.0, 5.0, 5.0, 7.0, 7.0, 4.0, 6.0, 9.0]
    assert pareto_front(x, y) == [1, 2, 0, 3]
    rng = np.random.default_rng(1)      # brute force on a grid with many ties
    x, y = rng.integers(0, 4, 60).astype(float), rng.integers(0, 4, 60).astype(float)
    brute = [i for i in range(60) if not any(
        x[j] <= x[i] and y[j] >= y[i] and (x[j] < x[i] or y[j] > y[i]) for j in range(60))]
    assert sorted(pareto_front(x, y)) == brute


GAIN = '[[param]]\nname = "gain"\ndist = "normal"\nmean = 1.0\nstd = 0.05\n'
BAD = [
    ('[sweep]\nkind = "analysis"\nproblem = "paper"\nn = 2\n' + GAIN, ["--scheduler", "notaurl"],
     "--scheduler: expected the address of a running Dask scheduler, e.g. tcp://host:8786"),
    ('[sweep]\nkind = "fleet"\nproblem = "paper"\n', [],
     "bad.toml: [fleet] missing: a fleet sweep needs a [fleet] table"),
    ('[sweep]\nkind = "analysis"\nproblem = "paper"\nn = 2\n[analysis]\n'
     'controller = "empty_s.json"\n' + GAIN, [],
     "empty_s.json: [controller.S] expected at least one coefficient"),
    (('[sweep]\nkind = "analysis"\nproblem = "paper"\nn = 2\n[[param]]\nname = "age_years"\n'
      'dist = "uniform"\nlo = 0.0\nhi = 5.0\n'), [],
     "[param.0.name] age_years acts through the [ageing] rates"),
]


def test_bad_sweep_inputs_are_one_line_naming_what_was_expected(tmp_path, capsys):
    (tmp_path / "empty_s.json").write_text('{"controller": {"R": [1.0, 2.0], "S": [],'
                                           ' "T": [3.0]}}')
    for i, (text, args, expected) in enumerate(BAD):
        path = tmp_path / "bad.toml"
        path.write_text(text)
        out = tmp_path / f"o{i}"
        assert main(["sweep", str(path), "--out", str(out), "--quiet", *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("robrst: error: ") and expected in err[0], err
        assert "computation failed" not in err[0] and not out.exists()


@pytest.mark.slow
def test_variants_far_outside_leak_no_numpy_warnings(tmp_path, capsys):
    """Poles at 1e-6 rad/s (the lowest a file may state; 1e-90 is refused by the sweep file
    check) fail on the way to their rows: the rows say so, and `sweep --json` prints its
    JSON and no warning."""
    import json
    import warnings

    path = tmp_path / "far.toml"
    path.write_text('[sweep]\nkind = "design"\nproblem = "paper"\n[[param]]\n'
                    'name = "poles.wn"\ndist = "grid"\nvalues = [600.0, 1e-6]\n'
                    '[[param]]\nname = "poles.zeta"\ndist = "grid"\nvalues = [1.0, 0.01]\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rc = main(["sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0",
                   "--json"])
    s = json.loads(capsys.readouterr().out)
    assert rc == 1 and s["done"] == 4 and s["failed"] >= 1
    assert [str(w.message) for w in caught] == []


def test_variant_table_is_drawn_in_blocks_without_copies(monkeypatch):
    """The table is the documented draw (rng.random((n, k)) by inverse CDF, repeated at
    every grid point) however it is blocked, and building it needs little beyond the table
    itself (10 million variants used ~700 MB for a 160 MB table)."""
    import tracemalloc

    import robrst.studies.sweep._variants as variants
    from robrst.studies.sweep.files import parse_sweep

    sweep = parse_sweep({"sweep": {"kind": "analysis", "problem": "paper", "seed": 5, "n": 50},
                         "param": [{"name": "specs.Mu_max", "dist": "grid",
                                    "values": [100.0, 150.0, 200.0]},
                                   {"name": "damping", "dist": "uniform", "lo": 0.5, "hi": 2.0},
                                   {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.1}]})
    monkeypatch.setattr(variants, "DRAW_BLOCK", 7)
    v = variants.variant_table(sweep).values
    u = np.random.default_rng(5).random((50, 2))
    d = 0.5 + 1.5 * u[:, 0]
    assert np.array_equal(v[:, 0], np.repeat([100.0, 150.0, 200.0], 50))
    assert np.array_equal(v[:, 1], np.tile(d, 3))
    assert np.array_equal(v[:, 2], np.tile(variants.draw(sweep.params[2], u[:, 1]), 3))
    monkeypatch.undo()
    big = parse_sweep({"sweep": {"kind": "analysis", "problem": "paper", "n": 1_000_000},
                       "param": [{"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.1},
                                 {"name": "damping", "dist": "uniform", "lo": 0.5,
                                  "hi": 2.0}]})
    tracemalloc.start()
    try:
        table = variants.variant_table(big)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1.6 * table.values.nbytes, peak / table.values.nbytes


def test_a_one_parameter_design_sweep_prints_no_warning(tmp_path, capsys):
    """One parameter, every design made: the front figure has no labelled curve, and
    `sweep --json` prints its JSON and no matplotlib warning about an empty legend."""
    import json
    import warnings

    path = tmp_path / "one.toml"
    path.write_text('[sweep]\nkind = "design"\nproblem = "paper"\n[[param]]\n'
                    'name = "poles.wn"\ndist = "grid"\nvalues = [500.0, 700.0]\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rc = main(["sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0",
                   "--json"])
    assert rc in (0, 1) and json.loads(capsys.readouterr().out)["done"] == 2
    assert [str(w.message) for w in caught] == []
    assert (tmp_path / "o" / "report" / "front.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
