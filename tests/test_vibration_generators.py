"""The two noise generators of the filtered-noise vibrations (``generator``, issue 26 item 2).

``decimated_noise`` (default) draws the white noise at ``node_rate_hz / D`` and
zero-stuffs it to the node rate inside the overlap-save convolution;
``node_rate_noise`` draws it at the node rate (the earlier sequences). The
references are independent of the overlap-save code: the noise redrawn from
the documented generator keys and convolved with the taps by
``scipy.signal.oaconvolve``, scipy's Welch PSD with chi-square confidence
intervals, and the table.

Tolerances
----------
* Convolution: the FFT (overlap-save, length 2^17) against scipy's
  overlap-add of different block sizes; both are accurate to a few ``eps``
  times the norm of the taps and noise: ``1e-12`` of the RMS of the node
  quantity allowed (measured 4e-15). ``decimated_noise`` convolves in single
  precision (issue 26): ``eps = 6e-8`` times the FFT's error growth
  (``log2`` of its length, 17): ``5e-6`` allowed (measured 7.9e-7 at most).
* Welch (Hann, 1 Hz bins, 50 % overlap, ``T = 40`` s): a bin's estimate is
  ``S chi^2_nu / nu`` with ``nu = 2 K / 1.056`` (``K = 2 T - 1`` segments,
  the overlap correlation of the Hann window, Welch 1967); a third-octave
  band of ``n`` bins has at least ``nu n / 2`` degrees of freedom (adjacent
  Hann bins correlate). Each band must lie in the two-sided chi-square
  interval of level ``1 - 1e-3 / (number of bands x 3 axes)`` (Bonferroni:
  the whole check fails by chance with probability below 1e-3).
* Images: between the band's top (widened by the window's edge rounding and
  four Welch bins) and the node Nyquist, the rate PSD must stay below 1e-9
  of its in-band level, the leakage floor of the Blackman-Harris Welch
  window (sidelobes -92 dB; measured 5e-10 decimated, 3e-10 node rate, next
  to the band). Where the images of the decimated noise fall
  (``fs / D - f`` for ``f`` in the band: 5.2-7.18 kHz here) below 1e-11
  for ``node_rate_noise`` (measured 4.4e-13: the FIR's stopband); for
  ``decimated_noise``, convolved in single precision, below 1e-10: the
  rounding floor of float32, white over the node band, lies there above the
  stuffing images (4.2e-13 in double precision) at 2.1e-11 (-107 dB,
  measured: the largest Welch bin), 5 dB below the quintic images the truth
  has above the node Nyquist (-102.5 dB). The
  quintic Hermite images above the node Nyquist: the design's
  ``image_level_db`` within 1 dB (measured -102.2 and -102.1 dB against
  -102.5 dB).
* Stationarity: zero-stuffed noise is cyclostationary; after the FIR (band
  below ``fs / (2 D)``) the variance of a node quantity is the same at each
  of the ``D`` node phases to the FIR's stopband: ``1e-12`` allowed
  (measured 2e-14, rounding).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import signal, stats

from chunking import uneven_chunks
from sins_sim.config import scenario as scenario_config
from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.models.motion import FilteredNoiseVibration, LinearRandomVibration
from sins_sim.models.motion.vibration import GENERATORS

DEG = math.pi / 180.0
#: nav-stationary-1h's angular vibration: 1e-6 (deg/s)^2/Hz from 20 Hz to 2 kHz, in (rad/s)^2/Hz
FLAT = ((20.0, 1e-6 * DEG**2), (2000.0, 1e-6 * DEG**2))
SHAPED = ((10.0, 1e-4), (100.0, 1e-3), (1000.0, 1e-3), (2000.0, 2e-4))  # (rad/s)^2/Hz
FS = 72_000.0
SIZES = (1, 3, 10, 7, 19, 997, 2, 4001, 250, 0, 30_011)


def test_schema_and_model_list_the_same_generators():
    assert scenario_config.GENERATORS == GENERATORS
    assert GENERATORS[0] == "decimated_noise"
    assert FilteredNoiseVibration(FLAT).generator == LinearRandomVibration(FLAT).generator == "decimated_noise"


@pytest.mark.parametrize("f_hi, expect", [(2000.0, 2), (400.0, 16), (4000.0, 2)])
def test_decimation_keeps_the_band_below_the_noise_nyquist(f_hi, expect):
    vib = FilteredNoiseVibration(((20.0, 1.0), (f_hi, 1.0)))
    d = vib.noise_decimation
    top = f_hi + 4.0 * vib.node_rate_hz / (vib.n_taps - 1)  # the band widened by the window's edge rounding
    assert d == expect
    assert 2 * d * top <= vib.node_rate_hz < 4 * d * top  # the largest power of two that keeps it
    assert FilteredNoiseVibration(((20.0, 1.0), (f_hi, 1.0)), generator="node_rate_noise").noise_decimation == 1


@pytest.mark.parametrize("generator", GENERATORS)
def test_nodes_are_the_linear_convolution_of_the_documented_noise(generator):
    """Block 1's nodes against scipy's convolution of noise blocks 0 and 1 redrawn from their keys."""
    seed, weights = 77, (1.0, 0.0, 2.5)
    vib = FilteredNoiseVibration(SHAPED, f_lo_hz=20.0, f_hi_hz=2000.0, axis_weights=weights, seed=seed,
                                 generator=generator)
    sh = vib._noise()
    d, dec = sh.d, vib.noise_decimation
    nb, taps = d.block, d.taps
    nodes = sh._node_block(1)
    for a in range(3):
        if weights[a] == 0.0:
            assert_array_equal(nodes[:, a], 0.0)
            continue
        # full-rate noise of global samples 0 .. 2 nb - 1: every D-th sample, scaled by sqrt(D)
        low = np.concatenate([np.random.default_rng([seed, a, b]).standard_normal(nb // dec) for b in (0, 1)])
        full = np.zeros(2 * nb)
        full[::dec] = low * math.sqrt(dec) * weights[a]
        for q in range(3):
            g = np.fft.irfft(d.spectra[q], d.fft_size)[:taps]  # the taps (the rest is zero padding)
            ref = signal.oaconvolve(full, g)[nb:2 * nb]  # nodes nb .. 2 nb - 1
            got = nodes[q, a, taps - 1:taps - 1 + nb]
            tol = 5e-6 if generator == "decimated_noise" else 1e-12  # single precision (module docstring)
            assert np.abs(got - ref).max() < tol * np.sqrt(np.mean(ref**2)), (a, q)


def test_decimated_noise_gives_a_stationary_process():
    """Variance of each node quantity at each of the D node phases (polyphase energies of the taps)."""
    for table, f_hi in ((FLAT, 2000.0), (((20.0, 1.0), (400.0, 1.0)), 400.0)):
        vib = FilteredNoiseVibration(table, f_lo_hz=20.0, f_hi_hz=f_hi)
        d, dec = vib._noise().d, vib.noise_decimation
        assert dec > 1
        for q in range(3):
            g = np.fft.irfft(d.spectra[q], d.fft_size)[:d.taps]
            energy = np.array([np.sum(g[p::dec] ** 2) for p in range(dec)]) * dec
            assert np.abs(energy / np.sum(g**2) - 1.0).max() < 1e-12, (f_hi, q, energy / np.sum(g**2) - 1.0)


def _chi2_band_check(p, f, expect, bands, nu_bin, alpha):
    """Each band's mean of ``p`` against ``expect`` inside its chi-square interval; returns the worst z-like ratio."""
    worst = 0.0
    for lo, hi in bands:
        sel = (f >= lo) & (f < hi)
        nu = nu_bin * max(sel.sum() / 2.0, 1.0)
        ratio = p[sel].mean() / expect(f[sel]).mean()
        low, high = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], nu) / nu
        assert low < ratio < high, (lo, hi, ratio, low, high)
        worst = max(worst, abs(ratio - 1.0) / (high - 1.0))
    return worst


@pytest.mark.parametrize("generator", GENERATORS)
def test_psd_against_the_table_with_chi_square_confidence(generator):
    fsamp, t_rec = 8192.0, 40.0
    vib = FilteredNoiseVibration(FLAT, f_lo_hz=20.0, f_hi_hz=2000.0, axis_weights=(1.0, 0.5, 2.0), seed=21,
                                 generator=generator)
    rate = vib.body_rate(np.arange(int(fsamp * t_rec)) / fsamp)
    f, p = signal.welch(rate, fsamp, nperseg=int(fsamp), axis=0, detrend=False)
    nu_bin = 2.0 * (2 * t_rec - 1) / 1.056
    edge = 4.0 * vib.node_rate_hz / (vib.n_taps - 1)
    centres = 1000.0 * 2.0 ** (np.arange(-16, 3) / 3.0)  # 25 Hz .. 1.6 kHz
    bands = [(fc * 2 ** (-1 / 6), fc * 2 ** (1 / 6)) for fc in centres]
    bands = [(max(lo, 20.0 + edge), min(hi, 2000.0 - edge)) for lo, hi in bands]
    alpha = 1e-3 / (3 * len(bands))
    for i, w in enumerate((1.0, 0.5, 2.0)):
        # the table itself: the design follows it within 0.02 dB inside the band less its edges
        _chi2_band_check(p[:, i], f, lambda x, w=w: w * w * vib.psd(x), bands, nu_bin, alpha)
    # images of the decimated noise (at fs / D - f) and anything else between the band and the node Nyquist
    fhs = 4 * vib.node_rate_hz
    fast = vib.body_rate(np.arange(int(4 * fhs)) / fhs)[:, 0]
    f, p = signal.welch(fast, fhs, window="blackmanharris", nperseg=2**15, detrend=False)
    level = p[(f > 100.0) & (f < 1900.0)].mean()
    gap = (f > 2000.0 + edge + 4 * f[1]) & (f < vib.node_rate_hz / 2)
    assert p[gap].max() < 1e-9 * level, p[gap].max() / level
    images = (f > vib.node_rate_hz / 2 - 2000.0) & (f < vib.node_rate_hz / 2 - 20.0)
    floor = 1e-10 if generator == "decimated_noise" else 1e-11  # float32's rounding floor (module docstring)
    assert p[images].max() < floor * level, p[images].max() / level
    # the interpolation images above the node Nyquist: the design's level (as for node_rate_noise)
    inband = f < vib.node_rate_hz / 2
    measured = 10 * np.log10(p[~inband].sum() / p[inband].sum())
    assert measured == pytest.approx(vib.image_level_db, abs=1.0)


@pytest.mark.parametrize("generator", GENERATORS)
def test_streaming_equals_one_call_and_random_access(generator):
    kw = dict(psd_table=SHAPED, f_lo_hz=20.0, f_hi_hz=2000.0, seed=4, generator=generator)
    vib = FilteredNoiseVibration(**kw)
    t = np.arange(1, 660_001) / FS  # 9.2 s: crosses the end of block 0 (7.96 s)
    assert t[-1] * vib.node_rate_hz > vib.block_nodes
    whole_rate, whole_angle = vib.body_rate(t), vib.gyro_angle(t)
    fresh = FilteredNoiseVibration(**kw)
    chunks = uneven_chunks(t, SIZES)
    assert_array_equal(np.concatenate([fresh.body_rate(c) for c in chunks]), whole_rate)
    assert_array_equal(np.concatenate([fresh.gyro_angle(c) for c in chunks]), whole_angle)
    # the engine's grid pass, chunked, equals the whole
    h = 1.0 / FS
    grid = FilteredNoiseVibration(**kw)
    tg = np.arange(1, 72_001) * h  # the grid's times t_j = (j + 1) h
    angle, rate = grid.grid_angle_rate(0, tg.size, h)
    parts = [grid.grid_angle_rate(i0, len(c), h) for i0, c in zip(np.cumsum([0, *map(len, uneven_chunks(tg, SIZES))]),
                                                                       uneven_chunks(tg, SIZES))]
    assert_array_equal(np.concatenate([p[1] for p in parts]), rate)
    assert_array_equal(np.concatenate([p[0] for p in parts]), angle)
    # against the general kernel at the rounded times: to the rounding of t (eps t) times the derivative
    # (1.5 times the largest finite difference) plus 8 eps of the values (tests/test_vibration.py explains)
    dt, eps8 = np.finfo(float).eps * tg[-1], 8 * np.finfo(float).eps
    accel = np.abs(np.diff(rate, axis=0)).max() / h
    assert_allclose(rate, fresh.body_rate(tg), rtol=0, atol=1.5 * accel * dt + eps8 * np.abs(rate).max())
    assert_allclose(angle, fresh.gyro_angle(tg), rtol=0, atol=np.abs(rate).max() * dt + eps8 * np.abs(angle).max())
    # a late time first (block 125), then from the start
    late = np.array([1000.3, 1000.3 + h])
    first = FilteredNoiseVibration(**kw)
    r_late = first.body_rate(late)
    assert_array_equal(first.body_rate(t[:7200]), whole_rate[:7200])
    seq = FilteredNoiseVibration(**kw)
    for s in (0.0, 8.0, 16.0, 500.0, 999.0):
        seq.body_rate(s + t[:72_000])
    assert_array_equal(seq.body_rate(late), r_late)
    # the translational vibration streams the same way
    lin_kw = dict(psd_table=((20.0, 0.002), (2000.0, 0.002)), seed=5021, generator=generator)
    lin = LinearRandomVibration(**lin_kw)
    acc, vel = lin.accel(t), lin.velocity(t)
    again = LinearRandomVibration(**lin_kw)
    assert_array_equal(np.concatenate([again.accel(c) for c in chunks]), acc)
    assert_array_equal(np.concatenate([again.velocity(c) for c in chunks]), vel)


def test_seeds_and_generators():
    t = np.arange(1, 72_001) / FS
    a, b, c = (FilteredNoiseVibration(FLAT, seed=s) for s in (1, 1, 2))
    old = FilteredNoiseVibration(FLAT, seed=1, generator="node_rate_noise")
    assert a == b and a != c and a != old and hash(a) == hash(b)
    ra = a.body_rate(t)
    assert_array_equal(b.body_rate(t), ra)
    # different seeds, or the same seed through the other generator: independent realisations
    # (correlation of 1 s of a 20-2000 Hz process: sigma about 1 / sqrt(2 x 1980) = 0.016; 5 sigma allowed)
    for other in (c, old):
        assert abs(np.corrcoef(ra[:, 0], other.body_rate(t)[:, 0])[0, 1]) < 0.08
    with pytest.raises(ValueError, match=r"FilteredNoiseVibration\.generator: must be one of decimated_noise, "
                                         r"node_rate_noise, got 'fft'"):
        FilteredNoiseVibration(FLAT, generator="fft")
    with pytest.raises(ValueError, match=r"LinearRandomVibration\.generator"):
        LinearRandomVibration(FLAT, generator="")


def test_scenario_key_selects_the_generator(tmp_path):
    imu = Path(__file__).resolve().parents[1] / "configs" / "default-imu.yaml"
    base = (f"name: g\nduration_s: 2.0\nimu: {imu}\nmotion:\n  - type: random_vibration\n"
            "    psd_deg2_s2_per_hz: [[20, 1.0e-6], [2000, 1.0e-6]]\n    f_lo_hz: 20\n    f_hi_hz: 2000\n")
    linear = ("linear_vibration:\n  - type: random\n    psd_g2_per_hz: [[20, 0.002], [2000, 0.002]]\n"
              "    f_lo_hz: 20\n    f_hi_hz: 2000\n")

    def load(text):
        path = tmp_path / "s.yaml"
        path.write_text(text)
        return load_scenario(path)

    sc = load(base + linear)
    assert sc.motion.generator == "decimated_noise" and sc.translation.generator == "decimated_noise"
    sc = load(base + "    generator: node_rate_noise\n" + linear + "    generator: node_rate_noise\n")
    assert sc.motion.generator == "node_rate_noise" and sc.translation.generator == "node_rate_noise"
    with pytest.raises(ConfigError, match=r"motion\[0\]\.generator.*must be one of"):
        load(base + "    generator: fft\n")
    with pytest.raises(ConfigError, match=r"motion\[0\]: generator: node_rate_noise applies to method: "
                                          r"filtered_noise only"):
        load(base + "    method: tones\n    generator: node_rate_noise\n")
