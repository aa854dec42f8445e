"""The printed spec table: a figure certified beyond its bound (within the certificate's
relative tolerance) says so, with the excess to two digits, never as a bare '-0.0%'."""

from types import SimpleNamespace

from robrst.design.achieved import SpecRow
from robrst.report.text import spec_table


def _result(*rows, cert_tol=1e-3):
    return SimpleNamespace(specs_achieved=rows,
                           problem=SimpleNamespace(solver=SimpleNamespace(cert_tol=cert_tol)))


def test_a_figure_beyond_its_bound_names_the_tolerance():
    over = SpecRow("Mt_max", 1.3, 1.3001655, 1 - 1.3001655 / 1.3, "T28C", 28.0, "sampled",
                   True, "specs")
    inside = SpecRow("Ms_max", 2.0, 1.47, 1 - 1.47 / 2.0, "T45C", 45.0, "sampled", False,
                     "specs")
    lines = spec_table(_result(over, inside, cert_tol=2e-3))
    mt = next(line for line in lines if line.lstrip().startswith("Mt_max"))
    ms = next(line for line in lines if line.lstrip().startswith("Ms_max"))
    assert "-0.01%" in mt and "BINDS" in mt
    assert "beyond the bound by 0.013 %" in mt and "cert_tol = 0.002" in mt
    assert "26.5%" in ms and "beyond" not in ms and "BINDS" not in ms
