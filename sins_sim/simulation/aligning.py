"""Alignment inside a mission: each filter's own increments over a window at rest find its starting attitude.

With ``navigation.alignment.method`` other than ``truth``, a filter's navigation does not start from the true
attitude: over the window ``[start_s - duration_s, start_s)`` its increments (the dither filter's output
differenced, plus the sensor errors, and the accelerometers' increments) are summed to the navigation rate and
handed to the chosen method; the attitude it finds starts the navigation at ``start_s``, with the true position
(a surveyed site, as a real alignment takes it) and zero velocity (the base is at rest). A dither filter's
residual noise and bias then show up as alignment error, and the mission's errors include it.

Methods are plug-ins by name (:data:`ALIGNERS`): ``coarse`` (analytic levelling and gyrocompassing),
``inertial`` (inertial-frame alignment, robust to sway), ``kalman`` (fine alignment by the error-state filter
with zero-velocity and zero-position measurements). The observability bounds each method states come from the
unit's own sensor-error model (:func:`bias_sigmas`).

.. autosummary::

   AlignmentSettings
   AlignmentAccumulator
   ALIGNERS
   alignment_settings
   bias_sigmas
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim.navigation.alignment_result import ALIGNMENT_METHODS, AlignmentResult
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, HOUR, MICRO_G, STANDARD_GRAVITY

__all__ = ["AlignmentSettings", "AlignmentAccumulator", "ALIGNERS", "alignment_settings", "bias_sigmas",
           "imu_noise_numbers"]


@dataclass(frozen=True)
class AlignmentSettings:
    """How a mission's navigation finds its starting attitude.

    Parameters
    ----------
    method : str
        One of :data:`~sins_sim.navigation.alignment_result.ALIGNMENT_METHODS`; ``truth`` starts from the
        true attitude (the default of a simulated mission).
    duration_s : float
        The alignment window (s), ending at the navigation start.
    gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2 : tuple of 3 floats
        The unit's bias uncertainty per body axis (rad/s, m/s^2), the numbers behind the observability bounds
        (:func:`bias_sigmas`).
    noise : dict
        The unit's white-noise and bias-wander numbers in SI (:func:`imu_noise_numbers`), for the filter of
        ``kalman``.
    """

    method: str = "truth"
    duration_s: float = 300.0
    gyro_bias_sigma_rad_s: tuple = (0.0, 0.0, 0.0)
    accel_bias_sigma_m_s2: tuple = (0.0, 0.0, 0.0)
    noise: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        if self.method not in ALIGNMENT_METHODS:
            raise ValueError(f"navigation.alignment.method: must be one of {', '.join(ALIGNMENT_METHODS)}, "
                             f"got {self.method!r}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0.0):
            raise ValueError(f"navigation.alignment.duration_s: must be > 0, got {self.duration_s!r}")

    @property
    def active(self) -> bool:
        """Whether the navigation starts from an alignment (any method but ``truth``)."""
        return self.method != "truth"


def _axes3(x) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, dtype=np.float64), (3,)).astype(np.float64)


def _misalignment_rss(params) -> np.ndarray:
    """Per body axis, the root sum square of that axis's two misalignment angles (rad; order xy, xz, yx, yz, zx,
    zy), or zeros where the model has none."""
    m = np.asarray(getattr(params, "misalignment_arcsec", (0.0,) * 6), dtype=np.float64).reshape(-1)
    if m.size != 6:
        return np.zeros(3)
    return np.sqrt(m[0::2] ** 2 + m[1::2] ** 2) * ARCSEC


def bias_sigmas(sensors) -> tuple:
    """The unit's bias uncertainty per body axis as a still alignment sees it, ``(gyro rad/s (3,), accel m/s^2 (3,))``.

    The root sum square of what the unit's sensor-error model leaves unknown at the start of a run: the fixed
    bias (its spec value; a real unit's is known only to that), the turn-on bias (1 sigma), the bias
    instability's flat Allan floor (IEEE Std 952-1997, annex C), and the misalignment of each axis times what it
    sees at rest: gravity for an accelerometer (8 arcsec of misalignment toward the vertical reads as 39 ug of
    horizontal bias, which levelling cannot tell from a tilt), the Earth's rate for a gyro (Titterton & Weston
    2004, sec. 10.2.2: the alignment errors are those of the equivalent biases). Scale-factor errors at rest act
    on g along the vertical axis only and do not tilt the solution. ``sensors`` is a
    :class:`~sins_sim.models.sensor_errors.SensorErrors`-like object with ``gyro`` and ``accelerometer``
    parameters, or None (an ideal unit: zeros).
    """
    if sensors is None:
        return np.zeros(3), np.zeros(3)
    from sins_sim.earth import EARTH_RATE_RAD_S

    g, a = sensors.gyro, sensors.accelerometer
    gyro = np.sqrt((_axes3(g.bias_deg_h) ** 2 + _axes3(g.turn_on_bias_deg_h) ** 2
                    + _axes3(g.bias_instability_deg_h) ** 2) * DEG_PER_H ** 2
                   + (_misalignment_rss(g) * EARTH_RATE_RAD_S) ** 2)
    acc = np.sqrt((_axes3(a.bias_ug) ** 2 + _axes3(a.turn_on_bias_ug) ** 2
                   + _axes3(a.bias_instability_ug) ** 2) * MICRO_G ** 2
                  + (_misalignment_rss(a) * STANDARD_GRAVITY) ** 2)
    return gyro, acc


def imu_noise_numbers(sensors) -> dict:
    """The unit's white noise and bias wander in SI, per body axis (the numbers the Kalman alignment's
    process noise is built from; the same numbers that drive the simulation).

    ``gyro_arw_rad_rt_s`` (deg/sqrt(h) -> rad/sqrt(s): x DEG / 60), ``accel_vrw_m_s_rt_s`` (ug/sqrt(Hz) ->
    m/s/sqrt(s)), ``gyro_rrw_rad_s_rt_s`` and ``accel_rrw_m_s2_rt_s`` (rate random walk, per sqrt(h) -> per
    sqrt(s)), ``gyro_bias_sigma_rad_s`` and ``accel_bias_sigma_m_s2`` (:func:`bias_sigmas`).
    """
    gyro_b, acc_b = bias_sigmas(sensors)
    out = {"gyro_bias_sigma_rad_s": gyro_b, "accel_bias_sigma_m_s2": acc_b,
           "gyro_arw_rad_rt_s": np.zeros(3), "accel_vrw_m_s_rt_s": np.zeros(3),
           "gyro_rrw_rad_s_rt_s": np.zeros(3), "accel_rrw_m_s2_rt_s": np.zeros(3)}
    if sensors is None:
        return out
    g, a = sensors.gyro, sensors.accelerometer
    out["gyro_arw_rad_rt_s"] = _axes3(g.arw_deg_rt_h) * (math.pi / 180.0) / math.sqrt(HOUR)
    out["accel_vrw_m_s_rt_s"] = _axes3(a.vrw_ug_rt_hz) * MICRO_G
    out["gyro_rrw_rad_s_rt_s"] = _axes3(g.rrw_deg_h_rt_h) * DEG_PER_H / math.sqrt(HOUR)
    out["accel_rrw_m_s2_rt_s"] = _axes3(a.rrw_ug_rt_h) * MICRO_G / math.sqrt(HOUR)
    return out


def alignment_settings(method: str, duration_s: float, sensors) -> AlignmentSettings:
    """:class:`AlignmentSettings` for ``method`` over ``duration_s`` with the bias bounds and noise numbers of
    a unit's sensor-error model (``sensors``: an IMU's ``sensors``, or None for none known)."""
    gyro, acc = bias_sigmas(sensors)
    return AlignmentSettings(method=method, duration_s=float(duration_s),
                             gyro_bias_sigma_rad_s=tuple(float(x) for x in gyro),
                             accel_bias_sigma_m_s2=tuple(float(x) for x in acc), noise=imu_noise_numbers(sensors))


def _bounds(settings):
    """One gyro and one accelerometer bias sigma for the methods' bounds: the largest over the body axes (which
    body axes point east is what the alignment finds, so the bound takes the worst; conservative)."""
    return float(max(settings.gyro_bias_sigma_rad_s)), float(max(settings.accel_bias_sigma_m_s2))


def _coarse(dth, dv, dt, site, settings):
    from sins_sim.navigation.alignment import align_coarse

    sg, sa = _bounds(settings)
    return align_coarse(dth, dv, dt, site["lat_rad"], gyro_bias_sigma_rad_s=sg, accel_bias_sigma_m_s2=sa)


def _inertial(dth, dv, dt, site, settings):
    from sins_sim.navigation.alignment import align_inertial

    arw = settings.noise.get("gyro_arw_rad_rt_s")
    sg, sa = _bounds(settings)
    return align_inertial(dth, dv, dt, site["lat_rad"], site["h_m"], gyro_bias_sigma_rad_s=sg, accel_bias_sigma_m_s2=sa,
                          gyro_arw_rad_sqrt_s=0.0 if arw is None else float(np.max(arw)))


def filter_noise(settings: AlignmentSettings):
    """The Kalman filter's :class:`~sins_sim.navigation.ekf.ImuNoise` from the unit's numbers
    (:func:`imu_noise_numbers`; the filter takes one value per sensor type: the largest over the axes)."""
    from sins_sim.navigation.ekf import ImuNoise

    n = settings.noise

    def worst(key):
        return float(np.max(n.get(key, np.zeros(3))))

    return ImuNoise(gyro_arw_rad_sqrt_s=worst("gyro_arw_rad_rt_s"), accel_vrw_m_s_sqrt_s=worst("accel_vrw_m_s_rt_s"),
                    gyro_bias_sigma_rad_s=float(max(settings.gyro_bias_sigma_rad_s)),
                    accel_bias_sigma_m_s2=float(max(settings.accel_bias_sigma_m_s2)),
                    gyro_bias_rw_rad_s_sqrt_s=worst("gyro_rrw_rad_s_rt_s"),
                    accel_bias_rw_m_s2_sqrt_s=worst("accel_rrw_m_s2_rt_s"))


def _kalman(dth, dv, dt, site, settings):
    """Fine alignment by the error-state filter from the inertial method's attitude (robust to sway) as its
    coarse start; the prior sigmas are the inertial method's own (floored at 10 arcsec and 0.01 deg so that a
    perfect start still leaves the filter room)."""
    from sins_sim.navigation.static_kalman import align_kalman

    start = _inertial(dth, dv, dt, site, settings)
    return align_kalman(dth, dv, dt, site["lat_rad"], site["lon_rad"], site["h_m"], start.q_nb, filter_noise(settings),
                        prior_tilt_sigma_rad=max(float(start.sigma_rad[0]), float(start.sigma_rad[1]), 10.0 * ARCSEC),
                        prior_heading_sigma_rad=max(float(start.sigma_rad[2]), 0.01 * DEG))


#: The alignment methods by name: ``(dtheta, dv, dt_s, site, settings) -> AlignmentResult``; ``site`` holds
#: ``lat_rad``, ``lon_rad``, ``h_m``.
ALIGNERS = {"coarse": _coarse, "inertial": _inertial, "kalman": _kalman}


class AlignmentAccumulator:
    """Collects a filter's increments over the alignment window, summed to the navigation rate.

    ``add`` takes increments at the filter rate in any chunking (the sums carry across calls, so the result
    does not depend on the chunk sizes); ``finish`` runs the method on the window.
    """

    def __init__(self, settings: AlignmentSettings, n_sub: int, dt_s: float):
        self.settings = settings
        self.n_sub = int(n_sub)
        self.dt_s = float(dt_s)
        self._dth, self._dv = [], []
        self._carry_th = np.zeros(3)
        self._carry_v = np.zeros(3)
        self._carry_n = 0

    def add(self, dth: np.ndarray, dv: np.ndarray) -> None:
        """Add increments (n, 3) at the filter rate."""
        n = dth.shape[0]
        i = 0
        if self._carry_n:  # complete the block the last call left open
            take = min(self.n_sub - self._carry_n, n)
            self._carry_th = self._carry_th + dth[:take].sum(axis=0)
            self._carry_v = self._carry_v + dv[:take].sum(axis=0)
            self._carry_n += take
            i = take
            if self._carry_n == self.n_sub:
                self._dth.append(self._carry_th[None])
                self._dv.append(self._carry_v[None])
                self._carry_th, self._carry_v, self._carry_n = np.zeros(3), np.zeros(3), 0
        m = (n - i) // self.n_sub
        if m:
            blk = slice(i, i + m * self.n_sub)
            self._dth.append(dth[blk].reshape(m, self.n_sub, 3).sum(axis=1))
            self._dv.append(dv[blk].reshape(m, self.n_sub, 3).sum(axis=1))
            i += m * self.n_sub
        if i < n:
            self._carry_th = self._carry_th + dth[i:].sum(axis=0)
            self._carry_v = self._carry_v + dv[i:].sum(axis=0)
            self._carry_n += n - i

    def finish(self, lat_rad: float, lon_rad: float, h_m: float) -> AlignmentResult:
        """The alignment over the collected window (a partial last block is dropped)."""
        dth = np.concatenate(self._dth) if self._dth else np.zeros((0, 3))
        dv = np.concatenate(self._dv) if self._dv else np.zeros((0, 3))
        site = {"lat_rad": float(lat_rad), "lon_rad": float(lon_rad), "h_m": float(h_m)}
        return ALIGNERS[self.settings.method](dth, dv, self.n_sub * self.dt_s, site, self.settings)
