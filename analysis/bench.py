"""Speed against error (issue 7): one clay hole at several particle sizes, time steps and contact stiffnesses
(configs/studies/speed_vs_error.toml, run as a study), each case's cost beside the error of its hole metrics
against the finest case and against the field mean (seed 001 Table 3).

    ./holes bench speed-vs-error      ->  results/bench/speed_vs_error.csv and .png

Error of a case: for each of L0, L1, L2 and h1 the difference from the reference (mm), and their mean
relative size |m - ref| / ref (the `err_*_pct` columns), which the Pareto plot shows against wall time.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.config import ROOT, load_preset, load_resolution, load_soil
from analysis.io import atomic_csv, machine, read_table, stamp

METRICS = ("L0", "L1", "L2", "h1")
STUDY = ROOT / "configs/studies/speed_vs_error.toml"


def with_numerics(table: pd.DataFrame) -> pd.DataFrame:
    """The study table plus each case's grain radius, time-step factor and contact modulus (from the preset
    and soil a case did not override)."""
    t = table.copy()
    preset = t["preset"].map(load_preset)

    def value(field: str, default: pd.Series) -> pd.Series:
        """The case's own value of a field where it set one, else the default."""
        given = t[field] if field in t else pd.Series(np.nan, index=t.index, dtype=object)
        return given.where(given.notna(), default)

    t["resolution"] = value("resolution", preset.map(lambda p: p.resolution))
    t["radius_mm"] = t["resolution"].map(lambda r: 1000 * load_resolution(r).radius)
    t["dt_safety"] = value("dt_safety", preset.map(lambda p: p.dt_safety)).astype(float)
    t["young_pa"] = value("soil.young", t["soil"].map(lambda s: load_soil(s).young)).astype(float)
    return t


def errors(table: pd.DataFrame, field: pd.DataFrame) -> pd.DataFrame:
    """Each case's error against the finest case (the smallest grains at the base time step and modulus)
    and against the field mean of its soil."""
    t = with_numerics(table)
    base = t[(t.dt_safety == t.dt_safety.mode()[0]) & (t.young_pa == t.young_pa.mode()[0])]
    finest = base.loc[base.radius_mm.idxmin()]
    t["reference"] = finest["run"]
    means = field[field["run"].astype(str) == "mean"].set_index("soil")
    for m in METRICS:
        t[f"{m}_vs_finest"] = t[m] - finest[m]
        t[f"{m}_vs_field"] = t[m] - t["soil"].map(means[m])
    t["err_finest_pct"] = 100 * np.mean([np.abs(t[f"{m}_vs_finest"]) / abs(finest[m]) for m in METRICS], axis=0)
    t["err_field_pct"] = 100 * np.mean([np.abs(t[f"{m}_vs_field"]) / t["soil"].map(means[m]).abs()
                                        for m in METRICS], axis=0)
    t["particle_steps_per_s"] = t.particles * t.steps / t.wall_s
    t["machine"] = machine()
    return t


def pareto(t: pd.DataFrame, err: str) -> pd.Series:
    """True for the cases no other case beats in both wall time and error."""
    wall, e = t.wall_s.to_numpy(), t[err].to_numpy()
    return pd.Series([not np.any((wall <= w) & (e <= x) & ((wall < w) | (e < x))) for w, x in zip(wall, e)],
                     index=t.index)


def label(r) -> str:
    return f"r {r.radius_mm:g} mm, dt {r.dt_safety:g}, E {r.young_pa / 1e6:g} MPa"


def plot(t: pd.DataFrame, path: Path, note: str):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    for ax, err, what in zip(axes, ("err_finest_pct", "err_field_pct"), ("the finest case", "the field mean")):
        front = pareto(t, err)
        ax.scatter(t.wall_s, t[err], c=np.where(front, "tab:red", "tab:blue"))
        line = t[front].sort_values("wall_s")
        ax.plot(line.wall_s, line[err], "r--", lw=1, label="Pareto front")
        for r in t.itertuples():
            ax.annotate(label(r), (r.wall_s, getattr(r, err)), fontsize=7, xytext=(4, 4), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_xlabel("wall time, s")
        ax.set_ylabel(f"mean |error| of L0, L1, L2, h1 against {what}, %")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"speed against error, one clay hole\n{note}", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(workers: int, threads: int, runs_dir=None, bed_dir=None, out=None, study_path=STUDY) -> int:
    """Run the study's cases (finished ones are reused), then write the speed-vs-error table and plot."""
    from analysis import study
    from analysis.compare import field_table
    out = Path(out or ROOT / "results/bench")
    code = study.run(study_path, workers, threads, None, runs_dir, bed_dir, out / "cases")
    name = study.load_study(study_path)[0]["name"]
    path = out / "cases" / f"{name}.csv"
    if not path.exists():
        return 1
    t = errors(read_table(path), field_table())
    note = stamp("./holes bench speed-vs-error")
    cols = ["run", "soil", "resolution", "radius_mm", "dt_safety", "young_pa", "particles", "steps", "wall_s",
            "threads", "particle_steps_per_s", *METRICS, *(f"{m}_vs_finest" for m in METRICS),
            *(f"{m}_vs_field" for m in METRICS), "err_finest_pct", "err_field_pct", "reference", "machine"]
    atomic_csv(t[cols].round(4), out / f"{name}.csv", note)
    plot(t, out / f"{name}.png", note)
    print(t[["run", "radius_mm", "dt_safety", "young_pa", "particles", "wall_s", "err_finest_pct",
             "err_field_pct"]].round(2).to_string(index=False))
    return code
