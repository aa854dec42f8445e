"""Infeasible or not found (robrst.synthesis.feasibility): every proof re-checked by a few
lines of independent arithmetic, feasible problems never called infeasible, and a
pole-region failure answered with the mode, the damping reached and what to try.

The independent check of a proof: the model at the named temperature is rebuilt from the
problem document (``random_problems.model_at``, the thermal law re-derived), its response
evaluated with ``numpy.polyval`` on the unscaled polynomials (continuous loop) or through
python-control's ZOH model at ``z = exp(j w / fs)`` (sampled loop), and the two disc radii
``min(Ms, Msd/|D|)`` and ``min(Mt, Tres in its band, Mu |D|)`` computed by hand: they must
sum below 1 at the named frequency and at both ends of the named band.

Reproducers: ``tests/repro/optimum_scan/b_damp.toml`` (293 s and a bare "not certified";
the truth: no proof, name the mode), ``b_plain.toml``, ``a_ms1.5.toml``, ``a_ms2.0.toml``
(feasible: certified designs exist).
"""

import json
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import control
import numpy as np
import pytest

from random_problems import fold_band, model_at, random_case
from robrst import load_problem
from robrst.certificate.proof import certify_problem
from robrst.problem.files import parse_problem
from robrst.synthesis.analytic import pole_placement
from robrst.synthesis.feasibility import feasibility_verdict, prove_infeasible

TESTS = Path(__file__).resolve().parents[1]
SCAN = TESTS / "repro" / "optimum_scan"


def scan_doc(name, **specs):
    doc = tomllib.loads((SCAN / name).read_text(encoding="utf-8"))
    doc["specs"].update(specs)
    return doc


def response(doc, T, w_rad_s, loop):
    """The model's response at ``w`` [rad/s], independently of robrst."""
    B, A = model_at(doc, T)
    if loop == "continuous":
        return np.polyval(B, 1j * w_rad_s) / np.polyval(A, 1j * w_rad_s)
    fs = doc["specs"]["sample_rate_hz"]
    P = control.c2d(control.tf(B, A), 1 / fs, "zoh")
    z = np.exp(1j * w_rad_s / fs)
    return complex(P(z)) * z ** -doc["specs"].get("delay_samples", 0)


def radii(doc, D, f_hz, loop):
    """The two disc radii at ``f_hz`` (a sampled loop: bands folded into [0, Nyquist])."""
    sp = doc["specs"]
    mag = abs(D)
    rS = min(sp.get("Ms_max", np.inf), sp["Msd_max"] / mag if "Msd_max" in sp else np.inf)
    rT = min(sp.get("Mt_max", np.inf), sp["Mu_max"] * mag if "Mu_max" in sp else np.inf)
    fs = sp.get("sample_rate_hz") if loop == "sampled" else None
    w = 2 * np.pi * f_hz
    band = sp.get("resonance_band_hz")
    if band and sp.get("T_resonance_max") is not None:
        lo, hi = 2 * np.pi * band[0], 2 * np.pi * band[1]
        inside = (lo <= w <= hi if fs is None else
                  fold_band((lo, hi), fs)[0] <= w / fs <= fold_band((lo, hi), fs)[1])
        if inside:
            rT = min(rT, sp["T_resonance_max"])
    if "Mu_hf_max" in sp and f_hz >= min(sp["Mu_hf_above_hz"], fs / 2 if fs else np.inf):
        rT = min(rT, sp["Mu_hf_max"] * mag)
    return rS, rT


def check_proof(doc, pr):
    pts = [pr.worst_hz] + [f for f in pr.band_hz if np.isfinite(f)]
    for f in pts:
        D = response(doc, pr.temperature_C, 2 * np.pi * f, pr.loop)
        rS, rT = radii(doc, D, f, pr.loop)
        assert rS + rT < 1, (pr.reason, f, rS, rT)


def test_discs_that_miss_at_the_resonance_are_named_with_model_and_band():
    """Msd_max 0.5 (|D| = 1.68 µm/V at 1.3 kHz: |S| <= 0.30 there) and |T| <= 0.6 in the
    band: no complex T(jw) meets both, on every model, both loops."""
    doc = scan_doc("a_ms2.0.toml", Msd_max=0.5, T_resonance_max=0.6,
                   resonance_band_hz=[1200.0, 1400.0])
    p = parse_problem(doc, "<res>")
    t0 = time.perf_counter()
    proofs = prove_infeasible(p)
    assert time.perf_counter() - t0 < 60
    assert len(proofs) == 16           # 8 models x 2 loops
    pr = proofs[0]
    assert set(pr.specs) == {"Msd_max", "T_resonance_max"}
    assert 1200 <= pr.band_hz[0] < pr.worst_hz < pr.band_hz[1] <= 1400
    assert pr.model in pr.reason and "Hz" in pr.reason
    for pr in proofs:
        check_proof(doc, pr)


def test_integral_action_with_Mu_below_one_over_D0_is_infeasible_at_0Hz():
    doc = scan_doc("a_ms2.0.toml", Mu_max=15.0)
    proofs = prove_infeasible(parse_problem(doc, "<mu>"))
    assert proofs and all(p.band_hz == (0.0, 0.0) and p.specs == ("Mu_max",) for p in proofs)
    for p in proofs:
        B, A = model_at(doc, p.temperature_C)
        assert 15.0 * abs(B[-1] / A[-1]) < 1         # |U(0)| = 1/|D(0)| > Mu_max
        assert p.worst_sum == pytest.approx(15.0 * abs(B[-1] / A[-1]), rel=1e-9)


def test_a_corner_spec_is_infeasible_from_the_corner_itself():
    """|U| <= 5 V/µm above 500 Hz where |D| ~ 0.05 µm/V allows |T| <= 0.25, and Msd_max 0.02
    asks |S| <= 0.4: the discs miss from the corner on (the corner included, the bands are
    closed) up to where the resonance lifts |D|."""
    doc = scan_doc("a_ms2.0.toml", Msd_max=0.02, Mu_hf_max=5.0, Mu_hf_above_hz=500.0)
    proofs = prove_infeasible(parse_problem(doc, "<hf>"))
    assert len(proofs) == 16
    for pr in proofs:
        assert set(pr.specs) == {"Msd_max", "Mu_hf_max"}
        assert pr.band_hz[0] == pytest.approx(500.0, rel=1e-9) and pr.band_hz[1] < 1300
        check_proof(doc, pr)


@pytest.mark.parametrize("name", ["paper", "paper_robust", "paper_robust_continuous",
                                  "a_ms1.5.toml", "a_ms2.0.toml", "b_plain.toml"])
def test_feasible_problems_are_never_called_infeasible(name):
    """Problems with certified designs (shipped; the optimum scan's a_ms1.5, a_ms2.0,
    b_plain)."""
    p = load_problem(SCAN / name if name.endswith(".toml") else name)
    assert prove_infeasible(p) == ()


@pytest.mark.slow
def test_random_problems_proofs_hold_and_solvable_ones_are_never_called_infeasible():
    """Seeded random problems (orders 1-6, sampled loops with delays and folded bands,
    integrating plants): every proof found holds by the independent arithmetic, and no
    problem whose specs the analytic design at its own poles meets (by the independent
    checker) is called infeasible."""
    solvable = proved = 0
    for seed in range(12):
        c = random_case(seed)
        proofs = prove_infeasible(c.problem(), n=800)
        if c.baseline_ok:
            assert proofs == (), seed
            solvable += 1
        for pr in proofs:
            if pr.band_hz != (0.0, 0.0):
                check_proof(c.data, pr)
            proved += 1
    assert solvable >= 5


def test_b_damp_not_found_names_the_mode_and_what_to_try():
    """b_damp (damping_min 0.05): no proof exists for its peak specs; a design that misses
    the pole region gets the mode below the floor with the damping reached, checked against
    the roots of A S + B R of the named model, and the suggestions."""
    doc = tomllib.loads((SCAN / "b_damp.toml").read_text(encoding="utf-8"))
    p = load_problem(SCAN / "b_damp.toml")
    assert prove_infeasible(p) == ()
    ctrl = pole_placement(p.family.reference_model, p.poles, p.controller).controller
    cert = certify_problem(p, ctrl)
    assert not cert.certified
    v = feasibility_verdict(p, cert, ctrl)
    assert v.status == "not_found" and not v.proofs
    assert "damping" in v.mode and "extra_degree = 2" in v.suggestion
    assert "damping_min" in v.not_expressed
    low = [x for x in cert.violations if x.quantity == "closed-loop damping"]
    worst = min(low, key=lambda x: x.value)
    assert f"{worst.value:.4g}" in v.mode and worst.label in v.mode
    # the damping reached, independently: roots of the named model's closed loop
    B, A = model_at(doc, worst.temperature_C)
    if worst.loop == "continuous":
        r = np.roots(np.polyadd(np.polymul(A, ctrl.S), np.polymul(B, ctrl.R)))
    else:
        fs = doc["specs"]["sample_rate_hz"]
        P = control.c2d(control.tf(B, A), 1 / fs, "zoh")
        C = control.c2d(control.tf(ctrl.R, ctrl.S), 1 / fs, "tustin")
        r = np.log(control.feedback(P * C, 1).poles().astype(complex)) * fs
    zeta = -r.real / np.abs(r)
    k = int(np.argmin(zeta))
    assert zeta[k] == pytest.approx(worst.value, rel=1e-3)
    assert abs(abs(r[k].imag) - worst.freq_rad_s) < 0.01 * worst.freq_rad_s


@pytest.mark.slow
def test_design_of_infeasible_specs_answers_within_60_s(tmp_path):
    """``robrst design --json`` on specs no linear controller meets: exit 1 within 60 s,
    the proof in the JSON (model, band, specs) and in the text."""
    doc = scan_doc("a_ms2.0.toml", Msd_max=0.5, T_resonance_max=0.6,
                   resonance_band_hz=[1200.0, 1400.0])
    f = tmp_path / "res.toml"
    from random_problems import to_toml

    f.write_text(to_toml(doc), encoding="utf-8")
    root = Path(__file__).resolve().parents[2]
    env = {"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"}
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "robrst", "design", str(f), "--json",
                          "--quiet"], capture_output=True, text=True, env=env, timeout=120)
    assert time.perf_counter() - t0 < 60
    assert out.returncode == 1, out.stderr
    d = json.loads(out.stdout)
    fe = d["feasibility"]
    assert fe["status"] == "infeasible"
    pr = fe["proofs"][0]
    assert pr["model"].startswith("T") and 1200 <= pr["band_hz"][0] <= pr["band_hz"][1] <= 1400
    assert d["objective_bound"]["status"] == "infeasible"
    text = subprocess.run([sys.executable, "-m", "robrst", "design", str(f), "--quiet"],
                          capture_output=True, text=True, env=env, timeout=120).stdout
    assert "infeasible: no linear controller meets these specs" in text


def test_a_feasibility_problem_stops_at_the_first_controller_that_meets_every_spec():
    """``objective = "feasibility"`` asks for any certified controller: on ``paper_robust``
    with that objective the problem's own poles certify and meet the reference-step specs,
    and the global phase that followed (12,217 candidates, 8.4 s CPU) returned that same
    controller. It is not run any more; the answer is checked here on python-control's
    sampled loops (ZOH plant, Tustin controller) of every family member: stable, |S| and
    |T| within their bounds on a dense grid up to Nyquist."""
    from robrst.design import run_problem

    doc = tomllib.loads((TESTS.parent / "problems" / "paper_robust.toml").read_text())
    doc["solver"]["objective"] = "feasibility"
    doc["solver"].pop("compare_with", None)
    pr = parse_problem(doc, "<paper_robust, feasibility>")
    t0 = time.process_time()
    res = run_problem(pr, analyses=False)
    assert res.certified
    assert any("no global phase (nothing to optimise)" in n for n in res.synthesis.notes), res.synthesis.notes
    assert time.process_time() - t0 < 6.0
    fs, c = pr.specs.sample_rate_hz, res.controller
    # state space throughout: the expanded z-polynomials of the slow creep pole and the
    # resonance put spurious roots outside the unit circle
    Kd = control.c2d(control.ss(control.tf(c.R, c.S)), 1.0 / fs, "tustin")
    w = np.geomspace(1.0, np.pi * fs, 60000)
    for m in pr.family.models:
        L = control.c2d(control.ss(control.tf(m.B, m.A)), 1.0 / fs, "zoh") * Kd
        assert np.all(np.abs(control.poles(control.feedback(L, 1))) < 1), m.label
        Lj = L(np.exp(1j * w / fs))
        assert np.max(np.abs(1 / (1 + Lj))) <= pr.specs.Ms_max * 1.001, m.label
        assert np.max(np.abs(Lj / (1 + Lj))) <= pr.specs.Mt_max * 1.001, m.label
