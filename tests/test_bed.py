"""Soil beds and the virtual cone, on tiny scenes; each scene runs in its own YADE process."""
import json
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from analysis.core.schema import ROOT, ConfigError
from analysis.core.soil_config import load_soil
from analysis.soil.calibrate import cone_result_name
from analysis.core.io import read_table

TINY = ["--resolution", "tiny", "--threads", "2"]


def scene(script, *args):
    """Run a scene script; return its last stdout line as JSON, or raise with its stderr."""
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / script), *args], capture_output=True, text=True,
                       timeout=1200, cwd=ROOT)     # a guard against a hang, not a speed test
    if r.returncode != 0:
        raise AssertionError(f"{script} failed ({r.returncode}):\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def tiny_bed(tmp_path_factory):
    beds = tmp_path_factory.mktemp("beds")
    meta = scene("bed.py", "--soil", "clay", "--size", "120,120,100", "--bed-dir", str(beds), *TINY)
    return beds, meta


@pytest.mark.scene
def test_tiny_bed_settles_without_losing_particles(tiny_bed):
    beds, meta = tiny_bed
    assert meta["particles"] <= 3000
    data = np.load(beds / f"{meta['key']}.npz")
    pos, rad = data["pos"], data["radius"]
    assert len(rad) == meta["particles"]
    L, W, D = meta["size_m"]
    assert np.all(np.isfinite(pos))
    assert np.all((pos[:, 0] > 0) & (pos[:, 0] < L) & (pos[:, 1] > 0) & (pos[:, 1] < W) & (pos[:, 2] > 0))
    assert pos[:, 2].max() <= D + 0.25 * meta["radius"]     # levelled (a grain may be nudged up on re-settling)
    assert meta["surface_z"] > D - 2 * meta["radius"]       # and full to the top


@pytest.mark.scene
def test_tiny_bed_reaches_target_density(tiny_bed):
    """Bulk density measured independently: grain mass inside a central column over its volume."""
    beds, meta = tiny_bed
    soil = load_soil("clay")
    data = np.load(beds / f"{meta['key']}.npz")
    pos, rad = data["pos"], data["radius"]
    L, W, D = meta["size_m"]
    m = 2 * meta["radius"]
    inside = ((pos[:, 0] > m) & (pos[:, 0] < L - m) & (pos[:, 1] > m) & (pos[:, 1] < W - m)
              & (pos[:, 2] > m) & (pos[:, 2] < D - m))
    volume = (L - 2 * m) * (W - 2 * m) * (D - 2 * m)        # centres inside: whole spheres counted, so ± a shell
    dry = meta["grain_density"] * np.sum(4 / 3 * np.pi * rad[inside] ** 3) / volume / (1 + soil.moisture)
    assert dry == pytest.approx(soil.bulk_density, rel=0.08)
    assert 0.3 < meta["porosity"] < 0.65


@pytest.mark.scene
def test_bed_is_cached_by_its_key(tiny_bed):
    beds, meta = tiny_bed
    again = scene("bed.py", "--soil", "clay", "--size", "120,120,100", "--bed-dir", str(beds), *TINY)
    assert again["key"] == meta["key"] and again["wall_s"] == meta["wall_s"]     # loaded, not settled again


@pytest.fixture(scope="module")
def graded_bed(tmp_path_factory):
    beds = tmp_path_factory.mktemp("beds")
    meta = scene("bed.py", "--soil", "clay", "--size", "160,140,100", "--bed-dir", str(beds), "--resolution",
                 "tiny_graded", "--threads", "2")
    return beds, meta


@pytest.mark.scene
def test_graded_bed_keeps_its_fine_grains_where_the_punches_work(graded_bed):
    """A graded bed (configs/resolutions.toml: tiny_graded) loses no grain, settles full and level, puts its
    fine grains in the fine zone and its coarse ones round and under it (a few fine ones may sift into the
    coarse pores below), and has the target bulk density in the fine zone, measured independently of the
    porosity the bed builder used."""
    beds, meta = graded_bed
    g = meta["graded"]
    data = np.load(beds / f"{meta['key']}.npz")
    pos, rad = data["pos"], data["radius"]
    L, W, D = meta["size_m"]
    assert len(rad) == meta["particles"] == g["fine_particles"] + g["coarse_particles"]
    assert np.all(np.isfinite(pos)) and np.all((pos[:, :2] > 0) & (pos[:, :2] < (L, W))) and pos[:, 2].min() > 0
    fine = rad <= meta["radius"] * (1 + meta["spread"]) * (1 + 1e-9)
    r, rc = meta["radius"], g["coarse_radius"]
    in_band = np.abs(pos[:, 1] - W / 2) < g["fine_width"] / 2 + r
    in_zone = in_band & (pos[:, 2] > D - g["fine_depth"] - r)
    assert fine.sum() > 0 and (~fine).sum() > 0
    assert np.mean(in_zone[fine]) > 0.95                      # fine grains in the fine zone
    core = (np.abs(pos[:, 1] - W / 2) < g["fine_width"] / 2 - rc) & (pos[:, 2] > D - g["fine_depth"] + rc)
    assert not np.any(core & ~fine)                           # no coarse grain inside it
    tops = pos[:, 2] + rad
    assert tops[~fine].max() <= tops[fine].max() + 0.25 * r   # levelled: no coarse grain stands above the fine
    assert meta["surface_z"] > D - 2 * r
    m = 2 * r
    box = ((pos[:, 0] > m) & (pos[:, 0] < L - m) & (np.abs(pos[:, 1] - W / 2) < g["fine_width"] / 2 - m)
           & (pos[:, 2] > D - g["fine_depth"] + m) & (pos[:, 2] < D - m))
    volume = (L - 2 * m) * (g["fine_width"] - 2 * m) * (g["fine_depth"] - 2 * m)
    dry = meta["grain_density"] * np.sum(4 / 3 * np.pi * rad[box] ** 3) / volume / (1 + load_soil("clay").moisture)
    assert dry == pytest.approx(load_soil("clay").bulk_density, rel=0.1)
    assert 0.3 < g["coarse_porosity"] < 0.65


def side_solid_fraction(pos, rad, L, W, D, periodic: bool, n_points=100000, seed=0):
    """Solid fraction (Monte Carlo points) within half a mean radius of the sides x = 0, L and y = 0, W, and
    inside, both between 2 radii over the floor and 2 under the top. A periodic bed's grains are matched
    across the cell's sides."""
    from scipy.spatial import cKDTree
    r = rad.mean()
    rng = np.random.default_rng(seed)
    pts = rng.uniform([0, 0, 2 * r], [L, W, D - 2 * r], size=(n_points, 3))
    tree = cKDTree(pos, boxsize=(L, W, 10.0)) if periodic else cKDTree(pos)
    d, i = tree.query(pts, k=8)
    solid = (d < rad[i]).any(axis=1)
    side = np.minimum.reduce([pts[:, 0], L - pts[:, 0], pts[:, 1], W - pts[:, 1]]) < r / 2
    inner = np.minimum.reduce([pts[:, 0], L - pts[:, 0], pts[:, 1], W - pts[:, 1]]) > 2 * r
    return solid[side].mean(), solid[inner].mean()


@pytest.fixture(scope="module")
def periodic_bed(tmp_path_factory):
    beds = tmp_path_factory.mktemp("beds")
    meta = scene("bed.py", "--soil", "clay", "--size", "120,120,100", "--bed-dir", str(beds), "--lateral", "periodic",
                 *TINY)
    return beds, meta


@pytest.mark.scene
def test_periodic_bed_has_no_side_walls(tiny_bed, periodic_bed):
    """The walled bed is loose along its walls (grains cannot pack against a flat wall); the periodic bed is
    as dense at its cell's sides as inside, and keeps every grain in the cell."""
    fractions = {}
    for (beds, meta), periodic in ((tiny_bed, False), (periodic_bed, True)):
        data = np.load(beds / f"{meta['key']}.npz")
        pos, rad = data["pos"], data["radius"]
        L, W, D = meta["size_m"]
        assert np.all(np.isfinite(pos)) and np.all((pos[:, :2] >= 0) & (pos[:, :2] < (L, W)))
        assert pos[:, 2].min() > 0 and meta["surface_z"] > D - 2 * meta["radius"]
        fractions[periodic] = side_solid_fraction(pos, rad, L, W, D, periodic)
    assert periodic_bed[1]["lateral"] == "periodic" and "-per-" in periodic_bed[1]["key"]
    (walled_side, walled_inner), (per_side, per_inner) = fractions[False], fractions[True]
    assert walled_side < 0.8 * walled_inner
    assert per_side == pytest.approx(per_inner, rel=0.05)


def contacts(pos, rad, cell):
    """Overlapping pairs of a laterally periodic bed (nearest images across x and y): their overlaps, sorted."""
    from scipy.spatial import cKDTree
    tree = cKDTree(np.c_[pos[:, :2], pos[:, 2] - pos[:, 2].min()], boxsize=[cell[0], cell[1], 1e3])
    ij = tree.query_pairs(2 * rad.max(), output_type="ndarray")
    d = pos[ij[:, 0]] - pos[ij[:, 1]]
    d[:, :2] -= np.asarray(cell) * np.round(d[:, :2] / np.asarray(cell))
    overlap = rad[ij[:, 0]] + rad[ij[:, 1]] - np.linalg.norm(d, axis=1)
    return np.sort(overlap[overlap > 0])


@pytest.mark.scene
@pytest.mark.parametrize("tiles", [2, 3])
def test_tiled_bed_is_its_packing_repeated_round_the_same_centre(periodic_bed, tiles):
    """A tiled bed holds every contact of its periodic source n² times with the same overlap (so it is settled
    as it stands), fills its n-times-wider cell, and has the source's centre at its own centre (where the cone
    goes), so the tiled width check changes the cell and nothing else."""
    beds, meta = periodic_bed
    tiled = scene("bed.py", "--soil", "clay", "--size", "120,120,100", "--bed-dir", str(beds), "--lateral", "periodic",
                  "--tiles", str(tiles), *TINY)
    src, out = np.load(beds / f"{meta['key']}.npz"), np.load(beds / f"{tiled['key']}.npz")
    L, W, D = meta["size_m"]
    assert tiled["size_m"] == pytest.approx([tiles * L, tiles * W, D]) and f"-t{tiles}-" in tiled["key"]
    assert tiled["particles"] == tiles ** 2 * meta["particles"] == len(out["radius"])
    assert np.all((out["pos"][:, :2] >= 0) & (out["pos"][:, :2] < (tiles * L, tiles * W)))
    np.testing.assert_allclose(contacts(out["pos"], out["radius"], (tiles * L, tiles * W)),
                               np.repeat(contacts(src["pos"], src["radius"], (L, W)), tiles ** 2), atol=1e-12)
    def near(pos, c):
        return np.sort(np.linalg.norm(pos[:, :2] - c, axis=1))[:20]
    np.testing.assert_allclose(near(out["pos"], (tiles * L / 2, tiles * W / 2)), near(src["pos"], (L / 2, W / 2)),
                               atol=1e-12)


def test_only_a_periodic_bed_can_be_tiled():
    from scripts import beds as bed
    with pytest.raises(ConfigError, match=r"bed.tiles = 2: only a periodic bed"):
        bed.build("clay", "tiny", (100.0, 100.0, 60.0), tiles=2)
    with pytest.raises(ConfigError, match=r"bed.tiles = 9.*allowed"):
        bed.build("clay", "tiny", (100.0, 100.0, 60.0), tiles=9, lateral="periodic")


@pytest.fixture(scope="module")
def test_bed(tmp_path_factory):
    """About 2500 particles of r = 3.5 mm: a 25.7 mm cone is 3.7 particle diameters, enough for a depth trend."""
    beds = tmp_path_factory.mktemp("beds")
    scene("bed.py", "--soil", "clay", "--size", "100,100,100", "--bed-dir", str(beds), "--resolution", "test")
    return beds


def cone(tmp_path, beds, cohesion):
    summary = scene("cone.py", "--soil", "clay", "--size", "100,100,100", "--bed-dir", str(beds), "--out", str(tmp_path),
                    "--resolution", "test", "--cone-scale", "2", "--depth", "25", "--cone-speed", "0.5",
                    "--cohesion", str(cohesion), "--threads", "1")
    profile = read_table(tmp_path / f"{cone_result_name(summary['bed'], 2, 0.5, summary['cohesion_pa'])}.csv")
    return summary, profile


@pytest.mark.scene
def test_cone_resistance_grows_with_depth_and_cohesion(test_bed, tmp_path):
    # the two pushes side by side, one thread each: 2600 grains gain nothing from a second thread
    with ThreadPoolExecutor(max_workers=2) as pool:
        (weak, weak_profile), (strong, strong_profile) = pool.map(lambda c: cone(tmp_path, test_bed, c), (0.0, 1e5))
    assert strong["cone_index_pa"] > 1.3 * weak["cone_index_pa"] > 0
    cone_height = weak["cone_diameter_m"] / 2 / np.tan(np.radians(15))
    for d in (weak_profile, strong_profile):
        entering = d[(d.base_depth_m > -cone_height) & (d.base_depth_m < -cone_height / 2)].resistance_pa.mean()
        below = d[(d.base_depth_m >= 0) & (d.base_depth_m <= 0.025)].resistance_pa.mean()
        assert below > 2 * entering > 0          # the tip's first half-height vs the whole cone buried


def test_bad_soil_config_is_refused(tmp_path):
    bad = tmp_path / "clay.toml"
    text = re.sub(r"^friction_deg = [0-9.]+", "friction_deg = 95.0", (ROOT / "configs/soils/clay.toml").read_text(),
                  count=1, flags=re.M)
    bad.write_text(text)
    with pytest.raises(ConfigError, match=r"soil\.friction_deg = 95\.0 is out of range: allowed \[0, 60\] deg"):
        load_soil(bad)
    with pytest.raises(ConfigError, match="soil = 'peat'"):
        load_soil("peat")
    r = subprocess.run([sys.executable, str(ROOT / "scripts/bed.py"), "--soil", str(bad), *TINY],
                       capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert r.returncode == 2 and "friction_deg = 95.0 is out of range" in r.stderr


def test_a_cached_bed_settled_for_another_table2_is_refused(tmp_path):
    """The bed's key holds what shapes the packing; its grains' density follows Table 2. A cached bed whose
    metadata says it was settled for another bulk density is refused, not reused under the same key."""
    import json
    from analysis.core.schema import ConfigError
    from analysis.core.soil_config import load_soil
    from scripts.beds import check_cached
    clay = load_soil("clay")
    bed = tmp_path / "clay-x.npz"
    for density, ok in ((clay.bulk_density, True), (-clay.bulk_density, False), (1.1 * clay.bulk_density, False)):
        bed.with_suffix(".json").write_text(json.dumps({"target_dry_bulk_density": density,
                                                        "wet_bulk_density": clay.wet_density}))
        if ok:
            check_cached(bed, clay)
        else:
            with pytest.raises(ConfigError, match="settled for a dry bulk density"):
                check_cached(bed, clay)


def test_a_new_bed_is_settled_by_one_process_while_another_waits(tmp_path, monkeypatch):
    """Two runs that need the same new bed: the one holding its lock settles it; the other waits and then loads
    the bed the first saved, settling none itself. A lock whose process has died, or another host's held for
    hours, is taken over."""
    import socket
    import threading
    from analysis.core.bed_spec import bed_key
    from analysis.core.config import load_resolution
    from analysis.core.io import held
    from scripts import beds
    clay = load_soil("clay")
    out = tmp_path / f"{bed_key(clay, load_resolution('tiny'), (0.1, 0.1, 0.06), 1)}.npz"
    lock = out.with_suffix(".lock")
    lock.write_text(f"{socket.gethostname()} {__import__('os').getpid()}")     # a live process is settling it

    def the_other_process_saves_it():
        beds.save(out, np.zeros((3, 3)), np.full(3, 0.002), {"target_dry_bulk_density": clay.bulk_density,
                                                              "wet_bulk_density": clay.wet_density})
        lock.unlink()
    threading.Timer(0.5, the_other_process_saves_it).start()
    monkeypatch.setattr(beds, "settle_bed", lambda *a: pytest.fail("settled a bed another process was settling"))
    assert beds.build("clay", "tiny", (100.0, 100.0, 60.0), bed_dir=tmp_path, quiet=True) == out
    assert not lock.exists()

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    lock.write_text(f"{socket.gethostname()} {dead.stdout.strip()}")
    order = []
    with held(lock, poll_s=0.05):                       # the dead process's lock is taken over at once
        order.append("first")
        def wait_then_note():
            with held(lock, poll_s=0.05):
                order.append("second")
        waiter = threading.Thread(target=wait_then_note)
        waiter.start()
        waiter.join(0.3)
        assert waiter.is_alive() and order == ["first"]  # a held lock keeps the other waiting
    waiter.join(5)
    assert order == ["first", "second"]
    lock.write_text("another-host 12345")                # another host's lock, held for longer than any settling
    __import__("os").utime(lock, (0, 0))
    with held(lock, poll_s=0.05, stale_s=3600):
        assert lock.read_text().startswith(socket.gethostname())
