"""The hard blind set of ``diagnose-eval --hard`` (issue 24, item 7): its generator and its rules.

The generator is checked against independent reconstructions (the same seed without the defect), the
rules against hand-made verdicts; one small evaluation runs every class end to end.
"""

from __future__ import annotations

import numpy as np
import pytest

from sins_sim.identification import blind_hard as bh
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN


def _case(label, form, i=0, duration_s=0.5):
    return bh.make_hard_case(label, np.random.default_rng([7, 2, i]), duration_s, form=form)


def test_time_gap_drops_a_block_from_every_array():
    """The recording equals the one drawn with the same seed, less ``m`` samples of counts, drive and table
    angle at one instant; the header is unchanged (it still claims a continuous record)."""
    rec, info = _case("time_gap", "rate_table")
    m, i0 = info["defect"]["samples"], info["defect"]["first_sample"]
    assert 20 <= m <= 120 and 0.3 <= i0 / rec.n_samples <= 0.7
    full_rec, _ = _replay_without_drop()
    assert rec.n_samples == full_rec.n_samples - m
    assert np.array_equal(rec.counts[:i0], full_rec.counts[:i0])
    assert np.array_equal(rec.counts[i0:], full_rec.counts[i0 + m:])
    assert np.array_equal(rec.sins_angle[i0:], full_rec.sins_angle[i0 + m:])
    assert np.array_equal(rec.drive_v[i0:], full_rec.drive_v[i0 + m:])
    assert rec.meta["fs_hz"] == full_rec.meta["fs_hz"]


def _replay_without_drop():
    """What make_hard_case draws for a time gap before it drops the samples (kept in step with it)."""
    original = bh._drop
    try:
        bh._drop = lambda rec, i0, m: rec
        return bh.make_hard_case("time_gap", np.random.default_rng([7, 2, 0]), 0.5, form="rate_table")
    finally:
        bh._drop = original


def test_sign_flip_negates_the_counts_or_the_table_angle():
    """The two forms draw the same recording (the flip draws nothing) and negate one array each: the ``counts``
    form's counts are the ``table`` form's negated, its table angle the ``table`` form's negated, the drive
    the same."""
    by_counts, _ = _case("sign_flip", "counts", i=1)
    by_table, _ = _case("sign_flip", "table", i=1)
    assert np.array_equal(by_counts.counts, -by_table.counts)
    assert np.array_equal(by_counts.sins_angle, -by_table.sins_angle)
    assert np.array_equal(by_counts.drive_v, by_table.drive_v)
    assert np.ptp(by_table.sins_angle) > 0
    # the unflipped angle follows the table (slope +1, a closed form of the sign the gyro must have): regress the
    # table form's counts on its negated table angle
    q = by_table.quantum_rad
    slope = np.polyfit(-by_table.sins_angle[:, 0], by_table.counts[:, 0] * q, 1)[0]
    # the dither (at most 4.2 arcmin) is uncorrelated with a table that turns 2.5 deg or more in 0.5 s
    assert slope == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("label", [lab for lab in bh.HARD_LABELS])
def test_every_class_draws_a_randomised_unit(label):
    """The nominal resonance in 300-450 Hz and the dither amplitude in 1.8-4.2 arcmin for every class, and the
    drive is the one eq. 17 gives for that amplitude on the nominal unit (an independent call of
    ``SuspensionParams.drive_voltage``; the AFC sweep's plan scales it up to 1.3 x)."""
    for i in range(3):
        rec, info = _case(label, None, i=i)
        f0 = rec.nominal["x"]["f0_hz"]
        assert bh.F0_RANGE_HZ[0] <= f0 <= bh.F0_RANGE_HZ[1]
        amp = info["amplitude_arcmin"]
        assert bh.AMPLITUDE_RANGE_ARCMIN[0] <= amp <= bh.AMPLITUDE_RANGE_ARCMIN[1]
        vm = SuspensionParams(f0_hz=f0).drive_voltage(amp * ARCMIN)
        peak = float(np.max(np.abs(rec.drive_v[:, 0])))
        if rec.experiment == "afc_sweep":
            assert peak <= 1.3 * abs(vm) * (1 + 1e-12)
        else:
            # over 150+ dither periods at an irrational-looking f0 / fs, some sample lies within 0.045 rad of a
            # crest (cos 0.045 = 0.999)
            assert peak == pytest.approx(abs(vm), rel=1e-3)


def test_rules():
    j = bh.judge_hard
    inv = {"status": "invalid data", "effect": "invalid_data", "alternatives": [],
           "findings": [{"check": "time continuity"}]}
    assert j({"label": "time_gap", "form": "rate_table"}, inv)[1]
    assert not j({"label": "sign_flip", "form": "counts"}, inv)[1]
    assert j({"label": "sign_flip", "form": "table"}, {**inv, "findings": [{"check": "sign"}]})[1]
    close = {"status": "explained", "effect": "piezo_lag", "alternatives": ["readout_delay"], "effects": []}
    said = {"label": "near_degenerate", "form": "readout_delay", "round_trip_right": True,
            "round_trip_verdict": "readout_delay (explained)"}
    assert j(said, close)[1]
    assert not j(said, {**close, "alternatives": []})[1]  # the close call not said
    assert not j({**said, "round_trip_right": False}, close)[1]  # the suggested experiment did not separate them
    unk = {"status": "unknown", "effect": "unknown", "alternatives": []}
    assert j({"label": "structural_mode", "form": "stationary"}, unk)[1]
    assert not j({"label": "structural_mode", "form": "stationary"}, inv)[1]
    none = {"status": "none", "effect": "none", "alternatives": [], "effects": []}
    assert j({"label": "bias_drift", "form": "alone"}, none)[1]
    assert not j({"label": "bias_drift", "form": "with_effect", "inner": "lock_in", "weak": False}, none)[1]
    lock = {"status": "explained", "effect": "lock_in", "alternatives": [], "effects": [{"effect": "lock_in"}]}
    assert j({"label": "bias_drift", "form": "with_effect", "inner": "lock_in", "weak": False}, lock)[1]
    assert j({"label": "randomised", "form": "none", "inner": "none", "weak": False}, none)[1]


def test_holdout_seeds_are_apart_from_the_development_seeds():
    assert len(bh.HOLDOUT_SEEDS) == 2 and not set(bh.HOLDOUT_SEEDS) & set(bh.DEV_SEEDS)


def test_holdout_needs_hard(capsys):
    from sins_sim.cli import main

    assert main(["diagnose-eval", "--n", "1", "--holdout"]) != 0
    err = capsys.readouterr().err
    assert "--holdout" in err and len(err.strip().splitlines()) == 1
    assert main(["diagnose-eval", "--n", "1", "--seeds", "1,x"]) != 0
    assert "--seeds" in capsys.readouterr().err


def test_earth_rate_class_puts_the_site_in_the_header_only_when_its_form_says_so():
    """Each form of ``earth_rate`` (issue 39, item 4): three axes; the header's ``site`` present exactly for the
    ``*_site`` forms (the truth carries the Earth's rate in every form), a table axis only on the table forms,
    latitude and heading in their drawn ranges, a level unit on the still bench."""
    for i, form in enumerate(bh.HARD_FORMS["earth_rate"]):
        rec, info = _case("earth_rate", form, duration_s=0.2, i=i)
        assert list(rec.axes) == ["x", "y", "z"]
        given = form in ("still_site", "table_site")
        assert (rec.site is not None) == given, form
        site = info["site"]
        assert -70.0 <= site["latitude_deg"] <= 70.0 and 0.0 <= site["orientation_ned"]["heading_deg"] < 360.0
        assert ("table_axis_ned" in site) == form.startswith("table") == (rec.sins_angle is not None)
        if not form.startswith("table"):
            assert site["orientation_ned"]["pitch_deg"] == 0.0 == site["orientation_ned"]["roll_deg"]


def test_earth_rate_rules():
    j = bh.judge_hard
    none = {"status": "none", "effect": "none", "alternatives": [], "effects": [], "steady_rate": None}
    found = {**none, "steady_rate": {"finding": "earth_rate"}}
    assert j({"label": "earth_rate", "form": "still_site"}, none)[1]
    assert not j({"label": "earth_rate", "form": "still_site"}, found)[1]  # the model had the site: nothing left
    assert j({"label": "earth_rate", "form": "still_no_site"}, found)[1]
    assert not j({"label": "earth_rate", "form": "still_no_site"}, none)[1]  # the rate went unreported
    assert not j({"label": "earth_rate", "form": "still_no_site"},
                 {**none, "steady_rate": {"finding": "gyro_bias"}})[1]
    assert j({"label": "earth_rate", "form": "table_site"}, none)[1]
    unk = {"status": "unknown", "effect": "unknown", "alternatives": [], "effects": []}
    assert j({"label": "earth_rate", "form": "table_no_site"}, unk)[1]
    sf = {"status": "explained", "effect": "scale_factor", "alternatives": [], "effects": [{"effect": "scale_factor"}]}
    assert not j({"label": "earth_rate", "form": "table_no_site"}, sf)[1]  # a scale error claimed, the Earth unsaid
    assert j({"label": "earth_rate", "form": "table_no_site"},
             {**sf, "alternatives": ["earth_rate"], "steady_rate": {"finding": "earth_rate"}})[1]
