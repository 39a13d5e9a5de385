"""The GNSS-aided run's epochs in one compiled call per chunk (issue 37, item 7).

:func:`aided_chunk` does for every navigation update and every epoch of a chunk of increments what
:class:`sins_sim.navigation.aided.AidedRun` does in Python (its reference path, which the tests hold this one to):
the aided navigator's strapdown pieces between epochs with the bias estimates removed, the covariance propagation
in blocks (:func:`sins_sim._kernels.ekf.propagate_block_states`, with the bias priors carried alongside), the
solution rows kept for the fixes' latency and the raw gyro sum of each navigation update (the lever arm's rate),
and at each epoch the flush of the propagation, the fixes' ``H`` and ``dz`` at their time of validity
(:func:`sins_sim._kernels.ekf.gnss_measurement`), the Joseph update (:func:`sins_sim._kernels.ekf.joseph_update`),
each measurement's normalised innovation squared, the feedback into the navigator, the biases, the estimated
scale factors and misalignments (when the filter has those states; the increments are then corrected by
``(I + K_est)^-1`` after the biases and the blocks carry the states' columns) and the kept rows, and the epoch's
records. The same kernels in the same order on the same values, so the results are the reference
path's to the last bit (tested); what goes is the Python glue per update (about 0.2 ms per epoch and filter).

The run's state lives in arrays the caller owns and this call updates in place (their layouts below); nothing
here depends on the number of error states ``n`` beyond ``p.shape[0]`` and the sensor-error states' table.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels import ekf as kekf
from sins_sim._kernels import strapdown as ksd
from sins_sim._kernels._config import jit

__all__ = ["aided_chunk", "INT_BLOCK_N", "INT_HIST_N", "INT_HAVE_FREF", "INT_STATUS", "INT_SIZE", "HIST_COLS",
           "STATUS_OK", "STATUS_NOT_FINITE"]

#: Layout of the run's integer state (``ints``): navigation updates since the last block end, kept solution
#: rows, whether the unmodelled errors' specific-force reference is set, and the call's status.
INT_BLOCK_N, INT_HIST_N, INT_HAVE_FREF, INT_STATUS, INT_SIZE = 0, 1, 2, 3, 4
#: Columns of a kept solution row: ``t, lat, lon, h, v_N, v_E, v_D, q0..q3``.
HIST_COLS = 11
STATUS_OK, STATUS_NOT_FINITE = 0, 1


@jit
def _snapshot(st, acc, out):
    """``(lat, h, v, q)`` of the navigator's state and the running integrals (a block end)."""
    out[0] = st[ksd.ST_LAT]
    out[1] = st[ksd.ST_H]
    for k in range(3):
        out[2 + k] = st[ksd.ST_V + k]
    for k in range(4):
        out[5 + k] = st[ksd.ST_Q + k]
    for k in range(6):
        out[9 + k] = acc[k]


@jit
def _bias_prior_after(var, t, sig, tau, rw):
    """:meth:`sins_sim.navigation.ekf.ImuNoise.bias_variance_after` in place (gyros, then accelerometers)."""
    for b in range(2):
        if math.isfinite(tau[b]):
            phi2 = math.exp(-2.0 * t / tau[b])
            for i in range(3):
                var[3 * b + i] = phi2 * var[3 * b + i] + sig[b] * sig[b] * (1.0 - phi2)
        else:
            for i in range(3):
                var[3 * b + i] = var[3 * b + i] + rw[b] * rw[b] * t


@jit
def _block(start, end, n_upd, big_t, inv_tau, qc, unmod, origin, p, phi_acc, x, fix_tau, fix_var, prior, bsig, btau,
           brw, f_ref, sens):
    """One propagation block (:meth:`sins_sim.navigation.ekf.AidedNavigator._propagate_block`, closed loop; with no
    sensor-error states :func:`kekf.propagate_block_states` is that method's :func:`kekf.propagate_block`)."""
    t = n_upd * big_t
    kekf.propagate_block_states(start, end, t, inv_tau[0], inv_tau[1], qc, unmod, origin, p, phi_acc, x, False,
                                fix_tau, fix_var, f_ref, sens[0], sens[1], sens[2])
    _bias_prior_after(prior, t, bsig, btau, brw)
    for k in range(start.shape[0]):
        start[k] = end[k]


@jit
def _navigate(dth, dvel, a, n_upd, done, t0, dt, n_sub, ccoef, scoef, gains, st, bg, ba, has_unmod, ints, f_ref,
              acc, ring, hist, keep_rows, n_prop, big_t, inv_tau, qc, unmod, origin, p, phi_acc, x, fix_tau, fix_var,
              prior, bsig, btau, brw, block_start, sens, k_inv):
    """Navigate the ``n_upd`` navigation updates starting at sample ``a`` of the chunk (the updates ``done + 1``
    on), as :meth:`~sins_sim.navigation.aided.AidedRun._advance` with
    :meth:`~sins_sim.navigation.ekf.AidedNavigator._process_checked`: one strapdown piece with the current bias
    estimates removed (and the estimated scale factors and misalignments, ``(I + K_est)^-1``, with those states),
    the running integrals restarted at the piece (as the reference's per-piece call), the kept rows, the updates'
    raw gyro sums and the block ends."""
    if n_upd <= 0:
        return
    n = n_upd * n_sub
    th = dth[a:a + n]
    dv = dvel[a:a + n]
    th_c = np.empty((n, 3))
    dv_c = np.empty((n, 3))
    bg_dt = np.empty(3)
    ba_dt = np.empty(3)
    for i in range(3):
        bg_dt[i] = bg[i] * dt
        ba_dt[i] = ba[i] * dt
    for k in range(n):
        for i in range(3):
            th_c[k, i] = th[k, i] - bg_dt[i]
            dv_c[k, i] = dv[k, i] - ba_dt[i]
    if sens[0].shape[0] > 0:
        kekf.triad_corrected(th_c, k_inv[0])
        kekf.triad_corrected(dv_c, k_inv[1])
    out = np.empty((n_upd, ksd.OUT_SIZE))
    ksd.strapdown_run(th_c, dv_c, np.empty(0), dt, n_sub, ccoef, scoef, False, gains[0], gains[1], gains[2], st, out)
    accs = np.zeros((n_upd, 6))
    if has_unmod:
        if ints[INT_HAVE_FREF] == 0:
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for k in range(n):
                s0 += dv[k, 0]
                s1 += dv[k, 1]
                s2 += dv[k, 2]
            f_ref[0] = s0 / (n * dt)
            f_ref[1] = s1 / (n * dt)
            f_ref[2] = s2 / (n * dt)
            ints[INT_HAVE_FREF] = 1
        kekf.running_integrals(th, dv, acc, f_ref, big_t, n_sub, 0, accs)
        for i in range(6):
            acc[i] = accs[n_upd - 1, i]
    # the kept rows: compacted to the last keep_rows when full (the latency's interpolation reads only those)
    cap = hist.shape[0]
    hn = ints[INT_HIST_N]
    for k in range(n_upd):
        if hn == cap:
            for r in range(keep_rows):
                for c in range(HIST_COLS):
                    hist[r, c] = hist[cap - keep_rows + r, c]
            hn = keep_rows
        hist[hn, 0] = t0 + (done + 1 + k) * big_t
        hist[hn, 1] = out[k, ksd.OUT_LAT]
        hist[hn, 2] = out[k, ksd.OUT_LON]
        hist[hn, 3] = out[k, ksd.OUT_H]
        for i in range(3):
            hist[hn, 4 + i] = out[k, ksd.OUT_V + i]
        for i in range(4):
            hist[hn, 7 + i] = out[k, ksd.OUT_Q + i]
        hn += 1
    ints[INT_HIST_N] = hn
    # each update's raw gyro sum (kekf.update_sums), at ring row (update index) % rows
    nr = ring.shape[0]
    for k in range(n_upd):
        r = (done + 1 + k) % nr
        for i in range(3):
            s = 0.0
            for m in range(n_sub):
                s += th[k * n_sub + m, i]
            ring[r, i] = s
    # block ends: the updates with (block_n + k + 1) % n_prop == 0
    row = np.empty(15)
    for k in range(n_upd):
        ints[INT_BLOCK_N] += 1
        if ints[INT_BLOCK_N] == n_prop:
            row[0] = out[k, ksd.OUT_LAT]
            row[1] = out[k, ksd.OUT_H]
            for i in range(3):
                row[2 + i] = out[k, ksd.OUT_V + i]
            for i in range(4):
                row[5 + i] = out[k, ksd.OUT_Q + i]
            for i in range(6):
                row[9 + i] = accs[k, i]
            _block(block_start, row, n_prop, big_t, inv_tau, qc, unmod, origin, p, phi_acc, x, fix_tau, fix_var,
                   prior, bsig, btau, brw, f_ref, sens)
            ints[INT_BLOCK_N] = 0


@jit
def aided_chunk(dth, dvel, n_go, done0, ev_j, ev_ptr, ev_fix, f_tv, f_lat, f_lon, f_h, f_v, t0, dt, n_sub,
                big_t, n_prop, compensate, use_pos, use_vel, has_lever, lever, r_pos, r_vel, gm_pos, gm_vel,
                keep_rows, ccoef, scoef, gains, st, bg, ba, has_unmod, f_ref, acc, origin, unmod, qc, inv_tau, fix_tau,
                fix_var, prior, bsig, btau, brw, sens, k_est, k_inv, p, x, phi_acc, block_start, last_corr, ints,
                hist, ring,
                r_t, r_nav, r_bg, r_ba, r_sig, r_upd, r_tv, r_phi, r_pp, r_pu, r_corr,
                i_t, i_tv, i_name, i_nu, i_sig, i_nis):
    """A chunk of a closed-loop aided run: navigate ``n_go`` navigation updates from update ``done0`` and handle
    the epochs ``ev_j`` among them, in place (module docstring).

    Parameters
    ----------
    dth, dvel : ndarray, shape (N, 3)
        Raw increments from update ``done0`` on (``N >= n_go n_sub``).
    n_go : int
        Navigation updates to navigate.
    done0 : int
        Navigation updates done before.
    ev_j : ndarray of int64, shape (K,)
        The epochs (navigation update indices, ascending, in ``[done0, done0 + n_go]``).
    ev_ptr, ev_fix : ndarray of int64
        The fixes applied at epoch ``k``: ``ev_fix[ev_ptr[k]:ev_ptr[k + 1]]`` (indices into ``f_*``).
    f_tv, f_lat, f_lon, f_h : ndarray, shape (M,)
        The fixes' time of validity (s) and position.
    f_v : ndarray, shape (M, 3)
        Their velocity (m/s, NED).
    t0, dt, big_t : float
        The record's start, the increment period and the navigation update period (s).
    n_sub, n_prop : int
        Increments per navigation update; navigation updates per propagation block.
    compensate : bool
        Fixes against the solution at their time of validity (else at the epoch).
    use_pos, use_vel, has_lever : bool
        Which measurements; whether the lever arm is not zero.
    lever : ndarray, shape (3,)
        The antenna's lever arm (body, m).
    r_pos, r_vel : ndarray, shape (3, 3)
        The measurements' ``R``.
    gm_pos, gm_vel : int
        First column of the fix-error states of each measurement, or -1.
    keep_rows : int
        Solution rows the latency needs (at least ``floor(keep_s / big_t) + 1``); ``hist`` has more.
    ccoef, scoef, gains, st
        The navigator's coning and sculling coefficients, vertical gains and kernel state (in place).
    bg, ba : ndarray, shape (3,)
        Bias estimates (in place).
    has_unmod : bool
        Whether the unmodelled errors' running integrals are kept.
    f_ref, acc, origin : ndarray
        Their specific-force reference, the integrals at the last update, the origins (in place).
    unmod, qc, inv_tau, fix_tau, fix_var
        :func:`sins_sim._kernels.ekf.propagate_block`'s model arguments (``inv_tau`` gyro, accelerometer).
    prior, bsig, btau, brw : ndarray
        The bias priors carried (6, in place) and the noise's bias sigma, correlation time and random walk
        (gyro, accelerometer).
    sens : tuple of three ndarray of int64, shape (n_sens,)
        The sensor-error states' table (kind, row, column;
        :meth:`sins_sim.navigation.ekf.UnmodelledErrors.state_table`; empty without), the last ``n_sens`` states.
    k_est, k_inv : ndarray, shape (2, 3, 3)
        The estimated error matrices of the gyros and accelerometers and the inverses of ``I + K_est`` that correct
        the increments (in place).
    p, x, phi_acc, block_start, last_corr : ndarray
        Covariance, error state, transition product, the current block's start row, the last update's change of
        the state (in place).
    ints : ndarray of int64, shape (INT_SIZE,)
        Block count, kept rows, reference set, status (in place).
    hist : ndarray, shape (C, HIST_COLS)
        The kept solution rows (in place).
    ring : ndarray, shape (R, 3)
        Raw gyro sum of each navigation update at row ``update % R`` (in place).
    r_* : ndarray
        The epochs' records (written): time, ``(lat, lon, h, v, q)``, biases, sigma, updated, latest time of
        validity, ``Phi``, ``P`` before and after, the correction.
    i_* : ndarray
        The measurements' records (written): time, time of validity, name (0 position, 1 velocity), innovation,
        its sigma, NIS.

    Returns
    -------
    int
        Epochs handled (fewer than ``K`` only when a correction was not finite: ``ints[INT_STATUS]`` says so,
        the navigator left uncorrected at that epoch).
    """
    n = p.shape[0]
    n_sens = sens[0].shape[0]
    done = done0
    per_fix = 3 * (use_pos + use_vel)
    n_use = use_pos + use_vel
    m_rec = 0
    ints[INT_STATUS] = STATUS_OK
    snap = np.empty(15)
    zero3 = np.zeros(3)
    rate = np.empty(3)
    row = np.empty(10)
    rp = ring.shape[0]
    for e in range(ev_j.shape[0]):
        j = ev_j[e]
        _navigate(dth, dvel, (done - done0) * n_sub, j - done, done, t0, dt, n_sub, ccoef, scoef, gains, st, bg, ba,
                  has_unmod, ints, f_ref, acc, ring, hist, keep_rows, n_prop, big_t, inv_tau, qc, unmod, origin, p,
                  phi_acc, x, fix_tau, fix_var, prior, bsig, btau, brw, block_start, sens, k_inv)
        done = max(done, j)
        # the propagation up to now (AidedNavigator.propagate)
        if ints[INT_BLOCK_N] > 0:
            _snapshot(st, acc, snap)
            _block(block_start, snap, ints[INT_BLOCK_N], big_t, inv_tau, qc, unmod, origin, p, phi_acc, x, fix_tau,
                   fix_var, prior, bsig, btau, brw, f_ref, sens)
            ints[INT_BLOCK_N] = 0
        r_phi[e] = phi_acc
        phi_acc[:, :] = np.eye(n)
        r_pp[e] = p
        t_now = t0 + j * big_t
        f0, f1 = ev_ptr[e], ev_ptr[e + 1]
        k_fix = f1 - f0
        tv_max = np.nan
        for i in range(n):
            r_corr[e, i] = 0.0
        if k_fix > 0:
            hm = np.empty((k_fix * per_fix, n))
            dz = np.empty(k_fix * per_fix)
            rm = np.zeros((k_fix * per_fix, k_fix * per_fix))
            hn = ints[INT_HIST_N]
            for nf in range(k_fix):
                fi = ev_fix[f0 + nf]
                tv = f_tv[fi] if compensate else t_now
                kekf.interpolate_row(hist[:hn, 0], hist[:hn, 1], hist[:hn, 2], hist[:hn, 3], hist[:hn, 4:7],
                                     hist[:hn, 7:11], tv, row)
                if has_lever:
                    ju = max(1, int(round((tv - t0) / big_t)))
                    if ju > done:       # an update not navigated yet (a fix at the record's start): its increments
                        b = (ju - 1 - done + (done - done0)) * n_sub
                        for i in range(3):
                            s = 0.0
                            for m in range(n_sub):
                                if b + m < dth.shape[0]:
                                    s += dth[b + m, i]
                            rate[i] = s / big_t
                    else:
                        for i in range(3):
                            rate[i] = ring[ju % rp, i] / big_t
                else:
                    rate[:] = zero3
                r0 = nf * per_fix
                kekf.gnss_measurement(row[0], row[1], row[2], row[3:6], row[6:10], bg, rate, lever, f_lat[fi],
                                      f_lon[fi], f_h[fi], f_v[fi], use_pos, use_vel, hm[r0:r0 + per_fix],
                                      dz[r0:r0 + per_fix])
                rr = r0
                if use_pos:
                    if gm_pos >= 0:
                        for a in range(3):
                            hm[rr + a, gm_pos + a] = -1.0
                    rm[rr:rr + 3, rr:rr + 3] = r_pos
                    rr += 3
                if use_vel:
                    if gm_vel >= 0:
                        for a in range(3):
                            hm[rr + a, gm_vel + a] = -1.0
                    rm[rr:rr + 3, rr:rr + 3] = r_vel
                tv_max = f_tv[fi] if nf == 0 else max(tv_max, f_tv[fi])
            x_before = x.copy()
            nu, s_mat = kekf.joseph_update(p, x, hm, rm, dz)
            sizes = np.full(k_fix * n_use, 3, dtype=np.int64)
            nis = kekf.block_nis(s_mat, nu, sizes)
            for b in range(k_fix * n_use):
                nf = b // n_use
                i_t[m_rec] = t_now
                i_tv[m_rec] = f_tv[ev_fix[f0 + nf]]
                i_name[m_rec] = 0 if (use_pos and b % n_use == 0) else 1
                for a in range(3):
                    i_nu[m_rec, a] = nu[3 * b + a]
                    i_sig[m_rec, a] = math.sqrt(s_mat[3 * b + a, 3 * b + a])
                i_nis[m_rec] = nis[b]
                m_rec += 1
            for i in range(n):
                last_corr[i] = x[i] - x_before[i]
                r_corr[e, i] = last_corr[i]
            # the feedback (AidedNavigator._apply_feedback)
            tot = 0.0
            for i in range(15):
                tot += x[i]
            if not math.isfinite(tot):
                ints[INT_STATUS] = STATUS_NOT_FINITE
                return e
            kekf.correct_state(st, x)
            for i in range(3):
                bg[i] = bg[i] - x[9 + i]
                ba[i] = ba[i] - x[12 + i]
            for i in range(15):
                x[i] = 0.0
            if n_sens > 0:      # the scale factors and misalignments like the biases: K_est -= dK, then zeroed
                kekf.sensor_feedback(k_est, k_inv, x[n - n_sens:], sens[0], sens[1], sens[2])
                for i in range(n - n_sens, n):
                    x[i] = 0.0
            _snapshot(st, acc, block_start)
            hn = ints[INT_HIST_N]
            kekf.correct_rows(hist[:hn, 1], hist[:hn, 2], hist[:hn, 3], hist[:hn, 4:7], hist[:hn, 7:11],
                              last_corr[:15].reshape(1, 15))
        # the epoch's record (AidedNavigator.nav_state, sigma)
        r_t[e] = t_now
        r_nav[e, 0] = st[ksd.ST_LAT]
        r_nav[e, 1] = st[ksd.ST_LON]
        r_nav[e, 2] = st[ksd.ST_H]
        for i in range(3):
            r_nav[e, 3 + i] = st[ksd.ST_V + i]
        for i in range(4):
            r_nav[e, 6 + i] = st[ksd.ST_Q + i]
        for i in range(3):
            r_bg[e, i] = bg[i]
            r_ba[e, i] = ba[i]
        for i in range(n):
            r_sig[e, i] = math.sqrt(max(p[i, i], 0.0))
        r_upd[e] = k_fix > 0
        r_tv[e] = tv_max
        r_pu[e] = p
    _navigate(dth, dvel, (done - done0) * n_sub, done0 + n_go - done, done, t0, dt, n_sub, ccoef, scoef, gains, st,
              bg, ba, has_unmod, ints, f_ref, acc, ring, hist, keep_rows, n_prop, big_t, inv_tau, qc, unmod, origin, p,
              phi_acc, x, fix_tau, fix_var, prior, bsig, btau, brw, block_start, sens, k_inv)
    return ev_j.shape[0]


@jit
def rts_smooth(phi, p_pred, p_upd, corr, est, p_s):
    """The Rauch-Tung-Striebel recursion of :func:`sins_sim.navigation.aided.smooth` over all epochs in one call
    (its numpy form, :func:`sins_sim.navigation.aided._smooth_reference`, is the reference): backwards from the
    last epoch, ``C_k = P_k^+ Phi_(k+1)^T (P_(k+1)^-)^-1`` solved with ``P_(k+1)^-`` scaled to its correlation
    matrix, ``s_k = C_k (s_(k+1) + dx_(k+1))``, ``P_k^s = P_k^+ + C_k (P_(k+1)^s - P_(k+1)^-) C_k^T`` (symmetrised).

    ``est`` (K, n) zeros and ``p_s`` (K, n, n) a copy of ``p_upd`` on entry; both written in place."""
    k_ep = phi.shape[0]
    n = phi.shape[1]
    d = np.empty(n)
    for k in range(k_ep - 2, -1, -1):
        pp = p_pred[k + 1]
        for i in range(n):
            d[i] = math.sqrt(pp[i, i])
        b = np.dot(phi[k + 1], p_upd[k])
        ps = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                b[i, j] = b[i, j] / d[i]
                ps[i, j] = pp[i, j] / (d[i] * d[j])
        g = np.linalg.solve(ps, b)
        for i in range(n):
            for j in range(n):
                g[i, j] = g[i, j] / d[i]
        gain = g.T.copy()
        est[k] = np.dot(gain, est[k + 1] + corr[k + 1])
        p = p_upd[k] + np.dot(np.dot(gain, p_s[k + 1] - pp), gain.T)
        for i in range(n):
            for j in range(n):
                p_s[k, i, j] = 0.5 * (p[i, j] + p[j, i])
