"""``robrst diagnose --model-out DIR``: the answer's linear part as model files that robrst's
other commands read.

Stated before the run: on twin records with hysteresis hidden (the paper's D(s) as the
model), the answer is hysteresis and ``DIR/model.toml`` is a ``robrst-modal-1`` model file of
one input and one output whose response is the answer's re-fitted linear part (checked with
python-control against the poles and residues read with ``tomllib``); ``robrst design``'s
reader takes it as a problem (its design tables included) and a twin file's ``[twin] plant``
takes it; a file in the way that robrst diagnose did not write is refused (exit 2, one
line).  On periodic records at two levels, the amplitude-dependent answer writes one file
per excitation level.

The stiffness answer (the mirror recipe's records from a hardening spring, cubic stiffness
3e-6 /µm²) writes ``model.toml`` (the plant at small amplitude with the fitted gain: its
response, read with ``tomllib`` and built with python-control, is the paper's D(s) times
``1 + gain``) and ``twin.toml`` (that model with the fitted stiffness switched on):
``robrst design``'s reader takes the model, ``robrst simulate``'s reader takes the twin
file, and the twin run on the held-out record (one period of warm-up, as the diagnosis
simulates a periodic record) gives the held-out NRMSE the answer printed, recomputed here
with numpy (to 1e-6 relative); its static output at a held voltage solves ``y + c y^3 =
k u`` (numpy's roots), the Duffing law the file states.
"""

import json
import tomllib

import control
import numpy as np
import pytest

from robrst.cli import main as robrst
from robrst.core.plant import paper_plant
from robrst.data.dataset import save_dataset
from robrst.diagnose.validation import make_case
from robrst.problem.files import load_problem
from robrst.studies.twins import load_twin
from robrst.twin.simulate import simulate


def _bouc_wen_slopes(A, B, G, lo, hi, n=4000):
    """Least and largest ``d(u - h)/du`` on the periodic ``lo..hi`` triangle cycle of the
    Bouc-Wen recursion ``h += A du - B |du| h - G du |h|`` (third cycle from h = 0)."""
    u = np.concatenate([np.linspace(lo, hi, n), np.linspace(hi, lo, n)] * 3)
    h, v = 0.0, np.empty_like(u)
    for k in range(len(u)):
        d = u[k] - u[k - 1] if k else 0.0
        h += A * d - B * abs(d) * h - G * d * abs(h)
        v[k] = u[k] - h
    du, dv = np.diff(u[4 * n:]), np.diff(v[4 * n:])
    s = dv[du != 0] / du[du != 0]
    return np.array([s.min(), s.max()])


def _files(tmp_path, train, test):
    tr = [str(save_dataset(d, tmp_path / f"train{i}.npz")) for i, d in enumerate(train)]
    te = [str(save_dataset(d, tmp_path / f"test{i}.npz")) for i, d in enumerate(test)]
    return tr, te



def _diagnosed(tmp_path, capsys, train, test):
    """``robrst diagnose ... --model-out`` on the records: ``(train files, test files, model
    folder, the JSON)``."""
    tr, te = _files(tmp_path, train, test)
    out = tmp_path / "answer"
    code = robrst(["diagnose", "--train", *tr, "--test", *te, "--json", str(tmp_path / "d.json"),
                   "--model-out", str(out), "--quiet"])
    assert code == 0, capsys.readouterr().err
    return tr, te, out, json.loads((tmp_path / "d.json").read_text())

@pytest.mark.slow
def test_model_out_writes_a_model_design_and_simulate_read(tmp_path, capsys):
    train, test, truth = make_case("hysteresis", 1)
    tr, te, out, d = _diagnosed(tmp_path, capsys, train, test)
    assert d["cause"] == "hysteresis"
    # the hysteresis as the design's input-gain sector: the fitted map's incremental slopes
    # over the training records' voltages, recomputed here by the Bouc-Wen recursion
    sel = next(s for s in d["selected"] if s["name"] == "hysteresis")
    sec, q = sel["input_gain_sector"], sel["params"]
    lo, hi = sec["range_V"]
    u_train = np.concatenate([np.ravel(r.u) for r in train])
    assert (lo, hi) == pytest.approx((u_train.min(), u_train.max()), rel=1e-12)
    got = _bouc_wen_slopes(q["A"], q["B_per_V"], q["Gamma_per_V"], lo, hi) * q["gain"]
    assert sec["slopes"] == pytest.approx(list(got), rel=1e-6)
    assert sec["nominal"] * (1 - sec["delta"]) == pytest.approx(got[0], rel=1e-6)
    assert 0.05 < sec["delta"] < 0.5
    t = truth["params"]               # the hidden map's own sector, its gain normalised
    true = _bouc_wen_slopes(t["A"], t["B"], t["Gamma"], lo, hi)
    assert sec["delta"] == pytest.approx((true[1] - true[0]) / (true[1] + true[0]), abs=0.02)
    assert [f["file"] for f in d["model_files"]] == [str(out / "model.toml")]
    doc = tomllib.loads((out / "model.toml").read_text())
    at = doc["model"]["at"][0]
    assert doc["model"]["format"] == "robrst-modal-1" and doc["model"]["inputs"] == 1
    # the poles and residues as python-control sees them: a stable, positive-gain stage
    p = np.array(at["poles_re"]) + 1j * np.array(at["poles_im"])
    r = np.array(at["residues_re"])[:, 0, 0] + 1j * np.array(at["residues_im"])[:, 0, 0]
    terms = [control.tf([2 * ri.real, -2 * (ri * np.conj(pi)).real],
                        [1, -2 * pi.real, abs(pi) ** 2]) if pi.imag > 0
             else control.tf([ri.real], [1, -pi.real]) for pi, ri in zip(p, r)]
    g = sum(terms[1:], terms[0])
    dc = float(np.real(control.dcgain(g)))
    assert np.all(p.real < 0) and dc > 0
    problem = load_problem(out / "model.toml")         # what robrst design reads
    fam = problem.family
    assert fam.reference_model.dc_gain == pytest.approx(dc, rel=1e-6)
    twin = tmp_path / "twin.toml"
    twin.write_text('[twin]\nplant = "answer/model.toml"\n[noise]\n')
    cfg = load_twin(twin)                                # what robrst simulate reads
    assert cfg.linear_plant.dc_gain == pytest.approx(dc, rel=1e-6)
    # a file in the way that robrst diagnose did not write is refused
    (out / "model.toml").write_text("# mine\n")
    code = robrst(["diagnose", "--train", *tr, "--test", *te, "--model-out", str(out),
                   "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "not written by robrst diagnose" in err and err.count("\n") == 1


@pytest.mark.slow
def test_amplitude_dependent_answer_writes_a_model_per_level(tmp_path, capsys):
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from diagnosis_cases import make

    train, test, _, _ = make("recipe_hardening", 0)
    tr, te = _files(tmp_path, train, test)
    code = robrst(["diagnose", "--train", *tr, "--test", *te, "--json", str(tmp_path / "d.json"),
                   "--model-out", str(tmp_path / "m"), "--quiet"])
    assert code == 0, capsys.readouterr().err
    d = json.loads((tmp_path / "d.json").read_text())
    files = d["model_files"]
    if "amplitude_dependent_dynamics" in (d["final"] or {}).get("effects", []):
        assert len(files) == 3 and all(f["level_V"] for f in files)   # 8, 16, 24 V rms
        gains = [load_problem(f["file"]).family.reference_model.dc_gain for f in files]
        assert len(set(np.round(gains, 12))) == 3        # the model changes with the level
    else:                        # stiffness_nonlinearity (right: the mode hardens), or one model
        assert len(files) == 1


def _modal_tf(at):
    """python-control's transfer function of a [[model.at]] table read with tomllib."""
    p = np.array(at["poles_re"]) + 1j * np.array(at["poles_im"])
    r = np.array(at["residues_re"])[:, 0, 0] + 1j * np.array(at["residues_im"])[:, 0, 0]
    terms = [control.tf([2 * ri.real, -2 * (ri * np.conj(pi)).real],
                        [1, -2 * pi.real, abs(pi) ** 2]) if pi.imag > 0
             else control.tf([ri.real], [1, -pi.real]) for pi, ri in zip(p, r)]
    return sum(terms[1:], terms[0]) + at["D"][0][0]


def test_stiffness_answer_writes_a_model_and_a_twin_that_reproduce_it(tmp_path, capsys):
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from diagnosis_cases import make

    train, test, _, _ = make("recipe_hardening", 0)
    tr, te, out, d = _diagnosed(tmp_path, capsys, train, test)
    assert d["cause"] == "stiffness_nonlinearity"
    params = d["selected"][0]["params"]
    c, gain = params["cubic_per_um2"], params["gain"]
    assert c == pytest.approx(3e-6, rel=0.01)
    assert d["model_files"] == [{"file": str(out / "model.toml"), "level_V": None, "order": 3,
                                 "twin_file": str(out / "twin.toml")}]
    # the model: D(s) (1 + gain), checked with python-control on a dense grid
    at = tomllib.loads((out / "model.toml").read_text())["model"]["at"][0]
    g = _modal_tf(at)
    ref = paper_plant()
    w = np.logspace(1, np.log10(np.pi * 5000.0), 400)
    want = (1 + gain) * np.polyval(ref.B, 1j * w) / np.polyval(ref.A, 1j * w)
    assert np.max(np.abs(g(1j * w) - want) / np.abs(want)) < 1e-9
    assert load_problem(out / "model.toml").family.reference_model.dc_gain == pytest.approx(
        float(np.real(control.dcgain(g))), rel=1e-9)          # what robrst design reads
    # the twin file: what robrst simulate reads, the stiffness on with the fitted c
    cfg = load_twin(out / "twin.toml")
    assert [k for k in cfg.effects if cfg.enabled(k)] == ["stiffness_nonlinearity"]
    assert cfg.effects["stiffness_nonlinearity"]["cubic_per_um2"] == pytest.approx(c, rel=1e-12)
    assert cfg.sample_rate_hz == 5000.0
    # the held-out error of the answer, recomputed: the twin on the test record in steady state
    rec = test[0]
    P = rec.period
    u = np.concatenate([rec.u[-P:], rec.u])
    y = simulate(cfg, np.full(u.size, 30.0), u=u).y_true[P:]
    nrmse = np.linalg.norm(rec.y - y) / np.linalg.norm(rec.y - rec.y.mean())
    assert nrmse == pytest.approx(d["gap"]["after"], rel=1e-6)
    assert nrmse < 2 * d["gap"]["noise_floor"]
    # the Duffing law at a held voltage: y + c y^3 = k u (k the file's static gain)
    k = float(np.real(control.dcgain(g)))
    y_hold = simulate(cfg, np.full(20000, 30.0), u=np.full(20000, 100.0)).y_true[-1]
    root = np.roots([c, 0.0, 1.0, -k * 100.0])
    assert y_hold == pytest.approx(float(root[np.isreal(root)].real[0]), rel=1e-6)


def test_a_foreign_file_in_the_model_out_folder_is_refused_before_the_work(tmp_path, capsys,
                                                                            monkeypatch):
    """A model.toml (or model_<level>Vrms.toml, twin.toml) robrst did not write: refused
    before the diagnosis runs (it ran to the end, then refused), the file untouched."""
    import robrst.diagnose as diagnose_pkg

    t = np.arange(2000) / 20000.0
    rec = tmp_path / "r.csv"
    rec.write_text("t,u,y\n" + "\n".join(f"{a:.9g},{5 + np.sin(400 * a):.9g},{np.sin(400 * a):.9g}"
                                         for a in t) + "\n")

    def boom(*a, **k):
        raise AssertionError("diagnosed before refusing")

    monkeypatch.setattr(diagnose_pkg, "diagnose", boom)     # the CLI imports it when it runs
    for name in ("model.toml", "twin.toml", "model_0.1Vrms.toml"):
        folder = tmp_path / name.replace(".", "_")
        folder.mkdir()
        (folder / name).write_text("mine\n")
        assert robrst(["diagnose", "--train", str(rec), "--test", str(rec), "--quiet",
                       "--model-out", str(folder)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and name in err[0] and "not written by robrst" in err[0], err
        assert (folder / name).read_text() == "mine\n"
