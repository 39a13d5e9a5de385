"""The "exact" plant integrator (``sins_sim._kernels.plant_exact``) against closed forms and RK4.

The linear part of eq. 2 (oscillator, drive, Hermite-interpolated block motion) is propagated
exactly, the small terms (eq. 9, eq. 10, viscous) by a third-order predictor-corrector, events
located inside the step as in the RK4 kernel. Every tolerance is stated with its reason.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from sins_sim._kernels import physics as kphys
from sins_sim._kernels import plant_exact as kexact
from sins_sim.models.drive import DriveParams
from sins_sim.models.motion import ConstantRateMotion, SineMotion
from sins_sim.models.plant import Plant, PlantSettings, simulate_plant
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.units import ARCMIN, ARCSEC
from chunking import uneven_bounds

P = PAPER_SUSPENSION
FS = 72000.0
IGNORE_REGIME = pytest.mark.filterwarnings("ignore::sins_sim.errors.HysteresisRegimeWarning")


# --- the oscillator's convolution functions ---------------------------------------------------


@pytest.mark.parametrize("w0l", [1e-4, 0.0337, 0.3, math.pi / 4])
def test_phi_functions_match_closed_forms(w0l):
    # E_0 = cos, E_1 = sin/w0, E_2 = (1 - cos)/w0^2, E_3 = (L - sin/w0)/w0^2,
    # E_4 = (L^2/2 - (1 - cos)/w0^2)/w0^2. The closed forms cancel at small w0 L, so they are
    # written without cancellation where possible (2 sin^2(x/2) for 1 - cos) and compared with
    # a tolerance that grows with the cancellation (eps / (w0 L)^2 for E_3, eps / (w0 L)^4 for
    # E_4); at w0 L = 1e-4 the Taylor series' first two terms are exact to 1e-17 instead.
    w0 = P.omega0
    span = w0l / w0
    e = kexact.phi_functions(w0 * w0, span)
    one_minus_cos = 2.0 * math.sin(0.5 * w0l) ** 2
    assert e[0] == pytest.approx(math.cos(w0l), rel=1e-15)
    assert e[1] == pytest.approx(math.sin(w0l) / w0, rel=1e-15)
    assert e[2] == pytest.approx(one_minus_cos / w0**2, rel=1e-14)
    if w0l < 1e-3:
        assert e[3] == pytest.approx(span**3 / 6.0 * (1.0 - w0l**2 / 20.0), rel=1e-14)
        assert e[4] == pytest.approx(span**4 / 24.0 * (1.0 - w0l**2 / 30.0), rel=1e-14)
    else:
        eps = np.finfo(float).eps
        assert e[3] == pytest.approx((span - math.sin(w0l) / w0) / w0**2, rel=8 * eps / w0l**2)
        assert e[4] == pytest.approx((0.5 * span**2 - one_minus_cos / w0**2) / w0**2, rel=8 * eps / w0l**4)


def _run_kernel(sins_angle, sins_rate, volts, k1=0.0, k3=0.0, zeta2_w0=0.0, rule=kphys.RULE_PAPER, rate0=0.0):
    state = np.zeros(kexact.STATE_SIZE)
    state[kexact.X_RATE] = rate0  # block rate at t = 0 (angle 0), deflection at rest
    hyst = np.zeros(kphys.HYST_SIZE)
    stack = np.zeros(kphys.STACK_SIZE)
    kphys.hyst_reset(hyst, stack)
    out = np.empty(volts.size)
    kexact.plant_run_exact(sins_angle, sins_rate, volts, 1.0 / FS, P.omega0**2, k1, P.k2, k3, P.k4, P.k5,
                           zeta2_w0, rule, 0.25 / P.f0_hz, state, hyst, stack, out)
    return out


def test_linear_oscillator_with_kinematic_and_drive_input_is_exact():
    # k1 = k3 = zeta = 0 (kernel called directly; the public classes require some damping):
    # delta'' + w0^2 delta = -p''(t) - w0^2 k5 V. A cubic block angle p = alpha t^2 + beta t^3 is
    # reproduced exactly by the Hermite interpolant, V is constant: the closed form
    # delta = -(2 alpha + 6 beta t)/w0^2 - k5 V + (2 alpha/w0^2 + k5 V) cos(w0 t) + 6 beta/w0^3 sin(w0 t)
    # must come out to rounding: each of the 3600 steps adds a few ulp (relative) to delta and
    # delta', 3600 x 4 x 1.1e-16 = 1.6e-12 of max |delta| (measured 1.3e-12); bound 5e-12.
    alpha, beta, volt = 100.0, 3000.0, 2.0
    n = 3600
    t = np.arange(1, n + 1) / FS
    angle = alpha * t**2 + beta * t**3
    rate = 2.0 * alpha * t + 3.0 * beta * t**2
    d = _run_kernel(angle, rate, np.full(n, volt))
    w0 = P.omega0
    kv = P.k5 * volt
    expected = (-(2.0 * alpha + 6.0 * beta * t) / w0**2 - kv + (2.0 * alpha / w0**2 + kv) * np.cos(w0 * t)
                + 6.0 * beta / w0**3 * np.sin(w0 * t))
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(d - expected)) < 5e-12 * scale


def test_constant_rate_and_no_drive_keep_delta_zero():
    # no angular acceleration, no drive: nothing excites the oscillator. Only the rounding of
    # the per-step increments (angle samples rate * t, ~1e-17 rad) reaches the Hermite
    # interpolant's p''; measured |delta| 5e-18 rad, bound 1e-15 rad (2e-10 arcsec)
    n = 7200
    t = np.arange(1, n + 1) / FS
    rate = 0.3
    d = _run_kernel(rate * t, np.full(n, rate), np.zeros(n), k1=P.k1, k3=P.k3, rate0=rate)
    assert np.max(np.abs(d)) < 1e-15


# --- against RK4 at four times the rate --------------------------------------------------------


def _phi_rlg(integrator, rate_hz, rule, motion, duration_s=0.5):
    """3 arcmin dither from rest at resonance, DAC at 72 kHz held at every plant rate."""
    drive = DriveParams().resolve(P)
    r = int(round(rate_hz / FS))
    volts = np.repeat(drive.samples(0, int(round(duration_s * FS))), r)
    settings = PlantSettings(rate_hz=rate_hz, hysteresis=rule, integrator=integrator)
    _, _, phi_rlg, _ = simulate_plant(P, volts, motion=motion, settings=settings)
    return phi_rlg[::r]


@IGNORE_REGIME
@pytest.mark.parametrize("rule", ["paper", "masing"])
@pytest.mark.parametrize("f_hz", [100.0, 1500.0])
def test_exact_at_72khz_agrees_with_rk4_at_288khz(rule, f_hz):
    # The criterion: 0.5 s of 3 arcmin dither building up from rest (paper suspension,
    # drive at resonance) under a 1 arcmin block vibration at 100 Hz or 1.5 kHz (above 1.15 kHz
    # the vibration makes the turning points), the RLG angle at 72 kHz within 0.01 arcsec RMS
    # of RK4 at 288 kHz. Measured: 4.1e-4 / 2.9e-3 (paper, 100 Hz / 1.5 kHz) and 1.0e-4 / 8.6e-4
    # (masing) arcsec RMS, peaks below 0.007 arcsec. RK4 itself at 72 kHz: 1.7e-3 / 1.6e-3 /
    # 5.0e-4 / 3.6e-2 (it misses Masing closures that happen in the same step as a turning point).
    motion = SineMotion(ARCMIN, f_hz)
    ref = _phi_rlg("rk4", 4 * FS, rule, motion)
    got = _phi_rlg("exact", FS, rule, motion)
    err = (got - ref) / ARCSEC
    assert np.sqrt(np.mean(err**2)) < 0.01
    assert np.max(np.abs(err)) < 0.03


# --- streaming and batches ---------------------------------------------------------------------


def _uneven(n, sizes=(1, 0, 7, 1000, 333, 2, 4999, 13, 20000)):
    return uneven_bounds(n, sizes)


MOTION = SineMotion(3.0 * ARCMIN, 384.0) + SineMotion(ARCMIN, 1500.0, 0.3) + ConstantRateMotion(0.2)


@IGNORE_REGIME
@pytest.mark.parametrize("rule", ["paper", "masing"])
def test_chunked_equals_whole_array_bit_for_bit(rule):
    settings = PlantSettings(hysteresis=rule, integrator="exact")
    n = int(0.2 * FS)
    volts = DriveParams().resolve(P).samples(0, n)
    t, whole, _, _ = simulate_plant(P, volts, motion=MOTION, settings=settings)
    plant = Plant(P, settings)
    ang, rate = MOTION.angle_rate(t)
    plant.reset(ang[0], rate[0])
    pieces = [plant.step(ang[i + 1:j + 1], rate[i + 1:j + 1], volts[i:j]) for i, j in _uneven(n)]
    assert_array_equal(np.concatenate(pieces), whole[1:])


@IGNORE_REGIME
@pytest.mark.parametrize("rule", ["paper", "masing"])
def test_many_suspensions_together_equal_each_alone(rule):
    # plant_run_exact_many interleaves independent suspensions; each must get the bits it gets alone
    suspensions = [P, P.replace(f0_hz=352.0, zeta=0.001), P.replace(f0_hz=421.0, k3=3e-3)]
    n = int(0.05 * FS)
    t = np.arange(n + 1) / FS
    ang, rate = MOTION.angle_rate(t)
    volts = DriveParams().resolve(P).samples(0, n)
    alone = []
    for s in suspensions:
        plant = Plant(s, PlantSettings(hysteresis=rule))
        plant.reset(ang[0], rate[0])
        alone.append(plant.step(ang[1:], rate[1:], volts))
    m = len(suspensions)
    state = np.zeros((m, kexact.STATE_SIZE))
    state[:, kexact.X_PHI] = ang[0]
    state[:, kexact.X_RATE] = rate[0]
    hyst = np.zeros((m, kphys.HYST_SIZE))
    stack = np.zeros((m, kphys.STACK_SIZE))
    for i in range(m):
        kphys.hyst_reset(hyst[i], stack[i])
    params = np.array([[s.omega0**2, s.k1, s.k2, s.k3, s.k4, s.k5, 2.0 * s.zeta / s.omega0] for s in suspensions])
    out = np.empty((m, n))
    kexact.plant_run_exact_many(np.tile(ang[1:], (m, 1)), np.tile(rate[1:], (m, 1)), np.tile(volts, (m, 1)),
                                1.0 / FS, params, np.full(m, kphys.RULES[rule], dtype=np.int64),
                                np.array([0.25 / s.f0_hz for s in suspensions]), state, hyst, stack, out)
    for i in range(m):
        assert_array_equal(out[i], alone[i])


@IGNORE_REGIME
def test_three_suspensions_side_by_side_equal_each_alone_in_any_pieces():
    # run_three steps three suspensions in turn (the engine's one-thread path); each lane must get the
    # bits it gets alone, whatever its rule and however the steps are split into calls
    suspensions = [P, P.replace(f0_hz=352.0, zeta=0.001), P.replace(f0_hz=421.0, k3=3e-3)]
    rules = ["masing", "paper", "masing"]
    n = int(0.05 * FS)
    t = np.arange(n + 1) / FS
    ang, rate = MOTION.angle_rate(t)
    alone, q0s, q1s, consts = [], np.empty((3, n)), np.empty((3, n)), np.empty((3, kexact.N_CONSTS))
    for i, (s, rule) in enumerate(zip(suspensions, rules)):
        volts = DriveParams().resolve(s).samples(0, n)
        plant = Plant(s, PlantSettings(hysteresis=rule))
        plant.reset(ang[0], rate[0])
        alone.append(plant.step(ang[1:], rate[1:], volts))
        kexact._constants(consts, i, 1.0 / FS, s.omega0 ** 2, s.k1, s.k2, s.k3, s.k4, s.k5, 2.0 * s.zeta / s.omega0,
                          0.25 / s.f0_hz)
        kexact._forcing(ang[1:], rate[1:], volts, ang[0], rate[0], consts[i, kexact.C_IH], consts[i, kexact.C_IH2],
                        consts[i, kexact.C_W0SQ], consts[i, kexact.C_K5], q0s[i], q1s[i])
    state = np.zeros((3, kexact.STATE_SIZE))
    hyst = np.zeros((3, kphys.HYST_SIZE))
    stack = np.zeros((3, kphys.STACK_SIZE))
    for i in range(3):
        kphys.hyst_reset(hyst[i], stack[i])
    out = np.empty((3, n))
    rule_codes = np.array([kphys.RULES[r] for r in rules], dtype=np.int64)
    for i, j in _uneven(n):
        kexact.run_three(i, j, q0s, q1s, consts, rule_codes, state, hyst, stack, out)
    for i in range(3):
        assert_array_equal(out[i], alone[i])


# --- event location -----------------------------------------------------------------------------


def test_closure_is_found_before_a_turning_point_in_the_same_step():
    # delta rises through the Masing target at tau = 0.3 L, turns at 0.6 L and falls back below
    # the target by the end of the span: the RK4 kernel's end-of-span test misses the closure
    # (delta is below the target at both ends); the loop must close before the reversal.
    span = 1.0 / FS
    tg, tt = 0.3 * span, 0.6 * span
    # delta(tau) = -c (tau - tt)^2 + c (tt - tg)^2 (zero at tg, maximum at tt); target at 0
    c = 1e3
    x = lambda tau: -c * (tau - tt) ** 2 + c * (tt - tg) ** 2  # noqa: E731
    v = lambda tau: -2.0 * c * (tau - tt)  # noqa: E731
    acc = -2.0 * c
    tau, kind = kexact._find_event(1.0, kphys.RULE_MASING, 0.0, x(0.0), v(0.0), acc, x(span), v(span), acc, span)
    assert kind == kexact.EVENT_CLOSE
    assert tau == pytest.approx(tg, rel=1e-12)
    # with the paper rule (no target) the same span has its turning point
    tau, kind = kexact._find_event(1.0, kphys.RULE_PAPER, math.nan, x(0.0), v(0.0), acc, x(span), v(span), acc,
                                   span)
    assert kind == kexact.EVENT_TURN
    assert tau == pytest.approx(tt, rel=1e-12)


def test_two_turning_points_inside_one_step_are_found():
    # delta' = c (tau - t1)(tau - t2) + tiny: positive at both ends, negative between t1 and t2
    # (a wiggle near an extremum): the first turning point is at t1
    span = 1.0 / FS
    t1, t2 = 0.35 * span, 0.55 * span
    c = 1e9
    v = lambda tau: c * (tau - t1) * (tau - t2)  # noqa: E731
    a = lambda tau: c * (2.0 * tau - t1 - t2)  # noqa: E731
    tau, kind = kexact._find_event(1.0, kphys.RULE_PAPER, math.nan, 0.0, v(0.0), a(0.0), 0.0, v(span), a(span), span)
    assert kind == kexact.EVENT_TURN
    assert tau == pytest.approx(t1, rel=1e-12)
    # a monotone decelerating span has no event
    tau, kind = kexact._find_event(1.0, kphys.RULE_PAPER, math.nan, 0.0, 2.0, -1.0, 0.0, 1.0, -1.0, span)
    assert kind == kexact.EVENT_NONE


# --- settings --------------------------------------------------------------------------------------


def test_exact_is_the_default_and_rk4_stays_selectable():
    assert PlantSettings().integrator == "exact"
    assert PlantSettings(integrator="rk4").integrator == "rk4"
    with pytest.raises(ValueError, match="plant.integrator"):
        PlantSettings(integrator="euler")
