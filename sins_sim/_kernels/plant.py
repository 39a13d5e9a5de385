"""RK4 integrator of the dither suspension, eq. 2 (docs/theory/suspension.md, "Equation of motion (eq. 2)").

Equation of motion (eq. 2 divided by I, c/I = omega0^2)::

    d2(phi_rlg)/dt2 = -omega0^2 (delta + Nonl(delta) + Diss(delta) + k5 V + 2 zeta ddelta/dt / omega0)

with ``delta = phi_rlg - phi_sins``. The last term is an optional viscous
damping (``zeta = 0`` in the paper's model; used by the linear-resonance test
and the ``viscous_damping`` effect).

Integration scheme
------------------
The state is ``(delta, omega_rlg)``. Inside one plant step ``[t_n, t_n + h]``
the RLG angle is integrated relative to a moving origin ``phi_sins(t_n)``, and
the SINS angle is the cubic Hermite interpolant ``p(tau)`` of the grid samples
of angle and rate (4th-order accurate, the same order as RK4), so accumulated
angles never enter the arithmetic and recorded motion needs no derivatives
beyond the rate.

The drive voltage is held constant over the step (zero-order hold of the DAC
samples, docs/theory/suspension.md "Readout").

Eq. 10's branch (direction ``s``, amplitude ``a``) changes at turning points
of ``delta`` (and, for the Masing rule, where a minor loop closes). Such an
event is located inside the step: a trial RK4 step is taken with the branch
frozen; if ``d delta/dt`` changed sign (or ``delta`` passed the Masing
target), the event time is found as the root of the cubic Hermite interpolant
of the trial step (bisection, 48 halvings), the step is redone up to the
event, the branch is updated there, and integration continues to the grid
point. Updating only at the next grid point would make the scheme
first-order.
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit
from sins_sim._kernels.physics import (
    RULE_MASING,
    diss_jit,
    hyst_turn,
    masing_close,
    masing_target,
    nonl_jit,
)

# plant state layout
S_DELTA = 0
S_OMEGA = 1
S_PHI = 2
S_RATE = 3
S_TIME = 4
STATE_SIZE = 5

_MAX_EVENTS = 16
_BISECT = 48


@jit
def _hermite(tau, h, dp, r0, r1):
    """Cubic Hermite interpolant of the SINS angle over one step (origin at t_n).

    Returns ``(p, p', p'')`` at ``tau``; ``p(0) = 0``, ``p(h) = dp``,
    ``p'(0) = r0``, ``p'(h) = r1``.
    """
    t = tau / h
    t2 = t * t
    t3 = t2 * t
    p = (t3 - 2.0 * t2 + t) * h * r0 + (-2.0 * t3 + 3.0 * t2) * dp + (t3 - t2) * h * r1
    pd = (3.0 * t2 - 4.0 * t + 1.0) * r0 + (-6.0 * t2 + 6.0 * t) * dp / h + (3.0 * t2 - 2.0 * t) * r1
    pdd = ((6.0 * t - 4.0) * r0 + (-12.0 * t + 6.0) * dp / h + (6.0 * t - 2.0) * r1) / h
    return p, pd, pdd


@jit
def _accel(x, w, tau, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c):
    """d(omega_rlg)/dt, eq. 2, with the branch (s, a, c) of eq. 10 frozen."""
    p, pd, _ = _hermite(tau, h, dp, r0, r1)
    d = x - p
    dd = w - pd
    f = d + nonl_jit(d, k1, k2) + diss_jit(d, s, a, c, k3, k4) + k5 * volt + zeta2_w0 * dd
    return -w0sq * f


@jit
def _rk4(x, w, ta, tb, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c):
    """One classical RK4 step of (x, omega) from ``ta`` to ``tb`` inside the plant step."""
    hs = tb - ta
    tm = ta + 0.5 * hs
    a1 = _accel(x, w, ta, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c)
    x2 = x + 0.5 * hs * w
    w2 = w + 0.5 * hs * a1
    a2 = _accel(x2, w2, tm, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c)
    x3 = x + 0.5 * hs * w2
    w3 = w + 0.5 * hs * a2
    a3 = _accel(x3, w3, tm, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c)
    x4 = x + hs * w3
    w4 = w + hs * a3
    a4 = _accel(x4, w4, tb, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c)
    xn = x + hs / 6.0 * (w + 2.0 * w2 + 2.0 * w3 + w4)
    wn = w + hs / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return xn, wn


@jit
def _cubic(u, f0, f1, g0, g1, L):
    """Cubic Hermite on [0, L] with values f0, f1 and slopes g0, g1, at u."""
    t = u / L
    t2 = t * t
    t3 = t2 * t
    return (2.0 * t3 - 3.0 * t2 + 1.0) * f0 + (t3 - 2.0 * t2 + t) * L * g0 + (-2.0 * t3 + 3.0 * t2) * f1 + (t3 - t2) * L * g1


@jit
def _root(f0, f1, g0, g1, L):
    """First sign change of the cubic Hermite on [0, L] (f0, f1 of opposite signs), by bisection."""
    lo = 0.0
    hi = L
    flo = f0
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        fm = _cubic(mid, f0, f1, g0, g1, L)
        if (fm > 0.0) == (flo > 0.0) and fm != 0.0:
            lo = mid
            flo = fm
        else:
            hi = mid
    return hi


@jit
def plant_run(sins_angle, sins_rate, volts, h, w0sq, k1, k2, k3, k4, k5, zeta2_w0,
              rule, fast_dt, state, hyst, stack, out_delta):
    """Advance the suspension over ``len(volts)`` plant steps.

    Parameters
    ----------
    sins_angle, sins_rate : float64[N]
        SINS angle (rad) and rate (rad/s) at the grid points t_{n+1} .. t_{n+N};
        the values at t_n are in ``state``.
    volts : float64[N]
        Drive voltage held over each step (V).
    h : float
        Plant step (s).
    w0sq, k1, k2, k3, k4, k5, zeta2_w0 : float
        omega0^2, eq. 9/10/14 parameters, and 2 zeta / omega0.
    rule : int
        Hysteresis rule (``physics.RULE_PAPER`` or ``RULE_MASING``).
    fast_dt : float
        Half-cycles shorter than this are counted as "fast" (regime warning).
    state : float64[STATE_SIZE]
        ``delta, omega_rlg, phi_sins(t_n), rate_sins(t_n), t_n``; updated in place.
    hyst, stack : float64 arrays
        Hysteresis branch and reversal stack (see ``physics``); updated in place.
    out_delta : float64[N]
        Suspension deflection delta at t_{n+1} .. t_{n+N} (rad).
    """
    n_steps = volts.shape[0]
    d = state[S_DELTA]
    w = state[S_OMEGA]
    phi0 = state[S_PHI]
    r0 = state[S_RATE]
    t0 = state[S_TIME]
    for n in range(n_steps):
        phi1 = sins_angle[n]
        r1 = sins_rate[n]
        dp = phi1 - phi0
        volt = volts[n]
        # x: RLG angle relative to the origin phi_sins(t_n); x(0) = delta(t_n)
        x = d
        ta = 0.0
        for _ in range(_MAX_EVENTS):
            s = hyst[0]
            a = hyst[1]
            c = hyst[2]
            xb, wb = _rk4(x, w, ta, h, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c)
            pa, pda, pdda = _hermite(ta, h, dp, r0, r1)
            pb, pdb, pddb = _hermite(h, h, dp, r0, r1)
            da = x - pa
            dda = w - pda
            db = xb - pb
            ddb = wb - pdb
            if s == 0.0:
                # at rest so far: the first motion sets the direction, no turning point
                if ddb > 0.0:
                    hyst[0] = 1.0
                elif ddb < 0.0:
                    hyst[0] = -1.0
                x = xb
                w = wb
                break
            L = h - ta
            # candidate events: turning point (ddelta/dt changes sign) and Masing loop closure
            t_turn = 2.0 * h
            if ddb * s < 0.0:
                acc_a = _accel(x, w, ta, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c) - pdda
                acc_b = _accel(xb, wb, h, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c) - pddb
                t_turn = ta + _root(dda, ddb, acc_a, acc_b, L)
            t_close = 2.0 * h
            if rule == RULE_MASING:
                tgt = masing_target(hyst, stack)
                if not math.isnan(tgt) and (db - tgt) * s > 0.0 and (da - tgt) * s <= 0.0:
                    t_close = ta + _root(da - tgt, db - tgt, dda, ddb, L)
            if t_turn > h and t_close > h:
                x = xb
                w = wb
                break
            te = t_turn if t_turn <= t_close else t_close
            x, w = _rk4(x, w, ta, te, h, dp, r0, r1, volt, w0sq, k1, k2, k3, k4, k5, zeta2_w0, s, a, c)
            pe, _, _ = _hermite(te, h, dp, r0, r1)
            if t_turn <= t_close:
                hyst_turn(hyst, stack, rule, x - pe, t0 + te, fast_dt)
            else:
                masing_close(hyst, stack)
            ta = te
            if ta >= h:
                break
        d = x - dp
        phi0 = phi1
        r0 = r1
        t0 += h
        out_delta[n] = d
    state[S_DELTA] = d
    state[S_OMEGA] = w
    state[S_PHI] = phi0
    state[S_RATE] = r0
    state[S_TIME] = t0
