"""The two dither-removal filters at 7.2 kHz against same-run baselines.

- eq. 5 (both forms) against eq. 5 in plain Python (result check, speed-up) and against
  ``scipy.signal.sosfilt`` on the eliminator (the C-speed yardstick of the thresholds);
- the eliminator against ``scipy.signal.sosfilt`` (same recursion: equal bits).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from sins_sim.bench import correcting_reference, filter_input, median_ratio, median_time
from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign


@pytest.fixture(scope="module")
def readout(sizes):
    """A dithered, quantised 7.2 kHz readout record, the drive, and sosfilt on it."""
    x, volts = filter_input(sizes["n_filter"])
    sos = np.array(EliminatorDesign.paper().sos)
    return x, volts, sos, lambda: signal.sosfilt(sos, x)


@pytest.mark.parametrize("form", ["unity", "paper"])
def test_correcting_filter(benchmark, check_ratio, record, readout, sizes, form):
    x, volts, _, sosfilt = readout
    design = CorrectingFilterDesign(form=form)
    filt = CorrectingFilter(design)

    def run():
        filt.reset()
        return filt.process(x, volts)

    y = record(run)
    # result: eq. 5 as printed, in plain Python, on the first samples (the kernel works on
    # increments; the two agree to rounding, ~1e-18 rad here; 1e-12 rad is far below anything)
    n_ref = sizes["n_ref_filter"]
    ref = correcting_reference(x[:n_ref], volts[:n_ref], design)
    assert np.max(np.abs(y[:n_ref] - ref)) <= 1e-12
    ratio, ns, sosfilt_ns = median_ratio(run, x.size, sosfilt, x.size, sizes["repeats"])
    benchmark.extra_info.update(ns_per_sample=ns, scipy_sosfilt_ns_per_sample=sosfilt_ns)
    key = "correcting" if form == "unity" else "correcting_paper"
    check_ratio(f"{key}/scipy_sosfilt", ratio)
    if form == "unity":
        python_ns = median_time(lambda: correcting_reference(x[:n_ref], volts[:n_ref], design), 1) / n_ref * 1e9
        benchmark.extra_info["python_ns_per_sample"] = python_ns
        check_ratio("correcting_python/correcting", python_ns / ns)


def test_eliminator(benchmark, check_ratio, record, readout, sizes):
    x, _, sos, sosfilt = readout
    elim = Eliminator(EliminatorDesign.paper())

    def run():
        elim.reset()
        return elim.process(x)

    y = record(run)
    # result: the same transposed-direct-form-II recursion as scipy's, bit for bit
    np.testing.assert_array_equal(y, sosfilt())
    ratio, ns, sosfilt_ns = median_ratio(run, x.size, sosfilt, x.size, sizes["repeats"])
    benchmark.extra_info.update(ns_per_sample=ns, scipy_sosfilt_ns_per_sample=sosfilt_ns)
    check_ratio("eliminator/scipy_sosfilt", ratio)
