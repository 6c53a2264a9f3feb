"""The schema engine every config and command line is checked with: a `Field` per key (type, allowed range, unit,
meaning), `ConfigError` naming the file, the key and the allowed range, and TOML reading. No domain here: the
disk's, presets', soils' ... schemas and loaders are in config.py and soil_config.py.
"""
from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


class ConfigError(ValueError):
    """A config value is unknown, missing or outside its allowed range."""


@dataclass(frozen=True)
class Field:
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    kind: type = float
    unit: str = ""
    meaning: str = ""

    def allowed(self) -> str:
        if self.kind is str:
            return "a string"
        left = "(" if self.lo_open else "["
        right = ")" if self.hi_open else "]"
        lo, hi = (f"{int(v)}" if self.kind is int and math.isfinite(v) else f"{v:g}" for v in (self.lo, self.hi))
        return f"{left}{lo}, {hi}{right} {self.unit}".rstrip()

    def check(self, where: str, value):
        if self.kind is str:
            if not isinstance(value, str):
                raise ConfigError(f"{where} = {value!r}: must be a string")
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where} = {value!r}: must be a number in {self.allowed()}")
        if not math.isfinite(value):
            raise ConfigError(f"{where} = {value!r} is out of range: allowed {self.allowed()}")
        if self.kind is int and int(value) != value:
            raise ConfigError(f"{where} = {value!r}: must be a whole number in {self.allowed()}")
        ok_lo = value > self.lo if self.lo_open else value >= self.lo
        ok_hi = value < self.hi if self.hi_open else value <= self.hi
        if not (ok_lo and ok_hi and math.isfinite(value)):
            raise ConfigError(f"{where} = {value!r} is out of range: allowed {self.allowed()}")
        return self.kind(value)


def positive(unit="mm", meaning="", kind=float) -> Field:
    return Field(0.0, math.inf, lo_open=True, hi_open=True, kind=kind, unit=unit, meaning=meaning)


def invalid_values(field: Field) -> list:
    """Values `field` must refuse, generated from its range and kind as scikit-learn's parameter validation
    generates them: just outside each finite bound, NaN, ±inf and a word (a number for a string field).

    >>> invalid_values(Field(0.0, 1.0, lo_open=True))
    [0.0, 2.0, nan, inf, -inf, 'x']
    >>> invalid_values(Field(1, 20, kind=int))[:3]
    [0.0, 40, 1.5]
    """
    if field.kind is str:
        return [3.0]
    out = []
    if math.isfinite(field.lo):
        out.append(field.lo if field.lo_open else field.lo - max(1.0, abs(field.lo)))
    if math.isfinite(field.hi):
        out.append(field.hi if field.hi_open else field.hi + max(1.0, abs(field.hi)))
    if field.kind is int:
        out.append((field.lo if math.isfinite(field.lo) else 0) + 0.5)
    return [*out, math.nan, math.inf, -math.inf, "x"]


def number(value, where: str, field: Field):
    """A config or command-line value as a number for `field`: a word is refused naming `where` and the range."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{where} = {value!r}: must be a number, allowed {field.allowed()}") from None


def check_table(where: str, table: dict, schema: dict[str, Field], optional: dict | None = None) -> dict:
    """Validate one TOML table against a schema; `optional` gives defaults for keys that may be absent."""
    optional = optional or {}
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table of keys")
    unknown = sorted(set(table) - set(schema))
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {', '.join(unknown)}; known keys: {', '.join(schema)}")
    missing = sorted(set(schema) - set(table) - set(optional))
    if missing:
        raise ConfigError(f"{where}: missing key(s) {', '.join(missing)}")
    merged = {**optional, **table}
    return {k: schema[k].check(f"{where}.{k}", merged[k]) for k in schema}


def read_toml(path) -> dict:
    path = Path(path)
    if not path.is_absolute() and not path.exists():
        path = ROOT / path
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: cannot be read ({type(e).__name__}): allowed a TOML config file") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML: {e}") from None


def split_sections(path, data: dict, known: set[str]) -> dict:
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(f"{path}: unknown section(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    return data


# --- the hole-forming disk (seed 001 §2.4) ---------------------------------------------------------------


def check_sources(path, sources: dict, schema: dict):
    unknown = sorted(set(sources) - set(schema))
    if unknown:
        raise ConfigError(f"{path}: [source] names unknown key(s) {', '.join(unknown)}")



def as_dict(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in fields(obj)}


def digest(obj, length: int = 8) -> str:
    """The short hash a name carries of what it was made with (`obj`, as JSON with its keys sorted): the same inputs,
    the same name.

    >>> digest({"b": 1, "a": [0.5, None]}) == digest({"a": [0.5, None], "b": 1}), len(digest({}, 10))
    (True, 10)
    """
    return hashlib.sha1(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:length]
