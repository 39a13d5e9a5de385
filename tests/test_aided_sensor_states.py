"""Scale factors and misalignments as filter states (``UnmodelledErrors.states``, ``aiding.sensor_error_states``).

A state ``dK[i, j]`` is the error of the estimate of element ``(i, j)`` of a triad's error matrix ``K``
(``u_meas = (I + K) u + b``, Groves 2013 sec. 4.4.6); its column of ``F`` is ``-C[:, i] x_j`` on the attitude rows
(gyros, ``x`` the body rate) or the velocity rows (accelerometers, ``x`` the specific force). Checked here against
closed forms, against the strapdown navigator itself (a finite difference of the navigation with a perturbed
``K``), against the numpy reference, in closed loop, over a Monte Carlo whose errors are drawn from the filter's
own model, and in the plan layer.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sins_sim import earth
from sins_sim.config.scenario import AIDING_SENSOR_ERROR_STATES
from sins_sim.models.motion import CoordinatedTurn, Cruise, Trajectory
from sins_sim.models.sensor_errors import AccelErrorParams, GyroErrorParams, SensorErrorParams
from sins_sim.navigation import ekf
from sins_sim.navigation.attitude import attitude_error
from sins_sim.navigation.strapdown import StrapdownNavigator
from sins_sim.simulation.external import ideal_increments

LAT, LON, H = math.radians(52.0), math.radians(4.5), 300.0
ZERO = ekf.ImuNoise(0.0, 0.0, 0.0, 0.0)
ALL = ekf.SENSOR_ERROR_GROUPS
FS = 400.0
OMEGA = 0.5               # rad/s about body z
BLOCK_S = 0.2
SIG_S, SIG_M = 30e-6, 20e-6


def _rotating(states, p0_diag):
    """A level unit at rest turning at ``OMEGA`` about body z (down), zero noise, the given sensor states with the
    prior variances ``p0_diag`` (the 15 inertial states zero)."""
    g = float(earth.gravity_down(LAT, H))
    nav = StrapdownNavigator(LAT, 0.0, H, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), 1.0 / FS)
    un = ekf.UnmodelledErrors(SIG_S, SIG_M, 1e-4, 1e-4, (0.0, 0.0, -g), states)
    n = ekf.N_STATES + un.n_states
    p0 = np.zeros((n, n))
    p0[ekf.N_STATES:, ekf.N_STATES:] = np.diag(p0_diag)
    aided = ekf.AidedNavigator(nav, ZERO, p0, max_propagation_s=BLOCK_S, unmodelled=un)
    m = int(BLOCK_S * FS)
    return aided, un, np.tile([0.0, 0.0, OMEGA / FS], (m, 1)), np.tile([0.0, 0.0, -g / FS], (m, 1))


def test_state_table_layout_and_no_double_counting():
    """3 states per scale-factor group, 6 per misalignment group, in the canonical order whatever the order named;
    the priors are the group's sigma; a group that is a state has no process noise (``variances`` zero there)."""
    un = ekf.UnmodelledErrors(1e-5, 2e-5, 3e-5, 4e-5, None, ("accel_misalignment", "gyro_scale_factor"))
    kind, row, col, sig, names = un.state_table()
    assert un.states == ("gyro_scale_factor", "accel_misalignment") and un.n_states == 9
    assert names[:4] == ("dsf_gyro_x", "dsf_gyro_y", "dsf_gyro_z", "dmis_accel_xy")
    assert kind.tolist() == [0] * 3 + [1] * 6 and row.tolist() == [0, 1, 2, 0, 0, 1, 1, 2, 2]
    assert col.tolist() == [0, 1, 2, 1, 2, 0, 2, 0, 1]
    assert sig.tolist() == [1e-5] * 3 + [4e-5] * 6
    assert np.allclose(un.variances, [0.0, 4e-10, 9e-10, 0.0], rtol=1e-12, atol=0.0)
    assert AIDING_SENSOR_ERROR_STATES == ekf.SENSOR_ERROR_GROUPS
    with pytest.raises(ValueError, match="UnmodelledErrors.states: 'gyro_bias'"):
        ekf.UnmodelledErrors(1e-5, 1e-5, 1e-5, 1e-5, states=("gyro_bias",))


def test_constant_rate_scale_factor_and_misalignment_closed_forms():
    """A constant rate ``omega`` about body z (down) for ``t``, from the sensor states' priors alone:

    * scale factor z (sigma ``s``): ``psi_D = -omega t dK_z``, so ``var psi_D = s^2 (omega t)^2`` and
      ``cov(psi_D, dK_z) = -s^2 omega t`` (the coherent growth the process-noise model reaches only as a bound);
    * misalignment xz (sigma ``m``; the x gyro senses the z rate): ``psi' = -C[:, x] omega dK_xz`` with the body x
      axis turning in the level plane, ``C[:, x] = (cos omega t, sin omega t, 0)``, so ``psi_N = -dK (sin omega t)``,
      ``psi_E = -dK (1 - cos omega t)``: the chord, not the arc (the process-noise model's ``m^2 (omega t)^2``).

    The filter evaluates ``C`` at each block's middle (the normalised mean quaternion: exactly the half-way rotation
    about a fixed axis), so its sum over blocks of width ``h = omega T`` is the integral times
    ``(h/2) / sin(h/2)`` (the midpoint rule on a sinusoid, exact); the closed form carries that factor. What it
    leaves out: the Earth-rate coupling ``-[omega_ie x] psi``, at most ``Omega t`` (1.5e-4 over 2 s) of the other
    component (at most twice this one at the times read), so 6e-4 on a variance; RTOL 1e-3."""
    rtol = 1e-3
    aided, un, dth, dv = _rotating(("gyro_scale_factor", "gyro_misalignment"), [SIG_S ** 2] * 3 + [SIG_M ** 2] * 6)
    names = un.state_table()[4]
    k_sz = ekf.N_STATES + names.index("dsf_gyro_z")
    k_xz = ekf.N_STATES + names.index("dmis_gyro_xz")
    h = OMEGA * BLOCK_S
    mid = (h / 2.0) / math.sin(h / 2.0)
    for k in range(10):
        aided.process(dth, dv)
        aided.propagate()
        t = (k + 1) * BLOCK_S
        p = aided.p
        assert p[ekf.HEADING, ekf.HEADING] == pytest.approx(SIG_S ** 2 * (OMEGA * t) ** 2, rel=rtol), k
        assert p[ekf.HEADING, k_sz] == pytest.approx(-SIG_S ** 2 * OMEGA * t, rel=rtol), k
        a = OMEGA * t
        want_n = SIG_M ** 2 * (math.sin(a) * mid) ** 2
        want_e = SIG_M ** 2 * ((1.0 - math.cos(a)) * mid) ** 2
        # psi_N and psi_E from dK_xz alone (the other misalignments' shares are separate columns of P)
        phi_col = np.array([p[6, k_xz], p[7, k_xz]]) / SIG_M ** 2        # d psi / d dK_xz
        assert phi_col[0] ** 2 * SIG_M ** 2 == pytest.approx(want_n, rel=rtol), k
        assert phi_col[1] ** 2 * SIG_M ** 2 == pytest.approx(want_e, rel=rtol), k


def _nav_error(b, a):
    """``b``'s error against ``a`` in the state's definition (position NED m, velocity, psi)."""
    r_n, r_e = earth.radii(a.lat_rad)
    dr = [(b.lat_rad - a.lat_rad) * (r_n + a.h_m), (b.lon_rad - a.lon_rad) * (r_e + a.h_m) * math.cos(a.lat_rad),
          -(b.h_m - a.h_m)]
    return np.concatenate([dr, b.v_ned_m_s - a.v_ned_m_s, attitude_error(b.q_nb[None], a.q_nb[None])[0]])


@pytest.mark.parametrize("name", ["dsf_gyro_z", "dmis_gyro_xy", "dmis_gyro_yx", "dsf_accel_z", "dmis_accel_xz"])
def test_phi_column_against_the_strapdown_with_a_perturbed_matrix(name):
    """A 60 m/s cruise with a 90-deg coordinated turn over 20 s at 50 Hz: the navigator fed ``(I + K) u`` with one
    element of ``K`` at ``delta = 1e-4`` against the navigator fed the exact increments. The difference after 31 s
    is the column of the filter's ``Phi`` (propagated once per navigation update, so no block-mean approximation)
    times the state ``dK = 0 - delta``. The residual is the linearisation's second order, ``delta`` relative to the
    error itself; the tolerance is ten times that, 1e-3 of each block's largest component."""
    delta = 1e-4
    dt = 0.02
    traj = Trajectory(LAT, LON, H, 60.0, 0.4, [Cruise(5.0), CoordinatedTurn(20.0, math.pi / 2), Cruise(7.0)])
    t = dt * np.arange(1, round(31.0 / dt) + 1)
    dth, dv = ideal_increments(traj, t)
    tr = traj.evaluate(np.array([0.0]))

    def nav():
        return StrapdownNavigator(tr.lat_rad[0], tr.lon_rad[0], tr.h_m[0], tr.v_ned_m_s[0], tr.q_nv[0], dt)

    ref = nav()
    ref.process(dth, dv)
    un = ekf.UnmodelledErrors(1e-4, 1e-4, 1e-4, 1e-4, None, ALL)
    kind, row, col, _, names = un.state_table()
    k = names.index(name)
    pert = np.zeros((2, 3, 3))
    pert[kind[k], row[k], col[k]] = delta
    aided = ekf.AidedNavigator(nav(), ZERO, np.zeros((15, 15)), max_propagation_s=dt, unmodelled=un)
    aided.process(dth @ (np.eye(3) + pert[0]).T, dv @ (np.eye(3) + pert[1]).T)
    pred = aided.propagate()[:ekf.N_STATES, ekf.N_STATES + k] * -delta
    err = _nav_error(aided.navigator, ref)
    for sl in (ekf.POS, ekf.VEL, ekf.ATT):
        scale = np.max(np.abs(err[sl]))
        if sl == ekf.ATT and kind[k] == 1:
            continue      # an accelerometer error tilts psi only through the Schuler loop: 1e-12 rad, rounding
        assert np.all(np.abs(err[sl] - pred[sl]) <= 10.0 * delta * scale), (name, sl, err[sl], pred[sl])


def test_propagate_kernel_equals_the_reference_with_sensor_states():
    """The compiled block propagation with the 18 sensor-error states (and 3 fix-error states before them) against
    the numpy reference, open and closed loop: rounding-level, the bound of tests/test_ekf_kernels.py
    (100 n eps of the product chain, n = 36)."""
    from test_aided_fix_states import kernel_against_reference, random_covariance
    from test_ekf_kernels import _rows

    rng = np.random.default_rng(37)
    start, end = _rows(rng)
    noise = ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3, gyro_bias_tau_s=300.0, accel_bias_tau_s=600.0)
    fe = ekf.FixErrorStates([1.0, 1.0, 2.0], 300.0)
    for states in (ALL, ("gyro_misalignment",)):
        un = ekf.UnmodelledErrors(30e-6, 2.9e-5, 3e-4, 9.7e-5, (0.0, 0.0, -9.81), states)
        n = ekf.N_STATES + fe.n_states + un.n_states
        s, p0 = random_covariance(rng, np.concatenate([np.sqrt(fe.variance), un.state_table()[3]]))
        for feedback in (True, False):
            phi = kernel_against_reference(start, end, noise, p0, rng.standard_normal(n) * s, feedback,
                                           unmodelled=un, fix_errors=fe)
            sens = slice(ekf.N_STATES + fe.n_states, n)
            assert np.array_equal(phi[sens, sens], np.eye(un.n_states))       # random constants


def test_feedback_corrects_the_increments_like_the_biases():
    """After an update the estimated ``dK`` is fed back, ``K_est -= dK``, the states reset to zero, and the
    navigator then integrates ``(I + K_est)^-1 (u - b dt)``: the same solution, to rounding (1e-15 of the unit
    quaternion, 1e-15 m/s), as a twin filter without the feedback fed those increments."""
    states = ("gyro_scale_factor", "accel_misalignment")
    prior = [SIG_S ** 2] * 3 + [1e-8] * 6
    aided, un, dth, dv = _rotating(states, prior)
    twin, _, _, _ = _rotating(states, prior)
    aided.process(dth, dv)
    twin.process(dth, dv)
    sens = aided.sensor_error_slice
    aided._x[sens] = np.linspace(-3e-5, 4e-5, un.n_states)     # as an update would leave it (its change)
    aided._change = aided.x
    x_sens = aided.x[sens]
    aided._apply_feedback()
    assert np.all(aided.x == 0.0)
    kg, ka = aided.gyro_error_matrix, aided.accel_error_matrix
    assert np.array_equal(np.diag(kg), -x_sens[:3])
    assert ka[0, 1] == -x_sens[3] and ka[2, 1] == -x_sens[8] and np.all(np.diag(ka) == 0.0)
    aided.process(dth, dv)
    twin.process(dth @ np.linalg.inv(np.eye(3) + kg).T, dv @ np.linalg.inv(np.eye(3) + ka).T)
    a, b = aided.navigator, twin.navigator
    assert np.allclose(a.q_nb, b.q_nb, rtol=0.0, atol=1e-15)
    assert np.allclose(a.v_ned_m_s, b.v_ned_m_s, rtol=0.0, atol=1e-15)


#: Gyro scale factors and misalignments large enough to dominate the attitude error of the consistency mission
#: (tests/test_aided_consistency.py): 1000 ppm and 200 arcsec, 1-sigma, drawn per seed.
LARGE = SensorErrorParams(GyroErrorParams(scale_factor_ppm=1000.0, misalignment_arcsec=[200.0] * 6),
                          AccelErrorParams(scale_factor_ppm=300.0, misalignment_arcsec=[20.0] * 6))


def test_monte_carlo_nees_with_sensor_states_and_a_mistuned_prior_detected():
    """The mission of tests/test_aided_consistency.py (120 s, a 90-deg turn, GNSS at 1 Hz, 50 seeds) with the
    gyros' scale factors and misalignments drawn per seed from the sigmas the filter's 9 gyro states are told as
    priors (27 states). The 90 % rule judged as there: the fraction of epochs whose seed-averaged NEES is inside its
    chi-square 95 % interval has a Clopper-Pearson interval over the effectively independent epochs that reaches
    0.90 for position, velocity and attitude (measured 0.87 / 0.94 / 1.00, n_eff 6.0 / 12.9 / 9.7). Told a prior
    ten times too small, the filter is overconfident once the turn has shown the errors: the velocity and
    attitude fractions fall below 0.90 and their intervals exclude it (measured 0.29 and 0.26, upper ends 0.81 and
    0.87)."""
    from test_aided_consistency import GNSS, Mission, coverage, nees_mc
    from sins_sim.simulation.aiding import AidingSettings

    mission = Mission(AidingSettings(gnss=GNSS, update_rate_hz=1.0,
                                     sensor_error_states=("gyro_scale_factor", "gyro_misalignment")), LARGE)
    m = mission.model
    assert m.record["states"] == 27 and m.unmodelled.n_states == 9
    _, nees = nees_mc(mission, m.noise, m.position_sigma_m, m.velocity_sigma_m_s, m.unmodelled,
                      fix_errors=m.fix_errors)
    cov = coverage(nees)
    assert all(c[3] >= 0.9 for c in cov), cov
    un = m.unmodelled
    told = dataclasses.replace(un, gyro_scale_factor=un.gyro_scale_factor / 10.0,
                               gyro_misalignment_rad=un.gyro_misalignment_rad / 10.0)
    _, nees = nees_mc(mission, m.noise, m.position_sigma_m, m.velocity_sigma_m_s, told, fix_errors=m.fix_errors)
    cov = coverage(nees)
    for b in (1, 2):
        assert cov[b][0] < 0.9 and cov[b][3] < 0.9, cov


def test_filter_model_and_plan_checks():
    """``aiding.sensor_error_states`` reaches the filter model (27 states with the three fix-error states; the
    gyro bias prior no longer raised by the scale factors' constant part, which the states carry); a group named
    twice, or states without the IMU's ``sensors:``, are refused naming the key."""
    from sins_sim.navigation.gnss import GnssSettings
    from sins_sim.plan.scenario import _aiding_settings
    from sins_sim.simulation.aiding import AidingSettings, filter_model

    traj = Trajectory(LAT, LON, H, 60.0, 0.0, [Cruise(20.0), CoordinatedTurn(30.0, math.pi / 2), Cruise(31.0)])
    gnss = GnssSettings(rate_hz=1.0, markov_sigma_m=(0.5, 0.5, 1.0), markov_tau_s=300.0)
    noise = ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3)
    plain = filter_model(AidingSettings(gnss=gnss), noise, LARGE, traj, 0.0, 80.0)
    st = filter_model(AidingSettings(gnss=gnss, sensor_error_states=("gyro_scale_factor", "gyro_misalignment")),
                      noise, LARGE, traj, 0.0, 80.0)
    assert plain.record["states"] == 18 and st.record["states"] == 27
    assert st.record["sensor_error_states"] == "gyro_scale_factor, gyro_misalignment"
    assert np.all(st.bias_var_extra[:3] == 0.0) and np.any(plain.bias_var_extra[:3] > 0.0)
    assert np.array_equal(st.bias_var_extra[3:], plain.bias_var_extra[3:])
    assert st.unmodelled.variances[:2].tolist() == [0.0, 0.0] and st.unmodelled.variances[2] > 0.0

    class _Imu:
        filter_rate_hz = 400.0
        sensors = None

    class _Sc:
        imu = _Imu()
        nav = type("N", (), {"start_s": 1.0})()
        duration_s = 100.0

    a = {"rate_hz": 1.0, "update_rate_hz": None, "outages_s": [], "file": "", "position_sigma_m": [1.0] * 3,
         "velocity_sigma_m_s": [0.1] * 3, "markov_sigma_m": [0.0] * 3, "markov_tau_s": 300.0, "latency_s": 0.0,
         "lever_arm_m": [0.0] * 3, "measurements": ["position"], "feedback": True, "smoother": False,
         "fix_error_states": True}
    from sins_sim.plan.errors import PlanError

    with pytest.raises(PlanError, match=r"aiding.sensor_error_states: each group at most once"):
        _aiding_settings({}, {**a, "sensor_error_states": ["gyro_scale_factor"] * 2}, _Sc(), ".", "s.yaml", "d")
    with pytest.raises(PlanError, match=r"aiding.sensor_error_states: needs the IMU's sensors"):
        _aiding_settings({}, {**a, "sensor_error_states": ["gyro_misalignment"]}, _Sc(), ".", "s.yaml", "d")
    _Imu.sensors = LARGE
    got = _aiding_settings({}, {**a, "sensor_error_states": ["gyro_misalignment"]}, _Sc(), ".", "s.yaml", "d")
    assert got.sensor_error_states == ("gyro_misalignment",)


def test_mission_with_sensor_states_is_chunk_invariant_and_states_them():
    """Through the scenario layer: ``aiding.sensor_error_states`` reaches the mission's filter (24 states: no fix
    Gauss-Markov error here, 15 + 3 + 6), ``metrics.json`` states the groups, the run does not depend on the chunk
    length (the correction ``(I + K_est)^-1`` changes only at feedback, at update boundaries; the tolerance that of
    tests/test_mission_aided.py: sums taken in another association, a few ulps amplified by the gains to 1e-9 m),
    and an unknown group is refused naming the key."""
    from test_mission_aided import _doc, _refused, _run

    doc = _doc(duration_s=14.0, outages_s=[[6.0, 9.0]],
               sensor_error_states=["gyro_misalignment", "gyro_scale_factor"])
    a, _ = _run(doc, chunk_s=1.0)
    b, _ = _run(doc, chunk_s=0.37)
    ra, rb = a.aided["ideal"]["result"], b.aided["ideal"]["result"]
    assert ra.sigma.shape[1] == 24
    assert a.aided["ideal"]["filter_model"]["sensor_error_states"] == "gyro_scale_factor, gyro_misalignment"
    np.testing.assert_allclose(a.aided["ideal"]["errors"], b.aided["ideal"]["errors"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(ra.sigma, rb.sigma, rtol=1e-9)
    _refused(_doc(sensor_error_states=["gyro_bias"]), "aiding.sensor_error_states[0]")


def test_report_states_the_sensor_states_and_not_the_fix_states_they_are_not():
    """With sensor-error states and the Gauss-Markov fold (24 states, no fix-error states) the report names the
    groups and does not claim fix-error states (it gives the fold's NIS bound instead)."""
    from sins_sim.jobs.run import _aided_findings

    ref = {"horizontal_position_sigma_median_m": 0.9, "nees_position_within_95_fraction": 0.9,
           "nees_velocity_within_95_fraction": 0.9, "nees_attitude_within_95_fraction": 0.9, "nees_position_n": 10,
           "nis_position_mean": 0.03, "nis_position_bound_low": 2.8, "nis_position_bound_high": 3.2,
           "nis_position_n": 10, "filter_position_sigma_told_m_north": 10.0, "filter_position_sigma_told_m_east": 10.0,
           "filter_position_sigma_told_m_down": 20.0, "filter_states": 24,
           "filter_sensor_error_states": "gyro_scale_factor, gyro_misalignment"}
    metrics = {"aiding": {"position_sigma_m": [1.0, 1.0, 2.0], "markov_sigma_m": [0.5, 0.5, 1.0]}}
    text = _aided_findings(metrics, {"ideal": ref})[-1]
    assert "groups gyro_scale_factor, gyro_misalignment as states" in text, text
    assert "three position states" not in text and "expected at most" in text, text
