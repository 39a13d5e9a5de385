"""Kernels of the unmodelled effects (``sins_sim.models.effects``).

- :func:`mode_run`: a second-order mode driven by the table angle, stepped
  exactly for the cubic Hermite interpolant of the table angle (the
  ``block_mode`` structural resonance).
- :func:`lock_in_run`: the Adler equation of backscatter lock-in on the
  Sagnac phase, integrated with adaptive RK4 sub-steps inside each plant
  step (the ``lock_in`` effect).
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit

_TWO_PI = 2.0 * math.pi


@jit
def mode_run(angle, rate, h, w, z, phi, gam, x1, x2, out1, out2):
    """Second-order mode ``u'' + 2 z w u' + w^2 u = 2 z w p' + w^2 p`` stepped exactly.

    ``p`` is the cubic Hermite interpolant of the grid angles and rates (as
    the plant uses for the block), so the forcing is a cubic in each step
    and the step ``x[k+1] = Phi x[k] + Gam F_k`` (state ``x = (u, u')``,
    ``F_k`` the forcing and its first three derivatives at the step's
    start) is exact.

    Parameters
    ----------
    angle, rate : float64[N]
        Table angle (rad) and rate (rad/s) at the grid points.
    h : float
        Grid step (s).
    w, z : float
        Mode circular frequency (rad/s) and damping ratio.
    phi : float64[2, 2]
        ``exp(A h)``.
    gam : float64[2, 4]
        Weights of the forcing and its derivatives at the step's start.
    x1, x2 : float
        ``u``, ``u'`` at the first grid point.
    out1, out2 : float64[N]
        ``u`` and ``u'`` at every grid point.
    """
    n = angle.shape[0]
    out1[0] = x1
    out2[0] = x2
    w2 = w * w
    zw = 2.0 * z * w
    for k in range(n - 1):
        r0 = rate[k]
        r1 = rate[k + 1]
        sl = (angle[k + 1] - angle[k]) / h
        p2 = (6.0 * sl - 4.0 * r0 - 2.0 * r1) / h
        p3 = 6.0 * (r0 + r1 - 2.0 * sl) / (h * h)
        f0 = w2 * angle[k] + zw * r0
        f1 = w2 * r0 + zw * p2
        f2 = w2 * p2 + zw * p3
        f3 = w2 * p3
        y1 = phi[0, 0] * x1 + phi[0, 1] * x2 + gam[0, 0] * f0 + gam[0, 1] * f1 + gam[0, 2] * f2 + gam[0, 3] * f3
        y2 = phi[1, 0] * x1 + phi[1, 1] * x2 + gam[1, 0] * f0 + gam[1, 1] * f1 + gam[1, 2] * f2 + gam[1, 3] * f3
        x1 = y1
        x2 = y2
        out1[k + 1] = x1
        out2[k + 1] = x2


@jit
def _hermite_inc(t, r0, dp, r1):
    """Cubic Hermite increment on the unit step: 0 at 0, ``dp`` at 1, slopes ``r0``, ``r1`` (per step)."""
    t2 = t * t
    t3 = t2 * t
    return (t3 - 2.0 * t2 + t) * r0 + (-2.0 * t3 + 3.0 * t2) * dp + (t3 - t2) * r1


@jit
def _sin_integral(a, b, dt):
    """``int_0^dt sin(a + b t) dt`` without cancellation: ``dt sin(a + b dt/2) sinc(b dt/2)``."""
    x = 0.5 * b * dt
    sx = 1.0 - x * x / 6.0 * (1.0 - x * x / 20.0) if abs(x) < 1e-3 else math.sin(x) / x
    return dt * math.sin(a + x) * sx


@jit
def lock_in_run(phi, rate, h, omega_l, k, beta, max_dpsi, e0, out_e):
    """Adler equation of backscatter lock-in on the measured angle.

    With ``psi = k phi_meas + beta`` the Sagnac phase (``k = 2 pi / fringe``)
    and ``phi_meas = phi + e``, the Adler equation
    ``dpsi/dt = k dphi/dt - k omega_l sin(psi)`` becomes
    ``de/dt = -omega_l sin(k (phi(t) + e) + beta)``. ``phi(t)`` between grid
    points is the cubic Hermite interpolant of the grid angles and rates.

    Scheme: each plant step is split into ``m`` sub-intervals on which the
    phase ``k phi(t)`` is taken linear (through its values at their ends),
    few enough that the phase's curvature moves it at most ``max_dpsi / 8``
    off its chord, and that ``e`` moves the phase by at most ``max_dpsi``
    (the dither's turning points, where the lock-in acts, are resolved).
    On each sub-interval ``e`` takes a midpoint (two-stage) step in which
    ``int sin(k (phi(t) + e) + beta) dt`` is evaluated in closed form with
    ``e`` frozen, so the fast Sagnac beat costs nothing in accuracy.

    Parameters
    ----------
    phi, rate : float64[N]
        RLG angle (rad) and rate (rad/s) at the grid points.
    h : float
        Grid step (s).
    omega_l : float
        Lock-in threshold (rad/s of rotation), >= 0.
    k : float
        Sagnac phase per rad of rotation, ``2 pi / fringe_rad``.
    beta : float
        Backscatter phase (rad).
    max_dpsi : float
        Largest deviation of the phase from its chord per sub-interval, times 8 (rad).
    e0 : float
        ``e`` at the first grid point.
    out_e : float64[N]
        ``e = phi_meas - phi`` at the grid points (rad).
    """
    n = phi.shape[0]
    e = e0
    out_e[0] = e
    c = -omega_l * h
    for i in range(n - 1):
        dp = phi[i + 1] - phi[i]
        r0 = rate[i] * h
        r1 = rate[i + 1] * h
        kp = k * phi[i]
        base = kp - _TWO_PI * math.floor(kp / _TWO_PI) + beta
        # second derivative of the Hermite increment (per step^2) is linear in t: its ends bound it
        c2a = abs(-4.0 * r0 + 6.0 * dp - 2.0 * r1)
        c2b = abs(2.0 * r0 - 6.0 * dp + 4.0 * r1)
        curv = k * max(c2a, c2b)
        m = int(math.ceil(math.sqrt(curv / max_dpsi))) if curv > max_dpsi else 1
        m_e = int(math.ceil(k * omega_l * h / max_dpsi))
        if m_e > m:
            m = m_e
        dt = 1.0 / m
        pa = base
        for j in range(m):
            pb = base + k * _hermite_inc((j + 1) * dt, r0, dp, r1)
            b = (pb - pa) / dt
            i1 = _sin_integral(pa + k * e, b, dt)
            em = e + 0.5 * c * i1
            e = e + c * _sin_integral(pa + k * em, b, dt)
            pa = pb
        out_e[i + 1] = e
