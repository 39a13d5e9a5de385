"""External increments: ``sins-sim navigate`` and :func:`sins_sim.jobs.navigate.navigate_increments`.

The increments an ideal IMU riding the project's own truth outputs (:func:`ideal_increments`, Gauss-Legendre
integrals of the truth's rate and specific force) navigate to the numerical floor, and a gyro bias put into
them comes out in the same metrics as a run's: the gyro drift per body axis and the attitude drift per NED axis.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sins_sim.cli import main
from sins_sim.io import read_trajectory
from sins_sim.jobs.navigate import INCREMENT_COLUMNS, navigate_increments, read_increments, write_increments
from sins_sim.config.errors import ConfigError
from sins_sim.models.motion import SampledTrajectory, Stationary, Trajectory
from sins_sim.simulation.external import ideal_increments, uniform_period
from sins_sim.units import DEG_PER_H

ROOT = Path(__file__).resolve().parents[1]
FLIGHT = ROOT / "scenarios" / "trajectories" / "short-flight.csv"


@pytest.fixture(scope="module")
def flight():
    return SampledTrajectory.from_data(read_trajectory(FLIGHT))


def test_ideal_increments_of_the_flight_navigate_to_the_floor(flight):
    """The bundled flight (turns, a climb, an acceleration) at 200 Hz for 288 s, ideal increments.

    Bounds: the floor the engine's ideal sensors reach along a flight (tests/test_ins_loop.py, measured 0.018 m,
    1.0e-4 m/s, 3e-4 arcsec at most, set by the accelerometer pulses): external increments must navigate at least
    as well as a run's ideal filter. Measured here 1.8e-4 m, 7.7e-6 m/s, 7e-6 arcsec RMS (unquantised
    increments; at 200 Hz the two-sample coning/sculling residuals of the turns dominate: 7e-6 m at 1 kHz).
    """
    t = 2.0 + np.arange(1, 288 * 200 + 1) / 200.0
    dth, dv = ideal_increments(flight, t)
    m = navigate_increments(t, dth, dv, flight)["filters"]["external"]
    assert m["status"] == "ok"
    assert m["horizontal_position_error_m"]["max"] < 0.018
    assert m["velocity_error_m_s"]["max"] < 1e-4
    assert max(m["attitude_error_arcsec"]["rms"].values()) < 3e-4
    for ax in "xyz":  # an ideal record has no gyro drift
        assert m["gyro_drift_deg_h"][ax]["status"] != "drift"


def test_ideal_increments_are_the_integrals_of_a_constant_rate():
    """At rest on the Earth: dtheta = Omega_ie^b dt, dv = -g^b dt (closed form, to rounding)."""
    lat = 0.7
    truth = Trajectory(lat, 0.2, 100.0, 0.0, 0.0, [Stationary(10.0)])
    t = 0.01 * np.arange(1, 101)
    dth, dv = ideal_increments(truth, t)
    from sins_sim import earth

    w = earth.earth_rate_ned(lat)  # body = NED (level, heading north)
    g = earth.gravity_ned(lat, 100.0)
    assert np.allclose(dth, w * 0.01, rtol=0, atol=1e-18)
    assert np.allclose(dv, -g * 0.01, rtol=1e-12, atol=0)


@pytest.fixture(scope="module")
def at_rest():
    truth = Trajectory(0.7, 0.2, 100.0, 0.0, 0.0, [Stationary(600.0)])
    t = 0.01 * np.arange(1, 60001)
    return truth, t, *ideal_increments(truth, t)


def test_a_gyro_bias_shows_as_gyro_and_attitude_drift(at_rest):
    """0.01 deg/h on x (level, heading north: body x = north) over 600 s at rest.

    The gyro-angle error record is the bias times time exactly, so its ramp is 0.01 deg/h to rounding
    (1e-9 relative). The attitude drift from psi (its Earth-rate coupling removed) is the bias on the north
    axis: measured 0.0099999999 deg/h, bound 1e-6 relative; the other axes show none.
    """
    truth, t, dth, dv = at_rest
    bias = 0.01 * DEG_PER_H
    biased = dth.copy()
    biased[:, 0] += bias * 0.01
    m = navigate_increments(t, biased, dv, truth)["filters"]["external"]
    gx = m["gyro_drift_deg_h"]["x"]
    assert gx["status"] == "drift" and gx["value"] == pytest.approx(0.01, rel=1e-9)
    assert m["gyro_drift_deg_h"]["y"]["status"] != "drift" and m["gyro_drift_deg_h"]["z"]["status"] != "drift"
    north = m["attitude_drift_deg_h"]["north"]
    assert north["status"] == "drift" and north["value"] == pytest.approx(0.01, rel=1e-6)
    assert m["attitude_drift_deg_h"]["east"]["status"] != "drift"
    # and without the bias: no drift anywhere, errors at the floor
    ideal = navigate_increments(t, dth, dv, truth)["filters"]["external"]
    assert all(ideal["gyro_drift_deg_h"][ax]["status"] != "drift" for ax in "xyz")
    assert all(ideal["attitude_drift_deg_h"][ax]["status"] != "drift" for ax in ("north", "east", "down"))
    assert ideal["horizontal_position_error_m"]["max"] < 1e-6
    # the tilt a north-axis drift builds: phi_N = eps t, so the east position error is g eps t^3 / 6 for t much
    # shorter than the Schuler period (600 s of 5064 s: the series' next term, -(w_s t)^2 / 20, is 1.1 %)
    expected = 9.80 * bias * 600.0 ** 3 / 6.0
    assert abs(m["horizontal_position_error_m"]["final_east"]) == pytest.approx(expected, rel=0.03)


def test_cli_navigate_writes_the_metrics_of_the_api(tmp_path, flight, capsys):
    t = 2.0 + np.arange(1, 60 * 100 + 1) / 100.0
    dth, dv = ideal_increments(flight, t)
    dth[:, 2] += 0.05 * DEG_PER_H * 0.01
    path = tmp_path / "inc.csv"
    write_increments(path, t, dth, dv)
    t2, dth2, dv2 = read_increments(path)
    np.testing.assert_array_equal(t2, t)  # %.17g round-trips float64
    np.testing.assert_array_equal(dth2, dth)
    assert main(["navigate", str(path), "--truth", str(FLIGHT), "--out", str(tmp_path / "nav")]) == 0
    out = capsys.readouterr().out
    assert "gyro drift x,y,z [deg/h]" in out and "wrote" in out
    written = json.loads((tmp_path / "nav" / "metrics.json").read_text())
    api = navigate_increments(t, dth, dv, flight)
    assert written["filters"]["external"]["gyro_drift_deg_h"]["z"]["value"] == pytest.approx(0.05, rel=1e-6)
    assert (written["filters"]["external"]["horizontal_position_error_m"]
            == pytest.approx(api["filters"]["external"]["horizontal_position_error_m"]))
    assert written["navigation"]["rate_hz"] == pytest.approx(100.0)
    manifest = json.loads((tmp_path / "nav" / "manifest.json").read_text())  # the folder says what produced it
    assert manifest["command"] == "navigate" and set(manifest["inputs"]) >= {"increments", "truth"}
    pq = tmp_path / "inc.parquet"
    write_increments(pq, t, dth, dv)
    assert np.array_equal(read_increments(pq)[1], dth)


@pytest.mark.parametrize("edit,message", [
    (lambda df: df.drop(columns=["dv_z_m_s"]), r"inc\.csv: column dv_z_m_s: missing; the file needs time_s"),
    (lambda df: df.assign(extra=1.0), r"inc\.csv: column extra: unknown \(allowed: time_s"),
    (lambda df: df.assign(dtheta_x_rad=["x"] + [0.0] * (len(df) - 1)), r"dtheta_x_rad: row 1 is not a finite number"),
])
def test_bad_increment_files_are_one_line(tmp_path, edit, message):
    import pandas as pd

    df = pd.DataFrame(np.column_stack([0.01 * np.arange(1, 11), np.zeros((10, 6))]), columns=list(INCREMENT_COLUMNS))
    path = tmp_path / "inc.csv"
    edit(df).to_csv(path, index=False)
    with pytest.raises(ConfigError, match=message):
        read_increments(path)


def test_uneven_or_out_of_range_times_are_refused(tmp_path, capsys):
    with pytest.raises(ValueError, match=r"t_s: must be uniformly sampled"):
        uniform_period([0.0, 0.01, 0.02, 0.035], "t_s")
    path = tmp_path / "inc.csv"
    t = 1000.0 + 0.01 * np.arange(1, 11)  # past the flight's 300 s
    write_increments(path, t, np.zeros((10, 3)), np.zeros((10, 3)))
    assert main(["navigate", str(path), "--truth", str(FLIGHT), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "after the truth's end (300 s)" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_navigate_is_offered_by_completion(capsys):
    assert main(["completion", "bash"]) == 0
    assert "navigate)" in capsys.readouterr().out
