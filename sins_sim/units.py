"""Physical constants and unit conversions.

Everything inside sins-sim is SI with angles in rad; arcsec, arcmin and deg
appear only at the edges (configuration, plots, reports). This module
imports nothing from the package.
"""

from __future__ import annotations

import math

ARCSEC = math.pi / 648000.0
"""One arcsecond in rad (docs/conventions.md, "Units")."""
ARCMIN = math.pi / 10800.0
"""One arcminute in rad."""
DEG = math.pi / 180.0
"""One degree in rad."""
HOUR = 3600.0
"""One hour in s."""
DEG_PER_H = DEG / HOUR
"""One deg/h in rad/s."""

#: Fringe quantum of a 28 cm triangular He-Ne cavity (docs/theory/suspension.md, "Readout").
FRINGE_RAD = 2.42 * ARCSEC
#: The paper's interpolating readout: comparator + 12-bit ADC, 1/16 fringe.
INTERPOLATED_QUANTUM_RAD = FRINGE_RAD / 16.0


def rad_to_arcsec(x):
    """Convert rad to arcsec (works on scalars and arrays)."""
    return x / ARCSEC


def arcsec_to_rad(x):
    """Convert arcsec to rad."""
    return x * ARCSEC


def rad_to_arcmin(x):
    """Convert rad to arcmin."""
    return x / ARCMIN


def arcmin_to_rad(x):
    """Convert arcmin to rad."""
    return x * ARCMIN


def hz_to_rad_s(f):
    """Convert a frequency in Hz to a circular frequency in rad/s."""
    return 2.0 * math.pi * f


STANDARD_GRAVITY = 9.80665
"""Standard acceleration of gravity g_n (m/s^2), exact by definition (3rd CGPM, 1901): the g of
accelerometer datasheets (ug, ug/g^2)."""
MICRO_G = STANDARD_GRAVITY * 1e-6
"""One micro-g (ug) in m/s^2."""

#: The largest drive voltage a piezo stack takes (V): the drive model's limit and the recording reader's
#: (a recorded ``drive_v`` beyond it is refused there). High-voltage stacks are rated to about 1000 V
#: (e.g. PI's PICMA/PIC stacks); typical dither drives are well below 100 V.
PIEZO_V_MAX = 1000.0
