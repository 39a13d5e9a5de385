"""The Earth turns under every bench (issue 39, item 1): the diagnosis with and without ``meta.site``.

Recordings: 1 s at 7.2 kHz, written by RK4 at 72 kHz (the diagnosis fits with the exact integrator at its
own rate, so "none" is not an identical simulator), three axes x, y, z at 3 arcmin of dither, the unit at
latitude 56.8 deg. The Earth's rate there is 15.04 deg/h: over 1 s, 15 arcsec of ramp spread over the axes,
hundreds of times the readout's quantum (0.15 arcsec).

Tolerances on estimates are 4 of their reported one-sigma errors: a two-sided 4-sigma band is missed with
probability 6e-5 by a Gaussian error, so a failure means a wrong value or a sigma too small, not bad luck.
"""

from __future__ import annotations

import copy

import pytest

from sins_sim.earth import EARTH_RATE_RAD_S
from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording, write_report
from sins_sim.identification.steady_rate import MAX_PLAUSIBLE_BIAS_DEG_H
from sins_sim.io.recording import Recording
from sins_sim.jobs.recording_jobs import format_diagnosis
from sins_sim.models.effects import make_effect
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import ExperimentInputs, record, stationary_drive, table_motion
from sins_sim.simulation.site import SiteGeometry, earth_motions, table_on_axes
from sins_sim.units import ARCMIN, DEG, DEG_PER_H, INTERPOLATED_QUANTUM_RAD

from test_diagnose import FS, NOM, TRUTH, TRUTH_SETTINGS, _recording  # noqa: E402  (the shared bench unit)

AXES = ["x", "y", "z"]
NOM3 = {**NOM, "z": SuspensionParams(f0_hz=421.0)}
TRUTH3 = {**TRUTH, "z": NOM3["z"].replace(f0_hz=421.0 * 1.001, k3=4.4e-3 * 1.02, k5=-1.2e-5 * 0.99)}
LEVEL = {"latitude_deg": 56.8, "orientation_ned": {"heading_deg": 304.0, "pitch_deg": 0.0, "roll_deg": 0.0}}
TILTED = {"latitude_deg": 56.8, "orientation_ned": {"heading_deg": 304.0, "pitch_deg": -0.7, "roll_deg": 1.1},
          "table_axis_ned": [0.6, 0.0, 0.8]}
#: Only the Earth-rate and baseline machinery matter here: one cheap candidate keeps a wrong gap affordable.
SETTINGS = DiagnoseSettings(effects=("lock_in",))


def _bench(site: dict, duration: float = 1.0, table: bool = False) -> Recording:
    n = int(round(duration * FS)) + 1
    nom = {a: NOM3[a] for a in AXES}
    drive = stationary_drive(nom, AXES, 3 * ARCMIN, FS, n)
    tab = None
    if table:  # 12 deg/s about the tilted axis, with a 7 Hz swing of 30 arcmin on top
        tab = table_on_axes(site, AXES, table_motion(12 * DEG, [(30 * ARCMIN, 7.0, 0.3)]))
    inputs = ExperimentInputs(AXES, FS, n, FS, drive, tab, earth_motions(site, AXES, (n - 1) / FS, tab))
    return record(inputs, {a: TRUTH3[a] for a in AXES}, nom, INTERPOLATED_QUANTUM_RAD, [], TRUTH_SETTINGS,
                  experiment="rate_table" if table else "stationary", extra_meta={"site": site})


def _without_site(rec: Recording) -> Recording:
    meta = copy.deepcopy(rec.meta)
    meta.pop("site")
    return Recording(meta, rec.counts, rec.drive_v, rec.sins_angle)


@pytest.fixture(scope="module")
def level():
    return _bench(LEVEL)


def test_still_bench_with_site_is_none(level):
    js = diagnose_recording(level, SETTINGS).to_json()
    assert js["verdict"]["status"] == "none" and not js["gap"]["significant"]
    assert js["verdict"]["steady_rate"] is None
    # the model carries the Earth's rate, so the bias nuisance is left near 0: below a hundredth of the
    # Earth's rate on every axis, where a model without it leaves the whole projection (4 to 12.6 deg/h here)
    for a, d in js["baseline"]["bias_drift"].items():
        assert abs(d["bias_deg_h"]) < 0.01 * EARTH_RATE_RAD_S / DEG_PER_H, a


def test_still_bench_without_site_names_the_earth_rate(level, tmp_path):
    diag = diagnose_recording(_without_site(level), SETTINGS)
    js = write_report(diag, tmp_path)
    assert "steady rate (earth_rate): the Earth's rate: give the site" in (tmp_path / "report.md").read_text()
    assert "steady rate (earth_rate): the Earth's rate: give the site" in format_diagnosis(js)  # what the CLI prints
    assert js["verdict"]["status"] == "none"  # the bias nuisance absorbs the rates; the finding names them
    sr = js["verdict"]["steady_rate"]
    assert sr["finding"] == "earth_rate" and "give the site and orientation" in sr["message"]
    assert sr["magnitude_deg_h"] == pytest.approx(EARTH_RATE_RAD_S / DEG_PER_H, abs=4 * sr["magnitude_sigma_deg_h"])
    geo = SiteGeometry(LEVEL)
    want = geo.earth_body / EARTH_RATE_RAD_S
    for i, a in enumerate(AXES):
        assert sr["rate_deg_h"][a] == pytest.approx(geo.earth_body[i] / DEG_PER_H, abs=4 * sr["sigma_deg_h"][a])
        assert sr["earth_axis"][a] == pytest.approx(want[i], abs=4 * sr["earth_axis_sigma"][a]), a
    lv = sr["if_level"]
    assert lv["latitude_deg"] == pytest.approx(56.8, abs=4 * lv["latitude_sigma_deg"])
    assert lv["heading_deg"] == pytest.approx(304.0, abs=4 * lv["heading_sigma_deg"])
    # the sigmas are those of 1 s of a 0.15 arcsec counter: a few thousandths of a deg/h, not a free pass
    assert max(sr["sigma_deg_h"].values()) < 0.02


def test_tilted_rate_table_with_site_is_none():
    rec = _bench(TILTED, duration=0.5, table=True)
    js = diagnose_recording(rec, SETTINGS).to_json()
    assert js["verdict"]["status"] == "none" and not js["gap"]["significant"]
    # the same recording read without its site leaves the Earth's rate (no bias nuisance under a moving table)
    # as a ramp of up to 15 arcsec/s: a significant gap, so the site is what makes the verdict
    js2 = diagnose_recording(_without_site(rec), SETTINGS).to_json()
    assert js2["gap"]["significant"] and js2["verdict"]["status"] != "none"


@pytest.mark.parametrize("bias_deg_h, finding", [(2.0, "gyro_bias"), (3.0 * MAX_PLAUSIBLE_BIAS_DEG_H, "unknown")])
def test_a_steady_rate_of_another_magnitude(bias_deg_h, finding):
    rec = _recording("stationary", [make_effect("bias_drift", bias_rad_s=bias_deg_h * DEG_PER_H)], duration=1.0)
    sr = diagnose_recording(rec, SETTINGS).to_json()["verdict"]["steady_rate"]
    assert sr["finding"] == finding, sr["message"]
    assert sr["rate_deg_h"]["x"] == pytest.approx(bias_deg_h, abs=4 * sr["sigma_deg_h"]["x"])


def test_no_steady_rate_no_finding():
    rec = _recording("stationary", duration=1.0)
    assert diagnose_recording(rec, SETTINGS).to_json()["verdict"]["steady_rate"] is None
