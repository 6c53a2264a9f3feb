"""Benchmark: the contact detection's settings on a whole strip, from a run's checkpoint.

    .venv/bin/python scripts/collider_bench.py results/runs/<id> [--steps 3000] [--threads 2]
    # or: ./holes bench collider --run results/runs/<id>

YADE's InsertionSortCollider re-sorts the bounding boxes whenever a grain may have moved past its box's margin
(`verletDist`, by default half the smallest radius). With `targetInterv = 100` (YADE's default) a grain at
rest gets a margin of only 1/10 of that, so the first grains a punch stirs set the detection off again; with
`targetInterv = 0` every grain keeps the whole margin. Each setting below runs the same `steps` from the run's
checkpoint (punches in the soil), in a scratch copy (the run is left as it was), and the first setting runs
twice, to show whether the same setting repeats itself (on the default strip it did, bit for bit), so that
the other settings' drift is theirs: a different contact order changes the round-off, which granular flow
amplifies. Writes results/bench/collider.csv: per setting the wall time of the steps, particle-steps/s, detection
runs, interactions and real contacts at the end, the grains' drift from the first realisation (RMS and
largest, mm), and the share of the wall time each part of the scene took (YADE's `O.timingEnabled`: the
collider, the contact loop, Newton's integration with the force reset, the disk's Python hook, the tools'
kinematic engines; the rest is the stability guard and YADE's loop). With `--profile` only the adopted setting
runs, once: where a run's time goes (`./holes bench profile`, results/bench/profile.csv, one row per run, starting
step and sleepers' treatment). With `--from-start` the segment is the run's first `steps` from its committed bed
(only config.json is needed: a kept run of results/comparison/runs/ will do), the lead-in with it.
"""
from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import option, CommandLine  # noqa: E402
from analysis.core.config import COLLIDER_STEPS, THREADS
from analysis.core.schema import ROOT
from analysis.core.bed_spec import BED_DIR  # noqa: E402
from analysis.core.io import atomic_csv, machine, read_table, stamp  # noqa: E402

SETTINGS = [                # (name, InsertionSortCollider attributes); the first, YADE's default, runs twice
    ("YADE default: verletDist 0.5 r, targetInterv 100", {"verletDist": -0.5, "targetInterv": 100}),
    ("the same again", {"verletDist": -0.5, "targetInterv": 100}),
    ("verletDist 0.5 r, targetInterv 0", {"verletDist": -0.5, "targetInterv": 0}),
    ("verletDist 0.5 mm, targetInterv 0", {"verletDist": 5e-4, "targetInterv": 0}),   # disk.COLLIDER
    ("verletDist 1 mm, targetInterv 0", {"verletDist": 1e-3, "targetInterv": 0}),
]
ADOPTED = 3                 # SETTINGS' index of disk_parts.COLLIDER, the scenes' own setting

PARTS = {"collider": "collider", "InteractionLoop": "contacts", "newton": "integration", "hook": "hook",
         "ForceResetter": "integration"}     # the scene's engines (YADE's timing) by part; the rest move the tools


def main(argv=None) -> int:
    import numpy as np
    import pandas as pd
    from scripts import disk_parts as disk
    p = CommandLine(prog="holes bench collider", description=__doc__.splitlines()[0])
    p.add_argument("run", help="a run folder with a checkpoint (results/runs/<id>)")
    p.add_argument("--steps", type=option("--steps", COLLIDER_STEPS), default=3000,
                   help="steps per setting, [200, 100000] (default 3000)")
    p.add_argument("--threads", type=option("--threads", THREADS), default=2, help="YADE threads (default 2)")
    p.add_argument("--out", default=None, help="table (default results/bench/collider.csv; --profile: profile.csv, "
                   "its rows of other runs kept)")
    p.add_argument("--profile", action="store_true", help="the adopted setting only, once: where the run's time goes")
    p.add_argument("--from-start", action="store_true", help="the run's first steps from its bed, not its checkpoint")
    p.add_argument("--bed-dir", default=str(BED_DIR), help="--from-start: the beds (default results/cache/beds)")
    a = p.parse_args(argv)
    a.out = a.out or str(ROOT / "results/bench" / ("profile.csv" if a.profile else "collider.csv"))
    settings = [SETTINGS[ADOPTED]] if a.profile else SETTINGS
    run = Path(a.run)
    needs = ("config.json",) if a.from_start else (disk.CHECKPOINT, "config.json")
    if not all((run / f).exists() for f in needs):
        print(f"bench collider: {run} has no {' and '.join(needs)}: give a run stopped while running"
              + (" or any run's folder" if a.from_start else ""), file=sys.stderr)
        return 2
    params = json.loads((run / "config.json").read_text())
    ck = None if a.from_start else json.loads((run / disk.CHECKPOINT).read_text())
    start, copies = (0, ()) if ck is None else (ck["iter"], (disk.CHECKPOINT, ck["scene"]))
    rows, ref = [], None
    with tempfile.TemporaryDirectory(prefix="collider-bench-") as scratch:
        for k, (name, attrs) in enumerate(settings):
            folder = Path(scratch) / str(k) / params["id"]
            folder.mkdir(parents=True)
            for f in copies:
                shutil.copy(run / f, folder / f)
            print(f"bench collider: {name}, {a.steps} steps from step {start}", file=sys.stderr, flush=True)
            seg = disk.run(params, a.threads, folder.parent, bed_dir=Path(a.bed_dir), checkpoint_every=0, quiet=True,
                                stop_at=start + a.steps, collider=attrs)
            pos, engine_s = seg.pop("pos"), seg.pop("engine_s")
            share = {part: sum(t for name, t in engine_s.items() if PARTS.get(name, "kinematics") == part) / seg["wall_s"]
                     for part in ("collider", "contacts", "integration", "hook", "kinematics")}
            ref = pos if ref is None else ref
            drift = 1e3 * np.linalg.norm(pos - ref, axis=1)
            rows.append({"run": params["id"], "preset": params["preset"]["name"], "setting": name,
                         **{f"collider_{key}": v for key, v in attrs.items()},
                         "from_step": start, "steps": seg["steps"], "particles": seg["particles"],
                         "wall_s": round(seg["wall_s"], 1),
                         "particle_steps_per_s": round(seg["particles"] * seg["steps"] / seg["wall_s"]),
                         "detections": seg["detections"], "interactions": seg["interactions"],
                         "contacts": seg["contacts"], "awake": seg["awake"],
                         "drift_rms_mm": round(float(np.sqrt(np.mean(drift ** 2))), 4),
                         "drift_max_mm": round(float(drift.max()), 3),
                         **{f"share_{part}": round(v, 3) for part, v in share.items()},
                         "sleepers": "skipped" if disk.SKIP_SLEEPERS else "visited",
                         "threads": a.threads, "machine": machine()})
            print(pd.DataFrame(rows[-1:]).to_string(index=False), file=sys.stderr, flush=True)
    table = pd.DataFrame(rows)
    key = ["run", "from_step", "sleepers"]
    if a.profile and Path(a.out).exists():       # one row per run, start and sleepers profiled: the others stay
        earlier = read_table(a.out)
        again = earlier[key].apply(tuple, axis=1).isin(table[key].apply(tuple, axis=1))
        table = pd.concat([earlier[~again], table], ignore_index=True)
    what = "profile" if a.profile else "collider"
    atomic_csv(table, Path(a.out), stamp(f"./holes bench {what} --run {a.run} --steps {a.steps}"
                                         + (" --from-start" if a.from_start else "")) +
               f"; run {params['id']}" + ("; the other rows kept from before" if a.profile else ""))
    print(table.to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
