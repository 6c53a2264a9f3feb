"""Batch studies: 4 tiny cases on 2 local workers with a kill and a resume; a failing case on a Dask
LocalCluster (2 workers over loopback TCP) is reported while the other finishes; bad study files."""
import json
import re
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from analysis import cli
from analysis.core.schema import ROOT, ConfigError
from analysis.core.io import read_table
from analysis.core.runner import scene_args
from analysis.batch.study import case_from_table_line, export_batch, load_study

# one punch passage on the test strip, fast (fewer steps): studies here test the batch machinery
TINY = {"soil": "clay", "preset": "test", "holes": 1, "lead_in": 0, "speed_kmh": 5.0}


def study_file(tmp_path, name, grid: dict, cases=()):
    lines = ["[study]", f'name = "{name}"', "[base]"]
    lines += [f"{k} = {json.dumps(v)}" for k, v in TINY.items()]
    lines += ["[grid]"] + [f'"{k}" = {json.dumps(v)}' for k, v in grid.items()]
    for c in cases:
        lines += ["[[case]]"] + [f'"{k}" = {json.dumps(v)}' for k, v in c.items()]
    path = tmp_path / f"{name}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def study(path, tmp_path, *args, wait=True, beds=None):
    cmd = [sys.executable, "-m", "analysis.cli", "study", str(path), "--runs-dir", str(tmp_path / "runs"),
           "--bed-dir", str(beds or tmp_path / "beds"), "--out", str(tmp_path / "studies"), *args]
    if not wait:
        return subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, cwd=ROOT,
                                start_new_session=True)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=1500, cwd=ROOT)


@pytest.mark.scene
def test_four_cases_on_two_workers_survive_a_kill_and_resume(tmp_path, scene_dirs):
    path = study_file(tmp_path, "four", {"speed_kmh": [4.0, 5.0], "sleeve.stiffness": [4.0, 8.0]})
    _, cases = load_study(path)
    ids = [c.id for c in cases]
    proc = study(path, tmp_path, "--workers", "2", "--threads", "1", wait=False, beds=scene_dirs[1])
    for line in proc.stderr:                 # kill the whole study when its table first holds a finished case
        if "table updated" in line:
            os.killpg(proc.pid, signal.SIGKILL)
            break
    proc.wait()
    done = [i for i in ids if (tmp_path / "runs" / i / "summary.json").exists()]
    assert 1 <= len(done) < 4
    assert set(read_table(tmp_path / "studies/four.csv").run) <= set(done)   # no row for a killed case
    stamps = {i: (tmp_path / "runs" / i / "summary.json").stat().st_mtime for i in done}

    r = study(path, tmp_path, "--workers", "2", "--threads", "1", beds=scene_dirs[1])
    assert r.returncode == 0, r.stderr[-3000:]
    # the cases the table already held are not in the batch; the others finished earlier or run now
    m = re.search(r"(\d+) cases, (\d+) finished earlier, (\d+) to run", r.stderr)
    assert m and int(m[3]) == 4 - len(done) and int(m[1]) - int(m[2]) == int(m[3]), r.stderr[-2000:]
    assert all((tmp_path / "runs" / i / "summary.json").stat().st_mtime == t for i, t in stamps.items())
    table = read_table(tmp_path / "studies/four.csv")
    assert sorted(table.run) == sorted(ids) and len(table) == 4
    assert {"speed_kmh", "sleeve.stiffness", "L0", "L1", "L2", "h1", "pass_rate", "wall_s", "particles",
            "steps"} <= set(table.columns)
    assert (table.L0 > 0).all() and (table.L2 > 0).all() and (table.steps > 0).all()
    assert (tmp_path / "studies/four.png").stat().st_size > 5000


@pytest.mark.scene
def test_a_failing_case_on_a_dask_cluster_is_reported_and_the_other_finishes(tmp_path, scene_dirs):
    distributed = pytest.importorskip("distributed")
    path = study_file(tmp_path, "dask", {"sleeve.stiffness": [2.0, 16.0]})
    _, cases = load_study(path)
    bad = cases[0].id
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / bad).write_text("a file where the run folder should go")   # the run cannot write
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1")
        r = study(path, tmp_path, "--scheduler", cluster.scheduler_address, "--threads", "1", beds=scene_dirs[1])
    assert r.returncode == 1
    assert "FAILED" in r.stderr and bad in r.stderr and f"{bad}.log" in r.stderr
    table = read_table(tmp_path / "studies/dask.csv")
    assert list(table.run) == [cases[1].id]


@pytest.mark.parametrize("grid, message", [
    ({"slip": [0.0, 1.5]}, r"case 2 \(.*slip=1\.5\): run\.slip = 1\.5 is out of range: allowed \[0, 0\.9\]"),
    ({"disk.Q": [1.0]}, r"case 1 \(.*disk\.Q=1\.0\): tool override 'disk\.Q': allowed disk\.<"),
    ({"colour": ["red"]}, r"case 1 \(.*colour=red\): run field 'colour': allowed soil, "),
    ({"sleeve.stiffness": [-1.0]}, r"sleeve\.stiffness = -1\.0 is out of range: allowed \[0, 10000\] N/mm"),
    ({"awake": [[60, 2000]]}, r"run\.awake\.ahead = 2000\.0 is out of range: allowed \[0, 1000\] mm")])
def test_a_bad_study_names_the_field_before_any_scene(tmp_path, grid, message, capsys):
    """The message names the bad case, its field and value, and that field's allowed range (a list of every
    field does not pass for naming one)."""
    path = study_file(tmp_path, "bad", grid)
    assert cli.main(["study", str(path), "--runs-dir", str(tmp_path / "runs"), "--bed-dir", str(tmp_path / "beds"),
                     "--out", str(tmp_path / "studies")]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err) and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "runs").exists() and not (tmp_path / "beds").exists()


def test_the_yade_batch_table_holds_the_same_cases(tmp_path):
    path = study_file(tmp_path, "table", {"slip": [0.0, 0.1]}, cases=[{"disk.D": 45.0}])
    _, cases = load_study(path)
    table = export_batch(path, tmp_path / "t.table")
    for line, c in enumerate(cases, start=2):
        description, fields = case_from_table_line(table, line)
        assert description == c.id
        assert scene_args(fields) == scene_args({k: str(v) for k, v in c.fields.items()})
    with pytest.raises(ConfigError, match="no cases"):
        load_study(study_file(tmp_path, "empty", {}))


def test_several_studies_run_as_one_batch_with_a_shared_case_once(tmp_path, monkeypatch):
    from analysis.batch import study as study_mod
    a = study_file(tmp_path, "a", {"slip": [0.0, 0.1]})
    (tmp_path / "b").mkdir()
    b = study_file(tmp_path / "b", "b", {"speed_kmh": [5.0, 4.0]})      # its 5 km/h case is a's slip 0 case
    batches = []
    monkeypatch.setattr(study_mod, "run_all", lambda batch, *a, **k: batches.append(batch) or [])
    monkeypatch.setattr(study_mod, "write_table", lambda *a, **k: None)
    study_mod.run([a, b], 2, 1, runs_dir=tmp_path / "runs", bed_dir=tmp_path / "beds", out=tmp_path / "out")
    ids = [c["id"] for c in batches[0]]
    assert len(ids) == 3 and len(set(ids)) == 3
    (tmp_path / "c").mkdir()
    with pytest.raises(ConfigError, match="share a name"):
        study_mod.run([a, study_file(tmp_path / "c", "a", {"slip": [0.2]})], 1, 1, runs_dir=tmp_path / "runs")


def test_a_slip_study_plots_the_theory_beside_the_holes(tmp_path):
    from analysis.batch.study import plot, theory_lines
    lines = theory_lines("slip", [0.25, 0.0, 0.1, 0.0])
    table1 = lines["theory: Table 1"]
    assert table1["x"] == [0.0, 0.1, 0.25]
    assert table1["L0"] == pytest.approx([96.5, 90.1, 78.8])            # seed 001 Table 1
    assert all(a > b for a, b in zip(lines["theory: swept envelope"]["C"], lines["theory: swept envelope"]["C"][1:]))
    assert theory_lines("speed_kmh", [1.0, 5.0]) == {}
    import pandas as pd
    table = pd.DataFrame({"slip": [0.0, 0.1], "L0": [110.0, 100.0], "L1": [70.0, 69.0], "L2": [40.0, 41.0],
                          "h1": [10.0, 11.0], "C": [200.0, 180.0], "pass_rate": [1.0, 0.5]})
    for H in (5, 30, 60):
        table[f"l_{H}"] = [100.0 - H / 2, 95.0 - H / 2]
    plot(table, {"name": "slip"}, tmp_path / "slip.png", "test")
    assert (tmp_path / "slip.png").stat().st_size > 10_000
    assert (tmp_path / "slip_depth.png").stat().st_size > 10_000      # l_H beside Table 1


def test_no_run_tables_only_what_finished_and_says_when_nothing_has(tmp_path, capsys):
    path = study_file(tmp_path, "none", {"slip": [0.0, 0.1]})
    args = ["study", str(path), "--no-run", "--runs-dir", str(tmp_path / "runs"), "--out", str(tmp_path / "out")]
    assert cli.main(args) == 1
    assert "no case has finished" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists() and not (tmp_path / "out").exists()      # nothing was run


def test_a_one_hole_study_plots_without_an_all_nan_metric(tmp_path):
    """One hole per case has no spacing C: its panel is left empty, not drawn from NaN (a RuntimeWarning)."""
    import warnings
    import pandas as pd
    from analysis.batch.study import plot
    nan = float("nan")
    table = pd.DataFrame({"run": ["a", "b"], "depth": [nan, 180.0], "L0": [100.0, 80.0], "L1": [50.0, 52.0],
                          "L2": [38.0, 27.0], "h1": [16.0, 19.0], "C": [nan] * 2, "pass_rate": [0.0, 0.0]})
    for m in ("L0", "L1", "L2", "h1", "C"):
        table[f"{m}_sd"] = nan                          # one hole: no SD
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot(table, {"name": "one-hole"}, tmp_path / "one.png", "test")
    assert (tmp_path / "one.png").stat().st_size > 10_000


def test_a_posterior_study_is_drawn_per_soil_not_against_its_many_varied_parameters(tmp_path, monkeypatch):
    """A `[posterior]` study varies every contact parameter at once: its picture is per soil (a point per sample's
    strip, a bar at the weighted mean), never a line per combination of the other parameters (plot_axes)."""
    import warnings
    import pandas as pd
    from analysis.batch import study as study_mod
    monkeypatch.setattr(study_mod, "plot_axes", lambda t: pytest.fail("a posterior study went through plot_axes"))
    table = pd.DataFrame({"run": list("abcd"), "soil": ["clay", "clay", "sand", "sand"],
                          "soil.friction_deg": [9.2, 7.7, 17.0, 15.0], "soil.damping": [0.1, 0.14, 0.12, 0.09],
                          "posterior_weight": [0.7, 0.3, 0.6, 0.4], "found": 8, "pass_rate": [0.5, 1.0, 0.25, 0.5],
                          **{m: [60.0, 66.0, 55.0, 57.0] for m in ("L0", "L1", "L2", "L2_surface", "h1", "C")},
                          **{f"{m}_sd": 3.0 for m in ("L0", "L1", "L2", "L2_surface", "h1", "C")}})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        study_mod.plot(table, {"name": "posterior"}, tmp_path / "p.png", "test")
    assert (tmp_path / "p.png").stat().st_size > 10_000


def test_a_committed_table_keeps_its_cases_on_a_new_machine(tmp_path, monkeypatch, capsys):
    """runs/ is not committed: on a new clone a study reruns only the cases missing from its table, and the
    table it rewrites keeps the rows it already had (same run id = same parameters, soil constants included)."""
    from analysis.batch import study as study_mod
    from analysis.core.io import atomic_csv
    import pandas as pd
    path = study_file(tmp_path, "kept", {"slip": [0.0, 0.1]})
    _, cases = load_study(path)
    out = tmp_path / "out"
    atomic_csv(pd.DataFrame([{"slip": 0.0, "run": cases[0].id, "L0": 101.5, "L1": float("nan")},
                             {"slip": 0.3, "run": "clay-test-prescribed-0ldca5e0", "L0": 99.0}]),
               out / "kept.csv", "an earlier machine")
    batches, written = [], []
    monkeypatch.setattr(study_mod, "run_all", lambda batch, *a, **k: batches.append(batch) or [])
    monkeypatch.setattr(study_mod, "plot", lambda table, *a: written.append(table))
    study_mod.run(path, 1, 1, runs_dir=tmp_path / "runs", bed_dir=tmp_path / "beds", out=out)
    assert [c["id"] for c in batches[0]] == [cases[1].id]           # the committed case is not run again
    kept = read_table(out / "kept.csv")
    assert list(kept.run) == [cases[0].id] and kept.L0[0] == 101.5   # a row of another case is not kept
    assert "1 of its rows are runs this study no longer makes" in capsys.readouterr().err
    assert written[0].L1.dtype == float          # a missing value stays NaN (None made the plot fail)


def test_a_stamp_names_the_code_the_process_runs(monkeypatch):
    """A long run outlives later commits: its table is stamped with the commit the process loaded, and
    says so when the checkout moved on while it ran."""
    from analysis.core import io
    assert f"at commit {io.head()} on" in io.stamp("x")
    monkeypatch.setattr(io, "LOADED", "0000000")
    assert f"at commit 0000000 (the checkout moved to {io.head()} while it ran) on" in io.stamp("x")


def test_a_case_that_cannot_be_measured_is_reported_and_the_table_still_updates(tmp_path, monkeypatch, capsys):
    from analysis.batch import study as study_mod
    path = study_file(tmp_path, "three", {"slip": [0.0, 0.1, 0.2]})
    _, cases = load_study(path)

    def case_row(c, runs_dir, criteria):
        if c.id == cases[1].id:
            raise ValueError("no hole where the punch entered")
        return {"slip": c.fields["slip"], "run": c.id, "L0": 100.0}
    monkeypatch.setattr(study_mod, "run_all", lambda *a, **k: [])
    monkeypatch.setattr(study_mod, "finished", lambda runs_dir, case_id: True)
    monkeypatch.setattr(study_mod, "case_row", case_row)
    monkeypatch.setattr(study_mod, "plot", lambda *a: None)
    assert study_mod.run(path, 1, 1, runs_dir=tmp_path / "runs", bed_dir=tmp_path / "beds", out=tmp_path) == 1
    assert list(read_table(tmp_path / "three.csv").run) == [cases[0].id, cases[2].id]
    err = capsys.readouterr().err
    assert f"FAILED to measure {cases[1].id}" in err and "no hole where the punch entered" in err


def test_a_sensitivity_sets_each_case_beside_the_comparisons_holes_of_its_soil(tmp_path):
    """[study] against = PRESET: a case's mean 3 mm over the comparison's, with a tight scatter, is resolved and
    its shift reported in field units; a metric the scatter swamps is not; a soil the comparison lacks is left out."""
    import pandas as pd
    from analysis.batch.study import effect_table
    comparison = tmp_path / "comparison.csv"
    pd.DataFrame([{"preset": "validation_surface", "soil": "clay", "metric": m, "field_mean": 60.0, "sim_mean": 50.0,
                   "sim_sd": 1.0, "n_holes": 8} for m in ("h1", "L0")]
                 + [{"preset": "quick", "soil": "loam", "metric": "h1", "field_mean": 15.0, "sim_mean": 1.0,
                     "sim_sd": 1.0, "n_holes": 2}]).to_csv(comparison, index=False)
    table = pd.DataFrame([{"run": "a", "soil": "clay", "found": 4, "h1": 53.0, "h1_sd": 0.5, "L0": 53.0, "L0_sd": 20.0},
                          {"run": "b", "soil": "loam", "found": 4, "h1": 3.0, "h1_sd": 0.5}])
    effect = effect_table(table, "validation_surface", comparison).set_index("metric")
    assert list(effect.run) == ["a", "a"]
    assert effect.loc["h1", "shift"] == pytest.approx(3.0) and effect.loc["h1", "resolved"]
    assert effect.loc["h1", "shift_pct_of_field"] == pytest.approx(5.0)
    assert not effect.loc["L0", "resolved"] and effect.loc["L0", "shift_lo"] < 0 < effect.loc["L0", "shift_hi"]


def test_a_sensitivity_against_an_unknown_preset_names_it(tmp_path):
    path = study_file(tmp_path, "s", {"seed": [1]})
    path.write_text(path.read_text().replace('name = "s"', 'name = "s"\nagainst = "validation_fine"'))
    with pytest.raises(ConfigError, match="validation_fine"):
        load_study(path)


@pytest.mark.parametrize("header, message", [
    ('name = "x"\nagaints = "quick"', r"\[study\] has unknown key\(s\) againts: allowed name, description, against"),
    ('name = "../../x"', r"name = '\.\./\.\./x': allowed a plain file name"),
    ('name = ""', r"name = '': allowed a plain file name"),
    ('name = ".hidden"', r"name = '\.hidden': allowed a plain file name")])
def test_a_study_header_is_checked_and_its_name_is_a_plain_file_name(tmp_path, header, message, capsys):
    """A misspelt key would silently drop the sensitivity table; a name with a path would write outside --out."""
    path = study_file(tmp_path, "h", {"slip": [0.0]})
    path.write_text(path.read_text().replace('[study]\nname = "h"', f"[study]\n{header}"))
    assert cli.main(["study", str(path), "--runs-dir", str(tmp_path / "runs"), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err) and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "s").exists() and not (tmp_path / "runs").exists()


def test_export_batch_refuses_options_it_would_ignore(tmp_path, capsys):
    path = study_file(tmp_path, "e", {"slip": [0.0]})
    assert cli.main(["study", str(path), "--export-batch", str(tmp_path / "t.table"), "--no-run"]) == 2
    assert "--export-batch" in capsys.readouterr().err and not (tmp_path / "t.table").exists()


def morris_file(tmp_path, morris: str) -> Path:
    path = tmp_path / "screen.toml"
    path.write_text('[study]\nname = "screen"\n[base]\n' + "".join(f"{k} = {json.dumps(v)}\n" for k, v in TINY.items())
                    + morris)
    return path


MORRIS = ('[morris]\ntrajectories = 3\nlevels = 4\nseed = 0\n[morris.bounds]\n"disk.penetration" = [60.0, 75.0]\n'
          '"sleeve.stiffness" = [1.0, 8.0]\n')


def test_a_morris_section_makes_one_case_per_design_point_and_the_screening_ranks_them(tmp_path):
    """The design's points become cases (3 trajectories over 2 fields: 9 points, some shared); a made-up table
    where L2 follows P and hardly the spring ranks P first; a trajectory with a point not finished is left out of
    the screening."""
    import pandas as pd
    from analysis.batch.study import screening
    head, cases = load_study(morris_file(tmp_path, MORRIS))
    design = head["morris"]["design"]
    assert len(design) == 9 and len(cases) == len({tuple(row) for row in design})      # a shared point runs once
    table = pd.DataFrame([{**c.fields, "L2": 0.9 * c.fields["disk.penetration"] + 0.1 * c.fields["sleeve.stiffness"]}
                          for c in cases])
    ranks = screening(table, head["morris"], ["L2"])
    assert list(ranks.field) == ["disk.penetration", "sleeve.stiffness"] and set(ranks.trajectories) == {3}
    assert set(screening(table.iloc[1:], head["morris"], ["L2"]).trajectories) == {2}


def test_the_screening_says_which_field_stands_above_the_holes_scatter(tmp_path):
    """With each case's holes' SD in the table, a field that moves L2 by 13 mm over its range stands above what
    2-hole means scattering by 2 mm give, and a field that moves it by nothing stays under."""
    import pandas as pd
    from analysis.batch.study import screening
    head, cases = load_study(morris_file(tmp_path, MORRIS.replace("trajectories = 3", "trajectories = 6")))
    rng = np.random.default_rng(3)
    table = pd.DataFrame([{**c.fields, "L2": 0.9 * c.fields["disk.penetration"] + rng.normal(0, 2 / np.sqrt(2)),
                           "L2_sd": 2.0, "found": 2} for c in cases])
    ranks = screening(table, head["morris"], ["L2"]).set_index("field")
    assert ranks.loc["disk.penetration", "above_noise"] and not ranks.loc["sleeve.stiffness", "above_noise"]
    assert 2.0 < ranks.loc["sleeve.stiffness", "mu_star_noise95"] < 8.0


@pytest.mark.parametrize("change, message", [("levels = 4", "levels = 5"), ("trajectories = 3", "trajectories = 1"),
                                             ('"sleeve.stiffness" = [1.0, 8.0]', '"sleeve.stiffness" = [8.0, 1.0]'),
                                             ("seed = 0", "colour = 0")])
def test_a_bad_morris_section_is_refused_naming_its_key(tmp_path, change, message):
    with pytest.raises(ConfigError, match=r"morris|\[morris\]"):
        load_study(morris_file(tmp_path, MORRIS.replace(change, message)))


def test_a_study_plot_is_drawn_against_its_fields_not_against_what_its_runs_measured():
    """The energy balance's residual differs run to run; it is a reading of the run, never a line of the plot."""
    import pandas as pd
    from analysis.batch.study import plot_axes
    table = pd.DataFrame({"soil": ["clay", "sand"], "soil.damping": [0.1, 0.1], "energy_residual_pct": [3.3, 3.4],
                          "residual_flag": [False, True], "L2": [44.5, 37.9]})
    x, group, _ = plot_axes(table)
    assert (x, group) == ("soil", None)


def test_a_sensitivity_sets_a_case_beside_its_own_packings_holes_where_the_comparison_kept_them(tmp_path):
    """A case on packing 1 is set beside the comparison's packing-1 holes alone (the packing leaves the shift); a
    case on a packing the comparison's holes lack falls back to every packing's mean."""
    import pandas as pd
    from analysis.batch.study import effect_table
    comparison = tmp_path / "comparison.csv"
    pd.DataFrame([{"preset": "validation", "soil": "sand", "metric": "L2", "field_mean": 54.0, "sim_mean": 45.0,
                   "sim_sd": 4.0, "n_holes": 16}]).to_csv(comparison, index=False)
    (tmp_path / "comparison" / "validation").mkdir(parents=True)
    holes = [{"soil": "sand", "seed": s, "found": True, "L2": v} for s, base in ((1, 42.0), (2, 48.0))
             for v in (base - 1, base, base + 1, base)]
    holes.append({"soil": "sand", "seed": 1, "found": False, "L2": 90.0})      # not a hole: never read
    pd.DataFrame(holes).to_csv(tmp_path / "comparison" / "validation" / "holes.csv", index=False)
    table = pd.DataFrame([{"run": "p1", "soil": "sand", "seed": 1, "found": 8, "L2": 38.0, "L2_sd": 1.0},
                          {"run": "p3", "soil": "sand", "seed": 3, "found": 8, "L2": 38.0, "L2_sd": 1.0}])
    effect = effect_table(table, "validation", comparison).set_index("run")
    assert effect.loc["p1", "packings"] == "1" and effect.loc["p1", "validation_holes"] == 4
    assert effect.loc["p1", "shift"] == pytest.approx(-4.0) and effect.loc["p1", "resolved"]
    assert effect.loc["p3", "packings"] == "all" and effect.loc["p3", "shift"] == pytest.approx(-7.0)


POSTERIOR = """[study]
name = "post"
[base]
preset = "bench_soils_medium"
seed = 1
[posterior]
soils = ["clay"]
share = 0.85
samples = 4
"""


def made_up_posterior(bench):
    """A finished clay filter in `bench`: two iterations, the last one's weights 0.6, 0.3, 0.08, 0.02."""
    import pandas as pd
    bench.mkdir()
    rows = [{"iteration": it, "normal_cohesion": 8e4 + 1e4 * i, "friction_deg": 8.0 + i, "pressed_adhesion": 0.1,
             "rolling_friction": 0.2, "damping": 0.1 + 0.01 * i, "weight_last": w}
            for it, weights in ((1, [None] * 4), (2, [0.02, 0.6, 0.08, 0.3])) for i, w in enumerate(weights)]
    pd.DataFrame(rows).to_csv(bench / "clay.csv", index=False)
    (bench / "clay-posterior.json").write_text(json.dumps({
        "names": ["normal_cohesion", "friction_deg", "pressed_adhesion", "rolling_friction", "damping"],
        "fixed": {"new_contact_cohesion": 0.0, "bond_fragile": 0}}))


def test_a_posterior_section_runs_the_heaviest_samples_with_their_weights(tmp_path, monkeypatch):
    """[posterior]: the last iteration's samples by weight until they hold 85 % (0.6 + 0.3), each a case setting every
    calibrated parameter, the shear bond equal to the normal one and the fixed values; the weights renormalised over
    those taken; the budget's soil part is 1.96 × their holes' weighted SD. A soil without a finished filter, or a
    share out of its range, is refused naming the key."""
    import pandas as pd
    from analysis.core import soil_config
    from analysis.holes.budget_report import posterior_parts
    made_up_posterior(tmp_path / "bench")
    monkeypatch.setattr(soil_config, "posterior_folder", lambda soil: tmp_path / "bench")
    path = tmp_path / "post.toml"
    path.write_text(POSTERIOR)
    head, cases = load_study(path)
    assert [c.fields["soil.friction_deg"] for c in cases] == [9.0, 11.0]
    weights = [head["posterior"][c.id] for c in cases]
    assert np.allclose(weights, [0.6 / 0.9, 0.3 / 0.9])
    for c in cases:
        s = c.params["soil"]
        assert s["shear_cohesion"] == s["normal_cohesion"] == c.fields["soil.normal_cohesion"]
        assert s["new_contact_cohesion"] == 0 and s["bond_fragile"] == 0 and s["damping"] == c.fields["soil.damping"]
    table = pd.DataFrame({"soil": "clay", "posterior_weight": weights, "L2": [60.0, 57.0], "h1": [10.0, np.nan]})
    from analysis.batch.study import plot_axes
    assert plot_axes(table.assign(**{"soil.friction_deg": [9.0, 11.0]}))[0] == "soil.friction_deg"   # a weight is no field
    part = posterior_parts(table, ["L2", "h1"])
    assert list(part.metric) == ["L2"]                 # h1 has one strip measured: no spread
    assert part.soil_part.iloc[0] == pytest.approx(1.96 * 3 * np.sqrt(2 / 9 / (1 - 5 / 9)))
    path.write_text(POSTERIOR.replace("share = 0.85", "share = 1.5"))
    with pytest.raises(ConfigError, match=r"posterior\.share = 1\.5: allowed"):
        load_study(path)
    path.write_text(POSTERIOR.replace('["clay"]', '["sand"]'))
    with pytest.raises(ConfigError, match=r"sand: no finished bench calibration.*calibrate --soil sand --bench"):
        load_study(path)
