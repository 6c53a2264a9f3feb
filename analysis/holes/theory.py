"""Rigid-punch kinematics and hole-profile theory of seed 001 §2.3 (pure numpy).

Frames. The paper's frame (eqs 1-5): x along the travel axis, y up, origin a distance R below the disk
axis (the tip's lowest point at zero slip). Our world frame: the same x, Y up from the undisturbed soil
surface, so Y = y - (R - H0) where H0 is the axis height above the surface. θ is the punch's rotation from
the downward vertical; the disk advances towards -x as θ grows.

Two readings of the slip δ:
- "printed": the equations exactly as printed. Eq (3) shrinks the tip radius to R(1-δ) and advances the axis
  by Rθ; eqs (1), (2) shrink the edge radius to sqrt([R(1-δ)-h]^2+d^2) and advance by R(1-δ)θ.
- "rigid": a rigid punch (tip radius R, edge radius sqrt((R-h)^2+d^2)) on an axis that advances by the
  actual rolling radius r = R(1-δ) per radian, which is what δ = 1 - r/R (eq 1) defines.
At δ = 0 the two coincide.

The swept envelope is the exact hole a rigid punch cuts: the union over θ of the punch solid
(a cylinder of diameter D from the plate rim R0 to R-h, then a cone of height h to the tip).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.core.config import Disk
from analysis.core.kinematics import punch_section

READINGS = ("printed", "rigid")


def _check_reading(reading: str):
    if reading not in READINGS:
        raise ValueError(f"reading = {reading!r}: allowed {', '.join(READINGS)}")


def _check_slip(slip: float):
    if not 0.0 <= slip < 1.0:
        raise ValueError(f"slip = {slip!r} is out of range: allowed [0, 1)")


def edge_radius(disk: Disk, slip: float = 0.0, reading: str = "rigid") -> float:
    """Distance of the cylinder-cone edge points B, C from the axis, sqrt([R(1-δ)-h]^2 + d^2) (eq 1)."""
    Rp = disk.R * (1 - slip) if reading == "printed" else disk.R
    return float(np.hypot(Rp - disk.h, disk.d))


def edge_angle(disk: Disk, slip: float = 0.0, reading: str = "rigid") -> float:
    """α = -arctan(d / (R - h)), the angle of B off the punch centre line (eq 1); α' = -α for C (eq 2).

    The printed α uses R, not R(1-δ), even where the radius uses R(1-δ)."""
    return float(-np.arctan(disk.d / (disk.R - disk.h)))


def tip_path(theta, disk: Disk, slip: float = 0.0, reading: str = "rigid"):
    """Tip A, eq (3): x = R(1-δ) sinθ3 - Rθ3, y = R - R(1-δ) cosθ3 (printed); rigid: x = R sinθ - R(1-δ)θ."""
    _check_reading(reading), _check_slip(slip)
    theta = np.asarray(theta, float)
    R = disk.R
    radius, advance = (R * (1 - slip), R) if reading == "printed" else (R, R * (1 - slip))
    return radius * np.sin(theta) - advance * theta, R - radius * np.cos(theta)


def edge_path(theta, disk: Disk, slip: float = 0.0, edge: str = "B", reading: str = "rigid"):
    """Edge B (eq 1, entering, α < 0) or C (eq 2, leaving, α' = -α):
    x = ρ sin(θ + α) - R(1-δ)θ, y = R - ρ cos(θ + α), ρ = edge_radius."""
    _check_reading(reading), _check_slip(slip)
    if edge not in ("B", "C"):
        raise ValueError(f"edge = {edge!r}: allowed B, C")
    theta = np.asarray(theta, float)
    rho = edge_radius(disk, slip, reading)
    a = edge_angle(disk, slip, reading) * (1 if edge == "B" else -1)
    return rho * np.sin(theta + a) - disk.R * (1 - slip) * theta, disk.R - rho * np.cos(theta + a)


def length_eq4(H, disk: Disk, slip: float = 0.0, H0: float | None = None, reading: str = "printed", sign: int = 1):
    """Eq (4): l1 = 2{ρ sin(θ2 + α') - R(1-δ)θ2}, θ2 = arccos((H0 + H)/ρ) - α'. NaN where B, C miss depth H.

    `sign` = -1 flips the advance term (one of the readings we try against Table 1)."""
    H = np.asarray(H, float)
    H0 = disk.H0 if H0 is None else H0
    rho = edge_radius(disk, slip, reading)
    a2 = -edge_angle(disk, slip, reading)
    c = (H0 + H) / rho
    th2 = np.arccos(np.clip(c, -1, 1)) - a2
    return np.where(c <= 1, 2 * (rho * np.sin(th2 + a2) - sign * disk.R * (1 - slip) * th2), np.nan)


def length_eq5(H, disk: Disk, slip: float = 0.0, H0: float | None = None, reading: str = "printed", sign: int = 1):
    """Eq (5): l2 = 2[R(1-δ) sinθ3 - Rθ3], θ3 = arccos((H0 + H')/(R(1-δ))) (printed); NaN below the tip."""
    _check_reading(reading)
    H = np.asarray(H, float)
    H0 = disk.H0 if H0 is None else H0
    R = disk.R
    radius, advance = (R * (1 - slip), R) if reading == "printed" else (R, R * (1 - slip))
    c = (H0 + H) / radius
    th3 = np.arccos(np.clip(c, -1, 1))
    return np.where(c <= 1, 2 * (radius * np.sin(th3) - sign * advance * th3), np.nan)


def length_eqs(H, disk: Disk, slip: float = 0.0, H0: float | None = None, reading: str = "printed", sign: int = 1):
    """The hole length at depth H from the paper's contour a-b-o-c-d: eq (4) where the edges B, C reach
    depth H, else eq (5) from the tip's path (§2.3.3)."""
    l1 = length_eq4(H, disk, slip, H0, reading, sign)
    return np.where(np.isfinite(l1), l1, length_eq5(H, disk, slip, H0, reading, sign))


def hole_spacing(disk: Disk, slip: float = 0.0) -> float:
    """Hole spacing C = 2πR(1-δ)/N: eq (6) with the axis advancing R(1-δ) per radian."""
    _check_slip(slip)
    return 2 * np.pi * disk.R * (1 - slip) / disk.N


# --- the exact swept envelope -----------------------------------------------------------------------------

def to_world(u, v, theta, disk: Disk, slip: float = 0.0, phase: float = 0.0):
    """World position (X, Y) of point (u, v) of the punch set `phase` radians behind punch 0, when the disk
    has turned θ (punch 0 points straight down at θ = 0); Y is height above the undisturbed surface."""
    c, s = np.cos(theta - phase), np.sin(theta - phase)
    return -disk.R * (1 - slip) * theta + u * s + v * c, disk.H0 - u * c + v * s


def swept_extent(disk: Disk, slip: float, depths, z: float = 0.0, n_theta: int = 20001):
    """Front and rear x of the swept section z at each depth (mm below the surface); NaN where none.

    Each section is convex, so the punch meets a level in one interval; the union over θ is taken as
    [min x, max x]. θ is sampled over [-π/2, π/2] (the punch points downward); the error is below R·Δθ."""
    _check_slip(slip)
    poly = punch_section(disk, z)
    depths = np.atleast_1d(np.asarray(depths, float))
    lo = np.full(depths.shape, np.nan)
    hi = np.full(depths.shape, np.nan)
    if len(poly) == 0:
        return lo, hi
    theta = np.linspace(-np.pi / 2, np.pi / 2, n_theta)[:, None]
    X, Y = to_world(poly[:, 0][None], poly[:, 1][None], theta, disk, slip)
    X2, Y2 = np.roll(X, -1, axis=1), np.roll(Y, -1, axis=1)
    for i, H in enumerate(depths):
        level = -H
        crosses = ((Y - level) * (Y2 - level) <= 0) & (Y != Y2)
        if not crosses.any():
            continue
        t = (level - Y[crosses]) / (Y2[crosses] - Y[crosses])
        x = X[crosses] + t * (X2[crosses] - X[crosses])
        lo[i], hi[i] = x.min(), x.max()
    return lo, hi


def section_reach(disk: Disk, z: float) -> float:
    """Deepest depth the section at lateral offset z ever reaches: its farthest point from the axis, when
    that point passes straight below the axis. Independent of slip."""
    poly = punch_section(disk, z)
    if len(poly) == 0:
        return -np.inf
    return float(np.hypot(poly[:, 0], poly[:, 1]).max() - disk.H0)


def hole_width(disk: Disk, depths, tol: float = 1e-6):
    """Lateral width of the swept hole at each depth: 2·max{|z| : section z reaches the depth}."""
    out = []
    for H in np.atleast_1d(np.asarray(depths, float)):
        if section_reach(disk, 0.0) < H:
            out.append(np.nan)
            continue
        lo, hi = 0.0, disk.d
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if section_reach(disk, mid) >= H else (lo, mid)
        out.append(2 * lo)
    return np.array(out)


@dataclass
class HoleProfile:
    """The rigid swept hole: longitudinal extent and width at each depth, L0 and L1 at the surface, C."""
    slip: float
    depth: np.ndarray
    x_front: np.ndarray
    x_rear: np.ndarray
    width: np.ndarray
    C: float

    @property
    def length(self) -> np.ndarray:
        return self.x_rear - self.x_front

    @property
    def L0(self) -> float:
        return float(self.length[0])

    @property
    def L1(self) -> float:
        return float(self.width[0])

    def length_at(self, H) -> np.ndarray:
        return np.interp(H, self.depth, self.length)


def hole_profile(disk: Disk, slip: float = 0.0, dH: float = 0.5) -> HoleProfile:
    """Swept-envelope hole of a rigid punch at slip δ, from the surface (depth 0) to the tip's depth."""
    depth = np.arange(0.0, disk.penetration + 1e-9, dH)
    front, rear = swept_extent(disk, slip, depth)
    return HoleProfile(slip, depth, front, rear, hole_width(disk, depth), hole_spacing(disk, slip))
