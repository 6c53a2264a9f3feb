"""The one command-line entry: `./holes SUBCOMMAND ...` (see README)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from analysis.config import ROOT, ConfigError, load_disk


def cmd_theory(args) -> int:
    from analysis import theory_report
    disk = load_disk(args.disk)
    out = Path(args.out) if args.out else ROOT / "results/theory" / ("" if disk.name == "disk" else disk.name)
    command = "./holes theory" + ("" if args.disk == "configs/disk.toml" else f" --disk {args.disk}")
    res = theory_report.run(disk, out, command)
    t = res["table"]
    for slip in sorted(t.slip.unique()):
        r = t[t.slip == slip].set_index("quantity")
        print(f"slip {slip:4.2f}: envelope L0 {r.loc['L0', 'envelope_mm']:6.1f} mm, L1 {r.loc['L1', 'envelope_mm']:5.1f} mm"
              + (f"; Table 1 L0 {r.loc['L0', 'paper_mm']:.1f} mm" if r.paper_mm.notna().any() else ""))
    if len(res["readings"]):
        print(f"best reading of eqs (4)/(5) against Table 1: {res['best']} "
              f"(rms {res['readings'].rms_mm.min():.1f} mm)")
    print(f"wrote {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}/")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="holes", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("theory", help="rigid-punch theory: Table 1 and Figs. 5, 6, 8 analogs (seed 001 §2.3)")
    p.add_argument("--disk", default="configs/disk.toml", help="disk config (default: the seed's disk)")
    p.add_argument("--out", help="output folder (default results/theory/[disk name])")
    p.set_defaults(func=cmd_theory)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ConfigError as e:
        print(f"config error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
