"""Plain-text views of a design's records, shared by the CLI and the reports.

Each view reads the :class:`~robrst.design.result.DesignResult` and its records (the
analyses, the certificate, the achieved specs, the factored controller, the solver's and the
multi-start's summaries, the fleet record) and formats them: nothing is computed here.
"""

from __future__ import annotations

import math
from itertools import zip_longest
from typing import TYPE_CHECKING

from robrst.design.achieved import BINDING_SLACK

if TYPE_CHECKING:
    from robrst.design.achieved import PolyFactors
    from robrst.design.result import DesignResult
    from robrst.synthesis.scenario import FleetDesign

__all__ = ["margins_table", "sampled_summary", "design_summary", "objective_line",
           "fleet_summary", "fmt", "spec_table", "spec_rows", "controller_lines"]


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


def margins_table(result: DesignResult) -> str:
    """Margins per model (label, temperature, stable, Ms, Mt, Mu, GM, PM, MM, DM).

    Parameters
    ----------
    result : DesignResult
        The design (its analyses).

    Returns
    -------
    str
        A fixed-width table, one line per model.
    """
    head = (f"{'model':<8}{'T[°C]':>7}{'stable':>8}{'Ms':>8}{'Mt':>8}{'Mu[V/µm]':>10}"
            f"{'GM':>8}{'PM[°]':>8}{'MM':>7}{'DM[µs]':>9}")
    lines = [head, "-" * len(head)]
    for a in result.analyses:
        m, pk = a.margins, a.peaks
        dm = None if m.delay_margin_s is None else m.delay_margin_s * 1e6
        lines.append(
            f"{a.label:<8}{a.temperature_C:>7.1f}{str(bool(a.stable)):>8}"
            f"{_cell(pk['S'].value, '.3f', 8)}{_cell(pk['T'].value, '.3f', 8)}"
            f"{_cell(pk['U'].value, '.2f', 10)}"
            f"{_cell(m.gain_margin, '.2f', 8)}{_cell(m.phase_margin_deg, '.1f', 8)}"
            f"{_cell(m.modulus_margin, '.3f', 7)}{_cell(dm, '.1f', 9)}"
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


def sampled_summary(result: DesignResult) -> str | None:
    """One line on the sampled loop's certificate (``None`` when not asked for).

    Parameters
    ----------
    result : DesignResult
        The design (its specs and certificate).

    Returns
    -------
    str or None
    """
    sp, cert = result.problem.specs, result.certificate
    if not sp.sampled or not cert.models or cert.models[0].sampled is None:
        return None
    worst = {k: cert.worst(k, "sampled") for k in ("Ms", "Mt", "Mu")}
    stable = all(m.sampled.stable for m in cert.models)
    return (f"sampled loop (ZOH plant, Tustin controller at {sp.sample_rate_hz:g} Hz,"
            f" {sp.delay_samples} samples delay): worst Ms {worst['Ms']:.4g},"
            f" Mt {worst['Mt']:.4g}, Mu {worst['Mu']:.4g} V/µm;"
            f" {'all stable' if stable else 'NOT all stable'}")


def _num(x, digits=4):
    """A number for a designer: ``.4g`` with thousands grouped when it is large."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "inf" if x is not None and x > 0 else ("-inf" if x is not None else "-")
    if abs(x) >= 1e4 and abs(x) < 1e12:
        return f"{x:,.0f}"
    return format(x, f".{digits}g")


def _poly_factors(f: PolyFactors, var="s"):
    """A polynomial's factored form: gain, ``s^k``, ``(s + a)`` and damped pairs."""
    parts = [] if f.gain == 1.0 else [_num(f.gain)]
    if f.integrators:
        parts.append(var if f.integrators == 1 else f"{var}^{f.integrators}")
    for r in f.real:
        parts.append(f"({var} {'+' if r <= 0 else '-'} {_num(abs(r))})")
    for wn, z in f.pairs:
        parts.append(f"({var}^2 {'+' if z >= 0 else '-'} 2*{abs(z):.3g}*{_num(wn)} {var}"
                     f" + {_num(wn)}^2)")
    return " ".join(parts) or "1"


def controller_lines(result: DesignResult) -> list[str]:
    """The controller as factored gain, roots and damped pairs, and its coefficients in the
    scaled variable (``result.controller_factored``).

    Parameters
    ----------
    result : DesignResult
        The design.

    Returns
    -------
    list of str
    """
    f = result.controller_factored
    out = ["controller (factored; pairs as s^2 + 2 zeta wn s + wn^2, wn in rad/s):"]
    for k in "RST":
        out.append(f"  {k}(s) = {_poly_factors(getattr(f, k))}")
    w0 = f.w0_rad_s
    out.append(f"  coefficients in x = s/{_num(w0)} (all divided by {_num(w0)}^deg S):")
    for k in "RST":
        out.append(f"    {k}: " + " ".join(f"{v:.6g}" for v in getattr(f, k).scaled))
    return out


def objective_line(result: DesignResult) -> str:
    """The summary's objective line: what was optimised, the certified value, and what the
    global phase found (its spread in the objective's own terms: ``min_Ms`` as worst Ms).

    Parameters
    ----------
    result : DesignResult
        The design.

    Returns
    -------
    str
    """
    obj = result.solver_summary.objective
    if obj is None:       # the analytic design: no objective optimised
        return ("objective: none (analytic pole placement); integral gain"
                f" {_num(result.integral_gain)}")
    if obj == "max_integral_gain":
        val = f"integral gain {_num(result.integral_gain)} V/(µm s)"
    elif obj == "min_Ms":
        ms = [r for r in result.specs_achieved if r.spec == "Ms_max"]
        val = (f"worst Ms {_num(ms[0].achieved)}" if ms else
               f"worst Ms {_num(result.certificate.worst('Ms'))}")
    else:
        val = "feasibility (no objective)"
    line = f"objective: {obj} -> {val}"
    st = result.starts_summary
    if st:
        what = (f"global phase: {st.evaluations} candidates screened ({st.search_method},"
                f" {st.dimension} dimensions), {st.starts} tried"
                if st.search_method else f"multi-start: {st.starts} starts")
        if st.certified:
            # the starts' objectives are larger-is-better: min_Ms's is minus the worst Ms
            lo, hi = ((-st.best, -st.worst) if obj == "min_Ms" else (st.worst, st.best))
            name = "worst Ms" if obj == "min_Ms" else "optima"
            line += (f"; {what}, {st.certified} certified, {name} {_num(lo)} .."
                     f" {_num(hi)}, best from '{st.winner}'")
        else:
            line += f"; {what}, none certified"
    return line


def spec_rows(result: DesignResult) -> list[tuple[str, str, str, str, str, str]]:
    """Each spec's cells: name, bound, achieved (worst over the certificate's models),
    slack, where, and the tag (``BINDS``, within the certificate's tolerance, ``NOT
    MET``) from ``result.specs_achieved``; the text's table and the report's draw them.

    Parameters
    ----------
    result : DesignResult
        The design.

    Returns
    -------
    list of tuple of str
    """
    tol = result.problem.solver.cert_tol
    out = []
    for r in result.specs_achieved or ():
        name = r.spec + (" (default)" if r.source == "default" else "")
        where = (r.model if r.temperature_C is None else
                 f"{r.model} ({r.temperature_C:g} °C"
                 + (", sampled" if r.loop == "sampled" else "") + ")")
        tag = "BINDS" if r.binding else ""
        if r.slack < 0:
            # the slack's excess (1 - value/bound, 1 - bound/value for a lower bound) is
            # what the certificate's relative tolerance measures; the text says how far
            # the value lies from the bound
            beyond = abs(r.achieved - r.bound) / abs(r.bound) if r.bound else float("inf")
            if -r.slack <= tol * (1 + 1e-9):
                tag = (tag + " " if tag else "") + (
                    f"(beyond the bound by {100 * beyond:.2g} %: within the certificate's"
                    f" tolerance, [solver] cert_tol = {tol:g})")
            else:
                side = "above" if r.achieved > r.bound else "below"
                tag = f"NOT MET ({side} the bound by {100 * beyond:.2g} %)"
        slack = f"{100 * r.slack:.1f}%" if abs(r.slack) >= 5e-4 else f"{100 * r.slack:.2f}%"
        out.append((name, _num(r.bound), _num(r.achieved), slack, where, tag))
    return out


def spec_table(result: DesignResult) -> list[str]:
    """Each spec: bound, achieved (worst over the certificate's models), slack, where, and
    whether it binds (:func:`spec_rows`).

    Parameters
    ----------
    result : DesignResult
        The design.

    Returns
    -------
    list of str
    """
    rows = spec_rows(result)
    if not rows:
        return ["specs: none bounded"]
    head = f"  {'spec':<24}{'bound':>11}{'achieved':>12}{'slack':>9}  where"
    out = ["specs (worst over every checked model and temperature; slack = room left):", head]
    for name, bound, achieved, slack, where, tag in rows:
        out.append(f"  {name:<24}{bound:>11}{achieved:>12}{slack:>9}  {where}"
                   + (f"  {tag}" if tag else ""))
    return out


def design_summary(result: DesignResult) -> str:
    """The text ``robrst design`` prints: what ran and why, the objective, every spec with
    its achieved value and slack, the binding constraints, notes and warnings, the
    controller factored, margins, certificate and checks.

    Parameters
    ----------
    result : DesignResult
        The design.

    Returns
    -------
    str
    """
    p, cert = result.problem, result.certificate
    head = f"problem {p.name}  method {result.method}  certified: {bool(result.certified)}"
    out = [head, f"method: {p.solver.method_reason}", objective_line(result)]
    out += spec_table(result)
    so = result.solver_summary
    if so.binding:
        out.append("binding constraints (the optimiser's multipliers): " + "; ".join(
            b + (f" (held in the program: the certificate leaves {100 * sl:.1f} % slack)"
                 if sl is not None and sl > BINDING_SLACK else "")
            for b, sl in zip_longest(so.binding, so.binding_slack)))
    if result.best_achievable:
        out.append(result.best_achievable)
    if result.feasibility is not None:
        out += result.feasibility.lines()
    if result.objective_bound is not None:
        out.append(result.objective_bound.describe())
    if result.tolerance is not None:
        out.append("tolerated by the design (each factor alone, measured, not proved): "
                   + "; ".join(f.line() for f in result.tolerance.factors))
    assessment = result.assessment
    for n in list(so.notes) + list(assessment.notes if assessment else ()):
        out.append(f"note: {n}")
    for w in assessment.warnings if assessment else ():
        out.append(f"WARNING: {w}")
    if result.tolerance is not None and result.tolerance.warning:
        out.append(f"WARNING: {result.tolerance.warning}")
    out += controller_lines(result)
    out.append(margins_table(result))
    out.append(f"certificate: {len(cert.models)} models checked (family + temperature sweep),"
               f" {len(cert.violations)} violations")
    region = cert.interval.pole_region
    if region is not None:
        out.append(f"pole region: {region.statement}")
    line = sampled_summary(result)
    if line:
        out.append(line)
    if result.analytic_check is not None:
        ac = result.analytic_check
        out.append(f"analytic check: max rel. coefficient error {ac.max_rel_coef_error:.2e}"
                   f" -> {'passed' if ac.passed else 'FAILED'}")
    if result.comparison is not None:
        out.append(result.comparison.table)
    if result.fleet is not None:
        out.append(fleet_summary(result.fleet))
    return "\n".join(out)


def fleet_summary(f: FleetDesign) -> str:
    """The lines on a fleet design (``robrst design`` of a problem with a ``[spread]``).

    Parameters
    ----------
    f : FleetDesign
        The fleet record of the design.

    Returns
    -------
    str
    """
    head = (f"fleet design ({f.method}): {f.n_scenarios} drawn actuators, seed {f.seed},"
            f" {len(f.violated)} violated; {f.rounds} exchange rounds, compression set"
            f" {len(f.compression)} (in the program {len(f.support)}, discarded"
            f" {len(f.discarded)})")
    lines = [head]
    if f.guaranteed_yield is not None:
        lines.append(f"guaranteed yield {100 * f.guaranteed_yield:.2f} % at confidence"
                     f" {100 * f.confidence:g} % (target {100 * f.yield_target:g} %:"
                     f" {'met' if f.target_met else 'NOT met'}); {f.bound_statement}")
    if f.scenarios_for_target is not None:
        k = len(f.compression)
        lines.append(f"the target needs N = {f.scenarios_for_target} drawn actuators for a"
                     f" compression set of k = {k} ([spread] scenarios ="
                     f" {f.scenarios_for_target}; with more actuators the exchange may need"
                     " more of them in the program), or a target of at most"
                     f" {100 * f.guaranteed_yield:.2f} %")
    if f.integral_gain_ratio is not None:
        lines.append(f"integral gain {f.integral_gain:.5g}, {f.integral_gain_ratio:.3f}"
                     f" x the nominal design's {f.nominal_integral_gain:.5g}")
    return "\n".join(lines)
