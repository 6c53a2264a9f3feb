"""The error budget of a validation preset (no YADE): every predicted metric's miss against the field split into
its parts (analysis/holes/budget.py), each from the result that measures it:

- grain size: the metric's mean at the preset's grain radius minus its r → 0 limit (results/validation/
  grain_size.csv, the convergence study's clay hole), taken as the same shift in every soil; a metric the
  convergence study does not read (the openings: its runs kept no grains) takes the limit of the validation's own
  clay strip at several grain sizes (grain_size_strip.csv beside the budget), its source named in the row;
- measurement: the comparison's band (holes of known size carved in the same beds);
- machine: the fitted P and spring rate's 95 % half-widths (the machine fit of the preset's reading of L2) times the
  metric's slopes in P and k over the machine design's runs, in quadrature (linear propagation);
- packing: the 95 % half-width of the mean over the preset's packings (Student's t over the runs' means), when it
  ran two or more;
- soil: where the preset runs the cone-fitted soils, the bond's 95 % half-width (its cone calibration's replicate
  packings, budget.bond_interval) times the metric's slope in the bond, from the strip with the bond stepped down
  (configs/studies/soil_bond.toml, results/studies/soil_bond.csv) against the same packing's validation strip
  (results/validation/soil_bond.csv): their other contact parameters are fixed, so this part is the bond's share
  only. Where it runs the bench-calibrated soils (soils = "bench"), 1.96 × the weighted SD of the strips of each
  soil's heaviest posterior samples (configs/studies/soil_posterior.toml, results/studies/soil_posterior.csv;
  results/validation/soil_posterior.csv): every calibrated parameter at once, with its correlations.

A part not measured stays empty and is named in the row; nothing is filled in.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import atomic_csv, read_table, shown, stamp
from analysis.core.schema import ROOT, ConfigError
from analysis.holes.budget import bond_interval, budget
from analysis.holes.compare import kept_holes, packing_holes, shift_from_holes, t975

METRICS = ("L0", "L1", "L2", "L2_surface", "h1")
OUT = ROOT / "results/validation"
OWN = "bench_validation"    # the preset whose budget OUT itself holds (the README's validation section reads it)


def default_out(preset: str) -> Path:
    """Where a preset's budget goes unless --out says: OUT for OWN, OUT/<preset>/ for any other, so that no budget
    overwrites the one the README reads.

    >>> default_out("bench_validation") == OUT, default_out("validation") == OUT / "validation"
    (True, True)
    """
    return OUT if preset == OWN else OUT / preset


def grain_limits(convergence: pd.DataFrame, strip: pd.DataFrame | None) -> pd.DataFrame:
    """The r → 0 limits the budget takes, with their `source`: the convergence study's for every metric it reads,
    the validation strip's for the others.

    >>> c = pd.DataFrame({"metric": ["h1"], "radius_mm": [6.0], "mean": [20.0], "limit": [7.0]})
    >>> s = pd.DataFrame({"metric": ["h1", "L0"], "radius_mm": [6.0, 6.0], "mean": [14.0, 100.0], "limit": [0.0, 90.0]})
    >>> grain_limits(c, s)[["metric", "limit", "source"]].values.tolist()
    [['h1', 7.0, 'convergence'], ['L0', 90.0, 'strip']]
    """
    out = convergence.assign(source="convergence")
    if strip is not None and not strip.empty:
        out = pd.concat([out, strip[~strip.metric.isin(convergence.metric)].assign(source="strip")], ignore_index=True)
    return out


def grain_shift(grain: pd.DataFrame, radius_mm: float) -> dict:
    """Per metric: the mean at `radius_mm` minus the r → 0 limit, with the shift's range over the limit's interval."""
    out = {}
    for metric, g in grain.groupby("metric"):
        at = g[np.isclose(g.radius_mm, radius_mm)]
        if len(at):
            r = at.iloc[0]
            out[metric] = (r["mean"] - r["limit"], r["mean"] - r["limit_hi"], r["mean"] - r["limit_lo"])
    return out


def machine_slopes(rows: pd.DataFrame, metrics=METRICS) -> dict:
    """Per metric: its slopes in P (mm/mm) and spring rate (mm per N/mm) over the machine design's runs' means.

    >>> rows = pd.DataFrame({"run": list("abcd"), "P": [70, 70, 90, 90], "stiffness": [1, 4, 1, 4], "found": True,
    ...                      "L0": [80, 86, 100, 106], "L1": [50] * 4, "L2": [40] * 4, "L2_surface": [50] * 4, "h1": [10] * 4})
    >>> [round(v, 3) for v in machine_slopes(rows)["L0"]]
    [1.0, 2.0]
    """
    found = rows[rows.found.astype(bool)]
    means = found.groupby("run").agg({"P": "first", "stiffness": "first", **{m: "mean" for m in metrics}})
    if means.P.nunique() < 2 or means.stiffness.nunique() < 2:
        return {}
    X = np.column_stack([np.ones(len(means)), means.P, means.stiffness])
    return {m: tuple(np.linalg.lstsq(X, means[m].to_numpy(float), rcond=None)[0][1:]) for m in metrics}


def machine_half_width(slopes: tuple, fit: pd.Series) -> float:
    """The machine's 95 % half-width in a metric: its slopes times the fit's half-intervals, in quadrature."""
    if not slopes or not all(math.isfinite(float(fit.get(k, math.nan))) for k in ("P_lo", "P_hi", "stiffness_lo",
                                                                                  "stiffness_hi")):
        return math.nan
    hP, hk = (fit.P_hi - fit.P_lo) / 2, (fit.stiffness_hi - fit.stiffness_lo) / 2
    return float(math.hypot(slopes[0] * hP, slopes[1] * hk))


def packing_half_width(holes: pd.DataFrame, metric: str) -> float:
    """The 95 % half-width of the mean over the packings: t(n − 1) × SD of the runs' means / √n; NaN with one."""
    means = holes[holes.found.astype(bool)].groupby("run")[metric].mean().dropna()
    if len(means) < 2:
        return math.nan
    return float(t975(len(means) - 1) * means.std(ddof=1) / math.sqrt(len(means)))


def soil_bonds(calibration_dir: Path = ROOT / "results/calibration") -> pd.DataFrame:
    """Each soil's cone-fitted bond with its 95 % interval (kPa): the calibration's iterations (results/calibration/
    <soil>.csv) and the replicate packings at the adopted bond (cone_checks.csv, check = replicate), against
    Table 2's cone index."""
    from analysis.core.soil_config import table2_row
    checks = read_table(Path(calibration_dir) / "cone_checks.csv")
    rows = []
    for soil, rep in checks[checks.check == "replicate"].groupby("soil", sort=False):
        its = read_table(Path(calibration_dir) / f"{soil}.csv").groupby("iteration").agg(
            bond=("normal_cohesion_pa", "first"), cone=("mean_kpa", "first"))
        target = table2_row(soil, "configs/field/table2_soils.csv")["cone_index_kPa"]
        adopted = float(rep.cohesion_kpa.iloc[0])
        rows.append({"soil": soil, **bond_interval(its.bond / 1000, its.cone, adopted, rep.cone_index_kpa, target),
                     "target_kpa": target, "seeds": ",".join(str(int(v)) for v in rep.seed)})
    return pd.DataFrame(rows)


def soil_slopes(study: pd.DataFrame, holes: pd.DataFrame, bonds: pd.DataFrame, metrics=METRICS) -> pd.DataFrame:
    """Per soil and metric: the shift of the strip with the bond stepped (a row of the study's table) from the same
    packing's validation strip (its holes), with its 95 % interval (compare.shift), over the bond step: the slope
    (mm per kPa), and the soil part, |slope| × the bond's half-width, with the same for the shift's interval."""
    rows = []
    for case in study.to_dict("records"):
        b = bonds[bonds.soil == case["soil"]]
        base = packing_holes(holes, case["soil"], case["seed"])
        if b.empty or base.empty:
            continue
        b = b.iloc[0]
        step = case["soil.normal_cohesion"] / 1000 - b.adopted
        for m in metrics:
            d = shift_from_holes(case[m], case[f"{m}_sd"], int(case["found"]), base[m])
            slope = d["shift"] / step
            rows.append({"soil": case["soil"], "metric": m, "seed": case["seed"], "bond_kpa": b.adopted,
                         "step_kpa": step, "shift": d["shift"], "shift_lo": d["shift_lo"], "shift_hi": d["shift_hi"],
                         "resolved": d["resolved"], "slope_mm_per_kpa": slope,
                         "bond_half_width_kpa": b.half_width, "soil_part": abs(slope) * b.half_width,
                         "soil_part_hi": max(abs(d["shift_lo"]), abs(d["shift_hi"])) / abs(step) * b.half_width,
                         "run": case["run"]})
    return pd.DataFrame(rows)


def unfinished_posteriors(study: pd.DataFrame) -> dict[str, float]:
    """The soils of a `[posterior]` study's table with a sample's strip still to run, each with the share of its
    samples' weight that has (the weights are renormalised over the samples taken, so a finished soil's sum to 1, to
    the 4 decimals the study's table keeps).

    >>> unfinished_posteriors(pd.DataFrame({"soil": ["clay", "clay", "loam"], "posterior_weight": [0.6, 0.4, 0.7]}))
    {'loam': 0.7}
    >>> unfinished_posteriors(pd.DataFrame({"soil": ["clay"] * 4, "posterior_weight": [0.6578, 0.2065, 0.0782, 0.0574]}))
    {}
    """
    held = study.groupby("soil", sort=False).posterior_weight.sum()
    return {soil: float(w) for soil, w in held.items() if not math.isclose(w, 1.0, abs_tol=1e-3)}


def posterior_parts(study: pd.DataFrame, metrics=METRICS) -> pd.DataFrame:
    """Per soil and metric: the strips of the soil's posterior samples (a `[posterior]` study's table, its
    `posterior_weight`), their weighted mean and SD (reliability weights, unbiased) and the soil part, 1.96 × that
    SD. Each strip's own scatter (its holes, the packing's chaos) is in the spread too, so the part bounds the
    soil parameters' share from above; `strip_noise` is what that scatter alone would give, 1.96 × √(Σ w·sd²/found)
    from each strip's hole SD (`<metric>_sd`) and measured holes (`found`), NaN where the table lacks them. A soil is
    left out until every strip of its samples has finished (their weights, renormalised over the samples taken,
    sum to 1), and a metric measured on fewer than two strips.

    >>> t = pd.DataFrame({"soil": ["clay"] * 3, "posterior_weight": [0.5, 0.25, 0.25], "L2": [60.0, 62.0, 58.0],
    ...                   "L2_sd": [4.0, 4.0, 4.0], "found": [4, 4, 4]})
    >>> r = posterior_parts(t, ["L2"]).iloc[0]
    >>> float(r["mean"]), round(float(r["sd"]), 3), round(float(r["soil_part"]), 3)   # 2/(1 - 0.375): Σw² = 0.375
    (60.0, 1.789, 3.506)
    >>> round(float(r["strip_noise"]), 2)                  # 1.96 × 4/√4
    3.92
    """
    rows, unfinished = [], unfinished_posteriors(study)
    for soil, g in study.groupby("soil", sort=False):
        if soil in unfinished:
            continue
        for m in metrics:
            ok = g[np.isfinite(g[m].to_numpy(float)) & (g.posterior_weight > 0)]
            if len(ok) < 2:
                continue
            w = ok.posterior_weight.to_numpy(float) / ok.posterior_weight.sum()
            x = ok[m].to_numpy(float)
            mean = float(w @ x)
            sd = math.sqrt(float(w @ (x - mean) ** 2) / (1 - float(w @ w)))
            noise = math.nan
            if f"{m}_sd" in ok and "found" in ok:
                noise = 1.96 * math.sqrt(float(w @ (ok[f"{m}_sd"].to_numpy(float) ** 2 / ok.found.to_numpy(float))))
            rows.append({"soil": soil, "metric": m, "samples": len(ok), "mean": mean, "sd": sd,
                         "min": float(x.min()), "max": float(x.max()), "soil_part": 1.96 * sd, "strip_noise": noise})
    return pd.DataFrame(rows)


def table(comparison: pd.DataFrame, holes: pd.DataFrame, grain: pd.DataFrame, radius_mm: float,
          machine_rows: pd.DataFrame | None, machine_fit: pd.Series | None,
          soil_parts: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per soil and metric of one preset's comparison: the miss, its parts and what was not measured."""
    shifts = grain_shift(grain, radius_mm)
    sources = grain.groupby("metric").source.first().to_dict() if "source" in grain else {}
    soil_part = {} if soil_parts is None or soil_parts.empty else \
        soil_parts.set_index(["soil", "metric"]).soil_part.to_dict()
    slopes = machine_slopes(machine_rows) if machine_rows is not None else {}
    rows = []
    for r in comparison[comparison.metric.isin(METRICS)].itertuples():
        shift, shift_lo, shift_hi = shifts.get(r.metric, (math.nan,) * 3)
        parts = {"measurement": float(r.band) if pd.notna(r.band) else math.nan,
                 "machine": machine_half_width(slopes.get(r.metric), machine_fit) if machine_fit is not None else math.nan,
                 "packing": packing_half_width(holes[holes.soil == r.soil], r.metric),
                 "soil": soil_part.get((r.soil, r.metric), math.nan)}
        b = budget(r.sim_mean, r.field_mean, r.sim_mean - shift, **parts)
        b["soil_parameters"] = b.pop("soil")          # the part's column, beside the soil's name
        b["not_measured"] = ", ".join("soil_parameters" if k == "soil" else k for k in b["not_measured"].split(", ") if k)
        rows.append({**b, "soil": r.soil, "metric": r.metric, "calibration_target": bool(r.calibration_target),
                     "field_mean": r.field_mean, "sim_mean": r.sim_mean, "n_holes": r.n_holes, "n_runs": r.n_runs,
                     "grain_size_lo": shift_lo, "grain_size_hi": shift_hi,
                     "grain_size_source": sources.get(r.metric, "") if math.isfinite(shift) else ""})
    return pd.DataFrame(rows)


def run(preset: str = OWN, out: Path | None = None,
        comparison_path: Path = ROOT / "results/comparison.csv", machine_dir: Path | None = None) -> list[Path]:
    """error_budget.csv and error_budget.png in `out` (default `default_out(preset)`) for `preset`'s rows of the
    comparison, the machine's part from the calibration in `machine_dir` (default: the folder of the fit
    configs/machine.toml holds, else results/calibration)."""
    out = Path(out or default_out(preset))
    from analysis.core.config import load_machine, load_preset, load_resolution
    p = load_preset(preset)
    chosen = machine_dir is not None
    section = load_machine(p.machine) if getattr(p, "machine", None) else {}
    fitted = section.get("fit")                         # where its values came from
    machine_dir = Path(machine_dir or (ROOT / Path(fitted).parent if fitted else ROOT / "results/calibration"))
    if chosen and not (machine_dir / "machine_fit.csv").exists():
        raise ConfigError(f"--machine-dir {shown(machine_dir)}: no machine_fit.csv there; allowed a folder "
                          "`./holes calibrate-machine --out` wrote")
    comparison = read_table(comparison_path)
    comparison = comparison[comparison.preset == preset]
    if comparison.empty:
        raise ConfigError(f"{comparison_path} has no rows of preset {preset!r}: run `./holes compare "
                          f"--preset {preset}` first")
    holes = read_table(kept_holes(preset))
    strip = default_out(preset) / "grain_size_strip.csv"      # where `./holes bench grain-size --strip` writes it
    grain = grain_limits(read_table(OUT / "grain_size.csv"), read_table(strip) if strip.exists() else None)
    radius_mm = 1000 * load_resolution(p.resolution).radius
    machine_rows = machine_fit = None
    if getattr(p, "machine", None) and (Path(machine_dir) / "machine_fit.csv").exists():
        fits = read_table(Path(machine_dir) / "machine_fit.csv").set_index("variant")
        variant = section.get("variant", p.machine)     # a bench clay's section names its variant
        if variant in fits.index:
            machine_fit = fits.loc[variant]
            machine_rows = read_table(Path(machine_dir) / "machine.csv")
    command = (f"./holes budget --preset {preset}" + (f" --machine-dir {shown(machine_dir)}" if chosen else "")
               + ("" if out == default_out(preset) else f" --out {shown(out)}"))
    note = stamp(command)
    soil_parts = posterior_soil_parts(out, note) if p.soils == "bench" else bond_soil_parts(holes, out, note)
    t = table(comparison, holes, grain, radius_mm, machine_rows, machine_fit, soil_parts)
    t = t[["soil", "metric", "calibration_target", "field_mean", "sim_mean", "n_holes", "n_runs", "miss", "grain_size",
           "grain_size_lo", "grain_size_hi", "grain_size_source", "model", "measurement", "machine", "packing",
           "soil_parameters", "uncertain", "resolved", "dominant", "not_measured"]]
    path = out / "error_budget.csv"
    atomic_csv(t.round(3), path, note + f"; mm; the miss (sim − field) = grain_size + model; 95 % half-widths "
               f"measurement, machine ({p.machine} fit), packing, soil; r = {radius_mm:g} mm")
    return [path, picture(t, out / "error_budget.png", preset)]


def posterior_soil_parts(out: Path, note: str, study: Path = ROOT / "results/studies/soil_posterior.csv"):
    """The bench-calibrated soils' part (`posterior_parts` of the posterior study), also written to
    <out>/soil_posterior.csv; None before the study has run."""
    if not study.exists():
        return None
    strips = read_table(study)
    for soil, held in unfinished_posteriors(strips).items():
        print(f"budget: {soil}'s soil part not measured: the strips finished hold {held:.2f} of its posterior "
              f"samples' weight ({shown(study)}); ./holes study configs/studies/soil_posterior.toml runs the rest",
              file=sys.stderr)
    parts = posterior_parts(strips)
    if len(parts):
        atomic_csv(parts.round(4), out / "soil_posterior.csv", note + "; per soil, the strips of its heaviest bench "
                   "posterior samples (results/studies/soil_posterior.csv): weighted mean and SD, soil_part = 1.96 SD; "
                   "strip_noise: 1.96 × what the strips' own hole scatter alone gives; mm")
    return parts


def bond_soil_parts(holes: pd.DataFrame, out: Path, note: str, study: Path = ROOT / "results/studies/soil_bond.csv"):
    """The cone-fitted soils' part (`soil_slopes` of the bond study), with each bond's interval written to
    <out>/soil_bond.csv; None before the study has run."""
    if not study.exists():
        return None
    bonds = soil_bonds()
    parts = soil_slopes(read_table(study), holes, bonds)
    if len(parts):
        bond_cols = ["soil", "centre", "lo", "hi", "slope", "cone_mean", "cone_sd", "replicates", "seeds",
                     "target_kpa"]        # the adopted bond and its half-width are soil_slopes' bond_kpa and bond_half_width_kpa
        atomic_csv(parts.merge(bonds[bond_cols].rename(columns={"slope": "cone_slope_kpa_per_kpa"}), on="soil")
                   .round(4), out / "soil_bond.csv",
                   note + "; the cone-fitted bond's 95 % interval (kPa, from results/calibration/<soil>.csv and "
                   "cone_checks.csv replicates) and each metric's slope in it (results/studies/soil_bond.csv against "
                   "the same packing's validation strip); mm")
    return parts


def picture(t: pd.DataFrame, path: Path, preset: str) -> Path:
    """Per soil, each metric's miss beside its systematic parts (the grain size's interval and the model's, the miss
    less that interval, as error bars) and its uncertain parts' half-widths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    soils = list(dict.fromkeys(t.soil))
    parts = [("miss", "black"), ("grain_size", "tab:blue"), ("model", "tab:red"), ("measurement", "0.6"),
             ("machine", "tab:green"), ("packing", "tab:purple"), ("soil_parameters", "tab:orange")]
    fig, axes = plt.subplots(1, len(soils), figsize=(5 * len(soils), 4), squeeze=False, sharey=True)
    width = 0.8 / len(parts)
    for ax, soil in zip(axes[0], soils):
        s = t[t.soil == soil].reset_index(drop=True)
        lo, hi = s.grain_size_lo.to_numpy(float), s.grain_size_hi.to_numpy(float)
        spans = {"grain_size": (lo, hi), "model": (s.miss - hi, s.miss - lo)}
        for j, (part, colour) in enumerate(parts):
            values = s[part].to_numpy(float)
            span = spans.get(part)
            yerr = None if span is None else np.nan_to_num([values - span[0], span[1] - values])
            ax.bar(np.arange(len(s)) + (j - len(parts) / 2 + 0.5) * width, np.nan_to_num(values), width,
                   yerr=yerr, capsize=2, color=colour, label=part if soil == soils[0] else None,
                   hatch="//" if part in ("measurement", "machine", "packing", "soil_parameters") else None)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xticks(range(len(s)), [m + (" (target)" if c else "") for m, c in zip(s.metric, s.calibration_target)],
                      rotation=30, fontsize=8)
        ax.set_title(f"{soil} ({preset})")
    axes[0][0].set_ylabel("mm (95 %)\nhatched: half-widths; bars: intervals")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
