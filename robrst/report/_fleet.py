"""The report of a fleet design: the guarantee, the measured yield, the price of yield.

Draws the records written by ``python -m benchmarks.fleet`` (``fleet.json``: the design's
``robrst design --json`` with its ``fleet`` object, the verification on fresh draws and the
trade-off designs); computes nothing.  ``DIR/report/``: ``report.md``, ``report.html`` and
``price_of_yield.png`` (integral gain against the yield target, with each design's measured
yield and its 95 % interval).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from robrst.report.doc import Doc, write_folder
from robrst.report._figure import drawing

__all__ = ["fleet_doc", "write_fleet_report"]


def _f(x, spec=".4g"):
    if x is None:
        return "–"
    if isinstance(x, float) and not math.isfinite(x):
        return "∞"
    return format(x, spec)


def _pct(x, digits=1):
    return "–" if x is None else f"{100 * x:.{digits}f} %"


def fleet_doc(records: dict) -> tuple[Doc, list[str]]:
    """The report document of ``records`` (``fleet.json``).

    Parameters
    ----------
    records : dict
        The design's JSON, the verification and the trade-off.

    Returns
    -------
    (Doc, list of str)
        The document and the figure files it references.
    """
    d = records["design"]
    fl = d["fleet"]
    v = records["verification"]
    lo, hi = v["yield_ci95"]
    blocks = [("p", f"Problem `{records['problem']}`: designed for a yield of"
               f" {_pct(fl['yield_target'])} at confidence {_pct(fl['confidence'])} over its"
               f" manufacturing spread ({', '.join(fl['parameters'])}), method"
               f" `{fl['method']}`. Status of the design: **{d['status']}**."),
              ("h2", "Guarantee and measured yield"),
              ("table", ("", "value"), [
                  ("drawn actuators N", fl["scenarios"]),
                  ("decision variables d", fl["decision_variables"]),
                  ("N of the convex a-priori bound (Campi & Garatti 2008), for reference",
                   _f(fl.get("n_convex_a_priori"))),
                  ("compression set k (program + discarded + violated)", fl["compression_size"]),
                  ("exchange rounds", fl["rounds"]),
                  ("a-posteriori guarantee 1 - epsilon(k) (Campi, Garatti & Ramponi 2018)",
                   _pct(fl["guaranteed_yield"], 2)),
                  ("target met by the guarantee", fl["target_met"]),
              ] + ([("drawn actuators the target needs at this k",
                     fl["scenarios_for_target"])] if fl.get("scenarios_for_target") else []) + [
                  (f"measured yield on {v['n']} fresh actuators (seed {v['seed']})",
                   f"{v['certified']} / {v['n']} = {_pct(v['measured_yield'])}"),
                  ("95 % Wilson interval", f"{_pct(lo)} – {_pct(hi)}"),
                  ("unstable loops among them", v["unstable"]),
                  ("integral gain (fleet design)", _f(d["integral_gain"])),
                  ("integral gain (nominal design)", _f(records["nominal_integral_gain"])),
                  ("fleet / nominal integral gain", _f(fl["integral_gain_ratio"])),
                  ("fleet design wall time", f"{records['design_wall_s']:.1f} s"
                   + (f" (designs {fl['design_time_s']:.0f} s, actuator checks"
                      f" {fl['check_time_s']:.0f} s)" if fl.get("check_time_s") else "")),
                  ("nominal design wall time", f"{records['nominal_design_wall_s']:.1f} s"),
                  ("verification wall time", f"{v['wall_s']:.1f} s on {v['workers']} workers"),
              ]),
              ("p", f"The guarantee: with probability at least {_pct(fl['confidence'])} over"
               " the N drawn actuators, a fresh actuator certifies with probability at least"
               f" {_pct(fl['guaranteed_yield'], 2)}. {fl['bound']}.")]
    if v["worst"]:
        rows = []
        for w in v["worst"][:10]:
            params = ", ".join(f"{k}={x:.4g}" for k, x in w["params"].items())
            rows.append((w["index"], _f(w.get("worst_ratio")), w.get("violation") or "–",
                         params))
        blocks += [("h2", "Worst fresh actuators"),
                   ("table", ("actuator", "figure/bound", "worst violation", "parameters"),
                    rows)]
    files = []
    if records.get("tradeoff"):
        rows = []
        order = sorted(records["tradeoff"], key=lambda t: (t["yield_target"] is None,
                                                           t["yield_target"] or 0.0))
        for t in order:
            lo_t, hi_t = t["yield_ci95"]
            rows.append(("nominal (no spread)" if t["yield_target"] is None
                         else _pct(t["yield_target"]), t["scenarios"], t["compression_size"],
                         _pct(t["guaranteed_yield"], 2), _f(t["integral_gain"]),
                         f"{_pct(t['measured_yield'])} ({_pct(lo_t)} – {_pct(hi_t)}, n ="
                         f" {t['n']})", f"{t['design_wall_s']:.0f} s"))
        blocks += [("h2", "The price of yield"),
                   ("table", ("yield target", "N", "k", "guarantee", "integral gain",
                              "measured yield (95 % interval)", "design time"), rows),
                   ("img", "price_of_yield.png", "Integral gain of the design for each yield"
                    " target (left axis) and its yield measured on fresh actuators with its"
                    " 95 % interval (right axis); the nominal design at the left")]
        files.append("price_of_yield.png")
    blocks.append(("h2", "Controller"))
    c = d["controller"]
    blocks.append(("pre", "\n".join(f"{k}(s) = " + " ".join(f"{x:.6g}" for x in c[k])
                                    for k in "RST")))
    return Doc(title=f"robrst fleet design: {records['problem']}", blocks=tuple(blocks)), files


def _draw_tradeoff(records, path):
    pts = [t for t in records["tradeoff"] if t["yield_target"] is not None]
    nom = [t for t in records["tradeoff"] if t["yield_target"] is None]
    pts.sort(key=lambda t: t["yield_target"])
    with drawing(path, (6.5, 4.0)) as (fig, ax):
        x = [100 * t["yield_target"] for t in pts]
        ax.plot(x, [abs(t["integral_gain"]) for t in pts], "o-", color="C0",
                label="integral gain")
        ax.set_xlabel("yield target [%]")
        ax.set_ylabel("integral gain |ki| [V/(µm s)]", color="C0")
        ax2 = ax.twinx()
        y = [100 * t["measured_yield"] for t in pts]
        err = [[100 * (t["measured_yield"] - t["yield_ci95"][0]) for t in pts],
               [100 * (t["yield_ci95"][1] - t["measured_yield"]) for t in pts]]
        ax2.errorbar(x, y, yerr=err, fmt="s", color="C3", capsize=3, label="measured yield")
        ax2.plot(x, x, ":", color="C3", lw=1, label="target")
        if nom:
            x0 = min(x) - 5 if x else 50.0
            ax.plot([x0], [abs(nom[0]["integral_gain"])], "D", color="C0")
            ax2.plot([x0], [100 * nom[0]["measured_yield"]], "D", color="C3")
            ax.annotate("nominal", (x0, abs(nom[0]["integral_gain"])), textcoords="offset points",
                        xytext=(4, 4), fontsize=8)
        ax2.set_ylabel("measured yield [%]", color="C3")
        ax2.set_ylim(0, 102)
        ax.margins(y=0.1)
        ax2.legend(loc="center right", fontsize=8)


def write_fleet_report(records: dict, out_dir: str | os.PathLike, force: bool = False) -> Path:
    """Write ``OUT/report/`` (``report.md``, ``report.html``, figures) from ``records``.

    Parameters
    ----------
    records : dict
        As for :func:`fleet_doc`.
    out_dir : str or Path
        The run's folder; the report goes to its ``report`` folder.
    force : bool
        Write into a folder robrst did not write (its own files only).

    Returns
    -------
    Path
        The report folder.
    """
    doc, files = fleet_doc(records)

    def draw(tmp):
        if "price_of_yield.png" in files:
            _draw_tradeoff(records, Path(tmp) / "price_of_yield.png")

    return write_folder(Path(out_dir) / "report", doc, {}, draw, force=force)
