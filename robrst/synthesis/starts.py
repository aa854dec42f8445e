"""Start points of the robust program, and how good each is before any solve.

Candidates (decision vectors of one :class:`~robrst.synthesis.context.Context`):

* the analytic pole placement at the problem's poles, and — when the nominal poles
  may move — at several other ``(wn, zeta)``;
* seeds handed down (the best point of a previous attempt, the lower-degree optimum
  of the homotopy, embedded by a common factor);
* when every coefficient is free: an integral controller ``ki/s`` with fast roll-off
  poles, its gain chosen on a grid (a low-gain integrator is what keeps a stable plant
  with moving resonances stable; the pole placement cannot reach it), and the analytic
  design at bandwidths around the plant's resonance (``RESONANCE_STARTS``: a loop that
  damps the resonance actively crosses over near it);
* with fixed poles, on demand: the nominal convex (SOCP) design.

:func:`score` rates a start by the worst normalised spec ratio on the grid and the
largest closed-loop spectral abscissa over the models, without solving anything.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core.analysis import spectral_abscissa_many
from robrst.base.errors import RobrstError
from robrst.synthesis import analytic
from robrst.synthesis.context import low_frequency_coefficient
from robrst.synthesis._nlp import closed_loop_maps, objective_rows

if TYPE_CHECKING:
    from robrst.synthesis.context import Context
    from robrst.synthesis._nlp import GridBlock, NLPSetup

__all__ = ["Start", "score", "score_many", "candidates", "abscissa", "integral_seeds",
           "ON_SLOW_POLE"]

ON_SLOW_POLE = "on the plant's slowest pole"   # the name of a PI start with that zero

WN_FACTORS = (1.0, 0.5, 2.0, 0.25)
RESONANCE_STARTS = ((0.5, 0.7), (1.0, 0.7), (2.0, 0.7), (4.0, 0.7), (1.0, 1.0), (2.0, 1.0))
ZETAS = (1.0, 0.7)
KI_GRID = np.geomspace(1e-5, 1.0, 26)     # integral/PI starts: scaled crossover frequencies


@dataclass(frozen=True, eq=False)
class Start:
    """A start point: its name, controller vector, worst grid ratio and spectral abscissa.

    Parameters
    ----------
    name : str
        What the start is (``"analytic"``, ``"PI ..."``, ``"warm"``, ...).
    xc : numpy.ndarray
        The controller part of the decision vector.
    worst : float
        The worst ``|N|/(M |Delta|)`` over the grid constraints.
    abscissa : float
        The largest real part of the closed-loop roots over the models (scaled).
    wn, zeta : float, optional
        The scaled dominant pair (dominant placement).
    gain : float
        Integral/PI starts: their crossover (scaled).

    Attributes
    ----------
    stable : bool
        Every model's closed loop is stable.
    """

    name: str
    xc: np.ndarray
    worst: float
    abscissa: float
    wn: float = None          # scaled, for the dominant placement
    zeta: float = None
    gain: float = 0.0         # the integral gain sign R(0) / (S/s^k)(0) (scaled; 0 if not > 0)

    @property
    def stable(self):
        return self.abscissa < 0

    def key(self) -> tuple[bool, float]:
        """Sort key: stable first, then the smallest worst ratio.

        Returns
        -------
        tuple
        """
        return (not self.stable, self.worst if self.stable else self.abscissa)


def abscissa(setup: NLPSetup, xc: np.ndarray) -> float:
    """Largest real part of the closed-loop roots over every model of ``setup`` (scaled).

    A sampled-loop model whose closed-loop polynomial lost its leading coefficient
    (a pole at ``z = -1``) counts as unstable (``inf``).

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    xc : numpy.ndarray
        The controller part of the decision vector.

    Returns
    -------
    float
    """
    return _abscissae(setup, [xc])[0]


def _abscissae(setup, xcs):
    """:func:`abscissa` of each of the controller vectors ``xcs`` (roots of every model
    and vector computed together)."""
    cl = closed_loop_maps(setup)
    maps = [cl(a, b)[0] for _, _, a, b in setup.models]
    out, Ds, owner = np.full(len(xcs), -np.inf), [], []
    for i, xc in enumerate(xcs):
        mine = _closed_loops(maps, np.asarray(xc, float)[:setup.n_x])
        if mine is None:
            out[i] = np.inf
        else:
            Ds += mine
            owner += [i] * len(mine)
    for i, (sa, _) in zip(owner, spectral_abscissa_many(Ds) if Ds else []):
        out[i] = max(out[i], sa)
    return [float(v) for v in out]


def _closed_loops(maps, xc):
    """The closed-loop polynomials ``Dm xc + Dc`` of every model; ``None`` if one is not
    finite or lost its leading coefficient."""
    out = []
    for Dm, Dc in maps:
        D = Dm @ xc + Dc
        if not np.all(np.isfinite(D)) or D[0] == 0:
            return None
        scaled = poly.Scaling.natural(D).apply(D)     # its own scale: O(1) coefficients
        if abs(scaled[0]) <= 1e-12 * np.max(np.abs(scaled)):
            return None
        out.append(D)
    return out


def score(setup: NLPSetup, blocks: Sequence[GridBlock], name: str, xc: np.ndarray,
          wn: float | None = None, zeta: float | None = None) -> Start:
    """A :class:`Start` for ``xc``: worst ``|N|/(M |Delta|)`` over ``blocks`` and stability.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    blocks : sequence of GridBlock
        The grid constraints.
    name : str
        The start's name.
    xc : numpy.ndarray
        The controller part of the decision vector.
    wn, zeta : float, optional
        The scaled dominant pair.

    Returns
    -------
    Start
    """
    return score_many(setup, blocks, [(name, xc, wn, zeta)])[0]


def score_many(setup: NLPSetup, blocks: Sequence[GridBlock],
               items: Sequence[tuple]) -> list[Start]:
    """:func:`score` of each ``(name, xc, wn, zeta)`` of ``items``, computed together.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    blocks : sequence of GridBlock
        The grid constraints.
    items : sequence of (name, xc, wn, zeta)
        The starts.

    Returns
    -------
    list of Start
        In the order of ``items``.
    """
    if not items:
        return []
    X = np.stack([np.asarray(xc, float)[:setup.n_x] for _, xc, _, _ in items], axis=1)
    # each start's ratios alone (a matrix-vector product each: the same figures as one
    # score at a time, to the last bit), their closed-loop roots together
    worst = [max((float(b.ratio(x).max()) for b in blocks), default=0.0) for x in X.T]
    sa = _abscissae(setup, list(X.T))
    r0, q0, q0c = objective_rows(setup)
    num, den = r0 @ X, q0 @ X + q0c
    gain = np.where((num > 0) & (den > 0), num / np.where(den > 0, den, 1.0), 0.0)
    return [Start(name=name, xc=X[:, i].copy(), worst=worst[i], abscissa=sa[i], wn=wn,
                  zeta=zeta, gain=float(gain[i])) for i, (name, _, wn, zeta) in enumerate(items)]


def _analytic(ctx, spec):
    p = ctx.problem
    structure = replace(p.controller, extra_degree=ctx.extra_degree)
    try:
        d = analytic.pole_placement(p.family.reference_model, spec, structure)
        return ctx.param.vector(d.controller)
    except (RobrstError, ValueError, np.linalg.LinAlgError):
        return None


def _integral(ctx, setup, blocks):
    """:func:`integral_seeds` scored on ``blocks``."""
    return score_many(setup, blocks, [(n, x, None, None) for n, x in integral_seeds(ctx)])


def integral_seeds(ctx: Context, pure: bool = False) -> list[tuple[str, np.ndarray]]:
    """Integral and PI controllers with roll-off poles at ``p = -c`` (scaled), named.

    ``K = kappa (p + z) (p + c)^(kr-1) / (p Sf' (p + c)^ks)``: an integrator (``z``
    far above the crossover) or a PI with its zero at ``z`` (at the crossover, at 0.3 of
    it, or on the plant's slowest stable real pole), the gain set by the loop crossover
    ``wc`` (``K(jw) P(0) ~ wc / jw`` at low frequency), for every ``wc`` of ``KI_GRID``.

    Parameters
    ----------
    ctx : Context
        The synthesis's context (its parametrisation and scaling).
    pure : bool
        Also the pure integrators ``kappa / p`` (R's leading coefficients zero) when ``R``
        may have as many free roots as ``S'`` (there the integral start above is a PI with
        its zero at ``c``, whose proportional gain excites a lightly damped resonance).

    Returns
    -------
    list of (str, numpy.ndarray)
        ``(name, xc)`` in this context's parametrisation; empty unless the controller has
        one integrator and the plant at most one.
    """
    par = ctx.param
    if par.integrators != 1:
        return []
    ref = ctx.problem.family.reference_model
    plant_int = len(ref.A) - 1 - int(np.flatnonzero(ref.A)[-1])   # integrators of the plant
    if plant_int > 1 or ref.B[-1] == 0:
        return []
    dc = ref.B[-1] / low_frequency_coefficient(ref.A)   # D(0), or (s D)(0) if integrating
    c = 3.0
    sp = np.poly(-c * np.ones(par.ks)) if par.ks else np.ones(1)
    sfr = par.Sf[:-1]                                  # Sf / p (scaled)
    # the slowest stable real pole of the plant: a PI zero on it leaves K P ~ wc / jw above it
    reals = [-r.real / ctx.w0 for r in np.roots(ref.A) if r.imag == 0 and r.real < 0]
    slow = min(reals) if reals and not plant_int else None
    pure = pure and par.kr > par.ks
    items = []
    for wc in KI_GRID:
        zeros = (None, 1.0, 0.3) + ((slow / wc,) if slow is not None and slow < 0.3 * wc else ())
        zeros = (("pure",) if pure else ()) + zeros
        for zf in zeros:                               # integral; PI zeros at wc, 0.3 wc, pole
            if zf == "pure":
                if plant_int:
                    continue
                rp = np.concatenate([np.zeros(par.kr - par.ks), sp])
                name = f"integrator (crossover {wc * ctx.w0:.3g} rad/s)"
            elif zf is None or par.kr < 1:
                if plant_int:                          # I on an integrator: no phase margin
                    continue
                rp = np.poly(-c * np.ones(par.kr)) if par.kr else np.ones(1)
                name = f"integral (crossover {wc * ctx.w0:.3g} rad/s)"
            else:
                rp = np.convolve([1.0, zf * wc], np.poly(-c * np.ones(par.kr - 1)))
                name = (f"PI (crossover {wc * ctx.w0:.3g} rad/s, zero at {zf:.3g} of it"
                        + (f", {ON_SLOW_POLE})" if zf not in (1.0, 0.3) else ")"))
            gain0 = rp[-1] * par.Rf[-1] / (sp[-1] * sfr[-1])   # low-frequency K(w0 p) p / kappa
            if plant_int:   # |K P| = 1 at the crossover, K P ~ kappa gain0 dc / (w0 p^2) below
                s = 1j * wc
                k1 = (np.polyval(rp, s) * np.polyval(par.Rf, s)
                      / (np.polyval(sp, s) * np.polyval(par.Sf, s)))
                p1 = np.polyval(ref.B, s * ctx.w0) / np.polyval(ref.A, s * ctx.w0)
                kappa = np.sign(dc * gain0) / abs(k1 * p1)
            else:
                kappa = wc / (dc * gain0)
            items.append((name, np.concatenate([sp[1:], kappa * rp])))
    return items


def _resonance(plant):
    """The largest natural frequency of the plant's complex poles [rad/s] (``None``: none)."""
    p = np.roots(plant.A)
    c = p[np.abs(p.imag) > 1e-9 * np.abs(p)]
    return float(np.max(np.abs(c))) if c.size else None


def _boldest(starts):
    """The start with the highest crossover that meets the specs on the grid with 10 %
    to spare (closest to a ``max_integral_gain`` optimum), else the most robust one."""
    ok = [s for s in starts if s.stable and s.worst <= 0.9]
    return max(ok, key=lambda s: s.gain) if ok else min(starts, key=Start.key)


def candidates(ctx: Context, setup: NLPSetup, blocks: Sequence[GridBlock],
               seeds: Sequence[tuple] = (), convex: bool = False) -> list[Start]:
    """Scored start points for ``setup``, best first (see the module docstring).

    Parameters
    ----------
    ctx : Context
        The synthesis's context.
    setup : NLPSetup
        The program's data.
    blocks : sequence of GridBlock
        The grid constraints.
    seeds : sequence of tuple
        ``(name, xc)`` or ``(name, xc, wn, zeta)`` (scaled ``wn``) of this context's
        parametrisation.
    convex : bool
        Also start from the nominal SOCP's solution.

    Returns
    -------
    list of Start
        Stable first, then by the worst ratio.
    """
    p = ctx.problem
    items = [(*sd, None, None)[:4] for sd in seeds if sd[1] is not None]
    x = _analytic(ctx, p.poles)
    if x is not None:
        wn = None if p.poles.wn is None else p.poles.wn / ctx.w0
        items.append(("analytic", x, wn, p.poles.zeta))
    if setup.placement != "fixed" and p.poles.dominant_roots is None:
        lo, hi = (p.solver.wn_bounds or (0.0, np.inf)) if setup.placement == "dominant" \
            else (0.0, np.inf)
        zlo, zhi = (p.solver.zeta_bounds or (0.0, np.inf)) if setup.placement == "dominant" \
            else (0.0, np.inf)
        for f in WN_FACTORS:
            for z in ZETAS:
                wn = min(max(p.poles.wn * f, lo), hi)
                z = min(max(z, zlo), zhi)
                if (f, z) == (1.0, p.poles.zeta):
                    continue
                x = _analytic(ctx, replace(p.poles, wn=wn, zeta=z))
                if x is not None:
                    items.append((f"analytic wn={wn:.4g} zeta={z:g}", x, wn / ctx.w0, z))
    if setup.placement == "free" and p.poles.dominant_roots is None:
        # every coefficient free: the analytic design at bandwidths around the plant's
        # resonance too (a loop that damps the resonance actively crosses over near it)
        for f, z in RESONANCE_STARTS:
            wr = _resonance(p.family.reference_model)
            if wr is None:
                break
            x = _analytic(ctx, replace(p.poles, wn=f * wr, zeta=z, dominant_real=()))
            if x is not None:
                items.append((f"analytic wn={f * wr:.4g} zeta={z:g} (resonance x {f:g})", x,
                              f * wr / ctx.w0, z))
    out = score_many(setup, blocks, items)
    if setup.placement == "free":
        ints = _integral(ctx, setup, blocks)
        if ints:
            classic = [s for s in ints if ON_SLOW_POLE not in s.name]
            best = min(classic or ints, key=Start.key)
            out.append(best)
            for bold in (_boldest(ints), _boldest(classic) if classic else None):
                if bold is not None and all(bold is not s for s in out):
                    out.append(bold)     # the boldest, and the boldest without the pole zero
    if convex and setup.placement == "fixed":
        out.extend(_convex(ctx, setup, blocks))
    return sorted(out, key=Start.key)


def _convex(ctx, setup, blocks):
    from robrst.synthesis.convex import solve_convex   # cvxpy: only when asked for

    try:
        x, _ = solve_convex(ctx.problem, ctx.Am, ctx.param, setup.nu, "feasibility")
    except RobrstError:
        return []
    return [score(setup, blocks, "convex (nominal SOCP)", x)]
