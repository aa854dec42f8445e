"""The [spread] of a problem file: parsing, errors, and the actuators it draws.

The drawn actuators are checked against two independent constructions: the sweep engine's
variant problem of the same values (the TOML document re-parsed with the per-kelvin laws
set, the plant factors on it), and a hand-built model (the resonance and damping of D(s)'s
pole pairs scaled from its roots, the laws applied by hand) at one temperature.
"""

import json
from dataclasses import replace

import numpy as np
import pytest

from robrst.base.errors import SpecError
from robrst.base.schema import load_toml
from robrst.problem.files import load_problem, parse_problem
from robrst.problem.spread import actuator_family, draw_rows
from robrst.studies.sweep import load_sweep
from robrst.studies.sweep._model import variant_problem
from robrst.studies.sweep._prepare import prepare


def _fleet_doc(problems_dir):
    return load_toml(problems_dir / "paper_robust_fleet.toml", "problem file")


@pytest.fixture(scope="module")
def montecarlo(tmp_path_factory):
    """``paper_montecarlo`` prepared by the sweep engine (:func:`prepare`), its controller
    read from a result file instead of designed: the draws and the variant problems do not
    depend on the controller (the design of paper_robust would take 20 s)."""
    folder = tmp_path_factory.mktemp("montecarlo")
    result = folder / "result.json"
    result.write_text(json.dumps({"controller": {"R": [1.0], "S": [1.0, 0.0], "T": [1.0]}}))
    return prepare(replace(load_sweep("paper_montecarlo"), controller=str(result)))


def test_shipped_fleet_problem_states_the_montecarlo_spread(problems_dir):
    """paper_robust_fleet's spread is paper_montecarlo's, parameter by parameter."""
    p = load_problem("paper_robust_fleet")
    sweep = load_sweep("paper_montecarlo")
    assert p.spread.params == sweep.params
    assert (p.spread.yield_target, p.spread.confidence) == (0.95, 0.99)


def test_drawn_actuators_equal_the_sweep_variants_of_the_same_values(montecarlo):
    """Same values -> the same models, bit for bit, as the sweep's variant problems."""
    p = load_problem("paper_robust_fleet")
    ctx, table = montecarlo
    rows = table.values[:6]
    fams = p.spread.actuators(p.family, rows)
    for row, fam in zip(rows, fams):
        ref = variant_problem(ctx.base, ctx.doc, ctx.base.path,
                              dict(zip(table.names, map(float, row))), ctx.sweep.ageing).family
        assert [m.temperature_C for m in fam.models] == [m.temperature_C for m in ref.models]
        for a, b in zip(fam.models, ref.models):
            np.testing.assert_array_equal(a.B, b.B)
            np.testing.assert_array_equal(a.A, b.A)


def test_draws_are_the_sweep_engines_draws_for_the_same_seed(montecarlo):
    """One owner of the draws: the spread's rows are the sweep table's for the same seed."""
    p = load_problem("paper_robust_fleet")
    _, table = montecarlo
    np.testing.assert_array_equal(draw_rows(p.spread.params, 1000, 2026), table.values)
    assert not np.array_equal(p.spread.draws(50), table.values[:50])   # its own seed


def test_an_actuator_at_45C_equals_a_hand_built_model():
    """gain 1.1, resonance 0.97, damping 1.3, laws changed: D(s) rebuilt from its roots."""
    p = load_problem("paper_robust_fleet")
    fam0 = p.family
    values = {"gain": 1.1, "resonance": 0.97, "damping": 1.3,
              "family.parametric.gain_per_K": 0.002,
              "family.parametric.resonance_per_K": -0.0002,
              "family.parametric.creep_per_K": 0.005}
    fam = actuator_family(fam0, values)
    T, dT = 45.0, 45.0 - 28.0
    nom = fam0.nominal
    roots = np.roots(nom.A)
    A = np.array([1.0])
    for r in roots[roots.imag >= 0]:
        if r.imag == 0:
            A = np.convolve(A, [1.0, -r.real])
            continue
        wn, z = abs(r), -r.real / abs(r)
        wn *= 0.97 * (1 - 0.0002 * dT)
        z *= 1.3 * (1 + fam0.thermal.damping_per_K * dT)
        A = np.convolve(A, [1.0, 2 * z * wn, wn * wn])
    B = nom.B * 1.1 * (1 + 0.002 * dT)
    kappa, tau = 0.005 * dT, fam0.thermal.creep_tau_s
    B, A = np.convolve(B, [tau, 1 + kappa]), np.convolve(A, [tau, 1.0])
    m = fam.at(T)
    w = 2 * np.pi * np.geomspace(1, 1e4, 400)
    h_ref = np.polyval(B, 1j * w) / np.polyval(A, 1j * w)
    h = np.polyval(m.B, 1j * w) / np.polyval(m.A, 1j * w)
    np.testing.assert_allclose(h, h_ref, rtol=1e-9)


@pytest.mark.parametrize("change, match", [
    ({"name": "specs.Mu_max"}, "unknown parameter"),
    ({"dist": "grid"}, "expected one of"),
    ({"std": None}, "needs mean and std"),
    ({"median": 1.0}, "not used by dist"),
    ({"lo": 1.5, "hi": 1.2}, "expected lo < hi"),
])
def test_bad_spread_parameters_name_the_key(problems_dir, change, match):
    doc = _fleet_doc(problems_dir)
    doc["spread"]["param"][0].update(change)
    doc["spread"]["param"][0] = {k: v for k, v in doc["spread"]["param"][0].items()
                                 if v is not None}
    with pytest.raises(SpecError, match=match) as exc:
        parse_problem(doc, "fleet.toml")
    assert "fleet.toml" in str(exc.value) and "spread.param.0" in str(exc.value)


def test_spread_needs_the_nlp_and_a_parametric_family_for_the_laws(problems_dir):
    doc = _fleet_doc(problems_dir)
    doc["solver"]["method"] = "analytic"
    with pytest.raises(SpecError, match="needs \\[solver\\] method = 'nlp'"):
        parse_problem(doc, "fleet.toml")
    doc = load_toml(problems_dir / "paper.toml", "problem file")
    doc["solver"] = {"method": "nlp"}
    doc["spread"] = {"param": [{"name": "family.parametric.gain_per_K", "dist": "normal",
                                "mean": 0.0, "std": 1e-3}]}
    with pytest.raises(SpecError, match="not parametric"):
        parse_problem(doc, "p.toml")


def test_the_verification_sweep_file_draws_the_verified_actuators(tmp_path):
    """The sweep file written beside a fleet report is the verification's sweep: same
    parameters, seed and draws."""
    from robrst.studies.fleet import FRESH_SEED_OFFSET, fleet_sweep, verification_toml
    from robrst.studies.sweep._variants import variant_table

    p = load_problem("paper_robust_fleet")
    seed = p.spread.seed + FRESH_SEED_OFFSET
    (tmp_path / "result.json").write_text("{}")
    path = tmp_path / "verification.toml"
    path.write_text(verification_toml(p.name, p.spread, 50, seed))
    sweep = load_sweep(path)
    ref = fleet_sweep(p.path, tmp_path / "result.json", p.spread, 50, seed)
    assert sweep.params == ref.params and sweep.seed == ref.seed and sweep.n == 50
    assert sweep.overrides == ((("solver", "cert_temperatures"), 12),)
    np.testing.assert_array_equal(variant_table(sweep).values, variant_table(ref).values)
    np.testing.assert_array_equal(variant_table(sweep).values, p.spread.draws(50, seed))
