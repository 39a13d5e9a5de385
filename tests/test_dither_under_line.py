"""A vibration line near a gyro's resonance takes the dither from the amplitude loop (issue 38, finding 1): the
suspension's forced response leaks into the drive's synchronous detector, whose Hann window of ten dither cycles
passes lines within +-2 f_d / 10, and the loop holds the total; the dither at the drive frequency falls while the
drive reports its target. ``plan.advisories.dither_under_lines`` forecasts it and warns."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate

from sins_sim.models.drive import detector_leakage, held_dither_amplitude
from sins_sim.simulation.sins import NavSettings, simulate_sins
from sins_sim.simulation.unit import run_channels
from sins_sim.units import ARCSEC

ROOT = Path(__file__).resolve().parents[1]
LINE_HZ = 384.3  # 37 Hz under z's drive (421.6 Hz on the block), inside its detector's main lobe (+-84 Hz)


def test_the_detector_window_is_the_hann_transform():
    """Summed over a block of N plant steps the window's transform is the continuous Hann's
    ``|sinc(x) / (1 - x^2)|`` (``x = df T``, Harris 1978) to O(1 / N^2) (1707 steps: 1e-6); zero at x = 2, 3."""
    n, rate = 1707, 72000.0
    t = n / rate
    for x in (0.0, 0.5, 0.88, 1.5, 2.0, 3.0):
        want = 1.0 if x == 0 else abs(math.sin(math.pi * x) / (math.pi * x) / (1 - x * x)) if x != 1 else 0.5
        assert detector_leakage(n, rate, x / t) == pytest.approx(want, abs=1e-6)


def test_what_the_loop_holds_is_the_mean_modulus_at_its_target():
    """``held_dither_amplitude`` solves ``mean |a + c e^{i phi}| = a_t`` (checked by quadrature to 1e-9); a small
    leak takes ``c^2 / (4 a_t)`` (the next term is O(c^4 / a_t^3): 1e-3 relative at c = a_t / 10); a leak at or
    above the target leaves nothing."""
    at = 180.0
    for c in (18.0, 72.0, 150.0, 179.0):
        a = held_dither_amplitude(at, c)
        mean = integrate.quad(lambda p: abs(a + c * np.exp(1j * p)), 0, 2 * math.pi, limit=200)[0] / (2 * math.pi)
        assert mean == pytest.approx(at, rel=1e-9)
    assert at - held_dither_amplitude(at, 18.0) == pytest.approx(18.0 ** 2 / (4 * at), rel=2e-2)
    assert held_dither_amplitude(at, 180.0) == 0.0 and held_dither_amplitude(at, 0.0) == at


def _scenario(tmp_path, arcmin, block_cycles=10):
    from sins_sim.config.scenario import load_scenario

    imu = ROOT / "configs" / "isolated-block.yaml"
    if block_cycles != 10:
        text = imu.read_text()
        assert "block_cycles: 10}" in text
        imu = tmp_path / "imu.yaml"
        imu.write_text(text.replace("block_cycles: 10}", f"block_cycles: {block_cycles}}}"))
    p = tmp_path / f"line{arcmin}.yaml"
    p.write_text(f"name: line\nseed: 1\nduration_s: 4.0\nimu: {imu}\n"
                 f"motion:\n  - {{type: sines, amplitude_arcmin: [0.0, 0.0, {arcmin}], frequency_hz: [0.0, 0.0, "
                 f"{LINE_HZ}]}}\nmotion_enters: block\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scenario(p)
    return sc, [str(w.message) for w in caught]


def _lines(sc):
    """z's deflection (the raw readout less the truth) at its drive and at the line, over the last 2 s."""
    res = simulate_sins(sc.imu, sc.motion, 4.0, seed=1, nav=NavSettings(start_s=2.0, spectrum_s=2.0),
                        filters=("ideal", "raw"), motion_enters="block")
    t, e = res.spectra["t"], res.spectra["raw"][:, 2]
    fd = run_channels(sc.imu)[2].drive_signal().frequency_hz
    cols = []
    for f in (fd, LINE_HZ):
        w = 2 * math.pi * f
        cols += [np.cos(w * t), np.sin(w * t)]
    c, *_ = np.linalg.lstsq(np.column_stack(cols + [np.ones_like(t), t]), e, rcond=None)
    return math.hypot(c[0], c[1]), math.hypot(c[2], c[3]), res


def test_a_moderate_line_as_the_forecast(tmp_path):
    """0.4 arcmin at the block: z's forced response against ``|H| b`` (tolerance: eq. 10's loss as a viscous damper
    moves ``H`` by up to ``(1 / Q) / (1 - r^2)``, 3.5 % here; measured 0.3 %), and the dither the loop leaves: the
    reduction ``a_t - a`` (forecast 7.5 arcsec) within ``f_bw / f_alias`` of itself. The forecast is the mean modulus
    over the beat's phases, as a loop that does not follow the beat holds it; the control blocks sample the 37 Hz
    beat as a 4.9 Hz one, of which the 0.1 s loop (bandwidth ``1 / (2 pi loop_time_s)``, 1.6 Hz) follows a share of
    about that ratio, correlating the dither with the beat's phase (measured 6.4 arcsec, 15 % short; a loop slow
    enough not to follow it holds the forecast to 1 %, the last test)."""
    sc, notes = _scenario(tmp_path, 0.4)
    (d,) = [x for x in sc.dither_forecast if x["axis"] == "z"]
    dither, line, _ = _lines(sc)
    q = sc.imu.channels[2].suspension.q_factor(sc.imu.channels[2].drive.amplitude_rad)
    r2 = (LINE_HZ / sc.imu.channels[2].suspension.line_resonance_hz(sc.imu.channels[2].drive.amplitude_rad)) ** 2
    assert line / ARCSEC == pytest.approx(d["deflection_line_arcsec"], rel=(1 / q) / (1 - r2))
    block_s = 10 / d["drive_hz"]
    beat = abs(LINE_HZ - d["drive_hz"]) * block_s
    alias = abs(beat - round(beat)) / block_s
    bw = 1 / (2 * math.pi * sc.imu.drive_control.loop_time_s)
    drop = d["dither_target_arcsec"] - d["dither_held_arcsec"]
    assert (d["dither_target_arcsec"] - dither / ARCSEC) == pytest.approx(drop, rel=bw / alias)
    (msg,) = [n for n in notes if n.startswith("drive z")]  # 4 % short: beyond the drives' 1 % tolerance
    assert "384.3 Hz" in msg and "arcsec at the drive frequency" in msg


def test_the_finding_a_line_that_takes_the_dither(tmp_path):
    """Issue 38's case, 1 arcmin at the block: the detector reads 179 of the 180 arcsec target from the line alone,
    so the loop leaves almost no dither (forecast 23 arcsec; the mean modulus is flat there, so the number is
    sensitive: measured 44 arcsec, still a quarter of the target), and the advisory says so, with the detector
    window that would put the line at its first null."""
    sc, notes = _scenario(tmp_path, 1.0)
    (d,) = [x for x in sc.dither_forecast if x["axis"] == "z"]
    assert d["detector_reads_arcsec"] > 0.99 * d["dither_target_arcsec"]
    dither, _, res = _lines(sc)
    assert dither < 0.3 * d["dither_target_arcsec"] * ARCSEC
    (entry,) = [n for n in notes if n.startswith("motion line 384.3 Hz")]  # the block departs by 7.2 % there
    assert "7.19 %" in entry and "z gyro" in entry
    (msg,) = [n for n in notes if n.startswith("drive z")]
    assert f"block_cycles >= {d['block_cycles_for_null']}" in msg and d["block_cycles_for_null"] == 23


def test_a_detector_window_that_nulls_the_line_keeps_the_dither(tmp_path):
    """The advisory's remedy: the same 1 arcmin line with ``block_cycles: 23`` (the line 37.3 Hz off, past the
    Hann window's first null at 2 f_d / 23 = 36.7 Hz): the detector reads 1.7 arcsec of the 306 arcsec forced
    response (a side lobe) and the dither stays at its target: within 1 % (the drives' amplitude tolerance; measured
    179.9 of 180 arcsec) and no drive advisory."""
    sc, notes = _scenario(tmp_path, 1.0, block_cycles=23)
    (d,) = [x for x in sc.dither_forecast if x["axis"] == "z"]
    assert d["detector_reads_arcsec"] < 0.01 * d["deflection_line_arcsec"]
    dither, _, _ = _lines(sc)
    assert dither / ARCSEC == pytest.approx(d["dither_target_arcsec"], rel=0.01)
    assert not [n for n in notes if n.startswith("drive ")]


def test_a_slow_loop_holds_the_mean_modulus_at_its_target():
    """One channel on a rigid block (the z suspension, 421 Hz; its drive at 418.7 Hz), a 22.3 arcsec line at
    384.3 Hz, the amplitude loop slowed to 0.5 s so that it averages the beat as the control blocks sample it
    (0.82 cycles per block: a 7.5 Hz beat against the loop's 0.32 Hz bandwidth): the dither at the drive frequency
    is ``held_dither_amplitude`` of the leak the detector reads of the measured forced response. Tolerance on the
    reduction ``a_t - a`` (forecast 9 arcsec): the part of the beat the loop follows, ``f_bw / f_alias`` (4 %; the
    default 0.1 s loop follows 21 % and leaves 8 % less reduction), plus 2 % for the record's fit of two lines 34 Hz
    apart over 6 s (their leakage into each other is below 1e-3; the quantised readout's floor 0.1 arcsec of 9)."""
    from sins_sim.models.suspension import SuspensionParams
    from sins_sim.simulation.channel import ChannelChain, ChannelConfig, DriveControl

    b, fv, loop = 22.3 * ARCSEC, LINE_HZ, 0.5
    cfg = ChannelConfig(suspension=SuspensionParams(f0_hz=421.0))
    ch = ChannelChain(cfg, DriveControl(mode="closed_loop", loop_time_s=loop), np.random.default_rng(0))
    h, fd, fs = ch.plant.h, ch.drive.frequency_hz, cfg.filter_rate_hz
    ch.reset(0.0, b * 2 * math.pi * fv)
    chunk, n = 72000, 12 * 72000
    raw = []
    for i0 in range(0, n, chunk):
        k = np.arange(i0 + 1, i0 + chunk + 1) * h
        raw.append(np.array(ch.run(i0, b * np.sin(2 * math.pi * fv * k), b * 2 * math.pi * fv * np.cos(2 * math.pi * fv * k))["raw"]))
    raw = np.concatenate(raw)
    t = np.arange(raw.size) / fs - ch.readout.delay_s
    sel = t > 6.0
    cols = []
    for f in (fd, fv):
        cols += [np.cos(2 * math.pi * f * t[sel]), np.sin(2 * math.pi * f * t[sel])]
    c, *_ = np.linalg.lstsq(np.column_stack(cols + [np.ones(sel.sum())]),
                            (raw - b * np.sin(2 * math.pi * fv * t))[sel], rcond=None)
    dither, forced = math.hypot(c[0], c[1]), math.hypot(c[2], c[3])
    at = cfg.drive.amplitude_rad
    held = held_dither_amplitude(at, forced * detector_leakage(ch.block, cfg.plant.rate_hz, fv - fd))
    beat = abs(fv - fd) * ch.block / cfg.plant.rate_hz
    alias = abs(beat - round(beat)) * cfg.plant.rate_hz / ch.block
    tol = 1 / (2 * math.pi * loop) / alias + 0.02
    assert (at - dither) == pytest.approx(at - held, rel=tol), ((at - dither) / ARCSEC, (at - held) / ARCSEC)
    assert (at - held) / ARCSEC > 5  # a real reduction, not the fit's floor


def test_the_run_keeps_the_forecast_and_the_warning(tmp_path):
    """``metrics.json`` carries the forecast under ``dither_under_vibration`` and the warning among its warnings."""
    import json

    from sins_sim.jobs.run import run_scenario

    p = tmp_path / "run.yaml"
    p.write_text(f"name: line\nseed: 1\nduration_s: 1.5\nimu: {ROOT / 'configs' / 'isolated-block.yaml'}\n"
                 f"motion:\n  - {{type: sines, amplitude_arcmin: [0.0, 0.0, 0.4], frequency_hz: [0.0, 0.0, "
                 f"{LINE_HZ}]}}\nmotion_enters: block\nfilters: [ideal]\nnavigation: {{start_s: 0.5}}\n"
                 f"outputs: {{plots: false, timeseries: false}}\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run_scenario(p, tmp_path / "out")
    m = json.loads((tmp_path / "out" / "metrics.json").read_text())
    (d,) = [x for x in m["dither_under_vibration"] if x["axis"] == "z"]
    assert d["line_hz"] == LINE_HZ and d["dither_held_arcsec"] < 0.99 * d["dither_target_arcsec"]
    assert [w for w in m["warnings"] if w.startswith("drive z: the vibration line 384.3 Hz")]
