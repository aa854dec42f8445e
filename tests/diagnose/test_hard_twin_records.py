"""Gap diagnosis on twin records a probe found hard: a sensor offset (alone and under
hysteresis), the residual's decomposition when an effect gives it a nonzero mean, an
effect hidden behind another (creep behind saturation), and test records that do not
excite what the training records show.

Records: the paper's D(s) in the twin (sensor noise 10 nm and quantisation always on),
4 s at 5 kHz, two training records (steps, chirp) and two test records (triangle, sine);
explicit seeds.  Each test states the answer; the offset, shares and gaps are checked
against values computed here from the truth (the 2 µm added, the noise std).
"""

from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import chirp

from robrst.diagnose import diagnose
from robrst.twin.config import default_twin
from robrst.twin.simulate import simulate

FS, N, SIGMA, OFFSET_UM = 5000.0, 20000, 0.01, 2.0


def _u(kind, rng, hi):
    t = np.arange(N) / FS
    lo = 5.0
    if kind == "steps":
        k = int(0.25 * FS)
        u = np.repeat(rng.uniform(lo, hi, N // k + 1), k)[:N]
        u[:int(0.05 * FS)] = lo
        return u
    if kind == "chirp":
        return (lo + hi) / 2 - (hi - lo) / 2 * chirp(t, 0.5, t[-1], 300.0, method="linear",
                                                     phi=90.0)
    if kind == "tri":
        return lo + (hi - lo) * (1 - np.abs(2 * ((1.3 * t) % 1) - 1))
    return (lo + hi) / 2 - (hi - lo) / 2 * np.cos(2 * np.pi * 2.7 * t)


def _records(effects, seed, offset=0.0, ramps=False, hi=120.0):
    """(train, test) from the twin with ``effects`` on, ``offset`` µm added to y."""
    rng = np.random.default_rng(seed)
    over = {"noise": {"sigma_um": SIGMA}}
    cfg = replace(default_twin().with_effects(only=["noise", "quantization", *effects], **over),
                  sample_rate_hz=FS)
    t = np.arange(N) / FS
    recs = []
    for i, kind in enumerate(("steps", "chirp", "tri", "sine")):
        u = _u(kind, rng, hi)
        if ramps:
            a, b = (28.0, 44.0) if i % 2 == 0 else (43.0, 30.0)
            temp = a + (b - a) * np.clip((t - 0.3) / 2.5, 0, 1)
        else:
            temp = np.full(N, 28.0 + 3 * i)
        d = simulate(cfg, temp, u=u, seed=int(rng.integers(2 ** 31))).to_dataset()
        recs.append(replace(d, y=d.y + offset, source=f"{'+'.join(effects) or 'none'}-{i}"))
    return recs[:2], recs[2:]


def _offset(dg):
    return next(f for f in dg.findings if f.kind == "output_offset").details


def test_a_pure_sensor_offset_is_named_not_hysteresis():
    """y + 2 µm on the exact model: was `hysteresis` (0.0806 -> 0.0233, it imitates a
    constant in part) with no output_offset finding."""
    dg = diagnose(*_records((), 0, offset=OFFSET_UM))
    assert dg.cause == "output_offset", dg.reason
    assert dg.causes == ("output_offset",)
    assert _offset(dg)["offset_um"] == pytest.approx(OFFSET_UM, abs=0.002)   # 20 x its 1-sigma
    g = dg.as_dict()["gap"]
    assert g["after"] <= 1.25 * g["noise_floor"]
    # the residual is 2 µm + noise: a constant removes 4 / (4 + sigma^2) of its mean square
    sh = dg.decomposition
    assert sum(sh.values()) == pytest.approx(1.0, abs=1e-12)
    assert sh["offset"] == pytest.approx(4 / (4 + SIGMA ** 2), abs=2e-5)
    assert sh["linear_model_error"] + sh["unexplained_by_linear"] < 2e-5


@pytest.mark.slow
def test_a_hysteresis_under_an_offset_names_both():
    """Hysteresis + 2 µm: was `hysteresis` alone (81x the floor left), the offset unnamed."""
    dg = diagnose(*_records(("hysteresis",), 0, offset=OFFSET_UM))
    assert dg.cause == "hysteresis", dg.reason
    assert dg.causes == ("hysteresis", "output_offset")
    assert _offset(dg)["offset_um"] == pytest.approx(OFFSET_UM, abs=0.01)
    g = dg.as_dict()["gap"]
    assert g["after"] <= 1.25 * g["noise_floor"]


def test_b_decomposition_is_a_partition_when_an_effect_moves_the_mean():
    """Hysteresis alone (no offset): the shares were {offset 0.917, linear 0.083,
    unexplained 0} although the linear re-fit leaves 40 % of the mean square; now the
    re-fit comes first and what it leaves is split into a constant, the noise and the
    rest."""
    dg = diagnose(*_records(("hysteresis",), 0))
    assert dg.cause == "hysteresis" and "output_offset" not in dg.causes, dg.reason
    sh = dg.decomposition
    assert sum(sh.values()) == pytest.approx(1.0, abs=1e-12)
    assert min(sh.values()) >= 0.0
    left = (dg.linear_refit.gap_after / dg.gap_before) ** 2        # what the re-fit leaves
    assert left > 0.3
    assert sh["linear_model_error"] == pytest.approx(1 - left, abs=1e-12)
    assert sh["offset"] + sh["noise"] + sh["unexplained_by_linear"] == pytest.approx(left,
                                                                                   abs=1e-12)
    # a constant does not explain the hysteresis: a good part is left unexplained
    assert sh["unexplained_by_linear"] > 0.1
    assert sh["noise"] == pytest.approx((dg.noise_floor / dg.gap_before) ** 2, rel=1e-12)


@pytest.mark.slow
def test_c_creep_hidden_behind_saturation_is_named():
    """Creep + saturation (drive to 170 V, temperature ramps): creep alone did not improve
    on the model (0.1039 -> 0.1038) and was never tried; only saturation was named with
    77x the floor left.  Re-screened on top of saturation, creep shows."""
    dg = diagnose(*_records(("creep", "saturation"), 0, ramps=True, hi=170.0))
    assert set(dg.causes) == {"creep", "saturation"}, dg.reason
    g = dg.as_dict()["gap"]
    assert g["after"] <= 1.25 * g["noise_floor"]
    sat = next(s for s in dg.selected if s.name == "saturation").params
    assert sat["u_max_V"] == pytest.approx(default_twin().effects["saturation"]["u_max"],
                                           abs=0.5)


def test_d_a_gap_only_the_training_records_show_is_said():
    """Slew on: the training steps and chirp excite it (gap 300x the floor), the test
    triangle and sine do not: `none`, and the reason says so (it said nothing)."""
    train, test = _records(("slew",), 0)
    dg = diagnose(train, test)
    assert dg.cause == "none"
    assert "training records show a gap" in dg.reason
