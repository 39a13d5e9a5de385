"""Mission-truth kernels: vehicle interpolation, per-sample quadrature, plant-rate Hermite.

The equations are documented in :mod:`sins_sim.simulation.truth`; these kernels evaluate
them per filter sample without numpy temporaries.
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit
from sins_sim._kernels.nav import error_rotvec, quat_to_dcm
from sins_sim._kernels.strapdown import radii

#: 3-point Gauss-Legendre on [0, 1] (Abramowitz & Stegun 25.4.29).
GL_X0 = 0.5 - 0.5 * math.sqrt(0.6)
GL_X2 = 0.5 + 0.5 * math.sqrt(0.6)
GL_W0 = 5.0 / 18.0
GL_W1 = 8.0 / 18.0


@jit
def _lagrange_weights(t, h, j0):
    """Row of the node before ``t`` (``nodes`` index) and the weights of nodes ``i - 1 .. i + 2``
    (A&S 25.2.13)."""
    x = t / h
    j = math.floor(x)
    u = x - j
    w0 = -u * (u - 1.0) * (u - 2.0) / 6.0
    w1 = (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0
    w2 = -(u + 1.0) * u * (u - 2.0) / 2.0
    w3 = (u + 1.0) * u * (u - 1.0) / 6.0
    return int(j) - j0, w0, w1, w2, w3


@jit
def lagrange4_columns(nodes, j0, h, t, c_lo, out):
    """:func:`lagrange4` of columns ``c_lo .. c_lo + out.shape[1] - 1`` only, into ``out[:, 0:]``
    (no quaternion among them): the same values as those columns of a full evaluation."""
    for n in range(t.shape[0]):
        i, w0, w1, w2, w3 = _lagrange_weights(t[n], h, j0)
        for c in range(out.shape[1]):
            k = c_lo + c
            out[n, c] = w0 * nodes[i - 1, k] + w1 * nodes[i, k] + w2 * nodes[i + 1, k] + w3 * nodes[i + 2, k]


@jit
def lagrange4(nodes, j0, h, t, q_col, out, full_every=1, c_lo=0, c_hi=0):
    """4-point Lagrange interpolation of node rows at times ``t`` (A&S 25.2.13).

    ``nodes[i]`` is the row at time ``(j0 + i) h``; for ``t`` in ``[t_j, t_{j+1})`` the cubic
    through nodes ``j - 1 .. j + 2`` is evaluated. ``out[n, c]`` receives the values; the four
    columns from ``q_col`` (a quaternion) are renormalised (``q_col < 0``: none).

    Only rows ``n`` with ``n % full_every == full_every - 1`` get every column; the others get
    columns ``c_lo .. c_hi - 1`` only (each column is interpolated on its own, so its values do
    not depend on which others are formed) and NaN elsewhere. ``full_every=1``: every row full.
    An ``out`` narrower than ``nodes`` receives the leading columns only (each as in a full row).
    """
    n_cols = min(nodes.shape[1], out.shape[1])
    phase = 0  # n % full_every, kept by a counter (no integer division per row)
    for n in range(t.shape[0]):
        i, w0, w1, w2, w3 = _lagrange_weights(t[n], h, j0)
        phase += 1
        if phase != full_every:
            for c in range(c_lo):
                out[n, c] = math.nan
            for c in range(c_lo, c_hi):
                out[n, c] = w0 * nodes[i - 1, c] + w1 * nodes[i, c] + w2 * nodes[i + 1, c] + w3 * nodes[i + 2, c]
            for c in range(c_hi, n_cols):
                out[n, c] = math.nan
            continue
        phase = 0
        for c in range(n_cols):
            out[n, c] = w0 * nodes[i - 1, c] + w1 * nodes[i, c] + w2 * nodes[i + 1, c] + w3 * nodes[i + 2, c]
        if q_col >= 0:
            qn = math.sqrt(out[n, q_col] ** 2 + out[n, q_col + 1] ** 2 + out[n, q_col + 2] ** 2 + out[n, q_col + 3] ** 2)
            for c in range(q_col, q_col + 4):
                out[n, c] /= qn


@jit
def _cbv_from_q(q, c):
    """``C_bv = C(q_vb)^T`` (q_vb: block to vehicle, scalar first) into the 3x3 array ``c``."""
    quat_to_dcm(q, c)
    for i in range(3):
        for j in range(i + 1, 3):
            c[i, j], c[j, i] = c[j, i], c[i, j]


@jit
def _rotated_small(c, alpha, x, out):
    """``out = (I - [alpha x] + [alpha x]^2 / 2) C x`` for the 3x3 ``c``."""
    y0 = c[0, 0] * x[0] + c[0, 1] * x[1] + c[0, 2] * x[2]
    y1 = c[1, 0] * x[0] + c[1, 1] * x[1] + c[1, 2] * x[2]
    y2 = c[2, 0] * x[0] + c[2, 1] * x[1] + c[2, 2] * x[2]
    a0, a1, a2 = alpha[0], alpha[1], alpha[2]
    b0 = a1 * y2 - a2 * y1
    b1 = a2 * y0 - a0 * y2
    b2 = a0 * y1 - a1 * y0
    out[0] = y0 - b0 + 0.5 * (a1 * b2 - a2 * b1)
    out[1] = y1 - b1 + 0.5 * (a2 * b0 - a0 * b2)
    out[2] = y2 - b2 + 0.5 * (a0 * b1 - a1 * b0)


@jit
def truth_samples(hf, om, fv, acc, dv_vib, phib, q_vb, q_nv, state, dth, dv, s_nodes, ds_nodes, q_nb, gyro_only=False):
    """Per filter sample ``n``: ideal gyro increment, velocity increment, ``S`` and ``q_nb``.

    Parameters
    ----------
    hf : float
        Filter sample period (s).
    om, fv : float64[n, 4, 3]
        ``omega_iv^v`` (rad/s) and ``f^v`` (m/s^2) at the 3 Gauss-Legendre nodes and the end of
        each sample.
    acc : float64[n, 4, 3] or float64[0, 4, 3]
        The block's translational vibration (vehicle axes, m/s^2) at the same times, or empty.
    dv_vib : float64[n, 3] or float64[0, 3]
        Its exact velocity increment over each sample (m/s), or empty.
    phib : float64[n, 4, 3]
        The block's closed-form gyro angles (rad) at the same times.
    q_vb : float64[n, 4]
        Block attitude relative to the vehicle at the end of each sample.
    q_nv : float64[n, 4]
        Vehicle attitude at the end of each sample.
    state : float64[18]
        ``S (3), dS/dt (3), phi_b (3), C_bv (9, row-major)`` at the last node; updated.
    dth, dv : float64[n, 3]
        Ideal gyro increments (rad) and velocity increments (m/s), body axes.
    s_nodes, ds_nodes : float64[n + 1, 3]
        ``S`` and its rate at the previous node and at each new one.
    q_nb : float64[n, 4]
        ``q_nv (x) q_vb`` at each node.
    gyro_only : bool
        Only ``S`` and the gyro increments (the plant's inputs): ``fv``, ``acc``, ``dv_vib`` and
        ``q_nv`` are not read, ``dv`` and ``q_nb`` not written (they may be empty).
    """
    c = state[9:18].copy().reshape((3, 3))
    c_end = c.copy()
    alpha = state[0:3].copy()
    tmp = state[0:3].copy()
    xs = state[0:3].copy()
    for i in range(3):
        s_nodes[0, i] = state[i]
        ds_nodes[0, i] = state[3 + i]
    has_vib = acc.shape[0] > 0
    ws0 = GL_W0
    ws1 = GL_W1
    for n in range(om.shape[0]):
        ds0 = 0.0
        ds1 = 0.0
        ds2 = 0.0
        v0 = 0.0
        v1 = 0.0
        v2 = 0.0
        for k in range(3):
            w = ws1 if k == 1 else ws0
            for i in range(3):
                alpha[i] = phib[n, k, i] - state[6 + i]
            _rotated_small(c, alpha, om[n, k], tmp)
            ds0 += w * tmp[0]
            ds1 += w * tmp[1]
            ds2 += w * tmp[2]
            if gyro_only:
                continue
            for i in range(3):
                xs[i] = fv[n, k, i]
                if has_vib:
                    xs[i] += acc[n, k, i]
            _rotated_small(c, alpha, xs, tmp)
            v0 += w * tmp[0]
            v1 += w * tmp[1]
            v2 += w * tmp[2]
            if has_vib:  # the unrotated vibration term goes in exactly below
                for i in range(3):
                    xs[i] = acc[n, k, i]
                y0 = c[0, 0] * xs[0] + c[0, 1] * xs[1] + c[0, 2] * xs[2]
                y1 = c[1, 0] * xs[0] + c[1, 1] * xs[1] + c[1, 2] * xs[2]
                y2 = c[2, 0] * xs[0] + c[2, 1] * xs[1] + c[2, 2] * xs[2]
                v0 -= w * y0
                v1 -= w * y1
                v2 -= w * y2
        dsx = hf * ds0
        dsy = hf * ds1
        dsz = hf * ds2
        if not gyro_only:
            dv[n, 0] = hf * v0
            dv[n, 1] = hf * v1
            dv[n, 2] = hf * v2
        if has_vib and not gyro_only:
            for i in range(3):
                dv[n, i] += c[i, 0] * dv_vib[n, 0] + c[i, 1] * dv_vib[n, 1] + c[i, 2] * dv_vib[n, 2]
        dth[n, 0] = phib[n, 3, 0] - state[6] + dsx
        dth[n, 1] = phib[n, 3, 1] - state[7] + dsy
        dth[n, 2] = phib[n, 3, 2] - state[8] + dsz
        # advance the node state to the end of the sample
        state[0] += dsx
        state[1] += dsy
        state[2] += dsz
        _cbv_from_q(q_vb[n], c_end)
        for i in range(3):
            state[3 + i] = c_end[i, 0] * om[n, 3, 0] + c_end[i, 1] * om[n, 3, 1] + c_end[i, 2] * om[n, 3, 2]
            state[6 + i] = phib[n, 3, i]
            s_nodes[n + 1, i] = state[i]
            ds_nodes[n + 1, i] = state[3 + i]
        for i in range(3):
            for j in range(3):
                c[i, j] = c_end[i, j]
        if gyro_only:
            continue
        p = q_nv[n]
        q = q_vb[n]
        q_nb[n, 0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
        q_nb[n, 1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
        q_nb[n, 2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
        q_nb[n, 3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]
    for i in range(3):
        for j in range(3):
            state[9 + 3 * i + j] = c[i, j]


@jit
def hermite_plant(s_nodes, ds_nodes, herm, dherm, out_s, out_ds):
    """Add the cubic Hermite interpolant of ``S`` (values and rates at filter nodes) at the plant steps.

    ``herm[r]``, ``dherm[r]``: the basis (and its derivative) at step ``r + 1`` of ``R`` within a
    sample (``h00, h10 h, h01, h11 h``); added in place to rows ``n R + r`` of ``out_s`` and
    ``out_ds`` (which hold the block's own angles and rates).
    """
    rr = herm.shape[0]
    for n in range(s_nodes.shape[0] - 1):
        for r in range(rr):
            row = n * rr + r
            for i in range(3):
                a = s_nodes[n, i]
                b = ds_nodes[n, i]
                cc = s_nodes[n + 1, i]
                d = ds_nodes[n + 1, i]
                out_s[row, i] += herm[r, 0] * a + herm[r, 1] * b + herm[r, 2] * cc + herm[r, 3] * d
                out_ds[row, i] += dherm[r, 0] * a + dherm[r, 1] * b + dherm[r, 2] * cc + dherm[r, 3] * d


@jit
def hermite_plant_axes(s_nodes, ds_nodes, herm, dherm, ang_b, rate_b, out_s, out_ds):
    """:func:`hermite_plant` written per axis: ``out_s[i, row] = ang_b[row, i] + (Hermite of S)``.

    The same sums as :func:`hermite_plant` in the same order (bit-identical values), stored
    axis-major (``out_s``, ``out_ds``: float64[3, n R]) so that each axis's plant input is one
    contiguous row: the three channel kernels read it without a strided copy per chunk.
    """
    rr = herm.shape[0]
    for i in range(3):
        for n in range(s_nodes.shape[0] - 1):
            a = s_nodes[n, i]
            b = ds_nodes[n, i]
            cc = s_nodes[n + 1, i]
            d = ds_nodes[n + 1, i]
            for r in range(rr):
                row = n * rr + r
                out_s[i, row] = ang_b[row, i] + (herm[r, 0] * a + herm[r, 1] * b + herm[r, 2] * cc + herm[r, 3] * d)
                out_ds[i, row] = rate_b[row, i] + (dherm[r, 0] * a + dherm[r, 1] * b + dherm[r, 2] * cc
                                                   + dherm[r, 3] * d)


@jit
def filter_increments(y, ref, use_ref, gerr, out):
    """A filter's angle increments plus the sensor errors: ``out[k] = (y[k + 1] - y[k]) + gerr[k]``.

    ``y`` (float64[n + 1, 3]): the filter output; with ``use_ref`` its first row is replaced by
    ``ref`` (float64[3], the aligned reference of the first increment). The same operations as
    ``np.diff(y, axis=0) + gerr`` without the temporaries.
    """
    for k in range(out.shape[0]):
        for i in range(3):
            y0 = ref[i] if (use_ref and k == 0) else y[k, i]
            out[k, i] = (y[k + 1, i] - y0) + gerr[k, i]


@jit
def first_not_finite(dth, dv, h):
    """``3 row + axis`` of the first non-finite ``dth`` entry (row-major), else -2 if ``dv`` has one,
    -3 if ``h`` has one, -1 if all are finite."""
    for k in range(dth.shape[0]):
        for i in range(3):
            if not math.isfinite(dth[k, i]):
                return 3 * k + i
    for k in range(dv.shape[0]):
        for i in range(3):
            if not math.isfinite(dv[k, i]):
                return -2
    for k in range(h.shape[0]):
        if not math.isfinite(h[k]):
            return -3
    return -1


@jit
def surface_scales(lat, h, out):
    """Per truth row, what turns latitude and longitude errors into metres along the surface.

    ``out[n] = [cos(lat), R_E + h, R_N + h]`` with the radii of curvature of
    :func:`sins_sim.earth.radii` (WGS-84; Titterton & Weston 2004, sec. 3.7). Computed for the truth
    rows at the navigation updates, the only rows :func:`nav_errors` reads.
    """
    for n in range(lat.shape[0]):
        r_n, r_e = radii(lat[n])
        out[n, 0] = math.cos(lat[n])
        out[n, 1] = r_e + h[n]
        out[n, 2] = r_n + h[n]


@jit
def nav_errors(lat, lon, h, v, q, lat_t, lon_t, h_t, scales_t, v_t, q_t, e_body, free, att_limit, vel_limit, pos_limit,
               out):
    """Navigation errors against the truth, one row per update; returns the first bad row or -1.

    ``out[:, 0:3]``: north, east (m, along the surface at the true position: ``dlat (R_N + h)``,
    ``wrap(dlon) cos(lat) (R_E + h)``) and their norm; ``out[:, 3]``: height error (m, up);
    ``out[:, 4:7]``: NED velocity error (m/s); ``out[:, 7:10]``: attitude error ``psi`` (rad),
    the rotation vector of ``q_est (x) q_true*`` (``C_nb_est = (I + [psi x]) C_nb_true``);
    ``out[:, 12:15]``: the free attitude error, the gyro-angle error ``e_body`` (output minus
    truth, body axes, rad) accumulated in the navigation frame, ``sum C_nb,true de_body``;
    ``free = [psi_free (3), e_body at the previous update (3)]`` carries it across calls.
    ``scales_t``: the truth rows' :func:`surface_scales`. A row is bad when it is not finite,
    ``|psi|`` exceeds ``att_limit`` (rad), the velocity error's norm exceeds ``vel_limit`` (m/s), or
    the horizontal or the height error exceeds ``pos_limit`` (m): the first such row's index is
    returned (-1: none).
    """
    bad = -1
    for n in range(lat.shape[0]):
        dn = (lat[n] - lat_t[n]) * scales_t[n, 2]
        dl = lon[n] - lon_t[n]  # wrapped to [-pi, pi): exact (no rounding) when already inside
        if dl >= math.pi or dl < -math.pi:
            dl = (dl + math.pi) % (2.0 * math.pi) - math.pi
        de = dl * scales_t[n, 0] * scales_t[n, 1]
        out[n, 0] = dn
        out[n, 1] = de
        out[n, 2] = math.sqrt(dn * dn + de * de)
        out[n, 3] = h[n] - h_t[n]
        for i in range(3):
            out[n, 4 + i] = v[n, i] - v_t[n, i]
        e1, e2, e3 = error_rotvec(q[n, 0], q[n, 1], q[n, 2], q[n, 3], q_t[n, 0], q_t[n, 1], q_t[n, 2], q_t[n, 3])
        out[n, 7] = e1
        out[n, 8] = e2
        out[n, 9] = e3
        # free attitude error: d psi_free = C_nb de_body (rotate by the true attitude)
        d0 = e_body[n, 0] - free[3]
        d1 = e_body[n, 1] - free[4]
        d2 = e_body[n, 2] - free[5]
        free[3] = e_body[n, 0]
        free[4] = e_body[n, 1]
        free[5] = e_body[n, 2]
        w0, w1, w2, w3 = q_t[n, 0], q_t[n, 1], q_t[n, 2], q_t[n, 3]
        free[0] += (1 - 2 * (w2 * w2 + w3 * w3)) * d0 + 2 * (w1 * w2 - w0 * w3) * d1 + 2 * (w1 * w3 + w0 * w2) * d2
        free[1] += 2 * (w1 * w2 + w0 * w3) * d0 + (1 - 2 * (w1 * w1 + w3 * w3)) * d1 + 2 * (w2 * w3 - w0 * w1) * d2
        free[2] += 2 * (w1 * w3 - w0 * w2) * d0 + 2 * (w2 * w3 + w0 * w1) * d1 + (1 - 2 * (w1 * w1 + w2 * w2)) * d2
        out[n, 12] = free[0]
        out[n, 13] = free[1]
        out[n, 14] = free[2]
        if bad < 0:
            ok = math.sqrt(e1 * e1 + e2 * e2 + e3 * e3) <= att_limit
            dv2 = out[n, 4] * out[n, 4] + out[n, 5] * out[n, 5] + out[n, 6] * out[n, 6]
            if not (dv2 <= vel_limit * vel_limit and out[n, 2] <= pos_limit and abs(out[n, 3]) <= pos_limit):
                ok = False
            for i in range(10):
                if not math.isfinite(out[n, i]):
                    ok = False
            if not ok:
                bad = n
    return bad


@jit
def error_stats(rows, out):
    """One chunk's full-rate statistics of error rows (columns as :func:`nav_errors`), one pass.

    ``out`` (float64[6]) receives the largest horizontal error (column 2), the largest velocity
    error norm, the sums of squares of the attitude error per axis (columns 7-9, summed in row
    order) and the last row's velocity error norm. The norm is summed as
    ``(v_n^2 + v_d^2) + v_e^2``, the order of ``numpy.einsum('ij,ij->i')`` over three columns,
    so that the figures equal the numpy evaluation bit for bit. ``rows`` must have a row.
    """
    hmax = rows[0, 2]
    vmax = 0.0
    vn = 0.0
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for n in range(rows.shape[0]):
        if rows[n, 2] > hmax:
            hmax = rows[n, 2]
        vn = math.sqrt((rows[n, 4] * rows[n, 4] + rows[n, 6] * rows[n, 6]) + rows[n, 5] * rows[n, 5])
        if n == 0 or vn > vmax:
            vmax = vn
        s0 += rows[n, 7] * rows[n, 7]
        s1 += rows[n, 8] * rows[n, 8]
        s2 += rows[n, 9] * rows[n, 9]
    out[0] = hmax
    out[1] = vmax
    out[2] = s0
    out[3] = s1
    out[4] = s2
    out[5] = vn


@jit
def _block_columns3(x, n, every, i, m, out_mean, out_min, out_max, single=False):
    """:func:`block_stats` of rows ``n .. n + every - 1`` for columns ``i .. i + 2`` (``single``: column
    ``i`` only) into row ``m``: three independent sums in flight instead of one (each still from 0.0
    in row order)."""
    j = i if single else i + 1
    k = i if single else i + 2
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    lo0 = hi0 = x[n, i]
    lo1 = hi1 = x[n, j]
    lo2 = hi2 = x[n, k]
    for r in range(n, n + every):
        a = x[r, i]
        b = x[r, j]
        d = x[r, k]
        s0 += a
        s1 += b
        s2 += d
        lo0 = a if a < lo0 else lo0
        hi0 = a if a > hi0 else hi0
        lo1 = b if b < lo1 else lo1
        hi1 = b if b > hi1 else hi1
        lo2 = d if d < lo2 else lo2
        hi2 = d if d > hi2 else hi2
    out_mean[m, i] = s0 / every
    out_min[m, i] = lo0
    out_max[m, i] = hi0
    if not single:
        out_mean[m, j] = s1 / every
        out_min[m, j] = lo1
        out_max[m, j] = hi1
        out_mean[m, k] = s2 / every
        out_min[m, k] = lo2
        out_max[m, k] = hi2


@jit
def block_stats(x, every, acc, out_mean, out_min, out_max):
    """Block means, minima and maxima over ``every`` consecutive rows, streamed.

    ``acc``: ``[count, sums (C), mins (C), maxs (C)]`` of the open block, updated in place;
    each block completed in ``x`` writes one row of ``out_*``. Returns the number written.
    A block that lies whole in ``x`` is reduced column by column in registers; a block split
    between calls goes row by row through ``acc``. Both sum each column from 0.0 in row
    order, so the figures do not depend on how the rows are chunked.
    """
    c = x.shape[1]
    m = 0
    n = 0
    nx = x.shape[0]
    while n < nx:
        if acc[0] == 0.0 and nx - n >= every:  # a whole block: three columns at a time, scalars only
            i = 0
            while i < c:
                if i + 3 <= c:
                    _block_columns3(x, n, every, i, m, out_mean, out_min, out_max)
                    i += 3
                else:
                    _block_columns3(x, n, every, i, m, out_mean, out_min, out_max, True)
                    i += 1
            m += 1
            n += every
            continue
        if acc[0] == 0.0:
            for i in range(c):
                acc[1 + i] = 0.0
                acc[1 + c + i] = x[n, i]
                acc[1 + 2 * c + i] = x[n, i]
        acc[0] += 1.0
        for i in range(c):
            xi = x[n, i]
            acc[1 + i] += xi
            if xi < acc[1 + c + i]:
                acc[1 + c + i] = xi
            if xi > acc[1 + 2 * c + i]:
                acc[1 + 2 * c + i] = xi
        if acc[0] == every:
            for i in range(c):
                out_mean[m, i] = acc[1 + i] / every
                out_min[m, i] = acc[1 + c + i]
                out_max[m, i] = acc[1 + 2 * c + i]
            m += 1
            acc[0] = 0.0
        n += 1
    return m


@jit
def block_at_nodes(ang, rate, blk, rr, gl_r0, gl_w, hp, phib):
    """The block's gyro angles at the 3 Gauss-Legendre nodes and the end of each filter sample.

    ``ang, rate`` (float64[n R, 3]): the block's angles and rates at the plant steps; ``blk``
    (float64[6]): angle and rate at the start of the first sample; node ``g`` lies between plant
    steps ``gl_r0[g]`` and ``gl_r0[g] + 1`` of its sample (step 0: the sample's start) with cubic
    Hermite weights ``gl_w[g]`` (``h00, h10, h01, h11``; the rate terms scaled by the plant step
    ``hp``). ``phib`` (float64[n, 4, 3]) receives the angles; ``blk`` moves to the last step.
    """
    n = phib.shape[0]
    for k in range(n):
        for g in range(3):
            r0 = gl_r0[g]
            for i in range(3):
                if r0 == 0:
                    a0 = blk[i]
                    d0 = blk[3 + i]
                else:
                    a0 = ang[k * rr + r0 - 1, i]
                    d0 = rate[k * rr + r0 - 1, i]
                a1 = ang[k * rr + r0, i]
                d1 = rate[k * rr + r0, i]
                phib[k, g, i] = gl_w[g, 0] * a0 + gl_w[g, 1] * hp * d0 + gl_w[g, 2] * a1 + gl_w[g, 3] * hp * d1
        for i in range(3):
            phib[k, 3, i] = ang[k * rr + rr - 1, i]
            blk[i] = ang[k * rr + rr - 1, i]
            blk[3 + i] = rate[k * rr + rr - 1, i]


@jit
def block_attitude_grid(ang, rate, blk, rr, hp, q, q_out):
    """The block's attitude at the end of each filter sample from its angles and rates on the plant grid.

    Per filter sample (``rr`` plant steps of ``hp``), the rotation vector is Bortz's
    ``phi = int w dt + 1/2 int alpha x w dt`` with ``alpha(t) = theta(t) - theta(t_start)`` (the
    gyro angles are the exact integral of the rate); the second integral by Simpson's rule over
    pairs of plant steps (``rr`` even), error ``(w h_p)^4 / 180`` of the coning term (2e-6 at
    1.6 kHz and 72 kHz). The neglected Bortz term ``(1/12) phi x (phi x w)`` is third order in the
    block's rotation within a sample (below 1e-13 of it for rotations of 1e-4 rad). Then
    ``q <- q (x) exp(phi)`` (Bortz 1971; Savage 1998 part 1).

    ``blk``: angle (3) and rate (3) at the start of the first sample (not changed); ``q``
    (float64[4]) the attitude there, advanced in place; ``q_out`` (float64[n, 4]) the attitudes.
    """
    n = q_out.shape[0]
    a0 = blk[0]
    a1 = blk[1]
    a2 = blk[2]
    for k in range(n):
        base = k * rr
        # f(t) = alpha(t) x w(t) at the rr + 1 points of the sample (f = 0 at the start)
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for r in range(1, rr + 1, 2):  # Simpson weights 4 (odd r), then 2 (even r < rr) or 1 (r = rr)
            x0 = ang[base + r - 1, 0] - a0
            x1 = ang[base + r - 1, 1] - a1
            x2 = ang[base + r - 1, 2] - a2
            w0 = rate[base + r - 1, 0]
            w1 = rate[base + r - 1, 1]
            w2 = rate[base + r - 1, 2]
            s0 += 4.0 * (x1 * w2 - x2 * w1)
            s1 += 4.0 * (x2 * w0 - x0 * w2)
            s2 += 4.0 * (x0 * w1 - x1 * w0)
            x0 = ang[base + r, 0] - a0
            x1 = ang[base + r, 1] - a1
            x2 = ang[base + r, 2] - a2
            w0 = rate[base + r, 0]
            w1 = rate[base + r, 1]
            w2 = rate[base + r, 2]
            c = 1.0 if r + 1 == rr else 2.0
            s0 += c * (x1 * w2 - x2 * w1)
            s1 += c * (x2 * w0 - x0 * w2)
            s2 += c * (x0 * w1 - x1 * w0)
        e0 = ang[base + rr - 1, 0]
        e1 = ang[base + rr - 1, 1]
        e2 = ang[base + rr - 1, 2]
        p0 = (e0 - a0) + 0.5 * hp / 3.0 * s0
        p1 = (e1 - a1) + 0.5 * hp / 3.0 * s1
        p2 = (e2 - a2) + 0.5 * hp / 3.0 * s2
        a0, a1, a2 = e0, e1, e2
        # exp(phi): [cos(|phi|/2), sin(|phi|/2) phi/|phi|] (Taylor below 1e-6 rad^2)
        m2 = p0 * p0 + p1 * p1 + p2 * p2
        if m2 < 1e-6:
            cq = 1.0 - m2 / 8.0 + m2 * m2 / 384.0
            sq = 0.5 - m2 / 48.0 + m2 * m2 / 3840.0
        else:
            m = math.sqrt(m2)
            cq = math.cos(0.5 * m)
            sq = math.sin(0.5 * m) / m
        b0, b1, b2, b3 = cq, sq * p0, sq * p1, sq * p2
        r0 = q[0] * b0 - q[1] * b1 - q[2] * b2 - q[3] * b3
        r1 = q[0] * b1 + q[1] * b0 + q[2] * b3 - q[3] * b2
        r2 = q[0] * b2 - q[1] * b3 + q[2] * b0 + q[3] * b1
        r3 = q[0] * b3 + q[1] * b2 - q[2] * b1 + q[3] * b0
        nrm = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
        q[0] = r0 / nrm
        q[1] = r1 / nrm
        q[2] = r2 / nrm
        q[3] = r3 / nrm
        q_out[k, 0] = q[0]
        q_out[k, 1] = q[1]
        q_out[k, 2] = q[2]
        q_out[k, 3] = q[3]


@jit
def add_rotated(v, q, u, out):
    """``out[n] = v[n] + C(q[n]) u[n]``: ``u`` rotated from the vehicle frame into NED and added to ``v``.

    ``C(q)`` is the direction cosine matrix of the unit quaternion ``q`` (scalar first, ``v_n = C v_b``;
    Titterton & Weston 2004, ch. 3), each row applied as ``(C_i0 u_0 + C_i2 u_2) + C_i1 u_1``: the order in
    which numpy's ``einsum("nij,nj->ni", C, u)`` summed them in the version this replaces (the same bits as
    before on the development machine; the mission truth's velocity of a vibrating block, one pass instead
    of nine temporaries, a stack and an einsum).
    """
    for k in range(q.shape[0]):
        q0, q1, q2, q3 = q[k, 0], q[k, 1], q[k, 2], q[k, 3]
        u0, u1, u2 = u[k, 0], u[k, 1], u[k, 2]
        c00 = 1 - 2 * (q2 * q2 + q3 * q3)
        c01 = 2 * (q1 * q2 - q0 * q3)
        c02 = 2 * (q1 * q3 + q0 * q2)
        c10 = 2 * (q1 * q2 + q0 * q3)
        c11 = 1 - 2 * (q1 * q1 + q3 * q3)
        c12 = 2 * (q2 * q3 - q0 * q1)
        c20 = 2 * (q1 * q3 - q0 * q2)
        c21 = 2 * (q2 * q3 + q0 * q1)
        c22 = 1 - 2 * (q1 * q1 + q2 * q2)
        out[k, 0] = v[k, 0] + ((c00 * u0 + c02 * u2) + c01 * u1)
        out[k, 1] = v[k, 1] + ((c10 * u0 + c12 * u2) + c11 * u1)
        out[k, 2] = v[k, 2] + ((c20 * u0 + c22 * u2) + c21 * u1)
