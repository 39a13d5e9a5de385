"""Navigation of external increments: angle and velocity increments from elsewhere against a known truth.

Increments from another simulator or a logged IMU run through the same strapdown navigator and the same
error bookkeeping as a ``sins-sim run`` filter (:class:`~sins_sim.simulation.metrics.ErrorSeries`,
:class:`~sins_sim.simulation.metrics.NavErrorStats`, the sampled gyro-angle error records behind the
gyro drift and the Allan terms), so :func:`sins_sim.jobs.run.scenario_metrics` reads the result as it
reads a run's.

Conventions: increment ``i`` is the integral over ``(t_i - dt, t_i]`` of the body angular rate with
respect to inertial space (``dtheta``, rad) and of the specific force (``dv``, m/s), body = the vehicle
frame of the truth, raw (no coning or sculling compensation: the navigator applies its own). The sample
period ``dt`` is the time column's (uniform). Navigation starts aligned to the truth at ``t_0 - dt``.

.. autosummary::

   ideal_increments
   navigate_increments
   ExternalNavResult
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import truth as ktruth
from sins_sim.simulation.metrics import N_COLS, ErrorSeries, NavErrorStats

__all__ = ["ideal_increments", "navigate_increments", "navigate_free", "ExternalNavResult", "FreeNavResult", "GAUSS_NODES",
           "uniform_period"]

#: 3-point Gauss-Legendre nodes and weights on [0, 1] (Abramowitz & Stegun 25.4.29): exact for
#: polynomials of degree 5, so the ideal increments of a smooth truth are exact to (rate h)^6.
GAUSS_NODES = np.array([0.5 - math.sqrt(0.15), 0.5, 0.5 + math.sqrt(0.15)])
GAUSS_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 18.0
#: relative spread of the time steps still taken as uniform sampling
UNIFORM_TOLERANCE = 1e-6
#: rows navigated per chunk (memory does not grow with the record's length)
CHUNK_ROWS = 65536
#: stored error series: at most this rate (Hz) and this many blocks (as a run's default)
SERIES_RATE_HZ = 10.0
MAX_SERIES_BLOCKS = 7200
#: the gyro-angle error record behind the drift and Allan terms: at most this rate (Hz), this many samples
RECORD_RATE_HZ = 100.0
#: Largest body rate (rad/s) an angle increment may show: the input range of navigation-grade RLGs is +-400 to
#: +-1000 deg/s (the scenarios' block-rate bound, sins_sim.config.scenario.MAX_RATE_DEG_S, is the same).
MAX_RATE_RAD_S = math.radians(1000.0)
#: Largest specific force (m/s^2) a velocity increment may show: 2000 m/s^2, about 200 g, the scenarios' bound on
#: any acceleration (sins_sim.config.scenario.MAX_ACCEL_M_S2); navigation accelerometers measure 30-100 g.
MAX_SPECIFIC_FORCE_M_S2 = 2000.0
MAX_RECORD_SAMPLES = 2 ** 17


def uniform_period(t_s, owner: str = "time_s") -> float:
    """The sample period (s) of strictly increasing, uniformly spaced times; ValueError naming ``owner`` else."""
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"{owner}: needs at least 2 samples, got {t.size}")
    d = np.diff(t)
    if not np.all(d > 0.0):
        i = int(np.flatnonzero(~(d > 0.0))[0])
        raise ValueError(f"{owner}: must be strictly increasing (row {i + 1} is not after row {i})")
    dt = float((t[-1] - t[0]) / (t.size - 1))
    worst = int(np.argmax(np.abs(d - dt)))
    if abs(d[worst] - dt) > UNIFORM_TOLERANCE * dt + 1e-12:
        raise ValueError(f"{owner}: must be uniformly sampled (mean step {dt:.9g} s, step after row {worst} is "
                         f"{d[worst]:.9g} s); resample the increments to a constant rate")
    return dt


def _evaluator(truth):
    """A forward evaluator of ``truth`` (its ``stream()`` where it has one: a segment trajectory streams)."""
    return truth.stream() if hasattr(truth, "stream") else truth


def _node_times(t_end, dt):
    """Gauss nodes of each interval ``(t - dt, t]`` then its end, in time order: ``(n, 4)`` flattened."""
    t0 = t_end - dt
    return np.concatenate((t0[:, None] + dt * GAUSS_NODES[None, :], t_end[:, None]), axis=1).ravel()


def ideal_increments(truth, t_s):
    """The increments an ideal IMU riding the truth outputs over ``(t_i - dt, t_i]``: ``(dtheta, dv)``.

    ``dtheta = int omega_iv^v dt`` and ``dv = int f^v dt`` (vehicle axes) by 3-point Gauss-Legendre
    quadrature per interval (:data:`GAUSS_NODES`), the sensors' own definition of an increment.

    Parameters
    ----------
    truth : object with ``evaluate(t)``
        A trajectory (:class:`~sins_sim.models.motion.Trajectory`,
        :class:`~sins_sim.models.motion.SampledTrajectory`) on its own time axis.
    t_s : array_like (N,)
        End times of the increments (s), uniformly spaced, ``t_0 - dt >= 0``.

    Returns
    -------
    dtheta : ndarray (N, 3)
        rad.
    dv : ndarray (N, 3)
        m/s.
    """
    t = np.asarray(t_s, dtype=np.float64)
    dt = uniform_period(t)
    ev = _evaluator(truth)
    dth, dvel = np.empty((t.size, 3)), np.empty((t.size, 3))
    for lo in range(0, t.size, CHUNK_ROWS):
        hi = min(t.size, lo + CHUNK_ROWS)
        tr = ev.evaluate(_node_times(t[lo:hi], dt))
        dth[lo:hi] = _quadrature(tr.omega_iv_v_rad_s, dt)
        dvel[lo:hi] = _quadrature(tr.f_v_m_s2, dt)
    return dth, dvel


def _quadrature(values, dt):
    x = np.asarray(values).reshape(-1, 4, 3)[:, :3, :]
    return dt * np.einsum("k,nkj->nj", GAUSS_WEIGHTS, x)


@dataclass
class ExternalNavResult:
    """The navigation of external increments, with the attributes :func:`sins_sim.jobs.run.scenario_metrics`
    reads from a :class:`~sins_sim.simulation.sins.SinsResult` (one "filter", named ``name``).

    Attributes
    ----------
    filters : tuple of str
        ``(name,)``.
    stats, series, diverged : dict name -> ...
        Full-rate error statistics, stored error series (block means with their envelopes), and the
        divergence record if the solution left the truth by more than 0.5 rad, 7.91 km/s or 6371 km, or stopped
        being finite (:func:`sins_sim.simulation.sins.divergence_reason`).
    truth_series : dict
        The truth's ``t_s, lat_rad, lon_rad, h_m`` at the stored rate.
    records : dict
        ``t_s``, ``rate_hz``, ``speed_m_s`` and per name the accumulated gyro-angle error (increments minus
        the ideal ones, body axes, rad), and ``accelerometers`` the accumulated velocity-increment error (m/s).
    allan : dict
        The Allan analyses of those records (as a run's).
    duration_s, nav_start_s, dt_s : float
        End of the last increment, start of the navigation (both on the truth's time axis) and the period.
    """

    filters: tuple
    stats: dict
    series: dict
    truth_series: dict
    records: dict
    allan: dict
    diverged: dict
    duration_s: float
    nav_start_s: float
    dt_s: float
    settings: dict = field(default_factory=dict)


def _check_physical(dth: np.ndarray, dvel: np.ndarray, dt: float) -> None:
    """Refuse increments no IMU measures: a body rate beyond :data:`MAX_RATE_RAD_S` or a specific force beyond
    :data:`MAX_SPECIFIC_FORCE_M_S2` over one interval (another unit, deg for rad, or a corrupted value); the
    message names the element ``dtheta[i, j]`` or ``dv[i, j]``."""
    for label, arr, limit, shown, what in (
            ("dtheta", dth, MAX_RATE_RAD_S, lambda x: f"{math.degrees(x):.4g} deg/s", "the 1000 deg/s an RLG measures"),
            ("dv", dvel, MAX_SPECIFIC_FORCE_M_S2, lambda x: f"{x:.4g} m/s^2",
             "2000 m/s^2 (about 200 g; navigation accelerometers measure 30-100 g)")):
        if arr.size and float(np.max(np.abs(arr))) > limit * dt:
            i, j = np.unravel_index(int(np.argmax(np.abs(arr))), arr.shape)
            raise ValueError(f"{label}[{i}, {j}]: {float(arr[i, j]):.4g} in one {dt:.4g} s interval is "
                             f"{shown(abs(float(arr[i, j])) / dt)}, beyond {what} (another unit or a corrupted "
                             "value?)")


def _checked_increments(t_s, dtheta, dv) -> tuple:
    """``(t, dt, dtheta, dv)``: finite, uniformly spaced times, one (3,) row of each per time, physical values;
    a ValueError naming ``t_s``, ``dtheta`` or ``dv`` otherwise."""
    t = v.finite_array("", "t_s", t_s, ndim=1)
    dt = uniform_period(t, "t_s")
    n = t.size
    dth = v.finite_array("", "dtheta", dtheta, ndim=2)
    dvel = v.finite_array("", "dv", dv, ndim=2)
    for label, arr in (("dtheta", dth), ("dv", dvel)):
        if arr.shape != (n, 3):
            raise ValueError(f"{label}: must have shape ({n}, 3) (one row per time), got {arr.shape}")
    _check_physical(dth, dvel, dt)
    return t, dt, dth, dvel


def navigate_increments(t_s, dtheta, dv, truth, *, name: str = "external", coning: str = "two_sample",
                        sculling: str = "two_sample", vertical: str = "height_aid",
                        height_aid_tau_s: float = 100.0, q0_nb=None, v0_ned_m_s=None) -> ExternalNavResult:
    """Navigate given increments against a truth and keep the errors as a run keeps them.

    Parameters
    ----------
    t_s : array_like (N,)
        End time of each increment on the truth's time axis (s), uniformly spaced; navigation starts at
        ``t_0 - dt`` (>= 0), aligned to the truth there.
    dtheta : array_like (N, 3)
        Angle increments (rad), body axes, raw.
    dv : array_like (N, 3)
        Velocity increments (m/s), body axes, raw.
    truth : object with ``evaluate(t)`` (and optionally ``stream()``)
        The trajectory the increments were taken along (:class:`~sins_sim.models.motion.SampledTrajectory`,
        :class:`~sins_sim.models.motion.Trajectory`); its ``duration_s`` must cover ``t_{N-1}``.
    name : str
        The name the result goes under (the "filter" of the metrics).
    coning, sculling : {"none", "two_sample", "three_sample", "four_sample"}
    vertical : {"height_aid", "free"}
        Vertical channel: aided by the truth's height (a run's default) or free.
    height_aid_tau_s : float
    q0_nb, v0_ned_m_s : array_like, optional
        The starting attitude (body to NED) and velocity instead of the truth's at ``t_0 - dt``: an
        alignment's result (the errors against the truth then include the alignment's own).

    Returns
    -------
    ExternalNavResult

    Raises
    ------
    ValueError
        Shapes, non-finite values, non-uniform or decreasing times, a start before the truth's or an end
        after it, a rate beyond 1000 deg/s or a specific force beyond 2000 m/s^2 in an increment; the message
        names the argument.
    """
    from sins_sim.navigation.strapdown import StrapdownNavigator
    from sins_sim._kernels.strapdown import OUT_H, OUT_LAT, OUT_LON, OUT_Q, OUT_V
    from sins_sim.simulation.sins import (DIVERGED_ATTITUDE_RAD, DIVERGED_POSITION_M, DIVERGED_VELOCITY_M_S,
                                          _allan_analyses, _error_records, divergence_reason)

    t, dt, dth, dvel = _checked_increments(t_s, dtheta, dv)
    n = t.size
    t_start = float(t[0] - dt)
    end = float(getattr(truth, "duration_s", math.inf))
    if t_start < -1e-9:  # a first increment from the truth's start computes t[0] - dt to within rounding of 0
        raise ValueError(f"t_s: the first increment starts at {t_start:.6g} s, before the truth's start (0 s)")
    t_start = max(t_start, 0.0)
    if t[-1] > end + 1e-9:
        raise ValueError(f"t_s: the last increment ends at {t[-1]:.6g} s, after the truth's end ({end:.6g} s)")

    ev = _evaluator(truth)
    first = ev.evaluate(np.array([t_start]))
    nav = StrapdownNavigator(first.lat_rad[0], first.lon_rad[0], first.h_m[0],
                             first.v_ned_m_s[0] if v0_ned_m_s is None else v0_ned_m_s,
                             first.q_nv[0] if q0_nb is None else q0_nb, dt, coning=coning, sculling=sculling,
                             vertical=vertical, height_aid_tau_s=height_aid_tau_s)
    series_rate = min(SERIES_RATE_HZ, MAX_SERIES_BLOCKS / (t[-1] - t_start), 1.0 / dt)
    every = max(1, int(round(1.0 / (dt * series_rate))))
    record_rate = min(RECORD_RATE_HZ, MAX_RECORD_SAMPLES / (t[-1] - t_start), 1.0 / dt)
    stride = max(1, int(round(1.0 / (dt * record_rate))))
    stats, ser = NavErrorStats(), ErrorSeries(every, dt, t_start)
    free = np.zeros(6)
    gcum, acum = np.zeros(3), np.zeros(3)
    rec = {name: [], "accelerometers": [], "velocity_ned_m_s": []}
    truth_rows = {"t_s": [], "lat_rad": [], "lon_rad": [], "h_m": []}
    diverged = {}
    for lo in range(0, n, CHUNK_ROWS):
        hi = min(n, lo + CHUNK_ROWS)
        tr = ev.evaluate(_node_times(t[lo:hi], dt))
        ends = slice(3, None, 4)
        g_err = np.cumsum(dth[lo:hi] - _quadrature(tr.omega_iv_v_rad_s, dt), axis=0) + gcum
        a_err = np.cumsum(dvel[lo:hi] - _quadrature(tr.f_v_m_s2, dt), axis=0) + acum
        gcum, acum = g_err[-1].copy(), a_err[-1].copy()
        lat_t, lon_t, h_t = tr.lat_rad[ends], tr.lon_rad[ends], tr.h_m[ends]
        v_t, q_t = tr.v_ned_m_s[ends], tr.q_nv[ends]
        # records every `stride` samples (sample k of the whole record at index lo + j)
        k = np.arange(lo, hi)
        keep = (k + 1) % stride == 0
        rec[name].append(g_err[keep])
        rec["accelerometers"].append(a_err[keep])
        rec["velocity_ned_m_s"].append(v_t[keep].copy())  # _error_records smooths it to a speed
        keep_t = (k + 1) % every == 0
        truth_rows["t_s"].append(t[lo:hi][keep_t])
        for key, arr in (("lat_rad", lat_t), ("lon_rad", lon_t), ("h_m", h_t)):
            truth_rows[key].append(arr[keep_t])
        if diverged:
            continue
        out = nav._run(np.ascontiguousarray(dth[lo:hi]), np.ascontiguousarray(dvel[lo:hi]),
                       np.ascontiguousarray(h_t) if vertical == "height_aid" else np.empty(0))
        scales = np.empty((hi - lo, 3))
        ktruth.surface_scales(lat_t, h_t, scales)
        rows = np.empty((hi - lo, N_COLS))
        bad = ktruth.nav_errors(out[:, OUT_LAT], out[:, OUT_LON], out[:, OUT_H], out[:, OUT_V:OUT_V + 3],
                                out[:, OUT_Q:OUT_Q + 4], lat_t, lon_t, h_t, scales, np.ascontiguousarray(v_t),
                                np.ascontiguousarray(q_t), g_err, free, DIVERGED_ATTITUDE_RAD, DIVERGED_VELOCITY_M_S,
                                DIVERGED_POSITION_M, rows)
        rows[:, 10] = out[:, OUT_LAT]
        rows[:, 11] = out[:, OUT_LON]
        if bad >= 0:
            diverged[name] = {"axis": "-", "time_s": float(t[lo + bad]), "reason": divergence_reason(rows[bad])}
            rows = rows[:bad]
        stats.add(rows, t[lo:lo + rows.shape[0]])
        ser.add(rows)
    records = _error_records(rec, 1.0 / (dt * stride), t_start + dt * stride, diverged)
    return ExternalNavResult(
        filters=(name,), stats={name: stats}, series={name: ser.arrays()},
        truth_series={k: np.concatenate(x) for k, x in truth_rows.items()}, records=records,
        allan=_allan_analyses(records, diverged), diverged=diverged, duration_s=float(t[-1]), nav_start_s=t_start,
        dt_s=dt, settings={"coning": coning, "sculling": sculling, "vertical": vertical,
                           "height_aid_tau_s": height_aid_tau_s, "rate_hz": 1.0 / dt})


@dataclass
class FreeNavResult:
    """The navigation of increments with no truth beside them (a real unit's log): the solution itself.

    Attributes
    ----------
    solution : NavSolution
        The solution's rows at up to :data:`SERIES_RATE_HZ` (:class:`~sins_sim.navigation.strapdown.NavSolution`;
        its ``t_s`` here on the log's time axis).
    start : dict
        ``t_s``, ``lat_rad``, ``lon_rad``, ``h_m``: where the navigation started.
    settings : dict
        Coning, sculling, vertical channel (and the height it held), rate.
    """

    solution: object
    start: dict
    settings: dict = field(default_factory=dict)

    def displacement_m(self) -> np.ndarray:
        """North, east, up displacement from the start (m, (M, 3)): along the surface at the start's radii
        (:func:`sins_sim.earth.horizontal_error_m`). For a unit that stood still it is the navigation error."""
        from sins_sim import earth

        s, sol = self.start, self.solution
        dn, de, _ = earth.horizontal_error_m(sol.lat_rad, sol.lon_rad, s["lat_rad"], s["lon_rad"], s["h_m"])
        return np.column_stack((dn, de, sol.h_m - s["h_m"]))


def navigate_free(t_s, dtheta, dv, lat0_rad, lon0_rad, h0_m, q0_nb, v0_ned_m_s, *, coning: str = "two_sample",
                  sculling: str = "two_sample", vertical: str = "height_aid", height_aid_tau_s: float = 100.0
                  ) -> FreeNavResult:
    """Navigate increments from a given start with no truth: the solution at up to :data:`SERIES_RATE_HZ`.

    ``vertical="height_aid"`` holds the start height (a unit at rest or on level ground: say so where the
    result is reported); ``"free"`` is pure inertial. Times, shapes and chunking as :func:`navigate_increments`
    (navigation starts at ``t_0 - dt``).
    """
    from sins_sim.navigation.strapdown import NavSolution, StrapdownNavigator

    t, dt, dth, dvel = _checked_increments(t_s, dtheta, dv)
    n = t.size
    nav = StrapdownNavigator(lat0_rad, lon0_rad, h0_m, v0_ned_m_s, q0_nb, dt, coning=coning, sculling=sculling,
                             vertical=vertical, height_aid_tau_s=height_aid_tau_s)
    every = max(1, int(round(1.0 / (dt * min(SERIES_RATE_HZ, 1.0 / dt)))))
    keep = {"t_s": [], "lat_rad": [], "lon_rad": [], "h_m": [], "v_ned_m_s": [], "q_nb": []}
    for lo in range(0, n, CHUNK_ROWS):
        hi = min(n, lo + CHUNK_ROWS)
        h_aid = np.full(hi - lo, float(h0_m)) if vertical == "height_aid" else None
        sol = nav.process(dth[lo:hi], dvel[lo:hi], h_aid)
        k = np.arange(lo, hi)
        sel = ((k + 1) % every == 0) | (k == n - 1)
        keep["t_s"].append(t[lo:hi][sel])
        for key in ("lat_rad", "lon_rad", "h_m", "v_ned_m_s", "q_nb"):
            keep[key].append(getattr(sol, key)[sel])
    arrays = {k: np.concatenate(x) for k, x in keep.items()}
    return FreeNavResult(NavSolution(**arrays), start={"t_s": float(t[0] - dt), "lat_rad": float(lat0_rad),
                                          "lon_rad": float(lon0_rad), "h_m": float(h0_m)},
                         settings={"coning": coning, "sculling": sculling, "vertical": vertical,
                                   "height_aid_tau_s": height_aid_tau_s, "rate_hz": 1.0 / dt,
                                   **({"height_held_m": float(h0_m)} if vertical == "height_aid" else {})})
