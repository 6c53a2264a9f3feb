"""What fills a hole after its punch has left: the grains inside the punch's own volume at its deepest point, and
where they came from (their places in the settled bed). No YADE.

    ./holes refill results/runs/<id> ...      # refill.csv in --out (default results/comparison/refill)

The punch stands vertical at its deepest, at the hole's layout x, the strip's middle across it. Its volume there, a
cylinder of diameter D from TOP mm below the undisturbed surface (under the ring the sleeve's plate presses) and
its end cone of height h down to the tip at the penetration, was the punch's own: a grain lying wholly inside it
now came back after the punch left. `refill` is those grains' solid volume over the solid volume the same volume held
in the settled bed: 0 when the hole stands open, 1 when it is as full as the bed was. A grain came `from_ring` when it
started outside the punch's radius, `from_above` when it started more than a grain diameter higher than it lies now;
`origin_depth` and `origin_r` are the refilling grains' median start below the surface and from the axis.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import atomic_csv, stamp
from analysis.holes.measure import hole_centres, hole_tool, load_run

TOP = 20.0          # mm below the undisturbed surface: under the plate's ring, which subsides by up to about 20 mm
COLUMNS = ["run", "soil", "seed", "hole", "x", "grains", "refill", "from_ring", "from_above", "origin_depth",
           "origin_r"]


def refill_hole(pos, pos0, rad, x: float, y: float, z_surface: float, D: float, tip: float, h: float) -> dict:
    """The grains (positions now `pos` and in the settled bed `pos0`, radii `rad`, mm) wholly inside the punch standing
    on the vertical axis (x, y), its tip `tip` mm below `z_surface`, its end cone h high, from TOP mm down (module
    doc).

    >>> pos0 = np.array([[0.0, 0, -30], [0, 0, -40], [30, 0, -5], [0, 0, -75]])   # three in the punch's way, one beside
    >>> now = pos0 + [[0, 0, -200], [0, 0, -200], [-30, 0, -30], [0, 0, -200]]
    >>> row = refill_hole(now, pos0, np.full(4, 5.0), 0, 0, 0, 50, 80, 20)
    >>> row["grains"], round(row["refill"], 3), row["from_ring"], row["from_above"], row["origin_r"]
    (1, 0.333, 1, 1, 30.0)
    >>> refill_hole(pos0, pos0, np.full(4, 5.0), 20, 0, 0, 50, 80, 20)["grains"]      # the tip is narrower: off axis
    2
    """
    def inside(p):
        r = np.hypot(p[:, 0] - x, p[:, 1] - y)
        depth = z_surface - p[:, 2]
        radius = np.minimum(D / 2, D / 2 * (tip - depth) / h)          # the cylinder, then the cone to the tip
        return (r <= radius - rad) & (depth >= TOP + rad)

    now, before = inside(pos), inside(pos0)
    volume = rad ** 3
    r0 = np.hypot(pos0[now, 0] - x, pos0[now, 1] - y)
    fell = pos0[now, 2] - pos[now, 2]                      # how far each fell since the bed settled
    return {"grains": int(now.sum()),
            "refill": float(volume[now].sum() / volume[before].sum()) if before.any() else np.nan,
            "from_ring": int((r0 > D / 2).sum()), "from_above": int((fell > 2 * rad[now]).sum()),
            "origin_depth": float(np.median(z_surface - pos0[now, 2])) if now.any() else np.nan,
            "origin_r": float(np.median(r0)) if now.any() else np.nan}


def refill_run(folder) -> pd.DataFrame:
    """One row per measured hole of a finished run (module doc)."""
    cfg, summary, state = load_run(folder)
    if "z_surface" not in state or "disk" not in cfg:
        raise ValueError(f"{folder}: not a disk run with its undisturbed level (state.npz z_surface): allowed a disk "
                         "run's folder")
    pos, pos0, rad = state["pos"] * 1000, state["initial_pos"] * 1000, state["radius"] * 1000
    D = hole_tool(cfg)[0]
    y = cfg["bed_size_mm"][1] / 2
    xs = hole_centres(summary)[summary.get("lead_in", 0):]
    rows = [{"run": summary["id"], "soil": cfg["soil"]["name"], "seed": cfg["seed"], "hole": k + 1, "x": x,
             **refill_hole(pos, pos0, rad, x, y, float(state["z_surface"]) * 1000, D,
                           cfg["disk"]["penetration"], cfg["disk"]["h"])}
            for k, x in enumerate(xs)]
    return pd.DataFrame(rows, columns=COLUMNS)


def run(folders, out: Path) -> pd.DataFrame:
    """refill.csv in `out`: every measured hole of the given finished runs."""
    table = pd.concat([refill_run(f) for f in folders], ignore_index=True).round(3)
    out.mkdir(parents=True, exist_ok=True)
    command = "./holes refill " + " ".join(Path(f).name for f in folders)
    atomic_csv(table, out / "refill.csv", stamp(command) + f"; grains back inside the punch's volume from {TOP:g} mm "
               "below the surface to its tip after it left (analysis/holes/refill.py); mm")
    return table
