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


def pytest_collection_modifyitems(items):
    """The modules whose tests read the side scenes run last, each whole and otherwise in its place: the one-thread
    scenes of the modules after test_compare (test_soil_bench's, test_study's) run beside the side scenes rather
    than alone after them, a core idle."""
    last = {item.path.stem for item in items if "side_scenes" in getattr(item, "fixturenames", ())} - {"test_compare"}
    items.sort(key=lambda item: item.path.stem in last)       # test_compare asks for them only to start them


@pytest.fixture(scope="session")
def side_scenes(request, scene_dirs):
    """The one-thread scenes that tests only read, two at a time on background threads from the first test that
    asks: test_disk's (SIDE_SCENES), test_duckbeak's and the hard cases' (test_hard_cases.CASES, named
    "hard:<case>"), each only when a test of its module is collected. test_compare asks first, and its one-thread
    clay scene shares the cores with them; the tests after it that run one scene at a time leave a core to these,
    and the tests that read them run last and wait on them. Name ->
    future of the finished process (a failed scene is the asking test's failure, not this fixture's)."""
    from tests.test_disk import SIDE_SCENES, run_scene
    collected = {Path(item.nodeid.split("::")[0]).stem for item in request.session.items}   # doctests have no .module
    pool = ThreadPoolExecutor(max_workers=2)
    futures = {}
    if "test_disk" in collected:
        futures.update({name: pool.submit(run_scene, None, *args, dirs=scene_dirs, expect_ok=ok)
                        for name, (args, ok) in SIDE_SCENES.items()})
    if "test_duckbeak" in collected:
        from tests.test_duckbeak import run_duckbeak
        futures["duckbeak"] = pool.submit(run_duckbeak, scene_dirs)
    if "test_hard_cases" in collected:
        from tests.test_hard_cases import CASES, scene
        futures.update({f"hard:{name}": pool.submit(scene, scene_dirs, name) for name in CASES})
    yield futures
    pool.shutdown(cancel_futures=True)
