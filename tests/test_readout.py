"""Tests of the readout chain (reference-model.md, "Readout"): quantisation,
anti-alias FIR and decimation, streaming."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import signal

from sins_sim.models.readout import (
    AntiAliasParams,
    Decimator,
    Readout,
    ReadoutParams,
    quantise,
)
from sins_sim.units import ARCMIN, FRINGE_RAD, INTERPOLATED_QUANTUM_RAD
from chunking import uneven_chunks

FS_IN = 72_000.0


def _uneven_chunks(x, sizes=(1, 3, 0, 10, 7, 19, 20, 21, 997, 2, 4001)):
    """Chunks not multiples of 10, some shorter than the FIR history."""
    return uneven_chunks(x, sizes)


def _dither_angle(n, seed=0):
    """A 3 arcmin, 386 Hz dither on a slow rotation, sampled at 72 kHz (rad)."""
    t = np.arange(n) / FS_IN
    rng = np.random.default_rng(seed)
    return (
        3.0 * ARCMIN * np.sin(2.0 * math.pi * 386.0 * t)
        + 1e-3 * t
        + 1e-7 * rng.standard_normal(n)
    )


# --- parameters -----------------------------------------------------------


def test_defaults():
    p = ReadoutParams()
    assert p.quantum_rad == INTERPOLATED_QUANTUM_RAD
    assert p.decimation == 10
    assert p.anti_alias == AntiAliasParams(9000.0, 21, "hamming")
    # 21 taps at 72 kHz: 10 input samples = one 7.2 kHz output sample.
    assert p.delay_s == 1.0 / 7200.0
    assert ReadoutParams(anti_alias=None).delay_s == 0.0
    assert ReadoutParams(quantum_rad=FRINGE_RAD).quantum_rad == FRINGE_RAD


def test_taps_unity_dc_gain_and_symmetric():
    taps = ReadoutParams().taps()
    assert taps.shape == (21,)
    assert_allclose(np.sum(taps), 1.0, rtol=0, atol=1e-12)
    assert_allclose(taps, taps[::-1], rtol=0, atol=1e-15)
    assert_array_equal(ReadoutParams(anti_alias=None).taps(), [1.0])


def test_decimator_attributes():
    d = Decimator.from_readout(ReadoutParams())
    assert d.decimation == 10
    assert d.delay_s == 1.0 / 7200.0
    assert d.output_rate_hz == 7200.0
    assert_array_equal(d.taps, ReadoutParams().taps())
    assert not d.taps.flags.writeable


# --- decimator ------------------------------------------------------------


def test_decimator_matches_lfilter_then_decimate():
    p = ReadoutParams()
    x = _dither_angle(50_003)
    d = Decimator.from_readout(p)
    y = d.process(x)
    ref = signal.lfilter(d.taps, 1.0, x)[:: p.decimation]
    assert y.shape == ref.shape
    assert_allclose(y, ref, rtol=1e-13, atol=1e-13 * np.max(np.abs(ref)))


@pytest.mark.parametrize("r", [1, 3, 7])
def test_decimator_other_factors_and_taps(r):
    taps = signal.firwin(9, 0.2)
    x = np.random.default_rng(r).standard_normal(1001)
    y = Decimator(taps, r, 1000.0).process(x)
    assert_allclose(y, signal.lfilter(taps, 1.0, x)[::r], rtol=1e-13, atol=1e-13)


def test_anti_alias_off_is_plain_decimation():
    p = ReadoutParams(anti_alias=None)
    x = _dither_angle(12_345)
    assert_array_equal(Decimator.from_readout(p).process(x), x[::10])
    d = Decimator.from_readout(p)
    assert_array_equal(np.concatenate([d.process(c) for c in _uneven_chunks(x)]), x[::10])


def test_decimator_chunked_equals_whole_bit_for_bit():
    p = ReadoutParams()
    x = _dither_angle(60_000)
    whole = Decimator.from_readout(p).process(x)
    d = Decimator.from_readout(p)
    chunked = np.concatenate([d.process(c) for c in _uneven_chunks(x)])
    assert_array_equal(chunked, whole)


def test_decimator_reset():
    d = Decimator.from_readout(ReadoutParams())
    x = _dither_angle(1_007)
    first = d.process(x)
    d.reset()
    assert_array_equal(d.process(x), first)


def test_decimator_delay_aligns_a_slow_sine():
    """A slow sine comes out delayed by delay_s (linear-phase FIR: exact)."""
    p = ReadoutParams()
    d = Decimator.from_readout(p)
    n = 72_000
    f = 50.0
    t = np.arange(n) / FS_IN
    y = d.process(np.sin(2.0 * math.pi * f * t))
    t_out = np.arange(y.size) / p.output_rate_hz
    gain = abs(np.sum(d.taps * np.exp(-2j * math.pi * f * np.arange(21) / FS_IN)))
    expected = gain * np.sin(2.0 * math.pi * f * (t_out - d.delay_s))
    assert_allclose(y[5:], expected[5:], atol=1e-12)


# --- quantisation ---------------------------------------------------------


def test_quantise_floor_semantics():
    q = 0.5
    phi = np.array([-1.0, -0.75, -0.5, -0.25, -1e-12, 0.0, 0.25, 0.5, 0.74, 1.0])
    expected = np.array([-2, -2, -1, -1, -1, 0, 0, 1, 1, 2])
    counts = quantise(phi, q)
    assert counts.dtype == np.int64
    assert_array_equal(counts, expected)


def test_quantise_error_within_one_quantum():
    q = INTERPOLATED_QUANTUM_RAD
    phi = _dither_angle(10_000)
    err = phi - quantise(phi, q) * q
    assert np.all(err >= 0.0) and np.all(err < q * (1 + 1e-9))


def test_quantise_noise_reproducible():
    q = 1.0
    phi = np.linspace(-5.0, 5.0, 2001)
    a = quantise(phi, q, 0.7, np.random.default_rng(11))
    b = quantise(phi, q, 0.7, np.random.default_rng(11))
    c = quantise(phi, q, 0.7, np.random.default_rng(12))
    assert_array_equal(a, b)
    assert np.any(a != c)
    assert np.any(a != quantise(phi, q))


def test_quantise_noise_has_stated_std():
    """With a quantum much smaller than the noise, counts*q - phi has std noise_rad."""
    q = 1e-3
    phi = np.zeros(200_000)
    counts = quantise(phi, q, 0.1, np.random.default_rng(1))
    assert_allclose(np.std(counts * q), 0.1, rtol=1e-2)


# --- readout chain --------------------------------------------------------


def test_readout_chain_equals_its_parts():
    p = ReadoutParams()
    phi = _dither_angle(20_000)
    counts, angle = Readout(p).process(phi)
    assert counts.dtype == np.int64
    assert_array_equal(counts, quantise(phi, p.quantum_rad))
    assert_array_equal(angle, Decimator.from_readout(p).process(counts * p.quantum_rad))
    assert angle.size == 2_000


def test_readout_chunked_with_noise_equals_whole_bit_for_bit():
    p = ReadoutParams(noise_rad=0.3 * INTERPOLATED_QUANTUM_RAD)
    phi = _dither_angle(40_000)
    c_whole, a_whole = Readout(p, np.random.default_rng(2024)).process(phi)
    r = Readout(p, np.random.default_rng(2024))
    parts = [r.process(c) for c in _uneven_chunks(phi)]
    assert_array_equal(np.concatenate([c for c, _ in parts]), c_whole)
    assert_array_equal(np.concatenate([a for _, a in parts]), a_whole)
    c_other, _ = Readout(p, np.random.default_rng(2025)).process(phi)
    assert np.any(c_other != c_whole)


# --- validation -----------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"quantum_rad": 0.0}, r"readout\.quantum_rad"),
        ({"quantum_rad": -1e-6}, r"readout\.quantum_rad"),
        ({"quantum_rad": float("nan")}, r"readout\.quantum_rad"),
        ({"noise_rad": -1e-9}, r"readout\.noise_rad"),
        ({"noise_rad": float("inf")}, r"readout\.noise_rad"),
        ({"input_rate_hz": float("nan")}, r"readout\.input_rate_hz"),
        ({"output_rate_hz": 7000.0}, r"readout\.output_rate_hz"),
        ({"output_rate_hz": 144_000.0}, r"readout\.output_rate_hz"),
        ({"output_rate_hz": 0.0}, r"readout\.output_rate_hz"),
        ({"anti_alias": AntiAliasParams(cutoff_hz=36_000.0)}, r"readout\.anti_alias\.cutoff_hz"),
        ({"anti_alias": AntiAliasParams(cutoff_hz=50_000.0)}, r"readout\.anti_alias\.cutoff_hz"),
        ({"anti_alias": "hamming"}, r"readout\.anti_alias"),
    ],
)
def test_bad_readout_params_raise(kwargs, field):
    with pytest.raises(ValueError, match=field):
        ReadoutParams(**kwargs)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"numtaps": 20}, r"anti_alias\.numtaps"),
        ({"numtaps": 0}, r"anti_alias\.numtaps"),
        ({"numtaps": 21.0}, r"anti_alias\.numtaps"),
        ({"cutoff_hz": 0.0}, r"anti_alias\.cutoff_hz"),
        ({"cutoff_hz": float("nan")}, r"anti_alias\.cutoff_hz"),
        ({"window": "no-such-window"}, r"anti_alias\.window"),
    ],
)
def test_bad_anti_alias_raises(kwargs, field):
    with pytest.raises(ValueError, match=field):
        AntiAliasParams(**kwargs)


def test_bad_quantise_inputs_raise():
    with pytest.raises(ValueError, match=r"quantum_rad"):
        quantise([0.0], 0.0)
    with pytest.raises(ValueError, match=r"noise_rad"):
        quantise([0.0], 1.0, -1.0)
    with pytest.raises(ValueError, match=r"rng"):
        quantise([0.0], 1.0, 0.1)
    with pytest.raises(ValueError, match=r"phi_rad"):
        quantise([np.nan], 1.0)


def test_readout_needs_rng_with_noise():
    with pytest.raises(ValueError, match=r"readout\.rng"):
        Readout(ReadoutParams(noise_rad=1e-7))


def test_bad_decimator_inputs_raise():
    with pytest.raises(ValueError, match=r"decimator\.taps"):
        Decimator([1.0, 2.0], 2, 1000.0)
    with pytest.raises(ValueError, match=r"decimator\.taps"):
        Decimator([], 2, 1000.0)
    with pytest.raises(ValueError, match=r"decimator\.decimation"):
        Decimator([1.0], 0, 1000.0)
    with pytest.raises(ValueError, match=r"decimator\.input_rate_hz"):
        Decimator([1.0], 1, -1.0)
    d = Decimator.from_readout(ReadoutParams())
    with pytest.raises(ValueError, match=r"decimator\.x"):
        d.process([0.0, np.inf])
    with pytest.raises(ValueError, match=r"readout\.phi_rlg"):
        Readout(ReadoutParams()).process([np.nan])
