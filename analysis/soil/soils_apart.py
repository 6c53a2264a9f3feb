"""Which bench test tells which soil apart: for each pair of calibrated soils, each bench response of their
posteriors' checks (the posterior mean on the check packings, `<soil>-check.csv`) side by side with the interval of
the difference, and each calibrated parameter's posterior interval (`<soil>-posterior.json`). A response tells two
soils apart when the interval of the difference of their packings' means leaves zero out; whether the targets ask it
to is whether the two soils' target ranges are disjoint."""
import itertools
import json
from pathlib import Path

import pandas as pd

from analysis.core.io import atomic_csv
from analysis.core.soil_config import SOILS
from analysis.soil.bench_calibration import BENCH_DIR, RESPONSES, difference_interval, load_config, target_ranges


def responses_apart(checks: dict[str, pd.DataFrame], targets: dict[str, dict]) -> pd.DataFrame:
    """Per response and pair of soils (in `checks`' order): both packings' means, the difference (soil_2 − soil_1) with its 95 %
    interval, whether it leaves zero out (`apart`) and whether the two target ranges are disjoint (`targets_apart`).
    `targets[soil][response]` is the (lo, hi) range; a response one of the two soils' checks or targets lacks is left
    out of their pair."""
    rows = []
    for r in [*RESPONSES, "cone_kpa"]:
        for s1, s2 in itertools.combinations(checks, 2):
            if any(r not in checks[s] or r not in targets[s] for s in (s1, s2)):
                continue
            d, lo, hi = difference_interval(checks[s1][r], checks[s2][r])
            (a_lo, a_hi), (b_lo, b_hi) = targets[s1][r], targets[s2][r]
            rows.append({"response": r, "soil_1": s1, "soil_2": s2, "mean_1": checks[s1][r].mean(),
                         "mean_2": checks[s2][r].mean(), "difference": d, "lo": lo, "hi": hi,
                         "packings": f"{len(checks[s1])}+{len(checks[s2])}", "apart": bool(lo > 0 or hi < 0),
                         "targets_apart": bool(a_hi < b_lo or b_hi < a_lo)})
    return pd.DataFrame(rows)


def parameters_apart(posteriors: dict[str, dict]) -> pd.DataFrame:
    """Per calibrated parameter and pair of soils: both posterior means and 95 % intervals, and whether the
    intervals are disjoint (`apart`); a parameter one of the two did not calibrate is left out of their pair."""
    rows = []
    for s1, s2 in itertools.combinations(posteriors, 2):
        p1, p2 = posteriors[s1], posteriors[s2]
        for n in [n for n in p1["mean"] if n in p2["mean"]]:
            (lo1, hi1), (lo2, hi2) = p1["interval"][n], p2["interval"][n]
            rows.append({"parameter": n, "soil_1": s1, "soil_2": s2, "mean_1": p1["mean"][n], "lo_1": lo1, "hi_1": hi1,
                         "mean_2": p2["mean"][n], "lo_2": lo2, "hi_2": hi2, "apart": bool(hi1 < lo2 or hi2 < lo1)})
    return pd.DataFrame(rows)


def run(out_dir: Path = BENCH_DIR) -> list[Path]:
    """soils-apart.csv (the responses) and soils-apart-parameters.csv from every soil with a posterior and its check
    in out_dir; nothing when fewer than two soils have both."""
    out_dir = Path(out_dir)
    soils = [s for s in SOILS if (out_dir / f"{s}-check.csv").exists() and (out_dir / f"{s}-posterior.json").exists()]
    if len(soils) < 2:
        return []
    checks = {s: pd.read_csv(out_dir / f"{s}-check.csv", comment="#") for s in soils}
    posteriors = {s: json.loads((out_dir / f"{s}-posterior.json").read_text()) for s in soils}
    targets = {s: target_ranges(s, load_config(soil=s)) for s in soils}
    paths = [out_dir / "soils-apart.csv", out_dir / "soils-apart-parameters.csv"]
    atomic_csv(responses_apart(checks, targets).round(3), paths[0],
               "./holes calibration-report; per bench response and pair of soils, the difference of the posterior "
               "means' check packings, soil_2 − soil_1 (Welch 95 % interval), and whether the targets' ranges are disjoint")
    atomic_csv(parameters_apart(posteriors).round(4), paths[1],
               "./holes calibration-report; per calibrated parameter and pair of soils, the posteriors' 95 % "
               "intervals and whether they are disjoint")
    return paths
