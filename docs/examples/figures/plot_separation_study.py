"""
How far apart must the resonances be?
=====================================

``sins-sim separation-study IMU.yaml`` brings one axis's dither towards another's on the block and
measures, at each separation, the dither coning in each filter's heading error, the line each gyro
sees at the other's drive, and the drives on live PLLs: their pull and their modulation at the beat
(:doc:`/user-guide/block`). Here three separations and 12 s missions (the
command's default: nine separations from 40 Hz to 0.1 Hz, 30 s each).
"""

import tempfile
from pathlib import Path

from sins_sim.config.imu import load_imu
from sins_sim.jobs.separation_study import separation_study
from sins_sim.plots.block import plot_separation_study

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "configs").is_dir())
res = separation_study(load_imu(ROOT / "configs" / "isolated-block.yaml"), Path(tempfile.mkdtemp()) / "sep",
                       separations_hz=(10.0, 1.0, 0.2), duration_s=12.0)
fig = plot_separation_study(res)
