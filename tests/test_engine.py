"""The one engine: the fused per-axis kernel equals the composition of the public classes, bit
for bit; chunking and threads do not change results; ``import sins_sim`` stays light."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from sins_sim.config.imu import load_imu
from sins_sim.models.motion import AxisSines, Coning
from sins_sim.simulation.channel import ChannelChain, DriveControl
from sins_sim.units import ARCMIN
from chunking import uneven_bounds

IMU = load_imu("configs/default-imu.yaml")
H = 1.0 / 72000.0


def _run_chain(cfg, control, path, motion, axis, bounds):
    ch = ChannelChain(cfg, control, np.random.default_rng(5), np.random.default_rng(6), path=path)
    outs = []
    for i0, i1 in bounds:
        t = np.arange(i0 + 1, i1 + 1) * H
        outs.append(ch.run(i0, motion.gyro_angle(t)[:, axis].copy(), motion.body_rate(t)[:, axis].copy()))
    return {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}, ch


@pytest.mark.parametrize("axis", [0, 2])
@pytest.mark.parametrize("modulation", [0.0, 0.05])
def test_fused_kernel_equals_public_classes(axis, modulation):
    """Noise on, closed loop, amplitude modulation on and off, vibration that excites eq. 10's turning
    points: every output (readout, volts, both eq. 5 forms, eliminator, deflection) is identical."""
    cfg = IMU.channels[axis]
    cfg = dataclasses.replace(cfg, readout=dataclasses.replace(cfg.readout, noise_rad=0.02 * cfg.readout.quantum_rad))
    control = dataclasses.replace(IMU.drive_control, modulation_depth=modulation)
    motion = AxisSines(amplitude_rad=np.array([1.0, 0.7, 0.5]) * ARCMIN, frequency_hz=np.array([100.0, 230.0, 610.0]),
                       phase_rad=np.zeros(3))
    bounds = [(0, 36000), (36000, 43200), (43200, 93200), (93200, 108000)]
    fused, ch_f = _run_chain(cfg, control, "fused", motion, axis, bounds)
    ref, ch_r = _run_chain(cfg, control, "reference", motion, axis, bounds)
    for name in fused:
        np.testing.assert_array_equal(fused[name], ref[name], err_msg=name)
    assert ch_f.v_m == ch_r.v_m and ch_f.amp_meas == ch_r.amp_meas
    assert ch_f.amp_meas == pytest.approx(cfg.drive.amplitude_rad, rel=0.1)  # the loop holds the dither


def test_fused_kernel_does_not_depend_on_chunking():
    cfg = IMU.channels[1]
    motion = Coning(amplitude_rad=1.0 * ARCMIN, frequency_hz=300.0)
    n = 72000
    whole, _ = _run_chain(cfg, IMU.drive_control, "fused", motion, 1, [(0, n)])
    sizes = [10, 7200, 35990, 1230, 27570]
    parts, _ = _run_chain(cfg, IMU.drive_control, "fused", motion, 1, uneven_bounds(n, sizes))
    for name in whole:
        np.testing.assert_array_equal(whole[name], parts[name], err_msg=name)


@pytest.mark.parametrize("modulation", [0.0, 0.05])
def test_three_channels_side_by_side_equal_each_chain_alone(modulation):
    """The one-thread engine steps the three suspensions in turn (``SideBySide``); every output of every
    channel must equal that channel's own fused kernel, bit for bit, over uneven chunks (blocks of
    different lengths per axis end inside them), with readout noise and amplitude modulation."""
    from sins_sim.simulation.unit import SideBySide

    cfgs = [dataclasses.replace(c, readout=dataclasses.replace(c.readout, noise_rad=0.02 * c.readout.quantum_rad))
            for c in IMU.channels]
    control = dataclasses.replace(IMU.drive_control, modulation_depth=modulation)
    motion = AxisSines(amplitude_rad=np.array([1.0, 0.7, 0.5]) * ARCMIN, frequency_hz=np.array([100.0, 230.0, 610.0]),
                       phase_rad=np.zeros(3))

    def chains():
        return [ChannelChain(c, control, np.random.default_rng(5 + i), np.random.default_rng(9 + i), path="fused",
                             axis="xyz"[i]) for i, c in enumerate(cfgs)]

    alone, side = chains(), chains()
    three = SideBySide(side)
    for i0, i1 in uneven_bounds(86400, [7200, 30, 41970, 37200]):
        t = np.arange(i0 + 1, i1 + 1) * H
        ang, rate = np.asfortranarray(motion.gyro_angle(t)), np.asfortranarray(motion.body_rate(t))
        outs = three.run(i0, ang, rate)
        for a, ch in enumerate(alone):
            ref = ch.run_kernel(i0, ang[:, a].copy(), rate[:, a].copy())
            for name in ref:
                np.testing.assert_array_equal(outs[a][name], ref[name], err_msg=f"axis {a} {name}")
    for a in range(3):
        assert side[a].v_m == alone[a].v_m and side[a].amp_meas == alone[a].amp_meas
        np.testing.assert_array_equal(side[a].plant.state, alone[a].plant.state)


def test_chunk_must_be_whole_filter_samples():
    ch = ChannelChain(IMU.channels[0], DriveControl(), np.random.default_rng(0))
    with pytest.raises(ValueError, match="channel.chunk"):
        ch.run(0, np.zeros(15), np.zeros(15))


def test_import_sins_sim_does_not_import_matplotlib():
    code = "import sys, sins_sim, sins_sim.simulation.sins; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_public_api_is_exported_and_documented():
    """Every name of ``sins_sim.__all__`` resolves, and every public function and class has a numpydoc
    docstring listing its parameters (numpydoc's own parser, as python-control's docstring tests do)."""
    import inspect

    import sins_sim

    for name in sins_sim.__all__:
        obj = getattr(sins_sim, name)
        if name.startswith("__") or not callable(obj):
            continue
        doc = inspect.getdoc(obj)
        assert doc and doc.strip(), name
        if inspect.isfunction(obj):
            params = [p for p in inspect.signature(obj).parameters if p not in ("self",)]
            for p in params:
                assert p in doc, f"{name}: parameter {p!r} is not documented"


def test_navigation_on_threads_equals_the_serial_run_bit_for_bit():
    """With threads the three axes' kernels run on a worker (side by side; they release the GIL) while
    the calling thread prepares the next chunk's truth and navigates the previous one. Statistics,
    series, spectra and divergence records (filter order, first time) must equal the one-thread run
    exactly. The block spins at 100 deg/s about z so that the paper form diverges inside the run (its D
    carries (1 - B) X), and vibrates about x and y."""
    from sins_sim.models.motion import ConstantRate
    from sins_sim.simulation.sins import NavSettings, simulate_sins

    motion = ConstantRate(rate_rad_s=np.array([0.0, 0.0, 1.7453292519943295])) + AxisSines(
        amplitude_rad=np.array([1.0, 0.5, 0.0]) * ARCMIN, frequency_hz=np.array([150.0, 90.0, 0.0]),
        phase_rad=np.zeros(3))
    nav = NavSettings(start_s=0.3)
    runs = [simulate_sins(IMU, motion, 15.0, seed=3, nav=nav, chunk_s=0.7, threads=t) for t in (1, 3)]
    a, b = runs
    assert "correcting_paper" in a.diverged  # the divergence path is exercised
    assert list(a.diverged) == list(b.diverged) and a.diverged == b.diverged
    for name in a.series:
        for key, val in a.series[name].items():
            np.testing.assert_array_equal(val, b.series[name][key], err_msg=f"{name} {key}")
    for name in a.stats:
        for key, val in a.stats[name].last.items():
            np.testing.assert_array_equal(val, b.stats[name].last[key], err_msg=f"{name} {key}")
    for name in a.spectra:
        np.testing.assert_array_equal(a.spectra[name], b.spectra[name])


def test_axes_on_threads_without_navigation_equal_the_serial_run_bit_for_bit():
    """Without navigation each axis gets a thread of its own (the per-axis kernels); the one-thread run
    steps the three side by side: every output and drive must agree bit for bit."""
    from sins_sim.simulation.sins import simulate_sins

    motion = AxisSines(amplitude_rad=np.array([1.0, 0.5, 0.8]) * ARCMIN, frequency_hz=np.array([150.0, 90.0, 430.0]),
                       phase_rad=np.zeros(3))
    a, b = [simulate_sins(IMU, motion, 2.0, seed=5, nav=None, chunk_s=0.3, threads=t) for t in (1, 3)]
    for name in a.outputs_last:
        np.testing.assert_array_equal(a.outputs_last[name], b.outputs_last[name], err_msg=name)
    for name in a.spectra:
        np.testing.assert_array_equal(a.spectra[name], b.spectra[name], err_msg=name)
    assert a.drives == b.drives
