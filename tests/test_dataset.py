"""The data format: round trip, and bad files rejected with file and line named."""

import numpy as np
import pytest

from robrst.dataset import Dataset, load_dataset, save_dataset
from robrst.errors import DataError

GOOD = "# measured\nt,u,y,temp\n0.0,0,0,28\n0.001,1,0.5,28\n0.002,2,1.1,28.1\n"


def _write(tmp_path, text, name="d.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    n = 500
    ds = Dataset(t=np.arange(n) / 20000.0, u=rng.uniform(0, 150, n), y=rng.normal(0, 50, n),
                 temp=np.linspace(28, 45, n), yr=np.full(n, 10.0), comments=("twin",))
    back = load_dataset(save_dataset(ds, tmp_path / "a.csv"))
    for k, v in ds.columns().items():
        np.testing.assert_allclose(back.columns()[k], v, rtol=1e-8, atol=1e-12)
    assert back.fs == pytest.approx(20000.0, rel=1e-9) and back.comments == ("twin",)


def test_good_file_loads(tmp_path):
    ds = load_dataset(_write(tmp_path, GOOD))
    assert ds.n == 3 and ds.yr is None and ds.comments == ("measured",)


@pytest.mark.parametrize("text,match", [
    (GOOD.replace("t,u,y,temp", "t,u,y"), r"d.csv: line 2: missing column\(s\) temp"),
    (GOOD.replace("t,u,y,temp", "t,u,y,temp,extra").replace("28\n", "28,1\n").replace("28.1\n", "28.1,1\n"),
     r"line 2: unknown column\(s\) extra"),
    (GOOD.replace("0.001,1,0.5,28", "0.001,nan,0.5,28"), r"d.csv: line 4: NaN or inf in column\(s\) u"),
    (GOOD.replace("0.002,2,1.1", "0.0005,2,1.1"), r"line 5: time not strictly increasing"),
    (GOOD + "0.0035,3,1.2,28.1\n", r"line 6: non-uniform sampling"),
    (GOOD.replace("28.1", "301.2"), r"line 5: column temp = 301.2 outside .* \(kelvin\? expected °C\)"),
    (GOOD.replace("0.5,28", "5e-07,28").replace("1.1,28.1", "1.1e-06,28.1"), r"looks like metres"),
    (GOOD.replace("0.001,1,0.5,28", "0.001,1,0.5"), r"line 4: 3 fields, expected 4"),
    ("# only comments\n", r"no header line"),
    ("t,u,y,temp\n0,0,0,28\n", r"fewer than 2 data rows"),
])
def test_bad_files(tmp_path, text, match):
    with pytest.raises(DataError, match=match):
        load_dataset(_write(tmp_path, text))


def test_missing_file(tmp_path):
    with pytest.raises(DataError, match="not found"):
        load_dataset(tmp_path / "nope.csv")
