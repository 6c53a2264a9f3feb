import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from analysis.core.config import load_disk  # noqa: E402


@pytest.fixture(scope="session")
def disk():
    """The seed 001 disk (R0 = 70, L3 = 121, N = 6, D = 50, h = 20, penetration 70 mm)."""
    return load_disk(ROOT / "configs/disk.toml")


@pytest.fixture(scope="session")
def other_disk():
    """A different disk (N = 5, D = 40, R0 = 60, L3 = 100) so no test leans on the seed's numbers."""
    return load_disk(ROOT / "configs/disks/n5_d40.toml")


@pytest.fixture(scope="session")
def scene_dirs(tmp_path_factory):
    """Runs and beds folders shared by the scene tests: a run with the same parameters is made once and
    reused (scripts/disk.py skips a run whose folder has a summary)."""
    root = tmp_path_factory.mktemp("scenes")
    return root / "runs", root / "beds"


@pytest.fixture(scope="session")
def side_scenes(scene_dirs):
    """test_disk's one-thread scenes (SIDE_SCENES) and then test_duckbeak's, two at a time on background
    threads from the first test that asks: test_compare asks, and its one-thread clay scene shares the cores with
    them; once it has finished, the tests after it wait on these, so both cores stay busy (one at a time, the
    suite left a core idle for four minutes). Name -> future of the finished process (a failed scene is the asking
    test's failure, not this fixture's)."""
    from tests.test_disk import SIDE_SCENES, run_scene
    from tests.test_duckbeak import run_duckbeak
    pool = ThreadPoolExecutor(max_workers=2)
    futures = {name: pool.submit(run_scene, None, *args, dirs=scene_dirs, expect_ok=ok)
               for name, (args, ok) in SIDE_SCENES.items()}
    futures["duckbeak"] = pool.submit(run_duckbeak, scene_dirs)
    yield futures
    pool.shutdown(cancel_futures=True)
