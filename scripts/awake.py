"""Scene part: the awake window of the disk scene (scripts/disk_parts.py): only the soil near the tools moves.

Grains more than AHEAD ahead of the tools' reach sleep until the window comes, and those more than BEHIND behind it
sleep once they are still (slower than RESTLESS × the tip speed): held fixed, they push on awake grains and are
pushed on, but the contact loop skips sleeper against sleeper (`sleep_outside`). The window moves every
WINDOW_STEP mm.
"""
from __future__ import annotations

import math
import os
import time

from scripts.parts import GRAIN_MASK, PARKED_MASK

MM = 1e-3
SLEEP_MASK = GRAIN_MASK | 0b1000   # a sleeping grain (awake window): meets awake grains, walls, tools; no other sleeper
GRAIN_MASKS = (GRAIN_MASK, SLEEP_MASK)
# A sleeper also sits in a second subdomain (Body.subdomain 1), and YADE's per-body loops (Newton's integration, the
# force reset) run over the scene's subdomain only once its body lists are in use (BodyContainer.useRedirection): a
# sleeper is still in the collider and in every contact, but no longer visited at every step for nothing. The same
# grains bit for bit on one thread (tests/test_disk.py); HOLES_VISIT_SLEEPERS=1 visits them, for that test.
SKIP_SLEEPERS = not os.environ.get("HOLES_VISIT_SLEEPERS")
SLEEP_SUBDOMAIN = 1 if SKIP_SLEEPERS else 0
WINDOW_STEP = 5.0           # mm of the axis's travel between moves of the awake window
RESTLESS = 0.02             # × the tip speed: a grain behind the window sleeps only when slower than this


class AwakeWindow:
    """Only the soil from `behind` mm behind to `ahead` mm ahead of the tools' reach moves (module doc); `move`
    shifts the window with the axis, and books the stored energy's jump as `window` in the energy balance (the
    bonds between sleepers are dropped; a woken grain's come back new). `intact_bonds`: (normal, shear) cohesion,
    Pa, of the undisturbed soil's bonds when a contact made after disturbance gets less (the soil's
    new_contact_cohesion below 1): the contacts a woken grain makes are the undisturbed soil's and get them
    (`rebond`), not the disturbed soil's share."""

    def __init__(self, awake, grain_ids, detector, law, motion, tip_speed: float, intact_bonds=None):
        self.behind, self.ahead = awake
        self.grain_ids, self.detector, self.law, self.motion = grain_ids, detector, law, motion
        self.intact_bonds = intact_bonds
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
        self.n_awake = sum(1 for i in self.grain_ids if O.bodies[i].mask not in (SLEEP_MASK, PARKED_MASK))
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
        woken, slept, lost, v_rear, v_front = sleep_outside(self.grain_ids, x - self.reach_x - self.behind * MM,
                                                            x + self.reach_x + self.ahead * MM, self.detector,
                                                            self.restless)
        self.n_awake += len(woken) - slept
        st["slept_vmax"], st["front_vmax"] = max(st["slept_vmax"], v_rear), max(st["front_vmax"], v_front)
        st["window_x"] = x
        st["moves"] += 1
        O.run(1, True)
        if self.intact_bonds and woken:
            rebond(woken, self.intact_bonds)
        st["window_energy"] += self.law.elasticEnergy() - e0 - lost
        st["awake_steps"] += self.n_awake
        st["window_s"] += time.time() - t0

    def summary(self, n_particles: int, steps: int) -> dict:
        st = self.state
        return {"behind_mm": self.behind, "ahead_mm": self.ahead,
                "awake_fraction": st["awake_steps"] / (n_particles * steps),
                "slept_vmax_m_s": st["slept_vmax"], "front_vmax_m_s": st["front_vmax"],
                "moves": int(st["moves"]), "move_wall_s": st["window_s"]}


def rebond(woken, intact_bonds) -> int:
    """Give the grain-grain contacts the woken grains made in the step just run YADE's intact bond (CohFrictPhys:
    the cohesion times the smaller radius squared, as its Ip2 sets a bond); returns how many."""
    from yade import O
    normal, shear = intact_bonds
    made = O.iter - 1
    woken = set(woken)
    n = 0
    for i in woken:
        for I in O.interactions.withBody(i):
            other = I.id2 if I.id1 == i else I.id1
            if I.iterMadeReal != made or (other in woken and other < i) or O.bodies[other].mask not in GRAIN_MASKS:
                continue
            r2 = min(O.bodies[i].shape.radius, O.bodies[other].shape.radius) ** 2
            I.phys.normalAdhesion, I.phys.shearAdhesion, I.phys.cohesionBroken = normal * r2, shear * r2, False
            n += 1
    return n


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
    grain would. Returns (the woken grains' ids, how many put to sleep, their kinetic energy lost (J), the fastest
    slept behind and ahead (m/s)). The collider then sorts again: a woken grain's pairs with sleepers are new."""
    from yade import O, Vector3
    woken, slept = [], 0
    lost = v_rear = v_front = 0.0
    for i in grain_ids:
        b = O.bodies[i]
        if b.mask == PARKED_MASK:           # splashed out of the box (scripts/parts.py guard): never woken
            continue
        x = b.state.pos[0]
        if b.mask == SLEEP_MASK:
            if x_rear <= x <= x_front:
                b.dynamic, b.mask, b.subdomain = True, GRAIN_MASK, 0
                woken.append(i)
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
    if woken or slept:
        refresh_body_lists()
        collider.doSort = True
        collider()
    return woken, slept, lost, v_rear, v_front
