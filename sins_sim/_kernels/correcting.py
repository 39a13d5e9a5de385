"""The correcting digital filter, eq. 5 (docs/theory/suspension.md, "The correcting filter (eq. 5)").

With ``X_n`` the RLG angle, ``D = X_{n-1} - Y_{n-1}``::

    Y_n = a2 (X_n - 2 X_{n-1} + X_{n-2}) + g (X_{n-1} + Nonl(D) + Diss(D) + k5 V_{n-1})

paper form: ``a2 = 1/w^2``, ``g = B = 2 (1 - cos w)/w^2``; unity-DC form:
``a2 = 1/(2 (1 - cos w))``, ``g = 1`` (``w = omega0 dT``).

Precision over long runs: the kernel works on increments. With
``small_n = a2 (dX_n - dX_{n-1}) + g (Nonl + Diss + k5 V)`` it forms
``Y_n = g X_{n-1} + small_n`` and ``D_n = dX_n - small_n + (1 - g) X_{n-1}``,
so the deflection estimate never comes from the difference of two large
accumulated angles (for the unity form ``(1 - g) = 0`` exactly).

Eq. 10 inside the filter tracks turning points of its own ``D`` sequence: an
extremum at ``D_{n-2}`` is recognised when the sign of ``D_{n-1} - D_{n-2}``
differs from that of ``D_{n-2} - D_{n-3}``; its value is refined by the
parabola through the three samples (at 7.2 kHz a 384 Hz dither has 18.75
samples per cycle, so the raw sample would understate the amplitude by up to
1.4 %). ``sgn(dD/dt)`` at ``t_{n-1}`` is the sign of ``D_{n-1} - D_{n-2}``.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels._config import jit
from sins_sim._kernels.physics import RULE_MASING, hyst_turn, masing_close, masing_target

# filter state layout
F_X1 = 0  # X_{n-1}
F_DX1 = 1  # X_{n-1} - X_{n-2}
F_D1 = 2  # D_{n-1}
F_D2 = 3  # D_{n-2}
F_D3 = 4  # D_{n-3}
F_V1 = 5  # V_{n-1}
F_N = 6  # samples processed
STATE_SIZE = 7


@jit
def correcting_run(x, volts, a2, g, k1, k2, k3, k4, k5, dt, rule, fast_dt, state, hyst, stack, out):
    """Run eq. 5 over a chunk.

    Parameters
    ----------
    x : float64[N]
        RLG angle X_n (rad).
    volts : float64[N]
        Drive voltage V_n aligned with X_n (V).
    a2, g : float
        Coefficients of the chosen form (see module docstring).
    k1 .. k5 : float
        Eq. 9, 10, 14 parameters.
    dt : float
        Sampling period (s), for the regime counter's clock.
    rule : int
        Hysteresis rule.
    fast_dt : float
        Half-cycles of D shorter than this are counted (regime warning).
    state, hyst, stack : float64 arrays
        Filter state (layout above), hysteresis branch and reversal stack; updated in place.
    out : float64[N]
        Y_n, the SINS angle estimate; it describes the block at t_{n-1}.
    """
    x1 = state[F_X1]
    dx1 = state[F_DX1]
    d1 = state[F_D1]
    d2 = state[F_D2]
    d3 = state[F_D3]
    v1 = state[F_V1]
    nn = state[F_N]
    k2inv = 1.0 / k2
    kl = k1 / (2.0 * k2)
    a_cached = -1.0
    ainv = 0.0
    for n in range(x.shape[0]):
        # turning point of D at n-2, seen from the sign change of its increments. The same bookkeeping is
        # written out in _kernels/wideband.py: as a shared jit function it cost 3 ns of eq. 5's 18.5 ns per
        # sample (measured, also with inline="always"), so it stays inline in both sample loops.
        inc1 = d1 - d2
        inc0 = d2 - d3
        if nn >= 3.0 and inc1 * inc0 < 0.0:
            curv = d1 - 2.0 * d2 + d3
            ext = d2
            if curv != 0.0:
                ext = d2 - (d1 - d3) * (d1 - d3) / (8.0 * curv)
            hyst_turn(hyst, stack, rule, ext, (nn - 2.0) * dt, fast_dt)
            hyst[0] = 1.0 if inc1 > 0.0 else -1.0
        elif hyst[0] == 0.0 and inc1 != 0.0:
            hyst[0] = 1.0 if inc1 > 0.0 else -1.0
        if rule == RULE_MASING:
            tgt = masing_target(hyst, stack)
            if not math.isnan(tgt) and (d1 - tgt) * hyst[0] > 0.0:
                masing_close(hyst, stack)
        # eq. 9 as printed, without divisions: k1 (sgn(d) (sqrt(1 + |d|/k2) - 1) - d/(2 k2)). Unlike
        # physics.nonl this form cancels for tiny |d|, but only at the level eps k1 |d| / k2 ~ 2e-17 |d|,
        # far below any signal; it saves the divisions of the dependency chain. Eq. 10 with a cached 1/a.
        sq = math.sqrt(1.0 + abs(d1) * k2inv) - 1.0
        nl = (k1 * sq if d1 >= 0.0 else -k1 * sq) - kl * d1
        a = hyst[1]
        if a > 0.0:
            if a != a_cached:
                a_cached = a
                ainv = 1.0 / a
            u = (d1 - hyst[2]) * ainv
            r = 1.0 - u * u
            if r > 0.0:
                nl += hyst[0] * k3 * a * (1.0 + k4 * a) * math.sqrt(r)
        nl += k5 * v1
        xn = x[n]
        dx = xn - x1
        small = a2 * (dx - dx1) + g * nl
        y = g * x1 + small
        dn = dx - small + (1.0 - g) * x1
        out[n] = y
        d3 = d2
        d2 = d1
        d1 = dn
        dx1 = dx
        x1 = xn
        v1 = volts[n]
        nn += 1.0
    state[F_X1] = x1
    state[F_DX1] = dx1
    state[F_D1] = d1
    state[F_D2] = d2
    state[F_D3] = d3
    state[F_V1] = v1
    state[F_N] = nn


@jit
def correcting_lanes(x, volts, rows, par, rules, state, hyst, stack, out):
    """:func:`correcting_run` for several filters at once, stepped in turn sample by sample.

    Filter ``l`` reads row ``rows[l]`` of ``x`` and ``volts`` (float64[A, N]: several filters
    can share an input, as the two forms of one channel do) and writes ``out[l]``. ``par[l]``:
    ``a2, g, k1, k2, k3, k4, k5, dt, fast_dt``; ``rules[l]``: its hysteresis rule; ``state[l]``,
    ``hyst[l]``, ``stack[l]``: its state as in :func:`correcting_run`, updated in place.

    Every filter gets the arithmetic of :func:`correcting_run`, bit for bit (checked by
    ``tests/test_correcting.py``). Eq. 5 is a dependency chain (``D_n`` needs ``D_{n-1}``
    through a square root); stepping the six filters of a SINS (two forms per axis) in turn lets
    the processor overlap their chains: 0.44 against 0.78 ms per simulated second for the six
    (measured at 7.2 kHz). The sample's arithmetic is written out again here rather than shared
    with :func:`correcting_run` through a step function: that cost the single filter 75 %
    (its state left the registers), also with ``inline="always"``.
    """
    n_lanes = rows.shape[0]
    k2inv = np.empty(n_lanes)
    kl = np.empty(n_lanes)
    a_cached = np.full(n_lanes, -1.0)
    ainv = np.zeros(n_lanes)
    for l in range(n_lanes):
        k2inv[l] = 1.0 / par[l, 3]
        kl[l] = par[l, 2] / (2.0 * par[l, 3])
    for n in range(x.shape[1]):
        for l in range(n_lanes):
            d1 = state[l, F_D1]
            d2 = state[l, F_D2]
            d3 = state[l, F_D3]
            nn = state[l, F_N]
            # turning point of D at n-2 (as in correcting_run)
            inc1 = d1 - d2
            inc0 = d2 - d3
            if nn >= 3.0 and inc1 * inc0 < 0.0:
                curv = d1 - 2.0 * d2 + d3
                ext = d2
                if curv != 0.0:
                    ext = d2 - (d1 - d3) * (d1 - d3) / (8.0 * curv)
                hl = hyst[l]
                hyst_turn(hl, stack[l], rules[l], ext, (nn - 2.0) * par[l, 7], par[l, 8])
                hl[0] = 1.0 if inc1 > 0.0 else -1.0
            elif hyst[l, 0] == 0.0 and inc1 != 0.0:
                hyst[l, 0] = 1.0 if inc1 > 0.0 else -1.0
            if rules[l] == RULE_MASING:
                tgt = masing_target(hyst[l], stack[l])
                if not math.isnan(tgt) and (d1 - tgt) * hyst[l, 0] > 0.0:
                    masing_close(hyst[l], stack[l])
            # eq. 9 without divisions and eq. 10 with a cached 1/a (as in correcting_run)
            k1 = par[l, 2]
            sq = math.sqrt(1.0 + abs(d1) * k2inv[l]) - 1.0
            nl = (k1 * sq if d1 >= 0.0 else -k1 * sq) - kl[l] * d1
            a = hyst[l, 1]
            if a > 0.0:
                if a != a_cached[l]:
                    a_cached[l] = a
                    ainv[l] = 1.0 / a
                u = (d1 - hyst[l, 2]) * ainv[l]
                r = 1.0 - u * u
                if r > 0.0:
                    nl += hyst[l, 0] * par[l, 4] * a * (1.0 + par[l, 5] * a) * math.sqrt(r)
            nl += par[l, 6] * state[l, F_V1]
            row = rows[l]
            x1 = state[l, F_X1]
            xn = x[row, n]
            dx = xn - x1
            g = par[l, 1]
            small = par[l, 0] * (dx - state[l, F_DX1]) + g * nl
            out[l, n] = g * x1 + small
            state[l, F_D3] = d2
            state[l, F_D2] = d1
            state[l, F_D1] = dx - small + (1.0 - g) * x1
            state[l, F_DX1] = dx
            state[l, F_X1] = xn
            state[l, F_V1] = volts[row, n]
            state[l, F_N] = nn + 1.0
