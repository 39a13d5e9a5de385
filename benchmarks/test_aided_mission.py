"""GNSS-aided missions (issue 37, item 7): an aided mission against the free one, per simulated second.

The same scenario (the default unit in a 60 m/s cruise under rotor lines, ``ideal`` and two dither filters) run
free and with ``aiding:`` (GNSS at 5 Hz, or at the update rate when that is higher, the covariance propagated once
per update), both on one thread (so the calling thread's CPU time holds the whole run), same run, interleaved, at
the issue's update rates 1, 5 and 10 Hz. The issue asks for at most 1.2 times. Reported beside it (not enforced):
the aided navigation alone against the free navigation alone on the same increments (7.2 kHz, 400 Hz updates),
the part the aiding adds to. Besides, the filter with the gyros' scale-factor and misalignment states and the fixes'
Gauss-Markov states (27 states, updates at 5 Hz): the same compiled path with the bigger algebra.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sins_sim.bench import median_ratio

ROOT = Path(__file__).resolve().parents[1]
#: The filter's update rates of the benchmark (Hz): the issue's 1-10 Hz. Per update the filter costs about 30 us
#: per dither filter on this machine (the epoch in one compiled call per chunk: the 18 x 18 propagation, the
#: update, its records and the feedback), per simulated second and filter about 0.4 ms besides (the aided
#: navigator's own strapdown pass, the chunk's Python glue, the fixes); per run each filter's set-up and finish.
UPDATE_HZ = (1.0, 5.0, 10.0)
#: The ratios' names in thresholds.json, per update rate (the 1 Hz name is the original one).
RATIO_NAME = {1.0: "aided_mission/free_mission", 5.0: "aided_mission/free_mission 5 Hz",
              10.0: "aided_mission/free_mission 10 Hz"}


#: The filter with sensor-error states: the gyros' scale factors and misalignments (9) and the fixes' Gauss-Markov
#: position error (3), 27 states in all.
SENSOR_STATES = {"markov_sigma_m": [0.5, 0.5, 1.0], "sensor_error_states": ["gyro_scale_factor", "gyro_misalignment"]}


def _doc(duration_s, aided, update_hz=1.0, extra=None):
    doc = {"name": "bench-aided", "seed": 3, "duration_s": duration_s, "imu": "configs/nav-grade-rlg.yaml",
           "site": {"lat_deg": 52.0, "lon_deg": 4.5, "height_m": 300.0, "heading_deg": 40.0},
           "trajectory": {"speed_m_s": 60.0, "segments": [{"type": "cruise", "duration_s": duration_s + 5.0}]},
           "motion": [{"type": "sines", "amplitude_arcmin": [0.2, 0.3, 0.1], "frequency_hz": [21.6, 21.6, 21.6]},
                      {"type": "sines", "amplitude_arcmin": [0.02, 0.02, 0.03], "frequency_hz": [89.5, 89.5, 89.5]}],
           "filters": ["ideal", "eliminator", "correcting"], "navigation": {"start_s": 1.0, "rate_hz": 400.0},
           "outputs": {"plots": False, "timeseries": False}}
    if aided:
        doc["aiding"] = {"rate_hz": max(5.0, update_hz), "update_rate_hz": update_hz, "lever_arm_m": [0.5, 0.0, -1.2],
                         **(extra or {})}
    return doc


def _mission(duration_s, aided, update_hz=1.0, extra=None):
    from sins_sim.config.scenario import load_scenario
    from sins_sim.simulation.sins import simulate_sins

    sc = load_scenario(_doc(duration_s, aided, update_hz, extra), base_dir=ROOT)

    def run():
        return simulate_sins(sc.imu, sc.motion, sc.duration_s, seed=sc.seed, nav=sc.nav, filters=sc.filters,
                             threads=1, vehicle=sc.vehicle, translation=sc.translation)

    return run


def _navigations(n_s, update_hz=1.0):
    """The aided and the free navigation alone on the same increments (a level unit at rest: gravity and the
    Earth rate; fixes at the update rate, no outage)."""
    from sins_sim import earth
    from sins_sim.navigation import ekf
    from sins_sim.navigation.aided import AidedRun
    from sins_sim.navigation.gnss import GnssSettings, simulate_gnss
    from sins_sim.navigation.strapdown import StrapdownNavigator

    fs, n_sub = 7200.0, 18
    n = int(n_s * fs)
    lat, h = np.radians(52.0), 300.0
    dth = np.tile(earth.earth_rate_ned(lat) / fs, (n, 1))
    dv = np.tile([0.0, 0.0, -float(earth.gravity_down(lat, h)) / fs], (n, 1))
    t_truth = np.arange(0, n + 1) / fs
    t_fix = t_truth[::int(round(fs / update_hz))]     # the fixes' times at the update rate
    fixes = simulate_gnss(t_fix, np.full(t_fix.shape, lat), np.zeros(t_fix.shape), np.full(t_fix.shape, h),
                          np.zeros((t_fix.size, 3)),
                          GnssSettings(rate_hz=update_hz), seed=1)
    noise = ekf.ImuNoise.from_datasheet(0.002, 20.0, 0.0035, 25.0)
    p0 = ekf.initial_covariance(1.0, 0.05, 1e-4, 1e-3, noise)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])

    def aided():
        start = ekf.NavState(0.0, lat, 0.0, h, np.zeros(3), q0, np.zeros(3), np.zeros(3))
        run = AidedRun(0.0, 1.0 / fs, n, start, noise, p0, fixes.t_valid_s, fixes.t_deliver_s, fixes.position_sigma_m,
                       fixes.velocity_sigma_m_s, fixes.lever_arm_b_m, output_t_s=np.arange(0.0, n_s, 1.0),
                       n_sub=n_sub, max_propagation_s=1.0 / update_hz)
        run.add_fixes(fixes)
        for a in range(0, n, int(fs)):  # in the engine's 1 s chunks
            run.feed(dth[a:a + int(fs)], dv[a:a + int(fs)])
        return run.result()

    def free():
        nav = StrapdownNavigator(lat, 0.0, h, np.zeros(3), q0, 1.0 / fs, n_sub=n_sub)
        for a in range(0, n, int(fs)):
            nav.process(dth[a:a + int(fs)], dv[a:a + int(fs)])
        return nav

    return aided, free, n


@pytest.mark.parametrize("update_hz", UPDATE_HZ)
def test_aided_mission_against_the_free_one(benchmark, check_ratio, record, sizes, update_hz):
    dur = 4.0 if sizes["engine_s"] < 10 else 20.0
    aided, free = _mission(dur, True, update_hz), _mission(dur, False)
    res = record(aided)
    # result: every filter has an aided run with finite errors at its epochs, and the free runs are the same with
    # and without aiding (the aided navigation reads the same increments and changes nothing else)
    base = free()
    for name in ("ideal", "eliminator", "correcting"):
        assert np.all(np.isfinite(res.aided[name]["errors"])) and len(res.aided[name]["result"]) >= update_hz * (dur - 2)
        assert res.stats[name].last["horizontal_m"] == base.stats[name].last["horizontal_m"]
    reps = max(3, sizes["repeats"] // 2)
    ratio, ns, base_ns = median_ratio(aided, 1, free, 1, reps)
    nav_a, nav_f, n = _navigations(dur, update_hz)
    nav_ratio, nav_ns, free_ns = median_ratio(nav_a, n, nav_f, n, reps)
    benchmark.extra_info.update(aided_mission_s_per_simulated_s=ns * 1e-9 / dur,
                                free_mission_s_per_simulated_s=base_ns * 1e-9 / dur,
                                aided_navigation_ns_per_sample=nav_ns, free_navigation_ns_per_sample=free_ns)
    benchmark.extra_info["update_rate_hz"] = update_hz
    if update_hz == 1.0:
        check_ratio("aided_navigation/free_navigation", nav_ratio)
    else:
        benchmark.extra_info[f"aided_navigation/free_navigation {update_hz:g} Hz"] = round(nav_ratio, 4)
    check_ratio(RATIO_NAME[update_hz], ratio)


def test_aided_mission_with_sensor_states_against_the_free_one(benchmark, check_ratio, record, sizes):
    """The 27-state filter (gyro scale factors and misalignments, the fixes' Gauss-Markov error) at 5 Hz."""
    dur = 4.0 if sizes["engine_s"] < 10 else 20.0
    aided, free = _mission(dur, True, 5.0, SENSOR_STATES), _mission(dur, False)
    res = record(aided)
    base = free()
    for name in ("ideal", "eliminator", "correcting"):
        r = res.aided[name]["result"]
        assert r.sigma.shape[1] == 27 and np.all(np.isfinite(res.aided[name]["errors"])) and len(r) >= 5 * (dur - 2)
        assert res.stats[name].last["horizontal_m"] == base.stats[name].last["horizontal_m"]
    ratio, ns, base_ns = median_ratio(aided, 1, free, 1, max(3, sizes["repeats"] // 2))
    benchmark.extra_info.update(aided_mission_s_per_simulated_s=ns * 1e-9 / dur,
                                free_mission_s_per_simulated_s=base_ns * 1e-9 / dur, update_rate_hz=5.0)
    check_ratio("aided_mission/free_mission 27 states 5 Hz", ratio)
