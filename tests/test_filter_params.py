"""The filters' own parameters (issue 11, item 4): true, nominal (datasheet + dither PLL), explicit, diagnose."""

import json

import pytest

from sins_sim.config.imu import imu_from_dict, load_imu, load_yaml
from sins_sim.config.scenario import load_scenario
from sins_sim.config.errors import ConfigError
from sins_sim.models.motion import SineMotion
from sins_sim.simulation.channel import simulate_channel
from sins_sim.units import ARCMIN

SPREAD = load_yaml("configs/spread-imu.yaml")
DEFAULT = load_yaml("configs/default-imu.yaml")


def _imu(doc, fp, **kw):
    return imu_from_dict(dict(doc, filter_parameters=fp), "test.yaml", **kw)


def test_true_is_todays_behaviour():
    """No key and ``true`` give the filters the unit's own parameters (filter_suspension None)."""
    for imu in (load_imu("configs/spread-imu.yaml"), _imu(SPREAD, True), _imu(SPREAD, "true")):
        assert all(ch.filter_suspension is None for ch in imu.channels)


def test_nominal_takes_the_datasheet_and_the_pll_f0():
    imu = _imu(SPREAD, "nominal")
    sus = SPREAD["suspension"]
    for ch in imu.channels:
        b = ch.filter_suspension
        assert (b.k1, b.k2, b.k3, b.k4, b.k5) == (sus["k1"], sus["k2_rad"], sus["k3"], sus["k4_per_rad"],
                                                  sus["k5_rad_per_v"])
        # PLL: the believed F(a) equals the drive frequency the unit locks to
        assert b.resonance_hz(ch.drive.amplitude_rad) == pytest.approx(ch.drive_signal().frequency_hz, rel=1e-12)
        # the nominal k1, k2 differ from the unit's, so the PLL's f0 is off by a few hundred ppm, not more
        assert 0.0 < abs(b.f0_hz / ch.suspension.f0_hz - 1.0) < 2e-3


def test_pll_with_the_true_k_returns_the_true_f0():
    """When the believed k1, k2 are the true ones, inverting F(a) gives f0 back (to rounding)."""
    imu = _imu(DEFAULT, {"source": "true", "f0": "pll"})
    for ch in imu.channels:
        assert ch.filter_suspension.f0_hz == pytest.approx(ch.suspension.f0_hz, rel=1e-12)


def test_mismatch_ppm_and_explicit_values():
    imu = _imu(SPREAD, {"source": "true", "f0_mismatch_ppm": 1000.0})
    for ch in imu.channels:
        assert ch.filter_suspension.f0_hz == pytest.approx(ch.suspension.f0_hz * 1.001, rel=1e-12)
        assert ch.filter_suspension.k3 == ch.suspension.k3
    imu = _imu(SPREAD, {"source": "explicit", "f0": "given", "suspension": {"k3": 5e-3},
                        "channels": {"x": {"f0_hz": 383.0, "suspension": {"k1": 1.9e-4}},
                                     "y": {"f0_hz": 347.0}, "z": {"f0_hz": 429.0}}})
    x, y = imu.channels[0].filter_suspension, imu.channels[1].filter_suspension
    assert (x.f0_hz, x.k1, x.k3, x.k2) == (383.0, 1.9e-4, 5e-3, SPREAD["suspension"]["k2_rad"])
    assert (y.f0_hz, y.k1, y.k3) == (347.0, SPREAD["suspension"]["k1"], 5e-3)


def test_diagnose_json(tmp_path):
    params = {a: {"f0_hz": f, "k1": 1.8e-4, "k2": 1.0e-3, "k3": 4.3e-3, "k4": 245.0, "k5": -1.22e-5}
              for a, f in (("x", 383.4), ("y", 347.3), ("z", 428.8))}
    (tmp_path / "unit.json").write_text(json.dumps({"baseline": {"params": params}}))
    imu = _imu(SPREAD, {"source": "diagnose", "file": "unit.json"}, base_dir=tmp_path)
    assert [ch.filter_suspension.f0_hz for ch in imu.channels] == [383.4, 347.3, 428.8]
    assert imu.channels[2].filter_suspension.k4 == 245.0


@pytest.mark.parametrize("fp, match", [
    ("datasheet", "filter_parameters: must be true, nominal or a mapping"),
    (False, "filter_parameters: must be true, nominal or a mapping"),
    ({"source": "diagnose"}, r"filter_parameters.file: required with source: diagnose"),
    ({"source": "diagnose", "file": "missing.json"}, "filter_parameters.file: file not found"),
    ({"source": "nominal", "suspension": {"k1": 1e-4}}, "suspension and channels only with source: explicit"),
    ({"source": "explicit", "f0": "given"}, r"filter_parameters.channels.x.f0_hz: required with f0: given"),
    ({"source": "true", "f0_mismatch_ppm": 1e6}, r"filter_parameters.f0_mismatch_ppm: must be <="),
    ({"source": "explicit", "suspension": {"k3": 0.5}}, r"filter_parameters.suspension.k3: must be <="),
])
def test_bad_filter_parameters_are_one_line(fp, match, tmp_path):
    with pytest.raises(ConfigError, match=match) as exc:
        _imu(SPREAD, fp, base_dir=tmp_path)
    assert "\n" not in str(exc.value)


def test_bad_diagnosis_file(tmp_path):
    (tmp_path / "d.json").write_text(json.dumps({"verdict": {}}))
    with pytest.raises(ConfigError, match="has no baseline.params"):
        _imu(SPREAD, {"source": "diagnose", "file": "d.json"}, base_dir=tmp_path)
    (tmp_path / "d.json").write_text(json.dumps({"baseline": {"params": {"x": {"f0_hz": 383.0}}}}))
    with pytest.raises(ConfigError, match="baseline.params.x must hold f0_hz, k1..k5"):
        _imu(SPREAD, {"source": "diagnose", "file": "d.json"}, base_dir=tmp_path)


def test_scenario_key_replaces_the_imu_files(tmp_path):
    sc = tmp_path / "s.yaml"
    sc.write_text("name: s\nimu: %s\nduration_s: 2\nfilter_parameters: nominal\n"
                  % (__import__("pathlib").Path("configs/spread-imu.yaml").resolve()))
    s = load_scenario(sc)
    assert all(ch.filter_suspension is not None for ch in s.imu.channels)
    sc.write_text(sc.read_text().replace("filter_parameters: nominal", "filter_parameters: {source: guess}"))
    with pytest.raises(ConfigError, match="filter_parameters.source: must be one of"):
        load_scenario(sc)


def test_nominal_k_grow_the_correcting_residual_as_measured():
    """Issue 11's library measurement, axis x of the spread IMU under 1 arcmin at 100 Hz: the correcting
    filter's residual goes from 0.452 arcsec (true parameters) to 0.491 (nominal k's), a factor 1.086.
    The factor is checked within 10 % (the issue's tolerance; the absolute residuals depend on the run's
    length and settling, which the issue does not give, so the ratio is what is compared)."""
    motion = SineMotion(amplitude_rad=ARCMIN, frequency_hz=100.0)
    res = {}
    for key, fp in (("true", True), ("nominal", {"source": "nominal", "f0": "unit"})):
        r = simulate_channel(_imu(SPREAD, fp).channels[0], 2.0, motion=motion, seed=0)
        res[key] = r.residual_rms(settle_s=1.0)["correcting"]
    assert res["nominal"] / res["true"] == pytest.approx(0.491 / 0.452, rel=0.10)
    assert res["nominal"] > res["true"] * 1.03  # the mismatch costs something measurable
