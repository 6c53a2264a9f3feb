"""Scene: a settled, levelled soil bed (the bed part, scripts/beds.py), saved once in results/cache/beds/ and loaded
by every other scene.

    ./holes bed --soil clay --resolution default --size 200,200,150 --seed 1
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.schema import ConfigError  # noqa: E402
from scripts.beds import bed_arguments, bed_from_args, load_meta  # noqa: E402


def main(argv=None) -> int:
    a = bed_arguments(__doc__.splitlines()[0], "200,200,150").parse_args(argv)
    try:
        path = bed_from_args(a)
    except (ConfigError, ValueError) as e:
        print(f"bed: {e}", file=sys.stderr)
        return 2
    print(json.dumps(load_meta(path)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
