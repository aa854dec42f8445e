"""The sweep report draws the sweep's records: its tables and figures against the rows of
``results.parquet`` (read back with pyarrow), the worst variant's Bode curves against the
unscaled polynomials of a hand-built plant.

The sweep: 40 variants of the paper's analytic design (gain ~ N(1, 0.5), damping ~
U(0.5, 2), tests/sweep_files.py), in this process; the figures are captured as drawn
(``robrst.report._sweep_figures.drawing`` wrapped, the PNGs still written).  The references
are computed here: counts, the Wilson interval's closed form, the inverted-CDF quantiles
(each a data point), the order of the worst rows (failed first, then the largest figure /
bound), and D(s) of the paper with the variant's gain and damping put in by hand.
"""

import json
import math
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from sweep_files import fast_file
from drawn import drawn

from robrst.problem.files import load_problem
import robrst.report._sweep_figures as sweep_figures
from robrst.report.sweep import write_sweep_report
from robrst.studies.sweep import run_sweep


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """``(result, rows of results.parquet, figures by file name, report folder)``."""
    folder = tmp_path_factory.mktemp("sweep")
    result = run_sweep(fast_file(folder, n=40, chunk=10, std=0.5), folder / "out", workers=0)
    with drawn(sweep_figures) as figures:
        report = write_sweep_report(result)
    rows = pq.read_table(folder / "out" / "results.parquet").to_pylist()
    return result, rows, figures, report


def _table(md, head):
    """The rows (lists of cells) of the Markdown table whose header line starts ``head``."""
    lines = md.split("\n" + head, 1)[1].split("\n\n", 1)[0].splitlines()[2:]
    return [[c.strip() for c in line.strip().strip("|").split("|")] for line in lines]


def _g(x):
    if x is None:
        return "–"
    return "∞" if math.isinf(x) else format(x, ".4g")


def _wilson(k, n, z=1.959963984540054):
    p = k / n
    mid, half = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (mid - half) / (1 + z * z / n), (mid + half) / (1 + z * z / n)


def _worst_order(rows):
    """Failed rows first, then by figure/bound (largest first), then by index."""
    def key(r):
        ratio = r["worst_ratio"]
        ratio = math.inf if ratio is None or math.isnan(ratio) else ratio
        return (r["status"] == "ok", -ratio, r["index"])
    return sorted(rows, key=key)


def test_the_tables_are_the_records(sweep):
    result, rows, _, report = sweep
    md = (report / "report.md").read_text()
    n, k = len(rows), sum(bool(r["certified"]) for r in rows)
    assert n == 40 and 0 < k < n                         # both outcomes are in the tables
    lo, hi = _wilson(k, n)
    assert (f"{n} of 40 variants evaluated; **{k} certified**, yield **{k / n:.4f}**"
            f" (95 % interval {lo:.4f}–{hi:.4f})") in md
    statuses = sorted({r["status"] for r in rows})
    assert _table(md, "| status |") == [[s, str(sum(r["status"] == s for r in rows))]
                                        for s in statuses]
    spread = _table(md, "| figure | min |")
    assert {"Ms", "Mt", "Mu", "worst_ratio", "integral_gain"} <= {c[0] for c in spread}
    for name, *cells in spread:
        v = np.sort([r[name] for r in rows if r[name] is not None and not math.isnan(r[name])])
        want = [v[max(0, math.ceil(q * v.size) - 1)] for q in (0.0, 0.05, 0.5, 0.95, 1.0)]
        assert cells == [_g(float(x)) for x in want], name
    worst = _table(md, "| variant | status |")
    assert len(worst) == result.sweep.worst
    for cells, r in zip(worst, _worst_order(rows)):
        assert cells[:6] == [str(r["index"]), r["status"], _g(r["worst_ratio"]), _g(r["Ms"]),
                             _g(r["Mt"]), _g(r["Mu"])]
        assert cells[-1] == f"gain={r['gain']:.4g}, damping={r['damping']:.4g}"
    # a copy of the sweep's own summary.json
    assert (json.loads((report / "summary.json").read_text())
            == json.loads((Path(result.out) / "summary.json").read_text()))


def test_the_sensitivity_and_histogram_figures_draw_every_variant(sweep):
    _, rows, figures, _ = sweep
    ok = [r for r in rows if r["status"] == "ok"]
    for ax, name in zip(figures["sensitivity.png"].axes, ("gain", "damping")):
        assert ax.get_xlabel() == name
        blue, red = ax.get_lines()[:2]
        for line, cert in ((blue, True), (red, False)):
            drawn = sorted(zip(line.get_xdata(), line.get_ydata()))
            assert drawn == sorted((r[name], r["worst_ratio"]) for r in ok
                                   if bool(r["certified"]) == cert)
    ms = [ax for ax in figures["histograms.png"].axes if ax.get_title().startswith("worst |S|")]
    assert len(ms) == 1
    heights = [p.get_height() for p in ms[0].patches]
    values = np.array([r["Ms"] for r in ok])
    assert sum(heights) == np.isfinite(values).sum()
    edges = [p.get_x() for p in ms[0].patches] + [ms[0].patches[-1].get_x()
                                                   + ms[0].patches[-1].get_width()]
    assert edges[0] == pytest.approx(values.min()) and edges[-1] == pytest.approx(values.max())
    counts, _ = np.histogram(values, bins=len(heights))
    assert heights == counts.tolist()


def test_the_worst_bode_draws_the_worst_variant(sweep):
    """Its title names the worst row; its curves are |S|, |T|, |U| of the paper's D(s) with
    that row's gain and damping (the resonant pair's damping scaled, by hand) under the
    analysed controller, grey: the nominal D(s)."""
    result, rows, figures, _ = sweep
    worst = _worst_order([r for r in rows if r["status"] == "ok"])[0]
    axes = figures["worst_bode.png"].axes
    assert axes[0].get_title().startswith(f"worst case: variant {worst['index']}, worst"
                                          f" figure/bound {worst['worst_ratio']:.4g}")
    c = result.summary["controller"]
    R, S = np.array(c["R"]), np.array(c["S"])
    nominal = load_problem("paper").family.models[0]
    A = np.array([1.0])
    for r in np.roots(nominal.A):
        if r.imag < 0:
            continue
        if r.imag == 0:
            A = np.convolve(A, [1.0, -r.real])
        else:
            wn, z = abs(r), -r.real / abs(r) * worst["damping"]
            A = np.convolve(A, [1.0, 2 * z * wn, wn * wn])
    plants = {"grey": (nominal.B, nominal.A), "worst": (worst["gain"] * nominal.B, A)}
    for ax, name in zip(axes, ("S", "T", "U")):
        lines = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-"
                 and np.size(ln.get_xdata()) > 2]
        assert len(lines) == 2                           # the nominal (grey), the worst variant
        for ln, (B, A_) in zip(lines, (plants["grey"], plants["worst"])):
            s = 2j * np.pi * np.asarray(ln.get_xdata())
            delta = np.polyval(np.polyadd(np.polymul(A_, S), np.polymul(B, R)), s)
            num = {"S": np.polymul(A_, S), "T": np.polymul(B, R), "U": np.polymul(A_, R)}[name]
            ref = np.abs(np.polyval(num, s) / delta)
            np.testing.assert_allclose(10 ** (np.asarray(ln.get_ydata()) / 20), ref, rtol=1e-8)
        if name == "S":          # the row's certified Ms bounds the drawn curve, and is near it
            top = float(np.max(10 ** (np.asarray(lines[1].get_ydata()) / 20)))
            assert top <= worst["Ms"] * (1 + 1e-9) and top >= 0.99 * worst["Ms"]
