"""
Navigation error
================

Horizontal position, height and velocity error of every filter against the truth
(``navigation_error.png`` of ``sins-sim run``): lines are means over each stored interval, the light
bands behind them the min/max within it, the ideal floor dashed black. Here the first 40 s of the
bundled flight ``scenarios/nav-trajectory-file.yaml``.
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "nav-trajectory-file.yaml", duration_s=40.0)
fig = r.plot("navigation_error")
