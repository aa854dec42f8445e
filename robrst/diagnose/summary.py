"""Short human-readable summary of a :class:`~robrst.diagnose.result.Diagnosis`."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from robrst.core.plant import paper_plant

if TYPE_CHECKING:
    from robrst.diagnose.result import Diagnosis

__all__ = ["summary_text"]


def _pm(v, s):
    if s is None or not math.isfinite(s):
        return f"{v:.4g} (not determined by the data)"
    return f"{v:.4g} ± {s:.2g}"


def _g(v, fmt):
    return "n/a" if v is None else format(v, fmt)


def _num(v):
    """A figure as the JSON holds it (a non-finite one is ``None``)."""
    return v if v is not None and math.isfinite(v) else None


def _model_line(model) -> str:
    """Which model the gap is measured against: its label, order and poles (the paper's
    D(s) is said to be the default of ``robrst diagnose`` without ``--model``)."""
    hz = sorted(set(round(p, 9) for p in model.poles_hz))
    poles = ", ".join(f"{f:.4g}" for f in hz[:8]) + " Hz" + (
        f" and {len(hz) - 8} more" if len(hz) > 8 else "")
    line = (f"model under diagnosis: {model.label} (order {model.order}, poles at {poles},"
            f" {model.reference_C:g} °C)")
    if model.label == paper_plant().label:
        line += ": the paper's D(s), eq. (4), what robrst diagnose uses without --model"
    return line


def summary_text(diag: Diagnosis) -> str:
    """A dozen lines: gap, verdict, findings, candidates, the selected effects, where.

    Parameters
    ----------
    diag : Diagnosis
        The diagnosis.

    Returns
    -------
    str
        What ``robrst diagnose`` prints.
    """
    out = [f"gap of the simulation model (held-out NRMSE): {_g(_num(diag.gap_before), '.4g')}"
           f"   noise floor {_g(_num(diag.noise_floor), '.3g')}"
           f" ({(diag.noise_floor_method or 'n/a').replace('_', ' ')})"
           f"   training records {_g(_num(diag.gap_train), '.4g')}",
           _model_line(diag.model),
           f"cause: {diag.cause} — {diag.reason}"]
    for f in diag.findings:
        out.append(f"finding {f.kind}: {f.message}")
    if diag.skipped:
        out.append("not tried: " + "; ".join(f"{k} ({v})" for k, v in diag.skipped.items()))
    if diag.effects:
        out.append(f"  {'candidate (alone)':<30}{'gap before':>11}{'gap after':>11}{'shrink':>9}")
        rows = [(e.name, e) for e in diag.effects]
        if diag.linear_refit:
            rows.append(("(linear re-fit)", replace(diag.linear_refit, form="input")))
        if diag.output_offset:
            rows.append(("(output offset)", replace(diag.output_offset, form="output")))
        for name, e in rows:
            name += {"prandtl_ishlinskii": " (PI)"}.get(e.form, "")
            flag = "  overfit" if e.overfit else ""
            how = "  (screen)" if e.method == "screen" else ""
            out.append(f"  {name:<30}{e.gap_before:>11.4g}{e.gap_after:>11.4g}"
                       f"{100 * e.shrink:>8.1f}%{flag}{how}")
    for s in diag.selected:
        ps = ", ".join(f"{k} = {_pm(v, s.params_std.get(k))}" for k, v in list(
            s.params.items())[:6])
        without = f"; without it {s.gap_without:.4g}" if _num(s.gap_without) is not None else ""
        out.append(f"selected {s.name} ({s.form}): gap {s.gap_before:.4g} ->"
                   f" {s.gap_after:.4g}{without}; {ps}")
        sec = s.input_gain_sector
        if sec and math.isfinite(sec.delta):
            lo, hi = sec.range_V
            out.append(f"  as an input-gain sector over {lo:.4g}-{hi:.4g} V: slopes"
                       f" {sec.slopes[0]:.4g}-{sec.slopes[1]:.4g}, delta"
                       f" {sec.delta:.3g} around {sec.nominal:.4g} (a multi-axis"
                       f" problem's input_gain_deviation, its model's gain times the centre)")
    for t in diag.ties:
        after = f" after {' + '.join(t.after)}" if t.after else ""
        out.append(f"tie in slot {t.slot}{after}: {t.message}")
    for n in diag.not_causes:
        out.append(f"not a cause: {n.name} (the joint fit without it leaves"
                   f" {n.gap_without:.4g}, with it {n.gap_with:.4g})")
    for a in diag.alternatives:
        out.append(f"alternative to {a.effect}: {a.alternative} (held-out gap"
                   f" {a.gap_alternative:.4g})")
    fin = diag.final
    if fin:
        out.append(f"final model ({' + '.join(fin.effects)} + linear corrections): held-out gap"
                   f" {fin.gap_after:.4g}; the linear part moved by at most"
                   f" {100 * fin.linear_moved:.1f} % (log ratio / relative gain)")
    b = diag.best_partial
    if b:
        out.append(f"best partial explanation: {' + '.join(b.effects)} (held-out gap"
                   f" {b.gap_after:.4g}, {100 * b.shrink:.0f} %)")
    w = diag.where
    tw = w.time_windows
    if tw:
        first = ", ".join(f"{x.file} {x.start_s:.3g}–{x.end_s:.3g} s" for x in tw[:3])
        out.append(f"where (time): {len(tw)} window(s) above 3x noise, holding"
                   f" {100 * w.energy_fraction:.0f} % of the residual energy: {first}")
    else:
        out.append("where (time): no window rises above 3x the noise")
    band = w.frequency_band_hz
    out.append("where (frequency): " + (f"{band[0]:.3g}–{band[1]:.3g} Hz" if band
                                        else "residual spectrum at the noise floor"))
    reg = w.regime
    if reg.dominant:
        out.append(f"where (regime): {reg.dominant} explains"
                   f" {100 * reg.shares[reg.dominant]:.0f} % of the residual variance")
    t = diag.tests
    out.append(f"residual tests: whiteness {'passed' if t.whiteness.passed else 'failed'},"
               f" input cross-correlation {'passed' if t.cross_correlation.passed else 'failed'}")
    return "\n".join(out)
