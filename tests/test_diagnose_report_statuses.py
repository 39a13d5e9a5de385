"""``diagnose --report`` writes its JSON and its report after every status (issue 24, item 1).

One recording per status, each written to a file and diagnosed through the job the CLI runs
(``recording_jobs.diagnose`` with a JSON path and a report directory). The recordings are those of
``tests/test_diagnose.py`` (0.8 s, one axis, RK4 at 72 kHz against the diagnosis' exact integrator):

=================== ==============================================================================
status              recording
=================== ==============================================================================
``invalid data``    a clean recording with one impossible jump of 1e9 counts (the ``jump`` check)
``none``            the clean recording
``unknown``         a 50 Hz pickup of 0.8 arcsec (off the catalogue)
``explained``       a resonance drift of 0.5 Hz/s
``partly explained`` a piezo lag of 150 us (the dominant effect) plus a 50 Hz pickup of 0.6 arcsec
                    that no catalogue effect explains (the remainder)
=================== ==============================================================================
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from sins_sim.io.recording import Recording, write_recording
from sins_sim.jobs import recording_jobs
from sins_sim.models.effects import make_effect
from sins_sim.units import ARCSEC

from test_diagnose import _recording  # noqa: E402  (the shared bench unit)

EFFECTS = ["piezo_lag", "resonance_drift", "readout_delay"]


def _spiked(rec: Recording) -> Recording:
    c = rec.counts.copy()
    c[2000, 0] += 10 ** 9
    return Recording(dict(rec.meta), c, rec.drive_v, rec.sins_angle, {}, rec.source)


CASES = {
    "invalid data": lambda: _spiked(_recording(duration=0.8)),
    "none": lambda: _recording(duration=0.8),
    "unknown": lambda: _recording(effects=[make_effect("mains_pickup", amplitude_rad=0.8 * ARCSEC,
                                                       frequency_hz=50.0)], duration=0.8),
    "explained": lambda: _recording(effects=[make_effect("resonance_drift", rate_hz_per_s=0.5)], duration=0.8),
    "partly explained": lambda: _recording(effects=[make_effect("piezo_lag", tau_s=1.5e-4),
                                                    make_effect("mains_pickup", amplitude_rad=0.6 * ARCSEC,
                                                                frequency_hz=50.0)], duration=0.8),
}


@pytest.mark.parametrize("status", list(CASES))
def test_report_after_every_status(tmp_path, status):
    path = write_recording(tmp_path / "rec.npz", CASES[status]())
    js = recording_jobs.diagnose(path, tmp_path / "out.json", tmp_path / "report", effects=EFFECTS)
    assert js["verdict"]["status"] == status
    assert json.loads((tmp_path / "out.json").read_text()) == dict(js)
    md = (tmp_path / "report" / "report.md").read_text()
    assert f"status **{status}**" in md
    # every figure the report links exists and is not empty
    linked = [line[line.index("(") + 1:-1] for line in md.splitlines() if line.startswith("![")]
    assert linked
    for f in linked:
        assert (tmp_path / "report" / f).stat().st_size > 0
    if status == "invalid data":
        assert "| jump | x |" in md and js["findings"][0]["axis"] == "x"
        assert js["findings"][0]["time_s"] == pytest.approx(2000 / 7200.0, abs=1.5 / 7200.0)
    if status == "partly explained":
        assert js["verdict"]["effect"] == "piezo_lag" and "what remains sits on axis x" in md
    if status == "unknown":
        assert np.isclose(js["gap"]["band_hz"][0], 50.0, atol=20.0)
