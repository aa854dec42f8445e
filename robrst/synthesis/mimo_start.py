"""What the joint multi-axis program starts from: the decoupler, the grid, per-axis laws.

* :func:`static_decoupler` — the real matrix ``W`` closest (least squares) to
  ``G(j w)^-1`` of the reference model at one frequency: ``G W`` is then as close to the
  identity there as a real matrix makes it (the ALIGN idea of multivariable design);
* :class:`LoopPlant` and :func:`loop_plants` — the plants of every loop the program and
  the certificate see (each model's continuous loop and, with a rate, its sampled loop in
  the w-plane, :func:`robrst.core.mimo.sampled_mimo`);
* :func:`program_grid` — the frequency points of one loop: log-spaced over the band that
  matters, plus points across every lightly damped resonance, up to Nyquist for a sampled
  loop;
* :func:`axis_plant` — one diagonal channel ``(G W)_ii`` as a 1 x 1 plant, and
  :func:`start_gain` the integral-gain scan of a rolled-off integral law on it (the
  largest gain whose loops are stable and meet the bounds on the grid).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.core.mimo import MimoPlant, sampled_mimo
from robrst.core.mimo_loop import MimoController, mimo_loop
from robrst.core.sampled import warp

if TYPE_CHECKING:
    from robrst.problem.mimo import MimoSpecs
    from robrst.synthesis.mimo_program import AxisParam

__all__ = ["static_decoupler", "LoopPlant", "loop_plants", "program_grid", "nu_of",
           "axis_plant", "start_gain", "design_scale", "RESONANT_DAMPING", "NYQUIST_EDGE"]

RESONANT_DAMPING = 0.3     # poles less damped than this get points across their peak
#: the last point of a sampled loop's validation grid (and of the points the exact check
#: adds), as a fraction of Nyquist.  ``z = -1`` is ``nu = inf`` in the w-plane, and a real
#: closed-loop pole far out there (a z-plane pole near -1) peaks at Nyquist only: seeded
#: three-axis stage 4's program, its grid ending at 0.9995 of Nyquist, saw ``sigma_S``
#: 1.08 where it was 11.4 at Nyquist.  Here ``nu = 2 fs tan(pi / 2 NYQUIST_EDGE)`` is
#: 6.4e7 x ``2 fs``: finite, and a pole beyond it lies within 3e-8 of ``z = -1``.
NYQUIST_EDGE = 1.0 - 1e-8


def static_decoupler(plant: MimoPlant, freq_hz: float = 0.0) -> np.ndarray:
    """The real ``W`` minimising ``||G(j w) W - I||_F`` (``w = 2 pi freq_hz``).

    ``W = Re(G^H G)^-1 Re(G)^T``; at ``w = 0`` it is ``G(0)^-1``.

    Parameters
    ----------
    plant : MimoPlant
        A square plant.
    freq_hz : float
        Where to invert it [Hz].

    Returns
    -------
    numpy.ndarray
        ``(inputs, outputs)``.

    Raises
    ------
    SpecError
        A plant that is not square, or singular at that frequency.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoPlant
    >>> G = MimoPlant(-np.eye(2), np.eye(2), [[2.0, 1.0], [0.0, 1.0]], np.zeros((2, 2)))
    >>> np.round(static_decoupler(G) @ [[2.0, 1.0], [0.0, 1.0]], 12).tolist()
    [[1.0, 0.0], [0.0, 1.0]]
    """
    if plant.n_in != plant.n_out:
        raise SpecError(f"plant {plant.label!r}: {plant.n_out} x {plant.n_in}; a decoupler"
                        " needs a square plant")
    G = plant.freqresp([2 * np.pi * float(freq_hz)])[0]
    if not np.all(np.isfinite(G)):
        raise SpecError(f"plant {plant.label!r}: infinite gain at {freq_hz:g} Hz (a pole"
                        " there); choose another decoupler_hz")
    N = (G.conj().T @ G).real
    if np.linalg.cond(N) > 1e12:
        raise SpecError(f"plant {plant.label!r}: singular at {freq_hz:g} Hz; no static"
                        " decoupler inverts it (choose another decoupler_hz or none)")
    return np.linalg.solve(N, G.real.T)


@dataclass(frozen=True, eq=False)
class LoopPlant:
    """One loop the program holds: a model's continuous loop or its sampled loop.

    Parameters
    ----------
    plant : MimoPlant
        The loop's plant (the w-plane plant of a sampled loop).
    loop : {"continuous", "sampled"}
    fs : float or None
        The rate of a sampled loop [Hz].
    model : int
        Index of the model.
    """

    plant: MimoPlant
    loop: str
    fs: float | None
    model: int


def loop_plants(models: Sequence[MimoPlant], specs: MimoSpecs) -> list[LoopPlant]:
    """Every loop of ``models``: continuous, and sampled when the specs name a rate.

    Parameters
    ----------
    models : sequence of MimoPlant
    specs : MimoSpecs

    Returns
    -------
    list of LoopPlant
    """
    out = []
    for k, mdl in enumerate(models):
        out.append(LoopPlant(mdl, "continuous", None, k))
        if specs.sampled:
            out.append(LoopPlant(sampled_mimo(mdl, specs.sample_rate_hz, specs.delay_samples),
                                 "sampled", specs.sample_rate_hz, k))
    return out


def design_scale(plant: MimoPlant, specs: MimoSpecs, bandwidth_hz: float | None) -> float:
    """The start's crossover [rad/s]: ``bandwidth_hz``, or a tenth of the lowest lightly
    damped resonance of ``plant`` (at most ``fs / 40``; without a resonance, a tenth of
    the fastest pole).

    Parameters
    ----------
    plant : MimoPlant
    specs : MimoSpecs
    bandwidth_hz : float, optional

    Returns
    -------
    float
    """
    if bandwidth_hz:
        return 2 * np.pi * float(bandwidth_hz)
    p = plant.poles()
    mag = np.abs(p)
    res = (p.imag > 0) & (-p.real < RESONANT_DAMPING * mag)
    w = 0.1 * float(np.min(mag[res])) if np.any(res) else (
        0.1 * float(np.max(mag)) if mag.size else 2 * np.pi * 10.0)
    if specs.sampled:
        w = min(w, 2 * np.pi * specs.sample_rate_hz / 40)
    return w


def program_grid(plant: MimoPlant, fs: float | None, w_design: float, n: int,
                 resonances: bool = True, dense: bool = False) -> np.ndarray:
    """Physical frequencies [rad/s] of one loop's program points.

    ``n`` log-spaced points from ``w_design / 200`` to Nyquist (sampled loop, its end
    at ``0.9995`` of it; a dense grid has one more at :data:`NYQUIST_EDGE` of it) or to
    30 times the fastest pole or the design scale, plus eleven points across each
    resonance (damping below :data:`RESONANT_DAMPING`) in that range.

    Parameters
    ----------
    plant : MimoPlant
        The continuous model (its poles place the resonance points).
    fs : float or None
        The sampled loop's rate.
    w_design : float
        The start's crossover [rad/s].
    n : int
        Log-spaced points.
    resonances : bool
        Add the points across the resonances.
    dense : bool
        33 points across each resonance (within 8 dampings) instead of 11, and a sampled
        loop's point at :data:`NYQUIST_EDGE`: the grid the program's candidates are
        validated on (and the global phase screens on).

    Returns
    -------
    numpy.ndarray
        Sorted, unique.
    """
    p = plant.poles()
    mag = np.abs(p)
    lo = w_design / 200.0
    hi = 0.9995 * np.pi * fs if fs else 30.0 * max(float(mag.max()) if mag.size else 0.0,
                                                    w_design)
    w = list(np.geomspace(lo, hi, n))
    res = p[(p.imag > 0) & (-p.real < RESONANT_DAMPING * mag)] if resonances else []
    for pk in res:
        wn, z = abs(pk), -pk.real / abs(pk)
        for k in (np.linspace(-8.0, 8.0, 33) if dense else
                  (-6.0, -4.0, -2.5, -1.5, -0.75, 0.0, 0.75, 1.5, 2.5, 4.0, 6.0)):
            x = wn * (1.0 + k * max(z, 1e-4))
            if lo < x < hi:
                w.append(x)
    if fs and dense:
        w.append(NYQUIST_EDGE * np.pi * fs)
    return np.unique(np.asarray(w))


def nu_of(w: np.ndarray, fs: float | None) -> np.ndarray:
    """Loop-variable frequencies of physical ones (the w-plane's for a sampled loop).

    Parameters
    ----------
    w : numpy.ndarray
    fs : float or None

    Returns
    -------
    numpy.ndarray
    """
    return warp(w, fs) if fs else np.asarray(w, float)



def axis_plant(plant: MimoPlant, W: np.ndarray, i: int) -> MimoPlant:
    """The diagonal channel ``(G W)_ii`` as a 1 x 1 plant.

    Parameters
    ----------
    plant : MimoPlant
    W : numpy.ndarray
        A static decoupler (the identity: the plant's own channel ``G_ii``).
    i : int

    Returns
    -------
    MimoPlant
    """
    Bw = plant.B @ W[:, i:i + 1]
    Dw = plant.D[i:i + 1] @ W[:, i:i + 1]
    return MimoPlant(plant.A, Bw, plant.C[i:i + 1], Dw, f"{plant.label}[{i + 1}]",
                     plant.value, dict(plant.meta))


def start_gain(loops: Sequence[LoopPlant], axis: AxisParam, bounds: dict,
               grids: Sequence[np.ndarray], roll_pole: float = 10.0) -> tuple[float, float]:
    """The largest scaled integral gain of ``gain / (p (p / roll_pole + 1)^d)`` whose 1 x 1
    loops are all stable and meet ``bounds`` on the grids.

    Parameters
    ----------
    loops : sequence of LoopPlant
        1 x 1 loop plants.
    axis : AxisParam
    bounds : dict
        ``{"sigma_S": b, "sigma_T": b}`` (those given).
    grids : sequence of numpy.ndarray
        Physical frequencies of each loop.
    roll_pole : float
        The start's roll-off poles, in units of ``w0``.

    Returns
    -------
    gain : float
        The scaled gain (its sign the channel's at the design scale); 0 when none of the
        scanned gains works.
    sign : float
    """
    g0 = loops[0].plant.freqresp([axis.w0 / 10.0])[0][0, 0]
    sign = 1.0 if g0.real >= 0 else -1.0
    unit = 1.0 / max(abs(g0), 1e-300)
    frs = [lp.plant.freqresp(nu_of(w, lp.fs))[:, 0, 0] for lp, w in zip(loops, grids)]
    bases = [axis.basis(nu_of(w, lp.fs)) for lp, w in zip(loops, grids)]
    best = 0.0
    for k in np.geomspace(1e-3, 30.0, 46):
        gain = sign * unit * k
        x = axis.start(gain, roll_pole)
        ok = True
        for g, (ER, ES, e0) in zip(frs, bases):
            R = ER @ x[axis.d:]
            S = (ES @ x[:axis.d] if axis.d else 0.0) + e0
            P = S + g * R
            with np.errstate(all="ignore"):
                sv = np.abs(S / P)
                tv = np.abs(g * R / P)
            if ("sigma_S" in bounds and np.nanmax(sv) > bounds["sigma_S"]) or (
                    "sigma_T" in bounds and np.nanmax(tv) > bounds["sigma_T"]):
                ok = False
                break
        if ok:
            ctrl = MimoController([axis.controller(x)])
            ok = all(mimo_loop(lp.plant, ctrl).stable for lp in loops)
        if not ok:
            break
        best = gain
    return best, sign
