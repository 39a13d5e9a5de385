"""
Trajectory and horizontal error track
=====================================

The true path, and each filter's horizontal error track in its own panel at equal scales
(``trajectory.png``).
"""

import tempfile
from pathlib import Path

import sins_sim
from sins_sim.plots import navigation

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
scenario = sins_sim.load_scenario(ROOT / "scenarios" / "nav-trajectory-file.yaml", {"duration_s": 60.0})
res = sins_sim.simulate_sins(scenario.imu, scenario.motion, scenario.duration_s, seed=scenario.seed,
                             nav=scenario.nav, filters=scenario.filters, vehicle=scenario.vehicle,
                             translation=scenario.translation)
out = Path(tempfile.mkdtemp())
navigation.plot_trajectory(res, out / "trajectory.png", "nav-trajectory-file, first 60.0 s")
