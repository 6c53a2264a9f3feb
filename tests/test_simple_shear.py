"""The wall-free simple shear cell (scripts/simple_shear.py) and its reading (analysis/soil/cell.py): bad input is
refused before any packing, the size check runs each cell once and reads only the posterior's runs, and (scene
tier) a cohesionless cell reads no cohesion and a friction angle that grows with the grains' friction."""
import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from analysis.core.schema import ROOT, ConfigError
from analysis.soil import bench_calibration as bench
from analysis.soil import cell


def test_a_cell_too_small_for_its_grains_is_refused_before_any_packing(capsys):
    from scripts.simple_shear import main
    assert main(["--soil", "clay", "--size", "60", "--bed-dir", "/nonexistent"]) == 2
    assert "--size = 60 mm: allowed at least 66 mm" in capsys.readouterr().err
    assert main(["--soil", "clay", "--test-set", "friction_deg=99", "--bed-dir", "/nonexistent"]) == 2
    assert "friction_deg" in capsys.readouterr().err


@pytest.mark.parametrize("edges", ["[120]", "[180, 120]", "[20, 30]"])
def test_the_cells_edges_are_two_or_more_rising_ones(tmp_path, edges):
    text = bench.CONFIG.read_text().replace("cell_edges_mm = [120, 180]", f"cell_edges_mm = {edges}")
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="cell_edges_mm"):
        bench.load_config(tmp_path / "b.toml")


def fake_cell(soil: str, edge: int, seed: int, c: float, phi: float, overrides: dict) -> dict:
    """A cell's result file whose peaks lie on τ = c + σ tan φ."""
    import math
    tests = [{"stress_kpa": s, "sigma_at_peak_kpa": s, "tau_peak_kpa": c + s * math.tan(math.radians(phi)),
              "size_m": [edge / 1000] * 3} for s in (50.0, 100.0, 200.0)]
    return {"bed": f"{soil}-medium-cell{edge}-s{seed}-0123abcd", "overrides": overrides, "inertial": 1e-3,
            "tests": tests}


def fake_scenes(ran: dict, c: float, phi: float):
    """A stand-in for the bench scenes' process runner: the cell writes a result file whose peaks lie on
    τ = c + σ tan φ, with its fit as the cell's file has it, the collapse a 45° heap; `ran` maps each scene run to
    its command, in the order they ran."""
    from pathlib import Path
    from analysis.soil import shear

    def fake(cmd, sink):
        scene, folder = Path(cmd[1]).stem, Path(cmd[cmd.index("--out") + 1])
        ran[scene] = cmd
        if scene == "collapse":
            heap = [[x, max(0.0, min(100.0, 100.0 - (x - 100.0)))] for x in range(0, 400, 2)]
            (folder / "column.json").write_text(json.dumps({"profile_mm": heap}))
            return 0, json.dumps({"runout_mm": 100.0})
        result = fake_cell("clay", 120, 1, c, phi, {})
        result.update(shear.fit_tests(result["tests"]))
        (folder / "cell.json").write_text(json.dumps(result))
        return 0, json.dumps(shear.fit_tests(result["tests"]))
    return fake


def test_the_size_check_runs_each_cell_once_and_reads_only_the_posteriors_runs(tmp_path, monkeypatch):
    """Each edge and packing runs once with the posterior's overrides and the values its calibration held (a finished
    one is not run again, nor one the filter's check ran at the posterior in its evaluation's folder); another set's
    run in the folder is not read; the grown cell's shift under the packings' SD passes and the verdict is read in
    the smaller cell."""
    bench_dir = tmp_path / "bench"
    bench_dir.mkdir()
    post = {"normal_cohesion": 9e4, "friction_deg": 9.0, "pressed_adhesion": 0.1, "rolling_friction": 0.3,
            "damping": 0.1}
    (bench_dir / "clay-posterior.json").write_text(json.dumps({"mean": post, "fixed": {"adhesion_onset": 4e4}}))
    checked = bench_dir / "clay" / "s1-check"
    checked.mkdir(parents=True)
    (checked / "responses.json").write_text(json.dumps({"c_kpa": 23.0}))
    (checked / "cell.json").write_text(json.dumps(fake_cell("clay", 120, 1, 23.0, 26.1,
                                                            cell.posterior_overrides("clay", bench_dir))))
    monkeypatch.setattr(cell, "box_beside", lambda soil, cells, bench_dir: [])
    monkeypatch.setattr(cell, "plot", lambda read, beside, path: path)
    ran = []

    def fake_run(cmd, log_path):
        arg = dict(zip(cmd[2::2], cmd[3::2]))
        edge, seed = round(float(arg["--size"])), int(arg["--seed"])
        test = dict(item.split("=") for item in cmd[cmd.index("--test-set") + 1::2])
        ran.append((edge, seed))
        stresses = arg["--stress"].replace(",", "_")
        from pathlib import Path
        name = Path(log_path).stem
        result = fake_cell("clay", edge, seed, 22.0 + seed % 2, 26.0 + 0.1 * seed, {k: float(v) for k, v in test.items()})
        result["bed"] = name
        (Path(arg["--out"]) / f"{name}-{stresses}.json").write_text(json.dumps(result))
        return 0, ""
    monkeypatch.setattr(cell, "run_logged", fake_run)
    cfg = {**bench.load_config(soil="clay"), "cell_edges_mm": [120, 180]}
    other = tmp_path / "cells" / "clay" / "other"
    other.mkdir(parents=True)
    (other / "x.json").write_text(json.dumps(fake_cell("clay", 120, 9, 2.0, 20.0, {"friction_deg": 30.0})))
    table = cell.size_check("clay", cfg, [1, 2, 3], 2, bench_dir, tmp_path / "cells")
    assert sorted(ran) == [(120, 2), (120, 3), (180, 1), (180, 2), (180, 3)]     # (120, 1): the filter's check's
    cell.size_check("clay", cfg, [1, 2, 3], 2, bench_dir, tmp_path / "cells")
    assert len(ran) == 5                                           # every cell kept: none runs again
    sized = table[table["sized"]].set_index("response")
    assert sized.loc["c_kpa", "edge_mm"] == 120 and sized.loc["c_kpa", "packings"] == 3
    assert sized.loc["c_kpa", "verdict"] == "inside" and sized.loc["c_kpa", "mean"] == pytest.approx(22 + 2 / 3, abs=1e-3)
    sizes = pd.read_csv(bench_dir / "cell-size.csv")
    assert sizes["passes"].all() and set(sizes["response"]) == {"c_kpa", "phi_deg"}


@pytest.mark.scene
def test_a_cohesionless_cell_reads_no_cohesion_and_a_friction_angle_that_grows_with_the_grains(tmp_path):
    """Sand's grains without bonds or re-adhesion, in the smallest cell at three times the shear rate: c within a fifth
    of the higher stress's peak of zero, and φ higher for the rougher grains (27.3 and 32.0° at 10 and 40°, c 0.0 and
    4.0 kPa, on one packing)."""
    from concurrent.futures import ThreadPoolExecutor

    def one(mu):
        out = tmp_path / f"mu{mu:g}"
        r = subprocess.run([sys.executable, str(ROOT / "scripts/simple_shear.py"), "--soil", "sand", "--size", "80",
                            "--stress", "25,75", "--inertial", "0.003", "--bed-dir", str(tmp_path / "beds"),
                            "--out", str(out), "--test-set", f"friction_deg={mu}", "--test-set", "normal_cohesion=0",
                            "--test-set", "shear_cohesion=0", "--test-set", "pressed_adhesion=0"],
                           capture_output=True, text=True, timeout=900, cwd=ROOT)
        assert r.returncode == 0, r.stderr[-2000:]
        return json.loads(next(out.glob("*.json")).read_text())
    with ThreadPoolExecutor(max_workers=2) as pool:
        fits = dict(zip((10.0, 40.0), pool.map(one, (10.0, 40.0))))
    for fit in fits.values():
        assert abs(fit["c_kpa"]) < 0.2 * max(t["tau_peak_kpa"] for t in fit["tests"]), fit["c_kpa"]
    assert fits[40.0]["phi_deg"] > fits[10.0]["phi_deg"] + 2, (fits[10.0]["phi_deg"], fits[40.0]["phi_deg"])


def test_the_filter_takes_the_cell_as_its_shear_test_where_the_bench_says_so(tmp_path, monkeypatch):
    """[bench] shear_test = "cell": an evaluation runs scripts/simple_shear.py at the first cell edge (no box speed),
    fits its peaks at σzz, and is named apart from the box's evaluation of the same set; a bad shear_test is refused."""
    from analysis.core import runner
    cfg = bench.load_config()
    params = {"normal_cohesion": 9e4, "friction_deg": 9.0, "pressed_adhesion": 0.1, "rolling_friction": 0.3,
              "damping": 0.1}
    celled = {**cfg, "shear_test": "cell"}
    assert bench.evaluation_id("clay", 1, params, cfg) != bench.evaluation_id("clay", 1, params, celled)
    ran = {}
    monkeypatch.setattr(runner, "run_process", fake_scenes(ran, 7.0, 25.0))
    row = bench.evaluate("clay", 1, params, celled, tmp_path)
    assert set(ran) == {"simple_shear", "collapse"} and "--speed" not in ran["simple_shear"]
    assert ran["simple_shear"][ran["simple_shear"].index("--size") + 1] == "120"
    assert row["c_kpa"] == pytest.approx(7.0) and row["phi_deg"] == pytest.approx(25.0)
    text = bench.CONFIG.read_text().replace('shear_test = "box"', 'shear_test = "ring"')
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(ConfigError, match="shear_test"):
        bench.load_config(tmp_path / "b.toml")


def test_a_probe_reads_its_shift_in_c_against_the_posterior_on_its_packing_and_what_it_costs_the_cone(tmp_path):
    """A probe doubling the bond lifts the cell's c from 5 to 10 kPa on packing 1; the cone's plane charges 2 kPa per
    kPa of bond, so 200 kPa of cone for 5 of c, 40 per kPa, and lifting the cells' mean c (5) to clay's floor (20)
    costs 600 kPa over the posterior's cone (its check's, 450). A probe of another packing than the posterior's runs,
    or of another posterior (setting fewer parameters), is left out."""
    bench_dir, folder = tmp_path / "bench", tmp_path / "cells"
    bench_dir.mkdir()
    post = {"normal_cohesion": 1e5, "friction_deg": 10.0, "pressed_adhesion": 0.1, "rolling_friction": 0.2,
            "damping": 0.1}
    (bench_dir / "clay-posterior.json").write_text(json.dumps({"mean": post}))
    (bench_dir / "clay-check.json").write_text(json.dumps({"cone_kpa": {"mean": 450.0}}))
    terms = ["bond_kpa", "friction_deg", "disturbed_bond_kpa", "rolling_friction", "damping", "pressed_adhesion"]
    pd.DataFrame([{"soil": "clay", "response": r, "intercept": 0.0, **{t: 0.0 for t in terms}, "bond_kpa": b}
                  for r, b in (("cone_kpa", 2.0), ("collapse_deg", 0.0))]).to_csv(bench_dir / "surfaces.csv", index=False)
    base = cell.posterior_overrides("clay", bench_dir)
    doubled = {**base, "normal_cohesion": 2e5, "shear_cohesion": 2e5}
    fewer = {k: v for k, v in doubled.items() if k != "damping"}           # another posterior's: it set no damping
    for name, seed, overrides in (("bond2x", 1, doubled), ("elsewhere", 7, doubled), ("other", 1, fewer)):
        (folder / "clay" / "probes" / name).mkdir(parents=True)
        (folder / "clay" / "probes" / name / "x.json").write_text(json.dumps(fake_cell("clay", 120, seed, 10.0, 25.0,
                                                                                         overrides)))
    cells = pd.DataFrame([cell.cell_fit(fake_cell("clay", 120, 1, 5.0, 25.0, base))])
    rows = cell.levers("clay", cells, folder, bench_dir)
    assert [r["probe"] for r in rows] == ["bond2x"]
    row = rows[0]
    assert row["changed"] == "normal_cohesion=200000"
    assert row["c_shift"] == pytest.approx(5.0) and row["phi_shift"] == pytest.approx(0.0, abs=1e-9)
    assert row["cone_shift_plane"] == pytest.approx(200.0) and row["cone_per_c"] == pytest.approx(40.0)
    assert row["cone_at_c_floor"] == pytest.approx(450.0 + 40.0 * 15.0)


def test_the_cell_config_lays_clays_cell_filter_over_the_bench_config_and_nothing_else(tmp_path, capsys):
    """configs/bench_calibration_cell.toml: clay's filter shears in the 120 mm cell over six parameters (bond stretch
    the sixth, last), its tables in bench/cell-filter/; loam keeps the box, with the stretch among its parameters; the
    bench config itself is unchanged. A base that is not beside it is refused, and --config only with --bench."""
    from pathlib import Path
    from analysis.cli import main
    cell_cfg = bench.ROOT / "configs/bench_calibration_cell.toml"
    clay = bench.load_config(cell_cfg, soil="clay")
    assert clay["shear_test"] == "cell" and list(clay["bounds"])[-1] == "bond_stretch"
    assert clay["bounds"]["friction_deg"] == (3.0, 12.0) and clay["cone_target"] and clay["cone_screen_sd"] == 3
    assert bench.filter_dir(clay) == bench.BENCH_DIR / "cell-filter"
    loam = bench.load_config(cell_cfg, soil="loam")
    assert loam.get("shear_test", "box") == "box" and "bond_stretch" in loam["bounds"]
    assert "bond_stretch" not in bench.load_config(soil="clay")["bounds"]
    (tmp_path / "v.toml").write_text('base = "elsewhere.toml"\n')
    with pytest.raises(ConfigError, match="base = 'elsewhere.toml'.*allowed"):
        bench.load_config(Path(tmp_path / "v.toml"))
    assert main(["calibrate", "--soil", "clay", "--config", str(cell_cfg)]) == 2
    assert "--config: allowed only with --bench" in capsys.readouterr().err


def test_the_onset_config_fixes_the_held_onset_in_its_own_folder_and_refuses_a_folder_that_is_not_a_name(tmp_path):
    """configs/bench_calibration_onset.toml, laid over the cell config: clay's filter in the cell with the onset of
    pressed re-adhesion fixed (not calibrated), its evaluations in bench/onset-filter/; a filter_folder that is not a
    plain name is refused naming the key."""
    onset_cfg = bench.ROOT / "configs/bench_calibration_onset.toml"
    clay = bench.load_config(onset_cfg, soil="clay")
    assert clay["shear_test"] == "cell" and clay["fixed"]["adhesion_onset"] == 4.0e4
    assert "adhesion_onset" not in clay["bounds"] and clay["bounds"]["normal_cohesion"][0] == 6.0e4
    assert bench.filter_dir(clay) == bench.BENCH_DIR / "onset-filter"
    (tmp_path / "bench_calibration.toml").write_text(bench.CONFIG.read_text())
    (tmp_path / "v.toml").write_text('base = "bench_calibration.toml"\n[bench]\nfilter_folder = "../elsewhere"\n')
    with pytest.raises(ConfigError, match=r"bench.filter_folder = '../elsewhere'.*allowed"):
        bench.load_config(tmp_path / "v.toml")


def test_a_posterior_reaches_the_runs_soil_only_from_the_folder_it_names(tmp_path, monkeypatch):
    """Once another filter's posterior is adopted (configs/soils/<soil>.toml names its folder), the box filter's
    posterior written again goes into its own record, <BENCH_DIR>/<soil>.toml, and leaves the runs' soil as it is; the
    adopted filter's reaches both its record and the runs' soil."""
    box, adopted = tmp_path / "bench", tmp_path / "bench" / "corner"
    adopted.mkdir(parents=True)
    (tmp_path / "configs/soils").mkdir(parents=True)
    runs = tmp_path / "configs/soils/sand.toml"
    runs.write_text((bench.ROOT / "configs/soils/sand.toml").read_text()
                    .replace('folder = "results/calibration/bench"', 'folder = "bench/corner"'))
    monkeypatch.setattr(bench, "ROOT", tmp_path)
    monkeypatch.setattr(bench, "BENCH_DIR", box)
    assert bench.posterior_configs("sand", box) == [box / "sand.toml"]
    assert bench.posterior_configs("sand", adopted) == [adopted / "sand.toml", runs]
    post = {"names": ["friction_deg"], "mean": {"friction_deg": 6.1}, "interval": {"friction_deg": [5.0, 7.0]},
            "correlation": {"friction_deg": {"friction_deg": 1.0}}, "fixed": {}}
    check = {"c_kpa": {"mean": 3.0, "sd": 1.0, "target": [0, 12], "every_packing_inside": True, "mean_inside": True}}
    before = runs.read_text()
    assert bench.write_posterior("sand", post, check, "box", folder=box) == box / "sand.toml"
    assert runs.read_text() == before and "friction_deg = { mean = 6.1" in (box / "sand.toml").read_text()
    bench.write_posterior("sand", {**post, "mean": {"friction_deg": 7.2}}, check, "adopted", folder=adopted)
    for written in (adopted / "sand.toml", runs):
        text = written.read_text()
        assert text.count("[bench_posterior]") == 1 and "friction_deg = { mean = 7.2" in text


def test_a_variant_configs_checks_and_posterior_stay_in_its_folder(tmp_path, monkeypatch):
    """Under a variant config the checks of the posterior read and write the variant filter's folder, and its
    posterior goes into a copy of the soil config there: configs/soils/<soil>.toml, whose [bench_posterior] the runs
    use, is left as it is."""
    from analysis.cli import main
    onset_cfg, folder = "configs/bench_calibration_onset.toml", bench.BENCH_DIR / "onset-filter"
    seen = []
    result = {"c_kpa": {"mean": 21.0, "mean_interval": [19.0, 23.0], "mean_verdict": "undecided"}}
    monkeypatch.setattr(bench, "check_packings", lambda soil, seeds, cfg, out_dir, which: seen.append(out_dir) or result)
    monkeypatch.setattr(bench, "record_packings", lambda *a, **k: seen.append((a[3], k["command"])))
    assert main(["calibrate", "--soil", "clay", "--bench", "--config", onset_cfg, "--check-packings",
                 "--seeds", "1,2,3"]) == 0
    assert seen == [folder, (folder, f"./holes calibrate --soil clay --bench --config {onset_cfg}")]
    soils = bench.ROOT / "configs/soils/clay.toml"
    before = soils.read_text()
    assert bench.posterior_configs("clay", tmp_path) == [tmp_path / "clay.toml"]
    post = {"names": ["friction_deg"], "mean": {"friction_deg": 6.1}, "interval": {"friction_deg": [5.0, 7.0]},
            "correlation": {"friction_deg": {"friction_deg": 1.0}}, "fixed": {"adhesion_onset": 4.0e4}}
    check = {"c_kpa": {"mean": 21.0, "sd": 1.0, "target": [20, 35], "every_packing_inside": True, "mean_inside": True}}
    for _ in range(2):                                  # written again, it replaces its own table
        written = bench.write_posterior("clay", post, check, "test", folder=tmp_path)
    assert written == tmp_path / "clay.toml" and soils.read_text() == before
    text = written.read_text()
    assert text.count("[bench_posterior]") == 1 and "adhesion_onset = 40000" in text
    from analysis.core.soil_config import posterior_folder
    (tmp_path / "clay-posterior.json").write_text(json.dumps(post))
    assert posterior_folder("clay", written) == tmp_path                # copied over the runs' config, it names its folder
    head = bench.POSTERIOR_HEAD
    assert text[:text.index(head)].rstrip() == before[:before.index(head)].rstrip()   # the soil config's own tables


def test_a_variant_filters_pictures_show_its_own_parameters_in_its_folder(tmp_path, monkeypatch):
    """A variant filter's posterior is drawn with the variant's parameters (the corner config's modulus and stretch
    among them) into its own folder, without the main filter's response surfaces; a variant with no posterior
    draws nothing."""
    import matplotlib.pyplot as plt
    config = bench.ROOT / "configs/bench_calibration_corner.toml"
    names = list(bench.load_config(config, "clay")["bounds"])
    t = pd.DataFrame([{**{k: lo + (hi - lo) * f for k, (lo, hi) in bench.load_config(config, "clay")["bounds"].items()},
                       "c_kpa": 20 + 5 * f, "phi_deg": 22.0, "collapse_deg": 34.0, "iteration": 1 + (f > 0.4),
                       "weight_last": 0.5 if f > 0.4 else float("nan")} for f in (0.2, 0.6, 0.8)])
    t.to_csv(tmp_path / "clay.csv", index=False)
    (tmp_path / "clay-posterior.json").write_text(json.dumps({"mean": {k: t[k].mean() for k in names},
                                                              "interval": {k: [t[k].min(), t[k].max()] for k in names}}))
    monkeypatch.setattr(bench, "surfaces_report", lambda *a, **k: pytest.fail("a variant has no response surfaces"))
    drawn = []
    monkeypatch.setattr(plt.Figure, "savefig", lambda self, path, **k: drawn.append((Path(path).name, [
        ax.get_xlabel() for ax in self.axes])))
    paths = bench.report(tmp_path, config)
    assert [p.name for p in paths] == ["posterior.png", "responses.png"] and all(p.parent == tmp_path for p in paths)
    assert drawn[0][1] == names and "young" in names and "bond_stretch" in names
    assert bench.report(tmp_path / "none", config) == []


def test_a_shifted_filters_responses_are_pictured_as_it_weighs_them(tmp_path, monkeypatch):
    """A filter with a [bench] shear_shift (loam's sized filter) pictures c and φ as it weighs them, its reading plus
    the shift, and names the shift in the panel's title; the collapse slope, not shifted, as read."""
    import matplotlib.pyplot as plt
    config = bench.ROOT / "configs/bench_calibration_sized.toml"
    cfg = bench.load_config(config, "loam")
    shift, names = cfg["shear_shift"], list(cfg["bounds"])
    t = pd.DataFrame([{**{k: lo + (hi - lo) * f for k, (lo, hi) in cfg["bounds"].items()},
                       "c_kpa": 15 + 2 * f, "phi_deg": 25 + f, "collapse_deg": 34.0, "iteration": 1,
                       "weight_last": 0.5} for f in (0.2, 0.6)])
    t.to_csv(tmp_path / "loam.csv", index=False)
    (tmp_path / "loam-posterior.json").write_text(json.dumps({"mean": {k: t[k].mean() for k in names},
                                                              "interval": {k: [t[k].min(), t[k].max()] for k in names}}))
    drawn = {}
    monkeypatch.setattr(plt.Figure, "savefig", lambda self, path, **k: drawn.update({Path(path).name: [
        (ax.get_title(), sorted(ax.collections[0].get_offsets()[:, 1])) for ax in self.axes]}))
    bench.report(tmp_path, config)
    panels = dict(drawn["responses.png"])
    c_title, phi_title = (next(k for k in panels if k.startswith(r)) for r in ("c_kpa", "phi_deg"))
    assert panels[c_title] == pytest.approx(sorted(t["c_kpa"] + shift["c_kpa"]))
    assert panels[phi_title] == pytest.approx(sorted(t["phi_deg"] + shift["phi_deg"]))
    assert "shift" in c_title and f"{shift['phi_deg']:+g}" in phi_title
    assert panels["collapse_deg"] == pytest.approx(sorted(t["collapse_deg"]))


PARAMS = {"normal_cohesion": 9e4, "friction_deg": 6.0, "pressed_adhesion": 0.3, "rolling_friction": 0.2, "damping": 0.15,
          "bond_stretch": 0.4}


def test_a_column_on_fixed_grains_is_named_apart_and_reuses_the_plane_evaluations_cell(tmp_path, monkeypatch):
    """[bench] collapse_floor = "grains" (the onset config's): the evaluation is named apart from the plane's, which
    keeps its id; it reads the cell back from the plane's evaluation of the same set and packing and runs only the
    collapse test, on the grains; a floor that is not one of the two is refused naming the key."""
    from analysis.core import runner
    cfg = bench.load_config(bench.ROOT / "configs/bench_calibration_onset.toml", soil="clay")
    plane = {**cfg, "collapse_floor": "plane"}
    assert cfg["collapse_floor"] == "grains"
    assert bench.evaluation_id("clay", 1, PARAMS, plane) == bench.evaluation_id(
        "clay", 1, PARAMS, {k: v for k, v in cfg.items() if k != "collapse_floor"})
    assert bench.evaluation_id("clay", 1, PARAMS, cfg) != bench.evaluation_id("clay", 1, PARAMS, plane)
    ran = {}
    monkeypatch.setattr(runner, "run_process", fake_scenes(ran, 21.0, 26.0))
    bench.evaluate("clay", 1, PARAMS, plane, tmp_path)
    assert list(ran) == ["simple_shear", "collapse"]
    assert ran["collapse"][ran["collapse"].index("--floor") + 1] == "plane"
    ran.clear()
    row = bench.evaluate("clay", 1, PARAMS, cfg, tmp_path)
    assert list(ran) == ["collapse"] and ran["collapse"][ran["collapse"].index("--floor") + 1] == "grains"
    assert row["resumed"] == "shear (a twin's)" and row["c_kpa"] == pytest.approx(21.0)
    (tmp_path / "bench_calibration.toml").write_text(bench.CONFIG.read_text())
    (tmp_path / "v.toml").write_text('base = "bench_calibration.toml"\n[bench]\ncollapse_floor = "ice"\n')
    with pytest.raises(ConfigError, match=r"bench.collapse_floor = 'ice'.*allowed 'plane' or 'grains'"):
        bench.load_config(tmp_path / "v.toml")


def test_the_floors_grains_touch_in_a_close_packed_lattice_within_the_floor():
    """scripts/collapse.py's floor of fixed grains: every grain inside the floor, none overlapping, each inner one
    touching six, their tops at z = 0."""
    import numpy as np
    from scripts.collapse import floor_grains
    r = 0.006
    c = floor_grains(0.3, 0.12, r)
    assert c[:, 0].min() >= r - 1e-12 and c[:, 0].max() <= 0.3 - r + 1e-12 and c[:, 1].max() <= 0.12 - r + 1e-12
    assert np.allclose(c[:, 2] + r, 0.0)
    gaps = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2) + np.eye(len(c))
    assert gaps.min() == pytest.approx(2 * r)
    touching = (np.abs(gaps - 2 * r) < 1e-9).sum(axis=1)
    assert touching.max() == 6 and np.median(touching) == 6


def test_the_onset_config_shears_every_soil_in_the_cell_on_the_grains_floor():
    """Loam's and sand's onset filters take the cell and the grains floor as clay's does, each with its own prior."""
    onset_cfg = bench.ROOT / "configs/bench_calibration_onset.toml"
    cfgs = {s: bench.load_config(onset_cfg, soil=s) for s in ("clay", "loam", "sand")}
    assert {c["shear_test"] for c in cfgs.values()} == {"cell"}
    assert {c["collapse_floor"] for c in cfgs.values()} == {"grains"}
    assert cfgs["sand"]["bounds"]["pressed_adhesion"][1] <= 0.1 < cfgs["loam"]["bounds"]["pressed_adhesion"][1]
    assert len({tuple(sorted(c["bounds"].items())) for c in cfgs.values()}) == 3
