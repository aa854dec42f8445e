"""The specs of one loop, frequency by frequency, as two discs for ``T(jw)``.

Every peak spec robrst imposes on a model's loop bounds, at each frequency, one of ``|S|``,
``|T|``, ``|U| = |T / D|`` or ``|B S / Delta| = |D S|`` (``D`` the loop's plant), and
``S = 1 - T``.  At a frequency ``w`` with ``t = T(jw)`` they all read::

    |1 - t| <= r_S(w) = min(Ms_max, Msd_max / |D(jw)|)
    |t|     <= r_T(w) = min(Mt_max, T_resonance_max (in its band), Mu_max |D(jw)|,
                           Mu_hf_max |D(jw)| (above its corner))

Two discs in the complex plane: the one of radius ``r_S`` around 1 and the one of radius
``r_T`` around 0.  They meet iff ``r_S + r_T >= 1``.  :mod:`robrst.synthesis.feasibility`
uses that as a proof (no controller can put ``T(jw)`` in both discs when they do not meet);
:mod:`robrst.synthesis.bound` imposes both discs on a grid in the Youla program.

The sampled loop is the exact continuous-variable loop of :mod:`robrst.core.sampled`: the
plant ``P_w`` (ZOH, delay) in the loop variable ``nu = 2 fs tan(w / (2 fs))``, Nyquist at
``nu = inf``, bands warped and folded as the certificate does
(:func:`robrst.core.sampled.warp_band`).

What the discs do not express (:data:`NOT_EXPRESSED`): the reference path (``Mry_max``,
the time-domain specs), the pole region, a stable controller, and the controller's own
structure (degree, roll-off): a relaxation, so what the discs exclude no linear controller
reaches, and what they allow is not promised.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core.sampled import sampled_plant, unwarp, warp, warp_band

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.family import PlantFamily
    from robrst.core.plant import Plant
    from robrst.problem.records import Problem, Specs

__all__ = ["LoopPlant", "Discs", "loop_plants", "spec_discs", "expressed_specs",
           "EXPRESSED", "NOT_EXPRESSED", "RESONANCE_DAMPING", "loop_grid", "integrators_of"]

# spec keys the discs express (in the order they are named), and the ones they cannot
EXPRESSED = ("Ms_max", "Msd_max", "Mt_max", "T_resonance_max", "Mu_max", "Mu_hf_max")
NOT_EXPRESSED = ("Mry_max", "overshoot_max_pct", "settling_time_max_s", "step_u_max_V",
                 "damping_min", "decay_min", "controller_damping_min", "stable_controller")
RESONANCE_DAMPING = 0.1     # plant poles less damped than this get a dense grid around them


@dataclass(frozen=True, eq=False)
class LoopPlant:
    """One family model in one loop: the plant the loop sees and its frequency variable.

    Parameters
    ----------
    model : Plant
        The family model (its label and temperature name the loop).
    plant : Plant
        The loop's plant: ``model`` itself (continuous loop) or its sampled-loop plant
        ``P_w`` (:func:`robrst.core.sampled.sampled_plant`).
    fs : float, optional
        The sampling rate [Hz] of a sampled loop.

    Attributes
    ----------
    loop : {"continuous", "sampled"}
        Which loop.
    nyquist_rad_s : float
        ``pi fs`` (``inf`` for the continuous loop).
    """

    model: Plant
    plant: Plant
    fs: float = None

    @property
    def loop(self):
        """``"continuous"`` or ``"sampled"``."""
        return "continuous" if self.fs is None else "sampled"

    @property
    def nyquist_rad_s(self):
        """``pi fs`` [rad/s] (``inf`` for the continuous loop)."""
        return np.inf if self.fs is None else np.pi * self.fs

    def loop_frequency(self, w: ArrayLike) -> np.ndarray:
        """Physical frequency [rad/s] -> the loop variable (warped for a sampled loop;
        Nyquist -> ``inf``).

        Parameters
        ----------
        w : array_like
            Physical frequencies [rad/s], at most Nyquist for a sampled loop.

        Returns
        -------
        numpy.ndarray
        """
        w = np.asarray(w, float)
        if self.fs is None:
            return w
        with np.errstate(over="ignore"):
            return np.where(w >= self.nyquist_rad_s, np.inf, warp(np.minimum(w, self.nyquist_rad_s), self.fs))

    def physical(self, nu: ArrayLike) -> np.ndarray:
        """The loop variable -> physical frequency [rad/s] (``inf`` -> Nyquist).

        Parameters
        ----------
        nu : array_like

        Returns
        -------
        numpy.ndarray
        """
        nu = np.asarray(nu, float)
        return nu if self.fs is None else unwarp(nu, self.fs)

    def response(self, nu: ArrayLike) -> np.ndarray:
        """The loop plant's frequency response at ``j nu`` (``nu = inf``: its limit).

        Parameters
        ----------
        nu : array_like
            Loop-variable frequencies (``inf`` allowed).

        Returns
        -------
        numpy.ndarray
            Complex.
        """
        nu = np.atleast_1d(np.asarray(nu, float))
        out = np.empty(nu.shape, complex)
        fin = np.isfinite(nu)
        with np.errstate(all="ignore"):
            out[fin] = self.plant.freqresp(nu[fin])
        B, A = self.plant.B, self.plant.A
        out[~fin] = B[0] / A[0] if len(B) == len(A) else 0.0
        return out

    def dc(self) -> tuple[float, float]:
        """``(D(0), D'(0))`` of the loop plant (``D'`` with respect to the loop variable).

        Returns
        -------
        (float, float)
            ``inf`` for a plant with a pole at 0.
        """
        B, A = self.plant.B, self.plant.A
        a0, a1 = A[-1], (A[-2] if len(A) > 1 else 0.0)
        b0, b1 = B[-1], (B[-2] if len(B) > 1 else 0.0)
        if a0 == 0:
            return np.inf, np.inf
        return float(b0 / a0), float((b1 * a0 - b0 * a1) / (a0 * a0))

    @property
    def stable(self) -> bool:
        """Every pole of the loop plant in the open left half-plane (a sampled loop: inside
        the unit circle)."""
        p = self.plant.poles()
        return bool(len(p) == 0 or np.max(p.real) < 0)

    @property
    def temperature_C(self):
        """The model's temperature [°C]."""
        return self.model.temperature_C

    @property
    def label(self):
        """The model's label."""
        return self.model.label


def loop_plants(problem: Problem, models: list[Plant] | None = None,
                family: PlantFamily | None = None) -> list[LoopPlant]:
    """Every model's loops: the continuous one, and the sampled one when the problem names a
    sample rate.

    Parameters
    ----------
    problem : Problem
        The problem (its family and sample rate).
    models : list of Plant, optional
        The models (default: the family's members).
    family : PlantFamily, optional
        The family whose memo holds the sampled plants (default: the problem's).

    Returns
    -------
    list of LoopPlant
        The continuous loops in the models' order, then the sampled ones.
    """
    family = problem.family if family is None else family
    models = list(family.models if models is None else models)
    out = [LoopPlant(m, m) for m in models]
    sp = problem.specs
    if sp.sampled:
        fs, k = sp.sample_rate_hz, sp.delay_samples
        for m in models:
            try:
                ps = family.sampled(m, fs, k)
            except AttributeError:          # not a PlantFamily: no memo
                ps = sampled_plant(m, fs, k)
            out.append(LoopPlant(m, ps, fs))
    return out


def expressed_specs(specs: Specs) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The specs the discs express and the given ones they do not.

    Parameters
    ----------
    specs : Specs

    Returns
    -------
    (tuple of str, tuple of str)
        Spec keys given and expressed; given and not expressed (the default damping floor
        is not listed: it is not given).
    """
    given = [k for k in EXPRESSED if getattr(specs, k) is not None]
    lost = [k for k in NOT_EXPRESSED if getattr(specs, k) not in (None, False, 0, 0.0)]
    return tuple(given), tuple(lost)


@dataclass(frozen=True, eq=False)
class Discs:
    """The two discs of a loop on a set of frequencies.

    Parameters
    ----------
    w_rad_s : numpy.ndarray
        Physical frequencies [rad/s] (Nyquist for ``nu = inf``).
    nu : numpy.ndarray
        The loop variable at each (``w_rad_s`` itself for the continuous loop).
    D : numpy.ndarray
        The loop plant's response there.
    S_terms : dict
        Spec key -> radius around 1 it sets (``Ms_max``, ``Msd_max``).
    T_terms : dict
        Spec key -> radius around 0 it sets (``Mt_max``, ``T_resonance_max``, ``Mu_max``,
        ``Mu_hf_max``); ``inf`` where a spec does not apply.

    Attributes
    ----------
    r_S, r_T : numpy.ndarray
        The radii (``inf`` where nothing bounds).
    gap : numpy.ndarray
        ``1 - r_S - r_T``: positive where the discs do not meet.
    """

    w_rad_s: np.ndarray
    nu: np.ndarray
    D: np.ndarray
    S_terms: dict
    T_terms: dict

    @property
    def r_S(self):
        """Radius of the disc around 1 at each frequency (``inf``: none)."""
        return _least(self.S_terms, len(self.nu))

    @property
    def r_T(self):
        """Radius of the disc around 0 at each frequency (``inf``: none)."""
        return _least(self.T_terms, len(self.nu))

    @property
    def gap(self):
        """``1 - r_S - r_T`` (positive: the discs do not meet)."""
        with np.errstate(invalid="ignore"):
            return 1.0 - self.r_S - self.r_T

    def active(self, i: int) -> tuple[str, ...]:
        """The spec keys that set the two radii at frequency ``i``.

        Parameters
        ----------
        i : int

        Returns
        -------
        tuple of str
        """
        out = []
        for terms in (self.S_terms, self.T_terms):
            vals = {k: v[i] for k, v in terms.items() if np.isfinite(v[i])}
            if vals:
                best = min(vals.values())
                out += [k for k, v in vals.items() if v <= best * (1 + 1e-12)]
        return tuple(out)


def _least(terms, n):
    out = np.full(n, np.inf)
    for v in terms.values():
        out = np.fmin(out, v)
    return out


def spec_discs(lp: LoopPlant, w: ArrayLike, specs: Specs, rtol: float = 0.0) -> Discs:
    """The discs the frequency-domain specs set for ``T`` at physical frequencies ``w``.

    Parameters
    ----------
    lp : LoopPlant
        The loop.
    w : array_like
        Physical frequencies [rad/s] (a sampled loop: in ``[0, pi fs]``, Nyquist included).
    specs : Specs
        The bounds.
    rtol : float
        Every bound is widened by ``1 + rtol`` (the certificate's tolerance: a certified
        design meets the widened discs).

    Returns
    -------
    Discs
    """
    w = np.atleast_1d(np.asarray(w, float))
    nu = lp.loop_frequency(w)
    D = lp.response(nu)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        mag = np.abs(D)
    f = 1.0 + rtol
    full = np.ones(len(nu))
    S_terms, T_terms = {}, {}
    if specs.Ms_max is not None:
        S_terms["Ms_max"] = f * specs.Ms_max * full
    if specs.Msd_max is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            S_terms["Msd_max"] = np.where(mag > 0, f * specs.Msd_max / mag, np.inf)
    if specs.Mt_max is not None:
        T_terms["Mt_max"] = f * specs.Mt_max * full
    if specs.T_resonance_max is not None:
        lo, hi = (2 * np.pi * x for x in specs.resonance_band_hz)
        if lp.fs is not None:
            lo, hi = warp_band(lo, hi, lp.fs)
        inside = (nu >= lo) & (nu <= hi)
        T_terms["T_resonance_max"] = np.where(inside, f * specs.T_resonance_max, np.inf)
    if specs.Mu_max is not None:
        T_terms["Mu_max"] = f * specs.Mu_max * mag
    if specs.Mu_hf_max is not None:
        lo = 2 * np.pi * specs.Mu_hf_above_hz
        if lp.fs is not None:
            lo = warp_band(min(lo, lp.nyquist_rad_s), lp.nyquist_rad_s, lp.fs)[0]
        T_terms["Mu_hf_max"] = np.where(nu >= lo, f * specs.Mu_hf_max * mag, np.inf)
    for terms in (S_terms, T_terms):
        for k, v in terms.items():
            terms[k] = np.where(np.isnan(v), np.inf, v)
    return Discs(w_rad_s=lp.physical(nu), nu=nu, D=D, S_terms=S_terms, T_terms=T_terms)


def loop_grid(lp: LoopPlant, n: int, lo: float, hi: float, edges: ArrayLike = ()) -> np.ndarray:
    """A physical frequency grid [rad/s] for one loop: ``n`` log-spaced points in
    ``[lo, hi]`` (a sampled loop: up to Nyquist, Nyquist itself included), dense around
    every lightly damped pole of the model, and the ``edges`` (band ends, corners).

    Parameters
    ----------
    lp : LoopPlant
        The loop.
    n : int
        Log-spaced points.
    lo, hi : float
        Their range [rad/s].
    edges : array_like
        Further frequencies [rad/s] (kept when in range).

    Returns
    -------
    numpy.ndarray
        Increasing, positive; ends with ``pi fs`` for a sampled loop.
    """
    top = min(hi, lp.nyquist_rad_s)
    pts = [np.geomspace(lo, top, n)]
    for r in lp.model.poles():
        wr = abs(r)
        if wr == 0 or r.imag <= 0:
            continue
        z = -r.real / wr
        if z < RESONANCE_DAMPING:
            h = max(z, 1e-4)
            pts.append(wr * (1 + 0.5 * h * np.arange(-10, 11)))
    pts.append(np.asarray(edges, float))
    w = np.concatenate(pts)
    w = w[(w > 0) & (w <= top)]
    if lp.fs is not None:
        w = np.append(w, lp.nyquist_rad_s)
    return np.unique(w)


def integrators_of(problem: Problem) -> int:
    """Roots at ``s = 0`` of the controller's fixed factor ``S_fixed``.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    int
    """
    S = np.asarray(problem.controller.S_total, float)
    nz = np.flatnonzero(S)
    return len(S) - 1 - int(nz[-1]) if len(nz) else 0
