"""The project's one way into YADE: Debian's yade-double module imported by the system Python 3.11.

Call `boot(threads)` before anything else in a scene process; it sets OpenMP threads (as `yade -j` does),
imports YADE and returns its namespace. Analysis code never imports this module.
"""
import os
import sys

YADE_PY = "/usr/lib/x86_64-linux-gnu/yade-double/py"


def boot(threads: int = 1):
    if os.environ.get("HOLES_FAST_TIER"):
        raise RuntimeError("a test of the fast tier started YADE: mark it @pytest.mark.scene (tests/conftest.py)")
    os.environ["OMP_NUM_THREADS"] = str(threads)
    if YADE_PY not in sys.path:
        sys.path.insert(1, YADE_PY)
    import yade  # noqa: F401  (initialises the C++ core and puts O in builtins)
    return yade
