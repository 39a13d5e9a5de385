"""Recorded trajectory files (issue 25, items 8 and 9): velocity as a measurement, the smoothing fit, the pole limit.

* The pieces of :mod:`sins_sim.models.motion.smoothing` against independent computations: the quintic Hermite
  against scipy's ``BPoly.from_derivatives``, the RTS smoother against the batch least-squares solution of the same
  model (dense ``numpy.linalg.lstsq``), the noise estimators against known noise and rounding.
* A file written like a flight log (lat/lon to 7 decimals, velocity noise of 0.03 m/s RMS) is accepted, its truth
  velocity matches the clean file's, and the reported residuals are the noise put in; a file whose velocity
  contradicts its positions (a sign flip, another flight's) is refused naming the row and the column.
* The pole: a segment flight that would pass 89.5 deg is refused when the scenario is loaded, naming the key.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.interpolate import BPoly

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.io.trajectory import TrajectoryData, read_trajectory, write_trajectory
from sins_sim.models.motion import SampledTrajectory
from sins_sim.models.motion.smoothing import (A0_SIGMA_M_S2, noise_scale, quantisation_sigma, quintic_hermite,
                                              smooth_axis)

sys.path.insert(0, str(Path(__file__).parent))
from test_trajectory import short_flight  # noqa: E402  (the bundled file's flight)

ROOT = Path(__file__).resolve().parents[1]
IMU = str(ROOT / "configs" / "default-imu.yaml")
D = math.radians


# --- the pieces -----------------------------------------------------------------------------------------------


def test_quintic_hermite_is_scipys_bpoly():
    """Values and first and second derivatives at the knots, the piece in between: the same polynomial as
    ``BPoly.from_derivatives`` (Bernstein form, an independent construction); agreement to 1e-12 relative
    (rounding of coefficients of order 1)."""
    rng = np.random.default_rng(3)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 40)])
    p, v, a = np.sin(t), np.cos(t), -np.sin(t)
    ours = quintic_hermite(t, p, v, a)
    ref = BPoly.from_derivatives(t, np.stack([p, v, a], axis=1))
    x = np.linspace(0.0, t[-1], 997)
    for d in (0, 1, 2, 3):
        f, g = ours.derivative(d) if d else ours, ref.derivative(d) if d else ref
        assert np.max(np.abs(f(x) - g(x))) < 1e-12 * 10 ** d
    assert np.max(np.abs(ours(t) - p)) < 1e-15 and np.max(np.abs(ours.derivative(2)(t) - a)) < 1e-12


def test_rts_smoother_is_the_batch_least_squares_solution():
    """The fixed-interval smoother ([2] of the module) is the minimiser of the same quadratic cost written as one
    least-squares problem: measurements weighted by 1/sigma, the model's increments by Q^-1/2 (Q of the white-jerk
    model over each, unequal, step), the acceleration prior at the first sample. Agreement to 1e-9 of the
    values (float64 on a 60-sample problem of condition ~1e8)."""
    rng = np.random.default_rng(1)
    n = 60
    t = np.cumsum(np.r_[0.0, rng.uniform(0.08, 0.12, n - 1)])
    x = 100.0 * t + 50.0 * np.sin(0.1 * t) + 1e-3 * rng.standard_normal(n)
    vn = 100.0 + 5.0 * np.cos(0.1 * t) + 1e-2 * rng.standard_normal(n)
    sp, sv, q = 1e-3, 1e-2, 0.014
    ours, _ = smooth_axis(t, x, sp, vn, sv, q)
    rows, rhs = [], []

    def add(coefs, value, w):
        r = np.zeros(3 * n)
        for i, c in coefs:
            r[i] += c
        rows.append(r * w)
        rhs.append(value * w)

    for k in range(n):
        add([(3 * k, 1.0)], x[k], 1.0 / sp)
        add([(3 * k + 1, 1.0)], vn[k], 1.0 / sv)
    add([(2, 1.0)], 0.0, 1.0 / A0_SIGMA_M_S2)
    for k in range(n - 1):
        h = t[k + 1] - t[k]
        f = np.array([[1.0, h, h * h / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
        qm = q * np.array([[h ** 5 / 20, h ** 4 / 8, h ** 3 / 6], [h ** 4 / 8, h ** 3 / 3, h ** 2 / 2],
                           [h ** 3 / 6, h ** 2 / 2, h]])
        w = np.linalg.cholesky(np.linalg.inv(qm)).T
        m = np.zeros((3, 3 * n))
        m[:, 3 * k + 3:3 * k + 6] = np.eye(3)
        m[:, 3 * k:3 * k + 3] -= f
        for r in w @ m:
            rows.append(r)
            rhs.append(0.0)
    batch = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0].reshape(n, 3)
    assert np.max(np.abs(batch[:, :2] - ours[:, :2])) < 1e-9
    assert np.max(np.abs(batch[:, 2] - ours[:, 2])) < 1e-7  # acceleration: the least-determined state


def test_maximum_likelihood_jerk_density_whole_and_in_blocks(monkeypatch):
    """A simulated white-jerk motion (q = 0.5 m^2/s^5, 6000 samples at 10 Hz, position noise 0.01 m, velocity noise
    0.05 m/s): the maximum-likelihood q from the positions alone and from the velocities alone is 0.5 within
    25 % (measured 0.46 and 0.50; the estimate's relative spread is ~sqrt(2 / n) ~ 2 % per component plus the
    0.05-decade search tolerance), and so is the estimate from 10 blocks of 200 samples that a long file uses
    (measured 0.48, 0.50)."""
    from sins_sim.models.motion import smoothing as sm

    rng = np.random.default_rng(4)
    n, h, q = 6000, 0.1, 0.5
    f = np.array([[1.0, h, h * h / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
    cq = np.linalg.cholesky(q * np.array([[h ** 5 / 20, h ** 4 / 8, h ** 3 / 6], [h ** 4 / 8, h ** 3 / 3, h ** 2 / 2],
                                          [h ** 3 / 6, h ** 2 / 2, h]]))
    x, xs = np.zeros(3), np.empty((n, 3))
    for k in range(n):
        x = f @ x + cq @ rng.standard_normal(3)
        xs[k] = x
    t = np.arange(n) * h
    zp = xs[:, 0] + 0.01 * rng.standard_normal(n)
    zv = xs[:, 1] + 0.05 * rng.standard_normal(n)
    for samples in (n + 1, 2000):
        monkeypatch.setattr(sm, "ML_SAMPLES", samples)
        assert sm._ml_q(t, zp, 0.01, zv, 0.05, True, False) == pytest.approx(q, rel=0.25)
        assert sm._ml_q(t, zp, 0.01, zv, 0.05, False, True) == pytest.approx(q, rel=0.25)


def test_noise_estimators():
    """White noise of 0.01 on a smooth curve sampled with jitter: the robust divided-difference estimate is 0.01
    within 6 % (3000 overlapping windows: the median's sampling error is ~2 %, the curve's leakage ~1e-5);
    values rounded to 7 decimals have a rounding of 1e-7 / sqrt(12); full float values and a constant column
    none."""
    rng = np.random.default_rng(7)
    t = np.cumsum(np.r_[0.0, 0.1 + rng.uniform(-0.01, 0.01, 2999)])
    x = 50.0 * np.sin(0.1 * t) + 0.01 * rng.standard_normal(t.size)
    assert noise_scale(t, x) == pytest.approx(0.01, rel=0.06)
    assert noise_scale(t, 50.0 * np.sin(0.1 * t)) < 1e-4
    lat = 48.0 + 1e-5 * t
    assert quantisation_sigma(np.round(lat, 7), 1.0) == pytest.approx(1e-7 / math.sqrt(12.0), rel=1e-9)
    assert quantisation_sigma(lat + 1e-13 * rng.standard_normal(t.size), 1.0) == 0.0
    assert quantisation_sigma(np.full(10, 1500.0), 1.0) == 0.0


# --- files like flight logs -----------------------------------------------------------------------------------


def _clean(duration_s=100.0):
    tr = short_flight()
    s = tr.evaluate(np.arange(0.0, duration_s + 0.05, 0.1))
    return s, s.euler_rad


def _data(s, e, v):
    return TrajectoryData(s.t_s, s.lat_rad, s.lon_rad, s.h_m, e[:, 0], e[:, 1], e[:, 2], v)


def _scenario(tmp_path, csv, **traj):
    doc = {"name": "t", "duration_s": 99.0, "imu": IMU, "trajectory": {"file": csv.name, **traj},
           "navigation": {"start_s": 1.0}, "outputs": {"plots": False}}
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


T_CHECK = np.arange(0.0, 100.0, 0.05) + 0.01


def test_seven_decimal_positions_are_accepted_and_give_the_clean_velocity(tmp_path):
    """lat/lon written to 7 decimals (1.1 cm and 0.75 cm steps), heights to 1 cm, velocity to 1 mm/s: accepted.

    * The reported RMS position residuals are the rounding: 1e-7 deg (R_N + h) / sqrt(12) = 3.2 mm north and
      1e-7 deg (R_E + h) cos 48 deg / sqrt(12) = 2.1 mm east (measured 3.13, 2.09 mm); within 20 %.
    * The truth velocity is the clean file's within 2e-3 m/s (measured 6.1e-4): the fit follows the velocity
      columns, rounded by +-5e-4 m/s, far more precise than 1 cm positions differentiated at 10 Hz (~0.1 m/s).
      The interpolating spline of the rounded positions alone is off by ~0.1 m/s (asserted > 0.02 m/s), which is
      what the old 0.05 m/s check refused.
    """
    s, e = _clean()
    clean = SampledTrajectory.from_data(_data(s, e, s.v_ned_m_s)).evaluate(T_CHECK)
    csv = write_trajectory(tmp_path / "log7.csv", _data(s, e, s.v_ned_m_s), angle_decimals=7, height_decimals=2,
                           velocity_decimals=3)
    sc = load_scenario(_scenario(tmp_path, csv))
    fit = sc.vehicle.fit
    r_n = 6378137.0 * (1 - 0.00669437999014) / (1 - 0.00669437999014 * math.sin(D(48.0)) ** 2) ** 1.5 + 1500.0
    r_e = 6378137.0 / math.sqrt(1 - 0.00669437999014 * math.sin(D(48.0)) ** 2) + 1500.0
    q_n = D(1e-7) * r_n / math.sqrt(12.0)
    q_e = D(1e-7) * r_e * math.cos(D(48.0)) / math.sqrt(12.0)
    assert fit["position_residual_rms_m"][0] == pytest.approx(q_n, rel=0.2)
    assert fit["position_residual_rms_m"][1] == pytest.approx(q_e, rel=0.2)
    got = sc.vehicle.evaluate(T_CHECK)
    assert np.max(np.abs(got.v_ned_m_s - clean.v_ned_m_s)) < 2e-3
    no_vel = read_trajectory(csv)
    interp = SampledTrajectory.from_data({k: getattr(no_vel, k) for k in ("t_s", "lat_rad", "lon_rad", "h_m",
                                                                         "roll_rad", "pitch_rad", "yaw_rad")})
    assert np.max(np.abs(interp.evaluate(T_CHECK).v_ned_m_s - clean.v_ned_m_s)) > 0.02
    assert "smoothing fit" in sc.vehicle.describe() and "RMS residuals" in sc.vehicle.describe()


def test_gnss_grade_velocity_noise_is_accepted_and_the_truth_ignores_it(tmp_path):
    """Velocity noise of 0.03 m/s RMS (GNSS grade) on exact positions: accepted with the default tolerance.

    * The reported RMS velocity residual per axis is the noise put in, 0.03 m/s within 15 % (1001 samples:
      sampling error ~2 %; the fit follows the positions, so the residual is the noise itself).
    * The truth velocity is the clean file's within 2e-4 m/s: the exact positions fix the velocity; measured
      1.3e-5 .. 3.9e-5 m/s over four noise seeds (the noise suppressed ~1000-fold).
    * The tolerance is a setting: a bias of 0.5 m/s on vn_m_s (a velocity that does not fit the positions, by
      more than 5 standard deviations of the difference: 5 x 0.03) passes the default 1 m/s and is refused with
      ``velocity_tolerance_m_s: 0.2``, naming that key, the row and vn_m_s. A tolerance below the noise refuses
      nothing by itself (0.05 here): the 5-sigma guard keeps consistent noisy files.
    """
    s, e = _clean()
    clean = SampledTrajectory.from_data(_data(s, e, s.v_ned_m_s)).evaluate(T_CHECK)
    noisy = s.v_ned_m_s + 0.03 * np.random.default_rng(0).standard_normal(s.v_ned_m_s.shape)
    csv = write_trajectory(tmp_path / "gnss.csv", _data(s, e, noisy))
    sc = load_scenario(_scenario(tmp_path, csv))
    for rms in sc.vehicle.fit["velocity_residual_rms_m_s"]:
        assert rms == pytest.approx(0.03, rel=0.15)
    got = sc.vehicle.evaluate(T_CHECK)
    assert np.max(np.abs(got.v_ned_m_s - clean.v_ned_m_s)) < 2e-4
    load_scenario(_scenario(tmp_path, csv, velocity_tolerance_m_s=0.05))
    biased = write_trajectory(tmp_path / "bias.csv", _data(s, e, noisy + np.array([0.5, 0.0, 0.0])))
    assert load_scenario(_scenario(tmp_path, biased)).vehicle.fit["velocity_vs_positions_max_m_s"][0] > 0.5
    with pytest.raises(ConfigError, match=r"bias\.csv\): row \d+, column vn_m_s: differs .* beyond "
                                          r"trajectory\.velocity_tolerance_m_s = 0\.2 and 5 standard deviations"):
        load_scenario(_scenario(tmp_path, biased, velocity_tolerance_m_s=0.2))


@pytest.mark.parametrize("how, column", [("flip_east", "ve_m_s"), ("flip_down", "vd_m_s"),
                                         ("other_flight", "v[ne]_m_s")])
def test_velocity_that_contradicts_the_positions_is_refused_naming_the_column(tmp_path, how, column):
    """A sign flip of the east velocity (120 m/s flight: off by up to 240 m/s), of the down velocity (the 400 m
    climb at up to ~7 m/s: off by up to 14 m/s; the file runs 200 s to include it), or another stretch of the
    flight (the velocity 30 s later: off by the turn's change of ~170 m/s) exceeds the 1 m/s tolerance:
    refused naming the row and the column, with the key and the rule, no model names."""
    s, e = _clean(200.0 if how == "flip_down" else 100.0)
    v = s.v_ned_m_s.copy()
    if how == "flip_east":
        v[:, 1] *= -1.0
    elif how == "flip_down":
        v[:, 2] *= -1.0
    else:
        v = np.roll(v, 300, axis=0)
    csv = write_trajectory(tmp_path / "bad.csv", _data(s, e, v))
    with pytest.raises(ConfigError, match=rf"trajectory\.file \(bad\.csv\): row \d+, column {column}: differs from "
                                          r"the velocity of the smoothing fit of the positions .* beyond "
                                          r"trajectory\.velocity_tolerance_m_s = 1\.0") as info:
        load_scenario(_scenario(tmp_path, csv))
    assert "SampledTrajectory" not in str(info.value) and "v_tol" not in str(info.value)


def test_velocity_tolerance_key_needs_a_file_with_velocity_columns(tmp_path):
    s, e = _clean(20.0)
    csv = write_trajectory(tmp_path / "novel.csv", _data(s, e, None))
    p = _scenario(tmp_path, csv, velocity_tolerance_m_s=0.5)
    doc = yaml.safe_load(p.read_text())
    doc["duration_s"] = 10.0
    p.write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match=r"trajectory\.velocity_tolerance_m_s: applies to a file with velocity "
                                          r"columns; novel\.csv has none"):
        load_scenario(p)
    doc = {"name": "t", "duration_s": 5.0, "imu": IMU, "trajectory": {"speed_m_s": 10.0, "velocity_tolerance_m_s": 1},
           "outputs": {"plots": False}}
    with pytest.raises(ConfigError, match=r"trajectory\.velocity_tolerance_m_s: applies to a trajectory file"):
        load_scenario(doc)


# --- the pole (item 9) ----------------------------------------------------------------------------------------


def test_segment_flight_towards_the_pole_is_refused_when_loaded():
    """From 89 deg north at 3000 m/s northward the flight passes 89.5 deg (55.6 km) after ~18.5 s: refused by
    load_scenario (before any engine), naming trajectory.segments, the time within 1 s, and the reason; the
    same flight heading south is accepted."""
    doc = {"name": "pole", "duration_s": 30.0, "imu": IMU,
           "site": {"lat_deg": 89.0, "lon_deg": 0.0, "height_m": 1000.0, "heading_deg": 0.0},
           "trajectory": {"speed_m_s": 3000.0, "segments": [{"type": "cruise", "duration_s": 40.0}]},
           "outputs": {"plots": False}}
    with pytest.raises(ConfigError, match=r"trajectory\.segments: the flight from site\.lat_deg 89 passes 89\.5 deg "
                                          r"of latitude before t = (18|19)(\.\d+)? s: .*singular at the poles"):
        load_scenario(doc)
    doc["site"]["heading_deg"] = 180.0
    load_scenario(doc)


def test_schema_states_the_pole_limit_and_its_reason():
    from sins_sim.config.reference import render_text

    traj = render_text("trajectory")
    line = next(ln for ln in traj.splitlines() if ln.startswith("lat_deg"))
    assert "[-89.5, 89.5]" in line and "Titterton & Weston" in line
    assert "velocity_tolerance" in traj
    scen = render_text("scenario")
    line = next(ln for ln in scen.splitlines() if ln.startswith("site.lat_deg"))
    assert "89.5" in line and "singular at the poles" in line
    assert "trajectory.velocity_tolerance_m_s" in scen
