"""Compiled steps of the error-state Kalman filter (:mod:`sins_sim.navigation.ekf`).

The same equations as the numpy reference there, written for one call per filter step so that the
aided mission pays no Python-level cost per n x n product (n = 15, or more with fix-error and sensor-error states) (issue 37, item 7):

* :func:`propagate_block`: the continuous ``F`` at a block's mean navigation state (Groves 2013,
  sec. 14.2.4, eq. 14.64-14.71, the form of :func:`sins_sim.navigation.ekf.error_dynamics`), its
  discretisation by the Taylor series of ``Phi = expm(F T)`` and of van Loan's (1978) integral
  (:func:`sins_sim.navigation.ekf.discretize`), and ``P <- Phi P Phi^T + Q_d`` (Groves 2013, eq. 3.46);
* :func:`joseph_update`: ``S = H P H^T + R``, ``K = P H^T S^-1``, ``x += K (dz - H x)``,
  ``P = (I - K H) P (I - K H)^T + K R K^T`` (Bucy & Joseph 1968; Groves 2013, eq. 3.58);
* :func:`correct_rows`: the feedback's inverse of the error state on stored solution rows
  (:meth:`sins_sim.navigation.strapdown.StrapdownNavigator.apply_correction` row by row).

The module docstring of :mod:`sins_sim.navigation.ekf` states the model; the tests compare every kernel
with the numpy reference it replaces (rounding-level agreement).
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim import earth
from sins_sim._kernels._config import jit
from sins_sim._kernels.nav import quat_mul, quat_to_dcm, rotvec_to_quat
from sins_sim._kernels import strapdown as ksd
from sins_sim._kernels.strapdown import gravity_down, radii

__all__ = ["SERIES_ORDER", "propagate_block", "propagate_block_states", "unmodelled_increment_into", "running_integrals", "bias_corrected", "triad_corrected", "sensor_feedback", "update_sums", "joseph_update", "block_nis", "correct_rows", "correct_state", "interpolate_row", "gnss_measurement", "error_dynamics_into"]

#: Highest power of ``F`` in the series of ``Phi`` and ``Q_d`` (the reference's ``_SERIES_ORDER``).
SERIES_ORDER = 5

_E2 = earth.WGS84_E2
_OMEGA = earth.EARTH_RATE_RAD_S
_GE, _K, _A, _FL, _M = (earth.GAMMA_EQUATOR_M_S2, earth.SOMIGLIANA_K, earth.WGS84_A_M, earth.WGS84_F,
                        earth.WGS84_M)


@jit
def _skew_into(a0, a1, a2, out, r0, c0, sign):
    """``out[r0:r0+3, c0:c0+3] += sign [a x]``."""
    out[r0, c0 + 1] += -sign * a2
    out[r0, c0 + 2] += sign * a1
    out[r0 + 1, c0] += sign * a2
    out[r0 + 1, c0 + 2] += -sign * a0
    out[r0 + 2, c0] += -sign * a1
    out[r0 + 2, c0 + 1] += sign * a0


@jit
def error_dynamics_into(lat, h, vel, c, f_n, inv_tau_g, inv_tau_a, f):
    """The continuous ``F`` (15 x 15) written into ``f`` (zeroed first): the model of
    :func:`sins_sim.navigation.ekf.error_dynamics` (Groves 2013, eq. 14.64-14.71, NED metres, the radii's
    change with latitude kept); ``inv_tau_g``, ``inv_tau_a`` the bias correlation rates (0 for constant
    biases)."""
    f[:, :] = 0.0
    r_n, r_e = radii(lat)
    rn, re = r_n + h, r_e + h
    sl, cl = math.sin(lat), math.cos(lat)
    tl = math.tan(lat)
    vn, ve, vd = vel[0], vel[1], vel[2]
    wie0, wie2 = _OMEGA * cl, -_OMEGA * sl
    wen0, wen1, wen2 = ve / re, -vn / rn, -ve * tl / re
    # W_v = d omega_en / d dv (Groves eq. 14.65)
    wv = np.zeros((3, 3))
    wv[0, 1] = 1.0 / re
    wv[1, 0] = -1.0 / rn
    wv[2, 1] = -tl / re
    # W_r = d omega_en / d dr with the radii's change with latitude, Z_r = d omega_ie / d dr (eq. 14.66)
    w = 1.0 - _E2 * sl * sl
    dre = _A / math.sqrt(w) * _E2 * sl * cl / w
    drn = 3.0 * r_n * _E2 * sl * cl / (1.0 - _E2 * sl ** 2)
    wr = np.zeros((3, 3))
    wr[0, 0] = (-ve * dre / re ** 2) / rn
    wr[1, 0] = (vn * drn / rn ** 2) / rn
    wr[2, 0] = (-ve / (re * cl * cl) + ve * tl * dre / re ** 2) / rn
    wr[0, 2] = ve / re ** 2
    wr[1, 2] = -vn / rn ** 2
    wr[2, 2] = -ve * tl / re ** 2
    zr = np.zeros((3, 3))
    zr[0, 0] = _OMEGA * -sl / (r_n + h)
    zr[2, 0] = _OMEGA * -cl / (r_n + h)
    # position rows
    for i in range(3):
        f[i, 3 + i] = 1.0
    f[0, 0], f[0, 2] = -vd / rn, vn / rn
    f[1, 0], f[1, 1], f[1, 2] = ve * tl / rn, -vd / re - vn * tl / rn, ve / re
    f[1, 0] -= ve * dre / (re * rn)
    f[1, 1] += vn * dre / (rn * re)
    # velocity rows: [v x] (2 Z_r + W_r), [v x] W_v
    vx = np.zeros((3, 3))
    _skew_into(vn, ve, vd, vx, 0, 0, 1.0)
    for i in range(3):
        for j in range(3):
            a = 0.0
            b = 0.0
            for k in range(3):
                a += vx[i, k] * (2.0 * zr[k, j] + wr[k, j])
                b += vx[i, k] * wv[k, j]
            f[3 + i, j] = a
            f[3 + i, 3 + j] = b
    # normal gravity's change with latitude and height (NIMA TR8350.2 eq. 4-1 and 4-3, differentiated)
    s2 = sl * sl
    wg = 1.0 - _E2 * s2
    g0 = _GE * (1.0 + _K * s2) / math.sqrt(wg)
    hf = 1.0 - 2.0 / _A * (1.0 + _FL + _M - 2.0 * _FL * s2) * h + 3.0 * h * h / (_A * _A)
    dg0 = _GE * sl * cl * (2.0 * _K / math.sqrt(wg) + (1.0 + _K * s2) * _E2 / wg ** 1.5)
    dhf_dl = 8.0 * _FL * sl * cl * h / _A
    dhf_dh = -2.0 / _A * (1.0 + _FL + _M - 2.0 * _FL * s2) + 6.0 * h / (_A * _A)
    f[5, 0] += (dg0 * hf + g0 * dhf_dl) / rn
    f[5, 2] += -(g0 * dhf_dh)
    _skew_into(2.0 * wie0 + wen0, wen1, 2.0 * wie2 + wen2, f, 3, 3, -1.0)
    _skew_into(f_n[0], f_n[1], f_n[2], f, 3, 6, -1.0)
    for i in range(3):
        for j in range(3):
            f[3 + i, 12 + j] = -c[i, j]
            f[6 + i, j] = -(zr[i, j] + wr[i, j])
            f[6 + i, 3 + j] = -wv[i, j]
            f[6 + i, 9 + j] = -c[i, j]
    _skew_into(wie0 + wen0, wen1, wie2 + wen2, f, 6, 6, -1.0)
    for i in range(3):
        f[9 + i, 9 + i] = -inv_tau_g
        f[12 + i, 12 + i] = -inv_tau_a


@jit
def unmodelled_increment_into(a0, a1, origin, s2, m2, out):
    """Per body axis ``max(0, v_i(a1 - o) - v_i(a0 - o))`` with ``v_i(a) = s2 a_i^2 + m2 (|a|^2 - a_i^2)``, into
    ``out``; the origin ``o`` (``origin``, in place) restarts at ``a0`` when the step heads back towards it
    (:func:`sins_sim.navigation.ekf.unmodelled_variance_increment`, the reference)."""
    back = 0.0
    for i in range(3):
        back += (a1[i] - a0[i]) * (a0[i] - origin[i])
    if back < 0.0:
        for i in range(3):
            origin[i] = a0[i]
    n0 = 0.0
    n1 = 0.0
    for i in range(3):
        n0 += (a0[i] - origin[i]) ** 2
        n1 += (a1[i] - origin[i]) ** 2
    for i in range(3):
        b0 = (a0[i] - origin[i]) ** 2
        b1 = (a1[i] - origin[i]) ** 2
        out[i] = max(0.0, s2 * (b1 - b0) + m2 * ((n1 - b1) - (n0 - b0)))


@jit
def bias_corrected(dth, dvel, bg_dt, ba_dt, dth_out, dv_out, dth_sum):
    """``dth_out = dth - bg_dt`` and ``dv_out = dvel - ba_dt`` row by row (the increments with the bias estimates
    removed), and ``dth_sum += `` the column sums of ``dth`` (added sequentially from zero, as numpy sums a
    C-contiguous ``(n, 3)`` array over axis 0): the numpy expressions of
    :meth:`sins_sim.navigation.ekf.AidedNavigator._process_checked` in one pass, same values."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for k in range(dth.shape[0]):
        s0 += dth[k, 0]
        s1 += dth[k, 1]
        s2 += dth[k, 2]
        for i in range(3):
            dth_out[k, i] = dth[k, i] - bg_dt[i]
            dv_out[k, i] = dvel[k, i] - ba_dt[i]
    dth_sum[0] += s0
    dth_sum[1] += s1
    dth_sum[2] += s2


@jit
def triad_corrected(d, m):
    """``d[k] <- m d[k]`` for every row ``k`` of an ``(n, 3)`` array of one triad's increments, in place: the
    estimated scale factors and misalignments removed, ``m = (I + K_est)^-1`` (Titterton & Weston 2004, sec. 4.3.3,
    ``u_meas = (I + K) u``). Each element the sum ``m_i0 d_0 + m_i1 d_1 + m_i2 d_2`` left to right, on the
    Python path (:meth:`sins_sim.navigation.ekf.AidedNavigator._process_checked`) and the compiled one alike."""
    for k in range(d.shape[0]):
        a0 = d[k, 0]
        a1 = d[k, 1]
        a2 = d[k, 2]
        for i in range(3):
            d[k, i] = m[i, 0] * a0 + m[i, 1] * a1 + m[i, 2] * a2


@jit
def _inverse_identity_plus(k, out):
    """``out = (I + k)^-1`` of a 3x3 ``k`` by the adjugate over the determinant (Cramer's rule; Strang 2016,
    *Introduction to Linear Algebra*, sec. 5.3): exact algebra, accurate for ``I + K`` near the identity."""
    a = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            a[i, j] = k[i, j] + (1.0 if i == j else 0.0)
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    out[0, 0] = c00 / det
    out[1, 0] = c01 / det
    out[2, 0] = c02 / det
    out[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) / det
    out[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) / det
    out[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) / det
    out[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) / det
    out[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) / det
    out[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) / det


@jit
def sensor_feedback(k_est, k_inv, dx, kind, row, col):
    """The sensor-error states fed back like the biases, in place: ``K_est[kind, row, col] -= dx`` per state
    (:meth:`sins_sim.navigation.ekf.UnmodelledErrors.state_table`), then ``k_inv = (I + K_est)^-1`` of both triads
    (gyros 0, accelerometers 1), which :func:`triad_corrected` applies to the increments."""
    for s in range(kind.shape[0]):
        k_est[kind[s], row[s], col[s]] -= dx[s]
    for b in range(2):
        _inverse_identity_plus(k_est[b], k_inv[b])


@jit
def update_sums(x, n_sub, out):
    """The sums of ``x`` over each navigation update's ``n_sub`` rows, into ``out`` (added sequentially, as
    ``x.reshape(-1, n_sub, 3).sum(axis=1)``)."""
    for j in range(out.shape[0]):
        for i in range(3):
            a = 0.0
            for k in range(n_sub):
                a += x[j * n_sub + k, i]
            out[j, i] = a


@jit
def running_integrals(dth, dvel, acc0, f_ref, big_t, n_sub, pending, out):
    """The running integrals at the end of each of the ``out.shape[0]`` navigation updates a chunk completes, into
    ``out`` (rows ``acc0[:3] + sum dtheta``, ``acc0[3:] + sum dv - (j + 1) T f_ref``; the chunk's first
    ``n_sub - pending`` samples complete the pending update): the sums sequential, as ``np.cumsum``, so the rows
    equal those of :meth:`sins_sim.navigation.ekf.AidedNavigator._integrals_reference` bit for bit, without the
    cumulative sum of every sample of the chunk."""
    s = np.zeros(6)
    k = 0
    for j in range(out.shape[0]):
        end = (j + 1) * n_sub - pending
        while k < end:
            for i in range(3):
                s[i] += dth[k, i]
                s[3 + i] += dvel[k, i]
            k += 1
        t_row = (j + 1) * big_t
        for i in range(3):
            out[j, i] = acc0[i] + s[i]
            out[j, 3 + i] = acc0[3 + i] + s[3 + i] - t_row * f_ref[i]


@jit
def propagate_block(start, end, t, inv_tau_g, inv_tau_a, qc, unmod, origin, p, phi_acc, x, open_loop, fix_tau,
                    fix_var):
    """:func:`propagate_block_states` with no sensor-error states (the 15 inertial states and the fix errors)."""
    none = np.zeros(0, dtype=np.int64)
    return propagate_block_states(start, end, t, inv_tau_g, inv_tau_a, qc, unmod, origin, p, phi_acc, x, open_loop,
                                  fix_tau, fix_var, np.zeros(3), none, none, none)


@jit
def propagate_block_states(start, end, t, inv_tau_g, inv_tau_a, qc, unmod, origin, p, phi_acc, x, open_loop, fix_tau,
                           fix_var, f_ref, sens_kind, sens_row, sens_col):
    """Propagate the covariance over one block of navigation updates, in place.

    The state has ``n = p.shape[0]`` entries: the 15 of the inertial errors, then ``len(fix_tau)`` first-order
    Gauss-Markov errors of the aiding fixes (:class:`sins_sim.navigation.ekf.FixErrorStates`), each decoupled
    from the rest with the exact discrete model ``Phi_k = exp(-T/tau_k)``,
    ``Q_d,k = sigma_k^2 (1 - exp(-2 T/tau_k))`` (Gelb 1974, sec. 3.8; Brown & Hwang 2012, sec. 4.2), then
    ``len(sens_kind)`` random constants, the errors ``dK[row, col]`` of the estimated scale-factor and misalignment
    matrices (:meth:`sins_sim.navigation.ekf.UnmodelledErrors.state_table`), whose columns of ``F`` are
    ``-C[:, row] x_col`` on the attitude rows (gyros, ``x`` the block's mean body rate from the running angle) or
    the velocity rows (accelerometers, ``x`` the mean specific force, the running velocity's change over ``T`` plus
    ``f_ref``) (:func:`sins_sim.navigation.ekf.sensor_error_columns`).

    Parameters
    ----------
    start, end : ndarray, shape (15,)
        The navigator's ``(lat, h, v_N, v_E, v_D, q0, q1, q2, q3)`` at the block's start and end, then the
        running integrals of the raw rate (rad, body) and of the specific force less its reference (m/s, body)
        that the unmodelled scale factors and misalignments multiply.
    t : float
        The block's length (s).
    inv_tau_g, inv_tau_a : float
        Bias correlation rates (1/s; 0 for constant biases).
    qc : ndarray, shape (n, n)
        ``Q' = G Q G^T`` (per second; zero on the fix-error rows).
    unmod : ndarray, shape (4,)
        Variances of the scale factor and the misalignment of the gyros, then of the accelerometers
        (dimensionless); their block's variance increments (:func:`unmodelled_increment_into`, body axes) enter
        ``Q'`` as ``C diag(d) C^T / T`` on the attitude and the velocity rows.
    origin : ndarray, shape (6,)
        The integrals' origins (gyros, accelerometers), updated in place.
    p : ndarray, shape (n, n)
        Covariance, replaced by ``Phi P Phi^T + Q_d`` (symmetrised).
    phi_acc : ndarray, shape (n, n)
        Product of the transitions so far, replaced by ``Phi phi_acc``.
    x : ndarray, shape (n,)
        Error state, replaced by ``Phi x`` when ``open_loop``; in closed loop only its fix-error entries
        (not fed back) are carried.
    open_loop : bool
        Whether the error state is carried (no feedback).
    fix_tau, fix_var : ndarray, shape (n_fix,)
        Correlation times (s) and stationary variances of the fix-error states.
    f_ref : ndarray, shape (3,)
        The specific-force reference the running velocity integral is taken less of (m/s^2, body).
    sens_kind, sens_row, sens_col : ndarray of int64, shape (n - 15 - n_fix,)
        Per sensor-error state: 0 gyro, 1 accelerometer; the element of the error matrix.

    Returns
    -------
    phi : ndarray, shape (n, n)
        The block's transition matrix.

    Notes
    -----
    Mean state over the block as in :meth:`sins_sim.navigation.ekf.AidedNavigator`: latitude, height and
    velocity averaged, ``C_nb`` of the normalised sign-aligned mean quaternion, and the specific force from
    the velocity change, ``f^n = (v_1 - v_0)/T + (2 omega_ie + omega_en) x v - g^n`` (the navigation
    equation, Titterton & Weston 2004 ch. 3, solved for ``f``).
    """
    n = p.shape[0]
    lat = 0.5 * (start[0] + end[0])
    h = 0.5 * (start[1] + end[1])
    vel = np.empty(3)
    for i in range(3):
        vel[i] = 0.5 * (start[2 + i] + end[2 + i])
    dot = 0.0
    for i in range(4):
        dot += start[5 + i] * end[5 + i]
    sgn = 1.0 if dot >= 0.0 else -1.0
    qm = np.empty(4)
    nq = 0.0
    for i in range(4):
        qm[i] = start[5 + i] + sgn * end[5 + i]
        nq += qm[i] * qm[i]
    nq = math.sqrt(nq)
    for i in range(4):
        qm[i] /= nq
    c = np.empty((3, 3))
    quat_to_dcm(qm, c)
    r_n, r_e = radii(lat)
    w0 = 2.0 * _OMEGA * math.cos(lat) + vel[1] / (r_e + h)
    w1 = -vel[0] / (r_n + h)
    w2 = 2.0 * -_OMEGA * math.sin(lat) + -vel[1] * math.tan(lat) / (r_e + h)
    f_n = np.empty(3)
    f_n[0] = (end[2] - start[2]) / t + (w1 * vel[2] - w2 * vel[1])
    f_n[1] = (end[3] - start[3]) / t + (w2 * vel[0] - w0 * vel[2])
    f_n[2] = (end[4] - start[4]) / t + (w0 * vel[1] - w1 * vel[0])
    f_n[2] -= gravity_down(lat, h)
    f = np.empty((n, n))
    error_dynamics_into(lat, h, vel, c, f_n, inv_tau_g, inv_tau_a, f)
    n_fix = fix_tau.shape[0]
    for k in range(sens_kind.shape[0]):      # the sensor-error states' columns, -C[:, row] x_col
        i, j = sens_row[k], sens_col[k]
        if sens_kind[k] == 0:
            xj = (end[9 + j] - start[9 + j]) / t
            r0 = 6
        else:
            xj = (end[12 + j] - start[12 + j]) / t + f_ref[j]
            r0 = 3
        for r in range(3):
            f[r0 + r, 15 + n_fix + k] = -c[r, i] * xj
    m = qc.copy()
    d = np.empty(3)
    for blk in range(2):
        if unmod[2 * blk] == 0.0 and unmod[2 * blk + 1] == 0.0:
            continue
        unmodelled_increment_into(start[9 + 3 * blk:12 + 3 * blk], end[9 + 3 * blk:12 + 3 * blk],
                                  origin[3 * blk:3 * blk + 3], unmod[2 * blk], unmod[2 * blk + 1], d)
        r0 = 6 if blk == 0 else 3          # gyros: attitude rows; accelerometers: velocity rows
        for i in range(3):
            for j in range(3):
                a = 0.0
                for k in range(3):
                    a += c[i, k] * d[k] * c[j, k]
                m[r0 + i, r0 + j] += a / t
    # Phi = sum (F T)^k / k!
    ft = f * t
    term = np.eye(n)
    phi = np.eye(n)
    for k in range(1, SERIES_ORDER + 1):
        term = np.dot(term, ft) / k
        phi += term
    # Q_d = sum M_k T^(k+1) / (k+1)!, M_0 = Q', M_k = F M_(k-1) + M_(k-1) F^T
    q_d = m * t
    coef = t
    for k in range(1, SERIES_ORDER + 1):
        fm = np.dot(f, m)
        m = fm + fm.T
        coef *= t / (k + 1)
        q_d += m * coef
    # the fix-error states: F and Q' are zero on their rows, so the series left them I and 0; their exact model
    for i in range(n_fix):
        k = 15 + i
        phi[k, k] = math.exp(-t / fix_tau[i])
        q_d[k, k] = fix_var[i] * -math.expm1(-2.0 * t / fix_tau[i])
    pn = np.dot(np.dot(phi, p), phi.T) + 0.5 * (q_d + q_d.T)
    for i in range(n):
        for j in range(n):
            p[i, j] = 0.5 * (pn[i, j] + pn[j, i])
    phi_acc[:, :] = np.dot(phi, phi_acc)
    if open_loop:
        x[:] = np.dot(phi, x)
    else:
        for k in range(15, 15 + n_fix):
            x[k] *= phi[k, k]
    return phi


@jit
def joseph_update(p, x, h, r, dz):
    """One stacked measurement update in Joseph form, in place on ``p`` and ``x``.

    Parameters
    ----------
    p : ndarray, shape (n, n)
        Covariance (replaced, symmetrised).
    x : ndarray, shape (n,)
        Error state (replaced by ``x + K nu``).
    h : ndarray, shape (m, n)
        Measurement matrix.
    r : ndarray, shape (m, m)
        Measurement noise covariance.
    dz : ndarray, shape (m,)
        ``h(x_c) - z``.

    Returns
    -------
    nu : ndarray, shape (m,)
        The innovation ``dz - H x`` (with the ``x`` before the update).
    s : ndarray, shape (m, m)
        Its covariance ``H P H^T + R`` (symmetrised).
    """
    n = p.shape[0]
    nu = dz - np.dot(h, x)
    ph = np.dot(p, h.T)
    s = np.dot(h, ph) + r
    s = 0.5 * (s + s.T)
    gain = np.linalg.solve(s, ph.T).T.copy()
    x += np.dot(gain, nu)
    ikh = np.eye(n) - np.dot(gain, h)
    pn = np.dot(np.dot(ikh, p), ikh.T) + np.dot(np.dot(gain, r), gain.T)
    for i in range(n):
        for j in range(n):
            p[i, j] = 0.5 * (pn[i, j] + pn[j, i])
    return nu, s


@jit
def block_nis(s, nu, sizes):
    """``nu_b^T S_b^-1 nu_b`` of each diagonal block ``b`` of sizes ``sizes`` (the normalised innovation
    squared of each measurement of a stacked update; Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4)."""
    out = np.empty(sizes.shape[0])
    k0 = 0
    for b in range(sizes.shape[0]):
        d = sizes[b]
        sb = np.ascontiguousarray(s[k0:k0 + d, k0:k0 + d])
        nb = np.ascontiguousarray(nu[k0:k0 + d])
        out[b] = np.dot(nb, np.linalg.solve(sb, nb))
        k0 += d
    return out


@jit
def correct_rows(lat, lon, h, vel, q, dx):
    """Remove error states from solution rows, in place: per row ``i`` (``dx`` row ``i``, or its only row)::

        lat -= dr_N / (R_N + h),  lon -= dr_E / ((R_E + h) cos lat)  (wrapped),  h += dr_D,
        v -= dv,                  q <- q(-psi) (x) q  (normalised)

    the inverse of the state's definition (:meth:`StrapdownNavigator.apply_correction`), radii at the row's
    latitude before the correction.
    """
    one = dx.shape[0] == 1
    rv = np.empty(3)
    dq = np.empty(4)
    qi = np.empty(4)
    for i in range(lat.shape[0]):
        d = dx[0] if one else dx[i]
        r_n, r_e = radii(lat[i])
        la = lat[i]
        lat[i] = la - d[0] / (r_n + h[i])
        lon[i] = (lon[i] - d[1] / ((r_e + h[i]) * math.cos(la)) + math.pi) % (2.0 * math.pi) - math.pi
        h[i] = h[i] + d[2]
        for k in range(3):
            vel[i, k] -= d[3 + k]
            rv[k] = -d[6 + k]
        rotvec_to_quat(rv, dq)
        for k in range(4):
            qi[k] = q[i, k]
        quat_mul(dq, qi, qi)
        nq = math.sqrt(qi[0] * qi[0] + qi[1] * qi[1] + qi[2] * qi[2] + qi[3] * qi[3])
        for k in range(4):
            q[i, k] = qi[k] / nq


@jit
def correct_state(st, dx):
    """The feedback on a navigator's kernel state ``st`` (layout ``sins_sim._kernels.strapdown.ST_*``, vertical
    channel free), in place: :meth:`sins_sim.navigation.strapdown.StrapdownNavigator.apply_correction` with the
    error state's first nine entries (the same expressions; the previous update's latitude, height and velocity
    that the next update extrapolates from corrected alike)."""
    r_n, r_e = radii(st[ksd.ST_LAT])
    lat, h = st[ksd.ST_LAT], st[ksd.ST_H]
    dlat = dx[0] / (r_n + h)
    dlon = dx[1] / ((r_e + h) * math.cos(lat))
    st[ksd.ST_LAT] -= dlat
    st[ksd.ST_PREV_LAT] -= dlat
    st[ksd.ST_LON] = (st[ksd.ST_LON] - dlon + math.pi) % (2.0 * math.pi) - math.pi
    st[ksd.ST_H] += dx[2]
    st[ksd.ST_PREV_H] += dx[2]
    for k in range(3):
        st[ksd.ST_V + k] -= dx[3 + k]
        st[ksd.ST_PREV_V + k] -= dx[3 + k]
    rv = np.empty(3)
    for k in range(3):
        rv[k] = -dx[6 + k]
    dq = np.empty(4)
    rotvec_to_quat(rv, dq)
    qi = np.empty(4)
    for k in range(4):
        qi[k] = st[ksd.ST_Q + k]
    q = np.empty(4)
    quat_mul(dq, qi, q)
    nq = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for k in range(4):
        st[ksd.ST_Q + k] = q[k] / nq


@jit
def interpolate_row(t, lat, lon, h, vel, q, t_v, out):
    """The stored solution rows interpolated linearly to ``t_v`` into ``out`` = ``(lat, lon, h, v_N, v_E, v_D,
    q0..q3)``: the bracketing rows (clamped to the stored span), the longitude difference wrapped, the quaternions
    sign-aligned and the result normalised (:meth:`sins_sim.navigation.aided._History.state_at_reference`)."""
    n = t.shape[0]
    i = min(max(np.searchsorted(t, t_v) - 1, 0), max(n - 2, 0))
    if n == 1:
        w = 0.0
        j = 0
    else:
        j = i + 1
        w = min(max((t_v - t[i]) / (t[j] - t[i]), 0.0), 1.0)
    dlon = (lon[j] - lon[i] + math.pi) % (2.0 * math.pi) - math.pi
    out[0] = (1.0 - w) * lat[i] + w * lat[j]
    out[1] = lon[i] + w * dlon
    out[2] = (1.0 - w) * h[i] + w * h[j]
    for k in range(3):
        out[3 + k] = (1.0 - w) * vel[i, k] + w * vel[j, k]
    dot = 0.0
    for k in range(4):
        dot += q[i, k] * q[j, k]
    sgn = 1.0 if dot >= 0.0 else -1.0
    nq = 0.0
    for k in range(4):
        out[6 + k] = (1.0 - w) * q[i, k] + w * sgn * q[j, k]
        nq += out[6 + k] * out[6 + k]
    nq = math.sqrt(nq)
    for k in range(4):
        out[6 + k] /= nq


@jit
def gnss_measurement(lat, lon, h, vel, q, bg, rate, lever, z_lat, z_lon, z_h, z_v, use_pos, use_vel, h_out, dz_out):
    """``H`` and ``dz = h(x_c) - z`` of a GNSS position and/or velocity fix at a point ``lever`` (body, m) from
    the IMU, written into the rows of ``h_out`` (zeroed first) and ``dz_out``: position first when used.

    The models of :class:`sins_sim.navigation.ekf.Position` (Groves 2013, eq. 14.110)::

        dz = ((lat - z_lat)(R_N + h), wrap(lon - z_lon)(R_E + h) cos lat, -(h - z_h)) + C l
        H  = [I, 0, -[(C l) x], 0, 0]

    and :class:`sins_sim.navigation.ekf.Velocity` (eq. 14.113-14.114), ``w = rate - bg``::

        dz = v + C (w x l) - omega_ie x (C l) - z_v
        H  = [[C l x] d omega_ie / d dr_N, I, -[(C (w x l)) x] + [omega_ie x][(C l) x], C [l x], 0]
    """
    h_out[:, :] = 0.0
    c = np.empty((3, 3))
    quat_to_dcm(q, c)
    cl = np.empty(3)
    for i in range(3):
        cl[i] = c[i, 0] * lever[0] + c[i, 1] * lever[1] + c[i, 2] * lever[2]
    r_n, r_e = radii(lat)
    row = 0
    if use_pos:
        dz_out[0] = (lat - z_lat) * (r_n + h) + cl[0]
        dz_out[1] = ((lon - z_lon + math.pi) % (2.0 * math.pi) - math.pi) * (r_e + h) * math.cos(lat) + cl[1]
        dz_out[2] = -(h - z_h) + cl[2]
        for i in range(3):
            h_out[i, i] = 1.0
        _skew_into(cl[0], cl[1], cl[2], h_out, 0, 6, -1.0)
        row = 3
    if use_vel:
        for i in range(3):
            h_out[row + i, 3 + i] = 1.0
        if lever[0] != 0.0 or lever[1] != 0.0 or lever[2] != 0.0:
            w0, w1, w2 = rate[0] - bg[0], rate[1] - bg[1], rate[2] - bg[2]
            wl0 = w1 * lever[2] - w2 * lever[1]
            wl1 = w2 * lever[0] - w0 * lever[2]
            wl2 = w0 * lever[1] - w1 * lever[0]
            cwl = np.empty(3)
            for i in range(3):
                cwl[i] = c[i, 0] * wl0 + c[i, 1] * wl1 + c[i, 2] * wl2
            e0, e2 = _OMEGA * math.cos(lat), _OMEGA * -math.sin(lat)
            # omega_ie x (C l), omega_ie = (e0, 0, e2)
            ex0 = -e2 * cl[1]
            ex1 = e2 * cl[0] - e0 * cl[2]
            ex2 = e0 * cl[1]
            dz_out[row] = vel[0] + cwl[0] - ex0 - z_v[0]
            dz_out[row + 1] = vel[1] + cwl[1] - ex1 - z_v[1]
            dz_out[row + 2] = vel[2] + cwl[2] - ex2 - z_v[2]
            _skew_into(cwl[0], cwl[1], cwl[2], h_out, row, 6, -1.0)
            sw = np.zeros((3, 3))
            _skew_into(e0, 0.0, e2, sw, 0, 0, 1.0)
            sc = np.zeros((3, 3))
            _skew_into(cl[0], cl[1], cl[2], sc, 0, 0, 1.0)
            sl = np.zeros((3, 3))
            _skew_into(lever[0], lever[1], lever[2], sl, 0, 0, 1.0)
            d0, d2 = _OMEGA * -math.sin(lat) / (r_n + h), _OMEGA * -math.cos(lat) / (r_n + h)
            for i in range(3):
                h_out[row + i, 0] = sc[i, 0] * d0 + sc[i, 2] * d2
                for j in range(3):
                    a = 0.0
                    b = 0.0
                    for k in range(3):
                        a += sw[i, k] * sc[k, j]
                        b += c[i, k] * sl[k, j]
                    h_out[row + i, 6 + j] += a
                    h_out[row + i, 9 + j] = b
        else:
            for i in range(3):
                dz_out[row + i] = vel[i] - z_v[i]
