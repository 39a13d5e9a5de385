"""The filtered-noise generator key (issue 26, item 2): ``generator`` on ``random_vibration`` and on a
``linear_vibration`` of type ``random``. Either legal name runs; a misspelt one, or one beside ``method: tones``
other than the default, is refused in one line naming the key."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

IMU = {"channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}}
LEGAL = ("decimated_noise", "node_rate_noise")
MISSPELT = ("fft", "Decimated_noise", "node-rate-noise", "", "recursive")


def _make(rng: random.Random) -> Made:
    cls = rng.choice(("legal", "misspelt", "tones_with_generator"))
    f_hi = rng.choice([200.0, 1000.0, 2000.0])
    angular = {"type": "random_vibration", "psd_deg2_s2_per_hz": [[20.0, 1e-6], [f_hi, 1e-6]],
               "f_lo_hz": 20.0, "f_hi_hz": f_hi}
    linear = {"type": "random", "psd_g2_per_hz": [[20.0, 0.002], [f_hi, 0.002]], "f_lo_hz": 20.0, "f_hi_hz": f_hi}
    expect, where = "valid", rng.choice(("motion", "linear", "both"))
    if cls == "legal":
        name = rng.choice(LEGAL)
    elif cls == "misspelt":
        name, expect = rng.choice(MISSPELT), "invalid"
    else:
        angular["method"], where = "tones", "motion"
        name = rng.choice(LEGAL)
        expect = "valid" if name == LEGAL[0] else "invalid"
    if where in ("motion", "both"):
        angular["generator"] = name
    if where in ("linear", "both"):
        linear["generator"] = name
    doc = {"name": "generator", "seed": rng.randrange(1000), "duration_s": rng.choice([0.05, 0.2]), "imu": IMU,
           "motion": [angular], "linear_vibration": [linear], "navigation": {"start_s": 0.0}}
    what = f"generator {name!r} on {where}" + (" with method: tones" if cls == "tones_with_generator" else "")
    return Made(cls, expect, what, {"scenario.yaml": yaml.safe_dump(doc).encode()}, "scenario.yaml")


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="vibration_generator", weight=0.03, classes=("legal", "misspelt", "tones_with_generator"),
                make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
