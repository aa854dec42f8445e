"""Where a record's hysteresis memory rested before it (``memory_rest_fraction``).

The twin's hysteresis rests at 0 V; a record taken where the actuator had settled at its
first input starts with the memory there.  The diagnosis fits the fraction of the first
input the memory rested at (0: at 0 V, 1: at the first input).  The stages are checked
against the discrete updates written out here, the chain's column against a central
difference of its output, and the fit on records of both kinds."""

import numpy as np
import pytest

from robrst.data.dataset import Dataset
from robrst.diagnose._effects import Chain, summary
from robrst.diagnose._stages import stage

FS = 5000.0


def _input(n=2000, seed=3, lo=20.0, hi=120.0):
    rng = np.random.default_rng(seed)
    steps = rng.uniform(lo, hi, n // 200)
    return np.repeat(steps, 200)[:n] + np.linspace(0.0, 5.0, n)


def _bouc_wen(u, m, A, B, G, gain):
    """The twin's Bouc-Wen update from rest at ``m`` (loop variable 0 there)."""
    h, prev, out = 0.0, m, np.empty_like(u)
    for i, v in enumerate(u):
        du = v - prev
        h = h + A * du - B * abs(du) * h - G * du * abs(h)
        out[i], prev = gain * (v - h), v
    return out


def _plays(u, m, thresholds, weights):
    """``u + sum_i w_i (play_ri(u) - u)``, every play at rest at ``m``."""
    p = np.full(len(thresholds), m, float)
    out = np.empty_like(u)
    for i, v in enumerate(u):
        p = np.minimum(np.maximum(p, v - np.asarray(thresholds)), v + np.asarray(thresholds))
        out[i] = v + np.dot(weights, p - v)
    return out


@pytest.mark.parametrize("where", ["zero", "first", "between"])
def test_bouc_wen_stage_starts_where_its_memory_rested(where):
    u = _input()
    m = {"zero": 0.0, "first": u[0], "between": 0.4 * u[0]}[where]
    values = (0.35, 0.004, 0.003, 1.3)
    out, _ = stage("hysteresis", FS).run(u, np.full(u.size, 30.0), values, memory_V=m)
    assert np.max(np.abs(out - _bouc_wen(u, m, *values))) < 1e-9 * np.max(np.abs(u))


@pytest.mark.parametrize("m", [0.0, 37.0])
def test_plays_start_where_their_memory_rested(m):
    u = _input(seed=4)
    thr, w = (4.0, 11.0), np.array([0.3, -0.1])
    out, _ = stage("pi_hysteresis", FS, thresholds_V=thr).run(u, np.full(u.size, 30.0), w,
                                                             memory_V=m)
    assert np.max(np.abs(out - _plays(u, m, thr, w))) < 1e-9 * np.max(np.abs(u))


def _record(u, periodic=False):
    t = np.arange(u.size) / FS
    if periodic:
        return Dataset(t=np.arange(2 * u.size) / FS, u=np.tile(u, 2), y=np.tile(u, 2),
                       period=u.size)
    return Dataset(t=t, u=u, y=u)


@pytest.mark.parametrize("effect", ["hysteresis", "pi_hysteresis"])
def test_memory_column_is_the_derivative_of_the_output(effect):
    u = _input(seed=5)
    d = _record(u - u[0] + 10.0)    # plays wider than 10 V keep where they rested
    ch = Chain((effect,), 1, FS, 28.0, summary([d]))
    z = ch.z0.copy()
    if effect == "pi_hysteresis":
        z[:-1] = np.linspace(0.4, -0.2, z.size - 1)
    z[-1] = 0.3
    T = np.full(d.n, 30.0)
    _, dV = ch.run(z, d.U, T)
    h = 1e-5
    up, down = z.copy(), z.copy()
    up[-1] += h
    down[-1] -= h
    central = (ch.run(up, d.U, T, jac=False)[0] - ch.run(down, d.U, T, jac=False)[0])[:, 0] / (2 * h)
    assert np.max(np.abs(central)) > 1e-3                  # the memory shows in this record
    # the plays are piecewise linear in it: a sample where one leaves its rest between the
    # two differences' steps differs (a few samples), hence a norm over the record
    assert np.linalg.norm(dV[0][:, -1] - central) < 1e-2 * np.linalg.norm(central)


@pytest.mark.parametrize("kind", ["periodic", "from_0V"])
def test_records_that_do_not_show_the_memory_hold_it(kind):
    u = _input(seed=6)
    d = _record(u, periodic=True) if kind == "periodic" else _record(u - u[0])
    for effect in ("hysteresis", "pi_hysteresis"):
        ch = Chain((effect,), 1, FS, 28.0, summary([d]))
        assert ch.upper[-1] - ch.lower[-1] < 1e-9 and ch.z0[-1] == 0.0


@pytest.mark.slow
def test_a_play_started_at_the_first_input_is_hysteresis_alone(withheld):
    """The backlash case on seed 7003 (the play's memory at the records' first input, about
    10 V): before, hysteresis + an input dead zone at 9.4 V that stood in for where the
    memory started (10.5x the floor left); with the memory fitted, hysteresis alone."""
    d, _, _ = withheld("hard", "backlash", 7003)
    assert d.causes == ("hysteresis",), d.reason
    assert d.final.gap_after < 4.0 * d.noise_floor, d.reason
    fitted = next(e for e in d.effects if e.name == "hysteresis").params
    assert fitted["memory_rest_fraction"] > 0.9


@pytest.mark.slow
def test_the_twins_hysteresis_rests_at_zero(withheld):
    """Records of the twin (its memory at 0 V, the records starting at 2-15 V): the fit
    finds the memory there."""
    d, _, _ = withheld("hard", "hysteresis_2kHz", 7001)
    assert d.causes == ("hysteresis",), d.reason
    fitted = next(e for e in d.effects if e.name == "hysteresis").params
    assert fitted["memory_rest_fraction"] < 0.05
