"""Scene: a direct shear box (a soil bench test) on a settled bed: c and φ of the model soil.

    .venv/bin/python scripts/shear.py --soil clay --resolution medium --size 150,150,100 --stress 50,100,200

Parts: bed (scripts/beds.py; intact bonds on the settled contacts; a contact made later gets the soil's
new_contact_cohesion of their strength, as in the tool scenes; `--remoulded`: every contact a new one, as in the
collapse column, bonded only as the lid's load presses it (pressed_adhesion), a sample packed from disturbed soil
as a laboratory's remoulded one is), box (the lower half fixed, the upper half's four
thin walls pushed along +x at a constant speed, the shear plane at mid-height with a gap between the frames of
GAP × the smallest grain's diameter, so no grain is squeezed out through it, and the lower half's rim reaching
beyond it as far as the upper half travels, so the soil the upper half carries past the lower one rests on it
as it does on a real box's rim (a grain that leaves all the same is
taken away and counted; more than MAX_ESCAPED of them stop the test); frames and lid smooth, so no wall
friction wedges the sample),
lid (a plate resting on the sample under a dead load σn·A, free to rise and sink, moving with the upper half;
`--preload`: first under a higher load, then eased to σn before shearing, so the sample keeps the bonds the preload
pressed into it, as an overconsolidated sample does),
recorder (the shear force the upper half takes, and the shear and normal forces the grains pass across the shear
plane through their contacts, against the shift, each over the sheared area). One fresh sample per normal stress,
as a shear box test is run; the peak shear stress over a shift of SHEAR_STRAIN × the box's length is τ at that σn.
Writes results/soils/shear/<bed key>-<stresses>.json (per σn: peak and residual τ, the plane's τ and σ, the lid's
rise, the curve) with the Mohr-Coulomb fit (analysis/soil/shear.py), and prints the fit as a JSON line. Each normal
stress's test is kept beside it as it finishes (<bed key>-<σn>-<its settings' hash>.part.json) and reused by a run
asking for the same of the same code, so a stopped run resumes at the stress it stopped in; the result written, they
go.
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import folder, option  # noqa: E402
from analysis.core.schema import ROOT, ConfigError, Field, digest
from analysis.core.io import atomic_write, kept_each  # noqa: E402

STRESS = Field(1.0, 1000.0, unit="kPa", meaning="normal stress on the sample")
SPEED = Field(0.001, 0.2, unit="m/s", meaning="the upper half's shearing speed")
SHEAR_STRAIN = 0.2             # the upper half is pushed this fraction of the box's length
CONSOLIDATE_S = 0.05           # s under the lid's load before shearing
LID_T = 0.01                   # m: the lid's half-thickness
FRAME_T = 0.002                # m: the frames' half-thickness (a thin edge at the shear plane)
GAP = 0.9                      # the gap between the frames, in the smallest grain's diameters: no grain passes it
MAX_ESCAPED = 0.01             # the share of the grains that may leave through the gap before the box is a leak
SCENE_SOURCES = tuple(ROOT / "scripts" / n for n in ("shear.py", "soil.py", "beds.py"))   # the code a kept test ran
CHUNK = 50                     # steps between two records of the curve (0.09 mm of shift at 0.05 m/s, r = 6 mm)


def run(bed_path: Path, soil_name: str, stress_kpa: float, speed: float = 0.05, threads: int = 1,
        overrides: dict | None = None, quiet: bool = False, remoulded: bool = False,
        preload_kpa: float | None = None) -> dict:
    """Consolidate the bed's sample (remoulded: every contact a new one) under σn = stress_kpa (first under
    preload_kpa, then eased to σn), shear it, return its curve's summary."""
    from scripts.beds import bench_start
    soil, meta, data, log = bench_start(bed_path, soil_name, overrides, threads, quiet)
    import numpy as np
    from yade import O, utils
    from scripts import soil as part

    wall0 = time.time()
    L, W, D = meta["size_m"]
    r, top = data.r, data.top
    mat = O.materials.append(part.soil_material(part.disturbed(soil) if remoulded else soil,
                                                density=meta["grain_density"], cohesive=True))
    steel = O.materials.append(part.steel_material(soil, friction_deg=0.0))     # smooth: no wall friction wedges
    grains = list(O.bodies.append([utils.sphere(tuple(p), rr, material=mat)
                                   for p, rr in zip(data.pos, data.radius)]))
    n_grains = len(grains)
    plane, gap, t, height = D / 2, GAP * 2 * float(np.min(data.radius)), FRAME_T, top + 0.1
    lower = part.container(L, W, plane - gap / 2, steel, t=t)       # floor and walls up to the shear plane
    rim = SHEAR_STRAIN * L + 4 * r              # the lower half's rim beyond x = L: the upper half's soil rests on it
    lower.append(utils.box((L + 2 * t + rim / 2, W / 2, (plane - gap / 2) / 2), (rim / 2, W / 2 + t, (plane - gap / 2) / 2),
                           fixed=True, material=steel))
    upper = [utils.box(c, e, fixed=True, material=steel) for c, e in (
        ((-t, W / 2, (plane + gap / 2 + height) / 2), (t, W / 2 + t, (height - plane - gap / 2) / 2)),
        ((L + t, W / 2, (plane + gap / 2 + height) / 2), (t, W / 2 + t, (height - plane - gap / 2) / 2)),
        ((L / 2, -t, (plane + gap / 2 + height) / 2), (L / 2 + t, t, (height - plane - gap / 2) / 2)),
        ((L / 2, W + t, (plane + gap / 2 + height) / 2), (L / 2 + t, t, (height - plane - gap / 2) / 2)))]
    O.bodies.append(lower)
    upper_ids = list(O.bodies.append(upper))
    lid = utils.box((L / 2, W / 2, top + LID_T + 0.001), (L / 2 - 0.002, W / 2 - 0.002, LID_T), material=steel)
    lid.state.blockedDOFs = "xyXYZ"                   # it sinks and rises; it moves along x with the upper half
    lid_id = O.bodies.append(lid)
    area = L * W
    load = stress_kpa * 1e3 * area
    O.forces.setPermF(lid_id, (0, 0, -(preload_kpa * 1e3 * area if preload_kpa else load)))
    rows = []
    O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True,
                             extra=part.bond_rules(O, soil))
    for i in upper_ids:                                  # moved by their velocity, set once, not by forces
        O.bodies[i].dynamic = False
    O.dt = 0.5 * utils.PWaveTimeStep()
    n_consolidate = int(CONSOLIDATE_S / O.dt)
    O.run(1, True)                                      # the intact bonds (remoulded: the disturbed soil's)
    part.bond_new_contacts(O, soil)
    O.run(n_consolidate - 1, True)
    if preload_kpa:                                     # eased to σn, at rest again before shearing
        O.forces.setPermF(lid_id, (0, 0, -load))
        O.run(n_consolidate, True)
    n_sheared_from = O.iter
    z_lid0 = O.bodies[lid_id].state.pos[2]
    travel = SHEAR_STRAIN * L
    n_shear = int(travel / speed / O.dt) + 1
    for i in upper_ids:
        O.bodies[i].state.vel = (speed, 0, 0)
    O.bodies[lid_id].state.vel = (speed, 0, 0)          # x is blocked: the lid keeps this speed along x
    t_shear, wall_shear0 = O.time, time.time()
    report = max(1, n_shear // 10)
    chunk = CHUNK
    escaped = 0
    while O.iter < n_sheared_from + n_shear:
        O.run(chunk, True)
        fx = -sum(O.forces.f(i)[0] for i in upper_ids) - O.forces.f(lid_id)[0]    # the push the soil resists
        f_plane, n_plane = across_plane(O, n_grains, plane)
        if not math.isfinite(fx):
            raise RuntimeError(f"shear: the force is {fx} at t = {O.time:.4f} s (numerical blow-up)")
        shift = speed * (O.time - t_shear)
        area = (L - shift) * W
        rows.append((shift, fx / area, O.bodies[lid_id].state.pos[2] - z_lid0, f_plane / area, n_plane / area))
        if (O.iter - n_sheared_from) % report < chunk:
            log(f"shear σn {stress_kpa:g} kPa: {100 * shift / travel:3.0f} %  τ {rows[-1][1] / 1e3:6.1f} kPa  "
                f"at the plane {abs(rows[-1][3]) / 1e3:6.1f} kPa under σ {abs(rows[-1][4]) / 1e3:6.1f} kPa  "
                f"lid {1000 * rows[-1][2]:+.1f} mm  wall {time.time() - wall0:.0f} s, "
                f"ETA {(time.time() - wall_shear0) * (travel - shift) / max(shift, 1e-12):.0f} s")
        escaped += remove_escaped(O, grains, L + push_room(speed, O.time - t_shear), W, 2 * r)
        if escaped > MAX_ESCAPED * n_grains:
            raise RuntimeError(f"shear: {escaped} grains left the box through the frames' gap (the box leaks)")
        vmax = max(O.bodies[i].state.vel.norm() for i in grains[::7] if O.bodies[i])
        if vmax > 100 * speed + 1.0:
            raise RuntimeError(f"shear: a grain moves at {vmax:.2f} m/s (unstable)")
    d = np.array(rows)
    d[:, 3:5] = np.abs(d[:, 3:5])          # the contacts' sums, whichever body YADE books them on
    tail = d[int(0.8 * len(d)):]
    return {"bed": meta["key"], "soil": soil.name, "radius_m": r, "size_m": [L, W, D], "stress_kpa": stress_kpa,
            "remoulded": remoulded, "preload_kpa": preload_kpa,
            "tau_peak_kpa": float(d[:, 1].max() / 1e3), "tau_residual_kpa": float(tail[:, 1].mean() / 1e3),
            "tau_plane_peak_kpa": float(d[:, 3].max() / 1e3), "tau_plane_residual_kpa": float(tail[:, 3].mean() / 1e3),
            "sigma_plane_mean_kpa": float(d[:, 4].mean() / 1e3),
            "friction_plane_peak": float((d[:, 3] / np.maximum(d[:, 4], 1e-9)).max()),
            "shift_at_peak_mm": float(1000 * d[int(np.argmax(d[:, 1])), 0]),
            "lid_rise_mm": float(1000 * d[-1, 2]), "particles": len(grains), "escaped": escaped,
            "gap_mm": 1000 * gap, "steps": int(O.iter), "dt": O.dt,
            "wall_s": time.time() - wall0, "threads": threads,
            "curve": [[round(1000 * a, 3), round(b / 1e3, 3), round(1000 * c, 3), round(e / 1e3, 3), round(s / 1e3, 3)]
                      for a, b, c, e, s in d[::2]]}


def push_room(speed: float, t: float) -> float:
    """How far the upper frame has moved along x: the box's extent beyond L."""
    return speed * max(0.0, t)


def remove_escaped(O, grains: list, x_hi: float, W: float, margin: float) -> int:
    """Erase the grains that have left the box (squeezed out through the gap between the frames, then falling
    outside it) and return how many: a grain outside [−margin, x_hi + margin] × [−margin, W + margin] or below the
    floor."""
    gone = []
    for i in grains:
        b = O.bodies[i]
        if b is None:
            continue
        x, y, z = b.state.pos
        if x < -margin or x > x_hi + margin or y < -margin or y > W + margin or z < -margin:
            gone.append(i)
    for i in gone:
        O.bodies.erase(i)
    return len(gone)


def across_plane(O, n_grains: int, plane: float) -> float:
    """The x- and z-forces the grains below the shear plane pass to those above it through their contacts (N):
    what the sample itself carries at the plane, shear and normal."""
    total = normal = 0.0
    for i in O.interactions:
        if not i.isReal or i.id1 >= n_grains or i.id2 >= n_grains:
            continue
        z1, z2 = O.bodies[i.id1].state.pos[2], O.bodies[i.id2].state.pos[2]
        if (z1 - plane) * (z2 - plane) < 0:
            f = i.phys.normalForce + i.phys.shearForce
            sign = 1.0 if z2 > plane else -1.0     # booked on the upper body of the pair
            total += sign * f[0]
            normal += sign * f[2]
    return total, normal


def arguments():
    """The shear box's command line: the bed's options and the box's, each number checked against its Field."""
    from scripts import beds as bed
    p = bed.bed_arguments(__doc__.splitlines()[0], "150,150,100", "holes shear")
    p.add_argument("--stress", type=option("--stress", STRESS, many=True), default=[50.0, 100.0, 200.0],
                   help="normal stresses, kPa (one sample each; default 50,100,200)")
    p.add_argument("--speed", type=option("--speed", SPEED), default=0.05, help="shearing speed, m/s (default 0.05)")
    p.add_argument("--remoulded", action="store_true",
                   help="every contact of the sample a new one, bonded only as the load presses it (a remoulded sample)")
    p.add_argument("--preload", type=option("--preload", STRESS),
                   help="kPa: each sample first consolidated under this load, then eased to its normal stress before "
                        "shearing (above every --stress)")
    bed.add_test_set(p)
    p.add_argument("--out", type=folder("--out"), help="where the result goes (default results/soils/shear)")
    return p


def main(argv=None) -> int:
    from scripts import beds as bed
    a = arguments().parse_args(argv)
    stresses = a.stress
    try:
        test = bed.test_overrides(a)
        if a.preload is not None and a.preload <= max(stresses):
            raise ConfigError(f"--preload = {a.preload:g} kPa: allowed above the highest --stress ({max(stresses):g} "
                              "kPa), the load the sample is eased to")
        bed_path = bed.bed_from_args(a)
        out = Path(a.out) if a.out else ROOT / "results/soils/shear"
        settings = settings_digest(test, a)
        parts = [out / f"{bed_path.stem}-{s:g}-{settings}.part.json" for s in stresses]
        rows = kept_each(parts, lambda i: run(bed_path, a.soil, stresses[i], a.speed, a.threads, test,   # resumable
                                              remoulded=a.remoulded, preload_kpa=a.preload))
    except (ConfigError, ValueError) as e:
        print(f"shear: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"shear stopped: {e}", file=sys.stderr)
        return 3
    from analysis.soil.shear import fit_tests
    fit = fit_tests(rows)
    name = (f"{rows[0]['bed']}-{'_'.join(f'{s:g}' for s in stresses)}{'-remoulded' if a.remoulded else ''}"
            f"{f'-pre{a.preload:g}' if a.preload else ''}")
    summary = {"bed": rows[0]["bed"], "soil": rows[0]["soil"], "radius_mm": 1000 * rows[0]["radius_m"],
               **({"remoulded": True} if a.remoulded else {}), **({"preload_kpa": a.preload} if a.preload else {}),
               "overrides": test, **fit, "tests": rows}
    atomic_write(out / f"{name}.json", json.dumps(summary, indent=1))
    for part in parts:
        part.unlink(missing_ok=True)
    print(json.dumps({k: v for k, v in summary.items() if k != "tests"}))
    return 0


def settings_digest(test: dict, a) -> str:
    """What a sample's test is run with besides its bed and normal stress (the soil's contact law with the test's
    overrides, the speed, remoulded, the preload) and the code that runs it (SCENE_SOURCES), hashed: a kept test is
    reused only by a run asking for the same of the same code."""
    import dataclasses
    from analysis.core.soil_config import load_soil, soil_with
    return digest({"soil": dataclasses.asdict(soil_with(load_soil(a.soil), test)), "speed": a.speed,
                   "remoulded": a.remoulded, "preload": a.preload,
                   "code": [p.read_text() for p in SCENE_SOURCES]})


if __name__ == "__main__":
    sys.exit(main())
