"""The public face: ``import robrst`` gives the entry points, documented and typed."""

import importlib
import inspect
import pkgutil

import pytest

import robrst

ENTRY_POINTS = ("load_problem", "run_problem", "certify_problem", "analyze", "pole_placement",
                "simulate", "write_design_report", "export_controller", "digital_controller",
                "closed_loop_control", "assert_margins", "load_sweep", "run_sweep",
                "write_sweep_report", "load_design", "load_twin")


def test_every_export_resolves_even_after_every_module_is_imported():
    """A subpackage imported later must not shadow an exported function of the same name."""
    for mod in pkgutil.walk_packages(robrst.__path__, "robrst."):
        if not mod.name.endswith("__main__"):
            importlib.import_module(mod.name)
    for name in robrst.__all__:
        obj = getattr(robrst, name)
        assert not inspect.ismodule(obj), name


@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_entry_points_have_numpydoc_and_type_hints(name):
    fn = getattr(robrst, name)
    doc = inspect.getdoc(fn) or ""
    for section in ("Parameters", "Returns", "Examples"):
        assert f"{section}\n---" in doc, (name, section)
    sig = inspect.signature(fn)
    assert sig.return_annotation is not inspect.Signature.empty, name
    assert all(p.annotation is not inspect.Parameter.empty for p in sig.parameters.values()), name


def test_unknown_attribute_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        robrst.nope  # noqa: B018
