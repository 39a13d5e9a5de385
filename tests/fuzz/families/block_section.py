"""The IMU file's ``block:`` section key by key (issue 40): every key missing, misspelt, of the wrong type, out of
its range or on the wrong axis, and the legal forms (no block, ``block: null``, offsets across the axis, a free
block). Each refusal names the key path under ``imu.block``."""

from __future__ import annotations

import copy

from . import Family
from ._listed import CHANNELS, pick, run_command, scenario, scenario_made, validate_scenario

BLOCK = {"mass_kg": 3.0, "inertia_kg_m2": {"xx": 0.012, "yy": 0.013, "zz": 0.015},
         "gyro_inertia_kg_m2": [2.0e-4, 2.0e-4, 2.0e-4],
         "isolators": {"stiffness_n_per_m": [7.58e5] * 3, "damping_n_s_per_m": [151.0] * 3,
                       "rotational_stiffness_n_m_per_rad": [4737.0, 5132.0, 5922.0],
                       "rotational_damping_n_m_s_per_rad": [0.754, 0.817, 0.942]}}


def _with(**changes) -> dict:
    """The block with ``changes`` (``a__b``: key b under a; None removes the key)."""
    block = copy.deepcopy(BLOCK)
    for path, value in changes.items():
        node, keys = block, path.split("__")
        for k in keys[:-1]:
            node = node.setdefault(k, {})
        if value is None:
            node.pop(keys[-1], None)
        else:
            node[keys[-1]] = value
    return block


#: (class, expect, what, block value)
_CASES = [
    ("block_key_valid", "valid", "the block", BLOCK),
    ("block_key_valid", "valid", "block: null (a rigid block)", None),
    ("block_key_valid", "valid", "an input axis 2 mrad off across it", _with(gyro_axes_mrad={"y": [2.0, 0.0, 0.0]})),
    ("block_key_valid", "valid", "a free block (no isolator stiffness)",
     _with(isolators__stiffness_n_per_m=[0.0] * 3, isolators__rotational_stiffness_n_m_per_rad=[0.0] * 3)),
    ("block_key_valid", "valid", "the elastic centre 30 mm below the c.g.",
     _with(isolators__elastic_centre_mm=[0.0, 0.0, 30.0])),
    ("block_key_refused", "invalid", "mass_kg missing", _with(mass_kg=None)),
    ("block_key_refused", "invalid", "mass_kg misspelt", _with(mass_kg=None, mas_kg=3.0)),
    ("block_key_refused", "invalid", "mass_kg zero", _with(mass_kg=0.0)),
    ("block_key_refused", "invalid", "mass_kg 1e6", _with(mass_kg=1.0e6)),
    ("block_key_refused", "invalid", "mass_kg as text", _with(mass_kg="3 kg")),
    ("block_key_refused", "invalid", "inertia as a number", _with(inertia_kg_m2=0.012)),
    ("block_key_refused", "invalid", "inertia without zz", _with(inertia_kg_m2__zz=None)),
    ("block_key_refused", "invalid", "inertia violating the triangle inequality", _with(inertia_kg_m2__zz=0.03)),
    ("block_key_refused", "invalid", "gyro_inertia of two values", _with(gyro_inertia_kg_m2=[2.0e-4, 2.0e-4])),
    ("block_key_refused", "invalid", "gyro_inertia 1 kg m^2", _with(gyro_inertia_kg_m2=[1.0] * 3)),
    ("block_key_refused", "invalid", "an offset along its own axis", _with(gyro_axes_mrad={"x": [1.0, 0.0, 0.0]})),
    ("block_key_refused", "invalid", "an offset for axis w", _with(gyro_axes_mrad={"w": [0.0, 1.0, 0.0]})),
    ("block_key_refused", "invalid", "an offset of 2 components", _with(gyro_axes_mrad={"x": [0.0, 1.0]})),
    ("block_key_refused", "invalid", "an offset of 60 mrad", _with(gyro_axes_mrad={"x": [0.0, 60.0, 0.0]})),
    ("block_key_refused", "invalid", "isolators missing", _with(isolators=None)),
    ("block_key_refused", "invalid", "isolator stiffness negative", _with(isolators__stiffness_n_per_m=[-1.0] * 3)),
    ("block_key_refused", "invalid", "isolator damping NaN",
     _with(isolators__damping_n_s_per_m=[float("nan"), 151.0, 151.0])),
    ("block_key_refused", "invalid", "isolator key misspelt", _with(isolators__stifness_n_per_m=[7.58e5] * 3)),
    ("block_key_refused", "invalid", "the elastic centre 1 km away", _with(isolators__elastic_centre_mm=[1.0e6, 0, 0])),
    ("block_key_refused", "invalid", "block as a list", [1.0, 2.0]),
    ("block_key_refused", "invalid", "block empty", {}),
]


def _made(cls, expect, what, block):
    imu = {"channels": CHANNELS, "block": copy.deepcopy(block)}
    return lambda: scenario_made(cls, expect, f"block: {what}", scenario(imu))


CASES = [_made(*c) for c in _CASES]

FAMILY = Family(kind="block_section", weight=0.02, classes=("block_key_valid", "block_key_refused"),
                make=lambda rng: pick(CASES, rng), command=run_command, validate=validate_scenario)
