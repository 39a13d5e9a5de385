"""Sim-to-real gap: refit, noise floor, localisation, candidate effects, verdict, report.

Given a recording (``sins_sim.io.recording``), :func:`diagnose_recording`

1. **refits** the nominal parameters ``f0, k1..k5`` of every axis by
   simulating the same experiment (same drive, block motion and readout
   instants, ``sins_sim.simulation.experiment``) and minimising the
   residual with ``scipy.optimize.least_squares`` (parameters scaled by
   their nominal values, a weak prior towards the nominal values for the
   directions the data cannot resolve, uncertainty from the Jacobian with
   the residual's correlation length taken into account). The axes are
   independent in the nominal model, so each axis is fitted alone;
2. estimates the **noise floor** from the data: the quantisation
   ``q / sqrt(12)``, or more if the residual's high-frequency band (where
   the model has no content) says so (white readout noise);
3. **localises** the gap: per axis the excess of the residual's RMS over the
   floor; on the worst axis the band holding the excess power (Welch
   spectrum), the time window holding it (residual envelope), and for AFC
   sweeps the operating points (segments of constant drive voltage and
   frequency, found from ``drive_v``) ranked by their excess;
4. **explains**: every effect of the catalogue (``sins_sim.models.effects``)
   that the experiment can show is fitted together with the nominal
   parameters on each axis with a significant gap; it is scored on held-out
   data (the recording is cut in blocks; even blocks fit, odd blocks
   score), so an extra parameter that only fits noise gains nothing;
   ``gap_reduction`` is the fraction of the excess residual power over the
   floor it removes;
5. gives a **verdict**: ``none`` when the refit nominal model sits at the
   floor (its excess RMS below ``max(rel_tol * floor, abs_tol)``, a
   tolerance that covers integration-method, interpolation and noise
   differences between simulators), the best-scoring effect when it
   removes at least ``min_gap_reduction`` of the excess power, else
   ``unknown`` (the localisation is then the answer).

Conventions: the measured angle is ``counts * q + q / 2`` (the floor of the
counter makes ``counts * q`` half a quantum low on average). With
``initial_state = "unknown"`` a constant offset is profiled out and the
first ``settle`` seconds (6 amplitude time constants ``2 Q / omega``, at
most 40 % of the recording) are left out of every residual, the model
starting from rest at ``t = 0`` with the recorded drive.

Functions
---------
.. autosummary::

   DiagnoseSettings
   noise_floor
   fit_axis
   localise
   diagnose_recording
   write_report
"""

from __future__ import annotations

import json
import math
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import optimize, signal
from scipy.interpolate import CubicSpline

from sins_sim import _validate as v
from sins_sim.identification.afc import hb_stiffness_ratio
from sins_sim.io.recording import NOMINAL_KEYS, Recording
from sins_sim.models.effects import EFFECTS, AxisCoupling, Effect, rate_from_grid
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import (FIT_SETTINGS, ExperimentInputs, ExperimentSettings, simulate_axis,
                                            suspension_from_nominal)
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["DiagnoseSettings", "AxisFit", "Diagnosis", "noise_floor", "fit_axis", "localise", "operating_points",
           "diagnose_recording", "write_report"]

#: Relative bounds of the nominal parameters in the fit (multiples of the nominal value).
_BOUNDS = {"f0_hz": (0.97, 1.03), "k1": (0.0, 10.0), "k2": (0.05, 20.0), "k3": (0.05, 20.0), "k4": (-2.0, 20.0),
           "k5": (0.1, 10.0)}
#: Relative finite-difference steps of the Jacobian (f0 is known to 1e-6 and acts strongly).
import os
_XSCALE = os.environ.get("XS", "jac")
_XSCALE = float(_XSCALE) if _XSCALE != "jac" else _XSCALE
#: Typical sizes of (F, k1, k2, 1/Q, k4, k5), used as scale where a nominal value is 0.
_TYPICAL = np.array([386.0, 1.75e-4, 1.05e-3, 5e-3, 250.0, 1.2e-5])
#: Bounds (in those typical units) of a parameter whose nominal value is 0.
_ZERO_BOUNDS = {"f0_hz": (0.5, 2.0), "k1": (0.0, 10.0), "k2": (0.05, 20.0), "k3": (0.0, 20.0), "k4": (-2.0, 20.0),
                "k5": (-10.0, 10.0)}
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
    max_nfev : int
        Evaluation budget of each least-squares fit (Jacobian columns not counted).
    rel_tol, abs_tol_arcsec : float
        The gap is significant when the excess RMS over the floor exceeds
        ``max(rel_tol * floor, abs_tol)``.
    min_gap_reduction : float
        Fraction of the excess power an effect must remove to be the verdict.
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
    rel_tol: float = 0.5
    abs_tol_arcsec: float = 0.02
    min_gap_reduction: float = 0.6
    block_s: float | None = None
    effects: tuple | None = None
    threads: int = 2

    def __post_init__(self):
        v.positive("diagnose", "prior_f0", self.prior_f0)
        v.positive("diagnose", "prior_k", self.prior_k)
        if int(self.max_nfev) != self.max_nfev or self.max_nfev < 2:
            raise ValueError(f"diagnose.max_nfev: must be an integer >= 2, got {self.max_nfev!r}")
        v.non_negative("diagnose", "rel_tol", self.rel_tol)
        v.non_negative("diagnose", "abs_tol_arcsec", self.abs_tol_arcsec)
        g = v.finite("diagnose", "min_gap_reduction", self.min_gap_reduction)
        if not 0.0 < g <= 1.0:
            raise ValueError(f"diagnose.min_gap_reduction: must be in (0, 1], got {g!r}")
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
                 coupled: dict | None, a_ref: float):
        self.inputs = inputs
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

    def model(self, sus: SuspensionParams, effect: Effect | None) -> np.ndarray:
        self.nfev += 1
        effects = () if effect is None else (effect,)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = simulate_axis(self.inputs, self.axis, sus, effects, self.settings.experiment, coupled=self.coupled)
        if self.offset:
            m = m + float(np.mean((self.y - m)[self.used]))
        return m


def _solve(prob: _Problem, effect_cls, x0_nom, x0_eff, space, max_nfev, threads, mask):
    """Least squares over (nominal relative, effect scaled) on ``mask``; returns (x, J, cost)."""
    n_nom = len(NOMINAL_KEYS)
    scales = np.array([p.scale for p in space])
    lo = np.concatenate([prob.lo, [p.lo / p.scale for p in space]])
    hi = np.concatenate([prob.hi, [p.hi / p.scale for p in space]])
    steps = np.array([_STEPS[k] for k in NOMINAL_KEYS] + [1e-3] * len(space))
    x0 = np.clip(np.concatenate([x0_nom, x0_eff]), lo + 1e-12, hi - 1e-12)
    prior_sd = np.array([prob.settings.prior_f0] + [prob.settings.prior_k] * (n_nom - 1))
    cache = {}

    def unpack(x):
        sus = prob.suspension(x[:n_nom])
        eff = None
        if effect_cls is not None:
            eff = effect_cls.build(prob.axis, prob.inputs.axes, {p.name: float(xi * s) for p, xi, s in
                                                                 zip(space, x[n_nom:], scales)})
        return sus, eff

    def fun(x):
        key = x.tobytes()
        if key in cache:
            return cache[key]
        try:
            sus, eff = unpack(x)
            m = prob.model(sus, eff)
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

    def jac(x):
        f0 = fun(x)
        hs = np.where(x + steps * np.maximum(1.0, np.abs(x)) <= hi, 1.0, -1.0) * steps * np.maximum(1.0, np.abs(x))

        def col(i):
            xp = x.copy()
            xp[i] += hs[i]
            return (fun(xp) - f0) / hs[i]

        if threads > 1:
            with ThreadPoolExecutor(max_workers=threads) as ex:
                cols = list(ex.map(col, range(x.size)))
        else:
            cols = [col(i) for i in range(x.size)]
        return np.column_stack(cols)

    sol = optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=_XSCALE,
                                 max_nfev=max_nfev, xtol=1e-8, ftol=1e-8, gtol=1e-8)
    return sol.x, sol.jac, unpack


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


def fit_axis(prob: _Problem, effect_cls=None, start: AxisFit | None = None, effect_starts=None,
             max_nfev: int | None = None) -> AxisFit:
    """Fit the nominal parameters (and an effect's) on one axis, on the training blocks.

    Parameters
    ----------
    prob : _Problem
    effect_cls : Effect subclass or None
    start : AxisFit, optional
        Start of the nominal parameters (default: the recording's nominal).
    effect_starts : list of dict, optional
        Candidate starts of the effect's parameters; the one with the lowest
        cost (at the start's nominal parameters) is refined.
    """
    n_nom = len(NOMINAL_KEYS)
    space = effect_cls.fit_space(prob.axis, prob.inputs.axes) if effect_cls is not None else []
    x0_nom = prob.x_c.copy() if start is None else prob.x_of(start.suspension)
    x0_eff = np.zeros(len(space))
    if effect_cls is not None:
        starts = effect_starts or [{p.name: (p.default if p.default is not None else 0.0) for p in space}]
        if len(starts) > 1:
            sus0 = prob.suspension(x0_nom)
            best = None

            def cost(st):
                try:
                    eff = effect_cls.build(prob.axis, prob.inputs.axes, st)
                    r = (prob.y - prob.model(sus0, eff))[prob.train]
                    return float(np.mean(r * r))
                except ValueError:
                    return math.inf

            with ThreadPoolExecutor(max_workers=prob.settings.threads) as ex:
                costs = list(ex.map(cost, starts))
            best = starts[int(np.argmin(costs))]
        else:
            best = starts[0]
        x0_eff = np.array([best.get(p.name, 0.0) / p.scale for p in space])
    x, jac, unpack = _solve(prob, effect_cls, x0_nom, x0_eff, space, max_nfev or prob.settings.max_nfev,
                            prob.settings.threads, prob.train)
    sus, eff = unpack(x)
    model = prob.model(sus, eff)
    res = prob.y - model
    res = np.where(prob.used, res, np.nan)
    # uncertainty: J^T J of the data part, residual variance inflated by its correlation length
    nd = int(prob.train.sum())
    jd = jac[:nd]
    r_train = res[prob.train]
    dof = max(1, nd - x.size)
    s2 = float(np.sum(r_train * r_train)) / dof / prob.sigma ** 2 * _correlation_length(r_train)
    jtj = jd.T @ jd + np.diag(np.concatenate([1.0 / np.array([prob.settings.prior_f0] + [prob.settings.prior_k] * (n_nom - 1)) ** 2, np.zeros(len(space))]))
    try:
        cov = np.linalg.pinv(jtj) * s2
    except np.linalg.LinAlgError:
        cov = np.full((x.size, x.size), math.nan)
    gmap = prob.p_jacobian(x[:n_nom])
    cov_p = gmap @ cov[:n_nom, :n_nom] @ gmap.T
    sigma = {k: float(math.sqrt(max(0.0, cov_p[i, i]))) for i, k in enumerate(NOMINAL_KEYS)}
    for j, p in enumerate(space):
        sigma[p.name] = float(math.sqrt(max(0.0, cov[n_nom + j, n_nom + j])) * p.scale)
    heldout = prob.used & ~prob.train
    return AxisFit(axis=prob.axis, suspension=sus, effect=eff, model=model, residual=res, sigma=sigma,
                   nfev=prob.nfev, train_rms=_rms(res[prob.train]), heldout_rms=_rms(res[heldout]) if heldout.any()
                   else math.nan, rms=_rms(res))


# --- localisation ------------------------------------------------------------------------------------
def operating_points(drive: np.ndarray, drive_fs_hz: float, block_s: float = 0.02, rel_tol: float = 0.01,
                     freq_tol_hz: float = 0.05) -> list:
    """Segments of constant drive amplitude and frequency (an AFC sweep's operating points).

    The drive is cut into blocks of ``block_s``; in each the dominant
    frequency (FFT peak refined by a 3-parameter sine fit) and amplitude are
    estimated; consecutive blocks that agree within ``rel_tol`` (amplitude)
    and ``freq_tol_hz`` form one point. Returns ``[{"t_s": [t0, t1],
    "v_m": V, "frequency_hz": f}]``.
    """
    x = np.asarray(drive, dtype=np.float64)
    nb = max(16, int(round(block_s * drive_fs_hz)))
    est = []
    for i0 in range(0, x.size - nb + 1, nb):
        seg = x[i0:i0 + nb]
        t = np.arange(nb) / drive_fs_hz
        spec = np.abs(np.fft.rfft(seg * np.hanning(nb), 8 * nb))
        f = np.fft.rfftfreq(8 * nb, 1.0 / drive_fs_hz)[int(np.argmax(spec[1:])) + 1]

        def res(p):
            return p[0] * np.cos(2 * np.pi * p[1] * t) + p[2] * np.sin(2 * np.pi * p[1] * t) - seg

        a0 = np.linalg.lstsq(np.column_stack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]), seg,
                             rcond=None)[0]
        sol = optimize.least_squares(res, [a0[0], f, a0[1]], method="lm", max_nfev=50)
        est.append((i0, float(np.hypot(sol.x[0], sol.x[2])), float(abs(sol.x[1]))))
    points = []
    for i0, amp, f in est:
        if points and abs(amp - points[-1]["_a"]) <= rel_tol * max(points[-1]["_a"], 1e-12) and \
                abs(f - points[-1]["_f"]) <= freq_tol_hz:
            points[-1]["t_s"][1] = (i0 + nb) / drive_fs_hz
            continue
        points.append({"t_s": [i0 / drive_fs_hz, (i0 + nb) / drive_fs_hz], "_a": amp, "_f": f})
    if points:
        points[-1]["t_s"][1] = x.size / drive_fs_hz
    return [{"t_s": p["t_s"], "v_m": p["_a"], "frequency_hz": p["_f"]} for p in points]


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
    locals: dict = field(default_factory=dict)
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


def _masks(rec: Recording, settings: DiagnoseSettings, nominal: dict):
    n = rec.n_samples
    fs = rec.fs_hz
    used = np.ones(n, dtype=bool)
    if rec.initial_state == "unknown":
        tau = max(2.0 * s.q_factor(3.0 * ARCMIN) / s.omega0 for s in nominal.values())
        settle = min(6.0 * tau, 0.4 * rec.duration_s)
        used[: int(round(settle * fs))] = False
    block = settings.block_s or min(0.5, max(0.025, rec.duration_s / 20.0))
    nb = max(2, int(round(block * fs)))
    train = used & ((np.arange(n) // nb) % 2 == 0)
    return used, train


def _coupling_sources(rec: Recording, inputs: ExperimentInputs, settings: ExperimentSettings) -> dict:
    """Measured deflections of every axis on the plant grid: ``(delta, rate)`` (for ``axis_coupling``)."""
    g = inputs.grid(settings)
    t = np.arange(g.n_steps + 1) * g.h
    out = {}
    for a in rec.axes:
        y = rec.angle(a) + 0.5 * rec.quantum_rad
        if rec.sins_angle is not None:
            y = y - inputs.table[a].angle_rate(rec.time())[0]
        spl = CubicSpline(rec.time(), y)
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
        return [{"frequency_hz": f, "zeta": z, "gain": g} for f in freqs for z in (0.03, 0.15) for g in (-0.3, 0.3)]
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
    inputs = ExperimentInputs.from_recording(rec)
    nominal = {a: suspension_from_nominal(rec.nominal[a]) for a in rec.axes}
    used, train = _masks(rec, settings, nominal)
    offset = rec.initial_state == "unknown"
    q = rec.quantum_rad
    fs = rec.fs_hz
    ys = {a: rec.angle(a) + 0.5 * q for a in rec.axes}
    sig0 = q / math.sqrt(12.0)
    coupled = _coupling_sources(rec, inputs, settings.experiment) if rec.n_axes > 1 else None

    a_ref = {}
    for i, a in enumerate(rec.axes):
        d = ys[a] - (inputs.table[a].angle_rate(rec.time())[0] if rec.sins_angle is not None else 0.0)
        half = d[rec.n_samples // 2:]
        a_ref[a] = max(math.sqrt(2.0) * float(np.std(half - np.mean(half))), 10.0 * q)

    def problem(a, sigma):
        return _Problem(inputs, a, ys[a], nominal[a], settings, used, train, offset, sigma, coupled, a_ref[a])

    # 1. baseline refit, per axis
    fits = {}
    for a in rec.axes:
        fits[a] = fit_axis(problem(a, sig0))
        if progress:
            progress(f"baseline {a}")
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
    names = settings.effects or tuple(EFFECTS)
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
            for a in sig_axes:
                prob = problem(a, sig0)
                cfits[a] = fit_axis(prob, cls, start=fits[a], effect_starts=_effect_starts(cls, a, locs[a], fs))
            cand_ex = sum(max(0.0, cfits[a].rms ** 2 - floors[a]["floor_rad"] ** 2) for a in sig_axes)
            red = 1.0 - cand_ex / base_ex if base_ex > 0 else 0.0
            held = math.sqrt(np.mean([cfits[a].heldout_rms ** 2 for a in sig_axes]))
            candidates.append({
                "effect": name, "fits": cfits,
                "rms_rad": math.sqrt(np.mean([cfits[a].rms ** 2 for a in rec.axes])),
                "gap_reduction": float(red), "score": held / ARCSEC,
                "params": {a: cfits[a].effect.values(a) for a in sig_axes},
                "uncertainty": {a: {k: val for k, val in cfits[a].sigma.items() if k not in NOMINAL_KEYS}
                                for a in sig_axes},
            })
            timing[name] = time.perf_counter() - t0
            if progress:
                progress(f"candidate {name}")
        candidates.sort(key=lambda c: c["score"])
    base_held = math.sqrt(np.mean([fits[a].heldout_rms ** 2 for a in sig_axes])) if sig_axes else math.nan
    if not significant:
        verdict = {"effect": "none", "gap_reduction": 0.0}
    else:
        best = candidates[0] if candidates else None
        if best is not None and best["gap_reduction"] >= settings.min_gap_reduction and \
                best["score"] < base_held / ARCSEC:
            verdict = {"effect": best["effect"], "gap_reduction": best["gap_reduction"]}
        else:
            verdict = {"effect": "unknown", "gap_reduction": best["gap_reduction"] if best else 0.0}
    verdict["baseline_score"] = base_held / ARCSEC if significant else None
    timing["total"] = time.perf_counter() - t_start
    return Diagnosis(recording=rec, floors=floors, baseline=baseline, gap=gap, candidates=candidates,
                     verdict=verdict, locals=locs, timing=timing, skipped=skipped)


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
    loc = diag.locals[axis]
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
        env = diag.locals[a]["envelope"]
        ax.plot(env["t"], env["rms"] / ARCSEC, label=f"{a} baseline")
        if best is not None and a in best["fits"] and best["fits"][a] is not diag.baseline["fits"][a]:
            eb = localise(best["fits"][a].residual, diag.floors[a]["floor_rad"], fs)["envelope"]
            ax.plot(eb["t"], eb["rms"] / ARCSEC, ls=":", label=f"{a} with {best['effect']}")
    ax.axhline(floor / ARCSEC, color="k", ls="--", label="noise floor")
    if diag.gap["time_s"]:
        ax.axvspan(*diag.gap["time_s"], color="orange", alpha=0.15, label="window with the excess")
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
             f"- noise floor {js['noise_floor_arcsec']:.4g} arcsec RMS (quantisation {rec.quantum_rad / ARCSEC / math.sqrt(12):.4g})",
             f"- verdict: **{js['verdict']['effect']}** (gap reduction {js['verdict']['gap_reduction']:.3f})", "",
             "## Baseline refit", "", "| axis | residual RMS (arcsec) | excess (arcsec) | f0 (Hz) | k1 | k2 | k3 | k4 | k5 |",
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
