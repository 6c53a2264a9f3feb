"""The pot seedling of seed 001 §1.1 and §4.2's pass criteria written in its dimensions (configs/seedling.toml)."""
from __future__ import annotations

from dataclasses import dataclass

from analysis.core.schema import ConfigError, check_sources, check_table, positive, read_toml, split_sections

SEEDLING_FIELDS = {
    "a1": positive(meaning="upper side of the square pot"),
    "a2": positive(meaning="lower side of the square pot"),
    "h0": positive(meaning="pot height"),
}


@dataclass(frozen=True)
class Seedling:
    a1: float
    a2: float
    h0: float

    @property
    def l2_diameter(self) -> float:
        """√2·a2: the inner diameter down to which the effective depth L2 is measured (seed 001 §4.2)."""
        return 2 ** 0.5 * self.a2


def load_seedling(path="configs/seedling.toml") -> Seedling:
    data = split_sections(path, read_toml(path), {"seedling", "source", "criteria"})
    check_sources(path, data.get("source", {}), SEEDLING_FIELDS)
    return Seedling(**check_table(f"{path}: seedling", data.get("seedling", {}), SEEDLING_FIELDS))


CRITERIA_METRICS = ("L0", "L1", "L2")
L2_COLUMN = {"subsided level": "L2", "undisturbed surface": "L2_surface"}   # §4.2's two readings of L2


def threshold(expr: str, seedling: Seedling, where: str = "criteria") -> float:
    """A pass threshold written as a seedling dimension, optionally times sqrt2 (§4.2).

    >>> threshold("sqrt2*a1", Seedling(35.0, 25.0, 40.0))
    49.49747468305833
    """
    factor, _, name = expr.strip().rpartition("*")
    if name not in SEEDLING_FIELDS or factor not in ("", "sqrt2"):
        raise ConfigError(f"{where} = {expr!r}: allowed NAME or sqrt2*NAME with NAME in {', '.join(SEEDLING_FIELDS)}")
    return getattr(seedling, name) * (2 ** 0.5 if factor else 1.0)


def load_criteria(path="configs/seedling.toml") -> dict[str, dict[str, float]]:
    """Every reading of the pass criteria: {reading: {"L0": min, "L1": min, L2 column: min}} in mm. A reading's
    `L2_from` says which of §4.2's two readings of L2 it judges: "subsided level" (the literal one, L2 from the
    pressed surface round the hole, the holes' column L2; the default) or "undisturbed surface" (L2 + h1, the
    column L2_surface)."""
    seedling = load_seedling(path)
    readings = read_toml(path).get("criteria", {})
    if not readings:
        raise ConfigError(f"{path}: no [criteria.<reading>] table")
    out = {}
    for name, table in readings.items():
        table = dict(table)
        origin = table.pop("L2_from", "subsided level")
        if origin not in L2_COLUMN:
            raise ConfigError(f"{path}: criteria.{name}.L2_from = {origin!r}: allowed {' or '.join(map(repr, L2_COLUMN))}")
        if set(table) != set(CRITERIA_METRICS):
            raise ConfigError(f"{path}: criteria.{name} has {sorted(table)}: allowed exactly {', '.join(CRITERIA_METRICS)}"
                              " and optionally L2_from")
        out[name] = {(L2_COLUMN[origin] if m == "L2" else m): threshold(table[m], seedling, f"{path}: criteria.{name}.{m}")
                     for m in CRITERIA_METRICS}
    return out
