"""``filter_parameters: {source: online}`` with every filter, in its short form, with the other navigation choices
and with a block (issue 40); misspelt keys and sources are refused naming the key with the closest one."""

from __future__ import annotations

from . import Family
from ._listed import CHANNELS, pick, run_command, scenario, scenario_made, validate_scenario

FILTERS = ("raw", "eliminator", "correcting", "correcting_paper", "correcting_aligned", "correcting_lownoise",
           "correcting_wideband", "lms_stripper")
DRIVE = {"modulation_depth": 0.05}
BLOCK = {"mass_kg": 3.0, "inertia_kg_m2": {"xx": 0.012, "yy": 0.013, "zz": 0.015},
         "gyro_inertia_kg_m2": [2.0e-4] * 3,
         "isolators": {"stiffness_n_per_m": [7.58e5] * 3, "damping_n_s_per_m": [151.0] * 3,
                       "rotational_stiffness_n_m_per_rad": [4737.0, 5132.0, 5922.0],
                       "rotational_damping_n_m_s_per_rad": [0.754, 0.817, 0.942]}}


def _imu(fp, drive=DRIVE, **extra):
    return {"channels": CHANNELS, "drive": dict(drive), "filter_parameters": fp, **extra}


#: (class, expect, what, imu, filters, navigation)
_CASES = [("online_valid", "valid", f"online with {f}", _imu({"source": "online"}), ("ideal", f), None)
          for f in FILTERS]
_CASES += [
    ("online_valid", "valid", "the short form filter_parameters: online", _imu("online"), ("ideal", "correcting"), None),
    ("online_valid", "valid", "online with filter_tuned coning", _imu({"source": "online", "track": True}),
     ("ideal", "correcting"), {"coning": "filter_tuned", "tuned_band_hz": [200.0, 400.0]}),
    ("online_valid", "valid", "online at a 400 Hz navigation rate", _imu({"source": "online"}),
     ("ideal", "correcting"), {"rate_hz": 400.0}),
    ("online_valid", "valid", "online on a block", _imu({"source": "online"}, block=BLOCK), ("ideal", "correcting"),
     None),
    ("online_refused", "invalid", "online misspelt", _imu({"source": "online", "onlien": {}}),
     ("ideal", "correcting"), None),
    ("online_refused", "invalid", "an online key misspelt", _imu({"source": "online", "online": {"forgeting_s": 1.0}}),
     ("ideal", "correcting"), None),
    ("online_refused", "invalid", "source misspelt", _imu({"source": "onlin"}), ("ideal", "correcting"), None),
    ("online_refused", "invalid", "online without modulation", _imu({"source": "online"}, drive={}),
     ("ideal", "correcting"), None),
    ("online_refused", "invalid", "online as a number", _imu({"source": "online", "online": 3.0}),
     ("ideal", "correcting"), None),
    ("online_refused", "invalid", "forgetting_s NaN", _imu({"source": "online", "online": {"forgetting_s": float("nan")}}),
     ("ideal", "correcting"), None),
    ("online_refused", "invalid", "online with filter_tuned and the LMS stripper", _imu({"source": "online"}),
     ("ideal", "lms_stripper"), {"coning": "filter_tuned", "tuned_band_hz": [200.0, 400.0]}),
]


def _made(cls, expect, what, imu, filters, nav):
    return lambda: scenario_made(cls, expect, f"online parameters: {what}", scenario(imu, filters, nav))


CASES = [_made(*c) for c in _CASES]

FAMILY = Family(kind="online_parameters", weight=0.02, classes=("online_valid", "online_refused"),
                make=lambda rng: pick(CASES, rng), command=run_command, validate=validate_scenario)
