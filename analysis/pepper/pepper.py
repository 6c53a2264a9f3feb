"""Kinematics of the pepper transplanter's multi-bar duck-beak planting mechanism (seed 000, eqs 1-16).

Points in the plane (mm), A at the origin, as complex numbers x + iy. The crank AB (L1) turns at θ1; the rod
BD (L2) slides and swings in the guide C fixed at L3∠θ3 (eqs 1, 3, 4); D also hangs from the frame through
DE (L4), the body EF (L5, fixed direction θ5: the parallelogram FGHI keeps body EFIJ from turning) and the
rocker FG (L6) about G = L14∠α (eqs 2, 7-13); M = D + L8∠θ4 (eq 14) and the planter tip P = M + L7∠(θ4 + β)
(eq 15, with β the angle between DM and MP as Table 1 defines it; the printed eq 15 writes cos β for
cos θ7). The crank turns counter-clockwise (§2). Moving trajectory (eq 16): X = x + sign·v·t. Eq 16 prints
+vt (sign = +1), but §2 says the machine moves along -x, which gives -vt: the text is inconsistent, so the
sign is a setting ([operation] travel_sign in configs/pepper.toml) and the frame search tries both.

Printed slips, corrected here and noted in the README: eq (4)'s θ2 = 2 arctan(...) does not follow from
eq (3) (the rod passes through the guide, so θ2 = arg(C - B)); eq (13)'s A2 and B2 are swapped (the
coefficient of sin θ4 is -2·L4·b).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from analysis.core.schema import read_toml, ConfigError


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
    machine's frame: the time derivatives of eq (15) (the ground frame of eq 16 adds sign·v to the x velocity)."""
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


TRAVEL_SIGNS = {+1: "eq 16 as printed: X = x + vt", -1: "§2: the machine moves along -x, X = x - vt"}
SPREAD_READINGS = {"gap": "the widest horizontal gap between the entry and exit paths at one level below III",
                   "width": "the horizontal extent of P's path below III (the abstract's 'maximum transverse "
                            "distance of the track under the ridge surface')"}


def check_travel_sign(sign) -> int:
    if sign not in TRAVEL_SIGNS:
        raise ConfigError(f"pepper travel_sign = {sign!r}: allowed +1 (eq 16 as printed) or -1 (§2's direction)")
    return int(sign)


def moving_path(link: Linkage, speed_mm_s: float, omega: float, t, sign: int = +1, theta1_0: float = 0.0):
    """P's moving trajectory (eq 16) at times t (s): the static point at crank angle θ1 = θ1_0 + ωt (the crank
    turns counter-clockwise, §2) plus sign·v·t. Eq 16 prints +vt (sign = +1); §2 says the machine moves
    along -x, which makes it -vt (sign = -1): the paper is inconsistent, so both are kept (TRAVEL_SIGNS)."""
    t = np.asarray(t, float)
    return solve(link, theta1_0 + omega * t)["P"] + sign * speed_mm_s * t


def trajectory(link: Linkage, speed_mm_s: float, omega: float, n: int = 3601, theta1_0: float = 0.0,
               sign: int = +1):
    """One crank turn of P from θ1_0: times, static points and the moving trajectory (eq 16)."""
    t = np.linspace(0, 2 * np.pi, n) / omega
    s = solve(link, theta1_0 + omega * t)
    return t, s["P"], s["P"] + sign * speed_mm_s * t


def _boxes(Z, block):
    """Bounding boxes (xmin, xmax, ymin, ymax) of the polyline Z's segments taken `block` at a time."""
    idx = np.arange(0, len(Z) - 1, block)

    def ends(f, v):
        return f(f.reduceat(v[:-1], idx), f.reduceat(v[1:], idx))
    return ends(np.minimum, Z.real), ends(np.maximum, Z.real), ends(np.minimum, Z.imag), ends(np.maximum, Z.imag)


def crossings(A, B, block: int = 32):
    """Every point where polyline A crosses polyline B (complex arrays): rows (i + s, j + u), A's and B's
    fractional sample indices, with A[i] + s·(A[i+1] - A[i]) = B[j] + u·(B[j+1] - B[j]), 0 <= s, u < 1.
    Blocks of segments whose bounding boxes do not overlap are skipped, so a long path costs little.

    >>> crossings(np.array([0, 2 + 2j]), np.array([2, 2j]))
    array([[0.5, 0.5]])
    """
    A, B = np.asarray(A, complex), np.asarray(B, complex)
    ax0, ax1, ay0, ay1 = _boxes(A, block)
    bx0, bx1, by0, by1 = _boxes(B, block)
    pairs = np.argwhere((ax0[:, None] <= bx1[None]) & (bx0[None] <= ax1[:, None])
                        & (ay0[:, None] <= by1[None]) & (by0[None] <= ay1[:, None]))
    out = []
    for p, q in pairs:
        i = np.arange(p * block, min((p + 1) * block, len(A) - 1))[:, None]
        j = np.arange(q * block, min((q + 1) * block, len(B) - 1))[None, :]
        r, d, w = A[i + 1] - A[i], B[j + 1] - B[j], B[j] - A[i]
        den = (r.real * d.imag - r.imag * d.real)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (w.real * d.imag - w.imag * d.real) / den
            v = (w.real * r.imag - w.imag * r.real) / den
        hit = (den != 0) & (s >= 0) & (s < 1) & (v >= 0) & (v < 1)
        ii, jj = np.nonzero(hit)
        out += [(i[k, 0] + s[k, m], j[0, m] + v[k, m]) for k, m in zip(ii, jj)]
    return np.array(sorted(out), float).reshape(-1, 2)


def _level_x(Z, levels):
    """Each level's lowest and highest x where the polyline Z crosses it (nan where it does not)."""
    y0, y1 = Z.imag[:-1][None], Z.imag[1:][None]
    L = np.asarray(levels)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = (L - y0) / (y1 - y0)
    x = np.where((f >= 0) & (f <= 1), Z.real[:-1][None] + f * (Z.real[1:] - Z.real[:-1])[None], np.nan)
    return np.nanmin(x, axis=1), np.nanmax(x, axis=1)


def trajectory_metrics(link: Linkage, speed_mm_s: float, omega: float, n: int = 3601, theta1_0: float = 0.0,
                       sign: int = +1, spread: str = "gap") -> dict:
    """§3.1.1's three goals on the moving trajectory of P (eq 16), in mm, on the continuous path (no wrap):
    - height: highest minus lowest point (goal 230);
    - depth: the lowest point II up to III, where the exit path first crosses the entry path (the ridge
      surface; goal 100): a true self-intersection of the path within one crank turn round II;
    - spread: below III, by the reading `spread` (SPREAD_READINGS; goal 0);
    - ground: III's level, the ridge surface, in the mechanism's frame (x_III: III's x on the path).
    A path with no loop at the bottom has no III: crossed is False and depth, spread and ground are nan.
    `n` samples per crank turn; θ1_0 only moves the path along x, so no metric depends on it."""
    if spread not in SPREAD_READINGS:
        raise ConfigError(f"pepper spread reading = {spread!r}: allowed {', '.join(SPREAD_READINGS)}")
    _, Z, height = bottom_window(link, speed_mm_s, omega, n, theta1_0, sign)
    return {**loop_metrics(Z, spread), "height": height}


def bottom_window(link: Linkage, speed_mm_s: float, omega: float, n: int = 3601, theta1_0: float = 0.0,
                  sign: int = +1):
    """P's moving path (eq 16) sampled n times per crank turn, one turn either side of its lowest point II
    (the middle sample): (times, path, height of one turn's path)."""
    T = 2 * np.pi / omega
    t1 = np.arange(n) * T / n
    Y1 = solve(link, theta1_0 + omega * t1)["P"].imag
    t = t1[int(np.argmin(Y1))] + np.arange(-n, n + 1) * T / n
    return t, moving_path(link, speed_mm_s, omega, t, sign, theta1_0), float(Y1.max() - Y1.min())


def loop_metrics(Z, spread: str = "gap") -> dict:
    """Depth, spread and ground (III's level) of a moving path Z sampled evenly over one crank turn either
    side of its lowest point II, which is its middle sample (see trajectory_metrics); nan and crossed False
    where the exit path never meets the entry path within one turn. The height of Z is reported too."""
    n = (len(Z) - 1) // 2
    entry, exit_ = Z[:n + 1], Z[n:]
    out = {"height": float(Z.imag.max() - Z.imag.min()), "depth": math.nan, "spread": math.nan, "crossed": False,
           "ground": math.nan, "x_III": math.nan}
    c = crossings(entry, exit_)
    c = c[c[:, 1] <= c[:, 0]]      # within one crank turn: entry sample a is at a - n, exit b at b; b - (a - n) <= n
    if not len(c):
        return out
    a, b = c[np.argmin(c[:, 1])]                             # where the exit first meets the entry
    ia, ib = int(a), int(b)
    III = entry[ia] + (a - ia) * (entry[ia + 1] - entry[ia])
    y_min, y3 = float(Z.imag[n]), float(III.imag)
    loop_in = np.append(III, entry[ia + 1:])                 # III down to II ...
    loop_out = np.append(exit_[:ib + 1], III)                # ... and back up to III
    if spread == "gap":
        levels = np.linspace(y_min, y3, 202)[1:-1]
        (ein, eax), (xin, xax) = _level_x(loop_in, levels), _level_x(loop_out, levels)
        width = np.nanmax(np.abs(np.concatenate([xax - ein, eax - xin])))
    else:
        loop = np.concatenate([loop_in, loop_out])
        below = loop[loop.imag <= y3]
        width = below.real.max() - below.real.min()
    out.update(depth=y3 - y_min, spread=float(width), crossed=True, ground=y3, x_III=float(III.real))
    return out


def check_dead_point(link: Linkage, s: dict, tol: float = 1.0):
    """§3.1.2: L_BD - L_DE < L_BE < L_BD + L_DE along the whole cycle, with `tol` mm to spare (B, D, E
    always form a triangle, so the margin is never negative; zero is a dead point)."""
    margin = dead_point_margin(link, s)
    if margin < tol:
        raise ValueError(f"pepper linkage passes within {margin:.2f} mm of a dead point "
                         f"(L_BE reaches L_BD ± L_DE); allowed margin >= {tol:g} mm")
    return margin


def pose(link: Linkage, speed_mm_s: float, omega: float, t, y_ground: float, sign: int = +1):
    """P on the ground's frame at times t (s) from θ1 = 0 (eq 16 with travel sign `sign`: x from a point fixed
    in the ground, y up from the ridge surface), and θ4, the angle of the body DM that carries the planter
    (mm, rad)."""
    t = np.asarray(t, float)
    s = solve(link, omega * t)
    Z = s["P"] + sign * speed_mm_s * t
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


def planter_pass(link: Linkage, speed_mm_s: float, omega: float, clearance: float, n: int = 7201,
                 sign: int = +1) -> PlanterPass:
    """Find the pass on two crank turns sampled at n points per turn (it may straddle θ1 = 0). ValueError if
    the path has no loop at the bottom (no ridge surface III)."""
    m = trajectory_metrics(link, speed_mm_s, omega, sign=sign)
    if not m["crossed"]:
        raise ValueError("pepper planter: P's moving path has no loop at the bottom, so no ridge surface III")
    y_ground = m["ground"]
    t = np.linspace(0.0, 4 * np.pi, 2 * n - 1) / omega
    x, y, th4 = pose(link, speed_mm_s, omega, t, y_ground, sign)
    half = (n - 1) // 2
    i_min = half + int(np.argmin(y[half:half + n]))            # the lowest point of one turn, inside the window
    before, after = np.flatnonzero(y[:i_min] > clearance), np.flatnonzero(y[i_min:] > clearance)
    if not len(before) or not len(after):
        raise ValueError(f"pepper planter: the tip never rises {clearance:g} mm above the ridge surface")
    return PlanterPass(float(t[before[-1]]), float(t[i_min]), float(t[i_min + after[0]]), y_ground,
                       float(-y[i_min]), float(x[i_min]), float(th4[i_min]))
