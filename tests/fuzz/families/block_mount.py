"""The block on its isolators in missions (issue 27): an IMU ``block:`` section with products of inertia, axis
offsets and an elastic centre off the c.g., under linear vibration entering at the chassis or the block. Legal
variants run; a misspelt ``vibration_enters``, an inertia tensor that is no body (not positive definite, or
violating the triangle inequality of principal moments), a negative isolator stiffness or an axis offset beyond
50 mrad is refused in one line naming the key."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

_CLASSES = ("block_valid", "enters_misspelt", "inertia_not_a_body", "negative_stiffness", "axis_offset_too_large")


def _block(rng: random.Random) -> dict:
    jxy = rng.choice([0.0, 2e-4, -5e-4])
    return {"mass_kg": rng.choice([1.5, 3.0, 6.0]),
            "inertia_kg_m2": {"xx": 0.012, "yy": 0.013, "zz": 0.015, "xy": jxy, "xz": 0.0, "yz": 0.0},
            "gyro_inertia_kg_m2": [2.0e-4, 2.0e-4, 2.0e-4],
            "gyro_axes_mrad": {"y": [rng.choice([0.0, 2.0, -5.0]), 0.0, 0.0]},
            "isolators": {"stiffness_n_per_m": [7.58e5] * 3, "damping_n_s_per_m": [151.0] * 3,
                          "rotational_stiffness_n_m_per_rad": [4737.0, 5132.0, 5922.0],
                          "rotational_damping_n_m_s_per_rad": [0.754, 0.817, 0.942],
                          "elastic_centre_mm": [rng.choice([0.0, 10.0]), 0.0, rng.choice([0.0, 30.0, -20.0])]}}


def _make(rng: random.Random) -> Made:
    cls = rng.choice(_CLASSES)
    block = _block(rng)
    enters = rng.choice(("chassis", "block"))
    expect, what = "invalid", cls
    if cls == "block_valid":
        expect = "valid"
        what = (f"block (J_xy {block['inertia_kg_m2']['xy']:g}, offset {block['isolators']['elastic_centre_mm']} "
                f"mm), vibration at the {enters}")
    elif cls == "enters_misspelt":
        enters = rng.choice(("Chassis", "isolators", "", "mount"))
        what = f"vibration_enters {enters!r}"
    elif cls == "inertia_not_a_body":
        block["inertia_kg_m2"].update(rng.choice(({"xy": 0.02}, {"zz": 0.03}, {"xx": -0.012})))
        what = f"inertia {block['inertia_kg_m2']}"
    elif cls == "negative_stiffness":
        block["isolators"]["rotational_stiffness_n_m_per_rad"][rng.randrange(3)] = -4737.0
        what = "a negative rotational stiffness"
    else:
        block["gyro_axes_mrad"] = {"y": [rng.choice([60.0, -120.0, 1000.0]), 0.0, 0.0]}
        what = f"gyro_axes_mrad {block['gyro_axes_mrad']}"
    imu = {"name": "fuzz-block", "channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}},
           "block": block}
    doc = {"name": "block-mount", "seed": rng.randrange(1000), "duration_s": rng.choice([0.1, 0.3]), "imu": imu,
           "linear_vibration": [{"type": "random", "psd_g2_per_hz": [[20.0, 0.002], [2000.0, 0.002]],
                                 "f_lo_hz": 20.0, "f_hi_hz": 2000.0}],
           "vibration_enters": enters, "navigation": {"start_s": 0.0}}
    return Made(cls, expect, what, {"scenario.yaml": yaml.safe_dump(doc).encode()}, "scenario.yaml")


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="block_mount", weight=0.03, classes=_CLASSES, make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
