"""The calibration search and the config write-back, on known functions (no YADE)."""
import shutil

import pytest

from analysis.soil import calibrate
from analysis.core.schema import ROOT
from analysis.core.soil_config import load_soil

quiet = dict(log=lambda *a: None)


@pytest.mark.parametrize("f,target", [(lambda x: 2 * x + 1, 11.0), (lambda x: 300 + x ** 1.5 / 100, 450.0),
                                      (lambda x: 1e5 * (1 - 2.718 ** (-x / 3e4)) + 2e5, 2.6e5)])
def test_search_lands_within_tolerance(f, target):
    x, y, history = calibrate.bracket_search(f, target, 0.0, 1e5, **quiet)
    assert abs(y / target - 1) <= calibrate.TOLERANCE
    assert y == f(x) and len(history) <= 10


def test_unreachable_target_is_an_error_naming_the_value():
    with pytest.raises(ValueError, match="already 500 at the lower bound 0, above the target 450"):
        calibrate.bracket_search(lambda x: 500 + x, 450.0, 0.0, 10.0, **quiet)
    with pytest.raises(ValueError, match="only 20 at the upper bound 10, below the target 450"):
        calibrate.bracket_search(lambda x: 10 + x, 450.0, 0.0, 10.0, **quiet)


def test_write_back_keeps_comments_and_validates(tmp_path, monkeypatch):
    soils = tmp_path / "configs/soils"
    soils.mkdir(parents=True)
    (tmp_path / "configs/field").mkdir()
    shutil.copy(ROOT / "configs/soils/sand.toml", soils / "sand.toml")
    shutil.copy(ROOT / "configs/field/table2_soils.csv", tmp_path / "configs/field/table2_soils.csv")
    monkeypatch.setattr(calibrate, "ROOT", tmp_path)
    import analysis.core.schema as schema
    monkeypatch.setattr(schema, "ROOT", tmp_path)
    calibrate.write_back("sand", ("normal_cohesion", "shear_cohesion"), 12345.0)
    text = (soils / "sand.toml").read_text()
    assert "normal_cohesion = 1.234e+04  # Pa, tensile bond strength" in text
    s = load_soil(soils / "sand.toml")
    assert s.normal_cohesion == s.shear_cohesion == pytest.approx(12340.0)


def test_cone_checks_config_is_checked_before_anything_runs(tmp_path):
    from analysis.soil import cone_checks
    from analysis.core.schema import ConfigError
    cases = cone_checks.load_cases(ROOT / "configs/cone_checks.toml")
    assert {c["check"] for c in cases} == set(cone_checks.CHECKS)
    assert len({(c["bed"], c["cone_scale"]) for c in cases}) == len(cases)          # no case twice
    assert {c["cohesion"] for c in cases if c["soil"] == "clay"} == {load_soil("clay").normal_cohesion}
    pinned = cone_checks.load_cases(ROOT / "configs/cone_periodic.toml")
    assert {c["cohesion"] for c in pinned} == {30110.0}                             # a study at one cohesion
    base = '[base]\nsoil = "clay"\nresolution = "quick"\nsize = [200, 200, 280]\nseed = 1\ncone_scale = 3.0\nspeed = 0.5\n'
    for case, message in (('check = "depth"', r"check = 'depth': allowed replicate, width, ratio"),
                          ('check = "width"\nsize = [300, 300]', r"size = \[300, 300\]: give \[length, width, depth\]"),
                          ('check = "ratio"\ncone_scale = 40.0', r"cone_scale = 40.0 is out of range: allowed \[0.5, 20\]"),
                          ('check = "ratio"\nsoil = "peat"', "peat"),
                          ('check = "width"\nlateral = "open"', r"bed.lateral = 'open': allowed walls, periodic"),
                          ('check = "tiled"\ntiles = 2', r"case 1.tiles = 2: only a periodic bed"),
                          ('check = "width"\ncohesion = -5.0',
                           r"case 1.cohesion = -5.0 is out of range: allowed \[0, 1e\+07\] Pa")):
        path = tmp_path / "checks.toml"
        path.write_text(base + "[[case]]\n" + case + "\n")
        with pytest.raises(ConfigError, match=message):
            cone_checks.load_cases(path)


def test_cone_checks_summary_states_the_width_change_and_the_scatter():
    import pandas as pd
    from analysis.soil import cone_checks
    common = dict(soil="clay", resolution="quick", lateral="periodic", target_kpa=450.0, dry_density_core=1270,
                  core_error_percent=3.2,
                  cone_diameter_mm=38.49)
    table = pd.DataFrame([dict(check="replicate", seed=1, size_mm="200x200x280", cone_index_kpa=440.0, **common),
                          dict(check="replicate", seed=2, size_mm="200x200x280", cone_index_kpa=480.0, **common),
                          dict(check="width", seed=1, size_mm="450x450x280", cone_index_kpa=485.1, **common),
                          dict(check="width", seed=1, size_mm="300x300x280", cone_index_kpa=462.0, **common)])
    lines = cone_checks.summarise(table)
    assert lines[0].startswith("clay (quick, periodic bed 200x200x280 mm): cone index 460 ± 28 kPa over 2 seed(s) (Table 2 450)")
    assert "300x300x280 mm gives 462 kPa, +5.0 % against 200x200x280 mm" in lines[3]      # each bed against
    assert "450x450x280 mm gives 485 kPa, +5.0 % against 300x300x280 mm" in lines[4]      # the next narrower


def test_tiled_width_check_is_judged_on_the_seeds_paired_changes():
    """Each seed's wider cell against its narrower one (the same packing); the criterion is met only when the
    95 % interval of the mean change lies within ± 5 %, fails when it lies beyond, and is otherwise unresolved."""
    import pandas as pd
    from analysis.soil import cone_checks

    def table(changes):
        rows = []
        for seed, c in enumerate(changes, 1):
            rows += [dict(check="tiled", soil="clay", seed=seed, cone_diameter_mm=38.49, size_mm="450x450x280",
                          cone_index_kpa=400.0 + seed),
                     dict(check="tiled", soil="clay", seed=seed, cone_diameter_mm=38.49, size_mm="675x675x280",
                          cone_index_kpa=(400.0 + seed) * (1 + c / 100))]
        return pd.DataFrame(rows)

    steps = cone_checks.tiled_changes(table([1.0, -1.0, 2.0, 0.0]))
    assert list(steps.change_percent.round(6)) == [1.0, -1.0, 2.0, 0.0] and set(steps.narrow) == {450.0}
    met, = cone_checks.tiled_verdict(table([1.0, -1.0, 2.0, 0.0]))
    assert "4 seeds: +0.5 ± 0.6 %" in met and met.endswith("criterion is met")
    assert cone_checks.tiled_verdict(table([9.0, 11.0, 10.0]))[0].endswith("criterion fails")
    assert cone_checks.tiled_verdict(table([1.0, 12.0, -3.0]))[0].endswith("criterion is not resolved")


def test_cone_checks_no_run_tables_stored_cases_only(tmp_path, monkeypatch):
    """--no-run runs no scene: with nothing stored it says so; a stored cone run whose bed was settled on
    another machine (beds are not committed) is tabled with its densities left out, not a crash."""
    from analysis.soil import cone_checks
    base = '[base]\nsoil = "clay"\nresolution = "quick"\nsize = [200, 200, 280]\ncone_scale = 3.0\nspeed = 0.5\n'
    path = tmp_path / "checks.toml"
    path.write_text(base + '[[case]]\ncheck = "replicate"\nseed = 999999\n')
    with pytest.raises(RuntimeError, match="none stored"):
        cone_checks.run(path, out=tmp_path, no_run=True)
    assert not (tmp_path / "checks.csv").exists() and not (tmp_path / "checks.png").exists()
    case = cone_checks.load_cases(path)[0]
    monkeypatch.setattr(cone_checks, "BED_DIR", tmp_path)                   # no beds there
    summary = {"cone_diameter_m": 0.03849, "cone_to_particle": 3.85, "cohesion_pa": case["cohesion"],
               "cone_index_pa": 445e3, "particles": 10146, "steps": 19000, "wall_s": 500.0, "threads": 1}
    row = cone_checks.row(case, summary)
    assert row["cone_index_kpa"] == 445.0 and row["ci_error_percent"] == -1.1
    assert all(row[k] != row[k] for k in ("dry_density_interior", "dry_density_core", "bed_settle_s"))  # NaN


def test_a_stored_cone_run_is_reused_within_the_bond_tolerance_only():
    """The calibration and the cone checks find stored runs by one lookup: the same bed, cone and speed and a
    bond strength within 0.1 % (the sand calibration's last step, 53,673.5 Pa, is what its config keeps as
    5.367e4), and nothing 1 % off or at another cone."""
    from analysis.soil.calibrate import stored_cone
    bed = "sand-quick-200x200x280-per-s1-adbe045a"
    path, s = stored_cone(bed, 3.0, 0.5, 53670.0)
    assert path.name.endswith("coh53673.5.json") and s["cohesion_pa"] == pytest.approx(53673.5)
    assert stored_cone(bed, 3.0, 0.5, 53673.5 * 1.01) is None
    assert stored_cone(bed, 2.0, 0.5, 53673.5) is None


def test_damage_map_bins_bonds_by_depth_and_ring_with_the_periodic_image():
    import numpy as np
    from scripts.cone import damage_map
    surface, axis, period = 0.28, (0.05, 0.1), (0.2, 0.2)
    pos = np.array([[0.05, 0.10, 0.27], [0.06, 0.10, 0.27],      # beside the axis, 10 mm down: ring 0, band 0
                    [0.10, 0.10, 0.20], [0.11, 0.10, 0.20],      # 55 mm off the axis, 80 mm down: ring 5, band 1
                    [0.18, 0.10, 0.20], [0.19, 0.10, 0.20]])     # 135 mm off; 65 mm from the image at x = 0.25
    first = {(0, 1), (2, 3), (4, 5)}
    t = damage_map(first, {(2, 3)}, pos, axis, surface, period)
    got = {(r.depth_lo_mm, r.r_lo_mm): (r.bonds, r.broken) for r in t.itertuples()}
    assert got == {(0.0, 0.0): (1, 1), (50.0, 50.0): (1, 0), (50.0, 60.0): (1, 1)}
    walled = damage_map(first, set(), pos, axis, surface, None)      # no image: the third bond is 135 mm off
    assert set(walled.r_lo_mm) == {0.0, 50.0, 130.0} and walled.broken.sum() == 3


def test_cone_damage_summary_reads_the_reach_and_refuses_an_empty_folder(tmp_path):
    import json
    import pandas as pd
    from analysis.soil import cone_damage
    from analysis.core.schema import ConfigError
    with pytest.raises(ConfigError, match="no \\*-damage.csv"):
        cone_damage.maps(tmp_path)
    stem = "clay-quick-200x200x280-per-s1-abc-c3-v0.5-coh70000"
    (tmp_path / f"{stem}.json").write_text(json.dumps({"bed": "clay-quick-200x200x280-per-s1-abc", "speed": 0.5,
                                                      "cohesion_pa": 7e4, "cone_index_pa": 4.5e5, "wall_s": 1.0}))
    pd.DataFrame({"depth_lo_mm": [0.0, 0.0, 0.0, 150.0], "depth_hi_mm": [50.0, 50.0, 50.0, 300.0],
                  "r_lo_mm": [0.0, 10.0, 20.0, 0.0], "r_hi_mm": [10.0, 20.0, 30.0, 10.0],
                  "bonds": [10, 10, 10, 10], "broken": [5, 4, 1, 10]}).to_csv(tmp_path / f"{stem}-damage.csv", index=False)
    row = cone_damage.summary(cone_damage.maps(tmp_path)).iloc[0]
    assert row.broken_fraction == 0.5 and row.broken_fraction_0_150mm == pytest.approx(1 / 3)
    assert row.reach_mm == 20.0 and row.half_width_mm == 100.0    # 9 of the 10 broken within 20 mm


def test_the_calibration_report_keeps_its_rows_where_the_beds_are_not(tmp_path, monkeypatch):
    """results/cache/beds is not in git: on a machine without the calibration's beds, each soil's row of the
    committed summary.csv is kept (its cone profiles, which are committed, still plotted) instead of a crash."""
    import shutil
    from analysis.core.io import read_table
    from analysis.soil import calibration_report as report
    monkeypatch.setattr(report, "BED_DIR", tmp_path / "no-beds")
    shutil.copy(report.CAL / "summary.csv", tmp_path / "summary.csv")
    table = report.run(tmp_path)
    kept = read_table(report.CAL / "summary.csv")
    assert list(table.soil) == list(kept.soil) == ["clay", "loam", "sand"]
    assert table.set_index("soil").normal_cohesion_kpa.to_dict() == kept.set_index("soil").normal_cohesion_kpa.to_dict()
    assert (tmp_path / "resistance_depth.png").stat().st_size > 5000
