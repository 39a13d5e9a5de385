"""Families whose cases are a fixed list (issue 40): each family module lists every case it makes, so that a test
can run all of them (``tests/fuzz/test_fuzz_listed.py``) while the seeded generator draws from the same list."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Made

CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}


def scenario(imu: dict | None = None, filters=("ideal", "correcting"), nav: dict | None = None, motion=None,
             duration_s: float = 0.2) -> dict:
    """A short scenario: the unit ``imu`` (default: three channels) at rest, navigation from a quarter in."""
    return {"name": "fuzz-listed", "seed": 3, "duration_s": duration_s, "imu": imu or {"channels": CHANNELS},
            "motion": motion or [{"type": "static"}], "filters": list(filters),
            "navigation": {"start_s": round(0.25 * duration_s, 6), **(nav or {})},
            "outputs": {"plots": False, "timeseries": False}}


def scenario_made(cls: str, expect: str, what: str, doc: dict) -> Made:
    return Made(cls, expect, what, {"scenario.yaml": yaml.safe_dump(doc, sort_keys=False).encode()}, "scenario.yaml")


def pick(cases: list, rng: random.Random) -> Made:
    """One of ``cases`` (a list of zero-argument functions returning a Made)."""
    return rng.choice(cases)()


def run_command(folder: Path) -> list:
    return ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"]


def validate_scenario(folder: Path) -> None:
    """What ``sins-sim run`` checks before its engine starts."""
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))
