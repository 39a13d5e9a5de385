"""Tests of the strapdown mechanization (``sins_sim.navigation.strapdown``): closed forms of the
stationary INS, the Schuler loop, the vertical channel and the sculling error, bit-exact streaming,
a slow numpy reference of the kernel, and input validation.

Every input here is exact: at rest (and in the Schuler tests) the body rate and specific force are
constant, so ``dtheta = omega dt`` and ``dv = f dt`` hold exactly; the vibrating body of the sculling
test has increments from 8-point Gauss-Legendre quadrature of smooth trigonometric integrands
(relative quadrature error < 1e-15 for the at most 0.63 rad of phase per interval); the smooth
motion of the ``n_sub`` and streaming tests has closed-form integrals of sines.
Tolerances are stated next to each assertion with the reason for their size.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.optimize import curve_fit
from scipy.spatial.transform import Rotation

from chunking import uneven_chunks
from sins_sim import earth
from sins_sim._kernels import strapdown as ksd
from sins_sim.navigation import (
    NavSolution,
    StrapdownNavigator,
    attitude_error,
    euler_from_quat,
    height_aid_gains,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
)
from sins_sim.navigation.coning import CONING_COEFFICIENTS, ConingAlgorithm, coefficient_matrix
from sins_sim.units import ARCSEC, DEG, DEG_PER_H

LAT45 = math.radians(45.0)
LON0 = math.radians(10.0)
GL_X, GL_W = np.polynomial.legendre.leggauss(8)


# --- helpers ----------------------------------------------------------------------------------


def _q_euler(roll, pitch, yaw):
    """``q_nb`` with ``C_nb = R_z(yaw) R_y(pitch) R_x(roll)`` (scalar first)."""
    return Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_quat()[[3, 0, 1, 2]]


def _rotate(q, vec):
    """``C(q) vec`` by the quaternion sandwich ``q (x) [0, vec] (x) q*``."""
    return quat_multiply(quat_multiply(q, np.concatenate([[0.0], vec])), quat_conjugate(q))[1:]


def _rest_rates(lat, h, q_nb, gyro_bias_b=(0.0, 0.0, 0.0), accel_bias_b=(0.0, 0.0, 0.0)):
    """Body rate and specific force at rest: ``omega_ib^b = C_bn omega_ie^n``, ``f^b = -C_bn g^n``."""
    q_bn = quat_conjugate(q_nb)
    w_b = _rotate(q_bn, earth.earth_rate_ned(lat)) + np.asarray(gyro_bias_b)
    f_b = _rotate(q_bn, -earth.gravity_ned(lat, h)) + np.asarray(accel_bias_b)
    return w_b, f_b


def _constant(w_b, f_b, dt, n):
    return np.tile(w_b * dt, (n, 1)), np.tile(f_b * dt, (n, 1))


def _concat(sols):
    return NavSolution(*(np.concatenate([getattr(s, f) for s in sols]) for f in
                         ("t_s", "lat_rad", "lon_rad", "h_m", "v_ned_m_s", "q_nb")))


# smooth body motion (not a physical trajectory: only the consistency tests use it)
_W_AMP = np.array([0.05, 0.03, 0.02])  # rad/s
_W_FREQ = np.array([1.1, 0.7, 0.3])  # rad/s
_W_PH = np.array([0.3, 1.0, 2.0])
_F_AMP = np.array([0.5, 0.3, 0.2])  # m/s^2
_F_FREQ = np.array([0.9, 1.3, 0.5])
_F_PH = np.array([0.1, 0.5, 1.5])


def _smooth_increments(dt, n, lat=LAT45):
    """Exact increments of ``omega = w0 + a sin(b t + c)`` and ``f = f0 + ...`` per axis (closed-form integrals)."""
    w0, f0 = _rest_rates(lat, 0.0, np.array([1.0, 0.0, 0.0, 0.0]))
    t0 = np.arange(n)[:, None] * dt
    t1 = t0 + dt

    def integral(c, amp, freq, ph):
        return c * dt - amp / freq * (np.cos(freq * t1 + ph) - np.cos(freq * t0 + ph))

    return integral(w0, _W_AMP, _W_FREQ, _W_PH), integral(f0, _F_AMP, _F_FREQ, _F_PH)


# --- a slow, obvious reference of the kernel ----------------------------------------------------


def _naive_strapdown(dth, dv, dt, n_sub, coning, sculling, lat, lon, h, v0, q0, prev_dth, prev_dv,
                     gains=None, h_aid=None):
    """The module-docstring equations with numpy vectors and the numpy Earth model, one sample at a time."""
    cc = coefficient_matrix(coning)  # [component, lag - 1]
    sc = coefficient_matrix(sculling)
    big_t = n_sub * dt
    v = np.array(v0, dtype=float)
    q = np.array(q0, dtype=float)
    # past increments, oldest first, three deep (zeros before the given ones)
    pth = [np.zeros(3)] * (3 - len(prev_dth)) + [np.array(x, dtype=float) for x in prev_dth]
    pdv = [np.zeros(3)] * (3 - len(prev_dv)) + [np.array(x, dtype=float) for x in prev_dv]
    lat_p, h_p, v_p = lat, h, v.copy()
    dh, acc = 0.0, 0.0
    alpha, ups, beta, scul = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
    rows, count = [], 0
    for i in range(len(dth)):
        d, u = dth[i], dv[i]
        # component i of each lag's cross product weighted by row i of the coefficients
        beta = beta + 0.5 * np.cross(alpha, d) + sum(cc[:, j] * np.cross(pth[-1 - j], d) for j in range(3))
        scul = (scul + 0.5 * (np.cross(alpha, u) + np.cross(ups, d))
                + sum(sc[:, j] * (np.cross(pth[-1 - j], u) + np.cross(pdv[-1 - j], d)) for j in range(3)))
        alpha, ups = alpha + d, ups + u
        pth, pdv = pth[1:] + [d], pdv[1:] + [u]
        count += 1
        if count < n_sub:
            continue
        lat_x, h_x, v_x = 1.5 * lat - 0.5 * lat_p, 1.5 * h - 0.5 * h_p, 1.5 * v - 0.5 * v_p
        w_ie = earth.earth_rate_ned(lat_x)
        w_en = earth.transport_rate_ned(lat_x, h_x, v_x)
        zeta = (w_ie + w_en) * big_t
        dv_n = _rotate(q, ups + 0.5 * np.cross(alpha, ups) + scul)
        dv_n = dv_n - 0.5 * np.cross(zeta, dv_n)
        v_new = v + dv_n + (earth.gravity_ned(lat_x, h_x) - np.cross(2.0 * w_ie + w_en, v_x)) * big_t
        if gains is not None:
            v_new[2] += (gains[1] * dh + acc) * big_t
            acc += gains[2] * dh * big_t
        h_new = h - 0.5 * big_t * (v[2] + v_new[2])
        if gains is not None:
            h_new -= gains[0] * dh * big_t
        r_n, r_e = earth.radii(lat_x)
        h_mid = 0.5 * (h + h_new)
        lat_new = lat + 0.5 * big_t * (v[0] + v_new[0]) / (r_n + h_mid)
        lon_new = lon + 0.5 * big_t * (v[1] + v_new[1]) / ((r_e + h_mid) * math.cos(lat_x))
        q = quat_multiply(quat_from_rotvec(-zeta), quat_multiply(q, quat_from_rotvec(alpha + beta)))
        q = q / np.linalg.norm(q)
        lat_p, h_p, v_p = lat, h, v
        lat, lon, h, v = lat_new, lon_new, h_new, v_new
        if gains is not None:
            dh = h - h_aid[i]
        rows.append(np.concatenate([[lat, lon, h], v, q]))
        alpha, ups, beta, scul = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
        count = 0
    return np.array(rows)


# a filter-tuned-like design: rows differ per component (the kernel's per-component path)
TUNED_LIKE = np.array([[0.13, -0.03, 0.004], [0.41, -0.18, 0.05], [1.5, -1.1, 0.2]])


@pytest.mark.parametrize("algorithm", ["three_sample", "four_sample", "tuned"])
def test_kernel_matches_naive_reference(algorithm):
    """Element-wise against the numpy transcription of the equations (n_sub = 3, three- and
    four-sample coning and sculling, height aiding, previous increments given (two and three), a
    smooth motion at 400 Hz).

    The two differ only by rounding (operation order; numba's and numpy's sin/sqrt): after 100
    updates the observed differences are a few ulp of each quantity, so the tolerances are a few
    hundred ulp: 1e-13 rad on lat/lon (ulp 1.1e-16), 1e-11 m on h, 1e-12 m/s on v, 1e-13 on q.
    """
    dt, n_sub = 0.0025, 3
    n_prev = 2 if algorithm == "three_sample" else 3
    algorithm = TUNED_LIKE if algorithm == "tuned" else algorithm
    dth, dv = _smooth_increments(dt, 300 + n_prev)
    prev_dth, prev_dv = dth[:n_prev], dv[:n_prev]
    dth, dv = dth[n_prev:], dv[n_prev:]
    h_aid = 0.3 * np.sin(0.01 * np.arange(300))
    q0 = _q_euler(2 * DEG, -1 * DEG, 30 * DEG)
    v0 = np.array([1.0, -2.0, 0.1])
    nav = StrapdownNavigator(LAT45, LON0, 12.0, v0, q0, dt, coning=algorithm, sculling=algorithm,
                             n_sub=n_sub, vertical="height_aid", height_aid_tau_s=1.0,
                             dtheta_prev=prev_dth, dv_prev=prev_dv)
    sol = nav.process(dth, dv, h_aid=h_aid)
    ref = _naive_strapdown(dth, dv, dt, n_sub, algorithm, algorithm, LAT45, LON0, 12.0, v0, q0,
                           prev_dth, prev_dv, gains=nav.height_aid_gains, h_aid=h_aid)
    assert len(sol) == len(ref) == 100
    assert_allclose(sol.lat_rad, ref[:, 0], rtol=0, atol=1e-13)
    assert_allclose(sol.lon_rad, ref[:, 1], rtol=0, atol=1e-13)
    assert_allclose(sol.h_m, ref[:, 2], rtol=0, atol=1e-11)
    assert_allclose(sol.v_ned_m_s, ref[:, 3:6], rtol=0, atol=1e-12)
    assert_allclose(sol.q_nb, ref[:, 6:10], rtol=0, atol=1e-13)
    # the aiding loop did act (the test would not see a wrong gain otherwise)
    assert abs(nav.vertical_accel_correction_m_s2) > 1e-6


# --- stationary INS -------------------------------------------------------------------------------


REST_RATES_HZ = (100, 1000, 7200)


@pytest.fixture(scope="module")
def rest_runs():
    """One hour at rest at 45 deg N, roll 2 deg, pitch -1 deg, yaw 30 deg, vertical channel free, at
    100 Hz, 1 kHz and 7.2 kHz (the full hour at every rate: 26 million updates at 7.2 kHz take about
    3 s). Errors are taken at the end of every 36 s chunk (100 points; the errors here vary on the
    Schuler and vertical time scales, minutes)."""
    q0 = _q_euler(2 * DEG, -1 * DEG, 30 * DEG)
    w_b, f_b = _rest_rates(LAT45, 0.0, q0)
    out = {}
    for fs in REST_RATES_HZ:
        dt = 1.0 / fs
        dth, dv = _constant(w_b, f_b, dt, 36 * fs)
        nav = StrapdownNavigator(LAT45, LON0, 0.0, np.zeros(3), q0, dt, coning="two_sample", sculling="two_sample")
        hor, vert, att = [], [], []
        for _ in range(100):
            sol = nav.process(dth, dv)
            hor.append(earth.horizontal_error_m(sol.lat_rad[-1], sol.lon_rad[-1], LAT45, LON0)[2])
            vert.append(abs(sol.h_m[-1]))
            att.append(np.linalg.norm(attitude_error(sol.q_nb[-1], q0)))
        assert nav.n_updates == 3600 * fs and abs(sol.t_s[-1] - 3600.0) < 1e-9
        out[fs] = (np.array(hor), np.array(vert), np.array(att))
    return out


def test_rest_position_stays_put_at_every_rate(rest_runs):
    """Ideal increments at rest: 1 h, free vertical channel, 100 Hz / 1 kHz / 7.2 kHz.

    The mechanization is exact for this case to second order (the rotation compensation
    ``1/2 alpha x upsilon`` and the navigation-frame correction ``-1/2 zeta x`` cancel, the attitude
    update ``q(-zeta) q q(C_bn zeta)`` is the identity); what is left is rounding and the third-order
    product ``-1/4 zeta x (alpha x upsilon)`` (6.5e-13 m/s^2 at 100 Hz, proportional to dt), which the
    Schuler loop bounds horizontally (< 1e-6 m) and the unstable vertical channel amplifies by about
    cosh(3600 s / 570 s) = 280. Achieved maxima over the hour: horizontal 2.1e-5 m (100 Hz),
    1.3e-4 m (1 kHz, rounding of 10x more updates), 0 (7.2 kHz: the position increments fall below
    one ulp of lat/lon); height 5.0e-5 m, 3.4e-6 m, 1.3e-7 m.
    Tolerance 1e-2 m for each (the brief asks < 1 m; 1e-2 m is still 70x the largest observed value and
    far below any algorithmic error: a first-order Earth-rate compensation alone would leave
    0.5 (Omega T)^2 g-level tilts growing to metres), and the rates must agree within 1e-2 m:
    the error does not grow as dt shrinks.
    """
    worst = {}
    for fs, (hor, vert, _) in rest_runs.items():
        assert np.all(np.isfinite(hor))
        assert hor.max() < 1e-2, f"{fs} Hz: horizontal error {hor.max():.3g} m"
        assert vert.max() < 1e-2, f"{fs} Hz: height error {vert.max():.3g} m"
        worst[fs] = max(hor.max(), vert.max())
    assert max(worst.values()) - min(worst.values()) < 1e-2


def test_rest_attitude_senses_earth_rate_exactly(rest_runs):
    """At rest the gyros sense only the Earth rate; the navigation-frame update removes it exactly,
    so the attitude stays at the truth. Achieved after 1 h: 4.0e-6 arcsec (100 Hz), 4.0e-5 arcsec
    (1 kHz), 0 (7.2 kHz). Bound 1e-3 arcsec: rounding of up to 2.6e7 quaternion products (1e-16 rad
    each, a random walk of ~1e-12 rad) stays far below it, while one missing or wrongly signed
    Earth-rate term would be 15 deg/h."""
    for fs, (_, _, att) in rest_runs.items():
        assert att.max() / ARCSEC < 1e-3, f"{fs} Hz: attitude error {att.max() / ARCSEC:.3g} arcsec"


def test_gravity_at_rest_keeps_vertical_velocity_zero():
    """Free vertical channel, 60 s at rest at 45 deg N with a tilted body, ``f^b = -C_bn g^n`` from
    ``earth.gravity_ned``: the mechanization's gravity is the same normal gravity, so ``v_D`` stays at
    rounding level. Achieved: |v_D| <= 3.9e-11 m/s, the third-order product of the test above
    (6.5e-13 m/s^2 at 100 Hz) over 60 s. Bound 1e-9 m/s; a gravity mismatch of 1 ug
    (1e-8 m/s^2) would already give 6e-7 m/s, and the standard-gravity constant instead of Somigliana
    (a 5e-4 m/s^2 difference at 45 deg) 0.03 m/s."""
    q0 = _q_euler(2 * DEG, -1 * DEG, 30 * DEG)
    w_b, f_b = _rest_rates(LAT45, 0.0, q0)
    dt = 0.01
    nav = StrapdownNavigator(LAT45, LON0, 0.0, np.zeros(3), q0, dt, vertical="free")
    sol = nav.process(*_constant(w_b, f_b, dt, 6000))
    assert np.max(np.abs(sol.v_ned_m_s[:, 2])) < 1e-9
    # and a 1 ug mismatch is seen (the bound can fail)
    w_b, f_b = _rest_rates(LAT45, 0.0, q0, accel_bias_b=_rotate(quat_conjugate(q0), [0, 0, 1e-8]))
    sol = StrapdownNavigator(LAT45, LON0, 0.0, np.zeros(3), q0, dt).process(*_constant(w_b, f_b, dt, 6000))
    assert abs(sol.v_ned_m_s[-1, 2] - 6e-7) < 1e-8


# --- Schuler loop -----------------------------------------------------------------------------------


# At the equator the east channel is a pure Schuler oscillator: with the Earth rate along north, a tilt
# about north does not couple into the other axes (omega_ie x psi = 0), the Coriolis coupling
# 2 Omega sin(lat) of the horizontal channels vanishes, and the east radius of curvature is R_E = a.
# At 45 deg N the Foucault coupling (Omega sin(lat) = 5.2e-5 rad/s) turns the error towards north
# within the hour (a 0.01 deg/h drift gives 380 m of north error after 2 h and the east error misses
# the closed form by 2.2 %), so the closed forms are checked at the equator.
# The vertical channel is aided (tau = 10 s) against the true height: free, the Coriolis coupling
# 2 Omega dv_E drives the unstable vertical channel to kilometres. The aided loop itself couples back
# through the same Coriolis terms and lowers w^2 by 12 Omega^2 tau^2 (6.4e-4 at tau = 100 s, 6.4e-6 at
# tau = 10 s), hence the stiff loop.
SCHULER_TAU_S = 10.0
A_EQ = earth.WGS84_A_M
W_EAST = math.sqrt(float(earth.gravity_down(0.0, 0.0)) / A_EQ)  # rad/s: period 84.57 min


def _equator_run(q_nav0, gyro_bias_b, duration_s, dt=0.1):
    w_b, f_b = _rest_rates(0.0, 0.0, np.array([1.0, 0, 0, 0]), gyro_bias_b=gyro_bias_b)
    n = int(round(duration_s / dt))
    nav = StrapdownNavigator(0.0, 0.0, 0.0, np.zeros(3), q_nav0, dt, vertical="height_aid",
                             height_aid_tau_s=SCHULER_TAU_S)
    sol = nav.process(*_constant(w_b, f_b, dt, n), h_aid=np.zeros(n))
    dn, de, _ = earth.horizontal_error_m(sol.lat_rad, sol.lon_rad, 0.0, 0.0)
    return sol.t_s, dn, de


def test_schuler_oscillation_of_an_initial_tilt():
    """A 10 arcsec tilt about north (``q_nav0 = q(psi) (x) q_true``, level, heading north, equator),
    otherwise ideal increments, 2.2 Schuler periods at 10 Hz.

    Linear error model (Titterton & Weston 2004, ch. 12): ``dv_E' = g psi_N``, ``psi_N' = -dv_E / R_E``,
    so ``dp_E = R_E psi (1 - cos(w t))`` with ``w = sqrt(g / R_E)``, ``R_E = a`` at the equator.
    Achieved: largest deviation from the closed form 4.1e-5 of ``R psi`` (309 m); least-squares
    amplitude and frequency within 7e-7 and 3.2e-6 (the 3.2e-6 is the loop coupling described above).
    Tolerance 1e-3 (the brief's 1 % with margin for nothing but the linearisation and that coupling).
    """
    psi0 = 10.0 * ARCSEC
    t, dn, de = _equator_run(quat_from_rotvec([psi0, 0.0, 0.0]), (0.0, 0.0, 0.0), 2.2 * 2 * math.pi / W_EAST)
    amp = A_EQ * psi0
    closed = amp * (1.0 - np.cos(W_EAST * t))
    assert np.max(np.abs(de - closed)) < 1e-3 * amp
    assert np.max(np.abs(dn)) < 1e-6 * amp  # the north channel is not excited
    popt, _ = curve_fit(lambda tt, a, w, c: a * (1.0 - np.cos(w * tt)) + c, t, de, p0=[amp, W_EAST, 0.0])
    assert abs(popt[0] / amp - 1.0) < 1e-3
    assert abs(popt[1] / W_EAST - 1.0) < 1e-3
    # 84.57 min at the equator (earth.schuler_rate_rad_s uses sqrt(R_N R_E): 84.4 min at 45 deg)
    assert abs(2 * math.pi / popt[1] / 60.0 - 84.567) < 0.01


def test_schuler_ramp_of_a_constant_gyro_bias():
    """A constant 0.01 deg/h bias on the north gyro (level, heading north, equator), 2 h at 10 Hz:
    ``psi_N' = eps - dv_E / R`` gives ``dp_E = R eps (t - sin(w t) / w)`` (Titterton & Weston 2004,
    ch. 12), 2105 m at 2 h. Achieved: largest deviation 3.1e-6 of the largest error. Tolerance 1e-3
    (the brief asks 2 %)."""
    eps = 0.01 * DEG_PER_H
    t, dn, de = _equator_run(np.array([1.0, 0, 0, 0]), (eps, 0.0, 0.0), 7200.0)
    closed = A_EQ * eps * (t - np.sin(W_EAST * t) / W_EAST)
    assert closed[-1] == pytest.approx(2104.7, abs=0.1)
    assert np.max(np.abs(de - closed)) < 1e-3 * np.max(closed)
    assert np.max(np.abs(dn)) < 1e-6 * np.max(closed)


# --- vertical channel -------------------------------------------------------------------------------


def test_height_aid_gains_place_a_triple_pole():
    """``s^3 + k1 s^2 + (k2 + dg/dh) s + k3 = (s + 1/tau)^3`` with ``dg/dh`` of earth.gravity_down, at
    h = 0 the derivative of its height expansion ``-(2 gamma / a)(1 + f + m - 2 f sin^2 lat)`` (NIMA
    TR8350.2 eq. 4-3; the central difference of a quadratic is exact, 1e-9 leaves room for rounding):
    roots to 1e-4 relative (a triple root is found to about the cube root of the rounding, 1e-5)."""
    tau = 100.0
    k1, k2, k3 = height_aid_gains(tau, LAT45, 0.0)
    assert (k1, k3) == (3.0 / tau, 1.0 / tau ** 3)
    s2 = math.sin(LAT45) ** 2
    dgdh = -(2.0 * float(earth.gravity_down(LAT45, 0.0)) / earth.WGS84_A_M) * (
        1.0 + earth.WGS84_F + earth.WGS84_M - 2.0 * earth.WGS84_F * s2)
    assert k2 == pytest.approx(3.0 / tau ** 2 - dgdh, rel=1e-9)
    roots = np.roots([1.0, k1, k2 + dgdh, k3])
    assert_allclose(roots.real, -1.0 / tau, rtol=1e-4)
    assert np.max(np.abs(roots.imag)) < 1e-4 / tau


def test_free_vertical_channel_diverges_as_cosh():
    """Free channel, a 1e-4 m/s^2 down accelerometer error, 30 min at 10 Hz (45 deg N, level):
    ``dh'' = -b + k_s dh`` with ``k_s = -dg/dh`` gives ``dh = -(b/k_s)(cosh(sqrt(k_s) t) - 1)`` (time
    constant 569 s), -351 m at 30 min: the instability the docstring states. Achieved 2.2e-3 relative;
    tolerance 1e-2: the Coriolis coupling with the east channel (``4 Omega^2 cos^2(lat) / k_s`` = 3.4e-3
    of ``k_s``) is left out of the closed form."""
    b, dt = 1e-4, 0.1
    q0 = np.array([1.0, 0, 0, 0])
    w_b, f_b = _rest_rates(LAT45, 0.0, q0, accel_bias_b=(0.0, 0.0, b))
    sol = StrapdownNavigator(LAT45, 0.0, 0.0, np.zeros(3), q0, dt).process(*_constant(w_b, f_b, dt, 18000))
    k_s = -float(earth.gravity_down(LAT45, 100.0) - earth.gravity_down(LAT45, -100.0)) / 200.0
    closed = -(b / k_s) * (np.cosh(math.sqrt(k_s) * sol.t_s) - 1.0)
    assert closed[-1] == pytest.approx(-351.0, abs=1.0)
    assert np.max(np.abs(sol.h_m - closed)) < 1e-2 * abs(closed[-1])


def test_height_aided_loop_response_to_an_accelerometer_error():
    """Aided channel (tau = 100 s, truth height 0), the same kind of down accelerometer error
    ``b = 1e-3 m/s^2``: the error dynamics ``(s + 1/tau)^3 dh = -b`` give
    ``dh = -b t^2 exp(-t/tau) / 2`` (peak -2.71 m at t = 2 tau) and the loop's acceleration correction
    ``a_c = -b (1 - exp(-t/tau)(1 + t/tau + t^2/(2 tau^2)))`` -> -b. Achieved: 4.6e-4 of the peak and
    1.2e-4 of b after 1500 s. Tolerance 5e-3: one Euler step per update and the one-update delay of
    the height error, both O(T/tau) = 1e-3."""
    b, dt, tau = 1e-3, 0.1, 100.0
    q0 = np.array([1.0, 0, 0, 0])
    w_b, f_b = _rest_rates(LAT45, 0.0, q0, accel_bias_b=(0.0, 0.0, b))
    nav = StrapdownNavigator(LAT45, 0.0, 0.0, np.zeros(3), q0, dt, vertical="height_aid", height_aid_tau_s=tau)
    sol = nav.process(*_constant(w_b, f_b, dt, 15000), h_aid=np.zeros(15000))
    t = sol.t_s
    peak = b * 2.0 * tau ** 2 * math.exp(-2.0)
    assert np.max(np.abs(sol.h_m + b * t ** 2 / 2.0 * np.exp(-t / tau))) < 5e-3 * peak
    x = t[-1] / tau
    a_c = -b * (1.0 - math.exp(-x) * (1.0 + x + x * x / 2.0))
    assert abs(nav.vertical_accel_correction_m_s2 - a_c) < 5e-3 * b


# --- sculling ---------------------------------------------------------------------------------------


def _sculling_increments(amp_rad, acc_m_s2, w, lat, dt, n, start=0):
    """Exact increments of the sculling motion at rest on the Earth (8-point Gauss-Legendre per interval).

    Truth: at ``lat``, height 0, the body yaws ``theta(t) = A sin(w t)`` about the local vertical
    (``C_nb = R_z(theta)``) while it oscillates east, ``v_E = -(B/w) cos(w t)``, ``a_E = B sin(w t)``.
    Then ``f^n = a^n - g^n + (2 omega_ie + omega_en) x v^n``, ``f^b = R_z(-theta) f^n`` and
    ``omega_ib^b = [0, 0, theta'] + R_z(-theta)(omega_ie + omega_en)``. Along body y the specific
    force ``B sin(w t) cos(theta)`` is in phase with ``theta``: classical sculling (rotation about z,
    linear motion along y). Gravity lies along the rotation axis, so it takes no part.
    """
    k = np.arange(start, start + n)
    t = (k[:, None] + 0.5 + 0.5 * GL_X[None, :]) * dt
    th = amp_rad * np.sin(w * t)
    v_e = -(acc_m_s2 / w) * np.cos(w * t)
    z = np.zeros_like(t)
    _, r_e = earth.radii(lat)
    w_ie = earth.earth_rate_ned(lat)
    w_en = np.stack([v_e / r_e, z, -v_e * math.tan(lat) / r_e], axis=-1)
    v_n = np.stack([z, v_e, z], axis=-1)
    f_n = (np.stack([z, acc_m_s2 * np.sin(w * t), z - earth.gravity_down(lat, 0.0)], axis=-1)
           + np.cross(2.0 * w_ie + w_en, v_n))
    c, s = np.cos(th)[..., None], np.sin(th)[..., None]

    def to_body(x):  # R_z(-theta) x
        y_part = -s * x[..., :1] + c * x[..., 1:2]
        return np.concatenate([c * x[..., :1] + s * x[..., 1:2], y_part, x[..., 2:]], axis=-1)

    w_b = to_body(w_ie + w_en)
    w_b[..., 2] += amp_rad * w * np.cos(w * t)
    f_b = to_body(f_n)
    return (0.5 * dt * np.einsum("j,njk->nk", GL_W, w_b),
            0.5 * dt * np.einsum("j,njk->nk", GL_W, f_b))


def _sculling_rate_closed_form(amp_rad, acc_m_s2, x, algorithm):
    """Mean north velocity error rate (m/s^2) of the algorithm under the sculling motion.

    Per update (``x = w T``), to first order in ``A`` and exactly in ``x``: with ``theta(t) = A sin(w t)``
    about body z and ``f_y = B sin(w t)``, the exact increment in the frame of the previous update
    has x component ``-int dtheta(s) f_y ds`` (``dtheta(s) = theta(t) - theta_{k-1}``), of phase average
    ``-(AB/2)(T - sin(x)/w)``. The algorithm forms ``-1/2 dtheta_k dv_k`` (zero phase average for
    this in-phase motion) plus the sculling sum ``-sum_j c_j (dtheta_{k-j} dv_k - dv_{k-j} dtheta_k)``
    of phase average ``-(AB/w) 2 (1 - cos x) sum_j c_j sin(j x)``. Their difference over ``T``::

        rate_N = -(AB / x) [2 (1 - cos x) sum_j c_j sin(j x) - (x - sin x) / 2]

    (the same bracket as the coning residual with ``sin^2(alpha)`` -> ``AB``; ``c_j`` of the sculling
    choice). Leading terms ``+AB x^2 / 12`` (none), ``+AB x^4 / 60`` (two-sample), ``+AB x^6 / 280``
    (three-sample): positive, north, for ``A B > 0``. The phase averages are exact over whole periods
    sampled at >= 3 points per period.
    """
    lags = CONING_COEFFICIENTS[ConingAlgorithm(algorithm)]
    bracket = (2.0 * (1.0 - math.cos(x)) * sum(c * math.sin((j + 1) * x) for j, c in enumerate(lags))
               - 0.5 * (x - math.sin(x)))
    return -(amp_rad * acc_m_s2 / x) * bracket


SCULL_A, SCULL_B, SCULL_HZ = 1e-3, 5.0, 10.0  # rad, m/s^2, Hz: 0.06 deg, 0.5 g, 1.3 mm at 10 Hz


@pytest.fixture(scope="module")
def sculling_rates():
    """Fitted north velocity-error rate (m/s^2) per algorithm at 100 Hz and 200 Hz (10 s, 100 periods)."""
    w = 2.0 * math.pi * SCULL_HZ
    rates = {}
    for fs in (100, 200):
        dt = 1.0 / fs
        per = fs // int(SCULL_HZ)
        n = 10 * fs
        dth, dv = _sculling_increments(SCULL_A, SCULL_B, w, LAT45, dt, n)
        pth, pdv = _sculling_increments(SCULL_A, SCULL_B, w, LAT45, dt, 3, start=-3)
        for alg in ("none", "two_sample", "three_sample", "four_sample"):
            nav = StrapdownNavigator(LAT45, 0.0, 0.0, [0.0, -SCULL_B / w, 0.0], [1.0, 0, 0, 0], dt,
                                     coning="three_sample", sculling=alg, dtheta_prev=pth, dv_prev=pdv)
            sol = nav.process(dth, dv)
            idx = np.arange(per - 1, n, per)  # whole vibration periods: the truth is back to v = [0, -B/w, 0]
            rates[alg, fs] = np.polyfit(sol.t_s[idx], sol.v_ned_m_s[idx, 0], 1)[0]
    return rates


@pytest.mark.parametrize("alg", ["none", "two_sample", "three_sample"])
@pytest.mark.parametrize("fs", [100, 200])
def test_sculling_error_rate_matches_closed_form(sculling_rates, alg, fs):
    """The velocity error rate of each sculling compensation equals the closed form
    (:func:`_sculling_rate_closed_form`). Achieved (relative): 2.4e-5 (none), 3.1e-5 / 5.4e-5
    (two-sample), 1.2e-4 / 1.5e-3 (three-sample at 100 / 200 Hz). Tolerance 1e-3 relative plus
    1e-10 m/s^2: the closed form is first order in A (corrections A^2 = 1e-6) and leaves out the Earth-
    and transport-rate couplings of the vibrating body, which set a floor of a few 1e-11 m/s^2 (the
    down channel of the same runs drifts at 2.5e-11 to 1e-10 m/s^2); the three-sample error at 200 Hz
    is only 1.7e-8 m/s^2."""
    _check_sculling_rate(sculling_rates, alg, fs)


def _check_sculling_rate(sculling_rates, alg, fs):
    x = 2.0 * math.pi * SCULL_HZ / fs
    expected = _sculling_rate_closed_form(SCULL_A, SCULL_B, x, alg)
    assert expected > 0.0
    assert abs(sculling_rates[alg, fs] - expected) < 1e-3 * expected + 1e-10


def test_four_sample_sculling_matches_closed_form(sculling_rates):
    """The four-sample sculling (lag coefficients 113/840, -13/420, 1/280 by the duality of
    Ignagni 1998) against the same closed form at 100 Hz, where its error rate, ``AB x^8 / 1260`` to
    leading order = 1.0e-7 m/s^2, is three decades above the 1e-10 m/s^2 floor (at 200 Hz it would
    be 4e-10, at the floor). Same tolerance as the other algorithms."""
    _check_sculling_rate(sculling_rates, "four_sample", 100)
    x = 2.0 * math.pi * SCULL_HZ / 100
    # leading order within 5 %: the next term is x^2 * 1260 / 4620 = 11 % of it at x = 0.63, so the
    # leading term only bounds the order of magnitude here; the closed form above is the real check
    assert sculling_rates["four_sample", 100] == pytest.approx(SCULL_A * SCULL_B * x ** 8 / 1260.0, rel=0.2)


def test_sculling_error_order_in_the_sample_period(sculling_rates):
    """Halving the period divides the error rate by 2^(2N): N = 1 (none, (wT)^2), 2 (two-sample,
    (wT)^4), 3 (three-sample, (wT)^6). Achieved exponents 1.98, 3.95, 5.92 (the leading-order
    exponents are approached from below by the next term of each series); tolerance 0.1. And each
    compensation gains the expected factor over the previous one at 100 Hz: two-sample vs none
    ``5 / x^2`` = 12.7, three-sample vs two-sample ``14 / (3 x^2)`` = 11.8, to 10 % (next-order terms)."""
    for alg, order in (("none", 2), ("two_sample", 4), ("three_sample", 6)):
        exponent = math.log2(sculling_rates[alg, 100] / sculling_rates[alg, 200])
        assert abs(exponent - order) < 0.1, (alg, exponent)
    x = 2.0 * math.pi * SCULL_HZ / 100
    assert sculling_rates["none", 100] / sculling_rates["two_sample", 100] == pytest.approx(5.0 / x ** 2, rel=0.1)
    assert (sculling_rates["two_sample", 100] / sculling_rates["three_sample", 100]
            == pytest.approx(14.0 / (3.0 * x ** 2), rel=0.1))


# --- streaming and the two-rate structure -----------------------------------------------------------


def test_chunked_processing_is_bit_exact():
    """Uneven chunks (sizes 1, 7, 0, 333, 2, 1000, 13, not multiples of n_sub = 3) give the same bits
    as one call: outputs and the whole kernel state, with height aiding and three-sample algorithms."""
    dt = 0.0025
    dth, dv = _smooth_increments(dt, 4000)
    h_aid = 0.5 * np.sin(0.003 * np.arange(4000))
    kw = dict(coning="three_sample", sculling="three_sample", n_sub=3, vertical="height_aid", height_aid_tau_s=5.0)
    q0 = _q_euler(5 * DEG, 3 * DEG, -120 * DEG)
    whole = StrapdownNavigator(LAT45, LON0, 100.0, [3.0, -1.0, 0.2], q0, dt, **kw)
    ref = whole.process(dth, dv, h_aid=h_aid)
    chunked = StrapdownNavigator(LAT45, LON0, 100.0, [3.0, -1.0, 0.2], q0, dt, **kw)
    sizes = (1, 7, 0, 333, 2, 1000, 13)
    parts = [chunked.process(a, b, h_aid=c) for a, b, c in
             zip(uneven_chunks(dth, sizes), uneven_chunks(dv, sizes), uneven_chunks(h_aid, sizes))]
    got = _concat(parts)
    assert len(ref) == 1333
    for field in ("t_s", "lat_rad", "lon_rad", "h_m", "v_ned_m_s", "q_nb"):
        assert_array_equal(getattr(got, field), getattr(ref, field), err_msg=field)
    assert_array_equal(chunked.state_array(), whole.state_array())
    assert chunked.pending_samples == whole.pending_samples == 4000 % 3
    assert chunked.n_samples == 4000 and chunked.n_updates == 1333


def test_n_sub_high_rate_accumulation_agrees_with_single_sample_updates():
    """The same smooth motion (rates up to 0.1 rad/s, accelerations up to 0.5 m/s^2, 60 s) navigated
    with n_sub = 4 at 400 Hz and n_sub = 1 at 100 Hz (the 100 Hz increments are the sums of four
    400 Hz ones): both update the navigation at 100 Hz, so they differ only by the body-frame
    algorithms' truncation. Achieved with two-sample coning and sculling: attitude 2.4e-5 arcsec,
    velocity 4.6e-8 m/s, position 1.4e-6 m. Bounds 1e-3 arcsec, 1e-6 m/s, 1e-4 m: uncompensated
    algorithms ("none") differ by 1e-2 arcsec, 8e-6 m/s, 1.6e-4 m here, and dropping the sub-sample
    composition term ``1/2 alpha x dtheta`` would cost about 25 arcsec per minute."""
    dth4, dv4 = _smooth_increments(0.0025, 24000)
    dth1, dv1 = dth4.reshape(-1, 4, 3).sum(axis=1), dv4.reshape(-1, 4, 3).sum(axis=1)
    q0 = np.array([1.0, 0, 0, 0])

    def pair(alg):
        a = StrapdownNavigator(LAT45, 0.0, 0.0, np.zeros(3), q0, 0.01, coning=alg, sculling=alg).process(dth1, dv1)
        b = StrapdownNavigator(LAT45, 0.0, 0.0, np.zeros(3), q0, 0.0025, n_sub=4, coning=alg,
                               sculling=alg).process(dth4, dv4)
        assert_array_equal(a.t_s, b.t_s)
        pos = earth.horizontal_error_m(a.lat_rad, a.lon_rad, b.lat_rad, b.lon_rad)[2].max()
        vel = np.abs(a.v_ned_m_s - b.v_ned_m_s).max()
        att = np.abs(attitude_error(a.q_nb, b.q_nb)).max() / ARCSEC
        return pos, vel, att, np.abs(b.v_ned_m_s).max()

    pos, vel, att, travel = pair("two_sample")
    assert travel > 10.0  # the motion is not trivial: tens of m/s by the end
    assert att < 1e-3 and vel < 1e-6 and pos < 1e-4, (att, vel, pos)
    pos, vel, att, _ = pair("none")
    assert att > 1e-3 and vel > 1e-6 and pos > 1e-4, (att, vel, pos)


def test_outputs_and_properties():
    """One row per update, times ``k n_sub dt``; the properties are the last row; with n_sub = 5 a
    chunk of 12 samples gives 2 updates and leaves 2 samples pending."""
    q0 = _q_euler(0.0, 0.0, 90 * DEG)
    w_b, f_b = _rest_rates(LAT45, 50.0, q0)
    nav = StrapdownNavigator(LAT45, LON0, 50.0, np.zeros(3), q0, 0.01, n_sub=5)
    sol = nav.process(*_constant(w_b, f_b, 0.01, 12))
    assert len(sol) == 2 and nav.pending_samples == 2 and nav.n_samples == 12
    assert_allclose(sol.t_s, [0.05, 0.10], rtol=1e-15)
    assert nav.update_period_s == pytest.approx(0.05)
    assert nav.lat_rad == sol.lat_rad[-1] and nav.lon_rad == sol.lon_rad[-1] and nav.h_m == sol.h_m[-1]
    assert_array_equal(nav.v_ned_m_s, sol.v_ned_m_s[-1])
    assert_array_equal(nav.q_nb, sol.q_nb[-1])
    assert_allclose(euler_from_quat(nav.q_nb), [0.0, 0.0, 90 * DEG], atol=1e-12)
    assert sol.q_nb.shape == (2, 4) and sol.v_ned_m_s.shape == (2, 3)
    empty = nav.process(np.empty((0, 3)), np.empty((0, 3)))
    assert len(empty) == 0 and nav.pending_samples == 2
    sol = nav.process(*_constant(w_b, f_b, 0.01, 3))
    assert len(sol) == 1 and sol.t_s[0] == pytest.approx(0.15)
    assert (nav.coning, nav.sculling, nav.vertical, nav.n_sub) == ("two_sample", "two_sample", "free", 5)
    assert nav.height_aid_gains == (0.0, 0.0, 0.0)


def test_longitude_wraps_across_the_antimeridian():
    """Eastward at 100 m/s from lon = pi - 1e-5 rad: the longitude wraps into [-pi, pi) and the
    horizontal error measure (which wraps too) sees a continuous track."""
    lat, dt = 0.1, 0.1
    lon0 = math.pi - 1e-5
    q0 = np.array([1.0, 0, 0, 0])
    w_b, f_b = _rest_rates(lat, 0.0, q0)
    nav = StrapdownNavigator(lat, lon0, 0.0, [0.0, 100.0, 0.0], q0, dt, vertical="height_aid",
                             height_aid_tau_s=10.0)
    sol = nav.process(*_constant(w_b, f_b, dt, 100), h_aid=np.zeros(100))
    # 1000 m east = 1.58e-4 rad of longitude: from pi - 1e-5 to about -pi + 1.5e-4
    assert sol.lon_rad[0] > 0.0 and sol.lon_rad[-1] < -math.pi + 2e-4
    assert np.all(sol.lon_rad >= -math.pi) and np.all(sol.lon_rad < math.pi)
    east = earth.horizontal_error_m(lat, sol.lon_rad, lat, lon0)[1]
    assert np.all(np.diff(east) > 0.0)


# --- validation ----------------------------------------------------------------------------------------


_GOOD = dict(lat0_rad=LAT45, lon0_rad=0.0, h0_m=0.0, v0_ned_m_s=[0.0, 0.0, 0.0], q0_nb=[1.0, 0.0, 0.0, 0.0],
             dt_s=0.01)


@pytest.mark.parametrize("field, value", [
    ("lat0_rad", math.pi / 2), ("lat0_rad", float("nan")), ("lat0_rad", "north"),
    ("lon0_rad", float("inf")), ("h0_m", None),
    ("v0_ned_m_s", [0.0, 0.0]), ("v0_ned_m_s", [0.0, float("nan"), 0.0]),
    ("q0_nb", [1.0, 0.1, 0.0, 0.0]), ("q0_nb", [1.0, 0.0, 0.0]),
    ("dt_s", 0.0), ("dt_s", -0.01),
    ("coning", "five_sample"), ("coning", [[0.1, 0.0]]), ("sculling", "bogus"), ("sculling", 2), ("vertical", "baro"),
    ("n_sub", 0), ("n_sub", 1.5), ("n_sub", True),
    ("height_aid_tau_s", -1.0), ("height_aid_tau_s", float("nan")),
    ("dtheta_prev", np.zeros(3)), ("dv_prev", np.full((2, 3), np.inf)),
])
def test_constructor_rejects_bad_arguments(field, value):
    with pytest.raises(ValueError, match=rf"^{field}: "):
        StrapdownNavigator(**{**_GOOD, field: value})


def test_height_aid_time_constant_must_span_ten_updates():
    with pytest.raises(ValueError, match=r"^height_aid_tau_s: must be >= 10 update periods"):
        StrapdownNavigator(**_GOOD, vertical="height_aid", n_sub=4, height_aid_tau_s=0.39)
    StrapdownNavigator(**_GOOD, vertical="height_aid", n_sub=4, height_aid_tau_s=0.4)
    StrapdownNavigator(**_GOOD, vertical="free", n_sub=4, height_aid_tau_s=0.39)  # unused when free


@pytest.mark.parametrize("vertical, args, field", [
    ("free", (np.zeros(3), np.zeros((1, 3))), "dtheta"),
    ("free", (np.zeros((4, 2)), np.zeros((4, 3))), "dtheta"),
    ("free", (np.zeros((4, 3)), np.zeros((4, 3, 1))), "dv"),
    ("free", (np.zeros((4, 3)), np.zeros((5, 3))), "dv"),
    ("free", (np.full((4, 3), np.nan), np.zeros((4, 3))), "dtheta"),
    ("free", (np.zeros((4, 3)), np.full((4, 3), -np.inf)), "dv"),
    ("free", (np.zeros((4, 3)), np.zeros((4, 3)), np.zeros(4)), "h_aid"),
    ("height_aid", (np.zeros((4, 3)), np.zeros((4, 3))), "h_aid"),
    ("height_aid", (np.zeros((4, 3)), np.zeros((4, 3)), np.zeros(3)), "h_aid"),
    ("height_aid", (np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 1))), "h_aid"),
    ("height_aid", (np.zeros((4, 3)), np.zeros((4, 3)), [0.0, 0.0, np.nan, 0.0]), "h_aid"),
])
def test_process_rejects_bad_arguments(vertical, args, field):
    nav = StrapdownNavigator(**_GOOD, vertical=vertical)
    state = nav.state_array()
    with pytest.raises(ValueError, match=rf"^{field}: "):
        nav.process(*args)
    assert_array_equal(nav.state_array(), state)  # nothing ran


def test_height_aid_none_message_is_clear():
    nav = StrapdownNavigator(**_GOOD, vertical="height_aid")
    with pytest.raises(ValueError, match=r"h_aid: required with vertical='height_aid'"):
        nav.process(np.zeros((2, 3)), np.zeros((2, 3)))


def test_kernel_state_layout_is_consistent():
    """The state slots do not overlap and fill the array; the output row has the documented columns."""
    slots = [(ksd.ST_LAT, 1), (ksd.ST_LON, 1), (ksd.ST_H, 1), (ksd.ST_V, 3), (ksd.ST_Q, 4), (ksd.ST_DTH1, 3),
             (ksd.ST_DTH2, 3), (ksd.ST_DV1, 3), (ksd.ST_DV2, 3), (ksd.ST_ALPHA, 3), (ksd.ST_UPS, 3),
             (ksd.ST_BETA, 3), (ksd.ST_SCUL, 3), (ksd.ST_COUNT, 1), (ksd.ST_PREV_LAT, 1), (ksd.ST_PREV_H, 1),
             (ksd.ST_PREV_V, 3), (ksd.ST_DH, 1), (ksd.ST_ACC, 1), (ksd.ST_DTH3, 3), (ksd.ST_DV3, 3)]
    used = sorted(i for start, size in slots for i in range(start, start + size))
    assert used == list(range(ksd.STATE_SIZE))
    assert (ksd.OUT_LAT, ksd.OUT_LON, ksd.OUT_H, ksd.OUT_V, ksd.OUT_Q, ksd.OUT_SIZE) == (0, 1, 2, 3, 6, 10)
