"""Garbage in, a refusal out (issue 13, item 5): corrupted copies of a clean stationary recording.

Each corruption must give a finding that names the check, the axis and the time, and no verdict;
the clean recording must pass the checks. The recording is 0.4 s on two axes (x, y) so that the
finding must name the right axis; only axis y is corrupted.
"""

from __future__ import annotations

import numpy as np
import pytest

from sins_sim.identification.checks import check_recording, format_findings
from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording
from sins_sim.io.recording import Recording
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import ExperimentInputs, ExperimentSettings, record, stationary_drive
from sins_sim.units import ARCMIN, INTERPOLATED_QUANTUM_RAD

FS = 7200.0
NOM = {"x": SuspensionParams(f0_hz=386.0), "y": SuspensionParams(f0_hz=352.0)}


@pytest.fixture(scope="module")
def clean():
    n = int(0.4 * FS) + 1
    drive = stationary_drive(NOM, ["x", "y"], 3 * ARCMIN, FS, n)
    inputs = ExperimentInputs(["x", "y"], FS, n, FS, drive, None)
    truth = {"x": NOM["x"].replace(f0_hz=386.4), "y": NOM["y"].replace(f0_hz=351.7, k3=4.5e-3)}
    return record(inputs, truth, NOM, INTERPOLATED_QUANTUM_RAD, [], ExperimentSettings(plant_rate_hz=72000.0,
                                                                                      integrator="rk4"),
                  noise_rad=0.05 * 4.848e-6, seed=1)


def _with(rec: Recording, counts=None, drive=None, nominal_y=None) -> Recording:
    meta = dict(rec.meta)
    if nominal_y is not None:
        meta["nominal"] = {**meta["nominal"], "y": {**meta["nominal"]["y"], **nominal_y}}
    return Recording(meta, rec.counts if counts is None else counts, rec.drive_v if drive is None else drive,
                     rec.sins_angle, {}, rec.source)


def _corrupt_y(rec, fn):
    c = rec.counts.copy()
    c[:, 1] = fn(c[:, 1].copy())
    return c


def test_the_clean_recording_passes(clean):
    assert check_recording(clean) == []


def _spike(c):
    c[1000] += 10 ** 9
    return c


def _saturate(c):
    return np.clip(c, None, int(np.percentile(c, 90)))


CORRUPTIONS = {
    "random counts": (lambda c: np.random.default_rng(3).integers(c.min(), c.max() + 1, c.size), "not continuous"),
    "shuffled rows": (lambda c: np.random.default_rng(4).permutation(c), "not continuous"),
    "single spike": (_spike, "jump"),
    "negated counts": (lambda c: -c, "sign"),
    "all-zero gyro": (lambda c: np.zeros_like(c), "dead"),
    "saturated channel": (_saturate, "saturated"),
    "noisy channel": (lambda c: c + np.round(np.random.default_rng(5).normal(0.0, 20.0, c.size)).astype(np.int64),
                      "noise"),
}


@pytest.mark.parametrize("name", list(CORRUPTIONS))
def test_corrupted_counts_are_refused(clean, name):
    fn, check = CORRUPTIONS[name]
    rec = _with(clean, counts=_corrupt_y(clean, fn))
    findings = check_recording(rec)
    assert [f["check"] for f in findings] == [check], findings
    f = findings[0]
    assert f["axis"] == "y" and f["message"].startswith("axis y: ") and f["time_s"] is not None
    if name == "single spike":
        assert f["time_s"] == pytest.approx(1000 / FS, abs=1.5 / FS)


def test_flipped_drive_and_wrong_sign_k5_are_refused(clean):
    drive = np.asarray(clean.drive_v).copy()
    drive[:, 1] = -drive[:, 1]
    for rec in (_with(clean, drive=drive), _with(clean, nominal_y={"k5": -clean.meta["nominal"]["y"]["k5"]})):
        findings = check_recording(rec)
        assert [(f["check"], f["axis"]) for f in findings] == [("sign", "y")], findings


def test_the_diagnosis_gives_no_verdict_on_bad_data(clean):
    rec = _with(clean, counts=_corrupt_y(clean, _spike))
    js = diagnose_recording(rec, DiagnoseSettings(effects=())).to_json()
    assert js["verdict"]["status"] == "invalid data" and js["verdict"]["effect"] == "invalid_data"
    assert js["findings"][0]["check"] == "jump"
    line = format_findings(js["findings"])
    assert line.count("\n") == 0 and "axis y" in line and "t = 0.1389 s" in line
