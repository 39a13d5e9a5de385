"""Tests of the filter-free alignments (``sins_sim.navigation.alignment``): coarse and inertial-frame.

The increments are built here, independently of the simulator: a still base (body rate ``C_bn Omega_ie^n``,
specific force ``-C_bn g^n``, exact increments) and a swaying base (a constant attitude times three small
rotations oscillating at 1.5-3 Hz, a lever arm and a translational sway; rates and specific forces analytic,
integrated per interval by 4-point Gauss-Legendre). Each tolerance is derived next to its assertion.

Closed forms (Groves 2013, attitude initialization; Titterton and Weston 2004, sec. 10.2), ``b`` and ``eps`` the
accelerometer and gyro biases resolved in NED, ``psi`` with ``C_nb_est = (I + [psi x]) C_nb_true``:
coarse ``psi_N = -b_E / g``, ``psi_E = b_N / g``, ``psi_D = -eps_E / (Omega cos lat) + tan(lat) b_E / g``;
the inertial method's end attitude adds half the gyros' drift over the window, ``psi_N += eps_N T / 2`` and
``psi_D += eps_D T / 2`` (docs/theory/alignment.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial import polynomial as npoly
from scipy.integrate import quad_vec
from scipy.spatial.transform import Rotation

from sins_sim.earth import EARTH_RATE_RAD_S, earth_rate_ned, gravity_down, gravity_ned
from sins_sim.navigation import (
    align_coarse,
    align_inertial,
    attitude_error,
    quat_from_rotvec,
    quat_multiply,
)
from sins_sim.navigation.alignment import (
    _davenport,
    _gravity_integral_n0,
    _quat_from_dcm,
)
from sins_sim.navigation.attitude import dcm_from_quat
from sins_sim.units import ARCMIN, DEG, DEG_PER_H, MICRO_G

OMEGA = EARTH_RATE_RAD_S
#: A navigation-grade unit (issue 35): gyro bias 0.01 deg/h, accelerometer bias 50 ug, ARW 0.002 deg/sqrt(h),
#: VRW 10 ug/sqrt(Hz).
GYRO_BIAS = 0.01 * DEG_PER_H
ACCEL_BIAS = 50.0 * MICRO_G
ARW = 0.002 * DEG / 60.0  # deg/sqrt(h) -> rad/sqrt(s)
VRW = 10.0 * MICRO_G  # ug/sqrt(Hz) -> m/s/sqrt(s)


# --- increment builders -----------------------------------------------------------------------------------


def q_from_euler(roll, pitch, yaw):
    """``q_nb`` of a 3-2-1 attitude, ``C_nb = R_z(yaw) R_y(pitch) R_x(roll)``."""
    return quat_multiply(quat_multiply(quat_from_rotvec([0.0, 0.0, yaw]), quat_from_rotvec([0.0, pitch, 0.0])),
                         quat_from_rotvec([roll, 0.0, 0.0]))


def still(q_nb, lat, n, dt, gyro_bias=0.0, accel_bias=0.0, arw=0.0, vrw=0.0, rng=None):
    """Raw increments of a still base: constant rate and force, exact over each interval, plus white noise."""
    c_bn = dcm_from_quat(q_nb).T
    w = c_bn @ earth_rate_ned(lat) + gyro_bias
    f = -c_bn @ gravity_ned(lat, 0.0) + accel_bias
    dth = np.tile(w * dt, (n, 1))
    dv = np.tile(f * dt, (n, 1))
    if arw:
        dth += rng.normal(scale=arw * math.sqrt(dt), size=dth.shape)
    if vrw:
        dv += rng.normal(scale=vrw * math.sqrt(dt), size=dv.shape)
    return dth, dv


def _skew(x):
    z = np.zeros(x.shape[:-1])
    return np.stack([np.stack([z, -x[..., 2], x[..., 1]], -1), np.stack([x[..., 2], z, -x[..., 0]], -1),
                     np.stack([-x[..., 1], x[..., 0], z], -1)], -2)


def _elementary(axis, a):
    """Rotation matrices about body axis ``axis`` by angles ``a`` (Rodrigues), and the axis' cross matrix."""
    e = np.zeros(a.shape + (3,))
    e[..., axis] = 1.0
    k = _skew(e)
    return np.eye(3) + np.sin(a)[..., None, None] * k + (1.0 - np.cos(a))[..., None, None] * (k @ k), k


#: 4-point Gauss-Legendre nodes and weights on [-1, 1] (exact for polynomials of degree 7; per 0.01 s interval a
#: 3 Hz sine is integrated to a relative (2 pi 3 Hz 0.01 s)^8 / 8! ~ 4e-11).
GL_X = np.array([-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526])
GL_W = np.array([0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538])


def sway(q0, lat, n, dt, amp, freq, phase, lever, trans_amp, trans_freq, gyro_bias=0.0, accel_bias=0.0,
         arw=0.0, vrw=0.0, rng=None):
    """Raw increments of a swaying base and the true ``q_nb`` at the end.

    ``C_nb(t) = C0 R(t)``, ``R = R_x(a_1) R_y(a_2) R_z(a_3)``, ``a_i = amp_i sin(2 pi freq_i t + phase_i)``; the IMU
    sits at ``lever`` (body, m) from the pivot and the pivot sways by ``trans_amp sin(2 pi trans_freq t)`` (NED, m).
    Analytic: ``w_nb^b = vee(R^T dR/dt)``, ``w_ib^b = C_bn Omega^n + w_nb^b``; IMU position ``C0 R l + x``, its
    velocity ``v^n`` and acceleration ``a^n`` from ``dR/dt`` and ``d2R/dt2`` by the product rule on the three
    elementary rotations (``dR_i/dt = a_i' K_i R_i``, ``d2R_i/dt2 = (a_i'' K_i + a_i'^2 K_i^2) R_i``);
    ``f^n = a^n + 2 Omega^n x v^n - g^n`` (plumb gravity; transport rate ``|v| / R ~ 1e-9 rad/s`` neglected),
    ``f^b = C_bn f^n``.
    """
    c0 = dcm_from_quat(q0)
    t = (np.arange(n)[:, None] + 0.5 + 0.5 * GL_X[None, :]) * dt
    wn = 2.0 * np.pi * np.asarray(freq)
    arg = wn * t[..., None] + phase
    a, a1, a2 = amp * np.sin(arg), amp * wn * np.cos(arg), -amp * wn ** 2 * np.sin(arg)
    mats, ks = zip(*(_elementary(i, a[..., i]) for i in range(3)))
    d1 = [a1[..., i, None, None] * ks[i] @ mats[i] for i in range(3)]
    d2 = [(a2[..., i, None, None] * ks[i] + a1[..., i, None, None] ** 2 * (ks[i] @ ks[i])) @ mats[i]
          for i in range(3)]
    r = mats[0] @ mats[1] @ mats[2]
    r1 = d1[0] @ mats[1] @ mats[2] + mats[0] @ d1[1] @ mats[2] + mats[0] @ mats[1] @ d1[2]
    r2 = (d2[0] @ mats[1] @ mats[2] + mats[0] @ d2[1] @ mats[2] + mats[0] @ mats[1] @ d2[2]
          + 2.0 * (d1[0] @ d1[1] @ mats[2] + d1[0] @ mats[1] @ d1[2] + mats[0] @ d1[1] @ d1[2]))
    om = np.swapaxes(r, -1, -2) @ r1
    w_nb = np.stack([om[..., 2, 1], om[..., 0, 2], om[..., 1, 0]], -1)
    wt = 2.0 * np.pi * trans_freq
    v_n = (c0 @ (r1 @ lever)[..., None])[..., 0] + trans_amp * wt * np.cos(wt * t[..., None])
    a_n = (c0 @ (r2 @ lever)[..., None])[..., 0] - trans_amp * wt ** 2 * np.sin(wt * t[..., None])
    om_ie = earth_rate_ned(lat)
    f_n = a_n + 2.0 * np.cross(om_ie, v_n) - gravity_ned(lat, 0.0)
    c_bn = np.swapaxes(c0 @ r, -1, -2)
    f_b = (c_bn @ f_n[..., None])[..., 0]
    w_b = c_bn @ om_ie + w_nb
    dth = 0.5 * dt * np.einsum("j,njk->nk", GL_W, w_b) + gyro_bias * dt
    dv = 0.5 * dt * np.einsum("j,njk->nk", GL_W, f_b) + accel_bias * dt
    if arw:
        dth += rng.normal(scale=arw * math.sqrt(dt), size=dth.shape)
    if vrw:
        dv += rng.normal(scale=vrw * math.sqrt(dt), size=dv.shape)
    a_end = amp * np.sin(wn * n * dt + phase)
    r_end = np.eye(3)
    for i in range(3):
        r_end = r_end @ _elementary(i, np.array(a_end[i]))[0]
    return dth, dv, _quat_from_dcm(c0 @ r_end)


def coarse_closed_form(q_nb, lat, eps_b, ba_b):
    """``psi`` (N, E, D) of the coarse alignment from the biases (module docstring)."""
    c = dcm_from_quat(q_nb)
    eps, b = c @ eps_b, c @ ba_b
    g = float(gravity_down(lat, 0.0))
    return np.array([-b[1] / g, b[0] / g, -eps[1] / (OMEGA * math.cos(lat)) + math.tan(lat) * b[1] / g])


def inertial_closed_form(q_nb, lat, eps_b, ba_b, window):
    """``psi`` of the inertial alignment's end attitude: the coarse one plus half the drift about north and down."""
    eps = dcm_from_quat(q_nb) @ eps_b
    return coarse_closed_form(q_nb, lat, eps_b, ba_b) + 0.5 * window * np.array([eps[0], 0.0, eps[2]])


def _lsq_dual():
    """The weight ``w(s)`` with ``c_2 = int_0^1 w(s) y(s) ds`` the ``s^2`` coefficient of the least-squares fit of
    ``y`` on ``{1, s, s^2}`` over ``[0, 1]`` (the inverse Hilbert matrix's last row): ``30 - 180 s + 180 s^2``; and
    ``h(s) = int_s^1 w``, ``H(s) = int_s^1 h``."""
    gram = np.array([[1.0, 1 / 2, 1 / 3], [1 / 2, 1 / 3, 1 / 4], [1 / 3, 1 / 4, 1 / 5]])
    w = np.linalg.solve(gram, [0.0, 0.0, 1.0])

    def tail(p):
        anti = npoly.polyint(p)
        out = -anti
        out[0] += npoly.polyval(1.0, anti)
        return out

    h = tail(w)
    return w, h, tail(h)


def _sq_int(p) -> float:
    return float(npoly.polyval(1.0, npoly.polyint(npoly.polymul(p, p))))


def inertial_noise_sigma(lat, window, arw, vrw):
    """1-sigma heading error of the inertial fit from white gyro and accelerometer noise (rad).

    Linearised, the fit's heading is the ``t^2`` coefficient of the north velocity integral against the
    Earth-rate curvature ``g Omega cos(lat) t^2 / 2`` (the free offset and the tilt about east absorb ``1`` and
    ``t``): ``psi_D = 2 c_2 / (g Omega cos lat)``. Angle random walk ``N`` makes the north error ``g int W``, with
    ``Var c_2 = g^2 N^2 T^-1 int_0^1 H^2``; velocity random walk ``V`` makes it ``V W``, ``Var c_2 = V^2 T^-3
    int_0^1 h^2`` (``c_2`` per unit of normalised time squared, divided by ``T^2``)."""
    _, h, big_h = _lsq_dual()
    oc = OMEGA * math.cos(lat)
    g = float(gravity_down(lat, 0.0))
    s_arw = 2.0 * arw * math.sqrt(_sq_int(big_h) / window) / oc
    s_vrw = 2.0 * vrw * math.sqrt(_sq_int(h) / window ** 3) / (g * oc)
    return math.hypot(s_arw, s_vrw)


def _first_order_scale(lat, eps, ba) -> float:
    """The largest small ratio of the closed forms: ``|eps| / (Omega cos lat)``, ``|b| / g max(1, |tan lat|)``."""
    return max(float(np.linalg.norm(eps)) / (OMEGA * math.cos(lat)),
               float(np.linalg.norm(ba)) / float(gravity_down(lat, 0.0)) * max(1.0, abs(math.tan(lat))))


def _psi(res, q_true):
    return attitude_error(res.q_nb, q_true)


KW = {"gyro_bias_sigma_rad_s": GYRO_BIAS, "accel_bias_sigma_m_s2": ACCEL_BIAS}


# --- the pieces --------------------------------------------------------------------------------------------


def test_davenport_solves_wahba_like_the_svd():
    """Davenport's q-method gives the rotation of the SVD solution of Wahba's problem (Markley 1988), an
    independent algorithm: for noisy vectors both are the same least-squares optimum, to the eigen- and singular
    value solvers' ~1e-15 (asserted 1e-12)."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        c_true = Rotation.random(random_state=rng).as_matrix()
        b = rng.normal(size=(20, 3))
        r = b @ c_true.T + 0.05 * rng.normal(size=(20, 3))
        bm = r.T @ b
        u, _, vt = np.linalg.svd(bm)
        c_svd = u @ np.diag([1.0, 1.0, np.linalg.det(u) * np.linalg.det(vt)]) @ vt
        np.testing.assert_allclose(dcm_from_quat(_davenport(bm)), c_svd, atol=1e-12)


def test_gravity_integral_matches_quadrature():
    """The closed-form ``V^n0(t)`` against adaptive quadrature of ``C_n0_n(s) f^n`` with scipy's rotation (an
    independent Rodrigues): agreement to the quadrature's tolerance (epsabs 1e-10 m/s)."""
    lat, g, t_end = 0.7, 9.80, 900.0
    axis = np.array([math.cos(lat), 0.0, -math.sin(lat)])
    f = np.array([0.0, 0.0, -g])
    ref, _ = quad_vec(lambda s: Rotation.from_rotvec(OMEGA * s * axis).apply(f), 0.0, t_end, epsabs=1e-10)
    np.testing.assert_allclose(_gravity_integral_n0(np.array([t_end]), lat, g)[0], ref, rtol=0, atol=1e-8)


# --- coarse on a still base --------------------------------------------------------------------------------------


def test_coarse_still_base_reaches_the_closed_form_per_seed():
    """Levelling and gyrocompassing with constant biases and no noise: every component equals its closed form.

    The TRIAD of the biased means is exact; the closed forms are its first order in the small ratios
    ``|eps| / (Omega cos lat)`` and ``|b| / g`` (times ``tan lat`` in the coupling), whatever their direction (e.g.
    ``eps_N`` rescales the horizontal Earth rate the heading divides by). The neglected terms are products of two
    of them, below ``2 s^2`` with ``s`` the largest (at most 3e-3 here)."""
    rng = np.random.default_rng(35)
    for _ in range(20):
        lat = rng.uniform(-70.0, 70.0) * DEG
        q0 = q_from_euler(*rng.uniform(-10.0, 10.0, 2) * DEG, rng.uniform(-180.0, 180.0) * DEG)
        eps = rng.normal(scale=GYRO_BIAS, size=3)
        ba = rng.normal(scale=ACCEL_BIAS, size=3)
        dth, dv = still(q0, lat, 600, 0.1, eps, ba)
        res = align_coarse(dth, dv, 0.1, lat, **KW)
        pred = coarse_closed_form(q0, lat, eps, ba)
        tol = 2.0 * _first_order_scale(lat, eps, ba) ** 2
        # tilt: the accelerometer bias over g about the right axis (north tilt from the east bias and vice versa)
        np.testing.assert_allclose(_psi(res, q0)[:2], pred[:2], rtol=0, atol=tol)
        # heading: -eps_E / (Omega cos lat) + tan(lat) b_E / g
        assert abs(_psi(res, q0)[2] - pred[2]) <= tol
        assert res.notes == ()  # no noise, no motion: nothing to warn about


def test_coarse_heading_spread_is_the_gyro_bias_over_the_earth_rate():
    """Over 400 draws of the gyro biases (per axis N(0, (0.01 deg/h)^2), no accelerometer bias, no noise), the
    standard deviation of the heading error is ``sigma / (Omega cos lat)``, and each reported ``sigma_rad[2]`` is
    exactly that.

    The east bias ``eps_E`` is a unit row of ``C_nb`` times the body biases, N(0, sigma^2) for any attitude, so
    the heading errors are N(0, (sigma / (Omega cos lat))^2) to first order. The sample standard deviation of
    ``n = 400`` values has a relative sampling error ``1 / sqrt(2 (n - 1)) = 3.5 %``; 10 % is 2.8 of those.
    The reported sigma is the closed form plus the block-means scatter of noise-free data (float rounding,
    ~1e-16 of the mean rate, i.e. 1e-13 relative): asserted to 1e-9."""
    lat = 48.0 * DEG
    floor = GYRO_BIAS / (OMEGA * math.cos(lat))
    rng = np.random.default_rng(400)
    errs = []
    for _ in range(400):
        q0 = q_from_euler(*rng.uniform(-5.0, 5.0, 2) * DEG, rng.uniform(-180.0, 180.0) * DEG)
        dth, dv = still(q0, lat, 200, 0.1, rng.normal(scale=GYRO_BIAS, size=3))
        res = align_coarse(dth, dv, 0.1, lat, gyro_bias_sigma_rad_s=GYRO_BIAS, accel_bias_sigma_m_s2=0.0)
        errs.append(_psi(res, q0)[2])
        assert res.sigma_rad[2] == pytest.approx(floor, rel=1e-9)
    n = len(errs)
    assert 1.0 / math.sqrt(2 * (n - 1)) * 2.5 <= 0.10
    assert np.std(errs, ddof=1) == pytest.approx(floor, rel=0.10)


def test_coarse_block_means_standard_error_matches_white_noise():
    """With white noise only (ARW, VRW), the coarse heading scatter is ``N / sqrt(T) / (Omega cos lat)`` (the
    standard error of a mean rate); the block-means estimate in ``sigma_rad[2]`` (bias sigmas 0) reproduces it.
    Over 60 runs the rms error has a sampling error of ``1 / sqrt(2 * 60) = 9 %``, and the mean of 60 block-means
    estimates from ``K = 10`` blocks (each 24 %) 3 %: asserted within 30 %, about 3 combined sampling errors."""
    lat, dt, n = 30.0 * DEG, 0.05, 6000
    q0 = q_from_euler(1.0 * DEG, 2.0 * DEG, 50.0 * DEG)
    expected = ARW / math.sqrt(n * dt) / (OMEGA * math.cos(lat))
    errs, sigmas = [], []
    for seed in range(60):
        dth, dv = still(q0, lat, n, dt, arw=ARW, vrw=VRW, rng=np.random.default_rng(seed))
        res = align_coarse(dth, dv, dt, lat, gyro_bias_sigma_rad_s=0.0, accel_bias_sigma_m_s2=0.0)
        errs.append(_psi(res, q0)[2])
        sigmas.append(res.sigma_rad[2])
    assert math.sqrt(np.mean(np.square(errs))) == pytest.approx(expected, rel=0.30)
    assert np.mean(sigmas) == pytest.approx(expected, rel=0.30)


# --- the inertial method -----------------------------------------------------------------------------------------


def test_inertial_still_base_reaches_the_closed_form():
    """The inertial method with constant biases and no noise: the coarse closed form plus half the gyros' drift
    over the window about north and down (docs/theory/alignment.md). Neglected: products of two first-order errors
    (below ``2 s^2``, as for the coarse method) and the Earth's turn over the window acting on the drift terms (``Omega T`` of
    ``|eps| T``)."""
    rng = np.random.default_rng(7)
    window = 300.0
    for lat_deg in (-40.0, 0.0, 30.0, 60.0):
        lat = lat_deg * DEG
        q0 = q_from_euler(*rng.uniform(-5.0, 5.0, 2) * DEG, rng.uniform(-180.0, 180.0) * DEG)
        eps = rng.choice([-1.0, 1.0], 3) * GYRO_BIAS
        ba = rng.choice([-1.0, 1.0], 3) * ACCEL_BIAS
        dth, dv = still(q0, lat, 15000, 0.02, eps, ba)
        res = align_inertial(dth, dv, 0.02, lat, **KW)
        pred = inertial_closed_form(q0, lat, eps, ba, window)
        tol = 2.0 * _first_order_scale(lat, eps, ba) ** 2 + OMEGA * window * math.sqrt(3.0) * GYRO_BIAS * window
        np.testing.assert_allclose(_psi(res, q0), pred, rtol=0, atol=tol)
        # the bounds it reports: the same closed forms' 1-sigma, plus the sub-window scatter, which for noise-free
        # data is only the drift accumulated before each of the K = 5 sub-windows: its spread is within the window's
        # drift range |eps| T, so its standard deviation is at most |eps| T / 2, and over sqrt(K) that much at most
        oc = OMEGA * math.cos(lat)
        g = float(gravity_down(lat, 0.0))
        bound = np.array([math.hypot(ACCEL_BIAS / g, 0.5 * GYRO_BIAS * window), ACCEL_BIAS / g,
                          math.sqrt((GYRO_BIAS / oc) ** 2 + (math.tan(lat) * ACCEL_BIAS / g) ** 2
                                    + (0.5 * GYRO_BIAS * window) ** 2)])
        assert np.all(res.sigma_rad >= bound * (1.0 - 1e-12))
        extra = np.sqrt(np.maximum(res.sigma_rad ** 2 - bound ** 2, 0.0))
        assert np.all(extra <= float(np.linalg.norm(eps)) * window / 2.0 / math.sqrt(5.0))
        # noise-free, the end heading estimated from the data up to t moves only by its drift share: the estimate
        # centred on [0, t] and tracked to T carries eps_D (T - t / 2), which moves by eps_D 0.2 T / 2 over the
        # last fifth
        assert res.settling_rad <= 0.1 * float(np.linalg.norm(eps)) * window


def test_inertial_agrees_with_coarse_on_a_still_base():
    """Same noisy still-base data: the two estimates differ by less than their combined 1-sigma in every
    component, and each lies within 3 of its own sigma of the truth (the bias parts are shared, so their difference
    is noise only, well inside the combined sigma that includes the bias bounds)."""
    lat, dt, n = 45.0 * DEG, 0.02, 15000
    for seed in range(3):
        rng = np.random.default_rng(100 + seed)
        q0 = q_from_euler(*rng.uniform(-3.0, 3.0, 2) * DEG, rng.uniform(-180.0, 180.0) * DEG)
        dth, dv = still(q0, lat, n, dt, rng.normal(scale=GYRO_BIAS, size=3),
                        rng.normal(scale=ACCEL_BIAS, size=3), ARW, VRW, rng)
        rc = align_coarse(dth, dv, dt, lat, **KW)
        ri = align_inertial(dth, dv, dt, lat, **KW)
        diff = attitude_error(ri.q_nb, rc.q_nb)
        assert np.all(np.abs(diff) <= np.hypot(rc.sigma_rad, ri.sigma_rad))
        assert np.all(np.abs(_psi(rc, q0)) <= 3.0 * rc.sigma_rad)
        assert np.all(np.abs(_psi(ri, q0)) <= 3.0 * ri.sigma_rad)


def test_inertial_north_tilt_carries_the_gyro_random_walk():
    """With angle random walk only, the end attitude's north tilt is the tracked random walk less the fit's share,
    ``int_0^1 dW(s) (3 s^2 - 2 s^3)`` (T = 1; the fit's tilt is the slope of ``g int W`` against ``g t`` with a free
    offset): rms ``sqrt(13/35) N sqrt(T)``. Over 200 runs the rms has a sampling error ``1 / sqrt(2 n) = 5 %``:
    asserted within 15 %. Given ``gyro_arw_rad_sqrt_s``, the reported north sigma includes that term."""
    lat, dt, n = 50.0 * DEG, 0.1, 6000
    q0 = q_from_euler(0.5 * DEG, -0.5 * DEG, 75.0 * DEG)
    expected = math.sqrt(13.0 / 35.0) * ARW * math.sqrt(n * dt)
    psi_n = []
    for seed in range(200):
        dth, dv = still(q0, lat, n, dt, arw=ARW, rng=np.random.default_rng(seed))
        res = align_inertial(dth, dv, dt, lat, gyro_bias_sigma_rad_s=0.0, accel_bias_sigma_m_s2=0.0,
                             gyro_arw_rad_sqrt_s=ARW)
        psi_n.append(_psi(res, q0)[0])
        assert res.sigma_rad[0] >= expected
    assert math.sqrt(np.mean(np.square(psi_n))) == pytest.approx(expected, rel=0.15)


SWAY_SEEDS = range(8)
SWAY_LAT = 30.0 * DEG
SWAY_DT, SWAY_N = 0.01, 30000  # 100 Hz, 300 s
LEVER = np.array([0.3, -0.2, -0.5])
TRANS_AMP, TRANS_FREQ = np.array([2e-4, 1e-4, 5e-5]), 2.2


def _sway_case(seed):
    rng = np.random.default_rng(seed)
    q0 = q_from_euler(*rng.uniform(-3.0, 3.0, 2) * DEG, rng.uniform(-180.0, 180.0) * DEG)
    amp = rng.uniform(2.0, 6.0, 3) * ARCMIN
    freq = rng.uniform(1.5, 3.0, 3)
    phase = rng.uniform(0.0, 2.0 * np.pi, 3)
    eps = rng.choice([-1.0, 1.0], 3) * GYRO_BIAS
    ba = rng.choice([-1.0, 1.0], 3) * ACCEL_BIAS
    dth, dv, q_end = sway(q0, SWAY_LAT, SWAY_N, SWAY_DT, amp, freq, phase, LEVER, TRANS_AMP, TRANS_FREQ,
                          eps, ba, ARW, VRW, rng)
    return dth, dv, q_end, eps, ba, amp, freq


@pytest.fixture(scope="module")
def sway_runs():
    out = []
    for seed in SWAY_SEEDS:
        dth, dv, q_end, eps, ba, amp, freq = _sway_case(seed)
        out.append({"q_end": q_end, "eps": eps, "ba": ba, "amp": amp, "freq": freq,
                        "coarse": align_coarse(dth, dv, SWAY_DT, SWAY_LAT, **KW),
                        "inertial": align_inertial(dth, dv, SWAY_DT, SWAY_LAT, **KW)})
    return out


def test_inertial_heading_on_a_swaying_base(sway_runs):
    """Several arcmin of sway at 1.5-3 Hz, 0.01 deg/h, 50 ug, ARW 0.002 deg/sqrt(h), VRW 10 ug/sqrt(Hz), 300 s:
    the inertial heading is the closed form of the biases within the noise, and within 0.1 deg on every seed.

    Tolerance on ``|psi_D - closed form|``: 3.3 sigma of the white-noise heading (:func:`inertial_noise_sigma`,
    two-sided 1e-3 per seed) plus the sway's own bound. The sway's velocity ``v`` (at most
    ``sum_i amp_i 2 pi f_i |l| + 2 pi f_t |x|``) enters the north fit as ``c_2 = T^-2 int_0^1 w(s) v(sT) ds``;
    by parts, an oscillation at ``omega`` gives ``|c_2| <= v (|w(0)| + |w(1)| + TV(w)) / (omega T) / T^2 =
    150 v / (omega T^3)``. The two-sample coning residual (``a^2 W (W h)^4 / 60``, 1e-9 rad/s here) moves the end
    heading by under 1e-6 rad in 300 s: added as that.

    The 0.1 deg is the issue's acceptance figure, not a derived bound: the 1-sigma budget here is the bias floor
    (0.044 deg) and ARW (0.037 deg), so 0.1 deg is about 1.7 sigma of the total."""
    window = SWAY_N * SWAY_DT
    oc = OMEGA * math.cos(SWAY_LAT)
    g = float(gravity_down(SWAY_LAT, 0.0))
    s_noise = inertial_noise_sigma(SWAY_LAT, window, ARW, VRW)
    for run in sway_runs:
        res = run["inertial"]
        psi = _psi(res, run["q_end"])
        pred = inertial_closed_form(run["q_end"], SWAY_LAT, run["eps"], run["ba"], window)
        w_min = 2.0 * np.pi * min(float(run["freq"].min()), TRANS_FREQ)
        v_max = float(np.sum(run["amp"] * 2.0 * np.pi * run["freq"])) * float(np.linalg.norm(LEVER)) \
            + 2.0 * np.pi * TRANS_FREQ * float(np.linalg.norm(TRANS_AMP))
        sway_bound = 2.0 * 150.0 * v_max / (w_min * window) / (g * oc * window ** 2)
        coning = float(np.max(run["amp"])) ** 2 * 2 * np.pi * 3.0 * (2 * np.pi * 3.0 * SWAY_DT) ** 4 / 60 * window
        assert abs(psi[2] - pred[2]) <= 3.3 * s_noise + sway_bound + coning
        assert abs(psi[2]) < 0.1 * DEG
        assert abs(psi[2]) <= 3.0 * res.sigma_rad[2]  # the reported sigma covers it
        assert np.all(np.abs(psi[:2]) <= 3.0 * res.sigma_rad[:2])


def test_coarse_misses_by_degrees_on_the_same_sway(sway_runs):
    """The same data through the coarse method: the mean rate carries the sway's net rotation over the window
    (arcmin / 300 s, against Omega cos(lat) = 13 deg/h), so the heading misses by more than 1 deg on most seeds
    (at least 5 of 8); the reported sigma grows with the block-means scatter to at least half of each miss (block
    means of a bounded oscillation overstate its standard error by about sqrt(K) = 3.2 on average) and is more
    than 1 deg on every seed, with a note that the scatter dominates."""
    misses = []
    for run in sway_runs:
        res = run["coarse"]
        miss = abs(_psi(res, run["q_end"])[2])
        misses.append(miss)
        assert res.sigma_rad[2] >= 0.5 * miss
        assert res.sigma_rad[2] > 1.0 * DEG
        assert any("dominates" in note and "heading" in note for note in res.notes)
    assert sum(m > 1.0 * DEG for m in misses) >= 5


# --- the result and its history ----------------------------------------------------------------------------------


@pytest.mark.parametrize("align", [align_coarse, align_inertial])
def test_history_ends_at_the_result(align):
    """The history runs at ``history_rate_hz`` and ends at the window's end with the returned attitude."""
    lat, dt = 20.0 * DEG, 0.05
    q0 = q_from_euler(0.5 * DEG, -1.0 * DEG, 200.0 * DEG)
    dth, dv = still(q0, lat, 1200, dt)
    res = align(dth, dv, dt, lat, **KW, history_rate_hz=2.0)
    t = res.convergence["t_s"]
    np.testing.assert_allclose(np.diff(t), 0.5, rtol=1e-12)
    assert t[-1] == pytest.approx(60.0)
    assert res.duration_s == pytest.approx(60.0)
    np.testing.assert_allclose(
        [res.convergence[k][-1] for k in ("roll_rad", "pitch_rad", "heading_rad")], res.euler_rad, atol=1e-12)
    assert res.method == align.__name__.split("_")[1]


@pytest.mark.parametrize("align", [align_coarse, align_inertial])
@pytest.mark.parametrize("change, field", [
    ({"dtheta": np.zeros((600, 2))}, "dtheta"),
    ({"dv": np.zeros((599, 3))}, "dv"),
    ({"dv": "nan"}, "dv"),
    ({"dtheta": "inf"}, "dtheta"),
    ({"lat_rad": 89.9 * DEG}, "lat_rad"),
    ({"lat_rad": float("nan")}, "lat_rad"),
    ({"dt_s": 0.005}, "dtheta"),  # 600 x 5 ms = 3 s, shorter than the 5 s minimum
    ({"dt_s": 0.0}, "dt_s"),
    ({"gyro_bias_sigma_rad_s": -1.0}, "gyro_bias_sigma_rad_s"),
    ({"accel_bias_sigma_m_s2": float("inf")}, "accel_bias_sigma_m_s2"),
    ({"history_rate_hz": 0.0}, "history_rate_hz"),
])
def test_refusals_name_the_argument(align, change, field):
    """Bad input: one ValueError line that starts with the argument's name."""
    dth, dv = still(q_from_euler(0.0, 0.0, 0.0), 0.5, 600, 0.1)
    args = dict(dtheta=dth, dv=dv, dt_s=0.1, lat_rad=0.5, **KW)
    for key, val in change.items():
        if isinstance(val, str):
            bad = args[key].copy()
            bad[17, 1] = float(val)
            val = bad
        args[key] = val
    with pytest.raises(ValueError) as info:
        align(args.pop("dtheta"), args.pop("dv"), args.pop("dt_s"), args.pop("lat_rad"), **args)
    msg = str(info.value)
    assert msg.startswith(f"{field}:") and "\n" not in msg


def test_inertial_refuses_an_unknown_coning():
    dth, dv = still(q_from_euler(0.0, 0.0, 0.0), 0.5, 600, 0.1)
    with pytest.raises(ValueError, match="^coning:"):
        align_inertial(dth, dv, 0.1, 0.5, **KW, coning="five_sample")
    with pytest.raises(ValueError, match="^h_m:"):
        align_inertial(dth, dv, 0.1, 0.5, float("nan"), **KW)
    with pytest.raises(ValueError, match="^gyro_arw_rad_sqrt_s:"):
        align_inertial(dth, dv, 0.1, 0.5, **KW, gyro_arw_rad_sqrt_s=-1e-7)


@pytest.mark.parametrize("align", [align_coarse, align_inertial])
def test_notes_say_when_the_window_is_too_short_or_the_base_moved(align):
    """20 s of a navigation-grade unit: the angle random walk's heading scatter (coarse:
    ``N / (sqrt(T) Omega cos lat)`` = 0.12 deg at 45 deg, inertial 1.2 times that) is about twice the
    east-gyro-bias bound (0.054 deg), so a note says the scatter dominates and names a window long enough. A
    constant 0.2 m/s^2 along the vertical body axis of this level unit (2 % of g, against the 1 % rest tolerance)
    adds a note that the base was not at rest.
    """
    lat, dt, n = 45.0 * DEG, 0.01, 2000
    q0 = q_from_euler(0.0, 0.0, 0.3)
    dth, dv = still(q0, lat, n, dt, arw=ARW, vrw=VRW, rng=np.random.default_rng(5))
    res = align(dth, dv, dt, lat, **KW)
    assert any("heading scatter" in note and "too short" in note and "would need about" in note
               for note in res.notes)
    dv_moving = dv + np.array([0.0, 0.0, 0.2]) * dt
    assert any("not at rest" in note for note in align(dth, dv_moving, dt, lat, **KW).notes)
