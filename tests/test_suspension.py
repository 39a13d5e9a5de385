"""Closed forms of the suspension model (reference-model.md, "One dithered gyro channel").

Equation numbers refer to the paper (``correcting-filter-paper.txt``): eq. 9
(elastic nonlinearity), eq. 16 (Q from k3, k4), eq. 17 (k5 from Q and V_m).
Every tolerance is stated with the reason for its size.
"""

from __future__ import annotations

import math
import warnings
from decimal import Decimal, localcontext

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, solve_ivp

from sins_sim._kernels.physics import dnonl, nonl, nonl_jit
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams, nonl_array
from sins_sim.units import ARCMIN

P = PAPER_SUSPENSION
A_M = 3.0 * ARCMIN  # the paper's dither amplitude
EPS = np.finfo(np.float64).eps


# --- eq. 16 / 17 ------------------------------------------------------------------------------


def test_q_at_3_arcmin_from_eq16():
    # 1/Q = k3 (1 + k4 a) with k3 = 4.4e-3, k4 = 250 1/rad, a = 3 arcmin = pi/3600 rad.
    q_exact = 1.0 / (4.4e-3 * (1.0 + 250.0 * math.pi / 3600.0))
    q = P.q_factor(A_M)
    assert q == pytest.approx(q_exact, rel=1e-14)  # same formula, a few roundings apart
    assert abs(q - 186.57) < 0.005  # 186.5696: the value stated to 2 decimals
    assert abs(q / 187.0 - 1.0) < 0.01  # the paper's "187 from the formulas", within 1 %


def test_drive_voltage_and_k5_for_round_trip_eq17():
    q = P.q_factor(A_M)
    v_m = P.drive_voltage(A_M)
    # eq. 17 solved for V_m: V_m = -a_m / (Q k5); positive because k5 < 0 for the paper's suspension
    assert v_m == pytest.approx(-A_M / (q * P.k5), rel=1e-15)
    assert v_m > 0.0
    # and back: k5 = -a_m / (Q V_m) (a division and a multiplication: a few ulp)
    assert P.k5_for(A_M, v_m) == pytest.approx(P.k5, rel=4 * EPS)
    for a in (0.5 * ARCMIN, 6.0 * ARCMIN):
        assert P.k5_for(a, P.drive_voltage(a)) == pytest.approx(P.k5, rel=4 * EPS)


@pytest.mark.parametrize("q, v_m", [(186.57, 0.39), (100.0, 1.0), (1000.0, 0.05)])
def test_from_q_reproduces_q_and_k5(q, v_m):
    s = SuspensionParams.from_q(q, A_M, v_m, k4=P.k4)
    # eq. 16 inverted and re-evaluated: k3 = 1/(Q (1 + k4 a)), 1/(k3 (1 + k4 a)): ~4 roundings
    assert s.q_factor(A_M) == pytest.approx(q, rel=8 * EPS)
    assert s.k5 == pytest.approx(-A_M / (q * v_m), rel=4 * EPS)
    assert s.drive_voltage(A_M) == pytest.approx(v_m, rel=8 * EPS)
    assert s.k4 == P.k4


# --- eq. 9 --------------------------------------------------------------------------------------


def _nonl_printed(d: float, k1: float, k2: float) -> float:
    """Eq. 9 exactly as printed, ``k1 (sgn(d) (sqrt(1 + |d|/k2) - 1) - d/(2 k2))``, in decimal.

    The printed form cancels twice (``sqrt(1+x) - 1`` and then ``- x/2``, leaving
    ``-x^2/8``), losing about ``2 |log10 x|`` digits; the working precision is
    raised by that much so that the result keeps at least 50 significant digits.
    """
    if d == 0.0:
        return 0.0
    x_est = abs(d) / k2
    extra = int(2 * max(0.0, -math.log10(x_est))) + 10
    with localcontext() as ctx:
        ctx.prec = 50 + extra
        dd, kk1, kk2 = Decimal(d), Decimal(k1), Decimal(k2)  # exact conversions of binary floats
        sgn = 1 if dd > 0 else -1
        val = kk1 * (sgn * ((1 + abs(dd) / kk2).sqrt() - 1) - dd / (2 * kk2))
        return float(val)


def _d_grid():
    """d over [-1e-2, 1e-2] rad: a dense log grid in |d| from 1e-30 rad up, both signs, plus
    round values and the paper's operating points (3 arcmin, k2)."""
    mags = np.concatenate([np.logspace(-30, -2, 241), [1e-12, 1e-9, A_M, 6 * ARCMIN, P.k2, 1e-2]])
    rng = np.random.default_rng(9)
    mags = np.concatenate([mags, 10.0 ** rng.uniform(-8.0, -2.0, 200)])
    mags = mags[mags <= 1e-2]
    return np.concatenate([mags, -mags])


def test_nonl_cancellation_free_form_matches_printed_formula_to_1e_15():
    d = _d_grid()
    ref = np.array([_nonl_printed(float(x), P.k1, P.k2) for x in d])
    assert np.all(ref != 0.0)  # the reference keeps full precision even at |d| = 1e-30
    impls = {
        "physics.nonl": np.array([nonl(float(x), P.k1, P.k2) for x in d]),
        "physics.nonl_jit": np.array([nonl_jit(float(x), P.k1, P.k2) for x in d]),
        "nonl_array": nonl_array(d, P.k1, P.k2),
        "SuspensionParams.nonl": P.nonl(d),
    }
    for name, val in impls.items():
        rel = np.abs(val / ref - 1.0)
        # The cancellation-free form -k1 x^2 / (2 (1 + sqrt(1+x))^2), x = |d|/k2, takes
        # 7 correctly rounded operations: relative error <= ~7 * eps/2 = 7.8e-16 < 1e-15.
        # The printed form in float64 would lose everything below |d| ~ 1e-12 rad.
        assert rel.max() < 1e-15, (name, float(rel.max()), float(d[np.argmax(rel)]))


def test_nonl_is_odd_softening_and_flat_at_zero():
    d = _d_grid()
    pos = nonl_array(d, P.k1, P.k2)
    # odd symmetry: the form depends on |d| and applies sgn(d) last, so it is exact
    np.testing.assert_array_equal(nonl_array(-d, P.k1, P.k2), -pos)
    # softening: Nonl(d) has the opposite sign of d (restoring force d + Nonl(d) < d)
    assert np.all(np.sign(pos) == -np.sign(d))
    assert nonl(0.0, P.k1, P.k2) == 0.0
    # Nonl'(0) = 0: the analytic derivative vanishes exactly...
    assert dnonl(0.0, P.k1, P.k2) == 0.0
    # ... and the slope Nonl(h)/h -> 0 like -k1 h / (8 k2^2) (leading term of eq. 9)
    for h in (1e-9, 1e-7, 1e-5):
        slope = nonl(h, P.k1, P.k2) / h
        assert slope == pytest.approx(-P.k1 * h / (8.0 * P.k2**2), rel=2 * h / P.k2)


# --- amplitude-dependent resonance -----------------------------------------------------------


AMPS = np.array([0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]) * ARCMIN


def _f_exact_ode(a: float) -> float:
    """Independent reference: quarter period of d'' = -omega0^2 (d + Nonl(d)) from (a, 0) to d = 0.

    DOP853 at rtol 1e-13 on the ODE itself (no potential, no quadrature), time of the first zero
    located by the event finder."""
    w0sq = P.omega0**2

    def rhs(_t, y):
        return [y[1], -w0sq * (y[0] + nonl(y[0], P.k1, P.k2))]

    def crossing(_t, y):
        return y[0]

    crossing.terminal = True
    crossing.direction = -1
    sol = solve_ivp(rhs, [0.0, 1.0], [a, 0.0], method="DOP853", rtol=1e-13, atol=1e-16 * a,
                    events=crossing)
    return 1.0 / (4.0 * sol.t_events[0][0])


def test_harmonic_balance_and_exact_period_agree_over_0p5_to_6_arcmin():
    f_hb = np.array([P.resonance_hz(a) for a in AMPS])
    with warnings.catch_warnings():
        warnings.simplefilter("error", IntegrationWarning)  # the period integral must converge here
        f_ex = np.array([P.resonance_hz_exact(a) for a in AMPS])
    # both below f0 and decreasing with amplitude (softening spring)
    assert np.all(f_hb < P.f0_hz) and np.all(f_ex < P.f0_hz)
    assert np.all(np.diff(f_hb) < 0.0) and np.all(np.diff(f_ex) < 0.0)
    # the shift is substantial: 2.12 Hz at 3 arcmin, 3.46 Hz at 6 arcmin
    assert P.f0_hz - P.resonance_hz(A_M) == pytest.approx(2.1234, abs=1e-3)
    # Harmonic balance keeps the first harmonic only. With eps = 1 - (F/f0)^2 (0.0023 .. 0.018
    # here) the third harmonic of the response is ~ eps/40 of the amplitude and changes the
    # frequency at second order, ~ eps^2 / 80; measured 0.004 .. 0.007 eps^2 (HB above exact).
    eps_nl = 1.0 - (f_hb / P.f0_hz) ** 2
    rel = f_hb / f_ex - 1.0
    assert np.all(np.abs(rel) < 0.02 * eps_nl**2), rel / eps_nl**2
    assert np.all(np.abs(rel) < 2e-6)  # i.e. < 0.8 mHz at 383 Hz
    # the exact-period integral against an independent ODE integration (both ~1e-13 accurate)
    for a, fe in zip(AMPS[[0, 3, 6]], f_ex[[0, 3, 6]]):
        assert fe == pytest.approx(_f_exact_ode(a), rel=1e-10)


def test_small_amplitude_limit_and_leading_order_closed_form():
    # For small d, sqrt(1+x) = 1 + x/2 - x^2/8 + x^3/16 - ..., so eq. 9 is
    #   Nonl(d) = -c |d| d + c3 d^3 + ...,  c = k1/(8 k2^2),  c3 = k1/(16 k2^3).
    # First harmonic for d = a cos(theta): (2/pi) int_0^pi |cos| cos^2 = 8/(3 pi), and
    # (3/4) for cos^3, hence
    #   (omega/omega0)^2 = 1 - (8/(3 pi)) c a + (3/4) c3 a^2 = 1 - k1 a/(3 pi k2^2) + 3 k1 a^2/(64 k2^3).
    k1, k2 = P.k1, P.k2
    a = 0.01 * ARCMIN  # 2.9e-6 rad, a/k2 = 2.8e-3
    shift = 1.0 - (P.resonance_hz(a) / P.f0_hz) ** 2
    lead = k1 * a / (3.0 * math.pi * k2**2)
    second = 3.0 * k1 * a * a / (64.0 * k2**3)
    # leading order alone: the next term is (9 pi a /(64 k2)) = 1.2e-3 of it -> 0.2 % tolerance
    assert shift == pytest.approx(lead, rel=2e-3)
    # with the second term: the remainder is O((a/k2)^2) = 8e-6 relative (measured 2.6e-6)
    assert shift == pytest.approx(lead - second, rel=2e-5)
    # the limit a -> 0 is f0 itself
    assert P.resonance_hz(0.0) == P.f0_hz
    # at 1e-12 rad the shift k1 a/(6 pi k2^2) is 8.4e-12 of f0
    assert P.resonance_hz(1e-12) < P.f0_hz
    assert P.resonance_hz(1e-12) == pytest.approx(P.f0_hz, rel=1e-10)
    # the exact period at 0.01 arcmin has the same leading-order shift (first-order perturbation
    # theory equals harmonic balance); 0.3 % covers the second-order term (0.12 %) and the
    # integral's error at this amplitude (3.5e-9 of f0 = 1.4e-4 of the shift)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        shift_ex = 1.0 - (P.resonance_hz_exact(a) / P.f0_hz) ** 2
    assert shift_ex == pytest.approx(lead, rel=3e-3)


# Regression: the eq. 9 potential once cancelled terms of size k1 a (fixed by the series in _g).
def test_exact_period_at_tiny_amplitude_is_below_f0_and_clean():
    a = 1e-4 * ARCMIN
    with warnings.catch_warnings():
        warnings.simplefilter("error", IntegrationWarning)
        f = P.resonance_hz_exact(a)
    lead = P.k1 * a / (3.0 * math.pi * P.k2**2)  # 4.9e-7: the shift is 9.4e-5 Hz
    assert f < P.f0_hz
    assert 1.0 - (f / P.f0_hz) ** 2 == pytest.approx(lead, rel=1e-2)


# --- validation ---------------------------------------------------------------------------------


FIELDS = ("f0_hz", "k1", "k2", "k3", "k4", "k5", "zeta")


@pytest.mark.parametrize("changes, field", [
    ({"f0_hz": 0.0}, "f0_hz"),
    ({"f0_hz": -386.0}, "f0_hz"),
    ({"k2": 0.0}, "k2"),
    ({"k2": -1.05e-3}, "k2"),
    ({"k3": 0.0, "zeta": 0.0}, "k3"),
    ({"k5": 0.0}, "k5"),
    ({"k1": -1e-4}, "k1"),
    ({"zeta": -0.01}, "zeta"),
] + [({name: math.nan}, name) for name in FIELDS] + [({name: math.inf}, name) for name in FIELDS])
def test_bad_field_raises_value_error_naming_it(changes, field):
    with pytest.raises(ValueError, match=rf"\b{field}\b"):
        SuspensionParams(**changes)


def test_k3_zero_is_fine_with_viscous_damping():
    s = SuspensionParams(k3=0.0, zeta=0.01)
    assert s.q_factor(A_M) == pytest.approx(1.0 / 0.02, rel=1e-15)  # 1/Q = 2 zeta


@pytest.mark.parametrize("q", [0.0, -5.0, math.nan])
def test_from_q_rejects_non_positive_q(q):
    with pytest.raises(ValueError, match=r"\bQ\b"):
        SuspensionParams.from_q(q, A_M, 0.39)


def test_from_q_rejects_bad_voltage_and_amplitude():
    with pytest.raises(ValueError, match="v_m"):
        SuspensionParams.from_q(187.0, A_M, 0.0)
    with pytest.raises(ValueError, match="amplitude_rad"):
        SuspensionParams.from_q(187.0, -A_M, 0.39)
