"""Benchmark: the same settled bed and single punch in LIGGGHTS (Debian's `liggghts`) and in YADE.

    .venv/bin/python scripts/peer.py          # or: ./holes bench peer

Both codes start from one settled bed (scripts/beds.py, clay, quick grains) with one time step (half YADE's
P-wave critical step), on one thread, and run two phases: the bed at rest under gravity (`REST_STEPS`: the
settling's contact-rich cost per step) and one punch (seed 001's D = 50 mm cylinder and cone) pushed straight
down into it at 1 m/s (`PUNCH_STEPS`). Contact laws: the ones each code would use for moist soil. YADE: the
scenes' CohFrictMat with cohesion on new contacts and rolling resistance (scripts/soil.py). LIGGGHTS: Hertz
with tangential history, SJKR cohesion and CDT rolling friction, the same modulus, Poisson ratio, friction and
rolling coefficient. They are not the same law, so this compares cost, not answers.
Writes results/bench/peer.csv: per code and phase the wall time, particles, steps, particle-steps/s and the
machine, YADE's speed as a fraction of LIGGGHTS', and the soil's vertical force on the punch at the end (the
same scene in both: the punch is in the soil in both).
"""
from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.config import load_disk  # noqa: E402
from analysis.core.schema import ROOT
from analysis.core.soil_config import load_soil
from analysis.core.io import atomic_csv, machine  # noqa: E402
from analysis.core.kinematics import TIP_SPHERE_RATIO  # noqa: E402

BED = ("clay", "quick", (200, 200, 280), 1)      # soil, resolution, size (mm), seed: the calibration bed
REST_STEPS, PUNCH_STEPS = 2000, 3000
PUNCH_SPEED = 1.0           # m/s, straight down
PUNCH_LENGTH = 120.0        # mm of punch modelled (cylinder + cone)
START_ABOVE = 5.0           # mm between the tip and the bed's top at the start
LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")
LAST_FORCE = re.compile(rf"^\s*{REST_STEPS + PUNCH_STEPS}\s+\d+\s+\S+\s+(\S+)\s*$", re.M)


def liggghts_input(soil, dt: float, radius: float, L: float, W: float) -> str:
    """The LIGGGHTS script: read the bed, rest, then push the punch mesh (punch.stl, mm) down."""
    mu, mu_w = math.tan(math.radians(soil.friction_deg)), math.tan(math.radians(25.0))
    return f"""# made by scripts/peer.py
atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
units si
processors 1 1 1
read_data bed.data
neighbor {0.5 * radius:g} bin
neigh_modify delay 0
fix m1 all property/global youngsModulus peratomtype {soil.young:g} {soil.young:g}
fix m2 all property/global poissonsRatio peratomtype {soil.poisson:g} {soil.poisson:g}
fix m3 all property/global coefficientRestitution peratomtypepair 2 0.5 0.5 0.5 0.5
fix m4 all property/global coefficientFriction peratomtypepair 2 {mu:.4f} {mu_w:.4f} {mu_w:.4f} {mu_w:.4f}
fix m5 all property/global coefficientRollingFriction peratomtypepair 2 {soil.rolling_friction:g} 0 0 0
fix m6 all property/global cohesionEnergyDensity peratomtypepair 2 {soil.normal_cohesion:g} 0 0 0
pair_style gran model hertz tangential history cohesion sjkr rolling_friction cdt
pair_coeff * *
timestep {dt:.6g}
fix gravi all gravity 9.81 vector 0.0 0.0 -1.0
fix floor all wall/gran model hertz tangential history primitive type 2 zplane 0.0
fix wx0 all wall/gran model hertz tangential history primitive type 2 xplane 0.0
fix wx1 all wall/gran model hertz tangential history primitive type 2 xplane {L:g}
fix wy0 all wall/gran model hertz tangential history primitive type 2 yplane 0.0
fix wy1 all wall/gran model hertz tangential history primitive type 2 yplane {W:g}
fix integr all nve/sphere
thermo_style custom step atoms ke
thermo 1000
thermo_modify lost error norm no
run {REST_STEPS}
fix punch all mesh/surface/stress file punch.stl type 2 scale 0.001
fix punchwall all wall/gran model hertz tangential history mesh n_meshes 1 meshes punch
fix push all move/mesh mesh punch linear 0.0 0.0 {-PUNCH_SPEED:g}
thermo_style custom step atoms ke f_punch[3]
thermo {PUNCH_STEPS}
run {PUNCH_STEPS}
"""


def write_data(path: Path, pos, rad, density: float, L: float, W: float, H: float):
    lines = ["LIGGGHTS data file made by scripts/peer.py", "", f"{len(rad)} atoms", "2 atom types", "",
             f"0 {L:g} xlo xhi", f"0 {W:g} ylo yhi", f"-0.01 {H:g} zlo zhi", "", "Atoms", ""]
    lines += [f"{i + 1} 1 {2 * r:.8g} {density:.6g} {p[0]:.8g} {p[1]:.8g} {p[2]:.8g}"
              for i, (p, r) in enumerate(zip(pos, rad))]
    path.write_text("\n".join(lines) + "\n")


def write_stl(path: Path, tris):
    out = ["solid punch"]
    for t in tris:
        out += ["facet normal 0 0 0", " outer loop", *(f"  vertex {x:.6g} {y:.6g} {z:.6g}" for x, y, z in t),
                " endloop", "endfacet"]
    path.write_text("\n".join(out + ["endsolid punch"]) + "\n")


def main() -> int:
    from scripts import beds as bedmod
    from scripts.parts import punch_surface
    from analysis.holes.metrology import surface_level
    import numpy as np
    exe = shutil.which("liggghts")
    if exe is None:
        print("bench peer: LIGGGHTS is missing; install it once as root: apt-get install -y liggghts", file=sys.stderr)
        return 2
    soil_name, res, size, seed = BED
    soil = load_soil(soil_name)
    bed_path = bedmod.build(soil_name, res, size, seed, threads=1)
    meta = bedmod.load_meta(bed_path)
    data = np.load(bed_path)
    pos, rad = data["pos"], data["radius"]
    L, W, _ = meta["size_m"]
    H = 0.6
    density = meta["grain_density"]
    dt = 0.5 * float(np.min(rad)) * math.sqrt(density / soil.young)      # YADE's PWaveTimeStep for these grains
    z_top = surface_level(pos, rad, 4 * meta["radius"])
    disk = load_disk("configs/disk.toml")
    a = TIP_SPHERE_RATIO * disk.d
    tris, (u_sphere, _) = punch_surface(0.0, PUNCH_LENGTH, disk.d, disk.h, a)
    tip0 = 1000 * z_top + START_ABOVE + a / math.sin(math.atan2(disk.d, disk.h)) - a   # the cone's apex (mm)

    def world(p):                             # punch axis straight down, apex at (L/2, W/2, tip0) mm
        return (1000 * L / 2 + p[1], 1000 * W / 2 + p[2], tip0 + PUNCH_LENGTH - p[0])
    mesh = [[world(p) for p in t] for t in tris]
    rows = []

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_data(tmp / "bed.data", pos, rad, density, L, W, H)
        write_stl(tmp / "punch.stl", mesh)
        (tmp / "in.peer").write_text(liggghts_input(soil, dt, meta["radius"], L, W))
        print(f"bench peer: LIGGGHTS on {len(rad)} grains, {REST_STEPS} + {PUNCH_STEPS} steps of {dt:.3g} s ...",
              file=sys.stderr, flush=True)
        r = subprocess.run([exe, "-in", "in.peer", "-echo", "none", "-log", "log.liggghts"], cwd=tmp,
                           capture_output=True, text=True, env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin",
                                                               "OMPI_ALLOW_RUN_AS_ROOT": "1",
                                                               "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"})
        loops = LOOP.findall(r.stdout)
        if r.returncode != 0 or len(loops) != 2:
            print(f"bench peer: LIGGGHTS failed ({r.returncode}):\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}",
                  file=sys.stderr)
            return 3
        force = LAST_FORCE.findall(r.stdout)
        for phase, (wall, procs, steps, atoms) in zip(("bed at rest", "punch"), loops):
            rows.append({"code": "LIGGGHTS 3.8.0 (Debian)", "phase": phase, "particles": int(atoms),
                         "steps": int(steps),
                         "wall_s": float(wall), "threads": int(procs),
                         "punch_force_z_end_n": float(force[-1]) if phase == "punch" and force else np.nan})

    print("bench peer: YADE ...", file=sys.stderr, flush=True)
    from scripts.parts import TOOL_SELF, as_tool, start_scene
    _, grains, steel, _, _ = start_scene(soil, bed_path, meta, 1, H - z_top)
    from yade import O, TranslationEngine, utils
    from scripts import soil as part
    mm = 1e-3
    tool = as_tool([O.bodies.append(utils.facet([tuple(c * mm for c in v) for v in t], material=steel)) for t in mesh]
                   + [O.bodies.append(utils.sphere(tuple(c * mm for c in world((u_sphere, 0, 0))), a * mm, fixed=True,
                                                   material=steel))])
    push = TranslationEngine(translationAxis=(0, 0, -1), velocity=0.0, ids=tool)
    O.engines = part.engines(soil.damping, cohesion_on_new_contacts=True, cohesion_now=True, extra=[push],
                             avoid_self_mask=TOOL_SELF)
    part.hold_tool_friction(O, soil)
    O.dt = dt
    for phase, steps, speed in (("bed at rest", REST_STEPS, 0.0), ("punch", PUNCH_STEPS, PUNCH_SPEED)):
        push.velocity = speed
        t0 = time.time()
        O.run(steps, True)
        rows.append({"code": "YADE 2023.02a (Debian)", "phase": phase, "particles": len(grains), "steps": steps,
                     "wall_s": time.time() - t0, "threads": 1,
                     "punch_force_z_end_n": utils.sumForces(tool, (0, 0, 1)) if speed else np.nan})
    lost = sum(1 for i in grains if not (-0.01 < O.bodies[i].state.pos[2] < H))
    import pandas as pd
    t = pd.DataFrame(rows)
    t["particle_steps_per_s"] = t.particles * t.steps / t.wall_s
    t["machine"] = machine()
    lig = t[t.code.str.startswith("LIGGGHTS")].set_index("phase").particle_steps_per_s
    t["yade_over_liggghts"] = [r.particle_steps_per_s / lig[r.phase] if r.code.startswith("YADE") else np.nan
                               for r in t.itertuples()]
    out = ROOT / "results/bench/peer.csv"
    atomic_csv(t.round(4), out, f"scripts/peer.py: one settled clay bed ({meta['key']}), dt {dt:.4g} s, one thread; "
               f"YADE lost {lost} grains")
    print(t.to_string(index=False))
    print(f"wrote {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
