"""Figures of a design report: Bode of S, T, U; Nyquist with the modulus circle; steps.

Every function takes a :class:`~robrst.design.DesignResult`, the curves computed for it
(:func:`robrst.studies.design_curves.design_curves`) and a file path, and writes one PNG
(:func:`robrst.report._figure.drawing`: no global matplotlib state).  The figures draw
what the records carry: nothing is computed here.  Frequencies are in Hz on log axes,
magnitudes in dB, time in ms, displacement in µm.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.report._figure import colors as _colors
from robrst.report._figure import drawing
from robrst.problem.specs import PEAK_SPECS, spec

if TYPE_CHECKING:
    from pathlib import Path

    from robrst.design import DesignResult
    from robrst.studies.design_curves import DesignCurves

__all__ = ["bode_figure", "nyquist_figure", "step_figure"]


def _db(x):
    return 20 * np.log10(np.maximum(np.abs(x), 1e-300))


def bode_figure(result: DesignResult, curves: DesignCurves, path: str | Path) -> None:
    """``|S|, |T|, |U|`` for every family temperature, spec bounds dashed, peaks marked.

    Parameters
    ----------
    result : DesignResult
        The design (its analyses' peaks and the specs are drawn).
    curves : DesignCurves
        The frequency responses (:func:`robrst.studies.design_curves.design_curves`).
    path : str or pathlib.Path
        The PNG file.
    """
    with drawing(path, (8, 9), 3, 1, sharex=True) as (fig, axes):
        _bode(result, curves, axes)


def _bode(result, curves, axes):
    specs = result.problem.specs
    cols = _colors(len(curves.models))
    for (name, key), ax in zip(PEAK_SPECS.items(), axes):     # robrst.problem.specs
        unit = spec(key).unit or "-"
        for mc, a, c in zip(curves.models, result.analyses, cols):
            ax.semilogx(curves.freq_hz, _db(getattr(mc, name)), color=c, lw=1.2,
                        label=f"{mc.temperature_C:g} °C")
            pk = a.peaks[name]
            if pk.freq_rad_s is not None and np.isfinite(pk.freq_rad_s):
                ax.plot(pk.freq_rad_s / (2 * np.pi), _db(pk.value), "x", color=c, ms=8)
        bound = getattr(specs, key)
        if bound is not None:
            ax.axhline(_db(bound), color="k", ls="--", lw=1, label=f"bound {key} = {bound:g}")
        ax.set_ylabel(f"|{name}| [dB{'' if unit == '-' else ' re 1 ' + unit}]")
        ax.set_title(f"|{name}(j2πf)| per temperature (× = certified peak)")
    axes[0].legend(fontsize=8, ncol=3, loc="lower right")
    axes[2].legend(fontsize=8, loc="lower left")
    axes[-1].set_xlabel("frequency f [Hz] (log)")


def nyquist_figure(result: DesignResult, curves: DesignCurves, path: str | Path) -> None:
    """Loop L = BR/(AS) per temperature around -1 with the modulus-margin circles.

    Parameters
    ----------
    result : DesignResult
        The design.
    curves : DesignCurves
        The loops (:func:`robrst.studies.design_curves.design_curves`).
    path : str or pathlib.Path
        The PNG file.
    """
    with drawing(path, (7, 6.5)) as (fig, ax):
        _nyquist(result, curves, ax)


def _nyquist(result, curves, ax):
    for mc, c in zip(curves.models, _colors(len(curves.models))):
        L = np.where(np.abs(mc.L) < 20, mc.L, np.nan)
        ax.plot(L.real, L.imag, color=c, lw=1.2, label=f"{mc.temperature_C:g} °C")
        ax.plot(L.real, -L.imag, color=c, lw=0.6, ls=":")
    th = np.linspace(0, 2 * np.pi, 400)
    ms_max = result.problem.specs.Ms_max
    if ms_max:
        r = 1 / ms_max
        ax.plot(-1 + r * np.cos(th), r * np.sin(th), "k--", lw=1,
                label=f"spec: modulus margin {r:.2g}")
    worst = max(a.peaks["S"].value for a in result.analyses)
    r = 1 / worst
    ax.plot(-1 + r * np.cos(th), r * np.sin(th), "g-", lw=1,
            label=f"achieved: modulus margin {r:.2g}")
    ax.plot([-1], [0], "r+", ms=12, mew=2)
    ax.set_xlim(-3, 2)
    ax.set_ylim(-2.5, 2.5)
    ax.set_aspect("equal")
    ax.set_xlabel("Re L(jω) [-]")
    ax.set_ylabel("Im L(jω) [-]")
    ax.set_title("Nyquist plot of the loop (solid ω > 0, dotted ω < 0)")
    ax.legend(fontsize=8, loc="lower left")


def step_figure(result: DesignResult, curves: DesignCurves, path: str | Path) -> None:
    """Reference and input-disturbance steps at the extreme temperatures, with the
    digital twin's reference steps (``curves.twin``: sampled controller, every effect
    on) drawn on the reference panel.

    Parameters
    ----------
    result : DesignResult
        The design.
    curves : DesignCurves
        The step responses (:func:`robrst.studies.design_curves.design_curves`).
    path : str or pathlib.Path
        The PNG file.
    """
    with drawing(path, (11, 4.2), 1, 2) as (fig, (a1, a2)):
        _steps(curves, a1, a2)


def _steps(curves, a1, a2):
    for sc, c in zip(curves.steps, ("tab:blue", "tab:red")):
        a1.plot(sc.t_s * 1e3, sc.reference_um, color=c,
                label=f"linear, {sc.temperature_C:g} °C")
        a2.plot(sc.t_s * 1e3, sc.disturbance_um, color=c,
                label=f"linear, {sc.temperature_C:g} °C")
    for (label, (tt, yy)), c in zip(curves.twin.items(), ("tab:cyan", "tab:orange")):
        a1.plot(tt * 1e3, yy, color=c, lw=1, ls="--", label=label)
    a1.set_title("reference step 1 µm")
    a1.set_ylabel("displacement y [µm]")
    a2.set_title("input-disturbance step 1 V")
    a2.set_ylabel("displacement y [µm]")
    for a in (a1, a2):
        a.set_xlabel("time t [ms]")
        a.legend(fontsize=8)
