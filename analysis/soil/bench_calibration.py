"""The soils' bench calibration: the contact parameters of configs/bench_calibration.toml per soil (intact bond
strength, inter-particle friction, the cohesion a contact gets when it forms after disturbance, rolling friction)
fitted with GrainLearning's Bayesian filter
(analysis/soil/bayes.py) to the direct shear box's c and φ and the collapse test's slope
(configs/field/soil_targets.csv), and where a soil's bench settings say so (`cone_target`) to the cone index of
Table 2 too, every evaluation a YADE run of scripts/shear.py and scripts/collapse.py (and scripts/cone.py) in its
own folder, results/calibration/bench/<soil>/<id>/, reused when the filter asks for it again (the filter's
samples repeat themselves: its random state is fixed), so a stopped calibration resumes. The holes never enter.
The prior is the config's common ranges, or a soil's own narrower ones (`[soil_bounds.<soil>]`); the response
surfaces (`response_surfaces`, `feasible_region`) say where in the common prior a soil's targets lie. The
posterior mean is checked on three packings and on the cone beside Table 2 (`check`, `cone_check`).
"""
from __future__ import annotations

import io
import json
import math
import re
import sys
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from analysis.core.config import SEED
from analysis.core.io import atomic_csv, atomic_write, say, shown
from analysis.core.runner import run_logged
from analysis.core.schema import ROOT, ConfigError, Field, digest, read_toml
from analysis.core.soil_config import BENCH_DIR, SOIL_COLOURS
from analysis.soil.collapse import FLOORS
from analysis.soil.shear import READING, fit_tests

CONFIG = ROOT / "configs/bench_calibration.toml"
TARGETS = ROOT / "configs/field/soil_targets.csv"
TOOL_FRICTION = ROOT / "configs/field/tool_friction.csv"
TOOL_FRICTIONS = ("grain", "field")   # [cone_check] tool_friction: the lesser of the grain's and the steel's, or the soil's
RESPONSES = ("c_kpa", "phi_deg", "collapse_deg")
SHEAR_RESPONSES = ("c_kpa", "phi_deg")    # the shear box's: what its size check moves
SHIFT_LIMIT = {"c_kpa": 20.0, "phi_deg": 10.0}   # the largest [bench] shear_shift: a cell this far off is no sized cell
UNTESTABLE = 3         # a bench scene's exit code when it stopped the test itself (scripts/shear.py, scripts/collapse.py)
SCENES_VERSION = 3     # raised whenever scripts/shear.py or scripts/collapse.py measure otherwise: no stale evaluation is reused


def laid_over(path: Path, seen: tuple = ()) -> dict:
    r"""A bench config's tables; one naming a `base` config (a file beside it) is that config with its own tables laid
    over it key by key, a table within a table likewise (a filter's variant that states only what differs).

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "a.toml").write_text("[bench]\nx = 1\ny = 2\n[soil_bounds.clay]\nf = [1, 2]\n")
    >>> _ = (d / "b.toml").write_text('base = "a.toml"\n[bench]\ny = 3\n[soil_bounds.clay]\ng = [0, 1]\n')
    >>> laid_over(d / "b.toml")
    {'bench': {'x': 1, 'y': 3}, 'soil_bounds': {'clay': {'f': [1, 2], 'g': [0, 1]}}}
    """
    cfg = tomllib.loads(Path(path).read_text())
    base = cfg.pop("base", None)
    if base is None:
        return cfg
    chain = (*seen, Path(path).resolve())
    if not isinstance(base, str) or not (Path(path).parent / base).is_file() or \
            (Path(path).parent / base).resolve() in chain:
        raise ConfigError(f"{path}: base = {base!r}: allowed the name of another bench config beside it, not one "
                          "laid over this one")

    def over(a: dict, b: dict) -> dict:
        return {**a, **{k: over(a[k], v) if isinstance(v, dict) and isinstance(a.get(k), dict) else v
                        for k, v in b.items()}}
    return over(laid_over(Path(path).parent / base, chain), cfg)


def load_config(path: Path = CONFIG, soil: str | None = None) -> dict:
    """The calibration's settings and its parameters' prior ranges, checked; with `soil`, the ranges its
    `[soil_bounds.<soil>]` table narrows replace the common ones, its `[soil_bench.<soil>]` settings the common
    [bench] ones and its `[soil_cone_check.<soil>]` ones the common [cone_check] ones."""
    from analysis.core.soil_config import SOIL_FIELDS, SOILS
    cfg = laid_over(Path(path))
    bench, bounds, fixed = dict(cfg.get("bench", {})), dict(cfg.get("bounds", {})), cfg.get("fixed", {})
    per_soil = cfg.get("soil_bounds", {})
    cone = dict(cfg["cone_check"]) if "cone_check" in cfg else None
    own_settings = {"soil_bench": ("bench", bench), "soil_cone_check": ("cone_check", cone or {})}
    for table, rows in (("soil_bounds", per_soil), *((t, cfg.get(t, {})) for t in own_settings)):
        unknown = sorted(set(rows) - set(SOILS))
        if unknown:
            raise ConfigError(f"{path}: [{table}.{unknown[0]}]: allowed soils {', '.join(SOILS)}")
    for table, (common, settings) in own_settings.items():   # a soil's own settings replace the common ones
        for name, own in cfg.get(table, {}).items():
            stray = sorted(set(own) - set(settings))
            if stray:
                raise ConfigError(f"{path}: {table}.{name}.{stray[0]}: not in [{common}]; allowed "
                                  f"{', '.join(settings) or 'nothing: there is no such section'}")
    if soil is not None:
        bench.update(cfg.get("soil_bench", {}).get(soil, {}))
        if cone is not None:
            cone.update(cfg.get("soil_cone_check", {}).get(soil, {}))
    need = {"resolution", "size_mm", "stresses_kpa", "speed_m_s", "calibration_seed", "check_seeds", "samples",
            "iterations", "workers"}
    if need - set(bench):
        raise ConfigError(f"{path}: [bench] lacks {', '.join(sorted(need - set(bench)))}")
    stresses = bench["stresses_kpa"]
    if len(stresses) < 3 or any(float(s) <= 0 for s in stresses) or len(set(stresses)) < len(stresses):
        raise ConfigError(f"{path}: stresses_kpa = {stresses}: allowed three or more distinct normal stresses above "
                          "0 kPa (c and φ with an interval)")
    for where, ranges in {"bounds": bounds, **{f"soil_bounds.{n}": own for n, own in per_soil.items()}}.items():
        stray = sorted(set(ranges) - set(bounds))          # a soil narrows the common parameters only
        if stray:
            raise ConfigError(f"{path}: {where}.{stray[0]}: not in [bounds]; allowed {', '.join(bounds)}")
        for name, rng in ranges.items():
            if not isinstance(rng, list) or len(rng) != 2:
                raise ConfigError(f"{path}: {where}.{name} = {rng!r}: allowed [lo, hi], two numbers with lo < hi")
            field = SOIL_FIELDS.get(name, Field())      # each end inside the contact law's range, refused here and not
            lo, hi = (field.check(f"{path}: {where}.{name}", v) for v in rng)   # in every evaluation that draws
            if not lo < hi:                             # past it; a name no parameter has is refused below
                raise ConfigError(f"{path}: {where}.{name} = {rng!r}: allowed [lo, hi], two numbers with lo < hi")
    turn = [SEED.check(f"{path}: bench.calibration_seed", s) for s in filter_seeds(bench)]
    if not turn or len(set(turn)) < len(turn):
        raise ConfigError(f"{path}: bench.calibration_seed = {bench['calibration_seed']!r}: allowed a packing seed, or a "
                          "list of distinct ones that the filter's samples take in turn")
    column = bench.get("collapse_size_mm")
    if column is not None and (len(column) != 3 or any(float(v) <= 0 for v in column)):
        raise ConfigError(f"{path}: bench.collapse_size_mm = {column}: allowed three lengths above 0 mm (the collapse "
                          "column's; left out, the shear box's size_mm)")
    box = bench.get("check_box_mm")
    if box is not None and (len(box) != 3 or any(float(v) <= 0 for v in box)):
        raise ConfigError(f"{path}: bench.check_box_mm = {box}: allowed three lengths above 0 mm (the shear box the "
                          "checks read; left out, the filter's size_mm)")
    grown = bench.get("size_check_mm")
    if grown is not None and (len(grown) != 3 or any(float(g) <= float(b) for g, b in zip(grown, bench["size_mm"]))):
        raise ConfigError(f"{path}: bench.size_check_mm = {grown}: allowed three lengths, each above size_mm's "
                          f"{bench['size_mm']}")
    grown_check = bench.get("check_size_check_mm")
    if grown_check is not None and (box is None or len(grown_check) != 3
                                    or any(float(g) <= float(b) for g, b in zip(grown_check, box))):
        raise ConfigError(f"{path}: bench.check_size_check_mm = {grown_check}: allowed three lengths, each above "
                          f"check_box_mm's {box}")
    taller = bench.get("check_height_check_mm")
    if taller is not None and (box is None or len(taller) != 3 or [float(v) for v in taller[:2]] != [float(v) for v in box[:2]]
                               or float(taller[2]) <= float(box[2])):
        raise ConfigError(f"{path}: bench.check_height_check_mm = {taller}: allowed check_box_mm's {box} with a "
                          "greater height")
    folder = bench.get("filter_folder")
    if folder is not None and not (isinstance(folder, str) and re.fullmatch(r"[a-z0-9][a-z0-9-]*", folder)):
        raise ConfigError(f"{path}: bench.filter_folder = {folder!r}: allowed a folder name of lower-case letters, "
                          "digits and hyphens (the filter's own folder in results/calibration/bench/)")
    edges = bench.get("cell_edges_mm")
    if edges is not None and (len(edges) < 2 or any(not 40 <= float(e) <= 500 for e in edges)
                              or any(float(b) <= float(a) for a, b in zip(edges, edges[1:]))):
        raise ConfigError(f"{path}: bench.cell_edges_mm = {edges}: allowed two or more rising edges of 40-500 mm (the "
                          "simple shear cell's size check)")
    if bench.get("shear_test", "box") not in ("box", "cell") or (bench.get("shear_test") == "cell" and edges is None):
        raise ConfigError(f"{path}: bench.shear_test = {bench.get('shear_test')!r}: allowed \"box\" (the direct shear "
                          "box) or \"cell\" (the wall-free simple shear cell, at the first of cell_edges_mm, which it "
                          "needs)")
    shift = bench.get("shear_shift", {})
    if not isinstance(shift, dict) or set(shift) - set(SHEAR_RESPONSES) or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) or abs(v) > SHIFT_LIMIT[r] for r, v in shift.items()):
        raise ConfigError(f"{path}: bench.shear_shift = {shift!r}: allowed a table of c_kpa (within ± "
                          f"{SHIFT_LIMIT['c_kpa']:g} kPa) and phi_deg (within ± {SHIFT_LIMIT['phi_deg']:g}°), the sized "
                          "cell's reading minus the filter's")
    if bench.get("collapse_floor", "plane") not in FLOORS:
        raise ConfigError(f"{path}: bench.collapse_floor = {bench['collapse_floor']!r}: allowed "
                          f"{' or '.join(repr(f) for f in FLOORS)} (scripts/collapse.py --floor)")
    if soil is not None:
        bounds.update(per_soil.get(soil, {}))
    if len(bounds) < 3:
        raise ConfigError(f"{path}: [bounds] names {len(bounds)} parameters: allowed three or more")
    if set(fixed) & set(bounds):
        raise ConfigError(f"{path}: {', '.join(sorted(set(fixed) & set(bounds)))} both fixed and calibrated: allowed one")
    unknown = sorted((set(fixed) | set(bounds)) - set(SOIL_FIELDS))
    if unknown:
        raise ConfigError(f"{path}: {', '.join(unknown)}: allowed soil contact parameters {', '.join(SOIL_FIELDS)}")
    for name, value in fixed.items():
        SOIL_FIELDS[name].check(f"{path}: fixed.{name}", value)
    screen_sd = bench.get("cone_screen_sd", 0)
    if not isinstance(screen_sd, (int, float)) or isinstance(screen_sd, bool) or not 0 <= screen_sd <= 10:
        raise ConfigError(f"{path}: cone_screen_sd = {screen_sd!r}: allowed 0 (every evaluation's cone runs) to 10 "
                          "packing-scatter SDs")
    if screen_sd and not cfg.get("packing_scatter"):
        raise ConfigError(f"{path}: cone_screen_sd = {screen_sd}: allowed only with a [packing_scatter] section, the "
                          "SDs it counts in")
    if not isinstance(bench.get("cone_target", False), bool):
        raise ConfigError(f"{path}: cone_target = {bench['cone_target']!r}: allowed true or false")
    if bench.get("cone_target") and cone is None:
        raise ConfigError(f"{path}: cone_target = true without a [cone_check] section: the cone's bed and cone are "
                          "not given")
    if cone is not None:
        need_cone = {"resolution", "size_mm", "seed", "cone_scale", "speed_m_s", "tolerance"}
        if need_cone - set(cone):
            raise ConfigError(f"{path}: [cone_check] lacks {', '.join(sorted(need_cone - set(cone)))}")
        if not 0 < float(cone["tolerance"]) < 1:
            raise ConfigError(f"{path}: cone_check.tolerance = {cone['tolerance']}: allowed (0, 1), a share of Table 2")
        if cone.get("tool_friction", "grain") not in TOOL_FRICTIONS:
            raise ConfigError(f"{path}: cone_check.tool_friction = {cone['tool_friction']!r}: allowed \"grain\" (a grain "
                              "slides on the cone at the lesser of its own and the steel's friction) or \"field\" (at "
                              f"the soil's friction on steel, {TOOL_FRICTION.relative_to(ROOT)})")
        if not 0.5 <= float(cone.get("transfer", 1.0)) <= 1.5:
            raise ConfigError(f"{path}: cone_check.transfer = {cone['transfer']}: allowed 0.5-1.5, the runs' grains' "
                              "cone index over this cone's")
    scatter, responses = cfg.get("packing_scatter", {}), (*RESPONSES, "cone_kpa")
    bad = sorted(k for k, v in scatter.items() if k not in responses or not float(v) > 0)
    if bad:
        raise ConfigError(f"{path}: packing_scatter.{bad[0]} = {scatter[bad[0]]}: allowed an SD above 0 for each of "
                          f"{', '.join(responses)}")
    return {**bench, "bounds": {k: tuple(map(float, v)) for k, v in bounds.items()},
            **({"packing_scatter": {k: float(v) for k, v in scatter.items()}} if scatter else {}),
            "fixed": {k: float(v) for k, v in fixed.items()}, **({"cone_check": dict(cone)} if cone else {})}


def target_ranges(soil: str, cfg: dict) -> dict:
    """Each of the filter's responses' target range (lo, hi): the bench's from configs/field/soil_targets.csv, the
    cone's Table 2 ± the [cone_check] tolerance."""
    t = load_targets(soil)
    ranges = {r: (float(t.loc[r, "lo"]), float(t.loc[r, "hi"])) for r in RESPONSES}
    return {**ranges, **({"cone_kpa": cone_range(soil, cfg)} if cfg.get("cone_target") else {})}


def load_targets(soil: str, path: Path = TARGETS) -> pd.DataFrame:
    """The soil's bench targets: response, lo, hi, the value (the range's middle) and the source."""
    t = pd.read_csv(path, comment="#")
    t = t[t["soil"] == soil].set_index("response")
    if t.empty or set(RESPONSES) - set(t.index):
        raise ConfigError(f"{path}: soil {soil!r} needs a target for each of {', '.join(RESPONSES)}")
    t["value"] = (t["lo"] + t["hi"]) / 2
    return t


def field_tool_friction(soil: str, path: Path = TOOL_FRICTION) -> float:
    """The soil's friction on the tools' steel, degrees: the value of configs/field/tool_friction.csv, checked to lie
    in its row's range and in `tool_friction_deg`'s."""
    from analysis.core.soil_config import SOIL_FIELDS
    t = pd.read_csv(path, comment="#").set_index("soil")
    if soil not in t.index:
        raise ConfigError(f"{path}: soil {soil!r} has no row; allowed a row per soil with lo_deg, hi_deg, value_deg")
    lo, hi, value = (float(t.loc[soil, k]) for k in ("lo_deg", "hi_deg", "value_deg"))
    if not lo <= value <= hi:
        raise ConfigError(f"{path}: {soil}.value_deg = {value:g}: allowed {lo:g}-{hi:g}, its row's range")
    return SOIL_FIELDS["tool_friction_deg"].check(f"{path}: {soil}.value_deg", value)


def collapse_size(cfg: dict) -> list:
    """The collapse column's size (mm): [bench] collapse_size_mm where set, else the shear box's size_mm."""
    return list(cfg.get("collapse_size_mm", cfg["size_mm"]))


def checks_bench(cfg: dict) -> dict:
    """cfg with the shear box the posterior's checks read c and φ in ([bench] check_box_mm, where set), the collapse
    column as configured; `twins` the bench settings under which the same set and packing may already have run a
    scene with the same inputs (the filter's box, the size check's grown box), which `evaluate` reuses.

    >>> b = checks_bench({"size_mm": [150, 150, 100], "collapse_size_mm": [225, 225, 150], "check_box_mm": [225, 225, 150]})
    >>> b["size_mm"], b["collapse_size_mm"], [t["size_mm"] for t in b["twins"]]
    ([225, 225, 150], [225, 225, 150], [[150, 150, 100]])
    """
    box = cfg.get("check_box_mm")
    if box is None or list(box) == list(cfg["size_mm"]):
        return cfg
    twins = [cfg] + ([grown_bench(cfg)] if "size_check_mm" in cfg else [])
    return {**cfg, "size_mm": list(box), "collapse_size_mm": collapse_size(cfg), "twins": twins}


def grown_bench(cfg: dict) -> dict:
    """cfg with the size check's box ([bench] size_check_mm) and its collapse column grown by as much."""
    grow = [float(g) / float(b) for g, b in zip(cfg["size_check_mm"], cfg["size_mm"])]
    return {**cfg, "size_mm": list(cfg["size_check_mm"]),
            "collapse_size_mm": [round(v * k) for v, k in zip(collapse_size(cfg), grow)]}


def scene_inputs(scene: str, cfg: dict) -> dict:
    """What a bench scene reads of the bench's settings beyond the soil, the packing and the set: two evaluations
    alike in these ran the scene alike."""
    common = {"resolution": cfg["resolution"], "fixed": dict(sorted((cfg.get("fixed") or {}).items()))}
    if scene == "shear":
        return {**common, "size_mm": [float(v) for v in cfg["size_mm"]],
                "stresses": [float(v) for v in cfg["stresses_kpa"]], "speed": float(cfg["speed_m_s"]),
                **shear_test_key(cfg)}
    return {**common, "size_mm": [float(v) for v in collapse_size(cfg)], **collapse_floor_key(cfg)}


def collapse_floor_key(cfg: dict) -> dict:
    """What names the collapse column's floor: nothing for the plane (evaluations keep their ids), the floor for
    fixed grains ([bench] collapse_floor = "grains").

    >>> collapse_floor_key({}), collapse_floor_key({"collapse_floor": "grains"})
    ({}, {'collapse_floor': 'grains'})
    """
    floor = cfg.get("collapse_floor", "plane")
    return {} if floor == "plane" else {"collapse_floor": floor}


def floor_twins(cfg: dict) -> list[dict]:
    """cfg's twins (`from_twin`): its own ("twins", the checks' boxes), and for a column on fixed grains the same
    bench on the plane, whose shear tests are this bench's (a filter moved onto the grains keeps its finished cells).

    >>> [t.get("collapse_floor", "plane") for t in floor_twins({"collapse_floor": "grains"})], floor_twins({})
    (['plane'], [])
    """
    own = list(cfg.get("twins", []))
    if collapse_floor_key(cfg):
        own.append({**cfg, "collapse_floor": "plane", "twins": []})
    return own


def shear_test_key(cfg: dict) -> dict:
    """What names a filter's shear test beyond the box's settings: nothing for the box (evaluations keep their ids),
    the cell and its edge for the wall-free cell ([bench] shear_test = "cell", its first cell_edges_mm).

    >>> shear_test_key({}), shear_test_key({"shear_test": "cell", "cell_edges_mm": [120, 180]})
    ({}, {'shear_test': 'cell', 'cell_edge_mm': 120.0})
    """
    if cfg.get("shear_test", "box") == "box":
        return {}
    return {"shear_test": "cell", "cell_edge_mm": float(cfg["cell_edges_mm"][0])}


def filter_dir(cfg: dict, out_dir: Path = BENCH_DIR) -> Path:
    """Where the soil's filter keeps its evaluations and tables: `out_dir`, its [bench] filter_folder within it (a
    variant config's filter), or its cell-filter/ folder for a filter shearing in the wall-free cell
    (`shear_test_key`), so that the box-drawn posterior and the tables read from it stand until the cell's filter has
    drawn its own.

    >>> cell = {"shear_test": "cell", "cell_edges_mm": [120, 180]}
    >>> filter_dir({}, Path("b")), filter_dir(cell, Path("b")), filter_dir({**cell, "filter_folder": "f"}, Path("b"))
    (PosixPath('b'), PosixPath('b/cell-filter'), PosixPath('b/f'))
    """
    folder = cfg.get("filter_folder") or ("cell-filter" if shear_test_key(cfg) else "")
    return Path(out_dir) / folder if folder else Path(out_dir)


def from_twin(scene: str, soil: str, seed: int, params: dict, cfg: dict, folder: Path, out_dir: Path) -> dict | None:
    """The scene's finished result from a twin evaluation (cfg["twins"]) of the same set and packing whose scene had
    the same inputs (`scene_inputs`), copied into `folder` with its log; None if no twin finished it."""
    for twin in floor_twins(cfg):
        if scene_inputs(scene, twin) != scene_inputs(scene, cfg):
            continue
        source = Path(out_dir) / soil / evaluation_id(soil, seed, params, twin)
        found = scene_file(source, scene) if source.is_dir() else None
        if found is None:
            continue
        for path in (found, source / f"{scene}.log"):
            if path.exists():
                atomic_write(folder / path.name, path.read_text())
        return json.loads(found.read_text())
    return None


def evaluation_id(soil: str, seed: int, params: dict, cfg: dict) -> str:
    """One evaluation's folder name: the soil, the packing and a hash of the parameters (4 significant digits)
    and the bench's settings."""
    key = {"soil": soil, "seed": seed, "params": dict(sorted(rounded(params).items())),
           "resolution": cfg["resolution"], "size_mm": list(cfg["size_mm"]), "stresses": list(cfg["stresses_kpa"]),
           "speed": float(cfg["speed_m_s"]), "scenes": SCENES_VERSION}
    if cfg.get("fixed"):                    # named only when there is one: the earlier evaluations keep their ids
        key["fixed"] = dict(sorted(cfg["fixed"].items()))
    if collapse_size(cfg) != list(cfg["size_mm"]):     # likewise a collapse column of its own
        key["collapse_size_mm"] = collapse_size(cfg)
    key.update(shear_test_key(cfg))                     # and the wall-free cell in place of the box
    key.update(collapse_floor_key(cfg))                 # and a column on fixed grains
    return f"s{seed}-{digest(key, 10)}"


def rounded(params: dict) -> dict:
    """The parameters to 4 significant digits: what an evaluation runs with and is named by."""
    return {k: float(f"{v:.4g}") for k, v in params.items()}


def overrides(params: dict, fixed: dict | None = None) -> list[str]:
    """The scenes' --test-set items for a parameter set and the calibration's fixed parameters (the shear bond
    kept equal to the normal bond)."""
    from analysis.core.soil_config import equal_bonds
    return [f"{k}={v}" for k, v in equal_bonds({**(fixed or {}), **rounded(params)}).items()]


def evaluate(soil: str, seed: int, params: dict, cfg: dict, out_dir: Path = BENCH_DIR) -> dict:
    """Run (or reuse) the shear box (or the wall-free cell, [bench] shear_test) and the collapse test of one parameter
    set on one packing; returns the responses with the parameters. An evaluation stopped between its tests reruns
    only the test it lacks (`scene_result`; `resumed` names the one read back, and `wall_s` is this run's time). A
    failed scene raises RuntimeError with its log's tail."""
    folder = Path(out_dir) / soil / evaluation_id(soil, seed, params, cfg)
    done = folder / "responses.json"
    if done.exists():
        row = json.loads(done.read_text())
        return row if row.get("failed") else measured(row, folder)
    folder.mkdir(parents=True, exist_ok=True)
    common = ["--soil", soil, "--resolution", cfg["resolution"], "--seed", str(seed), "--threads", "1",
              "--out", str(folder)]
    for item in overrides(params, cfg.get("fixed")):
        common += ["--test-set", item]
    wall0 = time.time()
    results, resumed = {}, []
    cell = shear_test_key(cfg)
    shear = ["--size", f"{cell['cell_edge_mm']:g}" if cell else ",".join(map(str, cfg["size_mm"])),
             "--stress", ",".join(map(str, cfg["stresses_kpa"])), *([] if cell else ["--speed", str(cfg["speed_m_s"])])]
    script = {"shear": "simple_shear" if cell else "shear", "collapse": "collapse"}
    column = ["--size", ",".join(map(str, collapse_size(cfg))), "--floor", cfg.get("collapse_floor", "plane")]
    for scene, extra in (("shear", shear), ("collapse", column)):
        results[scene] = scene_result(folder, scene)
        if results[scene] is not None:       # a stopped evaluation resumes after its last finished test
            resumed.append(scene)
            continue
        results[scene] = from_twin(scene, soil, seed, params, cfg, folder, out_dir)
        if results[scene] is not None:       # the same scene of the same set and packing, run beside another box
            resumed.append(f"{scene} (a twin's)")
            continue
        code, out = run_logged([sys.executable, str(ROOT / f"scripts/{script[scene]}.py"), *common, *extra],
                               folder / f"{scene}.log")
        if code != 0:
            tail = "".join((folder / f"{scene}.log").read_text().splitlines(keepends=True)[-8:])
            if code == UNTESTABLE:      # the scene stopped the test (a leaking box, a grain flying): no response
                row = {"id": folder.name, "soil": soil, "seed": seed, **params, **{r: math.nan for r in RESPONSES},
                       "failed": f"scripts/{scene}.py: {tail.strip().splitlines()[-1]}", "wall_s": time.time() - wall0}
                atomic_write(done, json.dumps(row, indent=1))
                say(f"calibrate {soil} {folder.name}: {row['failed']} (weighs nothing in the filter)")
                return row
            raise RuntimeError(f"{soil} {folder.name}: scripts/{scene}.py exited {code}:\n{tail}")
        results[scene] = json.loads(out.strip().splitlines()[-1])
    row = {"id": folder.name, "soil": soil, "seed": seed, **params, "c_kpa": results["shear"]["c_kpa"],
           "phi_deg": results["shear"]["phi_deg"], "collapse_runout_mm": results["collapse"]["runout_mm"],
           "tau_peak_kpa": _shear_peaks(folder), "wall_s": time.time() - wall0}
    if resumed:
        row["resumed"] = ", ".join(resumed)
    atomic_write(done, json.dumps(row, indent=1))
    return measured(row, folder)


SCENE_DETAIL = {"shear": "tests", "collapse": "profile_mm"}   # what a scene's result file holds beyond its stdout


def scene_file(folder: Path, scene: str) -> Path | None:
    """A bench scene's result file in an evaluation's folder (the one holding its SCENE_DETAIL: the shear box's
    tests, the collapse's profile), if the scene finished there (it writes the file atomically when it ends); None
    if not. The folder is named by every parameter and setting (`evaluation_id`), so a file in it is this
    evaluation's."""
    for path in sorted(folder.glob("*.json")):
        if path.name != "responses.json" and SCENE_DETAIL[scene] in json.loads(path.read_text()):
            return path
    return None


def scene_result(folder: Path, scene: str) -> dict | None:
    """The contents of the scene's result file in an evaluation's folder (`scene_file`), None if it has none."""
    path = scene_file(folder, scene)
    return json.loads(path.read_text()) if path else None


def measured(row: dict, folder: Path, kept_only: bool = False) -> dict:
    """The evaluation's responses measured from its stored scene results each time it is read: c and φ fitted to the
    shear box's tests (analysis/soil/shear.py), the collapse slope from the column's profile
    (analysis/soil/collapse.py). A finished evaluation is so measured the way the current code measures; its
    responses.json keeps what its run read. `kept_only`: a row of a table, kept as it is where its evaluation
    failed or its folder lacks a scene's result (another machine's run, not sent here); else that raises."""
    from analysis.soil.collapse import profile_angle
    if kept_only and (isinstance(row.get("failed"), str) or not folder.is_dir()):
        return row
    box, column = scene_result(folder, "shear"), scene_result(folder, "collapse")
    if box is None or column is None:
        if kept_only:
            return row
        raise RuntimeError(f"{folder}: no {'shear box tests' if box is None else 'collapse profile'}")
    fit = fit_tests(box["tests"])
    return {**row, "c_kpa": fit["c_kpa"], "phi_deg": fit["phi_deg"], "collapse_deg": profile_angle(column["profile_mm"])}


def _shear_peaks(folder: Path) -> list[float]:
    """The peak shear stresses (kPa) of the evaluation's shear box, one per normal stress."""
    data = scene_result(folder, "shear")
    return [t["tau_peak_kpa"] for t in data["tests"]] if data else []


def evaluate_all(soil: str, seeds_params: list[tuple[int, dict]], cfg: dict, out_dir: Path = BENCH_DIR,
                 cfgs: list[dict] | None = None, with_cone: bool = False, screen=None) -> list[dict]:
    """Every (seed, parameters) evaluation, `cfg["workers"]` at a time, with progress and an ETA; `cfgs`: each
    evaluation's own bench settings in place of cfg (the size check's two boxes); `with_cone`: each tested one's
    cone index too, on the cone's bed of the same packing seed (`cone_check`: `cone_kpa` what the filter weighs,
    `cone_reading_kpa` the cone's reading), except where `screen(row)` says its bench responses already put it out
    (`cone_kpa` NaN, `cone_screened` true)."""
    def one(i):
        seed, params = seeds_params[i]
        row = evaluate(soil, seed, params, cfgs[i] if cfgs else cfg, out_dir)
        if with_cone and not row.get("failed"):
            if screen is not None and screen(row):
                return {**row, "cone_kpa": math.nan, "cone_screened": True}
            row = {**row, **cone_columns(soil, params, cfg, out_dir, seed)}
        return row

    return in_parallel(one, list(range(len(seeds_params))), int(cfg["workers"]), f"calibrate {soil}", "evaluations")


def filter_seeds(cfg: dict) -> list[int]:
    """The packings the filter's evaluations run on: [bench] calibration_seed, one seed or a list the samples take in
    turn (sample i of every iteration on the list's (i mod its length)-th), so that a sample's weight carries the
    packings' scatter instead of one packing's luck.

    >>> filter_seeds({"calibration_seed": 1}), filter_seeds({"calibration_seed": [1, 2, 3]})
    ([1], [1, 2, 3])
    """
    seeds = cfg["calibration_seed"]
    return list(seeds) if isinstance(seeds, list) else [seeds]


def in_turn(seeds: list[int], rows: list) -> list[tuple[int, dict]]:
    """Each of an iteration's parameter sets with its packing: the seeds in turn.

    >>> in_turn([1, 2], [{"a": 0}, {"a": 1}, {"a": 2}])
    [(1, {'a': 0}), (2, {'a': 1}), (1, {'a': 2})]
    """
    return [(seeds[i % len(seeds)], p) for i, p in enumerate(rows)]


REUSED_S = 5.0          # s: a job done sooner reused kept results (a twin's evaluation, a finished scene)


def in_parallel(fn, jobs: list, workers: int, label: str, unit: str) -> list:
    """fn of each job, `workers` at a time (threads, each starting its own YADE process), in the jobs' order;
    after each one that ran, and after the last, says how many are done, the time so far and an ETA from the jobs
    that ran (a job done within REUSED_S reused a kept result: it says nothing of the time the others take, and a
    resumed calibration's kept jobs print no line each)."""
    done: list = []
    ran: list[float] = []
    wall0 = time.time()

    def one(job):
        t0 = time.time()
        out = fn(job)
        done.append(job)
        took = time.time() - t0
        if took > REUSED_S:
            ran.append(took)
        elif len(done) < len(jobs):
            return out
        left = len(jobs) - len(done)
        eta = f"{sum(ran) / len(ran) * math.ceil(left / workers):.0f} s" if ran else "unknown until one has run"
        say(f"{label}: {len(done)}/{len(jobs)} {unit} done, {time.time() - wall0:.0f} s, ETA {eta}")
        return out

    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(one, jobs))


def calibrate(soil: str, cfg: dict | None = None, out_dir: Path = BENCH_DIR) -> dict:
    """The soil's posterior over cfg's bounds against its targets; writes results/calibration/bench/<soil>.csv
    (every evaluation with its iteration and last weight) and <soil>-posterior.json, and while it runs
    <soil>-running.csv (the iterations finished so far: a calibration that outlasts a machine shows where it is)."""
    from analysis.soil.bayes import calibrate as bayes
    cfg = cfg or load_config(soil=soil)
    targets = load_targets(soil)
    seeds = filter_seeds(cfg)
    history = []
    running = Path(out_dir) / f"{soil}-running.csv"

    def finished() -> pd.DataFrame:
        """Every evaluation of the finished iterations with its iteration (the shear peaks left out)."""
        return pd.DataFrame([{**r, "iteration": i + 1} for i, batch in enumerate(history) for r in batch]) \
            .drop(columns=["tau_peak_kpa"], errors="ignore")

    ranges = target_ranges(soil, cfg)
    shift = cfg.get("shear_shift", {})
    screen = cone_screen(ranges, cfg)

    def model_batch(rows: list[dict]) -> list[dict]:
        out = evaluate_all(soil, in_turn(seeds, rows), cfg, out_dir, with_cone=bool(cfg.get("cone_target")),
                           screen=screen)
        history.append(out)
        atomic_csv(finished(), running, f"./holes calibrate --soil {soil} --bench: the filter's finished iterations, "
                   f"until its posterior is drawn ({len(history)} of {cfg['iterations']})")
        return [screened_as_met(shifted(r, shift), ranges) for r in out]

    post = bayes(model_batch, ranges, cfg["bounds"], samples=int(cfg["samples"]), iterations=int(cfg["iterations"]),
                 batch=True, scatter=cfg.get("packing_scatter"))
    table = finished()
    table["weight_last"] = np.nan
    last = table["iteration"] == table["iteration"].max()
    table.loc[last, "weight_last"] = np.asarray(post["weights"])[-1] if np.ndim(post["weights"]) > 1 else post["weights"]
    summary = {k: post[k] for k in ("names", "mean", "cv", "most_probable")}
    summary["fixed"] = dict(cfg.get("fixed", {}))
    summary["likelihood_sigma"] = post["sigma"]
    summary["packing_scatter"] = dict(cfg.get("packing_scatter", {}))
    summary["shear_reading"] = READING      # without it: drawn on the lid's load alone
    if shift:
        summary["shear_shift"] = dict(shift)    # what the filter added to its shear test's c and φ
    summary["prior"] = {k: list(v) for k, v in cfg["bounds"].items()}
    summary["interval"] = weighted_intervals(table[last], post["names"], table.loc[last, "weight_last"].to_numpy())
    summary["correlation"] = weighted_correlation(table[last], post["names"], table.loc[last, "weight_last"].to_numpy())
    summary["targets"] = {r: [*ranges[r], targets.loc[r, "source"] if r in targets.index else
                              f"Table 2 ± {float(cfg['cone_check']['tolerance']):g} (configs/soils/{soil}.toml)"]
                          for r in ranges}
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_csv(table, Path(out_dir) / f"{soil}.csv")
    atomic_write(Path(out_dir) / f"{soil}-posterior.json", json.dumps(summary, indent=1))
    running.unlink(missing_ok=True)
    return summary


def cone_screen(ranges: dict, cfg: dict):
    """The filter's cone screen: a function telling whether an evaluation's bench responses (c and φ plus [bench]
    shear_shift, as the filter weighs them, `shifted`) already put it more than [bench] cone_screen_sd
    packing-scatter SDs ([packing_scatter]) outside one of its ranges, so that its cone (two thirds of an
    evaluation's cost) is not run; None where the soil's cone is no target or cone_screen_sd is 0.

    >>> screen = cone_screen({"c_kpa": (20, 35), "phi_deg": (20, 30), "collapse_deg": (30, 38)},
    ...                      {"cone_target": True, "cone_screen_sd": 3, "packing_scatter": {"c_kpa": 5.1,
    ...                       "phi_deg": 1.8, "collapse_deg": 1.6, "cone_kpa": 42}})
    >>> screen({"c_kpa": 26.1, "phi_deg": 24.4, "collapse_deg": 39.7}), screen({"c_kpa": 28, "phi_deg": 32.6,
    ...                                                                         "collapse_deg": 46.1})
    (False, True)
    """
    k = float(cfg.get("cone_screen_sd", 0))
    if not cfg.get("cone_target") or k == 0:
        return None
    scatter, shift = cfg["packing_scatter"], cfg.get("shear_shift", {})

    def out(row: dict) -> bool:
        row = shifted(row, shift)                # c and φ as the filter weighs them
        return any(max(ranges[r][0] - row[r], row[r] - ranges[r][1]) > k * scatter[r] for r in RESPONSES)
    return out


def shifted(row: dict, shift: dict) -> dict:
    """An evaluation's c and φ as the filter weighs them: its shear test's reading plus [bench] shear_shift
    ({response: shift}, the sized cell's reading minus the filter's cell's, measured at a posterior), so that a filter
    shearing in a cell that fails its size check aims where the check judges; its table keeps the reading.

    >>> shifted({"c_kpa": 16.0, "phi_deg": 25.5, "collapse_deg": 34.0}, {"c_kpa": 2.5, "phi_deg": -1.5})
    {'c_kpa': 18.5, 'phi_deg': 24.0, 'collapse_deg': 34.0}
    """
    return {**row, **{r: row[r] + float(v) for r, v in shift.items()}}


def screened_as_met(row: dict, ranges: dict) -> dict:
    """An evaluation as the filter weighs it: a screened cone (`cone_screen`) counts as met, in the middle of its
    range, the most it could give, so the screen never takes weight from a sample, only the cone's cost; the
    evaluation's table keeps its cone NaN.

    >>> screened_as_met({"cone_kpa": float("nan"), "cone_screened": True}, {"cone_kpa": (382.5, 517.5)})["cone_kpa"]
    450.0
    """
    return {**row, "cone_kpa": sum(ranges["cone_kpa"]) / 2} if row.get("cone_screened") else row


def weighted_intervals(table: pd.DataFrame, names: list[str], w) -> dict:
    """Each parameter's 2.5-97.5 % weighted quantiles over the last iteration's samples.

    >>> t = pd.DataFrame({"a": [1.0, 2.0, 3.0, 4.0]})
    >>> weighted_intervals(t, ["a"], [0, 0.5, 0.5, 0])
    {'a': [2.0, 3.0]}
    """
    w = np.asarray(w, float) / np.sum(w)
    out = {}
    for n in names:
        order = np.argsort(table[n].to_numpy())
        x, c = table[n].to_numpy()[order], np.cumsum(w[order])
        out[n] = [float(x[np.searchsorted(c, 0.025)]), float(x[min(len(x) - 1, np.searchsorted(c, 0.975))])]
    return out


def weighted_correlation(table: pd.DataFrame, names: list[str], w) -> dict:
    """The parameters' weighted correlation matrix over the last iteration's samples, as nested dicts."""
    x = table[names].to_numpy(float)
    w = np.asarray(w, float) / np.sum(w)
    m = w @ x
    cov = (x - m).T @ ((x - m) * w[:, None])
    sd = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    corr = cov / np.outer(sd, sd)
    return {a: {b: round(float(corr[i, j]), 3) for j, b in enumerate(names)} for i, a in enumerate(names)}


def check(soil: str, post: dict, cfg: dict | None = None, out_dir: Path = BENCH_DIR, label: str = "check",
          cone: bool = True, keep_earlier: bool = False) -> dict:
    """The posterior mean's (post["mean"]) bench responses on each check packing, the shear box in the checks' own
    ([bench] check_box_mm, `checks_bench`), against the targets' ranges; writes
    results/calibration/bench/<soil>-<label>.csv and .json. Returns per response: the mean over packings, their SD and
    whether every packing lies inside the target's range (strict: with packings as scattered as these runs' a set
    centred in every range passes on three packings about a fifth of the time, `every_packing_chance`) and
    whether their mean does; with a [cone_check], the cone index too, read at the bench's grains (the runs', `runs_cone`)
    whatever grains the filter's cone took: on every check packing when the filter fitted it (`cone_target`), else on
    the cone's one packing (`cone_check`); `cone` False: the shear box and the collapse test alone. Each response
    also carries its mean's 95 % interval over the packings and where that interval lies (`mean_verdict`), over the
    packings whose test ran to its end: `failed_packings` counts those its scene stopped (a heap still flowing), and
    with any of them no verdict is "inside".
    `keep_earlier`: the CSV keeps the rows of the sets checked before under the label (each row names its set; the
    JSON judges this set alone): the planes' deepest set moves as the planes take in its checks."""
    cfg = checks_bench(runs_cone(cfg or load_config(soil=soil)))
    params = {k: float(v) for k, v in post["mean"].items()}
    rows = evaluate_all(soil, [(int(s), params) for s in cfg["check_seeds"]], cfg, out_dir,
                        with_cone=cone and bool(cfg.get("cone_target")))
    table = pd.DataFrame(rows).drop(columns=["tau_peak_kpa"], errors="ignore")
    path = Path(out_dir) / f"{soil}-{label}.csv"
    atomic_csv(after_earlier(table, path) if keep_earlier else table, path)
    ranges = target_ranges(soil, cfg)
    if not cone:
        ranges.pop("cone_kpa", None)
    out = judged(table, ranges)
    if cone and "cone_check" in cfg and "cone_kpa" not in out:
        out["cone_kpa"] = cone_check(soil, params, cfg, out_dir)
    atomic_write(Path(out_dir) / f"{soil}-{label}.json", json.dumps(out, indent=1))
    return out


def judged(table: pd.DataFrame, ranges: dict) -> dict:
    """A check's verdicts: per response of `ranges` ({response: (lo, hi)}) in the table (one row a packing), the mean
    over packings, their SD, whether every packing and whether the mean lies inside the range, and the mean's
    interval's verdict (`mean_verdict`) over the packings whose test ran to its end: `failed_packings` counts those
    its scene stopped (a heap still flowing), and with any of them no verdict is "inside"."""
    out = {}
    for r, (lo, hi) in ranges.items():
        if r not in table:
            continue
        v = table[r].to_numpy(float)
        failed, v = int(np.isnan(v).sum()), v[np.isfinite(v)]      # a test its scene stopped reads nothing
        verdict = mean_verdict(v, lo, hi)
        if failed and verdict["mean_verdict"] == "inside":        # the packings it failed on may read otherwise
            verdict["mean_verdict"] = "undecided"
        out[r] = {"mean": float(v.mean()) if len(v) else math.nan, "sd": float(v.std(ddof=1)) if len(v) > 1 else math.nan,
                  "target": [lo, hi], "every_packing_inside": bool(not failed and np.all((v >= lo) & (v <= hi))),
                  "mean_inside": bool(len(v) and lo <= v.mean() <= hi), "failed_packings": failed, **verdict}
    return out


def remeasure(soil: str, out_dir: Path = BENCH_DIR, config: Path | None = None) -> list[Path]:
    """Every kept check of the soil (CHECK_TABLES, its deepest sets' three-packing checks and its size checks, in
    out_dir and in each folder of it that holds one: FILTER_BOX_CHECKS, the earlier calibrations') measured again
    from its evaluations' stored scene results (`measured`; an evaluation whose folder is not kept here keeps its
    row) and judged again (`judged`, a table holding several sets judging its last, as its check did; a size check by
    `size_verdict`); the posterior's checks recorded again in the soil's config (`record_packings`; `config`: another
    file). Nothing runs: a changed measurement reaches every check this way. The filters' own tables keep what the
    filters weighed. Returns the tables rewritten."""
    cfg = load_config(soil=soil)
    params = list(cfg["bounds"]) + list(cfg.get("fixed", {}))
    done = []
    folders = [Path(out_dir), *sorted(d for d in Path(out_dir).iterdir() if d.is_dir() and d.name != soil)]
    for folder in folders:
        for part in (*CHECK_TABLES, "-deepest-check", *SIZE_TABLES):
            path = folder / f"{soil}{part}.csv"
            if not path.exists():
                continue
            text = path.read_text()
            table = pd.read_csv(io.StringIO(text), comment="#", float_precision="round_trip")   # its parameters as written
            if "id" not in table:
                continue
            table = pd.DataFrame([measured(row, Path(out_dir) / soil / str(row["id"]), kept_only=True)
                                  for row in table.to_dict(orient="records")])[table.columns]
            atomic_csv(table, path, text[1:text.index("\n")].strip() if text.startswith("#") else None)
            verdicts = path.with_suffix(".json")
            if part in SIZE_TABLES:
                pooled = {label: posterior_packings(soil, str(size).split("x"), folder, out_dir)
                          for label, size in table.groupby("box")["size_mm"].first().items()} if "size_mm" in table else None
                atomic_write(verdicts, json.dumps(size_verdict(table, pooled).to_dict(orient="records"), indent=1))
            elif verdicts.exists():
                named = [p for p in params if p in table]
                last = table[(table[named] == table[named].iloc[-1]).all(axis=1)] if named else table
                old = json.loads(verdicts.read_text())
                old.update(judged(last, {r: old[r]["target"] for r in RESPONSES if r in old}))
                atomic_write(verdicts, json.dumps(old, indent=1))
            done.append(path)
    packings = Path(out_dir) / f"{soil}-check-packings.json"
    if packings.exists() and (Path(out_dir) / f"{soil}-check.json").exists():
        seeds = pd.read_csv(Path(out_dir) / f"{soil}-check-packings.csv", comment="#")["seed"].astype(int).tolist()
        record_packings(soil, json.loads(packings.read_text()), seeds, out_dir, config)
    return done


def mean_verdict(values, lo: float, hi: float, level: float = 0.95) -> dict:
    """Where the packings' mean of a response lies against its target's range, told by the mean's interval (Student
    t over the packings): "inside" when the whole interval lies inside the range, "outside" when it misses the range,
    "undecided" when it straddles an edge (the packings cannot tell the mean from the edge).

    >>> v = mean_verdict([9.0, 10.0, 11.0, 10.0, 9.5, 10.5], 0.0, 12.0)
    >>> v["mean_verdict"], [round(x, 2) for x in v["mean_interval"]]
    ('inside', [9.26, 10.74])
    >>> mean_verdict([11.0, 13.0, 12.0], 0.0, 12.0)["mean_verdict"], mean_verdict([14.0, 15.0, 16.0], 0.0, 12.0)["mean_verdict"]
    ('undecided', 'outside')
    """
    from scipy.stats import t
    v = np.asarray(values, float)
    if len(v) < 2:
        return {"mean_interval": [math.nan, math.nan], "mean_verdict": "undecided"}
    half = t.ppf(0.5 + level / 2, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v))
    a, b = float(v.mean() - half), float(v.mean() + half)
    verdict = "inside" if lo <= a and b <= hi else "outside" if b < lo or a > hi else "undecided"
    return {"mean_interval": [a, b], "mean_verdict": verdict}


CHECKED_SETS = ("posterior", "deepest")      # what --check-packings checks: the posterior mean, the planes' deepest set


def check_packings(soil: str, seeds: list[int], cfg: dict | None = None, out_dir: Path = BENCH_DIR,
                   which: str = "posterior") -> dict:
    """`check` of the soil's posterior mean (<out_dir>/<soil>-posterior.json) or, `which` "deepest", of the set its
    response planes put deepest inside every target (`deepest_set`), on the packings `seeds`, the shear box and the
    collapse test alone (their finished evaluations reused; the cone stays the check's, 30-40 min a packing at the
    runs' grains), written as <soil>-check-packings.csv (<soil>-deepest-check-packings.csv) and .json: more packings
    pin the mean a check of three leaves undecided."""
    cfg = cfg or load_config(soil=soil)
    if which not in CHECKED_SETS:
        raise ConfigError(f"--check-packings = {which}: allowed {' or '.join(CHECKED_SETS)}")
    if len(seeds) < 3:
        raise ConfigError(f"--seeds = {','.join(map(str, seeds))}: allowed three packings or more (the mean's interval)")
    params = posterior_mean(soil, out_dir) if which == "posterior" else deepest_set(soil, cfg, out_dir)
    deepest = which == "deepest"
    return check(soil, {"mean": params}, {**cfg, "check_seeds": list(seeds)}, out_dir,
                 "deepest-check-packings" if deepest else "check-packings", cone=False, keep_earlier=deepest)


def runs_cone(cfg: dict) -> dict:
    """cfg with its [cone_check] cone at the bench's grains ([bench] resolution, the runs'), its reading taken as it
    is (no transfer): the cone the check and the cone transfer read. Its bed, cone and packing stay the cone's.

    >>> runs_cone({"resolution": "medium", "cone_check": {"resolution": "coarse", "transfer": 0.84, "seed": 1}})
    {'resolution': 'medium', 'cone_check': {'resolution': 'medium', 'transfer': 1.0, 'seed': 1}}
    """
    if "cone_check" not in cfg:
        return cfg
    return {**cfg, "cone_check": {**cfg["cone_check"], "resolution": cfg["resolution"], "transfer": 1.0}}


def every_packing_chance(ranges: dict, scatter: dict, packings: int, means: dict | None = None) -> float:
    """The chance that every response lies inside its range {response: (lo, hi)} on each of `packings` packings, for
    responses scattered normally by `scatter` {response: SD} about `means` (default: each range's middle, the best a
    set can do).

    >>> round(every_packing_chance({"c": (-1.96, 1.96)}, {"c": 1.0}, 1), 3)
    0.95
    >>> round(every_packing_chance({"c": (0, 4), "phi": (0, 4)}, {"c": 1.0, "phi": 1.0}, 3), 3)
    0.756
    """
    from scipy.stats import norm
    p = 1.0
    for r, (lo, hi) in ranges.items():
        m = (lo + hi) / 2 if means is None else means[r]
        p *= norm.cdf((hi - m) / scatter[r]) - norm.cdf((lo - m) / scatter[r])
    return float(p ** packings)


def check_deepest(soil: str, cfg: dict | None = None, out_dir: Path = BENCH_DIR) -> dict:
    """`check` of the soil's deepest point (`deepest_set`) on the check packings, written as <soil>-deepest-check.csv
    and .json."""
    cfg = cfg or load_config(soil=soil)
    return check(soil, {"mean": deepest_set(soil, cfg, out_dir)}, cfg, out_dir, "deepest-check", keep_earlier=True)


def deepest_set(soil: str, cfg: dict, out_dir: Path = BENCH_DIR) -> dict:
    """The calibrated parameters of the soil's deepest point (<out_dir>/deepest.csv, `deepest_point`)."""
    path = Path(out_dir) / "deepest.csv"
    table = pd.read_csv(path, comment="#").set_index("soil") if path.exists() else pd.DataFrame()
    if soil not in table.index:
        raise ConfigError(f"{path}: no deepest point of {soil}: its filter has not run (`./holes calibrate --soil "
                          f"{soil} --bench`)")
    lacking = [n for n in cfg["bounds"] if n not in table or pd.isna(table.loc[soil, n])]
    if lacking:
        raise ConfigError(f"{path}: {soil}'s deepest point lacks {', '.join(lacking)}: the planes were drawn over "
                          "another prior; allowed after `./holes calibration-report` draws them over this one")
    return {n: float(table.loc[soil, n]) for n in cfg["bounds"]}


SIZE_CHECKS = ("filter", "checks", "height")   # the box a size check grows: the filter's shear box, the checks', or
                                               # the checks' in height alone
SIZE_TABLES = ("-size", "-box-size", "-box-height")  # their tables, <soil><part>.csv and .json (no "-check": the report reads
# every <soil>-check*.csv as checks in one box)


def size_check_boxes(cfg: dict, box: str = "filter") -> tuple[dict, dict, str]:
    """The bench settings of a size check's configured and grown box, and its table's name. "filter": the filter's
    shear box and collapse column ([bench] size_mm, collapse_size_mm) and both grown by half (size_check_mm);
    "checks": the checks' shear box (check_box_mm) and one grown by half (check_size_check_mm), the collapse column
    kept (sized on its own), so the grown box's column is its twins'; "height": the checks' shear box and one grown
    in height alone (check_height_check_mm), the column kept likewise.

    >>> cfg = {"size_mm": [150, 150, 100], "collapse_size_mm": [225, 225, 150], "check_box_mm": [225, 225, 150],
    ...        "size_check_mm": [225, 225, 150], "check_size_check_mm": [338, 338, 225]}
    >>> base, grown, name = size_check_boxes(cfg, "checks")
    >>> base["size_mm"], grown["size_mm"], grown["collapse_size_mm"], name
    ([225, 225, 150], [338, 338, 225], [225, 225, 150], 'box-size')
    >>> size_check_boxes({**cfg, "check_height_check_mm": [225, 225, 225]}, "height")[1]["size_mm"]
    [225, 225, 225]
    """
    if box not in SIZE_CHECKS:
        raise ConfigError(f"--size-check {box}: allowed {' or '.join(SIZE_CHECKS)}")
    key = {"filter": "size_check_mm", "checks": "check_size_check_mm", "height": "check_height_check_mm"}[box]
    if key not in cfg or (box != "filter" and "check_box_mm" not in cfg):
        raise ConfigError(f"{CONFIG}: [bench] lacks {key} (the grown box, mm)")
    if box == "filter":
        return cfg, grown_bench(cfg), SIZE_TABLES[0][1:]
    checks = checks_bench(cfg)
    grown = {**checks, "size_mm": list(cfg[key]), "twins": [checks, *checks.get("twins", [])]}
    return checks, grown, SIZE_TABLES[SIZE_CHECKS.index(box)][1:]


def size_check(soil: str, cfg: dict | None = None, out_dir: Path = BENCH_DIR, box: str = "filter",
               seeds: list[int] | None = None) -> pd.DataFrame:
    """The bench's size check at the soil's posterior mean (<out_dir>/<soil>-posterior.json): its responses on the
    check packings (`seeds`, else [bench] check_seeds) in the configured box and in one grown by half each way
    (`size_check_boxes`: the filter's box or the checks', or the checks' in height alone). Writes <soil>-size.csv
    (the checks' box: <soil>-box-size.csv; in height: <soil>-box-height.csv; every evaluation) and returns the
    verdict per response (`size_verdict`)."""
    cfg = cfg or load_config(soil=soil)
    configured, grown, name = size_check_boxes(cfg, box)
    params = posterior_mean(soil, out_dir)
    seeds = [int(s) for s in (seeds or cfg["check_seeds"])]
    boxes = {"configured": configured, "grown": grown}
    jobs = [(label, settings, s) for label, settings in boxes.items() for s in seeds]
    rows = evaluate_all(soil, [(s, params) for _, _, s in jobs], cfg, out_dir, cfgs=[b for _, b, _ in jobs])
    table = pd.DataFrame([{"box": label, "size_mm": mm(settings["size_mm"]), **row}
                          for (label, settings, _), row in zip(jobs, rows)]).drop(columns=["tau_peak_kpa"], errors="ignore")
    flag = "--size-check" + ("" if box == "filter" else f" {box}") + (f" --seeds {','.join(map(str, seeds))}"
                                                                       if seeds != [int(s) for s in cfg["check_seeds"]] else "")
    atomic_csv(table, Path(out_dir) / f"{soil}-{name}.csv",
               f"./holes calibrate --soil {soil} --bench {flag}; {soil}'s posterior mean on packings "
               f"{','.join(map(str, seeds))} in the {'filter' if box == 'filter' else 'checks'}' box and one grown by half"
               + (" in height alone" if box == "height" else ""))
    pooled = {label: posterior_packings(soil, settings["size_mm"], out_dir, out_dir) for label, settings in boxes.items()}
    verdict = size_verdict(table, pooled)
    atomic_write(Path(out_dir) / f"{soil}-{name}.json", json.dumps(verdict.to_dict(orient="records"), indent=1))
    return verdict


def posterior_mean(soil: str, out_dir: Path = BENCH_DIR) -> dict:
    """The calibrated parameters' posterior mean from <out_dir>/<soil>-posterior.json."""
    path = Path(out_dir) / f"{soil}-posterior.json"
    if not path.exists():
        raise ConfigError(f"{path}: no posterior of {soil}: run `./holes calibrate --soil {soil} --bench` first")
    return {k: float(v) for k, v in json.loads(path.read_text())["mean"].items()}


def cone_transfer(soil: str, seeds: list[int], cfg: dict | None = None, out_dir: Path = BENCH_DIR,
                  workers: int = 2) -> pd.DataFrame:
    """The posterior mean's cone index on the cone's bed at the filter's grains ([cone_check] resolution) and at
    the bench's, the main job's ([bench] resolution), on each packing of `seeds`, `workers` cones at a time: what
    the cone the filter fitted reads at the grains the runs use (its readings, whatever [cone_check] transfer the
    filter took). Writes <soil>-cone-transfer.csv, one row per packing with both cones and their ratio."""
    from analysis.core.config import load_resolution
    cfg = cfg or load_config(soil=soil)
    params = posterior_mean(soil, out_dir)
    grains = {"filter": cfg["cone_check"]["resolution"], "runs": cfg["resolution"]}
    if grains["filter"] == grains["runs"]:
        raise ConfigError(f"{CONFIG}: [cone_check] resolution is the bench's ({grains['runs']}): no transfer to measure")
    jobs = [(s, which) for s in seeds for which in grains]

    def one(job):
        s, which = job
        return cone_check(soil, params, runs_cone(cfg) if which == "runs" else cfg, out_dir, s)["raw"]

    found = dict(zip(jobs, in_parallel(one, jobs, workers, f"cone transfer {soil}", "cones")))
    lo, hi = cone_range(soil, cfg)
    radius = {w: load_resolution(r).radius * 1000 for w, r in grains.items()}
    table = pd.DataFrame([{"seed": s, "r_filter_mm": radius["filter"], "cone_filter_kpa": found[(s, "filter")],
                           "r_runs_mm": radius["runs"], "cone_runs_kpa": found[(s, "runs")],
                           "ratio": found[(s, "runs")] / found[(s, "filter")],
                           "runs_inside": bool(lo <= found[(s, "runs")] <= hi)} for s in seeds])
    atomic_csv(table.round(4), Path(out_dir) / f"{soil}-cone-transfer.csv",
               f"./holes calibrate --soil {soil} --bench --cone-transfer --seeds {','.join(map(str, seeds))}; "
               f"{soil}'s posterior mean's cone index at the filter's grains and the runs'; Table 2 ± tolerance: "
               f"{lo:g}-{hi:g} kPa")
    return table


def difference_interval(a, b, level: float = 0.95) -> tuple[float, float, float]:
    """The difference of two samples' means (b − a) and its Welch t interval.

    >>> d, lo, hi = difference_interval([20, 22, 24], [10, 12, 14])
    >>> round(d, 1), round(lo, 1), round(hi, 1)
    (-10.0, -14.5, -5.5)
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    se = np.sqrt(va + vb)
    dof = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1)) if se > 0 else np.inf
    d = b.mean() - a.mean()
    half = stats.t.ppf(0.5 + level / 2, dof) * se
    return float(d), float(d - half), float(d + half)


def size_shift(configured: pd.DataFrame, grown: pd.DataFrame, responses=RESPONSES) -> pd.DataFrame:
    """The size check's rule, per response of `responses` both tables hold: each box's mean and SD over its packings,
    the shift of the mean (grown − configured) with its Welch 95 % interval, whether the interval leaves zero out
    (`resolved`) and whether the box passes: the grown box moves the mean by less than the packings' SD in the
    configured box. A seed names a packing within one box only (grown, its grains are another draw), so each box is
    read over every packing it ran.

    >>> a = pd.DataFrame({"c_kpa": [27, 28, 29, 28], "phi_deg": [27, 28, 29, 28]})
    >>> b = pd.DataFrame({"c_kpa": [21, 22, 23], "phi_deg": [27.5, 28.5, 29.5]})
    >>> size_shift(a, b)[["response", "shift", "resolved", "passes"]].to_dict(orient="list")
    {'response': ['c_kpa', 'phi_deg'], 'shift': [-6.0, 0.5], 'resolved': [True, False], 'passes': [False, True]}
    """
    rows = []
    for r in [r for r in responses if r in configured and r in grown]:
        a, b = (t[r].dropna().to_numpy(float) for t in (configured, grown))
        if len(a) < 2 or len(b) < 1:
            continue
        sd = float(np.std(a, ddof=1))
        shift, lo, hi = difference_interval(a, b) if len(b) > 1 else (float(b.mean() - a.mean()), math.nan, math.nan)
        rows.append({"response": r, "configured_mean": float(a.mean()), "configured_sd": sd, "configured_n": len(a),
                     "grown_mean": float(b.mean()), "grown_sd": float(np.std(b, ddof=1)) if len(b) > 1 else math.nan,
                     "grown_n": len(b), "shift": shift, "shift_lo": lo, "shift_hi": hi,
                     "resolved": bool(lo > 0 or hi < 0), "passes": bool(abs(shift) < sd)})
    return pd.DataFrame(rows)


def pooled_shift(shifts: pd.DataFrame, level: float = 0.95) -> pd.DataFrame:
    """Several soils' size checks of one box pair (`size_shift` rows, a soil each) pooled per response: the
    fixed-effect mean of their shifts, each weighed by its inverse Welch variance, with its t interval at the
    Satterthwaite degrees of freedom and whether that leaves zero out; and Cochran's Q with its p-value (small: the
    soils' shifts differ beyond their scatter, and one shift for all summarises them poorly). A response needs two
    soils with two packings or more in each box.

    >>> one = {"configured_sd": 2.0, "configured_n": 9, "grown_sd": 2.0, "grown_n": 4, "response": "c_kpa"}
    >>> t = pd.DataFrame([{**one, "shift": -3.0}, {**one, "shift": -4.0}, {**one, "shift": -3.5}])
    >>> p = pooled_shift(t).iloc[0]
    >>> float(p["shift"]), int(p["soils"]), bool(p["resolved"]), round(float(p["q_p"]), 2)
    (-3.5, 3, True, 0.84)
    >>> apart = pooled_shift(t.assign(shift=[-4.0, -3.0, 4.0])).iloc[0]      # a soil that moves the other way
    >>> bool(apart["resolved"]), bool(apart["q_p"] < 0.01)
    (False, True)
    >>> pooled_shift(t[:1]).empty                                   # one soil: nothing to pool
    True
    """
    rows = []
    for response, t in shifts.groupby("response", sort=False):
        t = t[(t["configured_n"] > 1) & (t["grown_n"] > 1)]
        if len(t) < 2:
            continue
        va, vb = (t[f"{b}_sd"] ** 2 / t[f"{b}_n"] for b in ("configured", "grown"))
        w = 1 / (va + vb)
        k = w / w.sum()
        shift, var = float((k * t["shift"]).sum()), float(1 / w.sum())
        dof = var ** 2 / float((k ** 4 * (va ** 2 / (t["configured_n"] - 1) + vb ** 2 / (t["grown_n"] - 1))).sum())
        half = stats.t.ppf(0.5 + level / 2, dof) * math.sqrt(var)
        q = float((w * (t["shift"] - shift) ** 2).sum())
        rows.append({"response": response, "soils": len(t), "shift": shift, "shift_lo": shift - half,
                     "shift_hi": shift + half, "dof": dof, "resolved": bool(shift - half > 0 or shift + half < 0),
                     "q": q, "q_p": float(stats.chi2.sf(q, len(t) - 1))})
    return pd.DataFrame(rows)


def size_verdict(table: pd.DataFrame, pooled: dict | None = None) -> pd.DataFrame:
    """`size_shift` of a size check's table (`box` "configured" or "grown", one row per evaluation), c and φ read
    over `pooled`'s rows where given (per box, every packing it ran at the set: `posterior_packings`).

    >>> t = pd.DataFrame({"box": ["configured"] * 3 + ["grown"] * 3, "c_kpa": [27, 28, 29, 21, 22, 23],
    ...                   "phi_deg": [27, 28, 29, 27.5, 28.5, 29.5], "collapse_deg": [33, 37, 35, 36, 35, 34]})
    >>> size_verdict(t)[["response", "shift", "passes"]].to_dict(orient="list")
    {'response': ['c_kpa', 'phi_deg', 'collapse_deg'], 'shift': [-6.0, 0.5, 0.0], 'passes': [False, True, True]}
    >>> size_verdict(t)[["shift_lo", "shift_hi"]].round(1).to_dict(orient="list")
    {'shift_lo': [-8.3, -1.8, -4.2], 'shift_hi': [-3.7, 2.8, 4.2]}
    >>> more = t[t["box"] == "configured"].assign(c_kpa=[20, 22, 24])
    >>> pooled = {"configured": pd.concat([t[t["box"] == "configured"], more]), "grown": t[t["box"] == "grown"]}
    >>> v = size_verdict(t, pooled)
    >>> v["response"].tolist(), v["configured_n"].tolist(), v["shift"].tolist(), v["passes"].tolist()
    (['c_kpa', 'phi_deg', 'collapse_deg'], [6, 6, 3], [-3.0, 0.5, 0.0], [True, True, True])
    """
    own = size_shift(table[table["box"] == "configured"], table[table["box"] == "grown"])
    if not pooled:
        return own
    shear = size_shift(pooled["configured"], pooled["grown"], SHEAR_RESPONSES)
    if shear.empty:
        return own
    return pd.concat([shear, own[~own["response"].isin(shear["response"])]], ignore_index=True)


def at_posterior(table: pd.DataFrame, post: dict) -> pd.DataFrame:
    """The rows of a check table run at the parameter set `post` (each parameter to the digits an evaluation runs
    with): rows of another set, an earlier posterior's, give none."""
    want = rounded(post)
    if any(k not in table for k in want):
        return table.iloc[:0]
    return table[[rounded({k: row[k] for k in want}) == want for row in table.to_dict(orient="records")]]


def posterior_packings(soil: str, box_mm, folder: Path = BENCH_DIR, out_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """Every kept check of the soil's posterior mean (<folder>/<soil>-posterior.json) whose shear box was `box_mm`,
    one row per packing, measured (`measured`): the rows at that set of the check and size tables in `folder` (and
    in its FILTER_BOX_CHECKS), the box read from each evaluation's folder in <out_dir>/<soil>/. A seed names a
    packing within one box only, so the size check's rule reads each box over all of them."""
    folder, out_dir = Path(folder), Path(out_dir)
    if not (folder / f"{soil}-posterior.json").exists():
        return pd.DataFrame()
    post = posterior_mean(soil, folder)
    paths = [folder / f"{soil}{part}.csv" for part in (*CHECK_TABLES, *SIZE_TABLES)]
    paths += [folder / FILTER_BOX_CHECKS / f"{soil}{part}.csv" for part in CHECK_TABLES]
    rows, box = {}, [float(v) for v in box_mm]
    for path in [p for p in paths if p.exists()]:
        table = at_posterior(pd.read_csv(path, comment="#", float_precision="round_trip"), post)
        if not {"id", "seed"} <= set(table):
            continue
        for row in table.to_dict(orient="records"):
            evaluation = out_dir / soil / str(row["id"])
            if (int(row["seed"]) not in rows and not isinstance(row.get("failed"), str)
                    and evaluation_box(evaluation) == box):
                rows[int(row["seed"])] = measured(row, evaluation, kept_only=True)
    return pd.DataFrame([rows[s] for s in sorted(rows)])


def cone_path(soil: str, params: dict, cfg: dict, out_dir: Path = BENCH_DIR, seed: int | None = None) -> tuple[Path, dict]:
    """Where `cone_check` keeps the set's cone summary on packing `seed` (cfg's [cone_check] packing when None), named
    by the parameters, the calibration's fixed ones and the cone's bed, and that [cone_check] with its seed and, for
    tool_friction = "field", the soil's friction on steel in place of the word (`tool_friction_deg`)."""
    c = dict(cfg["cone_check"])
    if seed is not None:
        c["seed"] = int(seed)
    if c.pop("tool_friction", "grain") == "field":      # named only when set: the earlier cones keep their names
        c["tool_friction_deg"] = field_tool_friction(soil)
    key = {"params": dict(sorted(rounded(params).items())), "fixed": dict(sorted(cfg.get("fixed", {}).items())),
           "cone": {k: v for k, v in sorted(c.items()) if k not in ("tolerance", "transfer")}}
    return Path(out_dir) / "cone" / f"{soil}-s{c['seed']}-{digest(key, 10)}.json", c


def cone_check(soil: str, params: dict, cfg: dict, out_dir: Path = BENCH_DIR, seed: int | None = None) -> dict:
    """The parameter set's cone index on the cone calibration's bed (cfg's [cone_check]: its grains, periodic cell,
    cone, speed and packing, or packing `seed`) against Table 2's: inside when within the tolerance, one such bed's
    scatter. With a [cone_check] transfer, `mean` is the cone's reading times it (what the runs' grains read, where
    that ratio was measured) and `raw` the reading. The cone's summary is kept as
    <out_dir>/cone/<soil>-s<seed>-<hash>.json and reused."""
    path, c = cone_path(soil, params, cfg, out_dir, seed)
    if path.exists():
        summary = json.loads(path.read_text())
    else:
        args = ["--soil", soil, "--resolution", c["resolution"], "--size", ",".join(map(str, c["size_mm"])),
                "--lateral", "periodic", "--seed", str(c["seed"]), "--cone-scale", str(c["cone_scale"]),
                "--cone-speed", str(c["speed_m_s"]), "--threads", "1", "--out", str(path.parent)]
        held = {k: c[k] for k in ("tool_friction_deg",) if k in c}     # held like a fixed one: a probe's own stands
        items = overrides(params, {**cfg.get("fixed", {}), **held})
        bond = dict(item.split("=") for item in items).get("normal_cohesion")
        summary = cone_scene([*args, *(["--cohesion", bond] if bond else []),
                              *[a for item in items for a in ("--test-set", item)]], path.with_suffix(".log"))
        atomic_write(path, json.dumps(summary, indent=1))
    raw = summary["cone_index_pa"] / 1000
    value = raw * float(c.get("transfer", 1.0))
    lo, hi = cone_range(soil, cfg)
    return {"mean": float(value), "raw": float(raw), "sd": float("nan"), "target": [lo, hi],
            "every_packing_inside": bool(lo <= value <= hi), "mean_inside": bool(lo <= value <= hi)}


def cone_columns(soil: str, params: dict, cfg: dict, out_dir: Path = BENCH_DIR, seed: int | None = None) -> dict:
    """An evaluation's cone columns (`cone_check`): `cone_kpa`, the index the filter weighs, and `cone_reading_kpa`,
    the cone's reading (the same unless a [cone_check] transfer scales it)."""
    cone = cone_check(soil, params, cfg, out_dir, seed)
    return {"cone_kpa": cone["mean"], "cone_reading_kpa": cone["raw"]}


def cone_range(soil: str, cfg: dict) -> tuple[float, float]:
    """Table 2's cone index ± the [cone_check] tolerance, kPa."""
    from analysis.core.soil_config import load_soil
    table2, tol = load_soil(soil).cone_index / 1000, float(cfg["cone_check"]["tolerance"])
    return table2 * (1 - tol), table2 * (1 + tol)


def after_earlier(table: pd.DataFrame, path: Path) -> pd.DataFrame:
    """`table` after the rows an earlier call kept in `path`, one row per evaluation id (the newest)."""
    if not path.exists():
        return table
    return pd.concat([pd.read_csv(path, comment="#"), table]).drop_duplicates("id", keep="last")


def cones(soil: str, ids: list[str], cfg: dict, out_dir: Path = BENCH_DIR, workers: int = 2,
          runs_grains: bool = False) -> pd.DataFrame:
    """The cone check of finished evaluations (`ids`, folders of <out_dir>/<soil>/), each on its own packing, `workers`
    at a time, beside their bench responses: where in the bench's region the cone meets Table 2. Writes
    <out_dir>/<soil>-cones.csv (every evaluation whose cone has run, these and earlier ones); `runs_grains`: the cone
    at the runs' grains, as a check reads it (`runs_cone`), in <out_dir>/<soil>-cones-runs-grains.csv."""
    if "cone_check" not in cfg:
        raise ConfigError(f"{CONFIG}: no [cone_check] section: the cone's bed and cone are not given")
    cfg = runs_cone(cfg) if runs_grains else cfg
    rows = []
    for i in ids:
        done = Path(out_dir) / soil / i / "responses.json"
        row = json.loads(done.read_text()) if done.exists() else {}
        if not row or row.get("failed"):
            raise ConfigError(f"--cones: {i}: no finished evaluation of {soil} in {Path(out_dir) / soil}; allowed the "
                              "ids of its folders with a responses.json")
        rows.append(measured(row, done.parent))
    names = list(cfg["bounds"])

    def one(row):
        ran = [n for n in names if n in row]        # the parameters the evaluation set (the others: the soil's)
        return {**{k: row[k] for k in ("id", *ran, *RESPONSES)},
                **cone_columns(soil, {n: row[n] for n in ran}, cfg, out_dir, int(row["seed"]))}
    with ThreadPoolExecutor(max_workers=workers) as pool:
        table = pd.DataFrame(list(pool.map(one, rows)))
    path = Path(out_dir) / f"{soil}-cones{'-runs-grains' if runs_grains else ''}.csv"
    table = after_earlier(table, path)
    lo, hi = cone_range(soil, cfg)
    where = (" --runs-grains", " at the runs' grains") if runs_grains else ("", "")
    atomic_csv(table.round(4), path, f"./holes calibrate --soil {soil} --bench --cones ID,...{where[0]}; the cone "
               f"index of [cone_check]{where[1]} beside each evaluation's bench responses; Table 2 ± tolerance: "
               f"{lo:g}-{hi:g} kPa")
    return table


def probes(soil: str, sets: list[dict], cfg: dict, out_dir: Path = BENCH_DIR,
           seeds: list[int] | None = None) -> pd.DataFrame:
    """Chosen parameter sets' bench responses and cone index on the calibration's (first) packing, or on each of
    `seeds`, with the filter's tests and cone, cfg's workers at a time:
    where a soil's prior should lie, looked at before a filter spends its iterations there. Each set names every
    calibrated parameter (cfg's bounds) and may name other contact parameters the filter holds (a shear bond of its
    own: `shear_cohesion`); each evaluation is a run folder like the filter's and reused by it. Writes
    <out_dir>/<soil>-probes.csv (these probes and earlier ones)."""
    names = set(cfg["bounds"])
    for p in sets:
        if not names <= set(p):
            raise ConfigError(f"--probe {','.join(sorted(p))}: allowed every calibrated parameter "
                              f"{', '.join(sorted(names))}, each NAME=VALUE, and other contact parameters besides")
    seeds = seeds or filter_seeds(cfg)[:1]
    rows = evaluate_all(soil, [(s, dict(p)) for p in sets for s in seeds], cfg, out_dir, with_cone=True)
    table = pd.DataFrame(rows).drop(columns=["tau_peak_kpa"], errors="ignore")
    path = Path(out_dir) / f"{soil}-probes.csv"
    table = after_earlier(table, path)
    lo, hi = cone_range(soil, cfg)
    atomic_csv(table.round(4), path, f"./holes calibrate --soil {soil} --bench --probe NAME=VALUE,...; chosen "
               f"parameter sets' bench responses and [cone_check] cone index on the packing of each row's seed; Table 2 ± "
               f"tolerance: {lo:g}-{hi:g} kPa")
    return table


def cone_scene(args: list[str], log_path: Path) -> dict:
    """scripts/cone.py with `args` in its own process, its lines to `log_path`; its summary."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    code, out = run_logged([sys.executable, str(ROOT / "scripts/cone.py"), *args], log_path)
    if code != 0:
        raise RuntimeError(f"scripts/cone.py exited {code}:\n{''.join(log_path.read_text().splitlines(True)[-8:])}")
    return json.loads(out.strip().splitlines()[-1])


def report(out_dir: Path = BENCH_DIR, config: Path | None = None) -> list[Path]:
    """Pictures of every soil calibrated so far: the filter's samples and posterior per parameter
    (posterior.png), and each bench response of the samples and of the posterior's check packings against the
    target's range (responses.png; c and φ as the filter weighs them, plus its [bench] shear_shift); with the
    response surfaces (`surfaces_report`) for the filter of configs/bench_calibration.toml. `config`: a variant
    config, whose filter's folder `out_dir` is (`filter_dir`): its parameters, no surfaces."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    soils = [s for s in ("clay", "loam", "sand") if (Path(out_dir) / f"{s}.csv").exists()]
    if not soils:                     # no filter finished: the planes over the running ones' finished iterations
        return surfaces_report(out_dir) if config is None else []
    cfgs = {s: load_config(config or CONFIG, s) for s in soils}
    tables = {s: pd.read_csv(Path(out_dir) / f"{s}.csv", comment="#") for s in soils}
    names = list(dict.fromkeys(k for s in soils for k in cfgs[s]["bounds"]))
    fig, axes = plt.subplots(len(soils), len(names), figsize=(4 * len(names), 2.6 * len(soils)), squeeze=False)
    for i, soil in enumerate(soils):
        t = tables[soil]
        post = json.loads((Path(out_dir) / f"{soil}-posterior.json").read_text())
        last = t[t["weight_last"].notna()]
        for j, n in enumerate(names):
            ax = axes[i][j]
            if n not in post["mean"]:             # a filter that did not calibrate it (held at the soil's value)
                ax.text(0.5, 0.5, f"{soil}: {n} not calibrated", ha="center", transform=ax.transAxes)
                ax.set_axis_off()
                continue
            ax.scatter(t[n], t["iteration"], s=12, c="0.6", label="samples")
            ax.scatter(last[n], last["iteration"], s=20 + 300 * last["weight_last"], c=SOIL_COLOURS[soil],
                       label="last, by weight")
            lo, hi = post["interval"][n]
            ax.axvspan(lo, hi, color=SOIL_COLOURS[soil], alpha=0.15, label="95 % interval")
            ax.axvline(post["mean"][n], color=SOIL_COLOURS[soil], label="posterior mean")
            ax.set_xlabel(n), ax.set_ylabel(f"{soil}: iteration"), ax.set_yticks(sorted(t["iteration"].unique()))
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    paths = [Path(out_dir) / "posterior.png", Path(out_dir) / "responses.png"]
    fig.savefig(paths[0], dpi=110)
    plt.close(fig)
    checks = {soil: json.loads(p.read_text()) for soil in soils if (p := Path(out_dir) / f"{soil}-check.json").exists()}
    shifts = {soil: cfgs[soil].get("shear_shift", {}) for soil in soils}
    check_tables = {soil: pd.read_csv(p, comment="#") if (p := Path(out_dir) / f"{soil}-check.csv").exists()
                    else pd.DataFrame() for soil in soils}
    panels = [*RESPONSES, *(["cone_kpa"] if any("cone_kpa" in c for c in checks.values()) else [])]
    from analysis.soil.cell import rated_packings    # the cell's module reads this one's
    grown = {}              # a shifted filter's posterior in a cell larger than the filter's, where it ran there
    for soil in soils:
        cells = rated_packings(soil, bench_dir=out_dir) if shifts[soil] else pd.DataFrame()
        if len(cells) and cells["edge_mm"].max() > float(cfgs[soil].get("cell_edges_mm", [np.inf])[0]):
            grown[soil] = cells[cells["edge_mm"] == cells["edge_mm"].max()]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), squeeze=False)
    for j, r in enumerate(panels):
        ax = axes[0][j]
        for i, soil in enumerate(soils):
            if r == "cone_kpa":         # Table 2 ± its tolerance; a check on packing 1 unless the filter fitted it
                if r not in checks.get(soil, {}):
                    continue
                lo, hi = checks[soil][r]["target"]
            else:
                lo, hi = load_targets(soil).loc[r, ["lo", "hi"]]
            ax.add_patch(plt.Rectangle((i - 0.35, lo), 0.7, hi - lo, color=SOIL_COLOURS[soil], alpha=0.2,
                                       label="target range" if i == 0 else None))
            shift = float(shifts[soil].get(r, 0.0))     # a shifted filter's c and φ: its reading plus the shift
            t = tables[soil]
            if r in t:
                ax.scatter(np.full(len(t), i - 0.15), t[r] + shift, s=10, c="0.5",
                           label="filter's samples, as weighed" if i == 0 else None)
            c = check_tables[soil]
            points = c[r].to_numpy(float) if r in c else [checks[soil][r]["mean"]] if r in checks.get(soil, {}) else []
            ax.scatter(np.full(len(points), i + 0.15), np.asarray(points, float) + shift, s=36, marker="D",
                       c=SOIL_COLOURS[soil], label="posterior mean, check packings" if i == 0 else None)
            if r in shifts[soil] and soil in grown:     # what the shift stands in for: the grown cell's own reading
                g = grown[soil]
                ax.scatter(np.full(len(g), i + 0.3), g[r], s=36, marker="D", facecolors="none",
                           edgecolors=SOIL_COLOURS[soil], label=f"the same, {g['edge_mm'].iloc[0]:g} mm cell")
        moved = {f"{s} {shifts[s][r]:+g}" for s in soils if r in shifts[s]}
        ax.set_xticks(range(len(soils)), soils), ax.set_xlim(-0.6, len(soils) - 0.4)
        ax.set_title(f"{r}: reading + shift ({', '.join(sorted(moved))})" if moved else r)
        ax.autoscale_view()
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(paths[1], dpi=110)
    plt.close(fig)
    return paths + (surfaces_report(out_dir) if config is None else [])


def variant_reports(out_dir: Path = BENCH_DIR) -> list[Path]:
    """`report` of each variant config's filter (configs/bench_calibration_*.toml with a [bench] filter_folder) that
    has drawn a posterior, in its folder."""
    paths = []
    for config in sorted((ROOT / "configs").glob("bench_calibration_*.toml")):
        cfg = load_config(config)
        if cfg.get("filter_folder"):
            paths += report(filter_dir(cfg, out_dir), config)
    return paths


POSTERIOR_HEAD = "# GrainLearning's posterior on the bench tests"


def check_status(check_result: dict) -> str:
    """The check's two verdicts in words: which responses a packing reads outside their target, and which the
    packings' mean does.

    >>> check_status({"c_kpa": {"every_packing_inside": True, "mean_inside": True},
    ...               "collapse_deg": {"every_packing_inside": False, "mean_inside": False}})
    "outside its target on a check packing: collapse_deg; the packings' mean outside: collapse_deg"
    """
    missed = [r for r, v in check_result.items() if not v["every_packing_inside"]]
    off = [r for r, v in check_result.items() if not v["mean_inside"]]
    return ("within every target on every check packing" if not missed else "outside its target on a check packing: "
            + ", ".join(missed)) + ("; the packings' mean within every target" if not off else
                                    "; the packings' mean outside: " + ", ".join(off))


def packings_line(result: dict, seeds: list[int], key: str = "check_packings", box_mm=None) -> str:
    """The posterior's check on more packings (`check_packings`) as its `[bench_posterior]` line `key`: per response
    the verdict of the packings' mean, the mean and its 95 % interval (`box_mm`: the shear box's size, where named).

    >>> packings_line({"c_kpa": {"mean": 23.71, "mean_interval": [20.43, 27.0], "mean_verdict": "inside"}}, [1, 2, 3])
    'check_packings = { seeds = [1, 2, 3], c_kpa = "inside: 23.7 [20.4, 27]" }'
    """
    verdicts = [f'{r} = "{v["mean_verdict"]}: {v["mean"]:.3g} [{v["mean_interval"][0]:.3g}, {v["mean_interval"][1]:.3g}]"'
                for r, v in result.items()]
    box = [f"box_mm = {[float(v) for v in box_mm]}"] if box_mm is not None else []
    return f"{key} = {{ " + ", ".join([*box, f"seeds = {list(map(int, seeds))}", *verdicts]) + " }"


def posterior_block(soil: str, post: dict, check_result: dict, command: str, packings: str | None = None,
                    folder: Path = BENCH_DIR) -> str:
    """The `[bench_posterior]` table a soil's config carries: the folder its posterior and checks are kept in
    (`posterior_folder`), the parameters held fixed, each calibrated parameter's posterior mean and 95 % interval,
    their correlations, the bench responses of the mean over the check packings, and whether every packing's
    response lies inside every target's range (status); `packings`, its check on more packings (`packings_line`)."""
    status = check_status(check_result)
    source = shown(Path(folder).resolve() / f"{soil}-posterior.json")
    lines = [POSTERIOR_HEAD + f" (`{command}`), {source}; the presets",
             f'# of soils = "bench" run the one in configs/soils/{soil}.toml, the others [soil] above.', "[bench_posterior]",
             f'folder = "{shown(Path(folder).resolve())}"', f'status = "{status}"']
    if packings:
        lines.append(packings)
    if post.get("fixed"):                     # held, not calibrated: the posterior holds with these only
        lines.append("fixed = { " + ", ".join(f"{k} = {v:g}" for k, v in post["fixed"].items()) + " }")
    for n in post["names"]:
        lo, hi = post["interval"][n]
        lines.append(f"{n} = {{ mean = {post['mean'][n]:.4g}, lo = {lo:.4g}, hi = {hi:.4g} }}")
    names = post["names"]
    pairs = [f"{a}__{b} = {post['correlation'][a][b]:.2f}" for i, a in enumerate(names) for b in names[i + 1:]]
    lines.append("correlation = { " + ", ".join(pairs) + " }")
    for r, v in check_result.items():
        lines.append(f"{r} = {{ mean = {v['mean']:.3g}, sd = {v['sd']:.2g}, target = [{v['target'][0]:g}, "
                     f"{v['target'][1]:g}] }}")
    return "\n".join(lines) + "\n"


def posterior_configs(soil: str, folder: Path = BENCH_DIR) -> list[Path]:
    """The soil configs a filter's posterior is written into as their `[bench_posterior]`: the filter's own record,
    <folder>/<soil>.toml (a copy of the soil's config beside its evaluations), and configs/soils/<soil>.toml, the
    runs' soil (the presets' `soils = "bench"`), where its `[bench_posterior]` names `folder`. The box filter
    (configs/bench_calibration.toml, folder BENCH_DIR) keeps no record of its own while the runs' config carries its
    posterior or none yet. A posterior drawn in another folder so replaces none the runs use; copied over
    configs/soils/<soil>.toml it is adopted, and its filter's later checks reach both files.

    >>> [[str(c.relative_to(ROOT)) for c in posterior_configs(s, f)]
    ...  for s, f in (("sand", BENCH_DIR), ("sand", BENCH_DIR / "onset-filter"))]
    [['configs/soils/sand.toml'], ['results/calibration/bench/onset-filter/sand.toml']]
    """
    folder, runs = Path(folder), ROOT / "configs/soils" / f"{soil}.toml"
    drawn = read_toml(runs).get("bench_posterior", {}).get("folder")
    box = folder.resolve() == BENCH_DIR.resolve()
    here = folder.resolve() == (ROOT / drawn).resolve() if drawn else box
    return ([] if here and box else [folder / f"{soil}.toml"]) + ([runs] if here else [])


def write_posterior(soil: str, post: dict, check_result: dict, command: str, path: Path | None = None,
                    packings: str | None = None, folder: Path = BENCH_DIR) -> Path:
    """Put (or replace) the `[bench_posterior]` table of the soil config `path` (default: each of
    `posterior_configs`), keeping the rest of each file as it is (a path not yet written starts as a copy of
    configs/soils/<soil>.toml); each file must still load. Returns the first written."""
    from analysis.core.soil_config import load_soil
    paths = [Path(path)] if path else posterior_configs(soil, folder)
    block = posterior_block(soil, post, check_result, command, packings, folder)
    for p in paths:
        text = (p if p.exists() else ROOT / "configs/soils" / f"{soil}.toml").read_text()
        if POSTERIOR_HEAD in text:
            text = text[:text.index(POSTERIOR_HEAD)].rstrip("\n") + "\n"
        atomic_write(p, text + "\n" + block)
        load_soil(p)
    return paths[0]


def record_packings(soil: str, result: dict, seeds: list[int], out_dir: Path = BENCH_DIR,
                    path: Path | None = None, command: str | None = None) -> Path:
    """The posterior's check on more packings written into the soil config's `[bench_posterior]` beside the filter's
    posterior (<out_dir>/<soil>-posterior.json) and its check on the check packings (<soil>-check.json), and where
    the checks' box grown by half ([bench] check_size_check_mm) has run on two packings or more, its shear box's
    verdicts there (`grown_box_packings`), and the wall-free cell's where it has run (`cell_packings`, cell.csv)."""
    post, three = (json.loads((Path(out_dir) / f"{soil}-{name}.json").read_text()) for name in ("posterior", "check"))
    lines = [packings_line(result, seeds)]
    box = load_config(soil=soil).get("check_size_check_mm")
    grown = posterior_packings(soil, box, out_dir, out_dir) if box else pd.DataFrame()
    if len(grown) > 1:
        ranges = {r: result[r]["target"] for r in SHEAR_RESPONSES if r in result}
        lines.append(packings_line(judged(grown, ranges), grown["seed"], "grown_box_packings", box))
    from analysis.soil.cell import posterior_line       # the cell's module reads this one's
    cell = posterior_line(soil, out_dir)
    if cell:
        lines.append(cell)
    return write_posterior(soil, post, three, command or f"./holes calibrate --soil {soil} --bench", path,
                           "\n".join(lines), out_dir)


SURFACE_TERMS = ("bond_kpa", "friction_deg", "disturbed_bond_kpa", "rolling_friction", "damping", "pressed_adhesion")
UNSET_DAMPING = 0.2    # the local damping an evaluation that does not set one runs at: every soil's configured value
UNSET = {"new_contact_cohesion": 0.0, "damping": UNSET_DAMPING, "pressed_adhesion": 0.0}   # a term's value where
# neither an evaluation nor the calibration's [fixed] gives one


def surface_terms(table: pd.DataFrame, fixed: dict | None = None) -> pd.DataFrame:
    """An evaluation's parameters as the response surfaces' terms: the intact bond and the bond a contact made
    after disturbance gets (new-contact share × bond), both in kPa, the grains' friction, rolling friction, the
    local damping (UNSET_DAMPING where the evaluation did not set it) and the pressed re-adhesion (0 where not set).
    A parameter the table lacks takes its `fixed` value (the calibration's [fixed]), the share 0 and the damping
    UNSET_DAMPING failing that."""
    fixed = {**UNSET, **(fixed or {})}

    def column(name):
        given = table[name] if name in table else pd.Series(np.nan, index=table.index)
        return given.fillna(fixed[name]).astype(float)

    return pd.DataFrame({"bond_kpa": table["normal_cohesion"] / 1e3, "friction_deg": table["friction_deg"],
                         "disturbed_bond_kpa": table["normal_cohesion"] * column("new_contact_cohesion") / 1e3,
                         "rolling_friction": table["rolling_friction"], "damping": column("damping"),
                         "pressed_adhesion": column("pressed_adhesion")})


def response_surfaces(table: pd.DataFrame, fixed: dict | None = None) -> pd.DataFrame:
    """Each bench response (and the cone index, where the table has it) fitted as a plane in SURFACE_TERMS over a
    soil's finished evaluations (least squares; a term that does not vary over them gets no slope):
    one row per response with its intercept, a coefficient per term, R² and the residual SD (the packing's and the
    plane's misfit together). What each test answers to, and a cheap stand-in for the scenes over the prior.

    >>> t = pd.DataFrame({"normal_cohesion": [1e5, 2e5, 3e5, 1e5, 2e5, 4e5], "friction_deg": [10, 20, 15, 30, 25, 12],
    ...                   "new_contact_cohesion": [.01, .02, 0, .03, .01, .02], "rolling_friction": [0, .1, .2, .1, 0, .3]})
    >>> t["c_kpa"] = 0.1 * t.normal_cohesion / 1e3 + 5; t["phi_deg"] = 20 + 0.5 * t.friction_deg
    >>> t["collapse_deg"] = 30 + 2 * t.normal_cohesion * t.new_contact_cohesion / 1e3
    >>> s = response_surfaces(t).set_index("response")
    >>> round(s.loc["c_kpa", "bond_kpa"], 3), round(s.loc["phi_deg", "friction_deg"], 3), round(s.loc["collapse_deg", "r2"], 3)
    (0.1, 0.5, 1.0)
    """
    tested = table.dropna(subset=list(RESPONSES))
    rows = []
    for r in (*RESPONSES, *(["cone_kpa"] if "cone_kpa" in tested else [])):     # the cone where the filter fitted it
        ok = tested.dropna(subset=[r])
        terms = surface_terms(ok, fixed)
        varied = [t for t in SURFACE_TERMS if terms[t].nunique() > 1]
        coef, r2, resid = least_squares_plane(terms[varied].to_numpy(float), ok[r].to_numpy(float))
        slopes = {t: 0.0 for t in SURFACE_TERMS} | dict(zip(varied, coef[1:]))
        rows.append({"response": r, "intercept": coef[0], **slopes, "n": len(ok), "r2": r2,
                     "resid_sd": float(np.std(resid, ddof=len(coef))) if len(ok) > len(coef) else math.nan})
    return pd.DataFrame(rows)


def least_squares_plane(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """y fitted as a plane in X's columns (least squares): the intercept then a slope per column, R² (NaN where y
    does not vary) and the residuals.

    >>> coef, r2, _ = least_squares_plane(np.array([[0.0], [1.0], [2.0]]), np.array([1.0, 3.0, 5.0]))
    >>> coef.round(6).tolist(), round(r2, 6)
    ([1.0, 2.0], 1.0)
    """
    A = np.column_stack([np.ones(len(y)), X])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - A @ coef
    spread = np.sum((y - y.mean()) ** 2)
    return coef, float(1 - np.sum(resid ** 2) / spread) if spread > 0 else math.nan, resid


def feasible_region(surfaces: pd.DataFrame, targets: pd.DataFrame, bounds: dict, n: int = 200_000,
                    seed: int = 0, fixed: dict | None = None) -> dict:
    """Where in the prior (`bounds`, uniform) the surfaces put every response inside its target's range: the
    share of the prior that does, and each parameter's 5, 50 and 95 % there (NaN when none does). Where the next
    stage's prior belongs, not a posterior: the planes' misfit is left out.

    >>> s = pd.DataFrame([{"response": "c_kpa", "intercept": 0.0, "bond_kpa": 0.1, "friction_deg": 0.0,
    ...                    "disturbed_bond_kpa": 0.0, "rolling_friction": 0.0}])
    >>> t = pd.DataFrame({"lo": [20.0], "hi": [30.0]}, index=["c_kpa"])
    >>> r = feasible_region(s, t, {"normal_cohesion": (0, 1e6), "friction_deg": (10, 30),
    ...                            "new_contact_cohesion": (0, 0.1), "rolling_friction": (0, 0.3)})
    >>> round(r["share"], 2), [round(v / 1e3) for v in r["normal_cohesion"][::2]]
    (0.1, [205, 295])
    """
    rng = np.random.default_rng(seed)
    sample = pd.DataFrame({k: rng.uniform(lo, hi, n) for k, (lo, hi) in bounds.items()})
    terms = surface_terms(sample, fixed).to_numpy(float)
    inside = np.ones(n, bool)
    for s in surfaces.itertuples():
        pred = s.intercept + terms @ np.array([getattr(s, t, 0.0) for t in SURFACE_TERMS])
        inside &= (pred >= targets.loc[s.response, "lo"]) & (pred <= targets.loc[s.response, "hi"])
    out = {"share": float(inside.mean())}
    for k in bounds:
        out[k] = [float(v) for v in np.percentile(sample.loc[inside, k], [5, 50, 95])] if inside.any() else [math.nan] * 3
    return out


def deepest_margin(coefs: np.ndarray, intercepts, sds, ranges: list, box: list, rows: list = ()) -> tuple[np.ndarray, float]:
    """The point of `box` (a (lo, hi) per term, None unbounded) where every plane (a row of `coefs`, a slope per term,
    with its intercept and residual SD) lies the most residual SDs m inside its range ((lo, hi) each), and m (scipy's
    linear programme; negative where the ranges do not all meet in `box`); `rows`: constraints row · point <= 0 on the
    terms besides. The planes' deepest set: `deepest_point`'s and analysis/soil/onset.py's `deepest`.

    >>> x, m = deepest_margin(np.array([[1.0]]), [0.0], [2.0], [(10.0, 30.0)], [(0.0, 100.0)])
    >>> round(float(x[0]), 6), round(m, 6)
    (20.0, 5.0)
    """
    from scipy.optimize import linprog
    A = [[*row, 0.0] for row in rows]
    rhs = [0.0] * len(A)
    for coef, c0, sd, (lo, hi) in zip(coefs, intercepts, sds, ranges):
        A += [[*-coef, sd], [*coef, sd]]
        rhs += [c0 - lo, hi - c0]
    out = linprog([0.0] * len(box) + [-1.0], A_ub=A, b_ub=rhs, bounds=[*box, (None, None)])
    if not out.success:
        raise RuntimeError(f"the planes' deepest set: the linear programme did not solve ({out.message})")
    return out.x[:-1], float(out.x[-1])


def deepest_point(surfaces: pd.DataFrame, targets: pd.DataFrame, bounds: dict, fixed: dict | None = None) -> dict:
    """The parameter set in `bounds` whose planes lie deepest inside every target's range, the depth counted in
    each plane's residual SD (the runs' own scatter with the plane's misfit): the largest t with every response
    at least t SDs from both ends of its range (scipy's linear programme in the planes' terms; the share bond, share
    × intact bond, bounded by the share's range; a parameter `bounds` lacks held at its `fixed` value). Where a check
    on several packings has the best chance of finding every response inside; t < 0 when the planes meet the
    targets nowhere in `bounds` (the least miss).

    >>> s = pd.DataFrame([{"response": "c_kpa", "intercept": 0.0, "bond_kpa": 0.1, "friction_deg": 0.0,
    ...                    "disturbed_bond_kpa": 0.0, "rolling_friction": 0.0, "resid_sd": 1.0}])
    >>> t = pd.DataFrame({"lo": [20.0], "hi": [30.0]}, index=["c_kpa"])
    >>> d = deepest_point(s, t, {"normal_cohesion": (0, 1e6), "friction_deg": (10, 30),
    ...                          "new_contact_cohesion": (0, 0.1), "rolling_friction": (0, 0.3)})
    >>> round(d["margin_sd"], 3), round(d["normal_cohesion"] / 1e3), round(d["c_kpa"], 3)
    (5.0, 250, 25.0)
    """
    fixed = {**UNSET, **(fixed or {})}

    def held(name):
        return tuple(bounds.get(name, (fixed[name], fixed[name])))

    (b_lo, b_hi), (s_lo, s_hi) = bounds["normal_cohesion"], held("new_contact_cohesion")
    box = [(b_lo / 1e3, b_hi / 1e3), tuple(bounds["friction_deg"]), (0.0, None), tuple(bounds["rolling_friction"]),
           held("damping"), held("pressed_adhesion")]
    planes = surfaces.set_index("response").reindex(columns=[*SURFACE_TERMS, "intercept", "resid_sd"])
    coefs = planes[list(SURFACE_TERMS)].fillna(0.0).to_numpy(float)
    ranges = [tuple(targets.loc[r, ["lo", "hi"]]) for r in planes.index]
    x, margin = deepest_margin(coefs, planes["intercept"].to_numpy(float), planes["resid_sd"].to_numpy(float), ranges,
                               box, [[-s_hi, 0, 1, 0, 0, 0], [s_lo, 0, -1, 0, 0, 0]])   # the share bond in its range
    bond, friction, disturbed, rolling, damping, pressed = x
    point = {"margin_sd": float(margin), "normal_cohesion": float(bond * 1e3), "friction_deg": float(friction),
             **({"new_contact_cohesion": float(disturbed / bond) if bond > 0 else 0.0}
                if "new_contact_cohesion" in bounds else {}), "rolling_friction": float(rolling),
             **({"damping": float(damping)} if "damping" in bounds else {}),
             **({"pressed_adhesion": float(pressed)} if "pressed_adhesion" in bounds else {})}
    predicted = planes["intercept"].to_numpy(float) + coefs @ np.array([bond, friction, disturbed, rolling, damping,
                                                                        pressed])
    return {**point, **dict(zip(planes.index, map(float, predicted)))}


def margin_profile(surfaces: pd.DataFrame, targets: pd.DataFrame, bounds: dict, fixed: dict | None = None,
                   points: int = 9) -> pd.DataFrame:
    """How far the bench tests pin each calibrated parameter: the planes' deepest margin (`deepest_point`, in
    residual SDs) with the parameter held at each of `points` values across its prior and the others free. A
    profile that stays near its top across the prior is a parameter the others make up for, one the bench does not
    identify; one that falls below 0 on both sides of a narrow window is pinned. NaN where no margin can be
    counted (a plane without scatter that the held value leaves outside its range).

    >>> s = pd.DataFrame([{"response": "c_kpa", "intercept": 0.0, "bond_kpa": 0.1, "friction_deg": 0.0,
    ...                    "disturbed_bond_kpa": 0.0, "rolling_friction": 0.0, "resid_sd": 1.0}])
    >>> t = pd.DataFrame({"lo": [20.0], "hi": [30.0]}, index=["c_kpa"])
    >>> p = margin_profile(s, t, {"normal_cohesion": (0, 1e6), "friction_deg": (10, 30),
    ...                           "rolling_friction": (0, 0.3)}, points=5)
    >>> p[p.parameter == "normal_cohesion"].margin_sd.round(1).tolist()     # c 0, 25, 50, 75, 100 kPa: pinned
    [-20.0, 5.0, -20.0, -45.0, -70.0]
    >>> p[p.parameter == "friction_deg"].margin_sd.round(1).tolist()        # no response feels it: flat
    [5.0, 5.0, 5.0, 5.0, 5.0]
    """
    rows = []
    for name, (lo, hi) in bounds.items():
        for value in np.linspace(lo, hi, points):
            try:
                margin = deepest_point(surfaces, targets, {**bounds, name: (float(value), float(value))}, fixed)["margin_sd"]
            except RuntimeError:
                margin = math.nan
            rows.append({"parameter": name, "value": float(value), "margin_sd": margin})
    return pd.DataFrame(rows)


def profile_plot(profile: pd.DataFrame, path: Path) -> Path:
    """The margin profiles, one panel per parameter, a line per soil; above 0 the planes meet every target."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(dict.fromkeys(profile["parameter"]))
    fig, axes = plt.subplots(1, len(names), figsize=(3.4 * len(names), 3.0), squeeze=False, sharey=True)
    for ax, name in zip(axes[0], names):
        for soil, rows in profile[profile["parameter"] == name].groupby("soil"):
            ax.plot(rows["value"], rows["margin_sd"], "o-", ms=3, c=SOIL_COLOURS.get(soil), label=soil)
        ax.axhline(0, c="0.5", lw=0.8)
        ax.set_xlabel(name)
    axes[0][0].set_ylabel("deepest margin, residual SDs")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


CHECK_TABLES = ("-check", "-check-packings", "-deepest-check-packings")    # the checks the planes take in
FILTER_BOX_CHECKS = "filter-box"    # the posteriors' checks read in the filter's shear box, before the checks had a box
# of their own ([bench] check_box_mm): the planes, drawn in the filter's box, take them in


def soil_evaluations(soil: str, out_dir: Path = BENCH_DIR, box: list | None = None) -> tuple[pd.DataFrame, str] | None:
    """A soil's filter's and checks' evaluations as one table, each evaluation once (its first row: the three-packing
    check's, with its cone) and measured from its stored results (`measured`), and where they come from: its
    finished filter (<soil>.csv) with its posterior's checks on three and more packings and its deepest sets' on more
    (CHECK_TABLES, in out_dir and in FILTER_BOX_CHECKS), or while its filter runs, the iterations it has finished
    (<soil>-running.csv); None when it has neither. `box`: only the evaluations whose shear box had this size (mm;
    `evaluation_box`), those of unknown box kept."""
    tables = [Path(out_dir) / f"{soil}{part}.csv" for part in ("", *CHECK_TABLES)]
    tables += [Path(out_dir) / FILTER_BOX_CHECKS / f"{soil}{part}.csv" for part in CHECK_TABLES]
    if not tables[0].exists():
        tables = [Path(out_dir) / f"{soil}-running.csv"]
    found = [t for t in tables if t.exists()]
    if not found:
        return None
    table = pd.concat([pd.read_csv(t, comment="#").assign(_table=str(t.relative_to(out_dir))) for t in found])
    table = table.drop_duplicates("id") if "id" in table else table
    if "id" in table:                       # each measured as the current code measures (the filter's table keeps
        folders = [Path(out_dir) / soil / str(i) for i in table["id"]]     # what the filter weighed)
        table = pd.DataFrame([measured(row, f, kept_only=True) for row, f in zip(table.to_dict(orient="records"), folders)])
    if box is not None and "id" in table:
        boxes = [evaluation_box(Path(out_dir) / soil / str(i)) for i in table["id"]]
        table = table[[b is None or b == [float(v) for v in box] for b in boxes]]
    return table.drop(columns="_table"), ", ".join(table["_table"].unique())     # the tables that gave a row


def evaluation_box(folder: Path) -> list[float] | None:
    """The size (mm) of the shear box an evaluation's folder ran, from its result file; None if it holds none."""
    return shear_box_mm(scene_result(folder, "shear") if folder.is_dir() else None)


def mm(box) -> str:
    """A box's lengths as the tables name it.

    >>> mm([225, 225.0, 150])
    '225x225x150'
    """
    return "x".join(f"{float(v):g}" for v in box)


def shear_box_mm(data: dict | None) -> list[float] | None:
    """The size (mm) of the shear box a shear result ran; None if it names none.

    >>> shear_box_mm({"tests": [{"size_m": [0.225, 0.225, 0.15]}]}), shear_box_mm({"tests": [{}]})
    ([225.0, 225.0, 150.0], None)
    """
    size = data["tests"][0].get("size_m") if data and data.get("tests") else None
    return [round(v * 1e3, 3) for v in size] if size else None


def surfaces_report(out_dir: Path = BENCH_DIR, bounds: dict | None = None) -> list[Path]:
    """Every calibrated soil's response surfaces over its filter's and check's evaluations, or over the iterations
    its running filter has finished (surfaces.csv), where they meet all its targets (the cone's too, where the
    filter fitted it) inside the common prior (feasible.csv), the set they put deepest inside them (deepest.csv) and
    how far they pin each parameter (`margin_profile`: profiles.csv and .png). A response with no more finished runs
    than its plane's terms (a running filter's cones) is listed in surfaces.csv and left out of the rest."""
    bounds = bounds or load_config()["bounds"]
    from analysis.core.soil_config import SOILS
    rows, regions, deepest, profiles, sources = [], [], [], [], []
    for soil in SOILS:
        own = load_config(soil=soil)
        found = soil_evaluations(soil, out_dir, own["size_mm"])      # the planes are the filter's box's
        if found is None:
            continue
        table, source = found
        sources.append(f"{soil}: {source}")
        surf = response_surfaces(table, own["fixed"]).assign(soil=soil)
        rows.append(surf)
        surf = surf[np.isfinite(surf["resid_sd"])]     # a plane with no more runs than terms has no scatter to count in
        targets = load_targets(soil)
        if "cone_kpa" in set(surf.response):
            targets.loc["cone_kpa", ["lo", "hi"]] = cone_range(soil, own)
        region = feasible_region(surf, targets, bounds, fixed=own["fixed"])
        regions += [{"soil": soil, "parameter": k, "p05": v[0], "p50": v[1], "p95": v[2], "prior_share": region["share"]}
                    for k, v in region.items() if k != "share"]
        deepest.append({"soil": soil, **deepest_point(surf, targets, own["bounds"], own["fixed"])})
        profiles.append(margin_profile(surf, targets, own["bounds"], own["fixed"]).assign(soil=soil))
    if not rows:
        return []
    paths = [Path(out_dir) / "surfaces.csv", Path(out_dir) / "feasible.csv", Path(out_dir) / "deepest.csv",
             Path(out_dir) / "profiles.csv"]
    note = f"./holes calibration-report, over {'; '.join(sources)}"
    profile = pd.concat(profiles)[["soil", "parameter", "value", "margin_sd"]]
    atomic_csv(profile.round(5), paths[3], f"{note}; in the soil's own prior, the planes' deepest margin (residual SDs) "
               "with one parameter held at each value and the others free: flat where the bench does not pin it")
    paths.append(profile_plot(profile, Path(out_dir) / "profiles.png"))
    atomic_csv(pd.DataFrame(deepest).round(5), paths[2],
               f"{note}; in the soil's own prior, the parameter set whose planes lie deepest inside every target, "
               "margin_sd its depth in the planes' residual SDs, and the responses the planes predict there")
    atomic_csv(pd.concat(rows)[["soil", "response", "intercept", *SURFACE_TERMS, "r2", "resid_sd", "n"]].round(5),
               paths[0], f"{note}; each response a plane in the terms over the soil's filter and check evaluations")
    atomic_csv(pd.DataFrame(regions).round(5), paths[1],
               f"{note}; the share of the common prior where the planes meet all the soil's targets, and each parameter's "
               "5/50/95 % there")
    return paths
