"""The hole's opening read as §4.2's vernier caliper reads it, straight from the grains (mm; no grid, no YADE).

Seed 001 §4.2: the opening length L0 is the mean of 4 caliper readings along the travel, "均分4处" (4 lines
equally spaced across the opening), the upper width L1 the mean of 4 across it, both read at the subsided
level round the hole ("从下陷深度处测得"). A reading here is an inside caliper: two flat jaws, each a vertical
rectangle `width` wide (across its line) and `height` tall centred on the reading level, put into the hole at
its start point and opened along the line until each face meets a grain. The reading is the distance between
the two faces. A knife edge is the jaw of zero width and height.

The candidates (JAWS) were set against carved holes of known size at every grain radius a preset uses
(`./holes metrology-band`, results/comparison/metrology/) and the one of least bias and spread chosen by
`choose_jaw` before any run was measured again; the level below the subsided level is LEVEL_BELOW.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SECTIONS = (0.2, 0.4, 0.6, 0.8)       # §4.2's "均分4处": lines at 1/5 ... 4/5 of the opening the other way
LEVELS = (0.0, 5.0, 10.0, 20.0)       # mm below the subsided level: the level table (level_table)
REACH = 150.0                         # mm: a jaw that meets no grain this far from its start stops here


@dataclass(frozen=True)
class Jaw:
    """A caliper jaw: a flat face `width` wide across its line and `height` tall about the reading level (mm);
    `per_radius`: both given in grain radii instead (a jaw that scales with the grains)."""
    name: str
    width: float
    height: float
    per_radius: bool = False

    def size(self, r: float) -> tuple[float, float]:
        k = r if self.per_radius else 1.0
        return self.width * k, self.height * k


JAWS = (Jaw("knife", 0.0, 0.0), Jaw("jaw_2x10mm", 2.0, 10.0), Jaw("jaw_10x10mm", 10.0, 10.0),
        Jaw("jaw_1r", 1.0, 1.0, True), Jaw("jaw_2r", 2.0, 2.0, True))
LEVEL_CANDIDATES = (0.0, 2.0, 5.0)     # mm below the subsided level the jaws' centre may sit (choose_jaw)
JAW = JAWS[1]                          # the chosen jaw and level: choose_jaw on the carved holes
LEVEL_BELOW = 5.0


def gap(pos, rad, along: int, line: float, z: float, start: float, width: float, height: float,
        window: float) -> tuple[float, float]:
    """The free stretch a caliper's jaws open to on one line: along axis `along` (0: x, 1: y), at the other
    horizontal coordinate `line` and level z. A grain blocks the jaw face at position s along the line when
    its sphere reaches the face's rectangle; the free stretches are what no grain blocks. Returns the stretch
    that holds `start`, or, if a grain sits on `start`, the widest stretch overlapping start ± window (the
    jaws are put into the hole where they fit); (start, start) if none."""
    other = 1 - along
    dy = np.maximum(np.abs(pos[:, other] - line) - width / 2, 0.0)
    dz = np.maximum(np.abs(pos[:, 2] - z) - height / 2, 0.0)
    d2 = rad ** 2 - dy ** 2 - dz ** 2
    hit = d2 > 0
    half = np.sqrt(d2[hit])
    lo, hi = pos[hit, along] - half, pos[hit, along] + half
    keep = (hi > start - REACH) & (lo < start + REACH)
    merged = []                                        # the union of the blocked intervals
    for a, b in sorted(zip(lo[keep], hi[keep])):
        if merged and a <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    bounds = [start - REACH, *(v for m in merged for v in m), start + REACH]
    free = [(a, b) for a, b in zip(bounds[::2], bounds[1::2]) if b > a]
    for a, b in free:
        if a <= start <= b:
            return a, b
    near = [(b - a, a, b) for a, b in free if b >= start - window and a <= start + window]
    return (near and max(near)[1:]) or (start, start)


@dataclass
class Reading:
    """One hole's opening at one level (mm): L0, L1 (each the mean of 4 lines), the 4 lines' mean faces along
    the travel and across, so L0's split ahead (+x, the travel) and behind the point the jaws went in at."""
    L0: float
    L1: float
    x_lo: float
    x_hi: float
    y_lo: float
    y_hi: float
    ahead: float
    behind: float


def read_opening(pos, rad, x0: float, y0: float, z: float, width: float, height: float,
                 window: float) -> Reading:
    """§4.2's two readings at level z, the jaws put in at (x0, y0) (the hole's axis): a first line
    across through x0 finds the width the 4 lines along are spread over; the 4 lines along give L0 and the
    extent the 4 lines across are spread over; those give L1."""
    ya, yb = gap(pos, rad, 1, x0, z, y0, width, height, window)
    along = [gap(pos, rad, 0, ya + f * (yb - ya), z, x0, width, height, window) for f in SECTIONS]
    x_lo, x_hi = float(np.mean([a for a, _ in along])), float(np.mean([b for _, b in along]))
    across = [gap(pos, rad, 1, x_lo + f * (x_hi - x_lo), z, y0, width, height, window) for f in SECTIONS]
    return Reading(L0=float(np.mean([b - a for a, b in along])), L1=float(np.mean([b - a for a, b in across])),
                   x_lo=x_lo, x_hi=x_hi, y_lo=float(np.mean([a for a, _ in across])),
                   y_hi=float(np.mean([b for _, b in across])), ahead=x_hi - x0, behind=x0 - x_lo)


def near_hole(pos, rad, x0: float, y0: float, z_low: float):
    """The grains that can meet a jaw round a hole at (x0, y0) above z_low: a speed-up, not a choice."""
    keep = (np.abs(pos[:, 0] - x0) < REACH + 20) & (np.abs(pos[:, 1] - y0) < REACH + 20) & (pos[:, 2] + rad > z_low)
    return pos[keep], rad[keep]
