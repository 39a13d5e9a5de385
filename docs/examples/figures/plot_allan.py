"""
Allan deviation of every filter
===============================

The Allan deviation of each filter's gyro-angle error (``allan.png``): overlapping ADEV by
allantools, the terms read by a weighted power-law fit (IEEE Std 952-1997, Annex C). Here the
navigation-grade unit (``configs/nav-grade-rlg.yaml``, ARW 0.002 deg/sqrt(h)) at rest with the
vibration of ``scenarios/nav-stationary-1h.yaml`` for 30 s instead of the hour: the short record
shows the white-angle-noise slope of eq. 5 and the sensor's ARW line.
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "nav-stationary-1h.yaml", duration_s=30.0,
                 imu=ROOT / "configs" / "nav-grade-rlg.yaml")
fig = r.plot("allan")
