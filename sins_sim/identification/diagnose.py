"""Sim-to-real gap: refit, noise floor, localisation, candidate effects, verdict, report.

Given a recording (``sins_sim.io.recording``), :func:`diagnose_recording`

1. **refits** the nominal parameters ``f0, k1..k5`` of every axis by
   simulating the same experiment (same drive, block motion and readout
   instants, ``sins_sim.simulation.experiment``, exact integrator at about
   28.8 kHz) and minimising the residual with
   ``scipy.optimize.least_squares``. The axes are independent in the
   nominal model, so each axis is fitted alone (in parallel threads).
   Parametrisation: ``(F(a_ref), k1, k2, 1/Q(a_ref), k4, k5)`` relative to
   their nominal values, with ``F`` the harmonic-balance resonance and
   ``1/Q = k3 (1 + k4 a)`` at the measured dither amplitude ``a_ref``:
   what a dither shows directly, so the fit does not crawl along the
   valleys ``(f0, k1, k2)`` and ``(k3, k4)`` that a steady dither leaves.
   A weak prior (1 % on F, 30 % on the others) keeps unresolved directions
   at the nominal values. Stages: a grid over F (a dither far off phase is
   far from the quadratic regime), then ``F, 1/Q, k5``, then all six;
   the solver's unit step is one plausible variation of each parameter
   (``_XSCALE``). Uncertainty: from the Jacobian and the prior, the
   residual variance inflated by the residual's correlation length.
   A recording longer than ``1.5 window_s`` is fitted on its first
   ``window_s`` seconds and then refined on the whole of it;
2. estimates the **noise floor** from the data (:func:`noise_floor`): the
   quantisation ``q / sqrt(12)``, or more where the residual's
   high-frequency band (where the model has no content) says so;
3. **localises** the gap (:func:`localise`): per axis the excess of the
   residual's RMS over the floor; on the worst axis the band holding 90 %
   of the excess power (Welch spectrum) and its peaks, the time window
   holding 90 % of the excess energy (residual envelope), and for AFC
   sweeps the operating points (:func:`operating_points`, segments of
   constant drive amplitude and frequency found from ``drive_v``) ranked by
   their excess;
4. **explains**: every catalogue effect (``sins_sim.models.effects``) that
   the experiment can show is fitted together with the nominal parameters
   on each axis with a significant gap, from the best of a few starts of
   its parameters (for ``block_mode`` including the residual's peaks).
   ``gap_reduction`` is the fraction of the excess residual power over the
   floor it removes; the ``score`` is the RMS residual on held-out data
   (the recording is cut in blocks; even blocks fit, odd blocks score), so
   an extra parameter that only fits noise gains nothing;
5. gives a **verdict**: ``none`` when the refit nominal model sits at the
   floor (excess RMS below ``max(rel_tol * floor, abs_tol)``: a tolerance
   that covers integration-method, interpolation and noise differences
   between simulators); the best-scoring effect when it closes the gap
   (leaves an excess within the tolerance, or below ``close_fraction`` of
   the excess it started from, and removes at least ``min_gap_reduction``
   of the power), with the effects that do as well within
   ``ALTERNATIVE_MARGIN`` named as ``alternatives``; else ``unknown`` (the
   localisation is then the answer).

Conventions: the measured angle is ``counts * q + q / 2`` (the floor of the
counter makes ``counts * q`` half a quantum low on average). A recording
with ``initial_state = "unknown"`` is simulated from rest 6 time constants
``2 Q / omega`` before its start, the drive (and table motion) before
``t = 0`` continued as it starts; the suspension's state at ``t = 0`` is
then fitted as well (two more parameters: a change of deflection and of
its rate there, applied as a fictitious block kick that only the plant
sees), a constant (the counter's start) is profiled out, and the first
half time constant is left out.

Functions
---------
.. autosummary::

   DiagnoseSettings
   noise_floor
   fit_axis
   localise
   operating_points
   diagnose_recording
   write_report
"""

from __future__ import annotations

import json
import math
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import optimize, signal
from scipy.interpolate import CubicSpline

from sins_sim import _validate as v
from sins_sim.identification.afc import hb_stiffness_ratio
from sins_sim.io.recording import NOMINAL_KEYS, Recording
from sins_sim.models.effects import EFFECTS, Effect, Param
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import (FIT_SETTINGS, ExperimentInputs, ExperimentSettings, simulate_axis,
                                            suspension_from_nominal)
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["DiagnoseSettings", "AxisFit", "Diagnosis", "noise_floor", "fit_axis", "localise", "operating_points",
           "diagnose_recording", "write_report"]

#: Candidates scoring within this fraction of the best one are named as alternatives of the verdict.
ALTERNATIVE_MARGIN = 0.05
#: Relative bounds of the nominal parameters in the fit (multiples of the nominal value).
#: A unit's parameters differ from the nominal ones by per cent (f0) or tens of per cent (k); wider
#: bounds only let the refit bend weakly resolved parameters to absorb an unmodelled effect.
_BOUNDS = {"f0_hz": (0.97, 1.03), "k1": (0.0, 5.0), "k2": (0.2, 5.0), "k3": (0.2, 5.0), "k4": (-1.0, 5.0),
           "k5": (0.2, 5.0)}
#: Termination tolerance of the least-squares stages (relative change of the cost, step in solver units).
_TOL = 1e-4
#: Plausible variation of the fitted nominal quantities (F(a_ref), k1, k2, 1/Q, k4, k5), relative:
#: the solver's unit step in each (see ``_solve``).
_XSCALE = np.array([0.002, 0.1, 0.1, 0.05, 0.1, 0.05])
#: Typical sizes of (F, k1, k2, 1/Q, k4, k5), used as scale where a nominal value is 0.
_TYPICAL = np.array([386.0, 1.75e-4, 1.05e-3, 5e-3, 250.0, 1.2e-5])
#: Bounds (in those typical units) of a parameter whose nominal value is 0.
_ZERO_BOUNDS = {"f0_hz": (0.5, 2.0), "k1": (0.0, 5.0), "k2": (0.2, 5.0), "k3": (0.0, 5.0), "k4": (-1.0, 5.0),
                "k5": (-5.0, 5.0)}
#: Relative finite-difference steps of the Jacobian (F is resolved to 1e-6 and acts strongly).
_STEPS = {"f0_hz": 2e-7, "k1": 1e-3, "k2": 1e-3, "k3": 1e-3, "k4": 1e-3, "k5": 1e-4}


@dataclass(frozen=True)
class DiagnoseSettings:
    """Settings of the diagnosis.

    Parameters
    ----------
    experiment : ExperimentSettings
        How the model is simulated (plant rate, integrator).
    prior_f0, prior_k : float
        Relative standard deviation of the prior on f0 and on k1..k5 around
        the recording's nominal values (keeps unresolvable directions there).
    max_nfev, candidate_nfev : int
        Evaluation budget of the baseline's and of each candidate's last least-squares stage
        (Jacobian columns not counted; the first stage gets half).
    window_s : float or None
        A recording longer than 1.5 x this is fitted on its first ``window_s`` seconds and the
        result refined on the whole recording (``polish_nfev`` evaluations); ``None``: always
        the whole recording.
    polish_nfev : int
        Evaluation budget of that refinement.
    rel_tol, abs_tol_arcsec : float
        The gap is significant when the excess RMS over the floor exceeds
        ``max(rel_tol * floor, abs_tol)``.
    min_gap_reduction : float
        Fraction of the excess power an effect must remove to be the verdict.
    close_fraction : float
        An effect closes the gap when the excess RMS it leaves on every axis is below the
        tolerance or below this fraction of the excess RMS the baseline left; only an
        effect that closes the gap can be the verdict.
    block_s : float or None
        Length of the fit / held-out blocks (s); ``None``: 1/20 of the
        recording, between 25 ms and 0.5 s.
    effects : tuple of str or None
        Catalogue effects to try (``None``: all).
    threads : int
        Simulations run in parallel for the Jacobian (the kernels release the GIL).
    """

    experiment: ExperimentSettings = FIT_SETTINGS
    prior_f0: float = 0.01
    prior_k: float = 0.3
    max_nfev: int = 30
    candidate_nfev: int = 16
    window_s: float | None = 3.0
    polish_nfev: int = 4
    rel_tol: float = 0.5
    abs_tol_arcsec: float = 0.02
    min_gap_reduction: float = 0.6
    close_fraction: float = 0.15
    block_s: float | None = None
    effects: tuple | None = None
    threads: int = 2

    def __post_init__(self):
        v.positive("diagnose", "prior_f0", self.prior_f0)
        v.positive("diagnose", "prior_k", self.prior_k)
        if self.window_s is not None:
            v.positive("diagnose", "window_s", self.window_s)
        for name in ("max_nfev", "candidate_nfev", "polish_nfev"):
            val = getattr(self, name)
            if int(val) != val or val < 2:
                raise ValueError(f"diagnose.{name}: must be an integer >= 2, got {val!r}")
        v.non_negative("diagnose", "rel_tol", self.rel_tol)
        v.non_negative("diagnose", "abs_tol_arcsec", self.abs_tol_arcsec)
        g = v.finite("diagnose", "min_gap_reduction", self.min_gap_reduction)
        if not 0.0 < g <= 1.0:
            raise ValueError(f"diagnose.min_gap_reduction: must be in (0, 1], got {g!r}")
        c = v.finite("diagnose", "close_fraction", self.close_fraction)
        if not 0.0 <= c < 1.0:
            raise ValueError(f"diagnose.close_fraction: must be in [0, 1), got {c!r}")
        if self.block_s is not None:
            v.positive("diagnose", "block_s", self.block_s)
        for name in self.effects or ():
            v.choice("diagnose", "effects", name, EFFECTS)
        if int(self.threads) != self.threads or self.threads < 1:
            raise ValueError(f"diagnose.threads: must be an integer >= 1, got {self.threads!r}")


# --- noise floor ---------------------------------------------------------------------------------
def noise_floor(residual: np.ndarray, quantum_rad: float, fs_hz: float) -> dict:
    """Noise floor of a residual from the data: quantisation and the high-frequency band.

    The readout quantisation alone gives ``q / sqrt(12)``. White noise of
    any other origin shows in the residual's spectrum where the model has
    nothing to say: the level is the median of the Welch PSD over
    ``[0.55, 0.95] fs/2`` (a median, so that dither harmonics or a
    resonance line in that band do not count), and ``sigma = sqrt(level fs/2)``.

    Returns
    -------
    dict
        ``floor_rad`` (the larger of the two), ``quantisation_rad``, ``white_rad``.
    """
    x = np.asarray(residual, dtype=np.float64)
    qn = quantum_rad / math.sqrt(12.0)
    nper = int(min(256, max(16, x.size // 8)))
    f, p = signal.welch(x - x.mean(), fs=fs_hz, nperseg=nper, detrend="linear")
    band = (f >= 0.55 * fs_hz / 2) & (f <= 0.95 * fs_hz / 2)
    white = math.sqrt(float(np.median(p[band])) * fs_hz / 2.0) if np.any(band) else 0.0
    return {"floor_rad": max(qn, white), "quantisation_rad": qn, "white_rad": white}


# --- fitting -----------------------------------------------------------------------------------------
@dataclass
class AxisFit:
    """Result of one least-squares fit on one axis.

    Attributes
    ----------
    axis : str
    suspension : SuspensionParams
        The fitted nominal parameters.
    effect : Effect or None
        The fitted effect (acting on this axis only).
    model : ndarray
        Model angle at every sample (rad), offset included.
    residual : ndarray
        Measured minus model (rad); NaN where excluded (settling).
    sigma : dict
        One-sigma uncertainty of each fitted parameter (nominal: ``f0_hz,
        k1..k5``; effect: its parameters).
    nfev : int
        Model evaluations (Jacobian columns included).
    train_rms, heldout_rms, rms : float
        RMS residual on the fit blocks, the held-out blocks and all used samples (rad).
    start_state : (d_delta, d_rate) or None
        The fitted state change at ``t = 0`` of a recording that starts mid-operation.
    """

    axis: str
    suspension: SuspensionParams
    effect: Effect | None
    model: np.ndarray
    residual: np.ndarray
    sigma: dict
    nfev: int
    train_rms: float = math.nan
    heldout_rms: float = math.nan
    rms: float = math.nan
    start_state: tuple | None = None


class _Problem:
    """One axis of a recording: data, masks, and the model as a function of scaled parameters.

    The nominal parameters are fitted as ``u = (F(a_ref), k1, k2, 1/Q(a_ref), k4, k5)``
    relative to their nominal values: ``F(a_ref)`` the harmonic-balance resonance at the
    operating amplitude and ``1/Q(a_ref) = k3 (1 + k4 a_ref)``. These are what a dither
    at ``a_ref`` shows directly, so the fit does not have to follow the long valleys of
    ``(f0, k1, k2)`` and ``(k3, k4)`` that a stationary recording leaves.
    """

    def __init__(self, inputs: ExperimentInputs, axis: str, y: np.ndarray, nominal: SuspensionParams,
                 settings: DiagnoseSettings, used: np.ndarray, train: np.ndarray, offset: bool, sigma_rad: float,
                 coupled: dict | None, a_ref: float, skip: int = 0):
        self.inputs = inputs
        self.skip = int(skip)
        self.axis = axis
        self.y = y
        self.nominal = nominal
        self.settings = settings
        self.used = used
        self.train = train
        self.offset = offset
        self.sigma = sigma_rad
        self.coupled = coupled
        self.a_ref = float(a_ref)
        self.p_nom = np.array([getattr(nominal, k) for k in NOMINAL_KEYS])
        u = self.to_u(self.p_nom)
        # scale of each fitted quantity: its nominal value, or a typical size where that is 0
        self.u_nom = np.where(u != 0.0, np.abs(u), _TYPICAL)
        self.x_c = u / self.u_nom  # the nominal point (+-1, or 0)
        lo, hi = [], []
        for k, xc in zip(NOMINAL_KEYS, self.x_c):
            a, b = _BOUNDS[k]
            if xc != 0.0:
                lo.append(min(a * xc, b * xc))
                hi.append(max(a * xc, b * xc))
            else:
                lo.append(_ZERO_BOUNDS[k][0])
                hi.append(_ZERO_BOUNDS[k][1])
        self.lo = np.array(lo)
        self.hi = np.array(hi)
        self.nfev = 0
        # a recording that starts mid-operation: the suspension's state at t = 0 is fitted too, as a
        # change (delta, rate) of the model's state there (``simulate_axis``'s kick)
        self.kick_index = self.skip * inputs.grid(settings.experiment).r
        self.nuisance = []
        if offset:
            w = nominal.omega0
            self.nuisance = [Param("start_delta_rad", "state change at t = 0", -3.0 * a_ref, 3.0 * a_ref, a_ref),
                             Param("start_rate_rad_s", "state change at t = 0", -3.0 * a_ref * w, 3.0 * a_ref * w,
                                   a_ref * w)]

    def to_u(self, p) -> np.ndarray:
        """(f0, k1, k2, k3, k4, k5) -> (F(a_ref), k1, k2, 1/Q(a_ref), k4, k5)."""
        f0, k1, k2, k3, k4, k5 = p
        kap = float(hb_stiffness_ratio(self.a_ref, k1, k2))
        return np.array([f0 * math.sqrt(kap), k1, k2, k3 * (1.0 + k4 * self.a_ref), k4, k5])

    def to_p(self, u) -> np.ndarray:
        fr, k1, k2, iq, k4, k5 = u
        kap = float(hb_stiffness_ratio(self.a_ref, k1, k2))
        return np.array([fr / math.sqrt(kap), k1, k2, iq / (1.0 + k4 * self.a_ref), k4, k5])

    def suspension(self, xn) -> SuspensionParams:
        p = self.to_p(np.asarray(xn) * self.u_nom)
        return self.nominal.replace(**{k: float(val) for k, val in zip(NOMINAL_KEYS, p)})

    def x_of(self, s: SuspensionParams) -> np.ndarray:
        return self.to_u(np.array([getattr(s, k) for k in NOMINAL_KEYS])) / self.u_nom

    def p_jacobian(self, xn) -> np.ndarray:
        """d p / d x (6 x 6), for propagating the covariance to (f0, k1..k5)."""
        g = np.empty((6, 6))
        p0 = self.to_p(np.asarray(xn) * self.u_nom)
        for j in range(6):
            dx = np.array(xn, dtype=np.float64)
            hj = 1e-6 * max(1.0, abs(dx[j]))
            dx[j] += hj
            g[:, j] = (self.to_p(dx * self.u_nom) - p0) / hj
        return g

    def model(self, sus: SuspensionParams, effect: Effect | None, start=None) -> np.ndarray:
        """Model angle at the recording's samples; ``start`` = (d_delta, d_rate) at t = 0 or None."""
        self.nfev += 1
        effects = () if effect is None else (effect,)
        kick = None if start is None else (self.kick_index, float(start[0]), float(start[1]))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = simulate_axis(self.inputs, self.axis, sus, effects, self.settings.experiment, coupled=self.coupled,
                              kick=kick)
        m = m[self.skip:]
        if self.offset:
            m = m + float(np.mean((self.y - m)[self.used]))
        return m


def _solve(prob: _Problem, effect_cls, x0, space, max_nfev, threads, mask, free=None):
    """Least squares over (nominal, effect) parameters on the samples ``mask``.

    ``x0`` is the full start vector (nominal relative, then the start state
    of a recording that starts mid-operation and the effect's parameters, in
    units of their ``Param.scale``; ``space`` lists those); only the indices
    ``free`` move. The solver
    works in ``z = (x - x0) / _XSCALE``: the first trust region then spans
    about one plausible variation of every parameter (a unit's f0 is off
    by 0.2 %, its k by tens of %), not ``|x0|``, which keeps the first
    steps of a badly started fit from jumping into nonsense.

    Returns ``(x, jac, unpack)``: the full solution, the Jacobian of the
    data residuals with respect to the free ``x`` (columns in ``free``
    order), and a function ``x -> (SuspensionParams, Effect or None, start state or None)``.
    """
    n_nom = len(NOMINAL_KEYS)
    n = n_nom + len(space)
    free = np.arange(n) if free is None else np.asarray(free)
    scales = np.array([p.scale for p in space])
    lo = np.concatenate([prob.lo, [p.lo / p.scale for p in space]])
    hi = np.concatenate([prob.hi, [p.hi / p.scale for p in space]])
    xs = np.concatenate([_XSCALE, np.ones(len(space))])[free]
    steps = np.array([_STEPS[k] for k in NOMINAL_KEYS] + [1e-3] * len(space))
    # a start on a bound stalls the trust-region reflective solver (its scaling shrinks the steps there
    # to nothing): start the free parameters a little inside
    x0 = np.asarray(x0, dtype=np.float64).copy()
    xs_all = np.concatenate([_XSCALE, np.ones(len(space))])
    margin = np.minimum(0.05 * xs_all, 0.25 * (hi - lo))
    x0[free] = np.clip(x0[free], (lo + margin)[free], (hi - margin)[free])
    x0 = np.clip(x0, lo, hi)
    prior_sd = np.array([prob.settings.prior_f0] + [prob.settings.prior_k] * (n_nom - 1))
    cache = {}

    n_nui = len(prob.nuisance)

    def unpack(x):
        sus = prob.suspension(x[:n_nom])
        start = tuple(float(val) for val in x[n_nom:n_nom + n_nui] * scales[:n_nui]) if n_nui else None
        eff = None
        if effect_cls is not None:
            eff = effect_cls.build(prob.axis, prob.inputs.axes, {p.name: float(xi * s) for p, xi, s in
                                                                 zip(space[n_nui:], x[n_nom + n_nui:], scales[n_nui:])})
        return sus, eff, start

    def full(z):
        x = x0.copy()
        x[free] = x0[free] + z * xs
        return x

    def fun(z):
        key = z.tobytes()
        if key in cache:
            return cache[key]
        x = full(z)
        try:
            sus, eff, start = unpack(x)
            m = prob.model(sus, eff, start)
            r = (prob.y - m)[mask] / prob.sigma
            if not np.all(np.isfinite(r)):
                raise ValueError("non-finite model")
        except ValueError:
            r = np.full(int(mask.sum()), 1e3)
        out = np.concatenate([r, (x[:n_nom] - prob.x_c) / prior_sd])
        if len(cache) > 64:
            cache.clear()
        cache[key] = out
        return out

    def jac(z):
        f0 = fun(z)
        x = full(z)
        hx = steps[free] * np.maximum(1.0, np.abs(x[free]))
        hx = np.where(x[free] + hx <= hi[free], hx, -hx)
        hz = hx / xs

        def col(i):
            zp = z.copy()
            zp[i] += hz[i]
            return (fun(zp) - f0) / hz[i]

        if threads > 1:
            with ThreadPoolExecutor(max_workers=threads) as ex:
                cols = list(ex.map(col, range(z.size)))
        else:
            cols = [col(i) for i in range(z.size)]
        return np.column_stack(cols)

    zlo = (lo[free] - x0[free]) / xs
    zhi = (hi[free] - x0[free]) / xs
    sol = optimize.least_squares(fun, np.zeros(free.size), jac=jac, bounds=(zlo, zhi), method="trf",
                                 x_scale=1.0, max_nfev=max_nfev, xtol=_TOL, ftol=_TOL, gtol=_TOL)
    return full(sol.x), sol.jac / xs[None, :], unpack


def _rms(x):
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else math.nan


def _correlation_length(r: np.ndarray) -> float:
    """Integrated autocorrelation time of a residual (samples, >= 1), up to the first zero crossing."""
    r = r[np.isfinite(r)]
    r = r - r.mean()
    n = r.size
    if n < 8:
        return 1.0
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:n]
    ac = ac / ac[0] if ac[0] > 0 else ac
    neg = np.flatnonzero(ac <= 0.0)
    m = int(neg[0]) if neg.size else n
    return max(1.0, 1.0 + 2.0 * float(np.sum(ac[1:m])))


#: Indices of (F(a_ref), 1/Q(a_ref), k5): what a dither shows first; the first fit stage moves only these.
_MAIN = (0, 3, 5)
#: The grid of F(a_ref) (relative to nominal) that starts a baseline fit: +-1.5 % in 0.1 % steps,
#: finer than the resonance's half width (about 0.27 % at Q = 187).
_F_GRID = np.linspace(-0.015, 0.015, 31)


def _cost(prob: _Problem, sus: SuspensionParams, effect, start=None) -> float:
    try:
        r = (prob.y - prob.model(sus, effect, start))[prob.train]
        return float(np.mean(r * r))
    except ValueError:
        return math.inf


def _bent(prob: _Problem, xn: np.ndarray) -> bool:
    """Whether k1, k2 or k4 of ``xn`` sit more than the prior's width from the nominal values."""
    idx = [1, 2, 4]
    return bool(np.any(np.abs(xn[idx] - prob.x_c[idx]) > prob.settings.prior_k))


def _drift_centred(prob: _Problem, effect_cls, xn: np.ndarray, values: dict) -> np.ndarray:
    """For a ``resonance_drift`` start: f0 moved so that f0 in the middle of the data is unchanged.

    A fit without the drift finds the recording's mean resonance; the
    drift's f0 is the one at the start of the simulation (the model's
    ``t = 0``, before any pre-roll), so a drift start keeps the mean where
    the fit found it.
    """
    if effect_cls is None or effect_cls.name != "resonance_drift":
        return xn
    rate = float(values.get("rate_hz_per_s", 0.0))
    t_mid = (prob.skip + 0.5 * prob.y.size) / prob.inputs.fs_hz
    sus = prob.suspension(xn)
    try:
        return prob.x_of(sus.replace(f0_hz=sus.f0_hz - rate * t_mid))
    except ValueError:
        return xn


def fit_axis(prob: _Problem, effect_cls=None, start: AxisFit | None = None, effect_starts=None,
             max_nfev: int | None = None, polish: bool = False) -> AxisFit:
    """Fit the nominal parameters (and an effect's) on one axis, on the training blocks.

    Stages: (0) without a start, the grid :data:`_F_GRID` of the
    operating-point resonance (the residual is far from quadratic when the
    dither's phase is off); with an effect, the best of ``effect_starts``
    at the start's nominal parameters; (1) least squares over ``F, 1/Q,
    k5``, the start state (recordings that start mid-operation) and the
    effect's parameters; (2) least squares over everything. Stages 1 and 2
    run from the start's nominal parameters and, when the start has bent
    the weakly resolved ``k1, k2, k4`` more than their prior's width
    (a baseline absorbing what the effect explains), from the recording's
    nominal ones too; the better result is kept.

    Parameters
    ----------
    prob : _Problem
    effect_cls : Effect subclass or None
    start : AxisFit, optional
        Start of the nominal parameters (default: the recording's nominal).
    effect_starts : list of dict, optional
        Candidate starts of the effect's parameters.
    max_nfev : int, optional
        Budget of the last stage (default ``settings.max_nfev``).
    polish : bool
        Only the last stage, from ``start`` (nominal and effect parameters):
        the refinement on the whole recording of a fit made on its first window.
    """
    n_nom = len(NOMINAL_KEYS)
    n_nui = len(prob.nuisance)
    threads = prob.settings.threads
    eff_space = effect_cls.fit_space(prob.axis, prob.inputs.axes) if effect_cls is not None else []
    space = list(prob.nuisance) + list(eff_space)
    x0_nom = prob.x_c.copy() if start is None else prob.x_of(start.suspension)
    x0_nui = np.zeros(n_nui)
    if start is not None and start.start_state is not None and n_nui:
        x0_nui = np.array(start.start_state) / np.array([p.scale for p in prob.nuisance])
    state0 = None if start is None else start.start_state
    x0_eff = np.zeros(len(eff_space))
    if polish:
        if start is None:
            raise ValueError("fit_axis: polish needs a start")
        if effect_cls is not None:
            vals = start.effect.values(prob.axis)
            x0_eff = np.array([vals[p.name] / p.scale for p in eff_space])
        x, jac, unpack = _solve(prob, effect_cls, np.concatenate([x0_nom, x0_nui, x0_eff]), space,
                                max_nfev or prob.settings.polish_nfev, threads, prob.train)
        return _finish(prob, x, jac, unpack, space)
    if effect_cls is None and start is None:
        def grid_cost(df):
            x = x0_nom.copy()
            x[0] = prob.x_c[0] * (1.0 + df)
            try:
                return _cost(prob, prob.suspension(x), None)
            except ValueError:
                return math.inf

        with ThreadPoolExecutor(max_workers=threads) as ex:
            costs = list(ex.map(grid_cost, _F_GRID))
        x0_nom[0] = prob.x_c[0] * (1.0 + _F_GRID[int(np.argmin(costs))])
    nominal_starts = []
    if effect_cls is not None:
        starts = effect_starts or [{p.name: (p.default if p.default is not None else 0.0) for p in eff_space}]
        # nominal starts: the given one (the baseline refit) and, where the baseline bent the weakly
        # resolved k1, k2, k4 (absorbing what the effect explains), the recording's nominal parameters

        def cost(trial):
            try:
                return _cost(prob, prob.suspension(trial[0]), effect_cls.build(prob.axis, prob.inputs.axes, trial[1]),
                             state0)
            except ValueError:
                return math.inf

        trials = [(_drift_centred(prob, effect_cls, x0_nom, st), st) for st in starts]
        if len(trials) > 1:
            with ThreadPoolExecutor(max_workers=threads) as ex:
                costs = list(ex.map(cost, trials))
        else:
            costs = [math.inf]
        best = trials[int(np.argmin(costs))]
        x0_eff = np.array([best[1].get(p.name, 0.0) / p.scale for p in eff_space])
        x0_nom = best[0].copy()
        if start is not None and _bent(prob, x0_nom):
            nominal_starts.append(_drift_centred(prob, effect_cls, prob.x_c, best[1]))
    stage1 = list(_MAIN) + list(range(n_nom, n_nom + len(space)))
    budget = max_nfev or (prob.settings.max_nfev if effect_cls is None else prob.settings.candidate_nfev)
    best, best_cost = None, math.inf
    for xn in [x0_nom] + nominal_starts:
        x, _, _ = _solve(prob, effect_cls, np.concatenate([xn, x0_nui, x0_eff]), space, max(4, budget // 2),
                         threads, prob.train, free=stage1)
        x, jac, unpack = _solve(prob, effect_cls, x, space, budget, threads, prob.train)
        c = _cost(prob, *unpack(x))
        if best is None or c < best_cost:
            best, best_cost = (x, jac, unpack), c
    return _finish(prob, *best, space)


def _finish(prob: _Problem, x, jac, unpack, space) -> AxisFit:
    """The fit's model, residual and uncertainties at the solution ``x``."""
    n_nom = len(NOMINAL_KEYS)
    sus, eff, state = unpack(x)
    model = prob.model(sus, eff, state)
    res = prob.y - model
    res = np.where(prob.used, res, np.nan)
    # uncertainty: J^T J of the data part plus the prior, the residual variance inflated by the
    # residual's correlation length (neighbouring samples are not independent)
    nd = int(prob.train.sum())
    jd = jac[:nd]
    r_train = res[prob.train]
    dof = max(1, nd - x.size)
    s2 = float(np.sum(r_train * r_train)) / dof / prob.sigma ** 2 * _correlation_length(r_train)
    prior = np.concatenate([1.0 / np.array([prob.settings.prior_f0] + [prob.settings.prior_k] * (n_nom - 1)) ** 2,
                            np.zeros(len(space))])
    try:
        cov = np.linalg.pinv(jd.T @ jd + np.diag(prior)) * s2
    except np.linalg.LinAlgError:
        cov = np.full((x.size, x.size), math.nan)
    gmap = prob.p_jacobian(x[:n_nom])
    cov_p = gmap @ cov[:n_nom, :n_nom] @ gmap.T
    sigma = {k: float(math.sqrt(max(0.0, cov_p[i, i]))) for i, k in enumerate(NOMINAL_KEYS)}
    for j, p in enumerate(space):
        sigma[p.name] = float(math.sqrt(max(0.0, cov[n_nom + j, n_nom + j])) * p.scale)
    heldout = prob.used & ~prob.train
    return AxisFit(axis=prob.axis, suspension=sus, effect=eff, model=model, residual=res, sigma=sigma,
                   nfev=prob.nfev, train_rms=_rms(res[prob.train]),
                   heldout_rms=_rms(res[heldout]) if heldout.any() else math.nan, rms=_rms(res), start_state=state)


# --- localisation ------------------------------------------------------------------------------------
def _sine_fit(seg: np.ndarray, fs_hz: float, f_guess: float | None = None):
    """Least-squares ``c cos + s sin`` at a refined frequency: (amplitude, frequency, phase, rms error)."""
    n = seg.size
    t = np.arange(n) / fs_hz
    if f_guess is None:
        spec = np.abs(np.fft.rfft(seg * np.hanning(n), 8 * n))
        f_guess = float(np.fft.rfftfreq(8 * n, 1.0 / fs_hz)[int(np.argmax(spec[1:])) + 1])

    def design(f):
        w = 2.0 * math.pi * f
        return np.column_stack([np.cos(w * t), np.sin(w * t)])

    def res(p):
        d = design(p[0])
        return d @ np.linalg.lstsq(d, seg, rcond=None)[0] - seg

    f = float(optimize.least_squares(res, [f_guess], method="lm", max_nfev=40).x[0])
    c, s = np.linalg.lstsq(design(f), seg, rcond=None)[0]
    err = float(np.sqrt(np.mean(res([f]) ** 2)))
    return float(math.hypot(c, s)), abs(f), float(math.atan2(-s, c)), err


def operating_points(drive: np.ndarray, drive_fs_hz: float, block_s: float = 0.02, rel_tol: float = 0.01,
                     freq_tol_hz: float = 0.05) -> list:
    """Segments of constant drive amplitude and frequency (an AFC sweep's operating points).

    The drive is cut into blocks of ``block_s``; a sine is fitted to each.
    Blocks the sine fits to within 0.1 % of its amplitude (or 3 times the
    median misfit, the drive's own noise) are steady; runs of
    steady blocks that agree within ``rel_tol`` (amplitude) and
    ``freq_tol_hz`` form one point, and a step between two points is placed
    at the sample where the sine of the point after it starts to fit better
    than the sine of the point before it. Returns ``[{"t_s": [t0, t1],
    "v_m": V, "frequency_hz": f}]`` in time order.
    """
    x = np.asarray(drive, dtype=np.float64)
    nb = max(16, int(round(block_s * drive_fs_hz)))
    blocks = []
    for i0 in range(0, x.size - nb + 1, nb):
        amp, f, ph, err = _sine_fit(x[i0:i0 + nb], drive_fs_hz)
        blocks.append((i0, amp, f, err / max(amp, 1e-30)))
    # a block is steady when the sine fits it about as well as it fits most blocks (the drive's own
    # noise), and to 0.1 %: a block holding a step fits much worse
    level = max(1e-3, 3.0 * float(np.median([b[3] for b in blocks]))) if blocks else 1e-3
    blocks = [(i0, amp, f, rel <= level) for i0, amp, f, rel in blocks]
    segs = []  # [first block start, last block end, amplitude, frequency]
    for i0, amp, f, steady in blocks:
        if not steady:
            continue
        if segs and segs[-1][1] == i0 and abs(amp - segs[-1][2]) <= rel_tol * max(segs[-1][2], 1e-30) and \
                abs(f - segs[-1][3]) <= freq_tol_hz:
            segs[-1][1] = i0 + nb
            continue
        if segs and abs(amp - segs[-1][2]) <= rel_tol * max(segs[-1][2], 1e-30) and \
                abs(f - segs[-1][3]) <= freq_tol_hz:
            segs[-1][1] = i0 + nb  # the same point on both sides of an unsteady block
            continue
        segs.append([i0, i0 + nb, amp, f])
    if not segs:
        return []
    # refine each point's sine on its whole steady span, then place the steps between points
    fits = []
    for s0, s1, amp, f in segs:
        a, fr, ph, _ = _sine_fit(x[s0:s1], drive_fs_hz, f)
        fits.append((s0, s1, a, fr, ph))
    bounds = [0]
    for (a0, a1, amp_a, f_a, ph_a), (b0, b1, amp_b, f_b, ph_b) in zip(fits[:-1], fits[1:]):
        k = np.arange(a1, b0)
        if k.size == 0:
            bounds.append(b0)
            continue
        ya = amp_a * np.cos(2.0 * math.pi * f_a * (k - a0) / drive_fs_hz + ph_a)
        yb = amp_b * np.cos(2.0 * math.pi * f_b * (k - b0) / drive_fs_hz + ph_b)
        ea = np.concatenate(([0.0], np.cumsum((x[k] - ya) ** 2)))
        eb = np.concatenate((np.cumsum(((x[k] - yb) ** 2)[::-1])[::-1], [0.0]))
        bounds.append(int(a1 + np.argmin(ea + eb)))
    bounds.append(x.size)
    return [{"t_s": [bounds[i] / drive_fs_hz, bounds[i + 1] / drive_fs_hz], "v_m": fits[i][2],
             "frequency_hz": fits[i][3]} for i in range(len(fits))]


def _quantile_span(x: np.ndarray, w: np.ndarray, lo: float = 0.05, hi: float = 0.95):
    w = np.clip(w, 0.0, None)
    if w.sum() <= 0:
        return None
    c = np.cumsum(w) / w.sum()
    return [float(x[int(np.searchsorted(c, lo))]), float(x[min(int(np.searchsorted(c, hi)), x.size - 1)])]


def localise(residual: np.ndarray, floor_rad: float, fs_hz: float, window_s: float | None = None) -> dict:
    """Where a residual exceeds its floor: spectrum band, peaks, time window, envelope.

    Parameters
    ----------
    residual : ndarray
        Measured minus model (rad); NaN samples (left out) are skipped.
    floor_rad : float
        The white noise floor (rad RMS).

    Returns
    -------
    dict
        ``band_hz`` [lo, hi] holding 90 % of the excess power (or None),
        ``peaks_hz`` (up to 3 strongest excess peaks), ``time_s`` [t0, t1]
        holding 90 % of the excess energy (or None), ``envelope`` (``t``,
        ``rms``), ``spectrum`` (``f``, ``psd``, ``floor_psd``).
    """
    r = np.asarray(residual, dtype=np.float64)
    t = np.arange(r.size) / fs_hz
    ok = np.isfinite(r)
    i0 = int(np.argmax(ok))
    rr = r[i0:][np.isfinite(r[i0:])] if ok.any() else np.zeros(8)
    nper = int(min(rr.size, max(64, min(4096, int(0.5 * fs_hz)))))
    f, p = signal.welch(rr, fs=fs_hz, nperseg=nper, detrend="constant")
    floor_psd = floor_rad ** 2 / (fs_hz / 2.0)
    excess = np.clip(p - floor_psd, 0.0, None) * (p > 2.0 * floor_psd)
    band = _quantile_span(f, excess)
    peaks = []
    if excess.any():
        idx, _ = signal.find_peaks(excess)
        if excess[0] > 0 and (excess.size < 2 or excess[0] >= excess[1]):
            idx = np.concatenate(([0], idx))
        idx = idx[np.argsort(excess[idx])[::-1]][:3]
        peaks = [float(f[i]) for i in idx]
    if window_s is None:
        window_s = min(0.05, max(r.size / fs_hz / 40.0, 8.0 / fs_hz))
    nw = max(4, int(round(window_s * fs_hz)))
    env_t, env = [], []
    for j in range(0, r.size - nw + 1, nw):
        seg = r[j:j + nw]
        seg = seg[np.isfinite(seg)]
        if seg.size:
            env_t.append((j + 0.5 * nw) / fs_hz)
            env.append(float(np.sqrt(np.mean(seg * seg))))
    env_t = np.array(env_t)
    env = np.array(env)
    ex_t = np.clip(env ** 2 - floor_rad ** 2, 0.0, None) * (env > 1.2 * floor_rad)
    span = _quantile_span(env_t, ex_t)
    if span is not None:
        span = [max(0.0, span[0] - 0.5 * window_s), min(t[-1], span[1] + 0.5 * window_s)]
    return {"band_hz": band, "peaks_hz": peaks, "time_s": span, "envelope": {"t": env_t, "rms": env},
            "spectrum": {"f": f, "psd": p, "floor_psd": floor_psd}}


# --- the diagnosis --------------------------------------------------------------------------------------
@dataclass
class Diagnosis:
    """Everything a diagnosis found; :meth:`to_json` gives the issue's JSON keys."""

    recording: Recording
    floors: dict
    baseline: dict
    gap: dict
    candidates: list
    verdict: dict
    localisation: dict = field(default_factory=dict)
    timing: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        a = ARCSEC
        floor_all = math.sqrt(np.mean([fl["floor_rad"] ** 2 for fl in self.floors.values()]))
        base = self.baseline
        out = {
            "noise_floor_arcsec": floor_all / a,
            "noise_floor_axes_arcsec": {ax: fl["floor_rad"] / a for ax, fl in self.floors.items()},
            "baseline": {
                "residual_rms_arcsec": base["rms_rad"] / a,
                "residual_rms_axes_arcsec": {ax: f.rms / a for ax, f in base["fits"].items()},
                "params": {ax: _susp_dict(f.suspension) for ax, f in base["fits"].items()},
                "uncertainty": {ax: {k: f.sigma[k] for k in NOMINAL_KEYS} for ax, f in base["fits"].items()},
            },
            "gap": _json_clean(self.gap),
            "candidates": [{"effect": c["effect"], "residual_rms_arcsec": c["rms_rad"] / a,
                            "gap_reduction": c["gap_reduction"], "score": c["score"],
                            "closes_gap": c["closes_gap"], "remaining_excess_arcsec": c["remaining_excess_arcsec"],
                            "params": c["params"], "uncertainty": c["uncertainty"],
                            "nominal": {ax: _susp_dict(f.suspension) for ax, f in c["fits"].items()}}
                           for c in self.candidates],
            "verdict": dict(self.verdict),
            "skipped_effects": dict(self.skipped),
            "timing_s": dict(self.timing),
        }
        return _json_clean(out)


def _susp_dict(s: SuspensionParams) -> dict:
    return {k: float(getattr(s, k)) for k in NOMINAL_KEYS}


def _json_clean(x):
    if isinstance(x, dict):
        return {k: _json_clean(val) for k, val in x.items() if not k.startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_json_clean(val) for val in x]
    if isinstance(x, np.ndarray):
        return _json_clean(x.tolist())
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def _sine_extension(x: np.ndarray, fs_hz: float, n_pre: int, block_s: float = 0.05) -> np.ndarray:
    """``n_pre`` samples before ``x[0]``: the sinusoid plus constant fitted to the first ``block_s`` of ``x``.

    Used when a recording starts mid-operation: the drive (and a coupled
    axis' deflection) before ``t = 0`` is taken to have continued as it
    started.
    """
    x = np.asarray(x, dtype=np.float64)
    nb = int(min(x.size, max(16, round(block_s * fs_hz))))
    seg = x[:nb]
    t = np.arange(nb) / fs_hz
    spec = np.abs(np.fft.rfft((seg - seg.mean()) * np.hanning(nb), 16 * nb))
    f = float(np.fft.rfftfreq(16 * nb, 1.0 / fs_hz)[int(np.argmax(spec))])

    def design(freq, tt):
        w = 2.0 * math.pi * freq
        return np.column_stack([np.cos(w * tt), np.sin(w * tt), np.ones_like(tt)])

    if f > 0.0:
        sol = optimize.least_squares(
            lambda p: design(p[0], t) @ np.linalg.lstsq(design(p[0], t), seg, rcond=None)[0] - seg, [f],
            method="lm", max_nfev=60)
        f = float(sol.x[0])
    coef = np.linalg.lstsq(design(f, t), seg, rcond=None)[0]
    t_pre = np.arange(-n_pre, 0) / fs_hz
    return design(f, t_pre) @ coef


class _ShiftedMotion:
    """A recording's table motion delayed by ``t_shift`` (a model pre-roll), continued linearly before it."""

    def __init__(self, base, t_shift: float):
        self.base = base
        self.t_shift = float(t_shift)
        a0, r0 = base.angle_rate(np.zeros(1))
        self.a0, self.r0 = float(a0[0]), float(r0[0])

    def angle_rate(self, t):
        tt = np.asarray(t, dtype=np.float64) - self.t_shift
        a, r = self.base.angle_rate(np.maximum(tt, 0.0))
        before = tt < 0.0
        return np.where(before, self.a0 + self.r0 * tt, a), np.where(before, self.r0, r)


def _model_inputs(rec: Recording, n_pre: int) -> ExperimentInputs:
    """The experiment to simulate: the recording's, preceded by ``n_pre`` samples of extrapolated drive."""
    inputs = ExperimentInputs.from_recording(rec)
    if n_pre == 0:
        return inputs
    r = rec.drive_ratio
    drive = np.asarray(rec.drive_v, dtype=np.float64)
    ext = np.column_stack([_sine_extension(drive[:, i], rec.drive_fs_hz, n_pre * r) for i in range(rec.n_axes)])
    table = None
    if rec.sins_angle is not None:
        table = {a: _ShiftedMotion(inputs.table[a], n_pre / rec.fs_hz) for a in rec.axes}
    return ExperimentInputs(rec.axes, rec.fs_hz, rec.n_samples + n_pre, rec.drive_fs_hz,
                            np.concatenate([ext, drive]), table)


def _truncate(rec: Recording, n: int) -> Recording:
    """The first ``n`` samples of a recording (drive and table angle cut to match)."""
    sins = None
    if rec.sins_angle is not None:
        k = min(rec.sins_angle.shape[0], int(math.ceil((n - 1) * rec.sins_fs_hz / rec.fs_hz)) + 9)
        sins = rec.sins_angle[:k]
    return Recording(rec.meta, rec.counts[:n], rec.drive_v[:n * rec.drive_ratio], sins, {}, rec.source)


def _table_angles(rec: Recording) -> dict:
    """The table angle at the readout instants, per axis (0 without ``sins_angle``)."""
    if rec.sins_angle is None:
        return {a: np.zeros(rec.n_samples) for a in rec.axes}
    inputs = ExperimentInputs.from_recording(rec)
    return {a: inputs.table[a].angle_rate(rec.time())[0] for a in rec.axes}


def _tau(nominal: dict) -> float:
    """Longest amplitude time constant ``2 Q / omega`` of the axes at 3 arcmin (s)."""
    return max(2.0 * s.q_factor(3.0 * ARCMIN) / s.omega0 for s in nominal.values())


def _masks(rec: Recording, settings: DiagnoseSettings, nominal: dict):
    n = rec.n_samples
    fs = rec.fs_hz
    used = np.ones(n, dtype=bool)
    if rec.initial_state == "unknown":
        # the model starts from a pre-roll (see diagnose_recording); its first instants still carry
        # what the extrapolated drive could not know
        used[: int(round(min(0.5 * _tau(nominal), 0.2 * rec.duration_s) * fs))] = False
    block = settings.block_s or min(0.5, max(0.025, rec.duration_s / 20.0))
    nb = max(2, int(round(block * fs)))
    train = used & ((np.arange(n) // nb) % 2 == 0)
    return used, train


def _coupling_sources(rec: Recording, inputs: ExperimentInputs, settings: ExperimentSettings, n_pre: int) -> dict:
    """Measured deflections of every axis on the plant grid of ``inputs``: ``(delta, rate)``.

    For ``axis_coupling``: the readout minus the table angle, by cubic
    spline; before the recording (a model pre-roll of ``n_pre`` samples)
    continued as the sinusoid it starts with.
    """
    g = inputs.grid(settings)
    t = np.arange(g.n_steps + 1) * g.h
    out = {}
    tt = np.arange(rec.n_samples + n_pre) / rec.fs_hz
    for a in rec.axes:
        y = rec.angle(a) + 0.5 * rec.quantum_rad
        if rec.sins_angle is not None:
            y = y - inputs.table[a].angle_rate(tt[n_pre:])[0]
        if n_pre:
            y = np.concatenate([_sine_extension(y, rec.fs_hz, n_pre), y])
        spl = CubicSpline(tt, y)
        out[a] = (spl(t), spl(t, 1))
    return out


def _effect_starts(cls, axis: str, loc: dict, fs_hz: float) -> list:
    name = cls.name
    if name == "piezo_lag":
        return [{"tau_s": x} for x in (3e-5, 1e-4, 3e-4, 1e-3)]
    if name == "viscous_damping":
        return [{"zeta": x} for x in (1e-4, 5e-4, 2e-3)]
    if name == "resonance_drift":
        return [{"rate_hz_per_s": x} for x in (-0.3, 0.0, 0.3)]
    if name == "readout_delay":
        return [{"delay_s": x} for x in (3e-6, 2e-5, 1e-4, 4e-4)]
    if name == "scale_factor":
        return [{"error": 0.0}]
    if name == "block_mode":
        freqs = [f for f in loc.get("peaks_hz", []) if f > 5.0]
        freqs += [60.0, 120.0, 250.0, 500.0, 1000.0, 2000.0]
        freqs = [f for f in freqs if f < 0.45 * fs_hz * 4]
        return [{"frequency_hz": f, "zeta": 0.08, "gain": g} for f in freqs for g in (-0.3, 0.3)]
    if name == "lock_in":
        return [{"threshold_rad_s": w, "phase_rad": p} for w in (1e-3, 4e-3) for p in (0.0, 1.6, 3.1, 4.7)]
    if name == "axis_coupling":
        return None
    return None


def diagnose_recording(rec: Recording, settings: DiagnoseSettings = DiagnoseSettings(), progress=None) -> Diagnosis:
    """Refit, noise floor, localisation, candidate effects and verdict for a recording."""
    import time

    t_start = time.perf_counter()
    timing = {}
    nominal = {a: suspension_from_nominal(rec.nominal[a]) for a in rec.axes}
    # a recording that starts mid-operation is simulated from rest 6 time constants earlier, the drive
    # before t = 0 continued as it starts, so that the model is in its steady state when the data begin
    n_pre = int(round(6.0 * _tau(nominal) * rec.fs_hz)) if rec.initial_state == "unknown" else 0
    offset = rec.initial_state == "unknown"
    q = rec.quantum_rad
    fs = rec.fs_hz
    sig0 = q / math.sqrt(12.0)
    table = _table_angles(rec)
    a_ref = {}
    for a in rec.axes:
        d = rec.angle(a) - table[a]
        half = d[rec.n_samples // 2:]
        a_ref[a] = max(math.sqrt(2.0) * float(np.std(half - np.mean(half))), 10.0 * q)

    def context(r: Recording):
        inputs = _model_inputs(r, n_pre)
        used, train = _masks(r, settings, nominal)
        coupled = _coupling_sources(r, inputs, settings.experiment, n_pre) if r.n_axes > 1 else None
        return inputs, used, train, {a: r.angle(a) + 0.5 * q for a in r.axes}, coupled

    full = context(rec)
    used = full[1]
    n_win = int(round(settings.window_s * fs)) + 1 if settings.window_s is not None else rec.n_samples
    win = context(_truncate(rec, n_win)) if rec.n_samples > 1.5 * n_win else None

    def problem(a, ctx, sett=settings):
        inputs, u, tr, ys, coupled = ctx
        return _Problem(inputs, a, ys[a], nominal[a], sett, u, tr, offset, sig0, coupled, a_ref[a], n_pre)

    def fit(a, cls=None, start=None, starts=None, sett=settings):
        """A fit on the whole recording, through its first window when it is long."""
        if win is None:
            return fit_axis(problem(a, full, sett), cls, start, starts)
        fw = fit_axis(problem(a, win, sett), cls, start, starts)
        ff = fit_axis(problem(a, full, sett), cls, start=fw, polish=True)
        ff.nfev += fw.nfev
        return ff

    def per_axis(axes, job):
        """``job(axis, settings)`` for every axis, in parallel threads when there are several."""
        if len(axes) > 1 and settings.threads > 1:
            inner = replace(settings, threads=max(1, settings.threads // len(axes)))
            with ThreadPoolExecutor(max_workers=min(settings.threads, len(axes))) as ex:
                return dict(zip(axes, ex.map(lambda a: job(a, inner), axes)))
        return {a: job(a, settings) for a in axes}

    # 1. baseline refit, per axis (independent in the nominal model)
    fits = per_axis(list(rec.axes), lambda a, sett: fit(a, sett=sett))
    if progress:
        progress("baseline")
    timing["baseline"] = time.perf_counter() - t_start
    # 2. noise floor and significance per axis
    floors = {a: noise_floor(fits[a].residual[used], q, fs) for a in rec.axes}
    tol = {a: max(settings.rel_tol * floors[a]["floor_rad"], settings.abs_tol_arcsec * ARCSEC) for a in rec.axes}
    excess = {a: max(0.0, fits[a].rms ** 2 - floors[a]["floor_rad"] ** 2) for a in rec.axes}
    sig_axes = [a for a in rec.axes if math.sqrt(excess[a]) > tol[a]]
    worst = max(rec.axes, key=lambda a: excess[a] / tol[a] ** 2)
    # 3. localisation on every axis; the gap on the worst one
    locs = {a: localise(fits[a].residual, floors[a]["floor_rad"], fs) for a in rec.axes}
    points = []
    if rec.experiment == "afc_sweep" or "afc" in rec.experiment:
        i = rec.axis_index(worst)
        ops = operating_points(rec.drive_v[:, i], rec.drive_fs_hz)
        r = fits[worst].residual
        for p in ops:
            i0, i1 = int(p["t_s"][0] * fs), int(p["t_s"][1] * fs)
            rms = _rms(r[i0:i1])
            ex = math.sqrt(max(0.0, rms ** 2 - floors[worst]["floor_rad"] ** 2)) if math.isfinite(rms) else math.nan
            points.append({**p, "residual_rms_arcsec": rms / ARCSEC, "excess_rms_arcsec": ex / ARCSEC})
    significant = bool(sig_axes)
    lw = locs[worst]
    gap = {"significant": significant, "axis": worst if significant else None,
           "band_hz": lw["band_hz"] if significant else None, "time_s": lw["time_s"] if significant else None,
           "peaks_hz": lw["peaks_hz"] if significant else [],
           "excess_rms_arcsec": {a: math.sqrt(excess[a]) / ARCSEC for a in rec.axes},
           "tolerance_arcsec": {a: tol[a] / ARCSEC for a in rec.axes},
           "significant_axes": sig_axes,
           "operating_points": sorted(points, key=lambda p: -(p["excess_rms_arcsec"] or 0.0))}
    base_rms = math.sqrt(np.mean([fits[a].rms ** 2 for a in rec.axes]))
    baseline = {"fits": fits, "rms_rad": base_rms}
    timing["localise"] = time.perf_counter() - t_start
    # 4. candidates on the significant axes
    candidates = []
    skipped = {}
    moving = rec.sins_angle is not None and float(np.ptp(rec.sins_angle)) > 0.0
    names = tuple(EFFECTS) if settings.effects is None else settings.effects
    base_ex = sum(excess[a] for a in sig_axes)
    if significant:
        for name in names:
            cls = EFFECTS[name]
            if cls.needs_motion and not moving:
                skipped[name] = "the block does not move in this recording: the effect cannot show"
                continue
            if rec.n_axes < cls.min_axes:
                skipped[name] = f"needs at least {cls.min_axes} axes"
                continue
            t0 = time.perf_counter()
            cfits = dict(fits)
            cfits.update(per_axis(sig_axes, lambda a, sett: fit(a, cls, fits[a], _effect_starts(cls, a, locs[a], fs),
                                                                 sett)))
            cand_axes = {a: max(0.0, cfits[a].rms ** 2 - floors[a]["floor_rad"] ** 2) for a in sig_axes}
            cand_ex = sum(cand_axes.values())
            red = 1.0 - cand_ex / base_ex if base_ex > 0 else 0.0
            held = math.sqrt(np.mean([cfits[a].heldout_rms ** 2 for a in sig_axes]))
            # the gap is closed when what is left on every axis is within the tolerance, or a small
            # fraction of the excess it started from (a large effect leaves model error of its own size)
            closes = all(math.sqrt(cand_axes[a]) <= max(tol[a], settings.close_fraction * math.sqrt(excess[a]))
                         for a in sig_axes)
            candidates.append({
                "effect": name, "fits": cfits,
                "rms_rad": math.sqrt(np.mean([cfits[a].rms ** 2 for a in rec.axes])),
                "gap_reduction": float(red), "score": held / ARCSEC, "closes_gap": bool(closes),
                "remaining_excess_arcsec": {a: math.sqrt(cand_axes[a]) / ARCSEC for a in sig_axes},
                "params": {a: cfits[a].effect.values(a) for a in sig_axes},
                "uncertainty": {a: {k: val for k, val in cfits[a].sigma.items()
                                    if k not in NOMINAL_KEYS and not k.startswith("start_")} for a in sig_axes},
                "nfev": sum(cfits[a].nfev for a in sig_axes),
            })
            timing[name] = time.perf_counter() - t0
            if progress:
                progress(f"candidate {name}")
        candidates.sort(key=lambda c: c["score"])
    base_held = math.sqrt(np.mean([fits[a].heldout_rms ** 2 for a in sig_axes])) if sig_axes else math.nan
    if not significant:
        verdict = {"effect": "none", "gap_reduction": 0.0, "alternatives": []}
    else:
        best = candidates[0] if candidates else None
        if best is not None and best["closes_gap"] and best["gap_reduction"] >= settings.min_gap_reduction and \
                best["score"] < base_held / ARCSEC:
            # effects the data cannot tell from the best one: they close the gap as well and score
            # within ALTERNATIVE_MARGIN of it
            alts = [c["effect"] for c in candidates[1:] if c["closes_gap"]
                    and c["score"] <= best["score"] * (1.0 + ALTERNATIVE_MARGIN)]
            verdict = {"effect": best["effect"], "gap_reduction": best["gap_reduction"], "alternatives": alts}
        else:
            verdict = {"effect": "unknown", "gap_reduction": best["gap_reduction"] if best else 0.0,
                       "alternatives": []}
    verdict["baseline_score"] = base_held / ARCSEC if significant else None
    timing["total"] = time.perf_counter() - t_start
    return Diagnosis(recording=rec, floors=floors, baseline=baseline, gap=gap, candidates=candidates,
                     verdict=verdict, localisation=locs, timing=timing, skipped=skipped)


# --- report ----------------------------------------------------------------------------------------------
def write_report(diag: Diagnosis, report_dir, json_path=None) -> dict:
    """Write ``report.md`` with ``spectrum.png``, ``envelope.png``, ``ranking.png`` (and the JSON if asked).

    Returns the JSON dictionary.
    """
    out = Path(report_dir)
    out.mkdir(parents=True, exist_ok=True)
    js = diag.to_json()
    if json_path is not None:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps(js, indent=2) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = diag.recording
    fs = rec.fs_hz
    axis = diag.gap["axis"] or max(rec.axes, key=lambda a: diag.baseline["fits"][a].rms)
    best = diag.candidates[0] if diag.candidates else None
    floor = diag.floors[axis]["floor_rad"]
    # spectrum before / after the best effect
    fig, ax = plt.subplots(figsize=(8, 4.5))
    loc = diag.localisation[axis]
    ax.semilogy(loc["spectrum"]["f"], np.sqrt(loc["spectrum"]["psd"]) / ARCSEC, label="baseline refit")
    if best is not None:
        lb = localise(best["fits"][axis].residual, floor, fs)
        ax.semilogy(lb["spectrum"]["f"], np.sqrt(lb["spectrum"]["psd"]) / ARCSEC, label=f"with {best['effect']}")
    ax.axhline(math.sqrt(loc["spectrum"]["floor_psd"]) / ARCSEC, color="k", ls="--", label="noise floor")
    if diag.gap["band_hz"]:
        ax.axvspan(*diag.gap["band_hz"], color="orange", alpha=0.2, label="band with the excess")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("residual ASD (arcsec/sqrt(Hz))")
    ax.set_title(f"axis {axis}: residual spectrum")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "spectrum.png", dpi=110)
    plt.close(fig)
    # envelope over time, every axis
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for a in rec.axes:
        env = diag.localisation[a]["envelope"]
        ax.plot(env["t"], env["rms"] / ARCSEC, label=f"{a} baseline")
        if best is not None and a in best["fits"] and best["fits"][a] is not diag.baseline["fits"][a]:
            eb = localise(best["fits"][a].residual, diag.floors[a]["floor_rad"], fs)["envelope"]
            ax.plot(eb["t"], eb["rms"] / ARCSEC, ls=":", label=f"{a} with {best['effect']}")
    ax.axhline(floor / ARCSEC, color="k", ls="--", label="noise floor")
    if diag.gap["time_s"]:
        ax.axvspan(*diag.gap["time_s"], color="orange", alpha=0.15, label="window with the excess")
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("residual RMS (arcsec)")
    ax.set_title("residual envelope")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "envelope.png", dpi=110)
    plt.close(fig)
    # ranking
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 4))
    names = [c["effect"] for c in diag.candidates]
    if names:
        a1.barh(names[::-1], [c["gap_reduction"] for c in diag.candidates][::-1])
        a1.axvline(0.6, color="k", ls="--")
        a2.barh(names[::-1], [c["score"] for c in diag.candidates][::-1])
        if diag.verdict.get("baseline_score"):
            a2.axvline(diag.verdict["baseline_score"], color="k", ls="--", label="baseline")
            a2.legend()
    a1.set_xlabel("gap reduction")
    a2.set_xlabel("held-out residual RMS (arcsec)")
    a1.set_title("candidates")
    fig.tight_layout()
    fig.savefig(out / "ranking.png", dpi=110)
    plt.close(fig)
    lines = [f"# Sim-to-real diagnosis: {rec.source}", "",
             f"- experiment `{rec.experiment}`, axes {', '.join(rec.axes)}, {rec.n_samples} samples at "
             f"{fs:g} Hz ({rec.duration_s:.3g} s), initial state `{rec.initial_state}`",
             f"- noise floor {js['noise_floor_arcsec']:.4g} arcsec RMS "
             f"(quantisation {rec.quantum_rad / ARCSEC / math.sqrt(12):.4g})",
             f"- verdict: **{js['verdict']['effect']}** (gap reduction {js['verdict']['gap_reduction']:.3f}"
             + (f"; the data cannot tell it from {', '.join(js['verdict']['alternatives'])}"
                if js["verdict"].get("alternatives") else "") + ")", "",
             "## Baseline refit", "",
             "| axis | residual RMS (arcsec) | excess (arcsec) | f0 (Hz) | k1 | k2 | k3 | k4 | k5 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for a in rec.axes:
        p = js["baseline"]["params"][a]
        lines.append(f"| {a} | {js['baseline']['residual_rms_axes_arcsec'][a]:.4g} | "
                     f"{js['gap']['excess_rms_arcsec'][a]:.4g} | {p['f0_hz']:.5f} | {p['k1']:.4g} | {p['k2']:.4g} | "
                     f"{p['k3']:.4g} | {p['k4']:.4g} | {p['k5']:.4g} |")
    g = js["gap"]
    lines += ["", "## Gap", "", f"- significant: {g['significant']}, axis {g['axis']}, band {g['band_hz']} Hz, "
              f"peaks {g['peaks_hz']} Hz, time window {g['time_s']} s"]
    if g["operating_points"]:
        lines += ["", "| operating point t (s) | V_m (V) | f (Hz) | excess RMS (arcsec) |", "|---|---|---|---|"]
        for p in g["operating_points"][:10]:
            lines.append(f"| {p['t_s'][0]:.3f}-{p['t_s'][1]:.3f} | {p['v_m']:.4g} | {p['frequency_hz']:.3f} | "
                         f"{p['excess_rms_arcsec']:.4g} |")
    lines += ["", "## Candidates (best first)", "", "| effect | residual RMS (arcsec) | gap reduction | "
              "score (held-out RMS, arcsec) | parameters |", "|---|---|---|---|---|"]
    for c in js["candidates"]:
        lines.append(f"| {c['effect']} | {c['residual_rms_arcsec']:.4g} | {c['gap_reduction']:.3f} | "
                     f"{c['score']:.4g} | {json.dumps(c['params'])} |")
    for name, why in js["skipped_effects"].items():
        lines.append(f"| {name} | - | - | - | skipped: {why} |")
    lines += ["", "![spectrum](spectrum.png)", "", "![envelope](envelope.png)", "", "![ranking](ranking.png)", ""]
    (out / "report.md").write_text("\n".join(lines))
    return js
