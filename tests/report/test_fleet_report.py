"""The fleet report draws the records it is given (and computes nothing)."""

from robrst.report._fleet import write_fleet_report


def _records():
    fleet = {"method": "scenario", "scenarios": 294, "seed": 800,
             "parameters": ["gain", "resonance", "damping"], "decision_variables": 4,
             "yield_target": 0.95, "confidence": 0.99, "support": [0, 4, 7],
             "discarded": [9], "violated": [], "compression_size": 4, "rounds": 4,
             "epsilon": 0.0446, "guaranteed_yield": 0.9554, "target_met": True,
             "bound": "Campi, Garatti & Ramponi (2018), Theorem 1: a-posteriori, compression"
                      " size k = 4, N = 294, beta = 0.01",
             "n_convex_a_priori": 198, "nominal_integral_gain": 26847.0,
             "integral_gain": 33472.0, "integral_gain_ratio": 1.2468, "wall_time_s": 689.0,
             "worst": []}
    design = {"problem": "stage800_fleet", "status": "certified", "integral_gain": 33472.0,
              "controller": {"R": [1.0, 2.0], "S": [1.0, 0.0], "T": [3.0]}, "fleet": fleet}
    ver = {"n": 1000, "seed": 1000803, "certified": 987, "measured_yield": 0.987,
           "yield_ci95": [0.9779, 0.9924], "unstable": 0, "workers": 2, "wall_s": 321.0,
           "worst": [{"index": 17, "params": {"gain": 1.1, "resonance": 0.95, "damping": 0.4},
                      "worst_ratio": 1.04, "violation": "model T15C (15 °C): |S| = 2.08 > 2"}]}
    trade = [{"yield_target": t, "integral_gain": g, "scenarios": n, "compression_size": 3,
              "guaranteed_yield": gy, "measured_yield": m, "yield_ci95": [m - 0.02, m + 0.01],
              "n": 300, "design_wall_s": 100.0}
             for t, g, n, gy, m in ((0.8, 40000.0, 69, 0.83, 0.9), (0.95, 33472.0, 294, 0.9554,
                                                                     0.987))]
    trade.append({"yield_target": None, "integral_gain": 26847.0, "scenarios": 0,
                  "compression_size": 0, "guaranteed_yield": None, "measured_yield": 0.21,
                  "yield_ci95": [0.17, 0.26], "n": 300, "design_wall_s": 10.0})
    return {"problem": "stage800_fleet", "design": design, "design_wall_s": 689.0,
            "nominal_design_wall_s": 10.0, "nominal_integral_gain": 26847.0,
            "verification": ver, "tradeoff": trade}


def test_fleet_report_states_guarantee_measured_yield_and_price(tmp_path):
    write_fleet_report(_records(), tmp_path)
    md = (tmp_path / "report" / "report.md").read_text()
    assert "987 / 1000 = 98.7 %" in md and "97.8 % – 99.2 %" in md
    assert "95.54 %" in md and "Campi, Garatti & Ramponi (2018)" in md
    assert "| nominal (no spread) |" in md and "price_of_yield.png" in md
    # a table cell's "|" escaped: the Markdown table keeps its columns
    assert "model T15C (15 °C): \\|S\\| = 2.08 > 2" in md
    html = (tmp_path / "report" / "report.html").read_text()
    assert "model T15C (15 °C): |S| = 2.08 &gt; 2" in html
    assert (tmp_path / "report" / "price_of_yield.png").stat().st_size > 1000
    assert (tmp_path / "report" / "report.html").is_file()


def test_a_missed_target_shows_the_draws_it_needs(tmp_path):
    records = _records()
    records["design"]["fleet"] = {**records["design"]["fleet"], "target_met": False,
                                  "guaranteed_yield": 0.9231, "compression_size": 9,
                                  "scenarios_for_target": 431}
    write_fleet_report(records, tmp_path)
    md = (tmp_path / "report" / "report.md").read_text()
    assert "drawn actuators the target needs at this k" in md and "431" in md
