"""Recordings, format ``sins-sim-recording/1`` (shared spec ``recording-format.md``).

Every broken-file case must be rejected with one ValueError naming the key
and the rule; files are built here with plain ``np.savez`` so that the
reader is tested independently of the writer.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from sins_sim.io.recording import (FORMAT, NOMINAL_KEYS, REQUIRED_META, Recording, RecordingError,
                                   read_csv_recording, read_recording, write_recording)

NOMINAL = {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}


def _meta(**over):
    meta = {"format": FORMAT, "axes": ["x", "y"], "fs_hz": 7200.0, "drive_fs_hz": 14400.0, "sins_fs_hz": 7200.0,
            "quantum_rad": 7.3e-7, "initial_state": "rest", "experiment": "rate_table",
            "nominal": {"x": dict(NOMINAL), "y": dict(NOMINAL, f0_hz=352.0)},
            "description": "unit 7, bench 2", "operator": "nobody", "temperature_c": [21.5, 22.0]}
    meta.update(over)
    return meta


def _arrays(n=20, meta=None):
    rng = np.random.default_rng(0)
    meta = _meta() if meta is None else meta
    return {"meta": np.array(json.dumps(meta)),
            "counts": rng.integers(-1000, 1000, size=(n, 2)).astype(np.int64),
            "drive_v": rng.standard_normal((2 * n, 2)),
            "sins_angle": rng.standard_normal((n, 2)) * 1e-3}


def _save(tmp_path, arrays, name="rec.npz", compressed=True):
    path = tmp_path / name
    with open(path, "wb") as fh:
        (np.savez_compressed if compressed else np.savez)(fh, **arrays)
    return path


def _expect(tmp_path, arrays, key, rule):
    path = _save(tmp_path, arrays)
    with pytest.raises(RecordingError) as exc:
        read_recording(path)
    msg = str(exc.value)
    assert isinstance(exc.value, ValueError)
    assert key in msg and rule in msg, msg


def _with_meta(**over):
    return _arrays(meta=_meta(**over))


# --- valid files --------------------------------------------------------------------------------
@pytest.mark.parametrize("compressed", [True, False])
def test_read_valid_file(tmp_path, compressed):
    arrays = _arrays()
    arrays["temperature"] = np.linspace(20, 21, 5)  # an array the format does not define: preserved
    rec = read_recording(_save(tmp_path, arrays, compressed=compressed))
    assert rec.axes == ("x", "y")
    assert rec.n_samples == 20 and rec.drive_ratio == 2
    assert rec.meta["operator"] == "nobody" and rec.meta["temperature_c"] == [21.5, 22.0]
    np.testing.assert_array_equal(rec.counts, arrays["counts"])
    np.testing.assert_array_equal(rec.drive_v, arrays["drive_v"])
    np.testing.assert_array_equal(rec.sins_angle, arrays["sins_angle"])
    np.testing.assert_array_equal(rec.extra["temperature"], arrays["temperature"])
    np.testing.assert_allclose(rec.angle("y"), arrays["counts"][:, 1] * 7.3e-7)
    assert rec.nominal["y"]["f0_hz"] == 352.0
    assert not rec.counts.flags.writeable


def test_round_trip_preserves_everything(tmp_path):
    arrays = _arrays()
    arrays["drive_v"] = arrays["drive_v"].astype(np.float32)
    meta = _meta()
    meta["nominal"]["x"]["zeta"] = 1e-4  # unknown key inside an entry: preserved
    rec = Recording(meta, arrays["counts"], arrays["drive_v"], arrays["sins_angle"], {"t_c": np.arange(3.0)})
    for compressed in (True, False):
        path = write_recording(tmp_path / f"out{compressed}.npz", rec, compressed=compressed)
        back = read_recording(path)
        assert back.meta == rec.meta
        assert back.drive_v.dtype == np.float32
        np.testing.assert_array_equal(back.counts, rec.counts)
        np.testing.assert_array_equal(back.drive_v, rec.drive_v)
        np.testing.assert_array_equal(back.sins_angle, rec.sins_angle)
        np.testing.assert_array_equal(back.extra["t_c"], np.arange(3.0))


def test_optional_parts(tmp_path):
    meta = _meta()
    del meta["sins_fs_hz"], meta["description"]
    arrays = _arrays(meta=meta)
    del arrays["sins_angle"]
    rec = read_recording(_save(tmp_path, arrays))
    assert rec.sins_angle is None and rec.sins_fs_hz is None
    sub = rec.select(["y"])
    assert sub.axes == ("y",) and sub.counts.shape == (20, 1) and list(sub.meta["nominal"]) == ["y"]


# --- broken files: container ------------------------------------------------------------------------
def test_not_an_archive(tmp_path):
    path = tmp_path / "junk.npz"
    path.write_bytes(b"this is not a zip file")
    with pytest.raises(RecordingError, match="file: must be a NumPy .npz archive"):
        read_recording(path)
    npy = tmp_path / "single.npz"
    with open(npy, "wb") as fh:
        np.save(fh, np.zeros(3))
    with pytest.raises(RecordingError, match="file: must be a NumPy .npz archive"):
        read_recording(npy)
    with pytest.raises(RecordingError, match="file: does not exist"):
        read_recording(tmp_path / "missing.npz")


@pytest.mark.parametrize("key", ["meta", "counts", "drive_v"])
def test_missing_array(tmp_path, key):
    arrays = _arrays()
    del arrays[key]
    _expect(tmp_path, arrays, key, "is a required array but missing")


def test_object_array_is_rejected(tmp_path):
    arrays = _arrays()
    arrays["counts"] = np.empty((20, 2), dtype=object)
    path = tmp_path / "obj.npz"
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
    with pytest.raises(RecordingError, match="counts: must be a plain"):
        read_recording(path)


@pytest.mark.parametrize("bad, rule", [
    (np.array([json.dumps(_meta())]), "0-d unicode array"),
    (np.array(json.dumps(_meta()).encode()), "0-d unicode array"),
    (np.array("{not json"), "must hold valid JSON"),
    (np.array("[1, 2]"), "must hold a JSON object"),
    (np.array(json.dumps(_meta(fs_hz=float("nan")))), "must hold valid JSON"),
])
def test_meta_container(tmp_path, bad, rule):
    arrays = _arrays()
    arrays["meta"] = bad
    _expect(tmp_path, arrays, "meta", rule)


# --- broken files: header ---------------------------------------------------------------------------
@pytest.mark.parametrize("key", REQUIRED_META)
def test_missing_header_key(tmp_path, key):
    meta = _meta()
    del meta[key]
    _expect(tmp_path, _arrays(meta=meta), f"meta.{key}", "is required but missing")


@pytest.mark.parametrize("over, key, rule", [
    ({"format": "sins-sim-recording/2"}, "meta.format", "must be 'sins-sim-recording/1'"),
    ({"axes": "xy"}, "meta.axes", "list of 1 to 3"),
    ({"axes": []}, "meta.axes", "list of 1 to 3"),
    ({"axes": ["x", "y", "z", "w"]}, "meta.axes", "list of 1 to 3"),
    ({"axes": ["x", "x"]}, "meta.axes", "distinct"),
    ({"axes": ["x", 3]}, "meta.axes[1]", "non-empty string"),
    ({"fs_hz": 0.0}, "meta.fs_hz", "must be a number in"),
    ({"fs_hz": "7200"}, "meta.fs_hz", "must be a number in"),
    ({"fs_hz": True}, "meta.fs_hz", "must be a number in"),
    ({"drive_fs_hz": -1.0}, "meta.drive_fs_hz", "must be a number in"),
    ({"drive_fs_hz": 10000.0}, "meta.drive_fs_hz", "must be an integer >= 1"),
    ({"drive_fs_hz": 3600.0}, "meta.drive_fs_hz", "must be an integer >= 1"),
    ({"sins_fs_hz": 0.0}, "meta.sins_fs_hz", "must be a number in"),
    ({"quantum_rad": 0.0}, "meta.quantum_rad", "must be a number in"),
    ({"quantum_rad": None}, "meta.quantum_rad", "must be a number in"),
    ({"fs_hz": 7.2, "drive_fs_hz": 7.2}, "meta.fs_hz", "must be a number in [100, 1e+06] Hz"),  # kHz by mistake
    ({"fs_hz": 1e30, "drive_fs_hz": 1e30}, "meta.fs_hz", "must be a number in"),
    ({"quantum_rad": 0.15125}, "meta.quantum_rad", "must be a number in"),  # arcsec by mistake
    ({"initial_state": "warm"}, "meta.initial_state", "must be one of ['rest', 'unknown']"),
    ({"experiment": 3}, "meta.experiment", "must be a string"),
    ({"description": ["a"]}, "meta.description", "must be a string"),
    ({"nominal": [1, 2]}, "meta.nominal", "must be an object"),
    ({"nominal": {"x": NOMINAL}}, "meta.nominal.y", "one entry per axis"),
    ({"nominal": {"x": NOMINAL, "y": NOMINAL, "z": NOMINAL}}, "meta.nominal.z", "is not an axis"),
    ({"nominal": {"x": NOMINAL, "y": [1]}}, "meta.nominal.y", "must be an object"),
    ({"nominal": {"x": NOMINAL, "y": dict(NOMINAL, f0_hz=-1.0)}}, "meta.nominal.y.f0_hz", "> 0"),
    ({"nominal": {"x": NOMINAL, "y": dict(NOMINAL, k1=-1e-4)}}, "meta.nominal.y.k1", ">= 0"),
    ({"nominal": {"x": NOMINAL, "y": dict(NOMINAL, k2=0.0)}}, "meta.nominal.y.k2", "> 0"),
    ({"nominal": {"x": NOMINAL, "y": dict(NOMINAL, k3=-1.0)}}, "meta.nominal.y.k3", ">= 0"),
    ({"nominal": {"x": NOMINAL, "y": dict(NOMINAL, k4="250")}}, "meta.nominal.y.k4", "finite number"),
    ({"nominal": {"x": NOMINAL, "y": dict(NOMINAL, k5=0.0)}}, "meta.nominal.y.k5", "!= 0"),
])
def test_bad_header_value(tmp_path, over, key, rule):
    _expect(tmp_path, _with_meta(**over), key, rule)


@pytest.mark.parametrize("key", NOMINAL_KEYS)
def test_nominal_needs_every_parameter(tmp_path, key):
    entry = {k: val for k, val in NOMINAL.items() if k != key}
    _expect(tmp_path, _with_meta(nominal={"x": NOMINAL, "y": entry}), f"meta.nominal.y.{key}", "is required")


def test_sins_fs_required_with_sins_angle(tmp_path):
    meta = _meta()
    del meta["sins_fs_hz"]
    _expect(tmp_path, _arrays(meta=meta), "meta.sins_fs_hz", "is required when sins_angle is present")


# --- broken files: arrays -------------------------------------------------------------------------------
@pytest.mark.parametrize("mutate, key, rule", [
    (lambda a: a.update(counts=a["counts"].astype(np.int32)), "counts", "must be an int64 array"),
    (lambda a: a.update(counts=a["counts"].astype(np.float64)), "counts", "must be an int64 array"),
    (lambda a: a.update(counts=a["counts"][:, 0]), "counts", "shape (N, A)"),
    (lambda a: a.update(counts=a["counts"][:, :1]), "counts", "shape (N, A)"),
    (lambda a: a.update(counts=a["counts"][:1], drive_v=a["drive_v"][:2]), "counts", "at least 4 samples"),
    (lambda a: a.update(drive_v=a["drive_v"].astype(np.int64)), "drive_v", "float64 or float32"),
    (lambda a: a.update(drive_v=a["drive_v"][:-1]), "drive_v", "M = N * drive_fs_hz / fs_hz"),
    (lambda a: a.update(drive_v=a["drive_v"][:, :1]), "drive_v", "shape (M, A)"),
    (lambda a: a["drive_v"].__setitem__((3, 1), np.nan), "drive_v", "must be finite"),
    (lambda a: a.update(sins_angle=a["sins_angle"].astype(np.float32)), "sins_angle", "must be a float64 array"),
    (lambda a: a.update(sins_angle=a["sins_angle"][:, :1]), "sins_angle", "shape (K, A)"),
    (lambda a: a.update(sins_angle=a["sins_angle"][:3]), "sins_angle", "at least 4 samples"),
    (lambda a: a.update(sins_angle=a["sins_angle"][:10]), "sins_angle", "must cover the time span"),
    (lambda a: a["sins_angle"].__setitem__((2, 0), np.inf), "sins_angle", "must be finite"),
])
def test_bad_array(tmp_path, mutate, key, rule):
    arrays = _arrays()
    mutate(arrays)
    _expect(tmp_path, arrays, key, rule)


def test_constructor_checks_too():
    a = _arrays()
    with pytest.raises(RecordingError, match="meta.fs_hz"):
        Recording(_meta(fs_hz=-2.0), a["counts"], a["drive_v"], a["sins_angle"])
    with pytest.raises(ValueError, match="extra.counts"):
        Recording(_meta(), a["counts"], a["drive_v"], a["sins_angle"], {"counts": np.zeros(2)})


# --- CSV import -------------------------------------------------------------------------------------------
def _csv(tmp_path, header, rows, name="lab.csv"):
    path = tmp_path / name
    lines = ["# exported by the bench", ",".join(header)] + [",".join(str(x) for x in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_csv_import(tmp_path):
    fs = 1000.0
    n = 12
    rows = [[f"{i / fs:.9f}", i * 3, -i, 0.5 * i, 0.25 * i, 1e-6 * i, 2e-6 * i] for i in range(n)]
    header = ["time_s", "counts_x", "counts_z", "drive_v_x", "drive_v_z", "sins_angle_rad_x", "sins_angle_rad_z"]
    rec = read_csv_recording(_csv(tmp_path, header, rows), quantum_rad=1e-6, nominal={"x": NOMINAL, "z": NOMINAL},
                             experiment="rate_table", description="bench", bench="B2")
    assert rec.axes == ("x", "z")
    assert rec.fs_hz == pytest.approx(fs) and rec.drive_fs_hz == rec.fs_hz == rec.sins_fs_hz
    np.testing.assert_array_equal(rec.counts[:, 0], np.arange(n) * 3)
    np.testing.assert_allclose(rec.drive_v[:, 1], 0.25 * np.arange(n))
    np.testing.assert_allclose(rec.sins_angle[:, 1], 2e-6 * np.arange(n))
    assert rec.meta["bench"] == "B2"
    back = read_recording(write_recording(tmp_path / "lab.npz", rec))
    assert back.meta == rec.meta


@pytest.mark.parametrize("header, rows, key, rule", [
    (["time_s", "counts_x", "drive_v_x", "volts"], [[0, 0, 0, 0], [0.001, 1, 0, 0]], "volts", "unknown column"),
    (["counts_x", "drive_v_x"], [[0, 0], [1, 0]], "time_s", "required"),
    (["time_s", "counts_x"], [[0, 0], [0.001, 1]], "drive_v_x", "required"),
    (["time_s", "counts_x", "drive_v_x", "drive_v_y"], [[0, 0, 0, 0], [0.001, 1, 0, 0]], "drive_v_y",
     "no counts_y"),
    (["time_s", "counts_x", "drive_v_x"], [[0, 0, 0], [0.001, 1.5, 0], [0.002, 2, 0]], "counts_x row 2",
     "integer"),
    (["time_s", "counts_x", "drive_v_x"], [[0, 0, 0], [0.001, 1, 0], [0.0035, 2, 0], [0.004, 2, 0]], "time_s",
     "uniform"),
    (["time_s", "counts_x", "drive_v_x"], [[0, 0, "a"], [0.001, 1, 0]], "drive_v_x row 1", "must be a number"),
    (["time_s", "counts_x", "drive_v_x"], [[0, 0, 0], [0.001, 1]], "row 2", "fields"),
])
def test_csv_errors(tmp_path, header, rows, key, rule):
    path = _csv(tmp_path, header, rows)
    with pytest.raises(RecordingError) as exc:
        read_csv_recording(path, quantum_rad=1e-6, nominal={"x": NOMINAL})
    assert key in str(exc.value) and rule in str(exc.value), str(exc.value)


def test_csv_header_errors_are_recording_errors(tmp_path):
    path = _csv(tmp_path, ["time_s", "counts_x", "drive_v_x"], [[0, 0, 0], [0.001, 1, 0], [0.002, 2, 0]])
    with pytest.raises(RecordingError, match="meta.nominal.x.k5"):
        read_csv_recording(path, quantum_rad=1e-6, nominal={"x": dict(NOMINAL, k5=0.0)})
    with pytest.raises(RecordingError, match="meta.quantum_rad"):
        read_csv_recording(path, quantum_rad=-1.0, nominal={"x": NOMINAL})
