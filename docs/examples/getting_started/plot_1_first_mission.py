"""
First mission
=============

The quick start runs the bundled five-minute flight from the command line::

    sins-sim run scenarios/nav-trajectory-file.yaml --out out/nav-trajectory-file

The same job from Python is :func:`sins_sim.run_scenario`. Here the mission is cut to 30 s
(``overrides`` replaces top-level keys, like ``--duration`` on the command line) so that the
page builds quickly; everything else is the bundled scenario: the default unit (three dithered
gyros at 386, 352 and 421 Hz), a 10 Hz flight log, a light sine vibration of the block, and four
filters navigated against the truth.
"""

# %%
# Run the scenario into a fresh folder. It writes ``metrics.json``, ``timeseries.npz``, the
# figures that have data, ``report.md`` and ``manifest.json`` with ``inputs/``.
import tempfile
from pathlib import Path

import sins_sim

# the checkout that holds scenarios/ (this folder or one above it)
ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
out = Path(tempfile.mkdtemp()) / "first-mission"
metrics = sins_sim.run_scenario(ROOT / "scenarios" / "nav-trajectory-file.yaml", out,
                                overrides={"duration_s": 30.0})
print(sorted(p.name for p in out.iterdir()))

# %%
# Each filter's final position, velocity and attitude error against the truth (``metrics.json``,
# per filter under ``filters``). ``ideal`` navigates the true increments: the floor of the
# algorithm; every other filter's excess over it is that filter's cost.
import pandas as pd

rows = {}
for name, m in metrics["filters"].items():
    rows[name] = {
        "horizontal final (m)": m["horizontal_position_error_m"]["final"],
        "velocity final (m/s)": m["velocity_error_m_s"]["final"],
        **{f"attitude RMS {ax} (arcsec)": m["attitude_error_arcsec"]["rms"][ax] for ax in ("north", "east", "down")},
    }
table = pd.DataFrame(rows).T
table.style.format("{:.3g}")
