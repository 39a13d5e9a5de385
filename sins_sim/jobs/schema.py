"""A small declarative schema for YAML configuration: types, units, rules, key paths.

Every scenario and IMU file is checked against a schema before anything runs.
An error names the file, the key path and the rule, e.g.::

    scenarios/bad.yaml: motion[0].amplitude_arcmin: must be >= 0, got -1.0

Units live in the key names (``_hz``, ``_s``, ``_arcmin``, ``_arcsec``,
``_deg``, ``_deg_s``...): the schema converts them to SI and rad and stores
the value under the SI name (``amplitude_arcmin`` -> ``amplitude_rad``). A key
without its unit suffix is rejected with a hint (``amplitude: give a unit,
e.g. amplitude_arcmin``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

from sins_sim.units import ARCMIN, ARCSEC, DEG

__all__ = ["ConfigError", "Num", "Str", "Bool", "Vec", "Map", "ListOf", "OneOf", "UNITS", "validate"]


class ConfigError(ValueError):
    """A configuration file broke a rule; the message names the file, the key path and the rule."""


#: unit suffix -> (SI suffix, factor to SI)
UNITS = {
    "hz": ("hz", 1.0),
    "s": ("s", 1.0),
    "ms": ("s", 1e-3),
    "rad": ("rad", 1.0),
    "arcmin": ("rad", ARCMIN),
    "arcsec": ("rad", ARCSEC),
    "deg": ("rad", DEG),
    "deg_s": ("rad_s", DEG),
    "rad_s": ("rad_s", 1.0),
    "deg2_s2_per_hz": ("rad2_s2_per_hz", DEG * DEG),
    "v": ("v", 1.0),
    "db": ("db", 1.0),
    "per_rad": ("per_rad", 1.0),
    "rad_per_v": ("rad_per_v", 1.0),
    "m": ("m", 1.0),
    "m_s": ("m_s", 1.0),
    "m_s2": ("m_s2", 1.0),
}


def _fail(ctx, path, rule):
    raise ConfigError(f"{ctx}: {path}: {rule}")


@dataclass
class Num:
    """A number; ``unit`` is the suffix the YAML key must carry (None: dimensionless)."""

    unit: str | None = None
    default: Any = None
    required: bool = False
    min: float | None = None
    min_exclusive: bool = False
    max: float | None = None
    integer: bool = False
    nonzero: bool = False
    doc: str = ""

    def check(self, value, ctx, path):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            _fail(ctx, path, f"must be a number, got {type(value).__name__} {value!r}")
        if not math.isfinite(value):
            _fail(ctx, path, f"must be finite, got {value!r}")
        if self.integer and (not float(value).is_integer()):
            _fail(ctx, path, f"must be an integer, got {value!r}")
        if self.min is not None:
            if self.min_exclusive and not value > self.min:
                _fail(ctx, path, f"must be > {self.min:g}, got {value!r}")
            if not self.min_exclusive and not value >= self.min:
                _fail(ctx, path, f"must be >= {self.min:g}, got {value!r}")
        if self.max is not None and value > self.max:
            _fail(ctx, path, f"must be <= {self.max:g}, got {value!r}")
        if self.nonzero and value == 0:
            _fail(ctx, path, "must be != 0")
        if self.integer:
            return int(value)
        return float(value) * (UNITS[self.unit][1] if self.unit else 1.0)


@dataclass
class Str:
    choices: tuple | None = None
    default: Any = None
    required: bool = False
    doc: str = ""

    def check(self, value, ctx, path):
        if not isinstance(value, str):
            _fail(ctx, path, f"must be a string, got {type(value).__name__} {value!r}")
        if self.choices is not None and value not in self.choices:
            _fail(ctx, path, f"must be one of {list(self.choices)}, got {value!r}")
        return value


@dataclass
class Bool:
    default: Any = None
    required: bool = False
    doc: str = ""

    def check(self, value, ctx, path):
        if not isinstance(value, bool):
            _fail(ctx, path, f"must be true or false, got {value!r}")
        return value


@dataclass
class Vec:
    """A list of ``n`` numbers with one unit."""

    n: int = 3
    unit: str | None = None
    default: Any = None
    required: bool = False
    min: float | None = None
    doc: str = ""

    def check(self, value, ctx, path):
        if not isinstance(value, (list, tuple)) or len(value) != self.n:
            _fail(ctx, path, f"must be a list of {self.n} numbers, got {value!r}")
        item = Num(unit=self.unit, min=self.min)
        return [item.check(x, ctx, f"{path}[{i}]") for i, x in enumerate(value)]


@dataclass
class ListOf:
    item: Any = None
    default: Any = None
    required: bool = False
    min_len: int = 0
    doc: str = ""

    def check(self, value, ctx, path):
        if not isinstance(value, list):
            _fail(ctx, path, f"must be a list, got {type(value).__name__} {value!r}")
        if len(value) < self.min_len:
            _fail(ctx, path, f"must have at least {self.min_len} item(s), got {len(value)}")
        return [self.item.check(x, ctx, f"{path}[{i}]") for i, x in enumerate(value)]


@dataclass
class Map:
    """A mapping with known keys (unknown keys are errors)."""

    fields: dict = field(default_factory=dict)
    default: Any = None
    required: bool = False
    allow_null: bool = False
    post: Callable | None = None
    doc: str = ""

    def check(self, value, ctx, path):
        if value is None and self.allow_null:
            return None
        if not isinstance(value, dict):
            _fail(ctx, path, f"must be a mapping, got {type(value).__name__} {value!r}")
        out = {}
        known = {}
        for key, spec in self.fields.items():
            unit = getattr(spec, "unit", None)
            known[_yaml_key(key, unit)] = (key, spec)
        for key in value:
            if not isinstance(key, str):
                _fail(ctx, _join(path, str(key)), "keys must be strings")
            if key not in known:
                _fail(ctx, _join(path, key), _unknown_rule(key, known))
        for ykey, (key, spec) in known.items():
            sub = _join(path, ykey)
            if ykey in value:
                out[_si_key(key, getattr(spec, "unit", None))] = spec.check(value[ykey], ctx, sub)
            elif spec.required:
                _fail(ctx, sub, "is required")
            else:
                default = spec.default
                if default is not None and not isinstance(spec, Map):
                    default = spec.check(default, ctx, sub)
                elif isinstance(spec, Map) and spec.default is not None:
                    default = spec.check(spec.default, ctx, sub)
                out[_si_key(key, getattr(spec, "unit", None))] = default
        if self.post is not None:
            self.post(out, ctx, path)
        return out


@dataclass
class OneOf:
    """A mapping whose ``type`` key selects the schema of the rest."""

    variants: dict = field(default_factory=dict)
    key: str = "type"
    default: Any = None
    required: bool = False
    doc: str = ""

    def check(self, value, ctx, path):
        if not isinstance(value, dict):
            _fail(ctx, path, f"must be a mapping with a '{self.key}' key, got {value!r}")
        kind = value.get(self.key)
        if kind not in self.variants:
            _fail(ctx, _join(path, self.key), f"must be one of {sorted(self.variants)}, got {kind!r}")
        rest = {k: v for k, v in value.items() if k != self.key}
        out = self.variants[kind].check(rest, ctx, path)
        out[self.key] = kind
        return out


def _join(path, key):
    return f"{path}.{key}" if path else key


def _yaml_key(name, unit):
    return f"{name}_{unit}" if unit else name


def _si_key(name, unit):
    return f"{name}_{UNITS[unit][0]}" if unit else name


def _unknown_rule(key, known):
    for ykey in known:
        base = known[ykey][0]
        if key == base and ykey != base:
            return f"needs a unit: write {ykey}"
        if key.startswith(base + "_") and ykey != key:
            return f"unknown unit in {key!r}: write {ykey}"
    return f"unknown key (allowed: {', '.join(sorted(known))})"


def validate(doc, schema, ctx: str, path: str = ""):
    """Check ``doc`` (parsed YAML) against ``schema``; return it in SI units."""
    return schema.check(doc, ctx, path)
