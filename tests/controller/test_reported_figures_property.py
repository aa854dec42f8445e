"""Every figure that ``certify``, ``export``, ``check`` and ``load_design`` report equals an
independent recomputation on the unscaled loop (fourth round: a controller without its
integrator was reported with an integral gain it does not have).

Seeded random problems (one or two resonances, a parametric family or a single model,
continuous or sampled with 0 or 1 samples of delay) and random controllers (pole placement
at random poles; in one case of three the integrator replaced by a slow real pole, ``S(0) !=
0``), saved as a design's JSON and read back by each reporting path.  Truth, independent of
robrst's numerical code:

* continuous loop: ``|S|, |T|, |U|, |B S/Delta|`` on a dense logarithmic grid of the unscaled
  polynomials (``numpy.polyval``) with local refinement; gain, phase and modulus margins by
  ``control.stability_margins`` of ``L = B R / (A S)``; the delay margin from the gain
  crossovers found on the grid;
* sampled loop: the plant through ``control.c2d`` (ZOH) behind ``z**-k``, the controller
  ``R/S`` through ``control.c2d(..., "tustin")`` (``pcloop``), peaks on a dense unit-circle
  grid with local refinement;
* integral gain: ``s R(s)/S(s)`` at ``s = 1e-40`` in 60-digit mpmath (0 without an
  integrator).

python-control plants (continuous and ``control.c2d``'s discrete ones) through
``robrst.analyze`` are checked against the same truth.
"""

import json
import math

import control
import mpmath
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import pcloop
import robrst
from robrst.cli import main
from robrst.controller.artefact import load_design
from robrst.core.plant import Plant
from robrst.design import run_problem
from robrst.problem.files import load_problem

RTOL = 1e-6


def _pair(f, z):
    w = 2 * math.pi * f
    return [1.0, 2 * z * w, w * w]


def draw(seed):
    """``(problem TOML text, remove the integrator?, sample rate, delay)`` of ``seed``."""
    rng = np.random.default_rng(seed)
    f1, z1 = rng.uniform(300, 2000), rng.uniform(0.005, 0.05)
    A = _pair(f1, z1)
    if rng.uniform() < 0.4:
        A = np.convolve(A, _pair(f1 * rng.uniform(2.0, 4.0), rng.uniform(0.005, 0.05))).tolist()
    k = rng.uniform(0.02, 0.2)
    B = [k * A[-1]]
    fs = [None, 10000.0, 20000.0, 25000.0][int(rng.integers(0, 4))]
    delay = int(rng.integers(0, 2)) if fs else 0
    single = rng.uniform() < 0.3
    wn = 2 * math.pi * f1 / rng.uniform(4, 8)
    lines = ["[problem]", f'name = "prop{seed}"', "[plant]", f"B = {B}", f"A = {list(A)}",
             "temperature_C = 25.0"]
    if not single:
        lines += ["[family]", "temperatures_C = [20.0, 30.0, 40.0]", "[family.parametric]",
                  f"resonance_per_K = {rng.uniform(-3e-4, 3e-4):.6g}",
                  f"damping_per_K = {rng.uniform(-3e-3, 3e-3):.6g}",
                  f"gain_per_K = {rng.uniform(-2e-3, 2e-3):.6g}"]
    lines += ["[controller]", f"extra_degree = {int(rng.integers(0, 2))}",
              "[poles]", f"wn = {wn:.6g}", "zeta = 1.0", "[specs]", "Ms_max = 4.0"]
    if fs:
        lines += [f"sample_rate_hz = {fs}", f"delay_samples = {delay}"]
    lines += ["[solver]", 'method = "analytic"', "cert_temperatures = 5"]
    return "\n".join(lines) + "\n", rng.uniform() < 0.35, fs, delay


def _peak(N, D, lo=1e-2, hi=1e7, n=100_001):
    w = np.geomspace(lo, hi, n)
    g = np.abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w))
    i = int(np.argmax(g))
    a, b = w[max(i - 1, 0)], w[min(i + 1, n - 1)]
    r = minimize_scalar(lambda x: -abs(np.polyval(N, 1j * x) / np.polyval(D, 1j * x)),
                        bounds=(a, b), method="bounded", options={"xatol": 1e-12 * b})
    top = max(float(g[i]), -float(r.fun))
    if len(np.trim_zeros(N, "f")) == len(np.trim_zeros(D, "f")):   # the limit at infinity
        top = max(top, abs(np.trim_zeros(N, "f")[0] / np.trim_zeros(D, "f")[0]))
    return top


def continuous_truth(B, A, R, S):
    mul, add = np.polymul, np.polyadd
    D = add(mul(A, S), mul(B, R))
    out = {"Ms": _peak(mul(A, S), D), "Mt": _peak(mul(B, R), D), "Mu": _peak(mul(A, R), D),
           "Msd": _peak(mul(B, S), D)}
    L = control.tf(mul(B, R), mul(A, S))
    gm, pm, sm, wpc, wgc, wms = control.stability_margins(L)
    out.update(gm_pc=gm, phase_margin_deg=pm, modulus_margin=1 / out["Ms"])
    w = np.geomspace(1e-2, 1e7, 400_001)
    Lw = np.polyval(mul(B, R), 1j * w) / np.polyval(mul(A, S), 1j * w)
    cross = np.flatnonzero(np.diff(np.sign(np.abs(Lw) - 1.0)))
    dms = []
    for i in cross:
        x = minimize_scalar(lambda v: abs(abs(np.polyval(mul(B, R), 1j * v)
                                              / np.polyval(mul(A, S), 1j * v)) - 1),
                            bounds=(w[i], w[i + 1]), method="bounded",
                            options={"xatol": 1e-13 * w[i + 1]}).x
        ang = np.angle(np.polyval(mul(B, R), 1j * x) / np.polyval(mul(A, S), 1j * x))
        dms.append(((ang + np.pi) % (2 * np.pi)) / x)
    out["delay_margin_s"] = max(0.0, min(dms)) if dms else None
    out["stable"] = bool(np.all(np.roots(D).real < 0))
    return out


def sampled_truth(B, A, R, S, fs, delay):
    plant = Plant(B, A)
    Pz = control.tf(pcloop.zoh_plant(plant, fs, delay))
    w0 = pcloop.time_scale(plant)
    degS = len(S) - 1

    def scaled(c):
        c = np.concatenate([np.zeros(degS + 1 - len(c)), c])
        return c * w0 ** np.arange(degS, -1, -1) / w0 ** degS

    Kz = control.c2d(control.tf(scaled(R), scaled(S)), w0 / fs, "tustin")
    L = lambda z: pcloop.resp(Pz, z) * pcloop.resp(Kz, z)     # noqa: E731
    return {"Ms": pcloop.unit_circle_max(lambda z: 1 / (1 + L(z))),
            "Mt": pcloop.unit_circle_max(lambda z: L(z) / (1 + L(z))),
            "Mu": pcloop.unit_circle_max(lambda z: pcloop.resp(Kz, z) / (1 + L(z)))}


def integral_gain_truth(R, S):
    s = mpmath.mpf("1e-40")
    with mpmath.workdps(60):
        def h(c):
            out = mpmath.mpf(0)
            for a in c:
                out = out * s + mpmath.mpf(float(a))
            return out
        return float(s * h(R) / h(S))


def _close(a, b, what):
    if b is None or (isinstance(b, float) and math.isinf(b)):
        assert a is None or math.isinf(a), (what, a, b)
        return
    assert a == pytest.approx(b, rel=RTOL, abs=1e-12), (what, a, b)


def _saved(seed, tmp_path):
    text, no_int, fs, delay = draw(seed)
    (tmp_path / "p.toml").write_text(text)
    d = run_problem(load_problem(tmp_path / "p.toml")).as_dict()
    if no_int:          # the integrator replaced by a slow real pole: S' s -> S' (s + eps)
        S = np.array(d["controller"]["S"])
        eps = 1e-4 * d["controller_factored"]["w0_rad_s"]
        d["controller"]["S"] = np.convolve(S[:-1], [1.0, eps]).tolist()
    path = tmp_path / "D.json"
    path.write_text(json.dumps(d))
    return path, no_int, fs, delay


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(8))
def test_every_reported_figure_is_the_loops(seed, tmp_path, capsys):
    path, no_int, fs, delay = _saved(seed, tmp_path)
    res = load_design(path)
    ctrl = res.controller
    R, S = np.trim_zeros(ctrl.R, "f"), np.trim_zeros(ctrl.S, "f")
    ki = integral_gain_truth(R, S)
    if no_int:
        assert ki == pytest.approx(0.0, abs=1e-25)
        assert not res.certified and res.integral_gain == 0.0
    _close(res.integral_gain, ki, "integral_gain")
    # certify: the same figures as load_design, from the JSON
    rc = main(["certify", str(path), "--json"])
    cj = json.loads(capsys.readouterr().out)
    assert rc == (0 if cj["certified"] else 1) and cj["certified"] == res.certified
    _close(cj["integral_gain"], ki, "certify integral_gain")
    # the golden of check --update: per family member
    golden = tmp_path / "g.toml"
    main(["check", str(path), "--golden", str(golden), "--update", "--quiet"])
    capsys.readouterr()
    from robrst.testing import read_golden

    g = read_golden(golden)
    if g["objective"] is not None:
        _close(g["objective"][1], abs(ki) if not no_int else 0.0, "golden objective")
    # export at the problem's rate (or 20 kHz): its sampled figures
    efs = fs or 20000.0
    assert main(["export", str(path), "--fs", str(efs), "--quiet", "--out",
                 str(tmp_path / "x.json")]) in (0, 1)
    capsys.readouterr()
    ex = json.loads((tmp_path / "x.json").read_text())["certificate"]
    plants = {m.label: m for m in res.problem.family.models}
    for rec, am, jm in zip(res.analyses, res.problem.family.models, cj["models"]):
        t = continuous_truth(am.B, am.A, R, S)
        for key, pk in (("Ms", "S"), ("Mt", "T"), ("Mu", "U"), ("Msd", "Sd")):
            _close(rec.peaks[pk].value, t[key], f"{am.label} {key}")
            _close(jm[key], t[key], f"certify {am.label} {key}")
            if key in g["models"][am.label]:
                _close(g["models"][am.label][key][0], t[key], f"golden {am.label} {key}")
        m = rec.margins
        gm_rob = m.gain_margin if m.gain_margin_lower is None else (
            m.gain_margin_lower if m.gain_margin is None else
            min((m.gain_margin, m.gain_margin_lower), key=lambda x: abs(math.log(x))))
        _close(gm_rob, t["gm_pc"], f"{am.label} gain margin")
        assert m.phase_margin_deg == pytest.approx(t["phase_margin_deg"], abs=1e-6)
        _close(m.modulus_margin, t["modulus_margin"], "modulus margin")
        _close(jm["delay_margin_s"], t["delay_margin_s"], "delay margin")
        assert rec.stable == t["stable"]
        # python-control plants through robrst.analyze: the same continuous loop
        a = robrst.analyze(control.tf(am.B, am.A), ctrl)
        _close(a.peaks["S"].value, t["Ms"], "analyze(control.tf) Ms")
    # sampled figures: the certificate's (load_design, certify), the export's, the golden's
    worst = {k: 0.0 for k in ("Ms", "Mt", "Mu")}
    assert len(cj["certificate"]["models"]) == len(res.certificate.models)
    for r, jr in zip(res.certificate.models, cj["certificate"]["models"]):
        plant = plants.get(r.label) or res.problem.family.at(r.temperature_C)
        ts = sampled_truth(plant.B, plant.A, R, S, efs, delay if fs else 0)
        for k in worst:
            worst[k] = max(worst[k], ts[k])
        if fs:
            for k in worst:
                _close(r.value(k, "sampled"), ts[k], f"{r.label} {k}_sampled")
                _close(jr[f"{k}_sampled"], ts[k], f"certify {r.label} {k}_sampled")
            if r.family_member and f"{k}_sampled" in g["models"].get(r.label, {}):
                _close(g["models"][r.label][f"{k}_sampled"][0], ts[k], "golden sampled")
    if fs:
        for k in worst:
            _close(ex[f"{k}_sampled"], worst[k], f"export {k}_sampled")
        # a discrete python-control plant: the sampled loop
        m0 = res.problem.family.models[0]
        Pz = control.c2d(control.tf(m0.B, m0.A), 1 / fs, "zoh")
        if delay:
            Pz = Pz * control.tf([1.0], [1.0] + [0.0] * delay, 1 / fs)
        a = robrst.analyze(Pz, ctrl)
        ts = sampled_truth(m0.B, m0.A, R, S, fs, delay)
        assert a.peaks["S"].value == pytest.approx(ts["Ms"], rel=1e-5)


@pytest.mark.large
@pytest.mark.parametrize("seed", range(8, 48))
def test_every_reported_figure_is_the_loops_large(seed, tmp_path, capsys):
    test_every_reported_figure_is_the_loops(seed, tmp_path, capsys)
