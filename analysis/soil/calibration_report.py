"""The calibration summary: per soil the accepted cohesion, cone index and bed density against seed 001
Table 2, and the resistance-vs-depth plot of the accepted cone runs, averaged over their packing seeds
(results/calibration/)."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from analysis.soil.calibrate import TOLERANCE, cone_result_name
from analysis.core.schema import ROOT
from analysis.core.soil_config import SOIL_COLOURS, load_soil
from analysis.core.io import atomic_csv, read_table, say, shown, stamp
from analysis.core.bed_spec import BED_DIR, CONE_DIR

CAL = ROOT / "results/calibration"


def accepted(soil: str) -> pd.DataFrame | None:
    """The runs (one per packing seed) of the last iteration whose seed-mean is within the tolerance, or None.
    A calibration on one seed has one row per iteration and no mean column."""
    path = CAL / f"{soil}.csv"
    if not path.exists():
        return None
    t = read_table(path)
    t = t.assign(mean_kpa=t["mean_kpa"] if "mean_kpa" in t else t.cone_index_kpa)
    ok = t[t.error.abs() <= TOLERANCE]
    return t[t.iteration == ok.iteration.iloc[-1]] if len(ok) else None


def core_density(bed: str, grain_density: float, moisture: float, diameter=0.0505, height=0.05, top=0.025,
                 n_points=200000, seed=0) -> float:
    """Dry bulk density of a virtual cutting-ring core (100 cm³ ring, as field density is sampled) at the
    bed's centre, `top` below the surface: solid fraction by Monte Carlo points × grain density / (1 + w)."""
    from scipy.spatial import cKDTree
    data = np.load(BED_DIR / f"{bed}.npz")
    pos, rad = data["pos"], data["radius"]
    cx, cy = pos[:, 0].mean(), pos[:, 1].mean()
    z_top = np.percentile(pos[:, 2] + rad, 95) - top
    rng = np.random.default_rng(seed)
    r = diameter / 2 * np.sqrt(rng.uniform(size=n_points))
    a = rng.uniform(0, 2 * np.pi, n_points)
    pts = np.column_stack([cx + r * np.cos(a), cy + r * np.sin(a), z_top - rng.uniform(0, height, n_points)])
    d, i = cKDTree(pos).query(pts, k=8)
    solid = (d < rad[i]).any(axis=1).mean()
    return float(solid * grain_density / (1 + moisture))


def run(out=CAL) -> pd.DataFrame:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = []
    kept = read_table(out / "summary.csv").set_index("soil") if (out / "summary.csv").exists() else pd.DataFrame()
    fig, ax = plt.subplots(figsize=(6, 5))
    for soil, colour in SOIL_COLOURS.items():
        runs = accepted(soil)
        if runs is None:
            continue
        a = runs.iloc[0]
        missing = [bed for bed in runs.bed if not all((BED_DIR / f"{bed}{x}").exists() for x in (".json", ".npz"))]
        cones, profiles = [], []
        for r in runs.itertuples():
            stem = cone_result_name(r.bed, r.cone_scale, r.speed_m_s, r.normal_cohesion_pa)    # may hold a "."
            cones.append(json.loads((CONE_DIR / f"{stem}.json").read_text()))
            prof = read_table(CONE_DIR / f"{stem}.csv")
            prof = prof[(prof.base_depth_m >= 0) & (prof.base_depth_m <= 0.15)]
            profiles.append(prof.groupby((prof.base_depth_m * 1000 // 10) * 10 + 5).resistance_pa.mean() / 1000)
        mean = pd.concat(profiles, axis=1).mean(axis=1)
        ax.plot(mean.values, mean.index, color=colour, label=f"{soil}: {a.mean_kpa:.0f} kPa")
        ax.axvline(a.target_kpa, color=colour, ls=":", lw=1)
        if missing:                      # the beds are settled on another machine (results/cache/beds is not in git)
            if soil in kept.index:
                say(f"calibration-report: {soil}'s beds are not on this machine ({missing[0]}): its row kept from "
                    f"{shown(out / 'summary.csv')}")
                rows.append({"soil": soil, **kept.loc[soil].to_dict()})
            else:
                say(f"calibration-report: {soil}'s beds are not on this machine ({missing[0]}) and summary.csv has no "
                    "row of it: left out")
            continue
        metas = [json.loads((BED_DIR / f"{bed}.json").read_text()) for bed in runs.bed]
        target = load_soil(soil)
        core = np.mean([core_density(m["key"], m["grain_density"], target.moisture) for m in metas])
        whole = np.mean([m["whole_bed_dry_bulk_density"] for m in metas])
        rows.append({"soil": soil, "lateral": a.get("lateral", "walls"), "seeds": len(runs),
                     "normal_cohesion_kpa": round(a.normal_cohesion_pa / 1000, 2),
                     "friction_deg": a.friction_deg, "rolling_friction": a.rolling_friction,
                     "cone_index_kpa": round(a.mean_kpa, 1),
                     "cone_index_sd_kpa": round(runs.cone_index_kpa.std(ddof=1), 1) if len(runs) > 1 else None,
                     "target_kpa": a.target_kpa, "ci_error_percent": round(100 * a.error, 1),
                     "dry_density_interior": round(np.mean([m["dry_bulk_density"] for m in metas])),
                     "dry_density_core": round(core),
                     "density_error_core_percent": round(100 * (core / target.bulk_density - 1), 1),
                     "dry_density_whole_bed": round(whole), "target_density": target.bulk_density,
                     "density_error_whole_bed_percent": round(100 * (whole / target.bulk_density - 1), 1),
                     "porosity": round(np.mean([m["porosity"] for m in metas]), 3),
                     "grain_density": round(np.mean([m["grain_density"] for m in metas])),
                     "particles": round(np.mean([m["particles"] for m in metas])),
                     "bed_settle_s": round(np.mean([m["wall_s"] for m in metas])),
                     "cone_run_s": round(np.mean([c["wall_s"] for c in cones])), "cone_threads": cones[0]["threads"],
                     "cone_to_particle": round(cones[0]["cone_to_particle"], 2),
                     "iterations": int(read_table(CAL / f"{soil}.csv").iteration.max())})
    ax.invert_yaxis()
    ax.set_xlabel("cone resistance, kPa (10 mm bins; dotted: Table 2 cone index)")
    ax.set_ylabel("cone base depth, mm")
    ax.set_title("Virtual cone in the calibrated beds (mean over the seeds)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "resistance_depth.png", dpi=120)
    table = pd.DataFrame(rows)
    atomic_csv(table, out / "summary.csv", stamp("./holes calibration-report"))
    return table
