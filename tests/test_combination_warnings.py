"""Combinations that went wrong without a word (issue 38, item 4): the filter-tuned design that is ill-conditioned
for its filter, the eliminator's centre on a block, and the isolator modes with the gyros' inertia."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from sins_sim.config.imu import load_imu
from sins_sim.config.scenario import load_scenario
from sins_sim.navigation.coning import coefficient_matrix
from sins_sim.simulation.responses import tuned_design

ROOT = Path(__file__).resolve().parents[1]


# --- filter_tuned: checked against two-sample, falls back when ill-conditioned ---------------------------------------

@pytest.fixture(scope="module")
def unit():
    imu = load_imu(ROOT / "configs" / "default-imu.yaml")
    return imu.channels, imu.filter_rate_hz


def test_an_ill_conditioned_design_falls_back_to_two_sample(unit):
    """correcting_wideband over 20-200 Hz: the least-squares design reaches coefficients in the hundreds (348 on
    the default unit) for a 0.7 % in-band gain, and over the whole band of the increments it leaves hundreds of
    times the coning rate where two-sample leaves about half of it (its uncompensated fraction at high x). The
    fallback is the two-sample coefficient matrix exactly; the rejected design is kept for the record."""
    channels, fs = unit
    d = tuned_design(channels, "correcting_wideband", (20.0, 200.0), fs)
    assert d["fallback"] == "two_sample"
    np.testing.assert_array_equal(d["coefficients"], coefficient_matrix("two_sample"))
    assert np.max(np.abs(d["tuned_coefficients"])) > 100.0
    whole = d["whole_band_residual"]
    # the decision's own terms: what it removes in band is smaller than what it adds over the whole band
    assert np.any(d["check"]["loss"] > d["check"]["gain"])
    assert np.all(whole["filter_tuned"]["rms"] > 100.0 * whole["two_sample"]["rms"])
    assert "correcting_wideband navigates with two_sample" in d["reason"] and "\n" not in d["reason"]


@pytest.mark.parametrize("name, band", [("eliminator", (200.0, 300.0)), ("eliminator", (600.0, 1000.0)),
                                        ("ideal", (20.0, 200.0)), ("correcting", (600.0, 1000.0))])
def test_a_well_conditioned_design_is_kept(unit, name, band):
    """The eliminator's designs have large coefficients too (150-1700), but its response falls off outside its
    band, so over the whole band it leaves no more than two-sample: kept (the pseudo-coning-300hz-tuned scenario
    and the coning table's 600-1000 Hz rely on it). The identity's flat design and eq. 5 above its resonances are
    kept as well."""
    channels, fs = unit
    d = tuned_design(channels, name, band, fs)
    assert d["fallback"] is None
    assert d["coefficients"] is d["tuned_coefficients"]
    assert np.all(d["check"]["gain"] >= d["check"]["loss"])


def _nav_doc(**nav):
    return {"name": "t", "duration_s": 3.0, "imu": str(ROOT / "configs" / "default-imu.yaml"),
            "motion": [{"type": "random_vibration", "psd_deg2_s2_per_hz": [[20, 1.0e-6], [2000, 1.0e-6]],
                        "f_lo_hz": 20, "f_hi_hz": 2000, "axes": [1.0, 1.0, 1.0]}],
            "filters": ["ideal", "eliminator", "correcting_wideband"],
            "navigation": {"start_s": 1.0, **nav}, "outputs": {"plots": False, "timeseries": False}}


def test_the_scenario_warns_one_line_and_that_filter_navigates_two_sample():
    """At load: one warning line for correcting_wideband only; its navigator gets the two-sample coefficients for
    coning and sculling; the eliminator and the ideal keep their tuned designs."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scenario(_nav_doc(coning="filter_tuned", sculling="filter_tuned", tuned_band_hz=[20.0, 200.0]))
    lines = [str(w.message) for w in caught if "ill-conditioned" in str(w.message)]
    assert len(lines) == 1 and "\n" not in lines[0], lines
    assert lines[0].startswith("navigation.coning: filter_tuned over 20-200 Hz is ill-conditioned for the filter "
                               "correcting_wideband")
    coning, sculling = sc.nav.compensation("correcting_wideband")
    np.testing.assert_array_equal(coning, coefficient_matrix("two_sample"))
    np.testing.assert_array_equal(sculling, coefficient_matrix("two_sample"))
    assert sc.nav.designs["eliminator"]["fallback"] is None
    assert sc.nav.designs["ideal"]["fallback"] is None


# --- the eliminator's centre on a block: the drive it is built on -----------------------------------------------------

def test_the_eliminator_centre_is_the_drive_the_engine_builds_on_a_block(tmp_path):
    """On a block each drive runs at its suspension's coupled resonance (3.4 Hz above the rigid one on the bundled
    block). The engine's eliminator, the drives table (the chains' drive frequency), the manifest's filter table
    (the report's "around the drive at" line) and the tuned coning design all use that one frequency."""
    from sins_sim.jobs.manifest import Manifest, record_run
    from sins_sim.jobs.run import _filter_parameters_report
    from sins_sim.models.block import coupled_dither_frequencies
    from sins_sim.simulation.sins import tuned_designs
    from sins_sim.simulation.unit import SensorUnit

    path = ROOT / "scenarios" / "isolated-block.yaml"
    sc = load_scenario({**load_scenario(path).document, "imu": str(ROOT / "configs" / "isolated-block.yaml"),
                        "filters": ["ideal", "eliminator"]})
    imu = sc.imu
    rigid = [c.drive_signal().frequency_hz for c in imu.channels]
    coupled = coupled_dither_frequencies(imu.block, [2.0 * math.pi * f for f in rigid])
    assert np.all(coupled - np.array(rigid) > 1.0)  # the two candidates differ by far more than the checks' rounding
    unit = SensorUnit(imu, seed=0)
    manifest = Manifest("run")
    record_run(manifest, sc, sc.document, None, tmp_path)
    used = manifest.doc["run"]["filter_parameters"]["filters"]["eliminator"]
    report = _filter_parameters_report(manifest.doc["run"]["filter_parameters"])
    designs = tuned_designs(imu, ["eliminator"], (600.0, 1000.0))
    for a, (axis, chain) in enumerate(zip("xyz", unit.chains)):
        band = chain.filters["eliminator"].design.band_hz
        centre = 0.5 * (band[0] + band[1])
        # the band is built as drive +- width / 2: its centre is the drive to rounding (1e-12 relative)
        assert centre == pytest.approx(coupled[a], rel=1e-12)
        assert chain.drive.frequency_hz == pytest.approx(coupled[a], rel=1e-12)  # the drives table's source
        assert used[axis]["drive_hz"] == pytest.approx(coupled[a], rel=1e-12)
        assert f"around the drive at {coupled[a]:.6g} Hz" in report
    # the tuned design reads the eliminator of the run's channels: the same as the engine's responses
    from sins_sim.simulation.responses import increment_responses
    from sins_sim.simulation.unit import run_channels

    f = np.linspace(600.0, 1000.0, 201)
    got = tuned_design(run_channels(imu), "eliminator", (600.0, 1000.0), imu.filter_rate_hz)
    np.testing.assert_array_equal(designs["eliminator"]["tuned_coefficients"], got["tuned_coefficients"])
    assert not np.allclose(increment_responses(imu.channels, "eliminator", f),
                           increment_responses(run_channels(imu), "eliminator", f), rtol=1e-3)


# --- the isolator modes include the gyros' inertia ----------------------------------------------------------------------

def _free_rocking_hz(block, suspensions, rate_hz, seconds=0.5):
    """The rocking frequency about x of the coupled plant the engine integrates (``CoupledPlant``), from its free
    oscillation after a step in the chassis rate about x (an impulse of angular acceleration), by the mean period
    between the first and the last upward zero crossing (linear interpolation)."""
    from sins_sim.models.block import CoupledPlant
    from sins_sim.models.plant import PlantSettings

    plant = CoupledPlant(suspensions, block, PlantSettings(rate_hz=rate_hz))
    n = int(seconds * rate_hz)
    t = np.arange(1, n + 1) / rate_hz
    rate = np.zeros((3, n))
    rate[0] = 1e-3  # rad/s from t = 0+: the block is left behind and rocks on its isolators
    ang = np.zeros((3, n))
    ang[0] = 1e-3 * t
    _, z = plant.step(ang, rate, np.zeros((3, n)))
    th = z[3] - np.mean(z[3])
    up = np.nonzero((th[:-1] < 0.0) & (th[1:] >= 0.0))[0]
    tc = t[up] + (t[up + 1] - t[up]) * (-th[up]) / (th[up + 1] - th[up])
    return (len(tc) - 1) / (tc[-1] - tc[0])


def test_reported_isolator_mode_is_the_mode_the_plant_integrates():
    """The bundled block with undamped isolators: the rocking about x measured on the coupled plant is the reported
    mode (the linearised block with its gyros on their suspensions) to 1e-4; the gyro-locked model is 6e-4 off, and
    the block without its gyros' inertia (what the report gave before) 8e-3 off: 1 + J_g / J_b = 1.0167 in inertia.
    The tolerance: the zero-crossing period over 50 cycles at 72 kHz resolves 1e-7 of a period; the plant's exact
    step and its cubic torque history leave O((w h)^4) = 1e-10; the suspensions' hysteresis at the micro-radian
    deflections the rocking makes damps it by under 1e-6 of critical, which moves the frequency by its square."""
    from sins_sim.models.block import BlockParams

    imu = load_imu(ROOT / "configs" / "isolated-block.yaml")
    b = imu.block
    free = BlockParams(mass_kg=b.mass_kg, inertia_kg_m2=b.inertia_kg_m2, gyro_inertia_kg_m2=b.gyro_inertia_kg_m2,
                       k_trans_n_per_m=b.k_trans_n_per_m, k_rot_n_m_per_rad=b.k_rot_n_m_per_rad)
    sus = [c.suspension for c in imu.channels]
    om = [2.0 * math.pi * c.drive_signal().frequency_hz for c in imu.channels]
    measured = _free_rocking_hz(free, sus, imu.plant_rate_hz)
    reported = [f for f, _ in free.isolator_modes(om)]
    nearest = min(reported, key=lambda f: abs(f - measured))
    assert nearest == pytest.approx(measured, rel=1e-4), (reported, measured)
    locked = min((f for f, _ in free.isolator_modes()), key=lambda f: abs(f - measured))
    without = math.sqrt(free.k_rot_n_m_per_rad[0] / free.inertia_kg_m2[0, 0]) / (2.0 * math.pi)
    assert abs(locked / measured - 1.0) > 3e-4 and abs(without / measured - 1.0) > 5e-3


def test_the_run_reports_the_modes_of_the_coupled_model():
    """What a run stores (``SinsResult.block``, the report's "Isolator modes" line) is the coupled model's."""
    from sins_sim.simulation.unit import SensorUnit

    imu = load_imu(ROOT / "configs" / "isolated-block.yaml")
    om = [2.0 * math.pi * c.drive_signal().frequency_hz for c in imu.channels]
    rec = SensorUnit(imu, seed=0).record(0, imu.filter_rate_hz)
    expected = [f for f, _ in imu.block.isolator_modes(om) if f > 0.0]
    assert rec["isolator_modes_hz"] == pytest.approx(expected, rel=1e-12)
    # the rocking modes sit below the gyro-less ones by about J_g / (2 J_b) = 0.8 %
    bare = [math.sqrt(k / j) / (2.0 * math.pi) for k, j in zip(imu.block.k_rot_n_m_per_rad,
                                                                 np.diag(imu.block.inertia_kg_m2))]
    assert max(rec["isolator_modes_hz"][3:]) < min(bare)
