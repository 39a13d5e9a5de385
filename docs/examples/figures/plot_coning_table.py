"""
Coning: what each filter keeps
==============================

The three coning scenarios (``scenarios/coning-*.yaml``) put the block through classic coning, 1 arcmin
on x and y with a 90 degree phase, at 100, 600 and 1500 Hz, at rest at 45 deg N. The true attitude
turns about z at the closed-form coning rate ``(1/2) a_x a_y omega sin(phase)``
(:doc:`/theory/navigation`). Each entry below is the effective heading drift ``attitude_drift_deg_h.down`` of a
filter's integrated solution (deg/h): the part of the coning rate that the filter's output loses.
``raw`` is the readout with the dither in it; "none found" means no ramp explains the data (its 95 % bound is in
``metrics.json``). The table is computed here, at every documentation build.
"""

import math
import tempfile
from pathlib import Path

import pandas as pd
import yaml

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
rows = {}
for hz in (100, 600, 1500):
    path = ROOT / "scenarios" / f"coning-{hz}hz.yaml"
    cone = yaml.safe_load(path.read_text())["motion"][0]
    a = math.radians(cone["amplitude_arcmin"] / 60.0)
    true_rate = 0.5 * a * a * 2.0 * math.pi * cone["frequency_hz"] * math.sin(math.radians(cone["phase_deg"]))
    metrics = sins_sim.run_scenario(path, Path(tempfile.mkdtemp()) / path.stem)
    row = {"true coning rate": math.degrees(true_rate) * 3600.0}
    for name, m in metrics["filters"].items():
        drift = m["attitude_drift_deg_h"]["down"]
        row[name] = drift["value"] if drift["value"] is not None else math.nan
    rows[f"{hz} Hz"] = row
table = pd.DataFrame(rows).T
table.style.format("{:.3g}", na_rep="none found")
