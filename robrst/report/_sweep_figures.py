"""Figures of a sweep report: histograms, sensitivity, trade-off front, fleet, worst-case Bode.

Every function takes a :class:`~robrst.studies.sweep.engine.SweepResult` and a file path and writes
one PNG (:func:`robrst.report._figure.drawing`: no global matplotlib state).  Only variants
evaluated without error (status ``ok``) are drawn; infinite margins are counted in the titles.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.report._figure import colors, drawing
from robrst.studies.sweep.curves import ok_rows
from robrst.studies.sweep.summary import front_values, pareto_front
from robrst.problem.mimo import MIMO_SPECS
from robrst.problem.specs import PEAK_SPECS, spec_columns

if TYPE_CHECKING:
    from pathlib import Path
    from robrst.studies.sweep.curves import WorstCaseCurves
    from robrst.studies.sweep.engine import SweepResult

__all__ = ["histograms_figure", "sensitivity_figure", "front_figure", "fleet_figure",
           "worst_bode_figure", "HIST"]

LOG_SPAN = 100.0     # a front whose maximised figure spans more than this ratio: log axes
# figure column -> (axis label, scale, spec bound attribute); the spec columns from the table
HIST = (*((row.column, row.column_label, 1.0, row.key) for row in spec_columns()),
        ("gain_margin", "smallest gain margin [-]", 1.0, None),
        ("phase_margin_deg", "smallest phase margin [°]", 1.0, None),
        ("delay_margin_s", "smallest delay margin [µs]", 1e6, None),
        ("worst_ratio", "worst figure / bound [-]", 1.0, None))


def _values(table, name, scale=1.0):
    v = np.array([np.nan if x is None else x for x in table.column(name).to_pylist()], float)
    return v * scale


def histograms_figure(result: SweepResult, path: str | Path) -> None:
    """Histograms of the worst-case figures of every variant, spec bounds dashed.

    Parameters
    ----------
    result : SweepResult
        The sweep.
    path : str or pathlib.Path
        The PNG file.
    """
    t = ok_rows(result.table)
    specs = result.context.base.specs
    if result.context.mimo:
        panels = _mimo_panels(specs)
    else:
        # the columns of the specs only this sweep's problem bounds (robrst.problem.specs)
        panels = HIST + tuple((row.column, row.column_label, 1.0, row.key)
                              for row in spec_columns(specs) if not row.always_column)
    cols = (len(panels) + 1) // 2
    with drawing(path, (13 * cols / 4, 6.5), 2, cols) as (fig, axes):
        for ax in axes.ravel()[len(panels):]:
            ax.set_visible(False)
        for ax, (name, label, scale, bound) in zip(axes.ravel(), panels):
            b = (bound if isinstance(bound, float) else getattr(specs, bound) if bound
                 else (1.0 if name == "worst_ratio" else None))
            v = _values(t, name, scale)
            n_inf = int(np.sum(np.isinf(v)))
            title = label + (f" (∞: {n_inf})" if n_inf else "")
            _histogram(ax, v[np.isfinite(v)], b)
            ax.set_title(title, fontsize=9)
            ax.set_ylabel("variants")
        fig.suptitle(f"{result.sweep.name}: {t.num_rows} variants evaluated of"
                     f" {result.summary['done']}, yield {result.summary['yield']:.3f}")


def _mimo_panels(specs):
    """A multi-axis sweep's histogram panels: the singular-value peaks of S, T and U and
    every bounded figure, the least tracking bandwidth, the worst figure/bound."""
    bounded = specs.bounded
    rows = [r for r in MIMO_SPECS if r.figure in bounded or r.kind == "sigma"
            and r.figure != "sigma_Sd"]
    return (*((r.figure, f"worst {r.figure}" + (f" [{r.unit}]" if r.unit else " [-]"), 1.0,
               bounded.get(r.figure)) for r in rows),
            ("bandwidth_hz", "least tracking bandwidth [Hz]", 1.0, None),
            ("worst_ratio", "worst figure / bound [-]", 1.0, None))


def _histogram(ax, fin, bound):
    """One panel: the histogram, the bound if it is on scale (else named in a note)."""
    if fin.size == 0:
        ax.text(0.5, 0.5, "no finite value", ha="center", va="center", transform=ax.transAxes,
                fontsize=11)
        return
    lo, hi = float(fin.min()), float(fin.max())
    mid = 0.5 * (lo + hi)
    if hi - lo <= 1e-9 * max(abs(mid), 1.0):     # every variant has the same value
        ax.text(0.5, 0.5, f"all {fin.size} variants:\n{mid:.6g}"
                + ("" if bound is None else f"\n(bound {bound:g})"),
                ha="center", va="center", transform=ax.transAxes, fontsize=11)
        ax.set_xticks([])
        return
    ax.hist(fin, bins=min(40, max(5, fin.size // 10)), color="tab:blue", alpha=0.8)
    ax.ticklabel_format(axis="x", useOffset=False)
    if bound is None:
        return
    pad = 0.25 * (hi - lo)
    if lo - pad <= bound <= hi + pad:
        ax.axvline(bound, color="k", ls="--", lw=1, label=f"bound {bound:g}")
        ax.legend(fontsize=8)
    else:
        ax.text(0.03, 0.95, f"bound {bound:g} off scale", transform=ax.transAxes, fontsize=8,
                va="top")


def sensitivity_figure(result: SweepResult, path: str | Path) -> None:
    """``worst_ratio`` against every varied parameter (certified blue, not certified red).

    Parameters
    ----------
    result : SweepResult
        The sweep.
    path : str or pathlib.Path
        The PNG file.
    """
    t = ok_rows(result.table)
    names = list(result.context.names)[:8]
    ncols = min(4, max(1, len(names)))
    nrows = max(1, -(-len(names) // ncols))
    ratio = _values(t, "worst_ratio")
    cert = np.array(t.column("certified").to_pylist(), bool)
    with drawing(path, (3.3 * ncols, 3.0 * nrows), nrows, ncols, squeeze=False) as (fig, axes):
        for ax, name in zip(axes.ravel(), names):
            x = _values(t, name)
            ax.plot(x[cert], ratio[cert], ".", ms=3, color="tab:blue", label="certified")
            ax.plot(x[~cert], ratio[~cert], ".", ms=4, color="tab:red", label="not certified")
            ax.axhline(1.0, color="k", ls="--", lw=1)
            ax.set_xlabel(name, fontsize=8)
            ax.set_ylabel("worst figure / bound")
        for ax in axes.ravel()[len(names):]:
            ax.set_visible(False)
        axes.ravel()[0].legend(fontsize=7)


def front_figure(result: SweepResult, path: str | Path) -> None:
    """Trade-off: the maximised figure against the first parameter, and the Pareto front.

    Parameters
    ----------
    result : SweepResult
        A design sweep.
    path : str or pathlib.Path
        The PNG file.
    """
    t = ok_rows(result.table)
    x_name, y_name = result.sweep.front
    names = list(result.context.names)
    cert = np.array(t.column("certified").to_pylist(), bool)
    y = front_values(y_name, _values(t, y_name))
    if y_name == "integral_gain":
        y_name = "|integral_gain|"
    with drawing(path, (12, 4.8), 1, 2) as (fig, (a1, a2)):
        if names:
            p0 = _values(t, names[0])
            groups = np.unique(_values(t, names[1])) if len(names) > 1 else [None]
            if len(groups) > 8:
                groups = [None]
            for g, c in zip(groups, colors(len(groups), "viridis")):
                sel = np.ones(t.num_rows, bool) if g is None else _values(t, names[1]) == g
                o = np.argsort(p0[sel])
                lab = "" if g is None else f"{names[1]} = {g:g}"
                a1.plot(p0[sel][o], y[sel][o], "-", color=c, lw=1, label=lab)
                a1.plot(p0[sel & cert], y[sel & cert], "o", color=c, ms=5)
                a1.plot(p0[sel & ~cert], y[sel & ~cert], "o", mfc="none", color=c, ms=5)
            failed = [r[names[0]] for r in result.table.to_pylist() if r["status"] != "ok"]
            if failed:
                a1.plot(failed, [np.nanmin(y) if np.isfinite(y).any() else 0.0] * len(failed),
                        "x", color="tab:red", ms=8, label=f"failed ({len(failed)})")
            a1.set_xlabel(names[0])
            if a1.get_legend_handles_labels()[1]:   # one parameter, no failure: no labels
                a1.legend(fontsize=8)
        a1.set_ylabel(y_name)
        a1.set_title("filled: certified; hollow: not certified; ×: no design (see the table)",
                     fontsize=9)
        x = _values(t, x_name)
        a2.plot(x[cert], y[cert], "o", color="tab:blue", ms=5, label="certified")
        a2.plot(x[~cert], y[~cert], "o", mfc="none", color="tab:red", ms=5,
                label="not certified")
        xs, ys = np.where(cert, x, np.nan), np.where(cert, y, np.nan)
        f = pareto_front(xs, ys)
        if f:
            a2.step(x[f], y[f], where="post", color="k", lw=1.2, label="Pareto front")
        a2.set_xlabel(f"{x_name} (achieved, minimised)")
        a2.set_ylabel(f"{y_name} (maximised)")
        a2.legend(fontsize=8)
        pos = y[np.isfinite(y)]
        if pos.size and pos.min() > 0 and pos.max() > LOG_SPAN * pos.min():
            a1.set_yscale("log")          # values over decades: each one readable
            a2.set_yscale("log")


def fleet_figure(result: SweepResult, path: str | Path) -> None:
    """Per fleet member: worst figure/bound and integral gain.

    Parameters
    ----------
    result : SweepResult
        A fleet sweep.
    path : str or pathlib.Path
        The PNG file.
    """
    t = result.table
    files = t.column("file").to_pylist()
    ratio = _values(t, "worst_ratio")
    gain = _values(t, "integral_gain")
    cert = t.column("certified").to_pylist()
    pos = np.arange(len(files))
    with drawing(path, (max(6, 0.8 * len(files) + 3), 6), 2, 1, sharex=True) as (fig, (a1, a2)):
        a1.bar(pos, np.where(np.isfinite(ratio), ratio, np.nan),
               color=["tab:blue" if c else "tab:red" for c in cert])
        a1.axhline(1.0, color="k", ls="--", lw=1)
        a1.set_ylabel("worst figure / bound")
        a1.set_title("blue: certified; red: not certified or failed", fontsize=9)
        a2.bar(pos, gain, color="tab:gray")
        a2.set_ylabel("integral gain [V/(µm s)]")
        a2.set_xticks(pos, files, rotation=30, ha="right", fontsize=8)


def worst_bode_figure(curves: WorstCaseCurves, path: str | Path) -> None:
    """``|S|, |T|, |U|`` of the worst variant per temperature; thin grey: the base family.

    Parameters
    ----------
    curves : WorstCaseCurves
        The worst variant's responses (:func:`robrst.studies.sweep.curves.worst_case_curves`).
    path : str or pathlib.Path
        The PNG file.
    """
    sp, f = curves.specs, curves.freq_hz
    with drawing(path, (8, 9), 3, 1, sharex=True) as (fig, axes):
        for k, ((name, key), ax) in enumerate(zip(PEAK_SPECS.items(), axes)):
            for mc in curves.base:
                ax.semilogx(f, _db(mc.responses[k]), color="0.7", lw=0.8)
            for mc, c in zip(curves.models, colors(len(curves.models))):
                ax.semilogx(f, _db(mc.responses[k]), color=c, lw=1.2,
                            label=f"{mc.temperature_C:g} °C")
            b = getattr(sp, key)
            if b is not None:
                ax.axhline(_db(b), color="k", ls="--", lw=1, label=f"{key} = {b:g}")
            if name == "T" and sp.T_resonance_max is not None:
                ax.plot(sp.resonance_band_hz, [_db(sp.T_resonance_max)] * 2, "r-", lw=2,
                        label="resonance-band bound")
            ax.set_ylabel(f"|{name}| [dB]")
        axes[0].legend(fontsize=7, ncol=4, loc="lower right")
        axes[1].legend(fontsize=7, loc="lower left")
        axes[-1].set_xlabel("frequency f [Hz] (log)")
        axes[0].set_title(f"worst case: {curves.what}, worst figure/bound"
                          f" {curves.worst_ratio:.4g}"
                          + (" (grey: nominal family)" if curves.base else ""), fontsize=9)


def _db(x):
    return 20 * np.log10(np.maximum(np.abs(x), 1e-300))
