"""
Attitude error
==============

The attitude error phi about north, east and down (``attitude_error.png``): the rotation
vector of q_est x q_true*, on a symmetric-log axis whose linear half-width is taken from the data
and stated on it (conventions: :doc:`/conventions`).
"""

import tempfile
from pathlib import Path

import sins_sim
from sins_sim.plots import navigation

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
scenario = sins_sim.load_scenario(ROOT / "scenarios" / "nav-trajectory-file.yaml", {"duration_s": 40.0})
res = sins_sim.simulate_sins(scenario.imu, scenario.motion, scenario.duration_s, seed=scenario.seed,
                             nav=scenario.nav, filters=scenario.filters, vehicle=scenario.vehicle,
                             translation=scenario.translation)
out = Path(tempfile.mkdtemp())
navigation.plot_attitude_error(res, out / "attitude_error.png", "nav-trajectory-file, first 40.0 s")
