"""The pressed ring beside each hole (seed 001 §1.2, §4.2's h1): the surface across the travel on each side of
the hole, beside the level the sleeve's plate face reached, and where h1 is read.

The plate (an annulus from D/2 to the sleeve's outer radius) presses its ring down to its face, which at the
deepest point stands `penetration - rest_from_tip - travel` below the scene's surface level, `travel` being how
far the soil pushed the plate back on its spring (the run's greatest sleeve travel); put in the metrology's
datum (plate_depths). h1 is the median of the
probed surface on the inner half of the ring, D/2 ... (D/2 + outer radius)/2 (metrology.measure_hole): the rim
the punch and plate heave round the plate overhangs the probed surface over the outer half.

The openings L0 and L1 are caliper readings at a level below the subsided level −h1 (caliper.py). levels.csv
gives each hole's L0, L1 and L0's split ahead of and behind its axis at 0, 5, 10 and 20 mm below −h1,
so how much the answer hangs on the level is a number per soil, not a caveat (levels_summary.csv, levels-*.png).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import atomic_csv, stamp
from analysis.holes.measure import hole_centres, hole_tool, measure_run
from analysis.holes.caliper import JAW, LEVEL_BELOW, LEVELS
from analysis.holes.metrology import caliper_reading, h1_band, side_profile


def plate_depths(cfg: dict, summary: dict, z_surface: float) -> list[float]:
    """Depth of the plate face below the undisturbed level the metrology reads (`z_surface`, mm) at each measured
    hole's deepest point. The scene places the tips (and so the plate) from its own level, the median of the
    highest grain top in each 4-radius cell (scripts/parts.py), which stands 2.4-3.0 mm above the median probed
    surface the metrology reads h1 from (the kept runs' beds); both are in summary.json and the bed, so the
    plate is put in the metrology's datum: P - rest_from_tip - travel - (scene level - metrology level)."""
    lead_in = summary.get("lead_in", 0)
    offset = 1000 * summary["z_surface_m"] - z_surface
    return [cfg["disk"]["penetration"] - cfg["sleeve"]["rest_from_tip"] - t - offset
            for t in summary["sleeve_max_travel_mm"][lead_in:]]


def profiles(measured) -> pd.DataFrame:
    """One row per hole, side and distance r from the axis: the depth of the probed surface there (mm), the
    hole's h1, its plate's face depth and the band h1 is read in. `measured`: a run's measure_run()."""
    table, holes, z_surface, (xs, ys, S), (cfg, summary, _) = measured
    D, outer = cfg["disk"]["D"], cfg["sleeve"]["outer_diameter"]
    band_lo, band_hi = h1_band(D, outer)
    half_width = cfg["bed_size_mm"][1] / 2
    entries = hole_centres(summary)[summary.get("lead_in", 0):]
    rows = []
    for row, xc, plate in zip(table.itertuples(), entries, plate_depths(cfg, summary, z_surface)):
        r, depth = side_profile(S, xs, ys, z_surface, xc, half_width, D, min(outer + 10, half_width))
        for side, d in zip(("-y", "+y"), depth):
            rows += [{"run": summary["id"], "soil": cfg["soil"]["name"], "hole": row.hole, "h1": row.h1,
                      "plate_depth": plate, "band_lo": band_lo, "band_hi": band_hi, "side": side,
                      "r": ri, "depth": di} for ri, di in zip(r, d)]
    return pd.DataFrame(rows)


def level_table(measured) -> pd.DataFrame:
    """One row per hole and level (caliper.LEVELS, mm below the subsided level −h1): the caliper's L0 and L1
    there and L0's split ahead of (+x, the travel) and behind the hole's axis (its section's centroid at L2),
    mm. `measured`: a run's measure_run()."""
    table, holes, z_surface, _, (cfg, summary, state) = measured
    D, _ = hole_tool(cfg)
    grains = (state["pos"] * 1000, state["radius"] * 1000)
    rows = []
    for row, h in zip(table.itertuples(), holes):
        for below in LEVELS:
            r = caliper_reading(grains, h.x0, h.y0, h.z_open, JAW, below, row.probe, D) if h.found else None
            rows.append({"run": summary["id"], "soil": cfg["soil"]["name"], "hole": row.hole, "below": below,
                         **{k: getattr(r, k) if r else float("nan") for k in ("L0", "L1", "ahead", "behind")}})
    return pd.DataFrame(rows)


def level_summary(levels: pd.DataFrame) -> pd.DataFrame:
    """Per soil and level: the holes' mean and SD of L0, L1 and L0's split, and how far each moves per mm of
    level against the level the runs read at (caliper.LEVEL_BELOW), from the least-squares slope over LEVELS."""
    g = levels.groupby(["soil", "below"], sort=False)[["L0", "L1", "ahead", "behind"]]
    out = g.mean().add_suffix("_mean").join(g.std().add_suffix("_sd")).join(g.size().rename("holes")).reset_index()
    slopes = {}
    for soil, s in levels.groupby("soil", sort=False):
        for m in ("L0", "L1", "ahead", "behind"):
            v = s[["below", m]].dropna()
            slopes[(soil, m)] = float(np.polyfit(v.below, v[m], 1)[0]) if v.below.nunique() > 1 else np.nan
    for m in ("L0", "L1", "ahead", "behind"):
        out[f"{m}_per_mm"] = [slopes[(soil, m)] for soil in out.soil]
    return out


def plot_levels(levels: pd.DataFrame, out: Path, command: str) -> list[Path]:
    """One picture per soil: L0 (with its split ahead and behind) and L1 against the level, each hole a thin
    line, the mean bold."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for soil, s in levels.groupby("soil", sort=False):
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
        for ax, metrics in zip(axes, (("L0", "ahead", "behind"), ("L1",))):
            for m, colour in zip(metrics, ("C0", "C2", "C3")):
                for _, h in s.groupby(["run", "hole"]):
                    ax.plot(h[m], h.below, "-", color=colour, lw=0.4, alpha=0.5)
                mean = s.groupby("below")[m].mean()
                ax.plot(mean.values, mean.index, "o-", color=colour, lw=2, label=f"{m} (mean)")
            ax.axhline(LEVEL_BELOW, color="k", lw=0.8, ls="--", label="the runs' reading level")
            ax.set(xlabel="mm", title=f"{soil}: " + ("L0 and its split about the hole's axis" if len(metrics) > 1
                                                     else "L1"))
            ax.legend(fontsize=7)
        axes[0].set_ylabel("level below the subsided level (−h1), mm")
        axes[0].invert_yaxis()
        fig.text(0.01, 0.01, f"`{command}`", fontsize=6, color="0.4")
        fig.tight_layout()
        path = out / f"levels-{soil}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths


def write_levels(folder: Path, levels: pd.DataFrame, command: str):
    """How much the openings hang on the level they are read at (level_table): levels.csv, levels_summary.csv and
    one picture per soil, in `folder`."""
    folder.mkdir(parents=True, exist_ok=True)
    atomic_csv(levels.round(2), folder / "levels.csv", stamp(command) + f"; mm; the caliper ({JAW.name}) `below` mm "
               "under the subsided level; ahead/behind: L0's parts either side of the hole's axis")
    atomic_csv(level_summary(levels).round(3), folder / "levels_summary.csv",
               stamp(command) + "; mm per soil and level; *_per_mm: the move per mm of level (least squares)")
    plot_levels(levels, folder, command)


def run(folders, out: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """rings.csv, rings.png, levels.csv, levels_summary.csv and levels-<soil>.png in `out`: every hole of the
    given finished runs."""
    measured = [measure_run(f) for f in folders]
    table = pd.concat([profiles(m) for m in measured], ignore_index=True).round(2)
    levels = pd.concat([level_table(m) for m in measured], ignore_index=True)
    out.mkdir(parents=True, exist_ok=True)
    command = "./holes rings " + " ".join(Path(f).name for f in folders)
    atomic_csv(table, out / "rings.csv", stamp(command) + "; mm below the undisturbed surface, r from the hole's axis")
    plot(table, out / "rings.png", command)
    write_levels(out, levels, command)
    return table, levels


def plot(table: pd.DataFrame, path: Path, command: str):
    """One panel per hole: the surface on each side against r, the plate's face, −h1 and the band it is read in."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    holes = list(table.groupby(["run", "hole"], sort=False))
    cols = min(4, len(holes))
    rows = -(-len(holes) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.0 * rows), squeeze=False, sharey=True)
    for ax, ((run, hole), g) in zip(axes.flat, holes):
        for side, colour in (("-y", "tab:blue"), ("+y", "tab:orange")):
            s = g[g.side == side]
            ax.plot(s.r, -s.depth, "-", color=colour, lw=1.2, label=f"surface, {side} side")
        first = g.iloc[0]
        ax.axhline(-first.plate_depth, color="k", lw=0.8, ls="--", label="plate face at the deepest point")
        ax.axhline(-first.h1, color="r", lw=0.8, label="−h1")
        ax.axhline(0, color="0.6", lw=0.5)
        ax.axvspan(first.band_lo, first.band_hi, color="r", alpha=0.08, label="band h1 is read in")
        ax.set(title=f"{run.split('-')[0]} {run.split('-')[-1][:4]} hole {hole}", xlabel="r from the axis, mm")
    for ax in axes[:, 0]:
        ax.set_ylabel("z − undisturbed level, mm")
    for ax in axes.flat[len(holes):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6, loc="lower right")
    fig.suptitle(f"the pressed ring beside each hole (`{command}`)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
