"""Plain-text view of a multi-axis design (the CLI's summary, the benchmark), drawn from its
records (:class:`~robrst.design.mimo.MimoDesignResult`, its certificate); nothing is
computed here."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from robrst.design.achieved import BINDING_SLACK
from robrst.design.mimo import COMPARISON_VIOLATIONS
from robrst.report.text import fmt

if TYPE_CHECKING:
    from robrst.certificate.mimo import MimoCertificate, MimoLoopFigures
    from robrst.design.mimo import MimoDesignResult

__all__ = ["mimo_summary", "mimo_members_table", "comparison_lines"]

SHOWN_VIOLATIONS = 8         # the summary's violation lines; the JSON keeps them all


def _pk(lp: MimoLoopFigures, key: str) -> str:
    p = lp.peaks.get(key)
    return "—" if p is None else fmt(p.value, ".4g")


def mimo_members_table(cert: MimoCertificate, axes: list[str]) -> str:
    """One row per family member and loop: stability, sigma peaks, crosstalk, bandwidths.

    Parameters
    ----------
    cert : MimoCertificate
        A multi-axis certificate.
    axes : list of str
        The axes' names.

    Returns
    -------
    str
        A Markdown table.
    """
    rows = ["| model | loop | stable | σ̄(S) | σ̄(T) | σ̄(U) [V/µm] | max \\|S_ii\\| |"
            " crosstalk | bandwidth [Hz] (" + ", ".join(axes) + ") |",
            "|---|---|---|---|---|---|---|---|---|"]
    for m in cert.models:
        if not m.member:
            continue
        for loop in ("continuous", "sampled"):
            lp = m.loop(loop)
            if lp is None:
                continue
            axis_s = lp.axis.get("S")
            xs = "—" if not axis_s else fmt(max(p.value for p in axis_s), ".4g")
            xt = lp.crosstalk
            bw = lp.bandwidth_hz
            rows.append(f"| {m.label} | {loop} | {'yes' if lp.stable else '**no**'} |"
                        f" {_pk(lp, 'sigma_S')} | {_pk(lp, 'sigma_T')} | {_pk(lp, 'sigma_U')} |"
                        f" {xs} | {'—' if xt is None else fmt(xt[0].value, '.3g')} |"
                        f" {'—' if not bw else ', '.join('—' if b is None else f'{b:.4g}' for b in bw)} |")
    return "\n".join(rows)


def comparison_lines(result: MimoDesignResult) -> list[str]:
    """One line per comparison design: certified, worst ratios or why not.

    Parameters
    ----------
    result : MimoDesignResult
        The design.

    Returns
    -------
    list of str
    """
    out = []
    for name, c in result.comparisons.items():
        cert = c.certificate
        if cert.certified:
            what = "certified"
        else:
            unstable = [v for v in cert.violations[:COMPARISON_VIOLATIONS] if v.kind == "unstable"]
            worst = [f"{k} {fmt(v, '.3g')}x" for k, v in sorted(cert.ratios().items(),
                                                               key=lambda kv: -kv[1])[:2]]
            what = "NOT certified: " + ("closed loop unstable on "
                                        + ", ".join(sorted({v.label for v in unstable}))
                                        if unstable else "worst ratios " + ", ".join(worst))
        out.append(f"{name} ({c.note}): {what}")
    return out


def mimo_summary(result: MimoDesignResult) -> str:
    """The text summary of a multi-axis design.

    Parameters
    ----------
    result : MimoDesignResult
        The design.

    Returns
    -------
    str
    """
    p, cert = result.problem, result.certificate
    fam = p.family
    vals = [m.value for m in fam.models if m.value is not None]
    rng = f" over {fam.parameter} {min(vals):g}-{max(vals):g} {fam.unit}" if len(vals) > 1 \
        else ""
    specs = p.specs.as_dict()       # the listing below, as the JSON states the specs
    fs = p.specs.sample_rate_hz
    lines = [f"{p.name}: {len(p.axes)} axes, {len(fam.models)} model(s){rng}"
             + (f", sampled at {fs:g} Hz" if fs else "")
             + f" — certified: {'yes' if result.certified else 'NO'}",
             "specs: " + ", ".join(f"{k} = {v}" for k, v in specs.items()),
             f"decoupler: {result.controller.decoupler_kind}; integral gains"
             f" [V/(µm s)] " + ", ".join(fmt(g, ".4g") for g in result.integral_gains()),
             "", mimo_members_table(cert, list(p.axes)), ""]
    sectors = [f for f in ("sector_S", "sector_T", "sector_U") if f in cert.bounds]
    if sectors:
        parts = []
        for f in sectors:
            worst = [(loop, cert.worst(f, loop)) for loop in ("continuous", "sampled")]
            parts.append(f"{f} " + ", ".join(f"{fmt(w, '.4g')} {loop}" for loop, w in worst
                                             if w is not None)
                         + f" (bound {fmt(cert.bounds[f], '.4g')})")
        lines.append(f"input gains within ±{p.specs.input_gain_deviation:g} of nominal"
                     " (a sector), worst over the family: " + "; ".join(parts))
    b = result.binding
    if b is not None:
        r = b.ratio
        at = (f"{b.figure} at {fmt(r, '.4g') if r is not None and math.isfinite(r) else 'inf'}"
              f" of its bound ({b.model}, {b.loop} loop)")
        if r is not None and r < 1.0 - BINDING_SLACK:
            # the figure nearest its bound, with room left: no bound limits the design
            lines.append(f"nearest its bound: {at}; no bound binds ({fmt(100 * (1 - r), '.3g')}"
                         " % slack)")
        else:
            lines.append(f"binding: {at}")
    if cert.interval.statement:
        lines.append(f"between the models: {cert.interval.statement}")
    for v in cert.violations[:SHOWN_VIOLATIONS]:
        lines.append(f"violation: {v.quantity} = {fmt(v.value, '.4g')} (bound"
                     f" {fmt(v.bound, '.4g')}) on {v.label} [{v.kind}, {v.loop}]")
    lines += [""] + comparison_lines(result)
    lines += [f"note: {n}" for n in result.notes]
    lines.append(f"{result.seconds:.1f} s")
    return "\n".join(lines)
