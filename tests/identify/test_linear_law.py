"""The thermal law's test accepts exactly linear laws (fourth round: records of a resonance
moving by exactly -2e-4 /K were fitted -1.9965e-4 +- 2.2e-7, then the law was rejected and
three explicit models written, ``tests/repro/turn4/identify_linear_law_gen_records.py``).

The per-model standard errors were too small: the fit stopped short of the output-error
optimum and the covariance assumed white noise.  Now the fit is polished onto the optimum
and the covariance is a long-run (Newey-West) sandwich; the law is rejected when a model
misses it by more than chi-square's mean plus 5 standard deviations.  Its false-rejection
rate on exactly linear laws, measured on the 200 seeded stages of ``linear_law_stages``
(a quarter with coloured noise): 3 of 200 (1.5 %), the standardised errors of the fitted
resonances, dampings and gains with standard deviations 1.00 .. 1.07 (``-m large`` runs it;
the default suite runs 10 of them).  The starting design of the identified problem bounds
``|U|`` from the identified gain (``Mu_max = 10 / k``: 200 V/µm for this 0.05 µm/V stage).
"""

import subprocess
import sys
import tomllib

import pytest

from linear_law_stages import REF_C, law, records
from robrst.cli import main
from robrst.identify.identification import identify


def _check_law(th, seed):
    """The law fitted holds, each coefficient within 4 sigma of the truth (the truth's
    relative change per kelvin around the law's reference temperature)."""
    wn0, zeta0, gain0, r, z, g, temps, noise, colour = law(seed)
    assert th.consistent, (seed, th.note)
    d = th.reference_C - REF_C
    truth = {"resonance_per_K": r / (1 + r * d), "damping_per_K": z / (1 + z * d),
             "gain_per_K": g / (1 + g * d)}
    for k, v in truth.items():
        assert abs(getattr(th, k) - v) <= 4 * th.std[k], (seed, k, getattr(th, k), v, th.std[k])


@pytest.mark.parametrize("seed", [s if s in (1, 2) else pytest.param(s, marks=pytest.mark.slow)
                                  for s in range(10)])          # 2-4 s each
def test_exactly_linear_laws_are_accepted(seed):
    train, validate = records(seed)
    _check_law(identify(train, validate, order=2).thermal, seed)


@pytest.mark.large
def test_false_rejection_rate_on_200_linear_stages():
    rejected = []
    for seed in range(200):
        train, validate = records(seed)
        if not identify(train, validate, order=2).thermal.consistent:
            rejected.append(seed)
    assert len(rejected) <= 10, rejected          # at most 5 %; measured: 3 (1.5 %)


@pytest.mark.slow
def test_the_reproducer_writes_the_linear_law_and_a_Mu_bound(repro_dir, tmp_path, capsys):
    gen = repro_dir / "turn4" / "identify_linear_law_gen_records.py"
    subprocess.run([sys.executable, str(gen)], cwd=tmp_path, check=True, capture_output=True)
    args = ["identify", "--train"] + [str(tmp_path / "ident" / f"T{T}_a.csv")
                                      for T in ("15", "32.5", "50")]
    args += ["--validate"] + [str(tmp_path / "ident" / f"T{T}_b.csv") for T in ("15", "32.5", "50")]
    out = tmp_path / "stage.toml"
    assert main(args + ["--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    doc = tomllib.loads(out.read_text())
    par = doc["family"]["parametric"]
    # the truth around the law's reference (15 °C): -2e-4 / (1 - 10 x 2e-4 ... ) per kelvin
    assert doc["family"]["reference_C"] == 15.0
    assert par["resonance_per_K"] == pytest.approx(-2e-4 / (1 + 2e-4 * 10), rel=2e-3)
    specs = doc["specs"]
    assert specs["Mu_max"] == pytest.approx(200.0, rel=1e-2)        # 10 / 0.05 µm/V
    assert "identified static gain" in specs["Mu_reason"] and "20 V" in specs["Mu_reason"]
