"""
The block's motion on its isolators
===================================

With a ``block:`` section in the IMU file the three dithered gyros hang on one sensor block on isolators
(:doc:`/user-guide/block`). Each gyro's dither reaction counter-rotates the block by about ``J_g / J_b`` of
its amplitude, at its own frequency: ``block_spectrum.png`` shows that rotation's spectral density about
each block axis, with the drive lines and the isolator modes marked. Here the bundled unit at rest
(``scenarios/isolated-block.yaml``, 3 s).
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "isolated-block.yaml")
fig = r.plot("block_spectrum")

# %%
# The line at each drive against the linear coupled model (``metrics.json``, ``block.dither_lines``):
import pandas as pd

lines = r.metrics["block"]["dither_lines"]
pd.DataFrame({f"about block {ax}": {f"{k}: simulated (arcsec)": v["simulated_arcsec"] for k, v in row.items()}
              | {f"{k}: linear model (arcsec)": v["linear_model_arcsec"] for k, v in row.items()}
              for ax, row in lines.items()}).round(4)
