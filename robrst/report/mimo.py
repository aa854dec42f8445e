"""Plain-text view of a multi-axis design's JSON dict (the CLI's summary, the benchmark)."""

from __future__ import annotations

import math

from robrst.report.text import fmt

__all__ = ["mimo_summary", "mimo_members_table", "comparison_lines"]


def _pk(lp: dict, key: str) -> str:
    v = lp.get(key)
    return "—" if v is None else fmt(v["value"], ".4g")


def mimo_members_table(cert: dict, axes: list[str]) -> str:
    """One row per family member and loop: stability, sigma peaks, crosstalk, bandwidths.

    Parameters
    ----------
    cert : dict
        A multi-axis certificate (``MimoCertificate.as_dict()``).
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
    for m in cert["models"]:
        if not m["member"]:
            continue
        for loop in ("continuous", "sampled"):
            lp = m.get(loop)
            if lp is None:
                continue
            axis_s = lp.get("axis_S")
            xs = "—" if not axis_s else fmt(max(p["value"] for p in axis_s), ".4g")
            xt = lp.get("crosstalk")
            bw = lp.get("bandwidth_hz")
            rows.append(f"| {m['label']} | {loop} | {'yes' if lp['stable'] else '**no**'} |"
                        f" {_pk(lp, 'sigma_S')} | {_pk(lp, 'sigma_T')} | {_pk(lp, 'sigma_U')} |"
                        f" {xs} | {'—' if xt is None else fmt(xt['value'], '.3g')} |"
                        f" {'—' if not bw else ', '.join('—' if b is None else f'{b:.4g}' for b in bw)} |")
    return "\n".join(rows)


def comparison_lines(d: dict) -> list[str]:
    """One line per comparison design: certified, worst ratios or why not.

    Parameters
    ----------
    d : dict
        The design's JSON dict.

    Returns
    -------
    list of str
    """
    out = []
    for name, c in d.get("comparisons", {}).items():
        if c["certified"]:
            what = "certified"
        else:
            unstable = [v for v in c["violations"] if v["kind"] == "unstable"]
            worst = [f"{k} {fmt(v, '.3g')}x" for k, v in sorted(c["ratios"].items(),
                                                               key=lambda kv: -kv[1])[:2]]
            what = "NOT certified: " + ("closed loop unstable on "
                                        + ", ".join(sorted({v["label"] for v in unstable}))
                                        if unstable else "worst ratios " + ", ".join(worst))
        out.append(f"{name} ({c['note']}): {what}")
    return out


def mimo_summary(d: dict) -> str:
    """The text summary of a multi-axis design.

    Parameters
    ----------
    d : dict
        ``MimoDesignResult.as_dict()``.

    Returns
    -------
    str
    """
    cert = d["certificate"]
    vals = [v for v in d["values"] if v is not None]
    rng = f" over {d['parameter']} {min(vals):g}-{max(vals):g} {d['unit']}" if len(vals) > 1 \
        else ""
    fs = d["specs"].get("sample_rate_hz")
    lines = [f"{d['problem']}: {len(d['axes'])} axes, {len(d['models'])} model(s){rng}"
             + (f", sampled at {fs:g} Hz" if fs else "")
             + f" — certified: {'yes' if d['certified'] else 'NO'}",
             "specs: " + ", ".join(f"{k} = {v}" for k, v in d["specs"].items()),
             f"decoupler: {d['controller']['decoupler']['kind']}; integral gains"
             f" [V/(µm s)] " + ", ".join(fmt(g, ".4g") for g in d["integral_gains"]),
             "", mimo_members_table(cert, d["axes"]), ""]
    b = d.get("binding") or {}
    if b:
        r = b.get("ratio")
        lines.append(f"binding: {b.get('figure')} at {fmt(r, '.4g') if r is not None and math.isfinite(r) else 'inf'}"
                     f" of its bound ({b.get('model')}, {b.get('loop')} loop)")
    iv = cert.get("interval", {})
    if iv.get("statement"):
        lines.append(f"between the models: {iv['statement']}")
    for v in cert["violations"][:8]:
        lines.append(f"violation: {v['quantity']} = {fmt(v['value'], '.4g')} (bound"
                     f" {fmt(v['bound'], '.4g')}) on {v['label']} [{v['kind']}, {v['loop']}]")
    lines += [""] + comparison_lines(d)
    lines.append(f"{d['seconds']:.1f} s")
    return "\n".join(lines)
