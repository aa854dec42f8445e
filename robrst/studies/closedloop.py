"""A digital controller as it runs on hardware, in closed loop with the twin.

The controller is its exported C code (:func:`robrst.controller.c_code.c_files`, or the
files ``robrst export --format c`` wrote), compiled together with the twin's step
(:func:`robrst.twin.compiled.compile_controlled_loop`) in the precision a target runs it
(``float64`` or ``float32``, ``-D<PREFIX>_REAL``).  Every sample: the twin's measured
output at the sample, the controller's command for the reference and that measurement,
applied after the computation delay and held over the sample (ZOH), the twin's step.  With
every effect off the twin's linear part is the exact ZOH model of its plant
(:mod:`robrst.twin.model`), so the run is the sampled loop the certificate covers.
Without a C compiler a saved design runs through the reference step of the same
operations (:func:`robrst.controller.implementation.controller_step`, numpy's float32 or
float64); a C file needs the compiler.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.base.fileio import read_utf8
from robrst.twin.compiled import ControlledLoop, compile_controlled_loop, compiler
from robrst.twin.model import build_model
from robrst.twin.simulate import SimResult, rest_state

__all__ = ["LoopController", "controller_of_design", "controller_of_c_file",
           "run_closed_loop", "PRECISIONS"]

PRECISIONS = {"float64": ("double", np.float64), "float32": ("float", np.float32)}

if TYPE_CHECKING:
    from robrst.controller.export import ExportedController



@dataclass(frozen=True, eq=False)
class LoopController:
    """A digital controller ready to run: its C files and what they state.

    Attributes
    ----------
    name : str
    files : dict
        File name -> text of its C (header and source).
    header : str
        The header the source includes.
    prefix : str
        Its C prefix.
    sample_rate_hz : float
    delay_samples : int
        Computation delay [samples].
    py_step : callable or None
        ``py_step(dtype) -> step(yr, y)``: a Python step with the same operations
        (``None`` for a C file given as it is).
    exported : ExportedController or None
        The export, when made here.
    source : str
        Where it came from (named in messages).
    meta : dict
    """

    name: str
    files: dict
    header: str
    prefix: str
    sample_rate_hz: float
    delay_samples: int
    py_step: Callable = None
    exported: ExportedController | None = None
    source: str = ""
    meta: dict = field(default_factory=dict)


def controller_of_design(result: object, sample_rate_hz: float | None = None,
                         delay_samples: int | None = None,
                         u_range: tuple | None = None) -> LoopController:
    """The exported controller of a design as C, ready to run.

    Parameters
    ----------
    result : DesignResult
    sample_rate_hz, delay_samples : optional
        Default the design's (:func:`robrst.controller.export.export_controller`: Tustin
        sections at that rate, certified there).
    u_range : (float, float), optional
        The amplifier range the code saturates to (default none: the twin's own
        ``[saturation]`` models the amplifier).

    Returns
    -------
    LoopController
    """
    from robrst.controller.c_code import c_files
    from robrst.controller.export import export_controller
    from robrst.controller.implementation import controller_step

    rng = (-np.inf, np.inf) if u_range is None else tuple(u_range)
    exp = export_controller(result, sample_rate_hz, delay_samples, rng)
    header, source = c_files(exp, "ctrl", "robrst_ctrl")
    return LoopController(name=exp.problem, files={"ctrl.h": header, "ctrl.c": source},
                          header="ctrl.h", prefix="robrst_ctrl",
                          sample_rate_hz=float(exp.digital.sample_rate_hz),
                          delay_samples=int(exp.delay_samples),
                          py_step=lambda dtype: controller_step(exp.digital, dtype, exp.u_range),
                          exported=exp, source=f"design {exp.problem}")


_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
_TYPEDEF = re.compile(r"typedef\s+\w+\s+(\w+)_real\s*;")


def _define(text, prefix, name, path):
    m = re.search(rf"#define\s+{prefix.upper()}_{name}\s+(\S+)", text)
    if m is None:
        raise SpecError(f"{path}: no #define {prefix.upper()}_{name}; expected a header"
                        " written by robrst export --format c")
    return float(m.group(1))


def controller_of_c_file(path: str | Path) -> LoopController:
    """The controller of the C files ``robrst export --format c`` wrote, run as it is.

    Parameters
    ----------
    path : str or Path
        ``ctrl.c`` (or ``ctrl.h``): the source and the header it includes, side by side.

    Returns
    -------
    LoopController

    Raises
    ------
    SpecError
        Naming the file: not found, not robrst's C controller (its prefix, rate and delay
        are read from the header's ``typedef`` and ``#define`` lines).
    """
    p = Path(path)
    src = p.with_suffix(".c") if p.suffix in (".c", ".h") else p
    source = read_utf8(src, "C controller", "C", SpecError)
    inc = _INCLUDE.findall(source)
    if not inc:
        raise SpecError(f"{src}: includes no header; expected the C of robrst export"
                        " --format c")
    hdr = src.parent / inc[0]
    header = read_utf8(hdr, "C header", "C", SpecError)
    m = _TYPEDEF.search(header)
    if m is None:
        raise SpecError(f"{hdr}: no 'typedef ... <prefix>_real;'; expected a header written"
                        " by robrst export --format c")
    prefix = m.group(1)
    fs = _define(header, prefix, "SAMPLE_RATE_HZ", hdr)
    k = int(_define(header, prefix, "DELAY_SAMPLES", hdr))
    return LoopController(name=src.stem, files={inc[0]: header, src.name: source},
                          header=inc[0], prefix=prefix, sample_rate_hz=fs, delay_samples=k,
                          source=str(src))


def run_closed_loop(twin: object, controller: LoopController, yr: object, temp: object,
                    precision: str = "float64", seed: int = 0, t0: float = 0.0) -> SimResult:
    """Run ``controller`` in closed loop with ``twin`` on a reference profile.

    Parameters
    ----------
    twin : TwinConfig
        At the controller's sampling rate.
    controller : LoopController
    yr, temp : array_like
        Reference [µm] and ambient temperature [°C], one value per sample.
    precision : {"float64", "float32"}
        The controller's arithmetic.
    seed : int
        Seed of the sensor noise.
    t0 : float
        Time of the first sample [s].

    Returns
    -------
    SimResult
        ``u_cmd`` the controller's (saturated) command, ``u_applied`` what reached the
        actuator, ``y`` the measurement, ``y_true`` the displacement; ``meta`` says how it
        ran (``compiled``, ``precision``, ``controller``).

    Raises
    ------
    SpecError
        Different rates, a bad precision, profiles of different lengths, a C file and no
        compiler.
    """
    if precision not in PRECISIONS:
        raise SpecError(f"precision: expected one of {', '.join(PRECISIONS)}, got {precision!r}")
    fs = float(twin.sample_rate_hz)
    if abs(controller.sample_rate_hz - fs) > 1e-9 * fs:
        raise SpecError(f"the controller runs at {controller.sample_rate_hz:g} Hz and the twin"
                        f" {twin.name!r} at {fs:g} Hz; give the twin the controller's rate"
                        " ([twin] sample_rate_hz)")
    yr, temp = np.asarray(yr, float), np.asarray(temp, float)
    if yr.shape != temp.shape or yr.ndim != 1 or yr.size == 0:
        raise SpecError(f"reference and temperature need the same non-zero length (got"
                        f" {yr.size}, {temp.size})")
    real, dtype = PRECISIONS[precision]
    model = build_model(twin)
    if not model.strictly_proper:
        raise SpecError("closed-loop simulation needs a strictly proper plant (no feedthrough)")
    model.check_temperatures(temp)
    loop = None
    if compiler() is not None:
        loop = compile_controlled_loop(model.step, model.output, controller.files,
                                       controller.header, controller.prefix, real,
                                       controller.delay_samples)
    if loop is None:
        if controller.py_step is None:
            raise SpecError(f"{controller.source}: running a C controller needs a C compiler"
                            " (gcc or $CC); none works here")
        loop = ControlledLoop(model.step, model.output, controller.delay_samples,
                              py_step=controller.py_step(dtype))
    noise = np.random.default_rng(seed).standard_normal(yr.size)
    x0 = rest_state(model, 0.0, temp[0])
    Y, _ = loop(np.vstack([yr, temp, noise]), x0, model.theta0)
    meta = {"twin": twin.name, "sample_rate_hz": fs, "seed": int(seed),
            "effects_on": [k for k in twin.effects if twin.enabled(k)],
            "compiled": loop.is_compiled, "precision": precision,
            "controller": controller.source, "delay_samples": controller.delay_samples}
    return SimResult(t=t0 + np.arange(yr.size) / fs, u_cmd=Y[3], u_applied=Y[2], y=Y[0],
                     y_true=Y[1], temp=temp, yr=yr, meta=meta)
