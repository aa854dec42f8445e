"""The printed spec table: a figure certified beyond its bound (within the certificate's
relative tolerance) says so, with the excess to two digits, never as a bare '-0.0%'; a
figure beyond the tolerance (a design that is not certified) is named not met, never as
within the tolerance."""

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


def test_a_spec_not_met_is_never_said_to_be_within_the_tolerance():
    """An uncertified design's damping 0.03625 against a floor of 0.2 (a lower bound: slack
    1 - 0.2/0.03625 = -452 %, as the JSON has it) is printed as not met, 82 % below the
    bound (1 - 0.03625/0.2), and an Ms 1 % above its bound too."""
    low = SpecRow("damping_min", 0.2, 0.03625, 1 - 0.2 / 0.03625, "T15C", 15.0, "sampled",
                  True, "specs")
    high = SpecRow("Ms_max", 2.0, 2.02, 1 - 2.02 / 2.0, "T45C", 45.0, "sampled", True,
                   "specs")
    lines = spec_table(_result(low, high))
    dm = next(line for line in lines if line.lstrip().startswith("damping_min"))
    ms = next(line for line in lines if line.lstrip().startswith("Ms_max"))
    assert "NOT MET (below the bound by 82 %)" in dm and "tolerance" not in dm
    assert "NOT MET (above the bound by 1 %)" in ms and "tolerance" not in ms
