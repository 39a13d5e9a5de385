"""The three suspensions and the sensor block stepped together (reference-model.md, "The block as a body").

The block's relative motion (``sins_sim.models.block``: linear, base-excited, exact step for inputs linear in
time) and the three suspensions (``plant_exact``: eq. 2, 9, 10, 14, the exact-oscillator integrator) are
advanced one plant step at a time, coupled both ways:

- the suspensions' torques ``T_i = -J_g,i w0_i^2 (delta_i + F_i + k5_i V_i)`` load the block (``-T_i u_i``);
- the block's rotation about each gyro's input axis adds to the SINS angle that drives that suspension.

Coupling scheme (a staggered, explicit partitioned step; Felippa, Park and Farhat 2001, "Partitioned analysis of
coupled mechanical systems", CMAME 190, sec. 4): over step ``n`` the torque's smooth part
``-J_g w0^2 (delta + F)`` is extrapolated by the cubic through ``t_{n-1} .. t_{n-4}`` (fourth order; from one
step back, so that the block's step does not wait for the suspensions' step that ends at ``t_n`` and the
processor overlaps the two) and the piezo
part ``-J_g w0^2 k5 V_n`` is held, as the suspension holds its drive (zero-order hold); the block advances
exactly under that input; its relative angle and rate about ``u_i`` at ``t_{n+1}`` extend the suspension's
Hermite interpolant of the SINS angle (``plant_exact._forcing``) by the relative part, which is linear in the
samples, so ``q0 += -p0_rel`` and ``q1 += -p1_rel``; then each suspension takes its step with exactly the
arithmetic of ``plant_exact.run_three``. With the relative motion identically zero (the rigid block) the
suspensions get bit for bit the numbers of ``run_three``.

The coupling's own error is that of the torque extrapolation. With a linear extrapolation from ``t_{n-1}, t_n``
(second order) the block's response at 386 Hz and 72 kHz was off by 4.7e-4 (``5/12 (w h)^2``, halving ``h``
quartered it), and near resonance the suspension's amplitude by as much, through the coupled frequency; the
quadratic through ``t_{n-2} .. t_n`` left 2.2e-5 (third order); the cubic from one step back leaves
``(w h)^4``-order errors (``tests/test_block.py`` states the measured figures against the frequency-domain
solution of the coupled linear system).

Block state (``bstate``, float64[B_SIZE]): ``z`` (12: translation, rotation vector, and their rates, relative to
the chassis), the relative angle and rate about each input axis at ``t_n``, and the torques' smooth parts at
``t_n .. t_{n-4}``. All zeros is rest.
"""

from __future__ import annotations

import numpy as np

from sins_sim._kernels import chain as kchain
from sins_sim._kernels import plant_exact as kexact
from sins_sim._kernels._config import jit

B_Z = 0  # z, 12 values
B_REL = 12  # relative angle about u_i at t_n, 3 values
B_RELR = 15  # relative rate about u_i at t_n, 3 values
B_SM = 18  # smooth torque parts at t_n, t_{n-1}, ..., t_{n-4}: 5 rows of 3 values
N_HIST = 5
B_SIZE = 33


@jit
def chassis_input(ang, rate, phi0, rate0, ih, ih2, lin0, lin1, gch, out_c):
    """The chassis' contribution to the block's step, for every step of a chunk (no dependency between steps).

    ``ang, rate``: (3, N) chassis angle and rate about block axes x, y, z at ``t_{n+1}``; ``phi0, rate0``: (3,)
    at the chunk's start. The chassis angular acceleration over a step is the second derivative of the same cubic
    Hermite interpolant the suspensions use, ``P0 + P1 tau`` (``plant_exact`` module docstring); ``lin0, lin1``:
    (3, N) the chassis linear acceleration at the c.g. over each step, ``a0 + a1 tau``. ``gch``: (12, 12),
    ``[F0[:, :6], F1[:, :6]]`` (``BlockParams.discrete``); ``out_c``: (N, 12), step-major like every block array
    here (one cache line per step, not twelve streams), ``= gch @ (a0, P0, a1, P1)``
    (an input that is exactly zero, a chassis at rest or no linear vibration, is skipped).
    """
    n = ang.shape[1]
    gt = np.ascontiguousarray(gch.T)  # column j of gch as a row: one AXPY per input
    u = np.empty(12)
    pa = phi0.copy()
    ra = rate0.copy()
    acc = np.empty(12)
    for k in range(n):
        for i in range(3):
            slope = (ang[i, k] - pa[i]) * ih
            u[3 + i] = (6.0 * slope - 4.0 * ra[i] - 2.0 * rate[i, k]) * ih
            u[9 + i] = 6.0 * (ra[i] + rate[i, k] - 2.0 * slope) * ih2
            pa[i] = ang[i, k]
            ra[i] = rate[i, k]
            u[i] = lin0[i, k]
            u[6 + i] = lin1[i, k]
        for r in range(12):
            acc[r] = 0.0
        for j in range(12):
            uj = u[j]
            if uj != 0.0:
                for r in range(12):
                    acc[r] += gt[j, r] * uj
        for r in range(12):
            out_c[k, r] = acc[r]


@jit(inline="always")
def _relative(umat, zn, pos, a):
    """Relative angle and rate of the block about input axis ``a``: ``u_a . theta``, ``u_a . theta'``
    (``pos``: where theta and theta' sit in the chained state)."""
    r = umat[a, 0] * zn[pos[0]] + umat[a, 1] * zn[pos[1]] + umat[a, 2] * zn[pos[2]]
    rr = umat[a, 0] * zn[pos[3]] + umat[a, 1] * zn[pos[4]] + umat[a, 2] * zn[pos[5]]
    return r, rr


@jit(inline="always")
def _lane_step(k, lane, q0, q1, rule, hyst, stack):
    xb, vb, fb, rb, rare = kexact._lane_trial(k, lane, q0, q1)
    if rare:
        return kexact._lane_change(k, lane, xb, vb, fb, rb, q0, q1, rule, hyst, stack)
    return kexact._lane_commit(k, lane, xb, vb, fb, rb)


@jit
def run_three_block(j0, j1, q0s, q1s, cs, rules, state, hyst, stack, gain, umat, phit, tt, idx, pos, cin, bstate,
                    out_delta, out_z):
    """The three suspensions and the block over steps ``j0 .. j1 - 1`` (module docstring).

    Suspension arguments as ``plant_exact.run_three`` (``q0s, q1s``: (3, N), the forcing from the chassis and
    the drive, ``plant_exact._forcing``). The block: only the ``nc`` states the torques reach are chained
    (``idx``: their rows of ``z``; all 12, or the rotation's 6 when the elastic centre is at the c.g. and
    translation cannot feel the gyros), with ``phit`` (nc, nc) the transposed step matrix of those states,
    ``tt`` (nh, 3, nc) the transposed input matrices of the torques' smooth parts at ``t_{n-1} .. t_{n-nh}``
    (the extrapolation folded in, ``BlockStep``), ``pos`` (6,) where ``theta, theta'`` sit among them,
    ``gain`` (3,) ``-J_g w0^2``, ``cin`` (N, 12) the chassis and piezo inputs of every step. ``out_z`` (N, 12):
    the chained rows at ``t_{n+1}`` are written (the others by :func:`propagate_rest`).
    """
    ka = kexact._lane_constants(cs, 0)
    kb = kexact._lane_constants(cs, 1)
    kc = kexact._lane_constants(cs, 2)
    la = kexact._lane_load(state, 0, cs, rules[0], hyst[0], stack[0])
    lb = kexact._lane_load(state, 1, cs, rules[1], hyst[1], stack[1])
    lc = kexact._lane_load(state, 2, cs, rules[2], hyst[2], stack[2])
    h = ka[kexact.C_H]
    ih = 1.0 / h
    ih2 = ih * ih
    nc = idx.shape[0]
    z = np.empty(nc)
    for r in range(nc):
        z[r] = bstate[B_Z + idx[r]]
    zn = np.empty(nc)
    nh = tt.shape[0]  # history values used: t_{n-1} .. t_{n-nh}
    sm = np.empty((N_HIST, 3))  # smooth torque parts at t_n, t_{n-1}, ... (rows), per axis
    for k in range(N_HIST):
        for a in range(3):
            sm[k, a] = bstate[B_SM + 3 * k + a]
    rel = bstate[B_REL:B_REL + 3].copy()
    relr = bstate[B_RELR:B_RELR + 3].copy()
    q0 = np.zeros(3)
    q1 = np.zeros(3)
    for n in range(j0, j1):
        for r in range(nc):
            zn[r] = cin[n, idx[r]]
        for j in range(nc):
            zj = z[j]
            for r in range(nc):
                zn[r] += phit[j, r] * zj
        for kind in range(nh):  # from t_{n-1} back: independent of the suspensions' step that ends at t_n
            for a in range(3):
                s_ = sm[kind + 1, a]
                for r in range(nc):
                    zn[r] += tt[kind, a, r] * s_
        # the relative motion's share of each suspension's forcing (Hermite, as plant_exact._forcing)
        for a in range(3):
            r_, rr = _relative(umat, zn, pos, a)
            slope = (r_ - rel[a]) * ih
            q0[a] = q0s[a, n] - (6.0 * slope - 4.0 * relr[a] - 2.0 * rr) * ih
            q1[a] = q1s[a, n] - 6.0 * (relr[a] + rr - 2.0 * slope) * ih2
            rel[a] = r_
            relr[a] = rr
        la = _lane_step(ka, la, q0[0], q1[0], rules[0], hyst[0], stack[0])
        lb = _lane_step(kb, lb, q0[1], q1[1], rules[1], hyst[1], stack[1])
        lc = _lane_step(kc, lc, q0[2], q1[2], rules[2], hyst[2], stack[2])
        for k in range(N_HIST - 1, 0, -1):
            for a in range(3):
                sm[k, a] = sm[k - 1, a]
        sm[0, 0] = gain[0] * (la[0] + la[2])
        sm[0, 1] = gain[1] * (lb[0] + lb[2])
        sm[0, 2] = gain[2] * (lc[0] + lc[2])
        out_delta[0, n] = la[0]
        out_delta[1, n] = lb[0]
        out_delta[2, n] = lc[0]
        for r in range(nc):
            z[r] = zn[r]
            out_z[n, idx[r]] = zn[r]
    kexact._lane_store(state, 0, la)
    kexact._lane_store(state, 1, lb)
    kexact._lane_store(state, 2, lc)
    for r in range(nc):
        bstate[B_Z + idx[r]] = z[r]
    for k in range(N_HIST):
        for a in range(3):
            bstate[B_SM + 3 * k + a] = sm[k, a]
    for a in range(3):
        bstate[B_REL + a] = rel[a]
        bstate[B_RELR + a] = relr[a]


@jit
def propagate_rest(ridx, phi, cin, bstate, out_z):
    """The rows ``ridx`` of ``z`` that the torques do not reach (the translation of a block whose elastic centre is
    at its c.g.), over the chunk, after :func:`run_three_block` wrote the others: ``z_r(n+1) = Phi[r, :] z(n) +
    cin[r, n]`` with the full step matrix (its other columns are zero for these rows in that case)."""
    n = cin.shape[0]
    zr = np.empty(ridx.shape[0])
    prev = np.empty(12)
    for r in range(12):
        prev[r] = bstate[B_Z + r]
    for k in range(n):
        for i in range(ridx.shape[0]):
            r = ridx[i]
            acc = cin[k, r]
            for j in range(12):
                acc += phi[r, j] * prev[j]
            zr[i] = acc
        for i in range(ridx.shape[0]):
            out_z[k, ridx[i]] = zr[i]
        for r in range(12):
            prev[r] = out_z[k, r]
    for r in range(12):
        bstate[B_Z + r] = prev[r]


@jit
def drive_plant_three_block(i0, ang, rate, uniforms, fpar, ipar, dstate, pstate, physt, pstack, delta, volts, q0s,
                            q1s, used, gain, umat, phi, phit, tt, f0t, gch, idx, ridx, pos, lin0, lin1, bstate, cin,
                            out_z):
    """``chain.drive_plant_three`` with the three suspensions on one block (module docstring).

    The drive, detector and amplitude loop of each channel are those of ``chain.drive_plant_three`` (the same
    segments, ending wherever a channel ends an amplitude-control block); the plant steps are those of
    :func:`run_three_block`. ``ang, rate``: (3, n) the chassis angle and rate about block axes; ``lin0, lin1``:
    (3, n) the chassis linear acceleration at the c.g. and its slope over each step; ``f0t`` (12, 3): ``F0``'s torque
    columns, through which each segment's piezo torques (held, ``gain k5 V``) enter; the block matrices as
    ``BlockStep``; ``bstate``: float64[B_SIZE]; ``cin``: (n, 12) a work buffer (the caller keeps it from chunk to
    chunk: a fresh 7 MB array per chunk costs its page faults); ``out_z``: (n, 12). Other arguments as ``chain.drive_plant_three``.
    """
    n = ang.shape[1]
    consts = np.empty((3, kexact.N_CONSTS))
    rules = np.empty(3, dtype=np.int64)
    for a in range(3):
        f = fpar[a]
        kexact._constants(consts, a, f[kchain.P_H], f[kchain.P_W0SQ], f[kchain.P_K1], f[kchain.P_K2],
                          f[kchain.P_K3], f[kchain.P_K4], f[kchain.P_K5], f[kchain.P_Z], f[kchain.P_FAST])
        rules[a] = ipar[a, kchain.I_RULE]
        used[a] = 0
    phi0 = np.empty(3)
    rate0 = np.empty(3)
    for a in range(3):
        phi0[a] = pstate[a, kexact.X_PHI]
        rate0[a] = pstate[a, kexact.X_RATE]
    chassis_input(ang, rate, phi0, rate0, consts[0, kexact.C_IH], consts[0, kexact.C_IH2], lin0, lin1, gch, cin)
    bz0 = bstate[B_Z:B_Z + 12].copy()
    j = 0
    while j < n:
        m = n - j
        for a in range(3):
            m = min(m, int(dstate[a, kchain.D_LEFT]))
        for a in range(3):
            kchain._segment_forcing(i0 + j, ang[a][j:j + m], rate[a][j:j + m], volts[a][j:j + m], fpar[a], ipar[a],
                                    dstate[a], pstate[a], consts[a], q0s[a][j:j + m], q1s[a][j:j + m])
            pstate[a, kexact.X_PHI] = ang[a, j + m - 1]
            pstate[a, kexact.X_RATE] = rate[a, j + m - 1]
        for k in range(j, j + m):  # the piezo torques, held over each step, through F0's torque columns
            p0 = gain[0] * consts[0, kexact.C_K5] * volts[0, k]
            p1 = gain[1] * consts[1, kexact.C_K5] * volts[1, k]
            p2 = gain[2] * consts[2, kexact.C_K5] * volts[2, k]
            for r in range(12):
                cin[k, r] += f0t[r, 0] * p0 + f0t[r, 1] * p1 + f0t[r, 2] * p2
        run_three_block(j, j + m, q0s, q1s, consts, rules, pstate, physt, pstack, gain, umat, phit, tt, idx, pos, cin,
                        bstate, delta, out_z)
        for a in range(3):
            used[a] = kchain._close_segment(i0, j, m, delta[a][j:j + m], fpar[a], ipar[a], dstate[a], uniforms[a],
                                            used[a])
        j += m
    if ridx.shape[0] > 0:  # the rows the torques do not reach, from the chunk's start
        for r in range(12):
            bstate[B_Z + r] = bz0[r]
        propagate_rest(ridx, phi, cin, bstate, out_z)


# carry of :func:`block_truth` between chunks
T_THETA = 0  # theta at the last step, 3 values
T_XDOT = 3  # x' at the last step, 3 values
T_G = 6  # the second-order rate g at the last step, 3 values
T_C = 9  # its integral c, 3 values
T_SIZE = 12


@jit
def block_truth(z, rate, umat, h, r, carry, add, dth, theta_avg, theta_end, dvel):
    """What the block's relative motion adds to the gyros and the truth, from its state at the plant steps.

    The block's inertial rate in block axes is ``w_b = R(theta)^T w_c + J_r(theta) theta'``, to second order
    ``w_c + theta' + g`` with ``g = -theta x w_c - (1/2) theta x theta'`` (the right Jacobian of the rotation
    vector, Bortz 1971; ``R(theta)^T w_c`` the chassis rate seen in the rocked block). Its integral beyond the
    chassis' own is ``theta + c`` with ``c = int g dt`` (trapezoid over the plant steps, error
    ``(w h)^2 / 12`` of a term that is itself second order in the arcsec-level ``theta``). The second-order part
    is what makes dither coning: it drifts when two axes rock at one frequency.

    Parameters
    ----------
    z : (n, 12)
        Block state at the ends of the plant steps (``run_three_block``).
    rate : (3, n)
        Chassis rate about block axes at the same steps (rad/s).
    umat : (3, 3)
        Gyro input axes (rows).
    h : float
        Plant step (s).
    r : int
        Plant steps per filter sample (``n`` is a whole number of them).
    carry : float64[T_SIZE]
        State between chunks (zeros at rest), updated.
    add : (3, n), filled
        Gyro ``i``'s rotation beyond the chassis', ``u_i . (theta + c)`` (rad): added to the chassis angle the
        readout sees.
    dth : (3, m), filled
        The same as ideal increments over each filter sample, ``u_i . Delta(theta + c)`` (rad).
    theta_avg, theta_end : (3, m), filled
        ``theta`` averaged over each filter sample and at its end (block axes, rad): the accelerometers' tilt and
        the block's attitude relative to the chassis.
    dvel : (3, m), filled
        ``Delta x'`` over each filter sample (m/s): the block's velocity increment relative to the chassis.
    """
    n = z.shape[0]
    th = np.empty(3)
    g = np.empty(3)
    for i in range(3):
        th[i] = carry[T_THETA + i]
    gp0 = carry[T_G]
    gp1 = carry[T_G + 1]
    gp2 = carry[T_G + 2]
    c0 = carry[T_C]
    c1 = carry[T_C + 1]
    c2 = carry[T_C + 2]
    prev_add = np.empty(3)
    for i in range(3):
        prev_add[i] = (umat[i, 0] * (th[0] + c0) + umat[i, 1] * (th[1] + c1) + umat[i, 2] * (th[2] + c2))
    xd = np.empty(3)
    for i in range(3):
        xd[i] = carry[T_XDOT + i]
    half_h = 0.5 * h
    for k in range(n // r):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for jj in range(r):
            j = k * r + jj
            t0 = z[j, 3]
            t1 = z[j, 4]
            t2 = z[j, 5]
            d0 = z[j, 9]
            d1 = z[j, 10]
            d2 = z[j, 11]
            w0 = rate[0, j]
            w1 = rate[1, j]
            w2 = rate[2, j]
            g[0] = -(t1 * w2 - t2 * w1) - 0.5 * (t1 * d2 - t2 * d1)
            g[1] = -(t2 * w0 - t0 * w2) - 0.5 * (t2 * d0 - t0 * d2)
            g[2] = -(t0 * w1 - t1 * w0) - 0.5 * (t0 * d1 - t1 * d0)
            c0 += half_h * (gp0 + g[0])
            c1 += half_h * (gp1 + g[1])
            c2 += half_h * (gp2 + g[2])
            gp0 = g[0]
            gp1 = g[1]
            gp2 = g[2]
            for i in range(3):
                add[i, j] = umat[i, 0] * (t0 + c0) + umat[i, 1] * (t1 + c1) + umat[i, 2] * (t2 + c2)
            s0 += t0
            s1 += t1
            s2 += t2
        j = k * r + r - 1
        for i in range(3):
            dth[i, k] = add[i, j] - prev_add[i]
            prev_add[i] = add[i, j]
            theta_end[i, k] = z[j, 3 + i]
            dvel[i, k] = z[j, 6 + i] - xd[i]
            xd[i] = z[j, 6 + i]
        theta_avg[0, k] = s0 / r
        theta_avg[1, k] = s1 / r
        theta_avg[2, k] = s2 / r
    if n > 0:
        for i in range(3):
            carry[T_THETA + i] = z[n - 1, 3 + i]
            carry[T_XDOT + i] = z[n - 1, 6 + i]
    carry[T_G] = gp0
    carry[T_G + 1] = gp1
    carry[T_G + 2] = gp2
    carry[T_C] = c0
    carry[T_C + 1] = c1
    carry[T_C + 2] = c2
