"""
Attitude error
==============

The attitude error phi about north, east and down (``attitude_error.png``): the rotation
vector of q_est x q_true*, on a symmetric-log axis whose linear half-width is taken from the data
and stated on it (conventions: :doc:`/conventions`).
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "nav-trajectory-file.yaml", duration_s=40.0)
fig = r.plot("attitude_error")
