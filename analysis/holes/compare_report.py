"""The field comparison written out (analysis/holes/compare.py computes it): the markdown table with its counts
of claims, and one plot per metric. No YADE."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.holes.compare import (CLAIM_PCTS, FIELD_COLUMN, RESIDUAL_LIMIT, RESOLVABLE_PCT, VALIDATED, WITHIN_PCT,
                                    with_l2_surface)


def markdown(table: pd.DataFrame, preset: str, note: str) -> str:
    targets = (table["calibration_target"] if "calibration_target" in table else
               pd.Series(False, index=table.index)).fillna(False).astype(bool)
    lines = [f"# Simulated holes against the field (seed 001 Table 3), preset `{preset}`", "", note, "",
             "| soil | metric | field mean ± SD [range] | simulated mean ± SD [95 % CI] (holes/runs) | measurement band | "
             "error | in range | within 5 % / 10 % (claim) | field mean in CI | theory: Table 1 / envelope |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for i, r in table.iterrows():
        unit = "%" if r.metric.startswith("pass") else "mm"
        sd = "" if pd.isna(r.sim_sd) else f" ± {r.sim_sd:.1f}"
        extra = f", {int(r.passed_holes)}/{int(r.n_holes)} passed" if r.metric.startswith("pass") else ""
        if r.metric.startswith("pass") and pd.notna(r.get("flip_pct", math.nan)):
            band = f"{r.flip_pct:.0f} % of holes flip"
        else:
            band = "–" if pd.isna(r.get("band", math.nan)) else f"± {r.band:.1f} mm"
        claims = " / ".join(str(r.get(f"claim_{p:g}pct", "–")) for p in CLAIM_PCTS)
        theory = " / ".join("–" if pd.isna(v) else f"{v:.1f}" for v in (r.theory_table1, r.theory_envelope))
        fsd = f" ± {r.field_sd:.1f}" if "field_sd" in r and pd.notna(r.field_sd) else ""
        yes = {True: "yes", False: "no"}
        target = " (target)" if targets[i] else ""
        lines.append(f"| {r.soil} | {r.metric}{target} | {r.field_mean:.1f}{fsd} [{r.field_min:.1f}–{r.field_max:.1f}] | "
                     f"{r.sim_mean:.1f}{sd} [{r.ci_lo:.1f}–{r.ci_hi:.1f}] ({int(r.n_holes)}/{int(r.n_runs)}{extra}) | "
                     f"{band} | {r.abs_error:+.1f} {unit} ({r.rel_error_pct:+.0f} %) | {yes[bool(r.inside_field_range)]} | "
                     f"{claims} | {yes[bool(r.get('field_in_ci', False))]} | {theory} |")
    if targets.any():
        marked = ", ".join(f"{r.soil} {r.metric}" for r in table[targets].itertuples())
        predicted = table[table.metric.isin(VALIDATED) & ~targets]
        passes = table[table.metric.str.startswith("pass") & ~targets]
        lines += ["", f"Calibration targets (the machine was fitted to them, or they follow from the fitted ones: "
                  f"not predictions, not counted): {marked}.",
                  "", f"**Predicted ({len(predicted)} hole-metric means: {', '.join(VALIDATED)} per soil, the targets "
                  f"left out): {claim_counts(predicted)}** (a claim needs the simulated 95 % interval widened by the "
                  "measurement band inside ±5 or ±10 % of the field mean; `no`: wholly outside; `open`: neither; not "
                  f"resolvable: the band alone is wider than {RESOLVABLE_PCT:g} % of the field mean). "
                  f"Point estimates: {int(predicted.within_10pct.sum())} of {len(predicted)} within {WITHIN_PCT:g} %, "
                  f"{int(predicted.field_in_ci.sum())} with the field mean inside the simulated 95 % interval, "
                  f"{int(predicted.inside_field_range.sum())} inside the field's range; pass rates: "
                  f"{int(passes.within_10pct.sum())} of {len(passes)} within {WITHIN_PCT:g} %."]
    judged = table[table.metric.isin(VALIDATED)]
    lines += ["", f"Of the {len(judged)} hole-metric means judged ({', '.join(VALIDATED)} per soil; C is set by the "
              f"prescribed kinematics and not counted): {int(judged.inside_field_range.sum())} inside the field's range, "
              f"{int(judged.within_10pct.sum())} within {WITHIN_PCT:g} % of the field mean, "
              f"{int(judged.field_in_ci.sum())} with the field mean inside the simulated 95 % interval. "
              "L2 is read from the subsided level (§4.2 as printed), L2_surface from the undisturbed surface; "
              "the field's one L2 stands beside both."]
    if "energy_residual_pct" in table:
        e = table.groupby("soil", sort=False).energy_residual_pct.first()
        flagged = [s for s, v in e.items() if v > RESIDUAL_LIMIT]
        lines += ["", "Energy residual, the largest of each soil's runs (% of the tools' work): "
                  + ", ".join(f"{s} {v:.1f}" if pd.notna(v) else f"{s} not recorded" for s, v in e.items())
                  + (f"; above {RESIDUAL_LIMIT:g} %, so flagged: {', '.join(flagged)}." if flagged
                     else f"; none above {RESIDUAL_LIMIT:g} %.")]
    return "\n".join(lines) + "\n"


def claim_counts(rows: pd.DataFrame) -> str:
    """The claims of `rows` counted: at 10 % and at 5 %, yes / open / no, and the not resolvable apart.

    >>> claim_counts(pd.DataFrame({"claim_5pct": ["yes", "no", "not resolvable"],
    ...                            "claim_10pct": ["yes", "open", "not resolvable"]}))
    'within 10 %: 1 yes, 1 open, 0 no; within 5 %: 1 yes, 0 open, 1 no; 1 not resolvable at this grain size'
    """
    if "claim_10pct" not in rows:
        return "no measurement band"
    parts = []
    for p in sorted(CLAIM_PCTS, reverse=True):
        c = rows[f"claim_{p:g}pct"].value_counts()
        parts.append(f"within {p:g} %: {c.get('yes', 0)} yes, {c.get('open', 0)} open, {c.get('no', 0)} no")
    unresolved = int((rows["claim_10pct"] == "not resolvable").sum())
    return "; ".join(parts) + f"; {unresolved} not resolvable at this grain size"


def plot(table: pd.DataFrame, holes: pd.DataFrame, field: pd.DataFrame, preset: str, out: Path, note: str):
    """One PNG per metric: field runs as points, the simulation as its mean with the 95 % interval and its
    holes as small marks, theory as a line."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    holes = with_l2_surface(holes)
    for m in sorted(set(table.metric)):
        t = table[table.metric == m]
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        for i, (_, r) in enumerate(t.iterrows()):
            col = "pass_percent" if m.startswith("pass") else FIELD_COLUMN.get(m, m)
            fv = field[(field.soil == r.soil) & (field.run != "mean")][col]
            ax.plot(np.full(len(fv), i - 0.12), fv, "ko", ms=4, label="field runs" if i == 0 else None)
            ci = None if pd.isna(r.ci_lo) else [[r.sim_mean - r.ci_lo], [r.ci_hi - r.sim_mean]]  # none from one value
            band = r.get("band", math.nan)
            if pd.notna(band) and ci is not None:
                ax.vlines(i + 0.12, r.ci_lo - band, r.ci_hi + band, colors="C0", lw=6, alpha=0.2,
                          label="95 % CI widened by the measurement band" if i == 0 else None)
            ax.errorbar(i + 0.12, r.sim_mean, yerr=ci, fmt="s",
                        color="C0", capsize=4, label="simulated mean, 95 % CI" if i == 0 else None)
            if not m.startswith("pass"):
                hv = holes[holes.soil == r.soil][m].dropna()
                ax.plot(np.full(len(hv), i + 0.25), hv, "_", color="C0", ms=8,
                        label="simulated holes" if i == 0 else None)
            for v, style, label in ((r.theory_table1, "-", "theory, Table 1"), (r.theory_envelope, "--",
                                                                               "theory, swept envelope")):
                if not pd.isna(v):
                    ax.hlines(v, i - 0.35, i + 0.35, colors="C3", linestyles=style, label=label if i == 0 else None)
        ax.set_xticks(range(len(t)), t.soil)
        ax.set(ylabel=f"{m}, {'%' if m.startswith('pass') else 'mm'}", title=f"{m}: field vs simulation ({preset})")
        ax.legend(fontsize=7)
        fig.text(0.01, 0.005, note, fontsize=5, color="0.4")
        fig.tight_layout()
        path = out / f"{m}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
