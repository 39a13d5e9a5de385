"""
Eq. 5 against the wideband designs
==================================

``sins-sim compare-filters`` measures every correcting filter on the default unit: the end-to-end gain
on the nonlinear plant with the dither running (``gain.png``; +-2 % around each dither frequency
excluded) and the quantisation-noise trade-off against the bound of exact inversion
(``noise_tradeoff.png``). Here the quick settings (``--quick``); the designs are derived in
:doc:`/wideband-filters`.
"""

import tempfile
from pathlib import Path

from sins_sim.jobs.compare_filters import run_compare_filters

out = Path(tempfile.mkdtemp()) / "filters"
run_compare_filters(out, out.parent / "filters.json", quick=True)

# %%
# The numbers behind the figures (``filters.json``), at the quick settings' resolution: the worst gain
# deviation from 80 Hz up to each band edge, the coning drift error against the true coning rate,
# the residual of a stationary unit, the quantisation noise and the group delay.
import json

import pandas as pd

doc = json.loads((out.parent / "filters.json").read_text())
table = pd.DataFrame({
    name: {"max deviation 80-1000 Hz (%)": f["max_dev_pct"]["80-1000"],
           "max deviation 80-2500 Hz (%)": f["max_dev_pct"]["80-2500"],
           "coning drift error 600 Hz (deg/h)": f["coning_drift_error_deg_per_h"]["600"],
           "coning drift error 1000 Hz (deg/h)": f["coning_drift_error_deg_per_h"]["1000"],
           "stationary residual (arcsec)": f["stationary_residual_arcsec"],
           "quantisation noise (arcsec)": f["quantization_noise_arcsec"],
           "delay (ms)": 1e3 * f["group_delay_s"]}
    for name, f in doc["filters"].items()}).T
table.style.format("{:.3g}")
