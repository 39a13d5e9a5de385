"""Sensor output kernels: pulse quantisation of integrating sensors."""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit


@jit
def pulse_quantise(x, frac, out):
    """Pulses per sample of an integrating sensor, sample by sample.

    ``x[n, i]``: the true increment of axis ``i`` over sample ``n`` in units of the quantum;
    ``frac[i]``: the part of a pulse accumulated and not yet emitted (in [0, 1)), updated in
    place; ``out[n, i]``: whole pulses emitted in sample ``n``. ``u = frac + x``,
    ``out = floor(u)``, ``frac = u - out`` (exact), so chunked and whole-array runs agree bit
    for bit and the emitted total never differs from the true integral by a pulse or more.
    """
    for n in range(x.shape[0]):
        for i in range(x.shape[1]):
            u = frac[i] + x[n, i]
            c = math.floor(u)
            frac[i] = u - c
            out[n, i] = c
