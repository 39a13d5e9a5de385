"""Tests of the filtered-noise and translational vibrations (``sins_sim.models.motion.vibration``).

References are independent of the implementation: a Gauss quadrature of the
rate for the angle (and of the acceleration for the velocity), scipy's Welch
PSD and the table for the spectrum, the table's integral for the RMS,
``AttitudeStream``'s own closed form and a fine-step reference for the attitude.

Tolerances
----------
* Exact integrals: the rate is a quartic in time on each node segment, so a
  6-point quadrature per segment is exact for it. Its nodes are floats, off
  their ideal places by ``eps |t|``; the weights are solved for the nodes'
  actual positions (moment equations), so the reference stays exact to
  rounding at any ``t`` (measured 3.5e-18 rad at t = 0, 20, 3600 s against
  angles of 1e-3 rad). Allowed: 1e-16 rad (angles, ``eps`` times their scale
  is 2e-19) and 1e-16 m/s (velocities).
* Spectra: Welch with a Hann window, ``nperseg = fs`` (1 Hz bins), 50 %
  overlap, over ``T = 60`` s: ``K = 119`` segments, about ``K / 1.06``
  independent (Hann overlap correlation 0.167^2 ...), so a bin scatters by
  ``1 / sqrt(K / 1.06) = 9.4 %`` and a band of ``n`` bins (adjacent bins of a
  Hann window correlate: ``n / 2`` independent) by
  ``sigma = 9.4 % / sqrt(n / 2)``. Third-octave bands are checked against
  the design PSD at 5 sigma plus 0.5 % (0.02 dB); the whole band against
  the table at 5 sigma (sigma = 0.3 %, 0.013 dB).
* RMS over ``T``: the variance estimate of a Gaussian process scatters by
  ``sqrt(integral S^2 df / T) / integral S df`` (relative); RMS by half
  that: 0.16 % here; 5 sigma allowed.
* Autocorrelation at a lag ``L << T``: scatter
  ``sqrt(integral S^2 df / T) / integral S df`` (0.32 %); 5 sigma allowed.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import integrate, signal
from scipy.spatial.transform import Rotation

from chunking import uneven_bounds, uneven_chunks
from sins_sim.models.motion import (
    STANDARD_GRAVITY,
    AttitudeStream,
    AxisSines,
    Coning,
    FilteredNoiseVibration,
    LinearRandomVibration,
    LinearSines,
    RandomVibration,
    SumTranslation,
    Translation,
)
from sins_sim.units import ARCMIN

RV_TABLE = ((10.0, 1e-4), (100.0, 1e-3), (1000.0, 1e-3), (2000.0, 2e-4))  # (rad/s)^2/Hz
ENGINE_G2 = ((20.0, 0.002), (80.0, 0.04), (350.0, 0.04), (2000.0, 0.007))  # g^2/Hz, an engine-like shape
WEIGHTS = (1.0, 0.5, 2.0)
FS = 72_000.0  # plant rate
FSAMP = 8192.0  # rate sampling for the spectra
T_REC = 60.0
SIZES = (1, 3, 10, 7, 19, 997, 2, 4001, 250, 0, 30_011)


@pytest.fixture(scope="module")
def vib():
    return FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, axis_weights=WEIGHTS, seed=11)


@pytest.fixture(scope="module")
def record(vib):
    """60 s of rate sampled at 8192 Hz, (N, 3)."""
    t = np.arange(int(FSAMP * T_REC)) / FSAMP
    return vib.body_rate(t)


def loglog_power(table, lo, hi, power=1):
    """``integral_lo^hi S(f)^power df`` of the log-log table, by scipy quad."""
    f = np.log([r[0] for r in table])
    p = np.log([r[1] for r in table])

    def s(x):
        return math.exp(power * np.interp(math.log(x), f, p))

    pts = [math.exp(x) for x in f if lo < math.exp(x) < hi]
    return integrate.quad(s, lo, hi, points=pts or None, epsabs=0.0, epsrel=1e-12, limit=200)[0]


def exact_quadrature(func, a, b, fs, order=6):
    """``integral_a^b func dt`` (3-vector): Gauss points per node segment, weights fitted to their float positions."""
    if a == b:
        return np.zeros(3)
    br = np.arange(math.ceil(a * fs), math.floor(b * fs) + 1) / fs
    br = np.concatenate(([a], br[(br > a) & (br < b)], [b]))
    lo, hi = br[:-1], br[1:]
    x, _ = np.polynomial.legendre.leggauss(order)
    tt = lo[:, None] + 0.5 * (hi - lo)[:, None] * (x + 1.0)[None, :]
    span = (hi - lo)[:, None]
    s = (tt - lo[:, None]) / span  # the nodes' actual places
    vander = s[:, None, :] ** np.arange(order)[None, :, None]
    moments = np.broadcast_to(1.0 / (np.arange(order) + 1.0), (lo.size, order))[..., None]
    weights = np.linalg.solve(vander, moments)[..., 0] * span
    vals = func(tt.ravel()).reshape(lo.size, order, 3)
    return np.einsum("ni,nic->c", weights, vals)


def qangle(qa, qb):
    ra = Rotation.from_quat(np.roll(np.atleast_2d(qa), -1, axis=-1))
    rb = Rotation.from_quat(np.roll(np.atleast_2d(qb), -1, axis=-1))
    return (ra.inv() * rb).magnitude()


# --- statistics -------------------------------------------------------------------


def test_psd_matches_the_table(vib, record):
    f, p = signal.welch(record, FSAMP, nperseg=int(FSAMP), axis=0, detrend=False)
    k_eff = (2 * T_REC - 1) / 1.06
    bin_sigma = 1.0 / math.sqrt(k_eff)
    # the design itself: within 0.02 dB of the table away from the edges (measured 0.015 dB)
    edge = 4.0 * vib.node_rate_hz / (vib.n_taps - 1)
    inner = f[(f >= 20.0 + edge) & (f <= 2000.0 - edge)]
    dev = 10 * np.log10(vib.design_psd(inner) / vib.psd(inner))
    assert np.abs(dev).max() < 0.02, np.abs(dev).max()
    # third-octave bands 25 Hz .. 1.6 kHz, each axis: 5 sigma of Welch's scatter (worst measured 2.8 sigma)
    centres = 1000.0 * 2.0 ** (np.arange(-16, 3) / 3.0)
    for fc in centres:
        band = (f >= fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))
        sigma = bin_sigma / math.sqrt(max(band.sum() / 2.0, 1.0))
        expect = vib.design_psd(f[band]).mean()  # the edge band at 25 Hz is rounded off by design
        for i, w in enumerate(WEIGHTS):
            ratio = p[band, i].mean() / (w * w * expect)
            assert abs(ratio - 1.0) < 5 * sigma + 0.005, (fc, i, ratio, sigma)
    # the whole band 20 Hz + edge .. 2 kHz - edge (measured -0.012, -0.005, +0.010 dB; sigma 0.013 dB)
    band = (f >= 20.0 + edge) & (f <= 2000.0 - edge)
    sigma = bin_sigma / math.sqrt(band.sum() / 2.0)
    for i, w in enumerate(WEIGHTS):
        ratio = np.mean(p[band, i] / (w * w * vib.psd(f[band])))
        assert abs(ratio - 1.0) < 5 * sigma, (i, ratio, sigma)
    # nothing outside the band widened by the edge rounding: the design below 1e-11 of its peak
    # (measured 2e-12), Welch with a Blackman-Harris window (sidelobes -92 dB) below 1e-9 (measured 1.6e-10)
    fd = np.linspace(0.0, FSAMP / 2, 40_961)
    outside = (fd < 20.0 - edge) | (fd > 2000.0 + edge)
    assert vib.design_psd(fd[outside]).max() < 1e-11 * vib.design_psd(fd).max()
    f, p = signal.welch(record, FSAMP, window="blackmanharris", nperseg=int(FSAMP), axis=0, detrend=False)
    peak = p[(f > 20) & (f < 2000)].max()
    assert p[f < 15.0].max() < 1e-9 * peak
    assert p[(f > 2010.0) & (f < 4000.0)].max() < 1e-9 * peak


def test_rms_matches_the_table(vib, record):
    power = loglog_power(RV_TABLE, 20.0, 2000.0)
    expect = math.sqrt(power) * np.array(WEIGHTS)
    assert_allclose(vib.rms_rate_rad_s, expect, rtol=1e-12)
    sigma = 0.5 * math.sqrt(loglog_power(RV_TABLE, 20.0, 2000.0, power=2) / T_REC) / power
    rms = np.sqrt(np.mean(record**2, axis=0))
    # measured -0.10 %, -0.06 %, +0.03 % (sigma = 0.16 %)
    assert_allclose(rms, expect, rtol=5 * sigma)
    assert np.abs(record.mean(axis=0)).max() < 5 * sigma * expect.max()


def test_no_periodicity(vib, record):
    power = loglog_power(RV_TABLE, 20.0, 2000.0)
    sigma = math.sqrt(loglog_power(RV_TABLE, 20.0, 2000.0, power=2) / T_REC) / power
    var = np.mean(record**2, axis=0)
    block_s = vib.block_nodes / vib.node_rate_hz
    for lag_s in (1.0, 0.5, block_s, 2 * block_s):
        lag = int(round(lag_s * FSAMP))
        rho = np.mean(record[:-lag] * record[lag:], axis=0) / var
        assert np.abs(rho).max() < 5 * sigma, (lag_s, rho)  # measured below 0.004 (sigma 0.0032)
    # cross-axis independence at zero lag
    corr = np.corrcoef(record.T)
    assert np.abs(corr[np.triu_indices(3, 1)]).max() < 5 * sigma
    # the comb RandomVibration with df = 1 Hz (tones at 20.5, 21.5, ... Hz) flips sign every second
    # and repeats every 2 s: the check would see it
    rv = RandomVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=200.0, seed=1, df_hz=1.0)
    t = np.arange(3000) / 1000.0
    r = rv.body_rate(t)[:, 0]
    assert abs(np.mean(r[:-1000] * r[1000:]) / np.mean(r**2)) > 0.99


def test_angle_is_bounded_over_an_hour(vib):
    """The angle is a stationary filtered process: no random walk (random access to t = 3600 s)."""
    d = vib._noise().d
    rms_angle = math.sqrt(np.sum(d.value_psd) * (d.freqs[1] - d.freqs[0])) * np.array(WEIGHTS)
    t = 3600.0 + np.arange(14_400) / 14_400.0
    phi = vib.gyro_angle(t) + vib._noise().value0()  # theta(t)
    assert np.all(np.abs(phi.mean(axis=0)) < 1.0 * rms_angle)
    assert_allclose(np.sqrt(np.mean(phi**2, axis=0)), rms_angle, rtol=0.5)  # 1 s of a 20 Hz-dominated angle
    assert np.abs(vib.gyro_angle(3600.0)).max() < 6 * rms_angle.max()


def test_interpolation_images(vib):
    """Rate sampled at 8 node rates: the power above the node Nyquist is the design's image level."""
    fhs = 8 * vib.node_rate_hz
    t = np.arange(int(2 * fhs)) / fhs
    f, p = signal.welch(vib.body_rate(t)[:, 0], fhs, nperseg=16_384)
    inband = f < vib.node_rate_hz / 2
    measured = 10 * np.log10(p[~inband].sum() / p[inband].sum())
    # measured -106.98 dB, design -106.95 dB; quintic images at f_hi = fs/7.2 are -92 dB of the rate there
    assert vib.image_level_db < -100.0
    assert measured == pytest.approx(vib.image_level_db, abs=1.0)


# --- exactness, chunking, random access, seeds ------------------------------------------


@pytest.mark.parametrize("base", [0.0, 20.0, 3600.0, -50.0])
def test_gyro_angle_is_the_exact_integral_of_the_rate(vib, base):
    rng = np.random.default_rng(int(abs(base)) + 1)
    ta = base + rng.uniform(-1.0, 1.0, 12)
    tb = ta + rng.uniform(0.0, 3e-3, 12)
    tb[0] = ta[0]
    for a, b in zip(ta, tb):
        ref = exact_quadrature(vib.body_rate, a, b, vib.node_rate_hz)
        assert np.abs(vib.angle_increment(a, b) - ref).max() < 1e-16  # measured 3.5e-18 rad
        assert np.abs((vib.gyro_angle(b) - vib.gyro_angle(a)) - ref).max() < 1e-16 + 1e-15 * abs(ref).max()
    assert_array_equal(vib.gyro_angle(0.0), 0.0)


def test_rate_is_continuous_at_nodes_and_block_ends(vib):
    fs = vib.node_rate_hz
    nb = vib.block_nodes
    t = np.array([1, 2, 777, nb - 1, nb, nb + 1, 2 * nb, -nb]) / fs
    tm, tp = t - 1e-12, t + 1e-12
    # across a node 2 ps apart: the rate changes by rate' 2 ps (< 1e-6 rad/s), the angle by rate 2 ps
    assert np.abs(vib.body_rate(tp) - vib.body_rate(tm)).max() < 1e-6
    step = vib.gyro_angle(tp) - vib.gyro_angle(tm)
    assert np.abs(step - vib.body_rate(t) * (tp - tm)[:, None]).max() < 1e-17


def test_chunks_equal_one_call_bit_for_bit():
    vib = FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, seed=4)
    t = np.arange(1, 660_001) / FS  # 9.2 s: crosses a block end (8 s)
    assert t[-1] * vib.node_rate_hz > vib.block_nodes
    whole_rate, whole_angle = vib.body_rate(t), vib.gyro_angle(t)
    fresh = FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, seed=4)
    chunks = uneven_chunks(t, SIZES)
    assert_array_equal(np.concatenate([fresh.body_rate(c) for c in chunks]), whole_rate)
    assert_array_equal(np.concatenate([fresh.gyro_angle(c) for c in chunks]), whole_angle)
    whole_inc = vib.angle_increment(t[:-1], t[1:])
    pairs = np.stack((t[:-1], t[1:]), axis=1)
    parts = [fresh.angle_increment(c[:, 0], c[:, 1]) for c in uneven_chunks(pairs, SIZES)]
    assert_array_equal(np.concatenate(parts), whole_inc)


def test_grid_angle_rate_is_one_pass_of_both():
    vib = FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, axis_weights=WEIGHTS, seed=12)
    h = 1.0 / FS
    angle, rate = vib.grid_angle_rate(99, 50_000, h)
    t = np.arange(100, 50_100) * h
    assert angle.flags.f_contiguous and rate.flags.f_contiguous  # axis-major, as the engine adds to it in place
    # 72 kHz is 5 steps per 14.4 kHz node segment: the grid's positions are the exact (m mod 5) / 5, the
    # general kernel's those of the rounded times m h, which differ by at most eps t (the rounding of
    # m h, eps t / 2, and of the position in the segment, eps / fs); the values by that times the
    # derivative (bounded by 1.5 times the largest finite difference on the grid) plus their own
    # rounding (8 eps of the largest value: about 10 operations each)
    dt = np.finfo(float).eps * t[-1]
    accel = np.abs(np.diff(rate, axis=0)).max() / h
    ref_angle, ref_rate = vib.gyro_angle(t), vib.body_rate(t)
    eps8 = 8 * np.finfo(float).eps
    assert_allclose(angle, ref_angle, rtol=0, atol=np.abs(rate).max() * dt + eps8 * np.abs(ref_angle).max())
    assert_allclose(rate, ref_rate, rtol=0, atol=1.5 * accel * dt + eps8 * np.abs(ref_rate).max())
    assert not np.array_equal(rate, ref_rate)  # the grid path was taken (exact positions, other roundings)
    a0, r0 = vib.grid_angle_rate(-1, 1, h)  # t = 0, a node: the same operations as the general kernel
    assert_array_equal(a0, 0.0)
    assert_array_equal(r0, vib.body_rate([0.0]))
    parts = [vib.grid_angle_rate(i0, i1 - i0, h) for i0, i1 in uneven_bounds(50_000, SIZES)]
    assert_array_equal(np.concatenate([p[0] for p in parts]), vib.grid_angle_rate(0, 50_000, h)[0])
    assert_array_equal(np.concatenate([p[1] for p in parts]), vib.grid_angle_rate(0, 50_000, h)[1])
    mot = Coning(ARCMIN, 100.0) + vib  # a sum uses it through its parts
    a2, r2 = mot.grid_angle_rate(99, 1000, h)
    # the coning's recurrence to 1e-17 rad and 1e-14 rad/s, plus the vibration's grid positions (above)
    dt = np.finfo(float).eps * t[999]
    assert_allclose(a2, mot.gyro_angle(t[:1000]), rtol=0, atol=1e-17 + np.abs(rate).max() * dt)
    assert_allclose(r2, mot.body_rate(t[:1000]), rtol=0, atol=1e-14 + 1.5 * accel * dt + eps8 * np.abs(rate).max())


def test_random_access_equals_sequential():
    kw = dict(psd_table=RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, seed=9)
    late = np.array([1000.3, 1000.3 + 1 / FS])
    first = FilteredNoiseVibration(**kw)
    r_late, a_late = first.body_rate(late), first.gyro_angle(late)  # late time first (block 125)
    seq = FilteredNoiseVibration(**kw)
    t = np.arange(0, 36_000) / FS
    r0 = seq.body_rate(t)
    assert_array_equal(seq.body_rate(late), r_late)
    assert_array_equal(seq.gyro_angle(late), a_late)
    # after the early blocks left the cache, coming back gives the same values
    for s in (17.0, 33.0, 49.0):
        seq.body_rate(s + t)
    assert_array_equal(seq.body_rate(t), r0)
    assert_array_equal(first.body_rate(t), r0)
    # times far apart and unsorted in one call (one pass per block)
    mixed = np.array([1000.3, 0.25, -3.0, 500.0, 0.25 + 1 / FS, 1000.3 + 1 / FS])
    one = FilteredNoiseVibration(**kw).body_rate(mixed)
    assert_array_equal(one[[0, 5]], r_late)
    assert_array_equal(one[1], r0[18_000])
    assert_array_equal(one, np.stack([seq.body_rate(x) for x in mixed]))


def test_seed_reproduces_and_differs():
    kw = dict(psd_table=RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0)
    a, b, c = (FilteredNoiseVibration(seed=s, **kw) for s in (1, 1, 2))
    assert a == b and hash(a) == hash(b) and a != c
    t = np.arange(1, 72_001) / FS
    assert_array_equal(a.body_rate(t), b.body_rate(t))
    assert_array_equal(a.gyro_angle(t), b.gyro_angle(t))
    ra, rc = a.body_rate(t), c.body_rate(t)
    assert np.abs(np.corrcoef(ra[:, 0], rc[:, 0])[0, 1]) < 0.05  # 1 s: sigma ~ 0.02
    # a pickled copy (caches dropped) evaluates the same
    d = pickle.loads(pickle.dumps(a))
    assert d == a
    assert_array_equal(d.body_rate(t[:1000]), ra[:1000])
    # the translational noise of the same seed is independent of the angular one
    lin = LinearRandomVibration(((20.0, 1.0), (2000.0, 1.0)), seed=1)
    assert np.abs(np.corrcoef(lin.accel(t)[:, 0], ra[:, 0])[0, 1]) < 0.05


def test_single_axis_weights_and_static():
    vx = FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=400.0, axis_weights=(0.0, 1.0, 0.0), seed=3)
    t = np.arange(1, 3601) / FS
    r = vx.body_rate(t)
    assert_array_equal(r[:, [0, 2]], 0.0)
    assert vx.has_closed_form_attitude
    still = FilteredNoiseVibration(RV_TABLE, axis_weights=0.0)
    assert_array_equal(still.gyro_angle(t), 0.0)
    assert still.has_closed_form_attitude
    # the single-axis interface
    ang, rate = vx.axis("y").angle_rate(t)
    assert_array_equal(ang, vx.gyro_angle(t)[:, 1])
    assert_array_equal(rate, r[:, 1])


# --- attitude ------------------------------------------------------------------------


def test_attitude_stream_with_filtered_vibration():
    vib = FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, axis_weights=(0.3, 0.3, 0.3), seed=5)
    mot = Coning(ARCMIN, 386.0) + vib
    assert not mot.has_closed_form_attitude
    t = np.arange(1, 14_401) / FS
    q0 = np.roll(Rotation.from_rotvec([0.1, 0.2, -0.3]).as_quat(), 1)
    whole = mot.attitude_stream(0.0, q0, t)
    stream = AttitudeStream(mot, q0=q0)
    parts = [stream.advance(c) for c in uneven_chunks(t, SIZES)]
    assert_array_equal(np.concatenate(parts), whole)
    # fourth order on a 7.2 kHz grid against 32 substeps
    tg = np.arange(1, 1441) / 7200.0
    ref = mot.attitude(tg, substeps=32)
    errs = np.array([qangle(ref, mot.attitude(tg, substeps=m)).max() for m in (1, 2, 4)])
    order = np.log2(errs[:-1] / errs[1:])
    assert np.all(order > 3.5), (errs, order)
    # one live axis: the closed form and the numerical integration agree
    vy = FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0, f_hi_hz=2000.0, axis_weights=(0.0, 2.0, 0.0), seed=6)
    closed = vy.attitude(t)
    numeric = vy.attitude(t, method="numeric")
    assert qangle(closed, numeric).max() < 1e-13


# --- translation ---------------------------------------------------------------------


def test_linear_sines_closed_forms():
    s = LinearSines((2.0, 0.5, 9.0), (100.0, 386.0, 1600.0), (0.3, -1.0, 2.0))
    w = 2 * math.pi * np.array([100.0, 386.0, 1600.0])
    t = np.linspace(-0.01, 0.05, 7)
    assert_allclose(s.accel(t), np.array([2.0, 0.5, 9.0]) * np.sin(t[:, None] * w + [0.3, -1.0, 2.0]), rtol=1e-14)
    for a, b in ((0.0, 0.013), (0.0211, 0.0212), (-0.004, 0.0)):
        ref = [integrate.quad(lambda x, i=i: s.accel(x)[i], a, b, epsabs=1e-15, epsrel=1e-12, limit=200)[0]
               for i in range(3)]
        assert_allclose(s.velocity_increment(a, b), ref, rtol=0, atol=1e-14)
        assert_allclose(s.velocity(b) - s.velocity(a), ref, rtol=0, atol=1e-14)
    # no cancellation over 1 ns; zero-mean velocity over whole periods
    tb = 0.02 + 1e-9
    tiny = s.velocity_increment(0.02, tb)
    assert_allclose(tiny, s.accel(0.5 * (0.02 + tb)) * (tb - 0.02), rtol=1e-9)
    tt = np.arange(72_000) / FS
    assert np.abs(s.velocity(tt).mean(axis=0)).max() < 1e-15
    assert s.velocity_increment([[0.0], [0.1]], [0.1, 0.2]).shape == (2, 2, 3)


def test_linear_random_vibration():
    lin = LinearRandomVibration(ENGINE_G2, axis_weights=(1.0, 0.0, 0.7), seed=21)
    power = loglog_power(ENGINE_G2, 20.0, 2000.0)
    assert_allclose(lin.rms_accel_g, math.sqrt(power) * np.array([1.0, 0.0, 0.7]), rtol=1e-12)
    assert_allclose(lin.rms_accel_m_s2, lin.rms_accel_g * STANDARD_GRAVITY, rtol=1e-15)
    t = np.arange(int(FSAMP * T_REC)) / FSAMP
    acc = lin.accel(t) / STANDARD_GRAVITY
    assert_array_equal(acc[:, 1], 0.0)
    sigma = 0.5 * math.sqrt(loglog_power(ENGINE_G2, 20.0, 2000.0, power=2) / T_REC) / power
    assert_allclose(np.sqrt(np.mean(acc[:, 0] ** 2)), lin.rms_accel_g[0], rtol=5 * sigma)
    f, p = signal.welch(acc[:, 0], FSAMP, nperseg=int(FSAMP), detrend=False)
    edge = 4.0 * lin.node_rate_hz / (lin.n_taps - 1)
    band = (f >= 20.0 + edge) & (f <= 2000.0 - edge)
    ratio = np.mean(p[band] / lin.psd(f[band]))  # g^2/Hz against g^2/Hz
    assert abs(ratio - 1.0) < 5 / math.sqrt((2 * T_REC - 1) / 1.06 * band.sum() / 2)
    # exact velocity increments, at 0 s and after an hour
    for base in (0.0, 3600.0):
        for a, b in ((base + 0.1, base + 0.1021), (base - 0.3, base - 0.2999)):
            ref = exact_quadrature(lin.accel, a, b, lin.node_rate_hz)
            assert np.abs(lin.velocity_increment(a, b) - ref).max() < 1e-16
    # zero-mean, bounded velocity after an hour
    d = lin._noise().d
    rms_vel = math.sqrt(np.sum(d.value_psd) * (d.freqs[1] - d.freqs[0]))  # m/s, unit weight
    vel = lin.velocity(3600.0 + np.arange(7200) / 7200.0)[:, 0]
    assert np.abs(vel).max() < 6 * rms_vel
    assert abs(vel.mean()) < rms_vel


def test_linear_sample_grid_is_the_truth_at_exact_positions():
    """The mission truth's pass (acceleration at the Gauss-Legendre nodes and sample ends, velocity increments
    and end velocities at 7.2 kHz) against the public methods at the rounded times, chunked against whole."""
    lin = LinearRandomVibration(ENGINE_G2, axis_weights=(1.0, 0.3, 0.7), seed=21)
    h, inner = 1.0 / 7200.0, np.array([0.5 - 0.5 * math.sqrt(0.6), 0.5, 0.5 + 0.5 * math.sqrt(0.6)])
    k0, n = 7200 * 3600 - 17, 60_000  # an hour in, across a block end (7.96 s)
    acc, dv, vel = lin.sample_grid(k0, n, h, inner)
    ref_acc, ref_dv, ref_vel = Translation.sample_grid(lin, k0, n, h, inner)  # the default: rounded times
    # positions differ by the rounding of t (eps t): values by that times the derivative (bounded by 1.5 times
    # the largest finite difference between the grid's points, spaced at most 0.39 h) plus 8 eps of the values
    dt, eps8 = np.finfo(float).eps * (k0 + n) * h, 8 * np.finfo(float).eps
    jerk = np.abs(np.diff(acc.reshape(-1, 3), axis=0)).max() / (0.39 * h)
    assert_allclose(acc, ref_acc, rtol=0, atol=1.5 * jerk * dt + eps8 * np.abs(acc).max())
    assert_allclose(vel, ref_vel, rtol=0, atol=np.abs(acc).max() * dt + eps8 * np.abs(vel).max())
    assert_allclose(dv, ref_dv, rtol=0, atol=2 * np.abs(acc).max() * dt + eps8 * np.abs(vel).max())
    # the increments are differences of consecutive end velocities (node values): they telescope exactly
    start = lin.sample_grid(k0 - 1, 1, h, inner)[2][0]
    assert_array_equal(dv[1:], np.diff(vel, axis=0))
    assert_array_equal(dv[0], vel[0] - start)
    # a pure function of the sample index: uneven chunks reproduce the whole
    fresh = LinearRandomVibration(ENGINE_G2, axis_weights=(1.0, 0.3, 0.7), seed=21)
    parts = [fresh.sample_grid(k0 + i0, i1 - i0, h, inner) for i0, i1 in uneven_bounds(n, SIZES)]
    for q in range(3):
        assert_array_equal(np.concatenate([p[q] for p in parts]), (acc, dv, vel)[q])
    # a sum passes it to its parts
    s = LinearSines((1.0, 0.0, 2.0), 50.0, 0.0)
    both = s + lin
    for got, a, b in zip(both.sample_grid(k0, 100, h, inner), s.sample_grid(k0, 100, h, inner),
                         lin.sample_grid(k0, 100, h, inner)):
        assert_array_equal(got, (np.zeros_like(a) + a) + b)


def test_translation_sum():
    s = LinearSines((1.0, 0.0, 0.0), 50.0, 0.0)
    r = LinearRandomVibration(ENGINE_G2, seed=2)
    both = s + r
    assert isinstance(both, SumTranslation) and isinstance(both, Translation)
    assert sum([s, r]) == both and (both + s).parts == (s, r, s)
    t = np.arange(1, 1001) / FS
    assert_array_equal(both.accel(t), s.accel(t) + r.accel(t))
    assert_array_equal(both.velocity(t), s.velocity(t) + r.velocity(t))
    assert_allclose(both.velocity_increment(t[:-1], t[1:]),
                    s.velocity_increment(t[:-1], t[1:]) + r.velocity_increment(t[:-1], t[1:]), rtol=0, atol=1e-17)
    assert_array_equal(SumTranslation().accel(t), 0.0)


# --- validation ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: FilteredNoiseVibration(((1.0, 1.0),)), r"FilteredNoiseVibration\.psd_table"),
        (lambda: FilteredNoiseVibration("flat"), r"FilteredNoiseVibration\.psd_table"),
        (lambda: FilteredNoiseVibration(((20.0, 1.0), (10.0, 1.0))), r"FilteredNoiseVibration\.psd_table"),
        (lambda: FilteredNoiseVibration(((20.0, 1.0), (90.0, 0.0))), r"FilteredNoiseVibration\.psd_table"),
        (lambda: FilteredNoiseVibration(((20.0, 1.0), (90.0, np.nan))), r"FilteredNoiseVibration\.psd_table"),
        (lambda: FilteredNoiseVibration(RV_TABLE, f_lo_hz=5.0), r"FilteredNoiseVibration\.f_lo_hz"),
        (lambda: FilteredNoiseVibration(RV_TABLE, f_hi_hz=3000.0), r"FilteredNoiseVibration\.f_hi_hz"),
        (lambda: FilteredNoiseVibration(RV_TABLE, f_lo_hz=50.0, f_hi_hz=40.0), r"FilteredNoiseVibration\.f_hi_hz"),
        (lambda: FilteredNoiseVibration(RV_TABLE, axis_weights=(1, -1, 1)),
         r"FilteredNoiseVibration\.axis_weights\[1\]"),
        (lambda: FilteredNoiseVibration(RV_TABLE, axis_weights=(1, 1)), r"FilteredNoiseVibration\.axis_weights"),
        (lambda: FilteredNoiseVibration(RV_TABLE, seed=-1), r"FilteredNoiseVibration\.seed"),
        (lambda: FilteredNoiseVibration(RV_TABLE, seed=2**32), r"FilteredNoiseVibration\.seed"),
        (lambda: FilteredNoiseVibration(RV_TABLE, seed=True), r"FilteredNoiseVibration\.seed"),
        (lambda: FilteredNoiseVibration(RV_TABLE, node_rate_hz=5000.0), r"FilteredNoiseVibration\.node_rate_hz"),
        (lambda: FilteredNoiseVibration(RV_TABLE, node_rate_hz=-1.0), r"FilteredNoiseVibration\.node_rate_hz"),
        (lambda: FilteredNoiseVibration(((1.0, 1.0), (100.0, 1.0))), r"FilteredNoiseVibration\.f_lo_hz"),
        (lambda: LinearRandomVibration(((20.0, 1.0),)), r"LinearRandomVibration\.psd_table"),
        (lambda: LinearRandomVibration(ENGINE_G2, seed=1.5), r"LinearRandomVibration\.seed"),
        (lambda: LinearSines((-1.0, 0.0, 0.0), 1.0), r"LinearSines\.amplitude_m_s2\[0\]"),
        (lambda: LinearSines(1.0, (1.0, 0.0, 1.0)), r"LinearSines\.frequency_hz\[1\]"),
        (lambda: LinearSines(1.0, 1.0, (0.0, 0.0)), r"LinearSines\.phase_rad"),
        (lambda: SumTranslation((LinearSines(), 3)), r"SumTranslation\.parts\[1\]"),
        (lambda: LinearSines().accel([0.0, np.inf]), r"translation\.t"),
        (lambda: FilteredNoiseVibration(RV_TABLE).body_rate([0.0, np.nan]), r"motion\.t"),
        (lambda: FilteredNoiseVibration(RV_TABLE, f_lo_hz=20.0).body_rate(1e15), r"FilteredNoiseVibration\.t"),
    ],
)
def test_bad_parameters_name_the_field(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_defaults_and_documentation():
    v = FilteredNoiseVibration(RV_TABLE)
    assert (v.f_lo_hz, v.f_hi_hz, v.node_rate_hz) == (10.0, 2000.0, 14400.0)
    assert FilteredNoiseVibration(((20.0, 1.0), (5000.0, 1.0))).node_rate_hz == 36000.0
    assert LinearRandomVibration(ENGINE_G2, node_rate_hz=9600).node_rate_hz == 9600.0
    assert v.psd(5.0) == 0.0 and v.psd(100.0) == pytest.approx(1e-3)
    numpydoc = pytest.importorskip("numpydoc.docscrape")
    import inspect

    for cls in (FilteredNoiseVibration, LinearSines, LinearRandomVibration, SumTranslation):
        doc = numpydoc.ClassDoc(cls)
        documented = set()
        for par in doc["Parameters"]:
            documented.update(s.strip() for s in par.name.split(","))
        missing = [p for p in inspect.signature(cls).parameters if p not in documented]
        assert not missing, (cls.__name__, missing)


def test_sine_grid_three_axes_side_by_side_equal_one_axis_at_a_time():
    """``sines_grid`` advances the three axes' tones side by side when all three are live and one axis
    at a time otherwise; both must give the same bits (each element receives its tones in order), on
    any chunking, and match the closed form to rounding: at 1.7 kHz and t = 0.28 s the closed form's own
    argument w t ~ 3e3 rad carries ~3.5e-13 relative rounding, so the bounds are 1e-15 rad on angles of
    up to 2.9e-4 rad and 1e-11 rad/s on rates of up to 1.2 rad/s (both ~3e-12 relative)."""
    amp = np.array([1.0, 0.7, 0.4]) * ARCMIN
    freq = np.array([100.0, 130.0, 1700.0])
    ph = np.array([0.3, -1.1, 2.0])
    three = AxisSines(amplitude_rad=amp, frequency_hz=freq, phase_rad=ph)
    singles = [AxisSines(amplitude_rad=amp * (np.arange(3) == i), frequency_hz=freq, phase_rad=ph) for i in range(3)]
    h = 1.0 / FS
    a3, r3 = three.grid_angle_rate(99, 20_000, h)
    a1 = sum(s.grid_angle_rate(99, 20_000, h)[0] for s in singles)
    r1 = sum(s.grid_angle_rate(99, 20_000, h)[1] for s in singles)
    assert_array_equal(a3, a1)
    assert_array_equal(r3, r1)
    assert a3.flags.f_contiguous  # axis-major: the engine adds the Earth terms in place, one column per channel
    parts = [three.grid_angle_rate(99 + i0, i1 - i0, h) for i0, i1 in uneven_bounds(20_000, SIZES)]
    assert_array_equal(np.concatenate([p[0] for p in parts]), a3)
    t = np.arange(100, 20_100) * h
    assert_allclose(a3, three.gyro_angle(t), rtol=0, atol=1e-15)
    assert_allclose(r3, three.body_rate(t), rtol=0, atol=1e-11)
