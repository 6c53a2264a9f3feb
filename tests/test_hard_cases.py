"""Hard cases: each scene has a pinned outcome. All eight finish stable on the machines measured (results/bench/
README.md's table, and a fresh machine's suite run): every energy term finite, the energy residual under
RESIDUAL_BOUND, and the hole found with finite L0, L1, L2 (slip 0.5 excepted: its punch drags a trench across
the strip, found on one machine and not on another, so only its consistency is checked). A case that the
stability guard stops instead fails here with the guard's named cause in the message. One punch passage on the
test strip, one thread per scene, in the background beside the suite's other scenes (tests/conftest.py)."""
import json
import math

import pytest

from analysis.holes import measure
from analysis.holes.compare import RESIDUAL_LIMIT
from analysis.core.soil_config import load_soil
from tests.test_disk import run_scene

CLAY = load_soil("clay")
# % of the tools' work: the largest measured is clay bonds × 10 (3.9 % and 3.95 % on two machines; bond energy
# lost at breakage grows with the bonds); the others 2.2 % or less. The comparison's flag is at the same 5 %.
RESIDUAL_BOUND = RESIDUAL_LIMIT
HOLE_FOUND = {"slip-0.5": None}        # None: not pinned (see the module's docstring); every other case: found


CASES = {                      # run in this order, two at a time: the strips other cases share are settled first
    "speed-5kmh": ("clay", ["--speed-kmh", "5"]),                         # the clay strip (cached by the whole suite)
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
def hard_runs(side_scenes):
    """Every case's finished process: conftest's side_scenes runs them in the background, one thread each, two
    at a time, in CASES' order after test_disk's and test_duckbeak's scenes, from the suite's first long scene
    on (a case needing a bed another is settling waits for it: the bed's lock, scripts/beds.py)."""
    return {name: side_scenes[f"hard:{name}"].result() for name in CASES}


@pytest.mark.scene
@pytest.mark.parametrize("name", list(CASES))
def test_hard_case_finishes_stable_with_its_hole(scene_dirs, hard_runs, name):
    r = hard_runs[name]
    assert r.returncode == 0, f"disk.py exited {r.returncode} (3: the stability guard stopped it):\n{r.stderr[-3000:]}"
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    energy = summary["energy_J"]
    assert all(math.isfinite(v) for v in energy.values()), energy
    assert energy["work_tool"] > 1.0 and 100 * abs(energy["residual_fraction"]) < RESIDUAL_BOUND, energy
    holes = measure.run(scene_dirs[0] / summary["id"], pictures=False)
    assert len(holes) == 1
    hole = holes.iloc[0]
    assert math.isfinite(hole.h1), hole.to_dict()
    # a hole found where the punch entered has finite measures; one not found has none, never plausible numbers
    assert all(math.isfinite(hole[m]) == bool(hole.found) for m in ("L0", "L1", "L2")), hole.to_dict()
    expected = HOLE_FOUND.get(name, True)
    if expected is not None:
        assert bool(hole.found) == expected, hole.to_dict()
