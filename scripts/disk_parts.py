"""Parts of the disk scene (scripts/disk.py) and their assembly, `run`: the rolling six-punch disk with
spring-loaded press sleeves in a soil strip (seed 001 §1.2, §2, Fig. 2). scripts/disk.py is its command line;
the collider benchmark (scripts/collider_bench.py) runs segments of the same assembly.

- bed: a settled strip from the bed part (scripts/beds.py), long enough for `holes` consecutive holes
  (analysis/core/kinematics.py), cohesion on for existing and new contacts; walled, or (preset `lateral =
  "periodic"`) periodic across the travel, so its width is the spacing of a row of identical disks (the
  roller's, seed 001 §2.2) and no side wall stiffens the soil (the walls made the cone read 35 % high);
- `Tool`: N punches, each a facet cylinder (diameter D, from the mounting plate R0 to R - h) and a facet cone
  of height h closed by an inscribed steel sphere (the blunt tip the cone scene needed too: many facets meeting
  in one vertex give a grain there too many stiff contacts); on each punch a press sleeve, an annular facet plate;
- `Motion`: the axis advances at v and turns at ω = v / (R(1 - δ)) (eq 1), prescribed; or mode "free", where
  ω is integrated from the soil's torque on the punches (I_disk dω/dt = M_y) and slip comes out, and with a
  weight W the axis also sinks under W (the machine's own weight on the disk, §1.2: (W/g) dv_z/dt = F_z - W),
  so the penetration comes out too, down to the limit device's stop (`depth_stop`) if one is set; each
  sleeve's axial travel s is integrated from the soil's force on it, its return spring (preload +
  stiffness·s), viscous damping, gravity and the centrifugal pull, between its stop and `travel`;
- `Recorder`: punch and sleeve forces, sleeve travel and the disk's position, every RECORD_DT of simulated time;
- `AwakeWindow` (`awake` = [BEHIND, AHEAD] mm, optional): only the soil near the tools moves. Grains more than
  AHEAD ahead of the tools' reach sleep until the window comes, and those more than BEHIND behind it sleep once
  they are still (slower than RESTLESS × the tip speed): held fixed, they push on awake grains and are pushed
  on, but the contact loop skips sleeper against sleeper (`sleep_outside`). The window moves every WINDOW_STEP mm;
- the guard (scripts/parts.py): stops the run, naming the cause, on NaN, a grain faster than GUARD_SPEED × the
  tip speed, a grain outside the box, or kinetic energy above that of the whole bed moving at the tip speed;
- the checkpoint: every `checkpoint_every` s of wall time an unfinished run saves itself
  (checkpoint-<step>.yade.gz: YADE's whole scene, bonds included; checkpoint.json, written after it and naming
  it: the parts' states and the energy so far), so a run killed or cut off goes on from there when started
  again with the same parameters; it is removed when the run finishes.

Writes results/runs/<id>/: config.json, timeseries.csv, state.npz (final positions, radii), summary.json
(written last: a run without it did not finish), optional VTK.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path

from analysis.core.config import load_soil
from analysis.core.io import atomic_write, provenance
from analysis.core.kinematics import TIP_SPHERE_RATIO, formed_hole_x, inertial_number, slip_between_holes, wrapped
from analysis.core.run_spec import CHECKPOINT_EVERY
from scripts.parts import (GRAIN_MASK, GUARD_EVERY, GUARD_SPEED, TOOL_SELF, as_tool, band, circle, guard,
                           open_run_folder, punch_surface, save_state, start_scene)

SLEEVE_CLEARANCE = 1.0      # mm between the punch and the plate's bore
RECORD_DT = 5e-4            # s of simulated time between records
CHECKPOINT = "checkpoint.json"   # the run's state, naming the scene file it goes with
# contact detection: every grain's box keeps a 0.5 mm margin and the collider runs when one has moved past it. YADE's
# default (margin 0.5 r, cut to a tenth for grains at rest: targetInterv 100) ran it at every step of the default
# strip; this took 0.70 of that wall time there (`./holes bench collider`, results/bench/README.md)
COLLIDER = {"verletDist": 5e-4, "targetInterv": 0}
SLEEP_MASK = GRAIN_MASK | 0b1000   # a sleeping grain (awake window): meets awake grains, walls, tools; no other sleeper
# A sleeper also sits in a second subdomain (Body.subdomain 1), and YADE's per-body loops (Newton's integration, the
# force reset) run over the scene's subdomain only once its body lists are in use (BodyContainer.useRedirection): a
# sleeper is still in the collider and in every contact, but no longer visited at every step for nothing. The same
# grains bit for bit on one thread (tests/test_disk.py); HOLES_VISIT_SLEEPERS=1 visits them, for that test.
SKIP_SLEEPERS = not os.environ.get("HOLES_VISIT_SLEEPERS")
SLEEP_SUBDOMAIN = 1 if SKIP_SLEEPERS else 0
AVOID_SELF = TOOL_SELF | 0b1000    # the collider's avoidSelfInteractionMask: tool parts, and sleepers, meet no kin
WINDOW_STEP = 5.0           # mm of the axis's travel between moves of the awake window
RESTLESS = 0.02             # × the tip speed: a grain behind the window sleeps only when slower than this
MM = 1e-3
HOOK = "disk_hook"          # the per-step hook's name in YADE's global namespace (never an engine's label)


def punch_mesh(disk, sleeve, a: float):
    """Punch and plate triangles in the punch frame (u along the axis from the disk centre, v in the disk
    plane, w across it), in mm; the tip sphere (centre u, radius) closes the cone."""
    punch, sphere = punch_surface(disk.R0, disk.R, disk.d, disk.h, a)
    u_plate = disk.R - sleeve.rest_from_tip
    plate = band(circle(u_plate, disk.d + SLEEVE_CLEARANCE), circle(u_plate, sleeve.outer_diameter / 2))
    return punch, plate, sphere


def frame(phi):
    """Unit vectors of the punch axis (outward) and the in-plane normal for the angle φ from straight down."""
    from yade import Vector3
    return Vector3(math.sin(phi), 0, -math.cos(phi)), Vector3(math.cos(phi), 0, math.sin(phi))


class Tool:
    """The N punches and their press plates, placed for t = 0 round the axis at `axis0`: punch k at
    φ0 + k·pitch. `punch_ids[k]` ends with its tip sphere; `ids` are all of them, made tool bodies."""

    def __init__(self, disk, sleeve, lay, axis0, steel):
        from yade import O, Vector3, utils
        punch_tris, plate_tris, (u_sphere, self.r_sphere) = punch_mesh(disk, sleeve, TIP_SPHERE_RATIO * disk.d)

        def world(p, phi):
            ax, b = frame(phi)
            return axis0 + (ax * p[0] + b * p[1] + Vector3(0, 1, 0) * p[2]) * MM

        self.punch_ids, self.plate_ids = [], []
        for k in range(disk.N):
            phi = lay.phi0 + k * lay.pitch
            ids = [O.bodies.append(utils.facet([world(p, phi) for p in tri], material=steel)) for tri in punch_tris]
            ids.append(O.bodies.append(utils.sphere(world((u_sphere, 0, 0), phi), self.r_sphere * MM, fixed=True,
                                                    material=steel)))
            self.punch_ids.append(ids)
            self.plate_ids.append([O.bodies.append(utils.facet([world(p, phi) for p in tri], material=steel))
                                   for tri in plate_tris])
        self.ids = as_tool([i for ids in self.punch_ids + self.plate_ids for i in ids])


class Motion:
    """The disk's motion and its sleeves': YADE engines move the punches (advance + rotation + sinking) and each
    plate (the same + its slide along the punch); `step`, called every step before the engines act, integrates
    what is not prescribed (the sleeves; ω in free mode; the axis's sinking under a weight, down to the stop) and
    books the tools' work on the soil. `state` is what a checkpoint keeps."""

    def __init__(self, params: dict, disk, sleeve, lay, tool: Tool, axis0, g: float, floor_room: float):
        from yade import O, RotationEngine, TranslationEngine, Vector3, utils
        # what `step` uses every step, bound once (YADE is started by now)
        self._O, self._utils, self._Vector3 = O, utils, Vector3
        self._x_dir, self._y_dir, self._z_dir = Vector3(1, 0, 0), Vector3(0, 1, 0), Vector3(0, 0, 1)
        self.disk, self.sleeve, self.lay, self.tool, self.axis0, self.g = disk, sleeve, lay, tool, axis0, g
        self.v = lay.speed * MM
        self.free = params["mode"] == "free"
        self.weight = params.get("weight")
        self.inertia = params["disk_inertia"]
        self.floor_room = floor_room
        # the limit device (seed 001 §1.2): the axis sinks no lower than where the tips reach depth_stop
        self.z_stop = -(params["depth_stop_mm"] - disk.penetration) * MM if params.get("depth_stop_mm") else -math.inf
        self.t_load = lay.phi0 / lay.omega      # W grows from 0 while the first punch goes down: no drop onto one tip
        self.rot = RotationEngine(rotationAxis=(0, 1, 0), angularVelocity=lay.omega, rotateAroundZero=True,
                                  zeroPoint=axis0)
        advance = TranslationEngine(translationAxis=(1, 0, 0), velocity=self.v)
        self.slides = [TranslationEngine(translationAxis=(0, 0, 1), velocity=0.0) for _ in range(disk.N)]
        self.sink = TranslationEngine(translationAxis=(0, 0, 1), velocity=0.0)   # the axis's vertical motion
        punches = advance + self.rot + self.sink
        punches.ids, punches.label = [i for ids in tool.punch_ids for i in ids], "disk_motion"
        self.engines = [punches]
        for k in range(disk.N):
            e = advance + self.rot + self.sink + self.slides[k]
            e.ids, e.label = tool.plate_ids[k], f"plate_motion_{k}"
            self.engines.append(e)
        self.k_s, self.m_s = sleeve.stiffness * 1e3, sleeve.mass                      # N/m, kg
        self.c_s = 2 * sleeve.damping_ratio * math.sqrt(max(self.k_s, 1e-9) * self.m_s)
        self.u_plate0 = (disk.R - sleeve.rest_from_tip) * MM
        self.travel = sleeve.travel * MM
        self.sleeve_speed_limit = math.inf      # m/s: a plate faster than this stops the run (set by run())
        # the angles where a punch is in the soil or near it: its sleeve is integrated and it is recorded there
        self.window = (lay.phi_out - math.radians(15), lay.phi_in + math.radians(15))
        self.state = {"theta": 0.0, "omega": lay.omega, "s": [0.0] * disk.N, "sdot": [0.0] * disk.N,
                      "s_max": [0.0] * disk.N, "work_tool": 0.0, "z": 0.0, "vz": 0.0, "z_min": 0.0, "z_max": 0.0,
                      "on_stop_steps": 0}

    def rebind(self, engines):
        """After YADE loaded a saved scene: its engines, which the saved ones replaced."""
        motion = {e.label: e for e in engines}
        _, self.rot, self.sink = motion["disk_motion"].comb    # shared with the plates' engines, as they were saved
        self.slides = [motion[f"plate_motion_{k}"].comb[3] for k in range(self.disk.N)]

    def angle(self, k: int) -> float:
        """Punch k's angle from straight down now, in [-π, π) (φ falls as the disk turns): on every pass, so a
        punch's sleeve works and it is recorded on its second turn too."""
        return wrapped(self.lay.phi0 + k * self.lay.pitch - self.state["theta"])

    def step(self):
        """One step's integration; returns (t, the axis's position) at the step's start."""
        O, Vector3, utils = self._O, self._Vector3, self._utils
        st, sleeve = self.state, self.sleeve
        m_s, k_s, c_s, g = self.m_s, self.k_s, self.c_s, self.g
        dt, t = O.dt, O.time
        axis = self.axis0 + Vector3(self.v * t, 0, st["z"])
        self.rot.zeroPoint = axis
        slide_power = 0.0
        for k in range(self.disk.N):
            phi = self.angle(k)
            active = self.window[0] < phi < self.window[1]
            if not active and st["s"][k] == 0.0:
                continue
            ax, _ = frame(phi)
            f_axial = utils.sumForces(self.tool.plate_ids[k], ax)     # the soil's push on the plate along the punch
            s, sdot = st["s"][k], st["sdot"][k]
            rho = self.u_plate0 - s
            force = (-f_axial - (sleeve.preload + k_s * s) - c_s * sdot
                     + m_s * g * math.cos(phi) + m_s * st["omega"] ** 2 * rho)
            sdot += force / m_s * dt
            if s + sdot * dt < 0.0:
                sdot = -s / dt
            elif s + sdot * dt > self.travel:
                sdot = (self.travel - s) / dt
            if not abs(sdot) <= self.sleeve_speed_limit:      # NaN too
                raise RuntimeError(f"sleeve {k} moves at {sdot:.3g} m/s along its punch, > {self.sleeve_speed_limit:.2f} "
                                   f"m/s ({GUARD_SPEED:g} × the tool's top speed), at t = {t:.4f} s, under a soil force "
                                   f"of {f_axial:.3g} N: its integration is unstable (sleeve mass, stiffness or step)")
            st["s"][k] = min(max(s + sdot * dt, 0.0), self.travel)
            st["sdot"][k] = sdot if 0.0 < st["s"][k] < self.travel else 0.0
            st["s_max"][k] = max(st["s_max"][k], st["s"][k])
            self.slides[k].translationAxis = -ax
            self.slides[k].velocity = sdot
            slide_power += sdot * f_axial
        torque = utils.sumTorques(self.tool.ids, self._y_dir, axis)
        if self.free:                       # I dω/dt = M_y: the soil turns the disk
            st["omega"] += torque / self.inertia * dt
            self.rot.angularVelocity = st["omega"]
        # the tools' work on the soil at this step's velocities: P = -(F_x v + M_y ω [+ F_z v_z]) over every tool
        # body, + each plate's slide
        power = slide_power - self.v * utils.sumForces(self.tool.ids, self._x_dir) - st["omega"] * torque
        if self.weight:                     # (W/g) dv_z/dt = F_z - W(t): the soil carries the disk
            f_z = utils.sumForces(self.tool.ids, self._z_dir)
            st["vz"] += (f_z - self.weight * min(1.0, t / self.t_load)) * g / self.weight * dt
            if st["z"] + st["vz"] * dt < self.z_stop:       # on the stop: it takes what the soil does not carry
                st["vz"] = (self.z_stop - st["z"]) / dt
                st["on_stop_steps"] += 1
            self.sink.velocity = st["vz"]
            st["z"] += st["vz"] * dt
            st["z_min"], st["z_max"] = min(st["z_min"], st["z"]), max(st["z_max"], st["z"])
            power -= st["vz"] * f_z
        st["work_tool"] += power * dt
        st["theta"] += st["omega"] * dt
        return t, axis

    def check_floor(self, depth_mm: float):
        """A weight that sank the tips to the strip's floor stops the run: no hole from a bottomed-out disk."""
        from yade import O
        if self.weight and -self.state["z"] > self.floor_room:
            raise RuntimeError(f"the disk sank {-1000 * self.state['z']:.1f} mm under W = {self.weight:g} N at t = "
                               f"{O.time:.4f} s: its tips reach the strip's floor ({depth_mm:g} mm deep); a lighter W "
                               "or a deeper strip")

    def sink_summary(self, steps: int) -> dict | None:
        """How far below its prescribed height the axis went (mm; < 0: above it), with a weight."""
        if not self.weight:
            return None
        st = self.state
        return {"final": -1000 * st["z"], "max": -1000 * st["z_min"], "min": -1000 * st["z_max"],
                # the share of the steps the disk sat on the limit device (depth_stop)
                **({"on_stop_fraction": st["on_stop_steps"] / max(steps, 1)} if math.isfinite(self.z_stop) else {})}


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


class AwakeWindow:
    """Only the soil from `behind` mm behind to `ahead` mm ahead of the tools' reach moves (module doc); `move`
    shifts the window with the axis, and books the stored energy's jump as `window` in the energy balance (the
    bonds between sleepers are dropped; a woken grain's come back new)."""

    def __init__(self, awake, grain_ids, detector, law, motion: Motion, tip_speed: float):
        self.behind, self.ahead = awake
        self.grain_ids, self.detector, self.law, self.motion = grain_ids, detector, law, motion
        self.restless = RESTLESS * tip_speed
        disk, lay = motion.disk, motion.lay
        # the tools touch the soil within sqrt(R² - H²) of the axis (a punch's tip at the surface), widened by the
        # punch's radius
        self.reach_x = (math.sqrt(max(disk.R ** 2 - lay.H0 ** 2, 0.0)) + disk.d) * MM
        # the window's last position (m), its moves, their energy jumps (J) and wall time (s), the grain-steps
        # awake, and the fastest grain put to sleep behind and ahead of it (m/s)
        self.state = {"window_x": -math.inf, "moves": 0, "window_energy": 0.0, "window_s": 0.0, "awake_steps": 0.0,
                      "slept_vmax": 0.0, "front_vmax": 0.0}
        self.count_awake()

    def count_awake(self):
        """The grains awake now, from the masks (a resumed run's sleepers were saved with it)."""
        from yade import O
        self.n_awake = sum(1 for i in self.grain_ids if O.bodies[i].mask != SLEEP_MASK)
        for i in self.grain_ids:            # a saved scene's subdomains follow this process's SKIP_SLEEPERS
            O.bodies[i].subdomain = SLEEP_SUBDOMAIN if O.bodies[i].mask == SLEEP_MASK else 0
        refresh_body_lists()

    def due(self) -> bool:
        from yade import O
        return (self.motion.v * O.time + self.motion.axis0[0] - self.state["window_x"]) >= WINDOW_STEP * MM

    def move(self, elastic_now: float | None = None):
        """Wake the grains within the window round the axis, put to sleep those ahead of it and the settled ones
        behind it (sleep_outside); one step then makes the new contacts. `elastic_now`: the contacts' elastic energy
        (J) where YADE cannot be asked for it (a resumed run's first move, before any step)."""
        from yade import O
        st = self.state
        x, t0 = self.motion.axis0[0] + self.motion.v * O.time, time.time()
        e0 = self.law.elasticEnergy() if elastic_now is None else elastic_now
        woke, slept, lost, v_rear, v_front = sleep_outside(self.grain_ids, x - self.reach_x - self.behind * MM,
                                                           x + self.reach_x + self.ahead * MM, self.detector,
                                                           self.restless)
        self.n_awake += woke - slept
        st["slept_vmax"], st["front_vmax"] = max(st["slept_vmax"], v_rear), max(st["front_vmax"], v_front)
        st["window_x"] = x
        st["moves"] += 1
        O.run(1, True)
        st["window_energy"] += self.law.elasticEnergy() - e0 - lost
        st["awake_steps"] += self.n_awake
        st["window_s"] += time.time() - t0

    def summary(self, n_particles: int, steps: int) -> dict:
        st = self.state
        return {"behind_mm": self.behind, "ahead_mm": self.ahead,
                "awake_fraction": st["awake_steps"] / (n_particles * steps),
                "slept_vmax_m_s": st["slept_vmax"], "front_vmax_m_s": st["front_vmax"],
                "moves": int(st["moves"]), "move_wall_s": st["window_s"]}


def refresh_body_lists():
    """YADE rebuilds the body lists its per-body loops run over (SKIP_SLEEPERS) only after a body is inserted or
    erased: one empty body is, and goes again."""
    from yade import O, Body
    O.bodies.useRedirection = True
    O.bodies.erase(O.bodies.append(Body()))


def sleep_outside(grain_ids, x_rear: float, x_front: float, collider, restless: float):
    """The awake window [x_rear, x_front] (m) along the travel: a sleeping grain inside it wakes; a grain ahead
    of it, or behind it and slower than `restless` (m/s), sleeps: held still (not dynamic), mask SLEEP_MASK,
    so the collider pairs it with awake grains, walls and tools but never with another sleeper, and its
    contacts with sleepers are dropped. What a sleeper meets still pushes on it, and it on them, as a fixed
    grain would. Returns (woken, put to sleep, their kinetic energy lost (J), the fastest slept behind and
    ahead (m/s)). The collider then sorts again: a woken grain's pairs with sleepers are new."""
    from yade import O, Vector3
    woke = slept = 0
    lost = v_rear = v_front = 0.0
    for i in grain_ids:
        b = O.bodies[i]
        x = b.state.pos[0]
        if b.mask == SLEEP_MASK:
            if x_rear <= x <= x_front:
                b.dynamic, b.mask, b.subdomain = True, GRAIN_MASK, 0
                woke += 1
            continue
        if x_rear <= x <= x_front:
            continue
        speed, behind = b.state.vel.norm(), x < x_rear
        if behind and speed >= restless:
            continue
        if behind:
            v_rear = max(v_rear, speed)
        else:
            v_front = max(v_front, speed)
        w = b.state.angVel
        lost += 0.5 * b.state.mass * speed ** 2 + 0.5 * sum(b.state.inertia[j] * w[j] ** 2 for j in range(3))
        b.state.vel, b.state.angVel = Vector3(0, 0, 0), Vector3(0, 0, 0)
        b.dynamic, b.mask, b.subdomain = False, SLEEP_MASK, SLEEP_SUBDOMAIN
        slept += 1
        for I in O.interactions.withBodyAll(i):
            other = I.id2 if I.id1 == i else I.id1
            if O.bodies[other].mask == SLEEP_MASK:
                O.interactions.erase(I.id1, I.id2)
    if slept:       # erase only resets a pair to potential, which becomes real again while the bounds overlap: the
        O.interactions.eraseNonReal()   # pairs go, and the full sort below makes the potential ones it may again
    if woke or slept:
        refresh_body_lists()
        collider.doSort = True
        collider()
    return woke, slept, lost, v_rear, v_front


def energy_now(law, motion: Motion, window: AwakeWindow | None) -> dict:
    """What the soil holds and has lost so far, and the tools' work on it (J). YADE's gravWork is the
    potential energy gained; the law books friction and rolling/twisting slip, Newton's damping books
    nonviscDamp."""
    from yade import O, utils
    booked = dict(O.energy.items())
    return {"work_tool": motion.state["work_tool"], "kinetic": utils.kineticEnergy(), "elastic": law.elasticEnergy(),
            "potential": booked.get("gravWork", 0.0), **({"window": window.state["window_energy"]} if window else {}),
            **{k: v for k, v in booked.items() if k not in ("kinetic", "gravWork", "elastPotential")}}


def energy_balance(start: dict, end: dict) -> dict:
    """The tools' work on the soil beside what it went into, between two `energy_now` readings (J):
    work = Δkinetic + Δelastic + Δpotential + dissipated − window + residual (window: the awake window's jumps).
    The residual is what no term books: the elastic energy of cohesive bonds at the moment they break (YADE's
    CohFrictPhys law does not book it) and the time integration's error."""
    delta = {k: end[k] - start.get(k, 0.0) for k in end}
    stored = {f"d_{k}": delta.pop(k) for k in ("kinetic", "elastic", "potential")}
    work = delta.pop("work_tool")
    # the awake window: the stored energy's jumps at its moves (bonds between sleepers dropped, new ones made,
    # the kinetic energy of the grains put to sleep); no force did work on them
    window = delta.pop("window", None)
    residual = work - sum(stored.values()) - sum(delta.values()) + (window or 0.0)   # `delta`: the booked dissipation
    return {"work_tool": work, **stored, **({"window": window} if window is not None else {}),
            **{f"dissipated_{k}": v for k, v in delta.items()},
            "residual": residual, "residual_fraction": residual / work if work else float("nan")}


TOOL_GUARD_EVERY = 5 * GUARD_EVERY    # steps between checks of the tools' energy balance
TOOL_RESIDUAL_LIMIT = 0.5             # the residual may not pass this share of the tools' work (or of the scale)


def tool_guard(balance: dict, scale: float):
    """The guard on the tools, as `guard` is on the grains: the energy balance since the start (energy_balance)
    may leave unexplained at most TOOL_RESIDUAL_LIMIT of the tools' work, or of `scale` (J, the whole bed at the
    tool's top speed) while the work is still smaller. A finished strip leaves 2-3 %; an unstable sleeve or
    disk integration makes or eats energy no force booked, and the run stops naming it, before any result.

    >>> tool_guard({"work_tool": 400.0, "residual": 10.0}, 10.0)
    >>> tool_guard({"work_tool": -577906.0, "residual": -618000.0}, 10.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    RuntimeError: the tools' energy balance broke: work -5.78e+05 J, residual -6.18e+05 J (more than 50 % ...
    """
    work, residual = balance["work_tool"], balance["residual"]
    if not abs(residual) <= TOOL_RESIDUAL_LIMIT * max(abs(work), scale):
        raise RuntimeError(f"the tools' energy balance broke: work {work:.3g} J, residual {residual:.3g} J (more than "
                           f"{100 * TOOL_RESIDUAL_LIMIT:.0f} % of the work or of {scale:.3g} J): the tool integration is "
                           "unstable (sleeve mass, stiffness or step)")


def save_checkpoint(out: Path, state: dict):
    """YADE's scene, then the run's Python state naming it (the json replaced atomically, last), so the
    checkpoint.json on disk always names a whole scene file; then the older scene files go."""
    from yade import O
    scene = f"checkpoint-{O.iter}.yade.gz"
    tmp = out / f".tmp-{scene}"              # same ending: YADE picks the format by it
    O.save(str(tmp))
    tmp.replace(out / scene)
    atomic_write(out / CHECKPOINT, json.dumps({**state, "scene": scene}))
    for old in out.glob("checkpoint-*.yade.gz"):
        if old.name != scene:
            old.unlink()


def load_checkpoint(out: Path) -> dict:
    """The saved scene loaded into YADE, and the checkpoint's state; a checkpoint that does not match is an
    error naming the way out."""
    from yade import O
    ck = json.loads((out / CHECKPOINT).read_text())
    if "motion" not in ck:
        raise RuntimeError(f"{out / CHECKPOINT} was written by an older version of the disk scene; run again with "
                           "--rerun")
    O.load(str(out / ck["scene"]))
    if O.iter != ck["iter"]:
        raise RuntimeError(f"{out / ck['scene']} is at step {O.iter}, its checkpoint.json at {ck['iter']}; "
                           "run again with --rerun")
    return ck


def drop_checkpoint(out: Path):
    """The checkpoint's files, and any half-written scene file of a process killed while saving."""
    (out / CHECKPOINT).unlink(missing_ok=True)
    for old in [*out.glob("checkpoint-*.yade.gz"), *out.glob(".tmp-checkpoint-*")]:
        old.unlink()


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
                          overrides={k: params["soil"][k] for k in soil.settling_key()}, lateral=preset["lateral"])
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
        PyRunner(command=HOOK + "()", iterPeriod=1, label="hook"), *motion.engines], avoid_self_mask=AVOID_SELF,
        gravity=tuple(x / k_density for x in part.GRAVITY))
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
        energy0, vmax = ck["energy0"], ck["vmax"]
        resumed_at = [*ck.get("resumed_at", []), int(O.iter)]
        wall0, cpu0 = wall0 - ck["wall_s"], cpu0 - ck["cpu_s"]
        log(f"run {params['id']}: resumed at step {O.iter} of {n_steps} ({ck['wall_s']:.0f} s of wall time done)")
    detector = next(e for e in O.engines if e.label == "collider")
    for key, value in {**COLLIDER, **(collider or {})}.items():
        setattr(detector, key, value)
    tip_speed = motion.v + lay.omega * lay.tip_reach * MM
    motion.sleeve_speed_limit = GUARD_SPEED * tip_speed
    window = AwakeWindow(params["awake_mm"], grain_ids, detector, law, motion, tip_speed) \
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
        vmax = 0.0
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
        vmax = max(vmax, guard(grain_ids, meta, z_surface, GUARD_SPEED * tip_speed, 0.5 * bed_mass * tip_speed ** 2))
        if checkpoint_every and time.time() - last_save > checkpoint_every and O.iter < n_steps:
            save_checkpoint(out, {"motion": motion.state, "recorder": recorder.state,
                                  "window": window.state if window else None, "energy0": energy0, "vmax": vmax,
                                  "iter": O.iter, "resumed_at": resumed_at, "wall_s": time.time() - wall0,
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
               "vmax_m_s": vmax, "tip_speed_m_s": tip_speed, "tool_bodies": len(tool.ids), "energy_J": energy,
               "density_scale": k_density, "tilled": params.get("tilled"),
               "inertial_number": inertial_number(tip_speed, disk.D * MM, 2 * meta["radius"],
                                                  meta["grain_density"] * k_density, soil.cone_index),
               "awake": window.summary(n_particles, O.iter) if window else None}
    atomic_write(out / "summary.json", json.dumps(summary, indent=1))
    drop_checkpoint(out)
    return summary
