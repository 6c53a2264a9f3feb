"""Part: a settled, levelled soil bed, saved once and loaded by every scene (the bed scene, scripts/bed.py,
builds one from the command line: `./holes bed --soil clay --resolution default --size 200,200,150 --seed 1`).

Steps: a random cloud in a walled box; gravity deposition with softer contacts (young/4) and damping 0.4,
without cohesion, until the unbalanced force is below SETTLE_UNBALANCED; levelling (particles whose centre is
above the bed depth are removed); a second settling at the working modulus; porosity n measured in the
interior; then the grain density is set to ρ_d(1 + w)/(1 - n) so that the bed weighs what the moist field
soil of Table 2 weighs at its dry bulk density ρ_d and moisture w. Cohesion is switched on by the scenes
that use the bed, so calibrating cohesion never re-settles a bed.

Graded beds (a resolution with `coarse_radius`): grains of the resolution's radius in the fine
zone, a band `fine_width` wide along the strip's middle and `fine_depth` deep, where the punches and plates work,
and grains of `coarse_radius` under and beside it. The cloud is made zone by zone (`zones`), each at the same
solid fraction, so each zone settles where it belongs; levelling removes a coarse grain whose centre is above
D - (coarse radius - radius), so its top stays under the fine grains' highest; the porosity that sets the grain
density is the fine zone's, where the holes are formed (the coarse zone's is reported beside it).

Sides: rigid walls (`lateral = "walls"`), or none (`"periodic"`): a YADE periodic cell in x and y, so the bed
stands for an unbounded field and a cone or punch meets no wall; the saved positions are wrapped into the cell.

Tiled beds (`tiles` = n > 1, periodic only): the settled periodic bed repeated n × n times in a cell n times as
long and wide (`tile`). Every grain keeps its contacts, so the tiled bed is settled as it stands, and beds of
different n share one packing: the paired width check of the cone index, where only the cell differs.

Beds are keyed by soil (its settling parameters), resolution, size, sides and seed: results/cache/beds/<key>.npz + .json.
A new bed is settled under a lock (<key>.lock, `analysis.core.io.held`): a second run that needs it meanwhile waits
and loads it.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import folder, option, CommandLine
from analysis.core.config import LATERAL, SEED, THREADS, check_lateral, load_resolution, Resolution
from analysis.core.schema import ConfigError
from analysis.core.soil_config import load_soil, parse_overrides, soil_with
from analysis.core.bed_spec import (BED_DIR, bed_key, check_grains_fit, check_graded, check_size, check_tiles,  # noqa: E402
                               mean_volume, zones)
from analysis.core.io import atomic_write, held  # noqa: E402

SETTLE_UNBALANCED = 0.01     # settled when mean unbalanced force / mean contact force falls below this
SETTLE_MIN_TIME = 0.05       # s of deposition before the criterion is checked
SETTLE_MAX_TIME = 3.0        # s; a bed that does not settle by then is an error, not a result
CLOUD_FRACTION = 0.30        # solid fraction of the initial random cloud


def tile(source: Path, tiles: int, out: Path) -> Path:
    """The periodic bed `source` repeated tiles × tiles times in a cell tiles × as long and wide, saved as `out`.
    The copies are shifted by half a cell for even `tiles`, so the cell's centre, where a cone goes, lies at
    the same point of the packing for every `tiles` (the source cell's centre)."""
    import numpy as np
    meta = load_meta(source)
    data = np.load(source)
    L, W, D = meta["size_m"]
    shift = (tiles - 1) / 2 * np.array([L, W])
    pos = np.concatenate([data["pos"] + [i * L, j * W, 0] for i in range(tiles) for j in range(tiles)])
    pos[:, :2] = (pos[:, :2] + shift) % (tiles * L, tiles * W)
    rad = np.tile(data["radius"], tiles * tiles)
    meta.update(key=out.stem, size_m=[tiles * L, tiles * W, D], particles=int(len(rad)), tiles=tiles,
                tiled_from=meta["key"])      # the settling's cost fields stay the source bed's
    return save(out, pos, rad, meta)


def save(out: Path, pos, rad, meta: dict) -> Path:
    """The bed's grains (`out`, .npz) and metadata (.json beside it), each written atomically, the grains first:
    a bed is on disk only once its .json is."""
    import numpy as np
    tmp = out.with_name(f".{out.stem}.{os.getpid()}.tmp.npz")     # two processes settling one bed write apart
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(tmp, pos=pos, radius=rad)
    tmp.replace(out)
    atomic_write(out.with_suffix(".json"), json.dumps(meta, indent=1))
    return out


def settle(O, utils, max_time: float, label: str, log):
    """Run until the unbalanced force falls below SETTLE_UNBALANCED; stop with a diagnostic otherwise."""
    t_end = O.time + max_time
    t_min = O.time + SETTLE_MIN_TIME
    wall0 = time.time()
    while True:
        O.run(500, True)
        ub = utils.unbalancedForce()
        if not math.isfinite(ub) and O.interactions.countReal() == 0 and O.time < t_end:   # 0 / 0: falling freely
            log(f"{label}: t={O.time:.3f} s  no contacts yet")
            continue
        if not math.isfinite(ub):
            raise RuntimeError(f"{label}: unbalanced force is {ub} at t = {O.time:.3f} s (numerical blow-up)")
        log(f"{label}: t={O.time:.3f} s  unbalanced={ub:.4f}  steps={O.iter}  wall={time.time() - wall0:.0f} s")
        if O.time > t_min and ub < SETTLE_UNBALANCED:
            return ub
        if O.time > t_end:
            raise RuntimeError(f"{label}: not settled after {max_time} s simulated (unbalanced {ub:.3f} > {SETTLE_UNBALANCED})")


def check_cached(out: Path, soil):
    """A cached bed was settled for its soil's Table 2 row (its grains' density follows from the bulk density and
    moisture, and the key holds only what shapes the packing): a bed settled for other Table 2 values is refused,
    never reused under the same key."""
    meta = json.loads(out.with_suffix(".json").read_text())
    target = meta.get("target_dry_bulk_density")
    wet = meta.get("wet_bulk_density")
    if target is not None and (abs(target - soil.bulk_density) > 1e-6 * soil.bulk_density
                               or (wet is not None and abs(wet - soil.wet_density) > 1e-6 * soil.wet_density)):
        raise ConfigError(f"bed {out.stem}: settled for a dry bulk density of {target:g} kg/m³ and wet {wet:g} kg/m³; "
                          f"configs/field/table2_soils.csv now gives {soil.bulk_density:g} and {soil.wet_density:g} "
                          f"for {soil.name}: allowed only the bed of the current Table 2 (remove {out.name} and its "
                          ".json to settle it anew)")


def build(soil_name: str, resolution: str, size_mm, seed: int = 1, threads: int = 2, quiet: bool = False,
          bed_dir: Path = BED_DIR, overrides: dict | None = None, lateral: str = "walls", tiles: int = 1) -> Path:
    """Build (or find) the bed; returns the .npz path. All checks run before YADE starts. With `tiles` > 1 the
    bed of `size_mm` is built (or found) and tiled (`tile`)."""
    soil, res = soil_with(load_soil(soil_name), overrides or {}), load_resolution(resolution)
    size = check_size([s / 1000.0 for s in size_mm])
    key = bed_key(soil, res, size, SEED.check("bed.seed", seed), check_lateral(lateral),
                  check_tiles(tiles, lateral))
    check_graded(res, size, lateral)
    check_grains_fit(res, size)
    out = Path(bed_dir) / f"{key}.npz"
    if out.exists() and out.with_suffix(".json").exists():
        check_cached(out, soil)
        return out
    if tiles > 1:
        return tile(build(soil_name, resolution, size_mm, seed, threads, quiet, bed_dir, overrides, lateral),
                    tiles, out)
    log = (lambda *a: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    with held(out.with_suffix(".lock"), log):      # two runs needing one new bed: one settles it, the other waits
        if out.exists() and out.with_suffix(".json").exists():
            check_cached(out, soil)
            return out
        return settle_bed(soil, res, size, key, seed, threads, lateral, out, log)


def settle_bed(soil, res: Resolution, size, key: str, seed: int, threads: int, lateral: str, out: Path, log) -> Path:
    """Deposit, level and settle a new bed (the module's steps) and save it to `out`."""
    from scripts.yadeboot import boot
    boot(threads)
    import numpy as np
    from yade import O, Sphere, pack, utils
    from scripts import soil as part

    wall0 = time.time()
    O.reset()
    L, W, D = size
    r = res.radius
    n_target = int(1.12 * L * W * D * 0.45 / mean_volume(r, res.spread))   # 0.45 solid + levelling margin
    cloud_h = 1.12 * D * 0.45 / CLOUD_FRACTION + 2 * r
    settle_mat = O.materials.append(part.soil_material(soil, density=2650.0, young=soil.young / 4, cohesive=False))
    steel = O.materials.append(part.steel_material(soil))
    periodic = lateral == "periodic"
    sp = pack.SpherePack()
    if res.graded:                  # zone by zone, each at the cloud's solid fraction: it settles where it belongs
        stretch = cloud_h / (1.12 * D)
        for k, (lo, hi, rz) in enumerate(zones(res, L, W, D)):
            n_zone = int((hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) * 0.45 / mean_volume(rz, res.spread))
            sp.makeCloud((lo[0], lo[1], lo[2] * stretch), (hi[0], hi[1], hi[2] * stretch), rMean=rz,
                         rRelFuzz=res.spread, num=n_zone, seed=seed + 1000 * k)
        n_target = None
    else:
        # A periodic cloud fills the cell up to its sides (a walled one keeps its centres a radius from them, which
        # in a periodic cell left a loose column along the sides after settling); its z-period is the cloud's
        # height, so it starts a largest radius above the floor. The scene's cell is set after toSimulation,
        # which sets its own.
        z0 = r * (1 + res.spread) if periodic else 0.0
        sp.makeCloud((0, 0, z0), (L, W, cloud_h), rMean=r, rRelFuzz=res.spread, num=n_target, seed=seed,
                     periodic=periodic)
    sp.toSimulation(material=settle_mat)
    if periodic:
        part.periodic_cell(O, L, W, cloud_h)
    O.bodies.append(part.container(L, W, cloud_h, steel, lateral=lateral))
    log(f"bed {key}: {len(sp)} particles in the cloud (asked {n_target or 'zone by zone'})")
    O.engines = part.engines(damping=0.4, cohesion_on_new_contacts=False)
    O.dt = 0.5 * utils.PWaveTimeStep()
    settle(O, utils, SETTLE_MAX_TIME, "deposition", log)

    coarse_drop = res.coarse_radius - r if res.graded else 0.0             # a coarse top stays under a fine one
    removed = [b.id for b in O.bodies if isinstance(b.shape, Sphere)
               and b.state.pos[2] > D - (0.0 if res.is_fine(b.shape.radius) else coarse_drop)]
    for i in removed:
        O.bodies.erase(i)
    O.materials[settle_mat].young = soil.young                            # working stiffness from here on
    O.interactions.clear()                                                # contacts re-form with the new modulus
    O.dt = 0.5 * utils.PWaveTimeStep()
    settle(O, utils, SETTLE_MAX_TIME, "levelled", log)

    spheres = [b for b in O.bodies if isinstance(b.shape, Sphere)]
    pos = np.array([tuple(b.state.pos) for b in spheres])
    if periodic:
        pos[:, :2] %= (L, W)                                               # wrapped into the cell
    rad = np.array([b.shape.radius for b in spheres])
    if not np.all(np.isfinite(pos)) or (pos[:, 2] < -r).any():
        raise RuntimeError("bed: particles left the box or became NaN while settling")
    if res.graded:                  # the fine zone's porosity sets the density; the coarse one's is reported
        lo, hi, _ = zones(res, L, W, D)[0]
        n = porosity_in(pos, rad, np.add(lo, 2 * r), (hi[0] - 2 * r, hi[1] - 2 * r, D - 2 * r), k=16)
        m = res.coarse_radius
        n_coarse = porosity_in(pos, rad, (m, m, m), (L - m, W - m, D - 2 * m),
                               outside=(np.subtract(lo, m), (hi[0] + m, hi[1] + m, np.inf)), k=16)
    else:
        n = interior_porosity(pos, rad, L, W, D, r)
    grain_density = soil.wet_density / (1.0 - n)
    meta = {"key": key, "soil": soil.name, "resolution": res.name, "radius": r, "spread": res.spread,
            "size_m": list(size), "seed": seed, "lateral": lateral, "particles": int(len(rad)), "removed_levelling": len(removed),
            "porosity": n, "grain_density": grain_density, "wet_bulk_density": grain_density * (1 - n),
            "dry_bulk_density": grain_density * (1 - n) / (1 + soil.moisture),
            "target_dry_bulk_density": soil.bulk_density,
            "whole_bed_dry_bulk_density": grain_density * float(np.sum(4 / 3 * np.pi * rad ** 3)) / (L * W * D)
            / (1 + soil.moisture), "surface_z": float(np.max(pos[:, 2] + rad)),
            "settle_unbalanced": SETTLE_UNBALANCED, "steps": int(O.iter), "sim_time_s": O.time,
            "wall_s": time.time() - wall0, "threads": threads, "particle_steps": int(O.iter) * int(len(rad))}
    if res.graded:
        fine = res.is_fine(rad)
        meta["graded"] = {"coarse_radius": res.coarse_radius, "fine_width": res.fine_width,
                          "fine_depth": res.fine_depth, "fine_particles": int(fine.sum()),
                          "coarse_particles": int((~fine).sum()), "coarse_porosity": n_coarse,
                          "coarse_dry_bulk_density": grain_density * (1 - n_coarse) / (1 + soil.moisture)}
    save(out, pos, rad, meta)
    log(f"bed {key}: {len(rad)} particles, porosity {n:.3f}, grain density {grain_density:.0f} kg/m3, "
        f"{meta['wall_s']:.0f} s wall")
    return out


def interior_porosity(pos, rad, L, W, D, r, n_points: int = 200000, seed: int = 0) -> float:
    """Porosity by Monte Carlo points in the interior (2 mean radii from walls, bottom and surface)."""
    m = 2 * r
    return porosity_in(pos, rad, (m, m, m), (L - m, W - m, D - 2 * m), n_points=n_points, seed=seed)


def porosity_in(pos, rad, lo, hi, outside=None, k: int = 8, n_points: int = 200000, seed: int = 0) -> float:
    """Porosity by Monte Carlo points in the box [lo, hi], leaving out those in the box `outside` (lo, hi); a
    point is solid if one of its `k` nearest grain centres holds it (mixed sizes want more than one size's 8)."""
    import numpy as np
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(seed)
    pts = rng.uniform(lo, hi, size=(n_points, 3))
    if outside is not None:
        pts = pts[~np.all((pts >= outside[0]) & (pts <= outside[1]), axis=1)]
    tree = cKDTree(pos)
    inside = np.zeros(len(pts), bool)
    for idx in tree.query(pts, k=k)[1].T:
        inside |= np.linalg.norm(pts - pos[idx], axis=1) < rad[idx]
    return float(1.0 - inside.mean())


def bed_resolution(meta: dict) -> Resolution:
    """The grain sizes a bed was built with, from its metadata (not from today's configs/resolutions.toml)."""
    graded = meta.get("graded") or {}
    return Resolution(meta["resolution"], meta["radius"], meta["spread"],
                      **{k: graded.get(k, 0.0) for k in ("coarse_radius", "fine_width", "fine_depth")})


def load_meta(path: Path) -> dict:
    return json.loads(Path(path).with_suffix(".json").read_text())


def bed_arguments(description: str, default_size: str, prog: str = "holes bed") -> argparse.ArgumentParser:
    """The options every scene takes to name its bed."""
    p = CommandLine(prog=prog, description=description)
    p.add_argument("--soil", default="clay", help="clay | loam | sand, or a soil config's path (default clay)")
    p.add_argument("--resolution", default="default", help="grain size: r3 r4 r5 r6 r8 (radius in mm) or a section of "
                   "configs/resolutions.toml (default: default, r = 4 mm)")
    p.add_argument("--size", default=default_size, help="bed length,width,depth in mm")
    p.add_argument("--seed", type=option("--seed", SEED), default=1, help="packing seed, >= 0 (default 1)")
    p.add_argument("--lateral", default="walls", help="the bed's sides: " + " | ".join(LATERAL))
    p.add_argument("--tiles", type=int, default=1, help="a periodic bed repeated tiles x tiles times (--size: one copy)")
    p.add_argument("--threads", type=option("--threads", THREADS), default=2, help="YADE threads (default 2)")
    p.add_argument("--bed-dir", type=folder("--bed-dir"), default=str(BED_DIR), help="where beds are kept")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a soil contact parameter")
    return p


def bench_start(bed_path: Path, soil_name: str, overrides: dict | None, threads: int, quiet: bool):
    """A bench test's first steps on a settled bed: the soil with the test's overrides, the bed's metadata, YADE
    booted on `threads` with an empty scene, the bed's grains (pos, radius; r their mean radius, top the highest
    grain's top, m) and a progress logger."""
    soil = soil_with(load_soil(soil_name), overrides or {})
    meta = load_meta(bed_path)
    log = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    from scripts.yadeboot import boot
    boot(threads)
    import numpy as np
    from yade import O
    O.reset()
    data = np.load(bed_path)
    from types import SimpleNamespace
    grains = SimpleNamespace(pos=data["pos"], radius=data["radius"], r=float(np.mean(data["radius"])),
                             top=float(np.max(data["pos"][:, 2] + data["radius"])))
    return soil, meta, grains, log


def add_test_set(p: argparse.ArgumentParser):
    """A bench test's overrides of the soil's contact parameters that leave its bed as configured: the packing is
    prepared one way for every test of a calibration, and only the tested contact law varies."""
    p.add_argument("--test-set", action="append", metavar="KEY=VALUE",
                   help="override a soil contact parameter in the test only (the bed settles as configured)")


def test_overrides(a) -> dict:
    """A bench test's contact overrides, `--set` (bed and test) then `--test-set` (test only), each checked against
    the soil's fields before a bed settles."""
    test = {**parse_overrides(a.set), **parse_overrides(a.test_set)}
    soil_with(load_soil(a.soil), test)
    return test


def bed_from_args(a) -> Path:
    return build(a.soil, a.resolution, [float(s) for s in a.size.split(",")], a.seed, a.threads, bed_dir=Path(a.bed_dir),
                 overrides=parse_overrides(a.set), lateral=a.lateral, tiles=a.tiles)
