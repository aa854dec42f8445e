"""A valid noise-free sine record of 3,000 samples ended in "computation failed".

Reproducer (copied with its header; the generator below is the reproducer's own)::

    # MASKED CRASH (turn 3): `robrst diagnose --train sine3000.csv --test sine3000.csv` ends in
    # "robrst: error: computation failed (ValueError: array must not contain infs or NaNs) ...
    # please report it" (exit 2).  The record is valid: 3000 samples at 20 kHz, u = 10 + 5
    # sin(k/7) V, y = 6.68 sin(k/7) um, noise-free.  With 2000 samples it is diagnosed (exit 0);
    # 4000, 10000, 20000 and 2.6 M samples fail the same way.  ROBRST_DEBUG=1:
    # robrst/diagnose/fit.py:247 fit_model -> scipy least_squares gets NaN (via
    # diagnose/select.py _fit).

Root cause: the Bouc–Wen candidate's upper bound on B (30 / peak-to-peak = 3 /V for this
10 V record) let the discrete update ``h+ = h (1 - (B + Gamma) |du|) + A du`` leave its
stable range for the record's steps (the memory starts at 0 V, so the first step is 10 V;
the sine moves 0.7 V a sample): the loop and its sensitivities overflowed (1e175) and the
Jacobian became NaN.  B is now bounded so the update is a contraction for the largest
step of the data.
"""

import json

import numpy as np
import pytest

from robrst.cli import main
from robrst.diagnose._effects import Chain, summary
from robrst.data.dataset import Dataset


def _write_reproducer(path, n=3000):
    k = np.arange(n)
    with open(path, "w") as fh:
        fh.write("t,u,y\n")
        fh.write("".join(f"{x:.12g},{v:.9g},{w:.9g}\n"
                         for x, v, w in zip(k / 20000, 10 + 5 * np.sin(k / 7),
                                            6.68 * np.sin(k / 7))))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("n", [3000, 4000])
def test_noise_free_sine_is_diagnosed_not_a_crash(tmp_path, capsys, n):
    rec = _write_reproducer(tmp_path / "sine.csv", n)
    out = tmp_path / "d.json"
    code = main(["diagnose", "--train", str(rec), "--test", str(rec), "--json", str(out),
                 "--quiet"])
    assert code == 0, capsys.readouterr().err
    d = json.loads(out.read_text())
    assert d["gap"]["before"] > 1.0          # the paper's D(s) is not this record's system
    assert all(e["gap_after"] is not None and np.isfinite(e["gap_after"]) for e in d["effects"])


def test_bouc_wen_bound_keeps_the_discrete_update_a_contraction():
    """At the bounds, (B + |Gamma|) |du| <= 1.9 for every step of the record (and the first
    step from the memory's 0 V): the effective input and its Jacobian stay finite."""
    k = np.arange(3000)
    d = Dataset(t=k / 20000, u=10 + 5 * np.sin(k / 7), y=6.68 * np.sin(k / 7))
    s = summary([d])
    assert s["du_max"] == pytest.approx(10.0, rel=1e-6)
    ch = Chain(("hysteresis",), 1, d.fs, 28.0, s)
    b_max = 10 ** ch.upper[1]
    assert 2 * b_max * s["du_max"] <= 1.9 + 1e-12
    for z in (ch.upper, ch.lower, np.r_[ch.upper[:2], -1.0, ch.upper[3:]]):
        V, dV = ch.run(z, d.U, np.full(d.n, 28.0))
        assert np.all(np.isfinite(V)) and np.all(np.isfinite(dV[0]))
        assert np.max(np.abs(dV[0])) < 1e6
