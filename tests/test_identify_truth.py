"""``sins-sim identify LOG --truth TRAJECTORY``: a moving log fitted against its known trajectory.

The truth is a trajectory file of a unit rocked about all three axes on a fixed site (a motion table); its ideal
increments (:func:`sins_sim.simulation.external.ideal_increments`) are the reference, and the log is made here from
them with the error model ``x_meas = x_true + b dt + E x_true + n`` (Groves 2013, sec. 4.4.6), white noise of density
``N`` per sample ``N sqrt(dt)`` (IEEE Std 952-1997, Annex C). A still truth excites no scale factor or misalignment:
those are "not observable", the biases still are.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2, norm

from sins_sim.config.errors import ConfigError
from sins_sim.io.trajectory import TrajectoryData, write_trajectory
from sins_sim.jobs.identify import identify, identify_truth
from sins_sim.jobs.import_log import write_log_table
from sins_sim.models.motion import SampledTrajectory
from sins_sim.simulation.external import ideal_increments
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

LAT, LON, H = math.radians(52.0), math.radians(13.0), 40.0
DT = 0.01
T_S = 300.0
B_G = np.array([0.5, -0.3, 0.8]) * DEG_PER_H
B_A = np.array([120.0, -80.0, 60.0]) * MICRO_G
E_G = np.array([[50e-6, 20 * ARCSEC, -15 * ARCSEC], [10 * ARCSEC, -30e-6, 25 * ARCSEC],
                [-20 * ARCSEC, 5 * ARCSEC, 80e-6]])
E_A = np.array([[200e-6, -30 * ARCSEC, 40 * ARCSEC], [15 * ARCSEC, -150e-6, -10 * ARCSEC],
                [25 * ARCSEC, 35 * ARCSEC, 100e-6]])
ARW = 0.01 * DEG / 60.0          # rad/sqrt(s)
VRW = 30.0 * MICRO_G             # m/s^2/sqrt(Hz)


def _truth_file(path, rocking: bool):
    t = np.arange(0.0, T_S + 5.0, 0.05)
    n = t.size
    w = 2.0 * math.pi
    amp = 1.0 if rocking else 0.0
    roll = amp * math.radians(20.0) * np.sin(w * 0.05 * t)
    pitch = amp * math.radians(15.0) * np.sin(w * 0.07 * t + 1.0)
    yaw = math.radians(30.0) + amp * math.radians(40.0) * np.sin(w * 0.03 * t + 2.0)
    data = TrajectoryData(t, np.full(n, LAT), np.full(n, LON), np.full(n, H), roll, pitch, yaw, np.zeros((n, 3)))
    write_trajectory(path, data)
    return path


def _log(path, truth_path, seed):
    rng = np.random.default_rng(seed)
    from sins_sim.io.trajectory import read_trajectory

    truth = SampledTrajectory.from_data(read_trajectory(truth_path))
    t = np.arange(1, int(T_S / DT) + 1) * DT
    th, v = ideal_increments(truth, t - truth.time_offset_s)
    dth = th + B_G * DT + th @ E_G.T + rng.standard_normal(th.shape) * ARW * math.sqrt(DT)
    dv = v + B_A * DT + v @ E_A.T + rng.standard_normal(v.shape) * VRW * math.sqrt(DT)
    write_log_table(path, t, dth, dv, {"site": {"lat_rad": LAT, "lon_rad": LON, "height_m": H}})
    return path


def _pairs(tf):
    out = []
    for s, bkey, b, e, bscale in (("gyro", "bias_deg_h", B_G, E_G, 1.0 / DEG_PER_H),
                                  ("accelerometer", "bias_ug", B_A, E_A, 1.0 / MICRO_G)):
        for i, a in enumerate("xyz"):
            out.append((tf[s][bkey][a], b[i] * bscale))
            for j, c in enumerate("xyz"):
                out.append((tf[s]["scale_factor_ppm"][a], e[i, i] * 1e6) if i == j else
                           (tf[s]["misalignment_arcsec"][a + c], e[i, j] / ARCSEC))
    return out


def test_rocking_log_recovers_every_term_within_its_sigma(tmp_path):
    truth = _truth_file(tmp_path / "truth.csv", rocking=True)
    log = _log(tmp_path / "log.parquet", truth, 7)
    r = identify_truth(log, truth, tmp_path / "out")
    pairs = _pairs(r["truth_fit"])
    assert all("value" in e for e, _ in pairs), [e for e, _ in pairs if "value" not in e]
    # 24 estimates, each normal about its truth with its stated sigma (t with K - 4 ~ 296 dof: normal to 1 %):
    # all inside the 1 % family-wise band (Bonferroni), and their mean square inside chi-square's 99 % interval
    z = np.array([(e["value"] - want) / e["sigma"] for e, want in pairs])
    assert np.max(np.abs(z)) < norm.ppf(1.0 - 0.01 / (2 * z.size)), z
    assert chi2.ppf(0.005, z.size) / z.size < float(np.mean(z * z)) < chi2.ppf(0.995, z.size) / z.size
    assert "scale_factor_ppm: [" in (tmp_path / "out" / "imu-sensors.yaml").read_text()


def test_still_truth_gives_biases_and_not_observable(tmp_path):
    truth = _truth_file(tmp_path / "still.csv", rocking=False)
    log = _log(tmp_path / "log.parquet", truth, 8)
    tf = identify_truth(log, truth)["truth_fit"]
    for s, bkey in (("gyro", "bias_deg_h"), ("accelerometer", "bias_ug")):
        assert all("value" in tf[s][bkey][a] for a in "xyz")
        for key in ("scale_factor_ppm", "misalignment_arcsec"):
            assert all(e["status"].startswith("not observable") for e in tf[s][key].values())
    # at rest E x_true is constant and absorbed into the bias: the six biases against b + E x_true / dt (x_true the
    # first ideal row), 1 % family-wise (Bonferroni)
    from sins_sim.io.trajectory import read_trajectory

    tr = SampledTrajectory.from_data(read_trajectory(truth))
    th, v = ideal_increments(tr, np.array([DT, 2 * DT]))
    z = []
    for s, bkey, b, e_mat, x, scale in (("gyro", "bias_deg_h", B_G, E_G, th[0], 1.0 / DEG_PER_H),
                                        ("accelerometer", "bias_ug", B_A, E_A, v[0], 1.0 / MICRO_G)):
        want = (b + e_mat @ x / DT) * scale
        z += [(tf[s][bkey][a]["value"] - want[i]) / tf[s][bkey][a]["sigma"] for i, a in enumerate("xyz")]
    assert max(abs(x) for x in z) < norm.ppf(1.0 - 0.01 / 12), z


def test_moving_log_refusal_points_to_truth(tmp_path):
    truth = _truth_file(tmp_path / "truth.csv", rocking=True)
    log = _log(tmp_path / "log.parquet", truth, 9)
    with pytest.raises(ConfigError, match="--truth TRAJECTORY"):
        identify(log, twin_seeds=0)
    with pytest.raises(ConfigError, match="--twin-seeds"):
        identify_truth(log, truth, twin_seeds=1)
    short = _truth_file(tmp_path / "short.csv", rocking=True)
    with pytest.raises(ConfigError, match="must cover the log's"):
        data = TrajectoryData(*[np.asarray(x)[:100] for x in (
            np.arange(0, 5, 0.05), np.full(100, LAT), np.full(100, LON), np.full(100, H), np.zeros(100),
            np.zeros(100), np.zeros(100))], np.zeros((100, 3)))
        write_trajectory(short, data)
        identify_truth(log, short)


def _stepped_log(path, truth_path, seed, t_step, step_rad_s):
    """The log of :func:`_log` with a gyro x bias step of ``step_rad_s`` from ``t_step`` on."""
    from sins_sim.jobs.import_log import read_log_table

    t, dth, dv, _ = read_log_table(_log(path, truth_path, seed))
    dth = dth.copy()
    dth[t > t_step, 0] += step_rad_s * DT
    path.unlink()
    write_log_table(path, t, dth, dv, {"site": {"lat_rad": LAT, "lon_rad": LON, "height_m": H}})
    return path


def test_twin_on_the_truth_holds_the_log_and_finds_a_bias_step(tmp_path):
    truth = _truth_file(tmp_path / "truth.csv", rocking=True)
    log = _log(tmp_path / "log.parquet", truth, 7)
    seeds = 8
    r = identify_truth(log, truth, tmp_path / "out", twin_seeds=seeds)
    tw = r["twin"]
    # the log is a run of its twin up to the fitted terms' errors: the envelope (prediction interval at the
    # family-wise 5 % of twin_gap, Bonferroni over the 7 quantities) leaves it out with a chance of at most 5 %
    assert tw["findings"] == [], tw["findings"]
    # on a known trajectory every quantity is an error against the truth (the attitude too: psi, not a drift)
    assert set(tw["navigation_at_end"]) == {"north position error", "east position error", "north velocity error",
                                            "east velocity error", "attitude error about north",
                                            "attitude error about east", "attitude error about down"}
    # a float log has no pulse weight (its smallest step between values is float rounding, not a pulse)
    assert "pulses" not in tw["simulated_at"]
    assert (tmp_path / "out" / "twin-nav.png").is_file() and "## The twin beside the log" in (
        tmp_path / "out" / "report.md").read_text()
    # the twin's white noise, read from the residual's sample variance, is the log's own to its chi-square spread:
    # s^2 / sigma^2 ~ chi2(n - 1) / (n - 1) with n = 30000 samples; checked against the wider interval of the
    # K = 300 one-second blocks (K - 4 degrees of freedom), 99.9 % two-sided per axis (6 axes)
    k = r["truth_fit"]["blocks"]
    lo, hi = (math.sqrt(chi2.ppf(q, k - 4) / (k - 4)) for q in (0.0005 / 6, 1.0 - 0.0005 / 6))
    arw = np.array(tw["sensors"]["gyro"]["arw_deg_rt_h"]) * DEG / 60.0
    vrw = np.array(tw["sensors"]["accelerometer"]["vrw_ug_rt_hz"]) * MICRO_G
    assert np.all((lo < arw / ARW) & (arw / ARW < hi)) and np.all((lo < vrw / VRW) & (vrw / VRW < hi)), (arw, vrw)
    # a gyro x bias step at mid-log, 40 times the bias's white-noise sigma (ols_sigma): the fit takes half of it into
    # the bias, so the twin's tilt grows as s t / 2 from the start, the log's as s (t - T/2) after the step (the two
    # part from the start, not at the step); the velocity error (g times the tilt's integral) then differs at the end
    # by g s T^2 / 8, far outside the twin's band (whose random walk, fitted to the residual, reads part of the
    # step). In the residual against the fitted terms the step is +-s/2 about zero: only the overlapping Allan pairs
    # that straddle it (2 tau / T of them) differ, by about s, so its Allan variance grows as s^2 tau / T and such a
    # finding lies at the long taus (above 10 s here). Where the residual's step scan finds the step, it is a finding
    # too, at the step's time to a block of the scan (T / 200) and its resolution
    sigma = r["truth_fit"]["gyro"]["ols_sigma"]["bias_deg_h"][0] * DEG_PER_H
    t_step = T_S / 2.0
    bad = _stepped_log(tmp_path / "stepped.parquet", truth, 7, t_step, 40.0 * sigma)
    found = identify_truth(bad, truth, twin_seeds=seeds)["twin"]["findings"]
    nav = [f for f in found if f["quantity"] == "navigation"]
    assert nav, f"no navigation finding for a bias step of 40 sigma: {found}"
    for f in found:
        if f["quantity"] == "allan_deviation":
            assert (f["sensor"], f["axis"], f["side"]) == ("gyro", "x", "above") and f["tau_range_s"][1] >= 10.0, f
        elif f["quantity"] == "bias_step":
            assert (f["sensor"], f["axis"]) == ("gyro", "x"), f
            assert abs(f["time_s"] - t_step) <= f["time_resolution_s"] + T_S / 200.0, f
        else:
            assert f["quantity"] == "navigation", f
