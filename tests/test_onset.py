"""The onset's tables (analysis/soil/onset.py): the planes it reaches with, and its single tests read from their
folders."""
import json

import numpy as np
import pandas as pd
import pytest

from analysis.soil import onset


def test_a_plane_recovers_made_up_slopes_with_the_bond_in_kpa():
    rng = np.random.default_rng(0)
    t = pd.DataFrame({k: rng.uniform(lo, hi, 20) for k, (lo, hi) in zip(
        onset.TERMS, [(4e4, 2e5), (3, 12), (0, 0.3), (0, 0.25), (0.05, 0.2), (0, 0.8)])})
    t["c_kpa"] = 2 + 0.01 * t.normal_cohesion / 1e3 + 40 * t.pressed_adhesion + 14 * t.bond_stretch
    coef, r2, _ = onset.plane(t, "c_kpa")
    assert coef == pytest.approx([2, 0.01, 0, 40, 0, 0, 14], abs=1e-9) and r2 == pytest.approx(1.0)


def test_the_single_tests_are_read_with_their_commands_and_a_column_still_moving(tmp_path):
    """Each test's parameters come from its command's --test-sets; a collapse without a result is still moving."""
    stood = tmp_path / "held" / "collapse" / "a"
    moving = tmp_path / "impacts" / "collapse" / "b"
    for d, onset_pa in ((stood, 4e4), (moving, 2e4)):
        d.mkdir(parents=True)
        (d / "command").write_text(f"python scripts/collapse.py --soil clay --test-set adhesion_onset={onset_pa:g} "
                                   "--test-set friction_deg=9")
    (stood / "r.json").write_text(json.dumps({"angle_deg": 26.0, "height_ratio": 0.84, "runout_mm": 635.0}))
    (moving / "collapse.log").write_text("collapse stopped: collapse: 1 % of the grains still move faster than ...")
    t = onset.probes(tmp_path).set_index("name")
    assert t.loc["a", "angle_deg"] == 26.0 and t.loc["a", "adhesion_onset"] == 4e4 and t.loc["b", "friction_deg"] == 9
    assert bool(t.loc["b", "still_moving"]) and np.isnan(t.loc["b", "angle_deg"])


def test_a_cones_grains_size_speed_and_bond_are_read_from_its_command(tmp_path):
    """A cone's --cohesion is both bonds unless a --test-set names one; its grains, scale and speed are columns."""
    d = tmp_path / "held" / "cone" / "F1-r6"
    d.mkdir(parents=True)
    (d / "command").write_text("./holes cone --soil clay --resolution medium --cone-scale 4.4 --cone-speed 0.1 "
                               "--cohesion 64979.12 --test-set shear_cohesion=5e4 --test-set pressed_adhesion=0.25")
    (d / "r.json").write_text(json.dumps({"cone_index_pa": 485702.1}))
    row = onset.probes(tmp_path).set_index("name").loc["F1-r6"]
    assert (row.resolution, row.cone_scale, row.cone_speed) == ("medium", 4.4, 0.1)
    assert (row.normal_cohesion, row.shear_cohesion, row.pressed_adhesion) == (64979.12, 5e4, 0.25)
    assert row.cone_kpa == pytest.approx(485.7021)


def test_one_sets_cones_are_pooled_by_cone_to_grain_ratio_and_compared_by_welch():
    """Repeats that differ in the bond's last digits group together; another set, and a slow cone, stay out."""
    f1 = dict(zip(onset.TERMS, (64979.12, 6.4804, 0.2485, 0.3805, 0.189, 0.4176)))
    rows = [{**f1, "normal_cohesion": b, "cone_to_particle": 2.41, "cone_kpa": v, "name": f"a{i}"}
            for i, (b, v) in enumerate(((64979.12, 540), (64990, 550), (64980, 530)))]
    rows += [{**f1, "cone_to_particle": g, "cone_kpa": v, "name": f"b{i}"}
             for i, (g, v) in enumerate(((3.21, 480), (4.70, 490), (3.21, 485)))]
    rows += [{**f1, "cone_to_particle": 3.21, "cone_kpa": 900, "name": "slow", "cone_speed": 0.1},
             {**f1, "pressed_adhesion": 0.0, "cone_to_particle": 2.41, "cone_kpa": 280, "name": "other"}]
    t = pd.DataFrame([{"test": "cone", "cone_speed": 0.5, **r} for r in rows])
    r = onset.cone_ratio(t).set_index("grains_across")
    assert list(r.index) == ["2.41", ">= 3.2"] and list(r["n"]) == [3, 3]
    assert r.loc["2.41", "mean_kpa"] == pytest.approx(540) and r.loc[">= 3.2", "mean_kpa"] == pytest.approx(485)
    assert r.loc[">= 3.2", "minus_smallest_kpa"] == pytest.approx(-55)
    assert r.loc[">= 3.2", "lo_kpa"] < -55 < r.loc[">= 3.2", "hi_kpa"] < 0 and r.loc[">= 3.2", "welch_p"] < 0.05
    assert r.loc[">= 3.2", "ratio_of_means"] == pytest.approx(485 / 540)


def made_up_cell() -> list[dict]:
    """A cell's three tests at 50, 100 and 200 kPa on a Mohr-Coulomb line of c 20 kPa, φ 25°."""
    import math
    return [{"stress_kpa": s, "sigma_at_peak_kpa": s, "tau_peak_kpa": 20 + s * math.tan(math.radians(25)),
             "size_m": [0.12] * 3} for s in (50.0, 100.0, 200.0)]


def test_the_filters_evaluations_are_read_with_their_floor_and_a_failed_columns_cell(tmp_path):
    """One evaluation on the grains that finished, one on the plane whose column was still moving: each row names its
    floor, c and φ come from the cell in both, the slope from the finished column only, the failure's reason kept;
    an evaluation drawn under other bench settings is left out."""
    tests, params = made_up_cell(), dict(zip(onset.TERMS, (9e4, 6.0, 0.3, 0.2, 0.15, 0.4)))
    heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]
    cfg = onset.load_config(onset.ONSET_CONFIG, "clay")
    ids = {f: onset.evaluation_id("clay", 1, params, {**cfg, "collapse_floor": f}) for f in ("plane", "grains")}
    for floor, failed in (("grains", None), ("plane", "scripts/collapse.py: collapse stopped: collapse: 1 % of the "
                                                      "grains still move faster")):
        name = ids[floor]
        d = tmp_path / "clay" / name
        d.mkdir(parents=True)
        (d / "cell.json").write_text(json.dumps({"tests": tests}))
        if failed is None:
            (d / "column.json").write_text(json.dumps({"profile_mm": heap, "floor": floor}))
        (d / "responses.json").write_text(json.dumps({"id": name, "soil": "clay", "seed": 1, **params,
                                                      **({"failed": failed} if failed else {})}))
    other = tmp_path / "clay" / "s1-0123456789"           # drawn under other bench settings: left out
    other.mkdir()
    (other / "responses.json").write_text(json.dumps({"id": other.name, "soil": "clay", "seed": 1, **params}))
    (tmp_path / "clay-probes.csv").write_text(f"# a probe\nid,c_kpa\n{ids['plane']},20\n")
    t = onset.filter_evaluations(tmp_path).set_index("floor")
    assert len(t) == 2
    assert t.loc["grains", "id"] == ids["grains"] and t.loc["plane", "id"] == ids["plane"]
    assert t["probe"].to_dict() == {"grains": False, "plane": True}
    assert t["c_kpa"].to_numpy() == pytest.approx([20, 20], abs=1e-6)
    assert t.loc["grains", "collapse_deg"] == pytest.approx(45.0, abs=1.0) and np.isnan(t.loc["plane", "collapse_deg"])
    assert t.loc["plane", "failed"].startswith("1 % of the grains") and t.loc["grains", "failed"] == ""
    assert np.isnan(t["cone_kpa"]).all()


@pytest.mark.parametrize("key, value, alpha", [("shear_cohesion", 1.8e5, 0.3), ("adhesion_share", 0.4, 0.0)])
def test_a_probe_with_a_parameter_of_its_own_is_read_with_it_and_kept_out_of_the_planes(tmp_path, key, value, alpha):
    """A --probe that gave a contact parameter besides the filter's terms (a shear bond of its own, the share law in
    place of α) is found under its id (drawn with it) and carries it in its column, empty for the filter's sets; the
    planes, whose terms hold the shear bond equal to the normal and re-adhere by α, leave it out."""
    tests, params = made_up_cell(), dict(zip(onset.TERMS, (9e4, 6.0, 0.3, 0.2, 0.15, 0.4)))
    cfg = onset.load_config(onset.ONSET_CONFIG, "clay")
    grains = {**cfg, "collapse_floor": "grains"}
    own_set = {**params, "pressed_adhesion": alpha, key: value}
    for each in (params, own_set):
        name = onset.evaluation_id("clay", 1, each, grains)
        d = tmp_path / "clay" / name
        d.mkdir(parents=True)
        (d / "cell.json").write_text(json.dumps({"tests": tests}))
        (d / "responses.json").write_text(json.dumps({"id": name, "soil": "clay", "seed": 1, **each}))
    probe = onset.evaluation_id("clay", 1, own_set, grains)
    (tmp_path / "clay-probes.csv").write_text(f"# a probe\nid,c_kpa\n{probe},20\n")
    t = onset.filter_evaluations(tmp_path)
    assert len(t) == 2 and set(t["floor"]) == {"grains"}
    assert t.set_index("probe")[key].to_dict().get(True) == value
    assert np.isnan(t.set_index("probe").loc[False, key])
    assert all(len(rows) == 1 for rows in onset.plane_rows(t).values())


def test_the_deepest_set_lies_as_many_residual_sds_inside_every_range_as_the_planes_allow():
    """Made-up evaluations of known planes with scatter: the set `deepest` returns lies inside the bounds and
    margin_sd residual SDs inside every range, and some range is met at exactly that depth (none deeper is possible);
    ranges that cannot all be met inside the bounds give a negative margin. The cone is weighed times the transfer,
    and a twin (the same set on the plane floor) counts once."""
    rng = np.random.default_rng(3)
    bounds = {"normal_cohesion": (6e4, 1.5e5), "friction_deg": (3.0, 10.0), "pressed_adhesion": (0.2, 0.6),
              "rolling_friction": (0.15, 0.4), "damping": (0.1, 0.25), "bond_stretch": (0.2, 0.8)}
    n = 30
    t = pd.DataFrame({k: rng.uniform(lo, hi, n) for k, (lo, hi) in bounds.items()})
    b, f, a, eta, d, st = (t[k] for k in onset.TERMS)
    t["c_kpa"] = 2 + 0.05 * b / 1e3 + 20 * a + 15 * st - 20 * d + rng.normal(0, 1.0, n)
    t["phi_deg"] = 16 + 0.7 * f + 5 * a + 4 * eta + rng.normal(0, 0.5, n)
    t["collapse_deg"] = 18 + 1.5 * f + 8 * a + 16 * d + rng.normal(0, 0.8, n)
    t["cone_kpa"] = (-450 + 4 * b / 1e3 + 50 * f + 450 * a + 500 * d + 200 * st + rng.normal(0, 20, n)) / 0.9
    t["floor"] = "grains"
    twin = t.iloc[[0]].assign(floor="plane", collapse_deg=np.nan)
    ranges = {"c_kpa": (20, 35), "phi_deg": (20, 30), "collapse_deg": (30, 38), "cone_kpa": (382.5, 517.5)}
    got = onset.deepest(pd.concat([t, twin], ignore_index=True), ranges, bounds, transfer=0.9)
    assert onset.has_planes(t.iloc[:8]) and not onset.has_planes(t.iloc[:7])    # a filter just begun: no planes yet
    assert got["n_c_kpa"] == n and got["n_collapse_deg"] == n and got["r2_cone_kpa"] > 0.9
    assert all(lo <= got[k] <= hi for k, (lo, hi) in bounds.items())
    m = got["margin_sd"]
    assert m > 0
    depth = [min(got[r] - lo, hi - got[r]) / got[f"resid_sd_{r}"] for r, (lo, hi) in ranges.items()]
    assert min(depth) == pytest.approx(m, abs=1e-6)
    assert 0.5 < got["resid_sd_cone_kpa"] / 20 < 1.6 and 0.5 < got["resid_sd_c_kpa"] < 1.6
    assert onset.deepest(t, {**ranges, "c_kpa": (60, 70)}, bounds, transfer=0.9)["margin_sd"] < 0


def test_the_tools_planes_recover_made_up_slopes_and_another_soils_offsets(monkeypatch):
    """Clay's planes in the seven terms (the modulus per MPa) come back from made-up responses; loam's sets, the same
    responses shifted, give back the shift, and loam's shifted reach reads the planes plus the shift at its set; loam's
    own planes (fitted to its sets alone) give back the shifted intercepts."""
    rng = np.random.default_rng(1)
    spans = [(5e4, 1.5e5), (6, 14), (0.1, 1.0), (0.05, 0.5), (0.1, 0.25), (0.0, 1.0), (4e6, 2e7)]
    slopes = {"c_kpa": [15, 0.02, -1, 0, -7, 2, 10, -0.15], "phi_deg": [8, 0.05, 0.7, 0.8, 3.6, -3, 2.7, 0.37],
              "collapse_deg": [10, 0.02, 1.3, 4, 1.5, 35, -1, 0.13], "cone_kpa": [-500, 4.4, 49, -93, 94, 270, 115, 26]}
    shift = {"c_kpa": -2.0, "phi_deg": 1.5, "collapse_deg": 0.5, "cone_kpa": -100.0}

    def sets(soil, n):
        t = pd.DataFrame({k: rng.uniform(lo, hi, n) for k, (lo, hi) in zip(onset.TOOLS_TERMS, spans)})
        x = np.column_stack([t[k] / onset.SCALE.get(k, 1.0) for k in onset.TOOLS_TERMS])
        for r, c in slopes.items():
            t[r] = c[0] + x @ np.array(c[1:]) + rng.normal(0, 0.01, n) + (shift[r] if soil == "loam" else 0.0)
        return t.assign(soil=soil, floor="grains")

    monkeypatch.setattr(onset, "tools_evaluations", lambda bench_dir=None: pd.concat([sets("clay", 30), sets("loam", 4)]))
    planes, reach = onset.tools_priors()
    got = planes.set_index("response")
    for r, c in slopes.items():
        assert got.loc[r, ["intercept", *onset.TOOLS_TERMS]].to_numpy(float) == pytest.approx(c, abs=0.05 * max(map(abs, c)))
    loam = reach[reach["soil"] == "loam"].set_index(["prior", "shift"])
    assert loam.loc[("corner-filter", "own"), [f"offset_{r}" for r in shift]].to_numpy(float) == pytest.approx(
        list(shift.values()), abs=0.1)
    assert set(reach[reach["soil"] == "clay"]["shift"]) == {"none"}
    own = loam.loc[("corner-filter", "own")]
    x = np.array([own[k] / onset.SCALE.get(k, 1.0) for k in onset.TOOLS_TERMS])
    for r in slopes:                                    # loam's cone transfer is 1
        c = got.loc[r, ["intercept", *onset.TOOLS_TERMS]].to_numpy(float)
        assert own[r] == pytest.approx(c[0] + c[1:] @ x + own[f"offset_{r}"], rel=1e-6)
    assert 0 <= own["share"] <= 1 and np.isfinite(loam["margin_sd"]).all()
    monkeypatch.setattr(onset, "tools_evaluations", lambda bench_dir=None: pd.concat([sets("clay", 30), sets("loam", 30)]))
    planes, reach = onset.tools_priors(planes_soil="loam")      # loam's own planes: the slopes, its shifted intercepts
    got = planes.set_index("response")
    assert set(planes["soil"]) == {"loam"} and set(reach[reach["soil"] == "loam"]["shift"]) == {"none"}
    for r, c in slopes.items():
        assert got.loc[r, "intercept"] == pytest.approx(c[0] + shift[r], abs=0.05 * max(map(abs, c)))
