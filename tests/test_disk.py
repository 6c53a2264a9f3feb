"""The rolling punch disk with press sleeves, on a tiny strip; each scene is its own YADE process."""
import json
import re
import math
import os
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from analysis.core.config import load_disk
from analysis.core.schema import ROOT, ConfigError
from analysis.holes.metrology import deficit_centres
from analysis.holes.theory import hole_spacing


def run_scene(tmp, *args, expect_ok=True, dirs=None):
    runs, beds = dirs or (tmp / "runs", tmp / "beds")
    r = subprocess.run([sys.executable, str(ROOT / "scripts/disk.py"), "--preset", "test",
                        "--out", str(runs), "--bed-dir", str(beds), *args],
                       capture_output=True, text=True, timeout=1500, cwd=ROOT)
    if expect_ok and r.returncode != 0:
        raise AssertionError(f"disk.py failed ({r.returncode}):\n{r.stderr[-3000:]}")
    return r


# The one-thread scenes of the free-rolling tests (one thread makes a scene deterministic; on two threads the
# contact order varies and the slip of this short, one-hole strip scatters by about ±0.04 from run to run).
# conftest's side_scenes runs them in the background from the suite's first long scene on, on the core a
# one-thread scene leaves idle.
FREE = ["--soil", "clay", "--holes", "1", "--lead-in", "0", "--mode", "free", "--threads", "1"]
SIDE_SCENES = {                                 # name: (arguments, whether the run must finish)
    # two holes: the slip between them covers one whole pitch, every phase of entry and exit once (over the
    # whole run the next punch's entry at the end brakes the disk: slip_out -0.15 here against -0.06)
    "low-resistance": ([*FREE, "--holes", "2", "--set", "normal_cohesion=0", "--set", "shear_cohesion=0"], True),
    "light": ([*FREE, "--depth", "120", "--weight", "100"], True),         # heavy's strip
    # the punch after the hole now enters soil and catches a heavy disk: in the 160 mm strip 2000 N sank it 46.9 mm
    # and 4000 N 64.4 mm, neither to the floor; in a 120 mm strip 4000 N reaches the floor at t = 0.218 s
    "heavy": ([*FREE, "--depth", "120", "--weight", "4000"], False),
    # the coarsest grains (800 of them, about a minute): the side scenes must end within test_compare's scene
    "periodic": (["--soil", "clay", "--holes", "1", "--lead-in", "0", "--threads", "1", "--lateral", "periodic",
                  "--width", "160", "--resolution", "coarse"], True),
    # the coarse test strip (a lead-in and 2 holes) with the far field asleep, and the same strip all awake
    "asleep": (["--soil", "clay", "--threads", "1", "--resolution", "coarse", "--lead-in", "1", "--awake", "60,120"], True),
    "awake": (["--soil", "clay", "--threads", "1", "--resolution", "coarse", "--lead-in", "1"], True),
    # a graded bed (r = 6 mm round the tools, 10 mm elsewhere) on a strip wide enough for its 90 mm fine zone
    "graded": (["--soil", "clay", "--holes", "1", "--lead-in", "0", "--threads", "1", "--resolution", "tiny_graded",
                "--width", "140"], True),
}


@pytest.fixture(scope="module")
def two_holes(scene_dirs):
    """The clay test strip: two measured holes (shared with test_compare, which reuses it)."""
    # one thread: the scene is deterministic (contact order on two threads varies from run to run)
    summary = json.loads(run_scene(None, "--soil", "clay", "--threads", "1", dirs=scene_dirs).stdout.strip()
                         .splitlines()[-1])
    return summary, scene_dirs[0] / summary["id"]


@pytest.mark.scene
def test_tip_reaches_the_configured_depth_and_sleeves_work(two_holes):
    summary, run = two_holes
    disk = load_disk("configs/disk.toml")
    cfg = json.loads((run / "config.json").read_text())
    assert summary["tip_min_depth_mm"] == pytest.approx([disk.penetration] * 2, abs=0.5)
    travel_limit = cfg["sleeve"]["travel"]
    for s in summary["sleeve_max_travel_mm"]:
        assert 0.0 < s <= travel_limit
    ts = np.genfromtxt(run / "timeseries.csv", delimiter=",", names=True)
    assert np.all(np.isfinite(ts["punch_fz_n"]))
    assert ts["punch_fz_n"].max() > 1.0                    # the soil pushes the punch up


@pytest.mark.scene
def test_spacing_is_2piR_over_N_and_no_grain_is_lost(two_holes):
    summary, run = two_holes
    state = np.load(run / "state.npz")
    cfg = json.loads((run / "config.json").read_text())
    pos, rad = state["pos"], state["radius"]
    assert len(rad) == summary["particles"] and np.all(np.isfinite(pos))
    L, W, _ = (s / 1000 for s in cfg["bed_size_mm"])
    assert np.all((pos[:, 0] > -0.01) & (pos[:, 0] < L + 0.01) & (pos[:, 1] > -0.01) & (pos[:, 1] < W + 0.01)
                  & (pos[:, 2] > -0.01))
    x = deficit_centres(pos, state["initial_pos"], rad, W / 2, cfg["disk"]["D"] / 4000, 2 * rad.mean(),
                        [h / 1000 for h in summary["hole_x_mm"][summary["lead_in"]:]], 0.09)
    expected = hole_spacing(load_disk("configs/disk.toml"), cfg["slip"]) / 1000
    assert abs((x[1] - x[0]) - expected) < 2 * rad.mean()


@pytest.mark.scene
def test_free_rolling_at_low_resistance_rolls_without_slip(side_scenes):
    """Without bonds the free disk turns nearly at the rolling rate: the slip its hole spacing gives (eq 1) stays
    near zero, where a locked disk would give δ → 1 and a spinning one δ ≪ 0. One spacing on this short strip
    scatters with the packing: packings 1-6 on one machine gave -0.150 to +0.021 (mean -0.062, SD 0.060), and
    packing 1 gave +0.101 on another; the bound is the mean ± 4 SD, |δ| < 0.3."""
    summary = json.loads(side_scenes["low-resistance"].result().stdout.strip().splitlines()[-1])
    assert len(summary["slip_holes"]) == 1 and abs(summary["slip_holes"][0]) < 0.3


@pytest.mark.scene
def test_weight_sets_the_penetration(side_scenes):
    """Free rolling with sinking under W (the 120 mm strip, one hole): a light disk rides up on its punches, so
    its tip goes less deep than the prescribed 70 mm; a heavy one sinks until its tips reach the strip's floor,
    and the run stops saying so instead of writing a hole."""
    summary = json.loads(side_scenes["light"].result().stdout.strip().splitlines()[-1])
    assert 5.0 < summary["tip_min_depth_mm"][0] < 60.0
    assert summary["axis_sink_mm"]["min"] < -10.0                  # the axis rose above the prescribed height
    heavy = side_scenes["heavy"].result()
    assert heavy.returncode == 3 and "sank" in heavy.stderr and "floor" in heavy.stderr


@pytest.mark.parametrize("args, field", [(["--slip", "1.5"], "slip"), (["--speed-kmh", "0"], "speed_kmh"),
                                         (["--mode", "dragged"], "mode"), (["--depth", "50"], "depth"),
                                         (["--weight", "100"], "weight"),
                                         (["--mode", "free", "--weight", "0.1"], "weight"),
                                         (["--lateral", "open"], "lateral"), (["--awake", "60"], "awake"),
                                         (["--awake=-5,100"], "awake"), (["--depth-stop", "75"], "depth_stop"),
                                         (["--mode", "free", "--weight", "100", "--depth-stop", "65"], "depth_stop"),
                                         (["--mode", "free", "--weight", "100", "--depth-stop", "90"], "depth_stop"),
                                         (["--tilled", "100"], "tilled"), (["--tilled", "60,1.2"], "tilled.density"),
                                         (["--tilled", "5,0.85"], "tilled.depth"),
                                         (["--tilled", "200,0.85"], "tilled.depth"),
                                         # each inside its own range, together an unstable plate (ω·dt in the
                                         # thousands): refused before the scene, not left to run
                                         (["--tool", "sleeve.mass=1e-9", "--tool", "sleeve.stiffness=1e4"],
                                          "sleeve.mass")])
def test_bad_run_input_names_the_field(args, field):
    from analysis.core.run_spec import plan_from_argv
    with pytest.raises(ConfigError) as e:
        plan_from_argv(["--soil", "clay", "--preset", "test", *args])
    assert field in str(e.value) and "allowed" in str(e.value), str(e.value)


def test_the_tool_guard_stops_a_balance_no_force_explains():
    """The guard on the tools (analysis/core/energy.py): a finished strip's 2.5 % residual passes; the unstable
    sleeve's run (work -577,906 J, residual 107 % of it) stops; so does a residual above half the bed's
    kinetic scale before the tools have worked."""
    from analysis.core.energy import tool_guard
    tool_guard({"work_tool": 401.9, "residual": 10.2}, 10.0)
    tool_guard({"work_tool": 0.5, "residual": 4.0}, 10.0)
    for balance in ({"work_tool": -577906.0, "residual": -618000.0}, {"work_tool": 0.5, "residual": 6.0},
                    {"work_tool": 1.0, "residual": float("nan")}):
        with pytest.raises(RuntimeError, match="energy balance broke"):
            tool_guard(balance, 10.0)


def test_a_tilled_layer_is_a_new_run_and_an_untilled_one_keeps_its_id():
    from analysis.core.run_spec import plan
    plain, tilled = plan("clay", "test"), plan("clay", "test", tilled=[60, 0.85])
    assert "tilled" not in plain and tilled["tilled"] == {"depth_mm": 60.0, "density": 0.85}
    assert tilled["id"] != plain["id"] and tilled["bed_size_mm"] == plain["bed_size_mm"]     # the same bed


def test_the_scene_refuses_bad_input_before_building_a_bed(tmp_path):
    r = run_scene(tmp_path, "--soil", "clay", "--slip", "1.5", expect_ok=False)
    assert r.returncode == 2 and "slip" in r.stderr and "allowed" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "beds").exists()            # rejected before any scene was built


@pytest.mark.scene
def test_energy_balance_closes(two_holes):
    """The tools' work on the soil = Δkinetic + Δelastic + Δpotential + booked dissipation + residual; the
    residual (bond energy lost at breakage, integration error) stays within 3 % of the work."""
    e = two_holes[0]["energy_J"]
    assert e["work_tool"] > 1.0
    dissipated = {k: v for k, v in e.items() if k.startswith("dissipated_")}
    assert dissipated["dissipated_shearDissip"] > 0 and dissipated["dissipated_nonviscDamp"] > 0
    assert abs(e["residual_fraction"]) < 0.03, e


@pytest.mark.scene
def test_the_yade_version_is_read_one_way(two_holes):
    """The scene (YADE loaded, its bed settled in the same process or not) and this process (no YADE) write the
    same version text into a run's provenance."""
    from analysis.core.io import yade_version
    summary, run = two_holes
    assert summary["provenance"]["yade"] == yade_version() == json.loads((run / "config.json").read_text()).get(
        "provenance", summary["provenance"])["yade"]


@pytest.mark.scene
def test_periodic_strip_forms_a_measured_hole_without_side_walls(side_scenes, scene_dirs):
    """The strip periodic across the travel (the paper preset's sides): the punch reaches its
    depth, the sleeve works, no grain is lost, positions come back wrapped into the cell's width, and the hole
    is measured (test_bed checks that a periodic bed has no wall layer at its sides)."""
    from analysis.holes import measure
    summary = json.loads(side_scenes["periodic"].result().stdout.strip().splitlines()[-1])
    run = scene_dirs[0] / summary["id"]
    cfg = json.loads((run / "config.json").read_text())
    assert cfg["preset"]["lateral"] == "periodic"
    assert summary["tip_min_depth_mm"] == pytest.approx([cfg["disk"]["penetration"]], abs=0.5)
    assert 0.0 < summary["sleeve_max_travel_mm"][0] <= cfg["sleeve"]["travel"]
    state = np.load(run / "state.npz")
    pos = state["pos"]
    L, W, _ = (s / 1000 for s in cfg["bed_size_mm"])
    assert len(pos) == summary["particles"] and np.all(np.isfinite(pos))
    assert np.all((pos[:, 1] >= 0) & (pos[:, 1] < W)) and np.all((pos[:, 0] > -0.01) & (pos[:, 0] < L + 0.01))
    hole = measure.run(run).iloc[0]
    assert hole.found and all(np.isfinite(hole[m]) for m in ("L0", "L1", "L2", "h1")), hole.to_dict()


@pytest.mark.scene
def test_a_graded_bed_forms_a_hole_measured_at_its_fine_grains(side_scenes, scene_dirs):
    """A graded strip (configs/resolutions.toml: tiny_graded): the tip reaches the configured depth, no grain is
    lost, the balance closes, and the hole is found and measured with a probe of the fine grains' radius, from
    the fine zone's undisturbed level (the scene's and the metrology's agree within a fine radius)."""
    from analysis.holes import measure
    summary = json.loads(side_scenes["graded"].result().stdout.strip().splitlines()[-1])
    run = scene_dirs[0] / summary["id"]
    cfg = json.loads((run / "config.json").read_text())
    g = cfg["graded"]
    assert summary["tip_min_depth_mm"] == pytest.approx([cfg["disk"]["penetration"]], abs=0.5)
    state = np.load(run / "state.npz")
    rad = state["radius"]
    assert len(rad) == summary["particles"] and np.all(np.isfinite(state["pos"]))
    assert abs(summary["energy_J"]["residual_fraction"]) < 0.03
    fine = rad <= g["radius"] * (1 + g["spread"]) * (1 + 1e-9)
    assert 0 < (~fine).sum() < fine.sum()
    table, holes, z_surface, _, _ = measure.measure_run(run)
    hole = table.iloc[0]
    assert hole.found and all(np.isfinite(hole[m]) for m in ("L0", "L1", "L2", "h1")), hole.to_dict()
    assert hole.probe == pytest.approx(1000 * rad[fine].mean())
    assert z_surface == pytest.approx(1000 * summary["z_surface_m"], abs=1000 * g["radius"])


@pytest.mark.scene
def test_a_sleeping_far_field_keeps_the_work_of_forming_the_holes(side_scenes, scene_dirs):
    """--awake 60,120: only the soil within 60 mm behind and 120 mm ahead of the tools' reach moves. A good
    part of the strip sleeps at any time, yet every hole is formed to depth and measured, no grain is lost, the
    energy balance still closes with the window's jumps booked, and the tools do the work they do with every
    grain awake, within the scatter of round-off (coarse strip, contact modulus changed in the 8th digit: four
    all-awake runs 241-267 J, four windowed ones 231-284 J)."""
    from analysis.holes import measure
    asleep, awake = (json.loads(side_scenes[k].result().stdout.strip().splitlines()[-1]) for k in ("asleep", "awake"))
    assert awake["awake"] is None and 0.3 < asleep["awake"]["awake_fraction"] < 0.8, asleep["awake"]
    assert asleep["awake"]["slept_vmax_m_s"] < 0.05 * asleep["tip_speed_m_s"]     # only still grains sleep
    assert asleep["particles"] == awake["particles"] and asleep["steps"] == awake["steps"]
    assert asleep["tip_min_depth_mm"] == pytest.approx([70.0] * 3, abs=0.5)
    state = np.load(scene_dirs[0] / asleep["id"] / "state.npz")
    assert len(state["pos"]) == asleep["particles"] and np.all(np.isfinite(state["pos"]))
    e = asleep["energy_J"]
    assert math.isfinite(e["window"]) and abs(e["window"]) < 0.02 * e["work_tool"], e
    assert abs(e["residual_fraction"]) < 0.03, e
    assert e["work_tool"] == pytest.approx(awake["energy_J"]["work_tool"], rel=0.25)
    holes = measure.run(scene_dirs[0] / asleep["id"])
    assert len(holes) == 2 and holes.found.all()
    assert np.isfinite(holes[["L0", "L1", "L2", "h1"]].to_numpy()).all(), holes


COARSE_ONE_HOLE = ["--soil", "clay", "--holes", "1", "--lead-in", "0", "--threads", "1", "--resolution", "coarse"]


@pytest.mark.scene
def test_a_killed_run_goes_on_from_its_checkpoint(scene_dirs, tmp_path):
    """A run killed after a checkpoint, started again, resumes there and finishes the same run: the same steps,
    the records before the checkpoint as the uninterrupted run's (test_hard_cases' coarsest case), and the
    next 2 ms of punch force within 1 % (beyond that the two are different realisations: the collider
    rebuilt on loading orders contacts differently, and granular flow amplifies round-off)."""
    whole = json.loads(run_scene(None, *COARSE_ONE_HOLE, dirs=scene_dirs).stdout.strip().splitlines()[-1])
    runs = tmp_path / "runs"
    cmd = [sys.executable, str(ROOT / "scripts/disk.py"), "--preset", "test", "--out", str(runs),
           "--bed-dir", str(scene_dirs[1]), *COARSE_ONE_HOLE, "--checkpoint-every", "1"]
    folder = runs / whole["id"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while not (folder / "checkpoint.json").exists() and proc.poll() is None and time.time() - t0 < 600:
        time.sleep(0.1)
    proc.kill()
    proc.wait()
    ck = json.loads((folder / "checkpoint.json").read_text())
    assert (folder / ck["scene"]).exists() and not (folder / "summary.json").exists()
    # the collider benchmark runs segments from this checkpoint in a scratch copy and leaves the run as it was
    table = tmp_path / "collider.csv"
    bench = subprocess.run([sys.executable, str(ROOT / "scripts/collider_bench.py"), str(folder), "--steps", "200",
                            "--threads", "1", "--out", str(table)], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert bench.returncode == 0, bench.stderr[-3000:]
    segments = pd.read_csv(table, comment="#")
    assert len(segments) == 5 and (segments.steps == 200).all() and (segments.wall_s > 0).all()
    assert (segments.detections > 0).all() and (segments.contacts > 0).all() and (segments.share_contacts > 0).all()
    shares = segments.filter(like="share_").sum(axis=1)
    assert ((shares > 0.3) & (shares < 1.05)).all(), shares      # the engines' timed parts within the wall time
    # the first setting's repeat (one thread) is the same run bit for bit; 200 steps: grains barely move
    assert (segments.drift_max_mm.iloc[:2] == 0).all() and (segments.drift_max_mm < 5).all()
    assert json.loads((folder / "checkpoint.json").read_text()) == ck and not (folder / "summary.json").exists()
    # the profile of the run's first steps from its bed, each treatment of the sleepers its own row; a repeat
    # replaces its row
    profile = tmp_path / "profile.csv"
    for visit in ("", "1", ""):
        env = {k: v for k, v in os.environ.items() if k != "HOLES_VISIT_SLEEPERS"} | (
            {"HOLES_VISIT_SLEEPERS": visit} if visit else {})
        p = subprocess.run([sys.executable, str(ROOT / "scripts/collider_bench.py"), str(folder), "--profile",
                            "--from-start", "--bed-dir", str(scene_dirs[1]), "--steps", "200", "--threads", "1",
                            "--out", str(profile)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, p.stderr[-3000:]
    rows = pd.read_csv(profile, comment="#")
    assert sorted(rows.sleepers) == ["skipped", "visited"] and (rows.from_step == 0).all(), rows
    assert ((rows.steps > 150) & (rows.steps <= 200)).all() and (rows.share_contacts > 0).all()
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=1500)
    assert r.returncode == 0, r.stderr[-3000:]
    resumed_at = int(r.stderr.split("resumed at step ")[1].split()[0])
    assert 0 < resumed_at < whole["steps"]
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["steps"] == whole["steps"] and summary["particles"] == whole["particles"]
    assert summary["resumed_at_steps"] == [resumed_at] and whole["resumed_at_steps"] == []   # the resume recorded
    assert not list(folder.glob("checkpoint*"))
    a = pd.read_csv(scene_dirs[0] / whole["id"] / "timeseries.csv")
    b = pd.read_csv(folder / "timeseries.csv")
    assert len(a) == len(b)
    t_resume = resumed_at * summary["dt"]
    before, after = a.t_s < t_resume - 1e-9, (a.t_s >= t_resume) & (a.t_s < t_resume + 2e-3)
    pd.testing.assert_frame_equal(a[before], b[before])
    assert after.sum() > 0
    force_a, force_b = a[after].punch_fz_n.to_numpy(), b[after].punch_fz_n.to_numpy()
    assert np.allclose(force_b, force_a, rtol=0.01, atol=1.0), (force_a, force_b)


@pytest.mark.scene
def test_a_killed_sleeping_run_goes_on_from_its_checkpoint(scene_dirs, tmp_path):
    """A run with a sleeping far field (`--awake`, the validation presets' way) killed after a checkpoint resumes
    and finishes: its window moves at once on resuming, before any step has run (YADE's contact law knows its
    scene only after a step: asking it for the stored energy there crashed the process), the steps are the
    planned ones, and the energy balance closes with the window's jumps booked."""
    runs = tmp_path / "runs"
    cmd = [sys.executable, str(ROOT / "scripts/disk.py"), "--preset", "test", "--out", str(runs),
           "--bed-dir", str(scene_dirs[1]), *COARSE_ONE_HOLE, "--awake", "60,120", "--checkpoint-every", "1"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while not list(runs.glob("*/checkpoint.json")) and proc.poll() is None and time.time() - t0 < 600:
        time.sleep(0.1)
    proc.kill()
    proc.wait()
    assert list(runs.glob("*/checkpoint.json")), "no checkpoint was written"
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=1500)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "resumed at step " in r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    planned = int(re.search(r"(\d+) steps of ", r.stderr).group(1))
    assert summary["steps"] == planned
    e = summary["energy_J"]
    assert summary["awake"]["moves"] > 0 and math.isfinite(e["window"]), summary["awake"]
    assert abs(e["residual_fraction"]) < 0.03, e


@pytest.mark.scene
def test_sleepers_left_out_of_the_per_body_loops_change_nothing(scene_dirs, tmp_path):
    """Sleepers sit in a second subdomain, so YADE's integration and force reset skip them (awake.SKIP_SLEEPERS);
    the collider and the contacts still have them. On one thread the run is the same bit for bit as one that
    visits every sleeper at every step: a short coarse strip with a narrow window, so that grains are put to sleep
    and woken again many times."""
    finals = []
    for visit in ("", "1"):
        runs = tmp_path / f"runs{visit}"
        r = subprocess.run([sys.executable, str(ROOT / "scripts/disk.py"), "--preset", "test", "--out", str(runs),
                            "--bed-dir", str(scene_dirs[1]), *COARSE_ONE_HOLE, "--awake", "20,40"], cwd=ROOT,
                           capture_output=True, text=True, timeout=1500, env={**os.environ, "HOLES_VISIT_SLEEPERS": visit})
        assert r.returncode == 0, r.stderr[-3000:]
        summary = json.loads(r.stdout.strip().splitlines()[-1])
        assert summary["awake"]["moves"] > 20 and summary["awake"]["awake_fraction"] < 0.8, summary["awake"]
        finals.append(np.load(runs / summary["id"] / "state.npz")["pos"])
    assert np.array_equal(finals[0], finals[1])


@pytest.mark.parametrize("changes, pattern", [
    ({"slip": 0.1, "tool": {"disk.slip": 0.5}}, "run.slip and disk.slip are both given"),
    ({"speed_kmh": 2.0, "tool": {"disk.speed_kmh": 3.0}}, "run.speed_kmh and disk.speed_kmh are both given"),
    ({"disk_inertia": 0.2}, "run.disk_inertia = 0.2: allowed only in free mode")])
def test_conflicting_or_idle_run_options_are_refused(changes, pattern):
    """One value per quantity: `--slip 0.1 --tool disk.slip=0.5` ran 0.1 and recorded 0.5; a prescribed disk's
    inertia changed its id and nothing else."""
    from analysis.core.run_spec import plan
    with pytest.raises(ConfigError, match=pattern):
        plan("clay", "test", **changes)
    assert plan("clay", "test", mode="free", disk_inertia=0.2)["disk_inertia"] == 0.2
