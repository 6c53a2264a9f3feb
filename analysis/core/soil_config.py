"""The soils: contact physics from configs/soils/<name>.toml, field targets from seed 001 Table 2
(configs/field/table2_soils.csv), each key range-checked before anything runs."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from analysis.core.schema import ROOT, ConfigError, Field, check_sources, check_table, number, read_toml, split_sections


SOIL_FIELDS = {
    "young": Field(1e5, 1e10, unit="Pa", meaning="contact modulus"),
    "poisson": Field(0.0, 0.5, hi_open=True, meaning="contact shear stiffness / normal stiffness (YADE's FrictMat poisson)"),
    "friction_deg": Field(0.0, 60.0, unit="deg", meaning="inter-particle friction angle"),
    "rolling_stiffness": Field(0.0, 10.0, meaning="alphaKr: rolling stiffness / shear stiffness"),
    "rolling_friction": Field(0.0, 5.0, meaning="etaRoll: plastic rolling moment limit / (radius · normal force)"),
    "normal_cohesion": Field(0.0, 1e8, unit="Pa", meaning="tensile bond strength; times r_min² the bond's force (YADE, no π)"),
    "shear_cohesion": Field(0.0, 1e8, unit="Pa", meaning="shear bond strength; times r_min² the bond's shear force"),
    "damping": Field(0.0, 0.9, meaning="YADE local damping in tool scenes"),
    "new_contact_cohesion": Field(0.0, 1.0, meaning="the bond a contact made after disturbance gets, as a fraction "
                                  "of the intact bonds' strength (1: moist soil re-adheres fully; 0: friction only)"),
    "bond_fragile": Field(0, 1, kind=int, meaning="1: a bond whose strength is exceeded breaks for good (friction only after); "
                          "0: it slides keeping its shear strength and breaks only when pulled apart"),
    "pressed_adhesion": Field(0.0, 5.0, meaning="a contact holding less than the intact bond gains a bond of this "
                              "times the greatest compressive force it has carried, up to the intact bond (moist soil "
                              "re-adheres where it is pressed together; 0: not at all)"),
    "adhesion_onset": Field(0.0, 1e7, unit="Pa", meaning="the compression a contact must carry at two passes of the "
                            "bond rules in a row (longer than a grain's impact) before pressed re-adhesion acts on it, "
                            "times r_min² a force (a moist contact re-adheres once it yields plastically; a loose "
                            "heap's light contacts do not); 0: from any load, at once"),
    "adhesion_share": Field(0.0, 1.0, meaning="the bond a contact held pressed past the onset re-adheres at, as a "
                            "fraction of the intact bond, whatever its press (moist soil pressed together re-adheres "
                            "once it yields, its bridges' strength then set by the water, not the load); in place of "
                            "pressed_adhesion, with an adhesion_onset; 0: not this law"),
    "bond_stretch": Field(0.0, 1.0, meaning="how far a ductile bond held at its tensile strength stretches before it "
                          "parts, in radii of the smaller grain (YADE's CohFrictPhys.unpMax over r_min), as a moist "
                          "soil's water bridge necks before it snaps; 0: it parts once its strength is passed"),
    "tool_friction_deg": Field(0.0, 45.0, unit="deg", meaning="friction of a grain on a tool's steel (the cone, the "
                               "punches), whatever the grain's own; 0: the lesser of the grain's and the steel's 25° "
                               "(YADE's Ip2 takes the lesser of two materials' angles)"),
}
# optional in a soil config; a run's id leaves them out
SOIL_DEFAULTS = {"new_contact_cohesion": 1.0, "bond_fragile": 1, "pressed_adhesion": 0.0, "bond_stretch": 0.0,
                 "adhesion_onset": 0.0, "adhesion_share": 0.0, "tool_friction_deg": 0.0}
SOILS = ("clay", "loam", "sand")
SOIL_COLOURS = {"clay": "tab:brown", "loam": "tab:olive", "sand": "tab:orange"}    # one colour a soil in every plot


@dataclass(frozen=True)
class Soil:
    """One soil: contact physics from configs/soils/<name>.toml, field targets from seed 001 Table 2."""
    name: str
    young: float
    poisson: float
    friction_deg: float
    rolling_stiffness: float
    rolling_friction: float
    normal_cohesion: float
    shear_cohesion: float
    damping: float
    bulk_density: float      # kg/m3, dry, Table 2
    cone_index: float        # Pa, mean over 0-150 mm, Table 2
    moisture: float          # mass fraction of water to dry soil, Table 2
    new_contact_cohesion: float = 1.0   # fraction of the intact bonds' strength a new contact gets
    bond_fragile: int = 1               # 1: bonds break when exceeded; 0: they slide and break only in tension
    pressed_adhesion: float = 0.0       # bond gained per newton of the greatest compression a weaker contact carried
    bond_stretch: float = 0.0           # radii of r_min a ductile bond stretches at its strength before it parts
    adhesion_onset: float = 0.0         # Pa: times r_min², the compression below which no pressed re-adhesion acts
    adhesion_share: float = 0.0         # the intact bond's share a contact held pressed past the onset re-adheres at
    tool_friction_deg: float = 0.0      # grain on a tool's steel, whatever the grain's; 0: the lesser of the two

    def __post_init__(self):
        if self.bond_stretch > 0 and self.bond_fragile:
            raise ConfigError(f"{self.name}: bond_stretch = {self.bond_stretch:g} with bond_fragile = 1: allowed "
                              "bond_stretch 0 for fragile bonds (they part once exceeded), or bond_fragile = 0")
        if self.adhesion_share > 0 and (self.pressed_adhesion > 0 or self.adhesion_onset <= 0):
            raise ConfigError(f"{self.name}: adhesion_share = {self.adhesion_share:g} with pressed_adhesion = "
                              f"{self.pressed_adhesion:g} and adhesion_onset = {self.adhesion_onset:g}: allowed "
                              "adhesion_share above 0 only with pressed_adhesion 0 (one re-adhesion law) and "
                              "adhesion_onset above 0")

    @property
    def wet_density(self) -> float:
        """Mass of moist soil per bed volume, ρ_d(1 + w): what the particles must weigh."""
        return self.bulk_density * (1.0 + self.moisture)

    def settling_key(self) -> dict:
        """The parameters that shape a settled packing (cohesion is switched on after settling)."""
        return {"friction_deg": self.friction_deg, "rolling_stiffness": self.rolling_stiffness,
                "rolling_friction": self.rolling_friction, "poisson": self.poisson}


TABLE2 = ROOT / "configs/field/table2_soils.csv"
TABLE2_FIELDS = {       # seed 001 Table 2's columns, ranged like every other config value
    "bulk_density_g_cm3": Field(0.5, 2.5, unit="g/cm³", meaning="dry bulk density of the field soil"),
    "cone_index_kPa": Field(0.0, 1e4, lo_open=True, unit="kPa", meaning="cone index, mean over 0-150 mm"),
    "moisture_percent": Field(0.0, 100.0, hi_open=True, unit="%", meaning="moisture, mass of water to dry soil"),
}


def table2_row(name: str, where: str, path=TABLE2) -> dict:
    """A soil's row of seed 001 Table 2, every number checked against TABLE2_FIELDS."""
    import csv
    with open(path) as f:
        rows = {r["soil"]: r for r in csv.DictReader(line for line in f if not line.startswith("#"))}
    if name not in rows:
        raise ConfigError(f"{where}: soil {name!r} is not in seed 001 Table 2; allowed: {', '.join(rows)}")
    out = {}
    for key, field in TABLE2_FIELDS.items():
        text = rows[name].get(key)
        try:
            value = float(text)
        except (TypeError, ValueError):
            raise ConfigError(f"{path}: {name}.{key} = {text!r}: must be a number, allowed {field.allowed()}") from None
        out[key] = field.check(f"{path}: {name}.{key}", value)
    return out


def soil_from_dict(name: str, values: dict, where: str) -> Soil:
    v = check_table(where, values, SOIL_FIELDS, optional=SOIL_DEFAULTS)
    t = table2_row(name, where)
    return Soil(name=name, **v, bulk_density=1000 * t["bulk_density_g_cm3"],
                cone_index=1000 * t["cone_index_kPa"], moisture=t["moisture_percent"] / 100)


def load_soil(name_or_path) -> Soil:
    """Load `clay`, `loam`, `sand` or a path to a soil TOML whose file name is one of those."""
    path = Path(name_or_path)
    if path.suffix != ".toml":
        if str(name_or_path) not in SOILS:
            raise ConfigError(f"soil = {name_or_path!r}: allowed {', '.join(SOILS)} or a path to a soil .toml")
        path = ROOT / "configs/soils" / f"{name_or_path}.toml"
    data = split_sections(path, read_toml(path), {"soil", "source", "bench_posterior"})   # the last: see bench_calibration
    check_sources(path, data.get("source", {}), SOIL_FIELDS)
    return soil_from_dict(path.stem, data.get("soil", {}), f"{path}: soil")


SOIL_SOURCES = ("table", "bench")    # a preset's `soils`: each config's [soil], or its [bench_posterior]


def bench_soil(soil: Soil, path=None) -> Soil:
    """The soil as its bench calibration left it: the posterior mean of every calibrated parameter and the values
    the calibration held fixed (the `[bench_posterior]` table `./holes calibrate --soil S --bench` writes into
    configs/soils/<soil>.toml), the shear bond equal to the normal one as the bench tests ran it; the rest (rolling
    stiffness, and the modulus and the damping where the calibration did not set them) from [soil]. A soil never
    calibrated on its bench tests is a ConfigError.

    >>> s = bench_soil(load_soil("sand"))          # sand's calibration held the modulus
    >>> s.bond_fragile, s.shear_cohesion == s.normal_cohesion, s.young == load_soil("sand").young
    (0, True, True)
    """
    path = Path(path or ROOT / "configs/soils" / f"{soil.name}.toml")
    post = read_toml(path).get("bench_posterior")
    if not post:
        raise ConfigError(f"{path}: no [bench_posterior]: soils = 'bench' needs the soil calibrated on its bench tests "
                          f"(./holes calibrate --soil {soil.name} --bench); allowed soils = 'table' until then")
    values = {k: v["mean"] for k, v in post.items() if k in SOIL_FIELDS and isinstance(v, dict)}
    return soil_with(soil, equal_bonds({**values, **post.get("fixed", {})}))


BENCH_DIR = ROOT / "results/calibration/bench"    # the bench calibration's tables (`./holes calibrate --bench`)


def posterior_folder(soil: str, path=None) -> Path:
    """Where the posterior the soil's config carries was drawn and checked: its `[bench_posterior]` folder (relative
    to the project), which holds <soil>-posterior.json, the filter's samples and the checks' tables; a config
    without one is a ConfigError.

    >>> posterior_folder("sand").relative_to(ROOT).as_posix()
    'results/calibration/bench'
    """
    path = Path(path or ROOT / "configs/soils" / f"{soil}.toml")
    folder = read_toml(path).get("bench_posterior", {}).get("folder")
    if not isinstance(folder, str) or not (ROOT / folder / f"{soil}-posterior.json").is_file():
        raise ConfigError(f"{path}: bench_posterior.folder = {folder!r}: allowed the folder, relative to the project, "
                          f"that holds {soil}-posterior.json (`./holes calibrate --soil {soil} --bench` writes it)")
    return ROOT / folder


def heaviest(samples: list[dict], share: float, most: int) -> list[dict]:
    """The samples by descending `weight` until together they hold `share` of the total, at most `most`; each with
    its weight renormalised over those taken.

    >>> [(s["a"], round(s["weight"], 3)) for s in heaviest([{"a": 1, "weight": 0.1}, {"a": 2, "weight": 0.6},
    ...                                                      {"a": 3, "weight": 0.3}], share=0.85, most=4)]
    [(2, 0.667), (3, 0.333)]
    """
    ranked = sorted((s for s in samples if s["weight"] > 0), key=lambda s: -s["weight"])
    total, taken, held = sum(s["weight"] for s in ranked), [], 0.0
    for s in ranked[:most]:
        taken.append(s)
        held += s["weight"]
        if held >= share * total:
            break
    return [{**s, "weight": s["weight"] / held} for s in taken]


def posterior_samples(soil: str, share: float, most: int, bench_dir=None) -> list[dict]:
    """The soil's bench posterior as a few parameter sets: the filter's last iteration's samples
    (<bench_dir>/<soil>.csv, `weight_last`; by default the folder of the posterior the soil's config carries,
    `posterior_folder`) by `heaviest`, each the calibrated parameters (the shear bond equal to
    the normal one, as the bench ran them), the values the calibration held fixed and its `weight`. A soil whose
    filter has not finished is a ConfigError."""
    import json

    import pandas as pd
    bench_dir = Path(bench_dir or posterior_folder(soil))
    table, post = bench_dir / f"{soil}.csv", bench_dir / f"{soil}-posterior.json"
    if not (table.exists() and post.exists()):
        raise ConfigError(f"{soil}: no finished bench calibration ({table.name}, {post.name} in {bench_dir}): "
                          f"run ./holes calibrate --soil {soil} --bench first")
    meta = json.loads(post.read_text())
    t = pd.read_csv(table, comment="#")
    last = t[t.iteration == t.iteration.max()]
    rows = [{**{k: float(r[k]) for k in meta["names"]}, "weight": float(r["weight_last"])}
            for r in last.to_dict("records") if pd.notna(r["weight_last"])]
    return [{**equal_bonds({k: v for k, v in s.items() if k != "weight"}), **meta.get("fixed", {}),
             "weight": s["weight"]} for s in heaviest(rows, share, most)]


def equal_bonds(values: dict) -> dict:
    """Contact parameters with the shear bond set equal to the normal one, as the bench calibration varies them,
    unless they name a shear bond of their own (a probe of the bond's shear-to-tension ratio).

    >>> equal_bonds({"normal_cohesion": 3e5, "friction_deg": 12.0})
    {'normal_cohesion': 300000.0, 'friction_deg': 12.0, 'shear_cohesion': 300000.0}
    >>> equal_bonds({"normal_cohesion": 3e5, "shear_cohesion": 6e5})["shear_cohesion"]
    600000.0
    """
    if "normal_cohesion" not in values or "shear_cohesion" in values:
        return dict(values)
    return {**values, "shear_cohesion": values["normal_cohesion"]}


def soil_with(soil: Soil, overrides: dict) -> Soil:
    """The soil with some contact parameters replaced (`--set key=value`), each checked against SOIL_FIELDS."""
    import dataclasses
    unknown = sorted(set(overrides) - set(SOIL_FIELDS))
    if unknown:
        raise ConfigError(f"soil override {', '.join(unknown)}: allowed keys {', '.join(SOIL_FIELDS)}")
    checked = {k: SOIL_FIELDS[k].check(f"soil override {k}", number(v, f"soil override {k}", SOIL_FIELDS[k]))
               for k, v in overrides.items()}
    return dataclasses.replace(soil, **checked)


def parse_overrides(items) -> dict:
    """`["friction_deg=20", ...]` -> {"friction_deg": 20.0}; a malformed item is a ConfigError."""
    out = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise ConfigError(f"{item!r}: write KEY=NUMBER, e.g. friction_deg=20 or disk.D=45")
    return out
