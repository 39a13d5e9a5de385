"""Missions that start from an alignment (``navigation.alignment``) instead of the true attitude.

Checks:

* the window's accumulation to the navigation rate does not depend on the chunking (the engine feeds it in
  chunks of any size) and equals the block sums;
* the schema refuses an alignment window over which the vehicle moves, and one longer than ``start_s``,
  each with one line naming the key;
* on a still base with the true increments (``ideal``) and known sensor biases, each method's alignment
  inside the engine reaches the closed form of gyrocompassing: heading error ``eps_E / (Omega cos lat)``
  (with the sign of the project's psi convention) and tilt from the accelerometer bias over g, and the
  mission's metrics carry it; the default (``truth``) mission is unchanged.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.simulation.aligning import AlignmentAccumulator, AlignmentSettings, bias_sigmas


def test_the_schema_offers_the_methods_the_navigation_has():
    from sins_sim.config.scenario import ALIGNMENT_METHODS as in_schema
    from sins_sim.navigation.alignment_result import ALIGNMENT_METHODS
    from sins_sim.simulation.aligning import ALIGNERS

    assert in_schema == ALIGNMENT_METHODS and set(ALIGNERS) == set(ALIGNMENT_METHODS) - {"truth"}


def test_accumulator_sums_blocks_whatever_the_chunking():
    rng = np.random.default_rng(3)
    n_sub, n = 7, 7 * 40 + 3  # a partial last block is dropped
    dth, dv = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    whole = AlignmentAccumulator(AlignmentSettings(method="coarse"), n_sub, 0.01)
    whole.add(dth, dv)
    pieces = AlignmentAccumulator(AlignmentSettings(method="coarse"), n_sub, 0.01)
    cuts = np.sort(rng.choice(np.arange(1, n), size=25, replace=False))
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, n]):
        pieces.add(dth[a:b], dv[a:b])
    ref = dth[:280].reshape(40, n_sub, 3).sum(axis=1)
    for acc in (whole, pieces):
        got = np.concatenate(acc._dth)
        assert got.shape == (40, 3)
        # sums of the same 7 numbers in another association: equal to a few ulps of the block's magnitude
        np.testing.assert_allclose(got, ref, rtol=0, atol=8 * np.spacing(np.abs(dth).max() * n_sub))


def test_bias_sigmas_root_sum_square_of_the_model():
    class G:
        bias_deg_h, turn_on_bias_deg_h, bias_instability_deg_h = 0.003, 0.004, 0.0

    class A:
        bias_ug, turn_on_bias_ug, bias_instability_ug = (30.0, 0.0, 0.0), 0.0, (40.0, 0.0, 40.0)

    class S:
        gyro, accelerometer = G, A

    g, a = bias_sigmas(S)
    np.testing.assert_allclose(g, 0.005 * math.pi / 180 / 3600, rtol=1e-12)
    np.testing.assert_allclose(a, np.array([50.0, 0.0, 40.0]) * 9.80665e-6, rtol=1e-12)
    assert np.all(bias_sigmas(None)[0] == 0.0)
    # a misalignment reads gravity (accelerometers) and the Earth rate (gyros) as a bias at rest: x's two angles
    # 3 and 4 arcsec are 5 arcsec, g x 5 arcsec (24 ug); the gyro y's 6 and 8 arcsec are 10 arcsec of the Earth rate
    A.bias_ug, A.bias_instability_ug, A.misalignment_arcsec = 0.0, 0.0, (3.0, 4.0, 0.0, 0.0, 0.0, 0.0)
    G.misalignment_arcsec = (0.0, 0.0, 6.0, 8.0, 0.0, 0.0)
    g, a = bias_sigmas(S)
    arcsec = math.pi / 648000
    np.testing.assert_allclose(a, [9.80665 * 5 * arcsec, 0.0, 0.0], rtol=1e-12, atol=0)
    np.testing.assert_allclose(g[1], math.hypot(0.005 * math.pi / 180 / 3600, 7.292115e-5 * 10 * arcsec), rtol=1e-12)


def _doc(**nav):
    return {"name": "align", "seed": 4, "duration_s": 12.0, "imu": "configs/nav-grade-rlg.yaml",
            "site": {"lat_deg": 56.8, "lon_deg": 7.0, "height_m": 100.0, "heading_deg": 85.0},
            "filters": ["ideal"], "navigation": {"start_s": 8.0, "alignment": {"method": "coarse", "duration_s": 6.0},
                                                  **nav}}


def _repo():
    from pathlib import Path

    return Path(__file__).resolve().parents[1]


def test_window_longer_than_start_refused_in_one_line():
    doc = _doc(start_s=4.0)
    with pytest.raises(ConfigError) as err:
        load_scenario(doc, base_dir=_repo())
    msg = str(err.value)
    assert "\n" not in msg and "navigation.alignment.duration_s" in msg and "start_s >= 7" in msg, msg


def test_window_while_the_vehicle_moves_refused_in_one_line():
    doc = _doc()
    doc["trajectory"] = {"speed_m_s": 10.0, "segments": [{"type": "cruise", "duration_s": 13.0}]}
    with pytest.raises(ConfigError) as err:
        load_scenario(doc, base_dir=_repo())
    msg = str(err.value)
    assert "\n" not in msg and "navigation.alignment" in msg and "at rest" in msg and "10 m/s" in msg, msg


def _still_unit_scenario(method: str, gyro_bias_deg_h, accel_bias_ug, **extra):
    """A unit at rest at 56.8 deg N, heading 85 deg, level; only ``ideal`` (the true increments plus the sensor
    errors); sensor errors: the given biases alone (no noise, scale factor or misalignment), so the alignment's
    error has a closed form."""
    from sins_sim.config.yaml_io import load_yaml

    imu = load_yaml(_repo() / "configs" / "nav-grade-rlg.yaml")
    imu["sensors"] = {"gyro": {"bias_deg_h": list(gyro_bias_deg_h)}, "accelerometer": {"bias_ug": list(accel_bias_ug)}}
    doc = _doc()
    doc["imu"] = imu
    doc["duration_s"] = 64.0
    doc["navigation"] = {"start_s": 61.0, "alignment": {"method": method, "duration_s": 60.0}, **extra}
    return doc


def _closed_form_alignment_error(gyro_bias_deg_h, accel_bias_ug, lat_deg=56.8, heading_deg=85.0):
    """psi (N, E, D) of gyrocompassing and levelling on a still level base, the project's convention
    ``C_nb_est = (I + [psi x]) C_nb_true`` (Titterton & Weston 2004, sec. 10.2; the derivation in the
    alignment theory page): ``psi_N = -acc_E / g``, ``psi_E = acc_N / g``,
    ``psi_D = -eps_E / (Omega cos L) - psi_N tan L``, biases resolved in NED through the heading."""
    from sins_sim import earth
    from sins_sim.units import DEG, DEG_PER_H, MICRO_G

    lat, yaw = lat_deg * DEG, heading_deg * DEG
    c = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    eps = c @ (np.asarray(gyro_bias_deg_h) * DEG_PER_H)
    acc = c @ (np.asarray(accel_bias_ug) * MICRO_G)
    g = float(earth.gravity_down(lat, 100.0))
    psi_n, psi_e = -acc[1] / g, acc[0] / g
    psi_d = -eps[1] / (earth.EARTH_RATE_RAD_S * math.cos(lat)) - psi_n * math.tan(lat)
    return np.array([psi_n, psi_e, psi_d])


def test_coarse_alignment_in_a_mission_reaches_the_closed_form():
    """The engine's alignment of the true increments plus known biases: the error it reports against the true
    attitude equals the closed form of gyrocompassing to second order. Tolerance: the neglected terms are of the
    order of the errors squared (psi ~ 6e-4 rad here, so 4e-7 relative) and the levelling's use of the measured
    |f| for g (acc_D / g ~ 4e-5 relative): 1e-3 of each component; plus the accelerometers' quantisation: the
    counter carries its residual, so the window's mean force is off by at most one quantum (1e-4 m/s) over 60 s,
    1.7e-7 rad of tilt, and tan(56.8 deg) = 1.53 times that on the heading: 3e-7 rad."""
    from sins_sim.jobs.run import scenario_metrics
    from sins_sim.simulation.sins import simulate_sins

    gb, ab = (0.004, -0.003, 0.002), (40.0, -30.0, 20.0)
    sc = load_scenario(_still_unit_scenario("coarse", gb, ab), base_dir=_repo())
    res = simulate_sins(sc.imu, sc.motion, sc.duration_s, sc.seed, sc.nav, vehicle=sc.vehicle,
                        filters=sc.filters)
    err = res.alignments["ideal"]["error_rad"]
    ref = _closed_form_alignment_error(gb, ab)
    np.testing.assert_allclose(err, ref, rtol=1e-3, atol=3e-7)
    m = scenario_metrics(res, sc)["ideal"]["alignment"]
    assert m["method"] == "coarse" and m["duration_s"] == pytest.approx(60.0, abs=0.01)
    assert m["error_heading_deg"] == pytest.approx(math.degrees(ref[2]), rel=1e-3)
    # the stated sigma is the 1-sigma observability bound of the unit's own biases (the largest per axis): these
    # biases, about 1 sigma each, give errors of about one sigma (1.03 on the heading: its tilt coupling adds)
    assert all(abs(x) <= 1.5 for x in m["error_over_sigma_ned"]), m


@pytest.mark.parametrize("method", ["inertial", "kalman"])
def test_other_methods_in_a_mission_land_within_their_stated_sigma(method):
    """The inertial and Kalman methods on the same still unit: their error against the truth is within 3 of their
    own stated sigmas on each axis (the bias bounds make the sigma at least the closed-form error)."""
    from sins_sim.simulation.sins import simulate_sins

    gb, ab = (0.004, -0.003, 0.002), (40.0, -30.0, 20.0)
    sc = load_scenario(_still_unit_scenario(method, gb, ab), base_dir=_repo())
    res = simulate_sins(sc.imu, sc.motion, sc.duration_s, sc.seed, sc.nav, vehicle=sc.vehicle, filters=sc.filters)
    got = res.alignments["ideal"]
    assert got["result"].method == method
    assert np.all(np.abs(got["error_rad"]) <= 3.0 * got["result"].sigma_rad + 1e-9), (got["error_rad"],
                                                                                      got["result"].sigma_rad)
