"""The suspension plant (eq. 2 integrated by RK4 with in-step event location) against closed forms.

reference-model.md, "One dithered gyro channel": ``delta'' = -omega0^2 (delta + Nonl + Diss + k5 V)``
(plus the optional viscous ``2 zeta delta'/omega0``), the drive held constant over each DAC period.
Every tolerance is stated with the reason for its size.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from scipy.integrate import trapezoid

from sins_sim.errors import HysteresisRegimeWarning
from sins_sim.models.drive import DriveParams
from sins_sim.models.motion import ConstantRateMotion, SineMotion
from sins_sim.models.plant import Plant, PlantSettings, simulate_plant
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams
from sins_sim.units import ARCMIN, ARCSEC, DEG
from chunking import uneven_bounds

P = PAPER_SUSPENSION
A_M = 3.0 * ARCMIN
FS = 72000.0
IGNORE_REGIME = pytest.mark.filterwarnings("ignore::sins_sim.errors.HysteresisRegimeWarning")


def _drive(f_hz, v_m, n_steps, plant_rate=FS, dac_rate=None):
    """ZOH drive over ``n_steps`` plant steps: DAC sample k = V_m cos(2 pi f k / dac_rate)
    held for plant_rate/dac_rate steps (the same continuous signal at any plant rate)."""
    dac_rate = plant_rate if dac_rate is None else dac_rate
    r = int(round(plant_rate / dac_rate))
    k = np.arange(n_steps) // r
    return v_m * np.cos(2.0 * math.pi * f_hz * k / dac_rate)


def _fit(t, y, omegas, n):
    """Complex amplitudes z_k of the last n samples, y ~ c + sum_k Re(z_k exp(j omega_k t)),
    all frequencies fitted jointly by least squares (so a large fundamental does not leak into a
    small harmonic when the window is not an exact number of periods)."""
    tt = t[-n:]
    omegas = np.atleast_1d(omegas)
    cols = [np.ones_like(tt)]
    for w in omegas:
        cols += [np.cos(w * tt), np.sin(w * tt)]
    c, *_ = np.linalg.lstsq(np.column_stack(cols), y[-n:], rcond=None)
    z = c[1::2] - 1j * c[2::2]
    return z if z.size > 1 else z[0]


def _peaks(d):
    """Maxima of a sampled oscillation, refined by the parabola through the 3 samples around each."""
    i = np.flatnonzero((d[1:-1] > d[:-2]) & (d[1:-1] >= d[2:])) + 1
    y0, y1, y2 = d[i - 1], d[i], d[i + 1]
    return y1 - (y2 - y0) ** 2 / (8.0 * (y2 - 2.0 * y1 + y0))


def _steady_amplitude(suspension, f_hz, v_m, duration_s, settings=PlantSettings(), cycles=10):
    n = int(round(duration_s * settings.rate_hz))
    t, d, _, _ = simulate_plant(suspension, _drive(f_hz, v_m, n, settings.rate_hz), settings=settings)
    tail = d[-int(round(cycles * settings.rate_hz / f_hz)):]
    return float(np.mean(_peaks(tail))), t, d


# --- linear suspension: forced oscillator ---------------------------------------------------

ZETA = 0.02
LINEAR = SuspensionParams(k1=0.0, k3=0.0, zeta=ZETA, k5=-1.2e-5)
FREQS = [100.0, 193.0, 347.4, 378.3, 386.0, 393.7, 424.6, 772.0, 1930.0]


INTEGRATORS = ["exact", "rk4"]


def _tol_linear(f_hz):
    """Tolerance of the forced-oscillator comparison (relative amplitude and rad of phase).

    RK4: relative frequency error ~ (w0 h)^4/120 = 1e-8, amplified by Q = 25 near the peak
    (measured <= 5.3e-7); far above resonance the cubic interpolation of the block motion and the
    drive's ZOH images bring ~(w h)^4/384 (3e-6 at 1930 Hz).
    "exact" integrator: the oscillator, the drive and the interpolated kinematic input are
    propagated exactly; the viscous term 2 zeta delta'/w0 (2 zeta w/w0 = 0.2 of the spring at
    5 f0) is a third-order predictor-corrector, error ~ (w h)^3/24 of it: <= 5e-6 below 2 f0,
    2e-5 (drive) and 3e-5 (kinematic) at 1930 Hz (measured).
    Bound: 1e-5 + 0.01 (w h)^3, i.e. 1e-5 near resonance and 5.8e-5 at 1930 Hz, about twice the
    largest measured error at each frequency.
    """
    wh = 2.0 * math.pi * f_hz / FS
    return 1e-5 + 0.01 * wh**3


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("f_hz", FREQS)
def test_linear_suspension_matches_forced_oscillator(f_hz, integrator):
    s = LINEAR
    settings = PlantSettings(integrator=integrator)
    w0, w, h = s.omega0, 2.0 * math.pi * f_hz, 1.0 / FS
    # time constant 1/(zeta w0) = 20.6 ms: 0.4 s is 19 of them, the start transient is e^-19 ~ 6e-9
    n = int(0.4 * FS)
    n_fit = int(round(5 * FS / f_hz))  # about five periods
    v_m = 1.0
    tol = _tol_linear(f_hz)

    # dynamic input: delta'' = -w0^2 (delta + 2 zeta delta'/w0 + k5 V)
    t, d, _, _ = simulate_plant(s, _drive(f_hz, v_m, n), settings=settings)
    h_analog = -s.k5 * w0**2 / (w0**2 - w**2 + 2j * ZETA * w0 * w)
    # The DAC holds V_k over [t_k, t_k + h]: the fundamental of that staircase is the sine times
    # sinc(w h/2) delayed by h/2 (phase -w h/2 = -0.017 rad at 386 Hz, 1700 x the tolerance, so
    # the test does see the hold). Its images near 72 kHz are attenuated by (f0/72k)^2 ~ 3e-5.
    x = w * h / 2.0
    expected = v_m * h_analog * (math.sin(x) / x) * np.exp(-1j * x)
    z = _fit(t, d, w, n_fit)
    assert abs(z / expected) - 1.0 == pytest.approx(0.0, abs=tol)
    assert np.angle(z / expected) == pytest.approx(0.0, abs=tol)

    # kinematic input, no drive: phi_rlg / phi_sins = (w0^2 + 2j zeta w0 w) / (w0^2 - w^2 + 2j zeta w0 w)
    amp = ARCMIN
    with warnings.catch_warnings():
        # k3 = 0: no hysteresis at all, the regime counter's verdict is irrelevant here
        warnings.simplefilter("ignore", HysteresisRegimeWarning)
        t, _, phi_rlg, _ = simulate_plant(s, np.zeros(n), motion=SineMotion(amp, f_hz), settings=settings)
    g = (w0**2 + 2j * ZETA * w0 * w) / (w0**2 - w**2 + 2j * ZETA * w0 * w)
    expected_k = -1j * amp * g  # phi_sins = A sin(w t) = Re(-j A exp(j w t)); no hold on this input
    z = _fit(t, phi_rlg, w, n_fit)
    assert abs(z / expected_k) - 1.0 == pytest.approx(0.0, abs=tol)
    assert np.angle(z / expected_k) == pytest.approx(0.0, abs=tol)


# --- the paper's suspension at its operating point -------------------------------------------


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_paper_suspension_driven_at_resonance_holds_3_arcmin(integrator):
    f = P.resonance_hz(A_M)
    v_m = P.drive_voltage(A_M)
    # Q = 187: time constant 2Q/omega = 0.155 s; 2.5 s = 16 of them (measured change from 2.5 s
    # to 4 s: 3e-8 relative)
    amp, t, d = _steady_amplitude(P, f, v_m, 2.5, PlantSettings(integrator=integrator))
    # First-harmonic theory (eq. 15-17 with eq. 9 by harmonic balance) gives exactly a_m.
    # Residual, measured +1.44e-4 (rk4) and +1.41e-4 (exact), i.e. 0.026 arcsec:
    #  - eq. 9 has a third harmonic: the response carries |delta_3| = |N_3| / (9 (F/f0)^2 - 1),
    #    2.3e-4 of a_m, which the peak includes and which distorts eq. 10's ellipse, a
    #    second-order effect on the first harmonic of the same size;
    #  - the DAC hold scales the drive by sinc(w h/2) = 1 - 4.7e-5 (at 144 kHz: 1.2e-5, and the
    #    residual grows by 3e-5 as it should).
    # 1e-3 (0.18 arcsec) bounds these second-order terms with a factor ~4.
    assert amp / A_M - 1.0 == pytest.approx(0.0, abs=1e-3)
    # The third harmonic is what the closed form says. 5 %: the response to it is itself shifted
    # by the nonlinearity and eq. 10 (~ eps = 1 %); measured 0.6 %.
    w = 2.0 * math.pi * f
    n_fit = int(round(10 * FS / f))
    _, z3, _ = _fit(t, d, [w, 3.0 * w, 5.0 * w], n_fit)
    th = np.linspace(0.0, math.pi, 20001)
    n3 = (2.0 / math.pi) * trapezoid(P.nonl(A_M * np.cos(th)) * np.cos(3.0 * th), th)
    pred3 = abs(n3) / (9.0 * (f / P.f0_hz) ** 2 - 1.0)
    assert abs(z3) == pytest.approx(pred3, rel=0.05)


def _sweep_peak(v_m, duration_s=2.0):
    """Frequency and amplitude of the maximum response at drive amplitude v_m.

    A coarse grid (0.25 Hz, from f0 - 4.25 Hz up, independent of any theory) finds the maximum;
    two 3-point parabolas (spacing 0.1 Hz, then 0.03 Hz, each centred on the previous vertex)
    refine it. The resonance curve of the softening suspension is asymmetric, so a wide parabola
    is biased (0.025 Hz at 0.2 Hz spacing); at 0.03 Hz the bias is ~5e-4 Hz.
    """
    grid = P.f0_hz + np.arange(-4.25, 0.26, 0.25)
    amps = np.array([_steady_amplitude(P, f, v_m, duration_s)[0] for f in grid])
    i = int(np.argmax(amps))
    assert 0 < i < grid.size - 1  # the maximum lies inside the grid
    fc = float(grid[i])
    for sp in (0.1, 0.03):
        fx = fc + np.array([-sp, 0.0, sp])
        y = np.array([_steady_amplitude(P, f, v_m, duration_s)[0] for f in fx])
        curv = y[0] - 2.0 * y[1] + y[2]
        assert curv < 0.0
        fc = float(fx[1] + sp * (y[0] - y[2]) / (2.0 * curv))
        apk = float(y[1] - (y[2] - y[0]) ** 2 / (8.0 * curv))
    return fc, apk


def test_frequency_of_maximum_response_follows_eq9_backbone():
    # voltages that hold 1, 3 and 6 arcmin at resonance (eq. 17); Q = 212, 187, 158
    results = [_sweep_peak(P.drive_voltage(a * ARCMIN)) for a in (1.0, 3.0, 6.0)]
    f_pk = np.array([r[0] for r in results])
    a_pk = np.array([r[1] for r in results])
    # the peak amplitude is the one eq. 17 promises (same second-order residual as above)
    np.testing.assert_allclose(a_pk / ARCMIN, [1.0, 3.0, 6.0], rtol=1e-3)
    # the peak falls with amplitude: 0.85, 2.12, 3.46 Hz below f0
    assert np.all(np.diff(f_pk) < 0.0)
    # In harmonic balance the maximum of the response lies on the backbone F(a): at the peak
    # the drive is in quadrature and the elastic terms balance at the amplitude's own resonance.
    # 0.01 Hz = 1.2 % of the smallest shift (0.85 Hz); it covers the parabola's bias on the
    # asymmetric curve (5e-4 Hz), the harmonic-balance error (< 1e-3 Hz) and the 10-cycle
    # amplitude estimate. Measured differences are ~1e-3 Hz.
    for f, a in zip(f_pk, a_pk):
        assert f == pytest.approx(P.resonance_hz(a), abs=0.01)


# --- convergence ---------------------------------------------------------------------------


def _phi_rlg(suspension, rate, dac_rate, duration_s, motion=None, rule="paper", integrator="exact"):
    f, v_m = P.resonance_hz(A_M), P.drive_voltage(A_M)
    n = int(round(duration_s * rate))
    settings = PlantSettings(rate_hz=rate, hysteresis=rule, integrator=integrator)
    t, _, phi_rlg, _ = simulate_plant(suspension, _drive(f, v_m, n, rate, dac_rate), motion=motion,
                                      settings=settings)
    return t, phi_rlg


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


MOTIONS = {"static": None, "sine_100Hz_1arcmin": SineMotion(ARCMIN, 100.0)}


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("rule", ["paper", "masing"])
@pytest.mark.parametrize("motion", list(MOTIONS))
def test_halving_the_step_changes_the_readout_by_under_0p01_arcsec(motion, rule, integrator):
    # 0.3 s of dither building up from rest, the drive's DAC at 72 kHz at both plant rates
    _, p72 = _phi_rlg(P, 72000.0, 72000.0, 0.3, MOTIONS[motion], rule, integrator)
    _, p144 = _phi_rlg(P, 144000.0, 72000.0, 0.3, MOTIONS[motion], rule, integrator)
    diff = p72 - p144[::2]
    # measured 0.0002 .. 0.0012 arcsec RMS, < 0.003 arcsec peak: far below the 1/16-fringe
    # readout quantum (0.15 arcsec) that the 0.01 arcsec criterion protects
    assert _rms(diff) / ARCSEC < 0.01
    assert np.max(np.abs(diff)) / ARCSEC < 0.05


def _richardson_ratio(suspension, duration_s, window, motion=None, integrator="exact"):
    """rms(x36 - x72) / rms(x72 - x144) on common times in ``window``, paper rule, DAC at 36 kHz
    (the same held drive at every plant rate). Order p gives 2^p: 16 for RK4, 8 for third order."""
    runs = {r: _phi_rlg(suspension, r, 36000.0, duration_s, motion, "paper", integrator)
            for r in (36000.0, 72000.0, 144000.0)}
    t = runs[36000.0][0]
    m = (t >= window[0]) & (t <= window[1])
    x36, x72, x144 = runs[36000.0][1], runs[72000.0][1][::2], runs[144000.0][1][::4]
    return _rms((x36 - x72)[m]) / _rms((x72 - x144)[m]), _rms((x72 - x144)[m])


#: Error ratio for one halving of the step expected from each integrator's order, with a
#: margin for the next-order remainder: RK4 (4th order) 16 -> [12, 20]; the exact integrator's
#: third-order predictor-corrector 8 -> [6, 10] (measured 7.0 - 7.1). 3rd order gives 8, 2nd 4.
ORDER_RANGE = {"rk4": (12.0, 20.0), "exact": (6.0, 10.0)}


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_convergence_order_without_hysteresis(integrator):
    # eq. 9 alone (k3 = 0, light viscous damping): smooth right-hand side; 0.3 s from rest
    s = P.replace(k3=0.0, zeta=0.003)
    ratio, _ = _richardson_ratio(s, 0.3, (0.0, 0.3), integrator=integrator)
    lo, hi = ORDER_RANGE[integrator]
    assert lo < ratio < hi, ratio


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_high_order_in_steady_pure_dither(integrator):
    # Eq. 10 active, steady 3 arcmin dither (2.5 .. 3 s, 16 time constants after the start),
    # block at rest: successive extrema are equal, so eq. 10's square root vanishes exactly at
    # the (located) turning points and the right-hand side is smooth between events. Measured
    # ratios 13.2 (rk4) and 7.8 (exact): the order of the method.
    ratio, err = _richardson_ratio(P, 3.0, (2.5, 3.0), integrator=integrator)
    assert ratio >= ORDER_RANGE[integrator][0], ratio
    assert err / ARCSEC < 1e-3


# Known limitation of both plant kernels (_kernels/plant.py, _kernels/plant_exact.py): whenever
# |delta| exceeds the previous half-cycle amplitude a before its turning point (dither building up,
# or any superposed block motion), eq. 10's sqrt(max(0, 1 - delta^2/a^2)) reaches 0 and clamps inside
# the half-cycle: a sqrt(t_c - t) singularity in time that neither RK4 nor the exponential integrator
# resolves (locating the crossing as an event does not help: the Masing rule's loop closure does
# exactly that and shows the same ratios). Measured error ratios for 36/72/144 kHz: rk4 2.3 (build-up,
# static), 1.65 (build-up, 100 Hz motion), 2.8 (steady, 100 Hz motion); exact 4.1 and 2.3 with motion,
# i.e. order ~1-2. The absolute error at 72 kHz stays ~0.001 arcsec RMS, 10x inside the 0.01 arcsec
# convergence requirement (test_halving_the_step_changes_the_readout_by_under_0p01_arcsec).
CLAMP_REASON = "known limitation: eq. 10's clamp at |delta| = a is a sqrt singularity in time; order ~1-2 there"


@pytest.mark.xfail(strict=True, reason=CLAMP_REASON)
@pytest.mark.parametrize("integrator, motion, duration_s, window", [
    ("rk4", "static", 0.3, (0.0, 0.3)),
    ("rk4", "sine_100Hz_1arcmin", 0.3, (0.0, 0.3)),
    ("exact", "sine_100Hz_1arcmin", 0.3, (0.0, 0.3)),
    ("rk4", "sine_100Hz_1arcmin", 3.0, (2.5, 3.0)),
    ("exact", "sine_100Hz_1arcmin", 3.0, (2.5, 3.0)),
])
def test_high_order_with_growing_half_cycles(integrator, motion, duration_s, window):
    ratio, _ = _richardson_ratio(P, duration_s, window, MOTIONS[motion], integrator)
    assert ratio >= ORDER_RANGE[integrator][0], ratio


# --- streaming -----------------------------------------------------------------------------


def _uneven(n, sizes=(1, 0, 7, 1000, 333, 2, 4999, 13, 20000)):
    return uneven_bounds(n, sizes)


@IGNORE_REGIME
@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("rule", ["paper", "masing"])
def test_chunked_plant_equals_whole_array_bit_for_bit(rule, integrator):
    # dither + a 1.5 kHz vibration + a slow rotation: turning points of both origins, minor loops
    motion = SineMotion(A_M, 384.0) + SineMotion(ARCMIN, 1500.0, 0.3) + ConstantRateMotion(0.2)
    settings = PlantSettings(hysteresis=rule, integrator=integrator)
    n = int(0.15 * FS)
    volts = _drive(P.resonance_hz(A_M), P.drive_voltage(A_M), n)
    t, delta_whole, _, _ = simulate_plant(P, volts, motion=motion, settings=settings)

    plant = Plant(P, settings)
    ang, rate = motion.angle_rate(t)
    plant.reset(ang[0], rate[0])
    pieces = [plant.step(ang[i + 1:j + 1], rate[i + 1:j + 1], volts[i:j]) for i, j in _uneven(n)]
    assert_array_equal(np.concatenate(pieces), delta_whole[1:])
    # the equal-chunk path of simulate_plant too
    _, delta_eq, _, _ = simulate_plant(P, volts, motion=motion, settings=settings, chunk=777)
    assert_array_equal(delta_eq, delta_whole)
    if rule == "masing":
        assert plant.hyst[3] >= 1  # the reversal stack was used


# --- hysteresis rules ------------------------------------------------------------------------


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_masing_equals_paper_rule_for_a_pure_dither(integrator):
    f, v_m = P.resonance_hz(A_M), P.drive_voltage(A_M)
    a_paper, _, _ = _steady_amplitude(P, f, v_m, 2.5, PlantSettings(hysteresis="paper", integrator=integrator))
    a_masing, _, _ = _steady_amplitude(P, f, v_m, 2.5, PlantSettings(hysteresis="masing", integrator=integrator))
    # Both rules give the same ellipse for one dominant oscillation; they differ only in where
    # the clamp of eq. 10 is met inside a step during the build-up (integration error ~0.001
    # arcsec, see the convergence tests), which decays with the 0.155 s time constant.
    # Measured 3e-9 (rk4), 3e-8 (exact) relative; 1e-6 (0.0002 arcsec) is the integration-error bound.
    assert a_masing == pytest.approx(a_paper, rel=1e-6)


def test_fast_vibration_warns_for_paper_rule_only():
    # 1 arcmin at 1.5 kHz on the 3 arcmin dither: the vibration's rate (9.4 rad/s) exceeds the
    # dither's (3.8 rad/s), so the deflection's turning points come from the vibration
    motion = SineMotion(ARCMIN, 1500.0)
    n = int(0.3 * FS)
    volts = _drive(P.resonance_hz(A_M), P.drive_voltage(A_M), n)
    with pytest.warns(HysteresisRegimeWarning, match="hysteresis='masing'"):
        simulate_plant(P, volts, motion=motion, settings=PlantSettings(hysteresis="paper"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", HysteresisRegimeWarning)
        _, d, _, _ = simulate_plant(P, volts, motion=motion, settings=PlantSettings(hysteresis="masing"))
    assert np.all(np.isfinite(d))
    # and a pure dither raises no warning under either rule
    for rule in ("paper", "masing"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", HysteresisRegimeWarning)
            simulate_plant(P, volts, settings=PlantSettings(hysteresis=rule))


# --- kinematics ---------------------------------------------------------------------------------


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_constant_rate_motion_without_drive_keeps_delta_zero(integrator):
    rate = 10.0 * DEG
    n = int(0.2 * FS)
    t, d, phi_rlg, phi_sins = simulate_plant(P, np.zeros(n), motion=ConstantRateMotion(rate),
                                             settings=PlantSettings(integrator=integrator))
    # no angular acceleration, no drive: the RLG turns with the block. The plant integrates
    # relative to phi_sins(t_n), so only per-step increments (2.4e-6 rad) enter the arithmetic:
    # rounding leaves |delta| ~ 1e-17 rad (measured 6e-18); 1e-15 rad = 2e-10 arcsec.
    assert np.max(np.abs(d)) < 1e-15
    np.testing.assert_allclose(phi_rlg, rate * t, rtol=0.0, atol=1e-15)
    np.testing.assert_array_equal(phi_sins, rate * t)


def test_drive_params_resolve_to_the_eq17_operating_point():
    sig = DriveParams().resolve(P)
    assert sig.frequency_hz == P.resonance_hz(A_M)
    assert sig.v_m == P.drive_voltage(A_M)
