"""How far a cone's bond damage reaches: the damage maps `./holes cone ... --damage` writes (scripts/cone.py,
`<stem>-damage.csv`: the bed's first bonds by depth band and ring round the cone's axis, and how many the
penetration broke), summarised per run and plotted as the broken fraction against the distance from the axis.

    ./holes cone-damage results/cone_speed      -> damage_summary.csv, damage.png in that folder
"""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from analysis.core.schema import ConfigError
from analysis.core.io import atomic_csv, stamp

FAR = 0.10          # broken fraction drawn as the plot's guide line
REACH = 0.9         # the reach: the radius holding this share of the broken bonds


def maps(folder: Path) -> list[tuple[Path, dict, pd.DataFrame]]:
    """Every damage map in `folder`, read once: (its path, its cone run's summary JSON, the map)."""
    found = [(path, json.loads(path.with_name(path.name.replace("-damage.csv", ".json")).read_text()), pd.read_csv(path))
             for path in sorted(folder.glob("*-damage.csv"))]
    if not found:
        raise ConfigError(f"cone-damage: no *-damage.csv in {folder}; run `./holes cone ... --damage --out {folder}`")
    return found


def bed_of(run: dict) -> tuple[str, float, float]:
    """A cone run's bed resolution and its length and width (mm), from the bed key soil-res-LxWxD-..."""
    _, resolution, size = run["bed"].split("-")[:3]
    length, width = (float(v) for v in size.split("x")[:2])
    return resolution, length, width


def ring_width(t: pd.DataFrame) -> float:
    """A damage map's ring width round the cone's axis, mm (scripts/cone.py's DAMAGE_RING)."""
    return float((t.r_hi_mm - t.r_lo_mm).iloc[0])


def near_surface(t: pd.DataFrame) -> pd.DataFrame:
    """A damage map's bonds and broken bonds per ring over the cone index's depths, 0-150 mm."""
    return t[t.depth_hi_mm <= 150].groupby("r_lo_mm")[["bonds", "broken"]].sum()


def summary(found: list) -> pd.DataFrame:
    """One row per damage map (`maps`): the cone run's bed, speed and cone index, the bonds broken over the
    whole bed, at 0-150 mm depth, and the reach: the radius within which REACH of the broken bonds at 0-150 mm
    lie (the outer edge of that ring), against the bed's half-width."""
    rows = []
    for path, run, t in found:
        top = near_surface(t)
        share = top.broken.cumsum() / top.broken.sum()
        _, length, width = bed_of(run)
        rows.append({"bed": run["bed"], "speed_m_s": run["speed"], "cohesion_kpa": run["cohesion_pa"] / 1000,
                     "cone_index_kpa": run["cone_index_pa"] / 1000, "bonds": int(t.bonds.sum()),
                     "broken_fraction": t.broken.sum() / t.bonds.sum(),
                     "broken_fraction_0_150mm": top.broken.sum() / top.bonds.sum(),
                     "reach_mm": float(share.index[share >= REACH][0]) + ring_width(t),
                     "half_width_mm": min(length, width) / 2, "wall_s": run["wall_s"], "map": path.name})
    return pd.DataFrame(rows)


def plot(found: list, out: Path) -> None:
    """Broken fraction (0-150 mm deep) against the distance from the cone's axis, one line per map (`maps`)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for _, run, t in found:
        top = near_surface(t)
        top = top[top.bonds >= 20]                          # rings with too few bonds say nothing
        resolution, length, _ = bed_of(run)
        ax.plot(top.index + ring_width(t) / 2, top.broken / top.bonds, marker="o", ms=3,
                label=f"{run['soil']}, {resolution} {length:g} mm bed, {run['speed']:g} m/s, "
                      f"{run['cohesion_pa'] / 1000:g} kPa bonds: index {run['cone_index_pa'] / 1000:.0f} kPa")
    ax.axhline(FAR, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("distance of the bond from the cone's axis (mm; nearest periodic image)")
    ax.set_ylabel("bonds broken, 0-150 mm deep (fraction)")
    ax.set_title("How far the cone breaks the bed's bonds")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def run(folder: Path) -> pd.DataFrame:
    found = maps(folder)
    table = summary(found)
    atomic_csv(table.round(4), folder / "damage_summary.csv", stamp(f"./holes cone-damage {folder}"))
    plot(found, folder / "damage.png")
    return table
