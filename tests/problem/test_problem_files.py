"""Problem-file validation: each kind of bad input names the file and key."""

import dataclasses

import numpy as np
import pytest

from robrst.base.errors import CoprimeError, DegreeError, SpecError
from robrst.design import run_problem
from robrst.problem.files import load_problem

GOOD = """
[plant]
name = "paper"
[poles]
wn = 600.0
zeta = 1.0
[controller]
extra_degree = 1
"""


def write(tmp_path, text, name="p.toml"):
    f = tmp_path / name
    f.write_text(text)
    return f


def test_shipped_problems_load(problems_dir):
    from robrst.twin import load_twin

    for f in sorted(problems_dir.glob("*.toml")):
        if f.name.startswith("twin_"):  # twin files have their own schema
            assert load_twin(f).enabled("hysteresis")
            continue
        pr = load_problem(f)
        assert pr.family.models


def test_robust_family_has_seven_temperatures_and_nominal_is_paper_model(problems_dir):
    pr = load_problem(problems_dir / "paper_robust.toml")
    t = pr.family.temperatures
    assert len(t) >= 7 and t[0] == 28.0 and t[-1] == 45.0
    ref = pr.family.reference_model
    np.testing.assert_allclose(ref.A, [1.0, 693.0, 1.5027342e7, 9.765e9], rtol=1e-15)
    # fast dynamics barely change, creep (low frequency) grows with temperature
    hot = pr.family.models[-1]
    wr_ref = np.max(np.abs(ref.poles().imag))
    wr_hot = np.max(np.abs(hot.poles().imag))
    assert abs(wr_hot / wr_ref - 1) < 0.01
    slow = lambda m: m.freqresp(np.array([0.01]))[0]  # noqa: E731
    assert abs(slow(hot)) / abs(slow(ref)) > 1.05
    # interpolation at any temperature in range
    mid = pr.family.at(36.5)
    assert mid.temperature_C == 36.5 and abs(mid.dc_gain - ref.dc_gain) > 0


@pytest.mark.parametrize("text,match", [
    (GOOD.replace("[poles]", "[poles]\nwm = 3.0"), r"p.toml: \[poles.wm\] unknown key; did you mean 'wn'"),
    (GOOD + "\n[specs]\nMs_mx = 2.0\n", r"\[specs.Ms_mx\] unknown key; did you mean 'Ms_max'"),
    (GOOD + "\n[bogus]\nx = 1\n", r"\[bogus\] unknown key"),
    (GOOD.replace('wn = 600.0', 'wn = "fast"'), r"\[poles.wn\] expected a finite number"),
    (GOOD.replace('zeta = 1.0\n', ''), r"\[poles\] give 'wn' and 'zeta'"),
    (GOOD.replace('[plant]\nname = "paper"', '[plant]'), r"\[plant\] give exactly one of"),
    (GOOD.replace('name = "paper"', 'name = "papr"'), r"unknown plant name 'papr'"),
    (GOOD.replace('name = "paper"', 'B = [1.0, 2.0, 3.0]\nA = [1.0, 2.0]'), r"\[plant\].*improper"),
    (GOOD.replace('wn = 600.0', 'wn = -600.0'), r"\[poles.wn\] expected number >= 1e-06 and <= 1e\+09, got -600.0"),
    (GOOD.replace('extra_degree = 1', 'extra_degree = 1.5'), r"\[controller.extra_degree\] expected an integer"),
    (GOOD.replace('extra_degree = 1', 'S_fixed = [1.0, 1.0]'), r"\[controller.S_fixed\] must contain the integrator"),
    (GOOD + "\n[solver]\nmethod = \"magic\"\n", r"\[solver.method\] expected one of analytic, nlp, convex"),
    (GOOD + "\n[specs]\nMs_max = 0.5\n", r"\[specs.Ms_max\] expected number >= 1, got 0.5"),
    (GOOD + "\n[family]\nreference_C = 28.0\n", r"\[family.temperatures_C\] missing required key"),
    ("[plant\n", r"p.toml: invalid TOML"),
    (GOOD + '\n[solver]\nmethod = "nlp"\ninit = "convex"\nfree_poles = true\nwn_bounds = [1.0, 2.0]'
     '\nzeta_bounds = [0.5, 1.0]\n', r"\[solver.init\] 'convex' needs a fixed Am"),
])
def test_bad_problem_files(tmp_path, text, match):
    with pytest.raises(SpecError, match=match):
        load_problem(write(tmp_path, text))


def test_missing_file_is_a_spec_error(tmp_path):
    with pytest.raises(SpecError, match="nope.toml: problem file not found"):
        load_problem(tmp_path / "nope.toml")


def test_unstable_aux_and_slow_aux_rejected(tmp_path):
    """Refused when the file is read (before any work), naming the file and the key."""
    bad = GOOD.replace("zeta = 1.0", "zeta = 1.0\naux_factor = 4.0")
    with pytest.raises(SpecError, match=r"p.toml: \[poles.aux_factor\] expected number >= 10"):
        load_problem(write(tmp_path, bad))
    bad = GOOD.replace("zeta = 1.0", "zeta = 1.0\naux_roots = [1e4, -1e4, -1e4, -1e4, -1e4]")
    with pytest.raises(SpecError, match=r"p.toml: \[poles.aux_roots\] auxiliary roots must be"):
        load_problem(write(tmp_path, bad))
    bad = GOOD.replace("zeta = 1.0", "zeta = 1.0\naux_roots = [-1e3, -1e4, -1e4, -1e4, -1e4]")
    with pytest.raises(SpecError, match=r"p.toml: \[poles.aux_roots\] auxiliary poles must be >= 10x"):
        load_problem(write(tmp_path, bad))
    pr = load_problem(write(tmp_path, GOOD))     # a problem built in Python: the design refuses
    with pytest.raises(SpecError, match=r"p.toml \(changed in Python\): \[poles.aux_factor\]"
                                         r" expected number >= 10"):
        run_problem(dataclasses.replace(pr, poles=dataclasses.replace(pr.poles, aux_factor=4.0)))


def test_improper_degree_request(tmp_path):
    bad = GOOD.replace("extra_degree = 1", 'T_mode = "cancel_aux"')
    with pytest.raises(DegreeError, match="improper"):
        run_problem(load_problem(write(tmp_path, bad)))


def test_non_coprime_plant_file(tmp_path):
    bad = GOOD.replace('name = "paper"', "B = [1.0, 5.0]\nA = [1.0, 8.0, 15.0]")  # (s+5)/((s+3)(s+5))
    with pytest.raises(CoprimeError, match="share the root s = -5"):
        run_problem(load_problem(write(tmp_path, bad)))


def test_explicit_family(tmp_path):
    text = GOOD + """
[family]
reference_C = 30.0
[[family.models]]
temperature_C = 30.0
B = [1.0]
A = [1.0, 2.0, 1.0]
[[family.models]]
temperature_C = 40.0
B = [1.2]
A = [1.0, 2.2, 1.1]
"""
    text = text.replace('name = "paper"', "B = [1.0]\nA = [1.0, 2.0, 1.0]\ntemperature_C = 30.0")
    pr = load_problem(write(tmp_path, text))
    mid = pr.family.at(35.0)
    np.testing.assert_allclose(mid.A, [1.0, 2.1, 1.05], rtol=1e-15)
    np.testing.assert_allclose(mid.B, [1.1], rtol=1e-15)
    with pytest.raises(SpecError, match="outside the range"):
        pr.family.at(50.0)


def test_explicit_family_needs_no_plant_table(tmp_path):
    """[[family.models]] alone is a problem: its reference is the model at reference_C
    (default the first), and the design equals the one of the same file with that [plant]."""
    models = ("[[family.models]]\ntemperature_C = 40.0\nB = [1.2e6]\nA = [1.0, 2.2e3, 1.1e6]\n"
              "[[family.models]]\ntemperature_C = 30.0\nB = [1.0e6]\nA = [1.0, 2.0e3, 1.0e6]\n")
    rest = "[poles]\nwn = 800.0\nzeta = 0.9\n[controller]\nextra_degree = 1\n"
    alone = load_problem(write(tmp_path, models + rest))
    assert alone.family.reference_model.temperature_C == 30.0
    assert list(alone.family.temperatures) == [30.0, 40.0]
    hot = load_problem(write(tmp_path, "[family]\nreference_C = 40.0\n" + models + rest))
    np.testing.assert_array_equal(hot.family.reference_model.A, [1.0, 2.2e3, 1.1e6])
    both = load_problem(write(tmp_path, "[plant]\nB = [1.0e6]\nA = [1.0, 2.0e3, 1.0e6]\n"
                              "temperature_C = 30.0\n" + models + rest))
    a, b = run_problem(alone), run_problem(both)
    for k in "RST":
        np.testing.assert_array_equal(getattr(a.controller, k), getattr(b.controller, k))
    assert a.certified == b.certified


def test_problems_folder_spelling_names_the_builtin(tmp_path, monkeypatch):
    """`problems/paper_robust.toml` (as the issues and README spell the shipped files) works
    from any folder when no such file exists; a user's own file of that path wins."""
    from robrst.problem.files import resolve_problem_path
    from robrst.studies.sweep.files import resolve_sweep_path

    monkeypatch.chdir(tmp_path)
    assert resolve_problem_path("problems/paper_robust.toml").name == "paper_robust.toml"
    assert resolve_problem_path("problems/paper_robust.toml").parent.name == "problems"
    assert resolve_sweep_path("problems/sweeps/paper_montecarlo.toml").is_file()
    own = tmp_path / "problems" / "paper_robust.toml"
    own.parent.mkdir()
    own.write_text("[plant]\nname = 'paper'\n")
    assert resolve_problem_path("problems/paper_robust.toml") == own.relative_to(tmp_path)
    with pytest.raises(SpecError, match="elsewhere/paper.toml: problem file not found"):
        resolve_problem_path("elsewhere/paper.toml")


def test_a_folder_named_like_a_builtin_does_not_hide_it(tmp_path, monkeypatch):
    """`robrst design paper` from a folder holding a sub-folder `paper/` (it failed: "is a
    folder"); a folder with no built-in of its name is still refused, naming it."""
    (tmp_path / "paper").mkdir()
    (tmp_path / "mine").mkdir()
    monkeypatch.chdir(tmp_path)
    assert load_problem("paper").name == "paper"
    with pytest.raises(SpecError, match="mine: is a folder"):
        load_problem("mine")


@pytest.mark.parametrize("free,bounds", [("false", "[1e-9, 3000.0]"), ("true", "[1e-7, 5000.0]"),
                                         ("true", "[100.0, 1e9]")])
def test_wide_wn_bounds_are_accepted(tmp_path, free, bounds):
    """Bounds wider than the poles any design places (or unused, free_poles = false) were
    refused at load by this round's pole limits; the files designed and certified before."""
    text = GOOD + (f'\n[solver]\nmethod = "nlp"\nfree_poles = {free}\nwn_bounds = {bounds}\n'
                   "zeta_bounds = [0.5, 1.0]\n")
    pr = load_problem(write(tmp_path, text))
    assert pr.solver.wn_bounds == tuple(eval(bounds))


LAW = """
[plant]
B = [0.1]
A = [1.0, 100.0, 4.0e6]
{temperature}
[family]
reference_C = 20.0
temperatures_C = [20.0, 30.0]
[family.parametric]
resonance_per_K = -0.001
[poles]
wn = 300.0
zeta = 1.0
[controller]
extra_degree = 1
"""


def test_a_parametric_family_moves_the_plant_from_reference_c(tmp_path):
    """[plant] without its own temperature is the model at reference_C (not at the default
    28 °C): the family's model there is the plant, 10 K above it the resonance moved by
    the law (2000 rad/s x (1 - 0.01), from the roots)."""
    pr = load_problem(write(tmp_path, LAW.format(temperature="")))
    assert pr.family.nominal.temperature_C == 20.0
    at20, at30 = pr.family.at(20.0), pr.family.at(30.0)
    np.testing.assert_allclose(at20.A / at20.A[0], [1.0, 100.0, 4.0e6], rtol=1e-12)
    w30 = np.abs(np.roots(at30.A)).max()
    assert w30 == pytest.approx(2000.0 * 0.99, rel=1e-9)


def test_reference_c_contradicting_the_plant_temperature_is_refused(tmp_path, capsys):
    """A [plant] at 28 °C with reference_C = 20 °C: the law would move the plant's model by
    the wrong 10 K, silently (a design of such a file ran 45 s and missed every step spec
    by 60,000 %); refused when the file is read, naming the key."""
    from robrst.cli import main

    f = write(tmp_path, LAW.format(temperature="temperature_C = 28.0"))
    with pytest.raises(SpecError, match=r"\[family.reference_C\] 20 °C differs from \[plant\]"
                                        r" temperature_C = 28 °C"):
        load_problem(f)
    assert main(["design", str(f), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "p.toml" in err[0] and "Traceback" not in err[0]
    # the same temperature in both keys, or reference_C omitted, is fine
    ok = LAW.format(temperature="temperature_C = 20.0")
    assert load_problem(write(tmp_path, ok, "q.toml")).family.nominal.temperature_C == 20.0
    same = ok.replace("reference_C = 20.0\n", "")
    assert load_problem(write(tmp_path, same, "r.toml")).family.thermal.reference_C == 20.0
