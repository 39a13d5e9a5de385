"""
Trajectory and horizontal error track
=====================================

The true path, and each filter's horizontal error track in its own panel at equal scales
(``trajectory.png``).
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "nav-trajectory-file.yaml", duration_s=60.0)
fig = r.plot("trajectory")
