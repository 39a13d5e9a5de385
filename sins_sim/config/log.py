"""Log descriptions (``sins-sim import-log LOG --describe LOG.yaml``): how a unit's own log is laid out.

A navigation-grade unit logs integer pulse counts per interval in its own axes; the description says
how to read them, and :func:`load_log_description` turns it into the plain
:class:`~sins_sim.io.unitlog.LogLayout` the reader (:func:`sins_sim.io.unitlog.read_unit_log`) takes::

    format: {type: text, delimiter: whitespace, header_rows: 4, comment: "#"}
    columns: {time: 0, gyro: [1, 2, 3], accelerometer: [4, 5, 6]}   # 0-based positions, or names (csv, parquet)
    time: {unit: s, rate_hz: 100, gaps: refuse}
    gyro: {kind: counts, weight_arcsec: 0.1}            # one pulse; a scalar or one value per axis
    accelerometer: {kind: counts, weight_ug_s: 125}
    axes: RFU                                           # the log's x, y, z: right, forward, up
    site:
      lat_deg: {header: Latitude}                       # from a header line "Latitude: 56.8" or "Latitude = 56.8"
      lon_deg: {header: Longitude}
      height_m: 150.0
    initial_velocity: {north_m_s: 0, east_m_s: 0, down_m_s: 0}

Every key is checked by :data:`LOG_SCHEMA` (``sins-sim schema log`` lists them); the rules across keys
are checked here, each broken one a single :class:`ConfigError` line naming the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from sins_sim.io.trajectory import HEIGHT_RANGE_M, MAX_SPEED_M_S
from sins_sim.io.unitlog import DELIMITERS, ROTATION_TOLERANCE, HeaderValue, LogLayout, axes_matrix, check_rotation
from sins_sim.units import ARCSEC, DEG, MICRO_G, STANDARD_GRAVITY
from sins_sim.config.schema import UNIT_LABELS, UNITS, ConfigError, Map, Num, Str, fill_defaults, validate

__all__ = ["LOG_SCHEMA", "LogDescription", "load_log_description", "CHANNEL_UNITS"]

_FT = 0.3048  # international foot (m), exact by definition (1959)

#: Per channel and kind: unit suffix -> (SI per unit, label). ``ug`` is the micro-g of standard gravity
#: (9.80665 m/s^2, the conventional value of the 3rd CGPM, 1901), so 125 ug s = 1.2258 mm/s.
CHANNEL_UNITS = {
    ("gyro", "counts"): {"arcsec": (ARCSEC, "arcsec"), "rad": (1.0, "rad")},
    ("gyro", "totals"): {"arcsec": (ARCSEC, "arcsec"), "rad": (1.0, "rad")},
    ("gyro", "increments"): {"rad": (1.0, "rad"), "mrad": (1e-3, "mrad"), "urad": (1e-6, "urad"), "deg": (DEG, "deg"),
                             "arcsec": (ARCSEC, "arcsec")},
    ("gyro", "rates"): {"rad_s": (1.0, "rad/s"), "deg_s": (DEG, "deg/s"), "deg_h": (DEG / 3600.0, "deg/h"),
                        "arcsec_s": (ARCSEC, "arcsec/s")},
    ("accelerometer", "counts"): {"m_s": (1.0, "m/s"), "ug_s": (MICRO_G, "ug s")},
    ("accelerometer", "totals"): {"m_s": (1.0, "m/s"), "ug_s": (MICRO_G, "ug s")},
    ("accelerometer", "increments"): {"m_s": (1.0, "m/s"), "mm_s": (1e-3, "mm/s"), "ft_s": (_FT, "ft/s"),
                                      "ug_s": (MICRO_G, "ug s"), "g_s": (STANDARD_GRAVITY, "g s")},
    ("accelerometer", "rates"): {"m_s2": (1.0, "m/s^2"), "ft_s2": (_FT, "ft/s^2"), "g": (STANDARD_GRAVITY, "g"),
                                 "mg": (1e-3 * STANDARD_GRAVITY, "mg"), "ug": (MICRO_G, "ug")},
}
_KINDS = ("counts", "totals", "increments", "rates")
_PULSES = ("counts", "totals")
#: A running-total counter's width (bits) when it rolls over.
_WRAP_BITS = (8, 64)
_LAT_HINT = (" (decimal degrees; a value beyond 90 is in another unit: NMEA ddmm.mm, arc minutes, or a number "
             "meant for another key)")


def _fail(ctx, path, rule):
    raise ConfigError(f"{ctx}: {path}: {rule}")


def _rows(path, kind, unit, rng, default, doc):
    return {"key": path, "kind": kind, "unit": unit, "range": rng, "default": default, "doc": doc}


class _Column:
    """A column: a 0-based position (integer >= 0) or a name (non-empty string)."""

    unit = None

    def __init__(self, default=None, required=False, doc=""):
        self.default, self.required, self.doc = default, required, doc

    def check(self, value, ctx, path):
        if isinstance(value, bool) or not isinstance(value, (int, str)) or (isinstance(value, int) and value < 0) \
                or (isinstance(value, str) and not value.strip()):
            _fail(ctx, path, f"must be a 0-based column position (integer >= 0) or a column name, got {value!r}")
        return value

    def describe_rows(self, path):
        return [_rows(path, "integer or string", "", ">= 0, or a name", "required" if self.required else "(none)",
                      self.doc)]

    def json_schema(self):
        return {"oneOf": [{"type": "integer", "minimum": 0}, {"type": "string", "minLength": 1}],
                "description": self.doc}


class _Columns3(_Column):
    """Three columns: the log's x, y, z channels."""

    def check(self, value, ctx, path):
        if not isinstance(value, list) or len(value) != 3:
            _fail(ctx, path, f"must be a list of 3 columns (the log's x, y, z), got {value!r}")
        return [_Column.check(self, v, ctx, f"{path}[{i}]") for i, v in enumerate(value)]

    def describe_rows(self, path):
        return [_rows(path, "list of 3 columns", "", "each >= 0, or a name", "required", self.doc)]

    def json_schema(self):
        return {"type": "array", "minItems": 3, "maxItems": 3, "items": _Column.json_schema(self),
                "description": self.doc}


def _per_axis(value, ctx, path):
    """A scalar or 3 numbers, each finite and != 0: three floats."""
    items = value if isinstance(value, list) else [value]
    if len(items) not in (1, 3) or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in items):
        _fail(ctx, path, f"must be a number or a list of 3 numbers (x, y, z), got {value!r}")
    for i, x in enumerate(items):
        where = path if len(items) == 1 else f"{path}[{i}]"
        if not math.isfinite(x) or x == 0:
            _fail(ctx, where, f"must be finite and != 0, got {x!r}")
    return [float(x) for x in items] * (3 if len(items) == 1 else 1)


class _Channel:
    """``gyro`` or ``accelerometer``: what the three channels hold and in which unit."""

    unit = None
    default = None
    required = True

    def __init__(self, sensor: str):
        self.sensor = sensor
        self.doc = (f"what the three {sensor} channels hold: kind counts or totals (pulses; one weight_<unit> key: "
                    "the value of one pulse), increments or rates (unit, and scale: the value of one logged unit)")

    def _units(self, kind):
        return CHANNEL_UNITS[(self.sensor, kind)]

    def _weight_keys(self):
        return [f"weight_{u}" for u in self._units("counts")]

    def check(self, value, ctx, path):
        if not isinstance(value, dict):
            _fail(ctx, path, f"must be a mapping with a 'kind' key, got {value!r}")
        kind = value.get("kind")
        if kind not in _KINDS:
            _fail(ctx, f"{path}.kind", f"must be one of {list(_KINDS)}, got {kind!r}")
        pulses = kind in _PULSES
        allowed = {"kind"} | (set(self._weight_keys()) if pulses else {"unit", "scale"})
        if kind == "totals":
            allowed.add("wrap_bits")
        for key in value:
            if key in allowed:
                continue
            if key.startswith("weight") and pulses:
                _fail(ctx, f"{path}.{key}", f"unknown unit: write one of {', '.join(self._weight_keys())}")
            if key.startswith("weight"):
                _fail(ctx, f"{path}.{key}", f"a weight is for counts and totals; {kind} take unit (one of "
                                            f"{', '.join(self._units(kind))}) and optionally scale")
            if key in ("unit", "scale"):
                _fail(ctx, f"{path}.{key}", f"{kind} take a weight_<unit> key (the value of one pulse), not unit "
                                            "or scale")
            if key == "wrap_bits":
                _fail(ctx, f"{path}.{key}", "only for kind totals (a running counter that rolls over)")
            _fail(ctx, f"{path}.{key}", f"unknown key (allowed: {', '.join(sorted(allowed))})")
        wrap = None
        if "wrap_bits" in value:
            wrap = Num(integer=True, min=_WRAP_BITS[0], max=_WRAP_BITS[1]).check(value["wrap_bits"], ctx,
                                                                                 f"{path}.wrap_bits")
        if pulses:
            weights = sorted(k for k in value if k.startswith("weight_"))
            if len(weights) != 1:
                _fail(ctx, f"{path}.{weights[1] if weights else self._weight_keys()[0]}",
                      f"{kind} need exactly one weight key (the value of one pulse), got {len(weights)}")
            unit = weights[0][len("weight_"):]
            factor, values = self._units(kind)[unit][0], _per_axis(value[weights[0]], ctx, f"{path}.{weights[0]}")
        else:
            unit = value.get("unit")
            if unit not in self._units(kind):
                _fail(ctx, f"{path}.unit", f"{kind} need a unit, one of {list(self._units(kind))}, got {unit!r}")
            factor, values = self._units(kind)[unit][0], _per_axis(value.get("scale", 1.0), ctx, f"{path}.scale")
        return {"kind": kind, "unit": unit, "scale_si": [factor * v for v in values], "wrap_bits": wrap}

    def describe_rows(self, path):
        def labels(kind):
            return ", ".join(f"{u} ({lab})" for u, (_, lab) in self._units(kind).items())

        rows = [_rows(path, "mapping", "", "mapping", "required", self.doc),
                _rows(f"{path}.kind", "string", "", "one of " + ", ".join(_KINDS), "required",
                      "counts: whole pulses per interval; totals: a running pulse counter read out at each row (the "
                      "increments are the differences of consecutive rows; the first row is the reference); "
                      "increments: angle (velocity) per interval; rates: angular rate (specific force), integrated "
                      "by the rectangle rule (increment = rate x period)")]
        for u, (_, lab) in self._units("counts").items():
            rows.append(_rows(f"{path}.weight_{u}", "number or list of 3 numbers", lab, "!= 0 each", "(none)",
                              "counts and totals: the value of one pulse, one for all channels or x, y, z; exactly "
                              "one weight key; negative for a channel counting against its axis"))
        rows.append(_rows(f"{path}.wrap_bits", "integer", "", f"[{_WRAP_BITS[0]}, {_WRAP_BITS[1]}]", "(none)",
                          "totals: the counter's width when it rolls over (16: 65535 is followed by 0); absent: it "
                          "does not"))
        rows.append(_rows(f"{path}.unit", "string", "", f"increments: {labels('increments')}; rates: "
                                                        f"{labels('rates')}", "(none)",
                          "increments and rates: the unit of the logged values"))
        rows.append(_rows(f"{path}.scale", "number or list of 3 numbers", "", "!= 0 each", "1",
                          "increments and rates: logged value x scale is in unit (an LSB weight; negative for a "
                          "channel counting against its axis)"))
        return rows

    def json_schema(self):
        num3 = {"oneOf": [{"type": "number", "not": {"const": 0}},
                          {"type": "array", "minItems": 3, "maxItems": 3,
                           "items": {"type": "number", "not": {"const": 0}}}]}
        props = {"kind": {"enum": list(_KINDS)}, "scale": num3,
                 "unit": {"enum": sorted({u for k in ("increments", "rates") for u in self._units(k)})},
                 "wrap_bits": {"type": "integer", "minimum": _WRAP_BITS[0], "maximum": _WRAP_BITS[1]}}
        props.update({key: num3 for key in self._weight_keys()})
        return {"type": "object", "required": ["kind"], "properties": props, "additionalProperties": False,
                "description": self.doc}


class _Axes:
    """The log's axes: a convention string or a 3x3 matrix (rows: the log's x, y, z axes in FRD)."""

    unit = None
    default = None
    required = True
    doc = ("the log's x, y, z axes: a letter triple of F/B (forward/back), R/L (right/left), U/D (up/down) such as "
           "RFU, FLU, FRD, or long forms (right-forward-up); or a 3x3 matrix whose rows are the log's x, y, z axes "
           f"expressed in body FRD (x forward, y right, z down), orthonormal to {ROTATION_TOLERANCE:g}, det +1")

    def check(self, value, ctx, path):
        if not isinstance(value, (str, list)):
            _fail(ctx, path, f"must be a convention string (e.g. RFU) or a 3x3 matrix, got {value!r}")
        try:
            m = axes_matrix(value) if isinstance(value, str) else check_rotation(value)
        except ValueError as exc:
            _fail(ctx, path, str(exc))
        return {"text": value if isinstance(value, str) else None, "matrix": m.tolist()}

    def describe_rows(self, path):
        return [_rows(path, "string or 3x3 list", "", "right-handed", "required", self.doc)]

    def json_schema(self):
        row = {"type": "array", "minItems": 3, "maxItems": 3, "items": {"type": "number"}}
        return {"oneOf": [{"type": "string"}, {"type": "array", "minItems": 3, "maxItems": 3, "items": row}],
                "description": self.doc}


class _ValueOrHeader:
    """A number in the key's unit, or ``{header: KEY}``: the value a header line ``KEY: value`` carries."""

    def __init__(self, unit, lo, hi, doc, default=None, hint=""):
        self.unit, self.lo, self.hi, self.doc, self.default, self.hint = unit, lo, hi, doc, default, hint
        self.required = False

    def check(self, value, ctx, path):
        if isinstance(value, dict):
            if set(value) != {"header"} or not isinstance(value["header"], str) or not value["header"].strip():
                _fail(ctx, path, f"must be a number or {{header: KEY}} (a header line 'KEY: value'), got {value!r}")
            return {"header": value["header"].strip()}
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            _fail(ctx, path, f"must be a number or {{header: KEY}}, got {value!r}")
        if not self.lo <= value <= self.hi:
            _fail(ctx, path, f"must lie in [{self.lo:g}, {self.hi:g}] {UNIT_LABELS[self.unit]}, got {value!r}"
                             f"{self.hint}")
        return float(value) * UNITS[self.unit][1]

    def header_value(self, entry, path):
        """The reader's :class:`HeaderValue` of a ``{header: KEY}`` entry (the range and hint travel with it)."""
        return HeaderValue(entry["header"], UNITS[self.unit][1], path, self.lo, self.hi, self.hint)

    def describe_rows(self, path):
        d = "(none)" if self.default is None else f"{self.default:g}"
        return [_rows(path, "number or {header: KEY}", UNIT_LABELS[self.unit], f"[{self.lo:g}, {self.hi:g}]", d,
                      self.doc)]

    def json_schema(self):
        return {"oneOf": [{"type": "number", "minimum": self.lo, "maximum": self.hi},
                          {"type": "object", "required": ["header"], "properties": {"header": {"type": "string"}},
                           "additionalProperties": False}],
                "description": f"[{UNIT_LABELS[self.unit]}] {self.doc}"}


_SITE = {
    "lat": _ValueOrHeader("deg", -90.0, 90.0, "geodetic latitude (WGS-84)", hint=_LAT_HINT),
    "lon": _ValueOrHeader("deg", -360.0, 360.0, "longitude"),
    "height": _ValueOrHeader("m", *HEIGHT_RANGE_M, "height above the WGS-84 ellipsoid"),
}
_VELOCITY = {axis: _ValueOrHeader("m_s", -MAX_SPEED_M_S, MAX_SPEED_M_S, f"{axis} velocity at the log's start",
                                  default=0.0) for axis in ("north", "east", "down")}

LOG_SCHEMA = Map({
    "name": Str(default="", doc="a label for the unit or the log"),
    "format": Map({
        "type": Str(choices=("text", "csv", "parquet"), required=True,
                    doc="text: header rows, then one row per interval; csv: header rows, then a names row, then "
                        "the rows; parquet: one row per interval, header values in the key-value metadata"),
        "delimiter": Str(choices=tuple(DELIMITERS), default=None,
                         doc="between the fields: text whitespace unless given, csv comma unless given (or "
                             "semicolon, tab)"),
        "header_rows": Num(integer=True, min=0, max=100000, default=0,
                           doc="text and csv: lines at the top before the data (or the names row); searched for "
                               "header values"),
        "comment": Str(default="#", doc="text and csv: lines starting with it are skipped (those before the data "
                                        "are header lines); empty: none"),
    }, required=True, doc="the file's layout"),
    "columns": Map({
        "time": _Column(doc="the time column (absent: a fixed rate time.rate_hz)"),
        "gyro": _Columns3(required=True, doc="the gyro channels along the log's x, y, z axes"),
        "accelerometer": _Columns3(required=True, doc="the accelerometer channels along the log's x, y, z axes"),
        "temperature": _Column(doc="the unit's temperature (one reading per row; unit temperature.unit): written "
                                   "to the increments as temperature_c for sins-sim identify's coefficients"),
    }, required=True, doc="0-based positions or names (csv and parquet)"),
    "time": Map({
        "rate": Num(unit="hz", min=0.0, min_exclusive=True, max=1.0e6, default=None,
                    doc="the interval rate; required without a time column; with one, the column is checked "
                        "against it (absent: the fitted rate)"),
        "unit": Str(choices=("s", "ms", "us", "ns", "count"), default="s",
                    doc="the time column's unit; count: a sample counter, time = count / rate_hz"),
        "stamp": Str(choices=("end", "start"), default="end", doc="which end of its interval a row's time marks"),
        "start": Num(unit="s", min=0.0, default=0.0,
                     doc="without a time column: where the first interval starts (totals: the time of the first "
                         "row, the reference reading)"),
        "jitter": Num(min=0.0, max=0.45, default=0.1,
                      doc="largest distance of a logged time from its grid point, in periods"),
        "gaps": Str(choices=("refuse", "fill_mean"), default="refuse",
                    doc="a missing interval: refuse, or fill it with the mean of the intervals either side (each "
                        "filled interval listed in the output's metadata)"),
    }, default={}, doc="the time base"),
    "temperature": Map({
        "unit": Str(choices=("C", "K"), default="C", doc="the temperature column's unit: deg C or kelvin"),
    }, default={}, doc="the temperature column (columns.temperature)"),
    "gyro": _Channel("gyro"),
    "accelerometer": _Channel("accelerometer"),
    "axes": _Axes(),
    "site": Map(_SITE, default={}, doc="where the log starts: numbers, or {header: KEY} for a header line "
                                       "'KEY: value' or 'KEY = value' (absent: unknown)"),
    "initial_velocity": Map(_VELOCITY, default={}, doc="NED velocity at the log's start"),
}, rules=("columns.time or time.rate_hz: at least one",
          "time.unit count needs time.rate_hz; time.unit, stamp, jitter and gaps need columns.time; time.start_s "
          "only without it",
          "format.delimiter for text and csv (csv: not whitespace); a text log names its columns by 0-based position "
          "(it has no names row)",
          "columns: each column at most once",
          "gyro, accelerometer: counts and totals take exactly one weight_<unit> key (totals optionally wrap_bits); "
          "increments and rates take unit and optionally scale",
          "totals: time.stamp end",
          "a value from the header is checked against its key's range when the log is read"))


@dataclass(frozen=True)
class LogDescription:
    """A validated log description.

    Attributes
    ----------
    layout : LogLayout
        What :func:`sins_sim.io.unitlog.read_unit_log` takes (SI, plain values).
    resolved : dict
        The description with every default written out, in the file's own keys and units, plus the axes
        matrix (``axes_matrix_frd``: rows = the log's axes in FRD): what the output's metadata records.
    source : str
        The description's file (or ``log description (dict)``).
    """

    layout: LogLayout
    resolved: dict
    source: str


def _given(doc, section) -> set:
    part = doc.get(section) if isinstance(doc, dict) else None
    return set(part) if isinstance(part, dict) else set()


def _description(doc: dict, ctx: str) -> LogDescription:
    c = validate(doc, LOG_SCHEMA, ctx)
    fmt, cols, tm = c["format"], c["columns"], c["time"]
    given_time, given_fmt = _given(doc, "time"), _given(doc, "format")
    if cols["time"] is None:
        if tm["rate_hz"] is None:
            _fail(ctx, "time.rate_hz", "needed without a time column (columns.time)")
        needless = sorted(given_time & {"unit", "stamp", "jitter", "gaps"})
        if needless:
            _fail(ctx, f"time.{needless[0]}", "needs a time column (columns.time): with a fixed rate there is no "
                                             "time to check")
    elif "start_s" in given_time:
        _fail(ctx, "time.start_s", "only without a time column (the column gives the times)")
    g, a = c["gyro"], c["accelerometer"]
    if "totals" in (g["kind"], a["kind"]) and tm["stamp"] == "start":
        _fail(ctx, "time.stamp", "a running total is read at an instant: its row's time ends the interval it closes "
                                 "(stamp end)")
    if tm["unit"] == "count" and tm["rate_hz"] is None:
        _fail(ctx, "time.rate_hz", "needed with time.unit: count (time = count / rate)")
    delimiter = fmt["delimiter"] or {"text": "whitespace", "csv": "comma", "parquet": "whitespace"}[fmt["type"]]
    if fmt["type"] == "parquet" and "delimiter" in given_fmt:
        _fail(ctx, "format.delimiter", "only for text and csv logs (parquet has its own)")
    if fmt["type"] == "csv" and delimiter == "whitespace":
        _fail(ctx, "format.delimiter", "a csv log's fields are split by comma, semicolon or tab (whitespace: "
                                       "format.type text)")
    if fmt["type"] == "parquet":
        for key in sorted(given_fmt & {"header_rows", "comment"}):
            _fail(ctx, f"format.{key}", "only for text and csv logs (a parquet log's header values are its "
                                        "key-value metadata)")
    refs = [("columns.time", cols["time"])] if cols["time"] is not None else []
    refs += [(f"columns.{s}[{i}]", r) for s in ("gyro", "accelerometer") for i, r in enumerate(cols[s])]
    if cols["temperature"] is not None:
        refs.append(("columns.temperature", cols["temperature"]))
    elif "unit" in _given(doc, "temperature"):
        _fail(ctx, "temperature.unit", "needs a temperature column (columns.temperature)")
    if fmt["type"] == "text":
        named = next(((k, r) for k, r in refs if isinstance(r, str)), None)
        if named:
            _fail(ctx, named[0], f"{named[1]!r} is a name, but a text log has no names row: give the column's 0-based "
                                 "position (or format.type: csv)")
    seen = {}
    for key, r in refs:
        if r in seen:
            _fail(ctx, key, f"column {r!r} is already {seen[r]}")
        seen[r] = key
    site, velocity = {}, {}
    for name, spec in _SITE.items():
        si_key = f"{name}_{UNITS[spec.unit][0]}"
        value = c["site"][si_key]
        site[si_key] = spec.header_value(value, f"site.{name}_{spec.unit}") if isinstance(value, dict) else value
    for name, spec in _VELOCITY.items():
        value = c["initial_velocity"][f"{name}_m_s"]
        velocity[f"{name}_m_s"] = (spec.header_value(value, f"initial_velocity.{name}_m_s")
                                   if isinstance(value, dict) else value)
    time_scale = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "count": 1.0}[tm["unit"]]
    layout = LogLayout(
        fmt=fmt["type"], gyro_columns=tuple(cols["gyro"]), accel_columns=tuple(cols["accelerometer"]),
        gyro_kind=g["kind"], accel_kind=a["kind"], gyro_scale=tuple(g["scale_si"]), accel_scale=tuple(a["scale_si"]),
        axes=tuple(tuple(r) for r in c["axes"]["matrix"]), gyro_wrap_bits=g["wrap_bits"],
        accel_wrap_bits=a["wrap_bits"], time_column=cols["time"], time_scale=time_scale,
        time_count=tm["unit"] == "count", time_stamp=tm["stamp"], rate_hz=tm["rate_hz"], start_s=tm["start_s"],
        jitter=tm["jitter"], gaps=tm["gaps"], delimiter=delimiter, header_rows=fmt["header_rows"],
        comment=fmt["comment"], site=site, velocity=velocity, temperature_column=cols["temperature"],
        temperature_offset=-273.15 if c["temperature"]["unit"] == "K" else 0.0)
    return LogDescription(layout, _resolved(doc, layout, c["axes"]["matrix"]), ctx)


def _resolved(doc: dict, layout: LogLayout, matrix) -> dict:
    """The description with the defaults that apply written out (one that loads again to the same layout)."""
    out = fill_defaults(doc, LOG_SCHEMA)
    drop_time = ("unit", "stamp", "jitter", "gaps") if layout.time_column is None else ("start_s",)
    out["time"] = {k: v for k, v in out["time"].items() if k not in drop_time}
    if layout.temperature_column is None:
        out.pop("temperature", None)
    if layout.fmt == "parquet":
        out["format"] = {k: v for k, v in out["format"].items() if k not in ("header_rows", "comment")}
    else:
        out["format"] = {**out["format"], "delimiter": layout.delimiter}
    return {**out, "axes_matrix_frd": matrix}


def load_log_description(source) -> LogDescription:
    """Load and validate a log description (a YAML file, or the same content as a mapping).

    Parameters
    ----------
    source : path or mapping

    Returns
    -------
    LogDescription

    Raises
    ------
    ConfigError
        One line naming the file (``log description (dict)`` for a mapping), the key path (with its line
        and column in a file) and the rule.

    Examples
    --------
    >>> d = load_log_description({"format": {"type": "text"}, "columns": {"gyro": [0, 1, 2],
    ...                           "accelerometer": [3, 4, 5]}, "time": {"rate_hz": 100},
    ...                           "gyro": {"kind": "counts", "weight_arcsec": 0.1},
    ...                           "accelerometer": {"kind": "counts", "weight_ug_s": 125}, "axes": "RFU"})
    >>> d.layout.axes
    ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))
    """
    from collections.abc import Mapping

    if isinstance(source, Mapping):
        import copy

        return _description(copy.deepcopy(dict(source)), "log description (dict)")
    from sins_sim.config.yaml_io import load_yaml

    path = Path(source)
    return _description(load_yaml(path), str(path))
