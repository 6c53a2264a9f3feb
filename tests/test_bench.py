"""Speed against error (analysis/batch/bench.py) on a made-up study table: the reference, the errors, the front."""
import pandas as pd
import pytest

from analysis.batch.bench import economies, errors, pareto, settings
from analysis.holes.compare import field_table


def table():
    rows = [("a", "coarse", None, None, 10.0, 100.0, 120.0, 60.0, 30.0, 10.0),
            ("b", "quick", None, None, 40.0, 110.0, 115.0, 58.0, 33.0, 12.0),
            ("c", "default", None, None, 90.0, 100.0, 110.0, 55.0, 35.0, 12.0),
            ("d", None, 0.8, None, 25.0, 100.0, 116.0, 57.0, 33.0, 12.0),
            ("e", None, None, 1.0e7, 60.0, 100.0, 130.0, 65.0, 25.0, 15.0)]
    t = pd.DataFrame(rows, columns=["run", "resolution", "dt_safety", "soil.young", "wall_s", "particles", "L0",
                                    "L1", "L2", "h1"])
    t["soil"], t["preset"], t["steps"] = "clay", "quick", 1000
    return t


def test_errors_are_against_the_finest_base_case_and_the_field_mean():
    t = errors(table(), field_table())
    assert set(t.reference) == {"c"}                   # 4 mm grains at the preset's step and modulus
    assert t.loc[t.run == "c", "err_finest_pct"].item() == 0.0
    b = t[t.run == "b"].iloc[0]
    assert b.L0_vs_finest == pytest.approx(5.0) and b.L2_vs_finest == pytest.approx(-2.0)
    field = field_table()
    clay = field[(field.soil == "clay") & (field.run.astype(str) == "mean")].iloc[0]
    assert b.err_finest_pct == pytest.approx(100 * (5 / clay.L0 + 3 / clay.L1 + 2 / clay.L2 + 0 / clay.h1) / 4)
    assert b.L1_vs_field == pytest.approx(58.0 - clay.L1)
    assert t.loc[t.run == "d", "dt_safety"].item() == 0.8 and t.loc[t.run == "a", "dt_safety"].item() == 0.5
    assert t.loc[t.run == "e", "young_pa"].item() == 1.0e7 and t.loc[t.run == "a", "radius_mm"].item() == 8.0


def test_pareto_front_keeps_only_unbeaten_cases():
    t = pd.DataFrame({"wall_s": [10, 20, 30, 40], "err": [9.0, 3.0, 5.0, 1.0]})
    assert list(pareto(t, "err")) == [True, True, False, True]


def test_economies_are_changes_against_the_seed_1_reference_with_the_seed_scatter():
    t = pd.DataFrame({"run": list("abcdef"), "seed": [1, 1, 1, 1, 2, 3],
                      "width": [None, 240, None, None, None, None], "lead_in": [None, None, 0, None, None, None],
                      "mode": [None, None, None, "free", None, None],
                      "particles": [100, 150, 100, 100, 100, 100], "steps": [1000, 1000, 600, 1000, 1000, 1000],
                      "wall_s": [10.0, 30.0, 9.0, 11.0, 10.0, 10.0], "cpu_s": [None, 15.0, 6.0, 11.0, 10.0, 10.0],
                      "L0": [100.0, 104, 90, 100, 102, 98], "L1": [60.0] * 6, "L2": [30.0] * 6, "h1": [10.0] * 6})
    e = economies(t).set_index("change")
    assert list(e.index) == ["reference", "width = 240.0", "lead_in = 0.0", "mode = free",
                             "seed-to-seed SD (3 packings)"]
    assert e.loc["width = 240.0", "particle_steps_ratio"] == pytest.approx(1.5)
    assert e.loc["width = 240.0", "cost_ratio"] == pytest.approx(1.5)    # CPU time: the timed packings' mean
    assert e.loc["lead_in = 0.0", "dL0"] == pytest.approx(-10.0)
    assert e.loc["seed-to-seed SD (3 packings)", "dL0"] == pytest.approx(2.0)
    assert e.loc["seed-to-seed SD (3 packings)", "dL1"] == 0.0
    assert e.slip_holes.isna().all()                      # a table made before studies recorded it
    slips = economies(t.assign(slip_holes=[0.0, 0.0, 0.0, -0.056, 0.0, 0.0])).set_index("change").slip_holes
    assert slips["mode = free"] == pytest.approx(-0.056) and slips["reference"] == 0.0


def test_packings_of_a_setting_are_pooled_and_its_error_set_against_their_scatter():
    t = table()
    extra = t[t.run.isin(["b", "c"])].assign(run=["b2", "c2"], L0=[100.0, 120.0])  # a second packing of b and c
    e = errors(pd.concat([t, extra], ignore_index=True), field_table())
    assert set(e.reference.iloc[0].split()) == {"c", "c2"}
    assert e.loc[e.run == "c", "L0_vs_finest"].item() == pytest.approx(-5.0)    # against the packings' mean 115
    s = settings(e).set_index("runs")
    assert len(s) == 5 and s.loc["c c2", "packings"] == 2 and s.loc["c c2", "dL0"] == 0.0
    assert s.loc["c c2", "err_finest_pct"] == 0.0
    assert s.loc["b b2", "L0"] == pytest.approx(107.5) and s.loc["b b2", "dL0"] == pytest.approx(-7.5)
    sd_b, sd_c = pd.Series([115.0, 100.0]).std(), pd.Series([110.0, 120.0]).std()
    assert s.loc["b b2", "dL0_se"] == pytest.approx((sd_b ** 2 / 2 + sd_c ** 2 / 2) ** 0.5)
    assert pd.isna(s.loc["a", "dL0_se"])                                        # one packing: no scatter


def test_bench_presets_refuses_a_reference_it_has_no_holes_of(capsys):
    from analysis import cli
    code = cli.main(["bench", "presets", "--against", "nonesuch"])
    err = capsys.readouterr().err
    assert code == 2 and "--against = 'nonesuch'" in err and "allowed" in err and "Traceback" not in err, err


def test_bench_speed_vs_error_names_the_tables_it_needs(tmp_path, capsys):
    """Without presets.csv and convergence.csv it says which commands make them, writes nothing, exits 1."""
    from analysis import cli
    code = cli.main(["bench", "speed-vs-error", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 1 and "./holes bench presets" in err and "./holes bench convergence" in err, err
    assert list(tmp_path.iterdir()) == []
