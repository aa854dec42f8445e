"""Periodic records recognised from the data, and a fallback floor that never counts an
excited band as noise.

Stated before the runs:

* The mirror's multisine records written as plain ``t, u, y`` files (two periods, no
  ``period_samples``; the measured input repeats to 4e-4 of its RMS, not exactly): the
  period is found (8192 samples), the noise floor is the period differences' (the same as
  with the declared period, 0.8 % at 300 mV, not the 12 % the Welch fallback took from the
  excited band), and the answer says so (finding ``periodic_records``).
* Twin records of every kind the suites use (steps, sines, triangles, multisines, ramps)
  are not periodic; a recipe record without its period is, and is diagnosed exactly as
  with it.
* Without periods, a record whose input excites every band has no floor of its own (0,
  finding ``noise_undetermined``), and a band-limited one (to 88 % of Nyquist) is measured above its band
  (the true noise within 10 %) however large the model error inside it.
"""

from dataclasses import replace

import numpy as np
import pytest

from diagnosis_cases import make
from mirror_data import mirror_data_dir
from robrst.data.convert import records_from_arrays
from robrst.data.dataset import Dataset, load_dataset, save_dataset
from robrst.diagnose import diagnose, _signals as signals
from robrst.diagnose._findings import floor_of, noise_estimate
from robrst.diagnose._periodic import find_period, with_periods
from robrst.diagnose.validation import make_case

MIRROR = mirror_data_dir()


def _mirror(period=True):
    recs = []
    for lv, sp in ((100, "train"), (200, "train"), (300, "test")):
        r = records_from_arrays(np.load(MIRROR / f"u_{lv}mV_{sp}.npy"),
                                np.load(MIRROR / f"y_{lv}mV_{sp}.npy"), 6400.0,
                                source=f"m{lv}_{sp}")
        recs += r if period else [replace(d, period=0) for d in r]
    return recs


@pytest.mark.skipif(MIRROR is None, reason="no mirror data in this checkout")
def test_plain_mirror_files_are_found_periodic_with_the_period_floor(tmp_path):
    declared = _mirror()
    files = [save_dataset(d, tmp_path / f"{d.source}.csv") for d in _mirror(period=False)]
    plain = [load_dataset(f) for f in files]
    assert all(d.period == 0 for d in plain)
    # the measured input does not repeat exactly: 4e-4 of its RMS between the periods
    d = plain[-1]
    du = d.U[8192:] - d.U[:8192]
    assert 1e-5 < np.sqrt(np.mean(du ** 2)) / d.level < 1e-3
    found, info = with_periods(plain)
    assert [x.period for x in found] == [8192] * 3
    assert [f["periods"] for f in info] == [2] * 3
    # the floor: period differences, independently (numpy on the arrays), as declared
    floors = []
    for recs in (found, declared):
        res = [np.zeros_like(r.Y) for r in recs]
        est = noise_estimate(recs, res, 6400.0)
        assert est.method == "period_differences"
        d = recs[-1]
        y = d.Y.reshape(2, 8192, 3)
        D2 = (y[1] - y[0]) ** 2                      # 16 blocks of 512: the median mean square
        sig = np.sqrt(np.median(D2.reshape(16, 512, 3).mean(axis=1), axis=0) / 2)
        rms = np.sqrt(np.mean(D2, axis=0) / 2)
        assert np.all(np.abs(sig / rms - 1) < 0.25)   # stationary: near the plain RMS
        want = np.sqrt(d.n * np.sum(sig ** 2) / np.sum((d.Y - d.Y.mean(0)) ** 2))
        floors.append(floor_of(recs[-1:], est.levels[-1:]))
        assert floors[-1] == pytest.approx(want, rel=1e-12)
    assert floors[0] == pytest.approx(floors[1], rel=1e-6)     # the CSV's 9 digits
    assert 0.004 < floors[0] < 0.015
    # without the periods the Welch fallback has no band free of the multisine: no floor
    # (the residual of a model that predicts nothing: the output itself)
    est = noise_estimate(plain[-1:], [plain[-1].Y], 6400.0)
    assert est.method == "undetermined" and est.levels.max() == 0.0


@pytest.mark.slow
def test_twin_records_of_every_kind_are_not_periodic():
    for case in ("hysteresis", "creep", "thermal_drift", "delay", "slew", "none"):
        for seed in (1, 2):
            train, test, truth = make_case(case, seed)
            assert [find_period(d) for d in train + test] == [0] * 4, (case, seed, truth)
    for name in ("hysteresis+creep", "creep+thermal_drift", "dead_zone", "asymmetric_slew",
                 "cross_coupling_2ch"):
        train, test, _, _ = make(name, 0)
        assert [find_period(d) for d in train + test] == [0] * 4, name


def test_a_temperature_ramp_is_not_periodic():
    n, P = 4000, 500
    u = np.tile(np.sin(2 * np.pi * np.arange(P) / P), n // P) * 10 + 50
    t = np.arange(n) / 5000.0
    d = Dataset(t=t, u=u, y=0.1 * u)
    assert find_period(d) == P
    assert find_period(replace(d, temp=np.linspace(28, 40, n))) == 0
    assert find_period(replace(d, temp=np.full(n, 30.0))) == P


@pytest.mark.slow
def test_a_recipe_record_without_its_period_is_diagnosed_as_with_it():
    train, test, model, _ = make("recipe_bouc_wen", 0)
    plain = [replace(d, period=0) for d in train + test]
    a = diagnose(train, test, plant=model)
    b = diagnose(plain[:len(train)], plain[len(train):], plant=model)
    assert b.cause == a.cause and b.causes == a.causes
    assert b.noise_floor == pytest.approx(a.noise_floor, rel=1e-12)
    assert b.gap_before == pytest.approx(a.gap_before, rel=1e-12)
    f = next(x for x in b.findings if x.kind == "periodic_records")
    assert len(f.details["records"]) == len(plain) and "period-to-period differences" in f.message
    assert not any(x.kind == "periodic_records" for x in a.findings)


def test_the_fallback_floor_never_counts_an_excited_band_as_noise():
    fs, n, sigma = 5000.0, 40000, 0.01
    rng = np.random.default_rng(4)
    t = np.arange(n) / fs
    # a multisine up to 88 % of Nyquist (not periodic in the record: no period to find)
    fr = np.linspace(3.1, 0.88 * fs / 2, 600) + rng.uniform(0, 1, 600)
    u = 60 + 20 * np.sum(np.sin(2 * np.pi * fr[:, None] * t[None, :]
                                + rng.uniform(0, 6.3, (fr.size, 1))), axis=0) / np.sqrt(fr.size)
    err = 0.5 * np.convolve(u - u.mean(), np.ones(3) / 3, "same")    # a model error in band
    r = err + sigma * rng.standard_normal(n)
    got = signals.noise_sigma(r, fs, u)
    assert got == pytest.approx(sigma, rel=0.1)
    assert signals.noise_sigma(r, fs) > 3 * sigma          # the old floor took the band
    # the input excites every band: no floor of its own
    u2 = 60 + 20 * rng.standard_normal(n)
    assert np.isnan(signals.noise_sigma(sigma * rng.standard_normal(n) + 0.1 * u2, fs, u2))
    d = Dataset(t=t, u=u2, y=0.1 * u2 + sigma * rng.standard_normal(n))
    est = noise_estimate([d], [d.Y - 0.1 * d.U], fs)
    assert est.undetermined == (0,) and est.levels.max() == 0.0 and est.upper.max() > 0
