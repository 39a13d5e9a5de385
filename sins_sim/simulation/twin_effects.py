"""The twin at rest with candidate effects added: the deterministic part a candidate explains, on every seed.

A SINS-level candidate effect at rest (:mod:`sins_sim.identification.twin_explain`) is, in the log's own units, an
added rate (gyro axes) and specific force (accelerometer axes) ``p(t)`` per interval, the mean over each interval
of what the effect adds (a sway line's interval mean, a bias step, a ramp, a temperature term, the Earth's rate and
gravity over an interval that is longer or shorter than its nominal). Added to the twin it enters each seed's
increments as ``p dt`` (the increment of a rate is its interval mean times the interval;
Titterton and Weston 2004, sec. 11.2), on top of the twin's noise (:func:`sins_sim.simulation.twin.twin_increments`),
and the log's mission at rest is run on the sum (:func:`sins_sim.simulation.twin.rest_run`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["twin_runs_with"]


def twin_runs_with(sensors, t_s, site: dict, q_nb, method: str, seeds, added=None, pulses=None, **kwargs) -> list:
    """:func:`~sins_sim.simulation.twin.rest_run` on the twin plus the added rate and force, once per seed.

    Parameters
    ----------
    sensors : SensorErrorParams
        The twin's ``sensors:``.
    t_s : ndarray
        The log's time axis (N,), evenly spaced.
    site : dict
        ``lat_rad``, ``lon_rad``, ``height_m``.
    q_nb : array_like
        The log's aligned attitude (the twin's truth).
    method : str
        ``coarse`` or ``inertial``.
    seeds : iterable of int
        The twin's seeds (the same as the plain twin's, so that the comparison is paired).
    added : ndarray or None
        (N, 6) rate (rad/s, gyro x, y, z) and specific force (m/s^2, accelerometer x, y, z) added to every seed;
        None adds nothing. It enters before the readout's quantisation.
    pulses : PulseWeights or None
        The readout's pulse weights (:func:`sins_sim.simulation.twin.twin_increments`), as the plain twin has them.
    **kwargs
        Passed to :func:`~sins_sim.simulation.twin.rest_run`.

    Returns
    -------
    list of tuple
        ``(RestRun, values)`` per seed, ``values`` the (N, 6) rate and specific force the run was made on (what a
        scan of the twin's own record needs, e.g. for a bias step).

    Raises
    ------
    ValueError
        ``added`` not of shape (N, 6) or not finite.
    """
    from sins_sim.simulation.twin import checked_added, seed_runs

    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    added = checked_added(added, t.size)
    return [(run, np.hstack([dth, dv]) / dt)
            for run, dth, dv in seed_runs(sensors, t, site, q_nb, method, seeds, pulses=pulses, added=added, **kwargs)]
