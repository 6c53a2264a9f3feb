"""Hard cases (issue 7): each scene either stays stable (no NaN, no grain out of the box, kinetic energy
bounded, finite hole metrics and energy balance) or stops with a diagnostic naming the cause. One punch
passage on the test strip, one thread per scene, two scenes at a time."""
import json
import math
from concurrent.futures import ThreadPoolExecutor

import pytest

from analysis import measure
from analysis.config import load_soil
from tests.test_disk import run_scene

CAUSES = ("non-finite", "left the box", "moves at", "kinetic energy")
CLAY = load_soil("clay")


CASES = {                      # run in this order, two at a time: the strips other cases share are settled first
    "speed-5kmh": ("clay", ["--speed", "5"]),                         # the clay strip (cached by the whole suite)
    "loosest-sand": ("sand", ["--set", "friction_deg=60"]),           # the loosest sand bed the builder makes
    "coarsest": ("clay", ["--resolution", "coarse"]),                 # 8 mm grains: three across the punch
    "penetration-90": ("clay", ["--tool", "disk.penetration=90", "--depth", "120"]),
    "slip-0.5": ("clay", ["--slip", "0.5"]),
    "dt-0.9": ("clay", ["--dt-safety", "0.9"]),
    "clay-cohesion-x10": ("clay", ["--set", f"normal_cohesion={10 * CLAY.normal_cohesion:g}",
                                   "--set", f"shear_cohesion={10 * CLAY.shear_cohesion:g}"]),
    "sleeve-spring-x10": ("clay", ["--tool", "sleeve.stiffness=80"]),  # 10 × the sleeve's return spring
}


def scene(scene_dirs, name):
    soil, args = CASES[name]
    return run_scene(None, "--soil", soil, "--holes", "1", "--lead-in", "0", "--threads", "1", *args,
                     dirs=scene_dirs, expect_ok=False)


@pytest.fixture(scope="module")
def hard_runs(scene_dirs):
    """Every case's finished process, two at a time (one thread each), in CASES' order: both workers are busy
    from the start; while the first case settles the clay strip (when no earlier test did), the other worker
    settles the sand, coarse and deeper strips, so the four cases sharing the clay strip normally start after
    it is cached (a race only costs time: beds are written atomically)."""
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {name: pool.submit(scene, scene_dirs, name) for name in CASES}
        done = {name: f.result() for name, f in futures.items()}
    return done


@pytest.mark.parametrize("name", list(CASES))
def test_hard_case_is_stable_or_stops_with_a_named_cause(scene_dirs, hard_runs, name):
    """Stable (summary with finite energy terms, kinetic energy bounded by the guard, and a hole either found
    with finite metrics or reported not found) or stopped by the stability guard with a named cause."""
    r = hard_runs[name]
    if r.returncode == 3:                                  # the stability guard stopped it
        assert "run stopped:" in r.stderr and any(c in r.stderr for c in CAUSES), r.stderr[-2000:]
        return
    assert r.returncode == 0, f"disk.py exited {r.returncode}:\n{r.stderr[-3000:]}"
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["vmax_m_s"] < 20 * summary["tip_speed_m_s"]
    assert all(math.isfinite(v) for v in summary["energy_J"].values())
    holes = measure.run(scene_dirs[0] / summary["id"])
    assert len(holes) == 1
    hole = holes.iloc[0]
    assert math.isfinite(hole.h1), hole.to_dict()
    # a hole found where the punch entered has finite measures; one not found (the named outcome when the
    # strip is churned past recognition, metrology.measure_hole) has none, never plausible numbers
    assert all(math.isfinite(hole[m]) == bool(hole.found) for m in ("L0", "L1", "L2")), hole.to_dict()
