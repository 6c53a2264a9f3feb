"""The pressed ring beside each hole (seed 001 §1.2, §4.2's h1): the surface across the travel on each side of
the hole, beside the level the sleeve's plate face reached, and where h1 is read.

The plate (an annulus from D/2 to the sleeve's outer radius) presses its ring down to its face, which at the
deepest point stands `penetration - rest_from_tip - travel` below the scene's surface level, `travel` being how
far the soil pushed the plate back on its spring (the run's greatest sleeve travel); put in the metrology's
datum (plate_depths). h1 is the median of the
probed surface on the inner half of the ring, D/2 ... (D/2 + outer radius)/2 (metrology.measure_hole): the rim
the punch and plate heave round the plate overhangs the probed surface over the outer half.

The opening's edges (L0, L1) are where the wall crosses the level `cut` below the subsided level −h1 (one probe
radius by default, the grain-scale roughness of the pressed ring) or turns flat below it (metrology.wall_edges).
cut.csv gives each hole's L0, L1 and L2 at 0 ... 2 probe radii, so the measure's dependence on that level is a
number, not a caveat.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from analysis.core.io import atomic_csv, stamp
from analysis.core.config import load_seedling
from analysis.holes.measure import hole_centres, hole_tool, measure_run
from analysis.holes.metrology import h1_band, measure_hole, side_profile

CUTS = (0.0, 0.5, 1.0, 1.5, 2.0)      # the opening's cut below −h1, in probe radii (1: the rule)


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


def cut_levels(measured, seedling_path="configs/seedling.toml") -> pd.DataFrame:
    """One row per hole and cut (CUTS, in probe radii below −h1): the hole's L0, L1 and L2 measured with the
    opening cut there (metrology.measure_hole), mm. `measured`: a run's measure_run()."""
    table, holes, z_surface, (xs, ys, S), (cfg, summary, _) = measured
    D, outer = hole_tool(cfg)
    seedling = load_seedling(seedling_path)
    rows = []
    for row, xc in zip(table.itertuples(), hole_centres(summary)[summary.get("lead_in", 0):]):
        for k in CUTS:
            h = measure_hole(S, xs, ys, z_surface, xc, cfg["bed_size_mm"][1] / 2, D, outer, row.probe,
                             seedling.l2_diameter, cut=k * row.probe)
            rows.append({"run": summary["id"], "soil": cfg["soil"]["name"], "hole": row.hole, "probe": row.probe,
                         "cut_probes": k, "cut": k * row.probe, "h1": h.h1, "L0": h.L0, "L1": h.L1, "L2": h.L2})
    return pd.DataFrame(rows)


def cut_slopes(cuts: pd.DataFrame) -> pd.DataFrame:
    """Per hole, how far L0, L1 and L2 move (mm) when the cut goes from 0.5 to 1.5 probe radii, the rule ± half
    a probe radius."""
    wide = cuts.set_index(["run", "soil", "hole", "cut_probes"])[["L0", "L1", "L2"]].unstack("cut_probes")
    return pd.DataFrame({m: wide[(m, 1.5)] - wide[(m, 0.5)] for m in ("L0", "L1", "L2")}).reset_index()


def run(folders, out: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """rings.csv, rings.png and cut.csv in `out`: every hole of the given finished runs."""
    measured = [measure_run(f) for f in folders]
    table = pd.concat([profiles(m) for m in measured], ignore_index=True).round(2)
    cuts = pd.concat([cut_levels(m) for m in measured], ignore_index=True).round(2)
    out.mkdir(parents=True, exist_ok=True)
    command = "./holes rings " + " ".join(Path(f).name for f in folders)
    atomic_csv(table, out / "rings.csv", stamp(command) + "; mm below the undisturbed surface, r from the hole's axis")
    atomic_csv(cuts, out / "cut.csv", stamp(command) + "; mm; the opening cut `cut` below −h1 (1 probe: the rule)")
    plot(table, out / "rings.png", command)
    return table, cuts


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
