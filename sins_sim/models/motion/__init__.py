"""Motion of the SINS block and of the vehicle carrying it, with exact truth.

One module per kind of motion:

* :mod:`~sins_sim.models.motion.single_axis`: the block angle about one gyro's
  sensitive axis (``angle_rate(t)``), the single-channel interface;
* :mod:`~sins_sim.models.motion.body`: three-axis block motions (static,
  rates, turns, sines, coning, random vibration, shocks, rate-table sweeps)
  with closed-form gyro angles and attitude truth.

Everything public is re-exported here, so ``from sins_sim.models.motion import
Coning, SineMotion`` works whichever module holds the class.
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

__all__ = [
    # single axis
    "StaticMotion", "SineMotion", "ConstantRateMotion", "SampledMotion", "CallableMotion", "SumMotion", "as_motion",
    # three axes
    "Motion3D", "GyroAxis", "AttitudeStream", "Static", "ConstantRate", "Turn", "AxisSines", "Coning",
    "RandomVibration", "Shock", "RateTableSweep", "SumMotion3D", "MOTION_TYPES", "build_motion",
    "specific_force_body", "STANDARD_GRAVITY", "DEFAULT_SUBSTEPS",
]
