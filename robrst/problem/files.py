"""Problem files (TOML) -> a validated :class:`~robrst.problem.records.Problem`.

Every key is declared in :data:`SCHEMA` (validated by the neutral :mod:`robrst.base.schema`);
unknown or misspelled keys are rejected with the file name, the key path and the
closest valid key.  The documentation's problem-file reference is generated from the
same schema (:func:`schema_markdown`).  Built-in problem files ship with the package (:mod:`robrst.base.resources`).
"""

import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from robrst.base import resources
from robrst.base.errors import SpecError
from robrst.base.modelformat import read_model_table
from robrst.core.lti import modal_polynomials
from robrst.core.family import PlantFamily, ThermalCoefficients, explicit_family, parametric_family
from robrst.core.plant import Plant, named_plant
from robrst.problem.records import (AUX_MIN_FACTOR, HOMOTOPIES, INITS, METHODS, OBJECTIVES,
                            PLACEMENTS, T_MODES, ControllerStructure, Problem, SolverOptions, Specs)
from robrst.problem.specs import DEFAULTED, specs_schema
from robrst.base.schema import ArrayOf, Field, key_error, load_toml, markdown_rows, validate
from robrst.problem.spread import (COEF as COEF_NAME, DIST_KEYS, RANDOM_DISTS, SPREAD_METHODS,
                                   THERMAL_KEYS, Param, Spread, check_plant_params,
                                   check_truncation)
from robrst.problem.checks import (MAX_RATE, MIN_RATE, MIN_RATE_HZ, check_combinations, check_generated,
                              check_pairs, check_rates, pole_spec)

__all__ = ["load_problem", "parse_problem", "resolve_problem_path", "SCHEMA", "schema_markdown",
           "FAMILY_TABLES", "model_document"]

TEMP = dict(lo=-100.0, hi=500.0)      # plausible temperatures [°C]
BAND = dict(positive=True, length=2)  # [lo, hi] pairs
# size limits: beyond them the float64 maths overflows (root products, Sylvester matrices);
# poles robrst generates from several keys are checked by robrst.problem.checks
RATE = dict(lo=-MAX_RATE, hi=MAX_RATE)
COEF = dict(lo=-1e100, hi=1e100)      # polynomial coefficients and gains
FAMILY_TABLES = ("plant", "family")   # the tables the plant family is built from (alone)

SCHEMA = {
    "problem": {
        "name": Field("str", None, "problem name (default: file stem)"),
        "description": Field("str", "", "free text"),
    },
    "plant": {
        "name": Field("str", None, "built-in model: 'paper' = D(s) of eq. (4)"),
        "B": Field("numbers", None, "numerator coefficients [µm/V], highest power first",
                   **COEF),
        "A": Field("numbers", None, "denominator coefficients, highest power first",
                   **COEF),
        "zeros": Field("numbers", None, "real zeros [rad/s] (with 'poles', 'gain')", **RATE),
        "poles": Field("numbers", None, "real poles [rad/s]", **RATE),
        "gain": Field("number", None, "leading gain k of k*prod(s-z)/prod(s-p)", **COEF),
        "temperature_C": Field("number", 28.0, "temperature of the nominal model [°C] (default"
                               " a parametric family's reference_C when given, else 28)", **TEMP),
        "source": Field("str", "", "where the model comes from"),
    },
    "family": {
        "reference_C": Field("number", None, "temperature of the nominal model (default"
                             " plant.temperature_C; with [[family.models]] and no [plant], the"
                             " coldest model's); a parametric family's law moves [plant] from"
                             " it, so a [plant] temperature_C must equal it", **TEMP),
        "temperatures_C": Field("numbers", None, "temperatures of a parametric family [°C]", **TEMP),
        "source": Field("str", "", "where the coefficients come from"),
        "parametric": {
            "gain_per_K": Field("number", 0.0, "relative change per K of B (the static gain also moves as 1/wn^2 of each resonance)"),
            "resonance_per_K": Field("number", 0.0, "relative natural-frequency change per K of"
                                     " every resonant pole pair of A (damping < 0.999)"),
            "damping_per_K": Field("number", 0.0, "relative damping change per K of every"
                                   " resonant pole pair of A; real poles stay"),
            "creep_per_K": Field("number", 0.0, "creep strength gained per K above reference"),
            "creep_at_ref": Field("number", 0.0, "creep strength at the reference temperature"),
            "creep_tau_s": Field("number", 1.0, "creep time constant [s]",
                                 lo=1 / MAX_RATE, hi=1 / MIN_RATE),
        },
        "models": ArrayOf({
            "temperature_C": Field("number", None, "temperature [°C]", required=True, **TEMP),
            "B": Field("numbers", None, "numerator coefficients", required=True, **COEF),
            "A": Field("numbers", None, "denominator coefficients", required=True, **COEF),
        }),
    },
    "controller": {
        "S_fixed": Field("numbers", (1.0, 0.0), "fixed factor of S (must contain s)"),
        "R_fixed": Field("numbers", (1.0,), "fixed factor of R (e.g. a roll-off)"),
        "extra_degree": Field("int", 0, "degrees of S above the paper's minimum", lo=0, hi=20),
        "T_mode": Field("str", "paper", "paper | static | cancel_aux | reference_model",
                        choices=T_MODES),
        "T_zeros": Field("numbers", (), "zeros of T = Bm_aux [rad/s] (T_mode = paper)", **RATE),
        "relative_degree": Field("int", 0, "deg R <= deg S - this (1: strictly proper controller)",
                                 lo=0, hi=10),
        "roll_off_order": Field("int", 0, "poles of a fixed roll-off factor (s/wc + 1)^order in S"
                                " (adds to the relative degree)", lo=0, hi=10),
        "roll_off_hz": Field("number", None, "corner wc/2pi of the roll-off factor [Hz]",
                             lo=MIN_RATE_HZ, hi=1.5e8),
        "reference_wn": Field("number", None, "reference model bandwidth [rad/s]"
                              " (T_mode = reference_model)", lo=MIN_RATE, hi=MAX_RATE),
        "reference_zeta": Field("number", 1.0, "reference model damping (its poles within"
                                " [1e-6, 1e9] rad/s)", positive=True),
        "T_cancel_damping": Field("number", 0.5, "T cancels nominal closed-loop factors at least"
                                  " this damped (T_mode = reference_model)", lo=0.0, hi=1.0),
    },
    "poles": {
        "wn": Field("number", None, "dominant natural frequency [rad/s]", lo=MIN_RATE,
                    hi=MAX_RATE),
        "zeta": Field("number", None, "dominant damping (the pair's poles within [1e-6, 1e9]"
                      " rad/s)", positive=True),
        "dominant_real": Field("numbers", (), "extra dominant real poles [rad/s, < 0]", **RATE),
        "dominant_roots_re": Field("numbers", None, "explicit dominant roots, real parts",
                                   **RATE),
        "dominant_roots_im": Field("numbers", None, "explicit dominant roots, imaginary parts"
                                   " (with dominant_roots_re)", **RATE),
        "aux_factor": Field("number", 10.0, "auxiliary poles at -aux_factor*|fastest dominant|"
                            " (within 1e9 rad/s)", lo=AUX_MIN_FACTOR, hi=1e4),
        "aux_roots": Field("numbers", None, "explicit real auxiliary roots [rad/s]", **RATE),
    },
    "specs": specs_schema(),       # one row per spec: robrst.problem.specs
    "solver": {
        "method": Field("str", None, "analytic | nlp | convex; default: nlp (the robust"
                        " program) when [specs] bounds anything, else analytic",
                        choices=METHODS),
        "objective": Field("str", "max_integral_gain", "max_integral_gain | min_Ms | feasibility",
                           choices=OBJECTIVES),
        "free_poles": Field("bool", False, "let wn and zeta vary within the bounds"),
        "wn_bounds": Field("numbers", None, "[lo, hi] rad/s", **BAND),
        "zeta_bounds": Field("numbers", None, "[lo, hi]", **BAND),
        "n_freq": Field("int", 120, "frequency-grid points per model", lo=2, hi=20000),
        "max_rounds": Field("int", 6, "certification rounds", lo=1, hi=100),
        "exchange": Field("bool", True, "impose the grid by constraint exchange (active subset,"
                          " grown until every grid point holds); false: every point in one NLP"),
        "cert_temperatures": Field("int", 35, "temperatures in the certification sweep",
                                   lo=1, hi=10000),
        "cert_tol": Field("number", 1e-3, "relative tolerance on certified peaks",
                          positive=True, hi=0.1),
        "init": Field("str", "analytic", "NLP start: analytic (Sylvester) | convex (nominal SOCP;"
                      " fixed poles only)", choices=INITS),
        "max_iter": Field("int", 500, "IPOPT iterations", lo=1, hi=100000),
        "ipopt_tol": Field("number", 1e-9, "IPOPT tolerance", positive=True, hi=1e-2),
        "compare_with": Field("str", None, "problem file (relative) whose analytic design is"
                              " compared"),
        "placement": Field("str", "auto", "nominal closed-loop poles: fixed (as [poles] and"
                           " free_poles ask) | free (every coefficient free: the global phase)"
                           " | auto (both, the better certified answer)", choices=PLACEMENTS),
        "homotopy": Field("str", "on_failure", "lower extra_degree solved first: on_failure |"
                          " always (more degrees never certify a worse objective)",
                          choices=HOMOTOPIES),
        "multistart": Field("bool", True, "nlp: run the global phase (every controller of the"
                            " structure searched by CMA-ES, the best distinct candidates"
                            " polished and certified, in process); false: one local run from"
                            " the problem's start (sweeps)"),
        "starts": Field("int", 2, "nlp global phase: distinct candidates polished beyond the"
                        " best (0: no global phase, one local run)", lo=0, hi=64),
        "edge_runs": Field("bool", True, "nlp global phase, max_integral_gain: also search"
                           " the controllers with one and two poles at the controller-pole"
                           " strip's edge (four CMA-ES runs more)"),
        "bound": Field("bool", True, "state what any linear controller could reach on the"
                       " family (the objective's estimate; always when not certified)"),
    },
    "spread": {
        "yield": Field("number", 0.95, "share of the actuators the controller must certify on"
                       " (the yield target)", lo=0.5, hi=0.9999),
        "confidence": Field("number", 0.99, "confidence 1 - beta of the scenario guarantee",
                            lo=0.5, hi=1 - 1e-9),
        "seed": Field("int", 0, "seed of the drawn actuators (numpy.random.default_rng)", lo=0),
        "method": Field("str", "scenario", "scenario (drawn actuators, a stated yield) | box"
                        " (worst case over the parameter box: centre and corners)",
                        choices=SPREAD_METHODS),
        "scenarios": Field("int", None, "drawn actuators (default: from the scenario bound of"
                           " yield, confidence and the decision variables)", lo=1, hi=100_000),
        "box_sigmas": Field("number", 3.0, "box: half-width of a normal or lognormal"
                            " parameter in standard deviations (within its truncation)",
                            positive=True, hi=10.0),
        "cert_temperatures": Field("int", None, "temperatures of the certificate on each drawn"
                                   " actuator (default: solver.cert_temperatures)",
                                   lo=1, hi=10000),
        "param": ArrayOf({
            "name": Field("str", None, "gain, resonance, damping, a coefficient factor (A1, B0,"
                          " ...) or a per-kelvin law (family.parametric.gain_per_K, ...)",
                          required=True),
            "dist": Field("str", None, "normal | uniform | lognormal", required=True,
                          choices=RANDOM_DISTS),
            "mean": Field("number", None, "normal: mean"),
            "std": Field("number", None, "normal: standard deviation", positive=True),
            "median": Field("number", None, "lognormal: median", positive=True),
            "sigma": Field("number", None, "lognormal: standard deviation of the logarithm",
                           positive=True),
            "lo": Field("number", None, "uniform: lower end; normal, lognormal: truncation"),
            "hi": Field("number", None, "uniform: upper end; normal, lognormal: truncation"),
            "note": Field("str", "", "where the spread comes from"),
        }, doc="one parameter of the manufacturing spread", max_items=64),
    },
}


def schema_markdown() -> list[str]:
    """The problem-file reference as Markdown table rows (rendered in the documentation).

    Returns
    -------
    list of str
        One row ``| table | key | type | required | default | meaning |`` per key of
        :data:`SCHEMA`.
    """
    return markdown_rows(SCHEMA)


def _plant(path, p):
    if p is None:
        raise key_error(path, ("plant",), "missing required table [plant]")
    kinds = [k for k in ("name", "B", "zeros") if p[k] is not None]
    if p["A"] is not None and p["B"] is None:
        raise key_error(path, ("plant", "B"), "missing: 'A' is given without 'B'")
    if len(kinds) != 1:
        raise key_error(path, ("plant",), "give exactly one of: name | B and A | zeros, poles and gain")
    T = p["temperature_C"]
    try:
        if p["name"] is not None:
            pl = named_plant(p["name"])
        elif p["B"] is not None:
            if p["A"] is None:
                raise key_error(path, ("plant", "A"), "missing required key (with 'B')")
            pl = Plant(p["B"], p["A"], label="plant")
        else:
            if p["poles"] is None or p["gain"] is None:
                raise key_error(path, ("plant",), "'zeros' needs 'poles' and 'gain'")
            pl = Plant.from_zpk(p["zeros"], p["poles"], p["gain"])
    except SpecError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise key_error(path, ("plant",), str(exc)) from None
    return check_rates(path, ("plant",),
                        Plant(pl.B, pl.A, label=f"T{T:g}C", temperature_C=T, meta=pl.meta))


def _same_degrees(path, models):
    """An explicit family interpolates coefficient by coefficient: one degree of A and of B."""
    order = sorted(range(len(models)), key=lambda i: models[i].temperature_C)
    for i, j in zip(order[:-1], order[1:]):
        a, b = models[i], models[j]
        if (a.n, a.m) != (b.n, b.m):
            raise key_error(path, ("family", "models", str(j)),
                            f"degrees (A {b.n}, B {b.m}) differ from those at"
                            f" {a.temperature_C:g} °C (A {a.n}, B {a.m}): an explicit family"
                            " interpolates coefficient by coefficient between neighbours, so"
                            " every model needs the same degrees")


PLANT_IN_FAMILY_RTOL = 1e-9   # [plant] beside [[family.models]]: the model at its temperature


def _check_plant_in_family(path, nominal, family):
    """With ``[[family.models]]`` the models are the family's: a ``[plant]`` beside them is
    not used, so it must be the family's model at its temperature (as ``robrst identify``
    writes it); a different one would be ignored silently."""
    from robrst.core.poly import rel_coef_error

    lo, hi = family.range_C
    T = nominal.temperature_C
    why = ("[[family.models]] define the models and [plant] is not used beside them: remove"
           " [plant], or give it as the family's model at its temperature")
    if not lo <= T <= hi:
        raise key_error(path, ("plant", "temperature_C"), f"{T:g} °C is outside the models'"
                        f" range [{lo:g}, {hi:g}] °C; {why}")
    m = family.at(T)
    same = len(m.A) == len(nominal.A) and len(m.B) == len(nominal.B) and max(
        rel_coef_error(nominal.A, m.A), rel_coef_error(nominal.B, m.B)
    ) <= PLANT_IN_FAMILY_RTOL
    if not same:
        raise key_error(path, ("plant",), f"differs from the family's model at {T:g} °C"
                        f" (B = {list(m.B)}, A = {list(m.A)}); {why}")


def _law_reference(path, data, v):
    """A parametric family moves ``[plant]`` by its law from ``reference_C``: the plant is
    the model at ``reference_C``.  Without its own ``temperature_C`` it takes that one
    (not the default 28 °C); with a different one the two keys contradict each other (the
    law would move the plant's model by the wrong number of kelvin, silently)."""
    fam, plant = v["family"], v["plant"]
    if plant is None or fam is None or fam["models"] or fam["reference_C"] is None:
        return
    ref = fam["reference_C"]
    if "temperature_C" not in (data.get("plant") or {}):
        plant["temperature_C"] = ref
    elif plant["temperature_C"] != ref:
        raise key_error(path, ("family", "reference_C"),
                        f"{ref:g} °C differs from [plant] temperature_C = "
                        f"{plant['temperature_C']:g} °C: a parametric family moves the [plant]"
                        " model by its law from reference_C, so [plant] is the model at"
                        " reference_C; give them equal, or omit reference_C (it defaults to"
                        " the plant's temperature)")


def _family(path, f, nominal):
    """The family; no ``[plant]``: reference at ``reference_C``, default the coldest model."""
    if f is None:
        return PlantFamily(models=(nominal,), reference=0)
    ref = f["reference_C"] if f["reference_C"] is not None else (
        nominal.temperature_C if nominal else min(m["temperature_C"] for m in f["models"]))
    if f["models"] is not None:
        if f["temperatures_C"] is not None or f["parametric"] is not None:
            raise key_error(path, ("family",), "give either 'models' or 'temperatures_C'+'parametric'")
        if not f["models"]:
            raise key_error(path, ("family", "models"), "expected at least one [[family.models]]")
        models = []
        for i, m in enumerate(f["models"]):
            try:
                models.append(Plant(m["B"], m["A"], label=f"T{m['temperature_C']:g}C",
                                    temperature_C=m["temperature_C"]))
            except SpecError as exc:
                raise key_error(path, ("family", "models", str(i)), str(exc)) from None
            check_rates(path, ("family", "models", str(i)), models[-1])
        _same_degrees(path, models)
        try:
            return explicit_family(models, ref)
        except SpecError as exc:
            raise key_error(path, ("family", "models"), str(exc)) from None
    if not f["temperatures_C"]:
        raise key_error(path, ("family", "temperatures_C"), "missing required key" if
                        f["temperatures_C"] is None else "expected at least one temperature")
    par = f["parametric"] or validate(path, {}, SCHEMA["family"]["parametric"])
    coeffs = ThermalCoefficients(reference_C=ref, **par)
    try:
        return parametric_family(nominal, f["temperatures_C"], coeffs)
    except SpecError as exc:
        raise key_error(path, ("family",), str(exc)) from None


def _solver(t, specs):
    """The solver options; no ``method``: the robust program when the specs bound anything
    (``method_source`` says which rule chose it)."""
    if t["method"] is None:
        return SolverOptions(**{**t, "method": "nlp" if specs.bounded else "analytic",
                                "method_source": "default"})
    return SolverOptions(**t)


def _table(path, v, name):
    return v[name] or validate(path, {}, SCHEMA[name], (name,))


def _check_compare_with(path, solver):
    """The compared problem file exists and is a valid problem (its own compare_with is
    checked when it is designed)."""
    other = solver.compare_with
    if other is None or str(path).startswith("<"):
        return
    target = Path(str(path)).parent / other
    if not target.is_file():
        what = "is a folder" if target.is_dir() else "not found"
        raise key_error(path, ("solver", "compare_with"), f"{target}: {what}; expected a problem"
                        " file (a path relative to this file)")
    try:
        parse_problem(load_toml(target, "problem file"), target, compare=False)
    except SpecError as exc:
        raise key_error(path, ("solver", "compare_with"), f"not a valid problem file: {exc}"
                        ) from None


def model_document(path: str | os.PathLike, data: dict) -> dict:
    """The problem document of a model file of ``robrst identify`` (``[model]``).

    One input and one output: its ``[[model.at]]`` become ``[plant]`` (the first, lowest
    temperature: the reference) and, for several temperatures, an explicit ``[family]``,
    as ``robrst identify`` writes a problem file; the design tables the file carries
    (:data:`robrst.base.modelformat.DESIGN_TABLES`) are kept.

    Parameters
    ----------
    path : str or Path
        Named in every error.
    data : dict
        The parsed model file.

    Returns
    -------
    dict
        A problem document (:func:`parse_problem` takes it).

    Raises
    ------
    SpecError
        Naming the file and the key: a bad ``[model]`` table, several inputs or outputs,
        ``[plant]`` or ``[family]`` beside it, an order whose expanded polynomials overflow.
    """
    table = read_model_table(path, data, design_tables=True)
    if (table.inputs, table.outputs) != (1, 1):
        raise key_error(path, ("model",), f"a model of {table.inputs} input(s) and"
                        f" {table.outputs} output(s); a problem needs one input and one"
                        " output (robrst identify --channel I,J writes the problem file of"
                        " one channel)")
    polys = []
    for n, at in enumerate(table.at):
        B, A = modal_polynomials(at.poles, at.residues[:, 0, 0], at.D[0, 0])
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
            raise key_error(path, ("model", "at", str(n)), f"its expanded polynomials B(s),"
                            f" A(s) of order {len(A) - 1} overflow float64; a design needs"
                            " them (identify a lower order)")
        polys.append((B.tolist(), A.tolist(), at.temperature_C))
    doc = {k: v for k, v in data.items() if k != "model"}
    B, A, T0 = polys[0]
    doc["plant"] = {"B": B, "A": A, "source": "model file (robrst identify)"}
    if T0 is not None:
        doc["plant"]["temperature_C"] = T0
    if len(polys) > 1:
        doc["family"] = {"reference_C": T0, "models": [
            {"temperature_C": T, "B": B, "A": A} for B, A, T in polys]}
    return doc


def parse_problem(data: dict, path: str | Path = "<problem>", compare: bool = True) -> Problem:
    """Validate a parsed TOML document and build the :class:`~robrst.problem.records.Problem`.

    Parameters
    ----------
    data : dict
        The parsed TOML document.
    path : str or pathlib.Path
        Where it came from (named in every error).
    compare : bool
        Also validate the ``[solver] compare_with`` problem file.

    Returns
    -------
    Problem

    Raises
    ------
    SpecError
        Naming the file and the key path of the first problem found.
    """
    if isinstance(data, dict) and "model" in data:    # a model file of robrst identify
        data = model_document(path, data)
    v = validate(path, data, SCHEMA)
    _law_reference(path, data, v)
    explicit = v["plant"] is None and v["family"] is not None and v["family"]["models"]
    nominal = None if explicit else _plant(path, v["plant"])
    family = _family(path, v["family"], nominal)
    if nominal is not None and v["family"] is not None and v["family"]["models"]:
        _check_plant_in_family(path, nominal, family)
    poles = pole_spec(path, v["poles"])
    ctrl = ControllerStructure(**_table(path, v, "controller"))
    specs = _specs(_table(path, v, "specs"))
    solver = _solver(_table(path, v, "solver"), specs)
    for k in ("S_fixed", "R_fixed"):
        if not getattr(ctrl, k) or getattr(ctrl, k)[0] == 0.0:
            raise key_error(path, ("controller", k), "expected polynomial coefficients, highest"
                            f" power first, with a non-zero leading one, got {list(getattr(ctrl, k))}")
    if len(ctrl.S_fixed) < 2 or ctrl.S_fixed[-1] != 0.0:
        raise key_error(path, ("controller", "S_fixed"),
                        "must contain the integrator s (last coefficient 0)")
    if specs.delay_samples and specs.sample_rate_hz is None:
        raise key_error(path, ("specs", "delay_samples"), "needs 'sample_rate_hz'")
    if (specs.T_resonance_max is None) != (specs.resonance_band_hz is None):
        raise key_error(path, ("specs",), "'T_resonance_max' and 'resonance_band_hz' go together")
    check_combinations(path, ctrl, specs)
    check_pairs(path, specs, solver)
    if solver.init == "convex" and solver.free_poles:
        raise key_error(path, ("solver", "init"), "'convex' needs a fixed Am (free_poles = false):"
                        " the SOCP is posed at fixed closed-loop poles")
    if solver.free_poles and (solver.wn_bounds is None or solver.zeta_bounds is None):
        raise key_error(path, ("solver", "free_poles"), "needs 'wn_bounds' and 'zeta_bounds'")
    meta = v["problem"] or {}
    name = meta.get("name") or Path(str(path)).stem
    problem = Problem(name=name, family=family, poles=poles, controller=ctrl, specs=specs,
                      solver=solver, path=str(path), description=meta.get("description", ""),
                      plant_name=(v["plant"] or {}).get("name"))
    check_generated(path, problem)
    if v["spread"] is not None:
        if solver.method != "nlp":
            raise key_error(path, ("spread",), "a design for a spread needs [solver] method ="
                            f" 'nlp' (got '{solver.method}')")
        problem = replace(problem, spread=_spread(path, v["spread"], family))
    if compare:
        _check_compare_with(path, solver)
    return problem


def _specs(table):
    """The :class:`Specs` of a validated ``[specs]`` table: a default switched off by
    ``false`` is named in ``off`` (``damping_min``: also 0)."""
    off = tuple(k for k in DEFAULTED if table.get(k) is False)
    table = {k: (None if k in off else v) for k, v in table.items()}
    if "damping_min" in off:
        table["damping_min"] = 0.0
    return Specs(**table, off=off)


def _spread(path, sp, family):
    """The :class:`~robrst.problem.spread.Spread` of a validated ``[spread]`` table."""
    params = []
    for i, p in enumerate(sp["param"] or ()):
        key = ("spread", "param", str(i))
        name, dist = p["name"], p["dist"]
        if name not in THERMAL_KEYS and name not in ("gain", "resonance", "damping") \
                and not COEF_NAME.match(name):
            raise key_error(path, key + ("name",), f"unknown parameter {name!r}: expected gain,"
                            " resonance, damping, A<i>, B<i> or one of " + ", ".join(THERMAL_KEYS))
        if name in [q.name for q in params]:
            raise key_error(path, key + ("name",), f"parameter {name!r} given twice")
        given = {k for k in ("mean", "std", "median", "sigma", "lo", "hi") if p[k] is not None}
        need, allowed = DIST_KEYS[dist]
        for k in sorted(need - given):
            raise key_error(path, key + (k,), f"missing: dist = '{dist}' needs "
                            + " and ".join(sorted(need)))
        for k in sorted(given - need - allowed):
            raise key_error(path, key + (k,), f"not used by dist = '{dist}'")
        lo, hi = p["lo"], p["hi"]
        if lo is not None and hi is not None and not lo < hi:
            raise key_error(path, key, f"expected lo < hi, got lo = {lo:g}, hi = {hi:g}")
        if dist == "lognormal" and lo is not None and not lo > 0:
            raise key_error(path, key + ("lo",), "lognormal truncation needs lo > 0")
        if dist in ("normal", "lognormal") and (lo is not None or hi is not None):
            check_truncation(path, key, dist, p)     # a truncation holding no probability
        params.append(Param(name=name, dist=dist, mean=p["mean"], std=p["std"],
                            median=p["median"], sigma=p["sigma"], lo=lo, hi=hi, note=p["note"]))
    if not params:
        raise key_error(path, ("spread", "param"), "a spread needs at least one"
                        " [[spread.param]] table (what varies between the actuators)")
    try:
        check_plant_params(params, family, path)
    except SpecError as exc:
        raise key_error(path, ("spread", "param"), str(exc).removeprefix(f"{path}: ")) from None
    if sp["method"] == "box" and len(params) > 12:
        raise key_error(path, ("spread", "method"), f"a box of {len(params)} parameters has"
                        f" {2 ** len(params)} corners; at most 12 parameters")
    return Spread(params=tuple(params), yield_target=sp["yield"], confidence=sp["confidence"],
                  seed=sp["seed"], method=sp["method"], scenarios=sp["scenarios"],
                  box_sigmas=sp["box_sigmas"], cert_temperatures=sp["cert_temperatures"])


def resolve_problem_path(name_or_path: str | os.PathLike) -> Path:
    """A problem file's path: an existing file, or a built-in problem by name.

    ``"paper_robust"`` and ``"paper_robust.toml"`` name the built-in problem when no
    such file exists in the current folder.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A file, or a built-in problem's name.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    SpecError
        Neither a file nor a built-in problem (the message lists the built-ins).
    """
    found = resources.find_file(name_or_path, "problem")
    if found is not None:
        return found
    raise SpecError(f"{name_or_path}: problem file not found (built-in problems:"
                    f" {', '.join(resources.problem_names())})")


def load_problem(path: str | os.PathLike) -> Problem:
    """Read and validate a TOML problem file (or a built-in problem by name).

    Parameters
    ----------
    path : str or Path
        A problem file, or the name of a built-in problem (``"paper_robust"``).

    Returns
    -------
    Problem

    Raises
    ------
    SpecError
        Naming the file and the key path of the first problem found.

    Examples
    --------
    >>> from robrst import load_problem
    >>> load_problem("paper").specs.Ms_max
    2.0
    """
    path = resolve_problem_path(path)
    return parse_problem(load_toml(path, "problem file"), path)
