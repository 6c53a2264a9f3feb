"""Parameter studies (`./holes study configs/studies/NAME.toml [MORE.toml ...]`): a grid or a list of cases over run fields,
each case one disk scene (analysis/core/runner.py), one tidy table per study in results/studies/NAME.csv.

A study file:
    [study]   name, description; optionally against = PRESET: a sensitivity, each case's holes set beside the
              field comparison's at that preset for its soil (NAME-effect.csv: the shift and its 95 % interval)
    [base]    fields every case shares (soil = "clay", preset = "quick", seed = 1, ...)
    [grid]    field = [values ...]: every combination            } one of the two, or both
    [[case]]  field = value ...: one case each                    } (grid cases, then the listed ones)
    [morris]  trajectories, levels, seed and [morris.bounds] field = [lo, hi]: SALib's Morris design over those
              fields, one case per design point (a screening: NAME-morris.csv ranks the fields by μ* per metric)
    [posterior] soils, share, samples: each soil's bench posterior as its heaviest samples (the calibration's last
              iteration, together `share` of its weight, at most `samples`), one case each with every calibrated
              and fixed contact parameter set; the table's `posterior_weight` is the sample's weight renormalised
              over those taken (the error budget's soil part: the weighted spread of their holes)
Fields: soil, preset, seed, slip, speed_kmh, holes, lead_in, width, depth, mode, resolution, dt_safety, awake
([behind, ahead] mm), weight, depth_stop, disk_inertia, density_scale, tilled ([depth mm, density ratio]);
disk.<field> and sleeve.<field> (configs/disk.toml) and soil.<field> (the soil's contact parameters).
"""
from __future__ import annotations

import itertools
import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.core.io import say
from analysis.core.runner import finished, plan_case, run_all, scene_args
from analysis.holes.compare import RESIDUAL_LIMIT, VALIDATED, kept_holes, packing_holes, residual_pct, shift
from analysis.core.config import load_preset
from analysis.core.seedling import load_criteria
from analysis.core.schema import ROOT, read_toml, ConfigError
from analysis.core.io import atomic_csv, atomic_write, read_table, stamp

METRICS = ("L0", "L1", "L2", "L2_surface", "h1", "C")


@dataclass(frozen=True)
class Case:
    fields: dict          # as the study file names them (soil, slip, disk.D, ...)
    params: dict          # scripts/disk.py's checked run parameters

    @property
    def id(self) -> str:
        return self.params["id"]

    def label(self) -> str:
        return ", ".join(f"{k}={v}" for k, v in self.fields.items())


STUDY_KEYS = {"name": "the stem of results/studies/NAME.csv and .png", "description": "one line for the plot",
              "against": "a preset whose comparison table the study's effects are set against"}


def load_study(path) -> tuple[dict, list[Case]]:
    """The study's header and its cases (each a dict of fields), every case checked before any runs."""
    data = read_toml(path)
    unknown = sorted(set(data) - {"study", "base", "grid", "case", "morris", "posterior"})
    if unknown:
        raise ConfigError(f"{path}: unknown section(s) {', '.join(unknown)}; allowed study, base, grid, case, morris, "
                          "posterior")
    head = data.get("study", {})
    unknown = sorted(set(head) - set(STUDY_KEYS))
    if unknown:
        raise ConfigError(f"{path}: [study] has unknown key(s) {', '.join(unknown)}: allowed {', '.join(STUDY_KEYS)}")
    if "name" not in head:
        raise ConfigError(f"{path}: [study] needs a name")
    if not isinstance(head["name"], str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", head["name"]):
        raise ConfigError(f"{path}: [study] name = {head['name']!r}: allowed a plain file name (letters, digits, "
                          "_ . -, not starting with a dot), the stem of results/studies/NAME.csv")
    if "against" in head:
        load_preset(head["against"])        # a preset's name, or an error naming the allowed ones
    base = data.get("base", {})
    grid = data.get("grid", {})
    for k, v in grid.items():
        if not isinstance(v, list) or not v:
            raise ConfigError(f"{path}: grid.{k} = {v!r}: allowed a non-empty list of values")
    cases = [{**base, **dict(zip(grid, combo))} for combo in itertools.product(*grid.values())] if grid else []
    cases += [{**base, **c} for c in data.get("case", [])]
    if "morris" in data:
        head = {**head, "morris": morris_design(path, data["morris"])}
        seen = set()
        for row in head["morris"]["design"]:
            point = {**base, **dict(zip(head["morris"]["problem"]["names"], map(float, row)))}
            key = tuple(sorted(point.items()))
            if key not in seen:                    # trajectories may share a point: it runs once
                seen.add(key)
                cases.append(point)
    weights = [None] * len(cases)                 # a [posterior] sample's weight, per case
    if "posterior" in data:
        for fields, weight in posterior_cases(path, data["posterior"]):
            cases.append({**base, **fields})
            weights.append(weight)
    if not cases:
        raise ConfigError(f"{path}: no cases (give [grid] lists, [[case]] tables, a [morris] design or a [posterior])")
    checked = []
    for i, c in enumerate(cases):
        try:
            checked.append(Case(c, plan_case(c)))
        except ConfigError as e:
            raise ConfigError(f"{path}: case {i + 1} ({', '.join(f'{k}={v}' for k, v in c.items())}): {e}") from None
    if len({c.id for c in checked}) < len(checked):
        raise ConfigError(f"{path}: two cases have the same parameters")
    if "posterior" in data:
        head = {**head, "posterior": {c.id: w for c, w in zip(checked, weights) if w is not None}}
    return head, checked


MORRIS_KEYS = {"trajectories": "Morris trajectories (each one case per field + 1), at least 2",
               "levels": "grid levels per field, an even number of at least 4", "seed": "the design's random state",
               "bounds": "field = [lo, hi] for each field screened"}


def morris_design(path, spec: dict) -> dict:
    """The [morris] section checked, and SALib's design over its bounds: {"problem", "design", "levels"}."""
    from analysis.holes.budget import morris_design as design
    unknown = sorted(set(spec) - set(MORRIS_KEYS))
    if unknown:
        raise ConfigError(f"{path}: [morris] has unknown key(s) {', '.join(unknown)}: allowed {', '.join(MORRIS_KEYS)}")
    trajectories, levels = spec.get("trajectories", 10), spec.get("levels", 4)
    if not isinstance(trajectories, int) or trajectories < 2:
        raise ConfigError(f"{path}: morris.trajectories = {trajectories!r}: allowed a whole number of at least 2")
    if not isinstance(levels, int) or levels < 4 or levels % 2:
        raise ConfigError(f"{path}: morris.levels = {levels!r}: allowed an even whole number of at least 4")
    bounds = spec.get("bounds", {})
    if len(bounds) < 2:
        raise ConfigError(f"{path}: [morris.bounds] names {len(bounds)} field(s): allowed two or more")
    for k, v in bounds.items():
        if not (isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v) and v[0] < v[1]):
            raise ConfigError(f"{path}: morris.bounds.{k} = {v!r}: allowed [lo, hi] with lo < hi")
    problem, X = design({k: tuple(map(float, v)) for k, v in bounds.items()}, trajectories, levels,
                        int(spec.get("seed", 0)))
    return {"problem": problem, "design": X, "levels": levels}


POSTERIOR_KEYS = {"soils": "the soils whose bench posteriors are drawn (clay, loam, sand)",
                  "share": "the share of the last iteration's weight the samples taken hold, above 0 and at most 1",
                  "samples": "the most samples taken per soil, at least 2"}


def posterior_cases(path, spec: dict) -> list[tuple[dict, float]]:
    """The [posterior] section checked, and its cases: (fields, weight) per soil's heaviest posterior sample
    (analysis/core/soil_config.py `posterior_samples`), every contact parameter as a `soil.` field."""
    from analysis.core.soil_config import SOILS, posterior_samples
    unknown = sorted(set(spec) - set(POSTERIOR_KEYS))
    if unknown:
        raise ConfigError(f"{path}: [posterior] has unknown key(s) {', '.join(unknown)}: allowed {', '.join(POSTERIOR_KEYS)}")
    soils, share, most = spec.get("soils", []), spec.get("share", 0.85), spec.get("samples", 4)
    if not (isinstance(soils, list) and soils and all(s in SOILS for s in soils)):
        raise ConfigError(f"{path}: posterior.soils = {soils!r}: allowed a non-empty list of {', '.join(SOILS)}")
    if not (isinstance(share, (int, float)) and 0 < share <= 1):
        raise ConfigError(f"{path}: posterior.share = {share!r}: allowed a number above 0 and at most 1")
    if not (isinstance(most, int) and most >= 2):
        raise ConfigError(f"{path}: posterior.samples = {most!r}: allowed a whole number of at least 2")
    out = []
    for soil in soils:
        for s in posterior_samples(soil, float(share), most):
            weight = s.pop("weight")
            out.append(({"soil": soil, **{f"soil.{k}": v for k, v in s.items()}}, weight))
    return out


def screening(table: pd.DataFrame, design: dict, metrics=METRICS) -> pd.DataFrame:
    """The Morris screening of each metric over the finished trajectories: μ* and σ per field, ranked by μ*
    (analysis/holes/budget.py `morris`); a trajectory with an unfinished point is left out. Empty with none whole.
    Where the table has each case's holes' SD (`<metric>_sd`, `found`): the μ* the holes' scatter alone reaches
    (`mu_star_noise95`, the 95 % quantile, `morris_noise`) and whether the field's stands above it.

    >>> m = morris_design("x", {"trajectories": 4, "bounds": {"a": [0.0, 1.0], "b": [0.0, 1.0]}})
    >>> t = pd.DataFrame([{"a": a, "b": b, "L2": 10 * a + b} for a, b in m["design"]])
    >>> s = screening(t, m, ["L2"])
    >>> list(s.field), list(s["rank"])
    (['a', 'b'], [1, 2])
    """
    from analysis.holes.budget import morris, morris_noise
    names, X = design["problem"]["names"], np.asarray(design["design"], float)
    per = len(names) + 1
    keys = table[names].to_numpy(float)
    row_of = [next(iter(np.flatnonzero(np.all(np.isclose(keys, x), axis=1))), None) for x in X]   # None: not run
    rows = []
    for metric in metrics:
        if metric not in table:
            continue
        y = np.array([np.nan if i is None else table[metric].iloc[i] for i in row_of], float)
        whole = [t for t in range(len(X) // per) if np.isfinite(y[t * per:(t + 1) * per]).all()]
        if not whole:
            continue
        take = np.concatenate([np.arange(t * per, (t + 1) * per) for t in whole])
        ranks = morris(design["problem"], X[take], y[take], levels=design["levels"])
        noise = {}
        if f"{metric}_sd" in table and "found" in table:
            se = np.array([np.nan if i is None else table[f"{metric}_sd"].iloc[i] / np.sqrt(table["found"].iloc[i])
                           for i in row_of], float)
            if np.isfinite(se[take]).all():
                noise = morris_noise(design["problem"], X[take], se[take])
        rows += [{"metric": metric, "field": f, "mu_star": v["mu_star"], "sigma": v["sigma"], "rank": i + 1,
                  "trajectories": len(whole),
                  **({"mu_star_noise95": noise[f], "above_noise": bool(v["mu_star"] > noise[f])} if noise else {})}
                 for i, (f, v) in enumerate(ranks.items())]
    return pd.DataFrame(rows)


def case_row(case: Case, runs_dir: Path, criteria: dict) -> dict:
    """One tidy row: the case's fields, its cost and its holes' means and pass rate (stated reading); `found`
    counts the holes found where the punch entered (the means are over those, the pass rate over all);
    slip_holes: the mean slip between consecutive holes' entries (eq 1, summary.json)."""
    from analysis.holes import measure
    run = runs_dir / case.id
    summary = json.loads((run / "summary.json").read_text())
    holes = measure.run(run)
    stated = criteria["stated"]
    passed = np.all([holes[m] > stated[m] for m in stated], axis=0)
    row = dict(case.fields)
    row.update({"run": summary["id"], "holes": len(holes), "found": int(holes.found.sum())})
    row.update({m: float(holes[m].mean()) for m in METRICS})
    row.update({f"{m}_sd": float(holes[m].std(ddof=1)) if len(holes) > 1 else np.nan for m in METRICS})
    row.update({c: float(holes[c].mean()) for c in holes.columns if c.startswith("l_")})    # l_H, Table 1
    row.update({"pass_rate": float(passed.mean()), "passed": int(passed.sum()),
                "wall_s": summary["wall_s"], "cpu_s": summary.get("cpu_s", np.nan),
                "particles": summary["particles"], "steps": summary["steps"],
                "threads": summary["threads"], "slip_out": summary.get("slip_out"),
                "slip_holes": float(np.mean(summary["slip_holes"])) if summary.get("slip_holes") else np.nan})
    residual = residual_pct([summary]).get(summary["id"], np.nan)
    row.update({"energy_residual_pct": residual, "residual_flag": bool(residual > RESIDUAL_LIMIT)})
    return row


def write_table(name: str, head: dict, cases: list[Case], rows: dict, runs_dir: Path, out: Path, command: str):
    """results/studies/NAME.csv from every finished case and its plot, written atomically, so a crash or a
    killed case never leaves a partial row. `rows` keeps each case's row by id: a case is measured once. A
    finished case that cannot be measured is said once and kept out (its row None); the others still go in."""
    criteria = load_criteria()
    for c in cases:
        if c.id not in rows and finished(runs_dir, c.id):
            try:
                rows[c.id] = case_row(c, runs_dir, criteria)
            except Exception as e:                 # noqa: BLE001 - one bad run must not stop the table
                rows[c.id] = None
                say(f"study {name}: FAILED to measure {c.id} ({c.label()}): {e!r}")
    measured = [rows[c.id] for c in cases if rows.get(c.id) is not None]
    if not measured:
        return None
    table = pd.DataFrame(measured)
    if head.get("posterior"):                     # each case's weight, by its run id
        table["posterior_weight"] = table.run.map(head["posterior"])
    note = stamp(command)
    atomic_csv(table.round(4), out / f"{name}.csv", note)
    if head.get("morris"):
        screen = screening(table, head["morris"])
        if len(screen):
            atomic_csv(screen.round(4), out / f"{name}-morris.csv", note + "; SALib's Morris screening over the "
                       "finished trajectories: mu_star, the mean size of a field's elementary effects (mm per its range); "
                       "mu_star_noise95, what the cases' holes' scatter alone reaches (95 %), above_noise")
    comparison = ROOT / "results/comparison.csv"
    if head.get("against") and comparison.exists():
        effect = effect_table(table, head["against"], comparison)
        if len(effect):
            atomic_csv(effect.round(3), out / f"{name}-effect.csv", note + f"; against {head['against']}'s holes "
                       f"of the case's packing (results/comparison/{head['against']}/holes.csv), or of every packing "
                       "(results/comparison.csv) where those lack it")
    plot(table, head, out / f"{name}.png", note)
    say(f"study {name}: table updated, {len(table)}/{len(cases)} cases")
    return table


def effect_table(table: pd.DataFrame, against: str, comparison: Path) -> pd.DataFrame:
    """A sensitivity's effect (`[study] against = PRESET`): each case's hole means beside those of the field
    comparison's runs at that preset for the case's soil, the shift with its 95 % interval (compare.shift), and the
    shift in % of the field mean. Where the comparison's holes (<comparison's folder>/comparison/PRESET/holes.csv)
    hold the case's packing, the case is set beside that packing's holes alone, so the packing does not enter the
    shift (`packings` names it); else beside every packing's (results/comparison.csv, `packings` "all"). Cases whose
    soil the comparison lacks are left out."""
    base = read_table(comparison)
    base = base[base.preset == against]
    kept = kept_holes(against, Path(comparison).parent)
    holes = read_table(kept) if kept.exists() else pd.DataFrame(columns=["soil", "seed", "found"])
    rows = []
    for r in table.to_dict("records"):
        own = packing_holes(holes, r.get("soil"), r.get("seed"))                       # the case's packing
        for m in VALIDATED:
            b = base[(base.soil == r.get("soil")) & (base.metric == m)]
            if b.empty or not np.isfinite(r.get(m, np.nan)):
                continue
            b = b.iloc[0]
            same = own.get(m, pd.Series(dtype=float)).dropna()
            if len(same) >= 2:
                mean, sd, n, packings = same.mean(), same.std(ddof=1), len(same), str(int(r["seed"]))
            else:
                mean, sd, n, packings = b.sim_mean, b.sim_sd, int(b.n_holes), "all"
            d = shift(r[m], r.get(f"{m}_sd", np.nan), r["found"], mean, sd, n)
            rows.append({"run": r["run"], "soil": r["soil"], "metric": m, "mean": r[m], "holes": r["found"],
                         f"{against}_mean": mean, f"{against}_holes": n, "packings": packings,
                         "field_mean": b.field_mean, **d, "shift_pct_of_field": 100 * d["shift"] / b.field_mean})
    return pd.DataFrame(rows)


def committed_rows(table_path: Path, cases: list[Case]) -> dict:
    """The rows of a study's table already written (and committed) whose run ids are still the study's cases.
    A run id hashes every parameter, soil constants included, so a row is reused only for the same run; the
    runs/ folders are not committed, so on a new machine these rows are all that is left of finished cases."""
    if not table_path.exists():
        return {}
    ids = {c.id for c in cases}
    table = read_table(table_path)
    stale = sorted(set(table.run) - ids)
    if stale:
        say(f"{table_path}: {len(stale)} of its rows are runs this study no longer makes (other parameters, such as "
            f"an earlier calibration's soil); the rewritten table leaves them out (git history keeps them): "
            f"{', '.join(stale)}")
    return {r["run"]: r for r in table.to_dict("records") if r["run"] in ids}


def theory_lines(x: str, values) -> dict[str, dict]:
    """The rigid-punch theory beside a slip study, at each slip: seed 001 Table 1 (eqs 1-5 as the authors
    evaluated them: L0, L1; C = 2πR(1-δ)/N, eq 6) and the punch's exact swept envelope (L0, L1, L2, C).
    Other studies get none."""
    if x != "slip":
        return {}
    from analysis.holes.compare import theory_values
    slips = sorted(set(float(v) for v in values))
    th = [theory_values(slip=s) for s in slips]
    return {label: {"x": slips, **{m: [t[key].get(m, np.nan) for t in th] for m in METRICS}}
            for label, key in (("theory: Table 1", "table1"), ("theory: swept envelope", "envelope"))}


def plot_axes(table: pd.DataFrame) -> tuple[str, str | None, pd.DataFrame]:
    """(x, group, table) for a study's plot: x is the first field the cases vary, and each combination of the
    other varied fields is one line, the "variant" column naming the fields a case sets ("reference" when it
    sets none of them). If some case leaves x unset, every run is its own point.

    >>> t = pd.DataFrame({"seed": [1, 1, 2, 2], "depth": [None, 180.0, None, 180.0], "L2": [38.4, 26.6, 38.9, 35.3]})
    >>> x, group, t = plot_axes(t)
    >>> x, group, list(t.variant)
    ('seed', 'variant', ['reference', 'depth = 180', 'reference', 'depth = 180'])
    """
    cost = ("wall_s", "cpu_s", "particles", "steps", "threads")
    keys = [k for k in table.columns if k not in ("run", "holes", "found", "passed", *cost, "slip_out", "slip_holes",
                                                  "pass_rate", "energy_residual_pct", "residual_flag", "posterior_weight",
                                                  *METRICS)
            and not k.endswith("_sd") and not k.startswith("l_") and table[k].astype(str).nunique(dropna=False) > 1]
    if not keys or table[keys[0]].isna().any():
        return "run", None, table
    if len(keys) == 1:
        return keys[0], None, table
    variant = [", ".join(f"{k} = {v:g}" if isinstance(v, (int, float, np.number)) else f"{k} = {v}"
                         for k in keys[1:] if pd.notna(v := row[k])) or "reference" for _, row in table.iterrows()]
    return keys[0], "variant", table.assign(variant=variant)


def plot(table: pd.DataFrame, head: dict, path: Path, note: str):
    """Each hole metric and the pass rate against the study's first varied field (a line per other value); a
    `[posterior]` study's per soil (`plot_posterior`)."""
    if "posterior_weight" in table:
        return plot_posterior(table, head, path, note)
    import matplotlib
    x, group, table = plot_axes(table)
    theory = theory_lines(x, table[x]) if x in table else {}
    fig, panels = metric_figure()
    for ax, m in panels:
        for (label, line), style in zip(theory.items(), ("k--", "k:")):
            if m in line and np.isfinite(line[m]).any():
                ax.plot(line["x"], line[m], style, marker=".", label=label)
        for label, part in (table.groupby(group) if group else [(None, table)]):
            part = part.sort_values(x)
            if m not in part or part[m].isna().all():  # C in a one-hole study, a table from before: nothing to draw
                continue
            err = part.get(f"{m}_sd")                  # SD over a case's holes; none with one hole
            ax.errorbar(part[x], part[m], yerr=None if err is None else err.fillna(0.0), marker="o", capsize=3,
                        label=label if group else None)
        ax.set_xlabel(x)
        if x == "run":
            ax.tick_params(axis="x", labelrotation=30, labelsize=6)
        elif pd.api.types.is_integer_dtype(table[x]):                # seeds, hole counts: whole ticks
            ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    if group or theory:
        panels[0][0].legend(fontsize=7)
    save_figure(fig, path, f"study {head['name']}: {head.get('description', '')}\n{note}")
    if theory and any(c.startswith("l_") for c in table.columns):
        plot_length_at_depth(table, path.with_name(path.stem + "_depth.png"), note)


def plot_posterior(table: pd.DataFrame, head: dict, path: Path, note: str):
    """Each hole metric and the pass rate per soil of a `[posterior]` study: every sample's strip (its mean ± its
    standard error over the holes, the marker's area its posterior weight) and the soil's weighted mean (a bar)."""
    soils = list(dict.fromkeys(table.soil))
    fig, panels = metric_figure()
    for ax, m in panels:
        for i, soil in enumerate(soils):
            g = table[(table.soil == soil) & np.isfinite(table[m].to_numpy(float))]
            if g.empty:
                continue
            w = g.posterior_weight.to_numpy(float)
            xs = i + (np.linspace(-0.25, 0.25, len(g)) if len(g) > 1 else np.zeros(1))
            se = (g[f"{m}_sd"] / np.sqrt(g.found)).fillna(0.0) if f"{m}_sd" in g else None
            ax.errorbar(xs, g[m], yerr=se, fmt="none", ecolor="0.5", capsize=3)
            ax.scatter(xs, g[m], s=20 + 300 * w, color=f"C{i}", zorder=3)
            ax.hlines(float(w @ g[m].to_numpy(float)) / w.sum(), i - 0.35, i + 0.35, color=f"C{i}", lw=2)
        ax.set_xticks(range(len(soils)), soils)
        ax.set_xlim(-0.6, len(soils) - 0.4)
    save_figure(fig, path, f"study {head['name']}: {head.get('description', '')}; a point per posterior sample's "
                f"strip (mean ± SE over its holes; area: its weight), a bar per soil's weighted mean\n{note}")


def metric_figure():
    """A study picture's frame: a panel per hole metric and the pass rate (2 × 4, the last hidden), labelled;
    (figure, [(axes, metric), ...])."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 4, figsize=(16, 7))
    axes.flat[-1].set_visible(False)
    panels = list(zip(axes.flat, (*METRICS, "pass_rate")))
    for ax, m in panels:
        ax.set_ylabel(m + (" (stated criteria)" if m == "pass_rate" else ", mm"))
        ax.grid(alpha=0.3)
    return fig, panels


def save_figure(fig, path: Path, title: str):
    """A study picture titled and written to `path`."""
    import matplotlib.pyplot as plt
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_length_at_depth(table: pd.DataFrame, path: Path, note: str):
    """The hole's length along the travel against depth below the undisturbed surface, at each slip: the DEM
    holes (mean over a case's holes) beside seed 001 Table 1's l_H."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from analysis.core.io import read_table
    t1 = read_table(ROOT / "configs/field/table1.csv")
    cols = [c for c in table.columns if c.startswith("l_")]
    depths = [int(c[2:]) for c in cols]
    fig, ax = plt.subplots(figsize=(7, 5))
    for i, r in enumerate(table.sort_values("slip").itertuples(index=False)):
        colour = f"C{i}"
        ax.plot([getattr(r, c) for c in cols], depths, "-o", color=colour, label=f"DEM, slip {r.slip:g}")
        ref = t1[np.isclose(t1.slip, r.slip)]
        if len(ref):
            ax.plot([ref.iloc[0][c] for c in cols if c in ref], [d for d, c in zip(depths, cols) if c in ref], "--",
                    color=colour, label=f"Table 1, slip {r.slip:g}")
    ax.invert_yaxis()
    ax.set_xlabel("hole length along the travel l_H, mm")
    ax.set_ylabel("depth H below the undisturbed surface, mm")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"length at depth: DEM beside seed 001 Table 1\n{note}", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(paths, workers: int | None = None, threads: int | None = None, scheduler: str | None = None, runs_dir=None, bed_dir=None,
        out=None, no_run: bool = False) -> int:
    """Run one or more studies as one batch (a case two studies share, such as the baseline, runs once), each
    study's table rewritten as its cases finish; with no_run, only tabulate the cases that finished."""
    from analysis.core.bed_spec import BED_DIR
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    studies = [(path, *load_study(path)) for path in paths]
    names = [head["name"] for _, head, _ in studies]
    if len(set(names)) < len(names):
        raise ConfigError(f"two study files share a name: {', '.join(names)}")
    runs_dir = Path(runs_dir or ROOT / "results/runs")
    bed_dir = Path(bed_dir or BED_DIR)
    out = Path(out or ROOT / "results/studies")
    rows = {head["name"]: committed_rows(out / f"{head['name']}.csv", cases) for _, head, cases in studies}
    batch, members = {}, {}
    for path, head, cases in studies:
        for c in cases:
            if c.id in rows[head["name"]]:
                continue
            batch.setdefault(c.id, {"id": c.id, "args": scene_args(c.fields), "tag": f"[{head['name']} {c.label()}]",
                                    "asleep": bool(c.params.get("awake_mm"))})
            members.setdefault(c.id, []).append((path, head, cases))

    def write(path, head, cases):
        return write_table(head["name"], head, cases, rows[head["name"]], runs_dir, out, f"./holes study {path}")

    label = "study " + "+".join(names)
    failures = [] if no_run else run_all(list(batch.values()), workers, threads, runs_dir, bed_dir,
                                         scheduler=scheduler, label=label,
                                         on_done=lambda c, s: [write(*m) for m in members[c["id"]]])
    n_tables = 0
    for path, head, cases in studies:
        table = write(path, head, cases)
        if table is not None:
            n_tables += 1
            say(f"study {head['name']}: {len(table)}/{len(cases)} cases in {out / (head['name'] + '.csv')}")
        else:
            say(f"study {head['name']}: no case has finished in {runs_dir}; no table written")
    for f in failures:
        say(f"FAILED: {f.splitlines()[0]}")
    unmeasured = sum(r is None for table_rows in rows.values() for r in table_rows.values())
    return 1 if failures or unmeasured or n_tables < len(studies) else 0


def export_batch(path, table_path: Path) -> Path:
    """The study as a yade-batch parameter table: a `description` column (the run id) and one column per
    field, one line per case ("-": the field is not set in that case). `yade-batch TABLE
    scripts/batch_case.py` runs the same cases: each job hands its line to scripts/disk.py."""
    _, cases = load_study(path)
    keys = list(dict.fromkeys(k for c in cases for k in c.fields))
    lines = [" ".join(["description", *keys])]
    for c in cases:
        cells = [str(c.fields.get(k, "-")) for k in keys]
        if any(not cell or any(ch.isspace() for ch in cell) for cell in cells):
            raise ConfigError(f"{path}: a value with spaces cannot go into a yade-batch table: {cells}")
        lines.append(" ".join([c.id, *cells]))
    atomic_write(table_path, "\n".join(lines) + "\n")
    return table_path


def case_from_table_line(table_path, line: int) -> tuple[str, dict]:
    """(description, case fields) of one line (1-based, as yade-batch counts) of an exported table."""
    rows = Path(table_path).read_text().splitlines()
    head, cells = rows[0].split(), rows[line - 1].split()
    case = {}
    for k, v in zip(head[1:], cells[1:]):
        if v != "-":
            case[k] = v
    return cells[0], case
