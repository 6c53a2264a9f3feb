"""Scene: the collapse of a column of disturbed soil (a soil bench test): the slope disturbed soil stands at.

    .venv/bin/python scripts/collapse.py --soil clay --resolution medium --size 150,150,100

A settled bed's grains stand in a box (a back wall, two smooth side walls, a gate, a rough floor reaching
RUNOUT_LENGTHS × the column's length beyond the gate). The floor (--floor) is a plane of the soil's friction and
rolling resistance ("plane"), or a layer of fixed grains of the bed's radius in a close-packed lattice, their tops at
the plane's level ("grains"), as a laboratory glues grains to its base: a plane is only as rough as the grains' own
friction, and grains of a few degrees run out along it as on ice. Every contact is a new one, bonded at the soil's
`new_contact_cohesion` of the intact bonds' strength: the column is soil that a tool has broken and that has been
pressed together again, what falls back into a hole. The gate is taken away and the column slumps under gravity
until all but a few grains (STILL_SHARE) move slower than STILL_SPEED; a grain that rolls off the floor's end is
taken out (counted as ran_off), and the test stops when more than that few do. The slope angle is the drop from 80 %
to 20 % of the crest's height over the distance between where the surface's height profile first falls below each, downhill
from the crest, each crossing interpolated between bins (analysis/soil/collapse.py; the surface: the highest
grain top per bin of one grain diameter along the run-out), the front the farthest a grain got. Writes
results/soils/collapse/<bed key>.json (or --out) and prints it as a JSON line.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import folder, option  # noqa: E402
from analysis.core.schema import ROOT, ConfigError, Field  # noqa: E402
from analysis.core.io import atomic_write  # noqa: E402
from analysis.soil.collapse import FLOORS, slope_angle  # noqa: E402

RUNOUT_LENGTHS = 4.0           # the floor beyond the gate, in column lengths (room for a low-damping heap's toe)
STILL_SPEED = 0.01             # m/s: the collapse is over when STILL_SHARE of the grains move slower
STILL_SHARE = 0.99             # (a few grains rolling away on the floor do not hold the test open)
MAX_TIME_FIELD = Field(0.5, 30.0, unit="s", meaning="the longest a collapse may run")
MIN_TIME = 0.3                 # s before the stillness is checked (the gate's opening takes a few ms)
MAX_TIME = 3.0                 # s: a column still moving by then is reported as such, never as a slope (--max-time)


def run(bed_path: Path, soil_name: str, threads: int = 1, overrides: dict | None = None, quiet: bool = False,
        max_time: float = MAX_TIME, floor: str = "plane") -> dict:
    """Let the bed's column of disturbed soil collapse; return its slope, height and run-out."""
    from scripts.beds import bench_start
    soil, meta, data, log = bench_start(bed_path, soil_name, overrides, threads, quiet)
    import numpy as np
    from yade import O, utils
    from scripts import soil as part

    wall0 = time.time()
    L, W, D = meta["size_m"]
    r, top0 = data.r, data.top
    mat = O.materials.append(part.soil_material(part.disturbed(soil), density=meta["grain_density"], cohesive=True))
    smooth = O.materials.append(part.steel_material(soil, friction_deg=0.0))
    rough = O.materials.append(part.soil_material(soil, density=meta["grain_density"], cohesive=False,
                                                  label="floor"))  # soil on soil: its friction and rolling resistance,
    # never bonded (a floor without rolling resistance lets grains roll on until the local damping stops them)
    grains = list(O.bodies.append([utils.sphere(tuple(p), rr, material=mat)
                                   for p, rr in zip(data.pos, data.radius)]))
    t, H = 0.02, top0 + 0.05
    far = L * (1 + RUNOUT_LENGTHS)
    base = 0.0
    if floor == "grains":                             # the fixed grains' tops at z = 0, the plane under their centres
        centres = floor_grains(far, W, r)
        O.bodies.append([utils.sphere(tuple(c), r, fixed=True, material=rough) for c in centres])
        base = -r
    O.bodies.append([
        utils.box((far / 2, W / 2, base - t), (far / 2 + t, W / 2 + t, t), fixed=True, material=rough),  # floor
        utils.box((-t, W / 2, H / 2), (t, W / 2 + t, H / 2), fixed=True, material=smooth),             # back wall
        utils.box((far / 2, -t, H / 2), (far / 2 + t, t, H / 2), fixed=True, material=smooth),         # sides
        utils.box((far / 2, W + t, H / 2), (far / 2 + t, t, H / 2), fixed=True, material=smooth)])
    gate = O.bodies.append(utils.box((L + t, W / 2, H / 2), (t, W / 2, H / 2), fixed=True, material=smooth))
    O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True,
                             extra=part.bond_rules(O, soil))
    O.dt = 0.5 * utils.PWaveTimeStep()
    O.run(1, True)                                    # every contact bonded at the disturbed soil's strength
    O.bodies.erase(gate)
    still, column, ran_off = False, len(grains), 0
    while O.time < max_time:
        O.run(1000, True)
        off = {i for i in grains if O.bodies[i].state.pos[0] > far}
        if off:                                       # rolled off the floor's end: not the heap's, and falling
            for i in off:                             # they would read as unstable
                O.bodies.erase(i)
            grains, ran_off = [i for i in grains if i not in off], ran_off + len(off)
            if ran_off > (1 - STILL_SHARE) * column:
                raise RuntimeError(f"collapse: {ran_off} grains ran off the floor's end, {RUNOUT_LENGTHS:g} column "
                                   f"lengths past the gate, by t = {O.time:.3f} s: the heap runs out farther than the "
                                   "test measures")
        v = np.array([O.bodies[i].state.vel.norm() for i in grains])
        if not np.all(np.isfinite(v)) or v.max() > 20.0:
            raise RuntimeError(f"collapse: a grain moves at {np.nanmax(v):.2f} m/s at t = {O.time:.3f} s (unstable)")
        front = max(O.bodies[i].state.pos[0] for i in grains)
        moving = float(np.quantile(v, STILL_SHARE))
        log(f"collapse: t {O.time:.2f} s  {100 * STILL_SHARE:g} % of the grains under {moving:.3f} m/s  front "
            f"{1000 * front:.0f} mm  wall {time.time() - wall0:.0f} s")
        if O.time > MIN_TIME and moving < STILL_SPEED:
            still = True
            break
    if not still:
        raise RuntimeError(f"collapse: {100 * (1 - STILL_SHARE):g} % of the grains still move faster than {moving:.3f} m/s "
                           f"after {max_time:g} s, the front {1000 * (front - L):.0f} mm past the gate")
    pos = np.array([O.bodies[i].state.pos for i in grains])
    rad = np.array([O.bodies[i].shape.radius for i in grains])
    edges = np.arange(0.0, far + 2 * r, 2 * r)
    which = np.digitize(pos[:, 0], edges) - 1
    top = np.zeros(len(edges) - 1)
    np.maximum.at(top, np.clip(which, 0, len(top) - 1), pos[:, 2] + rad)
    slope = slope_angle((edges[:-1] + edges[1:]) / 2, top)
    return {"bed": meta["key"], "soil": soil.name, "radius_m": r, "size_m": [L, W, D], "floor": floor,
            "new_contact_cohesion": soil.new_contact_cohesion, "angle_deg": slope["angle_deg"], "slope_run_m": slope["run_m"],
            "height_ratio": slope["height_m"] / top0, "runout_mm": 1000 * (float(np.max(pos[:, 0] + rad)) - L),
            "particles": column, "ran_off": ran_off, "steps": int(O.iter), "dt": O.dt, "time_s": O.time,
            "wall_s": time.time() - wall0,
            "threads": threads, "profile_mm": [[round(1000 * a, 1), round(1000 * b, 1)] for a, b in zip(edges[:-1], top)]}


def floor_grains(length: float, width: float, r: float):
    """The centres of a floor of touching grains of radius r in a close-packed (hexagonal) lattice over length ×
    width from the origin, their centres at z = -r: rows along x, 2r apart, √3 r between rows, odd rows shifted by r.

    >>> c = floor_grains(0.1, 0.05, 0.01)
    >>> len(c), c[0].tolist(), c[5].round(4).tolist()
    (9, [0.01, 0.01, -0.01], [0.02, 0.0273, -0.01])
    """
    import numpy as np
    rows = np.arange(r, width - r + 1e-12, np.sqrt(3) * r)
    out = []
    for j, y in enumerate(rows):
        xs = np.arange(r * (1 + j % 2), length - r + 1e-12, 2 * r)
        out += [(x, y, -r) for x in xs]
    return np.array(out)


def arguments():
    """The collapse test's command line: the bed's options, the test's overrides and where the result goes."""
    from scripts import beds as bed
    p = bed.bed_arguments(__doc__.splitlines()[0], "150,150,100", "holes collapse")
    bed.add_test_set(p)
    p.add_argument("--out", type=folder("--out"), help="where the result goes (default results/soils/collapse)")
    p.add_argument("--max-time", type=option("--max-time", MAX_TIME_FIELD), default=MAX_TIME,
                   help=f"simulated seconds the column may take to come to rest (default {MAX_TIME:g})")
    p.add_argument("--floor", choices=FLOORS, default="plane",
                   help="the floor's roughness: a plane of the soil's friction (default) or a layer of fixed grains")
    return p


def main(argv=None) -> int:
    from scripts import beds as bed
    a = arguments().parse_args(argv)
    try:
        test = bed.test_overrides(a)
        row = run(bed.bed_from_args(a), a.soil, a.threads, test, max_time=a.max_time, floor=a.floor)
    except (ConfigError, ValueError) as e:
        print(f"collapse: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"collapse stopped: {e}", file=sys.stderr)
        return 3
    out = Path(a.out) if a.out else ROOT / "results/soils/collapse"
    row["overrides"] = test
    atomic_write(out / f"{row['bed']}.json", json.dumps(row, indent=1))
    print(json.dumps({k: v for k, v in row.items() if k != "profile_mm"}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
