"""The process noise per step of the scale factors and misalignments the 15 states do not hold, against closed forms.

:class:`~sins_sim.navigation.ekf.UnmodelledErrors`: a constant error matrix ``K`` (``sigma_S`` on the diagonal,
``sigma_M`` off it) on the body rate gives the attitude error ``K a(t)``, ``a`` the angle turned through, with per
body axis the variance ``sigma_S^2 a_i^2 + sigma_M^2 (|a|^2 - a_i^2)``. For a constant rate ``omega`` about the body
z axis of a level unit (body z down, so ``C_nb`` keeps it on the down axis and turns x and y in the level plane),
from zero covariance and with no other noise: ``var psi_D = sigma_S^2 (omega t)^2`` and ``var psi_N = var psi_E =
sigma_M^2 (omega t)^2`` (the horizontal injection is the same on body x and y, so turning it about down leaves it
as it is), step ``k`` adding ``sigma_S^2 omega^2 T^2 (2 k + 1)``; once the rate stops nothing is added; a turn back
starts a new leg.

What the closed form leaves out: the attitude error's coupling to the Earth rate and, through the velocity, to the
Schuler loop, of relative size ``(Omega t)^2 = 2e-8`` and ``(w_s t)^2 = (1.24e-3 * 2)^2 = 6e-6`` over the 2 s
turned here; the tolerance is 1e-4 relative, ten times the larger.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim import earth
from sins_sim._kernels import ekf as kekf
from sins_sim.navigation import ekf
from sins_sim.navigation.strapdown import StrapdownNavigator

LAT, H = math.radians(52.0), 300.0
FS = 400.0
OMEGA = 0.5               # rad/s about body z
BLOCK_S = 0.2
SIG_S, SIG_M = 30e-6, 20e-6
RTOL = 1e-4               # module docstring
ZERO = ekf.ImuNoise(0.0, 0.0, 0.0, 0.0)


def _navigator(unmodelled, n_sub=1):
    g = float(earth.gravity_down(LAT, H))
    nav = StrapdownNavigator(LAT, 0.0, H, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), 1.0 / FS, n_sub=n_sub)
    un = ekf.UnmodelledErrors(SIG_S, SIG_M, 1e-4, 1e-4, (0.0, 0.0, -g))
    aided = ekf.AidedNavigator(nav, ZERO, np.zeros((ekf.N_STATES, ekf.N_STATES)), max_propagation_s=BLOCK_S,
                               unmodelled=un if unmodelled else None)
    n = int(BLOCK_S * FS)
    dth = np.tile([0.0, 0.0, OMEGA / FS], (n, 1))
    dv = np.tile([0.0, 0.0, -g / FS], (n, 1))
    return aided, dth, dv


def test_constant_rate_about_one_axis_adds_the_coherent_variance_step_by_step():
    aided, dth, dv = _navigator(True)
    t_b = BLOCK_S
    prev = 0.0
    for k in range(10):
        aided.process(dth, dv)
        aided.propagate()
        t = (k + 1) * t_b
        p = aided.p
        want_d = SIG_S ** 2 * (OMEGA * t) ** 2
        want_h = SIG_M ** 2 * (OMEGA * t) ** 2
        assert p[ekf.HEADING, ekf.HEADING] == pytest.approx(want_d, rel=RTOL), k
        assert p[6, 6] == pytest.approx(want_h, rel=RTOL) and p[7, 7] == pytest.approx(want_h, rel=RTOL), k
        # the step's own share sigma_S^2 omega^2 T^2 (2k + 1), not a white sigma_S^2 omega^2 T: a difference of two
        # values each within RTOL of theirs, so within 2 RTOL of the larger
        step = p[ekf.HEADING, ekf.HEADING] - prev
        assert step == pytest.approx(SIG_S ** 2 * (OMEGA * t_b) ** 2 * (2 * k + 1), abs=2 * RTOL * want_d), k
        prev = p[ekf.HEADING, ekf.HEADING]
    last = aided.p
    # the rate stops (cruise): nothing is added to the attitude (the velocity variance grows from the tilt, g psi)
    aided.process(np.zeros_like(dth), dv)
    aided.propagate()
    assert aided.p[ekf.HEADING, ekf.HEADING] == pytest.approx(last[ekf.HEADING, ekf.HEADING], rel=RTOL)


def test_a_turn_back_adds_its_own_leg():
    """+omega for 1 s, then -omega for 1 s: the second leg starts anew at the turn back, so the heading variance
    is ``2 sigma_S^2 omega^2`` (each leg's coherent ``sigma_S^2 (omega * 1 s)^2``), not the first leg's alone
    (``|a|`` falling) nor the ``4 sigma_S^2 omega^2`` of one coherent 2 s leg."""
    aided, dth, dv = _navigator(True)
    for sign in (1.0, 1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0, -1.0):
        aided.process(sign * dth, dv)
    aided.propagate()
    assert aided.p[ekf.HEADING, ekf.HEADING] == pytest.approx(2.0 * SIG_S ** 2 * OMEGA ** 2, rel=RTOL)


def test_without_unmodelled_errors_and_zero_noise_nothing_grows():
    aided, dth, dv = _navigator(False)
    for _ in range(3):
        aided.process(dth, dv)
    aided.propagate()
    assert np.all(aided.p == 0.0)


def test_step_increments_against_the_reference_and_the_turn_back():
    """The kernel's per-axis increments equal :func:`ekf.unmodelled_variance_increment` to rounding (a sum of three
    products: 8 eps of its terms), a step toward the start (``|a|`` falling) adds nothing, and a chunking that
    splits navigation updates gives the same covariance (the integrals count whole updates)."""
    rng = np.random.default_rng(5)
    out = np.empty(3)
    for _ in range(40):     # random steps and origins: about half head back (the origin restarts)
        a0, a1, o = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
        origin = o.copy()
        kekf.unmodelled_increment_into(a0, a1, origin, SIG_S ** 2, SIG_M ** 2, out)
        ref, ref_o = ekf.unmodelled_variance_increment(a0, a1, SIG_S, SIG_M, o)
        big = max((a0 - ref_o) @ (a0 - ref_o), (a1 - ref_o) @ (a1 - ref_o))
        assert np.allclose(out, ref, rtol=0.0, atol=8 * np.finfo(float).eps * (SIG_S ** 2 + 2 * SIG_M ** 2) * big)
        assert np.array_equal(origin, ref_o)
    # heading back: the origin restarts at the step's start, and the step adds its own leg
    d, o = ekf.unmodelled_variance_increment([0.0, 0.0, 1.0], [0.0, 0.0, 0.5], SIG_S, 0.0)
    assert o.tolist() == [0.0, 0.0, 1.0] and d[2] == pytest.approx(SIG_S ** 2 * 0.25, rel=1e-12)
    a, dth, dv = _navigator(True, n_sub=4)
    b, _, _ = _navigator(True, n_sub=4)
    # same increments, 4 samples per navigation update: chunks of 80 against 37 and 43 (updates split)
    for _ in range(3):
        a.process(dth, dv)
        b.process(dth[:37], dv[:37])
        b.process(dth[37:], dv[37:])
    assert np.allclose(a.propagate(), b.propagate(), rtol=0.0, atol=1e-15)
    # the running sums differ by their summation order (a few eps of the angle): 1e-12 of each entry's scale
    scale = np.sqrt(np.outer(np.diag(a.p), np.diag(a.p)))
    assert np.all(np.abs(a.p - b.p) <= 1e-12 * scale)
