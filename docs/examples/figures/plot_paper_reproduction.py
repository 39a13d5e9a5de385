"""
The paper's figures
===================

``sins-sim reproduce`` remakes Figs. 1 and 3 to 7 of the paper, the Abel inversion and the
sensitivity table, and writes ``numbers.json`` and ``report.md``, which sets the paper's numbers
beside sins-sim's. Here the quick settings (``--quick``); the full run takes about 30 s.
"""

import json
import tempfile
from pathlib import Path

from sins_sim.jobs.reproduce.job import run_reproduce

out = Path(tempfile.mkdtemp()) / "paper"
numbers = run_reproduce(out, quick=True)
print(sorted(p.name for p in out.glob("*.png")))

# %%
# A few of the numbers the report compares with the paper (``numbers.json``):
doc = json.loads((out / "numbers.json").read_text())
print(json.dumps({k: doc[k] for k in list(doc)[:6]}, indent=1, default=str)[:2000])
