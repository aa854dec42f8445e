"""The data formats (CSV and .npz, one or several channels, periodic records): round trips,
bad files rejected with file and line (or array) named, and the array converter."""

import time

import numpy as np
import pytest

from robrst.cli import main
from robrst.data.convert import records_from_arrays
from robrst.data.dataset import Dataset, load_dataset, save_dataset
from robrst.base.errors import DataError

GOOD = "# measured\nt,u,y,temp\n0.0,0,0,28\n0.001,1,0.5,28\n0.002,2,1.1,28.1\n"
MIMO = "t,u1,u2,y1,y2,y3\n0,0,1,0,0,0\n0.5,1,1,0.5,1,2\n1.0,2,0,1.1,2,3\n"


def _write(tmp_path, text, name="d.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    n = 500
    ds = Dataset(t=np.arange(n) / 20000.0, u=rng.uniform(0, 150, n), y=rng.normal(0, 50, n),
                 temp=np.linspace(28, 45, n), yr=np.full(n, 10.0), comments=("twin",))
    for name in ("a.csv", "a.npz"):
        back = load_dataset(save_dataset(ds, tmp_path / name))
        for k, v in ds.columns().items():
            np.testing.assert_allclose(back.columns()[k], v, rtol=1e-8, atol=1e-12)
        assert back.fs == pytest.approx(20000.0, rel=1e-9)
    assert load_dataset(tmp_path / "a.csv").comments == ("twin",)


def test_mimo_periodic_round_trip_and_shapes(tmp_path):
    rng = np.random.default_rng(1)
    P, periods = 64, 3
    u = np.tile(rng.normal(size=(P, 3)), (periods, 1))
    y = rng.normal(size=(P * periods, 2))
    ds = Dataset(t=np.arange(P * periods) / 6400.0, u=u, y=y, period=P)
    for name in ("m.csv", "m.npz"):
        back = load_dataset(save_dataset(ds, tmp_path / name))
        assert (back.n_in, back.n_out, back.period, back.periods) == (3, 2, P, periods)
        assert back.temp is None and back.U.shape == (P * periods, 3)
        np.testing.assert_allclose(back.Y, y, rtol=1e-8, atol=1e-12)
    assert tmp_path.joinpath("m.csv").read_text().splitlines()[:2] == [
        "# period_samples = 64", "t,u1,u2,u3,y1,y2"]


def test_good_files_load(tmp_path):
    ds = load_dataset(_write(tmp_path, GOOD))
    assert ds.n == 3 and ds.yr is None and ds.comments == ("measured",) and ds.u.ndim == 1
    no_temp = load_dataset(_write(tmp_path, "t,u,y\n0,0,0\n1,1,1\n", "n.csv"))
    assert no_temp.temp is None and no_temp.temp_or(30.0).tolist() == [30.0, 30.0]
    m = load_dataset(_write(tmp_path, MIMO, "m.csv"))
    assert (m.n_in, m.n_out) == (2, 3) and m.u.shape == (3, 2)


@pytest.mark.parametrize("text,match", [
    (GOOD.replace("t,u,y,temp", "t,u,temp").replace(",0,28", ",28").replace(",0.5,28", ",28")
     .replace(",1.1,28.1", ",28.1"), r"d.csv: line 2: missing column\(s\) y"),
    (GOOD.replace("t,u,y,temp", "t,u,y,temp,extra").replace("28\n", "28,1\n").replace("28.1\n", "28.1,1\n"),
     r"line 2: unknown column\(s\) extra"),
    ("t,u1,u3,y\n0,0,0,0\n1,1,1,1\n", r"line 1: columns u1, u3 must be numbered u1..u2"),
    ("t,u,u1,y\n0,0,0,0\n1,1,1,1\n", r"line 1: column u mixed with u1"),
    ("t,u,y,y\n0,0,0,0\n1,1,1,1\n", r"line 1: duplicate column\(s\) y"),
    (GOOD.replace("0.001,1,0.5,28", "0.001,nan,0.5,28"), r"d.csv: line 4: NaN or inf in column\(s\) u"),
    (GOOD.replace("0.002,2,1.1", "0.0005,2,1.1"), r"line 5: time not strictly increasing"),
    (GOOD + "0.0035,3,1.2,28.1\n", r"line 6: non-uniform sampling"),
    (GOOD.replace("28.1", "301.2"), r"line 5: column temp = 301.2 outside .* \(kelvin\? expected °C\)"),
    (GOOD.replace("0.5,28", "5e-07,28").replace("1.1,28.1", "1.1e-06,28.1"), r"y never exceeds .* metres"),
    (MIMO.replace("1,2,3\n", "1e-9,2e-9,3e-9\n").replace("0.5,1,2", "5e-10,1e-9,2e-9"),
     r"column y1 never exceeds .* metres"),
    (GOOD.replace("0.001,1,0.5,28", "0.001,1,0.5"), r"line 4: 3 fields, expected 4"),
    (GOOD.replace("0.001,1,0.5,28", "0.001,1,abc,28"), r"line 4: non-numeric value"),
    ("# period_samples = 2\n" + GOOD, r"period_samples = 2 does not divide the 3 samples"),
    ("# only comments\n", r"no header line"),
    ("t,u,y,temp\n0,0,0,28\n", r"fewer than 2 data rows"),
])
def test_bad_files(tmp_path, text, match):
    with pytest.raises(DataError, match=match):
        load_dataset(_write(tmp_path, text))


def test_bad_npz_names_the_array(tmp_path):
    t = np.arange(10) / 100.0
    for arrays, match in [({"t": t, "u": t}, r"missing array 'y'"),
                          ({"t": t, "u": t, "y": t, "v": t}, r"unknown array\(s\) v"),
                          ({"t": t, "u": np.ones((9, 2)), "y": t}, r"array u has shape \(9, 2\)"),
                          ({"t": t, "u": t, "y": t * np.nan}, r"sample 0: NaN or inf in column\(s\) y"),
                          ({"t": t, "u": t, "y": t, "period_samples": 3.0},
                           r"period_samples must be an integer")]:
        p = tmp_path / "x.npz"
        np.savez(p, **arrays)
        with pytest.raises(DataError, match=match):
            load_dataset(p)
    p = tmp_path / "junk.npz"
    p.write_text("not a zip")
    with pytest.raises(DataError, match="junk.npz: not a readable .npz"):
        load_dataset(p)


def test_missing_file(tmp_path):
    with pytest.raises(DataError, match="not found"):
        load_dataset(tmp_path / "nope.csv")


def test_bulk_parse_is_fast_and_exact(tmp_path):
    """200 000 rows: bulk parse (the line-by-line parser took 7.4 s here)."""
    n = 200_000
    rng = np.random.default_rng(2)
    ds = Dataset(t=np.arange(n) / 20000.0, u=rng.uniform(0, 150, n), y=rng.normal(0, 50, n),
                 temp=np.full(n, 30.0))
    p = save_dataset(ds, tmp_path / "big.csv")
    t0 = time.perf_counter()
    back = load_dataset(p)
    elapsed = time.perf_counter() - t0
    np.testing.assert_allclose(back.y, ds.y, rtol=1e-8)
    assert elapsed < 3.0
    text = p.read_text().splitlines()
    text[150_001] = text[150_001].replace(",", ";", 1)
    p.write_text("\n".join(text) + "\n")
    with pytest.raises(DataError, match=r"big.csv: line 150002: 3 fields, expected 4"):
        load_dataset(p)


def test_arrays_to_records_and_convert_cli(tmp_path, capsys):
    """(time, channel, realization, period) arrays in V and metres -> periodic records in µm."""
    rng = np.random.default_rng(3)
    N, R, P = 32, 2, 3
    u = rng.normal(size=(N, 3, R, P))
    y = 1e-6 * rng.normal(size=(N, 3, R, P))
    recs = records_from_arrays(u, y, 6400.0, source="lvl")
    assert [d.source for d in recs] == ["lvl_r1", "lvl_r2"]
    d = recs[1]
    assert (d.n, d.period, d.periods, d.n_in, d.n_out) == (N * P, N, P, 3, 3)
    np.testing.assert_array_equal(d.U[N:2 * N], u[:, :, 1, 1])
    np.testing.assert_allclose(d.Y[2 * N:], 1e6 * y[:, :, 1, 2], rtol=1e-15)
    with pytest.raises(DataError, match="differ along realization"):
        records_from_arrays(u, y[:, :, :1], 6400.0)
    with pytest.raises(DataError, match="layout"):
        records_from_arrays(u, y, 6400.0, layout="time,channel,run,period")
    np.save(tmp_path / "u_x.npy", u)
    np.save(tmp_path / "y_x.npy", y)
    args = ["convert", str(tmp_path / "u_x.npy"), str(tmp_path / "y_x.npy"), "--fs", "6400",
            "--out", str(tmp_path / "out")]
    assert main(args) == 0
    back = load_dataset(tmp_path / "out" / "x_r2.npz")
    np.testing.assert_allclose(back.Y, d.Y, rtol=1e-15)
    assert back.period == N and back.fs == 6400.0
    capsys.readouterr()
    assert main(args) == 2                                     # never overwrites silently
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "x_r1.npz: exists; use --overwrite" in err[0]
    assert main(args + ["--overwrite", "--quiet"]) == 0        # --quiet: nothing on stdout
    assert capsys.readouterr().out == ""
