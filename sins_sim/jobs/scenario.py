"""Scenario files (``scenarios/*.yaml``): the schema and the loader.

A scenario names an IMU configuration, the mission (a site, and a trajectory of segments or
a trajectory file), the block's motion on its mounts as a list of parts that add up, the
filters to compare, navigation settings and a seed. A run is reproducible from the YAML and
the seed; :func:`sins_sim.jobs.run.run_scenario` runs it and writes the results.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sins_sim.jobs.imu import imu_from_dict, load_yaml
from sins_sim.jobs.schema import Bool, ConfigError, ListOf, Map, Num, OneOf, Str, Vec, validate
from sins_sim.simulation.sins import DEFAULT_FILTERS, SINS_FILTERS, NavSettings

__all__ = ["SCENARIO_SCHEMA", "MOTION_SCHEMA", "SEGMENT_SCHEMA", "load_scenario", "run_scenario", "Scenario"]

_POS = dict(min=0.0, min_exclusive=True)

MOTION_SCHEMA = OneOf({
    "static": Map({}),
    "constant_rate": Map({"rate": Vec(3, unit="deg_s", required=True)}),
    "turn": Map({"axis": Vec(3, required=True), "angle": Num(unit="deg", required=True),
                 "duration": Num(unit="s", required=True, **_POS), "start": Num(unit="s", min=0.0, default=0.0)}),
    "sines": Map({"amplitude": Vec(3, unit="arcmin", required=True, min=0.0),
                  "frequency": Vec(3, unit="hz", required=True, min=0.0),
                  "phase": Vec(3, unit="deg", default=[0.0, 0.0, 0.0])}),
    "coning": Map({"amplitude": Num(unit="arcmin", required=True, **_POS),
                   "frequency": Num(unit="hz", required=True, **_POS),
                   "phase": Num(unit="deg", default=90.0)}),
    "random_vibration": Map({"psd_deg2_s2_per_hz": ListOf(Vec(2, min=0.0), required=True, min_len=2,
                                           doc="[[f_hz, rate PSD (deg/s)^2/Hz], ...]"),
                             "f_lo": Num(unit="hz", required=True, **_POS),
                             "f_hi": Num(unit="hz", required=True, **_POS),
                             "axes": Vec(3, default=[1.0, 1.0, 1.0], min=0.0),
                             "method": Str(choices=("filtered_noise", "tones"), default="filtered_noise",
                                           doc="filtered_noise: streaming, never repeats (missions); tones: a "
                                               "sum of 1 Hz-spaced sines, periodic in 1 s (short runs)")}),
    "shock": Map({"axis": Vec(3, required=True), "peak_rate": Num(unit="deg_s", required=True),
                  "duration": Num(unit="ms", required=True, **_POS), "start": Num(unit="s", min=0.0, default=0.0),
                  "ring_frequency": Num(unit="hz", min=0.0, default=0.0),
                  "ring_amplitude": Num(unit="deg_s", default=0.0),
                  "ring_decay": Num(unit="ms", min=0.0, min_exclusive=True, default=5.0)}),
    "sweep": Map({"axis": Vec(3, required=True), "amplitude": Num(unit="arcmin", required=True, **_POS),
                  "f_start": Num(unit="hz", required=True, **_POS), "f_stop": Num(unit="hz", required=True, **_POS),
                  "duration": Num(unit="s", required=True, **_POS), "start": Num(unit="s", min=0.0, default=0.0),
                  "kind": Str(choices=("linear", "log"), default="linear")}),
})

LINEAR_SCHEMA = OneOf({
    "sines": Map({"amplitude": Vec(3, unit="m_s2", required=True, min=0.0),
                  "frequency": Vec(3, unit="hz", required=True, min=0.0),
                  "phase": Vec(3, unit="deg", default=[0.0, 0.0, 0.0])}),
    "random": Map({"psd_g2_per_hz": ListOf(Vec(2, min=0.0), required=True, min_len=2,
                                           doc="[[f_hz, acceleration PSD g^2/Hz], ...]"),
                   "f_lo": Num(unit="hz", required=True, **_POS),
                   "f_hi": Num(unit="hz", required=True, **_POS),
                   "axes": Vec(3, default=[1.0, 1.0, 1.0], min=0.0)}),
})

SEGMENT_SCHEMA = OneOf({
    "stationary": Map({"duration": Num(unit="s", required=True, **_POS)}),
    "cruise": Map({"duration": Num(unit="s", required=True, **_POS)}),
    "accelerate": Map({"duration": Num(unit="s", required=True, **_POS),
                       "delta_speed": Num(unit="m_s", required=True)}),
    "turn": Map({"duration": Num(unit="s", required=True, **_POS),
                 "heading_change": Num(unit="deg", required=True)}),
    "climb": Map({"duration": Num(unit="s", required=True, **_POS),
                  "delta_height": Num(unit="m", required=True)}),
})

SITE_SCHEMA = Map({
    "lat": Num(unit="deg", min=-89.0, max=89.0, default=45.0, doc="latitude of the start (geodetic)"),
    "lon": Num(unit="deg", min=-180.0, max=180.0, default=0.0),
    "height": Num(unit="m", min=-1000.0, max=100000.0, default=0.0, doc="above the WGS-84 ellipsoid"),
    "heading": Num(unit="deg", default=0.0, doc="from north towards east"),
}, default={})

TRAJECTORY_SCHEMA = Map({
    "speed": Num(unit="m_s", min=0.0, default=0.0, doc="speed at the start"),
    "transition": Num(unit="s", default=4.0, **_POS, doc="length of each smooth ramp of a segment"),
    "segments": ListOf(SEGMENT_SCHEMA, default=[], doc="flown in order after the start"),
    "file": Str(default="", doc="CSV or Parquet trajectory file (sins_sim/io/trajectory.py), relative to the scenario"),
}, default={})

SCENARIO_SCHEMA = Map({
    "name": Str(required=True),
    "description": Str(default=""),
    "seed": Num(integer=True, min=0, default=0),
    "duration": Num(unit="s", required=True, **_POS),
    "imu": None,  # path or mapping: checked by load_scenario
    "site": SITE_SCHEMA,
    "trajectory": TRAJECTORY_SCHEMA,
    "motion": ListOf(MOTION_SCHEMA, default=[{"type": "static"}], min_len=1),
    "linear_vibration": ListOf(LINEAR_SCHEMA, default=[], doc="the block's translational vibration (mount axes)"),
    "filters": ListOf(Str(choices=SINS_FILTERS), default=list(DEFAULT_FILTERS), min_len=1),
    "navigation": Map({
        "coning": Str(choices=("none", "two_sample", "three_sample"), default="two_sample"),
        "sculling": Str(choices=("none", "two_sample", "three_sample"), default="two_sample"),
        "start": Num(unit="s", min=0.0, default=1.0),
        "n_sub": Num(integer=True, min=1, default=1, doc="filter samples per navigation update"),
        "vertical": Str(choices=("height_aid", "free"), default="height_aid"),
        "height_aid_tau": Num(unit="s", **_POS, default=100.0),
        "accel_delay": Str(choices=("matched", "none"), default="matched"),
        "align": Num(unit="s", min=0.0, default=0.5, doc="window before start_s over which each filter's offset "
                                                           "from the truth is averaged (alignment)"),
        "timeseries_rate": Num(unit="hz", **_POS, default=None,
                               doc="stored series rate; default 10 Hz, slower for missions over 12 min "
                                   "(at most 7200 stored blocks, each with its min/max envelope)"),
        "spectrum": Num(unit="s", min=0.0, default=2.0),
    }, default={}),
    "outputs": Map({"plots": Bool(default=True), "timeseries": Bool(default=True)}, default={}),
})


class _Any:
    """Placeholder schema entry for ``imu`` (a path or a mapping, checked separately)."""

    unit = None
    default = None
    required = True

    def check(self, value, ctx, path):
        if not isinstance(value, (str, dict)):
            raise ConfigError(f"{ctx}: {path}: must be a path to an IMU file or an IMU mapping, got {value!r}")
        return value


SCENARIO_SCHEMA.fields["imu"] = _Any()


class Scenario:
    """A validated scenario: IMU, motion, filters, navigation settings, seed."""

    def __init__(self, doc: dict, ctx: str, base_dir: Path):
        c = validate(doc, SCENARIO_SCHEMA, ctx)
        self.name = c["name"]
        self.description = c["description"]
        self.seed = int(c["seed"])
        self.duration_s = c["duration_s"]
        imu = c["imu"]
        if isinstance(imu, str):
            imu_path = (base_dir / imu).resolve()
            if not imu_path.exists():
                raise ConfigError(f"{ctx}: imu: file not found: {imu_path}")
            self.imu_source = str(imu)
            self.imu = imu_from_dict(load_yaml(imu_path), f"{ctx} -> {imu_path.name}")
        else:
            self.imu_source = "inline"
            self.imu = imu_from_dict(imu, ctx, "imu")
        self.motion_spec = c["motion"]
        self.motion = _build_motion(c["motion"], self.seed, ctx)
        self.filters = tuple(dict.fromkeys(c["filters"]))
        nv = c["navigation"]
        try:
            self.nav = NavSettings(coning=nv["coning"], sculling=nv["sculling"], start_s=nv["start_s"],
                                   n_sub=nv["n_sub"], vertical=nv["vertical"],
                                   height_aid_tau_s=nv["height_aid_tau_s"], accel_delay=nv["accel_delay"], align_s=nv["align_s"],
                                   timeseries_rate_hz=nv["timeseries_rate_hz"], spectrum_s=nv["spectrum_s"])
        except ValueError as exc:
            raise ConfigError(f"{ctx}: {exc}") from None
        if self.nav.start_s >= self.duration_s:
            raise ConfigError(f"{ctx}: navigation.start_s: must be < duration_s = {self.duration_s:g}, "
                              f"got {self.nav.start_s:g}")
        self.site = c["site"]
        self.trajectory_spec = c["trajectory"]
        self.vehicle = _build_vehicle(c["site"], c["trajectory"], self.duration_s, ctx, base_dir)
        self.events = _events(c["motion"], self.vehicle)
        self.translation = _build_translation(c["linear_vibration"], self.seed, ctx)
        self.outputs = c["outputs"]


def _build_motion(segments, seed, ctx):
    from sins_sim.models import motion as m3

    parts = []
    for i, seg in enumerate(segments):
        kind = seg["type"]
        path = f"motion[{i}]"
        try:
            if kind == "static":
                part = m3.Static()
            elif kind == "constant_rate":
                part = m3.ConstantRate(rate_rad_s=np.array(seg["rate_rad_s"]))
            elif kind == "turn":
                part = m3.Turn(axis=np.array(seg["axis"]), angle_rad=seg["angle_rad"],
                               duration_s=seg["duration_s"], start_s=seg["start_s"])
            elif kind == "sines":
                part = m3.AxisSines(amplitude_rad=np.array(seg["amplitude_rad"]),
                                    frequency_hz=np.array(seg["frequency_hz"]), phase_rad=np.array(seg["phase_rad"]))
            elif kind == "coning":
                part = m3.Coning(amplitude_rad=seg["amplitude_rad"], frequency_hz=seg["frequency_hz"],
                                 phase_rad=seg["phase_rad"])
            elif kind == "random_vibration":
                table = [(f, p * (math.pi / 180.0) ** 2) for f, p in seg["psd_deg2_s2_per_hz"]]  # (deg/s)^2/Hz -> (rad/s)^2/Hz
                cls = m3.FilteredNoiseVibration if seg["method"] == "filtered_noise" else m3.RandomVibration
                part = cls(psd_table=tuple(table), f_lo_hz=seg["f_lo_hz"], f_hi_hz=seg["f_hi_hz"],
                           axis_weights=tuple(seg["axes"]), seed=seed + 1000 * (i + 1))
            elif kind == "shock":
                part = m3.Shock(axis=np.array(seg["axis"]), peak_rate_rad_s=seg["peak_rate_rad_s"],
                                duration_s=seg["duration_s"], start_s=seg["start_s"],
                                ring_frequency_hz=seg["ring_frequency_hz"] or None,
                                ring_amplitude_rad_s=seg["ring_amplitude_rad_s"], ring_decay_s=seg["ring_decay_s"])
            else:  # sweep (the schema admits no other type)
                part = m3.RateTableSweep(axis=np.array(seg["axis"]), amplitude_rad=seg["amplitude_rad"],
                                         f_start_hz=seg["f_start_hz"], f_stop_hz=seg["f_stop_hz"],
                                         duration_s=seg["duration_s"], start_s=seg["start_s"], kind=seg["kind"])
        except ValueError as exc:
            raise ConfigError(f"{ctx}: {path}: {exc}") from None
        parts.append(part)
    motion = parts[0]
    for part in parts[1:]:
        motion = motion + part
    return motion


def _build_translation(segments, seed, ctx):
    """The block's translational vibration (None when there is none)."""
    from sins_sim.models import motion as m3

    parts = []
    for i, seg in enumerate(segments):
        try:
            if seg["type"] == "sines":
                parts.append(m3.LinearSines(tuple(seg["amplitude_m_s2"]), tuple(seg["frequency_hz"]),
                                            tuple(seg["phase_rad"])))
            else:
                parts.append(m3.LinearRandomVibration(psd_table=tuple(tuple(r) for r in seg["psd_g2_per_hz"]),
                                                      f_lo_hz=seg["f_lo_hz"], f_hi_hz=seg["f_hi_hz"],
                                                      axis_weights=tuple(seg["axes"]), seed=seed + 5000 + 1000 * i))
        except ValueError as exc:
            raise ConfigError(f"{ctx}: linear_vibration[{i}]: {exc}") from None
    if not parts:
        return None
    total = parts[0]
    for part in parts[1:]:
        total = total + part
    return total


def _build_vehicle(site, spec, duration_s, ctx, base_dir):
    """The vehicle: a trajectory file, segments after the start, or at rest at the site."""
    from sins_sim.models.motion import trajectory as tj

    try:
        if spec["file"]:
            from sins_sim.io.trajectory import read_trajectory

            path = (base_dir / spec["file"]).resolve()
            data = read_trajectory(path)
            vehicle = tj.SampledTrajectory.from_data(data)
            where = f"trajectory.file ({spec['file']})"
        else:
            segs = []
            for seg in spec["segments"]:
                kind = seg["type"]
                if kind == "stationary":
                    segs.append(tj.Stationary(seg["duration_s"]))
                elif kind == "cruise":
                    segs.append(tj.Cruise(seg["duration_s"]))
                elif kind == "accelerate":
                    segs.append(tj.Accelerate(seg["duration_s"], seg["delta_speed_m_s"]))
                elif kind == "turn":
                    segs.append(tj.CoordinatedTurn(seg["duration_s"], seg["heading_change_rad"]))
                else:
                    segs.append(tj.Climb(seg["duration_s"], seg["delta_height_m"]))
            flown = sum(sg.duration_s for sg in segs)
            tail = duration_s + 1.0 - flown  # after the last segment the vehicle holds its state
            if tail > 0:
                segs.append(tj.Stationary(tail) if _ends_at_rest(spec, segs) else tj.Cruise(tail))
            vehicle = tj.Trajectory(site["lat_rad"], site["lon_rad"], site["height_m"], spec["speed_m_s"],
                                    site["heading_rad"], tuple(segs), transition_s=spec["transition_s"])
            where = "trajectory"
    except ValueError as exc:
        raise ConfigError(f"{ctx}: trajectory: {exc}") from None
    if vehicle.duration_s < duration_s + 0.1:
        raise ConfigError(f"{ctx}: duration_s: must be <= the {where}'s length {vehicle.duration_s:g} s minus "
                          f"0.1 s, got {duration_s:g}")
    return vehicle


def _ends_at_rest(spec, segs) -> bool:
    speed = spec["speed_m_s"]
    for sg in segs:
        speed += getattr(sg, "delta_speed_m_s", 0.0)
    return abs(speed) < 1e-9


def _events(motion_spec, vehicle):
    """Shocks and block turns of the motion list, for the step and scale-factor metrics."""
    out = []
    for seg in motion_spec:
        if seg["type"] == "shock":
            out.append({"kind": "shock", "start_s": seg["start_s"], "end_s": seg["start_s"] + seg["duration_s"]})
        elif seg["type"] == "turn":
            ax = np.asarray(seg["axis"], dtype=float)
            out.append({"kind": "turn", "start_s": seg["start_s"], "end_s": seg["start_s"] + seg["duration_s"],
                        "angle_rad": seg["angle_rad"], "axis_body": (ax / np.linalg.norm(ax)).tolist()})
    return out


def load_scenario(path, overrides: dict | None = None) -> Scenario:
    """Read and validate a scenario file (errors name the file, the key path and the rule).

    ``overrides`` replaces top-level keys before validation (``{"seed": 3, "duration_s": 60}``,
    from the command line), so an override is checked like the file's own value.
    """
    path = Path(path)
    doc = load_yaml(path)
    if overrides:
        doc = dict(doc)
        for key, value in overrides.items():
            if key not in ("seed", "duration_s"):
                raise ConfigError(f"{path}: {key}: cannot be overridden (allowed: seed, duration_s)")
            doc[key] = value
    return Scenario(doc, str(path), path.parent)


from sins_sim.jobs.run import run_scenario  # noqa: E402  (the run job re-exported where it always was)
