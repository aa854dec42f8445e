"""Digital-twin configuration: every effect switchable and parametrised (TOML).

The defaults are the paper's actuator (``problems/twin_paper.toml`` repeats them
with their sources).  Effects: ``thermal_dynamics`` (gain, resonance and damping
versus temperature, the plant family's coefficients), ``hysteresis`` (Bouc–Wen,
Hammerstein), ``creep`` (bank of first-order cells, log law growing with
temperature), ``thermal_drift`` (lagged, saturating, hysteretic in temperature),
``delay``, ``saturation`` and ``slew`` (amplifier), ``noise`` and ``quantization``
(sensor).
"""

import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from robrst.errors import SpecError
from robrst.plant import named_plant
from robrst.spec import NUM, NUMS, key_error, validate_table

__all__ = ["EFFECTS", "TWIN_SCHEMA", "TwinConfig", "load_twin", "parse_twin", "default_twin"]

EFFECTS = ("thermal_dynamics", "hysteresis", "creep", "thermal_drift", "delay", "saturation",
           "slew", "noise", "quantization")

_ON = (bool, False, True, "switch the effect on/off")
TWIN_SCHEMA = {
    "twin": {
        "name": (str, False, "twin", "name"),
        "plant": (str, False, "paper", "built-in nominal linear model (D(s) of eq. 4)"),
        "fs_hz": (NUM, False, 20000.0, "simulation and control sampling rate [Hz]"),
        "reference_C": (NUM, False, 28.0, "temperature of the nominal model [°C]"),
        "source": (str, False, "", "where the defaults come from"),
    },
    "thermal_dynamics": {"enabled": _ON,
                         "gain_per_K": (NUM, False, 0.0015, "relative static gain per K"),
                         "resonance_per_K": (NUM, False, -0.0001, "relative resonance per K"),
                         "damping_per_K": (NUM, False, 0.005, "relative damping per K"),
                         "source": (str, False, "", "")},
    "hysteresis": {"enabled": _ON,
                   "A": (NUM, False, 0.45, "Bouc–Wen A [-]"),
                   "B": (NUM, False, 0.0045, "Bouc–Wen beta [1/V]"),
                   "Gamma": (NUM, False, 0.0045, "Bouc–Wen gamma [1/V]"),
                   "slope_range_V": (NUMS, False, [0.0, 150.0],
                                     "voltage cycle on which the mean slope of u-h is 1"),
                   "source": (str, False, "", "")},
    "creep": {"enabled": _ON,
              "per_decade": (NUM, False, 0.01, "creep per decade of time at reference_C [-]"),
              "per_K": (NUM, False, 0.05, "relative growth of creep per K above reference"),
              "tau_min_s": (NUM, False, 0.1, "fastest cell [s]"),
              "tau_max_s": (NUM, False, 1.0e4, "slowest cell [s]"),
              "cells_per_decade": (int, False, 2, "cells per decade"),
              "source": (str, False, "", "")},
    "thermal_drift": {"enabled": _ON,
                      "lag_s": (NUM, False, 20.0, "thermal lag of the stack [s]"),
                      "A": (NUM, False, 1.0, "Bouc–Wen A in temperature [-]"),
                      "B": (NUM, False, 0.1, "beta [1/K]"),
                      "Gamma": (NUM, False, 0.1, "gamma [1/K]"),
                      "gain_V_per_K": (NUM, False, 0.9, "input-referred drift [V/K]"),
                      "source": (str, False, "", "")},
    "delay": {"enabled": _ON, "seconds": (NUM, False, 0.0, "transport delay [s], whole samples"),
              "source": (str, False, "", "")},
    "saturation": {"enabled": _ON, "u_min": (NUM, False, 0.0, "amplifier low limit [V]"),
                   "u_max": (NUM, False, 150.0, "amplifier high limit [V]"),
                   "source": (str, False, "", "")},
    "slew": {"enabled": _ON, "V_per_s": (NUM, False, 6.0e4, "slew-rate limit [V/s]"),
             "source": (str, False, "", "")},
    "noise": {"enabled": _ON, "sigma_um": (NUM, False, 0.005, "sensor noise std [µm]"),
              "source": (str, False, "", "")},
    "quantization": {"enabled": _ON, "step_um": (NUM, False, 0.0015, "sensor LSB [µm]"),
                     "source": (str, False, "", "")},
}


@dataclass(frozen=True)
class TwinConfig:
    """A validated twin: sampling rate, nominal plant name, and per-effect settings.

    ``effects[name]`` is a dict of that effect's parameters including ``enabled``.
    Use :meth:`with_effects` to switch effects (e.g. only one on).
    """

    name: str = "twin"
    plant: str = "paper"
    fs_hz: float = 20000.0
    reference_C: float = 28.0
    effects: dict = field(default_factory=dict)
    path: str = "<default>"

    def enabled(self, name):
        return bool(self.effects[name]["enabled"])

    def with_effects(self, only=None, off=(), **overrides):
        """Copy with only ``only`` enabled (if given), ``off`` disabled, parameters overridden.

        ``overrides`` map an effect name to a dict of parameter values.
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
        return 1.0 / self.fs_hz


def parse_twin(data, path="<twin>"):
    """Validate a parsed twin TOML document; see :func:`load_twin`."""
    v = validate_table(path, data, TWIN_SCHEMA)
    tw = v["twin"] or validate_table(path, {}, TWIN_SCHEMA["twin"], ("twin",))
    effects = {k: (v[k] or validate_table(path, {}, TWIN_SCHEMA[k], (k,))) for k in EFFECTS}
    if tw["fs_hz"] <= 0:
        raise key_error(path, ("twin", "fs_hz"), f"must be > 0, got {tw['fs_hz']}")
    named_plant(tw["plant"])  # raises with the valid names
    positive = {("creep", "tau_min_s"), ("creep", "tau_max_s"), ("creep", "cells_per_decade"),
                ("thermal_drift", "lag_s"), ("slew", "V_per_s"), ("quantization", "step_um")}
    for e, p in positive:
        if effects[e][p] <= 0:
            raise key_error(path, (e, p), f"must be > 0, got {effects[e][p]}")
    for e, p in (("delay", "seconds"), ("noise", "sigma_um"), ("creep", "per_decade")):
        if effects[e][p] < 0:
            raise key_error(path, (e, p), f"must be >= 0, got {effects[e][p]}")
    if effects["creep"]["tau_max_s"] <= effects["creep"]["tau_min_s"]:
        raise key_error(path, ("creep", "tau_max_s"), "must exceed tau_min_s")
    if effects["saturation"]["u_max"] <= effects["saturation"]["u_min"]:
        raise key_error(path, ("saturation", "u_max"), "must exceed u_min")
    h = effects["hysteresis"]
    if not 0 <= h["A"] < 1 or h["B"] + h["Gamma"] <= 0 or abs(h["Gamma"]) > h["B"] + 1e-15:
        raise key_error(path, ("hysteresis",), "Bouc–Wen needs 0 <= A < 1, B + Gamma > 0 and"
                        " |Gamma| <= B (bounded, passive loops)")
    if len(h["slope_range_V"]) != 2 or not h["slope_range_V"][0] < h["slope_range_V"][1]:
        raise key_error(path, ("hysteresis", "slope_range_V"), "expected [lo, hi] with lo < hi")
    d = effects["thermal_drift"]
    if d["B"] + d["Gamma"] <= 0 or abs(d["Gamma"]) > d["B"] + 1e-15:
        raise key_error(path, ("thermal_drift",), "needs B + Gamma > 0 and |Gamma| <= B")
    return TwinConfig(name=tw["name"], plant=tw["plant"], fs_hz=tw["fs_hz"],
                      reference_C=tw["reference_C"], effects=effects, path=str(path))


def load_twin(path):
    """Load and validate a twin TOML file (errors name the file and the key)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise SpecError(f"{path}: twin file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: invalid TOML: {exc}") from None
    return parse_twin(data, str(path))


def default_twin():
    """The paper's twin with every effect on (the built-in defaults)."""
    return parse_twin({}, "<default twin>")
