"""Layout of the disk run (analysis/core/kinematics.py) and the sleeve / preset configs; no YADE."""
import dataclasses

import numpy as np
import pytest

from analysis.core.config import load_disk, load_preset, load_sleeve, sleeve_from_dict
from analysis.core.schema import as_dict, ConfigError
from analysis.core.kinematics import (TIP_SPHERE_RATIO, formed_hole_x, layout, punch_outline, slip_between_holes,
                                     to_axis_frame, wrapped)
from analysis.holes.measure import hole_centres
from analysis.holes.metrology import deficit_centres
from analysis.holes.theory import hole_spacing, swept_extent

DISK = load_disk("configs/disk.toml")


@pytest.mark.parametrize("slip", [0.0, 0.1, 0.25])
def test_holes_fall_at_the_theoretical_spacing_inside_the_strip(slip):
    lay = layout(DISK, 1.9, slip, 2, lead_in=1, run_out=100.0, tip_sphere=5.0)
    assert len(lay.hole_x) == 3 and lay.lead_in == 1
    assert np.diff(lay.hole_x) == pytest.approx([hole_spacing(DISK, slip)] * 2, abs=1e-9)
    assert lay.hole_x[0] - lay.hole_rear > 0                       # the first hole lies wholly in the bed
    assert lay.length == pytest.approx(max(lay.hole_x[-1] + lay.hole_front, lay.tool_front) + 100.0)
    lo, hi = swept_extent(DISK, slip, [0.0])                         # the same swept hole as the theory's
    assert lay.hole_rear + lay.hole_front == pytest.approx(hi[0] - lo[0], abs=3.0)


@pytest.mark.parametrize("preset,slip", [("quick", 0.0), ("paper", 0.0), ("test", 0.0), ("paper", 0.2),
                                         ("validation_surface", 0.0), ("validation_surface", 0.2)])
def test_every_punch_in_the_soil_before_the_end_stays_inside_the_bed(preset, slip):
    """The punch after the last hole enters while that hole's punch is still in the soil; the bed must hold it
    (it once swept through the end wall and crushed grains against it). Checked on a densified outline, punch by
    punch, independently of layout's own sweep."""
    p = load_preset(preset)
    lay = layout(DISK, DISK.speed_kmh, slip, p.holes, p.lead_in, p.run_out, tip_sphere=TIP_SPHERE_RATIO * DISK.d)
    out = punch_outline(DISK, TIP_SPHERE_RATIO * DISK.d)
    f = np.linspace(0.0, 1.0, 20, endpoint=False)[:, None, None]
    dense = (out[None] + f * (np.roll(out, -1, axis=0)[None] - out[None])).reshape(-1, 2)
    t = np.linspace(0.0, lay.t_end, 3000)
    front = []
    for k in range(len(lay.hole_x) + DISK.N):       # the k-th pass down, punch k mod N's (past N: round again)
        phi = lay.phi0 + k * lay.pitch - lay.omega * t
        x, z = to_axis_frame(dense, phi)
        x = (x + (lay.x_axis0 + lay.speed * t)[:, None])[(z < -lay.H0) & (np.abs(phi) < np.pi / 2)[:, None]]
        if x.size == 0:
            continue
        # the punch that trails punch 0 is in the soil at t = 0 behind the bed's start and never reaches it
        assert x.min() >= 0.0 or x.max() <= -5.0, f"pass {k} crosses the bed's start"
        front.append(x.max())
    assert max(front) <= lay.length - p.run_out + 0.5               # ahead: run_out of soil past every punch
    assert max(front) > lay.hole_x[-1] + lay.hole_front + 50.0      # the next punch is in the soil at the end


def test_slip_between_holes_recovers_eq_1():
    """Records of a disk turning at ω = v / (R(1 - δ)) give δ back from the axis advance between two holes; a
    pair outside the records is left out."""
    lay = layout(DISK, 1.9, 0.15, 2, lead_in=1, run_out=100.0, tip_sphere=5.0)
    t = np.linspace(0.0, lay.t_end, 500)
    theta, x = lay.omega * t, lay.x_axis0 + lay.speed * t
    assert slip_between_holes(theta, x, lay.phi0, lay.pitch, DISK.R, 3) == pytest.approx([0.15, 0.15], abs=1e-3)
    assert len(slip_between_holes(theta, x, lay.phi0, lay.pitch, DISK.R, 4)) == 2


def test_blunt_tip_reaches_the_penetration_and_the_outline_is_closed():
    lay = layout(DISK, 1.9, 0.0, 1, tip_sphere=5.0)
    out = punch_outline(DISK, 5.0)
    x, z = to_axis_frame(out, 0.0)
    assert lay.H0 + z.min() == pytest.approx(-DISK.penetration, abs=1e-9)
    assert np.all(np.diff(out[: np.argmax(out[:, 0]) + 1, 0]) >= -1e-9)   # upper side runs towards the tip


def test_overlapping_holes_are_a_clear_error():
    with pytest.raises(ConfigError, match="holes overlap"):
        layout(dataclasses.replace(DISK, N=12), 1.9, 0.0, 3)


@pytest.mark.parametrize("slip", [0.0, 0.2])
def test_each_hole_more_lengthens_the_strip_by_one_spacing(slip):
    """Past N holes the punches go round again: the strip still grows by exactly one spacing C per hole (it once
    stopped counting the next punch's front after the first revolution, and an 8-hole strip was 150 mm short)."""
    lengths = [layout(DISK, 1.9, slip, n, lead_in=1, run_out=100.0, tip_sphere=5.0).length for n in range(1, 14)]
    # within the 0.05° angular grid of layout's sweep (0.04 mm of front at R)
    assert np.diff(lengths) == pytest.approx([hole_spacing(DISK, slip)] * 12, abs=0.1)


def test_sleeve_and_preset_configs_are_checked():
    sleeve = load_sleeve("configs/disk.toml", DISK)
    assert sleeve.outer_diameter > DISK.D
    with pytest.raises(ConfigError, match="outer_diameter"):
        sleeve_from_dict({**as_dict(sleeve), "outer_diameter": 40.0}, DISK)
    with pytest.raises(ConfigError, match="travel"):
        sleeve_from_dict({**as_dict(sleeve), "travel": 200.0}, DISK)
    with pytest.raises(ConfigError, match="preset"):
        load_preset("fast")


def test_deficit_centres_find_carved_holes():
    rng = np.random.default_rng(0)
    n = 20000
    pos = np.column_stack([rng.uniform(0, 0.6, n), rng.uniform(0, 0.16, n), rng.uniform(0, 0.1, n)])
    rad = np.full(n, 0.004)
    after = pos.copy()
    for xc in (0.15, 0.35):
        inside = (np.hypot(pos[:, 0] - xc, pos[:, 1] - 0.08) < 0.03)
        after[inside, 2] -= 0.05 * (1 - np.hypot(pos[inside, 0] - xc, pos[inside, 1] - 0.08) / 0.03)
    x = deficit_centres(after, pos, rad, 0.08, 0.0125, 0.008, [0.15, 0.35], 0.09)
    assert x == pytest.approx([0.15, 0.35], abs=0.004)


def rolling_record(lay, slip: float, record_dt: float = 5e-4):
    """A disk's record (scripts/disk_parts.py Recorder's time, punch, tip x and tip depth, mm) as it rolls at
    `slip` from the start of the layout `lay` over its whole time, punches recorded near the soil only."""
    adv = DISK.R * (1 - slip)
    omega = lay.speed / adv
    rows = []
    for t in np.arange(0.0, lay.t_end, record_dt):
        x_axis = lay.x_axis0 + lay.speed * t
        for k in range(DISK.N):
            phi = wrapped(lay.phi0 + k * lay.pitch - omega * t)
            if abs(phi) < lay.phi_in + 0.2:
                rows.append((t, k, x_axis + lay.tip_reach * np.sin(phi), lay.H0 - lay.tip_reach * np.cos(phi)))
    return [np.array(c) for c in zip(*rows)]


@pytest.mark.parametrize("slip", [0.0, 0.2])
def test_holes_are_found_where_the_record_says_the_punches_went_deepest(slip):
    """A free disk forms its holes where it rolls, not at the layout's x: from the record of a disk planned at
    slip 0 that rolls at `slip`, the formed holes are the slip-`slip` layout's (within the record's step of
    travel), every one of the 8 holes of a strip longer than a turn, and free mode's measured centres are them."""
    planned = layout(DISK, 1.9, 0.0, 8, lead_in=1, run_out=100.0, tip_sphere=5.0)
    rolled = layout(DISK, 1.9, slip, 8, lead_in=1, run_out=100.0, tip_sphere=5.0)
    formed = formed_hole_x(*rolling_record(planned, slip), gap=1.5e-3)
    step = planned.speed * 5e-4
    assert len(formed) >= 9
    first = [x - planned.x_axis0 for x in formed[:9]]
    assert first == pytest.approx([x - rolled.x_axis0 for x in rolled.hole_x], abs=step)
    summary = {"mode": "free", "hole_x_mm": list(planned.hole_x), "hole_x_formed_mm": formed}
    assert hole_centres(summary) == formed[:9]
    assert hole_centres({**summary, "mode": "prescribed"}) == list(planned.hole_x)
    if slip:
        assert np.all(np.abs(np.subtract(formed[:9], planned.hole_x))[1:] > 5 * step)
