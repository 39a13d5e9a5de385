"""Issue 40, items 1-13: defects an outside campaign and a new user found, each reproduced here.

Every test failed before its fix: a traceback, a file deleted without a word, an input accepted and ignored, a
message in internal words or naming no input, a README command that exits 2, a column in the wrong unit, a doc
pointing at a file no user has, a summary cut at "eq.", an estimate 3x too short, a rule missing from the schema.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.io.recording import (FORMAT, SINS_RATE_MAX_RAD_S, SINS_SWING_MAX_RAD, RecordingError,
                                   read_recording)

ROOT = Path(__file__).resolve().parents[1]
CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}
NOMINAL = {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}


# --- item 1: a recording's sins_angle beyond any physical block angle ----------------------------------------------
def _recording(tmp_path, angle: np.ndarray) -> Path:
    n = angle.shape[0]
    meta = {"format": FORMAT, "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0, "sins_fs_hz": 7200.0,
            "quantum_rad": 7.3e-7, "initial_state": "rest", "experiment": "rate_table", "nominal": {"x": NOMINAL}}
    path = tmp_path / "rec.npz"
    np.savez_compressed(path, meta=np.array(json.dumps(meta)), counts=np.zeros((n, 1), np.int64),
                        drive_v=np.zeros((n, 1)), sins_angle=angle)
    return path


def _table_angle(n=2161, fs=7200.0, rate_deg_s=5.0):
    """A 5 deg/s table with a 3 arcmin, 20 Hz swing (the rate_table experiment's block angle)."""
    t = np.arange(n) / fs
    return (math.radians(rate_deg_s) * t + math.radians(3.0 / 60.0) * np.sin(2 * math.pi * 20.0 * t))[:, None]


def test_a_physical_block_angle_is_read(tmp_path):
    assert read_recording(_recording(tmp_path, _table_angle())).sins_angle.shape == (2161, 1)


@pytest.mark.parametrize("scale", [1e300, 1e6])  # the campaign's corruption; microradians read as rad
def test_a_block_angle_beyond_its_physical_range_is_refused_naming_sins_angle(tmp_path, scale):
    with pytest.raises(RecordingError) as exc:
        read_recording(_recording(tmp_path, _table_angle() * scale))
    msg = str(exc.value)
    assert "sins_angle: must stay within the physical range" in msg and "1000 deg/s" in msg and "axis x" in msg, msg


def test_the_bound_is_the_largest_swing_plus_the_largest_rate_times_t(tmp_path):
    """Just inside the bound at the last sample is read, just outside is refused (the bound is 10 deg + 1000 deg/s t,
    so a relative margin of 1e-9 is far above the float64 rounding of the comparison, 1e-16)."""
    n, fs = 721, 7200.0
    limit = SINS_SWING_MAX_RAD + SINS_RATE_MAX_RAD_S * (n - 1) / fs
    for factor, ok in ((1 - 1e-9, True), (1 + 1e-9, False)):
        angle = np.zeros((n, 1))
        angle[-1, 0] = factor * limit
        if ok:
            read_recording(_recording(tmp_path, angle))
        else:
            with pytest.raises(RecordingError, match="sins_angle"):
                read_recording(_recording(tmp_path, angle))
    start = np.full((n, 1), 7.0)  # 7 rad > 2 pi: no orientation about an axis
    with pytest.raises(RecordingError, match="sins_angle: must start within one turn"):
        read_recording(_recording(tmp_path, start))


def test_format_diagnosis_prints_none_as_n_a():
    from sins_sim.jobs.recording_jobs import format_diagnosis

    js = {"verdict": {"effect": "none", "status": "none", "explained_fraction": None, "alternatives": [],
                      "effects": [{"effect": "a", "explained_fraction": None}, {"effect": "b",
                                                                              "explained_fraction": 0.5}]},
          "noise_floor_arcsec": None, "baseline": {"residual_rms_arcsec": None},
          "gap": {"significant": True, "axis": "x", "band_hz": None, "time_s": None},
          "candidates": [{"effect": "x", "gap_reduction": None, "score": None, "params": {}}]}
    text = format_diagnosis(js)
    assert "noise floor n/a arcsec" in text and "gap reduction n/a" in text and "a n/a" in text, text
