"""A unit's log, imported, aligned and navigated (``sins-sim navigate`` with ``--align``, with and without a truth).

The round trip of issue 35: a vehicle's exact increments are logged as a real unit logs them (pulse counts with
the residual carried, right-forward-up axes, header rows with the site), imported, aligned over the first 60 s
(the vehicle at rest) and navigated. The result must equal the direct run (the same quantised increments in
forward-right-down axes, aligned by the same method and navigated) to rounding; without a truth the solution's
displacement from the start must equal the truth's own displacement plus the error the truth run measured.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sins_sim.cli import main
from sins_sim.jobs.import_log import import_log
from sins_sim.jobs.navigate import navigate_file, navigate_increments
from sins_sim.models.motion import Stationary, Trajectory
from sins_sim.models.motion.trajectory import Accelerate, CoordinatedTurn, Cruise
from sins_sim.navigation import align_inertial
from sins_sim.simulation.external import ideal_increments
from sins_sim.units import ARCSEC, MICRO_G

RATE_HZ = 100.0
W_GYRO, W_ACCEL = 0.1 * ARCSEC, 125.0 * MICRO_G
LAT_DEG, LON_DEG, HEIGHT_M = 56.8, 37.6, 150.0
RFU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # rows: right, forward, up in FRD
ALIGN_S = 60.0
DESCRIPTION = f"""\
name: round trip
format: {{type: text, delimiter: whitespace, header_rows: 4, comment: "#"}}
columns: {{time: 0, gyro: [1, 2, 3], accelerometer: [4, 5, 6]}}
time: {{unit: s, rate_hz: {RATE_HZ:g}}}
gyro: {{kind: counts, weight_arcsec: 0.1}}
accelerometer: {{kind: counts, weight_ug_s: 125}}
axes: right-forward-up
site: {{lat_deg: {{header: Latitude}}, lon_deg: {{header: Longitude}}, height_m: {{header: Height}}}}
"""


def _counts(x, w):
    total = np.floor(np.cumsum(x / w, axis=0))
    return np.diff(np.vstack([np.zeros((1, 3)), total]), axis=0).astype(np.int64)


@pytest.fixture(scope="module")
def unit(tmp_path_factory):
    """A level vehicle heading 30 deg, 80 s at rest (the alignment window and some), then it drives and turns;
    its log in the foreign layout, imported; the quantised increments in FRD built by hand for the direct run."""
    truth = Trajectory(math.radians(LAT_DEG), math.radians(LON_DEG), HEIGHT_M, 0.0, math.radians(30.0),
                       [Stationary(80.0), Accelerate(15.0, 10.0), CoordinatedTurn(20.0, math.pi / 2), Cruise(15.0)])
    t = np.arange(1, int(round(truth.duration_s * RATE_HZ)) + 1) / RATE_HZ
    dth, dv = ideal_increments(truth, t)
    ng, na = _counts(dth @ RFU.T, W_GYRO), _counts(dv @ RFU.T, W_ACCEL)
    d = tmp_path_factory.mktemp("unit")
    header = ["RLG unit, pulse log", f"Latitude: {LAT_DEG}", f"Longitude: {LON_DEG}", f"Height: {HEIGHT_M}"]
    body = [" ".join([f"{t[i]:.2f}", *map(str, ng[i]), *map(str, na[i])]) for i in range(t.size)]
    (d / "unit.log").write_text("\n".join(header + body) + "\n")
    (d / "unit.yaml").write_text(DESCRIPTION)
    import_log(d / "unit.log", d / "unit.yaml", d / "unit.parquet")
    by_hand = (np.column_stack([ng[:, 1], ng[:, 0], -ng[:, 2]]) * W_GYRO,
               np.column_stack([na[:, 1], na[:, 0], -na[:, 2]]) * W_ACCEL)
    truth_csv = d / "truth.csv"
    _write_truth(truth, truth_csv)
    return truth, t, by_hand, d, truth_csv


def _write_truth(truth, path):
    from sins_sim.io import TrajectoryData, write_trajectory

    tt = np.arange(0.0, truth.duration_s + 1e-9, 0.1)
    tr = truth.evaluate(tt)
    e = tr.euler_rad
    write_trajectory(path, TrajectoryData(tt, tr.lat_rad, tr.lon_rad, tr.h_m, e[:, 0], e[:, 1], e[:, 2], tr.v_ned_m_s))


def test_import_align_navigate_equals_the_direct_run(unit, tmp_path):
    """Against the truth: the imported log aligned by the inertial method and navigated gives the direct run's
    alignment and errors to rounding. The inputs agree to a few ulp (each entry is one count x weight either
    way); the alignment and the navigation are smooth functions of them, so the attitude agrees to ~1e-12 rad
    and the positions far below a micrometre (asserted: 1e-9 rad, 1e-6 m)."""
    truth, t, (q_dth, q_dv), d, truth_csv = unit
    m = navigate_file(d / "unit.parquet", truth_csv, tmp_path / "out", align="inertial", align_duration_s=ALIGN_S)
    got = m["filters"]["external"]
    n_w = int(round(ALIGN_S * RATE_HZ))
    direct_al = align_inertial(q_dth[:n_w], q_dv[:n_w], 1.0 / RATE_HZ, math.radians(LAT_DEG), HEIGHT_M,
                               gyro_bias_sigma_rad_s=0.0, accel_bias_sigma_m_s2=0.0)
    ref = navigate_increments(t[n_w:], q_dth[n_w:], q_dv[n_w:], truth, q0_nb=direct_al.q_nb,
                              v0_ned_m_s=np.zeros(3))["filters"]["external"]
    assert got["alignment"]["heading_deg"] == pytest.approx(direct_al.to_dict()["heading_deg"], abs=1e-9)
    for key, stat in (("horizontal_position_error_m", "final"), ("horizontal_position_error_m", "max"),
                      ("velocity_error_m_s", "final")):
        assert abs(got[key][stat] - ref[key][stat]) < 1e-6, (key, stat)
    # the alignment is what the truth says to within its stated sigma (quantised increments, no biases: the
    # sigma is the data's scatter, which the 0.1 arcsec pulses dominate)
    assert abs(got["alignment"]["error_heading_deg"]) <= 3.0 * got["alignment"]["sigma_heading_deg"]
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["filters"]["external"]["alignment"]


def test_without_a_truth_the_solution_is_the_truth_plus_the_measured_error(unit, tmp_path):
    """No truth: the site comes from the table's metadata, and the solution's final displacement from its start
    equals the true displacement plus the error the truth run measured (the same navigator from the same start:
    equal to rounding and to the surface-distance approximation, 1e-3 relative over 300 m: asserted 0.05 m)."""
    from sins_sim import earth

    truth, t, _, d, truth_csv = unit
    with_truth = navigate_file(d / "unit.parquet", truth_csv, tmp_path / "a", align="inertial",
                               align_duration_s=ALIGN_S)["filters"]["external"]
    free = navigate_file(d / "unit.parquet", None, tmp_path / "b", align="inertial", align_duration_s=ALIGN_S)
    n_w = int(round(ALIGN_S * RATE_HZ))
    start, end = truth.evaluate([t[n_w - 1]]), truth.evaluate([t[-1]])
    true_n, true_e, _ = earth.horizontal_error_m(end.lat_rad[0], end.lon_rad[0], start.lat_rad[0], start.lon_rad[0],
                                                 start.h_m[0])
    disp = free["solution"]["final_displacement_m"]
    err = with_truth["horizontal_position_error_m"]
    assert disp["north"] == pytest.approx(true_n + err["final_north"], abs=0.05)
    assert disp["east"] == pytest.approx(true_e + err["final_east"], abs=0.05)
    assert free["navigation"]["site"]["lat_deg"] == pytest.approx(LAT_DEG, abs=1e-9)
    for name in ("solution.parquet", "alignment.png", "displacement.png", "report.md", "metrics.json"):
        assert (tmp_path / "b" / name).is_file(), name


def test_cli_refusals_are_one_line(unit, tmp_path, capsys):
    _, _, _, d, truth_csv = unit
    cases = [
        (["--align", "truth"], "--align: with no --truth"),
        (["--align", "inertial", "--align-duration", "1000"], "--align-duration: the window must hold"),
        (["--align", "coarse", "--align-duration", "60", "--site-lat-deg", "95"], "--site-lat-deg: must be within"),
    ]
    for extra, words in cases:
        rc = main(["navigate", str(d / "unit.parquet"), "--out", str(tmp_path / "x"), *extra])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and words in err and "\n" not in err, (extra, err)
        assert not (tmp_path / "x").exists()


def _still_log(path, heading_deg, gyro_bias_deg_h, accel_bias_ug, seed, duration_s=600.0, rate_hz=50.0):
    """A unit standing still, level, at ``heading_deg``: exact increments (body rate C_bn Omega_ie, specific force
    -C_bn g) plus constant biases and the white noise of the nav-grade preset (ARW 0.002 deg/sqrt(h), VRW
    5 ug/sqrt(Hz)), written as a plain increments file (no metadata: the site comes from flags)."""
    from sins_sim import earth
    from sins_sim.jobs.navigate import write_increments
    from sins_sim.units import DEG, DEG_PER_H

    lat, yaw, dt = math.radians(LAT_DEG), heading_deg * DEG, 1.0 / rate_hz
    c_nb = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    w_b = c_nb.T @ earth.earth_rate_ned(lat)
    f_b = -c_nb.T @ earth.gravity_ned(lat, HEIGHT_M)
    n = int(round(duration_s * rate_hz))
    rng = np.random.default_rng(seed)
    arw = 0.002 * DEG / 60.0  # rad/sqrt(s)
    vrw = 5.0 * MICRO_G  # m/s/sqrt(s)
    dth = (w_b + np.asarray(gyro_bias_deg_h) * DEG_PER_H) * dt + arw * math.sqrt(dt) * rng.standard_normal((n, 3))
    dv = (f_b + np.asarray(accel_bias_ug) * MICRO_G) * dt + vrw * math.sqrt(dt) * rng.standard_normal((n, 3))
    write_increments(path, np.arange(1, n + 1) * dt, dth, dv)
    return path


def test_zupt_on_a_still_log_reports_biases_and_what_rest_cannot_see(tmp_path, capsys):
    """A still log navigated with zero-velocity updates after a 120 s alignment. Heading 0: body x points north,
    y east, z down. At rest the east gyro bias (y) is not separable from the heading, and the horizontal
    accelerometer biases (x, y) not from the tilts: they must be reported as not observable, never as numbers.
    The north gyro bias (x) and the vertical accelerometer bias (z) are observable: the estimate within 3 of its
    own sigma of the truth (a 3-sigma band misses 0.3 % of the time for a consistent filter: a fixed seed)."""
    from sins_sim.cli import main as cli

    gb, ab = (0.003, -0.002, 0.0025), (20.0, -15.0, 30.0)
    log = _still_log(tmp_path / "still.csv", 0.0, gb, ab, seed=11)
    rc = cli(["navigate", str(log), "--align", "inertial", "--align-duration", "120", "--zupt", "--imu",
              "configs/nav-grade-rlg.yaml", "--site-lat-deg", str(LAT_DEG), "--site-lon-deg", str(LON_DEG),
              "--site-height-m", str(HEIGHT_M), "--out", str(tmp_path / "z")])
    out = capsys.readouterr().out
    assert rc == 0 and "zero-velocity updates" in out, out
    z = json.loads((tmp_path / "z" / "metrics.json").read_text())["zupt"]
    assert z["gyro_bias_y_deg_h"] == "not observable"
    assert z["accel_bias_x_ug"] == "not observable" and z["accel_bias_y_ug"] == "not observable"
    assert abs(z["gyro_bias_x_deg_h"] - gb[0]) <= 3.0 * z["gyro_bias_x_sigma_deg_h"], z
    assert abs(z["accel_bias_z_ug"] - ab[2]) <= 3.0 * z["accel_bias_z_sigma_ug"], z
    # the vertical accelerometer bias is pinned far below its prior (the preset's 25 ug RSS 5 ug): the updates
    # did the work
    assert z["accel_bias_z_sigma_ug"] < 0.2 * 25.5
    assert (tmp_path / "z" / "zupt.parquet").is_file()
    report = (tmp_path / "z" / "report.md").read_text()
    assert "not observable" in report and "Zero-velocity updates" in report


def test_zupt_needs_an_imu_and_no_truth(unit, tmp_path, capsys):
    _, _, _, d, truth_csv = unit
    for extra, words in ((["--zupt"], "--zupt: give --imu"),
                         (["--zupt", "--imu", "configs/nav-grade-rlg.yaml", "--truth", str(truth_csv)],
                          "--zupt: navigates a log that stood still")):
        rc = main(["navigate", str(d / "unit.parquet"), "--align", "coarse", "--align-duration", "60", "--out",
                   str(tmp_path / "x"), *extra])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and words in err and "\n" not in err, err
