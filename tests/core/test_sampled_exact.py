"""The sampled plant is exact for every pole location; sampled bands reach Nyquist exactly.

Reference: :class:`random_problems.ExactZOH`, the zero-order hold in 60-digit mpmath (one
matrix exponential of the augmented matrix ``[[A T, B T], [0, 0]]``), independent of
robrst's kernels and of python-control.  The sampled plant ``P_w`` of robrst must equal
``P_d(e^{j w T})`` at ``nu = 2 fs tan(w T / 2)``, Nyquist (``z = -1``, ``nu = inf``)
included, for near-integrators (a pole at ``-eps`` beside O(1) poles), near-cancellations
and clusters, at 100 Hz and 20 kHz.

Reproducers: ``tests/repro/sampled_near_integrator.toml`` (a wrong certificate: the sampled
plant's zeros of ``2/((s + 1e-9)(s + 1)(s + 2))`` came out as -4.0e4 and -0.006 +- 24.5j
instead of -344.9, 200, 347.9, and Ms 1.3401 was certified where the truth is 1.37344) and
``tests/repro/sampled_band_top_unchecked/`` (the sampled band was checked only up to
0.999 x Nyquist: 0.0911984 certified where the truth is 0.0912067 > 0.0912).
"""

import json
import math

import numpy as np
import pytest

import random_problems as rp
from robrst.certificate.proof import certify_problem
from robrst.cli import main
from robrst.core.plant import Plant, paper_plant
from robrst.core.rst import RSTController
from robrst.core.sampled import sampled_plant, warp, warp_band
from robrst.design import run_problem
from robrst.problem.files import load_problem


def _A(*poles):
    return np.real(np.poly(poles))


PLANTS = {
    # near-integrators: a pole at -eps beside poles at -1, -2 (the reproducer's plant at 1e-9)
    "integrator": ([2.0], _A(0.0, -1.0, -2.0)),
    "near_integrator_1e-9": ([2.0], np.polymul(np.polymul([1, 1e-9], [1, 1]), [1, 2])),
    "near_integrator_1e-6": ([2.0], np.polymul(np.polymul([1, 1e-6], [1, 1]), [1, 2])),
    "near_integrator_1e-3": ([2.0], np.polymul(np.polymul([1, 1e-3], [1, 1]), [1, 2])),
    "two_near_integrators": ([1.0], _A(0.0, -1e-9, -5.0)),
    "near_integrator_resonance": ([3e4], np.polymul([1, 1e-8], [1, 20.0, 1e4])),
    "near_cancellation": (np.polymul([1, 1e-9 + 1e-12], [3.0]),
                          np.polymul(np.polymul([1, 1e-9], [1, 1]), [1, 2])),
    "cluster": ([1.0], _A(-1.0, -1.0 - 1e-7, -3.0)),
    "double_integrator": ([1.0], [1.0, 0.0, 0.0]),
    "paper": (paper_plant().B, paper_plant().A),
}


def _theta(fs):
    """rad/sample: log-spaced from low to just below Nyquist, then Nyquist itself."""
    return np.concatenate([np.geomspace(1e-4, 0.999 * np.pi, 40), [np.pi]])


def _pw_at(pw, theta, fs):
    """``P_w(j nu)`` of robrst's sampled plant (``nu = inf`` at Nyquist: the limit)."""
    out = []
    for th in theta:
        if th >= np.pi:
            out.append(pw.B[0] / pw.A[0] if len(pw.B) == len(pw.A) else 0.0)
        else:
            s = 1j * 2 * fs * math.tan(th / 2)
            out.append(np.polyval(pw.B, s) / np.polyval(pw.A, s))
    return np.array(out)


@pytest.mark.parametrize("fs", [100.0, 20000.0])
@pytest.mark.parametrize("name", sorted(PLANTS))
def test_sampled_plant_equals_the_extended_precision_zoh(name, fs):
    B, A = PLANTS[name]
    pw = sampled_plant(Plant(B, A), fs)
    th = _theta(fs)
    ref = rp.ExactZOH(B, A, fs).at(th)
    got = _pw_at(pw, th, fs)
    tiny = 1e-40 * np.max(np.abs(ref))           # an exact zero of P_d at Nyquist
    err = np.abs(got - ref) / np.maximum(np.abs(ref), tiny)
    # float64 resolves P_d to ~1e-11 where |P_d| is 1e-9 of its low-frequency size
    # (the double integrator's zero at Nyquist: only its approach is evaluated)
    assert np.max(err[:-1]) < 1e-9, (name, fs, th[np.argmax(err)], np.max(err))
    assert abs(got[-1] - ref[-1]) <= 1e-9 * abs(ref[-1]) + tiny


def test_near_integrator_zeros_are_those_of_the_integrator():
    """At eps = 1e-9 the w-plane zeros are -344.9, 200, 347.9 (within 1e-6 relative of the
    exact integrator's: the zeros move by O(eps))."""
    for eps in (1e-9, 1e-6):
        A = np.polymul(np.polymul([1, eps], [1, 1]), [1, 2])
        z = np.sort(np.roots(sampled_plant(Plant([2.0], A), 100.0).B).real)
        assert np.allclose(z, [-344.918281, 200.0, 347.918352], rtol=2e-6), (eps, z)


def test_sampled_dc_gain_is_exact():
    """The ZOH keeps the static gain: P_w(0) = B(0)/A(0), for random plants (orders 1-6,
    resonances, RHP zeros, 1-100 kHz) and a near-integrator (static gain 1e9)."""
    worst = 0.0
    for seed in range(200):
        ch = rp.NumpyChooser(seed)
        fs = ch.loguniform(1e3, 1e5)
        pairs, reals, zp, zr, _ = rp._plant_parts(ch, {}, fs)
        B, A = rp._coeffs(pairs, reals, zp, zr, ch.loguniform(0.01, 10.0), 1.0)
        if A[-1] == 0:
            continue
        p = Plant(B, A)
        worst = max(worst, abs(sampled_plant(p, fs).dc_gain / p.dc_gain - 1))
    assert worst < 1e-11, worst
    ni = Plant(*PLANTS["near_integrator_1e-9"])
    for fs in (100.0, 20000.0):
        assert sampled_plant(ni, fs).dc_gain == pytest.approx(ni.dc_gain, rel=1e-12)


def test_near_integrator_reproducer_is_not_certified(repro_dir):
    """sampled_near_integrator.toml: the sampled Ms is 1.37344 (python-control's discrete
    loop and the 60-digit ZOH agree) > Ms_max = 1.36: not certified."""
    pr = load_problem(repro_dir / "sampled_near_integrator.toml")
    res = run_problem(pr)
    B, A = pr.family.reference_model.B, pr.family.reference_model.A
    ref = rp.sampled_figures(B, A, res.controller, 100.0, 0, n_grid=40000)
    assert ref["stable"] and ref["Ms"] == pytest.approx(1.37344, abs=1e-5)
    rec = res.certificate.models[0]
    assert rec.sampled.Ms == pytest.approx(ref["Ms"], rel=1e-7)
    assert not res.certified
    # the exact ZOH at the reported frequency gives the same |S|
    z = rp.ExactZOH(B, A, 100.0)
    th = rec.sampled.Ms_freq_rad_s / 100.0
    c = res.controller
    q = np.exp(1j * th)
    K = np.polyval(c.R, 200.0 * (q - 1) / (q + 1)) / np.polyval(c.S, 200.0 * (q - 1) / (q + 1))
    assert abs(1 / (1 + z.at([th])[0] * K)) == pytest.approx(rec.sampled.Ms, rel=1e-9)


# ---------------------------------------------------------------- bands up to Nyquist

def test_warp_band_folds_above_nyquist_and_keeps_nyquist_exact():
    fs = 100.0
    nyq = np.pi * fs
    assert warp_band(10.0, 20.0, fs) == (float(warp(10.0, fs)), float(warp(20.0, fs)))
    assert warp_band(10.0, nyq, fs) == (float(warp(10.0, fs)), np.inf)     # Nyquist included
    lo, hi = warp_band(2.5 * fs, 3.9 * fs, fs)        # folds: 3.9 fs -> (2 pi - 3.9) fs
    assert hi == np.inf and lo == pytest.approx(float(warp((2 * np.pi - 3.9) * fs, fs)))
    assert warp_band(7.0 * fs, 8.0 * fs, fs) == pytest.approx(
        (float(warp((7 - 2 * np.pi) * fs, fs)), float(warp((8 - 2 * np.pi) * fs, fs))))
    assert warp_band(5.0 * fs, 7.0 * fs, fs)[0] == 0.0                    # 2 pi fs inside
    assert warp_band(1.0, 1.0 + 2 * nyq, fs) == (0.0, np.inf)             # a whole period
    assert warp_band(nyq, nyq, fs) == (np.inf, np.inf)                    # Nyquist alone
    # the checker's folding (random_problems.fold_band) agrees
    for band in [(10.0, 20.0), (2.5 * fs, 3.9 * fs), (2.9 * fs, 3.3 * fs), (7.0 * fs, 8.0 * fs), (5.0 * fs, 7.0 * fs)]:
        a, b = rp.fold_band(band, fs)
        lo, hi = warp_band(*band, fs)
        assert lo == pytest.approx(0.0 if a == 0 else float(warp(a * fs, fs)))
        assert hi == (np.inf if b == np.pi else pytest.approx(float(warp(b * fs, fs))))


def _band_top(repro_dir):
    folder = repro_dir / "sampled_band_top_unchecked"
    pr = load_problem(folder / "base.toml")
    ctrl = RSTController(**json.loads((folder / "controller.json").read_text())["controller"])
    return folder, pr, ctrl


def test_band_containing_nyquist_is_checked_at_nyquist(repro_dir):
    """sampled_band_top_unchecked/base.toml + controller.json: |T| at Nyquist (inside the
    band [11, 12] Hz at fs = 22.665 Hz) is 0.0912067 > 0.0912 (60-digit ZOH and
    python-control agree): not certified, the band peak reported at Nyquist."""
    _, pr, ctrl = _band_top(repro_dir)
    fs = pr.specs.sample_rate_hz
    B, A = pr.family.reference_model.B, pr.family.reference_model.A
    zoh = rp.ExactZOH(B, A, fs)
    K = ctrl.R[0] / ctrl.S[0]                      # K at nu = inf (Tustin: z = -1)
    L = zoh.at([np.pi])[0] * K
    truth = abs(L / (1 + L))
    assert truth == pytest.approx(0.0912067032958594, rel=1e-12)
    ref = rp.sampled_figures(B, A, ctrl, fs, 0, band=tuple(2 * np.pi * f for f in
                                                            pr.specs.resonance_band_hz))
    assert ref["Mt_band"] == pytest.approx(truth, rel=1e-9)
    cert = certify_problem(pr, ctrl)
    rec = cert.models[0]
    assert rec.sampled.Mt_resonance_band == pytest.approx(truth, rel=1e-9)
    assert not cert.certified
    assert any(v.quantity == "|T| in resonance band" and v.loop == "sampled"
               and v.freq_rad_s == pytest.approx(np.pi * fs) for v in cert.violations)


@pytest.mark.slow
def test_band_top_sweep_is_not_certified(repro_dir, tmp_path, capsys, monkeypatch):
    """`robrst sweep sampled_band_top_unchecked/sweep.toml --workers 0`: exit 1 (was 0)."""
    folder, _, _ = _band_top(repro_dir)
    monkeypatch.chdir(folder)
    rc = main(["sweep", "sweep.toml", "--workers", "0", "--out", str(tmp_path / "sw"), "--quiet"])
    out = capsys.readouterr()
    assert rc == 1, out.err
    summary = json.loads((tmp_path / "sw" / "summary.json").read_text())
    assert summary["certified"] == 0 and summary["failed"] == 0 and summary["done"] == 1
    assert "computation failed" not in out.err
