"""Scene: the rolling six-punch disk with spring-loaded press sleeves in a soil strip (seed 001 §1.2, §2, Fig. 2).

    ./holes run --soil clay --preset quick          # ./holes run --help: every option

The run is planned without YADE (analysis/core/run_spec.py: the checked parameters and the run id), then assembled
from the parts in scripts/disk_parts.py (the bed, the tool, the disk's motion and the sleeves, the recorder, the
awake window, the guard, the checkpoint) and run there; its pictures and report come from analysis/holes/run_report.py.
Exit codes: 0 done (or reused), 2 bad input (before any scene starts), 3 stopped by the stability guard or a
bottomed-out disk, with the reason.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.schema import ROOT, ConfigError  # noqa: E402
from analysis.core.run_spec import arguments, plan_args  # noqa: E402


def main(argv=None) -> int:
    a = arguments().parse_args(argv)
    runs = Path(a.out) if a.out else ROOT / "results/runs"
    try:
        params = plan_args(a)
        done = runs / params["id"] / "summary.json"
        if done.exists() and not a.rerun and not a.vtk:
            print(f"run {params['id']}: finished earlier, reused (--rerun to run it again)", file=sys.stderr)
            print(json.dumps(json.loads(done.read_text())))
            return 0
        from scripts.disk_parts import run
        summary = run(params, a.threads, runs, Path(a.bed_dir), a.vtk, checkpoint_every=a.checkpoint_every,
                      resume=not a.rerun)
    except ConfigError as e:
        print(f"run: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"run stopped: {e}", file=sys.stderr)
        return 3
    from analysis.holes import run_report
    run_report.run(runs / summary["id"])
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
