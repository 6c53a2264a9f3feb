"""The one command-line entry: `./holes SUBCOMMAND ...` (see README)."""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from analysis.commands import (cmd_bench, cmd_budget, cmd_calibrate, cmd_calibrate_machine, cmd_calibration_report,
                               cmd_compare, cmd_cone_checks, cmd_cone_damage, cmd_measure, cmd_metrology_band,
                               cmd_params, cmd_pepper, cmd_pepper_frame, cmd_refill, cmd_report, cmd_rings, cmd_study, cmd_theory,
                               run_scene)
from analysis.core.cli_types import CommandLine, folder, option
from analysis.core.config import COLLIDER_STEPS, CONE_FIELDS, SEED, THREADS, WORKERS, grain_size_strips
from analysis.core.schema import ConfigError, Field


SHARE_HELP = ("(default: shared out by the cases: side by side on one thread each when they fill the cores evenly or "
              "their far field sleeps (then as many at a time as finish soonest, up to two per core), else one at a "
              "time on every core; analysis/core/runner.py share_cores)")


def scene_batch_options(p, out_help: str):
    """The options every batch of disk scenes shares (compare, study, calibrate-machine, bench)."""
    p.add_argument("--workers", type=option("--workers", WORKERS), help="runs at a time " + SHARE_HELP)
    p.add_argument("--threads", type=option("--threads", THREADS), help="YADE threads per run " + SHARE_HELP)
    p.add_argument("--runs-dir", type=folder("--runs-dir"), help="runs folder (default results/runs)")
    p.add_argument("--bed-dir", type=folder("--bed-dir"), help="beds folder (default results/cache/beds)")
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


def evaluation_ids(text: str) -> list[str]:
    """Bench evaluation ids, comma-separated: s<seed>-<10 hex digits> each."""
    ids = [t.strip() for t in text.split(",") if t.strip()]
    if not ids or not all(re.fullmatch(r"s\d+-[0-9a-f]{10}", i) for i in ids):
        raise argparse.ArgumentTypeError(f"--cones = {text!r}: allowed evaluation ids s<seed>-<10 hex digits>, "
                                         "comma-separated (the folders of results/calibration/bench/<soil>/)")
    return ids


def parameter_set(text: str) -> dict:
    """A soil contact parameter set, NAME=VALUE comma-separated, each in its soil config range.

    >>> parameter_set("normal_cohesion=1.2e5,friction_deg=16")
    {'normal_cohesion': 120000.0, 'friction_deg': 16.0}
    """
    from analysis.core.soil_config import SOIL_FIELDS
    out = {}
    for item in (t.strip() for t in text.split(",") if t.strip()):
        name, _, value = item.partition("=")
        if name not in SOIL_FIELDS:
            raise argparse.ArgumentTypeError(f"--probe {item!r}: allowed NAME=VALUE with NAME one of "
                                             f"{', '.join(SOIL_FIELDS)}")
        out[name] = option(f"--probe {name}", SOIL_FIELDS[name])(value)
    if not out:
        raise argparse.ArgumentTypeError("--probe: allowed NAME=VALUE,... (the calibrated contact parameters)")
    return out


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
    scene("collapse", "collapse.py", "a column of disturbed soil let slump: the slope it stands at")
    scene("simple-shear", "simple_shear.py", "a wall-free (periodic) simple shear cell: peak shear stress at each "
          "normal stress, c and φ")
    p = sub.add_parser("calibrate", help="fit a soil's cohesion to the Table 2 cone index (within 5 %%)")
    p.add_argument("--soil", required=True)
    p.add_argument("--resolution", default="coarse", help="the beds' grains (default: r = 8 mm, as calibrated)")
    p.add_argument("--size", default="450,450,280",
                   help="bed length,width,depth in mm (default: wide enough to hold the cone's bond damage)")
    p.add_argument("--cone-scale", type=option("--cone-scale", CONE_FIELDS["cone_scale"]), default=3.0,
                   help="cone size / ASABE S313 size (default 3)")
    p.add_argument("--cone-speed", type=option("--cone-speed", CONE_FIELDS["speed"]), default=0.5,
                   help="the cone's penetration speed, m/s (default 0.5)")
    p.add_argument("--seeds", type=option("--seeds", SEED, many=True), default=None,
                   help="packing seeds; the cone index is their mean (default 1), e.g. 1,2,3; with --size-check the "
                        "packings it checks (default [bench] check_seeds)")
    p.add_argument("--lateral", default="periodic", help="the beds' sides: periodic (no side walls) | walls")
    p.add_argument("--workers", type=option("--workers", WORKERS), default=None,
                   help="scenes at a time: cones (default 2), or with --bench its evaluations and cones (default "
                        "configs/bench_calibration.toml [bench] workers)")
    p.add_argument("--threads", type=option("--threads", THREADS), default=1, help="threads per scene")
    p.add_argument("--cohesion-range", type=cohesion_range, default=(0.0, 200000.0),
                   help="lo,hi in Pa (default 0,200000)")
    p.add_argument("--bench", action="store_true",
                   help="calibrate bond, friction, new-contact cohesion and rolling friction on the shear box and the "
                        "collapse test (and the cone, where the soil's cone_target is set) with GrainLearning "
                        "(configs/bench_calibration.toml, configs/field/soil_targets.csv) instead")
    p.add_argument("--config", default=None, metavar="TOML",
                   help="with --bench: the bench settings (default configs/bench_calibration.toml, whose posterior "
                        "goes to configs/soils/<soil>.toml [bench_posterior]; a variant such as "
                        "configs/bench_calibration_onset.toml keeps its filter, the checks of its posterior and that "
                        "posterior, as a soil config <soil>.toml, in its folder, e.g. "
                        "results/calibration/bench/onset-filter/)")
    p.add_argument("--cones", type=evaluation_ids, default=None,
                   help="with --bench: no calibration; the cone check of these finished evaluations of the soil "
                        "(ids of results/calibration/bench/<soil>/, comma-separated), --workers at a time: the cone "
                        "across the bench's region (results/calibration/bench/<soil>-cones.csv)")
    p.add_argument("--runs-grains", action="store_true",
                   help="with --cones: the cone at the runs' grains, as the checks read it, instead of the filter's "
                        "(results/calibration/bench/<soil>-cones-runs-grains.csv)")
    p.add_argument("--size-check", nargs="?", const="filter", default=None, metavar="filter|checks|height|cell",
                   help="with --bench: no calibration; the posterior mean's bench responses on the check packings in "
                        "the filter's box (or the checks' shear box) and one grown by half (height: the checks' box "
                        "grown in height alone; cell: the wall-free simple shear cell at each of [bench] "
                        "cell_edges_mm) (results/calibration/bench/<soil>-size.csv, <soil>-box-size.csv, "
                        "<soil>-box-height.csv, cell.csv)")
    p.add_argument("--remeasure", action="store_true",
                   help="with --bench: nothing runs; every kept check of the soil measured again from its evaluations' "
                        "stored results (c and φ, the collapse slope) and judged again, the posterior's recorded in "
                        "configs/soils/<soil>.toml [bench_posterior]")
    p.add_argument("--check-deepest", action="store_true",
                   help="with --bench: no calibration; the bench responses (and cone) of the set whose response planes "
                        "lie deepest inside every target (results/calibration/bench/deepest.csv) on the check packings "
                        "(results/calibration/bench/<soil>-deepest-check.csv, .json)")
    p.add_argument("--check-packings", nargs="?", const="posterior", default=None, metavar="posterior|deepest",
                   help="with --bench: no calibration; the shear box and collapse test of the posterior mean (or of the "
                        "planes' deepest set) on the packings of --seeds (three or more), the mean's 95 %% interval "
                        "against each target (results/calibration/bench/<soil>[-deepest]-check-packings.csv, .json)")
    p.add_argument("--cone-transfer", action="store_true",
                   help="with --bench: no calibration; the posterior mean's cone index at the filter's grains and at the "
                        "bench's (the main job's) on the packings of --seeds, --workers at a time "
                        "(results/calibration/bench/<soil>-cone-transfer.csv)")
    p.add_argument("--probe", type=parameter_set, action="append", default=None, metavar="NAME=VALUE,...",
                   help="with --bench: no calibration; this parameter set's bench responses and cone index on the "
                        "calibration packing or on each of --seeds (every calibrated parameter named, other contact "
                        "parameters such as a shear_cohesion of its own besides; repeat for more sets, run --workers "
                        "at a time): results/calibration/bench/<soil>-probes.csv")
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
    p = sub.add_parser("refill", help="the grains back inside each punch's volume after it left, and where they came "
                       "from (refill.csv)")
    p.add_argument("folders", nargs="+", type=run_folder, help="results/runs/<id> ...")
    p.add_argument("--out", type=folder("--out"), default="results/comparison/refill")
    p.set_defaults(func=cmd_refill)
    p = sub.add_parser("calibrate-machine", help="fit the penetration and the sleeve's spring on clay's field "
                       "holes (results/calibration/machine.csv, machine_fit.csv)")
    p.add_argument("design", nargs="?", default="configs/studies/machine_clay.toml",
                   help="a study file over disk.penetration and sleeve.stiffness, clay only")
    scene_batch_options(p, "folder of machine.csv and the kept runs (default results/calibration)")
    p.add_argument("--no-run", action="store_true", help="measure and fit the finished or kept runs; run nothing")
    p.add_argument("--adopt", nargs="?", const="literal,surface", metavar="VARIANTS",
                   help="write the fit to configs/machine.toml, where the presets read it, also when --out is another "
                   "folder (by default only the default --out writes there); with VARIANTS (literal, surface or both, "
                   "comma-separated) only those sections, the others kept as they are")
    p.set_defaults(func=cmd_calibrate_machine)
    p = sub.add_parser("compare", help="the main job: run, measure and set the holes beside the field's Table 3")
    p.add_argument("--preset", default="bench_validation_medium",
                   help="run preset of configs/presets.toml (default bench_validation_medium: the bench-calibrated "
                   "soils and the machine calibrated on that clay, 8 holes per soil, r = 6 mm grains; "
                   "bench_validation the same over packings 1-3; validation_medium the cone-fitted soils)")
    p.add_argument("--soils", default="clay,loam,sand", help="the soils to run (default all three); the preset's "
                   "table also keeps every other soil's finished or kept run of the same settings and seeds")
    p.add_argument("--seeds", type=option("--seeds", SEED, many=True),
                   help="packing seeds, one run each, e.g. 1,2,3 (default: the preset's `seeds`, else 1)")
    p.add_argument("--scheduler", type=scheduler_address, help="Dask distributed scheduler address (tcp://host:8786): "
                   "the runs go to its workers, as a study's cases do; default: local")
    scene_batch_options(p, "where comparison.csv/.md and comparison/ go (default results)")
    p.add_argument("--no-run", action="store_true", help="measure the finished runs only; run nothing")
    p.add_argument("--kept", action="store_true", help="a run not on this machine but kept beside the table "
                   "(<out>/comparison/runs/) is not run: it is measured again from its kept grains (state.npz), or "
                   "its kept holes.csv is read if it has none; pool runs made elsewhere")
    p.set_defaults(func=cmd_compare)
    p = sub.add_parser("budget", help="the error budget of a compared preset: each miss against the field split into "
                       "grain size, model, measurement, machine, packing and soil (results/validation/)")
    p.add_argument("--preset", default="bench_validation", help="a preset of results/comparison.csv (default "
                   "bench_validation, the validation: the main job's strips over three packings)")
    p.add_argument("--machine-dir", type=folder("--machine-dir"), default=None,
                   help="the machine calibration whose intervals and design slopes are propagated: its machine_fit.csv "
                   "and machine.csv (default: the folder of the fit configs/machine.toml holds for the preset's "
                   "machine, its `fit`)")
    p.add_argument("--out", type=folder("--out"), default=None,
                   help="where error_budget.csv and .png and the soil part's table go (default results/validation for "
                   "bench_validation, results/validation/<preset>/ for any other)")
    p.set_defaults(func=cmd_budget)
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
    p.add_argument("what", choices=["beds", "runs", "ladder", "economies", "convergence", "grain-size", "presets",
                                    "speed-vs-error",
                                    "peer", "collider", "profile"])
    p.add_argument("--against", default="validation_surface",
                   help="presets: the reference preset (default validation_surface); every preset in "
                   "results/comparison.csv with its calibrated machine is set against it")
    p.add_argument("--strip", nargs="?", const="bench_validation", choices=tuple(grain_size_strips()),
                   help="grain-size: from clay's strip of a validation (default bench_validation; validation: the "
                   "cone-fitted soils') and its `grain_size` presets (configs/presets.toml: r = 6, 5 and 4 mm) in "
                   "results/comparison.csv instead of bench convergence's one hole; written to that validation's "
                   "budget folder")
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
    if rest and args.command not in ("bed", "cone", "shear", "collapse", "simple-shear", "run", "duckbeak"):
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    args.rest = rest
    try:
        return args.func(args)
    except ConfigError as e:
        print(f"config error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
