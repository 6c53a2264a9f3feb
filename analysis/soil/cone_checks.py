"""Checks of the calibrated beds, `./holes cone-checks [configs/cone_checks.toml]`: the cone index on
replicate beds (other packing seeds), on a bed 1.5 × as wide, and against the cone-to-particle diameter ratio
(grain size or cone size changed), each at the soil config's calibrated cohesion, beside seed 001 Table 2.
Also the dry density of a 100 cm³ cutting-ring core in each bed (calibration_report.core_density), a density
check independent of the interior porosity the grain density is set from.

A case may tile its bed (`tiles` = n, periodic beds: scripts/beds.py's `tile`): the bed of `size` repeated n × n
times, so beds of one seed and different n hold one packing in cells of different widths. The "tiled" check
compares them seed by seed: the width check with the packing's scatter taken out.

A case may pin its bond strength (`cohesion`, Pa, normal = shear), as a study at one cohesion does; by default
it is the soil config's calibrated value.

Every case is one cone scene (scripts/cone.py, its own YADE process); cases sharing a bed run one after another,
others `workers` at a time. A case already in results/cache/cone/ (same bed, cone, speed, and a cohesion within 0.1 %:
the config keeps 4 significant digits of the calibrated value) is reused. results/calibration/<config's stem>.csv is
rewritten as each case finishes, and <stem>.png drawn at the end.
"""
from __future__ import annotations

import json
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import say
from analysis.soil.calibrate import cone_index, cone_run, same_cohesion, stored_cone
from analysis.soil.calibration_report import CAL, core_density
from analysis.core.config import SEED, check_lateral, load_resolution
from analysis.core.schema import check_table, read_toml, ConfigError, Field
from analysis.core.soil_config import load_soil
from analysis.core.io import atomic_csv, read_table, stamp
from analysis.core.bed_spec import TILES, bed_key, check_size, check_tiles
from analysis.core.config import CONE_FIELDS
from analysis.core.bed_spec import BED_DIR

CHECKS = ("replicate", "width", "ratio", "tiled")
CASE_FIELDS = {"check": Field(kind=str), "soil": Field(kind=str), "resolution": Field(kind=str),
               "seed": SEED, "lateral": Field(kind=str), "tiles": TILES, **CONE_FIELDS}
COHESION = Field(0.0, 1e7, unit="Pa", meaning="bond strength, normal = shear")


def load_cases(path) -> list[dict]:
    """The config's cases, each [base] updated by its own fields, all checked before anything runs."""
    data = read_toml(path)
    unknown = sorted(set(data) - {"base", "case"})
    if unknown:
        raise ConfigError(f"{path}: unknown section(s) {', '.join(unknown)}; allowed base, case")
    cases = []
    for i, fields in enumerate(data.get("case", [])):
        where = f"{path}: case {i + 1}"
        merged = {**data.get("base", {}), **fields}
        size, cohesion = merged.pop("size", None), merged.pop("cohesion", None)
        c = check_table(where, merged, CASE_FIELDS, optional={"lateral": "walls", "tiles": 1})
        check_tiles(c["tiles"], check_lateral(c["lateral"]), f"{where}.tiles")
        if c["check"] not in CHECKS:
            raise ConfigError(f"{where}.check = {c['check']!r}: allowed {', '.join(CHECKS)}")
        if not isinstance(size, list) or len(size) != 3 or not all(isinstance(v, (int, float)) for v in size):
            raise ConfigError(f"{where}.size = {size!r}: give [length, width, depth] in mm")
        c["soil_cfg"], c["res"] = load_soil(c["soil"]), load_resolution(c["resolution"])
        c["cohesion"] = (c["soil_cfg"].normal_cohesion if cohesion is None
                         else COHESION.check(f"{where}.cohesion", cohesion))
        c["size"], c["size_m"] = size, check_size([v / 1000 for v in size])
        c["bed"] = bed_key(c["soil_cfg"], c["res"], c["size_m"], c["seed"], c["lateral"], c["tiles"])
        c["source"] = bed_key(c["soil_cfg"], c["res"], c["size_m"], c["seed"], c["lateral"])   # the bed it tiles
        cases.append(c)
    if not cases:
        raise ConfigError(f"{path}: no [[case]] tables")
    return cases


def stored(case: dict) -> dict | None:
    """A finished cone run of this case in results/cache/cone/, or None."""
    found = stored_cone(case["bed"], case["cone_scale"], case["speed"], case["cohesion"])
    return found[1] if found else None


def row(case: dict, s: dict, earlier: dict | None = None) -> dict:
    """One tidy row: the case, its cone index and bed densities against Table 2, and its cost. A bed not on this
    machine keeps the densities and settling time of its row in `earlier` (bed -> the table's last row of it)."""
    soil = case["soil_cfg"]
    bed = BED_DIR / f"{case['bed']}.json"
    interior = core = settle_s = float("nan")
    if bed.exists():
        meta = json.loads(bed.read_text())
        interior, settle_s = meta["dry_bulk_density"], meta["wall_s"]
        core = core_density(case["bed"], meta["grain_density"], soil.moisture)
    elif case["bed"] in (earlier or {}):      # a committed cone run whose bed was settled on another machine
        e = earlier[case["bed"]]
        interior, core, settle_s = e["dry_density_interior"], e["dry_density_core"], e["bed_settle_s"]
    else:
        say(f"cone-checks: bed {case['bed']} not in results/cache/beds/ nor in the earlier table; its densities are left out")
    n = case["tiles"]
    cell = [n * case["size"][0], n * case["size"][1], case["size"][2]]
    return {"check": case["check"], "soil": soil.name, "resolution": case["resolution"],
            "radius_mm": 1000 * case["res"].radius, "size_mm": "x".join(f"{v:g}" for v in cell),
            "lateral": case["lateral"], "tiles": n,
            "seed": case["seed"], "cone_diameter_mm": round(1000 * s["cone_diameter_m"], 2),
            "cone_to_particle": round(s["cone_to_particle"], 2), "cohesion_kpa": round(s["cohesion_pa"] / 1000, 2),
            "cone_index_kpa": round(s["cone_index_pa"] / 1000, 1), "target_kpa": soil.cone_index / 1000,
            "ci_error_percent": round(100 * (s["cone_index_pa"] / soil.cone_index - 1), 1),
            "dry_density_interior": round(interior, 0), "dry_density_core": round(core, 0),
            "target_density": soil.bulk_density,
            "core_error_percent": round(100 * (core / soil.bulk_density - 1), 1),
            "particles": s["particles"], "steps": s["steps"], "cone_s": round(s["wall_s"]),
            "bed_settle_s": round(settle_s, 0), "threads": s["threads"], "bed": case["bed"]}


def width_beds(table: pd.DataFrame, checks=("replicate", "width")) -> pd.DataFrame:
    """The rows of `checks` (by default the replicate and width beds), with each bed's width in mm (size_mm is
    length x width x depth)."""
    beds = table[table.check.isin(checks)]
    return beds.assign(width=[float(s.split("x")[1]) for s in beds.size_mm])


SERIES = ["soil", "seed", "resolution", "lateral", "cone_diameter_mm"]      # one width series: beds differing only in size


def summarise(table: pd.DataFrame) -> list[str]:
    """The checks' verdicts in words: the scatter over seeds per bed, each width step, the ratio trend."""
    lines = []
    beds = width_beds(table)
    for (soil, res, lateral, size), g in beds.groupby(["soil", "resolution", "lateral", "size_mm"], sort=False):
        sd = g.cone_index_kpa.std(ddof=1) if len(g) > 1 else float("nan")
        lines.append(f"{soil} ({res}, {lateral} bed {size} mm): cone index {g.cone_index_kpa.mean():.0f} ± {sd:.0f} kPa over "
                     f"{len(g)} seed(s) (Table 2 {g.target_kpa.iloc[0]:.0f}); core density "
                     f"{g.dry_density_core.mean():.0f} kg/m³ ({g.core_error_percent.mean():+.1f} %)")
    for key, g in beds.groupby(SERIES, sort=False):
        if (g.check == "width").any():            # each bed against the next narrower one: the width series
            g = g.sort_values("width")
            for (_, a), (_, b) in zip(g.iloc[:-1].iterrows(), g.iloc[1:].iterrows()):
                change = 100 * (b.cone_index_kpa / a.cone_index_kpa - 1)
                lines.append(f"{key[0]} ({b.resolution}, seed {key[1]}): {b.lateral} bed {b.size_mm} mm gives "
                             f"{b.cone_index_kpa:.0f} kPa, {change:+.1f} % against {a.size_mm} mm (criterion < 5 %)")
    lines += tiled_verdict(table)
    ratio = table[table.check == "ratio"]
    if len(ratio):
        lines.append("ratio: " + ", ".join(f"{r.cone_to_particle:.2f} -> {r.cone_index_kpa:.0f} kPa" for r in
                                           ratio.sort_values("cone_to_particle").itertuples()))
    return lines


def tiled_changes(table: pd.DataFrame) -> pd.DataFrame:
    """The tiled check seed by seed: per soil and cone, each cell width's cone index against the next narrower
    cell's of the same packing, in % (one row per seed and width step)."""
    t, out = width_beds(table, ["tiled"]), []
    for (soil, cone, seed), g in t.groupby(["soil", "cone_diameter_mm", "seed"], sort=False):
        g = g.sort_values("width")
        for (_, a), (_, b) in zip(g.iloc[:-1].iterrows(), g.iloc[1:].iterrows()):
            out.append({"soil": soil, "cone_diameter_mm": cone, "seed": seed, "narrow": a.width, "wide": b.width,
                        "change_percent": 100 * (b.cone_index_kpa / a.cone_index_kpa - 1)})
    return pd.DataFrame(out)


def tiled_verdict(table: pd.DataFrame) -> list[str]:
    """The paired width steps in words: mean change over seeds ± its standard error, the 95 % interval
    (Student's t) and whether that interval lies within the < 5 % criterion."""
    from scipy import stats
    changes, lines = tiled_changes(table), []
    if not len(changes):
        return lines
    for (soil, narrow, wide), g in changes.groupby(["soil", "narrow", "wide"], sort=False):
        c, n = g.change_percent, len(g)
        if n < 2:
            lines.append(f"{soil} tiled, {narrow:g} -> {wide:g} mm: {c.iloc[0]:+.1f} % (one seed)")
            continue
        se = c.std(ddof=1) / n ** 0.5
        half = stats.t.ppf(0.975, n - 1) * se
        lo, hi = c.mean() - half, c.mean() + half
        verdict = ("is met" if -5 < lo and hi < 5 else "fails" if lo >= 5 or hi <= -5 else "is not resolved")
        lines.append(f"{soil} tiled, {narrow:g} -> {wide:g} mm, same packing, {n} seeds: {c.mean():+.1f} ± {se:.1f} % "
                     f"(mean ± SE; seed SD {c.std(ddof=1):.1f} %), 95 % interval {lo:+.1f} to {hi:+.1f} %: "
                     f"the < 5 % criterion {verdict}")
    return lines


def curve(r) -> pd.DataFrame | None:
    """The resistance-depth curve of a table row's cone run (results/cache/cone/<bed>-...csv), or None."""
    found = cone_run(r.bed, lambda s: abs(1000 * s["cone_diameter_m"] - r.cone_diameter_mm) < 0.01
                     and same_cohesion(s, 1000 * r.cohesion_kpa))
    return pd.read_csv(found[0].with_suffix(".csv"), comment="#") if found else None


def legend(ax):
    """A legend if the axes has labelled lines (a panel with no width series has none)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)


def plot(table: pd.DataFrame, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ((a, b), (c, d)) = plt.subplots(2, 2, figsize=(13, 9))
    clay = table[table.soil == "clay"]
    ref = clay[(clay.check == "replicate") & (clay.seed == 1) & (clay.resolution == "quick")]
    if len(ref) and (clay.check == "ratio").any():   # the two sweeps through the calibration case: grain, cone size
        ref = ref.iloc[0]
        pts = pd.concat([clay[clay.check == "ratio"], ref.to_frame().T])
        for label, same, marker in (("grain size varied (38.5 mm cone)", "cone_diameter_mm", "o"),
                                    ("cone size varied (r = 5 mm)", "radius_mm", "s")):
            p = pts[pts[same] == ref[same]].sort_values("cone_to_particle")
            a.plot(p.cone_to_particle, p.cone_index_kpa, marker=marker, label=label)
        t = clay.target_kpa.iloc[0]
        a.axhspan(0.95 * t, 1.05 * t, color="0.85", label="Table 2 ± 5 %")
        a.set_xlabel("cone-to-particle diameter ratio")
        a.set_ylabel("clay cone index over 0-150 mm, kPa")
        a.legend(fontsize=8)
    else:
        a.set_visible(False)
    for i, (soil, g) in enumerate(table.groupby("soil", sort=False)):
        t = g.target_kpa.iloc[0]
        b.add_patch(plt.Rectangle((i - 0.4, 0.95 * t), 0.8, 0.1 * t, color="0.85"))
        rep, wide = g[g.check == "replicate"], g[g.check == "width"]
        b.plot(np.full(len(rep), i - 0.1), rep.cone_index_kpa, "o", color="tab:blue",
               label="replicate beds (seeds)" if i == 0 else None)
        b.plot(np.full(len(wide), i + 0.1), wide.cone_index_kpa, "D", color="tab:red",
               label="wider beds" if i == 0 else None)
    b.set_xticks(range(table.soil.nunique()), list(dict.fromkeys(table.soil)))
    b.set_ylabel("cone index over 0-150 mm, kPa (grey: Table 2 ± 5 %)")
    legend(b)
    beds = width_beds(table)
    for _, g in beds.groupby(SERIES, sort=False):
        if (g.check == "width").any():          # the width series' curves: dashed for the wider beds
            for r in g.itertuples():
                if (t := curve(r)) is not None:
                    t = t[t.base_depth_m >= 0]
                    c.plot(1000 * t.base_depth_m, t.resistance_pa.rolling(25, center=True).mean() / 1000,
                           "-" if r.check == "replicate" else "--",
                           label=f"{r.soil}, r = {r.radius_mm:g} mm, {r.lateral} bed {r.size_mm} mm: "
                                 f"{r.cone_index_kpa:.0f} kPa")
    for (soil, res, lateral), g in beds.groupby(["soil", "resolution", "lateral"], sort=False):   # index vs width
        line, = d.plot(g.width, g.cone_index_kpa, "o", alpha=0.5)
        mean = g.groupby("width").cone_index_kpa.mean()
        d.plot(mean.index, mean.values, "-", color=line.get_color(),
               label=f"{soil}, r = {g.radius_mm.iloc[0]:g} mm, {lateral}: seeds (points), mean (line)")
    tiled = width_beds(table, ["tiled"])
    for i, (seed, g) in enumerate(tiled.groupby("seed")):          # the tiled check: one packing per line
        g = g.sort_values("width")
        d.plot(g.width, g.cone_index_kpa, "-", color="0.6", lw=0.8, label="tiled: one packing per line" if i == 0 else None)
    if len(tiled):
        mean = tiled.groupby("width").cone_index_kpa.mean()
        d.plot(mean.index, mean.values, "k-o", lw=2, label="tiled: mean over packings")
    d.set_xlabel("bed width = length, mm (cone 38.5 mm)")
    d.set_ylabel("cone index over 0-150 mm, kPa")
    legend(d)
    c.set_xlabel("cone base depth, mm (index: mean over 0-150)")
    c.set_ylabel("resistance, kPa (running mean of 25 samples)")
    legend(c)
    fig.suptitle("Virtual cone checks of the calibrated beds")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(config="configs/cone_checks.toml", workers: int = 2, threads: int = 1, out=CAL,
        no_run: bool = False) -> pd.DataFrame:
    """Run the config's unfinished cases (unless `no_run`: then the stored ones only are tabled);
    results/calibration/<config's stem>.csv and .png."""
    cases, stem = load_cases(config), Path(config).stem
    note = stamp(f"./holes cone-checks {config} " + ("--no-run" if no_run else f"--workers {workers} --threads {threads}"))
    done = {i: s for i, c in enumerate(cases) if (s := stored(c)) is not None}
    table_path = out / f"{stem}.csv"
    earlier = (read_table(table_path).drop_duplicates("bed", keep="last").set_index("bed").to_dict("index")
               if table_path.exists() else {})
    rows = {i: row(cases[i], s, earlier) for i, s in done.items()}
    groups: dict[str, list[int]] = {}
    for i, c in enumerate(cases):
        if i not in done and not no_run:      # one worker per settled bed: a tiled bed's copies come after it
            groups.setdefault(c["source"], []).append(i)
    say(f"cone-checks: {len(cases)} cases, {len(done)} stored, " + (f"{len(cases) - len(done)} left out (--no-run)"
        if no_run else f"{len(cases) - len(done)} to run ({workers} at a time, {threads} thread(s) each)"))

    def write():
        atomic_csv(pd.DataFrame([rows[i] for i in sorted(rows)]), table_path, note)

    failures, lock = [], threading.Lock()

    def run_group(ids):
        """The cases on one bed, one after another (the first may settle the bed)."""
        for i in ids:
            c = cases[i]
            size = ",".join(f"{v:g}" for v in c["size"])
            tiled = f" x{c['tiles']}" if c["tiles"] > 1 else ""
            tag = f"[{c['check']} {c['soil']} {c['resolution']} {size}{tiled} s{c['seed']} c{c['cone_scale']:g}]"
            try:
                s = cone_index(c["soil"], c["resolution"], size, c["cone_scale"], c["cohesion"],
                               c["seed"], c["speed"], threads, c["lateral"], tag=tag, tiles=c["tiles"])
            except RuntimeError as e:               # a failing scene is reported; the others go on
                failures.append(f"{tag} {e}")
                say(failures[-1])
                continue
            with lock:
                rows[i] = row(c, s, earlier)
                write()
                say(f"cone-checks: {tag} {rows[i]['cone_index_kpa']} kPa; {len(rows)}/{len(cases)} finished, "
                    f"{len(failures)} failed")

    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        for fut in [pool.submit(run_group, ids) for ids in groups.values()]:
            fut.result()
    if not rows:
        raise RuntimeError("no case finished" + (" (--no-run: none stored in results/cache/cone/)" if no_run else ""))
    write()
    table = pd.DataFrame([rows[i] for i in sorted(rows)])
    plot(table, out / f"{stem}.png")
    for line in summarise(table):
        print(line)
    if failures:
        raise RuntimeError(f"{len(failures)} cone case(s) failed; the table holds the others")
    return table
