"""The strapdown's Coriolis and transport terms against the closed form of constant-velocity flight.

A vehicle flies level at constant height and constant ground speed, its body axes fixed to the local-level frame
(heading along its track):

- due east along a parallel: latitude constant, ``lon(t) = lon0 + v t / ((R_E + h) cos lat)``;
- due north along a meridian: ``dlat/dt = v / (R_N(lat) + h)``, integrated to 1e-14 rad (the meridian arc of the
  ellipsoid has no elementary inverse).

The exact sensor outputs of that motion follow from the navigation equation (Titterton & Weston 2004, sec. 3.7):
the body turns with the local-level frame, ``omega_ib = omega_ie + omega_en`` (Earth rate plus transport rate,
resolved in body axes), and the accelerometers measure ``f = dv/dt + (2 omega_ie + omega_en) x v - g`` with
``dv/dt = 0``: the Coriolis, the centripetal (transport) and the gravity terms, all from ``sins_sim.earth``. The
increments are their integrals over each sample (constant on the parallel; 5-point Gauss-Legendre of the closed
form on the meridian, exact to ~(dt / 1 h)^10).

Error budget of the navigator (two-sample coning and sculling, one update per sample, dt = 10 ms, 600 s):

- constant body rate and specific force: the coning and sculling sums vanish, and the attitude update
  ``q(-zeta) q q(alpha)`` is exact (``alpha`` and ``zeta`` are the same rotation); the specific-force
  increment misses third-order terms, ``|zeta|^2 |f| T / 4 ~ (1e-6)^2 10 0.01 / 4 = 2.5e-14`` m/s per update,
  5e-10 m/s and 1e-7 m after 60000 updates (x 1.6 for the unstable vertical channel, ``cosh(600 / 570)``);
- the rates at the mid-interval (extrapolated latitude): on the meridian their error is second order in the
  latitude step (3e-7 rad): ~1e-14 relative per update;
- rounding of the latitude (ulp 1.1e-16 rad at 45 deg) accumulated over 60000 updates: at most 7e-12 rad,
  4e-5 m, if every update rounded the same way.

So 1 mm bounds the position (25 x the worst-case rounding), 1e-6 m/s the velocity and 1e-9 rad the attitude.
A Coriolis term without its factor 2 misplaces the vehicle by about ``|omega_ie x v| t^2 / 2`` (2.6 km here) and
a transport rate of the wrong sign by more (its tilt feeds gravity into the horizontal channels): both millions of
times the bound (asserted below from the closed forms).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sins_sim import earth
from sins_sim.navigation.strapdown import StrapdownNavigator

LAT0, LON0, H0 = math.radians(45.0), math.radians(10.0), 1000.0
SPEED = 200.0           # m/s
DT = 0.01               # s
DURATION = 600.0        # s
N_STEPS = int(round(DURATION / DT))
POS_BOUND_M = 1e-3
VEL_BOUND_M_S = 1e-6
ATT_BOUND_RAD = 1e-9
GAUSS_X, GAUSS_W = np.polynomial.legendre.leggauss(5)


def _heading_quat(heading):
    """Body to NED for a level vehicle heading ``heading`` (rotation about down)."""
    return np.array([math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2)])


def _rates_and_force(lat, v_ned, h=H0):
    """``omega_ie + omega_en`` and ``(2 omega_ie + omega_en) x v - g`` in NED at latitude ``lat`` (arrays ok)."""
    w_ie = earth.earth_rate_ned(lat)
    w_en = earth.transport_rate_ned(lat, h, v_ned)
    f = np.cross(2.0 * w_ie + w_en, v_ned) - earth.gravity_ned(lat, h)
    return w_ie + w_en, f


def _navigate(dtheta, dv, v_ned, heading):
    nav = StrapdownNavigator(LAT0, LON0, H0, v_ned, _heading_quat(heading), DT)
    return nav.process(dtheta, dv)


def _attitude_error(q, heading):
    """Rotation angle (rad) between each ``q`` and the level attitude at ``heading``: twice the norm of the vector
    part of ``conj(q0) (x) q`` (resolves 1e-16 rad, where an arccos of the dot product resolves only 1e-8)."""
    c, s = math.cos(heading / 2), math.sin(heading / 2)  # conj(q0) = (c, 0, 0, -s)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    vec = np.stack([c * x + s * y, c * y - s * x, c * z - s * w], axis=-1)
    return 2.0 * np.linalg.norm(vec, axis=-1)


def _east_increments():
    v = np.array([0.0, SPEED, 0.0])
    w, f = _rates_and_force(LAT0, v)
    heading = 0.5 * math.pi
    dth = earth.level_body_from_ned(w, heading) * DT
    dvel = earth.level_body_from_ned(f, heading) * DT
    return np.tile(dth, (N_STEPS, 1)), np.tile(dvel, (N_STEPS, 1)), v, heading


def _meridian_truth():
    """Latitude along the meridian (dense), from ``dlat/dt = v / (R_N + h)``."""
    def rhs(_, y):
        r_n, _ = earth.radii(y[0])
        return [SPEED / (r_n + H0)]
    sol = solve_ivp(rhs, (0.0, DURATION), [LAT0], method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)
    assert sol.success
    return sol.sol


def _north_increments(lat_of_t):
    v = np.array([SPEED, 0.0, 0.0])
    t_end = (np.arange(N_STEPS) + 1) * DT
    nodes = (t_end[:, None] - DT) + 0.5 * DT * (GAUSS_X[None, :] + 1.0)
    lat = lat_of_t(nodes.ravel())[0]
    w, f = _rates_and_force(lat, np.broadcast_to(v, (lat.size, 3)))
    weights = 0.5 * DT * GAUSS_W
    dth = np.einsum("k,nkj->nj", weights, w.reshape(N_STEPS, GAUSS_X.size, 3))
    dvel = np.einsum("k,nkj->nj", weights, f.reshape(N_STEPS, GAUSS_X.size, 3))
    return dth, dvel, v, 0.0  # heading north: body axes are NED


def test_due_east_along_a_parallel():
    dth, dvel, v, heading = _east_increments()
    sol = _navigate(dth, dvel, v, heading)
    t = sol.t_s
    r_n, r_e = earth.radii(LAT0)
    lon_true = LON0 + SPEED * t / ((r_e + H0) * math.cos(LAT0))
    dn, de, _ = earth.horizontal_error_m(sol.lat_rad, sol.lon_rad, np.full_like(t, LAT0), lon_true, H0)
    assert np.max(np.abs(dn)) < POS_BOUND_M
    assert np.max(np.abs(de)) < POS_BOUND_M
    assert np.max(np.abs(sol.h_m - H0)) < POS_BOUND_M
    assert np.max(np.abs(sol.v_ned_m_s - v)) < VEL_BOUND_M_S
    assert np.max(_attitude_error(sol.q_nb, heading)) < ATT_BOUND_RAD
    assert t[-1] == pytest.approx(DURATION)


def test_due_north_along_a_meridian():
    lat_of_t = _meridian_truth()
    dth, dvel, v, heading = _north_increments(lat_of_t)
    sol = _navigate(dth, dvel, v, heading)
    lat_true = lat_of_t(sol.t_s)[0]
    assert lat_true[-1] - LAT0 == pytest.approx(SPEED * DURATION / (earth.radii(LAT0)[0] + H0), rel=1e-3)
    dn, de, _ = earth.horizontal_error_m(sol.lat_rad, sol.lon_rad, lat_true, np.full_like(lat_true, LON0), H0)
    assert np.max(np.abs(dn)) < POS_BOUND_M
    assert np.max(np.abs(de)) < POS_BOUND_M
    assert np.max(np.abs(sol.h_m - H0)) < POS_BOUND_M
    assert np.max(np.abs(sol.v_ned_m_s - v)) < VEL_BOUND_M_S
    assert np.max(_attitude_error(sol.q_nb, heading)) < ATT_BOUND_RAD


def test_the_bound_is_far_below_what_a_wrong_coriolis_or_transport_term_does():
    """The position a wrong term would give, from the closed forms over 600 s (short against the 84 min Schuler
    period: ``(1 - cos(w_s t)) / (w_s^2 t^2 / 2) = 0.95``, so ``a t^2 / 2`` is within 5 % of the drift):

    - Coriolis without its factor 2 leaves out ``omega_ie x v`` (1.0e-2 m/s^2 flying east at 45 deg);
    - the transport rate with its sign flipped doubles it in the Coriolis term, ``2 omega_en x v``
      (``2 v^2 / R``, 1.3e-2 m/s^2), before the tilt it causes (``2 v / R`` rad/s) feeds gravity in.
    """
    w_s = float(earth.schuler_rate_rad_s(LAT0, H0))
    schuler = (1.0 - math.cos(w_s * DURATION)) / (0.5 * (w_s * DURATION) ** 2)
    assert schuler > 0.9
    for v in (np.array([0.0, SPEED, 0.0]), np.array([SPEED, 0.0, 0.0])):
        w_ie = earth.earth_rate_ned(LAT0)
        w_en = earth.transport_rate_ned(LAT0, H0, v)
        for wrong in (np.cross(w_ie, v), 2.0 * np.cross(w_en, v)):
            horiz = np.hypot(wrong[0], wrong[1])
            drift = 0.5 * (horiz if horiz > 0 else abs(wrong[2])) * DURATION ** 2 * schuler
            assert drift > 1e5 * POS_BOUND_M, (v, wrong)
