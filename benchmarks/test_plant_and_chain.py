"""One suspension's plant step and the whole three-axis chain against same-run baselines.

- the plant ("exact" integrator) against RK4 in plain Python on a short record (result
  check and speed-up), against the numba RK4 reference integrator, and against
  ``scipy.signal.sosfilt`` (the machine's yardstick);
- the three-axis chain (3 x plant at 72 kHz, readout and drive decimated to 7.2 kHz, eq. 5 in
  both forms, eliminator, one attitude update per filter sample) through the kernels, checked
  bit for bit against the same chain through the public classes, per plant step of one axis.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from sins_sim.benchmarking import (ApiChain, FusedChain, check_fused_chain, filter_input, median_ratio, median_time,
                                   plant_input, plant_rk4_reference)
from sins_sim.filters.eliminator import EliminatorDesign
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.units import ARCMIN, ARCSEC

H = 1.0 / 72000.0
RATE0 = ARCMIN * 2.0 * math.pi * 100.0  # the 100 Hz vibration's rate at t = 0


@pytest.fixture(scope="module")
def sosfilt(sizes):
    """``scipy.signal.sosfilt`` on the eliminator's input (the machine's yardstick) and its length."""
    x, _ = filter_input(sizes["n_filter"])
    sos = np.array(EliminatorDesign.paper().sos)
    return (lambda: signal.sosfilt(sos, x)), x.size


def _plant_runner(integrator, ang, rate, volts):
    plant = Plant(PAPER_SUSPENSION, PlantSettings(integrator=integrator))

    def run():
        plant.reset(0.0, RATE0)
        return plant.step(ang, rate, volts)

    return run


def test_plant_step_one_axis(benchmark, check_ratio, record, sizes, sosfilt):
    ang, rate, volts = plant_input(sizes["n_plant"])
    n = ang.size
    run = _plant_runner("exact", ang, rate, volts)
    delta = record(run)
    # result: RK4 in plain Python (turning points located inside the step, as the kernels do) on
    # the first steps: measured 1e-6 arcsec after 400 steps, 1.3e-4 after 3000; bound 0.01 arcsec
    n_ref = sizes["n_ref_plant"]
    ref = plant_rk4_reference(ang[:n_ref], rate[:n_ref], volts[:n_ref], H, PAPER_SUSPENSION, 0.0, RATE0)
    assert np.max(np.abs(delta[:n_ref] - ref)) / ARCSEC < 0.01
    reps = sizes["repeats"]
    ratio_rk4, ns, rk4_ns = median_ratio(run, n, _plant_runner("rk4", ang, rate, volts), n, reps)
    ratio_sos, _, sosfilt_ns = median_ratio(run, n, sosfilt[0], sosfilt[1], reps)
    python_ns = median_time(lambda: plant_rk4_reference(ang[:n_ref], rate[:n_ref], volts[:n_ref], H,
                                                        PAPER_SUSPENSION, 0.0, RATE0), 1) / n_ref * 1e9
    benchmark.extra_info.update(ns_per_step=ns, rk4_ns_per_step=rk4_ns, python_rk4_ns_per_step=python_ns,
                                scipy_sosfilt_ns_per_sample=sosfilt_ns)
    check_ratio("plant_step_1axis/plant_step_1axis_rk4", ratio_rk4)
    check_ratio("plant_step_1axis/scipy_sosfilt", ratio_sos)
    check_ratio("plant_rk4_python/plant_step_1axis", python_ns / ns)


def test_three_axis_chain(benchmark, check_ratio, record, sizes, sosfilt):
    # result: the fused chain gives the public classes' bits (plant, readout, decimated drive,
    # both eq. 5 forms, eliminator, attitude), over two chunks
    check_fused_chain()
    n_chunks = sizes["chain_chunks"]
    fused, api = FusedChain(), ApiChain()

    def run():
        fused.reset()
        fused.run(n_chunks)

    def run_api():
        api.reset()
        api.run(n_chunks)

    record(run)
    assert np.all(np.isfinite(fused.qout))
    steps = 3 * n_chunks * fused.n  # plant steps of one axis, times three axes
    reps = sizes["repeats"]
    ratio_api, ns, api_ns = median_ratio(run, steps, run_api, steps, max(3, reps // 2))
    ratio_sos, _, sosfilt_ns = median_ratio(run, steps, sosfilt[0], sosfilt[1], reps)
    benchmark.extra_info.update(ns_per_plant_step=ns, api_ns_per_plant_step=api_ns,
                                realtime_factor_3axis=1e9 / (3.0 * ns * fused.n / (fused.n * fused.h)),
                                scipy_sosfilt_ns_per_sample=sosfilt_ns)
    check_ratio("sins_chain_per_plant_step/scipy_sosfilt", ratio_sos)
    check_ratio("sins_chain_per_plant_step/sins_chain_api", ratio_api)
