"""Identification on data nobody here wrote: users' stages, biased drives, single steps,
families validated at their own temperatures, high orders, and the files it writes.

Every record is simulated by python-control (``control.c2d`` ZOH + ``forced_response``),
independently of robrst's modal simulator; identified models are compared with the true
one on the frequency response over the excited band, and written files are read back.
"""

import json
import tomllib

import control
import numpy as np
import pytest

from robrst.cli import main
from robrst.data.dataset import Dataset, save_dataset
from robrst.studies.linear_model import load_linear_model
from robrst.identify.identification import identify

FS = 20000.0


def _stage(f_hz=800.0, zeta=0.02, gain=0.1):
    """A 2nd-order piezo stage ``gain wn^2 / (s^2 + 2 zeta wn s + wn^2)`` [µm/V]."""
    wn = 2 * np.pi * f_hz
    return control.tf([gain * wn ** 2], [1.0, 2 * zeta * wn, wn ** 2])


def _simulate(sys_c, u, noise=0.0, seed=0):
    sysd = control.c2d(sys_c, 1.0 / FS, method="zoh")
    y = np.asarray(control.forced_response(sysd, U=u).outputs).ravel()
    return y + noise * np.random.default_rng(seed).standard_normal(y.size)


def _steps(n, seed, hold=400, lo=0.0, hi=100.0):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(lo, hi, n // hold + 1), hold)[:n]
    u[:hold] = 0.0
    return u


def _record(sys_c, u, noise=0.0, seed=0, temp=None, name="r"):
    y = _simulate(sys_c, u, noise, seed)
    n = u.size
    return Dataset(t=np.arange(n) / FS, u=u, y=y, source=name,
                   temp=None if temp is None else np.full(n, float(temp)))


def _frf_error(model, sys_c, f_lo=10.0, f_hi=3000.0):
    """Largest relative error of the identified model's response over [f_lo, f_hi] Hz."""
    w = 2 * np.pi * np.geomspace(f_lo, f_hi, 400)
    h_true = np.asarray(control.frequency_response(sys_c, w).complex).ravel()
    h = model.freqresp(w)[:, 0, 0]
    return float(np.max(np.abs(h - h_true) / np.abs(h_true)))


def test_periodic_multisine_on_a_bias_is_identified():
    """A unipolar drive: 99 lines up to 1 kHz (5 V RMS) on a 75 V bias.  The bias is no
    excitation of the dynamics; it used to hide every line (IndexError)."""
    P, periods = 2000, 4
    k = np.arange(1, 100)
    phases = np.random.default_rng(3).uniform(0, 2 * np.pi, k.size)
    t = np.arange(P) / FS
    one = np.sum(np.sin(2 * np.pi * np.outer(t, k * FS / P) + phases), axis=1)
    one *= 5.0 / np.std(one)
    sys_c = _stage()
    u = 75.0 + np.tile(one, periods + 2)
    y = _simulate(sys_c, u)[2 * P:]                   # steady state: 2 periods dropped
    rec = Dataset(t=np.arange(periods * P) / FS, u=u[2 * P:], y=y, period=P, source="ms")
    res = identify([rec], max_order=6)
    assert res.order == 2
    assert _frf_error(res.model, sys_c, 10.0, 990.0) < 1e-6


def test_too_few_excited_lines_are_a_note_not_a_crash():
    """Three excited lines cannot carry order 12: those orders are noted, not a crash."""
    P = 1000
    t = np.arange(P) / FS
    one = sum(np.sin(2 * np.pi * f * t) for f in (100.0, 400.0, 800.0))
    sys_c = _stage()
    u = np.tile(one, 5)
    rec = Dataset(t=np.arange(3 * P) / FS, u=u[2 * P:], y=_simulate(sys_c, u)[2 * P:],
                  period=P, source="three")
    res = identify([rec], max_order=12)
    assert any("too few excited lines" in s.note for s in res.scores)
    assert res.order <= 4


@pytest.mark.slow
def test_single_step_record_chooses_the_order_on_the_whole_record():
    """One 50 V step, 0.5 s: the last 30 % has settled and cannot tell orders apart (every
    order scored ~1 there and order 1 was chosen, missing the resonance)."""
    n = 10000
    u = np.where(np.arange(n) >= 200, 50.0, 0.0)
    sys_c = _stage()
    res = identify([_record(sys_c, u, noise=0.02, seed=4, name="step")])
    assert res.order == 2, [(s.order, s.heldout_nrmse) for s in res.scores]
    assert res.heldout[0].startswith("none: the last 30 %")
    assert _frf_error(res.model, sys_c, 10.0, 2000.0) < 0.02


@pytest.mark.slow
def test_validation_records_are_scored_at_their_own_temperature():
    """A family at 20/45/70 °C (resonance 800/700/600 Hz) validated on records at those
    temperatures: each record against its own temperature's model (all were scored against
    one model, which chose order 1 with held-out NRMSE 0.99)."""
    train, val, truth = [], [], {}
    for T, f in ((20.0, 800.0), (45.0, 700.0), (70.0, 600.0)):
        truth[T] = _stage(f)
        train.append(_record(truth[T], _steps(8000, int(T)), 0.005, int(T), T, f"tr{T:g}"))
        val.append(_record(truth[T], _steps(8000, int(T) + 1), 0.005, int(T) + 1, T,
                           f"va{T:g}"))
    res = identify(train, validate=val, max_order=6)
    assert res.order == 2
    assert res.heldout_nrmse < 0.05
    for m in res.models:
        assert _frf_error(m, truth[m.temperature_C], 10.0, 2000.0) < 1e-2
    # validation only at a temperature other than the largest group's: still scored there
    res = identify(train + [train[0]], validate=val[2:], max_order=4)
    assert res.order == 2 and res.heldout_nrmse < 0.05


@pytest.mark.slow
def test_problem_file_reproduces_the_identified_model_at_high_order(tmp_path):
    """Order 8 (two resonances + spare poles): the written B, A reproduce the identified
    model to the expansion's rounding (B's high powers used to be zeroed after unscaling:
    the file's response was 5.9x the model's at 675 Hz)."""
    w1, w2 = 2 * np.pi * 400.0, 2 * np.pi * 1400.0
    sys_c = control.tf([0.1 * w1 ** 2 * w2 ** 2],
                       np.polymul([1, 2 * 0.03 * w1, w1 ** 2], [1, 2 * 0.02 * w2, w2 ** 2]))
    recs = [_record(sys_c, _steps(12000, s), 0.001, s, name=f"r{s}") for s in (1, 2)]
    paths = []
    for r in recs:
        paths.append(tmp_path / f"{r.source}.csv")
        save_dataset(r, paths[-1])
    out = tmp_path / "stage.toml"
    assert main(["identify", "--train", *map(str, paths), "--order", "8", "--out", str(out),
                 "--quiet"]) == 0
    res = identify(recs, order=8)
    plant = tomllib.loads(out.read_text())["plant"]   # the file's polynomials, evaluated
    w = 2 * np.pi * np.geomspace(10.0, 5000.0, 300)
    h_mem = res.model.freqresp(w)[:, 0, 0]
    h_file = np.polyval(plant["B"], 1j * w) / np.polyval(plant["A"], 1j * w)
    # the stage's numerator is a constant over four poles: relative degree 4, which the
    # data support (the spare poles' residues too); the file's B has 9 - 4 coefficients
    assert res.relative_degree == 4
    assert len(plant["B"]) == 5 and len(plant["A"]) == 9
    # expanded polynomials carry the rounding of the expansion (spare pole/zero pairs with
    # large residues cancel): relative to the largest response, not the local one
    assert np.max(np.abs(h_file - h_mem)) < 1e-9 * np.max(np.abs(h_mem))
    (model,), _ = load_linear_model(out)              # read back by robrst (modal form)
    h_back = model.freqresp(w)[:, 0, 0]
    assert np.max(np.abs(h_back - h_mem)) < 1e-8 * np.max(np.abs(h_mem))


def test_orders_a_problem_file_cannot_hold_are_refused_before_writing(tmp_path, capsys):
    """Order 24 expands to coefficients beyond 1e100: one clear line and no file (it used to
    write an unreadable one); --modal writes the modal model file, which reads back."""
    rec = _record(_stage(), _steps(8000, 5), 0.001, 5, name="r")
    data = tmp_path / "r.csv"
    save_dataset(rec, data)
    out = tmp_path / "p24.toml"
    assert main(["identify", "--train", str(data), "--order", "24", "--out", str(out),
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--modal" in err and "1e+100" in err
    assert not out.exists()
    assert main(["identify", "--train", str(data), "--order", "24", "--modal", "--out",
                 str(out), "--quiet"]) == 0
    (model,), _ = load_linear_model(out)
    assert model.order == 24


def test_output_targets_are_checked_before_any_work_or_write(tmp_path, capsys):
    """A folder as --json (or a file as --report, a folder as --out) fails at once; the
    model file is not written."""
    rec = _record(_stage(), _steps(4000, 6), 0.001, 6, name="r")
    data = tmp_path / "r.csv"
    save_dataset(rec, data)
    out = tmp_path / "m.toml"
    (tmp_path / "afile").write_text("mine\n")
    for extra in (["--json", str(tmp_path)], ["--report", str(tmp_path / "afile")]):
        assert main(["identify", "--train", str(data), "--out", str(out), *extra]) == 2
        assert not out.exists()
    assert main(["identify", "--train", str(data), "--out", str(tmp_path)]) == 2
    assert main(["identify", "--train", str(data), "--out", str(out), "--max-order", "0"]) == 2
    err = capsys.readouterr().err
    assert "is a folder" in err and "--max-order" in err
    assert (tmp_path / "afile").read_text() == "mine\n"


def test_diagnose_takes_the_problem_file_identify_writes(tmp_path, capsys):
    """One input and one output: identify writes a problem file (with a starting design);
    diagnose --model reads it (it used to demand [poles]), also with the design tables gone."""
    sys_c = _stage()
    paths = []
    for s in (7, 8):
        paths.append(tmp_path / f"r{s}.csv")
        save_dataset(_record(sys_c, _steps(8000, s), 0.002, s, name=f"r{s}"), paths[-1])
    model = tmp_path / "stage.toml"
    assert main(["identify", "--train", str(paths[0]), "--out", str(model), "--quiet"]) == 0
    text = model.read_text()
    model.write_text(text[:text.index("[poles]")])       # the plant alone
    capsys.readouterr()
    assert main(["diagnose", "--train", str(paths[0]), "--test", str(paths[1]), "--model",
                 str(model), "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["cause"] == "none"
