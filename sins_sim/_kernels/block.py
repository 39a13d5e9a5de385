"""The three suspensions and the sensor block stepped together (docs/user-guide/block.md).

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

Kernels, by the block's structure (``models.block.BlockStep`` decides from exact zeros of the discrete matrices):

- axis-decoupled (:func:`run_three_block_axes`): a diagonal inertia with the elastic centre at the c.g. (the
  bundled preset): each rotation axis is a 2x2 step of its own, the gyros' torques enter as the moments they exert
  about the block's axes (``-sum_i T_i u_i``, formed once per step, so a tilted input axis costs three products,
  not a denser step), and the chassis' angular acceleration and the piezo torques are formed inside the step loop
  (no ``chassis_input`` pass, no input buffer); the translation, which neither the gyros nor the rotation reach,
  follows in its own pass (:func:`propagate_translation_axes`);
- otherwise the general kernel (:func:`run_three_block`, and :func:`run_three_block6` for the six rotation states
  of a decoupled mount) on the ``nc`` chained states, the inputs prepared by :func:`chassis_input`. Each state sums
  its inputs first and the previous state last, so the chain from ``z(n)`` to ``z(n+1)`` is ``nc`` additions long;
- a translation at rest with no linear input over a chunk (the decoupled mounts, while linear vibration does not
  reach the isolators) stays exactly zero and is written so, without its steps.

Cost per plant step of three axes on the engine's channel path against the rigid engine (``benchmarks/
test_block_speed.py``): about 1.8 times with the axis-decoupled kernel, 2.9 with twelve chained states; the
suspensions' step itself, a latency-bound chain that the rigid engine overlaps three ways, roughly doubles once the
block's arithmetic and the coupling share its loop.

Block state (``bstate``, float64[B_SIZE]): ``z`` (12: translation, rotation vector, and their rates, relative to
the chassis), the relative angle and rate about each input axis at ``t_n``, and the torques' smooth parts at
``t_n .. t_{n-4}`` (the axis-decoupled kernel keeps there the moments they exert about the block's axes x, y, z
instead). All zeros is rest.
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

# per-axis coefficients of the axis-decoupled kernel (``ax``: (3, AX_SIZE), ``BlockStep``): rotation about axis k
# (theta_k, theta_k'): its 2x2 step matrix, the chassis' P0 and P1, the held piezo moment, the moment history at
# t_{n-1} .. t_{n-4} (theta_k and theta_k' interleaved); translation along k (x_k, x_k'): its 2x2 step matrix, the
# chassis' a0 and a1
AX_PAA = 0
AX_PAB = 1
AX_PBA = 2
AX_PBB = 3
AX_CA0 = 4
AX_CB0 = 5
AX_CA1 = 6
AX_CB1 = 7
AX_MA = 8
AX_MB = 9
AX_HA = 10
AX_HB = 11
AX_TAA = 18
AX_TAB = 19
AX_TBA = 20
AX_TBB = 21
AX_LA0 = 22
AX_LB0 = 23
AX_LA1 = 24
AX_LB1 = 25
AX_SIZE = 26


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
        for kind in range(nh):  # from t_{n-1} back: independent of the suspensions' step that ends at t_n
            for a in range(3):
                s_ = sm[kind + 1, a]
                for r in range(nc):
                    zn[r] += tt[kind, a, r] * s_
        for j in range(nc):  # the state last: the chain from z(n) to z(n+1) is nc additions long, not nc + 3 nh
            zj = z[j]
            for r in range(nc):
                zn[r] += phit[j, r] * zj
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
def run_three_block6(j0, j1, q0s, q1s, cs, rules, state, hyst, stack, gain, umat, phit, tt, idx, pos, cin, bstate,
                     out_delta, out_z):
    """:func:`run_three_block` for the common case of six chained states (the rotation of a block whose mount does
    not couple translation and rotation, ``idx = (3, 4, 5, 9, 10, 11)``, ``pos = 0 .. 5``), written out in scalars so
    that the step matrix and the torque inputs stay in registers: the same arithmetic in the same order, the same
    bits (``tests/test_block.py``)."""
    ka = kexact._lane_constants(cs, 0)
    kb = kexact._lane_constants(cs, 1)
    kc = kexact._lane_constants(cs, 2)
    la = kexact._lane_load(state, 0, cs, rules[0], hyst[0], stack[0])
    lb = kexact._lane_load(state, 1, cs, rules[1], hyst[1], stack[1])
    lc = kexact._lane_load(state, 2, cs, rules[2], hyst[2], stack[2])
    h = ka[kexact.C_H]
    ih = 1.0 / h
    ih2 = ih * ih
    z0 = bstate[B_Z + idx[0]]
    z1 = bstate[B_Z + idx[1]]
    z2 = bstate[B_Z + idx[2]]
    z3 = bstate[B_Z + idx[3]]
    z4 = bstate[B_Z + idx[4]]
    z5 = bstate[B_Z + idx[5]]
    p00 = phit[0, 0]
    p01 = phit[0, 1]
    p02 = phit[0, 2]
    p03 = phit[0, 3]
    p04 = phit[0, 4]
    p05 = phit[0, 5]
    p10 = phit[1, 0]
    p11 = phit[1, 1]
    p12 = phit[1, 2]
    p13 = phit[1, 3]
    p14 = phit[1, 4]
    p15 = phit[1, 5]
    p20 = phit[2, 0]
    p21 = phit[2, 1]
    p22 = phit[2, 2]
    p23 = phit[2, 3]
    p24 = phit[2, 4]
    p25 = phit[2, 5]
    p30 = phit[3, 0]
    p31 = phit[3, 1]
    p32 = phit[3, 2]
    p33 = phit[3, 3]
    p34 = phit[3, 4]
    p35 = phit[3, 5]
    p40 = phit[4, 0]
    p41 = phit[4, 1]
    p42 = phit[4, 2]
    p43 = phit[4, 3]
    p44 = phit[4, 4]
    p45 = phit[4, 5]
    p50 = phit[5, 0]
    p51 = phit[5, 1]
    p52 = phit[5, 2]
    p53 = phit[5, 3]
    p54 = phit[5, 4]
    p55 = phit[5, 5]
    t000 = tt[0, 0, 0]
    t001 = tt[0, 0, 1]
    t002 = tt[0, 0, 2]
    t003 = tt[0, 0, 3]
    t004 = tt[0, 0, 4]
    t005 = tt[0, 0, 5]
    t010 = tt[0, 1, 0]
    t011 = tt[0, 1, 1]
    t012 = tt[0, 1, 2]
    t013 = tt[0, 1, 3]
    t014 = tt[0, 1, 4]
    t015 = tt[0, 1, 5]
    t020 = tt[0, 2, 0]
    t021 = tt[0, 2, 1]
    t022 = tt[0, 2, 2]
    t023 = tt[0, 2, 3]
    t024 = tt[0, 2, 4]
    t025 = tt[0, 2, 5]
    t100 = tt[1, 0, 0]
    t101 = tt[1, 0, 1]
    t102 = tt[1, 0, 2]
    t103 = tt[1, 0, 3]
    t104 = tt[1, 0, 4]
    t105 = tt[1, 0, 5]
    t110 = tt[1, 1, 0]
    t111 = tt[1, 1, 1]
    t112 = tt[1, 1, 2]
    t113 = tt[1, 1, 3]
    t114 = tt[1, 1, 4]
    t115 = tt[1, 1, 5]
    t120 = tt[1, 2, 0]
    t121 = tt[1, 2, 1]
    t122 = tt[1, 2, 2]
    t123 = tt[1, 2, 3]
    t124 = tt[1, 2, 4]
    t125 = tt[1, 2, 5]
    t200 = tt[2, 0, 0]
    t201 = tt[2, 0, 1]
    t202 = tt[2, 0, 2]
    t203 = tt[2, 0, 3]
    t204 = tt[2, 0, 4]
    t205 = tt[2, 0, 5]
    t210 = tt[2, 1, 0]
    t211 = tt[2, 1, 1]
    t212 = tt[2, 1, 2]
    t213 = tt[2, 1, 3]
    t214 = tt[2, 1, 4]
    t215 = tt[2, 1, 5]
    t220 = tt[2, 2, 0]
    t221 = tt[2, 2, 1]
    t222 = tt[2, 2, 2]
    t223 = tt[2, 2, 3]
    t224 = tt[2, 2, 4]
    t225 = tt[2, 2, 5]
    t300 = tt[3, 0, 0]
    t301 = tt[3, 0, 1]
    t302 = tt[3, 0, 2]
    t303 = tt[3, 0, 3]
    t304 = tt[3, 0, 4]
    t305 = tt[3, 0, 5]
    t310 = tt[3, 1, 0]
    t311 = tt[3, 1, 1]
    t312 = tt[3, 1, 2]
    t313 = tt[3, 1, 3]
    t314 = tt[3, 1, 4]
    t315 = tt[3, 1, 5]
    t320 = tt[3, 2, 0]
    t321 = tt[3, 2, 1]
    t322 = tt[3, 2, 2]
    t323 = tt[3, 2, 3]
    t324 = tt[3, 2, 4]
    t325 = tt[3, 2, 5]
    s00 = bstate[B_SM + 0]
    s01 = bstate[B_SM + 1]
    s02 = bstate[B_SM + 2]
    s10 = bstate[B_SM + 3]
    s11 = bstate[B_SM + 4]
    s12 = bstate[B_SM + 5]
    s20 = bstate[B_SM + 6]
    s21 = bstate[B_SM + 7]
    s22 = bstate[B_SM + 8]
    s30 = bstate[B_SM + 9]
    s31 = bstate[B_SM + 10]
    s32 = bstate[B_SM + 11]
    s40 = bstate[B_SM + 12]
    s41 = bstate[B_SM + 13]
    s42 = bstate[B_SM + 14]
    rel0 = bstate[B_REL + 0]
    relr0 = bstate[B_RELR + 0]
    u00 = umat[0, 0]
    u01 = umat[0, 1]
    u02 = umat[0, 2]
    rel1 = bstate[B_REL + 1]
    relr1 = bstate[B_RELR + 1]
    u10 = umat[1, 0]
    u11 = umat[1, 1]
    u12 = umat[1, 2]
    rel2 = bstate[B_REL + 2]
    relr2 = bstate[B_RELR + 2]
    u20 = umat[2, 0]
    u21 = umat[2, 1]
    u22 = umat[2, 2]
    g0 = gain[0]
    g1 = gain[1]
    g2 = gain[2]
    for n in range(j0, j1):
        n0 = cin[n, idx[0]]
        n1 = cin[n, idx[1]]
        n2 = cin[n, idx[2]]
        n3 = cin[n, idx[3]]
        n4 = cin[n, idx[4]]
        n5 = cin[n, idx[5]]
        n0 += t000 * s10
        n1 += t001 * s10
        n2 += t002 * s10
        n3 += t003 * s10
        n4 += t004 * s10
        n5 += t005 * s10
        n0 += t010 * s11
        n1 += t011 * s11
        n2 += t012 * s11
        n3 += t013 * s11
        n4 += t014 * s11
        n5 += t015 * s11
        n0 += t020 * s12
        n1 += t021 * s12
        n2 += t022 * s12
        n3 += t023 * s12
        n4 += t024 * s12
        n5 += t025 * s12
        n0 += t100 * s20
        n1 += t101 * s20
        n2 += t102 * s20
        n3 += t103 * s20
        n4 += t104 * s20
        n5 += t105 * s20
        n0 += t110 * s21
        n1 += t111 * s21
        n2 += t112 * s21
        n3 += t113 * s21
        n4 += t114 * s21
        n5 += t115 * s21
        n0 += t120 * s22
        n1 += t121 * s22
        n2 += t122 * s22
        n3 += t123 * s22
        n4 += t124 * s22
        n5 += t125 * s22
        n0 += t200 * s30
        n1 += t201 * s30
        n2 += t202 * s30
        n3 += t203 * s30
        n4 += t204 * s30
        n5 += t205 * s30
        n0 += t210 * s31
        n1 += t211 * s31
        n2 += t212 * s31
        n3 += t213 * s31
        n4 += t214 * s31
        n5 += t215 * s31
        n0 += t220 * s32
        n1 += t221 * s32
        n2 += t222 * s32
        n3 += t223 * s32
        n4 += t224 * s32
        n5 += t225 * s32
        n0 += t300 * s40
        n1 += t301 * s40
        n2 += t302 * s40
        n3 += t303 * s40
        n4 += t304 * s40
        n5 += t305 * s40
        n0 += t310 * s41
        n1 += t311 * s41
        n2 += t312 * s41
        n3 += t313 * s41
        n4 += t314 * s41
        n5 += t315 * s41
        n0 += t320 * s42
        n1 += t321 * s42
        n2 += t322 * s42
        n3 += t323 * s42
        n4 += t324 * s42
        n5 += t325 * s42
        n0 += p00 * z0
        n1 += p01 * z0
        n2 += p02 * z0
        n3 += p03 * z0
        n4 += p04 * z0
        n5 += p05 * z0
        n0 += p10 * z1
        n1 += p11 * z1
        n2 += p12 * z1
        n3 += p13 * z1
        n4 += p14 * z1
        n5 += p15 * z1
        n0 += p20 * z2
        n1 += p21 * z2
        n2 += p22 * z2
        n3 += p23 * z2
        n4 += p24 * z2
        n5 += p25 * z2
        n0 += p30 * z3
        n1 += p31 * z3
        n2 += p32 * z3
        n3 += p33 * z3
        n4 += p34 * z3
        n5 += p35 * z3
        n0 += p40 * z4
        n1 += p41 * z4
        n2 += p42 * z4
        n3 += p43 * z4
        n4 += p44 * z4
        n5 += p45 * z4
        n0 += p50 * z5
        n1 += p51 * z5
        n2 += p52 * z5
        n3 += p53 * z5
        n4 += p54 * z5
        n5 += p55 * z5
        r0 = u00 * n0 + u01 * n1 + u02 * n2
        rr0 = u00 * n3 + u01 * n4 + u02 * n5
        sl0 = (r0 - rel0) * ih
        qa0 = q0s[0, n] - (6.0 * sl0 - 4.0 * relr0 - 2.0 * rr0) * ih
        qb0 = q1s[0, n] - 6.0 * (relr0 + rr0 - 2.0 * sl0) * ih2
        rel0 = r0
        relr0 = rr0
        r1 = u10 * n0 + u11 * n1 + u12 * n2
        rr1 = u10 * n3 + u11 * n4 + u12 * n5
        sl1 = (r1 - rel1) * ih
        qa1 = q0s[1, n] - (6.0 * sl1 - 4.0 * relr1 - 2.0 * rr1) * ih
        qb1 = q1s[1, n] - 6.0 * (relr1 + rr1 - 2.0 * sl1) * ih2
        rel1 = r1
        relr1 = rr1
        r2 = u20 * n0 + u21 * n1 + u22 * n2
        rr2 = u20 * n3 + u21 * n4 + u22 * n5
        sl2 = (r2 - rel2) * ih
        qa2 = q0s[2, n] - (6.0 * sl2 - 4.0 * relr2 - 2.0 * rr2) * ih
        qb2 = q1s[2, n] - 6.0 * (relr2 + rr2 - 2.0 * sl2) * ih2
        rel2 = r2
        relr2 = rr2
        la = _lane_step(ka, la, qa0, qb0, rules[0], hyst[0], stack[0])
        lb = _lane_step(kb, lb, qa1, qb1, rules[1], hyst[1], stack[1])
        lc = _lane_step(kc, lc, qa2, qb2, rules[2], hyst[2], stack[2])
        s40 = s30
        s41 = s31
        s42 = s32
        s30 = s20
        s31 = s21
        s32 = s22
        s20 = s10
        s21 = s11
        s22 = s12
        s10 = s00
        s11 = s01
        s12 = s02
        s00 = g0 * (la[0] + la[2])
        out_delta[0, n] = la[0]
        s01 = g1 * (lb[0] + lb[2])
        out_delta[1, n] = lb[0]
        s02 = g2 * (lc[0] + lc[2])
        out_delta[2, n] = lc[0]
        z0 = n0
        out_z[n, idx[0]] = n0
        z1 = n1
        out_z[n, idx[1]] = n1
        z2 = n2
        out_z[n, idx[2]] = n2
        z3 = n3
        out_z[n, idx[3]] = n3
        z4 = n4
        out_z[n, idx[4]] = n4
        z5 = n5
        out_z[n, idx[5]] = n5
    kexact._lane_store(state, 0, la)
    kexact._lane_store(state, 1, lb)
    kexact._lane_store(state, 2, lc)
    bstate[B_Z + idx[0]] = z0
    bstate[B_Z + idx[1]] = z1
    bstate[B_Z + idx[2]] = z2
    bstate[B_Z + idx[3]] = z3
    bstate[B_Z + idx[4]] = z4
    bstate[B_Z + idx[5]] = z5
    bstate[B_SM + 0] = s00
    bstate[B_SM + 1] = s01
    bstate[B_SM + 2] = s02
    bstate[B_SM + 3] = s10
    bstate[B_SM + 4] = s11
    bstate[B_SM + 5] = s12
    bstate[B_SM + 6] = s20
    bstate[B_SM + 7] = s21
    bstate[B_SM + 8] = s22
    bstate[B_SM + 9] = s30
    bstate[B_SM + 10] = s31
    bstate[B_SM + 11] = s32
    bstate[B_SM + 12] = s40
    bstate[B_SM + 13] = s41
    bstate[B_SM + 14] = s42
    bstate[B_REL + 0] = rel0
    bstate[B_RELR + 0] = relr0
    bstate[B_REL + 1] = rel1
    bstate[B_RELR + 1] = relr1
    bstate[B_REL + 2] = rel2
    bstate[B_RELR + 2] = relr2


@jit
def run_three_block_axes(j0, j1, q0s, q1s, cs, rules, state, hyst, stack, gain, umat, ax, ang, rate, volts, gk5, phi_a,
                         rate_a, bstate, out_delta, out_z):
    """:func:`run_three_block` for a block whose three rotation axes are independent (module docstring,
    "Axis-decoupled kernel"): written out in scalars (generated), so that the block's 2x2 steps, their inputs and
    the moment history stay in registers; the chassis' angular acceleration (the Hermite of ``ang, rate``, from
    ``phi_a, rate_a`` (3,) at ``t_{j0}``, updated) and the held piezo torques (``gk5 volts``, ``gk5``: (3,)
    ``gain k5``) are formed inside the step loop. ``ax`` (3, AX_SIZE): the per-axis
    coefficients (``BlockStep``). Writes rows 3-5 and 9-11 of ``out_z``."""
    ka = kexact._lane_constants(cs, 0)
    kb = kexact._lane_constants(cs, 1)
    kc = kexact._lane_constants(cs, 2)
    la = kexact._lane_load(state, 0, cs, rules[0], hyst[0], stack[0])
    lb = kexact._lane_load(state, 1, cs, rules[1], hyst[1], stack[1])
    lc = kexact._lane_load(state, 2, cs, rules[2], hyst[2], stack[2])
    h = ka[kexact.C_H]
    ih = 1.0 / h
    ih2 = ih * ih
    # axis 0: state, step matrix, inputs
    a0 = bstate[B_Z + 3]
    b0 = bstate[B_Z + 9]
    paa0 = ax[0, AX_PAA]
    pab0 = ax[0, AX_PAB]
    pba0 = ax[0, AX_PBA]
    pbb0 = ax[0, AX_PBB]
    ca00 = ax[0, AX_CA0]
    cb00 = ax[0, AX_CB0]
    ca10 = ax[0, AX_CA1]
    cb10 = ax[0, AX_CB1]
    ma0 = ax[0, AX_MA]
    mb0 = ax[0, AX_MB]
    ha10 = ax[0, AX_HA + 0]
    hb10 = ax[0, AX_HB + 0]
    ha20 = ax[0, AX_HA + 2]
    hb20 = ax[0, AX_HB + 2]
    ha30 = ax[0, AX_HA + 4]
    hb30 = ax[0, AX_HB + 4]
    ha40 = ax[0, AX_HA + 6]
    hb40 = ax[0, AX_HB + 6]
    m00 = bstate[B_SM + 0]
    m10 = bstate[B_SM + 3]
    m20 = bstate[B_SM + 6]
    m30 = bstate[B_SM + 9]
    m40 = bstate[B_SM + 12]
    pa0 = phi_a[0]
    ra0 = rate_a[0]
    # axis 1: state, step matrix, inputs
    a1 = bstate[B_Z + 4]
    b1 = bstate[B_Z + 10]
    paa1 = ax[1, AX_PAA]
    pab1 = ax[1, AX_PAB]
    pba1 = ax[1, AX_PBA]
    pbb1 = ax[1, AX_PBB]
    ca01 = ax[1, AX_CA0]
    cb01 = ax[1, AX_CB0]
    ca11 = ax[1, AX_CA1]
    cb11 = ax[1, AX_CB1]
    ma1 = ax[1, AX_MA]
    mb1 = ax[1, AX_MB]
    ha11 = ax[1, AX_HA + 0]
    hb11 = ax[1, AX_HB + 0]
    ha21 = ax[1, AX_HA + 2]
    hb21 = ax[1, AX_HB + 2]
    ha31 = ax[1, AX_HA + 4]
    hb31 = ax[1, AX_HB + 4]
    ha41 = ax[1, AX_HA + 6]
    hb41 = ax[1, AX_HB + 6]
    m01 = bstate[B_SM + 1]
    m11 = bstate[B_SM + 4]
    m21 = bstate[B_SM + 7]
    m31 = bstate[B_SM + 10]
    m41 = bstate[B_SM + 13]
    pa1 = phi_a[1]
    ra1 = rate_a[1]
    # axis 2: state, step matrix, inputs
    a2 = bstate[B_Z + 5]
    b2 = bstate[B_Z + 11]
    paa2 = ax[2, AX_PAA]
    pab2 = ax[2, AX_PAB]
    pba2 = ax[2, AX_PBA]
    pbb2 = ax[2, AX_PBB]
    ca02 = ax[2, AX_CA0]
    cb02 = ax[2, AX_CB0]
    ca12 = ax[2, AX_CA1]
    cb12 = ax[2, AX_CB1]
    ma2 = ax[2, AX_MA]
    mb2 = ax[2, AX_MB]
    ha12 = ax[2, AX_HA + 0]
    hb12 = ax[2, AX_HB + 0]
    ha22 = ax[2, AX_HA + 2]
    hb22 = ax[2, AX_HB + 2]
    ha32 = ax[2, AX_HA + 4]
    hb32 = ax[2, AX_HB + 4]
    ha42 = ax[2, AX_HA + 6]
    hb42 = ax[2, AX_HB + 6]
    m02 = bstate[B_SM + 2]
    m12 = bstate[B_SM + 5]
    m22 = bstate[B_SM + 8]
    m32 = bstate[B_SM + 11]
    m42 = bstate[B_SM + 14]
    pa2 = phi_a[2]
    ra2 = rate_a[2]
    rel0 = bstate[B_REL + 0]
    relr0 = bstate[B_RELR + 0]
    u00 = umat[0, 0]
    v00 = -umat[0, 0]
    u01 = umat[0, 1]
    v01 = -umat[0, 1]
    u02 = umat[0, 2]
    v02 = -umat[0, 2]
    g0 = gain[0]
    rel1 = bstate[B_REL + 1]
    relr1 = bstate[B_RELR + 1]
    u10 = umat[1, 0]
    v10 = -umat[1, 0]
    u11 = umat[1, 1]
    v11 = -umat[1, 1]
    u12 = umat[1, 2]
    v12 = -umat[1, 2]
    g1 = gain[1]
    rel2 = bstate[B_REL + 2]
    relr2 = bstate[B_RELR + 2]
    u20 = umat[2, 0]
    v20 = -umat[2, 0]
    u21 = umat[2, 1]
    v21 = -umat[2, 1]
    u22 = umat[2, 2]
    v22 = -umat[2, 2]
    g2 = gain[2]
    gk50 = gk5[0]
    gk51 = gk5[1]
    gk52 = gk5[2]
    for n in range(j0, j1):
        pz0 = gk50 * volts[0, n]  # the held piezo torques
        pz1 = gk51 * volts[1, n]
        pz2 = gk52 * volts[2, n]
        # axis 0: the chassis' angular acceleration over the step, P0 + P1 tau (as chassis_input)
        an0 = ang[0, n]
        rn0 = rate[0, n]
        sl0 = (an0 - pa0) * ih
        c00 = (6.0 * sl0 - 4.0 * ra0 - 2.0 * rn0) * ih
        c10 = 6.0 * (ra0 + rn0 - 2.0 * sl0) * ih2
        pa0 = an0
        ra0 = rn0
        mp0 = (v00 * pz0 + v10 * pz1) + v20 * pz2
        ia0 = ((ca00 * c00 + ca10 * c10) + ma0 * mp0) + ((ha10 * m10 + ha20 * m20) + (ha30 * m30 + ha40 * m40))
        ib0 = ((cb00 * c00 + cb10 * c10) + mb0 * mp0) + ((hb10 * m10 + hb20 * m20) + (hb30 * m30 + hb40 * m40))
        na0 = ia0 + (paa0 * a0 + pab0 * b0)
        nb0 = ib0 + (pba0 * a0 + pbb0 * b0)
        # axis 1: the chassis' angular acceleration over the step, P0 + P1 tau (as chassis_input)
        an1 = ang[1, n]
        rn1 = rate[1, n]
        sl1 = (an1 - pa1) * ih
        c01 = (6.0 * sl1 - 4.0 * ra1 - 2.0 * rn1) * ih
        c11 = 6.0 * (ra1 + rn1 - 2.0 * sl1) * ih2
        pa1 = an1
        ra1 = rn1
        mp1 = (v01 * pz0 + v11 * pz1) + v21 * pz2
        ia1 = ((ca01 * c01 + ca11 * c11) + ma1 * mp1) + ((ha11 * m11 + ha21 * m21) + (ha31 * m31 + ha41 * m41))
        ib1 = ((cb01 * c01 + cb11 * c11) + mb1 * mp1) + ((hb11 * m11 + hb21 * m21) + (hb31 * m31 + hb41 * m41))
        na1 = ia1 + (paa1 * a1 + pab1 * b1)
        nb1 = ib1 + (pba1 * a1 + pbb1 * b1)
        # axis 2: the chassis' angular acceleration over the step, P0 + P1 tau (as chassis_input)
        an2 = ang[2, n]
        rn2 = rate[2, n]
        sl2 = (an2 - pa2) * ih
        c02 = (6.0 * sl2 - 4.0 * ra2 - 2.0 * rn2) * ih
        c12 = 6.0 * (ra2 + rn2 - 2.0 * sl2) * ih2
        pa2 = an2
        ra2 = rn2
        mp2 = (v02 * pz0 + v12 * pz1) + v22 * pz2
        ia2 = ((ca02 * c02 + ca12 * c12) + ma2 * mp2) + ((ha12 * m12 + ha22 * m22) + (ha32 * m32 + ha42 * m42))
        ib2 = ((cb02 * c02 + cb12 * c12) + mb2 * mp2) + ((hb12 * m12 + hb22 * m22) + (hb32 * m32 + hb42 * m42))
        na2 = ia2 + (paa2 * a2 + pab2 * b2)
        nb2 = ib2 + (pba2 * a2 + pbb2 * b2)
        r0 = (u00 * na0 + u01 * na1) + u02 * na2
        rr0 = (u00 * nb0 + u01 * nb1) + u02 * nb2
        sl0 = (r0 - rel0) * ih
        qa0 = q0s[0, n] - (6.0 * sl0 - 4.0 * relr0 - 2.0 * rr0) * ih
        qb0 = q1s[0, n] - 6.0 * (relr0 + rr0 - 2.0 * sl0) * ih2
        rel0 = r0
        relr0 = rr0
        r1 = (u10 * na0 + u11 * na1) + u12 * na2
        rr1 = (u10 * nb0 + u11 * nb1) + u12 * nb2
        sl1 = (r1 - rel1) * ih
        qa1 = q0s[1, n] - (6.0 * sl1 - 4.0 * relr1 - 2.0 * rr1) * ih
        qb1 = q1s[1, n] - 6.0 * (relr1 + rr1 - 2.0 * sl1) * ih2
        rel1 = r1
        relr1 = rr1
        r2 = (u20 * na0 + u21 * na1) + u22 * na2
        rr2 = (u20 * nb0 + u21 * nb1) + u22 * nb2
        sl2 = (r2 - rel2) * ih
        qa2 = q0s[2, n] - (6.0 * sl2 - 4.0 * relr2 - 2.0 * rr2) * ih
        qb2 = q1s[2, n] - 6.0 * (relr2 + rr2 - 2.0 * sl2) * ih2
        rel2 = r2
        relr2 = rr2
        la = _lane_step(ka, la, qa0, qb0, rules[0], hyst[0], stack[0])
        lb = _lane_step(kb, lb, qa1, qb1, rules[1], hyst[1], stack[1])
        lc = _lane_step(kc, lc, qa2, qb2, rules[2], hyst[2], stack[2])
        t0 = g0 * (la[0] + la[2])
        t1 = g1 * (lb[0] + lb[2])
        t2 = g2 * (lc[0] + lc[2])
        out_delta[0, n] = la[0]
        out_delta[1, n] = lb[0]
        out_delta[2, n] = lc[0]
        m40 = m30
        m30 = m20
        m20 = m10
        m10 = m00
        m00 = (v00 * t0 + v10 * t1) + v20 * t2  # the moment on the block about axis 0
        a0 = na0
        b0 = nb0
        out_z[n, 3] = na0
        out_z[n, 9] = nb0
        m41 = m31
        m31 = m21
        m21 = m11
        m11 = m01
        m01 = (v01 * t0 + v11 * t1) + v21 * t2  # the moment on the block about axis 1
        a1 = na1
        b1 = nb1
        out_z[n, 4] = na1
        out_z[n, 10] = nb1
        m42 = m32
        m32 = m22
        m22 = m12
        m12 = m02
        m02 = (v02 * t0 + v12 * t1) + v22 * t2  # the moment on the block about axis 2
        a2 = na2
        b2 = nb2
        out_z[n, 5] = na2
        out_z[n, 11] = nb2
    kexact._lane_store(state, 0, la)
    kexact._lane_store(state, 1, lb)
    kexact._lane_store(state, 2, lc)
    bstate[B_Z + 3] = a0
    bstate[B_Z + 9] = b0
    bstate[B_SM + 0] = m00
    bstate[B_SM + 3] = m10
    bstate[B_SM + 6] = m20
    bstate[B_SM + 9] = m30
    bstate[B_SM + 12] = m40
    phi_a[0] = pa0
    rate_a[0] = ra0
    bstate[B_Z + 4] = a1
    bstate[B_Z + 10] = b1
    bstate[B_SM + 1] = m01
    bstate[B_SM + 4] = m11
    bstate[B_SM + 7] = m21
    bstate[B_SM + 10] = m31
    bstate[B_SM + 13] = m41
    phi_a[1] = pa1
    rate_a[1] = ra1
    bstate[B_Z + 5] = a2
    bstate[B_Z + 11] = b2
    bstate[B_SM + 2] = m02
    bstate[B_SM + 5] = m12
    bstate[B_SM + 8] = m22
    bstate[B_SM + 11] = m32
    bstate[B_SM + 14] = m42
    phi_a[2] = pa2
    rate_a[2] = ra2
    bstate[B_REL + 0] = rel0
    bstate[B_RELR + 0] = relr0
    bstate[B_REL + 1] = rel1
    bstate[B_RELR + 1] = relr1
    bstate[B_REL + 2] = rel2
    bstate[B_RELR + 2] = relr2

@jit
def _translation_at_rest(bstate, lin0, lin1, out_z):
    """Whether the block's translation (rows 0-2, 6-8 of ``z``) is at rest and no linear input moves it over the
    chunk; if so its rows of ``out_z`` are written as zeros. For a block whose mount does not couple translation and
    rotation that is exact: its step matrix and inputs from rotation, chassis rotation and torques are exact zeros
    (``BlockStep``)."""
    for k in range(3):
        if bstate[B_Z + k] != 0.0 or bstate[B_Z + 6 + k] != 0.0:
            return False
    for k in range(3):
        for j in range(lin0.shape[1]):
            if lin0[k, j] != 0.0 or lin1[k, j] != 0.0:
                return False
    for j in range(out_z.shape[0]):
        for k in range(3):
            out_z[j, k] = 0.0
            out_z[j, 6 + k] = 0.0
    return True


@jit
def propagate_translation_axes(ax, lin0, lin1, bstate, out_z):
    """The translation of an axis-decoupled block (``run_three_block_axes``) over the chunk: along each axis
    ``(x_k, x_k')`` by its 2x2 step under the chassis' linear acceleration ``a0 + a1 tau`` (``lin0, lin1``: (3, N)),
    rows 0-2 and 6-8 of ``out_z``. The gyros neither feel nor move it; at rest with no linear input over the chunk
    it stays exactly zero and is written as such without the steps."""
    if _translation_at_rest(bstate, lin0, lin1, out_z):
        return
    n = out_z.shape[0]
    for k in range(3):
        x = bstate[B_Z + k]
        xd = bstate[B_Z + 6 + k]
        taa = ax[k, AX_TAA]
        tab = ax[k, AX_TAB]
        tba = ax[k, AX_TBA]
        tbb = ax[k, AX_TBB]
        la0 = ax[k, AX_LA0]
        lb0 = ax[k, AX_LB0]
        la1 = ax[k, AX_LA1]
        lb1 = ax[k, AX_LB1]
        for j in range(n):
            a0 = lin0[k, j]
            a1 = lin1[k, j]
            nx = (la0 * a0 + la1 * a1) + (taa * x + tab * xd)
            xd = (lb0 * a0 + lb1 * a1) + (tba * x + tbb * xd)
            x = nx
            out_z[j, k] = x
            out_z[j, 6 + k] = xd
        bstate[B_Z + k] = x
        bstate[B_Z + 6 + k] = xd


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
                            q1s, used, gain, umat, phi, phit, tt, f0t, gch, idx, ridx, pos, ax, lin0, lin1, bstate, cin,
                            out_z, base_ang, base_rate, base_prev):
    """``chain.drive_plant_three`` with the three suspensions on one block (module docstring).

    The drive, detector and amplitude loop of each channel are those of ``chain.drive_plant_three`` (the same
    segments, ending wherever a channel ends an amplitude-control block); the plant steps are those of
    :func:`run_three_block`. ``ang, rate``: (3, n) the chassis angle and rate about block axes; ``lin0, lin1``:
    (3, n) the chassis linear acceleration at the c.g. and its slope over each step; ``f0t`` (12, 3): ``F0``'s torque
    columns, through which each segment's piezo torques (held, ``gain k5 V``) enter; the block matrices as
    ``BlockStep`` (``ax``: (3, AX_SIZE) for an axis-decoupled block, which then runs
    :func:`run_three_block_axes` and :func:`propagate_translation_axes` and leaves ``cin`` alone; (0, AX_SIZE)
    otherwise); ``bstate``: float64[B_SIZE]; ``cin``: (n, 12) a work buffer (the caller keeps it from chunk to
    chunk: a fresh 7 MB array per chunk costs its page faults); ``out_z``: (n, 12). ``base_ang, base_rate``:
    (3, n) the angle and rate of the frame that excites the block through its isolators (``ang, rate`` themselves
    when every angular profile enters at the chassis; without the profiles that enter at the block otherwise,
    ``sins_sim.simulation.unit.SideBySide.run``), ``base_prev`` (6,): their values at the chunk's start (zeros at
    rest), updated. Other arguments as ``chain.drive_plant_three``.
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
        phi0[a] = base_prev[a]
        rate0[a] = base_prev[3 + a]
    axes = ax.shape[0] == 3
    gk5 = np.empty(3)
    for a in range(3):
        gk5[a] = gain[a] * consts[a, kexact.C_K5]
    if not axes:
        chassis_input(base_ang, base_rate, phi0, rate0, consts[0, kexact.C_IH], consts[0, kexact.C_IH2], lin0, lin1,
                      gch, cin)
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
        if axes:  # the chassis' and the piezo inputs formed in the step loop; phi0, rate0 advance there
            run_three_block_axes(j, j + m, q0s, q1s, consts, rules, pstate, physt, pstack, gain, umat, ax, base_ang,
                                 base_rate, volts, gk5, phi0, rate0, bstate, delta, out_z)
        else:
            for k in range(j, j + m):  # the piezo torques, held over each step, through F0's torque columns
                p0 = gk5[0] * volts[0, k]
                p1 = gk5[1] * volts[1, k]
                p2 = gk5[2] * volts[2, k]
                for r in range(12):
                    cin[k, r] += f0t[r, 0] * p0 + f0t[r, 1] * p1 + f0t[r, 2] * p2
            if idx.shape[0] == 6 and tt.shape[0] == 4:
                run_three_block6(j, j + m, q0s, q1s, consts, rules, pstate, physt, pstack, gain, umat, phit, tt, idx,
                                 pos, cin, bstate, delta, out_z)
            else:
                run_three_block(j, j + m, q0s, q1s, consts, rules, pstate, physt, pstack, gain, umat, phit, tt, idx,
                                pos, cin, bstate, delta, out_z)
        for a in range(3):
            used[a] = kchain._close_segment(i0, j, m, delta[a][j:j + m], fpar[a], ipar[a], dstate[a], uniforms[a],
                                            used[a])
        j += m
    if n > 0:
        for a in range(3):
            base_prev[a] = base_ang[a, n - 1]
            base_prev[3 + a] = base_rate[a, n - 1]
    if axes:
        propagate_translation_axes(ax, lin0, lin1, bstate, out_z)
    elif ridx.shape[0] > 0 and not _translation_at_rest(bstate, lin0, lin1, out_z):
        # the rows the torques do not reach (the translation), from the chunk's start
        for r in range(12):
            bstate[B_Z + r] = bz0[r]
        propagate_rest(ridx, phi, cin, bstate, out_z)


@jit(inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    """``a x b`` of two vectors given by their components."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


# carry of :func:`block_truth` between chunks
T_THETA = 0  # theta at the last step, 3 values
T_XDOT = 3  # x' at the last step, 3 values
T_G = 6  # the second-order rate g at the last step, 3 values
T_C = 9  # its integral c, 3 values
T_THD = 12  # theta' at the last step, 3 values
T_WV = 15  # the rotating-frame integrand at the last step (w x (x' + w x x) and its third order), 3 values
T_WX = 18  # the boundary term w x x - theta x (w x x) + (1/2) theta x (theta x x') at the last step, 3 values
T_SIZE = 21


@jit
def block_truth(z, rate, lin0, lin1, umat, h, r, carry, add, dth, theta_avg, theta_end, dvel, xdot_end, x_end):
    """What the block's relative motion adds to the gyros and the truth, from its state at the plant steps.

    Frames and point. ``c``: the chassis (the truth's body frame without the block: the vehicle turned by the
    angular profiles that enter at the chassis), rotating at ``w`` (its inertial rate, chassis axes); ``b``: the
    block, turned from ``c`` by the small rotation vector ``theta``. The point is the block's c.g., where its
    accelerometers' specific force and the navigated position are taken; it sits at ``x`` (chassis axes, zero at
    rest) from the chassis point it rests on.

    Angle. The block's inertial rate in block axes is ``w_b = R(theta)^T w + J_r(theta) theta'``, to third order
    ``w + theta' + g`` with ``g = -theta x w - (1/2) theta x theta' + theta x ((1/2) theta x w + (1/6) theta x
    theta')`` (``R(theta)^T = I - [theta x] + [theta x]^2 / 2`` and the right Jacobian of the rotation vector
    ``J_r = I - [theta x] / 2 + [theta x]^2 / 6``, Bortz 1971; ``R(theta)^T w`` the chassis rate seen in the
    rocked block). Its integral beyond the chassis' own is ``theta + c`` with ``c = int g dt`` (trapezoid over
    the plant steps, error ``(w h)^2 / 12`` of a term that is itself second order in the arcsec-level
    ``theta``). The second-order part is what makes dither coning: it drifts when two axes rock at one frequency.
    The third order keeps the increments on the exact kinematics to fourth order (``tests/
    test_block_truth_combined.py`` checks them against ``R(theta)`` and ``J_r(theta)`` exactly); what is left out is
    below ``|theta|^3 |w| / 6``, 1e-10 rad/s for 250 arcsec of rocking on a chassis turning at 0.3 rad/s.

    Velocity. The c.g.'s position relative to the chassis point, ``C_ic x``, differentiated twice in the inertial
    frame (the theorem of Coriolis applied twice, motion with respect to a rotating frame: Groves 2013, sec. 2.3):
    velocity ``C_ic (x' + w x x)``, acceleration
    ``C_ic (x'' + 2 w x x' + w' x x + w x (w x x))``. So the block's accelerometers see

        ``f_b = (I - [theta x]) (f_c + x'' + 2 w x x' + w' x x + w x (w x x))``

    (``f_c`` the chassis' specific force; ``(I - [theta x])`` here stands for ``I - [theta x] + [theta x]^2 / 2``
    on ``x''`` and ``I - [theta x]`` on the rotating-frame terms: the third order, as for the angle). The three
    rotating-frame terms couple the chassis' rotation to the block's translation on its isolators: under angular
    and linear vibration at the chassis ``w x x'`` is the product of two vibrations (mm/s^2), which leaving out
    walked the velocity away from the truth's (``C_nc x'``, whose derivative holds ``w x x'``). Over a filter
    sample, with ``w' x x`` by parts (``int w' x x = Delta(w x x) - int w x x'``), they integrate to
    ``Delta(w x x) + int w x u dt`` with ``u = x' + w x x``; their third order to
    ``-Delta(theta x (w x x)) - int (theta x (w x u) - theta' x (w x x)) dt``, and that of ``x''`` to
    ``(1/2) Delta(theta x (theta x x')) - (1/2) int (theta' x (theta x x') + theta x (theta' x x')) dt`` (each
    integral by the trapezoid over the plant steps). The Earth-rate parts of ``w`` relative to the Earth are left
    out (the truth's velocity is taken with the inertial ``w``: ``7e-5 rad/s`` times a micrometre displacement).

    Tilt. ``int C_bc f_c dt`` is formed by the caller as ``(I - [theta_avg x] + [theta_avg x]^2 / 2) Delta v_c``
    (``simulation.unit.apply_block_to_truth``) with ``theta_avg`` the trapezoid mean of ``theta`` over the sample
    (the mean of the steps' ends alone lags by half a plant step: ``h theta' / 2`` against gravity and against the
    vibration it rocks with); the chassis' linear vibration ``a`` (``lin0``,
    ``lin1``: the fast part of ``f_c``) varies within the sample as ``theta`` does, and
    ``int (theta - theta_avg) x a dt`` (the same trapezoid) is subtracted here. What remains,
    ``(theta - theta_avg) x (f_c - a)``, is third order (``f_c - a`` is gravity turned by the chassis' arcsec-level
    rocking).

    Parameters
    ----------
    z : (n, 12)
        Block state at the ends of the plant steps (``run_three_block``).
    rate : (3, n)
        Chassis rate about block axes at the same steps (rad/s): ``w``.
    lin0, lin1 : (3, n)
        The chassis' linear vibration at each step's start and its slope over the step (m/s^2, m/s^3;
        ``CoupledPlant.step``); zeros when none enters at the chassis.
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
        ``theta`` averaged over each filter sample (trapezoid over its plant steps, both ends halved) and at its
        end (block axes, rad): the accelerometers' tilt and the block's attitude relative to the chassis.
    dvel : (3, m), filled
        What the block's relative motion adds to its accelerometers' velocity increment over each filter sample
        beyond ``(I - [theta_avg x]) Delta v_c`` (m/s):
        ``int (I - [theta x]) x'' dt = Delta x' - Delta(theta x x') + int theta' x x' dt`` (by parts), plus the
        rotating-frame terms ``Delta(w x x) + int w x (x' + w x x) dt``, plus the third orders (above), minus
        ``int (theta - theta_avg) x a dt``; each integral by the trapezoid over the plant steps (error
        ``(w h)^2 / 12`` of a second-order term).
        The ``theta x x''`` part is sculling: under chassis vibration the relative acceleration is as large as the
        chassis' own, and a rocking in phase with it rectifies (``(1/2) theta x''`` cos of their phase).
    xdot_end : (3, m), filled
        ``x' + w x x`` at the end of each filter sample (m/s, chassis axes): the block's c.g. velocity relative to
        the chassis point, seen from the inertial frame (cm/s under chassis vibration near the isolator modes).
    x_end : (3, m), filled
        ``x`` at the end of each filter sample (m, chassis axes): the block's c.g. displacement relative to the
        chassis (tens of micrometres under chassis vibration near the isolator modes), the position truth's part.
    """
    n = z.shape[0]
    th = np.empty(3)  # theta at the sample's start
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
    # theta x x' at the sample's start and theta' x x' at the last step (the sculling of the relative translation)
    cs0 = th[1] * xd[2] - th[2] * xd[1]
    cs1 = th[2] * xd[0] - th[0] * xd[2]
    cs2 = th[0] * xd[1] - th[1] * xd[0]
    q0 = carry[T_THD + 1] * xd[2] - carry[T_THD + 2] * xd[1]
    q1 = carry[T_THD + 2] * xd[0] - carry[T_THD] * xd[2]
    q2 = carry[T_THD] * xd[1] - carry[T_THD + 1] * xd[0]
    # the chassis frame's rotation: w x (x' + w x x) at the last step, and w x x at the sample's start
    iv0 = carry[T_WV]
    iv1 = carry[T_WV + 1]
    iv2 = carry[T_WV + 2]
    wx0 = carry[T_WX]
    wx1 = carry[T_WX + 1]
    wx2 = carry[T_WX + 2]
    pt0 = th[0]  # theta at the last step
    pt1 = th[1]
    pt2 = th[2]
    half_h = 0.5 * h
    for k in range(n // r):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        la0 = 0.0  # int a dt and int theta x a dt over the sample (trapezoid)
        la1 = 0.0
        la2 = 0.0
        ta0 = 0.0
        ta1 = 0.0
        ta2 = 0.0
        for jj in range(r):
            j = k * r + jj
            t0 = z[j, 3]
            t1 = z[j, 4]
            t2 = z[j, 5]
            d0 = z[j, 9]
            d1 = z[j, 10]
            d2 = z[j, 11]
            v0 = z[j, 6]
            v1 = z[j, 7]
            v2 = z[j, 8]
            p0 = d1 * v2 - d2 * v1
            p1 = d2 * v0 - d0 * v2
            p2 = d0 * v1 - d1 * v0
            w0 = rate[0, j]
            w1 = rate[1, j]
            w2 = rate[2, j]
            # the rotating-frame terms at this step: w x u with u = x' + w x x; then the third-order integrand
            # -theta x (w x u) + theta' x (w x x) - (1/2) theta' x (theta x x') - (1/2) theta x (theta' x x')
            wa0, wa1, wa2 = _cross(w0, w1, w2, z[j, 0], z[j, 1], z[j, 2])
            m0, m1, m2 = _cross(w0, w1, w2, v0 + wa0, v1 + wa1, v2 + wa2)
            ya0, ya1, ya2 = _cross(t0, t1, t2, m0, m1, m2)
            yb0, yb1, yb2 = _cross(d0, d1, d2, wa0, wa1, wa2)
            tx0, tx1, tx2 = _cross(t0, t1, t2, v0, v1, v2)
            yc0, yc1, yc2 = _cross(d0, d1, d2, tx0, tx1, tx2)
            yd0, yd1, yd2 = _cross(t0, t1, t2, p0, p1, p2)
            m0 += (yb0 - ya0) - 0.5 * (yc0 + yd0)
            m1 += (yb1 - ya1) - 0.5 * (yc1 + yd1)
            m2 += (yb2 - ya2) - 0.5 * (yc2 + yd2)
            a0 += half_h * ((q0 + p0) + (iv0 + m0))
            a1 += half_h * ((q1 + p1) + (iv1 + m1))
            a2 += half_h * ((q2 + p2) + (iv2 + m2))
            q0 = p0
            q1 = p1
            q2 = p2
            iv0 = m0
            iv1 = m1
            iv2 = m2
            # the chassis' linear vibration at the step's start and end, and theta x a there
            b0 = lin0[0, j]
            b1 = lin0[1, j]
            b2 = lin0[2, j]
            e0 = b0 + h * lin1[0, j]
            e1 = b1 + h * lin1[1, j]
            e2 = b2 + h * lin1[2, j]
            la0 += half_h * (b0 + e0)
            la1 += half_h * (b1 + e1)
            la2 += half_h * (b2 + e2)
            ta0 += half_h * ((pt1 * b2 - pt2 * b1) + (t1 * e2 - t2 * e1))
            ta1 += half_h * ((pt2 * b0 - pt0 * b2) + (t2 * e0 - t0 * e2))
            ta2 += half_h * ((pt0 * b1 - pt1 * b0) + (t0 * e1 - t1 * e0))
            pt0 = t0
            pt1 = t1
            pt2 = t2
            # g = -theta x w - (1/2) theta x theta' + theta x ((1/2) theta x w + (1/6) theta x theta')
            tw0, tw1, tw2 = _cross(t0, t1, t2, w0, w1, w2)
            td0, td1, td2 = _cross(t0, t1, t2, d0, d1, d2)
            g3a, g3b, g3c = _cross(t0, t1, t2, 0.5 * tw0 + td0 / 6.0, 0.5 * tw1 + td1 / 6.0, 0.5 * tw2 + td2 / 6.0)
            g[0] = (-tw0 - 0.5 * td0) + g3a
            g[1] = (-tw1 - 0.5 * td1) + g3b
            g[2] = (-tw2 - 0.5 * td2) + g3c
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
        # the trapezoid mean of theta: the start and the end halved, every step between
        m0 = (s0 + 0.5 * (th[0] - z[j, 3])) / r
        m1 = (s1 + 0.5 * (th[1] - z[j, 4])) / r
        m2 = (s2 + 0.5 * (th[2] - z[j, 5])) / r
        theta_avg[0, k] = m0
        theta_avg[1, k] = m1
        theta_avg[2, k] = m2
        # int (theta - theta_avg) x a dt
        ta0 -= m1 * la2 - m2 * la1
        ta1 -= m2 * la0 - m0 * la2
        ta2 -= m0 * la1 - m1 * la0
        e0 = z[j, 4] * z[j, 8] - z[j, 5] * z[j, 7]
        e1 = z[j, 5] * z[j, 6] - z[j, 3] * z[j, 8]
        e2 = z[j, 3] * z[j, 7] - z[j, 4] * z[j, 6]
        # w x x at the sample's end (the last step's w and x), and the boundary term
        # w x x - theta x (w x x) + (1/2) theta x (theta x x') of the integrals by parts
        f0, f1, f2 = _cross(rate[0, j], rate[1, j], rate[2, j], z[j, 0], z[j, 1], z[j, 2])
        ya0, ya1, ya2 = _cross(z[j, 3], z[j, 4], z[j, 5], 0.5 * e0 - f0, 0.5 * e1 - f1, 0.5 * e2 - f2)
        ya0 += f0
        ya1 += f1
        ya2 += f2
        dvel[0, k] = z[j, 6] - xd[0] - (e0 - cs0) + a0 + (ya0 - wx0) - ta0
        dvel[1, k] = z[j, 7] - xd[1] - (e1 - cs1) + a1 + (ya1 - wx1) - ta1
        dvel[2, k] = z[j, 8] - xd[2] - (e2 - cs2) + a2 + (ya2 - wx2) - ta2
        cs0 = e0
        cs1 = e1
        cs2 = e2
        wx0 = ya0
        wx1 = ya1
        wx2 = ya2
        for i in range(3):
            dth[i, k] = add[i, j] - prev_add[i]
            prev_add[i] = add[i, j]
            theta_end[i, k] = z[j, 3 + i]
            th[i] = z[j, 3 + i]
            xd[i] = z[j, 6 + i]
            x_end[i, k] = z[j, i]
        xdot_end[0, k] = xd[0] + f0
        xdot_end[1, k] = xd[1] + f1
        xdot_end[2, k] = xd[2] + f2
    if n > 0:
        for i in range(3):
            carry[T_THETA + i] = z[n - 1, 3 + i]
            carry[T_XDOT + i] = z[n - 1, 6 + i]
            carry[T_THD + i] = z[n - 1, 9 + i]
    carry[T_G] = gp0
    carry[T_G + 1] = gp1
    carry[T_G + 2] = gp2
    carry[T_C] = c0
    carry[T_C + 1] = c1
    carry[T_C + 2] = c2
    carry[T_WV] = iv0
    carry[T_WV + 1] = iv1
    carry[T_WV + 2] = iv2
    carry[T_WX] = wx0
    carry[T_WX + 1] = wx1
    carry[T_WX + 2] = wx2
