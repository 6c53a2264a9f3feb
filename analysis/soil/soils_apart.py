"""Which bench test tells which soil apart: for each pair of the soils the runs use, each bench response of their
posterior means side by side with the interval of the difference (the shear box over every packing each box ran,
`posterior_packings`; the wall-free cell over every packing each edge ran; the collapse column and the cone over the
checks' packings, `<soil>-check.csv`), and each parameter's posterior interval (`<soil>-posterior.json`; a parameter
one soil held, at its value). A response tells two soils apart when the
interval of the difference of their packings' means leaves zero out; whether the targets ask it to is whether the two
soils' target ranges are disjoint. Beside them, how the filter's own packing reads against the
other check packings over every posterior checked so far (`filter-packing.csv`), and how far the check packings'
scatter lets a check on each packing tell a set inside a target at all (`check-odds.csv`)."""
import dataclasses
import itertools
import json
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from analysis.core.io import atomic_csv, shown
from analysis.core.soil_config import SOILS
from analysis.soil.bench_calibration import (BENCH_DIR, RESPONSES, at_posterior, cone_path, cone_range,
                                             difference_interval, filter_seeds, load_config, mean_verdict, measured,
                                             mm, posterior_mean, posterior_packings,
                                             pooled_shift, runs_cone, scene_result, shear_box_mm, SHEAR_RESPONSES,
                                             size_shift, target_ranges)
from analysis.soil.shear import READING


def responses_apart(checks: dict[str, pd.DataFrame], targets: dict[str, dict],
                    responses=(*RESPONSES, "cone_kpa")) -> pd.DataFrame:
    """Per response of `responses` and pair of soils (in `checks`' order): both packings' means, the difference
    (soil_2 − soil_1) with its 95 % interval, whether it leaves zero out (`apart`) and whether the two target ranges
    are disjoint (`targets_apart`). `targets[soil][response]` is the (lo, hi) range; a response one of the two soils'
    checks or targets lacks, or that either read on fewer than two packings, is left out of their pair."""
    rows = []
    for r in responses:
        for s1, s2 in itertools.combinations(checks, 2):
            if any(r not in checks[s] or r not in targets[s] or checks[s][r].notna().sum() < 2 for s in (s1, s2)):
                continue
            d, lo, hi = difference_interval(checks[s1][r].dropna(), checks[s2][r].dropna())
            (a_lo, a_hi), (b_lo, b_hi) = targets[s1][r], targets[s2][r]
            rows.append({"response": r, "soil_1": s1, "soil_2": s2, "mean_1": checks[s1][r].mean(),
                         "mean_2": checks[s2][r].mean(), "difference": d, "lo": lo, "hi": hi,
                         "packings": f"{checks[s1][r].notna().sum()}+{checks[s2][r].notna().sum()}",
                         "apart": bool(lo > 0 or hi < 0),
                         "targets_apart": bool(a_hi < b_lo or b_hi < a_lo)})
    return pd.DataFrame(rows)


def parameters_apart(posteriors: dict[str, dict], held: dict[str, dict] | None = None) -> pd.DataFrame:
    """Per parameter either soil of a pair calibrated and pair of soils: both posterior means and 95 % intervals, and
    whether the intervals are disjoint (`apart`). A soil that held the parameter enters with its value `held[soil]`
    as a point (`calibrated` names who calibrated it); a parameter neither has a value for is left out of the pair.

    >>> post = lambda m, lo, hi: {"mean": {"young": m}, "interval": {"young": [lo, hi]}}
    >>> t = parameters_apart({"clay": post(5.6e6, 4.7e6, 6.8e6), "sand": {"mean": {}, "interval": {}}},
    ...                      {"sand": {"young": 2e7}})
    >>> t[["parameter", "lo_2", "hi_2", "calibrated", "apart"]].values.tolist()
    [['young', 20000000.0, 20000000.0, 'clay', True]]
    """
    held = held or {}
    rows = []
    for s1, s2 in itertools.combinations(posteriors, 2):
        p1, p2 = posteriors[s1], posteriors[s2]
        for n in dict.fromkeys([*p1["mean"], *p2["mean"]]):
            ends = []
            for s, p in ((s1, p1), (s2, p2)):
                value = p["mean"].get(n, held.get(s, {}).get(n))
                ends.append((value, *(p["interval"][n] if n in p["mean"] else (value, value))))
            if any(e[0] is None for e in ends):
                continue
            (m1, lo1, hi1), (m2, lo2, hi2) = ends
            rows.append({"parameter": n, "soil_1": s1, "soil_2": s2, "mean_1": m1, "lo_1": lo1, "hi_1": hi1,
                         "mean_2": m2, "lo_2": lo2, "hi_2": hi2,
                         "calibrated": "both" if n in p1["mean"] and n in p2["mean"] else (s1 if n in p1["mean"] else s2),
                         "apart": bool(hi1 < lo2 or hi2 < lo1)})
    return pd.DataFrame(rows)


def column_packings(soil: str, folder: Path) -> pd.DataFrame:
    """The collapse slope of the soil's posterior mean (<folder>/<soil>-posterior.json), one row per packing its
    checks ran (<folder>/<soil>-check.csv and -check-packings.csv, the rows at the posterior mean; a packing both
    hold is read once), measured from the evaluation's folder where it holds the shear box and the column
    (`measured`), else as the check recorded it."""
    post = posterior_mean(soil, folder)
    rows = {}
    for part in ("-check", "-check-packings"):
        path = Path(folder) / f"{soil}{part}.csv"
        if path.exists():
            table = at_posterior(pd.read_csv(path, comment="#", float_precision="round_trip"), post)
            for row in table.to_dict(orient="records"):
                if int(row["seed"]) not in rows and not isinstance(row.get("failed"), str):
                    row = measured(row, Path(folder) / soil / str(row["id"]), kept_only=True)
                    rows[int(row["seed"])] = {"seed": int(row["seed"]), "collapse_deg": row.get("collapse_deg")}
    return pd.DataFrame([rows[s] for s in sorted(rows)])


def run(out_dir: Path = BENCH_DIR, folders: dict[str, Path] | None = None) -> list[Path]:
    """soils-apart.csv (the responses) and soils-apart-parameters.csv in out_dir, for the soils the runs use: each
    soil's posterior and checks read in `folders[soil]` (by default the folder its config's [bench_posterior] names,
    `posterior_folder`); nothing when fewer than two soils have a posterior and its check there. Each response is
    read where it is judged: the shear box's c and φ over every packing the checks' box ran, and again over every
    packing of the checks' box grown by half; the wall-free cell's c and φ over every packing each cell edge ran
    (analysis/soil/cell.py: the size check's cells and a cell filter's checks); the collapse slope over every packing
    the checks ran (`column_packings`); the cone over the check's packings. A parameter one soil held and the other
    calibrated enters at the held value (the runs' soil config, `bench_soil`)."""
    from analysis.core.soil_config import bench_soil, load_soil, posterior_folder
    out_dir = Path(out_dir)
    folders = {s: Path(f) for s, f in (folders or {s: posterior_folder(s) for s in SOILS}).items()}
    soils = [s for s in SOILS if s in folders and (folders[s] / f"{s}-check.csv").exists()
             and (folders[s] / f"{s}-posterior.json").exists()]
    if len(soils) < 2:
        return []
    cfg = load_config()
    posteriors = {s: json.loads((folders[s] / f"{s}-posterior.json").read_text()) for s in soils}
    targets = {s: target_ranges(s, load_config(soil=s)) for s in soils}
    tables = []
    for key in ("check_box_mm", "check_size_check_mm"):
        box = cfg[key]
        checks = {s: posterior_packings(s, box, folders[s], folders[s]) for s in soils}
        tables.append(responses_apart(checks, targets, SHEAR_RESPONSES).assign(read_in=mm(box)))
    from analysis.soil.cell import rated_packings
    cells = {s: t for s in soils if len(t := rated_packings(s, bench_dir=folders[s]))}
    for edge in sorted({e for t in cells.values() for e in t["edge_mm"]}):     # the wall-free cell, each edge
        at = {s: t[t["edge_mm"] == edge] for s, t in cells.items()}
        tables.append(responses_apart(at, targets, SHEAR_RESPONSES).assign(read_in=f"cell {edge:g}"))
    columns = {s: column_packings(s, folders[s]) for s in soils}
    tables.append(responses_apart(columns, targets, ("collapse_deg",)).assign(read_in="column"))
    cones = {s: pd.read_csv(folders[s] / f"{s}-check.csv", comment="#") for s in soils}
    tables.append(responses_apart(cones, targets, ("cone_kpa",)).assign(read_in="cone"))
    held = {s: dataclasses.asdict(bench_soil(load_soil(s))) for s in soils}
    paths = [out_dir / "soils-apart.csv", out_dir / "soils-apart-parameters.csv"]
    atomic_csv(pd.concat(tables).round(3), paths[0],
               "./holes calibration-report; per bench response, where it is read (read_in: the shear box, mm, over "
               "every packing it ran at the posterior mean; the wall-free cell of that edge, mm, over every packing it "
               "ran; the collapse column and the cone over the checks' packings) and pair of soils, the runs' "
               "posteriors (" + ", ".join(f"{s}: {shown(folders[s])}" for s in soils) + "): the difference of the "
               "packings' means, soil_2 − soil_1 (Welch 95 % interval), and whether the targets' ranges are disjoint")
    atomic_csv(parameters_apart(posteriors, held).round(4), paths[1],
               "./holes calibration-report; per parameter and pair of soils, the runs' posteriors' 95 % intervals (a "
               "parameter a soil held: its value, both ends) and whether they are disjoint")
    return paths


def packing_effects(checks: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """Whether a packing seed reads a response the same way in every soil: per response and pair of soils (each a
    check of one set on many packings, with `seed`), the correlation of the two soils' per-packing deviations from
    their own mean over the seeds both ran, with its 95 % interval (Fisher z) and whether that leaves zero out. A
    scatter that is the packing's (its grains' places) correlates; one that is each run's own does not.

    >>> a = pd.DataFrame({"seed": range(1, 10), "c_kpa": [1.0, 2, 3, 4, 5, 6, 7, 8, 9]})
    >>> b = pd.DataFrame({"seed": range(1, 10), "c_kpa": [2.0, 1, 4, 3, 6, 5, 8, 7, 9]})
    >>> r = packing_effects({"clay": a, "sand": b}).iloc[0]
    >>> r.packings, round(r.correlation, 2), bool(r.resolved)
    (9, 0.93, True)
    """
    rows = []
    for r in RESPONSES:
        for s1, s2 in itertools.combinations(checks, 2):
            if r not in checks[s1] or r not in checks[s2]:
                continue
            both = pd.merge(checks[s1][["seed", r]], checks[s2][["seed", r]], on="seed").dropna()
            if len(both) < 4:
                continue
            x, y = both[f"{r}_x"], both[f"{r}_y"]
            rho = float(np.corrcoef(x, y)[0, 1])
            half = stats.norm.ppf(0.975) / np.sqrt(len(both) - 3)
            lo, hi = float(np.tanh(np.arctanh(rho) - half)), float(np.tanh(np.arctanh(rho) + half))
            rows.append({"response": r, "soil_1": s1, "soil_2": s2, "packings": len(both), "correlation": rho,
                         "lo": lo, "hi": hi, "resolved": bool(lo > 0 or hi < 0)})
    return pd.DataFrame(rows)


def packing_effects_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """packing-effects.csv: `packing_effects` over every soil's posterior checked on more packings
    (`<soil>-check-packings.csv`); None when fewer than two soils have one."""
    out_dir = Path(out_dir)
    checks = {s: pd.read_csv(out_dir / f"{s}-check-packings.csv", comment="#") for s in SOILS
              if (out_dir / f"{s}-check-packings.csv").exists()}
    if len(checks) < 2:
        return None
    path = out_dir / "packing-effects.csv"
    atomic_csv(packing_effects(checks).round(3), path,
               "./holes calibration-report; per bench response and pair of soils, the correlation of their posteriors' "
               "per-packing deviations over the packing seeds both checked (`<soil>-check-packings.csv`), its 95 % "
               "interval (Fisher z) and whether it leaves zero out: a packing seed that reads a response high in every "
               "soil correlates")
    return path


def filter_packing(checks: list[pd.DataFrame], seed: int) -> pd.DataFrame:
    """Per bench response, over posterior checks each calibrated on packing `seed`: the mean offset of that packing's
    reading from the other check packings' mean, its 95 % t interval, how many checks it pools and in how many the
    filter's packing reads lower. A filter keeps the samples whose one packing read inside the targets, and that
    packing's luck with them: an interval that leaves zero out says the posteriors read the response off on the
    packings they were not fitted on. A check without the response, or without `seed` and another packing, is left
    out; a response fewer than two checks have, too.

    >>> t = lambda c: pd.DataFrame({"seed": [1, 2, 3], "c_kpa": c})
    >>> r = filter_packing([t([10, 13, 13]), t([20, 22, 24]), t([5, 7, 8])], 1).iloc[0]
    >>> r.response, r.checks, round(r.offset, 1), r.below, bool(r.hi < 0)
    ('c_kpa', 3, -2.8, 3, True)
    """
    rows = []
    for r in [*RESPONSES, "cone_kpa"]:
        d = []
        for t in checks:
            if r not in t or "seed" not in t or t[r].isna().any():
                continue
            own, others = t.loc[t["seed"] == seed, r], t.loc[t["seed"] != seed, r]
            if len(own) == 1 and len(others):
                d.append(float(own.iloc[0] - others.mean()))
        if len(d) < 2:
            continue
        d = np.array(d)
        offset = d.mean()
        half = stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d))
        rows.append({"response": r, "checks": len(d), "offset": offset, "lo": offset - half, "hi": offset + half,
                     "below": int((d < 0).sum()), "resolved": bool(abs(offset) > half)})
    return pd.DataFrame(rows)


def filter_packing_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """filter-packing.csv from every posterior's check in out_dir and its folders of earlier calibrations
    (`<soil>-check.csv`), each fitted on the common filter packing; None when fewer than two checks are there. Left
    out: the checks of the planes' deepest sets (not posteriors) and a current posterior whose soil's filter takes
    its packings in turn (`[soil_bench.<soil>] calibration_seed`), which no one packing fitted."""
    out_dir = Path(out_dir)
    seed = filter_seeds(load_config())[0]

    def one_packing(f: Path) -> bool:
        soil = f.stem.removesuffix("-check")
        return f.parent != out_dir or soil not in SOILS or filter_seeds(load_config(soil=soil)) == [seed]
    files = sorted(f for f in [*out_dir.glob("*-check.csv"), *out_dir.glob("*/*-check.csv")]
                   if not f.name.endswith("-deepest-check.csv") and one_packing(f))
    table = filter_packing([pd.read_csv(f, comment="#") for f in files], seed)
    if table.empty:
        return None
    path = out_dir / "filter-packing.csv"
    atomic_csv(table.round(3), path,
               f"./holes calibration-report; per bench response, over {len(files)} posterior checks (bench/ and its "
               f"folders), packing {seed}'s reading (the filters') minus the other check packings' mean: mean, 95 % t "
               "interval, checks pooled, and in how many it reads lower")
    return path


def shear_scatter(sets: list[tuple[list[float], np.ndarray]]) -> pd.DataFrame:
    """Where the shear box's packing scatter lies: per normal stress (kPa), the peak shear stress's SD over the packings
    of one parameter set, pooled over `sets` (each its stresses and a packings × stresses array of peaks), with its
    degrees of freedom and its share of the mean peak; sets with other stresses pool by stress.

    >>> a = np.array([[30.0, 60.0, 120.0], [32.0, 64.0, 128.0], [28.0, 56.0, 112.0]])
    >>> t = shear_scatter([([50, 100, 200], a)]).set_index("stress_kpa")
    >>> t.loc[200.0, "tau_sd_kpa"], t.loc[50.0, "dof"], round(t.loc[100.0, "share"], 3)
    (8.0, 2, 0.067)
    """
    rows = []
    for stress in sorted({float(x) for stresses, _ in sets for x in stresses}):
        cols = [(tau[:, list(map(float, stresses)).index(stress)]) for stresses, tau in sets if stress in map(float, stresses)]
        ss = sum(((c - c.mean()) ** 2).sum() for c in cols)
        dof = sum(len(c) - 1 for c in cols)
        sd = float(np.sqrt(ss / dof)) if dof else np.nan
        rows.append({"stress_kpa": stress, "sets": len(cols), "dof": dof, "tau_sd_kpa": sd,
                     "share": sd / float(np.mean([c.mean() for c in cols]))})
    return pd.DataFrame(rows)


CHECKED_PARAMETERS = ("normal_cohesion", "friction_deg", "new_contact_cohesion", "pressed_adhesion", "rolling_friction",
                      "damping")      # a checked set's parameters: what names it in a check's rows


def checked_sets(out_dir: Path = BENCH_DIR) -> list[tuple[Path, str, dict, pd.DataFrame]]:
    """Every parameter set checked in out_dir and its folders (`*-check*.csv`: on three packings, on more, a deepest
    set's), each evaluation once: its folder, soil, parameters (CHECKED_PARAMETERS it names) and its rows."""
    found = []
    for folder in [out_dir, *sorted(p for p in out_dir.iterdir() if p.is_dir())]:
        files = sorted(folder.glob("*-check*.csv"))
        if not files:
            continue
        table = pd.concat([pd.read_csv(f, comment="#") for f in files]).drop_duplicates("id")
        names = [n for n in table.columns if n in CHECKED_PARAMETERS]
        for (soil, *_), rows in table.groupby(["soil", *names], dropna=False):
            params = {n: float(rows[n].iloc[0]) for n in names if pd.notna(rows[n].iloc[0])}
            found.append((folder, soil, params, rows))
    return found


def shear_scatter_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """shear-scatter.csv: `shear_scatter` over every set checked in out_dir and its folders (`*-check*.csv`: a check
    on three packings, on more, a deepest set's; each evaluation once, a set by its soil and parameters) that ran with
    ductile bonds (the model's) on three packings or more, each set's peaks read from its evaluations' shear-box
    results; None when no check is there."""
    out_dir = Path(out_dir)
    by_box: dict[str, list] = {}
    for folder, soil, _, rows in checked_sets(out_dir):
        found = (next((p for p in (folder / soil / i, out_dir / soil / i) if p.is_dir()), None) for i in rows["id"])
        data = [d for d in (scene_result(p, "shear") for p in found if p is not None)
                if d and d["overrides"].get("bond_fragile") == 0]          # ductile bonds, the model's
        stresses = {tuple(t["stress_kpa"] for t in d["tests"]) for d in data}
        boxes = {mm(shear_box_mm(d) or []) for d in data}
        if len(data) >= 3 and len(stresses) == 1 and len(boxes) == 1:
            by_box.setdefault(boxes.pop(), []).append(
                (list(stresses.pop()), np.array([[t["tau_peak_kpa"] for t in d["tests"]] for d in data])))
    if not by_box:
        return None
    path = out_dir / "shear-scatter.csv"
    table = pd.concat([shear_scatter(sets).assign(box_mm=box) for box, sets in sorted(by_box.items())])
    atomic_csv(table.round(3), path,
               f"./holes calibration-report; the shear box's peak shear stress per normal stress and box (mm): its SD "
               f"over the packings of one parameter set pooled over the checked sets (bench/ and its folders; "
               f"{', '.join(f'{len(v)} in the {b} mm box' for b, v in sorted(by_box.items()))}), its degrees of "
               "freedom and its share of the mean peak")
    return path


def box_pairs(cfg: dict) -> list[tuple[list, list]]:
    """The shear box's size checks as (configured, grown) boxes in mm: the filter's box and the checks', the checks'
    and it grown by half, and, where [bench] sets one, the checks' and it grown in height alone, and that tall box
    and the box grown by half (in width alone where their heights agree).

    >>> box_pairs({"size_mm": [1], "check_box_mm": [2], "check_size_check_mm": [3], "check_height_check_mm": [4]})
    [([1], [2]), ([2], [3]), ([2], [4]), ([4], [3])]
    """
    pairs = list(itertools.pairwise([cfg[k] for k in ("size_mm", "check_box_mm", "check_size_check_mm")]))
    if "check_height_check_mm" not in cfg:
        return pairs
    tall = cfg["check_height_check_mm"]
    return pairs + [(cfg["check_box_mm"], tall), (tall, cfg["check_size_check_mm"])]


def box_shift_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """box-shift.csv: the shear box's size checks over every packing each box ran (`size_shift` of
    `posterior_packings`), per soil's posterior mean and box pair (`box_pairs`); None when no soil has a pair."""
    out_dir, pairs = Path(out_dir), box_pairs(load_config())
    boxes = {mm(box): box for pair in pairs for box in pair}          # a box in several pairs is read once
    tables = []
    for soil in SOILS:
        read = {name: posterior_packings(soil, box, out_dir, out_dir) for name, box in boxes.items()}
        for small, big in pairs:
            a, b = read[mm(small)], read[mm(big)]
            shift = size_shift(a, b, SHEAR_RESPONSES) if len(a) and len(b) else pd.DataFrame()
            if len(shift):
                tables.append(shift.assign(soil=soil, configured_mm=mm(small), grown_mm=mm(big)))
    if not tables:
        return None
    path = out_dir / "box-shift.csv"
    atomic_csv(pd.concat(tables).round(3), path,
               "./holes calibration-report; the shear box's size checks, each soil's posterior mean over every packing "
               "each box ran (its checks and size checks): the filter's box against the checks' and the checks' "
               "against it grown by half; the shift of each response's mean with its Welch 95 % interval, resolved "
               "when that leaves zero out; passes: under the configured box's packing SD")
    return path


def box_shift_pooled_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """box-shift-pooled.csv: box-shift.csv's soils pooled per box pair and response (`pooled_shift`): whether growing
    the box moves every soil's mean alike, beside each soil's own size check; None when no pair has two soils."""
    source = Path(out_dir) / "box-shift.csv"
    if not source.exists():
        return None
    shifts = pd.read_csv(source, comment="#")
    pooled = [pooled_shift(t).assign(configured_mm=small, grown_mm=big, soils_pooled=" ".join(t["soil"].unique()))
              for (small, big), t in shifts.groupby(["configured_mm", "grown_mm"], sort=False)]
    pooled = [t for t in pooled if len(t)]             # a pair checked in one soil pools nothing
    if not pooled:
        return None
    table = pd.concat(pooled)
    path = Path(out_dir) / "box-shift-pooled.csv"
    atomic_csv(table.round(3), path,
               "./holes calibration-report; box-shift.csv's soils pooled per box pair and response: the fixed-effect "
               "mean of their shifts weighed by inverse Welch variance, its 95 % t interval (Satterthwaite dof), "
               "resolved when that leaves zero out; Cochran's Q and its p-value (small: the soils' shifts differ)")
    return path


def posterior_peaks(soil: str, box_mm, out_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """The shear box's peak shear stress (kPa) of the soil's posterior mean in box `box_mm`, one row per packing
    (`posterior_packings`), a column per normal stress (kPa)."""
    rows = []
    for i in posterior_packings(soil, box_mm, out_dir, out_dir).get("id", []):
        data = scene_result(Path(out_dir) / soil / str(i), "shear")
        if data:
            rows.append({float(t["stress_kpa"]): float(t["tau_peak_kpa"]) for t in data["tests"]})
    return pd.DataFrame(rows)


def peak_shift(configured: pd.DataFrame, grown: pd.DataFrame) -> pd.DataFrame:
    """The size check of the shear box's peaks: per normal stress both boxes ran (`posterior_peaks`' columns),
    `size_shift`'s row with the shift, its interval and both SDs as shares of the configured box's mean peak, in %
    (the stress in `stress_kpa`, every row's response `tau_peak_pct`).

    >>> a = pd.DataFrame({50.0: [50.0, 52.0, 48.0], 100.0: [100.0, 104.0, 96.0]})
    >>> r = peak_shift(a, a * 0.95)
    >>> r[["stress_kpa", "shift"]].round(2).to_dict(orient="list")
    {'stress_kpa': [50.0, 100.0], 'shift': [-5.0, -5.0]}
    """
    stresses = [c for c in configured if c in grown]
    table = size_shift(configured, grown, stresses)
    scale = 100 / table["configured_mean"]
    for col in ("configured_sd", "grown_sd", "shift", "shift_lo", "shift_hi"):
        table[col] = table[col] * scale
    return table.rename(columns={"response": "stress_kpa"}).assign(response="tau_peak_pct")


def box_peaks_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """box-peaks.csv: where the shear box's size check moves c and φ from, its peaks: per soil, box pair (as in
    box-shift.csv) and normal stress, the shift of the posterior mean's peak shear stress in % of the configured box's
    (`peak_shift`), pooled over its stresses (`pooled_shift`, the stress left blank), and per box pair every soil's
    and stress's shift pooled (soil "pooled"), each with Cochran's Q for whether the shifts it pools differ; None when
    no soil has a pair."""
    out_dir, pairs = Path(out_dir), box_pairs(load_config())
    boxes = {mm(box): box for pair in pairs for box in pair}          # a box in several pairs is read once
    tables = []
    for soil in SOILS:
        read = {name: posterior_peaks(soil, box, out_dir) for name, box in boxes.items()}
        for small, big in pairs:
            a, b = read[mm(small)], read[mm(big)]
            if len(a) > 1 and len(b) > 1:
                tables.append(peak_shift(a, b).assign(soil=soil, configured_mm=mm(small), grown_mm=mm(big)))
    if not tables:
        return None
    table = pd.concat(tables)
    pooled = []
    for keys in (["soil", "configured_mm", "grown_mm"], ["configured_mm", "grown_mm"]):   # each soil's, then all
        for (*soil, small, big), t in table.groupby(keys, sort=False):
            if keys[0] == "soil" or t["soil"].nunique() > 1:       # all soils: where more than one ran the pair
                pooled.append(pooled_shift(t).rename(columns={"soils": "pooled_rows"}).assign(
                    soil=soil[0] if soil else "pooled", configured_mm=small, grown_mm=big))
    path = out_dir / "box-peaks.csv"
    table = pd.concat([table, *pooled]).drop(columns="response").rename(columns={
        "configured_mean": "configured_kpa", "grown_mean": "grown_kpa", "configured_sd": "configured_sd_pct",
        "grown_sd": "grown_sd_pct", "shift": "shift_pct", "shift_lo": "shift_lo_pct", "shift_hi": "shift_hi_pct"})
    first = ["soil", "configured_mm", "grown_mm", "stress_kpa"]
    table = table[first + [c for c in table if c not in first]].astype(
        {c: "Int64" for c in ("configured_n", "grown_n", "pooled_rows")})
    atomic_csv(table.round(3), path,
               "./holes calibration-report; the shear box's size checks read on its peaks: per soil, box pair and "
               "normal stress, the posterior mean's peak shear stress (kPa) over every packing each box ran, its SDs "
               "and the grown box's shift in % of the configured box's mean peak, with its Welch 95 % interval; "
               "passes: the size rule on the peak; per soil and box pair (the stress blank) its stresses' shifts "
               "pooled by inverse Welch variance, and (soil 'pooled') every soil's and stress's, with Cochran's Q")
    return path


def reading_reweighted(table: pd.DataFrame, post: dict, measured_table: pd.DataFrame) -> pd.DataFrame:
    """A filter's last iteration weighed again under another reading of its evaluations: each sample's last weight
    (`table`'s `weight_last`, as the filter weighed its responses) times the ratio of its likelihood under
    `measured_table`'s responses (the same rows, read as the current code reads them) to that under the table's:
    GrainLearning's Gaussian on the responses in units of their ranges (`in_ranges`), at the SD of the filter's last
    iteration (`post`'s `likelihood_sigma`, `scale_cov_with_max`). Per calibrated parameter: the posterior mean as
    drawn and so weighed again, the shift as a share of the posterior's 95 % interval, and both effective sample
    sizes. The samples stay the filter's: how far the reading would move the posterior before a refit draws anew.

    >>> t = pd.DataFrame({"a": [1.0, 3.0], "c_kpa": [6.0, 18.0], "weight_last": [0.5, 0.5]})
    >>> post = {"names": ["a"], "mean": {"a": 2.0}, "interval": {"a": [1.0, 3.0]}, "likelihood_sigma": [0.01],
    ...         "targets": {"c_kpa": [0.0, 12.0, "a source"]}}
    >>> r = reading_reweighted(t, post, t)                          # read alike: weighed alike
    >>> float(r["mean_drawn"].iloc[0]), float(r["mean_reweighted"].iloc[0]), float(r["shift_share"].iloc[0])
    (2.0, 2.0, 0.0)
    >>> r = reading_reweighted(t, post, t.assign(c_kpa=[6.0, 6.0]))   # the second sample's c read inside: its weight
    >>> float(r["mean_reweighted"].round(3).iloc[0]), float(r["shift_share"].round(2).iloc[0])
    (3.0, 0.5)
    """
    from analysis.soil.bayes import MIDDLE, in_ranges, largest_step
    ranges = {r: v[:2] for r, v in post["targets"].items() if r in RESPONSES}
    sd = np.sqrt(post["likelihood_sigma"][-1]) * largest_step(post["targets"])

    def misfit(t):
        return np.sum([(t[r].map(lambda v, rg=rg: in_ranges(v, rg)).to_numpy(float) - MIDDLE) ** 2
                       for r, rg in ranges.items() if r in t], axis=0)
    drawn = table["weight_last"].to_numpy(float) / table["weight_last"].sum()
    again = drawn * np.exp(-0.5 * (misfit(measured_table) - misfit(table)) / sd ** 2)
    again = again / again.sum()
    rows = []
    for n in post["names"]:
        lo, hi = post["interval"][n]
        a, b = float(np.sum(drawn * table[n])), float(np.sum(again * table[n]))
        rows.append({"parameter": n, "mean_drawn": a, "mean_reweighted": b, "interval_lo": lo, "interval_hi": hi,
                     "shift_share": (b - a) / (hi - lo) if hi > lo else np.nan,
                     "ess_drawn": float(1 / np.sum(drawn ** 2)), "ess_reweighted": float(1 / np.sum(again ** 2))})
    return pd.DataFrame(rows)


def reading_reweighted_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """reading-reweighted.csv: `reading_reweighted` of every soil whose filter drew its posterior under another
    reading of the shear box than the current one (no `shear_reading`, or another), its last iteration's evaluations
    measured again from their stored results; None when no soil's was."""
    out_dir = Path(out_dir)
    tables = []
    for soil in SOILS:
        paths = out_dir / f"{soil}.csv", out_dir / f"{soil}-posterior.json"
        if not all(p.exists() for p in paths):
            continue
        post = json.loads(paths[1].read_text())
        if post.get("shear_reading") == READING or "likelihood_sigma" not in post:
            continue
        table = pd.read_csv(paths[0], comment="#", float_precision="round_trip")
        last = table[table["weight_last"].notna()].reset_index(drop=True)
        again = pd.DataFrame([measured(r, out_dir / soil / str(r["id"]), kept_only=True)
                              for r in last.to_dict(orient="records")])
        tables.append(reading_reweighted(last, post, again).assign(soil=soil, drawn_under=post.get("shear_reading",
                                                                                                   "the lid's load")))
    if not tables:
        return None
    path = out_dir / "reading-reweighted.csv"
    atomic_csv(pd.concat(tables).round(4), path,
               f"./holes calibration-report; each filter drawn under another reading of the shear box than the current "
               f"one ({READING}): its last iteration's samples weighed again with their responses measured again, "
               "the posterior mean as drawn and so weighed, the shift as a share of the 95 % interval; the samples stay "
               "the filter's")
    return path


def cone_per_c(sets: list[dict]) -> pd.DataFrame:
    """How the cone index follows the shear box's cohesion: per checked set (`soil`, its box's c per packing `c`, its
    cone at the runs' grains per packing `cone`, the soil's cone floor `cone_lo`), each mean with its 95 % t interval,
    their ratio, and the c that ratio asks for the cone to reach its floor. A cone that reads c times a bearing factor
    ties c's range to the cone's: where that c lies over c's range, no set of this kind meets both.

    >>> t = cone_per_c([{"soil": "sand", "c": [10.0, 12.0, 14.0], "cone": [350.0, 370.0, 390.0], "cone_lo": 357.0}])
    >>> r = t.iloc[0]; round(r.c_mean, 1), round(r.cone_mean), round(r.ratio, 1), round(r.c_for_cone_floor, 1)
    (12.0, 370, 30.8, 11.6)
    """
    rows = []
    for one in sets:
        c, cone = np.asarray(one["c"], float), np.asarray(one["cone"], float)
        (c_lo, c_hi), (cone_a, cone_b) = (mean_verdict(v, -np.inf, np.inf)["mean_interval"] for v in (c, cone))
        ratio = cone.mean() / c.mean()
        rows.append({**{k: v for k, v in one.items() if k not in ("c", "cone")}, "packings_c": len(c),
                     "c_mean": c.mean(), "c_lo": c_lo, "c_hi": c_hi, "packings_cone": len(cone),
                     "cone_mean": cone.mean(), "cone_mean_lo": cone_a, "cone_mean_hi": cone_b, "ratio": ratio,
                     "c_for_cone_floor": one["cone_lo"] / ratio})
    return pd.DataFrame(rows)


def cone_per_c_run(out_dir: Path = BENCH_DIR) -> Path | None:
    """cone-per-c.csv: `cone_per_c` over every set checked in out_dir and its folders (`checked_sets`) with its box on
    three packings or more and its cone at the runs' grains (`runs_cone`, kept in <out_dir>/cone/) on one or more;
    None when no set has both."""
    out_dir = Path(out_dir)
    sets = []
    cfgs = {s: runs_cone(load_config(soil=s)) for s in SOILS}      # each soil's cone as the checks read it
    for folder, soil, params, rows in checked_sets(out_dir):
        cfg = cfgs[soil]
        c = rows["c_kpa"].dropna().to_numpy(float)
        paths = [cone_path(soil, params, cfg, out_dir, int(seed))[0] for seed in sorted(rows["seed"].unique())]
        cone = [json.loads(p.read_text())["cone_index_pa"] / 1000 for p in paths if p.exists()]
        if len(c) >= 3 and cone:
            sets.append({"soil": soil, "folder": folder.relative_to(out_dir).as_posix() or ".",
                         **{k: round(v, 5) for k, v in params.items()}, "cone_lo": cone_range(soil, cfg)[0],
                         "c": c, "cone": cone})
    if not sets:
        return None
    path = out_dir / "cone-per-c.csv"
    atomic_csv(cone_per_c(sets).round(3), path,
               "./holes calibration-report; per checked set (bench/ and its folders): the box's c over its packings and "
               "the cone at the runs' grains over those it ran on, each mean with its 95 % t interval, the cone per kPa "
               "of c and the c that ratio asks for the cone to reach Table 2's floor (cone_lo)")
    return path


ODDS_PACKINGS = (3, 6, 9, 12)           # the check sizes check-odds.csv tells the odds of


def check_odds(ranges: dict[str, tuple], scatter: dict[str, float], packings: int, draws: int = 20_000) -> pd.DataFrame:
    """Per response: what a check on `packings` packings can tell of its target range (lo, hi) given the packings'
    scatter (SD at one parameter set): the range's half-width in packing SDs, the chance that one packing of a set
    whose mean over many packings is the range's middle lies inside (`one_inside`) and that every one of them does
    (`all_inside`: the best odds of the per-packing check), that the 95 % t interval of their mean lies inside
    (`interval_inside`: the mean verdict decided, `draws` seeded draws) and the standard error of the packings' mean.

    >>> t = check_odds({"c_kpa": (0, 12)}, {"c_kpa": 5.1}, 3).iloc[0]
    >>> round(t.half_width_sd, 2), round(t.one_inside, 2), round(t.all_inside, 2), round(t.mean_se, 2)
    (1.18, 0.76, 0.44, 2.94)
    >>> round(t.interval_inside, 2), round(check_odds({"c_kpa": (0, 12)}, {"c_kpa": 5.1}, 9).iloc[0].interval_inside, 2)
    (0.09, 0.74)
    """
    rng = np.random.default_rng(0)
    z = rng.standard_normal((draws, packings))
    m, sd = z.mean(axis=1), z.std(axis=1, ddof=1)
    half_t = stats.t.ppf(0.975, packings - 1) * sd / np.sqrt(packings)
    rows = []
    for r, (lo, hi) in ranges.items():
        half_sd = (hi - lo) / 2 / scatter[r]
        one = 2 * stats.norm.cdf(half_sd) - 1
        rows.append({"response": r, "lo": lo, "hi": hi, "packing_sd": scatter[r], "half_width_sd": half_sd,
                     "one_inside": one, "all_inside": one ** packings,
                     "interval_inside": float(np.mean(np.abs(m) + half_t <= half_sd)),
                     "mean_se": scatter[r] / np.sqrt(packings)})
    return pd.DataFrame(rows)


def check_odds_run(out_dir: Path = BENCH_DIR) -> Path:
    """check-odds.csv: check_odds for every soil's targets (the cone's where its filter fits it) with the
    [packing_scatter] SDs, on its [bench] check_seeds and on each of ODDS_PACKINGS packings."""
    tables = []
    for soil in SOILS:
        cfg = load_config(soil=soil)
        for n in sorted({len(cfg["check_seeds"]), *ODDS_PACKINGS}):
            odds = check_odds(target_ranges(soil, cfg), cfg["packing_scatter"], n)
            every = pd.DataFrame([{"response": "every target", **{k: odds[k].prod() for k in
                                                                   ("one_inside", "all_inside", "interval_inside")}}])
            tables.append(pd.concat([odds, every]).assign(soil=soil, packings=n))
    table = pd.concat(tables)[["soil", "packings", "response", "lo", "hi", "packing_sd", "half_width_sd",
                               "one_inside", "all_inside", "interval_inside", "mean_se"]]
    path = Path(out_dir) / "check-odds.csv"
    atomic_csv(table.round(3), path,
               "./holes calibration-report; per soil, number of packings checked and target, the packings' SD "
               "([packing_scatter]) against the range, for a set whose mean over many packings is the range's middle: "
               "the chance one packing, and every checked packing, lies inside, that the 95 % t interval of the checked "
               "packings' mean lies inside (the mean verdict decided), and that mean's standard error; `every target`: "
               "all of a soil's targets at once, the packings' scatter taken as independent between responses")
    return path
