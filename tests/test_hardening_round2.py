"""Issue 25, round 2 of the hardening: items 3, 6 (shock, random vibration) and 11 (four messages).

* Item 3: every sensor-error key has a physical range (navigation grade to beyond the loosest consumer MEMS), stated
  in the reference with its reason, and out-of-range values are refused naming the key; the divergence check
  watches velocity and position as well as attitude.
* Item 6: a random vibration with all axis weights zero and a shock shorter than 3 plant steps are refused.
* Item 11: a coordinated turn beyond 200 g or 1000 deg/s is refused naming ``heading_change_deg``;
  ``compare-filters --json`` and ``lockin-study --out`` are checked before the study; a recorded drive beyond
  1000 V is refused naming ``drive_v``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.imu import load_imu
from sins_sim.config.reference import render_text
from sins_sim.config.scenario import load_scenario
from sins_sim.models import sensor_errors as se
from sins_sim.units import MICRO_G

ROOT = Path(__file__).resolve().parents[1]
CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}


def _imu(section: str, key: str, value):
    return load_imu({"channels": CHANNELS, "sensors": {section: {key: value}}})


RANGED = [k[:4] for k in se.key_ranges() if k[4]]  # the per-axis keys and the misalignment


# --- item 3: physical ranges -------------------------------------------------------------------------------------
def test_every_sensor_error_key_has_a_stated_range_and_reason():
    """Each per-axis key, the misalignment and the full-scale rate has an upper bound (none is open), and the
    reference (``sins-sim schema imu``) shows that range and why (the consumer-MEMS datasheet it is tied to)."""
    keys = {f"{sec}.{name}" for sec, name, _, _ in RANGED}
    assert len(keys) == 18  # 9 per section: every key but bias_instability_tau_s (and the gyro's full_scale_deg_s)
    assert keys <= set(se.PHYSICAL_RANGES)
    text = render_text("imu")
    for sec, name, lo, hi in RANGED:
        line = next(ln for ln in text.splitlines() if ln.startswith(f"sensors.{sec}.{name} "))
        assert f"{hi:g}" in line, line
        assert "MPU-6050" in line, line
    fs = next(ln for ln in text.splitlines() if ln.startswith("sensors.gyro.full_scale_deg_s "))
    assert "[1, 10000]" in fs


def test_the_bundled_units_lie_inside_the_ranges():
    """The navigation-grade and tactical-grade files (the other end of the range) still load."""
    for name in ("nav-grade-rlg.yaml", "tactical-grade.yaml"):
        assert load_imu(ROOT / "configs" / name).sensors is not None


@pytest.mark.parametrize("section, key, lo, hi", RANGED, ids=[f"{s}.{k}" for s, k, _, _ in RANGED])
def test_range_edges_are_accepted_and_beyond_is_refused_naming_the_key(section, key, lo, hi):
    """At the bound and just inside: accepted; 1 % beyond, 1e300, inf and (for magnitudes) -1: one line naming
    ``sensors.<section>.<key>`` and the rule."""
    shape = 6 if key == "misalignment_arcsec" else 3
    for value in (hi, 0.999 * hi, lo):
        _imu(section, key, [value] * shape)
    bad = [1.01 * hi, 1e300, math.inf]
    if lo == 0.0:
        bad.append(-1.0)
    else:
        bad.append(1.01 * lo)
    for value in bad:
        with pytest.raises(ConfigError) as err:
            _imu(section, key, [value] * shape)
        msg = str(err.value)
        assert f"sensors.{section}.{key}[0]: must " in msg, msg
        assert "\n" not in msg
        if math.isfinite(value) and value > hi:
            assert f"{hi:g}" in msg and "physical range" in msg, msg


def test_max_sensor_errors_apply_without_numpy_warnings():
    """Every key at its bound (both sample rates of the engine): finite outputs and no numpy warning (the
    bias instability at 1e300 printed numpy's divide warning; now it is refused before)."""
    import warnings

    g = se.GyroErrorParams(**{k: se.PHYSICAL_RANGES[f"gyro.{k}"][0] for s, k, _, _ in RANGED
                              if s == "gyro" and k != "misalignment_arcsec"}, bias_instability_tau_s=(10.0, 1e7),
                           full_scale_deg_s=se.FULL_SCALE_RANGE_DEG_S[0])
    a = se.AccelErrorParams(**{k: se.PHYSICAL_RANGES[f"accelerometer.{k}"][0] for s, k, _, _ in RANGED
                               if s == "accelerometer" and k != "misalignment_arcsec"},
                            bias_instability_tau_s=(1e-6, 1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for dt in (1.0 / 7200.0, 1.0 / 72000.0):
            x = se.GyroErrors(g, np.random.default_rng(1), dt).apply(np.full((500, 3), math.radians(999.0) * dt))
            y = se.AccelErrors(a, np.random.default_rng(2), dt).apply(np.full((500, 3), 20.0 * dt))
            assert np.all(np.isfinite(x)) and np.all(np.isfinite(y))


# --- item 3: divergence on velocity and position -------------------------------------------------------------------
def _nav_error_rows(dv_north, dh):
    """nav_errors on a truth at rest at 45 N (identity attitude) and a solution off by ``dv_north`` (m/s, north
    velocity) and ``dh`` (m, height) per row."""
    from sins_sim._kernels import truth as ktruth
    from sins_sim.simulation.metrics import N_COLS
    from sins_sim.simulation.sins import DIVERGED_ATTITUDE_RAD, DIVERGED_POSITION_M, DIVERGED_VELOCITY_M_S

    n = len(dv_north)
    lat = np.full(n, math.radians(45.0))
    lon = np.zeros(n)
    h = np.zeros(n)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    v = np.zeros((n, 3))
    v_est = v.copy()
    v_est[:, 0] = dv_north
    scales = np.empty((n, 3))
    ktruth.surface_scales(lat, h, scales)
    rows = np.empty((n, N_COLS))
    bad = ktruth.nav_errors(lat, lon, h + np.asarray(dh, float), v_est, q, lat, lon, h, scales, v, q,
                            np.zeros((n, 3)), np.zeros(6), DIVERGED_ATTITUDE_RAD, DIVERGED_VELOCITY_M_S,
                            DIVERGED_POSITION_M, rows)
    return bad, rows


def test_the_divergence_limits_are_the_first_cosmic_velocity_and_the_earth_radius():
    """sqrt(GM / R) with WGS 84's GM and the mean radius: 7.91 km/s (to the 3 digits stated)."""
    from sins_sim.simulation.sins import DIVERGED_POSITION_M, DIVERGED_VELOCITY_M_S

    assert DIVERGED_VELOCITY_M_S == pytest.approx(math.sqrt(3.986004418e14 / 6.371e6), rel=1e-3)
    assert DIVERGED_POSITION_M == 6.371e6


def test_velocity_and_position_errors_mark_the_first_bad_row():
    """Rows with growing velocity (and height) errors: the first row beyond the limit is returned and the reason
    names the limit; the row numbers are the independent ``argmax`` of the same comparison."""
    from sins_sim.simulation.sins import DIVERGED_POSITION_M, DIVERGED_VELOCITY_M_S, divergence_reason

    dv = np.linspace(0.0, 2.0 * DIVERGED_VELOCITY_M_S, 101)
    bad, rows = _nav_error_rows(dv, np.zeros(101))
    assert bad == int(np.argmax(dv > DIVERGED_VELOCITY_M_S)) == 51
    assert "velocity error" in divergence_reason(rows[bad]) and "7910 m/s" in divergence_reason(rows[bad])
    dh = np.linspace(0.0, 2.0 * DIVERGED_POSITION_M, 101)
    bad, rows = _nav_error_rows(np.zeros(101), dh)
    assert bad == int(np.argmax(dh > DIVERGED_POSITION_M)) == 51
    assert "position error" in divergence_reason(rows[bad])
    bad, _ = _nav_error_rows(np.full(5, 0.999 * DIVERGED_VELOCITY_M_S), np.full(5, 0.999 * DIVERGED_POSITION_M))
    assert bad == -1


def test_a_velocity_divergence_is_reported_with_its_time(monkeypatch):
    """The engine stops a navigation whose velocity error leaves the limit and reports it. An accelerometer bias
    b along body x at rest gives a velocity error b t (Schuler: relative deviation (w_s t)^2 / 6 = 1e-7 here);
    with the limit lowered to V = 0.05 m/s every filter diverges at start_s + V / b (0.510 s after the start).
    Tolerance 5 ms: one navigation update (2 / 7200 s), the accelerometer quantum and the filters' few-arcsec
    attitude errors (g psi t, < 1e-4 m/s) move the crossing by well under 1 ms; the run ends normally."""
    import sins_sim.simulation.sins as sins
    from sins_sim.config.imu import imu_from_dict
    from sins_sim.models import motion as m3

    limit = 0.05
    monkeypatch.setattr(sins, "DIVERGED_VELOCITY_M_S", limit)
    imu = imu_from_dict({"channels": CHANNELS, "sensors": {"accelerometer": {"bias_ug": [1.0e4, 0.0, 0.0]}}}, "t")
    res = sins.simulate_sins(imu, m3.Static(), 1.5, seed=1, nav=sins.NavSettings(start_s=0.5),
                             filters=("ideal", "correcting"))
    expected = 0.5 + limit / (1.0e4 * MICRO_G)
    for name in ("ideal", "correcting"):
        d = res.diverged[name]
        assert d["time_s"] == pytest.approx(expected, abs=5e-3), (name, d)
        assert "velocity error" in d["reason"]


# --- item 6: random vibration axes, shock duration -----------------------------------------------------------------
def _scenario(motion, imu=None):
    return {"name": "t", "duration_s": 0.5, "imu": imu or {"channels": CHANNELS}, "motion": motion,
            "navigation": {"start_s": 0.0}}


RV = {"type": "random_vibration", "psd_deg2_s2_per_hz": [[10, 1e-4], [1000, 1e-4]], "f_lo_hz": 20, "f_hi_hz": 900}


def test_random_vibration_with_zero_axes_is_refused_naming_the_key():
    with pytest.raises(ConfigError, match=r"motion\[0\]\.axes: must not be all zero"):
        load_scenario(_scenario([dict(RV, axes=[0, 0, 0])]))
    load_scenario(_scenario([dict(RV, axes=[0, 0, 1e-3])]))  # one axis is enough
    lin = {"type": "random", "psd_g2_per_hz": [[10, 1e-4], [1000, 1e-4]], "f_lo_hz": 20, "f_hi_hz": 900,
           "axes": [0, 0, 0]}
    with pytest.raises(ConfigError, match=r"linear_vibration\[0\]\.axes: must not be all zero"):
        load_scenario(dict(_scenario([{"type": "static"}]), linear_vibration=[lin]))


@pytest.mark.parametrize("plant_hz", [72000.0, 36000.0])
def test_a_shock_shorter_than_three_plant_steps_is_refused(plant_hz):
    """The half-sine's main lobe ends at 1.5 / T (first zero of its Fourier transform, checked here with scipy's
    quadrature); it must lie below the plant's Nyquist: T >= 3 / rate_hz. At the bound: accepted; 1 % shorter and
    1e-6 ms: refused naming ``duration_ms``."""
    from scipy.integrate import quad

    t = 1.0
    mag = lambda f: math.hypot(quad(lambda x: math.sin(math.pi * x / t) * math.cos(2 * math.pi * f * x), 0, t)[0],
                               quad(lambda x: math.sin(math.pi * x / t) * math.sin(2 * math.pi * f * x), 0, t)[0])
    assert mag(1.5 / t) < 1e-9 < mag(1.4 / t) and mag(1.6 / t) > 1e-9  # the first zero of the lobe is 1.5 / T
    imu = {"channels": CHANNELS, "plant": {"rate_hz": plant_hz}, "drive": {"dac_rate_hz": plant_hz}}
    t_min_ms = 3.0 / plant_hz * 1e3
    shock = {"type": "shock", "axis": [0, 0, 1], "peak_rate_deg_s": 100.0, "start_s": 0.1}
    load_scenario(_scenario([dict(shock, duration_ms=t_min_ms)], imu))
    for d in (0.99 * t_min_ms, 1e-6):
        with pytest.raises(ConfigError, match=rf"motion\[0\]\.duration_ms: must be >= {t_min_ms:.4g} ms"):
            load_scenario(_scenario([dict(shock, duration_ms=d)], imu))


# --- item 11: the turn, the output paths, the drive voltage --------------------------------------------------------
def _turn(speed, heading_change_deg, duration_s, transition_s):
    return {"name": "t", "duration_s": 0.2, "imu": {"channels": CHANNELS}, "navigation": {"start_s": 0.0},
            "trajectory": {"speed_m_s": speed, "transition_s": transition_s,
                           "segments": [{"type": "turn", "duration_s": duration_s,
                                         "heading_change_deg": heading_change_deg},
                                        {"type": "cruise", "duration_s": 1.0}]}}


def test_a_36000_deg_turn_in_10_ms_is_refused_naming_the_key():
    with pytest.raises(ConfigError, match=r"trajectory\.segments\[0\]\.heading_change_deg: the turn's centripetal "
                                          r"acceleration .* must be <= 2000 m/s\^2 .*, got 36000$"):
        load_scenario(_turn(100.0, 36000.0, 0.01, 0.004))


def test_the_turn_body_rate_bound_against_an_independent_evaluation():
    """The peak body rate of a coordinated turn: heading rate r s(x) and roll rate d/dt atan(V r s / g),
    differentiated here numerically from the bank (central differences on 20001 points), independent of the
    closed form the model uses; they agree to 1e-4 (the model samples 4001 points, the peak is smooth)."""
    from sins_sim.models.motion.trajectory import turn_peak_body_rate

    speed, r, tr, g = 50.0, math.radians(40.0), 0.5, 9.80665
    x = np.linspace(0.0, 1.0, 20001)
    s = x ** 4 * (35 - 84 * x + 70 * x ** 2 - 20 * x ** 3)
    phi = np.arctan2(speed * r * s, g)
    dphi = np.gradient(phi, x * tr)
    expected = np.max(np.hypot(r * s, dphi))
    assert turn_peak_body_rate(speed, r, tr, g) == pytest.approx(expected, rel=1e-4)
    # a turn inside both bounds runs to a finite state; one just beyond the rate bound is refused
    load_scenario(_turn(50.0, 40.0 * 1.5, 2.0, 0.5))
    with pytest.raises(ConfigError, match=r"trajectory\.segments\[0\]\.heading_change_deg: the turn's peak body "
                                          r"rate .* must be <= 1000 deg/s"):
        load_scenario(_turn(0.0, 1010.0 * 0.5, 1.0, 0.5))


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "sins_sim.cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=120)


def _main(args, capsys):
    from sins_sim.cli import main

    rc = main(list(args))
    return rc, capsys.readouterr().err


def test_compare_filters_json_is_checked_before_the_study(tmp_path, monkeypatch, capsys):
    """An unwritable --json (a virtual file system, a folder) is refused naming --json before the study starts
    (the study is replaced by one that fails the test if it runs)."""
    import sins_sim.jobs.compare_filters as cf

    monkeypatch.setattr(cf, "run_compare_filters", lambda *a, **k: pytest.fail("the study ran"))
    for target in ("/proc/cf.json", str(tmp_path)):
        rc, err = _main(["compare-filters", "--out", str(tmp_path / "cf"), "--json", target, "--quick", "--quiet"],
                        capsys)
        assert rc == 2 and err.startswith("sins-sim: error: --json: ") and err.count("\n") == 1, err


def test_lockin_study_out_is_checked_before_the_study(tmp_path, monkeypatch, capsys):
    import sins_sim.jobs.lockin_study as ls

    monkeypatch.setattr(ls, "lockin_study", lambda *a, **k: pytest.fail("the study ran"))
    f = tmp_path / "existing"
    f.write_text("x")
    rc, err = _main(["lockin-study", "--out", str(f), "--quick"], capsys)
    assert rc == 2
    assert err.strip() == f"sins-sim: error: --out: {f} exists and is not a directory"


def test_a_recorded_drive_beyond_what_a_piezo_takes_is_refused_naming_drive_v():
    """``drive_v`` scaled by 1e30 (it gave "array must not contain infs or NaNs" in the fit): refused by the
    reader; at the bound it is read."""
    from sins_sim.io.recording import DRIVE_V_MAX, RecordingError, check_recording
    from sins_sim.models.drive import V_MAX

    assert V_MAX == DRIVE_V_MAX == 1000.0
    meta = {"format": "sins-sim-recording/1", "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0,
            "quantum_rad": 7.33e-7, "initial_state": "rest", "experiment": "stationary",
            "nominal": {"x": {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}}}
    counts = np.zeros((100, 1), dtype=np.int64)
    drive = np.sin(np.arange(100.0))[:, None] * 0.39
    check_recording(meta, counts, drive * DRIVE_V_MAX / 0.39)
    with pytest.raises(RecordingError, match=r"^rec: drive_v: must lie in \[-1000, 1000\] V .* got -3\.9e\+29 at \(11, 0\)$"):
        check_recording(meta, counts, drive * 1e30, where="rec")


def test_the_json_schema_flags_an_out_of_range_sensor_error_at_its_key():
    """``sins-sim schema imu --json-schema`` carries the ranges: the independent ``jsonschema`` validator flags
    ``vrw_ug_rt_hz: 1e12`` at ``sensors.accelerometer.vrw_ug_rt_hz`` and accepts the bound."""
    import json

    jsonschema = pytest.importorskip("jsonschema")
    from sins_sim.config.reference import render_json_schema

    val = jsonschema.Draft202012Validator(json.loads(render_json_schema("imu")))
    hi = se.PHYSICAL_RANGES["accelerometer.vrw_ug_rt_hz"][0]
    ok = {"channels": CHANNELS, "sensors": {"accelerometer": {"vrw_ug_rt_hz": [hi, 0.0, 1.0]}}}
    assert not list(val.iter_errors(ok))
    bad = {"channels": CHANNELS, "sensors": {"accelerometer": {"vrw_ug_rt_hz": 1e12}}}
    assert [list(e.absolute_path) for e in val.iter_errors(bad)] == [["sensors", "accelerometer", "vrw_ug_rt_hz"]]
