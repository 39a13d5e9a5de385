"""
Gyro error spectrum
===================

Each filter's gyro-angle error (output minus truth) as an amplitude spectral density
(``gyro_error_spectrum.png``); the Welch window, its length and overlap and the span analysed are
in the title. The eliminator passes block motion with the suspension's gain, eq. 5 amplifies the
readout quantum near Nyquist.
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "nav-trajectory-file.yaml", duration_s=20.0)
fig = r.plot("gyro_error_spectrum")
