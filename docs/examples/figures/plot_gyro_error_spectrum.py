"""
Gyro error spectrum
===================

Each filter's gyro-angle error (output minus truth) as an amplitude spectral density
(``gyro_error_spectrum.png``); the Welch window, its length and overlap and the span analysed are
in the title. The eliminator passes block motion with the suspension's gain, eq. 5 amplifies the
readout quantum near Nyquist.
"""

import tempfile
from pathlib import Path

import sins_sim
from sins_sim.plots import navigation

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
scenario = sins_sim.load_scenario(ROOT / "scenarios" / "nav-trajectory-file.yaml", {"duration_s": 20.0})
res = sins_sim.simulate_sins(scenario.imu, scenario.motion, scenario.duration_s, seed=scenario.seed,
                             nav=scenario.nav, filters=scenario.filters, vehicle=scenario.vehicle,
                             translation=scenario.translation)
out = Path(tempfile.mkdtemp())
navigation.plot_gyro_error_spectrum(res, out / "gyro_error_spectrum.png", "nav-trajectory-file, first 20.0 s")
