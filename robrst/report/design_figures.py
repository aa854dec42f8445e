"""Figures of a design report: Bode of S, T, U; Nyquist with the modulus circle; steps.

Every function takes a :class:`~robrst.design.DesignResult` and a file path and
writes one PNG (:func:`robrst.report.figure.drawing`: no global matplotlib state).
Frequencies are in Hz on log axes, magnitudes in dB, time in ms, displacement in µm.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core.analysis import sensitivity, step_response
from robrst.report.figure import colors as _colors
from robrst.report.figure import drawing
from robrst.core.rst import closed_loop

if TYPE_CHECKING:
    from pathlib import Path
    from robrst.design import DesignResult

__all__ = ["bode_figure", "nyquist_figure", "step_figure", "step_horizon"]

_F = np.logspace(0, 4.7, 1500)  # 1 Hz .. 50 kHz


def _db(x):
    return 20 * np.log10(np.maximum(np.abs(x), 1e-300))


def bode_figure(result: DesignResult, path: str | Path) -> None:
    """``|S|, |T|, |U|`` for every family temperature, spec bounds dashed, peaks marked.

    Parameters
    ----------
    result : DesignResult
        The design (its analyses and certificate are drawn).
    path : str or pathlib.Path
        The PNG file.
    """
    fam = result.problem.family.models
    specs = result.problem.specs
    with drawing(path, (8, 9), 3, 1, sharex=True) as (fig, axes):
        _bode(result, fam, specs, axes)


def _bode(result, fam, specs, axes):
    cols = _colors(len(fam))
    for (name, key, unit), ax in zip((("S", "Ms_max", "-"), ("T", "Mt_max", "-"),
                                      ("U", "Mu_max", "V/µm")), axes):
        for m, a, c in zip(fam, result.analyses, cols):
            ax.semilogx(_F, _db(sensitivity(m, result.controller, name, 2 * np.pi * _F)),
                        color=c, lw=1.2, label=f"{m.temperature_C:g} °C")
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


def nyquist_figure(result: DesignResult, path: str | Path) -> None:
    """Loop L = BR/(AS) per temperature around -1 with the modulus-margin circles.

    Parameters
    ----------
    result : DesignResult
        The design.
    path : str or pathlib.Path
        The PNG file.
    """
    with drawing(path, (7, 6.5)) as (fig, ax):
        _nyquist(result, ax)


def _nyquist(result, ax):
    fam = result.problem.family.models
    w = 2 * np.pi * np.logspace(-1, 5, 6000)
    for m, c in zip(fam, _colors(len(fam))):
        L = (poly.eval_jw(poly.pmul(m.B, result.controller.R), w)
             / poly.eval_jw(poly.pmul(m.A, result.controller.S), w))
        L = np.where(np.abs(L) < 20, L, np.nan)
        ax.plot(L.real, L.imag, color=c, lw=1.2, label=f"{m.temperature_C:g} °C")
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


def step_horizon(result: DesignResult, t_max: float = 1.0) -> float:
    """Three times the slowest 2 % settling time of the reference step [s], 5 ms..1 s.

    (The spectral abscissa would be misleading: a slow pole nearly cancelled by a
    zero of T hardly shows in the response.)

    Parameters
    ----------
    result : DesignResult
        The design.
    t_max : float
        Upper limit [s].

    Returns
    -------
    float
        The time span of the step figure [s].
    """
    t = np.linspace(0, t_max, 20001)
    ts = 0.0
    for m in result.problem.family.models:
        cl = closed_loop(m, result.controller)
        y = step_response(cl.nums["Tr"], cl.Delta, t)
        final = y[-1] if abs(y[-1]) > 1e-12 else 1.0
        out = np.flatnonzero(np.abs(y - final) > 0.02 * abs(final))
        ts = max(ts, t[out[-1]] if out.size else 0.0)
    return float(np.clip(3 * ts, 5e-3, t_max))


def step_figure(result: DesignResult, path: str | Path,
                twin: dict[str, tuple] | None = None) -> None:
    """Reference and input-disturbance steps at the extreme temperatures.

    Parameters
    ----------
    result : DesignResult
        The design.
    path : str or pathlib.Path
        The PNG file.
    twin : dict, optional
        Maps a label to ``(t [s], y [µm])`` curves of the digital twin (sampled
        controller, every effect on), drawn on the reference panel.
    """
    fam = result.problem.family.models
    ext = [fam[0], fam[-1]] if len(fam) > 1 else [fam[0]]
    t = np.linspace(0, step_horizon(result), 2000)
    with drawing(path, (11, 4.2), 1, 2) as (fig, (a1, a2)):
        _steps(result, ext, t, twin, a1, a2)


def _steps(result, ext, t, twin, a1, a2):
    for m, c in zip(ext, ("tab:blue", "tab:red")):
        cl = closed_loop(m, result.controller)
        a1.plot(t * 1e3, step_response(cl.nums["Tr"], cl.Delta, t), color=c,
                label=f"linear, {m.temperature_C:g} °C")
        a2.plot(t * 1e3, step_response(cl.nums["Sd"], cl.Delta, t), color=c,
                label=f"linear, {m.temperature_C:g} °C")
    for (label, (tt, yy)), c in zip((twin or {}).items(), ("tab:cyan", "tab:orange")):
        a1.plot(tt * 1e3, yy, color=c, lw=1, ls="--", label=label)
    a1.set_title("reference step 1 µm")
    a1.set_ylabel("displacement y [µm]")
    a2.set_title("input-disturbance step 1 V")
    a2.set_ylabel("displacement y [µm]")
    for a in (a1, a2):
        a.set_xlabel("time t [ms]")
        a.legend(fontsize=8)
