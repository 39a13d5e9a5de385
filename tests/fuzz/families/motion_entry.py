"""Where the angular motion enters with a block on isolators (issue 27, ``motion_enters``): an angular profile (sines
or coning, below and across the rocking modes) at the chassis or at the block, with or without linear vibration at
the chassis. Legal variants run; a misspelt ``motion_enters`` is refused in one line naming the key."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made
from .block_mount import _block, _validate

_CLASSES = ("motion_entry_valid", "motion_enters_misspelt")


def _make(rng: random.Random) -> Made:
    cls = rng.choice(_CLASSES)
    enters = rng.choice(("chassis", "block"))
    motion = rng.choice(([{"type": "sines", "amplitude_arcmin": [1.7, 1.0, 0.0],
                           "frequency_hz": [rng.choice([30.0, 95.0, 250.0]), 47.0, 1.0]}],
                         [{"type": "coning", "amplitude_arcmin": rng.choice([0.3, 3.0]),
                           "frequency_hz": rng.choice([10.0, 110.0])}]))
    expect, what = "valid", f"{motion[0]['type']} at the {enters}"
    if cls == "motion_enters_misspelt":
        enters = rng.choice(("Block", "vehicle", "", "isolators"))
        expect, what = "invalid", f"motion_enters {enters!r}"
    imu = {"name": "fuzz-block", "channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}},
           "block": _block(rng)}
    doc = {"name": "motion-entry", "seed": rng.randrange(1000), "duration_s": rng.choice([0.1, 0.3]), "imu": imu,
           "motion": motion, "motion_enters": enters, "navigation": {"start_s": 0.0}}
    if rng.random() < 0.5:
        doc["linear_vibration"] = [{"type": "sines", "amplitude_m_s2": [9.81, 0.0, 0.0],
                                    "frequency_hz": [60.0, 60.0, 60.0]}]
    return Made(cls, expect, what, {"scenario.yaml": yaml.safe_dump(doc).encode()}, "scenario.yaml")


FAMILY = Family(kind="motion_entry", weight=0.02, classes=_CLASSES, make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
