"""Motion of the SINS block and of the vehicle carrying it, with exact truth.

One module per kind of motion:

* :mod:`~sins_sim.models.motion.single_axis`: the block angle about one gyro's
  sensitive axis (``angle_rate(t)``), the single-channel interface;
* three-axis block motions with closed-form gyro angles and attitude truth:
  :mod:`~sins_sim.models.motion.base` (the ``Motion3D`` interface, sums,
  one gyro's view, chunked attitude), :mod:`~sins_sim.models.motion.rotations`
  (static, constant rate, turn), :mod:`~sins_sim.models.motion.sines` (sines,
  coning, random vibration as tones), :mod:`~sins_sim.models.motion.shocks`,
  :mod:`~sins_sim.models.motion.sweeps` (rate-table sweeps),
  :mod:`~sins_sim.models.motion.specific_force` (ideal accelerometers) and
  :mod:`~sins_sim.models.motion.body` (the registry ``MOTION_TYPES`` /
  ``build_motion``, and the overview with references);
* :mod:`~sins_sim.models.motion.vibration`: random vibration as filtered noise
  (angular, non-repeating, O(1) per evaluated time) and the block's
  translational vibration (``Translation``: sines, random in g^2/Hz);
* :mod:`~sins_sim.models.motion.trajectory`: vehicle trajectories on the
  WGS-84 Earth (segments or samples) with navigation truth: position,
  velocity, attitude, inertial angular rate and specific force.

Everything public is re-exported here, so ``from sins_sim.models.motion import
Coning, SineMotion`` works whichever module holds the class. The trajectory's
coordinated turn is exported as ``CoordinatedTurn`` (``Turn`` here is the
block motion of :mod:`~sins_sim.models.motion.rotations`).
"""

from sins_sim.models.motion.single_axis import (
    CallableMotion,
    ConstantRateMotion,
    SampledMotion,
    SineMotion,
    StaticMotion,
    SumMotion,
    _Motion,
    as_motion,
)
from sins_sim.models.motion.base import DEFAULT_SUBSTEPS, AttitudeStream, GyroAxis, Motion3D, SumMotion3D
from sins_sim.models.motion.rotations import ConstantRate, Static, Turn
from sins_sim.models.motion.sines import AxisSines, Coning, RandomVibration
from sins_sim.models.motion.shocks import Shock
from sins_sim.models.motion.sweeps import RateTableSweep
from sins_sim.models.motion.specific_force import STANDARD_GRAVITY, specific_force_body
from sins_sim.models.motion.body import MOTION_TYPES, build_motion
from sins_sim.models.motion.vibration import (
    DEFAULT_NODE_RATE_HZ,
    FilteredNoiseVibration,
    LinearRandomVibration,
    LinearSines,
    SumTranslation,
    Translation,
)
from sins_sim.models.motion.trajectory import (
    DEFAULT_STEP_S,
    DEFAULT_TRANSITION_S,
    SEGMENT_TYPES,
    Accelerate,
    Climb,
    CoordinatedTurn,
    Cruise,
    Hover,
    SampledTrajectory,
    SampledTrajectoryStream,
    Sideways,
    Stationary,
    Trajectory,
    TrajectoryStream,
    TrajectoryTruth,
    build_trajectory,
)

__all__ = [
    # single axis
    "StaticMotion", "SineMotion", "ConstantRateMotion", "SampledMotion", "CallableMotion", "SumMotion", "as_motion",
    # three axes
    "Motion3D", "GyroAxis", "AttitudeStream", "Static", "ConstantRate", "Turn", "AxisSines", "Coning",
    "RandomVibration", "Shock", "RateTableSweep", "SumMotion3D", "MOTION_TYPES", "build_motion",
    "specific_force_body", "STANDARD_GRAVITY", "DEFAULT_SUBSTEPS",
    # filtered-noise and translational vibration
    "FilteredNoiseVibration", "Translation", "LinearSines", "LinearRandomVibration", "SumTranslation",
    "DEFAULT_NODE_RATE_HZ",
    # vehicle trajectories
    "Stationary", "Cruise", "Accelerate", "CoordinatedTurn", "Climb", "Hover", "Sideways", "SEGMENT_TYPES", "Trajectory",
    "TrajectoryStream", "TrajectoryTruth", "SampledTrajectory", "SampledTrajectoryStream", "build_trajectory",
    "DEFAULT_TRANSITION_S", "DEFAULT_STEP_S",
]
