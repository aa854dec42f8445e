"""A design problem as frozen typed records: what the problem file says, validated.

:class:`Problem` bundles the plant family (:mod:`robrst.core.family`) with four records:
the controller structure, the closed-loop pole specification, the specs the design
must meet and the solver options.  Problem files are parsed into these records by
:mod:`robrst.problem.files`; a problem can equally be built in Python.  Nothing downstream
sees a dict of options or the raw TOML.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.problem.specs import (EXTRA_PEAK_SPECS, PEAK_SPECS, RELATIVE_PEAK_SPECS, SPEC_TABLE,
                                  SPECS_BY_KEY, bound_specs)

if TYPE_CHECKING:
    from robrst.core.family import PlantFamily
    from robrst.problem.spread import Spread

__all__ = ["PoleSpec", "ControllerStructure", "Specs", "SolverOptions", "Problem",
           "PEAK_SPECS", "EXTRA_PEAK_SPECS", "METHODS", "OBJECTIVES", "T_MODES", "INITS",
           "PLACEMENTS", "HOMOTOPIES", "AUX_MIN_FACTOR", "DEFAULT_DAMPING_CAP",
           "DEFAULT_DAMPING_SHARE", "DEFAULT_OVERSHOOT_WARN_PCT", "RESONANT_DAMPING",
           "RELATIVE_PEAK_SPECS",
           "DampingFloor", "plant_damping", "with_defaults", "default_notes"]

METHODS = ("analytic", "nlp", "convex")
OBJECTIVES = ("max_integral_gain", "min_Ms", "feasibility")
T_MODES = ("paper", "static", "cancel_aux", "reference_model")
INITS = ("analytic", "convex")
PLACEMENTS = ("auto", "fixed", "free")
HOMOTOPIES = ("on_failure", "always")
AUX_MIN_FACTOR = 10.0   # auxiliary poles at least this many times faster than the dominant
DEFAULT_DAMPING_CAP = 0.1       # default closed-loop damping floor: at most this ...
DEFAULT_DAMPING_SHARE = 1.0     # ... and at most this share of the plant's least damping
DEFAULT_OVERSHOOT_WARN_PCT = 20.0   # reference-step overshoot that earns a warning
RESONANT_DAMPING = 2 ** -0.5    # a mode damped less than this has a resonant peak in |B/A|


def plant_damping(family: PlantFamily) -> float:
    """The least damping ``-Re p / |p|`` of a complex pole of any member of ``family``
    (1.0 when no member has a complex pole).

    Parameters
    ----------
    family : PlantFamily

    Returns
    -------
    float
    """
    out = 1.0
    for m in family.models:
        p = np.asarray(m.poles(), complex)
        w = np.abs(p)
        cplx = (np.abs(p.imag) > 1e-9 * w) & (w > 0)
        if np.any(cplx):
            out = min(out, float(np.min(-p.real[cplx] / w[cplx])))
    return out


@dataclass(frozen=True)
class DampingFloor:
    """The closed-loop damping floor of a problem, resolved once
    (:attr:`Problem.damping_floor`, from :meth:`Specs.damping_floor`).

    Parameters
    ----------
    value : float or None
        The floor (``None``: no floor).
    source : {"specs", "default"}
        Given by ``damping_min``, or the default on the family's own damping.
    """

    value: float | None
    source: str


@dataclass(frozen=True)
class PoleSpec:
    """Closed-loop pole specification ``Am = Am_dom * Am_aux``.

    Parameters
    ----------
    wn : float
        Natural frequency of the dominant pair [rad/s] (ignored if ``dominant_roots``).
    zeta : float
        Damping of the dominant pair.
    dominant_real : tuple of float
        Extra dominant real poles [rad/s, negative].
    dominant_roots : tuple of complex or None
        Explicit dominant roots (replaces ``wn``/``zeta``/``dominant_real``).
    aux_factor : float
        Auxiliary poles, unless given, are all at ``-aux_factor * |fastest dominant|``.
    aux_roots : tuple of complex or None
        Explicit auxiliary roots; each must be >= 10x faster than the dominant ones.
    """

    wn: float = None
    zeta: float = None
    dominant_real: tuple = ()
    dominant_roots: tuple = None
    aux_factor: float = 10.0
    aux_roots: tuple = None

    def dominant(self) -> np.ndarray:
        """The dominant closed-loop roots [rad/s] (complex array).

        Returns
        -------
        numpy.ndarray
            The pair of ``wn, zeta`` (two real roots for ``zeta >= 1``) and
            ``dominant_real``, or the explicit ``dominant_roots``.

        Raises
        ------
        SpecError
            Missing, unstable or non-conjugate roots.

        Examples
        --------
        >>> from robrst.problem.records import PoleSpec
        >>> PoleSpec(wn=600.0, zeta=1.0).dominant().real.tolist()
        [-600.0, -600.0]
        """
        if self.dominant_roots is not None:
            roots = np.asarray(self.dominant_roots, dtype=complex)
            cplx = roots[roots.imag != 0]
            if np.sort_complex(cplx).tolist() != np.sort_complex(cplx.conj()).tolist():
                raise SpecError("poles: explicit dominant roots must come in conjugate pairs"
                                f" (every a+bj with its a-bj), got {roots.tolist()}")
        else:
            if self.wn is None or self.zeta is None:
                raise SpecError("poles: give either 'dominant_roots' or both 'wn' and 'zeta'")
            if not self.wn > 0 or not self.zeta > 0:
                raise SpecError(
                    f"poles: wn = {self.wn} and zeta = {self.zeta} must be > 0 (stable poles)"
                )
            wn, z = float(self.wn), float(self.zeta)
            if z < 1:
                wd = wn * np.sqrt(1 - z * z)
                pair = [-z * wn + 1j * wd, -z * wn - 1j * wd]
            else:
                d = wn * np.sqrt(z * z - 1)
                pair = [-z * wn + d, -z * wn - d]
            roots = np.concatenate([pair, np.asarray(self.dominant_real, dtype=complex)])
        if np.any(roots.real >= 0):
            raise SpecError(
                f"poles: dominant roots must be in the open left half-plane, got {roots.tolist()}"
            )
        return roots


@dataclass(frozen=True)
class ControllerStructure:
    """Fixed parts and degrees of the RST controller ``S u = T yr - R y``.

    Parameters
    ----------
    S_fixed : tuple of float
        Fixed factor of ``S = S_fixed S'`` (coefficients in s, highest power first; must
        contain the integrator ``s``).
    R_fixed : tuple of float
        Fixed factor of ``R = R_fixed R'`` (e.g. a roll-off).
    extra_degree : int
        Degrees of ``S`` above the paper's minimum (free Youla parameter for the NLP).
    T_mode : {"paper", "static", "cancel_aux", "reference_model"}
        How the feed-forward polynomial T is chosen: ``T = Bm_aux`` with ``T(0) = R(0)``
        (the paper), ``T = Am(0)/B(0)``, T cancelling ``Am_aux``, or a designed reference
        model (two degrees of freedom, :mod:`robrst.synthesis.tracking`).
    T_zeros : tuple of float
        Zeros of ``T = Bm_aux`` [rad/s] (``T_mode = "paper"``).
    relative_degree : int
        ``deg R <= deg S - relative_degree`` (1: a strictly proper controller).
    roll_off_order : int
        Poles of a fixed roll-off factor ``(s/wc + 1)**order`` in S (adds to the
        relative degree).
    roll_off_hz : float, optional
        Its corner ``wc / 2 pi`` [Hz].
    reference_wn : float, optional
        Bandwidth of the reference model [rad/s] (``T_mode = "reference_model"``).
    reference_zeta : float
        Damping of the reference model.
    T_cancel_damping : float
        T cancels nominal closed-loop factors damped at least this much
        (``T_mode = "reference_model"``).

    Attributes
    ----------
    S_total : numpy.ndarray
        ``S_fixed`` times the fixed roll-off factor.
    controller_relative_degree : int
        Required ``deg S - deg R`` of the controller.
    """

    S_fixed: tuple = (1.0, 0.0)
    R_fixed: tuple = (1.0,)
    extra_degree: int = 0
    T_mode: str = "paper"
    T_zeros: tuple = ()
    relative_degree: int = 0
    roll_off_order: int = 0
    roll_off_hz: float = None
    reference_wn: float = None
    reference_zeta: float = 1.0
    T_cancel_damping: float = 0.5

    @property
    def S_total(self):
        """``S_fixed`` times the fixed roll-off factor ``(s/wc + 1)**roll_off_order``."""
        S = np.asarray(self.S_fixed, float)
        if self.roll_off_order:
            wc = 2 * np.pi * self.roll_off_hz
            for _ in range(self.roll_off_order):
                S = np.convolve(S, [1.0 / wc, 1.0])
        return S

    @property
    def controller_relative_degree(self):
        """Required ``deg S - deg R`` of the controller."""
        return int(self.relative_degree) + int(self.roll_off_order)


@dataclass(frozen=True)
class Specs:
    """What the closed loop must achieve on every model of the family (``None``: no bound).

    Parameters
    ----------
    Ms_max : float, optional
        Bound on ``|S|`` (modulus margin >= ``1/Ms_max``).
    Mt_max : float, optional
        Bound on ``|T|``.
    Mu_max : float, optional
        Bound on ``|U|`` [V/µm].
    Mu_reason : str
        Why this ``Mu_max`` (free text).
    T_resonance_max : float, optional
        Bound on ``|T|`` over ``resonance_band_hz``.
    resonance_band_hz : tuple of float, optional
        ``(f_lo, f_hi)`` [Hz].
    stable_controller : bool
        Require ``S/s`` Hurwitz.
    sample_rate_hz : float, optional
        Also design and certify the sampled loop (ZOH plant, Tustin controller) at this
        rate [Hz].
    delay_samples : int
        Computation delay of the sampled loop [samples].
    Mu_hf_max : float, optional
        Bound on ``|U|`` above ``Mu_hf_above_hz`` [V/µm] (the amplifier budget at high
        frequency).
    Mu_hf_above_hz : float, optional
        Where that bound starts [Hz].
    overshoot_max_pct : float, optional
        Overshoot of a reference step [%].
    settling_time_max_s : float, optional
        2 % settling time of a reference step [s].
    step_um : float
        The reference step of ``step_u_max_V`` [µm].
    step_u_max_V : float, optional
        Peak ``|u|`` for a reference step of ``step_um`` [V].
    Msd_max : float, optional
        Bound on the input-disturbance sensitivity ``|B S / Delta|`` [µm/V].
    Mry_max : float, optional
        Bound on the reference-to-output ``|B T / Delta|`` (``Mt_max`` keeps bounding
        ``|B R / Delta|``).
    Msd_rel_max : float, optional
        Bound on the input-disturbance peak ``|B S / Delta|`` relative to the same
        model's open-loop peak ``|B / A|`` (in the sampled loop: its zero-order-hold
        plant's own peak); 1: the controller never amplifies input disturbances beyond
        what the bare actuator does.
    damping_min : float, optional
        Least damping of every closed-loop pole of every model (the sampled loop's poles
        mapped back to s by ``fs ln z``), as MATLAB's ``TuningGoal.Poles``.  ``None``: the
        default floor (:meth:`damping_floor`: the plant's own least damped resonance,
        at most ``DEFAULT_DAMPING_CAP``); 0: none.
    decay_min : float, optional
        Least decay rate ``-Re p`` of every closed-loop pole [rad/s].
    controller_damping_min : float, optional
        Least damping of the controller's own poles.
    off : tuple of str
        Defaults switched off (``false`` in the problem file;
        :data:`robrst.problem.specs.DEFAULTED`).
    defaults : tuple of str
        The specs whose value is a default (:func:`with_defaults`).
    resolved : bool
        The defaults are resolved (:func:`with_defaults` ran).

    Attributes
    ----------
    time_domain : bool
        A time-domain spec is given (certified on every model and the sweep,
        :mod:`robrst.certificate.steps`).
    sampled : bool
        The sampled loop is part of the specs.
    """

    Ms_max: float = None
    Mt_max: float = None
    Mu_max: float = None
    Mu_reason: str = ""
    T_resonance_max: float = None
    resonance_band_hz: tuple = None
    stable_controller: bool = False
    sample_rate_hz: float = None
    delay_samples: int = 0
    Mu_hf_max: float = None
    Mu_hf_above_hz: float = None
    overshoot_max_pct: float = None
    settling_time_max_s: float = None
    step_um: float = 1.0
    step_u_max_V: float = None
    Msd_max: float = None
    Mry_max: float = None
    Msd_rel_max: float = None
    damping_min: float = None
    decay_min: float = None
    controller_damping_min: float = None
    off: tuple = ()
    defaults: tuple = ()
    resolved: bool = False

    def damping_floor(self, family: PlantFamily) -> tuple[float | None, str]:
        """The closed-loop damping floor on ``family``: ``(value, source)``.

        ``source`` is ``"specs"`` (``damping_min`` given; ``value`` ``None`` when it is
        0, no floor), or ``"default"``: ``min(DEFAULT_DAMPING_CAP, DEFAULT_DAMPING_SHARE
        * zeta_plant)`` with ``zeta_plant`` the least damping of a complex pole of any
        family member (:func:`plant_damping`; ``DEFAULT_DAMPING_CAP`` when none has one;
        no default floor when a member has an unstable resonance).

        Parameters
        ----------
        family : PlantFamily

        Returns
        -------
        (float or None, str)
        """
        if self.damping_min is not None:
            source = "default" if "damping_min" in self.defaults else "specs"
            return (self.damping_min if self.damping_min > 0 else None), source
        if "damping_min" in self.off:
            return None, "specs"
        zeta = plant_damping(family)
        if zeta <= 0:          # an unstable resonance: no default floor below it
            return None, "default"
        return min(DEFAULT_DAMPING_CAP, DEFAULT_DAMPING_SHARE * zeta), "default"

    def pole_region(self, family: PlantFamily) -> tuple[float | None, float | None]:
        """The region the closed-loop poles must meet on ``family``.

        Parameters
        ----------
        family : PlantFamily
            The plant family (the default floor depends on its damping).

        Returns
        -------
        (float or None, float or None)
            The damping floor and the decay rate [rad/s] (``None``: no bound).
        """
        floor, _ = self.damping_floor(family)
        return floor, (self.decay_min if self.decay_min else None)

    def extra_peak_bound(self, name: str) -> float | None:
        """Bound on the peak of ``Sd`` (``Msd_max``) or ``Tr`` (``Mry_max``).

        Parameters
        ----------
        name : {"Sd", "Tr"}
            The closed-loop transfer function (:func:`robrst.core.rst.closed_loop`'s name).

        Returns
        -------
        float or None
        """
        return getattr(self, EXTRA_PEAK_SPECS[name])

    def relative_peak_bound(self, name: str) -> float | None:
        """Bound on the peak of ``name`` relative to the model's open-loop peak
        (``Msd_rel_max`` for ``Sd``).

        Parameters
        ----------
        name : {"Sd"}
            The closed-loop transfer function.

        Returns
        -------
        float or None
        """
        key = RELATIVE_PEAK_SPECS.get(name)
        return None if key is None else getattr(self, key)

    @property
    def bounded(self):
        """True when any bound is given (a peak, a band, a time-domain or a pole-region spec):
        what makes the robust program the default method (every bound of
        :data:`robrst.problem.specs.SPEC_TABLE`; a damping floor of 0 is none)."""
        return any(bool(self.damping_min) if s.key == "damping_min"
                   else getattr(self, s.key) is not None
                   for s in bound_specs(loop_figures=False))

    @property
    def time_domain(self):
        """True when a time-domain spec is given."""
        return any(v is not None for v in (self.overshoot_max_pct, self.settling_time_max_s,
                                           self.step_u_max_V))

    def without_time_domain(self) -> Specs:
        """These specs without the time-domain ones (what the feedback synthesis certifies).

        Returns
        -------
        Specs
        """
        from dataclasses import replace

        return replace(self, overshoot_max_pct=None, settling_time_max_s=None,
                       step_u_max_V=None)

    def peak_bound(self, name: str) -> float | None:
        """Bound on the peak of sensitivity ``name`` (S, T or U), or ``None``.

        Parameters
        ----------
        name : {"S", "T", "U"}
            The sensitivity.

        Returns
        -------
        float or None
        """
        return getattr(self, PEAK_SPECS[name])

    @property
    def sampled(self):
        """True when the sampled loop is part of the specs."""
        return self.sample_rate_hz is not None


@dataclass(frozen=True)
class SolverOptions:
    """How the controller is computed and certified (see the problem-file reference).

    Parameters
    ----------
    method : {"analytic", "nlp", "convex"}
        Pole placement, the robust synthesis, or nominal convex shaping.
    objective : {"max_integral_gain", "min_Ms", "feasibility"}
        What the NLP optimises.
    free_poles : bool
        Let ``wn`` and ``zeta`` vary within ``wn_bounds`` and ``zeta_bounds``.
    wn_bounds, zeta_bounds : tuple of float, optional
        ``(lo, hi)``.
    n_freq : int
        Frequency-grid points per model.
    max_rounds : int
        Certification rounds.
    exchange : bool
        Impose the grid by constraint exchange (false: every point in one NLP).
    cert_temperatures : int
        Temperatures of the certification sweep.
    cert_tol : float
        Relative tolerance on certified peaks.
    init : {"analytic", "convex"}
        The NLP's start.
    max_iter : int
        IPOPT iterations.
    ipopt_tol : float
        IPOPT tolerance.
    compare_with : str, optional
        A problem file (relative) whose analytic design is compared.
    placement : {"auto", "fixed", "free"}
        ``"fixed"`` keeps the nominal closed-loop poles the [poles] table (and
        ``free_poles``) asks for; ``"free"`` searches every controller of the structure
        (the global phase, :mod:`robrst.synthesis.search`; the pole placement is only a
        start); ``"auto"`` solves both and keeps the better certified answer.
    homotopy : {"on_failure", "always"}
        ``"on_failure"`` solves ``extra_degree - 1`` (recursively) only when the requested
        degree does not certify; ``"always"`` solves every degree from 0 up, each seeded
        with the one below, so more degrees never give a worse certified objective.
    multistart : bool
        The robust program runs its global phase (every controller of the structure
        searched, the best distinct candidates polished and certified, in process); off:
        one local run from the problem's start (sweeps).
    starts : int
        How many starts beyond the one asked for.
    method_source : {"given", "default", "command line", "infeasible"}
        Who chose ``method`` (see :attr:`method_reason`; ``"infeasible"``: the pipeline,
        after a proof that no linear controller meets the specs).
    edge_runs : bool
        The global phase also searches the controllers whose free ``S`` has one and two
        roots at the controller-pole strip's edge (``max_integral_gain``;
        :class:`robrst.synthesis.search.EdgeSpace`): four CMA-ES runs more (the
        default since 2026-12-07).
    bound : bool
        State the estimate of what any linear controller could reach on the family
        (:mod:`robrst.synthesis.bound`) beside a certified design (a design that is not
        certified always gets it, with the feasibility verdict).
        Distinct candidates of the global phase polished beyond the best (0: no global
        phase).
    method_source : {"given", "default", "command line"}
        Who chose ``method`` (see :attr:`method_reason`).
    """

    method: str = "analytic"
    objective: str = "max_integral_gain"
    free_poles: bool = False
    wn_bounds: tuple = None
    zeta_bounds: tuple = None
    n_freq: int = 120
    max_rounds: int = 6
    exchange: bool = True
    cert_temperatures: int = 35
    cert_tol: float = 1e-3
    init: str = "analytic"
    max_iter: int = 500
    ipopt_tol: float = 1e-9
    compare_with: str = None
    placement: str = "auto"
    homotopy: str = "on_failure"
    multistart: bool = True
    starts: int = 2
    method_source: str = "given"
    bound: bool = True
    edge_runs: bool = True

    @property
    def method_reason(self):
        """Why this method runs, in words."""
        if self.method_source == "default":
            return (f"{self.method}: the default ([solver] method not given; the robust program"
                    " whenever [specs] bounds anything, the analytic design otherwise)")
        if self.method_source == "command line":
            return f"{self.method}: as the command line asks (--method)"
        if self.method_source == "infeasible":
            return (f"{self.method}: the specs are provably infeasible"
                    " (robrst.synthesis.feasibility), the synthesis is skipped")
        return f"{self.method}: as the problem asks ([solver] method)"


@dataclass(frozen=True, eq=False)
class Problem:
    """A validated design problem.

    Parameters
    ----------
    name : str
        The problem's name.
    family : PlantFamily
        The models the design must hold on (a single model is a family of one).
    poles : PoleSpec
        The closed-loop pole specification.
    controller : ControllerStructure
        The controller's fixed parts and degrees.
    specs : Specs
        What the closed loop must achieve.
    solver : SolverOptions
        How the controller is computed and certified.
    path : str
        The problem file (``"<python>"`` for problems built in code); relative
        ``compare_with`` paths are resolved against its folder.
    description : str
        Free text.
    plant_name : str or None
        The built-in plant the nominal model came from (e.g. ``"paper"``), if any.
    spread : Spread or None
        The manufacturing spread the design must hold on, with its yield target
        (:mod:`robrst.problem.spread`; a problem file's ``[spread]``).
    scenarios : tuple of PlantFamily
        Further actuators (each with its temperature family) the synthesis must hold on
        besides ``family``: the drawn actuators of a fleet design that bind.

    Attributes
    ----------
    damping_floor : DampingFloor
        The closed-loop damping floor on ``family``, resolved once.
    families : tuple of PlantFamily
        ``(family, *scenarios)``: every actuator the synthesis holds on.
    needs_scipy : bool
        Designing or certifying this problem uses SciPy's linear algebra (the sampled
        loop, step responses, a designed reference path).

    Examples
    --------
    >>> from robrst import PlantFamily, PoleSpec, Problem, Specs, paper_plant, run_problem
    >>> pr = Problem("mine", PlantFamily(models=(paper_plant().with_label("nominal", 28.0),)),
    ...              poles=PoleSpec(wn=600.0, zeta=1.0), specs=Specs(Ms_max=2.0))
    >>> run_problem(pr).certified
    True
    """

    name: str
    family: PlantFamily
    poles: PoleSpec = field(default_factory=PoleSpec)
    controller: ControllerStructure = field(default_factory=ControllerStructure)
    specs: Specs = field(default_factory=Specs)
    solver: SolverOptions = field(default_factory=SolverOptions)
    path: str = "<python>"
    description: str = ""
    plant_name: str = None
    spread: Spread | None = None
    scenarios: tuple = ()

    @cached_property
    def damping_floor(self) -> DampingFloor:
        """The closed-loop damping floor on this problem's family, resolved once
        (:meth:`Specs.damping_floor`)."""
        return DampingFloor(*self.specs.damping_floor(self.family))

    @property
    def families(self):
        """``(family, *scenarios)``: every actuator the synthesis holds on."""
        return (self.family,) + tuple(self.scenarios)

    @property
    def needs_scipy(self):
        """True when designing or certifying this problem uses SciPy's linear algebra: the
        sampled loop (exact ZOH), step responses (time-domain specs, a designed reference
        path) and the balanced realisations they are computed from."""
        return (self.specs.sampled or self.specs.time_domain
                or self.controller.T_mode == "reference_model")


def with_defaults(problem: Problem) -> Problem:
    """``problem`` with its default specs resolved, once (idempotent).

    A problem whose specs bound anything (:attr:`Specs.bounded`) must also give a
    controller an engineer accepts, so every spec with a ``default_bound`` in
    :data:`robrst.problem.specs.SPEC_TABLE` applies unless the problem gives its own value
    or switches it off (``false``; 0 for ``damping_min``):

    * ``overshoot_max_pct`` = 20 %: the reference step;
    * ``damping_min`` = the plant's least damping (of any family member's resonance), at
      most ``DEFAULT_DAMPING_CAP`` (:meth:`Specs.damping_floor`): no closed-loop pole
      rings longer than the bare actuator (the cap: a well-damped plant does not ask every
      closed-loop pole to be damped as much as it is);
    * ``Msd_rel_max`` = 1: the input-disturbance peak ``|B S/Delta|`` of every model at
      most the model's own open-loop peak ``|B/A|`` (only when every family member is
      stable, an unstable plant having no open-loop peak, and some member has a resonance,
      a mode damped below ``RESONANT_DAMPING``: without one the open-loop peak is the static
      gain, and integral action with a bandwidth below the plant's poles lifts ``|B S/Delta|``
      above it without any ringing; not when the problem gives its own ``Msd_max``).

    Parameters
    ----------
    problem : Problem
        The problem as read.

    Returns
    -------
    Problem
        ``specs.defaults`` names the specs that took their default value,
        ``specs.resolved`` is true.

    Examples
    --------
    >>> from robrst import load_problem
    >>> from robrst.problem.records import with_defaults
    >>> sp = with_defaults(load_problem("paper")).specs
    >>> sp.overshoot_max_pct, sp.Msd_rel_max, sp.defaults
    (20.0, 1.0, ('overshoot_max_pct', 'Msd_rel_max', 'damping_min'))
    """
    from dataclasses import replace

    sp = problem.specs
    if sp.resolved:
        return problem
    changes, used = {"resolved": True}, []
    if sp.bounded:
        stable = None
        for row in SPEC_TABLE:
            if (row.default_bound is None or getattr(sp, row.key) is not None
                    or row.key in sp.off
                    or any(getattr(sp, k) is not None for k in row.default_unless)):
                continue
            if row.default_bound == "plant_damping":
                value, _ = sp.damping_floor(problem.family)
                changes[row.key] = value or 0.0
                if not value:
                    continue
            else:
                if row.relative_to == "open_loop_peak":
                    if stable is None:
                        stable = all(np.all(np.roots(m.A).real < 0)
                                     for f in problem.families for m in f.models) and \
                            any(plant_damping(f) < RESONANT_DAMPING for f in problem.families)
                    if not stable:
                        continue
                changes[row.key] = float(row.default_bound)
            used.append(row.key)
    changes["defaults"] = tuple(used)
    return replace(problem, specs=replace(sp, **changes))


def default_notes(specs: Specs) -> list[str]:
    """One line per default spec that applied (:func:`with_defaults`), with its off switch.

    Parameters
    ----------
    specs : Specs
        Resolved specs.

    Returns
    -------
    list of str
    """
    return ["default: " + SPECS_BY_KEY[k].default_note.format(value=getattr(specs, k))
            for k in specs.defaults]
