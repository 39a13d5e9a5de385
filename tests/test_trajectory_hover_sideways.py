"""Hover and sideways-flight segments: the truth's kinematics, specific force and rates against closed forms.

A hover holds zero velocity with an eased roll and pitch; sideways flight moves along the body y axis with the
bank that balances its acceleration, ``phi = atan(u' / g)`` (Titterton & Weston 2004, sec. 3.5-3.6). The truth's
specific force ``f^v = C_vn (a + (2 omega_ie + omega_en) x v - g^n)`` and rate ``omega_iv^v = omega_nv^v +
C_vn omega_in^n`` are recomputed here from the closed-form motion with :mod:`sins_sim.earth` (not the kernel's
inline Earth terms) and from :mod:`scipy.spatial.transform` for the attitude.
"""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sins_sim import earth
from sins_sim.models.motion import Hover, Sideways, Stationary, Trajectory, build_trajectory

LAT, LON, H = math.radians(52.0), math.radians(4.5), 300.0
PSI = math.radians(40.0)
TR = 4.0
# float64 closed forms against the kernel: every quantity is O(10) in SI units and a few tens of operations
# deep, so a rounding budget of 1e-11 (about 1e5 ulp of 10) bounds them with a wide margin; the kernel and the
# test share only the trajectory's position (lat, h).
TOL_F = 1e-10  # m/s^2
TOL_W = 1e-12  # rad/s (rates are O(1e-1) at most)


def _c_vn(q):
    """C_vn (NED -> body) per sample from q_nv (scalar first) with scipy (scalar last)."""
    return Rotation.from_quat(np.asarray(q)[:, [1, 2, 3, 0]]).as_matrix().transpose(0, 2, 1)


def _expected(truth, a_ned, omega_nv_v):
    """The closed-form specific force and inertial rate of the sampled truth (Titterton & Weston sec. 3.5)."""
    c_vn = _c_vn(truth.q_nv)
    f = np.empty((len(truth), 3))
    w = np.empty((len(truth), 3))
    for i in range(len(truth)):
        lat, h, v = truth.lat_rad[i], truth.h_m[i], truth.v_ned_m_s[i]
        w_ie = earth.earth_rate_ned(lat)
        w_en = earth.transport_rate_ned(lat, h, v)
        f[i] = c_vn[i] @ (a_ned[i] + np.cross(2.0 * w_ie + w_en, v) - earth.gravity_ned(lat, h))
        w[i] = omega_nv_v[i] + c_vn[i] @ (w_ie + w_en)
    return f, w


def _ramp(x):
    """Septic smoothstep s, s', s'' on [0, 1] (the profile of Trajectory's ramps)."""
    s = x ** 4 * (35.0 - 84.0 * x + 70.0 * x ** 2 - 20.0 * x ** 3)
    ds = 140.0 * (x * (1.0 - x)) ** 3
    dds = 420.0 * (x * (1.0 - x)) ** 2 * (1.0 - 2.0 * x)
    return s, ds, dds


def test_hover_specific_force_and_rates_closed_form():
    roll, pitch, dur = math.radians(3.0), math.radians(-2.0), 30.0
    tr = Trajectory(LAT, LON, H, 0.0, PSI, (Stationary(5.0), Hover(dur, roll, pitch), Stationary(5.0)), TR)
    t = np.linspace(5.0, 5.0 + dur, 301)
    truth = tr.evaluate(t)
    tau = t - 5.0
    x = np.where(tau < TR, tau / TR, np.where(tau > dur - TR, (dur - tau) / TR, 1.0))
    s, ds, _ = _ramp(np.clip(x, 0.0, 1.0))
    sign = np.where(tau > dur - TR, -1.0, 1.0)
    phi, dphi = roll * s, roll * ds / TR * sign
    theta, dtheta = pitch * s, pitch * ds / TR * sign
    # attitude: yaw held, roll and pitch eased (Euler 3-2-1)
    eul = Rotation.from_quat(truth.q_nv[:, [1, 2, 3, 0]]).as_euler("ZYX")
    np.testing.assert_allclose(eul[:, 2], phi, atol=1e-13)
    np.testing.assert_allclose(eul[:, 1], theta, atol=1e-13)
    np.testing.assert_allclose(eul[:, 0], PSI, atol=1e-13)
    # zero velocity, position and height held
    assert np.max(np.abs(truth.v_ned_m_s)) == 0.0 and np.max(np.abs(truth.a_ned_m_s2)) == 0.0
    assert np.all(truth.h_m == H) and np.all(truth.lat_rad == truth.lat_rad[0])
    # omega_nv^v of the Euler rates with psi' = 0 (Titterton & Weston sec. 3.6)
    w_nv = np.stack([dphi, dtheta * np.cos(phi), -dtheta * np.sin(phi)], axis=1)
    f, w = _expected(truth, np.zeros((t.size, 3)), w_nv)
    np.testing.assert_allclose(truth.f_v_m_s2, f, rtol=0, atol=TOL_F)
    np.testing.assert_allclose(truth.omega_iv_v_rad_s, w, rtol=0, atol=TOL_W)
    # on the plateau: g resolved in the tilted body, [g sin theta, -g sin phi cos theta, -g cos phi cos theta]
    g = earth.gravity_down(LAT, H)
    mid = np.abs(tau - dur / 2) < 1.0
    want = np.array([g * math.sin(pitch), -g * math.sin(roll) * math.cos(pitch), -g * math.cos(roll) * math.cos(pitch)])
    np.testing.assert_allclose(truth.f_v_m_s2[mid], np.broadcast_to(want, (mid.sum(), 3)), rtol=0, atol=TOL_F)


def test_sideways_velocity_bank_specific_force_and_rates():
    u_max, dur = 8.0, 24.0
    tr = Trajectory(LAT, LON, H, 0.0, PSI, (Hover(3.0), Sideways(dur, u_max), Hover(3.0)), TR)
    t = np.linspace(3.0, 3.0 + dur, 481)
    truth = tr.evaluate(t)
    tau = t - 3.0
    fall = tau > dur - TR
    x = np.clip(np.where(tau < TR, tau / TR, np.where(fall, (dur - tau) / TR, 1.0)), 0.0, 1.0)
    s, ds, dds = _ramp(x)
    sgn = np.where(fall, -1.0, 1.0)
    u, du, ddu = u_max * s, u_max * ds / TR * sgn, u_max * dds / TR ** 2
    right = np.array([-math.sin(PSI), math.cos(PSI), 0.0])  # the unit vector to the right of the heading
    np.testing.assert_allclose(truth.v_ned_m_s, u[:, None] * right, rtol=0, atol=1e-12)
    np.testing.assert_allclose(truth.a_ned_m_s2, du[:, None] * right, rtol=0, atol=1e-12)
    g_ref = earth.gravity_down(LAT, H)
    phi = np.arctan2(du, g_ref)
    dphi = g_ref * ddu / (g_ref ** 2 + du ** 2)
    eul = Rotation.from_quat(truth.q_nv[:, [1, 2, 3, 0]]).as_euler("ZYX")
    np.testing.assert_allclose(eul[:, 2], phi, atol=1e-13)
    np.testing.assert_allclose(eul[:, 1], 0.0, atol=1e-13)
    np.testing.assert_allclose(eul[:, 0], PSI, atol=1e-13)
    f, w = _expected(truth, du[:, None] * right, np.stack([dphi, 0 * dphi, 0 * dphi], axis=1))
    np.testing.assert_allclose(truth.f_v_m_s2, f, rtol=0, atol=TOL_F)
    np.testing.assert_allclose(truth.omega_iv_v_rad_s, w, rtol=0, atol=TOL_W)
    # the balance: no body-y specific force but the Earth's terms: the Coriolis force 2 Omega |v| (<= 1.2e-3
    # m/s^2 at 8 m/s), the transport term |v|^2 / R (1e-5) and local against reference gravity at the sampled
    # height (the height is held: 0), so |f_y| <= 2 Omega u_max + u_max^2 / 6.3e6
    bound = 2.0 * earth.EARTH_RATE_RAD_S * u_max + u_max ** 2 / 6.3e6
    assert np.max(np.abs(truth.f_v_m_s2[:, 1])) <= bound
    assert np.max(np.abs(truth.f_v_m_s2[:, 1])) > 0.1 * bound  # the Coriolis term is there (not a zeroed output)


def test_sideways_moves_the_distance_at_the_held_heading_and_height():
    u_max, dur = -6.0, 40.0
    tr = Trajectory(LAT, LON, H, 0.0, PSI, (Sideways(dur, u_max), Hover(2.0)), TR)
    truth = tr.evaluate(np.array([0.0, dur]))
    r_n, r_e = earth.radii(LAT)
    dn = (truth.lat_rad[1] - truth.lat_rad[0]) * (r_n + H)
    de = (truth.lon_rad[1] - truth.lon_rad[0]) * (r_e + H) * math.cos(LAT)
    want = u_max * (dur - TR)  # U (duration - transition): the profile's integral
    # the flat-Earth projection of a 216 m displacement: relative error ~ d / R (3e-5), i.e. < 1e-2 m; the RK4
    # position integration at 100 Hz adds < 1e-9 m
    np.testing.assert_allclose([dn, de], [-want * math.sin(PSI), want * math.cos(PSI)], rtol=0, atol=1e-2)
    assert np.all(truth.h_m == H)
    assert "sideways -6.0 m/s (-216.0 m" in tr.describe()


@pytest.mark.parametrize("segments, match", [
    ([{"type": "cruise", "duration_s": 10.0}, {"type": "hover", "duration_s": 10.0}], "Hover needs speed 0"),
    ([{"type": "sideways", "duration_s": 6.0, "lateral_speed_m_s": 5.0}], "must be >= 2 transition_s"),
    ([{"type": "sideways", "duration_s": 20.0, "lateral_speed_m_s": 49.0}], "balances the sideways acceleration"),
    ([{"type": "hover", "duration_s": 5.0, "roll_rad": 0.05}], "a hover with a roll or pitch must last"),
])
def test_refusals_name_the_field(segments, match):
    spec = {"start_lat_rad": LAT, "start_lon_rad": LON, "start_h_m": H, "start_speed_m_s": 10.0 if
            segments[0]["type"] == "cruise" else 0.0, "start_heading_rad": PSI, "transition_s": TR,
            "segments": segments}
    with pytest.raises(ValueError, match=match):
        build_trajectory(spec)


def test_hover_attitude_bound():
    with pytest.raises(ValueError, match=r"Hover.roll_rad: \|roll_rad\| must be <= 30 deg"):
        Hover(10.0, math.radians(31.0))
    with pytest.raises(ValueError, match="Sideways.lateral_speed_m_s: must be within"):
        Sideways(20.0, 51.0)
