"""Measuring holes from particles (seed 001 §4.2), without YADE: height maps of the bed's top surface.

A height map cell holds the highest grain top (z + r) over the grains whose centres fall in it; cells with no
grain are NaN. The undisturbed surface level is the median cell top of the strip's untouched margins.
"""
from __future__ import annotations

import numpy as np


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
