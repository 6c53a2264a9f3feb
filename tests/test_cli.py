"""Bad input on the command line: refused with the option, its allowed range and exit code 2, before any scene
starts and without writing anything (in-process where the command line is parsed in-process)."""
import subprocess
import sys

import pytest

from analysis import cli
from analysis.core.schema import ROOT, ConfigError


@pytest.mark.parametrize("argv, field", [
    (["study", "configs/studies/slip.toml", "--threads", "0"], "--threads"),
    (["compare", "--threads", "0"], "--threads"),
    (["compare", "--workers", "0"], "--workers"),
    (["compare", "--seeds", "1,x"], "--seeds"),
    (["compare", "--seeds", "-1"], "--seeds"),
    (["calibrate", "--soil", "clay", "--seeds", "1,abc"], "--seeds"),
    (["calibrate", "--soil", "clay", "--cohesion-range", "abc"], "--cohesion-range"),
    (["calibrate", "--soil", "clay", "--cohesion-range", "70000,30000"], "--cohesion-range"),
    (["calibrate", "--soil", "clay", "--cone-speed", "-1"], "--cone-speed"),
    (["cone-checks", "--workers", "0"], "--workers"),
    (["report", "/nonexistent"], "/nonexistent"),
    (["measure", "/nonexistent"], "/nonexistent"),
    (["rings", "/nonexistent"], "/nonexistent"),
    (["pepper", "--starts", "0"], "--starts"),
    (["pepper-frame", "--screen", "x"], "--screen"),
    (["bench", "ladder", "--threads", "0"], "--threads"),
])
def test_bad_option_exits_2_naming_it_and_its_range(argv, field, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main([*argv, *(["--runs-dir", str(tmp_path / "runs")] if argv[0] == "compare" else [])])
    err = capsys.readouterr().err
    assert e.value.code == 2 and field in err and "allowed" in err, err
    assert "Traceback" not in err and not (tmp_path / "runs").exists()


def test_a_scene_refuses_zero_threads_before_it_plans():
    from analysis.core.run_spec import plan_from_argv
    with pytest.raises(ConfigError, match=r"--threads = 0 is out of range: allowed \[1, 64\]"):
        plan_from_argv(["--soil", "clay", "--preset", "test", "--threads", "0"])


@pytest.mark.parametrize("option, value", [("--cone-speed", "-1"), ("--cone-scale", "0"), ("--depth", "0"),
                                           ("--cohesion", "-5"), ("--cohesion", "nan")])
def test_the_cone_checks_its_own_numbers_before_settling_a_bed(tmp_path, option, value):
    r = subprocess.run([sys.executable, str(ROOT / "scripts/cone.py"), "--soil", "clay", "--bed-dir", str(tmp_path),
                        option, value], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 2 and "allowed" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not any(tmp_path.iterdir())                  # no bed was settled


def test_one_slip_range_for_the_disk_config_and_a_run():
    from analysis.core.config import DISK_FIELDS
    from analysis.core.run_spec import RUN_FIELDS
    assert DISK_FIELDS["slip"] is RUN_FIELDS["slip"]


@pytest.mark.parametrize("argv", [["compare", "--kep", "--no-run"], ["compare", "--pre", "quick", "--no-run"]])
def test_an_abbreviated_option_is_refused(argv, capsys):
    """argparse would take `--kep` for `--kept`: every command names its options in full."""
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2 and "unrecognized arguments" in capsys.readouterr().err


def test_a_scene_refuses_an_abbreviated_option():
    from analysis.core.run_spec import plan_from_argv
    with pytest.raises(SystemExit) as e:
        plan_from_argv(["--soil", "clay", "--preset", "test", "--speed", "3"])
    assert e.value.code == 2


@pytest.mark.parametrize("argv, field", [(["calibrate", "--soil", "peat"], "peat"),
                                         (["calibrate", "--soil", "clay", "--resolution", "huge"], "huge"),
                                         (["calibrate", "--soil", "clay", "--size", "450,450"], "size"),
                                         (["calibrate", "--soil", "clay", "--size", "a,b,c"], "--size")])
def test_calibrate_refuses_bad_soils_resolutions_and_sizes_with_exit_2(argv, field, capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert field in err and "allowed" in err and "Traceback" not in err, err


def test_a_stored_cone_run_at_zero_cohesion_is_found_without_dividing_by_it():
    """The default cohesion range starts at 0 Pa: looking a run up there must not divide by zero."""
    from analysis.soil.calibrate import same_cohesion
    assert same_cohesion({"cohesion_pa": 0.0}, 0.0) and not same_cohesion({"cohesion_pa": 5000.0}, 0.0)
    assert same_cohesion({"cohesion_pa": 48000.0}, 48000.0 * (1 + 1e-4))


@pytest.mark.parametrize("damage", ["no summary", "bad summary", "bad state", "empty state"])
@pytest.mark.parametrize("command", [["measure"], ["report"], ["rings", "--out", "OUT"], ["refill", "--out", "OUT"]])
def test_a_broken_run_folder_is_refused_in_one_line(tmp_path, capsys, damage, command):
    """A kept run copied whole, then one of its files missing or corrupt: every command that reads a run says so
    in one line with exit 2, no traceback, and writes nothing."""
    import shutil
    run = tmp_path / "run"
    kept = ROOT / "tests/data/kept_run"
    shutil.copytree(kept, run)
    if damage == "no summary":
        (run / "summary.json").unlink()
    elif damage == "bad summary":
        (run / "summary.json").write_text("{")
    elif damage == "bad state":
        (run / "state.npz").write_bytes(b"not a zip")
    else:
        import numpy as np
        np.savez(run / "state.npz", other=np.zeros(3))
    before = sorted(p.name for p in run.iterdir())
    argv = [c if c != "OUT" else str(tmp_path / "out") for c in command]
    assert cli.main([*argv[:1], str(run), *argv[1:]]) == 2
    err = capsys.readouterr().err.strip()
    assert str(run) in err and "allowed" in err and "\n" not in err and "Traceback" not in err, err
    assert sorted(p.name for p in run.iterdir()) == before and not (tmp_path / "out").exists()


@pytest.mark.parametrize("option", ["--out", "--runs-dir", "--bed-dir"])
def test_a_folder_option_that_is_a_file_is_refused_before_anything_runs(tmp_path, option, capsys):
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(SystemExit) as e:
        cli.main(["compare", "--no-run", option, str(afile)])
    err = capsys.readouterr().err
    assert e.value.code == 2 and option in err and "this is a file" in err


@pytest.mark.parametrize("command", [["compare"], ["study", "configs/studies/slip.toml"]])
def test_a_scheduler_that_is_not_an_address_is_refused(command, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main([*command, "--scheduler", "notaurl"])
    assert e.value.code == 2 and "--scheduler" in capsys.readouterr().err


def test_a_write_that_fails_leaves_no_temporary_file(tmp_path, monkeypatch):
    """A full disk found mid-write: the error goes up, the old file stays whole and no temporary file is left."""
    from pathlib import Path
    from analysis.core.io import atomic_write
    target = tmp_path / "table.csv"
    target.write_text("old\n")

    def full(self, data, *a, **k):
        Path.write_bytes(self, b"par")
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OSError, match="No space"):
        atomic_write(target, "new\n")
    monkeypatch.undo()
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


@pytest.mark.parametrize("argv", [["study", "configs"], ["calibrate-machine", "configs", "--no-run"],
                                  ["theory", "--disk", "configs"], ["cone-checks", "configs", "--no-run"]])
def test_a_folder_where_a_config_file_is_expected_is_refused(argv, capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "allowed a TOML config file" in err and "\n" not in err
