"""Synthetic particle beds with holes of known shape carved in them, for the metrology tests (mm)."""
import numpy as np


def lattice_bed(length: float, width: float, height: float, r: float, jitter: float = 0.0, seed: int = 0,
                turn: float = 0.0):
    """Close-packed (hexagonal layers, ABC stacking) spheres of radius r filling the box, top at ≈ height.
    `jitter`: random displacement of each centre, as a fraction of r (grains then overlap slightly);
    `turn`: the lattice's rotation about z in degrees, so that its rows need not line up with a hole."""
    big = np.hypot(length, width)
    pos, rad = _lattice(big, big, height, r)
    c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
    x, y = pos[:, 0] - big / 2, pos[:, 1] - big / 2
    pos = np.column_stack([c * x - s * y + length / 2, s * x + c * y + width / 2, pos[:, 2]])
    pos = pos[(pos[:, 0] >= r) & (pos[:, 0] <= length - r) & (pos[:, 1] >= r) & (pos[:, 1] <= width - r)]
    if jitter:
        pos = pos + np.random.default_rng(seed).uniform(-jitter * r, jitter * r, pos.shape)
    return pos, np.full(len(pos), r)


def _lattice(length, width, height, r):
    a = 2 * r
    pts = []
    layer_h = a * np.sqrt(2 / 3)
    shifts = [(0.0, 0.0), (a / 2, a / (2 * np.sqrt(3))), (a, a / np.sqrt(3))]
    for k in range(int((height - r) / layer_h) + 1):
        sx, sy = shifts[k % 3]
        for j in range(int(width / (a * np.sqrt(3) / 2)) + 2):
            y = r + j * a * np.sqrt(3) / 2 + sy
            x0 = r + (a / 2 if j % 2 else 0.0) + sx
            for x in np.arange(x0 % a if x0 > a else x0, length, a):
                pts.append((x, y, r + k * layer_h))
    pos = np.array(pts)
    return pos, np.full(len(pos), r)


def stadium_distance(x, y, xc, yc, length, width):
    """Signed distance to a stadium (slot) of the given length along x and width along y (negative inside)."""
    half_straight = (length - width) / 2
    dx = np.maximum(np.abs(x - xc) - half_straight, 0.0)
    return np.hypot(dx, y - yc) - width / 2


def carve(pos, radius, xc, yc, z_top, L0, W, depth_straight, taper, h1, ring):
    """Remove every grain whose centre is in the hole; lower the surface round it by h1.

    The hole: a stadium of length L0 and width W from z_top down `depth_straight`, then shrinking
    linearly about its centre to nothing over `taper`. Round it (stadium distance < ring) the grains are
    moved down by h1 (overlaps do not matter to geometry), so the pressed surface sits h1 lower."""
    x, y, z = pos.T
    depth = z_top - h1 - z
    scale = np.clip(1 - (depth - depth_straight) / taper, 0.0, 1.0)
    scale = np.where(depth < depth_straight, 1.0, scale)
    d = stadium_distance(x, y, xc, yc, np.maximum(L0 * scale, 1e-9), np.maximum(W * scale, 1e-9))
    in_hole = (scale > 0) & (d < 0)
    pressed = (stadium_distance(x, y, xc, yc, L0, W) >= 0) & (stadium_distance(x, y, xc, yc, L0, W) < ring)
    pos = pos.copy()
    pos[pressed, 2] -= h1
    keep = ~in_hole
    return pos[keep], radius[keep]


def four_section_length(L0, W):
    """Mean of the stadium's chords along x on the 4 lines at 1/5 ... 4/5 of its width."""
    offs = (np.array([0.2, 0.4, 0.6, 0.8]) - 0.5) * W
    return float(np.mean(L0 - W + 2 * np.sqrt((W / 2) ** 2 - offs ** 2)))


def four_section_width(L0, W):
    """Mean of the stadium's chords across y on the 4 lines at 1/5 ... 4/5 of its length."""
    offs = (np.array([0.2, 0.4, 0.6, 0.8]) - 0.5) * L0
    dx = np.maximum(np.abs(offs) - (L0 - W) / 2, 0.0)
    return float(np.mean(2 * np.sqrt(np.maximum((W / 2) ** 2 - dx ** 2, 0.0))))
