"""The random-vibration truth per simulated second: ``decimated_noise`` (default) against ``node_rate_noise``.

Issue 26, item 2: a cheaper random-vibration truth of the same spectrum. Both generators stream
nav-stationary-1h's vibrations (angular 1e-6 (deg/s)^2/Hz and translational 0.002 g^2/Hz, 20 Hz to
2 kHz, 3 axes, node rate 14.4 kHz) the way the engine asks for them (``sins_sim.simulation.truth``):
gyro angle and rate on the 72 kHz plant grid (``grid_angle_rate``), acceleration at the three
Gauss-Legendre nodes and the end of each 7.2 kHz filter sample, velocity increments and end velocities per
sample (``Translation.sample_grid``); one-second chunks. Each timed call
streams at least one noise block (7.96 s) of both vibrations, so block generation is part of every
call. ``vibration_truth/node_rate_noise`` is the same-run ratio of their CPU times per simulated
second (thresholds.json).
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.bench import median_ratio
from sins_sim.models.motion import FilteredNoiseVibration, LinearRandomVibration
from sins_sim.simulation.truth import GL_NODES

DEG = math.pi / 180.0
PLANT_HZ, FILTER_HZ = 72_000, 7_200
ANGULAR = ((20.0, 1e-6 * DEG**2), (2000.0, 1e-6 * DEG**2))  # (rad/s)^2/Hz
LINEAR = ((20.0, 0.002), (2000.0, 0.002))  # g^2/Hz


def _streamer(generator: str, seconds: int):
    """A call streams the next ``seconds`` of both vibrations in 1 s chunks; returns the last chunk's rate."""
    ang = FilteredNoiseVibration(ANGULAR, seed=1021, generator=generator)
    lin = LinearRandomVibration(LINEAR, seed=5021, generator=generator)
    hf = 1.0 / FILTER_HZ
    state = {"s": 0}

    def run():
        for _ in range(seconds):
            s = state["s"]
            state["s"] += 1
            _, rate = ang.grid_angle_rate(s * PLANT_HZ - 1, PLANT_HZ, 1.0 / PLANT_HZ)
            lin.sample_grid(s * FILTER_HZ, FILTER_HZ, hf, GL_NODES)  # acceleration, increments, end velocities
        return rate, ang

    return run


def test_vibration_truth_per_simulated_second(benchmark, check_ratio, record, sizes):
    seconds = 8 if sizes["engine_s"] < 10 else 16  # at least one 7.96 s block per call
    new, old = _streamer("decimated_noise", seconds), _streamer("node_rate_noise", seconds)
    # result check: a second of each process has the table's RMS rate (sigma of the RMS over 1 s of a
    # 1980 Hz band: 0.5 / sqrt(1980) = 1.1 %; 5 sigma)
    for run in (new, old):
        rate, ang = run()
        assert np.allclose(np.sqrt(np.mean(rate**2, axis=0)), ang.rms_rate_rad_s, rtol=0.056)
    record(new)
    reps = max(3, sizes["repeats"])
    ratio, ns_new, ns_old = median_ratio(new, seconds, old, seconds, reps)
    benchmark.extra_info.update(ms_per_simulated_s_decimated_noise=ns_new * 1e-6,
                                ms_per_simulated_s_node_rate_noise=ns_old * 1e-6)
    check_ratio("vibration_truth/node_rate_noise", ratio)
