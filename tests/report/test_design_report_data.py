"""The design report draws the right numbers: every curve of bode.png, nyquist.png and
step.png, the certified peaks it marks and its margins table, against python-control.

The design: the paper's analytic RST controller on a three-member family of D(s) over
28-45 °C (the laws of paper_robust), so the figures hold several temperatures.  The
figures are captured as drawn (``robrst.report._design_figures.drawing`` wrapped, the PNGs
still written); the independent references are the unscaled polynomials' values on the
figures' grids (``S = A S/Delta``, ``T = B R/Delta``, ``U = A R/Delta``, products formed with
numpy), python-control's loop ``L = P K`` and margins, peaks refined by scipy around a dense
grid's largest value, and python-control's step responses of the loop polynomials formed with numpy, in a scaled time ``p = s / w0`` so
the state space has O(1) coefficients.
"""


import control
import numpy as np
import pytest
from drawn import drawn
from scipy.optimize import minimize_scalar

from robrst.base.resources import problems_dir
from robrst.base.schema import load_toml
from robrst.design import run_problem
from robrst.problem.files import parse_problem
import robrst.report._design_figures as design_figures
from robrst.report.design import write_design_report
from robrst.studies.design_curves import design_curves

TEMPS = [28.0, 36.5, 45.0]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """``(result, figures by file name, report folder)``."""
    doc = load_toml(problems_dir() / "paper.toml", "problem file")
    doc["problem"]["name"] = "paper_three_temperatures"
    doc["family"] = {"reference_C": 28.0, "temperatures_C": TEMPS,
                     "parametric": {"gain_per_K": 0.0015, "resonance_per_K": -0.0001,
                                    "damping_per_K": 0.005, "creep_per_K": 0.004,
                                    "creep_at_ref": 0.0, "creep_tau_s": 0.5}}
    result = run_problem(parse_problem(doc, "paper_three_temperatures.toml"))
    with drawn(design_figures) as figures:
        folder = write_design_report(result, tmp_path_factory.mktemp("r") / "report",
                                     curves=design_curves(result))
    return result, figures, folder


def _response(m, ctrl, name, w):
    """S = A S/Delta, T = B R/Delta or U = A R/Delta of plant ``m`` under ``ctrl`` at ``w``
    [rad/s] (numpy's products and values of the unscaled polynomials, Delta = A S + B R)."""
    s = 1j * np.asarray(w, float)
    A, B, R, S = m.A, m.B, ctrl.R, ctrl.S
    num = {"S": np.polymul(A, S), "T": np.polymul(B, R), "U": np.polymul(A, R)}[name]
    return np.polyval(num, s) / np.polyval(np.polyadd(np.polymul(A, S), np.polymul(B, R)), s)


def _loop(m, ctrl, w):
    """python-control's loop L = P K at ``w`` > 0 [rad/s]."""
    s = 1j * np.asarray(w, float)
    return control.tf(m.B, m.A)(s) * control.tf(ctrl.R, ctrl.S)(s)


def _peak(m, ctrl, name):
    """The largest |name(jw)| over w >= 0: a dense grid (0 and a log grid), refined by
    scipy around its maximum."""
    w = np.concatenate([[0.0], np.geomspace(1e-2, 2 * np.pi * 1e5, 200_001)])
    mag = np.abs(_response(m, ctrl, name, w))
    k = int(np.argmax(mag))
    if k == 0:
        return mag[0], 0.0
    res = minimize_scalar(lambda x: -abs(_response(m, ctrl, name, np.array([x]))[0]),
                          bounds=(w[max(k - 1, 0)], w[min(k + 1, w.size - 1)]),
                          method="bounded", options={"xatol": 1e-10 * w[k]})
    return max(mag[k], -res.fun), res.x


def _model_lines(ax):
    return [ln for ln in ax.get_lines() if str(ln.get_label()).endswith("°C")]


def test_bode_curves_and_marked_peaks_are_python_controls(report):
    result, figures, folder = report
    axes = figures["bode.png"].axes
    models, ctrl = result.problem.family.models, result.controller
    assert [m.temperature_C for m in models] == TEMPS and (folder / "bode.png").is_file()
    for ax, name in zip(axes, ("S", "T", "U")):
        lines = _model_lines(ax)
        marks = [ln for ln in ax.get_lines() if ln.get_marker() == "x"]
        assert [ln.get_label() for ln in lines] == [f"{T:g} °C" for T in TEMPS]
        assert len(marks) == len(models)
        for ln, mark, m in zip(lines, marks, models):
            f = np.asarray(ln.get_xdata())
            assert f[0] == pytest.approx(1.0) and f[-1] == pytest.approx(10 ** 4.7)
            ref = np.abs(_response(m, ctrl, name, 2 * np.pi * f))
            np.testing.assert_allclose(10 ** (np.asarray(ln.get_ydata()) / 20), ref, rtol=1e-8)
            # the x marks the certified peak: the largest value python-control finds
            peak, w_peak = _peak(m, ctrl, name)
            (f_mark,), (db_mark,) = mark.get_xdata(), mark.get_ydata()
            assert 10 ** (db_mark / 20) == pytest.approx(peak, rel=1e-7), (name, m.label)
            assert 2 * np.pi * f_mark == pytest.approx(w_peak, rel=1e-3), (name, m.label)
        bound = {"S": 2.0, "T": 1.3, "U": 150.0}[name]        # paper.toml's specs, dashed
        dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert len(dashed) == 1
        assert 10 ** (np.asarray(dashed[0].get_ydata())[0] / 20) == pytest.approx(bound)


def test_nyquist_loops_and_margin_circles_are_python_controls(report):
    result, figures, _ = report
    ax = figures["nyquist.png"].axes[0]
    models, ctrl = result.problem.family.models, result.controller
    lines = _model_lines(ax)
    assert len(lines) == len(models)
    for ln, m in zip(lines, models):
        x, y = np.asarray(ln.get_xdata()), np.asarray(ln.get_ydata())
        w = 2 * np.pi * np.logspace(-1, 5, x.size)          # the figure's grid, 0.1 Hz..100 kHz
        L = _loop(m, ctrl, w)
        drawn = np.isfinite(x)
        assert np.array_equal(drawn, np.abs(L) < 20)         # off-scale points left out
        np.testing.assert_allclose(x[drawn] + 1j * y[drawn], L[drawn], rtol=1e-8, atol=1e-12)

    def radius(label):
        ln, = [ln for ln in ax.get_lines() if str(ln.get_label()).startswith(label)]
        return np.abs(np.asarray(ln.get_xdata()) + 1j * np.asarray(ln.get_ydata()) + 1)

    worst_ms = max(_peak(m, ctrl, "S")[0] for m in models)
    np.testing.assert_allclose(radius("achieved"), 1 / worst_ms, rtol=1e-7)
    np.testing.assert_allclose(radius("spec"), 1 / 2.0, rtol=1e-12)


def _scaled(num, den, w0):
    """``num(w0 p) / den(w0 p)`` as a python-control tf with O(1) coefficients."""
    n = len(den) - 1
    num = np.concatenate([np.zeros(n + 1 - len(num)), num])
    k = w0 ** np.arange(n, -1, -1.0)                      # s^j = w0^j p^j
    return control.tf(num * k / (den[0] * k[0]), den * k / (den[0] * k[0]))


def test_step_curves_are_python_controls(report):
    """Reference step (B T / Delta) and 1 V input-disturbance step (B S / Delta) at the
    extreme temperatures, Delta = A S + B R formed with numpy."""
    result, figures, _ = report
    a1, a2 = figures["step.png"].axes
    ctrl, fam = result.controller, result.problem.family.models
    for ax, num_of in ((a1, lambda m: np.polymul(m.B, ctrl.T)),
                       (a2, lambda m: np.polymul(m.B, ctrl.S))):
        lines = ax.get_lines()
        assert [ln.get_label() for ln in lines] == ["linear, 28 °C", "linear, 45 °C"]
        for ln, m in zip(lines, (fam[0], fam[-1])):
            t = np.asarray(ln.get_xdata()) * 1e-3                     # drawn in ms
            delta = np.polyadd(np.polymul(m.A, ctrl.S), np.polymul(m.B, ctrl.R))
            w0 = abs(delta[-1]) ** (1 / (len(delta) - 1))
            _, y = control.step_response(_scaled(num_of(m), delta, w0), T=t * w0)
            ref = np.ravel(y)
            np.testing.assert_allclose(np.asarray(ln.get_ydata()), ref,
                                       atol=1e-7 * np.max(np.abs(ref)))
    # the horizon: three 2 % settling times of the slowest reference step (5 ms .. 1 s)
    assert 5e-3 <= float(np.asarray(a1.get_lines()[0].get_xdata())[-1]) * 1e-3 <= 1.0


def test_margins_table_is_python_controls(report):
    """The Markdown table's Ms, Mt, Mu (the certified peaks) and gain and phase margins."""
    result, _, folder = report
    md = (folder / "report.md").read_text()
    head = "| model | T [°C] | stable | Ms | Mt | Mu [V/µm] | GM | PM [°] | MM | DM [µs] |"
    rows = md.split(head, 1)[1].split("\n\n", 1)[0].strip().splitlines()[1:]
    assert len(rows) == len(TEMPS)
    ctrl = result.controller
    for row, m in zip(rows, result.problem.family.models):
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[:3] == [m.label, f"{m.temperature_C:.1f}", "yes"]
        for cell, name, spec in zip(cells[3:6], "STU", (".3f", ".3f", ".1f")):
            assert cell == format(_peak(m, ctrl, name)[0], spec), (m.label, name)
        gm, pm = control.stability_margins(control.tf(m.B, m.A) * control.tf(ctrl.R, ctrl.S))[:2]
        assert cells[6] == f"{gm:.2f}" and cells[7] == f"{pm:.1f}", (m.label, cells, gm, pm)
        assert cells[8] == format(1 / _peak(m, ctrl, "S")[0], ".3f")
