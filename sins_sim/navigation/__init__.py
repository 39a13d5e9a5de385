"""Navigation layer: coning-corrected attitude integration and navigation error.

Arrays in, arrays out; this package imports neither ``sins_sim.models`` nor
``sins_sim.filters`` (the simulation engine connects them).

Frames and units: ``q_nb`` Hamilton quaternions, scalar first, body to
navigation; gyro angle increments in rad (body frame); rates in rad/s; times
in s; positions in m. The navigation frame of the error model is local-level
north-east-down.

- :mod:`~sins_sim.navigation.alignment`: :func:`align_coarse` (levelling and
  gyrocompassing from the mean force and rate) and :func:`align_inertial`
  (inertial-frame alignment by Davenport's q-method, robust to base sway),
  both returning :class:`~sins_sim.navigation.alignment_result.AlignmentResult`.
- :mod:`~sins_sim.navigation.attitude`: :func:`integrate_attitude`,
  :class:`AttitudeIntegrator`, :func:`attitude_error`, :func:`drift_rate`,
  numpy quaternion helpers.
- :mod:`~sins_sim.navigation.coning`: :class:`ConingAlgorithm`, the classical
  cone (exact rate, attitude and increments), :func:`coning_drift_closed_form`,
  :func:`algorithm_residual_drift`.
- :mod:`~sins_sim.navigation.error`: the Schuler-loop error model,
  :func:`position_error_from_attitude_error`,
  :func:`equivalent_position_error_1h`, :func:`strapdown_position_error`.
- :mod:`~sins_sim.navigation.strapdown`: :class:`StrapdownNavigator` (the full
  INS loop, local-level NED on WGS-84), :class:`NavSolution`,
  :func:`height_aid_gains`.
- :mod:`~sins_sim.navigation.ekf`: the error-state Kalman filter in closed loop,
  :class:`AidedNavigator`, :class:`ImuNoise`, the measurement plug-ins
  (:data:`MEASUREMENTS`), :func:`error_dynamics`, :func:`discretize`.
- :mod:`~sins_sim.navigation.static_kalman`: :func:`align_kalman` (Kalman fine
  alignment at rest), :func:`navigate_zupt` (a still log with zero-velocity
  updates), :class:`ZuptResult`.
- :mod:`~sins_sim.navigation.gnss`: :func:`simulate_gnss` (GNSS position and
  velocity fixes of a truth: white and Gauss-Markov noise, latency, lever arm,
  outages), :class:`GnssSettings`, :class:`GnssFixes`.
- :mod:`~sins_sim.navigation.aided`: :func:`navigate_aided` (a record of
  increments aided by GNSS fixes, latency handled at the time of validity),
  :func:`smooth` (Rauch-Tung-Striebel), :func:`outage_growth`.
"""

from sins_sim.navigation.aided import (
    AidedResult,
    OutageGrowth,
    SmoothedResult,
    navigate_aided,
    outage_growth,
    smooth,
)
from sins_sim.navigation.alignment import align_coarse, align_inertial
from sins_sim.navigation.attitude import (
    AttitudeIntegrator,
    attitude_error,
    drift_rate,
    euler_from_quat,
    integrate_attitude,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    rotvec_from_quat,
)
from sins_sim.navigation.coning import (
    CONING_ALGORITHMS,
    ConingAlgorithm,
    algorithm_residual_drift,
    cone_body_rate,
    cone_increments,
    cone_quaternion,
    coning_drift_closed_form,
)
from sins_sim.navigation.error import (
    EARTH_RADIUS_M,
    EARTH_RATE_RAD_S,
    GRAVITY_M_S2,
    SCHULER_RAD_S,
    NavigationError,
    equivalent_position_error_1h,
    position_error_from_attitude_error,
    schuler_ramp_position_error,
    strapdown_position_error,
)
from sins_sim.navigation.ekf import (
    MEASUREMENTS,
    N_STATES,
    STATE_NAMES,
    AidedNavigator,
    Height,
    ImuNoise,
    Innovation,
    NavState,
    Position,
    Velocity,
    ZeroAngularRate,
    ZeroVelocity,
    discretize,
    error_dynamics,
    initial_covariance,
    make_measurement,
    process_noise_density,
)
from sins_sim.navigation.gnss import GnssFixes, GnssSettings, simulate_gnss
from sins_sim.navigation.static_kalman import ZuptResult, align_kalman, navigate_zupt, observability
from sins_sim.navigation.strapdown import (
    SCULLING_ALGORITHMS,
    VERTICAL_MODES,
    NavSolution,
    StrapdownNavigator,
    height_aid_gains,
)

__all__ = [
    "align_coarse",
    "align_inertial",
    "AttitudeIntegrator",
    "attitude_error",
    "drift_rate",
    "euler_from_quat",
    "integrate_attitude",
    "quat_conjugate",
    "quat_from_rotvec",
    "quat_multiply",
    "rotvec_from_quat",
    "CONING_ALGORITHMS",
    "ConingAlgorithm",
    "algorithm_residual_drift",
    "cone_body_rate",
    "cone_increments",
    "cone_quaternion",
    "coning_drift_closed_form",
    "EARTH_RADIUS_M",
    "EARTH_RATE_RAD_S",
    "GRAVITY_M_S2",
    "SCHULER_RAD_S",
    "NavigationError",
    "equivalent_position_error_1h",
    "position_error_from_attitude_error",
    "schuler_ramp_position_error",
    "strapdown_position_error",
    "SCULLING_ALGORITHMS",
    "VERTICAL_MODES",
    "NavSolution",
    "StrapdownNavigator",
    "height_aid_gains",
    "MEASUREMENTS",
    "N_STATES",
    "STATE_NAMES",
    "AidedNavigator",
    "Height",
    "ImuNoise",
    "Innovation",
    "NavState",
    "Position",
    "Velocity",
    "ZeroAngularRate",
    "ZeroVelocity",
    "discretize",
    "error_dynamics",
    "initial_covariance",
    "make_measurement",
    "process_noise_density",
    "ZuptResult",
    "align_kalman",
    "navigate_zupt",
    "observability",
    "GnssFixes",
    "GnssSettings",
    "simulate_gnss",
    "AidedResult",
    "OutageGrowth",
    "SmoothedResult",
    "navigate_aided",
    "outage_growth",
    "smooth",
]
