"""Holes of known size carved in settled beds, the ground truth the metrology is judged on (mm; no YADE).

A carved hole is a void over a floor: at (x, y) every point more than `floor(x, y)` below the bed's undisturbed
level is empty (floor -inf: nothing carved there). Three shapes, each with a pressed ring h1 deep round it:
- `cylinder`: the punch's 50 mm section straight down, then tapering to nothing, the sleeve's 80 mm ring round it;
- `mouth`: a 90 x 50 mm stadium (the opening the rolling punch leaves) in a 20 mm ring;
- `basin`: the mouth in a 140 x 80 mm basin the plate pressed, whose floor ramps down into the hole ahead of it
  (+x, the travel): 12 mm over the 30 mm before the hole's front, across the hole's width.
The plate's ring and basin are pressed: the grains over them move down by the floor's depth, so the pressed
surface keeps the roughness of the undisturbed one. The hole is then cut two ways: `touch`, every grain that
reaches into it removed (the wall stands at or behind the cut), and `centre`, every grain whose centre is in it
removed (wall grains stand up to a radius into the hole). The truth is read off the void itself on a 0.25 mm
grid, by the same four-line rule as the caliper (caliper.read_opening), so a miss is the grains' and the
instrument's, not the rule's.
"""
from __future__ import annotations

import numpy as np

from analysis.holes.caliper import SECTIONS

SHAPES = ("cylinder", "mouth", "basin")
CARVINGS = ("touch", "centre")
D, W, MOUTH, STRAIGHT, TAPER, H1 = 50.0, 50.0, 90.0, 45.0, 25.0, 13.0
RAMP_LENGTH, RAMP_DROP = 30.0, 12.0
BASIN = (140.0, 80.0)


def stadium_scale(x, y, length: float, width: float):
    """The smallest s in (0, 1] for which (x, y) lies in the stadium scaled by s about the origin; inf outside
    the unscaled one (bisection, 40 halvings)."""
    def inside(s):
        half_straight = s * (length - width) / 2
        return np.hypot(np.maximum(np.abs(x) - half_straight, 0.0), y) <= s * width / 2
    lo, hi = np.zeros_like(x, float), np.ones_like(x, float)
    for _ in range(40):
        mid = (lo + hi) / 2
        ok = inside(mid)
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
    return np.where(inside(np.ones_like(x, float)), hi, np.inf)


def hole_floor(shape: str, x, y):
    """Depth below the undisturbed level of the hole's floor at (x, y) from its axis: the wall straight down
    from the pressed ring, then the taper; -inf outside the hole."""
    s = stadium_scale(x, y, D if shape == "cylinder" else MOUTH, W)
    return np.where(np.isfinite(s), H1 + STRAIGHT + TAPER * (1 - s), -np.inf)


def ring_floor(shape: str, x, y):
    """Depth of the surface the plate pressed at (x, y) from the hole's axis: h1 over the ring (and the hole's
    footprint), the basin's ramp ahead of the hole; -inf where the plate did not press."""
    if shape == "cylinder":
        ring = np.hypot(x, y) <= 40.0
    elif shape == "mouth":
        ring = np.hypot(np.maximum(np.abs(x) - (MOUTH - W) / 2, 0.0), y) <= W / 2 + 20.0
    else:
        ring = (np.abs(x - 15.0) <= BASIN[0] / 2) & (np.abs(y) <= BASIN[1] / 2)
    f = np.where(ring, H1, -np.inf)
    if shape == "basin":
        on_ramp = (x >= (MOUTH - W) / 2) & (x <= MOUTH / 2 + RAMP_LENGTH) & (np.abs(y) <= W / 2)
        ramp = H1 + RAMP_DROP * np.clip((MOUTH / 2 + RAMP_LENGTH - x) / RAMP_LENGTH, 0.0, 1.0)
        f = np.where(on_ramp, np.maximum(f, ramp), f)
    return f


def floor(shape: str, x, y, xc: float = 0.0, yc: float = 0.0):
    """Depth of the void below the undisturbed level at (x, y): the pressed surface, the hole below it."""
    x, y = np.asarray(x, float) - xc, np.asarray(y, float) - yc
    return np.maximum(hole_floor(shape, x, y), ring_floor(shape, x, y))


def carve(pos, rad, shape: str, carving: str, xc: float, yc: float, z_ref: float):
    """The grains after pressing and carving `shape` at (xc, yc) below level z_ref: every grain over the pressed
    ring or basin moved down by its floor's depth there (the surface keeps its grain-scale roughness, as a plate
    leaves it), then the hole cut out of them `carving`'s way (module doc)."""
    x, y = pos[:, 0] - xc, pos[:, 1] - yc
    press = ring_floor(shape, x, y)
    pos = pos.copy()
    pos[:, 2] -= np.where(np.isfinite(press), press, 0.0)
    depth = z_ref - pos[:, 2]                           # of each centre below the level
    gone = np.zeros(len(pos), bool)
    near = np.flatnonzero((np.abs(x) <= MOUTH / 2 + rad) & (np.abs(y) <= W / 2 + rad))   # only these can go
    xn, yn, dn, rn = x[near], y[near], depth[near], rad[near]
    if carving == "centre":
        gone[near] = dn < hole_floor(shape, xn, yn)
    else:      # a grain reaches the void if some point of it is above the floor there: sampled on rings
        hit = dn - rn < hole_floor(shape, xn, yn)
        for frac in (0.35, 0.7, 1.0):
            rho = frac * rn
            lift = np.sqrt(rn ** 2 - rho ** 2)
            for a in np.linspace(0, 2 * np.pi, 16, endpoint=False):
                hit |= dn - lift < hole_floor(shape, xn + rho * np.cos(a), yn + rho * np.sin(a))
        gone[near] = hit
    return pos[~gone], rad[~gone]


def truth(shape: str, below: float = 0.0, diameter_min: float = 2 ** 0.5 * 25.0, step: float = 0.25) -> dict:
    """The carved hole's dimensions (mm): L0, L1 by the four-line rule on the void `below` mm under the
    subsided level (which is h1 down), L2 from that level and from the surface, h1, the split of L0 ahead of
    and behind the axis."""
    g = np.arange(-120.0, 120.0 + step / 2, step)
    void_at = lambda x, y: floor(shape, x, y, 0.0, 0.0) > H1 + below     # noqa: E731

    def run(xs, ys, along):
        inside = void_at(xs, ys)
        coord = xs if along == 0 else ys
        start = int(np.argmin(np.abs(coord)))
        if not inside[start]:
            return 0.0, 0.0
        lo = hi = start
        while lo > 0 and inside[lo - 1]:
            lo -= 1
        while hi < len(g) - 1 and inside[hi + 1]:
            hi += 1
        return coord[lo] - step / 2, coord[hi] + step / 2

    ya, yb = run(np.zeros_like(g), g, 1)
    along = [run(g, np.full_like(g, ya + f * (yb - ya)), 0) for f in SECTIONS]
    x_lo, x_hi = np.mean([a for a, _ in along]), np.mean([b for _, b in along])
    across = [run(np.full_like(g, x_lo + f * (x_hi - x_lo)), g, 1) for f in SECTIONS]
    L2 = STRAIGHT + TAPER * (1 - diameter_min / W)
    return {"L0": float(np.mean([b - a for a, b in along])), "L1": float(np.mean([b - a for a, b in across])),
            "ahead": float(x_hi), "behind": float(-x_lo), "h1": H1, "L2": L2, "L2_surface": L2 + H1}
