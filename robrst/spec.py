"""Problem files (TOML) -> frozen, validated :class:`Problem` specs.

Every key is declared in :data:`SCHEMA`; unknown or misspelled keys are rejected
with the file name, the key path and the closest valid key.  The README's
"Problem-file reference" documents the same schema.
"""

import difflib
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robrst.errors import SpecError
from robrst.family import ThermalCoefficients, explicit_family, parametric_family
from robrst.plant import Plant, named_plant
from robrst.synthesis.analytic import PoleSpec

__all__ = ["Problem", "load_problem", "parse_problem", "SCHEMA", "schema_markdown", "validate_table",
           "key_error"]

NUM = (int, float)
NUMS = "list of numbers"

# key -> (type, required, default, doc); nested tables are dicts; "[[..]]" lists of tables.
SCHEMA = {
    "problem": {
        "name": (str, False, None, "problem name (default: file stem)"),
        "description": (str, False, "", "free text"),
    },
    "plant": {
        "name": (str, False, None, "built-in model: 'paper' = D(s) of eq. (4)"),
        "B": (NUMS, False, None, "numerator coefficients [µm/V], highest power first"),
        "A": (NUMS, False, None, "denominator coefficients, highest power first"),
        "zeros": (NUMS, False, None, "real zeros [rad/s] (with 'poles', 'gain')"),
        "poles": (NUMS, False, None, "real poles [rad/s]"),
        "gain": (NUM, False, None, "leading gain k of k*prod(s-z)/prod(s-p)"),
        "temperature_C": (NUM, False, 28.0, "temperature of the nominal model [°C]"),
        "source": (str, False, "", "where the model comes from"),
    },
    "family": {
        "reference_C": (NUM, False, None, "temperature of the nominal model (default plant.temperature_C)"),
        "temperatures_C": (NUMS, False, None, "temperatures of a parametric family [°C]"),
        "source": (str, False, "", "where the coefficients come from"),
        "parametric": {
            "gain_per_K": (NUM, False, 0.0, "relative static-gain change per K"),
            "resonance_per_K": (NUM, False, 0.0, "relative natural-frequency change per K"),
            "damping_per_K": (NUM, False, 0.0, "relative damping change per K"),
            "creep_per_K": (NUM, False, 0.0, "creep strength gained per K above reference"),
            "creep_at_ref": (NUM, False, 0.0, "creep strength at the reference temperature"),
            "creep_tau_s": (NUM, False, 1.0, "creep time constant [s]"),
        },
        "models": ("[[]]", False, None, {
            "temperature_C": (NUM, True, None, "temperature [°C]"),
            "B": (NUMS, True, None, "numerator coefficients"),
            "A": (NUMS, True, None, "denominator coefficients"),
        }),
    },
    "controller": {
        "S_fixed": (NUMS, False, [1.0, 0.0], "fixed factor of S (must contain s)"),
        "R_fixed": (NUMS, False, [1.0], "fixed factor of R (e.g. a roll-off)"),
        "extra_degree": (int, False, 0, "degrees of S above the paper's minimum"),
        "T_mode": (str, False, "paper", "paper | static | cancel_aux"),
        "T_zeros": (NUMS, False, [], "zeros of T = Bm_aux [rad/s] (T_mode = paper)"),
    },
    "poles": {
        "wn": (NUM, False, None, "dominant natural frequency [rad/s]"),
        "zeta": (NUM, False, None, "dominant damping"),
        "dominant_real": (NUMS, False, [], "extra dominant real poles [rad/s, < 0]"),
        "dominant_roots_re": (NUMS, False, None, "explicit dominant roots, real parts"),
        "dominant_roots_im": (NUMS, False, None, "explicit dominant roots, imaginary parts"),
        "aux_factor": (NUM, False, 10.0, "auxiliary poles at -aux_factor*|fastest dominant|"),
        "aux_roots": (NUMS, False, None, "explicit real auxiliary roots [rad/s]"),
    },
    "specs": {
        "Ms_max": (NUM, False, None, "bound on |S| (modulus margin >= 1/Ms_max)"),
        "Mt_max": (NUM, False, None, "bound on |T|"),
        "Mu_max": (NUM, False, None, "bound on |U| [V/µm]"),
        "Mu_reason": (str, False, "", "why this Mu bound"),
        "T_resonance_max": (NUM, False, None, "bound on |T| over the resonance band"),
        "resonance_band_hz": (NUMS, False, None, "[f_lo, f_hi] band for T_resonance_max"),
        "stable_controller": (bool, False, False, "require S/s Hurwitz"),
        "sample_rate_hz": (NUM, False, None, "also certify (nlp: also design) the sampled loop:"
                           " ZOH plant, Tustin controller at this rate [Hz]"),
        "delay_samples": (int, False, 0, "computation delay of the sampled loop [samples]"),
    },
    "solver": {
        "method": (str, False, "analytic", "analytic | nlp | convex"),
        "objective": (str, False, "max_integral_gain", "max_integral_gain | min_Ms | feasibility"),
        "free_poles": (bool, False, False, "let wn and zeta vary within the bounds"),
        "wn_bounds": (NUMS, False, None, "[lo, hi] rad/s"),
        "zeta_bounds": (NUMS, False, None, "[lo, hi]"),
        "n_freq": (int, False, 120, "frequency-grid points per model"),
        "max_rounds": (int, False, 6, "certification rounds"),
        "exchange": (bool, False, True, "impose the grid by constraint exchange (active subset,"
                     " grown until every grid point holds); false: every point in one NLP"),
        "cert_temperatures": (int, False, 35, "temperatures in the certification sweep"),
        "cert_tol": (NUM, False, 1e-3, "relative tolerance on certified peaks"),
        "init": (str, False, "analytic", "NLP start: analytic (Sylvester) | convex (nominal SOCP; fixed poles only)"),
        "max_iter": (int, False, 500, "IPOPT iterations"),
        "ipopt_tol": (NUM, False, 1e-9, "IPOPT tolerance"),
        "compare_with": (str, False, None, "problem file (relative) whose analytic design is compared"),
    },
}


@dataclass(frozen=True, eq=False)
class Problem:
    """A validated problem: where it came from, the family, and the design choices."""

    name: str
    path: str
    family: object
    poles: PoleSpec
    controller: dict
    specs: dict
    solver: dict
    raw: dict


def schema_markdown(schema=None, prefix=""):
    """The problem-file reference as Markdown table rows (the README's table)."""
    schema = SCHEMA if schema is None else schema
    rows = []
    for key, val in schema.items():
        if isinstance(val, dict):
            rows.extend(schema_markdown(val, f"{prefix}{key}."))
        elif val[0] == "[[]]":
            rows.extend(schema_markdown(val[3], f"{prefix}{key}[]."))
        else:
            typ, req, default, doc = val
            tname = typ if isinstance(typ, str) else ("number" if typ == NUM else typ.__name__)
            rows.append(f"| `{prefix[:-1]}` | `{key}` | {tname} | {'yes' if req else 'no'}"
                        f" | {default!r} | {doc.replace('|', chr(92) + '|')} |")
    return rows


def _err(path, key, msg):
    where = ".".join(key) if key else "(top level)"
    return SpecError(f"{path}: [{where}] {msg}")


def _check_type(path, key, value, typ):
    if typ == NUMS:
        if not isinstance(value, list) or not all(
            isinstance(v, NUM) and not isinstance(v, bool) for v in value
        ):
            raise _err(path, key, f"expected a list of numbers, got {value!r}")
        if not all(np.isfinite(value)):
            raise _err(path, key, f"numbers must be finite, got {value!r}")
        return [float(v) for v in value]
    if typ == NUM:
        if isinstance(value, bool) or not isinstance(value, NUM) or not np.isfinite(value):
            raise _err(path, key, f"expected a finite number, got {value!r}")
        return float(value)
    if typ is int and (isinstance(value, bool) or not isinstance(value, int)):
        raise _err(path, key, f"expected an integer, got {value!r}")
    if not isinstance(value, typ):
        raise _err(path, key, f"expected {typ.__name__}, got {value!r}")
    return value


def _validate(path, data, schema, key=()):
    if not isinstance(data, dict):
        raise _err(path, key, f"expected a table, got {data!r}")
    out = {}
    for k, v in data.items():
        if k not in schema:
            close = difflib.get_close_matches(k, schema, n=1, cutoff=0.5)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            raise _err(path, key + (k,), f"unknown key{hint} (valid: {', '.join(schema)})")
    for k, spec in schema.items():
        if isinstance(spec, dict):
            out[k] = _validate(path, data[k], spec, key + (k,)) if k in data else None
            continue
        typ, required, default, doc = spec
        if typ == "[[]]":
            if k in data:
                if not isinstance(data[k], list):
                    raise _err(path, key + (k,), "expected an array of tables [[...]]")
                out[k] = [_validate(path, d, doc, key + (k, str(i))) for i, d in enumerate(data[k])]
            else:
                out[k] = None
            continue
        if k not in data:
            if required:
                raise _err(path, key + (k,), f"missing required key ({doc})")
            out[k] = list(default) if isinstance(default, list) else default
        else:
            out[k] = _check_type(path, key + (k,), data[k], typ)
    return out


def validate_table(path, data, schema, key=()):
    """Validate ``data`` against ``schema`` (same rules as problem files); fill defaults."""
    return _validate(path, data, schema, key)


def key_error(path, key, msg):
    """A :class:`SpecError` naming the file and the key path."""
    return _err(path, key, msg)


def _plant(path, p):
    if p is None:
        raise _err(path, ("plant",), "missing required table [plant]")
    kinds = [k for k in ("name", "B", "zeros") if p[k] is not None]
    if p["A"] is not None and p["B"] is None:
        raise _err(path, ("plant", "B"), "missing: 'A' is given without 'B'")
    if len(kinds) != 1:
        raise _err(path, ("plant",), "give exactly one of: name | B and A | zeros, poles and gain")
    T = p["temperature_C"]
    try:
        if p["name"] is not None:
            pl = named_plant(p["name"])
        elif p["B"] is not None:
            if p["A"] is None:
                raise _err(path, ("plant", "A"), "missing required key (with 'B')")
            pl = Plant(p["B"], p["A"], label="plant")
        else:
            if p["poles"] is None or p["gain"] is None:
                raise _err(path, ("plant",), "'zeros' needs 'poles' and 'gain'")
            pl = Plant.from_zpk(p["zeros"], p["poles"], p["gain"])
    except SpecError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise _err(path, ("plant",), str(exc)) from None
    return Plant(pl.B, pl.A, label=f"T{T:g}C", temperature_C=T, meta=pl.meta)


def _family(path, f, nominal):
    from robrst.family import PlantFamily

    if f is None:
        return PlantFamily(models=(nominal,), reference=0)
    ref = f["reference_C"] if f["reference_C"] is not None else nominal.temperature_C
    if f["models"] is not None:
        if f["temperatures_C"] is not None or f["parametric"] is not None:
            raise _err(path, ("family",), "give either 'models' or 'temperatures_C'+'parametric'")
        models = []
        for i, m in enumerate(f["models"]):
            try:
                models.append(Plant(m["B"], m["A"], label=f"T{m['temperature_C']:g}C",
                                    temperature_C=m["temperature_C"]))
            except SpecError as exc:
                raise _err(path, ("family", "models", str(i)), str(exc)) from None
        try:
            return explicit_family(models, ref)
        except SpecError as exc:
            raise _err(path, ("family", "models"), str(exc)) from None
    if f["temperatures_C"] is None:
        raise _err(path, ("family", "temperatures_C"), "missing required key")
    par = f["parametric"] or _validate(path, {}, SCHEMA["family"]["parametric"])
    coeffs = ThermalCoefficients(reference_C=ref, **par)
    try:
        return parametric_family(nominal, f["temperatures_C"], coeffs)
    except SpecError as exc:
        raise _err(path, ("family",), str(exc)) from None


def _poles(path, p):
    if p is None:
        raise _err(path, ("poles",), "missing required table [poles]")
    dom = None
    if p["dominant_roots_re"] is not None:
        im = p["dominant_roots_im"] or [0.0] * len(p["dominant_roots_re"])
        if len(im) != len(p["dominant_roots_re"]):
            raise _err(path, ("poles", "dominant_roots_im"), "must match dominant_roots_re in length")
        dom = tuple(complex(a, b) for a, b in zip(p["dominant_roots_re"], im))
    elif p["wn"] is None or p["zeta"] is None:
        raise _err(path, ("poles",), "give 'wn' and 'zeta' (or 'dominant_roots_re')")
    spec = PoleSpec(wn=p["wn"], zeta=p["zeta"], dominant_real=tuple(p["dominant_real"]),
                    dominant_roots=dom, aux_factor=p["aux_factor"],
                    aux_roots=None if p["aux_roots"] is None else tuple(p["aux_roots"]))
    try:
        spec.dominant()
    except SpecError as exc:
        raise _err(path, ("poles",), str(exc).removeprefix("poles: ")) from None
    return spec


def _choice(path, key, value, choices):
    if value not in choices:
        raise _err(path, key, f"expected one of {', '.join(choices)}, got {value!r}")


def parse_problem(data, path="<problem>"):
    """Validate a parsed TOML document; see :func:`load_problem`."""
    v = _validate(path, data, SCHEMA)
    nominal = _plant(path, v["plant"])
    family = _family(path, v["family"], nominal)
    poles = _poles(path, v["poles"])
    ctrl = v["controller"] or _validate(path, {}, SCHEMA["controller"])
    specs = v["specs"] or _validate(path, {}, SCHEMA["specs"])
    solver = v["solver"] or _validate(path, {}, SCHEMA["solver"])
    _choice(path, ("controller", "T_mode"), ctrl["T_mode"], ("paper", "static", "cancel_aux"))
    _choice(path, ("solver", "method"), solver["method"], ("analytic", "nlp", "convex"))
    _choice(path, ("solver", "init"), solver["init"], ("analytic", "convex"))
    _choice(path, ("solver", "objective"), solver["objective"],
            ("max_integral_gain", "min_Ms", "feasibility"))
    if ctrl["extra_degree"] < 0:
        raise _err(path, ("controller", "extra_degree"), "must be >= 0")
    if len(ctrl["S_fixed"]) < 2 or ctrl["S_fixed"][-1] != 0.0:
        raise _err(path, ("controller", "S_fixed"), "must contain the integrator s (last coefficient 0)")
    for k in ("Ms_max", "Mt_max", "Mu_max", "T_resonance_max"):
        if specs[k] is not None and specs[k] <= 0:
            raise _err(path, ("specs", k), f"must be > 0, got {specs[k]}")
    if specs["Ms_max"] is not None and specs["Ms_max"] < 1:
        raise _err(path, ("specs", "Ms_max"), "must be >= 1 (|S| tends to 1 at high frequency)")
    if specs["sample_rate_hz"] is not None and not specs["sample_rate_hz"] > 0:
        raise _err(path, ("specs", "sample_rate_hz"), f"must be > 0, got {specs['sample_rate_hz']}")
    if specs["delay_samples"] < 0:
        raise _err(path, ("specs", "delay_samples"), "must be >= 0")
    if specs["delay_samples"] and specs["sample_rate_hz"] is None:
        raise _err(path, ("specs", "delay_samples"), "needs 'sample_rate_hz'")
    if (specs["T_resonance_max"] is None) != (specs["resonance_band_hz"] is None):
        raise _err(path, ("specs",), "'T_resonance_max' and 'resonance_band_hz' go together")
    for k in ("wn_bounds", "zeta_bounds", "resonance_band_hz"):
        tab = "specs" if k == "resonance_band_hz" else "solver"
        b = (specs if tab == "specs" else solver)[k]
        if b is not None and (len(b) != 2 or not 0 < b[0] < b[1]):
            raise _err(path, (tab, k), f"expected [lo, hi] with 0 < lo < hi, got {b}")
    if solver["init"] == "convex" and solver["free_poles"]:
        raise _err(path, ("solver", "init"), "'convex' needs a fixed Am (free_poles = false):"
                   " the SOCP is posed at fixed closed-loop poles")
    if solver["free_poles"] and (solver["wn_bounds"] is None or solver["zeta_bounds"] is None):
        raise _err(path, ("solver", "free_poles"), "needs 'wn_bounds' and 'zeta_bounds'")
    for k in ("n_freq", "max_rounds", "cert_temperatures", "max_iter"):
        if solver[k] < 1:
            raise _err(path, ("solver", k), "must be >= 1")
    name = (v["problem"] or {}).get("name") or Path(str(path)).stem
    return Problem(name=name, path=str(path), family=family, poles=poles, controller=ctrl,
                   specs=specs, solver=solver, raw=data)


def load_problem(path):
    """Read and validate a TOML problem file.

    Raises
    ------
    SpecError
        Naming the file and the key path of the first problem found.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SpecError(f"{path}: cannot read problem file ({exc.strerror})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: invalid TOML ({exc})") from None
    return parse_problem(data, path)
