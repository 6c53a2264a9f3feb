"""The machine's unknowns calibrated on clay, the other soils then predicted (seed 001 gives neither how deep the
punches went nor the press sleeve's spring). No YADE: the runs are disk scenes (analysis/core/runner.py).

    ./holes calibrate-machine [configs/studies/machine_clay.toml] [--no-run]

The design is a study file (analysis/batch/study.py) over the penetration P (`disk.penetration`) and the sleeve's
spring rate (`sleeve.stiffness`), every case on clay. Each finished run is measured (analysis/holes/measure.py) and
kept with its grains in results/calibration/machine/runs/<id>/, so the fit can be made again anywhere; every
hole is a row of results/calibration/machine.csv with its packing seed, P, spring rate, the mean vertical soil
force on the disk W, and the hole's L2, L2_surface (= L2 + h1) and h1.

The fit reads clay's field means only (configs/field/table3.csv), never loam's or sand's:
  - P to the √2·a2 level's depth below the undisturbed surface, L2_surface, under each of §4.2's two readings
    of the field's L2: "literal" (the field's L2 from the subsided level, so the target is its L2 + h1 = 75.6 mm)
    and "surface" (the field's L2 from the undisturbed surface, target 62.1 mm);
  - the spring rate to the field's h1 (13.5 mm).
Over the run means, L2_surface = a0 + a1·P + a2·k and h1 = b0 + b1·P + b2·k (least squares; it needs two
penetrations and two spring rates at least), then the two targets solved for (P, k). The interval resamples each
design point's packings and then their holes (2,000 times) and fits again: within-run scatter only where a point has
one packing. A value outside the bracketed range is flagged as extrapolated; one inside it is "resolved" only when
both intervals are narrower than the design's range.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import say
from analysis.core.runner import finished, run_all
from analysis.core.config import MACHINE
from analysis.core.schema import ROOT, ConfigError
from analysis.core.io import atomic_csv, atomic_write, read_table, shown, stamp

DESIGN = ROOT / "configs/studies/machine_clay.toml"
P_KEY, K_KEY = "disk.penetration", "sleeve.stiffness"
# clay's rows of a comparison that the calibration fixes, under either variant: the two fitted (L2_surface or L2,
# and h1) and the one they fix (L2 = L2_surface - h1), and the pass rates, which turn on L2; not predictions
TARGET_METRICS = ("L2", "L2_surface", "h1", "pass_stated", "pass_field", "pass_stated_surface", "pass_field_surface")
VARIANTS = {"literal": "the field's L2 read from the subsided level: L2_surface to its L2 + h1",
            "surface": "the field's L2 read from the undisturbed surface: L2_surface to its L2"}


def targets(field: pd.DataFrame) -> dict:
    """Clay's field means, the only field numbers the fit reads: {"literal", "surface", "h1"} in mm."""
    clay = field[(field.soil == "clay") & (field.run == "mean")]
    if len(clay) != 1:
        raise ConfigError("the field table has no single clay mean row (configs/field/table3.csv)")
    row = clay.iloc[0]
    return {"literal": float(row.L2 + row.h1), "surface": float(row.L2), "h1": float(row.h1)}


def load_design(path) -> list:
    """The design's cases, checked: every case on clay and with P and the spring rate given."""
    from analysis.batch.study import load_study
    _, cases = load_study(path)
    for c in cases:
        if c.params["soil"]["name"] != "clay":
            raise ConfigError(f"{path}: soil = {c.params['soil']['name']!r}: allowed 'clay' only (the machine is "
                              "calibrated on clay; loam and sand are predictions)")
        if P_KEY not in c.fields or K_KEY not in c.fields:
            raise ConfigError(f"{path}: every case needs {P_KEY} and {K_KEY} (base or grid)")
    soil_sets = {c.params["preset"].get("soils", "") for c in cases}
    if len(soil_sets) > 1:
        raise ConfigError(f"{path}: its presets run different soil sets ({', '.join(repr(s) for s in sorted(soil_sets))}); "
                          "allowed one: a machine is calibrated on one clay")
    return cases


def section_of(variant: str, cases: list) -> str:
    """configs/machine.toml's section a design's fit of `variant` is written to: the variant's name on the cone-fitted
    clay, "bench_<variant>" on the bench-calibrated one (its preset's soils = "bench"), so that neither clay's machine
    overwrites the other's, which other presets run.

    >>> from types import SimpleNamespace as C
    >>> section_of("surface", [C(params={"preset": {"soils": "bench"}})]), section_of("surface", [C(params={"preset": {}})])
    ('bench_surface', 'surface')
    """
    return f"bench_{variant}" if cases and cases[0].params["preset"].get("soils") == "bench" else variant


def vertical_load(folder: Path, lead_in: int, holes: int) -> float:
    """W (N): the time-mean vertical force of the soil on the disk's punches and plates over the measured holes'
    whole punch periods (from the lead-in's punch at its lowest to `holes` periods later), from the run's time
    series: per record, each punch in the soil's punch force plus its plate's force along the axis, resolved
    vertically; records with no punch in the soil add nothing."""
    ts = pd.read_csv(folder / "timeseries.csv", comment="#")
    if ts.empty:
        return math.nan
    dt = float(np.median(np.diff(np.unique(ts.t_s))))
    omega = float(ts.omega_rad_s.median())
    first = ts[ts.punch == lead_in % int(ts.punch.max() + 1)]   # the punch of the first measured hole ...
    if omega > 0:                                       # ... on its first pass: a punch forms every N-th hole
        first = first[first.t_s < first.t_s.iloc[0] + math.pi / omega]
    t0 = float(first.t_s.iloc[int(np.argmin(np.abs(first.phi_deg.to_numpy())))])
    period = 2 * math.pi / omega / int(ts.punch.max() + 1) if omega > 0 else math.nan
    window = ts[(ts.t_s >= t0) & (ts.t_s < t0 + holes * period)]
    fz = window.punch_fz_n + window.sleeve_force_n * np.cos(np.radians(window.phi_deg))
    return float(fz.sum() * dt / (holes * period))


def load_of(folder: Path, summary: dict, holes: int) -> float:
    """A finished run's W (vertical_load), from its load.json, or computed from its time series and kept there
    (a kept run has no time series: its load.json is kept beside its grains). nan when neither is there."""
    if (folder / "load.json").exists():
        return json.loads((folder / "load.json").read_text())["W_n"]
    if not (folder / "timeseries.csv").exists():
        return math.nan
    w = vertical_load(folder, summary.get("lead_in", 0), holes)
    atomic_write(folder / "load.json", json.dumps({"W_n": w}))
    return w


def run_rows(case, folder: Path) -> pd.DataFrame:
    """One row per measured hole of a finished case: its fields, W, and the hole's measures."""
    from analysis.holes import measure
    from analysis.holes.compare import with_l2_surface
    summary = json.loads((folder / "summary.json").read_text())
    holes = measure.run(folder, pictures=False) if (folder / "state.npz").exists() else read_table(folder / "holes.csv")
    holes = with_l2_surface(holes)
    w = load_of(folder, summary, len(holes))
    return pd.DataFrame({"run": summary["id"], "seed": case.params["seed"], "P": case.fields[P_KEY],
                         "stiffness": case.fields[K_KEY], "W_n": w, "hole": holes.hole, "found": holes.found,
                         "L0": holes.L0, "L1": holes.L1, "L2": holes.L2, "L2_surface": holes.L2_surface,
                         "h1": holes.h1, "residual_pct": 100 * abs(summary["energy_J"]["residual_fraction"]),
                         "wall_s": summary["wall_s"]})


def _solve(m: np.ndarray, want: dict, variant: str):
    """(P, k) where the planes through the run means (rows of MEAN_COLUMNS) meet the variant's targets, and the two
    planes' coefficients."""
    X = np.column_stack([np.ones(len(m)), m[:, 0], m[:, 1]])
    a = np.linalg.lstsq(X, m[:, 2], rcond=None)[0]
    b = np.linalg.lstsq(X, m[:, 3], rcond=None)[0]
    A = np.array([[a[1], a[2]], [b[1], b[2]]])
    if abs(np.linalg.det(A)) < 1e-12:
        return math.nan, math.nan, a, b
    P, k = np.linalg.solve(A, [want[variant] - a[0], want["h1"] - b[0]])
    return float(P), float(k), a, b


MEAN_COLUMNS = ("P", "stiffness", "L2_surface", "h1")


def resampled_means(found: pd.DataFrame, rng, n: int) -> np.ndarray:
    """n bootstrap draws of the design's run means, shape (n, runs, 4) in MEAN_COLUMNS' order: at each design point
    its runs (packings) drawn with replacement, then each drawn run's holes with replacement; so a point's
    interval carries the packings' scatter where it has two or more, and the holes' alone where it has one."""
    points = [[g[list(MEAN_COLUMNS)].to_numpy(float) for _, g in point.groupby("run")]
              for _, point in found.groupby(["P", "stiffness"])]
    draws = np.empty((n, sum(len(runs) for runs in points), len(MEAN_COLUMNS)))
    for d in range(n):
        row = 0
        for runs in points:
            for i in rng.integers(0, len(runs), len(runs)):
                holes = runs[i]
                draws[d, row] = np.nanmean(holes[rng.integers(0, len(holes), len(holes))], axis=0)
                row += 1
    return draws


def run_means(found: pd.DataFrame) -> pd.DataFrame:
    return found.groupby("run").agg(P=("P", "first"), stiffness=("stiffness", "first"),
                                    L2_surface=("L2_surface", "mean"), h1=("h1", "mean")).reset_index()


def status_of(P: float, k: float, interval_P, interval_k, means: pd.DataFrame) -> str:
    """"resolved": inside the design's range and both 95 % intervals narrower than it; else why not."""
    if k < 0:
        return "not physical: a negative spring rate"
    span_P, span_k = means.P.max() - means.P.min(), means.stiffness.max() - means.stiffness.min()
    if not (means.P.min() <= P <= means.P.max() and means.stiffness.min() <= k <= means.stiffness.max()):
        return "extrapolated beyond the bracket"
    if interval_P[1] - interval_P[0] < span_P and interval_k[1] - interval_k[0] < span_k:
        return "resolved"
    return "inside the bracket, not resolved: an interval wider than the design's range"


def fit(rows: pd.DataFrame, want: dict, n_boot: int = 2000, seed: int = 0) -> pd.DataFrame:
    """Per variant: the fitted P and spring rate with 95 % intervals (a bootstrap over each design point's packings
    and their holes, `resampled_means`), the two linear models' coefficients and residual SDs, and a status (`status_of`)."""
    found = rows[rows.found.astype(bool)]
    means = run_means(found)
    out = []
    draws = None                    # the bootstrap's resampled means, drawn once and solved for every variant
    for variant, meaning in VARIANTS.items():
        row = {"variant": variant, "meaning": meaning, "target_L2_surface": want[variant], "target_h1": want["h1"],
               "runs": len(means), "holes": len(found),
               "packings_per_point": int(found.groupby(["P", "stiffness"]).run.nunique().min()) if len(found) else 0}
        if means.P.nunique() < 2 or means.stiffness.nunique() < 2 or len(means) < 3:
            out.append({**row, "status": f"not determined: {means.P.nunique()} penetration(s) and "
                        f"{means.stiffness.nunique()} spring rate(s) in {len(means)} run(s); it needs 2, 2 and 3"})
            continue
        P, k, a, b = _solve(means[list(MEAN_COLUMNS)].to_numpy(float), want, variant)
        if draws is None:
            rng = np.random.default_rng(seed)
            draws = resampled_means(found, rng, n_boot)
        boot = np.array([_solve(d, want, variant)[:2] for d in draws])
        interval_P = (np.nanpercentile(boot[:, 0], 2.5), np.nanpercentile(boot[:, 0], 97.5))
        interval_k = (np.nanpercentile(boot[:, 1], 2.5), np.nanpercentile(boot[:, 1], 97.5))
        X = np.column_stack([np.ones(len(means)), means.P, means.stiffness])
        out.append({**row, "P": P, "P_lo": interval_P[0], "P_hi": interval_P[1],
                    "stiffness": k, "stiffness_lo": interval_k[0], "stiffness_hi": interval_k[1],
                    "dL2s_dP": a[1], "dL2s_dk": a[2], "dh1_dP": b[1], "dh1_dk": b[2],
                    "L2s_resid_sd": float(np.std(means.L2_surface - X @ a, ddof=0)),
                    "h1_resid_sd": float(np.std(means.h1 - X @ b, ddof=0)),
                    "status": status_of(P, k, interval_P, interval_k, means)})
    return pd.DataFrame(out)


def adopted_variants(text: str | None) -> tuple:
    """`--adopt`'s variants: None or "" for every one, else a comma-separated list of VARIANTS' names, checked.

    >>> adopted_variants("literal"), adopted_variants(None)
    (('literal',), ('literal', 'surface'))
    """
    names = tuple(dict.fromkeys(v.strip() for v in (text or "").split(",") if v.strip())) or tuple(VARIANTS)
    unknown = [v for v in names if v not in VARIANTS]
    if unknown:
        raise ConfigError(f"--adopt {text}: {unknown[0]!r} is not a variant; allowed {', '.join(VARIANTS)}")
    return names


def run(design=DESIGN, workers: int | None = None, threads: int | None = None, runs_dir=None, bed_dir=None, out=None,
        no_run: bool = False, scheduler: str | None = None, machine_path=None, variants: tuple = tuple(VARIANTS)) -> int:
    """Run the design's missing cases (unless `no_run`), measure and keep every finished one, write
    machine.csv (every hole) and machine_fit.csv (both variants), and the fitted values of `variants` to
    configs/machine.toml (`machine_path`), where a preset's `machine` key reads them; its other sections stay. An
    --out folder keeps every variant's values in its own machine.toml, adopted or not."""
    from analysis.core.bed_spec import BED_DIR
    from analysis.core.runner import scene_args
    from analysis.holes.compare import field_table
    from analysis.batch.compare_job import keep
    cases = load_design(design)
    want = targets(field_table())
    runs_dir = Path(runs_dir or ROOT / "results/runs")
    bed_dir = Path(bed_dir or BED_DIR)
    out = Path(out or ROOT / "results/calibration")
    kept = out / "machine" / "runs"
    failures = []
    if not no_run:
        todo = [{"id": c.id, "tag": f"[machine {c.label()}]", "args": scene_args(c.fields),
                 "asleep": bool(c.params.get("awake_mm"))} for c in cases
                if not (kept / c.id / "summary.json").exists()]
        failures = run_all(todo, workers, threads, runs_dir, bed_dir, scheduler=scheduler, label="calibrate-machine")
    tables, found = [], []
    for c in cases:
        if finished(runs_dir, c.id):
            tables.append(run_rows(c, runs_dir / c.id))          # measured and W computed in the run's folder
            keep(runs_dir / c.id, kept / c.id)                    # compare_job's kept files, W with them
            found.append((c, runs_dir / c.id))
        elif (kept / c.id / "summary.json").exists():
            say(f"calibrate-machine: {c.id} not on this machine; measured again from its kept grains")
            tables.append(run_rows(c, kept / c.id))
            found.append((c, kept / c.id))
        else:
            say(f"calibrate-machine: {c.id} ({c.label()}) has no finished run; left out")
    default_out = out == ROOT / "results/calibration"
    machine_path = Path(machine_path) if machine_path else (ROOT / MACHINE if default_out else out / "machine.toml")
    adopt = "" if set(variants) == set(VARIANTS) else " " + ",".join(variants)
    command = (f"./holes calibrate-machine {shown(design)}" + ("" if default_out else f" --out {shown(out)}")
               + (f" --adopt{adopt}" if machine_path == ROOT / MACHINE and not default_out else ""))
    if not tables:
        say("calibrate-machine: no case has finished; nothing written")
        return 1
    rows = pd.concat(tables, ignore_index=True)
    atomic_csv(rows.round(3), out / "machine.csv", stamp(command) + "; one row per hole, mm, N, s; clay only")
    table = fit(rows, want)
    draw_sections(found, out / "sections.png")
    atomic_csv(table.round(3), out / "machine_fit.csv",
               stamp(command) + f"; fitted on clay's field means only (L2 {want['surface']:g}, h1 {want['h1']:g} mm)")
    written = write_machine(table[table.variant.isin(variants)], cases, machine_path, stamp(command), want,
                            out / "machine_fit.csv")
    if not default_out and machine_path != out / "machine.toml":   # adopted: the folder's own record still follows its fit
        write_machine(table, cases, out / "machine.toml", stamp(command), want, out / "machine_fit.csv")
    if written:
        say(f"calibrate-machine: {', '.join(written)} written to {machine_path}")
        if machine_path == ROOT / MACHINE:              # the parameter page shows the configs' values
            from analysis import params_doc
            params_doc.write()
    for r in table.itertuples():
        say(f"calibrate-machine {r.variant}: " + (r.status if str(r.status).startswith("not determined") else
            f"P {r.P:.1f} mm [{r.P_lo:.1f}-{r.P_hi:.1f}], spring {r.stiffness:.2f} N/mm "
            f"[{r.stiffness_lo:.2f}-{r.stiffness_hi:.2f}], {r.status}"))
    for f in failures:
        say(f"FAILED: {f.splitlines()[0]}")
    return 1 if failures else 0


def draw_sections(found: list, path: Path) -> Path | None:
    """One hole's section at every design point of the first packing that has run, deepest punch first
    (analysis/holes/run_report.py sections): how far each hole kept the depth its punch went to."""
    from analysis.holes.run_report import sections
    if not found:
        return None
    first = min(c.params["seed"] for c, _ in found)
    points = sorted(((c, f) for c, f in found if c.params["seed"] == first and (f / "state.npz").exists()),
                    key=lambda cf: (-cf[0].fields[P_KEY], cf[0].fields[K_KEY]))
    if not points:
        return None
    labels = [f"P {c.fields[P_KEY]:g} mm, spring {c.fields[K_KEY]:g} N/mm, packing {first}" for c, _ in points]
    return sections([f for _, f in points], labels, path)


def sections_of(text: str) -> dict:
    """A machine file's text split into its variants' sections ({name: text}, each with its sub-tables), in order.

    >>> list(sections_of("# head\\n[a]\\nx = 1\\n[a.tool]\\ny = 2\\n\\n[b]\\nz = 3\\n"))
    ['a', 'b']
    """
    out, name = {}, None
    for line in text.splitlines():
        head = line.strip()
        if head.startswith("[") and head.endswith("]") and "." not in head:
            name = head[1:-1]
            out[name] = []
        if name is not None:
            out[name].append(line)
    return {k: "\n".join(v).strip() + "\n" for k, v in out.items()}


def write_machine(table: pd.DataFrame, cases: list, path: Path, note: str, want: dict,
                  fit_path: Path = ROOT / "results/calibration/machine_fit.csv") -> list[str]:
    """Each variant of `table` with a fitted P and spring rate as a section of configs/machine.toml (`section_of`,
    naming its `variant`): the design's other tool fields (the sleeve's rest, travel, preload: the same in every
    case) and the fitted two, rounded to 0.1 mm and 0.01 N/mm, with the fit's status, intervals, source and the
    command that made it (`made_by`); the file's other sections stay as they are. Returns the sections written."""
    tool = {}
    for key in cases[0].fields:
        if key.partition(".")[0] in ("disk", "sleeve") and key not in (P_KEY, K_KEY):
            values = {c.fields[key] for c in cases}
            if len(values) == 1:
                tool[key] = float(values.pop())
    head = ["# The machine's unknowns calibrated on clay (seed 001 Table 3, clay's means only), one section per "
            "reading of §4.2's L2 and clay", "# (the cone-fitted clay's literal and surface, the bench-calibrated "
            "clay's bench_literal and bench_surface);", "# a preset's `machine` key names one. Written by `./holes "
            "calibrate-machine`, each section by the command its made_by names: do not edit by hand.", ""]
    sections = sections_of(path.read_text()) if path.exists() else {}
    written = []
    for r in table.itertuples():
        if not (math.isfinite(getattr(r, "P", math.nan)) and math.isfinite(getattr(r, "stiffness", math.nan))
                and r.stiffness > 0):
            continue
        values = {**tool, P_KEY: round(float(r.P), 1), K_KEY: round(float(r.stiffness), 2)}
        name = section_of(r.variant, cases)
        lines = [f"[{name}]", f'variant = "{r.variant}"', f'meaning = "{r.meaning}"', f'status = "{r.status}"',
                 f'source = "calibrated on clay, seed 001 Table 3 (L2 {want["surface"]:g}, h1 {want["h1"]:g} mm): '
                 f'{shown(fit_path)}, {r.runs} runs, {r.holes} holes"', f'fit = "{shown(fit_path)}"',
                 f"P_interval_mm = [{r.P_lo:.1f}, {r.P_hi:.1f}]",
                 f"stiffness_interval_n_per_mm = [{r.stiffness_lo:.2f}, {r.stiffness_hi:.2f}]",
                 f"made_by = {json.dumps(note.removeprefix('made by '), ensure_ascii=False)}",
                 f"[{name}.tool]", *(f'"{k}" = {v:g}' for k, v in values.items())]
        sections[name] = "\n".join(lines) + "\n"
        written.append(name)
    if written:
        atomic_write(path, "\n".join(head) + "\n" + "\n".join(sections[k] for k in sorted(sections)))
    return written
