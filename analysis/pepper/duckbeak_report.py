"""The duck-beak's hole (seed 000 in the soil): measured as a punch hole is (seed 001 §4.2),
pictured with the planter's pass. No YADE.

Writes into the run's folder and copies to `dest` (default results/pepper/duckbeak/): hole.csv, summary.json,
holes_top.png, holes_sections.png and pass.png (the beak's outline along its pass over the measured section).
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from analysis.pepper import pepper
from analysis.core.io import atomic_csv
from analysis.holes.measure import measure_run, plot

FILES = ("hole.csv", "summary.json", "holes_top.png", "holes_sections.png", "pass.png")


def beak_outline(cfg: dict, t: float) -> np.ndarray:
    """The planter's side outline (x, z mm, bed frame, z up from the ridge surface) at crank time t: the
    closed beak's cone from its blunt tip P and the body above it, on the axis pepper.beak_axis."""
    p, ps = cfg["planter"], cfg["pass"]
    link = pepper.linkage_from_config(cfg["linkage"])
    x, y, th4 = pepper.pose(link, cfg["speed_mm_s"], cfg["omega_rad_s"], [t], ps["y_ground"],
                            cfg.get("travel_sign", -1))          # runs made before the sign was a setting used -1
    psi = float(pepper.beak_axis(th4[0], ps["theta4_bottom"]))
    e, n = np.array([math.cos(psi), math.sin(psi)]), np.array([-math.sin(psi), math.cos(psi)])
    tip = np.array([float(x[0]) + cfg["x_shift_mm"], float(y[0])])
    r, b, top = p["D"] / 2, p["beak_length"] - cfg["tip"]["blunt"], p["beak_length"] + p["body_length"]
    pts = [tip, tip - b * e + r * n, tip - top * e + r * n, tip - top * e - r * n, tip - b * e - r * n, tip]
    return np.array(pts)


def run(folder, dest: Path | None = None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    folder = Path(folder)
    table, holes, z_surface, surf, loaded = measure_run(folder)
    cfg, summary, state = loaded
    table["path_depth"] = summary["path_depth_mm"]
    table["tip_min_depth"] = summary["tip_min_depth_mm"][0]
    atomic_csv(table.round(2), folder / "hole.csv",
               "the duck-beak's hole (mm) measured by analysis/holes/metrology.py as seed 001 §4.2 measures a punch hole; "
               "path_depth: the linkage's loop depth (analysis/pepper/pepper.py); tip_min_depth: the tip's deepest")
    plot(folder, loaded, holes, z_surface, surf)

    xs, ys, S = surf
    W = cfg["bed_size_mm"][1]
    ps = cfg["pass"]
    fig, ax = plt.subplots(figsize=(7, 5))
    for t in np.linspace(ps["t_in"], ps["t_out"], 9):
        o = beak_outline(cfg, t)
        ax.plot(o[:, 0], o[:, 1], color=plt.cm.viridis((t - ps["t_in"]) / (ps["t_out"] - ps["t_in"])), lw=0.9)
    t = np.linspace(ps["t_in"], ps["t_out"], 200)
    link_tip = np.array([beak_outline(cfg, ti)[0] for ti in t])
    ax.plot(link_tip[:, 0], link_tip[:, 1], "k--", lw=0.8, label="tip P (eq 16, moving)")
    ax.plot(xs, S[:, np.argmin(np.abs(ys - W / 2))] - z_surface, "b-", lw=1.2, label="soil after the pass (centreline)")
    h = holes[0]
    ax.axhline(-h.h1, color="r", lw=0.6, ls=":", label=f"opening level; L0 {h.L0:.0f}, L1 {h.L1:.0f}, "
               f"L2 {h.L2:.0f}, bottom {h.bottom:.0f} mm")
    ax.set(xlabel="x along the ground, mm", ylabel="z above the ridge surface, mm", aspect="equal",
           ylim=(-cfg["bed_size_mm"][2], 200),
           title=f"duck-beak pass ({1000 * (ps['t_out'] - ps['t_in']):.0f} ms, colour: time), {cfg['soil']['name']}")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(folder / "pass.png", dpi=110)
    plt.close(fig)
    if dest is not None:
        dest.mkdir(parents=True, exist_ok=True)
        for name in FILES:
            shutil.copyfile(folder / name, dest / name)
    return table
