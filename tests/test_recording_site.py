"""The optional ``meta.site`` of a recording: where the bench stands and how the unit sits on it.

Files are built with plain ``np.savez`` so that the reader is tested apart from the writer; the round trip
goes through :func:`write_recording`.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from sins_sim.io.recording import FORMAT, Recording, RecordingError, read_recording, write_recording

NOMINAL = {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}
SITE = {"latitude_deg": 56.8, "orientation_ned": {"heading_deg": 304.0, "pitch_deg": -0.7, "roll_deg": 1.1},
        "table_axis_ned": [0.6, 0.0, 0.8]}


def _meta(axes=("x", "y"), **over):
    meta = {"format": FORMAT, "axes": list(axes), "fs_hz": 7200.0, "drive_fs_hz": 7200.0, "quantum_rad": 7.3e-7,
            "initial_state": "rest", "experiment": "stationary", "nominal": {a: dict(NOMINAL) for a in axes}}
    meta.update(over)
    return meta


def _save(tmp_path, meta, n=20):
    path = tmp_path / "rec.npz"
    rng = np.random.default_rng(0)
    np.savez(path, meta=np.array(json.dumps(meta)), counts=rng.integers(-9, 9, (n, len(meta["axes"]))).astype(np.int64),
             drive_v=rng.standard_normal((n, len(meta["axes"]))))
    return path


def test_site_round_trip(tmp_path):
    rec = read_recording(_save(tmp_path, _meta(site=SITE)))
    assert rec.site == SITE
    out = read_recording(write_recording(tmp_path / "out.npz", rec))
    assert out.site == SITE and out.meta == rec.meta


def test_without_site_stays_valid(tmp_path):
    rec = read_recording(_save(tmp_path, _meta()))
    assert rec.site is None


def _bad(**change):
    site = json.loads(json.dumps(SITE))
    for key, val in change.items():
        if key in ("heading_deg", "pitch_deg", "roll_deg"):
            site["orientation_ned"][key] = val
        elif val is None:
            site.pop(key)
        else:
            site[key] = val
    return site


@pytest.mark.parametrize("site, key, rule", [
    ("north", "meta.site", "must be an object"),
    (_bad(latitude_deg=None), "meta.site.latitude_deg", "is required"),
    (_bad(latitude_deg=91.0), "meta.site.latitude_deg", "[-90, 90] deg"),
    (_bad(latitude_deg=True), "meta.site.latitude_deg", "must be a number"),
    (_bad(orientation_ned=[0, 0, 0]), "meta.site.orientation_ned", "must be an object"),
    (_bad(pitch_deg=95.0), "meta.site.orientation_ned.pitch_deg", "[-90, 90] deg"),
    (_bad(heading_deg="NW"), "meta.site.orientation_ned.heading_deg", "must be a number"),
    (_bad(table_axis_ned=[1.0, 1.0, 0.0]), "meta.site.table_axis_ned", "unit vector"),
    (_bad(table_axis_ned=[1.0, 0.0]), "meta.site.table_axis_ned", "unit vector"),
])
def test_bad_site_is_refused_naming_the_key(tmp_path, site, key, rule):
    with pytest.raises(RecordingError) as exc:
        read_recording(_save(tmp_path, _meta(site=site)))
    msg = str(exc.value)
    assert f": {key}: " in msg and rule in msg and "\n" not in msg, msg


def test_site_needs_triad_axis_names(tmp_path):
    with pytest.raises(RecordingError, match=r"meta.axes: must name axes of the triad"):
        read_recording(_save(tmp_path, _meta(axes=("a",), site=SITE)))
    # and a missing orientation angle is named
    site = _bad()
    del site["orientation_ned"]["roll_deg"]
    with pytest.raises(RecordingError, match=r"meta.site.orientation_ned.roll_deg: is required"):
        Recording(_meta(site=site), np.zeros((4, 2), np.int64), np.zeros((4, 2)))
