"""A design problem as frozen typed records: what the problem file says, validated.

:class:`Problem` bundles the plant family (:mod:`robrst.core.family`) with four records:
the controller structure, the closed-loop pole specification, the specs the design
must meet and the solver options.  Problem files are parsed into these records by
:mod:`robrst.problem.files`; a problem can equally be built in Python.  Nothing downstream
sees a dict of options or the raw TOML.
"""

from dataclasses import dataclass, field

import numpy as np

from robrst.base.errors import SpecError

__all__ = ["PoleSpec", "ControllerStructure", "Specs", "SolverOptions", "Problem",
           "PEAK_SPECS", "METHODS", "OBJECTIVES", "T_MODES", "INITS", "PLACEMENTS",
           "HOMOTOPIES", "AUX_MIN_FACTOR"]

METHODS = ("analytic", "nlp", "convex")
OBJECTIVES = ("max_integral_gain", "min_Ms", "feasibility")
T_MODES = ("paper", "static", "cancel_aux", "reference_model")
INITS = ("analytic", "convex")
PLACEMENTS = ("auto", "fixed", "free")
HOMOTOPIES = ("on_failure", "always")
AUX_MIN_FACTOR = 10.0   # auxiliary poles at least this many times faster than the dominant
PEAK_SPECS = {"S": "Ms_max", "T": "Mt_max", "U": "Mu_max"}   # sensitivity -> bound attribute


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

    def dominant(self):
        """The dominant closed-loop roots [rad/s] (complex array).

        Raises
        ------
        SpecError
            Missing, unstable or non-conjugate roots.
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

    ``S = S_fixed * S'`` and ``R = R_fixed * R'`` (coefficients in s, highest power
    first; ``S_fixed`` contains the integrator ``s``); ``extra_degree`` raises
    ``deg S`` above the paper's minimum (free Youla parameter for the NLP);
    ``T_mode`` and ``T_zeros`` choose the feed-forward polynomial T.

    Roll-off: ``deg R <= deg S - relative_degree`` (1: a strictly proper controller),
    and ``roll_off_order`` poles at ``roll_off_hz`` fixed in ``S`` (their order adds to
    the relative degree).  ``T_mode = "reference_model"`` designs T for the reference
    model of ``reference_wn``/``reference_zeta`` (two degrees of freedom, see
    :mod:`robrst.synthesis.tracking`).
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
    """What the closed loop must achieve on every model of the family.

    Peak bounds on ``|S|`` (``Ms_max``), ``|T|`` (``Mt_max``), ``|U|`` [V/µm]
    (``Mu_max``) and on ``|T|`` over ``resonance_band_hz`` (``T_resonance_max``);
    ``stable_controller`` asks for ``S/s`` Hurwitz; with ``sample_rate_hz`` the sampled
    loop (ZOH plant, Tustin controller, ``delay_samples`` of delay) is designed and
    certified as well.  ``Mu_hf_max`` bounds ``|U|`` above ``Mu_hf_above_hz`` (the
    amplifier budget at high frequency).  Time-domain specs (certified on every model
    and the sweep, :mod:`robrst.certificate.steps`): ``overshoot_max_pct`` and
    ``settling_time_max_s`` (2 %) of a reference step, and ``step_u_max_V`` on the peak
    control voltage for a reference step of ``step_um``.  ``None`` means no bound.
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

    @property
    def time_domain(self):
        """True when a time-domain spec is given."""
        return any(v is not None for v in (self.overshoot_max_pct, self.settling_time_max_s,
                                           self.step_u_max_V))

    def without_time_domain(self):
        """These specs without the time-domain ones (what the feedback synthesis certifies)."""
        from dataclasses import replace

        return replace(self, overshoot_max_pct=None, settling_time_max_s=None,
                       step_u_max_V=None)

    def peak_bound(self, name):
        """Bound on the peak of sensitivity ``name`` (S, T or U), or ``None``."""
        return getattr(self, PEAK_SPECS[name])

    @property
    def sampled(self):
        """True when the sampled loop is part of the specs."""
        return self.sample_rate_hz is not None


@dataclass(frozen=True)
class SolverOptions:
    """How the controller is computed and certified (see the problem-file reference).

    ``placement``: ``"fixed"`` keeps the nominal closed-loop poles the [poles] table
    (and ``free_poles``) asks for; ``"free"`` lets every controller coefficient move
    (the pole placement is only a start); ``"auto"`` starts as ``"fixed"`` and frees the
    poles when the specs cannot be met with them.  ``homotopy``: ``"on_failure"``
    solves ``extra_degree - 1`` (recursively) only when the requested degree does not
    certify; ``"always"`` solves every degree from 0 up, each seeded with the one
    below, so more degrees never give a worse certified objective.
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


@dataclass(frozen=True, eq=False)
class Problem:
    """A validated design problem.

    Parameters
    ----------
    name : str
    family : PlantFamily
        The models the design must hold on (a single model is a family of one).
    poles : PoleSpec
    controller : ControllerStructure
    specs : Specs
    solver : SolverOptions
    path : str
        The problem file (``"<python>"`` for problems built in code); relative
        ``compare_with`` paths are resolved against its folder.
    description : str
    plant_name : str or None
        The built-in plant the nominal model came from (e.g. ``"paper"``), if any.
    spread : Spread or None
        The manufacturing spread the design must hold on, with its yield target
        (:mod:`robrst.problem.spread`; a problem file's ``[spread]``).
    scenarios : tuple of PlantFamily
        Further actuators (each with its temperature family) the synthesis must hold on
        besides ``family``: the drawn actuators of a fleet design that bind.
    """

    name: str
    family: object
    poles: PoleSpec = field(default_factory=PoleSpec)
    controller: ControllerStructure = field(default_factory=ControllerStructure)
    specs: Specs = field(default_factory=Specs)
    solver: SolverOptions = field(default_factory=SolverOptions)
    path: str = "<python>"
    description: str = ""
    plant_name: str = None
    spread: object = None
    scenarios: tuple = ()

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
