"""Grains taken out of a tool scene's work, on tiny scenes each in its own YADE process: the awake window's
sleepers (scripts/awake.py: a grain that sleeps loses its bonds to other sleepers, and when it wakes its contacts
are the undisturbed soil's again) and the guard's splashed grains (scripts/parts.py guard)."""
import json
import subprocess
import sys

import pytest

from analysis.core.schema import ROOT

SCENE = """
import json, sys
sys.path.insert(0, {root!r})
from scripts.yadeboot import boot
boot(1)
from yade import O, utils
from analysis.core.soil_config import load_soil, soil_with
from scripts import soil as part
from scripts.awake import rebond, sleep_outside
from scripts.parts import GRAIN_MASK

soil = soil_with(load_soil("clay"), {{"new_contact_cohesion": 0.01, "bond_fragile": 0, "normal_cohesion": 3e5,
                                      "shear_cohesion": 3e5}})
mat = O.materials.append(part.soil_material(soil, density=2000.0))
r = 0.005
ids = [O.bodies.append(utils.sphere((i * 1.9 * r, j * 1.9 * r, k * 1.9 * r), r * (1 - 0.04 * ((i + j + k) % 2)),
                                    material=mat, mask=GRAIN_MASK))
       for i in range(6) for j in range(3) for k in range(3)]
O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True, gravity=(0, 0, 0))
O.dt = 1e-7
O.run(1, True)
part.bond_new_contacts(O, soil)
collider = next(e for e in O.engines if e.label == "collider")

def bonds():
    out = []
    for I in O.interactions:
        if I.isReal:
            r2 = min(O.bodies[I.id1].shape.radius, O.bodies[I.id2].shape.radius) ** 2
            out.append(I.phys.normalAdhesion / (soil.normal_cohesion * r2))
    return out

intact = bonds()
sleep_outside(ids, -1.0, 2.5 * 1.9 * r, collider, restless=1.0)      # the far half sleeps
asleep = len(bonds())
woken, *_ = sleep_outside(ids, -1.0, 1.0, collider, restless=1.0)     # and wakes
O.run(1, True)
remade = bonds()
rebond(woken, (soil.normal_cohesion, soil.shear_cohesion))
print(json.dumps({{"intact": intact, "asleep": asleep, "woken": len(woken), "remade": remade, "rebonded": bonds()}}))
"""


@pytest.mark.scene
def test_a_woken_grain_gets_the_undisturbed_soils_bonds_back():
    """Sleepers' mutual bonds go; when they wake, YADE makes their contacts as new ones, bonded at the disturbed
    share (0.01 of the intact bond here); `rebond` gives them the intact bond again, every contact as before."""
    r = subprocess.run([sys.executable, "-c", SCENE.format(root=str(ROOT))], capture_output=True, text=True,
                       timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert len(out["intact"]) > 50 and out["intact"] == pytest.approx([1.0] * len(out["intact"]))
    assert out["asleep"] < len(out["intact"]) and out["woken"] > 0
    assert len(out["remade"]) == len(out["intact"])
    assert min(out["remade"]) == pytest.approx(0.01)                   # what the window did without rebond
    assert out["rebonded"] == pytest.approx([1.0] * len(out["intact"]))


GUARD = """
import json, sys
sys.path.insert(0, {root!r})
from scripts.yadeboot import boot
boot(1)
from yade import O, utils
from analysis.core.soil_config import load_soil
from scripts import soil as part
from scripts.parts import GRAIN_MASK, PARKED_DEPTH, guard

mat = O.materials.append(part.soil_material(load_soil("clay"), density=2000.0))
r = 0.005
pair = [O.bodies.append(utils.sphere((0.05 + 1.9 * r * k, 0.05, 0.02), r, material=mat, mask=GRAIN_MASK)) for k in range(2)]
lone = O.bodies.append(utils.sphere((0.05, -0.05, 0.5), r, material=mat, mask=GRAIN_MASK))     # over the side wall
O.engines = part.engines(0.2, cohesion_on_new_contacts=True, cohesion_now=True, gravity=(0, 0, 0))
O.dt = 1e-7
O.run(1, True)
meta = {{"size_m": [0.2, 0.1, 0.05]}}
out = {{}}
try:
    guard(pair + [lone], meta, 0.05, 10.0, 1e9)
except RuntimeError as e:
    out["without"] = str(e)
splashes = []
out["vmax"] = guard(pair + [lone], meta, 0.05, 10.0, 1e9, splashes)
out["splashes"] = splashes
b = O.bodies[lone]
out["parked"] = [list(b.state.pos), b.dynamic, b.mask, PARKED_DEPTH]
O.bodies[pair[1]].state.pos = (0.05 + 1.9 * r, 0.05, 0.5)                # a bonded pair pulled out together
O.bodies[pair[0]].state.pos = (0.05, 0.05, 0.5)
try:
    guard(pair + [lone], meta, 0.05, 10.0, 1e9, splashes)
except RuntimeError as e:
    out["carried"] = str(e)
print(json.dumps(out))
"""


@pytest.mark.scene
def test_a_grain_splashed_out_of_the_box_is_parked_and_a_carried_one_stops_the_scene():
    """Without a splash list the guard stops a scene when a grain leaves the box; with one, a lone slow grain is
    parked under the floor inside the bed's footprint, meeting nothing, noted, and the scene goes on; grains that
    leave touching one another (a clod) still stop it, named."""
    r = subprocess.run([sys.executable, "-c", GUARD.format(root=str(ROOT))], capture_output=True, text=True,
                       timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert "left the box" in out["without"] and "touching 0 tool bodies and 0 grains" in out["without"]
    assert len(out["splashes"]) == 1 and out["splashes"][0]["pos_m"][2] == pytest.approx(0.5)
    pos, dynamic, mask, depth = out["parked"]
    assert pos == pytest.approx([0.05, 0.0, -depth]) and not dynamic and mask == 0
    assert "left the box" in out["carried"] and "touching 0 tool bodies and 1 grains (1 bonded)" in out["carried"]
