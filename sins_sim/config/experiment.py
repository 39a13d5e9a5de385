"""Experiment files (``sins-sim simulate-recording SPEC.yaml``): the schema and the loader.

An experiment file describes a bench recording to simulate; :func:`experiment_from_dict` validates it, and the
plan (:func:`sins_sim.plan.experiment.resolve_experiment`) builds the engine's inputs
(:mod:`sins_sim.simulation.experiment`); the command
(:func:`sins_sim.jobs.recording_jobs.simulate_recording`) writes the recording.

Experiment YAML (units in the key names; every key optional except ``experiment`` and ``duration_s``; a
documented example ships as ``scenarios/experiments/experiment-example.yaml``)::

    experiment: stationary          # stationary | afc_sweep | rate_table
    description: "bench run 3"      # written to the recording
    axes: [x, y, z]                 # 1 to 3 names, default [x]
    duration_s: 2.0
    seed: 0                         # readout noise and the random perturbation
    fs_hz: 7200                     # readout rate
    drive_fs_hz: 7200               # drive update rate (a multiple of fs_hz), default fs_hz
    plant_rate_hz: 72000            # truth simulation rate (a multiple of drive_fs_hz)
    integrator: exact               # exact | rk4
    hysteresis: paper               # paper | masing
    quantum_arcsec: 0.15125         # readout quantum (2.42/16 arcsec)
    noise_arcsec: 0.0               # white readout noise before quantisation
    initial_state: rest             # rest | unknown (the recording starts after preroll_s)
    preroll_s: 1.0
    amplitude_arcmin: 3.0           # dither amplitude the drive is set up for (from the nominal parameters)
    nominal:                        # per axis, as in configs/*.yaml; defaults: the paper, f0 386/352/421 Hz
      x: {f0_hz: 386, k1: 1.75e-4, k2_rad: 1.05e-3, k3: 4.4e-3, k4_per_rad: 250, k5_rad_per_v: -1.2e-5}
    perturb: {f0: 0.002, k: 0.05}   # the unit differs from nominal: relative std, seeded
    truth:                          # or explicitly (overrides the perturbation), per axis
      x: {f0_hz: 386.6}
    afc: {voltage_factors: [0.5, 0.75, 1.0, 1.25], frequency_offsets_hz: [-3, -1.5, 0, 1.5, 3], dwell_s: 0.25}
    rate_table:                     # the table's angle about every axis listed (default all)
      rate_deg_s: 10
      sines: [{amplitude_arcmin: 30, frequency_hz: 7}, {amplitude_arcmin: 3, frequency_hz: 80, phase_deg: 60}]
      axes: [x]
    site:                           # where the bench stands: the gyros read the Earth's rate (default: none)
      latitude_deg: 56.8
      orientation_ned: {heading_deg: 304, pitch_deg: -0.7, roll_deg: 1.1}   # x, y, z against NED, 3-2-1
      table_axis_ned: [0.6, 0, 0.8]   # rate_table: the axis it turns about (unit vector, NED)
    effects:                        # catalogue effects (sins_sim.models.effects), SI parameters
      - {name: piezo_lag, tau_s: 1.0e-4, axes: [x]}
      - {name: axis_coupling, coefficients: {x: {y: 0.01}}}

With ``site`` the axes are named from ``x, y, z`` (the triad the orientation places), every gyro reads the
Earth's rate ``C_nb^T Omega (cos lat, 0, -sin lat)`` (:mod:`sins_sim.simulation.site`), and the recording's
header carries ``site``; a ``rate_table`` then turns about ``table_axis_ned`` and each gyro sees the table's
angle projected on its axis (``rate_table.axes`` is not used).

The drive runs at the amplitude-dependent resonance of the *nominal* suspension with eq. 17's voltage
(stationary, rate_table) or steps through the AFC plan (afc_sweep), as an engineer would set it up.
"""

from __future__ import annotations

from sins_sim.config.effects_schema import EffectsList
from sins_sim.config.errors import ConfigError
from sins_sim.config.schema import ListOf, Map, Num, Str, validate

__all__ = ["EXPERIMENT_SCHEMA", "DEFAULT_F0_HZ", "MAX_EXPERIMENT_S", "MAX_EXPERIMENT_STEPS", "SUSPENSION_YAML_KEYS",
           "experiment_from_dict"]

#: Default small-amplitude resonances per axis (docs/user-guide/block.md: 300-450 Hz, all different).
DEFAULT_F0_HZ = {"x": 386.0, "y": 352.0, "z": 421.0}
_POS = dict(min=0.0, min_exclusive=True)


def _suspension_fields():
    from sins_sim.models import suspension as sus

    k5 = sus.K5_RANGE_RAD_PER_V[1]
    return {
        "f0": Num(unit="hz", min=sus.F0_RANGE_HZ[0], max=sus.F0_RANGE_HZ[1]),
        "k1": Num(min=0.0, max=sus.K1_MAX),
        "k2": Num(unit="rad", min=sus.K2_RANGE_RAD[0], max=sus.K2_RANGE_RAD[1]),
        "k3": Num(min=0.0, max=sus.K3_MAX),
        "k4": Num(unit="per_rad", min=sus.K4_MIN_PER_RAD, max=sus.K4_MAX_PER_RAD),
        "k5": Num(unit="rad_per_v", min=-k5, max=k5, nonzero=True),
        "zeta": Num(min=0.0, max=sus.ZETA_MAX),
    }


#: Longest experiment (s): the simulator keeps the whole record at the plant rate in memory (about 60 B per
#: plant step and axis: 13 MB per second for 3 axes at 72 kHz); bench experiments last seconds to minutes.
MAX_EXPERIMENT_S = 300.0
#: Most plant steps x axes an experiment may hold (about 4 GB at 60 B each).
MAX_EXPERIMENT_STEPS = 6.5e7


class _PerAxis:
    """A mapping axis name -> suspension overrides (axis names are free)."""

    unit = None
    default = None
    required = False

    def __init__(self):
        self.item = Map(_suspension_fields())

    def describe_rows(self, path):
        from sins_sim.config.schema import describe

        head = {"key": path, "kind": "mapping", "unit": "", "range": "axis name -> parameters", "default": "(none)",
                "doc": "per axis (a name of axes), the suspension keys of the IMU format"}
        return [head] + describe(self.item, f"{path}.AXIS")

    def json_schema(self):
        from sins_sim.config.schema import json_schema

        return {"type": "object", "additionalProperties": json_schema(self.item),
                "description": "per axis (a name of axes), the suspension keys of the IMU format"}

    def check(self, value, ctx, path):
        if not isinstance(value, dict):
            raise ConfigError(f"{ctx}: {path}: must be a mapping axis -> parameters, got {value!r}")
        return {str(k): self.item.check(v, ctx, f"{path}.{k}") for k, v in value.items()}


_RATE = dict(min=100.0, max=1.0e6)
EXPERIMENT_SCHEMA = Map({
    "name": Str(default=""),
    "experiment": Str(choices=("stationary", "afc_sweep", "rate_table"), required=True),
    "description": Str(default=""),
    "axes": ListOf(Str(), default=["x"], min_len=1, max_len=3, doc="1 to 3 distinct names"),
    "duration": Num(unit="s", required=True, **_POS, max=MAX_EXPERIMENT_S),
    "seed": Num(integer=True, min=0, max=2 ** 32 - 1, default=0),
    "fs": Num(unit="hz", default=7200.0, **_RATE, doc="readout rate"),
    "drive_fs": Num(unit="hz", **_RATE, doc="drive update rate, a multiple of fs_hz (default fs_hz)"),
    "plant_rate": Num(unit="hz", default=72000.0, min=1.0e3, max=1.0e6,
                      doc="truth simulation rate, a multiple of drive_fs_hz, >= 40 f0"),
    "integrator": Str(choices=("exact", "rk4"), default="exact"),
    "hysteresis": Str(choices=("paper", "masing"), default="paper"),
    "quantum": Num(unit="arcsec", default=2.42 / 16.0, min=0.001, max=60.0),
    "noise": Num(unit="arcsec", min=0.0, max=60.0, default=0.0),
    "initial_state": Str(choices=("rest", "unknown"), default="rest"),
    "preroll": Num(unit="s", min=0.0, max=60.0, default=1.0, doc="simulated before the record (initial_state: "
                                                                 "unknown)"),
    "amplitude": Num(unit="arcmin", default=3.0, min=0.01, max=60.0, doc="dither amplitude the drive is set up for"),
    "nominal": _PerAxis(),
    "truth": _PerAxis(),
    "perturb": Map({"f0": Num(min=0.0, max=0.05, default=0.0), "k": Num(min=0.0, max=0.5, default=0.0)},
                   default={}, doc="relative std of the unit's difference from nominal (seeded)"),
    "afc": Map({
        "voltage_factors": ListOf(Num(**_POS, max=10.0), default=[0.5, 0.75, 1.0, 1.25], min_len=1, max_len=100),
        "frequency_offsets_hz": ListOf(Num(min=-100.0, max=100.0), default=[-3.0, -1.5, 0.0, 1.5, 3.0], min_len=1,
                                       max_len=100),
        "dwell": Num(unit="s", default=0.25, **_POS, max=60.0),
    }, default={}),
    "rate_table": Map({
        "rate": Num(unit="deg_s", default=10.0, min=-1000.0, max=1000.0),
        "sines": ListOf(Map({"amplitude": Num(unit="arcmin", required=True, min=0.0, max=600.0),
                             "frequency": Num(unit="hz", required=True, **_POS, max=5.0e5, doc="< fs_hz / 2"),
                             "phase": Num(unit="deg", default=0.0, min=-360.0, max=360.0)}),
                        max_len=100,
                        default=[{"amplitude_arcmin": 30.0, "frequency_hz": 7.0},
                                 {"amplitude_arcmin": 3.0, "frequency_hz": 80.0, "phase_deg": 60.0},
                                 {"amplitude_arcmin": 1.0, "frequency_hz": 230.0, "phase_deg": 120.0}]),
        "axes": ListOf(Str(), min_len=1),
    }, default={}),
    "site": Map({
        "latitude": Num(unit="deg", required=True, min=-90.0, max=90.0),
        "orientation_ned": Map({"heading": Num(unit="deg", default=0.0, min=-360.0, max=360.0),
                                "pitch": Num(unit="deg", default=0.0, min=-90.0, max=90.0),
                                "roll": Num(unit="deg", default=0.0, min=-180.0, max=180.0)}, default={}),
        "table_axis_ned": ListOf(Num(min=-1.0, max=1.0), min_len=3, max_len=3, doc="unit vector, NED"),
    }, doc="the bench's latitude and the unit's orientation (the gyros read the Earth's rate)"),
    "effects": EffectsList(axes=None, catalogue_only=False,
                           doc="the off-catalogue disturbances mains_pickup, drive_harmonic, mount_mode and bias_drift too"),
}, rules=(f"(duration_s + preroll_s) x plant_rate_hz x axes <= {MAX_EXPERIMENT_STEPS:.3g} plant steps (memory)",
          "plant_rate_hz >= 40 x f0_hz of every axis; rate_table sines below fs_hz / 2 and their peak rate "
          "<= 1000 deg/s"))

#: the suspension keys of the YAML formats -> the SuspensionParams fields
SUSPENSION_YAML_KEYS = {"f0_hz": "f0_hz", "k1": "k1", "k2_rad": "k2", "k3": "k3", "k4_per_rad": "k4", "k5_rad_per_v": "k5",
              "zeta": "zeta"}


def experiment_from_dict(doc: dict, ctx: str = "experiment") -> dict:
    """Validate an experiment mapping and build everything :func:`sins_sim.jobs.recording_jobs.simulate_recording` needs.

    Returns a dict with ``inputs`` (ExperimentInputs, pre-roll included), ``truth`` and ``nominal``
    (axis -> SuspensionParams), ``effects``, ``settings``, ``quantum_rad``, ``noise_rad``, ``seed``,
    ``preroll_samples``, ``experiment``, ``description`` and ``points`` (AFC plan).

    Raises
    ------
    ConfigError
        Naming ``ctx``, the key path and the rule.
    """
    c = validate(doc, EXPERIMENT_SCHEMA, ctx)
    axes = list(c["axes"])
    if len(axes) > 3 or len(set(axes)) != len(axes):
        raise ConfigError(f"{ctx}: axes: must be 1 to 3 distinct names, got {axes!r}")
    for key in ("nominal", "truth"):
        for a in c[key] or {}:
            if a not in axes:
                raise ConfigError(f"{ctx}: {key}.{a}: is not one of axes {axes}")
    from sins_sim.plan import PlanError
    from sins_sim.plan.experiment import resolve_experiment

    # the file's suspension keys -> the model's fields; the rest needs the physics (the plan)
    overrides = {key: {a: {SUSPENSION_YAML_KEYS[k]: float(v) for k, v in (over or {}).items() if v is not None}
                       for a, over in (c[key] or {}).items()} for key in ("nominal", "truth")}
    f0_default_hz = {a: DEFAULT_F0_HZ.get(a, 386.0 - 17.0 * i) for i, a in enumerate(axes)}
    try:
        return resolve_experiment(c, overrides, f0_default_hz, doc.get("site"), MAX_EXPERIMENT_STEPS, ctx)
    except PlanError as exc:
        raise ConfigError(str(exc)) from None
