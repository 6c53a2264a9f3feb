"""What a miss against the field is made of (no YADE): the grain size's share by extrapolating a metric to r → 0,
the error budget that splits a miss into its parts, and the screening of the machine's unknowns.

- `extrapolate`: a metric's means at several grain radii, fitted as m(r) = m0 + a·r^p (p fitted when four radii or
  more are given, else the order `p` assumed), m0 with its 95 % interval from a parametric bootstrap over the
  means' standard errors.
- `budget`: the miss (simulated − field) split into the grain size's part (the simulated mean − its r → 0 limit)
  and the rest, which the finest model leaves (the limit − field); beside them the uncertainties (measurement
  band, the machine's interval propagated, the soil's parameters, packing scatter) as half-widths, combined in
  quadrature. The systematic parts add up to the miss; the uncertain ones say how much of it is resolved.
- `bond_interval`: the 95 % interval of a soil's cone-fitted bond from its cone calibration: the cone index's slope
  in the bond over the calibration's iterations, and the mean over the replicate packings at the adopted bond with
  its t-interval, carried back through the slope to the bond that meets the target.
- `morris`: SALib's Morris screening of a model over the machine's unknowns (penetration, spring, preload, plate
  diameter and rest position): which matter, before any is fitted.
"""
from __future__ import annotations

import math

import numpy as np


def power_law(r, m0: float, a: float, p: float):
    return m0 + a * np.asarray(r, float) ** p


def extrapolate(radii, means, ses, p: float = 1.0, n_boot: int = 2000, seed: int = 0,
                fit_order: bool | None = None) -> dict:
    """The limit m0 of a metric as the grain radius goes to 0 (module doc), with its 95 % interval; `fit_order`
    (default: with four radii or more) fits the order too, else `p` is taken as known.

    >>> r = extrapolate([8, 6, 5, 4], power_law([8, 6, 5, 4], 14.0, 1.3, 1.0), [0.01] * 4, n_boot=50)
    >>> round(r["m0"], 2), r["fitted_order"]
    (14.0, True)
    """
    from scipy.optimize import curve_fit
    r, m, se = (np.asarray(v, float) for v in (radii, means, ses))
    fit_order = len(r) >= 4 if fit_order is None else fit_order

    def fit(values):
        if fit_order:
            guess = (values[np.argmin(r)], (values.max() - values.min()) / max(r.max() - r.min(), 1e-9), 1.0)
            try:
                (m0, a, q), _ = curve_fit(power_law, r, values, p0=guess, bounds=([-np.inf, -np.inf, 0.2], [np.inf] * 2 + [4.0]),
                                          maxfev=20000)
                return m0, a, q
            except RuntimeError:
                pass
        X = np.column_stack([np.ones_like(r), r ** p])
        (m0, a), *_ = np.linalg.lstsq(X, values, rcond=None)
        return m0, a, p

    m0, a, q = fit(m)
    rng = np.random.default_rng(seed)
    boot = np.array([fit(rng.normal(m, np.maximum(se, 1e-12)))[0] for _ in range(n_boot)])
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return {"m0": float(m0), "m0_lo": float(lo), "m0_hi": float(hi), "a": float(a), "order": float(q),
            "fitted_order": bool(fit_order)}


def within_of_limit(mean: float, limit: dict, field_mean: float, pct: float = 5.0) -> bool:
    """Whether a grain size's mean lies within pct % of the field mean from the r → 0 limit, all of its interval.

    >>> within_of_limit(60.0, {"m0": 59.0, "m0_lo": 58.5, "m0_hi": 59.5}, 60.0)
    True
    """
    half = pct / 100 * abs(field_mean)
    return bool(abs(mean - limit["m0_lo"]) <= half and abs(mean - limit["m0_hi"]) <= half)


UNCERTAIN = ("measurement", "machine", "soil", "packing")


def budget(sim_mean: float, field_mean: float, limit: float, **half_widths: float) -> dict:
    """One metric's miss split into its parts (module doc): `grain_size` + `model` = `miss`; each uncertain part
    (UNCERTAIN, 95 % half-widths) and their quadrature sum `uncertain`; `resolved`: the miss exceeds it. A part not
    measured (NaN: no r → 0 limit, an uncertain part not run) stays NaN, is left out of the sum and named in
    `not_measured`; `dominant` is the largest measured part.

    >>> b = budget(66.0, 60.0, 64.0, measurement=1.0, machine=2.0, soil=2.0, packing=0.0)
    >>> b["miss"], b["grain_size"], b["model"], b["uncertain"], b["resolved"]
    (6.0, 2.0, 4.0, 3.0, True)
    >>> b = budget(66.0, 60.0, float("nan"), measurement=1.0, machine=2.0)
    >>> b["not_measured"], b["dominant"], b["uncertain"]
    ('grain_size, model, soil, packing', 'machine', 2.23606797749979)
    """
    unknown = sorted(set(half_widths) - set(UNCERTAIN))
    if unknown:
        raise ValueError(f"budget: unknown part(s) {', '.join(unknown)}; allowed {', '.join(UNCERTAIN)}")
    parts = {k: float(half_widths.get(k, math.nan)) for k in UNCERTAIN}
    miss = sim_mean - field_mean
    sizes = {"grain_size": sim_mean - limit, "model": limit - field_mean, **parts}
    measured = {k: abs(v) for k, v in sizes.items() if math.isfinite(v)}
    uncertain = math.sqrt(sum(v ** 2 for k, v in parts.items() if math.isfinite(v)))
    return {"miss": miss, "grain_size": sizes["grain_size"], "model": sizes["model"], **parts,
            "uncertain": uncertain, "resolved": bool(abs(miss) > uncertain),
            "dominant": max(measured, key=measured.get) if measured else "",
            "not_measured": ", ".join(k for k in sizes if k not in measured)}


def bond_interval(bonds, cone_means, adopted: float, replicates, target: float) -> dict:
    """A cone-fitted bond's 95 % interval (module doc). `bonds`, `cone_means`: the calibration's iterations (the bond
    tried, the cone index over its packings); `replicates`: cone indices of packings at the `adopted` bond.
    `centre` is the bond whose replicate mean meets `target`; `half_width` the t-interval of that mean (n − 1 degrees
    of freedom) over the slope. NaN half-width with one replicate or a slope that is not positive.

    >>> r = bond_interval([40, 50, 60], [370, 450, 530], 50, [440, 450, 460], 450)
    >>> round(r["slope"], 2), round(r["centre"], 2), round(r["half_width"], 2)
    (8.0, 50.0, 3.11)
    """
    from analysis.holes.compare import t975
    x, y, rep = (np.asarray(v, float) for v in (bonds, cone_means, replicates))
    slope = float(np.polyfit(x, y, 1)[0]) if len(np.unique(x)) >= 2 else math.nan
    n = len(rep)
    mean = float(rep.mean())
    rising = math.isfinite(slope) and slope > 0
    half = float(t975(n - 1) * rep.std(ddof=1) / math.sqrt(n) / slope) if rising and n >= 2 else math.nan
    centre = adopted + (target - mean) / slope if rising else math.nan
    return {"slope": slope, "adopted": float(adopted), "replicates": n, "cone_mean": mean,
            "cone_sd": float(rep.std(ddof=1)) if n > 1 else math.nan, "centre": float(centre), "half_width": half,
            "lo": float(centre - half), "hi": float(centre + half)}


MACHINE_UNKNOWNS = {"disk.penetration": (70.0, 95.0), "sleeve.stiffness": (0.5, 8.0), "sleeve.preload": (0.0, 50.0),
                    "sleeve.outer_diameter": (70.0, 90.0), "sleeve.rest_from_tip": (22.0, 30.0)}


def morris_design(bounds: dict = MACHINE_UNKNOWNS, trajectories: int = 10, levels: int = 4, seed: int = 0):
    """SALib's Morris design over `bounds` ({name: (lo, hi)}): the problem and the sample (one row per model
    run, one column per unknown)."""
    from SALib.sample import morris as sample
    problem = {"num_vars": len(bounds), "names": list(bounds), "bounds": [list(b) for b in bounds.values()]}
    state = np.random.get_state()       # SALib draws from numpy's global generator and seeds it only when the seed
    np.random.seed(seed)                # is not 0: seeded here, every seed (0 too) gives one design, and the
    try:                                # caller's random state is left as it was
        return problem, sample.sample(problem, trajectories, num_levels=levels)
    finally:
        np.random.set_state(state)


def morris_noise(problem: dict, design, errors, draws: int = 2000, quantile: float = 0.95, seed: int = 0) -> dict:
    """What μ* reaches from the outputs' own scatter alone: each design row's output replaced by a draw of its
    standard error (`errors`, one per row: a case's holes' SD over √holes), μ* taken over the design's elementary
    effects as `morris` takes it (per unit of each unknown's range), and its `quantile` over `draws` such designs,
    per unknown. An unknown whose μ* stays under it is not told apart from the holes' scatter.

    >>> prob, X = morris_design({"a": (0, 1), "b": (0, 10)}, trajectories=10)
    >>> noise = morris_noise(prob, X, np.full(len(X), 1.0))
    >>> 1.5 < noise["a"] < 3.5 and abs(noise["a"] / noise["b"] - 1) < 0.2
    True
    """
    X, se = np.asarray(design, float), np.asarray(errors, float)
    names, k = problem["names"], problem["num_vars"]
    span = np.array([hi - lo for lo, hi in problem["bounds"]], float)
    e = np.random.default_rng(seed).normal(size=(draws, len(X))) * se
    sums, counts = np.zeros((draws, k)), np.zeros(k)
    for t in range(len(X) // (k + 1)):
        for j in range(t * (k + 1), (t + 1) * (k + 1) - 1):
            step = (X[j + 1] - X[j]) / span
            f = int(np.argmax(np.abs(step)))
            sums[:, f] += np.abs(e[:, j + 1] - e[:, j]) / abs(step[f])
            counts[f] += 1
    return dict(zip(names, map(float, np.quantile(sums / counts, quantile, axis=0))))


def morris(problem: dict, design, outputs, levels: int = 4, seed: int = 0) -> dict:
    """The Morris screening of outputs (one per design row): μ* (the mean size of an unknown's elementary
    effects) and σ per unknown, ranked by μ*.

    >>> prob, X = morris_design({"a": (0, 1), "b": (0, 1), "c": (0, 1)}, trajectories=20)
    >>> ranks = morris(prob, X, 10 * X[:, 0] + X[:, 1] ** 2 + 0 * X[:, 2])
    >>> list(ranks)[0], list(ranks)[-1]
    ('a', 'c')
    """
    from SALib.analyze import morris as analyze
    res = analyze.analyze(problem, np.asarray(design), np.asarray(outputs, float), num_levels=levels, seed=seed)
    rows = {n: {"mu_star": float(m), "sigma": float(s)} for n, m, s in zip(problem["names"], res["mu_star"],
                                                                             res["sigma"])}
    return dict(sorted(rows.items(), key=lambda kv: -kv[1]["mu_star"]))
