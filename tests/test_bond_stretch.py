"""Bond stretch (`bond_stretch`, scripts/soil.py): a ductile bond pulled to its tensile strength holds that force while
it stretches by bond_stretch radii of the smaller grain, and parts beyond; at 0 it parts once its strength is passed.
Two bonded grains pulled apart in their own YADE process."""
import json
import subprocess
import sys

import pytest

from analysis.core.schema import ROOT, ConfigError
from analysis.core.soil_config import load_soil, soil_with

PULL = """
import json, sys
sys.path.insert(0, {root!r})
from scripts.yadeboot import boot
boot(1)
from yade import O, utils, Vector3
from analysis.core.soil_config import load_soil, soil_with
from scripts import soil as part

out = {{}}
for stretch in (0.0, 0.1):
    O.reset()
    soil = soil_with(load_soil("clay"), {{"bond_fragile": 0, "new_contact_cohesion": 0, "normal_cohesion": 9e4,
                                          "shear_cohesion": 9e4, "bond_stretch": stretch}})
    mat = O.materials.append(part.soil_material(soil, density=2000.0))
    r = 0.006
    a = O.bodies.append(utils.sphere((0, 0, 0), r, material=mat, fixed=True))
    b = O.bodies.append(utils.sphere((2 * r - 1e-5, 0, 0), r, material=mat, fixed=True))
    O.engines = part.engines(0.0, cohesion_on_new_contacts=True, cohesion_now=True, gravity=(0, 0, 0),
                             extra=part.bond_rules(O, soil, every=1))
    O.dt = 1e-6
    O.run(2, True)
    bond = O.interactions[a, b].phys.normalAdhesion
    O.bodies[b].state.vel = Vector3(1.0, 0, 0)            # 1 um a step
    held = 0.0
    while O.interactions.has(a, b) and O.interactions[a, b].isReal and O.iter < 20000:
        O.run(2, True)
        if O.interactions.has(a, b) and O.interactions[a, b].isReal:
            held = max(held, O.interactions[a, b].phys.normalForce.norm())
    out[str(stretch)] = {{"gap_r": (O.bodies[b].state.pos[0] - 2 * r) / r, "held_n": held, "bond_n": bond}}
print(json.dumps(out))
"""


def test_bond_stretch_is_off_unless_set_and_refused_on_fragile_bonds():
    """A soil without `bond_stretch` has none; a stretch on fragile bonds (which part once exceeded) or out of its
    range is refused, naming the key."""
    assert load_soil("clay").bond_stretch == 0.0
    assert soil_with(load_soil("clay"), {"bond_fragile": 0, "bond_stretch": 0.2}).bond_stretch == 0.2
    with pytest.raises(ConfigError, match=r"bond_stretch = 0.2 with bond_fragile = 1.*allowed"):
        soil_with(load_soil("clay"), {"bond_fragile": 1, "bond_stretch": 0.2})
    with pytest.raises(ConfigError, match=r"bond_stretch.*out of range.*allowed"):
        soil_with(load_soil("clay"), {"bond_fragile": 0, "bond_stretch": 2})


@pytest.mark.scene
def test_a_stretched_bond_holds_its_strength_until_it_has_stretched_its_share_of_a_radius():
    """Two grains (r = 6 mm, bond 9e4 Pa × r² = 3.24 N) pulled apart: without stretch the bond parts within its
    elastic reach (about 27 um, 0.005 r); with 0.1 it holds 3.24 N and parts after 0.1 r more."""
    r = subprocess.run([sys.executable, "-c", PULL.format(root=str(ROOT))], capture_output=True, text=True,
                       timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    rigid, stretched = out["0.0"], out["0.1"]
    assert rigid["bond_n"] == pytest.approx(3.24, rel=1e-3) and rigid["gap_r"] < 0.01, rigid
    assert stretched["gap_r"] == pytest.approx(0.1 + rigid["gap_r"], abs=0.005), stretched
    assert stretched["held_n"] == pytest.approx(stretched["bond_n"], rel=0.01), stretched
