"""``sins-sim identify``: spectral lines, temperature coefficients and the twin beside the log.

The logs are made here, independently of the code under test, from closed forms: at rest the body rate and specific
force are ``C_bn w_ie^n`` and ``C_bn (0, 0, -g)`` (Titterton and Weston 2004, sec. 10.2); a sinusoidal input
``A sin(2 pi f t)`` enters each increment as its exact integral over the interval; white noise of density ``N`` has
the per-sample sigma ``N sqrt(fs)``; a rate random walk ``K`` steps by ``K / sqrt(fs)`` per sample (IEEE Std
952-1997, Annex C).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.earth import earth_rate_ned, gravity_down
from sins_sim.jobs.import_log import write_log_table
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

LAT = math.radians(45.0)
H_M = 200.0
FS = 100.0
DT = 1.0 / FS
#: A navigation-grade gyro: ARW 0.003 deg/sqrt(h) with a rate random walk crossing it at 100 s; VRW 20 ug/sqrt(Hz).
N_SI = 0.003 * DEG / 60.0
K_SI = math.sqrt(3.0) * N_SI / 100.0
VRW_SI = 20.0 * MICRO_G
HEADING = math.radians(30.0)
#: Sway: 0.2 arcsec about body x at 0.3 Hz (rate amplitude 2 pi f theta = 1.8e-6 rad/s, 0.38 deg/h); vibration:
#: 2 mg along body z at 47 Hz.
SWAY_HZ, SWAY_ARCSEC = 0.3, 0.2
VIB_HZ, VIB_UG = 47.0, 2000.0


def _sine_increments(amp, f_hz, t_end):
    """Exact integral of ``amp sin(2 pi f t)`` over each interval ``(t - dt, t]``."""
    w = 2.0 * math.pi * f_hz
    return amp / w * (np.cos(w * (t_end - DT)) - np.cos(w * t_end))


def rest_log(path, seed, minutes=10.0, *, sway=False, vibration=False, temperature=None, gyro_tc_deg_h_c=(0, 0, 0),
             accel_tc_ug_c=(0, 0, 0), rrw=K_SI, step=None):
    """Write a log at rest (level, heading 30 deg); return ``(t, rate, force)`` before noise."""
    rng = np.random.default_rng(seed)
    n = int(minutes * 60.0 * FS)
    t = np.arange(1, n + 1) * DT
    c, s = math.cos(HEADING), math.sin(HEADING)
    c_nb = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    w_b = c_nb.T @ earth_rate_ned(LAT)
    f_b = c_nb.T @ np.array([0.0, 0.0, -gravity_down(LAT, H_M)])
    dth = (np.tile(w_b * DT, (n, 1)) + rng.standard_normal((n, 3)) * N_SI * math.sqrt(DT)
           + np.cumsum(rng.standard_normal((n, 3)), axis=0) * rrw * math.sqrt(DT) * DT)
    dv = np.tile(f_b * DT, (n, 1)) + rng.standard_normal((n, 3)) * VRW_SI * math.sqrt(DT)
    if sway:
        dth[:, 0] += _sine_increments(2.0 * math.pi * SWAY_HZ * SWAY_ARCSEC * ARCSEC, SWAY_HZ, t)
    if vibration:
        dv[:, 2] += _sine_increments(VIB_UG * MICRO_G, VIB_HZ, t)
    if step is not None:                               # (axis, time_s, deg/h): a gyro bias step
        dth[t > step[1], step[0]] += step[2] * DEG_PER_H * DT
    if temperature is not None:
        dt_c = temperature - temperature.mean()
        dth += np.outer(dt_c, np.asarray(gyro_tc_deg_h_c) * DEG_PER_H * DT)
        dv += np.outer(dt_c, np.asarray(accel_tc_ug_c) * MICRO_G * DT)
    write_log_table(path, t, dth, dv, {"site": {"lat_rad": LAT, "lon_rad": 0.2, "height_m": H_M}},
                    temperature_c=temperature)
    return t


# --- spectral lines ------------------------------------------------------------------------------------------------

def test_welch_edf_matches_the_closed_form_for_disjoint_segments():
    # segments that do not overlap are independent: nu = 2 N_B exactly (Percival and Walden 1993, eq. 292b: the sum
    # is empty). At 50 % overlap the Hann window's normalised overlap sum is rho = sum sin^2 cos^2 / sum sin^4 over
    # the half it overlaps = (N / 16) / (3 N / 8) = 1/6, so nu = 2 N_B / (1 + 2 (1 - 1/N_B) / 36) -> 36 N_B / 19
    from sins_sim.navigation.spectral_lines import welch_edf

    assert welch_edf(256, 10, 256) == pytest.approx(20.0, rel=1e-12)
    assert welch_edf(4096, 400, 2048) == pytest.approx(800.0 / (1.0 + 2.0 * (1.0 - 1.0 / 400) / 36.0), rel=1e-9)


def test_a_sway_and_a_vibration_line_are_found_with_their_amplitudes(tmp_path):
    from sins_sim.jobs.identify import identify

    rows = []
    for seed in (1, 2, 3):
        p = tmp_path / f"log{seed}.parquet"
        rest_log(p, seed, sway=True, vibration=True)
        m = identify(p, twin_seeds=0)
        sway = m["lines"]["gyro"]["x"]
        vib = m["lines"]["accelerometer"]["z"]
        assert len(sway["lines"]) == 1 and len(vib["lines"]) == 1, (sway["lines"], vib["lines"])
        ls, lv = sway["lines"][0], vib["lines"][0]
        # within one frequency resolution fs / nperseg = 8 / T
        assert abs(ls["frequency_hz"] - SWAY_HZ) <= sway["resolution_hz"]
        assert abs(lv["frequency_hz"] - VIB_HZ) <= vib["resolution_hz"]
        # the amplitude within 3 of its stated (conservative) sigmas: P(miss) < 0.3 % each for a Gaussian error;
        # the 47 Hz line is seen through the increments' sinc(0.47) = 0.674: corrected, it reads the input's 2 mg
        rows.append((ls["angle_amplitude_arcsec"], ls["angle_amplitude_sigma_arcsec"], lv["amplitude_ug"],
                     lv["amplitude_sigma_ug"]))
        assert abs(ls["angle_amplitude_arcsec"] - SWAY_ARCSEC) <= 3.0 * ls["angle_amplitude_sigma_arcsec"]
        assert abs(lv["amplitude_ug"] - VIB_UG) <= 3.0 * lv["amplitude_sigma_ug"]
        # no other line anywhere: the false-alarm level is 1 % for the whole log
        others = [ln for s in ("gyro", "accelerometer") for ax, e in m["lines"][s].items() for ln in e["lines"]
                  if (s, ax) not in (("gyro", "x"), ("accelerometer", "z"))]
        assert others == []
    # the sigmas are informative, not vacuous: the sway's below a quarter of its amplitude (SNR ~ 40 in the peak bin)
    assert all(r[1] < 0.25 * SWAY_ARCSEC for r in rows)


def test_a_line_free_log_gives_no_lines_in_19_of_20_seeds():
    # six channels of noise (white + rate random walk + the twin model's bias instability, a sum of Gauss-Markov
    # processes: a coloured floor) searched at the per-log level 1 %, split over the channels: a log with a false
    # line has probability <= 1 %, so two or more among 20 logs <= 1.7 % (binomial)
    from sins_sim.models.sensor_errors import AccelErrorParams, AccelErrors, GyroErrorParams, GyroErrors
    from sins_sim.navigation.spectral_lines import find_lines

    n = int(10 * 60 * FS)
    gp = GyroErrorParams(arw_deg_rt_h=0.003, rrw_deg_h_rt_h=0.003, bias_instability_deg_h=0.003,
                         bias_instability_tau_s=(1.0, 100.0))
    ap = AccelErrorParams(vrw_ug_rt_hz=20.0, bias_instability_ug=5.0, bias_instability_tau_s=(1.0, 100.0))
    logs_with_lines = 0
    for seed in range(20):
        rng = np.random.default_rng(1000 + seed)
        x = np.hstack([GyroErrors(gp, rng, DT).apply(np.zeros((n, 3))), AccelErrors(ap, rng, DT).apply(
            np.zeros((n, 3)))]) / DT
        found = sum(len(find_lines(x[:, i], FS, false_alarm=0.01 / 6.0, increment_dt=DT).lines) for i in range(6))
        logs_with_lines += found > 0
    assert logs_with_lines <= 1


def test_psd_figure_and_table(tmp_path):
    from sins_sim.jobs.identify import identify

    p = tmp_path / "log.parquet"
    rest_log(p, 4, sway=True, vibration=True)        # 10 min: the search starts at 13 bins = 0.17 Hz
    m = identify(p, tmp_path / "out", twin_seeds=0)
    assert m.files["psd.png"].stat().st_size > 20000
    lines = m.to_pandas()["lines"]
    assert set(zip(lines["sensor"], lines["axis"])) == {("gyro", "x"), ("accelerometer", "z")}
    assert "## Spectral lines" in (tmp_path / "out" / "report.md").read_text()


# --- temperature -----------------------------------------------------------------------------------------------------

def test_temperature_coefficients_recovered_within_their_sigma(tmp_path):
    from sins_sim.jobs.identify import identify

    t = np.arange(1, int(10 * 60 * FS) + 1) * DT
    # a warm-up of 4 deg C with a 2 deg C cycle of 120 s: the cycle separates the coefficient from a drift
    temp = 25.0 + 4.0 * t / t[-1] + 2.0 * np.sin(2.0 * math.pi * t / 120.0)
    gyro_tc = (0.1, 0.0, -0.08)                        # deg/h per deg C
    accel_tc = (0.0, 8.0, 0.0)                         # ug per deg C
    p = tmp_path / "log.parquet"
    rest_log(p, 7, temperature=temp, gyro_tc_deg_h_c=gyro_tc, accel_tc_ug_c=accel_tc)
    m = identify(p, twin_seeds=0)
    tm = m["temperature"]
    for sensor, truth, key in (("gyro", gyro_tc, "coefficient_deg_h_per_c"),
                               ("accelerometer", accel_tc, "coefficient_ug_per_c")):
        for ax, k in zip("xyz", truth):
            e = tm[sensor][ax][key]
            if k != 0.0:
                # present and significant, and within 3 sigma of the truth. The sigma is conservative (about
                # 0.01 deg/h/C here: the random walk taken at its upper bound from the record, temperature effect
                # included), so the coefficients are 8 to 10 of it, far over the threshold z = 2.64
                # (5 % / 6 axes)
                assert "value" in e, (sensor, ax, e)
                assert abs(e["value"] - k) <= 3.0 * e["sigma"], (sensor, ax, e, k)
            else:
                # no coefficient: reported only when significant at 5 % over the six axes (a false one < 5 %)
                assert e.get("status") == "not significant", (sensor, ax, e)
    # the correlated noise is accounted for: the sigma exceeds the white-residual (OLS) one for the gyros, whose
    # rate random walk makes the block means wander
    assert tm["gyro"]["x"]["coefficient_deg_h_per_c"]["sigma"] > tm["gyro"]["x"]["coefficient_deg_h_per_c"]["ols_sigma"]


def test_gls_sigma_covers_a_random_walk_that_ols_does_not():
    # 40 logs of white noise + a rate random walk with a known coefficient: the normalised errors (k - k_true) / sigma
    # must not be larger than N(0, 1)'s: RMS <= 1.3 (the chi-square 97.5 % point of 40 dof gives RMS 1.26 for a true
    # sigma); the ordinary least-squares sigma, blind to the walk, gives an RMS far above it (> 2)
    from sins_sim.navigation.temperature_fit import fit_temperature_coefficient

    n = int(10 * 60 * FS)
    t = np.arange(n) * DT
    temp = 20.0 + 10.0 * t / t[-1] + 1.5 * np.sin(2.0 * math.pi * t / 200.0)
    k_true = 0.05 * DEG_PER_H
    k_rw = math.sqrt(3.0) * N_SI / 10.0
    z, z_ols = [], []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        y = (k_true * (temp - temp.mean()) + rng.standard_normal(n) * N_SI * math.sqrt(FS)
             + np.cumsum(rng.standard_normal(n)) * k_rw / math.sqrt(FS))
        f = fit_temperature_coefficient(y, temp, FS)
        z.append((f.coefficient - k_true) / f.sigma)
        z_ols.append((f.coefficient - k_true) / f.ols_sigma)
    assert math.sqrt(np.mean(np.square(z))) <= 1.3
    assert math.sqrt(np.mean(np.square(z_ols))) > 2.0


def test_import_log_carries_the_temperature_column(tmp_path):
    from sins_sim.jobs.import_log import import_log, read_log_temperature

    n = 300
    rows = ["# a log with a temperature column in kelvin"]
    for k in range(n):
        rows.append(f"{(k + 1) * 0.01:.2f} 1 2 3 40 50 -8000 {298.15 + 0.001 * k:.4f}")
    log = tmp_path / "unit.txt"
    log.write_text("\n".join(rows) + "\n")
    desc = {"format": {"type": "text", "header_rows": 0}, "columns": {"time": 0, "gyro": [1, 2, 3],
                                                                         "accelerometer": [4, 5, 6], "temperature": 7},
            "time": {"rate_hz": 100}, "temperature": {"unit": "K"},
            "gyro": {"kind": "counts", "weight_arcsec": 0.1}, "accelerometer": {"kind": "counts", "weight_ug_s": 125},
            "axes": "FRD"}
    out = tmp_path / "log.parquet"
    import_log(log, desc, out)
    temp = read_log_temperature(out)
    # kelvin to deg C: 298.15 K is 25 deg C exactly; 0.001 K per row
    assert temp.shape == (n,)
    assert temp[0] == pytest.approx(25.0, abs=1e-9) and temp[-1] == pytest.approx(25.0 + 0.001 * (n - 1), abs=1e-9)


def test_temperature_unit_without_a_column_is_one_line():
    from sins_sim.config.errors import ConfigError
    from sins_sim.config.log import load_log_description

    desc = {"format": {"type": "text"}, "columns": {"gyro": [0, 1, 2], "accelerometer": [3, 4, 5]},
            "time": {"rate_hz": 100}, "temperature": {"unit": "K"}, "gyro": {"kind": "counts", "weight_arcsec": 0.1},
            "accelerometer": {"kind": "counts", "weight_ug_s": 125}, "axes": "FRD"}
    with pytest.raises(ConfigError, match=r"temperature\.unit: needs a temperature column"):
        load_log_description(desc)


# --- the twin beside the log -----------------------------------------------------------------------------------------

#: A 1 deg/h step of the z gyro at 240 s: the step's sigma is about 0.15 deg/h in 8 min (the noise's GLS), so
#: z ~ 7 against a threshold of 4.1 (5 % over 181 boundaries and 6 axes)
STEP = (2, 240.0, 1.0)


@pytest.fixture(scope="module")
def twin_runs(tmp_path_factory):
    from sins_sim.jobs.identify import identify

    folder = tmp_path_factory.mktemp("twin")
    rest_log(folder / "plain.parquet", 31, minutes=8.0)
    rest_log(folder / "sway.parquet", 32, minutes=8.0, sway=True, step=STEP)
    plain = identify(folder / "plain.parquet", folder / "plain", twin_seeds=5)
    sway = identify(folder / "sway.parquet", twin_seeds=5)
    return plain, sway, folder


def test_a_log_of_the_twins_kind_stays_in_its_envelope(twin_runs):
    # the log is white noise + a rate random walk, exactly what the twin models: its findings are false alarms, at
    # most 5 % per kind of quantity (Allan, navigation) and 1 % for lines; one log: none expected
    plain = twin_runs[0]
    assert plain["twin"]["findings"] == [], plain["twin"]["findings"]
    # the twin's noise is the log's fitted noise
    assert plain["twin"]["sensors"]["gyro"]["arw_deg_rt_h"][0] == pytest.approx(
        plain["noise"]["gyro"]["x"]["arw_deg_rt_h"]["value"], rel=1e-12)


def test_a_sway_line_and_a_bias_step_are_localised_in_band_and_time(twin_runs):
    sway = twin_runs[1]
    steps = [f for f in sway["twin"]["findings"] if f["quantity"] == "bias_step"]
    assert len(steps) == 1
    s = steps[0]
    assert (s["sensor"], s["axis"]) == ("gyro", "z")
    # the time to one block (2.4 s), the size within 3 of its sigmas
    assert abs(s["time_s"] - STEP[1]) <= s["time_resolution_s"]
    assert abs(s["size_deg_h"] - STEP[2]) <= 3.0 * s["sigma_deg_h"]
    lines = [f for f in sway["twin"]["findings"] if f["quantity"] == "psd_line"]
    assert len(lines) == 1
    f = lines[0]
    assert (f["sensor"], f["axis"]) == ("gyro", "x")
    assert f["band_hz"][0] <= SWAY_HZ <= f["band_hz"][1]
    assert f["twin_seeds_with_line"] == 0


def test_twin_figures_written_and_the_api(twin_runs):
    plain, _, folder = twin_runs
    out = folder / "plain"
    for name in ("twin-allan.png", "twin-psd.png", "twin-alignment.png", "twin-nav.png", "psd.png", "allan.png"):
        assert plain.files[name] == out / name and (out / name).stat().st_size > 20000
    assert "## The twin beside the log" in (out / "report.md").read_text()
    tables = plain.to_pandas()
    assert set(tables) == {"noise", "bias", "lines", "temperature", "findings", "candidates"}
    assert plain.verdict["status"] == "none" and tables["candidates"].empty
    assert len(tables["bias"]) == 12
    fig = plain.plot("twin-nav")
    assert len(fig.axes) == 8
    import matplotlib.pyplot as plt

    plt.close(fig)
    with pytest.raises(ValueError, match="kind must be one of"):
        plain.plot("nope")


def test_twin_increments_at_rest_are_the_earth_rate_and_gravity():
    # with no sensor errors the twin's increments are the closed form exactly (float64 rounding of w dt ~ 1e-20 rad)
    from sins_sim.models.sensor_errors import SensorErrorParams
    from sins_sim.navigation.attitude import quat_from_rotvec
    from sins_sim.simulation.twin import twin_increments

    q = quat_from_rotvec(np.array([0.0, 0.0, HEADING]))
    site = {"lat_rad": LAT, "lon_rad": 0.0, "height_m": H_M}
    _, dth, dv = twin_increments(SensorErrorParams(), 10, DT, site, q, 0)
    c, s = math.cos(HEADING), math.sin(HEADING)
    c_nb = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(dth, c_nb.T @ earth_rate_ned(LAT) * DT, rtol=0.0, atol=1e-18)
    assert np.allclose(dv, c_nb.T @ np.array([0.0, 0.0, -gravity_down(LAT, H_M)]) * DT, rtol=0.0, atol=1e-15)


def test_twin_seeds_flag_is_checked(tmp_path):
    from sins_sim.config.errors import ConfigError
    from sins_sim.jobs.identify import identify

    p = tmp_path / "log.parquet"
    rest_log(p, 1, minutes=1.0)
    with pytest.raises(ConfigError, match=r"^--twin-seeds: must be 0 \(no twin\) or an integer in \[2, 100\]"):
        identify(p, twin_seeds=1)
