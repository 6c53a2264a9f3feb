"""The holes of one run, measured as the field measured them (seed 001 §4.2), and their pictures. No YADE.

    ./holes measure results/runs/<id>      # writes holes.csv, holes_top.png, holes_sections.png there
"""
from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.config import Resolution
from analysis.core.seedling import load_seedling
from analysis.core.schema import ConfigError
from analysis.core.io import atomic_csv, read_table, stamp
from analysis.core.kinematics import formed_hole_x
from analysis.holes.metrology import DEPTHS, measure_state

COLUMNS = ["run", "soil", "seed", "hole", "found", "x", "C", "h1", "L0", "L1", "L2", "L2_surface", "L0_ahead",
           "L0_behind", "bottom", "grain_radius", "probe", "cell", *(f"l_{H}" for H in DEPTHS)]


def current(holes: pd.DataFrame) -> bool:
    """Whether a holes table was measured by this metrology (its columns are this one's): a table measured by a
    former one (other openings, caliper.py) is not pooled with this one's."""
    return set(COLUMNS) <= set(holes.columns)


def kept_holes(folder: Path) -> pd.DataFrame:
    """A kept run's holes.csv, checked against its summary.json: readable, one row per measured hole, the hole
    numbers 1 ... n; a ConfigError naming the file otherwise (a truncated or foreign table is never pooled)."""
    path = Path(folder) / "holes.csv"
    try:
        holes = read_table(path)
        summary = json.loads((Path(folder) / "summary.json").read_text())
        expected = len(summary["hole_x_mm"]) - summary.get("lead_in", 0)
    except (OSError, ValueError, KeyError, pd.errors.ParserError) as e:
        raise ConfigError(f"{path}: not a kept run's holes and summary ({type(e).__name__}: {e})") from None
    if "hole" not in holes or len(holes) != expected or list(holes.hole) != list(range(1, expected + 1)):
        raise ConfigError(f"{path}: {len(holes)} rows, allowed exactly {expected} holes numbered 1 ... {expected} "
                          "(its summary.json's measured holes): a truncated or foreign table")
    return holes


def load_run(folder: Path):
    folder = Path(folder)
    if not (folder / "summary.json").exists():
        raise ConfigError(f"{folder}: no summary.json: allowed the folder of a finished run")
    try:
        cfg = json.loads((folder / "config.json").read_text())
        summary = json.loads((folder / "summary.json").read_text())
        with np.load(folder / "state.npz") as npz:
            state = {k: npz[k] for k in npz.files}
        missing = {"pos", "radius", "initial_pos"} - set(state)
        if missing:
            raise KeyError(f"state.npz has no {', '.join(sorted(missing))}")
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as e:
        raise ConfigError(f"{folder}: its config.json, summary.json or state.npz cannot be read ({type(e).__name__}: "
                          f"{e}): allowed the files of a finished run") from None
    record = folder / "timeseries.csv"
    if summary.get("mode") == "free" and "hole_x_formed_mm" not in summary and record.exists():
        # a free run from before its summary kept where the holes formed: from its record, as the scene does
        ts = pd.read_csv(record)
        summary["hole_x_formed_mm"] = formed_hole_x(ts.t_s, ts.punch, ts.tip_x_m * 1000, ts.tip_z_m,
                                                    gap=3 * np.median(np.diff(np.unique(ts.t_s))))
    return cfg, summary, state


def hole_tool(cfg: dict) -> tuple[float, float]:
    """The tool's diameter and the outer diameter of the ring where h1 is read: a disk run's punch D and its
    sleeve; the duck-beak's D (scripts/duckbeak.py) and a ring of 2 D, as wide round the hole as a sleeve."""
    if cfg.get("scene") == "duckbeak":
        return cfg["planter"]["D"], 2 * cfg["planter"]["D"]
    return cfg["disk"]["D"], cfg["sleeve"]["outer_diameter"]


def hole_centres(summary: dict) -> list:
    """Every hole's x (mm), lead-in holes first: the prescribed layout's, except in free mode, where the disk
    rolls as the soil lets it and the k-th hole is where the k-th punch passage into the soil was deepest
    (summary `hole_x_formed_mm`, from the run's record; a hole the record lacks keeps the layout's x). A passage
    before the bed's start (x < 0: the punch standing at its lowest under the axis when the run starts, where no
    soil is) is not a hole.

    >>> hole_centres({"mode": "free", "hole_x_mm": [100, 300, 500], "hole_x_formed_mm": [110.0, 322.0]})
    [110.0, 322.0, 500]
    >>> hole_centres({"mode": "free", "hole_x_mm": [100, 300], "hole_x_formed_mm": [-84.0, 170.0, 370.0, 570.0]})
    [170.0, 370.0]
    """
    planned = list(summary["hole_x_mm"])
    formed = summary.get("hole_x_formed_mm") if summary.get("mode") == "free" else None
    if formed is None:
        return planned
    formed = [x for x in formed if x >= 0]
    return [*formed[:len(planned)], *planned[len(formed):]]


def measure_run(folder, cell: float = 1.0, seedling_path="configs/seedling.toml"):
    """One row per measured hole (mm): centre x, spacing C to the next hole (NaN for the last), h1, L0, L1, L2,
    L0's parts ahead of (+x) and behind the hole's axis, the bottom depth and the length along the travel at
    5 ... 60 mm below the undisturbed surface (l_5 ...);
    the probe is the mean grain radius. A hole not found where the punch entered (metrology.measure_hole)
    keeps its kinematic x and NaN measures, and no spacing C is taken to or from it. Also returns what the
    pictures need: the hole measures, the undisturbed level, the probed surface and the loaded run."""
    cfg, summary, state = loaded = load_run(folder)
    seedling = load_seedling(seedling_path)
    pos, rad, pos0 = state["pos"] * 1000, state["radius"] * 1000, state["initial_pos"] * 1000
    measured_x = hole_centres(summary)[summary.get("lead_in", 0):]        # lead-in holes are not measured
    width = cfg["bed_size_mm"][1]
    graded = Resolution("graded", **cfg["graded"]) if cfg.get("graded") else None     # scripts/disk.py's plan
    band = tuple(1000 * y for y in graded.fine_band(width / 1000)) if graded else None
    probe = float(rad[graded.is_fine(rad / 1000)].mean() if graded else rad.mean())
    holes, z_surface, surf = measure_state(pos, rad, pos0, rad, width, measured_x, *hole_tool(cfg),
                                           seedling.l2_diameter, cell=cell, probe=probe, band=band)
    x = np.array([h.x if h.found else np.nan for h in holes])      # C: NaN to or from a hole not found
    rows = [{"run": summary["id"], "soil": cfg["soil"]["name"], "seed": cfg["seed"], "hole": k + 1,
             "found": h.found, "x": h.x,
             "C": (x[k + 1] - x[k]) if k + 1 < len(x) else np.nan, "h1": h.h1, "L0": h.L0, "L1": h.L1, "L2": h.L2,
             "L2_surface": h.L2 + h.h1,
             "L0_ahead": h.ahead, "L0_behind": h.behind, "bottom": h.bottom, "grain_radius": probe, "probe": probe, "cell": cell,
             **{f"l_{H}": v for H, v in zip(DEPTHS, h.l_depth)}}
            for k, h in enumerate(holes)]
    return pd.DataFrame(rows, columns=COLUMNS), holes, z_surface, surf, loaded


def run(folder, cell: float = 1.0, pictures: bool = True) -> pd.DataFrame:
    """Measure a finished run; write holes.csv and (unless not `pictures`) the pictures into its folder."""
    return measure_and_write(folder, cell, pictures)[0]


def measure_and_write(folder, cell: float = 1.0, pictures: bool = True):
    """run(), also returning measure_run()'s whole answer for what is read off the same grains next."""
    folder = Path(folder)
    measured = table, holes, z_surface, surf, loaded = measure_run(folder, cell)
    table = table.round(2)                  # what holes.csv holds, so a kept run's table reads the same
    atomic_csv(table, folder / "holes.csv", stamp(f"./holes measure {folder.name}") + "; mm, seed 001 §4.2")
    if pictures:
        plot(folder, loaded, holes, z_surface, surf)
    return table, measured


def plot(folder: Path, loaded, holes, z_surface: float, surf):
    """holes_top.png: the probed surface with each opening's sections; holes_sections.png: along and across
    each hole through its centre, the grains in a slab one grain thick and the probed surface."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cfg, summary, state = loaded
    xs, ys, S = surf
    pos, rad = state["pos"] * 1000, state["radius"] * 1000
    L, W = cfg["bed_size_mm"][:2]
    fig, ax = plt.subplots(figsize=(min(12.0, 2.5 + 3.0 * L / W), 3.6))
    im = ax.imshow((S - z_surface).T, origin="lower", extent=(xs[0], xs[-1], ys[0], ys[-1]), cmap="terrain",
                   vmin=-70, vmax=25, aspect="equal")
    fig.colorbar(im, ax=ax, label="probed surface − undisturbed level, mm")
    for h in holes:
        level = (S < h.z_open - rad.mean())
        ax.contour(xs, ys, level.T.astype(float), levels=[0.5], colors="k", linewidths=0.6)
        ax.annotate(f"L0 {h.L0:.0f}\nL1 {h.L1:.0f}\nL2 {h.L2:.0f}\nh1 {h.h1:.0f}", (h.x, W - 4), ha="center",
                    va="top", fontsize=7)
    ax.set(xlabel="x along the travel, mm", ylabel="y, mm",
           title=f"{summary['id']}: top of the bed; black: the openings (probe below the subsided level)")
    fig.tight_layout()
    fig.savefig(folder / "holes_top.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(2, len(holes), figsize=(4.2 * len(holes), 6.5), squeeze=False)
    for k, h in enumerate(holes):
        for row, (along, other, centre, grid_along, cut) in enumerate(
                ((0, 1, W / 2, xs, S[:, np.argmin(np.abs(ys - W / 2))]),
                 (1, 0, h.x, ys, S[np.argmin(np.abs(xs - h.x)), :]))):
            ax = axes[row, k]
            slab = np.abs(pos[:, other] - centre) < rad.mean()
            near = np.abs(pos[:, along] - (h.x if along == 0 else W / 2)) < 90
            sel = slab & near
            for p, r in zip(pos[sel], rad[sel]):
                ax.add_patch(plt.Circle((p[along], p[2] - z_surface), r, color="0.6", lw=0))
            ax.plot(grid_along, cut - z_surface, "b-", lw=1, label="probed surface")
            ax.axhline(h.z_open - z_surface, color="r", lw=0.8, ls="--", label="opening level (−h1)")
            ax.axhline(h.z_open - z_surface - h.L2, color="m", lw=0.8, ls=":", label="L2")
            mid = h.x if along == 0 else W / 2
            ax.set(xlim=(mid - 90, mid + 90), ylim=(-cfg["bed_size_mm"][2], 40), aspect="equal",
                   xlabel=("x" if along == 0 else "y") + ", mm", ylabel="z − undisturbed level, mm",
                   title=f"hole {k + 1}, " + ("along the travel" if along == 0 else "across"))
            if k == 0 and row == 0:
                ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(folder / "holes_sections.png", dpi=100)
    plt.close(fig)
