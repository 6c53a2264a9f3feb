"""The field-table comparison (seed 001 Table 3): simulated holes beside the field's, per soil. No YADE.

    ./holes compare --preset quick          # runs (or reuses) the scenes, measures them, writes the table

Statistics. Each metric's mean and SD are over every measured hole of a soil (C over consecutive pairs). The
95 % interval of the mean is Student's t over the run means when there are two runs or more (holes in one
bed are not independent of each other), else over the holes of the one run. The pass rate is estimated from
the per-hole distributions: each of L0, L1, L2 is taken as normal with the holes' mean and SD, the three
independent, so p = Π P(X > threshold); its interval is a parametric bootstrap (resample as many holes from
the fitted normals, refit, recompute). The raw count k/n of passing holes is given beside it.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.config import load_disk
from analysis.core.seedling import load_seedling
from analysis.core.schema import ROOT
from analysis.core.io import read_table

METRICS = ("L0", "L1", "L2", "L2_surface", "h1", "C")
FIELD_COLUMN = {"L2_surface": "L2"}   # the field's one L2, read from the undisturbed surface (§4.2's other reading)
VALIDATED = ("L0", "L1", "L2", "L2_surface", "h1")   # C is set by the prescribed kinematics: reported, not counted
WITHIN_PCT = 10.0       # a simulated mean within this of the field mean (% of it) counts as reproduced
CLAIM_PCTS = (5.0, 10.0)   # the claims judged with the measurement band (claim)
RESOLVABLE_PCT = 5.0    # a metric whose measurement band is wider than this (% of the field mean) is not resolvable
BAND_PATH = ROOT / "results/comparison/metrology/band.csv"
RESIDUAL_LIMIT = 5.0    # % of the tools' work: a run whose energy balance leaves more unexplained is flagged


def t975(dof: int) -> float:
    """Two-sided 95 % Student t quantile (scipy.stats); nan below one degree of freedom.

    >>> round(t975(4), 3)
    2.776
    """
    from scipy.stats import t
    return float(t.ppf(0.975, dof)) if dof >= 1 else math.nan


def kept_holes(preset: str, results: Path = ROOT / "results") -> Path:
    """Where `./holes compare --preset PRESET` keeps every measured hole of its runs (one row per hole)."""
    return Path(results) / "comparison" / preset / "holes.csv"


def packing_holes(holes: pd.DataFrame, soil: str, seed: int) -> pd.DataFrame:
    """The holes a soil's strip found on one packing (the rows of a kept holes table)."""
    return holes[(holes.soil == soil) & (holes.seed == seed) & holes.found.astype(bool)]


def shift_from_holes(mean: float, sd: float, n: int, holes: pd.Series) -> dict:
    """`shift` of a case (mean, SD, count) from measured holes' values, blanks left out.

    >>> shift_from_holes(12.0, 1.0, 2, pd.Series([9.0, 10.0, 11.0, None]))["shift"]
    2.0
    """
    h = holes.dropna()
    return shift(mean, sd, n, h.mean(), h.std(ddof=1), len(h))


def shift(mean: float, sd: float, n: int, base_mean: float, base_sd: float, base_n: int) -> dict:
    """A variant's mean against a baseline's, from each one's holes (mean, SD, count): the shift and its 95 %
    interval (Welch: the two spreads not assumed equal), and whether the interval excludes 0 (resolved).

    >>> r = shift(12.0, 1.0, 2, 10.0, 1.0, 8)
    >>> round(r["shift"], 2), round(r["shift_lo"], 2), round(r["shift_hi"], 2), r["resolved"]
    (2.0, -2.55, 6.55, False)
    """
    v, v0 = sd ** 2 / n, base_sd ** 2 / base_n
    se = math.sqrt(v + v0)
    dof = (v + v0) ** 2 / (v ** 2 / (n - 1) + v0 ** 2 / (base_n - 1)) if n > 1 and base_n > 1 and se > 0 else 0
    half = t975(dof) * se if dof >= 1 else math.nan
    d = mean - base_mean
    return {"shift": d, "shift_lo": d - half, "shift_hi": d + half,
            "resolved": bool(math.isfinite(half) and abs(d) > half)}


def field_table(path=ROOT / "configs/field/table3.csv") -> pd.DataFrame:
    return read_table(path)


def theory_values(disk_path="configs/disk.toml", slip: float | None = None) -> dict:
    """Theory beside the field and the simulation, no subsidence in either:
    - "table1": the paper's own theory, Table 1 (eqs 1-5 as the authors evaluated them): L0, L1 at the slip
      (nearest tabulated), and C = 2πR(1-δ)/N (eq 6);
    - "envelope": the exact swept envelope of the rigid punch: L0 and L1 at the surface, L2 from the surface
      to where the swept section's smaller extent falls to √2·a2, and C."""
    from analysis.holes.theory import hole_profile, hole_spacing
    disk = load_disk(disk_path)
    slip = disk.slip if slip is None else slip
    prof = hole_profile(disk, slip)
    size = np.fmin(prof.length, prof.width)
    below = np.flatnonzero(size <= load_seedling().l2_diameter)
    t1 = read_table(ROOT / "configs/field/table1.csv")
    row = t1.iloc[int(np.argmin(np.abs(t1.slip - slip)))]
    return {"table1": {"L0": float(row.L0), "L1": float(row.L1), "C": hole_spacing(disk, slip)},
            "envelope": {"L0": prof.L0, "L1": prof.L1,
                         "L2": float(prof.depth[below[0]]) if len(below) else float(prof.depth[-1]), "C": prof.C}}


def metric_stats(holes: pd.DataFrame, metric: str) -> dict:
    """Mean, SD, n and the 95 % interval of the mean of one metric over a soil's holes (see module doc)."""
    v = holes[["run", metric]].dropna()
    n, runs = len(v), v.run.nunique()
    if n == 0:
        return {"sim_mean": math.nan, "sim_sd": math.nan, "ci_lo": math.nan, "ci_hi": math.nan, "n_holes": 0,
                "n_runs": 0}
    mean, sd = float(v[metric].mean()), float(v[metric].std(ddof=1)) if n > 1 else math.nan
    if runs >= 2:
        means = v.groupby("run")[metric].mean()
        half = t975(runs - 1) * means.std(ddof=1) / math.sqrt(runs)
    else:
        half = t975(n - 1) * sd / math.sqrt(n) if n > 1 else math.nan
    return {"sim_mean": mean, "sim_sd": sd, "ci_lo": mean - half, "ci_hi": mean + half, "n_holes": n,
            "n_runs": runs}


def pass_probability(holes: pd.DataFrame, criteria: dict, n_boot: int = 2000, seed: int = 0) -> dict:
    """Pass rate (%) from the per-hole distributions of L0, L1, L2, with a bootstrap 95 % interval, and the
    raw count (module doc). A hole with a NaN measure was not found where the punch entered
    (metrology.measure_hole): it counts as failed, so the rate is the found fraction × the found holes' rate.

    >>> h = pd.DataFrame({"L0": [90., 92, 94], "L1": [50., 52, 54], "L2": [60., 61, 62]})
    >>> r = pass_probability(h, {"L0": 49.5, "L1": 49.5, "L2": 40.0})
    >>> round(r["pass_pct"], 1), r["passed"], r["n"]
    (89.4, 3, 3)
    """
    from statistics import NormalDist
    v = holes[list(criteria)].dropna()
    n = len(holes)
    passed = int(np.all([v[m] > t for m, t in criteria.items()], axis=0).sum())
    if len(v) < 2:                                      # no spread to take a distribution from: the count only
        return {"pass_pct": math.nan, "pass_lo": math.nan, "pass_hi": math.nan, "passed": passed, "n": n}

    def prob(mu, sd):
        p = 1.0
        for m, t in criteria.items():
            s = max(sd[m], 1e-9)
            p *= 1 - NormalDist(mu[m], s).cdf(t)
        return p

    found = len(v) / n                                  # the fraction of holes found; the rest fail
    mu, sd = v.mean(), v.std(ddof=1)
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(n_boot):
        sample = {m: rng.normal(mu[m], sd[m], len(v)) for m in criteria}
        boot.append(prob({m: s.mean() for m, s in sample.items()}, {m: s.std(ddof=1) for m, s in sample.items()}))
    return {"pass_pct": 100 * found * prob(mu, sd), "pass_lo": 100 * found * float(np.percentile(boot, 2.5)),
            "pass_hi": 100 * found * float(np.percentile(boot, 97.5)), "passed": passed, "n": n}


def field_consistency(field: pd.DataFrame, criteria: dict) -> pd.DataFrame:
    """Can each field run's pass rate be true under a reading? For each metric with a threshold t, a run
    with mean m and pass fraction p needs its failing holes to average at most (m - p·t)/(1 - p) (all
    passing holes above t). Reported per run: that bound for L1, and whether the run mean is above t."""
    rows = []
    for _, r in field[field.run != "mean"].iterrows():
        p = r.pass_percent / 100
        for m, t in criteria.items():
            rows.append({"soil": r.soil, "run": r.run, "metric": m, "field_mean": r[m], "threshold": round(t, 2),
                         "pass_percent": r.pass_percent, "mean_above_threshold": bool(r[m] > t),
                         "max_mean_of_failing_holes": round((r[m] - p * t) / (1 - p), 1)})
    return pd.DataFrame(rows)


def depth_reach(field: pd.DataFrame, holes: pd.DataFrame, bound: float) -> pd.DataFrame:
    """How far below the undisturbed surface each hole's √2·a2 level lies: L2 + h1 (§4.2 counts L2 from the
    hole's top, which lies h1 below it). A rigid punch at the configured penetration cannot cut that level
    deeper than its swept envelope's L2, `bound` (theory_values), whatever the soil does. One row per field
    run, then one per simulated soil (mean and SD over its holes).

    >>> f = pd.DataFrame({"soil": ["clay", "clay"], "run": ["1", "mean"], "L2": [63.8, 62.1], "h1": [12.4, 13.5]})
    >>> h = pd.DataFrame({"soil": ["clay", "clay"], "L2": [52.0, 40.0], "h1": [2.0, 14.0]})
    >>> depth_reach(f, h, 56.0)[["source", "L2_plus_h1", "beyond_bound"]].values.tolist()
    [['field run 1', 76.2, 20.2], ['simulated', 54.0, -2.0]]
    """
    rows = [{"soil": r.soil, "source": f"field run {r.run}", "L2_plus_h1": r.L2 + r.h1, "sd": math.nan, "n": 1}
            for r in field[field.run != "mean"].itertuples()]
    for soil, h in holes.groupby("soil", sort=False):
        v = (h.L2 + h.h1).dropna()
        rows.append({"soil": soil, "source": "simulated", "L2_plus_h1": v.mean(),
                     "sd": v.std(ddof=1) if len(v) > 1 else math.nan, "n": len(v)})
    out = pd.DataFrame(rows)
    out["bound"] = bound
    out["beyond_bound"] = out.L2_plus_h1 - bound
    return out.round(2)


def residual_pct(summaries: list[dict]) -> dict:
    """Each run's energy residual (the tools' work the balance leaves unexplained: bond energy lost at breakage
    and integration error), in % of the work, by run id; runs whose summary has no balance are left out."""
    return {s["id"]: 100 * abs(s["energy_J"]["residual_fraction"]) for s in summaries
            if s.get("energy_J", {}).get("residual_fraction") is not None}


def measurement_bands(grain_radius: float, column: str = "band_mean", path=BAND_PATH) -> dict:
    """Each metric's measurement band (mm, metrology_band: `band_mean` for a mean over holes, `band` for one
    hole's reading) at grain radius `grain_radius` (mm), interpolated linearly between the radii carved, the
    nearest one outside them; {} when the band table is absent.

    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "band.csv"
    >>> _ = f.write_text("radius,metric,band\\n4,L0,6\\n6,L0,10\\n4,h1,2\\n6,h1,4\\n")
    >>> measurement_bands(5.0, "band", f), measurement_bands(8.0, "band", f)["L0"]
    ({'L0': 8.0, 'h1': 3.0}, 10.0)
    """
    if not Path(path).exists():
        return {}
    t = read_table(path)
    return {m: float(np.interp(grain_radius, g.radius, g[column])) for m, g in t.sort_values("radius").groupby("metric")}


def claim(sim_mean: float, ci_lo: float, ci_hi: float, field_mean: float, band: float, pct: float) -> str:
    """Whether "within pct % of the field mean" can be claimed when both the statistical interval and the
    measurement band are allowed for: `yes` when the interval widened by the band on each side lies within
    ±pct % of the field mean, `no` when it lies wholly outside, `open` otherwise; `not resolvable` when the
    band alone is wider than RESOLVABLE_PCT of the field mean (counted apart).

    >>> claim(100.0, 98.0, 102.0, 100.0, 2.0, 10.0), claim(130.0, 125.0, 135.0, 100.0, 2.0, 10.0)
    ('yes', 'no')
    >>> claim(108.0, 104.0, 112.0, 100.0, 2.0, 10.0), claim(100.0, 99.0, 101.0, 100.0, 8.0, 10.0)
    ('open', 'not resolvable')
    """
    band = 0.0 if not math.isfinite(band) else band
    if band > RESOLVABLE_PCT / 100 * abs(field_mean):
        return "not resolvable"
    lo = (ci_lo if math.isfinite(ci_lo) else sim_mean) - band
    hi = (ci_hi if math.isfinite(ci_hi) else sim_mean) + band
    near_lo, near_hi = field_mean * (1 - pct / 100), field_mean * (1 + pct / 100)
    if near_lo <= lo and hi <= near_hi:
        return "yes"
    if hi < near_lo or lo > near_hi:
        return "no"
    return "open"


def pass_flips(holes: pd.DataFrame, criteria: dict, bands: dict) -> float:
    """The share of holes (%) whose pass or fail flips inside the measurement band: passing when every measure
    is read a band higher, failing when every one is read a band lower (a hole not found fails either way)."""
    v = holes[list(criteria)]
    if not len(v):
        return math.nan
    up = np.all([(v[m] + bands.get(m, 0.0)) > t for m, t in criteria.items()], axis=0)
    down = np.all([(v[m] - bands.get(m, 0.0)) > t for m, t in criteria.items()], axis=0)
    return float(100 * np.mean(up != down))


def agreement(sim_mean: float, ci_lo: float, ci_hi: float, field_mean: float) -> dict:
    """Whether a simulated mean reproduces the field's: within WITHIN_PCT of it, and the field mean inside the
    simulated 95 % interval."""
    return {"within_10pct": bool(abs(sim_mean - field_mean) <= WITHIN_PCT / 100 * field_mean),
            "field_in_ci": bool(ci_lo <= field_mean <= ci_hi)}


def with_l2_surface(holes: pd.DataFrame) -> pd.DataFrame:
    """The holes with L2_surface = L2 + h1, the depth of the √2·a2 level below the undisturbed surface (§4.2's
    other reading of L2), also for the holes of a kept holes.csv measured before the column existed."""
    return holes.assign(L2_surface=holes.L2 + holes.h1)


def compare(holes: pd.DataFrame, field: pd.DataFrame, theory: dict, criteria: dict[str, dict],
            residuals: dict | None = None, targets=()) -> pd.DataFrame:
    """One row per soil and metric (and per pass-criteria reading): field mean and range, simulated mean ±
    SD and interval, errors, inside-the-range, theory, and the largest energy residual of the soil's runs (%
    of the tools' work, `residuals` by run id; nan where no run's balance is known), flagged above
    RESIDUAL_LIMIT. `targets`: the (soil, metric) pairs the machine was calibrated to (calibration_target:
    reported, never counted as a prediction)."""
    rows = []
    residuals = residuals or {}
    targets = set(targets)
    holes = with_l2_surface(holes)
    for soil, h in holes.groupby("soil", sort=False):
        radius = float(h.grain_radius.mean()) if "grain_radius" in h and h.grain_radius.notna().any() else math.nan
        bands = measurement_bands(radius) if math.isfinite(radius) else {}
        hole_bands = measurement_bands(radius, "band") if math.isfinite(radius) else {}
        known = [residuals[r] for r in h.run.unique() if r in residuals]
        energy = {"energy_residual_pct": max(known) if known else math.nan,
                  "residual_flag": bool(known) and max(known) > RESIDUAL_LIMIT}
        f = field[field.soil == soil]
        fr, fm = f[f.run != "mean"], f[f.run == "mean"].iloc[0]
        for m in METRICS:
            s = metric_stats(h, m)
            fc = FIELD_COLUMN.get(m, m)
            lo, hi, mean = float(fr[fc].min()), float(fr[fc].max()), float(fm[fc])
            rows.append({"soil": soil, "metric": m, "field_mean": mean, "field_min": lo, "field_max": hi,
                         "field_sd": float(fr[fc].std(ddof=1)), **s, "abs_error": s["sim_mean"] - mean,
                         "rel_error_pct": 100 * (s["sim_mean"] - mean) / mean,
                         "inside_field_range": bool(lo <= s["sim_mean"] <= hi),
                         **agreement(s["sim_mean"], s["ci_lo"], s["ci_hi"], mean),
                         "band": bands.get(m, math.nan),
                         **{f"claim_{p:g}pct": claim(s["sim_mean"], s["ci_lo"], s["ci_hi"], mean,
                                                     bands.get(m, math.nan), p) for p in CLAIM_PCTS},
                         "theory_table1": theory["table1"].get(fc, math.nan),
                         "theory_envelope": theory["envelope"].get(fc, math.nan), **energy,
                         "calibration_target": (soil, m) in targets})
        for reading, crit in criteria.items():
            p = pass_probability(h, crit)
            lo, hi, mean = float(fr.pass_percent.min()), float(fr.pass_percent.max()), float(fm.pass_percent)
            rows.append({"soil": soil, "metric": f"pass_{reading}", "field_mean": mean,
                         "field_min": lo, "field_max": hi, "field_sd": float(fr.pass_percent.std(ddof=1)),
                         "sim_mean": p["pass_pct"], "sim_sd": math.nan,
                         "ci_lo": p["pass_lo"], "ci_hi": p["pass_hi"], "n_holes": p["n"],
                         "n_runs": h.run.nunique(), "abs_error": p["pass_pct"] - mean,
                         "rel_error_pct": 100 * (p["pass_pct"] - mean) / mean,
                         "inside_field_range": bool(lo <= p["pass_pct"] <= hi),
                         **agreement(p["pass_pct"], p["pass_lo"], p["pass_hi"], mean),
                         **{f"claim_{q:g}pct": "–" for q in CLAIM_PCTS}, "theory_table1": math.nan,
                         "theory_envelope": math.nan,
                         "passed_holes": p["passed"], "flip_pct": pass_flips(h, crit, hole_bands), **energy,
                         "calibration_target": (soil, f"pass_{reading}") in targets})
    return pd.DataFrame(rows)


def position_trend(holes: pd.DataFrame, metrics=VALIDATED) -> pd.DataFrame:
    """Are a run's holes exchangeable? Per run and metric, the least-squares slope of the metric against the
    hole's place along the strip (mm per hole) with its 95 % interval (Student t, n - 2 degrees of freedom);
    `trend` when the interval excludes 0. Runs with fewer than 4 measured holes are left out.

    >>> h = pd.DataFrame({"run": ["a"] * 5, "soil": ["clay"] * 5, "hole": [1, 2, 3, 4, 5],
    ...                   "L2": [60.0, 61.0, 60.5, 59.5, 60.0]})
    >>> position_trend(h, ["L2"])[["metric", "n", "trend"]].values.tolist()
    [['L2', 5, False]]
    """
    from scipy.stats import linregress
    rows = []
    data = with_l2_surface(holes) if {"L2", "h1"} <= set(holes) else holes
    for (run, soil), g in data.groupby(["run", "soil"], sort=False):
        for m in metrics:
            v = g[["hole", m]].dropna()
            n = len(v)
            if n < 4:
                continue
            fit = linregress(v.hole.to_numpy(float), v[m].to_numpy(float))
            slope, half = float(fit.slope), t975(n - 2) * float(fit.stderr)
            rows.append({"run": run, "soil": soil, "metric": m, "n": n, "slope_per_hole": slope,
                         "slope_lo": slope - half, "slope_hi": slope + half, "trend": bool(abs(slope) > half)})
    return pd.DataFrame(rows, columns=["run", "soil", "metric", "n", "slope_per_hole", "slope_lo", "slope_hi",
                                       "trend"])


def soil_difference(holes: pd.DataFrame, field: pd.DataFrame, a: str = "clay", b: str = "sand",
                    metrics=("L2", "L2_surface")) -> pd.DataFrame:
    """How much deeper soil a's holes are than soil b's, simulated beside the field (whose L2 both readings are
    set against), each with its 95 % interval (Welch, `shift`): the field's over its runs; the simulation's over
    the packings' means when each soil has three or more, else over the holes (`basis`). Empty without both soils.

    >>> field = pd.DataFrame({"soil": ["clay"] * 3 + ["sand"] * 3, "run": ["1", "2", "mean"] * 2,
    ...                       "L2": [63.0, 61.0, 62.0, 55.0, 53.0, 54.0]})
    >>> holes = pd.DataFrame({"soil": ["clay"] * 4 + ["sand"] * 4, "run": ["c"] * 4 + ["s"] * 4, "found": True,
    ...                       "L2": [60, 62, 61, 61, 57, 59, 58, 58.0], "L2_surface": [70.0] * 8})
    >>> d = soil_difference(holes, field).set_index("metric")
    >>> d.loc["L2", "sim"], d.loc["L2", "field"], d.loc["L2", "basis"], d.loc["L2_surface", "sim"]
    (3.0, 8.0, 'holes', 0.0)
    """
    runs = field[field.run.astype(str) != "mean"]
    found = holes[holes.found.astype(bool)]
    if not {a, b} <= set(found.soil) or not {a, b} <= set(runs.soil):
        return pd.DataFrame()
    rows = []
    fa, fb = runs[runs.soil == a].L2, runs[runs.soil == b].L2
    f = shift(fa.mean(), fa.std(ddof=1), len(fa), fb.mean(), fb.std(ddof=1), len(fb))
    for m in metrics:
        per_run = found.groupby(["soil", "run"])[m].mean()
        basis = "packings" if min(len(per_run[a]), len(per_run[b])) >= 3 else "holes"
        sa, sb = (per_run[s] if basis == "packings" else found[found.soil == s][m] for s in (a, b))
        d = shift(sa.mean(), sa.std(ddof=1), len(sa), sb.mean(), sb.std(ddof=1), len(sb))
        rows.append({"metric": m, "difference": f"{a} - {b}", "sim": d["shift"], "sim_lo": d["shift_lo"],
                     "sim_hi": d["shift_hi"], "sim_resolved": d["resolved"], "basis": basis, "field": f["shift"],
                     "field_lo": f["shift_lo"], "field_hi": f["shift_hi"],
                     "field_in_sim_interval": bool(d["shift_lo"] <= f["shift"] <= d["shift_hi"])})
    return pd.DataFrame(rows)


def ordering(table: pd.DataFrame) -> dict:
    """The field's soil ordering clay > loam > sand, checked on the simulated means of L0, L2, pass rate;
    `tie`: two soils' simulated means are equal at the table's precision (0.1), as zero pass rates are, so the
    ordering is neither shown nor refuted; `resolved`: the simulation shows it beyond its scatter (each soil's
    95 % interval above the next one's); `steps`: each step (clay > loam, loam > sand) shown and resolved apart."""
    out = {}
    for m in ("L0", "L2", "L2_surface", "pass_stated", "pass_field", "pass_stated_surface", "pass_field_surface"):
        t = table[table.metric == m].set_index("soil")
        if not {"clay", "loam", "sand"} <= set(t.index):
            continue
        s = t.sim_mean.round(1)
        tie = bool(s.clay == s.loam or s.loam == s.sand)
        steps = {f"{a} > {b}": {"simulated": bool(s[a] > s[b]), "resolved": bool(t.ci_lo[a] > t.ci_hi[b])}
                 for a, b in (("clay", "loam"), ("loam", "sand"))}
        out[m] = {"field": bool(t.field_mean.clay > t.field_mean.loam > t.field_mean.sand),
                  "simulated": bool(s.clay > s.loam > s.sand), "tie": tie,
                  "resolved": all(v["resolved"] for v in steps.values()), "steps": steps}
    return out
