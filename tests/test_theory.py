"""Laws the rigid-punch theory must obey (seed 001 §2.3)."""
import numpy as np
import pytest

from analysis.holes import theory

SLIPS = [0.0, 0.1, 0.25]


def test_tip_path_is_a_cycloid_at_zero_slip(disk):
    th = np.linspace(-1.0, 1.0, 2001)
    x, y = theory.tip_path(th, disk, 0.0)
    R = disk.R
    assert np.allclose(x, R * np.sin(th) - R * th, atol=1e-9)
    assert np.allclose(y, R * (1 - np.cos(th)), atol=1e-9)
    speed = np.hypot(np.gradient(x, th), np.gradient(y, th))     # mm per radian
    i0 = np.argmin(np.abs(th))
    assert speed[i0] < 1e-3 * R                                   # at rest at its lowest point
    assert y[i0] == pytest.approx(0.0, abs=1e-9)
    assert np.all(speed[np.abs(th) > 0.1] > 0.5)


@pytest.mark.parametrize("slip", SLIPS)
def test_tip_velocity_at_bottom_is_slip_times_R(disk, slip):
    """With slip the tip's lowest point moves backward at Rδ per radian (prolate trochoid)."""
    dth = 1e-6
    x, _ = theory.tip_path(np.array([-dth, dth]), disk, slip)
    assert (x[1] - x[0]) / (2 * dth) == pytest.approx(disk.R * slip, abs=1e-4)


@pytest.mark.parametrize("slip", SLIPS)
@pytest.mark.parametrize("which", ["disk", "other_disk"])
def test_spacing_from_consecutive_punches(request, which, slip):
    """Two consecutive punches, 2π/N apart, bottom out C = 2πR(1-δ)/N apart (eq 6 with slip)."""
    d = request.getfixturevalue(which)
    step = 2 * np.pi / d.N
    th = np.linspace(-0.5, 0.5 + step, 400001)
    x1, y1 = theory.to_world(d.R, 0.0, th, d, slip)          # punch 1
    x2, y2 = theory.to_world(d.R, 0.0, th, d, slip, phase=step)   # punch 2 trails by 2π/N
    spacing = abs(x2[np.argmin(y2)] - x1[np.argmin(y1)])
    assert spacing == pytest.approx(theory.hole_spacing(d, slip), abs=0.05)
    assert theory.hole_spacing(d, slip) == pytest.approx(2 * np.pi * d.R * (1 - slip) / d.N)


@pytest.mark.parametrize("slip", SLIPS)
def test_entry_exit_symmetry(disk, slip):
    depths = np.arange(0, disk.penetration, 2.5)
    front, rear = theory.swept_extent(disk, slip, depths)
    assert np.allclose(front, -rear, atol=0.05)


@pytest.mark.parametrize("which", ["disk", "other_disk"])
def test_width_at_least_D_where_the_cylinder_crosses(request, which):
    d = request.getfixturevalue(which)
    depths = np.arange(0, d.penetration - d.h + 1e-9, 2.0)   # the cylinder reaches down to p - h
    assert np.all(theory.hole_width(d, depths) >= d.D - 1e-4)
    below = theory.hole_width(d, [d.penetration - 0.5 * d.h])
    assert below[0] < d.D                                      # the cone is narrower


def test_width_below_the_cylinder_matches_the_cone(disk):
    """Deeper than the edge points B, C reach, only the cone's axis points matter: width = D(p - H)/h."""
    reach_B = np.hypot(disk.R - disk.h, disk.d) - disk.H0
    H = np.linspace(reach_B + 1, disk.penetration - 1, 5)
    assert np.allclose(theory.hole_width(disk, H), disk.D * (disk.penetration - H) / disk.h, atol=1e-4)


@pytest.mark.parametrize("which", ["disk", "other_disk"])
def test_length_decreases_with_depth_at_zero_slip(request, which):
    d = request.getfixturevalue(which)
    prof = theory.hole_profile(d, 0.0)
    assert np.all(np.diff(prof.length) < 0)
    assert prof.length[-1] == pytest.approx(0.0, abs=0.5)


@pytest.mark.parametrize("slip", SLIPS)
def test_equations_match_envelope_point_paths(disk, slip):
    """Eqs (1)-(3) in the rigid reading are the paths of the outline's vertices A, B, C."""
    th = np.linspace(-1.2, 1.2, 101)
    shift = disk.R - disk.H0                              # paper frame y -> height above the surface
    cases = [(theory.tip_path(th, disk, slip), (disk.R, 0.0)),
             (theory.edge_path(th, disk, slip, "B"), (disk.R - disk.h, -disk.d)),
             (theory.edge_path(th, disk, slip, "C"), (disk.R - disk.h, disk.d))]
    poly = theory.punch_section(disk, 0.0)
    for (x, y), (u, v) in cases:
        assert np.any(np.all(np.isclose(poly, [u, v]), axis=1)), (u, v)   # a vertex of the outline
        X, Y = theory.to_world(u, v, th, disk, slip)
        assert np.allclose(x, X, atol=1e-9) and np.allclose(y - shift, Y, atol=1e-9)


def test_printed_and_rigid_readings_agree_at_zero_slip(disk):
    th = np.linspace(-1, 1, 51)
    for f in (lambda r: theory.tip_path(th, disk, 0.0, r), lambda r: theory.edge_path(th, disk, 0.0, "B", r)):
        assert np.allclose(f("printed"), f("rigid"))
    H = np.arange(5, 61, 5)
    assert np.allclose(theory.length_eqs(H, disk, 0.0, reading="printed"),
                       theory.length_eqs(H, disk, 0.0, reading="rigid"), equal_nan=True)


def test_swept_envelope_contains_every_punch_point(disk):
    """Any point of the punch at any instant lies inside the swept extent at its depth."""
    rng = np.random.default_rng(1)
    poly = theory.punch_section(disk)
    for slip in SLIPS:
        th = rng.uniform(-0.9, 0.9, 200)
        k = rng.integers(0, len(poly), 200)
        X, Y = theory.to_world(poly[k, 0], poly[k, 1], th, disk, slip)
        inside = Y < -0.5
        front, rear = theory.swept_extent(disk, slip, -Y[inside])
        assert np.all(X[inside] >= front - 0.05) and np.all(X[inside] <= rear + 0.05)


@pytest.mark.parametrize("bad", [-0.1, 1.0, 1.5])
def test_bad_slip_is_refused(disk, bad):
    with pytest.raises(ValueError, match=r"slip .*\[0, 1\)"):
        theory.hole_profile(disk, bad)
