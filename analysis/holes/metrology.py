"""Measuring holes from particles (seed 001 §4.2), without YADE: height maps of the bed's top surface.

A height map cell holds the highest grain top (z + r) over the grains whose centres fall in it; cells with no
grain are NaN. The undisturbed surface level is the median cell top of the strip's untouched margins.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from analysis.holes.caliper import JAW, LEVEL_BELOW, Jaw, near_hole, read_opening


def height_map(pos, radius, cell: float, x_range, y_range):
    """Top surface z(x, y) on a grid of square cells of side `cell`: returns (x centres, y centres, z[ix, iy])."""
    pos, radius = np.asarray(pos, float), np.asarray(radius, float)
    xe = np.arange(x_range[0], x_range[1] + cell / 2, cell)
    ye = np.arange(y_range[0], y_range[1] + cell / 2, cell)
    ix = np.clip(np.searchsorted(xe, pos[:, 0]) - 1, 0, len(xe) - 2)
    iy = np.clip(np.searchsorted(ye, pos[:, 1]) - 1, 0, len(ye) - 2)
    inside = (pos[:, 0] >= xe[0]) & (pos[:, 0] <= xe[-1]) & (pos[:, 1] >= ye[0]) & (pos[:, 1] <= ye[-1])
    top = np.full((len(xe) - 1, len(ye) - 1), -np.inf)
    np.maximum.at(top, (ix[inside], iy[inside]), pos[inside, 2] + radius[inside])
    top[~np.isfinite(top)] = np.nan
    return (xe[:-1] + xe[1:]) / 2, (ye[:-1] + ye[1:]) / 2, top


def surface_level(pos, radius, cell: float) -> float:
    """Median cell top over the whole bed, with cells along the walls left out."""
    pos = np.asarray(pos, float)
    lo, hi = pos[:, :2].min(axis=0), pos[:, :2].max(axis=0)
    _, _, top = height_map(pos, radius, cell, (lo[0] + cell, hi[0] - cell), (lo[1] + cell, hi[1] - cell))
    return float(np.nanmedian(top))


def centreline_profile(pos, radius, y_centre: float, half_band: float, cell: float, x_range):
    """Top surface along the travel over the band |y - y_centre| <= half_band: (x centres, z top)."""
    x, _, top = height_map(pos, radius, cell, x_range, (y_centre - half_band, y_centre + half_band))
    return x, np.nanmax(np.where(np.isnan(top), -np.inf, top), axis=1)


def deficit_centres(pos, initial_pos, radius, y_centre: float, half_band: float, cell: float, expected_x,
                    window: float):
    """Centre of each hole along the travel: the centroid of the surface's fall (initial top - final top,
    positive part) along the centreline band, within ±window of the expected centre."""
    x_range = (float(np.min(initial_pos[:, 0])), float(np.max(initial_pos[:, 0])))
    x, top1 = centreline_profile(pos, radius, y_centre, half_band, cell, x_range)
    _, top0 = centreline_profile(initial_pos, radius, y_centre, half_band, cell, x_range)
    fall = np.clip(np.nan_to_num(top0 - top1, nan=0.0, posinf=0.0, neginf=0.0), 0.0, None)
    out = []
    for xc in expected_x:
        w = np.where(np.abs(x - xc) <= window, fall, 0.0)
        out.append(float(np.sum(w * x) / np.sum(w)) if w.sum() > 0 else np.nan)
    return np.array(out)


# --- the hole measures of seed 001 §4.2, on a probed surface -----------------------------------------------
# Lengths in mm from here on. One surface serves every measure: the height S(x, y) at which the bottom of a
# probe ball, lowered straight down at (x, y), first touches a grain (the way a caliper jaw or the pot meets
# the soil). The probe bridges the gaps between grains, so S is a surface at the grains' scale whatever
# their size; its resolution is the grid step across and about the probe radius in height.

DEPTHS = tuple(range(5, 65, 5))      # mm below the undisturbed surface: Table 1's l_5 ... l_60


def probed_surface(pos, radius, xs, ys, probe: float):
    """S[ix, iy] = max_i z_i + sqrt((r_i + p)² - d_i²) - p over the grains within r_i + p of (x, y), where
    d_i is the horizontal distance to grain i's centre and p the probe radius; NaN where no grain is under
    the probe. `xs`, `ys`: evenly spaced grid lines."""
    pos, radius = np.asarray(pos, float), np.asarray(radius, float)
    step = xs[1] - xs[0]
    reach = radius + probe
    n = int(np.ceil(reach.max() / step))
    ix0 = np.rint((pos[:, 0] - xs[0]) / step).astype(int)
    iy0 = np.rint((pos[:, 1] - ys[0]) / step).astype(int)
    top = np.full((len(xs), len(ys)), -np.inf)
    for di in range(-n, n + 1):
        for dj in range(-n, n + 1):
            ix, iy = ix0 + di, iy0 + dj
            ok = (ix >= 0) & (ix < len(xs)) & (iy >= 0) & (iy < len(ys))
            h2 = np.full(len(pos), -1.0)
            h2[ok] = reach[ok] ** 2 - (xs[ix[ok]] - pos[ok, 0]) ** 2 - (ys[iy[ok]] - pos[ok, 1]) ** 2
            ok &= h2 > 0
            np.maximum.at(top, (ix[ok], iy[ok]), pos[ok, 2] + np.sqrt(h2[ok]) - probe)
    top[~np.isfinite(top)] = np.nan
    return top


def grow(mask, seed):
    """The 4-connected part of boolean grid `mask` that holds cell `seed` (empty if the seed is not in it)."""
    labels, _ = ndimage.label(mask)
    return (labels == labels[seed]) & mask if mask[seed] else np.zeros_like(mask)


def inscribed_diameter(mask, step: float, probe: float) -> float:
    """Diameter of the widest circle inside the region that the probe's centre reaches (`mask`): twice the
    largest distance from a reached cell to an unreached one (less half a cell), plus the probe's diameter."""
    if not mask.any():
        return 0.0
    if mask.all():
        return np.inf
    reach = ndimage.distance_transform_edt(mask).max()
    return float(2 * (reach * step - step / 2 + probe))


def h1_band(D: float, sleeve_outer: float) -> tuple[float, float]:
    """The distances from a hole's axis, across the travel, between which h1 is read (measure_hole): the inner
    half of the ring the sleeve's plate presses, from the punch's wall D/2 to (D/2 + sleeve_outer/2)/2."""
    return D / 2, (D + sleeve_outer) / 4


@dataclass
class HoleMeasure:
    """One hole, measured as in seed 001 §4.2 (mm). z_open: the level of the opening (subsided surface)."""
    x: float            # centre along the travel: the centroid of the hole's section at its effective depth L2
    h1: float           # subsidence of the pressed ring beside the hole
    L0: float           # opening length along the travel, mean of 4 caliper readings (caliper.py)
    L1: float           # opening width across the travel, mean of 4 caliper readings
    L2: float           # effective depth: opening level down to where the inner diameter falls to √2·a2
    bottom: float       # deepest probed point of the hole below the undisturbed surface
    z_open: float
    l_depth: tuple = ()  # length along the travel at each of DEPTHS below the undisturbed surface (Table 1's l_H)
    found: bool = True   # False: the opening's centre and its deepest point are both more than D/2 from where
                         # the punch entered
    x0: float = np.nan   # where the caliper's jaws are put in: the centroid of the hole's section at L2 (x0 = x),
    y0: float = np.nan   # or its deepest probed point when no opening is found
    ahead: float = np.nan   # L0's part ahead of x0 (+x, the travel) and behind it
    behind: float = np.nan


def subsided_level(S, xs, ys, z_surface: float, xc: float, yc: float, D: float, sleeve_outer: float) -> float:
    """h1, the subsidence round a hole: z_surface minus the median probed surface on the inner half of the ring
    the sleeve's plate pressed beside it across the travel, |x - xc| <= D/4 and D/2 <= |y - yc| <= (D/2 +
    sleeve_outer/2)/2 (h1_band). Not ahead of or behind the hole, where the plate's basin ramps into it, and not
    the ring's outer half, where the rim heaved round the plate overhangs the probed surface (results/rings)."""
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    lo, hi = h1_band(D, sleeve_outer)
    side = (np.abs(X - xc) <= D / 4) & (np.abs(Y - yc) >= lo) & (np.abs(Y - yc) <= hi)
    return z_surface - float(np.nanmedian(S[side]))


def measure_hole(S, xs, ys, z_surface: float, xc: float, yc: float, D: float, sleeve_outer: float,
                 probe: float, diameter_min: float, grains, dz: float = 1.0,
                 jaw: Jaw = JAW, below: float = LEVEL_BELOW) -> HoleMeasure:
    """Measure the hole nearest (xc, yc) on the probed surface S of the grains `grains` = (pos, radius) (§4.2).

    h1: subsided_level. The opening: the cells the probe reaches more than one probe radius (the grain-scale
    roughness) below the subsided level z_open = z_surface - h1, grown from the deepest cell within D/2 of
    (xc, yc); it finds the hole, it does not size it. L0, L1: the caliper (caliper.read_opening) with `jaw`
    centred `below` mm under z_open, put in at the centroid of the hole's section at L2 (its axis, robust to
    where its floor happens to be deepest). L2: scanning down from z_open in steps dz, the
    region the probe reaches below z (grown from that deepest cell) until its inscribed diameter is no more than
    `diameter_min`, interpolated between steps. An opening whose centroid and deepest point both lie more than
    D/2 from (xc, yc) is not this punch's hole (e.g. the hole is buried and the region found is a trough beside
    it): the hole is reported not found, with L0, L1, L2 and l_H NaN, so it fails every criterion and no mean
    takes a number that does not describe it. An opening smeared along the travel whose bottom is where the
    punch went down is the punch's hole, wherever its centroid lies.

    The hole's centre x (for the spacing C, §4.2's "centre distance of adjacent holes") is the centroid of its
    section at the effective depth L2, where the seedling's root ball sits, so C is the plant spacing. The
    opening's centroid is not: a wall the disk drags up on one side moves it a punch radius or more."""
    step = xs[1] - xs[0]
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    h1 = subsided_level(S, xs, ys, z_surface, xc, yc, D, sleeve_outer)
    z_open = z_surface - h1
    near = np.hypot(X - xc, Y - yc) <= D / 2
    Sn = np.where(near & np.isfinite(S), S, np.inf)
    seed = np.unravel_index(np.argmin(Sn), S.shape)
    below_ = np.where(np.isfinite(S), S, -np.inf)
    opening = grow(below_ < z_open - probe, seed)
    x0, y0 = float(X[seed]), float(Y[seed])
    if not opening.any():
        return HoleMeasure(xc, h1, 0.0, 0.0, 0.0, z_surface - float(S[seed]), z_open, x0=x0, y0=y0)
    x_open, y_open = float(X[opening].mean()), float(Y[opening].mean())       # the opening's centroid
    deepest = np.unravel_index(np.argmin(np.where(opening, S, np.inf)), S.shape)
    if min(np.hypot(x_open - xc, y_open - yc), np.hypot(X[deepest] - xc, Y[deepest] - yc)) > D / 2:
        return HoleMeasure(xc, h1, np.nan, np.nan, np.nan, z_surface - float(S[seed]), z_open,
                           (np.nan,) * len(DEPTHS), found=False, x0=x0, y0=y0)
    prev_z, prev_d = z_open, inscribed_diameter(opening, step, probe)
    z = z_open
    L2 = z_open - float(S[seed])
    while z > S[seed]:
        z -= dz
        d = inscribed_diameter(grow(below_ < z, seed), step, probe)
        if d <= diameter_min:
            frac = (prev_d - diameter_min) / (prev_d - d) if np.isfinite(prev_d) and prev_d > d else 1.0
            L2 = z_open - (prev_z - frac * dz)
            break
        prev_z, prev_d = z, d
    section = grow(below_ <= z_open - L2, seed)                        # holds the seed: L2 <= z_open - S[seed]
    x0, y0 = float(X[section].mean()), float(Y[section].mean())
    reading = caliper_reading(grains, x0, y0, z_open, jaw, below, probe, D)
    return HoleMeasure(x0, h1, reading.L0, reading.L1, L2, z_surface - float(S[seed]), z_open,
                       tuple(length_at_depth(below_, seed, z_surface - H, step, probe) for H in DEPTHS),
                       x0=x0, y0=y0, ahead=reading.ahead, behind=reading.behind)


def caliper_reading(grains, x0: float, y0: float, z_open: float, jaw: Jaw, below: float, probe: float,
                    D: float):
    """The caliper's reading (caliper.read_opening) of the hole whose jaws go in at (x0, y0), `below` mm
    under the subsided level z_open, with `jaw` sized for grains of radius `probe`."""
    pos, rad = grains
    width, height = jaw.size(probe)
    z = z_open - below
    near_pos, near_rad = near_hole(pos, rad, x0, y0, z - height / 2 - 2 * probe)
    return read_opening(near_pos, near_rad, x0, y0, z, width, height, D / 4)


def side_profile(S, xs, ys, z_surface: float, xc: float, yc: float, D: float, r_max: float, dr: float = 2.0):
    """Depth below the undisturbed surface beside a hole against the distance from its axis across the travel,
    on each side: the median of S over the cells within D/4 of xc along the travel (the strip h1 is read in,
    measure_hole) in bins dr wide from D/2 to r_max. Returns (bin centres, depth[side, bin]), sides -y, +y."""
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    along = np.abs(X - xc) <= D / 4
    edges = np.arange(D / 2, r_max + dr / 2, dr)
    depth = np.full((2, len(edges) - 1), np.nan)
    for k, side in enumerate((-1, 1)):
        r = side * (Y - yc)
        for j, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
            cells = S[along & (r >= lo) & (r < hi)]
            if np.isfinite(cells).any():
                depth[k, j] = z_surface - float(np.nanmedian(cells))
    return (edges[:-1] + edges[1:]) / 2, depth


def chord(mask_line, step: float) -> float:
    """A chord on one grid line of a region: from its first cell to its last."""
    idx = np.flatnonzero(mask_line)
    return float((idx[-1] - idx[0] + 1) * step) if len(idx) else 0.0


def length_at_depth(below, seed, z: float, step: float, probe: float) -> float:
    """The hole's length along the travel at level z (Table 1's l_H): the caliper chord along x through the
    middle of the region the probe reaches below z (grown from the hole's deepest cell), plus the probe's
    diameter; 0 below the hole's bottom."""
    region = grow(below < z, seed)
    if not region.any():
        return 0.0
    iy = np.nonzero(region)[1]
    return chord(region[:, int(round((iy.min() + iy.max()) / 2))], step) + 2 * probe


def measure_state(pos_mm, radius_mm, initial_pos_mm, initial_radius_mm, width: float, hole_x, D: float,
                  sleeve_outer: float, diameter_min: float, cell: float = 1.0, probe: float | None = None,
                  band: tuple | None = None, **caliper):
    """Every hole of a strip (positions in mm, strip 0 <= y <= width, holes expected at `hole_x` on its
    centreline): a list of HoleMeasure and the undisturbed surface level (the median probed surface of the
    bed before the disk, walls' cells left out, and only within `band` = (y_lo, y_hi) if given: a graded bed's
    fine zone); `caliper`: measure_hole's jaw and level. The probe defaults to the mean grain radius; spacing C
    is the difference of consecutive centres (measure_hole: each at the hole's effective depth)."""
    probe = float(np.mean(radius_mm)) if probe is None else probe
    x_lo, x_hi = float(np.min(initial_pos_mm[:, 0])), float(np.max(initial_pos_mm[:, 0]))
    xs = np.arange(x_lo, x_hi + cell / 2, cell)
    ys = np.arange(0.0, width + cell / 2, cell)
    margin = 2 * probe
    y_lo, y_hi = band or (0.0, width)
    inner = np.ix_((xs > x_lo + margin) & (xs < x_hi - margin), (ys > y_lo + margin) & (ys < y_hi - margin))
    z_surface = float(np.nanmedian(probed_surface(initial_pos_mm, initial_radius_mm, xs, ys, probe)[inner]))
    S = probed_surface(pos_mm, radius_mm, xs, ys, probe)
    grains = (np.asarray(pos_mm, float), np.asarray(radius_mm, float))
    return [measure_hole(S, xs, ys, z_surface, xc, width / 2, D, sleeve_outer, probe, diameter_min, grains,
                         **caliper) for xc in hole_x], z_surface, (xs, ys, S)
