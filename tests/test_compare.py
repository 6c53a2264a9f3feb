"""The main job on the test strip: run (reusing test_disk's clay strip), measure, compare; and bad input."""
import json
import subprocess
import sys

import numpy as np
import pytest

from analysis.core.schema import ROOT
from analysis.core.io import read_table
from analysis.holes.caliper import LEVEL_BELOW, LEVELS

COLUMNS = {"preset", "soil", "metric", "field_mean", "field_min", "field_max", "sim_mean", "sim_sd", "ci_lo",
           "ci_hi", "n_holes", "n_runs", "abs_error", "rel_error_pct", "inside_field_range", "theory_table1",
           "theory_envelope", "passed_holes", "field_sd", "within_10pct", "field_in_ci", "band", "claim_5pct",
           "claim_10pct", "flip_pct"}


def compare(*args, dirs, out):
    return subprocess.run([sys.executable, "-m", "analysis.cli", "compare", "--preset", "test", "--runs-dir",
                           str(dirs[0]), "--bed-dir", str(dirs[1]), "--out", str(out), *args],
                          capture_output=True, text=True, timeout=1500, cwd=ROOT)


@pytest.mark.scene
def test_compare_writes_every_column_metric_and_plot(scene_dirs, tmp_path, side_scenes):
    # side_scenes: test_disk's one-thread scenes start now, beside this one-thread clay scene
    r = compare("--soils", "clay", "--threads", "1", dirs=scene_dirs, out=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    table = read_table(tmp_path / "comparison.csv")
    assert COLUMNS <= set(table.columns)
    assert set(table.metric) == {"L0", "L1", "L2", "L2_surface", "h1", "C", "pass_stated", "pass_field",
                                 "pass_stated_surface", "pass_field_surface"}
    hole_rows = table[~table.metric.str.startswith("pass")]
    assert hole_rows[["field_mean", "sim_mean", "abs_error"]].notna().all().all()
    assert (table.field_min <= table.field_mean).all() and (table.field_mean <= table.field_max).all()
    holes = read_table(tmp_path / "comparison" / "test" / "holes.csv")
    assert len(holes) == 2 and (holes.L2 > 0).all() and (holes.L0 > 0).all()
    assert np.allclose(holes.L2_surface, holes.L2 + holes.h1, atol=0.02)     # §4.2's other reading of L2
    for m in table.metric:
        assert (tmp_path / "comparison" / "test" / f"{m}.png").stat().st_size > 5000
    assert "| clay | L0 |" in (tmp_path / "comparison.md").read_text()
    reach = read_table(tmp_path / "comparison" / "test" / "depth_reach.csv")     # L2 + h1 per field run and the run
    assert len(reach) == 5 and set(reach.soil) == {"clay"}
    sim = reach[reach.source == "simulated"].iloc[0]
    assert sim.n == 2 and abs(sim.L2_plus_h1 - (holes.L2 + holes.h1).mean()) < 0.01
    # the pressed ring beside each hole (./holes rings): both sides of both holes, the plate's face from the run
    from analysis.holes import rings
    run_dir = scene_dirs[0] / holes.run.iloc[0]
    profile, levels = rings.run([run_dir], tmp_path / "rings")
    assert set(profile.groupby(["hole", "side"]).groups) == {(1, "-y"), (1, "+y"), (2, "-y"), (2, "+y")}
    summary = json.loads((run_dir / "summary.json").read_text())
    # in the metrology's datum: the scene's level (highest grain top per 4-radius cell) stands above the median
    # probed surface the holes are measured from, by a fraction of a grain
    from analysis.holes.measure import measure_run
    offset = 1000 * summary["z_surface_m"] - measure_run(run_dir)[2]
    assert 0 < offset < 2 * holes.grain_radius.iloc[0]
    assert list(profile.groupby("hole").plate_depth.first()) == pytest.approx(
        [70.0 - 40.0 - t - offset for t in summary["sleeve_max_travel_mm"][summary["lead_in"]:]], abs=0.01)
    assert profile.depth.notna().mean() > 0.8 and (tmp_path / "rings" / "rings.png").stat().st_size > 5000
    # the openings at 0, 5, 10, 20 mm below the subsided level: at the rule's 5 mm, the table's; the split adds up
    rule = levels[levels.below == LEVEL_BELOW].set_index("hole")
    assert np.allclose(rule[["L0", "L1"]], holes.set_index("hole")[["L0", "L1"]], atol=0.01)
    assert np.allclose(levels.ahead + levels.behind, levels.L0, atol=0.01, equal_nan=True)
    assert set(levels.below) == set(LEVELS) and (tmp_path / "rings" / "levels-clay.png").stat().st_size > 5000
    assert (tmp_path / "comparison" / "test" / "levels" / "levels_summary.csv").exists()
    assert set(table.claim_10pct.dropna()) <= {"yes", "no", "open", "not resolvable", "–"}
    # the run kept beside the table stands in for a run folder this machine does not have
    kept = tmp_path / "comparison" / "runs"
    kept_run = next(kept.iterdir())
    assert {p.name for p in kept_run.iterdir()} == {"holes.csv", "summary.json", "config.json", "state.npz"}

    def lengthen_first_L0():                  # a kept holes.csv that disagrees with the kept grains by 10 mm
        held = read_table(kept_run / "holes.csv")
        held.loc[0, "L0"] += 10.0
        held.to_csv(kept_run / "holes.csv", index=False)

    lengthen_first_L0()                       # with the grains kept, the run is measured again: the table holds
    again = compare("--soils", "clay", "--no-run", "--kept", dirs=(tmp_path / "elsewhere", scene_dirs[1]), out=tmp_path)
    assert again.returncode == 0 and "measured again from its kept grains" in again.stderr, again.stderr[-3000:]
    assert read_table(tmp_path / "comparison.csv").equals(table)
    assert "Not on this machine" in (tmp_path / "comparison.md").read_text()
    (kept_run / "state.npz").unlink()         # kept before the states were: its holes read as they were measured
    lengthen_first_L0()
    earlier = compare("--soils", "clay", "--no-run", "--kept", dirs=(tmp_path / "elsewhere", scene_dirs[1]), out=tmp_path)
    assert earlier.returncode == 0 and "its holes as measured earlier" in earlier.stderr, earlier.stderr[-3000:]
    held = read_table(tmp_path / "comparison.csv").set_index("metric")
    assert held.loc["L0", "sim_mean"] == pytest.approx(table.set_index("metric").loc["L0", "sim_mean"] + 5.0, abs=0.01)
    partial = compare("--soils", "clay,sand", "--no-run", "--kept", dirs=(tmp_path / "elsewhere", scene_dirs[1]),
                      out=tmp_path)                           # sand was never run: the table says it is missing
    assert partial.returncode == 0, partial.stderr[-3000:]
    assert "not in this table" in (tmp_path / "comparison.md").read_text().split("| soil |")[0]
    assert "sand seed 1" in (tmp_path / "comparison.md").read_text().split("| soil |")[0]
    held = read_table(kept_run / "holes.csv")                 # a truncated kept table is refused, not pooled
    held.iloc[:1].to_csv(kept_run / "holes.csv", index=False)
    cut = compare("--soils", "clay", "--no-run", "--kept", dirs=(tmp_path / "elsewhere", scene_dirs[1]), out=tmp_path)
    assert cut.returncode == 2 and "holes.csv" in cut.stderr and "Traceback" not in cut.stderr, cut.stderr[-2000:]
    without = compare("--soils", "clay", "--no-run", dirs=(tmp_path / "elsewhere", scene_dirs[1]), out=tmp_path)
    assert without.returncode == 1 and "no run finished" in without.stderr     # kept runs only on asking


@pytest.mark.parametrize("args, field", [(["--preset", "huge"], "preset"), (["--soils", "peat"], "peat"),
                                         (["--seeds", "1,1"], "--seeds"), (["--soils", "clay,clay"], "--soils")])
def test_compare_refuses_bad_input_before_any_scene(tmp_path, args, field):
    r = subprocess.run([sys.executable, "-m", "analysis.cli", "compare", "--runs-dir", str(tmp_path / "runs"),
                        "--bed-dir", str(tmp_path / "beds"), "--out", str(tmp_path), *args],
                       capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 2 and field in r.stderr
    assert not (tmp_path / "beds").exists() and not (tmp_path / "runs").exists()


def test_a_table_remade_for_one_soil_keeps_the_others_runs(tmp_path):
    # compare --soils clay must not drop loam's and sand's rows: their finished (here) or kept (beside the table)
    # runs of the same settings are pooled, never run; a soil with neither is left out
    from analysis.batch.compare_job import not_asked
    from analysis.core.runner import plan_case
    runs, kept = tmp_path / "runs", tmp_path / "comparison" / "runs"
    ids = {s: plan_case({"soil": s, "preset": "test", "seed": 1})["id"] for s in ("clay", "loam", "sand")}
    (runs / ids["loam"]).mkdir(parents=True)
    (runs / ids["loam"] / "summary.json").write_text("{}")
    (kept / ids["sand"]).mkdir(parents=True)
    (kept / ids["sand"] / "holes.csv").write_text("run\n")
    found = not_asked(["clay"], "test", [1], runs, kept)
    assert [(f["soil"], c["id"]) for c, f in found] == [("loam", ids["loam"]), ("sand", ids["sand"])]
    assert not_asked(["clay"], "test", [2], runs, kept) == []           # another packing: another run
    assert [f["soil"] for _, f in not_asked(["clay", "loam"], "test", [1], runs, kept)] == ["sand"]
