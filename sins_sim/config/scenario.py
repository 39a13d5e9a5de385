"""Scenario files (``scenarios/*.yaml``): the schema and the loader.

A scenario names an IMU configuration, the mission (a site, and a trajectory of segments or
a trajectory file), the block's motion on its mounts as a list of parts that add up, the
filters to compare, navigation settings and a seed. A run is reproducible from the YAML and
the seed. This module checks a scenario's keys, units and ranges; :class:`Scenario` then has the plan
(:func:`sins_sim.plan.resolve_plan`) resolve what needs the physics, and holds the :class:`~sins_sim.plan.Plan`
the engine takes (an :class:`~sins_sim.simulation.sins.ImuConfig`, :class:`~sins_sim.simulation.sins.NavSettings`,
the motion, the vehicle, the filters); the commands above run it (``sins-sim run``, :func:`sins_sim.run_scenario`).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

from sins_sim.config import filter_params as _fparams
from sins_sim.config import vibration_spec as _vspec
from sins_sim.config.errors import ConfigError, alias_marks, forget_mark
from sins_sim.config.schema import Bool, ListOf, Map, Num, OneOf, Str, Vec, validate
from sins_sim.config.yaml_io import load_yaml
from sins_sim.filters import registry as filter_registry

# The scenario's own schema needs no model, engine or numba: a scenario file is checked before those are
# imported (they are imported where the IMU, the motion and the navigation are built), so a configuration
# error is reported in well under 2 s (issue 22, point 8).
SINS_FILTERS = filter_registry.BUILTIN_FILTERS
DEFAULT_FILTERS = filter_registry.DEFAULT_FILTERS

__all__ = ["SCENARIO_SCHEMA", "MOTION_SCHEMA", "SEGMENT_SCHEMA", "load_scenario", "scenario_document", "Scenario"]

_POS = dict(min=0.0, min_exclusive=True)

# --- ranges (issue 12, points 3 and 4) -------------------------------------------------------------------
#: Longest mission (s): sample indices at the plant rate (at most 1 MHz) stay exact float64 integers
#: (< 2^53), so every time t = k / rate the engine forms is exact. Whether a run that long can finish is
#: the estimate's business (sins_sim.jobs.estimate refuses runs above 48 h of wall time).
MAX_DURATION_S = 2.0 ** 53 / 1.0e6
#: Block rates (deg/s): the input range of navigation-grade RLGs is +-400 to +-1000 deg/s. A block motion
#: part whose peak rate exceeds 1000 deg/s is refused.
MAX_RATE_DEG_S = 1000.0
#: Angular vibration amplitudes (arcmin): a block on its isolators moves by arcminutes; 10 deg would tear them.
MAX_ANGLE_ARCMIN = 600.0
#: Frequencies (Hz): the schema's ceiling is the highest plant Nyquist (1 MHz / 2); the loader then requires
#: every block and translational motion frequency to lie below the filter Nyquist (readout.output_rate_hz / 2,
#: 3.6 kHz by default): the filters, the truth they are compared with and the navigation all run at the filter
#: rate, so a motion above it aliases into the navigation band. Above NEAR_NYQUIST of it: a warning.
MAX_FREQUENCY_HZ = 5.0e5
NEAR_NYQUIST = 0.8
#: Phases (deg): one turn either way.
_PHASE = dict(min=-360.0, max=360.0)
#: Rate PSD of angular random vibration ((deg/s)^2/Hz): 1e-6 is a unit on isolators in a running vehicle;
#: 1 (deg/s)^2/Hz over 2 kHz would be 45 deg/s RMS, beyond any mount.
MAX_RATE_PSD = 1.0
#: Acceleration PSD (g^2/Hz): 10 g^2/Hz over 2 kHz is 141 g RMS, beyond any qualification test.
MAX_ACCEL_PSD = 10.0
#: Translational vibration amplitude (m/s^2): 2000 m/s^2 is about 200 g.
MAX_ACCEL_M_S2 = 2000.0
#: Vehicle speed (m/s) and heights (m): the trajectory file format's limits (sins_sim.io.trajectory).
MAX_SPEED_M_S = 3000.0
#: Stored error series: at most this many blocks per filter (~360 B each), and spectra of at most 600 s
#: (the full-rate gyro error of every filter is kept in memory: 7.2 kHz x 600 s x 24 B = 100 MB per filter).
MAX_SPECTRUM_S = 600.0
#: The alignment methods (the names of ``sins_sim.navigation.alignment_result.ALIGNMENT_METHODS``, written here so
#: that loading a scenario imports neither the navigation package nor numba; tests/test_mission_alignment.py checks
#: that the two agree).
ALIGNMENT_METHODS = ("truth", "coarse", "inertial", "kalman")
_DUR = dict(min=0.0, min_exclusive=True, max=MAX_DURATION_S)
_START = dict(min=0.0, max=MAX_DURATION_S)
_FREQ_RULE = (f"every frequency must be < the filter Nyquist (readout.output_rate_hz / 2 of the IMU, 3600 Hz by "
              f"default); above {NEAR_NYQUIST:g} of it a warning")
_RATE_RULE = f"the part's peak rate must be <= {MAX_RATE_DEG_S:g} deg/s"
_AXES_RULE = "axes not all zero (all zero makes no motion)"
_SHOCK_RULE = ("duration_ms >= 3 plant steps, 3000 / plant.rate_hz ms (0.042 ms at 72 kHz): the half-sine's main "
               "lobe, up to 1.5 / duration, below the plant's Nyquist")


#: sins_sim.models.motion.vibration.GENERATORS, written out so that parsing a file stays light (no numba;
#: tests/test_vibration_generators.py checks that the two agree)
GENERATORS = ("decimated_noise", "node_rate_noise")
_GENERATOR = Str(choices=GENERATORS, default=GENERATORS[0],
                 doc="filtered-noise generator: decimated_noise (white noise below the node rate, zero-stuffed; "
                     "cheaper) or node_rate_noise (the sequences of versions before 2026-11); same PSD")


def _psd_row(max_psd, unit_doc):
    return Vec(2, items=(Num(min=0.0, min_exclusive=True, max=MAX_FREQUENCY_HZ),
                         Num(min=0.0, min_exclusive=True, max=max_psd)),
               doc=f"[f_hz, {unit_doc}]")


#: Coning/sculling choices (``sins_sim.navigation.coning.CONING_ALGORITHMS`` and ``filter_tuned``, the
#: engine's ``NAV_ALGORITHMS``; spelled out so that a scenario is checked before the engine is imported).
NAV_ALGORITHMS = ("none", "two_sample", "three_sample", "four_sample", "filter_tuned")

MOTION_SCHEMA = OneOf({
    "static": Map({}, doc="no block motion"),
    "constant_rate": Map({"rate": Vec(3, unit="deg_s", required=True, min=-MAX_RATE_DEG_S, max=MAX_RATE_DEG_S,
                                      doc="body rate about x, y, z")}, doc="a steady rotation of the block"),
    "turn": Map({"axis": Vec(3, required=True, min=-1.0e6, max=1.0e6, doc="body axis (normalised; not zero)"),
                 "angle": Num(unit="deg", required=True, min=-36000.0, max=36000.0),
                 "duration": Num(unit="s", required=True, **_DUR),
                 "start": Num(unit="s", default=0.0, **_START)},
                doc="a turn by angle about a fixed axis, raised-cosine rate (peak 2 angle / duration)"),
    "sines": Map({"amplitude": Vec(3, unit="arcmin", required=True, min=0.0, max=MAX_ANGLE_ARCMIN),
                  "frequency": Vec(3, unit="hz", required=True, min=0.0, max=MAX_FREQUENCY_HZ),
                  "phase": Vec(3, unit="deg", default=[0.0, 0.0, 0.0], **_PHASE)},
                 doc="per-axis sinusoidal gyro angles (peak rate 2 pi f A)"),
    "coning": Map({"amplitude": Num(unit="arcmin", required=True, **_POS, max=MAX_ANGLE_ARCMIN),
                   "frequency": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                   "phase": Num(unit="deg", default=90.0, **_PHASE, doc="+90 or -90 (a circular cone)")},
                  doc="classic coning about z (peak rate 2 pi f A)"),
    "random_vibration": Map({"psd_deg2_s2_per_hz": ListOf(_psd_row(MAX_RATE_PSD, "rate PSD (deg/s)^2/Hz"),
                                                           required=True, min_len=2, max_len=1000,
                                                           doc="[[f_hz, rate PSD (deg/s)^2/Hz], ...], f increasing"),
                             "f_lo": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                             "f_hi": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                             "axes": Vec(3, default=[1.0, 1.0, 1.0], min=0.0, max=10.0),
                             "method": Str(choices=("filtered_noise", "tones"), default="filtered_noise",
                                           doc="filtered_noise: streaming, never repeats (missions); tones: a "
                                               "sum of 1 Hz-spaced sines, periodic in 1 s (short runs)"),
                             "generator": _GENERATOR},
                            doc="band-limited angular random vibration, log-log interpolated PSD"),
    "shock": Map({"axis": Vec(3, required=True, min=-1.0e6, max=1.0e6, doc="body axis (normalised; not zero)"),
                  "peak_rate": Num(unit="deg_s", required=True, min=-MAX_RATE_DEG_S, max=MAX_RATE_DEG_S),
                  "duration": Num(unit="ms", required=True, **_POS, max=1000.0),
                  "start": Num(unit="s", default=0.0, **_START),
                  "ring_frequency": Num(unit="hz", min=0.0, max=MAX_FREQUENCY_HZ, default=0.0,
                                        doc="0: no ringing"),
                  "ring_amplitude": Num(unit="deg_s", default=0.0, min=-MAX_RATE_DEG_S, max=MAX_RATE_DEG_S),
                  "ring_decay": Num(unit="ms", min=0.0, min_exclusive=True, max=1.0e4, default=5.0)},
                 doc="a half-sine rate pulse, optionally ringing afterwards"),
    "sweep": Map({"axis": Vec(3, required=True, min=-1.0e6, max=1.0e6, doc="body axis (normalised; not zero)"),
                  "amplitude": Num(unit="arcmin", required=True, **_POS, max=MAX_ANGLE_ARCMIN),
                  "f_start": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                  "f_stop": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                  "duration": Num(unit="s", required=True, **_DUR), "start": Num(unit="s", default=0.0, **_START),
                  "kind": Str(choices=("linear", "log"), default="linear")},
                 doc="a rate-table sine sweep (peak rate 2 pi f A)"),
}, rules={
    "constant_rate": (),
    "turn": (_RATE_RULE,),
    "sines": (_FREQ_RULE, _RATE_RULE),
    "coning": (_FREQ_RULE, _RATE_RULE),
    "random_vibration": (_FREQ_RULE, "f_lo_hz < f_hi_hz, both inside the table", _AXES_RULE),
    "shock": ("ring_frequency_hz: " + _FREQ_RULE, "ring_frequency_hz > 0 when ring_amplitude_deg_s != 0",
              _SHOCK_RULE),
    "sweep": (_FREQ_RULE, _RATE_RULE),
})

LINEAR_SCHEMA = OneOf({
    "sines": Map({"amplitude": Vec(3, unit="m_s2", required=True, min=0.0, max=MAX_ACCEL_M_S2,
                                   doc="0 leaves an axis still"),
                  "frequency": Vec(3, unit="hz", required=True, min=0.0, min_exclusive=True, max=MAX_FREQUENCY_HZ),
                  "phase": Vec(3, unit="deg", default=[0.0, 0.0, 0.0], **_PHASE)},
                 doc="per-axis sinusoidal acceleration"),
    "random": Map({"psd_g2_per_hz": ListOf(_psd_row(MAX_ACCEL_PSD, "acceleration PSD g^2/Hz"), required=True,
                                           min_len=2, max_len=1000,
                                           doc="[[f_hz, acceleration PSD g^2/Hz], ...], f increasing"),
                   "f_lo": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                   "f_hi": Num(unit="hz", required=True, **_POS, max=MAX_FREQUENCY_HZ),
                   "axes": Vec(3, default=[1.0, 1.0, 1.0], min=0.0, max=10.0),
                   "generator": _GENERATOR},
                  doc="band-limited random acceleration"),
}, rules={"sines": (_FREQ_RULE,), "random": (_FREQ_RULE, _AXES_RULE)})

SEGMENT_SCHEMA = OneOf({
    "stationary": Map({"duration": Num(unit="s", required=True, **_DUR)}, doc="at rest"),
    "cruise": Map({"duration": Num(unit="s", required=True, **_DUR)}, doc="straight and level at the current speed"),
    "accelerate": Map({"duration": Num(unit="s", required=True, **_DUR),
                       "delta_speed": Num(unit="m_s", required=True, min=-MAX_SPEED_M_S, max=MAX_SPEED_M_S)},
                      doc="speed change along the track"),
    "turn": Map({"duration": Num(unit="s", required=True, **_DUR),
                 "heading_change": Num(unit="deg", required=True, min=-36000.0, max=36000.0)},
                doc="a coordinated turn"),
    "climb": Map({"duration": Num(unit="s", required=True, **_DUR),
                  "delta_height": Num(unit="m", required=True, min=-101000.0, max=101000.0)},
                 doc="height change (heights stay in [-1000, 100000] m)"),
    "hover": Map({"duration": Num(unit="s", required=True, **_DUR),
                  "roll": Num(unit="deg", default=0.0, min=-30.0, max=30.0,
                              doc="roll on the plateau (+ = right wing down), eased in and out"),
                  "pitch": Num(unit="deg", default=0.0, min=-30.0, max=30.0,
                               doc="pitch on the plateau (+ = nose up), eased in and out")},
                 doc="hover at the current height: zero velocity, a small attitude (from rest)"),
    "sideways": Map({"duration": Num(unit="s", required=True, **_DUR),
                     "lateral_speed": Num(unit="m_s", required=True, min=-50.0, max=50.0,
                                          doc="speed to the right of the heading on the plateau (- = left)")},
                    doc="sideways flight from a hover back to a hover: velocity perpendicular to the heading, "
                        "the bank atan(u'/g) balancing its acceleration"),
}, rules={"hover": ("needs speed 0 at its start; with a roll or pitch it lasts at least 2 transition_s",),
          "sideways": ("needs speed 0 at its start (a hover); lasts at least 2 transition_s; the balancing bank "
                       "stays within 60 deg and its roll rate within 1000 deg/s: lengthen transition_s",),
          "climb": ("the flight-path angle asin(h'/V) stays within 60 deg (a climb needs a speed > 0; the pitch "
                    "stays away from the Euler singularity): a steeper climb is refused",),
          "turn": ("the centripetal acceleration V psi' stays <= 2000 m/s^2 (about 200 g) and the peak body rate "
                   "(heading rate and the roll rate into the coordinated bank) <= 1000 deg/s, the range of an RLG: "
                   "a sharper turn is refused",)})

SITE_SCHEMA = Map({
    "lat": Num(unit="deg", min=-89.0, max=89.0, default=45.0,
               doc="latitude of the start (geodetic); a flight must stay within 89.5 deg: the north-east-down "
                   "mechanisation's transport rate (tan lat, sec lat) is singular at the poles (Titterton & Weston "
                   "2004, sec. 3.5); polar routes need a wander-azimuth mechanisation, not modelled"),
    "lon": Num(unit="deg", min=-180.0, max=180.0, default=0.0),
    "height": Num(unit="m", min=-1000.0, max=100000.0, default=0.0, doc="above the WGS-84 ellipsoid"),
    "heading": Num(unit="deg", default=0.0, min=-360.0, max=360.0, doc="from north towards east"),
}, default={}, doc="where the mission starts")

TRAJECTORY_SCHEMA = Map({
    "speed": Num(unit="m_s", min=0.0, max=MAX_SPEED_M_S, default=0.0, doc="speed at the start"),
    "transition": Num(unit="s", default=4.0, **_POS, max=3600.0, doc="length of each smooth ramp of a segment"),
    "segments": ListOf(SEGMENT_SCHEMA, default=[], max_len=10000, doc="flown in order after the start"),
    "file": Str(default="", doc="CSV or Parquet trajectory file (format: sins-sim schema trajectory), relative to "
                                "the scenario"),
    "velocity_tolerance": Num(unit="m_s", min=1e-3, max=100.0, default=1.0,
                              doc="a file with velocity columns: largest difference of vn_m_s, ve_m_s or vd_m_s from "
                                  "the velocity of the smoothing fit of the file's positions, at any row (the truth "
                                  "is the fit of positions and velocities together; GNSS-grade noise of 0.1 m/s with "
                                  "positions to 5 decimals of a degree stays below 0.6 m/s)"),
    "extend": Str(choices=("none", "hold"), default="none",
                  doc="none: a run longer than the segments is refused; hold: after the last segment the vehicle "
                      "holds its state (at rest if it ended at rest, else straight and level at its speed) until "
                      "the run ends (segments only)"),
}, default={}, doc="how the vehicle moves (segments, or a file); without either it sits at the site",
    rules=("the trajectory must last at least duration_s + 0.1 s (segments: unless extend is hold)",
           "every segment lasts at least 2 transition_s (a smooth ramp in and one out)",
           "a file's yaw must fit its ground track and its roll its turns (a file in radians is refused)",
           "a file with velocity columns: its truth is a smoothing fit of positions and velocities (fixed-interval "
           "Rauch-Tung-Striebel smoother, constant-acceleration model; noise levels from the file, "
           "sins_sim.models.motion.smoothing), its RMS residuals are reported in metrics.json "
           "(mission.trajectory_fit) and the report; a velocity column off the positions' own fit by more than "
           "velocity_tolerance_m_s at any row is refused"))

_TEMP = dict(min=173.15, max=473.15)
_COEFF = {
    "f0": Num(unit="ppm_per_k", required=True, min=-1000.0, max=1000.0,
              doc="relative change of each channel's f0 per kelvin: f0 (1 + c (T - reference_k)); f0 ~ sqrt(E), "
                  "so about half the modulus' coefficient: spring steel -110 to -145, Elinvar / Ni-Span-C within "
                  "+-20 (sins_sim.simulation.temperature)"),
    "k_ppm_per_k": Map({name: Num(min=-1.0e4, max=1.0e4, default=0.0, doc=f"{name}, ppm/K")
                        for name in ("k1", "k2", "k3", "k4", "k5")}, default={},
                       doc="relative change of k1 .. k5 per kelvin, ppm/K (default 0: not measured; a PZT's k5 "
                           "rises by roughly 1000-3000)"),
    "reference": Num(unit="k", **_TEMP, default=None,
                     doc="the temperature at which the IMU file's f0 and k's hold (default: the profile's at t = 0)"),
    "update": Num(unit="s", min=1e-4, max=10.0, default=0.02,
                  doc="interval of the plant's parameter updates, counted from t = 0 (rounded to whole filter "
                      "samples)"),
    "isolators": Map({
        "stiffness": Num(unit="ppm_per_k", min=-1.0e4, max=1.0e4, default=0.0,
                         doc="relative change of the block's isolator stiffness (translational and rotational) per "
                             "kelvin; an entropy spring +1/T (+3400 at 293 K), filled damped elastomers fall on "
                             "warming: the mount's own curve (sins_sim.simulation.temperature); 0: held"),
        "damping": Num(unit="ppm_per_k", min=-1.0e4, max=1.0e4, default=0.0,
                       doc="relative change of the block's isolator damping per kelvin; 0: held"),
    }, default={}, doc="with an IMU block: the isolators' temperature coefficients (refused without a block)"),
}
_INITIAL = Num(unit="k", required=True, **_TEMP, doc="the temperature at t = 0")

TEMPERATURE_SCHEMA = OneOf({
    "constant": Map({"initial": _INITIAL, **_COEFF}, doc="a constant temperature (initial_k)"),
    "ramp": Map({"initial": _INITIAL, "final": Num(unit="k", required=True, **_TEMP, doc="after the ramp"),
                 "start": Num(unit="s", default=0.0, **_START, doc="when the ramp starts"),
                 "duration": Num(unit="s", required=True, **_DUR, doc="how long the ramp takes"), **_COEFF},
                doc="initial_k until start_s, linear to final_k over duration_s, then final_k"),
    "step": Map({"initial": _INITIAL, "step": Num(unit="k", required=True, min=-300.0, max=300.0, doc="the jump"),
                 "start": Num(unit="s", required=True, **_START, doc="when the temperature jumps"), **_COEFF},
                doc="initial_k, then initial_k + step_k from start_s on"),
    "table": Map({"table_s_k": ListOf(Vec(2, items=(Num(min=0.0, max=MAX_DURATION_S), Num(**_TEMP))),
                                      required=True, min_len=2, max_len=100000,
                                      doc="[[t_s, temp_k], ...], t increasing"),
                  **_COEFF}, doc="linear between the rows, held before the first and after the last"),
}, key="profile", default=None, rules={name: (
    "the profile's extremes over the mission keep every channel physical (f0 range, steps per dither period, Q, "
    "drive voltage; with filter_parameters.track the filters' f0 below the filter Nyquist)",)
    for name in ("constant", "ramp", "step", "table")})


class _FilterName(Str):
    """A filter name: built-in, shipped plug-in (the reference lists these) or registered at run time."""

    def check(self, value, ctx, path):
        if not isinstance(value, str) or not filter_registry.is_known(value):
            known = list(SINS_FILTERS + filter_registry.plugin_names())
            raise ConfigError(f"{ctx}: {path}: must be one of {known}, got {value!r}")
        return value


SCENARIO_SCHEMA = Map({
    "name": Str(required=True),
    "description": Str(default=""),
    "seed": Num(integer=True, min=0, max=2 ** 32 - 1, default=0, doc="seed of every random stream of the run"),
    "duration": Num(unit="s", required=True, **_DUR, doc="mission length"),
    "imu": None,  # path or mapping: checked by load_scenario
    "site": SITE_SCHEMA,
    "trajectory": TRAJECTORY_SCHEMA,
    "motion": ListOf(MOTION_SCHEMA, default=[{"type": "static"}], min_len=1, max_len=1000,
                     doc="the block's own motion on its mounts: parts that add up"),
    "linear_vibration": ListOf(LINEAR_SCHEMA, default=[], max_len=1000,
                               doc="the translational vibration (mount axes): the block's, or with an IMU block "
                                   "the chassis' (vibration_enters)"),
    "vibration_enters": Str(choices=("chassis", "block"), default="chassis",
                            doc="with an IMU block: chassis = linear_vibration shakes the chassis and reaches the "
                                "block through the isolators (rocking it when the elastic centre is off the c.g.); "
                                "block = it is the block's own, as without a block. Angular motion: motion_enters. "
                                "Without an IMU block: no effect"),
    "motion_enters": Str(choices=("chassis", "block"), default="chassis",
                         doc="with an IMU block: chassis = the motion profiles rotate the chassis and the block "
                             "follows through the isolators; block = they are the block's own rotation as measured "
                             "on it (as without a block), the block's response to the dithers and to what enters at "
                             "the chassis superposed (the block's model is linear). Without an IMU block: no "
                             "effect"),
    "filters": ListOf(_FilterName(choices=SINS_FILTERS + filter_registry.shipped_plugin_names()),
                      default=list(DEFAULT_FILTERS), min_len=1, max_len=20),
    "navigation": Map({
        "coning": Str(choices=NAV_ALGORITHMS, default="two_sample",
                      doc="filter_tuned: coefficients designed per filter over tuned_band_hz (Mark & Tazartes 2001)"),
        "sculling": Str(choices=NAV_ALGORITHMS, default="two_sample"),
        "tuned_band": Vec(2, unit="hz", min=0.0, min_exclusive=True, max=MAX_FREQUENCY_HZ, default=None,
                          doc="design band of filter_tuned coning/sculling; required with it, refused without it "
                              "(except under a single coning motion, where the run's coning table uses it)"),
        "start": Num(unit="s", default=1.0, **_START, doc="navigation starts aligned to the truth; < duration_s"),
        "n_sub": Num(integer=True, min=1, max=1000, default=None,
                     doc="filter samples per navigation update; default: from rate_hz"),
        "rate": Num(unit="hz", **_POS, max=1.0e6, default=None,
                    doc="navigation update rate (attitude, velocity, position); the coning and sculling sums run "
                        "at the filter rate; sets n_sub = readout.output_rate_hz / rate_hz (a whole number); "
                        "default: about 400 Hz, n_sub = round(readout.output_rate_hz / 400) (18 at 7.2 kHz); "
                        "readout.output_rate_hz for every filter sample"),
        "vertical": Str(choices=("height_aid", "free"), default="height_aid"),
        "height_aid_tau": Num(unit="s", **_POS, max=1.0e5, default=100.0),
        "accel_delay": Str(choices=("matched", "none"), default="matched"),
        "align": Num(unit="s", min=0.0, max=3600.0, default=0.5,
                     doc="window before start_s over which each filter's offset from the truth is averaged "
                         "(alignment)"),
        "timeseries_rate": Num(unit="hz", **_POS, max=1.0e6, default=None,
                               doc="stored series rate; default 10 Hz, slower for missions over 12 min "
                                   "(at most 7200 stored blocks, each with its min/max envelope)"),
        "spectrum": Num(unit="s", min=0.0, max=MAX_SPECTRUM_S, default=2.0,
                        doc="full-rate gyro-error record kept for the spectra"),
        "alignment": Map({
            "method": Str(choices=ALIGNMENT_METHODS, default="truth",
                          doc="how each filter's navigation finds its starting attitude: truth (the true attitude); "
                              "coarse (levelling and gyrocompassing, a still base only); inertial (inertial-frame, "
                              "robust to sway); kalman (fine alignment by the error-state filter with zero-velocity "
                              "and zero-position updates); each aligns from the filter's own increments over the "
                              "window and starts with zero velocity"),
            "duration": Num(unit="s", **_POS, max=86400.0, default=300.0,
                            doc="the alignment window, ending at start_s (start_s >= duration_s; the vehicle must "
                                "be at rest over it)"),
        }, default={}),
    }, default={}, rules=("timeseries_rate_hz <= the navigation update rate (readout.output_rate_hz / n_sub)",
                          "tuned_band_hz: low < high < the filter Nyquist, given with filter_tuned and only with it (or under "
                          "a single coning motion, for the coning table)",
                          "the stored series and spectra must fit in memory (checked with the run's estimate)")),
    "outputs": Map({"plots": Bool(default=True), "timeseries": Bool(default=True)}, default={}),
    "temperature": TEMPERATURE_SCHEMA,
    "aiding": None,  # AIDING_SCHEMA, set below
    "vibration": _vspec.VIBRATION_SCHEMA,
}, rules=("the run's estimated wall time must be <= 48 h (sins_sim.jobs.estimate; shown before the run starts)",))


class _Any:
    """Placeholder schema entry for ``imu`` (a path or a mapping, checked separately)."""

    unit = None
    default = None
    required = True

    def describe_rows(self, path):
        return [{"key": path, "kind": "path or mapping", "unit": "", "range": "an IMU file or mapping",
                 "default": "required", "doc": "the unit: a path relative to the scenario, or the IMU keys inline "
                                              "(sins-sim schema imu)"}]

    def json_schema(self):
        from sins_sim.config.imu import IMU_SCHEMA
        from sins_sim.config.schema import json_schema

        return {"anyOf": [{"type": "string"}, json_schema(IMU_SCHEMA)],
                "description": "the unit: a path relative to the scenario, or the IMU keys inline"}

    def check(self, value, ctx, path):
        if not isinstance(value, (str, dict)):
            raise ConfigError(f"{ctx}: {path}: must be a path to an IMU file or an IMU mapping, got {value!r}")
        return value


class _FilterParameters:
    """Schema entry for the scenario's ``filter_parameters`` (replaces the IMU file's; checked by the IMU loader)."""

    unit = None
    default = None
    required = False

    def describe_rows(self, path):
        return [{"key": path, "kind": "true, nominal or mapping", "unit": "", "range": "sins-sim schema imu",
                 "default": "(the IMU file's)", "doc": "what the filters believe about each unit: the true "
                 "parameters, the datasheet (nominal, f0 from the dither PLL), explicit values or a diagnosis; "
                 "replaces the IMU file's filter_parameters"}]

    def json_schema(self):
        from sins_sim.config.schema import json_schema

        return json_schema(_fparams.FILTER_PARAMETERS_SCHEMA)

    def check(self, value, ctx, path):
        if value is None:
            return None
        _fparams.parse_filter_parameters(value, ctx, path)
        return value


#: The fix components the aided filter can apply (``sins_sim.navigation.aided.GNSS_MEASUREMENTS``, written here so
#: that loading a scenario does not import the navigation package; tests/test_mission_aided.py checks they agree).
AIDING_MEASUREMENTS = ("position", "velocity")
#: The scale-factor and misalignment groups the aided filter can estimate as states
#: (``sins_sim.navigation.ekf.SENSOR_ERROR_GROUPS``, written here for the same reason; tests/test_aided_sensor_states.py
#: checks they agree).
AIDING_SENSOR_ERROR_STATES = ("gyro_scale_factor", "gyro_misalignment", "accel_scale_factor", "accel_misalignment")
_SIG3 = dict(min=0.0, min_exclusive=True, max=1.0e4)
AIDING_SCHEMA = Map({
    "rate": Num(unit="hz", min=0.0, min_exclusive=True, max=100.0, default=1.0,
                doc="GNSS fix rate; must divide readout.output_rate_hz into whole samples (the fixes are the "
                    "truth at filter samples); with file: the rate the file's rows are taken at (its own times)"),
    "latency": Num(unit="s", min=0.0, max=10.0, default=0.0,
                   doc="delay from a fix's time of validity to its delivery; the filter applies it against its "
                       "solution at the time of validity"),
    "lever_arm": Vec(3, unit="m", min=-100.0, max=100.0, default=[0.0, 0.0, 0.0],
                     doc="antenna position from the IMU, body axes x, y, z"),
    "position_sigma": Vec(3, unit="m", **_SIG3, default=[1.0, 1.0, 2.0],
                          doc="white position noise 1-sigma north, east, down (with file: the file's accuracy, "
                              "the filter's R)"),
    "velocity_sigma": Vec(3, unit="m_s", **_SIG3, default=[0.05, 0.05, 0.1],
                          doc="white velocity noise 1-sigma north, east, down (with file: its accuracy)"),
    "markov_sigma": Vec(3, unit="m", min=0.0, max=1.0e4, default=[0.0, 0.0, 0.0],
                        doc="stationary 1-sigma of the first-order Gauss-Markov position error NED (atmosphere, "
                            "multipath; 0: none); simulated fixes only"),
    "markov_tau": Num(unit="s", min=0.0, min_exclusive=True, max=1.0e6, default=300.0,
                      doc="correlation time of the Gauss-Markov error; simulated fixes only"),
    "outages_s": ListOf(Vec(2, unit=None, min=0.0, max=MAX_DURATION_S), default=[], max_len=10000,
                        doc="[[start_s, end_s], ...]: no fix valid in [start, end) (s); start < end, within "
                            "(navigation.start_s, duration_s)"),
    "measurements": ListOf(Str(choices=AIDING_MEASUREMENTS), default=list(AIDING_MEASUREMENTS), min_len=1,
                           max_len=2, doc="the fix components the filter applies (plug-in names)"),
    "update_rate": Num(unit="hz", min=0.0, min_exclusive=True, max=100.0, default=None,
                       doc="the filter's measurement update rate: every rate_hz / update_rate_hz-th fix is applied "
                           "(a whole number) and the covariance is propagated once per update interval; default: "
                           "rate_hz"),
    "feedback": Bool(default=True, doc="closed loop (corrections fed back to the navigator) or open loop"),
    "smoother": Bool(default=False, doc="also run the Rauch-Tung-Striebel fixed-interval smoother"),
    "fix_error_states": Bool(default=True, doc="model the Gauss-Markov error (markov_sigma_m) as three filter "
                                               "states, R the white noise (Gelb 1974 sec. 3.8); false: fold it "
                                               "into R as the variance of the mean over the longest aided "
                                               "stretch (15 states)"),
    "sensor_error_states": ListOf(Str(choices=AIDING_SENSOR_ERROR_STATES), default=[], max_len=4,
                                  doc="scale-factor and misalignment groups the filter estimates as states (3 per "
                                      "scale-factor group, 6 per misalignment group; random constants with the "
                                      "IMU's sensors: numbers as priors, fed back into the increments), instead "
                                      "of process noise per step from the angle turned (Groves 2013 sec. 14.2.4)"),
    "file": Str(default="", doc="a recorded GNSS solution instead of simulated fixes (CSV or Parquet: time_s, "
                                "lat_deg, lon_deg, height_m, optional vn_m_s, ve_m_s, vd_m_s), relative to the "
                                "scenario; it must cover navigation.start_s to duration_s"),
}, default=None, allow_null=True,
    doc="GNSS aiding: each filter's increments also navigated by an error-state Kalman filter (15 states, 18 with "
        "the Gauss-Markov fix-error states, up to 18 more with sensor_error_states) with the "
        "same fixes (absent: free navigation only)",
    rules=("rate_hz divides readout.output_rate_hz (simulated fixes); update_rate_hz divides rate_hz",
           "markov_sigma_m and markov_tau_s describe simulated fixes: refused with file",
           "velocity in measurements needs the file's velocity columns",
           "sensor_error_states names each group once and needs the IMU's sensors: section",
           "outages lie within (navigation.start_s, duration_s); a file covers navigation.start_s to duration_s"))
SCENARIO_SCHEMA.fields["aiding"] = AIDING_SCHEMA

SCENARIO_SCHEMA.fields["imu"] = _Any()
SCENARIO_SCHEMA.fields["filter_parameters"] = _FilterParameters()


class Scenario:
    """A validated scenario: its keys checked here, its mission resolved by the plan.

    The keys, units and ranges are checked here (and the IMU file's, :func:`sins_sim.config.imu.parse_imu`);
    everything that needs the physics is resolved by :func:`sins_sim.plan.resolve_plan`, called once, whose
    :class:`~sins_sim.plan.Plan` is :attr:`plan` (what the engine runs, :func:`sins_sim.plan.run_plan`); its
    fields are also this object's attributes (``imu``, ``nav``, ``motion``, ``vehicle``, ``site``, ...).
    ``duration_key`` is how a refusal names the run's length (``duration_s``, or ``--duration`` when the
    command line set it). Configuration-time advisories (:mod:`sins_sim.plan.advisories`) are issued as
    :class:`UserWarning` and kept in :attr:`advisories`.
    """

    def __init__(self, doc: dict, ctx: str, base_dir: Path, duration_key: str = "duration_s"):
        c = validate(doc, SCENARIO_SCHEMA, ctx)
        if c["navigation"]["start_s"] >= c["duration_s"]:  # before the models are imported: a light check
            raise ConfigError(f"{ctx}: navigation.start_s: must be < duration_s = {c['duration_s']:g}, "
                              f"got {c['navigation']['start_s']:g}")
        _check_file_trajectory(doc, ctx)
        # the IMU's own schema is checked before the models and the engine are imported (sins_sim.config.imu),
        # so a wrong IMU file fails as fast
        from sins_sim.config.imu import parse_imu

        self.ctx = ctx
        #: the mapping validated (overrides applied) and the folder its relative paths are taken from
        self.document = doc
        self.base_dir = Path(base_dir)
        #: the scenario file (set by :func:`load_scenario`; None for a mapping)
        self.path = None
        self.name = c["name"]
        self.description = c["description"]
        imu = c["imu"]
        if isinstance(imu, str):
            imu_path = (base_dir / imu).resolve()
            if not imu_path.exists():
                raise ConfigError(f"{ctx}: imu: file not found: {imu_path}")
            self.imu_source = str(imu)
            imu_doc = load_yaml(imu_path)
            if c["filter_parameters"] is not None and isinstance(imu_doc, dict):
                imu_doc = dict(imu_doc, filter_parameters=c["filter_parameters"])
            alias_marks(f"{ctx} -> {imu_path.name}", str(imu_path))  # its errors give the IMU file's lines
            unit = parse_imu(imu_doc, f"{ctx} -> {imu_path.name}", base_dir=imu_path.parent)
        else:
            self.imu_source = "inline"
            if c["filter_parameters"] is not None:
                imu = dict(imu, filter_parameters=c["filter_parameters"])
            unit = parse_imu(imu, ctx, "imu", base_dir=base_dir)
            imu_doc = imu
        #: what the filters believe (sins_sim.config.filter_params): source, f0, f0_mismatch_ppm, track
        fp = imu_doc.get("filter_parameters", True) if isinstance(imu_doc, dict) else True
        self.filter_spec = _fparams.parse_filter_parameters(fp, ctx)
        _check_motion(c["motion"], c["linear_vibration"], unit["c"]["readout"]["output_rate_hz"], ctx,
                      unit["c"]["plant"]["rate_hz"])
        self.motion_spec = c["motion"]
        self.trajectory_spec = c["trajectory"]
        #: the vibration specification (sins_sim.models.vibration_spec.SineOnRandomSpec) or None; the plan builds
        #: the translational vibration from it
        vibration_spec = None
        if c["vibration"] is not None:
            if doc.get("linear_vibration"):  # an empty list (the default written out) duplicates nothing
                raise ConfigError(f"{ctx}: vibration.spec: refused beside linear_vibration, which it would "
                                  f"duplicate (the spec resolves to the translational vibration): give one of them")
            vibration_spec = _vspec.parse_vibration_spec(c["vibration"]["spec"], base_dir, ctx,
                                                         0.5 * unit["c"]["readout"]["output_rate_hz"])
        self.outputs = c["outputs"]
        # the one entry point into the physics: the plan resolves the unit, the rates, the designs, the vehicle,
        # the alignment and the aiding, and refuses what does not compose (its lines are this file's errors)
        from sins_sim.plan import PlanError, resolve_plan

        try:
            #: what the engine runs (sins_sim.plan.run_plan)
            self.plan = resolve_plan({"c": c, "doc": doc, "imu": unit, "ctx": ctx, "base_dir": base_dir,
                                      "duration_key": duration_key, "vibration_spec": vibration_spec})
        except PlanError as exc:
            raise ConfigError(str(exc)) from None
        for field in dataclasses.fields(self.plan):
            setattr(self, field.name, getattr(self.plan, field.name))


def _motion_frequencies(seg):
    """(key, Hz) of every frequency a motion or translation part puts on the block (amplitude not zero)."""
    kind = seg["type"]
    if kind == "sines":
        amp = seg.get("amplitude_rad", seg.get("amplitude_m_s2"))
        return [(f"frequency_hz[{i}]", f) for i, (f, a) in enumerate(zip(seg["frequency_hz"], amp)) if a > 0.0]
    if kind == "coning":
        return [("frequency_hz", seg["frequency_hz"])]
    if kind in ("random_vibration", "random"):
        return [("f_hi_hz", seg["f_hi_hz"])]
    if kind == "shock":
        return [("ring_frequency_hz", seg["ring_frequency_hz"])] if seg["ring_amplitude_rad_s"] != 0.0 else []
    if kind == "sweep":
        return [("f_start_hz", seg["f_start_hz"]), ("f_stop_hz", seg["f_stop_hz"])]
    return []


def _peak_rate_deg_s(seg):
    """(key, peak rate in deg/s) of a block motion part, where the schema alone cannot bound it."""
    kind = seg["type"]
    two_pi = 2.0 * math.pi
    if kind == "turn":
        return [("angle_deg", 2.0 * abs(seg["angle_rad"]) / seg["duration_s"])]
    if kind == "sines":
        return [(f"amplitude_arcmin[{i}]", two_pi * f * a)
                for i, (f, a) in enumerate(zip(seg["frequency_hz"], seg["amplitude_rad"]))]
    if kind == "coning":
        return [("amplitude_arcmin", two_pi * seg["frequency_hz"] * seg["amplitude_rad"])]
    if kind == "sweep":
        return [("amplitude_arcmin", two_pi * max(seg["f_start_hz"], seg["f_stop_hz"]) * seg["amplitude_rad"])]
    return []


#: A shock's half-sine must last at least this many plant steps: its spectrum's main lobe ends at 1.5 / T (the first
#: zero of the Fourier transform of ``sin(pi t / T)`` on ``[0, T]``, ``|F(f)| ~ |cos(pi f T)| / |1 - (2 f T)^2|``),
#: which must lie below the plant's Nyquist ``rate_hz / 2``: ``T >= 3 / rate_hz`` (0.042 ms at 72 kHz). A shorter
#: pulse is not resolved by the plant, whose dither dynamics integrate the rate at its steps.
SHOCK_MIN_PLANT_STEPS = 3.0


def _check_motion(motion, linear, fs_hz: float, ctx: str, plant_hz: float | None = None) -> None:
    """Every motion frequency below the filter Nyquist (a warning near it); every part's peak rate in range; a
    random part's axis weights not all zero; a shock resolved at the plant rate ``plant_hz``."""
    nyq = 0.5 * fs_hz
    for group, parts in (("motion", motion), ("linear_vibration", linear)):
        for i, seg in enumerate(parts):
            if seg["type"] in ("random_vibration", "random") and not any(w > 0.0 for w in seg["axes"]):
                raise ConfigError(f"{ctx}: {group}[{i}].axes: must not be all zero (the per-axis weights of the "
                                  f"vibration: all zero makes no motion; leave the part out instead), got "
                                  f"{list(seg['axes'])}")
            if seg["type"] == "shock" and plant_hz is not None:
                t_min = SHOCK_MIN_PLANT_STEPS / plant_hz
                if seg["duration_s"] < t_min * (1.0 - 1e-12):
                    raise ConfigError(f"{ctx}: {group}[{i}].duration_ms: must be >= {t_min * 1e3:.4g} ms, "
                                      f"{SHOCK_MIN_PLANT_STEPS:g} steps of the plant rate {plant_hz:g} Hz (the "
                                      f"half-sine's main lobe, up to 1.5 / duration, must lie below the plant's "
                                      f"Nyquist), got {seg['duration_s'] * 1e3:g}")
            for key, f in _motion_frequencies(seg):
                where = f"{group}[{i}].{key}"
                if not f < nyq:
                    raise ConfigError(f"{ctx}: {where}: must be < the filter Nyquist {nyq:g} Hz "
                                      f"(readout.output_rate_hz / 2: the filters, the truth they are compared with "
                                      f"and the navigation run at the filter rate; above it the motion aliases), "
                                      f"got {f:g}")
                if f > NEAR_NYQUIST * nyq:
                    warnings.warn(f"{where}: {f:g} Hz is near the filter Nyquist {nyq:g} Hz (above "
                                  f"{NEAR_NYQUIST:.0%} of it the motion is barely resolved at the filter rate)",
                                  UserWarning, stacklevel=2)
            if group == "motion":
                for key, rate in _peak_rate_deg_s(seg):
                    rate_deg = math.degrees(rate)
                    if rate_deg > MAX_RATE_DEG_S:
                        raise ConfigError(f"{ctx}: {group}[{i}].{key}: gives a peak rate of {rate_deg:.4g} deg/s, "
                                          f"beyond the {MAX_RATE_DEG_S:g} deg/s an RLG measures")


def _check_file_trajectory(doc, ctx) -> None:
    """A trajectory file holds the whole motion and its own start: keys that would be ignored beside it are refused
    (they were dropped without a word, and metrics.json then reported the default site)."""
    tr = doc.get("trajectory") if isinstance(doc, dict) else None
    if isinstance(tr, dict) and not tr.get("file") and "velocity_tolerance_m_s" in tr:
        raise ConfigError(f"{ctx}: trajectory.velocity_tolerance_m_s: applies to a trajectory file with velocity "
                          "columns (segments have no measured velocity): remove it or give trajectory.file")
    if not (isinstance(tr, dict) and tr.get("file")):
        return
    extra = [f"trajectory.{k}" for k in ("segments", "speed_m_s", "transition_s") if k in tr]
    if "site" in doc:
        extra.append("site")
    if extra:
        raise ConfigError(f"{ctx}: {extra[0]}: would be ignored beside trajectory.file, which holds the whole motion "
                          f"and starts at its first row: remove {', '.join(extra)} or the file")


def load_scenario(source, overrides: dict | None = None, base_dir=None) -> Scenario:
    """Read and validate a scenario file or mapping (errors name the file, the key path and the rule).

    Parameters
    ----------
    source : path or mapping
        The scenario YAML, or a dict with the same keys and values (a notebook needs no file), validated
        exactly like a file; its errors name ``scenario (dict)`` and the key, and its relative paths
        (``imu``, ``trajectory.file``) are taken from the working directory.
    overrides : dict, optional
        Replaces top-level keys before validation (``{"seed": 3, "duration_s": 60}``, from the command
        line), so an override is checked like the file's own value: ``seed``, ``duration_s``,
        ``filter_parameters`` and ``imu`` (a path, taken relative to the working directory like any
        command-line path, or a mapping).
    base_dir : path, optional
        For a mapping: where its relative paths are taken from (default: the working directory).

    Returns
    -------
    Scenario
        With :attr:`Scenario.document` (the mapping validated, overrides applied), :attr:`Scenario.base_dir`
        and :attr:`Scenario.path` (the file, None for a mapping).
    """
    from collections.abc import Mapping

    key = "--duration" if overrides and "duration_s" in overrides else "duration_s"
    doc = scenario_document(source, overrides)
    if isinstance(source, Mapping):
        sc = Scenario(doc, SCENARIO_DICT_CONTEXT, Path(base_dir) if base_dir is not None else Path.cwd(),
                      duration_key=key)
        sc.path = None
    else:
        path = Path(source)
        sc = Scenario(doc, str(path), path.parent, duration_key=key)
        sc.path = path
    return sc


#: How configuration errors name a scenario given as a mapping.
SCENARIO_DICT_CONTEXT = "scenario (dict)"


def scenario_document(source, overrides: dict | None = None) -> dict:
    """The scenario file's (or mapping's) content with the command line's ``overrides`` applied (not yet validated)."""
    from collections.abc import Mapping

    if isinstance(source, Mapping):
        import copy

        where = SCENARIO_DICT_CONTEXT
        doc = copy.deepcopy(dict(source))  # the caller's dict is never changed
    elif isinstance(source, (str, Path)):
        where = Path(source)
        doc = load_yaml(where)
    else:
        raise ConfigError(f"scenario: expected a path, a mapping or a Scenario, got {type(source).__name__}")
    if overrides:
        doc = dict(doc)
        for key, value in overrides.items():
            if key not in OVERRIDABLE:
                raise ConfigError(f"{where}: {key}: cannot be overridden (allowed: {', '.join(OVERRIDABLE)})")
            if key == "imu" and isinstance(value, (str, Path)):
                value = str(Path(value).resolve())
            doc[key] = value
            if not isinstance(source, Mapping):
                forget_mark(str(where), key)  # the value is the command line's: no line in the file
    return doc


#: Scenario keys that a command line (``--seed``, ``--duration``, ``--imu``, ``--filter-parameters``) may replace.
OVERRIDABLE = ("seed", "duration_s", "imu", "filter_parameters")

