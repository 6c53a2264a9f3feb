"""What each `./holes` command does once its command line is parsed (analysis/cli.py parses it): one function per
command, each returning the exit code."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from analysis.core.config import MACHINE, load_disk
from analysis.core.schema import ROOT, ConfigError
from analysis.core.bed_spec import BED_DIR
from analysis.core.io import shown


def cmd_theory(args) -> int:
    from analysis.holes import theory_report
    disk = load_disk(args.disk)
    out = Path(args.out) if args.out else ROOT / "results/theory" / ("" if disk.name == "disk" else disk.name)
    command = "./holes theory" + ("" if args.disk == "configs/disk.toml" else f" --disk {args.disk}")
    res = theory_report.run(disk, out, command)
    t = res["table"]
    for slip in sorted(t.slip.unique()):
        r = t[t.slip == slip].set_index("quantity")
        print(f"slip {slip:4.2f}: envelope L0 {r.loc['L0', 'envelope_mm']:6.1f} mm, L1 {r.loc['L1', 'envelope_mm']:5.1f} mm"
              + (f"; Table 1 L0 {r.loc['L0', 'paper_mm']:.1f} mm" if r.paper_mm.notna().any() else ""))
    if len(res["readings"]):
        print(f"best reading of eqs (4)/(5) against Table 1: {res['best']} "
              f"(rms {res['readings'].rms_mm.min():.1f} mm)")
    print(f"wrote {shown(out)}/")
    return 0


def run_scene(script: str, args: list[str]) -> int:
    """Each scene is its own YADE process (scripts/<script>), run by this same interpreter."""
    return subprocess.call([sys.executable, str(ROOT / "scripts" / script), *args], cwd=ROOT)


def cmd_params(args) -> int:
    from analysis import params_doc
    try:
        print(f"wrote {params_doc.write()}")
    except ConfigError as e:
        print(f"params: {e}", file=sys.stderr)
        return 2
    return 0


BENCH_CHECKS = ("--size-check", "--cones", "--probe", "--cone-transfer", "--check-deepest", "--check-packings",
                "--remeasure")


def bench_checks_asked(args) -> list[str]:
    """The `calibrate --bench` checks (each a check of the calibration or its prior, no calibration) given."""
    return [flag for flag in BENCH_CHECKS if getattr(args, flag[2:].replace("-", "_"))]


def cmd_calibrate(args) -> int:
    if args.bench:
        return cmd_calibrate_bench(args)
    if bench_checks_asked(args) or args.config:
        flag = (bench_checks_asked(args) or ["--config"])[0]
        print(f"calibrate: {flag}: allowed only with --bench (a check of the bench calibration, or its settings)",
              file=sys.stderr)
        return 2
    from analysis.soil import calibrate
    from analysis.core.bed_spec import check_size
    from analysis.core.config import check_lateral, load_resolution
    from analysis.core.soil_config import load_soil
    lo, hi = args.cohesion_range
    try:                                    # every input before any bed or cone scene
        load_soil(args.soil), load_resolution(args.resolution), check_lateral(args.lateral)
        check_size([float(v) / 1000 for v in args.size.split(",")])
    except ConfigError as e:
        print(f"calibrate: {e}", file=sys.stderr)
        return 2
    except ValueError:
        print(f"calibrate: --size {args.size!r}: allowed three numbers length,width,depth in mm", file=sys.stderr)
        return 2
    try:
        calibrate.run(args.soil, args.resolution, args.size, args.cone_scale, lo, hi, args.seeds or [1], args.cone_speed,
                      args.threads, args.lateral, args.workers or 2)
    except (ValueError, RuntimeError) as e:
        print(f"calibrate {args.soil}: {e}", file=sys.stderr)
        return 1
    return 0


def cmd_cone_checks(args) -> int:
    from analysis.soil import cone_checks
    try:
        cone_checks.run(args.config, args.workers, args.threads, no_run=args.no_run)
    except RuntimeError as e:
        print(f"cone-checks: {e}", file=sys.stderr)
        return 1
    return 0


def cmd_report(args) -> int:
    from analysis.holes import run_report
    for path in run_report.run(args.folder):
        print(f"wrote {path}")
    return 0


def cmd_measure(args) -> int:
    from analysis.holes import measure
    for run_dir in args.folders:
        table = measure.run(run_dir)
        print(table.drop(columns=["run"]).round(1).to_string(index=False))
    return 0


def cmd_metrology_band(args) -> int:
    from analysis.holes import metrology_band
    band = metrology_band.run()
    print(band.round(1).to_string(index=False))
    return 0


def cmd_refill(args) -> int:
    from analysis.holes import refill
    try:
        table = refill.run(args.folders, Path(args.out))
    except (ConfigError, ValueError) as e:
        print(f"refill: {e}", file=sys.stderr)
        return 2
    print(table.drop(columns=["run"]).to_string(index=False))
    print(f"wrote {args.out}/refill.csv")
    return 0


def cmd_rings(args) -> int:
    from analysis.holes import rings
    table, levels = rings.run(args.folders, Path(args.out))
    inner = table[(table.r >= table.band_lo) & (table.r <= table.band_hi)]
    print(inner.groupby(["run", "hole"], sort=False)[["h1", "plate_depth", "depth"]]
          .agg({"h1": "first", "plate_depth": "first", "depth": ["min", "max"]}).round(1).to_string())
    print("L0, L1 (mm) and L0's split at each level below -h1, per soil:")
    print(rings.level_summary(levels).round(1).to_string(index=False))
    print(f"wrote {args.out}/rings.csv, rings.png, levels.csv, levels_summary.csv, levels-<soil>.png")
    return 0


def cmd_budget(args) -> int:
    from analysis.holes import budget_report
    try:
        for path in budget_report.run(args.preset, out=args.out, machine_dir=args.machine_dir):
            print(f"wrote {path}")
    except ConfigError as e:
        print(f"budget: {e}", file=sys.stderr)
        return 2
    return 0


def cmd_compare(args) -> int:
    from analysis.batch import compare_job
    try:
        return compare_job.run(args.preset, args.soils.split(","), args.seeds,
                               args.threads, args.workers, args.runs_dir, args.bed_dir, args.out, args.no_run, args.kept,
                               args.scheduler)
    except ConfigError as e:
        print(f"compare: {e}", file=sys.stderr)
        return 2


def calibrate_command(args) -> str:
    """The `calibrate --bench` command that draws the soil's posterior under args' --config."""
    return f"./holes calibrate --soil {args.soil} --bench" + (f" --config {args.config}" if args.config else "")


def packings_checked(args, cfg: dict, out_dir: Path) -> dict:
    """`calibrate --bench --check-packings`: the check on the packings of --seeds of the posterior (or deepest set) of
    the filter kept in out_dir; the posterior's is recorded in its soil config's [bench_posterior] too
    (`posterior_configs`)."""
    from analysis.soil import bench_calibration as bench
    seeds = args.seeds or [1]
    result = bench.check_packings(args.soil, seeds, cfg, out_dir, which=args.check_packings)
    if args.check_packings == "posterior":
        bench.record_packings(args.soil, result, seeds, out_dir, command=calibrate_command(args))
    return result


def size_checked(args, cfg: dict, out_dir: Path):
    """`calibrate --bench --size-check`: the shear box's or collapse column's (analysis/soil/bench_calibration.py) at
    the posterior of the filter kept in out_dir, or with `cell` the simple shear cell's (analysis/soil/cell.py) at
    that posterior too, on --seeds (default [bench] check_seeds)."""
    from analysis.soil import bench_calibration as bench
    if args.size_check == "cell":
        from analysis.soil import cell
        return cell.size_check(args.soil, cfg, args.seeds or [int(s) for s in cfg["check_seeds"]],
                               cfg["workers"], bench_dir=out_dir).round(2)
    return bench.size_check(args.soil, cfg, out_dir, box=args.size_check, seeds=args.seeds).round(2)


def bench_config(given: str | None) -> Path:
    """The bench calibration's settings file: `--config`, else configs/bench_calibration.toml; a missing one is a
    ConfigError naming the flag."""
    from analysis.soil import bench_calibration as bench
    if given is None:
        return bench.CONFIG
    path = Path(given) if Path(given).is_absolute() else ROOT / given
    if not path.is_file():
        raise ConfigError(f"--config {given}: no such file; allowed a bench config such as configs/bench_calibration.toml")
    return path


def cmd_calibrate_bench(args) -> int:
    """`calibrate --bench`: the soil's three contact parameters on its bench tests (GrainLearning), then the
    posterior's bench responses on the check packings."""
    from analysis.soil import bench_calibration as bench
    from analysis.core.soil_config import load_soil
    from analysis.core.config import load_resolution
    try:
        cfg = bench.load_config(bench_config(args.config), soil=args.soil)
        load_soil(args.soil), bench.load_targets(args.soil), load_resolution(cfg["resolution"])
        cfg["workers"] = args.workers or cfg["workers"]
    except ConfigError as e:
        print(f"calibrate: {e}", file=sys.stderr)
        return 2
    asked = bench_checks_asked(args)
    if args.runs_grains and asked != ["--cones"]:
        print("calibrate: --runs-grains: allowed only with --cones (the cone of chosen evaluations)", file=sys.stderr)
        return 2
    if len(asked) > 1:
        print(f"calibrate: {', '.join(BENCH_CHECKS[:-1])} and {BENCH_CHECKS[-1]}: allowed one of them", file=sys.stderr)
        return 2
    out_dir = bench.filter_dir(cfg)        # a variant config's filter and every check of its posterior: its folder
    if asked:
        import pandas as pd
        checks = {"--size-check": lambda: size_checked(args, cfg, out_dir),
                  "--cones": lambda: bench.cones(args.soil, args.cones, cfg, out_dir, workers=cfg["workers"],
                                                runs_grains=args.runs_grains),
                  "--probe": lambda: bench.probes(args.soil, args.probe, cfg, out_dir, args.seeds),
                  "--cone-transfer": lambda: bench.cone_transfer(args.soil, args.seeds or [1], cfg, out_dir,
                                                                 workers=cfg["workers"]).round(2),
                  "--check-deepest": lambda: pd.DataFrame(bench.check_deepest(args.soil, cfg, out_dir)).T,
                  "--check-packings": lambda: pd.DataFrame(packings_checked(args, cfg, out_dir)).T,
                  "--remeasure": lambda: pd.DataFrame({"remeasured": [str(p.relative_to(ROOT))
                                                                      for p in bench.remeasure(args.soil)]})}
        try:
            table = checks[asked[0]]()
        except ConfigError as e:
            print(f"calibrate: {e}", file=sys.stderr)
            return 2
        except RuntimeError as e:
            print(f"calibrate {args.soil}: {e}", file=sys.stderr)
            return 1
        print(table.to_string(index=False))
        return 0
    try:
        post = bench.calibrate(args.soil, cfg, out_dir)
        check = bench.check(args.soil, post, cfg, out_dir)
    except RuntimeError as e:
        print(f"calibrate {args.soil}: {e}", file=sys.stderr)
        return 1
    written = bench.write_posterior(args.soil, post, check, calibrate_command(args), folder=out_dir)
    bench.report()
    print(f"calibrate {args.soil}: the posterior mean on packings {', '.join(map(str, cfg['check_seeds']))}: "
          f"{bench.check_status(check)} ({written.relative_to(ROOT)} [bench_posterior])")
    print(json.dumps({"posterior": post["mean"], "interval": post["interval"], "check": check}))
    return 0


def cmd_calibrate_machine(args) -> int:
    from analysis.batch import machine
    try:
        variants = machine.adopted_variants(args.adopt)
        return machine.run(args.design, args.workers, args.threads, args.runs_dir, args.bed_dir, args.out, args.no_run,
                           machine_path=ROOT / MACHINE if args.adopt else None, variants=variants)
    except ConfigError as e:
        print(f"calibrate-machine: {e}", file=sys.stderr)
        return 2


def cmd_study(args) -> int:
    from analysis.batch import study
    try:
        if args.export_batch:
            if len(args.file) != 1:
                raise ConfigError("--export-batch takes one study file")
            if args.no_run or args.scheduler:
                raise ConfigError("--export-batch writes a table and runs nothing: allowed without --no-run and "
                                  "--scheduler")
            path = study.export_batch(args.file[0], Path(args.export_batch))
            print(f"wrote {path}; run it with: yade-batch {path} scripts/batch_case.py")
            return 0
        return study.run(args.file, args.workers, args.threads, args.scheduler, args.runs_dir, args.bed_dir, args.out,
                         args.no_run)
    except ConfigError as e:
        print(f"study: {e}", file=sys.stderr)
        return 2


def cmd_pepper_frame(args) -> int:
    from analysis.pepper import pepper_frame
    out = Path(args.out) if args.out else ROOT / "results/pepper"
    table = pepper_frame.run(out, f"./holes pepper-frame --screen {args.screen}", args.screen, args.workers,
                             lambda m: print(m, file=sys.stderr, flush=True))
    print(pepper_frame.summary(table).to_string(index=False))
    print(f"wrote {out / 'frame_fit.csv'}")
    return 0


def cmd_pepper(args) -> int:
    from analysis.pepper import pepper_design
    out = Path(args.out) if args.out else ROOT / "results/pepper"
    try:
        result, table, written = pepper_design.run(out, "./holes pepper", starts=args.starts)
    except (ConfigError, ValueError) as e:
        print(f"pepper: {e}", file=sys.stderr)
        return 2
    print(table.round(2).to_string(index=False))
    print(f"goal attainment: gamma {result.gamma:.2f} mm after {result.evaluations} evaluations from "
          f"{result.starts} starts; margins: dead point {result.margins[0]:.1f} mm, assembly {result.margins[1]:.1f} mm")
    for w in written:
        print(f"wrote {w}")
    return 0


def cmd_cone_damage(args) -> int:
    import pandas as pd
    from analysis.soil import cone_damage
    try:
        table = cone_damage.run(Path(args.folder))
    except ConfigError as e:
        print(e, file=sys.stderr)
        return 2
    with pd.option_context("display.width", 200):
        print(table.drop(columns=["map"]).round(3).to_string(index=False))
    return 0


def cmd_calibration_report(args) -> int:
    from analysis.soil import bench_calibration, calibration_report, cell, onset, soils_apart
    print(calibration_report.run().to_string(index=False))
    for path in [*bench_calibration.report(), *bench_calibration.variant_reports(), *soils_apart.run(),
                 soils_apart.filter_packing_run(),
                 soils_apart.check_odds_run(), soils_apart.shear_scatter_run(), soils_apart.packing_effects_run(),
                 soils_apart.cone_per_c_run(), soils_apart.box_shift_run(), soils_apart.box_shift_pooled_run(),
                 soils_apart.box_peaks_run(),
                 soils_apart.reading_reweighted_run(), *cell.run(), *onset.run()]:
        if path:
            print(f"wrote {path}")
    return 0


def cmd_bench(args) -> int:
    """`bench beds`: every bed's own measured settling cost (from its metadata) with the machine;
    `bench runs`: every finished disk run's cost (in --runs-dir), and the wall time per 200 mm of travel (one
    hole), added to the runs already tabulated; duck-beak runs, which have no travel, are left out;
    `bench ladder`, `bench economies`, `bench convergence`, `bench presets`, `bench speed-vs-error`:
    analysis/batch/bench.py; `bench peer`: scripts/peer.py (LIGGGHTS
    beside YADE); `bench collider`, `bench profile`: scripts/collider_bench.py (contact detection settings, or
    the adopted one's time per part, from a run's checkpoint)."""
    from analysis.core.io import machine
    if args.what == "peer":
        return run_scene("peer.py", [])
    if args.what in ("collider", "profile"):
        if not args.run:
            print(f"bench {args.what}: give --run results/runs/<id>, a run with a checkpoint (with --from-start, any run's "
                  "folder)", file=sys.stderr)
            return 2
        return run_scene("collider_bench.py", [args.run, "--steps", str(args.steps), "--threads", str(args.threads or 2),
                                               *(["--profile"] if args.what == "profile" else []),
                                               *(["--from-start"] if args.from_start else []),
                                               *(["--bed-dir", args.bed_dir] if args.bed_dir else [])])
    if args.what == "presets":
        from analysis.batch import bench_reference
        try:
            return bench_reference.run_presets(args.against, args.out)
        except ValueError as e:
            print(e, file=sys.stderr)
            return 2
    if args.what == "grain-size":
        from analysis.batch import bench_reference
        return bench_reference.run_grain_size(args.out, strip=args.strip)
    if args.what == "speed-vs-error":
        from analysis.batch import bench_reference
        return bench_reference.run_speed_vs_error(args.out)
    if args.what in ("ladder", "economies", "convergence"):
        from analysis.batch import bench, bench_reference
        go = {"ladder": bench.run, "economies": bench.run_economies,
              "convergence": bench_reference.run_convergence}[args.what]
        return go(args.workers, args.threads, args.runs_dir, args.bed_dir, args.out, args.no_run)
    if args.what == "runs":
        from analysis.batch.bench import run_cost
        rows = []
        for path in sorted(Path(args.runs_dir or ROOT / "results/runs").glob("*/summary.json")):
            m = json.loads(path.read_text())
            if "travel_mm" not in m:                # a duck-beak run
                continue
            bed = Path(args.bed_dir or BED_DIR) / f"{m['bed']}.json"
            rows.append({**run_cost(m, json.loads(bed.read_text()) if bed.exists() else None), "machine": machine()})
        return write_costs(rows, "run", "no finished runs in results/runs; make one with ./holes run")
    rows = []
    for meta_path in sorted(BED_DIR.glob("*.json")):
        m = json.loads(meta_path.read_text())
        rows.append({"bed": m["key"], "soil": m["soil"], "resolution": m["resolution"], "radius_mm": 1000 * m["radius"],
                     "size_mm": "x".join(f"{1000 * s:.0f}" for s in m["size_m"]), "particles": m["particles"],
                     "steps": m["steps"], "wall_s": round(m["wall_s"], 1), "threads": m["threads"],
                     "particle_steps_per_s": round(m["particle_steps"] / m["wall_s"]),
                     "porosity": round(m["porosity"], 4), "machine": machine()})
    return write_costs(rows, "bed", "no beds in results/cache/beds; build one with ./holes bed")


def write_costs(rows: list[dict], key: str, none: str) -> int:
    """results/bench/<key>s.csv: this machine's rows, and those of runs or beds not here kept from before."""
    import pandas as pd
    from analysis.core.io import atomic_csv, stamp
    if not rows:
        print(f"bench: {none}", file=sys.stderr)
        return 1
    out, here = ROOT / f"results/bench/{key}s.csv", pd.DataFrame(rows)
    atomic_csv(with_earlier(here, out, key), out, stamp(f"./holes bench {key}s") + f"; rows of {key}s not on this "
               "machine kept from before")
    print(here.to_string(index=False))
    return 0


def with_earlier(here, out: Path, key: str):
    """This machine's rows (`here`) with the rows of `out`'s table made elsewhere: a row measured again is
    replaced, rows sorted by `key`."""
    import pandas as pd
    from analysis.core.io import read_table
    if not out.exists():
        return here
    earlier = read_table(out)
    return pd.concat([earlier[~earlier[key].isin(here[key])], here]).sort_values(key)
