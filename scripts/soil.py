"""Scene part: the moist-soil contact physics (YADE CohFrictMat family), shared by every scene.

Cohesion is a bond strength in Pa times the smaller grain's radius squared, r_min² (YADE 2023.02a's Ip2, no π: 48
kPa bonds 1.18 N at r_min 4.96 mm), so a bond's force scales with the particle size and the bed's macroscopic
cohesion does not depend on the resolution to first order.
`Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionOnNewContacts=True)` bonds every new contact, so soil that a
punch has broken re-adheres where it is pressed together (as moist soil does). Fragile bonds (`bond_fragile` 1),
once their strength is exceeded, leave friction only; ductile ones (0) slide keeping their shear strength, as the
suction of a moist soil's water holds while it shears, and break only when pulled apart. Rolling resistance
(`momentRotationLaw`, alphaKr, etaRoll) stands in for grain angularity. Pressed re-adhesion (`pressed_adhesion` α
above 0): a contact holding less than the intact bond gains a bond of α times the compressive force it carries,
kept at the most it was pressed to and at most the intact bond, as moist soil pressed together re-adheres and a
loose heap of it does not (the pull-off force of elasto-plastic adhesive contacts grows with their preload). With
an onset (`adhesion_onset` above 0, a pressure: times r_min² a force) only a contact compressed beyond it re-adheres,
as a moist contact re-adheres once it yields plastically (Tomas's contact consolidation), so a heap's light contacts
stay as they were while soil pressed by a tool or a confining stress re-adheres; the press must hold over two of
the rule's passes, 20 steps apart, longer than a grain's impact lasts, so grains striking one another do not bond.
With a share (`adhesion_share` above 0, in place of α, with an onset) a contact held pressed past the onset
re-adheres at that share of the intact bond whatever its press: the bond of a moist contact that has yielded is set by
its water bridges, so soil pressed by a tool or a confining stress gains the same cohesion at every stress, where α F
grows with the press as friction does.
Bond stretch (`bond_stretch` above 0, ductile bonds): a bond pulled to its tensile strength holds it while it
stretches by that many radii of the smaller grain, and parts beyond (YADE's CohFrictPhys.unpMax), as a moist soil's
water bridge necks before it snaps; at 0 it parts once its strength is passed.
Tools are steel (25°, never bonded); YADE's Ip2 gives a contact the lesser of its two materials' friction angles, so a
grain slides on a tool at its own friction where that is under the steel's, unless the soil names a tool friction
(`tool_friction_deg` above 0, `hold_tool_friction`), which every grain-steel contact then takes.
"""
import math

from yade import (CohFrictMat, ForceResetter, InsertionSortCollider, InteractionLoop, NewtonIntegrator,
                  Bo1_Sphere_Aabb, Bo1_Box_Aabb, Bo1_Facet_Aabb, Ig2_Sphere_Sphere_ScGeom6D,
                  Ig2_Box_Sphere_ScGeom6D, Ig2_Facet_Sphere_ScGeom6D, Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                  Law2_ScGeom6D_CohFrictPhys_CohesionMoment)

GRAVITY = (0.0, 0.0, -9.81)
PRESS_EVERY = 20                 # steps between the passes of the pressed re-adhesion
CELL_MARGIN = 0.1                # m between anything in a periodic cell and its nearest image
STEEL_SOIL_FRICTION_DEG = 25.0   # soil on polished steel, typical 20-30 deg


def soil_material(soil, density: float, young: float | None = None, cohesive: bool = True, label: str = "soil"):
    """The soil's particle material; `young` overrides the modulus (softer while settling). Spheres labelled "soil"
    are the grains the bond rules act on; a bench test's fixed grains take another label."""
    return CohFrictMat(young=young or soil.young, poisson=soil.poisson, frictionAngle=math.radians(soil.friction_deg),
                       density=density, isCohesive=cohesive, fragile=bool(soil.bond_fragile),
                       normalCohesion=soil.normal_cohesion if cohesive else 0.0,
                       shearCohesion=soil.shear_cohesion if cohesive else 0.0,
                       momentRotationLaw=True, alphaKr=soil.rolling_stiffness, etaRoll=soil.rolling_friction,
                       label=label)


def disturbed(soil):
    """The soil as its disturbed grains have it: every bond new_contact_cohesion of the intact one (a column let
    collapse, a remoulded sample), the intact bond still the cap of its pressed re-adhesion."""
    from analysis.core.soil_config import soil_with
    return soil_with(soil, {"normal_cohesion": soil.new_contact_cohesion * soil.normal_cohesion,
                            "shear_cohesion": soil.new_contact_cohesion * soil.shear_cohesion})


def steel_material(soil, friction_deg: float = STEEL_SOIL_FRICTION_DEG):
    """Tools and container walls: frictional (`friction_deg`; 0 for a bench test's smooth frame), never bonded,
    no rolling moment."""
    return CohFrictMat(young=soil.young, poisson=soil.poisson, frictionAngle=math.radians(friction_deg),
                       density=7850.0, isCohesive=False, momentRotationLaw=False, label="steel")


def container(L: float, W: float, H: float, material, t: float = 0.02, lateral: str = "walls") -> list:
    """A fixed floor at z = 0 under [0, L] × [0, W] and four side walls of height H round it (YADE boxes). A
    laterally periodic bed has no walls, and its floor is 4 × 4 tiles filling the cell: YADE's periodic collider
    needs every body smaller than half the period."""
    from yade import utils
    if lateral == "periodic":
        n = 4
        return [utils.box(((i + 0.5) * L / n, (j + 0.5) * W / n, -t), (L / (2 * n), W / (2 * n), t), fixed=True,
                          material=material) for i in range(n) for j in range(n)]
    boxes = [((L / 2, W / 2, -t), (L / 2 + t, W / 2 + t, t))]
    sides = (((-t, W / 2), (t, W / 2 + t)), ((L + t, W / 2), (t, W / 2 + t)),       # x = 0 and x = L
             ((L / 2, -t), (L / 2 + t, t)), ((L / 2, W + t), (L / 2 + t, t)))       # y = 0 and y = W
    boxes += [((*centre, H / 2), (*half, H / 2 + t)) for centre, half in sides]
    return [utils.box(c, e, fixed=True, material=material) for c, e in boxes]


def end_walls(x_lo: float, x_hi: float, W: float, H: float, material, t: float = 0.02, tiles: int = 4) -> list:
    """Walls from the floor to H across a laterally periodic strip, their faces at x_lo and x_hi, each made of
    square boxes, `tiles` across the width W (the periodic collider needs every body smaller than half the
    period, in z too)."""
    from yade import utils
    side = W / tiles
    rows = math.ceil(H / side)
    return [utils.box((x, (j + 0.5) * side, (k + 0.5) * H / rows), (t, side / 2, H / (2 * rows)), fixed=True,
                      material=material) for x in (x_lo - t, x_hi + t) for j in range(tiles) for k in range(rows)]


def periodic_cell(O, L: float, W: float, top: float):
    """Make the scene laterally periodic: a YADE periodic cell [0, L] × [0, W] × [0, top + CELL_MARGIN], so grains
    leaving one side re-enter at the other and a tool meets no side wall. YADE's cell is periodic in z too:
    `top` is the highest a grain or tool gets, and the floor's image stays CELL_MARGIN above it."""
    O.periodic = True
    O.cell.setBox(L, W, top + CELL_MARGIN)


def engines(damping: float, cohesion_on_new_contacts: bool, cohesion_now: bool = False, extra=(),
            avoid_self_mask: int = 0, gravity=GRAVITY):
    """Contact detection, the cohesive-frictional law, and Newton's integration under `gravity` (m/s²).
    `cohesion_now` bonds the contacts that exist at the first step (a settled bed); bodies whose masks share
    a bit with `avoid_self_mask` never meet one another (tool parts)."""
    return [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb(), Bo1_Facet_Aabb()],
                              avoidSelfInteractionMask=avoid_self_mask, label="collider"),
        InteractionLoop(
            [Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Box_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
            [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionOnNewContacts=cohesion_on_new_contacts,
                                                     setCohesionNow=cohesion_now, label="ip2")],
            [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=True,
                                                       label="law")]),
        *extra,
        NewtonIntegrator(gravity=gravity, damping=damping, label="newton"),
    ]


def hold_tool_friction(O, soil):
    """When the soil names a tool friction (`tool_friction_deg` above 0), every contact of a soil grain with steel
    (a tool) takes it, whatever the grain's own: YADE's Ip2 otherwise gives a contact the lesser of its two materials'
    angles, the grain's where it is under the steel's. Call once the materials and engines exist."""
    if not soil.tool_friction_deg:
        return
    from yade import MatchMaker
    soil_ids = [m.id for m in O.materials if m.label == "soil"]
    steel_ids = [m.id for m in O.materials if m.label == "steel"]
    angle = math.radians(soil.tool_friction_deg)
    ip2 = next(e for e in O.engines if isinstance(e, InteractionLoop)).physDispatcher.functors[0]
    ip2.frictAngle = MatchMaker(matches=[(a, b, angle) for a in soil_ids for b in steel_ids], algo="min")


def contact_law(O):
    """The scene's cohesive-frictional law functor (it books the contacts' elastic energy)."""
    return next(e for e in O.engines if isinstance(e, InteractionLoop)).lawDispatcher.functors[0]


def bond_new_contacts(O, soil):
    """Call once the intact bonds exist (after the first step of a scene that bonds its settled contacts): every
    contact made from now on, where the soil was disturbed, gets `new_contact_cohesion` of the intact bonds'
    strength (YADE's Ip2 reads the material's cohesion when a contact forms; bonds made earlier keep theirs)."""
    if soil.new_contact_cohesion == 1.0:
        return
    new = disturbed(soil)
    for m in O.materials:
        if m.label == "soil":
            m.normalCohesion, m.shearCohesion = new.normal_cohesion, new.shear_cohesion


def press_bonds(O, alpha: float, normal: float, shear: float, grain, stretch: float = 0.0, onset: float = 0.0,
                held: set | None = None, share: float = 0.0) -> int:
    """One pass of the bond rules (module doc) over the grain-grain contacts (`grain`: a bool per body id). Pressed
    re-adhesion (α > 0): a contact whose bond is below the intact one (`normal` times r_min², YADE's Ip2) and that is
    compressed by a force F gets α F as its bond when that is more than it holds, capped at the intact one. With an
    `onset` only a contact compressed by more than onset × r_min² at this pass and at the one before (its pair in
    `held`, which the pass then replaces with this pass's) re-adheres: a grain's impact lasts less than a pass's
    interval. With a `share` (> 0, α 0, with an onset) such a contact gets share × the intact bond instead of α F.
    Bond stretch (`stretch` > 0): every bonded contact not yet given it may stretch `stretch` × r_min at its
    strength before it parts. Returns how many bonds the pass made or raised."""
    n, size, now = 0, len(grain), set()
    for I in O.interactions:
        if not I.isReal or I.id1 >= size or I.id2 >= size or not (grain[I.id1] and grain[I.id2]):
            continue
        phys, geom = I.phys, I.geom
        r_min = min(geom.refR1, geom.refR2)
        cap = normal * r_min ** 2
        if (alpha or share) and phys.normalAdhesion < cap:
            pressed = phys.normalForce.dot(geom.normal)
            if onset:
                if pressed <= onset * r_min ** 2:
                    pressed = 0.0
                else:
                    now.add((I.id1, I.id2))
                    if held is not None and (I.id1, I.id2) not in held:
                        pressed = 0.0
            bond = min(cap, share * cap if share and pressed > 0 else alpha * pressed)
            if bond > phys.normalAdhesion:
                phys.normalAdhesion, phys.shearAdhesion, phys.cohesionBroken = bond, bond * shear / normal, False
                n += 1
        if stretch and phys.unpMax == 0 and phys.normalAdhesion > 0:
            phys.unpMax = stretch * r_min
    if held is not None:
        held.clear()
        held.update(now)
    return n


def bond_rules(O, soil, every: int = PRESS_EVERY) -> list:
    """The engine of the bond rules (module doc) when the soil has one (`pressed_adhesion`, `adhesion_share` or
    `bond_stretch` above 0), else none: every `every` steps a pass of press_bonds over the soil's spheres. PyRunner
    evaluates its command in YADE's global namespace: the pass is put there under a name no engine's label takes."""
    if not (soil.pressed_adhesion or soil.adhesion_share or soil.bond_stretch):
        return []
    import builtins
    import numpy as np
    from yade import PyRunner, Sphere

    grain, held = np.zeros(0, bool), set()

    def press():
        nonlocal grain
        if len(grain) != len(O.bodies):    # the soil's grains, not a tool's steel spheres (a punch's or cone's tip);
            grain = np.array([b is not None and isinstance(b.shape, Sphere) and b.material.label == "soil"
                              for b in O.bodies], bool)     # found again only when bodies come or go
        press_bonds(O, soil.pressed_adhesion, soil.normal_cohesion, soil.shear_cohesion, grain, soil.bond_stretch,
                    soil.adhesion_onset, held, soil.adhesion_share)

    builtins.holes_press_bonds = press
    return [PyRunner(command="holes_press_bonds()", iterPeriod=every, label="pressed")]
