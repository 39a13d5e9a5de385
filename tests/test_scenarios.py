"""YAML validation (IMU and scenario files) and reproducibility of scenario runs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from sins_sim.cli import main
from sins_sim.config.imu import imu_from_dict, load_imu
from sins_sim.config.scenario import load_scenario
from sins_sim.config.errors import ConfigError
from sins_sim.jobs.run import run_scenario

ROOT = Path(__file__).resolve().parents[1]
GOOD_CHANNELS = {"x": {"f0_hz": 386}, "y": {"f0_hz": 352}, "z": {"f0_hz": 421}}


@pytest.mark.parametrize("path", sorted((ROOT / "configs").glob("*.yaml")))
def test_bundled_imu_configs_load(path):
    imu = load_imu(path)
    f0 = [c.suspension.f0_hz for c in imu.channels]
    assert len(set(f0)) == 3 and all(300.0 <= f <= 450.0 for f in f0)


@pytest.mark.parametrize("path", sorted(p for p in (ROOT / "scenarios").glob("*.yaml") if not p.name.startswith("sweep-")))
def test_bundled_scenarios_validate(path):
    sc = load_scenario(path)
    assert sc.duration_s > sc.nav.start_s


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("sweep-*.yaml")))
def test_bundled_sweeps_validate(path):
    from sins_sim.config.sweep import load_sweep

    sw = load_sweep(path)
    assert sw.units >= 1


@pytest.mark.parametrize(
    "doc, match",
    [
        ({"channels": {"x": {"f0_hz": 386}, "y": {"f0_hz": 352}}}, r"channels\.z: is required"),
        ({"channels": {**GOOD_CHANNELS, "z": {"f0_hz": -1}}}, r"channels\.z\.f0_hz: must be >= 20"),
        ({"channels": GOOD_CHANNELS, "readout": {"quantum": 0.1}}, r"readout\.quantum: needs a unit: write quantum_arcsec"),
        ({"channels": GOOD_CHANNELS, "readout": {"quantum_arcmin": 0.1}}, r"unknown unit in 'quantum_arcmin'"),
        ({"channels": GOOD_CHANNELS, "readuot": {}}, r"readuot: unknown key"),
        ({"channels": GOOD_CHANNELS, "suspension": {"k2_rad": "big"}}, r"suspension\.k2_rad: must be a number"),
        ({"channels": GOOD_CHANNELS, "suspension": {"k2_rad": 0}}, r"suspension\.k2_rad: must be >= 1e-06"),
        ({"channels": GOOD_CHANNELS, "suspension": {"k5_rad_per_v": 0}}, r"k5_rad_per_v: must be != 0"),
        ({"channels": GOOD_CHANNELS, "readout": {"output_rate_hz": 7000}}, r"readout\.output_rate_hz: plant\.rate_hz / output_rate_hz must be a whole number"),
        ({"channels": GOOD_CHANNELS, "readout": {"output_rate_hz": 720}}, r"output_rate_hz: the filter rate must be > 2 x f0"),
        ({"channels": {**GOOD_CHANNELS, "y": {"f0_hz": 386}}}, r"resonances must differ"),
        ({"channels": GOOD_CHANNELS, "drive": {"control": "pid"}}, r"drive\.control: must be one of"),
        ({"channels": GOOD_CHANNELS, "suspension": {"k4_per_rad": -5000}}, r"suspension\.k4_per_rad: must be >= -20"),
        ({"channels": GOOD_CHANNELS, "suspension": {"k3": 0.15, "k4_per_rad": 200}},
         r"suspension \(shared, with channels\.x\.f0_hz\): suspension\.k3: the loss 1/Q = k3 \(1 \+ k4 a\) \+ 2 zeta "
         r"must stay < 1"),
    ],
)
def test_imu_validation_errors_name_key_and_rule(doc, match):
    with pytest.raises(ConfigError, match=match) as info:
        imu_from_dict(doc, "imu.yaml")
    assert str(info.value).startswith("imu.yaml: ")


def _write(tmp_path, doc, name="s.yaml"):
    (tmp_path / "imu.yaml").write_text((ROOT / "configs" / "default-imu.yaml").read_text())
    p = tmp_path / name
    p.write_text(yaml.safe_dump(doc) if isinstance(doc, dict) else doc)
    return p


BASE = {"name": "t", "duration_s": 1.3, "imu": "imu.yaml", "motion": [{"type": "static"}],
        "navigation": {"start_s": 1.0}}


@pytest.mark.parametrize(
    "change, match",
    [
        ({"duration": 2}, r"duration: needs a unit: write duration_s"),
        ({"duration_s": -1}, r"duration_s: must be > 0"),
        ({"motion": [{"type": "wobble"}]}, r"motion\[0\]\.type: must be one of"),
        ({"motion": [{"type": "coning", "amplitude_arcmin": 1}]}, r"motion\[0\]\.frequency_hz: is required"),
        ({"motion": [{"type": "coning", "amplitude_arcmin": 1, "frequency_hz": 100, "spin": 1}]},
         r"motion\[0\]\.spin: unknown key"),
        ({"motion": [{"type": "sines", "amplitude_arcmin": [1, 1], "frequency_hz": [1, 1, 1]}]},
         r"motion\[0\]\.amplitude_arcmin: must be a list of 3 numbers"),
        ({"motion": []}, r"motion: must have at least 1 item"),
        ({"filters": ["raw", "kalman"]}, r"filters\[1\]: must be one of"),
        ({"navigation": {"start_s": 5.0}}, r"navigation\.start_s: must be < duration_s"),
        ({"navigation": {"coning": "magic"}}, r"navigation\.coning: must be one of"),
        ({"imu": "missing.yaml"}, r"imu: file not found"),
        ({"imu": 3}, r"imu: must be a path"),
        ({"seed": 1.5}, r"seed: must be an integer"),
    ],
)
def test_scenario_validation_errors(tmp_path, change, match):
    doc = {**BASE, **change}
    if "duration" in change:  # the key without its unit replaces the good one
        doc.pop("duration_s")
    p = _write(tmp_path, doc)
    with pytest.raises(ConfigError, match=match) as info:
        load_scenario(p)
    assert str(p) in str(info.value)


def test_malformed_yaml_names_file_and_line(tmp_path):
    p = _write(tmp_path, "name: t\nmotion: [ {type: static\n")
    with pytest.raises(ConfigError, match=r"s\.yaml: line \d+, column \d+: malformed YAML"):
        load_scenario(p)


def test_cli_reports_config_errors_in_one_line(tmp_path, capsys):
    p = _write(tmp_path, {**BASE, "duration_s": -1})
    assert main(["run", str(p), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sins-sim: error: ") and "duration_s: must be > 0" in err[0]


def test_run_is_reproducible_from_yaml_and_seed(tmp_path):
    doc = {**BASE, "duration_s": 1.25, "seed": 4,
           "motion": [{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 200.0}],
           "outputs": {"plots": False}}
    p = _write(tmp_path, doc)
    m1 = run_scenario(p, tmp_path / "a")
    m2 = run_scenario(p, tmp_path / "b")
    assert m1["filters"] == m2["filters"]
    a = np.load(tmp_path / "a" / "timeseries.npz")
    b = np.load(tmp_path / "b" / "timeseries.npz")
    for key in a.files:
        np.testing.assert_array_equal(a[key], b[key])
    saved = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert set(saved["filters"]) == {"ideal", "eliminator", "correcting", "correcting_paper"}  # the default list
    for name in saved["filters"]:
        m = saved["filters"][name]
        assert m["status"] == "ok"
        assert set(m["attitude_error_arcsec"]["final"]) == {"north", "east", "down"}
        assert np.isfinite(m["horizontal_position_error_m"]["final"])
        assert m["horizontal_position_error_m"]["max"] >= m["horizontal_position_error_m"]["final"]
