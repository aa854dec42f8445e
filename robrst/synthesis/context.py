"""What every solve of one problem shares: scaling, parametrisation, grids, setups.

:class:`Context` is built once per problem (and per controller degree of the
homotopy): the frequency scaling ``w0`` (of the start's closed-loop polynomial), the
decision-vector parametrisation, the frequency grid, the sampled-loop plants, and
:meth:`Context.setup` turns a list of models and a grid into the numeric
:class:`~robrst.synthesis._nlp.NLPSetup` of one program.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core.peaks import peak_gain
from robrst.core.sampled import warp
from robrst.problem.specs import SPEC_TABLE
from robrst.synthesis._nlp import PEAK_KEYS, NLPSetup, Region, scale_plant
from robrst.synthesis.parametrize import (Parametrization, TrackingRule, frequency_grid,
                                          integral_gain)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.plant import Plant
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem, SolverOptions
    from robrst.synthesis.analytic import AnalyticDesign

__all__ = ["Context", "BOUND_MARGIN", "FREE_MARGIN", "ipopt_options", "CTRL_POLE_RATIO",
           "CTRL_POLE_SLACK", "low_frequency_coefficient", "controller_strip", "strip_note"]

BOUND_MARGIN = 0.9995   # grid constraints just inside the specs (half the certificate tolerance)
FREE_MARGIN = 0.98      # freely placed poles: sharp resonances move between the models
CTRL_POLE_RATIO = 0.1   # max_integral_gain: controller poles at Re s <= -0.1 |slowest dominant|
CTRL_POLE_SLACK = 0.02  # ... a pole this share short of the strip's edge is on it (IPOPT's
#                         tolerances; the global phase's screen slack)
CTRL_MAX = 30.0         # free placement: controller poles at Re s >= -30 |fastest start root|
REGION_MARGIN = 1e-3    # the program's damping floor just inside the certificate's
HF_POINTS = 40          # points of the high-frequency |U| band up to the grid's end (and to Nyquist)


def ipopt_options(so: SolverOptions) -> dict:
    """IPOPT options of the problem's solver settings.

    Parameters
    ----------
    so : SolverOptions
        The problem's solver options (``max_iter``, ``ipopt_tol``).

    Returns
    -------
    dict
        Options for CasADi's ``nlpsol("ipopt")``.
    """
    return {"max_iter": so.max_iter, "tol": so.ipopt_tol, "print_level": 0,
            "sb": "yes", "mu_strategy": "monotone", "nlp_scaling_method": "none"}


def low_frequency_coefficient(a: ArrayLike) -> float:
    """The lowest nonzero coefficient of ``a`` (``a(0)``, or that of ``a / s^k`` for a
    polynomial with ``k`` roots at the origin); 0 for the zero polynomial.

    Parameters
    ----------
    a : array_like
        Coefficients, highest power first.

    Returns
    -------
    float

    Examples
    --------
    >>> from robrst.synthesis.context import low_frequency_coefficient
    >>> low_frequency_coefficient([1.0, 3.0, 0.0, 0.0])      # s^3 + 3 s^2 = s^2 (s + 3)
    3.0
    """
    nz = np.flatnonzero(np.asarray(a, float))
    return float(a[nz[-1]]) if nz.size else 0.0


def controller_strip(problem: Problem) -> float:
    """The edge of the controller-pole strip of ``max_integral_gain`` [rad/s]: every
    controller pole but the integrators at ``Re p <= -strip``, ``CTRL_POLE_RATIO`` times
    the slowest dominant pole (with freely placed poles, the slowest the solver bounds
    allow).  Without it a slow controller pole, a lag ``(s + a)/(s + b)``, multiplies the
    integral gain ``lim s K(s)`` by ``a/b`` without limit and buys no integral action
    between ``b`` and ``a``.

    Parameters
    ----------
    problem : Problem
        The problem (its poles and solver bounds).

    Returns
    -------
    float
    """
    slow = float(np.min(np.abs(problem.poles.dominant())))
    so = problem.solver
    if so.free_poles:
        slow = min(slow, so.wn_bounds[0] * min(1.0, so.zeta_bounds[0]))
    return CTRL_POLE_RATIO * slow


def strip_note(problem: Problem, ctrl: RSTController) -> str | None:
    """Why the integral gain of ``ctrl`` does not count (``max_integral_gain``): its
    slowest pole (its integrators aside) lies outside the strip of :func:`controller_strip`
    by more than ``CTRL_POLE_SLACK`` of its edge; ``None`` when it counts (or for another
    objective).

    Parameters
    ----------
    problem : Problem
        The problem.
    ctrl : RSTController
        A continuous controller.

    Returns
    -------
    str or None

    Examples
    --------
    >>> from robrst import load_problem
    >>> from robrst.core.rst import RSTController
    >>> from robrst.synthesis.context import controller_strip, strip_note
    >>> pr = load_problem("paper_robust")
    >>> round(controller_strip(pr), 6)
    15.0
    >>> strip_note(pr, RSTController(R=[1.0, 1.0], S=[1.0, 7.5, 0.0], T=[1.0]))[:34]
    'a controller pole at Re p = -7.5 r'
    >>> strip_note(pr, RSTController(R=[1.0, 1.0], S=[1.0, 30.0, 0.0], T=[1.0])) is None
    True
    """
    S = np.trim_zeros(np.asarray(ctrl.S, float), "b")     # the integrators aside
    if problem.solver.objective != "max_integral_gain" or len(S) < 2:
        return None
    edge, slowest = controller_strip(problem), float(np.max(np.roots(S).real))
    if slowest <= -edge * (1.0 - CTRL_POLE_SLACK):
        return None
    return (f"a controller pole at Re p = {slowest:.4g} rad/s, outside the program's strip"
            f" (Re p <= -{edge:.4g} rad/s): its integral gain is a lag's and is not counted")


@dataclass(frozen=True, eq=False)
class Context:
    """Per-problem data of the synthesis (see the module docstring).

    Parameters
    ----------
    problem : Problem
        The problem.
    param : Parametrization
        The decision vector's degrees, factors and scaling.
    tracking : TrackingRule
        T from R.
    nu : numpy.ndarray
        The physical frequency grid [rad/s].
    Am : numpy.ndarray
        The start's closed-loop polynomial (in s).
    sign : float
        Sign of the integral gain of a stabilising controller.
    ctrl_shift : float
        Scaled: the controller's slow poles stay at ``Re p <= -ctrl_shift``.
    ctrl_max : float
        Scaled: controller poles no faster than this (free placement).
    ipopt : dict
        IPOPT options.
    extra_degree : int
        The degree of this context (the homotopy's lower degrees have their own).
    free_margin : float
        The grid constraints' share of the bounds with every coefficient free
        (``FREE_MARGIN``; the global phase polishes at ``BOUND_MARGIN``).

    Attributes
    ----------
    w0 : float
        The frequency scale [rad/s].
    """

    problem: Problem
    param: Parametrization
    tracking: TrackingRule
    nu: np.ndarray             # physical frequency grid [rad/s]
    Am: np.ndarray             # the start's closed-loop polynomial (in s)
    sign: float
    ctrl_shift: float          # scaled
    ctrl_max: float            # scaled: controller poles no faster than this (free placement)
    ipopt: dict
    extra_degree: int = 0
    free_margin: float = FREE_MARGIN

    @classmethod
    def of(cls, problem: Problem, start: AnalyticDesign, extra_degree: int | None = None) -> Context:
        """The context of ``problem`` around the analytic design ``start``.

        Parameters
        ----------
        problem : Problem
            The problem.
        start : AnalyticDesign
            The analytic design at the problem's poles.
        extra_degree : int, optional
            Overrides the structure's (the homotopy's lower degrees).

        Returns
        -------
        Context
        """
        so = problem.solver
        sc = poly.Scaling.natural(start.Am)
        ref = problem.family.reference_model
        param = Parametrization.of(problem.controller, ref, sc, extra_degree)
        tracking = TrackingRule(problem.controller.T_mode, problem.controller.T_zeros, ref.B)
        # the integral gain of a stabilising low-gain integral action has the sign of D(0),
        # for a plant with integrators the sign of (s^k D)(0)
        ki = integral_gain(start.controller)
        a0 = low_frequency_coefficient(ref.A)
        if a0 != 0 and ref.B[-1] != 0:
            sign = float(np.sign(ref.B[-1] / a0))
        else:
            sign = float(np.sign(ki)) if np.isfinite(ki) and ki != 0 else 1.0
        q = poly.trim(start.controller.S)
        q = q[:len(q) - param.integrators] if len(q) > param.integrators else np.ones(1)
        fast = max([float(np.max(np.abs(np.roots(c)))) for c in (q, start.Am) if len(c) > 1],
                   default=sc.w0)
        return cls(problem=problem, param=param, tracking=tracking, ctrl_max=CTRL_MAX * fast / sc.w0,
                   nu=frequency_grid(problem.family, start.Am, so.n_freq), Am=start.Am,
                   sign=sign, ctrl_shift=controller_strip(problem) / sc.w0,
                   ipopt=ipopt_options(so),
                   extra_degree=problem.controller.extra_degree if extra_degree is None
                   else extra_degree)

    @property
    def w0(self):
        return self.param.scaling.w0

    def around(self, ctrl: RSTController) -> Context:
        """This context rescaled around the controller ``ctrl``: its scaling and grid from
        ``ctrl``'s nominal closed-loop polynomial, the same program otherwise (the
        controller strip kept in rad/s).  A program polished from a point far from the
        start (a global-phase candidate) is then well scaled there.

        Parameters
        ----------
        ctrl : RSTController
            A controller of this context's structure.

        Returns
        -------
        Context
        """
        p = self.problem
        ref = p.family.reference_model
        Am = poly.trim(poly.padd(poly.pmul(ref.A, ctrl.S), poly.pmul(ref.B, ctrl.R)))
        sc = poly.Scaling.natural(Am)
        f = self.w0 / sc.w0
        param = Parametrization.of(p.controller, ref, sc, self.extra_degree)
        return replace(self, param=param, nu=frequency_grid(p.family, Am, p.solver.n_freq),
                       Am=poly.monic(Am), ctrl_shift=self.ctrl_shift * f,
                       ctrl_max=self.ctrl_max * f)

    def sampled(self, model: Plant) -> Plant:
        """The sampled-loop plant of ``model`` (the family's memo).

        Parameters
        ----------
        model : Plant
            A model of the problem's family.

        Returns
        -------
        Plant
        """
        sp = self.problem.specs
        return self.problem.family.sampled(model, sp.sample_rate_hz, sp.delay_samples)

    def default_placement(self) -> str:
        """``"dominant"`` with free poles, else ``"fixed"``.

        Returns
        -------
        str
        """
        return "dominant" if self.problem.solver.free_poles else "fixed"

    def region(self) -> Region | None:
        """The pole region of the program.

        Returns
        -------
        Region or None
            The damping floor (the default floor when ``damping_min`` is not given), the
            scaled decay rate and the controller's damping floor; ``None`` when the specs
            impose none.
        """
        p = self.problem
        sp = p.specs
        floor = p.damping_floor.value
        zeta = None if not floor else min(0.999, floor + REGION_MARGIN)
        sigma = sp.decay_min / self.w0 if sp.decay_min else None
        cz = sp.controller_damping_min
        cz = min(0.999, cz + REGION_MARGIN) if cz else None
        if zeta is None and sigma is None and cz is None:
            return None
        return Region(zeta=zeta, sigma=sigma, ctrl_zeta=cz)

    def setup(self, models: Sequence[Plant], nu: np.ndarray, placement: str) -> NLPSetup:
        """The numeric program data for ``models`` on the grid ``nu`` [rad/s].

        Parameters
        ----------
        models : sequence of Plant
            The models of the program (and, for a sampled problem, their sampled loops).
        nu : numpy.ndarray
            The physical grid [rad/s].
        placement : {"fixed", "dominant", "free"}
            The nominal pole placement.

        Returns
        -------
        NLPSetup
        """
        p = self.problem
        sp, so = p.specs, p.solver
        sc, w0 = self.param.scaling, self.w0
        margin = self.free_margin if placement == "free" else BOUND_MARGIN
        # every absolute peak bound of the table (robrst.problem.specs) on its program block
        bounds = {key: None for key in PEAK_KEYS}
        for row in SPEC_TABLE:
            v = getattr(sp, row.key)
            if row.program is not None and row.relative_to is None and v is not None:
                bounds[row.program] = v * margin
        band = np.zeros(0)
        if sp.resonance_band_hz is not None:
            band = np.geomspace(*(2 * np.pi * np.asarray(sp.resonance_band_hz)), 25)
        hf = np.zeros(0)
        if sp.Mu_hf_above_hz is not None:
            lo = 2 * np.pi * sp.Mu_hf_above_hz
            top = max(lo, nu.max())     # dense up to the grid's end, sparse beyond
            hf = np.unique(np.concatenate([np.geomspace(lo, top, HF_POINTS),
                                           np.geomspace(top, top * 1e3, 10)]))
        ref_T = p.family.reference_model.temperature_C
        ref = [m.temperature_C for m in models].index(ref_T)
        bands, hfs, rates = [band / w0] * len(models), [hf / w0] * len(models), ()
        grids = [nu / w0] * len(models)
        if sp.sampled:   # the sampled loops too (exact bilinear equivalent plants)
            fs = sp.sample_rate_hz
            nyq = np.pi * fs
            sampled = [self.sampled(m) for m in models]
            rates = tuple((m.label, fs) for m in sampled)
            below = nu[nu < nyq]          # the physical grid, warped; far points stay far
            grid_s = np.unique(np.concatenate([warp(np.concatenate([below, [0.99 * nyq]]), fs),
                                               nu[nu >= nyq] * 1e2]))
            grids += [grid_s / w0] * len(sampled)
            bands += [warp(np.minimum(band, 0.999 * nyq), fs) / w0] * len(sampled)
            # the sampled loop's |U| rises to Nyquist: as dense below it as the continuous
            hf_s = np.unique(np.concatenate([
                hf[hf < nyq], np.geomspace(min(hf[0], 0.99 * nyq), 0.9999 * nyq, HF_POINTS)])) \
                if hf.size else hf
            hfs += [warp(hf_s, fs) / w0] * len(sampled)
            models = list(models) + sampled
        n_cont = len(models) - (len(rates) if sp.sampled else 0)
        own = {}         # relative bounds: the ratio times each model's own open-loop peak
        for row in SPEC_TABLE:
            v = getattr(sp, row.key)
            if row.relative_to == "open_loop_peak" and v is not None:
                peaks = [peak_gain(m.B, m.A).value for m in models]
                own[row.program] = tuple(v * pk * margin for pk in peaks)
        ms = tuple((m.label, m.temperature_C, *scale_plant(m, sc)) for m in models)
        pb, domr = None, ()
        if placement == "dominant":
            pb = (tuple(v / w0 for v in so.wn_bounds), tuple(so.zeta_bounds))
            domr = tuple(r / w0 for r in p.poles.dominant_real)
        return NLPSetup(w0=w0, models=ms, ref=ref, Sf=self.param.Sf, Rf=self.param.Rf,
                        ks=self.param.ks, kr=self.param.kr, nu=nu / w0, bounds=bounds,
                        objective=so.objective,
                        Am_fixed=sc.normalize(self.Am) if placement == "fixed" else None,
                        pole_bounds=pb, aux_factor=p.poles.aux_factor, n_dom_real=domr,
                        stable_controller=sp.stable_controller, bands=tuple(bands),
                        rates=rates, placement=placement, hf=tuple(hfs),
                        integrators=self.param.integrators, sign=self.sign,
                        ctrl_shift=self.ctrl_shift, ctrl_max=self.ctrl_max,
                        grids=tuple(grids), T_shape=self.T_shape(),
                        fs_of=(None,) * n_cont + (sp.sample_rate_hz,) * (len(ms) - n_cont),
                        region=self.region(), model_bounds=own or None)

    def T_shape(self) -> np.ndarray:
        """The scaled feed-forward shape ``T / R(0)`` of the structure.

        Returns
        -------
        numpy.ndarray
            ``T_shape(0) = 1``.
        """
        c = self.problem.controller
        if c.T_mode == "static" or not c.T_zeros:
            return np.ones(1)
        Bm = poly.from_roots(c.T_zeros)
        return self.param.scaling.apply(Bm) / Bm[-1]

    def full(self, xc: np.ndarray, setup: NLPSetup, wn: float | None = None,
             zeta: float | None = None, gamma: float = 1.0) -> np.ndarray:
        """The full variable vector ``[xc, (wn, zeta), gamma]`` for ``setup``.

        Parameters
        ----------
        xc : numpy.ndarray
            The controller part.
        setup : NLPSetup
            The program (``wn, zeta`` only for the dominant placement).
        wn, zeta : float, optional
            The scaled dominant pair (default the start's).
        gamma : float
            The soft phase's scale.

        Returns
        -------
        numpy.ndarray
        """
        parts = [np.asarray(xc, float)[:self.param.n_x]]
        if setup.placement == "dominant":
            (wl, wh), (zl, zh) = setup.pole_bounds
            p = self.problem.poles
            wn = p.wn / self.w0 if wn is None else wn
            zeta = p.zeta if zeta is None else zeta
            parts.append([min(max(wn, wl), wh), min(max(zeta, zl), zh)])
        parts.append([gamma])
        return np.concatenate(parts)

    def controller(self, x: np.ndarray) -> RSTController:
        """The RST controller of a (full) variable vector.

        Parameters
        ----------
        x : numpy.ndarray
            The variable vector (its controller part is used).

        Returns
        -------
        RSTController
        """
        return self.param.controller(np.asarray(x, float)[:self.param.n_x], self.tracking)
