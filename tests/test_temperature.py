"""Temperature profiles and the tracking dither PLL (issue 11, item 4).

The plant's f0 follows ``f0 (1 + c (T - T_ref))`` block by block; with ``pll_tracking`` the drive
follows the plant's ``F(a)`` phase-continuously and eq. 5's f0 follows the drive; without it both
stay at their t = 0 values. Runs: one closed-loop channel at rest (x axis of the default IMU,
f0 = 386 Hz), the temperature ramped by 30 K in a few seconds (the amplitude loop's time constant
is 0.15 s, so the ramp is still quasi-static for the plant), -30 ppm/K.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import yaml

from sins_sim._kernels import chain as kchain
from sins_sim._kernels import drive as kdrive
from sins_sim.config.imu import load_imu
from sins_sim.config.scenario import load_scenario
from sins_sim.config.errors import ConfigError
from sins_sim.simulation.channel import ChannelChain, DriveControl
from sins_sim.simulation.temperature import TemperatureProfile, ThermalModel
from sins_sim.units import ARCSEC
from chunking import uneven_bounds

IMU = load_imu("configs/default-imu.yaml")
CFG = IMU.channels[0]
FP = CFG.plant.rate_hz
C_F0 = -30e-6  # 1/K
RAMP = TemperatureProfile("ramp", start_k=293.15, end_k=323.15, start_s=0.5, duration_s=4.0)


def _cfg(c_f0=C_F0, track=False, profile=RAMP, **kw):
    return dataclasses.replace(CFG, temperature=ThermalModel(profile, f0_per_k=c_f0, **kw), pll_tracking=track)


def _run(cfg, seconds, chunk=7200, path="auto", control=DriveControl(), history=False):
    n = int(round(seconds * FP))
    ch = ChannelChain(cfg, control, np.random.default_rng(1), np.random.default_rng(2), path=path)
    if history:
        ch.thermal.history = []
    ch.reset(0.0, 0.0)
    outs, vm = [], []
    bounds = chunk if isinstance(chunk, list) else uneven_bounds(n, [chunk])
    for i0, i1 in bounds:
        z = np.zeros(i1 - i0)
        o = ch.run(i0, z, z.copy())
        o["delta"] = np.array(o["delta"])  # the fused path reuses its work buffer
        outs.append(o)
        vm.append(ch.v_m)
    return {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}, ch, vm


def test_zero_coefficient_reproduces_todays_run_bit_for_bit():
    """A profile with every coefficient 0 runs the block machinery (split kernel calls, tracking, fpar
    repacking) and must give exactly the run without a profile, on both paths."""
    for path in ("fused", "reference"):
        base, _, _ = _run(CFG, 0.6, path=path)
        for track in (False, True):
            out, ch, _ = _run(_cfg(0.0, track), 0.6, path=path)
            assert ch.thermal is not None
            for k in base:
                assert np.array_equal(base[k], out[k]), (path, track, k)


def test_chunking_invariance_and_paths_agree_with_a_profile():
    """Blocks are counted from step 0: uneven chunks (not multiples of a block) give the same bits; the
    reference composition gives the fused kernel's bits."""
    cfg = _cfg(track=True, profile=TemperatureProfile("ramp", start_k=293.15, end_k=333.15, start_s=0.0,
                                                      duration_s=1.0))
    n = int(0.8 * FP)
    whole, _, _ = _run(cfg, 0.8, chunk=[(0, n)])
    uneven, _, _ = _run(cfg, 0.8, chunk=uneven_bounds(n, [1230, 0, 14570, 10, 2880]))
    ref, _, _ = _run(cfg, 0.8, chunk=uneven_bounds(n, [4570, 7200]), path="reference")
    for k in whole:
        assert np.array_equal(whole[k], uneven[k]), k
        assert np.array_equal(whole[k], ref[k]), k
    assert not np.array_equal(whole["correcting"], _run(CFG, 0.8)[0]["correcting"])  # the profile acted


def test_plant_follows_the_profile_in_closed_form():
    """Per block: T at the block's middle is the ramp's closed form and the plant's f0 is f0 (1 + c dT);
    the kernel's omega0^2 is (2 pi f0)^2 of that block (relative 1e-15: one rounding)."""
    out, ch, _ = _run(_cfg(), 5.0, history=True)
    h = np.array(ch.thermal.history)
    t_mid = (h[:, 0] + 0.5) * ch.thermal.block / FP
    assert np.allclose(h[:, 1], t_mid, rtol=0, atol=1e-12)
    temp = 293.15 + 30.0 * np.clip((t_mid - 0.5) / 4.0, 0.0, 1.0)
    assert np.allclose(h[:, 2], temp, rtol=0, atol=1e-9)
    assert np.allclose(h[:, 3], 386.0 * (1.0 + C_F0 * (temp - 293.15)), rtol=1e-14, atol=0)
    assert ch.plant.suspension.f0_hz == pytest.approx(386.0 * (1 - 900e-6), rel=1e-14)
    assert ch.fpar[kchain.P_W0SQ] == pytest.approx((2 * math.pi * h[-1, 3]) ** 2, rel=1e-15)
    # without tracking the drive and the filters stay at t = 0
    assert np.all(h[:, 4] == ch.drive.frequency_hz) and np.all(h[:, 5] == CFG.correcting_design("unity").f0_hz)


def test_the_resonance_moves_as_the_profile_says():
    """Physics, not bookkeeping: at the end of the ramp (F down by 900 ppm) the closed amplitude loop
    holds 3 arcmin. Without tracking the drive sits 900 ppm above the resonance and needs
    V / V0 = sqrt(1 + (2 Q delta)^2) (the driven oscillator's response at relative detuning delta,
    eq. 2 linearised with the loss 1/Q of eq. 16 at the held amplitude): 1.0552 for Q = 187; measured
    1.0535: within 0.5 % (the hysteretic loss and the softening spring are not a linear oscillator's).
    With tracking the drive stays on the resonance and V / V0 stays within 0.1 % of 1 (measured 0.9997)."""
    q = CFG.suspension.q_factor(CFG.drive.amplitude_rad)
    expect = math.sqrt(1.0 + (2.0 * q * 900e-6) ** 2)
    _, ch, vm = _run(_cfg(track=False), 6.0, chunk=72000)
    assert vm[-1] / ch.v_m0 == pytest.approx(expect, rel=5e-3)
    _, ch, vm = _run(_cfg(track=True), 6.0, chunk=72000)
    assert vm[-1] / ch.v_m0 == pytest.approx(1.0, abs=1e-3)
    assert ch.amp_meas == pytest.approx(CFG.drive.amplitude_rad, rel=1e-3)


def test_tracking_drive_follows_F_of_a_and_the_filter_follows_the_drive():
    """Each block's drive frequency is the plant's F(a_m) by harmonic balance at that block (relative
    1e-15); the filter's f0 is f_drive f0_b / F_b(a) (1e-13), here f0 (1 + c dT) itself, since the believed
    k1, k2 are the true ones and only f0 moves."""
    _, ch, _ = _run(_cfg(track=True), 5.0, history=True)
    s0 = CFG.suspension
    a = CFG.drive.amplitude_rad
    for b, t_mid, temp, f0, f_drive, f0_filter in ch.thermal.history[::50]:
        f_expect = s0.replace(f0_hz=f0).resonance_hz(a)
        assert f_drive == pytest.approx(f_expect, rel=1e-15)
        assert f0_filter == pytest.approx(f_drive * s0.f0_hz / s0.resonance_hz(a), rel=1e-13)
        assert f0_filter == pytest.approx(386.0 * (1.0 + C_F0 * (temp - 293.15)), rel=1e-13)
    assert ch.filters["correcting"].design.f0_hz == pytest.approx(386.0 * (1 - 900e-6), rel=1e-13)


def test_tracking_keeps_the_drive_waveform_and_the_detector_phase_continuous():
    """At a frequency change the sample at the block's first DAC index is the one the old frequency gives
    (to 1e-9 V at 0.39 V: the phase is carried in float64 from frac(c k) with c k ~ 1e4), and the next
    advances at the new frequency; likewise the detector's reference at its first index."""
    ch = ChannelChain(_cfg(track=True), DriveControl(), np.random.default_rng(1))
    th, fp = ch.thermal, ch.fpar
    i_b = 1440 * 1000  # a block start 20 s in
    old = (fp[kchain.P_CYC_DAC], fp[kchain.P_PHASE], fp[kchain.P_CYC_STEP], fp[kchain.P_DPHASE])
    f_new = ch.drive.frequency_hz * (1 - 900e-6)
    th._set_drive(ch, i_b, f_new)
    before, after = np.empty(2), np.empty(2)
    kdrive.dac_cosine(i_b, ch.r_dac, old[0], old[1], 1.0, before)
    kdrive.dac_cosine(i_b, ch.r_dac, fp[kchain.P_CYC_DAC], fp[kchain.P_PHASE], 1.0, after)
    assert after[0] == pytest.approx(before[0], abs=1e-9)
    ph0 = 2 * math.pi * (old[0] * i_b % 1.0) + old[1]
    assert after[1] == pytest.approx(math.cos(ph0 + 2 * math.pi * f_new / CFG.drive.dac_rate_hz), abs=1e-9)
    # the detector: sin/cos sums over one sample at index i_b + 1 equal the old reference's
    for cyc, ph in ((old[2], old[3]), (fp[kchain.P_CYC_STEP], fp[kchain.P_DPHASE])):
        acc = np.zeros(3)
        kdrive.demod_accumulate(np.ones(1), i_b, cyc, 0, 1, acc, ph)
        if cyc == old[2]:
            ref = acc.copy()
    assert np.allclose(acc, ref, atol=1e-9)


@pytest.fixture(scope="module")
def residuals():
    """Correcting-filter residual over the last 1 s (T = 323.15 K, f0 down 900 ppm), block at rest (truth 0):
    RMS and the amplitude of its line at the drive frequency (least squares), both in arcsec."""
    out = {}
    for name, cfg in (("no_drift", CFG), ("tracking", _cfg(track=True)), ("fixed", _cfg(track=False))):
        o, ch, _ = _run(cfg, 6.0, chunk=72000)
        y = o["correcting"][-7200:]
        t = np.arange(o["correcting"].shape[0])[-7200:] / CFG.filter_rate_hz
        w = 2.0 * math.pi * ch.drive_hz * t
        basis = np.column_stack([np.cos(w), np.sin(w), np.ones_like(t)])
        c = np.linalg.lstsq(basis, y, rcond=None)[0]
        out[name] = (float(np.sqrt(np.mean(y * y))) / ARCSEC, math.hypot(c[0], c[1]) / ARCSEC, ch.drive_hz)
    return out


def test_tracking_keeps_the_correcting_residual_near_the_no_drift_value(residuals):
    """Measured (seeds 1, 2): RMS no drift 0.412 arcsec, tracking 0.411, no tracking 0.475 (+15 %); the dither
    line in the residual: 0.0154, 0.0149 and 0.342 arcsec.

    Tracking: RMS within 2 % of the no-drift value (the readout quantisation noise, 0.40 arcsec RMS, is the
    same process; the dither line is 0.015 arcsec either way, so 2 % is the noise's variation between two
    dither paths) and the line within 0.005 arcsec of it. Without tracking the line is eq. 5's omega0 error:
    with the plant's relation ``X + Nonl + Diss + k5 V = -X''/omega_p^2`` the unity-DC filter leaves
    ``a ((Omega/omega_p)^2 - (1 - cos theta)/(1 - cos w_f))`` at the dither (a = 180 arcsec, theta = Omega dT,
    w_f = omega_f dT): 0.302 arcsec for omega_f = 386 Hz, omega_p 900 ppm below; measured 0.342 (+13 %,
    not yet explained: a 15 % tolerance). The RMS grows by at least 10 %."""
    rms, line, _ = zip(*(residuals[k] for k in ("no_drift", "tracking", "fixed")))
    assert rms[1] == pytest.approx(rms[0], rel=0.02)
    assert abs(line[1] - line[0]) < 0.005
    fs = CFG.filter_rate_hz
    big_f, f_p, f_f = residuals["fixed"][2], 386.0 * (1 - 900e-6), 386.0
    theta, w_f = 2 * math.pi * big_f / fs, 2 * math.pi * f_f / fs
    closed = 180.0 * abs((big_f / f_p) ** 2 - (1 - math.cos(theta)) / (1 - math.cos(w_f)))
    assert line[2] == pytest.approx(closed, rel=0.15)
    assert rms[2] > 1.10 * rms[0]


def _scenario(tmp_path, temperature, fparams=None):
    doc = {"name": "t", "duration_s": 2.0, "imu": "configs/default-imu.yaml", "temperature": temperature}
    if fparams is not None:
        doc["filter_parameters"] = fparams
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    import os

    os.symlink(os.path.abspath("configs"), tmp_path / "configs")
    return p


def test_scenario_section_loads_and_reaches_every_channel(tmp_path):
    p = _scenario(tmp_path, {"profile": "table", "table_s_k": [[0, 293.15], [1, 303.15]], "f0_ppm_per_k": -30,
                             "k_ppm_per_k": {"k5": 2000}}, {"source": True, "f0": "pll", "track": True})
    sc = load_scenario(p)
    assert all(c.temperature is sc.temperature and c.pll_tracking for c in sc.imu.channels)
    assert sc.temperature.k_per_k[4] == pytest.approx(2e-3) and sc.temperature.profile.at(0.5) == pytest.approx(298.15)


@pytest.mark.parametrize("temperature, fparams, message", [
    ({"profile": "ramp", "initial_k": 293.15, "final_k": 303.15, "duration_s": 10}, None,
     "temperature.f0_ppm_per_k: is required"),
    ({"profile": "warm", "initial_k": 293.15, "f0_ppm_per_k": 1}, None, "temperature.profile: must be one of"),
    ({"profile": "step", "initial_k": 293.15, "step_k": 60, "start_s": 0.5, "f0_ppm_per_k": -30,
      "k_ppm_per_k": {"k3": -10000}}, None, "temperature.k_ppm_per_k.k3: the linear model leaves its range at 353.15 K"),
    ({"profile": "table", "table_s_k": [[1, 293.15], [0, 303.15]], "f0_ppm_per_k": 1}, None,
     "temperature.table_s_k: times must increase strictly"),
    ({"profile": "constant", "initial_k": 293.15, "f0_ppm_per_k": 1, "update_s": 0.02}, {"track": 1},
     "filter_parameters.track: must be true or false"),
    ({"profile": "table", "table_s_k": [[0, 293.15], [1, 500]], "f0_ppm_per_k": -30}, None,
     "temperature.table_s_k[1][1]: must be <= 473.15"),
])
def test_bad_temperature_input_is_one_line_naming_the_key(tmp_path, temperature, fparams, message):
    with pytest.raises(ConfigError) as err:
        load_scenario(_scenario(tmp_path, temperature, fparams))
    text = str(err.value)
    assert message in text and "\n" not in text, text
