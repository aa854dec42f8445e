"""Closed-loop analysis of a plant under an RST controller.

Sensitivities ``S = AS/Delta``, ``T = BR/Delta``, ``U = AR/Delta`` [V/µm] and
``Sd = BS/Delta`` [µm/V]; closed-loop poles; gain, phase, modulus and delay margins
(over *all* crossovers, found as roots of polynomials in w**2 and polished); exact
peaks (:mod:`robrst.core.peaks`); step responses.  All root finding is done in the scaled
variable ``p = s / w0``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.core.peaks import mag2_poly, peak_gains_many
from robrst.core.plant import Plant, as_plant
from robrst.core.rst import RSTController, as_controller, closed_loop

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["Margins", "Analysis", "analyze", "sampled_analysis", "sensitivity", "crossovers",
           "loop_value",
           "bracketed_root",
           "step_response", "spectral_abscissa", "spectral_abscissa_many", "analyze_many"]

SENSITIVITIES = ("S", "T", "U", "Sd")


@dataclass(frozen=True)
class Margins:
    """Classical margins of the loop ``L = BR/(AS)``; ``None`` means infinite.

    Parameters
    ----------
    gain_margin : float or None
        The smallest factor > 1 by which the loop gain can grow before a phase crossover
        reaches -1 (None: infinite).  Where robrst differs from python-control: its
        ``stability_margins`` answers one gain margin, of this and
        :attr:`gain_margin_lower` the one nearest 1 on a log scale; a conditionally
        stable loop has both, and robrst states both.
    gain_crossover_rad_s : tuple of float
        Every gain crossover [rad/s].
    phase_crossover_rad_s : tuple of float
        Every phase crossover with ``Re L < 0`` [rad/s]; ``w = 0`` (``L(0) < 0``) and
        ``w = inf`` (biproper ``L`` with ``L(inf) < 0``) included, as python-control
        counts them (0.0 or inf then).
    phase_margin_deg : float or None
        As python-control defines it: at every gain crossover ``(arg L(j wc) mod 360) -
        180``, the one smallest in magnitude, with its sign (negative: ``arg L`` in
        (0, 180)).
    delay_margin_s : float or None
        The smallest pure delay that puts ``L`` on -1 (phase lag only, over every
        crossover) [s].
    modulus_margin : float
        ``1 / Ms``.
    gain_margin_lower : float or None
        The largest factor < 1 to which the loop gain can shrink before a phase crossover
        reaches -1 (None: down to 0, as in a loop stable for every smaller gain).
        python-control's ``stability_margins`` gm is whichever of the two gain margins is
        closer to 1 in log.
    """

    gain_margin: float
    gain_crossover_rad_s: tuple
    phase_crossover_rad_s: tuple
    phase_margin_deg: float
    delay_margin_s: float
    modulus_margin: float
    gain_margin_lower: float = None


@dataclass(frozen=True, eq=False)
class Analysis:
    """Everything :func:`analyze` computes for one plant/controller pair.

    Parameters
    ----------
    label : str
        The plant's label.
    temperature_C : float or None
        The plant's temperature [°C].
    stable : bool
        The closed loop is stable (spectral abscissa < 0).
    poles : numpy.ndarray
        Closed-loop poles [rad/s].
    spectral_abscissa : float
        Largest real part of the closed-loop poles [rad/s].
    peaks : dict
        ``"S"``, ``"T"``, ``"U"``, ``"Sd"`` -> exact :class:`~robrst.core.peaks.Peak`.
    margins : Margins
        Gain, phase, modulus and delay margins.
    sample_rate_hz : float, optional
        ``None``: the continuous loop.  Else the analysis is the sampled loop's at this
        rate (ZOH plant, Tustin controller, ``delay_samples``; :func:`analyze` of a discrete
        plant): peaks and crossovers at physical frequencies up to Nyquist, poles mapped
        to ``s = fs ln z``, the delay margin in seconds.
    delay_samples : int
        The sampled loop's computation delay [samples].
    """

    label: str
    temperature_C: float
    stable: bool
    poles: np.ndarray
    spectral_abscissa: float
    peaks: dict
    margins: Margins
    sample_rate_hz: float = None
    delay_samples: int = 0


def sensitivity(plant: Plant, ctrl: RSTController, name: str, w: ArrayLike) -> np.ndarray:
    """Complex frequency response of sensitivity ``name`` in S, T, U, Sd, Tr at ``w`` [rad/s].

    Parameters
    ----------
    plant : Plant
        The plant.
    ctrl : RSTController
        The controller.
    name : {"S", "T", "U", "Sd", "Tr"}
        Which closed-loop transfer function.
    w : array_like
        Frequencies [rad/s].

    Returns
    -------
    numpy.ndarray
        Complex values at ``s = jw``.
    """
    cl = closed_loop(plant, ctrl)
    N, D = cl.tf(name)
    return poly.eval_jw(N, w) / poly.eval_jw(D, w)


def spectral_abscissa(Delta: ArrayLike) -> tuple[float, np.ndarray]:
    """Largest real part of the roots of ``Delta`` (computed in scaled form).

    Parameters
    ----------
    Delta : array_like
        A polynomial in s, highest power first.

    Returns
    -------
    abscissa : float
        The largest real part of its roots [rad/s].
    roots : numpy.ndarray
        The roots [rad/s].
    """
    return spectral_abscissa_many([Delta])[0]


def spectral_abscissa_many(Deltas: Sequence[ArrayLike]) -> list[tuple[float, np.ndarray]]:
    """:func:`spectral_abscissa` of each polynomial, the root computations batched
    (:func:`robrst.core.poly.roots_many`: identical roots).

    Parameters
    ----------
    Deltas : sequence of array_like
        Polynomials in s, highest power first.

    Returns
    -------
    list of (float, numpy.ndarray)
        Spectral abscissa and roots [rad/s] of each.
    """
    scs = [poly.Scaling.natural(D) for D in Deltas]
    rts = poly.roots_many([sc.apply(poly.trim(D)) for sc, D in zip(scs, Deltas)])
    out = []
    for sc, r in zip(scs, rts):
        r = sc.unfreq(r)
        out.append((float(np.max(r.real)), r))
    return out


def _positive_roots_x(q, w0):
    """Positive real roots x = w**2 of polynomial q (in scaled x), returned as w [rad/s]."""
    q = poly.trim(q)
    if len(q) < 2:
        return np.zeros(0)
    r = np.roots(q / np.max(np.abs(q)))
    x = r[(np.abs(r.imag) <= 1e-7 * np.maximum(1.0, np.abs(r))) & (r.real > 0)].real
    return np.sort(np.sqrt(x)) * w0


def _polish(f, w):
    """Refine a simple root of f near w with a bracketed solve; keep w if no bracket."""
    for d in (1e-6, 1e-4, 1e-2):
        a, b = w * (1 - d), w * (1 + d)
        fa, fb = f(a), f(b)
        if np.sign(fa) != np.sign(fb):
            return bracketed_root(f, a, b, fa, fb, xtol=1e-14 * w)
    return w


def bracketed_root(f: Callable[[float], float], a: float, b: float, fa: float, fb: float,
                   xtol: float, max_iter: int = 200) -> float:
    """A root of ``f`` in ``[a, b]`` (``fa``, ``fb`` of opposite signs) to ``xtol``.

    Illinois (modified regula falsi): superlinear on a simple root, and the bracket
    always holds it; a bisection step whenever the bracket fails to halve.  Replaces
    ``scipy.optimize.brentq`` here: importing scipy.optimize costs 0.2 s per command.

    Parameters
    ----------
    f : callable
        A continuous function of one float.
    a, b : float
        The bracket.
    fa, fb : float
        ``f(a)`` and ``f(b)``, of opposite signs (or one of them 0).
    xtol : float
        Width of the final bracket.
    max_iter : int
        Iteration cap.

    Returns
    -------
    float
        The end of the final bracket with the smaller ``|f|`` (or an exact zero).

    Examples
    --------
    >>> from robrst.core.analysis import bracketed_root
    >>> round(bracketed_root(lambda x: x * x - 2.0, 1.0, 2.0, -1.0, 2.0, 1e-12), 12)
    1.414213562373
    """
    if fa == 0:
        return a
    if fb == 0:
        return b

    def keep(c, fc):
        """Replace the end whose value has the sign of ``fc``; -1: b replaced, 1: a."""
        nonlocal a, b, fa, fb
        if np.sign(fc) == np.sign(fb):
            b, fb = c, fc
            return -1
        a, fa = c, fc
        return 1

    side = 0
    for _ in range(max_iter):
        width = abs(b - a)
        c = (a * fb - b * fa) / (fb - fa)
        if not min(a, b) < c < max(a, b):
            c = 0.5 * (a + b)
        fc = f(c)
        if fc == 0:
            return c
        new = keep(c, fc)
        if new == side:                     # the same end twice: halve the other's value
            if new == -1:
                fa *= 0.5
            else:
                fb *= 0.5
        side = new
        if abs(b - a) > 0.5 * width:        # slow side: bisect once
            m = 0.5 * (a + b)
            fm = f(m)
            if fm == 0:
                return m
            keep(m, fm)
            side = 0
        if abs(b - a) <= xtol:
            break
    return a if abs(fa) <= abs(fb) else b


def crossovers(num: ArrayLike, den: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Gain and phase crossover frequencies [rad/s] of ``L = num/den``.

    Gain crossovers solve ``|num|^2 - |den|^2 = 0`` and phase crossovers
    ``Im(num(jw) den(-jw)) = 0`` with ``Re L < 0``, both as polynomials in
    ``x = w**2`` in the scaled variable, then polished on the exact function.

    The ends of the frequency axis count as phase crossovers where ``L`` is finite and
    on the negative real axis there, as python-control counts them: ``w = 0`` when
    ``L(0) < 0`` (a real closed-loop pole crosses ``s = 0`` when the gain falls to
    ``1/|L(0)|``), and ``w = inf`` when ``L`` is biproper with ``L(inf) < 0`` (a pole
    passes through infinity; python-control's discrete loops count Nyquist, ``z = -1``,
    in the same way, the image of ``w = inf`` for robrst's sampled loops).

    Parameters
    ----------
    num, den : array_like
        Numerator and denominator of the loop gain in s, highest power first.

    Returns
    -------
    gain_crossovers, phase_crossovers : numpy.ndarray
        Frequencies [rad/s], increasing.

    Examples
    --------
    >>> wg, wp = crossovers([2.0], [1.0, -1.0])      # L = 2/(s - 1): L(0) = -2
    >>> wp.tolist()
    [0.0]
    """
    num, den = poly.trim(num), poly.trim(den)
    sc = poly.Scaling.natural(num, den)
    w0 = sc.w0
    ns, ds = sc.apply(num), sc.apply(den)
    L = lambda w: poly.eval_jw(ns, w) / poly.eval_jw(ds, w)  # noqa: E731  (scaled w)
    g = poly.padd(mag2_poly(ns), -mag2_poly(ds))
    wg = [_polish(lambda w: np.log(abs(L(w))), w) for w in _positive_roots_x(g, 1.0)]
    # Im(L) = 0  <=>  odd part of num(s) den(-s) vanishes at s = jw
    dm = ds * (-1.0) ** np.arange(len(ds) - 1, -1, -1)
    F = np.polymul(ns, dm)
    odd = F[::-1][1::2][::-1]  # coefficients of s^(2k+1), highest first
    k = np.arange(len(odd) - 1, -1, -1)
    q = odd * (-1.0) ** k
    wp = [_polish(lambda w: L(w).imag / abs(L(w)), w) for w in _positive_roots_x(q, 1.0)]
    wp = [w for w in wp if L(w).real < 0]
    wp = np.array(wp) * w0
    ends = []
    if den[-1] != 0 and num[-1] / den[-1] < 0:
        ends.append(0.0)
    if len(num) == len(den) and num[0] / den[0] < 0:
        ends.append(np.inf)
    if ends:
        wp = np.sort(np.concatenate([wp, ends]))
    return np.array(wg) * w0, wp


def loop_value(num: ArrayLike, den: ArrayLike, w: float) -> complex:
    """``L(jw) = num(jw)/den(jw)``, with the limits at ``w = 0`` and ``w = inf``.

    Parameters
    ----------
    num, den : array_like
        Numerator and denominator of the loop gain in s, highest power first.
    w : float
        Frequency [rad/s], ``inf`` allowed.

    Returns
    -------
    complex

    Examples
    --------
    >>> loop_value([-0.5, 1.5], [1.0, 1.0], float("inf"))
    (-0.5+0j)
    """
    num, den = poly.trim(num), poly.trim(den)
    if np.isinf(w):
        return complex(num[0] / den[0]) if len(num) == len(den) else 0j
    return complex(poly.eval_jw(num, w) / poly.eval_jw(den, w))


def margins(plant, ctrl, Ms):
    """Margins of ``L = BR/(AS)`` over every crossover; ``Ms`` is the exact |S| peak.

    Phase crossovers include ``w = 0`` and ``w = inf`` where ``L`` is finite and negative
    there (:func:`crossovers`), as python-control counts them.
    """
    num = poly.pmul(plant.B, ctrl.R)
    den = poly.pmul(plant.A, ctrl.S)
    wg, wp = crossovers(num, den)
    L = lambda w: loop_value(num, den, w)  # noqa: E731
    gms = [1.0 / abs(L(w)) for w in wp]
    up = [g for g in gms if g > 1.0]
    down = [g for g in gms if g < 1.0]
    gm = min(up) if up else None
    gm_lower = max(down) if down else None
    # python-control's phase margin: (arg L(j wc) mod 360) - 180, smallest in magnitude
    args = [float(np.degrees(np.angle(L(w)))) for w in wg]
    pms = [a % 360.0 - 180.0 for a in args]
    pm = min(pms, key=abs) if pms else None
    # phase lag a pure delay must add at each crossover before L reaches -1
    dms = [np.radians((a + 180.0) % 360.0) / w for a, w in zip(args, wg) if w > 0]
    dm = None if not dms else max(0.0, float(min(dms)))
    return Margins(gain_margin=gm, gain_crossover_rad_s=tuple(float(w) for w in wg),
                   phase_crossover_rad_s=tuple(float(w) for w in wp),
                   phase_margin_deg=pm if pm is None else float(pm),
                   delay_margin_s=dm, modulus_margin=1.0 / Ms, gain_margin_lower=gm_lower)


def analyze(plant: Plant, ctrl: RSTController, rtol: float = 1e-10) -> Analysis:
    """Full closed-loop analysis of ``plant`` under ``ctrl``.

    A **discrete** plant (a python-control system with ``dt > 0``, or a :class:`Plant`
    read from one, whose ``meta`` carries ``sample_rate_hz``) is what a controller at
    ``fs = 1/dt`` sees: the analysis is then the **sampled loop's** (the ZOH plant it is,
    the Tustin controller at ``fs``, its delay samples), exactly as the certificate
    computes it (:mod:`robrst.core.sampled`): ``Analysis.sample_rate_hz`` says so.

    Parameters
    ----------
    plant : Plant or control.TransferFunction or control.StateSpace
        The plant (a python-control system: :func:`~robrst.core.plant.as_plant`).
    ctrl : RSTController or control.TransferFunction or control.StateSpace
        The controller (a python-control system: :func:`~robrst.core.rst.as_controller`).
    rtol : float
        Relative accuracy of the exact peaks.

    Returns
    -------
    Analysis
        Stability, closed-loop poles, exact peaks of S, T, U, Sd, and the margins (of the
        sampled loop for a discrete plant).

    Examples
    --------
    >>> from robrst import analyze, paper_plant, pole_placement, PoleSpec
    >>> ctrl = pole_placement(paper_plant(), PoleSpec(wn=600.0, zeta=1.0)).controller
    >>> a = analyze(paper_plant(), ctrl)
    >>> bool(a.stable), round(float(a.margins.phase_margin_deg), 1)
    (True, 86.7)
    """
    plant = as_plant(plant)
    fs = plant.meta.get("sample_rate_hz")
    if fs is None:
        return analyze_many([plant], ctrl, rtol)[0]
    return sampled_analysis(plant, ctrl, fs, int(plant.meta.get("delay_samples", 0)), rtol)


def sampled_analysis(plant: Plant, ctrl: RSTController, sample_rate_hz: float,
                     delay_samples: int = 0, rtol: float = 1e-10) -> Analysis:
    """:func:`analyze` of the sampled loop: ``plant`` behind a ZOH, ``ctrl`` by Tustin at
    ``sample_rate_hz``, ``delay_samples`` of computation delay.

    The loop in the bilinear variable (:func:`robrst.core.sampled.sampled_plant`) has the
    sampled loop's stability, peaks and margins at warped frequencies; they are reported
    at physical frequencies (:func:`robrst.core.sampled.unwarp`; Nyquist is ``pi fs``).

    Parameters
    ----------
    plant : Plant or control.TransferFunction or control.StateSpace
        The continuous plant (a discrete python-control plant: its continuous pre-image).
    ctrl : RSTController or control.TransferFunction or control.StateSpace
        The controller.
    sample_rate_hz : float
        The controller's rate [Hz].
    delay_samples : int
        Whole samples of computation delay.
    rtol : float
        Relative accuracy of the exact peaks.

    Returns
    -------
    Analysis
        ``stable`` (every closed-loop pole inside the unit circle), ``poles`` mapped to
        ``s = fs ln z`` [rad/s] and their spectral abscissa, the peaks and margins of the
        sampled loop (``delay_margin_s``: the extra delay it tolerates, in seconds), and
        ``sample_rate_hz``, ``delay_samples``.

    Examples
    --------
    >>> import control
    >>> from robrst import analyze, paper_plant, pole_placement, PoleSpec
    >>> ctrl = pole_placement(paper_plant(), PoleSpec(wn=600.0, zeta=1.0)).controller
    >>> Pz = control.c2d(paper_plant().to_tf(), 1 / 20000.0)    # ZOH at 20 kHz
    >>> a = analyze(Pz, ctrl)
    >>> a.sample_rate_hz, bool(a.stable), a.peaks["S"].value > analyze(paper_plant(), ctrl).peaks["S"].value
    (20000.0, True, True)
    """
    from dataclasses import replace

    from robrst.core import region
    from robrst.core.sampled import sampled_plant, unwarp

    plant, ctrl = as_plant(plant), as_controller(ctrl)
    fs, k = float(sample_rate_hz), int(delay_samples)
    pw = sampled_plant(plant, fs, k)
    a = analyze_many([pw], ctrl, rtol)[0]
    Delta = poly.trim(closed_loop(pw, ctrl).Delta)
    lost = len(Delta) < pw.n + len(poly.trim(ctrl.S))   # a pole at z = -1 (Nyquist)
    poles = region.s_poles(a.poles, fs)
    sa = float(np.max(poles.real)) if poles.size else -np.inf
    stable = bool(a.stable and not lost)
    if not stable:
        sa = max(sa, 0.0)

    def phys(w):
        return float(unwarp(w, fs))

    peaks = {k_: replace(pk, freq_rad_s=phys(pk.freq_rad_s)) for k_, pk in a.peaks.items()}
    m = a.margins
    num, den = poly.pmul(pw.B, ctrl.R), poly.pmul(pw.A, ctrl.S)
    dms = []
    for nu in m.gain_crossover_rad_s:
        if 0 < nu < np.inf:
            arg = float(np.degrees(np.angle(loop_value(num, den, nu))))
            dms.append(np.radians((arg + 180.0) % 360.0) / phys(nu))
    margins = replace(m, gain_crossover_rad_s=tuple(phys(w) for w in m.gain_crossover_rad_s),
                      phase_crossover_rad_s=tuple(phys(w) for w in m.phase_crossover_rad_s),
                      delay_margin_s=None if not dms else max(0.0, float(min(dms))))
    return Analysis(label=plant.label, temperature_C=plant.temperature_C, stable=stable,
                    poles=poles, spectral_abscissa=sa, peaks=peaks, margins=margins,
                    sample_rate_hz=fs, delay_samples=k)


def analyze_many(plants: Sequence[Plant], ctrl: RSTController,
                 rtol: float = 1e-10) -> tuple[Analysis, ...]:
    """:func:`analyze` of each plant under ``ctrl``, the roots and the peak computations of
    all loops batched (the same figures as one plant at a time).

    Parameters
    ----------
    plants : sequence of Plant
        The plants.
    ctrl : RSTController
        The controller.
    rtol : float
        Relative accuracy of the exact peaks.

    Returns
    -------
    tuple of Analysis
        One per plant, in order.
    """
    plants, ctrl = [as_plant(p) for p in plants], as_controller(ctrl)
    cls = [closed_loop(plant, ctrl) for plant in plants]
    stab = spectral_abscissa_many([cl.Delta for cl in cls])
    # the four peaks of a loop together: the same figures as peak_gain of each
    pks = peak_gains_many([([cl.nums[k] for k in SENSITIVITIES], cl.Delta, ()) for cl in cls],
                          rtol=rtol)
    out = []
    for plant, (sa, roots), pk in zip(plants, stab, pks):
        peaks = dict(zip(SENSITIVITIES, pk))
        out.append(Analysis(label=plant.label, temperature_C=plant.temperature_C,
                            stable=sa < 0, poles=roots, spectral_abscissa=sa, peaks=peaks,
                            margins=margins(plant, ctrl, peaks["S"].value)))
    return tuple(out)


def step_response(N: ArrayLike, D: ArrayLike, t: ArrayLike) -> np.ndarray:
    """Response of ``N(s)/D(s)`` to a unit step at t = 0, sampled at ``t`` [s].

    Simulated exactly (matrix exponential of the zero-order-hold discretisation
    of the balanced scaled realisation), independent of coefficient size.

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s, ``deg N <= deg D``.
    t : array_like
        Increasing, evenly spaced times from 0 [s].

    Returns
    -------
    numpy.ndarray
        The response at ``t``.
    """
    import scipy.signal as sig

    t = np.asarray(t, dtype=float)
    sc = poly.Scaling.natural(D)
    w0 = sc.w0
    A, B, C, d = lti.companion(N, D, sc)
    # in scaled time tau = w0 t, dx/dtau = A x + B u, y = C x + d u
    sys = sig.StateSpace(A, B, C, np.array([[d]]))
    _, y, _ = sig.lsim(sys, np.ones_like(t), t * w0)
    return np.asarray(y, dtype=float)
