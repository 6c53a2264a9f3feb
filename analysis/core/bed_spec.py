"""A soil bed's specification, without YADE: its cache key and folder, the checks of its size, tiling and
graded zones. scripts/beds.py (the part that settles it) and the analysis side both use these."""
from __future__ import annotations

import math

from analysis.core.schema import ROOT, ConfigError, Field, digest

BED_DIR = ROOT / "results/cache/beds"           # settled beds, made once and loaded by every scene
CONE_DIR = ROOT / "results/cache/cone"          # cone runs, reused by the calibration and its checks
SIZE_FIELDS = {"length": Field(0.02, 3.0, unit="m"), "width": Field(0.02, 1.0, unit="m"), "depth": Field(0.02, 0.5, unit="m")}


def bed_key(soil, res, size, seed: int, lateral: str = "walls", tiles: int = 1) -> str:
    """The bed's cache name; a periodic bed's carries "-per" (walled beds keep the keys they always had), a tiled
    one's "-t<n>" and the tiled cell's size."""
    params = {"soil": soil.name, **soil.settling_key(), "young": soil.young, "radius": res.radius,
              "spread": res.spread, "size_m": [round(s, 6) for s in size], "seed": seed, "version": 1}
    if res.graded:                     # beds of one size keep the keys they always had
        params["graded"] = [res.coarse_radius, res.fine_width, res.fine_depth]
    if lateral == "periodic":
        params["lateral"] = lateral
        params["version"] = 2          # the periodic cloud (version 1 left a loose column along the cell's sides)
    if tiles > 1:
        params["tiles"] = tiles
    L, W, D = round(1000 * size[0] * tiles), round(1000 * size[1] * tiles), round(1000 * size[2])
    sides = ("-per" if lateral == "periodic" else "") + (f"-t{tiles}" if tiles > 1 else "")
    return f"{soil.name}-{res.name}-{L}x{W}x{D}{sides}-s{seed}-{digest(params)}"


def mean_volume(r: float, spread: float) -> float:
    """E[4/3 π r³] of radii uniform in r(1 ± spread)."""
    return 4 / 3 * math.pi * r ** 3 * (1 + spread ** 2)


def zones(res, L: float, W: float, D: float) -> list:
    """The bed's zones as (lower corner, upper corner, mean radius), m, in the settled bed's frame: a graded bed's
    fine zone, then the coarse boxes under and beside it (Resolution). The top ones reach 1.12 D: the levelling's
    margin."""
    (y0, y1), zf, top = res.fine_band(W), D - res.fine_depth, 1.12 * D
    boxes = [((0, y0, zf), (L, y1, top), res.radius), ((0, 0, 0), (L, W, zf), res.coarse_radius),
             ((0, 0, zf), (L, y0, top), res.coarse_radius), ((0, y1, zf), (L, W, top), res.coarse_radius)]
    return [b for b in boxes if b[1][1] > b[0][1]]      # a fine zone across the whole width has no sides


GRAINS_ACROSS = 4       # the fewest of the largest grains a bed must hold across its width and its depth


def check_grains_fit(res, size):
    """A bed holds at least GRAINS_ACROSS of its largest grains across its width and its depth (a grain as big as the
    strip makes no soil).

    >>> from types import SimpleNamespace as N
    >>> check_grains_fit(N(name="big", radius=0.03, spread=0.25, coarse_radius=0.0), (2.0, 0.16, 0.14))
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    analysis.core.schema.ConfigError: resolution 'big': grains up to 75 mm across in a bed 160 x 140 mm ...
    """
    largest = 2 * max(res.radius, getattr(res, "coarse_radius", 0.0) or 0.0) * (1 + res.spread)
    smallest = min(size[1], size[2])
    if largest * GRAINS_ACROSS > smallest:
        raise ConfigError(f"resolution {res.name!r}: grains up to {1000 * largest:.0f} mm across in a bed "
                          f"{1000 * size[1]:.0f} x {1000 * size[2]:.0f} mm (width x depth): allowed at most "
                          f"{1000 * smallest / GRAINS_ACROSS:.0f} mm, {GRAINS_ACROSS} across each")


def check_graded(res, size, lateral: str):
    """A graded bed's fine zone fits inside the bed, with room for a coarse grain beside and under it; walled only."""
    if not res.graded:
        return
    L, W, D = size
    if lateral != "walls":
        raise ConfigError(f"resolution = {res.name!r} is graded: allowed with lateral = 'walls' only (its coarse "
                          "sides would be periodic images of each other)")
    room = 2 * res.coarse_radius * (1 + res.spread)
    side = (W - res.fine_width) / 2     # <= 0: the fine zone spans the width, coarse grains under it only
    if 0 < side < room or res.fine_depth > D - room:
        raise ConfigError(f"resolution {res.name!r}: fine_width = {1000 * res.fine_width:g} mm and fine_depth = "
                          f"{1000 * res.fine_depth:g} mm are out of range for a {1000 * W:g} x {1000 * D:g} mm section: "
                          f"allowed up to {1000 * (W - 2 * room):g} (or the whole width) and {1000 * (D - room):g} mm (a "
                          "coarse grain beside and under the fine zone)")


TILES = Field(1, 4, kind=int, meaning="copies of the periodic bed along its length and its width")


def check_tiles(tiles: int, lateral: str, where: str = "bed.tiles") -> int:
    """A tiled bed repeats a periodic cell; a walled bed's copies would have walls inside the bed."""
    TILES.check(where, tiles)
    if tiles > 1 and lateral != "periodic":
        raise ConfigError(f"{where} = {tiles}: only a periodic bed (lateral = \"periodic\") can be tiled; allowed 1 "
                          f"for lateral = {lateral!r}")
    return tiles


def check_size(size) -> tuple:
    if len(size) != 3:
        raise ConfigError(f"size = {size!r}: allowed three lengths, length,width,depth in mm")
    return tuple(SIZE_FIELDS[k].check(f"bed.{k}", v) for k, v in zip(SIZE_FIELDS, size))


def tilled_keep(z, z_surface: float, depth: float, density: float, seed: int):
    """Which grains a loosened top layer keeps (a boolean mask): of the grains whose centres lie within `depth`
    of the surface (all in one unit), a random share 1 - `density` is taken out, the same ones for the same
    seed, so the layer's bulk density is `density` times the bed's; those below are all kept. The rotary tiller
    works the soil just before the disk (seed 001 §1.2); the remaining grains keep the soil's calibrated bonds.

    >>> keep = tilled_keep([0.0, -5, -10, -15, -200], 0.0, 100.0, 0.5, 1)
    >>> int(keep[:4].sum()), bool(keep[4])
    (2, True)
    """
    import numpy as np
    z = np.asarray(z, float)
    layer = np.flatnonzero(z > z_surface - depth)
    out = np.random.default_rng(seed).choice(layer, size=int(round((1 - density) * layer.size)), replace=False)
    keep = np.ones(z.size, bool)
    keep[out] = False
    return keep


CELL_SETTLE_KPA = 1.0        # a simple shear cell's packing's vertical stress: a bed's own weight at a 150 mm box's mid-depth
CELL_PACKED_FRACTION = 0.55  # the solid fraction its cloud is planned for (the cell ends about cubic)
CELL_INERTIAL = 1e-3         # the inertial number γ̇ d / √(σn / ρ) a cell is sheared at: half of it moves the peaks
                             # less than the packings' scatter (results/calibration/bench/cell-rate.csv)


def cell_key(soil, res, edge: float, seed: int, settle_kpa: float = CELL_SETTLE_KPA,
             packed_fraction: float = CELL_PACKED_FRACTION) -> str:
    """A simple shear cell's packing's cache name (scripts/simple_shear.py): the soil's settling parameters, the
    grains, the cell's edge, the seed and the packing's own settings.

    >>> from types import SimpleNamespace as N
    >>> soil = N(name="clay", young=2e7, settling_key=lambda: {"friction_deg": 25.0})
    >>> cell_key(soil, N(name="medium", radius=0.006, spread=0.25), 0.12, 3, 1.0, 0.55).rsplit("-", 1)[0]
    'clay-medium-cell120-s3'
    """
    params = {"soil": soil.name, **soil.settling_key(), "young": soil.young, "radius": res.radius,
              "spread": res.spread, "edge": round(edge, 6), "seed": seed, "settle_kpa": settle_kpa,
              "packed_fraction": packed_fraction, "version": 1}
    return f"{soil.name}-{res.name}-cell{round(1000 * edge)}-s{seed}-{digest(params)}"
