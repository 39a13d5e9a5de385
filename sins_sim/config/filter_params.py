"""The filters' own parameters: what the correcting filter and its plug-ins believe about each unit.

A real unit's filter does not know the suspension's true f0 and k1..k5: it runs on the batch's
datasheet values, on a refit of that unit, or on values a user gives, and its omega0 comes from
the dither phase-locked loop ("omega0 was determined by the dither phase-locked loop taking
into account a relative mismatch", the paper, section on Fig. 6). The IMU file's
``filter_parameters`` key says which (issue 11, item 4)::

    filter_parameters: true          # the unit's true parameters (the ideal case; the default)
    filter_parameters: nominal       # the datasheet (the IMU file's shared suspension), f0 from the PLL
    filter_parameters:
      source: explicit               # true | nominal | explicit | diagnose
      f0: pll                        # pll | unit | given
      f0_mismatch_ppm: 0.0           # relative offset of the filter's f0 on top
      suspension: {k1: ..., k2_rad: ..., k3: ..., k4_per_rad: ..., k5_rad_per_v: ...}   # explicit, shared
      channels: {x: {f0_hz: 386.1, suspension: {k3: 4.5e-3}}}                          # explicit, per axis
      file: unit-17-diagnosis.json   # source: diagnose; a ``sins-sim diagnose --json`` file
      track: false                   # true: the PLL follows the resonance over the mission (temperature)
      online: {forgetting_s: 5.0, update_s: 0.1, smoothing_s: 0.0}   # source: online (issue 29)

Sources of k1..k5 (eq. 9, 10, 14):

``true``
    The unit's own (each channel's merged suspension).
``nominal``
    The IMU file's shared top-level ``suspension`` block (the batch's datasheet), the same for
    the three axes, whatever the channels override.
``explicit``
    The shared block of ``filter_parameters.suspension`` (defaults: the nominal values), then
    the per-axis overrides of ``filter_parameters.channels``.
``diagnose``
    ``baseline.params[axis]`` of a diagnosis JSON: the refit of that unit's nominal model
    (``f0_hz``, ``k1`` .. ``k5``).
``online``
    Learned in operation (:mod:`sins_sim.filters.online_estimator`, :mod:`sins_sim.simulation.online`):
    the filters start on the datasheet (as ``nominal``, f0 from the PLL) and every ``online.update_s``
    take the estimator's current f0, k1 .. k5 (smoothed over ``online.smoothing_s``). The estimator
    learns from the amplitude modulation (``drive.modulation_depth`` > 0 is required; ``drive.modulation``
    chooses its schedule) with exponential forgetting of time constant ``online.forgetting_s``; k4 stays
    at the datasheet (the paper's choice).

Source of omega0 (``f0``):

``pll``
    The PLL locks the drive to the dither's resonance at the working amplitude, ``F(a)``
    (eq. 9 by harmonic balance, :meth:`SuspensionParams.resonance_hz`); the filter turns the
    locked frequency back into omega0 with the k1, k2 it believes:
    ``f0_filter = f_drive * f0_b / F_b(a)``. Exact when the believed k1, k2 are the true ones.
``unit``
    The unit's true small-amplitude f0 (an oracle; what ``true`` uses).
``given``
    The f0 of the source (``explicit``: ``channels.AXIS.f0_hz``, required; ``diagnose``: the
    refit's f0; ``nominal``: the channel's ``f0_hz`` of the IMU file, the design value).

Tracking (``track: true``): the drive follows the unit's current ``F(a)`` block by block and the
filters' f0 follows the drive by the same inversion (``sins_sim.simulation.channel._ThermalSchedule``);
without it the drive and the filters keep their t = 0 values while a temperature profile or a
resonance drift moves the plant.

Defaults: ``true`` takes ``unit``; ``nominal``, ``explicit`` and ``online`` take ``pll``; ``diagnose`` takes
``given``. ``f0_mismatch_ppm`` scales the result by ``1 + ppm 1e-6`` (the PLL's relative
mismatch, Fig. 6).
"""

from __future__ import annotations

from sins_sim.config.schema import Bool, ConfigError, Map, Num, Str, json_schema, validate

__all__ = ["FILTER_PARAMETERS_SCHEMA", "SOURCES", "F0_SOURCES", "parse_filter_parameters"]

SOURCES = ("true", "nominal", "explicit", "diagnose", "online")
F0_SOURCES = ("pll", "unit", "given")
_DEFAULT_F0 = {"true": "unit", "nominal": "pll", "explicit": "pll", "diagnose": "given", "online": "pll"}


def _k_fields():
    return {
        "k1": Num(min=0.0, max=0.1, doc="eq. 9 scale (default: the nominal)"),
        "k2": Num(unit="rad", min=1e-6, max=0.1, doc="eq. 9 angle (default: the nominal)"),
        "k3": Num(min=0.0, max=0.2, doc="eq. 10 dissipation (default: the nominal)"),
        "k4": Num(unit="per_rad", min=-20.0, max=1.0e4, doc="eq. 10 amplitude dependence (default: the nominal)"),
        "k5": Num(unit="rad_per_v", min=-1e-2, max=1e-2, nonzero=True, doc="eq. 14 piezo gain (default: the nominal)"),
    }


ONLINE_SCHEMA = Map({
    "forgetting": Num(unit="s", min=0.05, max=1e4, default=5.0,
                      doc="time constant of the estimator's exponential forgetting: a steady drift is followed with "
                          "this lag"),
    "update": Num(unit="s", min=1e-3, max=100.0, default=0.1, doc="interval between updates of the filters"),
    "smoothing": Num(unit="s", min=0.0, max=1e4, default=0.0,
                     doc="time constant of the first-order smoothing of the values fed to the filters (0: none)"),
    "interval_cycles": Num(min=1, max=1000, integer=True, default=2,
                           doc="dither periods per integration interval of the estimator"),
    "window_cycles": Num(min=1, max=1000, integer=True, default=2,
                         doc="dither periods of the envelope's Hann window (<= interval_cycles)"),
    "band": Num(min=0.01, max=0.99, default=0.5,
                doc="intervals whose amplitude leaves a_m (1 +- band) are left out (a dead readout, a start-up)"),
    "k_prior": Num(min=0.01, max=10.0, default=0.5,
                   doc="standard deviation of the log-normal prior of k1, k2 around the datasheet"),
    "min_spread": Num(min=1e-4, max=0.5, default=0.005,
                      doc="RMS relative amplitude modulation below which no estimate is applied"),
}, default={}, doc="source: online; the estimator's settings (sins_sim.filters.online_estimator)")


FILTER_PARAMETERS_SCHEMA = Map({
    "source": Str(choices=SOURCES, default="true",
                  doc="where the filters' k1..k5 come from: the unit's true values, the datasheet (shared "
                      "suspension), explicit values, or a diagnosis JSON"),
    "f0": Str(choices=F0_SOURCES, default=None,
              doc="where the filters' omega0 comes from: the dither PLL (drive frequency through the believed "
                  "k1, k2), the unit's true f0, or the source's value (default: unit for true, pll for nominal and "
                  "explicit, given for diagnose)"),
    "f0_mismatch": Num(unit="ppm", min=-1e5, max=1e5, default=0.0,
                       doc="relative offset of the filters' f0 (the PLL's relative mismatch, Fig. 6)"),
    "suspension": Map(_k_fields(), default={}, doc="explicit: shared values"),
    "channels": Map({axis: Map({"f0": Num(unit="hz", min=20.0, max=5000.0, doc="explicit f0 (f0: given)"),
                                "suspension": Map(_k_fields(), default={})}, default={})
                     for axis in ("x", "y", "z")}, default={}, doc="explicit: per-axis values"),
    "file": Str(default=None, doc="source: diagnose; a `sins-sim diagnose --json` file, relative to the IMU file"),
    "online": ONLINE_SCHEMA,
    "track": Bool(default=False,
                  doc="the dither PLL follows the unit's current resonance F(a) over the mission (under a scenario's "
                      "temperature profile or resonance drift) and the filters' f0 follows the drive, f0_filter = "
                      "f_drive f0_b / F_b(a); false: drive and filters stay at their t = 0 values"),
}, default={}, doc="what the correcting filter and the plug-in filters believe: true (the unit's own values, the default), nominal (the datasheet, f0 from the dither PLL) or this mapping")


def _json_schema() -> dict:
    """``filter_parameters`` for editors: ``true``, a source name, or the mapping (``source: true`` too)."""
    mapping = json_schema(Map(FILTER_PARAMETERS_SCHEMA.fields))
    mapping["properties"]["source"] = {"anyOf": [{"const": True}, mapping["properties"]["source"]]}
    shorthands = [s for s in SOURCES if s not in ("explicit", "diagnose")]
    return {"anyOf": [{"const": True}, {"enum": shorthands}, mapping], "description": FILTER_PARAMETERS_SCHEMA.doc}


FILTER_PARAMETERS_SCHEMA.json = _json_schema


def parse_filter_parameters(value, ctx: str, path: str = "filter_parameters") -> dict:
    """Validate the key; ``true``/``"true"``/``"nominal"``/... are short for ``{source: ...}``."""
    if value is True:
        value = {"source": "true"}
    elif isinstance(value, str):
        if value not in SOURCES or value in ("explicit", "diagnose"):
            raise ConfigError(f"{ctx}: {path}: must be true, nominal or a mapping with source "
                              f"(one of {', '.join(SOURCES)}), got {value!r}")
        value = {"source": value}
    elif value is None or value is False:
        raise ConfigError(f"{ctx}: {path}: must be true, nominal or a mapping, got {value!r}")
    elif isinstance(value, dict) and value.get("source") is True:  # YAML reads `source: true` as a boolean
        value = dict(value, source="true")
    c = validate(value, FILTER_PARAMETERS_SCHEMA, ctx, path)
    if c["f0"] is None:
        c["f0"] = _DEFAULT_F0[c["source"]]
    if c["source"] == "diagnose" and not c["file"]:
        raise ConfigError(f"{ctx}: {path}.file: required with source: diagnose")
    if c["source"] != "diagnose" and c["file"]:
        raise ConfigError(f"{ctx}: {path}.file: only with source: diagnose (source is {c['source']!r})")
    if c["source"] != "explicit" and (any(v is not None for v in c["suspension"].values())
                                      or any(c["channels"][a]["f0_hz"] is not None
                                             or any(v is not None for v in c["channels"][a]["suspension"].values())
                                             for a in ("x", "y", "z"))):
        raise ConfigError(f"{ctx}: {path}: suspension and channels only with source: explicit")
    if c["source"] != "online" and isinstance(value, dict) and value.get("online") is not None:
        raise ConfigError(f"{ctx}: {path}.online: only with source: online (source is {c['source']!r})")
    if c["source"] != "online":
        c.pop("online")  # the estimator's settings mean nothing to another source (and keep manifests as they were)
    if c["source"] == "online":
        if c["f0"] == "given":
            raise ConfigError(f"{ctx}: {path}.f0: given has no value with source: online (pll or unit)")
        o = c["online"]
        if o["window_cycles"] > o["interval_cycles"]:
            raise ConfigError(f"{ctx}: {path}.online.window_cycles: must be <= interval_cycles = "
                              f"{int(o['interval_cycles'])}, got {int(o['window_cycles'])}")
    if c["source"] == "explicit" and c["f0"] == "given":
        missing = [a for a in ("x", "y", "z") if c["channels"][a]["f0_hz"] is None]
        if missing:
            raise ConfigError(f"{ctx}: {path}.channels.{missing[0]}.f0_hz: required with f0: given")
    if c["source"] == "true" and c["f0"] != "unit":
        pass  # the true k's with a PLL-tracked or mismatched f0: allowed (the mismatch study)
    return c


