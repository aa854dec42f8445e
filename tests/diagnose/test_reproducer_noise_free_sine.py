"""tests/repro/diagnose_noise_free_sine/make.py: a valid noise-free sine record of 3,000
samples (u = 10 + 5 sin(k/7) V, y = 6.68 sin(k/7) µm, 20 kHz) ended in the last-resort
line "computation failed (ValueError: array must not contain infs or NaNs) ... please
report it".  Its own script writes the record; robrst diagnoses it (exit 0), or refuses it
with one clear line, never the last resort."""

import runpy

import pytest

from robrst.cli import LAST_RESORT, main


@pytest.mark.slow
def test_noise_free_sine_record_is_diagnosed(repro_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(repro_dir / "diagnose_noise_free_sine" / "make.py"))
    assert (tmp_path / "sine3000.csv").is_file()
    rc = main(["diagnose", "--train", "sine3000.csv", "--test", "sine3000.csv", "--quiet"])
    err = capsys.readouterr().err
    assert LAST_RESORT not in err and "Traceback" not in err, err
    assert rc == 0 or (rc == 2 and len(err.strip().splitlines()) == 1), (rc, err)
