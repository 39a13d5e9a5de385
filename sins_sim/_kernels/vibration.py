"""Kernels of the filtered-noise vibrations (``sins_sim.models.motion.vibration``).

The vibration's primary quantity ``x(t)`` (the angle of an angular vibration,
the velocity of a translational one) is a quintic Hermite interpolant of its
node values: at node ``n`` (time ``n h``, ``h = 1 / fs``) the caller gives,
per axis ``a``, the value ``x_n``, the scaled first derivative ``h x'_n`` and
the scaled second derivative ``h^2 x''_n`` (:func:`_coefficients`).
On segment ``[n h, (n + 1) h]``, with ``u = t fs - n`` in ``[0, 1)``
(computed without the rounding of the product ``t fs``, :func:`_segment`),

    x(u) = x_0 + d_0 u + s_0 u^2 / 2 + c_3 u^3 + c_4 u^4 + c_5 u^5,
    c_3 = 10 D - 6 d_0 - 4 d_1 - 3/2 s_0 + 1/2 s_1,
    c_4 = -15 D + 8 d_0 + 7 d_1 + 3/2 s_0 - s_1,
    c_5 = 6 D - 3 d_0 - 3 d_1 - 1/2 s_0 + 1/2 s_1,

``D = x_1 - x_0``, ``d = h x'``, ``s = h^2 x''`` at the segment's ends 0 and
1: the unique quintic matching value, first and second derivative at both
ends (the quintic Hermite basis, e.g. Burden and Faires, *Numerical
Analysis*, sect. 3.4, written in powers of ``u`` for Horner evaluation). The
derivative ``x'(t) = fs dx/du`` (the rate, or the acceleration) is the exact
derivative of that polynomial, so ``x(t_b) - x(t_a)`` is its exact integral.

:func:`_coefficients` turns the two node values of a segment into its six
power-basis coefficients when an evaluation enters a segment, then one Horner
polynomial per axis. Each time is evaluated on its own (segment from
``floor(t fs)``), so the results do not depend on how the times are chunked.
Kernels never validate: the caller guarantees that every
``floor(t fs) - n0 + col`` and the column after it are columns of ``nodes``.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels._config import jit


_SPLITTER = 134217729.0  # 2^27 + 1 (Veltkamp splitting of a float64)


@jit
def _split(x):
    """``x = hi + lo`` with ``hi`` holding the upper 26 bits (Veltkamp), so products of halves are exact."""
    c = _SPLITTER * x
    hi = c - (c - x)
    return hi, x - hi


@jit
def _segment(t, fs, fh, fl):
    """Segment index ``k = floor(t fs)`` and ``u = t fs - k`` with the product's rounding error restored.

    ``t fs`` is rounded to ``p``; Dekker's two-product (T. J. Dekker, "A
    floating-point technique for extending the available precision", Numer.
    Math. 18, 224-242, 1971) gives its exact error ``e = t fs - p``
    (``fh + fl = fs`` from :func:`_split`), and ``p - k`` is exact for
    ``p >= 0`` (Sterbenz), so ``u = (p - k) + e`` is within ``eps`` of the
    true position instead of ``eps t fs`` (6e-9 of a segment at
    ``t = 3600`` s and 14.4 kHz): the angle stays the exact integral of the
    rate to rounding at any time. ``u`` may leave ``[0, 1)`` by
    ``eps t fs`` when ``p`` rounds across a node; the segment's polynomial
    is then used that far outside it, where it agrees with its neighbour's
    to rounding.
    """
    p = t * fs
    th, tl = _split(t)
    e = ((th * fh - p) + th * fl + tl * fh) + tl * fl
    k = math.floor(p)
    return int(k), (p - k) + e


@jit
def _coefficients(nodes, a, i):
    """``c_0 .. c_5`` (module docstring) of the segment from node column ``i`` to ``i + 1``, axis ``a``."""
    x0 = np.float64(nodes[0, a, i])  # float32 nodes are widened first: the arithmetic is float64 for both
    d0 = np.float64(nodes[1, a, i])
    s0 = np.float64(nodes[2, a, i])
    x1 = np.float64(nodes[0, a, i + 1])
    d1 = np.float64(nodes[1, a, i + 1])
    s1 = np.float64(nodes[2, a, i + 1])
    dd = x1 - x0
    c3 = 10.0 * dd - 6.0 * d0 - 4.0 * d1 - 1.5 * s0 + 0.5 * s1
    c4 = -15.0 * dd + 8.0 * d0 + 7.0 * d1 + 1.5 * s0 - s1
    c5 = 6.0 * dd - 3.0 * d0 - 3.0 * d1 - 0.5 * s0 + 0.5 * s1
    return x0, d0, 0.5 * s0, c3, c4, c5


@jit
def _load(nodes, i, c):
    """``c[6 a .. 6 a + 5]`` = :func:`_coefficients` of column ``i``, axes ``a = 0, 1, 2``."""
    for a in range(3):
        c[6 * a], c[6 * a + 1], c[6 * a + 2], c[6 * a + 3], c[6 * a + 4], c[6 * a + 5] = _coefficients(nodes, a, i)


@jit
def _at(t, fs, fh, fl, n0, nodes, col, c, last):
    """Position ``u`` of ``t`` in its segment, with ``c`` holding that segment's coefficients (:func:`_load`).

    ``last`` is the column whose coefficients ``c`` holds; returns ``(u, column)``. Times in order share a
    segment's coefficients (5 per segment on the plant grid), so they are formed only on entering a segment.
    """
    k, u = _segment(t, fs, fh, fl)
    i = k - n0 + col
    if i != last:
        _load(nodes, i, c)
    return u, i


@jit
def _value(c, a, u):
    """``x(u)`` of axis ``a`` by Horner's rule on the coefficients ``c`` (:func:`_load`)."""
    b = 6 * a
    p = c[b + 4] + u * c[b + 5]
    p = c[b + 3] + u * p
    p = c[b + 2] + u * p
    p = c[b + 1] + u * p
    return c[b] + u * p


@jit
def _slope(c, a, u):
    """``dx/du`` of axis ``a`` by Horner's rule on the coefficients ``c`` (:func:`_load`)."""
    b = 6 * a
    p = 4.0 * c[b + 4] + u * (5.0 * c[b + 5])
    p = 3.0 * c[b + 3] + u * p
    p = 2.0 * c[b + 2] + u * p
    return c[b + 1] + u * p


@jit
def hermite5_value(t, fs, n0, nodes, col, offset, out):
    """Quintic Hermite interpolant at the times ``t``, less ``offset``.

    The segment's coefficients are formed from its two nodes when a time falls in another segment than
    the time before (:func:`_coefficients`, about 20 operations per axis), not kept in a table: a table
    of 18 float64 per node, written once per node block, cost more in memory traffic than forming them
    here for the 2 to 5 times per segment of the engine's grids (issue 26).

    Parameters
    ----------
    t : float64[N]
        Times (s).
    fs : float
        Node rate (Hz); node ``n`` sits at ``t = n / fs``.
    n0 : int
        Index of the node in column ``col`` of ``nodes``.
    nodes : float64 or float32 [3, 3, M]
        ``nodes[q, a, col + n - n0]``: quantity ``q`` of node ``n`` on axis ``a``, ``q = 0, 1, 2``
        for the value ``x``, ``h x'`` and ``h^2 x''`` (``h = 1 / fs``; units of the value). Every
        segment the times fall in needs both its nodes.
    col : int
        Column of node ``n0``.
    offset : float64[3]
        Subtracted from the value of each axis (``x(0)`` for the integral
        from 0; zeros for the value itself).
    out : float64[N, 3]
        Filled with ``x(t) - offset`` (units of the node values).
    """
    n = t.shape[0]
    fh, fl = _split(fs)
    c = np.empty(18)
    last = -1
    for j in range(n):
        u, last = _at(t[j], fs, fh, fl, n0, nodes, col, c, last)
        for a in range(3):
            out[j, a] = _value(c, a, u) - offset[a]


@jit
def hermite5_slope(t, fs, n0, nodes, col, out):
    """Time derivative of :func:`hermite5_value` at the times ``t``.

    Parameters
    ----------
    t : float64[N]
        Times (s).
    fs : float
        Node rate (Hz).
    n0, nodes, col
        As for :func:`hermite5_value`.
    out : float64[N, 3]
        Filled with ``dx/dt = fs dx/du`` (units of the value per second).
    """
    n = t.shape[0]
    fh, fl = _split(fs)
    c = np.empty(18)
    last = -1
    for j in range(n):
        u, last = _at(t[j], fs, fh, fl, n0, nodes, col, c, last)
        for a in range(3):
            out[j, a] = fs * _slope(c, a, u)


@jit
def hermite5_value_slope(t, fs, n0, nodes, col, offset, value, slope):
    """:func:`hermite5_value` and :func:`hermite5_slope` in one pass (same operations, same bits).

    Parameters
    ----------
    t : float64[N]
        Times (s).
    fs : float
        Node rate (Hz).
    n0, nodes, col
        As for :func:`hermite5_value`.
    offset : float64[3]
        Subtracted from the value of each axis.
    value : float64[N, 3]
        Filled with ``x(t) - offset``.
    slope : float64[N, 3]
        Filled with ``dx/dt``.
    """
    n = t.shape[0]
    fh, fl = _split(fs)
    c = np.empty(18)
    last = -1
    for j in range(n):
        u, last = _at(t[j], fs, fh, fl, n0, nodes, col, c, last)
        for a in range(3):
            value[j, a] = _value(c, a, u) - offset[a]
            slope[j, a] = fs * _slope(c, a, u)


@jit
def _basis(us, fs):
    """Quintic Hermite basis (module docstring) at the positions ``us``: weights of ``x_0, d_0, s_0, x_1, d_1, s_1``
    in the value, ``bv[p]``, and in ``dx/dt = fs dx/du``, ``bs[p]`` (the coefficients of ``c_3 .. c_5`` collected
    per node quantity)."""
    r = us.shape[0]
    bv = np.empty((r, 6))
    bs = np.empty((r, 6))
    for p in range(r):
        u = us[p]
        u2 = u * u
        u3 = u2 * u
        u4 = u3 * u
        u5 = u4 * u
        bv[p, 0] = 1.0 - 10.0 * u3 + 15.0 * u4 - 6.0 * u5
        bv[p, 1] = u - 6.0 * u3 + 8.0 * u4 - 3.0 * u5
        bv[p, 2] = 0.5 * u2 - 1.5 * u3 + 1.5 * u4 - 0.5 * u5
        bv[p, 3] = 10.0 * u3 - 15.0 * u4 + 6.0 * u5
        bv[p, 4] = -4.0 * u3 + 7.0 * u4 - 3.0 * u5
        bv[p, 5] = 0.5 * u3 - u4 + 0.5 * u5
        bs[p, 0] = fs * (-30.0 * u2 + 60.0 * u3 - 30.0 * u4)
        bs[p, 1] = fs * (1.0 - 18.0 * u2 + 32.0 * u3 - 15.0 * u4)
        bs[p, 2] = fs * (u - 4.5 * u2 + 6.0 * u3 - 2.5 * u4)
        bs[p, 3] = fs * (30.0 * u2 - 60.0 * u3 + 30.0 * u4)
        bs[p, 4] = fs * (-12.0 * u2 + 28.0 * u3 - 15.0 * u4)
        bs[p, 5] = fs * (1.5 * u2 - 4.0 * u3 + 2.5 * u4)
    return bv, bs


@jit
def hermite5_grid(i0, r, fs, n0, nodes, col, offset, value, slope):
    """:func:`hermite5_value_slope` on a grid of ``r`` points per segment, axis-major, positions exact.

    Point ``j`` is step ``m = i0 + 1 + j`` of the grid ``t_m = m / (r fs)`` (``r`` an integer: the
    plant rate a multiple of the node rate), in segment ``k = floor(m / r)`` at ``u = (m mod r) / r``:
    the exact position of ``t_m``, taken from the integers instead of from the rounded time (the
    general kernels' :func:`_segment` restores the rounding of ``t fs`` but not that of ``t`` itself,
    ``eps t / 2``: at ``t = 3600`` s a difference of ``rate' 4e-13 s`` in the rate). The positions
    repeat in every segment, so the quintic is evaluated in the Hermite basis at those ``r``
    positions (:func:`_basis`, tabulated once per call): six products per value from the six
    node quantities, no per-segment coefficients and no Horner chain (0.59 against 0.89 ms for
    72,000 steps on 3 axes in the Horner form, same run). The same polynomial as the general
    kernels' to rounding (3e-15 of the largest rate); the value at a node is the node's exactly, so
    the angle is still the integral of the rate to rounding.

    Parameters
    ----------
    i0 : int
        Step before the first point (``m >= 0``).
    r : int
        Grid points per node segment.
    fs : float
        Node rate (Hz).
    n0, nodes, col
        As for :func:`hermite5_value`; the segments ``floor((i0 + 1) / r) .. floor((i0 + n) / r)``
        and the node after the last must be columns of ``nodes``.
    offset : float64[3]
        Subtracted from the value of each axis.
    value, slope : float64[3, n]
        Filled with ``x(t_m) - offset`` and ``dx/dt`` (rows: axes; ``n`` points).
    """
    n = value.shape[1]
    if n == 0:
        return
    us = np.empty(r)
    for p in range(r):
        us[p] = p / r
    bv, bs = _basis(us, fs)
    m_first = i0 + 1
    k_first = m_first // r
    k_last = (i0 + n) // r
    for a in range(3):
        off = offset[a]
        for k in range(k_first, k_last + 1):
            i = k - n0 + col
            x0 = np.float64(nodes[0, a, i])  # float32 nodes widened: the arithmetic is float64
            d0 = np.float64(nodes[1, a, i])
            s0 = np.float64(nodes[2, a, i])
            x1 = np.float64(nodes[0, a, i + 1])
            d1 = np.float64(nodes[1, a, i + 1])
            s1 = np.float64(nodes[2, a, i + 1])
            p_lo = m_first - k * r if k == k_first else 0
            p_hi = i0 + n - k * r + 1 if k == k_last else r
            j0 = k * r - m_first
            for p in range(p_lo, p_hi):
                value[a, j0 + p] = (bv[p, 0] * x0 + bv[p, 1] * d0 + bv[p, 2] * s0 + bv[p, 3] * x1 + bv[p, 4] * d1
                                    + bv[p, 5] * s1) - off
                slope[a, j0 + p] = (bs[p, 0] * x0 + bs[p, 1] * d0 + bs[p, 2] * s0 + bs[p, 3] * x1 + bs[p, 4] * d1
                                    + bs[p, 5] * s1)


@jit
def hermite5_samples(k0, q, cs, fs, n0, nodes, col, slope, value):
    """The derivative at fixed points of each sample of a grid ``q`` times coarser than the nodes, and the
    value at the samples' ends.

    Sample ``j`` spans ``[(k0 + j) H, (k0 + j + 1) H]`` with ``H = q / fs`` (``q`` an integer: the node
    rate a multiple of the sample rate), i.e. node segments ``(k0 + j) q .. (k0 + j + 1) q - 1``; its point
    ``g`` at ``(k0 + j + cs[g]) H`` lies in segment ``(k0 + j) q + floor(cs[g] q)`` at
    ``u = cs[g] q - floor(cs[g] q)``, from the integers (as :func:`hermite5_grid`: the exact positions, not
    those of rounded times), the derivative in the Hermite basis tabulated at those positions (:func:`_basis`). The value at a sample boundary ``(k0 + j) H`` is node ``(k0 + j) q`` itself
    (``u = 0``: the polynomial's ``c_0``), so that differences of consecutive values are the exact integral
    of the derivative over each sample, and telescope.

    Parameters
    ----------
    k0 : int
        First sample.
    q : int
        Node segments per sample.
    cs : float64[G]
        Points within a sample as fractions of it, ``0 <= cs[g] <= 1``.
    fs : float
        Node rate (Hz).
    n0, nodes, col
        As for :func:`hermite5_value`; segments ``k0 q .. (k0 + n) q`` must be columns of ``nodes``
        with the node after the last.
    slope : float64[n, G, 3]
        Filled with ``dx/dt`` at the points.
    value : float64[n + 1, 3]
        Filled with ``x`` at the boundaries ``(k0 + j) H``, ``j = 0 .. n``.
    """
    n = slope.shape[0]
    ng = cs.shape[0]
    shift = np.empty(ng, dtype=np.int64)
    us = np.empty(ng)
    for g in range(ng):
        x = cs[g] * q
        s = math.floor(x)
        shift[g] = int(s)
        us[g] = x - s
    _, bs = _basis(us, fs)  # the positions repeat in every sample: the slope's weights, tabulated once
    for j in range(n):
        base = (k0 + j) * q - n0 + col
        for g in range(ng):
            i = base + shift[g]
            for a in range(3):
                slope[j, g, a] = (bs[g, 0] * np.float64(nodes[0, a, i]) + bs[g, 1] * np.float64(nodes[1, a, i])
                                  + bs[g, 2] * np.float64(nodes[2, a, i]) + bs[g, 3] * np.float64(nodes[0, a, i + 1])
                                  + bs[g, 4] * np.float64(nodes[1, a, i + 1]) + bs[g, 5] * np.float64(nodes[2, a, i + 1]))
    for j in range(n + 1):
        i = (k0 + j) * q - n0 + col
        for a in range(3):
            value[j, a] = np.float64(nodes[0, a, i])
