"""Slow, obvious plain-Python references the benchmarked kernels are checked against."""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels import physics as kphys
from sins_sim.filters.correcting import CorrectingFilterDesign
from sins_sim.models.suspension import SuspensionParams

__all__ = ["correcting_reference", "plant_rk4_reference"]


def correcting_reference(x, volts, design: CorrectingFilterDesign) -> np.ndarray:
    """Eq. 5 as printed, in plain Python (paper hysteresis rule): the slow, obvious reference.

    ``Y_n = a2 (X_n - 2 X_{n-1} + X_{n-2}) + g (X_{n-1} + Nonl(D) + Diss(D) + k5 V_{n-1})``,
    ``D = X_{n-1} - Y_{n-1}``, at rest before the first sample (``X = 0``,
    ``D = 0``). Eq. 10's amplitude is ``|D|`` at the last turning point of
    the ``D`` sequence, refined by the parabola through the three samples
    around it, and its sign that of the last increment of ``D``
    (``_kernels/correcting.py``).
    """
    if design.hysteresis != "paper":
        raise ValueError("bench.correcting_reference: the reference implements the paper rule only")
    a2, g = design.coefficients
    k1, k2, k3, k4, k5 = design.k1, design.k2, design.k3, design.k4, design.k5
    out = np.empty(len(x))
    x1 = x2 = 0.0
    v1 = 0.0
    d_hist = [0.0, 0.0, 0.0]  # D_{n-1}, D_{n-2}, D_{n-3}
    s, a = 0.0, 0.0
    for n in range(len(x)):
        d1, d2, d3 = d_hist
        inc1, inc0 = d1 - d2, d2 - d3
        if n >= 3 and inc1 * inc0 < 0.0:
            curv = d1 - 2.0 * d2 + d3
            ext = d2 - (d1 - d3) ** 2 / (8.0 * curv) if curv != 0.0 else d2
            a = abs(ext)
            s = 1.0 if inc1 > 0.0 else -1.0
        elif s == 0.0 and inc1 != 0.0:
            s = 1.0 if inc1 > 0.0 else -1.0
        bracket = x1 + kphys.nonl(d1, k1, k2) + kphys.diss(d1, s, a, 0.0, k3, k4) + k5 * v1
        y = a2 * (x[n] - 2.0 * x1 + x2) + g * bracket
        out[n] = y
        d_hist = [x[n] - y, d1, d2]
        x2, x1, v1 = x1, x[n], volts[n]
    return out


def plant_rk4_reference(sins_angle, sins_rate, volts, h: float, suspension: SuspensionParams,
                        angle0: float = 0.0, rate0: float = 0.0) -> np.ndarray:
    """RK4 of eq. 2 in plain Python, from rest: the slow, obvious reference of one plant step.

    ``delta'' = -omega0^2 (delta + Nonl + Diss + k5 V + 2 zeta delta'/omega0) - phi_sins''``
    with ``phi_sins`` the cubic Hermite interpolant of the angle and rate
    samples (as both kernels), the drive held over each step, the paper's
    hysteresis rule. ``angle0, rate0``: the block at t = 0 (the deflection
    starts at rest). A step in which ``delta'`` changes sign against the
    branch's direction is redone in two RK4 pieces split at the turning
    point (root of the cubic Hermite of ``delta'``, by bisection), where
    ``a = |delta|`` is taken. Returns ``delta`` at the ends of the steps (rad).
    """
    w0sq = suspension.omega0 ** 2
    k1, k2, k3, k4, k5 = suspension.k1, suspension.k2, suspension.k3, suspension.k4, suspension.k5
    z = 2.0 * suspension.zeta / suspension.omega0
    d, dd, s, a = 0.0, 0.0, 0.0, 0.0
    phi0, r0 = float(angle0), float(rate0)
    out = np.empty(len(volts))
    for n in range(len(volts)):
        dp, r1 = sins_angle[n] - phi0, sins_rate[n]
        pdd0 = (6.0 * dp / h - 4.0 * r0 - 2.0 * r1) / h  # second derivative of phi_sins at the start
        pddd = 6.0 * (r0 + r1 - 2.0 * dp / h) / (h * h)  # third derivative, constant over the step
        kv = k5 * volts[n]

        def acc(tau, x, v, s, a):
            f = kphys.nonl(x, k1, k2) + kphys.diss(x, s, a, 0.0, k3, k4) + kv + z * v
            return -w0sq * (x + f) - (pdd0 + pddd * tau)

        def rk4(ta, tb, x, v, s, a):
            hs, tm = tb - ta, 0.5 * (ta + tb)
            a1 = acc(ta, x, v, s, a)
            a2 = acc(tm, x + 0.5 * hs * v, v + 0.5 * hs * a1, s, a)
            a3 = acc(tm, x + 0.5 * hs * (v + 0.5 * hs * a1), v + 0.5 * hs * a2, s, a)
            a4 = acc(tb, x + hs * (v + 0.5 * hs * a2), v + hs * a3, s, a)
            return (x + hs * v + hs * hs / 6.0 * (a1 + a2 + a3),
                    v + hs / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4))

        d_new, dd_new = rk4(0.0, h, d, dd, s, a)
        if s == 0.0:
            if dd_new != 0.0:
                s = 1.0 if dd_new > 0.0 else -1.0
        elif dd_new * s < 0.0:
            g0, g1 = acc(0.0, d, dd, s, a), acc(h, d_new, dd_new, s, a)
            lo, hi = 0.0, h
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                if _hermite_cubic(mid, h, dd, dd_new, g0, g1) * s > 0.0:
                    lo = mid
                else:
                    hi = mid
            d_t, dd_t = rk4(0.0, hi, d, dd, s, a)
            s, a = -s, abs(d_t)
            d_new, dd_new = rk4(hi, h, d_t, dd_t, s, a)
        d, dd, phi0, r0 = d_new, dd_new, sins_angle[n], r1
        out[n] = d
    return out


def _hermite_cubic(tau, span, f0, f1, g0, g1):
    """Cubic Hermite on ``[0, span]`` with values ``f0, f1`` and slopes ``g0, g1``, at ``tau``."""
    t = tau / span
    return ((2.0 * t - 3.0) * t * t + 1.0) * f0 + ((t - 2.0) * t + 1.0) * t * span * g0 \
        + (3.0 - 2.0 * t) * t * t * f1 + (t - 1.0) * t * t * span * g1
