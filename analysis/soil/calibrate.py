"""The `calibrate` subcommand: adjust one soil parameter until the virtual cone index is within 5 % of
seed 001 Table 2. Each evaluation is one cone scene (its own YADE process); every iteration is appended to
results/calibration/<soil>.csv; the result is written back into configs/soils/<soil>.toml. Table 3 is never
read here.
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pandas as pd

from analysis.core.io import say
from analysis.core.runner import run_process
from analysis.core.schema import ROOT, ConfigError
from analysis.core.soil_config import load_soil
from analysis.core.io import atomic_csv, atomic_write, read_table, stamp
from analysis.core.bed_spec import CONE_DIR

TOLERANCE = 0.05
COHESION_KEYS = ("normal_cohesion", "shear_cohesion")   # calibrated together, kept equal
SAME_COHESION = 1e-3           # relative: a stored cone run at this bond strength is the same run (configs keep 4 digits)


def bracket_search(f, target: float, lo: float, hi: float, tol: float = TOLERANCE, max_iter: int = 12, log=print):
    """Find x in [lo, hi] with |f(x)/target - 1| <= tol for f increasing in x, by regula falsi with the
    Illinois modification (the end kept twice has its value halved). Returns (x, f(x), history). Raises
    ValueError, naming the value reached, when the target lies outside [f(lo), f(hi)].

    >>> round(bracket_search(lambda x: 2 * x + 1, 11.0, 0.0, 10.0, log=lambda *a: None)[0], 3)
    5.0
    """
    history = []

    def g(x):
        y = f(x)
        history.append((x, y))
        log(f"calibrate: x = {x:.4g} -> {y:.4g} (target {target:.4g})")
        return y

    for x in (lo, hi):
        y = g(x)
        if abs(y / target - 1) <= tol:
            return x, y, history
    (_, y_lo), (_, y_hi) = history
    if y_lo > target:
        raise ValueError(f"already {y_lo:.4g} at the lower bound {lo:.4g}, above the target {target:.4g}")
    if y_hi < target:
        raise ValueError(f"only {y_hi:.4g} at the upper bound {hi:.4g}, below the target {target:.4g}")
    g_lo, g_hi, side = y_lo - target, y_hi - target, 0
    for _ in range(max_iter):
        x = hi - g_hi * (hi - lo) / (g_hi - g_lo)
        y = g(x)
        if abs(y / target - 1) <= tol:
            return x, y, history
        if y < target:
            lo, g_lo = x, y - target
            g_hi = g_hi / 2 if side == -1 else g_hi
            side = -1
        else:
            hi, g_hi = x, y - target
            g_lo = g_lo / 2 if side == 1 else g_lo
            side = 1
    closest = min(history, key=lambda h: abs(h[1] - target))
    raise ValueError(f"no value within {tol:.0%} after {max_iter} steps; closest x = {closest[0]:.4g} -> {closest[1]:.4g}")


def cone_result_name(bed: str, cone_scale: float, speed: float, cohesion: float) -> str:
    """File stem of one cone run's results in results/cache/cone/ (written by scripts/cone.py)."""
    return f"{bed}-c{cone_scale:g}-v{speed:g}-coh{cohesion:g}"


def cone_tested(overrides: dict, normal: float, shear: float) -> dict:
    """The tested contact parameters that name a cone run apart from the configured soil's (scripts/cone.py): all
    but the bond its name already carries (coh<normal>), and the shear bond too where it equals the normal one.

    >>> cone_tested({"normal_cohesion": 1e5, "shear_cohesion": 1e5, "friction_deg": 20.0}, 1e5, 1e5)
    {'friction_deg': 20.0}
    >>> cone_tested({"normal_cohesion": 4e5, "shear_cohesion": 1e5}, 4e5, 1e5)
    {'shear_cohesion': 100000.0}
    """
    return {k: v for k, v in overrides.items() if k != "normal_cohesion" and not (k == "shear_cohesion" and shear == normal)}


def cone_run(bed: str, match) -> tuple[Path, dict] | None:
    """The first finished cone run on `bed` in results/cache/cone/ whose summary satisfies `match`: (its summary's
    path, the summary), or None."""
    for path in sorted(CONE_DIR.glob(f"{bed}-*.json")):
        s = json.loads(path.read_text())
        if match(s):
            return path, s
    return None


def same_cohesion(s: dict, cohesion_pa: float) -> bool:
    """A stored cone run's bond strength is the asked one within SAME_COHESION."""
    return abs(s["cohesion_pa"] - cohesion_pa) <= SAME_COHESION * max(abs(cohesion_pa), 1.0)   # 1 Pa about 0


def stored_cone(bed: str, cone_scale: float, speed: float, cohesion: float) -> tuple[Path, dict] | None:
    """The finished cone run in results/cache/cone/ of this bed, cone, speed and bond strength (within
    SAME_COHESION), or None: the one lookup the calibration and the cone checks reuse runs by."""
    return cone_run(bed, lambda s: (s["cone_scale"], s["speed"]) == (cone_scale, speed) and same_cohesion(s, cohesion))


def cone_index(soil: str, resolution: str, size: str, cone_scale: float, cohesion: float, seed: int = 1,
               speed: float = 0.5, threads: int = 2, lateral: str = "periodic", tag: str = "", tiles: int = 1) -> dict:
    """One cone scene in its own YADE process; its progress lines are echoed (prefixed with `tag`) as it runs.
    Returns its summary; a run of the same bed, cone, speed and bond strength already in results/cache/cone/
    (`stored_cone`) is reused."""
    from analysis.core.config import load_resolution
    from analysis.core.bed_spec import bed_key, check_size
    bed = bed_key(load_soil(soil), load_resolution(resolution), check_size([float(v) / 1000 for v in size.split(",")]),
                  seed, lateral, tiles)
    if found := stored_cone(bed, cone_scale, speed, cohesion):
        say(f"{tag}{' ' if tag else ''}reused {found[0].name}")
        return {**found[1], "reused": True}
    cmd = [sys.executable, str(ROOT / "scripts/cone.py"), "--soil", soil, "--resolution", resolution, "--size", size,
           "--cone-scale", str(cone_scale), "--cohesion", str(cohesion), "--seed", str(seed), "--cone-speed", str(speed),
           "--threads", str(threads), "--lateral", lateral, "--tiles", str(tiles)]
    tail = []

    def on_line(line):
        tail[:] = (tail + [line])[-30:]
        say(f"{tag}{' ' if tag else ''}{line.rstrip()}")
    returncode, out = run_process(cmd, on_line)
    if returncode != 0:
        raise RuntimeError(f"cone scene failed for {soil} at cohesion {cohesion:g} Pa:\n{''.join(tail)[-2000:]}")
    return json.loads(out.strip().splitlines()[-1])


def write_back(soil: str, keys, value: float):
    """Set `keys` = value in configs/soils/<soil>.toml, keeping its comments, then re-validate the file."""
    path = ROOT / "configs/soils" / f"{soil}.toml"
    text = path.read_text()
    for key in keys:
        text, n = re.subn(rf"^{key} = [^#\n]*?(\s*#.*)?$", lambda m: f"{key} = {value:.4g}{m.group(1) or ''}", text,
                          count=1, flags=re.M)
        if n != 1:
            raise ConfigError(f"{path}: no line `{key} = ...` to update")
    atomic_write(path, text)
    load_soil(soil)


def run(soil: str, resolution: str, size: str, cone_scale: float, lo: float, hi: float, seeds=(1,),
        speed: float = 0.5, threads: int = 1, lateral: str = "periodic", workers: int = 2) -> float:
    """Fit the bond strength so that the cone index, averaged over the packing `seeds` (one bed and cone scene
    each, `workers` at a time), is within TOLERANCE of Table 2. Every seed's run is a row of
    results/calibration/<soil>.csv, with its iteration's mean and that mean's error."""
    from concurrent.futures import ThreadPoolExecutor
    soil_cfg = load_soil(soil)
    target = soil_cfg.cone_index
    out = ROOT / "results/calibration" / f"{soil}.csv"
    done = read_table(out) if out.exists() else pd.DataFrame()
    rows = [done] if len(done) else []
    note = stamp(f"./holes calibrate --soil {soil} --resolution {resolution} --size {size} --cone-scale {cone_scale:g} "
                 f"--cone-speed {speed:g} --seeds {','.join(map(str, seeds))} --lateral {lateral}")
    iteration = int(done.iteration.max()) if len(done) else 0

    def f(cohesion):
        nonlocal iteration
        with ThreadPoolExecutor(max(1, workers)) as pool:
            runs = list(pool.map(lambda seed: cone_index(soil, resolution, size, cone_scale, cohesion, seed, speed,
                                                         threads, lateral, tag=f"[{soil} seed {seed}]"), seeds))
        mean = sum(s["cone_index_pa"] for s in runs) / len(runs)
        iteration += 1
        rows.append(pd.DataFrame([{"iteration": iteration, "normal_cohesion_pa": cohesion, "seed": seed,
                                   "cone_index_kpa": s["cone_index_pa"] / 1000, "mean_kpa": mean / 1000,
                                   "target_kpa": target / 1000, "error": mean / target - 1, "bed": s["bed"],
                                   "lateral": lateral, "particles": s["particles"], "cone_scale": cone_scale,
                                   "cone_to_particle": round(s["cone_to_particle"], 2), "speed_m_s": speed,
                                   "friction_deg": soil_cfg.friction_deg, "rolling_friction": soil_cfg.rolling_friction,
                                   "wall_s": round(s["wall_s"], 1), "threads": threads,
                                   "reused": s.get("reused", False)}
                                  for seed, s in zip(seeds, runs)]))
        atomic_csv(pd.concat(rows, ignore_index=True), out, note)          # every iteration, as it finishes
        return mean

    x, y, _ = bracket_search(f, target, lo, hi, log=lambda m: print(m, file=sys.stderr, flush=True))
    write_back(soil, COHESION_KEYS, x)
    print(f"calibrate {soil}: normal_cohesion = shear_cohesion = {x:.4g} Pa gives {y / 1000:.1f} kPa over seeds "
          f"{', '.join(map(str, seeds))} (target {target / 1000:.0f} kPa, {100 * (y / target - 1):+.1f} %)")
    return x
