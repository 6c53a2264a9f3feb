"""Where the rolling disk starts, where its holes fall and how long the strip must be (seed 001 §2.3, eqs 1-6).

Frame: x along the travel, z up, the undisturbed surface at z = 0; the disk axis is parallel to y at height
H0 = R_tip - penetration and advances at v. Punch k's axis points at angle φ from straight down (φ > 0:
forward), and φ falls at ω = v / (R(1 - δ)) (the rolling rate of eq 1 with slip δ). A point (u, v) of a
punch (u along its axis from the disk centre, v across it in the disk plane, forward at φ = 0) is at
x = u·sin φ + v·cos φ, z = -u·cos φ + v·sin φ relative to the axis. Lengths in mm, angles in rad.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from analysis.core.config import Disk
from analysis.core.schema import ConfigError

TIP_SPHERE_RATIO = 0.2      # blunt tip: inscribed sphere radius / punch radius (scripts/disk_parts.py builds it)
START_MARGIN_DEG = 3.0      # punch 0 starts this far before it first touches the surface
STOP_MARGIN_DEG = 2.0       # the run stops this far after the last punch has left the soil


def punch_section(disk: Disk, z: float = 0.0, n_cone: int = 32) -> np.ndarray:
    """Outline (u, v) of the punch cut by the plane at lateral offset z from its centre plane, as a convex
    polygon: u along the punch axis from the disk centre, v across it in the disk plane. Empty if |z| >= d."""
    d, R, h = disk.d, disk.R, disk.h
    z = abs(z)
    if z >= d:
        return np.empty((0, 2))
    w = np.sqrt(d * d - z * z)                       # cylinder: strip of half-width w
    u_end = R - h * z / d                            # cone radius d(R-u)/h falls to z here
    u = np.linspace(R - h, u_end, n_cone)
    wc = np.sqrt(np.maximum((d * (R - u) / h) ** 2 - z * z, 0.0))
    upper = np.column_stack([np.r_[disk.R0, u], np.r_[w, wc]])
    lower = upper[::-1] * [1, -1]
    return np.vstack([upper, lower[1:]])           # the tip point (v = 0) appears once


def rolling_rate(disk: Disk, speed: float, slip: float) -> float:
    """ω = v / (R(1 - δ)) in rad/s for v in mm/s (eq 1: the axis advances R(1-δ) per radian)."""
    return speed / (disk.R * (1.0 - slip))


def blunt_tip(radius: float, h: float, u_tip: float, a: float) -> tuple[float, float, float]:
    """The blunt tip of a cone of base `radius` and height `h` whose apex is at u_tip along its axis: the
    inscribed sphere of radius `a` tangent to the cone's faces, and where it cuts the cone. Returns (the cone's
    half-angle, the sphere's centre, the cut) along the axis; the scenes build it (scripts/parts.py), the
    theory draws it (punch_outline).

    >>> [round(float(v), 3) for v in blunt_tip(25.0, 20.0, 191.0, 5.0)]
    [0.896, 184.597, 188.501]
    """
    half = float(np.arctan2(radius, h))
    return half, u_tip - a / np.sin(half), u_tip - (a / np.sin(half)) * np.cos(half) ** 2


def punch_outline(disk: Disk, tip_sphere: float = 0.0) -> np.ndarray:
    """(u, v) outline of the punch in its own plane; with a blunt tip of radius `tip_sphere` the cone is cut
    where the inscribed sphere touches it and the sphere's arc closes the end."""
    pts = punch_section(disk, 0.0, n_cone=8)
    if tip_sphere <= 0:
        return pts
    half, centre, u_cut = blunt_tip(disk.d, disk.h, disk.R, tip_sphere)
    tip = int(np.argmax(pts[:, 0]))
    upper, lower = pts[:tip], pts[tip + 1:]
    arc = np.linspace(np.pi / 2 - half, -(np.pi / 2 - half), 9)     # from the upper tangent point to the lower
    cap = np.column_stack([centre + tip_sphere * np.cos(arc), tip_sphere * np.sin(arc)])
    return np.vstack([upper[upper[:, 0] < u_cut], cap, lower[lower[:, 0] < u_cut]])


def to_axis_frame(outline: np.ndarray, phi):
    """Outline points relative to the axis for each angle φ: arrays (n_phi, n_pts) of x and z."""
    phi = np.atleast_1d(phi)[:, None]
    u, v = outline[:, 0][None, :], outline[:, 1][None, :]
    return u * np.sin(phi) + v * np.cos(phi), -u * np.cos(phi) + v * np.sin(phi)


def in_soil_range(outline: np.ndarray, phis, H0: float):
    """x-range (relative to the axis) of the outline's part below the surface, for each φ: the vertices
    below it and the points where the outline's edges cross it; NaN where the punch is out of the soil."""
    x, z = to_axis_frame(outline, phis)
    x2, z2 = np.roll(x, -1, axis=1), np.roll(z, -1, axis=1)
    below = z < -H0
    cross = (z + H0) * (z2 + H0) < 0
    t = np.where(cross, (-H0 - z) / np.where(cross, z2 - z, 1.0), np.nan)
    xc = x + t * (x2 - x)
    cand = np.concatenate([np.where(below, x, np.nan), np.where(cross, xc, np.nan)], axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)        # all-NaN rows: the punch is out of the soil
        return np.nanmin(cand, axis=1), np.nanmax(cand, axis=1)


@dataclass(frozen=True)
class Layout:
    """The run's geometry and timing, in mm, rad and s."""
    omega: float              # rad/s
    speed: float              # mm/s
    slip: float
    H0: float                 # axis height above the surface
    tip_reach: float          # axis to the lowest point of the (blunt) tip
    phi_in: float             # angle at which a punch first touches the surface
    phi_out: float            # angle at which it leaves
    phi0: float               # punch 0's angle at t = 0
    x_axis0: float            # axis x at t = 0
    hole_x: tuple             # x of each formed hole's centre (the axis x when that punch points straight down)
    lead_in: int              # the first `lead_in` holes are formed but not measured
    hole_rear: float          # hole extent behind / in front of its centre, from the swept outline
    hole_front: float
    tool_front: float         # farthest x any punch reaches in the soil before t_end (the next punch's, entering)
    length: float             # bed length, from x = 0
    t_end: float
    pitch: float              # 2π/N: punch k leads punch 0 by k·pitch


def layout(disk: Disk, speed_kmh: float, slip: float, holes: int, lead_in: int = 0, run_out: float = 30.0,
           tip_sphere: float = 0.0, gap: float = 10.0) -> Layout:
    """Place the disk so that punch 0 is the first to touch the bed (at x >= 0) and the punch already in the
    soil at t = 0 stays `gap` mm clear of it. `lead_in` + `holes` holes are formed; the first `lead_in` are
    not measured, because the first hole of a strip has no heave of a predecessor in front of it (measured:
    quick runs' first holes were 31 mm longer than the second). The bed ends `run_out` mm past the farthest
    point a punch reaches in the soil before t_end: the next punch enters while the last hole's punch is still
    in (in soil over 2·φ_in > 2π/N), so that is its front, not the last hole's."""
    outline = punch_outline(disk, tip_sphere)
    tip_reach = float(outline[:, 0].max())
    H0 = tip_reach - disk.penetration
    speed = speed_kmh / 3.6 * 1000.0
    omega = rolling_rate(disk, speed, slip)
    adv = disk.R * (1.0 - slip)                             # axis advance per radian
    pitch = 2 * np.pi / disk.N
    phis = np.linspace(-np.pi / 2, np.pi / 2, 3601)
    lo, hi = in_soil_range(outline, phis, H0)
    touching = np.isfinite(lo)
    phi_in, phi_out = float(phis[touching].max()), float(phis[touching].min())
    phi0 = phi_in + np.radians(START_MARGIN_DEG)
    # the swept hole, relative to the axis position at which the punch points straight down
    hole_rear = float(-np.nanmin(lo - adv * phis))
    swept_front = hi - adv * phis            # the in-soil front relative to the axis x when the punch points down
    hole_front = float(np.nanmax(swept_front))
    # the punch that trails punch 0 is in the soil at t = 0 (its angle phi0 - pitch, if > phi_out)
    trail = (phis <= phi0 - pitch) & touching
    x_trail = float(np.max(hi[trail] + adv * (phi0 - pitch - phis[trail]))) if trail.any() else -np.inf
    x_axis0 = -x_trail - gap if np.isfinite(x_trail) else gap + hole_rear - adv * phi0
    if x_axis0 + adv * phi0 - hole_rear < 0:
        raise ConfigError(f"holes overlap: spacing {2 * np.pi * adv / disk.N:.1f} mm is shorter than a hole "
                          f"({hole_rear + hole_front:.1f} mm) plus the {gap:g} mm gap; allowed: slip or N smaller")
    hole_x = tuple(float(x_axis0 + adv * (phi0 + k * pitch)) for k in range(lead_in + holes))
    t_end = (phi0 + (len(hole_x) - 1) * pitch - phi_out + np.radians(STOP_MARGIN_DEG)) / omega
    # at t_end the k-th pass of a punch (punch k mod N; k = 0 is punch 0's first) is at phi_end + k·pitch; its
    # front so far is its swept front over the angles it has passed. Passes past the last hole's are the next
    # punches', entering; a strip longer than N holes has punches on their second pass.
    phi_end = phi0 - omega * t_end
    passed = [touching & (phis >= phi_end + k * pitch) for k in range(len(hole_x) + disk.N)]
    tool_front = max(float(x_axis0 + adv * (phi0 + k * pitch) + np.max(swept_front[m]))
                     for k, m in enumerate(passed) if m.any())
    length = max(hole_x[-1] + hole_front, tool_front) + run_out
    return Layout(omega=omega, speed=speed, slip=slip, H0=H0, tip_reach=tip_reach, phi_in=phi_in, phi_out=phi_out,
                  phi0=float(phi0), x_axis0=float(x_axis0), hole_x=hole_x, lead_in=lead_in, hole_rear=hole_rear,
                  hole_front=hole_front, tool_front=tool_front, length=float(length), t_end=float(t_end), pitch=float(pitch))


def slip_between_holes(theta, x_axis, phi0: float, pitch: float, R: float, n_holes: int) -> list:
    """Slip δ of each pair of consecutive holes, as their spacing gives it (eq 1: the axis advances
    C = R(1 - δ)·2π/N while the disk turns one pitch): δ = 1 - Δx / (R·pitch), Δx being the axis advance
    between the instants punches k and k + 1 point straight down (turned θ = φ0 + k·pitch). theta (rad) and
    x_axis (mm) are a run's records; pairs outside them are left out. Prescribed rolling gives the set slip."""
    theta, x_axis = np.asarray(theta, float), np.asarray(x_axis, float)
    if theta.size == 0:
        return []
    order = np.argsort(theta, kind="stable")
    theta, x_axis = theta[order], x_axis[order]
    turned = phi0 + pitch * np.arange(n_holes)
    inside = (turned >= theta[0]) & (turned <= theta[-1])
    x = np.interp(turned, theta, x_axis)
    return [float(1.0 - (x[k + 1] - x[k]) / (R * pitch)) for k in range(n_holes - 1) if inside[k] and inside[k + 1]]


def inertial_number(tip_speed: float, punch_d: float, grain_d: float, grain_density: float, pressure: float) -> float:
    """The punch's inertial number I = γ̇·d·√(ρ/p): the shear rate γ̇ = tip speed / punch diameter, d the grain
    diameter, ρ the grains' density (scaled with density scaling), p the soil's cone index (Table 2) as the
    stress the punch works against. I < 1e-3 is quasi-static, where density scaling changes nothing.

    >>> round(inertial_number(0.5, 0.05, 0.01, 3000.0, 450e3), 4)
    0.0082
    """
    return float(tip_speed / punch_d * grain_d * np.sqrt(grain_density / pressure))


def wrapped(phi: float) -> float:
    """An angle in [-π, π): a punch's angle from straight down on whichever turn of the disk. One already in
    that range is returned as it is, to the last bit (the modulo's rounding would change the first turn's
    arithmetic, and a granular run amplifies any change).

    >>> [round(wrapped(x), 3) for x in (0.5, 0.5 - 2 * np.pi, 3.5, -3.5)], wrapped(0.1) == 0.1
    ([0.5, 0.5, -2.783, 2.783], True)
    """
    return float(phi) if -np.pi <= phi < np.pi else float((phi + np.pi) % (2 * np.pi) - np.pi)


def formed_hole_x(t, punch, tip_x, tip_z, gap: float) -> list:
    """Where a run's punches actually made their holes, from its record (scripts/disk_parts.py Recorder: time,
    punch, tip x and tip depth below the surface, tip_z < 0 in the soil): one x per passage into the soil, where
    the tip was deepest, in the order the passages happened. A passage is one punch's rows without a pause
    longer than `gap` (its time in the window); only passages whose deepest point lies inside them (not at the
    first or last row: a punch already leaving, or still entering, when the record starts or ends) and below
    the surface count. Free rolling forms its holes where the soil lets it, not at the prescribed layout's x.

    >>> t = np.r_[0:5] * 1.0; z = np.array([-1.0, -3, -4, -2, 1])
    >>> formed_hole_x(np.r_[t, t + 10], np.r_[[0] * 5, [1] * 5], np.r_[t * 10, t * 10 + 200], np.r_[z, z], 2.0)
    [20.0, 220.0]
    """
    t, punch, tip_x, tip_z = (np.asarray(a, float) for a in (t, punch, tip_x, tip_z))
    found = []                                  # (time of the deepest point, its x)
    for k in np.unique(punch):
        rows = np.flatnonzero(punch == k)
        rows = rows[np.argsort(t[rows], kind="stable")]
        for passage in np.split(rows, np.flatnonzero(np.diff(t[rows]) > gap) + 1):
            deepest = int(np.argmin(tip_z[passage]))
            if 0 < deepest < len(passage) - 1 and tip_z[passage[deepest]] < 0:
                found.append((t[passage[deepest]], tip_x[passage[deepest]]))
    return [float(x) for _, x in sorted(found)]
