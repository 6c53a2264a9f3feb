"""The wall-free simple shear cell's reading of the soils (scripts/simple_shear.py runs the cell; no YADE here).

Each soil's posterior mean (results/calibration/bench/<soil>-posterior.json) sheared in periodic cells of two edges,
one the other grown by half, on several packings each (`./holes calibrate --soil S --bench --size-check cell --seeds
1,2,3`, the runs kept in results/calibration/bench/cell/<soil>/set-<hash>/): c and φ of each packing's Mohr–Coulomb
fit (peak τ against σzz at the peak, analysis/soil/shear.py); the cell's size check by the shear box's rule
(`size_shift`: the grown cell moves the mean less than the packings' SD in the smaller); each soil's c and φ in the
smallest cell that passes against its target's range (`mean_verdict`); and each shear box's peak beside the cell's,
per normal stress.
Writes cell.csv, cell-size.csv, cell-rate.csv (the rate check: a cell sheared at half the rate), cell-box.csv
and cell.png in results/calibration/bench/; and cell-levers.csv: what single contact parameters moved off the
posterior do to the cell's c (the probes kept in results/calibration/bench/cell/<soil>/probes/<name>/, each run as
`./holes simple-shear` with the posterior's --test-sets and one changed) beside what they cost the cone.
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.bed_spec import CELL_INERTIAL, cell_key
from analysis.core.config import load_resolution
from analysis.core.io import atomic_csv
from analysis.core.runner import run_logged
from analysis.core.schema import ROOT, digest
from analysis.core.soil_config import BENCH_DIR, SOIL_COLOURS, SOILS, equal_bonds, load_soil
from analysis.soil.bench_calibration import (SHEAR_RESPONSES, cone_path, cone_range, in_parallel, load_config,
                                             mean_verdict, mm, posterior_mean, posterior_packings, rounded,
                                             scene_result, size_shift, surface_terms, target_ranges)
from analysis.soil.shear import fit_tests

CELL_DIR = BENCH_DIR / "cell"
UNMEASURED = -200.0       # kPa: where cell-levers.png draws a probe whose cone shift is neither measured nor planed
GROWTH = 1.5              # the size check grows the cell's edge by half


def size_check(soil: str, cfg: dict, seeds: list[int], workers: int, bench_dir: Path = BENCH_DIR,
               folder: Path = CELL_DIR) -> pd.DataFrame:
    """The soil's posterior mean (<bench_dir>/<soil>-posterior.json) sheared in every cell of [bench] cell_edges_mm
    on the packings `seeds`, `workers` scenes at a time, each kept in <folder>/<soil>/set-<its overrides' hash>/ (a
    cell `cell_packings` already reads, finished there or among the filter's checks, is not run again); then the
    tables (`run`). Returns the soil's rows of cell.csv."""
    test = posterior_overrides(soil, bench_dir)
    out = Path(folder) / soil / f"set-{digest(test, 8)}"
    out.mkdir(parents=True, exist_ok=True)
    stresses = ",".join(f"{float(s):g}" for s in cfg["stresses_kpa"])
    soil_cfg, res = load_soil(soil), load_resolution(cfg["resolution"])

    def one(job):
        edge, seed = job
        key = cell_key(soil_cfg, res, edge / 1000, seed)
        cmd = [sys.executable, str(ROOT / "scripts/simple_shear.py"), "--soil", soil, "--resolution", cfg["resolution"],
               "--size", f"{edge:g}", "--seed", str(seed), "--stress", stresses, "--out", str(out),
               *[a for k, v in test.items() for a in ("--test-set", f"{k}={v}")]]
        code, _ = run_logged(cmd, out / f"{key}.log")
        if code != 0:
            raise RuntimeError(f"scripts/simple_shear.py exited {code} ({out / f'{key}.log'})")

    held = cell_packings(soil, folder, bench_dir)     # run here before, or by the filter's checks: not run again
    held = set() if held.empty else {(e, s) for e, s, i in zip(held["edge_mm"], held["seed"], held["inertial"])
                                     if i == CELL_INERTIAL}
    jobs = [(float(e), s) for e in cfg["cell_edges_mm"] for s in seeds if (round(float(e)), s) not in held]
    in_parallel(one, jobs, workers, f"cell {soil}", "cells")
    run(folder, bench_dir)
    table = pd.read_csv(Path(bench_dir) / "cell.csv")
    return table[table["soil"] == soil]


def cell_fit(result: dict) -> dict:
    """c and φ of one packing's cell tests: the peak τ against σzz at the peak.

    >>> tests = [{"stress_kpa": s, "sigma_at_peak_kpa": s, "tau_peak_kpa": 5 + 0.5 * s, "size_m": [0.12] * 3}
    ...          for s in (50, 100, 200)]
    >>> r = cell_fit({"bed": "clay-medium-cell120-s3-0a", "inertial": 1e-3, "tests": tests})
    >>> r["edge_mm"], r["seed"], r["inertial"], round(r["c_kpa"], 2), round(r["phi_deg"], 2)
    (120, 3, 0.001, 5.0, 26.57)
    """
    tests = result["tests"]
    fit = fit_tests(tests)
    seed = int(re.search(r"-s(\d+)-", result["bed"]).group(1))
    return {"edge_mm": round(1000 * tests[0]["size_m"][0]), "seed": seed, "inertial": float(result["inertial"]),
            "c_kpa": fit["c_kpa"], "phi_deg": fit["phi_deg"], **{float(t["stress_kpa"]): float(t["tau_peak_kpa"]) for t in tests}}


def cell_packings(soil: str, folder: Path = CELL_DIR, bench_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """Every finished cell run of the soil's posterior mean (<bench_dir>/<soil>-posterior.json; its test overrides
    those of `posterior_overrides`), one row per cell edge, shear rate and packing: `cell_fit` with the peaks per
    normal stress (kPa columns). Read in <folder>/<soil>/ (the size check's and the probes' cells) and in the
    evaluations of a filter that shears in the cell (<bench_dir>/<soil>/<id>/: its checks at the posterior); a cell
    both hold is read once."""
    if not (Path(bench_dir) / f"{soil}-posterior.json").exists():
        return pd.DataFrame()
    want = posterior_overrides(soil, bench_dir)
    rows = {}
    for path in (Path(folder) / soil, Path(bench_dir) / soil):
        for f in sorted(path.rglob("*.json")) if path.is_dir() else []:
            if f.name.endswith(".part.json") or f.name == "responses.json":
                continue
            result = json.loads(f.read_text())
            if result.get("overrides") == want and "inertial" in result:
                row = cell_fit(result)
                rows.setdefault((row["edge_mm"], row["inertial"], row["seed"]), row)
    return pd.DataFrame(list(rows.values())).sort_values(["edge_mm", "inertial", "seed"]) if rows else pd.DataFrame()


def rated_packings(soil: str, folder: Path = CELL_DIR, bench_dir: Path = BENCH_DIR) -> pd.DataFrame:
    """`cell_packings` at the cell's shear rate (CELL_INERTIAL): the readings its checks judge."""
    cells = cell_packings(soil, folder, bench_dir)
    return cells[cells["inertial"] == CELL_INERTIAL] if len(cells) else cells


def rate_table(cells: pd.DataFrame) -> pd.DataFrame:
    """The cell's rate check: per edge, each other inertial number's c and φ against CELL_INERTIAL's (`size_shift`'s
    rule: the slower cell moves the mean less than the packings' SD).

    >>> cells = pd.DataFrame({"edge_mm": [120] * 6, "inertial": [1e-3] * 3 + [5e-4] * 3,
    ...                       "c_kpa": [5, 6, 7, 4.5, 5.5, 6.5], "phi_deg": [25, 26, 27, 25, 26, 27]})
    >>> rate_table(cells)[["inertial", "response", "shift", "passes"]].to_dict(orient="list")
    {'inertial': [0.0005, 0.0005], 'response': ['c_kpa', 'phi_deg'], 'shift': [-0.5, 0.0], 'passes': [True, True]}
    """
    tables = []
    for (edge, inertial), t in cells.groupby(["edge_mm", "inertial"]):
        base = cells[(cells["edge_mm"] == edge) & (cells["inertial"] == CELL_INERTIAL)]
        if inertial != CELL_INERTIAL and len(base):
            tables.append(size_shift(base, t, SHEAR_RESPONSES).assign(edge_mm=edge, inertial=inertial))
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()


def posterior_overrides(soil: str, bench_dir: Path = BENCH_DIR) -> dict:
    """The scene's --test-set of the soil's posterior mean with the parameters its calibration held fixed (both from
    <bench_dir>/<soil>-posterior.json), as the scene records them (the bench calibration's `overrides`, as
    numbers)."""
    mean = rounded(posterior_mean(soil, bench_dir))       # a missing posterior: its ConfigError, naming the command
    fixed = json.loads((Path(bench_dir) / f"{soil}-posterior.json").read_text()).get("fixed") or {}
    return dict(sorted(equal_bonds({**fixed, **mean}).items()))


def size_table(cells: pd.DataFrame) -> pd.DataFrame:
    """The cell's size check, per pair of edges one GROWTH apart (`size_shift` of c and φ).

    >>> cells = pd.DataFrame({"edge_mm": [120] * 3 + [180] * 3, "c_kpa": [5, 6, 7, 5.5, 6.5, 7.5],
    ...                       "phi_deg": [25, 26, 27, 25, 26, 27]})
    >>> size_table(cells)[["configured_mm", "response", "shift", "passes"]].to_dict(orient="list")
    {'configured_mm': [120, 120], 'response': ['c_kpa', 'phi_deg'], 'shift': [0.5, 0.0], 'passes': [True, True]}
    """
    edges = sorted(cells["edge_mm"].unique()) if len(cells) else []
    tables = []
    for small in edges:
        big = [e for e in edges if abs(e / small - GROWTH) < 0.02]
        if big:
            shift = size_shift(cells[cells["edge_mm"] == small], cells[cells["edge_mm"] == big[0]], SHEAR_RESPONSES)
            tables.append(shift.assign(configured_mm=small, grown_mm=big[0]))
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()


def sized_edge(sizes: pd.DataFrame, response: str) -> int | None:
    """The smallest cell edge whose growth by half passes for `response`; None where none does."""
    passed = sizes[(sizes["response"] == response) & sizes["passes"]] if len(sizes) else sizes
    return int(passed["configured_mm"].min()) if len(passed) else None


def verdicts(soil: str, cells: pd.DataFrame, sizes: pd.DataFrame) -> list[dict]:
    """Per cell edge and response: the packings' mean, SD and mean's interval against the target, and whether the
    edge is the one the size check points to (`sized`)."""
    ranges = target_ranges(soil, load_config(soil=soil))
    rows = []
    for edge, t in cells.groupby("edge_mm"):
        for r in SHEAR_RESPONSES:
            v = t[r].dropna().to_numpy(float)
            verdict = mean_verdict(v, *ranges[r])
            rows.append({"soil": soil, "edge_mm": int(edge), "response": r, "packings": len(v),
                         "mean": float(v.mean()), "sd": float(v.std(ddof=1)) if len(v) > 1 else np.nan,
                         "mean_lo": verdict["mean_interval"][0], "mean_hi": verdict["mean_interval"][1],
                         "target_lo": ranges[r][0], "target_hi": ranges[r][1], "verdict": verdict["mean_verdict"],
                         "sized": sized_edge(sizes, r) == int(edge)})
    return rows


def posterior_line(soil: str, bench_dir: Path = BENCH_DIR) -> str | None:
    """The soil's cell reading (<bench_dir>/cell.csv) as its `[bench_posterior]` line `cell_packings`: per response
    the verdict, mean and interval in the cell its size check points to, or in the largest cell, marked unsized,
    where the check passes in none; None where the soil has no cell runs.

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> rows = [("c_kpa", 120, 6.91, 5.12, 8.7, "outside", True), ("phi_deg", 120, 25.6, 25.1, 26.1, "inside", False),
    ...         ("phi_deg", 180, 25.5, 25.0, 26.0, "inside", False)]
    >>> pd.DataFrame([dict(soil="clay", response=r, edge_mm=e, packings=3, mean=m, mean_lo=lo, mean_hi=hi,
    ...               verdict=v, sized=z) for r, e, m, lo, hi, v, z in rows]).to_csv(d / "cell.csv", index=False)
    >>> for part in posterior_line("clay", d).split(", phi"):
    ...     print(part)
    cell_packings = { c_kpa = "outside: 6.91 [5.12, 8.7] (120 mm cell, 3 packings)"
    _deg = "unsized, inside: 25.5 [25, 26] (180 mm cell, 3 packings)" }
    """
    path = Path(bench_dir) / "cell.csv"
    table = pd.read_csv(path) if path.exists() else pd.DataFrame(columns=["soil"])
    table = table[table["soil"] == soil]
    if table.empty:
        return None
    items = []
    for r, t in table.groupby("response", sort=False):
        sized = t[t["sized"].astype(bool)]
        row = (sized if len(sized) else t[t["edge_mm"] == t["edge_mm"].max()]).iloc[0]
        items.append(f'{r} = "{"" if len(sized) else "unsized, "}{row["verdict"]}: {row["mean"]:.3g} '
                     f'[{row["mean_lo"]:.3g}, {row["mean_hi"]:.3g}] ({int(row["edge_mm"])} mm cell, '
                     f'{int(row["packings"])} packings)"')
    return "cell_packings = { " + ", ".join(items) + " }"


def box_beside(soil: str, cells: pd.DataFrame, bench_dir: Path = BENCH_DIR) -> list[dict]:
    """Per normal stress: each cell edge's and each shear box's mean peak τ over its packings, and its peak over the
    cell's (the largest cell), in %. The box reads its peak on the sheared area's normal stress, about 1.2 σn at its
    peak's shift; the cell at σn: `tau_over_sigma` is each peak over the normal stress it was read at."""
    cfg = load_config(soil=soil)
    boxes = [cfg["size_mm"], cfg["check_box_mm"], cfg["check_size_check_mm"]]
    stresses = [c for c in cells.columns if isinstance(c, float)]
    largest = cells[cells["edge_mm"] == cells["edge_mm"].max()]
    rows = []
    for edge, t in cells.groupby("edge_mm"):
        for s in stresses:
            rows.append({"soil": soil, "test": f"cell {int(edge)} mm", "stress_kpa": s, "packings": int(t[s].notna().sum()),
                         "tau_peak_kpa": float(t[s].mean()), "tau_over_sigma": float(t[s].mean() / s)})
    for box in boxes:
        peaks, sigmas = box_peaks(soil, box, bench_dir)
        for s in stresses:
            if s in peaks:
                rows.append({"soil": soil, "test": f"box {mm(box)} mm", "stress_kpa": s, "packings": len(peaks[s]),
                             "tau_peak_kpa": float(np.mean(peaks[s])),
                             "tau_over_sigma": float(np.mean(peaks[s]) / np.mean(sigmas[s]))})
    for row in rows:
        row["over_cell_pct"] = 100 * (row["tau_peak_kpa"] / float(largest[row["stress_kpa"]].mean()) - 1)
    return rows


def box_peaks(soil: str, box_mm, bench_dir: Path = BENCH_DIR) -> tuple[dict, dict]:
    """The soil's posterior mean's shear box peaks (kPa) in box `box_mm` per normal stress, and the normal stress
    on the sheared area each was read at (analysis/soil/shear.py), over every packing the box ran."""
    from analysis.soil.shear import sheared_stress
    peaks, sigmas = {}, {}
    for i in posterior_packings(soil, box_mm, bench_dir, bench_dir).get("id", []):
        data = scene_result(Path(bench_dir) / soil / str(i), "shear")
        for t in (data or {}).get("tests", []):
            peaks.setdefault(float(t["stress_kpa"]), []).append(float(t["tau_peak_kpa"]))
            sigmas.setdefault(float(t["stress_kpa"]), []).append(sheared_stress(t))
    return peaks, sigmas


def levers(soil: str, cells: pd.DataFrame, folder: Path = CELL_DIR, bench_dir: Path = BENCH_DIR) -> list[dict]:
    """Each probe of the soil (<folder>/<soil>/probes/<name>/: its posterior mean with some parameters changed, in a
    cell of the posterior's) against the posterior on the same packing and cell: the shift in c and φ, and the
    cone's shift, measured where the set's cone ran on the filter's cone bed (`cone_path`, packing 1) and from the
    soil's cone plane (surfaces.csv) over the plane's terms. `cone_per_c` is the cone's shift per kPa of the cell's c
    (measured, else the plane's), and `cone_at_c_floor` the posterior's cone (its check, <soil>-check.json) plus
    that cost of lifting the cell's mean c to its target's floor, where the probe lifts it: a lever whose cone there
    stays under Table 2's ceiling could lift c alone. A probe is this posterior's where it sets every parameter the
    posterior's overrides set (a probe of another posterior, which calibrated or held fewer, is not)."""
    path = Path(folder) / soil / "probes"
    post_file = Path(bench_dir) / f"{soil}-posterior.json"
    if not path.is_dir() or not post_file.exists() or cells.empty:
        return []
    want, post = posterior_overrides(soil, bench_dir), rounded(posterior_mean(soil, bench_dir))
    results = [(f, json.loads(f.read_text())) for f in sorted(path.glob("*/*.json")) if not f.name.endswith(".part.json")]
    results = [(f, r) for f, r in results if set(want) <= set(r["overrides"])]
    if not results:
        return []
    cfg = load_config(soil=soil)
    base = {(int(r["edge_mm"]), int(r["seed"])): r for _, r in cells.iterrows()}
    surfaces = Path(bench_dir) / "surfaces.csv"
    planes = pd.read_csv(surfaces, comment="#") if surfaces.exists() else pd.DataFrame(columns=["soil", "response"])
    check = Path(bench_dir) / f"{soil}-check.json"
    cone_post = float(json.loads(check.read_text()).get("cone_kpa", {}).get("mean", np.nan)) if check.exists() else np.nan
    lo, hi = cone_range(soil, cfg) if "cone_check" in cfg else (np.nan, np.nan)
    fixed = cfg.get("fixed", {})
    c_floor = target_ranges(soil, cfg)["c_kpa"][0]
    c_mean = float(cells[cells["edge_mm"] == cells["edge_mm"].min()]["c_kpa"].mean())
    rows = []
    for f, result in results:
        changed = {k: v for k, v in result["overrides"].items() if want.get(k) != v and k != "shear_cohesion"}
        fit = cell_fit(result)
        ref = base.get((fit["edge_mm"], fit["seed"]))
        if ref is None or fit["inertial"] != CELL_INERTIAL or not changed:
            continue
        probe_cfg = {**cfg, "fixed": {**fixed, **{k: v for k, v in changed.items() if k in fixed}}}
        params = {**post, **{k: v for k, v in changed.items() if k not in fixed}}
        step = surface_terms(pd.DataFrame([post, params]), fixed).diff().iloc[1]    # the planes' terms, moved
        shift = {}
        for response in ("cone_kpa", "collapse_deg"):       # the planes cover the posterior's own parameters only
            plane = planes[(planes["soil"] == soil) & (planes["response"] == response)]
            shift[response] = float(sum(plane.iloc[0][t] * step[t] for t in step.index)) \
                if len(plane) and set(changed) <= set(post) else np.nan
        cones = [json.loads(where.read_text())["cone_index_pa"] / 1e3 if where.exists() else np.nan
                 for where in (cone_path(soil, post, cfg, bench_dir)[0], cone_path(soil, params, probe_cfg, bench_dir)[0])]
        dc = fit["c_kpa"] - ref["c_kpa"]
        measured = cones[1] - cones[0]
        per_c = (measured if np.isfinite(measured) else shift["cone_kpa"]) / dc if dc > 0 else np.nan
        rows.append({"soil": soil, "probe": f.parent.name, "changed": " ".join(f"{k}={v:g}" for k, v in changed.items()),
                     "edge_mm": fit["edge_mm"], "seed": fit["seed"], "c_kpa": fit["c_kpa"], "c_shift": dc,
                     "phi_deg": fit["phi_deg"], "phi_shift": fit["phi_deg"] - ref["phi_deg"],
                     "cone_shift_measured": measured, "cone_shift_plane": shift["cone_kpa"], "cone_per_c": per_c,
                     "collapse_shift_plane": shift["collapse_deg"],
                     "cone_at_c_floor": cone_post + per_c * max(0.0, c_floor - c_mean), "cone_hi": hi, "cone_lo": lo,
                     "cell_c_mean": c_mean, "c_floor": c_floor, "cone_posterior": cone_post})
    return rows


def run(folder: Path = CELL_DIR, bench_dir: Path = BENCH_DIR) -> list[Path]:
    """cell.csv, cell-size.csv, cell-rate.csv, cell-box.csv and cell.png in `bench_dir` from every soil's kept cell
    runs (at CELL_INERTIAL; the rate check's beside them); none where no soil has one."""
    verdict_rows, size_tables, rate_tables, beside, lever_rows = [], [], [], [], []
    read = {}
    for soil in SOILS:
        every = cell_packings(soil, folder, bench_dir)
        if every.empty:
            continue
        rates = rate_table(every)
        if len(rates):
            rate_tables.append(rates.assign(soil=soil))
        cells = every[every["inertial"] == CELL_INERTIAL]
        read[soil] = cells
        sizes = size_table(cells)
        if len(sizes):
            size_tables.append(sizes.assign(soil=soil))
        verdict_rows += verdicts(soil, cells, sizes)
        beside += box_beside(soil, cells, bench_dir)
        lever_rows += levers(soil, cells, folder, bench_dir)
    if not read:
        return []
    bench_dir = Path(bench_dir)
    paths = [bench_dir / "cell.csv", bench_dir / "cell-box.csv"]
    atomic_csv(pd.DataFrame(verdict_rows).round(4), paths[0])
    atomic_csv(pd.DataFrame(beside).round(4), paths[1])
    if size_tables:
        paths.append(bench_dir / "cell-size.csv")
        atomic_csv(pd.concat(size_tables, ignore_index=True).round(4), paths[-1])
    if rate_tables:
        paths.append(bench_dir / "cell-rate.csv")
        atomic_csv(pd.concat(rate_tables, ignore_index=True).round(4), paths[-1])
    if lever_rows:
        paths.append(bench_dir / "cell-levers.csv")
        atomic_csv(pd.DataFrame(lever_rows).round(4), paths[-1])
        paths.append(levers_plot(pd.DataFrame(lever_rows), bench_dir / "cell-levers.png"))
    paths.append(plot(read, pd.DataFrame(beside), bench_dir / "cell.png"))
    return paths


def levers_plot(levers_table: pd.DataFrame, path: Path) -> Path:
    """Per soil: each probe's shift in the cell's c against the cone's shift (measured, else its plane's; a probe with
    neither on a strip below), and the corner where the cells' mean c reaches the target's floor with the cone under
    Table 2's ceiling."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    soils = list(dict.fromkeys(levers_table["soil"]))
    fig, axes = plt.subplots(1, len(soils), figsize=(5.5 * len(soils), 4.4), squeeze=False)
    for ax, soil in zip(axes[0], soils):
        t = levers_table[levers_table["soil"] == soil]
        first = t.iloc[0]
        need, room = first["c_floor"] - first["cell_c_mean"], first["cone_hi"] - first["cone_posterior"]
        cone = t["cone_shift_measured"].where(t["cone_shift_measured"].notna(), t["cone_shift_plane"])
        ax.add_patch(plt.Rectangle((need, UNMEASURED + 50), 1e3, room - UNMEASURED - 50, color="tab:green", alpha=0.12,
                                   label="c at its floor, cone under Table 2 + 15 %"))
        for (_, row), y in zip(t.iterrows(), cone):
            mark = "o" if np.isfinite(row["cone_shift_measured"]) else "s" if np.isfinite(y) else "x"
            y = y if np.isfinite(y) else UNMEASURED
            ax.plot(row["c_shift"], y, mark, color="k" if mark == "o" else "0.5")
            ax.annotate(row["changed"].replace("normal_cohesion", "bond").replace("new_contact_cohesion", "share"),
                        (row["c_shift"], y), fontsize=6, xytext=(3, 3), textcoords="offset points")
        ax.axhline(0, color="0.7", lw=0.5), ax.axvline(0, color="0.7", lw=0.5)
        ax.axhspan(UNMEASURED - 50, UNMEASURED + 50, color="0.9")
        ax.text(0.99, UNMEASURED - 40, "cone not measured", fontsize=7, ha="right", transform=ax.get_yaxis_transform())
        top = max(float(np.nanmax(cone.to_numpy(float))), room) if cone.notna().any() else room
        ax.set(xlim=(min(-5.0, t["c_shift"].min() - 1), max(need, t["c_shift"].max()) + 2), ylim=(UNMEASURED - 50, top + 100),
               xlabel="shift in the cell's c, kPa (packing 1)",
               ylabel="shift in the cone, kPa (o measured, s its plane, x none)")
        ax.set_title(f"{soil}: one parameter off the posterior (cell c {first['cell_c_mean']:.1f} kPa, "
                     f"cone {first['cone_posterior']:.0f} kPa)", fontsize=8)
        ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot(read: dict, beside: pd.DataFrame, path: Path) -> Path:
    """Per soil: the cells' peaks against the normal stress (each packing, each edge), the boxes' mean peaks against
    the stress they were read at, and the target's Mohr–Coulomb envelopes (c and φ at their ranges' ends)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(read), figsize=(4.2 * len(read), 3.8), squeeze=False)
    for ax, (soil, cells) in zip(axes[0], read.items()):
        ranges = target_ranges(soil, load_config(soil=soil))
        s = np.linspace(0, 260, 50)
        lo = ranges["c_kpa"][0] + s * np.tan(np.radians(ranges["phi_deg"][0]))
        hi = ranges["c_kpa"][1] + s * np.tan(np.radians(ranges["phi_deg"][1]))
        ax.fill_between(s, lo, hi, color=SOIL_COLOURS.get(soil, "grey"), alpha=0.15, label="target's envelopes")
        stresses = [c for c in cells.columns if isinstance(c, float)]
        for k, (edge, t) in enumerate(cells.groupby("edge_mm")):
            for _, row in t.iterrows():
                ax.plot(stresses, [row[x] for x in stresses], "o" if k == 0 else "s", ms=3.5, alpha=0.7,
                        color=f"C{k}", label=f"cell {int(edge)} mm" if _ == t.index[0] else None)
        boxes = beside[(beside["soil"] == soil) & beside["test"].str.startswith("box")]
        for k, (name, t) in enumerate(boxes.groupby("test", sort=False)):
            ax.plot(t["tau_peak_kpa"] / t["tau_over_sigma"], t["tau_peak_kpa"], "^--",         # at the box's σ
                    color=f"C{k + 3}", ms=5, label=name)
        ax.set(title=soil, xlabel="normal stress at the peak, kPa", ylabel="peak shear stress, kPa", xlim=(0, 260))
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path

