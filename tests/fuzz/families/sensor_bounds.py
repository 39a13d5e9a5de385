"""Sensor-error values at, inside and beyond their physical ranges, and the edge values of issue 25 items 6 and 11.

``unbounded_sensor_error``: one key of an IMU's ``sensors:`` section (every per-axis key, the misalignment and the
gyro's full-scale rate; :data:`sins_sim.models.sensor_errors.PHYSICAL_RANGES`) at its bound, just inside, at the
lower end, 1 % or 10x beyond, 1e300, -1 or inf, in a 0.05 s run: inside runs (a navigation that diverges is reported
as diverged, exit 0), beyond is refused naming ``sensors.<section>.<key>``.

``edge_values``: a random vibration with all axis weights zero; a shock of 1e-6 ms or of 3 plant steps; a coordinated
turn of 36000 deg in 10 ms or one inside the 200 g / 1000 deg/s bounds; ``compare-filters --json`` into /proc or onto a
folder; ``lockin-study --out`` onto an existing file; a recording whose ``drive_v`` is scaled by 1e30.
"""

from __future__ import annotations

import io
import json
import math
import random
from pathlib import Path

import numpy as np
import yaml

from . import Family, Made

CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}
CASE = "case.json"  # the command line (``{dir}``: the case's folder) and what the fast tier checks


def _run_case(cls, expect, what, doc) -> Made:
    files = {"scenario.yaml": yaml.safe_dump(doc).encode(),
             CASE: json.dumps({"argv": ["run", "{dir}/scenario.yaml", "--out", "{dir}/out", "--quiet"],
                               "check": "scenario"}).encode()}
    return Made(cls, expect, what, files, "scenario.yaml")


def _scenario(imu=None, **extra):
    return {"name": "fuzz", "seed": 1, "duration_s": 0.05, "imu": imu or {"channels": CHANNELS},
            "navigation": {"start_s": 0.0}, **extra}


def _sensor_case(rng: random.Random) -> Made:
    from sins_sim.models.sensor_errors import key_ranges

    section, key, lo, hi, shape = rng.choice(key_ranges())
    label, value = rng.choice([("at the bound", hi), ("just inside", 0.999 * hi), ("at the lower end", lo),
                               ("1 % beyond", 1.01 * hi), ("10x beyond", 10.0 * hi), ("1e300", 1e300),
                               ("-1", -1.0), ("inf", math.inf), ("below the lower end", lo - 0.01 * hi)])
    valid = lo <= value <= hi
    entry = value if shape == 0 else [value] * shape
    imu = {"channels": CHANNELS, "sensors": {section: {key: entry}}}
    return _run_case("unbounded_sensor_error", "valid" if valid else "invalid",
                     f"sensors.{section}.{key} {label} ({value:g}; range [{lo:g}, {hi:g}])", _scenario(imu))


def _recording(scale: float) -> bytes:
    """A minimal valid recording (one axis at rest, a 0.39 V drive), its drive scaled by ``scale``."""
    meta = {"format": "sins-sim-recording/1", "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0,
            "quantum_rad": 7.33e-7, "initial_state": "rest", "experiment": "stationary",
            "nominal": {"x": {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0,
                              "k5": -1.2e-5}}}
    n = 7200
    t = np.arange(n) / 7200.0
    counts = np.round(3.0 * 2.9e-4 / 7.33e-7 * np.sin(2 * np.pi * 386.0 * t)).astype(np.int64)[:, None]
    drive = (0.39 * np.cos(2 * np.pi * 386.0 * t))[:, None] * scale
    buf = io.BytesIO()
    np.savez(buf, meta=np.array(json.dumps(meta)), counts=counts, drive_v=drive)
    return buf.getvalue()


def _turn(speed, change_deg, duration_s, transition_s):
    return _scenario(trajectory={"speed_m_s": speed, "transition_s": transition_s,
                                 "segments": [{"type": "turn", "duration_s": duration_s,
                                               "heading_change_deg": change_deg},
                                              {"type": "cruise", "duration_s": 1.0}]})


_RV = {"type": "random_vibration", "psd_deg2_s2_per_hz": [[10, 1e-4], [1000, 1e-4]], "f_lo_hz": 20, "f_hi_hz": 900}
_SHOCK = {"type": "shock", "axis": [0, 0, 1], "peak_rate_deg_s": 100.0, "start_s": 0.01}


def _edge_case(rng: random.Random) -> Made:
    cls = "edge_values"
    pick = rng.randrange(11)
    if pick == 0:
        return _run_case(cls, "invalid", "random_vibration axes [0, 0, 0]", _scenario(motion=[dict(_RV, axes=[0, 0, 0])]))
    if pick == 1:
        return _run_case(cls, "valid", "random_vibration axes [0, 0, 0.001]",
                         _scenario(motion=[dict(_RV, axes=[0, 0, 0.001])]))
    if pick == 2:
        return _run_case(cls, "invalid", "shock duration_ms 1e-6", _scenario(motion=[dict(_SHOCK, duration_ms=1e-6)]))
    if pick == 3:  # 3 plant steps at 72 kHz = 0.04167 ms
        return _run_case(cls, "valid", "shock duration_ms 0.0417 (3 plant steps)",
                         _scenario(motion=[dict(_SHOCK, duration_ms=0.0417)]))
    if pick == 4:
        return _run_case(cls, "invalid", "turn of 36000 deg in 10 ms", _turn(100.0, 36000.0, 0.01, 0.004))
    if pick == 5:  # 40 deg/s at 50 m/s (35 m/s^2), rolled in over 0.5 s
        return _run_case(cls, "valid", "turn inside the bounds (60 deg in 2 s at 50 m/s)", _turn(50.0, 60.0, 2.0, 0.5))
    if pick == 6:
        return _run_case(cls, "invalid", "pivot turn at 1010 deg/s", _turn(0.0, 505.0, 1.0, 0.5))
    if pick in (7, 8):
        target = "/proc/cf.json" if pick == 7 else "{dir}"
        argv = ["compare-filters", "--out", "{dir}/cf", "--json", target, "--quick", "--quiet"]
        return Made(cls, "invalid", f"compare-filters --json {target}",
                    {CASE: json.dumps({"argv": argv, "check": "json", "path": target}).encode()}, CASE)
    if pick == 9:
        argv = ["lockin-study", "--out", "{dir}/existing", "--quick"]
        return Made(cls, "invalid", "lockin-study --out an existing file",
                    {"existing": b"x", CASE: json.dumps({"argv": argv, "check": "out", "path": "{dir}/existing"}).encode()},
                    CASE)
    argv = ["diagnose", "{dir}/recording.npz", "--json", "{dir}/diagnosis.json"]
    return Made(cls, "invalid", "recording with drive_v x 1e30",
                {"recording.npz": _recording(1e30), CASE: json.dumps({"argv": argv, "check": "recording"}).encode()},
                "recording.npz")


def _make(rng: random.Random) -> Made:
    return _sensor_case(rng) if rng.random() < 0.6 else _edge_case(rng)


def _spec(folder: Path) -> dict:
    return json.loads((folder / CASE).read_text())


def _command(folder: Path) -> list:
    return [a.replace("{dir}", str(folder)) for a in _spec(folder)["argv"]]


def _validate(folder: Path) -> None:
    """What each command checks before it runs anything."""
    spec = _spec(folder)
    check = spec["check"]
    if check == "scenario":
        from sins_sim.config.scenario import load_scenario
        from sins_sim.jobs.estimate import check_run

        check_run(load_scenario(folder / "scenario.yaml"))
    elif check == "json":
        from sins_sim.jobs.output import check_out_file

        check_out_file(spec["path"].replace("{dir}", str(folder)), "--json")
    elif check == "out":
        from sins_sim.jobs.output import check_out_dir

        check_out_dir(spec["path"].replace("{dir}", str(folder)), "--out")
    else:
        from sins_sim.io.recording import read_recording

        read_recording(folder / "recording.npz")


FAMILY = Family(kind="sensor_bounds", weight=0.04, classes=("unbounded_sensor_error", "edge_values"), make=_make,
                command=_command, validate=_validate)
