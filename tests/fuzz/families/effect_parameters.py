"""The ``effects:`` list of an IMU file parameter by parameter (issue 40): every catalogue effect's parameters
misspelt (refused with the allowed keys and the closest), out of range (1e30, -1e30), of the wrong type, on an
axis the unit lacks, twice on one axis, and legal forms; axis_coupling's own parameters too."""

from __future__ import annotations

from . import Family
from ._listed import CHANNELS, pick, run_command, scenario, scenario_made, validate_scenario

#: A legal item of each catalogue effect (its required parameters at typical values).
LEGAL = {"piezo_lag": {"tau_s": 1.0e-4}, "axis_coupling": {"coefficients": {"x": {"y": 0.01}}},
         "block_mode": {"frequency_hz": 1500.0, "zeta": 0.05, "gain": 0.01},
         "viscous_damping": {"zeta": 0.001}, "resonance_drift": {"rate_hz_per_s": 0.1},
         "readout_delay": {"delay_s": 1.0e-5}, "scale_factor": {"error": 1.0e-3},
         "lock_in": {"threshold_rad_s": 2.0e-3, "phase_rad": 0.3}}


def _cases() -> list:
    out = []
    for name, params in LEGAL.items():
        if name == "axis_coupling":  # refused in missions: the block section couples the axes there
            out.append(("effect_out_of_range", "invalid", "axis_coupling in a mission", [{"name": name, **params}]))
        else:
            out.append(("effect_valid", "valid", f"{name} {params}", [{"name": name, **params}]))
        for key in (k for k in params if k != "coefficients"):
            out.append(("effect_misspelt", "invalid", f"{name}.{key} misspelt",
                        [{"name": name, **{k: v for k, v in params.items() if k != key}, key[:-1]: params[key]}]))
            for bad in (1.0e30, -1.0e30, "0.1", True, [1.0]):
                out.append(("effect_out_of_range", "invalid", f"{name}.{key} = {bad!r}",
                            [{"name": name, **params, key: bad}]))
    out += [
        ("effect_misspelt", "invalid", "axis_coupling.coefficient", [{"name": "axis_coupling",
                                                                       "coefficient": {"x": {"y": 0.01}}}]),
        ("effect_misspelt", "invalid", "an effect name misspelt", [{"name": "piezo_lagg", "tau_s": 1.0e-4}]),
        ("effect_misspelt", "invalid", "the name as a list", [{"name": ["piezo_lag"], "tau_s": 1.0e-4}]),
        ("effect_misspelt", "invalid", "no name", [{"tau_s": 1.0e-4}]),
        ("effect_out_of_range", "invalid", "a coupling of 5", [{"name": "axis_coupling", "coefficients": {"x": {"y": 5.0}}}]),
        ("effect_out_of_range", "invalid", "a coupling into axis q",
         [{"name": "axis_coupling", "coefficients": {"q": {"x": 0.01}}}]),
        ("effect_out_of_range", "invalid", "a coupling of an axis to itself",
         [{"name": "axis_coupling", "coefficients": {"x": {"x": 0.01}}}]),
        ("effect_out_of_range", "invalid", "axes: [w]", [{"name": "piezo_lag", "tau_s": 1.0e-4, "axes": ["w"]}]),
        ("effect_out_of_range", "invalid", "axes as text", [{"name": "piezo_lag", "tau_s": 1.0e-4, "axes": "x"}]),
        ("effect_out_of_range", "invalid", "piezo_lag twice on every axis",
         [{"name": "piezo_lag", "tau_s": 1.0e-4}, {"name": "piezo_lag", "tau_s": 2.0e-4}]),
        ("effect_out_of_range", "invalid", "lock_in twice on x",
         [{"name": "lock_in", "threshold_rad_s": 2e-3, "axes": ["x"]},
          {"name": "lock_in", "threshold_rad_s": 3e-3, "axes": ["x", "y"]}]),
        ("effect_valid", "valid", "lock_in on x and another on y",
         [{"name": "lock_in", "threshold_rad_s": 2e-3, "axes": ["x"]},
          {"name": "lock_in", "threshold_rad_s": 3e-3, "axes": ["y"]}]),
    ]
    return out


def _made(cls, expect, what, effects):
    return lambda: scenario_made(cls, expect, f"effects: {what}", scenario({"channels": CHANNELS, "effects": effects}))


CASES = [_made(*c) for c in _cases()]

FAMILY = Family(kind="effect_parameters", weight=0.02, classes=("effect_valid", "effect_misspelt", "effect_out_of_range"),
                make=lambda rng: pick(CASES, rng), command=run_command, validate=validate_scenario)
