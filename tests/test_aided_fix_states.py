"""The fixes' Gauss-Markov error as filter states (sins_sim.navigation.ekf.FixErrorStates, issue 37).

With no inertial error (exact increments at rest, zero sensor noise, zero initial covariance of the 15 inertial
states) the augmented filter reduces, per axis, to the scalar Kalman filter of a first-order Gauss-Markov process
``e_(k+1) = a e_k + w_k``, ``a = exp(-T/tau)``, ``var(w) = sigma^2 (1 - a^2)`` (Gelb 1974, sec. 3.8), observed
as ``z = e + v``, ``var(v) = r``: its covariance and its estimate have closed forms to test against.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from sins_sim import earth
from sins_sim._kernels import ekf as kekf
from sins_sim.models.motion import Stationary, Trajectory
from sins_sim.navigation import ekf
from sins_sim.navigation.strapdown import StrapdownNavigator
from sins_sim.simulation.external import ideal_increments

LAT, LON, H = math.radians(52.0), math.radians(4.5), 300.0
DT = 0.05
ZERO = ekf.ImuNoise(0.0, 0.0, 0.0, 0.0)
GM_SIGMA = np.array([1.0, 1.0, 2.0])
WHITE = np.array([0.5, 0.5, 1.0])


def _navigator(fix_errors, p0_gm=None):
    """An aided navigator at rest from the truth, the inertial states' covariance zero."""
    nav = StrapdownNavigator(LAT, LON, H, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), DT)
    n = ekf.N_STATES + fix_errors.n_states
    p0 = np.zeros((n, n))
    p0[ekf.N_STATES:, ekf.N_STATES:] = np.diag(fix_errors.variance if p0_gm is None else p0_gm)
    return ekf.AidedNavigator(nav, ZERO, p0, max_propagation_s=1.0, fix_errors=fix_errors)


def _increments(duration_s):
    traj = Trajectory(LAT, LON, H, 0.0, 0.0, [Stationary(duration_s + 1.0)])
    t = DT * np.arange(1, round(duration_s / DT) + 1)
    return ideal_increments(traj, t)


def riccati_steady(a, q, r):
    """Steady ``(P-, P+)`` of the scalar filter: ``P- = a^2 P+ + q``, ``P+ = P- r / (P- + r)``, i.e. the positive
    root of ``P-^2 + (r (1 - a^2) - q) P- - q r = 0``."""
    b = r * (1.0 - a * a) - q
    pm = 0.5 * (-b + math.sqrt(b * b + 4.0 * q * r))
    return pm, pm * r / (pm + r)


def test_gauss_markov_state_propagates_to_its_closed_form():
    """No measurement: from ``P = 0`` the state's variance is ``sigma^2 (1 - exp(-2 t/tau))`` and the estimate
    decays as ``exp(-t/tau)`` (closed loop: the fix-error states are carried, not fed back), and the stationary
    ``sigma^2`` stays; to rounding (1e-12 relative: one ``exp`` and one product per 1 s block, 60 blocks)."""
    fe = ekf.FixErrorStates(GM_SIGMA, 20.0)
    dth, dv = _increments(60.0)
    for p0_gm in (np.zeros(3), GM_SIGMA ** 2):
        a = _navigator(fe, p0_gm)
        a._x[ekf.N_STATES:] = [0.3, -0.2, 1.0]
        a.process(dth, dv)
        a.propagate()
        t = a.t_s
        want = p0_gm * math.exp(-2.0 * t / 20.0) + GM_SIGMA ** 2 * -math.expm1(-2.0 * t / 20.0)
        gm = np.arange(ekf.N_STATES, ekf.N_STATES + 3)
        assert np.allclose(a.p[gm, gm], want, rtol=1e-12, atol=0.0)
        assert np.allclose(a.x[ekf.N_STATES:], np.array([0.3, -0.2, 1.0]) * math.exp(-t / 20.0), rtol=1e-12)
        assert np.all(a.p[:ekf.N_STATES] == 0.0)      # decoupled from the inertial states


def test_gauss_markov_state_reaches_the_steady_covariance_and_estimates_the_error():
    """Position fixes at 1 Hz with white noise ``r`` and a Gauss-Markov error (tau 2 s) drawn as the model says.
    (1) The state's covariance after the update reaches the Riccati steady state (after 100 updates the transient
    ``~ (a^2 r / (P- + r))^(2k)`` is below 1e-30; 1e-9 relative for the rounding of the recursion).
    (2) The estimate's error ``x - e`` at epochs 20 s apart (10 tau: correlation e^-10, independent) has the
    variance ``P+``: ``sum (x - e)^2 / P+`` within the chi-square 0.1 % and 99.9 % quantiles of its count.
    (3) The estimate's correlation with the true error is ``sqrt(1 - P+/sigma^2)`` (the optimal estimator's
    ``E[x e] = E[x^2] = sigma^2 - P+``): Fisher's z of the sample correlation within 3.29 / sqrt(N - 3) (0.1 %
    two-sided) of it."""
    tau, period, duration = 2.0, 1.0, 600.0
    fe = ekf.FixErrorStates(GM_SIGMA, tau)
    a_gm = math.exp(-period / tau)
    q = GM_SIGMA ** 2 * (1.0 - a_gm ** 2)
    dth, dv = _increments(duration)
    n_upd = round(period / DT)
    r_n, r_e = earth.radii(LAT)
    z2, xs, es = [], [], []
    gm = np.arange(ekf.N_STATES, ekf.N_STATES + 3)
    for seed in range(4):
        rng = np.random.default_rng([seed, 37])
        e = rng.normal(0.0, GM_SIGMA)
        a = _navigator(fe)
        for k in range(round(duration / period)):
            a.process(dth[k * n_upd:(k + 1) * n_upd], dv[k * n_upd:(k + 1) * n_upd])
            e = a_gm * e + rng.normal(0.0, np.sqrt(q))
            d = e + rng.normal(0.0, WHITE)
            a.update(ekf.Position(LAT + d[0] / (r_n + H), LON + d[1] / ((r_e + H) * math.cos(LAT)), H - d[2], WHITE))
            if k == 100:
                for i in range(3):
                    _, pp = riccati_steady(a_gm, q[i], WHITE[i] ** 2)
                    assert a.p[gm[i], gm[i]] == pytest.approx(pp, rel=1e-9)
            if k >= 20 and k % 20 == 0:
                p_plus = a.p[gm, gm]
                x = a.x[ekf.N_STATES:]
                z2.append((x - e) ** 2 / p_plus)
                xs.append(x / GM_SIGMA)
                es.append(e / GM_SIGMA)
    z2 = np.concatenate(z2)
    n = z2.size
    lo, hi = chi2.ppf([0.001, 0.999], n)
    assert lo <= z2.sum() <= hi, (z2.sum(), lo, hi)
    xs, es = np.concatenate(xs), np.concatenate(es)
    rho = [math.sqrt(1.0 - riccati_steady(a_gm, q[i], WHITE[i] ** 2)[1] / GM_SIGMA[i] ** 2) for i in range(3)]
    assert rho[0] == pytest.approx(rho[2])          # sigma and white noise scaled together: one correlation
    r_hat = np.corrcoef(xs, es)[0, 1]
    assert abs(math.atanh(r_hat) - math.atanh(rho[0])) <= 3.29 / math.sqrt(n - 3), (r_hat, rho[0])


def test_fix_error_states_enter_position_rows_only_and_are_not_fed_back():
    """``H`` of a position fix carries ``-I`` on the three states (dz = H x - e + v), a zero-velocity measurement
    none; after an update the inertial states are reset by the feedback and the fix-error estimates kept, and
    ``last_correction`` holds the update's change of all 18."""
    fe = ekf.FixErrorStates(GM_SIGMA, 300.0)
    a = _navigator(fe)
    p0 = ekf.initial_covariance(3.0, 0.1, 1e-4, 1e-3, ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3))
    a._p[:ekf.N_STATES, :ekf.N_STATES] = p0
    r_n, _ = earth.radii(LAT)
    a.update(ekf.Position(LAT + 2.0 / (r_n + H), LON, H, WHITE), ekf.ZeroVelocity(0.01))
    assert a.n_states == 18
    x = a.x
    assert np.all(x[:ekf.N_STATES] == 0.0)
    # the fix 2 m north of the navigator: dz_N = -2 m = dr_N - e_N, shared as the prior variances say (3 m
    # inertial, 1 m Gauss-Markov, 0.5 m white): dr_N = -2 * 9 / 10.25, e_N = +2 * 1 / 10.25
    assert x[ekf.N_STATES] == pytest.approx(2.0 / 10.25, rel=1e-6)
    corr = a.last_correction
    assert corr.shape == (18,) and corr[ekf.N_STATES] == x[ekf.N_STATES]
    assert corr[0] == pytest.approx(-18.0 / 10.25, rel=1e-6)


def random_covariance(rng, extra_sigma):
    """``(sigma, P)``: the 15 inertial states' sigmas of a navigation-grade filter (3-5 m, 0.05-0.1 m/s, 0.1-1 mrad,
    the bias sigmas) then ``extra_sigma``, and a random positive-definite ``P`` with them on its diagonal and
    correlations of a few tenths (a Wishart draw plus ``n I``, scaled to its correlation matrix)."""
    s = np.concatenate([[3.0, 3.0, 5.0, 0.05, 0.05, 0.1, 1e-4, 1e-4, 1e-3], [5e-8] * 3, [1e-3] * 3, extra_sigma])
    n = s.size
    g = rng.standard_normal((n, n))
    c = g @ g.T + n * np.eye(n)
    d = np.sqrt(np.diag(c))
    return s, c / np.outer(d, d) * np.outer(s, s)


def kernel_against_reference(start, end, noise, p0, x0, feedback, **kwargs):
    """One block of 80 navigation updates (0.2 s) from ``start`` to ``end`` by the compiled propagation and by the
    numpy reference, from ``p0`` and ``x0``: ``P`` and ``x`` agree to rounding, the bound of
    tests/test_ekf_kernels.py (100 n eps of the product chain); returns the block's ``Phi``."""
    n = p0.shape[0]
    navs = []
    for _ in range(2):
        nav = StrapdownNavigator(start[0], 0.08, start[1], start[2:5], start[5:9], 1.0 / 400.0)
        navs.append(ekf.AidedNavigator(nav, noise, p0, feedback=feedback, **kwargs))
    for a in navs:
        a._block_start = start.copy()
        a._x = x0.copy()
    navs[0]._propagate_block(end.copy(), 80)
    navs[1]._propagate_block_reference(end.copy(), 80)
    phi = navs[0]._phi_acc
    bound = 100 * n * np.finfo(float).eps
    assert np.all(np.abs(navs[0].p - navs[1].p) <= bound * (np.abs(phi) @ np.abs(p0) @ np.abs(phi).T))
    assert np.all(np.abs(navs[0]._x - navs[1]._x) <= bound * (np.abs(phi) @ np.abs(x0)))
    return phi


def test_propagate_kernel_equals_the_reference_with_fix_states():
    """The compiled block propagation with 3 and 6 fix-error states against the numpy reference, open and closed
    loop (rounding-level: the bound of tests/test_ekf_kernels.py, 100 n eps of the product chain, n = 21)."""
    from test_ekf_kernels import UNMODELLED, _rows

    rng = np.random.default_rng(37)
    start, end = _rows(rng)
    noise = ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3, gyro_bias_tau_s=300.0, accel_bias_tau_s=600.0)
    for fe in (ekf.FixErrorStates(GM_SIGMA, 300.0), ekf.FixErrorStates(GM_SIGMA, 300.0, [0.02, 0.02, 0.05], 60.0)):
        n = ekf.N_STATES + fe.n_states
        s, p0 = random_covariance(rng, np.sqrt(fe.variance))
        for feedback in (True, False):
            phi = kernel_against_reference(start, end, noise, p0, rng.standard_normal(n) * s, feedback,
                                           unmodelled=UNMODELLED, fix_errors=fe)
            gm = np.arange(ekf.N_STATES, n)
            assert np.allclose(phi[gm, gm], np.exp(-0.2 / fe.tau_s), rtol=1e-15)


def test_gnss_measurement_kernel_with_fix_states_in_a_run():
    """The compiled measurement's ``H`` on 18 columns: zero on the fix-error columns from the kernel (the run adds
    ``-I``), the 15 inertial columns as on 15."""
    h15, h18 = np.empty((6, 15)), np.full((6, 18), 7.0)
    dz15, dz18 = np.empty(6), np.empty(6)
    args = (LAT, LON, H, np.array([50.0, 10.0, 0.0]), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3),
            np.array([0.0, 0.0, 0.1]), np.array([0.5, 0.0, -1.2]), LAT, LON, H - 1.0, np.array([50.0, 10.0, 0.1]),
            True, True)
    kekf.gnss_measurement(*args, h15, dz15)
    kekf.gnss_measurement(*args, h18, dz18)
    assert np.array_equal(h18[:, :15], h15) and np.all(h18[:, 15:] == 0.0) and np.array_equal(dz15, dz18)


def test_fix_error_states_bad_input():
    with pytest.raises(ValueError, match="position_tau_s"):
        ekf.FixErrorStates(GM_SIGMA, 0.0)
    with pytest.raises(ValueError, match="give both or neither"):
        ekf.FixErrorStates(GM_SIGMA, 300.0, velocity_sigma_m_s=[0.1] * 3)
    with pytest.raises(ValueError, match="position_sigma_m"):
        ekf.FixErrorStates([-1.0, 1.0, 1.0], 300.0)


def test_augmented_filter_nees_within_bounds_and_mistuned_states_detected():
    """The mission of tests/test_aided_consistency.py (a tactical unit, 120 s with a 90-deg turn, GNSS at 1 Hz,
    its scale factors and misalignments drawn per seed) with the helicopter's Gauss-Markov correlation, 300 s,
    longer than the run, filtered with the three fix-error states (18 states, R the white noise), 50 seeds. The
    90 % rule judged as there: the fraction of epochs whose seed-averaged NEES lies inside its chi-square 95 %
    interval has a Clopper-Pearson 95 % interval over the effectively independent epochs that reaches 0.90, for
    position, velocity and attitude (measured 1.00 / 0.96 / 1.00, n_eff 5.5 / 14.0 / 5.8). Told a Gauss-Markov
    sigma / sqrt(10) or a correlation time / 10, the filter trusts the fixes too much: the position fraction
    falls below 0.90 (measured 0.00 and 0.28) and its interval excludes 0.90 (upper ends 0.27 and 0.88)."""
    from test_aided_consistency import GNSS, Mission, coverage, nees_mc
    from sins_sim.simulation.aiding import AidingSettings

    gnss = dataclasses.replace(GNSS, markov_tau_s=300.0)
    mission = Mission(AidingSettings(gnss=gnss, update_rate_hz=1.0))
    m = mission.model
    assert m.record["states"] == 18 and m.fix_errors is not None
    assert np.array_equal(m.position_sigma_m, gnss.position_sigma_m)          # R: the white noise only
    _, nees = nees_mc(mission, m.noise, m.position_sigma_m, m.velocity_sigma_m_s, m.unmodelled,
                      fix_errors=m.fix_errors)
    cov = coverage(nees)
    assert all(c[3] >= 0.9 for c in cov), cov
    for told in (ekf.FixErrorStates(m.fix_errors.position_sigma_m / math.sqrt(10.0), 300.0),
                 ekf.FixErrorStates(m.fix_errors.position_sigma_m, 30.0)):
        _, nees = nees_mc(mission, m.noise, m.position_sigma_m, m.velocity_sigma_m_s, m.unmodelled, fix_errors=told)
        frac, _, _, hi = coverage(nees)[0]
        assert frac < 0.9 and hi < 0.9, (told, coverage(nees))


def test_filter_model_chooses_states_or_fold():
    """``aiding.fix_error_states`` (default true) gives 18 states with R the white noise; false the fold (15
    states, R the equivalent white variance, larger than the white); no Gauss-Markov error: 15 states either way."""
    from sins_sim.navigation.gnss import GnssSettings
    from sins_sim.simulation.aiding import AidingSettings, filter_model

    noise = ekf.ImuNoise(1e-6, 2e-4, 5e-8, 1e-3)
    gnss = GnssSettings(rate_hz=5.0, position_sigma_m=(1.0, 1.0, 2.0), markov_sigma_m=(0.5, 0.5, 1.0),
                        markov_tau_s=300.0)
    states = filter_model(AidingSettings(gnss=gnss, update_rate_hz=5.0), noise, t0_s=0.0, t1_s=100.0)
    fold = filter_model(AidingSettings(gnss=gnss, update_rate_hz=5.0, fix_error_states=False), noise, t0_s=0.0,
                        t1_s=100.0)
    assert states.record["states"] == 18 and states.fix_errors.n_states == 3
    assert np.array_equal(states.position_sigma_m, [1.0, 1.0, 2.0])
    assert fold.record["states"] == 15 and fold.fix_errors is None and np.all(fold.position_sigma_m > [1.0, 1.0, 2.0])
    plain = filter_model(AidingSettings(gnss=dataclasses.replace(gnss, markov_sigma_m=(0.0, 0.0, 0.0)),
                                        update_rate_hz=5.0), noise)
    assert plain.record["states"] == 15 and plain.fix_errors is None


def test_report_states_the_fix_error_states():
    """With the Gauss-Markov states (``filter_states`` 18) the report says so and gives no fold bound on the NIS."""
    from sins_sim.jobs.run import _aided_findings

    ref = {"horizontal_position_sigma_median_m": 0.9, "nees_position_within_95_fraction": 0.9,
           "nees_velocity_within_95_fraction": 0.9, "nees_attitude_within_95_fraction": 0.9, "nees_position_n": 10,
           "nis_position_mean": 3.0, "nis_position_bound_low": 2.8, "nis_position_bound_high": 3.2,
           "nis_position_n": 10, "filter_position_sigma_told_m_north": 1.0, "filter_position_sigma_told_m_east": 1.0,
           "filter_position_sigma_told_m_down": 2.0, "filter_states": 18, "filter_gnss_markov_tau_s": 300.0}
    metrics = {"aiding": {"position_sigma_m": [1.0, 1.0, 2.0], "markov_sigma_m": [0.5, 0.5, 1.0]}}
    text = _aided_findings(metrics, {"ideal": ref})[-1]
    assert "three position states (18 states" in text and "correlation 300 s" in text, text
    assert "expected at most" not in text


def test_smoother_with_fix_error_states_is_consistent():
    """The Rauch-Tung-Striebel smoother over the 18-state filter (the fix-error states carried through its
    recursion, not fed back): the mission of the NEES test above, 50 seeds; at 20, 60 and 100 s (before, after and
    well after the turn) each block's smoothed NEES summed over the seeds is chi-square with 150 degrees of freedom
    for a consistent smoother (independent seeds), inside its 0.1 % and 99.9 % quantiles (102 to 209; measured
    125 to 161)."""
    from test_aided_consistency import GNSS, N_SEEDS, Mission
    from sins_sim.navigation.aided import smooth
    from sins_sim.simulation.aiding import AidingSettings

    mission = Mission(AidingSettings(gnss=dataclasses.replace(GNSS, markov_tau_s=300.0), update_rate_hz=1.0))
    m = mission.model
    o = mission.out_truth
    total = np.zeros((3, 3))
    for seed in range(N_SEEDS):
        res, _ = mission.run(seed, m.noise, m.position_sigma_m, m.velocity_sigma_m_s, m.unmodelled, m.fix_errors)
        sm = smooth(res)
        assert sm.p.shape[1:] == (18, 18)
        err = sm.errors(o.lat_rad, o.lon_rad, o.h_m, o.v_ned_m_s, o.q_nv)
        for i, k in enumerate(np.searchsorted(res.t_s, [20.0, 60.0, 100.0])):
            for b, sl in enumerate((ekf.POS, ekf.VEL, ekf.ATT)):
                total[i, b] += err[k, sl] @ np.linalg.solve(sm.p[k, sl, sl], err[k, sl])
    lo, hi = chi2.ppf([0.001, 0.999], 3 * N_SEEDS)
    assert np.all((total >= lo) & (total <= hi)), total


def test_aided_run_with_velocity_fix_states():
    """Position and velocity fix-error states in a run (21 states): each fix's position rows carry ``-I`` on
    states 15-17 and its velocity rows on 18-20, so both triples are observed. At rest with no inertial error
    (the first test's setting), 30 fixes at 1 Hz bring each triple's variance to its scalar filter's value after
    30 updates (the Riccati recursion from the stationary prior, 1e-9 relative: the states see the fixes alone)."""
    from sins_sim.navigation.aided import navigate_aided
    from sins_sim.navigation.gnss import GnssSettings, simulate_gnss

    vel_gm, vel_white = np.array([0.02, 0.02, 0.04]), np.array([0.05, 0.05, 0.1])
    fe = ekf.FixErrorStates(GM_SIGMA, 20.0, vel_gm, 10.0)
    dth, dv = _increments(30.0)
    t = DT * np.arange(1, dth.shape[0] + 1)
    tt = np.concatenate([[0.0], t])
    fixes = simulate_gnss(tt, np.full(tt.size, LAT), np.full(tt.size, LON), np.full(tt.size, H),
                          np.zeros((tt.size, 3)), GnssSettings(rate_hz=1.0, position_sigma_m=tuple(WHITE),
                                                               velocity_sigma_m_s=tuple(vel_white)), seed=3)
    p0 = np.zeros((21, 21))
    p0[15:, 15:] = np.diag(fe.variance)
    start = ekf.NavState(0.0, LAT, LON, H, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(3))
    res = navigate_aided(t, dth, dv, start, ZERO, p0, fixes, fix_errors=fe)
    assert res.p_upd.shape[1:] == (21, 21)
    for sl, sig, white, tau in ((slice(15, 18), GM_SIGMA, WHITE, 20.0), (slice(18, 21), vel_gm, vel_white, 10.0)):
        a = math.exp(-1.0 / tau)
        p = sig ** 2
        for _ in range(int(res.updated.sum())):          # P- = a^2 P+ + q, P+ = P- r / (P- + r)
            pm = a * a * p + sig ** 2 * (1.0 - a * a)
            p = pm * white ** 2 / (pm + white ** 2)
        assert np.allclose(np.diag(res.p_upd[-1])[sl], p, rtol=1e-9, atol=0.0), (np.diag(res.p_upd[-1])[sl], p)
