"""The between-epoch part of a multi-rate navigation's error, averaged over each navigation interval (issue 26).

A navigator that updates every ``n`` filter samples (``navigation.rate_hz``) has its errors at the epochs only, but
the gyro-angle and accelerometer errors it integrates exist at every filter sample. Between epochs ``m - 1`` and
``m`` the navigator's attitude is ``q_{m-1} (x) q(alpha_l + beta_l)``, the last epoch composed with the rotation
accumulated since it (Savage 1998, Part 1), and its error against the truth at sample ``l`` is, to first order
in the errors (the psi-angle equation over one interval ``T = n / fs``; Titterton & Weston 2004, sec. 12.3.3)::

    psi(l) = psi_m + C_nb,m (e(l) - e_m) + r(l)

with ``e`` the filter's gyro-angle error (its output minus the true gyro angle plus the sensor errors, body
axes, rad) and ``C_nb,m`` the truth's body-to-NED rotation at epoch ``m``. ``r(l)`` gathers what changes slowly
across the interval or is of second order: the navigation-frame rotation applied at the epoch
(``|w_in| T``: 2e-7 of ``psi`` at rest at 400 Hz), the coning algorithm's own error (second order in the
increments), the body's rotation within the interval (``|w| T`` of the between-epoch part: 1e-3 of it at
0.5 rad/s, 400 Hz). The velocity error likewise gains ``C_nb,m (u(l) - u_m)``, ``u`` the accumulated error of the
velocity increments the navigator is fed (the accelerometers' error, plus with ``accel_delay: none`` the
increments' offset in time), which is what reaches it between epochs (Savage 1998, Part 2: the velocity update
takes the sum of the increments over the interval).

:func:`interval_fast_means` forms, per interval, the mean over its ``n`` filter samples ``l = 1 .. n`` of the
between-epoch term measured from its own straight line between the epochs::

    C_nb,m (mean_l e(l) - e_m + k (e_m - e_{m-1})),      k = (n - 1) / (2 n)

(the mean of the line through ``e_{m-1}`` and ``e_m`` over the interval is ``e_m - k (e_m - e_{m-1})``).
:func:`interval_means` adds it to the interval mean of the line through the epochs' errors, ``x_m - k (x_m -
x_{m-1})``: the slowly varying part (``psi - C_nb e``: alignment, Schuler, coning drift) is linear across a 2.5 ms
interval, the fast part is measured. The sum is the interval mean of ``psi(l)`` to the order above; a block mean of
such rows is the block mean over every filter sample (a boxcar of the filter-rate error: an anti-alias filter
before the stored rate) and lies at the block's centre in filter samples, as a full-rate navigation's would,
instead of a mean over samples at the navigation rate, where content at and above the navigation Nyquist (the
dither lines at 300-450 Hz, vibration) folds into the stored series.

References
----------
.. [1] P. G. Savage, "Strapdown inertial navigation integration algorithm design, Parts 1 and 2", J. Guidance,
   Control, and Dynamics 21(1), 19-28, and 21(2), 208-221, 1998.
.. [2] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IEE, 2004.
"""

from __future__ import annotations

from sins_sim._kernels._config import jit


@jit
def body_to_ned(q, x0, x1, x2):
    """``C(q) x``: the body vector ``x`` in NED, ``C(q)`` the direction cosine matrix of the unit quaternion ``q``
    (scalar first, body to NED; Titterton & Weston 2004, ch. 3)."""
    w0, w1, w2, w3 = q[0], q[1], q[2], q[3]
    return ((1.0 - 2.0 * (w2 * w2 + w3 * w3)) * x0 + 2.0 * (w1 * w2 - w0 * w3) * x1 + 2.0 * (w1 * w3 + w0 * w2) * x2,
            2.0 * (w1 * w2 + w0 * w3) * x0 + (1.0 - 2.0 * (w1 * w1 + w3 * w3)) * x1 + 2.0 * (w2 * w3 - w0 * w1) * x2,
            2.0 * (w1 * w3 - w0 * w2) * x0 + 2.0 * (w2 * w3 + w0 * w1) * x1 + (1.0 - 2.0 * (w1 * w1 + w2 * w2)) * x2)


@jit
def interval_fast_means(n, q_t, y, phi, gerr, aerr, dv_fed, dv_here, state, out):
    """Per navigation interval, the NED mean of the between-epoch attitude and velocity error (module docstring).

    Interval ``i`` (``i < m = q_t.shape[0]``) is filter samples ``i n .. i n + n - 1`` of the arrays; its last
    sample is epoch ``i``. Per sample ``l`` the gyro-angle error is ``e(l) = G(l) + y[l] - phi[l]`` (without ``y``
    rows: ``G(l)``, the ideal increments), ``G`` the running sum of the gyro sensor errors ``gerr``, and the
    accumulated error of the velocity increments fed is ``u(l)``, the running sum of ``aerr + dv_fed - dv_here``
    (without ``dv_fed`` rows: of ``aerr``). The running sums are the kernel's own, carried in ``state``, so that
    the result does not depend on how the samples are split between calls.

    ``out[i, 0:3] = C(q_t[i]) (mean_l e(l) - e_i + k (e_i - e_{i-1}))`` (rad) and ``out[i, 3:6]`` the same of
    ``u`` (m/s), ``k = (n - 1) / (2 n)``, ``C(q)`` the rotation of unit quaternion ``q`` (scalar first, body to
    NED).

    Parameters
    ----------
    n : int
        Filter samples per navigation interval.
    q_t : ndarray, shape (m, 4)
        The truth's attitude at each epoch.
    y, phi : ndarray, shape (m n, 3) or (0, 3)
        The filter's output (aligned to the truth) and the true gyro angle (rad).
    gerr, aerr : ndarray, shape (m n, 3)
        The gyro sensor errors' angle increments (rad) and the accelerometers' velocity-increment errors (m/s).
    dv_fed, dv_here : ndarray, shape (m n, 3) or (0, 3)
        The velocity increments fed to the navigator and those at the truth's own samples (m/s).
    state : ndarray, shape (9,)
        ``e`` at the epoch before the first interval, ``G`` and ``u`` there; read and updated in place
        (streaming: consecutive calls give the same bits as one).
    out : ndarray, shape (m, 6)
        Written in full.
    """
    has_y = y.shape[0] > 0
    has_dv = dv_fed.shape[0] > 0
    inv_n = 1.0 / n
    k = 0.5 * (n - 1) * inv_n
    p0, p1, p2 = state[0], state[1], state[2]  # e at the previous epoch
    g0, g1, g2 = state[3], state[4], state[5]  # G: the gyro sensor errors' running sum
    u0, u1, u2 = state[6], state[7], state[8]  # u: the velocity-increment errors' running sum
    for i in range(q_t.shape[0]):
        v0, v1, v2 = u0, u1, u2  # u at the previous epoch
        se0 = se1 = se2 = 0.0
        su0 = su1 = su2 = 0.0
        e0 = e1 = e2 = 0.0
        for l in range(i * n, i * n + n):
            g0 += gerr[l, 0]
            g1 += gerr[l, 1]
            g2 += gerr[l, 2]
            e0, e1, e2 = g0, g1, g2
            if has_y:
                e0 += y[l, 0] - phi[l, 0]
                e1 += y[l, 1] - phi[l, 1]
                e2 += y[l, 2] - phi[l, 2]
            u0 += aerr[l, 0]
            u1 += aerr[l, 1]
            u2 += aerr[l, 2]
            if has_dv:
                u0 += dv_fed[l, 0] - dv_here[l, 0]
                u1 += dv_fed[l, 1] - dv_here[l, 1]
                u2 += dv_fed[l, 2] - dv_here[l, 2]
            se0 += e0
            se1 += e1
            se2 += e2
            su0 += u0
            su1 += u1
            su2 += u2
        # the interval means against the line between the epochs
        d0 = se0 * inv_n - e0 + k * (e0 - p0)
        d1 = se1 * inv_n - e1 + k * (e1 - p1)
        d2 = se2 * inv_n - e2 + k * (e2 - p2)
        f0 = su0 * inv_n - u0 + k * (u0 - v0)
        f1 = su1 * inv_n - u1 + k * (u1 - v1)
        f2 = su2 * inv_n - u2 + k * (u2 - v2)
        p0, p1, p2 = e0, e1, e2
        out[i, 0], out[i, 1], out[i, 2] = body_to_ned(q_t[i], d0, d1, d2)
        out[i, 3], out[i, 4], out[i, 5] = body_to_ned(q_t[i], f0, f1, f2)
    state[0], state[1], state[2] = p0, p1, p2
    state[3], state[4], state[5] = g0, g1, g2
    state[6], state[7], state[8] = u0, u1, u2


#: Columns of the error rows (:func:`sins_sim._kernels.truth.nav_errors`) that :func:`interval_means` touches:
#: velocity 4-6 and attitude 7-9 gain the between-epoch part, the free attitude 12-14 too; the solution's
#: latitude and longitude (10, 11) stay the values at the updates.
_COL_V, _COL_ATT, _COL_LAT, _COL_LON, _COL_FREE = 4, 7, 10, 11, 12


@jit
def interval_means(n, q_t, y, phi, gerr, aerr, dv_fed, dv_here, rows, prev_row, state, fast, means):
    """The error rows averaged over each update's ``n`` filter samples (module docstring), in one pass.

    ``means[i] = rows[i] - k (rows[i] - rows[i-1])`` (``rows[-1]``: ``prev_row``; ``k = (n - 1) / (2 n)``), the
    mean of the straight line between the updates, for every column but the solution's latitude and longitude
    (10, 11), which stay ``rows[i]``; plus :func:`interval_fast_means` (written to ``fast``, shape (m, 6)) on the
    attitude (7-9) and the free attitude (12-14), and its velocity part on the velocity (4-6). ``prev_row``
    becomes ``rows[-1]``. Arguments as :func:`interval_fast_means`; ``rows``, ``means``: (m, C), ``prev_row``: (C,).
    """
    interval_fast_means(n, q_t, y, phi, gerr, aerr, dv_fed, dv_here, state, fast)
    k = 0.5 * (n - 1) / n
    c = rows.shape[1]
    for i in range(rows.shape[0]):
        for j in range(c):
            x = rows[i, j]
            p = prev_row[j] if i == 0 else rows[i - 1, j]
            means[i, j] = x - k * (x - p)
        means[i, _COL_LAT] = rows[i, _COL_LAT]
        means[i, _COL_LON] = rows[i, _COL_LON]
        for j in range(3):
            means[i, _COL_ATT + j] += fast[i, j]
            means[i, _COL_FREE + j] += fast[i, j]
            means[i, _COL_V + j] += fast[i, 3 + j]
    if rows.shape[0] > 0:
        for j in range(c):
            prev_row[j] = rows[rows.shape[0] - 1, j]
