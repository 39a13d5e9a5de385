"""The recording reader against hostile or degenerate files: one clean RecordingError, no allocation bombs.

Files are assembled member by member with ``zipfile`` so that a header can
claim what the data do not hold (``np.savez`` would never write that).
"""

from __future__ import annotations

import io
import json
import tracemalloc
import zipfile

import numpy as np
import pytest

from sins_sim.io.recording import (FORMAT, MAX_META_DEPTH, MIN_SAMPLES, Recording, RecordingError, read_recording,
                                   write_recording)

NOMINAL = {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}
META = {"format": FORMAT, "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0, "quantum_rad": 7.3e-7,
        "initial_state": "rest", "experiment": "stationary", "nominal": {"x": NOMINAL}}


def _npy(arr: np.ndarray, shape=None) -> bytes:
    """An .npy stream of ``arr``'s bytes whose header claims ``shape`` (default: the true one)."""
    buf = io.BytesIO()
    header = {"descr": np.lib.format.dtype_to_descr(arr.dtype), "fortran_order": False,
              "shape": arr.shape if shape is None else shape}
    np.lib.format.write_array_header_1_0(buf, header)
    buf.write(arr.tobytes())
    return buf.getvalue()


def _archive(tmp_path, members: dict, compression=zipfile.ZIP_DEFLATED, name="rec.npz"):
    path = tmp_path / name
    with zipfile.ZipFile(path, "w", compression) as zf:
        for key, data in members.items():
            zf.writestr(f"{key}.npy", data)
    return path


def _members(n=20, meta=None):
    return {"meta": _npy(np.array(json.dumps(META if meta is None else meta))),
            "counts": _npy(np.zeros((n, 1), np.int64)),
            "drive_v": _npy(np.zeros((n, 1)))}


def _rejects(path, *parts) -> str:
    with pytest.raises(RecordingError) as exc:
        read_recording(path)
    msg = str(exc.value)
    assert "\n" not in msg
    for part in parts:
        assert part in msg, msg
    return msg


def test_the_hand_built_archive_is_valid(tmp_path):
    """The construction used below gives a readable file when the headers tell the truth."""
    for compression in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        rec = read_recording(_archive(tmp_path, _members(), compression))
        assert rec.n_samples == 20


# --- a header claiming 2^40 rows ----------------------------------------------------------------------
@pytest.mark.parametrize("compression", [zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED])
@pytest.mark.parametrize("key", ["counts", "drive_v"])
def test_header_claiming_2_to_the_40_rows_is_refused_before_allocating(tmp_path, compression, key):
    members = _members()
    arr = np.zeros((20, 1), np.int64 if key == "counts" else np.float64)
    members[key] = _npy(arr, shape=(2 ** 40, 1))
    path = _archive(tmp_path, members, compression)
    tracemalloc.start()
    try:
        msg = _rejects(path, f": {key}: ", "(1099511627776, 1)", "must fit in the file")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "160 bytes" in msg  # what the member really holds
    assert peak < 2 ** 26  # nothing near 8 TiB (or even 64 MiB) was asked for


def test_header_claiming_a_few_more_rows_than_stored_is_refused(tmp_path):
    """The rule is exact, not a sanity bound: one missing row is enough."""
    members = _members()
    members["counts"] = _npy(np.zeros((20, 1), np.int64), shape=(21, 1))
    _rejects(_archive(tmp_path, members), ": counts: ", "(21, 1)", "must fit in the file")


def test_extra_member_with_a_lying_header_is_refused_too(tmp_path):
    members = _members()
    members["temperature"] = _npy(np.zeros(3), shape=(2 ** 40,))
    _rejects(_archive(tmp_path, members), ": temperature: ", "must fit in the file")


def test_member_compressed_with_another_method_is_refused(tmp_path):
    path = _archive(tmp_path, _members(), zipfile.ZIP_BZIP2)
    _rejects(path, ": meta: ", "stored or deflated")


# --- deeply nested JSON header ---------------------------------------------------------------------------
def _nested(depth: int):
    value = 1
    for _ in range(depth):
        value = {"a": value}
    return value


@pytest.mark.parametrize("depth", [MAX_META_DEPTH, 10_000])
def test_meta_nested_too_deeply_is_refused(tmp_path, depth):
    # the header itself is one level: MAX_META_DEPTH more below it is one too many
    text = json.dumps(META)[:-1] + ', "extra": ' + "[" * depth + "]" * depth + "}"
    members = _members()
    members["meta"] = _npy(np.array(text))
    _rejects(_archive(tmp_path, members), ": meta: ", f"at most {MAX_META_DEPTH} levels")


def test_meta_nested_within_the_limit_is_kept(tmp_path):
    meta = dict(META, extra=_nested(MAX_META_DEPTH - 2))
    rec = read_recording(_archive(tmp_path, _members(meta=meta)))
    assert rec.meta["extra"] == meta["extra"]


def test_brackets_inside_strings_do_not_count(tmp_path):
    meta = dict(META, description="[[[[" * 100 + "{" * 100 + '"\\"[')
    rec = read_recording(_archive(tmp_path, _members(meta=meta)))
    assert rec.meta["description"] == meta["description"]


# --- too few samples ----------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [2, MIN_SAMPLES - 1])
def test_too_few_samples_is_refused_at_read_time(tmp_path, n):
    _rejects(_archive(tmp_path, _members(n=n)), ": counts: ", f"must hold at least {MIN_SAMPLES} samples",
             f"got {n}")


def test_minimum_length_recording_is_read(tmp_path):
    assert read_recording(_archive(tmp_path, _members(n=MIN_SAMPLES))).n_samples == MIN_SAMPLES


# --- the writer ----------------------------------------------------------------------------------------
def test_write_recording_replaces_in_one_step(tmp_path, monkeypatch):
    """A write that fails at the last step leaves the earlier file whole and no temporary file behind."""
    import os

    path = write_recording(tmp_path / "r.npz", Recording(META, np.zeros((8, 1), np.int64), np.zeros((8, 1))))
    before = path.read_bytes()

    def fail(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError):
        write_recording(path, Recording(META, np.ones((16, 1), np.int64), np.zeros((16, 1))))
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.npz"]
    assert read_recording(path).n_samples == 8


# --- a member stored twice ---------------------------------------------------------------------------------
def test_member_stored_twice_is_refused(tmp_path):
    """zipfile keeps both copies and numpy.load reads one of them: which array the recording holds would be an
    accident of the archive's layout, so the reader refuses it, naming the member."""
    import warnings

    path = _archive(tmp_path, _members())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zipfile warns "Duplicate name"
        with zipfile.ZipFile(path, "a") as zf:
            zf.writestr("counts.npy", _npy(np.ones((20, 1), np.int64)))
    _rejects(path, ": counts: ", "stored twice")
