"""The Earth's rate on a bench (``sins_sim.simulation.site``) and in simulated recordings.

Closed forms: a level unit heading ``psi`` reads ``Omega (cos lat cos psi, -cos lat sin psi, -sin lat)``
(:func:`sins_sim.earth.level_body_from_ned`, an independent rotation); a table turning at a constant rate
``w`` adds ``a t + b sin(w t) / w + s (1 - cos(w t)) / w`` about each gyro axis (the integral of
``a + b cos + s sin``); a suspension at rest, undriven, under a constant rate does not deflect, so its
readout is the Earth's angle alone.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.experiment import experiment_from_dict
from sins_sim.earth import EARTH_RATE_RAD_S, earth_rate_ned, level_body_from_ned
from sins_sim.io.recording import read_recording
from sins_sim.models.motion import ConstantRateMotion
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import ExperimentInputs, TRUTH_SETTINGS, record
from sins_sim.simulation.site import SiteGeometry, dcm_nb, earth_motions
from sins_sim.units import DEG

AXES = ("x", "y", "z")


def test_level_unit_reads_the_earth_rate_by_heading():
    lat, psi = 56.8, 304.0
    geo = SiteGeometry({"latitude_deg": lat, "orientation_ned": {"heading_deg": psi, "pitch_deg": 0.0,
                                                                 "roll_deg": 0.0}})
    want = level_body_from_ned(earth_rate_ned(lat * DEG), psi * DEG)
    # both are rotations of the same vector: agreement to rounding (1e-16 relative of 7.3e-5 rad/s)
    np.testing.assert_allclose(geo.earth_body, want, rtol=0, atol=1e-18)
    assert math.isclose(float(np.linalg.norm(geo.earth_body)), EARTH_RATE_RAD_S, rel_tol=1e-14)


def test_dcm_is_a_rotation_whose_columns_are_the_body_axes():
    c = dcm_nb(0.3, -0.2, 1.1)
    np.testing.assert_allclose(c.T @ c, np.eye(3), atol=1e-15)
    assert math.isclose(np.linalg.det(c), 1.0, rel_tol=1e-15)
    # pitch up by 90 deg points the body x axis up (-down)
    np.testing.assert_allclose(dcm_nb(0.0, 0.5 * math.pi, 0.0)[:, 0], [0.0, 0.0, -1.0], atol=1e-15)


def test_table_turning_at_constant_rate_matches_the_integral():
    site = {"latitude_deg": 40.0, "orientation_ned": {"heading_deg": 30.0, "pitch_deg": 5.0, "roll_deg": -3.0},
            "table_axis_ned": [0.6, 0.0, 0.8]}
    geo = SiteGeometry(site)
    w = 0.2  # rad/s, the table's rate about its axis
    table = {a: ConstantRateMotion(w * geo.table_body[i]) for i, a in enumerate(AXES)}
    mot = earth_motions(site, AXES, 20.0, table)
    t = np.linspace(0.0, 20.0, 2001)
    for a in AXES:
        a0, b, s = geo.rate_terms(a)
        ang, rate = mot[a].angle_rate(t)
        # rate: exact at any t (rounding only); angle: trapezoid on a 1e-4 s grid, error T h^2 / 12 Omega w^2
        # = 20 * 1e-8 / 12 * 7.3e-5 * 0.04 = 5e-14 rad, then the spline through it (smaller)
        np.testing.assert_allclose(rate, a0 + b * np.cos(w * t) + s * np.sin(w * t), atol=1e-18)
        np.testing.assert_allclose(ang, a0 * t + b * np.sin(w * t) / w + s * (1.0 - np.cos(w * t)) / w, atol=1e-12)
    # at theta = 0 the terms give the still unit's rate; at every theta the vector keeps the Earth's magnitude
    for th in (0.0, 1.0, 2.5):
        vec = [sum(c * f for c, f in zip(geo.rate_terms(a), (1.0, math.cos(th), math.sin(th)))) for a in AXES]
        assert math.isclose(float(np.linalg.norm(vec)), EARTH_RATE_RAD_S, rel_tol=1e-13)
    np.testing.assert_allclose([sum(geo.rate_terms(a)[:2]) for a in AXES], geo.earth_body, atol=1e-19)


def test_a_moving_table_needs_its_axis():
    site = {"latitude_deg": 40.0, "orientation_ned": {"heading_deg": 0.0, "pitch_deg": 0.0, "roll_deg": 0.0}}
    n = 100
    meta = {"format": "sins-sim-recording/1", "axes": ["z"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0,
            "sins_fs_hz": 7200.0, "quantum_rad": 7.3e-7, "initial_state": "rest", "experiment": "rate_table",
            "nominal": {"z": {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}},
            "site": site}
    from sins_sim.io.recording import Recording

    rec = Recording(meta, np.zeros((n, 1), np.int64), np.zeros((n, 1)), np.linspace(0.0, 0.1, n)[:, None])
    with pytest.raises(ValueError, match=r"meta.site.table_axis_ned: is required with a moving table"):
        ExperimentInputs.from_recording(rec)
    # a table axis perpendicular to every recorded gyro: its angle is not in the recording
    east = Recording({**meta, "site": {**site, "table_axis_ned": [0.0, 1.0, 0.0]}}, rec.counts, rec.drive_v,
                     rec.sins_angle)
    with pytest.raises(ValueError, match=r"meta.site.table_axis_ned: the table turns about an axis perpendicular"):
        ExperimentInputs.from_recording(east)
    # the table about the gyro's own axis (down, the unit level): z keeps -Omega sin lat at every table angle
    down = Recording({**meta, "site": {**site, "table_axis_ned": [0.0, 0.0, 1.0]}}, rec.counts, rec.drive_v,
                     rec.sins_angle)
    t = np.linspace(0.0, down.duration_s, 7)
    ang, rate = ExperimentInputs.from_recording(down).inertial["z"].angle_rate(t)
    w = -EARTH_RATE_RAD_S * math.sin(40.0 * DEG)
    np.testing.assert_allclose(rate, w, rtol=1e-12)
    np.testing.assert_allclose(ang, w * t, rtol=0, atol=1e-16)


def test_undriven_unit_at_rest_reads_the_earth_angle():
    site = {"latitude_deg": 56.8, "orientation_ned": {"heading_deg": 304.0, "pitch_deg": -0.7, "roll_deg": 1.1}}
    fs, n = 7200.0, 7201
    geo = SiteGeometry(site)
    inputs = ExperimentInputs(AXES, fs, n, fs, np.zeros((n, 3)), None, earth_motions(site, AXES, (n - 1) / fs))
    sus = {a: SuspensionParams() for a in AXES}
    q = 1e-7
    rec = record(inputs, sus, sus, q, (), TRUTH_SETTINGS, extra_meta={"site": site})
    t = rec.time()
    for i, a in enumerate(AXES):
        # no deflection (a constant rate does not excite the suspension): the counter's floor, one quantum
        err = rec.angle(a) - geo.earth_body[i] * t
        assert np.all(err <= 1e-12) and np.all(err > -q - 1e-12), a
    assert rec.sins_angle is None and rec.site == site


def test_simulate_recording_writes_the_site(tmp_path):
    from sins_sim.jobs.recording_jobs import simulate_recording

    spec = tmp_path / "exp.yaml"
    spec.write_text("experiment: rate_table\naxes: [x, y]\nduration_s: 0.05\nplant_rate_hz: 72000\n"
                    "rate_table: {rate_deg_s: 10, sines: []}\n"
                    "site: {latitude_deg: 56.8, orientation_ned: {heading_deg: 304}, table_axis_ned: [0, 0.6, 0.8]}\n")
    out = simulate_recording(spec, tmp_path / "rec.npz")
    rec = read_recording(out["path"])
    assert rec.site["table_axis_ned"] == [0.0, 0.6, 0.8]
    geo = SiteGeometry(rec.site)
    # the encoder angle is the table's turn projected on each gyro axis: 10 deg/s * t * (C_nb0^T u)_i
    t = np.arange(rec.sins_angle.shape[0]) / rec.sins_fs_hz
    np.testing.assert_allclose(rec.sins_angle, np.outer(10.0 * DEG * t, geo.table_body[:2]), atol=1e-15)


@pytest.mark.parametrize("doc, rule", [
    ({"axes": ["a"]}, "axes: must be named from"),
    ({"experiment": "rate_table"}, "site.table_axis_ned: is required"),
])
def test_experiment_site_errors(doc, rule):
    base = {"experiment": "stationary", "duration_s": 0.01, "site": {"latitude_deg": 10.0}}
    with pytest.raises(ConfigError, match=rule):
        experiment_from_dict({**base, **doc})


def test_dcm_agrees_with_the_quaternion_sequence_of_the_navigation_layer():
    """C_nb of the 3-2-1 sequence equals the quaternion product q_z(psi) q_y(theta) q_x(phi) (Hamilton, body to
    NED, the project's convention) turned into a matrix, and its Euler angles come back (rounding only)."""
    from sins_sim.navigation.attitude import dcm_from_quat, euler_from_quat, quat_from_rotvec, quat_multiply

    psi, theta, phi = 304.0 * DEG, -0.7 * DEG, 1.1 * DEG
    q = quat_multiply(quat_multiply(quat_from_rotvec([0.0, 0.0, psi]), quat_from_rotvec([0.0, theta, 0.0])),
                      quat_from_rotvec([phi, 0.0, 0.0]))
    np.testing.assert_allclose(dcm_nb(psi, theta, phi), dcm_from_quat(q), atol=1e-15)
    roll, pitch, yaw = euler_from_quat(q)
    assert math.isclose(roll, phi, abs_tol=1e-14) and math.isclose(pitch, theta, abs_tol=1e-14)
    assert math.isclose(yaw % (2 * math.pi), psi, abs_tol=1e-14)
