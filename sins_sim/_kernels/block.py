"""The three suspensions and the sensor block stepped together (reference-model.md, "The block as a body").

The block's relative motion (``sins_sim.models.block``: linear, base-excited, exact step for inputs linear in
time) and the three suspensions (``plant_exact``: eq. 2, 9, 10, 14, the exact-oscillator integrator) are
advanced one plant step at a time, coupled both ways:

- the suspensions' torques ``T_i = -J_g,i w0_i^2 (delta_i + F_i + k5_i V_i)`` load the block (``-T_i u_i``);
- the block's rotation about each gyro's input axis adds to the SINS angle that drives that suspension.

Coupling scheme (a staggered, explicit partitioned step; Felippa, Park and Farhat 2001, "Partitioned analysis of
coupled mechanical systems", CMAME 190, sec. 4): over step ``n`` the torque's smooth part
``-J_g w0^2 (delta + F)`` is extrapolated by the quadratic through ``t_{n-2}, t_{n-1}, t_n`` (third order) and the piezo
part ``-J_g w0^2 k5 V_n`` is held, as the suspension holds its drive (zero-order hold); the block advances
exactly under that input; its relative angle and rate about ``u_i`` at ``t_{n+1}`` extend the suspension's
Hermite interpolant of the SINS angle (``plant_exact._forcing``) by the relative part, which is linear in the
samples, so ``q0 += -p0_rel`` and ``q1 += -p1_rel``; then each suspension takes its step with exactly the
arithmetic of ``plant_exact.run_three``. With the relative motion identically zero (the rigid block) the
suspensions get bit for bit the numbers of ``run_three``.

The coupling's own error is that of the torque extrapolation. With a linear extrapolation (second order) the block's
response at 386 Hz and 72 kHz was off by 4.7e-4 (``5/12 (w h)^2``, halving ``h`` quartered it), and near
resonance the suspension's amplitude by as much, through the coupled frequency; the quadratic leaves
``(w h)^3``-order errors (``tests/test_block.py`` states the measured figures against the frequency-domain
solution of the coupled linear system).

Block state (``bstate``, float64[B_SIZE]): ``z`` (12: translation, rotation vector, and their rates, relative to
the chassis), the torques' smooth parts at ``t_n``, ``t_{n-1}`` and ``t_{n-2}``, and the relative angle and rate about each
input axis at ``t_n``. All zeros is rest.
"""

from __future__ import annotations

import numpy as np

from sins_sim._kernels import chain as kchain
from sins_sim._kernels import plant_exact as kexact
from sins_sim._kernels._config import jit

B_Z = 0  # z, 12 values
B_SM0 = 12  # smooth torque part at t_n, 3 values
B_SMP = 15  # smooth torque part at t_{n-1}, 3 values
B_REL = 18  # relative angle about u_i at t_n, 3 values
B_RELR = 21  # relative rate about u_i at t_n, 3 values
B_SMPP = 24  # smooth torque part at t_{n-2}, 3 values
B_SIZE = 27


@jit
def chassis_input(ang, rate, phi0, rate0, ih, ih2, lin0, lin1, f0m, f1m, out_c):
    """The chassis' contribution to the block's step, for every step of a chunk (no dependency between steps).

    ``ang, rate``: (3, N) chassis angle and rate about block axes x, y, z at ``t_{n+1}``; ``phi0, rate0``: (3,)
    at the chunk's start. The chassis angular acceleration over a step is the second derivative of the same cubic
    Hermite interpolant the suspensions use, ``P0 + P1 tau`` (``plant_exact`` module docstring); ``lin0, lin1``:
    (3, N) the chassis linear acceleration at the c.g. over each step, ``a0 + a1 tau``. ``out_c``: (12, N),
    ``F0[:, :6] (a0, P0) + F1[:, :6] (a1, P1)`` (``BlockParams.discrete``).
    """
    n = ang.shape[1]
    u0 = [0.0] * 6
    u1 = [0.0] * 6
    pa = [phi0[0], phi0[1], phi0[2]]
    ra = [rate0[0], rate0[1], rate0[2]]
    for k in range(n):
        for i in range(3):
            slope = (ang[i, k] - pa[i]) * ih
            u0[3 + i] = (6.0 * slope - 4.0 * ra[i] - 2.0 * rate[i, k]) * ih
            u1[3 + i] = 6.0 * (ra[i] + rate[i, k] - 2.0 * slope) * ih2
            u0[i] = lin0[i, k]
            u1[i] = lin1[i, k]
            pa[i] = ang[i, k]
            ra[i] = rate[i, k]
        for r in range(12):
            acc = 0.0
            for j in range(6):
                acc += f0m[r, j] * u0[j] + f1m[r, j] * u1[j]
            out_c[r, k] = acc


@jit(inline="always")
def _relative(umat, z, a):
    """Relative angle and rate of the block about input axis ``a``: ``u_a . theta``, ``u_a . theta'``."""
    r = umat[a, 0] * z[3] + umat[a, 1] * z[4] + umat[a, 2] * z[5]
    rr = umat[a, 0] * z[9] + umat[a, 1] * z[10] + umat[a, 2] * z[11]
    return r, rr


@jit(inline="always")
def _lane_step(k, lane, q0, q1, rule, hyst, stack):
    xb, vb, fb, rb, rare = kexact._lane_trial(k, lane, q0, q1)
    if rare:
        return kexact._lane_change(k, lane, xb, vb, fb, rb, q0, q1, rule, hyst, stack)
    return kexact._lane_commit(k, lane, xb, vb, fb, rb)


@jit
def run_three_block(j0, j1, q0s, q1s, volts, cs, rules, state, hyst, stack, jg, umat, phi, f0m, f1m, f2m, cin, bstate,
                    out_delta, out_z):
    """The three suspensions and the block over steps ``j0 .. j1 - 1`` (module docstring).

    Suspension arguments as ``plant_exact.run_three`` (``q0s, q1s``: (3, N), the forcing from the chassis and
    the drive, ``plant_exact._forcing``); ``volts``: (3, N) the drive held over each step (V); ``jg``: (3,) gyro
    inertias (kg m^2); ``umat``: (3, 3) input axes (rows); ``phi, f0m, f1m, f2m``: ``BlockParams.discrete(h)``;
    ``cin``: (12, N) from :func:`chassis_input`; ``bstate``: float64[B_SIZE]; ``out_z``: (12, N) the block's
    state at ``t_{n+1}``.
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
    z = bstate[B_Z:B_Z + 12].copy()
    zn = z.copy()
    t0 = [0.0, 0.0, 0.0]
    t1 = [0.0, 0.0, 0.0]
    t2 = [0.0, 0.0, 0.0]
    ih2h = 0.5 * ih2
    gain = [-jg[0] * ka[kexact.C_W0SQ], -jg[1] * kb[kexact.C_W0SQ], -jg[2] * kc[kexact.C_W0SQ]]
    k5 = [ka[kexact.C_K5], kb[kexact.C_K5], kc[kexact.C_K5]]
    sm0 = [bstate[B_SM0], bstate[B_SM0 + 1], bstate[B_SM0 + 2]]
    smp = [bstate[B_SMP], bstate[B_SMP + 1], bstate[B_SMP + 2]]
    smpp = [bstate[B_SMPP], bstate[B_SMPP + 1], bstate[B_SMPP + 2]]
    rel = [bstate[B_REL], bstate[B_REL + 1], bstate[B_REL + 2]]
    relr = [bstate[B_RELR], bstate[B_RELR + 1], bstate[B_RELR + 2]]
    q0 = [0.0, 0.0, 0.0]
    q1 = [0.0, 0.0, 0.0]
    for n in range(j0, j1):
        # torque over the step: smooth part by the quadratic through t_{n-2}, t_{n-1}, t_n; piezo part held
        for a in range(3):
            t0[a] = sm0[a] + gain[a] * k5[a] * volts[a, n]
            t1[a] = (3.0 * sm0[a] - 4.0 * smp[a] + smpp[a]) * 0.5 * ih
            t2[a] = (sm0[a] - 2.0 * smp[a] + smpp[a]) * ih2h
        for r in range(12):
            acc = cin[r, n]
            for j in range(12):
                acc += phi[r, j] * z[j]
            for a in range(3):
                acc += f0m[r, 6 + a] * t0[a] + f1m[r, 6 + a] * t1[a] + f2m[r, 6 + a] * t2[a]
            zn[r] = acc
        # the relative motion's share of each suspension's forcing (Hermite, as plant_exact._forcing)
        for a in range(3):
            r, rr = _relative(umat, zn, a)
            slope = (r - rel[a]) * ih
            q0[a] = q0s[a, n] - (6.0 * slope - 4.0 * relr[a] - 2.0 * rr) * ih
            q1[a] = q1s[a, n] - 6.0 * (relr[a] + rr - 2.0 * slope) * ih2
            rel[a] = r
            relr[a] = rr
        la = _lane_step(ka, la, q0[0], q1[0], rules[0], hyst[0], stack[0])
        lb = _lane_step(kb, lb, q0[1], q1[1], rules[1], hyst[1], stack[1])
        lc = _lane_step(kc, lc, q0[2], q1[2], rules[2], hyst[2], stack[2])
        for a in range(3):
            smpp[a] = smp[a]
            smp[a] = sm0[a]
        sm0[0] = gain[0] * (la[0] + la[2])
        sm0[1] = gain[1] * (lb[0] + lb[2])
        sm0[2] = gain[2] * (lc[0] + lc[2])
        out_delta[0, n] = la[0]
        out_delta[1, n] = lb[0]
        out_delta[2, n] = lc[0]
        for r in range(12):
            z[r] = zn[r]
            out_z[r, n] = zn[r]
    kexact._lane_store(state, 0, la)
    kexact._lane_store(state, 1, lb)
    kexact._lane_store(state, 2, lc)
    for r in range(12):
        bstate[B_Z + r] = z[r]
    for a in range(3):
        bstate[B_SM0 + a] = sm0[a]
        bstate[B_SMP + a] = smp[a]
        bstate[B_SMPP + a] = smpp[a]
        bstate[B_REL + a] = rel[a]
        bstate[B_RELR + a] = relr[a]


@jit
def drive_plant_three_block(i0, ang, rate, uniforms, fpar, ipar, dstate, pstate, physt, pstack, delta, volts, q0s,
                            q1s, used, jg, umat, phi, f0m, f1m, f2m, lin0, lin1, bstate, out_z):
    """``chain.drive_plant_three`` with the three suspensions on one block (module docstring).

    The drive, detector and amplitude loop of each channel are those of ``chain.drive_plant_three`` (the same
    segments, ending wherever a channel ends an amplitude-control block); the plant steps are those of
    :func:`run_three_block`. ``ang, rate``: (3, n) the chassis angle and rate about block axes; ``lin0, lin1``:
    (3, n) the chassis linear acceleration at the c.g. and its slope over each step; ``bstate``:
    float64[B_SIZE]; ``out_z``: (12, n). Other arguments as ``chain.drive_plant_three``.
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
    cin = np.empty((12, n))
    chassis_input(ang, rate, phi0, rate0, consts[0, kexact.C_IH], consts[0, kexact.C_IH2], lin0, lin1, f0m, f1m,
                  cin)
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
        run_three_block(j, j + m, q0s, q1s, volts, consts, rules, pstate, physt, pstack, jg, umat, phi, f0m, f1m,
                        f2m, cin, bstate, delta, out_z)
        for a in range(3):
            used[a] = kchain._close_segment(i0, j, m, delta[a][j:j + m], fpar[a], ipar[a], dstate[a], uniforms[a],
                                            used[a])
        j += m


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
    z : (12, n)
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
    n = z.shape[1]
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
            t0 = z[3, j]
            t1 = z[4, j]
            t2 = z[5, j]
            d0 = z[9, j]
            d1 = z[10, j]
            d2 = z[11, j]
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
            theta_end[i, k] = z[3 + i, j]
            dvel[i, k] = z[6 + i, j] - xd[i]
            xd[i] = z[6 + i, j]
        theta_avg[0, k] = s0 / r
        theta_avg[1, k] = s1 / r
        theta_avg[2, k] = s2 / r
    if n > 0:
        for i in range(3):
            carry[T_THETA + i] = z[3 + i, n - 1]
            carry[T_XDOT + i] = z[6 + i, n - 1]
    carry[T_G] = gp0
    carry[T_G + 1] = gp1
    carry[T_G + 2] = gp2
    carry[T_C] = c0
    carry[T_C + 1] = c1
    carry[T_C + 2] = c2
