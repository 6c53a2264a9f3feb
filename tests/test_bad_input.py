"""Every Field of every command refuses every value outside it, generated from the Field itself (as scikit-learn
generates invalid parameter values), so a new key is covered without a new test: a run's own fields, its preset's,
the disk's, the sleeve's and the soil's through a run's overrides and a bench calibration's prior, and every
command-line option typed by a Field, each refused before anything runs (in-process: no YADE, nothing written)
with the field and its allowed range."""
import argparse
import json
import math
import shutil

import pytest

from analysis import cli
from analysis.core.config import DISK_FIELDS, PRESET_FIELDS, SLEEVE_FIELDS
from analysis.core.schema import invalid_values, ConfigError, Field
from analysis.core.soil_config import SOIL_FIELDS
from analysis.core.run_spec import RUN_FIELDS, arguments, plan
from analysis.soil import bench_calibration as bench

SPEC_FIELDS = {k: f for k, f in {**RUN_FIELDS, **PRESET_FIELDS}.items()
               if "." not in k and k in plan.__globals__["RunSpec"].__dataclass_fields__ and f.kind is not str
               and k != "awake"}
# a run with a weight and a stop needs free mode; awake and tilled are pairs (test_disk's list checks them)
NEEDS = {"weight": {"mode": "free"}, "depth_stop": {"mode": "free", "weight": 100.0},
         "disk_inertia": {"mode": "free"}}


def cases(schema: dict, skip=()):
    return [(key, bad) for key, field in schema.items() if key not in skip for bad in invalid_values(field)]


def refused(call, key: str):
    with pytest.raises(ConfigError) as e:
        call()
    message = str(e.value)
    assert key in message and ("allowed" in message or "must be" in message), message
    assert "\n" not in message


@pytest.mark.parametrize("key, bad", cases(SPEC_FIELDS), ids=str)
def test_a_runs_own_fields(key, bad):
    refused(lambda: plan("clay", "test", **{**NEEDS.get(key, {}), key: bad}), key)


@pytest.mark.parametrize("key, bad", cases(DISK_FIELDS), ids=str)
def test_the_disks_fields_through_a_run(key, bad):
    refused(lambda: plan("clay", "test", tool={f"disk.{key}": bad}), key)


@pytest.mark.parametrize("key, bad", cases(SLEEVE_FIELDS), ids=str)
def test_the_sleeves_fields_through_a_run(key, bad):
    refused(lambda: plan("clay", "test", tool={f"sleeve.{key}": bad}), key)


@pytest.mark.parametrize("key, bad", cases(SOIL_FIELDS), ids=str)
def test_the_soils_fields_through_a_run(key, bad):
    refused(lambda: plan("clay", "test", overrides={key: bad}), key)


BENCH_PRIOR = {k: f for k, f in SOIL_FIELDS.items() if k in bench.load_config()["bounds"]}


def bench_prior(tmp_path, key: str, rng: str):
    """A bench config laid over the default one whose clay prior sets `key` to the TOML array `rng`."""
    shutil.copy(bench.CONFIG, tmp_path)
    path = tmp_path / "b.toml"
    path.write_text(f'base = "{bench.CONFIG.name}"\n[soil_bounds.clay]\n{key} = {rng}\n')
    return path


@pytest.mark.parametrize("key, bad", cases(BENCH_PRIOR), ids=str)
def test_the_soils_fields_in_a_bench_prior(key, bad, tmp_path):
    """A prior reaching past a contact parameter's range, or not a number, is refused as the bench config is read,
    before any evaluation draws from it."""
    def toml(v):
        return json.dumps(v) if isinstance(v, str) else repr(v)
    high = bad + 1 if isinstance(bad, (int, float)) else bad
    path = bench_prior(tmp_path, key, f"[{toml(bad)}, {toml(high)}]")
    refused(lambda: bench.load_config(path, soil="clay"), f"soil_bounds.clay.{key}")


def test_calibrate_refuses_a_prior_past_a_fields_range_with_exit_2(tmp_path, capsys, monkeypatch):
    """`calibrate --bench` reads its config before any scene: a prior past a field's range exits 2 naming it."""
    def scene(*_):
        raise AssertionError("a scene started")
    for module in ("bench_calibration", "cell"):
        monkeypatch.setattr(f"analysis.soil.{module}.run_logged", scene)
    path = bench_prior(tmp_path, "pressed_adhesion", "[0.5, 6.0]")
    assert cli.main(["calibrate", "--soil", "clay", "--bench", "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert "soil_bounds.clay.pressed_adhesion = 6.0" in err and "allowed [0, 5]" in err and "Traceback" not in err, err


def typed_options(parser: argparse.ArgumentParser, prefix=()):
    """Every (command words, option, Field) of a parser and its subcommands whose type is a Field's."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from typed_options(sub, (*prefix, name))
        elif getattr(action.type, "field", None) is not None and action.option_strings:
            yield prefix, action.option_strings[0], action.type.field


def scene_parsers():
    """The YADE scenes' own command lines (parsed before any scene starts)."""
    from scripts import beds, collapse, cone, shear
    return {("bed",): beds.bed_arguments("bed", "100,100,100"), ("cone",): cone.arguments(),
            ("shear",): shear.arguments(), ("collapse",): collapse.arguments(), ("run",): arguments()}


OPTIONS = [*typed_options(cli.build_parser()),
           *(o for words, parser in scene_parsers().items() for o in typed_options(parser, words))]


def test_every_field_typed_option_is_found():
    names = {(c, o) for c, o, _ in OPTIONS}
    assert {(("compare",), "--seeds"), (("run",), "--threads"), (("cone",), "--cone-scale"), (("shear",), "--stress"),
            (("bed",), "--threads")} <= names and len(names) > 20


@pytest.mark.parametrize("command, option, field", OPTIONS, ids=lambda v: " ".join(v) if isinstance(v, tuple) else
                         (v if isinstance(v, str) else ""))
def test_every_field_typed_option_refuses_every_value_outside_its_field(command, option, field, capsys):
    for bad in invalid_values(field):
        text = "x" if isinstance(bad, str) else (repr(bad) if not math.isfinite(bad) else f"{bad:g}")
        with pytest.raises(SystemExit) as e:
            if command in scene_parsers():
                scene_parsers()[command].parse_args(["--soil", "clay", f"{option}={text}"])
            else:
                cli.main([*command, f"{option}={text}"])
        err = capsys.readouterr().err.strip()
        assert e.value.code == 2 and option in err and "allowed" in err and "\n" not in err, (bad, err)


def test_invalid_values_leave_a_valid_value_alone():
    f = Field(0.0, 1.0)
    for bad in invalid_values(f):
        with pytest.raises(ConfigError):
            f.check("x", bad)
    assert f.check("x", 0.5) == 0.5


def test_a_preload_not_above_every_normal_stress_is_refused_before_any_bed_settles(capsys, monkeypatch):
    from scripts import beds, shear
    monkeypatch.setattr(beds, "bed_from_args", lambda a: pytest.fail("a bed settled"))
    assert shear.main(["--soil", "clay", "--stress", "10,20", "--preload", "20"]) == 2
    err = capsys.readouterr().err
    assert "--preload" in err and "allowed above the highest --stress" in err
