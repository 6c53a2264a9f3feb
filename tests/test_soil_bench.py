"""The soils' bench calibration (analysis/soil/bench_calibration.py) and its bench tests (scripts/shear.py,
scripts/collapse.py): the targets and settings are checked, an evaluation is reused rather than run again, the
filter's posterior and the packings' check are written, and (scene tier) the shear box and the collapse test
answer the contact parameters the way a granular soil does."""
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.core.schema import ConfigError
from analysis.soil import bench_calibration as bench
from analysis.core import runner      # the scenes' process: run_logged runs it (its lines to the log)
from analysis.soil.bayes import HOLE_METRICS, calibrate, sigma_floor


def made_up_bench(p: dict) -> dict:
    """c, φ and a collapse slope, smooth in the parameters, each leaning on a different mix of them."""
    return {"c_kpa": 0.08 * p["normal_cohesion"] / 1e3 + 5 * p["pressed_adhesion"],
            "phi_deg": 0.7 * p["friction_deg"] + 30 * p.get("rolling_friction", 0.1),
            "collapse_deg": 0.6 * p["friction_deg"] + 25 * p["pressed_adhesion"] + 20 * p.get("rolling_friction", 0.1)}


def shear_box(c: float, phi: float, weight: float = 2.4, size: float = 0.15) -> dict:
    """A shear box's result file whose tests lie on τ = c + σ tan φ, σ the plane's load (σn and `weight` resting
    on the plane) over the sheared area at a 30 mm shift."""
    def test(s):
        L = 1000 * size
        sigma = (s + weight) * L / (L - 30.0)
        return {"size_m": [size] * 2 + [size * 2 / 3], "stress_kpa": s, "shift_at_peak_mm": 30.0,
                "tau_peak_kpa": c + sigma * math.tan(math.radians(phi)),
                "curve": [[x, 0.0, 0.0, 0.0, (s + weight) * L / (L - x)] for x in (0.0, 15.0, 30.0)]}
    return {"c_kpa": c, "phi_deg": phi, "tests": [test(s) for s in (50.0, 100.0, 200.0)]}


def around(values: dict, share: float = 0.1) -> dict:
    """Point values as targets: each a range of ± `share` about it."""
    return {r: (v * (1 - share), v * (1 + share)) for r, v in values.items()}


def test_every_soil_has_a_sourced_range_for_each_bench_response_and_none_is_a_hole_metric():
    t = pd.read_csv(bench.TARGETS, comment="#")
    assert not set(t["response"]) & HOLE_METRICS
    for soil in ("clay", "loam", "sand"):
        s = bench.load_targets(soil)
        assert set(bench.RESPONSES) <= set(s.index)
        assert (s["lo"] < s["hi"]).all() and s["source"].str.len().min() > 3


def test_bounds_out_of_order_are_refused(tmp_path):
    text = bench.CONFIG.read_text().replace("friction_deg = [10.0, 35.0]", "friction_deg = [35.0, 10.0]")
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="bounds.friction_deg"):
        bench.load_config(tmp_path / "b.toml")


@pytest.mark.parametrize("fixed, match", [("friction_deg = 20", "both fixed and calibrated"),
                                          ("grain_colour = 1", "grain_colour")])
def test_a_fixed_parameter_is_a_soil_parameter_not_also_calibrated(tmp_path, fixed, match):
    text = bench.CONFIG.read_text().replace("[fixed]", "[fixed]\n" + fixed)
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match=match):
        bench.load_config(tmp_path / "b.toml")


@pytest.mark.parametrize("line, match", [("tolerance = 0.15", "lacks tolerance"), ("tolerance = 1.5", "cone_check.tolerance")])
def test_a_bad_cone_check_is_refused(tmp_path, line, match):
    text = bench.CONFIG.read_text().replace("tolerance = 0.15", "" if match.startswith("lacks") else line)
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match=match):
        bench.load_config(tmp_path / "b.toml")


@pytest.mark.parametrize("path", sorted(bench.CONFIG.parent.glob("bench_calibration*.toml")), ids=lambda p: p.name)
def test_every_bench_config_loads_for_every_soil(path):
    """Each bench config in configs/ reads for every soil, every prior inside its contact parameter's range."""
    for soil in ("clay", "loam", "sand"):
        assert len(bench.load_config(path, soil=soil)["bounds"]) >= 3


def test_the_variants_filters_lie_in_folders_of_their_own():
    """Clay's filter of each bench config keeps its tables (running table, posterior, checks) in its own folder."""
    configs = sorted(bench.CONFIG.parent.glob("bench_calibration*.toml"))
    folders = [bench.filter_dir(bench.load_config(p, soil="clay")) for p in configs]
    assert len(set(folders)) == len(folders), dict(zip((p.name for p in configs), folders))


def test_a_soils_own_prior_narrows_the_common_one_and_is_checked(tmp_path):
    common, sand = bench.load_config()["bounds"], bench.load_config(soil="sand")["bounds"]
    assert set(sand) == set(common)
    assert all(common[k][0] <= sand[k][0] < sand[k][1] <= common[k][1] for k in common)
    assert sand != common
    for extra, match in [("[soil_bounds.peat]\nfriction_deg = [10.0, 20.0]", "soil_bounds.peat"),
                         ("[soil_bounds.clay]\ncolour = [1.0, 2.0]", "soil_bounds.clay.colour"),
                         ("[soil_bounds.clay]\nfriction_deg = [20.0, 10.0]", "soil_bounds.clay.friction_deg")]:
        text = bench.CONFIG.read_text()
        text = text[:text.index("[soil_bounds")] + extra + "\n"
        (tmp_path / "b.toml").write_text(text)
        with pytest.raises(ConfigError, match=match):
            bench.load_config(tmp_path / "b.toml", soil="clay")


def test_the_response_surfaces_find_the_region_a_made_up_planar_bench_puts_the_targets_in():
    """A bench that is planar in the surfaces' terms, with scatter: the planes come back, and the region where they
    meet targets set round a known parameter set holds that set."""
    rng = np.random.default_rng(3)
    bounds = bench.load_config()["bounds"]
    table = pd.DataFrame({k: rng.uniform(lo, hi, 60) for k, (lo, hi) in bounds.items()})

    def planar(t):
        x = bench.surface_terms(t)
        return pd.DataFrame({"c_kpa": 2 + 0.07 * x.bond_kpa + 40 * x.rolling_friction,
                             "phi_deg": 22 + 0.45 * x.friction_deg + 10 * x.rolling_friction,
                             "collapse_deg": 20 + 25 * x.pressed_adhesion + 0.5 * x.friction_deg + 50 * x.damping})
    clean = planar(table)
    for r in bench.RESPONSES:
        table[r] = clean[r] + rng.normal(0, 0.5, len(table))
    surf = bench.response_surfaces(table).set_index("response")
    assert surf.loc["c_kpa", "bond_kpa"] == pytest.approx(0.07, rel=0.05)
    assert surf.loc["collapse_deg", "pressed_adhesion"] == pytest.approx(25, rel=0.05)
    assert (surf["disturbed_bond_kpa"] == 0).all()    # the share is fixed (0): no term
    assert surf.loc["collapse_deg", "damping"] == pytest.approx(50, rel=0.05) and surf.loc["c_kpa", "damping"] < 2
    assert (surf["r2"] > 0.95).all() and (surf["resid_sd"] < 1.0).all()
    unset = bench.response_surfaces(table.drop(columns="damping").assign(collapse_deg=clean.collapse_deg))
    assert (unset["damping"] == 0).all()          # evaluations that all ran at one damping give it no slope
    truth = pd.DataFrame([{"normal_cohesion": 2e5, "friction_deg": 12.0, "pressed_adhesion": 0.2,
                           "rolling_friction": 0.1, "damping": 0.15}])
    at = planar(truth).iloc[0]
    targets = pd.DataFrame({"lo": at - 3, "hi": at + 3})
    region = bench.feasible_region(surf.reset_index(), targets, bounds)
    assert 0 < region["share"] < 0.2
    for k, v in truth.iloc[0].items():
        assert region[k][0] <= v <= region[k][2], (k, region[k])


def test_the_fixed_parameters_reach_the_scenes_and_name_the_evaluation():
    cfg = bench.load_config()
    params = {"normal_cohesion": 3e5, "friction_deg": 20.0, "new_contact_cohesion": 0.01, "rolling_friction": 0.1}
    items = bench.overrides(params, cfg["fixed"])
    assert "bond_fragile=0.0" in items and "shear_cohesion=300000.0" in items
    assert bench.evaluation_id("clay", 1, params, cfg) != bench.evaluation_id("clay", 1, params, {**cfg, "fixed": {}})


def test_the_batch_model_gives_the_one_by_one_posterior():
    bounds = bench.load_config()["bounds"]
    truth = {"normal_cohesion": 300e3, "friction_deg": 22.0, "pressed_adhesion": 0.2, "rolling_friction": 0.1}
    one = calibrate(made_up_bench, around(made_up_bench(truth)), bounds, samples=12, iterations=2)
    many = calibrate(lambda rows: [made_up_bench(r) for r in rows], around(made_up_bench(truth)), bounds, samples=12,
                     iterations=2, batch=True)
    assert one["mean"] == pytest.approx(many["mean"])


def test_a_finished_evaluation_is_read_back_never_run_again(tmp_path, monkeypatch):
    cfg = bench.load_config()
    params = {"normal_cohesion": 30e3, "friction_deg": 25.0, "new_contact_cohesion": 0.5}
    folder = tmp_path / "clay" / bench.evaluation_id("clay", 2, params, cfg)
    folder.mkdir(parents=True)
    (folder / "responses.json").write_text(json.dumps({"c_kpa": 1.0, "phi_deg": 40.0}))   # what its run read
    (folder / "box.json").write_text(json.dumps(shear_box(12.0, 30.0)))
    heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]       # 45° from x = 100 mm
    (folder / "bed.json").write_text(json.dumps({"profile_mm": heap}))
    monkeypatch.setattr(runner, "run_process", lambda *a: pytest.fail("a finished evaluation ran again"))
    again = bench.evaluate("clay", 2, params, cfg, tmp_path)
    assert again["c_kpa"] == pytest.approx(12.0) and again["phi_deg"] == pytest.approx(30.0)    # measured again
    assert again["collapse_deg"] == pytest.approx(45.0, abs=1.0)
    assert bench.evaluation_id("clay", 2, {**params, "friction_deg": 25.000001}, cfg) == folder.name
    assert bench.evaluation_id("clay", 3, params, cfg) != folder.name


def test_an_evaluation_stopped_between_its_tests_reruns_only_the_one_it_lacks(tmp_path, monkeypatch):
    """The shear box finished (its result file written) and the collapse test did not: the evaluation reads the box
    back and runs the collapse test alone; its responses are the box's file's."""
    cfg = bench.load_config()
    params = {"normal_cohesion": 9e4, "friction_deg": 9.0, "pressed_adhesion": 0.1, "rolling_friction": 0.3}
    folder = tmp_path / "clay" / bench.evaluation_id("clay", 1, params, cfg)
    folder.mkdir(parents=True)
    (folder / "box.json").write_text(json.dumps(shear_box(22.5, 28.1)))
    ran = []

    def fake(cmd, sink):
        ran.append(Path(cmd[1]).stem)
        heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]
        (folder / "column.json").write_text(json.dumps({"profile_mm": heap, "runout_mm": 90.0}))
        return 0, json.dumps({"runout_mm": 90.0})
    monkeypatch.setattr(runner, "run_process", fake)
    row = bench.evaluate("clay", 1, params, cfg, tmp_path)
    assert ran == ["collapse"] and row["resumed"] == "shear"
    assert (row["c_kpa"], row["phi_deg"]) == (pytest.approx(22.5), pytest.approx(28.1))
    assert row["tau_peak_kpa"] == [t["tau_peak_kpa"] for t in shear_box(22.5, 28.1)["tests"]]
    assert row["collapse_deg"] == pytest.approx(45.0, abs=1.0)


def test_a_test_the_scene_stopped_is_kept_as_failed_and_weighs_nothing(tmp_path, monkeypatch):
    """A leaking box (exit 3) is an evaluation without responses: kept, never run again, and its sample's miss is
    so large that the filter gives it no weight; a crash of another kind still stops the calibration."""
    cfg = bench.load_config()
    params = {"normal_cohesion": 2e4, "friction_deg": 10.0, "new_contact_cohesion": 0.0, "rolling_friction": 0.0}

    def leaking(cmd, sink):
        sink("shear stopped: shear: 12 grains left the box through the frames' gap (the box leaks)\n")
        return bench.UNTESTABLE, ""
    monkeypatch.setattr(runner, "run_process", leaking)
    row = bench.evaluate("clay", 1, params, cfg, tmp_path)
    assert "the box leaks" in row["failed"] and all(math.isnan(row[r]) for r in bench.RESPONSES)
    monkeypatch.setattr(runner, "run_process", lambda *a: pytest.fail("a failed evaluation ran again"))
    assert bench.evaluate("clay", 1, params, cfg, tmp_path)["failed"] == row["failed"]
    monkeypatch.setattr(runner, "run_process", lambda cmd, sink: (1, ""))
    with pytest.raises(RuntimeError, match="exited 1"):
        bench.evaluate("clay", 2, params, cfg, tmp_path)
    truth = {"normal_cohesion": 300e3, "friction_deg": 22.0, "pressed_adhesion": 0.2, "rolling_friction": 0.1}
    seen = []

    def half_untestable(p):
        seen.append(p)
        return {r: math.nan for r in bench.RESPONSES} if p["friction_deg"] < 15 else made_up_bench(p)
    post = calibrate(half_untestable, around(made_up_bench(truth)), cfg["bounds"], samples=12, iterations=2)
    weights = np.asarray(post["weights"])[-1] if np.ndim(post["weights"]) > 1 else np.asarray(post["weights"])
    assert np.isfinite(list(post["mean"].values())).all()
    assert weights[np.asarray([p["friction_deg"] < 15 for p in seen[-12:]])].sum() < 1e-6


def test_a_filter_with_packings_in_turn_runs_each_iterations_samples_on_every_packing(tmp_path, monkeypatch):
    """calibration_seed = [1, 2, 3]: an iteration's samples take the packings in turn, so each packing carries a third
    of them and a sample's packing follows its place in the iteration."""
    calls = []

    def fake(soil, seed, params, cfg, out_dir):
        calls.append(seed)
        return {"soil": soil, "seed": seed, **params, **made_up_bench(params), "tau_peak_kpa": [], "wall_s": 0.0}
    monkeypatch.setattr(bench, "evaluate", fake)
    cfg = {**bench.load_config(), "samples": 6, "iterations": 2, "workers": 1, "calibration_seed": [1, 2, 3]}
    bench.calibrate("clay", cfg, tmp_path)
    assert calls == [1, 2, 3] * 4
    assert pd.read_csv(tmp_path / "clay.csv", comment="#").seed.tolist() == calls


@pytest.mark.parametrize("value", ["-1", "[1, 1]", "[]", '"1"', "true", "[1, -2]"])
def test_the_filters_packings_are_distinct_seeds(tmp_path, value):
    text = bench.CONFIG.read_text().replace("calibration_seed = 1 ", f"calibration_seed = {value} ")
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="bench.calibration_seed"):
        bench.load_config(tmp_path / "b.toml")


@pytest.mark.parametrize("line, match", [("phi_deg = 0.0", "packing_scatter.phi_deg"),
                                         ("h1 = 1.0", "packing_scatter.h1")])
def test_a_packing_scatter_is_an_sd_of_a_bench_response(tmp_path, line, match):
    text = bench.CONFIG.read_text().replace("phi_deg = 1.8", line)
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match=match):
        bench.load_config(tmp_path / "b.toml")


def test_the_calibration_writes_its_posterior_and_checks_it_on_every_packing(tmp_path, monkeypatch):
    """Through a made-up bench whose packings scatter: the filter's samples, the posterior with intervals and
    correlations, and the check of the posterior mean against the targets' ranges on each check packing."""
    calls = []

    def fake(soil, seed, params, cfg, out_dir):
        calls.append(seed)
        return {"soil": soil, "seed": seed, **params, **{k: v * (1 + 0.01 * seed) for k, v in made_up_bench(params).items()},
                "tau_peak_kpa": [], "wall_s": 0.0}
    monkeypatch.setattr(bench, "evaluate", fake)
    cones = []

    def fake_cone(args, log_path):                    # a cone that reads 20 kPa per kPa of c
        cones.append(args)
        bond = float(args[args.index("--cohesion") + 1])
        return {"cone_index_pa": 20 * made_up_bench({"normal_cohesion": bond, "friction_deg": 20.0,
                                                     "pressed_adhesion": 0.0, "rolling_friction": 0.1})["c_kpa"] * 1e3}
    monkeypatch.setattr(bench, "cone_scene", fake_cone)
    cfg = {**bench.load_config(), "samples": 10, "iterations": 2, "workers": 1}
    post = bench.calibrate("clay", cfg, tmp_path)
    assert set(calls) == {cfg["calibration_seed"]} and len(calls) == 20
    table = pd.read_csv(tmp_path / "clay.csv", comment="#")
    assert len(table) == 20 and table["weight_last"].notna().sum() == 10
    for name, (lo, hi) in post["interval"].items():
        assert cfg["bounds"][name][0] <= lo <= hi <= cfg["bounds"][name][1]
    assert post["correlation"]["friction_deg"]["friction_deg"] == pytest.approx(1.0)
    written = json.loads((tmp_path / "clay-posterior.json").read_text())
    assert written["mean"] == post["mean"] and written["packing_scatter"] == cfg["packing_scatter"]
    assert written["shear_reading"] == "plane load"
    floor = sigma_floor(bench.target_ranges("clay", cfg), cfg["packing_scatter"])
    assert len(written["likelihood_sigma"]) == 2 and min(written["likelihood_sigma"]) >= floor * (1 - 1e-9)
    result = bench.check("clay", post, cfg, tmp_path)
    assert sorted(set(calls[20:])) == sorted(cfg["check_seeds"])
    for r in bench.RESPONSES:
        assert math.isfinite(result[r]["mean"]) and result[r]["sd"] > 0
        assert isinstance(result[r]["every_packing_inside"], bool)
        lo, hi = result[r]["target"]
        assert result[r]["mean_inside"] == (lo <= result[r]["mean"] <= hi)
        assert result[r]["mean_inside"] or not result[r]["every_packing_inside"]
    # the cone beside Table 2 (450 kPa for clay), once: a second check reuses the kept summary
    cone = result["cone_kpa"]
    assert cone["target"] == pytest.approx([450 * 0.85, 450 * 1.15]) and cone["mean"] > 0
    assert cone["every_packing_inside"] == (cone["target"][0] <= cone["mean"] <= cone["target"][1])
    assert len(cones) == 1 and "--test-set" in cones[0] and "bond_fragile=0.0" in cones[0]
    assert bench.check("clay", post, cfg, tmp_path)["cone_kpa"]["mean"] == cone["mean"] and len(cones) == 1
    assert [p.name for p in bench.report(tmp_path)] == ["posterior.png", "responses.png", "surfaces.csv", "feasible.csv",
                                                        "deepest.csv", "profiles.csv", "profiles.png"]
    config = tmp_path / "clay.toml"
    config.write_text((bench.ROOT / "configs/soils/clay.toml").read_text())
    for _ in range(2):                                       # written again, it replaces its own table
        bench.write_posterior("clay", post, result, "test", config)
    from analysis.core.schema import read_toml
    from analysis.core.soil_config import load_soil
    table = read_toml(config)["bench_posterior"]
    assert config.read_text().count("[bench_posterior]") == 1 and load_soil(config) == load_soil("clay")
    assert table["friction_deg"]["mean"] == pytest.approx(post["mean"]["friction_deg"], rel=1e-3)
    assert table["status"].startswith(("within every target", "outside its target"))
    assert "; the packings' mean " in table["status"] and "check_packings" not in table
    nine = {"c_kpa": {"mean": 23.7, "mean_interval": [20.4, 27.0], "mean_verdict": "inside"}}
    bench.record_packings("clay", nine, [1, 2, 3, 4], tmp_path, config)      # the check on more packings beside it
    table = read_toml(config)["bench_posterior"]
    assert table["check_packings"] == {"seeds": [1, 2, 3, 4], "c_kpa": "inside: 23.7 [20.4, 27]"}
    assert table["status"].startswith(("within every target", "outside its target")) and load_soil(config) == load_soil("clay")


@pytest.mark.parametrize("scene", ["collapse", "cone"])
def test_an_override_out_of_range_stops_a_bench_test_before_any_bed(capsys, scene):
    import importlib
    main = importlib.import_module(f"scripts.{scene}").main
    assert main(["--soil", "clay", "--bed-dir", "/nonexistent", "--test-set", "friction_deg=99"]) == 2
    assert "friction_deg" in capsys.readouterr().err
    assert main(["--soil", "clay", "--bed-dir", "/nonexistent", "--test-set", "bond_fragile=0.5"]) == 2
    assert "bond_fragile = 0.5: must be a whole number in [0, 1]" in capsys.readouterr().err


def test_the_collapse_slope_reads_a_made_up_heap():
    """Made-up heaps of known slope read within a degree on 2 mm bins and on the scene's 12 mm ones (the crossings
    are interpolated between bins);
    a face left standing reads steep, and a clump lying loose beyond its toe does not make it shallow."""
    from analysis.soil.collapse import slope_angle
    for step, tol in ((0.002, 1.0), (0.012, 1.0)):
        x = np.arange(0, 0.4, step)
        for angle in (25.0, 40.0, 60.0):
            h = np.clip(0.1 - (x - 0.1) * math.tan(math.radians(angle)), 0, 0.1)
            assert slope_angle(x, h)["angle_deg"] == pytest.approx(angle, abs=tol)
    x = np.arange(0, 0.4, 0.012)
    face = np.where(x < 0.15, 0.1, 0.0)
    assert slope_angle(x, face)["angle_deg"] > 75
    assert slope_angle(x, face + np.where((x > 0.17) & (x < 0.2), 0.04, 0.0))["angle_deg"] > 75


SMALL = ["--soil", "sand", "--resolution", "medium", "--size", "100,100,60", "--threads", "1"]


def bench_scenes(tmp_path, scene: str, cases: dict) -> dict:
    """Run scripts/<scene>.py once per case (name -> extra arguments), two at a time, on one bed (each settles it
    if it is not there yet; a bed is written atomically); name -> the JSON result it wrote."""
    import subprocess
    import sys
    from concurrent.futures import ThreadPoolExecutor

    def one(name):
        out = tmp_path / name
        r = subprocess.run([sys.executable, str(bench.ROOT / f"scripts/{scene}.py"), *SMALL, "--bed-dir",
                            str(tmp_path / "beds"), "--out", str(out), *cases[name]], capture_output=True, text=True,
                           timeout=600, cwd=bench.ROOT)
        assert r.returncode == 0, r.stderr[-2000:]
        return json.loads(next(out.glob("*.json")).read_text())
    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip(cases, pool.map(one, cases)))


@pytest.mark.scene
def test_a_cohesionless_shear_box_gives_a_friction_angle_that_grows_with_the_grains_friction(tmp_path):
    """Sand's grains without any bond at two inter-particle frictions: c near zero (within a quarter of the
    stress range's shear strength) and φ higher for the rougher grains."""
    fits = bench_scenes(tmp_path, "shear", {f"mu{mu:g}": ["--stress", "25,75", "--speed", "0.1", "--test-set",
                                                         f"friction_deg={mu}", "--test-set", "normal_cohesion=0",
                                                         "--test-set", "shear_cohesion=0"] for mu in (15.0, 35.0)})
    for fit in fits.values():
        assert abs(fit["c_kpa"]) < 0.25 * max(t["tau_peak_kpa"] for t in fit["tests"]), fit["c_kpa"]
    assert fits["mu35"]["phi_deg"] > fits["mu15"]["phi_deg"] + 3, (fits["mu15"]["phi_deg"], fits["mu35"]["phi_deg"])


@pytest.mark.scene
def test_a_remoulded_sample_holds_only_the_bonds_its_load_pressed_into_it(tmp_path):
    """`--remoulded`: every contact of the sample a new one (no share of the intact bond here), so at the low stress
    it shears weaker than the intact sample of the same bed and bonds; with pressed re-adhesion (α 0.5) it gains the
    strength its load pressed into its contacts (small box: peaks 36.9 intact, 32.6 remoulded, 39.5 and 103.5
    against 99.1 kPa at 25 and 75 kPa with α)."""
    bonds = ["--stress", "25,75", "--speed", "0.1", "--test-set", "normal_cohesion=100000", "--test-set",
             "shear_cohesion=100000", "--test-set", "new_contact_cohesion=0", "--test-set", "bond_fragile=0"]
    fits = bench_scenes(tmp_path, "shear", {"intact": bonds, "remoulded": [*bonds, "--remoulded"],
                                            "pressed": [*bonds, "--remoulded", "--test-set", "pressed_adhesion=0.5"]})
    peaks = {k: [t["tau_peak_kpa"] for t in fit["tests"]] for k, fit in fits.items()}
    assert peaks["remoulded"][0] < peaks["intact"][0] - 2, peaks
    assert np.mean(peaks["pressed"]) > np.mean(peaks["remoulded"]) + 2, peaks
    assert fits["remoulded"]["remoulded"] and "remoulded" not in fits["intact"]


@pytest.mark.scene
def test_a_preload_taken_off_leaves_a_remoulded_sample_the_bonds_it_pressed(tmp_path):
    """`--preload`: a remoulded sample pressed at 75 kPa and sheared at 10 kPa keeps the bonds its preload pressed
    into it: with pressed re-adhesion the preload raises its peak by more than it does without (small box: 18.9 to
    16.6 kPa without, 21.4 to 29.1 kPa at α 0.5)."""
    base = ["--stress", "10", "--speed", "0.1", "--remoulded", "--test-set", "normal_cohesion=100000", "--test-set",
            "shear_cohesion=100000", "--test-set", "new_contact_cohesion=0", "--test-set", "bond_fragile=0"]
    cases = {f"{name}-a{a:g}": [*base, *pre, "--test-set", f"pressed_adhesion={a}"]
             for a in (0.0, 0.5) for name, pre in (("steady", []), ("preloaded", ["--preload", "75"]))}
    peak = {k: fit["tests"][0]["tau_peak_kpa"] for k, fit in bench_scenes(tmp_path, "shear", cases).items()}
    gain = {a: peak[f"preloaded-a{a:g}"] - peak[f"steady-a{a:g}"] for a in (0.0, 0.5)}
    assert gain[0.5] > gain[0.0] + 2, peak


@pytest.mark.scene
def test_disturbed_soil_with_its_bonds_back_stands_steeper_than_without(tmp_path):
    runs = bench_scenes(tmp_path, "collapse", {f"f{frac:g}": ["--test-set", f"new_contact_cohesion={frac}"]
                                                for frac in (0.0, 1.0)})
    angles = {name: r["angle_deg"] for name, r in runs.items()}
    assert 15 < angles["f0"] < 60 and angles["f1"] > angles["f0"] + 10, angles


def test_the_cone_runs_on_chosen_evaluations_and_keeps_every_one(tmp_path, monkeypatch):
    """`calibrate --bench --cones`: each chosen evaluation's parameters through the cone check, beside its bench
    responses, in <soil>-cones.csv; a second call adds its rows and reruns no cone; an id without a finished
    evaluation is refused."""
    import shutil
    kept = [d for d in sorted(bench.BENCH_DIR.glob("clay/s1-*/responses.json"))
            if "failed" not in json.loads(d.read_text())][:2]                  # two of the committed evaluations
    for done in kept:
        shutil.copytree(done.parent, tmp_path / "clay" / done.parent.name)
    ids = [d.parent.name for d in kept]
    runs = []

    def fake_cone(args, log_path):
        runs.append(args)
        return {"cone_index_pa": 1e3 * float(args[args.index("--cohesion") + 1]) / 500}
    monkeypatch.setattr(bench, "cone_scene", fake_cone)
    cfg = bench.load_config(soil="clay")
    first = bench.cones("clay", ids[:1], cfg, tmp_path, workers=1)
    table = bench.cones("clay", ids, cfg, tmp_path, workers=2)
    assert len(runs) == 2 and list(table.id) == ids
    saved = pd.read_csv(tmp_path / "clay-cones.csv", comment="#")
    assert list(saved.id) == ids and set(bench.RESPONSES) <= set(saved.columns)
    assert saved.cone_kpa.iloc[0] == pytest.approx(first.cone_kpa.iloc[0])
    assert saved.cone_kpa.iloc[0] == pytest.approx(json.loads(kept[0].read_text())["normal_cohesion"] / 500, rel=1e-3)
    with pytest.raises(ConfigError, match="s1-0000000000"):
        bench.cones("clay", ["s1-0000000000"], cfg, tmp_path)
    bench.cones("clay", ids[:1], cfg, tmp_path, workers=1, runs_grains=True)     # the checks' cone: its own summary
    assert len(runs) == 3 and runs[-1][runs[-1].index("--resolution") + 1] == cfg["resolution"]
    assert {r[r.index("--seed") + 1] for r in runs} == {"1"}                  # each evaluation's own packing
    assert len(pd.read_csv(tmp_path / "clay-cones-runs-grains.csv", comment="#")) == 1


def test_the_size_check_runs_the_posterior_in_both_boxes_and_judges_each_response_by_the_packing_scatter(tmp_path,
                                                                                                       monkeypatch):
    """`calibrate --bench --size-check`: the posterior mean on every check packing in the configured box and in the
    grown one; a response whose mean the grown box moves by more than the packings' SD fails, one it moves less
    passes; <soil>-size.csv keeps every evaluation. A grown box no larger than the configured one is refused."""
    cfg = bench.load_config(soil="clay")
    post = {"normal_cohesion": 3e5, "friction_deg": 12.0, "new_contact_cohesion": 0.001, "rolling_friction": 0.1}
    (tmp_path / "clay-posterior.json").write_text(json.dumps({"mean": post}))
    seen = []

    def made_up(soil, seed, params, box, out_dir):
        seen.append((seed, tuple(box["size_mm"])))
        assert params == post
        small = box["size_mm"] == cfg["size_mm"]
        return {"id": f"s{seed}", "seed": seed, "c_kpa": (28.0 if small else 21.0) + seed,
                "phi_deg": 27.0 + seed + (0.0 if small else 0.3), "collapse_deg": 35.0 + 2 * seed}
    monkeypatch.setattr(bench, "evaluate", made_up)
    verdict = bench.size_check("clay", cfg, tmp_path).set_index("response")
    assert sorted(seen) == sorted((s, tuple(b)) for s in cfg["check_seeds"] for b in (cfg["size_mm"], cfg["size_check_mm"]))
    assert verdict.loc["c_kpa", "shift"] == pytest.approx(-7.0) and not verdict.loc["c_kpa", "passes"]
    assert verdict.loc["phi_deg", "passes"] and verdict.loc["collapse_deg", "passes"]
    saved = pd.read_csv(tmp_path / "clay-size.csv", comment="#")
    assert len(saved) == 2 * len(cfg["check_seeds"]) and set(saved.box) == {"configured", "grown"}
    text = bench.CONFIG.read_text().replace("size_check_mm = [225, 225, 150]", "size_check_mm = [225, 150, 100]")
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="size_check_mm"):
        bench.load_config(tmp_path / "b.toml")


def test_the_height_check_grows_the_checks_box_in_height_alone_into_its_own_table(tmp_path, monkeypatch):
    """`--size-check height`: the posterior on the check packings in the checks' box and in it grown in height
    alone (<soil>-box-height.csv, apart from the size check's tables); a height check that is not the checks' box
    made taller is refused, naming the field."""
    cfg = bench.load_config(soil="clay")
    post = {"normal_cohesion": 3e5, "friction_deg": 12.0, "new_contact_cohesion": 0.001, "rolling_friction": 0.1}
    (tmp_path / "clay-posterior.json").write_text(json.dumps({"mean": post}))
    seen = []

    def made_up(soil, seed, params, box, out_dir):
        seen.append(tuple(box["size_mm"]))
        return {"id": f"s{seed}-{box['size_mm'][2]}", "seed": seed, "c_kpa": 20.0 + seed, "phi_deg": 27.0 + seed,
                "collapse_deg": 35.0 + seed}
    monkeypatch.setattr(bench, "evaluate", made_up)
    bench.size_check("clay", cfg, tmp_path, box="height")
    assert set(seen) == {tuple(cfg["check_box_mm"]), tuple(cfg["check_height_check_mm"])}
    assert cfg["check_height_check_mm"][:2] == cfg["check_box_mm"][:2]
    assert cfg["check_height_check_mm"][2] > cfg["check_box_mm"][2]
    saved = pd.read_csv(tmp_path / "clay-box-height.csv", comment="#")
    assert set(saved.box) == {"configured", "grown"} and not (tmp_path / "clay-box-size.csv").exists()
    text = bench.CONFIG.read_text().replace("check_height_check_mm = [225, 225, 225]",
                                            "check_height_check_mm = [338, 338, 225]")
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="check_height_check_mm"):
        bench.load_config(tmp_path / "b.toml")


def test_the_size_check_asks_for_the_bench(capsys):
    from analysis.cli import main
    assert main(["calibrate", "--soil", "clay", "--size-check"]) == 2
    assert "--size-check: allowed only with --bench" in capsys.readouterr().err


def test_the_size_check_and_the_cones_are_one_at_a_time(capsys):
    from analysis.cli import main
    assert main(["calibrate", "--soil", "clay", "--bench", "--size-check", "--cones", "s1-0000000000"]) == 2
    assert "allowed one of them" in capsys.readouterr().err


def test_workers_sets_how_many_bench_scenes_run_at_a_time_else_the_config_does(monkeypatch):
    """`calibrate --bench --workers N` runs N evaluations at a time (the size check's here); without it, [bench]
    workers. The size check grows the box it is told and checks the packings of --seeds, else the config's."""
    from analysis.cli import main
    seen = []
    monkeypatch.setattr(bench, "size_check", lambda soil, cfg, out_dir, box, seeds:
                        seen.append((cfg["workers"], out_dir, box, seeds)) or pd.DataFrame())
    assert main(["calibrate", "--soil", "clay", "--bench", "--size-check", "--workers", "1"]) == 0
    assert main(["calibrate", "--soil", "clay", "--bench", "--size-check", "checks", "--seeds", "1,2"]) == 0
    folder = bench.BENCH_DIR
    assert seen == [(1, folder, "filter", None), (bench.load_config(soil="clay")["workers"], folder, "checks", [1, 2])]


def test_the_cone_transfer_reads_the_posterior_cone_at_both_grain_sizes_on_each_packing(tmp_path, monkeypatch, capsys):
    """`calibrate --bench --cone-transfer`: the posterior mean's cone on each packing at the filter's grains and at
    the bench's, their ratio per packing in <soil>-cone-transfer.csv; cones already run are reused; without a
    posterior, or without --bench, it is refused."""
    from analysis.cli import main
    cfg = bench.load_config(soil="loam")
    post = {"normal_cohesion": 1e5, "friction_deg": 16.0, "new_contact_cohesion": 0.005, "rolling_friction": 0.15}
    with pytest.raises(ConfigError, match="no posterior of loam"):
        bench.cone_transfer("loam", [1], cfg, tmp_path)
    (tmp_path / "loam-posterior.json").write_text(json.dumps({"mean": post}))
    ran = []

    def fake_cone(args, log):
        res, seed = args[args.index("--resolution") + 1], int(args[args.index("--seed") + 1])
        ran.append((res, seed))
        assert float(args[args.index("--cohesion") + 1]) == pytest.approx(post["normal_cohesion"])
        return {"cone_index_pa": (440e3 if res == cfg["cone_check"]["resolution"] else 400e3) + 1e3 * seed}
    monkeypatch.setattr(bench, "cone_scene", fake_cone)
    table = bench.cone_transfer("loam", [1, 2], cfg, tmp_path, workers=2)
    assert sorted(ran) == sorted((r, s) for r in (cfg["resolution"], cfg["cone_check"]["resolution"]) for s in (1, 2))
    assert table.ratio.to_numpy() == pytest.approx([401 / 441, 402 / 442])
    assert table.r_filter_mm.iloc[0] > table.r_runs_mm.iloc[0] and table.runs_inside.all()
    bench.cone_transfer("loam", [2], cfg, tmp_path)
    assert len(ran) == 4
    saved = pd.read_csv(tmp_path / "loam-cone-transfer.csv", comment="#")
    assert list(saved.seed) == [2] and saved.cone_runs_kpa.iloc[0] == pytest.approx(402.0)
    assert main(["calibrate", "--soil", "loam", "--bench", "--runs-grains"]) == 2
    assert "--runs-grains: allowed only with --cones" in capsys.readouterr().err
    assert main(["calibrate", "--soil", "loam", "--cone-transfer"]) == 2
    assert "--cone-transfer: allowed only with --bench" in capsys.readouterr().err


def test_the_deepest_point_lies_midway_in_made_up_planes_and_its_check_runs_it_on_every_check_packing(tmp_path,
                                                                                                      monkeypatch):
    """`deepest_point`: on made-up planes the set whose responses lie farthest inside their targets in units of each
    plane's scatter; `calibrate --bench --check-deepest` runs that set
    on every check packing into <soil>-deepest-check.csv, leaving the posterior's check alone."""
    bounds = {"normal_cohesion": (5e4, 1.5e5), "friction_deg": (10.0, 20.0), "pressed_adhesion": (0.0, 0.6),
              "rolling_friction": (0.0, 0.3), "damping": (0.05, 0.3)}
    planes = pd.DataFrame([
        {"response": "c_kpa", "intercept": 0.0, "bond_kpa": 0.2, "friction_deg": 0.0, "pressed_adhesion": 0.0,
         "rolling_friction": 0.0, "resid_sd": 1.875},
        {"response": "phi_deg", "intercept": 10.0, "bond_kpa": 0.0, "friction_deg": 1.0, "pressed_adhesion": 0.0,
         "rolling_friction": 0.0, "resid_sd": 1.0},
        {"response": "collapse_deg", "intercept": 30.0, "bond_kpa": 0.0, "friction_deg": 0.0,
         "pressed_adhesion": 10.0, "rolling_friction": 0.0, "resid_sd": 1.0}])
    targets = pd.DataFrame({"lo": [10.0, 24.0, 30.0], "hi": [25.0, 32.0, 38.0]}, index=["c_kpa", "phi_deg", "collapse_deg"])
    d = bench.deepest_point(planes, targets, bounds)
    assert d["normal_cohesion"] == pytest.approx(87_500, rel=1e-6) and d["friction_deg"] == pytest.approx(18.0)
    assert d["c_kpa"] == pytest.approx(17.5) and d["phi_deg"] == pytest.approx(28.0)
    assert d["margin_sd"] == pytest.approx(4.0) and d["pressed_adhesion"] == pytest.approx(0.4)
    assert "new_contact_cohesion" not in d           # fixed, not calibrated
    with_share = {**{k: v for k, v in bounds.items() if k != "pressed_adhesion"}, "new_contact_cohesion": (0.0, 0.01)}
    share = bench.deepest_point(planes.rename(columns={"pressed_adhesion": "disturbed_bond_kpa"}), targets, with_share)
    assert share["new_contact_cohesion"] == pytest.approx(0.4 / 87.5)   # a prior with the share: its bond a term
    assert d["collapse_deg"] == pytest.approx(34.0)
    pd.DataFrame([{"soil": "loam", **d}]).to_csv(tmp_path / "deepest.csv", index=False)
    cfg = {**bench.load_config(soil="loam"), "cone_target": False}
    seen = []

    def made_up(soil, seed, params, c, out_dir):
        seen.append(seed)
        assert params["normal_cohesion"] == pytest.approx(d["normal_cohesion"])
        return {"id": f"s{seed}", "seed": seed, **params, "c_kpa": 17.0 + seed, "phi_deg": 28.0, "collapse_deg": 34.0}
    monkeypatch.setattr(bench, "evaluate", made_up)
    monkeypatch.setattr(bench, "cone_check", lambda *a, **k: {"mean": 450.0})
    out = bench.check_deepest("loam", cfg, tmp_path)
    assert sorted(seen) == sorted(cfg["check_seeds"]) and out["c_kpa"]["every_packing_inside"]
    assert (tmp_path / "loam-deepest-check.csv").exists() and not (tmp_path / "loam-check.csv").exists()
    with pytest.raises(ConfigError, match="no deepest point of sand"):
        bench.check_deepest("sand", cfg, tmp_path)


def test_the_packings_check_runs_no_cone_and_tells_the_mean_by_its_interval(tmp_path, monkeypatch):
    post = {"normal_cohesion": 1.0e5, "friction_deg": 20.0, "pressed_adhesion": 0.05, "rolling_friction": 0.05,
            "damping": 0.15}
    (tmp_path / "sand-posterior.json").write_text(json.dumps({"mean": post}))
    cfg = bench.load_config(soil="sand")
    pd.DataFrame([{"soil": "sand", **{k: v for k, v in post.items() if k != "damping"}}]).to_csv(
        tmp_path / "deepest.csv", index=False)
    with pytest.raises(ConfigError, match="lacks damping"):    # planes drawn over a prior without it
        bench.check_packings("sand", [1, 2, 3], cfg, tmp_path, which="deepest")
    seen = []

    def made_up(soil, seed, params, c, out_dir):      # c straddles sand's 12 kPa edge, φ sits well inside 26-36°
        seen.append(seed)
        return {"id": f"s{seed}", "seed": seed, **params, "c_kpa": 12.0 + (-1) ** seed * seed, "phi_deg": 31.0 + 0.1 * seed,
                "collapse_deg": 45.0 + seed}
    monkeypatch.setattr(bench, "evaluate", made_up)
    monkeypatch.setattr(bench, "cone_check", lambda *a, **k: pytest.fail("the packings check runs no cone"))
    monkeypatch.setattr(bench, "cone_columns", lambda *a, **k: pytest.fail("the packings check runs no cone"))
    out = bench.check_packings("sand", [1, 2, 3, 4, 5, 6], cfg, tmp_path)
    assert sorted(seen) == [1, 2, 3, 4, 5, 6] and "cone_kpa" not in out
    assert out["c_kpa"]["mean_verdict"] == "undecided" and not out["c_kpa"]["every_packing_inside"]
    assert out["phi_deg"]["mean_verdict"] == "inside" and out["collapse_deg"]["mean_verdict"] == "outside"
    lo, hi = out["phi_deg"]["mean_interval"]
    assert lo < out["phi_deg"]["mean"] < hi
    assert (tmp_path / "sand-check-packings.csv").exists() and not (tmp_path / "sand-check.csv").exists()
    with pytest.raises(ConfigError, match="three packings or more"):
        bench.check_packings("sand", [1, 2], cfg, tmp_path)
    with pytest.raises(ConfigError, match="allowed posterior or deepest"):
        bench.check_packings("sand", [1, 2, 3], cfg, tmp_path, which="deep")
    pd.DataFrame([{"soil": "sand", **{**post, "normal_cohesion": 1.6e5}}]).to_csv(tmp_path / "deepest.csv", index=False)
    seen.clear()
    bench.check_packings("sand", [4, 5, 6], cfg, tmp_path, which="deepest")
    assert sorted(seen) == [4, 5, 6] and (tmp_path / "sand-deepest-check-packings.csv").exists()
    moved = {**post, "normal_cohesion": 1.7e5}             # the planes took the check in and moved their deepest set
    pd.DataFrame([{"soil": "sand", **moved}]).to_csv(tmp_path / "deepest.csv", index=False)
    monkeypatch.setattr(bench, "evaluate", lambda soil, seed, params, c, out_dir: {
        "id": f"s{seed}-{params['normal_cohesion']:.0f}", "seed": seed, **params, "c_kpa": 8.0 + seed, "phi_deg": 31.0,
        "collapse_deg": 34.0})
    out = bench.check_packings("sand", [4, 5, 6], cfg, tmp_path, which="deepest")
    kept = pd.read_csv(tmp_path / "sand-deepest-check-packings.csv")
    assert len(kept) == 6 and sorted(kept.normal_cohesion.unique()) == [1.6e5, 1.7e5]    # both sets' rows kept
    assert out["c_kpa"]["mean"] == pytest.approx(13.0)                                   # the verdict: this set's
    pd.DataFrame([{"id": "f1", "soil": "sand", **post, "c_kpa": 9.0}]).to_csv(tmp_path / "sand.csv", index=False)
    table, source = bench.soil_evaluations("sand", tmp_path)
    assert source == "sand.csv, sand-check-packings.csv, sand-deepest-check-packings.csv"
    assert table["id"].is_unique and (table["normal_cohesion"] == 1.7e5).sum() == 3     # the planes see the moved set


def test_the_planes_take_each_evaluation_once_with_its_three_packing_cone(tmp_path):
    """`soil_evaluations`: the filter's rows, then its checks' (CHECK_TABLES); an evaluation both the three-packing
    check and the check on more packings ran counts once, with the three-packing check's cone."""
    base = {"soil": "clay", "normal_cohesion": 1e5, "friction_deg": 10.0, "c_kpa": 20.0, "phi_deg": 28.0,
            "collapse_deg": 34.0}
    pd.DataFrame([{**base, "id": "f1", "cone_kpa": 440.0}]).to_csv(tmp_path / "clay.csv", index=False)
    pd.DataFrame([{**base, "id": f"s{i}", "cone_kpa": 450.0} for i in (1, 2, 3)]).to_csv(tmp_path / "clay-check.csv",
                                                                                      index=False)
    pd.DataFrame([{**base, "id": f"s{i}"} for i in range(1, 10)]).to_csv(tmp_path / "clay-check-packings.csv", index=False)
    table, source = bench.soil_evaluations("clay", tmp_path)
    assert source == "clay.csv, clay-check.csv, clay-check-packings.csv"
    assert len(table) == 10 and table["cone_kpa"].notna().sum() == 4
    assert bench.soil_evaluations("sand", tmp_path) is None
    for i, size in ((1, [0.15, 0.15, 0.1]), (2, [0.225, 0.225, 0.15])):       # packing 2's box another size
        (tmp_path / "clay" / f"s{i}").mkdir(parents=True)
        (tmp_path / "clay" / f"s{i}" / "box.json").write_text(json.dumps({"tests": [{"size_m": size}]}))
    table, _ = bench.soil_evaluations("clay", tmp_path, [150, 150, 100])
    assert len(table) == 9 and "s2" not in set(table["id"]) and bench.evaluation_box(tmp_path / "clay" / "s2") == [225, 225, 150]
    (tmp_path / "filter-box").mkdir()
    pd.DataFrame([{**base, "id": "s10"}]).to_csv(tmp_path / "filter-box" / "clay-check.csv", index=False)
    table, source = bench.soil_evaluations("clay", tmp_path, [150, 150, 100])
    assert source.endswith("filter-box/clay-check.csv") and "s10" in set(table["id"])


def test_a_probe_runs_chosen_sets_with_their_cone_and_refuses_a_partial_set(tmp_path, monkeypatch, capsys):
    """`calibrate --bench --probe`: each chosen set's bench responses and cone on the calibration packing (or on
    each of --seeds) in <soil>-probes.csv, earlier probes kept and none rerun; a set may name a shear bond of its
    own, which the scenes get; a set naming fewer than the calibrated parameters, or a value out of its range, is
    refused with exit 2 before any scene."""
    from analysis.cli import main
    ran = []

    def fake(soil, seed, params, cfg, out_dir):
        ran.append(params["normal_cohesion"])
        return {"id": f"s{seed}-{len(ran):010x}", "soil": soil, "seed": seed, **params, **made_up_bench(params),
                "tau_peak_kpa": [], "wall_s": 0.0}
    monkeypatch.setattr(bench, "evaluate", fake)
    monkeypatch.setattr(bench, "cone_scene",
                        lambda args, log: {"cone_index_pa": 2e3 * float(args[args.index("--cohesion") + 1]) / 1e3})
    cfg = bench.load_config(soil="loam")
    sets = [{"normal_cohesion": b, "friction_deg": 16.0, "pressed_adhesion": 0.2, "rolling_friction": 0.2,
             "damping": 0.15} for b in (1.2e5, 0.8e5)]
    bench.probes("loam", sets[:1], cfg, tmp_path)
    table = bench.probes("loam", sets[1:], cfg, tmp_path)
    saved = pd.read_csv(tmp_path / "loam-probes.csv", comment="#")
    assert ran == [1.2e5, 0.8e5] and len(table) == 2 and len(saved) == 2
    assert saved.cone_kpa.to_numpy() == pytest.approx([240.0, 160.0], rel=1e-3)
    assert set(bench.RESPONSES) <= set(saved.columns)
    own_shear = bench.probes("loam", [{**sets[0], "shear_cohesion": 2.4e5}], cfg, tmp_path)
    assert len(own_shear) == 3 and own_shear.shear_cohesion.iloc[-1] == 2.4e5 and own_shear.shear_cohesion.iloc[:2].isna().all()
    assert "shear_cohesion=240000.0" in bench.overrides({**sets[0], "shear_cohesion": 2.4e5})
    on_packings = bench.probes("loam", sets[1:], cfg, tmp_path, seeds=[2, 3])
    assert list(on_packings.seed.iloc[-2:]) == [2, 3] and len(on_packings) == 5
    with pytest.raises(ConfigError, match="allowed every calibrated parameter"):
        bench.probes("loam", [{"normal_cohesion": 1e5}], cfg, tmp_path)
    assert main(["calibrate", "--soil", "loam", "--bench", "--probe", "normal_cohesion=1e5"]) == 2
    assert "allowed every calibrated parameter" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        main(["calibrate", "--soil", "loam", "--bench", "--probe", "friction_deg=75"])
    assert stop.value.code == 2 and "friction_deg" in capsys.readouterr().err
    assert main(["calibrate", "--soil", "loam", "--probe", "friction_deg=20"]) == 2
    assert "--probe: allowed only with --bench" in capsys.readouterr().err
    assert ran == [1.2e5, 0.8e5, 1.2e5, 0.8e5, 0.8e5]


def test_a_soils_own_bench_settings_replace_the_common_ones_and_bad_ones_are_refused(tmp_path):
    """[soil_bench.<soil>] replaces [bench] keys for that soil only; an unknown soil, a key [bench] lacks or fewer
    than three distinct positive normal stresses is refused naming the field."""
    common, sand = bench.load_config(), bench.load_config(soil="sand")
    assert len(sand["stresses_kpa"]) > len(common["stresses_kpa"]) >= 3
    assert bench.load_config(soil="clay")["stresses_kpa"] == common["stresses_kpa"]
    params = {"normal_cohesion": 5e4, "friction_deg": 20.0, "new_contact_cohesion": 0.01, "rolling_friction": 0.05}
    assert bench.evaluation_id("sand", 1, params, sand) != bench.evaluation_id("sand", 1, params, common)
    text = bench.CONFIG.read_text()
    for extra, match in [("[soil_bench.peat]\nstresses_kpa = [25, 50, 100]", "soil_bench.peat"),
                         ("[soil_bench.sand]\ncolour = 1", "soil_bench.sand.colour"),
                         ("[soil_bench.sand]\nstresses_kpa = [50, 100]", "stresses_kpa"),
                         ("[soil_bench.sand]\nstresses_kpa = [0, 50, 100]", "stresses_kpa"),
                         ("[soil_bench.sand]\nstresses_kpa = [50, 50, 100]", "stresses_kpa")]:
        (tmp_path / "b.toml").write_text(text[:text.index("[soil_bench")] + extra + "\n")
        with pytest.raises(ConfigError, match=re.escape(match)):
            bench.load_config(tmp_path / "b.toml", soil="sand")


def test_a_soils_own_cone_settings_replace_the_common_ones_and_name_its_cones_apart(tmp_path):
    """[soil_cone_check.<soil>] replaces [cone_check] keys for that soil only, so its cones are other cones (their
    cache key holds the settings); an unknown soil or a key [cone_check] lacks is refused naming the field."""
    cfg = bench.CONFIG.read_text().split("[soil_bounds")[0]      # the common settings, no soil's own
    own = '\n[soil_cone_check.sand]\nresolution = "medium"\n'
    (tmp_path / "b.toml").write_text(cfg + own)
    sand, clay = (bench.load_config(tmp_path / "b.toml", soil=s) for s in ("sand", "clay"))
    assert sand["cone_check"]["resolution"] == "medium" != clay["cone_check"]["resolution"]
    assert {k: v for k, v in sand["cone_check"].items() if k != "resolution"} == \
        {k: v for k, v in clay["cone_check"].items() if k != "resolution"}
    assert bench.load_config(tmp_path / "b.toml")["cone_check"] == clay["cone_check"]
    for extra, match in [('\n[soil_cone_check.peat]\nresolution = "medium"\n', "soil_cone_check.peat"),
                         ("\n[soil_cone_check.sand]\ncolour = 1\n", "soil_cone_check.sand.colour")]:
        (tmp_path / "b.toml").write_text(cfg + extra)
        with pytest.raises(ConfigError, match=re.escape(match)):
            bench.load_config(tmp_path / "b.toml", soil="sand")


def test_a_cone_transfer_scales_the_reading_the_filter_takes_and_reuses_the_same_cone(tmp_path, monkeypatch):
    """[cone_check] transfer: the filter's cone index is the cone's reading times the ratio, from the same cone (one
    run, its summary reused); the cone transfer measures the readings themselves; a ratio out of 0.5-1.5 is refused."""
    ran = []

    def fake_cone(args, log_path):                  # 500 kPa at r = 8 mm, 420 at the runs' grains
        ran.append(args[args.index("--resolution") + 1])
        return {"cone_index_pa": 5.0e5 if ran[-1] == "coarse" else 4.2e5}
    monkeypatch.setattr(bench, "cone_scene", fake_cone)
    cfg = bench.load_config(soil="sand")
    params = {"normal_cohesion": 1.0e5, "friction_deg": 17.0}
    plain = bench.cone_check("sand", params, {**cfg, "cone_check": {**cfg["cone_check"], "transfer": 1.0}}, tmp_path)
    scaled = bench.cone_check("sand", params, {**cfg, "cone_check": {**cfg["cone_check"], "transfer": 0.84}}, tmp_path)
    assert ran == ["coarse"] and plain["mean"] == pytest.approx(500) and scaled["raw"] == pytest.approx(500)
    assert scaled["mean"] == pytest.approx(420) and not plain["mean_inside"] and scaled["mean_inside"]
    (tmp_path / "sand-posterior.json").write_text(json.dumps({"mean": params}))
    table = bench.cone_transfer("sand", [1], {**cfg, "cone_check": {**cfg["cone_check"], "transfer": 0.84}}, tmp_path, 1)
    assert table.loc[0, "cone_filter_kpa"] == pytest.approx(500) and table.loc[0, "ratio"] == pytest.approx(0.84)
    text = bench.CONFIG.read_text().replace("transfer = 0.84", "transfer = 2.0")
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match=re.escape("cone_check.transfer = 2.0: allowed 0.5-1.5")):
        bench.load_config(tmp_path / "b.toml", soil="sand")


def test_with_the_cone_as_a_fourth_target_every_evaluation_and_check_packing_has_its_own_cone(tmp_path, monkeypatch):
    """`cone_target`: the filter reads the cone index beside the bench's three responses, each evaluation's cone on
    the cone's bed of the evaluation's own packing; the table of the finished iterations is kept while it runs;
    the check runs a cone on every check packing, at the bench's grains whatever the filter's cone took, and judges
    it against Table 2 ± the tolerance like the bench responses; the posterior names the cone among its targets."""
    def fake(soil, seed, params, cfg, out_dir):
        return {"soil": soil, "seed": seed, **params, **made_up_bench(params), "tau_peak_kpa": [], "wall_s": 0.0}
    monkeypatch.setattr(bench, "evaluate", fake)
    cones, grains = [], []

    def fake_cone(args, log_path):                    # a cone that reads 2 kPa per kPa of bond plus 5 kPa per packing
        cones.append(int(args[args.index("--seed") + 1]))
        grains.append(args[args.index("--resolution") + 1])
        return {"cone_index_pa": 1e3 * (2 * float(args[args.index("--cohesion") + 1]) / 1e3 + 5 * cones[-1])}
    monkeypatch.setattr(bench, "cone_scene", fake_cone)
    cfg = {**bench.load_config(soil="clay"), "samples": 8, "iterations": 2, "workers": 2}
    assert cfg["cone_target"] and bench.target_ranges("clay", cfg)["cone_kpa"] == pytest.approx((382.5, 517.5))
    seen = []
    real_csv = bench.atomic_csv
    monkeypatch.setattr(bench, "atomic_csv", lambda t, path, *a: (seen.append((path.name, len(t))), real_csv(t, path, *a)))
    post = bench.calibrate("clay", cfg, tmp_path)
    assert seen[:2] == [("clay-running.csv", 8), ("clay-running.csv", 16)] and not (tmp_path / "clay-running.csv").exists()
    table = pd.read_csv(tmp_path / "clay.csv", comment="#")
    assert len(table) == 16 and table["cone_kpa"].notna().all()
    assert table["cone_reading_kpa"].equals(table["cone_kpa"])        # clay takes its cone's reading as it is
    assert table["cone_kpa"].to_numpy() == pytest.approx(2 * table["normal_cohesion"].round(-1) / 1e3 + 5, abs=0.5)
    assert set(cones) == {cfg["calibration_seed"]} and "cone_kpa" in post["targets"]
    result = bench.check("clay", post, cfg, tmp_path)
    assert sorted(cones[16:]) == sorted(cfg["check_seeds"])
    assert set(grains[:16]) == {cfg["cone_check"]["resolution"]} and set(grains[16:]) == {cfg["resolution"]} \
        and cfg["resolution"] != cfg["cone_check"]["resolution"]
    assert result["cone_kpa"]["sd"] > 0 and result["cone_kpa"]["target"] == pytest.approx([382.5, 517.5])
    assert "cone_kpa" in pd.read_csv(tmp_path / "clay-check.csv", comment="#")
    assert [p.name for p in bench.report(tmp_path)][:2] == ["posterior.png", "responses.png"]
    planes = pd.read_csv(tmp_path / "surfaces.csv", comment="#").set_index("response")
    assert planes.loc["cone_kpa", "bond_kpa"] == pytest.approx(2.0, abs=0.1)        # the made-up cone's 2 kPa per kPa
    text = bench.CONFIG.read_text()
    for old, new, match in [("cone_target = true", "cone_target = 1", "cone_target"),
                            ("[cone_check]", "[cone_elsewhere]", "cone_target = true without a [cone_check]")]:
        (tmp_path / "b.toml").write_text(text.replace(old, new).replace("[soil_cone_check.", "[soil_cone_elsewhere."))
        with pytest.raises(ConfigError, match=re.escape(match)):
            bench.load_config(tmp_path / "b.toml", soil="clay")


def test_the_collapse_column_takes_its_own_size_and_names_the_evaluation_only_when_set(tmp_path, monkeypatch):
    """[bench] collapse_size_mm sizes the collapse column apart from the shear box; left out, the column is the box
    and the evaluations keep their ids; a bad size is refused."""
    cfg = {k: v for k, v in bench.load_config().items() if k != "collapse_size_mm"}
    params = {"normal_cohesion": 30e3, "friction_deg": 25.0, "new_contact_cohesion": 0.5, "rolling_friction": 0.1}
    tall = {**cfg, "collapse_size_mm": [225, 225, 150]}
    assert bench.evaluation_id("clay", 1, params, {**cfg, "collapse_size_mm": list(cfg["size_mm"])}) == \
        bench.evaluation_id("clay", 1, params, cfg) != bench.evaluation_id("clay", 1, params, tall)
    sizes = {}

    def fake(cmd, sink):
        scene = Path(cmd[1]).stem
        sizes[scene] = cmd[cmd.index("--size") + 1]
        out = {"shear": {"c_kpa": 1.0, "phi_deg": 30.0}, "collapse": {"runout_mm": 100.0}}[scene]
        folder = Path(cmd[cmd.index("--out") + 1])
        if scene == "collapse":
            heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]
            (folder / "column.json").write_text(json.dumps({"profile_mm": heap}))
        else:
            (folder / "box.json").write_text(json.dumps(shear_box(1.0, 30.0)))
        return 0, json.dumps(out)
    monkeypatch.setattr(runner, "run_process", fake)
    row = bench.evaluate("clay", 1, params, tall, tmp_path)
    assert sizes == {"shear": "150,150,100", "collapse": "225,225,150"} and row["collapse_deg"] == pytest.approx(45, abs=1)
    text = bench.CONFIG.read_text().replace("collapse_size_mm = [225, 225, 150]", "collapse_size_mm = [225, 0, 150]", 1)
    assert "[225, 0, 150]" in text
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="collapse_size_mm"):
        bench.load_config(tmp_path / "b.toml")


def test_the_checks_read_their_own_box_and_take_a_scene_a_twin_already_ran(tmp_path, monkeypatch):
    """A check runs the shear box in [bench] check_box_mm; the collapse column it shares with the filter's box is
    copied from that evaluation of the same set and packing, not run again; a twin whose scene had other inputs (the
    size check's grown column) gives nothing; a bad check box is refused."""
    cfg = bench.load_config(soil="clay")
    params = {"normal_cohesion": 9e4, "friction_deg": 9.0, "pressed_adhesion": 0.1, "rolling_friction": 0.3,
              "damping": 0.1}
    checks = bench.checks_bench(cfg)
    assert checks["size_mm"] == cfg["check_box_mm"] != cfg["size_mm"]
    assert checks["collapse_size_mm"] == bench.collapse_size(cfg)
    heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]       # 45° from x = 100 mm
    filter_box = tmp_path / "clay" / bench.evaluation_id("clay", 1, params, cfg)
    filter_box.mkdir(parents=True)
    (filter_box / "column.json").write_text(json.dumps({"profile_mm": heap, "runout_mm": 90.0}))
    (filter_box / "box.json").write_text(json.dumps(shear_box(30.0, 25.0)))
    ran = []

    def fake(cmd, sink):
        ran.append((Path(cmd[1]).stem, cmd[cmd.index("--size") + 1]))
        box = shear_box(22.0, 28.0, size=0.225)
        (Path(cmd[cmd.index("--out") + 1]) / "box.json").write_text(json.dumps(box))
        return 0, json.dumps({k: box[k] for k in ("c_kpa", "phi_deg")})
    monkeypatch.setattr(runner, "run_process", fake)
    row = bench.evaluate("clay", 1, params, checks, tmp_path)
    assert ran == [("shear", ",".join(map(str, cfg["check_box_mm"])))]
    assert (row["c_kpa"], row["resumed"]) == (pytest.approx(22.0), "collapse (a twin's)")
    assert row["collapse_deg"] == pytest.approx(45.0, abs=1.0) and row["collapse_runout_mm"] == 90.0
    grown = bench.grown_bench(cfg)
    assert bench.scene_inputs("collapse", grown) != bench.scene_inputs("collapse", checks)
    assert bench.scene_inputs("shear", grown) == bench.scene_inputs("shear", checks)
    text = bench.CONFIG.read_text().replace("check_box_mm = [225, 225, 150]", "check_box_mm = [225, -1, 150]", 1)
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="check_box_mm"):
        bench.load_config(tmp_path / "b.toml")


def snippet(code: str, *args: str):
    """Run a YADE snippet (`code`, with `args` as its sys.argv) in its own process from the project's root; its last
    stdout line as JSON, or an AssertionError with its stderr's tail."""
    import os
    import subprocess
    import sys
    r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=bench.ROOT,
                       env={**os.environ, "PYTHONPATH": str(bench.ROOT)}, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


REBOUND = """
import json, sys
from scripts.yadeboot import boot
boot(1)
from yade import O, utils
from analysis.core.soil_config import load_soil
from scripts import soil as part
out = {}
for damping in map(float, sys.argv[1:]):
    O.reset()
    mat = O.materials.append(part.soil_material(load_soil("sand"), density=2650.0, cohesive=False))
    grain = O.bodies.append(utils.sphere((0, 0, 0.0061), 0.006, material=mat))
    O.bodies.append(utils.box((0, 0, -0.01), (0.05, 0.05, 0.01), fixed=True, material=mat))
    O.bodies[grain].state.vel = (0, 0, -0.5)
    O.engines = part.engines(damping, cohesion_on_new_contacts=False, gravity=(0, 0, 0))
    O.dt = 0.2 * utils.PWaveTimeStep()
    O.run(20000, True)
    out[damping] = O.bodies[grain].state.vel[2] / 0.5
print(json.dumps(out))
"""


@pytest.mark.scene
def test_the_local_damping_gives_one_grain_striking_a_wall_a_restitution_below_one():
    """The contact law alone is elastic in compression: a grain striking a wall without the local damping comes back
    at its own speed; with a local damping λ at √((1 − λ)/(1 + λ)) of it (the README's reading of the damping)."""
    restitution = {float(k): v for k, v in snippet(REBOUND, "0", "0.1", "0.2", "0.3").items()}
    for lam, e in restitution.items():
        assert e == pytest.approx(math.sqrt((1 - lam) / (1 + lam)), abs=0.01), (lam, e)


PRESSED = """
import json, sys
from scripts.yadeboot import boot
boot(1)
from yade import O, utils
from analysis.core.soil_config import load_soil, soil_with
from scripts import soil as part
alpha, press, pull, onset, share = map(float, sys.argv[1:6])
soil = soil_with(load_soil("clay"), {"normal_cohesion": 176e3, "shear_cohesion": 176e3, "bond_fragile": 0,
                                     "new_contact_cohesion": 0.0, "pressed_adhesion": alpha, "adhesion_onset": onset,
                                     "adhesion_share": share})
mat = O.materials.append(part.soil_material(soil, density=2650.0))
O.materials[mat].normalCohesion = O.materials[mat].shearCohesion = 0.0    # a new contact: no bond of its own
fixed_one = O.materials.append(part.steel_material(soil)) if len(sys.argv) > 6 else mat   # a tool's steel sphere
a = O.bodies.append(utils.sphere((0, 0, 0), 0.006, material=fixed_one, fixed=True))
b = O.bodies.append(utils.sphere((0, 0, 0.011999), 0.006, material=mat))    # touching: 1 µm
O.engines = part.engines(0.3, cohesion_on_new_contacts=True, gravity=(0, 0, 0), extra=part.bond_rules(O, soil))
O.dt = 0.2 * utils.PWaveTimeStep()
for k in range(1, 41):                                  # pressed slowly: no overshoot past the press
    O.forces.setPermF(b, (0, 0, -press * k / 40))
    O.run(200, True)
O.run(2000, True)
bond = O.interactions[a, b].phys.normalAdhesion
for k in range(1, 41):                                  # and pulled slowly
    O.forces.setPermF(b, (0, 0, -press + (press + pull) * k / 40))
    O.run(200, True)
O.run(2000, True)
print(json.dumps({"bond": bond, "apart": O.bodies[b].state.pos[2] > 0.0125}))
"""


@pytest.mark.scene
@pytest.mark.parametrize("alpha, pull, apart", [(0.0, 0.5, True), (0.5, 0.8, False), (0.5, 1.3, True),
                                                (5.0, 6.0, False), (5.0, 7.0, True)])
def test_grains_pressed_together_re_adhere_by_the_force_that_pressed_them_up_to_the_intact_bond(alpha, pull, apart):
    """Two grains whose new contact gets no bond, pressed together by 2 N, then pulled by `pull`: with pressed
    re-adhesion α they hold up to α × 2 N, and never past the intact bond (176 kPa × r² = 6.3 N); without it they
    part at once."""
    out = snippet(PRESSED, str(alpha), "2.0", str(pull), "0", "0")
    assert out["bond"] == pytest.approx(min(alpha * 2.0, 176e3 * 0.006 ** 2), rel=0.02)
    assert out["apart"] is apart


@pytest.mark.scene
@pytest.mark.parametrize("onset, bond", [(30e3, 1.0), (80e3, 0.0)])
def test_a_contact_re_adheres_only_once_pressed_past_the_onset(onset, bond):
    """`adhesion_onset`: two grains pressed together by 2 N at α 0.5 re-adhere by α × 2 N = 1 N where the onset's
    force (onset × r², r = 6 mm) is under the press (30 kPa: 1.08 N), not at all where it is over (80 kPa: 2.88 N),
    and then a pull of 0.5 N parts them."""
    out = snippet(PRESSED, "0.5", "2.0", "0.5", str(onset), "0")
    assert out["bond"] == pytest.approx(bond, rel=0.02, abs=1e-9) and out["apart"] is (bond == 0.0)


@pytest.mark.scene
@pytest.mark.parametrize("press, pull, bond, apart", [(2.0, 2.8, 3.17, False), (2.0, 3.6, 3.17, True),
                                                      (4.0, 2.8, 3.17, False), (0.5, 0.1, 0.0, True)])
def test_a_contact_held_past_the_onset_re_adheres_at_the_share_of_the_intact_bond_whatever_its_press(press, pull,
                                                                                                     bond, apart):
    """`adhesion_share`: two grains pressed together past the onset (30 kPa × r² = 1.08 N) re-adhere at half the
    intact bond (0.5 × 176 kPa × r² = 3.17 N) whether pressed by 2 N or 4 N, hold a pull under it and part over it;
    pressed by 0.5 N, under the onset, they do not re-adhere."""
    out = snippet(PRESSED, "0", str(press), str(pull), "30e3", "0.5")
    assert out["bond"] == pytest.approx(bond, rel=0.02, abs=1e-9) and out["apart"] is apart


TOOL = """
import json, math, sys
from scripts.yadeboot import boot
boot(1)
from yade import O, utils
from analysis.core.soil_config import load_soil, soil_with
from scripts import soil as part
soil = soil_with(load_soil("clay"), {"friction_deg": 5.0, "tool_friction_deg": float(sys.argv[1])})
grain = O.materials.append(part.soil_material(soil, density=2650.0))
steel = O.materials.append(part.steel_material(soil))
a = O.bodies.append(utils.sphere((0, 0, 0), 0.006, material=steel, fixed=True))
b = O.bodies.append(utils.sphere((0, 0, 0.0119), 0.006, material=grain))
c = O.bodies.append(utils.sphere((0, 0, 0.0238), 0.006, material=grain))
O.engines = part.engines(0.3, cohesion_on_new_contacts=False, gravity=(0, 0, 0))
part.hold_tool_friction(O, soil)
O.dt = 1e-6
O.step()
angle = lambda i, j: math.degrees(math.atan(O.interactions[i, j].phys.tangensOfFrictionAngle))
print(json.dumps({"tool": angle(a, b), "grains": angle(b, c)}))
"""


@pytest.mark.scene
@pytest.mark.parametrize("tool_friction, on_steel", [(0.0, 5.0), (25.0, 25.0)])
def test_a_grain_on_a_tool_slides_at_the_soils_tool_friction_or_else_at_the_lesser_angle(tool_friction, on_steel):
    """Grains of 5° friction, one touching a steel sphere (a tool): without a tool friction the grain-steel contact
    takes the lesser angle, the grain's 5° (YADE's Ip2), not the steel's 25°; with `tool_friction_deg` 25 it takes
    25°, and the grains' contact keeps its 5°."""
    out = snippet(TOOL, str(tool_friction))
    assert out["tool"] == pytest.approx(on_steel, abs=1e-6) and out["grains"] == pytest.approx(5.0, abs=1e-6)


STRUCK = """
import json, sys
from scripts.yadeboot import boot
boot(1)
from yade import O, utils
from analysis.core.soil_config import load_soil, soil_with
from scripts import soil as part
onset, speed = map(float, sys.argv[1:3])
soil = soil_with(load_soil("clay"), {"normal_cohesion": 176e3, "shear_cohesion": 176e3, "bond_fragile": 0,
                                     "new_contact_cohesion": 0.0, "pressed_adhesion": 0.5, "adhesion_onset": onset})
mat = O.materials.append(part.soil_material(soil, density=2650.0))
O.materials[mat].normalCohesion = O.materials[mat].shearCohesion = 0.0
a = O.bodies.append(utils.sphere((0, 0, 0), 0.006, material=mat, fixed=True))
b = O.bodies.append(utils.sphere((0, 0, 0.0125), 0.006, material=mat))
O.bodies[b].state.vel = (0, 0, -speed)
O.engines = part.engines(0.0, cohesion_on_new_contacts=True, gravity=(0, 0, 0), extra=part.bond_rules(O, soil))
O.dt = 0.5 * utils.PWaveTimeStep()                      # the scenes' step
peak, bond = 0.0, 0.0
for _ in range(4000):
    O.step()
    if O.interactions.has(a, b) and O.interactions[a, b].isReal:
        peak = max(peak, O.interactions[a, b].phys.normalForce.norm())
        bond = max(bond, O.interactions[a, b].phys.normalAdhesion)
print(json.dumps({"peak": peak, "bond": bond}))
"""


@pytest.mark.scene
@pytest.mark.parametrize("onset, bonded", [(0.0, True), (30e3, False)])
def test_a_grain_striking_another_re_adheres_without_an_onset_and_not_past_one(onset, bonded):
    """A grain striking a fixed one at 0.5 m/s presses it far past the onset's force (30 kPa × r² = 1.08 N) for less
    than the bond rules' two passes: at α 0.5 with no onset the strike bonds them (α × the force at the pass); with
    the onset it leaves no bond."""
    out = snippet(STRUCK, str(onset), "0.5")
    assert out["peak"] > 3 * 30e3 * 0.006 ** 2, out
    assert (out["bond"] > 0) is bonded, out


@pytest.mark.scene
def test_a_tools_steel_sphere_pressed_into_a_grain_never_re_adheres():
    """A punch's or cone's tip is a steel sphere: pressed into a grain by 2 N at α 0.5, the contact gets no bond,
    and the least pull parts them."""
    out = snippet(PRESSED, "0.5", "2.0", "0.05", "0", "0", "steel")
    assert out["bond"] == 0.0 and out["apart"] is True


def test_the_cone_screen_runs_no_cone_where_the_bench_already_misses_and_takes_weight_from_no_sample(tmp_path,
                                                                                                       monkeypatch):
    """`cone_screen_sd`: an evaluation whose shear box or collapse test reads a response more than that many packing
    SDs outside its range gets no cone (NaN in the table, `cone_screened`); the filter weighs its cone as met, so
    with a cone that reads inside everywhere the posterior is the one every cone would give; 0 runs every cone; the
    check never screens."""
    def fake(soil, seed, params, cfg, out_dir):
        return {"soil": soil, "seed": seed, **params, **made_up_bench(params), "tau_peak_kpa": [], "wall_s": 0.0}
    monkeypatch.setattr(bench, "evaluate", fake)
    coned = []
    cfg = {**bench.load_config(soil="loam"), "samples": 10, "iterations": 2, "workers": 1}

    def met(soil, params, cfg, out_dir, seed=None):                 # the cone's range's middle: met everywhere
        coned.append(params["normal_cohesion"])
        return {"mean": sum(bench.cone_range("loam", cfg)) / 2, "raw": sum(bench.cone_range("loam", cfg)) / 2}
    monkeypatch.setattr(bench, "cone_check", met)
    assert cfg["cone_screen_sd"] == 3 and bench.load_config(soil="clay")["cone_screen_sd"] == 0
    posts = {}
    for k in (3, 0):
        coned.clear()
        posts[k] = bench.calibrate("loam", {**cfg, "cone_screen_sd": k}, tmp_path / str(k))
        table = pd.read_csv(tmp_path / str(k) / "loam.csv", comment="#")
        ranges, scatter = bench.target_ranges("loam", cfg), cfg["packing_scatter"]
        far = np.any([np.maximum(ranges[r][0] - table[r], table[r] - ranges[r][1]) > 3 * scatter[r]
                      for r in bench.RESPONSES], axis=0)
        if k:
            assert far.any() and (~far).any()                    # the made-up responses put some far out, some not
            assert table.loc[far, "cone_kpa"].isna().all() and table.loc[far, "cone_screened"].all()
            assert table.loc[~far, "cone_kpa"].notna().all() and len(coned) == (~far).sum()
        else:
            assert table["cone_kpa"].notna().all() and len(coned) == len(table)
    for name in posts[0]["mean"]:
        assert posts[3]["mean"][name] == pytest.approx(posts[0]["mean"][name])
    coned.clear()
    bench.check("loam", posts[3], {**cfg, "cone_screen_sd": 3, "check_seeds": [1, 2]}, tmp_path / "3")
    assert len(coned) == 2
    text = bench.CONFIG.read_text()
    for bad in ("-1", "11", "true", '"3"'):
        (tmp_path / "b.toml").write_text(text.replace("cone_screen_sd = 0 ", f"cone_screen_sd = {bad} ", 1))
        with pytest.raises(ConfigError, match="cone_screen_sd"):
            bench.load_config(tmp_path / "b.toml")


def test_a_shear_shift_makes_the_filter_aim_at_the_sized_cells_reading_and_keep_its_own(tmp_path, monkeypatch):
    """[bench] shear_shift: the filter weighs c and φ as its cell's reading plus the shift, so that over a made-up
    bench whose sized cell reads c 2 kPa higher and φ 1.5° lower its posterior is the one a filter shearing in the
    sized cell draws, not the unshifted one; its table keeps its own cell's readings and its posterior names the
    shift. A shift past its limits, or of another response, is refused."""
    shift = {"c_kpa": 2.0, "phi_deg": -1.5}

    def bench_reading(sized: bool):
        def fake(soil, seed, params, cfg, out_dir):
            read = made_up_bench(params)
            moved = {r: read[r] + v for r, v in shift.items()} if sized else {}
            return {"soil": soil, "seed": seed, **params, **read, **moved, "tau_peak_kpa": [], "wall_s": 0.0}
        return fake
    cfg = {**bench.load_config(), "samples": 8, "iterations": 2, "workers": 1}
    monkeypatch.setattr(bench, "evaluate", bench_reading(sized=True))
    sized = bench.calibrate("clay", cfg, tmp_path / "sized")
    monkeypatch.setattr(bench, "evaluate", bench_reading(sized=False))
    aimed = bench.calibrate("clay", {**cfg, "shear_shift": shift}, tmp_path / "aimed")
    plain = bench.calibrate("clay", cfg, tmp_path / "plain")
    assert all(aimed["mean"][n] == pytest.approx(sized["mean"][n]) for n in sized["mean"])
    assert not all(plain["mean"][n] == pytest.approx(sized["mean"][n]) for n in sized["mean"])
    table = pd.read_csv(tmp_path / "aimed" / "clay.csv", comment="#")
    read = pd.DataFrame([made_up_bench(row) for row in table.to_dict(orient="records")])
    assert np.allclose(table[["c_kpa", "phi_deg"]], read[["c_kpa", "phi_deg"]])
    assert json.loads((tmp_path / "aimed" / "clay-posterior.json").read_text())["shear_shift"] == shift
    assert "shear_shift" not in json.loads((tmp_path / "plain" / "clay-posterior.json").read_text())
    text = bench.CONFIG.read_text()
    for bad in ("{c_kpa = 25.0}", "{phi_deg = -11}", "{h1 = 1.0}", "{phi_deg = true}", "[1, 2]"):
        (tmp_path / "b.toml").write_text(text.replace("shear_shift = {} ", f"shear_shift = {bad} ", 1))
        with pytest.raises(ConfigError, match="bench.shear_shift"):
            bench.load_config(tmp_path / "b.toml")


def test_while_a_filter_runs_the_report_draws_its_planes_and_profiles_over_the_finished_iterations(tmp_path):
    """No soil's filter finished: `calibration-report` fits the planes over <soil>-running.csv and draws each
    parameter's margin profile; a parameter no made-up response feels profiles flat, a pinned one falls off."""
    rng = np.random.default_rng(3)
    cfg = bench.load_config(soil="clay")
    rows = [{k: rng.uniform(lo, hi) for k, (lo, hi) in cfg["bounds"].items()} for _ in range(30)]
    table = pd.DataFrame([{**p, **{r: v + rng.normal(0, 1) for r, v in made_up_bench(p).items()},   # a packing's
                           "cone_kpa": 3.0 * p["normal_cohesion"] / 1e3 + 100 + rng.normal(0, 20),   # scatter
                           "iteration": 1} for p in rows])
    table.to_csv(tmp_path / "clay-running.csv", index=False)
    names = [p.name for p in bench.report(tmp_path)]
    assert names == ["surfaces.csv", "feasible.csv", "deepest.csv", "profiles.csv", "profiles.png"]
    profile = pd.read_csv(tmp_path / "profiles.csv", comment="#")
    assert set(profile["parameter"]) == set(cfg["bounds"]) and "clay-running.csv" in \
        (tmp_path / "profiles.csv").read_text().splitlines()[0]
    spread = profile.groupby("parameter")["margin_sd"].agg(lambda m: m.max() - m.min())
    assert spread["damping"] < 0.2 * spread["normal_cohesion"]     # made_up_bench has no damping term


def test_a_running_filter_with_fewer_cones_than_plane_terms_still_gets_its_report(tmp_path):
    """The cone screened on all but five evaluations: its plane (six terms) has no scatter to count in, so
    surfaces.csv lists it without a residual SD and the feasible region, the deepest set and the profiles stand on
    the three bench responses."""
    rng = np.random.default_rng(4)
    cfg = bench.load_config(soil="sand")
    rows = [{k: rng.uniform(lo, hi) for k, (lo, hi) in cfg["bounds"].items()} for _ in range(12)]
    table = pd.DataFrame([{**p, **{r: v + rng.normal(0, 1) for r, v in made_up_bench(p).items()},
                           "cone_kpa": 3.0 * p["normal_cohesion"] / 1e3 + 100 if i < 5 else np.nan,
                           "iteration": 1} for i, p in enumerate(rows)])
    table.to_csv(tmp_path / "sand-running.csv", index=False)
    assert len(bench.report(tmp_path)) == 5
    planes = pd.read_csv(tmp_path / "surfaces.csv", comment="#").set_index("response")
    assert np.isnan(planes.loc["cone_kpa", "resid_sd"]) and planes.loc["cone_kpa", "n"] == 5
    deepest = pd.read_csv(tmp_path / "deepest.csv", comment="#")
    assert "cone_kpa" not in deepest and np.isfinite(deepest["margin_sd"]).all()


CHECKED_SET = {"normal_cohesion": 1.2e5, "friction_deg": 19.0, "pressed_adhesion": 0.06, "rolling_friction": 0.04,
               "damping": 0.14}      # a posterior mean the made-up checks ran


def checked_rows(root: Path, soil: str, name: str, box_mm, cs, phis=None, **params) -> pd.DataFrame:
    """A made-up check of CHECKED_SET (`params` over it) on packings 1, 2, …: per packing an evaluation folder
    root/<soil>/<name><seed> holding a `box_mm` shear box of c `cs[i]` and φ `phis[i]` (30° or 31° by packing when
    None) and a collapse heap, and the table's row (its c left 0: the reading comes from the folder)."""
    heap = {"profile_mm": [[x, max(0.0, min(100.0, 200.0 - x))] for x in range(0, 400, 2)]}
    out = []
    for seed, c in enumerate(cs, start=1):
        folder = root / soil / f"{name}{seed}"
        folder.mkdir(parents=True)
        box = shear_box(c, phis[seed - 1] if phis else 30.0 + seed % 2, size=box_mm[0] / 1000)
        for t in box["tests"]:
            t["size_m"] = [v / 1000 for v in box_mm]
        (folder / "box.json").write_text(json.dumps(box))
        (folder / "column.json").write_text(json.dumps(heap))
        out.append({"id": f"{name}{seed}", "soil": soil, "seed": seed, **{**CHECKED_SET, **params}, "c_kpa": 0.0})
    return pd.DataFrame(out)


def test_soils_apart_reads_a_response_as_telling_two_soils_apart_only_when_its_interval_leaves_zero_out(tmp_path):
    """Made-up checks over every packing of the checks' box, each soil's in its own folder: c differs by 12 kPa over a
    1 kPa scatter (apart), φ by 0.3° over 1° (not), the collapse heaps alike; in the grown box, two packings each, c
    alike (not apart); the cone over the check's packings; the parameter intervals are disjoint for the bond only;
    the soils' own targets decide `targets_apart`."""
    from analysis.soil import soils_apart
    rng = np.random.default_rng(5)
    cfg = bench.load_config()
    folders = {"clay": tmp_path, "loam": tmp_path / "variant"}
    for soil, c, phi, bond, cone in (("clay", 25, 28, 90e3, 450e3), ("loam", 13, 28.3, 150e3, 460e3)):
        folder = folders[soil]
        folder.mkdir(exist_ok=True)
        post = {**CHECKED_SET, "normal_cohesion": bond}
        interval = {n: [v * 0.9, v * 1.1] for n, v in post.items()} | {"normal_cohesion": [bond - 10e3, bond + 10e3]}
        (folder / f"{soil}-posterior.json").write_text(json.dumps({"mean": post, "interval": interval}))
        checks = checked_rows(folder, soil, "k", cfg["check_box_mm"], c + rng.normal(0, 1, 5),
                              list(phi + rng.normal(0, 1, 5)), normal_cohesion=bond)
        checks.to_csv(folder / f"{soil}-check-packings.csv", index=False)
        checks[:3].assign(cone_kpa=cone / 1e3 + rng.normal(0, 5, 3)).to_csv(folder / f"{soil}-check.csv", index=False)
        grown = checked_rows(folder, soil, "g", cfg["check_size_check_mm"], [20.0, 22.0], normal_cohesion=bond)
        grown.assign(box="grown").to_csv(folder / f"{soil}-box-size.csv", index=False)
    paths = soils_apart.run(tmp_path, folders)
    table = pd.read_csv(paths[0], comment="#")
    checked, grown, column = (table[table.read_in == w].set_index("response") for w in
                              (*("x".join(f"{v:g}" for v in cfg[k]) for k in ("check_box_mm", "check_size_check_mm")),
                               "column"))
    assert checked.loc["c_kpa", "apart"] and not checked.loc["phi_deg", "apart"]
    assert checked.loc["c_kpa", "packings"] == "5+5" and set(checked.index) == {"c_kpa", "phi_deg"}
    assert list(column.index) == ["collapse_deg"] and column.loc["collapse_deg", "packings"] == "5+5"
    assert not column.loc["collapse_deg", "apart"]
    assert tuple(checked.loc["c_kpa", ["soil_1", "soil_2"]]) == ("clay", "loam")
    assert checked.loc["c_kpa", "difference"] < -9                                    # loam's c is the lower
    assert set(grown.index) == {"c_kpa", "phi_deg"} and not grown.loc["c_kpa", "apart"]
    cone = table[table.read_in == "cone"].set_index("response")
    assert list(cone.index) == ["cone_kpa"] and cone.loc["cone_kpa", "packings"] == "3+3"
    targets = {s: bench.load_targets(s) for s in ("clay", "loam")}
    c_disjoint = targets["clay"].loc["c_kpa", "lo"] > targets["loam"].loc["c_kpa", "hi"]
    assert checked.loc["c_kpa", "targets_apart"] == c_disjoint
    params = pd.read_csv(paths[1], comment="#").set_index("parameter")
    assert params.loc["normal_cohesion", "apart"] and not params.loc["friction_deg", "apart"]
    assert set(params["calibrated"]) == {"both"}
    (folders["loam"] / "loam-check.csv").unlink()
    assert soils_apart.run(tmp_path, folders) == []            # one soil checked: nothing to set apart


def test_filter_packing_reads_an_offset_of_the_filters_packing_only_where_the_checks_resolve_it(tmp_path, monkeypatch):
    """Made-up posterior checks on packings 1-3: packing 1 reads c 3 kPa under the others (over 0.5 kPa of noise),
    φ with no offset; the planes' deepest checks are no posteriors and stay out, earlier calibrations' folders count,
    and so does a soil's current check only while its filter runs on packing 1 alone."""
    from analysis.soil import soils_apart
    common = soils_apart.load_config
    monkeypatch.setattr(soils_apart, "load_config", lambda soil=None: {
        **common(soil=soil), **({"calibration_seed": [1, 2, 3]} if soil == "sand" else {"calibration_seed": 1})})
    assert soils_apart.filter_packing_run(tmp_path) is None                 # no check yet
    rng = np.random.default_rng(7)
    (tmp_path / "earlier").mkdir()
    for i, name in enumerate(["clay-check.csv", "loam-check.csv", "earlier/sand-check.csv", "earlier/clay-check.csv"]):
        c = 10 + 5 * i + rng.normal(0, 0.5, 3) + np.array([-3, 0, 0])
        phi = 30 + rng.normal(0, 1.0, 3)
        pd.DataFrame({"seed": [1, 2, 3], "c_kpa": c, "phi_deg": phi}).to_csv(tmp_path / name, index=False)
    for name in ["loam-deepest-check.csv", "sand-check.csv"]:              # a deepest set; packings in turn
        pd.DataFrame({"seed": [1, 2, 3], "c_kpa": [90, 0, 0], "phi_deg": [30, 30, 30]}).to_csv(tmp_path / name, index=False)
    table = pd.read_csv(soils_apart.filter_packing_run(tmp_path), comment="#").set_index("response")
    assert table.loc["c_kpa", "checks"] == 4 and table.loc["c_kpa", "below"] == 4
    assert table.loc["c_kpa", "lo"] < -3 < table.loc["c_kpa", "hi"] < 0 and table.loc["c_kpa", "resolved"]
    assert table.loc["phi_deg", "lo"] < 0 < table.loc["phi_deg", "hi"] and not table.loc["phi_deg", "resolved"]
    assert "collapse_deg" not in table.index                                  # no check has it


def test_check_odds_fall_with_the_packings_scatter_and_the_number_of_packings_checked(tmp_path):
    """A set reading a target's middle on average: a range ten SDs wide holds every packing, one two SDs wide holds
    one packing 68 % of the time and three 32 %; the written table has every soil's targets and their product."""
    from analysis.soil import soils_apart
    t = soils_apart.check_odds({"wide": (0, 10), "narrow": (0, 2)}, {"wide": 1.0, "narrow": 1.0}, 3).set_index("response")
    assert t.loc["wide", "all_inside"] > 0.999
    assert abs(t.loc["narrow", "one_inside"] - 0.6827) < 1e-3 and abs(t.loc["narrow", "all_inside"] - 0.6827 ** 3) < 1e-3
    assert soils_apart.check_odds({"narrow": (0, 2)}, {"narrow": 1.0}, 5).iloc[0].all_inside < t.loc["narrow", "all_inside"]
    n3, n9 = (soils_apart.check_odds({"narrow": (0, 2)}, {"narrow": 1.0}, n).iloc[0] for n in (3, 9))
    assert n3.interval_inside < n9.interval_inside < n9.one_inside      # more packings decide the mean more often
    table = pd.read_csv(soils_apart.check_odds_run(tmp_path), comment="#")
    for (soil, n), rows in table.groupby(["soil", "packings"]):
        targets = rows[rows.response != "every target"]
        assert {"c_kpa", "phi_deg", "collapse_deg"} <= set(targets.response)
        every = rows[rows.response == "every target"].iloc[0]
        assert abs(every.all_inside - targets.all_inside.prod()) < 2e-3
    assert set(table.packings) >= {3, 9}


def test_the_box_scatter_counts_each_checked_set_once_and_tells_a_moved_deepest_set_from_the_last(tmp_path):
    """`shear_scatter_run`: a set checked on three packings and again on more counts once, over its evaluations; a
    deepest set's check file holding two sets (the planes moved it) counts two."""
    from analysis.soil.soils_apart import shear_scatter_run
    peaks = {1: [30.0, 60.0, 120.0], 2: [32.0, 64.0, 128.0], 3: [28.0, 56.0, 112.0], 4: [30.0, 60.0, 120.0]}

    def evaluation(i, seed, bond):
        folder = tmp_path / "clay" / i
        folder.mkdir(parents=True)
        (folder / "shear.json").write_text(json.dumps({"overrides": {"bond_fragile": 0}, "tests": [
            {"stress_kpa": s, "tau_peak_kpa": t} for s, t in zip((50, 100, 200), peaks[seed])]}))
        return {"id": i, "soil": "clay", "seed": seed, "normal_cohesion": bond, "friction_deg": 10.0}
    posterior = [evaluation(f"p{s}", s, 1e5) for s in (1, 2, 3, 4)]
    pd.DataFrame(posterior[:3]).to_csv(tmp_path / "clay-check.csv", index=False)
    pd.DataFrame(posterior).to_csv(tmp_path / "clay-check-packings.csv", index=False)
    deepest = [evaluation(f"d{s}-{b:.0f}", s, b) for b in (1.5e5, 1.6e5) for s in (1, 2, 3)]
    pd.DataFrame(deepest).to_csv(tmp_path / "clay-deepest-check-packings.csv", index=False)
    table = pd.read_csv(shear_scatter_run(tmp_path), comment="#").set_index("stress_kpa")
    assert table.loc[200.0, "sets"] == 3 and table.loc[200.0, "dof"] == 3 + 2 + 2
    assert table.loc[200.0, "tau_sd_kpa"] == pytest.approx(np.sqrt(3 * 128 / 7), abs=1e-3)   # 128 each set


def test_the_box_shift_is_the_size_check_of_each_box_over_every_packing_it_ran(tmp_path):
    """`box_shift_run`: a soil whose posterior was checked in the filter's box, the checks' box and the checks' box
    grown by half gives a row per shear response and box pair, the bigger box's mean less the smaller's over every
    packing each box ran (its check and size tables, each packing once, the box read from the evaluation's result:
    a seed names a packing within one box only), with its interval and the size rule's verdict; rows of another set
    and a soil checked in one box only give none."""
    from analysis.soil.soils_apart import box_shift_run
    assert box_shift_run(tmp_path) is None
    (tmp_path / bench.FILTER_BOX_CHECKS).mkdir()
    post = CHECKED_SET

    def rows(soil, name, box_mm, cs, **params):
        return checked_rows(tmp_path, soil, name, box_mm, cs, **params)
    for soil in ("sand", "clay"):
        (tmp_path / f"{soil}-posterior.json").write_text(json.dumps({"mean": post}))
    rows("sand", "f", [150, 150, 100], [12.0, 14.0, 16.0, 13.0]).to_csv(
        tmp_path / bench.FILTER_BOX_CHECKS / "sand-check-packings.csv", index=False)
    checks = rows("sand", "k", [225, 225, 150], [9.0, 11.0, 13.0, 10.0])
    checks.to_csv(tmp_path / "sand-check-packings.csv", index=False)
    checks[:3].to_csv(tmp_path / "sand-check.csv", index=False)
    pd.concat([checks[:2].assign(box="configured", size_mm="225x225x150"),
               rows("sand", "g", [338, 338, 225], [3.0, 5.0, 7.0]).assign(box="grown", size_mm="338x338x225"),
               rows("sand", "x", [338, 338, 225], [0.0, 0.0], damping=0.2).assign(box="grown", size_mm="338x338x225")]
              ).to_csv(tmp_path / "sand-box-size.csv", index=False)
    rows("clay", "k", [225, 225, 150], [20.0, 22.0, 24.0]).to_csv(tmp_path / "clay-check-packings.csv", index=False)
    table = pd.read_csv(box_shift_run(tmp_path), comment="#")
    assert set(table.soil) == {"sand"} and set(table.response) == {"c_kpa", "phi_deg"}
    first, grown = (table[table.configured_mm == mm].set_index("response") for mm in ("150x150x100", "225x225x150"))
    assert first.loc["c_kpa", "shift"] == pytest.approx(-3.0) and first.loc["c_kpa", "grown_n"] == 4
    assert first.loc["c_kpa", "shift_lo"] < -3.0 < first.loc["c_kpa", "shift_hi"]
    assert first.loc["phi_deg", "shift"] == pytest.approx(0) and not first.loc["phi_deg", "resolved"]
    assert first.loc["phi_deg", "passes"]
    assert grown.loc["c_kpa", "configured_n"] == 4 and grown.loc["c_kpa", "grown_n"] == 3
    assert grown.loc["c_kpa", "shift"] == pytest.approx(5.0 - 10.75) and not grown.loc["c_kpa", "passes"]
    assert grown.loc["c_kpa", "grown_mm"] == "338x338x225"


def test_the_pooled_box_shift_weighs_each_soil_by_its_scatter_and_pools_one_box_pair_at_a_time(tmp_path):
    """`box_shift_pooled_run`: box-shift.csv's soils pooled per box pair and response; the soil read on more packings
    weighs more, a box pair checked in one soil gives no row, and soils moving apart show in Cochran's Q."""
    from analysis.soil.soils_apart import box_shift_pooled_run
    assert box_shift_pooled_run(tmp_path) is None

    def row(soil, small, big, response, shift, grown_n):
        return {"response": response, "configured_sd": 3.0, "configured_n": 9, "grown_sd": 3.0, "grown_n": grown_n,
                "shift": shift, "soil": soil, "configured_mm": small, "grown_mm": big}
    pd.DataFrame([row("clay", "225", "338", "c_kpa", -2.0, 4), row("sand", "225", "338", "c_kpa", -5.0, 40),
                  row("clay", "225", "338", "phi_deg", -3.0, 4), row("sand", "225", "338", "phi_deg", 3.0, 40),
                  row("sand", "150", "225", "c_kpa", 1.0, 9)]).to_csv(tmp_path / "box-shift.csv", index=False)
    table = pd.read_csv(box_shift_pooled_run(tmp_path), comment="#").set_index("response")
    assert set(table.configured_mm) == {225} and set(table.soils_pooled) == {"clay sand"}
    assert -5.0 < table.loc["c_kpa", "shift"] < -3.5                       # nearer sand's, read on ten times more
    assert table.loc["c_kpa", "resolved"] and table.loc["c_kpa", "q_p"] > 0.05
    assert table.loc["phi_deg", "q_p"] < table.loc["c_kpa", "q_p"]


def test_the_box_peaks_read_the_size_check_on_each_stress_peak_and_pool_the_soils_and_stresses(tmp_path):
    """`box_peaks_run`: sand's posterior read 4 kPa lower in c in the grown box, at the same φ, gives each stress's
    mean peak in both boxes and the grown box's shift in % of the checks' box's peak, resolved; sand's row pooled
    over its stresses lies among them, and with clay's, read alike in both boxes, the soils' pooled row lies between,
    Cochran's Q telling the two apart; a soil checked in one box gives no row."""
    from analysis.soil.soils_apart import box_peaks_run
    assert box_peaks_run(tmp_path) is None
    cfg = bench.load_config()
    for soil in ("sand", "clay", "loam"):
        (tmp_path / f"{soil}-posterior.json").write_text(json.dumps({"mean": CHECKED_SET}))
    c, phi = [10.0, 11.0, 9.0, 10.5], [30.0, 30.5, 29.5, 30.0]
    for soil, drop in (("sand", 4.0), ("clay", 0.0), ("loam", None)):
        checked_rows(tmp_path, soil, "k", cfg["check_box_mm"], c, phi).to_csv(
            tmp_path / f"{soil}-check-packings.csv", index=False)
        if drop is not None:
            checked_rows(tmp_path, soil, "g", cfg["check_size_check_mm"], [v - drop for v in c], phi) \
                .assign(box="grown").to_csv(tmp_path / f"{soil}-box-size.csv", index=False)
    table = pd.read_csv(box_peaks_run(tmp_path), comment="#")
    assert set(table.soil) == {"sand", "clay", "pooled"}
    sand = table[(table.soil == "sand") & table.stress_kpa.notna()].set_index("stress_kpa")
    assert list(sand.index) == [50.0, 100.0, 200.0] and sand["resolved"].all()
    def mean_peaks(box_mm, cs):
        return np.mean([[t["tau_peak_kpa"] for t in shear_box(v, f, size=box_mm[0] / 1000)["tests"]]
                        for v, f in zip(cs, phi)], axis=0)
    assert sand["configured_kpa"].to_numpy() == pytest.approx(mean_peaks(cfg["check_box_mm"], c), abs=1e-3)
    assert sand["grown_kpa"].to_numpy() == pytest.approx(mean_peaks(cfg["check_size_check_mm"], [v - 4 for v in c]),
                                                         abs=1e-3)
    assert sand["shift_pct"].to_numpy() == pytest.approx(
        100 * (sand["grown_kpa"] / sand["configured_kpa"] - 1).to_numpy(), abs=0.01)
    own = table[(table.soil == "sand") & table.stress_kpa.isna()]
    assert len(own) == 1 and own.pooled_rows.iloc[0] == 3                               # sand's stresses
    assert sand["shift_pct"].min() < own.shift_pct.iloc[0] < sand["shift_pct"].max()
    clay = table[(table.soil == "clay") & table.stress_kpa.isna()].shift_pct.iloc[0]
    both = table[table.soil == "pooled"]
    assert len(both) == 1 and both.pooled_rows.iloc[0] == 6
    assert own.shift_pct.iloc[0] < both.shift_pct.iloc[0] < clay and both.q_p.iloc[0] < 0.05     # they differ


def test_the_cone_per_c_table_reads_each_checked_sets_box_and_its_kept_cones_at_the_runs_grains(tmp_path):
    """`cone_per_c_run`: a set checked on three packings with its cone kept at the runs' grains on two gives one row,
    the cone per kPa of c and the c that ratio asks for Table 2's floor; a set with no cone kept gives none."""
    from analysis.soil.soils_apart import cone_per_c_run
    params = {"normal_cohesion": 1.5e5, "friction_deg": 20.0, "pressed_adhesion": 0.05, "rolling_friction": 0.0,
              "damping": 0.2}
    rows = [{"id": f"s{s}", "soil": "sand", "seed": s, **params, "c_kpa": c} for s, c in ((1, 10.0), (2, 12.0), (3, 14.0))]
    pd.DataFrame(rows).to_csv(tmp_path / "sand-deepest-check-packings.csv", index=False)
    cfg = bench.runs_cone(bench.load_config(soil="sand"))
    for seed, cone in ((1, 330e3), (2, 390e3)):
        path = bench.cone_path("sand", params, cfg, tmp_path, seed)[0]
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps({"cone_index_pa": cone}))
    (tmp_path / "earlier").mkdir()
    pd.DataFrame([{**r, "normal_cohesion": 1e5} for r in rows]).to_csv(tmp_path / "earlier" / "sand-check.csv", index=False)
    table = pd.read_csv(cone_per_c_run(tmp_path), comment="#")
    assert len(table) == 1 and table.packings_c[0] == 3 and table.packings_cone[0] == 2
    floor = bench.cone_range("sand", cfg)[0]
    assert table.ratio[0] == pytest.approx(30.0) and table.c_for_cone_floor[0] == pytest.approx(floor / 30.0, abs=1e-3)


def test_a_check_reads_a_packing_whose_scene_stopped_as_failed_and_calls_no_response_inside(tmp_path, monkeypatch):
    """`check`: a packing whose collapse still flowed (its evaluation failed, every response NaN) is counted in
    `failed_packings`; the others give the mean and its interval, and no verdict with a failed packing is "inside"."""
    post = {"normal_cohesion": 1.0e5, "friction_deg": 20.0, "pressed_adhesion": 0.05, "rolling_friction": 0.05,
            "damping": 0.15}
    (tmp_path / "sand-posterior.json").write_text(json.dumps({"mean": post}))

    def made_up(soil, seed, params, c, out_dir):
        if seed == 4:
            return {"id": f"s{seed}", "seed": seed, **params, "c_kpa": math.nan, "phi_deg": math.nan,
                    "collapse_deg": math.nan, "failed": "scripts/collapse.py: collapse stopped"}
        return {"id": f"s{seed}", "seed": seed, **params, "c_kpa": 6.0 + 0.1 * seed, "phi_deg": 31.0, "collapse_deg": 33.0}
    monkeypatch.setattr(bench, "evaluate", made_up)
    out = bench.check_packings("sand", [1, 2, 3, 4], bench.load_config(soil="sand"), tmp_path)
    c = out["c_kpa"]
    assert c["failed_packings"] == 1 and c["mean"] == pytest.approx(6.2) and math.isfinite(c["mean_interval"][0])
    assert c["mean_verdict"] == "undecided" and not c["every_packing_inside"]
    assert json.loads((tmp_path / "sand-check-packings.json").read_text())["collapse_deg"]["failed_packings"] == 1


def test_the_box_reads_c_against_the_load_the_plane_carries():
    """The lid's own weight and the soil above the plane load it besides σn: a fit on σn alone would read c higher by
    tan φ × that weight over the sheared area; the plane's load, measured from the curve, takes it back."""
    from analysis.soil.shear import fit_tests, plane_load
    box = shear_box(5.0, 30.0, weight=3.0)
    assert plane_load(box["tests"][0]) == pytest.approx(53.0)
    assert fit_tests(box["tests"])["c_kpa"] == pytest.approx(5.0)
    on_the_lid = [{**t, "curve": [[x, 0, 0, 0, t["stress_kpa"] * 150 / (150 - x)] for x, *_ in t["curve"]]}
                  for t in box["tests"]]
    assert fit_tests(on_the_lid)["c_kpa"] == pytest.approx(5.0 + 3.0 * 150 / 120 * math.tan(math.radians(30.0)))


def test_remeasure_reads_every_kept_check_again_and_records_the_posteriors(tmp_path):
    """`remeasure`: a check table's responses measured again from its evaluations' stored results and its verdicts
    judged again, in bench/ and in a folder of it; an evaluation not kept here keeps its row; the nine-packing
    verdict reaches the soil's config; the filter's own table is left as the filter weighed it."""
    from analysis.core.schema import read_toml
    heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]       # 45° from x = 100 mm
    params = {"normal_cohesion": 1e5, "friction_deg": 10.0, "pressed_adhesion": 0.1, "rolling_friction": 0.2,
              "damping": 0.1}
    rows = []
    for seed in (1, 2, 3, 4):
        folder = tmp_path / "clay" / f"s{seed}"
        if seed < 4:                                   # packing 4's folder is another machine's
            folder.mkdir(parents=True)
            (folder / "box.json").write_text(json.dumps(shear_box(20.0 + seed, 27.0)))
            (folder / "column.json").write_text(json.dumps({"profile_mm": heap}))
        rows.append({"id": f"s{seed}", "soil": "clay", "seed": seed, **params, "c_kpa": 40.0, "phi_deg": 20.0,
                     "collapse_deg": 30.0})
    table = pd.DataFrame(rows)
    for path in (tmp_path / "clay-check-packings.csv", tmp_path / "filter-box" / "clay-check.csv", tmp_path / "clay.csv"):
        path.parent.mkdir(exist_ok=True)
        table.to_csv(path, index=False)
    table[:3].to_csv(tmp_path / "clay-check.csv", index=False)
    sized = pd.concat([table[:3].assign(box="configured"), table[:3].assign(box="grown")])
    (tmp_path / "clay-size.csv").write_text("# the size check\n" + sized.to_csv(index=False))
    for seed in (1, 2):                                # the checks' box grown by half on packings 1 and 2
        folder = tmp_path / "clay" / f"g{seed}"
        folder.mkdir()
        box = shear_box(26.0 + seed, 26.0, size=0.338)
        for test in box["tests"]:
            test["size_m"] = [0.338, 0.338, 0.225]
        (folder / "box.json").write_text(json.dumps(box))
        (folder / "column.json").write_text(json.dumps({"profile_mm": heap}))
    grown = table[:2].assign(id=["g1", "g2"], box="grown", size_mm="338x338x225")
    pd.concat([table[:2].assign(box="configured", size_mm="225x225x150"), grown]).to_csv(tmp_path / "clay-box-size.csv",
                                                                                        index=False)
    stale = {r: {"mean": 0.0, "target": t} for r, t in (("c_kpa", [20, 35]), ("phi_deg", [20, 30]),
                                                        ("collapse_deg", [30, 38]))}
    (tmp_path / "clay-check-packings.json").write_text(json.dumps(stale))
    cone = {"mean": 450.0, "sd": 1.0, "target": [382.5, 517.5], "every_packing_inside": True, "mean_inside": True}
    (tmp_path / "clay-check.json").write_text(json.dumps({**stale, "cone_kpa": cone}))
    (tmp_path / "clay-posterior.json").write_text(json.dumps({
        "names": list(params), "mean": params, "interval": {k: [v, v] for k, v in params.items()},
        "correlation": {a: {b: 0.0 for b in params} for a in params}}))
    config = tmp_path / "clay.toml"
    config.write_text((bench.ROOT / "configs/soils/clay.toml").read_text())
    done = bench.remeasure("clay", tmp_path, config)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in done) == ["clay-box-size.csv", "clay-check-packings.csv",
                                                                         "clay-check.csv", "clay-size.csv",
                                                                         "filter-box/clay-check.csv"]
    size = {r["response"]: r for r in json.loads((tmp_path / "clay-size.json").read_text())}
    assert size["c_kpa"]["configured_mean"] == pytest.approx(22.0) and size["c_kpa"]["shift"] == pytest.approx(0.0)
    assert (tmp_path / "clay-size.csv").read_text().startswith("# the size check\n")
    three = json.loads((tmp_path / "clay-check.json").read_text())
    assert three["c_kpa"]["every_packing_inside"] is True and three["cone_kpa"] == cone
    for path in (p for p in done if not p.name.endswith("size.csv")):
        again = pd.read_csv(path)
        assert again["c_kpa"].tolist() == pytest.approx([21.0, 22.0, 23.0, 40.0][:len(again)])
        assert again["phi_deg"].tolist()[:3] == pytest.approx([27.0] * 3)
        assert again["collapse_deg"].tolist()[:3] == pytest.approx([45.0] * 3, abs=1.0)
    verdict = json.loads((tmp_path / "clay-check-packings.json").read_text())
    assert verdict["c_kpa"]["mean"] == pytest.approx((21 + 22 + 23 + 40) / 4)
    assert verdict["c_kpa"]["every_packing_inside"] is False
    assert pd.read_csv(tmp_path / "clay.csv")["c_kpa"].tolist() == [40.0] * 4          # what the filter weighed
    line = read_toml(config)["bench_posterior"]["check_packings"]
    assert line["seeds"] == [1, 2, 3, 4] and line["c_kpa"].startswith(verdict["c_kpa"]["mean_verdict"])
    grown_line = read_toml(config)["bench_posterior"]["grown_box_packings"]      # c 27 and 28 kPa, φ 26° there
    assert grown_line["box_mm"] == [338.0, 338.0, 225.0] and grown_line["seeds"] == [1, 2]
    assert grown_line["c_kpa"].startswith("inside: 27.5") and grown_line["phi_deg"].startswith("inside: 26")
    assert "collapse_deg" not in grown_line


def test_a_posterior_drawn_under_another_reading_is_weighed_again_from_its_stored_tests(tmp_path):
    """`reading_reweighted_run`: a filter drawn on the lid's load alone (no `shear_reading`) has its last iteration's
    evaluations measured again from their stored tests and its samples weighed again: a sample whose c reads back
    inside its range takes the weight; a filter drawn under the current reading gives no row."""
    from analysis.soil.shear import READING
    from analysis.soil.soils_apart import reading_reweighted_run
    heap = {"profile_mm": [[x, max(0.0, min(100.0, 200.0 - x))] for x in range(0, 400, 2)]}
    rows = []
    for i, (bond, c) in enumerate(((1e5, 10.0), (2e5, 10.0))):
        folder = tmp_path / "sand" / f"s{i}"
        folder.mkdir(parents=True)
        (folder / "box.json").write_text(json.dumps(shear_box(c, 34.0)))
        (folder / "column.json").write_text(json.dumps(heap))
        rows.append({"id": f"s{i}", "normal_cohesion": bond, "c_kpa": c + 10.0 * i, "phi_deg": 34.0,
                     "collapse_deg": 30.0, "iteration": 2, "weight_last": 0.5})    # the second read 20 kPa as weighed
    pd.DataFrame(rows).to_csv(tmp_path / "sand.csv", index=False)
    post = {"names": ["normal_cohesion"], "mean": {"normal_cohesion": 1.5e5}, "interval": {"normal_cohesion": [1e5, 2e5]},
            "likelihood_sigma": [0.01], "targets": {"c_kpa": [0, 12, "s"], "phi_deg": [26, 36, "s"]}}
    (tmp_path / "sand-posterior.json").write_text(json.dumps(post))
    table = pd.read_csv(reading_reweighted_run(tmp_path), comment="#").set_index("parameter")
    assert table.loc["normal_cohesion", "mean_drawn"] == pytest.approx(1.5e5)
    assert table.loc["normal_cohesion", "mean_reweighted"] == pytest.approx(2e5, rel=1e-3)   # its c read back inside
    assert table.loc["normal_cohesion", "ess_drawn"] == pytest.approx(2.0)
    assert table.loc["normal_cohesion", "ess_reweighted"] == pytest.approx(1.0, rel=1e-3)
    (tmp_path / "sand-posterior.json").write_text(json.dumps({**post, "shear_reading": READING}))
    assert reading_reweighted_run(tmp_path) is None


def test_a_stopped_shear_run_resumes_at_the_normal_stress_it_stopped_in(tmp_path, monkeypatch):
    """scripts/shear.py keeps each normal stress's test as it finishes: run again after a stop in its second stress,
    it runs that stress and the next only, reuses none of them for other settings, another soil law or other code,
    and leaves no kept test behind once its result is written."""
    import scripts.beds as beds
    import scripts.shear as shear
    monkeypatch.setattr(beds, "bed_from_args", lambda a: tmp_path / "beds" / "sand-medium-150x150x100-s1-abc.npz")
    code = tmp_path / "scene.py"
    code.write_text("the scene")
    monkeypatch.setattr(shear, "SCENE_SOURCES", (code,))
    ran = []

    def made_up(bed_path, soil, stress, speed, threads, test, remoulded=False, preload_kpa=None):
        ran.append((stress, speed))
        if stress == 100.0 and len(ran) == 2:
            raise RuntimeError("made-up stop")
        return shear_box(10.0, 30.0)["tests"][[50.0, 100.0, 200.0].index(stress)] | {"bed": bed_path.stem, "soil": soil,
                                                                                     "radius_m": 0.006}
    monkeypatch.setattr(shear, "run", made_up)
    argv = ["--soil", "sand", "--stress", "50,100,200", "--speed", "0.1", "--out", str(tmp_path / "out")]
    assert shear.main(argv) == 3 and ran == [(50.0, 0.1), (100.0, 0.1)]
    assert len(list((tmp_path / "out").glob("*.part.json"))) == 1
    assert shear.main(argv) == 0 and ran[2:] == [(100.0, 0.1), (200.0, 0.1)]
    assert not list((tmp_path / "out").glob("*.part.json"))
    result = json.loads(next((tmp_path / "out").glob("*.json")).read_text())
    assert [t["stress_kpa"] for t in result["tests"]] == [50.0, 100.0, 200.0]
    assert result["c_kpa"] == pytest.approx(10.0, abs=0.01)
    shear.main([*argv[:-2], "--speed", "0.05", "--out", str(tmp_path / "out")])     # other settings: all three run
    assert ran[4:] == [(50.0, 0.05), (100.0, 0.05), (200.0, 0.05)]
    import dataclasses
    import analysis.core.soil_config as soil_config
    load = soil_config.load_soil
    for change in (lambda: code.write_text("the scene, changed"),                  # stopped, then the code changes
                   lambda: monkeypatch.setattr(soil_config, "load_soil",         # or the soil's configured law
                                               lambda name: dataclasses.replace(load(name), damping=0.3))):
        del ran[:]
        assert shear.main(argv) == 3 and ran == [(50.0, 0.1), (100.0, 0.1)]
        change()
        assert shear.main(argv) == 0 and ran[2:] == [(50.0, 0.1), (100.0, 0.1), (200.0, 0.1)]


@pytest.mark.scene
def test_a_column_on_fixed_grains_holds_its_toe_where_a_plane_of_the_grains_friction_lets_it_run(tmp_path):
    """Cohesionless grains of 5° friction: on the plane floor the heap runs out along it, on the floor of fixed grains
    (--floor grains) it stands steeper and shorter (sand's small column: 11.5° and 168 mm on the plane, 23.9° and
    92 mm on the grains)."""
    low = ["--test-set", "friction_deg=5", "--test-set", "new_contact_cohesion=0"]
    runs = bench_scenes(tmp_path, "collapse", {floor: [*low, "--floor", floor] for floor in ("plane", "grains")})
    assert runs["grains"]["floor"] == "grains"
    assert runs["grains"]["angle_deg"] > runs["plane"]["angle_deg"] + 5, runs
    assert runs["grains"]["runout_mm"] < 0.8 * runs["plane"]["runout_mm"], runs


def test_a_cone_at_the_soils_field_friction_on_steel_is_named_and_run_with_it(tmp_path, monkeypatch):
    """[cone_check] tool_friction = "field": the cone runs with the soil's friction on steel from
    configs/field/tool_friction.csv (a probe's own friction stands) and is named by it, so a cone at the grain's
    friction is not reused; "grain" keeps the earlier name; another word, or a value outside its row's range, is
    refused with the field and the allowed values."""
    params = {"normal_cohesion": 8e4, "friction_deg": 6.0, "pressed_adhesion": 0.3, "rolling_friction": 0.3,
              "damping": 0.15}
    seen = []
    monkeypatch.setattr(bench, "cone_scene", lambda args, log: seen.append(args) or {"cone_index_pa": 4.5e5})
    cfg = bench.load_config(soil="clay")
    field = {**cfg, "cone_check": {**cfg["cone_check"], "tool_friction": "field"}}
    grain = {**cfg, "cone_check": {**cfg["cone_check"], "tool_friction": "grain"}}
    value = bench.field_tool_friction("clay")
    t = pd.read_csv(bench.TOOL_FRICTION, comment="#").set_index("soil")
    assert t.loc["clay", "lo_deg"] <= value <= t.loc["clay", "hi_deg"]
    assert bench.cone_path("clay", params, grain, tmp_path)[0] == bench.cone_path("clay", params, cfg, tmp_path)[0]
    assert bench.cone_path("clay", params, field, tmp_path)[0] != bench.cone_path("clay", params, cfg, tmp_path)[0]
    bench.cone_check("clay", params, field, tmp_path)
    bench.cone_check("clay", {**params, "tool_friction_deg": 30.0}, field, tmp_path)
    bench.cone_check("clay", params, cfg, tmp_path)
    named = [[a for a in args if a.startswith("tool_friction_deg=")] for args in seen]
    assert named == [[f"tool_friction_deg={value}"], ["tool_friction_deg=30.0"], []]
    bad = tmp_path / "bad.toml"
    bad.write_text(f'base = "{bench.CONFIG}"\n[cone_check]\ntool_friction = "steel"\n')
    with pytest.raises(ConfigError, match="cone_check.tool_friction = 'steel': allowed \"grain\""):
        bench.load_config(bad, "clay")
    table = tmp_path / "tool_friction.csv"
    table.write_text("soil,lo_deg,hi_deg,value_deg,source\nclay,10,21,25,made up\n")
    with pytest.raises(ConfigError, match="clay.value_deg = 25: allowed 10-21"):
        bench.field_tool_friction("clay", table)


def test_a_resumed_batch_prints_a_line_for_each_job_that_ran_and_for_the_last_not_for_each_kept_one(monkeypatch):
    """`in_parallel`: kept results (done within REUSED_S) print no line of their own; each job that ran prints one
    with an ETA from the jobs that ran, and the last job prints one whichever it was; results keep the jobs' order."""
    import time as clock
    lines = []
    monkeypatch.setattr(bench, "say", lines.append)
    monkeypatch.setattr(bench, "REUSED_S", 0.05)

    def fn(job):
        if job in (2, 3):
            clock.sleep(0.1)        # these ran; the others were kept
        return job * 10
    assert bench.in_parallel(fn, [0, 1, 2, 3, 4], 1, "calibrate clay", "evaluations") == [0, 10, 20, 30, 40]
    assert [line.split(" evaluations")[0] for line in lines] == ["calibrate clay: 3/5", "calibrate clay: 4/5",
                                                                 "calibrate clay: 5/5"]
    assert "ETA 0 s" in lines[-1] and "unknown" not in "".join(lines)
