"""The main job: run (or reuse) one disk scene per soil and packing seed, measure the holes, and write the
comparison with the field (results/comparison.csv, results/comparison.md, results/comparison/<preset>/: the
preset's holes, tables, plots and pictures).

Each scene is its own YADE process (scripts/disk.py) in results/runs/<id>/, named by a hash of its
parameters; a finished run (summary.json present) is reused, a failed one is reported with its log and the
others go on. All inputs are checked before the first scene starts.

Every run measured here is also kept in <out>/comparison/runs/<id>/ (holes.csv, summary.json, config.json and
the final grains, state.npz; committed with the table). With `kept`, a table pools runs made on other machines:
a run whose folder is not on this machine but is kept there is not run again; it is measured again from its
kept state.npz, so a change of the metrology reaches it, or, kept without its grains, its holes are read as they
were measured if this metrology measured them (else the run is left out and named). Without it, every run not
on this machine is run. The preset's table holds every soil with a run of its settings and seeds: `soils` names the
ones to run, and the others' finished or kept runs are pooled as they are (never run), so remaking the table for one
soil keeps the rest.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd

from analysis.holes import compare, compare_report, measure, rings
from analysis.core.io import say
from analysis.core.runner import finished, plan_case, run_all, scene_args
from analysis.core.config import load_preset, replicated
from analysis.core.seedling import load_criteria
from analysis.core.schema import ROOT, ConfigError
from analysis.batch.machine import TARGET_METRICS, load_of
from analysis.core.io import atomic_csv, atomic_write, read_table, stamp

KEPT = ("holes.csv", "summary.json", "config.json", "state.npz")   # a run's files kept beside the table
KEPT_IF_THERE = ("load.json",)      # the calibrated machine's load W (analysis/batch/machine.py load_of)
# results/comparison.md: the main job first, then its validation over three packings
MD_ORDER = ("bench_validation_medium", "bench_validation", "validation_medium", "validation", "validation_surface",
            "quick", "graded", "paper")


def run(preset: str, soils: list[str], seeds: list[int] | None = None, threads: int | None = None, parallel: int | None = None,
        runs_dir: Path | None = None, bed_dir: Path | None = None, out: Path | None = None,
        no_run: bool = False, kept_runs: bool = False, scheduler: str | None = None) -> int:
    """Run what is missing (unless `no_run`: then only the finished runs are measured; with `kept_runs`, runs
    kept beside the table are not missing; on a Dask cluster's workers with `scheduler`), measure, compare.
    A preset that replicates another (configs/presets.toml `replicates`) runs that one's runs, over its own seeds
    unless `seeds` are given, and its table is kept under its own name."""
    from analysis.core.bed_spec import BED_DIR
    runs_dir = Path(runs_dir or ROOT / "results/runs")
    bed_dir = Path(bed_dir or BED_DIR)
    out = Path(out or ROOT / "results")
    runs_preset, preset_seeds = replicated(preset)
    seeds = preset_seeds if seeds is None else seeds
    for name, values in (("--soils", soils), ("--seeds", seeds)):
        twice = sorted({str(v) for v in values if list(values).count(v) > 1})
        if twice:
            raise ConfigError(f"{name} names {', '.join(twice)} more than once: allowed each once (one run's holes "
                              "would be counted twice and the interval narrowed)")
    fields = [{"soil": soil, "preset": runs_preset, "seed": seed} for soil in soils for seed in seeds]
    cases = [plan_case(f) for f in fields]              # every input checked before any scene, no YADE
    criteria = load_criteria()
    machine = load_preset(preset).machine          # a calibrated machine: its targets on clay are not predictions
    kept = out / "comparison" / "runs"
    elsewhere = {c["id"] for c in cases if kept_runs and not finished(runs_dir, c["id"])
                 and (kept / c["id"] / "holes.csv").exists()}
    others = not_asked(soils, runs_preset, seeds, runs_dir, kept)
    elsewhere |= {c["id"] for c, _ in others if not finished(runs_dir, c["id"])}
    pooled = [f"{f['soil']} seed {f['seed']}" for _, f in others]
    batch = [{"id": c["id"], "tag": f"[{f['soil']} seed {f['seed']}]", "args": scene_args(f),
              "asleep": bool(c.get("awake_mm"))}
             for f, c in sorted(zip(fields, cases), key=lambda fc: seeds.index(fc[0]["seed"]))   # a packing at a time
             if c["id"] not in elsewhere]
    if no_run:
        failures = []
        for b in batch:
            if not finished(runs_dir, b["id"]):
                say(f"compare: {b['id']} {b['tag']} not run (--no-run); left out")
    else:
        failures = run_all(batch, parallel, threads, runs_dir, bed_dir, scheduler=scheduler, label=f"compare {preset}")

    tables, summaries, local, missing, levels = [], [], [], [], []
    for c, f in [*zip(cases, fields), *others]:
        if finished(runs_dir, c["id"]):
            table, measured = measure.measure_and_write(runs_dir / c["id"])
            tables.append(table)
            levels.append(rings.level_table(measured))
            if machine:                         # the load the calibrated machine must carry, kept with the run
                summary = json.loads((runs_dir / c["id"] / "summary.json").read_text())
                load_of(runs_dir / c["id"], summary, len(tables[-1]))
            keep(runs_dir / c["id"], kept / c["id"])
            local.append(c)
        elif c["id"] in elsewhere and (kept / c["id"] / "state.npz").exists():
            say(f"compare: {c['id']} is not on this machine; measured again from its kept grains ({kept / c['id']})")
            table, measured = measure.measure_and_write(kept / c["id"], pictures=False)
            tables.append(table)
            levels.append(rings.level_table(measured))
        elif c["id"] in elsewhere:
            held = measure.kept_holes(kept / c["id"])
            if not measure.current(held):
                say(f"compare: {c['id']} was measured with a former metrology and its grains were not kept; left out")
                missing.append(f"{f['soil']} seed {f['seed']} ({c['id']}: measured with a former metrology, no "
                               "grains kept to measure again)")
                continue
            say(f"compare: {c['id']} is not on this machine; its holes as measured earlier ({kept / c['id']})")
            tables.append(held)
        else:
            missing.append(f"{f['soil']} seed {f['seed']} ({c['id']})")
            continue
        if (kept / c["id"] / "summary.json").exists():
            summaries.append(json.loads((kept / c["id"] / "summary.json").read_text()))
    if not tables:
        say("compare: no run finished")
        return 1
    holes = pd.concat(tables, ignore_index=True)
    field = compare.field_table()
    targets = {("clay", m) for m in TARGET_METRICS} if machine else set()
    table = compare.compare(holes, field, compare.theory_values(), criteria, compare.residual_pct(summaries), targets)
    table.insert(0, "preset", preset)
    command = (f"./holes compare --preset {preset} --soils {','.join(soils)} --seeds {','.join(map(str, seeds))}"
               + " --no-run" * no_run + " --kept" * kept_runs)
    write(out, preset, holes, table, field, pd.DataFrame(summaries), criteria, runs_dir, local, seeds, command,
          missing, pooled)
    if levels:
        rings.write_levels(out / "comparison" / preset / "levels", pd.concat(levels, ignore_index=True), command)
    for f in failures:
        say(f"FAILED: {f.splitlines()[0]}")
    return 1 if failures else 0


def not_asked(soils: list[str], runs_preset: str, seeds: list[int], runs_dir: Path, kept: Path) -> list[tuple]:
    """The (case, fields) of every soil not in `soils` whose run of the preset and a seed is finished on this machine
    or kept beside the table: never run, but pooled, so a table remade for some soils keeps the others' rows. A run
    made with other settings has another id and is not among them."""
    from analysis.core.soil_config import SOILS
    fields = [{"soil": soil, "preset": runs_preset, "seed": seed} for soil in SOILS if soil not in soils
              for seed in seeds]
    cases = [(plan_case(f), f) for f in fields]
    return [(c, f) for c, f in cases if finished(runs_dir, c["id"]) or (kept / c["id"] / "holes.csv").exists()]


def keep(folder: Path, to: Path):
    """What measuring a finished run needs, kept beside the table: holes.csv, summary.json, config.json and its
    final grains (state.npz: 0.7 MB for a quick run, about 3 for a paper one; not the checkpoint or the time series)."""
    for name in KEPT:
        atomic_write(to / name, (folder / name).read_bytes())
    for name in KEPT_IF_THERE:
        if (folder / name).exists():
            atomic_write(to / name, (folder / name).read_bytes())


def write(out: Path, preset: str, holes, table, field, costs, criteria, runs_dir, local, seeds, command: str,
          missing: list[str], pooled: list[str]):
    """The table, its plots and pictures; `missing` names the asked cases with no finished run (failed or not run),
    `pooled` the cases of soils not asked, read from their finished or kept runs."""
    note = stamp(command)
    folder = out / "comparison"
    own = folder / preset                    # this preset's tables, plots and pictures
    own.mkdir(parents=True, exist_ok=True)
    atomic_csv(holes.round(2), compare.kept_holes(preset, out), note)
    cpu = (f" and {costs.cpu_s.sum():.0f} s of CPU" if "cpu_s" in costs and costs.cpu_s.notna().all() else "")
    cost = "Cost: not recorded for these runs." if costs.empty else (
        f"Cost: {len(costs)} runs, {int(costs.particles.mean())} grains each on average, "
        f"{costs.wall_s.sum():.0f} s of wall time{cpu} in all (YADE threads per run: "
        f"{'/'.join(map(str, sorted(set(costs.threads))))}; "
        f"{(costs.wall_s * 200 / costs.travel_mm).mean():.0f} s per 200 mm hole; wall time includes any time a run "
        f"was suspended).")
    unrecorded = holes.run.nunique() - len(costs)
    if unrecorded and not costs.empty:
        cost += f" The other {unrecorded} runs' summaries were not kept."
    earlier = sorted(set(holes.run) - {c["id"] for c in local})
    if earlier:
        cost += (f" Not on this machine, their holes read as measured earlier (comparison/runs/): "
                 f"{', '.join(earlier)}.")
    resumed = sorted(r["id"] for r in costs.to_dict("records")
                     if isinstance(r.get("resumed_at_steps"), list) and r["resumed_at_steps"])
    if resumed:
        cost += (f" Resumed from a checkpoint (another realisation of the same strip, results/scenes/README.md): "
                 f"{', '.join(resumed)}.")
    if pooled:
        cost += f" Soils not asked, from their finished or kept runs: {', '.join(pooled)}."
    if missing:
        cost += f" Asked for but not in this table (no finished run: failed or not run): {', '.join(missing)}."
    order = compare.ordering(table)
    order_text = "; ".join(
        f"{m}: field {'yes' if o['field'] else 'no'}, simulated "
        + ("tie" if o["tie"] else ", ".join(f"{step} {'yes' if v['simulated'] else 'no'} "
                                             f"({'resolved' if v['resolved'] else 'not resolved'})"
                                             for step, v in o["steps"].items()))
        for m, o in order.items())
    md = compare_report.markdown(table.drop(columns="preset"), preset, note + "\n\n" + cost)
    if order_text:
        md += f"\nSoil ordering (clay > loam > sand): {order_text}.\n"
    diff = compare.soil_difference(holes, field)
    if not diff.empty:
        atomic_csv(diff.round(3), own / "soil_difference.csv", "clay's holes deeper than sand's, simulated (both "
                   "readings of L2) and in the field, 95 % intervals; see analysis/holes/compare.py soil_difference")
        md += ("\nClay's holes against sand's (L2, mm; 95 % interval): field "
               f"{diff.field.iloc[0]:+.1f} [{diff.field_lo.iloc[0]:+.1f}, {diff.field_hi.iloc[0]:+.1f}]; simulated "
               + "; ".join(f"{'from the surface' if r.metric == 'L2_surface' else 'from the subsided level'} "
                           f"{r.sim:+.1f} [{r.sim_lo:+.1f}, {r.sim_hi:+.1f}] over the {r.basis}"
                           for r in diff.itertuples()) + f" (`comparison/{preset}/soil_difference.csv`).\n")
    bound = float(table[table.metric == "L2"].theory_envelope.iloc[0])     # the swept envelope's L2
    reach = compare.depth_reach(field[field.soil.isin(set(holes.soil))], holes, bound)
    atomic_csv(reach, own / "depth_reach.csv", "L2 + h1 per field run and simulated soil; see "
               "analysis/holes/compare.py depth_reach")
    per_soil = []
    for soil, g in reach.groupby("soil", sort=False):
        fld, sim = g[g.source != "simulated"].L2_plus_h1, g[g.source == "simulated"].L2_plus_h1
        per_soil.append(f"{soil} field {fld.min():.1f}–{fld.max():.1f}, simulated {sim.iloc[0]:.1f}")
    md += (f"\nL2 + h1, the √2·a2 level below the undisturbed surface, against the rigid punch's deepest "
           f"{bound:.1f} mm: {'; '.join(per_soil)} mm (`comparison/{preset}/depth_reach.csv`).\n")
    loads = {}
    for run_id, soil in holes[["run", "soil"]].drop_duplicates().itertuples(index=False):
        f = folder / "runs" / run_id / "load.json"
        if f.exists():
            loads.setdefault(soil, []).append(json.loads(f.read_text())["W_n"])
    if loads:
        md += ("\nThe load the machine must carry, W (the mean vertical soil force on the disk's punches and plates "
               "over the measured holes' punch periods, `analysis/batch/machine.py`): "
               + ", ".join(f"{soil} {sum(w) / len(w):.0f} N" for soil, w in loads.items()) + ".\n")
    trend = compare.position_trend(holes)
    if not trend.empty:
        atomic_csv(trend.round(3), own / "position_trend.csv", "per run and metric, the slope against "
                   "the hole's place along the strip (mm per hole), 95 % interval; see analysis/holes/compare.py position_trend")
        found = trend[trend.trend]
        md += (f"\nHoles along the strip (are a run's holes exchangeable?): of {len(trend)} run-metric slopes, "
               f"{len(found)} with a 95 % interval excluding 0"
               + (": " + ", ".join(f"{r.soil} {r.metric} {r.slope_per_hole:+.1f} mm per hole" for r in found.itertuples())
                  if len(found) else "") + f" (`comparison/{preset}/position_trend.csv`).\n")
    atomic_write(own / "table.md", md)
    combined = out / "comparison.csv"
    if combined.exists():
        old = read_table(combined)
        table = pd.concat([old[old.preset != preset], table], ignore_index=True)
    rank = {p: i for i, p in enumerate(MD_ORDER)}          # the main job first, then in MD_ORDER, others after
    table = table.sort_values("preset", key=lambda c: c.map(lambda p: rank.get(p, len(rank))), kind="stable")
    atomic_csv(table.round(3), combined, "one row per preset, soil and metric; see results/comparison.md")
    mds = sorted(folder.glob("*/table.md"), key=lambda p: (MD_ORDER.index(p.parent.name) if p.parent.name in MD_ORDER
                                                           else len(MD_ORDER), p.parent.name))
    atomic_write(out / "comparison.md", "\n".join(p.read_text() for p in mds))
    compare_report.plot(table[table.preset == preset], holes, field, preset, own, note)
    atomic_csv(compare.field_consistency(field, criteria["stated"]), folder / "field_consistency.csv",
               "can each field run's pass rate be true under the stated criteria? see analysis/holes/compare.py")
    for c in local:
        if c["seed"] == min(seeds):
            for name in ("holes_top.png", "holes_sections.png"):
                shutil.copyfile(runs_dir / c["id"] / name, own / f"{c['soil']['name']}-{name}")
    print(md)
