"""The one command-line entry: `./holes SUBCOMMAND ...` (see README)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from analysis.core.cli_types import folder, option, CommandLine
from analysis.core.config import COLLIDER_STEPS, CONE_FIELDS, SEED, THREADS, WORKERS, load_disk
from analysis.core.schema import ROOT, ConfigError, Field


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
    print(f"wrote {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}/")
    return 0


def run_scene(script: str, args: list[str]) -> int:
    """Each scene is its own YADE process (scripts/<script>), run by this same interpreter."""
    import subprocess
    return subprocess.call([sys.executable, str(ROOT / "scripts" / script), *args], cwd=ROOT)


def cmd_params(args) -> int:
    from analysis import params_doc
    try:
        print(f"wrote {params_doc.write()}")
    except ConfigError as e:
        print(f"params: {e}", file=sys.stderr)
        return 2
    return 0


def cmd_calibrate(args) -> int:
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
        calibrate.run(args.soil, args.resolution, args.size, args.cone_scale, lo, hi, args.seeds, args.cone_speed,
                      args.threads, args.lateral, args.workers)
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


def cmd_compare(args) -> int:
    from analysis.batch import compare_job
    try:
        return compare_job.run(args.preset, args.soils.split(","), args.seeds,
                               args.threads, args.workers, args.runs_dir, args.bed_dir, args.out, args.no_run, args.kept,
                               args.scheduler)
    except ConfigError as e:
        print(f"compare: {e}", file=sys.stderr)
        return 2


def cmd_calibrate_machine(args) -> int:
    from analysis.batch import machine
    try:
        return machine.run(args.design, args.workers, args.threads, args.runs_dir, args.bed_dir, args.out, args.no_run)
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
    from analysis.soil import calibration_report
    print(calibration_report.run().to_string(index=False))
    return 0


def cmd_bench(args) -> int:
    """`bench beds`: every bed's own measured settling cost (from its metadata) with the machine;
    `bench runs`: every finished disk run's cost (in --runs-dir), and the wall time per 200 mm of travel (one
    hole), added to the runs already tabulated; duck-beak runs, which have no travel, are left out;
    `bench ladder`, `bench economies`, `bench convergence`, `bench presets`, `bench speed-vs-error`:
    analysis/batch/bench.py; `bench peer`: scripts/peer.py (LIGGGHTS
    beside YADE); `bench collider`, `bench profile`: scripts/collider_bench.py (contact detection settings, or
    the adopted one's time per part, from a run's checkpoint)."""
    import json
    import pandas as pd
    from analysis.core.io import atomic_csv, machine, stamp
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
        from analysis.batch import bench
        try:
            return bench.run_presets(args.against, args.out)
        except ValueError as e:
            print(e, file=sys.stderr)
            return 2
    if args.what == "speed-vs-error":
        from analysis.batch import bench
        return bench.run_speed_vs_error(args.out)
    if args.what in ("ladder", "economies", "convergence"):
        from analysis.batch import bench
        go = {"ladder": bench.run, "economies": bench.run_economies,
              "convergence": bench.run_convergence}[args.what]
        return go(args.workers, args.threads, args.runs_dir, args.bed_dir, args.out, args.no_run)
    if args.what == "runs":
        from analysis.batch.bench import run_cost
        rows = []
        for path in sorted(Path(args.runs_dir or ROOT / "results/runs").glob("*/summary.json")):
            m = json.loads(path.read_text())
            if "travel_mm" not in m:                # a duck-beak run
                continue
            bed = Path(args.bed_dir or ROOT / "results/beds") / f"{m['bed']}.json"
            rows.append({**run_cost(m, json.loads(bed.read_text()) if bed.exists() else None), "machine": machine()})
        if not rows:
            print("bench: no finished runs in results/runs; make one with ./holes run", file=sys.stderr)
            return 1
        out, here = ROOT / "results/bench/runs.csv", pd.DataFrame(rows)
        atomic_csv(with_earlier(here, out, "run"), out, stamp("./holes bench runs") + "; rows of runs not on this "
                   "machine kept from before")
        print(here.to_string(index=False))
        return 0
    rows = []
    for meta_path in sorted((ROOT / "results/beds").glob("*.json")):
        m = json.loads(meta_path.read_text())
        rows.append({"bed": m["key"], "soil": m["soil"], "resolution": m["resolution"], "radius_mm": 1000 * m["radius"],
                     "size_mm": "x".join(f"{1000 * s:.0f}" for s in m["size_m"]), "particles": m["particles"],
                     "steps": m["steps"], "wall_s": round(m["wall_s"], 1), "threads": m["threads"],
                     "particle_steps_per_s": round(m["particle_steps"] / m["wall_s"]),
                     "porosity": round(m["porosity"], 4), "machine": machine()})
    if not rows:
        print("bench: no beds in results/beds; build one with ./holes bed", file=sys.stderr)
        return 1
    out, here = ROOT / "results/bench/beds.csv", pd.DataFrame(rows)
    atomic_csv(with_earlier(here, out, "bed"), out, stamp("./holes bench beds") + "; rows of beds not on this machine "
               "kept from before")
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


SHARE_HELP = ("(default: shared out by the cases: side by side on one thread each when they fill the cores evenly or "
              "their far field sleeps (then as many at a time as finish soonest, up to two per core), else one at a "
              "time on every core; analysis/core/runner.py share_cores)")


def scene_batch_options(p, out_help: str):
    """The options every batch of disk scenes shares (compare, study, calibrate-machine, bench)."""
    p.add_argument("--workers", type=option("--workers", WORKERS), help="runs at a time " + SHARE_HELP)
    p.add_argument("--threads", type=option("--threads", THREADS), help="YADE threads per run " + SHARE_HELP)
    p.add_argument("--runs-dir", type=folder("--runs-dir"), help="runs folder (default results/runs)")
    p.add_argument("--bed-dir", type=folder("--bed-dir"), help="beds folder (default results/beds)")
    p.add_argument("--out", type=folder("--out"), help=out_help)


STARTS = Field(1, 1000, kind=int, meaning="optimiser starts")
SCREEN = Field(1, 10 ** 6, kind=int, meaning="random frames scored per case")
COHESION = Field(0.0, 1e8, unit="Pa", meaning="bond strength")


def cohesion_range(text: str) -> tuple[float, float]:
    """--cohesion-range lo,hi (Pa): two numbers in COHESION's range, lo < hi."""
    values = option("--cohesion-range", COHESION, many=True)(text)
    if len(values) != 2 or values[0] >= values[1]:
        raise argparse.ArgumentTypeError(f"--cohesion-range = {text!r}: allowed lo,hi with lo < hi, each in "
                                         f"{COHESION.allowed()}")
    return values[0], values[1]


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address, PROTOCOL://HOST:PORT or HOST:PORT.

    >>> scheduler_address("tcp://10.0.0.5:8786")
    'tcp://10.0.0.5:8786'
    """
    import re
    if not re.fullmatch(r"((tcp|tls|ucx|ws|wss)://)?[A-Za-z0-9_.\-\[\]:]+:\d{1,5}", text):
        raise argparse.ArgumentTypeError(f"--scheduler = {text!r}: allowed a Dask scheduler's address, "
                                         "tcp://HOST:PORT or HOST:PORT")
    return text


def run_folder(text: str) -> Path:
    """A finished run's folder: it must hold the run's config.json."""
    if not (Path(text) / "config.json").is_file():
        raise argparse.ArgumentTypeError(f"run folder {text!r}: no config.json there; allowed: a folder "
                                         "results/runs/<id> of a finished run")
    return Path(text)


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLine(prog="holes", description=__doc__ + " Commands in workflow order: theory; "
                                     "beds and calibration; runs, measuring and the field comparison (the main job: "
                                     "compare); studies and benchmarks; seed 000's duck-beak; the parameter page.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    def scene(name: str, script: str, text: str):
        """A YADE scene's own command line (scripts/SCRIPT; `./holes NAME --help` shows its options)."""
        q = sub.add_parser(name, help=text, add_help=False)
        q.set_defaults(func=lambda a: run_scene(script, a.rest))

    p = sub.add_parser("theory", help="rigid-punch theory: Table 1 and Figs. 5, 6, 8 analogs (seed 001 §2.3)")
    p.add_argument("--disk", default="configs/disk.toml", help="disk config (default: the seed's disk)")
    p.add_argument("--out", type=folder("--out"), help="output folder (default results/theory/[disk name])")
    p.set_defaults(func=cmd_theory)
    scene("bed", "bed.py", "settle and level a soil bed (cached by soil, resolution, size, seed)")
    scene("cone", "cone.py", "virtual cone penetrometer in a bed (ASABE S313, scaled)")
    scene("shear", "shear.py", "a direct shear box on a settled bed: peak shear stress at each normal stress, c and φ")
    p = sub.add_parser("calibrate", help="fit a soil's cohesion to the Table 2 cone index (within 5 %%)")
    p.add_argument("--soil", required=True)
    p.add_argument("--resolution", default="coarse", help="the beds' grains (default: r = 8 mm, as calibrated)")
    p.add_argument("--size", default="450,450,280",
                   help="bed length,width,depth in mm (default: wide enough to hold the cone's bond damage)")
    p.add_argument("--cone-scale", type=option("--cone-scale", CONE_FIELDS["cone_scale"]), default=3.0,
                   help="cone size / ASABE S313 size (default 3)")
    p.add_argument("--cone-speed", type=option("--cone-speed", CONE_FIELDS["speed"]), default=0.5,
                   help="the cone's penetration speed, m/s (default 0.5)")
    p.add_argument("--seeds", type=option("--seeds", SEED, many=True), default=[1],
                   help="packing seeds; the cone index is their mean, e.g. 1,2,3")
    p.add_argument("--lateral", default="periodic", help="the beds' sides: periodic (no side walls) | walls")
    p.add_argument("--workers", type=option("--workers", WORKERS), default=2, help="cone scenes at a time")
    p.add_argument("--threads", type=option("--threads", THREADS), default=1, help="threads per scene")
    p.add_argument("--cohesion-range", type=cohesion_range, default=(0.0, 200000.0),
                   help="lo,hi in Pa (default 0,200000)")
    p.set_defaults(func=cmd_calibrate)
    p = sub.add_parser("cone-checks", help="the calibrated beds checked: replicate seeds, a 1.5x wider bed, the "
                       "cone-to-particle ratio, core density (results/calibration/cone_checks.csv, .png)")
    p.add_argument("config", nargs="?", default="configs/cone_checks.toml")
    p.add_argument("--workers", type=option("--workers", WORKERS), default=2, help="cone scenes at a time")
    p.add_argument("--threads", type=option("--threads", THREADS), default=1, help="threads per scene")
    p.add_argument("--no-run", action="store_true", help="table and plot of the stored cases only; run nothing")
    p.set_defaults(func=cmd_cone_checks)
    p = sub.add_parser("cone-damage", help="how far cone runs made with --damage broke the bed's bonds "
                       "(damage_summary.csv, damage.png in their folder)")
    p.add_argument("folder", nargs="?", default="results/cone_speed")
    p.set_defaults(func=cmd_cone_damage)
    p = sub.add_parser("calibration-report", help="table and resistance plot of the accepted calibrations")
    p.set_defaults(func=cmd_calibration_report)
    scene("run", "disk.py", "the rolling punch disk with press sleeves in a soil strip")
    p = sub.add_parser("measure", help="measure the holes of finished runs (L0, L1, L2, h1, C; seed 001 §4.2)")
    p.add_argument("folders", nargs="+", type=run_folder, help="results/runs/<id> ...")
    p.set_defaults(func=cmd_measure)
    p = sub.add_parser("metrology-band", help="each hole metric's measurement band, from holes of known size carved "
                       "in the committed beds (results/comparison/metrology/)")
    p.set_defaults(func=cmd_metrology_band)
    p = sub.add_parser("report", help="pictures of one run: the holes and the tool's forces")
    p.add_argument("folder", type=run_folder, help="results/runs/<id>")
    p.set_defaults(func=cmd_report)
    p = sub.add_parser("rings", help="the pressed ring beside each hole of finished runs, against the plate's level")
    p.add_argument("folders", nargs="+", type=run_folder, help="results/runs/<id> ...")
    p.add_argument("--out", type=folder("--out"), default="results/comparison/rings")
    p.set_defaults(func=cmd_rings)
    p = sub.add_parser("calibrate-machine", help="fit the penetration and the sleeve's spring on clay's field "
                       "holes (results/calibration/machine.csv, machine_fit.csv)")
    p.add_argument("design", nargs="?", default="configs/studies/machine_clay.toml",
                   help="a study file over disk.penetration and sleeve.stiffness, clay only")
    scene_batch_options(p, "folder of machine.csv and the kept runs (default results/calibration)")
    p.add_argument("--no-run", action="store_true", help="measure and fit the finished or kept runs; run nothing")
    p.set_defaults(func=cmd_calibrate_machine)
    p = sub.add_parser("compare", help="the main job: run, measure and set the holes beside the field's Table 3")
    p.add_argument("--preset", default="validation_medium",
                   help="run preset of configs/presets.toml (default validation_medium: the machine calibrated on "
                   "clay, 8 holes per soil, r = 6 mm grains; validation_surface is the same at r = 5 mm)")
    p.add_argument("--soils", default="clay,loam,sand")
    p.add_argument("--seeds", type=option("--seeds", SEED, many=True), default=[1],
                   help="packing seeds, one run each, e.g. 1,2,3")
    p.add_argument("--scheduler", type=scheduler_address, help="Dask distributed scheduler address (tcp://host:8786): "
                   "the runs go to its workers, as a study's cases do; default: local")
    scene_batch_options(p, "where comparison.csv/.md and comparison/ go (default results)")
    p.add_argument("--no-run", action="store_true", help="measure the finished runs only; run nothing")
    p.add_argument("--kept", action="store_true", help="a run not on this machine but kept beside the table "
                   "(<out>/comparison/runs/) is not run: it is measured again from its kept grains (state.npz), or "
                   "its kept holes.csv is read if it has none; pool runs made elsewhere")
    p.set_defaults(func=cmd_compare)
    p = sub.add_parser("study", help="a batch of disk scenes over a grid or list of parameters (configs/studies/)")
    p.add_argument("file", nargs="+", help="study file(s), e.g. configs/studies/slip.toml; several run as one batch")
    p.add_argument("--scheduler", type=scheduler_address,
                   help="Dask distributed scheduler address (tcp://host:8786); default: local")
    scene_batch_options(p, "table folder (default results/studies)")
    p.add_argument("--export-batch", metavar="TABLE", help="write a yade-batch parameter table instead of running")
    p.add_argument("--no-run", action="store_true", help="table and plot of the cases that finished; run nothing")
    p.set_defaults(func=cmd_study)
    p = sub.add_parser("bench", help="benchmarks: `bench beds` / `bench runs` tabulate measured costs; "
                       "`bench ladder` runs one clay hole at several resolutions and `bench economies` "
                       "what each scene economy costs in error (analysis/batch/bench.py); "
                       "`bench convergence`: one clay hole at r = 8, 6, 5, 4 and 3 mm on three packings each; "
                       "`bench presets`: each preset's holes against a reference preset's, with its cost per measured hole; "
                       "`bench speed-vs-error`: each preset against the converged grains (from presets and convergence); "
                       "`bench peer`: one bed and punch in LIGGGHTS and in YADE (scripts/peer.py); "
                       "`bench collider --run R`: contact detection settings on run R's strip from its checkpoint, "
                       "`bench profile --run R`: where its time goes, per part (scripts/collider_bench.py)")
    p.add_argument("what", choices=["beds", "runs", "ladder", "economies", "convergence", "presets", "speed-vs-error",
                                    "peer", "collider", "profile"])
    p.add_argument("--against", default="validation_surface",
                   help="presets: the reference preset (default validation_surface); every preset in "
                   "results/comparison.csv with its calibrated machine is set against it")
    p.add_argument("--run", help="collider, profile: a run folder with a checkpoint")
    p.add_argument("--steps", type=option("--steps", COLLIDER_STEPS), default=3000,
                   help="collider, profile: steps per setting (default 3000)")
    p.add_argument("--from-start", action="store_true",
                   help="collider, profile: the run's first --steps from its bed (any run's folder), not its checkpoint")
    scene_batch_options(p, "ladder, economies, convergence, presets, speed-vs-error: table folder (default "
                        "results/bench; ladder: results/bench/ladder)")
    p.add_argument("--no-run", action="store_true",
                   help="ladder, economies, convergence: tabulate the finished cases only; run nothing")
    p.set_defaults(func=cmd_bench)
    p = sub.add_parser("pepper", help="duck-beak mechanism (seed 000): goal-attainment design and results/pepper/")
    p.add_argument("--starts", type=option("--starts", STARTS), default=6,
                   help="optimiser starts: Table 2's initial column + random")
    p.add_argument("--out", type=folder("--out"), help="output folder (default results/pepper)")
    p.set_defaults(func=cmd_pepper)
    p = sub.add_parser("pepper-frame", help="duck-beak mechanism: infer the frame the text omits from its stated results")
    p.add_argument("--screen", type=option("--screen", SCREEN), default=8000,
                   help="random frames scored per case (the best 12 are fitted)")
    p.add_argument("--workers", type=option("--workers", WORKERS), default=2, help="cases fitted side by side (processes)")
    p.add_argument("--out", type=folder("--out"), help="output folder (default results/pepper)")
    p.set_defaults(func=cmd_pepper_frame)
    scene("duckbeak", "duckbeak.py", "the duck-beak planter (seed 000) through a ridge bed")
    p = sub.add_parser("params", help="write configs/README.md: every config key, its range, value, meaning, source")
    p.set_defaults(func=cmd_params)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    if rest and args.command not in ("bed", "cone", "shear", "run", "duckbeak"):
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    args.rest = rest
    try:
        return args.func(args)
    except ConfigError as e:
        print(f"config error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
