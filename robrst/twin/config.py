"""Digital-twin configuration: every effect switchable and parametrised (TOML).

The defaults are the paper's actuator (``problems/twin_paper.toml`` repeats them
with their sources).  Effects: ``thermal_dynamics`` (gain, resonance and damping
versus temperature, the plant family's coefficients), ``hysteresis`` (Bouc–Wen,
Hammerstein), ``creep`` (bank of first-order cells, log law growing with
temperature), ``thermal_drift`` (lagged, saturating, hysteretic in temperature),
``delay``, ``saturation`` and ``slew`` (amplifier), ``noise`` and ``quantization``
(sensor); and, off in the paper's actuator, ``input_nonlinearity`` (a dead zone and a
polynomial on the drive), ``output_nonlinearity`` (the sensor's curvature),
``stiffness_nonlinearity`` (a Duffing-type cubic stiffness of the structure) and
``pi_hysteresis`` (Prandtl–Ishlinskii: a weighted sum of play operators).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from robrst.base.errors import SpecError
from robrst.core.plant import NAMED_PLANTS, Plant, as_plant, named_plant
from robrst.base.schema import Field, key_error, load_toml, validate

if TYPE_CHECKING:
    from pathlib import Path
    from robrst.core.plant import Plant

__all__ = ["EFFECTS", "TWIN_SCHEMA", "TwinConfig", "load_twin", "parse_twin", "default_twin",
           "run_samples", "min_sample_rate_hz", "MAX_RUN_SAMPLES", "MAX_SUBSTEPS", "RK4_STEP"]

# samples of one simulated run (a scenario's profile): 5e7 is 400 MB per signal, 42 min at
# the paper's 20 kHz (its longest experiment, Fig. 2, is 9 min); a twin at 1e8 Hz asked
# for 2.4e10 (179 GiB)
MAX_RUN_SAMPLES = 50_000_000
# RK4 substeps per sample of the twin's linear part (robrst.twin.model.substeps): each at a
# scaled step w0 dt / n <= RK4_STEP; the step is unrolled in the generated C, and 64
# substeps of an order-4 plant compile in seconds (the 42,749 of the paper's plant at 1 Hz
# made a 50 MB file gcc did not finish)
RK4_STEP = 0.05
MAX_SUBSTEPS = 64
#: samples of transport delay the twin holds (its state carries one entry per sample): 0.1 s
#: at 20 kHz, far beyond any amplifier's or sensor's latency
MAX_DELAY_SAMPLES = 2000

EFFECTS = ("thermal_dynamics", "hysteresis", "creep", "thermal_drift", "delay", "saturation",
           "slew", "noise", "quantization", "input_nonlinearity", "output_nonlinearity",
           "stiffness_nonlinearity", "pi_hysteresis")

_OFF = Field("bool", False, "switch the effect on/off (off in the paper's actuator)")

_ON = Field("bool", True, "switch the effect on/off")
_SRC = Field("str", "", "")
TWIN_SCHEMA = {
    "twin": {
        "name": Field("str", "twin", "name"),
        "plant": Field("str", "paper", "the linear plant: 'paper' (D(s) of eq. 4), or a problem"
                       " file or model file of robrst identify (its reference model; a path"
                       " relative to the twin file); with a file, the effects whose tables"
                       " the twin file leaves out are off"),
        "sample_rate_hz": Field("number", None, "simulation and control sampling rate [Hz]"
                                " (default 20000; at least what the plant's RK4 steps need)",
                                lo=1e3, hi=1e6),
        "fs_hz": Field("number", None, "older name of sample_rate_hz", lo=1e3, hi=1e6),
        "reference_C": Field("number", 28.0, "temperature of the nominal model [°C]",
                             lo=-100.0, hi=500.0),
        "source": Field("str", "", "where the defaults come from"),
    },
    "thermal_dynamics": {"enabled": _ON,
                         "gain_per_K": Field("number", 0.0015, "relative static gain per K"),
                         "resonance_per_K": Field("number", -0.0001, "relative resonance per K"),
                         "damping_per_K": Field("number", 0.005, "relative damping per K"),
                         "source": _SRC},
    "hysteresis": {"enabled": _ON,
                   "A": Field("number", 0.45, "Bouc–Wen A [-]"),
                   "B": Field("number", 0.0045, "Bouc–Wen beta [1/V]"),
                   "Gamma": Field("number", 0.0045, "Bouc–Wen gamma [1/V]"),
                   "slope_range_V": Field("numbers", (0.0, 150.0),
                                          "voltage cycle on which the mean slope of u-h is 1",
                                          length=2),
                   "source": _SRC},
    "creep": {"enabled": _ON,
              "per_decade": Field("number", 0.01, "creep per decade of time at reference_C [-]",
                                  lo=0.0),
              "per_K": Field("number", 0.05, "relative growth of creep per K above reference"),
              "tau_min_s": Field("number", 0.1, "fastest cell [s]", positive=True),
              "tau_max_s": Field("number", 1.0e4, "slowest cell [s]", positive=True, hi=1e9),
              "cells_per_decade": Field("int", 2, "cells per decade", lo=1, hi=20),
              "source": _SRC},
    "thermal_drift": {"enabled": _ON,
                      "lag_s": Field("number", 20.0, "thermal lag of the stack [s]", positive=True),
                      "A": Field("number", 1.0, "Bouc–Wen A in temperature [-]"),
                      "B": Field("number", 0.1, "beta [1/K]"),
                      "Gamma": Field("number", 0.1, "gamma [1/K]"),
                      "gain_V_per_K": Field("number", 0.9, "input-referred drift [V/K]"),
                      "source": _SRC},
    "delay": {"enabled": _ON,
              "seconds": Field("number", 0.0, "transport delay [s], whole samples", lo=0.0, hi=10.0),
              "source": _SRC},
    "saturation": {"enabled": _ON, "u_min": Field("number", 0.0, "amplifier low limit [V]"),
                   "u_max": Field("number", 150.0, "amplifier high limit [V]"),
                   "source": _SRC},
    "slew": {"enabled": _ON,
             "V_per_s": Field("number", 6.0e4, "slew-rate limit [V/s]", positive=True),
             "V_per_s_down": Field("number", None, "falling slew-rate limit [V/s] (default:"
                                   " V_per_s, a symmetric limit)", positive=True),
             "source": _SRC},
    "noise": {"enabled": _ON,
              "sigma_um": Field("number", 0.005, "sensor noise std [µm]", lo=0.0),
              "source": _SRC},
    "quantization": {"enabled": _ON,
                     "step_um": Field("number", 0.0015, "sensor LSB [µm]", positive=True),
                     "source": _SRC},
    # effects beyond the paper's actuator (off by default)
    "input_nonlinearity": {
        "enabled": _OFF,
        "dead_zone_V": Field("number", 5.0, "half width of a dead zone about center_V [V]",
                             lo=0.0),
        "center_V": Field("number", 0.0, "centre of the dead zone and of the polynomial [V]"),
        "quadratic_per_V": Field("number", 0.0, "v += quadratic (u - center)^2 [1/V]"),
        "cubic_per_V2": Field("number", 0.0, "v += cubic (u - center)^3 [1/V^2]"),
        "source": _SRC},
    "output_nonlinearity": {
        "enabled": _OFF,
        "center_um": Field("number", 0.0, "centre of the sensor's polynomial [µm]"),
        "quadratic_per_um": Field("number", 0.002, "y += quadratic (y - center)^2 [1/µm]"),
        "cubic_per_um2": Field("number", 0.0, "y += cubic (y - center)^3 [1/µm^2]"),
        "source": _SRC},
    "stiffness_nonlinearity": {
        "enabled": _OFF,
        "cubic_per_um2": Field("number", 2e-6, "Duffing: stiffness k (1 + cubic y^2) of the"
                               " structure, y from rest [1/µm^2]"),
        "source": _SRC},
    "pi_hysteresis": {
        "enabled": _OFF,
        "thresholds_V": Field("numbers", (5.0, 15.0, 30.0, 50.0), "play thresholds r_i [V]",
                              lo=0.0),
        "weights": Field("numbers", (0.06, 0.05, 0.04, 0.03),
                         "v = u + sum w_i (play_{r_i}(u) - u)"),
        "source": _SRC},
}
DEFAULT_RATE_HZ = 20000.0


@dataclass(frozen=True)
class TwinConfig:
    """A validated twin: sampling rate, nominal plant name, and per-effect settings.

    Use :meth:`with_effects` to switch effects (e.g. only one on).

    Parameters
    ----------
    name : str
        The twin's name.
    plant : str
        The nominal linear model: a built-in name (``"paper"``: D(s) of eq. 4), or the
        label of ``plant_model``.
    sample_rate_hz : float
        Simulation and control sampling rate [Hz].
    reference_C : float
        Temperature of the nominal model [°C].
    effects : dict
        ``effects[name]`` is a dict of that effect's parameters including ``enabled``.
    path : str
        The twin file (``"<default>"`` for the built-in defaults).
    plant_model : Plant, optional
        The user's linear plant (a plant file, :meth:`with_plant`); ``None``: the built-in
        ``plant``.

    Attributes
    ----------
    dt : float
        The sampling period [s].
    linear_plant : Plant
        The nominal linear model in use.
    """

    name: str = "twin"
    plant: str = "paper"
    sample_rate_hz: float = DEFAULT_RATE_HZ
    reference_C: float = 28.0
    effects: dict = field(default_factory=dict)
    path: str = "<default>"
    plant_model: Plant | None = None

    @property
    def linear_plant(self):
        """The nominal linear model ``D(s)`` (a :class:`~robrst.core.plant.Plant`): the
        user's (:meth:`with_plant`, a plant file) or the built-in one named ``plant``."""
        return self.plant_model if self.plant_model is not None else named_plant(self.plant)

    def with_plant(self, plant: object, reference_C: float | None = None,
                   name: str | None = None) -> "TwinConfig":
        """Copy whose linear part is ``plant``: a :class:`~robrst.core.plant.Plant` or a SISO
        continuous python-control ``TransferFunction``/``StateSpace`` (a discrete one is read
        as :meth:`~robrst.core.plant.Plant.from_control` reads it: its continuous plant).

        Parameters
        ----------
        plant : Plant or control.TransferFunction or control.StateSpace
        reference_C : float, optional
            Temperature [°C] at which ``plant`` holds (default its ``temperature_C``, else
            this twin's).
        name : str, optional
            The ``plant`` label (default the plant's label).

        Returns
        -------
        TwinConfig

        Examples
        --------
        >>> import control
        >>> twin = default_twin().with_effects(only=[]).with_plant(control.tf([2.0], [1e-3, 1.0]))
        >>> round(float(twin.linear_plant.dc_gain), 12)
        2.0
        """
        p = as_plant(plant, "plant")
        ref = reference_C if reference_C is not None else (
            p.temperature_C if p.temperature_C is not None else self.reference_C)
        return replace(self, plant=name or p.label, plant_model=p, reference_C=float(ref))

    def enabled(self, name: str) -> bool:
        """Whether effect ``name`` is on.

        Parameters
        ----------
        name : str
            One of :data:`EFFECTS`.

        Returns
        -------
        bool
        """
        return bool(self.effects[name]["enabled"])

    def with_effects(self, only: Iterable[str] | None = None, off: Iterable[str] = (),
                     **overrides: dict) -> TwinConfig:
        """Copy with only ``only`` enabled (if given), ``off`` disabled, parameters overridden.

        Parameters
        ----------
        only : iterable of str, optional
            The effects left on (every other one off).
        off : iterable of str
            Effects switched off.
        **overrides
            Effect name -> dict of parameter values.

        Returns
        -------
        TwinConfig

        Raises
        ------
        SpecError
            An unknown effect or parameter.

        Examples
        --------
        >>> from robrst import default_twin
        >>> twin = default_twin().with_effects(only=["hysteresis"], hysteresis={"A": 0.3})
        >>> twin.enabled("hysteresis"), twin.enabled("creep"), twin.effects["hysteresis"]["A"]
        (True, False, 0.3)
        """
        eff = {k: dict(v) for k, v in self.effects.items()}
        if only is not None:
            unknown = set(only) - set(EFFECTS)
            if unknown:
                raise SpecError(f"unknown effect(s) {sorted(unknown)}; expected {EFFECTS}")
            for k in eff:
                eff[k]["enabled"] = k in only
        for k in off:
            eff[k]["enabled"] = False
        for k, vals in overrides.items():
            if k not in eff:
                raise SpecError(f"unknown effect {k!r}; expected one of {EFFECTS}")
            for p, v in vals.items():
                if p not in eff[k]:
                    raise SpecError(f"effect {k!r} has no parameter {p!r}; valid: {sorted(eff[k])}")
                eff[k][p] = v
        return replace(self, effects=eff)

    @property
    def dt(self):
        return 1.0 / self.sample_rate_hz


def min_sample_rate_hz(w0: float) -> float:
    """The slowest rate [Hz] at which a plant of natural scale ``w0`` [rad/s] needs at most
    :data:`MAX_SUBSTEPS` RK4 substeps per sample (:func:`robrst.twin.model.substeps`).

    Parameters
    ----------
    w0 : float
        The plant's natural scale [rad/s].

    Returns
    -------
    float

    Examples
    --------
    >>> round(min_sample_rate_hz(2137.4), 1)      # the paper's plant
    667.9
    """
    return float(w0) / (RK4_STEP * MAX_SUBSTEPS)


def _check_rate(path, key, rate, plant):
    """Refuse a rate at which the plant's RK4 step would need more substeps per sample than
    the generated C can hold (:func:`min_sample_rate_hz`)."""
    from robrst.core.poly import natural_scale

    need = min_sample_rate_hz(natural_scale(plant.A))
    if rate < need:
        raise key_error(path, key, f"{rate:g} Hz is too slow for the plant {plant.label!r}"
                        f" (natural scale {natural_scale(plant.A):.4g} rad/s): the twin's RK4"
                        f" steps need at least {need:.4g} Hz (at most {MAX_SUBSTEPS} substeps"
                        " per sample)")


def run_samples(config: TwinConfig, seconds: float, what: str = "the run") -> int:
    """Samples of a run of ``seconds`` at the twin's rate.

    Parameters
    ----------
    config : TwinConfig
    seconds : float
        Duration of the run [s].
    what : str
        The run, for the message.

    Returns
    -------
    int

    Raises
    ------
    SpecError
        Naming the twin file and ``[twin.sample_rate_hz]`` beyond :data:`MAX_RUN_SAMPLES`.
    """
    n = int(round(float(seconds) * config.sample_rate_hz))
    if n > MAX_RUN_SAMPLES:
        raise SpecError(f"{config.path}: [twin.sample_rate_hz] {config.sample_rate_hz:g} Hz:"
                        f" {what} of {seconds:g} s needs {n:.3g} samples, more than"
                        f" {MAX_RUN_SAMPLES:.3g}; lower the rate (or use a shorter run)")
    return n


def _plant_file(path, name, plant_loader):
    """``(Plant, reference °C, per-kelvin law or None)`` of ``[twin] plant = name``, a file
    (relative to the twin file) or what ``plant_loader`` knows by name."""
    if plant_loader is None:
        raise key_error(path, ("twin", "plant"), f"unknown plant name {name!r}; expected one of"
                        f" {sorted(NAMED_PLANTS)}, or a problem or model file (read by"
                        " robrst.load_twin)")
    target = Path(name)
    if not target.is_absolute() and not str(path).startswith("<"):
        near = Path(str(path)).parent / target
        target = near if near.exists() or not target.exists() else target
    try:
        return plant_loader(target)
    except SpecError as exc:
        raise key_error(path, ("twin", "plant"), str(exc)) from None


def parse_twin(data: dict, path: str = "<twin>", plant_loader: object = None) -> TwinConfig:
    """Validate a parsed twin TOML document; see :func:`load_twin`.

    Parameters
    ----------
    data : dict
        The parsed TOML.
    path : str
        Named in every error.
    plant_loader : callable, optional
        ``plant_loader(path) -> (Plant, reference_C, law)`` reads a ``[twin] plant`` that is
        a file (a problem file or a model file: :func:`robrst.studies.twins.load_twin`
        passes one); ``law`` is the family's per-kelvin law (``gain_per_K``,
        ``resonance_per_K``, ``damping_per_K``) or ``None``, the default of
        ``[thermal_dynamics]``.

    Returns
    -------
    TwinConfig

    Raises
    ------
    SpecError
        Naming the file and the key: unknown keys, values out of range, both
        ``sample_rate_hz`` and ``fs_hz``, Bouc–Wen parameters without a loop,
        ``tau_max_s <= tau_min_s``, ``u_max <= u_min``, an unknown plant or a plant file
        that cannot be read (``[twin.plant]``), a plant with feedthrough, a rate too slow
        for the plant's RK4 steps (``[twin.sample_rate_hz]``).
    """
    v = validate(path, data, TWIN_SCHEMA)
    tw = v["twin"] or validate(path, {}, TWIN_SCHEMA["twin"], ("twin",))
    user = tw["plant"] not in NAMED_PLANTS
    plant_model, law = None, None
    if user:
        plant_model, ref, law = _plant_file(path, tw["plant"], plant_loader)
        if "reference_C" not in (data.get("twin") or {}):
            tw = {**tw, "reference_C": float(ref if ref is not None else tw["reference_C"])}
    effects = {}
    for k in EFFECTS:
        given = v[k] is not None
        eff = dict(v[k] or validate(path, {}, TWIN_SCHEMA[k], (k,)))
        if k == "thermal_dynamics" and user:
            raw = data.get(k) or {}
            eff.update({q: float((law or {}).get(q, 0.0)) for q in
                        ("gain_per_K", "resonance_per_K", "damping_per_K") if q not in raw})
        if user and not given:      # a user's plant: only the effects the file switches on
            eff["enabled"] = False
        effects[k] = eff
    if tw["fs_hz"] is not None and tw["sample_rate_hz"] is not None:
        raise key_error(path, ("twin", "fs_hz"), "give sample_rate_hz only (fs_hz is its older name)")
    rate = tw["sample_rate_hz"] or tw["fs_hz"] or DEFAULT_RATE_HZ
    if effects["creep"]["tau_max_s"] <= effects["creep"]["tau_min_s"]:
        raise key_error(path, ("creep", "tau_max_s"), "must exceed tau_min_s")
    if effects["saturation"]["u_max"] <= effects["saturation"]["u_min"]:
        raise key_error(path, ("saturation", "u_max"), "must exceed u_min")
    h = effects["hysteresis"]
    if not 0 <= h["A"] < 1 or h["B"] + h["Gamma"] <= 0 or abs(h["Gamma"]) > h["B"] + 1e-15:
        raise key_error(path, ("hysteresis",), "Bouc–Wen needs 0 <= A < 1, B + Gamma > 0 and"
                        " |Gamma| <= B (bounded, passive loops)")
    if not h["slope_range_V"][0] < h["slope_range_V"][1]:
        raise key_error(path, ("hysteresis", "slope_range_V"), "expected [lo, hi] with lo < hi")
    pi = effects["pi_hysteresis"]
    if len(pi["thresholds_V"]) != len(pi["weights"]) or not pi["weights"]:
        raise key_error(path, ("pi_hysteresis", "weights"), "expected one weight per threshold"
                        f" ({len(pi['thresholds_V'])} thresholds, {len(pi['weights'])} weights)")
    d = effects["thermal_drift"]
    if d["B"] + d["Gamma"] <= 0 or abs(d["Gamma"]) > d["B"] + 1e-15:
        raise key_error(path, ("thermal_drift",), "needs B + Gamma > 0 and |Gamma| <= B")
    if user and not plant_model.m < plant_model.n:
        raise key_error(path, ("twin", "plant"), "the twin needs a strictly proper plant (no"
                        " feedthrough: y(k) must not depend on u(k))")
    if round(effects["delay"]["seconds"] * rate) > MAX_DELAY_SAMPLES:
        raise key_error(path, ("delay", "seconds"), f"{effects['delay']['seconds']:g} s is"
                        f" {round(effects['delay']['seconds'] * rate)} samples at {rate:g} Hz;"
                        f" expected at most {MAX_DELAY_SAMPLES} samples"
                        f" ({MAX_DELAY_SAMPLES / rate:g} s)")
    _check_rate(path, ("twin", "fs_hz" if tw["fs_hz"] is not None else "sample_rate_hz"),
                rate, plant_model if user else named_plant(tw["plant"]))
    return TwinConfig(name=tw["name"], plant=tw["plant"], sample_rate_hz=rate,
                      reference_C=tw["reference_C"], effects=effects, path=str(path),
                      plant_model=plant_model)


def load_twin(path: str | Path, plant_loader: object = None) -> TwinConfig:
    """Load and validate a twin TOML file (errors name the file and the key).

    Parameters
    ----------
    path : str or pathlib.Path
        The twin file (the shipped one: :func:`robrst.base.resources.builtin_twin`).
    plant_loader : callable, optional
        Reads a ``[twin] plant`` that is a file (see :func:`parse_twin`);
        :func:`robrst.studies.twins.load_twin` (``robrst.load_twin``) passes one.

    Returns
    -------
    TwinConfig

    Raises
    ------
    SpecError
        A missing or invalid file (see :func:`parse_twin`).
    """
    return parse_twin(load_toml(path, "twin file"), str(path), plant_loader)


def default_twin() -> TwinConfig:
    """The paper's twin with every effect on (the built-in defaults).

    Returns
    -------
    TwinConfig
    """
    return parse_twin({}, "<default twin>")

