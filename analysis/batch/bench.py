"""Cost against error. The ladder: one clay hole at several particle sizes, time steps and contact
stiffnesses (configs/studies/speed_vs_error.toml, run as a study), each case's cost beside the error of its hole
metrics against the finest case and against the field mean (seed 001 Table 3), and the economies. The presets
against each other and against converged grains, and the convergence in grain size: bench_reference.py.

    ./holes bench ladder              ->  results/bench/ladder/speed_vs_error{,_packings}{.csv,_settings.csv,.png}
    ./holes bench economies           ->  results/bench/economies.csv and .png

Error of a case: for each of L0, L1, L2 and h1 the difference from the reference (mm), and their mean size
relative to the field's mean of each metric, mean |m - ref| / field (the `err_*_pct` columns). The field mean
is the scale for both references, since a simulated h1 can be near zero and would make a relative error
meaningless. A setting (grain radius, time-step factor, contact modulus) may have several packings (bed
seeds; configs/studies/speed_vs_error_packings.toml, its own study and tables): the reference is the finest
setting's mean over its packings, and `<study>_settings.csv` sets each setting's mean difference from it
beside its standard error, the packing scatter a resolution's error must beat. The Pareto plot shows the
settings' means.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.config import load_preset, load_resolution
from analysis.core.schema import ROOT
from analysis.core.soil_config import load_soil
from analysis.core.io import atomic_csv, machine, read_table, stamp

METRICS = ("L0", "L1", "L2", "h1")
STUDY = ROOT / "configs/studies/speed_vs_error.toml"
PACKINGS = ROOT / "configs/studies/speed_vs_error_packings.toml"
SETTING = ["radius_mm", "dt_safety", "young_pa"]
ECONOMIES = ROOT / "configs/studies/economies.toml"
CONVERGENCE = ROOT / "configs/studies/convergence.toml"
SCENE_FIELDS = ("width", "depth", "lead_in", "mode")     # what an economies case may change (else: a seed)


def run_cost(summary: dict, bed_meta: dict | None = None) -> dict:
    """One finished disk run's cost (`./holes bench runs`, results/bench/runs.csv): its grains, steps and wall
    time, the wall and CPU time per measured hole (the run's own time, without settling its bed, over the holes
    after the lead-in ones) and per 200 mm of travel; the bed's settling time beside it when the bed's metadata
    is at hand (a cached bed is settled once for every run on it).

    >>> c = run_cost({"id": "r", "soil": "clay", "preset": "quick", "mode": "prescribed", "bed": "b",
    ...               "particles": 10, "steps": 5, "dt": 1e-5, "travel_mm": 400.0, "wall_s": 600.0, "cpu_s": 900.0,
    ...               "threads": 2, "particle_steps_per_s": 1.0, "holes": 3, "lead_in": 1}, {"wall_s": 120.0})
    >>> c["measured_holes"], c["wall_s_per_measured_hole"], c["cpu_s_per_measured_hole"], c["bed_wall_s"]
    (2, 300.0, 450.0, 120.0)
    """
    m, awake = summary, summary.get("awake")
    measured = m["holes"] - m["lead_in"]
    return {"run": m["id"], "soil": m["soil"], "preset": m["preset"], "mode": m["mode"], "bed": m["bed"],
            "particles": m["particles"], "steps": m["steps"], "dt_s": m["dt"], "travel_mm": round(m["travel_mm"]),
            "wall_s": round(m["wall_s"]), "cpu_s": round(m["cpu_s"]) if m.get("cpu_s") is not None else np.nan,
            "threads": m["threads"], "particle_steps_per_s": round(m["particle_steps_per_s"]),
            "wall_s_per_hole_200mm": round(m["wall_s"] * 200 / m["travel_mm"]), "measured_holes": measured,
            "wall_s_per_measured_hole": round(m["wall_s"] / measured, 1) if measured else np.nan,
            "cpu_s_per_measured_hole": (round(m["cpu_s"] / measured, 1) if measured and m.get("cpu_s") is not None
                                        else np.nan),
            "bed_wall_s": round(bed_meta["wall_s"], 1) if bed_meta else np.nan,
            # --awake: the window (mm behind, ahead) and the share of grain-steps awake; else all awake
            "awake_mm": f"{awake['behind_mm']:g},{awake['ahead_mm']:g}" if awake else "",
            "awake_fraction": round(awake["awake_fraction"], 3) if awake else 1.0}


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
    """Each case's error against the finest setting (the smallest grains at the base time step and modulus;
    the mean over its packings) and against the field mean of its soil, both in units of the field mean."""
    t = with_numerics(table)
    base = t[(t.dt_safety == t.dt_safety.mode()[0]) & (t.young_pa == t.young_pa.mode()[0])]
    finest = base[base.radius_mm == base.radius_mm.min()]
    t["reference"] = " ".join(finest["run"])
    means = field[field["run"].astype(str) == "mean"].set_index("soil")
    for m in METRICS:
        t[f"{m}_vs_finest"] = t[m] - finest[m].mean()
        t[f"{m}_vs_field"] = t[m] - t["soil"].map(means[m])
    scale = {m: t["soil"].map(means[m]).abs() for m in METRICS}
    for ref in ("finest", "field"):
        t[f"err_{ref}_pct"] = 100 * np.mean([np.abs(t[f"{m}_vs_{ref}"]) / scale[m] for m in METRICS], axis=0)
    t["particle_steps_per_s"] = t.particles * t.steps / t.wall_s
    t["machine"] = machine()
    return t


def settings(t: pd.DataFrame) -> pd.DataFrame:
    """One row per setting of the `errors` table, its packings pooled: their number, mean cost, each metric's
    mean and SD, and the mean's difference from the finest setting's mean (`d<m>`) with its standard error
    (`d<m>_se`, from both settings' packing SDs; empty where either has one packing)."""
    field = t.assign(**{f"{m}_field": t[m] - t[f"{m}_vs_field"] for m in METRICS})   # the case's field mean
    s = field.groupby(SETTING, sort=False).agg(
        resolution=("resolution", "first"), packings=("run", "size"), runs=("run", " ".join),
        particles=("particles", "mean"), steps=("steps", "mean"), wall_s=("wall_s", "mean"),
        particle_steps_per_s=("particle_steps_per_s", "mean"),
        **{m: (m, "mean") for m in METRICS}, **{f"{m}_sd": (m, "std") for m in METRICS},
        **{f"{m}_field": (f"{m}_field", "first") for m in METRICS}).reset_index()
    ref = s[s.runs.str.split().map(set) == set(t.reference.iloc[0].split())].iloc[0]
    for m in METRICS:
        s[f"d{m}"] = s[m] - ref[m]
        s[f"d{m}_se"] = np.sqrt(s[f"{m}_sd"] ** 2 / s.packings + ref[f"{m}_sd"] ** 2 / ref.packings)
    scale = {m: s[f"{m}_field"].abs() for m in METRICS}
    s["err_finest_pct"] = 100 * np.mean([s[f"d{m}"].abs() / scale[m] for m in METRICS], axis=0)
    s["err_field_pct"] = 100 * np.mean([(s[m] - s[f"{m}_field"]).abs() / scale[m] for m in METRICS], axis=0)
    s = s.drop(columns=[f"{m}_field" for m in METRICS])
    s["machine"] = machine()
    return s


def pareto(t: pd.DataFrame, err: str) -> pd.Series:
    """True for the cases no other case beats in both wall time and error."""
    wall, e = t.wall_s.to_numpy(), t[err].to_numpy()
    return pd.Series([not np.any((wall <= w) & (e <= x) & ((wall < w) | (e < x))) for w, x in zip(wall, e)],
                     index=t.index)


def label(r) -> str:
    return (f"r {r.radius_mm:g} mm, dt {r.dt_safety:g}, E {r.young_pa / 1e6:g} MPa"
            + (f" ({r.packings} packings)" if r.packings > 1 else ""))


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save(fig, path: Path, title: str):
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    pyplot().close(fig)


def plot(t: pd.DataFrame, path: Path, note: str):
    fig, axes = pyplot().subplots(1, 2, figsize=(13, 5))
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
    save(fig, path, f"speed against error, one clay hole\n{note}")


def economies(table: pd.DataFrame) -> pd.DataFrame:
    """Each case beside the reference (seed 1, no scene field changed): its cost as a ratio of particle-steps
    (contention-free) and of CPU time (against the mean CPU time of the reference's packings that recorded
    one; wall time where none did), its slip between holes (a free-rolling disk's own), and the change of each
    metric, case − reference; last, the reference's seed-to-seed SD of each metric, the scatter a change is
    set against."""
    t = table.copy()
    for f in SCENE_FIELDS:
        t[f] = t[f] if f in t else np.nan
    t["cpu_s"] = t["cpu_s"] if "cpu_s" in t else np.nan
    t["cost_s"] = t.cpu_s.fillna(t.wall_s)
    plain = t[list(SCENE_FIELDS)].isna().all(axis=1)
    ref = t[plain & (t.seed == 1)].iloc[0]
    timed = t[plain & t.cpu_s.notna()]
    ref_cost = timed.cpu_s.mean() if len(timed) else ref.wall_s
    rows = []
    for r in t[~plain].itertuples():
        change = next(f for f in SCENE_FIELDS if pd.notna(getattr(r, f)))
        rows.append({"run": r.run, "change": f"{change} = {getattr(r, change)}", "particles": r.particles,
                     "steps": r.steps, "cost_s": r.cost_s,
                     "particle_steps_ratio": r.particles * r.steps / (ref.particles * ref.steps),
                     "cost_ratio": r.cost_s / ref_cost, "slip_holes": getattr(r, "slip_holes", np.nan),
                     **{f"d{m}": getattr(r, m) - ref[m] for m in METRICS}})
    seeds = t[plain]
    rows.insert(0, {"run": ref.run, "change": "reference", "particles": ref.particles, "steps": ref.steps,
                    "cost_s": ref_cost, "particle_steps_ratio": 1.0, "cost_ratio": 1.0,
                    "slip_holes": ref.get("slip_holes", np.nan), **{f"d{m}": 0.0 for m in METRICS}})
    rows.append({"run": " ".join(seeds.run), "change": f"seed-to-seed SD ({len(seeds)} packings)",
                 **{f"d{m}": seeds[m].std(ddof=1) for m in METRICS}})
    return pd.DataFrame(rows)


def plot_economies(e: pd.DataFrame, path: Path, note: str):
    """Each economy's change of L0, L1, L2, h1 beside the packings' scatter (± 1 SD, grey), and its cost."""
    plt = pyplot()
    cases, sd = e.iloc[1:-1], e.iloc[-1]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 4.8), gridspec_kw={"width_ratios": [2, 1]})
    x = np.arange(len(METRICS))
    width = 0.8 / len(cases)
    for i, m in enumerate(METRICS):
        ax.add_patch(plt.Rectangle((i - 0.45, -sd[f"d{m}"]), 0.9, 2 * sd[f"d{m}"], color="0.88", zorder=0))
    for k, r in enumerate(cases.itertuples()):
        ax.bar(x - 0.4 + (k + 0.5) * width, [getattr(r, f"d{m}") for m in METRICS], width, label=r.change)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, METRICS)
    ax.set_ylabel("case − reference, mm (grey: ± 1 SD over packings)")
    ax.legend(fontsize=8)
    y = np.arange(len(cases))
    bx.barh(y + 0.2, cases.particle_steps_ratio, 0.4, label="particle-steps")
    bx.barh(y - 0.2, cases.cost_ratio, 0.4, label="CPU time")
    bx.axvline(1, color="k", lw=0.8)
    bx.set_yticks(y, cases.change)
    bx.set_xlabel("cost / reference's cost")
    bx.legend(fontsize=8)
    save(fig, path, f"economies, one clay hole at r = 8 mm (the missing bar: no hole found)\n{note}")


def study_table(study_path: Path, workers: int, threads: int, runs_dir, bed_dir, out: Path, no_run: bool):
    """Run a study's cases (finished ones are reused; none with no_run) into out/cases: the exit code, the
    study's name and its table (None if no case finished)."""
    from analysis.batch import study
    code = study.run(study_path, workers, threads, None, runs_dir, bed_dir, out / "cases", no_run)
    name = study.load_study(study_path)[0]["name"]
    path = out / "cases" / f"{name}.csv"
    return code, name, (read_table(path) if path.exists() else None)


def run_economies(workers: int, threads: int, runs_dir=None, bed_dir=None, out=None, no_run=False) -> int:
    """Run the economies study, then write results/bench/economies.csv and .png."""
    out = Path(out or ROOT / "results/bench")
    code, _, table = study_table(ECONOMIES, workers, threads, runs_dir, bed_dir, out, no_run)
    if table is None:
        return 1
    t = economies(table)
    t["machine"] = machine()
    note = stamp("./holes bench economies")
    atomic_csv(t.round(4), out / "economies.csv", note)
    plot_economies(t, out / "economies.png", note)
    print(t.drop(columns=["machine"]).round(2).to_string(index=False))
    return code


def run(workers: int, threads: int, runs_dir=None, bed_dir=None, out=None, no_run=False,
        study_paths=(STUDY, PACKINGS)) -> int:
    """Run each study's cases (finished ones are reused), then write its speed-vs-error tables and plot. Studies
    are not pooled: a study's cases share one soil calibration, and two studies made at different commits need
    not (speed_vs_error's cases were made with the first calibration's clay bond, its packings study with the
    third's)."""
    from analysis.holes.compare import field_table
    out = Path(out or ROOT / "results/bench/ladder")
    codes = []
    for study_path in study_paths:
        code, name, table = study_table(study_path, workers, threads, runs_dir, bed_dir, out, no_run)
        codes.append(code if table is not None else 1)
        if table is None:
            continue
        t = errors(table, field_table())
        note = stamp("./holes bench ladder")
        cols = ["run", "soil", "seed", "resolution", "radius_mm", "dt_safety", "young_pa", "particles", "steps",
                "wall_s", "threads", "particle_steps_per_s", *METRICS, *(f"{m}_vs_finest" for m in METRICS),
                *(f"{m}_vs_field" for m in METRICS), "err_finest_pct", "err_field_pct", "reference", "machine"]
        atomic_csv(t[cols].round(4), out / f"{name}.csv", note)
        st = settings(t)
        atomic_csv(st.round(4), out / f"{name}_settings.csv", note)
        plot(st, out / f"{name}.png", note)
        print(f"{name}:")
        print(st[["resolution", *SETTING, "packings", "particles", "wall_s", *METRICS, *(f"d{m}" for m in METRICS),
                  *(f"d{m}_se" for m in METRICS), "err_finest_pct"]].round(1).to_string(index=False))
    return max(codes)
