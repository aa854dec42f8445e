"""One declaration per spec: the table every layer derives its spec lists from.

Each key of a problem file's ``[specs]`` table is one :class:`SpecDef` row of
:data:`SPEC_TABLE`, in the order of the file reference, of
:class:`~robrst.problem.records.Specs` and of the design JSON: the key, the certificate
figure it bounds, the closed-loop transfer function whose peak that figure is, the bound's
direction, the loops it holds on, its unit, its label, the program's constraint block and
its schema (type, range, description).  From the table come

* :class:`~robrst.problem.records.Specs`' ``bounded`` and its peak-bound lookups
  (:data:`PEAK_SPECS`, :data:`EXTRA_PEAK_SPECS`);
* the problem-file schema's ``[specs]`` table (:func:`specs_schema`);
* the certificate's bound tables (:data:`robrst.certificate.models.BOUNDED`,
  ``LOWER_BOUNDED``, ``FIGURE_OF``);
* the synthesis's bounds (:meth:`robrst.synthesis.context.Context.setup`) and the
  multi-start's scaled bounds (:data:`robrst.synthesis.multistart.PEAK_BOUNDS`);
* the default constraints of a bounded problem (:data:`DEFAULTED`, resolved by
  :func:`robrst.problem.records.with_defaults`);
* the JSON's ``specs`` and ``specs_achieved`` (:mod:`robrst.design.contract`), the sweep's
  columns and the report labels.

Adding a spec is a row here, a field of ``Specs`` and its kernel (the figure the
certificate computes, and the program's constraint when it has one).
"""

from __future__ import annotations

from dataclasses import dataclass

from robrst.base.schema import Field

__all__ = ["SpecDef", "SPEC_TABLE", "SPECS_BY_KEY", "PEAK_SPECS", "EXTRA_PEAK_SPECS",
           "RELATIVE_PEAK_SPECS", "DEFAULTED", "bound_specs", "spec", "specs_schema", "LOOPS",
           "BAND_FIELD", "spec_columns", "MAX_RATE", "MIN_RATE", "MIN_RATE_HZ"]

LOOPS = ("continuous", "sampled")
MAX_RATE = 1e9      # fastest pole, zero or frequency [rad/s] (160 MHz)
MIN_RATE = 1e-6     # slowest pole a design places [rad/s] (a period of 72 days)
MIN_RATE_HZ = 1.6e-7   # MIN_RATE / 2 pi, rounded up: slowest corner or sampling rate [Hz]
BAND_FIELD = dict(positive=True, length=2)     # a [lo, hi] pair


@dataclass(frozen=True)
class SpecDef:
    """One key of ``[specs]``: what it bounds and how every layer names it.

    Parameters
    ----------
    key : str
        The key (``"Ms_max"``): a field of :class:`~robrst.problem.records.Specs`.
    field : Field
        Its schema (type, default, description, range).
    bound : {"upper", "lower"} or None
        The figure must stay below (``"upper"``) or above (``"lower"``) the key's value;
        ``None``: an option of other specs (a band, a rate, a step size).
    figure : str or None
        The certificate figure it bounds (a field of
        :class:`~robrst.certificate.figures.LoopFigures`, ``"controller_damping"`` for the
        controller's own poles).
    transfer : str or None
        The closed-loop transfer function whose peak the figure is
        (:func:`robrst.core.rst.closed_loop`'s names ``S, T, U, Sd, Tr``).
    loops : tuple of str
        The loops the bound holds on (``("continuous", "sampled")``: both when the
        specs name a rate; ``()``: not a loop's figure).
    unit : str
        The figure's unit (``""``: none).
    label : str
        The figure in words, for reports (``"|S| peak"``); a violation of the bound is
        named by it (:class:`~robrst.certificate.models.Violation` ``quantity``).
    program : str or None
        The robust program's constraint block (:data:`robrst.synthesis._nlp.PEAK_KEYS`).
    scaled : bool
        The multi-start's relaxed and tightened plans scale it
        (:mod:`robrst.synthesis.multistart`).
    floor : float or None
        The least value a scaled bound may take (``Ms_max`` >= 1).
    column : str or None
        The sweep's column of the worst figure (:mod:`robrst.studies.sweep._evaluate`).
    always_column : bool
        That column is in every sweep's results (else only in a sweep whose problem
        bounds it).
    column_label : str
        The column's axis label in the sweep's figures.
    relative_to : str or None
        The bound is relative: the figure's bound on a model is the key's value times
        that model's own figure named here (``"open_loop_peak"``: the peak of ``|B/A|``
        of the model, of its zero-order-hold plant in the sampled loop).
    published : {"always", "sampled", "given", "time_domain", "with", "never"}
        When the key appears in the design JSON's ``specs``: always; with a sampling rate;
        when given (not ``None``); with any time-domain spec; with the key ``with_key``;
        never.
    with_key : str or None
        The key a ``published = "with"`` key goes with (``resonance_band_hz`` with
        ``T_resonance_max``).
    time_domain : bool
        A reference-step spec (:attr:`~robrst.problem.records.Specs.time_domain`).
    default_bound : float or str or None
        The bound the spec takes by default when the problem bounds anything else
        (:func:`robrst.problem.records.with_defaults`): a number, or ``"plant_damping"``
        (the damping floor of :meth:`~robrst.problem.records.Specs.damping_floor`);
        ``None``: no default.  Such a key also accepts ``false`` (the default switched
        off).
    default_note : str
        What the default asks, for the design's notes (``{value}``: its value).
    default_unless : tuple of str
        Keys that replace the default when the problem gives them (``Msd_max`` for
        ``Msd_rel_max``: the user chose the disturbance bound).

    Attributes
    ----------
    lower : bool
        ``bound == "lower"``.
    """

    key: str
    field: Field
    bound: str | None = None
    figure: str | None = None
    transfer: str | None = None
    loops: tuple = LOOPS
    unit: str = ""
    label: str = ""
    program: str | None = None
    scaled: bool = False
    floor: float | None = None
    column: str | None = None
    always_column: bool = True
    column_label: str = ""
    relative_to: str | None = None
    published: str = "given"
    with_key: str | None = None
    time_domain: bool = False
    default_bound: float | str | None = None
    default_note: str = ""
    default_unless: tuple = ()

    @property
    def lower(self):
        """True for a lower bound."""
        return self.bound == "lower"


def _f(type_, default, doc, **kw):
    return Field(type_, default, doc, **kw)


SPEC_TABLE = (
    SpecDef("Ms_max", _f("number", None, "bound on |S| (modulus margin >= 1/Ms_max)", lo=1.0),
            "upper", "Ms", "S", unit="", label="|S| peak", program="S", scaled=True,
            floor=1.0, column="Ms", column_label="worst |S| peak Ms [-]", published="always"),
    SpecDef("Mt_max", _f("number", None, "bound on |T|", positive=True),
            "upper", "Mt", "T", label="|T| peak", program="T", scaled=True, column="Mt",
            column_label="worst |T| peak Mt [-]", published="always"),
    SpecDef("Mu_max", _f("number", None, "bound on |U| [V/µm]", positive=True),
            "upper", "Mu", "U", unit="V/µm", label="|U| peak", program="U", scaled=True,
            column="Mu", column_label="worst |U| peak Mu [V/µm]", published="always"),
    SpecDef("Mu_reason", _f("str", "", "why this Mu bound"), published="never"),
    SpecDef("T_resonance_max", _f("number", None, "bound on |T| over the resonance band",
                                  positive=True),
            "upper", "Mt_resonance_band", "T", label="|T| in resonance band",
            program="Tband", scaled=True, column="Mt_band",
            column_label="worst |T| in the resonance band [-]"),
    SpecDef("resonance_band_hz", _f("numbers", None, "[f_lo, f_hi] band for T_resonance_max",
                                    **BAND_FIELD), published="with",
            with_key="T_resonance_max"),
    SpecDef("stable_controller", _f("bool", False, "require S/s Hurwitz"),
            published="always"),
    SpecDef("sample_rate_hz", _f("number", None, "also certify (nlp: also design) the sampled"
                                 " loop: ZOH plant, Tustin controller at this rate [Hz]",
                                 lo=MIN_RATE_HZ, hi=1e9), published="sampled"),
    SpecDef("delay_samples", _f("int", 0, "computation delay of the sampled loop [samples];"
                                " plant order + delay <= 30", lo=0, hi=1000),
            published="sampled"),
    SpecDef("Mu_hf_max", _f("number", None, "bound on |U| above Mu_hf_above_hz [V/µm]",
                            positive=True),
            "upper", "Mu_hf", "U", unit="V/µm", label="|U| above corner", program="Uhf",
            scaled=True),
    SpecDef("Mu_hf_above_hz", _f("number", None, "where the Mu_hf_max bound starts [Hz]",
                                 positive=True), published="with", with_key="Mu_hf_max"),
    SpecDef("overshoot_max_pct", _f("number", None, "overshoot of a reference step [%]; above"
                                    " 100 the output would more than double the step: a bound"
                                    " no design means; default 20 when [specs] bounds"
                                    " anything, false: none", lo=0.0, hi=100.0,
                                    allow_off=True),
            "upper", "overshoot_pct", unit="%", label="overshoot_pct",
            published="time_domain", time_domain=True, default_bound=20.0,
            default_note="reference-step overshoot <= {value:g} % ([specs] overshoot_max_pct"
                         " = false: none)"),
    SpecDef("settling_time_max_s", _f("number", None, "2 % settling time of a reference step"
                                      " [s]", positive=True),
            "upper", "settling_time_s", unit="s", label="settling_time_s",
            published="time_domain", time_domain=True),
    SpecDef("step_um", _f("number", 1.0, "reference step for step_u_max_V [µm]",
                          positive=True), published="time_domain"),
    SpecDef("step_u_max_V", _f("number", None, "peak |u| for a reference step of step_um [V]",
                               positive=True),
            "upper", "step_u_peak_V", unit="V", label="step_u_peak_V",
            published="time_domain", time_domain=True),
    SpecDef("Msd_max", _f("number", None, "bound on the input-disturbance sensitivity"
                          " |B S/Delta| [µm/V]", positive=True),
            "upper", "Msd", "Sd", unit="µm/V", label="|B S/Delta| peak", program="Sd",
            scaled=True),
    SpecDef("Mry_max", _f("number", None, "bound on the reference-to-output |B T/Delta|"
                          " (Mt_max bounds |B R/Delta|)", positive=True),
            "upper", "Mry", "Tr", label="|B T/Delta| peak", program="Ry", scaled=True),
    SpecDef("Msd_rel_max", _f("number", None, "bound on the input-disturbance peak |B S/Delta|"
                              " relative to the same model's open-loop peak |B/A| (the ZOH"
                              " plant's in the sampled loop); 1: the controller never"
                              " amplifies input disturbances beyond the bare actuator;"
                              " default 1 when [specs] bounds anything, every model is"
                              " stable and no Msd_max is given; false: none", positive=True,
                              allow_off=True),
            "upper", "Msd_rel", "Sd", label="|B S/Delta| peak / open-loop |B/A| peak",
            program="Sd", scaled=True, column="Msd_rel", always_column=False,
            column_label="worst |B S/Delta| peak / open-loop peak [-]",
            relative_to="open_loop_peak", default_bound=1.0, default_unless=("Msd_max",),
            default_note="input-disturbance peak |B S/Delta| <= {value:g} x the model's"
                         " open-loop peak |B/A| ([specs] Msd_rel_max = false: none)"),
    SpecDef("damping_min", _f("number", None, "least damping of every closed-loop pole of every"
                              " model (sampled loop: poles mapped to s by fs ln z); default"
                              " min(0.1, the plant's least damping), 0 or false: none",
                              lo=0.0, hi=0.99, allow_off=True),
            "lower", "damping", label="closed-loop damping", default_bound="plant_damping",
            default_note="closed-loop damping >= {value:.4g} on every pole, the plant's least"
                         " damping (at most 0.1; [specs] damping_min = 0: none)"),
    SpecDef("decay_min", _f("number", None, "least decay rate -Re(p) of every closed-loop pole"
                            " [rad/s]", positive=True, hi=MAX_RATE),
            "lower", "decay_rad_s", unit="rad/s", label="closed-loop decay rate [rad/s]"),
    SpecDef("controller_damping_min", _f("number", None, "least damping of the controller's own"
                                         " poles", lo=0.0, hi=0.99),
            "lower", "controller_damping", loops=(), label="controller damping"),
)

SPECS_BY_KEY = {s.key: s for s in SPEC_TABLE}

# the peaks the certificate always computes (sensitivity -> bound key), and the peaks of
# further transfer functions computed only when a spec bounds them (transfer -> keys)
PEAK_SPECS = {s.transfer: s.key for s in SPEC_TABLE
              if s.program in ("S", "T", "U") and s.transfer in ("S", "T", "U")}
EXTRA_PEAK_SPECS = {s.transfer: s.key for s in SPEC_TABLE
                    if s.transfer not in ("S", "T", "U", None) and s.relative_to is None}
RELATIVE_PEAK_SPECS = {s.transfer: s.key for s in SPEC_TABLE if s.relative_to is not None}
# the specs a problem that bounds anything gets by default, each switched off by false
DEFAULTED = tuple(s.key for s in SPEC_TABLE if s.default_bound is not None)


def spec(key: str) -> SpecDef:
    """The row of ``key``.

    Parameters
    ----------
    key : str
        A ``[specs]`` key.

    Returns
    -------
    SpecDef

    Raises
    ------
    KeyError
        Not a spec.
    """
    return SPECS_BY_KEY[key]


def bound_specs(direction: str | None = None, loop_figures: bool = True) -> tuple:
    """The rows that bound a figure, in table order.

    Parameters
    ----------
    direction : {"upper", "lower"}, optional
        Only the upper or the lower bounds.
    loop_figures : bool
        Only bounds on a loop's figures (not the controller's own poles).

    Returns
    -------
    tuple of SpecDef
    """
    return tuple(s for s in SPEC_TABLE if s.bound is not None
                 and (direction is None or s.bound == direction)
                 and (not loop_figures or s.loops))


def specs_schema() -> dict:
    """The problem file's ``[specs]`` table: ``{key: Field}`` in table order.

    Returns
    -------
    dict
    """
    return {s.key: s.field for s in SPEC_TABLE}


def spec_columns(specs: object | None = None) -> tuple:
    """The rows whose worst figure is a sweep column: every ``always_column`` row, and,
    with ``specs``, the others that ``specs`` bounds.

    Parameters
    ----------
    specs : Specs, optional
        A sweep problem's specs.

    Returns
    -------
    tuple of SpecDef
    """
    return tuple(s for s in SPEC_TABLE if s.column is not None and (
        s.always_column or (specs is not None and getattr(specs, s.key) is not None)))
