"""Scene: a wall-free simple shear cell (a soil bench test): c and φ of the model soil with no box round it.

    ./holes simple-shear --soil clay --resolution medium --size 120 --stress 50,100,200 --seed 1

The direct shear box's walls and frames reach a few grains into the sample, and at r = 6 mm a box is a few tens of
grains across: its peaks fall as it grows (results/calibration/bench/README.md). A laboratory's box holds the field
soil's grains by the million, with no grain-scale walls. This cell has no walls at all at the model's grains: a cube
periodic in x, y and z, sheared on horizontal planes (x moving with z) under a constant vertical stress, as the box
shears its sample on its horizontal plane under the lid's load, but free to shear where it is weakest.

Parts: packing (`packing`: a periodic cloud compressed along z alone, its sides held, as a bed's deposition
compresses it under its own weight, with the settling material of scripts/beds.py to SETTLE_KPA, the bed's own
weight at a box's mid-depth, then the working modulus; porosity measured exactly from the cell's volume; cached as
beds are, results/cache/beds/<key>.npz + .json), load (`Servo`: the cell's vertical strain rate holds σzz at its
goal, the sides held), shear (the cell's velocity gradient ∂vx/∂z at a shear rate giving the inertial number
INERTIAL), recorder (τ = σxz and σzz from the contacts, Love–Weber, against the shear strain γ). Per normal stress:
bonds on the packing's contacts, new contacts as the soil's new_contact_cohesion and pressed re-adhesion have
them (scripts/soil.py), consolidated under σn, then sheared to GAMMA_MAX; the peak τ and σzz there. One fresh
sample per normal stress, each kept as it finishes and reused by a run asking for the same (a stopped run resumes
there), as scripts/shear.py does. Writes results/soils/simple_shear/<packing key>-<stresses>.json with the
Mohr–Coulomb fit (analysis/soil/shear.py) and prints the fit as a JSON line.
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from analysis.core.cli_types import CommandLine, folder, option  # noqa: E402
from analysis.core.config import SEED, THREADS, load_resolution  # noqa: E402
from analysis.core.bed_spec import (BED_DIR, CELL_INERTIAL as INERTIAL,  # noqa: E402
                                    CELL_PACKED_FRACTION as PACKED_FRACTION, CELL_SETTLE_KPA as SETTLE_KPA, cell_key,
                                    mean_volume)
from analysis.core.io import atomic_write, held, kept_each  # noqa: E402
from analysis.core.schema import ROOT, ConfigError, Field, digest  # noqa: E402
from analysis.core.soil_config import load_soil, parse_overrides, soil_with  # noqa: E402

STRESS = Field(1.0, 1000.0, unit="kPa", meaning="vertical stress on the sample")
INERTIAL_FIELD = Field(1e-5, 1e-2, meaning="the inertial number the shear rate is set by")
GAMMA_MAX = 1.0            # the shear strain a test ends at: past the peak (the box's peaks come late in its travel)
CLOUD_FRACTION = 0.30      # solid fraction of the initial cloud
SETTLE_UNBALANCED = 0.01   # as scripts/beds.py
SETTLE_MAX_TIME = 3.0      # s
HOLD_TOL = 0.02            # σzz within this share of its goal before consolidation's clock starts
CONSOLIDATE_S = 0.05       # s held under σn before shearing (the box's)
SERVO_EVERY = 5            # steps between two corrections of the vertical strain rate
SERVO_GAIN = 0.5           # share of σzz's error the servo corrects per period, at the Voigt stiffness estimate
CHUNK = 100                # steps between two records of the curve
SCENE_SOURCES = tuple(ROOT / "scripts" / n for n in ("simple_shear.py", "soil.py"))
OUT = ROOT / "results/soils/simple_shear"


class Servo:
    """Hold the cell's compressive σzz at `goal` (Pa) by its vertical strain rate, x and y held, with ∂vx/∂z =
    `shear_rate`: every SERVO_EVERY steps the strain rate that corrects SERVO_GAIN of the error at the contacts'
    Voigt estimate of the constrained modulus (kn l² ⟨n_z⁴⟩ per contact over the volume, an upper bound, so the
    correction undershoots and never rings), at most `max_rate` (1/s) either way."""

    def __init__(self, O, goal: float, max_rate: float, kn: float, branch: float, shear_rate: float = 0.0):
        self.O, self.goal, self.max_rate, self.kn, self.branch = O, goal, max_rate, kn, branch
        self.shear_rate = shear_rate
        self.sigma = self.tau = 0.0

    def stress(self):
        from yade import utils
        s = utils.getStress()                    # tensile positive
        self.sigma, self.tau = -s[2, 2], s[0, 2]
        return self.sigma, self.tau

    def __call__(self):
        from yade import Matrix3
        O = self.O
        sigma, _ = self.stress()
        contacts = O.interactions.countReal()
        modulus = max(contacts * self.kn * self.branch ** 2 * 0.2 / O.cell.volume, 1.0)
        rate = SERVO_GAIN * (sigma - self.goal) / (modulus * SERVO_EVERY * O.dt)
        rate = max(-self.max_rate, min(self.max_rate, rate))
        O.cell.velGrad = Matrix3(0, 0, self.shear_rate, 0, 0, 0, 0, 0, rate)


def start(threads: int):
    from scripts.yadeboot import boot
    boot(threads)
    from yade import O
    O.reset()
    return O


def servo_engines(O, damping: float, servo: Servo, cohesion: bool, extra=()):
    """The contact law without gravity (a periodic cell has no floor) and the servo, put in YADE's namespace for
    its PyRunner."""
    import builtins
    from yade import PyRunner
    from scripts import soil as part
    builtins.holes_cell_servo = servo
    return part.engines(damping, cohesion_on_new_contacts=cohesion, cohesion_now=cohesion, gravity=(0, 0, 0),
                        extra=[*extra, PyRunner(command="holes_cell_servo()", iterPeriod=SERVO_EVERY, label="servo")])


def settle_to(O, servo: Servo, tol: float, max_time: float, label: str, log, min_time: float = 0.0):
    """Run until σzz is within `tol` of the servo's goal and the unbalanced force is under SETTLE_UNBALANCED (after
    `min_time` s); stop with a diagnostic otherwise."""
    from yade import utils
    t_end, t_min, wall0 = O.time + max_time, O.time + min_time, time.time()
    while True:
        O.run(500, True)
        sigma, _ = servo.stress()
        ub = utils.unbalancedForce() if O.interactions.countReal() else math.inf
        if not math.isfinite(sigma) or (O.interactions.countReal() and not math.isfinite(ub)):
            raise RuntimeError(f"{label}: σzz {sigma}, unbalanced {ub} at t = {O.time:.3f} s (numerical blow-up)")
        log(f"{label}: t={O.time:.3f} s  σzz {sigma / 1e3:7.2f} kPa (goal {servo.goal / 1e3:g})  unbalanced={ub:.4f}  "
            f"wall={time.time() - wall0:.0f} s")
        if O.time >= t_min and abs(sigma - servo.goal) < tol * servo.goal and ub < SETTLE_UNBALANCED:
            return ub
        if O.time > t_end:
            raise RuntimeError(f"{label}: not at {servo.goal / 1e3:g} kPa after {max_time} s simulated "
                               f"(σzz {sigma / 1e3:.2f} kPa, unbalanced {ub:.3f})")


def packing(soil_name: str, resolution: str, edge: float, seed: int, threads: int = 1, log=lambda m: None,
            bed_dir: Path = BED_DIR) -> Path:
    """The cell's packing (module doc), made once under a lock and cached; returns its .npz."""
    soil, res = load_soil(soil_name), load_resolution(resolution)
    if res.graded:
        raise ConfigError(f"resolution = {resolution!r} is graded: allowed an ungraded one (a cell has one zone)")
    largest = 2 * res.radius * (1 + res.spread)
    if edge < 2.2 * largest * 2:
        raise ConfigError(f"--size = {1000 * edge:g} mm: allowed at least {1000 * 4.4 * largest:.0f} mm at "
                          f"{resolution!r} (the periodic collider needs each grain under half the cell)")
    out = Path(bed_dir) / f"{cell_key(soil, res, edge, seed)}.npz"
    if out.exists() and out.with_suffix(".json").exists():
        return out
    with held(out.with_suffix(".lock"), log):
        if out.exists() and out.with_suffix(".json").exists():
            return out
        return settle_packing(soil, res, edge, seed, threads, out, log)


def settle_packing(soil, res, edge: float, seed: int, threads: int, out: Path, log) -> Path:
    """Compress a periodic cloud along z to SETTLE_KPA with the beds' settling material, settle it again at the
    working modulus and save it to `out` with its porosity and the grain density that gives Table 2's bulk density."""
    O = start(threads)
    import numpy as np
    from yade import pack, utils
    from scripts import soil as part
    from scripts.beds import save
    wall0 = time.time()
    n = int(edge ** 3 * PACKED_FRACTION / mean_volume(res.radius, res.spread))
    h0 = edge * PACKED_FRACTION / CLOUD_FRACTION
    sp = pack.SpherePack()
    sp.makeCloud((0, 0, 0), (edge, edge, h0), rMean=res.radius, rRelFuzz=res.spread, num=n, seed=seed, periodic=True)
    O.periodic = True
    mat = O.materials.append(part.soil_material(soil, density=2650.0, young=soil.young / 4, cohesive=False))
    sp.toSimulation(material=mat)
    O.cell.setBox(edge, edge, h0)                        # after toSimulation, which sets a cell of its own
    servo = Servo(O, SETTLE_KPA * 1e3, 2.0, soil.young / 4 * res.radius, 2 * res.radius)
    O.engines = servo_engines(O, 0.4, servo, cohesion=False)
    O.dt = 0.5 * utils.PWaveTimeStep()
    log(f"cell {out.stem}: {len(sp)} grains in a {1000 * edge:.0f} x {1000 * edge:.0f} x {1000 * h0:.0f} mm cloud")
    settle_to(O, servo, 0.05, SETTLE_MAX_TIME, "compression", log, min_time=0.05)
    O.materials[mat].young = soil.young                  # the working stiffness, contacts made anew (as beds are)
    O.interactions.clear()
    servo.kn = soil.young * res.radius
    O.dt = 0.5 * utils.PWaveTimeStep()
    settle_to(O, servo, 0.05, SETTLE_MAX_TIME, "working modulus", log, min_time=0.02)
    from yade import Matrix3
    O.cell.velGrad = Matrix3.Zero
    cell = O.cell.hSize
    size = [float(cell[0, 0]), float(cell[1, 1]), float(cell[2, 2])]
    pos = np.array([tuple(O.cell.wrap(b.state.pos)) for b in O.bodies])
    rad = np.array([b.shape.radius for b in O.bodies])
    porosity = 1.0 - float(np.sum(4 / 3 * np.pi * rad ** 3)) / (size[0] * size[1] * size[2])
    grain_density = soil.wet_density / (1.0 - porosity)
    meta = {"key": out.stem, "soil": soil.name, "resolution": res.name, "radius": res.radius, "spread": res.spread,
            "size_m": size, "seed": seed, "lateral": "cell", "particles": int(len(rad)), "porosity": porosity,
            "grain_density": grain_density, "wet_bulk_density": soil.wet_density,
            "dry_bulk_density": soil.wet_density / (1 + soil.moisture), "target_dry_bulk_density": soil.bulk_density,
            "settle_kpa": SETTLE_KPA, "steps": int(O.iter), "sim_time_s": O.time, "wall_s": time.time() - wall0,
            "threads": threads}
    save(out, pos, rad, meta)
    log(f"cell {out.stem}: {len(rad)} grains, {1000 * size[2]:.0f} mm tall, porosity {porosity:.3f}, "
        f"{meta['wall_s']:.0f} s wall")
    return out


def run(packing_path: Path, soil_name: str, stress_kpa: float, inertial: float = INERTIAL, threads: int = 1,
        overrides: dict | None = None, log=lambda m: None) -> dict:
    """Bond the packing's contacts, consolidate under σn = stress_kpa, shear to GAMMA_MAX; the curve's summary."""
    import numpy as np
    O = start(threads)
    from yade import utils
    from scripts import soil as part
    soil = soil_with(load_soil(soil_name), overrides or {})
    meta = json.loads(packing_path.with_suffix(".json").read_text())
    data = np.load(packing_path)
    wall0 = time.time()
    O.periodic = True
    O.cell.setBox(*meta["size_m"])
    mat = O.materials.append(part.soil_material(soil, density=meta["grain_density"], cohesive=True))
    O.bodies.append([utils.sphere(tuple(p), r, material=mat) for p, r in zip(data["pos"], data["radius"])])
    r = float(np.mean(data["radius"]))
    goal = stress_kpa * 1e3
    shear_rate = inertial * math.sqrt(goal / meta["grain_density"]) / (2 * r)
    servo = Servo(O, goal, 2.0 * shear_rate + 0.5, soil.young * r, 2 * r)
    O.engines = servo_engines(O, soil.damping, servo, cohesion=True, extra=part.bond_rules(O, soil))
    O.dt = 0.5 * utils.PWaveTimeStep()
    O.run(1, True)                                    # the intact bonds on the packing's contacts
    part.bond_new_contacts(O, soil)
    settle_to(O, servo, HOLD_TOL, SETTLE_MAX_TIME, f"σn {stress_kpa:g} kPa", log)
    O.run(int(CONSOLIDATE_S / O.dt), True)
    servo.max_rate = 2.0 * shear_rate               # the servo follows the sample's dilation, no faster
    servo.shear_rate = shear_rate
    h0, t0, n_shear = O.cell.hSize[2, 2], O.time, int(GAMMA_MAX / shear_rate / O.dt) + 1
    rows, report, wall_shear0 = [], max(1, n_shear // 10), time.time()
    while O.time - t0 < GAMMA_MAX / shear_rate:
        O.run(CHUNK, True)
        sigma, tau = servo.stress()
        gamma = O.cell.hSize[0, 2] / O.cell.hSize[2, 2]
        if not (math.isfinite(sigma) and math.isfinite(tau)):
            raise RuntimeError(f"simple shear: σzz {sigma}, τ {tau} at γ = {gamma:.3f} (numerical blow-up)")
        rows.append((gamma, tau, sigma, O.cell.hSize[2, 2] / h0 - 1.0))
        if len(rows) % max(1, report // CHUNK) == 0:
            eta = (time.time() - wall_shear0) * (GAMMA_MAX - gamma) / max(gamma, 1e-9)
            log(f"simple shear σn {stress_kpa:g} kPa: γ {gamma:.3f}  τ {tau / 1e3:6.1f} kPa under σ {sigma / 1e3:6.1f}"
                f"  εzz {100 * rows[-1][3]:+.2f} %  ETA {eta:.0f} s")
        vmax = max(b.state.vel.norm() for b in O.bodies) if len(rows) % 10 == 0 else 0.0
        if vmax > 100 * shear_rate * meta["size_m"][2] + 1.0:
            raise RuntimeError(f"simple shear: a grain moves at {vmax:.2f} m/s (unstable)")
    d = np.array(rows)
    i = int(np.argmax(d[:, 1]))
    tail = d[int(0.8 * len(d)):]
    return {"bed": meta["key"], "soil": soil.name, "radius_m": r, "size_m": meta["size_m"], "stress_kpa": stress_kpa,
            "porosity": meta["porosity"], "inertial": inertial, "shear_rate": shear_rate,
            "tau_peak_kpa": float(d[i, 1] / 1e3), "sigma_at_peak_kpa": float(d[i, 2] / 1e3),
            "gamma_at_peak": float(d[i, 0]), "tau_residual_kpa": float(tail[:, 1].mean() / 1e3),
            "sigma_sd_kpa": float(d[:, 2].std() / 1e3), "particles": len(data["radius"]), "steps": int(O.iter),
            "dt": O.dt, "wall_s": time.time() - wall0, "threads": threads,
            "curve": [[round(g, 4), round(t / 1e3, 3), round(s / 1e3, 3), round(e, 5)] for g, t, s, e in d]}


def arguments():
    p = CommandLine(prog="holes simple-shear", description=__doc__.splitlines()[0])
    p.add_argument("--soil", default="clay", help="clay | loam | sand, or a soil config's path (default clay)")
    p.add_argument("--resolution", default="medium", help="grain size, ungraded (default medium, r = 6 mm)")
    p.add_argument("--size", type=option("--size", Field(40.0, 500.0, unit="mm", meaning="the cell's edge")),
                   default=120.0, help="the cell's edge, mm (default 120)")
    p.add_argument("--seed", type=option("--seed", SEED), default=1, help="packing seed, >= 0 (default 1)")
    p.add_argument("--stress", type=option("--stress", STRESS, many=True), default=[50.0, 100.0, 200.0],
                   help="normal stresses, kPa (one sample each; default 50,100,200)")
    p.add_argument("--inertial", type=option("--inertial", INERTIAL_FIELD), default=INERTIAL,
                   help=f"the inertial number the shear rate is set by (default {INERTIAL:g})")
    p.add_argument("--test-set", action="append", metavar="KEY=VALUE",
                   help="override a soil contact parameter in the test only (the packing is made as configured)")
    p.add_argument("--threads", type=option("--threads", THREADS), default=1, help="YADE threads (default 1)")
    p.add_argument("--bed-dir", type=folder("--bed-dir"), default=str(BED_DIR), help="where packings are kept")
    p.add_argument("--out", type=folder("--out"), help="where the result goes (default results/soils/simple_shear)")
    return p


def main(argv=None) -> int:
    a = arguments().parse_args(argv)

    def log(message: str):
        print(message, file=sys.stderr, flush=True)
    try:
        test = parse_overrides(a.test_set)
        soil_with(load_soil(a.soil), test)
        out = Path(a.out) if a.out else OUT
        path = packing(a.soil, a.resolution, a.size / 1000.0, a.seed, a.threads, log, Path(a.bed_dir))
        settings = digest({"soil": a.soil, "test": dict(sorted(test.items())), "inertial": a.inertial,
                           "code": [p.read_text() for p in SCENE_SOURCES]})
        parts = [out / f"{path.stem}-{s:g}-{settings}.part.json" for s in a.stress]
        rows = kept_each(parts, lambda i: run(path, a.soil, a.stress[i], a.inertial, a.threads, test, log))
    except (ConfigError, ValueError) as e:
        print(f"simple-shear: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"simple-shear stopped: {e}", file=sys.stderr)
        return 3
    from analysis.soil.shear import fit_tests
    fit = fit_tests(rows)
    summary = {"bed": rows[0]["bed"], "soil": rows[0]["soil"], "radius_mm": 1000 * rows[0]["radius_m"],
               "overrides": test, "inertial": a.inertial, **fit, "tests": rows}
    atomic_write(out / f"{path.stem}-{'_'.join(f'{s:g}' for s in a.stress)}.json", json.dumps(summary, indent=1))
    for part_path in parts:
        part_path.unlink(missing_ok=True)
    print(json.dumps({k: v for k, v in summary.items() if k != "tests"}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
