"""Hole metrology (seed 001 §4.2) on synthetic beds with carved holes of known shape, and the pass logic."""
import functools
import math

import numpy as np
import pandas as pd
import pytest

from analysis.holes import compare
from analysis.core.config import ROOT, ConfigError, Seedling, load_criteria, threshold
from analysis.holes.metrology import DEPTHS, measure_hole, measure_state, side_profile
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


@pytest.mark.parametrize("r", [3.0, 4.0])                # the paper and default resolutions
@pytest.mark.parametrize("turn, jitter", [(0, 0.0), (30, 0.3)])
def test_metrology_recovers_a_carved_hole_within_one_grain_radius(r, turn, jitter):
    pos, rad, pos0, rad0 = carved_bed(r, turn, jitter)
    (hole,), z_surface, _ = measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    expected = {"L0": four_section_length(L0, W), "L1": four_section_width(L0, W),
                "L2": STRAIGHT + TAPER * (1 - DIAMETER_MIN / W), "h1": H1}
    for name, value in expected.items():
        assert getattr(hole, name) == pytest.approx(value, abs=r), name
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
    centre, taken at its effective depth, is the hole's, not the scoop's. Its length is the hole's own: the
    wall turns flat at the scoop's floor, 22 mm below the opening level (until the wall-edge rule, the opening
    ran on to x = 270 and L0 read 160 mm)."""
    pos, rad, pos0, rad0 = carved_bed(4.0, 10, 0.2)
    z_top = np.percentile(pos0[:, 2] + rad0, 99)
    pos, rad = carve(pos, rad, 220.0, 80, z_top, 100.0, W, 30.0, 5.0, 0.0, ring=0.0)
    (hole,), _, _ = measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    assert hole.found                                                 # the centroid-only rule lost it
    assert hole.x == pytest.approx(150.0, abs=4.0)                    # the opening's centroid: ~183
    assert hole.L0 == pytest.approx(four_section_length(L0, W), abs=2 * 4.0)    # the hole: x 104 ... 196
    assert hole.bottom == pytest.approx(H1 + STRAIGHT + TAPER, abs=2 * 4.0)


@pytest.mark.parametrize("r", [4.0, 5.0])                # the default and quick resolutions
def test_h1_reads_the_pressed_ring_not_the_rim_heaved_round_it(r):
    """A round hole (D = 50) in a ring pressed 17 mm down out to the plate's 40 mm radius, and the surface
    beyond it heaved 8 mm, as the disk scenes leave it (README, issue 5). h1 is the ring's depth; the band the
    earlier rule read (D/2 + probe ... 40 mm) lay half on the rim, which overhangs the probed surface by a grain
    radius plus the probe, and read 2.3 mm at r = 4. The side profile shows the ring and the rim."""
    press, heave = 17.0, 8.0
    pos0, rad0 = lattice_bed(300, 160, 100, r, jitter=0.2, turn=10)
    z_top = np.percentile(pos0[:, 2] + rad0, 99)
    pos, rad = carve(pos0, rad0, 150, 80, z_top, 50.0, 50.0, STRAIGHT, TAPER, press, ring=15.0)
    pos[np.hypot(pos[:, 0] - 150, pos[:, 1] - 80) >= 40, 2] += heave
    (hole,), z_surface, (xs, ys, S) = measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)
    assert hole.h1 == pytest.approx(press, abs=r)
    assert hole.L1 == pytest.approx(50.0, abs=2 * r)             # the hole at the ring's level, not ring + hole
    centres, depth = side_profile(S, xs, ys, z_surface, 150.0, 80.0, 50.0, 70.0)
    assert np.allclose(depth[:, centres < 40 - 2 * r], press, atol=r)   # both sides, up to the rim's overhang
    assert np.allclose(depth[:, centres > 40 + r], -heave, atol=r)


@functools.lru_cache(maxsize=None)
def carved_with_shelf(r, shape, shelf):
    """A carved hole pressed 13 mm round (a stadium 92 x 50 mm with vertical walls 45 mm deep, or a cone 60 mm
    across at the ring whose diameter shrinks 1 mm per mm of depth), and optionally a shelf `shelf` mm below the
    pressed ring running 90 x 60 mm on from its +x end, as the sleeve's plate leaves beside a simulated hole."""
    pos0, rad0 = lattice_bed(300, 160, 100, r, jitter=0.2, turn=10)
    z_top = np.percentile(pos0[:, 2] + rad0, 99)
    length, width, straight, taper = (L0, W, STRAIGHT, TAPER) if shape == "stadium" else (60.0, 60.0, 0.0, 60.0)
    pos, rad = carve(pos0, rad0, 150, 80, z_top, length, width, straight, taper, H1, ring=20)
    if shelf:
        pos, rad = carve(pos, rad, 215, 80, z_top - H1, 90.0, 60.0, shelf, 0.5, 0.0, ring=0.0)
    return measure_state(pos, rad, pos0, rad0, 160, [150.0], 50.0, 80.0, DIAMETER_MIN)


@pytest.mark.parametrize("r", [4.0, 5.0])
@pytest.mark.parametrize("shape, shelf", [("stadium", 0.0), ("stadium", 6.0), ("stadium", 10.0), ("cone", 0.0),
                                          ("cone", 6.0)])
def test_one_probe_radius_of_cut_moves_the_opening_by_at_most_3_mm(r, shape, shelf):
    """L0 and L1 are read between the wall's edges: where it crosses the level one probe radius below the
    pressed ring, or turns flatter than 40° below it. Moving that level by one probe radius (0.5 -> 1.5) moves
    them by no more than 3 mm, on vertical walls, on a cone's 63° walls, and with a shelf 6 or 10 mm below the
    ring beside the hole (the earlier rule, the connected region below the level, took in a shelf cut below
    it: a median 35 mm of L0 on the simulated holes). A shelf is not the opening: L0 is the hole's own."""
    _, z_surface, (xs, ys, S) = carved_with_shelf(r, shape, shelf)
    shallow, deep = (measure_hole(S, xs, ys, z_surface, 150.0, 80.0, 50.0, 80.0, r, DIAMETER_MIN, cut=k * r)
                     for k in (0.5, 1.5))
    for name in ("L0", "L1"):
        assert abs(getattr(shallow, name) - getattr(deep, name)) <= 3.0, name
    assert deep.h1 == shallow.h1 and deep.L2 == shallow.L2
    (hole,), _, _ = carved_with_shelf(r, shape, 0.0)
    (with_shelf,), _, _ = carved_with_shelf(r, shape, shelf)
    assert with_shelf.L0 == pytest.approx(hole.L0, abs=r)


@pytest.mark.parametrize("r", [3.0, 4.0, 5.0])
def test_a_sloping_walls_mouth_reads_short_by_a_few_grains(r):
    """The wall-edge rule's known bias: where the wall slopes (the cone's 63°), the grains and the probe round
    its lip, and the turn is found below it. Measured against the cone's four-section chords at the ring
    (53.4 mm): L0 0.6-1.5 and L1 1.7-2.4 grain radii short at r = 3, 4 and 5 mm (vertical walls: within
    1.3 r, test above). Pinned so a change of the rule that moves it is seen."""
    (hole,), _, _ = carved_with_shelf(r, "cone", 0.0)
    expected = four_section_length(60.0, 60.0)
    for name in ("L0", "L1"):
        assert expected - 3 * r <= getattr(hole, name) <= expected + r, name


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
