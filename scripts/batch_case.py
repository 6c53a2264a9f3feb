"""yade-batch adapter: `yade-batch results/studies/NAME.table scripts/batch_case.py` runs each line of a table
written by `./holes study FILE --export-batch TABLE` as the same disk scene `./holes study` would run.

yade-batch starts this file under the yade launcher with YADE_BATCH=TABLE:LINE. It restarts itself on the
project's interpreter (the venv on /usr/bin/python3) and hands the line's fields to scripts/disk.py, so every
case runs the one way the project runs scenes.
"""
import os
import sys
from pathlib import Path

ROOT = Path(sys.argv[0]).resolve().parent.parent      # under the yade launcher __file__ is the launcher
PYTHON = ROOT / ".venv/bin/python"
if Path(sys.executable) != PYTHON and PYTHON.exists() and not os.environ.get("HOLES_BATCH_CASE"):
    os.environ["HOLES_BATCH_CASE"] = "1"
    os.execv(str(PYTHON), [str(PYTHON), str(ROOT / "scripts/batch_case.py")])
sys.path.insert(0, str(ROOT))

from analysis.core.runner import scene_args  # noqa: E402
from analysis.batch.study import case_from_table_line  # noqa: E402

table, line = os.environ["YADE_BATCH"].rsplit(":", 1)
description, case = case_from_table_line(table, int(line))
args = [sys.executable, str(ROOT / "scripts/disk.py"), *scene_args(case),
        "--threads", os.environ.get("OMP_NUM_THREADS", "1")]
print(f"batch_case: {description}: {' '.join(args[1:])}", flush=True)
os.chdir(ROOT)
os.execv(args[0], args)
