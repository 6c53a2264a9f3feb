"""The first validation strips' holes 1-5 (the punches' first turn, sleeves integrated) beside the field: holes
6-8 of these runs were formed with the plates held rigid (the punch's angle not wrapped on its second turn,
fixed since; such strips are new runs now). Run from the project root:
    .venv/bin/python results/comparison/first_turn/table.py
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
import pandas as pd  # noqa: E402

from analysis.core.config import load_criteria  # noqa: E402
from analysis.core.io import atomic_csv, atomic_write, stamp  # noqa: E402
from analysis.holes import compare, measure  # noqa: E402
from analysis.holes.machine import TARGET_METRICS, vertical_load  # noqa: E402

RUNS = tuple(sys.argv[1:]) or ("clay-validation_surface-prescribed-ed36d653", "loam-validation_surface-prescribed-a8684e71")
here = Path(__file__).parent
kept = here.parent / "runs"
tables, loads = [], {}
for run in RUNS:
    folder = Path("results/runs") / run if (Path("results/runs") / run / "timeseries.csv").exists() else kept / run
    h = measure.run(folder, pictures=False)
    summary = json.loads((folder / "summary.json").read_text())
    loads[summary["soil"]] = vertical_load(folder, summary["lead_in"], 5)      # over holes 1-5's punch periods
    tables.append(h)
holes = pd.concat(tables, ignore_index=True)
first = holes[holes.hole <= 5]
table = compare.compare(first, compare.field_table(), compare.theory_values(), load_criteria(), {},
                        {("clay", m) for m in TARGET_METRICS})
note = stamp("results/comparison/first_turn/table.py")
atomic_csv(holes.round(2), here / "holes.csv", note + "; every hole of the two strips, 6-8 with rigid plates")
atomic_csv(table.round(3), here / "comparison.csv", note + "; holes 1-5 only")
trend = compare.position_trend(first)
atomic_csv(trend.round(3), here / "position_trend.csv", note + "; holes 1-5")
md = compare.markdown(table, "validation_surface, holes 1-5 of the first strips", note)
md += ("\nW, the mean vertical soil force on the disk over holes 1-5's punch periods: "
       + ", ".join(f"{s} {w:.0f} N" for s, w in loads.items()) + ".\n")
atomic_write(here / "comparison.md", md)
print(md)
