"""Amplitude-frequency characteristics (AFC) of the driven suspension and their fit.

The paper's Fig. 2 and 4: the RLG on its suspension, block at rest, is
driven by ``V = V_m cos(2 pi f t)`` at four voltages and ten frequencies
near resonance; the steady dither amplitude is measured, eq. 2 is simulated
at the same points, and omega0, k1..k5 are varied to minimise

    S = 1/(4 x 10) sum_ij (a_model,ij - a_experiment,ij)^2

(the square root of S is the RMS deviation, 4 arcsec in the paper). The
sensitivity table gives the increase of that RMS when one parameter is
raised by 1 % from the minimum.

Simulation of one point (:func:`steady_amplitude`)
--------------------------------------------------
A run from rest needs many time constants ``2 Q / omega ~ 0.16 s`` to
settle. Instead the plant starts on the harmonic-balance (HB) estimate of
the steady state: the amplitude ``A`` solves the first-harmonic balance of
eq. 2, ``A |kappa(A) - (f/f0)^2 + j/Q(A)| = |k5| V_m``, with ``kappa`` the
secant stiffness of eq. 9 and ``1/Q`` eq. 16 (eq. 10 is exactly in
quadrature for a sinusoid). The plant starts at rest; a quick rotation of
the block by ``-A`` (a smooth cubic step over two plant steps,
:func:`kick_motion`) leaves the RLG body behind, so the deflection jumps to
``A`` with almost no rate: the state ``A cos(2 pi f (t - t_c))`` with ``t_c``
the middle of the kick. The drive phase is chosen so that this is the HB
solution. The kick is ordinary block motion, so this works with any plant
integrator; the block then stays at ``-A`` (irrelevant to the deflection).
What is left of the transient (the HB error, the kick's error of order
``(omega h)^2``, the half-cycle without eq. 10's term) decays during
``settle_s``; the amplitude is then the first-harmonic amplitude fitted
(sine, cosine, constant) over ``measure_s``.

Where the HB equation has three roots (a bent resonance curve) the branch is
a setting; for the paper's parameters and the voltages used here there is
only one.

Functions
---------
.. autosummary::

   AfcSettings
   hb_stiffness_ratio
   hb_amplitudes
   steady_amplitude
   simulate_afc
   fit_afc
   sensitivity
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from sins_sim import _validate as v
from sins_sim.models.drive import DriveSignal
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.suspension import SuspensionParams, nonl_array

__all__ = ["PARAM_NAMES", "AfcSettings", "AfcFit", "hb_stiffness_ratio", "hb_amplitudes", "hb_start",
           "kick_motion", "KICK_STEPS", "steady_amplitude", "simulate_afc", "params_vector", "with_params",
           "fit_afc", "sensitivity", "first_harmonic"]

#: Fitted parameters, in the order of the paper's table (f0 stands for omega0).
PARAM_NAMES = ("f0", "k1", "k2", "k3", "k4", "k5")
_FIELDS = {"f0": "f0_hz", "k1": "k1", "k2": "k2", "k3": "k3", "k4": "k4", "k5": "k5"}

_GL_X, _GL_W = np.polynomial.legendre.leggauss(48)
_TH = 0.25 * math.pi * (_GL_X + 1.0)  # nodes on [0, pi/2]
_TW = 0.25 * math.pi * _GL_W


@dataclass(frozen=True)
class AfcSettings:
    """How one AFC point is simulated.

    Parameters
    ----------
    settle_s : float
        Time from the HB start before the measurement (s), >= 0.
    measure_s : float
        Window of the first-harmonic fit (s), > 0.
    plant_rate_hz : float
        Plant integration rate (Hz); the drive DAC runs at the same rate.
    hysteresis : {"paper", "masing"}
        Eq. 10 rule in the plant.
    branch : {"upper", "lower"}
        HB root to start from when there are several.
    """

    settle_s: float = 0.3
    measure_s: float = 0.05
    plant_rate_hz: float = 72000.0
    hysteresis: str = "paper"
    branch: str = "upper"

    def __post_init__(self):
        v.non_negative("afc", "settle_s", self.settle_s)
        v.positive("afc", "measure_s", self.measure_s)
        v.positive("afc", "plant_rate_hz", self.plant_rate_hz)
        v.choice("afc", "branch", self.branch, ("upper", "lower"))


def hb_stiffness_ratio(amplitude, k1: float, k2: float) -> np.ndarray:
    """Secant stiffness ``kappa(A) = 1 + N1(A)/A`` of eq. 9 by first-harmonic balance (vectorised).

    ``N1(A) = (4/pi) int_0^{pi/2} Nonl(A cos th) cos th d th`` (Nonl is odd),
    48-point Gauss-Legendre; equals ``SuspensionParams.stiffness_ratio_hb``.
    """
    a = np.atleast_1d(np.asarray(amplitude, dtype=np.float64))
    c = np.cos(_TH)
    vals = nonl_array(a[:, None] * c[None, :], k1, k2) * c[None, :]
    n1 = (4.0 / math.pi) * (vals @ _TW)
    out = 1.0 + np.where(a > 0.0, n1 / np.where(a > 0.0, a, 1.0), 0.0)
    return out.reshape(np.shape(amplitude))


def _hb_mismatch(a, s: SuspensionParams, r2: float, p: float):
    kap = hb_stiffness_ratio(a, s.k1, s.k2)
    iq = s.k3 * (1.0 + s.k4 * a) + 2.0 * s.zeta
    return a * np.hypot(kap - r2, iq) - p


def hb_amplitudes(s: SuspensionParams, v_m: float, f_hz: float, a_max: float | None = None,
                  n_grid: int = 400) -> np.ndarray:
    """All steady amplitudes (rad) that harmonic balance allows at drive ``v_m`` (V), ``f_hz`` (Hz).

    Roots of ``A |kappa(A) - (f/f0)^2 + j/Q(A)| = |k5| V_m`` on ``(0, a_max]``
    (default: ``|k5| V_m / (k3 min(1, 1 + k4 A))`` bound, 4 x the resonant
    amplitude), increasing.
    """
    p = abs(s.k5) * v.non_negative("afc", "v_m", v_m)
    if p == 0.0:
        return np.zeros(1)
    r2 = (v.positive("afc", "f_hz", f_hz) / s.f0_hz) ** 2
    if a_max is None:
        a_max = 4.0 * p / (s.k3 + 2.0 * s.zeta)
    grid = np.linspace(a_max / n_grid, a_max, n_grid)
    g = _hb_mismatch(grid, s, r2, p)
    roots = []
    if g[0] > 0.0:
        roots.append(optimize.brentq(lambda x: float(_hb_mismatch(x, s, r2, p)), 1e-30, grid[0], xtol=1e-18))
    for i in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:])):
        roots.append(optimize.brentq(lambda x: float(_hb_mismatch(x, s, r2, p)), grid[i], grid[i + 1],
                                     xtol=1e-18, rtol=1e-13))
    if not roots:
        raise ValueError(f"afc: no harmonic-balance amplitude below {a_max!r} rad at {f_hz!r} Hz, {v_m!r} V")
    return np.array(sorted(roots))


def hb_start(s: SuspensionParams, v_m: float, f_hz: float, branch: str = "upper",
             t_c: float = 0.0) -> tuple[float, float]:
    """HB amplitude ``A`` (rad) and the drive phase (rad) that makes the HB solution ``A cos(2 pi f (t - t_c))``.

    With ``V = V_m cos(2 pi f t + phase)``.
    """
    roots = hb_amplitudes(s, v_m, f_hz)
    a = float(roots[-1] if branch == "upper" else roots[0])
    r2 = (f_hz / s.f0_hz) ** 2
    kap = float(hb_stiffness_ratio(a, s.k1, s.k2))
    iq = s.inverse_q(a)
    # phasor of delta for V = V_m cos(w t): -k5 V_m / (kappa - r^2 + j/Q)
    arg = math.atan2(0.0, -s.k5) - math.atan2(iq, kap - r2)
    return a, -2.0 * math.pi * f_hz * t_c - arg


#: Plant steps over which :func:`kick_motion` turns the block.
KICK_STEPS = 2


def kick_motion(amplitude_rad: float, rate_hz: float, steps: int = KICK_STEPS):
    """Block rotation by ``-amplitude_rad`` over ``steps`` plant steps (a cubic smooth step) from t = 0.

    ``angle = -A (3 u^2 - 2 u^3)``, ``u = t / T``, ``T = steps / rate_hz``;
    the plant's cubic Hermite interpolation of the block represents it
    exactly. The RLG body stays almost where it was, so the deflection
    becomes ``A`` with a rate of order ``omega0^2 A T / 2``: a start at
    amplitude ``A`` centred on ``t_c = T / 2``.

    Returns
    -------
    (motion, t_c) : (CallableMotion, float)
    """
    from sins_sim.models.motion import CallableMotion

    a = v.finite("afc", "amplitude_rad", amplitude_rad)
    dur = steps / v.positive("afc", "rate_hz", rate_hz)

    def f(t):
        u = np.clip(np.asarray(t, dtype=np.float64) / dur, 0.0, 1.0)
        return -a * (3.0 * u * u - 2.0 * u ** 3), -a * 6.0 * u * (1.0 - u) / dur

    return CallableMotion(f), 0.5 * dur


def first_harmonic(x, t, f_hz: float) -> tuple[float, float]:
    """Least-squares fit of ``c + a sin + b cos`` at ``f_hz``: (amplitude, phase of the sine)."""
    w = 2.0 * math.pi * f_hz
    m = np.column_stack((np.sin(w * t), np.cos(w * t), np.ones_like(t)))
    coef, *_ = np.linalg.lstsq(m, x, rcond=None)
    return float(math.hypot(coef[0], coef[1])), float(math.atan2(coef[1], coef[0]))


def steady_amplitude(s: SuspensionParams, v_m: float, f_hz: float, settings: AfcSettings = AfcSettings()) -> float:
    """Steady first-harmonic dither amplitude (rad) of eq. 2 driven by ``V_m cos(2 pi f t)``, block at rest.

    The run starts on the HB estimate (module docstring) and lasts
    ``settle_s + measure_s``.
    """
    fs = settings.plant_rate_hz
    kick, t_c = kick_motion(1.0, fs)
    a0, phase = hb_start(s, v_m, f_hz, settings.branch, t_c)
    kick, _ = kick_motion(a0, fs)
    plant = Plant(s, PlantSettings(rate_hz=fs, hysteresis=settings.hysteresis))
    n_settle = int(round(settings.settle_s * fs))
    n_meas = max(int(round(settings.measure_s * fs)), 8)
    n = n_settle + n_meas
    drive = DriveSignal(frequency_hz=f_hz, v_m=v_m, dac_rate_hz=fs, phase_rad=phase)
    volts = drive.samples(0, n)
    t = np.arange(1, n + 1) / fs
    angle, rate = kick.angle_rate(t)
    plant.reset(0.0, 0.0)
    delta = plant.step(angle, rate, volts)
    amp, _ = first_harmonic(delta[n_settle:], t[n_settle:], f_hz)
    return amp


def simulate_afc(s: SuspensionParams, volts, freqs, settings: AfcSettings = AfcSettings()) -> np.ndarray:
    """Steady amplitudes (rad), shape ``(len(volts), len(freqs))``.

    ``freqs`` is either one list for every voltage or one list per voltage
    (shape ``(len(volts), n)``).
    """
    volts = np.atleast_1d(np.asarray(volts, dtype=np.float64))
    freqs = np.asarray(freqs, dtype=np.float64)
    if freqs.ndim == 1:
        freqs = np.broadcast_to(freqs, (volts.size, freqs.size))
    out = np.empty(freqs.shape)
    for i, vm in enumerate(volts):
        for j, f in enumerate(freqs[i]):
            out[i, j] = steady_amplitude(s, float(vm), float(f), settings)
    return out


def params_vector(s: SuspensionParams) -> np.ndarray:
    """(f0, k1, k2, k3, k4, k5) of a suspension."""
    return np.array([getattr(s, _FIELDS[name]) for name in PARAM_NAMES], dtype=np.float64)


def with_params(s: SuspensionParams, p) -> SuspensionParams:
    """A copy of ``s`` with (f0, k1, k2, k3, k4, k5) = ``p``."""
    return s.replace(**{_FIELDS[name]: float(x) for name, x in zip(PARAM_NAMES, p)})


@dataclass(frozen=True)
class AfcFit:
    """Result of :func:`fit_afc`.

    Attributes
    ----------
    params : SuspensionParams
        The minimiser.
    rms : float
        ``sqrt(S)`` at the minimum (rad).
    model : ndarray
        Model amplitudes there (rad).
    nfev : int
        Objective evaluations (each one AFC set).
    success : bool
    start_rms : float
        ``sqrt(S)`` at the start (rad).
    """

    params: SuspensionParams
    rms: float
    model: np.ndarray
    nfev: int
    success: bool
    start_rms: float


def fit_afc(measured, volts, freqs, start: SuspensionParams, settings: AfcSettings = AfcSettings(),
            max_nfev: int = 60, diff_step: float = 1e-4) -> AfcFit:
    """Fit (omega0, k1..k5) to a measured AFC set by ``scipy.optimize.least_squares``.

    The unknowns are the parameters divided by their start values (all of
    order 1); residuals are in arcsec-sized units (rad / 1e-5) so that the
    tolerances mean something. ``S`` is the mean of the squared residuals.

    Parameters
    ----------
    measured : ndarray, shape (n_volts, n_freqs)
        Measured steady amplitudes (rad).
    volts, freqs
        As :func:`simulate_afc`.
    start : SuspensionParams
        Start of the search; fields other than the six are kept.
    max_nfev : int
        Evaluation budget (each evaluation simulates the whole set).
    diff_step : float
        Relative finite-difference step of the Jacobian.
    """
    measured = np.asarray(measured, dtype=np.float64)
    p0 = params_vector(start)
    unit = 1e-5

    def model(x):
        try:
            s = with_params(start, x * p0)
            return simulate_afc(s, volts, freqs, settings)
        except ValueError:
            return np.full(measured.shape, np.nan)

    def resid(x):
        r = (model(x) - measured).ravel() / unit
        return np.where(np.isfinite(r), r, 1e6)

    r0 = resid(np.ones(p0.size))
    sol = optimize.least_squares(resid, np.ones(p0.size), method="trf", x_scale=1.0, diff_step=diff_step,
                                 max_nfev=max_nfev, xtol=1e-10, ftol=1e-10, gtol=1e-10)
    best = with_params(start, sol.x * p0)
    mod = simulate_afc(best, volts, freqs, settings)
    rms = float(np.sqrt(np.mean((mod - measured) ** 2)))
    return AfcFit(params=best, rms=rms, model=mod, nfev=int(sol.nfev), success=bool(sol.success),
                  start_rms=float(np.sqrt(np.mean((r0 * unit) ** 2))))


def sensitivity(params: SuspensionParams, measured, volts, freqs, settings: AfcSettings = AfcSettings(),
                pct: float = 1.0) -> dict:
    """The paper's sensitivity table: RMS increase per ``pct`` % of each parameter.

    Returns
    -------
    dict
        ``{name: {"rms_increase": d, "model_change_rms": m}}`` in rad per %,
        where ``d = (RMS(p + pct %) - RMS(p)) / pct`` is the paper's
        definition (the increase of ``sqrt(S)``) and ``m`` the RMS of the
        change of the model amplitudes itself (independent of the residual
        floor at the minimum).
    """
    measured = np.asarray(measured, dtype=np.float64)
    base = simulate_afc(params, volts, freqs, settings)
    rms0 = float(np.sqrt(np.mean((base - measured) ** 2)))
    p = params_vector(params)
    out = {}
    for i, name in enumerate(PARAM_NAMES):
        q = p.copy()
        q[i] *= 1.0 + pct / 100.0
        mod = simulate_afc(with_params(params, q), volts, freqs, settings)
        rms = float(np.sqrt(np.mean((mod - measured) ** 2)))
        out[name] = {"rms_increase": (rms - rms0) / pct,
                     "model_change_rms": float(np.sqrt(np.mean((mod - base) ** 2))) / pct}
    return out
