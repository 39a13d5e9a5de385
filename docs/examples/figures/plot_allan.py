"""
Allan deviation of every filter
===============================

The Allan deviation of each filter's gyro-angle error (``allan.png``): overlapping ADEV by
allantools, the terms read by a weighted power-law fit (IEEE Std 952-1997, Annex C). Here the
navigation-grade unit (``configs/nav-grade-rlg.yaml``, ARW 0.002 deg/sqrt(h)) at rest with the
vibration of ``scenarios/nav-stationary-1h.yaml`` for 30 s instead of the hour: the short record
shows the white-angle-noise slope of eq. 5 and the sensor's ARW line.
"""

import tempfile
from pathlib import Path

import sins_sim
from sins_sim.plots.allan import plot_allan_filters

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
scenario = sins_sim.load_scenario(ROOT / "scenarios" / "nav-stationary-1h.yaml",
                                  {"duration_s": 30.0, "imu": str(ROOT / "configs" / "nav-grade-rlg.yaml")})
res = sins_sim.simulate_sins(scenario.imu, scenario.motion, scenario.duration_s, seed=scenario.seed,
                             nav=scenario.nav, filters=scenario.filters, vehicle=scenario.vehicle,
                             translation=scenario.translation)
out = Path(tempfile.mkdtemp())
gyro = {name: a for name, a in res.allan.items() if name in res.filters}
plot_allan_filters(gyro, out / "allan.png",
                   f"Allan deviation of each filter's gyro error ({res.allan['record_s']:.4g} s record)")
