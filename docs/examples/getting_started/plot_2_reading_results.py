"""
Reading the results
===================

A run folder holds everything needed to read, compare and repeat the run: ``metrics.json`` (the
numbers), ``timeseries.npz`` (block means with min/max envelopes), the figures, ``report.md`` and
``manifest.json`` with ``inputs/``. Column and key names: :doc:`/conventions`.
"""

# %%
# Run a short mission (20 s of the bundled flight) and open its files.
import json
import tempfile
from pathlib import Path

import numpy as np

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
out = Path(tempfile.mkdtemp()) / "run"
sins_sim.run_scenario(ROOT / "scenarios" / "nav-trajectory-file.yaml", out, overrides={"duration_s": 20.0})
metrics = json.loads((out / "metrics.json").read_text())
print(list(metrics))
print(json.dumps(metrics["definitions"], indent=1)[:1500])

# %%
# The time series: per filter ``NAME__KEY`` arrays, the truth as ``truth_KEY``.
series = np.load(out / "timeseries.npz")
print(sorted(k for k in series.files if k.startswith("correcting__")))
t = series["correcting__t_s"]
h = series["correcting__horizontal_m"]
print(f"correcting: {t.size} stored blocks from {t[0]:.2f} s to {t[-1]:.2f} s, "
      f"final horizontal error {h[-1]:.3g} m")

# %%
# What produced the result: versions, command, seed, input hashes, and the parameters each filter used.
manifest = json.loads((out / "manifest.json").read_text())
print({k: manifest[k] for k in list(manifest)[:4]})
