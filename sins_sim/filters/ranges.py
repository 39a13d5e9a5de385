"""The limits the eliminator's design declares, in a module that imports nothing heavy.

:mod:`sins_sim.config.imu` checks an IMU file against them before scipy and numba are imported, so a wrong
file fails in a fraction of a second; :mod:`sins_sim.filters.eliminator` re-exports them.
"""

from __future__ import annotations

__all__ = ["MAX_RP_DB", "MAX_RS_DB"]

#: Pass-band ripple (dB): a band-stop that ripples more than 6 dB (a factor 2) in its pass band is no
#: dither eliminator. Stop-band attenuation (dB): 200 dB is 1e-10, below float64 rounding of the angles.
MAX_RP_DB = 6.0
MAX_RS_DB = 200.0
