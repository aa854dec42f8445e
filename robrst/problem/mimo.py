"""Frozen records of a multi-axis problem: family, structure, specs, solver options.

The specs are declared once in :data:`MIMO_SPECS` (key, figure, closed-loop transfer,
what it bounds, unit, label); the problem file's schema
(:mod:`robrst.problem.mimo_files`), the certificate's bounds
(:mod:`robrst.certificate.mimo`), the program's constraints
(:mod:`robrst.synthesis.mimo_program`) and the reports read that table.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.core.mimo import MimoFamily

if TYPE_CHECKING:
    pass

__all__ = ["MimoSpec", "MIMO_SPECS", "MimoSpecs", "MimoStructure", "MimoSolverOptions",
           "MimoProblem", "DECOUPLERS", "MIMO_METHODS", "MIMO_T_MODES", "spec_row"]


@dataclass(frozen=True)
class MimoSpec:
    """One row of the spec table.

    Parameters
    ----------
    key : str
        The :class:`MimoSpecs` field (and problem-file key) of the bound.
    figure : str
        The certificate's figure it bounds.
    transfer : str
        The closed-loop transfer (:data:`robrst.core.mimo_loop.LOOP_TRANSFERS`).
    kind : {"sigma", "axis", "crosstalk", "sector"}
        ``sigma``: the peak of the largest singular value; ``axis``: every diagonal
        entry's peak; ``crosstalk``: every off-diagonal entry's peak over a band;
        ``sector``: ``sigma_max(Ti) * delta < 1`` (the input-gain deviation ``delta``);
        ``robust``: the ``sigma`` figure of ``transfer`` for every input gain in the
        sector (a small-gain bound, :func:`robrst.certificate.mimo.sector_figures`).
    unit : str
        The bound's unit.
    label : str
        Words for reports.
    """

    key: str
    figure: str
    transfer: str
    kind: str
    unit: str
    label: str


#: the specs of a multi-axis problem, declared once
MIMO_SPECS = (
    MimoSpec("sigma_S_max", "sigma_S", "S", "sigma", "", "largest singular value of S"),
    MimoSpec("sigma_T_max", "sigma_T", "T", "sigma", "", "largest singular value of T"),
    MimoSpec("sigma_U_max", "sigma_U", "U", "sigma", "V/µm",
             "largest singular value of the controller sensitivity K S"),
    MimoSpec("sigma_Sd_max", "sigma_Sd", "Sd", "sigma", "µm/V",
             "largest singular value of the input-disturbance sensitivity S G"),
    MimoSpec("axis_S_max", "axis_S", "S", "axis", "", "peak of |S_ii| on every axis"),
    MimoSpec("axis_T_max", "axis_T", "T", "axis", "", "peak of |T_ii| on every axis"),
    MimoSpec("crosstalk_max", "crosstalk", "Tr", "crosstalk", "",
             "peak of |Tr_ij| (i != j) over crosstalk_band_hz"),
    MimoSpec("input_gain_deviation", "sigma_Ti", "Ti", "sector", "",
             "input gains anywhere in [1 - delta, 1 + delta] (a sector): sigma_max(Ti) <"
             " 1/delta"),
    MimoSpec("sector_S_max", "sector_S", "S", "robust", "",
             "largest singular value of S for every input gain in the sector (needs"
             " input_gain_deviation)"),
    MimoSpec("sector_T_max", "sector_T", "T", "robust", "",
             "largest singular value of T for every input gain in the sector (needs"
             " input_gain_deviation)"),
    MimoSpec("sector_U_max", "sector_U", "U", "robust", "V/µm",
             "largest singular value of K S for every input gain in the sector (needs"
             " input_gain_deviation)"),
)


def spec_row(key: str) -> MimoSpec:
    """The row of :data:`MIMO_SPECS` of a bound or a figure.

    Parameters
    ----------
    key : str
        A bound's key (``"sigma_S_max"``) or a figure (``"sigma_S"``).

    Returns
    -------
    MimoSpec

    Raises
    ------
    KeyError
        Neither.
    """
    for row in MIMO_SPECS:
        if key in (row.key, row.figure):
            return row
    raise KeyError(key)


DECOUPLERS = ("none", "static", "given")
MIMO_METHODS = ("nlp", "per_axis")
MIMO_T_MODES = ("feedback", "static")


@dataclass(frozen=True)
class MimoSpecs:
    """Bounds every model of the family must meet (``None``: not bounded).

    Parameters
    ----------
    sigma_S_max, sigma_T_max, sigma_U_max, sigma_Sd_max : float, optional
        Bounds on the peaks of the largest singular values (:data:`MIMO_SPECS`).
    axis_S_max, axis_T_max : float, optional
        Bounds on every axis's ``|S_ii|`` and ``|T_ii|`` peaks.
    crosstalk_max : float, optional
        Bound on ``|Tr_ij|``, ``i != j``, over ``crosstalk_band_hz``.
    crosstalk_band_hz : (float, float), optional
        The band [Hz] of the crosstalk figure (default: every frequency).
    input_gain_deviation : float, optional
        ``delta`` in ``(0, 1)``: the loop must stay stable for input gains anywhere in
        ``[1 - delta, 1 + delta]`` (time-varying, per input): ``sigma_max(Ti) < 1/delta``.
    sector_S_max, sector_T_max, sector_U_max : float, optional
        Bounds on the largest singular values of ``S``, ``T`` and ``K S`` for every input
        gain in that sector (needs ``input_gain_deviation``; the certificate's small-gain
        bounds, :func:`robrst.certificate.mimo.sector_figures`).
    sample_rate_hz : float, optional
        Also certify (and design) the sampled loop: ZOH plant, Tustin controller.
    delay_samples : int
        Computation delay of the sampled loop [samples].

    Attributes
    ----------
    sampled : bool
        A sampling rate is given.
    bounded : dict
        ``{figure: bound}`` of every bound given (the sector as ``1/delta`` on
        ``sigma_Ti``).

    Raises
    ------
    SpecError
        A bound that is not a positive number, ``input_gain_deviation`` outside
        ``(0, 1)``, a sector bound without it, a band that is not ``0 <= lo < hi``.
    """

    sigma_S_max: float | None = None
    sigma_T_max: float | None = None
    sigma_U_max: float | None = None
    sigma_Sd_max: float | None = None
    axis_S_max: float | None = None
    axis_T_max: float | None = None
    crosstalk_max: float | None = None
    crosstalk_band_hz: tuple | None = None
    input_gain_deviation: float | None = None
    sector_S_max: float | None = None
    sector_T_max: float | None = None
    sector_U_max: float | None = None
    sample_rate_hz: float | None = None
    delay_samples: int = 0

    def __post_init__(self):
        for row in MIMO_SPECS:
            v = getattr(self, row.key)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise SpecError(f"{row.key}: expected a number > 0, got {v}")
        d = self.input_gain_deviation
        if d is not None and not d < 1:
            raise SpecError(f"input_gain_deviation: expected 0 < delta < 1, got {d}")
        robust = [r.key for r in MIMO_SPECS if r.kind == "robust" and getattr(self, r.key)]
        if robust and d is None:
            raise SpecError(f"{robust[0]}: a bound for every input gain in a sector needs"
                            f" input_gain_deviation (the sector's delta)")
        if self.crosstalk_band_hz is not None:
            b = tuple(float(x) for x in self.crosstalk_band_hz)
            if len(b) != 2 or not 0 <= b[0] < b[1]:
                raise SpecError(f"crosstalk_band_hz: expected [lo, hi] with 0 <= lo < hi,"
                                f" got {list(self.crosstalk_band_hz)}")
            object.__setattr__(self, "crosstalk_band_hz", b)
        fs = self.sample_rate_hz
        if fs is not None and not (np.isfinite(fs) and fs > 0):
            raise SpecError(f"sample_rate_hz: expected a number > 0, got {fs}")
        if int(self.delay_samples) != self.delay_samples or self.delay_samples < 0:
            raise SpecError(f"delay_samples: expected a whole number >= 0, got"
                            f" {self.delay_samples}")
        if self.delay_samples and fs is None:
            raise SpecError("delay_samples needs sample_rate_hz")

    @property
    def sampled(self) -> bool:
        return self.sample_rate_hz is not None

    @property
    def bounded(self) -> dict:
        out = {}
        for row in MIMO_SPECS:
            v = getattr(self, row.key)
            if v is not None:
                out[row.figure] = 1.0 / v if row.kind == "sector" else float(v)
        return out

    @property
    def crosstalk_band_rad_s(self) -> tuple[float, float]:
        """The crosstalk band [rad/s] (every frequency when none is given)."""
        if self.crosstalk_band_hz is None:
            return (0.0, np.inf)
        return (2 * np.pi * self.crosstalk_band_hz[0], 2 * np.pi * self.crosstalk_band_hz[1])

    def as_dict(self) -> dict:
        """The specs as a JSON-ready dict (only the keys given).

        Returns
        -------
        dict
        """
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is not None and not (f.name == "delay_samples" and v == 0):
                out[f.name] = list(v) if isinstance(v, tuple) else v
        return out


@dataclass(frozen=True)
class MimoStructure:
    """The decentralised controller: one RST law per axis and a decoupler.

    Parameters
    ----------
    decoupler : {"none", "static", "given"}
        ``static``: ``W`` the real matrix closest to ``G(j 2 pi decoupler_hz)^-1`` of the
        reference model (least squares, :func:`robrst.synthesis.mimo_start.static_decoupler`);
        ``given``: ``W`` (or a dynamic ``W(s)``, :attr:`decoupler_ss`) as stated;
        ``none``: the identity.
    decoupler_hz : float
        Where the static decoupler inverts the plant [Hz].
    W : array_like, optional
        The given static decoupler (``inputs x axes``).
    decoupler_ss : tuple or control.StateSpace, optional
        A given dynamic decoupler ``(A, B, C, D)`` (continuous, stable; a python-control
        system accepted).
    extra_degree : int
        Degree of ``S_i'`` per axis beyond the integrator (room for the program).
    relative_degree : int
        ``deg R_i <= deg S_i - relative_degree``.
    roll_off_order : int
        A fixed roll-off ``(s / w_r + 1)^order`` in every ``S_i``.
    roll_off_hz : float, optional
        Its corner [Hz] (with ``roll_off_order``).
    T_mode : {"feedback", "static"}
        ``feedback``: ``T_i = R_i`` (one degree of freedom: ``Tr = T``); ``static``:
        ``T_i = R_i(0)`` (no controller zeros on the reference path).
    axes : tuple of str
        The axes' names.

    Raises
    ------
    SpecError
        Inconsistent keys.
    """

    decoupler: str = "static"
    decoupler_hz: float = 0.0
    W: np.ndarray | None = None
    decoupler_ss: tuple | None = None
    extra_degree: int = 1
    relative_degree: int = 0
    roll_off_order: int = 0
    roll_off_hz: float | None = None
    T_mode: str = "feedback"
    axes: tuple = ()

    def __post_init__(self):
        if self.decoupler not in DECOUPLERS:
            raise SpecError(f"decoupler {self.decoupler!r}: expected one of"
                            f" {', '.join(DECOUPLERS)}")
        if self.T_mode not in MIMO_T_MODES:
            raise SpecError(f"T_mode {self.T_mode!r}: expected one of"
                            f" {', '.join(MIMO_T_MODES)}")
        given = self.W is not None or self.decoupler_ss is not None
        if (self.decoupler == "given") != given:
            raise SpecError("decoupler = 'given' goes with W (or a dynamic decoupler), and W"
                            " only with decoupler = 'given'")
        if self.W is not None:
            object.__setattr__(self, "W", np.atleast_2d(np.asarray(self.W, float)))
        ss = self.decoupler_ss
        if ss is not None and type(ss).__module__.split(".")[0] == "control":
            if getattr(ss, "dt", 0) not in (0, None):
                raise SpecError("decoupler: a continuous python-control system expected"
                                " (robrst implements it by Tustin at the controller's rate)")
            import control

            ss = control.ss(ss)
            object.__setattr__(self, "decoupler_ss", (ss.A, ss.B, ss.C, ss.D))
        if not 0 <= self.extra_degree <= 12 or not 0 <= self.relative_degree <= 4:
            raise SpecError("extra_degree must be in [0, 12] and relative_degree in [0, 4]")
        if (self.roll_off_order > 0) != (self.roll_off_hz is not None):
            raise SpecError("roll_off_order and roll_off_hz go together")
        if not self.decoupler_hz >= 0:
            raise SpecError(f"decoupler_hz: expected >= 0, got {self.decoupler_hz}")
        object.__setattr__(self, "axes", tuple(self.axes))


@dataclass(frozen=True)
class MimoSolverOptions:
    """How the multi-axis program runs.

    Parameters
    ----------
    method : {"nlp", "per_axis"}
        ``nlp``: the joint robust program over the family (every axis and the coupling
        at once), started from the per-axis designs; ``per_axis``: the per-axis designs
        only (each on its own diagonal channel of the decoupled plant, the coupling
        ignored), certified on the whole loop.
    bandwidth_hz : float, optional
        Crossover of the per-axis start designs [Hz] (default: a tenth of the lowest
        lightly damped resonance, at most ``fs / 40``).
    n_freq : int
        Grid points per model and loop of the program.
    max_rounds : int
        Certification rounds (the grid grows by the certificate's peak frequencies).
    cert_points : int
        Checked points inside each segment between neighbouring models.
    cert_tol : float
        Relative tolerance on the certified bounds.
    max_iter : int
        IPOPT iterations per solve.
    ipopt_tol : float
        IPOPT tolerance.
    multistart : bool
        ``nlp``: also run the global phase (a population search over every axis's law,
        :mod:`robrst.synthesis.mimo_search`), whose best law starts the joint program a
        second time; the better certified answer is kept.  Off by default: it costs
        one to nine times the design's CPU (docs: multi-axis guide).

    Raises
    ------
    SpecError
        An unknown method.
    """

    method: str = "nlp"
    bandwidth_hz: float | None = None
    n_freq: int = 80
    max_rounds: int = 5
    cert_points: int = 2
    cert_tol: float = 1e-3
    max_iter: int = 300
    ipopt_tol: float = 1e-6
    multistart: bool = False

    def __post_init__(self):
        if self.method not in MIMO_METHODS:
            raise SpecError(f"method {self.method!r}: expected one of {', '.join(MIMO_METHODS)}")


@dataclass(frozen=True, eq=False)
class MimoProblem:
    """A multi-axis design problem.

    Parameters
    ----------
    name : str
    family : MimoFamily
        The models the controller must hold on (square: as many inputs as outputs).
    structure : MimoStructure
    specs : MimoSpecs
    solver : MimoSolverOptions
    path : str
        The problem file (``"<api>"`` when built in Python).
    description : str

    Raises
    ------
    SpecError
        A plant that is not square, axes named for another number of outputs, a given
        decoupler of the wrong shape.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoFamily, MimoPlant
    >>> from robrst.problem.mimo import MimoProblem, MimoSpecs
    >>> G = MimoPlant(-np.eye(2), np.eye(2), [[1.0, 0.2], [0.1, 1.0]], np.zeros((2, 2)))
    >>> MimoProblem("stage", MimoFamily((G,)), specs=MimoSpecs(sigma_S_max=2.0)).axes
    ('axis1', 'axis2')
    """

    name: str
    family: MimoFamily
    structure: MimoStructure = field(default_factory=MimoStructure)
    specs: MimoSpecs = field(default_factory=MimoSpecs)
    solver: MimoSolverOptions = field(default_factory=MimoSolverOptions)
    path: str = "<api>"
    description: str = ""

    def __post_init__(self):
        fam = self.family
        if fam.n_in != fam.n_out:
            raise SpecError(f"{self.path}: the plant has {fam.n_in} inputs and {fam.n_out}"
                            " outputs; a decentralised design needs a square plant (as many"
                            " actuators as measured axes)")
        m = fam.n_out
        if self.structure.axes and len(self.structure.axes) != m:
            raise SpecError(f"{self.path}: {len(self.structure.axes)} axis names for {m}"
                            " outputs")
        W = self.structure.W
        if W is not None and W.shape != (m, m):
            raise SpecError(f"{self.path}: the decoupler W is {W.shape[0]} x {W.shape[1]};"
                            f" expected {m} x {m}")
        if self.structure.decoupler_ss is not None:     # shapes and stability, named
            from robrst.core.mimo_loop import MimoController
            from robrst.core.rst import RSTController

            try:
                K = MimoController([RSTController([1.0], [1.0, 0.0], [1.0])] * m,
                                   decoupler_ss=self.structure.decoupler_ss)
            except SpecError as exc:
                raise SpecError(f"{self.path}: {exc}") from None
            if K.n_inputs != fam.n_in:
                raise SpecError(f"{self.path}: the decoupler drives {K.n_inputs} inputs; the"
                                f" plant has {fam.n_in}")

    @property
    def axes(self) -> tuple[str, ...]:
        return self.structure.axes or tuple(f"axis{i + 1}" for i in range(self.family.n_out))
