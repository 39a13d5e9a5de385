"""One gyro channel over one chunk in two kernel calls: drive and suspension, then readout and filters.

This is the engine's inner loop (``sins_sim.simulation.channel.ChannelChain``):
everything a channel does at the plant rate and at the filter rate, fused so
that a chunk costs two calls per axis (:func:`drive_plant`, :func:`readout_filters`)
instead of a Python loop over amplitude control blocks. The arithmetic is that of
the separate kernels, called in the same order on the same numbers, so the result
is bit-identical to composing
the public classes (``Plant``, ``Readout``, ``Decimator``, ``CorrectingFilter``,
``Eliminator``) by hand (``tests/test_engine.py`` checks it):

1. per amplitude-control block (``block`` plant steps, docs/theory/suspension.md
   "Equation of motion (eq. 2)", drive): the DAC cosine held over ``r_dac``
   steps (``drive.dac_cosine``), the suspension (``plant_exact``: eq. 2, 9,
   10, 14), the Hann-windowed synchronous detector (``drive.demod_accumulate``)
   and, at the block's end, the PI amplitude loop whose zero cancels the eq. 15
   pole (see ``end_block``);
2. the readout: ``floor((phi_rlg + noise) / q)`` at the plant rate, the
   anti-alias FIR and decimation (``fir.fir_decimate``), the drive through the
   same FIR so volts stay aligned (docs/theory/suspension.md "Readout");
3. the filters at the filter rate: eq. 5 in the unity-DC and the paper form
   (``correcting.correcting_run``) and the elliptic eliminator
   (``sos.sos_filter``).

The kernels are ``nogil``: the engine can run the three axes of a SINS on threads. Or it runs
them through :func:`drive_plant_three`, the three suspensions stepped side by side (the same
bits, about 15 % less time per channel and step), then :func:`readout_fir` per channel, the six
correcting filters side by side (``correcting.correcting_lanes``) and each eliminator: the
steps of :func:`readout_filters`, bit for bit.
Random numbers (readout noise, amplitude-modulation draws) are drawn by the
caller, per chunk, in stream order, so results do not depend on chunking.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels import correcting as kcor
from sins_sim._kernels import drive as kdrive
from sins_sim._kernels import fir as kfir
from sins_sim._kernels import plant_exact as kexact
from sins_sim._kernels import sos as ksos
from sins_sim._kernels._config import jit

# float parameters (``fpar``)
P_H = 0  # plant step (s)
P_W0SQ = 1  # omega0^2 (rad^2/s^2)
P_K1 = 2
P_K2 = 3
P_K3 = 4
P_K4 = 5
P_K5 = 6
P_Z = 7  # 2 zeta / omega0
P_FAST = 8  # quarter dither period (s), the regime counter's threshold
P_CYC_DAC = 9  # drive cycles per DAC sample
P_PHASE = 10  # drive phase (rad)
P_CYC_STEP = 11  # drive cycles per plant step
P_Q = 12  # readout quantum (rad)
P_SIGMA = 13  # readout noise (rad)
P_AM = 14  # target amplitude a_m (rad)
P_VM0 = 15  # open-loop drive amplitude (V)
P_TAU = 16  # eq. 15 amplitude time constant 2 Q / omega (s)
P_KP = 17  # PI gain tau / loop_time
P_BLOCK_S = 18  # block length (s)
P_VMAX = 19  # drive saturation (multiple of V_m0)
P_DEPTH = 20  # amplitude-modulation depth
P_CLOSED = 21  # 1.0: closed loop, 0.0: open loop
P_DPHASE = 22  # phase of the synchronous detector's reference (rad; 0 unless a tracking PLL moved the frequency)
N_FPAR = 23

# integer parameters (``ipar``)
I_RDAC = 0  # plant steps per DAC sample
I_BLOCK = 1  # plant steps per amplitude-control block
I_RULE = 2  # plant hysteresis rule
I_RDEC = 3  # decimation (plant steps per filter sample)
N_IPAR = 4

# drive / readout state (``dstate``)
D_VM = 0  # current drive amplitude (V)
D_TARGET = 1  # current amplitude target (rad)
D_INTEGRAL = 2  # PI integrator
D_AMP = 3  # last measured amplitude (rad)
D_LEFT = 4  # plant steps left in the current block
D_ACC = 5  # detector sums (3 values)
D_CARRY = 8  # phi_rlg at the last plant step of the previous chunk
D_PH_X = 9  # decimation phase of the readout FIR
D_PH_V = 10  # decimation phase of the volts FIR
N_DSTATE = 11

# correcting-filter parameters (``cpar[form]``)
C_A2 = 0
C_G = 1
C_K1 = 2  # k1..k5 at 2..6
C_DT = 7
C_FAST = 8
C_RULE = 9
N_CPAR = 10


@jit
def end_block(fpar, dstate, u):
    """Close an amplitude-control block (``ChannelChain`` drive control).

    Amplitude by synchronous detection ``a = 2 |sum w delta e^{-i w t}| / sum w``;
    with modulation depth ``d`` a new target ``a_m (1 + d u)``; closed loop:
    ``V_m = V_m0 (a_t / a_m + kp (e + (1/tau) int e dt))`` with
    ``e = (a_t - a) / a_m``, the integrator frozen while the drive saturates
    (anti-windup); open loop with modulation: ``V_m = V_m0 a_t / a_m``.
    """
    wsum = dstate[D_ACC + 2]
    if wsum > 0.0:
        dstate[D_AMP] = 2.0 * math.hypot(dstate[D_ACC], dstate[D_ACC + 1]) / wsum
    else:
        dstate[D_AMP] = 0.0
    a_m = fpar[P_AM]
    if fpar[P_DEPTH] > 0.0:
        dstate[D_TARGET] = a_m * (1.0 + fpar[P_DEPTH] * u)
    if fpar[P_CLOSED] > 0.0:
        err = (dstate[D_TARGET] - dstate[D_AMP]) / a_m
        integral = dstate[D_INTEGRAL] + err * fpar[P_BLOCK_S]
        uu = dstate[D_TARGET] / a_m + fpar[P_KP] * (err + integral / fpar[P_TAU])
        if 0.0 <= uu <= fpar[P_VMAX]:
            dstate[D_INTEGRAL] = integral
        dstate[D_VM] = min(max(uu, 0.0), fpar[P_VMAX]) * fpar[P_VM0]
    elif fpar[P_DEPTH] > 0.0:
        dstate[D_VM] = fpar[P_VM0] * dstate[D_TARGET] / a_m
    dstate[D_ACC] = 0.0
    dstate[D_ACC + 1] = 0.0
    dstate[D_ACC + 2] = 0.0


@jit
def _segment_forcing(i, ang, rate, volts, fpar, ipar, dstate, pstate, cs, q0s, q1s):
    """The DAC over a plant segment from absolute step ``i`` (into ``volts``) and the plant's forcing
    without ``F`` there (``plant_exact._forcing``, into ``q0s, q1s``; ``cs``: the ``_constants`` row)."""
    kdrive.dac_cosine(i, ipar[I_RDAC], fpar[P_CYC_DAC], fpar[P_PHASE], dstate[D_VM], volts)
    kexact._forcing(ang, rate, volts, pstate[kexact.X_PHI], pstate[kexact.X_RATE], cs[kexact.C_IH], cs[kexact.C_IH2],
                    cs[kexact.C_W0SQ], cs[kexact.C_K5], q0s, q1s)


@jit
def _close_segment(i0, j, m, delta, fpar, ipar, dstate, uniforms, used):
    """The synchronous detector over a plant segment that ends at or before the block's end, and the
    amplitude loop when it ends there (step 1 of the module docstring). Returns the uniforms used."""
    block = ipar[I_BLOCK]
    acc = dstate[D_ACC:D_ACC + 3]
    kdrive.demod_accumulate(delta, i0 + j, fpar[P_CYC_STEP], block - int(dstate[D_LEFT]), block, acc, fpar[P_DPHASE])
    return _advance_block(m, fpar, ipar, dstate, uniforms, used)


@jit
def _advance_block(m, fpar, ipar, dstate, uniforms, used):
    """``m`` plant steps of the current amplitude-control block done; at its end the amplitude loop."""
    left = int(dstate[D_LEFT]) - m
    if left == 0:
        end_block(fpar, dstate, uniforms[used])
        used += 1
        left = ipar[I_BLOCK]
    dstate[D_LEFT] = left
    return used


@jit
def drive_plant(i0, ang, rate, uniforms, fpar, ipar, dstate, pstate, physt, pstack, delta, volts):
    """Step 1 of the module docstring for one channel: drive, suspension, detector, amplitude loop.

    Parameters
    ----------
    i0 : int
        Absolute index of the first plant step of the chunk.
    ang, rate : float64[n]
        Block angle about the sensitive axis (rad) and its rate (rad/s) at the ends of the
        steps ``i0 + 1 .. i0 + n``.
    uniforms : float64[nb]
        Uniform draws on [-1, 1], one per block that ends in this chunk, in order.
    fpar, ipar : float64[N_FPAR], int64[N_IPAR]
        Parameters (layouts above).
    dstate : float64[N_DSTATE]
        Drive and readout state, updated in place.
    pstate, physt, pstack : float64 arrays
        Suspension state and its hysteresis branch and reversal stack (``plant_exact``).
    delta, volts : float64[n]
        Filled: the deflection (rad) and the drive (V) at the plant steps.

    Returns
    -------
    int
        Number of uniforms consumed (blocks closed).
    """
    n = ang.shape[0]
    consts = np.empty((1, kexact.N_CONSTS))
    kexact._constants(consts, 0, fpar[P_H], fpar[P_W0SQ], fpar[P_K1], fpar[P_K2], fpar[P_K3], fpar[P_K4],
                      fpar[P_K5], fpar[P_Z], fpar[P_FAST])
    cs = consts[0]
    q0s = np.empty(n)
    q1s = np.empty(n)
    used = 0
    j = 0
    while j < n:
        m = min(int(dstate[D_LEFT]), n - j)
        aa = ang[j:j + m]
        rr = rate[j:j + m]
        vv = volts[j:j + m]
        _segment_forcing(i0 + j, aa, rr, vv, fpar, ipar, dstate, pstate, cs, q0s[:m], q1s[:m])
        kexact._run_axis(aa, rr, vv, q0s[:m], q1s[:m], cs, ipar[I_RULE], pstate, physt, pstack, delta[j:j + m])
        used = _close_segment(i0, j, m, delta[j:j + m], fpar, ipar, dstate, uniforms, used)
        j += m
    return used


@jit
def drive_plant_three(i0, ang, rate, uniforms, fpar, ipar, dstate, pstate, physt, pstack, delta, volts, q0s, q1s,
                      used):
    """:func:`drive_plant` for the three channels of a SINS at once, their suspensions side by side.

    Row ``a`` of every argument belongs to channel ``a`` (``ang, rate, delta, volts``: (3, n);
    ``uniforms``: (3, nb) with at least as many columns as any channel closes blocks;
    ``q0s, q1s``: (3, n) work buffers for the plant's forcing; ``used``: int64[3], the
    uniforms each channel consumed, written). The plant runs over
    segments that end wherever one of the channels ends an amplitude-control block, the three
    suspensions stepped in turn (``plant_exact.run_three``); every channel gets the arithmetic
    of :func:`drive_plant`, bit for bit (the plant, the DAC and the detector do not depend on
    how a block is split into calls). Row pieces are taken as ``x[a][j:k]``: a row of a
    C-contiguous array is C-contiguous, so the per-channel kernels get their contiguous
    specialisation (``x[a, j:k]`` would be typed as of any layout, strided code).
    """
    n = ang.shape[1]
    consts = np.empty((3, kexact.N_CONSTS))
    rules = np.empty(3, dtype=np.int64)
    for a in range(3):
        f = fpar[a]
        kexact._constants(consts, a, f[P_H], f[P_W0SQ], f[P_K1], f[P_K2], f[P_K3], f[P_K4], f[P_K5], f[P_Z],
                          f[P_FAST])
        rules[a] = ipar[a, I_RULE]
        used[a] = 0
    j = 0
    while j < n:
        m = n - j
        for a in range(3):
            m = min(m, int(dstate[a, D_LEFT]))
        for a in range(3):
            _segment_forcing(i0 + j, ang[a][j:j + m], rate[a][j:j + m], volts[a][j:j + m], fpar[a], ipar[a], dstate[a],
                             pstate[a], consts[a], q0s[a][j:j + m], q1s[a][j:j + m])
            pstate[a, kexact.X_PHI] = ang[a, j + m - 1]  # run_three leaves the segment's end to the caller
            pstate[a, kexact.X_RATE] = rate[a, j + m - 1]
        kexact.run_three(j, j + m, q0s, q1s, consts, rules, pstate, physt, pstack, delta)
        for a in range(3):
            used[a] = _close_segment(i0, j, m, delta[a][j:j + m], fpar[a], ipar[a], dstate[a], uniforms[a], used[a])
        j += m


@jit
def readout_filters(ang, noise, fpar, ipar, dstate, taps, fhist, vhist, cpar, fstate, fhyst, fstack, sos, zi,
                    delta, volts, feed, x, vx, y_unity, y_paper, e_out):
    """Steps 2 and 3 of the module docstring for one channel, after :func:`drive_plant`.

    Parameters
    ----------
    ang, delta, volts : float64[n]
        Block angle (rad), deflection (rad) and drive (V) at the plant steps of the chunk.
    noise : float64[n] or float64[0]
        Standard normal draws for the readout noise (empty when ``sigma = 0``).
    fpar, ipar, dstate : arrays
        As :func:`drive_plant` (the readout's carry and FIR phases live in ``dstate``).
    taps, fhist, vhist : float64 arrays
        Anti-alias FIR taps and the histories of the readout and volts FIRs.
    cpar : float64[2, N_CPAR]
        Correcting-filter parameters, unity-DC form first, then the paper form.
    fstate, fhyst, fstack : float64[2, ...]
        Their states.
    sos, zi : float64 arrays
        Eliminator sections and state.
    feed : float64[n]
        Work buffer (the readout input), left filled.
    x, vx, y_unity, y_paper, e_out : float64[m]
        Filter-rate outputs (``m = n / R``, whole): readout angle, volts, the two correcting
        forms, the eliminator.
    """
    readout_fir(ang, noise, fpar, ipar, dstate, taps, fhist, vhist, delta, volts, feed, x, vx)
    for f in range(2):
        out = y_unity if f == 0 else y_paper
        c = cpar[f]
        kcor.correcting_run(x, vx, c[C_A2], c[C_G], c[C_K1], c[C_K1 + 1], c[C_K1 + 2], c[C_K1 + 3], c[C_K1 + 4],
                            c[C_DT], int(c[C_RULE]), c[C_FAST], fstate[f], fhyst[f], fstack[f], out)
    ksos.sos_filter(sos, x, zi, e_out)


@jit
def readout_fir(ang, noise, fpar, ipar, dstate, taps, fhist, vhist, delta, volts, feed, x, vx):
    """Step 2 of the module docstring for one channel: the readout and its anti-alias FIRs.

    Arguments as :func:`readout_filters`; ``x`` and ``vx`` receive the filter-rate readout angle
    and drive, the inputs of the filters (step 3).
    """
    n = ang.shape[0]
    # readout: fringe counts of phi_rlg = block angle + deflection, one plant step late
    q = fpar[P_Q]
    sigma = fpar[P_SIGMA]
    carry = dstate[D_CARRY]
    for k in range(n):
        phi = carry
        carry = ang[k] + delta[k]
        if sigma > 0.0:
            phi = phi + sigma * noise[k]
        feed[k] = math.floor(phi / q) * q
    dstate[D_CARRY] = carry
    r = ipar[I_RDEC]
    _, ph = kfir.fir_decimate(taps, feed, fhist, int(dstate[D_PH_X]), x, r)
    dstate[D_PH_X] = ph
    _, ph = kfir.fir_decimate(taps, volts, vhist, int(dstate[D_PH_V]), vx, r)
    dstate[D_PH_V] = ph


@jit
def plant_run_rate(sins_angle, sins_rate, volts, h, w0sq, k1, k2, k3, k4, k5, zeta2_w0, rule, fast_dt,
                   state, hyst, stack, out_delta, out_ddelta):
    """``plant_exact.plant_run_exact`` one step at a time, also returning ``d delta/dt`` at every grid point.

    The effect stages of :class:`~sins_sim.simulation.channel.ChannelChain` need the RLG rate at
    the plant grid (lock-in integrates the Adler equation between grid points with a cubic
    Hermite angle; a delayed readout interpolates with it). The exact integrator carries
    ``d delta/dt`` in its state, so stepping it one step per call gives the rate exactly and
    causally (no finite difference that would need the next chunk), with the same arithmetic per
    step as the whole-array call (the plant is chunk-invariant bit for bit).

    Parameters
    ----------
    sins_angle, sins_rate, volts, h, w0sq, k1, k2, k3, k4, k5, zeta2_w0, rule, fast_dt, state, hyst, stack
        As ``plant_exact.plant_run_exact``.
    out_delta, out_ddelta : float64[N]
        ``delta`` (rad) and ``d delta/dt`` (rad/s) at the grid points ``t_{n+1} .. t_{n+N}``.
    """
    n = volts.shape[0]
    consts = np.empty((1, kexact.N_CONSTS))
    kexact._constants(consts, 0, h, w0sq, k1, k2, k3, k4, k5, zeta2_w0, fast_dt)
    cs = consts[0]
    q0s = np.empty(1)
    q1s = np.empty(1)
    for k in range(n):
        aa = sins_angle[k:k + 1]
        rr = sins_rate[k:k + 1]
        vv = volts[k:k + 1]
        kexact._forcing(aa, rr, vv, state[kexact.X_PHI], state[kexact.X_RATE], cs[kexact.C_IH], cs[kexact.C_IH2],
                        cs[kexact.C_W0SQ], cs[kexact.C_K5], q0s, q1s)
        kexact._run_axis(aa, rr, vv, q0s, q1s, cs, rule, state, hyst, stack, out_delta[k:k + 1])
        out_ddelta[k] = state[kexact.X_DDELTA]
