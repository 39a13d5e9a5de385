"""
Error budget
============

``sins-sim budget`` runs a scenario once with everything on, once with each error source switched off
in turn and once with every source off (``budget.png``): with the same seed the sources' random streams
are independent, so ``e(all on) - e(all on but S)`` is source S's contribution in this realisation. Here
the navigation-grade unit at rest (``scenarios/stationary.yaml`` with ``configs/nav-grade-rlg.yaml``) for
5 s instead of an hour, on two worker processes: the ranking of the sources, not their size after an hour.
"""

import tempfile
from pathlib import Path

from sins_sim.jobs.budget import run_budget

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
out = Path(tempfile.mkdtemp()) / "budget"
budget = run_budget(ROOT / "scenarios" / "stationary.yaml", out, workers=2,
                    overrides={"duration_s": 5.0, "imu": str(ROOT / "configs" / "nav-grade-rlg.yaml")})
print(sorted(budget))
