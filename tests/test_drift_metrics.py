"""Drift where drift is, the attitude error's definition, a filter's cost as a vector, Allan terms only
where they mean something (issue 22, items 1-3)."""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sins_sim import earth
from sins_sim._kernels.nav import error_rotvec
from sins_sim.config.imu import load_imu
from sins_sim.models import motion as m3
from sins_sim.models.sensor_errors import AccelErrorParams, GyroErrorParams, SensorErrorParams
from sins_sim.simulation.metrics import psi_angle
from sins_sim.simulation.sins import NavSettings, simulate_sins
from sins_sim.units import ARCSEC

IMU = load_imu("configs/default-imu.yaml")
NED = ("north", "east", "down")


def _run_metrics(tmp_path, imu_sensors: str, duration_s: float, filters=("ideal", "correcting"), name="s"):
    """Run a stationary scenario through the CLI's job and return its metrics."""
    from sins_sim.jobs.run import run_scenario

    imu_doc = (tmp_path / "imu.yaml")
    base = open("configs/default-imu.yaml").read()
    imu_doc.write_text(base + "\n" + imu_sensors + "\n")
    sc = tmp_path / f"{name}.yaml"
    sc.write_text(f"name: {name}\nimu: {imu_doc}\nduration_s: {duration_s}\nseed: 3\n"
                  f"filters: [{', '.join(filters)}]\nnavigation: {{start_s: 1.0}}\n"
                  "outputs: {plots: false, timeseries: false}\n")
    return run_scenario(sc, tmp_path / f"out-{name}", threads=2)


@pytest.fixture(scope="module")
def gyro_bias_metrics(tmp_path_factory):
    """A 0.01 deg/h bias on the x gyro (north: the unit sits level, heading north), nothing else, 20 min."""
    tmp = tmp_path_factory.mktemp("gyro-bias")
    return _run_metrics(tmp, "sensors:\n  gyro: {bias_deg_h: [0.01, 0.0, 0.0]}", 1200.0)


def test_gyro_bias_is_a_gyro_drift_on_its_axis_only(gyro_bias_metrics):
    """The bias is found as gyro drift within 5 % on x (the issue's tolerance; ideal and eq. 5 give 0.1 %:
    over 20 min the 12 arcsec ramp stands far above eq. 5's 0.4 arcsec quantisation noise), and y and z
    carry no drift."""
    for name in ("ideal", "correcting"):
        gd = gyro_bias_metrics["filters"][name]["gyro_drift_deg_h"]
        assert gd["x"]["status"] == "drift", (name, gd["x"])
        assert gd["x"]["value"] == pytest.approx(0.01, rel=0.05), name
        assert gd["x"]["ci95"] < 0.05 * 0.01
        for ax in "yz":
            assert gd[ax]["value"] is None and gd[ax]["status"] != "drift", (name, ax, gd[ax])


def test_gyro_bias_is_an_attitude_drift_north_despite_the_schuler_loop(gyro_bias_metrics):
    """At rest facing north the x bias is a north attitude drift. The tilt phi it causes is Schuler-bounded
    (the old ramp test on phi read 'no ramp'); the drift angle from psi reads 0.01 deg/h, and east and down,
    which the Earth rate couples to north (0.8 arcsec of east psi in 30 min), carry no drift."""
    for name in ("ideal", "correcting"):
        ad = gyro_bias_metrics["filters"][name]["attitude_drift_deg_h"]
        assert ad["north"]["status"] == "drift"
        assert ad["north"]["value"] == pytest.approx(0.01, rel=0.05)
        for ax in ("east", "down"):
            assert ad[ax]["status"] != "drift", (name, ax, ad[ax])


def test_accelerometer_bias_is_no_drift_anywhere(tmp_path):
    """A 10 ug accelerometer bias alone tilts the solution along the Schuler loop (phi of order b/g =
    2 arcsec, checked so that the test is not vacuous) and is reported as neither a gyro drift nor an
    attitude drift on any axis."""
    m = _run_metrics(tmp_path, "sensors:\n  accelerometer: {bias_ug: 10.0}", 1800.0)
    for name in ("ideal", "correcting"):
        f = m["filters"][name]
        assert max(f["attitude_error_arcsec"]["rms"][a] for a in ("north", "east")) > 1.0
        for ax in "xyz":
            assert f["gyro_drift_deg_h"][ax]["status"] != "drift", (name, ax)
        for ax in NED:
            assert f["attitude_drift_deg_h"][ax]["status"] != "drift", (name, ax, f["attitude_drift_deg_h"][ax])


def test_coning_heading_drift_keeps_its_values(tmp_path):
    """600 Hz coning (1 arcmin on x and y, 90 deg): the effective heading drift of eq. 5, its paper form and
    the eliminator navigated at every filter sample keeps the values of the coning table (1.80, 2.47,
    21.3 deg/h, README: an attitude replay at the filter rate). 0.5 %: the values are printed to three figures,
    their 95 % intervals are 0.002 deg/h.

    At the mission default, 400 Hz (issue 26), the drifts stay within 0.5 % of the full-rate ones: measured
    1.8098 against 1.8049 (eq. 5, +0.27 %), 2.4711 against 2.4669 (paper form, +0.17 %), 21.3316 against
    21.3339 deg/h (eliminator, -0.01 %). What the 400 Hz update adds is the third order of composing the
    sub-sample rotations of increments that carry the filters' residual dither, which the ideal increments
    do not (0.0797756 against 0.0797761 deg/h)."""
    from sins_sim.config.yaml_io import load_yaml
    from sins_sim.jobs.run import run_scenario

    path = Path("scenarios/coning-600hz.yaml").resolve()
    doc = dict(load_yaml(path))
    doc["imu"] = str((path.parent / doc["imu"]).resolve())
    doc["navigation"] = dict(doc["navigation"], rate_hz=7200.0)  # every filter sample
    full = run_scenario(doc, tmp_path / "c", threads=2)
    low = run_scenario(path, tmp_path / "d", threads=2)
    assert (full["navigation"]["n_sub"], low["navigation"]["n_sub"]) == (1, 18)
    for name, want in (("correcting", 1.80), ("correcting_paper", 2.47), ("eliminator", 21.3)):
        d = full["filters"][name]["attitude_drift_deg_h"]["down"]
        assert d["status"] == "drift"
        assert d["value"] == pytest.approx(want, rel=0.005, abs=0.005), name
        d400 = low["filters"][name]["attitude_drift_deg_h"]["down"]
        assert d400["value"] == pytest.approx(d["value"], rel=0.005), name


def _c_en(lat, lon):
    """C_e^n (ECEF to NED), written out (Titterton & Weston 2004, eq. 3.13)."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-sl * co, -sl * so, cl], [-so, co, 0.0], [-cl * co, -cl * so, -sl]])


def _q_scalar_first(mat):
    x, y, z, w = Rotation.from_matrix(mat).as_quat()
    return (w, x, y, z) if w >= 0 else (-w, -x, -y, -z)


@pytest.mark.parametrize("dn_m, de_m", [(30.0, 0.0), (0.0, -45.0), (20.0, 25.0)])
def test_phi_and_psi_against_an_independent_computation(dn_m, de_m):
    """One physical body orientation, a position error of tens of metres: the computed attitude is that
    orientation in the NED frame at the computed position. phi (the kernel's rotation vector of
    q_est (x) q_true*) must equal scipy's rotation vector of C_nb,est C_nb,true^T, and psi, the error
    against the computed position's frame, must vanish: the attitude itself is perfect. Tolerances:
    1e-12 rad for phi (two exact computations of the same rotation), and for psi the second order of the
    small-angle relation, (1e-5 rad)^2."""
    lat, lon, h = math.radians(45.0), math.radians(10.0), 500.0
    r_n, r_e = earth.radii(lat)
    lat_c = lat + dn_m / (r_n + h)
    lon_c = lon + de_m / ((r_e + h) * math.cos(lat))
    c_eb = Rotation.from_euler("ZYX", [0.7, -0.2, 0.3]).as_matrix()  # any body orientation in ECEF
    c_nb_true = _c_en(lat, lon) @ c_eb
    c_nb_est = _c_en(lat_c, lon_c) @ c_eb
    phi = np.array(error_rotvec(*_q_scalar_first(c_nb_est), *_q_scalar_first(c_nb_true)))
    want = Rotation.from_matrix(c_nb_est @ c_nb_true.T).as_rotvec()
    np.testing.assert_allclose(phi, want, atol=1e-12)
    assert np.linalg.norm(phi) > 1e-6  # the frames differ: phi is the position error angle here
    north = (lat_c - lat) * (r_n + h)
    east = (lon_c - lon) * math.cos(lat) * (r_e + h)
    ser = {"attitude_ned_rad": phi[None, :], "north_m": np.array([north]), "east_m": np.array([east]),
           "lat_rad": np.array([lat]), "h_m": np.array([h])}
    np.testing.assert_allclose(psi_angle(ser)[0], 0.0, atol=1e-10)


def test_psi_carries_no_schuler_tilt_in_the_engine():
    """In the engine, an accelerometer bias tilts phi by about b/g along the Schuler loop while psi stays
    at the navigation's numerical floor (below 1e-3 arcsec; phi: arcseconds)."""
    imu = dataclasses.replace(IMU, sensors=SensorErrorParams(accelerometer=AccelErrorParams(bias_ug=10.0)))
    res = simulate_sins(imu, m3.Static(), 1500.0, seed=1, nav=NavSettings(start_s=1.0), filters=("ideal",),
                        threads=2)
    ser = res.series["ideal"]
    phi = ser["attitude_ned_rad"] / ARCSEC
    psi = psi_angle(ser) / ARCSEC
    assert np.max(np.abs(phi[:, :2])) > 1.0
    assert np.max(np.abs(psi)) < 1e-3


def test_excess_over_ideal_is_the_norm_of_the_vector_difference(tmp_path):
    """On every bundled mission (first 12 s each): never negative, and the norm of the difference of the two
    final (north, east) error vectors as metrics.json gives them."""
    from sins_sim.jobs.run import run_scenario

    for mission in ("nav-trajectory-file", "nav-flight-30min", "nav-stationary-1h"):
        m = run_scenario(f"scenarios/{mission}.yaml", tmp_path / mission, overrides={"duration_s": 12.0}, threads=2)
        ideal = m["filters"]["ideal"]["horizontal_position_error_m"]
        for name, f in m["filters"].items():
            if name == "ideal" or "excess_over_ideal" not in f:
                continue
            h = f["horizontal_position_error_m"]
            exc = f["excess_over_ideal"]["horizontal_position_error_final_m"]
            assert exc >= 0.0
            want = math.hypot(h["final_north"] - ideal["final_north"], h["final_east"] - ideal["final_east"])
            assert exc == pytest.approx(want, rel=1e-12, abs=1e-15), (mission, name)


def test_allan_terms_not_determinable_in_flight(tmp_path):
    """A flight (the quick start's, first 40 s) on the default unit, which has no noise source: no noise
    term is reported for any filter or the accelerometers; each says why."""
    from sins_sim.jobs.run import run_scenario

    m = run_scenario("scenarios/nav-trajectory-file.yaml", tmp_path / "f", overrides={"duration_s": 40.0}, threads=2)
    assert m["allan"]["rest_span_s"] is None
    for name, f in m["filters"].items():
        for ax, r in f["allan"].items():
            assert r["determinable"] is False and "at rest" in r["reason"], (name, ax)
            assert all(r[k] is None for k in ("arw_deg_rt_h", "bias_instability_deg_h", "rrw_deg_h_rt_h"))
    json.dumps(m, allow_nan=False)


def test_stationary_navigation_grade_unit_reads_back_its_arw():
    """The navigation-grade unit (ARW 0.002 deg/sqrt(h)) at rest for 10 min: the ideal increments read back
    their ARW within 5 % (the issue's tolerance; two seeds gave 0.1-1.2 %: the fit spans three decades of
    tau with thousands of clusters at the short end). The eliminator's record, dominated at short tau by
    the aliased dither residual (a periodic, not a noise), is either not determinable or, where it is,
    its ARW is within 30 % of the sensor's."""
    imu = load_imu("configs/nav-grade-rlg.yaml")
    res = simulate_sins(imu, m3.Static(), 600.0, seed=1, nav=NavSettings(start_s=1.0),
                        filters=("ideal", "eliminator"), threads=2)
    for ax, a in res.allan["ideal"].items():
        assert a.determinable, a.reason
        assert a.readings()["arw_deg_rt_h"] == pytest.approx(0.002, rel=0.05), ax
    for ax, a in res.allan["eliminator"].items():
        arw = a.readings()["arw_deg_rt_h"]
        assert (not a.determinable and a.reason) or not np.isfinite(arw) or abs(arw / 0.002 - 1) < 0.3, ax


def test_a_vibrating_block_at_rest_is_at_rest():
    """The translational vibration of nav-stationary-1h (0.002 g^2/Hz, 20-2000 Hz: a few cm/s peak velocity)
    does not break the rest span the Allan analysis uses: the whole navigated record (29 s of 30) is at rest,
    where a raw speed threshold had kept 4 s."""
    from sins_sim.config.scenario import load_scenario

    sc = load_scenario("scenarios/nav-stationary-1h.yaml", {"duration_s": 30.0})
    res = simulate_sins(sc.imu, sc.motion, sc.duration_s, seed=sc.seed, nav=sc.nav, filters=("ideal",),
                        vehicle=sc.vehicle, translation=sc.translation, threads=2)
    assert res.allan["record_s"] == pytest.approx(29.0, abs=0.1)
    assert res.allan["rest_span_s"][0] == pytest.approx(1.0, abs=0.05)
