"""Monte Carlo over unit populations on dask.distributed (``sins-sim sweep``).

The sweep file (scenarios, population, units, seed) is configuration: :mod:`sins_sim.config.sweep`.

.. autosummary::

   population  seeded draws of each unit around the IMU file, applied to an IMU mapping
   tasks       one task per (unit, scenario), its key, and the worker's run (flat metrics)
   store       the sweep folder: Parquet parts written as runs finish, failures, resume
   summary     summary.json: percentiles with intervals where n supports them, drivers that pass a family-wise test
   job         run_sweep: validate, resume, submit, collect, summarise, plot
"""

from sins_sim.jobs.sweep.job import run_sweep
from sins_sim.config.sweep import SWEEP_SCHEMA, load_sweep

__all__ = ["run_sweep", "load_sweep", "SWEEP_SCHEMA"]
