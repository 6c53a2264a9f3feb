"""Scene part: the disk's tool and its motion (scripts/disk_parts.py assembles them).

- `Tool`: N punches, each a facet cylinder (diameter D, from the mounting plate R0 to R - h) and a facet cone of
  height h closed by an inscribed steel sphere (the blunt tip: many facets meeting in one vertex give a grain there
  too many stiff contacts); on each punch a press sleeve, an annular facet plate;
- `Motion`: the axis advances at v and turns at ω = v / (R(1 - δ)) (eq 1), prescribed; or mode "free", where ω is
  integrated from the soil's torque on the punches (I_disk dω/dt = M_y) and slip comes out, and with a weight W
  the axis also sinks under W (§1.2: (W/g) dv_z/dt = F_z - W) down to the limit device's stop if one is set; each
  sleeve's axial travel s is integrated from the soil's force on it, its return spring (preload + stiffness·s),
  viscous damping, gravity and the centrifugal pull, between its stop and `travel`.
"""
from __future__ import annotations

import math

from analysis.core.kinematics import TIP_SPHERE_RATIO, wrapped
from scripts.parts import GUARD_SPEED, as_tool, band, circle, punch_surface

SLEEVE_CLEARANCE = 1.0      # mm between the punch and the plate's bore
MM = 1e-3


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
