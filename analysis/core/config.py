"""Configs are data: TOML files whose every key is known and range-checked before anything runs.

A schema maps each key to a `Field` (type, allowed range, unit, meaning: analysis/core/schema.py). Unknown keys,
missing keys and out-of-range values raise `ConfigError` naming the file, the key and the allowed range. Here:
the disk and its sleeves, presets, the calibrated machine, the seedling and its criteria, grain sizes; the soils
are in soil_config.py.

>>> disk = load_disk("configs/disk.toml")
>>> disk.R
191.0
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from analysis.core.schema import (ROOT, ConfigError, Field, as_dict, check_sources, check_table, positive, read_toml,
                                  split_sections)


SLIP = Field(0.0, 0.9, meaning="slip rate δ = 1 − r/R (eq 1); the one range of every run, study and disk config")
THREADS = Field(1, 64, kind=int, meaning="YADE (OpenMP) threads per scene")
WORKERS = Field(1, 64, kind=int, meaning="scenes or cases at a time")
COLLIDER_STEPS = Field(200, 100_000, kind=int, meaning="steps per contact-detection setting (bench collider)")

CONE_FIELDS = {"cone_scale": Field(0.5, 20.0, meaning="cone size / ASABE S313 size"),    # scripts/cone.py
               "speed": Field(0.001, 2.0, lo_open=True, unit="m/s", meaning="penetration speed")}
CONE_DEPTH = Field(10.0, 1000.0, unit="mm", meaning="the cone's deepest base depth")

DISK_FIELDS = {
    "R0": positive(meaning="punch mounting-plate radius"),
    "L3": positive(meaning="punch length from the plate rim to the tip"),
    "N": Field(1, 360, kind=int, meaning="punches per disk"),
    "D": positive(meaning="punch (cylinder) diameter"),
    "h": positive(meaning="height of the punch's end cone"),
    "penetration": positive(meaning="depth of the tip's lowest point below the undisturbed surface"),
    "width": positive(meaning="disk (mounting plate) width B1"),
    "row_spacing": positive(meaning="distance between disks on the roller"),
    "rows": Field(1, 100, kind=int, meaning="disks on the roller"),
    "speed_kmh_min": positive("km/h", "lowest field forward speed"),
    "speed_kmh_max": positive("km/h", "highest field forward speed"),
    "speed_kmh": positive("km/h", "forward speed used by default"),
    "slip": SLIP,
}


@dataclass(frozen=True)
class Disk:
    """The rolling punch disk of seed 001 §2.4; lengths in mm."""
    R0: float
    L3: float
    N: int
    D: float
    h: float
    penetration: float
    width: float
    row_spacing: float
    rows: int
    speed_kmh_min: float
    speed_kmh_max: float
    speed_kmh: float
    slip: float
    name: str = "disk"

    @property
    def R(self) -> float:
        """Theoretical rolling radius of the tips, R = R0 + L3 (§2.4)."""
        return self.R0 + self.L3

    @property
    def d(self) -> float:
        return self.D / 2.0

    @property
    def H0(self) -> float:
        """Height of the disk axis above the undisturbed surface so that the tip reaches `penetration`."""
        return self.R - self.penetration


def disk_from_dict(values: dict, where: str = "disk", name: str = "disk") -> Disk:
    v = check_table(where, values, DISK_FIELDS)
    if v["penetration"] > v["L3"]:
        raise ConfigError(f"{where}.penetration = {v['penetration']:g} is out of range: allowed (0, L3 = {v['L3']:g}] mm "
                          "(the plate would enter the soil)")
    if v["h"] >= v["L3"]:
        raise ConfigError(f"{where}.h = {v['h']:g} is out of range: allowed (0, L3 = {v['L3']:g}) mm")
    if not v["speed_kmh_min"] <= v["speed_kmh_max"]:
        raise ConfigError(f"{where}.speed_kmh_min = {v['speed_kmh_min']:g} must not exceed speed_kmh_max = "
                          f"{v['speed_kmh_max']:g}")
    return Disk(**v, name=name)


def load_disk(path) -> Disk:
    data = split_sections(path, read_toml(path), DISK_SECTIONS)
    if "disk" not in data:
        raise ConfigError(f"{path}: missing section [disk]")
    check_sources(path, data.get("source", {}), DISK_FIELDS)
    return disk_from_dict(data["disk"], f"{path}: disk", Path(path).stem)


DISK_SECTIONS = {"disk", "source", "sleeve", "sleeve_source"}
SLEEVE_FIELDS = {
    "outer_diameter": positive(meaning="outer diameter of the annular press plate"),
    "rest_from_tip": positive(meaning="plate face to punch tip with the spring at its stop"),
    "travel": positive(meaning="how far the plate can be pushed back along the punch"),
    "stiffness": Field(0.0, 1e4, unit="N/mm", meaning="return spring rate"),
    "preload": Field(0.0, 1e5, unit="N", meaning="spring force at the stop"),
    "mass": Field(0.0, 100.0, lo_open=True, unit="kg", meaning="moving mass of the plate"),
    "damping_ratio": Field(0.0, 2.0, meaning="viscous damping of the plate's axial motion / critical"),
}


@dataclass(frozen=True)
class Sleeve:
    """The spring-loaded press sleeve on each punch (seed 001 §1.2, Fig. 2); lengths in mm, forces in N."""
    outer_diameter: float
    rest_from_tip: float
    travel: float
    stiffness: float
    preload: float
    mass: float
    damping_ratio: float


def sleeve_from_dict(values: dict, disk: Disk, where: str = "sleeve") -> Sleeve:
    v = check_table(where, values, SLEEVE_FIELDS)
    if v["outer_diameter"] <= disk.D:
        raise ConfigError(f"{where}.outer_diameter = {v['outer_diameter']:g} is out of range: allowed (D = {disk.D:g}, inf) mm")
    if not disk.h < v["rest_from_tip"] < disk.L3:
        raise ConfigError(f"{where}.rest_from_tip = {v['rest_from_tip']:g} is out of range: allowed (h = {disk.h:g}, "
                          f"L3 = {disk.L3:g}) mm (the plate sits on the cylinder)")
    if v["rest_from_tip"] + v["travel"] > disk.L3:
        raise ConfigError(f"{where}.travel = {v['travel']:g} is out of range: allowed (0, L3 - rest_from_tip = "
                          f"{disk.L3 - v['rest_from_tip']:g}] mm (the plate would pass the mounting plate)")
    return Sleeve(**v)


def load_sleeve(path, disk: Disk | None = None) -> Sleeve:
    data = split_sections(path, read_toml(path), DISK_SECTIONS)
    if "sleeve" not in data:
        raise ConfigError(f"{path}: missing section [sleeve]")
    check_sources(path, data.get("sleeve_source", {}), SLEEVE_FIELDS)
    return sleeve_from_dict(data["sleeve"], disk or load_disk(path), f"{path}: sleeve")


# --- scene presets (configs/presets.toml) ---------------------------------------------------------------

LATERAL = ("walls", "periodic")   # a bed's sides: rigid walls, or none (a periodic cell across them)


SEED = Field(0, 2 ** 31 - 1, kind=int, meaning="the bed's packing seed (YADE's makeCloud; a negative one would "
                                              "draw a random packing under a fixed name, so it is refused)")


def check_lateral(lateral: str, where: str = "bed.lateral") -> str:
    if lateral not in LATERAL:
        raise ConfigError(f"{where} = {lateral!r}: allowed {', '.join(LATERAL)}")
    return lateral


PRESET_FIELDS = {
    "resolution": Field(kind=str, meaning="a section of configs/resolutions.toml"),
    "width": Field(40.0, 1000.0, unit="mm", meaning="bed width across the travel"),
    "depth": Field(40.0, 500.0, unit="mm", meaning="bed depth"),
    "holes": Field(1, 20, kind=int, meaning="consecutive holes to measure"),
    "lead_in": Field(0, 3, kind=int, meaning="holes formed before the measured ones (the strip's start-up)"),
    "run_out": Field(0.0, 500.0, unit="mm", meaning="bed length past the last hole's front"),
    "dt_safety": Field(0.05, 1.0, meaning="time step / P-wave critical time step"),
    "lateral": Field(kind=str, meaning="the strip's sides: " + " | ".join(LATERAL)),
}


@dataclass(frozen=True)
class Preset:
    name: str
    resolution: str
    width: float
    depth: float
    holes: int
    lead_in: int
    run_out: float
    dt_safety: float
    lateral: str
    machine: str = ""             # a section of configs/machine.toml: the machine's calibrated values ("": the disk config's)
    awake: tuple | None = None    # (behind, ahead) mm: only the soil round the tools moves (None: all of it)
    soils: str = ""               # "bench": each soil as its bench calibration left it ("" or "table": its [soil])

    def in_run(self) -> dict:
        """The preset as a run's parameters hold it: `machine`, `awake` and `soils` only when set, so the ids of runs
        of presets without them stay as they were."""
        d = as_dict(self)
        for key in ("machine", "awake", "soils"):
            if not d[key]:
                d.pop(key)
        if d.get("awake"):
            d["awake"] = list(d["awake"])
        return d


AWAKE = Field(0.0, 1000.0, unit="mm", meaning="awake soil behind / ahead of the tools' reach")
PRESET_OPTIONAL = {"machine": Field(kind=str, meaning="a section of configs/machine.toml (the calibrated machine)"),
                   "awake": AWAKE,
                   "soils": Field(kind=str, meaning="the soils' contact parameters: table (each configs/soils/<soil>.toml "
                                  "[soil]) | bench (its [bench_posterior], the bench calibration's)")}


def check_awake(where: str, value) -> list[float]:
    """The awake window [BEHIND, AHEAD] (mm), from a preset or a run: two lengths, each in AWAKE's range."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ConfigError(f"{where} = {value!r}: allowed two lengths BEHIND, AHEAD in mm")
    return [AWAKE.check(f"{where}.{side}", x) for side, x in zip(("behind", "ahead"), value)]


def named_section(what: str, name: str, path, schema: dict, optional: dict | None = None) -> dict:
    """The checked table `name` of a file of named sections (presets, resolutions)."""
    data = read_toml(path)
    if name not in data:
        raise ConfigError(f"{what} = {name!r}: allowed {', '.join(data)}")
    return check_table(f"{path}: {name}", data[name], schema, optional)


PRESETS = ROOT / "configs/presets.toml"                               # a user's presets
CANDIDATES = ROOT / "configs/studies/preset_candidates.toml"          # the main job's candidates, judged and kept


def preset_names() -> dict:
    """Every preset's name -> the file it is in: a user's presets first, then the candidates."""
    return {**{n: CANDIDATES for n in read_toml(CANDIDATES)}, **{n: PRESETS for n in read_toml(PRESETS)}}


def load_preset(name: str, path=None) -> Preset:
    """The checked preset `name`, from `path`, or else from configs/presets.toml or the candidates' file."""
    if path is None:
        path = preset_names().get(name, PRESETS)
    data = read_toml(path)
    if name not in data:
        shown = ", ".join(data)
        raise ConfigError(f"preset = {name!r}: allowed {shown} (or a candidate of {CANDIDATES.relative_to(ROOT)})")
    table = dict(data[name])
    if "replicates" in table:                # another preset's runs over several packings: that preset, same ids
        return load_preset(replicated(name, path)[0], path)
    extra = {k: table.pop(k) for k in PRESET_OPTIONAL if k in table}
    v = check_table(f"{path}: {name}", table, PRESET_FIELDS)
    load_resolution(v["resolution"])
    check_lateral(v["lateral"], f"{path}: {name}.lateral")
    if "machine" in extra:
        v["machine"] = PRESET_OPTIONAL["machine"].check(f"{path}: {name}.machine", extra["machine"])
        load_machine(v["machine"])
    if "awake" in extra:
        v["awake"] = tuple(check_awake(f"{path}: {name}.awake", extra["awake"]))
    if "soils" in extra:
        from analysis.core.soil_config import SOIL_SOURCES
        soils = PRESET_OPTIONAL["soils"].check(f"{path}: {name}.soils", extra["soils"])
        if soils not in SOIL_SOURCES:
            raise ConfigError(f"{path}: {name}.soils = {soils!r}: allowed {' | '.join(SOIL_SOURCES)}")
        v["soils"] = "" if soils == "table" else soils
    return Preset(name, **v)


REPLICATE_KEYS = ("replicates", "seeds", "grain_size")


def grain_size_strips(path=PRESETS) -> dict[str, tuple[str, ...]]:
    """Each validation that names its grain-size strips (`grain_size` beside `replicates`): validation -> (the
    replicated preset, then the same strip at the finer grains), as `./holes bench grain-size --strip` reads them."""
    data = read_toml(path)
    strips = {}
    for name, table in data.items():
        if "grain_size" in table:
            runs, _ = replicated(name, path)
            strips[name] = (runs, *table["grain_size"])
    return strips


def replicated(name: str, path=None) -> tuple[str, list[int]]:
    """A preset's runs and packing seeds: (`replicates`, `seeds`) for a preset that replicates another over several
    packings (its runs are the other's, shared run for run), else (`name`, [1])."""
    path = preset_names().get(name, PRESETS) if path is None else path
    data = read_toml(path)
    table = dict(data.get(name, {}))
    if "replicates" not in table:
        return name, [1]
    where = f"{path}: {name}"
    unknown = sorted(set(table) - set(REPLICATE_KEYS))
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: not allowed beside replicates (allowed: {', '.join(REPLICATE_KEYS)})")
    runs = table["replicates"]
    target = data.get(runs) if isinstance(runs, str) else None
    if target is None or "replicates" in target:
        raise ConfigError(f"{where}.replicates = {runs!r}: allowed a preset of the same file that replicates none")
    strips = table.get("grain_size", [])
    if (not isinstance(strips, list) or len(set(map(str, strips))) != len(strips) or runs in strips
            or not all(isinstance(s, str) and s in data and "replicates" not in data[s] for s in strips)):
        raise ConfigError(f"{where}.grain_size = {strips!r}: allowed a list of distinct presets of the same file, "
                          f"other than {runs!r}, that replicate none")
    seeds = table.get("seeds")
    if (not isinstance(seeds, list) or len(seeds) < 2 or len(set(seeds)) != len(seeds)
            or not all(isinstance(x, int) and not isinstance(x, bool) and 1 <= x <= 1000 for x in seeds)):
        raise ConfigError(f"{where}.seeds = {seeds!r}: allowed two or more distinct packing seeds, each an integer "
                          "in [1, 1000]")
    return runs, seeds


MACHINE = "configs/machine.toml"


def load_machine(name: str, path=MACHINE) -> dict:
    """The machine's calibrated values `name` (a section of configs/machine.toml, written by `./holes
    calibrate-machine`): {"tool": {"disk.penetration": ..., "sleeve.stiffness": ..., ...}, "source": ...}."""
    data = read_toml(path)
    if name not in data:
        raise ConfigError(f"machine = {name!r}: allowed {', '.join(data) or 'none (no machine calibrated yet)'}")
    section = dict(data[name])
    tool = section.pop("tool", None)
    if not isinstance(tool, dict) or not tool:
        raise ConfigError(f"{path}: [{name}.tool] is missing: the calibrated disk.<field> / sleeve.<field> values")
    for key, value in tool.items():
        if key.partition(".")[0] not in ("disk", "sleeve"):
            raise ConfigError(f"{path}: {name}.tool.{key}: allowed disk.<field> or sleeve.<field>")
    return {"tool": tool, **section}


def preset_with(preset: Preset, changes: dict) -> Preset:
    """The preset with some fields replaced (`--width`, `--resolution`, ...), checked as the presets file is."""
    import dataclasses
    checked = {k: PRESET_FIELDS[k].check(f"run.{k}", v) for k, v in changes.items()}
    if "resolution" in checked:                # by either name; the run holds the section's
        checked["resolution"] = load_resolution(checked["resolution"]).name
    if "lateral" in checked:
        check_lateral(checked["lateral"], "run.lateral")
    return dataclasses.replace(preset, **checked)


def tool_with(disk: Disk, sleeve: Sleeve, changes: dict) -> tuple[Disk, Sleeve]:
    """The disk and sleeve with some fields replaced (`--tool disk.D=45`, `--tool sleeve.stiffness=16`), checked
    as the config files are (ranges and the cross-checks between fields)."""
    d, s = as_dict(disk), as_dict(sleeve)
    name = d.pop("name")
    for key, value in changes.items():
        part, _, field = key.partition(".")
        target, schema = {"disk": (d, DISK_FIELDS), "sleeve": (s, SLEEVE_FIELDS)}.get(part, (None, None))
        if target is None or field not in schema:
            raise ConfigError(f"tool override {key!r}: allowed disk.<{'|'.join(DISK_FIELDS)}> or "
                              f"sleeve.<{'|'.join(SLEEVE_FIELDS)}>")
        target[field] = value
    disk = disk_from_dict(d, "tool override: disk", name)
    return disk, sleeve_from_dict(s, disk, "tool override: sleeve")


RESOLUTION_FIELDS = {
    "radius": Field(0.0005, 0.05, lo_open=False, unit="m", meaning="mean particle radius (a graded bed's fine grains)"),
    "spread": Field(0.0, 0.8, unit="", meaning="relative half-width of the uniform radius distribution"),
    "coarse_radius": Field(0.0, 0.05, unit="m", meaning="graded bed: mean radius of the grains outside the fine "
                           "zone (same spread); 0 or absent: one size everywhere"),
    "fine_width": Field(0.0, 1.0, unit="m", meaning="graded bed: width of the fine zone across the strip, centred on "
                        "the punches' path"),
    "fine_depth": Field(0.0, 0.5, unit="m", meaning="graded bed: depth of the fine zone below the surface"),
    "also": Field(kind=str, meaning="the resolution's other name, by its grain radius (r6: r = 6 mm); either name "
                  "runs the same beds and runs (their keys and ids use the section's name)"),
}
GRADED = {"coarse_radius": 0.0, "fine_width": 0.0, "fine_depth": 0.0}   # absent: a bed of one size
OPTIONAL_RESOLUTION = {**GRADED, "also": ""}


@dataclass(frozen=True)
class Resolution:
    """Particle sizes (m). A graded bed (coarse_radius > 0) has grains of `radius` in the fine zone, a band
    `fine_width` wide along the strip's middle and `fine_depth` deep under its surface, where the punches and
    plates work, and grains of `coarse_radius` round and under it."""
    name: str
    radius: float
    spread: float
    coarse_radius: float = 0.0
    fine_width: float = 0.0
    fine_depth: float = 0.0
    also: str = ""

    @property
    def graded(self) -> bool:
        return self.coarse_radius > 0

    def is_fine(self, radius):
        """Whether grains of `radius` (m; a number or an array) are of the fine sizes, r (1 ± spread)."""
        return radius <= self.radius * (1 + self.spread) * (1 + 1e-9)

    def fine_band(self, width: float) -> tuple[float, float]:
        """(y_lo, y_hi), m: the fine zone across a strip `width` m wide, centred on the punches' path (at most the
        strip's width)."""
        w = min(self.fine_width, width)
        return (width - w) / 2, (width + w) / 2


def resolution_name(name: str, path="configs/resolutions.toml") -> str:
    """The section a resolution's name or its other name (`also`, by grain radius: r6) stands for."""
    sections = read_toml(path)
    if name in sections:
        return name
    named = [n for n, t in sections.items() if t.get("also") == name]
    return named[0] if named else name


def load_resolution(name: str, path="configs/resolutions.toml") -> Resolution:
    name = resolution_name(name, path)
    sections = read_toml(path)
    if name not in sections:
        by_radius = sorted((t["also"] for t in sections.values() if t.get("also")), key=lambda a: float(a[1:]))
        raise ConfigError(f"resolution = {name!r}: allowed {', '.join(by_radius)} (grain radius in mm) or "
                          f"{', '.join(sections)}")
    res = Resolution(name, **named_section("resolution", name, path, RESOLUTION_FIELDS, OPTIONAL_RESOLUTION))
    smallest_coarse = res.coarse_radius * (1 - res.spread)
    if res.graded and not (smallest_coarse > res.radius * (1 + res.spread) and res.fine_width > 0 and res.fine_depth > 0):
        raise ConfigError(f"{path}: {name}: a graded bed needs coarse_radius (1 - spread) > radius (1 + spread) = "
                          f"{res.radius * (1 + res.spread):g} m, so no coarse grain is as small as a fine one, and "
                          f"fine_width, fine_depth > 0 (got {res.coarse_radius:g}, {res.fine_width:g}, {res.fine_depth:g})")
    return res
