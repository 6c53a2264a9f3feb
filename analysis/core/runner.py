"""Running many disk scenes: each case is its own YADE process (scripts/disk.py) in runs/<id>/, named by a hash
of its parameters. A finished case (summary.json present) is never run again; a failed one raises with the
tail of its log and the others go on. Local worker threads by default; a Dask distributed scheduler when
one is given (its workers need this project at the same path and a shared runs folder).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

from analysis.core.schema import ROOT, ConfigError
from analysis.core.io import say

# A case's fields, named as in the seed and the configs, and the scripts/disk.py options that set them.
PLAIN = {"soil": "--soil", "preset": "--preset", "seed": "--seed", "slip": "--slip", "speed_kmh": "--speed-kmh",
         "holes": "--holes", "lead_in": "--lead-in", "width": "--width", "depth": "--depth", "mode": "--mode",
         "resolution": "--resolution", "dt_safety": "--dt-safety", "awake": "--awake",
         "weight": "--weight", "depth_stop": "--depth-stop", "disk_inertia": "--disk-inertia",
         "density_scale": "--density-scale", "tilled": "--tilled"}
PREFIXED = {"disk": "--tool", "sleeve": "--tool", "soil": "--set"}


def scene_args(fields: dict) -> list[str]:
    """The scripts/disk.py arguments that run a case with these fields (soil, slip, disk.D, soil.young, ...)."""
    args = []
    for key, value in fields.items():
        part, dot, field = key.partition(".")
        if not dot and key in PLAIN:
            args += [PLAIN[key], ",".join(map(str, value)) if isinstance(value, (list, tuple)) else str(value)]
        elif dot and part in PREFIXED:
            args += [PREFIXED[part], f"{key if part != 'soil' else field}={value}"]
        else:
            raise ConfigError(f"run field {key!r}: allowed {', '.join(PLAIN)}, disk.<field>, sleeve.<field>, "
                              "soil.<field>")
    return args


def plan_case(fields: dict) -> dict:
    """Check a case completely, as scripts/disk.py would (no YADE), and return its run parameters."""
    from analysis.core.run_spec import plan_from_argv
    return plan_from_argv(scene_args(fields))


def finished(runs_dir: Path, case_id: str) -> bool:
    return (Path(runs_dir) / case_id / "summary.json").exists()


def run_process(cmd: list[str], on_line) -> tuple[int, str]:
    """Run a scene process from the project root, handing each line of its stderr (progress) to `on_line`
    as it comes; returns its exit code and its stdout (the scene's summary line)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)

    def pump():
        for line in proc.stderr:
            on_line(line)
    t = threading.Thread(target=pump)
    t.start()
    out = proc.stdout.read()
    proc.wait()
    t.join()
    return proc.returncode, out


def run_logged(cmd: list[str], log_path: Path, on_line=None) -> tuple[int, str]:
    """`run_process` with each line of the scene's stderr written to `log_path` as it comes (line-buffered, so its
    progress can be read while it runs), then handed to `on_line` if given."""
    with open(log_path, "w", buffering=1) as log:

        def each(line):
            log.write(line)
            if on_line:
                on_line(line)
        return run_process(cmd, each)


def run_case(args: list[str], case_id: str, tag: str, threads: int, runs_dir, bed_dir, echo: bool = True) -> dict:
    """Run one scene (`scripts/disk.py ARGS`) or reuse it; its log goes to runs/<id>.log and its progress
    lines are echoed with `tag` (every 20 s at most). Returns the run's summary; RuntimeError if it failed."""
    runs_dir, bed_dir = Path(runs_dir), Path(bed_dir)
    log_path = runs_dir / f"{case_id}.log"
    runs_dir.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, str(ROOT / "scripts/disk.py"), *args, "--threads", str(threads), "--out", str(runs_dir),
           "--bed-dir", str(bed_dir)]
    last = [time.time()]

    def on_line(line):
        if echo and (time.time() - last[0] > 20 or not line.startswith(("run:", "bed:"))):
            last[0] = time.time()
            say(f"{tag} {line.rstrip()}")
    returncode, out = run_logged(cmd, log_path, on_line)
    if returncode != 0:
        tail = "".join(log_path.read_text().splitlines(keepends=True)[-15:])
        raise RuntimeError(f"{tag} scripts/disk.py exited {returncode}; log {log_path}:\n{tail}")
    return json.loads(out.strip().splitlines()[-1])


def share_cores(n_cases: int, asleep: bool, workers: int | None = None, threads: int | None = None,
                cores: int | None = None) -> tuple[int, int]:
    """Cases at a time and YADE threads each, where the command line leaves them open. Two scenes side by side
    on one thread each run 11 % more holes than one at a time on two threads with the whole strip awake, and
    30 % more with the far field asleep (whose contact loop loses its balance on two threads;
    results/bench/README.md). So: side by side on one thread each when the cases fill the cores evenly, or
    when their far field sleeps; otherwise (one case; three all-awake strips on two cores, whose third would
    run alone on one) one at a time on every core. Sleeping strips, one thread each, run as many at a time as
    finishes the batch soonest, up to two per core: the waves times each wave's share of a core,
    ceil(n / w) · max(1, w / cores), least (the fewer workers on a tie); so three strips on two cores run at
    once (1.5 against 2 for two and then one).

    >>> share_cores(3, False, cores=2), share_cores(3, True, cores=2), share_cores(4, False, cores=2)
    ((1, 2), (3, 1), (2, 1))
    >>> share_cores(1, True, cores=2), share_cores(4, False, workers=1, cores=2), share_cores(4, False, threads=1, cores=2)
    ((1, 2), (1, 2), (2, 1))
    >>> share_cores(2, True, cores=2), share_cores(4, True, cores=2), share_cores(5, True, cores=2)
    ((2, 1), (2, 1), (2, 1))
    """
    cores = cores or os.cpu_count() or 1
    if workers and threads:
        return workers, threads
    if workers:
        return workers, max(1, cores // workers)
    if threads:
        return max(1, cores // threads), threads
    if n_cases >= 2 and asleep:
        w = min(range(1, min(n_cases, 2 * cores) + 1), key=lambda w: (math.ceil(n_cases / w) * max(1, w / cores), w))
        return w, 1
    if n_cases >= 2 and n_cases % cores == 0:
        w = min(n_cases, cores)
        return w, max(1, cores // w)
    return 1, cores


def run_all(cases: list[dict], workers: int | None, threads: int | None, runs_dir, bed_dir, on_done=None,
            scheduler: str | None = None, label: str = "batch") -> list[str]:
    """Run every case that has not finished. A case is {"id", "tag", "args"} and, if its far field sleeps,
    "asleep": True. `workers` and `threads` left None are shared out by `share_cores`. `on_done(case,
    summary)` is called in this process as each finishes. Progress: finished / running / failed counts with an
    ETA. Returns the failure messages."""
    todo = [c for c in cases if not finished(runs_dir, c["id"])]
    workers, threads = share_cores(len(todo), any(c.get("asleep") for c in todo), workers, threads)
    n_done0 = len(cases) - len(todo)
    say(f"{label}: {len(cases)} cases, {n_done0} finished earlier, {len(todo)} to run "
        f"({'scheduler ' + scheduler if scheduler else f'{workers} local workers'}, {threads} threads each)")
    failures, durations = [], []
    wall0 = time.time()

    def progress(case, ok: bool):
        done = n_done0 + len(durations)
        left = len(todo) - len(durations) - len(failures)
        running = min(left, workers) if not scheduler else left
        eta = (sum(durations) / len(durations)) * left / max(1, workers) if durations else float("nan")
        say(f"{label}: {case['id']} {'finished' if ok else 'FAILED'}; {done}/{len(cases)} finished, "
            f"{running} running, {len(failures)} failed, {time.time() - wall0:.0f} s so far, ETA {eta:.0f} s")

    def collect(case, result):
        try:
            summary = result()
        except Exception as e:                      # a failing case is reported; the others go on
            failures.append(str(e))
            progress(case, False)
            say(str(e))
            return
        durations.append(summary["wall_s"])
        progress(case, True)
        if on_done:
            try:
                on_done(case, summary)
            except Exception as e:                  # the case's run folder is complete; only its report failed
                failures.append(f"{case['tag']} finished, but its report failed: {e!r}")
                say(failures[-1])

    if scheduler:
        from distributed import Client, as_completed as dask_completed
        with Client(scheduler) as client:
            futures = {client.submit(run_case, c["args"], c["id"], c["tag"], threads, str(runs_dir), str(bed_dir),
                                     False, key=f"case-{c['id']}", pure=False): c for c in todo}
            for fut in dask_completed(futures):
                collect(futures[fut], fut.result)
    else:
        with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
            futures = {pool.submit(run_case, c["args"], c["id"], c["tag"], threads, runs_dir, bed_dir): c
                       for c in todo}
            for fut in as_completed(futures):
                collect(futures[fut], fut.result)
    return failures
