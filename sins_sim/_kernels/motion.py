"""Kernels of the three-axis motion library (``sins_sim.models.motion``).

Two jobs:

* evaluating banks of sinusoids (rate and exact angle increments), the
  closed forms behind ``AxisSines``, ``Coning`` and ``RandomVibration``;
* integrating the attitude quaternion ``q' = 0.5 q (x) [0, omega_b]``
  (scalar-first Hamilton, body-to-navigation) with a 4th-order Magnus step
  whose first term is the exact angle increment.

Attitude scheme (``magnus4_run``)
---------------------------------
Over a substep ``[t_a, t_a + h]`` the attitude is advanced by
``q <- q (x) exp(sigma / 2)`` with the rotation vector

    sigma = dtheta + (sqrt(3) h^2 / 12) omega_1 x omega_2

where ``dtheta = integral omega dt`` over the substep is exact (closed form
from the motion) and ``omega_1``, ``omega_2`` are the body rates at the
2-point Gauss-Legendre nodes ``t_a + (1/2 -+ sqrt(3)/6) h``. This is the
4th-order Magnus integrator of Blanes, Casas, Oteo and Ros (2009), "The Magnus
expansion and some of its applications", Phys. Rep. 470, 151-238 (the
``Omega^[4]`` of their sect. 5.2 with its first term ``h/2 (A_1 + A_2)``
replaced by the exact integral, which keeps the order), written for the
right-multiplied body-rate equation: the commutator term is the Bortz (1971)
non-commutativity term ``1/2 integral theta x omega dt`` evaluated for a rate
linear in time, the same ``h^3/12 omega_mean x omega_dot`` that the classic
two-sample coning algorithm ``(2/3) dtheta_1 x dtheta_2`` gives (Savage 1998,
J. Guid. Control Dyn. 21(1), 19-28). Local error ``O(h^5)``, global
``O(h^4)``; the exponential is evaluated exactly (Taylor branch for small
angles) and ``q`` is renormalised after each substep.
"""

from __future__ import annotations

import math

from numba import prange

from sins_sim._kernels._config import jit

_SQRT3_12 = math.sqrt(3.0) / 12.0

#: Tones between exact re-evaluations of ``exp(i omega_k t)`` in the comb kernels.
COMB_ANCHOR = 32


@jit
def sines_rate(t, amp, omega, phase, out):
    """Rate of a bank of sinusoids per axis.

    Parameters
    ----------
    t : float64[N]
        Times (s).
    amp, omega, phase : float64[3, K]
        Rate amplitude (rad/s), circular frequency (rad/s) and phase (rad) of
        tone ``k`` on axis ``i``: ``rate_i(t) = sum_k amp cos(omega t + phase)``.
    out : float64[N, 3]
        Filled with the rates (rad/s).
    """
    n = t.shape[0]
    kk = amp.shape[1]
    for j in range(n):
        tj = t[j]
        for i in range(3):
            s = 0.0
            for k in range(kk):
                a = amp[i, k]
                if a != 0.0:
                    s += a * math.cos(omega[i, k] * tj + phase[i, k])
            out[j, i] = s


@jit
def sines_increment(ta, tb, amp, omega, phase, out):
    """Exact integral of :func:`sines_rate` from ``ta`` to ``tb``.

    Uses ``sin(x_b) - sin(x_a) = 2 cos((x_a + x_b)/2) sin((x_b - x_a)/2)`` so
    that a short increment is not the difference of two large angles; a tone
    with ``omega = 0`` is a constant rate ``amp cos(phase)``.

    Parameters
    ----------
    ta, tb : float64[N]
        Interval ends (s).
    amp, omega, phase : float64[3, K]
        As in :func:`sines_rate`.
    out : float64[N, 3]
        Filled with the angle increments (rad).
    """
    n = ta.shape[0]
    kk = amp.shape[1]
    for j in range(n):
        a0 = ta[j]
        a1 = tb[j]
        dt = a1 - a0
        tm = 0.5 * (a0 + a1)
        for i in range(3):
            s = 0.0
            for k in range(kk):
                a = amp[i, k]
                if a == 0.0:
                    continue
                w = omega[i, k]
                if w == 0.0:
                    s += a * math.cos(phase[i, k]) * dt
                else:
                    s += (2.0 * a / w) * math.cos(w * tm + phase[i, k]) * math.sin(0.5 * w * dt)
            out[j, i] = s


@jit(parallel=True)
def comb_rate(t, w0, dw, cre, cim, out):
    """Rate of a comb of equally spaced tones per axis (random vibration).

    ``rate_i(t) = sum_k Re(exp(1j omega_k t) c_ik)``, ``omega_k = w0 + k dw``,
    ``c_ik = cre + 1j cim`` (``= amp exp(1j phase)``). ``exp(1j omega_k t)``
    is advanced from tone to tone by one complex multiplication with
    ``exp(1j dw t)`` and re-evaluated exactly every ``COMB_ANCHOR`` tones,
    so each tone carries at most about ``2 COMB_ANCHOR`` ulp of extra
    relative error (< 1e-14), well below the rounding of the argument
    ``omega_k t`` itself, at a fraction of the cost of one cosine per tone
    and axis. Time points run in parallel; each is computed independently,
    so results do not depend on the number of threads or on chunking.

    Parameters
    ----------
    t : float64[N]
        Times (s).
    w0, dw : float
        First circular frequency and spacing (rad/s).
    cre, cim : float64[3, K]
        Real and imaginary parts of the complex amplitudes (rad/s).
    out : float64[N, 3]
        Filled with the rates (rad/s).
    """
    n = t.shape[0]
    kk = cre.shape[1]
    for j in prange(n):
        tj = t[j]
        rr = math.cos(dw * tj)
        ri = math.sin(dw * tj)
        er = 1.0
        ei = 0.0
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for k in range(kk):
            if k % COMB_ANCHOR == 0:
                arg = (w0 + k * dw) * tj
                er = math.cos(arg)
                ei = math.sin(arg)
            else:
                tmp = er * rr - ei * ri
                ei = er * ri + ei * rr
                er = tmp
            s0 += er * cre[0, k] - ei * cim[0, k]
            s1 += er * cre[1, k] - ei * cim[1, k]
            s2 += er * cre[2, k] - ei * cim[2, k]
        out[j, 0] = s0
        out[j, 1] = s1
        out[j, 2] = s2


@jit(parallel=True)
def comb_increment(ta, tb, w0, dw, cre, cim, out):
    """Exact integral of :func:`comb_rate` from ``ta`` to ``tb``.

    ``sum_k Re(exp(1j omega_k t_m) c_ik) 2 sin(omega_k h/2) / omega_k`` with
    ``t_m = (ta + tb)/2``, ``h = tb - ta`` (the product form of
    ``sin(x_b) - sin(x_a)``, free of cancellation); both exponentials are
    advanced by the recurrence of :func:`comb_rate`. Requires ``w0 > 0``.

    Parameters
    ----------
    ta, tb : float64[N]
        Interval ends (s).
    w0, dw, cre, cim
        As in :func:`comb_rate`.
    out : float64[N, 3]
        Filled with the angle increments (rad).
    """
    n = ta.shape[0]
    kk = cre.shape[1]
    for j in prange(n):
        tm = 0.5 * (ta[j] + tb[j])
        hh = 0.5 * (tb[j] - ta[j])
        rr = math.cos(dw * tm)
        ri = math.sin(dw * tm)
        dr = math.cos(dw * hh)
        di = math.sin(dw * hh)
        er = 1.0
        ei = 0.0
        gr = 1.0
        gi = 0.0
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for k in range(kk):
            wk = w0 + k * dw
            if k % COMB_ANCHOR == 0:
                er = math.cos(wk * tm)
                ei = math.sin(wk * tm)
                gr = math.cos(wk * hh)
                gi = math.sin(wk * hh)
            else:
                tmp = er * rr - ei * ri
                ei = er * ri + ei * rr
                er = tmp
                tmp = gr * dr - gi * di
                gi = gr * di + gi * dr
                gr = tmp
            f = 2.0 * gi / wk
            s0 += f * (er * cre[0, k] - ei * cim[0, k])
            s1 += f * (er * cre[1, k] - ei * cim[1, k])
            s2 += f * (er * cre[2, k] - ei * cim[2, k])
        out[j, 0] = s0
        out[j, 1] = s1
        out[j, 2] = s2


@jit
def quat_exp_half(sx, sy, sz):
    """``exp(sigma / 2)`` as a unit quaternion (scalar first) for a rotation vector ``sigma``.

    Taylor branch below ``|sigma|^2 = 1e-6`` (terms to ``x^6``, truncation
    below 1e-30).
    """
    ang2 = sx * sx + sy * sy + sz * sz
    if ang2 > 1e-6:
        ang = math.sqrt(ang2)
        c = math.cos(0.5 * ang)
        f = math.sin(0.5 * ang) / ang
    else:
        x2 = 0.25 * ang2
        c = 1.0 - x2 / 2.0 + x2 * x2 / 24.0 - x2 * x2 * x2 / 720.0
        f = 0.5 * (1.0 - x2 / 6.0 + x2 * x2 / 120.0 - x2 * x2 * x2 / 5040.0)
    return c, f * sx, f * sy, f * sz


@jit
def magnus4_run(dtheta, w1, w2, hsub, q, out):
    """Advance the attitude quaternion over ``n`` grid intervals of ``m`` substeps.

    Parameters
    ----------
    dtheta : float64[n, m, 3]
        Exact angle increment of each substep (rad).
    w1, w2 : float64[n, m, 3]
        Body rate at the first and second Gauss-Legendre node of each substep (rad/s).
    hsub : float64[n, m]
        Length of each substep (s); may be negative (backwards in time).
    q : float64[4]
        State: attitude at the start (scalar first); overwritten with the
        attitude at the end.
    out : float64[n, 4]
        Filled with the attitude at the end of each grid interval.
    """
    n = dtheta.shape[0]
    m = dtheta.shape[1]
    q0 = q[0]
    q1 = q[1]
    q2 = q[2]
    q3 = q[3]
    for k in range(n):
        for j in range(m):
            g = _SQRT3_12 * hsub[k, j] * hsub[k, j]
            ax = w1[k, j, 0]
            ay = w1[k, j, 1]
            az = w1[k, j, 2]
            bx = w2[k, j, 0]
            by = w2[k, j, 1]
            bz = w2[k, j, 2]
            sx = dtheta[k, j, 0] + g * (ay * bz - az * by)
            sy = dtheta[k, j, 1] + g * (az * bx - ax * bz)
            sz = dtheta[k, j, 2] + g * (ax * by - ay * bx)
            p0, p1, p2, p3 = quat_exp_half(sx, sy, sz)
            r0 = q0 * p0 - q1 * p1 - q2 * p2 - q3 * p3
            r1 = q0 * p1 + q1 * p0 + q2 * p3 - q3 * p2
            r2 = q0 * p2 - q1 * p3 + q2 * p0 + q3 * p1
            r3 = q0 * p3 + q1 * p2 - q2 * p1 + q3 * p0
            nrm = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
            q0 = r0 / nrm
            q1 = r1 / nrm
            q2 = r2 / nrm
            q3 = r3 / nrm
        out[k, 0] = q0
        out[k, 1] = q1
        out[k, 2] = q2
        out[k, 3] = q3
    q[0] = q0
    q[1] = q1
    q[2] = q2
    q[3] = q3


#: Steps between exact re-evaluations of a tone's phase in :func:`sines_grid`.
GRID_RESYNC = 128


@jit
def _tone_start(idx, w, h, p, cr, sr):
    """cos and sin of ``w t + p`` at grid index ``idx``: exact at the last multiple of ``GRID_RESYNC``
    at or below it, rotated forward from there (a function of ``idx`` alone)."""
    base = (idx // GRID_RESYNC) * GRID_RESYNC
    arg = w * (base * h) + p
    c = math.cos(arg)
    s = math.sin(arg)
    for _ in range(idx - base):
        c, s = c * cr - s * sr, s * cr + c * sr
    return c, s


@jit
def sines_grid(i0, n, h, amp, omega, phase, angle, rate):
    """Angle and rate of a sinusoid bank on the grid ``t_j = (i0 + 1 + j) h``, ``j < n``.

    Tone ``k`` of axis ``i`` (rate ``a cos(w t + p)``, angle ``(a/w)(sin(w t + p) - sin p)``,
    or ``a cos(p) t`` when ``w = 0``) is advanced by a rotation of ``w h`` per step and
    evaluated exactly at every absolute step index that is a multiple of ``GRID_RESYNC``
    (a chunk's first step rotates forward from the last such index): the result is a
    function of the index alone, so
    chunked and whole-grid evaluations agree bit for bit, and the rounding of the rotation
    stays below about 1e-14 relative. ``angle`` and ``rate`` (float64[n, 3]) are filled
    (axis-major arrays are filled contiguously).

    The three axes' tone ``k`` advance side by side in one pass (three independent rotation
    chains hide each other's latency); every value is computed exactly as one axis at a time
    would, and each element receives its tones in the order ``k = 0, 1, ...``.
    """
    kk = amp.shape[1]
    for i in range(3):
        for j in range(n):
            angle[j, i] = 0.0
            rate[j, i] = 0.0
    for k in range(kk):
        side = True  # the three axes side by side: every axis live with w != 0
        for i in range(3):
            if amp[i, k] == 0.0 or omega[i, k] == 0.0:
                side = False
        if side:
            w0, w1, w2 = omega[0, k], omega[1, k], omega[2, k]
            a0, a1, a2 = amp[0, k], amp[1, k], amp[2, k]
            g0, g1, g2 = a0 / w0, a1 / w1, a2 / w2
            s00, s01, s02 = math.sin(phase[0, k]), math.sin(phase[1, k]), math.sin(phase[2, k])
            cr0, sr0 = math.cos(w0 * h), math.sin(w0 * h)
            cr1, sr1 = math.cos(w1 * h), math.sin(w1 * h)
            cr2, sr2 = math.cos(w2 * h), math.sin(w2 * h)
            c0 = s0 = c1 = s1 = c2 = s2 = 0.0
            for j in range(n):
                idx = i0 + 1 + j
                if j == 0 or idx % GRID_RESYNC == 0:
                    c0, s0 = _tone_start(idx, w0, h, phase[0, k], cr0, sr0)
                    c1, s1 = _tone_start(idx, w1, h, phase[1, k], cr1, sr1)
                    c2, s2 = _tone_start(idx, w2, h, phase[2, k], cr2, sr2)
                else:
                    c0, s0 = c0 * cr0 - s0 * sr0, s0 * cr0 + c0 * sr0
                    c1, s1 = c1 * cr1 - s1 * sr1, s1 * cr1 + c1 * sr1
                    c2, s2 = c2 * cr2 - s2 * sr2, s2 * cr2 + c2 * sr2
                angle[j, 0] += g0 * (s0 - s00)
                rate[j, 0] += a0 * c0
                angle[j, 1] += g1 * (s1 - s01)
                rate[j, 1] += a1 * c1
                angle[j, 2] += g2 * (s2 - s02)
                rate[j, 2] += a2 * c2
            continue
        for i in range(3):
            a = amp[i, k]
            if a == 0.0:
                continue
            w = omega[i, k]
            p = phase[i, k]
            if w == 0.0:
                c0 = a * math.cos(p)
                for j in range(n):
                    angle[j, i] += c0 * ((i0 + 1 + j) * h)
                    rate[j, i] += c0
                continue
            cr = math.cos(w * h)
            sr = math.sin(w * h)
            s0 = math.sin(p)
            g = a / w
            c = 0.0
            s = 0.0
            for j in range(n):
                idx = i0 + 1 + j
                if j == 0 or idx % GRID_RESYNC == 0:
                    c, s = _tone_start(idx, w, h, p, cr, sr)
                else:
                    c, s = c * cr - s * sr, s * cr + c * sr
                angle[j, i] += g * (s - s0)
                rate[j, i] += a * c
