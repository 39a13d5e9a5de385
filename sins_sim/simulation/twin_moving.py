"""A unit's twin beside a moving log: both navigated on the known trajectory, their errors against it.

The mission of a log on a known trajectory (:func:`truth_run`), run alike on the log and on each seed of the twin:
free strapdown navigation (:class:`sins_sim.navigation.strapdown.StrapdownNavigator`) from the truth's own state
one interval before the first increment (position, velocity, attitude: no alignment on a moving log), the height
aided by the truth's, and at each kept time its error against the truth: north and east position along the
surface (:func:`sins_sim.earth.horizontal_error_m`), the NED velocity error, and the attitude error ``psi`` about
north, east, down (:func:`sins_sim.navigation.attitude.attitude_error`, ``C_nb_est = (I + [psi x]) C_nb_true``;
Titterton and Weston 2004, ch. 12).

The twin (:func:`twin_increments_on`) is simulated at the log's own level: the truth's exact increments
(:func:`sins_sim.simulation.external.ideal_increments`) with the twin's ``sensors:`` errors applied
(:class:`sins_sim.models.sensor_errors.GyroErrors`, :class:`~sins_sim.models.sensor_errors.AccelErrors`; the
model ``x_meas = x_true + b dt + (S + M) x_true + n`` of Groves 2013, sec. 4.4.6), then the readout's pulses
(:func:`sins_sim.simulation.twin.quantise_pulses`) where the log has them.

Beside the navigation, each run keeps the Allan deviation (:func:`sins_sim.navigation.allan.allan_deviation`) and the
spectral lines (:func:`sins_sim.navigation.spectral_lines.find_lines`) of its **residual**: its increments less the
twin's deterministic increments ``x_true + b dt + E x_true`` (the fit against the truth), as a rate and specific
force. On a moving log the raw record is the motion; the residual is the unit's noise and whatever the twin does not
model, and the twin's residual (its seeds less the same deterministic part) is its noise alone, so the two are
compared as at rest (:func:`sins_sim.identification.twin_gap.localise`). Each seed's deterministic part is best its
own fit against the truth, as the log's is (``expected`` a callable): the fit's error then leaves the same trace in
both residuals (a line at the motion's frequency of the size of the fitted terms' error, less power at the longest
taus where the fit takes the residual's projection out).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["MovingRun", "residual_analyses", "truth_run", "twin_increments_on", "twin_runs_on"]

#: Rows of the navigation error kept per second (at most; every row of a slower log).
KEEP_RATE_HZ = 10.0
#: Rows navigated per call of the navigator.
CHUNK_ROWS = 65536


@dataclass
class MovingRun:
    """One run of the mission on a known trajectory (module docstring).

    Attributes
    ----------
    nav_t_s : ndarray
        Times of the kept rows from the start of navigation (s).
    nav : dict
        ``position_m`` (M, 3) north, east, down error (the down error is the height aid's residue);
        ``velocity_m_s`` (M, 3) NED error; ``attitude_rad`` (M, 3) attitude error about north, east, down.
    allan : dict
        ``(sensor, axis) -> AllanCurve`` of the residual (empty without the deterministic part).
    lines : dict
        ``(sensor, axis) -> LineSearch`` of the residual (empty without the deterministic part).
    """

    nav_t_s: np.ndarray
    nav: dict = field(default_factory=dict)
    allan: dict = field(default_factory=dict)
    lines: dict = field(default_factory=dict)


def residual_analyses(dth, dv, expected, dt_s: float, false_alarm: float) -> tuple:
    """``(allan, lines)`` of the residual ``(dth, dv) - expected`` over ``dt_s`` (rad/s, m/s^2), per sensor axis,
    each axis less its mean (as :func:`sins_sim.simulation.twin.rest_run` reads a record at rest).

    Parameters
    ----------
    dth, dv : ndarray (N, 3)
        The increments.
    expected : ndarray (N, 6) or callable
        The deterministic increments (angle, velocity) they are read against, or ``expected(dth, dv) -> (N, 6)``
        (e.g. the record's own fit against the truth, so that a twin's residual is made as the log's is).
    false_alarm : float
        Per channel, the chance of one or more false lines.
    """
    from sins_sim.navigation.allan import allan_deviation
    from sins_sim.navigation.spectral_lines import find_lines

    if callable(expected):
        expected = expected(dth, dv)
    resid = (np.hstack([np.asarray(dth, dtype=np.float64), np.asarray(dv, dtype=np.float64)])
             - np.asarray(expected, dtype=np.float64)) / dt_s
    allan, lines = {}, {}
    for ch in range(6):
        key = ("gyro" if ch < 3 else "accelerometer", "xyz"[ch % 3])
        col = resid[:, ch] - resid[:, ch].mean()
        allan[key] = allan_deviation(col, 1.0 / dt_s)
        lines[key] = find_lines(col, 1.0 / dt_s, false_alarm=false_alarm, increment_dt=dt_s)
    return allan, lines


def truth_run(t_s, dth, dv, truth, expected=None, false_alarm: float = 0.01 / 6.0) -> MovingRun:
    """Navigate increments from the truth's state at ``t_s[0] - dt`` and keep their errors against it; with
    ``expected`` (N, 6), the residual's analyses too (:func:`residual_analyses`, at ``false_alarm``).

    Parameters
    ----------
    t_s : ndarray (N,)
        End time of each interval on the truth's time axis (s), evenly spaced.
    dth, dv : ndarray (N, 3)
        Angle (rad) and velocity (m/s) increments, body axes.
    truth : object with ``evaluate(t)``
        The trajectory (:class:`~sins_sim.models.motion.SampledTrajectory`), covering ``t_s[0] - dt`` to
        ``t_s[-1]``.
    """
    from sins_sim.earth import horizontal_error_m
    from sins_sim.navigation.attitude import attitude_error
    from sins_sim.navigation.strapdown import StrapdownNavigator

    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    n = t.size
    t0 = max(float(t[0] - dt), 0.0)   # a first increment from the truth's start: t[0] - dt is 0 to rounding
    first = truth.evaluate(np.array([t0]))
    nav = StrapdownNavigator(first.lat_rad[0], first.lon_rad[0], first.h_m[0], first.v_ned_m_s[0], first.q_nv[0],
                             dt, vertical="height_aid")
    every = max(1, int(round(1.0 / (dt * min(KEEP_RATE_HZ, 1.0 / dt)))))
    kept = {"t": [], "pos": [], "vel": [], "att": []}
    dth = np.asarray(dth, dtype=np.float64)
    dv = np.asarray(dv, dtype=np.float64)
    for lo in range(0, n, CHUNK_ROWS):
        hi = min(n, lo + CHUNK_ROWS)
        tr = truth.evaluate(t[lo:hi])
        sol = nav.process(dth[lo:hi], dv[lo:hi], np.asarray(tr.h_m, dtype=np.float64))
        k = np.arange(lo, hi)
        sel = ((k + 1) % every == 0) | (k == n - 1)
        dn, de, _ = horizontal_error_m(sol.lat_rad[sel], sol.lon_rad[sel], tr.lat_rad[sel], tr.lon_rad[sel],
                                       tr.h_m[sel])
        kept["t"].append(t[lo:hi][sel] - t0)
        kept["pos"].append(np.column_stack([dn, de, -(sol.h_m[sel] - tr.h_m[sel])]))
        kept["vel"].append(np.asarray(sol.v_ned_m_s)[sel] - np.asarray(tr.v_ned_m_s)[sel])
        kept["att"].append(attitude_error(np.asarray(sol.q_nb)[sel], np.asarray(tr.q_nv)[sel]))
    allan, lines = ({}, {}) if expected is None else residual_analyses(dth, dv, expected, dt, false_alarm)
    return MovingRun(np.concatenate(kept["t"]), {"position_m": np.concatenate(kept["pos"]),
                                                 "velocity_m_s": np.concatenate(kept["vel"]),
                                                 "attitude_rad": np.concatenate(kept["att"])}, allan, lines)


def twin_increments_on(sensors, ideal_dth, ideal_dv, dt_s: float, seed: int, pulses=None, added=None) -> tuple:
    """``(dtheta, dv)`` of the twin on a trajectory: the exact increments ``ideal_dth``, ``ideal_dv`` (N, 3) with
    the errors ``sensors`` (:class:`~sins_sim.models.sensor_errors.SensorErrorParams`) applied with ``seed``, then,
    with ``pulses`` (:class:`~sins_sim.simulation.twin.PulseWeights`), the readout's quantisation (its residues
    drawn after the errors from the same seed, as :func:`sins_sim.simulation.twin.twin_increments`); ``added``
    (N, 6) rate and specific force (a candidate effect) enters before the quantisation."""
    from sins_sim.simulation.twin import sensed_increments

    return sensed_increments(sensors, ideal_dth, ideal_dv, dt_s, seed, pulses, added)


def twin_runs_on(sensors, t_s, ideal_dth, ideal_dv, truth, seeds, *, pulses=None, added=None, expected=None,
                 false_alarm: float = 0.01 / 6.0) -> list:
    """:func:`truth_run` on the twin (:func:`twin_increments_on`, with ``added`` (N, 6) rate and specific force)
    once per seed, on the log's time axis ``t_s`` (the truth's); with ``expected``, the residual's analyses."""
    from sins_sim.simulation.twin import checked_added

    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    added = checked_added(added, t.size)
    runs = []
    for seed in seeds:
        dth, dv = twin_increments_on(sensors, ideal_dth, ideal_dv, dt, int(seed), pulses, added)
        runs.append(truth_run(t, dth, dv, truth, expected, false_alarm))
    return runs
