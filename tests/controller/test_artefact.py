"""A design is an artefact: ``robrst design PROBLEM --json > DESIGN.json`` is read back by
``robrst.load_design`` and every command that takes a problem file (export, check, report,
design, certify) without designing again; the problem document round-trips
(``parse_problem(problem_document(p))`` is ``p``); ``robrst certify`` re-certifies the saved
controller on another problem.  "Without designing" is checked by making every synthesis
entry point raise."""

import json

import numpy as np
import pytest

import robrst
from robrst import ControllerStructure, PlantFamily, PoleSpec, Problem, Specs, SolverOptions
from robrst.cli import main
from robrst.controller.artefact import load_design, merge_problem, read_design
from robrst.core.family import explicit_family, parametric_family
from robrst.core.plant import Plant, paper_plant
from robrst.core.thermal import ThermalCoefficients
from robrst.problem.documents import problem_document
from robrst.problem.files import parse_problem


def _no_design(monkeypatch):
    """Every way to design raises: a command that designs fails the test."""
    import robrst.design as design
    import robrst.design._pipeline  # noqa: F401  (the module patched below)
    import robrst.synthesis.robust as robust

    def boom(*a, **k):
        raise AssertionError("designed again")

    monkeypatch.setattr(design, "run_problem", boom)
    monkeypatch.setattr(design._pipeline, "design_single", boom)
    monkeypatch.setattr(design._pipeline, "fleet_design", boom)
    monkeypatch.setattr(robust, "robust_synthesis", boom)


@pytest.fixture(scope="module")
def saved(tmp_path_factory, designs):
    """paper_robust designed once, saved as its JSON."""
    path = tmp_path_factory.mktemp("art") / "DESIGN.json"
    path.write_text(json.dumps(designs("paper_robust").as_dict()))
    return path


def _python_problems():
    p = paper_plant()
    a = Plant(p.B, p.A, temperature_C=20.0)
    b = Plant(p.B * 1.1, p.A * [1, 1.01, 1, 1], temperature_C=40.0)
    base = dict(poles=PoleSpec(wn=600.0, zeta=1.0, dominant_real=(-900.0,)),
                controller=ControllerStructure(extra_degree=1, relative_degree=1),
                specs=Specs(Ms_max=2.0, sample_rate_hz=20000.0, delay_samples=1),
                solver=SolverOptions(cert_temperatures=5))
    yield Problem("single", PlantFamily(models=(a,)), **base)
    yield Problem("explicit", explicit_family([a, b], 20.0), **base)
    yield Problem("parametric", parametric_family(
        Plant(p.B, p.A, temperature_C=28.0), [28.0, 35.0, 45.0],
        ThermalCoefficients(28.0, gain_per_K=0.002, creep_per_K=0.004, creep_tau_s=0.5)), **base)


@pytest.mark.parametrize("name", ["paper", "paper_robust", "paper_robust_continuous"])
def test_problem_document_round_trips_the_shipped_problems(name):
    p = robrst.load_problem(name)
    doc = json.loads(json.dumps(problem_document(p)))       # through JSON, as saved
    q = parse_problem(doc, "<saved>", compare=False)
    assert problem_document(q) == problem_document(p)
    for a, b in zip(p.family.models, q.family.models):
        assert a.temperature_C == b.temperature_C
        assert np.array_equal(a.B, b.B) and np.array_equal(a.A, b.A)   # bit for bit
    assert (p.poles, p.controller, p.specs) == (q.poles, q.controller, q.specs)


@pytest.mark.parametrize("problem", list(_python_problems()), ids=lambda p: p.name)
def test_problem_document_round_trips_problems_built_in_python(problem):
    q = parse_problem(json.loads(json.dumps(problem_document(problem))), "<saved>")
    assert [m.temperature_C for m in q.family.models] == \
        [m.temperature_C for m in problem.family.models]
    for a, b in zip(problem.family.models, q.family.models):
        assert np.array_equal(a.B, b.B) and np.array_equal(a.A, b.A)
    assert q.family.reference == problem.family.reference
    assert (q.poles, q.controller, q.specs, q.solver) == \
        (problem.poles, problem.controller, problem.specs, problem.solver)


def test_load_design_gives_the_saved_controller_and_its_certificate_again(saved, designs,
                                                                         monkeypatch):
    _no_design(monkeypatch)
    first = designs("paper_robust")
    lines = []
    again = load_design(saved, progress=lines.append)
    for k in "RST":
        assert np.array_equal(getattr(again.controller, k), getattr(first.controller, k))
    assert again.certified and lines == ["re-certified the saved controller: certified (as saved)"]
    # the certificate computed again: the same figures (the 2-DOF polynomials, not R/S: rounding)
    for q in ("Ms", "Ms_sampled", "Mt_sampled", "Mu_sampled", "overshoot_pct_sampled"):
        assert again.certificate.worst(q) == pytest.approx(first.certificate.worst(q), rel=1e-12)
    d, e = again.as_dict(), first.as_dict()
    assert set(d) == set(e) and d["solver"] == e["solver"] and d["tracking"] == e["tracking"]
    assert d["artefact"]["problem_document"] == e["artefact"]["problem_document"]
    assert set(e["artefact"]["versions"]) >= {"robrst", "numpy", "scipy", "casadi", "control",
                                              "python"}
    for a, b in zip(d["models"], e["models"]):
        assert a["Ms"] == b["Ms"] and a["gain_margin"] == b["gain_margin"]


@pytest.mark.slow
def test_the_commands_take_a_saved_design_without_designing(saved, tmp_path, monkeypatch,
                                                             capsys, designs):
    _no_design(monkeypatch)
    assert main(["export", str(saved), "--format", "c", "--out", str(tmp_path / "ctrl")]) == 0
    io = capsys.readouterr()
    assert "designing" not in io.err and "no design" in io.err and "wrote" in io.out
    assert "Tustin at 20000 Hz" in (tmp_path / "ctrl.h").read_text()
    assert main(["export", str(saved), "--quiet"]) == 0
    exp = json.loads(capsys.readouterr().out)
    assert exp["controller_s"] == designs("paper_robust").controller.as_dict()
    golden = tmp_path / "g.toml"
    assert main(["check", str(saved), "--golden", str(golden), "--update", "--quiet"]) == 0
    assert main(["check", str(saved), "--golden", str(golden), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["design", str(saved), "--json", "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out)["controller"] == \
        designs("paper_robust").controller.as_dict()
    assert main(["report", str(saved), "--out", str(tmp_path / "rep"), "--quiet"]) == 0
    assert json.loads((tmp_path / "rep" / "result.json").read_text())["certified"] is True
    assert main(["certify", str(saved), "--quiet"]) == 0


@pytest.mark.slow
def test_export_of_a_saved_design_at_another_rate_certifies_that_loop(saved, monkeypatch,
                                                                      capsys, designs):
    """No re-design at another --fs (a problem file would be re-designed): the saved
    controller's loop at 5 kHz is certified as it is, here honestly not (sampled Ms > 2)."""
    _no_design(monkeypatch)
    rc = main(["export", str(saved), "--fs", "5000", "--quiet"])
    exp = json.loads(capsys.readouterr().out)
    assert exp["sample_rate_hz"] == 5000.0
    assert exp["controller_s"] == designs("paper_robust").controller.as_dict()
    assert rc == (0 if exp["certificate"]["certified"] else 1)


def test_certify_on_another_problem(saved, tmp_path, monkeypatch, capsys):
    """On a drawn actuator 20 % stiffer and 30 % more gain the saved controller is certified
    or not, by the exact certificate; --family-only keeps the design's specs."""
    _no_design(monkeypatch)
    p = paper_plant()
    drawn = tmp_path / "drawn.toml"
    drawn.write_text(f"[plant]\nB = {(p.B * 1.3).tolist()}\nA = {p.A.tolist()}\n"
                     "temperature_C = 30.0\n[specs]\nMs_max = 10.0\n")
    rc = main(["certify", str(saved), "--problem", str(drawn), "--json", "--quiet"])
    d = json.loads(capsys.readouterr().out)
    # the drawn problem's own specs (the contract adds the default-spec lists after them)
    assert {k: d["specs"][k] for k in ("Ms_max", "Mt_max", "Mu_max", "stable_controller")} \
        == {"Ms_max": 10.0, "Mt_max": None, "Mu_max": None, "stable_controller": False}
    assert set(d["specs"]) - {"Ms_max", "Mt_max", "Mu_max", "stable_controller"} \
        == {"defaults", "defaults_off"}
    assert rc == (0 if d["certified"] else 1) and len(d["models"]) == 1
    rc = main(["certify", str(saved), "--problem", str(drawn), "--family-only", "--json",
               "--quiet"])
    d = json.loads(capsys.readouterr().out)
    assert d["specs"]["Ms_max"] == 2.0 and d["specs"]["sample_rate_hz"] == 20000.0
    assert rc == 1 and not d["certified"] and d["problem"] == "drawn"
    # an independent check of the verdict: the continuous loop's roots by numpy
    ctrl = robrst.load_design(saved).controller
    Delta = np.polyadd(np.polymul(p.A, ctrl.S), np.polymul(p.B * 1.3, ctrl.R))
    assert (np.max(np.roots(Delta).real) < 0) == all(m["stable"] for m in d["models"])


def test_merge_problem_replaces_the_family_as_a_whole():
    doc = {"plant": {"name": "paper"}, "family": {"temperatures_C": [28.0]},
           "specs": {"Ms_max": 2.0}, "poles": {"wn": 1.0}}
    other = {"model": {"format": "x"}, "specs": {"Ms_max": 3.0}}
    assert merge_problem(doc, other) == {"model": {"format": "x"}, "specs": {"Ms_max": 3.0},
                                         "poles": {"wn": 1.0}}
    assert merge_problem(doc, other, family_only=True)["specs"] == {"Ms_max": 2.0}


def test_files_that_are_no_saved_design_are_one_line(tmp_path, capsys):
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"problem": "p", "controller": {}, "certificate": {}}))
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    # a .json argument is read as JSON by every command: "not valid JSON", never "invalid
    # TOML" (turn 4: export said "invalid TOML" where certify said "not valid JSON")
    for path, words in ((old, "design it again"), (bad, "not valid JSON")):
        for cmd in (["export", str(path)], ["check", str(path), "--golden",
                                            str(tmp_path / "g.toml"), "--update"],
                    ["certify", str(path)], ["report", str(path), "--out", str(tmp_path / "r")],
                    ["design", str(path)]):
            assert main(cmd) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and str(path) in err[0] and words in err[0], (cmd, err)
    with pytest.raises(robrst.SpecError, match="design it again"):
        read_design(old)


def test_a_saved_design_with_overflowing_or_unreadable_numbers_is_one_line(tmp_path, capsys):
    # found by mutating every field of a saved design: R of 1e300 overflowed A S + B R inside
    # the stability check (a raw LinAlgError), a target_char_poly of text a raw ValueError
    doc = robrst.run_problem(robrst.load_problem("paper")).as_dict()
    cases = {"big.json": ("controller", "R", [1e300] * len(doc["controller"]["R"])),
             "text.json": ("target_char_poly", None, "x")}
    for name, (key, sub, value) in cases.items():
        d = json.loads(json.dumps(doc))
        if sub is None:
            d[key] = value
        else:
            d[key][sub] = value
        path = tmp_path / name
        path.write_text(json.dumps(d))
        for cmd in (["certify", str(path), "--quiet"],
                    ["export", str(path), "--quiet", "--out", str(tmp_path / "c.json")]):
            assert main(cmd) == 2, cmd
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and str(path) in err[0] and f"[{key}]" in err[0], (cmd, err)
            assert "computation failed" not in err[0]
