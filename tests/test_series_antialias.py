"""Stored error series of a multi-rate navigation are means over every filter sample (issue 26, open point).

A mission navigates at 400 Hz by default while its errors exist at the filter rate (7.2 kHz). A block mean of the
errors at the 400 Hz updates folds content at and above the 200 Hz navigation Nyquist (the dither lines at
300-450 Hz, vibration) into the stored series: a 387 Hz line sampled at 400 Hz is a 13 Hz line, which a 0.1 s block
mean passes at ``|sin(40 pi 387/400) / (40 sin(pi 387/400))| = 0.198`` of its amplitude, where the mean over every
filter sample passes ``|sin(720 pi 387/7200) / (720 sin(pi 387/7200))| = 0.0067``.
:mod:`sins_sim._kernels.series` adds the between-epoch error, measured at the filter rate, to each update's row.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim._kernels.series import interval_fast_means
from sins_sim.simulation.metrics import N_COLS, ErrorSeries

ARCSEC = math.pi / 648000
ROOT = Path(__file__).resolve().parents[1]


def _rot(q):
    """Body-to-NED rotation matrix of unit quaternion ``q`` (scalar first), by scipy (independent of the kernel)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


def test_the_kernel_against_an_independent_evaluation_and_streaming():
    """:func:`interval_fast_means` against numpy on random data: per interval ``C (mean e - e_m + k (e_m - e_{m-1}))``
    of ``e = G + y - phi`` (``G`` the cumulative sum of the gyro errors from its state) and of ``u`` (the
    cumulative sum of ``aerr + dv_fed - dv_here``), ``k = (n - 1) / (2 n)``, C from scipy's quaternion; to 1e-12
    relative (rounding of sums of up to 126 terms of order one). Two calls over the halves give the bits of one."""
    rng = np.random.default_rng(1)
    n, m = 18, 7
    q = rng.normal(size=(m, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    y, phi, gerr, aerr, dvf, dvh = (rng.normal(size=(m * n, 3)) for _ in range(6))
    state0 = rng.normal(size=9)
    out = np.empty((m, 6))
    st = state0.copy()
    interval_fast_means(n, q, y, phi, gerr, aerr, dvf, dvh, st, out)
    e = state0[3:6] + np.cumsum(gerr, axis=0) + y - phi
    u = state0[6:9] + np.cumsum(aerr + dvf - dvh, axis=0)
    k = (n - 1) / (2 * n)
    e_prev, u_prev = state0[0:3], state0[6:9]
    for i in range(m):
        sl = slice(i * n, (i + 1) * n)
        c = _rot(q[i])
        want_e = c @ (e[sl].mean(axis=0) - e[sl][-1] + k * (e[sl][-1] - e_prev))
        want_u = c @ (u[sl].mean(axis=0) - u[sl][-1] + k * (u[sl][-1] - u_prev))
        np.testing.assert_allclose(out[i, :3], want_e, rtol=0, atol=1e-12 * np.abs(e).max())
        np.testing.assert_allclose(out[i, 3:], want_u, rtol=0, atol=1e-12 * np.abs(u).max())
        e_prev, u_prev = e[sl][-1], u[sl][-1]
    # without y and dv_fed rows: e = G (the ideal increments), u the accelerometers' error alone
    lone = np.empty((m, 6))
    interval_fast_means(n, q, np.zeros((0, 3)), np.zeros((0, 3)), gerr, aerr, np.zeros((0, 3)), np.zeros((0, 3)),
                        state0.copy(), lone)
    g = state0[3:6] + np.cumsum(gerr, axis=0)
    c = _rot(q[0])
    np.testing.assert_allclose(lone[0, :3], c @ (g[:n].mean(axis=0) - g[n - 1] + k * (g[n - 1] - state0[0:3])),
                               rtol=0, atol=1e-12 * np.abs(g).max())
    st2 = state0.copy()
    halves = np.empty((m, 6))
    cut = 3 * n
    interval_fast_means(n, q[:3], y[:cut], phi[:cut], gerr[:cut], aerr[:cut], dvf[:cut], dvh[:cut], st2, halves[:3])
    interval_fast_means(n, q[3:], y[cut:], phi[cut:], gerr[cut:], aerr[cut:], dvf[cut:], dvh[cut:], st2, halves[3:])
    np.testing.assert_array_equal(halves, out)
    np.testing.assert_array_equal(st2, st)


def _dirichlet(f_hz, rate_hz, n):
    """Gain of the mean of ``n`` samples at ``rate_hz`` on a line at ``f_hz``: ``sin(n pi f/r) / (n sin(pi f/r))``."""
    x = math.pi * f_hz / rate_hz
    return math.sin(n * x) / (n * math.sin(x))


def test_a_387_hz_line_is_averaged_over_every_filter_sample_not_aliased():
    """A synthetic attitude error of 3 arcsec at 387 Hz (the dither lines of ``block-dither-coupling.yaml``), body
    = NED, navigated at 400 Hz out of 7.2 kHz and stored at 10 Hz (40 updates per block). Closed form: the block
    mean of ``A sin(w t)`` over ``M`` samples at rate ``r`` centred on ``t_c`` is ``A D(f, r, M) sin(w t_c)``, ``D``
    the Dirichlet gain (:func:`_dirichlet`). With the interval means the stored means are the mean over the 720
    filter samples (gain 0.0067: at most 0.02 arcsec), to 1e-12 arcsec (rounding); the means of the errors at
    the updates alone (the path before) carry the alias, gain 0.198: up to 0.59 arcsec."""
    fs, n, every, amp, f = 7200.0, 18, 40, 3 * ARCSEC, 387.0
    blocks = 20
    t = np.arange(1, blocks * every * n + 1) / fs  # filter samples after the start (t = 0)
    e = np.zeros((t.size, 3))
    e[:, 0] = amp * np.sin(2 * math.pi * f * t)
    rows = np.zeros((blocks * every, N_COLS))
    rows[:, 7:10] = e[n - 1::n]  # the error at the updates (the navigator's psi = C e here)
    rows[:, 12:15] = rows[:, 7:10]
    q = np.tile([1.0, 0.0, 0.0, 0.0], (blocks * every, 1))
    fast = np.empty((blocks * every, 6))
    # the line as the gyro errors' increments (e = G, the ideal path), from e = 0 at the start
    interval_fast_means(n, q, np.zeros((0, 3)), np.zeros((0, 3)), np.diff(e, axis=0, prepend=0.0),
                        np.zeros_like(e), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(9), fast)
    k = (n - 1) / (2 * n)
    means = rows - k * (rows - np.concatenate([np.zeros((1, N_COLS)), rows[:-1]]))
    means[:, 7:10] += fast[:, :3]
    new, old = ErrorSeries(every, n / fs, 0.0, n), ErrorSeries(every, n / fs, 0.0, n)
    for a, b in ((0, 150), (150, 800)):  # in two chunks
        new.add(rows[a:b], means[a:b])
        old.add(rows[a:b])
    got, sampled = new.arrays(), old.arrays()
    tc = got["t_s"]  # the centre of each block's 720 filter samples
    np.testing.assert_allclose(tc, (np.arange(blocks) * every * n + (every * n + 1) / 2) / fs, rtol=0, atol=1e-12)
    want = amp * _dirichlet(f, fs, every * n) * np.sin(2 * math.pi * f * tc)
    assert np.max(np.abs(got["attitude_ned_rad"][:, 0] - want)) < 1e-12 * ARCSEC
    assert np.max(np.abs(want)) < 0.021 * ARCSEC
    # the old path: the mean of the 40 samples at the updates, centred half an interval later
    t_up = tc + (n - 1) / (2 * fs)
    alias = amp * _dirichlet(f, fs / n, every) * np.sin(2 * math.pi * f * t_up)
    np.testing.assert_allclose(sampled["attitude_ned_rad"][:, 0], alias, rtol=0, atol=1e-12 * ARCSEC)
    assert np.max(np.abs(alias)) > 0.5 * ARCSEC
    # the envelope holds the mean and spans the samples at the updates
    assert np.all(got["attitude_ned_rad_min"] <= got["attitude_ned_rad"])
    assert np.all(got["attitude_ned_rad_max"] >= got["attitude_ned_rad"])
    assert np.all(got["attitude_ned_rad_max"][:, 0] >= sampled["attitude_ned_rad_max"][:, 0])


def _block_scenario(rate_hz, duration_s=6.0, chunk_s=1.0, patch=None):
    from sins_sim.config.scenario import load_scenario
    from sins_sim.config.yaml_io import load_yaml
    from sins_sim.simulation import sins

    doc = load_yaml(ROOT / "scenarios" / "block-dither-coupling.yaml")
    doc["duration_s"] = duration_s
    doc["navigation"]["rate_hz"] = rate_hz
    doc["imu"] = str(ROOT / "configs" / "close-dithers-block.yaml")
    sc = load_scenario(doc)
    return sins.simulate_sins(sc.imu, sc.motion, sc.duration_s, seed=sc.seed, nav=sc.nav, filters=sc.filters,
                              vehicle=sc.vehicle, translation=sc.translation, chunk_s=chunk_s, threads=1)


@pytest.fixture(scope="module")
def block_runs():
    """``block-dither-coupling.yaml`` cut to 6 s at every filter sample, at 400 Hz, and at 400 Hz with the stored
    rows at the updates only (the code path before: ``_interval_means`` switched off)."""
    from sins_sim.simulation import sins

    full = _block_scenario(7200.0)
    new = _block_scenario(400.0)
    keep = sins._interval_means
    sins._interval_means = lambda *a, **k: None
    try:
        old = _block_scenario(400.0)
    finally:
        sins._interval_means = keep
    return full, new, old


#: Bound on a 400 Hz stored attitude mean against the full-rate one (arcsec): 4x the 1.2e-3 arcsec measured with
#: the ideal increments, which have no filter-rate error to average (the two navigations' own difference about
#: east in this scenario; 1e-6 arcsec about the other axes and for every filter's between-epoch part), and a
#: fortieth of the alias of a 3 arcsec line through the 40 updates of a block (0.198 x 3 = 0.59 arcsec).
AGREE_ARCSEC = 5e-3


def test_block_dither_coupling_at_400_hz_stores_the_full_rate_means(block_runs):
    """The block's 3 arcsec rocking at 387 Hz, which the eliminator removes with the dither (its attitude error
    carries it) and eq. 5 keeps in part: at 400 Hz every filter's stored attitude means equal the full-rate
    solution's within :data:`AGREE_ARCSEC` at the same block times (measured 1.2e-3 about east, 5e-6 about
    north and down). The path before, the means of the errors at the updates, is off by up to 0.61 arcsec
    (eliminator) and 0.15 (eq. 5); it fails the bound, and its error is the alias predicted from the filter-rate
    gyro-angle error kept for spectra (``SinsResult.spectra``, body = NED at rest heading north): the mean over
    each block's 40 updates minus the mean over its 720 filter samples, within the same bound."""
    full, new, old = block_runs
    ser_f = full.series
    n_sub, every = 18, 40
    for name in full.filters:
        a, b, c = (r.series[name]["attitude_ned_rad"] / ARCSEC for r in (full, new, old))
        nb = min(len(a), len(b))
        assert nb >= 30
        np.testing.assert_allclose(new.series[name]["t_s"][:nb], ser_f[name]["t_s"][:nb], rtol=0, atol=1e-9)
        assert np.max(np.abs(b[:nb] - a[:nb])) < AGREE_ARCSEC, name
        if name == "ideal":
            continue
        assert np.max(np.abs(c[:nb] - a[:nb])) > 20 * AGREE_ARCSEC, name
        e = new.spectra[name][1:]  # filter samples j0 + 1 ..: the first interval's
        nbs = e.shape[0] // (every * n_sub)
        e = e[:nbs * every * n_sub]
        alias = (e[n_sub - 1::n_sub].reshape(nbs, every, 3).mean(axis=1)
                 - e.reshape(nbs, every * n_sub, 3).mean(axis=1)) / ARCSEC
        assert np.max(np.abs((c[:nbs] - a[:nbs]) - alias)) < AGREE_ARCSEC, name
    assert np.max(np.abs(old.series["eliminator"]["attitude_ned_rad"][:nb] / ARCSEC
                         - ser_f["eliminator"]["attitude_ned_rad"][:nb] / ARCSEC)) > 0.5


def test_interval_means_do_not_depend_on_the_chunks():
    """The between-epoch state and the samples kept since the last update stream across chunks: 3 s of the block
    scenario at 400 Hz in 1 s and in 0.37 s chunks (intervals split across chunks) store the same series to 1e-9
    relative. (Not bit for bit: the engine's navigation with a block varies with the chunking by rounding,
    ``tests/test_block_engine.py``; measured 4e-12 relative here. A sample lost or counted twice at a chunk's edge
    would move the eliminator's means by a part of its arcsec-sized between-epoch error: order one relative.)"""
    a = _block_scenario(400.0, duration_s=3.0, chunk_s=1.0)
    b = _block_scenario(400.0, duration_s=3.0, chunk_s=0.37)
    for name in a.filters:
        for key, x in a.series[name].items():
            np.testing.assert_allclose(b.series[name][key], x, rtol=1e-9, atol=1e-15, err_msg=f"{name} {key}")


#: Bound on a 400 Hz stored velocity mean against the full-rate one under the chassis vibration (m/s): 3x the
#: 3.3e-6 m/s measured with the ideal increments (the two navigations' own difference under 2 g of broadband
#: vibration: the sculling the sums neglect), above the 6.2e-6 of the wideband form (the most delayed filter).
VEL_AGREE_M_S = 1e-5


def test_chassis_vibration_with_undelayed_accelerometers_stores_the_full_rate_velocity_means():
    """``block-chassis-vibration.yaml`` cut to 4 s with ``accel_delay: none``: each filter's navigation takes
    accelerometer increments its delay ahead of its gyro increments, an error at the vibration's frequencies
    (20-2000 Hz) that reaches the velocity between updates. At 400 Hz the stored velocity means equal the
    full-rate ones within :data:`VEL_AGREE_M_S` and the attitude means within :data:`AGREE_ARCSEC` (measured
    3.7e-6 m/s and 3e-4 arcsec); the means over the updates alone were off by 1.7e-4 m/s (1.5e-3 for the wideband
    form) and 0.71 arcsec (eliminator)."""
    from sins_sim.config.scenario import load_scenario
    from sins_sim.config.yaml_io import load_yaml
    from sins_sim.simulation import sins

    def run(rate_hz, updates_only=False):
        doc = load_yaml(ROOT / "scenarios" / "block-chassis-vibration.yaml")
        doc.update(duration_s=4.0, imu=str(ROOT / "configs" / "offset-mount-block.yaml"))
        doc["navigation"].update(rate_hz=rate_hz, accel_delay="none")
        sc = load_scenario(doc)
        keep = sins._interval_means
        if updates_only:
            sins._interval_means = lambda *a, **k: None
        try:
            return sins.simulate_sins(sc.imu, sc.motion, sc.duration_s, seed=sc.seed, nav=sc.nav,
                                      filters=sc.filters, vehicle=sc.vehicle, translation=sc.translation,
                                      vibration_enters=sc.vibration_enters, threads=1)
        finally:
            sins._interval_means = keep

    full, new, old = run(7200.0), run(400.0), run(400.0, updates_only=True)
    for name in full.filters:
        nb = min(len(full.series[name]["t_s"]), len(new.series[name]["t_s"]))
        assert nb >= 25
        v = [r.series[name]["velocity_ned_m_s"][:nb] for r in (full, new, old)]
        att = [r.series[name]["attitude_ned_rad"][:nb] / ARCSEC for r in (full, new, old)]
        assert np.max(np.abs(v[1] - v[0])) < VEL_AGREE_M_S, name
        assert np.max(np.abs(att[1] - att[0])) < AGREE_ARCSEC, name
        if name != "ideal":  # the delayed filters: the path before fails the bound
            assert np.max(np.abs(v[2] - v[0])) > 10 * VEL_AGREE_M_S, name
