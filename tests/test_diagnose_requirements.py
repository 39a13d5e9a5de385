"""A recording that lacks what its experiment needs is refused, naming the key (issue 25, items 5 and 6).

* a rate-table recording without ``sins_angle`` (before: ``axis_coupling``, every coefficient at its
  bound);
* a recording too short for the held-out significance test (before: a 20-sample recording got
  ``none``). The minimum is 8 blocks of 25 ms: 1441 samples at 7.2 kHz.
"""

from __future__ import annotations

import pytest

from sins_sim.identification.checks import MIN_BLOCKS, require_inputs
from sins_sim.identification.diagnose import diagnose_recording
from sins_sim.io.recording import Recording, RecordingError

from test_diagnose import _recording  # noqa: E402  (the shared bench unit)


def _cut(rec: Recording, n: int) -> Recording:
    sins = None if rec.sins_angle is None else rec.sins_angle[:n]
    return Recording(dict(rec.meta), rec.counts[:n], rec.drive_v[:n], sins, {}, "cut.npz")


def test_a_rate_table_recording_without_the_table_angle_is_refused():
    rec = _recording("rate_table", duration=0.3)
    require_inputs(rec)  # complete: accepted
    meta = {k: v for k, v in rec.meta.items() if k != "sins_fs_hz"}
    bare = Recording(meta, rec.counts, rec.drive_v, None, {}, "bare.npz")
    with pytest.raises(RecordingError, match=r"^bare\.npz: sins_angle: is required for a 'rate_table' recording"):
        diagnose_recording(bare)
    # a stationary recording needs no table angle
    require_inputs(_recording("stationary", duration=0.3))


def test_a_recording_too_short_for_the_held_out_test_is_refused():
    rec = _recording("stationary", duration=0.3)
    need = MIN_BLOCKS * 0.025 * 7200.0 + 1
    assert need == 1441
    require_inputs(_cut(rec, 1441))
    for n in (20, 1440):
        with pytest.raises(RecordingError, match=rf"^cut\.npz: counts: must hold at least 1441 samples \(8 blocks "
                                                 rf"of 25 ms at 7200 Hz.*held-out.*got {n}$"):
            diagnose_recording(_cut(rec, n))


def test_several_recordings_are_checked_for_their_requirements_before_any_work(tmp_path):
    """``diagnose A B`` refuses a short B before it spends any time on A."""
    from sins_sim.io.recording import write_recording
    from sins_sim.jobs.recording_jobs import diagnose_many

    a = write_recording(tmp_path / "a.npz", _recording("stationary", duration=0.3))
    b = write_recording(tmp_path / "b.npz", _cut(_recording("stationary", duration=0.3), 100))
    with pytest.raises(RecordingError, match=r"counts: must hold at least 1441 samples"):
        diagnose_many([a, b], json_dir=tmp_path / "out", jobs=1)
    assert not (tmp_path / "out" / "a.json").exists()  # A, first in line, was not diagnosed
