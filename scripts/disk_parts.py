"""Parts of the disk scene (scripts/disk.py) and their assembly, `run`: the rolling six-punch disk with
spring-loaded press sleeves in a soil strip (seed 001 §1.2, §2, Fig. 2). scripts/disk.py is its command line;
the collider benchmark (scripts/collider_bench.py) runs segments of the same assembly.

- bed: a settled strip from the bed part (scripts/beds.py), long enough for `holes` consecutive holes
  (analysis/core/kinematics.py), cohesion on for existing and new contacts; walled, or (preset `lateral =
  "periodic"`) periodic across the travel, so its width is the spacing of a row of identical disks (the
  roller's, seed 001 §2.2) and no side wall stiffens the soil (the walls made the cone read 35 % high);
- `Tool` and `Motion` (scripts/disk_tool.py): the punches with their press sleeves, the disk's prescribed or free
  motion and each sleeve's integration;
- `Recorder`: punch and sleeve forces, sleeve travel and the disk's position, every RECORD_DT of simulated time;
- `AwakeWindow` (scripts/awake.py, `awake` = [BEHIND, AHEAD] mm, optional): only the soil near the tools moves;
- the guard (scripts/parts.py): stops the run, naming the cause, on NaN, a grain faster than GUARD_SPEED × the
  tip speed, a grain outside the box, or kinetic energy above that of the whole bed moving at the tip speed;
  and the guard on the tools (analysis/core/energy.py): the energy balance no force explains stops the run;
- the checkpoint (scripts/checkpoint.py): a run killed or cut off goes on from its last checkpoint.

Writes results/runs/<id>/: config.json, timeseries.csv, state.npz (final positions, radii), summary.json
(written last: a run without it did not finish), optional VTK.
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path

from analysis.core.soil_config import load_soil
from analysis.core.io import atomic_write, provenance
from analysis.core.kinematics import formed_hole_x, inertial_number, slip_between_holes
from analysis.core.run_spec import CHECKPOINT_EVERY
from analysis.core.energy import energy_balance, tool_guard
from scripts.awake import SKIP_SLEEPERS, AwakeWindow  # noqa: F401  (SKIP_SLEEPERS: the benchmarks read it here)
from scripts.checkpoint import CHECKPOINT, drop_checkpoint, load_checkpoint, save_checkpoint
from scripts.disk_tool import Motion, Tool, frame
from scripts.parts import GUARD_EVERY, GUARD_SPEED, TOOL_SELF, guard, open_run_folder, save_state, start_scene

RECORD_DT = 5e-4            # s of simulated time between records
# contact detection: every grain's box keeps a 0.5 mm margin and the collider runs when one has moved past it. YADE's
# default (margin 0.5 r, cut to a tenth for grains at rest: targetInterv 100) ran it at every step of the default
# strip; this took 0.70 of that wall time there (`./holes bench collider`, results/bench/README.md)
COLLIDER = {"verletDist": 5e-4, "targetInterv": 0}
AVOID_SELF = TOOL_SELF | 0b1000    # the collider's avoidSelfInteractionMask: tool parts, and sleepers, meet no kin
MM = 1e-3
HOOK = "disk_hook"          # the per-step hook's name in YADE's global namespace (never an engine's label)


class Recorder:
    """Every RECORD_DT of simulated time, one row per punch near the soil: time, axis, rotation, the punch's
    angle, tip and forces, its sleeve's force and travel; and each punch's deepest tip."""

    HEADER = ("t_s,axis_x_m,axis_sink_m,theta_deg,omega_rad_s,punch,phi_deg,tip_x_m,tip_z_m,"
              "punch_fx_n,punch_fz_n,sleeve_force_n,sleeve_travel_m")

    def __init__(self, motion: Motion, z_surface: float):
        self.motion, self.z_surface = motion, z_surface
        self.state = {"tip_min": [math.inf] * motion.disk.N, "next_record": 0.0, "rows": []}

    def __call__(self, t, axis):
        st, m, tool = self.state, self.motion, self.motion.tool
        if t < st["next_record"]:
            return
        from yade import O, Vector3
        st["next_record"] += RECORD_DT
        for k in range(m.disk.N):
            phi = m.angle(k)
            if not m.window[0] < phi < m.window[1]:
                continue
            fp = sum((O.forces.f(i) for i in tool.punch_ids[k]), Vector3(0, 0, 0))
            fs = sum((O.forces.f(i) for i in tool.plate_ids[k]), Vector3(0, 0, 0))
            tip = O.bodies[tool.punch_ids[k][-1]].state.pos
            tip_z = tip[2] - tool.r_sphere * MM - self.z_surface
            st["tip_min"][k] = min(st["tip_min"][k], tip_z)
            ax, _ = frame(phi)
            st["rows"].append((t, axis[0], m.axis0[2] - axis[2], math.degrees(m.state["theta"]), m.state["omega"], k,
                               math.degrees(phi), tip[0], tip_z, fp[0], fp[2], -fs.dot(ax), m.state["s"][k]))


def energy_now(law, motion: Motion, window: AwakeWindow | None) -> dict:
    """What the soil holds and has lost so far, and the tools' work on it (J). YADE's gravWork is the
    potential energy gained; the law books friction and rolling/twisting slip, Newton's damping books
    nonviscDamp."""
    from yade import O, utils
    booked = dict(O.energy.items())
    return {"work_tool": motion.state["work_tool"], "kinetic": utils.kineticEnergy(), "elastic": law.elasticEnergy(),
            "potential": booked.get("gravWork", 0.0), **({"window": window.state["window_energy"]} if window else {}),
            **{k: v for k, v in booked.items() if k not in ("kinetic", "gravWork", "elastPotential")}}


TOOL_GUARD_EVERY = 5 * GUARD_EVERY    # steps between checks of the tools' energy balance


def run(params: dict, threads: int = 2, out_root: Path | None = None, bed_dir: Path | None = None,
        vtk: bool = False, quiet: bool = False, checkpoint_every: float = CHECKPOINT_EVERY,
        resume: bool = True, stop_at: int | None = None, collider: dict | None = None) -> dict:
    """The run (summary.json), going on from its checkpoint if it has one. `stop_at` (step) and `collider`
    (InsertionSortCollider attributes over COLLIDER's, set after any loading) are for benchmarks
    (scripts/collider_bench.py): a run stopped at `stop_at` before its end writes nothing more and returns that
    segment's cost and grains."""
    from scripts import beds
    from analysis.core.config import disk_from_dict, Sleeve
    from analysis.core.kinematics import Layout
    soil = load_soil(params["soil"]["name"])
    soil = dataclasses.replace(soil, **{k: params["soil"][k] for k in params["soil"] if k != "name"})
    disk = disk_from_dict({k: v for k, v in params["disk"].items() if k != "name"})
    sleeve = Sleeve(**params["sleeve"])
    lay = Layout(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in params["layout"].items()})
    preset = params["preset"]
    log = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    bed_path = beds.build(soil.name, preset["resolution"], params["bed_size_mm"], params["seed"], threads,
                          quiet=quiet, bed_dir=bed_dir or beds.BED_DIR,
                          overrides=params.get("bed_settled_as", {k: params["soil"][k] for k in soil.settling_key()}),
                          lateral=preset["lateral"])
    meta = beds.load_meta(bed_path)
    out = open_run_folder(out_root, params, threads)
    if not resume:
        drop_checkpoint(out)

    # the bed, with the container's walls tall enough that a flung grain falls back in
    wall0, cpu0 = time.time(), time.process_time()
    reach = disk.R * MM                     # m: the tools' reach from the axis, whichever way a punch points
    tool_box = (lay.x_axis0 * MM - reach, (lay.x_axis0 + lay.speed * lay.t_end) * MM + reach, lay.H0 * MM + reach)
    k_density = params.get("density_scale", 1.0)    # density scaling: grains k × heavier, gravity on them ÷ k
    data, grain_ids, steel, z_surface, bed_mass = start_scene(soil, bed_path, meta, threads, 0.2, tool_box,
                                                              density_scale=k_density, tilled=params.get("tilled"),
                                                              seed=params["seed"])
    from yade import O, PyRunner, Vector3, utils
    from scripts import soil as part
    n_particles = len(grain_ids)
    axis0 = Vector3(lay.x_axis0 * MM, meta["size_m"][1] / 2, z_surface + lay.H0 * MM)
    tool = Tool(disk, sleeve, lay, axis0, steel)
    floor_room = (preset["depth"] - disk.penetration) * MM - 2 * meta["radius"] if params.get("weight") else math.inf
    motion = Motion(params, disk, sleeve, lay, tool, axis0, -part.GRAVITY[2], floor_room)
    recorder = Recorder(motion, z_surface)

    failed = []

    def hook():
        """Per step: the motion's integration, then a record when one is due. A failure pauses YADE and is
        raised by the loop (YADE's PyRunner would print it at every step and go on without the motion)."""
        if failed:
            return
        try:
            recorder(*motion.step())
        except Exception as e:              # noqa: BLE001 - raised again, with its step, by hook_failed()
            failed.append(e)
            O.pause()

    def hook_failed():
        if failed:
            raise RuntimeError(f"the disk's per-step hook failed at step {O.iter}: {failed[0]!r}") from failed[0]

    O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True, extra=[
        PyRunner(command=HOOK + "()", iterPeriod=1, label="hook"), *motion.engines,
        *part.bond_rules(O, soil)], avoid_self_mask=AVOID_SELF,
        gravity=tuple(x / k_density for x in part.GRAVITY))
    part.hold_tool_friction(O, soil)
    import builtins
    # PyRunner evaluates its command in YADE's global namespace, where YADE also puts every engine by its label
    # (again when a saved scene is loaded): the command names no label, or a resumed run's PyRunner would call
    # itself
    setattr(builtins, HOOK, hook)
    O.dt = preset["dt_safety"] * utils.PWaveTimeStep()
    n_steps = int(lay.t_end / O.dt) + 1
    log(f"run {params['id']}: {n_particles} grains, bed {meta['key']}, {n_steps} steps of {O.dt:.2e} s, "
        f"{len(lay.hole_x)} holes at x = {', '.join(f'{x:.0f}' for x in lay.hole_x)} mm")
    O.trackEnergy = True
    law = part.contact_law(O)

    resumed = (out / CHECKPOINT).exists()
    if resumed:                             # go on from where an earlier process of this run stopped
        ck = load_checkpoint(out)
        next(e for e in O.engines if e.label == "hook").command = HOOK + "()"     # a scene saved before HOOK
        O.trackEnergy = True
        motion.rebind(O.engines)
        law = part.contact_law(O)
        motion.state.update(ck["motion"])
        recorder.state.update(ck["recorder"])
        energy0, vmax, splashes = ck["energy0"], ck["vmax"], ck.get("splashes", [])
        resumed_at = [*ck.get("resumed_at", []), int(O.iter)]
        wall0, cpu0 = wall0 - ck["wall_s"], cpu0 - ck["cpu_s"]
        log(f"run {params['id']}: resumed at step {O.iter} of {n_steps} ({ck['wall_s']:.0f} s of wall time done)")
    detector = next(e for e in O.engines if e.label == "collider")
    for key, value in {**COLLIDER, **(collider or {})}.items():
        setattr(detector, key, value)
    tip_speed = motion.v + lay.omega * lay.tip_reach * MM
    motion.sleeve_speed_limit = GUARD_SPEED * tip_speed
    intact = (soil.normal_cohesion, soil.shear_cohesion) if soil.new_contact_cohesion != 1.0 else None
    window = AwakeWindow(params["awake_mm"], grain_ids, detector, law, motion, tip_speed, intact) \
        if params.get("awake_mm") else None
    if resumed and window:
        if "elastic_J" not in ck:
            raise RuntimeError(f"{out / CHECKPOINT} has no elastic_J (saved before sleeping runs could resume); run "
                               "again with --rerun")
        window.state.update(ck["window"])
        # set where it stands now, before any step (every resume takes this path), from the stored energy saved
        # with the checkpoint: YADE's contact law knows its scene only once a step has run, and asking it crashes
        window.move(elastic_now=ck["elastic_J"])

    if not resumed:
        resumed_at = []
        O.run(1, True)                      # the bed's contacts exist from here on: the balance starts here
        part.bond_new_contacts(O, soil)
        hook_failed()
        energy0 = energy_now(law, motion, window)
        vmax, splashes = 0.0, []
        if window:
            window.move()
    n_end = min(n_steps, stop_at or n_steps)
    if n_end < n_steps:                     # a benchmark's segment: where its time goes, per engine
        O.timingEnabled = True
    exec0 = [e.execTime for e in O.engines]
    iter0, detections0, loop0 = O.iter, detector.numAction, time.time()
    last_save = time.time()
    report = max(GUARD_EVERY, (n_steps // 50) // GUARD_EVERY * GUARD_EVERY)
    while O.iter < n_end:
        if window and window.due() and O.iter < n_end - 1:
            window.move()
        chunk = min(GUARD_EVERY, n_end - O.iter)
        O.run(chunk, True)
        hook_failed()
        if window:
            window.state["awake_steps"] += window.n_awake * chunk
        vmax = max(vmax, guard(grain_ids, meta, z_surface, GUARD_SPEED * tip_speed, 0.5 * bed_mass * tip_speed ** 2,
                               splashes))
        if checkpoint_every and time.time() - last_save > checkpoint_every and O.iter < n_steps:
            save_checkpoint(out, {"motion": motion.state, "recorder": recorder.state,
                                  "window": window.state if window else None, "energy0": energy0, "vmax": vmax,
                                  "splashes": splashes, "iter": O.iter, "resumed_at": resumed_at, "wall_s": time.time() - wall0,
                                  "cpu_s": time.process_time() - cpu0,
                                  "elastic_J": law.elasticEnergy()})
            last_save = time.time()
        motion.check_floor(preset["depth"])
        if O.iter % TOOL_GUARD_EVERY < GUARD_EVERY:
            tool_guard(energy_balance(energy0, energy_now(law, motion, window)), 0.5 * bed_mass * tip_speed ** 2)
        if O.iter % report < GUARD_EVERY or O.iter >= n_end:
            done = O.iter / n_steps
            formed = sum(1 for k in range(len(lay.hole_x))
                         if lay.phi0 + k * lay.pitch - motion.state["theta"] < lay.phi_out)
            el = time.time() - wall0
            log(f"run: {100 * done:3.0f} %  travel {motion.v * O.time * 1000:5.0f}/{motion.v * lay.t_end * 1000:.0f} mm  "
                f"holes {formed}/{len(lay.hole_x)}  wall {el:.0f} s  ETA {el / max(done, 1e-9) * (1 - done):.0f} s"
                + (f"  ω {motion.state['omega']:.2f} rad/s" if motion.free else "")
                + (f"  awake {window.n_awake}/{n_particles}" if window else "")
                + (f"  sink {-1000 * motion.state['z']:.1f} mm" if motion.weight else ""))
    if O.iter < n_steps:                    # a benchmark's segment
        import numpy as np
        return {"steps": O.iter - iter0, "wall_s": time.time() - loop0, "detections": detector.numAction - detections0,
                "interactions": len(O.interactions), "contacts": O.interactions.countReal(), "particles": n_particles,
                "awake": window.n_awake if window else n_particles,
                "engine_s": {e.label or type(e).__name__: (e.execTime - t0) * 1e-9 for e, t0 in zip(O.engines, exec0)},
                "pos": np.array([tuple(O.bodies[i].state.pos) for i in grain_ids])}
    wall, cpu = time.time() - wall0, time.process_time() - cpu0
    energy = energy_balance(energy0, energy_now(law, motion, window))
    log(f"run: energy {energy}")
    save_state(out, grain_ids, z_surface, data, Recorder.HEADER, recorder.state["rows"])
    if vtk:
        from yade import export
        exp = export.VTKExporter(str(out / "vtk" / "scene"))
        (out / "vtk").mkdir(exist_ok=True)
        exp.exportSpheres(ids=list(grain_ids), what=dict(radius="b.shape.radius", disp="b.state.displ()"))
        exp.exportFacets(ids=[i for i in tool.ids if O.bodies[i].shape.__class__.__name__ == "Facet"])
    st = motion.state
    summary = {"id": params["id"], "provenance": provenance(threads), "soil": soil.name, "preset": preset["name"],
               "mode": params["mode"],
               # the steps this run was resumed at from a checkpoint: YADE rebuilds the collider on loading and
               # orders the contacts differently, so from there on the run is another realisation of the same
               # strip, not the uninterrupted run's bits (results/bench/README.md)
               "resumed_at_steps": resumed_at,
               "bed": meta["key"], "particles": n_particles, "steps": int(O.iter), "dt": O.dt, "wall_s": wall,
               "cpu_s": cpu, "threads": threads, "particle_steps_per_s": n_particles * O.iter / wall,
               "travel_mm": motion.v * O.time * 1000, "sim_time_s": O.time, "z_surface_m": z_surface,
               "holes": len(lay.hole_x), "lead_in": lay.lead_in, "hole_x_mm": list(lay.hole_x),
               "hole_x_formed_mm": formed_hole_x(*zip(*((r[0], r[5], r[7] / MM, r[8]) for r in recorder.state["rows"])),
                                                 gap=3 * RECORD_DT) if recorder.state["rows"] else [],
               "tip_min_depth_mm": [-1000 * z for z in recorder.state["tip_min"][:len(lay.hole_x)]],
               "sleeve_max_travel_mm": [1000 * s for s in st["s_max"][:len(lay.hole_x)]],
               "slip_out": 1 - motion.v / (st["theta"] / O.time * disk.R * MM) if O.time > 0 else None,
               "slip_holes": slip_between_holes([math.radians(r[3]) for r in recorder.state["rows"]],
                                                [r[1] / MM for r in recorder.state["rows"]],
                                                lay.phi0, lay.pitch, disk.R, len(lay.hole_x)),
               "axis_sink_mm": motion.sink_summary(O.iter),
               "vmax_m_s": vmax, "splashes": splashes, "tip_speed_m_s": tip_speed, "tool_bodies": len(tool.ids),
               "energy_J": energy,
               "density_scale": k_density, "tilled": params.get("tilled"),
               "inertial_number": inertial_number(tip_speed, disk.D * MM, 2 * meta["radius"],
                                                  meta["grain_density"] * k_density, soil.cone_index),
               "awake": window.summary(n_particles, O.iter) if window else None}
    atomic_write(out / "summary.json", json.dumps(summary, indent=1))
    drop_checkpoint(out)
    return summary
