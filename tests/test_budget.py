"""``sins-sim budget`` (issue 11, item 6): sources found, contributions against closed forms, parts add up."""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from sins_sim import earth
from sins_sim.jobs.budget import apply_off, budget_sources, run_budget
from sins_sim.config.scenario import load_scenario

IMU = Path("configs/default-imu.yaml").resolve()
ACCEL_BIAS_UG = 200.0


def _scenario(tmp_path, duration=20.0, extra=""):
    imu = tmp_path / "imu.yaml"
    imu.write_text(IMU.read_text() + f"""
sensors:
  gyro: {{bias_deg_h: [0.0, 0.5, 0.0], arw_deg_rt_h: 0.01}}
  accelerometer: {{bias_ug: [{ACCEL_BIAS_UG}, 0.0, 0.0]}}
""")
    sc = tmp_path / "s.yaml"
    sc.write_text(f"name: budget-test\nimu: imu.yaml\nduration_s: {duration}\nseed: 4\n"
                  "filters: [ideal, correcting]\nnavigation: {start_s: 1.0}\n" + extra)
    return sc


def test_sources_are_found_and_switched_off(tmp_path):
    sc = load_scenario(_scenario(tmp_path))
    src = budget_sources(sc.imu)
    assert src == ["gyro.bias", "gyro.arw", "accel.bias", "readout", "accelerometer_quantization"]
    off = apply_off(sc.imu, ["gyro.bias", "readout"])
    assert off.sensors.gyro.bias_deg_h == (0.0, 0.0, 0.0)
    assert off.sensors.gyro.arw_deg_rt_h == sc.imu.sensors.gyro.arw_deg_rt_h
    assert all(c.readout.quantum_rad == 1e-12 and c.readout.noise_rad == 0.0 for c in off.channels)
    with pytest.raises(ValueError, match="budget.sources: not in this unit"):
        apply_off(sc.imu, ["filter_mismatch"])


def test_budget_against_closed_form_and_parts_add_up(tmp_path):
    """The accelerometer bias's share of the ideal filter's position error is the Schuler closed form
    ``b (1 - cos(w_s t)) / w_s^2`` (Titterton & Weston 2004, sec. 12.3; within 2 %: the height-aided
    vertical channel and the Earth-rate coupling over 19 s change it by far less), and the budget's parts
    add up: floor + dither residual + sources equals the total to within 2 % of the total (the errors are
    small, so they superpose linearly; the remainder measures the departure)."""
    out = tmp_path / "out"
    b = run_budget(_scenario(tmp_path), out, workers=1)
    assert set(b) >= {"total", "sources", "floor", "remainder"}
    assert json.loads((out / "budget.json").read_text())["runs"] == 7
    assert (out / "budget.png").exists() and "## Final horizontal position error" in (out / "report.md").read_text()
    t = 19.0
    ws = float(earth.schuler_rate_rad_s(math.radians(45.0), 0.0))
    expect = ACCEL_BIAS_UG * 1e-6 * 9.80665 * (1 - math.cos(ws * t)) / ws ** 2
    got = b["sources"]["accel.bias"]["ideal"]["horizontal_position_error_m"]
    assert got == pytest.approx(expect, rel=0.02)
    assert b["sources"]["dither_residual"]["ideal"]["horizontal_position_error_m"] == 0.0
    for f in ("ideal", "correcting"):
        tot = b["total"][f]["horizontal_position_error_m"]
        assert b["remainder"][f]["horizontal_position_error_m"] <= 0.02 * tot
        assert b["floor"][f] == b["floor"]["ideal"]


def test_two_workers_give_the_same_budget(tmp_path):
    sc = _scenario(tmp_path, duration=6.0)
    a = run_budget(sc, tmp_path / "a", workers=1)
    b = run_budget(sc, tmp_path / "b", workers=2)
    assert a == b


def test_cli_budget_and_bad_input(tmp_path):
    sc = _scenario(tmp_path, duration=4.0)
    r = subprocess.run([sys.executable, "-m", "sins_sim.cli", "budget", str(sc), "--out", str(tmp_path / "o"),
                        "--quiet", "--workers", "1"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "accel.bias" in r.stdout and (tmp_path / "o" / "budget.json").exists()
    r = subprocess.run([sys.executable, "-m", "sins_sim.cli", "budget", str(tmp_path / "missing.yaml"), "--out",
                        str(tmp_path / "p")], capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1 and "missing.yaml" in r.stderr
    assert not (tmp_path / "p").exists()
