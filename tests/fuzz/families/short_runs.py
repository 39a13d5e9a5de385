"""Runs of minimal length with every output on (issue 25, item 7): a mission of 0.01-0.2 s, or a stored series
slower than the run, writes its figures, series and report, and never fails after the simulation."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

IMU = {"channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}}
MOTIONS = [[{"type": "static"}], [{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 100.0}],
           [{"type": "sines", "amplitude_arcmin": [1.0, 0.5, 0.0], "frequency_hz": [60.0, 90.0, 0.0]}]]


def _make(rng: random.Random) -> Made:
    duration = rng.choice([0.01, 0.02, 0.05, 0.1, 0.2, 3.0])
    nav = {"start_s": round(duration * rng.choice([0.0, 0.1, 0.5]), 6)}
    if duration >= 1 or rng.random() < 0.3:
        nav["timeseries_rate_hz"] = rng.choice([0.3, 1.0, 400.0])  # 400 Hz: every update at the default rate
    doc = {"name": "short", "seed": rng.randrange(100), "duration_s": duration, "imu": IMU,
           "motion": rng.choice(MOTIONS), "navigation": nav, "outputs": {"plots": True, "timeseries": True}}
    if rng.random() < 0.5:
        doc["filters"] = ["ideal", "eliminator", "correcting", "correcting_paper", "raw"]
    what = f"short run: {duration:g} s, series at {nav.get('timeseries_rate_hz', 'the default')} Hz"
    return Made("minimal_length", "valid", what, {"scenario.yaml": yaml.safe_dump(doc).encode()}, "scenario.yaml")


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="short_run", weight=0.03, classes=("minimal_length",), make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
