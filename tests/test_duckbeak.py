"""The duck-beak planter of seed 000 through a soil bed."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from analysis.pepper import pepper
from analysis.core.schema import ROOT, ConfigError
from scripts import duckbeak

SPEED, OMEGA = 300.0, 2 * math.pi          # configs/pepper.toml [operation]: 0.3 m/s, 60 plants/min


@pytest.mark.parametrize("column", ["initial", "designed"])
def test_the_pass_runs_from_clearance_down_to_the_loop_depth_and_back(column):
    link = pepper.load_linkage(column)
    ps = pepper.planter_pass(link, SPEED, OMEGA, clearance=20.0)
    _, y, _ = pepper.pose(link, SPEED, OMEGA, [ps.t_in, ps.t_bottom, ps.t_out], ps.y_ground)
    assert y[0] == pytest.approx(20.0, abs=0.5) and y[2] == pytest.approx(20.0, abs=0.5)
    assert -y[1] == pytest.approx(ps.depth)
    assert ps.depth == pytest.approx(pepper.trajectory_metrics(link, SPEED, OMEGA)["depth"], abs=0.2)
    assert ps.t_in < ps.t_bottom < ps.t_out


@pytest.mark.parametrize("change, field", [({"D": 5.0}, "planter].D"), ({"width": 100.0}, "width"),
                                           ({"beak_length": 40.0, "body_length": 10.0}, "beak_length"),
                                           ({"clearance": 0.0}, "clearance"), ({"column": "best"}, "column"),
                                           ({"soil": "peat"}, "peat"), ({"stiffness": 3.0}, "stiffness")])
def test_bad_duckbeak_input_names_the_field(change, field):
    with pytest.raises(ConfigError, match=field.replace("[", r"\[").replace("]", r"\]")):
        duckbeak.plan(**change)


def run_duckbeak(dirs):
    """The duck-beak scene on a coarse, narrow bed, one thread (conftest's side_scenes runs it in the background)."""
    runs, beds = dirs
    return subprocess.run([sys.executable, str(ROOT / "scripts/duckbeak.py"), "--resolution", "tiny", "--threads", "1",
                           "--set", "width=130", "--set", "margin=10", "--set", "below=25", "--set", "relax=0.6",
                           "--set", "dt_safety=0.8", "--out", str(runs), "--bed-dir", str(beds),
                           "--report", str(runs.parent / "duckbeak-report")],
                          capture_output=True, text=True, timeout=1200, cwd=ROOT)


@pytest.mark.scene
def test_the_duckbeak_forms_a_measured_hole(side_scenes, scene_dirs):
    """The closed beak reaches the loop's depth and leaves a hole about as wide as itself."""
    from analysis.holes.measure import measure_run
    r = side_scenes["duckbeak"].result()
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    run = scene_dirs[0] / summary["id"]
    table = measure_run(run)[0]
    hole = table.iloc[0]
    depth, D = summary["path_depth_mm"], 60.0
    assert summary["settled"]                                     # measured at rest, not mid-flight
    assert summary["tip_min_depth_mm"][0] > depth - 2             # the tip went where the linkage took it
    assert 0.3 * depth < hole.bottom < depth + 2                  # and left a hole (loose soil falls back in)
    assert 0.6 * D < hole.L1 < 2.5 * D and 0.6 * D < hole.L0      # about as wide as the beak (longer: it rocks)
    state = np.load(run / "state.npz")
    assert len(state["pos"]) == len(state["initial_pos"])
