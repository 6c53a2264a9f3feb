"""Scene: a virtual cone penetrometer (ASABE S313: 30° cone, 12.83 mm base) pushed into a settled bed.

    .venv/bin/python scripts/cone.py --soil clay --resolution default --size 200,200,260 --cone-scale 3

Parts: bed (loaded by the bed part, scripts/beds.py, cohesion switched on for existing and new contacts), tool (a facet
cone with a shaft of 0.74 × the base diameter, as S313's 9.53 mm shaft on the 12.83 mm cone), kinematics
(constant downward speed), recorder (force on the cone facets against the base depth).

The cone is scaled by `cone_scale` because a 12.83 mm cone meets only one or two particles of a bed that a
2-core machine can hold; cone index = mean (axial force on the cone / base area) over base depths 0-150 mm,
as in the field. Penetration is faster than S313's 30 mm/s (default 300 mm/s); the inertial number
I = (v/D_cone)·d/sqrt(p/ρ) stays below 1e-2, the quasi-static range, and the speed is an option.
Writes results/cache/cone/<bed key>-c<scale>-v<speed>-coh<cohesion>.csv (depth, resistance) and a summary JSON line;
with --damage also <stem>-damage.csv: the bed's first bonds by depth band and distance from the cone's axis,
and how many of them the penetration broke (how far the cone's damage reaches, against the bed's half-width).
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import folder, option
from analysis.core.config import CONE_DEPTH, CONE_FIELDS
from analysis.core.schema import ConfigError, digest  # noqa: E402
from analysis.core.bed_spec import CONE_DIR  # noqa: E402
from analysis.core.soil_config import SOIL_FIELDS, load_soil, soil_with
from analysis.core.io import atomic_write  # noqa: E402

S313_BASE_DIAMETER = 0.01283     # m
S313_SHAFT_RATIO = 9.53 / 12.83
S313_APEX_DEG = 30.0
S313_SPEED = 0.030               # m/s
APEX_SPHERE_RATIO = 0.2          # blunt-tip sphere radius / cone base radius
CI_DEPTH = 0.150                 # m: the field's cone index is the mean over 0-150 mm
DAMAGE_RING = 0.010             # m: radial bins of the damage map
DAMAGE_BANDS = (0.0, 0.05, 0.10, 0.15, 0.30)   # m below the surface: depth bands of the damage map
def run(bed_path: Path, soil_name: str, cone_scale: float = 3.0, speed: float = 0.3, cohesion: float | None = None,
        threads: int = 2, depth: float = CI_DEPTH, quiet: bool = False, out_dir: Path | None = None,
        overrides: dict | None = None, damage: bool = False) -> dict:
    """Push the cone from above the surface to `depth` (base depth) and return the summary; `damage` also
    writes the damage map (`damage_map`)."""
    cone_scale = CONE_FIELDS["cone_scale"].check("cone.cone_scale", cone_scale)
    speed = CONE_FIELDS["speed"].check("cone.speed", speed)
    soil = load_soil(soil_name)
    if cohesion is not None:          # the bond pair, then the tested parameters: a shear bond of their own wins
        soil = dataclasses.replace(soil, normal_cohesion=cohesion, shear_cohesion=cohesion)
    soil = soil_with(soil, overrides or {})
    from scripts.beds import load_meta
    meta = load_meta(bed_path)
    L, W, D = meta["size_m"]
    Rc = cone_scale * S313_BASE_DIAMETER / 2
    hc = Rc / math.tan(math.radians(S313_APEX_DEG / 2))
    if depth + hc + 2 * meta["radius"] * 2 > D:
        raise ConfigError(f"cone: bed depth {D * 1000:.0f} mm is too shallow for a {2 * Rc * 1000:.1f} mm cone to "
                          f"{depth * 1000:.0f} mm; allowed: depth + cone height + 4 radii <= bed depth")
    log = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))

    from scripts.yadeboot import boot
    boot(threads)
    import numpy as np
    from yade import O, Quaternion, TranslationEngine, geom, utils
    from scripts import soil as part

    wall0 = time.time()
    O.reset()
    data = np.load(bed_path)
    mat = O.materials.append(part.soil_material(soil, density=meta["grain_density"], cohesive=True))
    steel = O.materials.append(part.steel_material(soil))
    O.bodies.append([utils.sphere(tuple(p), r, material=mat) for p, r in zip(data["pos"], data["radius"])])
    n_particles = len(data["radius"])
    surface = float(np.percentile(data["pos"][:, 2] + data["radius"], 95))    # level of the upper grains
    lateral = meta.get("lateral", "walls")
    O.bodies.append(part.container(L, W, surface + 0.05, steel, lateral=lateral))
    x0, y0, z_tip0 = L / 2, W / 2, surface + 0.005
    # Blunt tip: a sphere of radius a inscribed at the apex, tangent to the faces, and the facet cone cut
    # where it touches. 24 facets meeting in one vertex would give a grain there up to 24 contacts at full
    # stiffness, far stiffer than the P-wave time step allows.
    half = math.radians(S313_APEX_DEG / 2)
    a = APEX_SPHERE_RATIO * Rc
    z_center = z_tip0 + a / math.sin(half)                 # measured from the virtual apex
    z_cut = z_tip0 + (a / math.sin(half)) * math.cos(half) ** 2
    flip = Quaternion((1, 0, 0), math.pi)                  # facetCone's narrow end down
    cone_ids = list(O.bodies.append(geom.facetCone((x0, y0, (z_cut + z_tip0 + hc) / 2), Rc, a * math.cos(half),
                                                   z_tip0 + hc - z_cut, orientation=flip, segmentsNumber=24,
                                                   wallMask=4, material=steel)))
    cone_ids.append(O.bodies.append(utils.sphere((x0, y0, z_center), a, fixed=True, material=steel)))
    shaft_len = depth + 0.03
    shaft_ids = O.bodies.append(geom.facetCylinder((x0, y0, z_tip0 + hc + shaft_len / 2), S313_SHAFT_RATIO * Rc,
                                                   shaft_len, segmentsNumber=16, wallMask=4, material=steel))
    if lateral == "periodic":                 # the floor's image at the cell's top stays clear of the shaft's top
        part.periodic_cell(O, L, W, z_tip0 + hc + shaft_len)
    tool = cone_ids + list(shaft_ids)
    rows = []

    def record():
        """Resistance = axial soil force on the cone / base area, against the base's depth."""
        base_depth = surface - (z_tip0 + hc) + speed * O.time
        fz = sum(O.forces.f(i)[2] for i in cone_ids)
        if not math.isfinite(fz):
            raise RuntimeError(f"cone: force is {fz} at t = {O.time:.4f} s (numerical blow-up)")
        rows.append((base_depth, fz / (math.pi * Rc * Rc)))

    O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True, extra=[
        TranslationEngine(ids=tool, translationAxis=(0, 0, -1), velocity=speed, label="push"),
        *part.bond_rules(O, soil)])
    part.hold_tool_friction(O, soil)
    O.dt = 0.5 * utils.PWaveTimeStep()
    n_steps = int(((surface - z_tip0) + hc + depth + 0.005) / speed / O.dt) + 1
    report = max(1, n_steps // 20)
    first_bonds = None
    while O.iter < n_steps:
        O.run(20, True)
        if O.iter == 20:                          # the bed's bonds exist; the cone is still above the surface
            part.bond_new_contacts(O, soil)
        record()
        if damage and first_bonds is None:        # the bed's bonds, made at the first step, before the cone arrives
            first_bonds = bonded_pairs(O, n_particles)
        if O.iter % report < 20:
            wall = time.time() - wall0
            log(f"cone: {100 * O.iter / n_steps:3.0f} %  base depth {rows[-1][0] * 1000:5.1f} mm  "
                f"resistance {rows[-1][1] / 1000:6.1f} kPa  wall {wall:.0f} s  ETA {wall * (n_steps / O.iter - 1):.0f} s")
            vmax = max(b.state.vel.norm() for b in O.bodies if b.dynamic)
            if vmax > 50 * speed:
                raise RuntimeError(f"cone: a particle moves at {vmax:.2f} m/s, > 50 × the cone speed (unstable)")
    d = np.array(rows)
    in_range = (d[:, 0] >= 0) & (d[:, 0] <= depth)
    ci = float(d[in_range, 1].mean())
    p_mean = max(ci, 1.0)
    inertial = (speed / (2 * Rc)) * 2 * meta["radius"] / math.sqrt(p_mean / meta["grain_density"])
    summary = {"bed": meta["key"], "soil": soil.name, "cohesion_pa": soil.normal_cohesion, "cone_scale": cone_scale,
               "cone_diameter_m": 2 * Rc, "cone_to_particle": 2 * Rc / (2 * meta["radius"]), "speed": speed,
               "cone_index_pa": ci, "lateral": lateral, "inertial_number": inertial, "particles": n_particles,
               "steps": int(O.iter),
               "dt": O.dt, "wall_s": time.time() - wall0, "threads": threads,
               "particle_steps_per_s": n_particles * O.iter / (time.time() - wall0)}
    out_dir = out_dir or CONE_DIR
    from analysis.soil.calibrate import cone_result_name, cone_tested
    name = cone_result_name(meta["key"], cone_scale, speed, soil.normal_cohesion)
    tested = cone_tested(overrides or {}, soil.normal_cohesion, soil.shear_cohesion)
    if tested:                         # a law tested on the configured bed: named apart from the configured soil's runs
        name += "-t" + digest(sorted(tested.items()))
        summary["overrides"] = tested
    atomic_write(out_dir / f"{name}.csv", "base_depth_m,resistance_pa\n" + "".join(f"{a:.5f},{b:.1f}\n" for a, b in rows))
    atomic_write(out_dir / f"{name}.json", json.dumps(summary, indent=1))
    if damage:
        now = bonded_pairs(O, n_particles)
        pos = np.array([O.bodies[i].state.pos for i in range(n_particles)])
        table = damage_map(first_bonds, now, pos, (x0, y0), surface, (L, W) if lateral == "periodic" else None)
        atomic_write(out_dir / f"{name}-damage.csv", table.to_csv(index=False))
    return summary


def bonded_pairs(O, n_grains: int) -> set:
    """The grain pairs (id1, id2) whose contact holds an unbroken bond now."""
    return {(i.id1, i.id2) for i in O.interactions
            if i.isReal and i.id1 < n_grains and i.id2 < n_grains and not i.phys.cohesionBroken}


def damage_map(first: set, now: set, pos, axis: tuple, surface: float, period: tuple | None):
    """The bonds of `first` by depth band (DAMAGE_BANDS) and ring round the cone's axis (DAMAGE_RING wide) at
    their midpoints, and how many are missing from `now` (broken, or their grains apart). In a periodic bed
    the distance is to the nearest image of the axis. Returns a pandas table."""
    import numpy as np
    import pandas as pd
    ij = np.array(sorted(first))
    mid = 0.5 * (pos[ij[:, 0]] + pos[ij[:, 1]])
    d = mid[:, :2] - np.asarray(axis)
    if period is not None:
        d -= np.asarray(period) * np.round(d / np.asarray(period))
    ring = np.floor(np.hypot(d[:, 0], d[:, 1]) / DAMAGE_RING).astype(int)
    band = np.digitize(surface - mid[:, 2], DAMAGE_BANDS) - 1
    broken = np.array([(i, j) not in now for i, j in ij])
    t = pd.DataFrame({"band": band, "ring": ring, "broken": broken})
    t = t[(t.band >= 0) & (t.band < len(DAMAGE_BANDS) - 1)]
    g = t.groupby(["band", "ring"]).broken.agg(["size", "sum"]).reset_index()
    return pd.DataFrame({"depth_lo_mm": [1000 * DAMAGE_BANDS[b] for b in g.band],
                         "depth_hi_mm": [1000 * DAMAGE_BANDS[b + 1] for b in g.band],
                         "r_lo_mm": 1000 * DAMAGE_RING * g.ring, "r_hi_mm": 1000 * DAMAGE_RING * (g.ring + 1),
                         "bonds": g["size"], "broken": g["sum"]})


def arguments():
    """The cone's command line: the bed's options and the cone's, each number checked against its Field."""
    from scripts import beds as bed
    p = bed.bed_arguments(__doc__.splitlines()[0], "200,200,260", "holes cone")
    p.add_argument("--cone-scale", type=option("--cone-scale", CONE_FIELDS["cone_scale"]), default=3.0,
                   help="cone size / ASABE S313 size, [0.5, 20] (default 3)")
    p.add_argument("--cone-speed", type=option("--cone-speed", CONE_FIELDS["speed"]), default=0.3,
                   help="the cone's penetration speed, m/s (default 0.3)")
    p.add_argument("--cohesion", type=option("--cohesion", SOIL_FIELDS["normal_cohesion"]),
                   help="Pa; overrides the soil config's normal and shear cohesion (a --test-set of either wins)")
    p.add_argument("--depth", type=option("--depth", CONE_DEPTH), default=CI_DEPTH * 1000,
                   help="deepest base depth, mm (field: 150)")
    p.add_argument("--out", type=folder("--out"), help="where the resistance CSV goes (default results/cache/cone)")
    p.add_argument("--damage", action="store_true", help="also map the bonds the cone broke (<stem>-damage.csv)")
    bed.add_test_set(p)
    return p


def main(argv=None) -> int:
    from scripts import beds as bed
    a = arguments().parse_args(argv)
    try:
        test = bed.test_overrides(a)
        summary = run(bed.bed_from_args(a), a.soil, a.cone_scale, a.cone_speed, a.cohesion, a.threads, a.depth / 1000,
                      out_dir=Path(a.out) if a.out else None, overrides=test, damage=a.damage)
    except (ConfigError, ValueError) as e:
        print(f"cone: {e}", file=sys.stderr)
        return 2
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
