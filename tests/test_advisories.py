"""Warnings an engineer needs (issue 22, points 7 and 8): vibration against stop bands and dithers, drives off
their operating point, trajectory files in radians, runs longer than their trajectory, errors naming the key."""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import integrate, signal

from sins_sim.cli import main
from sins_sim.io.trajectory import TrajectoryData, read_trajectory, write_trajectory
from sins_sim.plan import advisories
from sins_sim.config.imu import imu_from_dict
from sins_sim.config.scenario import load_scenario
from sins_sim.config.errors import ConfigError
from sins_sim.units import ARCMIN, ARCSEC, DEG

ROOT = Path(__file__).resolve().parents[1]
FLIGHT = ROOT / "scenarios" / "trajectories" / "short-flight.csv"


def _imu(y_f0_hz=374.0):
    """The bundled unit with the y resonance moved so that its dither (the drive at F(a)) sits near 372 Hz."""
    doc = yaml.safe_load((ROOT / "configs" / "default-imu.yaml").read_text())
    doc["channels"]["y"]["f0_hz"] = y_f0_hz
    return doc


def _scenario(tmp_path, motion, name="s.yaml", **extra):
    doc = {"name": "t", "duration_s": 1.3, "imu": _imu(), "motion": motion, "navigation": {"start_s": 1.0},
           "outputs": {"plots": False, "timeseries": False}, **extra}
    p = tmp_path / name
    p.write_text(yaml.safe_dump(doc))
    return p


def _load(path, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scenario(path, **kw)
    return sc, [str(w.message) for w in caught]


def _line(f_hz, amp_arcmin=2.0):
    amp = [0.0, amp_arcmin, 0.0]
    return [{"type": "sines", "amplitude_arcmin": amp, "frequency_hz": [0.0, f_hz, 0.0]}]


# --- vibration -------------------------------------------------------------------------------------------
def test_line_at_380_hz_near_the_372_hz_y_dither_warns_with_the_numbers(tmp_path):
    sc, msgs = _load(_scenario(tmp_path, _line(380.0)))
    ch = sc.imu.channels[1]
    fd = ch.drive_signal().frequency_hz
    assert abs(fd - 372.0) < 0.5  # the stated case: the y dither at 372 Hz
    hits = [m for m in msgs if m.startswith("vibration line 380 Hz on y")]
    assert len(hits) == 1, msgs
    msg = hits[0]
    # inside the eliminator's band: the band is centred on the dither, 40 Hz wide (configs/default-imu.yaml);
    # the gain at 380 Hz from scipy's own design of that elliptic band-stop
    lo, hi = fd - 20.0, fd + 20.0
    assert f"({lo:.0f}-{hi:.0f} Hz" in msg
    sos = signal.ellip(5, 0.1, 60.0, [lo, hi], btype="bandstop", fs=7200.0, output="sos")
    _, h = signal.sosfreqz(sos, worN=[380.0], fs=7200.0)
    gain_db = 20.0 * math.log10(abs(h[0]))
    assert gain_db < -40.0  # removed: the line sits in the 60 dB stop band
    assert f"gain {gain_db:.0f} dB at 380 Hz" in msg
    # the distance in resonance bandwidths f0/Q with Q from eq. 16, 1/Q = k3 (1 + k4 a), computed here
    a = 3.0 * ARCMIN
    bw = 374.0 * 4.4e-3 * (1.0 + 250.0 * a)
    assert f"= {(380.0 - fd) / bw:.2g} resonance bandwidths f0/Q = {bw:.3g} Hz" in msg
    assert "the y eliminator" in msg and "y dither" in msg


def test_line_far_from_any_stop_band_and_dither_is_silent(tmp_path):
    _, msgs = _load(_scenario(tmp_path, _line(150.0)))
    assert not [m for m in msgs if "vibration" in m]


def test_line_below_one_readout_quantum_is_silent(tmp_path):
    # 0.1 arcsec < the 0.151 arcsec quantum: under what the readout resolves
    _, msgs = _load(_scenario(tmp_path, _line(380.0, amp_arcmin=0.1 / 60.0)))
    assert not [m for m in msgs if "vibration" in m]


def test_line_just_outside_the_band_warns_only_for_the_dither_zone(tmp_path):
    # a 6 Hz eliminator (369-375 Hz) leaves 382 Hz outside its band, but 382 Hz is still within 10 bandwidths
    # (10 x 2 Hz) of the 372 Hz dither: only the dither-zone reason is given
    imu = _imu()
    imu["eliminator"] = {"width_hz": 6.0}
    doc = {"name": "t", "duration_s": 1.3, "imu": imu, "motion": _line(382.0), "navigation": {"start_s": 1.0}}
    p = tmp_path / "n.yaml"
    p.write_text(yaml.safe_dump(doc))
    _, msgs = _load(p)
    hits = [m for m in msgs if m.startswith("vibration line 382 Hz on y")]
    assert len(hits) == 1 and "eliminator" not in hits[0] and "resonance bandwidths" in hits[0]


def test_random_band_in_the_stop_band_reports_the_lost_angle(tmp_path):
    psd = 1.0e-3  # (deg/s)^2/Hz, flat
    motion = [{"type": "random_vibration", "psd_deg2_s2_per_hz": [[20, psd], [2000, psd]], "f_lo_hz": 20,
               "f_hi_hz": 2000, "axes": [0.0, 1.0, 0.0]}]
    sc, msgs = _load(_scenario(tmp_path, motion))
    hits = [m for m in msgs if m.startswith("random vibration 20-2000 Hz on y")]
    assert len(hits) == 1 and not [m for m in msgs if " on x " in m or " on z " in m]
    lo, hi = sc.imu.channels[1].eliminator_design().band_hz
    # angle PSD = rate PSD / (2 pi f)^2, integrated by scipy's quad over the band
    var, _ = integrate.quad(lambda f: psd * DEG ** 2 / (2 * math.pi * f) ** 2, lo, hi)
    assert f"puts {math.sqrt(var) / ARCSEC:.3g} arcsec RMS into the y eliminator's stop band" in hits[0]


def test_bundled_scenarios_load_without_new_warnings():
    """Only random-vibration.yaml warns: its 1e-3 (deg/s)^2/Hz puts ~0.3 arcsec RMS (two readout quanta) into
    each eliminator band, which the eliminator removes with the dither; and pseudo-coning-300hz-tuned.yaml, whose
    eq. 5 filter-tuned designs fall back to two-sample; and helicopter-unit.yaml, whose online estimators on a block
    learn the block's counter-rotation (told once, with each axis's value)."""
    for path in sorted((ROOT / "scenarios").glob("*.yaml")):
        if path.name.startswith("sweep-"):
            continue
        _, msgs = _load(path)
        if path.name == "random-vibration.yaml":
            assert [m.split(" (")[0] for m in msgs] == [f"random vibration 20-2000 Hz on {ax}" for ax in "xyz"]
        elif path.name == "pseudo-coning-300hz-tuned.yaml":
            # eq. 5's 200-300 Hz designs leave more of the coning rate over 0-3600 Hz than they remove in their band
            # (docs/theory/navigation.md): both forms navigate two-sample, the eliminator keeps its tuned design
            assert [m.split(" (")[0] for m in msgs] == [
                f"navigation.coning: filter_tuned over 200-300 Hz is ill-conditioned for the filter {n}"
                for n in ("correcting", "correcting_paper")]
        elif path.name == "helicopter-unit.yaml":
            assert [m.split(" (")[0] for m in msgs] == [
                "filter_parameters.source: online with imu.block: each estimator learns the gyro as the block "
                "presents it, its readout carrying the block's counter-rotation"]
        else:
            assert msgs == [], (path.name, msgs)


def test_cli_prints_the_configuration_warning_before_the_engine_runs_and_once(tmp_path, capsys, monkeypatch):
    import sins_sim.simulation.sins as sins_mod

    def engine(*args, **kwargs):  # the engine never starts: what is printed came before it
        raise RuntimeError("engine stopped by the test")

    monkeypatch.setattr(sins_mod, "simulate_sins", engine)  # run_scenario imports it once the scenario is valid
    rc = main(["run", str(_scenario(tmp_path, _line(380.0))), "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1
    assert [i for i, e in enumerate(err) if e.startswith("warning: vibration line 380 Hz on y")] == [0]
    assert "engine stopped by the test" in err[-1]


# --- drives ----------------------------------------------------------------------------------------------
def _drives(imu, amp_factor=(1.0, 1.0, 1.0), vm_factor=(1.0, 1.0, 1.0)):
    out = []
    for ax, ch, fa, fv in zip("xyz", imu.channels, amp_factor, vm_factor):
        a = ch.drive.amplitude_rad
        vm = -a / (ch.suspension.k5 / ch.suspension.inverse_q(a))  # eq. 17: V_m = -a / (Q k5)
        out.append({"axis": ax, "amplitude_target_rad": a, "amplitude_measured_rad": fa * a,
                    "v_m_initial": vm, "v_m_final": fv * vm})
    return out


def test_drive_off_its_amplitude_target_and_voltage_warns():
    imu = imu_from_dict(_imu(352.0), "imu.yaml")
    msgs = advisories.drive_advisories(_drives(imu, amp_factor=(1.0, 3.1 / 3.0, 1.0), vm_factor=(1.0, 1.0, 0.94)),
                                       imu, 10.0)
    assert len(msgs) == 2
    assert msgs[0].startswith("drive y: dither amplitude 3.1 arcmin against its target 3 arcmin (+3.3 %")
    assert msgs[1].startswith("drive z: V_m = ") and "-6.0 % off the eq. 17 voltage" in msgs[1]


def test_a_modulated_drive_is_judged_on_its_amplitude_not_its_voltage():
    """With drive.modulation_depth > 0 the target jumps every control block, faster than the loop settles, so V_m
    at the end is no equilibrium: a 12 % voltage offset (what the bundled 5 % modulated units end with) is not
    judged, while an amplitude beyond 1 % + depth still is, and the same voltage offset unmodulated warns."""
    doc = _imu(352.0)
    doc["drive"] = dict(doc.get("drive", {}), modulation_depth=0.05)
    imu = imu_from_dict(doc, "imu.yaml")
    assert advisories.drive_advisories(_drives(imu, (1.0, 1.0, 1.0), (0.88, 1.12, 1.0)), imu, 10.0) == []
    msgs = advisories.drive_advisories(_drives(imu, (1.0, 1.07, 1.0), (1.0, 1.0, 1.0)), imu, 10.0)
    assert len(msgs) == 1 and msgs[0].startswith("drive y: dither amplitude")
    plain = imu_from_dict(_imu(352.0), "imu.yaml")
    assert len(advisories.drive_advisories(_drives(plain, (1.0, 1.0, 1.0), (0.88, 1.12, 1.0)), plain, 10.0)) == 2


def test_a_drive_still_pulling_in_is_not_judged():
    """A run of fewer than DRIVE_SETTLE_LOOPS amplitude-loop periods (the default loop: 0.1 s) ends while the loop
    is still pulling the dither in (+12.5 % after 0.3 s, measured): no drive warning then, the same drives warn
    once the run is long enough."""
    imu = imu_from_dict(_imu(352.0), "imu.yaml")
    drives = _drives(imu, amp_factor=(1.125, 1.125, 1.125), vm_factor=(1.066, 1.066, 1.066))
    assert advisories.drive_advisories(drives, imu, 0.3) == []
    assert advisories.drive_advisories(drives, imu, 0.1 * advisories.DRIVE_SETTLE_LOOPS - 1e-9) == []
    assert len(advisories.drive_advisories(drives, imu, 0.1 * advisories.DRIVE_SETTLE_LOOPS)) == 6


def test_drive_within_tolerance_is_silent():
    imu = imu_from_dict(_imu(352.0), "imu.yaml")
    # 0.5 % in amplitude and 2 % in V_m: inside the stated 1 % and 3 %
    assert advisories.drive_advisories(_drives(imu, (1.005, 0.995, 1.0), (1.02, 0.98, 1.0)), imu, 10.0) == []


def test_default_run_has_no_warnings_and_the_380_hz_line_reaches_metrics(tmp_path):
    from sins_sim.jobs.run import run_scenario

    out = tmp_path / "stationary"
    m = run_scenario(ROOT / "scenarios" / "stationary.yaml", out, overrides={"duration_s": 1.5})
    assert m["warnings"] == []  # the bundled unit's drives sit on their target and their eq. 17 voltage
    p = _scenario(tmp_path, _line(380.0))
    with pytest.warns(UserWarning, match=r"vibration line 380 Hz on y"):  # told before the engine runs
        m = run_scenario(p, tmp_path / "line")
    saved = json.loads((tmp_path / "line" / "metrics.json").read_text())
    assert [w for w in saved["warnings"] if w.startswith("vibration line 380 Hz on y")]
    report = (tmp_path / "line" / "report.md").read_text()
    assert "## Warnings" in report and "vibration line 380 Hz on y" in report


# --- trajectory files ------------------------------------------------------------------------------------
def _rewrite(tmp_path, name, **scale):
    """short-flight.csv with some angle columns written in radians (the slip), without velocity columns."""
    d = read_trajectory(FLIGHT)
    fields = {}
    for f in ("lat_rad", "lon_rad", "roll_rad", "pitch_rad", "yaw_rad"):
        arr = np.asarray(getattr(d, f))
        fields[f] = arr * DEG if f in scale.get("radians", ()) else arr  # the file then holds rad as "deg"
    fields["yaw_rad"] = fields["yaw_rad"] + math.radians(scale.get("yaw_offset_deg", 0.0))
    data = TrajectoryData(t_s=d.t_s, h_m=d.h_m, v_ned_m_s=d.v_ned_m_s if scale.get("velocity") else None, **fields)
    return write_trajectory(tmp_path / name, data)


def _file_scenario(tmp_path, csv, duration_s=100.0):
    doc = {"name": "t", "duration_s": duration_s, "imu": str(ROOT / "configs" / "default-imu.yaml"),
           "trajectory": {"file": csv.name}, "navigation": {"start_s": 1.0}}
    p = tmp_path / "f.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def test_bundled_flight_log_passes_silently(tmp_path):
    assert advisories.trajectory_advisories(read_trajectory(FLIGHT), "short-flight.csv") == []


def test_trajectory_csv_in_radians_is_refused(tmp_path):
    csv = _rewrite(tmp_path, "rad.csv", radians=("lat_rad", "lon_rad", "roll_rad", "pitch_rad", "yaw_rad"))
    with pytest.raises(ConfigError, match=r"f\.yaml:\d+:\d+: trajectory\.file \(rad\.csv\): columns lat_deg, lon_deg, "
                                          r"roll_deg, yaw_deg look like radians") as info:
        load_scenario(_file_scenario(tmp_path, csv))
    assert "\n" not in str(info.value) and "multiply radians by 180/pi" in str(info.value)


@pytest.mark.parametrize("columns, velocity, match", [
    # the yaw alone: the ground track fits it only in radians
    (("yaw_rad",), False, r"columns yaw_deg look like radians, not degrees: the ground track from lat_deg/lon_deg "
                          r"differs from yaw_deg"),
    # the roll alone: in the turns it is the coordinated bank atan(v yaw_rate / g) in radians
    (("roll_rad",), False, r"columns roll_deg look like radians, not degrees: in the turns roll_deg is .* where the "
                           r"coordinated bank atan\(v yaw_rate / g\) is"),
    # the positions alone, caught by the velocity columns (the flight's 120-150 m/s)
    (("lat_rad", "lon_rad"), True, r"columns lat_deg, lon_deg look like radians, not degrees: the positions move at "
                                   r"[\d.]+ m/s where the velocity columns \(vn_m_s, ve_m_s\) "
                                   r"say 1[2-5]\d(\.\d*)? m/s"),
])
def test_one_slip_in_radians_is_refused(tmp_path, columns, velocity, match):
    csv = _rewrite(tmp_path, "one.csv", radians=columns, velocity=velocity)
    with pytest.raises(ConfigError, match=match):
        load_scenario(_file_scenario(tmp_path, csv))


def test_velocity_columns_off_the_positions_name_the_columns_and_row(tmp_path):
    d = read_trajectory(FLIGHT)
    data = TrajectoryData(t_s=d.t_s, lat_rad=d.lat_rad, lon_rad=d.lon_rad, h_m=d.h_m, roll_rad=d.roll_rad,
                          pitch_rad=d.pitch_rad, yaw_rad=d.yaw_rad, v_ned_m_s=3.0 * np.asarray(d.v_ned_m_s))
    csv = write_trajectory(tmp_path / "vel.csv", data)
    with pytest.raises(ConfigError, match=r"trajectory\.file \(vel\.csv\): row \d+, column (vn|ve|vd)_m_s: differs from "
                                          r"the velocity of the smoothing fit of the positions \(lat_deg, lon_deg, "
                                          r"height_m\) by \S+ m/s, beyond trajectory\.velocity_tolerance_m_s = 1\.0 "
                                          r".*the velocity columns do not fit the positions") as info:
        load_scenario(_file_scenario(tmp_path, csv))
    assert "SampledTrajectory" not in str(info.value) and "v_tol" not in str(info.value)


def test_yaw_far_from_the_track_but_not_radians_warns(tmp_path):
    csv = _rewrite(tmp_path, "crab.csv", yaw_offset_deg=45.0)
    _, msgs = _load(_file_scenario(tmp_path, csv))
    assert len(msgs) == 1 and msgs[0].startswith("trajectory.file (crab.csv): yaw_deg differs from the ground "
                                                 "track (from lat_deg/lon_deg) by 45 deg")


# --- runs longer than their trajectory -------------------------------------------------------------------
def test_duration_past_the_trajectory_file_is_refused_through_the_cli(tmp_path, capsys):
    rc = main(["run", str(ROOT / "scenarios" / "nav-trajectory-file.yaml"), "--duration", "1300",
               "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert re.search(r"--duration: 1300 s runs past the end of trajectory\.file \(trajectories/short-flight\.csv\), "
                     r"which lasts 300 s .*set --duration <= 299\.9", err[0])


SEGMENTS = {"speed_m_s": 100.0, "segments": [{"type": "cruise", "duration_s": 600},
                                             {"type": "turn", "duration_s": 20, "heading_change_deg": 20},
                                             {"type": "cruise", "duration_s": 600}]}


def test_duration_past_the_segments_is_refused_through_the_cli(tmp_path, capsys):
    p = _scenario(tmp_path, [{"type": "static"}], trajectory=SEGMENTS)
    rc = main(["run", str(p), "--duration", "1300", "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert ("--duration: 1300 s runs past the end of the trajectory's segments, which last 1220 s" in err[0]
            and "trajectory.extend: hold" in err[0])
    with pytest.raises(ConfigError, match=r"s\.yaml:\d+:\d+: duration_s: 1300 s runs past"):
        load_scenario(_scenario(tmp_path, [{"type": "static"}], trajectory=SEGMENTS, duration_s=1300.0))


def test_extend_hold_is_the_explicit_opt_in(tmp_path):
    p = _scenario(tmp_path, [{"type": "static"}], trajectory={**SEGMENTS, "extend": "hold"})
    sc, _ = _load(p, overrides={"duration_s": 1300.0})
    assert sc.vehicle.duration_s >= 1300.1
    assert type(sc.vehicle.segments[-1]).__name__ == "Cruise"  # it ended moving: straight and level
    # a file holds what it holds
    doc = {"name": "t", "duration_s": 10.0, "imu": str(ROOT / "configs" / "default-imu.yaml"),
           "trajectory": {"file": str(FLIGHT), "extend": "hold"}, "navigation": {"start_s": 1.0}}
    p = tmp_path / "e.yaml"
    p.write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match=r"trajectory\.extend: applies to segments only"):
        load_scenario(p)


# --- errors name the key the user wrote ------------------------------------------------------------------
def test_output_rate_error_names_output_rate_hz_and_plant_rate_hz():
    doc = _imu(352.0)
    doc["readout"]["output_rate_hz"] = 7500
    with pytest.raises(ConfigError) as info:
        imu_from_dict(doc, "imu.yaml")
    msg = str(info.value)
    assert msg.startswith("imu.yaml: readout.output_rate_hz: plant.rate_hz / output_rate_hz must be a whole number")
    assert "72000 / 7500 = 9.6" in msg and "7200 or 8000 Hz" in msg and "input_rate_hz" not in msg


def test_anti_alias_error_names_plant_rate_hz():
    doc = _imu(352.0)
    doc["readout"]["anti_alias"]["cutoff_hz"] = 40000.0
    with pytest.raises(ConfigError, match=r"readout\.anti_alias\.cutoff_hz: must be < plant\.rate_hz / 2") as info:
        imu_from_dict(doc, "imu.yaml")
    assert "input_rate_hz" not in str(info.value)


@pytest.mark.parametrize("name, warns", [("correcting_lownoise", True), ("correcting_wideband", False)])
def test_line_above_a_wideband_filters_pass_band_warns(tmp_path, name, warns):
    # sins_sim.filters.wideband: correcting_lownoise is flat to 1.5 kHz, correcting_wideband to 2.6 kHz (at 7.2 kHz)
    _, msgs = _load(_scenario(tmp_path, _line(2000.0, amp_arcmin=0.05), filters=["ideal", name]))
    hits = [m for m in msgs if m.startswith("vibration line 2000 Hz on y")]
    if warns:
        assert len(hits) == 1 and f"lies above {name}'s pass band on y (flat to 1500 Hz, rolled off from 2200 Hz)" \
            in hits[0]
    else:
        assert hits == []
