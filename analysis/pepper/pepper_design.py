"""Goal-attainment design of the duck-beak planting mechanism (seed 000 §3) and its report (results/pepper/).

The paper calls MATLAB's fgoalattain: minimise γ subject to F_i(x) - w_i·γ <= F*_i. Its three goals are two-sided
targets (lateral spread under the ridge → 0, depth 100 mm, trajectory height 230 mm), so here
γ(x) = max_i |F_i(x) - F*_i| / w_i, minimised over the seven design variables of §3.1.3 inside Table 2's
ranges, subject to the dead-point constraint of §3.1.2 (eqs 13, 16 give F). scipy's SLSQP solves the
equivalent smooth problem in (x, γ) from Table 2's initial column, then from a few perturbed starts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from analysis.core.schema import read_toml, ConfigError
from analysis.pepper.pepper import (ANGLES, SPREAD_READINGS, Linkage, assembly_margin, bottom_window, check_travel_sign,
                             dead_point_margin, linkage_to_config, load_linkage, motion, solve, trajectory,
                             trajectory_metrics)

VARIABLES = ("L1", "L2", "L4", "L5", "L6", "L8", "beta")
GOAL_NAMES = ("spread", "depth", "height")
DRAWS = 200            # random draws allowed per random start of the design
MARGIN_TOL = 0.05      # mm: how far past a margin the optimiser's last step may end and still count as feasible


@dataclass(frozen=True)
class Goals:
    target: tuple          # F*: spread, depth, height (mm)
    weight: tuple          # w, mm per unit γ
    dead_point_margin: float
    assembly_margin: float
    speed: float           # mm/s
    omega: float           # rad/s
    sign: int = 1          # eq 16's travel sign (analysis/pepper/pepper.py TRAVEL_SIGNS)
    spread_reading: str = "gap"    # analysis/pepper/pepper.py SPREAD_READINGS


def load_goals(path="configs/pepper.toml") -> Goals:
    data = read_toml(path)
    g, op = data["goals"], data["operation"]
    for k in ("target", "weight"):
        if len(g[k]) != 3 or (k == "weight" and min(g[k]) <= 0):
            raise ConfigError(f"{path}: goals.{k} = {g[k]!r}: allowed three numbers (spread, depth, height)"
                              + (", each > 0" if k == "weight" else ""))
    if g["spread_reading"] not in SPREAD_READINGS:
        raise ConfigError(f"{path}: goals.spread_reading = {g['spread_reading']!r}: allowed "
                          f"{', '.join(SPREAD_READINGS)}")
    return Goals(tuple(map(float, g["target"])), tuple(map(float, g["weight"])), float(g["dead_point_margin"]),
                 float(g["assembly_margin"]),
                 speed=1000.0 * op["speed"], omega=2 * math.pi * op["plants_per_min"] / 60.0,
                 sign=check_travel_sign(op["travel_sign"]), spread_reading=g["spread_reading"])


def ranges(path="configs/pepper.toml") -> np.ndarray:
    """Table 2's design ranges as (lo, hi) rows in VARIABLES' order, β in rad."""
    r = read_toml(path)["range"]
    return np.array([[math.radians(v) for v in r[k]] if k in ANGLES else r[k] for k in VARIABLES], float)


def with_values(link: Linkage, x) -> Linkage:
    return replace(link, **dict(zip(VARIABLES, map(float, x))))


def values(link: Linkage) -> np.ndarray:
    return np.array([getattr(link, k) for k in VARIABLES], float)


def goal_values(link: Linkage, goals: Goals, n: int = 1441) -> np.ndarray:
    """F(x) = (spread, depth, height) of P's moving trajectory (eq 16); ValueError if it cannot move or its
    path has no loop at the bottom (no ridge surface to measure the depth and spread from)."""
    m = trajectory_metrics(link, goals.speed, goals.omega, n, sign=goals.sign, spread=goals.spread_reading)
    if not m["crossed"]:
        raise ValueError("pepper: P's moving path has no loop at the bottom")
    return np.array([m["spread"], m["depth"], m["height"]])


def attainment(F, goals: Goals) -> float:
    """γ = max_i |F_i - F*_i| / w_i: the worst goal miss in units of its weight."""
    return float(np.max(np.abs(np.asarray(F) - goals.target) / goals.weight))


def margins(link: Linkage, n: int = 721) -> tuple[float, float]:
    """(dead-point margin, assembly margin) over one crank turn, mm; ValueError if it cannot be assembled."""
    th = np.linspace(0, 2 * np.pi, n)
    return dead_point_margin(link, solve(link, th)), assembly_margin(link, th)


def feasible(m: tuple[float, float], goals: Goals, tol: float = 0.0) -> bool:
    return m[0] >= goals.dead_point_margin - tol and m[1] >= goals.assembly_margin - tol


@dataclass
class Design:
    link: Linkage
    F: np.ndarray
    gamma: float
    margins: tuple
    evaluations: int
    starts: int


def design(start: Linkage, goals: Goals, bounds: np.ndarray, starts: int = 6, seed: int = 1,
           n: int = 1441) -> Design:
    """Goal attainment from `start` (and `starts - 1` random starts inside `bounds`, each drawn (seeded) until it
    assembles, loops under the ridge and clears the margins): the feasible design with the smallest γ.
    Infeasible points (unassemblable, dead point, no loop) are kept out by the constraints."""
    from scipy.optimize import minimize
    lo, hi = bounds[:, 0], bounds[:, 1]
    scale = hi - lo
    count = {"n": 0}
    cache = {}

    def F_of(z):
        key = z.tobytes()
        if key not in cache:
            count["n"] += 1
            link = with_values(start, lo + z * scale)
            try:
                cache[key] = (goal_values(link, goals, n), margins(link))
            except ValueError:
                cache[key] = (None, (-1.0, -1.0))
        return cache[key]

    def cons(v):
        z, g = v[:-1], v[-1]
        F, mg = F_of(z)
        if F is None:
            return -np.ones(8) * 1e3
        w = np.array(goals.weight)
        dev = F - goals.target
        return np.concatenate([w * g - dev, w * g + dev, [mg[0] - goals.dead_point_margin,
                                                          mg[1] - goals.assembly_margin]])

    def usable(z):
        F, mg = F_of(z)
        return F is not None and feasible(mg, goals)

    rng = np.random.default_rng(seed)
    z0s = [np.clip((values(start) - lo) / scale, 0, 1)]
    for _ in range(DRAWS * (starts - 1)):          # random starts that assemble, loop and clear the margins:
        if len(z0s) == starts:                      # most of Table 2's box does not
            break
        z = rng.uniform(0.05, 0.95, len(VARIABLES))
        if usable(z):
            z0s.append(z)
    best = None
    for z0 in z0s:
        F0, _ = F_of(z0)
        if F0 is None:
            continue
        v0 = np.append(z0, attainment(F0, goals))
        res = minimize(lambda v: v[-1], v0, method="SLSQP", constraints=[{"type": "ineq", "fun": cons}],
                       bounds=[(0, 1)] * len(VARIABLES) + [(0, None)], options={"maxiter": 200, "ftol": 1e-6})
        z = np.clip(res.x[:-1], 0, 1)
        F, mg = F_of(z)
        if F is None or not feasible(mg, goals, MARGIN_TOL):      # SLSQP ends on an active margin, a hair over
            continue
        gamma = attainment(F, goals)
        if best is None or gamma < best[0]:
            best = (gamma, z, F, mg)
    if best is None:
        raise ValueError("pepper design: no start reached a feasible linkage (assemblable, clear of dead points)")
    gamma, z, F, mg = best
    link = with_values(start, lo + z * scale)
    F = goal_values(link, goals, 3601)
    return Design(link, F, attainment(F, goals), margins(link, 3601), count["n"], len(z0s))


# --- results/pepper/: the design table and the Figs. 3-6 analogs -----------------------------------------------

PAPER = {"initial": (21.6, 102.1, 265.0), "designed": (8.3, 97.54, 233.0)}    # §4.1: spread, depth, height (mm)


def table(columns: dict, goals: Goals):
    """One row per design variable and per goal: every column's value, the paper's simulated results beside."""
    import pandas as pd
    rows = []
    for k in VARIABLES:
        rows.append({"quantity": k, "unit": "deg" if k in ANGLES else "mm",
                     **{c: linkage_to_config(link)[k] for c, (link, _) in columns.items()}})
    for i, name in enumerate(GOAL_NAMES):
        rows.append({"quantity": name, "unit": "mm", "goal": goals.target[i],
                     **{c: F[i] for c, (_, F) in columns.items()},
                     "paper_initial": PAPER["initial"][i], "paper_designed": PAPER["designed"][i]})
    rows.append({"quantity": "gamma", "unit": "mm", **{c: attainment(F, goals) for c, (_, F) in columns.items()}})
    return pd.DataFrame(rows)


def plot(columns: dict, goals: Goals, out, note: str):
    """trajectories.png (static and moving, Figs. 3-4), displacement.png (Fig. 5), motion.png (Fig. 6)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    written = []
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 5.2), layout="constrained")
    for (c, (link, F)), colour in zip(columns.items(), ("C0", "C1", "C2")):
        _, P, _ = trajectory(link, goals.speed, goals.omega, sign=goals.sign)
        a.plot(P.real, P.imag, color=colour, label=c)
        _, Z, _ = bottom_window(link, goals.speed, goals.omega, 1441, sign=goals.sign)
        m = trajectory_metrics(link, goals.speed, goals.omega, sign=goals.sign, spread=goals.spread_reading)
        x0 = m["x_III"] if m["crossed"] else Z.real[len(Z) // 2]
        b.plot(Z.real - x0, Z.imag, color=colour,
               label=f"{c}: spread {F[0]:.1f}, depth {F[1]:.1f}, height {F[2]:.1f}")
        if m["crossed"]:
            b.plot([0], [m["ground"]], "o", color=colour, ms=4)
            b.axhline(m["ground"], color=colour, lw=0.6, ls=":")
    sense = "+vt as printed" if goals.sign > 0 else "-vt, §2's direction"
    for ax, title in ((a, "(a) static trajectory of P (one crank turn)"),
                      (b, f"(b) moving trajectory (eq 16, {sense}), a turn either side of the bottom\n"
                          f"x from the crossing III (dot); dotted: the ridge surface")):
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x, mm")
        ax.set_ylabel("y, mm")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    b.legend(fontsize=7, loc="upper right")
    fig.suptitle(note, fontsize=8)
    written.append(out / "trajectories.png")
    fig.savefig(written[-1], dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for c, (link, _) in columns.items():
        th = np.linspace(0, 2 * np.pi, 721)
        s, dP, ddP = motion(link, th, goals.omega)
        t = th / goals.omega
        axes[0].plot(t, s["P"].imag - s["P"].imag.min(), label=f"{c}: y")
        axes[0].plot(t, s["P"].real + goals.sign * goals.speed * t - s["P"].real[0], ls="--", label=f"{c}: x (moving)")
        axes[1].plot(t, (dP.real + goals.sign * goals.speed) / 1000, label=f"{c}: vx")
        axes[1].plot(t, dP.imag / 1000, ls="--", label=f"{c}: vy")
        axes[2].plot(t, ddP.real / 1000, label=f"{c}: ax")
        axes[2].plot(t, ddP.imag / 1000, ls="--", label=f"{c}: ay")
    for ax, lab in zip(axes, ("displacement, mm", "velocity, m/s (ground frame)", "acceleration, m/s²")):
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=3)
    axes[-1].set_xlabel("t, s (one crank turn)")
    fig.suptitle(note, fontsize=8)
    fig.tight_layout()
    written.append(out / "motion.png")
    fig.savefig(written[-1], dpi=120)
    plt.close(fig)
    return written


def run(out, command: str, starts: int = 6, path="configs/pepper.toml"):
    """Design from Table 2's initial column; write design.csv and the plots into `out`."""
    from analysis.core.io import atomic_csv, stamp
    out.mkdir(parents=True, exist_ok=True)
    goals, bounds = load_goals(path), ranges(path)
    start, paper = load_linkage("initial", path), load_linkage("designed", path)
    result = design(start, goals, bounds, starts=starts)
    columns = {"initial": (start, goal_values(start, goals, 3601)),
               "table2_designed": (paper, goal_values(paper, goals, 3601)),
               "goal_attainment": (result.link, result.F)}
    note = stamp(command)
    t = table(columns, goals)
    atomic_csv(t.round(3), out / "design.csv", note)
    return result, t, [out / "design.csv", *plot(columns, goals, out, note)]
