"""Wideband correcting filters (docs/wideband-filters.md): an equalised second difference and eq. 2
inverted on the current sample.

With ``X`` the RLG angle at the filter rate, ``d2_n = X_n - 2 X_{n-1} + X_{n-2}`` (the second
difference of eq. 5), ``e`` a symmetric FIR of odd length ``2K - 1`` (the equaliser; ``e = [1]``,
``K = 1`` is eq. 5's own second difference) and ``c`` its scale, the block angle at ``t_{n-K}`` is
(eq. 2 solved for ``phi_sins``, as eq. 5 does, docs/theory/suspension.md)::

    A_n = c * sum_j e_j d2_{n-j}                       (~ X''(t_{n-K}) / omega0^2)
    D   solves  D + Nonl(D) + Diss(D) = -A_n - k5 V_{n-K}     (eq. 2, 9, 10, 14 at t_{n-K})
    Y_n = X_{n-K} - D                                  (the estimate of phi_sins(t_{n-K}))

Unlike eq. 5, whose ``Nonl`` and ``Diss`` read the deflection of the previous sample
(``D = X_{n-1} - Y_{n-1}``, one block increment late), the deflection here belongs to the same
instant as the output: the implicit equation is solved by fixed-point iteration from the predictor
``P = -A_n - k5 V_{n-K} - F_{n-1}`` (``F`` = Nonl + Diss of the previous sample). The map
``D -> -Nonl(D) - Diss(D)`` is a contraction with factor ``max |Nonl'| + |Diss'|`` ~ 0.03 at the
paper's k1, k2, k3 (away from the turning points, where eq. 10's square root has an infinite slope
but a value that goes to 0, so the iteration still converges, as ``|dD|^(1/2)``).

Eq. 10's half-cycle amplitude is tracked from the filter's own ``D`` as in
:mod:`sins_sim._kernels.correcting` (the same ``hyst_turn``, ``masing_*`` of
:mod:`sins_sim._kernels.physics`), one sample earlier: a turning point at ``n-1`` is seen from the
sign change between ``D_{n-1} - D_{n-2}`` and ``P - D_{n-1}`` and refined by the parabola through
``D_{n-2}, D_{n-1}, P``.

The FIR part (:func:`equalised_second_difference`) folds the symmetric taps and runs four outputs side
by side; each output sums in a fixed order (``fastmath`` stays off), so results are bit-identical for any
chunking.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels._config import jit
from sins_sim._kernels.physics import RULE_MASING, diss_jit, hyst_turn, masing_close, masing_target, nonl_jit

# state layout of wideband_run
W_D1 = 0  # D_{n-1}
W_D2 = 1  # D_{n-2}
W_F1 = 2  # Nonl + Diss at D_{n-1}
W_N = 3  # samples processed
STATE_SIZE = 4


@jit
def equalised_second_difference(xx, e, c, out):
    """``out[n] = c * sum_j e[j] * d2[n + L - 1 - j]`` with ``d2`` the second differences of ``xx``.

    Parameters
    ----------
    xx : float64[N + L + 1]
        The last ``L + 1`` angles of the previous chunk (rad), then the chunk's ``N`` angles.
    e : float64[L]
        Equaliser taps (exactly symmetric, odd ``L = 2 K - 1``).
    c : float
        Scale (``1 / (2 (1 - cos w) E(w))``: the notch sits exactly at omega0).
    out : float64[N]
        ``A_n``, the equalised second difference (rad, ~ X''(t_{n-K}) / omega0^2).

    Notes
    -----
    The symmetric taps are folded (``e_m (d2[b - m] + d2[b + m])``, half the products) and four outputs
    are accumulated side by side (independent dependency chains); every output sums its terms in the
    same order, so the result does not depend on where a chunk starts.
    """
    n_out = out.shape[0]
    ntap = e.shape[0]
    m = n_out + ntap - 1
    # d2[i] = xx[i+2] - 2 xx[i+1] + xx[i] as increments (no difference of two large sums)
    d2 = np.empty(m)
    for i in range(m):
        d2[i] = (xx[i + 2] - xx[i + 1]) - (xx[i + 1] - xx[i])
    kc = (ntap - 1) // 2
    n = 0
    while n + 4 <= n_out:
        b = n + ntap - 1 - kc
        e0 = e[kc]
        s0 = e0 * d2[b]
        s1 = e0 * d2[b + 1]
        s2 = e0 * d2[b + 2]
        s3 = e0 * d2[b + 3]
        for mm in range(1, kc + 1):
            em = e[kc + mm]
            s0 += em * (d2[b - mm] + d2[b + mm])
            s1 += em * (d2[b + 1 - mm] + d2[b + 1 + mm])
            s2 += em * (d2[b + 2 - mm] + d2[b + 2 + mm])
            s3 += em * (d2[b + 3 - mm] + d2[b + 3 + mm])
        out[n] = c * s0
        out[n + 1] = c * s1
        out[n + 2] = c * s2
        out[n + 3] = c * s3
        n += 4
    while n < n_out:
        b = n + ntap - 1 - kc
        s0 = e[kc] * d2[b]
        for mm in range(1, kc + 1):
            s0 += e[kc + mm] * (d2[b - mm] + d2[b + mm])
        out[n] = c * s0
        n += 1


@jit
def wideband_run(acc, xk, vk, k1, k2, k3, k4, k5, dt, rule, fast_dt, n_iter, state, hyst, stack, out):
    """Solve eq. 2 for the deflection at ``t_{n-K}`` and output the block angle there.

    Parameters
    ----------
    acc : float64[N]
        ``A_n`` from :func:`equalised_second_difference`.
    xk, vk : float64[N]
        ``X_{n-K}`` (rad) and ``V_{n-K}`` (V), the angle and drive at the output's instant.
    k1 .. k5 : float
        Eq. 9, 10, 14 parameters.
    dt : float
        Sampling period (s), for the regime counter.
    rule : int
        Hysteresis rule (physics.RULES).
    fast_dt : float
        Half-cycles of D shorter than this are counted (regime warning).
    n_iter : int
        Fixed-point corrections after the predictor (>= 1).
    state, hyst, stack : float64 arrays
        Filter state (layout above; ``W_F1`` keeps Nonl + Diss of the last iterate, the next
        sample's predictor), eq. 10 branch and reversal stack; updated in place.
    out : float64[N]
        ``Y_n``, the block angle at ``t_{n-K}`` (rad).
    """
    d1 = state[W_D1]
    d2 = state[W_D2]
    f1 = state[W_F1]
    nn = state[W_N]
    for n in range(acc.shape[0]):
        rhs = -acc[n] - k5 * vk[n]
        p = rhs - f1
        # eq. 10's branch from D's turning points, as in _kernels/correcting.py (kept inline in both sample
        # loops: a shared jit function cost 3 ns per sample)
        inc1 = p - d1
        inc0 = d1 - d2
        if nn >= 2.0 and inc1 * inc0 < 0.0:
            curv = p - 2.0 * d1 + d2
            ext = d1
            if curv != 0.0:
                ext = d1 - (p - d2) * (p - d2) / (8.0 * curv)
            hyst_turn(hyst, stack, rule, ext, (nn - 1.0) * dt, fast_dt)
            hyst[0] = 1.0 if inc1 > 0.0 else -1.0
        elif hyst[0] == 0.0 and inc1 != 0.0:
            hyst[0] = 1.0 if inc1 > 0.0 else -1.0
        if rule == RULE_MASING:
            tgt = masing_target(hyst, stack)
            if not math.isnan(tgt) and (p - tgt) * hyst[0] > 0.0:
                masing_close(hyst, stack)
        d = p
        f = f1
        for _ in range(n_iter):
            f = nonl_jit(d, k1, k2) + diss_jit(d, hyst[0], hyst[1], hyst[2], k3, k4)
            d = rhs - f
        out[n] = xk[n] - d
        d2 = d1
        d1 = d
        f1 = f
        nn += 1.0
    state[W_D1] = d1
    state[W_D2] = d2
    state[W_F1] = f1
    state[W_N] = nn
