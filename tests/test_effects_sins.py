"""The effects catalogue in the SINS engine: each effect acts in ``ChannelChain`` (the engine's per-axis
chain) as it does in the experiment simulator that writes recordings; streaming does not depend on
chunking; the fused path stays as it was when no effect stage acts; IMU files carry ``effects:``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from sins_sim._kernels import drive as kdrive
from sins_sim.config.imu import imu_from_dict, load_imu
from sins_sim.config.errors import ConfigError
from sins_sim.models.effects import make_effect
from sins_sim.models.motion import Static
from sins_sim.simulation.channel import ChannelChain, DriveControl
from sins_sim.simulation.experiment import ExperimentInputs, ExperimentSettings, simulate_axis, table_motion
from sins_sim.simulation.sins import ImuConfig, NavSettings, simulate_sins
from sins_sim.units import ARCMIN, ARCSEC
from chunking import uneven_bounds

IMU = load_imu("configs/default-imu.yaml")
CFG = IMU.channels[0]
FP = 72000.0
# drift blocks are 0.02 s = 1440 steps: the experiment's last block is whole with N - 1 = 25 x 1440 steps
N = 25 * 1440 + 1
MOTION = table_motion(1e-3, [(1.0 * ARCMIN, 100.0, 0.3)])


def _chain(effects, bounds, path="auto", control=DriveControl(mode="open_loop")):
    ch = ChannelChain(CFG, control, np.random.default_rng(1), np.random.default_rng(2), path=path, axis="x",
                      effects=effects)
    a0, r0 = MOTION.angle_rate(np.zeros(1))
    ch.reset(float(a0[0]), float(r0[0]))
    outs = []
    for i0, i1 in bounds:
        a, r = MOTION.angle_rate(np.arange(i0 + 1, i1 + 1) / FP)
        outs.append(ch.run(i0, np.ascontiguousarray(a), np.ascontiguousarray(r)))
    return {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}, ch


def _sensed(out):
    """The counter's input at grid points 0 .. n - 1 (fused path: block angle + delta, one step late)."""
    if "sensed" in out:
        return out["sensed"]
    n = out["delta"].shape[0]
    a, _ = MOTION.angle_rate(np.arange(n) / FP)
    return a + np.concatenate(([0.0], out["delta"][:-1]))


# Tolerances (rad, on the angle the counter sees, rest to 0.5 s under a 1 arcmin 100 Hz table and 1 mrad/s):
# 1e-12 where the arithmetic is the same up to rounding (lfilter's initial condition, cubic Hermite
# factors); lock-in and delay 1e-9 (5 uarcsec, 1/150 of the readout quantum 0.151 arcsec): the recording
# takes the RLG rate as a 4th-order finite difference of delta (relative error ~5e-6 at eq. 10's turning
# points), the engine the plant's exact d delta/dt (it has no future samples); measured 1e-10 and 4e-11.
CASES = [
    ({"name": "lock_in", "threshold_rad_s": 5e-3, "phase_rad": 0.4}, 1e-9),
    ({"name": "piezo_lag", "tau_s": 2e-4}, 1e-12),
    ({"name": "scale_factor", "error": 1e-3}, 1e-12),
    ({"name": "readout_delay", "delay_s": 3.3e-5}, 1e-9),
    ({"name": "block_mode", "frequency_hz": 900.0, "zeta": 0.05, "gain": 0.3}, 1e-12),
    ({"name": "resonance_drift", "rate_hz_per_s": 20.0}, 1e-12),
    ({"name": "viscous_damping", "zeta": 1e-3}, 1e-12),
]


@pytest.mark.parametrize("spec,tol", CASES, ids=[c[0]["name"] for c in CASES])
def test_engine_equals_recording_simulator(spec, tol):
    """Same single-axis input (open-loop drive, table motion) through the experiment simulator and the
    engine's chain with the same effect: the angle the counter sees agrees."""
    params = {k: v for k, v in spec.items() if k != "name"}
    effect = make_effect(spec["name"], **params)
    n = N + 9  # whole filter samples
    out, ch = _chain([effect], uneven_bounds(n, [7200, 3590, 10010]))
    volts = np.empty(n)
    kdrive.dac_cosine(0, ch.r_dac, ch.drive.frequency_hz / CFG.drive.dac_rate_hz, ch.drive.phase_rad, ch.v_m0, volts)
    inputs = ExperimentInputs(["x"], FP, N, CFG.drive.dac_rate_hz, volts[:N:ch.r_dac].reshape(-1, 1), {"x": MOTION})
    rec = simulate_axis(inputs, "x", CFG.suspension, [effect], ExperimentSettings(plant_rate_hz=FP))
    base = simulate_axis(inputs, "x", CFG.suspension, [], ExperimentSettings(plant_rate_hz=FP))
    got = _sensed(out)[:N]
    assert np.max(np.abs(got - rec)) < tol
    assert np.max(np.abs(rec - base)) > 100 * tol  # the effect is visible at that tolerance


def test_effect_stages_do_not_depend_on_chunking():
    effects = [make_effect("lock_in", threshold_rad_s=3e-3, axes=["x"]), make_effect("piezo_lag", tau_s=1e-4),
               make_effect("readout_delay", delay_s=2.5e-4), make_effect("block_mode", frequency_hz=700.0,
                                                                           zeta=0.02, gain=0.5),
               make_effect("resonance_drift", rate_hz_per_s=-5.0), make_effect("scale_factor", error=-2e-4)]
    control = dataclasses.replace(IMU.drive_control, modulation_depth=0.05)
    n = 43200
    whole, _ = _chain(effects, [(0, n)], control=control)
    parts, ch = _chain(effects, uneven_bounds(n, [10, 7200, 13990, 1230]), control=control)
    assert ch.path == "reference"
    for name in whole:
        np.testing.assert_array_equal(whole[name], parts[name], err_msg=name)


def test_fused_path_unchanged_without_effect_stages():
    """No effects, or a suspension-stage effect only: the fused kernel runs, and equals the reference path."""
    bounds = [(0, 14400), (14400, 21600)]
    plain, ch0 = _chain((), bounds)
    assert ch0.path == "fused"
    damped_f, ch1 = _chain([make_effect("viscous_damping", zeta=2e-3)], bounds)
    damped_r, _ = _chain([make_effect("viscous_damping", zeta=2e-3)], bounds, path="reference")
    assert ch1.path == "fused" and ch1.plant.suspension.zeta == 2e-3
    for name in damped_f:
        np.testing.assert_array_equal(damped_f[name], damped_r[name], err_msg=name)
    assert not np.array_equal(plain["delta"], damped_f["delta"])
    with pytest.raises(ValueError, match="channel.path: the fused kernel has no effect stages"):
        ChannelChain(CFG, DriveControl(), np.random.default_rng(0), path="fused",
                     effects=[make_effect("lock_in", threshold_rad_s=1e-3)])


def test_effect_on_another_axis_leaves_the_axis_on_the_fused_path():
    ch = ChannelChain(CFG, DriveControl(), np.random.default_rng(0), axis="y",
                      effects=[make_effect("lock_in", threshold_rad_s=1e-3, axes=["x"])])
    assert ch.path == "fused"


def test_imu_effects_validation():
    doc = yaml.safe_load(open("configs/default-imu.yaml"))
    doc["effects"] = [{"name": "lock_in", "axes": ["x"], "threshold_rad_s": 2e-3}, {"name": "piezo_lag", "tau_s": 1e-4}]
    imu = imu_from_dict(doc, "imu.yaml")
    assert [e.name for e in imu.effects] == ["lock_in", "piezo_lag"] and imu.effects[0].axes == ("x",)
    bad = [([{"name": "axis_coupling", "coefficients": {"x": {"y": 0.01}}}], "axis_coupling is not a mission effect"),
           ([{"name": "lock_in", "axes": ["w"], "threshold_rad_s": 1e-3}], "'w' is not one of the axes"),
           ([{"name": "lock_in"}], "threshold_rad_s: is required"),
           ([{"name": "piezo_lag", "tau_s": 1.0}], r"tau_s: must be in \[0, 0.01\]"),
           ([{"name": "mains_pickup", "amplitude_rad": 1e-6}], "name: must be one of"),
           ("lock_in", "must be a list of effects")]
    for value, match in bad:
        doc["effects"] = value
        with pytest.raises(ConfigError, match=match):
            imu_from_dict(doc, "imu.yaml")
    with pytest.raises(ValueError, match="axis_coupling"):
        ImuConfig(channels=IMU.channels, effects=(make_effect("axis_coupling", coefficients={"x": {"y": 0.01}}),))


def test_sins_run_with_lock_in_on_one_axis():
    """In the full loop: lock-in on x changes x's gyro-angle error and leaves y and z bit for bit."""
    nav = NavSettings(start_s=1.0, align_s=0.2, spectrum_s=0.3)
    kw = dict(duration_s=1.4, nav=nav, filters=("correcting",), threads=1)
    plain = simulate_sins(IMU, Static(), **kw)
    imu = dataclasses.replace(IMU, effects=(make_effect("lock_in", threshold_rad_s=2e-2, axes=["x"]),))
    locked = simulate_sins(imu, Static(), **kw)
    a, b = plain.spectra["correcting"], locked.spectra["correcting"]
    np.testing.assert_array_equal(a[:, 1:], b[:, 1:])
    assert np.max(np.abs(a[:, 0] - b[:, 0])) > 0.05 * ARCSEC
