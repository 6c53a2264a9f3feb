"""Each hole metric's measurement band, from holes of known size carved in the committed settled beds (no YADE).

    ./holes metrology-band        # results/comparison/metrology/: carved.csv, band.csv, candidates.csv, band.png

For every grain radius a preset uses (RADII), every carved shape and carving (carved.py) and REALISATIONS
places in each soil's bed, the hole is measured the way the runs' holes are (metrology.measure_state) and its
opening read by every candidate caliper (caliper.JAWS at caliper.LEVEL_CANDIDATES). Per candidate, radius
and metric: the bias (mean of measured - true) and the spread (SD) over the carvings, shapes and places; the
band is |bias| + 2 SD, the most a reading of one hole is off by, nineteen times in twenty; the band of a mean
over many holes (band_mean) is the largest offset of one shape and carving's mean, the part that does not
average away. The caliper the
runs use is the candidate `choose_jaw` picks: the least worst band of L0 and L1 over the radii. Closeness to
the field plays no part.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.seedling import load_seedling
from analysis.core.schema import ROOT
from analysis.core.io import atomic_csv, say, stamp
from analysis.holes import carved
from analysis.holes.caliper import JAWS, LEVEL_CANDIDATES, LEVELS
from analysis.holes.metrology import caliper_reading, measure_state
from analysis.core.bed_spec import BED_DIR

RADII = (4.0, 5.0, 6.0, 8.0)           # mm: the grain radii of the presets' beds (configs/resolutions.toml)
REALISATIONS = 2                        # places carved in each soil's bed
WINDOW = 320.0                          # mm of bed round each carved hole
OUT = ROOT / "results/comparison/metrology"


def beds(radius: float, bed_dir: Path = BED_DIR) -> list[Path]:
    """The uniform strip beds of grain radius `radius` (mm), one per soil: graded beds left out, and beds too
    short for two places of WINDOW (a bench test's box settled in the same folder is not a strip)."""
    found = {}
    for meta in sorted(bed_dir.glob("*.json")):
        m = json.loads(meta.read_text())
        long_enough = 1000 * m["size_m"][0] >= 2 * WINDOW + 100
        if (abs(1000 * m["radius"] - radius) < 1e-6 and "coarse_radius" not in m and long_enough
                and m["soil"] not in found):
            found[m["soil"]] = meta.with_suffix(".npz")
    return list(found.values())


def places(bed: Path, n: int):
    """n windows of the bed, evenly along it, away from its ends: (pos, radius, width) in mm, x from 0."""
    d = np.load(bed)
    pos, rad = d["pos"] * 1000, d["radius"] * 1000
    width = float(json.loads(bed.with_suffix(".json").read_text())["size_m"][1] * 1000)
    lo, hi = pos[:, 0].min() + 50, pos[:, 0].max() - 50 - WINDOW
    for x0 in np.linspace(lo, hi, n + 2)[1:-1]:
        keep = (pos[:, 0] >= x0) & (pos[:, 0] < x0 + WINDOW)
        p = pos[keep] - [x0, 0, 0]
        yield p, rad[keep], width


def measure_carved(radius: float, realisations: int = REALISATIONS, soils: int | None = None,
                   candidates=None) -> pd.DataFrame:
    """One row per carved hole, candidate and metric: measured and true value (mm); `soils`: only the first
    so many soils' beds; `candidates`: (jaw, level) pairs to read with (default: every JAWS at every level)."""
    candidates = candidates or [(jaw, below) for jaw in JAWS for below in sorted({*LEVEL_CANDIDATES, *LEVELS})]
    rows = []
    diameter_min = load_seedling().l2_diameter            # √2·a2
    truths = {(s, b): carved.truth(s, b, diameter_min) for s in carved.SHAPES for b in (*LEVEL_CANDIDATES, *LEVELS)}
    for bed in beds(radius)[:soils]:
        for k, (pos0, rad0, width) in enumerate(places(bed, realisations)):
            xc, yc = WINDOW / 2, width / 2
            _, z_ref, _ = measure_state(pos0, rad0, pos0, rad0, width, [xc], carved.D, 80.0, diameter_min)
            for shape in carved.SHAPES:           # carved below the bed's undisturbed level as the metrology reads it
                for carving in carved.CARVINGS:
                    pos, rad = carved.carve(pos0, rad0, shape, carving, xc, yc, z_ref)
                    (hole,), _, _ = measure_state(pos, rad, pos0, rad0, width, [xc], carved.D, 80.0, diameter_min)
                    base = {"radius": radius, "bed": bed.stem.split("-")[0], "place": k, "shape": shape,
                            "carving": carving}
                    t = truths[(shape, 0.0)]
                    for m in ("h1", "L2", "L2_surface"):
                        value = hole.L2 + hole.h1 if m == "L2_surface" else getattr(hole, m)
                        rows.append({**base, "jaw": np.nan, "below": np.nan, "metric": m, "measured": value,
                                     "true": t[m]})
                    for jaw, below in candidates:
                        r = caliper_reading((pos, rad), hole.x0, hole.y0, hole.z_open, jaw, below,
                                            float(rad.mean()), carved.D)
                        t = truths[(shape, below)]
                        for m in ("L0", "L1"):
                            rows.append({**base, "jaw": jaw.name, "below": below, "metric": m,
                                         "measured": getattr(r, m), "true": t[m]})
    out = pd.DataFrame(rows)
    out["error"] = out.measured - out.true
    return out


def band(carved_rows: pd.DataFrame) -> pd.DataFrame:
    """Per candidate (jaw, level), radius and metric: bias, SD, worst error, holes, the band of one hole's
    reading |bias| + 2 SD, and the band of a mean over many holes, `band_mean`: the largest offset of any one
    shape and carving's mean (what does not average away over holes; their scatter is already in a mean's
    statistical interval)."""
    rows = carved_rows.fillna({"jaw": "", "below": -1})
    keys = ["jaw", "below", "radius", "metric"]
    g = rows.groupby(keys, sort=False).error
    out = pd.DataFrame({"bias": g.mean(), "sd": g.std(ddof=1), "worst": g.apply(lambda e: e.abs().max()),
                        "n": g.size()})
    out["band_mean"] = rows.groupby([*keys, "shape", "carving"]).error.mean().abs().groupby(keys).max()
    out = out.reset_index()
    out["band"] = out.bias.abs() + 2 * out.sd
    out["below"] = out.below.replace(-1, np.nan)
    return out


def choose_jaw(bands: pd.DataFrame) -> tuple[str, float]:
    """The candidate (jaw name, mm below the subsided level) whose worst band of L0 and L1 over the radii is
    the least: fixed before any run's holes are measured with it."""
    c = bands[bands.metric.isin(["L0", "L1"]) & bands.below.isin(LEVEL_CANDIDATES)]
    worst = c.groupby(["jaw", "below"]).band.max()
    jaw, below = worst.idxmin()
    return jaw, float(below)


def run(out: Path = OUT, realisations: int = REALISATIONS) -> pd.DataFrame:
    out.mkdir(parents=True, exist_ok=True)
    parts = []
    for i, r in enumerate(RADII):
        say(f"metrology-band: carving and measuring at r = {r:g} mm ({i + 1}/{len(RADII)})")
        parts.append(measure_carved(r, realisations))
    rows = pd.concat(parts, ignore_index=True)
    bands = band(rows)
    jaw, below = choose_jaw(bands)
    command = "./holes metrology-band"
    atomic_csv(rows.round(3), out / "carved.csv", stamp(command) + "; mm; one row per carved hole, candidate, metric")
    atomic_csv(bands.round(3), out / "candidates.csv",
               stamp(command) + f"; mm; band = |bias| + 2 SD; chosen: {jaw} at {below:g} mm below the subsided level")
    chosen = bands[(bands.jaw == "") | ((bands.jaw == jaw) & (bands.below == below))].drop(columns="jaw")
    atomic_csv(chosen.round(3), out / "band.csv", stamp(command) + f"; mm; the runs' caliper: {jaw}, "
               f"{below:g} mm below the subsided level; band = |bias| + 2 SD (one hole); band_mean: a mean's")
    plot(bands, jaw, below, out / "band.png", command)
    say(f"metrology-band: chosen caliper {jaw} at {below:g} mm below the subsided level; {out}")
    return chosen


def plot(bands: pd.DataFrame, jaw: str, below: float, path: Path, command: str):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, m in zip(axes, ("L0", "L1")):
        b = bands[(bands.metric == m) & bands.below.isin(LEVEL_CANDIDATES)]
        for i, ((j, lv), g) in enumerate(b.groupby(["jaw", "below"])):
            style = dict(lw=2.2, color="k") if (j, lv) == (jaw, below) else dict(lw=0.9, alpha=0.7)
            ax.errorbar(g.radius + 0.02 * (i - 7), g.bias, yerr=2 * g.sd, marker="o", ms=3,
                        capsize=2, label=f"{j}, {lv:g} mm", **style)
        ax.axhline(0, color="0.5", lw=0.5)
        ax.set(xlabel="grain radius, mm", title=f"{m}: measured − true on carved holes (bias ± 2 SD)")
    axes[0].set_ylabel("mm")
    axes[1].legend(fontsize=6, ncol=2)
    fig.text(0.01, 0.01, f"`{command}`; black: the runs' caliper", fontsize=6, color="0.4")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
