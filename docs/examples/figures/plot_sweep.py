"""
Monte Carlo sweep on Dask
=========================

``sins-sim sweep`` draws a population of units around an IMU file and runs every unit through every
scenario of the sweep, each run a ``dask.distributed`` task; each finished run is written at once, so an
interrupted sweep resumes. The figures: the distribution of each headline metric per filter
(``distributions.png``) and, where a permutation test finds them, the drawn parameters that drive a
metric (``sensitivity_*.png``). Here ``scenarios/sweep-smoke.yaml`` (8 short runs) on two local workers.
"""

import tempfile
from pathlib import Path

from sins_sim.jobs.sweep import run_sweep

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
out = Path(tempfile.mkdtemp()) / "smoke"
summary = run_sweep(ROOT / "scenarios" / "sweep-smoke.yaml", out, workers=2)
print({k: summary[k] for k in ("runs", "failed") if k in summary})
