"""IMU configuration files (``configs/*.yaml``) -> :class:`ImuConfig`.

Layout (every key optional except ``channels``; units in the key names)::

    name: default
    suspension: {k1: 1.75e-4, k2_rad: 1.05e-3, k3: 4.4e-3, k4_per_rad: 250, k5_rad_per_v: -1.2e-5}
    drive: {amplitude_arcmin: 3.0, dac_rate_hz: 72000, control: closed_loop, loop_time_s: 0.1,
            block_cycles: 10, modulation_depth: 0.0}
    plant: {rate_hz: 72000, hysteresis: paper}
    readout: {quantum_arcsec: 0.15125, noise_arcsec: 0.0, output_rate_hz: 7200,
              anti_alias: {cutoff_hz: 9000, numtaps: 21}}      # anti_alias: null = off
    correcting: {hysteresis: paper}
    eliminator: {width_hz: 40, rp_db: 0.1, rs_db: 60}
    effects:                      # catalogue effects acting in the engine (sins_sim.config.effects_schema)
      - {name: lock_in, axes: [x], threshold_rad_s: 2.0e-3}
    filter_parameters: nominal    # what the filters believe: true (default) | nominal | a mapping
                                  # (sins_sim.config.filter_params)
    pickoff:                      # the three dither pickoffs (sins_sim.models.pickoff), read by lms_stripper
      {scale_v_per_rad_s: 1.0, gain_error: 0.03, lag_s: 2.0e-6, noise_v: 5.0e-4, nonlinearity_per_rad2: 0.0,
       cross_coupling: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}
    lms_stripper: {mu: 0.05, highpass_hz: 50, adapt_band: highpass}   # the three-axis LMS stripper
                                  # (sins_sim.filters.lms_stripper)
    channels:
      x: {f0_hz: 386}
      y: {f0_hz: 352, suspension: {k3: 4.6e-3}}
      z: {f0_hz: 421, drive: {amplitude_arcmin: 2.9}}

A channel's ``suspension`` and ``drive`` entries override the shared ones: the shared block is the
batch's datasheet (what ``filter_parameters: nominal`` hands the filters), the channel's values are
the unit's own.
"""

from __future__ import annotations

import math

# Only light imports here: the schema is built from the models' declared ranges (sins_sim.models.ranges,
# sins_sim.filters.ranges), so a file is checked key by key before the models, the engine, numba and scipy are
# imported (imu_from_dict imports them once the schema has passed): a wrong file fails in a fraction of a second.
from sins_sim.filters import ranges as _elim
from sins_sim.models import ranges as _ranges
from sins_sim.units import ARCSEC
from sins_sim.config import block_schema as _block
from sins_sim.config import filter_params as _fparams
from sins_sim.config.effects_schema import EffectsList
from sins_sim.config.schema import ConfigError, ListOf, Map, Num, Str, Vec, validate
from sins_sim.config.yaml_io import load_yaml  # re-exported: other modules import it from here

__all__ = ["IMU_SCHEMA", "load_yaml", "load_imu", "imu_from_dict", "parse_imu"]


# The ranges are the models' physical ranges (sins_sim.models.ranges, where each is justified); the schema repeats them so that an error names the YAML key and the reference lists them.
_K5 = _ranges.K5_RANGE_RAD_PER_V[1]


def _suspension_fields(defaults: bool):
    d = (lambda x: x) if defaults else (lambda x: None)
    return {
        "k1": Num(min=0.0, max=_ranges.K1_MAX, default=d(1.75e-4), doc="eq. 9 scale; also k1 < 2 k2"),
        "k2": Num(unit="rad", min=_ranges.K2_RANGE_RAD[0], max=_ranges.K2_RANGE_RAD[1], default=d(1.05e-3),
                  doc="eq. 9 angle"),
        "k3": Num(min=0.0, max=_ranges.K3_MAX, default=d(4.4e-3), doc="eq. 10 dissipation"),
        "k4": Num(unit="per_rad", min=_ranges.K4_MIN_PER_RAD, max=_ranges.K4_MAX_PER_RAD, default=d(250.0),
                  doc=f"eq. 10 amplitude dependence; the loss k3 (1 + k4 a) + 2 zeta < 1 up to "
                      f"a = {_ranges.LOSS_AMPLITUDE_RAD:g} rad"),
        "k5": Num(unit="rad_per_v", min=-_K5, max=_K5, nonzero=True, default=d(-1.2e-5),
                  doc=f"eq. 14 piezo gain; |k5| >= {_ranges.K5_RANGE_RAD_PER_V[0]:g}"),
        "zeta": Num(min=0.0, max=_ranges.ZETA_MAX, default=d(0.0), doc="extra viscous damping ratio"),
    }


def _drive_fields(defaults: bool):
    d = (lambda x: x) if defaults else (lambda x: None)
    lo, hi = _ranges.AMPLITUDE_RANGE_ARCMIN
    tlo, thi = _ranges.AMPLITUDE_TYPICAL_ARCMIN
    return {"amplitude": Num(unit="arcmin", min=lo, max=hi, default=d(3.0),
                             doc=f"dither amplitude; usual {tlo:g}-{thi:g} arcmin (outside: a warning)")}


_RATE = dict(min=_ranges.PLANT_RATE_RANGE_HZ[0], max=_ranges.PLANT_RATE_RANGE_HZ[1])
_F0 = _ranges.F0_RANGE_HZ


class _SensorsReference:
    """The ``sensors:`` section in the reference (parsed by :func:`sins_sim.models.sensor_errors.sensor_params_from_dict`)."""

    unit = None
    default = None
    required = False

    def describe_rows(self, path):
        from sins_sim.models.sensor_errors import reference_rows

        return reference_rows(path)

    def json_schema(self):
        """The gyro and accelerometer keys with their physical ranges
        (:func:`sins_sim.models.sensor_errors.key_ranges`); the parser,
        :func:`sins_sim.models.sensor_errors.sensor_params_from_dict`, checks the rest (the plateau of the bias
        instability, the misalignment's 3x3 form)."""
        from sins_sim.models.sensor_errors import key_ranges

        sections = {"gyro": {}, "accelerometer": {}}
        for section, key, lo, hi, values in key_ranges():
            num = {"type": "number", "minimum": lo, "maximum": hi}
            if values == 0:
                sections[section][key] = num
            elif values == 3:
                sections[section][key] = {"oneOf": [num, {"type": "array", "items": num, "minItems": 3,
                                                          "maxItems": 3}]}
            else:  # six angles or a 3x3 list with a zero diagonal
                sections[section][key] = {"type": "array"}
        for props in sections.values():
            props["bias_instability_tau_s"] = {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0},
                                               "minItems": 2, "maxItems": 2}
        return {"type": "object", "description": "sensor errors (sins-sim schema imu, sensors rows)",
                "additionalProperties": False,
                "properties": {name: {"type": ["object", "null"], "additionalProperties": False, "properties": props}
                               for name, props in sections.items()}}

    def check(self, value, ctx, path):  # never reached: imu_from_dict takes the section out first
        return value


IMU_SCHEMA = Map({
    "name": Str(default="imu"),
    "description": Str(default=""),
    "suspension": Map(_suspension_fields(True), default={}),
    "drive": Map({
        **_drive_fields(True),
        "dac_rate": Num(unit="hz", **_RATE, default=72000.0, doc="plant.rate_hz / dac_rate_hz an integer"),
        "control": Str(choices=("open_loop", "closed_loop"), default="closed_loop"),
        "loop_time": Num(unit="s", min=0.001, max=1000.0, default=0.1,
                         doc="time constant of the amplitude loop (1 ms to 1000 s)"),
        "block_cycles": Num(min=1, max=10000, integer=True, default=10,
                            doc="dither cycles per amplitude measurement"),
        "modulation_depth": Num(min=0.0, max=0.5, default=0.0),
        "modulation": Str(choices=("random", "steps", "sine"), default="random",
                          doc="schedule of the amplitude modulation: a uniform draw per block (against dynamic "
                              "lock-in), a square wave or a sine of period modulation_period_s"),
        "modulation_period": Num(unit="s", min=0.01, max=1e4, default=2.0,
                                 doc="period of the steps and sine modulation schedules"),
    }, default={}, rules=(
        f"the drive voltage that holds the amplitude at resonance (eq. 17) must be <= {_ranges.V_MAX:g} V (a piezo "
        f"stack); above {_ranges.V_TYPICAL_MAX:g} V a warning",
        f"the mechanical Q at the amplitude must lie in [{_ranges.Q_RANGE[0]:g}, {_ranges.Q_RANGE[1]:g}]",
    )),
    "plant": Map({
        "rate": Num(unit="hz", **_RATE, default=72000.0, doc="integration and readout rate"),
        "hysteresis": Str(choices=("paper", "masing"), default="paper"),
    }, default={}, rules=(f"rate_hz >= {_ranges.MIN_STEPS_PER_PERIOD} x f0_hz of every channel "
                          f"({_ranges.MIN_STEPS_PER_PERIOD} steps per dither period)",)),
    "readout": Map({
        "quantum": Num(unit="arcsec", min=_ranges.QUANTUM_REAL_RANGE_RAD[0] / ARCSEC,
                       max=_ranges.QUANTUM_REAL_RANGE_RAD[1] / ARCSEC, default=2.42 / 16,
                       doc="angle per count (2.42/16: the paper's interpolated fringe)"),
        "noise": Num(unit="arcsec", min=0.0, max=_ranges.NOISE_MAX_RAD / ARCSEC, default=0.0,
                     doc="white noise before quantisation (RMS)"),
        "output_rate": Num(unit="hz", min=100.0, max=_ranges.RATE_MAX_HZ, default=7200.0,
                           doc="filter rate; plant.rate_hz / output_rate_hz an integer, > 2 f0"),
        "anti_alias": Map({
            "cutoff": Num(unit="hz", min=0.0, min_exclusive=True, max=_ranges.RATE_MAX_HZ / 2, default=9000.0,
                          doc="< plant.rate_hz / 2"),
            "numtaps": Num(min=1, max=_ranges.MAX_NUMTAPS, integer=True, default=21, doc="odd"),
        }, default={}, allow_null=True, doc="null: no anti-alias filter"),
    }, default={}),
    "correcting": Map({"hysteresis": Str(choices=("paper", "masing"), default="paper")}, default={}),
    "eliminator": Map({
        "width": Num(unit="hz", min=1.0, max=1000.0, default=40.0,
                     doc="band centred on each channel's drive frequency, inside (0, output_rate_hz / 2)"),
        "rp": Num(unit="db", min=0.0, min_exclusive=True, max=_elim.MAX_RP_DB, default=0.1),
        "rs": Num(unit="db", min=0.0, min_exclusive=True, max=_elim.MAX_RS_DB, default=60.0, doc="> rp_db"),
    }, default={}),
    "channels": Map({
        axis: Map({
            "f0": Num(unit="hz", min=_F0[0], max=_F0[1], required=True,
                      doc=f"small-amplitude resonance; usual {_ranges.F0_TYPICAL_HZ[0]:g}-{_ranges.F0_TYPICAL_HZ[1]:g} Hz "
                          "(outside: a warning)"),
            "suspension": Map(_suspension_fields(False), default={}, doc="overrides of the shared suspension"),
            "drive": Map(_drive_fields(False), default={}, doc="overrides of the shared drive"),
        }, required=True) for axis in ("x", "y", "z")
    }, required=True, rules=("the three f0_hz must differ",)),
    "effects": EffectsList(doc="axis_coupling is refused in a mission: there the axes couple through the block "
                               "as a body (block:), whose cross terms above the isolator modes it is"),
    "block": _block.BLOCK_SCHEMA,
    "pickoff": Map({
        "scale_v_per_rad_s": Num(default=1.0, nonzero=True, min=-1e6, max=1e6,
                                 doc="nominal sensitivity of each coil (V per rad/s): what the stripper believes"),
        "gain_error": Num(default=0.03, min=-1.0, min_exclusive=True, max=1.0,
                          doc="relative error of the actual sensitivity"),
        "lag": Num(unit="s", default=2e-6, min=0.0, max=1e-3, doc="first-order lag of each coil (phase error)"),
        "noise": Num(unit="v", default=5e-4, min=0.0, max=1.0,
                     doc="white noise per sample at plant.rate_hz (read at the filter rate: / sqrt(decimation))"),
        "nonlinearity_per_rad2": Num(default=0.0, min=-1e6, max=1e6,
                                     doc="sensitivity change per rad^2 of deflection (S (1 + b delta^2))"),
        "cross_coupling": ListOf(Vec(3, min=-10.0, max=10.0), min_len=3, max_len=3,
                                 default=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                                 doc="3x3 matrix C: coil i reads sum_j C_ij delta_j; default identity"),
    }, default={}, rules=("cross_coupling: condition number <= 1000 (the coils must tell the axes apart)",),
        doc="the three dither pickoffs (sins_sim.models.pickoff), sampled at the filter rate; read by lms_stripper"),
    "lms_stripper": Map({
        "mu": Num(default=0.05, min=0.0, min_exclusive=True, doc="normalised LMS step; stable for 0 < mu < 2"),
        "highpass": Num(unit="hz", default=50.0, min=0.0, min_exclusive=True,
                        doc="corner of the adaptation high-pass; < output_rate_hz / 2"),
        "adapt_band": Str(choices=("highpass", "dither"), default="highpass",
                          doc="adapt on the high-passed signals (the patent) or on band_hz around each dither"),
        "band": Num(unit="hz", default=2.0, min=0.0, min_exclusive=True, max=1000.0,
                    doc="width of each dither band-pass (adapt_band: dither)"),
        "leak": Num(unit="hz", default=0.1, min=0.0, doc="corner of the pickoff integrators; < highpass_hz"),
        "power_time": Num(unit="s", default=0.01, min=0.0, min_exclusive=True, max=100.0,
                          doc="averaging time of the regressor power"),
        "regularisation": Num(default=1e-3, min=0.0, max=1.0, doc="added to the NLMS normaliser, x mean power"),
        "hold": Num(unit="s", default=0.1, min=0.0, max=1000.0, doc="adaptation starts this long after the start"),
    }, default={}, rules=("0 < mu < 2 (normalised LMS stability bound)",),
        doc="settings of the three-axis LMS dither stripper (sins_sim.filters.lms_stripper)"),
    # parsed by their own loaders before the rest; listed here for the reference
    "filter_parameters": _fparams.FILTER_PARAMETERS_SCHEMA,
    "sensors": _SensorsReference(),
})


def _check_rates(plant_hz: float, output_hz: float, ctx: str, pre: str) -> None:
    """plant.rate_hz / readout.output_rate_hz must be a whole number (the readout keeps every n-th plant sample)."""
    ratio = plant_hz / output_hz
    n = round(ratio)
    if n >= 1 and abs(ratio - n) <= 1e-9 * ratio:
        return
    options = sorted({plant_hz / k for k in (math.floor(ratio), math.ceil(ratio)) if k >= 1})
    hint = " or ".join(f"{x:g}" for x in options)
    raise ConfigError(f"{ctx}: {pre}readout.output_rate_hz: plant.rate_hz / output_rate_hz must be a whole number "
                      f"(the readout keeps every n-th plant sample), got {plant_hz:g} / {output_hz:g} = {ratio:.6g}; "
                      f"e.g. output_rate_hz {hint} Hz, or a plant.rate_hz that is a multiple of {output_hz:g}")


#: ``imu_from_dict``'s marker for an IMU without a ``sensors:`` section (``sensors: null`` is a section).
_NO_SENSORS = object()


def parse_imu(doc: dict, ctx: str, path: str = "", base_dir=None) -> dict:
    """Check an IMU mapping's keys, units, ranges and rates (errors name ``ctx`` and the key path).

    No model is imported: the schema is built from the ranges the models declare. The result is what the plan
    builds the unit from (:func:`sins_sim.plan.imu.resolve_imu`): ``c`` (the validated mapping, SI keys),
    ``fspec`` (``filter_parameters``, :mod:`sins_sim.config.filter_params`), ``sensors`` and ``has_sensors``
    (the ``sensors:`` section, parsed by :func:`sins_sim.models.sensor_errors.sensor_params_from_dict` there),
    ``ctx``, ``path`` and ``base_dir`` (where a diagnosis file named in ``filter_parameters`` is taken from;
    default: the working directory).
    """
    pre = f"{path + '.' if path else ''}"
    fspec = _fparams.parse_filter_parameters(True, ctx, f"{pre}filter_parameters")
    if isinstance(doc, dict) and "filter_parameters" in doc:
        doc = dict(doc)
        fspec = _fparams.parse_filter_parameters(doc.pop("filter_parameters"), ctx, f"{pre}filter_parameters")
    sensors_doc = _NO_SENSORS
    if isinstance(doc, dict) and "sensors" in doc:
        doc = dict(doc)
        sensors_doc = doc.pop("sensors")
    c = validate(doc, IMU_SCHEMA, ctx, path)
    _check_rates(c["plant"]["rate_hz"], c["readout"]["output_rate_hz"], ctx, pre)
    has_sensors = sensors_doc is not _NO_SENSORS
    return {"c": c, "fspec": fspec, "sensors": sensors_doc if has_sensors else None, "has_sensors": has_sensors,
            "ctx": ctx, "path": path, "base_dir": base_dir}


def imu_from_dict(doc: dict, ctx: str, path: str = "", base_dir=None) -> ImuConfig:
    """Validate an IMU mapping and build the ImuConfig (errors name ``ctx`` and the key path).

    :func:`parse_imu` checks the keys; the plan (:func:`sins_sim.plan.imu.resolve_imu`) builds the unit,
    once the keys, types, ranges and rates are right (the models and the engine, numba and scipy, are
    imported from there on). The optional ``sensors:`` section (gyro and accelerometer errors in datasheet
    units, see :func:`sins_sim.models.sensor_errors.sensor_params_from_dict`) and ``filter_parameters``
    (what the filters believe, :mod:`sins_sim.config.filter_params`) are validated by their own
    parsers; ``base_dir`` resolves a diagnosis file named there (default: the working directory).
    """
    parsed = parse_imu(doc, ctx, path, base_dir)
    from sins_sim.plan import PlanError
    from sins_sim.plan.imu import resolve_imu

    try:
        return resolve_imu(parsed)
    except PlanError as exc:
        raise ConfigError(str(exc)) from None


def load_imu(source) -> ImuConfig:
    """Load and validate an IMU file (``configs/*.yaml``) or the same content as a mapping.

    Parameters
    ----------
    source : path or mapping
        The YAML file: suspension, drive, plant, readout, filters and per-axis channels (the keys
        carry their units; see ``configs/default-imu.yaml``); or a dict with the same keys (a
        notebook needs no file), validated the same way, its relative paths (a diagnosis file)
        taken from the working directory.

    Returns
    -------
    ImuConfig

    Raises
    ------
    ConfigError
        One line naming the file (``IMU (dict)`` for a mapping), the key path and the rule.
    """
    from collections.abc import Mapping
    from pathlib import Path

    if isinstance(source, Mapping):
        import copy

        return imu_from_dict(copy.deepcopy(dict(source)), IMU_DICT_CONTEXT, base_dir=Path.cwd())
    if not isinstance(source, (str, Path)):
        raise ConfigError(f"load_imu: expected a path or a mapping, got {type(source).__name__}")
    return imu_from_dict(load_yaml(source), str(source), base_dir=Path(source).parent)


#: How configuration errors name an IMU given as a mapping.
IMU_DICT_CONTEXT = "IMU (dict)"
