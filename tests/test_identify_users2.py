"""Identification on users' records, second batch: records that do not start at rest or
carry a constant output offset, mixed temperature columns, the strings and numbers a
written file must hold, absurd orders, flat sensors and loaders' edge cases.

Records are simulated independently of robrst (``scipy.signal.cont2discrete`` ZOH and
``lfilter``); identified models are compared with the true plant's frequency response.
"""

import contextlib
import io
import json
import tomllib
import warnings

import numpy as np
import pytest
from scipy import signal

from robrst.cli import main
from robrst.dataset import Dataset, save_dataset
from robrst.experiments.linear_model import load_linear_model
from robrst.identify.core import identify

FS = 20000.0
WN = 2 * np.pi * 600.0
B_TRUE, A_TRUE = [WN ** 2], [1.0, 2 * 0.02 * WN, WN ** 2]      # 600 Hz, zeta 0.02, 1 µm/V


def _zoh(u):
    """The true plant's sampled response from rest (scipy's exact ZOH)."""
    Bd, Ad, _ = signal.cont2discrete((B_TRUE, A_TRUE), 1 / FS, method="zoh")
    return signal.lfilter(np.ravel(Bd), Ad, u)


def _steps(n, seed, amp=10.0):
    hold = n // 20
    return np.repeat(np.random.default_rng(seed).uniform(0, amp, 21), hold)[:n]


def _record(seed, bias=0.0, offset=0.0, n=20000, noise=0.0, name=None, temp=None):
    """Steps on a drive that sat at ``bias`` V before the record (so y starts settled at
    ``bias`` µm), plus a constant sensor ``offset`` [µm]."""
    u = bias + _steps(n, seed)
    y = _zoh(np.concatenate([np.full(n, bias), u]))[n:] + offset
    y = y + noise * np.random.default_rng(seed + 9).standard_normal(n)
    return Dataset(t=np.arange(n) / FS, u=u, y=y, source=name or f"rec{seed}",
                   temp=None if temp is None else np.full(n, float(temp)))


def _frf_error(model, f_lo=1.0, f_hi=9000.0):
    w = 2 * np.pi * np.geomspace(f_lo, f_hi, 400)
    h_true = np.polyval(B_TRUE, 1j * w) / np.polyval(A_TRUE, 1j * w)
    return float(np.max(np.abs(model.freqresp(w)[:, 0, 0] - h_true) / np.abs(h_true)))


def test_constant_output_offset_is_estimated_not_fitted_as_dynamics():
    """y + 5 µm: the old fit gave DC gain 2.13 (not 1.00) and poles near 1 Hz."""
    res = identify([_record(1, offset=5.0, name="k_tr")],
                   validate=[_record(2, offset=5.0, name="k_va")], max_order=6)
    assert res.order == 2
    assert _frf_error(res.model) < 1e-9
    (start,) = res.starts
    assert start.name == "k_tr" and abs(start.offset_um[0] - 5.0) < 1e-9
    assert start.initial_um[0] < 1e-8                     # it did start at rest
    assert any("k_tr" in n and "offset of 5 µm" in n for n in res.notes), res.notes


def test_record_that_does_not_start_at_rest_is_identified():
    """The drive sat at 50 V before the record; y starts settled at 50 µm.  The old fit
    returned order 4 with |G| 0.105x the truth at 600 Hz."""
    res = identify([_record(1, bias=50.0, name="l_tr")],
                   validate=[_record(2, bias=50.0, name="l_va")], max_order=6)
    assert res.order == 2
    assert _frf_error(res.model) < 1e-9
    (start,) = res.starts
    assert abs(start.offset_um[0]) < 1e-9                  # no offset: the state explains y
    # free response of the settled state: 50 µm at k = 0 (y[0] = 50, from rest 0)
    assert abs(start.initial_um[0] - 50.0) < 1e-7
    assert any("l_tr" in n and "does not start at rest" in n for n in res.notes), res.notes


def test_noisy_offset_and_bias_together_within_the_noise():
    """Both at once, 0.01 µm noise: the response within 2e-3 relative, offset within 1e-3 µm."""
    recs = [_record(s, bias=30.0, offset=-2.0, noise=0.01) for s in (1, 2, 3)]
    res = identify(recs, max_order=4)
    assert res.order == 2 and _frf_error(res.model, 1.0, 3000.0) < 2e-3
    assert all(abs(s.offset_um[0] + 2.0) < 1e-3 for s in res.starts)


def test_records_starting_at_rest_keep_the_from_rest_fit(tmp_path):
    """A record that does start at rest (0.01 µm noise): the terms are not significant,
    so the final fit is the from-rest one (as before), no note; the JSON lists the
    estimates."""
    f = tmp_path / "r.npz"
    save_dataset(_record(1, noise=0.01), f)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = main(["identify", "--train", str(f), "--out", str(tmp_path / "m.toml"),
                   "--max-order", "3", "--json", "-"])
    d = json.loads(out.getvalue())
    assert rc == 0 and d["notes"] == [] and d["order"] == 2
    (r,) = d["records"]
    assert r["record"] == str(f) and r["from_rest"] is True
    assert abs(r["offset_um"][0]) < 1e-3 and r["initial_um"][0] < 1e-2     # within the noise
    (m,), _ = load_linear_model(tmp_path / "m.toml")
    assert _frf_error(m, 1.0, 3000.0) < 2e-3
