"""Coning algorithms and the navigation rate (issues 28 and 26): the four-sample and filter-tuned choices with
their design band, and ``navigation.rate_hz``, valid and invalid; a short run with the pseudo-coning or the
coning motion, so the metrics sections they add are written too."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

IMU = {"channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}}
MOTIONS = [[{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 300.0}],
           [{"type": "sines", "amplitude_arcmin": [1.0, 1.0, 0.0], "frequency_hz": [300.0, 300.0, 0.0]}]]
#: (class, expect, navigation keys, what): the filter rate is the default 7.2 kHz
CASES = [
    ("algorithm_choice", "valid", {"coning": "four_sample", "sculling": "four_sample"}, "four-sample"),
    ("tuned_band", "valid", {"coning": "filter_tuned", "tuned_band_hz": [200.0, 400.0]}, "tuned 200-400 Hz"),
    ("tuned_band", "valid", {"sculling": "filter_tuned", "tuned_band_hz": [10.0, 3500.0]}, "tuned sculling"),
    ("tuned_band", "invalid", {"coning": "filter_tuned"}, "filter_tuned without a band"),
    ("tuned_band", "invalid", {"coning": "filter_tuned", "tuned_band_hz": [400.0, 200.0]}, "band reversed"),
    ("tuned_band", "invalid", {"coning": "filter_tuned", "tuned_band_hz": [100.0, 3600.0]}, "band to Nyquist"),
    ("nav_rate", "valid", {"rate_hz": 400.0}, "400 Hz updates"),
    ("nav_rate", "valid", {"rate_hz": 7200.0, "n_sub": 1}, "full rate, both keys"),
    ("nav_rate", "invalid", {"rate_hz": 700.0}, "rate not dividing 7.2 kHz"),
    ("nav_rate", "invalid", {"rate_hz": 400.0, "n_sub": 4}, "rate against n_sub"),
    ("nav_rate", "invalid", {"rate_hz": 14400.0}, "rate above the filter rate"),
]


def _make(rng: random.Random) -> Made:
    cls, expect, nav, what = rng.choice(CASES)
    duration = rng.choice([0.05, 0.1, 0.2])
    doc = {"name": "coning-algorithms", "seed": rng.randrange(100), "duration_s": duration, "imu": IMU,
           "motion": rng.choice(MOTIONS), "filters": ["ideal", "eliminator", "correcting"],
           "navigation": {"start_s": round(0.25 * duration, 6), **nav},
           "outputs": {"plots": False, "timeseries": True}}
    return Made(cls, expect, f"navigation: {what}", {"scenario.yaml": yaml.safe_dump(doc).encode()}, "scenario.yaml")


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="coning_algorithm", weight=0.03, classes=("algorithm_choice", "tuned_band", "nav_rate"),
                make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
