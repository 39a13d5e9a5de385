"""Coning and sculling choices with every filter (issue 40): ``filter_tuned`` designs each filter's coefficients at
load, so it composes with every single-axis filter and is refused with the three-axis LMS stripper in the user's
terms; a design band without ``filter_tuned`` is refused unless a single coning motion's coning table reads it."""

from __future__ import annotations

from . import Family
from ._listed import pick, run_command, scenario, scenario_made, validate_scenario

FILTERS = ("raw", "eliminator", "correcting", "correcting_paper", "correcting_aligned", "correcting_lownoise",
           "correcting_wideband", "lms_stripper")
BAND = [200.0, 400.0]
CONE = [{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 300.0}]
SINES = [{"type": "sines", "amplitude_arcmin": [1.0, 1.0, 0.0], "frequency_hz": [300.0, 300.0, 0.0]}]


def _expect(f):
    return "invalid" if f == "lms_stripper" else "valid"


#: (class, expect, what, filters, navigation, motion)
_CASES = [("coning_choice_tuned", _expect(f), f"coning filter_tuned with {f}", ("ideal", f),
           {"coning": "filter_tuned", "tuned_band_hz": BAND}, SINES) for f in FILTERS]
_CASES += [("coning_choice_tuned", _expect(f), f"sculling filter_tuned with {f}", (f,),
            {"sculling": "filter_tuned", "tuned_band_hz": BAND}, SINES) for f in FILTERS]
_CASES += [
    ("coning_choice_band", "invalid", "a band with two_sample coning", ("ideal", "correcting"),
     {"coning": "two_sample", "tuned_band_hz": BAND}, SINES),
    ("coning_choice_band", "invalid", "a band with four_sample coning and sculling", ("ideal", "correcting"),
     {"coning": "four_sample", "sculling": "four_sample", "tuned_band_hz": BAND}, SINES),
    ("coning_choice_band", "valid", "a band for the coning table of a coning motion", ("ideal", "correcting"),
     {"coning": "two_sample", "tuned_band_hz": BAND}, CONE),
    ("coning_choice_band", "invalid", "filter_tuned misspelt", ("ideal", "correcting"),
     {"coning": "filter-tuned", "tuned_band_hz": BAND}, SINES),
    ("coning_choice_band", "invalid", "a band of one value", ("ideal", "correcting"),
     {"coning": "filter_tuned", "tuned_band_hz": [200.0]}, SINES),
]


def _made(cls, expect, what, filters, nav, motion):
    return lambda: scenario_made(cls, expect, f"coning: {what}", scenario(None, filters, nav, motion))


CASES = [_made(*c) for c in _CASES]

FAMILY = Family(kind="coning_choice", weight=0.02, classes=("coning_choice_tuned", "coning_choice_band"),
                make=lambda rng: pick(CASES, rng), command=run_command, validate=validate_scenario)
