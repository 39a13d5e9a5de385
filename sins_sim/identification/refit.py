"""Refit of the nominal parameters on one axis of a recording (step 1 of the diagnosis).

:func:`fit_axis` fits ``f0, k1..k5`` of one axis (with a candidate effect's
parameters when given one) by simulating the recording's experiment
(``sins_sim.simulation.experiment``) and minimising the residual with
``scipy.optimize.least_squares``. Parametrisation:
``(F(a_ref), k1, k2, 1/Q(a_ref), k4, k5)`` relative to their nominal values,
with ``F`` the harmonic-balance resonance and ``1/Q = k3 (1 + k4 a)`` at the
measured dither amplitude ``a_ref``; a weak prior keeps unresolved directions
at the nominal values; stages: a grid over F, then ``F, 1/Q, k5``, then all
six; uncertainty from the Jacobian and the prior, the residual variance
inflated by the residual's correlation length. The whole procedure is
described in :mod:`sins_sim.identification.diagnose`.

:class:`DiagnoseSettings` holds the settings of every step of the diagnosis.

.. autosummary::

   DiagnoseSettings
   AxisFit
   fit_axis
"""

from __future__ import annotations

import math
import warnings
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize
from scipy.fft import next_fast_len

from sins_sim import _validate as v
from sins_sim.identification.afc import hb_stiffness_ratio
from sins_sim.io.recording import NOMINAL_KEYS
from sins_sim.models.effects import EFFECTS, Effect, Param
from sins_sim.models.suspension import (F0_RANGE_HZ, K1_MAX, K2_RANGE_RAD, K3_MAX, K4_MAX_PER_RAD, K4_MIN_PER_RAD,
                                        K5_RANGE_RAD_PER_V, Q_RANGE, SuspensionParams)
from sins_sim.simulation.experiment import FIT_SETTINGS, ExperimentInputs, ExperimentSettings, simulate_axis

__all__ = ["DiagnoseSettings", "AxisFit", "EffectSet", "fit_axis", "blas_threads", "in_processes"]

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
#: Models each ``_Problem`` keeps by their parameters (the oldest goes first).
_MEMO = 4
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
    gap_alpha : float
        False-alarm level of the gap's test over all axes (``sins_sim.identification.detection``:
        each axis at the Sidak level ``1 - (1 - gap_alpha)^(1 / n_axes)``).
    rel_tol, abs_tol_arcsec : float
        The gap is significant when the excess RMS over the floor exceeds
        ``max(test tolerance, rel_tol * floor, abs_tol)``: ``abs_tol`` covers model error between
        simulators that no noise statistic knows of; ``rel_tol`` (0: off) restores a fixed fraction of
        the floor (before issue 24 it was 0.5).
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
    max_effects : int
        Most effects the greedy forward selection names (1: the best effect only).
    greedy_candidates : int
        How many of the first round's best candidates each further greedy round tries.
    checks : bool
        Check the data before judging it (``sins_sim.identification.checks``).
    bias_drift : bool
        Profile a readout bias and its drift out of every fit (baseline and candidates alike) when the
        table does not move: the angle terms ``b t + c t^2`` (a rate bias ``b`` changing at ``2 c``; a slow
        random walk of the bias over a recording looks like that), fitted by linear least squares on each
        model's residual, so that no effect absorbs them (issue 24: a drift of 0.02-0.03 deg/h was
        absorbed as ``lock_in``). On a moving table a bias equals a scale error times the table rate over
        one recording (only turning both ways separates them), so the nuisance is left out there.
    """

    experiment: ExperimentSettings = FIT_SETTINGS
    prior_f0: float = 0.01
    prior_k: float = 0.3
    max_nfev: int = 30
    candidate_nfev: int = 16
    window_s: float | None = 3.0
    polish_nfev: int = 4
    rel_tol: float = 0.0
    abs_tol_arcsec: float = 0.02
    gap_alpha: float = 0.05
    min_gap_reduction: float = 0.6
    close_fraction: float = 0.15
    block_s: float | None = None
    effects: tuple | None = None
    threads: int = 2
    max_effects: int = 3
    greedy_candidates: int = 4
    checks: bool = True
    bias_drift: bool = True

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
        a = v.finite("diagnose", "gap_alpha", self.gap_alpha)
        if not 0.0 < a < 1.0:
            raise ValueError(f"diagnose.gap_alpha: must be in (0, 1), got {a!r}")
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
        for name in ("max_effects", "greedy_candidates"):
            val = getattr(self, name)
            if int(val) != val or val < 1:
                raise ValueError(f"diagnose.{name}: must be an integer >= 1, got {val!r}")
        if int(self.threads) != self.threads or self.threads < 1:
            raise ValueError(f"diagnose.threads: must be an integer >= 1, got {self.threads!r}")


# --- interruption ----------------------------------------------------------------------------------------
#: Set when the diagnosis is interrupted (Ctrl-C, SIGTERM): every model evaluation checks it first, so
#: the worker threads stop after the kernel call they are in (each simulates one axis once: tens of ms
#: for a 20 s recording) instead of finishing their fits.
CANCEL = threading.Event()


class Cancelled(Exception):
    """A model evaluation refused because the diagnosis was interrupted."""


@contextmanager
def worker_pool(n: int):
    """A thread pool that, when the body raises (an interrupt), cancels what is queued and does not wait.

    Python runs signal handlers in the main thread only, between bytecodes; a ``with
    ThreadPoolExecutor`` would then wait for every submitted fit to end before the interrupt could
    propagate. Here the pending tasks are cancelled, :data:`CANCEL` stops the running ones at their
    next model evaluation, and the exception goes on at once.
    """
    ex = ThreadPoolExecutor(max_workers=n)
    try:
        yield ex
    except BaseException:
        CANCEL.set()
        ex.shutdown(wait=False, cancel_futures=True)
        raise
    ex.shutdown(wait=True)


def in_processes(fn, tasks, jobs: int, done) -> None:
    """``fn(task)`` for every task, ``jobs`` at once in separate (spawned) processes: whole diagnoses of
    independent recordings. ``done(i, result)`` is called in this process as task ``i`` ends, in any
    order. An error or an interrupt cancels what is queued and goes on at once."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=multiprocessing.get_context("spawn")) as ex:
        futs = {ex.submit(fn, task): i for i, task in enumerate(tasks)}
        try:
            for fut in as_completed(futs):
                done(futs[fut], fut.result())
        except BaseException:
            ex.shutdown(wait=False, cancel_futures=True)
            raise


# --- BLAS threads -------------------------------------------------------------------------------------
@contextmanager
def blas_threads(n: int = 1):
    """The BLAS libraries (numpy's and scipy's OpenBLAS) limited to ``n`` threads inside the block.

    The least-squares solver's linear algebra is a few SVDs and products of a tall Jacobian (tens of
    thousands of rows, under a dozen columns): milliseconds of work, on which OpenBLAS' own threads
    mostly spin, and they compete with the diagnosis' worker threads. On the 20 s three-axis rate-table
    recording (2 cores, ``threads = 2``) the diagnosis took 55 s of CPU and 32 s of wall time with
    OpenBLAS' default threads, 29 s and 19 s with one. The limit is set and restored by
    ``threadpoolctl`` (the maintained library scikit-learn uses for this).
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=int(n), user_api="blas"):
        yield


# --- several effects at once ------------------------------------------------------------------------
class EffectSet:
    """Several catalogue effect classes fitted together (the greedy forward selection of the verdict).

    It follows the fitting protocol of :class:`sins_sim.models.effects.Effect`
    (``fit_space``, ``build``, ``needs_motion``, ``min_axes``); its
    parameters are the members' parameters named ``"<effect>.<param>"``.
    """

    def __init__(self, classes):
        self.classes = tuple(classes)
        if not self.classes:
            raise ValueError("diagnose.effects: an effect set needs at least one effect")
        self.name = "+".join(c.name for c in self.classes)
        self.needs_motion = any(c.needs_motion for c in self.classes)
        self.min_axes = max(c.min_axes for c in self.classes)

    def fit_space(self, axis: str, axes) -> list:
        return [replace(p, name=f"{c.name}.{p.name}") for c in self.classes for p in c.fit_space(axis, axes)]

    def build(self, axis: str, axes, values: dict) -> "BuiltEffects":
        parts = []
        for c in self.classes:
            pre = c.name + "."
            parts.append(c.build(axis, axes, {k[len(pre):]: val for k, val in values.items() if k.startswith(pre)}))
        return BuiltEffects(tuple(parts))


@dataclass(frozen=True)
class BuiltEffects:
    """The effects of an :class:`EffectSet` built for one axis (what ``_Problem.model`` simulates)."""

    effects: tuple

    def values(self, axis: str) -> dict:
        return {f"{e.name}.{k}": val for e in self.effects for k, val in e.values(axis).items()}


def effects_of(effect) -> tuple:
    """The Effect objects a fitted effect stands for: ``()``, ``(effect,)`` or a set's members."""
    if effect is None:
        return ()
    return tuple(effect.effects) if isinstance(effect, BuiltEffects) else (effect,)


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
    drift : (bias rad/s, bias rate rad/s^2) or None
        The readout bias drift profiled out of the fit (``DiagnoseSettings.bias_drift``).
        The fitted state change at ``t = 0`` of a recording that starts mid-operation.
    shared_jac : ndarray or None
        A polish's Jacobian columns of the nominal parameters and the start state (``x`` units,
        rows: training samples, then the prior), kept when asked for (``fit_axis``'s
        ``keep_jac``) so that the polishes of candidate effects on the same axis can start from
        them (``jac_hint``).
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
    drift: tuple | None = None
    shared_jac: np.ndarray | None = field(default=None, repr=False, compare=False)


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
                 coupled: dict | None, a_ref: float, skip: int = 0, drift: bool = False):
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
        # the nuisance profiled out of every model's residual: a constant (a recording that starts
        # mid-operation) and a bias drift b t + c t^2 (settings.bias_drift), by linear least squares on the used
        # samples; columns scaled to the recording's length for conditioning
        cols = []
        if offset:
            cols.append(np.ones(y.size))
        self.drift = bool(drift)
        self._t_end = max(y.size - 1, 1) / inputs.fs_hz
        if self.drift:
            tn = np.arange(y.size) / inputs.fs_hz / self._t_end
            cols += [tn, tn * tn]
        self.basis = np.column_stack(cols) if cols else None
        self._basis_used = None if self.basis is None else self.basis[used]
        # the last few models by their parameters: a fit asks again for the model at a point it has
        # just evaluated (the start of its next stage, its cost, its final residual)
        self._memo = {}
        self._memo_lock = threading.Lock()
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
        """The suspension of a trial point, projected onto the physical ranges the model declares
        (:func:`physical_clip`): the solver's box is relative to the nominal values and does not hold
        ``k4 >= -20 1/rad``, ``k1 < 2 k2`` or ``k3 >= 0`` everywhere (issue 25, item 10)."""
        p = physical_clip(self.to_p(np.asarray(xn) * self.u_nom))
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
        return self._model(sus, effect, start)[0].copy()

    def _model(self, sus: SuspensionParams, effect: Effect | None, start=None):
        """The model (not a copy: do not change it) and the nuisance's coefficients (or None)."""
        if CANCEL.is_set():
            raise Cancelled("diagnosis interrupted")
        effects = effects_of(effect)
        kick = None if start is None else (self.kick_index, float(start[0]), float(start[1]))
        key = (repr(sus), tuple(repr(e) for e in effects), kick)
        with self._memo_lock:
            hit = self._memo.get(key)
        if hit is not None:
            return hit
        self.nfev += 1
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = simulate_axis(self.inputs, self.axis, sus, effects, self.settings.experiment, coupled=self.coupled,
                              kick=kick)
        m = m[self.skip:]
        coef = None
        if self.basis is not None:
            coef = np.linalg.lstsq(self._basis_used, (self.y - m)[self.used], rcond=None)[0]
            m = m + self.basis @ coef
        with self._memo_lock:
            if len(self._memo) >= _MEMO:
                self._memo.pop(next(iter(self._memo)))
            self._memo[key] = (m, coef)
        return m, coef


    def drift_of(self, sus: SuspensionParams, effect: Effect | None, start=None) -> tuple | None:
        """The readout bias drift profiled out of the model at these parameters: ``(b rad/s, 2 c rad/s^2)``
        of its ``b t + c t^2``, or None without the nuisance."""
        if not self.drift:
            return None
        coef = self._model(sus, effect, start)[1]
        b, c = coef[-2] / self._t_end, coef[-1] / self._t_end ** 2
        return float(b), float(2.0 * c)


def _solve(prob: _Problem, effect_cls, x0, space, max_nfev, threads, mask, free=None, frozen_jac=False,
           jac_hint=None):
    """Least squares over (nominal, effect) parameters on the samples ``mask``.

    ``x0`` is the full start vector (nominal relative, then the start state
    of a recording that starts mid-operation and the effect's parameters, in
    units of their ``Param.scale``; ``space`` lists those); only the indices
    ``free`` move. The solver
    works in ``z = (x - x0) / _XSCALE``: the first trust region then spans
    about one plausible variation of every parameter (a unit's f0 is off
    by 0.2 %, its k by tens of %), not ``|x0|``, which keeps the first
    steps of a badly started fit from jumping into nonsense.

    ``frozen_jac``: the Jacobian is computed once, at ``x0``, and kept for
    every step (the chord method, Kelley 1995, "Iterative Methods for Linear
    and Nonlinear Equations", sec. 5.4): for a refinement that starts near
    its solution, where one Jacobian costs as many model evaluations as there
    are parameters and the steps only need its direction. Every step is still
    accepted on the true cost. ``jac_hint`` (with ``frozen_jac``, every
    parameter free): the first columns of that Jacobian, taken from another
    fit's (in ``x`` units, the rows of this problem): only the remaining
    columns are computed. The chord method needs only an approximate Jacobian;
    a polish of a candidate effect takes the nominal and start-state columns
    of the baseline's polish on the same axis and differences only its
    effect's parameters.

    Otherwise the Jacobian is computed by finite differences at the start
    and then, at every accepted step, updated by Broyden's rank-one secant
    update (Broyden 1965, "A class of methods for solving nonlinear
    simultaneous equations", Math. Comp. 19; for least squares Dennis &
    Schnabel 1983, "Numerical Methods for Unconstrained Optimization and
    Nonlinear Equations", sec. 10.3): the new residuals minus those
    predicted from the previous Jacobian, along the step. One finite-difference
    Jacobian costs one model evaluation per free parameter, the update none.
    The finite differences are taken again after an iteration that needed more
    than one trial step (a trial rejected: the linear model mispredicted the
    cost, so the secant information is not to be trusted further).

    Returns ``(x, jac, unpack, exact)``: the full solution, the solver's last
    Jacobian of the data residuals with respect to the free ``x`` (columns in
    ``free`` order; a secant update, or with ``frozen_jac`` the one at ``x0``),
    a function ``x -> (SuspensionParams, Effect or None, start state or None)``,
    and ``exact()``, the finite-difference Jacobian at the solution (what the
    uncertainties are computed from; taken when asked for, unless the last one
    was already that).
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

    frozen = []
    # Broyden state: (z, f(z), J) of the last Jacobian, whether it is a finite-difference one, and the
    # solver's residual evaluations (trial steps) in all and when the Jacobian was last asked for
    last = []
    trials = [0, 0]

    def trial(z):
        trials[0] += 1
        return fun(z)

    def jac(z):
        if frozen:
            return frozen[0].copy()
        n_trials = trials[0] - trials[1]
        trials[1] = trials[0]
        f0 = fun(z)
        if last and n_trials <= 1:
            zl, fl, jl, _ = last[0]
            step = z - zl
            ss = float(step @ step)
            if ss > 0.0:
                out = jl + np.outer((f0 - fl) - jl @ step, step / ss)
                last[:] = [(z.copy(), f0, out, False)]
                return out.copy()
        out = fd_jac(z, f0)
        last[:] = [(z.copy(), f0, out, True)]
        return out.copy()

    hint = None
    if frozen_jac and jac_hint is not None and free.size == n and jac_hint.shape[1] <= n \
            and jac_hint.shape[0] == int(mask.sum()) + n_nom:
        hint = jac_hint * xs[None, :jac_hint.shape[1]]  # to z units

    def fd_jac(z, f0):
        x = full(z)
        hx = steps[free] * np.maximum(1.0, np.abs(x[free]))
        hx = np.where(x[free] + hx <= hi[free], hx, -hx)
        hz = hx / xs

        def col(i):
            zp = z.copy()
            zp[i] += hz[i]
            return (fun(zp) - f0) / hz[i]

        first = 0 if hint is None else hint.shape[1]
        if threads > 1:
            with worker_pool(threads) as ex:
                cols = list(ex.map(col, range(first, z.size)))
        else:
            cols = [col(i) for i in range(first, z.size)]
        out = np.column_stack(([hint] if hint is not None else []) + cols)
        if frozen_jac:
            frozen.append(out.copy())
        return out

    zlo = (lo[free] - x0[free]) / xs
    zhi = (hi[free] - x0[free]) / xs
    sol = optimize.least_squares(trial, np.zeros(free.size), jac=jac, bounds=(zlo, zhi), method="trf",
                                 x_scale=1.0, max_nfev=max_nfev, xtol=_TOL, ftol=_TOL, gtol=_TOL)

    def exact():
        if frozen or (last and last[0][3] and np.array_equal(last[0][0], sol.x)):
            return sol.jac / xs[None, :]
        return fd_jac(sol.x, fun(sol.x)) / xs[None, :]

    return full(sol.x), sol.jac / xs[None, :], unpack, exact


#: Margin below ``2 k2`` that a clipped ``k1`` keeps (eq. 9 needs ``k1 < 2 k2`` strictly).
_K1_MARGIN = 1e-6


def physical_limits() -> dict:
    """The physical range of each nominal parameter as :class:`~sins_sim.models.suspension.SuspensionParams`
    checks it (``k1`` also below ``2 k2``, ``k5`` in magnitude; ``k3`` at least ``1 / Q_max``, so that Q
    stays finite without a viscous term)."""
    return {"f0_hz": F0_RANGE_HZ, "k1": (0.0, K1_MAX), "k2": K2_RANGE_RAD, "k3": (1.0 / Q_RANGE[1], K3_MAX),
            "k4": (K4_MIN_PER_RAD, K4_MAX_PER_RAD), "k5": K5_RANGE_RAD_PER_V}


def physical_clip(p) -> np.ndarray:
    """``(f0, k1, k2, k3, k4, k5)`` projected onto the ranges :class:`SuspensionParams` accepts.

    Clipping the trial rather than refusing it keeps every trial a valid unit, so the fit never stops on
    a value the user did not write; a parameter that ends at a limit is reported as implausible
    (``report.plausibility_flags``). Inside the ranges the point is returned unchanged. Non-finite
    values are left alone (the model refuses them and the solver sees a large residual).
    """
    f0, k1, k2, k3, k4, k5 = (float(x) for x in p)
    if not all(math.isfinite(x) for x in (f0, k1, k2, k3, k4, k5)):
        return np.array([f0, k1, k2, k3, k4, k5])
    lim = physical_limits()
    f0 = min(max(f0, lim["f0_hz"][0]), lim["f0_hz"][1])
    k2 = min(max(k2, lim["k2"][0]), lim["k2"][1])
    k1 = min(max(k1, 0.0), lim["k1"][1], 2.0 * k2 * (1.0 - _K1_MARGIN))
    k3 = min(max(k3, lim["k3"][0]), lim["k3"][1])
    k4 = min(max(k4, lim["k4"][0]), lim["k4"][1])
    mag = min(max(abs(k5), lim["k5"][0]), lim["k5"][1])
    k5 = math.copysign(mag, k5)
    return np.array([f0, k1, k2, k3, k4, k5])


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
    size = next_fast_len(2 * n - 1, real=True)  # any length >= 2n - 1 gives the linear autocorrelation
    f = np.fft.rfft(r, size)
    ac = np.fft.irfft(f * np.conj(f), size)[:n]
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


#: Indices of (k1, k2, k4): what a steady dither resolves weakly (the valleys of ``(f0, k1, k2)`` and ``(k3, k4)``).
_WEAK = [1, 2, 4]


def _bent(prob: _Problem, xn: np.ndarray) -> bool:
    """Whether k1, k2 or k4 of ``xn`` sit more than the prior's width from the nominal values."""
    return bool(np.any(np.abs(xn[_WEAK] - prob.x_c[_WEAK]) > prob.settings.prior_k))


def _drift_centred(prob: _Problem, effect_cls, xn: np.ndarray, values: dict) -> np.ndarray:
    """For a ``resonance_drift`` start: f0 moved so that f0 in the middle of the data is unchanged.

    A fit without the drift finds the recording's mean resonance; the
    drift's f0 is the one at the start of the simulation (the model's
    ``t = 0``, before any pre-roll), so a drift start keeps the mean where
    the fit found it.
    """
    # in an effect set, only a drift that is new (the last member) moves the start
    last = effect_cls.classes[-1].name if isinstance(effect_cls, EffectSet) else getattr(effect_cls, "name", "")
    if last != "resonance_drift":
        return xn
    rate = float(values.get("rate_hz_per_s", values.get("resonance_drift.rate_hz_per_s", 0.0)))
    t_mid = (prob.skip + 0.5 * prob.y.size) / prob.inputs.fs_hz
    sus = prob.suspension(xn)
    try:
        return prob.x_of(sus.replace(f0_hz=sus.f0_hz - rate * t_mid))
    except ValueError:
        return xn


def fit_axis(prob: _Problem, effect_cls=None, start: AxisFit | None = None, effect_starts=None,
             max_nfev: int | None = None, polish: bool = False, uncertainty: bool = True, jac_hint=None,
             keep_jac: bool = False, chord: bool = True) -> AxisFit:
    """Fit the nominal parameters (and an effect's) on one axis, on the training blocks.

    Stages: (0) without a start, the grid :data:`_F_GRID` of the
    operating-point resonance (the residual is far from quadratic when the
    dither's phase is off); with an effect, the best of ``effect_starts``
    at the start's nominal parameters; (1) least squares over ``F, 1/Q,
    k5``, the start state (recordings that start mid-operation) and the
    effect's parameters; (2) least squares over everything. Stages 1 and 2
    run from the start's nominal parameters and, when the start has bent
    the weakly resolved ``k1, k2, k4`` more than their prior's width
    (a baseline absorbing what the effect explains), also from the start
    with ``k1, k2, k4`` at the recording's nominal values (``F(a_ref),
    1/Q(a_ref), k5`` kept: the dither resolves them); the better result is
    kept.

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
        the refinement on the whole recording of a fit made on its first window,
        with the Jacobian of its start kept for every step (``_solve``'s
        ``frozen_jac``; the uncertainties are from that Jacobian).
    uncertainty : bool
        Compute the uncertainties from a finite-difference Jacobian at the solution (the solver's
        own last Jacobian is a secant update, see ``_solve``). ``False`` for a fit that only starts
        a polish (which computes its own): its ``sigma`` is then from the secant Jacobian.
    jac_hint : ndarray, optional
        With ``polish``: Jacobian columns of the nominal parameters and the start state from
        another polish on the same axis and samples (:attr:`AxisFit.shared_jac`), reused as the
        first columns of this one (``_solve``); the uncertainties are then from that mixed
        Jacobian (a polish's are from its start's Jacobian in any case).
    keep_jac : bool
        With ``polish``: keep those columns of this polish's Jacobian in
        :attr:`AxisFit.shared_jac`.
    chord : bool
        With ``polish``: the chord method (the start's Jacobian kept). ``False``: the Jacobian updated
        at every accepted step (``_solve``'s Broyden update), for a fit continued from where a small
        budget stopped it in a curved valley, where the start's Jacobian points off the valley floor;
        ``jac_hint`` is then not used.
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
        x, jac, unpack, _ = _solve(prob, effect_cls, np.concatenate([x0_nom, x0_nui, x0_eff]), space,
                                   max_nfev or prob.settings.polish_nfev, threads, prob.train, frozen_jac=chord,
                                   jac_hint=jac_hint if chord else None)
        fit = _finish(prob, x, jac, unpack, space)
        if keep_jac:
            fit.shared_jac = np.ascontiguousarray(jac[:, :n_nom + n_nui])
        return fit
    if effect_cls is None and start is None:
        def grid_cost(df):
            x = x0_nom.copy()
            x[0] = prob.x_c[0] * (1.0 + df)
            try:
                return _cost(prob, prob.suspension(x), None)
            except ValueError:
                return math.inf

        with worker_pool(threads) as ex:
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
            with worker_pool(threads) as ex:
                costs = list(ex.map(cost, trials))
        else:
            costs = [math.inf]
        best = trials[int(np.argmin(costs))]
        x0_eff = np.array([best[1].get(p.name, 0.0) / p.scale for p in eff_space])
        x0_nom = best[0].copy()
        if start is not None and _bent(prob, x0_nom):
            # k1, k2, k4 back at their nominal values; F(a_ref), 1/Q(a_ref) and k5, which the dither
            # resolves, stay where the start has them (at the nominal F the dither would be far off phase)
            xn = x0_nom.copy()
            xn[_WEAK] = prob.x_c[_WEAK]
            nominal_starts.append(xn)
    stage1 = list(_MAIN) + list(range(n_nom, n_nom + len(space)))
    budget = max_nfev or (prob.settings.max_nfev if effect_cls is None else prob.settings.candidate_nfev)
    best, best_cost = None, math.inf
    for xn in [x0_nom] + nominal_starts:
        if best is not None and not _bent(prob, best[0][:n_nom]):
            break  # the fit from the bent start came back to nominal k1, k2, k4: no restart needed
        x, _, _, _ = _solve(prob, effect_cls, np.concatenate([xn, x0_nui, x0_eff]), space, max(4, budget // 2),
                            threads, prob.train, free=stage1)
        x, jac, unpack, exact = _solve(prob, effect_cls, x, space, budget, threads, prob.train)
        c = _cost(prob, *unpack(x))
        if best is None or c < best_cost:
            best, best_cost = (x, jac, unpack, exact), c
    x, jac, unpack, exact = best
    return _finish(prob, x, exact() if uncertainty else jac, unpack, space)


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
                   heldout_rms=_rms(res[heldout]) if heldout.any() else math.nan, rms=_rms(res), start_state=state,
                   drift=prob.drift_of(sus, eff, state))
