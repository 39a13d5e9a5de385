"""Allan deviation and the noise terms read off it (sins_sim.navigation.allan, sins_sim.plots.allan).

Synthetic records of known coefficients, generated here independently of the sensor model: white
rate noise (ARW / VRW), flicker rate noise (bias instability; Kasdin & Walter 1992 fractional
integration), rate random walk (cumulative white noise), quantised angle (quantisation noise).
Every tolerance is stated with the scatter it covers: the spread of the reading over seeds,
measured while writing the test, and the estimate's own standard deviation.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sins_sim.navigation.allan import (
    FLICKER_FLOOR_FACTOR,
    accel_allan,
    allan_axes,
    allan_deviation,
    fit_allan,
    gyro_allan,
)
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G


def _white(n_coef_si, fs, seconds, seed):
    """White rate samples of two-sided PSD N^2: each sample's mean rate has sigma N sqrt(fs)."""
    return np.random.default_rng(seed).standard_normal(int(seconds * fs)) * n_coef_si * math.sqrt(fs)


def _flicker(b_si, fs, n, seed):
    """Flicker rate noise with IEEE bias instability B (Allan deviation 0.664 B), Kasdin & Walter 1992:
    white noise of variance qd through (1 - z^-1)^(-1/2) has one-sided PSD 2 qd / (2 pi f) = h_-1 / f at low f,
    h_-1 = qd / pi, and Allan variance 2 ln 2 h_-1 = (2 ln 2 / pi) B^2 when qd = B^2 (independent of fs)."""
    h = np.ones(n)
    k = np.arange(1, n)
    h[1:] = np.cumprod((k - 0.5) / k)
    w = np.random.default_rng(seed).standard_normal(n) * b_si
    return np.fft.irfft(np.fft.rfft(w, 2 * n) * np.fft.rfft(h, 2 * n), 2 * n)[:n]


def _rrw(k_si, fs, seconds, seed):
    """Rate random walk dr = K dW sampled as the rate at each sample."""
    n = int(seconds * fs)
    return np.cumsum(np.random.default_rng(seed).standard_normal(n)) * k_si / math.sqrt(fs)


ARW = 0.1                              # deg/sqrt(h)
ARW_SI = ARW * DEG / 60.0              # rad/sqrt(s)


@pytest.mark.parametrize("fs", [100.0, 1000.0])
def test_white_rate_noise_gives_back_its_arw(fs):
    """ARW 0.1 deg/sqrt(h), 1000 s: within 5 %. Over 10 seeds the reading scattered by 1.0 % (100 Hz) and 0.35 %
    (1 kHz) 1-sigma, worst 1.8 % and 0.6 %; these seeds: -0.33 % and -0.62 %. The -1/2 region covers the record
    from the first tau."""
    a = gyro_allan(_white(ARW_SI, fs, 1000.0, seed=int(fs)), fs)
    r = a.readings()
    assert r["arw_deg_rt_h"] == pytest.approx(ARW, rel=0.05)
    assert math.isnan(r["bias_instability_deg_h"]) and math.isnan(r["rrw_deg_h_rt_h"])
    term = a.terms["white"]
    assert term.tau_range_s[0] == pytest.approx(1.0 / fs) and term.tau_range_s[1] >= 50.0
    assert term.slope_measured == pytest.approx(-0.5, abs=0.06)
    # the reading is the -1/2 line at tau = 1 s
    assert a.line("white", 1.0) == pytest.approx(ARW_SI, rel=0.05)


def test_record_kinds_agree():
    """Rate, increment and angle records of the same noise give the same curve (to rounding of the cumsum)."""
    fs = 200.0
    rate = _white(ARW_SI, fs, 100.0, seed=3)
    inc = rate / fs
    angle = np.concatenate([[0.0], np.cumsum(inc)])
    a = allan_deviation(rate, fs, "rate")
    b = allan_deviation(inc, fs, "increment")
    c = allan_deviation(angle, fs, "angle")
    assert_allclose(a.tau_s, b.tau_s)
    assert_allclose(a.tau_s, c.tau_s)
    assert_allclose(a.adev, b.adev, rtol=1e-9)
    assert_allclose(a.adev, c.adev, rtol=1e-7)
    assert a.n_samples == b.n_samples == c.n_samples == 20000


@pytest.mark.parametrize("fs", [10.0, 100.0])
def test_flicker_plateau_gives_back_its_bias_instability(fs):
    """Flicker rate noise of B = 1 deg/h, 2^18 samples: B = flat floor / 0.664 within 15 %. Over 10 seeds the reading
    scattered by 1.3 % 1-sigma, worst 2.4 %; this seed -1.4 % at both rates (the same numbers scaled in time: the
    generator's level does not depend on fs)."""
    y = _flicker(1.0 * DEG_PER_H, fs, 2 ** 18, seed=5)
    a = gyro_allan(y, fs)
    assert a.readings()["bias_instability_deg_h"] == pytest.approx(1.0, rel=0.15)
    lo, hi = a.terms["flicker"].tau_range_s
    assert hi / lo > 100.0                                 # the flat region spans decades
    assert a.terms["flicker"].slope_measured == pytest.approx(0.0, abs=0.1)
    assert a.line("flicker", 10.0) == pytest.approx(FLICKER_FLOOR_FACTOR * DEG_PER_H, rel=0.15)


@pytest.mark.parametrize("fs", [10.0, 100.0])
def test_rate_random_walk_slope_and_coefficient(fs):
    """RRW K = 1 deg/h/sqrt(h), 20000 s: slope +1/2 within 0.08 and K (the +1/2 line at tau = 3 s) within 8 %. Over 10
    seeds: slope 0.480 +- 0.016 (10 Hz) and 0.498 +- 0.007 (100 Hz); K scattered by 1.6 % and 0.9 %, worst 3.4 %.
    These seeds: K -0.7 % and -0.1 %, slope 0.494 and 0.491."""
    k_si = 1.0 * DEG_PER_H / 60.0
    a = gyro_allan(_rrw(k_si, fs, 20000.0, seed=int(fs) + 1), fs)
    term = a.terms["random_walk"]
    assert term.slope_measured == pytest.approx(0.5, abs=0.08)
    assert a.readings()["rrw_deg_h_rt_h"] == pytest.approx(1.0, rel=0.08)
    assert a.line("random_walk", 3.0) == pytest.approx(k_si, rel=0.08)


def test_arw_and_rrw_regions_are_separated():
    """White noise and a rate random walk whose lines cross at tau = sqrt(3) N / K = 30 s: the -1/2 region lies below
    the crossing and the +1/2 region above it; both read within tolerance. Over 8 seeds N scattered by 0.4 % (worst 1.2 %;
    tolerance 5 %) and K by 3.4 % (worst 8.2 %; tolerance 15 %: K's region, 36-2000 s, holds 10-550 clusters).
    This seed: N -0.7 %, K +1.4 %."""
    fs = 50.0
    k_si = 1.0 * DEG_PER_H / 60.0
    n_si = 30.0 * k_si / math.sqrt(3.0)
    x = _white(n_si, fs, 20000.0, seed=11) + _rrw(k_si, fs, 20000.0, seed=12)
    a = gyro_allan(x, fs)
    w, k = a.terms["white"], a.terms["random_walk"]
    assert w.tau_range_s[1] < 30.0 < k.tau_range_s[0]
    assert a.terms["white"].coefficient == pytest.approx(n_si, rel=0.05)
    assert a.terms["random_walk"].coefficient == pytest.approx(k_si, rel=0.15)


def test_quantised_angle_gives_back_its_quantisation_noise():
    """A dithered angle read through a quantiser of step q (the readout quantum), the dither then removed exactly:
    the quantisation error is white angle noise of variance q^2/12, and the Allan deviation of the rate is
    sqrt(3) Q / tau with Q = q / sqrt(12) (IEEE Std 952-1997, Annex C). 0.15125 arcsec at 7200 Hz, a 3 arcmin dither
    at 386 Hz, 60 s: Q within 10 % (measured -0.02 %; the
    white-angle model holds because the dither spreads the error uniformly over a step)."""
    fs, q = 7200.0, 0.15125 * ARCSEC
    t = np.arange(int(60 * fs) + 1) / fs
    dither = 3.0 * 60.0 * ARCSEC * np.sin(2.0 * np.pi * 386.0 * t)
    true = 15.0 * DEG_PER_H * t                        # an Earth-rate-like steady turn
    angle = np.floor((true + dither) / q) * q - dither
    a = gyro_allan(angle, fs, data="angle")
    assert a.readings()["quantization_arcsec"] == pytest.approx(0.15125 / math.sqrt(12.0), rel=0.10)
    assert a.terms["quantization"].tau_range_s[0] == pytest.approx(1.0 / fs)


def test_accelerometer_units():
    """White specific force of VRW 20 ug/sqrt(Hz) at 400 Hz, 1000 s, read in ug/sqrt(Hz) and m/s/sqrt(h)
    (1 ug/sqrt(Hz) = 9.80665e-6 m/s/sqrt(s) = 5.884e-4 m/s/sqrt(h)); within 5 % (as the gyro ARW; measured +0.04 %)."""
    fs = 400.0
    f = _white(20.0 * MICRO_G, fs, 1000.0, seed=21)
    r = accel_allan(f, fs).readings()
    assert r["vrw_ug_rt_hz"] == pytest.approx(20.0, rel=0.05)
    assert r["vrw_m_s_rt_h"] == pytest.approx(20.0 * 5.88399e-4, rel=0.05)
    v = np.concatenate([[0.0], np.cumsum(f / fs)])
    assert accel_allan(v, fs, data="velocity").readings()["vrw_ug_rt_hz"] == pytest.approx(r["vrw_ug_rt_hz"], rel=1e-6)


def test_only_well_averaged_points_are_fitted():
    """Points averaged over fewer than min_clusters clusters are left out of every region."""
    fs = 100.0
    a = gyro_allan(_white(ARW_SI, fs, 500.0, seed=4), fs, min_clusters=20)
    assert a.terms["white"].tau_range_s[1] <= 500.0 / 20
    assert a.curve.tau_s[-1] > 100.0                       # the curve itself goes further


def test_axes_to_dict_is_json_ready():
    fs = 100.0
    x = np.column_stack([_white(ARW_SI, fs, 300.0, seed=s) for s in (1, 2, 3)])
    res = allan_axes(x, fs)
    assert set(res) == {"x", "y", "z"}
    d = {ax: an.to_dict() for ax, an in res.items()}
    text = json.dumps(d, allow_nan=False)
    assert '"bias_instability_deg_h": null' in text
    assert d["x"]["arw_deg_rt_h"] == pytest.approx(ARW, rel=0.08)
    assert d["x"]["tau_range_s"]["arw_deg_rt_h"][0] == pytest.approx(0.01)
    acc = allan_axes(x * 1e3, fs, sensor="accel", data="increment")
    assert "vrw_ug_rt_hz" in acc["z"].to_dict()


@pytest.mark.parametrize("call, message", [
    (lambda: allan_deviation(np.zeros((10, 2)), 100.0), r"^allan\.x: must be a 1-D record, got shape \(10, 2\)$"),
    (lambda: allan_deviation([1.0, np.nan, 2.0, 3.0, 4.0], 100.0), r"^allan\.x: must be finite everywhere$"),
    (lambda: allan_deviation(np.ones(100), 0.0), r"^allan\.rate_hz: must be > 0, got 0\.0$"),
    (lambda: allan_deviation(np.ones(3), 10.0), r"^allan\.x: needs at least 4 samples, got 3$"),
    (lambda: allan_deviation(np.ones(100), 10.0, data="phase"), r"^allan\.data: must be one of"),
    (lambda: gyro_allan(np.ones(100), 10.0, data="velocity"), r"^allan\.data: must be one of \['rate', 'increment', 'angle'\] for a gyro"),
    (lambda: allan_axes(np.ones((100, 3)), 10.0, min_cluster=3), r"^allan: unknown keyword\(s\) \['min_cluster'\]"),
    (lambda: allan_axes(np.ones((100, 3)), 10.0, sensor="mag"), r"^allan\.sensor: must be one of \['accel', 'gyro'\]"),
    (lambda: fit_allan(allan_deviation(np.ones(100), 10.0), min_clusters=1), r"^allan\.min_clusters: must be >= 2"),
    (lambda: fit_allan(allan_deviation(np.ones(100), 10.0), share=0.0), r"^allan\.share: must lie in \(0, 1\]"),
])
def test_validation(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_plot_writes_a_figure(tmp_path):
    pytest.importorskip("matplotlib")
    from sins_sim.plots.allan import plot_allan

    fs = 50.0
    k_si = 1.0 * DEG_PER_H / 60.0
    x = np.column_stack([_white(math.sqrt(10.0) * k_si, fs, 4000.0, seed=s) + _rrw(k_si, fs, 4000.0, seed=s + 10)
                         for s in (1, 2, 3)])
    path = tmp_path / "allan.png"
    plot_allan(allan_axes(x, fs), path, title="synthetic ARW + RRW")
    assert path.stat().st_size > 10_000
