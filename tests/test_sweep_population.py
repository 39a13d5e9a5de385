"""Sweep populations that would draw nothing, and population errors that name the sweep key the user wrote
(issue 25, items 4 and 11).

Everything here is checked before a task starts (``prepare_sweep``, or ``sins-sim sweep`` refusing with exit 2 and
one line); nothing is simulated.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from sins_sim.cli import main
from sins_sim.config.errors import ConfigError
from sins_sim.jobs.sweep.job import prepare_sweep
from sins_sim.jobs.sweep.population import SENSOR_SIGMA_KEYS

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"
NAV_GRADE = ROOT / "configs" / "nav-grade-rlg.yaml"


def _sweep(tmp_path, population, units=3, name="pop") -> Path:
    doc = {"name": name, "seed": 3, "units": units,
           "scenarios": [{"path": str(SCEN / "stationary.yaml"), "duration_s": 1.5}], "population": population}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def _refused(tmp_path, capsys, population, units=3) -> str:
    """The one line ``sins-sim sweep`` prints for a refused sweep (nothing written)."""
    p = _sweep(tmp_path, population, units)
    out = tmp_path / "out"
    assert main(["sweep", str(p), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sins-sim: error: ") and "\n" not in err and "Traceback" not in err, err
    assert not out.exists()
    return err


# --- item 4: draws that would draw nothing ---------------------------------------------------------------------
def test_sensor_draw_over_an_imu_without_sensors_is_refused(tmp_path, capsys):
    # scenarios/stationary.yaml flies configs/default-imu.yaml, which has no sensors: block
    assert "sensors" not in yaml.safe_load((ROOT / "configs" / "default-imu.yaml").read_text())
    err = _refused(tmp_path, capsys, {"sensors": {"draw": True}})
    assert "population.sensors.draw: true would draw nothing for scenarios[0] (stationary)" in err
    assert "default-imu.yaml has no sensors: block" in err and "population.sensors.preset" in err


def test_sensor_draw_over_a_preset_without_a_sigma_value_is_refused(tmp_path, capsys):
    # a sensors block with noise densities only (they are not drawn per unit) and zero 1-sigma values
    preset = tmp_path / "noise-only.yaml"
    preset.write_text(yaml.safe_dump({"sensors": {"gyro": {"arw_deg_rt_h": 0.002, "bias_deg_h": 0.0},
                                                  "accelerometer": {"vrw_ug_rt_hz": 20.0}}}))
    err = _refused(tmp_path, capsys, {"sensors": {"draw": True, "preset": str(preset)}})
    assert "population.sensors.draw: true would draw nothing" in err and "noise-only.yaml" in err
    assert "has no non-zero 1-sigma value (gyro.bias_deg_h" in err


def test_sensor_draw_over_a_preset_with_sigmas_draws_every_unit(tmp_path):
    """The accepted case draws: each unit's gyro bias is the preset's 1 sigma times its own score, and the table's
    column ``param.gyro.bias_deg_h.<axis>`` holds that value in deg/h (issue 40, item 9: it held the score)."""
    from sins_sim.jobs.sweep.population import draw_unit

    preset = yaml.safe_load(NAV_GRADE.read_text())["sensors"]
    assert any(preset["gyro"].get(k) for k in SENSOR_SIGMA_KEYS["gyro"])
    sweep, tasks, _ = prepare_sweep(_sweep(tmp_path, {"sensors": {"draw": True, "preset": str(NAV_GRADE)}}))
    sigma = float(preset["gyro"]["bias_deg_h"])
    for t in tasks:
        drawn = t.doc["imu"]["sensors"]["gyro"]["bias_deg_h"]
        score = draw_unit(sweep, t.unit)
        assert drawn == [sigma * score[f"gyro.bias_deg_h.{ax}"] for ax in "xyz"] and all(drawn)
        assert [t.params[f"gyro.bias_deg_h.{ax}"] for ax in "xyz"] == drawn


@pytest.mark.parametrize("population, key", [
    ({"temperature_k": {"width": 20}}, "population.temperature_k: draws nothing without "
                                       "population.temperature_coefficient_ppm_per_k"),
    ({"temperature_coefficient_ppm_per_k": {"mean": -30}}, "population.temperature_coefficient_ppm_per_k: draws "
                                                           "nothing without population.temperature_k"),
    ({"f0_ppm": {}}, "population.f0_ppm: mean 0 and width 0 draw nothing"),
    ({"k3_percent": {"distribution": "uniform"}}, "population.k3_percent: mean 0 and width 0 draw nothing"),
])
def test_other_draws_that_would_draw_nothing_are_refused(tmp_path, capsys, population, key):
    assert key in _refused(tmp_path, capsys, population)


def test_a_grid_of_zero_is_a_choice_not_an_empty_draw(tmp_path):
    """A grid names its values: [0] is the file's value on purpose (a control group), accepted."""
    _, tasks, _ = prepare_sweep(_sweep(tmp_path, {"k3_percent": {"distribution": "grid", "values": [0]}}))
    assert [t.params["k3_percent.x"] for t in tasks] == [0.0] * 3


# --- item 11: errors name the sweep key --------------------------------------------------------------------------
def test_a_mean_the_imu_refuses_names_population_key_mean(tmp_path, capsys):
    err = _refused(tmp_path, capsys, {"k5_percent": {"mean": -100}})
    assert "population.k5_percent.mean: -100 gives unit 0 an IMU the IMU schema refuses" in err
    assert "default-imu.yaml: channels.x.suspension.k5_rad_per_v: must be != 0" in err


def test_a_width_that_draws_out_of_range_names_population_key_width(tmp_path, capsys):
    # k3 >= 0 (IMU schema): a normal spread of 100 % sends a unit below -100 % within a few units
    err = _refused(tmp_path, capsys, {"k3_percent": {"width": 100}}, units=40)
    assert "population.k3_percent.width: 100 draws k3_percent.x " in err
    assert "suspension.k3: must be >= 0" in err


def test_the_named_unit_and_draws_are_the_first_refused_ones(tmp_path):
    """Independent check of the width message: the named unit is the first whose drawn k3 goes below -100 %."""
    from sins_sim.config.sweep import load_sweep
    from sins_sim.jobs.sweep.population import draw_unit

    p = _sweep(tmp_path, {"k3_percent": {"width": 100}}, units=40)
    with pytest.raises(ConfigError) as exc:
        prepare_sweep(p)
    sweep = load_sweep(p)
    first = next(i for i in range(40) if min(draw_unit(sweep, i)[f"k3_percent.{a}"] for a in "xyz") < -100.0)
    assert f" for unit {first}, " in str(exc.value)


def test_keys_refused_only_together_are_named_together(tmp_path, capsys):
    """An IMU at 25-35 Hz: f0_hz -4 Hz alone gives 21 Hz and the temperature pair alone -10 % (22.5 Hz), both inside
    the IMU's [20, 5000] Hz; together 21 x 0.9 = 18.9 Hz is refused, and no single key is to blame."""
    scen = tmp_path / "low.yaml"
    scen.write_text(yaml.safe_dump({"name": "low", "seed": 1, "duration_s": 1.5, "motion": [{"type": "static"}],
                                    "imu": {"channels": {"x": {"f0_hz": 25}, "y": {"f0_hz": 30}, "z": {"f0_hz": 35}}},
                                    "navigation": {"start_s": 1.0}}))
    doc = {"name": "combo", "seed": 1, "units": 1, "scenarios": [{"path": str(scen)}],
           "population": {"f0_hz": {"distribution": "grid", "values": [-4]},
                          "temperature_k": {"distribution": "grid", "values": [-100]},
                          "temperature_coefficient_ppm_per_k": {"distribution": "grid", "values": [1000]}}}
    p = tmp_path / "combo.yaml"
    p.write_text(yaml.safe_dump(doc))
    assert main(["sweep", str(p), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    # the keys in the order of ``sins-sim schema sweep`` (SPREAD_PARAMETERS)
    assert "population: f0_hz, temperature_coefficient_ppm_per_k, temperature_k together gives unit 0" in err
    assert f"channels.x.f0_hz: must be >= 20, got {(25 - 4) * (1 + 1e-6 * 1000 * -100)!r}" in err
