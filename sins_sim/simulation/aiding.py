"""GNSS aiding inside a mission (issue 37): every filter's increments also navigated by the error-state filter.

With ``aiding:`` in a scenario, each dither filter's increments (the same the free navigation takes, and
``ideal``'s) are also navigated by :class:`~sins_sim.navigation.aided.AidedRun`, the streaming form of
:func:`~sins_sim.navigation.aided.navigate_aided`, with GNSS fixes drawn once per seed: the errors of the whole
fix grid come from one generator ``[seed, 37]`` before the run starts (:func:`~sins_sim.navigation.gnss.gnss_errors`),
the fix values from the truth rows as the engine produces them (:func:`~sins_sim.navigation.gnss.fixes_from_truth`),
so every filter sees the same fixes (the comparison is paired) and a run stays a function of (configuration, seed).
A recorded solution (``aiding.file``) replaces the simulated fixes.

Process noise and the bias priors are the unit's sensor-error model, the numbers that drive the simulation
(:func:`sins_sim.simulation.aligning.filter_noise`). The filter starts where the free navigation starts: from
the truth, or from the filter's own alignment when ``navigation.alignment`` is configured (its attitude and its
stated sigma). The initial covariance: position the fixes' own 1-sigma (white and Gauss-Markov), velocity the
fixes' velocity sigma, attitude the alignment's sigma (a truth start: the floors of a fine alignment, 10 arcsec of
tilt and 0.01 deg of heading), biases the unit's bias sigmas.

What is kept: per filter the epochs of the run (every applied update, one per second where no fix comes for longer
than that, the times into each outage that the outage growth reads, the start and the end), the truth at those epochs, and until the end of the run the filter's
``(K, 15, 15)`` transition and covariance matrices (three of them per epoch, 5.4 kB; 27 kB per simulated second
at 5 Hz); once the metrics, the outage growth and the smoother are computed they are dropped, and the kept
:class:`~sins_sim.navigation.aided.AidedResult` carries ``(0, 15, 15)`` in their place.

.. autosummary::

   AidingSettings
   AidedMission
   FilterModel
   filter_model
   markov_equivalent_sigma
   unmodelled_errors
   OUTAGE_AFTER_S

The filter's model of what it does not estimate (15 inertial states; scale-factor and misalignment states only
with ``aiding.sensor_error_states``; :func:`filter_model`, stated in ``metrics.json`` ``aiding.filter_model`` with
the number of states):

* **The fixes' Gauss-Markov error**, with ``aiding.fix_error_states`` (the default), is three filter states
  (:class:`~sins_sim.navigation.ekf.FixErrorStates`: ``exp(-T/tau)`` transition, ``sigma^2 (1 - exp(-2 T/tau))``
  driving noise, Gelb 1974 sec. 3.8; 18 states) and ``R`` is the white noise. Without it, it enters ``R`` as an
  equivalent white variance (:func:`markov_equivalent_sigma`): the white variance whose mean over the ``n`` updates of the longest aided
  stretch has the variance of the mean of the first-order Gauss-Markov sequence over the same ``n``
  (the variance of the mean of an AR(1) sequence; Box, Jenkins & Reinsel 2008, sec. 2.1.5). With ``n = 1`` it is
  the Gauss-Markov variance itself, for ``n`` far beyond the correlation the familiar ``2 tau / dt`` inflation.
* **Scale factors and misalignments** (gyro and accelerometer) enter the process noise per propagation step
  (:func:`unmodelled_errors`, :class:`~sins_sim.navigation.ekf.UnmodelledErrors`): the variance their constant
  error ``K`` adds to the attitude (velocity) error over the step, from the angle turned through (the velocity
  change less the median specific force) since the start, ``sigma_S^2 a_i^2 + sigma_M^2 (|a|^2 - a_i^2)``
  per body axis, coherent as a constant error is (a constant rate ``omega`` about one axis for ``t``:
  ``sigma_S^2 omega^2 t^2``), and nothing in cruise. Their constant part (the median rate and specific force)
  raises the bias priors instead. A group named in ``aiding.sensor_error_states`` is estimated instead (3 or 6
  random-constant states with that sigma as prior, fed back into the increments;
  :class:`~sins_sim.navigation.ekf.UnmodelledErrors` ``states``), and neither its process noise nor its share of
  the bias priors is told (no double counting).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim.units import ARCSEC, DEG

__all__ = ["OUTAGE_AFTER_S", "OUTPUT_PERIOD_S", "AidedMission", "AidingSettings", "FilterModel", "filter_model",
           "markov_equivalent_sigma", "unmodelled_errors"]

#: Times into each outage at which the growth is read (s).
OUTAGE_AFTER_S = (10.0, 30.0, 60.0, 120.0)
#: Period of the output epochs besides the updates (s).
OUTPUT_PERIOD_S = 1.0
#: Attitude prior of a truth start (rad): the floors of a fine alignment (as the Kalman alignment's).
TRUTH_START_TILT_RAD = 10.0 * ARCSEC
TRUTH_START_HEADING_RAD = 0.01 * DEG
#: The generator stream of the GNSS errors, ``[seed, GNSS_STREAM]`` (the issue's number: apart from the others).
GNSS_STREAM = 37


@dataclass(frozen=True)
class AidingSettings:
    """A mission's aiding: the receiver, what the filter uses, and how it runs.

    Parameters
    ----------
    gnss : GnssSettings
        Rate, noise (white and Gauss-Markov), latency, lever arm and outages of the fixes.
    measurements : tuple of str
        The fix components applied (``position``, ``velocity``).
    update_rate_hz : float
        The filter's measurement update rate (Hz): every ``gnss.rate_hz / update_rate_hz``-th fix is applied
        (a whole number), and the covariance is propagated once per update interval.
    feedback : bool
        Closed loop (corrections fed back to the navigator) or open loop.
    smoother : bool
        Also run the Rauch-Tung-Striebel smoother over each filter's run.
    file : GnssFile or None
        A recorded solution instead of simulated fixes (its positions and velocities as they are; the noise
        sigmas of ``gnss`` are the filter's ``R``).
    fix_error_states : bool
        Model the fixes' Gauss-Markov error as three filter states (``R`` the white noise; default) rather than
        fold it into ``R`` (:func:`markov_equivalent_sigma`); no effect without a Gauss-Markov error.
    sensor_error_states : tuple of str
        The scale-factor and misalignment groups estimated as filter states
        (:data:`~sins_sim.navigation.ekf.SENSOR_ERROR_GROUPS`: ``gyro_scale_factor`` 3 states, ``gyro_misalignment``
        6, ``accel_scale_factor`` 3, ``accel_misalignment`` 6); the others stay process noise per step.
    """

    gnss: object
    measurements: tuple = ("position", "velocity")
    update_rate_hz: float = 1.0
    feedback: bool = True
    smoother: bool = False
    file: object = field(default=None, compare=False)
    fix_error_states: bool = True
    sensor_error_states: tuple = ()

    @property
    def decimation(self) -> int:
        """Fixes per applied fix."""
        return max(1, int(round(self.gnss.rate_hz / self.update_rate_hz)))


def markov_equivalent_sigma(white_sigma, markov_sigma, markov_tau_s, interval_s, n) -> np.ndarray:
    """The white 1-sigma a filter is told for fixes with white and first-order Gauss-Markov errors (per axis).

    ``R_eq = sigma_w^2 + sigma_gm^2 g(n)`` with ``rho = exp(-interval / tau)`` and
    ``g(n) = (1 + rho) / (1 - rho) - 2 rho (1 - rho^n) / (n (1 - rho)^2)``: ``sigma_gm^2 g(n) / n`` is the variance
    of the mean of ``n`` consecutive samples of the Gauss-Markov sequence (Box, Jenkins & Reinsel 2008, sec.
    2.1.5, the variance of a sample mean of an AR(1) process), so that a filter that averages the ``n`` fixes as
    white reaches the variance the true errors' mean has. ``g(1) = 1``; ``g(n) -> 2 tau / interval`` for
    ``n interval >> tau``.

    Parameters
    ----------
    white_sigma, markov_sigma : array_like, shape (3,)
        White and Gauss-Markov 1-sigma per axis.
    markov_tau_s : float
        Correlation time (s), > 0.
    interval_s : float
        Interval between the applied fixes (s), > 0.
    n : int
        Applied fixes the filter averages (the longest aided stretch), >= 1.

    Returns
    -------
    ndarray, shape (3,)

    Examples
    --------
    >>> markov_equivalent_sigma([1.0] * 3, [0.0] * 3, 300.0, 0.2, 500).tolist()
    [1.0, 1.0, 1.0]
    >>> round(float(markov_equivalent_sigma([0.0] * 3, [1.0] * 3, 300.0, 0.2, 1)[0]), 12)
    1.0
    """
    n = max(1, int(n))
    rho = math.exp(-float(interval_s) / float(markov_tau_s))
    one_m = -math.expm1(-float(interval_s) / float(markov_tau_s))
    g = (1.0 + rho) / one_m - 2.0 * rho * (1.0 - rho ** n) / (n * one_m * one_m)
    g = min(max(g, 1.0), float(n))   # the bounds of the exact sum (fully white: 1; fully correlated: n)
    return np.sqrt(np.asarray(white_sigma, dtype=np.float64) ** 2 + np.asarray(markov_sigma, dtype=np.float64) ** 2 * g)


def unmodelled_errors(sensors, vehicle, t0_s, t1_s, step_s=0.5, states=()):
    """The scale factors and misalignments as the filter is told them: process noise per step, or states.

    ``sigma_S`` the root sum square of scale factor and asymmetry, ``sigma_M`` the largest misalignment (the
    unit's numbers read as 1-sigma, the largest axis), for gyros and accelerometers: the process noise per
    propagation step of :class:`~sins_sim.navigation.ekf.UnmodelledErrors`, or, for the groups named in
    ``states``, the priors of their filter states (and then no process noise: no double counting). The
    accelerometers' reference is the vehicle's median specific force over the span (body; in level flight
    gravity): its error ``K f_ref`` is constant and reads as a bias, so the bias priors per body axis are raised by
    ``sigma_S^2 x_i^2 + sigma_M^2 sum_(j != i) x_j^2`` of the median rate and specific force instead (each term
    only for a group that is not a state: a state's ``F`` column carries the whole ``K x``).

    Parameters
    ----------
    sensors : SensorErrorParams or None
    vehicle : trajectory or None
        With ``evaluate(t)`` giving ``omega_iv_v_rad_s`` and ``f_v_m_s2``; None: the reference is the filter's
        first chunk (:class:`~sins_sim.navigation.ekf.UnmodelledErrors`) and the priors are not raised.
    t0_s, t1_s : float
        The aided span (s).
    step_s : float
        Sampling of the vehicle's motion for the medians (s).
    states : sequence of str
        The groups estimated as states (:data:`~sins_sim.navigation.ekf.SENSOR_ERROR_GROUPS`).

    Returns
    -------
    unmodelled : UnmodelledErrors or None
        None without ``sensors``.
    bias_var_extra : ndarray, shape (6,)
        The bias priors' added variances (gyros xyz in (rad/s)^2, accelerometers xyz in (m/s^2)^2).
    """
    from sins_sim.navigation.ekf import UnmodelledErrors

    extra = np.zeros(6)
    states = tuple(states)
    if sensors is None:
        if states:
            raise ValueError(f"states: {', '.join(states)} need the unit's sensor errors (sensors), got none")
        return None, extra
    ppm = 1e-6
    sig = {}
    for key, par in (("gyro", sensors.gyro), ("accel", sensors.accelerometer)):
        s = math.sqrt(float(np.max(np.asarray(par.scale_factor_ppm, dtype=float) ** 2
                                   + np.asarray(par.scale_factor_asymmetry_ppm, dtype=float) ** 2))) * ppm
        m = float(np.max(np.abs(np.asarray(par.misalignment_arcsec, dtype=float)))) * ARCSEC
        sig[key] = (s, m)
    f_ref = None
    if vehicle is not None and t1_s > t0_s:
        tr = vehicle.evaluate(np.arange(t0_s, t1_s + 1e-9, step_s))
        for k, (key, x) in enumerate((("gyro", np.asarray(tr.omega_iv_v_rad_s)), ("accel", np.asarray(tr.f_v_m_s2)))):
            s, m = sig[key]
            s = 0.0 if f"{key}_scale_factor" in states else s
            m = 0.0 if f"{key}_misalignment" in states else m
            med = np.median(x, axis=0)
            extra[3 * k:3 * k + 3] = s * s * med ** 2 + m * m * (np.sum(med ** 2) - med ** 2)
            if key == "accel":
                f_ref = med
    return UnmodelledErrors(sig["gyro"][0], sig["gyro"][1], sig["accel"][0], sig["accel"][1], f_ref, states), extra


@dataclass(frozen=True)
class FilterModel:
    """What the filter is told: its sensor noise and the fixes' sigmas (:func:`filter_model`).

    ``noise`` the unit's :class:`~sins_sim.navigation.ekf.ImuNoise`, ``position_sigma_m`` and
    ``velocity_sigma_m_s`` the fixes' ``R`` (1-sigma per NED axis), ``record`` the derivation's numbers for
    ``metrics.json`` (SI, units in the keys), ``unmodelled`` the scale factors and misalignments told as process
    noise per step, or as states for the groups of its ``states`` (:class:`~sins_sim.navigation.ekf.UnmodelledErrors`,
    or None), ``fix_errors`` the fixes'
    Gauss-Markov error as filter states (:class:`~sins_sim.navigation.ekf.FixErrorStates`, or None).
    """

    noise: object
    position_sigma_m: np.ndarray
    velocity_sigma_m_s: np.ndarray
    record: dict
    bias_var_extra: np.ndarray = field(default_factory=lambda: np.zeros(6))
    unmodelled: object = None
    fix_errors: object = None

    def initial_covariance(self, pos_sigma_m, vel_sigma_m_s, tilt_sigma_rad, heading_sigma_rad) -> np.ndarray:
        """``P0`` (:func:`~sins_sim.navigation.ekf.initial_covariance`) with the bias variances per body axis
        raised by the constant part of the scale factors' and misalignments' error (gyros xyz, accelerometers
        xyz; :func:`unmodelled_errors`), which the bias states take up."""
        from sins_sim.navigation import ekf

        p0 = ekf.initial_covariance(pos_sigma_m, vel_sigma_m_s, tilt_sigma_rad, heading_sigma_rad, self.noise)
        i = np.arange(6)
        p0[ekf.GYRO_BIAS.start + i, ekf.GYRO_BIAS.start + i] += self.bias_var_extra
        return p0


def _longest_aided_s(t0_s, t1_s, outages_s) -> float:
    edges = [t0_s]
    for a, b in sorted(outages_s):
        edges += [max(t0_s, min(a, t1_s)), max(t0_s, min(b, t1_s))]
    edges.append(t1_s)
    return max(edges[i + 1] - edges[i] for i in range(0, len(edges), 2))


def filter_model(settings: AidingSettings, noise, sensors=None, vehicle=None, t0_s=0.0, t1_s=None) -> FilterModel:
    """The filter's model from the numbers that drive the simulation (module docstring).

    Parameters
    ----------
    settings : AidingSettings
    noise : ImuNoise
        The unit's white noise and bias sigmas (:func:`~sins_sim.simulation.aligning.filter_noise`).
    sensors : SensorErrorParams or None
        The unit's sensor errors (scale factors, misalignments); None: none beyond ``noise``.
    vehicle : trajectory or None
        The vehicle's motion (rates and specific forces); None: no unmodelled-error noise.
    t0_s, t1_s : float
        The aided span (s); ``t1_s`` None: ``t0_s``.

    Returns
    -------
    FilterModel
    """
    g = settings.gnss
    t1 = t0_s if t1_s is None else float(t1_s)
    interval = settings.decimation / g.rate_hz
    span = _longest_aided_s(float(t0_s), t1, g.outages_s)
    n = max(1, math.floor(span / interval + 1e-9))
    from sins_sim.navigation.ekf import N_STATES, FixErrorStates

    fix_errors = None
    markov = settings.file is None and np.any(np.asarray(g.markov_sigma_m) > 0.0)
    if markov and settings.fix_error_states:
        pos = np.asarray(g.position_sigma_m, dtype=np.float64)
        fix_errors = FixErrorStates(g.markov_sigma_m, g.markov_tau_s)
        how = {"gnss_markov": "three first-order Gauss-Markov position states; R the white noise",
               "gnss_markov_sigma_m": [float(x) for x in g.markov_sigma_m], "gnss_markov_tau_s": float(g.markov_tau_s)}
    elif markov:
        pos = markov_equivalent_sigma(g.position_sigma_m, g.markov_sigma_m, g.markov_tau_s, interval, n)
        how = {"gnss_markov": "equivalent white variance in R over the longest aided stretch",
               "gnss_markov_fixes_averaged": n}
    else:
        pos = np.asarray(g.position_sigma_m, dtype=np.float64)
        how = {"gnss_markov": "none"}
    un, extra = unmodelled_errors(sensors, vehicle, float(t0_s), t1, states=settings.sensor_error_states)
    n_sens = 0 if un is None else un.n_states
    record = {"states": N_STATES + (0 if fix_errors is None else fix_errors.n_states) + n_sens, **how,
              "position_sigma_told_m": [float(x) for x in pos],
              "velocity_sigma_told_m_s": [float(x) for x in np.asarray(g.velocity_sigma_m_s)],
              "unmodelled": "process noise per step from the angle and velocity change (coherent accumulation)",
              "sensor_error_states": ", ".join(un.states) if un is not None and un.states else "none",
              "gyro_arw_rad_sqrt_s": noise.gyro_arw_rad_sqrt_s, "accel_vrw_m_s_sqrt_s": noise.accel_vrw_m_s_sqrt_s}
    if un is not None:
        record.update(gyro_scale_factor_sigma=un.gyro_scale_factor, gyro_misalignment_sigma_rad=un.gyro_misalignment_rad,
                      accel_scale_factor_sigma=un.accel_scale_factor,
                      accel_misalignment_sigma_rad=un.accel_misalignment_rad)
    gyro_prior = np.sqrt(noise.gyro_bias_sigma_rad_s ** 2 + extra[:3])
    accel_prior = np.sqrt(noise.accel_bias_sigma_m_s2 ** 2 + extra[3:])
    record["gyro_bias_prior_told_rad_s_body"] = [float(x) for x in gyro_prior]
    record["accel_bias_prior_told_m_s2_body"] = [float(x) for x in accel_prior]
    return FilterModel(noise, pos, np.asarray(g.velocity_sigma_m_s, dtype=np.float64), record, extra, un, fix_errors)


def _prior(settings: AidingSettings, alignment_result):
    g = settings.gnss
    pos = np.sqrt(np.asarray(g.position_sigma_m) ** 2 + np.asarray(g.markov_sigma_m) ** 2)
    vel = np.asarray(g.velocity_sigma_m_s)
    if alignment_result is None:
        return pos, vel, TRUTH_START_TILT_RAD, TRUTH_START_HEADING_RAD
    s = np.asarray(alignment_result.sigma_rad, dtype=np.float64)
    return pos, vel, float(max(s[0], s[1])), float(s[2])


class AidedMission:
    """The engine's side of the aiding: the fix schedule and values, one :class:`AidedRun` per filter.

    Parameters
    ----------
    settings : AidingSettings
    noise_settings : AlignmentSettings
        The unit's noise numbers (``navigation.alignment``; :func:`~sins_sim.simulation.aligning.filter_noise`).
    fs : float
        Filter rate (Hz): the truth rows are ``j / fs``.
    n_sub : int
        Filter samples per navigation update.
    duration_s : float
    seed : int
    compensation : callable(name) -> (coning, sculling)
        The navigators' compensation per filter.
    sensors : SensorErrorParams or None
        The unit's sensor errors: their scale factors and misalignments enter the filter's process noise
        (:func:`filter_model`).
    vehicle : trajectory or None
        The vehicle (its rates and specific forces, for the same).
    """

    def __init__(self, settings: AidingSettings, noise_settings, fs, n_sub, duration_s, seed, compensation,
                 sensors=None, vehicle=None):
        from sins_sim.navigation.gnss import gnss_errors
        from sins_sim.simulation.aligning import filter_noise

        self.settings = settings
        self.noise = filter_noise(noise_settings)
        self.sensors, self.vehicle = sensors, vehicle
        self._models = {}
        self.fs, self.n_sub, self.duration_s = float(fs), int(n_sub), float(duration_s)
        self.compensation = compensation
        g = settings.gnss
        if settings.file is None:
            step = int(round(self.fs / g.rate_hz))          # truth rows per fix (checked at load: whole)
            grid_j = np.arange(0, int(math.floor(duration_s * fs + 1e-9)) + 1, step)
            self._errors = gnss_errors(g, grid_j.shape[0], np.random.default_rng([int(seed), GNSS_STREAM]))
            keep = ~g.in_outage(grid_j / self.fs)
            keep[np.arange(grid_j.shape[0]) % settings.decimation != 0] = False
            self._grid_j = grid_j
            self._keep = keep
            self.t_valid_s = grid_j[keep] / self.fs
        else:
            f = settings.file
            keep = ~g.in_outage(f.t_s)
            keep[np.arange(len(f)) % settings.decimation != 0] = False
            self._keep = keep
            self.t_valid_s = f.t_s[keep]
        self.t_deliver_s = self.t_valid_s + g.latency_s
        self._next = 0                    # next grid (or file) row to turn into a fix
        self.parts = []                   # GnssFixes in schedule order
        self.outages_s = tuple(g.outages_s)

    # --- fixes --------------------------------------------------------------------------------------------------

    def make_fixes(self, tr_buf):
        """Fixes whose truth rows have arrived (``tr_buf``: the engine's truth rings); returns the new part."""
        from sins_sim.navigation.gnss import GnssFixes, fixes_from_truth

        g = self.settings.gnss
        if self.settings.file is not None:
            if self._next:
                return None
            f = self.settings.file
            k = self._keep
            v = f.v_ned_m_s[k] if f.v_ned_m_s is not None else np.zeros((int(k.sum()), 3))
            part = GnssFixes(t_valid_s=f.t_s[k], t_deliver_s=f.t_s[k] + g.latency_s, lat_rad=f.lat_rad[k],
                             lon_rad=f.lon_rad[k], h_m=f.h_m[k], v_ned_m_s=v,
                             position_error_ned_m=np.full((int(k.sum()), 3), np.nan),
                             velocity_error_ned_m_s=np.full((int(k.sum()), 3), np.nan),
                             position_sigma_m=np.asarray(g.position_sigma_m),
                             velocity_sigma_m_s=np.asarray(g.velocity_sigma_m_s),
                             lever_arm_b_m=np.asarray(g.lever_arm_b_m))
            self._next = len(f)
            self.parts.append(part)
            return part
        end = tr_buf["q"].end
        lo = self._next
        hi = int(np.searchsorted(self._grid_j, end))     # grid rows with truth index < end
        self._next = max(lo, hi)
        sel = np.arange(lo, hi)
        sel = sel[self._keep[lo:hi]]
        if sel.size == 0:
            return None
        j = self._grid_j[sel]
        base = tr_buf["q"].base
        if j[0] < base:  # pragma: no cover - the rings keep every row not yet made into a fix
            raise RuntimeError(f"the truth row {j[0]} of a GNSS fix was dropped before the fix was made")
        rows = {k: tr_buf[k].a[j - tr_buf[k].base] for k in ("lat", "lon", "h", "v", "q", "dth")}
        dr, dv = self._errors[0][sel], self._errors[1][sel]
        part = fixes_from_truth(j / self.fs, rows["lat"], rows["lon"], rows["h"], rows["v"], dr, dv, g,
                                q_nb=rows["q"], omega_ib_b_rad_s=rows["dth"] * self.fs)
        self.parts.append(part)
        return part

    @property
    def fixes_pending_from(self) -> int | None:
        """The first truth index a future fix needs (None: all made)."""
        if self.settings.file is not None or self._next >= self._grid_j.shape[0]:
            return None
        return int(self._grid_j[self._next])

    # --- one filter ---------------------------------------------------------------------------------------------

    def output_times(self, t0_s, t_end_s):
        """The run's epochs besides the updates: the start and the end, every :data:`OUTPUT_PERIOD_S` where no fix
        is applied for longer than that (the outages; the updates are epochs of their own), and the outage
        growth's times."""
        grid = np.arange(t0_s, t_end_s + 1e-9, OUTPUT_PERIOD_S)
        td = np.concatenate([[t0_s], np.sort(self.t_deliver_s), [np.inf]])
        k = np.searchsorted(td, grid, side="right")          # the last delivery at or before each grid time ...
        gap = td[np.minimum(k, td.size - 1)] - td[k - 1]     # ... and the gap it opens
        out = [t0_s, t_end_s] + list(grid[gap > OUTPUT_PERIOD_S * (1.0 + 1e-9)])
        big_t = self.n_sub / self.fs
        for start, _ in self.outages_s:
            before = np.flatnonzero(self.t_valid_s < start)
            if before.size == 0:
                continue
            ta = t0_s + math.ceil((self.t_deliver_s[before[-1]] - t0_s) / big_t - 1e-9) * big_t
            out += [ta + a for a in OUTAGE_AFTER_S]
        out = np.asarray(out)
        return np.unique(out[(out >= t0_s) & (out <= t_end_s + 1e-9)])

    def model(self, t0_s) -> FilterModel:
        """The filter's model over the aided span from ``t0_s`` to the mission's end (:func:`filter_model`), computed
        once per mission and shared by the filters (their own spans end a few samples earlier, by their group
        delays; one model keeps the comparison paired)."""
        key = round(float(t0_s), 9)
        if key not in self._models:
            self._models[key] = filter_model(self.settings, self.noise, self.sensors, self.vehicle, t0_s,
                                             self.duration_s)
        return self._models[key]

    def start_run(self, name, j0, n_increments, lat0, lon0, h0, v0, q0, alignment_result=None):
        """The :class:`AidedRun` of filter ``name`` starting at truth index ``j0`` (its fixes so far added)."""
        from sins_sim.navigation import ekf
        from sins_sim.navigation.aided import AidedRun

        t0 = j0 / self.fs
        g = self.settings.gnss
        t_end = (j0 + n_increments) / self.fs
        model = self.model(t0)
        pos, vel, tilt, heading = _prior(self.settings, alignment_result)
        p0 = model.initial_covariance(pos, vel, tilt, heading)
        start = ekf.NavState(t0, lat0, lon0, h0, np.asarray(v0, dtype=np.float64), np.asarray(q0, dtype=np.float64),
                             np.zeros(3), np.zeros(3))
        coning, sculling = self.compensation(name)
        run = AidedRun(t0, 1.0 / self.fs, n_increments, start, model.noise, p0, self.t_valid_s, self.t_deliver_s,
                       model.position_sigma_m, model.velocity_sigma_m_s, g.lever_arm_b_m,
                       output_t_s=self.output_times(t0, t_end), use=self.settings.measurements,
                       n_sub=self.n_sub, max_propagation_s=1.0 / self.settings.update_rate_hz,
                       feedback=self.settings.feedback, coning=coning, sculling=sculling, unmodelled=model.unmodelled,
                       fix_errors=model.fix_errors)
        for part in self.parts:
            run.add_fixes(part)
        return _FilterAided(run, len(self.parts), model)

    def feed(self, fa, dth, dv, tr_buf):
        """Feed a filter's increments (after adding the fixes made since) and keep the truth at its new epochs."""
        for part in self.parts[fa.parts_added:]:
            fa.run.add_fixes(part)
        fa.parts_added = len(self.parts)
        k = fa.run.n_epochs
        fa.run.feed(dth, dv)
        t = fa.run.epoch_times(k)
        if t.size:
            j = np.rint(t * self.fs).astype(np.int64)
            for key in ("lat", "lon", "h", "v", "q"):
                r = tr_buf[key]
                if j[0] < r.base:  # pragma: no cover - the rings keep the rows of the interval navigated
                    raise RuntimeError(f"the truth row {j[0]} of an aided epoch was dropped")
                fa.truth[key].append(r.a[j - r.base].copy())

    def finish(self, fa, records, name, gyro_bias_rad_s, accel_bias_m_s2) -> dict:
        """The filter's aided run, its errors, outage growth, smoother and consistency (the end of the run)."""
        from sins_sim.navigation.aided import outage_growth, smooth

        res = fa.run.result()
        tr = {k: np.concatenate(v) if v else np.zeros((0,)) for k, v in fa.truth.items()}
        n = len(res)
        tr = {k: x[:n] for k, x in tr.items()}
        errors = res.errors(tr["lat"], tr["lon"], tr["h"], tr["v"].reshape(n, 3), tr["q"].reshape(n, 4))
        growth = []
        for w in self.outages_s:
            try:
                growth += outage_growth(res, [w], OUTAGE_AFTER_S, errors=errors)
            except ValueError:  # no update before the outage (it starts before the first fix): nothing to read
                continue
        nees = nees_blocks(res, errors)
        smoothed = None
        if self.settings.smoother and n >= 2:
            sm = smooth(res)
            smoothed = {"errors": sm.errors(tr["lat"], tr["lon"], tr["h"], tr["v"].reshape(n, 3),
                                            tr["q"].reshape(n, 4)), "sigma": sm.sigma}
        empty = np.zeros((0, 15, 15))
        light = dataclasses.replace(res, phi=empty, p_pred=empty, p_upd=empty)
        return {"result": light, "errors": errors, "growth": growth, "nees": nees, "smoothed": smoothed,
                "filter_model": fa.model.record,
                "true_bias": true_biases(records, name, float(res.t_s[0]) if n else 0.0, gyro_bias_rad_s,
                                         accel_bias_m_s2),
                "unaided_bias_sigma": fa.run.unaided_bias_sigma}


class _FilterAided:
    """One filter's aided run and the truth at its epochs."""

    def __init__(self, run, parts_added, model):
        self.run = run
        self.model = model
        self.parts_added = parts_added
        self.truth = {k: [] for k in ("lat", "lon", "h", "v", "q")}


def nees_blocks(res, errors) -> dict:
    """Normalised estimation error squared per 3-state block at every epoch after its update:
    ``e^T P_block^-1 e`` with ``e`` the true error of the corrected solution (chi-square with 3 degrees of
    freedom for a consistent filter; Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4)."""
    out = {}
    for name, sl in (("position", slice(0, 3)), ("velocity", slice(3, 6)), ("attitude", slice(6, 9))):
        p = res.p_upd[:, sl, sl]
        e = errors[:, sl]
        ok = np.all(np.isfinite(e), axis=1) & (np.linalg.det(p) > 0.0)
        val = np.full(e.shape[0], np.nan)
        if np.any(ok):
            val[ok] = np.einsum("ki,ki->k", e[ok], np.linalg.solve(p[ok], e[ok][:, :, None])[:, :, 0])
        out[name] = val
    return out


def true_biases(records, name, t_from_s, gyro_bias_rad_s, accel_bias_m_s2) -> dict:
    """The biases a filter's increments carry (body axes).

    Gyros: the unit's own (fixed plus turn-on, as drawn for the run: ``gyro_bias_rad_s``) plus what the dither
    filter adds at DC, the least-squares slope of its gyro-angle error over ideal's (the engine's sensor-level
    records from ``t_from_s``; paired, so the unit's noise, scale factor and misalignment, common to both,
    cancel; a slope of the gyro record alone would carry the angle random walk's, 0.03 deg/h over 4 min at
    0.002 deg/sqrt(h)). Accelerometers (the same for every filter): the slope of their accumulated velocity-
    increment error over the same span, what a bias state absorbs: the bias plus the scale factor and the
    misalignments times the specific force (gravity, in level flight: 100 ppm of scale factor on the vertical
    axis reads as 98 ug); ``accel_bias_m_s2`` without a record. The bias instability's slow wander is not
    counted (its flat Allan floor is in the filter's prior)."""
    gyro = np.asarray(gyro_bias_rad_s, dtype=np.float64).copy()
    accel = np.asarray(accel_bias_m_s2, dtype=np.float64).copy()
    if records and "t_s" in records:
        t = records["t_s"]
        sel = t >= t_from_s
        if np.count_nonzero(sel) >= 3:
            tt = t[sel] - t[sel][0]
            if name != "ideal" and name in records and "ideal" in records:
                gyro += np.polyfit(tt, records[name][sel] - records["ideal"][sel], 1)[0]
            if "accelerometers" in records:
                accel = np.polyfit(tt, records["accelerometers"][sel], 1)[0]
    return {"gyro_rad_s": gyro, "accel_m_s2": np.asarray(accel)}
