"""Kalman fine alignment and zero-velocity navigation of a unit standing still (issue 35).

Both run the closed-loop error-state filter of :mod:`sins_sim.navigation.ekf` on a log known to stand
still: zero-velocity updates (ZUPT) at ``update_rate_hz``, and for the alignment also the known, unchanged
position (Titterton & Weston 2004, sec. 10.4 "fine alignment" by Kalman filtering; Groves 2013, sec.
14.4.1 and 16.2.4).

.. autosummary::

   align_kalman
   navigate_zupt
   ZuptResult

What a still base can tell (derivation in :mod:`sins_sim.navigation.ekf`): the tilts only together with
the horizontal accelerometer biases, the heading only together with the east gyro bias (its limit is
``sigma_east_bias / (Omega cos lat)``), the north gyro bias and the vertical accelerometer bias at once, the
down gyro bias slowly (minutes to hours, through the curvature of the east tilt). Which body axes that
makes observable follows from the attitude; the rule that decides it from the covariance is
:func:`observability`.

References
----------
.. [1] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IEE, 2004,
   ch. 10.
.. [2] P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd
   ed., Artech House, 2013, ch. 14 and 16.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from numbers import Integral

import numpy as np

from sins_sim import _validate as v
from sins_sim.navigation import ekf
from sins_sim.navigation.alignment_result import AlignmentResult
from sins_sim.navigation.attitude import _increments, _unit_quat, euler_from_quat
from sins_sim.navigation.strapdown import NavSolution, StrapdownNavigator

__all__ = ["align_kalman", "navigate_zupt", "ZuptResult", "observability", "OBSERVABLE_FRACTION"]

#: A bias state counts as observable when its posterior sigma is below this fraction of the sigma it
#: would have with no measurement (:func:`observability`).
OBSERVABLE_FRACTION = 0.9


def observability(aided, fraction=OBSERVABLE_FRACTION) -> dict:
    """Which bias states the measurements so far have made observable, decided from the covariance.

    Rule: a bias state (body axis) is observable when its posterior 1-sigma is below ``fraction`` of its
    unaided sigma, the sigma the same bias model reaches over the same time with no measurement (the
    prior, grown by any random walk or relaxed to a Gauss-Markov steady state). A state the data cannot
    reach keeps its unaided sigma up to the small share it has in the observable combinations: at rest
    the east gyro bias against a heading prior ``sigma_h``, ``1/sqrt(1 + (sigma_b / (Omega cos(lat)
    sigma_h))^2)`` of its prior, above 0.99 for a heading prior of a degree and a navigation-grade bias;
    the horizontal accelerometer biases against the tilt prior likewise. The flag is per body axis: an
    axis between north and east (heading near 45 deg) shares in the observable north combination and
    is counted observable once its sigma has fallen by ``1 - fraction``; the sigmas say how well.

    Parameters
    ----------
    aided : AidedNavigator
        The filter.
    fraction : float
        Threshold in (0, 1].

    Returns
    -------
    dict of str -> bool
        ``gyro_bias_x`` ... ``accel_bias_z``.
    """
    frac = v.positive("", "fraction", fraction)
    post = aided.sigma()[ekf.BIASES]
    prior = aided.unaided_bias_sigma
    return {key: bool(post[i] < frac * prior[i]) for i, key in enumerate(ekf.BIAS_KEYS)}


def _check_inputs(dtheta, dv, dt_s, lat_rad, lon_rad, h_m, q0_nb, noise, duration_s, update_rate_hz, n_sub):
    dth = _increments("dtheta", dtheta)
    dvel = _increments("dv", dv)
    if dvel.shape[0] != dth.shape[0]:
        raise ValueError(f"dv: must have {dth.shape[0]} rows (len(dtheta)), got {dvel.shape[0]}")
    dt = v.positive("", "dt_s", dt_s)
    if not isinstance(noise, ekf.ImuNoise):
        raise ValueError(f"noise: must be an ImuNoise, got {type(noise).__name__}")
    rate = v.positive("", "update_rate_hz", update_rate_hz)
    samples = v.integer_ratio("", "update_rate_hz", 1.0 / rate, dt, "1 / (update_rate_hz dt_s)")
    if isinstance(n_sub, bool) or not isinstance(n_sub, Integral) or n_sub < 1 or samples % int(n_sub):
        raise ValueError(f"n_sub: must be an integer >= 1 dividing the {samples} samples of one update "
                         f"interval, got {n_sub!r}")
    n = dth.shape[0]
    if duration_s is not None:
        n_dur = int(round(v.positive("", "duration_s", duration_s) / dt))
        if n_dur > n:
            raise ValueError(f"duration_s: must be at most the log's {n * dt!r} s, got {duration_s!r}")
        n = n_dur
    if n < samples:
        raise ValueError(f"dtheta: must hold at least one update interval ({samples} samples), got {n}")
    q0 = _unit_quat("q0_nb", q0_nb)
    lat = v.finite("", "lat_rad", lat_rad)
    return dth[:n], dvel[:n], dt, samples, lat, v.finite("", "lon_rad", lon_rad), v.finite("", "h_m", h_m), q0


def _run_still(dth, dvel, dt, samples, lat, lon, h, q0, noise, *, n_sub, prior_tilt, prior_heading,
               zupt_sigma, position_sigma, zero_rate, max_propagation_s):
    """The closed loop over a still log; returns the filter, the navigator rows and the per-epoch history."""
    nav = StrapdownNavigator(lat, lon, h, np.zeros(3), q0, dt, n_sub=int(n_sub))
    zs = v.positive("", "zupt_sigma_m_s", zupt_sigma)
    pos_sigma = None if position_sigma is None else v.positive("", "position_sigma_m", position_sigma)
    p0 = ekf.initial_covariance(pos_sigma if pos_sigma is not None else 0.0, zs,
                                v.positive("", "prior_tilt_sigma_rad", prior_tilt),
                                v.positive("", "prior_heading_sigma_rad", prior_heading), noise)
    aided = ekf.AidedNavigator(nav, noise, p0, max_propagation_s=max_propagation_s)
    rate_sigma = noise.gyro_arw_rad_sqrt_s / math.sqrt(samples * dt)
    if zero_rate and rate_sigma <= 0.0:
        raise ValueError("zero_rate: needs noise.gyro_arw_rad_sqrt_s > 0 (the zero-rate measurement's sigma is "
                         "ARW / sqrt(T))")
    zupt = ekf.ZeroVelocity(zs)
    still = ekf.Position(lat, lon, h, pos_sigma) if pos_sigma is not None else None
    k_epochs = dth.shape[0] // samples
    hist = {"t_s": np.empty(k_epochs), "q_nb": np.empty((k_epochs, 4)), "sigma": np.empty((k_epochs, ekf.N_STATES)),
            "bias": np.empty((k_epochs, 6))}
    rows = []
    for k in range(k_epochs):
        sl = slice(k * samples, (k + 1) * samples)
        rows.append(aided.process(dth[sl], dvel[sl]))
        meas = [zupt]
        if still is not None:
            meas.append(still)
        if zero_rate:
            meas.append(ekf.ZeroAngularRate(aided.mean_gyro_rate_b_rad_s, rate_sigma))
        aided.update(*meas)
        hist["t_s"][k] = aided.t_s
        hist["q_nb"][k] = aided.navigator.q_nb
        hist["sigma"][k] = aided.sigma()
        hist["bias"][k, :3] = aided.gyro_bias_rad_s
        hist["bias"][k, 3:] = aided.accel_bias_m_s2
    if dth.shape[0] > k_epochs * samples:  # the tail after the last update: navigated, not aided
        rows.append(aided.process(dth[k_epochs * samples:], dvel[k_epochs * samples:]))
    sol = NavSolution(*(np.concatenate([getattr(r, f) for r in rows]) for f in
                        ("t_s", "lat_rad", "lon_rad", "h_m", "v_ned_m_s", "q_nb")))
    return aided, sol, hist


def align_kalman(dtheta, dv, dt_s, lat_rad, lon_rad, h_m, q0_nb, noise, *, duration_s=None, update_rate_hz=1.0,
                 prior_tilt_sigma_rad, prior_heading_sigma_rad, zupt_sigma_m_s=1e-3, position_sigma_m=0.01,
                 n_sub=1, max_propagation_s=1.0, observable_fraction=OBSERVABLE_FRACTION) -> AlignmentResult:
    """Kalman fine alignment on a base at rest, from a coarse attitude ``q0_nb``.

    Zero-velocity and zero-position-change measurements every ``1 / update_rate_hz`` s drive the closed-loop
    error-state filter (:class:`~sins_sim.navigation.ekf.AidedNavigator`); the attitude at the end of the
    window is the result, with its 1-sigma from the filter's covariance. The psi-angle error model is
    linear in the attitude error: the coarse heading should be within a few degrees (the neglected terms
    are of relative size ``psi_D^2 / 2``, 4e-4 at 1.6 deg).

    Parameters
    ----------
    dtheta, dv : array_like, shape (n, 3)
        Gyro angle and velocity increments of the still log (rad, m/s; body axes), one per ``dt_s``.
    dt_s : float
        Sample period (s), > 0.
    lat_rad, lon_rad, h_m : float
        The base's position (rad, rad, m up).
    q0_nb : array_like, shape (4,)
        Coarse attitude at the start (body to NED, scalar first).
    noise : ImuNoise
        The unit's sensor-error model.
    duration_s : float, optional
        Use the first ``duration_s`` s of the log (all of it by default).
    update_rate_hz : float
        Measurement rate (Hz); ``1 / (update_rate_hz dt_s)`` must be a whole number of samples.
    prior_tilt_sigma_rad : float
        1-sigma of the coarse tilts (rad), > 0.
    prior_heading_sigma_rad : float
        1-sigma of the coarse heading (rad), > 0.
    zupt_sigma_m_s : float
        1-sigma of the base's residual velocity (m/s), > 0; 1 mm/s by default (a still base in a building).
    position_sigma_m : float or None
        1-sigma of the base's residual displacement (m), > 0; ``None`` for zero-velocity updates only.
    n_sub : int
        Input samples per navigation update (dividing the samples of one measurement interval).
    max_propagation_s : float
        Longest covariance propagation step (s).
    observable_fraction : float
        The rule of :func:`observability`.

    Returns
    -------
    AlignmentResult
        ``method="kalman"``; ``sigma_rad`` the filter's psi sigmas (N, E, D); the bias estimates with their
        sigmas and ``observable`` flags; ``convergence`` with ``t_s``, ``roll_rad``, ``pitch_rad``,
        ``heading_rad``, ``sigma_heading_rad`` per update; ``settling_rad`` the heading's peak-to-peak over
        the last fifth of the window.

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    args = _check_inputs(dtheta, dv, dt_s, lat_rad, lon_rad, h_m, q0_nb, noise, duration_s, update_rate_hz, n_sub)
    aided, _, hist = _run_still(*args, noise, n_sub=n_sub, prior_tilt=prior_tilt_sigma_rad,
                                prior_heading=prior_heading_sigma_rad, zupt_sigma=zupt_sigma_m_s,
                                position_sigma=position_sigma_m, zero_rate=False, max_propagation_s=max_propagation_s)
    n_used = args[0].shape[0]
    eul = euler_from_quat(hist["q_nb"])
    heading = np.unwrap(eul[:, 2])
    k = hist["t_s"].shape[0]
    tail = heading[k - max(1, k // 5):]
    sig = aided.sigma()
    notes = []
    nis = np.array([r.nis for r in aided.innovations if r.name == "zero_velocity"])
    # a consistent filter's mean NIS over K epochs is chi2(3K)/K: above 6 lies beyond its 99.9 % point for
    # every K >= 10 (chi2(30) 99.9 % = 59.7)
    if nis.size >= 10 and nis.mean() > 2.0 * 3.0:
        notes.append(f"zero-velocity innovations exceed the noise model (mean NIS {nis.mean():.3g} for 3 "
                     f"expected): the base moved, or zupt_sigma_m_s / the IMU noise is too small")
    return AlignmentResult(
        method="kalman", q_nb=aided.navigator.q_nb, sigma_rad=sig[ekf.ATT], duration_s=n_used * args[2],
        convergence={"t_s": hist["t_s"], "roll_rad": eul[:, 0], "pitch_rad": eul[:, 1],
                     "heading_rad": np.mod(heading, 2.0 * math.pi), "sigma_heading_rad": hist["sigma"][:, ekf.HEADING]},
        settling_rad=float(tail.max() - tail.min()),
        gyro_bias_rad_s=aided.gyro_bias_rad_s, gyro_bias_sigma_rad_s=sig[ekf.GYRO_BIAS],
        accel_bias_m_s2=aided.accel_bias_m_s2, accel_bias_sigma_m_s2=sig[ekf.ACCEL_BIAS],
        observable=observability(aided, observable_fraction), notes=tuple(notes))


@dataclass(frozen=True)
class ZuptResult:
    """Navigation of a still log with zero-velocity updates (:func:`navigate_zupt`).

    Attributes
    ----------
    solution : NavSolution
        The closed-loop navigation solution, one row per navigation update (corrected at each epoch).
    t_s : ndarray, shape (K,)
        The update epochs (s).
    innovation_m_s : ndarray, shape (K, 3)
        Zero-velocity innovations (velocity residuals before the update), NED (m/s).
    innovation_sigma_m_s : ndarray, shape (K, 3)
        Their predicted 1-sigma, ``sqrt(diag S)``.
    nis : ndarray, shape (K,)
        Normalised innovation squared of each zero-velocity update (chi-square, 3 degrees of freedom).
    gyro_bias_rad_s, gyro_bias_sigma_rad_s : ndarray, shape (3,)
        Final gyro bias estimate and 1-sigma (body axes).
    accel_bias_m_s2, accel_bias_sigma_m_s2 : ndarray, shape (3,)
        Final accelerometer bias estimate and 1-sigma (body axes).
    observable : dict of str -> bool
        Per bias state, whether this still log makes it observable (:func:`observability`).
    q_nb : ndarray, shape (K, 4)
        Attitude after each update.
    sigma : ndarray, shape (K, 15)
        1-sigma of the 15 error states after each update (:data:`sins_sim.navigation.ekf.STATE_NAMES`).
    bias : ndarray, shape (K, 6)
        Bias estimates after each update (gyro xyz rad/s, accel xyz m/s^2).
    """

    solution: NavSolution
    t_s: np.ndarray
    innovation_m_s: np.ndarray
    innovation_sigma_m_s: np.ndarray
    nis: np.ndarray
    gyro_bias_rad_s: np.ndarray
    gyro_bias_sigma_rad_s: np.ndarray
    accel_bias_m_s2: np.ndarray
    accel_bias_sigma_m_s2: np.ndarray
    observable: dict = field(default_factory=dict)
    q_nb: np.ndarray = None
    sigma: np.ndarray = None
    bias: np.ndarray = None

    def innovation_stats(self) -> dict:
        """Statistics of the velocity residuals: mean, standard deviation and RMS per NED axis (m/s), the mean
        NIS (3 for a consistent filter) and the fraction of epochs above the chi-square(3) 95 % point."""
        nu = self.innovation_m_s
        return {"mean_m_s": nu.mean(axis=0), "std_m_s": nu.std(axis=0, ddof=1) if len(nu) > 1 else np.zeros(3),
                "rms_m_s": np.sqrt(np.mean(nu * nu, axis=0)), "nis_mean": float(self.nis.mean()),
                "nis_above_95_fraction": float(np.mean(self.nis > _CHI2_3_95))}

    def to_pandas(self):
        """The per-epoch series as a DataFrame indexed by ``t_s``: innovations and their sigmas, NIS, the
        bias estimates, roll/pitch/heading and the error-state sigmas (units in the column names)."""
        import pandas as pd

        cols = {}
        for i, ax in enumerate("ned"):
            cols[f"innovation_{ax}_m_s"] = self.innovation_m_s[:, i]
            cols[f"innovation_sigma_{ax}_m_s"] = self.innovation_sigma_m_s[:, i]
        cols["nis"] = self.nis
        for i, ax in enumerate("xyz"):
            cols[f"gyro_bias_{ax}_rad_s"] = self.bias[:, i]
            cols[f"accel_bias_{ax}_m_s2"] = self.bias[:, 3 + i]
        eul = euler_from_quat(self.q_nb)
        cols["roll_rad"], cols["pitch_rad"], cols["heading_rad"] = eul[:, 0], eul[:, 1], np.mod(eul[:, 2], 2 * np.pi)
        for j, name in enumerate(ekf.STATE_NAMES):
            cols[f"sigma_{name}"] = self.sigma[:, j]
        return pd.DataFrame(cols, index=pd.Index(self.t_s, name="t_s"))


#: The chi-square(3) 95 % point (scipy.stats.chi2.ppf(0.95, 3)).
_CHI2_3_95 = 7.814727903251178


def navigate_zupt(dtheta, dv, dt_s, lat_rad, lon_rad, h_m, q0_nb, noise, *, prior_tilt_sigma_rad,
                  prior_heading_sigma_rad, update_rate_hz=1.0, zupt_sigma_m_s=1e-3, position_sigma_m=None,
                  zero_rate=False, n_sub=1, max_propagation_s=1.0,
                  observable_fraction=OBSERVABLE_FRACTION) -> ZuptResult:
    """Navigate a log known to stand still with zero-velocity updates; report residuals and biases.

    Parameters
    ----------
    dtheta, dv : array_like, shape (n, 3)
        Gyro angle and velocity increments (rad, m/s; body axes), one per ``dt_s``.
    dt_s : float
        Sample period (s), > 0.
    lat_rad, lon_rad, h_m : float
        The position of the still unit (rad, rad, m up).
    q0_nb : array_like, shape (4,)
        Initial attitude (body to NED).
    noise : ImuNoise
        The unit's sensor-error model.
    prior_tilt_sigma_rad, prior_heading_sigma_rad : float
        1-sigma of the initial tilts and heading (rad), > 0.
    update_rate_hz : float
        Zero-velocity update rate (Hz); a whole number of samples per interval.
    zupt_sigma_m_s : float
        1-sigma of the residual velocity at rest (m/s), > 0.
    position_sigma_m : float or None
        With a value, zero-position-change updates of that 1-sigma (m) too; none by default.
    zero_rate : bool
        Also apply zero-angular-rate updates (the mean gyro rate minus the Earth's rate is zero; sigma
        ``ARW / sqrt(T)``).
    n_sub : int
        Input samples per navigation update.
    max_propagation_s : float
        Longest covariance propagation step (s).
    observable_fraction : float
        The rule of :func:`observability`.

    Returns
    -------
    ZuptResult

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    args = _check_inputs(dtheta, dv, dt_s, lat_rad, lon_rad, h_m, q0_nb, noise, None, update_rate_hz, n_sub)
    aided, sol, hist = _run_still(*args, noise, n_sub=n_sub, prior_tilt=prior_tilt_sigma_rad,
                                  prior_heading=prior_heading_sigma_rad, zupt_sigma=zupt_sigma_m_s,
                                  position_sigma=position_sigma_m, zero_rate=bool(zero_rate),
                                  max_propagation_s=max_propagation_s)
    recs = [r for r in aided.innovations if r.name == "zero_velocity"]
    sig = aided.sigma()
    return ZuptResult(
        solution=sol, t_s=hist["t_s"], innovation_m_s=np.array([r.innovation for r in recs]),
        innovation_sigma_m_s=np.sqrt(np.array([np.diag(r.s_matrix) for r in recs])),
        nis=np.array([r.nis for r in recs]),
        gyro_bias_rad_s=aided.gyro_bias_rad_s, gyro_bias_sigma_rad_s=sig[ekf.GYRO_BIAS],
        accel_bias_m_s2=aided.accel_bias_m_s2, accel_bias_sigma_m_s2=sig[ekf.ACCEL_BIAS],
        observable=observability(aided, observable_fraction), q_nb=hist["q_nb"], sigma=hist["sigma"],
        bias=hist["bias"])
