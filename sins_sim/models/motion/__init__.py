"""Motion of the SINS block and of the vehicle carrying it, with exact truth.

One module per kind of motion:

* :mod:`~sins_sim.models.motion.single_axis`: the block angle about one gyro's
  sensitive axis (``angle_rate(t)``), the single-channel interface;
* :mod:`~sins_sim.models.motion.body`: three-axis block motions (static,
  rates, turns, sines, coning, random vibration, shocks, rate-table sweeps)
  with closed-form gyro angles and attitude truth;
* :mod:`~sins_sim.models.motion.vibration`: random vibration as filtered noise
  (angular, non-repeating, O(1) per evaluated time) and the block's
  translational vibration (``Translation``: sines, random in g^2/Hz);
* :mod:`~sins_sim.models.motion.trajectory`: vehicle trajectories on the
  WGS-84 Earth (segments or samples) with navigation truth: position,
  velocity, attitude, inertial angular rate and specific force.

Everything public is re-exported here, so ``from sins_sim.models.motion import
Coning, SineMotion`` works whichever module holds the class. The trajectory's
coordinated turn is exported as ``CoordinatedTurn`` (``Turn`` here is the
block motion of :mod:`~sins_sim.models.motion.body`).
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
from sins_sim.models.motion.body import (
    DEFAULT_SUBSTEPS,
    MOTION_TYPES,
    STANDARD_GRAVITY,
    AttitudeStream,
    AxisSines,
    Coning,
    ConstantRate,
    GyroAxis,
    Motion3D,
    RandomVibration,
    RateTableSweep,
    Shock,
    Static,
    SumMotion3D,
    Turn,
    build_motion,
    specific_force_body,
)
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
    SampledTrajectory,
    SampledTrajectoryStream,
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
    "Stationary", "Cruise", "Accelerate", "CoordinatedTurn", "Climb", "SEGMENT_TYPES", "Trajectory",
    "TrajectoryStream", "TrajectoryTruth", "SampledTrajectory", "SampledTrajectoryStream", "build_trajectory",
    "DEFAULT_TRANSITION_S", "DEFAULT_STEP_S",
]
