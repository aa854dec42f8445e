"""Plain-text views of a design's JSON dict, shared by the CLI and the reports."""

from __future__ import annotations

import math

__all__ = ["margins_table", "sampled_summary", "design_summary", "fleet_summary", "fmt"]


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


def design_summary(d: dict) -> str:
    """The text ``robrst design`` prints: controller, margins, certificate, checks.

    Parameters
    ----------
    d : dict
        The design JSON.

    Returns
    -------
    str
    """
    out = [f"problem {d['problem']}  method {d['method']}  certified: {d['certified']}"]
    c = d["controller"]
    for k in "RST":
        out.append(f"  {k}(s) = " + " ".join(f"{v:.6g}" for v in c[k]))
    out.append(margins_table(d))
    cert = d["certificate"]
    out.append(f"certificate: {len(cert['models'])} models checked (family + temperature sweep),"
               f" {len(cert['violations'])} violations")
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
