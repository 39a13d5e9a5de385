"""Vehicle trajectories on the WGS-84 Earth with exact navigation truth.

A vehicle flies over the rotating Earth; this module gives, at any times,
the truth the strapdown loop needs (docs/theory/navigation.md):
position, velocity, acceleration, attitude, and the two inputs of an ideal
IMU, the angular rate with respect to inertial space and the specific
force, both in vehicle axes.

Conventions
-----------
* Position: geodetic latitude ``lat`` and longitude ``lon`` (rad), height
  ``h`` (m, up) above the WGS-84 ellipsoid (:mod:`sins_sim.earth`).
* Navigation frame ``n``: local-level north-east-down (NED). Velocity
  ``v_ned`` (m/s) is the ground velocity in NED components, ``a_ned`` its
  time derivative (m/s^2, the derivative of the components).
* Vehicle body ``v``: x forward, y right, z down. Attitude ``q_nv``:
  Hamilton quaternion, scalar first, vehicle body to NED
  (``v_n = q (x) v_b (x) q*``), from the Euler angles roll ``phi``, pitch
  ``theta``, yaw ``psi`` (rad, sequence 3-2-1: yaw first),
  ``q = q_z(psi) (x) q_y(theta) (x) q_x(phi)`` ([1] sec. 3.6, [3] sec. 2.2).
  The quaternion is continuous in time (its sign is not canonicalised).
* ``omega_iv_v`` (rad/s): the vehicle's angular rate with respect to
  inertial space in vehicle axes,
  ``omega_iv^v = omega_nv^v + C_vn (omega_ie^n + omega_en^n)`` with the
  Euler-rate term (the inverse of the Euler-angle rate equations, [1] sec. 3.6,
  [3] sec. 2.2)::

      omega_nv^v = [phi' - psi' sin(theta),
                    theta' cos(phi) + psi' sin(phi) cos(theta),
                    -theta' sin(phi) + psi' cos(phi) cos(theta)]

  Earth rate ``omega_ie^n`` and transport rate ``omega_en^n`` as in
  :func:`sins_sim.earth.earth_rate_ned`, :func:`sins_sim.earth.transport_rate_ned`.
* ``f_v`` (m/s^2): specific force in vehicle axes, the inverse of the NED
  velocity equation in the local-level frame ([1] sec. 3.5, [2] ch. 4,
  [3] sec. 5.4)::

      f^v = C_vn (a_ned + (2 omega_ie^n + omega_en^n) x v_ned - g^n)

  with ``g^n`` from :func:`sins_sim.earth.gravity_ned` (normal gravity,
  plumb-bob, along the ellipsoid normal).

Sources of truth
----------------
:class:`Trajectory`
    Segments (:class:`Stationary`, :class:`Cruise`, :class:`Accelerate`,
    :class:`CoordinatedTurn`, :class:`Climb`, :class:`Hover`,
    :class:`Sideways`) strung together. Speed,
    heading, flight-path angle, height and their derivatives are closed-form
    functions of time; latitude and longitude are integrated (RK4) on a fixed
    internal grid, streaming (:class:`TrajectoryStream`).
:class:`SampledTrajectory`
    Interpolating splines through sampled positions and Euler angles (for
    instance a file read by :func:`sins_sim.io.read_trajectory`), with
    velocity, acceleration and rates from the splines' derivatives.

Both return :class:`TrajectoryTruth` from ``evaluate(t)`` and from the
``evaluate(t)`` of their ``stream()``.

.. autosummary::

   Stationary
   Cruise
   Accelerate
   CoordinatedTurn
   Climb
   Hover
   Sideways
   Trajectory
   TrajectoryStream
   TrajectoryTruth
   SampledTrajectory
   SampledTrajectoryStream
   build_trajectory

References
----------
.. [1] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004: Euler angles and quaternions (sec. 3.6),
   navigation equations in the local geographic frame (sec. 3.5), the same
   in components with radii and transport rate (sec. 3.7).
.. [2] P. G. Savage, *Strapdown Analytics*, 2nd ed., Strapdown Associates,
   2007, ch. 4 (velocity and position rate equations in the locally level
   frame) and ch. 5 (Earth model).
.. [3] P. D. Groves, *Principles of GNSS, Inertial, and Multisensor
   Integrated Navigation Systems*, 2nd ed., Artech House, 2013, sec. 2.2
   (attitude), 2.4 (Earth surface), 5.4 (local-navigation-frame equations).
.. [4] C. de Boor, *A Practical Guide to Splines*, rev. ed., Springer, 2001
   (B-spline interpolation and its error).
.. [5] ``scipy.spatial.transform.RotationSpline`` and the note it cites,
   "Smooth Attitude Interpolation" (scipy issue attachment 2932755): cubic
   rotation-vector segments with continuous angular rate and acceleration.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import make_interp_spline
from scipy.spatial.transform import Rotation

from sins_sim import _validate as v
from sins_sim import earth
from sins_sim._kernels._config import jit
from sins_sim.earth import MAX_ABS_LAT_DEG
from sins_sim.models.motion._registry import build_typed

__all__ = [
    "Stationary",
    "Cruise",
    "Accelerate",
    "CoordinatedTurn",
    "Turn",
    "Climb",
    "Hover",
    "Sideways",
    "sideways_peaks",
    "SEGMENT_TYPES",
    "Trajectory",
    "TrajectoryStream",
    "TrajectoryTruth",
    "SampledTrajectory",
    "SampledTrajectoryStream",
    "build_trajectory",
    "DEFAULT_TRANSITION_S",
    "DEFAULT_STEP_S",
    "MAX_ABS_LAT_RAD",
    "MAX_FLIGHT_PATH_ANGLE_RAD",
    "CHECK_SIGMAS",
    "velocity_check_in_file_terms",
]

DEFAULT_TRANSITION_S = 4.0
"""Default duration (s) of each smooth ramp of a rate at the start and end of a segment."""

DEFAULT_STEP_S = 0.01
"""Internal RK4 step (s) of the latitude/longitude integration (100 Hz); see :class:`TrajectoryStream`."""

MAX_ABS_LAT_RAD = math.radians(MAX_ABS_LAT_DEG)
"""Largest |latitude| (rad) a trajectory may reach (89.5 deg, :data:`sins_sim.io.trajectory.MAX_ABS_LAT_DEG`): the
longitude rate ``v_E / ((R_E + h) cos lat)`` and the NED transport rate (``tan lat``) are singular at the poles."""

CHECK_SIGMAS = 5.0
"""A velocity column is refused where it differs from the velocity of the positions' own smoothing fit by more
than the tolerance and by more than this many standard deviations of that difference (the velocity noise and the
fit's uncertainty: large at the ends of a short file of coarsely rounded positions)."""

MAX_FLIGHT_PATH_ANGLE_RAD = math.radians(60.0)
"""Largest |flight-path angle| (rad) of a :class:`Climb` (the pitch stays well away from the Euler
singularity at 90 deg)."""

MAX_TURN_BODY_RATE_RAD_S = math.radians(1000.0)
"""Largest body rate (rad/s) of a :class:`CoordinatedTurn`: ``sqrt(psi'^2 + phi'^2)`` (heading rate and the roll
rate of the coordinated bank, level flight) at its peak over the turn. 1000 deg/s is the range of an RLG, the same
bound as the block motions (``sins_sim.config.scenario.MAX_RATE_DEG_S``): a faster turn is not measured."""

MAX_TURN_ACCEL_M_S2 = 2000.0
"""Largest centripetal acceleration ``V psi'`` (m/s^2) of a :class:`CoordinatedTurn`: about 200 g, beyond any
vehicle's turn (fighters pull 9 g, missiles 30-60 g) and the same bound as the block's translational vibration
(``sins_sim.config.scenario.MAX_ACCEL_M_S2``)."""

MAX_HOVER_ATTITUDE_RAD = math.radians(30.0)
"""Largest |roll| and |pitch| (rad) of a :class:`Hover`: a helicopter hovers within a few degrees of level (a roll
of 2-4 deg against the tail rotor's thrust); 30 deg is beyond any hover."""

MAX_SIDEWAYS_SPEED_M_S = 50.0
"""Largest |sideways speed| (m/s) of a :class:`Sideways` segment: helicopters are cleared for sideways flight up to
about 35-45 kt (18-23 m/s); 50 m/s is beyond any rotorcraft's sideways envelope."""

MAX_SIDEWAYS_BANK_RAD = math.radians(60.0)
"""Largest bank (rad) of a :class:`Sideways` segment's balanced acceleration, ``atan(max|u'| / g)``."""

HEIGHT_RANGE_M = (-1000.0, 100000.0)
"""Allowed height range (m), the same as the trajectory file reader's."""

_KIND_CONSTANT, _KIND_ACCELERATE, _KIND_TURN, _KIND_CLIMB, _KIND_HOVER, _KIND_SIDEWAYS = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0
_TWO_PI = 2.0 * math.pi
_E2 = earth.WGS84_E2
_OMEGA = earth.EARTH_RATE_RAD_S

# The Earth model of sins_sim.earth compiled for the scalar kernels below:
# the same source and constants, so truth and navigation share one model.
_radii = jit(earth.radii)
_gravity_down = jit(earth.gravity_down)


# --- kernels: smooth ramps, kinematics, position integration, truth ------------


@jit
def _ramp(x):
    """Septic smoothstep ``s(x) = x^4 (35 - 84 x + 70 x^2 - 20 x^3)`` on [0, 1], its integral and derivative.

    ``s(0) = 0``, ``s(1) = 1`` and ``s', s'', s'''`` vanish at both ends
    (C3 joins to the constants 0 and 1); ``S(x) = int_0^x s = x^5 (7 - 14 x
    + 10 x^2 - 5/2 x^3)``, ``S(1) = 1/2``; ``s'(x) = 140 x^3 (1 - x)^3``.
    """
    x2 = x * x
    x4 = x2 * x2
    s = x4 * (35.0 + x * (-84.0 + x * (70.0 - 20.0 * x)))
    big_s = x4 * x * (7.0 + x * (-14.0 + x * (10.0 - 2.5 * x)))
    y = x * (1.0 - x)
    ds = 140.0 * y * y * y
    return big_s, s, ds


def turn_peak_body_rate(speed_m_s: float, rate_rad_s: float, transition_s: float, g_m_s2: float) -> float:
    """Peak body rate (rad/s) of a level coordinated turn with plateau heading rate ``rate_rad_s``.

    The heading rate is ``r s(x)`` and the bank ``phi = atan(V r s(x) / g)`` over a ramp (``x = tau /
    transition_s``, ``s`` the septic smoothstep of :func:`_ramp`), so the roll rate is ``phi' = g V r s'(x) /
    (transition_s (g^2 + (V r s)^2))``; in level flight the body rate is ``[phi', psi' sin phi, psi' cos phi]``,
    of norm ``sqrt(phi'^2 + psi'^2)``. Its largest value over the ramp (sampled at 4001 points; the plateau is the
    ramp's end, ``x = 1``) is returned.
    """
    x = np.linspace(0.0, 1.0, 4001)
    s = x ** 4 * (35.0 + x * (-84.0 + x * (70.0 - 20.0 * x)))
    ds = 140.0 * (x * (1.0 - x)) ** 3 / transition_s
    lat = speed_m_s * rate_rad_s * s
    dphi = g_m_s2 * speed_m_s * rate_rad_s * ds / (g_m_s2 * g_m_s2 + lat * lat)
    return float(np.max(np.hypot(rate_rad_s * s, dphi)))


@jit
def _profile(tau, dur, tr):
    """Trapezoid of smooth ramps: ``p`` rises 0 -> 1 over ``[0, tr]``, holds, falls 1 -> 0 over ``[dur - tr, dur]``.

    Returns ``(P, p, p')`` with ``P = int_0^tau p`` (so ``P(dur) = dur - tr``).
    """
    if tau < 0.0:
        tau = 0.0
    elif tau > dur:
        tau = dur
    if tau < tr:
        big_s, s, ds = _ramp(tau / tr)
        return tr * big_s, s, ds / tr
    if tau <= dur - tr:
        return tau - 0.5 * tr, 1.0, 0.0
    big_s, s, ds = _ramp((dur - tau) / tr)
    return (dur - tr) - tr * big_s, s, -ds / tr


@jit
def _profile_dd(tau, dur, tr):
    """``p''`` of :func:`_profile`: ``s''(x) / tr^2`` on the rising ramp, ``s''(x') / tr^2`` on the falling one
    (``x' = (dur - tau) / tr``; ``s''(x) = 420 x^2 (1 - x)^2 (1 - 2 x)``, the derivative of ``s'`` of :func:`_ramp`),
    0 on the plateau and outside."""
    if tau <= 0.0 or tau >= dur:
        return 0.0
    if tau < tr:
        x = tau / tr
    elif tau <= dur - tr:
        return 0.0
    else:
        x = (dur - tau) / tr
    y = x * (1.0 - x)
    return 420.0 * y * y * (1.0 - 2.0 * x) / (tr * tr)


@jit
def _find_segment(tab, t):
    """Index of the last table row with start time ``<= t`` (binary search)."""
    lo = 0
    hi = tab.shape[0] - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if tab[mid, 0] <= t:
            lo = mid
        else:
            hi = mid - 1
    return lo


@jit
def _kinematics(tab, t):
    """Closed-form speed, heading, flight-path angle, height, bank, pitch and sideways speed at time ``t``.

    Table columns: start time, duration, ramp, kind, speed, heading and
    height at the segment start, amplitude (speed rate, heading rate, climb
    rate or sideways speed at the plateau), reference gravity of the bank,
    and the hover's roll and pitch (rad).

    Returns ``V, V', psi, psi', gamma, gamma', h, phi, phi', theta, theta', u, u'`` (m/s, m/s^2,
    rad, rad/s, rad, rad/s, m, rad, rad/s, rad, rad/s, m/s, m/s^2): ``theta`` is the pitch (the flight-path
    angle, plus a hover's pitch), ``u`` the speed to the right of the heading (sideways flight).
    """
    i = _find_segment(tab, t)
    kind = tab[i, 3]
    speed = tab[i, 4]
    dspeed = 0.0
    psi = tab[i, 5]
    dpsi = 0.0
    ddpsi = 0.0
    gam = 0.0
    dgam = 0.0
    h = tab[i, 6]
    amp = tab[i, 7]
    g = tab[i, 8]
    phi0 = 0.0
    dphi0 = 0.0
    theta0 = 0.0
    dtheta0 = 0.0
    u = 0.0
    du = 0.0
    ddu = 0.0
    if kind != 0.0:
        big_p, p, dp = _profile(t - tab[i, 0], tab[i, 1], tab[i, 2])
        if kind == 1.0:
            speed = speed + amp * big_p
            if speed < 0.0:  # rounding at the end of a deceleration to rest
                speed = 0.0
            dspeed = amp * p
        elif kind == 2.0:
            psi = psi + amp * big_p
            dpsi = amp * p
            ddpsi = amp * dp
        elif kind == 3.0:
            gam = math.asin(amp * p / speed)
            dgam = amp * dp / (speed * math.cos(gam))
            h = h + amp * big_p
        elif kind == 4.0:  # hover: roll and pitch eased in and out with the profile
            phi0 = tab[i, 9] * p
            dphi0 = tab[i, 9] * dp
            theta0 = tab[i, 10] * p
            dtheta0 = tab[i, 10] * dp
        else:  # sideways: speed to the right u = amp p, its rate u' = amp p'
            u = amp * p
            du = amp * dp
            ddu = amp * _profile_dd(t - tab[i, 0], tab[i, 1], tab[i, 2])
    # Balanced bank: the lateral acceleration (V psi' of a level turn, u' of sideways flight) is carried by the
    # tilted lift, phi = atan(a_lat / g), so the specific force stays in the body x-z plane ([1] sec. 3.6 /
    # flight mechanics); a hover's roll adds to it.
    lat_acc = speed * dpsi + du
    dlat_acc = dspeed * dpsi + speed * ddpsi + ddu
    phi = math.atan2(lat_acc, g) + phi0
    dphi = g * dlat_acc / (g * g + lat_acc * lat_acc) + dphi0
    return speed, dspeed, psi, dpsi, gam, dgam, h, phi, dphi, gam + theta0, dgam + dtheta0, u, du


@jit
def _velocity(speed, dspeed, psi, dpsi, gam, dgam, u, du):
    """NED velocity and its derivative of speed ``V`` along heading ``psi`` and flight-path angle ``gamma``,
    plus the sideways speed ``u`` to the right of the heading.

    ``v = V [cos g cos psi, cos g sin psi, -sin g] + u [-sin psi, cos psi, 0]``,
    ``a = V' e + V (g' de/dg + psi' de/dpsi) + u' r - u psi' [cos psi, sin psi, 0]``.
    """
    sg = math.sin(gam)
    cg = math.cos(gam)
    sp = math.sin(psi)
    cp = math.cos(psi)
    vh = speed * cg
    vn = vh * cp - u * sp
    ve = vh * sp + u * cp
    vd = -speed * sg
    dvh = dspeed * cg - speed * dgam * sg
    an = dvh * cp - vh * dpsi * sp - du * sp - u * dpsi * cp
    ae = dvh * sp + vh * dpsi * cp + du * cp - u * dpsi * sp
    ad = -dspeed * sg - speed * dgam * cg
    return vn, ve, vd, an, ae, ad


@jit
def _position_rate(lat, h, vn, ve):
    """``lat' = v_N / (R_N + h)``, ``lon' = v_E / ((R_E + h) cos lat)`` ([1] sec. 3.7)."""
    r_n, r_e = _radii(lat)
    return vn / (r_n + h), ve / ((r_e + h) * math.cos(lat))


@jit
def _rate_at(tab, t, lat):
    """Position rate at time ``t`` for latitude ``lat`` (height and velocity from the closed forms)."""
    speed, dspeed, psi, dpsi, gam, dgam, h, phi, dphi, theta, dtheta, u, du = _kinematics(tab, t)
    vn, ve, vd, an, ae, ad = _velocity(speed, dspeed, psi, dpsi, gam, dgam, u, du)
    return _position_rate(lat, h, vn, ve)


@jit
def _two_sum(hi, lo, x):
    """Neumaier compensated addition of ``x`` to the pair ``hi + lo``."""
    s = hi + x
    if abs(hi) >= abs(x):
        lo += (hi - s) + x
    else:
        lo += (x - s) + hi
    return s, lo


# State vector of the streaming integration (float64):
# 0 k (node index), 1-2 lat (hi, lo) at node k, 3-4 lon (hi, lo) at node k,
# 5-6 (lat', lon') at node k, 7-8 RK4 increment k -> k+1, 9-10 (lat', lon') at node k+1,
# 11 last evaluated time (-1 before the first).
_STATE_SIZE = 12


@jit
def _rk4_step(tab, dt, state):
    """Fill the increment of node ``k`` -> ``k+1`` and the rate at node ``k+1`` (classic RK4)."""
    k = state[0]
    lat = state[1] + state[2]
    f1a = state[5]
    f1o = state[6]
    tm = (k + 0.5) * dt
    t1 = (k + 1.0) * dt
    f2a, f2o = _rate_at(tab, tm, lat + 0.5 * dt * f1a)
    f3a, f3o = _rate_at(tab, tm, lat + 0.5 * dt * f2a)
    f4a, f4o = _rate_at(tab, t1, lat + dt * f3a)
    inc_a = dt / 6.0 * (f1a + 2.0 * f2a + 2.0 * f3a + f4a)
    inc_o = dt / 6.0 * (f1o + 2.0 * f2o + 2.0 * f3o + f4o)
    state[7] = inc_a
    state[8] = inc_o
    lat1 = state[1] + (state[2] + inc_a)
    state[9], state[10] = _rate_at(tab, t1, lat1)
    return abs(lat1) > MAX_ABS_LAT_RAD


@jit
def _stream_init(tab, dt, lat0, lon0, state):
    """Node 0 at ``t = 0`` and the first step; returns True if the latitude limit is crossed."""
    state[0] = 0.0
    state[1] = lat0
    state[2] = 0.0
    state[3] = lon0
    state[4] = 0.0
    state[5], state[6] = _rate_at(tab, 0.0, lat0)
    state[11] = -1.0
    return _rk4_step(tab, dt, state)


@jit
def _advance(tab, dt, state):
    """Move the state from node ``k`` to ``k + 1`` (compensated sums) and take the next step."""
    state[1], state[2] = _two_sum(state[1], state[2], state[7])
    state[3], state[4] = _two_sum(state[3], state[4], state[8])
    state[5] = state[9]
    state[6] = state[10]
    state[0] += 1.0
    return _rk4_step(tab, dt, state)


@jit
def _truth_point(lat, h, vn, ve, vd, an, ae, ad, phi, theta, psi, dphi, dtheta, dpsi, q, w, f, i):
    """Attitude quaternion, inertial angular rate and specific force of one sample.

    ``q = q_z(psi) (x) q_y(theta) (x) q_x(phi)`` ([1] sec. 3.6);
    ``omega_iv^v = omega_nv^v + C_vn (omega_ie^n + omega_en^n)``;
    ``f^v = C_vn (a + (2 omega_ie^n + omega_en^n) x v - g^n)`` ([1] sec. 3.5, [3] sec. 5.4).
    """
    s1 = math.sin(0.5 * phi)
    c1 = math.cos(0.5 * phi)
    s2 = math.sin(0.5 * theta)
    c2 = math.cos(0.5 * theta)
    s3 = math.sin(0.5 * psi)
    c3 = math.cos(0.5 * psi)
    q0 = c1 * c2 * c3 + s1 * s2 * s3
    q1 = s1 * c2 * c3 - c1 * s2 * s3
    q2 = c1 * s2 * c3 + s1 * c2 * s3
    q3 = c1 * c2 * s3 - s1 * s2 * c3
    sphi = 2.0 * s1 * c1
    cphi = c1 * c1 - s1 * s1
    sth = 2.0 * s2 * c2
    cth = c2 * c2 - s2 * s2
    wnx = dphi - dpsi * sth
    wny = dtheta * cphi + dpsi * sphi * cth
    wnz = -dtheta * sphi + dpsi * cphi * cth
    _truth_from_q(lat, h, vn, ve, vd, an, ae, ad, q0, q1, q2, q3, wnx, wny, wnz, q, w, f, i)


@jit
def _truth_from_q(lat, h, vn, ve, vd, an, ae, ad, q0, q1, q2, q3, wnx, wny, wnz, q, w, f, i):
    """:func:`_truth_point` from the attitude quaternion ``q_nv`` and the rate ``omega_nv^v`` (rad/s)."""
    q[i, 0] = q0
    q[i, 1] = q1
    q[i, 2] = q2
    q[i, 3] = q3
    # C_nv (vehicle -> NED) from the quaternion; f^v = C_nv^T f^n.
    c11 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    c12 = 2.0 * (q1 * q2 - q0 * q3)
    c13 = 2.0 * (q1 * q3 + q0 * q2)
    c21 = 2.0 * (q1 * q2 + q0 * q3)
    c22 = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    c23 = 2.0 * (q2 * q3 - q0 * q1)
    c31 = 2.0 * (q1 * q3 - q0 * q2)
    c32 = 2.0 * (q2 * q3 + q0 * q1)
    c33 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    # Earth rate, transport rate and gravity: sins_sim.earth ([1] sec. 3.7).
    slat = math.sin(lat)
    clat = math.cos(lat)
    r_n, r_e = _radii(lat)
    g = _gravity_down(lat, h)
    oie_n = _OMEGA * clat
    oie_d = -_OMEGA * slat
    ren = r_e + h
    wen_n = ve / ren
    wen_e = -vn / (r_n + h)
    wen_d = -ve * math.tan(lat) / ren
    win_n = oie_n + wen_n
    win_e = wen_e
    win_d = oie_d + wen_d
    w[i, 0] = wnx + c11 * win_n + c21 * win_e + c31 * win_d
    w[i, 1] = wny + c12 * win_n + c22 * win_e + c32 * win_d
    w[i, 2] = wnz + c13 * win_n + c23 * win_e + c33 * win_d
    cx = 2.0 * oie_n + wen_n
    cy = wen_e
    cz = 2.0 * oie_d + wen_d
    fn = an + (cy * vd - cz * ve)
    fe = ae + (cz * vn - cx * vd)
    fd = ad + (cx * ve - cy * vn) - g
    f[i, 0] = c11 * fn + c21 * fe + c31 * fd
    f[i, 1] = c12 * fn + c22 * fe + c32 * fd
    f[i, 2] = c13 * fn + c23 * fe + c33 * fd


@jit
def _wrap_pi(x):
    """``x`` in ``[-pi, pi)`` (unchanged when already inside)."""
    if x >= math.pi or x < -math.pi:
        x = x - _TWO_PI * math.floor((x + math.pi) / _TWO_PI)
    return x


@jit
def _trajectory_run(tab, dt, state, t, lat, lon, h, vel, acc, q, w, f):
    """Evaluate the truth at the increasing times ``t``, advancing the streaming state.

    Returns -1, or the index of the first time whose integration crossed
    :data:`MAX_ABS_LAT_RAD` (outputs from there on are not filled).
    """
    for i in range(t.size):
        ti = t[i]
        while ti > (state[0] + 1.0) * dt:
            if _advance(tab, dt, state):
                return i
        k = state[0]
        s = (ti - k * dt) / dt
        s2 = s * s
        s3 = s2 * s
        h10 = s3 - 2.0 * s2 + s
        h01 = 3.0 * s2 - 2.0 * s3
        h11 = s3 - s2
        # Cubic Hermite between nodes k and k+1 (values and RK4 rates at both ends).
        lat[i] = state[1] + (state[2] + (h01 * state[7] + dt * (h10 * state[5] + h11 * state[9])))
        lo = state[3] + (state[4] + (h01 * state[8] + dt * (h10 * state[6] + h11 * state[10])))
        lon[i] = _wrap_pi(lo)
        speed, dspeed, psi, dpsi, gam, dgam, hi, phi, dphi, theta, dtheta, u, du = _kinematics(tab, ti)
        vn, ve, vd, an, ae, ad = _velocity(speed, dspeed, psi, dpsi, gam, dgam, u, du)
        h[i] = hi
        vel[i, 0] = vn
        vel[i, 1] = ve
        vel[i, 2] = vd
        acc[i, 0] = an
        acc[i, 1] = ae
        acc[i, 2] = ad
        _truth_point(lat[i], hi, vn, ve, vd, an, ae, ad, phi, theta, psi, dphi, dtheta, dpsi, q, w, f, i)
        state[11] = ti
    return -1


@jit
def _sampled_run(lat_ref, lon_ref, pos, att, lat, lon, h, vel, acc, q, w, f):
    """Truth from spline values: ``pos`` (N, 9) = (dlat, dlat', dlat'', dlon, dlon', dlon'', h, h', h''),
    ``att`` (N, 7) = (q_nv scalar first, omega_nv^v) from the rotation spline.

    ``v_N = lat' (R_N + h)``, ``v_E = lon' (R_E + h) cos lat``, ``v_D = -h'`` and
    their time derivatives with ``dR_N/dlat = 3 R_N e^2 sin lat cos lat / W``,
    ``dR_E/dlat = R_E e^2 sin lat cos lat / W``, ``W = 1 - e^2 sin^2 lat``
    (derivatives of :func:`sins_sim.earth.radii`).
    """
    for i in range(pos.shape[0]):
        la = lat_ref + pos[i, 0]
        dla = pos[i, 1]
        ddla = pos[i, 2]
        dlo = pos[i, 4]
        ddlo = pos[i, 5]
        hi = pos[i, 6]
        dh = pos[i, 7]
        ddh = pos[i, 8]
        slat = math.sin(la)
        clat = math.cos(la)
        r_n, r_e = _radii(la)
        wgt = 1.0 - _E2 * slat * slat
        d_rn = 3.0 * r_n * _E2 * slat * clat / wgt
        d_re = r_e * _E2 * slat * clat / wgt
        rn = r_n + hi
        re = r_e + hi
        vn = dla * rn
        ve = dlo * re * clat
        vd = -dh
        an = ddla * rn + dla * (d_rn * dla + dh)
        ae = ddlo * re * clat + dlo * ((d_re * dla + dh) * clat - re * slat * dla)
        ad = -ddh
        lat[i] = la
        lon[i] = _wrap_pi(lon_ref + pos[i, 3])
        h[i] = hi
        vel[i, 0] = vn
        vel[i, 1] = ve
        vel[i, 2] = vd
        acc[i, 0] = an
        acc[i, 1] = ae
        acc[i, 2] = ad
        _truth_from_q(la, hi, vn, ve, vd, an, ae, ad, att[i, 0], att[i, 1], att[i, 2], att[i, 3], att[i, 4],
                      att[i, 5], att[i, 6], q, w, f, i)


# --- truth container --------------------------------------------------------------


@dataclass(frozen=True)
class TrajectoryTruth:
    """Navigation truth at a set of times (all arrays float64, SI units, rad).

    Attributes
    ----------
    t_s : ndarray (N,)
        Times (s).
    lat_rad, lon_rad, h_m : ndarray (N,)
        Geodetic latitude and longitude (rad, longitude in ``[-pi, pi)``),
        height above the ellipsoid (m).
    v_ned_m_s : ndarray (N, 3)
        Ground velocity in NED (m/s).
    a_ned_m_s2 : ndarray (N, 3)
        ``d v_ned / dt`` (m/s^2), derivative of the NED components.
    q_nv : ndarray (N, 4)
        Attitude, Hamilton, scalar first, vehicle body to NED; continuous in time.
    omega_iv_v_rad_s : ndarray (N, 3)
        Angular rate of the vehicle with respect to inertial space, vehicle axes (rad/s).
    f_v_m_s2 : ndarray (N, 3)
        Specific force in vehicle axes (m/s^2).
    """

    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    v_ned_m_s: np.ndarray
    a_ned_m_s2: np.ndarray
    q_nv: np.ndarray
    omega_iv_v_rad_s: np.ndarray
    f_v_m_s2: np.ndarray

    def __len__(self) -> int:
        return int(self.t_s.size)

    @property
    def euler_rad(self) -> np.ndarray:
        """Roll, pitch, yaw (rad), shape (N, 3), from ``q_nv`` (3-2-1; roll and yaw in ``(-pi, pi]``).

        ``roll = atan2(C32, C33)``, ``pitch = -asin(C31)``, ``yaw = atan2(C21, C11)``
        with ``C = C_nv`` ([1] sec. 3.6).
        """
        q0, q1, q2, q3 = (self.q_nv[:, j] for j in range(4))
        c11 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
        c21 = 2.0 * (q1 * q2 + q0 * q3)
        c31 = 2.0 * (q1 * q3 - q0 * q2)
        c32 = 2.0 * (q2 * q3 + q0 * q1)
        c33 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
        return np.stack((np.arctan2(c32, c33), -np.arcsin(np.clip(c31, -1.0, 1.0)), np.arctan2(c21, c11)), axis=-1)

    @classmethod
    def concatenate(cls, parts) -> TrajectoryTruth:
        """One :class:`TrajectoryTruth` from consecutive chunks (in the given order)."""
        parts = list(parts)
        if not parts:
            raise ValueError("TrajectoryTruth.concatenate.parts: must hold at least one chunk")
        return cls(**{name: np.concatenate([getattr(p, name) for p in parts])
                      for name in cls.__dataclass_fields__})


def _allocate(n):
    return dict(t_s=None, lat_rad=np.empty(n), lon_rad=np.empty(n), h_m=np.empty(n), v_ned_m_s=np.empty((n, 3)),
                a_ned_m_s2=np.empty((n, 3)), q_nv=np.empty((n, 4)), omega_iv_v_rad_s=np.empty((n, 3)),
                f_v_m_s2=np.empty((n, 3)))


def _eval_times(owner, t, after, end):
    """A 1-D finite non-decreasing time array inside ``[max(0, after), end]``."""
    arr = np.asarray(t, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{owner}.t: must be a 1-D array of times, got shape {arr.shape}")
    if arr.size == 0:
        return np.ascontiguousarray(arr)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{owner}.t: times must be finite")
    if arr.size > 1 and not np.all(np.diff(arr) >= 0.0):
        raise ValueError(f"{owner}.t: times must be non-decreasing")
    if arr[0] < 0.0:
        raise ValueError(f"{owner}.t: times must be >= 0, got {arr[0]!r}")
    if arr[0] < after:
        raise ValueError(f"{owner}.t: a stream moves forward only; times must be >= the last evaluated time "
                         f"{after!r}, got {arr[0]!r}")
    if arr[-1] > end:
        raise ValueError(f"{owner}.t: times must be <= duration_s = {end!r}, got {arr[-1]!r}")
    return np.ascontiguousarray(arr)


# --- segments -----------------------------------------------------------------------


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class Stationary:
    """At rest on the ground for ``duration_s`` (s): speed 0, attitude and position constant.

    The speed at the segment's start must be 0 (decelerate first).

    Parameters
    ----------
    duration_s : float
        Duration (s), > 0.
    """

    duration_s: float

    def __post_init__(self):
        _set(self, "duration_s", v.positive("Stationary", "duration_s", self.duration_s))


@dataclass(frozen=True)
class Cruise:
    """Constant velocity for ``duration_s`` (s): speed, heading and height held (a rhumb line).

    Parameters
    ----------
    duration_s : float
        Duration (s), > 0.
    """

    duration_s: float

    def __post_init__(self):
        _set(self, "duration_s", v.positive("Cruise", "duration_s", self.duration_s))


@dataclass(frozen=True)
class Accelerate:
    """Change the speed along track by ``delta_speed_m_s`` (m/s) in ``duration_s`` (s), level, heading held.

    The speed rate is ``A p(tau)`` with ``p`` the smooth trapezoid of the
    trajectory's ``transition_s`` ramps (see :class:`Trajectory`) and
    ``A = delta_speed_m_s / (duration_s - transition_s)``. The speed must stay >= 0.

    Parameters
    ----------
    duration_s : float
        Duration (s), >= 2 transition_s.
    delta_speed_m_s : float
        Speed change (m/s), signed.
    """

    duration_s: float
    delta_speed_m_s: float

    def __post_init__(self):
        _set(self, "duration_s", v.positive("Accelerate", "duration_s", self.duration_s))
        _set(self, "delta_speed_m_s", v.finite("Accelerate", "delta_speed_m_s", self.delta_speed_m_s))


@dataclass(frozen=True)
class CoordinatedTurn:
    """Level coordinated turn: heading changes by ``delta_heading_rad`` (rad, + = right) in ``duration_s`` (s).

    Heading rate ``psi' = r p(tau)``, ``r = delta_heading_rad / (duration_s - transition_s)``;
    bank ``phi = atan(V psi' / g)`` (right turn, right wing down), which keeps
    the specific force in the body x-z plane on a flat non-rotating Earth
    (the residual lateral force is the Coriolis/transport term and the
    difference between local gravity and the reference ``g`` of the bank,
    normal gravity at the start latitude and the turn's height). Speed and
    height are held. At speed 0 the vehicle pivots in place (bank 0).
    Also available as ``Turn`` in this module (``sins_sim.models.motion.Turn``
    is the block motion of :mod:`~sins_sim.models.motion.rotations`).

    Parameters
    ----------
    duration_s : float
        Duration (s), >= 2 transition_s.
    delta_heading_rad : float
        Heading change (rad), signed; may exceed 2 pi.
    """

    duration_s: float
    delta_heading_rad: float

    def __post_init__(self):
        _set(self, "duration_s", v.positive("CoordinatedTurn", "duration_s", self.duration_s))
        _set(self, "delta_heading_rad", v.finite("CoordinatedTurn", "delta_heading_rad", self.delta_heading_rad))


Turn = CoordinatedTurn


@dataclass(frozen=True)
class Climb:
    """Climb (or descend) by ``delta_height_m`` (m, + = up) in ``duration_s`` (s) at constant speed.

    The vertical speed is ``c p(tau)``, ``c = delta_height_m / (duration_s -
    transition_s)``, so the height change is exact; the flight-path angle is
    ``gamma = asin(c p / V)`` (it returns to 0 at the end). The pitch equals
    the flight-path angle (no angle of attack), the roll is 0. Needs a speed
    > 0 and ``|gamma| <= 60 deg``.

    Parameters
    ----------
    duration_s : float
        Duration (s), >= 2 transition_s.
    delta_height_m : float
        Height change (m), signed.
    """

    duration_s: float
    delta_height_m: float

    def __post_init__(self):
        _set(self, "duration_s", v.positive("Climb", "duration_s", self.duration_s))
        _set(self, "delta_height_m", v.finite("Climb", "delta_height_m", self.delta_height_m))


@dataclass(frozen=True)
class Hover:
    """Hover at the current height for ``duration_s`` (s): zero velocity, a small roll and pitch held.

    The speed at the segment's start must be 0 (decelerate first). Roll and pitch follow ``phi_h p(tau)`` and
    ``theta_h p(tau)`` with ``p`` the smooth trapezoid of the trajectory's ``transition_s`` ramps (see
    :class:`Trajectory`), so the attitude returns to level at the end; with a non-zero attitude the hover lasts at
    least ``2 transition_s``. A helicopter hovers with a roll of a few degrees (the main rotor's thrust tilted
    against the tail rotor's) and a pitch set by its c.g.; the kinematics impose zero velocity, so the specific
    force is ``f^v = -C_vn g^n`` (plus the Coriolis-free Earth terms of zero velocity): ``g`` resolved in the
    tilted body, ``[g sin theta, -g sin phi cos theta, -g cos phi cos theta]`` with ``g`` the local gravity
    ([1] sec. 3.5, 3.6).

    Parameters
    ----------
    duration_s : float
        Duration (s), > 0 (>= 2 transition_s with a non-zero attitude).
    roll_rad, pitch_rad : float
        Roll and pitch on the plateau (rad), ``|.| <=`` :data:`MAX_HOVER_ATTITUDE_RAD`.
    """

    duration_s: float
    roll_rad: float = 0.0
    pitch_rad: float = 0.0

    def __post_init__(self):
        _set(self, "duration_s", v.positive("Hover", "duration_s", self.duration_s))
        for name in ("roll_rad", "pitch_rad"):
            val = v.finite("Hover", name, getattr(self, name))
            if abs(val) > MAX_HOVER_ATTITUDE_RAD:
                raise ValueError(f"Hover.{name}: |{name}| must be <= {math.degrees(MAX_HOVER_ATTITUDE_RAD):g} deg "
                                 f"(a hover's attitude is a few degrees), got {math.degrees(val)!r} deg")
            _set(self, name, val)


@dataclass(frozen=True)
class Sideways:
    """Sideways flight from a hover: the velocity is perpendicular to the heading (+ = to the right).

    The speed to the right of the heading is ``u = U p(tau)``: it rises to ``lateral_speed_m_s`` over the first
    ``transition_s``, holds, and falls back to 0 over the last, so the segment starts and ends in a hover and
    moves ``U (duration_s - transition_s)`` metres sideways; heading and height are held. The bank balances the
    sideways acceleration, ``phi = atan(u' / g)`` (the tilted rotor's thrust supplies ``u'``), so the specific
    force stays in the body x-z plane on a flat non-rotating Earth, as in :class:`CoordinatedTurn`; no
    aerodynamic drag is modelled, so the bank is 0 on the plateau. Needs speed 0 at its start, the peak bank
    ``atan(max|u'| / g) <= 60 deg`` and the peak roll rate ``<= 1000 deg/s``.

    Parameters
    ----------
    duration_s : float
        Duration (s), >= 2 transition_s.
    lateral_speed_m_s : float
        Sideways speed on the plateau (m/s), signed (+ = right), ``|.| <=`` :data:`MAX_SIDEWAYS_SPEED_M_S`.
    """

    duration_s: float
    lateral_speed_m_s: float

    def __post_init__(self):
        _set(self, "duration_s", v.positive("Sideways", "duration_s", self.duration_s))
        u = v.finite("Sideways", "lateral_speed_m_s", self.lateral_speed_m_s)
        if abs(u) > MAX_SIDEWAYS_SPEED_M_S:
            raise ValueError(f"Sideways.lateral_speed_m_s: must be within +-{MAX_SIDEWAYS_SPEED_M_S:g} m/s, got {u!r}")
        _set(self, "lateral_speed_m_s", u)


def sideways_peaks(lateral_speed_m_s: float, transition_s: float, g_m_s2: float) -> tuple:
    """Peak bank (rad) and peak roll rate (rad/s) of a :class:`Sideways` segment.

    ``u' = U s'(x) / tr`` and ``u'' = U s''(x) / tr^2`` over a ramp (``x = tau / tr``, ``s`` the septic smoothstep
    of :func:`_ramp`); ``phi = atan(u' / g)``, ``phi' = g u'' / (g^2 + u'^2)``; both sampled at 4001 points of the
    ramp (the falling ramp mirrors it).
    """
    x = np.linspace(0.0, 1.0, 4001)
    y = x * (1.0 - x)
    du = lateral_speed_m_s * 140.0 * y ** 3 / transition_s
    ddu = lateral_speed_m_s * 420.0 * y * y * (1.0 - 2.0 * x) / (transition_s * transition_s)
    bank = float(np.max(np.abs(np.arctan2(du, g_m_s2))))
    rate = float(np.max(np.abs(g_m_s2 * ddu / (g_m_s2 * g_m_s2 + du * du))))
    return bank, rate


SEGMENT_TYPES = {
    "stationary": Stationary,
    "cruise": Cruise,
    "accelerate": Accelerate,
    "turn": CoordinatedTurn,
    "climb": Climb,
    "hover": Hover,
    "sideways": Sideways,
}
"""Segment type names (the ``type`` key of :func:`build_trajectory`) and their classes."""

_SEGMENT_NAMES = {cls: name for name, cls in SEGMENT_TYPES.items()}


# --- the segment trajectory ----------------------------------------------------------


@dataclass(frozen=True)
class Trajectory:
    """A flight made of segments, with closed-form kinematics and streamed position.

    The vehicle starts in steady level flight (or at rest) and each segment
    changes one quantity (speed, heading or height) and ends in steady level
    flight again. Time runs from 0 to :attr:`duration_s`.

    Parameters
    ----------
    start_lat_rad, start_lon_rad : float
        Initial geodetic latitude (rad, ``|lat| <= 89 deg``) and longitude (rad).
    start_h_m : float
        Initial height (m) in ``[-1000, 100000]``.
    start_speed_m_s : float
        Initial speed (m/s), >= 0.
    start_heading_rad : float
        Initial heading (rad, from north towards east).
    segments : sequence of Stationary, Cruise, Accelerate, CoordinatedTurn, Climb, Hover, Sideways
        Flown in order (at least one).
    transition_s : float
        Duration (s) of each smooth ramp, > 0 (default 4 s). Accelerate,
        CoordinatedTurn and Climb last at least ``2 transition_s``.

    Notes
    -----
    Smoothness. Each changing rate (speed rate, heading rate, vertical speed)
    follows ``amp p(tau)``: ``p`` rises from 0 to 1 over the first
    ``transition_s`` of the segment with the septic smoothstep
    ``s(x) = 35 x^4 - 84 x^5 + 70 x^6 - 20 x^7`` (``s', s'', s'''`` vanish at
    both ends), holds 1, and falls back to 0 over the last ``transition_s``;
    so ``p`` is C3 everywhere, including the segment boundaries. Then speed,
    heading and height are C4, the flight-path angle ``asin(h'/V)`` and the
    bank ``atan(V psi'/g)`` C3, velocity C3, acceleration C2, and the
    angular rate ``omega_iv_v`` and specific force ``f_v`` are C2 in time
    (their third derivatives jump where a ramp starts or ends).

    Attitude: yaw = heading, pitch = flight-path angle (no angle of attack
    and no sideslip: the body x axis lies along the velocity), roll = the
    coordinated bank of turns, 0 otherwise; a :class:`Hover` adds its eased
    roll and pitch, and :class:`Sideways` flies along the body y axis with
    the bank that balances its sideways acceleration.

    Position: height is the closed-form integral of the vertical speed;
    latitude and longitude integrate ``v_N / (R_N + h)`` and
    ``v_E / ((R_E + h) cos lat)`` ([1] sec. 3.7); see
    :class:`TrajectoryStream` for the method and its accuracy.

    Examples
    --------
    >>> import math
    >>> from sins_sim.models.motion.trajectory import Trajectory, Cruise, CoordinatedTurn, Climb
    >>> tr = Trajectory(math.radians(45.0), math.radians(7.0), 1000.0, 150.0, 0.0,
    ...                 [Cruise(30.0), CoordinatedTurn(60.0, math.radians(90.0)), Climb(60.0, 300.0)])
    >>> tr.duration_s
    150.0
    >>> truth = tr.evaluate([0.0, 60.0, 150.0])
    >>> round(float(truth.h_m[-1]), 6)
    1300.0
    """

    start_lat_rad: float
    start_lon_rad: float
    start_h_m: float
    start_speed_m_s: float
    start_heading_rad: float
    segments: tuple
    transition_s: float = DEFAULT_TRANSITION_S
    _table: np.ndarray = field(init=False, repr=False, compare=False, default=None)
    _info: tuple = field(init=False, repr=False, compare=False, default=())

    def __post_init__(self):
        own = "Trajectory"
        lat0 = v.finite(own, "start_lat_rad", self.start_lat_rad)
        if abs(lat0) > math.radians(89.0):
            raise ValueError(f"{own}.start_lat_rad: |latitude| must be <= 89 deg, got {math.degrees(lat0)!r} deg")
        lon0 = v.finite(own, "start_lon_rad", self.start_lon_rad)
        h0 = v.finite(own, "start_h_m", self.start_h_m)
        if not HEIGHT_RANGE_M[0] <= h0 <= HEIGHT_RANGE_M[1]:
            raise ValueError(f"{own}.start_h_m: must lie in [{HEIGHT_RANGE_M[0]}, {HEIGHT_RANGE_M[1]}] m, got {h0!r}")
        speed = v.non_negative(own, "start_speed_m_s", self.start_speed_m_s)
        psi = v.finite(own, "start_heading_rad", self.start_heading_rad)
        tr = v.positive(own, "transition_s", self.transition_s)
        segs = self.segments
        if isinstance(segs, (str, bytes, Mapping)) or not hasattr(segs, "__iter__"):
            raise ValueError(f"{own}.segments: must be a sequence of segments, got {type(segs).__name__}")
        segs = tuple(segs)
        if not segs:
            raise ValueError(f"{own}.segments: must hold at least one segment")
        for i, seg in enumerate(segs):
            if type(seg) not in _SEGMENT_NAMES:
                raise ValueError(f"{own}.segments[{i}]: must be one of Stationary, Cruise, Accelerate, "
                                 f"CoordinatedTurn, Climb, Hover, Sideways, got {type(seg).__name__}")
        for name, val in (("start_lat_rad", lat0), ("start_lon_rad", lon0), ("start_h_m", h0),
                          ("start_speed_m_s", speed), ("start_heading_rad", psi), ("transition_s", tr),
                          ("segments", segs)):
            _set(self, name, val)

        rows, info = [], []
        t0 = 0.0
        h = h0
        for i, seg in enumerate(segs):
            where = f"{own}.segments[{i}]"
            dur = seg.duration_s
            kind, amp = _KIND_CONSTANT, 0.0
            g_ref = float(earth.gravity_down(lat0, h))
            start = dict(speed=speed, heading=psi, h=h)
            extra = {}
            hover_att = (0.0, 0.0)
            if isinstance(seg, (Stationary, Hover, Sideways)):
                name = type(seg).__name__
                if speed != 0.0:
                    raise ValueError(f"{where}: {name} needs speed 0 at its start, got {speed!r} m/s "
                                     "(decelerate to 0 first)")
            if isinstance(seg, Hover) and (seg.roll_rad != 0.0 or seg.pitch_rad != 0.0):
                if dur < 2.0 * tr:
                    raise ValueError(f"{where}.duration_s: a hover with a roll or pitch must last >= 2 "
                                     f"transition_s = {2.0 * tr!r} s (the attitude eased in and out), got {dur!r}")
                kind, hover_att = _KIND_HOVER, (seg.roll_rad, seg.pitch_rad)
                extra = dict(roll=seg.roll_rad, pitch=seg.pitch_rad)
            elif isinstance(seg, Hover):
                extra = dict(roll=0.0, pitch=0.0)
            elif isinstance(seg, Sideways):
                if dur < 2.0 * tr:
                    raise ValueError(f"{where}.duration_s: must be >= 2 transition_s = {2.0 * tr!r} s "
                                     f"(ramp in and out), got {dur!r}")
                bank, roll_rate = sideways_peaks(seg.lateral_speed_m_s, tr, g_ref)
                if bank > MAX_SIDEWAYS_BANK_RAD:
                    raise ValueError(f"{where}.lateral_speed_m_s: the bank that balances the sideways acceleration, "
                                     f"{math.degrees(bank):.4g} deg at its peak, must be <= "
                                     f"{math.degrees(MAX_SIDEWAYS_BANK_RAD):g} deg; lengthen transition_s, got "
                                     f"{seg.lateral_speed_m_s!r}")
                if roll_rate > MAX_TURN_BODY_RATE_RAD_S:
                    raise ValueError(f"{where}.lateral_speed_m_s: the roll rate into the balancing bank "
                                     f"{math.degrees(roll_rate):.4g} deg/s must be <= "
                                     f"{math.degrees(MAX_TURN_BODY_RATE_RAD_S):g} deg/s; lengthen transition_s, got "
                                     f"{seg.lateral_speed_m_s!r}")
                kind, amp = _KIND_SIDEWAYS, seg.lateral_speed_m_s
                extra = dict(lateral_speed=amp, distance=amp * (dur - tr), bank=bank)
            elif isinstance(seg, (Accelerate, CoordinatedTurn, Climb)):
                if dur < 2.0 * tr:
                    raise ValueError(f"{where}.duration_s: must be >= 2 transition_s = {2.0 * tr!r} s "
                                     f"(ramp in and out), got {dur!r}")
                plateau = dur - tr
                if isinstance(seg, Accelerate):
                    kind, amp = _KIND_ACCELERATE, seg.delta_speed_m_s / plateau
                    end = speed + seg.delta_speed_m_s
                    if end < -1e-9 * max(1.0, speed):
                        raise ValueError(f"{where}.delta_speed_m_s: the speed would end at {end!r} m/s; "
                                         "it must stay >= 0")
                    speed = speed + amp * plateau
                    if abs(speed) <= 1e-9 * max(1.0, start["speed"]):
                        speed = 0.0
                    extra = dict(accel=amp)
                elif isinstance(seg, CoordinatedTurn):
                    kind, amp = _KIND_TURN, seg.delta_heading_rad / plateau
                    if abs(speed * amp) > MAX_TURN_ACCEL_M_S2:
                        raise ValueError(f"{where}.delta_heading_rad: the turn's centripetal acceleration V psi' = "
                                         f"{abs(speed * amp):.4g} m/s^2 must be <= {MAX_TURN_ACCEL_M_S2:g} m/s^2 "
                                         f"(about 200 g); lengthen duration_s, got {seg.delta_heading_rad!r}")
                    peak = turn_peak_body_rate(speed, amp, tr, g_ref)
                    if peak > MAX_TURN_BODY_RATE_RAD_S:
                        raise ValueError(f"{where}.delta_heading_rad: the turn's peak body rate (heading rate and the "
                                         f"roll rate into the coordinated bank) {math.degrees(peak):.4g} deg/s must "
                                         f"be <= {math.degrees(MAX_TURN_BODY_RATE_RAD_S):g} deg/s (the range of an "
                                         f"RLG); lengthen duration_s or transition_s, got {seg.delta_heading_rad!r}")
                    psi = psi + amp * plateau
                    extra = dict(rate=amp, bank=math.atan2(speed * amp, g_ref))
                else:
                    if speed <= 0.0:
                        raise ValueError(f"{where}: Climb needs a speed > 0 at its start, got {speed!r} m/s")
                    kind, amp = _KIND_CLIMB, seg.delta_height_m / plateau
                    if abs(amp) > speed * math.sin(MAX_FLIGHT_PATH_ANGLE_RAD):
                        gmax = math.degrees(math.asin(min(1.0, abs(amp) / speed)))
                        raise ValueError(f"{where}.delta_height_m: flight-path angle asin(climb rate / speed) = "
                                         f"{gmax:.6g} deg must be <= 60 deg; lengthen duration_s, got "
                                         f"{seg.delta_height_m!r}")
                    h = h + amp * plateau
                    if not HEIGHT_RANGE_M[0] <= h <= HEIGHT_RANGE_M[1]:
                        raise ValueError(f"{where}.delta_height_m: the height would end at {h!r} m, outside "
                                         f"[{HEIGHT_RANGE_M[0]}, {HEIGHT_RANGE_M[1]}] m")
                    extra = dict(climb_rate=amp, gamma=math.asin(amp / speed))
            rows.append([t0, dur, tr, kind, start["speed"], start["heading"], start["h"], amp, g_ref, *hover_att])
            info.append(dict(kind=_SEGMENT_NAMES[type(seg)], t0=t0, t1=t0 + dur, start=start,
                             end=dict(speed=speed, heading=psi, h=h), **extra))
            t0 = t0 + dur
        # The state after the last segment continues as a cruise (used only by the
        # integrator's last node, which may lie past the end).
        rows.append([t0, math.inf, tr, _KIND_CONSTANT, speed, psi, h, 0.0, float(earth.gravity_down(lat0, h)),
                     0.0, 0.0])
        table = np.ascontiguousarray(np.array(rows, dtype=np.float64))
        table.setflags(write=False)
        _set(self, "_table", table)
        _set(self, "_info", tuple(info))

    @property
    def duration_s(self) -> float:
        """Total duration (s), the sum of the segments' durations."""
        return float(self._table[-1, 0])

    @property
    def segment_start_s(self) -> np.ndarray:
        """Start time (s) of each segment, shape ``(len(segments),)``."""
        return np.array(self._table[:-1, 0])

    def describe(self) -> str:
        """A header line, then one line per segment: times, kind and what changes (deg, m, m/s).

        Returns
        -------
        str
        """
        d = math.degrees

        def hdg(x):  # heading in deg, (-180, 180]
            return -math.degrees(math.remainder(-x, 2.0 * math.pi))

        lines = [f"trajectory: start {d(self.start_lat_rad):.6f} deg lat, {d(self.start_lon_rad):.6f} deg lon, "
                 f"h {self.start_h_m:.1f} m, {self.start_speed_m_s:.1f} m/s, heading {hdg(self.start_heading_rad):.1f} "
                 f"deg; {len(self.segments)} segments, {self.duration_s:.1f} s, ramps {self.transition_s:g} s"]
        for i, s in enumerate(self._info):
            a, b = s["start"], s["end"]
            head = f"{i + 1:3d} {s['t0']:8.1f} - {s['t1']:8.1f} s  {s['kind']:<10s} "
            if s["kind"] == "stationary":
                body = f"at rest, heading {hdg(a['heading']):.1f} deg, h {a['h']:.1f} m"
            elif s["kind"] == "cruise":
                body = f"{a['speed']:.1f} m/s, heading {hdg(a['heading']):.1f} deg, h {a['h']:.1f} m"
            elif s["kind"] == "accelerate":
                body = f"{a['speed']:.1f} -> {b['speed']:.1f} m/s (peak {s['accel']:+.3f} m/s^2)"
            elif s["kind"] == "hover":
                body = (f"hover at h {a['h']:.1f} m, heading {hdg(a['heading']):.1f} deg, roll {d(s['roll']):+.1f} "
                        f"deg, pitch {d(s['pitch']):+.1f} deg")
            elif s["kind"] == "sideways":
                body = (f"sideways {s['lateral_speed']:+.1f} m/s ({s['distance']:+.1f} m, peak bank "
                        f"{d(s['bank']):.1f} deg), heading {hdg(a['heading']):.1f} deg, h {a['h']:.1f} m")
            elif s["kind"] == "turn":
                body = (f"heading {hdg(a['heading']):.1f} -> {hdg(b['heading']):.1f} deg "
                        f"(rate {d(s['rate']):+.3f} deg/s, bank {d(s['bank']):+.1f} deg) at {a['speed']:.1f} m/s")
            else:
                body = (f"h {a['h']:.1f} -> {b['h']:.1f} m (vertical speed {s['climb_rate']:+.2f} m/s, flight-path "
                        f"angle {d(s['gamma']):+.2f} deg) at {a['speed']:.1f} m/s")
            lines.append(head + body)
        return "\n".join(lines)

    def stream(self, step_s: float = DEFAULT_STEP_S) -> TrajectoryStream:
        """A :class:`TrajectoryStream` starting at ``t = 0`` (internal RK4 step ``step_s``, s)."""
        return TrajectoryStream(self, step_s)

    def evaluate(self, t, step_s: float = DEFAULT_STEP_S) -> TrajectoryTruth:
        """Truth at the non-decreasing times ``t`` (s, in ``[0, duration_s]``) from a fresh stream.

        Parameters
        ----------
        t : array_like, 1-D
            Times (s).
        step_s : float
            Internal RK4 step (s).

        Returns
        -------
        TrajectoryTruth
        """
        return self.stream(step_s).evaluate(t)


class TrajectoryStream:
    """Evaluate a :class:`Trajectory` chunk by chunk, forward in time, in constant memory.

    Parameters
    ----------
    trajectory : Trajectory
        The flight.
    step_s : float
        Internal integration step (s) in ``(0, 1]``; default 0.01 s.

    Notes
    -----
    Latitude and longitude solve ``lat' = v_N / (R_N(lat) + h)``,
    ``lon' = v_E / ((R_E(lat) + h) cos lat)`` with the classic fourth-order
    Runge-Kutta method on the fixed grid ``t_k = k step_s`` driven by the
    closed-form velocity and height; nodes are added with Neumaier
    compensated summation, so rounding does not accumulate. Between nodes the
    position is the cubic Hermite interpolant of the node values and RK4
    rates. Only the current interval is kept (12 numbers), whatever the
    mission length.

    Accuracy at the default 0.01 s: position within about 1e-9 m of a
    0.001 s integration after 30 min of manoeuvring flight (the test asserts
    < 1e-6 m): RK4's global error ``~ step^4`` and the Hermite interpolation
    error ``step^4 / 384 |d^4 p/dt^4|`` are both far below a micrometre for
    the smooth segment profiles.

    Chunking: every output depends only on its own time and on the node
    sequence, which is fixed by the grid, and the kernel is scalar code
    without fastmath; so the same times evaluated in one call or in any
    chunks give results identical to the last bit.

    Examples
    --------
    >>> import math, numpy as np
    >>> from sins_sim.models.motion.trajectory import Trajectory, Cruise, CoordinatedTurn
    >>> tr = Trajectory(0.8, 0.1, 500.0, 100.0, 0.0, [Cruise(10.0), CoordinatedTurn(20.0, math.pi / 2)])
    >>> s = tr.stream()
    >>> t = np.arange(0, 30001) / 1000.0
    >>> a, b = s.evaluate(t[:12345]), s.evaluate(t[12345:])
    >>> len(a) + len(b)
    30001
    """

    def __init__(self, trajectory: Trajectory, step_s: float = DEFAULT_STEP_S):
        if not isinstance(trajectory, Trajectory):
            raise ValueError(f"TrajectoryStream.trajectory: must be a Trajectory, got {type(trajectory).__name__}")
        step = v.positive("TrajectoryStream", "step_s", step_s)
        if step > 1.0:
            raise ValueError(f"TrajectoryStream.step_s: must be <= 1 s, got {step!r}")
        self.trajectory = trajectory
        self.step_s = step
        self._state = np.empty(_STATE_SIZE)
        _stream_init(trajectory._table, step, trajectory.start_lat_rad, trajectory.start_lon_rad, self._state)

    @property
    def t(self) -> float:
        """Last evaluated time (s); ``-1`` before the first call."""
        return float(self._state[11])

    def copy(self) -> TrajectoryStream:
        """An independent stream in the same state (a checkpoint to branch from)."""
        other = object.__new__(TrajectoryStream)
        other.trajectory = self.trajectory
        other.step_s = self.step_s
        other._state = self._state.copy()
        return other

    def evaluate(self, t) -> TrajectoryTruth:
        """Truth at the times ``t`` (s), which continue forward from the previous call.

        Parameters
        ----------
        t : array_like, 1-D
            Non-decreasing times (s) in ``[0, duration_s]``, none before the
            last time of the previous call. May be empty.

        Returns
        -------
        TrajectoryTruth

        Raises
        ------
        ValueError
            Times out of order or out of range, or a latitude beyond 89.5 deg.
        """
        t = _eval_times("TrajectoryStream.evaluate", t, max(0.0, self.t), self.trajectory.duration_s)
        out = _allocate(t.size)
        fail = _trajectory_run(self.trajectory._table, self.step_s, self._state, t, out["lat_rad"], out["lon_rad"],
                               out["h_m"], out["v_ned_m_s"], out["a_ned_m_s2"], out["q_nv"],
                               out["omega_iv_v_rad_s"], out["f_v_m_s2"])
        if fail >= 0:
            raise ValueError(f"TrajectoryStream.evaluate: the latitude passes {math.degrees(MAX_ABS_LAT_RAD)} deg "
                             f"before t = {t[fail]!r} s (the longitude rate is singular at the poles)")
        out["t_s"] = t.copy()
        return TrajectoryTruth(**out)


def build_trajectory(spec) -> Trajectory:
    """Build a :class:`Trajectory` from a dictionary (SI units, rad), e.g. from YAML.

    Parameters
    ----------
    spec : dict
        The keyword arguments of :class:`Trajectory`; ``segments`` is a list
        of ``{"type": name, **fields}`` with ``name`` a key of
        :data:`SEGMENT_TYPES` (``stationary``, ``cruise``, ``accelerate``,
        ``turn``, ``climb``, ``hover``, ``sideways``).

    Returns
    -------
    Trajectory

    Raises
    ------
    ValueError
        Unknown or missing keys, unknown segment types, or invalid values;
        the message names the key.

    Examples
    --------
    >>> tr = build_trajectory({"start_lat_rad": 0.7, "start_lon_rad": 0.2, "start_h_m": 300.0,
    ...                        "start_speed_m_s": 0.0, "start_heading_rad": 0.0,
    ...                        "segments": [{"type": "stationary", "duration_s": 60.0},
    ...                                     {"type": "accelerate", "duration_s": 20.0, "delta_speed_m_s": 30.0}]})
    >>> tr.duration_s
    80.0
    """
    if not isinstance(spec, Mapping):
        raise ValueError(f"trajectory: must be a mapping of Trajectory arguments, got {type(spec).__name__}")
    params = inspect.signature(Trajectory).parameters
    allowed = [k for k in params if not k.startswith("_")]
    for key in spec:
        if key not in allowed:
            raise ValueError(f"trajectory.{key}: unknown key; allowed: {sorted(allowed)}")
    for key in allowed:
        if params[key].default is inspect.Parameter.empty and key not in spec:
            raise ValueError(f"trajectory.{key}: required")
    raw = spec["segments"]
    if isinstance(raw, (str, bytes, Mapping)) or not isinstance(raw, (list, tuple)):
        raise ValueError("trajectory.segments: must be a list of {'type': ..., ...} entries, got "
                         f"{type(raw).__name__}")
    segs = []
    for i, entry in enumerate(raw):
        segs.append(build_typed(entry, SEGMENT_TYPES, f"trajectory.segments[{i}]", "segment type"))
    return Trajectory(**{**{k: spec[k] for k in spec if k != "segments"}, "segments": segs})


# --- sampled trajectory ----------------------------------------------------------------


def velocity_check_in_file_terms(message: str, where: str, tolerance_key: str) -> str:
    """A :class:`SampledTrajectory` refusal of its velocity check in a trajectory file's words: the row (1-based)
    and the column (``vn_m_s``, ``ve_m_s``, ``vd_m_s``) for the sample and component, ``tolerance_key`` for
    ``v_tol_m_s``, ``where`` (the file as the user named it) in front. Other messages are returned unchanged."""
    import re

    columns = ("vn_m_s", "ve_m_s", "vd_m_s")
    return re.sub(r"SampledTrajectory\.v_ned_m_s\[:, (\d)\]: sample (\d+) differs from the velocity of the smoothing "
                  r"fit of the positions by (\S+) m/s, beyond v_tol_m_s = (\S+) (and .*?\)) \((.*)\): the velocity "
                  r"does not fit the positions",
                  lambda m: f"{where}: row {int(m.group(2)) + 1}, column {columns[int(m.group(1))]}: "
                            f"differs from the velocity of the smoothing fit of the positions (lat_deg, lon_deg, "
                            f"height_m) by {m.group(3)} m/s, beyond {tolerance_key} = {m.group(4)} {m.group(5)} "
                            f"({m.group(6)}): the velocity columns do not fit the positions (another flight's, a sign "
                            "or a unit?)", message)


def _fmt3(xs) -> str:
    return "/".join(f"{x:.3g}" for x in xs)


def _fit_positions_velocities(t, lat, lon, h, pos, vel):
    """Position spline (a C2 piecewise quintic), the :class:`~sins_sim.models.motion.smoothing.SmoothFit` of the
    positions ``pos`` (dlat, dlon rad; h m) and NED velocities ``vel`` at times ``t`` (from the first sample), and
    the NED velocity of the fit of the positions alone at the samples.

    The fit runs in metres: the latitude and longitude offsets scaled by the radii at the first sample
    (``R_N + h``, ``(R_E + h) cos lat``), the height up; a velocity maps into these axes through the radii at
    its own sample (``lat' = v_N / (R_N + h)``, ``lon' = v_E / ((R_E + h) cos lat)``, ``h' = -v_D``). The noise
    estimates are bounded below by the rounding of the values as written (their decimals).
    """
    from sins_sim.models.motion.smoothing import fit_positions_velocities, quantisation_sigma, quintic_hermite

    r_n, r_e = earth.radii(lat)
    r_n0, r_e0 = earth.radii(lat[0])
    scale = np.array([r_n0 + h[0], (r_e0 + h[0]) * math.cos(lat[0]), 1.0])
    local = np.stack((r_n + h, (r_e + h) * np.cos(lat), np.ones_like(h)), axis=-1)  # m per fit unit, per sample
    vel_scale = scale / local
    deg = math.pi / 180.0
    p_min = [quantisation_sigma(lat, deg) * scale[0], quantisation_sigma(lon, deg) * scale[1],
             quantisation_sigma(h, 1.0)]
    v_min = [quantisation_sigma(vel[:, i], 1.0) for i in range(3)]
    sign = np.array([1.0, 1.0, -1.0])
    fit = fit_positions_velocities(t, pos * scale, vel * sign * vel_scale, vel_scale, p_min, v_min)
    v_positions = fit.v_positions / vel_scale * sign
    sigma_check = fit.sigma_check / vel_scale
    return quintic_hermite(t, fit.p / scale, fit.v / scale, fit.a / scale), fit, v_positions, sigma_check


def _unit_quaternion_and_rate(s, ds):
    """``q = s / |s|`` and ``omega_nv^v = 2 vec(q* (x) dq/dt)`` from the quaternion spline ``s`` and its derivative.

    ``dq/dt = (ds - q (q . ds)) / |s|`` (the derivative of the normalisation); the rate is the exact
    derivative of the attitude returned, so attitude and rate agree to rounding.
    """
    norm = np.linalg.norm(s, axis=1)
    q = s / norm[:, None]
    dq = (ds - q * np.einsum("ij,ij->i", q, ds)[:, None]) / norm[:, None]
    q0, qv = q[:, :1], q[:, 1:]
    d0, dv = dq[:, :1], dq[:, 1:]
    rate = 2.0 * (q0 * dv - d0 * qv - np.cross(qv, dv))  # vector part of conj(q) (x) dq
    return q, rate


def _continuous_quaternions(rot) -> np.ndarray:
    """The samples' ``q_nv`` (scalar first), signs chosen so that neighbours have a positive dot product."""
    xyzw = rot.as_quat()
    q = np.concatenate((xyzw[:, 3:], xyzw[:, :3]), axis=1)
    flip = np.einsum("ij,ij->i", q[1:], q[:-1]) < 0.0
    sign = np.concatenate(([1.0], np.where(np.cumsum(flip) % 2 == 1, -1.0, 1.0)))
    sign *= -1.0 if q[0, 0] < 0.0 else 1.0  # the first sample with q0 >= 0, as the Euler formula gives it
    return q * sign[:, None]


_SAMPLED_FIELDS = ("t_s", "lat_rad", "lon_rad", "h_m", "roll_rad", "pitch_rad", "yaw_rad")


@dataclass(frozen=True, eq=False)
class SampledTrajectory:
    """Truth interpolated through sampled positions and Euler angles.

    Parameters
    ----------
    t_s : array_like (N,)
        Sample times (s), strictly increasing, N >= 4. Time 0 of
        :meth:`evaluate` is the first sample (the original first time is
        kept as :attr:`time_offset_s`). Sampling need not be uniform.
    lat_rad, lon_rad, h_m : array_like (N,)
        Geodetic latitude (rad, ``|lat| <= 89.5 deg``), longitude (rad; unwrapped
        here) and height (m, in ``[-1000, 100000]``).
    roll_rad, pitch_rad, yaw_rad : array_like (N,)
        Euler angles (rad, 3-2-1); ``|pitch| < pi/2``; roll and yaw are
        unwrapped (a step of more than pi between samples is taken as a wrap).
    v_ned_m_s : array_like (N, 3), optional
        Sampled NED velocity (m/s), a measurement: with it the truth is the
        smoothing fit of positions and velocities (see Notes).
    v_tol_m_s : float
        A velocity component is refused where it differs from the velocity of
        the positions' own smoothing fit by more than ``v_tol_m_s`` (m/s,
        default 1) and :data:`CHECK_SIGMAS` standard deviations of that
        difference.

    Notes
    -----
    Interpolation ([4]): latitude and longitude offsets from the first
    sample (rad) and height (m) by one interpolating B-spline of degree 5
    (degree 3 when N < 6), with scipy's ``make_interp_spline`` default
    ("not-a-knot") ends. The attitude is interpolated on the rotations
    themselves, not angle by angle: the samples' ``C_nv`` (from the Euler
    angles) are joined by scipy's ``RotationSpline`` [5], which between
    neighbouring samples turns about a fixed axis through a rotation vector
    cubic in time, with the angular rate and acceleration continuous across
    the samples; ``omega_nv^v`` is the spline's own angular rate, so the rate
    and the attitude agree exactly. A constant body rate (any axis) is
    reproduced exactly, and roll and yaw wraps or Euler-angle corners cost
    nothing (per-angle splines put a 10 Hz coordinated-turn entry about 1.4
    arcsec off between the samples, see ``tests/test_trajectory.py``). Velocity and
    acceleration are the first and second derivatives of the position
    spline mapped through the radii of curvature,
    ``v_N = lat' (R_N + h)``, ``v_E = lon' (R_E + h) cos lat``, ``v_D = -h'``
    (and their exact time derivatives), so position, velocity and
    acceleration are mutually consistent and continuous; the rates come
    from the Euler-angle derivatives. ``f_v`` and ``omega_iv_v`` then follow
    exactly as for :class:`Trajectory` and are continuous in time (the rate
    C1 with a continuous angular acceleration; the specific force C1, C0
    with the cubic position spline of N < 6).

    With ``v_ned_m_s`` the position spline is replaced by the smoothing fit
    of positions and velocities of :mod:`sins_sim.models.motion.smoothing`
    (a C2 piecewise quintic through the RTS-smoothed position, velocity and
    acceleration at the samples; velocity and acceleration are still its
    derivatives, so the truth stays self-consistent). :attr:`fit` then holds
    the residuals (RMS per axis N/E/D), the noise levels and the check of the
    velocity against the positions' own fit; a component beyond the rule of
    ``v_tol_m_s`` raises ``ValueError`` naming the component and the sample.

    Accuracy is limited by the sampling and by the resolution of the
    samples: a position quantised to ``eps`` (m) at spacing ``dt`` (s)
    perturbs the acceleration by about ``6 eps / dt^2``, so a 10 Hz file
    needs positions to about 1e-8 m (1e-13 deg) for a few 1e-6 m/s^2.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(60) * 0.1
    >>> st = SampledTrajectory(t, 0.7 + 1e-6 * t, np.full(60, 0.1), np.full(60, 100.0),
    ...                        np.zeros(60), np.zeros(60), np.zeros(60))
    >>> round(float(st.evaluate([1.0]).v_ned_m_s[0, 0]), 3)  # 1e-6 rad/s of latitude, about 6.4 m/s
    6.362
    """

    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    yaw_rad: np.ndarray
    v_ned_m_s: np.ndarray | None = None
    v_tol_m_s: float = 1.0
    time_offset_s: float = field(init=False, default=0.0)
    fit: dict | None = field(init=False, default=None)
    _pos: object = field(init=False, repr=False, default=None)
    _att: object = field(init=False, repr=False, default=None)

    def __post_init__(self):
        own = "SampledTrajectory"
        arrs = {}
        for name in _SAMPLED_FIELDS:
            arrs[name] = v.finite_array(own, name, getattr(self, name))
        n = arrs["t_s"].size
        for name, arr in arrs.items():
            if arr.size != n:
                raise ValueError(f"{own}.{name}: must have the length of t_s ({n}), got {arr.size}")
        if n < 4:
            raise ValueError(f"{own}.t_s: needs at least 4 samples, got {n}")
        dt = np.diff(arrs["t_s"])
        if not np.all(dt > 0.0):
            i = int(np.flatnonzero(~(dt > 0.0))[0])
            raise ValueError(f"{own}.t_s: must be strictly increasing (sample {i + 1} is not after sample {i})")
        self._range(own, "lat_rad", arrs["lat_rad"], -MAX_ABS_LAT_RAD, MAX_ABS_LAT_RAD, "|lat| <= 89.5 deg")
        self._range(own, "h_m", arrs["h_m"], *HEIGHT_RANGE_M, "height in [-1000, 100000] m")
        pitch = arrs["pitch_rad"]
        bad = np.flatnonzero(np.abs(pitch) >= 0.5 * math.pi)
        if bad.size:
            raise ValueError(f"{own}.pitch_rad: |pitch| must be < pi/2 (sample {int(bad[0])}, got {pitch[bad[0]]!r})")
        vel = None
        if self.v_ned_m_s is not None:
            vel = v.finite_array(own, "v_ned_m_s", self.v_ned_m_s, ndim=2)
            if vel.shape != (n, 3):
                raise ValueError(f"{own}.v_ned_m_s: must have shape ({n}, 3), got {vel.shape}")
        tol = v.positive(own, "v_tol_m_s", self.v_tol_m_s)

        t = arrs["t_s"] - arrs["t_s"][0]
        lat0 = float(arrs["lat_rad"][0])
        lon_u = np.unwrap(arrs["lon_rad"])
        lon0 = float(lon_u[0])
        pos = np.stack((arrs["lat_rad"] - lat0, lon_u - lon0, arrs["h_m"]), axis=-1)
        k = 5 if n >= 6 else 3
        fit = None
        if vel is None:
            spl_p = make_interp_spline(t, pos, k=k)
        else:  # the velocity is a measurement too: a smoothing fit of both (sins_sim.models.motion.smoothing)
            spl_p, fit, v_positions, sigma_check = _fit_positions_velocities(t, arrs["lat_rad"], arrs["lon_rad"],
                                                                             arrs["h_m"], pos, vel)
        pos_splines = (spl_p, spl_p.derivative(1), spl_p.derivative(2))
        # attitude on SO(3): C_nv = R_z(yaw) R_y(pitch) R_x(roll) at the samples, interpolated as a rotation
        rot = Rotation.from_euler("ZYX", np.stack((arrs["yaw_rad"], pitch, arrs["roll_rad"]), axis=-1))
        spl_q = make_interp_spline(t, _continuous_quaternions(rot), k=k)
        att_splines = (spl_q, spl_q.derivative(1))
        for name, arr in arrs.items():
            arr = arr.copy()
            arr.setflags(write=False)
            _set(self, name, arr)
        if vel is not None:
            vel = vel.copy()
            vel.setflags(write=False)
        _set(self, "v_ned_m_s", vel)
        _set(self, "v_tol_m_s", tol)
        _set(self, "time_offset_s", float(arrs["t_s"][0]))
        _set(self, "_pos", (lat0, lon0, pos_splines))
        _set(self, "_att", att_splines)
        _set(self, "fit", None)
        if vel is not None:
            truth = self.evaluate(t)
            res_v = vel - truth.v_ned_m_s
            r_n, r_e = earth.radii(arrs["lat_rad"])
            res_p = np.stack(((arrs["lat_rad"] - truth.lat_rad) * (r_n + arrs["h_m"]),
                              np.angle(np.exp(1j * (arrs["lon_rad"] - truth.lon_rad))) * (r_e + arrs["h_m"])
                              * np.cos(arrs["lat_rad"]),
                              -(arrs["h_m"] - truth.h_m)), axis=-1)
            res_c = vel - v_positions  # the check: the measured velocity against the positions' own
            # beyond the tolerance and beyond what the file can tell (CHECK_SIGMAS standard deviations)
            excess = np.abs(res_c) - np.maximum(tol, CHECK_SIGMAS * sigma_check)
            worst = np.argmax(excess, axis=0)
            worst_c = np.abs(res_c[worst, np.arange(3)])
            worst_x = excess[worst, np.arange(3)]
            _set(self, "fit", {
                "method": "fixed-interval RTS smoother of positions and velocities, constant-acceleration (white "
                          "jerk) model (sins_sim.models.motion.smoothing)",
                "position_residual_rms_m": np.sqrt(np.mean(res_p ** 2, axis=0)).tolist(),
                "velocity_residual_rms_m_s": np.sqrt(np.mean(res_v ** 2, axis=0)).tolist(),
                "velocity_residual_max_m_s": np.max(np.abs(res_v), axis=0).tolist(),
                "velocity_vs_positions_rms_m_s": np.sqrt(np.mean(res_c ** 2, axis=0)).tolist(),
                "velocity_vs_positions_max_m_s": np.max(np.abs(res_c), axis=0).tolist(),
                "position_noise_m": fit.sigma_p.tolist(), "velocity_noise_m_s": fit.sigma_v.tolist(),
                "jerk_psd_m2_s5": fit.q.tolist(), "velocity_tolerance_m_s": tol})
            axis = int(np.argmax(worst_x))
            if worst_x[axis] > 0.0:
                k = int(worst[axis])
                raise ValueError(f"{own}.v_ned_m_s[:, {axis}]: sample {k} differs from the velocity of the smoothing "
                                 f"fit of the positions by {res_c[k, axis]:.6g} m/s, beyond v_tol_m_s = {tol!r} "
                                 f"and {CHECK_SIGMAS:g} standard deviations of the difference "
                                 f"({sigma_check[k, axis]:.3g} m/s: the velocity noise and the fit's uncertainty) "
                                 f"(RMS over the file N/E/D {_fmt3(self.fit['velocity_vs_positions_rms_m_s'])} m/s): "
                                 "the velocity does not fit the positions")

    @staticmethod
    def _range(own, name, arr, lo, hi, rule):
        bad = np.flatnonzero((arr < lo) | (arr > hi))
        if bad.size:
            raise ValueError(f"{own}.{name}: must satisfy {rule} (sample {int(bad[0])}, got {arr[bad[0]]!r})")

    @classmethod
    def from_data(cls, data, v_tol_m_s: float = 1.0) -> SampledTrajectory:
        """Build from a :class:`sins_sim.io.TrajectoryData` or any object/mapping with its fields.

        Parameters
        ----------
        data : object or Mapping
            Has ``t_s, lat_rad, lon_rad, h_m, roll_rad, pitch_rad, yaw_rad``
            (arrays, SI/rad) and optionally ``v_ned_m_s`` ((N, 3) or None),
            as attributes or keys.
        v_tol_m_s : float
            As in the constructor (m/s).

        Returns
        -------
        SampledTrajectory
        """
        get = (lambda k, d=None: data.get(k, d)) if isinstance(data, Mapping) else (
            lambda k, d=None: getattr(data, k, d))
        missing = [k for k in _SAMPLED_FIELDS if get(k) is None]
        if missing:
            raise ValueError(f"SampledTrajectory.from_data.data: lacks {missing} (needs {list(_SAMPLED_FIELDS)} "
                             "and optionally v_ned_m_s)")
        return cls(*(get(k) for k in _SAMPLED_FIELDS), v_ned_m_s=get("v_ned_m_s"), v_tol_m_s=v_tol_m_s)

    @property
    def duration_s(self) -> float:
        """Time span (s) of the samples: evaluation times lie in ``[0, duration_s]``."""
        return float(self.t_s[-1] - self.t_s[0])

    def describe(self) -> str:
        """One line: samples, span, mean rate, and start/end position (deg, m)."""
        d = math.degrees
        n = self.t_s.size
        return (f"sampled trajectory: {n} samples over {self.duration_s:.3f} s (mean {(n - 1) / self.duration_s:.3g} "
                f"Hz), from {d(self.lat_rad[0]):.6f}, {d(self.lon_rad[0]):.6f} deg, h {self.h_m[0]:.1f} m to "
                f"{d(self.lat_rad[-1]):.6f}, {d(self.lon_rad[-1]):.6f} deg, h {self.h_m[-1]:.1f} m; "
                + ("velocity from the position spline" if self.fit is None else
                   "truth from a smoothing fit of positions and velocities, RMS residuals N/E/D: position "
                   f"{_fmt3(self.fit['position_residual_rms_m'])} m, velocity "
                   f"{_fmt3(self.fit['velocity_residual_rms_m_s'])} m/s"))

    def stream(self) -> SampledTrajectoryStream:
        """A forward-only :class:`SampledTrajectoryStream` (the interface of :class:`TrajectoryStream`)."""
        return SampledTrajectoryStream(self)

    def evaluate(self, t) -> TrajectoryTruth:
        """Truth at the non-decreasing times ``t`` (s since the first sample, in ``[0, duration_s]``).

        Stateless: any call may start anywhere. Each output depends only on
        its own time, so chunked and whole-array evaluations are identical to
        the last bit.

        Parameters
        ----------
        t : array_like, 1-D
            Times (s).

        Returns
        -------
        TrajectoryTruth
        """
        t = _eval_times("SampledTrajectory.evaluate", t, 0.0, self.duration_s)
        return self._evaluate(t)

    def _evaluate(self, t):
        lat0, lon0, (sp, sp1, sp2) = self._pos
        sq, sq1 = self._att
        n = t.size
        pos = np.empty((n, 9))
        att = np.empty((n, 7))
        if n:
            pos[:, 0::3] = sp(t)
            pos[:, 1::3] = sp1(t)
            pos[:, 2::3] = sp2(t)
            att[:, :4], att[:, 4:] = _unit_quaternion_and_rate(sq(t), sq1(t))
        out = _allocate(n)
        _sampled_run(lat0, lon0, pos, att, out["lat_rad"], out["lon_rad"], out["h_m"], out["v_ned_m_s"],
                     out["a_ned_m_s2"], out["q_nv"], out["omega_iv_v_rad_s"], out["f_v_m_s2"])
        out["t_s"] = t.copy()
        return TrajectoryTruth(**out)


class SampledTrajectoryStream:
    """Forward-only view of a :class:`SampledTrajectory` with the interface of :class:`TrajectoryStream`.

    Parameters
    ----------
    trajectory : SampledTrajectory
        The sampled trajectory.
    """

    def __init__(self, trajectory: SampledTrajectory):
        if not isinstance(trajectory, SampledTrajectory):
            raise ValueError("SampledTrajectoryStream.trajectory: must be a SampledTrajectory, got "
                             f"{type(trajectory).__name__}")
        self.trajectory = trajectory
        self._t = -1.0

    @property
    def t(self) -> float:
        """Last evaluated time (s); ``-1`` before the first call."""
        return self._t

    def copy(self) -> SampledTrajectoryStream:
        """An independent stream at the same time."""
        other = SampledTrajectoryStream(self.trajectory)
        other._t = self._t
        return other

    def evaluate(self, t) -> TrajectoryTruth:
        """Truth at times ``t`` (s) continuing forward from the previous call.

        See :meth:`SampledTrajectory.evaluate`; times must not go back.
        """
        t = _eval_times("SampledTrajectoryStream.evaluate", t, max(0.0, self._t), self.trajectory.duration_s)
        out = self.trajectory._evaluate(t)
        if t.size:
            self._t = float(t[-1])
        return out
