"""The aided run's compiled epochs (issue 37, item 7) against its Python path.

:class:`~sins_sim.navigation.aided.AidedRun` in closed loop handles all the epochs of a chunk in one compiled call
(:func:`sins_sim._kernels.ekf_epoch.aided_chunk`); its Python path (``_epoch``, ``_advance``: the same kernels one
step at a time, the form the filter's other tests hold to the numpy references) is the reference. Both run the
same record here, a turning flight (the lever arm's rate terms are not zero) with two navigation updates per
increment pair (``n_sub = 2``), a fix latency of 0.15 s (three increments: the fixes are applied against
interpolated rows), an outage, the lever arm, the fixes' Gauss-Markov states (18 states) and the unmodelled scale
factors and misalignments (once without both, 15 states, once with velocity fix-error states too, 21), and with
the scale factors and misalignments estimated as states (the gyros' nine, 24 states, or all four groups' eighteen,
33, each also with the position fix-error states: 27 and 36), fed in chunks of 37 increments (not whole navigation
updates, not whole fix intervals). The same kernels in the same order on the same values: every recorded array is
equal bit for bit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sins_sim.models.motion import CoordinatedTurn, Cruise, Trajectory
from sins_sim.navigation import ekf
from sins_sim.navigation.aided import AidedRun
from sins_sim.navigation.gnss import GnssSettings, simulate_gnss
from sins_sim.simulation.external import ideal_increments

LAT, LON, H = math.radians(45.0), math.radians(10.0), 1000.0
DT = 0.05
NOISE = ekf.ImuNoise.from_datasheet(0.05, 50.0, 1.0, 500.0)
P0 = ekf.initial_covariance(2.0, 0.1, 2e-4, 5e-3, NOISE)
SETTINGS = GnssSettings(rate_hz=2.0, position_sigma_m=1.0, velocity_sigma_m_s=0.05, markov_sigma_m=0.5,
                        markov_tau_s=100.0, latency_s=0.15, lever_arm_b_m=(1.0, -0.5, -2.0),
                        outages_s=[(20.0, 32.0)])
CHUNK = 37


@pytest.fixture(scope="module")
def record():
    traj = Trajectory(LAT, LON, H, 100.0, math.radians(30.0), [Cruise(10.0), CoordinatedTurn(20.0, math.pi),
                                                                   Cruise(30.0)])
    n = 1000                                   # 50 s
    t = DT * np.arange(1, n + 1)
    dth, dv = ideal_increments(traj, t)
    rng = np.random.default_rng(7)
    dth = dth + 1e-5 * DT + rng.normal(0.0, NOISE.gyro_arw_rad_sqrt_s * math.sqrt(DT), (n, 3))
    dv = dv + 3e-3 * DT + rng.normal(0.0, NOISE.accel_vrw_m_s_sqrt_s * math.sqrt(DT), (n, 3))
    tt = np.concatenate([[0.0], t])
    tr = traj.evaluate(tt)
    fixes = simulate_gnss(tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, SETTINGS, 11, q_nb=tr.q_nv,
                          omega_ib_b_rad_s=tr.omega_iv_v_rad_s)
    start = ekf.NavState(0.0, tr.lat_rad[0] + 1e-6, tr.lon_rad[0], tr.h_m[0] + 3.0, tr.v_ned_m_s[0] + 0.05,
                         tr.q_nv[0], np.zeros(3), np.zeros(3))
    return dth, dv, fixes, start


PER_FIX = ("t_valid_s", "t_deliver_s", "lat_rad", "lon_rad", "h_m", "v_ned_m_s", "position_error_ned_m",
           "velocity_error_ned_m_s")


def _part(fixes, a, b):
    """Fixes ``a:b`` (in schedule order)."""
    return dataclasses.replace(fixes, **{k: getattr(fixes, k)[a:b] for k in PER_FIX})


#: The sensor-error groups estimated for each state count (the counts with none: 15, 18, 21).
SENSORS = {24: ekf.SENSOR_ERROR_GROUPS[:2], 27: ekf.SENSOR_ERROR_GROUPS[:2], 33: ekf.SENSOR_ERROR_GROUPS,
           36: ekf.SENSOR_ERROR_GROUPS}


def _run(record, compiled, use=("position", "velocity"), latency="compensate", states=18):
    dth, dv, fixes, start = record
    sensors = SENSORS.get(states, ())
    unmod = ekf.UnmodelledErrors(100e-6, 20e-6, 300e-6, 50e-6, None, states=sensors) if states > 15 else None
    n_fix = states - 15 - 9 * len(sensors) // 2 if sensors else states - 15
    fe = {0: None, 3: ekf.FixErrorStates(SETTINGS.markov_sigma_m, SETTINGS.markov_tau_s),
          6: ekf.FixErrorStates(SETTINGS.markov_sigma_m, SETTINGS.markov_tau_s, (0.01,) * 3, 50.0)}[n_fix]
    run = AidedRun(0.0, DT, dth.shape[0], start, NOISE, P0, fixes.t_valid_s, fixes.t_deliver_s,
                   fixes.position_sigma_m, fixes.velocity_sigma_m_s, fixes.lever_arm_b_m,
                   output_t_s=np.arange(0.0, 50.0, 1.0), use=use, latency=latency, n_sub=2, max_propagation_s=0.5,
                   unmodelled=unmod, fix_errors=fe)
    assert run._compiled       # closed loop: the compiled path by default
    run._compiled = compiled
    # the fixes added as the record goes (each before the increments that reach its application)
    added = 0
    for a in range(0, dth.shape[0], CHUNK):
        t_end = (a + CHUNK + 2) * DT
        k = int(np.searchsorted(fixes.t_deliver_s, t_end, side="right"))
        if k > added:
            run.add_fixes(_part(fixes, added, k))
            added = k
        run.feed(dth[a:a + CHUNK], dv[a:a + CHUNK])
    return run.result()


FIELDS = ("t_s", "lat_rad", "lon_rad", "h_m", "v_ned_m_s", "q_nb", "gyro_bias_rad_s", "accel_bias_m_s2", "sigma",
          "updated", "t_valid_s", "phi", "p_pred", "p_upd", "correction", "innovation_t_s", "innovation_t_valid_s",
          "innovation_name", "innovation", "innovation_sigma", "nis")


@pytest.mark.parametrize("use, latency, states", [(("position", "velocity"), "compensate", 18),
                                                  (("velocity",), "ignore", 18), (("position",), "compensate", 18),
                                                  (("position", "velocity"), "compensate", 15),
                                                  (("position", "velocity"), "compensate", 21),
                                                  (("position", "velocity"), "compensate", 24),
                                                  (("position", "velocity"), "compensate", 27),
                                                  (("position", "velocity"), "compensate", 33),
                                                  (("position",), "compensate", 36)])
def test_compiled_epochs_equal_the_python_path_bit_for_bit(record, use, latency, states):
    fast, ref = _run(record, True, use, latency, states), _run(record, False, use, latency, states)
    assert fast.phi.shape[1] == states and np.count_nonzero(ref.updated) > 40 and len(ref.nis) > 40
    if states in SENSORS:      # the sensor-error states were estimated and fed back (the increments' correction)
        assert np.all(np.any(ref.correction[:, states - 9 * len(SENSORS[states]) // 2:] != 0.0, axis=0))
    # the outage: no update with a fix valid inside it
    assert not np.any(ref.updated & (ref.t_valid_s > 20.0) & (ref.t_valid_s < 32.0))
    for name in FIELDS:
        a, b = getattr(fast, name), getattr(ref, name)
        assert a.shape == b.shape and a.dtype.kind == b.dtype.kind, name
        np.testing.assert_array_equal(a, b, err_msg=name)


def test_a_fix_added_late_is_refused_on_both_paths(record):
    dth, dv, fixes, start = record
    for compiled in (True, False):
        run = AidedRun(0.0, DT, dth.shape[0], start, NOISE, P0, fixes.t_valid_s, fixes.t_deliver_s,
                       fixes.position_sigma_m, fixes.velocity_sigma_m_s, fixes.lever_arm_b_m)
        run._compiled = compiled
        run.add_fixes(_part(fixes, 0, 2))
        with pytest.raises(RuntimeError, match="has not been added"):
            run.feed(dth[:200], dv[:200])
        # navigated up to the epoch of the missing fix, and its epochs before it recorded
        assert run.n_epochs == 1 + 2


def test_compiled_smoother_equals_its_numpy_form(record):
    """The Rauch-Tung-Striebel recursion in one compiled call against its numpy form: the same LAPACK solve and
    BLAS products in the same order, where only the products' blocking may differ by a few ulp. The recursion
    over 126 epochs adds such rounding at each step (about 1e-15 of each term), far below 1e-9 of the smoothed
    sigma for the estimate and of ``sqrt(P_ii P_jj)`` for each covariance entry; the corrected solution then agrees
    to 1e-9 of the smoothed sigma too (1e-12 rad of latitude at the sigma's metres)."""
    from sins_sim.navigation.aided import _smooth_reference, smooth

    res = _run(record, True)
    fast, ref = smooth(res), _smooth_reference(res)
    assert np.all(np.abs(fast.estimate - ref.estimate) <= 1e-9 * ref.sigma)
    scale = ref.sigma[:, :, None] * ref.sigma[:, None, :]
    assert np.all(np.abs(fast.p - ref.p) <= 1e-9 * scale)
    np.testing.assert_allclose(fast.sigma, ref.sigma, rtol=1e-9)
    for name, sl in (("gyro_bias_rad_s", ekf.GYRO_BIAS), ("accel_bias_m_s2", ekf.ACCEL_BIAS),
                     ("v_ned_m_s", ekf.VEL)):
        assert np.all(np.abs(getattr(fast, name) - getattr(ref, name)) <= 1e-9 * ref.sigma[:, sl]), name
    np.testing.assert_allclose(fast.h_m, ref.h_m, rtol=0.0, atol=1e-9 * float(np.max(ref.sigma[:, 2])))


def test_sensor_feedback_and_increment_correction_against_numpy():
    """The two kernels both paths share for the sensor-error states: ``K_est -= dK`` at the states' elements (exact:
    one subtraction each), ``(I + K_est)^-1`` by the adjugate against LAPACK's inverse and ``m d`` row by row
    against numpy's product. ``I + K`` with ``|K| ~ 1e-3`` has condition number about 1, so either inverse is
    within a few ulp of the exact one: 8 eps on entries of size 1. A row's product is three products and two sums,
    each rounded once: within 3 eps of ``sum_j |m_ij d_j|`` (Higham 2002, sec. 3.1), 4 eps allowed."""
    from sins_sim._kernels import ekf as kekf

    eps = np.finfo(float).eps
    rng = np.random.default_rng(3)
    un = ekf.UnmodelledErrors(1e-3, 1e-3, 1e-3, 1e-3, None, states=ekf.SENSOR_ERROR_GROUPS)
    kind, row, col, _, _ = un.state_table()
    k_est, k_inv = np.zeros((2, 3, 3)), np.zeros((2, 3, 3))
    dx = rng.normal(0.0, 1e-3, kind.size)
    kekf.sensor_feedback(k_est, k_inv, dx, kind, row, col)
    want = np.zeros((2, 3, 3))
    want[kind, row, col] = -dx
    assert np.array_equal(k_est, want) and np.count_nonzero(k_est) == 18
    for b in range(2):
        assert np.all(np.abs(k_inv[b] - np.linalg.inv(np.eye(3) + k_est[b])) <= 8 * eps)
    d = rng.normal(0.0, 1e-3, (50, 3))
    got = d.copy()
    kekf.triad_corrected(got, k_inv[0])
    bound = 4 * eps * (np.abs(d) @ np.abs(k_inv[0]).T)
    assert np.all(np.abs(got - d @ k_inv[0].T) <= bound)
    assert not np.array_equal(got, d)
