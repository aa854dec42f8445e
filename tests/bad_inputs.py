"""The bad inputs of tests/cli/test_bad_input.py: files to create, the command line, and what the
error line must name.

Each :class:`V` names the files to write into an empty working folder (text, bytes or
:data:`DIR` for a folder), the ``robrst`` arguments, and substrings the one error line must
contain (the file, the key path or column, what was expected).
"""

import json
import math
from dataclasses import dataclass, field

import numpy as np

# ---------------------------------------------------------------------------- builders


def toml(doc):
    """A small TOML writer for tables of scalars and lists (enough for these files)."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, float):
            return "nan" if math.isnan(v) else ("inf" if v == math.inf else
                                                "-inf" if v == -math.inf else repr(v))
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return str(v)

    lines = []
    for tab, body in doc.items():
        lines.append(f"[{tab}]")
        lines.extend(f"{k} = {val(v)}" for k, v in body.items())
    return "\n".join(lines) + "\n"


BASE = {
    "plant": {"name": "paper", "temperature_C": 28.0},
    "controller": {"S_fixed": [1.0, 0.0], "extra_degree": 1},
    "poles": {"wn": 600.0, "zeta": 1.0},
    "specs": {"Ms_max": 2.0, "Mu_max": 150.0},
    "solver": {"method": "analytic"},
}


def problem(**changes):
    """BASE with ``table__key=value`` changes (``None`` removes the key; ``table=None`` the table)."""
    doc = {t: dict(b) for t, b in BASE.items()}
    for name, v in changes.items():
        if "__" not in name:
            if v is None:
                doc.pop(name, None)
            else:
                doc[name] = v
            continue
        tab, key = name.split("__")
        doc.setdefault(tab, {})
        if v is None:
            doc[tab].pop(key, None)
        else:
            doc[tab][key] = v
    return toml(doc)


GOOD = problem()


def csv(n=600, fs=1000.0, header="t,u,y,temp", rows=None, comments=("# record",)):
    """A valid dataset CSV (or its header with the given rows)."""
    if rows is None:
        t = np.arange(n) / fs
        u = 10.0 + 5.0 * np.sin(2 * np.pi * 20 * t)
        y = 0.5 * u
        rows = [f"{a:.12g},{b:.9g},{c:.9g},28" for a, b, c in zip(t, u, y)]
    return "\n".join([*comments, header, *rows]) + "\n"


def csv_rows(fn, n=600, fs=1000.0):
    """Rows ``t,u,y,temp`` with ``fn(i, row_list)`` editing each row list of strings."""
    out = []
    for i in range(n):
        t = i / fs
        u = 10.0 + 5.0 * math.sin(2 * math.pi * 20 * t)
        row = [f"{t:.12g}", f"{u:.9g}", f"{0.5 * u:.9g}", "28"]
        out.append(",".join(fn(i, row) or row))
    return out


GOOD_CSV = csv()
GOLDEN_OK = '[golden]\nformat = 1\nproblem = "paper"\n[design]\ncertified = true\n'


@dataclass(frozen=True)
class V:
    """One bad-input variant: files to create (name -> text/bytes/DIR), argv, substrings."""

    id: str
    files: dict
    argv: tuple
    expect: tuple = ()
    extra: dict = field(default_factory=dict)


DIR = object()    # a folder in `files`


def design(id, text, expect=(), name="p.toml"):
    """`robrst design FILE --quiet` on a problem file ``text``."""
    return V(id, {name: text}, ("design", name, "--quiet"), (name, *expect))


def diag(id, text, expect=(), which="train"):
    """`robrst diagnose` with one bad data file ``text`` (the other is valid)."""
    files = {"good.csv": GOOD_CSV, "bad.csv": text}
    other = "test" if which == "train" else "train"
    argv = ("diagnose", f"--{which}", "bad.csv", f"--{other}", "good.csv", "--quiet",
            "--json", "out.json")
    return V(id, files, argv, ("bad.csv", *expect))


def twin(id, text, expect=(), name="twin.toml"):
    """`robrst simulate fig2 --twin FILE` on a twin file ``text``."""
    return V(id, {name: text}, ("simulate", "fig2", "--twin", name, "--fast", "--quiet",
                                "--out", "sim"), (name, *expect))


def sweepf(id, text, expect=(), extra=()):
    return V(id, {"s.toml": text, "p.toml": GOOD}, ("sweep", "s.toml", "--workers", "0",
                                                    "--quiet", "--out", "sw", *extra),
             ("s.toml", *expect))


def golden(id, text, expect=(), extra=()):
    return V(id, {"g.toml": text, "p.toml": GOOD}, ("check", "p.toml", "--golden", "g.toml",
                                                    "--quiet", *extra), ("g.toml", *expect))


def export(id, args, expect=(), files=None):
    return V(id, {"p.toml": GOOD, **(files or {})}, ("export", "p.toml", "--quiet", *args),
             expect)


LATIN1 = GOOD.replace("[plant]", "# 28 \u00b0C is the reference\n[plant]").encode("latin-1")


def sweep_text(sweep=None, params=(), extra=""):
    head = {"kind": "analysis", "problem": "p.toml", "n": 2}
    head.update(sweep or {})
    head = {k: v for k, v in head.items() if v is not None}
    text = toml({"sweep": head})
    for p in params:
        text += "[[param]]\n" + "\n".join(f"{k} = {json.dumps(v)}" for k, v in p.items()) + "\n"
    return text + extra


GAIN = {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.05}

VARIANTS = [
    # ------------------------------------------------------------ problem files: encoding
    design("latin1_degree_comment", LATIN1, ("line 1", "UTF-8")),
    design("utf16_bom", GOOD.encode("utf-16"), ("UTF-16",)),
    design("utf16_be_bom", b"\xfe\xff" + GOOD.encode("utf-16-be"), ("UTF-16",)),
    design("utf16_no_bom", GOOD.encode("utf-16-le"), ("TOML",)),
    design("binary_garbage", np.random.default_rng(7).integers(0, 256, 512, dtype=np.uint8)
           .tobytes(), ("UTF-8",)),
    design("nul_bytes", b"\x00" * 64, ("TOML",)),
    design("empty_file", b"", ("empty problem file",)),
    design("whitespace_only", "\n\n   \n", ("empty problem file",)),
    design("comment_only", "# nothing here\n", ("empty problem file",)),
    # ------------------------------------------------------------ problem files: TOML syntax
    design("invalid_toml_bracket", GOOD.replace("[poles]", "[poles"), ("invalid TOML",)),
    design("invalid_toml_value", GOOD.replace("wn = 600.0", "wn = 600.0.0"), ("invalid TOML",)),
    design("invalid_toml_string", GOOD.replace('"analytic"', '"analytic'), ("invalid TOML",)),
    design("duplicate_key", GOOD.replace("zeta = 1.0", "zeta = 1.0\nzeta = 0.7"),
           ("invalid TOML",)),
    design("duplicate_table", GOOD + "[poles]\nwn = 1.0\n", ("invalid TOML",)),
    design("python_syntax", "plant = {'name': 'paper'}\n", ("invalid TOML",)),
    design("json_file", json.dumps(BASE), ("invalid TOML",)),
    # ------------------------------------------------------------ problem files: keys
    design("unknown_key", problem(poles__wobble=1), ("[poles.wobble]", "unknown key")),
    design("misspelled_key", problem(poles__wn=None, poles__wm=600.0),
           ("[poles.wm]", "did you mean 'wn'")),
    design("unknown_table", problem(plantt={"name": "paper"}), ("[plantt]", "unknown key")),
    design("top_level_value", "n_freq = 10\n" + GOOD, ("[n_freq]", "unknown key")),
    design("table_as_value", "plant = 5\n" + problem(plant=None), ("[plant]", "expected a table")),
    design("missing_plant", problem(plant=None), ("[plant]", "missing")),
    design("missing_poles", problem(poles=None), ("[poles]", "missing")),
    design("missing_wn", problem(poles__wn=None), ("[poles]", "wn")),
    design("plant_name_and_B", problem(plant__B=[1.0]), ("[plant]", "exactly one")),
    design("plant_A_without_B", problem(plant__name=None, plant__A=[1.0, 1.0]),
           ("[plant.B]", "missing")),
    design("plant_B_without_A", problem(plant__name=None, plant__B=[1.0]), ("[plant.A]",)),
    design("unknown_plant_name", problem(plant__name="nonesuch"), ("[plant]", "nonesuch")),
    design("zeros_without_poles", problem(plant__name=None, plant__zeros=[-1.0]),
           ("[plant]", "poles")),
    # ------------------------------------------------------------ problem files: types
    design("wn_string", problem(poles__wn="600"), ("[poles.wn]", "expected a finite number")),
    design("zeta_bool", problem(poles__zeta=True), ("[poles.zeta]", "expected a finite number")),
    design("B_string", problem(plant__name=None, plant__B="1, 2", plant__A=[1.0, 1.0]),
           ("[plant.B]", "expected a list of numbers")),
    design("A_mixed_list", problem(plant__name=None, plant__B=[1.0], plant__A=[1.0, "x"]),
           ("[plant.A]", "expected a list of numbers")),
    design("n_freq_float", problem(solver__n_freq=120.5), ("[solver.n_freq]", "integer")),
    design("stable_controller_string", problem(specs__stable_controller="yes"),
           ("[specs.stable_controller]", "true or false")),
    design("method_unknown", problem(solver__method="magic"), ("[solver.method]", "one of")),
    design("T_mode_unknown", problem(controller__T_mode="cancel"),
           ("[controller.T_mode]", "one of")),
    design("name_number", problem(problem={"name": 5}), ("[problem.name]", "string")),
    design("band_three_numbers", problem(specs__T_resonance_max=1.0,
                                         specs__resonance_band_hz=[1.0, 2.0, 3.0]),
           ("[specs.resonance_band_hz]", "2 numbers")),
    # ------------------------------------------------------------ problem files: values
    design("wn_nan", problem(poles__wn=math.nan), ("[poles.wn]", "finite")),
    design("wn_inf", problem(poles__wn=math.inf), ("[poles.wn]", "finite")),
    design("Ms_max_inf", problem(specs__Ms_max=math.inf), ("[specs.Ms_max]", "finite")),
    design("B_with_nan", problem(plant__name=None, plant__B=[math.nan], plant__A=[1.0, 1.0]),
           ("[plant.B]", "finite")),
    design("wn_1e300", problem(poles__wn=1e300), ("[poles.wn]", "<=")),
    design("aux_factor_1e300", problem(poles__aux_factor=1e300), ("[poles.aux_factor]", "<=")),
    design("B_1e300", problem(plant__name=None, plant__B=[1e300], plant__A=[1.0, 1.0]),
           ("[plant.B]", "<=")),
    design("A_1e300", problem(plant__name=None, plant__B=[1.0], plant__A=[1.0, 1e300]),
           ("[plant.A]", "<=")),
    design("gain_1e300", problem(plant__name=None, plant__zeros=[], plant__poles=[-1.0],
                                 plant__gain=1e300), ("[plant.gain]", "<=")),
    design("temperature_1e300", problem(plant__temperature_C=1e300),
           ("[plant.temperature_C]", "<= 500")),
    design("wn_negative", problem(poles__wn=-600.0), ("[poles.wn]", ">= 1e-06")),
    design("wn_zero", problem(poles__wn=0.0), ("[poles.wn]", ">= 1e-06")),
    design("zeta_zero", problem(poles__zeta=0.0), ("[poles.zeta]", "> 0")),
    design("zeta_negative", problem(poles__zeta=-0.5), ("[poles.zeta]", "> 0")),
    design("Ms_max_below_1", problem(specs__Ms_max=0.5), ("[specs.Ms_max]", ">= 1")),
    design("Mu_max_zero", problem(specs__Mu_max=0.0), ("[specs.Mu_max]", "> 0")),
    design("sample_rate_negative", problem(specs__sample_rate_hz=-1000.0),
           ("[specs.sample_rate_hz]", ">= 1.6e-07")),
    design("extra_degree_negative", problem(controller__extra_degree=-1),
           ("[controller.extra_degree]", ">= 0")),
    design("extra_degree_huge", problem(controller__extra_degree=100),
           ("[controller.extra_degree]", "<= 20")),
    design("overshoot_negative", problem(specs__overshoot_max_pct=-1.0),
           ("[specs.overshoot_max_pct]", ">= 0")),
    design("A_zero_leading", problem(plant__name=None, plant__B=[1.0], plant__A=[0.0, 1.0]),
           ("[plant]",)),
    design("A_empty", problem(plant__name=None, plant__B=[1.0], plant__A=[]), ("[plant]",)),
    design("B_zero", problem(plant__name=None, plant__B=[0.0], plant__A=[1.0, 1.0]),
           ("[plant]",)),
    design("improper_plant", problem(plant__name=None, plant__B=[1.0, 1.0, 1.0],
                                     plant__A=[1.0, 1.0]), ("[plant]",)),
    design("list_too_long", problem(plant__name=None, plant__B=[1.0] * 20001,
                                    plant__A=[1.0, 1.0]), ("[plant.B]", "at most")),
    # ------------------------------------------------------------ problem files: sizes
    design("n_freq_1e9", problem(solver__n_freq=1_000_000_000), ("[solver.n_freq]", "<=")),
    design("cert_temperatures_1e9", problem(solver__cert_temperatures=1_000_000_000),
           ("[solver.cert_temperatures]", "<=")),
    design("max_iter_1e12", problem(solver__max_iter=1_000_000_000_000),
           ("[solver.max_iter]", "<=")),
    design("max_rounds_huge", problem(solver__max_rounds=10**6), ("[solver.max_rounds]", "<=")),
    design("n_freq_1", problem(solver__n_freq=1), ("[solver.n_freq]", ">= 2")),
    design("ipopt_tol_negative", problem(solver__ipopt_tol=-1e-9), ("[solver.ipopt_tol]", "> 0")),
    design("ipopt_tol_zero", problem(solver__ipopt_tol=0.0), ("[solver.ipopt_tol]", "> 0")),
    design("cert_tol_huge", problem(solver__cert_tol=5.0), ("[solver.cert_tol]", "<=")),
    design("delay_samples_huge", problem(specs__sample_rate_hz=10000.0,
                                         specs__delay_samples=10**6),
           ("[specs.delay_samples]", "<=")),
    # ------------------------------------------------------------ problem files: consistency
    design("empty_family_temperatures", problem(family={"temperatures_C": []}),
           ("[family.temperatures_C]", "at least one")),
    design("empty_family_models", problem(family={"models": []}),
           ("[family.models]", "at least one")),
    design("empty_family_table", GOOD + "[family]\n", ("[family.temperatures_C]", "missing")),
    design("family_temperature_out_of_range", problem(family={"temperatures_C": [20.0, 1e300]}),
           ("[family.temperatures_C]", "<= 500")),
    design("family_model_without_A", GOOD + "[[family.models]]\ntemperature_C = 20.0\n"
           "B = [1.0]\n", ("[family.models.0.A]", "missing")),
    design("family_models_and_temperatures", GOOD + "[family]\ntemperatures_C = [20.0]\n"
           "[[family.models]]\ntemperature_C = 20.0\nB = [1.0]\nA = [1.0, 1.0]\n",
           ("[family]", "either")),
    design("dominant_roots_non_conjugate", problem(poles__wn=None, poles__zeta=None,
                                                   poles__dominant_roots_re=[-1.0, -2.0],
                                                   poles__dominant_roots_im=[1.0, 0.0]),
           ("[poles", "conjugate")),
    design("dominant_roots_lonely_complex", problem(poles__wn=None, poles__zeta=None,
                                                    poles__dominant_roots_re=[-300.0],
                                                    poles__dominant_roots_im=[100.0]),
           ("[poles", "conjugate")),
    design("dominant_roots_length_mismatch", problem(poles__wn=None, poles__zeta=None,
                                                     poles__dominant_roots_re=[-1.0, -1.0],
                                                     poles__dominant_roots_im=[1.0]),
           ("[poles.dominant_roots_im]", "length")),
    design("dominant_roots_unstable", problem(poles__wn=None, poles__zeta=None,
                                              poles__dominant_roots_re=[1.0, 1.0],
                                              poles__dominant_roots_im=[1.0, -1.0]),
           ("[poles]", "left half-plane")),
    design("S_fixed_no_integrator", problem(controller__S_fixed=[1.0, 1.0]),
           ("[controller.S_fixed]", "integrator")),
    design("S_fixed_empty", problem(controller__S_fixed=[]), ("[controller.S_fixed]",)),
    design("band_reversed", problem(specs__T_resonance_max=1.0,
                                    specs__resonance_band_hz=[680.0, 560.0]),
           ("[specs.resonance_band_hz]", "lo < hi")),
    design("band_without_bound", problem(specs__resonance_band_hz=[560.0, 680.0]),
           ("[specs]", "go together")),
    design("delay_without_rate", problem(specs__delay_samples=1), ("[specs.delay_samples]",)),
    design("free_poles_without_bounds", problem(solver__free_poles=True),
           ("[solver.free_poles]", "wn_bounds")),
    design("roll_off_without_corner", problem(controller__roll_off_order=1),
           ("[controller.roll_off_hz]",)),
    design("reference_model_without_wn", problem(controller__T_mode="reference_model"),
           ("[controller.reference_wn]",)),
    design("compare_with_missing", problem(solver__compare_with="nowhere.toml"),
           ("[solver.compare_with]", "nowhere.toml")),
    # ------------------------------------------------------------ problem paths
    V("problem_not_found", {}, ("design", "missing.toml", "--quiet"),
      ("missing.toml", "not found")),
    V("problem_is_folder", {"pdir": DIR}, ("design", "pdir", "--quiet"), ("pdir", "folder")),
    V("report_problem_is_folder", {"pdir": DIR}, ("report", "pdir", "--quiet", "--out", "r"),
      ("pdir", "folder")),
    # ------------------------------------------------------------ output targets
    V("report_out_dot", {"p.toml": GOOD, "notes.txt": "mine"},
      ("report", "p.toml", "--quiet", "--out", "."), ("--out",)),
    V("report_out_under_file", {"p.toml": GOOD, "afile": "mine"},
      ("report", "p.toml", "--quiet", "--out", "afile/rep"), ("afile",)),
    V("report_out_is_file", {"p.toml": GOOD, "afile": "mine"},
      ("report", "p.toml", "--quiet", "--out", "afile"), ("afile",)),
    V("report_out_user_folder", {"p.toml": GOOD, "proj/keep.txt": "mine"},
      ("report", "p.toml", "--quiet", "--out", "proj"), ("proj", "--force")),
    V("report_out_parent", {"sub/p.toml": GOOD},
      ("report", "sub/p.toml", "--quiet", "--out", ".."), ("--out",)),
    V("diagnose_json_folder", {"a.csv": GOOD_CSV, "jdir": DIR},
      ("diagnose", "--train", "a.csv", "--test", "a.csv", "--quiet", "--json", "jdir"),
      ("jdir", "folder")),
    V("diagnose_json_under_file", {"a.csv": GOOD_CSV, "afile": "mine"},
      ("diagnose", "--train", "a.csv", "--test", "a.csv", "--quiet", "--json", "afile/o.json"),
      ("afile",)),
    V("diagnose_report_under_file", {"a.csv": GOOD_CSV, "afile": "mine"},
      ("diagnose", "--train", "a.csv", "--test", "a.csv", "--quiet", "--report", "afile/r"),
      ("afile",)),
    V("diagnose_model_bad", {"a.csv": GOOD_CSV, "p.toml": problem(poles__wn=-1.0)},
      ("diagnose", "--train", "a.csv", "--test", "a.csv", "--quiet", "--model", "p.toml"),
      ("p.toml", "[poles.wn]")),
    V("simulate_out_under_file", {"afile": "mine"},
      ("simulate", "fig2", "--fast", "--quiet", "--out", "afile/sim"), ("afile",)),
    V("simulate_unknown_scenario", {}, ("simulate", "fig99", "--quiet", "--out", "sim"),
      ("fig99", "fig2")),
    V("check_update_under_file", {"p.toml": GOOD, "afile": "mine"},
      ("check", "p.toml", "--golden", "afile/g.toml", "--update", "--quiet"), ("afile",)),
    V("check_update_folder", {"p.toml": GOOD, "gdir": DIR},
      ("check", "p.toml", "--golden", "gdir", "--update", "--quiet"), ("gdir", "folder")),
    export("export_out_folder", ("--out", "edir"), ("edir", "folder"), {"edir": DIR}),
    export("export_out_under_file", ("--out", "afile/c.json"), ("afile",), {"afile": "mine"}),
    export("export_out_user_file", ("--out", "mine.json"), ("mine.json", "refusing"),
           {"mine.json": '{"mine": 1}'}),
    export("export_c_user_header", ("--format", "c", "--out", "ctrl"), ("ctrl.h", "refusing"),
           {"ctrl.h": "/* mine */\n"}),
    export("export_bad_prefix", ("--prefix", "1bad name"), ("prefix",)),
    export("export_u_range_reversed", ("--u-range", "150", "0"), ("u-range",)),
    export("export_u_range_nan", ("--u-range", "nan", "150"), ("u-range",)),
    export("export_fs_negative", ("--fs", "-1000"), ("--fs",)),
    export("export_fs_zero", ("--fs", "0"), ("--fs",)),
    export("export_fs_nan", ("--fs", "nan"), ("--fs",)),
    export("export_fs_inf", ("--fs", "inf"), ("--fs",)),
    export("export_delay_negative", ("--delay-samples", "-1"), ("delay",)),
    export("export_fs_not_a_number", ("--fs", "fast"), ("--fs",)),
    export("export_format_unknown", ("--format", "rust"), ("--format",)),
    V("export_problem_not_found", {}, ("export", "nope.toml", "--quiet"), ("nope.toml",)),
    # ------------------------------------------------------------ twin files
    V("twin_is_folder", {"tdir": DIR}, ("simulate", "fig2", "--twin", "tdir", "--quiet",
                                        "--out", "sim"), ("tdir", "folder")),
    V("twin_not_found", {}, ("simulate", "fig2", "--twin", "nope.toml", "--quiet",
                             "--out", "sim"), ("nope.toml", "not found")),
    twin("twin_latin1", "# 28 \u00b0C\n[twin]\nname = 'x'\n".encode("latin-1"), ("UTF-8",)),
    twin("twin_utf16", "[twin]\nname = 'x'\n".encode("utf-16"), ("UTF-16",)),
    twin("twin_unknown_key", "[twin]\nnmae = 'x'\n", ("[twin.nmae]", "did you mean 'name'")),
    twin("twin_unknown_effect", "[hysterisis]\nenabled = false\n", ("[hysterisis]",)),
    twin("twin_rate_negative", "[twin]\nsample_rate_hz = -1.0\n",
         ("[twin.sample_rate_hz]", ">= 1000")),
    twin("twin_rate_huge", "[twin]\nsample_rate_hz = 1e300\n", ("[twin.sample_rate_hz]", "<=")),
    twin("twin_wrong_type", "[creep]\nenabled = 'no'\n", ("[creep.enabled]", "true or false")),
    twin("twin_bad_plant", "[twin]\nplant = 'nonesuch'\n", ("[twin.plant]",)),
    twin("twin_invalid_toml", "[twin\n", ("invalid TOML",)),
    twin("twin_hysteresis_range", "[hysteresis]\nslope_range_V = [150.0, 0.0]\n",
         ("[hysteresis.slope_range_V]",)),
    twin("twin_binary", np.random.default_rng(5).integers(0, 256, 256, dtype=np.uint8).tobytes(),
         ("UTF-8",)),
    twin("twin_nan", "[creep]\nper_decade = nan\n", ("[creep.per_decade]", "finite")),
    twin("twin_duplicate_key", "[twin]\nname = 'a'\nname = 'b'\n", ("invalid TOML",)),
    twin("twin_rate_and_fs", "[twin]\nsample_rate_hz = 1e4\nfs_hz = 1e4\n", ("[twin.fs_hz]",)),
    twin("twin_saturation_reversed", "[saturation]\nu_min = 150.0\nu_max = 0.0\n",
         ("[saturation.u_max]",)),
    twin("twin_delay_too_long", "[delay]\nenabled = true\nseconds = 1.0\n",
         ("[delay.seconds]", "20000 samples", "at most 2000")),
    twin("twin_gain_changes_sign", "[thermal_dynamics]\nenabled = true\ngain_per_K = -1.0\n",
         ("[thermal_dynamics]", "gain factor", "45")),
    twin("twin_creep_negative", "[creep]\nenabled = true\nper_K = -1.0\n",
         ("[creep]", "per_K", "negative")),
    V("scenario_name_too_long", {"s.toml": "[scenario]\nduration_s = 0.01\ntwin = '"
                                 + "a" * 5000 + "'\n"},
      ("simulate", "s.toml", "--quiet", "--out", "sim"), ("s.toml", "5000 characters")),
    # ------------------------------------------------------------ data files
    diag("csv_missing_column", csv(header="t,u,temp", rows=["0,1,2", "0.001,1,2"]),
         ("missing column", "y")),
    diag("csv_non_numeric", csv(rows=csv_rows(lambda i, r: r[:2] + ["abc"] + r[3:]
                                              if i == 5 else None)), ("line", "non-numeric")),
    diag("csv_time_not_monotone", csv(rows=csv_rows(lambda i, r: ["0.0001"] + r[1:]
                                                    if i == 10 else None)), ("line", "time")),
    diag("csv_nan", csv(rows=csv_rows(lambda i, r: r[:2] + ["nan"] + r[3:]
                                      if i == 3 else None)), ("line", "column(s) y")),
    diag("csv_time_in_nanoseconds_read_as_seconds",
         csv(rows=csv_rows(lambda i, r: [f"{i * 1e6:.12g}"] + r[1:])),
         ("column t", "sampling rate", "1e-06 Hz", "plausible")),
    diag("csv_underscore_digits", csv(rows=csv_rows(lambda i, r: r[:1] + ["1_000"] + r[2:]
                                                    if i == 7 else None)),
         ("line 10", "non-numeric")),
    diag("csv_inf", csv(rows=csv_rows(lambda i, r: r[:1] + ["inf"] + r[2:]
                                      if i == 3 else None)), ("line", "column(s) u")),
    diag("csv_short_row", csv(rows=csv_rows(lambda i, r: r[:3] if i == 7 else None)),
         ("line", "fields")),
    diag("csv_long_row", csv(rows=csv_rows(lambda i, r: r + ["1"] if i == 7 else None)),
         ("line", "fields")),
    diag("csv_y_identically_zero", csv(rows=csv_rows(lambda i, r: r[:2] + ["0"] + r[3:])),
         ("column y",)),
    diag("csv_y_identically_zero_test", csv(rows=csv_rows(lambda i, r: r[:2] + ["0"] + r[3:])),
         ("column y",), which="test"),
    diag("csv_empty", "", ("header",)),
    diag("csv_header_only", csv(rows=[]), ("data rows",)),
    diag("csv_wrong_header", csv(header="time,voltage,disp,T"), ("unknown column", "time")),
    diag("csv_extra_column", csv(header="t,u,y,temp,z", rows=["0,1,2,28,0", "0.001,1,2,28,0"]),
         ("unknown column",)),
    diag("csv_duplicate_column", csv(header="t,u,y,temp,u", rows=["0,1,2,28,1"]),
         ("column",)),
    diag("csv_latin1", GOOD_CSV.replace("# record", "# 28 \u00b0C").encode("latin-1"),
         ("UTF-8",)),
    diag("csv_utf16", GOOD_CSV.encode("utf-16"), ("UTF-16",)),
    diag("csv_binary", np.random.default_rng(3).integers(0, 256, 300, dtype=np.uint8).tobytes(),
         ("UTF-8",)),
    diag("csv_kelvin", csv(rows=csv_rows(lambda i, r: r[:3] + ["301.15"])), ("temp", "kelvin")),
    diag("csv_non_uniform", csv(rows=csv_rows(lambda i, r: [f"{i * 1e-3 + (2e-4 if i == 20 else 0):.12g}"]
                                              + r[1:])), ("non-uniform",)),
    diag("csv_semicolons", GOOD_CSV.replace(",", ";"), ("unknown column",)),
    diag("csv_comments_only", "# a\n# b\n", ("header",)),
    diag("csv_repeated_time", csv(rows=csv_rows(lambda i, r: [f"{(i - (i == 30)) / 1000:.12g}"]
                                                + r[1:])), ("line", "time")),
    diag("csv_yr_nan", csv(header="t,u,y,temp,yr", rows=[r + ",nan" for r in csv_rows(
        lambda i, r: None)]), ("column(s) yr",)),
    diag("csv_metres", csv(rows=csv_rows(lambda i, r: r[:2] + [f"{float(r[2]) * 1e-6:.9g}"]
                                         + r[3:])), ("column y", "metres")),
    V("csv_is_folder", {"good.csv": GOOD_CSV, "ddir": DIR},
      ("diagnose", "--train", "ddir", "--test", "good.csv", "--quiet"), ("ddir", "folder")),
    V("csv_not_found", {"good.csv": GOOD_CSV},
      ("diagnose", "--train", "good.csv", "--test", "nope.csv", "--quiet"),
      ("nope.csv", "not found")),
    # ------------------------------------------------------------ sweep files
    V("sweep_not_found", {}, ("sweep", "nope.toml", "--workers", "0", "--quiet", "--out", "sw"),
      ("nope.toml", "not found")),
    sweepf("sweep_missing_kind", sweep_text({"kind": None}, [GAIN]), ("[sweep.kind]", "missing")),
    sweepf("sweep_unknown_kind", sweep_text({"kind": "monte"}, [GAIN]), ("[sweep.kind]",
                                                                         "one of")),
    sweepf("sweep_problem_missing", sweep_text({"problem": "gone.toml"}, [GAIN]),
           ("gone.toml",)),
    sweepf("sweep_bad_dist", sweep_text(params=[{**GAIN, "dist": "poisson"}]),
           ("[param.0.dist]", "one of")),
    sweepf("sweep_normal_without_std", sweep_text(params=[{"name": "gain", "dist": "normal",
                                                           "mean": 1.0}]), ("[param.0", "std")),
    sweepf("sweep_unknown_param", sweep_text(params=[{**GAIN, "name": "specs.Mu_maxx"}]),
           ("[param.0.name]", "Mu_maxx")),
    sweepf("sweep_n_zero", sweep_text({"n": 0}, [GAIN]), ("[sweep.n]", ">= 1")),
    sweepf("sweep_latin1", ("# \u00b0C\n" + sweep_text(params=[GAIN])).encode("latin-1"),
           ("UTF-8",)),
    sweepf("sweep_unknown_key", sweep_text(params=[GAIN], extra="[sweep2]\nx = 1\n"),
           ("[sweep2]", "unknown key")),
    V("sweep_min_yield", {"s.toml": sweep_text(params=[GAIN]), "p.toml": GOOD},
      ("sweep", "s.toml", "--quiet", "--out", "sw", "--min-yield", "2"), ("--min-yield",)),
    V("sweep_workers_negative", {"s.toml": sweep_text(params=[GAIN]), "p.toml": GOOD},
      ("sweep", "s.toml", "--quiet", "--out", "sw", "--workers", "-1"), ("workers",)),
    sweepf("sweep_utf16", sweep_text(params=[GAIN]).encode("utf-16"), ("UTF-16",)),
    sweepf("sweep_invalid_toml", "[sweep\n", ("invalid TOML",)),
    sweepf("sweep_n_huge", sweep_text({"n": 10**12}, [GAIN]), ("[sweep.n]", "<=")),
    sweepf("sweep_std_negative", sweep_text(params=[{**GAIN, "std": -0.1}]),
           ("[param.0.std]", "> 0")),
    sweepf("sweep_fleet_folder_missing", sweep_text({"kind": "fleet", "n": None}) + "[fleet]\n"
           "folder = \"nowhere\"\n", ("nowhere",)),
    sweepf("sweep_controller_missing", sweep_text(params=[GAIN]) + "[analysis]\n"
           "controller = \"gone.json\"\n", ("[analysis.controller]", "gone.json", "not found")),
    V("sweep_is_folder", {"sdir": DIR}, ("sweep", "sdir", "--workers", "0", "--quiet",
                                         "--out", "sw"), ("sdir", "folder")),
    V("sweep_out_under_file", {"s.toml": sweep_text(params=[GAIN]), "p.toml": GOOD,
                               "afile": "mine"},
      ("sweep", "s.toml", "--workers", "0", "--quiet", "--out", "afile/sw"), ("afile",)),
    # ------------------------------------------------------------ golden files
    V("golden_not_found", {"p.toml": GOOD}, ("check", "p.toml", "--golden", "nope.toml",
                                             "--quiet"), ("nope.toml", "not found")),
    V("golden_is_folder", {"p.toml": GOOD, "gdir": DIR}, ("check", "p.toml", "--golden",
                                                          "gdir", "--quiet"), ("gdir",)),
    golden("golden_invalid_toml", "[golden\n", ("TOML",)),
    golden("golden_latin1", ("# \u00b0C\n" + GOLDEN_OK).encode("latin-1"), ("UTF-8",)),
    golden("golden_utf16", GOLDEN_OK.encode("utf-16"), ("UTF-16",)),
    golden("golden_wrong_format", GOLDEN_OK.replace("format = 1", "format = 99"), ("format",)),
    golden("golden_unknown_table", GOLDEN_OK + "[extra]\nx = 1\n", ("extra", "unknown")),
    golden("golden_certified_string", GOLDEN_OK.replace("certified = true", "certified = 'yes'"),
           ("design.certified",)),
    golden("golden_figure_string", GOLDEN_OK + '[models.T28C]\nMs = "big"\n', ("Ms",)),
    golden("golden_other_problem", GOLDEN_OK.replace('"paper"', '"other"'), ("other",)),
    golden("golden_format_true", GOLDEN_OK.replace("format = 1", "format = true"), ("format",)),
    golden("golden_objective_name_list",
           GOLDEN_OK + 'objective = { name = ["a"], value = 1.0, rtol = 0.1 }\n',
           ("design.objective",)),
    golden("golden_model_at_another_temperature",
           GOLDEN_OK.replace('"paper"', '"p"')
           + "[models.T28C]\ntemperature_C = 40.0\nMs = { value = 2.0, rtol = 0.1 }\n",
           ("models.T28C.temperature_C", "40", "28")),
]
