"""Scalar physics of the dither suspension, shared by the plant and the filter.

Written once as plain Python on scalars; ``*_jit`` are the numba versions
that the kernels call. Equation numbers refer to the paper ("A Correcting
Filter for a Mechanically Dithered Single-Axis Ring Laser Gyro"); conventions to docs/theory/suspension.md.

Hysteresis state ("branch") used by both rules, stored in a small float64
array ``hyst``:

- ``hyst[0]`` ``s``: direction of the current half-cycle, sgn(d delta/dt), 0 before any motion;
- ``hyst[1]`` ``a``: half-range of the current branch (paper: ``|delta|`` at the last turning point);
- ``hyst[2]`` ``c``: centre of the current branch (paper rule: always 0);
- ``hyst[3]`` ``m``: number of reversal points on the Masing stack;
- ``hyst[4]`` time of the last turning point (s), ``hyst[5]`` count of "fast" half-cycles,
  ``hyst[6]`` time of the first fast half-cycle (-1 if none).

Rules (``rule`` argument): ``RULE_PAPER`` = 0, the paper's eq. 10 with ``a`` the
``|delta|`` of the most recent turning point; ``RULE_MASING`` = 1, Masing rules
on a stack of reversal points (docs/theory/suspension.md): a branch that starts at reversal ``r_top`` heads for
the previous reversal ``r_prev`` and dissipates by its own half-range
``|r_top - r_prev|/2`` about its own centre; once the path passes ``r_prev`` the
minor loop is closed, both points are dropped and the path rejoins the
enclosing branch. The outermost branch is centred on 0 with half-range
``|r_top|``, so for a pure dither both rules give the paper's ellipse.
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit

RULE_PAPER = 0
RULE_MASING = 1
#: Hysteresis rules by name, for the plant and the correcting filter alike.
RULES = {"paper": RULE_PAPER, "masing": RULE_MASING}
HYST_SIZE = 10
STACK_SIZE = 64
#: Branches smaller than this (rad, 10 arcsec) are ignored by the regime counter: while the
#: dither builds up from rest any motion makes the turning points, and eq. 10's term is then
#: below k3 * 10 arcsec ~ 0.05 arcsec whatever the rule.
FAST_MIN_AMPLITUDE = 10.0 * math.pi / 648000.0
#: The counter starts after 10 dither periods (40 quarter periods): a run from rest passes
#: through that regime trivially while the dither is still small.
WARMUP_QUARTER_PERIODS = 40.0


def nonl(d, k1, k2):
    """Elastic nonlinearity, eq. 9, in a cancellation-free form.

    ``k1 * (sgn(d) * (sqrt(1 + |d|/k2) - 1) - d/(2 k2))`` equals
    ``-k1 * sgn(d) * x^2 / (2 (1 + sqrt(1 + x))^2)`` with ``x = |d|/k2``
    (use ``sqrt(1+x) - 1 = x / (sqrt(1+x) + 1)``), which keeps full relative
    precision for small deflections.
    """
    x = abs(d) / k2
    r = 1.0 + math.sqrt(1.0 + x)
    v = -k1 * x * x / (2.0 * r * r)
    return v if d >= 0.0 else -v


def dnonl(d, k1, k2):
    """d Nonl / d delta of eq. 9: ``k1/(2 k2) * (1/sqrt(1 + |d|/k2) - 1)``."""
    return k1 / (2.0 * k2) * (1.0 / math.sqrt(1.0 + abs(d) / k2) - 1.0)


def diss(d, s, a, c, k3, k4):
    """Hysteretic dissipation, eq. 10, on a branch of half-range ``a`` about ``c``.

    ``s * k3 * a * (1 + k4 a) * sqrt(max(0, 1 - (d - c)^2 / a^2))``; zero when
    ``a == 0`` (before the first turning point).
    """
    if a <= 0.0:
        return 0.0
    u = (d - c) / a
    r = 1.0 - u * u
    if r <= 0.0:
        return 0.0
    return s * k3 * a * (1.0 + k4 * a) * math.sqrt(r)


nonl_jit = jit(nonl)
dnonl_jit = jit(dnonl)
diss_jit = jit(diss)


@jit
def hyst_reset(hyst, stack):
    """Rest state: no direction yet, no branch, empty stack."""
    for i in range(HYST_SIZE):
        hyst[i] = 0.0
    hyst[6] = -1.0
    for i in range(stack.shape[0]):
        stack[i] = 0.0


@jit
def _masing_branch(hyst, stack):
    """Set ``a`` and ``c`` from the top of the reversal stack."""
    m = int(hyst[3])
    if m == 0:
        hyst[1] = 0.0
        hyst[2] = 0.0
    elif m == 1:
        hyst[1] = abs(stack[0])
        hyst[2] = 0.0
    else:
        top = stack[m - 1]
        prev = stack[m - 2]
        hyst[1] = 0.5 * abs(top - prev)
        hyst[2] = 0.5 * (top + prev)


@jit
def masing_target(hyst, stack):
    """The value whose crossing closes the current branch (``nan`` if none)."""
    m = int(hyst[3])
    if m == 0:
        return math.nan
    if m == 1:
        return -stack[0]
    return stack[m - 2]


@jit
def hyst_turn(hyst, stack, rule, d, t, fast_dt):
    """Apply a turning point of ``delta`` at value ``d``, time ``t``.

    The direction flips; the paper's rule takes ``a = |d|``; the Masing rule
    pushes ``d`` on the reversal stack (dropping the oldest point when full).
    A half-cycle shorter than ``fast_dt`` (a quarter dither period) that ends
    well inside the current branch (``|d - c| < a/2``: the amplitude collapses)
    is counted, after the warm-up and above ``FAST_MIN_AMPLITUDE``: it marks
    the regime where vibration, not the dither, makes the turning points.
    Like a Schmitt trigger, the counter confirms a turning point only when
    the path then swings away from it by more than ``FAST_MIN_AMPLITUDE``: a
    fast half-cycle is counted at the next turning point, if both its own
    swing and the following one exceed the threshold. A noisy estimate of
    delta (the correcting filter's D carries the readout quantum amplified by
    eq. 5's gain near Nyquist, about 34) wiggles through spurious pairs of
    turning points a few arcsec apart near its zero crossings: noise, not
    vibration, and never confirmed. The turning points themselves, and hence
    the filter's output and the plant, are unchanged.
    """
    hyst[0] = -hyst[0]
    swing = abs(d - hyst[7])
    hyst[7] = d
    if hyst[8] > 0.0 and swing > FAST_MIN_AMPLITUDE:  # the previous fast half-cycle is confirmed
        hyst[5] += 1.0
        if hyst[6] < 0.0:
            hyst[6] = hyst[9]
    hyst[8] = 0.0
    fast = t - hyst[4] < fast_dt and abs(d - hyst[2]) < 0.5 * hyst[1] and swing > FAST_MIN_AMPLITUDE
    if fast and t > WARMUP_QUARTER_PERIODS * fast_dt and hyst[1] > FAST_MIN_AMPLITUDE:
        hyst[8] = 1.0
        hyst[9] = t
    hyst[4] = t
    if rule == RULE_PAPER:
        hyst[1] = abs(d)
        hyst[2] = 0.0
        return
    m = int(hyst[3])
    if m == stack.shape[0]:
        for i in range(m - 1):
            stack[i] = stack[i + 1]
        m -= 1
    stack[m] = d
    hyst[3] = m + 1
    _masing_branch(hyst, stack)


@jit
def masing_close(hyst, stack):
    """The path passed the current target: close the minor loop (Masing)."""
    m = int(hyst[3])
    if m >= 2:
        hyst[3] = m - 2
    else:
        hyst[3] = 0
    _masing_branch(hyst, stack)
