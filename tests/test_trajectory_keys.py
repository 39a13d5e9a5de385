"""Keys beside a trajectory file (issue 25, item 2): `trajectory: {file: ..., segments: [...]}` flew the file and
dropped the segments (and `speed_m_s`, and `site`) without a word, and metrics.json reported the default site."""

import math
from pathlib import Path

import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
FILE = ROOT / "scenarios" / "trajectories" / "short-flight.csv"
IMU = {"channels": {"x": {"f0_hz": 386}, "y": {"f0_hz": 352}, "z": {"f0_hz": 421}}}


def _doc(**extra):
    doc = {"name": "f", "imu": IMU, "duration_s": 10.0, "trajectory": {"file": str(FILE)}}
    for k, v in extra.items():
        if k in ("segments", "speed_m_s", "transition_s"):
            doc["trajectory"][k] = v
        else:
            doc[k] = v
    return doc


@pytest.mark.parametrize("extra, key", [
    ({"segments": [{"type": "cruise", "duration_s": 60}]}, "trajectory.segments"),
    ({"speed_m_s": 120.0}, "trajectory.speed_m_s"),
    ({"transition_s": 2.0}, "trajectory.transition_s"),
    ({"site": {"lat_deg": 10.0}}, "site"),
])
def test_keys_that_a_file_would_ignore_are_refused(extra, key):
    with pytest.raises(ConfigError, match=rf"{key}: would be ignored beside trajectory.file"):
        load_scenario(_doc(**extra))


def test_the_site_of_a_file_run_is_the_files_first_row():
    """The file starts at 48.000000 N, 11.500000 E, 1500 m (its first row; scenarios/trajectories): the scenario's
    site, which metrics.json reports and the linear error model uses, is that row, not the default 45 N."""
    sc = load_scenario(_doc())
    assert math.degrees(sc.site["lat_rad"]) == pytest.approx(48.0, abs=1e-9)
    assert math.degrees(sc.site["lon_rad"]) == pytest.approx(11.5, abs=1e-9)
    assert sc.site["height_m"] == pytest.approx(1500.0, abs=1e-6)
