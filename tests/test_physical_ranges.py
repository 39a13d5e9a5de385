"""Issue 12, point 4: physical sanity before any kernel runs.

Each unphysical value of the issue is refused by the model's parameter dataclass (the library is protected)
and, from a YAML file, with the key path; a legal but unusual value draws one warning.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
import yaml

from sins_sim.cli import main
from sins_sim.filters.correcting import CorrectingFilterDesign
from sins_sim.filters.eliminator import EliminatorDesign
from sins_sim.config.imu import imu_from_dict
from sins_sim.config.scenario import load_scenario
from sins_sim.config.errors import ConfigError
from sins_sim.models.drive import DriveParams
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.readout import AntiAliasParams, ReadoutParams
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN

ROOT = Path(__file__).resolve().parents[1]
CHANNELS = {"x": {"f0_hz": 386}, "y": {"f0_hz": 352}, "z": {"f0_hz": 421}}


def _no_warnings():
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("error")
    return ctx


# --- the library: the parameter dataclasses ---------------------------------------------------------------
@pytest.mark.parametrize("cls, kwargs, field", [
    (SuspensionParams, {"k5": 1e-30}, "suspension.k5"),
    (SuspensionParams, {"k5": -1.0}, "suspension.k5"),
    (SuspensionParams, {"f0_hz": 1e-30}, "suspension.f0_hz"),
    (SuspensionParams, {"f0_hz": 1e6}, "suspension.f0_hz"),
    (SuspensionParams, {"k1": 3e-3}, "suspension.k1"),  # >= 2 k2: the spring loses its stiffness
    (SuspensionParams, {"k2": 10.0}, "suspension.k2"),
    (SuspensionParams, {"k3": 5.0}, "suspension.k3"),
    (SuspensionParams, {"k4": 1e9}, "suspension.k4"),
    (SuspensionParams, {"zeta": 2.0}, "suspension.zeta"),
    (DriveParams, {"amplitude_rad": 1e-30 * ARCMIN}, "drive.amplitude_rad"),
    (DriveParams, {"amplitude_rad": 10000 * ARCMIN}, "drive.amplitude_rad"),
    (DriveParams, {"v_m": 1e25}, "drive.v_m"),
    (DriveParams, {"dac_rate_hz": 1e300}, "drive.dac_rate_hz"),
    (PlantSettings, {"rate_hz": 1e300}, "plant.rate_hz"),
    (PlantSettings, {"rate_hz": 10.0}, "plant.rate_hz"),
    (ReadoutParams, {"quantum_rad": 1.0}, "readout.quantum_rad"),
    (ReadoutParams, {"noise_rad": 1.0}, "readout.noise_rad"),
    (ReadoutParams, {"input_rate_hz": 1e300, "output_rate_hz": 7200.0}, "readout.input_rate_hz"),
    (AntiAliasParams, {"numtaps": 100001}, "readout.anti_alias.numtaps"),
    (CorrectingFilterDesign, {"f0_hz": 1e-30}, "correcting.f0_hz"),
    (CorrectingFilterDesign, {"k5": 1.0}, "correcting.k5"),
    (CorrectingFilterDesign, {"fs_hz": 1e300}, "correcting.fs_hz"),
    (EliminatorDesign, {"order": 500}, "eliminator.order"),
    (EliminatorDesign, {"rs_db": 1e4}, "eliminator.rs_db"),
    (EliminatorDesign, {"rp_db": 50.0, "rs_db": 60.0}, "eliminator.rp_db"),
])
def test_unphysical_values_are_refused_naming_the_field(cls, kwargs, field):
    with pytest.raises(ValueError, match=rf"^{field.replace('.', chr(92) + '.')}: "):
        cls(**kwargs)


def test_the_drive_voltage_is_what_a_piezo_stack_takes():
    s = SuspensionParams(k5=-1e-9)  # legal gain, but 3 arcmin at Q = 187 then needs ~4700 V
    with pytest.raises(ValueError, match=r"^suspension\.k5: holding 3 arcmin at Q = 186\.6 takes a drive of 4\.68e\+03 V"):
        DriveParams().resolve(s)
    with pytest.warns(UserWarning, match=r"^drive: 233\.9 V is beyond what most piezo stacks take continuously"):
        DriveParams().resolve(SuspensionParams(k5=-2e-8))
    ctx = _no_warnings()
    try:
        assert DriveParams().resolve(SuspensionParams()).v_m == pytest.approx(0.3898, rel=1e-3)
    finally:
        ctx.__exit__(None, None, None)


def test_q_at_the_amplitude_must_be_a_resonance():
    with pytest.raises(ValueError, match=r"^suspension\.k3: Q = .* must be in \[5, 1e\+06\] .* got 3\.333"):
        DriveParams().resolve(SuspensionParams(k3=0.2, k4=0.0, zeta=0.05))
    with pytest.raises(ValueError, match=r"^suspension\.k3: Q = .* got 8\.209e\+07"):
        DriveParams().resolve(SuspensionParams(k3=1e-8, k4=250.0))


def test_the_loss_stays_a_resonance_at_every_deflection():
    """Found by the property tests: a negative or above-1 loss made eq. 5 run away to NaN within 0.2 s."""
    with pytest.raises(ValueError, match=r"^suspension\.k4: must be in \[-20, 10000\]"):
        SuspensionParams(k3=0.17, k4=-9200.0)
    with pytest.raises(ValueError, match=r"^suspension\.k3: the loss 1/Q = k3 \(1 \+ k4 a\) \+ 2 zeta must stay < 1"):
        SuspensionParams(k3=0.15)
    with pytest.raises(ValueError, match=r"^correcting\.k3: the loss k3 \(1 \+ k4 a\) must stay < 1"):
        CorrectingFilterDesign(k3=0.01, k4=5000.0)


def test_the_plant_must_resolve_the_dither():
    with pytest.raises(ValueError, match=r"^plant\.rate_hz: must be >= 40 x f0 = 15440 Hz"):
        Plant(SuspensionParams(), PlantSettings(rate_hz=14400.0))
    Plant(SuspensionParams(f0_hz=1500.0), PlantSettings(rate_hz=72000.0))  # 48 steps per period: fine


def test_unusual_values_warn_once_in_one_line():
    with pytest.warns(UserWarning, match=r"^suspension\.f0_hz: 60 Hz is outside the usual band"):
        SuspensionParams(f0_hz=60.0)
    with pytest.warns(UserWarning, match=r"^drive\.amplitude: 0\.05 arcmin is outside the usual RLG dither amplitudes"):
        DriveParams(amplitude_rad=0.05 * ARCMIN)
    ctx = _no_warnings()  # the paper's values draw nothing
    try:
        SuspensionParams()
        DriveParams()
    finally:
        ctx.__exit__(None, None, None)


def test_an_unstable_eliminator_design_is_refused(monkeypatch):
    import numpy as np

    from sins_sim.filters import eliminator

    monkeypatch.setattr(eliminator.signal, "ellip", lambda *a, **k: np.array([[1.0, 0, 0, 1.0, -2.5, 1.5]]))
    eliminator._ellip_sos.cache_clear()  # designs are kept per process: design this one anew with the stand-in
    try:
        with pytest.raises(ValueError, match=r"^eliminator\.band_hz: .* is not stable in float64"):
            _ = EliminatorDesign().sos
    finally:
        eliminator._ellip_sos.cache_clear()  # nothing designed with the stand-in outlives the test


# --- the YAML layer: the same rules, named by the key path ------------------------------------------------
@pytest.mark.parametrize("change, match", [
    ({"suspension": {"k5_rad_per_v": 1e-30}},
     r"suspension \(shared, with channels\.x\.f0_hz\): suspension\.k5_rad_per_v: \|k5\| must be in "
     r"\[1e-09, 0\.01\]"),
    ({"channels": {**CHANNELS, "y": {"f0_hz": 352, "suspension": {"k5_rad_per_v": 1e-30}}}},
     r"channels\.y: suspension\.k5_rad_per_v: \|k5\| must be in \[1e-09, 0\.01\]"),
    ({"suspension": {"k5_rad_per_v": 1.0}}, r"suspension\.k5_rad_per_v: must be <= 0\.01"),
    ({"drive": {"amplitude_arcmin": 1e-30}}, r"drive\.amplitude_arcmin: must be >= 0\.01"),
    ({"drive": {"amplitude_arcmin": 10000}}, r"drive\.amplitude_arcmin: must be <= 60"),
    ({"channels": {**CHANNELS, "x": {"f0_hz": 1e-30}}}, r"channels\.x\.f0_hz: must be >= 20"),
    ({"plant": {"rate_hz": 1e300}}, r"plant\.rate_hz: must be <= 1e\+06"),
    ({"plant": {"rate_hz": 14400}, "readout": {"output_rate_hz": 1440, "anti_alias": None}},
     r"channels\.x: plant\.rate_hz: must be >= 40 x f0 = 15440 Hz"),
    ({"suspension": {"k1": 3e-3}}, r"suspension \(shared, with channels\.x\.f0_hz\): suspension\.k1: must be < 2 k2"),
    ({"channels": {**CHANNELS, "z": {"f0_hz": 421, "suspension": {"k1": 3e-3}}}},
     r"channels\.z: suspension\.k1: must be < 2 k2"),
    ({"eliminator": {"width_hz": 5000}}, r"eliminator\.width_hz: must be <= 1000"),
    ({"eliminator": {"width_hz": 800}}, r"channels\.x: eliminator\.width_hz \(the band centred on the dither\): must satisfy 0 < lo < hi"),
])
def test_imu_files_report_the_rules_with_the_key_path(change, match):
    doc = {"channels": CHANNELS, **change}
    with pytest.raises(ConfigError, match=match) as info:
        imu_from_dict(doc, "imu.yaml")
    assert str(info.value).startswith("imu.yaml: ") and "\n" not in str(info.value)


def _scenario(tmp_path, **change):
    doc = {"name": "t", "duration_s": 1.5, "imu": str(ROOT / "configs" / "default-imu.yaml"),
           "navigation": {"start_s": 1.0}, **change}
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


@pytest.mark.parametrize("motion, match", [
    ({"type": "sines", "amplitude_arcmin": [1, 0, 0], "frequency_hz": [5000, 0, 0]},
     r"motion\[0\]\.frequency_hz\[0\]: must be < the filter Nyquist 3600 Hz"),
    ({"type": "coning", "amplitude_arcmin": 1, "frequency_hz": 5000}, r"motion\[0\]\.frequency_hz: must be < the filter Nyquist"),
    ({"type": "shock", "axis": [1, 0, 0], "peak_rate_deg_s": 20, "duration_ms": 0.3, "ring_frequency_hz": 9000,
      "ring_amplitude_deg_s": 10}, r"motion\[0\]\.ring_frequency_hz: must be < the filter Nyquist"),
    ({"type": "constant_rate", "rate_deg_s": [0, 0, 2000]}, r"motion\[0\]\.rate_deg_s\[2\]: must be <= 1000"),
    ({"type": "turn", "axis": [0, 0, 1], "angle_deg": 3600, "duration_s": 1.0},
     r"motion\[0\]\.angle_deg: gives a peak rate of 7200 deg/s"),
    ({"type": "sines", "amplitude_arcmin": [20, 0, 0], "frequency_hz": [2000, 0, 0]},
     r"motion\[0\]\.amplitude_arcmin\[0\]: gives a peak rate of 4189 deg/s"),
])
def test_block_motion_beyond_the_filter_nyquist_or_an_rlg_range_is_refused(tmp_path, motion, match):
    with pytest.raises(ConfigError, match=match):
        load_scenario(_scenario(tmp_path, motion=[motion]))


def test_translational_vibration_beyond_the_filter_nyquist_is_refused(tmp_path):
    lin = {"type": "sines", "amplitude_m_s2": [1, 0, 0], "frequency_hz": [4000, 100, 100]}
    with pytest.raises(ConfigError, match=r"linear_vibration\[0\]\.frequency_hz\[0\]: must be < the filter Nyquist"):
        load_scenario(_scenario(tmp_path, linear_vibration=[lin]))


def test_a_motion_near_the_filter_nyquist_warns(tmp_path):
    motion = [{"type": "sines", "amplitude_arcmin": [0.1, 0, 0], "frequency_hz": [3000, 0, 0]}]
    with pytest.warns(UserWarning, match=r"^motion\[0\]\.frequency_hz\[0\]: 3000 Hz is near the filter Nyquist 3600 Hz"):
        load_scenario(_scenario(tmp_path, motion=motion))
    ctx = _no_warnings()
    try:
        load_scenario(_scenario(tmp_path, motion=[{"type": "coning", "amplitude_arcmin": 1, "frequency_hz": 1500}]))
    finally:
        ctx.__exit__(None, None, None)


# --- the CLI ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, start", [
    (["--motion", "sine", "--motion-hz", "1e6"], "sins-sim: error: --motion-hz: must be < the filter Nyquist 3600 Hz"),
    (["--k5", "1e-30"], "sins-sim: error: --k5: |k5| must be in [1e-09, 0.01] rad/V"),
    (["--dither-arcmin", "1e-30"], "sins-sim: error: --dither-arcmin: must be in [0.01, 60] arcmin"),
    (["--dither-arcmin", "10000"], "sins-sim: error: --dither-arcmin: must be in [0.01, 60] arcmin"),
    (["--f0", "1e-30"], "sins-sim: error: --f0: must be in [20, 5000] Hz"),
    (["--plant-rate", "1e300"], "sins-sim: error: --plant-rate: must be <= 1e+06 Hz"),
    (["--k5=-1e-9"], "sins-sim: error: --k5: holding 3 arcmin at Q = 186.6 takes a drive of 4.68e+03 V"),
])
def test_channel_refuses_unphysical_flags_in_one_line(tmp_path, capsys, args, start):
    out = tmp_path / "ch"
    assert main(["channel", "--out", str(out), "--quiet", *args]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(start), captured.err
    assert not out.exists()


def test_channel_unusual_values_warn_in_one_line_naming_the_flag(tmp_path, capsys):
    assert main(["channel", "--out", str(tmp_path / "ch"), "--quiet", "--duration", "0.2", "--motion", "sine",
                 "--motion-hz", "3000", "--motion-arcmin", "0.01"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert main(["channel", "--out", str(tmp_path / "ch2"), "--quiet", "--duration", "0.2", "--dither-arcmin", "0.05",
                 "--k5=-1e-6"]) == 0
    err2 = capsys.readouterr().err.splitlines()
    assert "warning: --dither-arcmin: 0.05 arcmin is outside the usual RLG dither amplitudes (0.1-30 arcmin)" in err2
    assert "warning: --motion-hz: 3000 Hz is near the filter Nyquist 3600 Hz (above 80% of it the motion is barely " \
           "resolved at the filter rate)" in err
