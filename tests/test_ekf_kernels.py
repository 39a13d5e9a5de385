"""The compiled filter steps (sins_sim._kernels.ekf, issue 37 item 7) against the numpy forms they replace.

Each kernel evaluates the same expressions as its numpy reference in another order, so the two agree to
rounding: for a product chain the bound is ``c n eps`` times the same chain in absolute values (Higham 2002,
sec. 3.5: ``|fl(AB) - AB| <= gamma_n |A||B|``, ``gamma_n ~ n eps``), with ``n = 15`` and a factor 100 for the
chains of up to six products (Phi's five powers, P's two) and the differently ordered sums of F's entries. A
missing or wrong term in a kernel shows as a difference of the term's own size, far above these bounds.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim import earth
from sins_sim._kernels import ekf as kekf
from sins_sim.navigation import ekf
from sins_sim.navigation.aided import _correct_rows, _correct_rows_reference
from sins_sim.navigation.attitude import quat_from_rotvec
from sins_sim.navigation.strapdown import StrapdownNavigator

EPS = np.finfo(float).eps
N = ekf.N_STATES
BOUND = 100 * N * EPS      # the product-chain bound of the module docstring


def _spd(rng, sigmas):
    """A full symmetric positive definite covariance with the given sigmas (random correlations)."""
    a = rng.standard_normal((N, N))
    c = a @ a.T + N * np.eye(N)
    d = np.sqrt(np.diag(c))
    return c / np.outer(d, d) * np.outer(sigmas, sigmas)


SIGMAS = np.array([3.0, 3.0, 5.0, 0.05, 0.05, 0.1, 1e-4, 1e-4, 1e-3, 5e-8, 5e-8, 5e-8, 1e-3, 1e-3, 1e-3])


def _rows(rng):
    """Block start and end rows (lat, h, v, q) of a 60 m/s turning cruise at 52 deg N, 0.2 s apart."""
    q0 = quat_from_rotvec([0.01, -0.02, 0.7])
    q1 = quat_from_rotvec([0.011, -0.019, 0.705])
    # the running integrals of the raw angle (rad) and of the velocity less the reference (m/s), body: a turn
    # in progress (the angle grows on every axis) and a velocity change that shrinks on one axis
    acc0 = np.array([0.1, -0.02, 0.7, 0.5, -0.3, 0.2])
    acc1 = np.array([0.101, -0.021, 0.705, 0.52, -0.29, 0.25])
    start = np.concatenate([[math.radians(52.0), 300.0], [46.0, 38.5, -0.3], q0, acc0])
    end = np.concatenate([[math.radians(52.0) + 9.2 / 6.4e6, 300.06], [45.8, 38.8, -0.28], -q1, acc1])  # sign flipped
    return start, end


#: Scale factors and misalignments of an unmodelled-error model (30 ppm / 6 arcsec gyros, 300 ppm / 20 arcsec
#: accelerometers), so that the kernel's per-block process noise enters the comparison.
UNMODELLED = ekf.UnmodelledErrors(30e-6, 2.9e-5, 3e-4, 9.7e-5, (0.0, 0.0, -9.81))


def _navigator(start, feedback, p0, noise, unmodelled=None):
    nav = StrapdownNavigator(start[0], 0.08, start[1], start[2:5], start[5:9], 1.0 / 400.0)
    return ekf.AidedNavigator(nav, noise, p0, feedback=feedback, unmodelled=unmodelled)


def test_propagate_block_equals_the_numpy_reference():
    """Phi P Phi^T + Q_d, the transition product and (open loop) Phi x: Gauss-Markov and random-walk biases,
    without and with the unmodelled scale factors' and misalignments' process noise per block."""
    rng = np.random.default_rng(37)
    start, end = _rows(rng)
    p0 = _spd(rng, SIGMAS)
    for noise in (ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3, gyro_bias_tau_s=300.0, accel_bias_tau_s=600.0),
                  ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3, gyro_bias_rw_rad_s_sqrt_s=1e-9)):
        for feedback, un in ((True, None), (False, None), (True, UNMODELLED), (False, UNMODELLED)):
            a, b = _navigator(start, feedback, p0, noise, un), _navigator(start, feedback, p0, noise, un)
            x0 = rng.standard_normal(N) * SIGMAS
            for nav in (a, b):
                nav._block_start = start.copy()
                nav._x = x0.copy()
            a._propagate_block(end.copy(), 80)
            b._propagate_block_reference(end.copy(), 80)
            phi = a._phi_acc
            # the bound's chain in absolute values: |Phi| |P0| |Phi|^T + |Q_d| (Q_d's scale is below the first)
            scale = np.abs(phi) @ np.abs(p0) @ np.abs(phi).T
            assert np.all(np.abs(a.p - b.p) <= BOUND * scale), np.max(np.abs(a.p - b.p) / scale)
            assert np.all(np.abs(a._phi_acc - b._phi_acc) <= BOUND * np.maximum(np.abs(b._phi_acc), EPS))
            assert np.all(np.abs(a._x - b._x) <= BOUND * (np.abs(phi) @ np.abs(x0)))
            if feedback:
                assert np.array_equal(a._x, x0)        # closed loop: the error state is not carried
            assert np.array_equal(a._block_start, end)


def test_running_integrals_equal_the_cumulative_sums_bit_for_bit():
    """The unmodelled errors' running integrals at the update ends: the kernel adds the samples in the order
    ``np.cumsum`` does (sequentially, from zero), so the rows are identical, not merely close; with samples
    pending from the previous chunk (the first update completed early) and a partial update left at the end."""
    rng = np.random.default_rng(371)
    n_sub, dt = 18, 1.0 / 7200.0
    for pending, n in ((0, 18 * 40), (7, 18 * 40 - 7 + 5), (0, 11)):
        dth = rng.standard_normal((n, 3)) * 1e-4
        dv = rng.standard_normal((n, 3)) * 1e-3 + np.array([0.0, 0.0, -9.81 * dt])
        m = (pending + n) // n_sub
        start = _rows(rng)[0]
        a, b = (ekf.AidedNavigator(StrapdownNavigator(start[0], 0.08, start[1], start[2:5], start[5:9], dt,
                                                      n_sub=n_sub),
                                   ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3), np.eye(N), unmodelled=UNMODELLED)
                for _ in range(2))
        acc0 = rng.standard_normal(6)
        for nav in (a, b):
            nav._acc = acc0.copy()
            nav._f_ref = None
        ra = a._integrals(dth, dv, pending, m)
        rb = b._integrals_reference(dth, dv, pending, m)
        assert ra.shape == (m, 6) and np.array_equal(ra, rb)
        assert np.array_equal(a._acc, b._acc) and np.array_equal(a._f_ref, b._f_ref)


def test_chunk_passes_equal_their_numpy_expressions_bit_for_bit():
    """The increments less the bias estimates, the gyro sum since the last epoch and the per-update sums: the
    kernels add in numpy's order for these shapes (sequentially over the rows), so they are identical."""
    rng = np.random.default_rng(372)
    for n in (0, 17, 18 * 400):
        dth = rng.standard_normal((n, 3)) * np.array([1e-4, 3e-6, 2e-2])
        dv = rng.standard_normal((n, 3)) * 1e-3
        bg_dt, ba_dt = rng.standard_normal(3) * 1e-9, rng.standard_normal(3) * 1e-7
        acc = rng.standard_normal(3)
        want = acc + dth.sum(axis=0)
        a, b = np.empty_like(dth), np.empty_like(dv)
        kekf.bias_corrected(dth, dv, bg_dt, ba_dt, a, b, acc)
        assert np.array_equal(a, dth - bg_dt) and np.array_equal(b, dv - ba_dt) and np.array_equal(acc, want)
        m = n // 18
        sums = np.empty((m, 3))
        kekf.update_sums(dth, 18, sums)
        assert np.array_equal(sums, dth[:18 * m].reshape(-1, 18, 3).sum(axis=1))


def test_error_dynamics_kernel_equals_the_numpy_reference():
    """F entry by entry at a cruise state off the equator (every motion term non-zero)."""
    lat, h = math.radians(-33.0), 1500.0
    vel = np.array([120.0, -80.0, 3.0])
    c = np.asarray(ekf._dcm(quat_from_rotvec([0.1, -0.2, 2.0])))
    f_n = np.array([0.3, -0.5, -9.7])
    noise = ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3, gyro_bias_tau_s=300.0, accel_bias_tau_s=600.0)
    ref = ekf.error_dynamics(lat, h, vel, c, f_n, noise)
    got = np.empty((N, N))
    kekf.error_dynamics_into(lat, h, vel, c, f_n, 1.0 / 300.0, 1.0 / 600.0, got)
    # each entry is a sum of at most four products of the same factors: 8 eps of its magnitude
    assert np.all(np.abs(got - ref) <= 8 * EPS * np.abs(ref)), np.max(np.abs(got - ref))
    assert np.array_equal(got == 0.0, ref == 0.0)


def test_joseph_update_equals_the_numpy_reference():
    """Stacked position and velocity update (6 rows, lever-arm columns) on a correlated covariance."""
    rng = np.random.default_rng(7)
    p0 = _spd(rng, SIGMAS)
    x0 = rng.standard_normal(N) * SIGMAS * 0.1
    h = np.zeros((6, N))
    h[:3, :3] = np.eye(3)
    h[3:, 3:6] = np.eye(3)
    h[:, 6:9] = rng.standard_normal((6, 3))
    r = np.diag([1.0, 1.0, 4.0, 0.0025, 0.0025, 0.01])
    dz = rng.standard_normal(6) * np.sqrt(np.diag(r))
    p_ref, x_ref, nu_ref, s_ref = ekf.AidedNavigator._joseph_reference(p0, x0, h, r, dz)
    p, x = p0.copy(), x0.copy()
    nu, s = kekf.joseph_update(p, x, h, r, dz)
    # S mixes metres and m/s (cond about 6e3 here): the solve adds at most cond * eps relative to K
    cond = np.linalg.cond(s_ref)
    assert cond < 1e4
    kh = np.abs(np.linalg.solve(s_ref, (p0 @ h.T).T).T) @ np.abs(h)
    ikh = np.eye(N) + kh
    scale = ikh @ np.abs(p0) @ ikh.T
    assert np.all(np.abs(p - p_ref) <= cond * BOUND * scale)
    assert np.all(np.abs(x - x_ref) <= cond * BOUND * (np.abs(x0) + kh @ np.abs(x0) + np.abs(dz).max()))
    assert np.all(np.abs(nu - nu_ref) <= BOUND * (np.abs(dz) + np.abs(h) @ np.abs(x0)))
    assert np.all(np.abs(s - s_ref) <= BOUND * (np.abs(h) @ np.abs(p0) @ np.abs(h).T + r))


def test_correct_rows_equals_the_numpy_reference():
    """The feedback on stored rows, one dx per row and one dx for all, near the date line (the wrap)."""
    rng = np.random.default_rng(11)
    k = 9
    lat = np.radians(52.0) + rng.standard_normal(k) * 1e-5
    lon = np.full(k, math.pi - 1e-7) + rng.standard_normal(k) * 1e-8
    h = 300.0 + rng.standard_normal(k)
    vel = rng.standard_normal((k, 3)) * 50.0
    q = quat_from_rotvec(rng.standard_normal((k, 3)))
    for dx in (rng.standard_normal((k, N)) * SIGMAS, rng.standard_normal(N) * SIGMAS):
        got = _correct_rows(lat, lon, h, vel, q, dx)
        ref = _correct_rows_reference(lat, lon, h, vel, q, dx)
        r_n, _ = earth.radii(lat)
        # lat, lon: a correction of dx/R (1e-6 rad) rounded in a different order, 4 eps of the angle;
        # lon may wrap by 2 pi at the date line; h, v: one addition; q: a unit quaternion, 8 eps per component
        dlon = (got[1] - ref[1] + math.pi) % (2 * math.pi) - math.pi
        assert np.all(np.abs(got[0] - ref[0]) <= 4 * EPS * np.abs(lat))
        assert np.all(np.abs(dlon) <= 4 * EPS * math.pi)
        assert np.all(np.abs(got[2] - ref[2]) <= EPS * np.abs(h))
        assert np.array_equal(got[3], ref[3])
        assert np.all(np.abs(got[4] - ref[4]) <= 8 * EPS)
        assert np.all(np.abs(got[0] - lat) > 0.0) and np.all(r_n > 0)
    # the inputs are not modified
    assert np.all(np.abs(lon) < math.pi)


def test_correct_state_equals_apply_correction():
    """The feedback on the navigator's state: the kernel against the public method, after some navigation (the
    previous update's rows set), with a correction of a converged filter's size and one of a fix's size. Same
    expressions, so equal to rounding: a few eps of each entry (the normalisation's sum in another order)."""
    rng = np.random.default_rng(373)
    start = _rows(rng)[0]
    for dx in (np.array([0.3, -0.2, 0.5, 0.01, -0.02, 0.005, 2e-5, -1e-5, 3e-4]),
               np.array([30.0, -25.0, 8.0, 0.5, -0.4, 0.1, 1e-3, -2e-3, 5e-3])):
        a = StrapdownNavigator(start[0], 0.08, start[1], start[2:5], start[5:9], 1.0 / 400.0)
        inc = rng.standard_normal((40, 3))
        a.process(inc * 1e-5, inc * 1e-3 + np.array([0.0, 0.0, -9.81 / 400.0]))
        st = a.state_array()
        a.apply_correction(dx[0:3], dx[3:6], dx[6:9])
        x = np.zeros(N)
        x[:9] = dx
        kekf.correct_state(st, x)
        assert np.all(np.abs(st - a.state_array()) <= 4 * EPS * np.abs(a.state_array()))


def test_interpolate_row_equals_the_numpy_reference():
    """The history's interpolation to a fix's time of validity: inside, at, and beyond the stored rows (clamped),
    across the longitude's wrap and with a quaternion stored with the other sign."""
    from sins_sim.navigation.aided import _History

    rng = np.random.default_rng(374)
    q0 = quat_from_rotvec([0.01, -0.02, 0.7])
    hist = _History(0.0, ekf.NavState(0.0, 0.9, math.pi - 1e-7, 300.0, np.array([40.0, 30.0, -1.0]), q0,
                                      np.zeros(3), np.zeros(3)))
    t = np.arange(1, 6) * 0.0025
    q = quat_from_rotvec(np.array([0.01, -0.02, 0.7]) + np.outer(t, [0.0, 0.0, 0.2]))
    q[2] = -q[2]
    lon = (math.pi - 1e-7 + 3e-8 * np.arange(1, 6) + math.pi) % (2.0 * math.pi) - math.pi
    sol = type("Sol", (), dict(lat_rad=0.9 + 1e-7 * np.arange(1, 6), lon_rad=lon, h_m=300.0 + 0.01 * np.arange(1, 6),
                               v_ned_m_s=rng.standard_normal((5, 3)) + 40.0, q_nb=q))
    hist.append(t, sol, 1.0)
    for t_v in (-0.001, 0.0, 0.0011, 0.005, 0.0062, 0.0125, 0.02):
        a = hist.state_at(t_v, np.zeros(3), np.zeros(3))
        b = hist.state_at_reference(t_v, np.zeros(3), np.zeros(3))
        for f in ("lat_rad", "lon_rad", "h_m", "v_ned_m_s", "q_nb"):
            x, y = np.asarray(getattr(a, f)), np.asarray(getattr(b, f))
            assert np.all(np.abs(x - y) <= 4 * EPS * np.maximum(np.abs(y), 1.0)), (t_v, f, x - y)


def test_gnss_measurement_equals_the_plug_ins():
    """H and dz of the compiled GNSS fix (AidedRun's path) against ekf.Position and ekf.Velocity, with and
    without a lever arm, position and velocity alone and stacked."""
    rng = np.random.default_rng(5)
    q = quat_from_rotvec([0.05, -0.03, 2.4])
    state = ekf.NavState(0.0, math.radians(52.0), math.pi - 2e-7, 310.0, np.array([40.0, -30.0, 1.0]), q,
                         np.array([1e-6, -2e-6, 3e-6]), np.zeros(3))
    rate = np.array([0.01, -0.02, 0.15])
    z_lat, z_lon, z_h = state.lat_rad + 2e-7, -math.pi + 1e-7, 308.0      # across the date line
    z_v = state.v_ned_m_s + rng.standard_normal(3) * 0.05
    for lever in (np.zeros(3), np.array([0.5, 0.0, -1.2])):
        pos = ekf.Position(z_lat, z_lon, z_h, 1.0, lever)
        vel = ekf.Velocity(z_v, 0.05, lever, rate)
        for use_pos, use_vel, plugs in ((True, True, (pos, vel)), (True, False, (pos,)), (False, True, (vel,))):
            rows = 3 * len(plugs)
            h, dz = np.full((rows, N), np.nan), np.full(rows, np.nan)
            kekf.gnss_measurement(state.lat_rad, state.lon_rad, state.h_m, state.v_ned_m_s, state.q_nb,
                                  state.gyro_bias_rad_s, rate, lever, z_lat, z_lon, z_h, z_v, use_pos, use_vel, h, dz)
            h_ref = np.vstack([m.h_matrix(state) for m in plugs])
            dz_ref = np.concatenate([m.innovation(state) for m in plugs])
            # each entry: the same sums of at most nine products, reordered: 16 eps of the largest term; the
            # position's dz (about 1 m) is a difference of metres on an Earth radius, 4 eps of R_E dlat
            assert np.all(np.abs(h - h_ref) <= 16 * EPS * np.maximum(np.abs(h_ref), 1.0)), np.max(np.abs(h - h_ref))
            assert np.array_equal(h == 0.0, h_ref == 0.0)
            assert np.all(np.abs(dz - dz_ref) <= 4 * EPS * 6.4e6 * 1e-6 + 16 * EPS * np.abs(dz_ref))


def test_aided_run_refuses_non_finite_fix_values_it_applies():
    """The compiled fix path reads checked values: add_fixes names a non-finite field of a measurement in use and
    accepts it in one that is not used (a recorded solution without velocities)."""
    import dataclasses

    from sins_sim.navigation.aided import AidedRun
    from sins_sim.navigation.gnss import GnssSettings, simulate_gnss

    lat, h = math.radians(52.0), 300.0
    t = np.arange(0.0, 3.0, 1.0)
    fixes = simulate_gnss(t, np.full(3, lat), np.zeros(3), np.full(3, h), np.zeros((3, 3)), GnssSettings(rate_hz=1.0),
                          seed=1)
    noise = ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3)
    p0 = ekf.initial_covariance(1.0, 0.05, 1e-4, 1e-3, noise)

    def run(use):
        start = ekf.NavState(0.0, lat, 0.0, h, np.zeros(3), np.array([1.0, 0, 0, 0]), np.zeros(3), np.zeros(3))
        return AidedRun(0.0, 0.01, 300, start, noise, p0, fixes.t_valid_s, fixes.t_deliver_s, fixes.position_sigma_m,
                        fixes.velocity_sigma_m_s, fixes.lever_arm_b_m, use=use)

    bad_v = dataclasses.replace(fixes, v_ned_m_s=np.full((3, 3), np.nan))
    with np.testing.assert_raises_regex(ValueError, r"fixes\.v_ned_m_s: must be finite"):
        run(("position", "velocity")).add_fixes(bad_v)
    run(("position",)).add_fixes(bad_v)
    bad_lat = dataclasses.replace(fixes, lat_rad=np.array([lat, np.inf, lat]))
    with np.testing.assert_raises_regex(ValueError, r"fixes\.lat_rad: must be finite"):
        run(("position",)).add_fixes(bad_lat)
