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


EARLY = {}      # the side scenes, started as soon as the collected suite is known to want them


def start_side_scenes(dirs):
    """test_disk's one-thread scenes (SIDE_SCENES) and then test_duckbeak's, two at a time on background threads.
    Name -> future of the finished process (a failed scene is the asking test's failure, not the pool's)."""
    from tests.test_disk import SIDE_SCENES, run_scene
    from tests.test_duckbeak import run_duckbeak
    pool = ThreadPoolExecutor(max_workers=2)
    futures = {name: pool.submit(run_scene, None, *args, dirs=dirs, expect_ok=ok)
               for name, (args, ok) in SIDE_SCENES.items()}
    futures["duckbeak"] = pool.submit(run_duckbeak, dirs)
    return pool, futures


def pytest_collection_finish(session):
    """When a collected test wants the side scenes, start them before the first test runs: they share the cores
    with the tests that start no scene (one process) and then with test_compare's one-thread clay scene, so both
    cores stay busy from the start (started by test_compare, they had left a core idle through the fast tests)."""
    if session.config.option.collectonly:
        return
    if any("side_scenes" in getattr(item, "fixturenames", ()) for item in session.items):
        root = session.config._tmp_path_factory.mktemp("scenes")
        EARLY["dirs"] = (root / "runs", root / "beds")
        EARLY["pool"], EARLY["futures"] = start_side_scenes(EARLY["dirs"])


def pytest_sessionfinish(session):
    if "pool" in EARLY:
        EARLY["pool"].shutdown(cancel_futures=True)


@pytest.fixture(scope="session")
def scene_dirs(tmp_path_factory):
    """Runs and beds folders shared by the scene tests: a run with the same parameters is made once and
    reused (scripts/disk.py skips a run whose folder has a summary)."""
    if "dirs" in EARLY:
        return EARLY["dirs"]
    root = tmp_path_factory.mktemp("scenes")
    return root / "runs", root / "beds"


@pytest.fixture(scope="session")
def side_scenes(scene_dirs):
    """The side scenes' futures (start_side_scenes), started at collection when the suite wants them, else now."""
    if "futures" in EARLY:
        yield EARLY["futures"]
        return
    pool, futures = start_side_scenes(scene_dirs)
    yield futures
    pool.shutdown(cancel_futures=True)
