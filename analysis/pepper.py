"""Kinematics of the pepper transplanter's multi-bar duck-beak planting mechanism (seed 000, eqs 1-16).

Points in the plane (mm), A at the origin, as complex numbers x + iy. The crank AB (L1) turns at θ1; the rod
BD (L2) slides and swings in the guide C fixed at L3∠θ3 (eqs 1, 3, 4); D also hangs from the frame through
DE (L4), the body EF (L5, fixed direction θ5: the parallelogram FGHI keeps body EFIJ from turning) and the
rocker FG (L6) about G = L14∠α (eqs 2, 7-13); M = D + L8∠θ4 (eq 14) and the planter tip P = M + L7∠(θ4 + β)
(eq 15, with β the angle between DM and MP as Table 1 defines it; the printed eq 15 writes cos β for
cos θ7). Moving trajectory (eq 16): the machine travels at v along -x, as §2 states (eq 16 prints + vt).

Printed slips, corrected here and noted in the README: eq (4)'s θ2 = 2 arctan(...) does not follow from
eq (3) (the rod passes through the guide, so θ2 = arg(C - B)); eq (13)'s A2 and B2 are swapped (the
coefficient of sin θ4 is -2·L4·b).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from analysis.config import ConfigError, read_toml


@dataclass(frozen=True)
class Linkage:
    L1: float
    L2: float
    L4: float
    L5: float
    L6: float
    L8: float
    beta: float        # rad, MP from DM
    L3: float
    theta3: float      # rad
    L14: float
    alpha: float       # rad
    theta5: float      # rad
    L7: float
    branch: int = 1    # the ± of eq (13)


ANGLES = ("beta", "theta3", "alpha", "theta5")     # Linkage fields in radians, in degrees in configs and results


def linkage_from_config(values: dict) -> Linkage:
    """A Linkage from lengths in mm and ANGLES in degrees (configs/pepper.toml, a scene's config.json)."""
    return Linkage(**{k: (math.radians(v) if k in ANGLES else v) for k, v in values.items()})


def linkage_to_config(link: Linkage) -> dict:
    """The inverse of linkage_from_config."""
    return {k: (math.degrees(v) if k in ANGLES else v) for k, v in asdict(link).items()}


def load_linkage(column: str = "designed", path="configs/pepper.toml", **changes) -> Linkage:
    """Table 2's `initial` or `designed` column with the frame of [frame]; angles converted to radians."""
    data = read_toml(path)
    if column not in ("initial", "designed"):
        raise ConfigError(f"pepper column = {column!r}: allowed initial, designed")
    return replace(linkage_from_config({**data[column], **data["frame"]}), **changes)


def u(angle):
    return np.exp(1j * np.asarray(angle, float))


def crank_guide(link: Linkage, theta1):
    """The crank-guide group at crank angles θ1: θ1 (array), B, C, θ2 and D (eqs 3, 4, 6, 10)."""
    th1 = np.atleast_1d(np.asarray(theta1, float))
    B = link.L1 * u(th1)                                     # eq (6)
    C = link.L3 * u(link.theta3)
    th2 = np.angle(C - B)                                    # eqs (3)-(4): the rod passes through C
    return th1, B, C, th2, B + link.L2 * u(th2)              # eq (10)


def chain_span(link: Linkage, D):
    """D - G - L5∠θ5 (eq 12's a + ib): what the links DE (L4) and FG (L6) must bridge."""
    return D - link.L14 * u(link.alpha) - link.L5 * u(link.theta5)     # G from eq (7)


def solve(link: Linkage, theta1):
    """Every point and angle at crank angles θ1 (rad, array). Raises ValueError where the linkage cannot be
    assembled (eq 13 has no real root) or the rod BD would leave the guide."""
    th1, B, C, th2, D = crank_guide(link, theta1)
    BC = np.abs(C - B)
    if np.any(BC >= link.L2) or np.any(BC < 1e-9):
        raise ValueError(f"pepper linkage: rod BD (L2 = {link.L2:g} mm) does not reach past the guide C "
                         f"(|BC| up to {BC.max():.1f} mm)")
    G = link.L14 * u(link.alpha)                             # eq (7)
    w = chain_span(link, D)
    a, b = w.real, w.imag
    A2, B2, C2 = -2 * link.L4 * b, -2 * link.L4 * a, a * a + b * b + link.L4 ** 2 - link.L6 ** 2   # eq (13)
    disc = A2 * A2 + B2 * B2 - C2 * C2
    if np.any(disc < 0):
        bad = math.degrees(float(th1[np.argmax(disc < 0)]))
        raise ValueError(f"pepper linkage cannot be assembled at θ1 = {bad:.1f}°: |D - G - L5∠θ5| leaves "
                         f"[|L6 - L4|, L6 + L4] = [{abs(link.L6 - link.L4):g}, {link.L6 + link.L4:g}] mm")
    th4 = 2 * np.arctan2(A2 + link.branch * np.sqrt(disc), B2 - C2)
    E = D - link.L4 * u(th4)
    th6 = np.angle(E - link.L5 * u(link.theta5) - G)
    F = G + link.L6 * u(th6)                                 # eq (8)
    M = D + link.L8 * u(th4)                                 # eq (14)
    P = M + link.L7 * u(th4 + link.beta)                     # eq (15)
    return {"theta1": th1, "theta2": th2, "theta4": th4, "theta6": th6, "B": B, "C": C, "D": D, "E": E,
            "F": F, "G": G, "M": M, "P": P}


def closure_residual(link: Linkage, s: dict) -> np.ndarray:
    """|eq (11)|: L1∠θ1 + L2∠θ2 - (L14∠α + L6∠θ6 + L5∠θ5 + L4∠θ4), and the rod's miss of the guide."""
    loop = (link.L1 * u(s["theta1"]) + link.L2 * u(s["theta2"])
            - (link.L14 * u(link.alpha) + link.L6 * u(s["theta6"]) + link.L5 * u(link.theta5)
               + link.L4 * u(s["theta4"])))
    miss = np.imag((s["C"] - s["B"]) * np.conj(u(s["theta2"])))
    return np.maximum(np.abs(loop), np.abs(miss))


def assembly_margin(link: Linkage, theta1) -> float:
    """min over θ1 of how far |D - G - L5∠θ5| stays inside [|L6 - L4|, L6 + L4] (mm; negative: eq 13 has no
    root somewhere). A few millimetres mean the chain D-E-F-G nearly folds flat (a toggle)."""
    w = np.abs(chain_span(link, crank_guide(link, theta1)[4]))
    return float(np.min(np.minimum(w - abs(link.L6 - link.L4), link.L6 + link.L4 - w)))


def dead_point_margin(link: Linkage, s: dict) -> float:
    """min over the cycle of the distance of L_BE from the ends of (L_BD - L_DE, L_BD + L_DE), §3.1.2;
    negative when the constraint is broken."""
    BE = np.abs(s["E"] - s["B"])
    return float(np.min(np.minimum(BE - abs(link.L2 - link.L4), link.L2 + link.L4 - BE)))


def motion(link: Linkage, theta1, omega: float):
    """Analytic velocity and acceleration of P (mm/s, mm/s²) at constant crank rate ω (rad/s), in the
    machine's frame: the time derivatives of eq (15) (the moving frame adds -v to the x velocity)."""
    s = solve(link, theta1)
    zB = s["B"]
    dB, ddB = 1j * omega * zB, -omega ** 2 * zB
    r = s["C"] - zB
    dr, ddr = -dB, -ddB
    q = dr / r
    w2 = q.imag                                              # θ2'
    a2 = (ddr / r - q * q).imag                              # θ2''
    e2, e4, e6 = u(s["theta2"]), u(s["theta4"]), u(s["theta6"])
    dD = dB + 1j * link.L2 * w2 * e2
    ddD = ddB + link.L2 * (1j * a2 - w2 ** 2) * e2
    # D - const = L6∠θ6 + L4∠θ4  →  dD = i L6 θ6' e6 + i L4 θ4' e4 (2×2 real system per instant)
    c6, c4 = 1j * link.L6 * e6, 1j * link.L4 * e4
    det = c6.real * c4.imag - c6.imag * c4.real

    def rates(rhs):
        """(θ6 term, θ4 term) with rhs = c6·x6 + c4·x4, x real (Cramer's rule per instant)."""
        return ((rhs.real * c4.imag - rhs.imag * c4.real) / det, (c6.real * rhs.imag - c6.imag * rhs.real) / det)
    w6, w4 = rates(dD)
    _, a4 = rates(ddD + link.L6 * w6 ** 2 * e6 + link.L4 * w4 ** 2 * e4)
    eP = u(s["theta4"] + link.beta)
    dP = dD + 1j * w4 * (link.L8 * e4 + link.L7 * eP)
    ddP = ddD + (1j * a4 - w4 ** 2) * (link.L8 * e4 + link.L7 * eP)
    return s, dP, ddP


def trajectory(link: Linkage, speed_mm_s: float, omega: float, n: int = 3601, theta1_0: float = 0.0):
    """One crank turn of P: static points and the moving trajectory (eq 16, the machine going along -x)."""
    th = theta1_0 + np.linspace(0, 2 * np.pi, n)
    s = solve(link, th)
    t = (th - theta1_0) / omega
    return t, s["P"], s["P"] - speed_mm_s * t


def _monotone_branch(Y, i_min, step):
    """Indices walking from the lowest point (cyclically, by `step` = ±1) while the height keeps rising."""
    n = len(Y)
    idx = [i_min]
    while len(idx) < n - 1:
        j = (idx[-1] + step) % n
        if Y[j] < Y[idx[-1]]:
            break
        idx.append(j)
    return np.array(idx)


def trajectory_metrics(link: Linkage, speed_mm_s: float, omega: float, n: int = 3601) -> dict:
    """§3.1.1's three goals on the moving trajectory of P (eq 16), in mm:
    - height: highest minus lowest point (goal 230);
    - depth: lowest point II up to point III where the entry and exit paths cross (the ridge surface; goal
      100); if they do not cross, III is where they come closest;
    - spread: the largest horizontal distance between the entry and exit paths below III (goal 0);
    - ground: III's level, the ridge surface, in the mechanism's frame."""
    _, _, Z = trajectory(link, speed_mm_s, omega, n)
    Z = Z[:-1]                                   # one period, the last point repeats the first
    X, Y = Z.real, Z.imag
    i_min = int(np.argmin(Y))
    entry = _monotone_branch(Y, i_min, -1)
    exit_ = _monotone_branch(Y, i_min, +1)
    top = min(Y[entry].max(), Y[exit_].max())
    levels = np.linspace(Y[i_min], top, 400)[1:]
    xe = np.interp(levels, Y[entry], X[entry])
    xx = np.interp(levels, Y[exit_], X[exit_])
    gap = xx - xe
    cross = np.flatnonzero(np.sign(gap[1:]) != np.sign(gap[:-1]))
    if len(cross):
        k = cross[0]
        y3 = levels[k] - gap[k] * (levels[k + 1] - levels[k]) / (gap[k + 1] - gap[k])
    else:
        k = int(np.argmin(np.abs(gap)))
        y3 = levels[k]
    below = levels <= y3
    spread = float(np.max(np.abs(gap[below]))) if below.any() else 0.0
    return {"height": float(Y.max() - Y.min()), "depth": float(y3 - Y[i_min]), "spread": spread,
            "crossed": bool(len(cross)), "ground": float(y3)}


def check_dead_point(link: Linkage, s: dict, tol: float = 1.0):
    """§3.1.2: L_BD - L_DE < L_BE < L_BD + L_DE along the whole cycle, with `tol` mm to spare (B, D, E
    always form a triangle, so the margin is never negative; zero is a dead point)."""
    margin = dead_point_margin(link, s)
    if margin < tol:
        raise ValueError(f"pepper linkage passes within {margin:.2f} mm of a dead point "
                         f"(L_BE reaches L_BD ± L_DE); allowed margin >= {tol:g} mm")
    return margin


def pose(link: Linkage, speed_mm_s: float, omega: float, t, y_ground: float):
    """P on the ground's frame at times t (s) from θ1 = 0 (eq 16: x along -v from a point fixed in the ground,
    y up from the ridge surface), and θ4, the angle of the body DM that carries the planter (mm, rad)."""
    t = np.asarray(t, float)
    s = solve(link, omega * t)
    Z = s["P"] - speed_mm_s * t
    return Z.real, Z.imag - y_ground, s["theta4"]


def beak_axis(theta4, theta4_bottom: float):
    """The beak's axis, tip-wards, as an angle ψ from +x (rad): rigid on the body DM (it turns with θ4), and
    pointing straight down at P's lowest point, since the text gives no angle between DM and the beak."""
    return np.asarray(theta4, float) - theta4_bottom - math.pi / 2


@dataclass(frozen=True)
class PlanterPass:
    """The planter's pass through the soil: from t_in, its tip going down `clearance` above the ridge
    surface (point III's level), through its lowest point at t_bottom, to t_out, as high again going up."""
    t_in: float
    t_bottom: float
    t_out: float
    y_ground: float      # the ridge surface in the mechanism's frame (mm)
    depth: float         # the tip's lowest point below the surface (mm)
    x_bottom: float      # P's x there, ground frame (mm)
    theta4_bottom: float


def planter_pass(link: Linkage, speed_mm_s: float, omega: float, clearance: float, n: int = 7201) -> PlanterPass:
    """Find the pass on two crank turns sampled at n points per turn (it may straddle θ1 = 0)."""
    y_ground = trajectory_metrics(link, speed_mm_s, omega)["ground"]
    t = np.linspace(0.0, 4 * np.pi, 2 * n - 1) / omega
    x, y, th4 = pose(link, speed_mm_s, omega, t, y_ground)
    half = (n - 1) // 2
    i_min = half + int(np.argmin(y[half:half + n]))            # the lowest point of one turn, inside the window
    before, after = np.flatnonzero(y[:i_min] > clearance), np.flatnonzero(y[i_min:] > clearance)
    if not len(before) or not len(after):
        raise ValueError(f"pepper planter: the tip never rises {clearance:g} mm above the ridge surface")
    return PlanterPass(float(t[before[-1]]), float(t[i_min]), float(t[i_min + after[0]]), y_ground,
                       float(-y[i_min]), float(x[i_min]), float(th4[i_min]))
