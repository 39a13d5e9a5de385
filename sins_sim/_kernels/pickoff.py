"""Dither stripping from a pickoff signal (the industry baseline), the per-sample loop.

See :mod:`sins_sim.filters.pickoff` for the method and its sources.
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit

# state layout
_U = 0  # integrator
_G = 1  # gain
_P = 2  # running power of BP(u)
_E1, _E2 = 3, 4  # band-pass state on x
_R1, _R2 = 5, 6  # band-pass state on u
_N = 7  # samples processed
STATE_SIZE = 8
G_INDEX = _G  # the adapted gain, read by the wrapper


@jit
def strip_run(x, volts, h, lam, b0, b1, b2, a1, a2, mu, kappa, hold, adapt, state, out, gains):
    """Pickoff stripping over a chunk (see module docstring); ``state`` updated in place."""
    u = state[_U]
    g = state[_G]
    p = state[_P]
    e1 = state[_E1]
    e2 = state[_E2]
    r1 = state[_R1]
    r2 = state[_R2]
    k = state[_N]
    for n in range(x.shape[0]):
        u = lam * u + h * volts[n]
        y = x[n] - g * u
        out[n] = y
        gains[n] = g
        # band-pass (transposed direct form II) of x and u; the band-passed output with the
        # current gain is BP(x) - g BP(u): no filter delay inside the adaptation loop
        xb = b0 * x[n] + e1
        e1 = b1 * x[n] - a1 * xb + e2
        e2 = b2 * x[n] - a2 * xb
        r = b0 * u + r1
        r1 = b1 * u - a1 * r + r2
        r2 = b2 * u - a2 * r
        p = (1.0 - kappa) * p + kappa * r * r
        k += 1.0
        if adapt and k > hold and p > 0.0:
            g += mu * (xb - g * r) * r / p
    state[_U] = u
    state[_G] = g
    state[_P] = p
    state[_E1] = e1
    state[_E2] = e2
    state[_R1] = r1
    state[_R2] = r2
    state[_N] = k
