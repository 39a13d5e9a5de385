"""A block on isolators with the channels' schedules (issue 38, item 2): a temperature profile, a tracking PLL and the
online estimator run on the block's stepper piece by piece (``simulation.unit.SideBySide``); the PLL locks each
drive to its coupled dither mode on the block; the isolators follow the temperature; what is not modelled is refused
when the scenario is loaded, naming both keys."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.config.yaml_io import load_yaml
from sins_sim.models.block import BlockParams, coupled_dither_frequencies
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.channel import ChannelConfig, DriveControl
from sins_sim.simulation.online import OnlineSpec
from sins_sim.simulation.sins import ImuConfig
from sins_sim.simulation.temperature import TemperatureProfile, ThermalModel
from sins_sim.simulation.unit import SensorUnit

ROOT = Path(__file__).resolve().parents[1]
F0 = (386.0, 352.0, 421.0)
#: The bundled isolated block (configs/isolated-block.yaml): 3 kg, rocking modes near 100 Hz, 2e-4 kg m^2 gyros.
BLOCK = BlockParams(mass_kg=3.0, inertia_kg_m2=np.diag([0.012, 0.013, 0.015]), gyro_inertia_kg_m2=[2.0e-4] * 3,
                    k_trans_n_per_m=[7.58e5] * 3, k_rot_n_m_per_rad=[4737.0, 5132.0, 5922.0],
                    c_trans_n_s_per_m=[151.0] * 3, c_rot_n_m_s_per_rad=[0.754, 0.817, 0.942])
T_REF = 293.15
#: A 10 K step at 0.3 s on a plain spring steel's -120 ppm/K (sins_sim.simulation.temperature): f0 falls by 0.12 %,
#: 0.46 Hz at 386 Hz, about half the dither's half-bandwidth (f / 2Q, Q near 190).
STEP = ThermalModel(TemperatureProfile("step", start_k=T_REF, end_k=T_REF + 10.0, step_k=10.0, start_s=0.3),
                    f0_per_k=-120e-6, reference_k=T_REF)
CONTROL = DriveControl(loop_time_s=0.05)


def _unit(temperature=None, track=False, online=None, block=BLOCK, seed=2):
    chans = tuple(ChannelConfig(suspension=SuspensionParams(f0_hz=f), temperature=temperature, pll_tracking=track,
                                online=online) for f in F0)
    return SensorUnit(ImuConfig(channels=chans, drive_control=CONTROL, block=block), seed=seed)


def _run(unit, duration_s, chunk_s=0.25):
    """The unit at rest on a still chassis for ``duration_s``, in chunks; returns the outputs per axis."""
    three = unit.mechanics(True)
    h = unit.chains[0].plant.h
    r_dec = unit.chains[0].r_dec
    n_all = int(round(duration_s / h)) // r_dec * r_dec
    step = int(round(chunk_s / h)) // r_dec * r_dec
    outs = [[] for _ in range(3)]
    i0 = 0
    while i0 < n_all:
        n = min(step, n_all - i0)
        res = three.run(i0, np.zeros((n, 3)), np.zeros((n, 3)))
        for a in range(3):
            outs[a].append({k: np.array(v) for k, v in res[a].items()})
        i0 += n
    return [{k: np.concatenate([o[k] for o in outs[a]]) for k in outs[a][0]} for a in range(3)]


def test_a_constant_temperature_at_the_reference_is_the_block_alone_bit_for_bit():
    """The schedule splits each chunk at its 0.02 s blocks; at the reference temperature it loads the file's
    suspension, so the outputs are the block's without a schedule to the bit (the block's kernel carries its state
    across any piece length)."""
    const = ThermalModel(TemperatureProfile("constant", start_k=T_REF, end_k=T_REF), f0_per_k=-120e-6)
    a = _run(_unit(), 0.6)
    b = _run(_unit(temperature=const, track=True), 0.6, chunk_s=0.13)
    for x, y in zip(a, b):
        for key in ("raw", "correcting", "eliminator", "block_dth", "block_theta_end"):
            np.testing.assert_array_equal(x[key], y[key], err_msg=key)


def _f_lock(model, temp_k, block):
    """Where a tracking PLL should hold each drive at ``temp_k``: the coupled dither modes of the three suspensions
    at that temperature on the block with its isolators at that temperature."""
    sus = [model.suspension_at(SuspensionParams(f0_hz=f), temp_k) for f in F0]
    a_m = ChannelConfig(suspension=SuspensionParams(f0_hz=F0[0])).drive.amplitude_rad
    return coupled_dither_frequencies(model.block_at(block, temp_k),
                                      [2 * math.pi * s.resonance_hz(a_m) for s in sus])


@pytest.mark.parametrize("isolators", [False, True])
def test_the_tracking_pll_locks_each_drive_to_its_coupled_mode(isolators):
    """After the step each drive sits on its coupled mode at the new temperature, the isolators' stiffness (-8000
    ppm/K: a damped elastomer softening on warming) included, to the rounding of the same function: the engine
    asks the coupled model, not the rigid fixture's resonance (which lies ``sqrt(1 + J_g / J_b)`` lower, about
    0.8 % or 3 Hz here)."""
    import dataclasses

    model = dataclasses.replace(STEP, isolator_stiffness_per_k=-8000e-6 if isolators else 0.0)
    unit = _unit(temperature=model, track=True)
    _run(unit, 0.4)
    want = _f_lock(model, T_REF + 10.0, BLOCK)
    got = np.array([ch.drive_hz for ch in unit.chains])
    np.testing.assert_allclose(got, want, rtol=1e-12)
    rigid = np.array([model.suspension_at(SuspensionParams(f0_hz=f), T_REF + 10.0).resonance_hz(
        unit.chains[0].cfg.drive.amplitude_rad) for f in F0])
    assert np.all(got - rigid > 1.0)  # the coupled modes, well clear of the rigid resonances
    if isolators:  # softer isolators: the block yields more, the coupled modes move (a real, if small, shift)
        assert not np.allclose(want, _f_lock(STEP, T_REF + 10.0, BLOCK), rtol=1e-9, atol=0.0)


def _deflection_per_volt(temp_k, axis, f_hz):
    """``|delta_i / (k5 V_i)|`` of the linearised coupled system (block, isolators, three suspensions at
    ``temp_k``) driven on ``axis`` at ``f_hz``: the frequency-domain steady state of
    ``models.block.dither_voltage_factor``, the suspension's hysteretic loss as the equivalent viscous damping
    ``zeta = 1 / (2 Q)`` at the amplitude."""
    from sins_sim.models.block import _matrices9

    a_m = ChannelConfig(suspension=SuspensionParams(f0_hz=F0[0])).drive.amplitude_rad
    sus = [STEP.suspension_at(SuspensionParams(f0_hz=f), temp_k) for f in F0]
    om = np.array([2 * math.pi * s.resonance_hz(a_m) for s in sus])
    m9, k9 = _matrices9(BLOCK, om)
    c9 = np.zeros((9, 9))
    c9[:6, :6] = BLOCK.damping_matrix()
    jg = BLOCK.gyro_inertia_kg_m2
    for j, s in enumerate(sus):
        c9[6 + j, 6 + j] = jg[j] * om[j] / s.q_factor(a_m)
    w = 2 * math.pi * f_hz
    drive = np.zeros(9, complex)
    drive[6 + axis] = jg[axis] * om[axis] ** 2
    return abs(np.linalg.solve(k9 - w * w * m9 + 1j * w * c9, drive)[6 + axis])


def test_tracking_holds_the_drive_voltage_through_the_step():
    """Closed loop, the amplitude is held; the voltage it takes tells where the drive is. Tracking the coupled mode
    keeps the voltage at its on-resonance value; a drive left at the t = 0 coupled mode after the 0.46 Hz step needs
    more, by the ratio of the coupled system's deflection per volt at the two points (``_deflection_per_volt``, a
    linear frequency-domain solve independent of the engine): 1.08 here, where the suspension alone
    (``Q sqrt((1 - r^2)^2 + (r / Q)^2)``) would say 1.10, the isolators' dampers lowering the coupled mode's Q.
    The tolerance, 1 %: the linear model takes the suspension's hysteretic loss and amplitude-dependent stiffness
    (eq. 9, 10) as a viscous damper and a spring at the amplitude, exact in the loss per cycle at resonance only;
    1 % is an eighth of the 8 % effect, so a drive on the coupled mode is told from one off it (0.2 % found).
    The amplitude loop holds each amplitude to 5e-4 (checked), which the voltage carries one to one."""
    base = _unit()
    _run(base, 1.5)
    tracked = _unit(temperature=STEP, track=True)
    _run(tracked, 1.5)
    fixed = _unit(temperature=STEP, track=False)
    _run(fixed, 1.5)
    for a in range(3):
        v0, vt, vf = base.chains[a].v_m, tracked.chains[a].v_m, fixed.chains[a].v_m
        for u in (base, tracked, fixed):
            assert abs(u.chains[a].amp_meas / u.chains[a].cfg.drive.amplitude_rad - 1.0) < 5e-4
        assert abs(vt / v0 - 1.0) < 0.01, (a, vt / v0)
        f_c0 = fixed.chains[a].drive_hz  # untracked: the t = 0 coupled mode
        want = _deflection_per_volt(T_REF, a, f_c0) / _deflection_per_volt(T_REF + 10.0, a, f_c0)
        assert want > 1.05  # the step moved the mode by a good part of its half-bandwidth
        assert abs((vf / v0) / want - 1.0) < 0.01, (a, vf / v0, want)


def test_the_online_estimator_runs_on_the_block():
    """Three estimators, each fed its axis's readout and drive piece by piece on the block's stepper: one update per
    ``update_s`` on each, every value finite, and the filters loaded with what was fed."""
    ds = {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}
    spec = OnlineSpec(update_s=0.1, datasheet=ds)
    control = DriveControl(loop_time_s=0.05, modulation_depth=0.05)
    chans = tuple(ChannelConfig(suspension=SuspensionParams(f0_hz=f), online=spec) for f in F0)
    unit = SensorUnit(ImuConfig(channels=chans, drive_control=control, block=BLOCK), seed=4)
    outs = _run(unit, 1.0, chunk_s=0.27)
    for a, ch in enumerate(unit.chains):
        hist = ch.online.history
        assert [round(h["t_s"], 9) for h in hist] == [round(0.1 * (k + 1), 9) for k in range(10)]
        assert all(math.isfinite(x) for h in hist for x in h["fed"].values())
        assert ch.filters["correcting"].design.f0_hz == hist[-1]["fed"]["f0_hz"]
        assert np.all(np.isfinite(outs[a]["correcting"]))


def test_isolator_coefficients_scale_stiffness_and_damping():
    """``block_at``: the isolators' stiffness times ``1 + c_k dT`` and damping times ``1 + c_c dT`` (the linear
    model's definition), the rest of the block unchanged; a model without them gives the block itself."""
    model = ThermalModel(TemperatureProfile(), reference_k=T_REF, isolator_stiffness_per_k=-5e-3,
                         isolator_damping_per_k=2e-3)
    hot = model.block_at(BLOCK, T_REF + 20.0)
    np.testing.assert_allclose(hot.stiffness_matrix(), BLOCK.stiffness_matrix() * 0.9, rtol=1e-15)
    np.testing.assert_allclose(hot.damping_matrix(), BLOCK.damping_matrix() * 1.04, rtol=1e-15)
    assert np.array_equal(hot.inertia_kg_m2, BLOCK.inertia_kg_m2) and hot.mass_kg == BLOCK.mass_kg
    assert ThermalModel().block_at(BLOCK, 400.0) is BLOCK


def _doc(**kw):
    imu = load_yaml(ROOT / "configs" / "isolated-block.yaml")
    doc = {"name": "t", "duration_s": 2.0, "imu": imu, "navigation": {"start_s": 1.0}}
    doc.update(kw)
    return doc


def test_isolator_coefficients_without_a_block_are_refused_naming_both_keys():
    doc = _doc(temperature={"profile": "constant", "initial_k": 293.15, "f0_ppm_per_k": -30.0,
                            "isolators": {"stiffness_ppm_per_k": -5000.0}})
    doc["imu"].pop("block")
    with pytest.raises(ConfigError, match=r"temperature\.isolators.*imu\.block"):
        load_scenario(doc)


def test_a_block_with_an_engine_effect_is_refused_at_load_naming_both_keys():
    doc = _doc()
    doc["imu"]["effects"] = [{"name": "viscous_damping", "zeta": 1e-4}, {"name": "piezo_lag", "tau_s": 1e-4}]
    with pytest.raises(ConfigError, match=r"imu\.effects\[1\] \(piezo_lag\) with imu\.block"):
        load_scenario(doc)
    doc["imu"]["effects"] = [{"name": "viscous_damping", "zeta": 1e-4}]  # the suspension's own: composes
    load_scenario(doc)


def test_the_isolator_coefficients_keep_the_linear_model_in_range():
    doc = _doc(temperature={"profile": "step", "initial_k": 293.15, "step_k": 100.0, "start_s": 0.5,
                            "f0_ppm_per_k": -30.0, "isolators": {"stiffness_ppm_per_k": -8000.0}})
    with pytest.raises(ConfigError, match=r"temperature\.isolators\.stiffness_ppm_per_k"):
        load_scenario(doc)


def test_online_estimation_on_a_block_warns_at_load_naming_both_keys():
    """The estimator learns the coupled system (docs/user-guide/combinations.md): loading says so, naming both keys,
    with each axis's counter-rotation at its drive; a rigid unit gets no such line."""
    doc = _doc(filter_parameters={"source": "online"})
    doc["imu"]["drive"]["modulation_depth"] = 0.05
    sc = load_scenario(doc)
    lines = [m for m in sc.advisories if "filter_parameters.source: online with imu.block" in m]
    assert len(lines) == 1 and "arcsec" in lines[0]
    doc["imu"].pop("block")
    assert not any("imu.block" in m for m in load_scenario(doc).advisories)
