"""Bad input fails before anything runs, with the key and the allowed range in the message."""
import math

import pytest

from analysis import cli, params_doc
from analysis.core.config import DISK_FIELDS, PRESET_FIELDS, SLEEVE_FIELDS, load_disk
from analysis.core.seedling import load_seedling
from analysis.core.schema import ROOT, ConfigError
from analysis.core.soil_config import SOIL_FIELDS
from analysis.core.run_spec import plan


def write_disk(tmp_path, **change):
    base = dict(R0=70.0, L3=121.0, N=6, D=50.0, h=20.0, penetration=70.0, width=100.0, row_spacing=300.0,
                rows=5, speed_kmh_min=1.8, speed_kmh_max=1.96, speed_kmh=1.9, slip=0.0)
    base.update(change)
    body = "[disk]\n" + "".join(f"{k} = {v!r}\n" for k, v in base.items() if v is not None)
    p = tmp_path / "d.toml"
    p.write_text(body)
    return p


def test_seed_configs_load(disk):
    assert (disk.R, disk.N, disk.D, disk.h, disk.penetration, disk.H0) == (191.0, 6, 50.0, 20.0, 70.0, 121.0)
    s = load_seedling()
    assert (s.a1, s.a2, s.h0) == (35.0, 25.0, 40.0)


@pytest.mark.parametrize("key,value,pattern", [
    ("R0", 0.0, r"disk\.R0 = 0\.0 is out of range: allowed \(0, inf\) mm"),
    ("D", -5.0, r"disk\.D = -5\.0 is out of range"),
    ("L3", -1.0, r"disk\.L3"),
    ("slip", 1.0, r"disk\.slip = 1\.0 is out of range: allowed \[0, 0\.9\]"),
    ("slip", -0.1, r"disk\.slip"),
    ("N", 0, r"disk\.N = 0 is out of range: allowed \[1, 360\]"),
    ("N", 2.5, r"disk\.N = 2\.5: must be a whole number"),
    ("penetration", 130.0, r"disk\.penetration = 130 is out of range: allowed \(0, L3 = 121\] mm"),
    ("h", "x", r"disk\.h = 'x': must be a number"),
])
def test_bad_disk_value(tmp_path, key, value, pattern):
    with pytest.raises(ConfigError, match=pattern):
        load_disk(write_disk(tmp_path, **{key: value}))


def test_unknown_and_missing_keys(tmp_path):
    with pytest.raises(ConfigError, match=r"unknown key\(s\) Rzero"):
        load_disk(write_disk(tmp_path, Rzero=3.0))
    with pytest.raises(ConfigError, match=r"missing key\(s\) N"):
        load_disk(write_disk(tmp_path, N=None))
    p = tmp_path / "s.toml"
    p.write_text("[disc]\nR0 = 1\n")
    with pytest.raises(ConfigError, match=r"unknown section\(s\) disc"):
        load_disk(p)


def test_cli_reports_bad_config_before_running(tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["theory", "--disk", str(write_disk(tmp_path, slip=2.0)), "--out", str(out)]) == 2
    assert "disk.slip = 2.0 is out of range" in capsys.readouterr().err
    assert not out.exists()


def test_theory_runs_on_another_disk(tmp_path, other_disk):
    """`theory` on a non-seed disk writes a consistent table: L1 = D, and no paper column to compare."""
    from analysis.holes import theory_report
    res = theory_report.run(other_disk, tmp_path, "test")
    t = res["table"].set_index(["slip", "quantity"])
    assert t.loc[(0.0, "L1"), "envelope_mm"] == pytest.approx(other_disk.D, abs=1e-3)
    assert t.paper_mm.isna().all()
    for name in ("table1.csv", "trajectories.png", "hole_contour.png", "slip_length.png"):
        assert (tmp_path / name).stat().st_size > 0


def test_every_help_page_prints(capsys):
    """`./holes --help` and each subcommand's --help format (argparse expands % in help texts). The scene
    commands (bed, cone, run, duckbeak) hand --help to their script's own parser."""
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if a.choices and isinstance(a.choices, dict)).choices
    own = [name for name, p in commands.items() if p.add_help]
    assert "calibrate" in own and "run" not in own
    for argv in ([], *([name] for name in own)):
        with pytest.raises(SystemExit) as done:
            parser.parse_args([*argv, "--help"])
        assert done.value.code == 0, argv
    assert "calibrate" in capsys.readouterr().out


def test_a_negative_packing_seed_is_refused_by_bed_and_run():
    """YADE's makeCloud draws a random packing for a negative seed: the bed would be cached under a name
    that does not make it again, so both entries refuse it before YADE starts."""
    from analysis.core import run_spec
    from scripts import beds as bed
    with pytest.raises(ConfigError, match=r"bed\.seed = -1 is out of range: allowed \[0, 2147483647\]"):
        bed.build("clay", "tiny", (100.0, 100.0, 60.0), seed=-1)
    with pytest.raises(ConfigError, match=r"--seed = -1 is out of range: allowed \[0, 2147483647\]"):
        run_spec.plan_from_argv(["--soil", "clay", "--preset", "test", "--seed", "-1"])
    assert run_spec.plan_from_argv(["--soil", "clay", "--preset", "test", "--seed", "0"])["seed"] == 0


def test_the_parameter_page_is_current():
    """configs/README.md is rendered from the schemas and the committed configs: every key is on it with its
    range and value, and a config or schema changed without `./holes params` fails here."""
    page = params_doc.render()
    for key in (*DISK_FIELDS, *SLEEVE_FIELDS, *PRESET_FIELDS, *SOIL_FIELDS):
        assert f"| `{key}` |" in page, key
    assert "| `normal_cohesion` | [0, 1e+08] | Pa | 48000 | 48920 | 37830 |" in page
    assert params_doc.PATH.read_text() == page, "configs/README.md is out of date: run `./holes params`"


def test_bad_graded_resolution_is_refused(tmp_path):
    """A graded bed (configs/resolutions.toml) whose coarse grains overlap the fine sizes, whose fine zone does
    not fit the strip or leaves the plate outside it, or whose sides are periodic, is refused before YADE starts."""
    from analysis.core.config import load_resolution
    p = tmp_path / "r.toml"
    p.write_text("[g]\nradius = 0.004\nspread = 0.25\ncoarse_radius = 0.006\nfine_width = 0.1\nfine_depth = 0.09\n")
    with pytest.raises(ConfigError, match=r"g: a graded bed needs coarse_radius \(1 - spread\) > radius \(1 \+ spread\)"):
        load_resolution("g", p)
    assert load_resolution("graded").graded and not load_resolution("default").graded
    with pytest.raises(ConfigError, match=r"fine_width = 100 mm and fine_depth = 80 mm are out of range for a "
                                          r"120 x 120 mm section: allowed up to 80 \(or the whole width\) and 100 mm"):
        plan("clay", "graded", resolution="graded", width=120)
    assert plan("clay", "graded", resolution="medium_floor", width=120, depth=140)["graded"]["fine_width"] == 1.0  # no sides
    with pytest.raises(ConfigError, match=r"allowed with lateral = 'walls' only"):
        plan("clay", "graded", resolution="graded", lateral="periodic")


def test_every_graded_preset_keeps_its_tools_in_the_fine_zone():
    """A graded preset's fine zone holds the plate's path and its machine's deepest tip, each with at least 1.5 fine
    radii of fine grains beyond it (configs/presets.toml, resolutions.toml, machine.toml); the graded study's
    shallower zone (configs/studies/graded.toml) is a study's question, not a preset."""
    from analysis.core.config import load_preset, load_resolution
    from analysis.core.config import preset_names
    graded = [name for name in preset_names() if load_resolution(load_preset(name).resolution).graded]
    assert {"graded", "validation_graded"} <= set(graded)
    for name in graded:
        p = plan("clay", name)
        g, margin = p["graded"], 1.5 * 1000 * p["graded"]["radius"]
        assert 1000 * g["fine_width"] >= p["sleeve"]["outer_diameter"] + 2 * margin, name
        assert 1000 * g["fine_depth"] >= p["disk"]["penetration"] + margin, name
    with pytest.raises(ConfigError, match=r"fine_width = 100 mm is out of range: allowed > sleeve outer diameter 110 mm"):
        plan("clay", "graded", resolution="graded", tool={"sleeve.outer_diameter": 110.0})
    assert plan("clay", "graded", resolution="graded")["graded"]["coarse_radius"] == 0.008
    assert "graded" not in plan("clay", "quick")


@pytest.mark.parametrize("extra,pattern", [('machine = "tuned"', r"machine = 'tuned': allowed (\w+, )*surface"),
                                           ("awake = [60.0]", r"awake = \[60.0\]: allowed two lengths"),
                                           ("awake = [60.0, -5.0]", r"awake.ahead = -5.0 is out of range"),
                                           ("machine = 3", "machine = 3: must be a string"),
                                           ('soils = "calibrated"', "soils = 'calibrated': allowed table | bench")])
def test_a_presets_machine_and_awake_are_checked(tmp_path, extra, pattern):
    from analysis.core.config import load_preset
    text = (ROOT / "configs/presets.toml").read_text()
    start = text.index("[quick]")
    section = text[start:text.index("\n[", start + 1)]
    path = tmp_path / "presets.toml"
    path.write_text(section + "\n" + extra + "\n")
    with pytest.raises(ConfigError, match=pattern):
        load_preset("quick", path)


def test_a_bench_soils_preset_runs_each_soil_as_its_bench_calibration_left_it(tmp_path):
    """soils = "bench": every calibrated parameter at its posterior mean, the held ones as held, the shear bond equal
    to the normal one, the rest of [soil] kept, the bed settled as [soil] settles it; the soil's run is a new one.
    The posterior is the one kept in the folder the table names. A soil without a [bench_posterior] is refused naming
    the command that makes one."""
    import json
    import tomllib
    from analysis.core.soil_config import bench_soil, load_soil, posterior_folder
    for soil in ("clay", "loam", "sand"):
        post = tomllib.loads((ROOT / f"configs/soils/{soil}.toml").read_text())["bench_posterior"]
        table, bench = plan(soil, "validation_medium"), plan(soil, "bench_soils_medium")
        calibrated = [k for k, v in post.items() if isinstance(v, dict) and "mean" in v and k in bench["soil"]]
        assert {"normal_cohesion", "friction_deg", "rolling_friction"} <= set(calibrated), (soil, calibrated)
        for name in calibrated:
            assert bench["soil"][name] == post[name]["mean"], (soil, name)
        for name, value in post["fixed"].items():
            assert bench["soil"][name] == value, (soil, name)
        assert bench["soil"]["shear_cohesion"] == bench["soil"]["normal_cohesion"]
        drawn = json.loads((posterior_folder(soil) / f"{soil}-posterior.json").read_text())["mean"]
        assert {n: float(f"{drawn[n]:.4g}") for n in calibrated} == {n: post[n]["mean"] for n in calibrated}, soil
        if "young" not in calibrated:                      # the modulus: [soil]'s unless the bench calibrated it
            assert bench["soil"]["young"] == table["soil"]["young"]
        assert bench["id"] != table["id"]
        # the bed settles as the bench tests' beds did (as [soil] says): the same bed as the table soil's runs
        assert bench["bed_settled_as"] == {k: table["soil"][k] for k in bench["bed_settled_as"]}
        assert "bed_settled_as" not in table
        # a study's contact-law overrides change the contact law, not the bed: it still settles as the bench's did
        varied = plan(soil, "bench_soils_medium", overrides={"friction_deg": 7.5, "rolling_friction": 0.2})
        assert varied["bed_settled_as"] == bench["bed_settled_as"] and varied["soil"]["friction_deg"] == 7.5
        assert {k: v for k, v in bench["preset"].items() if k not in ("name", "soils")} == \
            {k: v for k, v in table["preset"].items() if k != "name"}
    bare = tmp_path / "clay.toml"
    text = (ROOT / "configs/soils/clay.toml").read_text()
    bare.write_text(text[:text.index("# GrainLearning's posterior")])
    with pytest.raises(ConfigError, match=r"no \[bench_posterior\].*calibrate --soil clay --bench"):
        bench_soil(load_soil(bare), bare)


@pytest.mark.parametrize("column, value", [("bulk_density_g_cm3", "-1.230"), ("moisture_percent", "-24.2"),
                                           ("cone_index_kPa", "0"), ("cone_index_kPa", "nan"),
                                           ("bulk_density_g_cm3", "heavy")])
def test_table2_is_ranged_like_every_other_config(tmp_path, column, value):
    """A negative density or moisture, a zero or NaN cone index in Table 2 is refused naming the column and
    its range; the committed table passes."""
    from analysis.core.soil_config import TABLE2, table2_row
    import pandas as pd
    t = pd.read_csv(TABLE2, comment="#", dtype=str)
    t.loc[t.soil == "clay", column] = value
    path = tmp_path / "table2.csv"
    t.to_csv(path, index=False)
    with pytest.raises(ConfigError, match=f"clay.{column} = .*(out of range|must be a number).*allowed"):
        table2_row("clay", "test", path)
    for soil in ("clay", "loam", "sand"):
        assert table2_row(soil, "test")["cone_index_kPa"] > 0


def test_bond_fragile_is_a_switch_in_a_config_and_in_an_override(tmp_path):
    from analysis.core.soil_config import load_soil, soil_with
    assert load_soil("clay").bond_fragile == 1.0 and soil_with(load_soil("clay"), {"bond_fragile": 0}).bond_fragile == 0
    with pytest.raises(ConfigError, match=r"bond_fragile = 0.5: must be a whole number in \[0, 1\]"):
        soil_with(load_soil("clay"), {"bond_fragile": 0.5})
    text = (ROOT / "configs/soils/clay.toml").read_text().replace("damping =", "bond_fragile = 0.3\ndamping =", 1)
    (tmp_path / "clay.toml").write_text(text)
    with pytest.raises(ConfigError, match=r"soil.bond_fragile = 0.3: must be a whole number in \[0, 1\]"):
        load_soil(tmp_path / "clay.toml")


def test_pressed_re_adhesion_is_off_unless_set_and_leaves_a_runs_id_as_it_was():
    """A soil without `pressed_adhesion` has none (0) and plans the run it planned before the key existed; set, it
    names a run of its own; out of its range it is refused with the range."""
    from analysis.core.run_spec import plan
    from analysis.core.soil_config import load_soil, soil_with
    assert load_soil("clay").pressed_adhesion == 0.0
    before = plan("clay", "validation_medium", seed=1)
    assert "pressed_adhesion" not in before["soil"]
    assert plan("clay", "validation_medium", seed=1, overrides={"pressed_adhesion": 0.0})["id"] == before["id"]
    assert plan("clay", "validation_medium", seed=1, overrides={"pressed_adhesion": 0.2})["id"] != before["id"]
    assert load_soil("clay").adhesion_onset == 0.0 and "adhesion_onset" not in before["soil"]     # nor its onset
    assert plan("clay", "validation_medium", seed=1, overrides={"adhesion_onset": 0.0})["id"] == before["id"]
    with pytest.raises(ConfigError, match=r"pressed_adhesion = 7.*out of range.*allowed"):
        soil_with(load_soil("clay"), {"pressed_adhesion": 7})
    assert "adhesion_share" not in before["soil"] and "tool_friction_deg" not in before["soil"]  # nor the share
    assert plan("clay", "validation_medium", seed=1, overrides={"adhesion_share": 0.0})["id"] == before["id"]  # law's
    assert plan("clay", "validation_medium", seed=1, overrides={"tool_friction_deg": 0.0})["id"] == before["id"]
    assert plan("clay", "validation_medium", seed=1, overrides={"tool_friction_deg": 25.0})["id"] != before["id"]


@pytest.mark.parametrize("overrides", [{"adhesion_share": 0.5, "pressed_adhesion": 0.3, "adhesion_onset": 4e4},
                                       {"adhesion_share": 0.5}])
def test_the_share_law_is_refused_beside_alpha_or_without_an_onset(overrides):
    """`adhesion_share` replaces α and acts from an onset: with α above 0, or no onset, it is refused naming both."""
    from analysis.core.soil_config import load_soil, soil_with
    with pytest.raises(ConfigError, match=r"adhesion_share = 0.5 with pressed_adhesion.*allowed"):
        soil_with(load_soil("clay"), overrides)
    assert soil_with(load_soil("clay"), {"adhesion_share": 0.5, "adhesion_onset": 4e4}).adhesion_share == 0.5


@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan])
def test_a_whole_number_key_refuses_inf_and_nan_with_its_range(value):
    from analysis.core.config import SEED
    with pytest.raises(ConfigError, match="out of range: allowed"):
        SEED.check("run.seed", value)


def test_the_parameter_page_is_not_written_from_an_invalid_config(tmp_path, monkeypatch, capsys):
    """`./holes params` checks every config as a run loads it: a bad disk value exits 2 and writes nothing."""
    import shutil
    from analysis import params_doc
    shutil.copytree(ROOT / "configs", tmp_path / "configs")
    disk = tmp_path / "configs/disk.toml"
    disk.write_text(disk.read_text().replace("N = 6", "N = 0", 1))
    page = tmp_path / "configs/README.md"
    before = page.read_text()
    monkeypatch.setattr(params_doc, "ROOT", tmp_path)
    monkeypatch.setattr(params_doc, "PATH", page)
    assert cli.main(["params"]) == 2
    assert "N = 0" in capsys.readouterr().err and page.read_text() == before


def test_a_resolution_by_its_grain_radius_is_the_same_resolution_and_the_same_run():
    """r6 and medium name one resolution: the same grains, the run planned with either has one id (kept runs and
    beds keep their keys); an unknown name lists both kinds."""
    from analysis.core.config import load_resolution
    assert load_resolution("r6") == load_resolution("medium") and load_resolution("r6").radius == 0.006
    for alias, name in (("r8", "coarse"), ("r5", "quick"), ("r4", "default"), ("r3", "fine")):
        assert load_resolution(alias).name == name and load_resolution(alias).radius == float(alias[1:]) / 1000
    assert plan("clay", "quick", resolution="r6")["id"] == plan("clay", "quick", resolution="medium")["id"]
    with pytest.raises(ConfigError, match=r"allowed r3, r4, r5, r6, r8 \(grain radius in mm\) or quick"):
        load_resolution("r7")


def test_each_validations_grain_size_strips_start_with_its_own_strip():
    """configs/presets.toml's `grain_size` beside `replicates`: the validation's strip, then the same at finer grains."""
    from analysis.core.config import grain_size_strips, load_preset, load_resolution
    strips = grain_size_strips()
    assert strips["bench_validation"][0] == "bench_validation_medium" and strips["validation"][0] == "validation_medium"
    for presets in strips.values():
        radii = [load_resolution(load_preset(p).resolution).radius for p in presets]
        assert radii == sorted(radii, reverse=True) and len(set(radii)) == len(radii) >= 3


def test_the_validation_replicates_the_main_jobs_runs_over_three_packings():
    """The validation preset is the main job's strip over packings 1-3: the same run ids, so packing 1 is the main
    job's run itself and never runs twice."""
    from analysis.core.config import replicated
    from analysis.core.run_spec import plan
    assert replicated("validation") == ("validation_medium", [1, 2, 3])
    assert replicated("validation_medium") == ("validation_medium", [1])
    for seed in (1, 2):
        assert plan("clay", "validation", seed=seed)["id"] == plan("clay", "validation_medium", seed=seed)["id"]


@pytest.mark.parametrize("body, field", [('replicates = "quick"\nseeds = [1]', "seeds"),
                                         ('replicates = "quick"\nseeds = [1, 1]', "seeds"),
                                         ('replicates = "quick"\nseeds = [0, 2]', "seeds"),
                                         ('replicates = "nothing"\nseeds = [1, 2]', "replicates"),
                                         ('replicates = "quick"\nseeds = [1, 2]\nholes = 3', "holes"),
                                         ('replicates = "quick"\nseeds = [1, 2]\ngrain_size = ["nowhere"]', "grain_size"),
                                         ('replicates = "quick"\nseeds = [1, 2]\ngrain_size = ["quick"]', "grain_size"),
                                         ('replicates = "quick"\nseeds = [1, 2]\ngrain_size = ["validation"]',
                                          "grain_size")])
def test_a_bad_replicating_preset_is_refused_naming_its_field(tmp_path, body, field):
    from analysis.core.config import load_preset
    path = tmp_path / "presets.toml"
    path.write_text((ROOT / "configs/presets.toml").read_text() + f"\n[again]\n{body}\n")
    with pytest.raises(ConfigError, match=rf"again\.{field}"):
        load_preset("again", path)
