"""GNSS-aided navigation over a whole record, the fixed-interval smoother and the outage error growth (issue 37).

:func:`navigate_aided` feeds a record of increments through the closed-loop error-state filter
(:class:`~sins_sim.navigation.ekf.AidedNavigator`) and applies GNSS fixes
(:class:`~sins_sim.navigation.gnss.GnssFixes`, loosely coupled: position and velocity of the antenna)
when they are delivered. :func:`smooth` runs the Rauch-Tung-Striebel smoother backwards over the
recorded filter; :func:`outage_growth` reads the error growth in each GNSS outage against the filter's
own prediction. ``docs/theory/kalman.md`` writes the equations out.

Latency. A fix valid at ``t_v`` and delivered at ``t_d = t_v + L`` is applied at the first navigation
update at or after ``t_d``, against the navigator's solution at ``t_v``: the run keeps the solution rows
of the last ``L + 2 T`` seconds, interpolated linearly to ``t_v`` (quaternions normalised; the
interpolation error is second order in the update period ``T``, ``a T^2 / 8`` in position), and every
feedback correction is applied to these stored rows as well, so they stay the corrected trajectory
carried back in time. The innovation is then ``h(x(t_v)) - z`` and the update corrects the current
error state with it. Approximation: the error state is taken as constant over the latency
(``Phi(t_d, t_v) = I``); what that neglects is the error's change over ``L``, ``dv L`` in position
(0.05 m/s x 0.2 s = 1 cm) and ``g psi L`` in velocity, both far below a GNSS fix's noise
(Groves 2013, sec. 3.3.4 "measurement time-of-validity"). ``latency="ignore"`` applies each fix as if it
were valid at its delivery (the naive way, for comparison).

Smoother (closed loop). The filter's reference is its own solution: after the update at epoch ``k`` the
error of the corrected solution ``N_k^+`` has estimate 0 and covariance ``P_k^+``; the navigator carries
``N_k^+`` to ``N_(k+1)^-`` whose error is ``Phi_k e_k^+ + w`` (estimate 0, covariance ``P_(k+1)^-``);
the update finds ``dx_(k+1) = K nu`` and feeds it back, ``N_(k+1)^+ = N_(k+1)^- - dx_(k+1)``. The
Rauch-Tung-Striebel recursion (Rauch, Tung & Striebel 1965; Groves 2013, sec. 3.4.2) in these
references, with ``s_k`` the smoothed estimate of the error of ``N_k^+``::

    C_k   = P_k^+ Phi_k^T (P_(k+1)^-)^-1
    s_k   = C_k (s_(k+1) + dx_(k+1)),                 s_K = 0 (the last epoch is the filter's)
    P_k^s = P_k^+ + C_k (P_(k+1)^s - P_(k+1)^-) C_k^T

and the smoothed solution is ``N_k^+`` corrected by ``s_k``. This is the open-loop (textbook) smoother
written in the closed loop's references: with the free navigator's error estimated by ``x``, the textbook
``S_k = x_k^+ + C_k (S_(k+1) - Phi_k x_k^+)`` becomes the recursion above for ``s_k = S_k - x_k^+`` with
``dx_(k+1) = x_(k+1)^+ - x_(k+1)^-``, so :func:`smooth` serves both (``feedback=False`` records that
``dx``). Closed and open loop agree to first order in the error (the closed loop linearises about a
better trajectory; Groves 2013, sec. 14.1.1); tested.

.. autosummary::

   navigate_aided
   AidedRun
   AidedResult
   smooth
   SmoothedResult
   outage_growth
   OutageGrowth

References
----------
.. [1] P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd
   ed., Artech House, 2013, sec. 3.3.4 (time of validity), 3.4.2 (smoothing), 14.1 (closed loop),
   14.3 (loosely coupled integration).
.. [2] H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear dynamic systems",
   AIAA Journal 3(8), 1445-1450, 1965.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral

import numpy as np

from sins_sim import _validate as v
from sins_sim import earth
from sins_sim._kernels import ekf as kekf
from sins_sim._kernels import ekf_epoch as kep
from sins_sim.navigation import ekf
from sins_sim.navigation.attitude import _increments, attitude_error, quat_from_rotvec, quat_multiply
from sins_sim.navigation.gnss import GnssFixes
from sins_sim.navigation.strapdown import NavSolution, StrapdownNavigator

__all__ = ["navigate_aided", "AidedRun", "AidedResult", "smooth", "SmoothedResult", "outage_growth", "OutageGrowth",
           "LATENCY_MODES", "GNSS_MEASUREMENTS"]

#: How a fix's latency is handled: against the solution at its time of validity, or ignored.
LATENCY_MODES = ("compensate", "ignore")
_ZERO3 = np.zeros(3)
#: The GNSS measurements :func:`navigate_aided` can apply.
GNSS_MEASUREMENTS = ("position", "velocity")


def _correct_rows(lat, lon, h, vel, q, dx):
    """Remove error states ``dx`` (one row or one per row) from solution rows: the inverse of the state's
    definition, :meth:`StrapdownNavigator.apply_correction` row by row (compiled, :func:`kekf.correct_rows`;
    :func:`_correct_rows_reference` is the numpy form it is tested against). Returns new arrays."""
    out = [np.array(a, dtype=np.float64) for a in (lat, lon, h, vel, q)]
    d = np.ascontiguousarray(np.asarray(dx, dtype=np.float64).reshape(-1, ekf.N_STATES))
    kekf.correct_rows(*out, d)
    return tuple(out)


def _correct_rows_reference(lat, lon, h, vel, q, dx):
    """:func:`_correct_rows` vectorised in numpy."""
    dx = np.broadcast_to(dx, (lat.shape[0], ekf.N_STATES))
    r_n, r_e = earth.radii(lat)
    lat_c = lat - dx[:, 0] / (r_n + h)
    lon_c = (lon - dx[:, 1] / ((r_e + h) * np.cos(lat)) + math.pi) % (2.0 * math.pi) - math.pi
    qc = quat_multiply(quat_from_rotvec(-dx[:, ekf.ATT]), q)
    return lat_c, lon_c, h + dx[:, 2], vel - dx[:, ekf.VEL], qc / np.linalg.norm(qc, axis=1, keepdims=True)


@dataclass(frozen=True)
class _Series(NavSolution):
    """A navigation solution at epochs (:class:`NavSolution`'s fields) with the bias estimates and the 1-sigma of
    its error states (15, then any fix-error states)."""

    gyro_bias_rad_s: np.ndarray
    accel_bias_m_s2: np.ndarray
    sigma: np.ndarray

    def errors(self, lat_rad, lon_rad, h_m, v_ned_m_s, q_nb) -> np.ndarray:
        """Errors of the solution against a truth given at :attr:`t_s`, in the filter's definition.

        Parameters
        ----------
        lat_rad, lon_rad, h_m : array_like, shape (K,)
            True IMU position.
        v_ned_m_s : array_like, shape (K, 3)
            True velocity (m/s).
        q_nb : array_like, shape (K, 4)
            True attitude body to NED.

        Returns
        -------
        ndarray, shape (K, 9)
            Position error NED (m), velocity error (m/s), attitude error psi (rad); computed minus true.
        """
        h = np.asarray(h_m, dtype=np.float64)
        k = len(self)
        for name, arr, shape in (("lat_rad", lat_rad, (k,)), ("lon_rad", lon_rad, (k,)), ("h_m", h, (k,)),
                                 ("v_ned_m_s", v_ned_m_s, (k, 3)), ("q_nb", q_nb, (k, 4))):
            if np.shape(arr) != shape:
                raise ValueError(f"{name}: must have shape {shape} (the truth at t_s), got {np.shape(arr)}")
        dn, de, _ = earth.horizontal_error_m(self.lat_rad, self.lon_rad, np.asarray(lat_rad), np.asarray(lon_rad), h)
        return np.column_stack([dn, de, -(self.h_m - h), self.v_ned_m_s - np.asarray(v_ned_m_s),
                                attitude_error(self.q_nb, np.asarray(q_nb, dtype=np.float64))])

    def to_pandas(self):
        """The epochs as a DataFrame indexed by ``t_s``: position, velocity, attitude quaternion, bias estimates
        and the 1-sigma of each error state (``sigma_`` + :data:`~sins_sim.navigation.ekf.STATE_NAMES`)."""
        import pandas as pd

        cols = {"lat_rad": self.lat_rad, "lon_rad": self.lon_rad, "h_m": self.h_m}
        for i, ax in enumerate("ned"):
            cols[f"v_{ax}_m_s"] = self.v_ned_m_s[:, i]
        for i in range(4):
            cols[f"q{i}"] = self.q_nb[:, i]
        for i, ax in enumerate("xyz"):
            cols[f"gyro_bias_{ax}_rad_s"] = self.gyro_bias_rad_s[:, i]
            cols[f"accel_bias_{ax}_m_s2"] = self.accel_bias_m_s2[:, i]
        for i, name in enumerate(ekf.STATE_NAMES):
            cols[f"sigma_{name}"] = self.sigma[:, i]
        cols.update(self._extra_columns())
        return pd.DataFrame(cols, index=pd.Index(self.t_s, name="t_s"))

    def _extra_columns(self) -> dict:
        return {}


@dataclass(frozen=True)
class AidedResult(_Series):
    """A GNSS-aided run (:func:`navigate_aided`): the solution at every epoch (fix applications and output
    times) after any update, and what the smoother and the outage analysis need.

    Attributes
    ----------
    t_s, lat_rad, lon_rad, h_m, v_ned_m_s, q_nb : ndarray
        The solution at the epochs (s, rad, m, m/s, body-to-NED quaternion), ``(K,)`` or ``(K, n)``.
    gyro_bias_rad_s, accel_bias_m_s2 : ndarray, shape (K, 3)
        The bias estimates (body axes).
    sigma : ndarray, shape (K, n)
        1-sigma of the error states after the epoch's update.
    updated : ndarray of bool, shape (K,)
        Whether fixes were applied at the epoch.
    t_valid_s : ndarray, shape (K,)
        Latest time of validity of the fixes applied at the epoch (NaN without).
    phi : ndarray, shape (K, n, n)
        Transition matrix from the previous epoch (identity at the first).
    p_pred, p_upd : ndarray, shape (K, n, n)
        Covariance before and after the epoch's update (equal without one).
    correction : ndarray, shape (K, n)
        The update's change of the estimate at the epoch, ``x^+ - x^-`` (zeros without an update): in closed loop
        its first 15 entries are what was fed back.
    innovation_t_s, innovation_t_valid_s : ndarray, shape (M,)
        Time each measurement was applied and the time of validity of its fix.
    innovation_name : ndarray of str, shape (M,)
        ``position`` or ``velocity``.
    innovation : ndarray, shape (M, 3)
        ``nu = dz - H x`` (m or m/s, NED).
    innovation_sigma : ndarray, shape (M, 3)
        ``sqrt(diag S)``.
    nis : ndarray, shape (M,)
        ``nu^T S^-1 nu`` (chi-square with 3 degrees of freedom for a consistent filter).
    latency : str
        The latency handling (:data:`LATENCY_MODES`).
    update_period_s : float
        The navigation update period (s).
    """

    updated: np.ndarray
    t_valid_s: np.ndarray
    phi: np.ndarray
    p_pred: np.ndarray
    p_upd: np.ndarray
    correction: np.ndarray
    innovation_t_s: np.ndarray
    innovation_t_valid_s: np.ndarray
    innovation_name: np.ndarray
    innovation: np.ndarray
    innovation_sigma: np.ndarray
    nis: np.ndarray
    latency: str
    update_period_s: float

    def _extra_columns(self) -> dict:
        return {"updated": self.updated, "t_valid_s": self.t_valid_s}

    def innovations_to_pandas(self):
        """The innovation records as a DataFrame (one row per measurement, units in the column names)."""
        import pandas as pd

        cols = {"t_s": self.innovation_t_s, "t_valid_s": self.innovation_t_valid_s, "name": self.innovation_name}
        for i, ax in enumerate("ned"):
            cols[f"innovation_{ax}"] = self.innovation[:, i]
            cols[f"innovation_sigma_{ax}"] = self.innovation_sigma[:, i]
        cols["nis"] = self.nis
        return pd.DataFrame(cols)

    def normalised_innovations(self, name: str) -> np.ndarray:
        """The innovations of one measurement divided by their predicted sigma, shape (M_name, 3)."""
        v.choice("", "name", name, GNSS_MEASUREMENTS)
        sel = self.innovation_name == name
        return self.innovation[sel] / self.innovation_sigma[sel]


@dataclass(frozen=True)
class SmoothedResult(_Series):
    """The Rauch-Tung-Striebel smoothed solution at the filter's epochs (:func:`smooth`).

    Attributes
    ----------
    t_s, lat_rad, lon_rad, h_m, v_ned_m_s, q_nb, gyro_bias_rad_s, accel_bias_m_s2 : ndarray
        As in :class:`AidedResult`, smoothed.
    sigma : ndarray, shape (K, n)
        1-sigma of the smoothed error states.
    p : ndarray, shape (K, n, n)
        Smoothed covariance.
    estimate : ndarray, shape (K, n)
        Smoothed estimate ``s_k`` of the error of the filter's solution (the filter's solution minus it is
        the smoothed solution).
    """

    p: np.ndarray
    estimate: np.ndarray


class _History:
    """The solution rows of the last seconds (for fixes with latency), kept corrected by every feedback."""

    def __init__(self, t0, start: ekf.NavState):
        self.t = np.array([t0])
        self.lat, self.lon, self.h = (np.array([x]) for x in (start.lat_rad, start.lon_rad, start.h_m))
        self.v = np.asarray(start.v_ned_m_s, dtype=np.float64).reshape(1, 3)
        self.q = np.asarray(start.q_nb, dtype=np.float64).reshape(1, 4)

    def append(self, t, sol, keep_s):
        keep = np.concatenate([self.t, t]) >= t[-1] - keep_s if t.size else np.ones(self.t.size, bool)
        self.t = np.concatenate([self.t, t])[keep]
        self.lat = np.concatenate([self.lat, sol.lat_rad])[keep]
        self.lon = np.concatenate([self.lon, sol.lon_rad])[keep]
        self.h = np.concatenate([self.h, sol.h_m])[keep]
        self.v = np.concatenate([self.v, sol.v_ned_m_s])[keep]
        self.q = np.concatenate([self.q, sol.q_nb])[keep]

    def correct(self, dx):
        self.lat, self.lon, self.h, self.v, self.q = _correct_rows(self.lat, self.lon, self.h, self.v, self.q, dx)

    def state_at(self, t_v, bg, ba) -> ekf.NavState:
        """Linear interpolation between the stored rows (quaternions sign-aligned and normalised; compiled,
        :func:`kekf.interpolate_row`, :meth:`state_at_reference` the numpy form)."""
        r = np.empty(10)
        kekf.interpolate_row(self.t, self.lat, self.lon, self.h, self.v, self.q, float(t_v), r)
        return ekf.NavState(t_v, r[0], r[1], r[2], r[3:6], r[6:10], bg, ba)

    def state_at_reference(self, t_v, bg, ba) -> ekf.NavState:
        """:meth:`state_at` in numpy."""
        i = min(max(int(np.searchsorted(self.t, t_v)) - 1, 0), max(self.t.size - 2, 0))
        if self.t.size == 1:
            w, j = 0.0, 0
        else:
            j = i + 1
            w = min(max(float((t_v - self.t[i]) / (self.t[j] - self.t[i])), 0.0), 1.0)
        dlon = (self.lon[j] - self.lon[i] + math.pi) % (2.0 * math.pi) - math.pi
        qj = self.q[j] if float(self.q[i] @ self.q[j]) >= 0.0 else -self.q[j]
        q = (1.0 - w) * self.q[i] + w * qj
        return ekf.NavState(t_v, (1.0 - w) * self.lat[i] + w * self.lat[j], self.lon[i] + w * dlon,
                            (1.0 - w) * self.h[i] + w * self.h[j], (1.0 - w) * self.v[i] + w * self.v[j],
                            q / math.sqrt(float(q @ q)), bg, ba)


def _uniform_times(t_s, n):
    t = v.finite_array("", "t_s", t_s, ndim=1)
    if t.shape[0] != n or n < 2:
        raise ValueError(f"t_s: must have one end time per increment ({n}, at least 2), got shape {t.shape}")
    dt = (t[-1] - t[0]) / (n - 1)
    if not dt > 0.0 or np.max(np.abs(np.diff(t) - dt)) > 1e-6 * dt:
        raise ValueError("t_s: must be uniformly spaced and increasing (the increments' end times)")
    return t, dt


def navigate_aided(t_s, dtheta, dv, start: ekf.NavState, noise: ekf.ImuNoise, p0, fixes: GnssFixes, *,
                   output_t_s=None, use=GNSS_MEASUREMENTS, latency="compensate", n_sub=1,
                   max_propagation_s=1.0, feedback=True, unmodelled=None, fix_errors=None) -> AidedResult:
    """GNSS-aided navigation of a record of increments (module docstring).

    Parameters
    ----------
    t_s : array_like, shape (n,)
        End time of each increment (s), uniformly spaced by ``dt``; the run starts at ``t_s[0] - dt``.
    dtheta, dv : array_like, shape (n, 3)
        Raw gyro angle and velocity increments (rad, m/s; body axes).
    start : NavState
        The computed state at the start (``start.t_s = t_s[0] - dt``) with the initial bias estimates.
    noise : ImuNoise
        The filter's sensor-error model.
    p0 : array_like, shape (15, 15)
        Initial covariance (:func:`~sins_sim.navigation.ekf.initial_covariance`).
    fixes : GnssFixes
        The fixes (:func:`~sins_sim.navigation.gnss.simulate_gnss`); those valid before the start or
        delivered after the record are not used.
    output_t_s : array_like, optional
        Further times to record the solution at (s), rounded to the nearest navigation update.
    use : sequence of str
        Which fix components to apply (:data:`GNSS_MEASUREMENTS`).
    latency : {"compensate", "ignore"}
        Apply each fix against the solution at its time of validity (default), or as if it were current.
    n_sub : int
        Input samples per navigation update.
    max_propagation_s : float
        Longest covariance propagation step (s).
    feedback : bool
        Closed loop (default); ``False`` leaves the navigator free and the error state accumulating (the
        open-loop filter, whose solution is the free one minus the estimate; for comparison).
    unmodelled : UnmodelledErrors or None
        Scale factors and misalignments told to the filter as process noise per propagation step
        (:class:`~sins_sim.navigation.ekf.UnmodelledErrors`).
    fix_errors : FixErrorStates or None
        The fixes' Gauss-Markov errors as filter states (:class:`~sins_sim.navigation.ekf.FixErrorStates`; ``R``
        then the fixes' white noise); None: 15 states.

    Returns
    -------
    AidedResult
        Epochs: the start, every navigation update where fixes were applied, every output time (without
        ``output_t_s``, the record's last navigation update instead).

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    dth = _increments("dtheta", dtheta)
    dvel = _increments("dv", dv)
    if dvel.shape != dth.shape:
        raise ValueError(f"dv: must have the shape of dtheta {dth.shape}, got {dvel.shape}")
    t, dt = _uniform_times(t_s, dth.shape[0])
    if not isinstance(fixes, GnssFixes):
        raise ValueError(f"fixes: must be GnssFixes, got {type(fixes).__name__}")
    run = AidedRun(t[0] - dt, dt, dth.shape[0], start, noise, p0, fixes.t_valid_s, fixes.t_deliver_s,
                   fixes.position_sigma_m, fixes.velocity_sigma_m_s, fixes.lever_arm_b_m, output_t_s=output_t_s,
                   use=use, latency=latency, n_sub=n_sub, max_propagation_s=max_propagation_s, feedback=feedback,
                   unmodelled=unmodelled, fix_errors=fix_errors)
    run.add_fixes(fixes)
    run.feed(dth, dvel)
    return run.result()


class AidedRun:
    """:func:`navigate_aided` streaming: increments fed in chunks of any size, fixes added as they become known.

    The run's length, its fix schedule (times of validity and delivery) and its output times are given at the
    start, so its epochs are fixed before any increment arrives and the result does not depend on the chunking.
    A fix's values (:meth:`add_fixes`, in schedule order) must be added before the increments that reach the
    navigation update it is applied at.

    Parameters
    ----------
    t0_s : float
        Start of the record (s): ``start.t_s``; increment ``i`` ends at ``t0_s + (i + 1) dt_s``.
    dt_s : float
        Increment period (s).
    n_increments : int
        Increments in the whole record.
    start, noise, p0, output_t_s, use, latency, n_sub, max_propagation_s, feedback, unmodelled, fix_errors
        As in :func:`navigate_aided`.
    t_valid_s, t_deliver_s : array_like, shape (M,)
        The fix schedule: time of validity and of delivery of each fix (s).
    position_sigma_m, velocity_sigma_m_s, lever_arm_b_m : array_like, shape (3,)
        The fixes' white-noise sigmas (the filter's ``R``) and the antenna's lever arm.
    coning, sculling : str or sequence
        The navigator's coning and sculling compensation
        (:class:`~sins_sim.navigation.strapdown.StrapdownNavigator`).

    Notes
    -----
    In closed loop (``feedback=True``) each :meth:`feed` handles all the navigation updates and epochs its chunk
    reaches in one compiled call (:func:`sins_sim._kernels.ekf_epoch.aided_chunk`: the aided navigator's strapdown
    pieces, the propagation blocks, the fixes' measurements at their time of validity, the update, the NIS, the
    feedback, the sensor-error states' too, the kept rows and the records); the Python path that does the same one
    step at a time (``_epoch``, ``_advance``; the open loop's) is its reference, and the two give the same result
    bit for bit (tested). The aided navigator's own innovation list and mean gyro rate are then not kept (the run's
    records hold them).
    """

    def __init__(self, t0_s, dt_s, n_increments, start: ekf.NavState, noise: ekf.ImuNoise, p0, t_valid_s,
                 t_deliver_s, position_sigma_m, velocity_sigma_m_s, lever_arm_b_m, *, output_t_s=None,
                 use=GNSS_MEASUREMENTS, latency="compensate", n_sub=1, max_propagation_s=1.0, feedback=True,
                 coning="two_sample", sculling="two_sample", unmodelled=None, fix_errors=None):
        dt = v.positive("", "dt_s", dt_s)
        t0 = float(t0_s)
        if not isinstance(start, ekf.NavState):
            raise ValueError(f"start: must be a NavState, got {type(start).__name__}")
        if abs(start.t_s - t0) > 1e-6 * dt:
            raise ValueError(f"start.t_s: must be the record's start t_s[0] - dt = {t0!r}, got {start.t_s!r}")
        v.choice("", "latency", latency, LATENCY_MODES)
        use = tuple(use)
        if not use or any(u not in GNSS_MEASUREMENTS for u in use):
            raise ValueError(f"use: must be a non-empty subset of {GNSS_MEASUREMENTS}, got {use!r}")
        if isinstance(n_sub, bool) or not isinstance(n_sub, Integral) or n_sub < 1:
            raise ValueError(f"n_sub: must be an integer >= 1, got {n_sub!r}")
        tv = np.asarray(t_valid_s, dtype=np.float64).reshape(-1)
        td = np.asarray(t_deliver_s, dtype=np.float64).reshape(-1)
        if tv.shape != td.shape:
            raise ValueError(f"t_deliver_s: must have the shape of t_valid_s {tv.shape}, got {td.shape}")
        nav = StrapdownNavigator(start.lat_rad, start.lon_rad, start.h_m, start.v_ned_m_s, start.q_nb, dt,
                                 n_sub=n_sub, coning=coning, sculling=sculling)
        self._aided = ekf.AidedNavigator(nav, noise, p0, gyro_bias_rad_s=start.gyro_bias_rad_s,
                                         accel_bias_m_s2=start.accel_bias_m_s2, max_propagation_s=max_propagation_s,
                                         feedback=bool(feedback), unmodelled=unmodelled, fix_errors=fix_errors)
        self._t0, self._dt, self._n_sub = t0, dt, int(n_sub)
        self._big_t = big_t = nav.update_period_s
        self._n_upd = n_upd = int(n_increments) // self._n_sub
        self._use, self._latency, self._feedback = use, latency, bool(feedback)
        # the navigation update each fix is applied at: the first at or after its delivery
        f_upd = np.ceil((td - t0) / big_t - 1e-9).astype(np.int64)
        ok = (tv >= t0 - 1e-9 * big_t) & (f_upd <= n_upd) & (f_upd >= 0)
        fix_idx = np.flatnonzero(ok)
        events = {0, n_upd} if output_t_s is None else {0}
        if output_t_s is not None:
            out = v.finite_array("", "output_t_s", output_t_s, ndim=1)
            j_out = np.rint((out - t0) / big_t).astype(np.int64)
            events.update(int(j) for j in j_out[(j_out >= 0) & (j_out <= n_upd)])
        events.update(int(j) for j in f_upd[fix_idx])
        self._events = sorted(events)
        self._next_event = 0
        self._by_update = {}
        for i in fix_idx:
            self._by_update.setdefault(int(f_upd[i]), []).append(int(i))
        self._keep_s = float(np.max(td[fix_idx] - tv[fix_idx], initial=0.0)) + 2.0 * big_t
        self._hist = _History(t0, start)
        self._sig_p = np.broadcast_to(np.asarray(position_sigma_m, dtype=np.float64), (3,)).copy()
        self._sig_v = np.broadcast_to(np.asarray(velocity_sigma_m_s, dtype=np.float64), (3,)).copy()
        self._lever = np.asarray(lever_arm_b_m, dtype=np.float64).reshape(3).copy()
        # R and the lever arm checked once here (the per-fix measurements are built from checked values)
        self._lever = ekf._vec3("lever_arm_b_m", self._lever)
        self._r_pos = ekf._sigma_matrix("position_sigma_m", self._sig_p, 3) if "position" in use else None
        self._r_vel = ekf._sigma_matrix("velocity_sigma_m_s", self._sig_v, 3) if "velocity" in use else None
        self._r_by_count = {}
        self._has_lever = bool(np.any(self._lever != 0.0))
        self._tv = tv
        self._n_fix_sched = tv.shape[0]
        self._fix_parts, self._n_fixes = [], 0
        self._fix_tab = np.empty((tv.shape[0], 7))
        self._fix = None
        # pending increments (not yet navigated) and the gyro sums of the recent navigation updates
        self._pend_th, self._pend_v = np.zeros((0, 3)), np.zeros((0, 3))
        self._done = 0                       # navigation updates processed
        self._upd_sum = np.zeros((0, 3))     # raw gyro sum of updates [_upd_base, _done)
        self._upd_base = 0
        self._rec = {k: [] for k in ("t", "lat", "lon", "h", "v", "q", "bg", "ba", "sigma", "updated", "t_valid",
                                     "phi", "p_pred", "p_upd", "corr")}
        self._inn = {k: [] for k in ("t", "t_valid", "name", "nu", "sigma", "nis")}
        # the compiled path (closed loop): every epoch of a chunk in one call (_kernels.ekf_epoch.aided_chunk); the
        # Python path above (_epoch, _advance) is its reference. Records per chunk (the times also in _rec["t"]).
        # (the 15 inertial states, the fix errors and the sensor errors, the layout AidedNavigator makes)
        self._compiled = self._feedback
        self._parts = []
        self._fast = None

    @property
    def update_period_s(self) -> float:
        """The navigation update period (s)."""
        return self._big_t

    @property
    def unaided_bias_sigma(self) -> np.ndarray:
        """1-sigma the six bias states (gyro xyz, accel xyz) would have with no measurement (the prior, carried)."""
        return self._aided.unaided_bias_sigma

    @property
    def n_epochs(self) -> int:
        """Epochs recorded so far."""
        return len(self._rec["t"])

    def epoch_times(self, start: int = 0) -> np.ndarray:
        """Times of the epochs recorded from index ``start`` on (s)."""
        return np.asarray(self._rec["t"][start:], dtype=np.float64)

    def add_fixes(self, fixes: GnssFixes) -> None:
        """The values of the next fixes of the schedule (their times of validity must be the schedule's)."""
        if not isinstance(fixes, GnssFixes):
            raise ValueError(f"fixes: must be GnssFixes, got {type(fixes).__name__}")
        m = len(fixes)
        if m == 0:
            return
        want = self._tv[self._n_fixes:self._n_fixes + m]
        if want.shape[0] != m or np.max(np.abs(want - fixes.t_valid_s)) > 1e-9 * max(1.0, float(np.max(np.abs(want)))):
            raise ValueError("fixes: their times of validity must continue the schedule (t_valid_s) in order")
        for name, val, meas in (("lat_rad", fixes.lat_rad, "position"), ("lon_rad", fixes.lon_rad, "position"),
                                ("h_m", fixes.h_m, "position"), ("v_ned_m_s", fixes.v_ned_m_s, "velocity")):
            if meas in self._use and not np.all(np.isfinite(val)):
                raise ValueError(f"fixes.{name}: must be finite (a {meas} measurement is applied), got "
                                 f"{np.count_nonzero(~np.isfinite(val))} non-finite values")
        self._fix_parts.append(fixes)
        tab = self._fix_tab          # the compiled path's copy: time of validity, lat, lon, h, v_N, v_E, v_D
        a = self._n_fixes
        tab[a:a + m, 0], tab[a:a + m, 1], tab[a:a + m, 2], tab[a:a + m, 3] = (fixes.t_valid_s, fixes.lat_rad,
                                                                              fixes.lon_rad, fixes.h_m)
        tab[a:a + m, 4:7] = fixes.v_ned_m_s
        self._n_fixes += m
        self._fix = None

    def _fixes(self):
        if self._fix is None and self._fix_parts:
            from sins_sim.navigation.gnss import concat_fixes

            self._fix = concat_fixes(self._fix_parts)
            self._fix_parts = [self._fix]
        return self._fix

    def _r_stack(self, k_fix):
        """Block-diagonal ``R`` of ``k_fix`` fixes (position then velocity per fix, as in use), cached by count."""
        r = self._r_by_count.get(k_fix)
        if r is None:
            blocks = ([self._r_pos] if self._r_pos is not None else []) + ([self._r_vel] if self._r_vel is not None
                                                                          else [])
            r = np.zeros((3 * len(blocks) * k_fix,) * 2)
            for b, blk in enumerate(blocks * k_fix):
                r[3 * b:3 * b + 3, 3 * b:3 * b + 3] = blk
            self._r_by_count[k_fix] = r
        return r

    def _rate_at(self, j):
        """Mean raw gyro rate over the navigation update ending at update ``j`` (rad/s, body)."""
        j = max(1, j)
        if j > self._done:      # an update not navigated yet (a fix at the record's start): its pending increments
            i = (j - 1 - self._done) * self._n_sub
            return self._pend_th[i:i + self._n_sub].sum(axis=0) / self._big_t
        k = j - 1 - self._upd_base
        if not 0 <= k < self._upd_sum.shape[0]:
            raise RuntimeError(f"the gyro rate of navigation update {j} is no longer kept")
        return self._upd_sum[k] / self._big_t

    def feed(self, dtheta, dv) -> None:
        """Navigate a chunk of increments (raw; ``(n, 3)`` each), handling every epoch they reach.

        (Checked here once, shapes and values: the navigation of each piece between epochs reads them as checked.)"""
        dth = v.finite_array("", "dtheta", dtheta, ndim=2)
        dvel = v.finite_array("", "dv", dv, ndim=2)
        if dth.shape[1] != 3:
            raise ValueError(f"dtheta: must have shape (n, 3), got {dth.shape}")
        if dvel.shape != dth.shape:
            raise ValueError(f"dv: must have the shape of dtheta {dth.shape}, got {dvel.shape}")
        if self._compiled:
            self._feed_compiled(dth, dvel)
            return
        self._pend_th = np.concatenate([self._pend_th, dth])
        self._pend_v = np.concatenate([self._pend_v, dvel])
        avail = self._done + self._pend_th.shape[0] // self._n_sub
        while self._next_event < len(self._events) and self._events[self._next_event] <= avail:
            self._epoch(self._events[self._next_event])
            self._next_event += 1
        # navigate what remains up to the last whole update (the epochs after it come with later chunks)
        self._advance(avail)

    def _advance(self, j):
        """Navigate up to navigation update ``j`` with no epoch in between."""
        if j <= self._done:
            return
        n = (j - self._done) * self._n_sub
        dth, dvel = self._pend_th[:n], self._pend_v[:n]
        sol = self._aided._process_checked(np.ascontiguousarray(dth), np.ascontiguousarray(dvel))
        self._hist.append(self._t0 + sol.t_s, sol, self._keep_s)
        sums = np.empty((j - self._done, 3))
        kekf.update_sums(dth, self._n_sub, sums)     # dth.reshape(-1, n_sub, 3).sum(axis=1), compiled
        keep_upd = int(math.ceil(self._keep_s / self._big_t)) + 2
        self._upd_sum = np.concatenate([self._upd_sum, sums])
        drop = max(0, self._upd_sum.shape[0] - keep_upd)
        self._upd_sum = self._upd_sum[drop:]
        self._upd_base += drop
        self._pend_th, self._pend_v = self._pend_th[n:], self._pend_v[n:]
        self._done = j

    def _epoch(self, j):
        aided = self._aided
        self._advance(j)
        phi = aided.propagate()
        p_pred = aided.p
        t_now = self._t0 + j * self._big_t
        fix_list = self._by_update.get(j, [])
        n_x = aided.n_states
        corr = np.zeros(n_x)
        inn = self._inn
        fixes = None
        if fix_list:
            if max(fix_list) >= self._n_fixes:
                raise RuntimeError(f"the fix valid at {self._tv[max(fix_list)]!r} s is due at {t_now!r} s and has not "
                                   "been added (add_fixes)")
            fixes = self._fixes()
            aided._begin_update()
            bg, ba = aided.gyro_bias_rad_s, aided.accel_bias_m_s2
            use_pos, use_vel = "position" in self._use, "velocity" in self._use
            per_fix = 3 * (use_pos + use_vel)
            k_fix = len(fix_list)
            h = np.empty((k_fix * per_fix, n_x))
            fe = aided.fix_errors
            gm_cols = []       # (first row within a fix, fix-error state columns) of each measurement they enter
            if fe is not None:
                gm_cols = ([(0, fe.columns("position"))] if use_pos else []) + \
                          ([(3 * use_pos, fe.columns("velocity"))] if use_vel else [])
            dz = np.empty(k_fix * per_fix)
            t_valid = []
            for n, i in enumerate(fix_list):
                tv = float(fixes.t_valid_s[i]) if self._latency == "compensate" else t_now
                st = self._hist.state_at(tv, bg, ba)
                rate = (self._rate_at(int(round((tv - self._t0) / self._big_t))) if self._has_lever
                        else _ZERO3)
                # Position and Velocity (ekf) at the fix's time of validity, compiled; tested equal to the plug-ins
                kekf.gnss_measurement(st.lat_rad, st.lon_rad, st.h_m, st.v_ned_m_s, st.q_nb, bg, rate, self._lever,
                                      fixes.lat_rad[i], fixes.lon_rad[i], fixes.h_m[i], fixes.v_ned_m_s[i], use_pos,
                                      use_vel, h[n * per_fix:(n + 1) * per_fix], dz[n * per_fix:(n + 1) * per_fix])
                for row, cols in gm_cols:     # dz = H x - e + v: -I on the fix-error states (ekf module docstring)
                    if cols is not None:
                        h[n * per_fix + row + np.arange(3), np.arange(cols.start, cols.stop)] = -1.0
                t_valid += [float(fixes.t_valid_s[i])] * len(self._use)
            names = (["position"] * use_pos + ["velocity"] * use_vel) * k_fix
            x_before = aided.x
            recs = aided._update_stacked(h, dz, self._r_stack(k_fix), names, [3] * len(names))
            if self._feedback:
                corr = aided.last_correction
                self._hist.correct(corr[:ekf.N_STATES])
            else:       # open loop: the history stays the free solution, the estimate the change of x
                corr = aided.x - x_before
            for r, tv in zip(recs, t_valid):
                inn["t"].append(t_now)
                inn["t_valid"].append(tv)
                inn["name"].append(r.name)
                inn["nu"].append(r.innovation)
                inn["sigma"].append(np.sqrt(np.diag(r.s_matrix)))
                inn["nis"].append(r.nis)
        st = aided.nav_state() if self._feedback else aided.corrected_state()
        for key, val in (("t", t_now), ("lat", st.lat_rad), ("lon", st.lon_rad), ("h", st.h_m),
                         ("v", st.v_ned_m_s), ("q", st.q_nb), ("bg", st.gyro_bias_rad_s), ("ba", st.accel_bias_m_s2),
                         ("sigma", aided.sigma()), ("updated", bool(fix_list)),
                         ("t_valid", max((float(fixes.t_valid_s[i]) for i in fix_list), default=math.nan)),
                         ("phi", phi), ("p_pred", p_pred), ("p_upd", aided.p), ("corr", corr)):
            self._rec[key].append(val)

    # --- the compiled path ---------------------------------------------------------------------------------------

    def _fast_state(self):
        """The compiled path's arrays (made at the first chunk): the epochs' fixes as index lists, the kept rows
        (``t, lat, lon, h, v, q``; at least the ``keep_s`` the latency needs), the updates' raw gyro sums."""
        if self._fast is None:
            big_t = self._big_t
            ev = np.array(self._events, dtype=np.int64)
            lists = [self._by_update.get(int(j), []) for j in ev]
            ptr = np.zeros(ev.size + 1, dtype=np.int64)
            ptr[1:] = np.cumsum([len(x) for x in lists])
            fix = np.array([i for x in lists for i in x], dtype=np.int64)
            # the largest fix index needed up to each entry (a chunk's fixes all added: one comparison)
            cmax = np.maximum.accumulate(fix) if fix.size else fix
            keep_rows = int(math.ceil(self._keep_s / big_t)) + 3
            hist = np.empty((2 * keep_rows + 64, kep.HIST_COLS))
            st = self._hist
            hist[0] = [st.t[0], st.lat[0], st.lon[0], st.h[0], *st.v[0], *st.q[0]]
            ints = np.zeros(kep.INT_SIZE, dtype=np.int64)
            ints[kep.INT_HIST_N] = 1
            fe = self._aided.fix_errors
            gm = [-1, -1]
            if fe is not None:
                for k, name in enumerate(GNSS_MEASUREMENTS):
                    cols = fe.columns(name)
                    gm[k] = -1 if cols is None else cols.start
            r_pos = self._r_pos if self._r_pos is not None else np.zeros((3, 3))
            r_vel = self._r_vel if self._r_vel is not None else np.zeros((3, 3))
            self._fast = dict(ev=ev, ptr=ptr, fix=fix, cmax=cmax, keep_rows=keep_rows, hist=hist, ints=ints, gm=gm,
                              ring=np.zeros((keep_rows + 2, 3)), r_pos=np.ascontiguousarray(r_pos),
                              r_vel=np.ascontiguousarray(r_vel))
        return self._fast

    def _feed_compiled(self, dth, dvel):
        """:meth:`feed`'s epochs and navigation in one compiled call (:func:`kep.aided_chunk`; the same values as
        :meth:`_epoch` and :meth:`_advance`, tested)."""
        fs = self._fast_state()
        if self._pend_th.shape[0]:
            dth = np.concatenate([self._pend_th, dth])
            dvel = np.concatenate([self._pend_v, dvel])
        else:
            dth, dvel = np.ascontiguousarray(dth), np.ascontiguousarray(dvel)
        avail = self._done + dth.shape[0] // self._n_sub
        ev = fs["ev"]
        k0 = self._next_event
        k1 = int(np.searchsorted(ev, avail, side="right"))
        target, missing = avail, None
        p0, p1 = int(fs["ptr"][k0]), int(fs["ptr"][k1])
        if p1 > p0 and fs["cmax"][p1 - 1] >= self._n_fixes:
            # a fix due and not added: navigate up to its epoch, then say so
            late = p0 + int(np.argmax(fs["fix"][p0:p1] >= self._n_fixes))
            k_bad = int(np.searchsorted(fs["ptr"], late, side="right")) - 1
            missing = (int(ev[k_bad]), int(fs["fix"][late]))
            k1, target = k_bad, int(ev[k_bad])
        aided = self._aided
        nav = aided._nav
        n_x = aided.n_states
        k_ep = k1 - k0
        m_meas = int(fs["ptr"][k1] - fs["ptr"][k0]) * len(self._use)
        tab = self._fix_tab
        rec = dict(t=np.empty(k_ep), nav=np.empty((k_ep, 10)), bg=np.empty((k_ep, 3)), ba=np.empty((k_ep, 3)),
                   sigma=np.empty((k_ep, n_x)), updated=np.empty(k_ep, dtype=np.bool_), t_valid=np.empty(k_ep),
                   phi=np.empty((k_ep, n_x, n_x)), p_pred=np.empty((k_ep, n_x, n_x)), p_upd=np.empty((k_ep, n_x, n_x)),
                   corr=np.empty((k_ep, n_x)), i_t=np.empty(m_meas), i_tv=np.empty(m_meas),
                   i_name=np.empty(m_meas, dtype=np.int64), i_nu=np.empty((m_meas, 3)), i_sig=np.empty((m_meas, 3)),
                   i_nis=np.empty(m_meas))
        noise = aided._noise
        bg, ba = aided._bg.copy(), aided._ba.copy()
        if aided._f_ref is None:
            f_ref, fs["ints"][kep.INT_HAVE_FREF] = np.zeros(3), 0
        else:
            f_ref, fs["ints"][kep.INT_HAVE_FREF] = np.asarray(aided._f_ref, dtype=np.float64).copy(), 1
        x = aided._x.copy()
        ints = fs["ints"]
        ints[kep.INT_BLOCK_N] = aided._block_n
        n_go = target - self._done
        done = kep.aided_chunk(
            dth, dvel, n_go, self._done, ev[k0:k1], fs["ptr"][k0:k1 + 1] - fs["ptr"][k0],
            fs["fix"][fs["ptr"][k0]:fs["ptr"][k1]], tab[:, 0], tab[:, 1], tab[:, 2], tab[:, 3], tab[:, 4:7], self._t0,
            self._dt, self._n_sub, self._big_t, aided._n_prop, self._latency == "compensate", "position" in self._use,
            "velocity" in self._use, self._has_lever, self._lever, fs["r_pos"], fs["r_vel"], fs["gm"][0],
            fs["gm"][1], fs["keep_rows"], nav._ccoef, nav._scoef, np.asarray(nav._gains, dtype=np.float64),
            nav._state, bg, ba, aided._unmod is not None, f_ref, aided._acc, aided._origin, aided._unmod_var,
            aided._qc, np.asarray(aided._inv_tau, dtype=np.float64), aided._fix_tau, aided._fix_var,
            aided._prior_bias_var, np.array([noise.gyro_bias_sigma_rad_s, noise.accel_bias_sigma_m_s2], dtype=float),
            np.array([noise.gyro_bias_tau_s, noise.accel_bias_tau_s], dtype=float),
            np.array([noise.gyro_bias_rw_rad_s_sqrt_s, noise.accel_bias_rw_m_s2_sqrt_s], dtype=float),
            aided._sens, aided._k_est, aided._k_inv,
            aided._p, x, aided._phi_acc, aided._block_start, aided._last_correction, ints, fs["hist"], fs["ring"],
            rec["t"], rec["nav"], rec["bg"], rec["ba"], rec["sigma"], rec["updated"], rec["t_valid"], rec["phi"],
            rec["p_pred"], rec["p_upd"], rec["corr"], rec["i_t"], rec["i_tv"], rec["i_name"], rec["i_nu"],
            rec["i_sig"], rec["i_nis"])
        aided._bg, aided._ba, aided._x = bg, ba, x
        aided._block_n = int(ints[kep.INT_BLOCK_N])
        if aided._unmod is not None and ints[kep.INT_HAVE_FREF]:
            aided._f_ref = f_ref
        if ints[kep.INT_STATUS] != kep.STATUS_OK:
            raise ValueError(f"the filter's correction at t = {float(self._t0 + ev[k0 + done] * self._big_t)!r} s is "
                             "not finite (the covariance or a measurement is not)")
        n_used = n_go * self._n_sub
        nav._n_samples += n_used
        nav._n_updates += n_go
        self._pend_th, self._pend_v = dth[n_used:].copy(), dvel[n_used:].copy()
        self._done = target
        self._next_event = k1
        self._rec["t"].extend(rec["t"].tolist())
        self._parts.append(rec)
        if missing is not None:
            raise RuntimeError(f"the fix valid at {self._tv[missing[1]]!r} s is due at "
                               f"{float(self._t0 + missing[0] * self._big_t)!r} s and has not been added (add_fixes)")

    def _result_compiled(self) -> AidedResult:
        n_x = self._aided.n_states
        names = np.array(GNSS_MEASUREMENTS)

        def cat(key, shape):
            return np.concatenate([p[key] for p in self._parts]) if self._parts else np.zeros((0,) + shape)

        nav = cat("nav", (10,))
        return AidedResult(
            t_s=cat("t", ()), lat_rad=nav[:, 0].copy(), lon_rad=nav[:, 1].copy(), h_m=nav[:, 2].copy(),
            v_ned_m_s=nav[:, 3:6].copy(), q_nb=nav[:, 6:10].copy(), gyro_bias_rad_s=cat("bg", (3,)),
            accel_bias_m_s2=cat("ba", (3,)), sigma=cat("sigma", (n_x,)), updated=cat("updated", ()).astype(bool),
            t_valid_s=cat("t_valid", ()), phi=cat("phi", (n_x, n_x)), p_pred=cat("p_pred", (n_x, n_x)),
            p_upd=cat("p_upd", (n_x, n_x)), correction=cat("corr", (n_x,)), innovation_t_s=cat("i_t", ()),
            innovation_t_valid_s=cat("i_tv", ()), innovation_name=names[cat("i_name", ()).astype(np.int64)],
            innovation=cat("i_nu", (3,)), innovation_sigma=cat("i_sig", (3,)), nis=cat("i_nis", ()),
            latency=self._latency, update_period_s=self._big_t)

    def result(self) -> AidedResult:
        """The run so far as an :class:`AidedResult` (all epochs recorded)."""
        if self._compiled:
            return self._result_compiled()
        a = {k: np.array(val) for k, val in self._rec.items()}
        inn = self._inn
        m = len(inn["t"])
        return AidedResult(
            t_s=a["t"], lat_rad=a["lat"], lon_rad=a["lon"], h_m=a["h"], v_ned_m_s=a["v"], q_nb=a["q"],
            gyro_bias_rad_s=a["bg"], accel_bias_m_s2=a["ba"], sigma=a["sigma"], updated=a["updated"],
            t_valid_s=a["t_valid"], phi=a["phi"], p_pred=a["p_pred"], p_upd=a["p_upd"], correction=a["corr"],
            innovation_t_s=np.array(inn["t"]), innovation_t_valid_s=np.array(inn["t_valid"]),
            innovation_name=np.array(inn["name"], dtype=str),
            innovation=np.array(inn["nu"]).reshape(m, 3), innovation_sigma=np.array(inn["sigma"]).reshape(m, 3),
            nis=np.array(inn["nis"]), latency=self._latency, update_period_s=self._big_t)


def smooth(result: AidedResult) -> SmoothedResult:
    """Rauch-Tung-Striebel fixed-interval smoother over a closed-loop filter run (module docstring).

    The gain ``C_k = P_k^+ Phi_k^T (P_(k+1)^-)^-1`` is computed with ``P_(k+1)^-`` scaled to its
    correlation matrix (the states span sixteen decades of variance, rad^2/s^2 to m^2).

    Parameters
    ----------
    result : AidedResult
        The filter run (:func:`navigate_aided`).

    Returns
    -------
    SmoothedResult
        Equal to the filter at the last epoch.
    """
    if not isinstance(result, AidedResult):
        raise ValueError(f"result: must be an AidedResult, got {type(result).__name__}")
    k_ep = len(result)
    est = np.zeros((k_ep, result.phi.shape[1] if k_ep else ekf.N_STATES))
    p_s = np.ascontiguousarray(result.p_upd, dtype=np.float64).copy()
    if k_ep >= 2:      # the recursion compiled (kep.rts_smooth; _smooth_reference the numpy form, tested)
        kep.rts_smooth(*(np.ascontiguousarray(a, dtype=np.float64) for a in
                         (result.phi, result.p_pred, result.p_upd, result.correction)), est, p_s)
    return _smoothed(result, est, p_s)


def _smooth_reference(result: AidedResult) -> SmoothedResult:
    """:func:`smooth` with the recursion in numpy."""
    k_ep = len(result)
    est = np.zeros((k_ep, result.phi.shape[1] if k_ep else ekf.N_STATES))
    p_s = result.p_upd.copy()
    for k in range(k_ep - 2, -1, -1):
        pp = result.p_pred[k + 1]
        d = np.sqrt(np.diag(pp))
        b = (result.phi[k + 1] @ result.p_upd[k]) / d[:, None]
        gain = (np.linalg.solve(pp / np.outer(d, d), b) / d[:, None]).T       # C = P+ Phi^T (P-)^-1
        est[k] = gain @ (est[k + 1] + result.correction[k + 1])
        p = result.p_upd[k] + gain @ (p_s[k + 1] - pp) @ gain.T
        p_s[k] = 0.5 * (p + p.T)
    return _smoothed(result, est, p_s)


def _smoothed(result, est, p_s) -> SmoothedResult:
    """The filter's solution corrected by the smoothed estimates ``est`` with their covariance ``p_s``."""
    lat, lon, h, vel, q = _correct_rows(result.lat_rad, result.lon_rad, result.h_m, result.v_ned_m_s,
                                        result.q_nb, est[:, :ekf.N_STATES])
    return SmoothedResult(
        t_s=result.t_s.copy(), lat_rad=lat, lon_rad=lon, h_m=h, v_ned_m_s=vel, q_nb=q,
        gyro_bias_rad_s=result.gyro_bias_rad_s - est[:, ekf.GYRO_BIAS],
        accel_bias_m_s2=result.accel_bias_m_s2 - est[:, ekf.ACCEL_BIAS],
        sigma=np.sqrt(np.maximum(np.diagonal(p_s, axis1=1, axis2=2), 0.0)), p=p_s, estimate=est)


@dataclass(frozen=True)
class OutageGrowth:
    """The horizontal position error growth in one GNSS outage (:func:`outage_growth`).

    Attributes
    ----------
    window_s : tuple of float
        The outage ``(start, end)`` on the fixes' time of validity (s).
    t_last_update_s : float
        The epoch of the last update before the outage (s): the growth is counted from it.
    after_s : ndarray, shape (n,)
        Times into the outage asked for (s).
    t_s : ndarray, shape (n,)
        The epochs read (s; NaN where no epoch lies there or the outage has ended).
    predicted_sigma_m : ndarray, shape (n,)
        ``sqrt(P_NN + P_EE)``, the filter's covariance at ``t_last_update_s`` propagated with its own ``F``
        and ``Q_d`` with no update in between (m).
    error_m : ndarray, shape (n,)
        Horizontal error of the solution against the truth (m; NaN without a truth).
    """

    window_s: tuple
    t_last_update_s: float
    after_s: np.ndarray
    t_s: np.ndarray
    predicted_sigma_m: np.ndarray
    error_m: np.ndarray


def outage_growth(result: AidedResult, outages_s, after_s=(10.0, 30.0, 60.0, 120.0), errors=None) -> list:
    """Position error growth in each outage against the filter's closed-form prediction.

    For each window the growth is counted from the last update whose fixes were valid before the window's
    start. The prediction is the covariance the filter propagates from that update with no measurement,
    ``P(t) = Phi(t, t_a) P^+(t_a) Phi^T + Q_d(t, t_a)`` (its recorded ``p_pred``), read as the horizontal
    1-sigma ``sqrt(P_NN + P_EE)``; an epoch must lie within half a navigation update of ``t_a + after``
    (give ``output_t_s`` to :func:`navigate_aided`), and the outage must not have ended (no update in
    ``(t_a, t]``), otherwise NaN.

    Parameters
    ----------
    result : AidedResult
        The filter run.
    outages_s : sequence of (start, end)
        The outage windows (s), e.g. ``GnssSettings.outages_s``.
    after_s : sequence of float
        Times into each outage (s), > 0.
    errors : array_like, shape (K, >= 2), optional
        The solution's errors at the epochs (:meth:`AidedResult.errors`); the north and east columns are read.

    Returns
    -------
    list of OutageGrowth
    """
    after = np.asarray(after_s, dtype=np.float64)
    if after.ndim != 1 or not np.all(np.isfinite(after)) or np.any(after <= 0.0):
        raise ValueError(f"after_s: must be a sequence of finite times > 0 (s), got {after_s!r}")
    err = None
    if errors is not None:
        err = np.asarray(errors, dtype=np.float64)
        if err.ndim != 2 or err.shape[0] != len(result) or err.shape[1] < 2:
            raise ValueError(f"errors: must have shape ({len(result)}, >= 2) (one row per epoch), got {err.shape}")
    t = result.t_s
    tol = 0.5 * result.update_period_s
    out = []
    for w in outages_s:
        start, end = (float(x) for x in w)
        before = np.flatnonzero(result.updated & (result.t_valid_s < start))
        if before.size == 0:
            raise ValueError(f"outages_s: no update before the outage starting at {start!r} s")
        ka = int(before[-1])
        ta = float(t[ka])
        later = np.flatnonzero(result.updated & (t > ta))
        t_next = float(t[later[0]]) if later.size else math.inf
        rows = np.full(after.shape, -1)
        for n, tau in enumerate(after):
            k = int(np.argmin(np.abs(t - (ta + tau))))
            if abs(t[k] - (ta + tau)) <= tol * (1.0 + 1e-9) and t[k] < t_next:
                rows[n] = k
        have = rows >= 0
        pp = result.p_pred[rows]
        pred = np.where(have, np.sqrt(pp[:, 0, 0] + pp[:, 1, 1]), np.nan)
        e = np.full(after.shape, np.nan)
        if err is not None:
            e = np.where(have, np.hypot(err[rows, 0], err[rows, 1]), np.nan)
        out.append(OutageGrowth((start, end), ta, after.copy(), np.where(have, t[rows], np.nan), pred, e))
    return out
