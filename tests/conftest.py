"""Settings for the whole test session.

The progress display calibrates its estimates on the machine that runs (``sins_sim.jobs.estimate``:
``calibration.json`` under ``$XDG_CACHE_HOME/sins-sim``). Test runs are short and share a loaded machine:
their timings go to a temporary folder, never into the user's cache.
"""

import os
import tempfile

os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="sins-sim-test-cache-")
