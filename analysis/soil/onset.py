"""Why pressed re-adhesion has an onset: how far the wall-free cell's filter could lift clay's c without one, and the
single tests of the onset (no YADE here).

`reach`: the cell filter's evaluations (results/calibration/bench/cell-filter/clay/, and the evaluations with a bond
stretch run beside the box filter's in bench/clay/) fitted as planes in their six parameters (c, φ and the collapse
slope; the cone over these and the box filter's cones, which share every term but the stretch), and the most c the
planes give inside the cell prior with φ, the slope and the cone in their ranges (scipy's linear programme); again
with the collapse slope's α term taken out, the heap the onset is for.
`probes`: the onset's single tests (results/calibration/bench/onset/<law>/<test>/<name>/, each run as
scripts/collapse.py, simple_shear.py or cone.py with --test-set items, listed in that folder's README): one row
each with its parameters and reading.
`filter_evaluations`: the finished evaluations in the onset filter's folder (bench/onset-filter/: the filter's and
--probe's), one row each, before the filter has drawn its iteration's table.
`cone_ratio`: one set's cones by cone-to-grain ratio, the smallest against the pooled larger ones.
`deepest`: the onset filter's evaluations fitted as planes, and the set in its prior they put deepest inside every
target, in the planes' residual SDs: where a probe looks next, not a posterior.
Writes onset-reach.csv, onset-planes.csv, onset/probes.csv, onset/cone-ratio.csv, onset-filter/evaluations.csv and
onset-filter/deepest.csv in results/calibration/bench/.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import atomic_csv
from analysis.core.schema import ROOT
from analysis.core.soil_config import BENCH_DIR
from analysis.soil.collapse import FLOORS
from analysis.soil.bench_calibration import (cone_path, cone_range, deepest_margin, difference_interval,
                                             evaluation_id, least_squares_plane, load_config, measured,
                                             scene_result, target_ranges)

CELL_CONFIG = ROOT / "configs/bench_calibration_cell.toml"
ONSET_CONFIG = ROOT / "configs/bench_calibration_onset.toml"
TERMS = ("normal_cohesion", "friction_deg", "pressed_adhesion", "rolling_friction", "damping", "bond_stretch")
OWN = ("shear_cohesion", "adhesion_share", "tool_friction_deg", "young")   # a probe's own contact parameters besides TERMS:
# a shear bond of its own (the filter's sets hold it equal to the normal bond), the share law, the tools' friction,
# the contact modulus
SCALE = {"normal_cohesion": 1e3, "young": 1e6}     # the bond in kPa and the modulus in MPa in the planes
TOOLS_TERMS = (*TERMS, "young")                    # the planes of the filters that calibrate the contact modulus too
TOOLS_CONFIGS = {"tools-filter": ROOT / "configs/bench_calibration_tools.toml",   # the filters with the cone at the
                 "corner-filter": ROOT / "configs/bench_calibration_corner.toml",  # soil's friction on steel
                 "own-filter": ROOT / "configs/bench_calibration_own.toml",
                 "sized-filter": ROOT / "configs/bench_calibration_sized.toml",
                 "sized-cone-filter": ROOT / "configs/bench_calibration_sized_cone.toml"}
# a test's scene options kept in its row, each with its type: a cone's grains, size and speed
OPTIONS = {"--resolution": ("resolution", str), "--cone-scale": ("cone_scale", float),
           "--cone-speed": ("cone_speed", float)}
TESTS = {"collapse": ("angle_deg", "height_ratio", "runout_mm"), "cell": ("c_kpa", "phi_deg"),
         "cone": ("cone_index_pa", "cone_to_particle")}
RATIO_POOLED = 3.2         # cones this many grains across or more read alike (bench/onset/README.md): pooled


def cell_evaluations(soil: str = "clay", bench_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """Every finished cell evaluation with a bond stretch: parameters, c, φ, the collapse slope and (where it ran) the
    cone index, kPa."""
    cfg = load_config(CELL_CONFIG, soil)
    rows = []
    for out_dir in (Path(bench_dir) / "cell-filter", Path(bench_dir)):
        for done in sorted((out_dir / soil).glob("*/responses.json")):
            row = json.loads(done.read_text())
            if "bond_stretch" not in row or row.get("failed") or scene_result(done.parent, "shear") is None:
                continue
            row = measured(row, done.parent)
            path, _ = cone_path(soil, {k: row[k] for k in TERMS}, cfg, out_dir)
            cone = json.loads(path.read_text())["cone_index_pa"] / 1e3 if path.exists() else math.nan
            rows.append({"id": row["id"], **{k: row[k] for k in TERMS}, "c_kpa": row["c_kpa"],
                         "phi_deg": row["phi_deg"], "collapse_deg": row["collapse_deg"], "cone_kpa": cone})
    return pd.DataFrame(rows)


def plane(table: pd.DataFrame, response: str, terms: tuple = TERMS) -> tuple[np.ndarray, float, float]:
    """Least-squares plane of `response` in `terms` (the bond in kPa, the modulus in MPa): intercept then a slope per
    term, R² and the residual SD (n − terms − 1 degrees of freedom; NaN with no more rows than that)."""
    ok = table.dropna(subset=[response])
    X = np.column_stack([ok[t].fillna(0.0) / SCALE.get(t, 1.0) for t in terms])
    coef, r2, resid = least_squares_plane(X, ok[response].to_numpy(float))
    dof = len(ok) - len(terms) - 1
    return coef, r2, float(np.sqrt(np.sum(resid ** 2) / dof)) if dof > 0 else math.nan


def planes(soil: str = "clay", bench_dir: Path = BENCH_DIR) -> tuple[dict, int]:
    """The cell evaluations' planes (`plane`) of c, φ and the collapse slope, and the cone's over them and the box
    filter's evaluations (<soil>.csv, the stretch 0); and how many cell evaluations there are."""
    cells = cell_evaluations(soil, bench_dir)
    box = pd.read_csv(Path(bench_dir) / f"{soil}.csv", comment="#").assign(bond_stretch=0.0)
    fitted = {r: plane(cells, r) for r in ("c_kpa", "phi_deg", "collapse_deg")}
    fitted["cone_kpa"] = plane(pd.concat([box, cells], ignore_index=True), "cone_kpa")
    return fitted, len(cells)


def planes_table(fitted: dict) -> pd.DataFrame:
    """One row a response: its plane's intercept, a slope per term (per kPa of bond) and R²."""
    return pd.DataFrame([{"response": r, "intercept": c[0], **dict(zip(TERMS, c[1:])), "r2": r2}
                         for r, (c, r2, _) in fitted.items()])


def reach(soil: str = "clay", bench_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """The most c the planes give inside the cell prior with φ, the collapse slope and the cone in range; again with
    the slope's α term at 0. One row each: the planes' c, φ, slope and cone there and the parameters."""
    from scipy.optimize import linprog
    cfg = load_config(CELL_CONFIG, soil)
    ranges = {**target_ranges(soil, cfg), "cone_kpa": cone_range(soil, cfg)}
    planes_, n = planes(soil, bench_dir)
    bounds = [tuple(v / SCALE.get(t, 1.0) for v in cfg["bounds"][t]) for t in TERMS]
    rows = []
    for heap, alpha_in_heap in (("as fitted", True), ("without α in the heap", False)):
        coefs = {r: c.copy() for r, (c, *_) in planes_.items()}
        if not alpha_in_heap:
            coefs["collapse_deg"][1 + TERMS.index("pressed_adhesion")] = 0.0
        A, b = [], []
        for r in ("phi_deg", "collapse_deg", "cone_kpa"):
            lo, hi = ranges[r]
            A += [coefs[r][1:], -coefs[r][1:]]
            b += [hi - coefs[r][0], coefs[r][0] - lo]
        out = linprog(-coefs["c_kpa"][1:], A_ub=A, b_ub=b, bounds=bounds)
        x = out.x if out.success else np.full(len(TERMS), np.nan)
        rows.append({"soil": soil, "slope_plane": heap, "evaluations": n,
                     **{r: float(coefs[r][0] + coefs[r][1:] @ x) for r in coefs},
                     **{t: float(v * SCALE.get(t, 1.0)) for t, v in zip(TERMS, x)},
                     **{f"r2_{r}": planes_[r][1] for r in planes_}, "c_floor": ranges["c_kpa"][0]})
    return pd.DataFrame(rows)


def probes(folder: Path = BENCH_DIR / "onset") -> pd.DataFrame:
    """The onset's single tests, one row each: the law (the folder: impacts, held, no-readhesion), the test, the name,
    the --test-set parameters of the command it ran (its `command` file; a cone's --cohesion as both bonds), its
    OPTIONS, and its reading; a collapse that had not come to rest by its time limit reads NaN with `still_moving`."""
    rows = []
    for test_dir in sorted(Path(folder).glob("*/*/*")):
        law, test, name = test_dir.relative_to(folder).parts
        words = (test_dir / "command").read_text().split()
        row = {"law": law, "test": test, "name": name,
               **{OPTIONS[w][0]: OPTIONS[w][1](words[i + 1]) for i, w in enumerate(words) if w in OPTIONS},
               **{k: float(v) for k, v in (words[i + 1].split("=") for i, w in enumerate(words) if w == "--test-set")}}
        if "--cohesion" in words:                      # the cone's --cohesion: both bonds, a --test-set of either wins
            for key in ("normal_cohesion", "shear_cohesion"):
                row.setdefault(key, float(words[words.index("--cohesion") + 1]))
        result = next((json.loads(p.read_text()) for p in sorted(test_dir.glob("*.json"))), None)
        if result is None:
            row["still_moving"] = "still move" in next(test_dir.glob("*.log")).read_text()
        else:
            row.update({k: result[k] for k in TESTS[test] if k in result})
            if test == "cell":
                row["tau_peak_kpa"] = " ".join(f"{t['tau_peak_kpa']:.1f}" for t in result["tests"])
        rows.append(row)
    table = pd.DataFrame(rows)
    if "cone_index_pa" in table:
        table["cone_kpa"] = table.pop("cone_index_pa") / 1e3
    return table


def filter_evaluations(folder: Path, config: Path = ONSET_CONFIG) -> pd.DataFrame:
    """Every evaluation finished in the onset filter's folder (`folder`/<soil>/*/responses.json), the filter's and the
    chosen sets' of `--probe` (`probe`: its id in `folder`/<soil>-probes.csv), one row each: its id, the collapse
    column's floor, the parameters (OWN's where a probe gave them, else empty), c and φ
    from its cell (read where the column failed too), the collapse slope and
    why it failed, if it did; the cone index where it ran (`config`'s cone, kept in `folder`/cone/). An evaluation
    whose id neither floor under `config`'s settings draws (another box's, another stress's) is left out."""
    from analysis.soil.collapse import profile_angle
    from analysis.soil.shear import fit_tests
    rows, cfgs = [], {}
    probed = set().union(*(pd.read_csv(p, comment="#")["id"] for p in Path(folder).glob("*-probes.csv")))
    for done in sorted(Path(folder).glob("*/*/responses.json")):
        row, here = json.loads(done.read_text()), done.parent
        cell, column = scene_result(here, "shear"), scene_result(here, "collapse")
        fit = fit_tests(cell["tests"]) if cell else {}
        failed = row.get("failed") if isinstance(row.get("failed"), str) else ""
        if row["soil"] not in cfgs:                             # the config read once a soil
            cfgs[row["soil"]] = load_config(config, row["soil"])
        cfg, params = cfgs[row["soil"]], {k: row[k] for k in (*TERMS, *OWN) if k in row}
        floor = next((f for f in FLOORS                # the floor its id was drawn with
                      if evaluation_id(row["soil"], row["seed"], params, {**cfg, "collapse_floor": f}) == row["id"]),
                     None)
        if floor is None:                              # drawn under other bench settings: not the filter's
            continue
        cone, _ = cone_path(row["soil"], params, cfg, folder)
        rows.append({"soil": row["soil"], "id": row["id"], "seed": row["seed"], "probe": row["id"] in probed,
                     "floor": floor,
                     **{k: row[k] for k in TERMS}, **{k: row.get(k, math.nan) for k in OWN},
                     "c_kpa": fit.get("c_kpa", math.nan),
                     "phi_deg": fit.get("phi_deg", math.nan),
                     "collapse_deg": profile_angle(column["profile_mm"]) if column else math.nan,
                     "cone_kpa": json.loads(cone.read_text())["cone_index_pa"] / 1e3 if cone.exists() else math.nan,
                     "failed": failed.removeprefix("scripts/collapse.py: collapse stopped: collapse: ")})
    return pd.DataFrame(rows)


def cone_ratio(table: pd.DataFrame, pooled: float = RATIO_POOLED) -> pd.DataFrame:
    """The single tests' cones of one set at 0.5 m/s (`table`, probes(): every parameter alike to three significant
    figures, so readings that differ only in the last digits are repeats) by cone-to-grain ratio: one row for the
    smallest ratio and one for every ratio of `pooled` or more together, each with its readings, mean and SD; the
    pooled row also with Welch's difference from the smallest ratio's mean (95 % interval, p) and the ratio of the
    means. Sets without two cones at each are left out."""
    from scipy import stats
    cones = table[(table["test"] == "cone") & (table["cone_speed"] == 0.5)].copy()
    keys = [f"{t}_3sf" for t in TERMS]
    for t, k in zip(TERMS, keys):
        cones[k] = [float(f"{v:.3g}") for v in cones[t]]
    rows = []
    for _, group in cones.groupby(keys):
        low = group[group["cone_to_particle"] == group["cone_to_particle"].min()]
        high = group[group["cone_to_particle"] >= pooled]
        if len(low) < 2 or len(high) < 2:
            continue
        a, b = low["cone_kpa"].to_numpy(), high["cone_kpa"].to_numpy()
        diff, lo, hi = difference_interval(a, b)
        welch = stats.ttest_ind(b, a, equal_var=False)
        base = {t: group[k].iloc[0] for t, k in zip(TERMS, keys)}
        for part, x, label in ((low, a, f"{low['cone_to_particle'].iloc[0]:.2f}"), (high, b, f">= {pooled:g}")):
            rows.append({**base, "grains_across": label, "n": len(x), "names": " ".join(part["name"]),
                         "readings_kpa": " ".join(f"{v:.1f}" for v in x), "mean_kpa": x.mean(),
                         "sd_kpa": x.std(ddof=1)})
        rows[-1].update({"minus_smallest_kpa": diff, "lo_kpa": lo, "hi_kpa": hi,
                         "welch_p": welch.pvalue, "ratio_of_means": b.mean() / a.mean()})
    return pd.DataFrame(rows)


RESPONSES = ("c_kpa", "phi_deg", "collapse_deg", "cone_kpa")


def plane_rows(table: pd.DataFrame, transfer: float = 1.0) -> dict:
    """Each response's evaluations for its plane, from `table` (`filter_evaluations`): every parameter set once, the
    cone times `transfer`, the collapse slope from columns on the grains only (a twin on the plane counts once); the
    sets with a parameter of OWN left out, for the planes' terms hold the shear bond equal to the normal bond and
    re-adhere by α."""
    table = table[table[[k for k in OWN if k in table]].isna().all(axis=1)]
    sets = table.drop_duplicates(subset=list(TERMS)).assign(cone_kpa=lambda t: t["cone_kpa"] * transfer)
    grains = table[table["floor"] == "grains"].drop_duplicates(subset=list(TERMS))
    return {r: grains if r == "collapse_deg" else sets for r in RESPONSES}


def has_planes(table: pd.DataFrame) -> bool:
    """Whether every response of `table` has the evaluations a plane with a residual SD needs (`plane_rows`: two
    more than TERMS), as a filter that has just begun has not."""
    return all(own[r].notna().sum() >= len(TERMS) + 2 for r, own in plane_rows(table).items())


def deepest(table: pd.DataFrame, ranges: dict, bounds: dict, transfer: float = 1.0) -> dict:
    """The evaluations of `table` (`filter_evaluations`: each parameter set once, its collapse slope from a column on
    the grains only) fitted as planes (`plane`) of c, φ, the collapse slope and the cone times `transfer` (the
    config's cone transfer, as the filter weighs it), and the set inside `bounds` {term: (lo, hi)} the planes put
    deepest inside every range {response: (lo, hi)}: the largest margin m such that each plane lies m of its residual
    SDs (n − 7 degrees of freedom) inside its range (`deepest_margin`); a negative m, where the ranges do not meet
    inside the bounds. Returns margin_sd, the parameters, each response's plane value there, its plane's R² and
    residual SD and its evaluations."""
    coefs, fits = {}, {}
    for r, own in plane_rows(table, transfer).items():
        coefs[r], r2, sd = plane(own, r)
        fits[r] = {"r2": r2, "resid_sd": sd, "n": int(own[r].notna().sum())}
        if not np.isfinite(sd):
            raise ValueError(f"{r}: {fits[r]['n']} evaluations for a plane of {len(TERMS)} terms; allowed "
                             f"{len(TERMS) + 2} or more")
    x, margin = deepest_margin(np.array([coefs[r][1:] for r in RESPONSES]), [coefs[r][0] for r in RESPONSES],
                               [fits[r]["resid_sd"] for r in RESPONSES], [ranges[r] for r in RESPONSES],
                               [tuple(v / SCALE.get(k, 1.0) for v in bounds[k]) for k in TERMS])
    return {"margin_sd": margin, **{k: float(v * SCALE.get(k, 1.0)) for k, v in zip(TERMS, x)},
            **{r: float(coefs[r][0] + coefs[r][1:] @ x) for r in RESPONSES},
            **{f"{key}_{r}": fits[r][key] for r in RESPONSES for key in ("r2", "resid_sd", "n")}}


def deepest_table(folder: Path, config: Path = ONSET_CONFIG) -> pd.DataFrame:
    """`deepest` of each soil with the evaluations for its planes (`has_planes`) in the onset filter's folder, in its
    prior and against its targets (the cone's Table 2 ± tolerance, its reading times the config's transfer)."""
    table = filter_evaluations(folder, config)
    rows = []
    for soil, own in table.groupby("soil") if len(table) else []:
        if not has_planes(own):
            continue
        cfg = load_config(config, soil)
        ranges = {**target_ranges(soil, cfg), "cone_kpa": cone_range(soil, cfg)}
        transfer = float(cfg["cone_check"].get("transfer", 1.0))
        rows.append({"soil": soil, "cone_transfer": transfer, **deepest(own, ranges, cfg["bounds"], transfer)})
    return pd.DataFrame(rows)


def tools_evaluations(bench_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """Every finished evaluation of the filters that calibrate the contact modulus with the cone at the soil's
    friction on steel (TOOLS_CONFIGS: the filters' own and --probe's, `filter_evaluations`), each parameter set of a
    soil once, its filter named; a set with a contact parameter of its own besides the modulus (OWN) left out."""
    parts = [filter_evaluations(Path(bench_dir) / name, config).assign(filter=name)
             for name, config in TOOLS_CONFIGS.items() if (Path(bench_dir) / name).is_dir()]
    parts = [p for p in parts if len(p)]
    if not parts:
        return pd.DataFrame()
    table = pd.concat(parts, ignore_index=True)
    table = table[table[[k for k in OWN if k != "young"]].isna().all(axis=1) & table["young"].notna()]
    return table.drop_duplicates(subset=["soil", *TOOLS_TERMS]).reset_index(drop=True)


def prior_reach(coefs: dict, sds: dict, ranges: dict, bounds: dict, n: int = 200_000, seed: int = 0) -> dict:
    """Where planes {response: intercept then a slope per TOOLS_TERMS} meet every range {response: (lo, hi)} inside
    `bounds` {term: (lo, hi)}: the share of the prior (uniform) where every plane lies inside its range, and the set
    the planes put deepest inside them, its margin in the planes' residual SDs `sds` (`deepest_margin`; negative where
    they do not all meet) with the planes' responses there. Where a prior has room, not a posterior.

    >>> one = {"c_kpa": np.array([0.0, 0.1, 0, 0, 0, 0, 0, 0])}
    >>> r = prior_reach(one, {"c_kpa": 1.0}, {"c_kpa": (5.0, 10.0)}, {t: (0.0, 1.0) for t in TOOLS_TERMS}
    ...                 | {"normal_cohesion": (0.0, 2e5)})
    >>> round(r["share"], 2), round(r["margin_sd"], 2), round(r["c_kpa"], 2)
    (0.25, 2.5, 7.5)
    """
    rng = np.random.default_rng(seed)
    box = [tuple(v / SCALE.get(t, 1.0) for v in bounds[t]) for t in TOOLS_TERMS]
    sample = np.column_stack([rng.uniform(lo, hi, n) for lo, hi in box])
    inside = np.ones(n, bool)
    for r, c in coefs.items():
        plane_values = sample @ c[1:] + c[0]
        inside &= (plane_values >= ranges[r][0]) & (plane_values <= ranges[r][1])
    x, margin = deepest_margin(np.array([c[1:] for c in coefs.values()]), [c[0] for c in coefs.values()],
                               [sds[r] for r in coefs], [ranges[r] for r in coefs], box)
    return {"share": float(inside.mean()), "margin_sd": margin,
            **{t: float(v * SCALE.get(t, 1.0)) for t, v in zip(TOOLS_TERMS, x)},
            **{r: float(c[0] + c[1:] @ x) for r, c in coefs.items()}}


def tools_priors(bench_dir: Path = BENCH_DIR, planes_soil: str = "clay") -> tuple[pd.DataFrame, pd.DataFrame]:
    """`planes_soil`'s planes in TOOLS_TERMS over the tools and corner filters' evaluations (`tools_evaluations`; the
    cone as read, r = 8 mm, the collapse slope on the grains), and each soil's reach (`prior_reach`) in each of those
    filters' priors against its targets (the cone's reading times the config's transfer, c and φ plus its
    shear_shift): the planes as fitted, and for another soil also shifted by its own offsets, the mean residual of
    its own sets (its beds' density and its friction on steel differ). Returns the planes (a row a response) and the
    reaches (a row a soil, prior and shift)."""
    table = tools_evaluations(bench_dir)
    base = table[table["soil"] == planes_soil]
    fits = {r: plane(base[base["floor"] == "grains"] if r == "collapse_deg" else base, r, TOOLS_TERMS)
            for r in RESPONSES}
    planes_ = pd.DataFrame([{"soil": planes_soil, "response": r, "intercept": c[0], **dict(zip(TOOLS_TERMS, c[1:])),
                             "r2": r2, "resid_sd": sd, "n": int(base[r].notna().sum())}
                            for r, (c, r2, sd) in fits.items()])
    rows = []
    for soil, own in table.groupby("soil"):
        X = np.column_stack([own[t] / SCALE.get(t, 1.0) for t in TOOLS_TERMS])
        offsets = {r: float(np.nanmean(own[r] - (c[0] + X @ c[1:]))) for r, (c, _, _) in fits.items()}
        for name, config in TOOLS_CONFIGS.items():
            cfg = load_config(config, soil)
            transfer = float(cfg["cone_check"].get("transfer", 1.0))
            ranges = {**target_ranges(soil, cfg), "cone_kpa": cone_range(soil, cfg)}
            scale = {r: transfer if r == "cone_kpa" else 1.0 for r in RESPONSES}
            added = cfg.get("shear_shift", {})          # c and φ as that filter weighs them
            for shift in ("none", "own")[:1 if soil == planes_soil else 2]:
                coefs = {r: np.r_[(c[0] + (offsets[r] if shift == "own" else 0.0)) * scale[r] + added.get(r, 0.0),
                                  c[1:] * scale[r]] for r, (c, _, _) in fits.items()}
                rows.append({"soil": soil, "prior": name, "shift": shift, "own_sets": len(own),
                             **{f"offset_{r}": offsets[r] for r in RESPONSES},
                             **prior_reach(coefs, {r: sd * scale[r] for r, (_, _, sd) in fits.items()}, ranges,
                                           cfg["bounds"])})
    return planes_, pd.DataFrame(rows)


PLANES_FOLDERS = {"clay": "corner-filter", "loam": "own-filter"}   # each soil whose planes placed a prior: its filter


def tools_priors_run(soil: str, folder: Path, bench_dir: Path = BENCH_DIR) -> list[Path]:
    """planes.csv and priors.csv in `folder`: `soil`'s planes over the tools filters' evaluations and each soil's
    reach by them in each of those filters' priors (`tools_priors`)."""
    planes_, reach_ = tools_priors(bench_dir, planes_soil=soil)
    paths = [Path(folder) / "planes.csv", Path(folder) / "priors.csv"]
    atomic_csv(planes_.round(5), paths[0], f"./holes calibration-report: {soil}'s planes over the tools filters' "
               "evaluations (the cone as read at r = 8 mm), a slope per term (the bond per kPa, the modulus per MPa), "
               "R², residual SD (analysis/soil/onset.py)")
    atomic_csv(reach_.round(4), paths[1], f"./holes calibration-report: each soil in the tools filters' priors by "
               f"{soil}'s planes (shift own: moved by the soil's own sets' mean residual): the share of the prior "
               "inside every target, and the set deepest inside, margin_sd in the planes' residual SDs: where a prior "
               "has room, not a posterior (analysis/soil/onset.py)")
    return paths


def run(bench_dir: Path = BENCH_DIR) -> list[Path]:
    """onset-reach.csv, onset-planes.csv, onset-filter/evaluations.csv and deepest.csv, the planes and priors of each
    soil in PLANES_FOLDERS (`tools_priors_run`), onset/probes.csv and onset/cone-ratio.csv in `bench_dir`, where their
    inputs exist."""
    paths = []
    if (Path(bench_dir) / "cell-filter" / "clay").is_dir():
        paths += [Path(bench_dir) / "onset-reach.csv", Path(bench_dir) / "onset-planes.csv"]
        atomic_csv(reach("clay", bench_dir).round(4), paths[-2], "./holes calibration-report: the most c clay's cell "
                   "planes reach with φ, the collapse slope and the cone in range (analysis/soil/onset.py)")
        atomic_csv(planes_table(planes("clay", bench_dir)[0]).round(5), paths[-1], "./holes calibration-report: "
                   "clay's cell planes, a slope per term (the bond per kPa), R² (analysis/soil/onset.py)")
    if (Path(bench_dir) / "onset-filter").is_dir():
        paths.append(Path(bench_dir) / "onset-filter" / "evaluations.csv")
        atomic_csv(filter_evaluations(Path(bench_dir) / "onset-filter").round(4), paths[-1], "./holes "
                   "calibration-report: the finished evaluations of the onset filter, whichever iteration, and of "
                   "--probe (configs/bench_calibration_onset.toml; analysis/soil/onset.py)")
        paths.append(Path(bench_dir) / "onset-filter" / "deepest.csv")
        atomic_csv(deepest_table(Path(bench_dir) / "onset-filter").round(4), paths[-1], "./holes calibration-report: "
                   "the set in the onset prior whose planes over the onset filter's evaluations (and --probe's) lie "
                   "deepest inside every target, margin_sd in the planes' residual SDs: where a probe looks next, "
                   "not a posterior (analysis/soil/onset.py)")
    for soil, folder in PLANES_FOLDERS.items():
        if (Path(bench_dir) / folder).is_dir():
            paths += tools_priors_run(soil, Path(bench_dir) / folder, bench_dir)
    if (Path(bench_dir) / "onset").is_dir():
        paths += [Path(bench_dir) / "onset" / "probes.csv", Path(bench_dir) / "onset" / "cone-ratio.csv"]
        table = probes(Path(bench_dir) / "onset")
        atomic_csv(table.round(4), paths[-2], "./holes calibration-report: the onset's single tests "
                   "(results/calibration/bench/onset/README.md)")
        atomic_csv(cone_ratio(table).round(4), paths[-1], "./holes calibration-report: one set's cones by "
                   f"cone-to-grain ratio, the smallest against {RATIO_POOLED:g} or more (Welch; analysis/soil/onset.py)")
    return paths
