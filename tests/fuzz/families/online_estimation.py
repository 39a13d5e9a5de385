"""The online estimator's inputs (issue 29): ``filter_parameters: {source: online, online: {...}}`` with the drive's
amplitude-modulation schedule. Valid settings run (the estimator's guards keep every parameter finite); online
without modulation, online keys under another source, a window longer than the interval, a forgetting time or
update interval out of range and an unknown schedule are refused with one line naming the key."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}


def _valid(rng: random.Random) -> tuple[dict, dict, str]:
    online = {"forgetting_s": rng.choice([0.05, 0.5, 5.0, 100.0]), "update_s": rng.choice([0.001, 0.01, 0.1, 1.0]),
              "smoothing_s": rng.choice([0.0, 0.05, 2.0])}
    cycles = rng.choice([1, 2, 4, 8])
    online["interval_cycles"] = cycles
    online["window_cycles"] = rng.randint(1, cycles)
    if rng.random() < 0.3:
        online["band"] = rng.choice([0.01, 0.2, 0.99])
    if rng.random() < 0.3:
        online["k_prior"] = rng.choice([0.01, 1.0, 10.0])
    drive = {"modulation_depth": rng.choice([0.001, 0.05, 0.5]), "modulation": rng.choice(["random", "steps", "sine"]),
             "modulation_period_s": rng.choice([0.01, 0.3, 2.0])}
    return online, drive, (f"forgetting {online['forgetting_s']:g} s, update {online['update_s']:g} s, "
                           f"{drive['modulation']} {drive['modulation_depth']:g}")


#: (what, where, key, value): each one invalid on its own
_INVALID = [
    ("no modulation", "drive", "modulation_depth", 0.0),
    ("unknown schedule", "drive", "modulation", "chirp"),
    ("period zero", "drive", "modulation_period_s", 0.0),
    ("window longer than the interval", "online", "window_cycles", 9),
    ("forgetting zero", "online", "forgetting_s", 0.0),
    ("update negative", "online", "update_s", -0.1),
    ("band 1", "online", "band", 1.0),
    ("cycles not an integer", "online", "interval_cycles", 2.5),
    ("online keys under nominal", "fp", "source", "nominal"),
    ("f0 given", "fp", "f0", "given"),
]


def _make(rng: random.Random) -> Made:
    online, drive, what = _valid(rng)
    fp = {"source": "online", "track": rng.random() < 0.5, "online": online}
    expect, cls = "valid", "online_settings"
    if rng.random() < 0.5:
        what, where, key, value = rng.choice(_INVALID)
        {"drive": drive, "online": online, "fp": fp}[where][key] = value
        if key == "window_cycles":
            online["interval_cycles"] = 8
        expect, cls = "invalid", "online_refused"
    imu = {"channels": CHANNELS, "drive": drive, "filter_parameters": fp}
    duration = rng.choice([0.05, 0.2, 1.0])
    doc = {"name": "online", "seed": rng.randrange(100), "duration_s": duration, "imu": imu,
           "motion": [{"type": "static"}], "filters": ["ideal", "correcting", "correcting_paper"],
           "navigation": {"start_s": 0.0}, "outputs": {"plots": False, "timeseries": False}}
    return Made(cls, expect, f"online estimation: {what}", {"scenario.yaml": yaml.safe_dump(doc).encode()},
                "scenario.yaml")


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="online_estimation", weight=0.03, classes=("online_settings", "online_refused"), make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
