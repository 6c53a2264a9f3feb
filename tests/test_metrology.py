"""Hole metrology (seed 001 §4.2) on synthetic beds with carved holes of known shape, and the pass logic."""
import functools
import math

import numpy as np
import pandas as pd
import pytest

from analysis.holes import compare
from analysis.core.seedling import load_criteria, threshold, Seedling
from analysis.core.schema import ROOT, ConfigError
from analysis.core.io import read_table
from analysis.holes import carved, metrology_band
from analysis.holes.caliper import JAW, LEVEL_BELOW
from analysis.holes.metrology import DEPTHS, caliper_reading, measure_state, side_profile
from synthetic import carve, four_section_length, four_section_width, lattice_bed

L0, W, STRAIGHT, TAPER, H1 = 92.0, 50.0, 45.0, 25.0, 13.0
DIAMETER_MIN = 2 ** 0.5 * 25.0                        # √2·a2


def carved_bed(r, turn, jitter, centres=(150.0,), length=300.0):
    pos0, rad0 = lattice_bed(length, 160, 100, r, jitter=jitter, turn=turn)
    z_top = np.percentile(pos0[:, 2] + rad0, 99)
    pos, rad = pos0, rad0
    for xc in centres:
        pos, rad = carve(pos, rad, xc, 80, z_top, L0, W, STRAIGHT, TAPER, H1, ring=20)
    return pos, rad, pos0, rad0


@pytest.mark.parametrize("r", [3.0, 4.0])                # lattice beds finer than and at the default resolution
@pytest.mark.parametrize("turn, jitter", [(0, 0.0), (30, 0.3)])
def test_metrology_recovers_a_carved_hole_within_one_grain_radius(r, turn, jitter):
    pos, rad, pos0, rad0 = carved_bed(r, turn, jitter)
    (hole,), z_surface, _ = measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    expected = {"L2": STRAIGHT + TAPER * (1 - DIAMETER_MIN / W), "h1": H1}
    for name, value in expected.items():
        assert getattr(hole, name) == pytest.approx(value, abs=r), name
    band = compare.measurement_bands(r, "band")                   # the caliper's stated band for one hole
    assert hole.L0 == pytest.approx(four_section_length(L0, W), abs=band["L0"])
    assert hole.L1 == pytest.approx(four_section_width(L0, W), abs=band["L1"])
    assert hole.x == pytest.approx(150.0, abs=r)
    # Table 1's l_H in the straight part, below the pressed ring: one chord (not a mean of four sections), so
    # the wall grains that stand up to r into the hole at either end shorten it by up to 2r
    for H, length in zip(DEPTHS, hole.l_depth):
        if H1 + r < H <= H1 + STRAIGHT:
            assert length == pytest.approx(L0, abs=2 * r), H
    assert 0 < hole.l_depth[-1] < L0                        # 60 mm: in the taper, shorter


def test_spacing_between_two_carved_holes():
    pos, rad, pos0, rad0 = carved_bed(3.0, 17, 0.2, centres=(100.0, 300.0), length=400.0)
    holes, _, _ = measure_state(pos, rad, pos0, rad0, 160, [100.0, 300.0], 50.0, 80.0, DIAMETER_MIN)
    assert holes[1].x - holes[0].x == pytest.approx(200.0, abs=3.0)


def test_an_untouched_bed_has_no_opening():
    pos0, rad0 = lattice_bed(300, 160, 100, 4.0, jitter=0.3, turn=10)
    (hole,), _, _ = measure_state(pos0, rad0, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    assert hole.L0 == 0.0 and hole.L1 == 0.0 and abs(hole.h1) < 4.0


def test_a_hole_far_from_where_the_punch_entered_is_not_found():
    pos, rad, pos0, rad0 = carved_bed(4.0, 10, 0.2)
    near, far = measure_state(pos, rad, pos0, rad0, 160, [165.0, 185.0], 50.0, 80.0, DIAMETER_MIN)[0]
    assert near.found and near.x == pytest.approx(150.0, abs=4.0)          # 15 mm off: the same hole
    assert not far.found and far.x == 185.0                                # 35 mm > D/2: not this punch's
    assert all(math.isnan(v) for v in (far.L0, far.L1, far.L2, *far.l_depth))


def test_a_crater_smeared_ahead_of_its_hole_is_found():
    """The hole at x = 150 with a scoop 35 mm deep running on to x = 270: the opening's centroid is
    about 33 mm ahead of the entry (> D/2), but its bottom is under it, so it is this punch's hole, and its
    centre, taken at its effective depth, is the hole's, not the scoop's. The caliper, 5 mm under the subsided
    level, reads the opening there: the hole and the scoop open into it, so L0 runs on into the scoop."""
    pos, rad, pos0, rad0 = carved_bed(4.0, 10, 0.2)
    z_top = np.percentile(pos0[:, 2] + rad0, 99)
    pos, rad = carve(pos, rad, 220.0, 80, z_top, 100.0, W, 30.0, 5.0, 0.0, ring=0.0)
    (hole,), _, _ = measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    assert hole.found                                                 # the centroid-only rule lost it
    assert hole.x == pytest.approx(150.0, abs=4.0)                    # the opening's centroid: ~183
    assert hole.L0 > four_section_length(L0, W) and hole.ahead > hole.behind + 50   # the scoop is ahead
    assert hole.bottom == pytest.approx(H1 + STRAIGHT + TAPER, abs=2 * 4.0)


@pytest.mark.parametrize("r", [4.0, 5.0])                # the default and quick resolutions
def test_h1_reads_the_pressed_ring_not_the_rim_heaved_round_it(r):
    """A round hole (D = 50) in a ring pressed 17 mm down out to the plate's 40 mm radius, and the surface
    beyond it heaved 8 mm, as the disk scenes leave it (results/comparison/README.md). h1 is the ring's depth; the band the
    earlier rule read (D/2 + probe ... 40 mm) lay half on the rim, which overhangs the probed surface by a grain
    radius plus the probe, and read 2.3 mm at r = 4. The side profile shows the ring and the rim."""
    press, heave = 17.0, 8.0
    pos0, rad0 = lattice_bed(300, 160, 100, r, jitter=0.2, turn=10)
    z_top = np.percentile(pos0[:, 2] + rad0, 99)
    pos, rad = carve(pos0, rad0, 150, 80, z_top, 50.0, 50.0, STRAIGHT, TAPER, press, ring=15.0)
    pos[np.hypot(pos[:, 0] - 150, pos[:, 1] - 80) >= 40, 2] += heave
    (hole,), z_surface, (xs, ys, S) = measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    assert hole.h1 == pytest.approx(press, abs=r)
    assert hole.L1 == pytest.approx(four_section_width(50.0, 50.0), abs=compare.measurement_bands(r, "band")["L1"])
    centres, depth = side_profile(S, xs, ys, z_surface, 150.0, 80.0, 50.0, 70.0)
    assert np.allclose(depth[:, centres < 40 - 2 * r], press, atol=r)   # both sides, up to the rim's overhang
    assert np.allclose(depth[:, centres > 40 + r], -heave, atol=r)


RADII = metrology_band.RADII          # every grain radius a preset uses


@functools.lru_cache(maxsize=None)
def carved_rows(r):
    """The carved holes of one soil's bed at grain radius r, one place: every shape, both carvings."""
    return metrology_band.measure_carved(r, realisations=1, soils=1, candidates=[(JAW, LEVEL_BELOW)])


@pytest.mark.parametrize("r", RADII)
def test_the_runs_caliper_recovers_carved_holes_within_its_stated_bias(r):
    """Every shape and carving, at every grain radius a preset uses, carved at a place of the bed the band
    table did not use: the mean error of the chosen caliper's L0 and L1, and of h1, L2, L2_surface, lies within
    the band a mean carries (band_mean, results/comparison/metrology/band.csv). Single holes are not held to the
    one-hole band: the basin's L0 has a heavy tail (up to 1.6 bands at these places), said in the README."""
    rows = carved_rows(r)
    rows = rows[rows.jaw.isna() | ((rows.jaw == JAW.name) & (rows.below == LEVEL_BELOW))]
    band = compare.measurement_bands(r)
    assert set(rows.metric) == {"L0", "L1", "L2", "L2_surface", "h1"}
    for m, g in rows.groupby("metric"):
        assert abs(g.error.mean()) <= band[m], (m, g.error.round(1).tolist(), band[m])


@pytest.mark.parametrize("r", [5.0, 8.0])
def test_the_basin_hole_reads_the_same_opening_when_the_grid_step_halves(r):
    """The caliper reads the grains, not a grid: only the subsided level and the jaws' start come from the
    probed surface's grid. Halving its step (1 -> 0.5 mm) moved the basin hole's L0 and L1 by at most 3.5 mm
    at r = 5 and 8 mm; allowed: a quarter of the one-hole band."""
    bed = metrology_band.beds(r)[0]
    pos0, rad0, width = next(metrology_band.places(bed, 1))
    xc = metrology_band.WINDOW / 2
    _, z_ref, _ = measure_state(pos0, rad0, pos0, rad0, width, [xc], 50.0, 80.0, DIAMETER_MIN)
    pos, rad = carved.carve(pos0, rad0, "basin", "touch", xc, width / 2, z_ref)
    coarse, fine = (measure_state(pos, rad, pos0, rad0, width, [xc], 50.0, 80.0, DIAMETER_MIN, cell=c)[0][0]
                    for c in (1.0, 0.5))
    band = compare.measurement_bands(r, "band")
    for m in ("L0", "L1"):
        assert abs(getattr(coarse, m) - getattr(fine, m)) <= band[m] / 4, m


@pytest.mark.parametrize("r", [5.0, 6.0, 8.0])        # r = 4 mm's 300 mm periodic beds cost the fast tier most
def test_one_probe_radius_of_level_moves_the_opening_by_less_than_its_band(r):
    """Reading one probe radius deeper than the rule (5 mm under the subsided level) moves L0 and L1 of the
    straight-walled carved holes by no more than their one-hole band."""
    pos0, rad0, width = next(metrology_band.places(metrology_band.beds(r)[0], 1))
    xc = metrology_band.WINDOW / 2
    _, z_ref, _ = measure_state(pos0, rad0, pos0, rad0, width, [xc], 50.0, 80.0, DIAMETER_MIN)
    band = compare.measurement_bands(r, "band")
    for shape in ("cylinder", "mouth"):
        for carving in carved.CARVINGS:
            pos, rad = carved.carve(pos0, rad0, shape, carving, xc, width / 2, z_ref)
            (hole,), _, _ = measure_state(pos, rad, pos0, rad0, width, [xc], 50.0, 80.0, DIAMETER_MIN)
            deeper = caliper_reading((pos, rad), hole.x0, hole.y0, hole.z_open, JAW, LEVEL_BELOW + r,
                                     float(rad.mean()), 50.0)
            for m in ("L0", "L1"):
                assert abs(getattr(deeper, m) - getattr(hole, m)) <= band[m], (shape, carving, m)


def test_the_runs_caliper_is_the_one_the_carved_holes_chose():
    """The caliper the runs read with is the candidate choose_jaw picks from the committed carved-hole table."""
    bands = read_table(ROOT / "results/comparison/metrology/candidates.csv")
    assert metrology_band.choose_jaw(bands) == (JAW.name, LEVEL_BELOW)


def test_carved_truth_follows_the_four_line_rule():
    """The void's own readings: the mouth's stadium by the closed form; the basin's ramp lengthens L0 ahead of
    the axis the less deep the level; the cylinder's 4 lines are the circle's chords."""
    mouth = carved.truth("mouth", 5.0)
    assert mouth["L0"] == pytest.approx(four_section_length(90.0, 50.0), abs=0.5)
    assert mouth["L1"] == pytest.approx(four_section_width(90.0, 50.0), abs=0.5)
    shallow, deep = carved.truth("basin", 0.0), carved.truth("basin", 10.0)
    assert shallow["ahead"] > deep["ahead"] > mouth["ahead"] and shallow["behind"] == pytest.approx(deep["behind"])
    assert carved.truth("cylinder", 5.0)["L0"] == pytest.approx(four_section_length(50.0, 50.0), abs=0.5)


def test_a_pass_flips_inside_the_band_only_near_a_threshold():
    crit = {"L0": 49.5, "L1": 49.5, "L2": 40.0}
    holes = pd.DataFrame({"L0": [90.0, 90.0], "L1": [60.0, 51.0], "L2": [60.0, 60.0]})
    assert compare.pass_flips(holes, crit, {"L0": 3.0, "L1": 3.0, "L2": 3.0}) == 50.0
    assert compare.pass_flips(holes, crit, {}) == 0.0


def test_criteria_readings_and_a_bad_threshold():
    crit = load_criteria()
    assert crit["stated"] == pytest.approx({"L0": 35 * 2 ** 0.5, "L1": 35 * 2 ** 0.5, "L2": 40.0})
    assert crit["field"]["L1"] == pytest.approx(35.0)
    # §4.2's other reading of L2, from the undisturbed surface: the holes' column L2_surface = L2 + h1
    assert crit["field_surface"] == pytest.approx({"L0": 35 * 2 ** 0.5, "L1": 35.0, "L2_surface": 40.0})
    with pytest.raises(ConfigError, match="allowed NAME or sqrt2\\*NAME"):
        threshold("2*a1", Seedling(35.0, 25.0, 40.0))


def test_a_criteria_reading_of_an_unknown_L2_origin_is_refused(tmp_path):
    bad = tmp_path / "seedling.toml"
    bad.write_text((ROOT / "configs/seedling.toml").read_text().replace('L2_from = "undisturbed surface"',
                                                                        'L2_from = "the bottom"', 1))
    with pytest.raises(ConfigError, match="L2_from = 'the bottom': allowed 'subsided level' or 'undisturbed surface'"):
        load_criteria(bad)


def test_pass_rate_follows_the_per_hole_distributions():
    crit = {"L0": 49.5, "L1": 49.5, "L2": 40.0}
    wide = pd.DataFrame({"L0": [90.0, 95, 100], "L1": [60.0, 62, 64], "L2": [60.0, 62, 64]})
    r = compare.pass_probability(wide, crit)
    assert r["pass_pct"] > 99.9 and r["passed"] == 3
    narrow = wide.assign(L1=[45.0, 46, 47])
    r = compare.pass_probability(narrow, crit)
    assert r["pass_pct"] < 1.0 and r["passed"] == 0
    # a threshold at the mean gives one half, and the interval contains it
    half = wide.assign(L2=[38.0, 40, 42])
    r = compare.pass_probability(half, crit)
    assert r["pass_pct"] == pytest.approx(50.0, abs=0.5) and r["pass_lo"] < 50 < r["pass_hi"]
    # a hole not found (NaN measures) counts as failed: 3 of 4 found, all passing
    lost = pd.concat([wide, pd.DataFrame({"L0": [np.nan], "L1": [np.nan], "L2": [np.nan]})], ignore_index=True)
    r = compare.pass_probability(lost, crit)
    assert r["pass_pct"] == pytest.approx(75.0, abs=0.1) and r["passed"] == 3 and r["n"] == 4
    # one hole found and passing, one lost: no rate from one hole, but the count is 1 of 2
    r = compare.pass_probability(lost.iloc[[0, 3]], crit)
    assert math.isnan(r["pass_pct"]) and r["passed"] == 1 and r["n"] == 2


def test_interval_of_the_mean_uses_run_means_when_there_are_replicates():
    one = pd.DataFrame({"run": ["a"] * 4, "L0": [90.0, 92, 94, 96]})
    s = compare.metric_stats(one, "L0")
    assert s["sim_mean"] == 93.0 and s["n_runs"] == 1
    assert s["ci_hi"] - s["sim_mean"] == pytest.approx(3.1824 * one.L0.std() / 2, rel=1e-4)   # t(0.975, 3)
    two = pd.DataFrame({"run": ["a", "a", "b", "b"], "L0": [90.0, 92, 94, 96]})
    s = compare.metric_stats(two, "L0")
    assert s["ci_hi"] - s["sim_mean"] == pytest.approx(12.706 * np.std([91, 95], ddof=1) / math.sqrt(2), rel=1e-4)


def test_the_field_table_against_its_own_criteria():
    """Sand's mean width (49.0 mm) is below √2·a1 (49.5 mm) yet 90.4 % of its holes passed: under the
    stated reading its failing holes would have to be narrower than the pot's own side a1 on average."""
    field = compare.field_table()
    crit = load_criteria()
    stated = compare.field_consistency(field, crit["stated"])
    sand_l1 = stated[(stated.soil == "sand") & (stated.metric == "L1")]
    assert (~sand_l1.mean_above_threshold).sum() >= 3
    assert sand_l1.max_mean_of_failing_holes.min() < 35.0
    relaxed = compare.field_consistency(field, crit["field"])
    assert relaxed.mean_above_threshold.all()


def test_soil_ordering_is_resolved_only_when_the_intervals_part():
    """clay > loam > sand in the means is not enough: each soil's 95 % interval must lie above the next."""
    def table(ci_half):
        return pd.DataFrame({"soil": ["clay", "loam", "sand"], "metric": "L0", "field_mean": [91.8, 88.8, 85.2],
                             "sim_mean": [124.0, 121.0, 118.0], "ci_lo": [124.0 - ci_half, 121.0 - ci_half, 118.0 - ci_half],
                             "ci_hi": [124.0 + ci_half, 121.0 + ci_half, 118.0 + ci_half]})
    wide, narrow = compare.ordering(table(12.0))["L0"], compare.ordering(table(1.0))["L0"]
    assert wide["field"] and wide["simulated"] and not wide["resolved"] and not wide["tie"]
    assert narrow["simulated"] and narrow["resolved"]
    # each step on its own: loam's interval pulled down to sand's leaves only clay > loam resolved
    t = table(1.0)
    t.loc[t.soil == "loam", "ci_lo"] = 117.0
    steps = compare.ordering(t)["L0"]["steps"]
    assert steps["clay > loam"]["resolved"] and not steps["loam > sand"]["resolved"]
    assert steps["loam > sand"]["simulated"] and not compare.ordering(t)["L0"]["resolved"]


def test_soil_ordering_of_equal_rates_is_a_tie():
    """Zero pass rates that differ below the table's precision (0.1) neither show nor refute the ordering."""
    t = pd.DataFrame({"soil": ["clay", "loam", "sand"], "metric": "pass_stated", "field_mean": [94.4, 93.3, 90.4],
                      "sim_mean": [0.13, 0.08, 0.0], "ci_lo": [0.0] * 3, "ci_hi": [9.1, 6.5, 0.0]})
    o = compare.ordering(t)["pass_stated"]
    assert o["tie"] and not o["simulated"] and not o["resolved"]


def test_grains_put_back_into_a_punchs_volume_are_counted_with_where_they_came_from(tmp_path):
    """The kept run's holes stand open; grains moved from the ring beside the second hole into its punch's volume
    are found there, and only there, as having come from the ring and from above."""
    import shutil
    from analysis.holes import refill
    from analysis.holes.measure import hole_centres, load_run
    run = tmp_path / "run"
    shutil.copytree(ROOT / "tests/data/kept_run", run)
    before = refill.refill_run(run)
    assert (before.grains == 0).all() and (before.refill == 0).all()
    cfg, summary, state = load_run(run)
    x = hole_centres(summary)[summary.get("lead_in", 0) + 1] / 1000
    y, z_top = cfg["bed_size_mm"][1] / 2000, float(state["z_surface"])
    pos0 = state["initial_pos"]
    ring = np.flatnonzero((np.hypot(pos0[:, 0] - x, pos0[:, 1] - y) > 0.03) & (np.hypot(pos0[:, 0] - x, pos0[:, 1] - y) < 0.04)
                          & (pos0[:, 2] > z_top - 0.02))[:3]
    pos = state["pos"].copy()
    pos[ring] = [[x + 0.01 * k - 0.01, y, z_top - 0.045] for k in range(3)]   # 45 mm down, side by side on the axis
    np.savez(run / "state.npz", **{**state, "pos": pos})
    after = refill.refill_run(run)
    assert list(after.grains) == [0, 3] and list(after.from_ring) == [0, 3] and list(after.from_above) == [0, 3]
    assert 0 < after.refill[1] < 0.2 and after.origin_depth[1] < 20 and 30 < after.origin_r[1] < 40
