"""Bad input of every kind: one clear line, exit 2, nothing created, changed or deleted.

Each variant runs through ``robrst.cli.main`` in this process (a few through a real
``python -m robrst`` subprocess): return code 2, exactly one stderr line starting
``robrst: error:`` that names the file, key, column or flag at fault, no traceback, and
every file under the test's folder byte-for-byte as before (nothing written, nothing
deleted) — including the user's own folders a report or a golden would have gone into.
"""

import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robrst.cli import LAST_RESORT, main

ROOT = Path(__file__).parents[2]
BASE = (ROOT / "problems/paper.toml").read_text()
ROB = (ROOT / "problems/paper_robust_continuous.toml").read_text()
TW = (ROOT / "problems/twin_paper.toml").read_text()
GOOD_CSV = "t,u,y,temp\n" + "".join(f"{k / 20000},{10.0 * np.sin(k / 50)},{6.68 * np.sin(k / 50)},28.0\n"
                                    for k in range(800))


def sub(text, old, new):
    assert old in text, old
    return text.replace(old, new, 1)


# ---- problem files for `robrst design` (the file name is what the error must name)
V = {}
V["latin1_comment"] = BASE.replace("°", "\xb0").encode("latin-1", "replace")
V["utf16"] = BASE.encode("utf-16")
V["binary"] = bytes(range(256)) * 4
V["empty"] = ""
V["bad_toml"] = "[plant\nname = 'paper'"
V["dup_key"] = sub(BASE, 'zeta = 1.0 ', 'zeta = 1.0\nzeta = 0.9 ')
V["unknown_key"] = sub(BASE, "[poles]\n", "[poles]\nwobble = 1\n")
V["unknown_section"] = BASE + "\n[extra]\na = 1\n"
V["wn_string"] = sub(BASE, "wn = 600.0", 'wn = "fast"')
V["wn_nan"] = sub(BASE, "wn = 600.0", "wn = nan")
V["wn_inf"] = sub(BASE, "wn = 600.0", "wn = inf")
V["wn_1e300"] = sub(BASE, "wn = 600.0", "wn = 1e300")
V["wn_neg"] = sub(BASE, "wn = 600.0", "wn = -600.0")
V["wn_zero"] = sub(BASE, "wn = 600.0", "wn = 0.0")
V["zeta_neg"] = sub(BASE, "zeta = 1.0 ", "zeta = -1.0 ")
V["zeta_big"] = sub(BASE, "zeta = 1.0 ", "zeta = 1e300 ")
V["aux_neg"] = sub(BASE, "aux_factor = 10.0", "aux_factor = -1.0")
V["Ms_neg"] = sub(BASE, "Ms_max = 2.0", "Ms_max = -2.0")
V["Ms_below1"] = sub(BASE, "Ms_max = 2.0", "Ms_max = 0.5")
V["Ms_nan"] = sub(BASE, "Ms_max = 2.0", "Ms_max = nan")
V["Mu_1e300"] = sub(BASE, "Mu_max = 150.0", "Mu_max = 1e300")
V["band_reversed"] = sub(BASE, "[560.0, 680.0]", "[680.0, 560.0]")
V["band_one"] = sub(BASE, "[560.0, 680.0]", "[560.0]")
V["band_str"] = sub(BASE, "[560.0, 680.0]", '["a", "b"]')
V["band_neg"] = sub(BASE, "[560.0, 680.0]", "[-5.0, 680.0]")
V["S_fixed_empty"] = sub(BASE, "S_fixed = [1.0, 0.0]", "S_fixed = []")
V["S_fixed_zero"] = sub(BASE, "S_fixed = [1.0, 0.0]", "S_fixed = [0.0, 0.0]")
V["S_fixed_nan"] = sub(BASE, "S_fixed = [1.0, 0.0]", "S_fixed = [nan, 0.0]")
V["R_fixed_str"] = sub(BASE, "R_fixed = [1.0]", 'R_fixed = "1"')
V["extra_neg"] = sub(BASE, "extra_degree = 1 ", "extra_degree = -1 ")
V["extra_float"] = sub(BASE, "extra_degree = 1 ", "extra_degree = 1.5 ")
V["extra_huge"] = sub(BASE, "extra_degree = 1 ", "extra_degree = 100000 ")
V["T_mode_bad"] = sub(BASE, 'T_mode = "paper"', 'T_mode = "magic"')
V["plant_unknown"] = sub(BASE, 'name = "paper"            #', 'name = "nope"            #')
V["no_plant"] = BASE.replace("[plant]", "[plantx]")
V["temp_str"] = sub(BASE, "temperature_C = 28.0", 'temperature_C = "hot"')
V["temp_neg_abs"] = sub(BASE, "temperature_C = 28.0", "temperature_C = -500.0")
V["method_bad"] = sub(BASE, 'method = "analytic"', 'method = "magic"')
V["solver_ipopt_tol_neg"] = sub(ROB, '[solver]\n', '[solver]\nipopt_tol = -1.0\n')
V["solver_max_iter_huge"] = sub(ROB, '[solver]\n', '[solver]\nmax_iter = 1000000000000\n')
V["solver_nfreq_huge"] = sub(ROB, 'n_freq = ', 'n_freq = 1000000000 #')
V["solver_certT_huge"] = sub(ROB, 'cert_temperatures = ', 'cert_temperatures = 1000000000 #')
V["solver_nfreq_zero"] = sub(ROB, 'n_freq = ', 'n_freq = 0 #')
V["solver_rounds_neg"] = sub(ROB, 'max_rounds = ', 'max_rounds = -3 #')
V["cert_tol_neg"] = sub(ROB, 'cert_tol = ', 'cert_tol = -1.0 #')
V["empty_family"] = sub(ROB, "temperatures_C = [28.0, 31.0, 34.0, 37.0, 40.0, 43.0, 45.0]", "temperatures_C = []")
V["family_nan_T"] = sub(ROB, "temperatures_C = [28.0,", "temperatures_C = [nan,")
V["family_dup_T"] = sub(ROB, "temperatures_C = [28.0, 31.0,", "temperatures_C = [28.0, 28.0,")
V["compare_missing"] = sub(ROB, 'compare_with = "paper.toml"', 'compare_with = "nope.toml"')
V["wn_bounds_rev"] = sub(ROB, "wn_bounds = [", "wn_bounds = [3000.0, 300.0] #")
V["fs_neg"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = -20000.0\n")
V["fs_zero"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = 0.0\n")
V["fs_huge"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = 1e300\n")
V["delay_neg"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = 20000.0\ndelay_samples = -1\n")
V["delay_huge"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = 20000.0\ndelay_samples = 100000000\n")
V["dominant_nonconj"] = sub(BASE, "[poles]\nwn = 600.0", "[poles]\ndominant_roots_re = [-600.0, -600.0]\ndominant_roots_im = [100.0, 50.0]\nwn = 600.0")
V["plant_B_A_custom_bad"] = sub(BASE, 'name = "paper"            #', 'B = [1.0]\nA = [0.0, 1.0]\n#')
V["plant_A_empty"] = sub(BASE, 'name = "paper"            #', 'B = [1.0]\nA = []\n#')
V["plant_B_nan"] = sub(BASE, 'name = "paper"            #', 'B = [nan]\nA = [1.0, 1.0]\n#')
V["plant_improper"] = sub(BASE, 'name = "paper"            #', 'B = [1.0, 1.0, 1.0]\nA = [1.0, 1.0]\n#')
V["plant_zero_B"] = sub(BASE, 'name = "paper"            #', 'B = [0.0]\nA = [1.0, 1.0]\n#')
V["plant_huge"] = sub(BASE, 'name = "paper"            #', 'B = [1e300]\nA = [1.0, 1e-300]\n#')
V["roll_off_hz_alone"] = sub(BASE, "[controller]\n", "[controller]\nroll_off_hz = 3000.0\n")
# inputs that passed validation and ended in "computation failed" (or with numpy warnings):
# now refused when the file is read; every pole robrst generates lies within [1e-6, 1e9] rad/s
V["plant_zpk_no_poles"] = sub(BASE, 'name = "paper"            #', 'zeros = []\npoles = []\ngain = 1.0\n#')
V["plant_60_poles"] = sub(BASE, 'name = "paper"            #', 'zeros = []\npoles = ['
                          + ", ".join(f"{-10.0 * k}" for k in range(1, 61)) + ']\ngain = 1.0\n#')
V["dominant_roots_empty"] = sub(BASE, "[poles]\nwn = 600.0", "[poles]\ndominant_roots_re = []\nwn = 600.0")
V["dominant_im_only"] = sub(BASE, "[poles]\nwn = 600.0", "[poles]\ndominant_roots_im = [50.0, -50.0]\nwn = 600.0")
V["wn_1e-90"] = sub(BASE, "wn = 600.0", "wn = 1e-90")
V["wn_1e9_aux_beyond"] = sub(BASE, "wn = 600.0", "wn = 1e9")
V["zeta_1e90"] = sub(BASE, "zeta = 1.0 ", "zeta = 1e90 ")
V["aux_factor_tiny"] = sub(BASE, "aux_factor = 10.0", "aux_factor = 1e-6")
V["aux_roots_unstable"] = sub(BASE, "aux_factor = 10.0", "aux_roots = [1000.0]")
V["ref_zeta_1e90"] = sub(BASE, 'T_mode = "paper"', 'T_mode = "reference_model"\nreference_wn = 1000.0\nreference_zeta = 1e90')
V["ref_wn_1e-90"] = sub(BASE, 'T_mode = "paper"', 'T_mode = "reference_model"\nreference_wn = 1e-90')
V["roll_off_1e-90"] = sub(BASE, "[controller]\n", "[controller]\nroll_off_order = 10\nroll_off_hz = 1e-90\n")
V["S_fixed_root_1e200"] = sub(BASE, "S_fixed = [1.0, 0.0]", "S_fixed = [1e-100, 1e100, 0.0]")
FAM = "\n[family]\ntemperatures_C = [28.0, 45.0]\n[family.parametric]\n"
V["family_gain_1e90"] = BASE + FAM + "gain_per_K = 1e90\n"
V["family_creep_tau_tiny"] = BASE + FAM + "creep_tau_s = 1e-90\ncreep_at_ref = 0.1\n"
V["family_resonance_1e12"] = BASE + FAM + "resonance_per_K = 1e12\n"
V["compare_broken_toml"] = sub(ROB, 'compare_with = "paper.toml"', 'compare_with = "broken.toml"')


V["delay_over_order"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = 20000.0\ndelay_samples = 1000\n")
V["fs_1e-300"] = sub(BASE, "[specs]\n", "[specs]\nsample_rate_hz = 1e-300\n")
EXTRA_FILES = {"compare_broken_toml": {"broken.toml": "[plant\n"}}
DESIGN_CASES = [(name, {f"{name}.toml": data, **EXTRA_FILES.get(name, {})},
                 (lambda n: lambda t: ["design", str(t / f"{n}.toml"), "--json", "--quiet"])(name),
                 f"{name}.toml") for name, data in V.items()]

# ---- twin, data, golden, sweep files, output targets and flags of the other commands
cases = []   # (name, files{name: bytes|str}, argv builder(tmp), expect_named)
def add(name, files, argv, named):
    cases.append((name, files, argv, named))

# twin files
for nm, txt in {
    "twin_latin1": TW.replace("°", "\xb0").encode("latin-1", "replace"),
    "twin_utf16": TW.encode("utf-16"),
    "twin_unknown_key": sub(TW, "[creep]", "[creep]\nwobble = 2"),
    "twin_bad_fs": sub(TW, "fs_hz = 20000.0", "fs_hz = -1.0"),
    "twin_fs_huge": sub(TW, "fs_hz = 20000.0", "fs_hz = 1e12"),
    "twin_nan": sub(TW, "A = 0.45", "A = nan"),
    "twin_bad_plant": sub(TW, 'plant = "paper"', 'plant = "nope"'),
    "twin_empty": "",
    "twin_garbage": bytes(range(256)),
    "twin_enabled_str": sub(TW, "enabled = true", 'enabled = "yes"'),
    "twin_tau_rev": sub(TW, "tau_min_s = 0.1", "tau_min_s = 1e5"),
}.items():
    add(nm, {"tw.toml": txt}, lambda t: ["simulate", "fig2", "--fast", "--twin", str(t / "tw.toml"), "--out", str(t / "out"), "--quiet"], "tw.toml")
add("twin_is_dir", {"d/x": ""}, lambda t: ["simulate", "fig2", "--fast", "--twin", str(t / "d"), "--out", str(t / "out"), "--quiet"], "d")
add("twin_missing", {}, lambda t: ["simulate", "fig2", "--fast", "--twin", str(t / "no.toml"), "--out", str(t / "out"), "--quiet"], "no.toml")
add("simulate_bad_scenario", {}, lambda t: ["simulate", "fig99", "--out", str(t / "out")], "fig99")
add("simulate_out_under_file", {"f": "x"}, lambda t: ["simulate", "fig2", "--fast", "--out", str(t / "f" / "sub"), "--quiet"], "f")
# data files for diagnose
def csv_case(nm, text):
    add(nm, {"train.csv": text, "test.csv": GOOD_CSV}, lambda t: ["diagnose", "--train", str(t / "train.csv"), "--test", str(t / "test.csv"), "--json", str(t / "o.json"), "--quiet"], "train.csv")
lines = GOOD_CSV.splitlines()
csv_case("csv_empty", "")
csv_case("csv_header_only", "t,u,y,temp\n")
# temp is optional (constant-temperature labs); y is not: drop the y column
csv_case("csv_missing_col", "\n".join(",".join(l.split(",")[:2] + l.split(",")[3:]) for l in lines) + "\n")
csv_case("csv_extra_col", "\n".join(l + ",1" for l in lines) + "\n")
csv_case("csv_text_cell", GOOD_CSV.replace("\n0.0005,", "\nabc,", 1))
csv_case("csv_nan", "\n".join(lines[:10] + [lines[10].replace(",28.0", ",nan")] + lines[11:]) + "\n")
csv_case("csv_time_back", "\n".join(lines[:10] + [lines[12], lines[11], lines[10]] + lines[13:]) + "\n")
csv_case("csv_ragged", "\n".join(lines[:10] + [lines[10] + ",5,6"] + lines[11:]) + "\n")
csv_case("csv_y_zero", "t,u,y,temp\n" + "".join(f"{k/20000},{10.0*np.sin(k/50)},0.0,28.0\n" for k in range(800)))
csv_case("csv_latin1", ("# température °C\n" + GOOD_CSV).encode("latin-1"))
csv_case("csv_utf16", GOOD_CSV.encode("utf-16"))
csv_case("csv_binary", bytes(range(256)) * 8)
csv_case("csv_kelvin", GOOD_CSV.replace(",28.0\n", ",301.0\n"))
csv_case("csv_metres", "t,u,y,temp\n" + "".join(f"{k/20000},{10.0*np.sin(k/50)},{6.68e-6*np.sin(k/50)},28.0\n" for k in range(800)))
csv_case("csv_two_rows", "t,u,y,temp\n0,1,1,28\n0.00005,1,1,28\n")
csv_case("csv_dup_time", "\n".join(lines[:10] + [lines[10], lines[10]] + lines[11:]) + "\n")
csv_case("csv_semicolon", GOOD_CSV.replace(",", ";"))
csv_case("csv_inf", "\n".join(lines[:10] + [lines[10].replace(",28.0", ",inf")] + lines[11:]) + "\n")
add("diag_json_is_dir", {"train.csv": GOOD_CSV, "test.csv": GOOD_CSV, "o/x": ""}, lambda t: ["diagnose", "--train", str(t / "train.csv"), "--test", str(t / "test.csv"), "--json", str(t / "o"), "--quiet"], "o")
add("diag_missing_file", {"test.csv": GOOD_CSV}, lambda t: ["diagnose", "--train", str(t / "nope.csv"), "--test", str(t / "test.csv"), "--quiet"], "nope.csv")
add("diag_model_bad", {"train.csv": GOOD_CSV, "test.csv": GOOD_CSV, "m.toml": "[plant\n"}, lambda t: ["diagnose", "--train", str(t / "train.csv"), "--test", str(t / "test.csv"), "--model", str(t / "m.toml"), "--quiet"], "m.toml")
add("diag_report_user_dir", {"train.csv": GOOD_CSV, "test.csv": GOOD_CSV, "mine/notes.txt": "keep"}, lambda t: ["diagnose", "--train", str(t / "train.csv"), "--test", str(t / "test.csv"), "--report", str(t / "mine"), "--quiet"], "mine")
# report / design outputs
add("report_out_dot", {}, lambda t: ["report", "paper", "--out", ".", "--quiet"], ".")
add("report_out_under_file", {"f": "x"}, lambda t: ["report", "paper", "--out", str(t / "f" / "r"), "--quiet"], "f")
add("report_user_dir", {"mine/a.txt": "keep"}, lambda t: ["report", "paper", "--out", str(t / "mine"), "--quiet"], "mine")
add("design_missing", {}, lambda t: ["design", str(t / "none.toml")], "none.toml")
add("design_dir", {"d/x": ""}, lambda t: ["design", str(t / "d")], "d")
# check goldens
add("check_golden_garbage", {"g.toml": "not toml ["}, lambda t: ["check", "paper", "--golden", str(t / "g.toml"), "--quiet"], "g.toml")
add("check_golden_missing", {}, lambda t: ["check", "paper", "--golden", str(t / "g.toml"), "--quiet"], "g.toml")
add("check_golden_dir", {"g/x": ""}, lambda t: ["check", "paper", "--golden", str(t / "g"), "--quiet"], "g")
add("check_golden_latin1", {"g.toml": "# \xb0\n[x]\n".encode("latin-1")}, lambda t: ["check", "paper", "--golden", str(t / "g.toml"), "--quiet"], "g.toml")
add("check_update_user_file", {"g.toml": "my = 1\n"}, lambda t: ["check", "paper", "--golden", str(t / "g.toml"), "--update", "--quiet"], "g.toml")
# export
add("export_fs_neg", {}, lambda t: ["export", "paper", "--fs", "-5", "--quiet"], "--fs")
add("export_fs_zero", {}, lambda t: ["export", "paper", "--fs", "0", "--quiet"], "--fs")
add("export_fs_nan", {}, lambda t: ["export", "paper", "--fs", "nan", "--quiet"], "--fs")
add("export_fs_1e-300", {}, lambda t: ["export", "paper", "--fs", "1e-300", "--quiet"], "--fs")
add("export_delay_over_order", {}, lambda t: ["export", "paper", "--fs", "20000", "--delay-samples", "500", "--quiet"], "--delay-samples")
add("export_delay_neg", {}, lambda t: ["export", "paper", "--fs", "20000", "--delay-samples", "-1", "--quiet"], "--delay-samples")
add("export_urange_rev", {}, lambda t: ["export", "paper", "--fs", "20000", "--u-range", "150", "0", "--quiet"], "--u-range")
add("export_out_dir", {"o/x": ""}, lambda t: ["export", "paper", "--fs", "20000", "--out", str(t / "o"), "--quiet"], "o")
add("export_prefix_bad", {}, lambda t: ["export", "paper", "--fs", "20000", "--format", "c", "--prefix", "1 bad-name", "--out", str(t / "c"), "--quiet"], "prefix")
# sweep files
for nm, txt in {
    "sweep_empty": "",
    "sweep_garbage": b"\xff\xfe\x00junk",
    "sweep_bad_kind": '[sweep]\nkind = "magic"\nproblem = "paper"\n',
    "sweep_no_param": '[sweep]\nkind = "analysis"\nproblem = "paper"\n',
    "sweep_n_huge": '[sweep]\nkind = "analysis"\nproblem = "paper"\nn = 1000000000000\n[[param]]\nname = "gain"\ndist = "normal"\nmean = 1.0\nstd = 0.1\n',
}.items():
    add(nm, {"s.toml": txt}, lambda t: ["sweep", str(t / "s.toml"), "--out", str(t / "so"), "--workers", "0"], "s.toml")


ALL = DESIGN_CASES + cases


def snapshot(root):
    return {p: p.read_bytes() for p in root.rglob("*") if p.is_file()}


def run(tmp_path, files, argv):
    for fn, data in files.items():
        f = tmp_path / fn
        f.parent.mkdir(parents=True, exist_ok=True)
        (f.write_bytes if isinstance(data, bytes) else f.write_text)(data)
    before = snapshot(tmp_path)
    out, err = io.StringIO(), io.StringIO()
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main(argv(tmp_path))
    finally:
        os.chdir(cwd)
    return rc, out.getvalue(), err.getvalue(), before, snapshot(tmp_path)


def test_there_are_at_least_90_variants():
    assert len(ALL) >= 90 and len({c[0] for c in ALL}) == len(ALL)


@pytest.mark.parametrize("name,files,argv,named", ALL, ids=[c[0] for c in ALL])
def test_bad_input_is_one_line_exit_2_and_nothing_touched(tmp_path, name, files, argv, named):
    rc, out, err, before, after = run(tmp_path, files, argv)
    lines = err.strip().splitlines()
    assert rc == 2, (rc, err)
    assert len(lines) == 1 and lines[0].startswith("robrst: error:"), err
    assert named in lines[0], lines[0]
    assert "Traceback" not in err and LAST_RESORT not in lines[0]
    assert out == ""
    assert after == before


def test_double_integrator_gives_valid_json_with_null_integral_gain(tmp_path, capsys):
    """S_fixed = s^2: the integral gain lim s R/S is infinite; the JSON stays valid (null)."""
    f = tmp_path / "s2.toml"
    f.write_text(sub(BASE, "S_fixed = [1.0, 0.0]", "S_fixed = [1.0, 0.0, 0.0]"))
    rc = main(["design", str(f), "--json", "--quiet"])
    d = json.loads(capsys.readouterr().out)
    assert rc in (0, 1) and d["integral_gain"] is None and rc == (0 if d["certified"] else 1)


@pytest.mark.parametrize("argv,named", [
    (["design", "{t}/latin1.toml"], "latin1.toml"),
    (["simulate", "fig99"], "fig99"),
    (["export", "paper", "--fs", "-5"], "--fs"),
])
def test_real_subprocess_one_line_no_traceback(tmp_path, argv, named):
    (tmp_path / "latin1.toml").write_bytes(BASE.replace("°", "\xb0").encode("latin-1", "replace"))
    before = snapshot(tmp_path)
    r = subprocess.run([sys.executable, "-m", "robrst", *[a.format(t=tmp_path) for a in argv]],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("robrst: error:") and named in lines[0]
    assert snapshot(tmp_path) == before
