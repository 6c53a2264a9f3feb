"""Pictures of one run (results/runs/<id>/): the formed holes and the tool's time series. No YADE needed.

    ./holes report results/runs/<id>
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.holes.metrology import probed_surface


def draw_disk(ax, cfg, summary):
    """The punches (and their sleeves at rest) in the disk plane at the end of the run, from the layout."""
    from analysis.core.config import disk_from_dict
    from analysis.core.kinematics import TIP_SPHERE_RATIO, punch_outline, to_axis_frame
    disk = disk_from_dict({k: v for k, v in cfg["disk"].items() if k != "name"})
    lay = cfg["layout"]
    theta = lay["omega"] * summary["sim_time_s"]
    x_axis = lay["x_axis0"] + lay["speed"] * summary["sim_time_s"]
    outline = punch_outline(disk, TIP_SPHERE_RATIO * disk.d)
    ro, u_plate = cfg["sleeve"]["outer_diameter"] / 2, disk.R - cfg["sleeve"]["rest_from_tip"]
    plate = np.array([[u_plate, -ro], [u_plate, ro]])
    for k in range(disk.N):
        phi = lay["phi0"] + k * lay["pitch"] - theta
        if abs(phi) > np.pi / 2:
            continue
        for shape, style in ((outline, dict(color="k", lw=1.0)), (plate, dict(color="r", lw=2.0))):
            xr, zr = to_axis_frame(shape if shape is plate else np.vstack([shape, shape[:1]]), phi)
            ax.plot(x_axis + xr[0], lay["H0"] + zr[0], **style)
    ax.plot([x_axis], [lay["H0"]], "k+")
    ax.set_ylim(-cfg["preset"]["depth"] - 5, lay["H0"] + 15)


def run(folder) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from analysis.holes.measure import load_run
    folder = Path(folder)
    cfg, summary, state = load_run(folder)
    pos, rad, z0 = state["pos"] * 1000, state["radius"] * 1000, float(state["z_surface"]) * 1000
    disp = np.linalg.norm(state["pos"] - state["initial_pos"], axis=1) * 1000
    L, W, _ = cfg["bed_size_mm"]
    written = []

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(11, 7.5), gridspec_kw={"height_ratios": [1, 1.1]})
    band = np.abs(pos[:, 1] - W / 2) < 1.5 * rad.mean()
    sc = a1.scatter(pos[band, 0], pos[band, 2] - z0, s=(rad[band] * 0.9) ** 2, c=np.minimum(disp[band], 30),
                    cmap="viridis", vmin=0, vmax=30)
    fig.colorbar(sc, ax=a1, label="displacement, mm (capped at 30)")
    for k, x in enumerate(summary["hole_x_mm"]):
        a1.axvline(x, color="0.6" if k < summary.get("lead_in", 0) else "k", ls=":", lw=0.8)
    draw_disk(a1, cfg, summary)
    a1.axhline(0, color="grey", lw=0.5)
    a1.axhline(-cfg["disk"]["penetration"], color="r", ls="--", lw=0.8, label="configured tip depth")
    a1.set_aspect("equal")
    a1.set_ylabel("z - surface, mm")
    a1.set_title(f"{summary['id']}: centre slab (|y - W/2| < 1.5 r); dotted: theoretical hole centres (grey: lead-in)")
    a1.legend(loc="lower right", fontsize=8)
    step = rad.min()          # the grains' tops (sphere caps), so a coarse grain shows over every cell it covers
    top = probed_surface(pos, rad, np.arange(step / 2, L, step), np.arange(step / 2, W, step), probe=0.0)
    im = a2.imshow((top - z0).T, origin="lower", extent=(0, L, 0, W), cmap="terrain", vmin=-60, vmax=20,
                   aspect="equal")
    fig.colorbar(im, ax=a2, label="top surface - undisturbed level, mm")
    a2.set_xlabel("x along the travel, mm")
    a2.set_ylabel("y, mm")
    a2.set_title(f"height map of the formed holes: the grains' tops on a {step:.1f} mm grid")
    fig.tight_layout()
    written.append(folder / "holes.png")
    fig.savefig(written[-1], dpi=110)
    plt.close(fig)

    ts = pd.read_csv(folder / "timeseries.csv")
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    for k, g in ts.groupby("punch"):
        g = g[g.tip_z_m < 0.01]
        axes[0].plot(g.axis_x_m * 1000, g.punch_fz_n, lw=0.8, label=f"punch {k}")
        axes[1].plot(g.axis_x_m * 1000, g.sleeve_force_n, lw=0.8)
        axes[2].plot(g.axis_x_m * 1000, g.sleeve_travel_m * 1000, lw=0.8)
    axes[0].set_ylabel("soil force on punch, z (N)")
    axes[1].set_ylabel("soil force on sleeve,\nalong the punch (N)")
    axes[2].set_ylabel("sleeve travel (mm)")
    axes[2].axhline(cfg["sleeve"]["travel"], color="r", ls="--", lw=0.8)
    axes[2].set_xlabel("disk axis x, mm")
    axes[0].legend(fontsize=8, ncol=3)
    fig.tight_layout()
    written.append(folder / "forces.png")
    fig.savefig(written[-1], dpi=110)
    plt.close(fig)
    return written


def sections(folders: list, labels: list[str], out: Path, hole: int = 4, half_width: float = 120.0) -> Path:
    """One measured hole's section per run, stacked: the grains of a slab 1.5 grain radii either side of the hole's
    centre line, across ± `half_width` mm of travel, coloured by the depth they started at, with the hole's
    effective depth from the surface (L2_surface, dashed) and its deepest probed point (bottom, red). Where soil
    carried down from the surface or a plug pushed ahead of the punch ends up, and how far the hole kept its depth."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from analysis.holes.measure import load_run
    fig, axes = plt.subplots(len(folders), 1, figsize=(8, 2.6 * len(folders) + 0.6), squeeze=False)
    sc = None
    for ax, folder, label in zip(axes[:, 0], folders, labels):
        cfg, _, state = load_run(Path(folder))
        holes = pd.read_csv(Path(folder) / "holes.csv", comment="#")
        h = holes[(holes.hole == hole) & holes.found]
        h = h if len(h) else holes[holes.found].iloc[:1]
        pos, rad, z0 = state["pos"] * 1000, state["radius"] * 1000, float(state["z_surface"]) * 1000
        start = state["initial_pos"][:, 2] * 1000 - z0
        x0, W = float(h.x.iloc[0]), cfg["bed_size_mm"][1]
        slab = (np.abs(pos[:, 1] - W / 2) < 1.5 * rad.mean()) & (np.abs(pos[:, 0] - x0) < half_width)
        sc = ax.scatter(pos[slab, 0] - x0, pos[slab, 2] - z0, s=(rad[slab] * 0.9) ** 2, c=start[slab],
                        cmap="viridis", vmin=-cfg["preset"]["depth"], vmax=0)
        ax.axhline(-float(h.L2_surface.iloc[0]), color="k", ls="--", lw=0.8, label="L2 from the surface")
        ax.axhline(-float(h.bottom.iloc[0]), color="r", lw=0.8, label="bottom")
        ax.axhline(-cfg["disk"]["penetration"], color="r", ls=":", lw=0.8, label="tip depth P")
        ax.set_xlim(-half_width, half_width)
        ax.set_ylim(-cfg["preset"]["depth"], 30)
        ax.set_aspect("equal")
        ax.set_ylabel("z - surface, mm")
        ax.set_title(f"{label}: hole {int(h.hole.iloc[0])}", fontsize=9)
    axes[0, 0].legend(loc="lower right", fontsize=7)
    axes[-1, 0].set_xlabel("x from the hole's centre, mm")
    fig.colorbar(sc, ax=axes[:, 0], label="the grain's starting depth, mm")
    out = Path(out)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
