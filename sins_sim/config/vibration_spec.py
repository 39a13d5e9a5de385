"""The scenario's ``vibration.spec``: a sine-on-random specification as a test standard writes it.

Keys, units and ranges are checked here (one line naming the key); the specification resolves to the vibration
models in :mod:`sins_sim.models.vibration_spec`. The specification is a mapping, in the scenario or in a YAML file
it names (relative to the scenario)::

    vibration:
      spec:
        source: "where the levels come from"
        all:                          # or x:, y:, z: (an axis not given is still)
          random: {psd_g2_per_hz: [[10, 0.001], [100, 0.001], [500, 0.0002]]}
          sines: [{frequency_hz: 89.5, amplitude_g: 0.3}]
          rotor: {speed_rpm: 324, blades: 4, amplitude_g: [0.8, 0.3, 0.15]}
"""

from __future__ import annotations

from pathlib import Path

from sins_sim.config.errors import ConfigError, alias_marks
from sins_sim.config.schema import ListOf, Map, Num, Str, Vec, validate
from sins_sim.config.yaml_io import load_yaml

__all__ = ["VIBRATION_SPEC_SCHEMA", "VIBRATION_SCHEMA", "parse_vibration_spec", "MAX_LINE_G", "MAX_PSD_G2_PER_HZ"]

#: Sine line amplitude (g peak): 100 g is beyond any qualification's sine level (helicopter lines are 0.1-5 g).
MAX_LINE_G = 100.0
#: Background PSD (g^2/Hz): 10 g^2/Hz over 2 kHz is 141 g RMS, beyond any qualification test (as linear_vibration).
MAX_PSD_G2_PER_HZ = 10.0
#: Rotor speed (rev/s): main rotors turn at 3-7 rev/s, tail rotors at 20-30; 200 rev/s (12000 rpm) bounds any.
MAX_ROTOR_REV_S = 200.0
_F = dict(min=0.0, min_exclusive=True, max=5.0e5)

_AXIS_BODY = Map({
    "random": Map({"psd_g2_per_hz": ListOf(Vec(2, items=(Num(**_F), Num(min=0.0, min_exclusive=True,
                                                                         max=MAX_PSD_G2_PER_HZ))),
                                           required=True, min_len=2, max_len=1000,
                                           doc="[[f_hz, g^2/Hz], ...] breakpoints, f increasing; log-log "
                                               "interpolated between them, zero outside")},
                  default=None, allow_null=True, doc="the random background"),
    "sines": ListOf(Map({"frequency_hz": Num(required=True, **_F),
                         "amplitude_g": Num(required=True, min=0.0, max=MAX_LINE_G, doc="g peak")}),
                    default=[], max_len=1000, doc="sine lines"),
    "rotor": Map({"speed_rev_s": Num(min=0.0, min_exclusive=True, max=MAX_ROTOR_REV_S, default=None,
                                     doc="rotor speed (rev/s); or speed_rpm"),
                  "speed_rpm": Num(min=0.0, min_exclusive=True, max=60.0 * MAX_ROTOR_REV_S, default=None,
                                   doc="rotor speed (rev/min); or speed_rev_s"),
                  "blades": Num(integer=True, required=True, min=1, max=20),
                  "amplitude_g": ListOf(Num(min=0.0, max=MAX_LINE_G), required=True, min_len=1, max_len=100,
                                        doc="g peak of harmonic n = 1 .. N of the blade passage")},
                 default=None, allow_null=True,
                 doc="lines at n * blades * rotor rate, n = 1 .. len(amplitude_g)"),
}, doc="one axis (or all): random background, sine lines, rotor lines; at least one")

VIBRATION_SPEC_SCHEMA = Map({
    "source": Str(default="", doc="where the levels come from (reported with the run)"),
    "all": Map(_AXIS_BODY.fields, default=None, allow_null=True, doc="the same specification on x, y and z "
                                                                    "(independent noise per axis)"),
    "x": Map(_AXIS_BODY.fields, default=None, allow_null=True, doc="body x only"),
    "y": Map(_AXIS_BODY.fields, default=None, allow_null=True, doc="body y only"),
    "z": Map(_AXIS_BODY.fields, default=None, allow_null=True, doc="body z only"),
}, doc="sine-on-random specification (MIL-STD-810H Method 514.8 style): all, or per axis x, y, z",
    rules=("all, or any of x, y, z: not both",
           "each axis gives random, sines or rotor",
           "rotor: exactly one of speed_rev_s and speed_rpm",
           "one line per frequency on an axis (a sine line on a rotor harmonic is given once)",
           "every frequency below the filter Nyquist (readout.output_rate_hz / 2)"))


class _SpecEntry:
    """``vibration.spec``: a mapping (:data:`VIBRATION_SPEC_SCHEMA`) or a path to a YAML file holding one."""

    unit = None
    default = None
    required = True

    def describe_rows(self, path):
        from sins_sim.config.schema import describe

        return ([{"key": path, "kind": "path or mapping", "unit": "", "range": "a spec file or mapping",
                  "default": "required", "doc": "a sine-on-random specification, or a YAML file holding one "
                                                "(relative to the scenario)"}]
                + describe(VIBRATION_SPEC_SCHEMA, path)[1:])  # [0] is the mapping row of path itself

    def json_schema(self):
        from sins_sim.config.schema import json_schema

        return {"anyOf": [{"type": "string"}, json_schema(VIBRATION_SPEC_SCHEMA)],
                "description": "a sine-on-random specification, or a YAML file holding one"}

    def check(self, value, ctx, path):
        if not isinstance(value, (str, dict)):
            raise ConfigError(f"{ctx}: {path}: must be a path to a specification file or a mapping, got {value!r}")
        return value


VIBRATION_SCHEMA = Map({"spec": _SpecEntry()}, default=None, allow_null=True,
                       doc="the vibration as a specification (replaces linear_vibration)",
                       rules=("refused beside linear_vibration, which it would duplicate",))


def parse_vibration_spec(value, base_dir: Path, ctx: str, nyquist_hz: float):
    """``vibration.spec`` (mapping or file) -> :class:`~sins_sim.models.vibration_spec.SineOnRandomSpec`.

    Every refusal is one line naming the key (in the file, when the specification is one).
    """
    from sins_sim.models.vibration_spec import AxisSpec, SineOnRandomSpec, rotor_lines

    where, path = ctx, "vibration.spec"
    if isinstance(value, str):
        file = (Path(base_dir) / value).resolve()
        if not file.exists():
            raise ConfigError(f"{ctx}: vibration.spec: file not found: {file}")
        where, path = f"{ctx} -> {file.name}", ""
        alias_marks(where, str(file))
        value = load_yaml(file)
    c = validate(value, VIBRATION_SPEC_SCHEMA, where, path)

    def key(k):
        return f"{path}.{k}" if path else k

    given = [a for a in ("x", "y", "z") if c[a] is not None]
    if c["all"] is not None and given:
        raise ConfigError(f"{where}: {key('all')}: refused beside {key(given[0])} (all gives every axis): give "
                          f"one or the other")
    if c["all"] is None and not given:
        raise ConfigError(f"{where}: {path or 'spec'}: must give all, or at least one of x, y, z")
    axes = []
    for name in ("x", "y", "z"):
        body = c["all"] if c["all"] is not None else c[name]
        src = "all" if c["all"] is not None else name
        if body is None:
            axes.append(None)
            continue
        if body["random"] is None and not body["sines"] and body["rotor"] is None:
            raise ConfigError(f"{where}: {key(src)}: must give random, sines or rotor")
        table = None
        if body["random"] is not None:
            table = [tuple(r) for r in body["random"]["psd_g2_per_hz"]]
            for i in range(1, len(table)):
                if not table[i][0] > table[i - 1][0]:
                    raise ConfigError(f"{where}: {key(src)}.random.psd_g2_per_hz[{i}]: frequencies must increase, "
                                      f"got {table[i][0]:g} after {table[i - 1][0]:g}")
        lines, origin = [], []
        for i, s in enumerate(body["sines"]):
            lines.append((s["frequency_hz"], s["amplitude_g"]))
            origin.append(f"{src}.sines[{i}].frequency_hz")
        r = body["rotor"]
        if r is not None:
            both = [k for k in ("speed_rev_s", "speed_rpm") if r[k] is not None]
            if len(both) != 1:
                raise ConfigError(f"{where}: {key(src)}.rotor.speed_rev_s: give exactly one of speed_rev_s and "
                                  f"speed_rpm, got {' and '.join(both) if both else 'neither'}")
            rev_s = r["speed_rev_s"] if r["speed_rev_s"] is not None else r["speed_rpm"] / 60.0
            for n, (f, a) in enumerate(rotor_lines(rev_s, r["blades"], r["amplitude_g"]), start=1):
                lines.append((f, a))
                origin.append(f"{src}.rotor.amplitude_g[{n - 1}] (harmonic {n}, {f:g} Hz)")
        seen = {}
        for (f, _), o in zip(lines, origin):
            if f in seen:
                raise ConfigError(f"{where}: {key(o)}: a line at {f:g} Hz is already given by {key(seen[f])}: "
                                  f"give it once")
            seen[f] = o
        freqs = [(f, o) for (f, _), o in zip(lines, origin)]
        if table is not None:
            freqs.append((table[-1][0], f"{src}.random.psd_g2_per_hz[{len(table) - 1}]"))
        for f, o in freqs:
            if not f < nyquist_hz:
                raise ConfigError(f"{where}: {key(o)}: must be < the filter Nyquist {nyquist_hz:g} Hz "
                                  f"(readout.output_rate_hz / 2; above it the vibration aliases), got {f:g}")
        try:
            axes.append(AxisSpec(None if table is None else tuple(table), tuple(lines)))
        except ValueError as exc:
            raise ConfigError(f"{where}: {key(src)}: {exc}") from None
    return SineOnRandomSpec(tuple(axes), c["source"])
