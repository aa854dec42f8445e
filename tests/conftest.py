"""Shared fixtures: the shipped problems and their designs, computed once per session."""

import pathlib

import pytest

from robrst.design import run_problem
from robrst.base.resources import problems_dir as _problems_dir
from robrst.problem.files import load_problem

ROOT = pathlib.Path(__file__).resolve().parents[1]
REPRO = ROOT / "tests" / "repro"

# the reproducers are data (problem files, a script that writes a record), not test modules
collect_ignore = ["repro"]

# the package's doctests that design, sweep or simulate (8-15 s each) run with -m slow
SLOW_DOCTESTS = {"robrst.report.sweep.write_sweep_report",
                 "robrst.report.design.write_design_report",
                 "robrst.design.mimo.design_mimo"}


def pytest_collection_modifyitems(config, items):
    """Mark the slow doctests (a docstring cannot carry a pytest mark)."""
    for item in items:
        if item.name in SLOW_DOCTESTS:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def problems_dir():
    """The built-in problem files (package data)."""
    return _problems_dir()


@pytest.fixture(scope="session")
def repro_dir():
    """``tests/repro``: the reproducers (each file's header says what went wrong and the
    truth); ``tests/project/test_reproducers.py`` checks that every one has a test."""
    return REPRO


@pytest.fixture(scope="session")
def designs():
    """Design results of the shipped problems, computed on first use and shared."""
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = run_problem(load_problem(name))
        return cache[name]

    return get


@pytest.fixture(scope="session")
def robust_result(designs):
    return designs("paper_robust")


@pytest.fixture(scope="session")
def exports(designs):
    """Exported digital controllers of the shipped problems (20 kHz where none is named)."""
    from robrst.controller.export import export_controller

    cache = {}

    def get(name):
        if name not in cache:
            result = designs(name)
            fs = None if result.problem.specs.sampled else 20000.0
            cache[name] = export_controller(result, fs)
        return cache[name]

    return get
