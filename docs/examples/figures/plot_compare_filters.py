"""
Eq. 5 against the wideband designs
==================================

``sins-sim compare-filters`` measures every correcting filter on the default unit: the end-to-end gain
on the nonlinear plant with the dither running (``gain.png``; +-2 % around each dither frequency
excluded) and the quantisation-noise trade-off against the bound of exact inversion
(``noise_tradeoff.png``). Here the quick settings (``--quick``); the designs are derived in
:doc:`/wideband-filters`.
"""

import tempfile
from pathlib import Path

from sins_sim.jobs.compare_filters import run_compare_filters

out = Path(tempfile.mkdtemp()) / "filters"
result = run_compare_filters(out, out.parent / "filters.json", quick=True)
print(sorted(result))
