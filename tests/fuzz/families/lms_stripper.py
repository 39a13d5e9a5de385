"""The three-axis LMS stripper's inputs (issue 28, item 4): the IMU file's ``pickoff`` and ``lms_stripper`` sections
with a scenario that navigates ``lms_stripper``. Valid settings run without NaN or divergence; a step at or beyond
the normalised-LMS bound (``0 < mu < 2``), a cross-coupling the coils cannot invert, or a band outside the filter
rate is refused with one line naming the key."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}


def _coupling(rng: random.Random, spread: float) -> list:
    return [[(1.0 if i == j else 0.0) + rng.uniform(-spread, spread) for j in range(3)] for i in range(3)]


def _valid(rng: random.Random) -> tuple[dict, dict, str]:
    pickoff = {"gain_error": round(rng.uniform(-0.1, 0.1), 4), "lag_s": rng.choice([0.0, 2e-6, 2e-5]),
               "noise_v": rng.choice([0.0, 5e-4, 5e-3]), "nonlinearity_per_rad2": rng.choice([0.0, 500.0, -500.0]),
               "cross_coupling": _coupling(rng, rng.choice([0.0, 0.02, 0.1]))}
    lms = {"mu": rng.choice([1e-3, 0.05, 0.5, 1.0, 1.9]), "adapt_band": rng.choice(["highpass", "dither"])}
    if rng.random() < 0.5:
        lms["highpass_hz"] = rng.choice([5.0, 50.0, 200.0])
    if rng.random() < 0.3:
        lms["band_hz"] = rng.choice([0.5, 2.0, 40.0])
    return pickoff, lms, f"mu {lms['mu']:g}, {lms['adapt_band']}"


#: (what, section, key, value): each one invalid on its own
_INVALID = [
    ("mu at the bound", "lms_stripper", "mu", 2.0),
    ("mu beyond the bound", "lms_stripper", "mu", 3.5),
    ("mu zero", "lms_stripper", "mu", 0.0),
    ("high-pass above Nyquist", "lms_stripper", "highpass_hz", 5000.0),
    ("leak above the high-pass", "lms_stripper", "leak_hz", 60.0),
    ("unknown adaptation band", "lms_stripper", "adapt_band", "notch"),
    ("band wider than the dither", "lms_stripper", "band_hz", 500.0),
    ("singular cross-coupling", "pickoff", "cross_coupling", [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
    ("cross-coupling 2x3", "pickoff", "cross_coupling", [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    ("gain error -1", "pickoff", "gain_error", -1.0),
    ("scale zero", "pickoff", "scale_v_per_rad_s", 0.0),
]


def _make(rng: random.Random) -> Made:
    pickoff, lms, what = _valid(rng)
    expect, cls = "valid", "lms_settings"
    if rng.random() < 0.5:
        what, section, key, value = rng.choice(_INVALID)
        if key == "band_hz":
            lms["adapt_band"] = "dither"
        if key == "leak_hz":  # above this corner, whatever the valid draw chose
            lms["highpass_hz"] = 50.0
        (pickoff if section == "pickoff" else lms)[key] = value
        expect, cls = "invalid", "lms_refused"
    imu = {"channels": CHANNELS, "pickoff": pickoff, "lms_stripper": lms}
    duration = rng.choice([0.05, 0.2, 0.5])
    doc = {"name": "lms", "seed": rng.randrange(100), "duration_s": duration, "imu": imu,
           "motion": [{"type": "static"}], "filters": ["ideal", "correcting", "lms_stripper"],
           "navigation": {"start_s": 0.0}, "outputs": {"plots": False, "timeseries": False}}
    return Made(cls, expect, f"lms stripper: {what}", {"scenario.yaml": yaml.safe_dump(doc).encode()},
                "scenario.yaml")


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="lms_stripper", weight=0.03, classes=("lms_settings", "lms_refused"), make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
