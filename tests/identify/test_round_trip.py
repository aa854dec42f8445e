"""Identification by round trip: known model -> data -> identified model, compared on poles,
zeros and frequency response with stated tolerances.  The data are simulated by
python-control (``control.c2d`` + ``forced_response``), independently of robrst's own
modal simulator, and the identified model is checked back through python-control."""

import json

import control
import numpy as np
import pytest

from robrst.cli import main
from robrst.data.dataset import Dataset, save_dataset
from robrst.base.errors import DataError, SpecError
from robrst.identify.identification import identify
from robrst.identify.modal import ModalModel
from robrst.studies.linear_model import load_linear_model
from robrst.core.plant import Plant, paper_plant
from robrst.problem.files import load_problem

FS = 20000.0


def _steps(n, seed, hold=500):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(0, 150, n // hold + 1), hold)[:n]
    u[:hold] = 0.0
    return u


def _pc_response(sys_c, U, fs):
    """python-control: ZOH discretisation and simulation from rest; U is (N, k)."""
    sysd = control.c2d(sys_c, 1.0 / fs, method="zoh")
    return np.atleast_2d(np.asarray(control.forced_response(sysd, U=np.asarray(U).T).outputs)).T


def _siso_records(plant, noise, seeds=(1, 2, 3), n=20000, temp=None):
    out = []
    for s in seeds:
        u = _steps(n, s)
        y = _pc_response(plant.to_tf(), u[:, None], FS)[:, 0]
        y = y + noise * np.random.default_rng(100 + s).standard_normal(n)
        out.append(Dataset(t=np.arange(n) / FS, u=u, y=y, source=f"r{s}",
                           temp=None if temp is None else np.full(n, temp)))
    return out


def _rel_pole_error(model, plant):
    a = np.sort_complex(model.all_poles())
    b = np.sort_complex(np.roots(plant.A))
    assert a.size == b.size
    return np.max(np.abs(a - b) / np.abs(b))


@pytest.mark.parametrize("noise,pole_tol,frf_tol", [
    (0.0, 1e-9, 1e-9), pytest.param(0.005, 1e-4, 2e-4, marks=pytest.mark.slow)])
def test_siso_round_trip_paper_plant_from_steps(noise, pole_tol, frf_tol):
    """D(s) of the paper from voltage steps at 20 kHz: order 3 chosen on held-out records;
    poles, zeros and |G| match (noise 5 nm: within 1e-4 and 2e-4 relative)."""
    plant = paper_plant()
    res = identify(_siso_records(plant, noise), max_order=6)
    assert res.order == 3 and res.heldout == ("r3",)
    m = res.model
    assert _rel_pole_error(m, plant) < pole_tol
    fitted = m.channel()
    zt, zf = np.sort(np.roots(plant.B)), np.sort(np.roots(fitted.B))
    assert np.max(np.abs(zf - zt) / np.abs(zt)) < 20 * pole_tol
    w = 2 * np.pi * np.geomspace(1.0, 3000.0, 200)
    H, Ht = m.freqresp(w)[:, 0, 0], plant.freqresp(w)
    assert np.max(np.abs(H - Ht) / np.abs(Ht)) < frf_tol
    orders = {s.order: s.heldout_nrmse for s in res.scores}
    assert orders[2] > 100 * orders[3]            # too low an order is visibly worse


def test_mimo_periodic_round_trip_and_python_control_check():
    """2 outputs x 3 inputs, a real pole and two resonances, from periodic multisines
    (steady state); then python-control simulates the identified model on a fresh
    non-periodic record and must agree with the true system."""
    fs, P, periods = 6400.0, 4096, 2
    rng = np.random.default_rng(7)
    poles = np.array([-300.0 + 0j, -15 + 2 * np.pi * 420j, -40 + 2 * np.pi * 1300j])
    R = rng.normal(size=(3, 2, 3)) * 300 + 1j * rng.normal(size=(3, 2, 3)) * 300
    truth = ModalModel(poles, R, np.zeros((2, 3)))
    sys_t = truth.to_control()
    recs = []
    for r in range(4):
        U = rng.normal(size=(P, 3))                    # random-phase broadband, periodic
        Yall = _pc_response(sys_t, np.tile(U, (periods + 2, 1)), fs)[-periods * P:]
        Y = Yall + 0.002 * rng.standard_normal(Yall.shape)
        recs.append(Dataset(t=np.arange(periods * P) / fs, u=np.tile(U, (periods, 1)), y=Y,
                            period=P, source=f"ms{r}"))
    res = identify(recs[:3], validate=recs[3:], max_order=8)
    m = res.model
    assert res.order == 5 and (m.n_out, m.n_in) == (2, 3)
    a, b = np.sort_complex(m.all_poles()), np.sort_complex(truth.all_poles())
    assert np.max(np.abs(a - b) / np.abs(b)) < 1e-4
    w = 2 * np.pi * np.linspace(5.0, 2500.0, 400)
    H, Ht = m.freqresp(w), truth.freqresp(w)
    assert np.max(np.abs(H - Ht)) < 1e-3 * np.max(np.abs(Ht))
    u = _steps(6000, 9, hold=300)[:, None] * rng.uniform(-1, 1, 3)[None, :] / 150
    y_pc = _pc_response(m.to_control(), u, fs)          # python-control on the identified model
    y_true = _pc_response(sys_t, u, fs)
    assert np.max(np.abs(y_pc - y_true)) < 4e-4 * np.max(np.abs(y_true))
    y_own = m.discretise(fs).response(u)                # robrst's ZOH simulation agrees
    assert np.max(np.abs(y_own - y_pc)) < 1e-9 * np.max(np.abs(y_pc))


@pytest.mark.slow
def test_cli_temperature_family_problem_file_loads_and_designs(tmp_path, capsys):
    """Records at 28, 36 and 45 °C -> [[family.models]]; robrst design runs on the file as
    identify wrote it (its starting design), and with the user's [poles]."""
    base = paper_plant()
    files, truth = [], {}
    for T, g in ((28.0, 1.0), (36.0, 1.05), (45.0, 1.12)):
        A = base.A.copy()
        A[1] *= 1 + 0.01 * (T - 28)                      # damping changes with temperature
        pl = Plant(base.B * g, A)
        truth[T] = pl
        for rec in _siso_records(pl, 0.002, seeds=(int(T), int(T) + 1), n=12000, temp=T):
            files.append(str(save_dataset(rec, tmp_path / f"T{T:g}_{rec.source}.csv")))
    out = tmp_path / "model.toml"
    assert main(["identify", "--train", *files, "--out", str(out), "--quiet"]) == 0
    assert "identified order 3" in capsys.readouterr().out
    models, ref = load_linear_model(out)
    assert [mm.temperature_C for mm in models] == [28.0, 36.0, 45.0] and ref == 28.0
    w = 2 * np.pi * np.geomspace(1.0, 2000.0, 100)
    for mm in models:
        Ht = truth[mm.temperature_C].freqresp(w)
        assert np.max(np.abs(mm.freqresp(w)[:, 0, 0] - Ht) / np.abs(Ht)) < 1e-3
    prob = load_problem(out)                               # identify's starting design
    assert prob.solver.method == "nlp" and prob.specs.sample_rate_hz == FS
    text = out.read_text()
    out.write_text(text[:text.index("[poles]")] + "[poles]\nwn = 600.0\nzeta = 1.0\n")
    prob = load_problem(out)
    assert len(prob.family.models) == 3
    assert main(["design", str(out), "--quiet"]) in (0, 1)
    capsys.readouterr()
    assert main(["identify", "--train", *files[:2], "--out", str(out), "--order", "3",
                 "--quiet"]) == 0                           # robrst's own file: replaced


def test_identify_errors_name_the_problem(tmp_path, capsys):
    recs = _siso_records(paper_plant(), 0.0, seeds=(1, 2), n=3000)
    flat = Dataset(t=recs[0].t, u=np.full(3000, 5.0), y=recs[0].y, source="flat.csv")
    with pytest.raises(DataError, match="flat.csv: the input never changes"):
        identify([recs[0], flat])
    two = Dataset(t=recs[0].t, u=np.column_stack([recs[0].u, recs[1].u]), y=recs[0].y,
                  source="two.csv")
    with pytest.raises(DataError, match="two.csv: 2 input"):
        identify([recs[0], two])
    with pytest.raises(SpecError, match="order must be"):
        identify(recs, order=0)
    foreign = tmp_path / "mine.toml"
    foreign.write_text("# my notes\n")
    f = save_dataset(recs[0], tmp_path / "a.csv")
    assert main(["identify", "--train", str(f), "--out", str(foreign), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not written by robrst identify" in err[0]
    assert foreign.read_text() == "# my notes\n"
    assert main(["identify", "--train", str(f), "--out", str(tmp_path / "x.toml"),
                 "--order", "two"]) == 2


def test_orders_beyond_the_truth_stay_usable():
    """Orders far above the truth on noisy periodic records: vector fitting places spare
    poles anywhere, also on the negative real z axis (no continuous-time counterpart under
    ZOH).  Such poles are mirrored to the positive axis during relocation, so every
    candidate order gives a usable continuous-time model and a finite held-out NRMSE."""
    fs, P = 6400.0, 2048
    rng = np.random.default_rng(11)
    truth = ModalModel(np.array([-20 + 2 * np.pi * 500j]), np.array([[[400.0 + 100j]]]),
                       np.zeros((1, 1)))
    recs = []
    for r in range(3):
        u = rng.normal(size=P)
        y = _pc_response(truth.to_control(), np.tile(u, 4)[:, None], fs)[-2 * P:, 0]
        y = y + 0.3 * np.std(y) * rng.standard_normal(y.size)
        recs.append(Dataset(t=np.arange(2 * P) / fs, u=np.tile(u, 2), y=y, period=P,
                            source=f"n{r}"))
    res = identify(recs[:2], validate=recs[2:], max_order=24)
    assert all(np.isfinite(s.heldout_nrmse) for s in res.scores), [
        (s.order, s.note) for s in res.scores if s.note]
    z = res.model.discretise(fs).zpoles
    assert not np.any((np.abs(z.imag) == 0) & (z.real <= 0))
    assert res.heldout_nrmse < 0.35          # noise is 0.3 of the signal


def test_diagnose_takes_an_identified_model_file(tmp_path, capsys):
    """identify -> model file (2 outputs x 2 inputs) -> diagnose --model: the records of
    the same linear system come back ``none`` and the JSON names the model's channels;
    a problem file still gives its nominal plant (SISO)."""
    fs, P = 6400.0, 1024
    rng = np.random.default_rng(5)
    poles = np.array([-200.0 + 0j, -30 + 2 * np.pi * 700j])
    truth = ModalModel(poles, rng.normal(size=(2, 2, 2)) * 200 + 0j, np.zeros((2, 2)))
    files = []
    for r in range(4):
        U = rng.normal(size=(P, 2)) * 0.3
        Y = _pc_response(truth.to_control(), np.tile(U, (4, 1)), fs)[-2 * P:]
        Y = Y + 1e-3 * rng.standard_normal(Y.shape)
        rec = Dataset(t=np.arange(2 * P) / fs, u=np.tile(U, (2, 1)), y=Y, period=P,
                      source=f"r{r}")
        files.append(str(save_dataset(rec, tmp_path / f"r{r}.npz")))
    model = tmp_path / "model.toml"
    assert main(["identify", "--train", *files[:2], "--validate", files[2], "--out",
                 str(model), "--max-order", "4", "--quiet"]) == 0
    out = tmp_path / "diag.json"
    assert main(["diagnose", "--train", *files[:3], "--test", files[3], "--model", str(model),
                 "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert d["cause"] == "none" and (d["model"]["inputs"], d["model"]["outputs"]) == (2, 2)
    assert d["model"]["order"] == 3 and d["gap"]["before"] < 0.02
    capsys.readouterr()
    assert main(["diagnose", "--train", *files[:3], "--test", files[3], "--model",
                 "paper_robust", "--quiet"]) == 2          # SISO problem vs 2x2 records
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "2 input(s) and 2 output(s), but the model has 1 and 1" in err[0]
