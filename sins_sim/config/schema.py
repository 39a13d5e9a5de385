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
import re
from dataclasses import dataclass, field
from typing import Any, Callable

from sins_sim._validate import unknown_key
from sins_sim.config.errors import ConfigError
from sins_sim.units import ARCMIN, ARCSEC, DEG

__all__ = ["ConfigError", "Num", "Str", "Bool", "Vec", "Map", "ListOf", "OneOf", "UNITS", "UNIT_LABELS", "validate",
           "fill_defaults", "describe", "format_range",
           "json_schema", "JSON_SCHEMA_DIALECT"]


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
    "ppm": ("ppm", 1.0),
    "k": ("k", 1.0),
    "ppm_per_k": ("ppm_per_k", 1.0),
    "mm": ("m", 1e-3),
    "mrad": ("rad", 1e-3),
    "kg": ("kg", 1.0),
    "kg_m2": ("kg_m2", 1.0),
    "n_per_m": ("n_per_m", 1.0),
    "n_s_per_m": ("n_s_per_m", 1.0),
    "n_m_per_rad": ("n_m_per_rad", 1.0),
    "n_m_s_per_rad": ("n_m_s_per_rad", 1.0),
}


#: unit suffix -> how the unit reads in the reference (``sins-sim schema``)
UNIT_LABELS = {
    "hz": "Hz", "s": "s", "ms": "ms", "rad": "rad", "arcmin": "arcmin", "arcsec": "arcsec", "deg": "deg",
    "deg_s": "deg/s", "rad_s": "rad/s", "deg2_s2_per_hz": "(deg/s)^2/Hz", "v": "V", "db": "dB", "per_rad": "1/rad",
    "rad_per_v": "rad/V", "m": "m", "m_s": "m/s", "m_s2": "m/s^2", "ppm": "ppm",
    "k": "K", "ppm_per_k": "ppm/K", "mm": "mm", "mrad": "mrad", "kg": "kg", "kg_m2": "kg m^2", "n_per_m": "N/m",
    "n_s_per_m": "N s/m", "n_m_per_rad": "N m/rad", "n_m_s_per_rad": "N m s/rad",
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
            _fail(ctx, path, f"must be a number, got {_got(value)}{_numeric_text_hint(value)}")
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
            _fail(ctx, path, f"must be a string, got {_got(value)}")
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
    min_exclusive: bool = False
    max: float | None = None
    doc: str = ""
    #: optional: one Num per element (its own range), e.g. a [frequency, PSD] row
    items: tuple | None = None

    def check(self, value, ctx, path):
        if not isinstance(value, (list, tuple)) or len(value) != self.n:
            _fail(ctx, path, f"must be a list of {self.n} numbers, got {value!r}")
        if self.items is not None:
            return [item.check(x, ctx, f"{path}[{i}]") for i, (item, x) in enumerate(zip(self.items, value))]
        item = Num(unit=self.unit, min=self.min, min_exclusive=self.min_exclusive, max=self.max)
        return [item.check(x, ctx, f"{path}[{i}]") for i, x in enumerate(value)]


def _got(value) -> str:
    """A value as a refusal shows it, in YAML's words: ``str '7.58e5'``, ``list [1, 2]``, ``null`` (an empty value or
    ``~``; Python would say ``NoneType None``)."""
    if value is None:
        return "null (an empty value)"
    kind = {dict: "mapping", bool: "bool", int: "int", float: "float", str: "str", list: "list"}.get(type(value),
                                                                                               type(value).__name__)
    return f"{kind} {value!r}"


#: A number written as YAML 1.2 allows (``7.58e5``, ``1e-3``, ``.5``): PyYAML's ``yaml.safe_load`` (YAML 1.1) reads
#: the exponent forms without a dot or an exponent sign as strings.
_NUMBER_TEXT = re.compile(r"^\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*$")


def _numeric_text_hint(value) -> str:
    """For a string that reads as a number: why it is one (refused, not converted: a quoted value stays text, as
    the JSON Schema and every other reader of the file say) and what to do."""
    if not (isinstance(value, str) and _NUMBER_TEXT.match(value)):
        return ""
    return (" (a number read as text: PyYAML's yaml.safe_load reads forms such as 7.58e5 as strings; load the file "
            "with sins_sim.load_yaml, which reads them as numbers, or write the number unquoted with a dot and a "
            "signed exponent, 7.58e+5)")


@dataclass
class ListOf:
    item: Any = None
    default: Any = None
    required: bool = False
    min_len: int = 0
    max_len: int | None = None
    doc: str = ""

    def check(self, value, ctx, path):
        if not isinstance(value, list):
            _fail(ctx, path, f"must be a list, got {_got(value)}")
        if len(value) < self.min_len:
            _fail(ctx, path, f"must have at least {self.min_len} item(s), got {len(value)}")
        if self.max_len is not None and len(value) > self.max_len:
            _fail(ctx, path, f"must have at most {self.max_len} item(s), got {len(value)}")
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
    #: rules that involve several keys (checked by the loader), listed in the reference
    rules: tuple = ()
    #: optional: a function returning this entry's JSON Schema instead of the generic one (an entry whose loader
    #: also takes shorthands, e.g. ``filter_parameters: nominal``)
    json: Callable | None = None

    def check(self, value, ctx, path):
        if value is None and self.allow_null:
            return None
        if not isinstance(value, dict):
            _fail(ctx, path, f"must be a mapping, got {_got(value)}")
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
        # the values the file gives are checked before any missing required key is named: a wrong value the
        # user wrote is the first thing to hear about (the result keeps the schema's order)
        given = {ykey: spec.check(value[ykey], ctx, _join(path, ykey)) for ykey, (key, spec) in known.items()
                 if ykey in value}
        for ykey, (key, spec) in known.items():
            sub = _join(path, ykey)
            if ykey in value:
                out[_si_key(key, getattr(spec, "unit", None))] = given[ykey]
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
    #: per variant: rules that involve several keys or other parts of the file, for the reference
    rules: dict = field(default_factory=dict)

    def check(self, value, ctx, path):
        if not isinstance(value, dict):
            _fail(ctx, path, f"must be a mapping with a '{self.key}' key, got {value!r}")
        kind = value.get(self.key)
        if not isinstance(kind, str) or kind not in self.variants:
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
    return unknown_key(key, known, {known[y][0]: y for y in known})


def validate(doc, schema, ctx: str, path: str = ""):
    """Check ``doc`` (parsed YAML) against ``schema``; return it in SI units."""
    return schema.check(doc, ctx, path)


def fill_defaults(doc, schema):
    """``doc`` with every default the schema would fill in written out, in the file's own keys and units.

    The result is a document a person can read and sins-sim can load again: validating it gives
    exactly what validating ``doc`` gives (the user's values are kept as written, each default is
    the schema's own literal, which :func:`validate` converts the same way). Keys whose default is
    "none" (computed later, or switched off) stay absent. Parts the schema does not describe
    (entries checked by their own parsers) are kept as written. ``doc`` is assumed valid.

    Examples
    --------
    >>> fill_defaults({"a_hz": 3}, Map({"a": Num(unit="hz"), "b": Num(unit="s", default=2.0)}))
    {'a_hz': 3, 'b_s': 2.0}
    """
    import copy

    if isinstance(schema, Map):
        if not isinstance(doc, dict):
            return doc  # null where allowed
        out = dict(doc)
        for name, spec in schema.fields.items():
            key = _yaml_key(name, getattr(spec, "unit", None))
            if key in doc:
                out[key] = fill_defaults(doc[key], spec)
            elif not getattr(spec, "required", False) and getattr(spec, "default", None) is not None:
                out[key] = fill_defaults(copy.deepcopy(spec.default), spec)
        return out
    if isinstance(schema, OneOf):
        variant = schema.variants.get(doc.get(schema.key)) if isinstance(doc, dict) else None
        if variant is None:
            return doc
        rest = fill_defaults({k: v for k, v in doc.items() if k != schema.key}, variant)
        return {schema.key: doc[schema.key], **rest}
    if isinstance(schema, ListOf) and isinstance(doc, list):
        return [fill_defaults(x, schema.item) for x in doc]
    return doc


# --- the reference: every key with its unit, range and default, from the schema objects themselves ---------------
def _g(x) -> str:
    """A number as the reference prints it (``0.15125``, ``1e-06``, ``72000``)."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x)


def format_range(spec) -> str:
    """The range of a :class:`Num` or :class:`Vec` entry in interval notation (YAML units)."""
    lo, hi = getattr(spec, "min", None), getattr(spec, "max", None)
    if lo is None and hi is None:
        text = "any"
    elif hi is None:
        text = f"{'>' if spec.min_exclusive else '>='} {_g(lo)}"
    elif lo is None:
        text = f"<= {_g(hi)}"
    else:
        text = f"{'(' if spec.min_exclusive else '['}{_g(lo)}, {_g(hi)}]"
    if getattr(spec, "nonzero", False):
        text += ", != 0"
    if getattr(spec, "integer", False):
        text += ", integer"
    return text


def _default_text(spec) -> str:
    if getattr(spec, "required", False):
        return "required"
    d = getattr(spec, "default", None)
    if d is None:
        return "(none)"
    if isinstance(d, str):
        return f'"{d}"' if d == "" else d
    if isinstance(d, (list, tuple)):
        if d and isinstance(d[0], dict):
            return "; ".join("{" + ", ".join(f"{k}: {_g(v)}" for k, v in item.items()) + "}" for item in d)
        return "[" + ", ".join(_g(x) for x in d) + "]"
    if isinstance(d, dict):
        return "{}" if not d else ", ".join(f"{k}: {_g(v)}" for k, v in d.items())
    return _g(d)


def _row(key, kind, spec, unit=None, range_="", doc=None):
    return {"key": key, "kind": kind, "unit": UNIT_LABELS.get(unit, unit or ""), "range": range_,
            "default": _default_text(spec), "doc": doc if doc is not None else getattr(spec, "doc", "")}


def describe(schema, path: str = "") -> list:
    """Every key of ``schema`` as rows: ``key`` (YAML path), ``kind``, ``unit``, ``range``, ``default``, ``doc``.

    Lists are written ``key[]``, the variants of a :class:`OneOf` ``key[type=NAME]``. Rows of kind
    ``rule`` carry the rules that involve several keys (``Map.rules``, ``OneOf.rules``). Schema
    entries of other classes describe themselves with a ``describe_rows(path)`` method.
    """
    rows: list = []
    _walk(schema, path, rows)
    return rows


def _walk(spec, path, rows, key_name=None):
    if hasattr(spec, "describe_rows"):
        rows.extend(spec.describe_rows(path))
    elif isinstance(spec, Num):
        kind = "integer" if spec.integer else "number"
        rows.append(_row(path, kind, spec, spec.unit, format_range(spec)))
    elif isinstance(spec, Vec):
        if spec.items is not None:
            rng = "; ".join(f"[{i}] {format_range(it)}{' ' + UNIT_LABELS.get(it.unit, '') if it.unit else ''}"
                            for i, it in enumerate(spec.items))
        else:
            rng = format_range(spec) + " each"
        rows.append(_row(path, f"list of {spec.n} numbers", spec, spec.unit, rng))
    elif isinstance(spec, Str):
        rng = "one of " + ", ".join(spec.choices) if spec.choices else "text"
        rows.append(_row(path, "string", spec, None, rng))
    elif isinstance(spec, Bool):
        rows.append(_row(path, "bool", spec, None, "true or false"))
    elif isinstance(spec, ListOf):
        n = f"{spec.min_len} or more" if spec.max_len is None else f"{spec.min_len} to {spec.max_len}"
        item = spec.item
        if isinstance(item, (Num, Vec, Str)):  # a list of plain values: one row
            inner = describe(item, "")[0]
            rows.append({**_row(path, f"list of {inner['kind']}", spec, getattr(item, "unit", None),
                                f"{n} items; {inner['range']}"), "doc": spec.doc or inner["doc"]})
        else:
            rows.append(_row(path, "list", spec, None, f"{n} items"))
            _walk(item, f"{path}[]", rows)
    elif isinstance(spec, OneOf):
        for kind in sorted(spec.variants):
            # a list of typed entries: ``motion[]`` -> ``motion[type=sines]``
            sub = f"{path[:-2] if path.endswith('[]') else path}[{spec.key}={kind}]"
            variant = spec.variants[kind]
            rows.append({"key": sub, "kind": "variant", "unit": "", "range": "", "default": "",
                         "doc": variant.doc or spec.doc})
            for rule in spec.rules.get(kind, ()):
                rows.append({"key": sub, "kind": "rule", "unit": "", "range": "", "default": "", "doc": rule})
            _walk_fields(variant, sub, rows)
    elif isinstance(spec, Map):
        if path:
            rng = "mapping" + (" or null" if spec.allow_null else "")
            rows.append(_row(path, "mapping", spec, None, rng))
        for rule in spec.rules:
            rows.append({"key": path or "(top level)", "kind": "rule", "unit": "", "range": "", "default": "",
                         "doc": rule})
        _walk_fields(spec, path, rows)
    else:  # pragma: no cover - every schema class is handled above
        rows.append({"key": path, "kind": type(spec).__name__, "unit": "", "range": "", "default": "", "doc": ""})


def _walk_fields(spec: Map, path, rows):
    for name, sub in spec.fields.items():
        _walk(sub, _join(path, _yaml_key(name, getattr(sub, "unit", None))), rows)


# --- JSON Schema for editors: the same schema objects, exported ----------------------------------------------------
#: the JSON Schema dialect of :func:`json_schema`
JSON_SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"


def _json_schema_default(spec) -> dict:
    d = getattr(spec, "default", None)
    if d is None or getattr(spec, "required", False) or isinstance(d, tuple):
        return {}
    return {"default": d}


def _json_description(spec, unit=None) -> dict:
    doc = getattr(spec, "doc", "") or ""
    if unit:
        doc = f"[{UNIT_LABELS.get(unit, unit)}] {doc}".rstrip()
    return {"description": doc} if doc else {}


def _json_number(spec: Num) -> dict:
    out = {"type": "integer" if spec.integer else "number"}
    if spec.min is not None:
        out["exclusiveMinimum" if spec.min_exclusive else "minimum"] = spec.min
    if spec.max is not None:
        out["maximum"] = spec.max
    if spec.nonzero:
        out["not"] = {"const": 0}
    return out


def _json_map_body(spec: Map) -> tuple:
    props, required = {}, []
    for name, sub in spec.fields.items():
        ykey = _yaml_key(name, getattr(sub, "unit", None))
        props[ykey] = json_schema(sub)
        if getattr(sub, "required", False):
            required.append(ykey)
    return props, required


def json_schema(spec) -> dict:
    """The JSON Schema (draft 2020-12) of a schema entry, for editors (yaml-language-server) and other tools.

    Generated from the very objects :func:`validate` checks with, so the two cannot drift apart:
    keys carry their unit suffix as in the YAML, ranges become ``minimum``/``maximum``,
    ``exclusiveMinimum`` and ``not: {const: 0}``, choices ``enum``, unknown keys are refused
    (``additionalProperties: false``), a :class:`OneOf` selects its variant with ``if``/``then`` on
    its ``type`` key. Entries of other classes describe themselves with a ``json_schema()`` method;
    one without it is left open (``{}``). Rules across keys (``Map.rules``) stay with the loader:
    the export is a necessary condition, the loader the sufficient one.

    Examples
    --------
    >>> json_schema(Map({"rate": Num(unit="hz", min=0.0, min_exclusive=True, required=True)}))["properties"]
    {'rate_hz': {'type': 'number', 'exclusiveMinimum': 0.0, 'description': '[Hz]'}}
    """
    if spec is None:
        return {}
    if hasattr(spec, "json_schema"):
        return spec.json_schema()
    if isinstance(spec, Map) and spec.json is not None:
        return spec.json()
    if isinstance(spec, Num):
        return {**_json_number(spec), **_json_schema_default(spec), **_json_description(spec, spec.unit)}
    if isinstance(spec, Str):
        out = {"type": "string"}
        if spec.choices is not None:
            out["enum"] = list(spec.choices)
        return {**out, **_json_schema_default(spec), **_json_description(spec)}
    if isinstance(spec, Bool):
        return {"type": "boolean", **_json_schema_default(spec), **_json_description(spec)}
    if isinstance(spec, Vec):
        if spec.items is not None:
            items = {"prefixItems": [json_schema(it) for it in spec.items], "items": False}
        else:
            items = {"items": _json_number(Num(min=spec.min, min_exclusive=spec.min_exclusive, max=spec.max))}
        return {"type": "array", "minItems": spec.n, "maxItems": spec.n, **items, **_json_schema_default(spec),
                **_json_description(spec, spec.unit)}
    if isinstance(spec, ListOf):
        out = {"type": "array", "items": json_schema(spec.item)}
        if spec.min_len:
            out["minItems"] = spec.min_len
        if spec.max_len is not None:
            out["maxItems"] = spec.max_len
        return {**out, **_json_schema_default(spec), **_json_description(spec)}
    if isinstance(spec, OneOf):
        branches = []
        for kind in sorted(spec.variants):
            props, required = _json_map_body(spec.variants[kind])
            then = {"properties": {spec.key: {"const": kind}, **props}, "additionalProperties": False}
            if required:
                then["required"] = required
            then.update(_json_description(spec.variants[kind]))
            branches.append({"if": {"properties": {spec.key: {"const": kind}}, "required": [spec.key]},
                             "then": then})
        return {"type": "object", "required": [spec.key],
                "properties": {spec.key: {"enum": sorted(spec.variants)}}, "allOf": branches,
                **_json_description(spec)}
    if isinstance(spec, Map):
        props, required = _json_map_body(spec)
        out = {"type": ["object", "null"] if spec.allow_null else "object", "properties": props,
               "additionalProperties": False}
        if required:
            out["required"] = required
        return {**out, **_json_description(spec)}
    return {}  # pragma: no cover - every schema class is handled above
