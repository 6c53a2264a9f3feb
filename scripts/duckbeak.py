"""Scene: the pepper transplanter's closed duck-beak planter through a ridge bed (seed 000).

    .venv/bin/python scripts/duckbeak.py            # or: ./holes duckbeak [--soil loam] [--set D=50 ...]

Parts:
- bed: a settled bed from the bed part (scripts/beds.py) (loam by default), its top standing for the ridge's flat crown,
  long enough for the planter's reach along the travel and `below` mm deeper than the tip goes;
- tool: the closed beak, a facet cone (base diameter D, length beak_length) closed by an inscribed steel
  sphere whose lowest point is the tip P, on a facet cylinder (the planter body, body_length), as
  the disk scene (scripts/disk_parts.py) builds a punch;
- kinematics: the planter rides on the body DM of the designed linkage (analysis/pepper/pepper.py: eqs 1-16 with
  the machine moving at v), so its tip follows P's moving trajectory and it turns with θ4; the text gives no
  angle between DM and the beak, so the beak points straight down at the lowest point (configs/pepper.toml
  [planter].attachment). Each step sets the planter's velocity and spin to reach the next exact pose;
- recorder: the soil's force on the planter and the tip's position, every RECORD_DT of simulated time.

The pass runs from the tip `clearance` above the surface going down to as high again going up; the planter
is then taken away and the soil settles until its fastest grain is slower than `settled_speed` (what the beak
flung has landed), for at most `relax` s. The stability guard (scripts/parts.py) watches it.
Writes results/runs/<id>/ (config.json, timeseries.csv, state.npz, summary.json last), measured by
analysis/holes/measure.py as a disk run is: one hole at the tip's lowest point; analysis/pepper/duckbeak_report.py copies
the hole's table and pictures to results/pepper/duckbeak/.
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import folder, option, CommandLine
from analysis.core.config import SEED, THREADS, load_resolution
from analysis.core.schema import ROOT, as_dict, check_table, digest, read_toml, ConfigError, Field
from analysis.core.soil_config import load_soil, parse_overrides
from analysis.core.bed_spec import BED_DIR  # noqa: E402
from analysis.core.io import atomic_write, provenance  # noqa: E402
from analysis.core.kinematics import TIP_SPHERE_RATIO  # noqa: E402

PLANTER_FIELDS = {"D": Field(20.0, 150.0, unit="mm", meaning="closed beak's base diameter"),
                  "beak_length": Field(20.0, 300.0, unit="mm", meaning="beak cone length"),
                  "body_length": Field(0.0, 300.0, unit="mm", meaning="planter body modelled above the beak"),
                  "attachment": Field(kind=str)}
SCENE_FIELDS = {"column": Field(kind=str), "soil": Field(kind=str), "resolution": Field(kind=str),
                "seed": SEED, "width": Field(40.0, 1000.0, unit="mm"),
                "below": Field(10.0, 300.0, unit="mm"), "margin": Field(0.0, 500.0, unit="mm"),
                "clearance": Field(1.0, 100.0, unit="mm"), "relax": Field(0.0, 2.0, unit="s"),
                "settled_speed": Field(0.001, 1.0, unit="m/s", meaning="fastest grain when the soil counts as settled"),
                "dt_safety": Field(0.05, 1.0, unit="", meaning="time step / critical time step")}
RECORD_DT = 5e-4            # s of simulated time between records
PASS_SAMPLES = 200          # poses sampled along the pass to size the bed


def plan(path="configs/pepper.toml", **changes) -> dict:
    """Every parameter of the scene, checked, before YADE starts: the linkage's pass through the soil and the
    bed it needs (mm, s). `changes` override [planter] and [soil_scene] keys."""
    import numpy as np
    from analysis.pepper import pepper
    from analysis.pepper.pepper_design import load_goals
    data = read_toml(path)
    planter = check_table(f"{path} [planter]", {**data["planter"], **{k: v for k, v in changes.items()
                                                                       if k in PLANTER_FIELDS}}, PLANTER_FIELDS)
    scene = check_table(f"{path} [soil_scene]", {**data["soil_scene"], **{k: v for k, v in changes.items()
                                                                          if k in SCENE_FIELDS}}, SCENE_FIELDS)
    unknown = sorted(set(changes) - set(PLANTER_FIELDS) - set(SCENE_FIELDS))
    if unknown:
        raise ConfigError(f"duckbeak: unknown option(s) {', '.join(unknown)}")
    if scene["width"] <= 2 * planter["D"]:
        raise ConfigError(f"soil_scene.width = {scene['width']:g} is out of range: allowed > 2 D = "
                          f"{2 * planter['D']:g} mm")
    soil = load_soil(scene["soil"])
    load_resolution(scene["resolution"])
    link = pepper.load_linkage(scene["column"], path)
    goals = load_goals(path)                     # the operation: v (mm/s) and the crank's rate ω (rad/s)
    speed, omega = goals.speed, goals.omega
    ps = pepper.planter_pass(link, speed, omega, scene["clearance"], sign=goals.sign)
    if ps.depth >= planter["beak_length"] + planter["body_length"]:
        raise ConfigError(f"planter: beak_length + body_length = "
                          f"{planter['beak_length'] + planter['body_length']:g} mm "
                          f"is out of range: allowed > the tip's depth {ps.depth:.1f} mm")
    t = np.linspace(ps.t_in, ps.t_out, PASS_SAMPLES)
    x, y, th4 = pepper.pose(link, speed, omega, t, ps.y_ground, goals.sign)
    psi = pepper.beak_axis(th4, ps.theta4_bottom)
    top = x - (planter["beak_length"] + planter["body_length"]) * np.cos(psi)
    reach = (min(x.min(), top.min()) - planter["D"] / 2, max(x.max(), top.max()) + planter["D"] / 2)
    length = 10 * math.ceil((reach[1] - reach[0] + 2 * scene["margin"]) / 10)
    depth = 10 * math.ceil((ps.depth + scene["below"]) / 10)
    a_tip = TIP_SPHERE_RATIO * planter["D"] / 2
    # the blunt tip: an inscribed sphere whose lowest point is P; the sharp cone's apex would lie `blunt` beyond it
    tip = {"sphere": a_tip, "blunt": a_tip / math.sin(math.atan2(planter["D"] / 2, planter["beak_length"])) - a_tip}
    params = {"scene": "duckbeak", "soil": as_dict(soil), "planter": planter, "soil_scene": scene, "tip": tip,
              "linkage": pepper.linkage_to_config(link),
              "speed_mm_s": speed, "omega_rad_s": omega, "travel_sign": goals.sign, "seed": scene["seed"],
              "pass": dataclasses.asdict(ps),
              "x_shift_mm": (length - (reach[1] - reach[0])) / 2 - reach[0],     # the reach centred in the bed
              "bed_size_mm": [length, scene["width"], depth]}
    params["id"] = f"duckbeak-{soil.name}-{scene['resolution']}-{digest(params)}"
    return params


def main_run(params: dict, threads: int = 2, out_root: Path | None = None, bed_dir: Path | None = None,
             quiet: bool = False) -> dict:
    from scripts import beds as bedmod
    from scripts.parts import (GUARD_EVERY, GUARD_SPEED, TOOL_SELF, as_tool, guard, open_run_folder, punch_surface,
                              save_state, start_scene)
    from analysis.pepper import pepper
    planter, scene, ps = params["planter"], params["soil_scene"], params["pass"]
    soil = load_soil(params["soil"]["name"])
    log = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    bed_path = bedmod.build(soil.name, scene["resolution"], params["bed_size_mm"], params["seed"], threads,
                            quiet=quiet, bed_dir=bed_dir or BED_DIR)
    meta = bedmod.load_meta(bed_path)
    out = open_run_folder(out_root, params, threads)

    wall0 = time.time()
    data, grain_ids, steel, z_surface, bed_mass = start_scene(soil, bed_path, meta, threads, 0.3)
    import numpy as np
    from yade import O, PyRunner, RotationEngine, TranslationEngine, Vector3, utils
    from scripts import soil as part
    W = meta["size_m"][1]

    mm = 1e-3
    link = pepper.linkage_from_config(params["linkage"])
    speed, omega = params["speed_mm_s"], params["omega_rad_s"]
    y_c = W / 2

    def target(t):
        """The planter's reference point (its tip sphere's centre, m) and its axis angle ψ at crank time t."""
        x, y, th4 = pepper.pose(link, speed, omega, [t], ps["y_ground"], params["travel_sign"])
        psi = float(pepper.beak_axis(th4[0], ps["theta4_bottom"]))
        e = Vector3(math.cos(psi), 0, math.sin(psi))
        tip = Vector3((float(x[0]) + params["x_shift_mm"]) * mm, y_c, z_surface + float(y[0]) * mm)
        return tip - e * (u_sphere * mm), psi

    a_tip, blunt = params["tip"]["sphere"], params["tip"]["blunt"]
    total = planter["beak_length"] + planter["body_length"]
    tris, (u_sphere, r_sphere) = punch_surface(-total, blunt, planter["D"] / 2, planter["beak_length"], a_tip)
    u_sphere = -u_sphere                      # from the tip P back to the sphere's centre (mm): a_tip
    c0, psi0 = target(ps["t_in"])
    e0, n0 = Vector3(math.cos(psi0), 0, math.sin(psi0)), Vector3(-math.sin(psi0), 0, math.cos(psi0))

    def world(p):
        return c0 + (e0 * (p[0] + u_sphere) + n0 * p[1] + Vector3(0, 1, 0) * p[2]) * mm

    tool_ids = as_tool([O.bodies.append(utils.facet([world(p) for p in tri], material=steel)) for tri in tris]
                       + [O.bodies.append(utils.sphere(c0, r_sphere * mm, fixed=True, material=steel))])
    ref = tool_ids[-1]
    move = TranslationEngine(translationAxis=(1, 0, 0), velocity=0.0)
    spin = RotationEngine(rotationAxis=(0, 1, 0), angularVelocity=0.0, rotateAroundZero=True, zeroPoint=c0)
    planter_engine = move + spin
    planter_engine.ids = tool_ids
    st = {"psi": psi0, "next_record": 0.0, "rows": [], "tip_min": math.inf, "on": True}

    def hook():
        """Per step: the velocity and spin that take the planter to its exact pose at the next step."""
        if not st["on"]:
            return
        t, dt = O.time, O.dt
        c_next, psi_next = target(ps["t_in"] + t + dt)
        c = O.bodies[ref].state.pos
        d = c_next - c
        move.translationAxis = d / d.norm() if d.norm() > 0 else Vector3(1, 0, 0)
        move.velocity = d.norm() / dt
        spin.zeroPoint = c
        spin.angularVelocity = -(psi_next - st["psi"]) / dt     # +ψ turns x towards z: about -y
        st["psi"] = psi_next
        if t >= st["next_record"]:
            st["next_record"] += RECORD_DT
            f = utils.sumForces(tool_ids, Vector3(1, 0, 0)), utils.sumForces(tool_ids, Vector3(0, 0, 1))
            tip_z = (c[2] - r_sphere * mm - z_surface)
            st["tip_min"] = min(st["tip_min"], tip_z)
            st["rows"].append((t, c[0], tip_z, math.degrees(st["psi"]), f[0], f[1]))

    O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True, extra=[
        PyRunner(command="duckbeak_hook()", iterPeriod=1, label="hook"), planter_engine,
        *part.bond_rules(O, soil)], avoid_self_mask=TOOL_SELF)
    part.hold_tool_friction(O, soil)
    import builtins
    builtins.duckbeak_hook = hook           # PyRunner evaluates its command in YADE's global namespace
    O.dt = scene["dt_safety"] * utils.PWaveTimeStep()
    t_pass = ps["t_out"] - ps["t_in"]
    n_pass, n_relax = int(t_pass / O.dt) + 1, int(scene["relax"] / O.dt)
    top_speed = float(np.max(np.abs(pepper.motion(link, omega * np.linspace(ps["t_in"], ps["t_out"], 50), omega)[1]
                                    + params["travel_sign"] * speed))) * mm      # P's fastest, ground frame (m/s)
    log(f"duckbeak {params['id']}: {len(grain_ids)} grains, bed {meta['key']}, pass {1000 * t_pass:.0f} ms "
        f"({n_pass} steps of {O.dt:.2e} s) + settling for up to {n_relax} steps; tip to {ps['depth']:.1f} mm")
    vmax, v_now, splashes = 0.0, math.inf, []
    while O.iter < n_pass or (O.iter < n_pass + n_relax and v_now > scene["settled_speed"]):
        if O.iter >= n_pass and st["on"]:
            st["on"] = False
            planter_engine.dead = True      # the planter has left the soil: take it away
            for i in tool_ids:
                O.bodies.erase(i)
        O.run(min(GUARD_EVERY, (n_pass if st["on"] else n_pass + n_relax) - O.iter), True)
        v_now = guard(grain_ids, meta, z_surface, GUARD_SPEED * top_speed, 0.5 * bed_mass * top_speed ** 2, splashes)
        vmax = max(vmax, v_now)
        log(f"duckbeak: t {1000 * O.time:5.1f} ms of {1000 * t_pass:.0f} + settling (fastest grain {v_now:.2f} m/s, "
            f"settled below {scene['settled_speed']:g})  wall {time.time() - wall0:.0f} s")
    settled = v_now <= scene["settled_speed"]
    wall = time.time() - wall0
    save_state(out, grain_ids, z_surface, data, "t_s,ref_x_m,tip_z_m,psi_deg,planter_fx_n,planter_fz_n", st["rows"])
    summary = {"id": params["id"], "provenance": provenance(threads), "scene": "duckbeak", "soil": soil.name,
               "preset": scene["resolution"],
               "bed": meta["key"], "particles": len(grain_ids), "steps": int(O.iter), "dt": O.dt, "wall_s": wall,
               "threads": threads, "particle_steps_per_s": len(grain_ids) * O.iter / wall, "sim_time_s": O.time,
               "z_surface_m": z_surface, "holes": 1, "lead_in": 0,
               "hole_x_mm": [ps["x_bottom"] + params["x_shift_mm"]], "tip_min_depth_mm": [-1000 * st["tip_min"]],
               "path_depth_mm": ps["depth"], "vmax_m_s": vmax, "splashes": splashes, "settled": settled, "v_end_m_s": v_now,
               "tool_top_speed_m_s": top_speed}
    atomic_write(out / "summary.json", json.dumps(summary, indent=1))
    return summary


def main(argv=None) -> int:
    p = CommandLine(prog="holes duckbeak", description=__doc__.splitlines()[0])
    p.add_argument("--config", default="configs/pepper.toml", help="the mechanism's config (default configs/pepper.toml)")
    p.add_argument("--soil", help="default: [soil_scene].soil")
    p.add_argument("--column", help="Table 2's column: initial | designed")
    p.add_argument("--resolution", help="grain sizes (default: [soil_scene].resolution)")
    p.add_argument("--set", action="append", metavar="KEY=NUMBER",
                   help="override a number of [planter] or [soil_scene], e.g. D=50, seed=2, relax=0.5")
    p.add_argument("--threads", type=option("--threads", THREADS), default=2, help="YADE threads (default 2)")
    p.add_argument("--out", type=folder("--out"), help="runs folder (default results/runs)")
    p.add_argument("--report", default=str(ROOT / "results/pepper/duckbeak"),
                   help="where the hole's table and pictures are copied (default results/pepper/duckbeak)")
    p.add_argument("--bed-dir", type=folder("--bed-dir"), default=str(BED_DIR),
                   help="where beds are kept (default results/cache/beds)")
    p.add_argument("--rerun", action="store_true", help="run again even if this run's folder has a summary")
    a = p.parse_args(argv)
    runs = Path(a.out) if a.out else ROOT / "results/runs"
    try:
        changes = {k: v for k, v in (("soil", a.soil), ("column", a.column), ("resolution", a.resolution))
                   if v is not None}
        params = plan(a.config, **changes, **parse_overrides(a.set))
        done = runs / params["id"] / "summary.json"
        if done.exists() and not a.rerun:
            print(f"duckbeak {params['id']}: finished earlier, reused (--rerun to run it again)", file=sys.stderr)
            summary = json.loads(done.read_text())
        else:
            summary = main_run(params, a.threads, runs, Path(a.bed_dir))
    except (ConfigError, ValueError) as e:
        print(f"duckbeak: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"duckbeak stopped: {e}", file=sys.stderr)
        return 3
    from analysis.pepper import duckbeak_report
    table = duckbeak_report.run(runs / summary["id"], Path(a.report))
    print(table.drop(columns=["run"]).round(1).to_string(index=False), file=sys.stderr)
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
