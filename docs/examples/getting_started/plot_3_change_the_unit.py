"""
Changing the unit
=================

The scenario names its unit (``imu:``); ``overrides`` (or ``--imu`` on the command line) swaps it.
Here the same 30 s of flight with the default unit and with the navigation-grade unit
(``configs/nav-grade-rlg.yaml``: HG9900-class sensor errors), the filters on the datasheet
parameters (``filter_parameters: nominal``, as ``--filter-parameters nominal``). The sensor errors
now set the position error; the filters' own cost is what each adds to ``ideal``.
"""

import tempfile
from pathlib import Path

import pandas as pd

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
scenario = ROOT / "scenarios" / "nav-trajectory-file.yaml"
rows = {}
for unit in ("default-imu", "nav-grade-rlg"):
    overrides = {"duration_s": 30.0, "imu": str(ROOT / "configs" / f"{unit}.yaml"), "filter_parameters": "nominal"}
    metrics = sins_sim.run_scenario(scenario, Path(tempfile.mkdtemp()) / unit, overrides=overrides)
    for name, m in metrics["filters"].items():
        rows[(unit, name)] = {"horizontal final (m)": m["horizontal_position_error_m"]["final"],
                              "velocity final (m/s)": m["velocity_error_m_s"]["final"]}
table = pd.DataFrame(rows).T
table.style.format("{:.3g}")
