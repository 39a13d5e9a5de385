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
