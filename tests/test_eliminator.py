"""Tests of the elliptic eliminator (reference-model.md, "The elliptic eliminator")
and of the second-order-section kernel it runs on."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import signal

from sins_sim._kernels.sos import sos_filter
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign, eliminate
from chunking import uneven_chunks

FS = 7200.0


def _test_signal(n=40_000, seed=0):
    """White noise plus a 386 Hz, 3 arcmin-sized dither sine and a slow ramp."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    return (
        rng.standard_normal(n)
        + 50.0 * np.sin(2.0 * math.pi * 386.0 * t + 0.3)
        + 0.1 * t
    )


def _uneven_chunks(x, sizes=(1, 7, 0, 333, 2, 1000, 4999, 13)):
    return uneven_chunks(x, sizes)


# --- kernel ---------------------------------------------------------------


def test_sos_kernel_matches_scipy_sosfilt():
    # A writable copy: scipy's Cython sosfilt refuses read-only buffers.
    sos = np.array(EliminatorDesign.paper().sos)
    x = _test_signal()
    zi = np.zeros((sos.shape[0], 2))
    y = np.empty_like(x)
    sos_filter(sos, x, zi, y)
    y_ref, zf_ref = signal.sosfilt(sos, x, zi=np.zeros((sos.shape[0], 2)))
    assert_allclose(y, y_ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(y_ref)))
    assert_allclose(zi, zf_ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(zf_ref)))


def test_sos_kernel_matches_scipy_from_nonzero_state():
    sos = np.array(EliminatorDesign.centred(300.0).sos)
    x = _test_signal(5000, seed=3)
    zi0 = np.random.default_rng(4).standard_normal((sos.shape[0], 2))
    zi = zi0.copy()
    y = np.empty_like(x)
    sos_filter(sos, x, zi, y)
    y_ref, zf_ref = signal.sosfilt(sos, x, zi=zi0)
    assert_allclose(y, y_ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(y_ref)))
    assert_allclose(zi, zf_ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(zf_ref)))


# --- streaming ------------------------------------------------------------


def test_eliminator_chunked_equals_whole_bit_for_bit():
    design = EliminatorDesign.paper()
    x = _test_signal()
    whole = eliminate(x, design)
    e = Eliminator(design)
    chunked = np.concatenate([e.process(c) for c in _uneven_chunks(x)])
    assert_array_equal(chunked, whole)
    # The state after the stream is the same as after one call.
    e_whole = Eliminator(design)
    e_whole.process(x)
    assert_array_equal(e.state, e_whole.state)


def test_eliminator_starts_at_rest_and_resets():
    design = EliminatorDesign.paper()
    e = Eliminator(design)
    assert_array_equal(e.state, np.zeros((design.order, 2)))
    x = _test_signal(2000)
    first = e.process(x)
    assert np.any(e.state != 0.0)
    e.reset()
    assert_array_equal(e.state, 0.0)
    assert_array_equal(e.process(x), first)


def test_state_is_a_copy():
    e = Eliminator(EliminatorDesign.paper())
    s = e.state
    s[:] = 1.0
    assert_array_equal(e.state, 0.0)


# --- design ---------------------------------------------------------------


def test_paper_design_has_ten_stable_poles():
    d = EliminatorDesign.paper()
    assert d.n_poles == 10
    assert d.sos.shape == (5, 6)
    poles = d.poles()
    assert poles.size == 10
    assert np.all(np.abs(poles) < 1.0)


def test_sos_is_read_only_and_cached():
    d = EliminatorDesign.paper()
    assert d.sos is d.sos
    assert not d.sos.flags.writeable
    with pytest.raises(ValueError):
        d.sos[0, 0] = 0.0


def test_equal_designs_share_one_design_with_scipys_bits():
    # the per-process design cache: a second design of the same parameters (a second channel, a sweep's next run)
    # reuses the sections, which are exactly scipy's design of those parameters (independent call, same bits)
    a = EliminatorDesign.centred(386.0)
    b = EliminatorDesign.centred(386.0)
    assert a is not b and a.sos is b.sos
    ref = signal.ellip(5, 0.1, 60.0, [366.0, 406.0], btype="bandstop", fs=7200.0, output="sos")
    assert_array_equal(a.sos, ref)
    assert EliminatorDesign.centred(352.0).sos is not a.sos  # other parameters: their own design


def test_band_constructors():
    assert EliminatorDesign.centred(352.0).band_hz == (332.0, 372.0)
    p = EliminatorDesign.paper()
    assert p.band_hz == (370.0, 410.0)
    assert p.fs_hz == 7200.0
    assert (p.order, p.rp_db, p.rs_db) == (5, 0.1, 60.0)
    assert EliminatorDesign.centred(390.0) == p


def test_gain_in_stop_band_and_pass_band():
    d = EliminatorDesign.paper()
    # Tolerance: an elliptic stop band is equiripple and touches -rs_db exactly
    # at its ripple peaks, and scipy solves the design's degree equation
    # numerically; 1e-3 dB covers that rounding and nothing physical.
    tol_db = 1e-3
    centre = 0.5 * sum(d.band_hz)
    gain_centre_db = 20.0 * np.log10(np.abs(d.frequency_response(centre)))
    assert gain_centre_db <= -d.rs_db + tol_db
    # The whole neighbourhood of the dither is at least rs_db down.
    f_stop = np.linspace(centre - 5.0, centre + 5.0, 401)
    gain_stop_db = 20.0 * np.log10(np.abs(d.frequency_response(f_stop)))
    assert np.max(gain_stop_db) <= -d.rs_db + tol_db
    # Pass band: within rp_db of 0 dB (the ripple lies in [-rp, 0]).
    for f in (100.0, 1000.0, 2000.0):
        g = 20.0 * np.log10(np.abs(d.frequency_response(f)))
        assert -d.rp_db - tol_db <= g <= tol_db


def test_frequency_response_shapes():
    d = EliminatorDesign.paper()
    assert d.frequency_response(100.0).shape == ()
    assert d.frequency_response([100.0, 200.0]).shape == (2,)
    assert np.iscomplexobj(d.frequency_response([100.0]))
    assert d.group_delay_s(np.ones((2, 3))).shape == (2, 3)


def test_frequency_response_matches_time_domain():
    """Steady-state response of the streamed filter to a sine equals H(f)."""
    d = EliminatorDesign.paper()
    f = 500.0
    n = 20_000
    t = np.arange(n) / FS
    y = eliminate(np.cos(2.0 * math.pi * f * t), d)
    h = d.frequency_response(f)
    expected = np.abs(h) * np.cos(2.0 * math.pi * f * t + np.angle(h))
    assert_allclose(y[-2000:], expected[-2000:], atol=1e-9)


# --- group delay ----------------------------------------------------------


def _centroid(p):
    n = np.arange(p.size)
    return np.sum(n * p) / np.sum(p)


def test_group_delay_from_envelope_of_a_20_hz_wave_packet():
    """The envelope of a narrow-band packet at 20 Hz is delayed by the group delay.

    The complex packet ``g(n) exp(j 2 pi f n / fs)`` is filtered (real and
    imaginary parts through the real filter); the shift of the centroid of
    ``|y|^2`` is the ``|X|^2``-weighted mean group delay over the packet's
    band. With a 0.1 s Gaussian envelope that band is about 1 Hz wide and
    the group delay curves by ~4e-5 samples/Hz^2 there, so the centroid
    matches the group delay at 20 Hz to ~1e-4 samples; the tolerance of
    1e-3 samples still rejects the phase delay (0.0051 samples away).
    """
    d = EliminatorDesign.paper()
    f = 20.0
    n = 14_400
    k = np.arange(n)
    env = np.exp(-0.5 * ((k - n / 2) / (0.1 * FS)) ** 2)
    xr = env * np.cos(2.0 * math.pi * f * k / FS)
    xi = env * np.sin(2.0 * math.pi * f * k / FS)
    yr, yi = eliminate(xr, d), eliminate(xi, d)
    shift_samples = _centroid(yr**2 + yi**2) - _centroid(xr**2 + xi**2)
    assert_allclose(shift_samples, d.group_delay_s(f) * FS, atol=1e-3)
    phase_delay_samples = -np.angle(d.frequency_response(f)) / (2.0 * math.pi * f) * FS
    assert abs(shift_samples - phase_delay_samples) > 3e-3


def test_group_delay_of_a_20_hz_sine_by_phase_fit():
    """A steady 20 Hz sine comes out delayed by about the group delay.

    A single tone is delayed by the phase delay ``-arg H / omega``, which
    near DC differs from the group delay at second order in frequency: at
    20 Hz by 0.5 % (0.0051 of a 0.973-sample delay). The least-squares
    phase fit must match the phase delay to 1e-6 samples and the group
    delay to 1 %.
    """
    d = EliminatorDesign.paper()
    f = 20.0
    n = 36_000
    t = np.arange(n) / FS
    y = eliminate(np.sin(2.0 * math.pi * f * t), d)
    sl = slice(n // 2, None)  # after the start-up transient (poles |z| <= 0.998)
    basis = np.column_stack([np.sin(2.0 * math.pi * f * t[sl]), np.cos(2.0 * math.pi * f * t[sl])])
    (a, b), *_ = np.linalg.lstsq(basis, y[sl], rcond=None)
    delay_s = -math.atan2(b, a) / (2.0 * math.pi * f)
    phase_delay_s = -np.angle(d.frequency_response(f)) / (2.0 * math.pi * f)
    assert_allclose(delay_s * FS, phase_delay_s * FS, atol=1e-6)
    assert_allclose(delay_s, d.group_delay_s(f), rtol=1e-2)


def test_group_delay_at_dc_equals_first_moment_of_impulse_response():
    """Exact identity: group delay at DC = sum(n h[n]) / sum(h[n])."""
    d = EliminatorDesign.paper()
    imp = np.zeros(200_000)
    imp[0] = 1.0
    h = eliminate(imp, d)
    assert_allclose(_centroid(h), d.group_delay_s(0.0) * FS, rtol=1e-9)


# --- validation -----------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"band_hz": (410.0, 370.0)}, r"eliminator\.band_hz"),
        ({"band_hz": (390.0, 390.0)}, r"eliminator\.band_hz"),
        ({"band_hz": (0.0, 410.0)}, r"eliminator\.band_hz"),
        ({"band_hz": (370.0, 3600.0)}, r"eliminator\.band_hz"),
        ({"band_hz": (370.0, 4000.0)}, r"eliminator\.band_hz"),
        ({"band_hz": (float("nan"), 410.0)}, r"eliminator\.band_hz"),
        ({"band_hz": (370.0,)}, r"eliminator\.band_hz"),
        ({"rp_db": 0.0}, r"eliminator\.rp_db"),
        ({"rp_db": -0.1}, r"eliminator\.rp_db"),
        ({"rp_db": float("nan")}, r"eliminator\.rp_db"),
        ({"rs_db": 0.1}, r"eliminator\.rs_db"),
        ({"rs_db": 0.05}, r"eliminator\.rs_db"),
        ({"rs_db": float("inf")}, r"eliminator\.rs_db"),
        ({"fs_hz": float("nan")}, r"eliminator\.fs_hz"),
        ({"fs_hz": 0.0}, r"eliminator\.fs_hz"),
        ({"order": 0}, r"eliminator\.order"),
        ({"order": 2.5}, r"eliminator\.order"),
    ],
)
def test_bad_design_raises(kwargs, field):
    with pytest.raises(ValueError, match=field):
        EliminatorDesign(**kwargs)


def test_bad_centred_raises():
    with pytest.raises(ValueError, match=r"eliminator\.dither_hz"):
        EliminatorDesign.centred(float("nan"))
    with pytest.raises(ValueError, match=r"eliminator\.width_hz"):
        EliminatorDesign.centred(386.0, width_hz=-1.0)
    with pytest.raises(ValueError, match=r"eliminator\.band_hz"):
        EliminatorDesign.centred(10.0, width_hz=40.0)


def test_bad_signal_raises_before_the_state_changes():
    e = Eliminator(EliminatorDesign.paper())
    e.process(np.ones(10))
    before = e.state
    with pytest.raises(ValueError, match=r"eliminator\.x"):
        e.process(np.array([1.0, np.nan]))
    with pytest.raises(ValueError, match=r"eliminator\.x"):
        e.process(np.ones((2, 2)))
    assert_array_equal(e.state, before)


def test_bad_frequency_raises():
    with pytest.raises(ValueError, match=r"eliminator\.f_hz"):
        EliminatorDesign.paper().frequency_response([np.inf])
