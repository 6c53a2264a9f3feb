"""Scene parts the YADE scenes share (scripts/disk_parts.py, scripts/duckbeak.py, scripts/peer.py): the bed in a
started scene, a faceted punch, tools, the stability guard, the run folder and its final grains. Each scene
assembles its own from these; no scene imports another scene.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

from analysis.core.schema import ROOT
from analysis.core.io import atomic_write, provenance
from analysis.core.kinematics import blunt_tip

SEGMENTS = 16               # facets round a punch or a sleeve
GUARD_EVERY = 200           # steps between stability checks
GRAIN_MASK, TOOL_MASK, TOOL_SELF = 0b011, 0b110, 0b100   # grains meet grains, walls (mask 1) and tools (bit 2);
# tools meet grains only: bodies with the same mask sharing a bit with the collider's avoidSelfInteractionMask never meet
GUARD_SPEED = 20.0          # a grain faster than this × the tip speed is a blow-up
ESCAPE, ESCAPE_ABOVE = 0.02, 0.3   # m: a grain this far past the walls or floor, or above the surface, has left
PARKED_MASK = 0             # a splashed grain taken out of the scene (guard): it meets nothing
PARKED_DEPTH = 0.1          # m under the floor, where a parked grain is kept (no surface probe or column reaches it)
SPLASH_LIMIT = 20           # grains a scene may lose to splashes before the guard calls it a fault


def punch_surface(u_top: float, u_tip: float, radius: float, h: float, a: float):
    """Triangles of a cylinder-and-cone punch along its axis u (v, w across it), in mm: the cylinder of
    `radius` from u_top to the cone's base at u_tip - h, the cone to the apex u_tip, cut where the inscribed
    tip sphere of radius `a` (centre u_sphere) takes over. Returns (triangles, (u_sphere, a))."""
    _, u_sphere, u_cut = blunt_tip(radius, h, u_tip, a)
    r_cut = radius * (u_tip - u_cut) / h
    top, edge, cut = circle(u_top, radius), circle(u_tip - h, radius), circle(u_cut, r_cut)
    tris = band(top, edge) + band(edge, cut) + [(cut[i], cut[(i + 1) % SEGMENTS], (u_cut, 0.0, 0.0))
                                                for i in range(SEGMENTS)]
    return tris, (u_sphere, a)


def circle(u: float, r: float) -> list:
    """SEGMENTS points of the circle of radius r round the axis at u."""
    return [(u, r * math.cos(2 * math.pi * i / SEGMENTS), r * math.sin(2 * math.pi * i / SEGMENTS))
            for i in range(SEGMENTS)]


def band(lo: list, hi: list) -> list:
    """Triangles joining two circles."""
    tris = []
    for i in range(SEGMENTS):
        j = (i + 1) % SEGMENTS
        tris += [(lo[i], lo[j], hi[j]), (lo[i], hi[j], hi[i])]
    return tris


def open_run_folder(out_root: Path | None, params: dict, threads: int) -> Path:
    """results/runs/<id>/ with the run's config.json (its parameters and, under "provenance", where it was made:
    analysis/core/io.py provenance), and no summary.json until the run has finished."""
    out = (out_root or ROOT / "results/runs") / params["id"]
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").unlink(missing_ok=True)
    params = {k: v for k, v in params.items() if k != "provenance"}       # a config.json read back (benchmarks)
    atomic_write(out / "config.json", json.dumps({**params, "provenance": provenance(threads)}, indent=1))
    return out


def start_scene(soil, bed_path: Path, meta: dict, threads: int, wall_above: float, tool_box=None,
                density_scale: float = 1.0, tilled: dict | None = None, seed: int = 0):
    """YADE started on `threads` with the bed part of a scene: the settled grains of bed_path (scripts/beds.py)
    in the soil's cohesive material (mask GRAIN_MASK), a steel material for tools and walls, and the
    container's walls `wall_above` m over the bed's top. A laterally periodic bed becomes a strip periodic
    across the travel: a YADE cell periodic in y with the bed's width W, and in x longer than everything the
    tools sweep (`tool_box` = (x_min, x_max, top over the surface) in m), so nothing meets its image along the
    travel; end walls touch the bed's first and last grains. `density_scale` multiplies the grains' density
    (density scaling: the scene divides gravity by it, so they weigh what they did). `tilled` ({"depth_mm",
    "density"}) loosens the top layer (analysis/core/bed_spec.py tilled_keep, drawn with `seed`); the surface
    level is the bed's as levelled. Returns (the bed's arrays, grain ids, steel material id, the bed's surface
    level z (m), the bed's mass (kg))."""
    import numpy as np
    from scripts.yadeboot import boot
    boot(threads)
    from yade import O, utils
    from scripts import soil as part
    from analysis.holes.metrology import surface_level
    from scripts.beds import bed_resolution
    O.reset()
    data = dict(np.load(bed_path))
    L, W, _ = meta["size_m"]
    res, on = bed_resolution(meta), slice(None)
    if res.graded:                          # a graded bed's level is its fine zone's, where the holes are
        y_lo, y_hi = res.fine_band(W)
        on = (data["pos"][:, 1] >= y_lo) & (data["pos"][:, 1] <= y_hi)
    z_surface = surface_level(data["pos"][on], data["radius"][on], 4 * meta["radius"])
    if tilled:
        from analysis.core.bed_spec import tilled_keep
        keep = tilled_keep(data["pos"][:, 2], z_surface, tilled["depth_mm"] * 1e-3, tilled["density"], seed)
        data = {**data, "pos": data["pos"][keep], "radius": data["radius"][keep]}
    mat = O.materials.append(part.soil_material(soil, density=meta["grain_density"] * density_scale, cohesive=True))
    steel = O.materials.append(part.steel_material(soil))
    grain_ids = O.bodies.append([utils.sphere(tuple(p), r, material=mat, mask=GRAIN_MASK)
                                 for p, r in zip(data["pos"], data["radius"])])
    bed_mass = sum(O.bodies[i].state.mass for i in grain_ids)
    if meta.get("lateral", "walls") == "periodic":
        x_min, x_max, top = tool_box
        x_lo, x_hi = float(np.min(data["pos"][:, 0] - data["radius"])), float(np.max(data["pos"][:, 0] + data["radius"]))
        cell_x = max(L, x_hi, x_max) - min(0.0, x_lo, x_min) + part.CELL_MARGIN
        part.periodic_cell(O, cell_x, W, z_surface + max(wall_above, top))
        O.bodies.append(part.container(L, W, 0.0, steel, lateral="periodic"))        # the floor's tiles
        O.bodies.append(part.end_walls(x_lo, x_hi, W, z_surface + wall_above, steel))
    else:
        O.bodies.append(part.container(L, W, z_surface + wall_above, steel))
    return data, grain_ids, steel, z_surface, bed_mass


def save_state(out: Path, grain_ids, z_surface: float, data, header: str, rows):
    """The run's final grains (state.npz: positions, radii, the bed's level and initial positions, which
    analysis/ reads without YADE) and its time series (timeseries.csv), each written atomically. In a periodic
    strip, y is wrapped into the cell."""
    import numpy as np
    from yade import O
    pos = np.array([tuple(O.bodies[i].state.pos) for i in grain_ids])
    if O.periodic:
        pos[:, 1] %= O.cell.size[1]
    rad = np.array([O.bodies[i].shape.radius for i in grain_ids])
    tmp = out / f".state.{os.getpid()}.tmp.npz"
    np.savez_compressed(tmp, pos=pos, radius=rad, z_surface=z_surface, initial_pos=data["pos"])
    tmp.replace(out / "state.npz")
    atomic_write(out / "timeseries.csv", header + "\n" + "".join(",".join(f"{x:.6g}" for x in r) + "\n" for r in rows))


def as_tool(ids: list) -> list:
    """Make bodies parts of a tool: they meet grains only, never each other or the walls (collider's
    avoid_self_mask), and carry no local damping (YADE books it even for bodies that engines move)."""
    from yade import O
    for i in ids:
        O.bodies[i].mask = TOOL_MASK
        O.bodies[i].state.isDamped = False
    return ids


def park(b, L: float, W: float):
    """Take a splashed grain out of the scene: held still PARKED_DEPTH under the floor of the L × W bed, below
    where it left, meeting nothing (it stays among the grains the run saves, so their order holds)."""
    from yade import Vector3
    p = b.state.pos
    b.state.vel, b.state.angVel = Vector3(0, 0, 0), Vector3(0, 0, 0)
    b.state.pos = Vector3(min(max(p[0], 0.0), L), min(max(p[1], 0.0), W), -PARKED_DEPTH)
    b.dynamic, b.mask = False, PARKED_MASK


def contacts_of(i: int) -> tuple[int, int, int]:
    """What grain `i` touches: (tool bodies, grains, grains it is bonded to). A grain that leaves the box touching
    nothing was flung; one still on a tool, or bonded to a clod, was carried."""
    from yade import O
    tools = grains = bonded = 0
    for I in O.interactions.withBody(i):
        if not I.isReal:
            continue
        other = O.bodies[I.id2 if I.id1 == i else I.id1]
        if other.mask & TOOL_SELF:
            tools += 1
        elif other.mask & GRAIN_MASK == GRAIN_MASK:
            grains += 1
            bonded += not getattr(I.phys, "cohesionBroken", True) and getattr(I.phys, "normalAdhesion", 0.0) > 0
    return tools, grains, bonded


def guard(grain_ids, meta: dict, z_surface: float, speed_limit: float, ke_limit: float, splashes: list | None = None) -> float:
    """The stability guard: raises RuntimeError naming the cause on a non-finite grain, a grain out of the
    bed's box (ESCAPE m beyond its walls and floor (a periodic strip's y: anywhere), ESCAPE_ABOVE m over its
    surface), a grain faster than
    `speed_limit` (m/s) or kinetic energy above `ke_limit` (J); else returns the fastest grain's speed.
    With `splashes` (a list the scene keeps): a grain out of the box that touches nothing and is slower than the
    limit was splashed out by a tool, not blown up: it is parked (`park`), noted in `splashes` and the scene goes
    on, up to SPLASH_LIMIT of them."""
    from yade import O, utils
    L, W, _ = meta["size_m"]
    (x0, x1), (y0, y1), (z0, z1) = (-ESCAPE, L + ESCAPE), (-ESCAPE, W + ESCAPE), (-ESCAPE, z_surface + ESCAPE_ABOVE)
    if O.periodic:                                      # across the travel a grain re-enters at the other side
        y0, y1 = -math.inf, math.inf
    vmax, worst = 0.0, None
    for i in grain_ids:
        b = O.bodies[i]
        if b.mask == PARKED_MASK:
            continue
        p, vel = b.state.pos, b.state.vel.norm()
        if not (math.isfinite(p[0]) and math.isfinite(p[1]) and math.isfinite(p[2]) and math.isfinite(vel)):
            raise RuntimeError(f"grain {i} has a non-finite position or velocity at t = {O.time:.4f} s")
        if not (x0 < p[0] < x1 and y0 < p[1] < y1 and z0 < p[2] < z1):
            tools, grains, bonded = contacts_of(i)
            where = (f"grain {i} left the box at ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) m, t = {O.time:.4f} s, at "
                     f"{vel:.2f} m/s, touching {tools} tool bodies and {grains} grains ({bonded} bonded)")
            if splashes is None or vel > speed_limit or tools or grains:
                raise RuntimeError(where)
            if len(splashes) >= SPLASH_LIMIT:
                raise RuntimeError(f"{where}: more than {SPLASH_LIMIT} grains splashed out of the box")
            splashes.append({"grain": i, "t_s": O.time, "pos_m": [p[0], p[1], p[2]], "speed_m_s": vel})
            park(b, L, W)
            continue
        if vel > vmax:
            vmax, worst = vel, i
    if vmax > speed_limit:
        raise RuntimeError(f"grain {worst} moves at {vmax:.2f} m/s, > {speed_limit:.2f} m/s ({GUARD_SPEED:g} × the "
                           f"tool's top speed), at t = {O.time:.4f} s (unstable)")
    ke = utils.kineticEnergy()
    if not math.isfinite(ke) or ke > ke_limit:
        raise RuntimeError(f"kinetic energy {ke:.3g} J exceeds the whole bed moving at the tool's top speed "
                           f"({ke_limit:.3g} J) at t = {O.time:.4f} s (energy blow-up)")
    return vmax
