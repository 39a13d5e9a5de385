"""The time-continuity check finds short gaps under table motion (issue 24, open point).

Recordings come from the project's generator of the hard blind set (:mod:`sins_sim.identification.blind_hard`:
its randomised unit, its rate-table motion, :func:`~sins_sim.simulation.experiment.record`, and its ``_drop``,
which removes samples from every array while the header still claims a continuous record). A gap of ``m``
samples advances the dither's phase by ``2 pi f m / fs``; within STEP_MIN_RAD (10 deg) of a whole number of
periods it leaves the phase alone and no dither test can see it, so the rates below are over the gaps whose phase
step is more than 12 deg from a whole turn (the margin: the measured frequency's error over the windows).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from sins_sim.identification import blind_hard as bh
from sins_sim.identification.blind import FS
from sins_sim.identification.checks import check_recording
from sins_sim.io.recording import Recording
from sins_sim.simulation.experiment import ExperimentInputs, ExperimentSettings, record, stationary_drive
from sins_sim.units import ARCSEC, INTERPOLATED_QUANTUM_RAD

MAX_GAP = 20


def _base(seed: int, table: bool):
    """One second of a randomised unit (as ``make_hard_case`` draws it), at rest or on the rate table, recorded
    ``MAX_GAP`` samples longer; the gap's first sample drawn in 30-70 % of the record."""
    rng = np.random.default_rng([11, seed])
    nominal, truth, amp = bh._unit(rng, ["x"])
    n = int(round(FS)) + 1
    drive = stationary_drive(nominal, ["x"], amp, FS, n + MAX_GAP)
    inputs = ExperimentInputs(["x"], FS, n + MAX_GAP, FS, drive, {"x": bh._table(rng)} if table else None)
    integrator = "rk4" if rng.uniform() < 0.3 else "exact"
    noise = rng.uniform(0.02, 0.1) * ARCSEC if rng.uniform() < 0.4 else 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the plant's regime warnings on a 80-230 Hz table motion)
        rec = record(inputs, truth, nominal, INTERPOLATED_QUANTUM_RAD, [],
                     ExperimentSettings(plant_rate_hz=72000.0, integrator=integrator), noise_rad=noise,
                     seed=int(rng.integers(2 ** 31)), experiment="rate_table" if table else "stationary",
                     description="time-gap test")
    return rec, int(rng.uniform(0.3, 0.7) * n), n, truth["x"].f0_hz


def _cut(rec: Recording, i0: int, m: int, n: int) -> Recording:
    """``m`` samples dropped at ``i0`` from every array, the record cut to ``n`` samples."""
    r = bh._drop(rec, i0, m) if m else rec
    k = int(round(r.drive_fs_hz / r.fs_hz))
    return Recording(dict(r.meta), np.asarray(r.counts)[:n], np.asarray(r.drive_v)[:n * k],
                     np.asarray(r.sins_angle)[:n] if r.sins_angle is not None else None)


def _found(rec, i0):
    """Whether the check names a time-continuity step within one sample of the gap; and any such finding."""
    hits = [f for f in check_recording(rec) if f["check"] == "time continuity"]
    return bool(hits) and abs(hits[0]["time_s"] - i0 / FS) <= 1.5 / FS, hits


@pytest.mark.parametrize("table", [True, False], ids=["rate_table", "at_rest"])
def test_gaps_of_1_to_20_samples_are_found_and_gap_free_records_pass(table):
    """12 units x gaps of 1-20 samples, and each unit's gap-free record. Every gap-free record passes (false
    alarms: 0 / 12; 0 / 40 over seeds 0-39 on and off the table), and every gap whose phase step is more than
    12 deg from a whole turn is found at its sample (233 / 233 here on the table and at rest; over seeds 0-39,
    774 / 777 on the table and 776 / 777 at rest, the misses steps near half a turn placed a few samples off).
    The check before (the sine recursion at the nominal f0 against 10 robust standard deviations) found 218 / 233
    on the table (728 / 777 over 40 seeds): the table's 80 and 230 Hz lines, seen through the suspension at up
    to half the dither's amplitude, raised its noise estimate above short gaps' residuals and pulled its
    single-sine phase fits."""
    found = total = 0
    for seed in range(12):
        rec, i0, n, f0 = _base(seed, table)
        ok, hits = _found(_cut(rec, i0, 0, n), i0)
        assert not hits, (seed, hits)
        for m in range(1, MAX_GAP + 1):
            turn = (f0 * m / FS) % 1.0
            if min(turn, 1.0 - turn) * 360.0 <= 12.0:
                continue
            total += 1
            found += _found(_cut(rec, i0, m, n), i0)[0]
    assert total >= 200
    assert found == total, (found, total)


def test_the_holdout_miss_is_found():
    """The hard set's holdout miss (``docs/user-guide/diagnosis.md``: seed 2402, case 11, 9 samples dropped at
    0.536 s of a rate-table recording, unit at 330 Hz): the check names the gap at its sample and the samples lost
    modulo a dither period (9 of 21.8)."""
    rec, info = bh.make_hard_case("time_gap", np.random.default_rng([2402, 2, 11]), 1.0)
    assert info["defect"]["samples"] == 9
    ok, hits = _found(rec, info["defect"]["first_sample"])
    assert ok, hits
    assert "e.g. 9 samples" in hits[0]["message"]
    assert math.isclose(info["f0_hz"]["x"], 330.4, abs_tol=0.1)
