"""A disk run's specification, without YADE: its command line, the checks of every input and its plan (all
parameters and the run id). scripts/disk.py (the scene) runs a plan; batches, studies and the parameter page
read the same plan without starting a scene."""
from __future__ import annotations

import argparse
import dataclasses
import math

from analysis.core.bed_spec import BED_DIR, check_grains_fit, check_graded
from analysis.core.cli_types import folder, option, CommandLine
from analysis.core.config import (AWAKE, PRESET_FIELDS, SEED, SLIP, THREADS, check_awake, load_disk, load_machine,
                                  load_preset, load_resolution, load_sleeve, preset_with, tool_with)
from analysis.core.schema import as_dict, ConfigError, digest, Field
from analysis.core.soil_config import SOIL_DEFAULTS, bench_soil, load_soil, parse_overrides, soil_with
from analysis.core.kinematics import TIP_SPHERE_RATIO, layout

CHECKPOINT_EVERY = 600.0    # s of wall time between checkpoints of an unfinished run (0: none)
CHECKPOINT_FIELD = Field(0.0, 86400.0, unit="s", meaning="wall time between checkpoints (0: none)")
RUN_FIELDS = {"slip": SLIP,
              "speed_kmh": Field(0.1, 20.0, unit="km/h", meaning="forward speed"),
              "disk_inertia": Field(1e-4, 100.0, unit="kg·m²", meaning="disk moment of inertia (free mode)"),
              "weight": Field(1.0, 5000.0, unit="N", meaning="load the disk carries (free mode)"),
              "awake": AWAKE,
              "density_scale": Field(1.0, 100.0, meaning="density scaling: the grains k times heavier and gravity on "
                                     "them k times weaker (their weight kept), so the time step is √k longer"),
              "depth_stop": Field(1.0, 500.0, unit="mm", meaning="deepest tip depth the limit device lets the disk "
                                  "sink to (free mode with a weight)"),
              "tilled.depth": Field(10.0, 500.0, unit="mm", meaning="depth of the top layer the rotary tiller "
                                    "loosened (seed 001 §1.2)"),
              "tilled.density": Field(0.5, 0.99, meaning="the loosened layer's bulk density over the bed's: the "
                                      "share of its grains kept")}
MODES = ("prescribed", "free")


def run_id(params: dict) -> str:
    return f"{params['soil']['name']}-{params['preset']['name']}-{params['mode']}-{digest(params)}"


@dataclasses.dataclass(frozen=True)
class RunSpec:
    """What a run is asked for (`./holes run`'s options): the soil and preset by name, and what changes them
    (None: the preset's or the disk config's). `plan` checks it and makes the run's parameters."""
    soil: str
    preset: str
    disk_path: str = "configs/disk.toml"
    seed: int = 1
    mode: str = "prescribed"
    slip: float | None = None
    speed_kmh: float | None = None
    holes: int | None = None
    lead_in: int | None = None
    width: float | None = None
    depth: float | None = None
    resolution: str | None = None
    dt_safety: float | None = None
    lateral: str | None = None
    overrides: dict = dataclasses.field(default_factory=dict)   # soil contact parameters (`--set`)
    tool: dict = dataclasses.field(default_factory=dict)        # disk.<field> / sleeve.<field> (`--tool`)
    disk_inertia: float = 0.05
    weight: float | None = None
    depth_stop: float | None = None
    awake: tuple | list | None = None
    density_scale: float | None = None
    tilled: tuple | list | None = None      # [depth mm, density ratio]: the tiller's loosened top layer


GRAIN_DENSITY_BOUND = 4000.0   # kg/m³: above any Table 2 bed's grain density (about 3000), so the step is overestimated
SLEEVE_STEP = 0.5              # the sleeve's ω·dt may not exceed this (explicit integration is stable below 2)


def check_sleeve_step(sleeve, soil, res, dt_safety: float, density_scale: float = 1.0):
    """The press plate's axial motion is integrated explicitly (scripts/disk_parts.py Motion) against its
    spring and the soil's contacts under it; it is stable only while its natural period spans several time
    steps. Before any scene: ω·dt <= SLEEVE_STEP, with ω² = (k_spring + k_soil)/m, k_soil the normal stiffness
    of the grains the plate's ring can hold (its area over π r², each 2·E·r against steel) and dt YADE's
    P-wave step for the smallest grains at GRAIN_DENSITY_BOUND (an overestimate, so the check errs safe).

    >>> from types import SimpleNamespace as N
    >>> soil, res = N(young=2e7), N(radius=0.006, spread=0.25)
    >>> check_sleeve_step(N(mass=0.2, stiffness=8.0, outer_diameter=80.0, damping_ratio=0.2), soil, res, 0.5)
    >>> check_sleeve_step(N(mass=1e-9, stiffness=1e4, outer_diameter=80.0, damping_ratio=0.2), soil, res, 0.5)
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    analysis.core.schema.ConfigError: sleeve.mass = 1e-09 kg is out of range for this scene: allowed >= 0.083 kg ...
    """
    r_mean = res.radius
    r_min = res.radius * (1 - res.spread)
    dt = dt_safety * r_min * math.sqrt(GRAIN_DENSITY_BOUND * density_scale / soil.young)
    ring = math.pi / 4 * ((sleeve.outer_diameter / 1000) ** 2 - (2 * r_mean) ** 2)     # m², at least one grain
    k_soil = max(ring / (math.pi * r_mean ** 2), 1.0) * 2 * soil.young * r_mean
    k = sleeve.stiffness * 1e3 + k_soil
    omega_dt = math.sqrt(k / sleeve.mass) * dt
    if omega_dt > SLEEVE_STEP:
        need = k * (dt / SLEEVE_STEP) ** 2
        raise ConfigError(f"sleeve.mass = {sleeve.mass:g} kg is out of range for this scene: allowed >= {need:.2g} kg "
                          f"(the plate's period against the time step: ω·dt = {omega_dt:.2g} > {SLEEVE_STEP:g}, with the "
                          f"spring {sleeve.stiffness:g} N/mm and the soil under the plate about {k_soil / 1e3:.2g} N/mm, "
                          f"dt about {dt:.2g} s)")


def plan(spec: RunSpec | str, preset: str | None = None, **changes) -> dict:
    """Every parameter of the run, checked, before YADE starts: `plan(RunSpec(...))`, or `plan("clay", "quick",
    holes=4)` for the same spec written out."""
    spec = spec if isinstance(spec, RunSpec) else RunSpec(spec, preset, **changes)
    mode, seed, slip, speed_kmh, weight, awake, depth_stop = (spec.mode, spec.seed, spec.slip, spec.speed_kmh,
                                                              spec.weight, spec.awake, spec.depth_stop)
    if mode not in MODES:
        raise ConfigError(f"mode = {mode!r}: allowed {', '.join(MODES)}")
    seed = SEED.check("run.seed", seed)
    preset = load_preset(spec.preset)
    machine = load_machine(preset.machine)["tool"] if preset.machine else {}
    disk = load_disk(spec.disk_path)
    for key, given in (("slip", spec.slip), ("speed_kmh", spec.speed_kmh)):
        if given is not None and f"disk.{key}" in spec.tool:
            raise ConfigError(f"run.{key} and disk.{key} are both given: allowed one of them (the run's own option)")
    if mode != "free" and spec.disk_inertia != RunSpec.disk_inertia:
        raise ConfigError(f"run.disk_inertia = {spec.disk_inertia!r}: allowed only in free mode (a prescribed disk's "
                          "rotation is set, its inertia plays no part)")
    disk, sleeve = tool_with(disk, load_sleeve(spec.disk_path, disk), {**machine, **spec.tool})
    preset = preset_with(preset, {k: v for k, v in ((k, getattr(spec, k)) for k in ("width", "depth", "holes", "lead_in",
                                                                     "resolution", "dt_safety", "lateral")) if v is not None})
    table_soil = load_soil(spec.soil)
    soil = soil_with(bench_soil(table_soil) if preset.soils == "bench" else table_soil, spec.overrides)
    slip = RUN_FIELDS["slip"].check("run.slip", disk.slip if slip is None else slip)
    speed_kmh = RUN_FIELDS["speed_kmh"].check("run.speed_kmh", disk.speed_kmh if speed_kmh is None else speed_kmh)
    RUN_FIELDS["disk_inertia"].check("run.disk_inertia", spec.disk_inertia)
    if weight is not None:
        if mode != "free":
            raise ConfigError(f"run.weight = {weight:g} N needs mode = 'free': allowed only where the soil drives "
                              "the disk")
        RUN_FIELDS["weight"].check("run.weight", weight)
    awake = preset.awake if awake is None else awake
    if awake is not None:
        awake = check_awake("run.awake", awake)
    if preset.depth <= disk.penetration + 20:
        raise ConfigError(f"preset.depth = {preset.depth:g} is out of range: allowed > penetration + 20 = "
                          f"{disk.penetration + 20:g} mm")
    res = load_resolution(preset.resolution)
    if res.graded and res.fine_width * 1000 <= sleeve.outer_diameter:
        raise ConfigError(f"resolution {res.name!r}: fine_width = {1000 * res.fine_width:g} mm is out of range: allowed "
                          f"> sleeve outer diameter {sleeve.outer_diameter:g} mm (the plate works in the fine zone)")
    if preset.width <= sleeve.outer_diameter:
        raise ConfigError(f"preset.width = {preset.width:g} is out of range: allowed > sleeve outer diameter "
                          f"{sleeve.outer_diameter:g} mm")
    density_scale = (1.0 if spec.density_scale is None
                     else RUN_FIELDS["density_scale"].check("run.density_scale", spec.density_scale))
    check_sleeve_step(sleeve, soil, res, preset.dt_safety, density_scale)
    lay = layout(disk, speed_kmh, slip, preset.holes, preset.lead_in, preset.run_out,
                 tip_sphere=TIP_SPHERE_RATIO * disk.d)
    soil_params = {k: v for k, v in as_dict(soil).items() if SOIL_DEFAULTS.get(k, object()) != v}  # ids as before
    params = {"soil": soil_params, "disk": as_dict(disk), "sleeve": as_dict(sleeve), "preset": preset.in_run(),
              "slip": slip, "speed_kmh": speed_kmh, "seed": seed, "mode": mode, "disk_inertia": spec.disk_inertia,
              "layout": {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(lay).items()},
              "bed_size_mm": [10 * math.ceil(lay.length / 10), preset.width, preset.depth]}
    if weight is not None:                  # only then: the ids of runs without a weight stay as they were
        params["weight"] = weight
    if preset.soils == "bench":             # likewise; the bed settles as the bench tests' beds did, as [soil] says,
        params["bed_settled_as"] = table_soil.settling_key()   # whatever contact law the run's overrides then give it
    check_grains_fit(res, [x / 1000 for x in params["bed_size_mm"]])
    if res.graded:                          # likewise; measure.py reads the fine zone from here
        params["graded"] = {k: getattr(res, k) for k in ("radius", "spread", "coarse_radius", "fine_width",
                                                             "fine_depth")}
        check_graded(res, [x / 1000 for x in params["bed_size_mm"]], preset.lateral)
    if awake is not None:                   # likewise
        params["awake_mm"] = awake
    if density_scale != 1.0:                # likewise
        params["density_scale"] = density_scale
    if len(lay.hole_x) > disk.N:            # likewise
        # punches on a second turn (their sleeves work there too, the punch's angle wrapped): a strip longer than
        # N holes is marked, so its runs are never mistaken for runs made when its sleeves were held rigid
        params["punch_turns"] = math.ceil(len(lay.hole_x) / disk.N)
    if spec.tilled is not None:             # likewise
        if not isinstance(spec.tilled, (list, tuple)) or len(spec.tilled) != 2:
            raise ConfigError(f"run.tilled = {spec.tilled!r}: allowed two numbers DEPTH,DENSITY (mm, ratio)")
        depth_mm = RUN_FIELDS["tilled.depth"].check("run.tilled.depth", spec.tilled[0])
        if depth_mm > preset.depth - 20:
            raise ConfigError(f"run.tilled.depth = {depth_mm:g} is out of range: allowed [10, {preset.depth - 20:g}] "
                              "mm (20 mm above the strip's floor)")
        params["tilled"] = {"depth_mm": depth_mm,
                            "density": RUN_FIELDS["tilled.density"].check("run.tilled.density", spec.tilled[1])}
    if depth_stop is not None:              # likewise
        if weight is None:
            raise ConfigError(f"run.depth_stop = {depth_stop:g} mm needs a weight (free mode): allowed only where "
                              "the disk can sink")
        lo, hi = disk.penetration, preset.depth - 20
        if not lo <= RUN_FIELDS["depth_stop"].check("run.depth_stop", depth_stop) <= hi:
            raise ConfigError(f"run.depth_stop = {depth_stop:g} is out of range: allowed [{lo:g}, {hi:g}] mm (from "
                              "the penetration the disk starts at to 20 mm above the strip's floor)")
        params["depth_stop_mm"] = depth_stop
    # the layout is in the id, rounded (the last bits of its trigonometry may differ between machines), so a
    # change of the geometry's code is a new run, never a reused folder
    rounded = {k: ([round(x, 6) for x in v] if isinstance(v, list) else round(v, 6))
               for k, v in params["layout"].items()}
    params["id"] = run_id({**params, "layout": rounded})
    return params


def arguments(exit_on_error: bool = True) -> argparse.ArgumentParser:
    """The command line of one run; `plan_from_argv` and `main` read it."""
    p = CommandLine(prog="holes run", description="The rolling six-punch disk with spring-loaded press "
                                "sleeves in a soil strip (seed 001 §1.2, §2): one run (scripts/disk.py).",
                                exit_on_error=exit_on_error)
    p.add_argument("--soil", default="clay", help="clay | loam | sand, or a soil config's path (default clay)")
    p.add_argument("--preset", default="quick", help="run preset of configs/presets.toml (default quick)")
    p.add_argument("--disk", default="configs/disk.toml", help="disk config (default configs/disk.toml)")
    p.add_argument("--slip", type=float, help="slip rate δ = 1 - r/R, [0, 0.9] (default: the disk config's, 0)")
    p.add_argument("--speed-kmh", type=float, help="the disk's forward speed, km/h (default: the disk config's)")
    p.add_argument("--holes", type=option("--holes", PRESET_FIELDS["holes"]),
                   help="holes to measure (default: the preset's)")
    p.add_argument("--lead-in", type=option("--lead-in", PRESET_FIELDS["lead_in"]),
                   help="holes formed first and not measured (default: the preset's)")
    p.add_argument("--width", type=float, help="mm, overrides the preset")
    p.add_argument("--depth", type=float, help="mm, overrides the preset")
    p.add_argument("--resolution", help="grain size, r3 r4 r5 r6 r8 (radius in mm) or a section of configs/resolutions.toml; "
                   "overrides the preset")
    p.add_argument("--dt-safety", type=float, help="time step / critical time step, overrides the preset")
    p.add_argument("--lateral", help="the strip's sides, walls | periodic, overrides the preset")
    p.add_argument("--mode", default="prescribed", help="prescribed | free: the disk turned at the set slip, or "
                   "by the soil's torque (default prescribed)")
    p.add_argument("--disk-inertia", type=float, default=0.05, help="kg·m², free mode: the disk's moment of inertia "
                   "(default 0.05)")
    p.add_argument("--weight", type=float, help="N, free mode: the axis sinks under this load (default: held)")
    p.add_argument("--density-scale", type=float, metavar="K",
                   help="density scaling: grains K times heavier, gravity on them K times weaker, so the time step is "
                   "sqrt(K) longer; the summary gives the inertial number (default 1: none)")
    p.add_argument("--depth-stop", type=float, metavar="MM",
                   help="mm, free mode with --weight: the limit device (seed 001 §1.2) stops the disk sinking once "
                   "its tips reach this depth (default: no stop)")
    p.add_argument("--awake", type=awake_arg, metavar="BEHIND,AHEAD",
                   help="mm: only the soil from BEHIND behind the tools' reach to AHEAD ahead of it moves; the rest "
                   "sleeps (default: all of it moves)")
    p.add_argument("--tilled", type=pair_arg("DEPTH,DENSITY", "100,0.85"), metavar="DEPTH,DENSITY",
                   help="the rotary tiller's loosened top layer (seed 001 §1.2): its depth in mm and its bulk density "
                   "over the bed's, made by taking that share of the layer's grains out at random (default: none)")
    p.add_argument("--seed", type=option("--seed", SEED), default=1, help="the bed's packing seed, >= 0 (default 1)")
    p.add_argument("--threads", type=option("--threads", THREADS), default=2, help="YADE threads (default 2)")
    p.add_argument("--vtk", action="store_true", help="also write VTK files for ParaView")
    p.add_argument("--out", type=folder("--out"), help="runs folder (default results/runs)")
    p.add_argument("--bed-dir", type=folder("--bed-dir"), default=str(BED_DIR),
                   help="where beds are kept (default results/cache/beds)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a soil contact parameter")
    p.add_argument("--tool", action="append", metavar="PART.KEY=VALUE",
                   help="override a disk or sleeve field, e.g. disk.D=45, sleeve.stiffness=16")
    p.add_argument("--rerun", action="store_true", help="run again from the start, even if this run's folder "
                   "has a summary or a checkpoint")
    p.add_argument("--checkpoint-every", type=option("--checkpoint-every", CHECKPOINT_FIELD), default=CHECKPOINT_EVERY,
                   help="s of wall time between checkpoints of an unfinished run (0: none)")
    return p


def pair_arg(names: str, example: str):
    """An option's reader of two numbers `A,B` (`--awake BEHIND,AHEAD`, `--tilled DEPTH,DENSITY`)."""
    def read(text: str) -> list:
        try:
            a, b = (float(x) for x in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: allowed two numbers {names}, e.g. {example}") from None
        return [a, b]
    return read


awake_arg = pair_arg("BEHIND,AHEAD in mm", "60,120")


def plan_args(a: argparse.Namespace) -> dict:
    return plan(RunSpec(soil=a.soil, preset=a.preset, disk_path=a.disk, seed=a.seed, mode=a.mode, slip=a.slip,
                        speed_kmh=a.speed_kmh, holes=a.holes, lead_in=a.lead_in, width=a.width, depth=a.depth,
                        resolution=a.resolution, dt_safety=a.dt_safety, lateral=a.lateral,
                        overrides=parse_overrides(a.set), tool=parse_overrides(a.tool), disk_inertia=a.disk_inertia,
                        weight=a.weight, depth_stop=a.depth_stop, awake=a.awake, density_scale=a.density_scale,
                        tilled=a.tilled))


def plan_from_argv(argv: list[str]) -> dict:
    """The checked parameters of the run `scripts/disk.py ARGV` would make, without running it (batches)."""
    try:
        a = arguments(exit_on_error=False).parse_args(argv)
    except argparse.ArgumentError as e:
        raise ConfigError(str(e)) from None
    return plan_args(a)
