"""Cost against error against a reference: the presets against each other and against converged grains (the main
job's choice), and the convergence in grain size (analysis/batch/bench.py: the ladder, the economies and the
helpers both use).

    ./holes bench convergence         ->  results/bench/convergence.csv and .png
    ./holes bench presets             ->  results/bench/presets.csv, presets_summary.csv and .png
    ./holes bench speed-vs-error      ->  results/bench/speed_vs_error.csv, speed_vs_error_summary.csv and .png
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.batch.bench import (CONVERGENCE, pyplot, run_cost, save, study_table,
                                  with_numerics)
from analysis.core.config import grain_size_strips, load_preset, load_resolution
from analysis.core.schema import ROOT
from analysis.holes.budget_report import OUT, default_out
from analysis.holes.compare import kept_holes
from analysis.core.io import atomic_csv, machine, read_table, shown, stamp


# The presets against a reference preset (`./holes bench presets`): the same machine and strip at other grains.
# Fixed before any candidate's holes were seen: per soil and metric of compare.VALIDATED, the shift of
# the candidate's mean from the reference's (Welch, 95 %), in % of the field mean. A preset is fit for the main
# job when no shift is both resolved (interval excluding 0) and larger than 10 % of the field mean (the
# validation's own tolerance); the goal of 3 % is counted apart (shifts whose size is within it).
FIT_PCT, GOAL_PCT = 10.0, 3.0


def preset_errors(comparison: pd.DataFrame, reference: str, presets: list[str]) -> pd.DataFrame:
    """One row per candidate preset, soil and metric: both means and hole counts, the shift and its interval,
    `error_pct` = |shift| / field mean, `resolved`, `within_goal` (≤ GOAL_PCT) and `against_fit` (resolved and
    over FIT_PCT). `comparison` is results/comparison.csv (one row per preset, soil and metric).

    >>> rows = [{"preset": p, "soil": "clay", "metric": "L2", "field_mean": 50.0, "sim_mean": m, "sim_sd": 2.0,
    ...          "n_holes": 8} for p, m in (("ref", 50.0), ("a", 51.0), ("b", 60.0))]
    >>> e = preset_errors(pd.DataFrame(rows), "ref", ["a", "b"]).set_index("preset")
    >>> e.error_pct.tolist(), e.resolved.tolist(), e.within_goal.tolist(), e.against_fit.tolist()
    ([2.0, 20.0], [False, True], [True, False], [False, True])
    """
    from analysis.holes.compare import VALIDATED, shift
    ref = comparison[comparison.preset == reference].set_index(["soil", "metric"])
    if ref.empty:
        raise ValueError(f"bench presets: --against = {reference!r}: no rows of that preset in results/comparison.csv")
    rows = []
    for preset in presets:
        for r in comparison[(comparison.preset == preset) & comparison.metric.isin(VALIDATED)].itertuples():
            if (r.soil, r.metric) not in ref.index or not np.isfinite(r.sim_mean):
                continue
            b = ref.loc[(r.soil, r.metric)]
            d = shift(r.sim_mean, r.sim_sd, int(r.n_holes), b.sim_mean, b.sim_sd, int(b.n_holes))
            err = 100 * abs(d["shift"]) / r.field_mean
            rows.append({"preset": preset, "soil": r.soil, "metric": r.metric, "field_mean": r.field_mean,
                         "mean": r.sim_mean, "holes": int(r.n_holes), "reference": reference,
                         "reference_mean": b.sim_mean, "reference_holes": int(b.n_holes), **d,
                         "error_pct": err, "within_goal": err <= GOAL_PCT,
                         "against_fit": bool(d["resolved"] and err > FIT_PCT)})
    return pd.DataFrame(rows)


def preset_cost(costs: pd.DataFrame, preset: str) -> dict:
    """A preset's runs (`run_cost` rows) summed up: their number, grains, measured holes, threads, and the cost per
    measured hole (CPU and wall, mean over runs); empty values when it has none."""
    c = costs[costs.preset == preset] if len(costs) else costs
    if not len(c):
        return {"runs": 0, "particles": np.nan, "measured_holes": np.nan, "threads": "",
                "cpu_s_per_measured_hole": np.nan, "wall_s_per_measured_hole": np.nan}
    return {"runs": len(c), "particles": int(c.particles.mean()), "measured_holes": int(c.measured_holes.sum()),
            "threads": "/".join(map(str, sorted(set(c.threads)))),
            "cpu_s_per_measured_hole": round(c.cpu_s_per_measured_hole.mean(), 1),
            "wall_s_per_measured_hole": round(c.wall_s_per_measured_hole.mean(), 1)}


def preset_summary(errors: pd.DataFrame, costs: pd.DataFrame) -> pd.DataFrame:
    """Per preset: the mean and largest error, the soil-metric shifts within the goal, those against its fitness,
    and its cost per measured hole (preset_cost).

    >>> e = pd.DataFrame({"preset": ["a", "a"], "error_pct": [1.0, 12.0], "within_goal": [True, False],
    ...                   "against_fit": [False, True]})
    >>> c = pd.DataFrame({"preset": ["a"], "particles": [100], "cpu_s_per_measured_hole": [50.0],
    ...                   "wall_s_per_measured_hole": [52.0], "threads": [1], "measured_holes": [8]})
    >>> s = preset_summary(e, c).iloc[0]
    >>> s.mean_error_pct, s.max_error_pct, s.within_goal, s.against_fit, s.fit, s.cpu_s_per_measured_hole
    (6.5, 12.0, '1/2', 1, False, 50.0)
    """
    return pd.DataFrame([{"preset": preset, "mean_error_pct": round(g.error_pct.mean(), 1),
                          "max_error_pct": round(g.error_pct.max(), 1),
                          "within_goal": f"{int(g.within_goal.sum())}/{len(g)}",
                          "against_fit": int(g.against_fit.sum()), "fit": not g.against_fit.any(),
                          **preset_cost(costs, preset)}
                         for preset, g in errors.groupby("preset", sort=False)])


def cost_against_error(ax, summary: pd.DataFrame, what: str, reference: str | None = None):
    """Each preset of `summary` at its CPU time per measured hole and its mean error (bar up to its largest), with
    the goal's line; the reference preset black, the others in matplotlib's colour cycle, in order."""
    others = iter(range(len(summary)))
    for r in summary.itertuples():
        ax.errorbar(r.cpu_s_per_measured_hole, r.mean_error_pct, yerr=[[0], [r.max_error_pct - r.mean_error_pct]],
                    fmt="o", capsize=3, color="k" if r.preset == reference else f"C{next(others)}")
        ax.annotate(r.preset, (r.cpu_s_per_measured_hole, r.mean_error_pct), fontsize=8, xytext=(4, 4),
                    textcoords="offset points")
    ax.axhline(GOAL_PCT, color="g", ls="--", lw=1, label=f"goal {GOAL_PCT:g} % of the field mean")
    ax.set_xscale("log")
    ax.set_xlabel("CPU time per measured hole, s (one thread per run)")
    ax.set_ylabel(f"{what}, % of the field mean\n(mean over soils and metrics; bar to the largest)")
    ax.grid(alpha=0.3)


def run_presets(reference: str = "validation_surface", out=None, comparison_dir=None) -> int:
    """`./holes bench presets`: every preset in results/comparison.csv that runs the reference's calibrated machine
    set against the reference (preset_errors), with its cost per measured hole from its kept runs' summaries
    (results/comparison/runs/): results/bench/presets.csv (per soil and metric), presets_summary.csv and .png."""
    import json
    from analysis.holes.compare import VALIDATED
    results = Path(comparison_dir or ROOT / "results")
    out = Path(out or ROOT / "results/bench")
    comparison = read_table(results / "comparison.csv")
    machine_of = {p: load_preset(p).machine for p in comparison.preset.unique()}
    if reference not in machine_of:
        raise ValueError(f"bench presets: --against = {reference!r}: allowed a preset in results/comparison.csv "
                         f"({', '.join(sorted(machine_of))})")
    presets = [p for p, m in machine_of.items() if p != reference and m == machine_of[reference]]
    if not presets:
        raise ValueError(f"bench presets: no preset in results/comparison.csv runs {reference!r}'s machine "
                         f"({machine_of[reference] or 'the disk config'}); run one with ./holes compare --preset NAME")
    costs = []
    for preset in [reference, *presets]:
        runs = read_table(kept_holes(preset, results)).run.unique()
        for run in runs:
            summary = results / "comparison" / "runs" / run / "summary.json"
            if summary.exists():
                costs.append(run_cost(json.loads(summary.read_text())))
    costs = pd.DataFrame(costs)
    errors = preset_errors(comparison, reference, presets)
    ref = {"preset": reference, "mean_error_pct": np.nan, "max_error_pct": np.nan, "within_goal": "reference",
           "against_fit": 0, "fit": True, **preset_cost(costs, reference)}
    summary = pd.concat([pd.DataFrame([ref]), preset_summary(errors, costs)], ignore_index=True)
    summary["machine"] = machine()
    note = stamp(f"./holes bench presets --against {reference}")
    atomic_csv(errors.round(3), out / "presets.csv", note)
    atomic_csv(summary, out / "presets_summary.csv", note)
    fig, axes = pyplot().subplots(1, 2, figsize=(13, 5))
    ax = axes[0]
    cost_against_error(ax, summary.fillna({"mean_error_pct": 0.0, "max_error_pct": 0.0}), "|shift|", reference)
    ax.axhline(FIT_PCT, color="r", ls=":", lw=1, label=f"validation tolerance {FIT_PCT:g} %")
    ax.legend(fontsize=8)
    ax = axes[1]
    cells = [(s, m) for s in errors.soil.unique() for m in VALIDATED]
    for i, preset in enumerate(presets):
        g = errors[errors.preset == preset].set_index(["soil", "metric"])
        x = np.arange(len(cells)) + 0.8 * i / max(1, len(presets)) - 0.3
        y = [100 * g.loc[c, "shift"] / g.loc[c, "field_mean"] if c in g.index else np.nan for c in cells]
        half = [100 * (g.loc[c, "shift"] - g.loc[c, "shift_lo"]) / g.loc[c, "field_mean"] if c in g.index else np.nan
                for c in cells]
        ax.errorbar(x, y, yerr=half, fmt="o", capsize=2, label=preset)
    ax.axhspan(-GOAL_PCT, GOAL_PCT, color="g", alpha=0.1)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xticks(range(len(cells)), [f"{s} {m}" for s, m in cells], rotation=90, fontsize=7)
    ax.set_ylabel("shift, % of the field mean (95 % interval)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    save(fig, out / "presets_summary.png", f"presets against {reference}: the same machine and strip\n{note}")
    print(summary.to_string(index=False))
    return 0


def convergence(table: pd.DataFrame, field: pd.DataFrame) -> pd.DataFrame:
    """Convergence in grain size (configs/studies/convergence.toml): per grain radius and metric of
    compare.VALIDATED, the packings' mean and SD, the shift of the mean from the finest radius's with Welch's 95 %
    interval (compare.shift), in % of the soil's field mean, and `converged`: the shift not resolved and within
    GOAL_PCT of the field mean (the rule fixed in the study file before its runs).

    >>> t = pd.DataFrame({"soil": "clay", "preset": "quick", "resolution": ["quick"] * 3 + ["fine"] * 3,
    ...                   "run": list("abcdef"), "L2": [50.0, 51.0, 52.0, 51.0, 52.0, 53.0]})
    >>> f = pd.DataFrame({"soil": ["clay"], "run": ["mean"], "L2": [50.0]})
    >>> c = convergence(t, f).set_index("radius_mm")
    >>> c.loc[5.0, ["shift", "shift_pct_of_field", "resolved", "converged"]].tolist()
    [-1.0, -2.0, False, True]
    """
    from analysis.holes.compare import FIELD_COLUMN, VALIDATED, shift
    t = with_numerics(table)
    soil = t.soil.iloc[0]
    means = field[field["run"].astype(str) == "mean"].set_index("soil")
    finest = t[t.radius_mm == t.radius_mm.min()]
    rows = []
    for radius, g in t.groupby("radius_mm"):
        for m in (m for m in VALIDATED if m in t):
            fm = float(means.loc[soil, FIELD_COLUMN.get(m, m)])
            d = shift(g[m].mean(), g[m].std(), len(g), finest[m].mean(), finest[m].std(), len(finest))
            rows.append({"soil": soil, "resolution": g.resolution.iloc[0], "radius_mm": radius, "metric": m,
                         "packings": len(g), "mean": g[m].mean(), "sd": g[m].std(), "field_mean": fm, **d,
                         "shift_pct_of_field": 100 * d["shift"] / fm,
                         "converged": bool(not d["resolved"] and abs(100 * d["shift"] / fm) <= GOAL_PCT),
                         "particles": g.particles.mean() if "particles" in g else np.nan,
                         "steps": g.steps.mean() if "steps" in g else np.nan,
                         "cpu_s": g.cpu_s.mean() if "cpu_s" in g else np.nan})
    return pd.DataFrame(rows)


def run_convergence(workers: int, threads: int, runs_dir=None, bed_dir=None, out=None, no_run=False) -> int:
    """Run the convergence study (finished cases reused), then write results/bench/convergence.csv and .png."""
    from analysis.holes.compare import field_table
    out = Path(out or ROOT / "results/bench")
    code, _, table = study_table(CONVERGENCE, workers, threads, runs_dir, bed_dir, out, no_run)
    if table is None:
        return 1
    c = convergence(table, field_table())
    c["machine"] = machine()
    note = stamp("./holes bench convergence")
    atomic_csv(c.round(4), out / "convergence.csv", note)
    metrics = list(dict.fromkeys(c.metric))
    fig, axes = pyplot().subplots(1, len(metrics), figsize=(3.2 * len(metrics), 4))
    for ax, m in zip(np.atleast_1d(axes), metrics):
        g = c[c.metric == m]
        ax.errorbar(g.radius_mm, g["mean"], yerr=g.sd, fmt="o-", capsize=3, label="mean ± SD of the packings")
        ax.axhline(g.field_mean.iloc[0], color="k", ls=":", lw=1, label="field mean")
        ax.set_xlabel("grain radius r, mm")
        ax.set_ylabel(f"{m}, mm")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=7)
    save(fig, out / "convergence.png", f"convergence in grain size, one clay hole on a short strip\n{note}")
    print(c.drop(columns=["machine"]).round(2).to_string(index=False))
    return code


# The grain size's share (`./holes bench grain-size`): each metric of the convergence study's clay hole (r = 8 ... 3
# mm, three packings each) extrapolated to r -> 0 (analysis/holes/budget.py), linear in r (the leading order of a
# grain-scale error; five radii cannot fix the order: with it fitted the limit's interval spans tens of mm, kept
# beside as limit_fitted_*), and each grain size judged against that limit: within 5 % of the field mean over the
# limit's whole interval. The openings are left out: the
# convergence runs kept no grains, so theirs are the former reading's (results/comparison/README.md).
# `bench grain-size --strip [VALIDATION]` does the same for a validation's strip itself: clay's holes of its presets
# (STRIP_PRESETS[VALIDATION]: its replicated preset and its `grain_size` presets, configs/presets.toml: one strip,
# soils, machine and step at r = 6, 5 and 4 mm) from results/comparison.csv, every metric the comparison measures (the
# openings with the caliper), each mean's standard error over its holes.
GRAIN_SIZE_METRICS = ("L2", "L2_surface", "h1")
STRIP_PRESETS = grain_size_strips()
STRIP_METRICS = ("L0", "L1", "L2", "L2_surface", "h1")


def strip_means(comparison: pd.DataFrame, presets=STRIP_PRESETS["bench_validation"], soil: str = "clay") -> pd.DataFrame:
    """The validation strips' means in `bench convergence`'s columns (metric, radius_mm, mean, sd, n: holes)."""
    rows = []
    for preset in presets:
        t = comparison[(comparison.preset == preset) & (comparison.soil == soil) & comparison.metric.isin(STRIP_METRICS)]
        radius = 1000 * load_resolution(load_preset(preset).resolution).radius
        rows += [{"metric": r.metric, "radius_mm": radius, "mean": r.sim_mean, "sd": r.sim_sd, "n": r.n_holes,
                  "runs": r.n_runs, "field_mean": r.field_mean, "preset": preset} for r in t.itertuples()]
    return pd.DataFrame(rows)


def grain_size(conv: pd.DataFrame, metrics=GRAIN_SIZE_METRICS, n: str = "packings") -> pd.DataFrame:
    """One row per metric and grain radius: the mean over packings (or over `n`'s count), the r -> 0 limit with
    its interval, the mean's distance from the limit in % of the field mean, and whether the whole interval is
    within 5 %."""
    from analysis.holes.budget import extrapolate, within_of_limit
    rows = []
    for m in metrics:
        g = conv[conv.metric == m].sort_values("radius_mm")
        se = g.sd / np.sqrt(g[n])
        lim = extrapolate(g.radius_mm, g["mean"], se, p=1.0, fit_order=False, n_boot=2000)
        free = (extrapolate(g.radius_mm, g["mean"], se, fit_order=True, n_boot=500) if len(g) >= 4   # the order's
                else dict.fromkeys(("order", "m0", "m0_lo", "m0_hi"), np.nan))                  # sensitivity
        field = float(g.field_mean.iloc[0])
        for r in g.itertuples():
            rows.append({"metric": m, "radius_mm": r.radius_mm, "mean": r.mean, "sd": r.sd, n: getattr(r, n),
                         "field_mean": field, "limit": lim["m0"], "limit_lo": lim["m0_lo"], "limit_hi": lim["m0_hi"],
                         "from_limit_pct": 100 * (r.mean - lim["m0"]) / field,
                         "within_5pct": within_of_limit(r.mean, lim, field), "fitted_order": free["order"],
                         "limit_fitted_order": free["m0"], "limit_fitted_lo": free["m0_lo"],
                         "limit_fitted_hi": free["m0_hi"]})
    return pd.DataFrame(rows)


def run_grain_size(out=None, strip: str | None = None) -> int:
    """results/validation/grain_size.csv and .png from results/bench/convergence.csv, or (`strip`: a validation of
    STRIP_PRESETS) grain_size_strip.csv and .png from its strips in results/comparison.csv, in that validation's
    budget folder (no scene runs)."""
    home = default_out(strip) if strip else OUT
    out = Path(out or home)
    source = ROOT / ("results/comparison.csv" if strip else "results/bench/convergence.csv")
    if not source.exists():
        print(f"bench grain-size: no {source.relative_to(ROOT)}; `./holes "
              f"{'compare --preset P' if strip else 'bench convergence'}` makes it", file=sys.stderr)
        return 1
    if strip:
        presets = STRIP_PRESETS[strip]
        means = strip_means(read_table(source), presets)
        radii = sorted(set(means.radius_mm)) if len(means) else []
        if len(radii) < 2:
            print(f"bench grain-size --strip {strip}: clay's strip at {len(radii)} grain size(s) in "
                  f"results/comparison.csv; it needs two or more of {', '.join(presets)} "
                  "(`./holes compare --preset P --soils clay --seeds 1`)", file=sys.stderr)
            return 1
        metrics, n, name, what = STRIP_METRICS, "n", "grain_size_strip", f"clay's {strip} strip"
        t = grain_size(means, metrics, n)
    else:
        metrics, n, name, what = GRAIN_SIZE_METRICS, "packings", "grain_size", "the clay hole of bench convergence"
        t = grain_size(read_table(source))
    note = stamp("./holes bench grain-size" + (f" --strip {strip}" if strip else "")
                 + ("" if out == home else f" --out {shown(out)}"))
    atomic_csv(t.round(3), out / f"{name}.csv", note + f"; mm; {what} extrapolated to r -> 0 (analysis/holes/budget.py)"
               + ("; n: holes" if strip else ""))
    fig, axes = pyplot().subplots(1, len(metrics), figsize=(3.4 * len(metrics), 3.8))
    for ax, m in zip(axes, metrics):
        g = t[t.metric == m]
        ax.errorbar(g.radius_mm, g["mean"], yerr=g.sd / np.sqrt(g[n]) * 2, fmt="o", capsize=3,
                    label="mean, 95 %")
        rr = np.linspace(0, g.radius_mm.max(), 50)
        first = g.iloc[0]
        ax.fill_between([0, 0.3], first.limit_lo, first.limit_hi, color="C3", alpha=0.3, label="r → 0, 95 %")
        slope = np.polyfit(g.radius_mm, g["mean"], 1)[0]
        ax.plot(rr, first.limit + slope * rr, "C3--", lw=0.8, label="linear in r")
        ax.axhline(first.field_mean, color="k", ls=":", lw=1, label="field mean")
        ax.set(xlabel="grain radius r, mm", ylabel=f"{m}, mm", xlim=(-0.2, g.radius_mm.max() + 0.5))
    axes[0].legend(fontsize=6)
    save(fig, out / f"{name}.png", f"the grain size's share: {what} extrapolated to r → 0\n{note}")
    print(t.round(2).to_string(index=False))
    return 0


# Speed against error (`./holes bench speed-vs-error`): every preset of `bench presets` against the converged
# reference, r = 3 mm grains (`bench convergence`). A preset's shift from it is the chain of two measured shifts:
# the preset's from the reference preset on the same long strip and machine (presets.csv, per soil, 8 holes a side)
# and the reference preset's grain's from r = 3 mm on the convergence strip (convergence.csv: clay only, so taken
# for every soil), their 95 % half-widths added in quadrature. Judged by the presets' goal: |shift| within GOAL_PCT
# of the field mean.
def speed_vs_error(presets: pd.DataFrame, summary: pd.DataFrame, ladder: pd.DataFrame, radius_mm: float,
                   own_radius: dict | None = None) -> pd.DataFrame:
    """One row per preset (the reference preset, radius `radius_mm`, and the candidates of `presets`), soil and
    metric: the two shifts, their sum `shift` with `shift_lo`/`shift_hi`, `error_pct` (|shift| / field mean),
    `resolved`, `within_goal`, and the preset's cost per measured hole (`summary`, presets_summary.csv). Beside it,
    `direct_shift`: the ladder's own shift at the preset's grain (`own_radius`: preset -> mm, for one-size grains on
    the ladder), the same question asked on the convergence strip alone.

    >>> p = pd.DataFrame({"preset": ["a"], "reference": ["ref"], "soil": ["loam"], "metric": ["L2"], "field_mean": [50.0],
    ...                   "reference_mean": [40.0], "shift": [3.0], "shift_lo": [0.0], "shift_hi": [6.0]})
    >>> s = pd.DataFrame({"preset": ["ref", "a"], "cpu_s_per_measured_hole": [100.0, 20.0],
    ...                   "wall_s_per_measured_hole": [120.0, 30.0]})
    >>> c = pd.DataFrame({"radius_mm": [5.0, 3.0], "metric": ["L2", "L2"], "shift": [-1.0, 0.0], "shift_lo": [-5.0, 0.0],
    ...                   "shift_hi": [3.0, 0.0], "mean": [39.0, 40.0]})
    >>> e = speed_vs_error(p, s, c, 5.0).set_index("preset")
    >>> e.loc["ref", ["shift", "error_pct", "resolved"]].tolist(), e.loc["a", ["shift", "shift_hi", "error_pct"]].tolist()
    ([-1.0, 2.0, False], [2.0, 7.0, 4.0])
    """
    grain = ladder[ladder.radius_mm == radius_mm].set_index("metric")
    reference = presets.reference.iloc[0]
    rows = [{"preset": reference, "soil": r.soil, "metric": r.metric, "field_mean": r.field_mean,
             "mean": r.reference_mean, "preset_shift": 0.0, "preset_half": 0.0}
            for r in presets.drop_duplicates(["soil", "metric"]).itertuples()]
    rows += [{"preset": r.preset, "soil": r.soil, "metric": r.metric, "field_mean": r.field_mean,
              "mean": r.reference_mean + r.shift, "preset_shift": r.shift, "preset_half": (r.shift_hi - r.shift_lo) / 2}
             for r in presets.itertuples()]
    t = pd.DataFrame(rows)
    t = t[t.metric.isin(grain.index)].copy()
    t["grain_shift"] = t.metric.map(grain["shift"])
    t["grain_half"] = t.metric.map((grain.shift_hi - grain.shift_lo) / 2)
    t["shift"] = t.preset_shift + t.grain_shift
    half = np.sqrt(t.preset_half ** 2 + t.grain_half ** 2)
    t["shift_lo"], t["shift_hi"] = t["shift"] - half, t["shift"] + half
    t["resolved"] = (t.shift_lo > 0) | (t.shift_hi < 0)
    t["error_pct"] = 100 * t["shift"].abs() / t.field_mean
    t["within_goal"] = t.error_pct <= GOAL_PCT
    cost = summary.set_index("preset")
    for c in ("cpu_s_per_measured_hole", "wall_s_per_measured_hole"):
        t[c] = t.preset.map(cost[c])
    direct = ladder.set_index(["radius_mm", "metric"])["shift"]
    t["direct_shift"] = [direct.get(((own_radius or {}).get(p), m), np.nan) for p, m in zip(t.preset, t.metric)]
    t["reference"] = f"r = {ladder.radius_mm.min():g} mm (convergence.csv) via {reference}"
    return t.reset_index(drop=True)


def run_speed_vs_error(out=None) -> int:
    """`./holes bench speed-vs-error`: speed_vs_error.csv (per preset, soil and metric), speed_vs_error_summary.csv
    (per preset) and .png from presets.csv, presets_summary.csv and convergence.csv in `out` (results/bench); runs
    nothing."""
    out = Path(out or ROOT / "results/bench")
    need = [out / f for f in ("presets.csv", "presets_summary.csv", "convergence.csv")]
    if missing := [str(p) for p in need if not p.exists()]:
        print(f"bench speed-vs-error: missing {', '.join(missing)}: make them with ./holes bench presets and "
              "./holes bench convergence", file=sys.stderr)
        return 1
    presets, summary, ladder = (read_table(p) for p in need)
    reference = presets.reference.iloc[0]
    resolution = {p: load_preset(p).resolution for p in {*presets.preset, reference}}
    own = {p: None if load_resolution(r).graded else 1000 * load_resolution(r).radius for p, r in resolution.items()}
    if own[reference] not in set(ladder.radius_mm):
        print(f"bench speed-vs-error: the reference preset {reference!r} has {resolution[reference]!r} grains, not on "
              f"the convergence ladder (r = {', '.join(f'{r:g}' for r in sorted(set(ladder.radius_mm)))} mm, one size)",
              file=sys.stderr)
        return 1
    t = speed_vs_error(presets, summary, ladder, own[reference], own)
    t["machine"] = machine()
    direct_pct = (100 * t.direct_shift.abs() / t.field_mean).where(t.soil == "clay")   # the ladder is clay's
    s = pd.DataFrame([{"preset": p, "resolution": resolution[p],
                       "cpu_s_per_measured_hole": g.cpu_s_per_measured_hole.iloc[0],
                       "wall_s_per_measured_hole": g.wall_s_per_measured_hole.iloc[0],
                       "mean_error_pct": round(g.error_pct.mean(), 1), "max_error_pct": round(g.error_pct.max(), 1),
                       "within_goal": f"{int(g.within_goal.sum())}/{len(g)}", "resolved": int(g.resolved.sum()),
                       "max_error_cell": "{} {}".format(*g.loc[g.error_pct.idxmax(), ["soil", "metric"]]),
                       # the convergence strip's own shift at this grain, clay (empty for a grain not on the ladder)
                       "direct_mean_error_pct": round(direct_pct[g.index].mean(), 1),
                       "direct_max_error_pct": round(direct_pct[g.index].max(), 1)}
                      for p, g in t.groupby("preset", sort=False)])
    note = stamp("./holes bench speed-vs-error")
    atomic_csv(t.round(3), out / "speed_vs_error.csv", note)
    atomic_csv(s, out / "speed_vs_error_summary.csv", note)
    fig, ax = pyplot().subplots(figsize=(8, 5))
    cost_against_error(ax, s, "|shift| from r = 3 mm grains")
    ax.axvline(120, color="g", ls=":", lw=1, label="goal: 60 s of a 2-core machine per hole (120 s of CPU)")
    ax.legend(fontsize=8)
    save(fig, out / "speed_vs_error.png", f"presets against converged grains (r = 3 mm) via {reference}\n{note}")
    print(s.to_string(index=False))
    return 0
