"""Plain-text views of a design's JSON dict, shared by the CLI and the reports."""

from __future__ import annotations

import math

__all__ = ["margins_table", "sampled_summary", "design_summary", "fleet_summary", "fmt",
           "spec_table", "controller_lines"]


def fmt(x: float | None, spec: str) -> str:
    """``format(x, spec)``; ``"inf"`` for ``None`` (an infinite margin) or a non-finite value.

    Parameters
    ----------
    x : float or None
        The value.
    spec : str
        A format spec (``".3f"``).

    Returns
    -------
    str

    Examples
    --------
    >>> from robrst.report.text import fmt
    >>> fmt(1.23456, ".2f"), fmt(None, ".2f")
    ('1.23', 'inf')
    """
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "inf"
    return format(x, spec)


def margins_table(d: dict) -> str:
    """Margins per model (label, temperature, stable, Ms, Mt, Mu, GM, PM, MM, DM).

    Parameters
    ----------
    d : dict
        The design JSON (``DesignResult.as_dict()``).

    Returns
    -------
    str
        A fixed-width table, one line per model.
    """
    head = (f"{'model':<8}{'T[°C]':>7}{'stable':>8}{'Ms':>8}{'Mt':>8}{'Mu[V/µm]':>10}"
            f"{'GM':>8}{'PM[°]':>8}{'MM':>7}{'DM[µs]':>9}")
    lines = [head, "-" * len(head)]
    for m in d["models"]:
        dm = None if m["delay_margin_s"] is None else m["delay_margin_s"] * 1e6
        lines.append(
            f"{m['label']:<8}{m['temperature_C']:>7.1f}{str(m['stable']):>8}"
            f"{_cell(m['Ms'], '.3f', 8)}{_cell(m['Mt'], '.3f', 8)}{_cell(m['Mu'], '.2f', 10)}"
            f"{_cell(m['gain_margin'], '.2f', 8)}{_cell(m['phase_margin_deg'], '.1f', 8)}"
            f"{_cell(m['modulus_margin'], '.3f', 7)}{_cell(dm, '.1f', 9)}"
        )
    return "\n".join(lines)


def _cell(x, spec, width):
    """``x`` right-aligned in ``width`` with a space before it (fewer digits if too wide)."""
    s = fmt(x, spec)
    for digits in (3, 2, 1):
        if len(s) < width:
            break
        s = fmt(x, f".{digits}g")
    return f"{s:>{width}}"


def sampled_summary(d: dict) -> str | None:
    """One line on the sampled loop's certificate (``None`` when not asked for).

    Parameters
    ----------
    d : dict
        The design JSON.

    Returns
    -------
    str or None
    """
    sp, models = d["specs"], d["certificate"]["models"]
    if not sp.get("sample_rate_hz") or not models or "Ms_sampled" not in models[0]:
        return None
    worst = {k: max(m[f"{k}_sampled"] for m in models) for k in ("Ms", "Mt", "Mu")}
    stable = all(m["stable_sampled"] for m in models)
    return (f"sampled loop (ZOH plant, Tustin controller at {sp['sample_rate_hz']:g} Hz,"
            f" {sp.get('delay_samples', 0)} samples delay): worst Ms {worst['Ms']:.4g},"
            f" Mt {worst['Mt']:.4g}, Mu {worst['Mu']:.4g} V/µm;"
            f" {'all stable' if stable else 'NOT all stable'}")


def _num(x, digits=4):
    """A number for a designer: ``.4g`` with thousands grouped when it is large."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "inf" if x is not None and x > 0 else ("-inf" if x is not None else "-")
    if abs(x) >= 1e4 and abs(x) < 1e12:
        return f"{x:,.0f}"
    return format(x, f".{digits}g")


def _poly_factors(f, var="s"):
    """A polynomial's factored form: gain, ``s^k``, ``(s + a)`` and damped pairs."""
    parts = [] if f["gain"] == 1.0 else [_num(f["gain"])]
    if f["integrators"]:
        parts.append(var if f["integrators"] == 1 else f"{var}^{f['integrators']}")
    for r in f["real"]:
        parts.append(f"({var} {'+' if r <= 0 else '-'} {_num(abs(r))})")
    for wn, z in f["pairs"]:
        parts.append(f"({var}^2 {'+' if z >= 0 else '-'} 2*{abs(z):.3g}*{_num(wn)} {var}"
                     f" + {_num(wn)}^2)")
    return " ".join(parts) or "1"


def controller_lines(d: dict) -> list[str]:
    """The controller as factored gain, roots and damped pairs, and its coefficients in the
    scaled variable (``d["controller_factored"]``).

    Parameters
    ----------
    d : dict
        The design JSON.

    Returns
    -------
    list of str
    """
    f = d.get("controller_factored")
    c = d["controller"]
    if f is None:
        return [f"  {k}(s) = " + " ".join(f"{v:.6g}" for v in c[k]) for k in "RST"]
    out = ["controller (factored; pairs as s^2 + 2 zeta wn s + wn^2, wn in rad/s):"]
    for k in "RST":
        out.append(f"  {k}(s) = {_poly_factors(f[k])}")
    w0 = f["w0_rad_s"]
    out.append(f"  coefficients in x = s/{_num(w0)} (all divided by {_num(w0)}^deg S):")
    for k in "RST":
        out.append(f"    {k}: " + " ".join(f"{v:.6g}" for v in f[k]["scaled"]))
    return out


def _objective_line(d):
    so = d.get("solver", {})
    obj = so.get("objective")
    if obj is None:       # the analytic design: no objective optimised
        return f"objective: none (analytic pole placement); integral gain {_num(d['integral_gain'])}"
    if obj == "max_integral_gain":
        val = f"integral gain {_num(d['integral_gain'])} V/(µm s)"
    elif obj == "min_Ms":
        ms = [r for r in d.get("specs_achieved", []) if r["spec"] == "Ms_max"]
        val = (f"worst Ms {_num(ms[0]['achieved'])}" if ms else
               f"worst Ms {_num(max(m['Ms'] for m in d['certificate']['models']))}")
    else:
        val = "feasibility (no objective)"
    line = f"objective: {obj} -> {val}"
    st = d.get("starts")
    if st:
        sp = st["spread"]
        if sp.get("certified"):
            line += (f"; multi-start: {len(st['starts'])} starts, {sp['certified']} certified,"
                     f" optima {_num(sp['worst'])} .. {_num(sp['best'])}, best from"
                     f" '{st['winner']}'")
        else:
            line += f"; multi-start: {len(st['starts'])} starts, none certified"
    return line


def spec_table(d: dict) -> list[str]:
    """Each spec: bound, achieved (worst over the certificate's models), slack, where, and
    whether it binds (``d["specs_achieved"]``).

    Parameters
    ----------
    d : dict
        The design JSON.

    Returns
    -------
    list of str
    """
    rows = d.get("specs_achieved") or []
    if not rows:
        return ["specs: none bounded"]
    head = f"  {'spec':<24}{'bound':>11}{'achieved':>12}{'slack':>9}  where"
    out = ["specs (worst over every checked model and temperature; slack = room left):", head]
    for r in rows:
        name = r["spec"] + (" (default)" if r.get("source") == "default" else "")
        where = (r["model"] if r["temperature_C"] is None else
                 f"{r['model']} ({r['temperature_C']:g} °C"
                 + (", sampled" if r.get("loop") == "sampled" else "") + ")")
        out.append(f"  {name:<24}{_num(r['bound']):>11}{_num(r['achieved']):>12}"
                   f"{100 * r['slack']:>8.1f}%  {where}" + ("  BINDS" if r["binding"] else ""))
    return out


def design_summary(d: dict) -> str:
    """The text ``robrst design`` prints: what ran and why, the objective, every spec with
    its achieved value and slack, the binding constraints, notes and warnings, the
    controller factored, margins, certificate and checks.

    Parameters
    ----------
    d : dict
        The design JSON.

    Returns
    -------
    str
    """
    head = f"problem {d['problem']}  method {d['method']}  certified: {d['certified']}"
    out = [head]
    if d.get("method_reason"):
        out.append(f"method: {d['method_reason']}")
    out.append(_objective_line(d))
    out += spec_table(d)
    so = d.get("solver", {})
    if so.get("binding"):
        out.append("binding constraints (the optimiser's multipliers): "
                   + "; ".join(so["binding"]))
    if d.get("best_achievable"):
        out.append(d["best_achievable"])
    if d.get("feasibility"):
        out += d["feasibility"]["lines"]
    if d.get("objective_bound"):
        out.append(d["objective_bound"]["line"])
    notes = list(so.get("notes") or []) + list((d.get("assessment") or {}).get("notes") or [])
    for n in notes:
        out.append(f"note: {n}")
    for w in (d.get("assessment") or {}).get("warnings") or []:
        out.append(f"WARNING: {w}")
    out += controller_lines(d)
    out.append(margins_table(d))
    cert = d["certificate"]
    out.append(f"certificate: {len(cert['models'])} models checked (family + temperature sweep),"
               f" {len(cert['violations'])} violations")
    region = cert.get("interval", {}).get("pole_region")
    if region:
        out.append(f"pole region: {region['statement']}")
    line = sampled_summary(d)
    if line:
        out.append(line)
    if "analytic_check" in d:
        ac = d["analytic_check"]
        out.append(f"analytic check: max rel. coefficient error {ac['max_rel_coef_error']:.2e}"
                   f" -> {'passed' if ac['passed'] else 'FAILED'}")
    if d.get("comparison"):
        out.append(d["comparison"]["table"])
    if d.get("fleet"):
        out.append(fleet_summary(d["fleet"]))
    return "\n".join(out)


def fleet_summary(f: dict) -> str:
    """The lines on a fleet design (``robrst design`` of a problem with a ``[spread]``).

    Parameters
    ----------
    f : dict
        The ``fleet`` object of the design's JSON.

    Returns
    -------
    str
    """
    head = (f"fleet design ({f['method']}): {f['scenarios']} drawn actuators, seed {f['seed']},"
            f" {len(f['violated'])} violated; {f['rounds']} exchange rounds, compression set"
            f" {f['compression_size']} (in the program {len(f['support'])}, discarded"
            f" {len(f['discarded'])})")
    lines = [head]
    if f["guaranteed_yield"] is not None:
        lines.append(f"guaranteed yield {100 * f['guaranteed_yield']:.2f} % at confidence"
                     f" {100 * f['confidence']:g} % (target {100 * f['yield_target']:g} %:"
                     f" {'met' if f['target_met'] else 'NOT met'}); {f['bound']}")
    if f["integral_gain_ratio"] is not None:
        lines.append(f"integral gain {f['integral_gain']:.5g}, {f['integral_gain_ratio']:.3f}"
                     f" x the nominal design's {f['nominal_integral_gain']:.5g}")
    return "\n".join(lines)
