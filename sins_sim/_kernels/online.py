"""The online estimator's per-sample loop: complex envelopes and exponentially weighted normal equations.

Per filter sample ``n`` (``sins_sim.filters.online_estimator`` describes the model):

1. first differences ``dx_n = x_n - x_{n-1}``, ``dv_n = v_n - v_{n-1}`` (a steady rotation of the
   block becomes a constant, which the demodulation moves away from zero frequency);
2. demodulation at the drive frequency, ``z = d * exp(-i theta_n)`` with ``theta`` advancing by
   ``2 pi cyc`` per sample (phase kept in cycles modulo 1, so long runs do not lose bits);
3. a Hann low-pass of ``W`` taps (normalised to unit sum) and the factor
   ``2 / (1 - exp(-i 2 pi cyc))`` that undoes the difference: the complex amplitudes ``A`` of the
   readout and ``V`` of the drive (``x = Re(A exp(i theta))``);
4. trapezoid integrals over intervals of ``M`` samples of the regressors ``A``, ``u A``, ``u^2 A``
   and ``V`` (``u = |A| / a_ref - 1``, ``A`` in units of ``a_ref`` and ``V`` of ``v_ref``), so that
   the slow-flow equation ``dA/dt = (p0 + c1 u + c2 u^2) A + b V`` becomes
   ``A(end) - A(start) = p0 S_A + c1 S_uA + c2 S_uuA + b S_V`` (the integral method of
   continuous-time identification);
5. an interval whose every sample was valid waits for the next one: it is committed when that one
   closes valid too and dropped otherwise (the envelope low-pass lets a fault reach the interval
   before the fault's own, which is detected only once the amplitude has left the band; a window
   of at most one interval, ``W <= M``, keeps the fault's reach within one interval). A
   committed interval enters the normal equations
   ``R = lam R + phi phi^H``, ``r = lam r + phi^H y``, ``yy = lam yy + |y|^2`` and the amplitude
   moments ``m = lam m + (1, u, u^2, |V|)`` (``lam`` the forgetting factor per interval). An invalid
   interval (amplitude outside ``a_ref (1 +- band)``, drive at or beyond ``v_sat``, a non-finite
   input) is counted and left out: the equations keep what they held.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels._config import jit

# float state (``fs``)
F_PHASE = 0      # reference phase, cycles in [0, 1)
F_XPREV = 1      # last x
F_VPREV = 2      # last v
F_NPREV = 3      # 1.0 once a previous sample exists
F_FILLED = 4     # samples in the Hann history (up to W)
F_POS = 5        # ring position of the next sample
F_INT = 6        # samples done in the current interval
F_VALID = 7      # 1.0 while the current interval is valid
F_BAD_BAND = 8   # count of intervals left out: amplitude outside the band
F_BAD_SAT = 9    # ... the drive at saturation
F_BAD_NAN = 10   # ... a non-finite input
F_GOOD = 11      # count of intervals used
F_AMP = 12       # last amplitude |A| (rad)
F_VAMP = 13      # last drive amplitude |V| (V)
F_IM = 14        # the current interval's integrals of 1, u, u^2, |V| / v_ref (s), slots 14 .. 17
F_PEND = 18      # 1.0 while a closed valid interval waits for the next one (its moments: slots 19 .. 22)
F_PM = 19
N_FSTATE = 23

# complex state (``cs``)
C_AST = 0        # A at the interval's start (units of a_ref)
C_APREV = 1      # last A (units of a_ref)
C_UPREV = 2      # last u (real, stored in the real part)
C_VPREV = 3      # last V (units of v_ref)
C_SA = 4         # trapezoid integrals: A, u A, u^2 A, V
C_PPHI = 8       # the pending interval's regressors (4) and its y
C_PY = 12
N_CSTATE = 13

# parameters (``par``)
P_AREF = 0
P_VREF = 1
P_DT = 2
P_BAND = 3
P_VSAT = 4
P_LAM = 5
N_PAR = 6


@jit
def hann_taps(w, out):
    """``out[k] = sin^2(pi (k + 1/2) / w) / sum``, ``k = 0 .. w - 1``: the envelope low-pass."""
    s = 0.0
    for k in range(w):
        t = math.sin(math.pi * (k + 0.5) / w)
        out[k] = t * t
        s += out[k]
    for k in range(w):
        out[k] /= s


@jit
def envelope_normal_equations(x, v, cyc, m_int, par, taps, fs, cs, hx, hv, big_r, small_r, mom):
    """Advance the estimator over ``x`` (readout angle, rad) and ``v`` (drive, V) at ``cyc`` cycles/sample.

    ``hx``, ``hv``: complex rings of the demodulated differences (length ``W = len(taps)``);
    ``big_r`` (4, 4), ``small_r`` (4,) complex; ``mom`` (6,) real: forgetting-weighted sums of
    1, u, u^2, |V| / v_ref and |y|^2 (``mom[4]``), and the number of intervals' weight squared
    (``mom[5]``, for the effective sample count). All state is carried in the arrays, so the
    result does not depend on how a record is split into calls.
    """
    w = taps.shape[0]
    a_ref = par[P_AREF]
    v_ref = par[P_VREF]
    dt = par[P_DT]
    band = par[P_BAND]
    v_sat = par[P_VSAT]
    lam = par[P_LAM]
    ang = 2.0 * math.pi * cyc
    # 2 / (1 - exp(-i ang)): undo the first difference, and the 1/2 of demodulating a real cosine
    undo = 2.0 / (1.0 - complex(math.cos(ang), -math.sin(ang)))
    for n in range(x.shape[0]):
        xn = x[n]
        vn = v[n]
        if fs[F_NPREV] == 0.0:
            fs[F_XPREV] = xn
            fs[F_VPREV] = vn
            fs[F_NPREV] = 1.0
            continue
        dx = xn - fs[F_XPREV]
        dv = vn - fs[F_VPREV]
        fs[F_XPREV] = xn
        fs[F_VPREV] = vn
        ph = 2.0 * math.pi * fs[F_PHASE]
        e = complex(math.cos(ph), -math.sin(ph))
        p = fs[F_PHASE] + cyc
        fs[F_PHASE] = p - math.floor(p)
        pos = int(fs[F_POS])
        hx[pos] = dx * e
        hv[pos] = dv * e
        pos += 1
        if pos == w:
            pos = 0
        fs[F_POS] = pos
        if fs[F_FILLED] < w:
            fs[F_FILLED] += 1.0
            if fs[F_FILLED] < w:
                continue
        # Hann low-pass of the last w samples, oldest first; then back to the reference phase of now
        sx = 0j
        sv = 0j
        k = pos
        for j in range(w):
            sx += taps[j] * hx[k]
            sv += taps[j] * hv[k]
            k += 1
            if k == w:
                k = 0
        a = sx * undo / a_ref
        vv = sv * undo / v_ref
        amp = abs(a)
        u = amp - 1.0
        fs[F_AMP] = amp * a_ref
        fs[F_VAMP] = abs(vv) * v_ref
        finite = math.isfinite(a.real) and math.isfinite(a.imag) and math.isfinite(vv.real) and math.isfinite(vv.imag)
        if fs[F_INT] == 0.0:  # the interval starts here
            cs[C_AST] = a
            cs[C_APREV] = a
            cs[C_UPREV] = u
            cs[C_VPREV] = vv
            for i in range(4):
                cs[C_SA + i] = 0j
                fs[F_IM + i] = 0.0
            fs[F_VALID] = 1.0
            fs[F_INT] = 1.0
            if not finite:
                fs[F_VALID] = -3.0
            elif abs(u) > band:
                fs[F_VALID] = -1.0
            elif abs(vv) * v_ref >= v_sat:
                fs[F_VALID] = -2.0
            continue
        if not finite:
            fs[F_VALID] = -3.0
        elif fs[F_VALID] > 0.0:
            if abs(u) > band:
                fs[F_VALID] = -1.0
            elif abs(vv) * v_ref >= v_sat:
                fs[F_VALID] = -2.0
        if fs[F_VALID] > 0.0:
            a0 = cs[C_APREV]
            u0 = cs[C_UPREV].real
            h = 0.5 * dt
            cs[C_SA] += h * (a0 + a)
            cs[C_SA + 1] += h * (u0 * a0 + u * a)
            cs[C_SA + 2] += h * (u0 * u0 * a0 + u * u * a)
            cs[C_SA + 3] += h * (cs[C_VPREV] + vv)
            # amplitude moments along the interval (trapezoid, in seconds)
            fs[F_IM] += h * 2.0
            fs[F_IM + 1] += h * (u0 + u)
            fs[F_IM + 2] += h * (u0 * u0 + u * u)
            fs[F_IM + 3] += h * (abs(cs[C_VPREV]) + abs(vv))
        cs[C_APREV] = a
        cs[C_UPREV] = u
        cs[C_VPREV] = vv
        fs[F_INT] += 1.0
        if fs[F_INT] > m_int:  # m_int steps done: close the interval
            state = fs[F_VALID]
            if state > 0.0:
                if fs[F_PEND] > 0.0:  # the previous interval is confirmed: commit it
                    y = cs[C_PY]
                    for i in range(4):
                        small_r[i] = lam * small_r[i] + np.conj(cs[C_PPHI + i]) * y
                        for j in range(4):
                            big_r[i, j] = lam * big_r[i, j] + np.conj(cs[C_PPHI + i]) * cs[C_PPHI + j]
                    mom[4] = lam * mom[4] + abs(y) ** 2
                    mom[5] = lam * lam * mom[5] + 1.0
                    for i in range(4):
                        mom[i] = lam * mom[i] + fs[F_PM + i]
                    fs[F_GOOD] += 1.0
                for i in range(4):
                    cs[C_PPHI + i] = cs[C_SA + i]
                    fs[F_PM + i] = fs[F_IM + i]
                cs[C_PY] = a - cs[C_AST]
                fs[F_PEND] = 1.0
            else:
                fs[F_PEND] = 0.0  # the fault may have reached the pending interval through the low-pass
                if state == -1.0:
                    fs[F_BAD_BAND] += 1.0
                elif state == -2.0:
                    fs[F_BAD_SAT] += 1.0
                else:
                    fs[F_BAD_NAN] += 1.0
            fs[F_INT] = 0.0
