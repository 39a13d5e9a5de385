"""
Navigation error
================

Horizontal position, height and velocity error of every filter against the truth
(``navigation_error.png`` of ``sins-sim run``): lines are means over each stored interval, the light
bands behind them the min/max within it, the ideal floor dashed black. Here the first 40 s of the
bundled flight ``scenarios/nav-trajectory-file.yaml``.
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
navigation.plot_navigation_error(res, out / "navigation_error.png", "nav-trajectory-file, first 40.0 s")
