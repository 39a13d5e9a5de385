"""Exact-oscillator ("exponential") integrator of the dither suspension, eq. 2.

Where each equation comes from
------------------------------
- Eq. 2 of the paper divided by the moment of inertia (docs/theory/suspension.md,
  "Equation of motion (eq. 2)", with ``c/I = omega0^2``), written for the
  deflection ``delta = phi_rlg - phi_sins``::

      delta'' = -omega0^2 delta - p''(t) - omega0^2 (F(delta, delta') + k5 V)
      F       = Nonl(delta) + Diss(delta) + 2 zeta delta' / omega0

  ``Nonl`` is eq. 9, ``Diss`` eq. 10 (branch ``s, a, c`` from
  ``physics``), ``k5 V`` eq. 14; the viscous ``zeta`` term is the optional
  damping of ``_kernels.plant``. ``p(tau)`` is the SINS angle over the step,
  relative to its value at the step's start.
- ``p`` is the cubic Hermite interpolant of the SINS angle and rate samples
  at both ends of the step, exactly as in the RK4 kernel
  (``_kernels.plant._hermite``); its second derivative is linear in ``tau``:
  ``p''(tau) = P0 + P1 tau`` with ``P0 = (6 dp/h - 4 r0 - 2 r1)/h`` and
  ``P1 = 6 (r0 + r1 - 2 dp/h)/h^2``.
- The drive is held over the step (zero-order hold, docs/theory/suspension.md
  "Readout"), so ``k5 V`` is a constant of the step.

Scheme
------
The linear part ``delta'' = -omega0^2 delta + g(tau)`` is integrated exactly
(variation of constants). For a forcing given by its Taylor coefficients,
``g(tau) = sum_k g_k tau^k / k!``, the state after a span ``L`` is::

    delta(L)  = E0 delta + E1 delta' + sum_k g_k E_{k+2}
    delta'(L) = -omega0^2 E1 delta + E0 delta' + sum_k g_k E_{k+1}

with ``E_j(L) = sum_m (-omega0^2)^m L^(2m+j) / (2m+j)!`` (so ``E0 = cos``,
``E1 = sin / omega0`` and ``E_{k+2} = int_0^L sin(omega0 (L - u))/omega0
u^k/k! du``): the convolution of the oscillator's kernel with a polynomial,
evaluated by its power series (:func:`phi_functions`), which has no
cancellation at small ``omega0 L``. The kinematic input ``-p''`` is a linear
polynomial and the drive a constant, so both enter exactly.

Only the small terms ``F`` (about 1 % of the spring force) are approximated,
by the quadratic through three values of ``F`` in time, whose convolution
with the oscillator is again exact (weights ``-omega0^2 E_{k+2}``,
:func:`_quadratic_weights`, :func:`_history_weights`). ``F`` at a node is
evaluated at a predicted state: the state propagated with ``F`` extrapolated
linearly from the two latest known values. The corrected state uses the
predicted ``F`` values; ``F`` at the predicted end of a step is the next
step's starting value (predict-evaluate-correct). The predictor's error
enters only through ``F``'s slope, ``dF/d delta ~ 0.02``, times a weight of
``(omega0 h)^2 ~ 1e-3``, so one correction suffices.

- Regular step, ``F`` known at ``-h`` and ``0``: ``F`` is evaluated at the
  predicted end ``h``. If eq. 10's ``1 - u^2`` (``u = (delta - c)/a``)
  exceeds ``R_SMOOTH`` at all three nodes, ``F`` is smooth there and the
  quadratic through ``F(-h), F(0), F(h)`` corrects (one evaluation per
  step; error ``h^3 F^(3) / 24``). Otherwise (near a turning point, a clamp
  of eq. 10's square root, a Masing closure) ``F`` is also evaluated at the
  predicted midpoint and the quadratic through ``F(0), F(h/2), F(h)``
  (Simpson's nodes) corrects: a stencil inside the step, as close as
  possible to a square-root singularity without crossing it.
- Self-starting span (from rest, and the spans before and after an event):
  midpoint predicted with ``F`` held, end predicted with ``F`` linear
  through ``F(0)`` and ``F(L/2)``, then the same Simpson correction
  (:func:`_span_step`, a three-stage exponential Runge-Kutta step).

The result is third order in the smooth parts (``(omega0 h)^3/24 ~ 2e-6`` of
the small terms' effect at 72 kHz, e.g. 2e-6 of eq. 9's 0.6 % frequency
shift); at eq. 10's square-root clamps no polynomial in time is accurate and
the local error is ``O(h^1.5)``, as for RK4 (``tests/test_plant.py``).
Against RK4 at 288 kHz the 72 kHz result agrees within 0.003 arcsec RMS for
a 3 arcmin dither from rest under a 1 arcmin vibration at 100 Hz or 1.5 kHz,
with both hysteresis rules (``tests/test_plant_exact.py``).

Events (turning points of ``delta``, Masing loop closures) are handled as in
the RK4 kernel (``_kernels.plant``): a trial step with the branch frozen; if
an event lies inside, its time is the root of the cubic Hermite interpolant
of the trial step (Newton's method kept in a bracket), the span up to it is
integrated again (self-starting; towards a Masing closure in pieces halving
towards it, ``_GRADE`` times, because eq. 10's square root vanishes there),
the branch is updated there by ``physics.hyst_turn`` / ``masing_close``,
``F`` is evaluated under the new branch, and the rest of the step follows.
Two refinements of the RK4 kernel's event test (:func:`_find_event`): a
closure is looked for up to the turning point, not only at the span's end
(a path that passes the Masing target and turns back inside one step closes
the loop before it reverses), and two turning points inside one step (a
small wiggle near an extremum, from vibration) are found from the interior
minimum of the cubic of ``delta'``. An event breaks the smoothness of ``F``
(eq. 10 jumps), so the history never reaches back across one: the step
after an event uses the event point itself as its earlier node when it lies
at least ``h / 4`` back (with the Simpson correction), and starts afresh
otherwise.

Eq. 9, ``k1 (sgn(d) (sqrt(1 + |d|/k2) - 1) - d / (2 k2))``, is evaluated
as ``k1s sqrt(1 + |d|/k2) - (k1s + kl d)`` with ``k1s = sgn(d) k1`` and
``kl = k1 / (2 k2)``: one square root, no division, one operation between
the root and ``F``; the subtraction loses relative precision for tiny ``d``
but its absolute error is below ``k1 * 1e-16`` rad, far under any effect in
the model. Eq. 10 uses ``1/a`` and ``s k3 a (1 + k4 a)``, recomputed only
when the branch changes. The viscous term is added only when ``zeta != 0``.

Cost per step (:func:`_run_axis`): the forcing without ``F``,
``q0 + q1 tau`` (kinematic input and drive), depends on the inputs only and
is computed for the whole chunk first (:func:`_forcing`, a loop without
dependencies between steps); the per-step constants (``E(h)``, ``E(h/2)``,
the quadratic weights, and the predictor's weights, so that a prediction
is the state without ``F`` minus two products) are computed once per call
(:func:`_constants`); the state lives in local variables over the chunk;
``F`` at a step's end is the next step's ``F(0)`` (first same as last); a
cheap screen of :func:`_find_event`'s conditions keeps the common step (no
event) inline, and events leave the loop for :func:`_find_event` /
:func:`_step_events`. :func:`plant_run_exact_many` runs several independent
suspensions, each over the whole chunk in turn, bit for bit as
:func:`plant_run_exact` runs each alone; :func:`run_three` advances three
side by side, one step of each in turn (the step is a dependency chain of
about 70 processor cycles, so the processor overlaps the three), again bit
for bit.

State layout (``state``, float64[STATE_SIZE]): ``delta``, ``delta'``,
``phi_sins(t_n)``, ``rate_sins(t_n)``, ``t_n`` (as ``_kernels.plant`` for
indices 0, 2, 3, 4; index 1 is the deflection rate, not the RLG rate);
``F`` at ``t_n``; ``F`` at the earlier node and that node's distance before
``t_n`` (0: no usable history); eq. 10's ``1 - u^2`` at ``t_n`` and at the
earlier node. All zeros is rest at t = 0.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels._config import jit
from sins_sim._kernels.physics import RULE_MASING, hyst_turn, masing_close, masing_target

# state layout (0, 2, 3, 4 as in _kernels.plant)
X_DELTA = 0
X_DDELTA = 1
X_PHI = 2
X_RATE = 3
X_TIME = 4
X_F0 = 5
X_FPREV = 6
X_LPREV = 7
X_R0 = 8
X_RPREV = 9
STATE_SIZE = 10

EVENT_NONE = 0
EVENT_TURN = 1
EVENT_CLOSE = 2

_MAX_EVENTS = 16
#: The span before a Masing closure is integrated in pieces halving towards the closure
#: (eq. 10 has a square-root singularity there); this many halvings.
_GRADE = 6
#: The previous node must lie at least this fraction of a step back to be used.
_MIN_HISTORY = 0.25
#: Eq. 10's ``1 - u^2`` above this at -h, 0 and h: one evaluation of F per step (see module docstring).
R_SMOOTH = 0.25
_NEWTON_ITERATIONS = 60
#: 1/(2m+3)! and 1/(2m+4)!, m = 0..9: the series of E_3 and E_4 (|omega0 L| <= pi/4 needs 9 terms).
_INV_FACT_3 = tuple([1.0 / math.factorial(2 * m + 3) for m in range(10)])
_INV_FACT_4 = tuple([1.0 / math.factorial(2 * m + 4) for m in range(10)])


@jit
def phi_functions(w0sq, span):
    """``(E_0, .., E_4)`` at ``span`` (see the module docstring).

    ``E_j(L) = sum_m (-omega0^2)^m L^(2m+j) / (2m+j)!``: ``E_0 = cos(omega0 L)``,
    ``E_1 = sin(omega0 L)/omega0``, ``E_j' = E_{j-1}``. ``E_3`` and ``E_4``
    are summed by Horner's rule (10 terms: exact to rounding for
    ``omega0 L <= pi/4``, the plant's limit of 8 steps per period); the
    others follow from ``E_j = L^j/j! - omega0^2 E_{j+2}``, where the
    correction is small, so nothing cancels.

    Parameters
    ----------
    w0sq : float
        omega0^2 (rad^2/s^2).
    span : float
        L (s), >= 0.

    Returns
    -------
    tuple of 5 float
    """
    z = -w0sq * span * span
    s3 = _INV_FACT_3[9]
    s4 = _INV_FACT_4[9]
    for m in range(8, -1, -1):
        s3 = _INV_FACT_3[m] + z * s3
        s4 = _INV_FACT_4[m] + z * s4
    l2 = span * span
    e3 = l2 * span * s3
    e4 = l2 * l2 * s4
    e2 = 0.5 * l2 - w0sq * e4
    e1 = span - w0sq * e3
    e0 = 1.0 - w0sq * e2
    return e0, e1, e2, e3, e4


@jit
def _force(d, dd, k1, kl, k2inv, kd, ainv, c, z):
    """``F = Nonl(d) + Diss(d) + z dd``: eq. 9, eq. 10 on the frozen branch, viscous term.

    ``kl = k1 / (2 k2)``, ``k2inv = 1/k2``, ``kd = s k3 a (1 + k4 a)``,
    ``ainv = 1/a`` (0 without a branch), ``c`` the branch centre,
    ``z = 2 zeta / omega0``.
    """
    k1s = k1 if d >= 0.0 else -k1
    nl = k1s * math.sqrt(1.0 + abs(d) * k2inv) - (k1s + kl * d)  # eq. 9, see the module docstring
    u = (d - c) * ainv
    r = 1.0 - u * u
    ds = kd * math.sqrt(max(r, 0.0))  # clamped at r <= 0: kd * 0 (+-0 changes no sum), no branch
    if z != 0.0:
        return nl + ds + z * dd, r
    return nl + ds, r


@jit
def _span_step(d, dd, span, e, eh, q0, q1, f0, w0sq, k1, kl, k2inv, kd, ainv, c, z):
    """Self-starting three-stage step over ``span`` (``e = E(span)``, ``eh = E(span/2)``).

    ``q0 + q1 tau`` is the forcing without ``F`` (``-p'' - omega0^2 k5 V``,
    tau from the span's start), ``f0 = F`` at the start. ``F`` is evaluated
    at the midpoint (state predicted with ``F`` held) and at the end
    (predicted with ``F`` linear); the quadratic through the three values
    gives the corrected end state. Returns it and ``F`` at the predicted end.
    """
    e0, e1, e2, e3, e4 = e
    h0, h1, h2, h3, _ = eh
    g0 = q0 - w0sq * f0
    dm = h0 * d + h1 * dd + h2 * g0 + h3 * q1
    ddm = h0 * dd - w0sq * h1 * d + h1 * g0 + h2 * q1
    fm, _ = _force(dm, ddm, k1, kl, k2inv, kd, ainv, c, z)
    inv = 1.0 / span
    g1 = q1 - w0sq * (2.0 * (fm - f0) * inv)
    dp = e0 * d + e1 * dd + e2 * g0 + e3 * g1
    ddp = e0 * dd - w0sq * e1 * d + e1 * g0 + e2 * g1
    f1, r1 = _force(dp, ddp, k1, kl, k2inv, kd, ainv, c, z)
    g1 = q1 - w0sq * ((4.0 * fm - 3.0 * f0 - f1) * inv)
    g2 = -w0sq * (4.0 * (f0 - 2.0 * fm + f1) * inv * inv)
    d1 = e0 * d + e1 * dd + e2 * g0 + e3 * g1 + e4 * g2
    dd1 = e0 * dd - w0sq * e1 * d + e1 * g0 + e2 * g1 + e3 * g2
    return d1, dd1, f1, r1


@jit
def _quadratic_weights(w0sq, span, e):
    """Weights of ``F(0), F(span/2), F(span)`` in ``delta(span)`` and ``delta'(span)``.

    ``F`` is the quadratic through the three values; its Taylor coefficients
    ``F(0)``, ``(4 Fm - 3 F0 - F1)/L``, ``4 (F0 - 2 Fm + F1)/L^2`` enter with
    ``-omega0^2 E_{k+2}`` (``delta``) and ``-omega0^2 E_{k+1}`` (``delta'``).
    Returns ``(wx0, wxm, wxb, wv0, wvm, wvb)``, to be subtracted.
    """
    _, e1, e2, e3, e4 = e
    i1 = 1.0 / span
    i2 = i1 * i1
    wx0 = w0sq * (e2 - 3.0 * e3 * i1 + 4.0 * e4 * i2)
    wxm = w0sq * (4.0 * e3 * i1 - 8.0 * e4 * i2)
    wxb = w0sq * (-e3 * i1 + 4.0 * e4 * i2)
    wv0 = w0sq * (e1 - 3.0 * e2 * i1 + 4.0 * e3 * i2)
    wvm = w0sq * (4.0 * e2 * i1 - 8.0 * e3 * i2)
    wvb = w0sq * (-e2 * i1 + 4.0 * e3 * i2)
    return wx0, wxm, wxb, wv0, wvm, wvb


@jit
def _history_weights(w0sq, h, e):
    """Weights of ``F(-h), F(0), F(h)`` in ``delta(h)`` and ``delta'(h)`` (subtracted).

    ``F`` is the quadratic through the three values, Taylor coefficients
    ``F(0)``, ``(F(h) - F(-h))/(2h)``, ``(F(h) - 2 F(0) + F(-h))/h^2``.
    Returns ``(wxp, wx0, wxb, wvp, wv0, wvb)`` for ``-h, 0, h``.
    """
    _, e1, e2, e3, e4 = e
    i1 = 1.0 / h
    i2 = i1 * i1
    wxp = w0sq * (-0.5 * e3 * i1 + e4 * i2)
    wx0 = w0sq * (e2 - 2.0 * e4 * i2)
    wxb = w0sq * (0.5 * e3 * i1 + e4 * i2)
    wvp = w0sq * (-0.5 * e2 * i1 + e3 * i2)
    wv0 = w0sq * (e1 - 2.0 * e3 * i2)
    wvb = w0sq * (0.5 * e2 * i1 + e3 * i2)
    return wxp, wx0, wxb, wvp, wv0, wvb


@jit
def _cubic_coeffs(f0, f1, g0, g1, span):
    """Power form in ``t = tau/span`` of the cubic Hermite with values f0, f1 and slopes g0, g1 (per s)."""
    c1 = span * g0
    c2 = 3.0 * (f1 - f0) - span * (2.0 * g0 + g1)
    c3 = 2.0 * (f0 - f1) + span * (g0 + g1)
    return f0, c1, c2, c3


@jit
def _cubic_root(c0, c1, c2, c3, thi):
    """The root in ``(0, thi]`` of ``c0 + c1 t + c2 t^2 + c3 t^3``, whose ends have opposite signs.

    Newton's method kept inside a shrinking bracket (bisection when a step
    would leave it); stops when the step or the bracket is below 1e-15.
    """
    lo = 0.0
    hi = thi
    flo = c0
    t = 0.5 * thi
    fhi = c0 + thi * (c1 + thi * (c2 + thi * c3))
    if flo != fhi:
        t = thi * flo / (flo - fhi)  # secant start
        if not 0.0 < t < thi:
            t = 0.5 * thi
    for _ in range(_NEWTON_ITERATIONS):
        f = c0 + t * (c1 + t * (c2 + t * c3))
        if f == 0.0:
            return t
        if (f > 0.0) == (flo > 0.0):
            lo = t
            flo = f
        else:
            hi = t
        df = c1 + t * (2.0 * c2 + 3.0 * t * c3)
        tn = t - f / df if df != 0.0 else 0.5 * (lo + hi)
        if not lo < tn < hi:
            tn = 0.5 * (lo + hi)
        if abs(tn - t) <= 1e-15 or hi - lo <= 1e-15:
            return tn
        t = tn
    return t


@jit
def _interior_min(c1, c2, c3):
    """Where a cubic with ``c1 < 0`` and slope > 0 at ``t = 1`` has its minimum in ``(0, 1)``."""
    qa = 3.0 * c3
    qb = 2.0 * c2
    disc = qb * qb - 4.0 * qa * c1
    if disc < 0.0:
        disc = 0.0
    sq = math.sqrt(disc)
    # the two roots of c1 + qb t + qa t^2, without cancellation: q/qa and c1/q
    q = -0.5 * (qb + sq) if qb >= 0.0 else -0.5 * (qb - sq)
    t = 2.0
    if q != 0.0:
        t1 = c1 / q
        if 0.0 < t1 < 1.0:
            t = t1
    if qa != 0.0:
        t2 = q / qa
        if 0.0 < t2 < 1.0 and t2 < t:
            t = t2
    if t > 1.0:
        t = 0.5
    return t


@jit
def _find_event(s, rule, tgt, xa, va, acc_a, xb, vb, acc_b, span):
    """First event of a trial span (branch frozen), from the span's ends.

    Returns ``(tau, kind)``: the time from the span's start and
    ``EVENT_TURN`` / ``EVENT_CLOSE``, or ``(2 span, EVENT_NONE)``.

    - Turning point: ``s delta'`` is negative at the end, or (two turning
      points inside one step, a small wiggle near an extremum) positive at
      both ends while the cubic Hermite of ``delta'`` (slopes
      ``delta''``) dips below zero in between; the root is taken up to that
      minimum.
    - Masing closure (``rule == RULE_MASING``, ``tgt`` not NaN): ``delta``
      passes ``tgt`` in the direction ``s`` before the turning point. Up to
      the turning point ``delta`` is monotone, so there is one crossing at
      most; it is looked for at the turning point, not only at the span's
      end (a path that passes the target and turns back inside one step
      closes the loop before it reverses).
    """
    t_turn = 2.0
    v0, v1, v2, v3 = _cubic_coeffs(va, vb, acc_a, acc_b, span)
    if s * vb < 0.0:
        t_turn = _cubic_root(v0, v1, v2, v3, 1.0)
    elif s * va > 0.0 and s * acc_a < 0.0 and s * acc_b > 0.0:
        tm = _interior_min(s * v1, s * v2, s * v3)
        if s * (v0 + tm * (v1 + tm * (v2 + tm * v3))) < 0.0:
            t_turn = _cubic_root(v0, v1, v2, v3, tm)
    if rule == RULE_MASING and not math.isnan(tgt) and (xa - tgt) * s <= 0.0:
        x0, x1, x2, x3 = _cubic_coeffs(xa - tgt, xb - tgt, va, vb, span)
        t_end = t_turn if t_turn <= 1.0 else 1.0
        if (x0 + t_end * (x1 + t_end * (x2 + t_end * x3))) * s > 0.0:
            return span * _cubic_root(x0, x1, x2, x3, t_end), EVENT_CLOSE
    if t_turn <= 1.0:
        return span * t_turn, EVENT_TURN
    return 2.0 * span, EVENT_NONE


@jit
def _branch(hyst, stack, rule, k3, k4):
    """Constants of the current branch of eq. 10: ``s, kd = s k3 a (1 + k4 a), 1/a, c`` and the Masing target."""
    s = hyst[0]
    a = hyst[1]
    kd = s * k3 * a * (1.0 + k4 * a)
    ainv = 1.0 / a if a > 0.0 else 0.0
    tgt = masing_target(hyst, stack) if rule == RULE_MASING else math.nan
    return s, kd, ainv, hyst[2], tgt


@jit
def _step_events(xa, va, f0, r0, xb, vb, fb, rb, tau, kind, h, q0, q1, t0, w0sq, k1, kl, k2inv, k3, k4, z,
                 rule, fast_dt, hyst, stack):
    """Finish a step whose first trial span (from 0, branch frozen) has an event ``kind`` at ``tau``.

    Integrates up to the event (in pieces halving towards a Masing closure),
    updates the branch there (``physics.hyst_turn`` / ``masing_close``),
    evaluates ``F`` under the new branch and tries the rest of the step
    again, up to ``_MAX_EVENTS`` events. Returns the state at the step's
    end, ``F`` and eq. 10's ``1 - u^2`` there, and the earlier node for the
    next step (distance back, 0 if none usable, ``F`` and ``1 - u^2`` there).
    """
    s, kd, ainv, c, tgt = _branch(hyst, stack, rule, k3, k4)
    ta = 0.0
    lnext = 0.0
    fnext = 0.0
    rnext = 0.0
    for it in range(_MAX_EVENTS):
        if it > 0:
            span = h - ta
            fa = f0
            ra = r0
            xb, vb, fb, rb = _span_step(xa, va, span, phi_functions(w0sq, span), phi_functions(w0sq, 0.5 * span),
                                    q0 + q1 * ta, q1, f0, w0sq, k1, kl, k2inv, kd, ainv, c, z)
            kind = EVENT_NONE
            if it < _MAX_EVENTS - 1:
                acc_a = q0 + q1 * ta - w0sq * (xa + f0)
                acc_b = q0 + q1 * h - w0sq * (xb + fb)
                tau, kind = _find_event(s, rule, tgt, xa, va, acc_a, xb, vb, acc_b, span)
            if kind == EVENT_NONE:
                if span >= _MIN_HISTORY * h:
                    lnext = span
                    fnext = fa
                    rnext = ra
                return xb, vb, fb, rb, lnext, fnext, rnext
        te = ta + tau
        if te > h:
            te = h
        tc = ta
        fc = f0
        n_pieces = _GRADE + 1 if kind == EVENT_CLOSE else 1
        for piece in range(n_pieces):
            sub = te - tc if piece == n_pieces - 1 else 0.5 * (te - tc)
            if sub > 0.0:
                xa, va, fc, _ = _span_step(xa, va, sub, phi_functions(w0sq, sub), phi_functions(w0sq, 0.5 * sub),
                                        q0 + q1 * tc, q1, fc, w0sq, k1, kl, k2inv, kd, ainv, c, z)
                tc = tc + sub
        if kind == EVENT_TURN:
            hyst_turn(hyst, stack, rule, xa, t0 + te, fast_dt)
        else:
            masing_close(hyst, stack)
        s, kd, ainv, c, tgt = _branch(hyst, stack, rule, k3, k4)
        f0, r0 = _force(xa, va, k1, kl, k2inv, kd, ainv, c, z)
        ta = te
        if ta >= h:
            break
    return xa, va, f0, r0, lnext, fnext, rnext


# per-suspension constants (``consts[i, :]``), see ``_constants``
C_E = 0  # E_0 .. E_4 at h
C_EH = 5  # E_0 .. E_4 at h/2
C_W = 10  # wx0, wxm, wxb, wv0, wvm, wvb
C_IH = 16
C_IH2 = 17
C_KL = 18
C_K2INV = 19
C_W0SQ = 20
C_K1 = 21
C_K3 = 22
C_K4 = 23
C_K5 = 24
C_Z = 25
C_FAST = 26
C_H = 27
C_WM = 28  # weights of F at -h, 0, h for delta and delta' (uniform three-node quadratic)
C_P = 34  # predictor weights of F(0) and F(-h): delta(h), delta'(h), delta(h/2), delta'(h/2)
C_W0E1 = 42  # omega0^2 E_1(h), omega0^2 E_1(h/2)
N_CONSTS = 44


@jit
def _constants(consts, i, h, w0sq, k1, k2, k3, k4, k5, zeta2_w0, fast_dt):
    """Fill ``consts[i]`` for plant step ``h`` and one suspension's parameters.

    Besides the convolution weights, the predictor's: with ``F`` extrapolated
    linearly from ``F(-h)`` and ``F(0)`` (Taylor coefficients ``F(0)`` and
    ``(F(0) - F(-h))/h``), the predicted state is the state without ``F``
    minus ``omega0^2 ((E_2 + E_3/h) F(0) - E_3/h F(-h))`` (``delta``) and
    ``omega0^2 ((E_1 + E_2/h) F(0) - E_2/h F(-h))`` (``delta'``); at ``h/2``
    the same with ``E(h/2)``.
    """
    e = phi_functions(w0sq, h)
    eh = phi_functions(w0sq, 0.5 * h)
    wq = _quadratic_weights(w0sq, h, e)
    for j in range(5):
        consts[i, C_E + j] = e[j]
        consts[i, C_EH + j] = eh[j]
    for j in range(6):
        consts[i, C_W + j] = wq[j]
    ih = 1.0 / h
    consts[i, C_IH] = ih
    consts[i, C_IH2] = 1.0 / (h * h)
    consts[i, C_KL] = k1 / (2.0 * k2)
    consts[i, C_K2INV] = 1.0 / k2
    consts[i, C_W0SQ] = w0sq
    consts[i, C_K1] = k1
    consts[i, C_K3] = k3
    consts[i, C_K4] = k4
    consts[i, C_K5] = k5
    consts[i, C_Z] = zeta2_w0
    consts[i, C_FAST] = fast_dt
    consts[i, C_H] = h
    wm = _history_weights(w0sq, h, e)
    for j in range(6):
        consts[i, C_WM + j] = wm[j]
    consts[i, C_P] = w0sq * (e[2] + e[3] * ih)
    consts[i, C_P + 1] = w0sq * (e[3] * ih)
    consts[i, C_P + 2] = w0sq * (e[1] + e[2] * ih)
    consts[i, C_P + 3] = w0sq * (e[2] * ih)
    consts[i, C_P + 4] = w0sq * (eh[2] + eh[3] * ih)
    consts[i, C_P + 5] = w0sq * (eh[3] * ih)
    consts[i, C_P + 6] = w0sq * (eh[1] + eh[2] * ih)
    consts[i, C_P + 7] = w0sq * (eh[2] * ih)
    consts[i, C_W0E1] = w0sq * e[1]
    consts[i, C_W0E1 + 1] = w0sq * eh[1]


@jit(inline="always")
def _lane_constants(cs, a):
    """Row ``a`` of a ``_constants`` table as a tuple: a value, so the step loop holds no array view
    (a view is reference-counted, and the counting is an atomic operation that would serialise the
    suspensions :func:`run_three` overlaps)."""
    return (cs[a, 0], cs[a, 1], cs[a, 2], cs[a, 3], cs[a, 4], cs[a, 5], cs[a, 6], cs[a, 7], cs[a, 8], cs[a, 9],
            cs[a, 10], cs[a, 11], cs[a, 12], cs[a, 13], cs[a, 14], cs[a, 15], cs[a, 16], cs[a, 17], cs[a, 18],
            cs[a, 19], cs[a, 20], cs[a, 21], cs[a, 22], cs[a, 23], cs[a, 24], cs[a, 25], cs[a, 26], cs[a, 27],
            cs[a, 28], cs[a, 29], cs[a, 30], cs[a, 31], cs[a, 32], cs[a, 33], cs[a, 34], cs[a, 35], cs[a, 36],
            cs[a, 37], cs[a, 38], cs[a, 39], cs[a, 40], cs[a, 41], cs[a, 42], cs[a, 43])


@jit(inline="always")
def _regular_step(k, d, dd, f0, fp, lprev, r0, rp, kd, ainv, c, q0, q1):
    """One plant step with the branch frozen: the corrected end state, ``F`` and eq. 10's ``1 - u^2`` there.

    ``k``: the suspension's ``_constants`` as a tuple; ``d, dd, f0, r0``: the state, ``F`` and
    ``1 - u^2`` at the step's start; ``fp, rp``: ``F`` and ``1 - u^2`` at the earlier node
    ``lprev`` back (0: none); ``kd, ainv, c``: the branch (``_branch``); ``q0 + q1 tau``: the
    forcing without ``F``. Scalars only, so that several suspensions can be stepped side by
    side (:func:`run_three`) with the arithmetic of :func:`_run_axis`.
    """
    h = k[C_H]
    w0sq = k[C_W0SQ]
    k1 = k[C_K1]
    kl = k[C_KL]
    k2inv = k[C_K2INV]
    z = k[C_Z]
    e0 = k[C_E]
    e1 = k[C_E + 1]
    e2 = k[C_E + 2]
    e3 = k[C_E + 3]
    hx0 = k[C_EH]
    hx1 = k[C_EH + 1]
    hx2 = k[C_EH + 2]
    hx3 = k[C_EH + 3]
    w0e1 = k[C_W0E1]
    w0h1 = k[C_W0E1 + 1]
    wx0 = k[C_W]
    wxm = k[C_W + 1]
    wxb = k[C_W + 2]
    wv0 = k[C_W + 3]
    wvm = k[C_W + 4]
    wvb = k[C_W + 5]
    viscous = z != 0.0
    xl = e0 * d + e1 * dd + (e2 * q0 + e3 * q1)  # the state at h without F
    vl = e0 * dd - w0e1 * d + (e1 * q0 + e2 * q1)
    if lprev == h:
        # F known at -h and 0: predict the end with the line through them
        xp = xl - (k[C_P] * f0 - k[C_P + 1] * fp)
        vp = 0.0
        if viscous:  # the rates enter F only through the viscous term
            vp = vl - (k[C_P + 2] * f0 - k[C_P + 3] * fp)
        fb, rb = _force(xp, vp, k1, kl, k2inv, kd, ainv, c, z)
        if rp > R_SMOOTH and r0 > R_SMOOTH and rb > R_SMOOTH:
            # eq. 10 far from its square-root end points at -h, 0 and h: F is smooth, the
            # quadratic through F(-h), F(0), F(h) corrects (one evaluation per step)
            xb = xl - ((k[C_WM] * fp + k[C_WM + 1] * f0) + k[C_WM + 2] * fb)
            vb = vl - ((k[C_WM + 3] * fp + k[C_WM + 4] * f0) + k[C_WM + 5] * fb)
        else:
            # near a turning point or a clamp: F also at the midpoint (predicted with the
            # same line), the quadratic through F at 0, h/2 and h corrects
            xm = hx0 * d + hx1 * dd + (hx2 * q0 + hx3 * q1) - (k[C_P + 4] * f0 - k[C_P + 5] * fp)
            vm = 0.0
            if viscous:
                vm = hx0 * dd - w0h1 * d + (hx1 * q0 + hx2 * q1) - (k[C_P + 6] * f0 - k[C_P + 7] * fp)
            fm, _ = _force(xm, vm, k1, kl, k2inv, kd, ainv, c, z)
            xb = xl - ((wx0 * f0 + wxm * fm) + wxb * fb)
            vb = vl - ((wv0 * f0 + wvm * fm) + wvb * fb)
    elif lprev > 0.0:
        # the earlier node at -lprev (the last event): the line through F(-lprev), F(0)
        sl = (f0 - fp) / lprev
        g0 = q0 - w0sq * f0
        g1 = q1 - w0sq * sl
        xp = e0 * d + e1 * dd + (e2 * g0 + e3 * g1)
        vp = 0.0
        if viscous:
            vp = e0 * dd - w0e1 * d + (e1 * g0 + e2 * g1)
        fb, rb = _force(xp, vp, k1, kl, k2inv, kd, ainv, c, z)
        xm = hx0 * d + hx1 * dd + (hx2 * g0 + hx3 * g1)
        vm = 0.0
        if viscous:
            vm = hx0 * dd - w0h1 * d + (hx1 * g0 + hx2 * g1)
        fm, _ = _force(xm, vm, k1, kl, k2inv, kd, ainv, c, z)
        xb = xl - ((wx0 * f0 + wxm * fm) + wxb * fb)
        vb = vl - ((wv0 * f0 + wvm * fm) + wvb * fb)
    else:
        xb, vb, fb, rb = _span_step(d, dd, h, (e0, e1, e2, e3, k[C_E + 4]), (hx0, hx1, hx2, hx3, k[C_EH + 4]),
                                    q0, q1, f0, w0sq, k1, kl, k2inv, kd, ainv, c, z)
    return xb, vb, fb, rb


@jit(inline="always")
def _maybe_event(k, s, tgt, d, dd, f0, xb, vb, fb, q0, q1):
    """A cheap screen of :func:`_find_event`'s conditions (``s != 0``): most steps have no event."""
    maybe = s * vb < 0.0
    if not maybe and s * dd > 0.0:
        w0sq = k[C_W0SQ]
        acc_a = q0 - w0sq * (d + f0)
        acc_b = q0 + q1 * k[C_H] - w0sq * (xb + fb)
        maybe = s * acc_a < 0.0 and s * acc_b > 0.0
    if not maybe and not math.isnan(tgt):
        maybe = (d - tgt) * s <= 0.0 and (xb - tgt) * s > 0.0
    return maybe


@jit
def _branch_change(k, rule, hyst, stack, s, d, dd, f0, r0, xb, vb, fb, rb, q0, q1, t):
    """The rare part of a step: the first motion from rest sets the direction (``s == 0``), or an
    event (turning point, Masing closure) found by :func:`_find_event` is integrated through
    (:func:`_step_events`). Returns the step's end (``xb, vb, fb, rb``), the earlier node for the
    next step (``lprev, fp, rp``) and the branch (``s, kd, ainv, c, tgt``)."""
    h = k[C_H]
    w0sq = k[C_W0SQ]
    k3 = k[C_K3]
    k4 = k[C_K4]
    lprev = h
    fpn = f0
    rpn = r0
    if s == 0.0:
        # at rest so far: the first motion sets the direction, no turning point
        # (no branch yet, a = 0: eq. 10 stays 0 and F is unchanged)
        hyst[0] = 1.0 if vb > 0.0 else -1.0
    else:
        acc_a = q0 - w0sq * (d + f0)
        acc_b = q0 + q1 * h - w0sq * (xb + fb)
        tau, kind = _find_event(s, rule, masing_target(hyst, stack) if rule == RULE_MASING else math.nan,
                                d, dd, acc_a, xb, vb, acc_b, h)
        if kind != EVENT_NONE:
            xb, vb, fb, rb, lprev, fpn, rpn = _step_events(
                d, dd, f0, r0, xb, vb, fb, rb, tau, kind, h, q0, q1, t, w0sq, k[C_K1], k[C_KL],
                k[C_K2INV], k3, k4, k[C_Z], rule, k[C_FAST], hyst, stack)
    s, kd, ainv, c, tgt = _branch(hyst, stack, rule, k3, k4)
    return xb, vb, fb, rb, lprev, fpn, rpn, s, kd, ainv, c, tgt


@jit
def _run_axis(sins_angle, sins_rate, volts, q0s, q1s, cs, rule, state, hyst, stack, out_delta):
    """One suspension over the chunk: regular steps inline, events in ``_step_events``.

    ``q0s, q1s``: the forcing without ``F`` of every step (``q0 + q1 tau``,
    see ``plant_run_exact_many``); ``cs``: the suspension's ``_constants``
    row. The state lives in local variables over the chunk (the lane tuples of
    :func:`run_three` measured 10 % slower here, one suspension alone).
    """
    k = _lane_constants(cs.reshape((1, N_CONSTS)), 0)
    h = k[C_H]
    d = state[X_DELTA]
    dd = state[X_DDELTA]
    f0 = state[X_F0]
    fp = state[X_FPREV]
    lprev = state[X_LPREV]
    r0 = state[X_R0]
    rp = state[X_RPREV]
    t = state[X_TIME]
    s, kd, ainv, c, tgt = _branch(hyst, stack, rule, k[C_K3], k[C_K4])
    for n in range(volts.shape[0]):
        q0 = q0s[n]
        q1 = q1s[n]
        xb, vb, fb, rb = _regular_step(k, d, dd, f0, fp, lprev, r0, rp, kd, ainv, c, q0, q1)
        if (vb != 0.0) if s == 0.0 else _maybe_event(k, s, tgt, d, dd, f0, xb, vb, fb, q0, q1):
            xb, vb, fb, rb, lprev, fp, rp, s, kd, ainv, c, tgt = _branch_change(
                k, rule, hyst, stack, s, d, dd, f0, r0, xb, vb, fb, rb, q0, q1, t)
        else:
            fp = f0
            rp = r0
            lprev = h
        d = xb
        dd = vb
        f0 = fb
        r0 = rb
        t += h
        out_delta[n] = xb
    state[X_DELTA] = d
    state[X_DDELTA] = dd
    state[X_F0] = f0
    state[X_R0] = r0
    state[X_FPREV] = fp
    state[X_RPREV] = rp
    state[X_LPREV] = lprev
    state[X_TIME] = t
    n = volts.shape[0]
    if n > 0:
        state[X_PHI] = sins_angle[n - 1]
        state[X_RATE] = sins_rate[n - 1]


@jit(inline="always")
def _lane_trial(k, lane, q0, q1):
    """The regular step of a lane (``lane``: ``d, dd, f0, fp, lprev, r0, rp, t, s, kd, ainv, c, tgt``)
    and whether it needs :func:`_branch_change` (first motion, or a possible event)."""
    d, dd, f0, fp, lprev, r0, rp, t, s, kd, ainv, c, tgt = lane
    xb, vb, fb, rb = _regular_step(k, d, dd, f0, fp, lprev, r0, rp, kd, ainv, c, q0, q1)
    rare = (vb != 0.0) if s == 0.0 else _maybe_event(k, s, tgt, d, dd, f0, xb, vb, fb, q0, q1)
    return xb, vb, fb, rb, rare


@jit(inline="always")
def _lane_commit(k, lane, xb, vb, fb, rb):
    """The lane after a step without a branch change."""
    d, dd, f0, fp, lprev, r0, rp, t, s, kd, ainv, c, tgt = lane
    return xb, vb, fb, f0, k[C_H], rb, r0, t + k[C_H], s, kd, ainv, c, tgt


@jit
def _lane_change(k, lane, xb, vb, fb, rb, q0, q1, rule, hyst, stack):
    """The lane after a step through :func:`_branch_change` (rare: called out of line)."""
    d, dd, f0, fp, lprev, r0, rp, t, s, kd, ainv, c, tgt = lane
    xb, vb, fb, rb, lprev, fp, rp, s, kd, ainv, c, tgt = _branch_change(
        k, rule, hyst, stack, s, d, dd, f0, r0, xb, vb, fb, rb, q0, q1, t)
    return xb, vb, fb, fp, lprev, rb, rp, t + k[C_H], s, kd, ainv, c, tgt


@jit
def _lane_load(state, a, cs, rule, hyst, stack):
    s, kd, ainv, c, tgt = _branch(hyst, stack, rule, cs[a, C_K3], cs[a, C_K4])
    return (state[a, X_DELTA], state[a, X_DDELTA], state[a, X_F0], state[a, X_FPREV], state[a, X_LPREV],
            state[a, X_R0], state[a, X_RPREV], state[a, X_TIME], s, kd, ainv, c, tgt)


@jit
def _lane_store(state, a, lane):
    d, dd, f0, fp, lprev, r0, rp, t, s, kd, ainv, c, tgt = lane
    state[a, X_DELTA] = d
    state[a, X_DDELTA] = dd
    state[a, X_F0] = f0
    state[a, X_FPREV] = fp
    state[a, X_LPREV] = lprev
    state[a, X_R0] = r0
    state[a, X_RPREV] = rp
    state[a, X_TIME] = t


@jit
def run_three(j0, j1, q0s, q1s, cs, rules, state, hyst, stack, out_delta):
    """Three independent suspensions side by side over steps ``j0 .. j1 - 1``, one step of each in turn.

    Row ``a`` of every argument belongs to suspension ``a`` (``q0s, q1s, out_delta``: (3, N),
    ``cs``: ``_constants`` rows, ``state, hyst, stack``). Each gets exactly the arithmetic of
    :func:`_run_axis`, bit for bit. Why: one step is a dependency chain (predict, ``F`` with its
    square roots, correct: about 70 processor cycles of latency against about 20 of
    throughput), so stepping three independent chains in turn lets the processor overlap them.
    The three lanes are written out (not a loop over lanes): each has its own branch
    instructions, whose outcomes the processor then predicts per suspension; the lanes' state
    lives in tuples (values, no array views, whose reference counting is an atomic operation
    that would serialise the lanes). ``state[a, X_PHI]`` and ``X_RATE`` are left to the caller.
    """
    ka = _lane_constants(cs, 0)
    kb = _lane_constants(cs, 1)
    kc = _lane_constants(cs, 2)
    la = _lane_load(state, 0, cs, rules[0], hyst[0], stack[0])
    lb = _lane_load(state, 1, cs, rules[1], hyst[1], stack[1])
    lc = _lane_load(state, 2, cs, rules[2], hyst[2], stack[2])
    for n in range(j0, j1):
        q0 = q0s[0, n]
        q1 = q1s[0, n]
        xb, vb, fb, rb, rare = _lane_trial(ka, la, q0, q1)
        if rare:
            la = _lane_change(ka, la, xb, vb, fb, rb, q0, q1, rules[0], hyst[0], stack[0])
        else:
            la = _lane_commit(ka, la, xb, vb, fb, rb)
        q0 = q0s[1, n]
        q1 = q1s[1, n]
        xb, vb, fb, rb, rare = _lane_trial(kb, lb, q0, q1)
        if rare:
            lb = _lane_change(kb, lb, xb, vb, fb, rb, q0, q1, rules[1], hyst[1], stack[1])
        else:
            lb = _lane_commit(kb, lb, xb, vb, fb, rb)
        q0 = q0s[2, n]
        q1 = q1s[2, n]
        xb, vb, fb, rb, rare = _lane_trial(kc, lc, q0, q1)
        if rare:
            lc = _lane_change(kc, lc, xb, vb, fb, rb, q0, q1, rules[2], hyst[2], stack[2])
        else:
            lc = _lane_commit(kc, lc, xb, vb, fb, rb)
        out_delta[0, n] = la[0]
        out_delta[1, n] = lb[0]
        out_delta[2, n] = lc[0]
    _lane_store(state, 0, la)
    _lane_store(state, 1, lb)
    _lane_store(state, 2, lc)


@jit
def _forcing(sins_angle, sins_rate, volts, phi0, rate0, ih, ih2, w0sq, k5, q0s, q1s):
    """The forcing without ``F`` of each step, ``q0 + q1 tau`` (``-p''`` and the drive, see module docstring).

    Depends on the inputs only (not on the state), so it is computed for the
    whole chunk in a loop without dependencies between steps.
    """
    phi_a = phi0
    r_a = rate0
    for n in range(volts.shape[0]):
        phi1 = sins_angle[n]
        r1 = sins_rate[n]
        slope = (phi1 - phi_a) * ih
        p0 = (6.0 * slope - 4.0 * r_a - 2.0 * r1) * ih  # second derivative of the Hermite interpolant at 0
        p1 = 6.0 * (r_a + r1 - 2.0 * slope) * ih2  # its (constant) third derivative
        q0s[n] = -p0 - w0sq * (k5 * volts[n])  # forcing without F at tau = 0
        q1s[n] = -p1
        phi_a = phi1
        r_a = r1


@jit
def plant_run_exact(sins_angle, sins_rate, volts, h, w0sq, k1, k2, k3, k4, k5, zeta2_w0,
                    rule, fast_dt, state, hyst, stack, out_delta):
    """Advance the suspension over ``len(volts)`` plant steps (exact oscillator, see module docstring).

    Same arguments as ``_kernels.plant.plant_run``, except ``state``, which
    has this module's layout (``STATE_SIZE`` values, all zeros at rest).

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
        See the module docstring; updated in place.
    hyst, stack : float64 arrays
        Hysteresis branch and reversal stack (see ``physics``); updated in place.
    out_delta : float64[N]
        Suspension deflection delta at t_{n+1} .. t_{n+N} (rad).
    """
    n = volts.shape[0]
    params = np.empty((1, 7))
    params[0, 0] = w0sq
    params[0, 1] = k1
    params[0, 2] = k2
    params[0, 3] = k3
    params[0, 4] = k4
    params[0, 5] = k5
    params[0, 6] = zeta2_w0
    rules = np.full(1, rule, dtype=np.int64)
    fast_dts = np.full(1, fast_dt)
    plant_run_exact_many(sins_angle.reshape((1, n)), sins_rate.reshape((1, n)), volts.reshape((1, n)), h, params,
                         rules, fast_dts, state.reshape((1, STATE_SIZE)), hyst.reshape((1, hyst.shape[0])),
                         stack.reshape((1, stack.shape[0])), out_delta.reshape((1, n)))


@jit
def plant_run_exact_many(sins_angle, sins_rate, volts, h, params, rules, fast_dts, state, hyst, stack, out_delta):
    """``plant_run_exact`` for several independent suspensions over the same chunk.

    Each suspension's arithmetic is exactly that of ``plant_run_exact`` (bit
    for bit): its forcing is computed first (:func:`_forcing`), then it runs
    over the chunk (:func:`_run_axis`), one suspension after the other.
    (The engine's three axes advance side by side, one step of each in
    turn, through :func:`run_three`: 19-20 ns per suspension and step
    instead of 24 on the bench case, once no array view is
    reference-counted inside the loop and each lane has its own branch
    instructions.)

    Parameters
    ----------
    sins_angle, sins_rate, volts : float64[M, N]
        Per suspension, as in ``plant_run_exact``.
    h : float
        Plant step (s), common.
    params : float64[M, 7]
        ``omega0^2, k1, k2, k3, k4, k5, 2 zeta / omega0`` per suspension.
    rules : int64[M]
    fast_dts : float64[M]
    state : float64[M, STATE_SIZE]
    hyst : float64[M, HYST_SIZE]
    stack : float64[M, STACK_SIZE]
    out_delta : float64[M, N]
    """
    m_axes = volts.shape[0]
    n = volts.shape[1]
    consts = np.empty((m_axes, N_CONSTS))
    q0s = np.empty(n)
    q1s = np.empty(n)
    for i in range(m_axes):
        _constants(consts, i, h, params[i, 0], params[i, 1], params[i, 2], params[i, 3], params[i, 4],
                   params[i, 5], params[i, 6], fast_dts[i])
        _forcing(sins_angle[i], sins_rate[i], volts[i], state[i, X_PHI], state[i, X_RATE], consts[i, C_IH],
                 consts[i, C_IH2], consts[i, C_W0SQ], consts[i, C_K5], q0s, q1s)
        _run_axis(sins_angle[i], sins_rate[i], volts[i], q0s, q1s, consts[i], rules[i], state[i], hyst[i], stack[i],
                  out_delta[i])
