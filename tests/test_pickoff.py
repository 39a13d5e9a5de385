"""Tests of the pickoff sensor (sins_sim.models.pickoff) and the pickoff dither stripper (sins_sim.filters.pickoff)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from sins_sim.filters.pickoff import PickoffStripper, PickoffStripperDesign, strip
from sins_sim.models.pickoff import PickoffParams, PickoffSensor
from sins_sim.units import ARCMIN, ARCSEC

FS = 72000.0
FD = 384.0  # dither (Hz)
A = 3.0 * ARCMIN  # dither amplitude


def _signals(duration=2.0, motion_hz=100.0, motion_amp=1.0 * ARCMIN):
    """A dither deflection and a block sine; x = block + deflection as the RLG reads it."""
    t = np.arange(int(duration * FS)) / FS
    delta = A * np.sin(2 * math.pi * FD * t) + 0.3 * motion_amp * np.sin(2 * math.pi * motion_hz * t + 0.4)
    phi = motion_amp * np.sin(2 * math.pi * motion_hz * t)
    return t, delta, phi, phi + delta


def _chunks(x, sizes=(1, 7, 0, 3333, 2, 10000, 499, 13)):
    out, i, k = [], 0, 0
    while i < x.size:
        out.append(x[i:i + sizes[k % len(sizes)]])
        i += sizes[k % len(sizes)]
        k += 1
    return out


# --- sensor -------------------------------------------------------------------


def test_ideal_pickoff_integrates_back_to_the_deflection():
    # no lag, no scale error, no noise: sample n is the backward difference over the step, so h * cumsum is exact
    _, delta, _, _ = _signals(0.1)
    s = PickoffSensor(PickoffParams(scale_v_per_rad_s=2.5, gain_error=0.0, lag_s=0.0, noise_v=0.0), delta0=delta[0])
    volts = s.process(delta)
    assert_allclose(np.cumsum(volts) / FS / 2.5, delta - delta[0], atol=1e-12 * A)


@pytest.mark.parametrize("lag_s", [2e-6, 5e-5])
def test_lag_and_scale_error_of_the_integrated_signal(lag_s):
    # the integrated voltage is the deflection through (1 + gain_error) / (1 + j w lag), exactly for a deflection
    # linear between samples; for a 384 Hz sine at 72 kHz the first-order-hold error is ~(w h)^2/12 ~ 1e-4
    t, delta, _, _ = _signals(0.5, motion_amp=0.0)
    p = PickoffParams(gain_error=0.03, lag_s=lag_s, noise_v=0.0)
    u = np.cumsum(PickoffSensor(p).process(delta)) / FS
    w = 2 * math.pi * FD
    h = (1.0 + p.gain_error) / (1.0 + 1j * w * lag_s)
    expected = A * abs(h) * np.sin(w * t + np.angle(h))
    m = t > 0.1  # the lag's start-up transient is gone
    assert np.max(np.abs(u[m] - expected[m])) < 1e-4 * A


def test_frequency_response_matches_the_time_domain():
    p = PickoffParams(noise_v=0.0, lag_s=1e-5)
    t = np.arange(36000) / FS
    x = 1e-4 * np.sin(2 * math.pi * 500.0 * t)
    y = PickoffSensor(p).process(x)
    h = p.frequency_response(500.0)
    expected = 1e-4 * abs(h) * np.sin(2 * math.pi * 500.0 * t + np.angle(h))
    assert np.max(np.abs(y[3600:] - expected[3600:])) < 1e-9 * abs(h) * 1e4


def test_sensor_chunked_equals_whole_with_noise():
    _, delta, _, _ = _signals(0.3)
    p = PickoffParams()
    whole = PickoffSensor(p, np.random.default_rng(5)).process(delta)
    s = PickoffSensor(p, np.random.default_rng(5))
    chunked = np.concatenate([s.process(c) for c in _chunks(delta)])
    assert_array_equal(chunked, whole)


def test_sensor_noise_has_stated_std():
    p = PickoffParams(noise_v=1e-3)
    v = PickoffSensor(p, np.random.default_rng(1)).process(np.zeros(100_000))
    assert np.std(v) == pytest.approx(1e-3, rel=0.02)  # 1e5 samples: 0.2 % standard error


@pytest.mark.parametrize(
    "kwargs, field",
    [({"scale_v_per_rad_s": 0.0}, "scale_v_per_rad_s"), ({"gain_error": -1.0}, "gain_error"),
     ({"lag_s": -1e-6}, "lag_s"), ({"noise_v": -1.0}, "noise_v"), ({"rate_hz": 0.0}, "rate_hz"),
     ({"lag_s": float("nan")}, "lag_s")],
)
def test_bad_pickoff_params_raise(kwargs, field):
    with pytest.raises(ValueError, match=f"pickoff.{field}"):
        PickoffParams(**kwargs)


def test_sensor_needs_rng_with_noise():
    with pytest.raises(ValueError, match="pickoff.rng"):
        PickoffSensor(PickoffParams(noise_v=1e-3))


# --- stripper -------------------------------------------------------------------


def test_ideal_pickoff_strips_the_dither_exactly():
    # without block motion BP(x) = BP(u) exactly, so the LMS sees no error and the gain stays put
    _, delta, phi, x = _signals(1.0, motion_amp=0.0)
    p = PickoffParams(gain_error=0.0, lag_s=0.0, noise_v=0.0)
    volts = PickoffSensor(p, delta0=0.0).process(delta)
    design = PickoffStripperDesign(fs_hz=FS, dither_hz=FD, leak_hz=0.0)
    y, gains = PickoffStripper(design).process(x, volts, return_gain=True)
    # the gain starts right and the LMS finds nothing to correct: residual at round-off
    assert np.max(np.abs(y - phi)) < 1e-12 * A
    assert np.max(np.abs(gains - 1.0)) < 1e-12


def test_block_motion_far_from_the_dither_barely_pulls_the_gain():
    # a 1 arcmin, 100 Hz block sine is 284 Hz outside the 2 Hz adaptation band: it moves the gain by < 1e-5
    _, delta, phi, x = _signals(2.0)
    volts = PickoffSensor(PickoffParams(gain_error=0.0, lag_s=0.0, noise_v=0.0)).process(delta)
    design = PickoffStripperDesign(fs_hz=FS, dither_hz=FD, leak_hz=0.0)  # the leak has its own test
    y, gains = PickoffStripper(design).process(x, volts, return_gain=True)
    assert np.max(np.abs(gains - 1.0)) < 1e-5
    assert np.max(np.abs(y - phi)) < 1e-5 * A


def test_lms_removes_a_scale_error_and_keeps_the_block_motion():
    t, delta, phi, x = _signals(4.0)
    p = PickoffParams(gain_error=0.05, lag_s=0.0, noise_v=0.0)
    volts = PickoffSensor(p).process(delta)
    design = PickoffStripperDesign(fs_hz=FS, dither_hz=FD, adapt_time_s=0.2)
    y, gains = PickoffStripper(design).process(x, volts, return_gain=True)
    # converges to 1 / 1.05 within 0.05 % after ~17 adaptation times (the 100 Hz block motion is 284 Hz away
    # from a 2 Hz band-pass: its pull on the gain is ~(1 Hz / 284 Hz)^2 of its amplitude ratio)
    assert gains[-1] == pytest.approx(1.0 / 1.05, rel=5e-4)
    err0 = np.std((y - phi)[(t > 0.05) & (t < 0.4)])  # before adaptation (hold): 5 % of the deflection
    err1 = np.std((y - phi)[t > 3.5])
    assert err0 == pytest.approx(0.05 * np.std(delta), rel=0.02)
    assert err1 < err0 / 100.0


def test_gain_stays_during_the_hold_time():
    _, delta, _, x = _signals(0.6)
    volts = PickoffSensor(PickoffParams(gain_error=0.05, noise_v=0.0)).process(delta)
    design = PickoffStripperDesign(fs_hz=FS, dither_hz=FD, hold_s=0.3)
    _, gains = PickoffStripper(design).process(x, volts, return_gain=True)
    n_hold = int(0.3 * FS)
    assert np.all(gains[:n_hold] == 1.0)
    assert gains[-1] < 0.999


def test_phase_error_leaves_the_quadrature_residual():
    # a gain cannot remove the part of the dither in quadrature with the pickoff: a * w * lag (RMS / sqrt 2)
    t, delta, phi, x = _signals(3.0, motion_amp=0.0)
    lag = 5e-6
    volts = PickoffSensor(PickoffParams(gain_error=0.0, lag_s=lag, noise_v=0.0)).process(delta)
    y = strip(x, volts, PickoffStripperDesign(fs_hz=FS, dither_hz=FD, leak_hz=0.0))
    expected = A * 2 * math.pi * FD * lag / math.sqrt(2)
    assert np.std(y[t > 2.0]) == pytest.approx(expected, rel=0.02)


def test_stripper_chunked_equals_whole():
    _, delta, _, x = _signals(1.0)
    volts = PickoffSensor(PickoffParams(), np.random.default_rng(2)).process(delta)
    design = PickoffStripperDesign(fs_hz=FS, dither_hz=FD)
    whole = strip(x, volts, design)
    st = PickoffStripper(design)
    chunked = np.concatenate([st.process(a, b) for a, b in zip(_chunks(x), _chunks(volts))])
    assert_array_equal(chunked, whole)


def test_reset_restores_the_start():
    _, delta, _, x = _signals(0.8)
    volts = PickoffSensor(PickoffParams(noise_v=0.0)).process(delta)
    st = PickoffStripper(PickoffStripperDesign(fs_hz=FS, dither_hz=FD))
    first = st.process(x, volts)
    st.reset()
    assert st.gain == 1.0
    assert_array_equal(st.process(x, volts), first)


def test_frozen_gain():
    _, delta, _, x = _signals(0.8)
    volts = PickoffSensor(PickoffParams(gain_error=0.05, noise_v=0.0)).process(delta)
    st = PickoffStripper(PickoffStripperDesign(fs_hz=FS, dither_hz=FD, adapt_time_s=math.inf))
    st.process(x, volts)
    assert st.gain == 1.0


@pytest.mark.parametrize(
    "kwargs, field",
    [({"dither_hz": 40000.0}, "dither_hz"), ({"scale_v_per_rad_s": 0.0}, "scale_v_per_rad_s"),
     ({"adapt_time_s": 0.0}, "adapt_time_s"), ({"adapt_time_s": True}, "adapt_time_s"),
     ({"band_hz": 500.0}, "band_hz"), ({"power_time_s": 0.0}, "power_time_s"), ({"leak_hz": -1.0}, "leak_hz"),
     ({"hold_s": -1.0}, "hold_s"), ({"fs_hz": float("inf")}, "fs_hz")],
)
def test_bad_stripper_design_raises(kwargs, field):
    with pytest.raises(ValueError, match=f"pickoff_stripper.{field}"):
        PickoffStripperDesign(**kwargs)


def test_stripper_rejects_mismatched_inputs():
    st = PickoffStripper(PickoffStripperDesign())
    with pytest.raises(ValueError, match="pickoff_stripper.volts"):
        st.process(np.zeros(5), np.zeros(4))
    with pytest.raises(ValueError, match="pickoff_stripper.x"):
        st.process(np.array([0.0, np.nan]), np.zeros(2))


def test_noise_is_integrated_but_leak_bounds_it():
    # white pickoff noise integrates to a random walk; the 0.1 Hz leak bounds its RMS to
    # sigma h sqrt(1 / (1 - lambda^2)) ~ sigma h sqrt(fs / (4 pi f_leak)) (in V s, times the gain)
    n = int(20 * FS)
    sigma = 5e-4
    volts = sigma * np.random.default_rng(3).standard_normal(n)
    design = PickoffStripperDesign(fs_hz=FS, dither_hz=FD, adapt_time_s=math.inf)
    y = strip(np.zeros(n), volts, design)
    bound = sigma / FS * math.sqrt(FS / (4 * math.pi * design.leak_hz))
    assert np.std(y[n // 2:]) < 2.0 * bound
    assert np.std(y[n // 2:]) > 0.3 * bound
    assert bound < 1.0 * ARCSEC  # the default noise is harmless at this scale
