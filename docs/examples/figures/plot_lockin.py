"""
Dithered lock-in
================

``sins-sim lockin-study`` measures the angle random walk that dithered lock-in leaves with a randomly
modulated drive, against the stationary-phase result ``N = Omega_L / sqrt(K a w_D)``
(``arw_vs_lockin.png``), and the dynamic lock-in zones with a constant amplitude
(``dynamic_lockin.png``). Here the quick settings (``--quick``: shorter runs, fewer points).
"""

import tempfile
from pathlib import Path

from sins_sim.jobs.lockin_study import lockin_study

out = Path(tempfile.mkdtemp()) / "lockin"
study = lockin_study(out, quick=True, progress=None)
print(sorted(study))
