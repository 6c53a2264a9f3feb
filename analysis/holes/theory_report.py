"""The `theory` subcommand: seed 001 Table 1 from eqs (1)-(5) under each reading and from the swept envelope,
beside the paper's numbers, and the Fig. 5, 6 and 8 analogs."""
from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from analysis.holes import theory
from analysis.core.config import Disk
from analysis.core.schema import ROOT
from analysis.core.io import atomic_csv, read_table, stamp

SLIPS = (0.0, 0.10, 0.20, 0.25)
DEPTHS = np.arange(5, 61, 5)


def readings(disk: Disk):
    """Every plausible reading of eqs (4), (5): δ reading × where the axis sits (H0) × sign of the advance."""
    for reading, h0_rule, sign in itertools.product(theory.READINGS, ("R-p", "R(1-δ)-p"), (1, -1)):
        def H0(slip, rule=h0_rule):
            return disk.H0 if rule == "R-p" else disk.R * (1 - slip) - disk.penetration
        yield f"{reading}, H0={h0_rule}, advance sign {'as printed' if sign == 1 else 'flipped'}", reading, H0, sign


def eq_row(disk, slip, reading, H0, sign):
    """L0 (eq 4 at H = 0) and l at DEPTHS (eq 4, else 5) for one reading."""
    h0 = H0(slip)
    return float(theory.length_eq4(0.0, disk, slip, h0, reading, sign)), theory.length_eqs(DEPTHS, disk, slip, h0, reading, sign)


def table1(disk: Disk, paper: pd.DataFrame | None):
    """Long table: one row per slip × quantity, with the paper, the printed equations, the best reading and the
    swept envelope, and their differences from the paper."""
    all_readings = list(readings(disk))
    rows, reading_rows = [], []
    for name, reading, H0, sign in all_readings:
        res = []
        for slip in SLIPS:
            L0, l = eq_row(disk, slip, reading, H0, sign)
            if paper is not None:
                p = paper.loc[slip]
                res.append(np.r_[L0, l] - np.r_[p["L0"], [p[f"l_{H}"] for H in DEPTHS]])
        if res:
            r = np.concatenate(res)
            reading_rows.append({"reading": name, "rms_mm": float(np.sqrt(np.nanmean(r ** 2))),
                                 "max_abs_mm": float(np.nanmax(np.abs(r))), "undefined_values": int(np.isnan(r).sum()),
                                 "L0_at_slip0_mm": eq_row(disk, 0.0, reading, H0, sign)[0]})
    best = min(reading_rows, key=lambda r: r["rms_mm"])["reading"] if reading_rows else all_readings[0][0]
    lookup = {name: (reading, H0, sign) for name, reading, H0, sign in all_readings}
    for slip in SLIPS:
        prof = theory.hole_profile(disk, slip)
        printed = eq_row(disk, slip, *lookup[all_readings[0][0]])
        chosen = eq_row(disk, slip, *lookup[best])
        quantities = [("L0", 0.0, printed[0], chosen[0], prof.L0),
                      ("L1", 0.0, disk.D, disk.D, prof.L1)]
        quantities += [(f"l_{H}", float(H), printed[1][i], chosen[1][i], float(prof.length_at(H)))
                       for i, H in enumerate(DEPTHS)]
        for q, H, e_print, e_best, env in quantities:
            ref = float(paper.loc[slip, q]) if paper is not None else np.nan
            rows.append({"slip": slip, "quantity": q, "H_mm": H, "paper_mm": ref,
                         "eqs_printed_mm": e_print, "eqs_best_reading_mm": e_best, "envelope_mm": env,
                         "eqs_printed_minus_paper": e_print - ref, "eqs_best_minus_paper": e_best - ref,
                         "envelope_minus_paper": env - ref})
    return pd.DataFrame(rows).round(2), pd.DataFrame(reading_rows).round(2), best


def plot_trajectories(disk: Disk, path: Path, note: str):
    """Fig. 5 analog: paths of the tip A and edges B, C (rigid punch) and the punch at a few instants."""
    fig, ax = plt.subplots(figsize=(7, 5))
    th = np.linspace(-1.2, 1.2, 801)
    for slip, ls in ((0.0, "-"), (0.25, "--")):
        y0 = disk.R - disk.H0                     # paper frame -> height above the surface
        for label, (x, y), c in (("A (eq 3)", theory.tip_path(th, disk, slip), "k"),
                                 ("B (eq 1)", theory.edge_path(th, disk, slip, "B"), "tab:red"),
                                 ("C (eq 2)", theory.edge_path(th, disk, slip, "C"), "tab:blue")):
            ax.plot(x, y - y0, ls, color=c, lw=1.2, label=f"{label}, δ={slip:g}")
    poly = theory.punch_section(disk)
    for t in np.linspace(-0.9, 0.9, 7):
        X, Y = theory.to_world(poly[:, 0], poly[:, 1], t, disk)
        ax.fill(X, Y, color="0.6", alpha=0.25, lw=0.5, ec="0.4")
    ax.axhline(0, color="saddlebrown", lw=1)
    ax.set(xlabel="x along travel (mm); the disk moves to -x", ylabel="height above undisturbed surface (mm)",
           title=f"Punch point paths ({disk.name}: R={disk.R:g}, D={disk.D:g}, h={disk.h:g})",
           xlim=(-160, 160), ylim=(-disk.penetration - 10, 60), aspect="equal")
    ax.legend(fontsize=7, ncol=2, loc="upper center")
    _save(fig, path, note)


def plot_contour(disk: Disk, paper, path: Path, note: str):
    """Fig. 6 analog: the swept-envelope hole beside the paper's a-b-o-c-d contour at δ = 0."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    prof = theory.hole_profile(disk, 0.0)
    ax.fill_betweenx(-prof.depth, prof.x_front, prof.x_rear, color="tab:orange", alpha=0.35,
                     label=f"swept envelope (L0 = {prof.L0:.1f} mm)")
    th = np.linspace(-1.2, 1.2, 2001)
    y0 = disk.R - disk.H0
    xb, yb = theory.edge_path(th[th < 0], disk, 0.0, "B")
    xa, ya = theory.tip_path(th, disk, 0.0)
    xc, yc = theory.edge_path(th[th > 0], disk, 0.0, "C")
    for (x, y), lab, c in (((xb, yb), "ab: edge B (eq 1)", "tab:red"), ((xa, ya), "bc: tip A (eq 3)", "k"),
                           ((xc, yc), "cd: edge C (eq 2)", "tab:blue")):
        keep = y - y0 <= 0
        ax.plot(x[keep], (y - y0)[keep], color=c, lw=1.2, label=lab)
    if paper is not None:
        p = paper.loc[0.0]
        half = np.r_[p["L0"], [p[f"l_{H}"] for H in DEPTHS]] / 2
        H = np.r_[0, DEPTHS]
        ax.plot(np.r_[-half, half], -np.r_[H, H], "o", ms=4, mfc="none", color="purple", label="seed 001 Table 1 (±l/2)")
    ax.axhline(0, color="saddlebrown", lw=1)
    ax.set(xlabel="x along travel (mm)", ylabel="height above undisturbed surface (mm)", aspect="equal",
           title="Hole contour at zero slip: rigid envelope vs eqs (1)-(3) vs Table 1")
    ax.legend(fontsize=7, loc="lower right")
    _save(fig, path, note)


def plot_slip(disk: Disk, table: pd.DataFrame, path: Path, note: str):
    """Fig. 8 analog: hole length against depth for each slip rate."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    colors = plt.cm.viridis(np.linspace(0, 0.85, len(SLIPS)))
    for slip, c in zip(SLIPS, colors):
        prof = theory.hole_profile(disk, slip)
        ax.plot(prof.depth, prof.length, "-", color=c, label=f"envelope δ={slip:g}")
        t = table[(table.slip == slip) & table.quantity.str.startswith("l_")]
        if t.paper_mm.notna().any():
            ax.plot(t.H_mm, t.paper_mm, "o", color=c, ms=4, label=f"Table 1 δ={slip:g}")
        ax.plot(t.H_mm, t.eqs_printed_mm, ":", color=c, lw=1)
    ax.plot([], [], "k:", lw=1, label="eqs (4)/(5) as printed")
    ax.set(xlabel="depth H below the undisturbed surface (mm)", ylabel="longitudinal hole length (mm)",
           title="Slip rate and hole length (Fig. 8 analog)")
    ax.legend(fontsize=7, ncol=2)
    _save(fig, path, note)


def _save(fig, path: Path, note: str):
    fig.text(0.005, 0.005, note, fontsize=6, color="0.4")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=130)
    plt.close(fig)
    tmp.replace(path)


def run(disk: Disk, out: Path, command: str) -> dict:
    """Write table1.csv, table1_readings.csv and the three plots for `disk` into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    paper = None
    if disk.name == "disk":                         # Table 1 belongs to the seed disk only
        paper = read_table(ROOT / "configs/field/table1.csv").set_index("slip")
    table, reads, best = table1(disk, paper)
    note = stamp(command)
    atomic_csv(table, out / "table1.csv", note)
    if len(reads):
        atomic_csv(reads.sort_values("rms_mm"), out / "table1_readings.csv", note)
    plot_trajectories(disk, out / "trajectories.png", note)
    plot_contour(disk, paper, out / "hole_contour.png", note)
    plot_slip(disk, table, out / "slip_length.png", note)
    return {"table": table, "readings": reads, "best": best}
