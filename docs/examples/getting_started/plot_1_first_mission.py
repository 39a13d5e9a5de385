"""
First mission
=============

The quick start runs the bundled five-minute flight from the command line::

    sins-sim run scenarios/nav-trajectory-file.yaml --out out/nav-trajectory-file

The same job from Python is :func:`sins_sim.run`: it takes a scenario file, a dict or a scenario
object and returns a :class:`sins_sim.MissionResult` with tables, figures and ``save``. Here the
mission is cut to 30 s (``duration_s`` replaces the scenario's, like ``--duration``) so that the
page builds quickly; everything else is the bundled scenario: the default unit (three dithered
gyros at 386, 352 and 421 Hz), a 10 Hz flight log, a light sine vibration of the block, and four
filters navigated against the truth.
"""

# %%
# Run the scenario. The result's text gives each filter's headline errors.
from pathlib import Path

import sins_sim

# the checkout that holds scenarios/ (this folder or one above it)
ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "nav-trajectory-file.yaml", duration_s=30.0)
print(r)

# %%
# One row per filter (``metrics.json`` as a table). ``ideal`` navigates the true increments: the
# floor of the algorithm; every other filter's excess over it is that filter's cost.
frames = r.to_pandas()
frames["summary"]

# %%
# The same figure ``sins-sim run`` writes as ``navigation_error.png``.
fig = r.plot("navigation_error")

# %%
# ``save`` writes exactly what the command line writes: ``metrics.json``, ``timeseries.npz``, the
# figures that have data, ``report.md`` and ``manifest.json`` with ``inputs/``.
import tempfile

folder = r.save(Path(tempfile.mkdtemp()) / "first-mission")
print(sorted(p.name for p in Path(folder).iterdir()))
