"""Sensor biases a unit at rest shows against the Earth's rate and gravity, and which of them it shows at all.

At rest the gyros measure ``w_b = C_bn w_ie^n + eps`` and the accelerometers ``f_b = C_bn (0, 0, -g) + b``
(``C_bn = C_nb^T``; body axes forward-right-down, navigation frame NED). With the attitude found from the same
record by a self-alignment (levelling from ``f``, gyrocompassing from ``w``), a horizontal accelerometer bias is
absorbed by the tilt and the east gyro bias by the heading (Titterton and Weston 2004, sec. 10.2; Groves 2013,
attitude initialization): ``psi_N = -b_E / g``, ``psi_E = b_N / g``, ``psi_D = -eps_E / (Omega cos lat) - psi_N
tan lat``. What is left, the residual of the means resolved in the aligned NED frame ``r = C_nb w_b - w_ie^n``,
``s = C_nb f_b - (0, 0, -g)``, reads

- the north gyro component ``eps_N`` (``r_N``) and the down component ``eps_D`` (``r_D``), each with the tilt's
  coupling of the Earth rate, ``(psi x w_ie^n)``: ``psi_E Omega sin lat`` and ``psi_E Omega cos lat``, where
  ``psi_E = b_N / g`` (so the north accelerometer bias's prior enters their sigma);
- the down accelerometer component ``b_D = s_D`` (against normal gravity at the site, ``earth.gravity_down``;
  a tilt enters it only to second order);

and nothing of ``eps_E``, ``b_N``, ``b_E``: those are "not observable". A body axis's own bias is the
combination ``eps_i = n_i eps_N + e_i eps_E + d_i eps_D`` (``n, e, d`` the body-frame unit vectors of north,
east, down: the rows of ``C_nb``), so it is observable only when the body axis lies in the observable
directions' span: ``|e_i| <= AXIS_TOL`` for a gyro, ``|n_i|, |e_i| <= AXIS_TOL`` for an accelerometer; the
neglected unobservable part, at most ``AXIS_TOL`` times the prior bias, is added to its sigma.

.. autosummary::

   rest_biases
   RestBiases

References
----------
D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IEE, 2004, sec. 10.2.
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., Artech
House, 2013 (attitude initialization, its error limits).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim.earth import earth_rate_ned, gravity_down
from sins_sim.navigation.attitude import dcm_from_quat

__all__ = ["AXIS_TOL", "RestBiases", "rest_biases"]

#: A body axis counts as lying in the observable span when its unobservable direction cosines are at most this
#: (0.01: within 0.57 deg); the neglected part, ``AXIS_TOL`` times the prior bias, is added to the sigma.
AXIS_TOL = 0.01


@dataclass(frozen=True)
class RestBiases:
    """Biases observed at rest (SI: rad/s, m/s^2), NaN where not observable.

    Parameters
    ----------
    gyro_ned_rad_s, gyro_ned_sigma_rad_s : ndarray (3,)
        Gyro bias resolved north, east, down and its 1-sigma (east NaN: not observable).
    accel_ned_m_s2, accel_ned_sigma_m_s2 : ndarray (3,)
        Accelerometer bias north, east, down and its 1-sigma (north and east NaN).
    gyro_body_rad_s, gyro_body_sigma_rad_s, accel_body_m_s2, accel_body_sigma_m_s2 : ndarray (3,)
        Per body axis x, y, z (NaN where the axis is not in the observable span).
    c_nb : ndarray (3, 3)
        The attitude used (body to NED): the aligned heading, levelled from the record's mean force.
    """

    gyro_ned_rad_s: np.ndarray
    gyro_ned_sigma_rad_s: np.ndarray
    accel_ned_m_s2: np.ndarray
    accel_ned_sigma_m_s2: np.ndarray
    gyro_body_rad_s: np.ndarray
    gyro_body_sigma_rad_s: np.ndarray
    accel_body_m_s2: np.ndarray
    accel_body_sigma_m_s2: np.ndarray
    c_nb: np.ndarray


def _relevelled(c_nb, f_b) -> np.ndarray:
    """``C_nb`` with its down axis from the mean specific force, ``d = -f / |f|`` (levelling over the whole
    record, Titterton and Weston 2004, sec. 10.2), and its north axis the given one's made horizontal: the
    given attitude contributes the heading alone. An inertial alignment's end attitude carries the gyros'
    drift over its window in the tilt; at rest the record's mean force is the better level."""
    d_b = -f_b / np.linalg.norm(f_b)
    n_b = c_nb[0] - (c_nb[0] @ d_b) * d_b
    n_b = n_b / np.linalg.norm(n_b)
    e_b = np.cross(d_b, n_b)                      # N x E = D, so E = D x N
    return np.vstack([n_b, e_b, d_b])


def rest_biases(dtheta, dv, dt_s, lat_rad, h_m, q_nb, *, gyro_mean_sigma_rad_s, accel_mean_sigma_m_s2,
                gyro_bias_prior_rad_s, accel_bias_prior_m_s2) -> RestBiases:
    """The biases a record at rest shows against the Earth's rate and normal gravity (module docstring).

    Parameters
    ----------
    dtheta, dv : array_like, shape (N, 3)
        Raw angle (rad) and velocity (m/s) increments, body FRD, one per ``dt_s``; the unit at rest.
    dt_s : float
        Increment interval (s).
    lat_rad, h_m : float
        Site latitude (rad) and height (m).
    q_nb : array_like (4,)
        Attitude aligned from the same record (body to NED, Hamilton, scalar first); its heading is used, the
        tilt is levelled again from the record's mean specific force (:func:`_relevelled`).
    gyro_mean_sigma_rad_s, accel_mean_sigma_m_s2 : array_like (3,)
        1-sigma of each body axis's record mean (the sensor noise over the record, e.g. the Allan deviation at
        the record's length).
    gyro_bias_prior_rad_s, accel_bias_prior_m_s2 : float
        1-sigma of the biases before the record (enters through the tilt's coupling and the neglected part of
        an axis near the observable span).

    Returns
    -------
    RestBiases
    """
    dth = v.finite_array("", "dtheta", dtheta, ndim=2)
    dvel = v.finite_array("", "dv", dv, ndim=2)
    if dth.shape[1] != 3 or dvel.shape != dth.shape:
        raise ValueError(f"dtheta, dv: must both have shape (N, 3), got {dth.shape} and {dvel.shape}")
    dt = v.positive("", "dt_s", dt_s)
    lat, h = v.finite("", "lat_rad", lat_rad), v.finite("", "h_m", h_m)
    sg = np.broadcast_to(np.asarray(gyro_mean_sigma_rad_s, dtype=np.float64), (3,))
    sa = np.broadcast_to(np.asarray(accel_mean_sigma_m_s2, dtype=np.float64), (3,))
    pg = v.non_negative("", "gyro_bias_prior_rad_s", gyro_bias_prior_rad_s)
    pa = v.non_negative("", "accel_bias_prior_m_s2", accel_bias_prior_m_s2)
    t_total = dth.shape[0] * dt
    w_b = dth.sum(axis=0) / t_total
    f_b = dvel.sum(axis=0) / t_total
    c_nb = _relevelled(dcm_from_quat(np.asarray(q_nb, dtype=np.float64)), f_b)
    g = gravity_down(lat, h)
    w_ie = np.asarray(earth_rate_ned(lat), dtype=np.float64)
    r = c_nb @ w_b - w_ie
    s = c_nb @ f_b - np.array([0.0, 0.0, -g])
    # noise of the means resolved in NED: sigma_j^2 = sum_i C_ji^2 sigma_i^2 (independent axes)
    sr = np.sqrt((c_nb ** 2) @ (sg ** 2))
    ss = np.sqrt((c_nb ** 2) @ (sa ** 2))
    tilt = pa / g                                      # psi_E = b_N / g, 1-sigma
    coupling = np.array([tilt * abs(w_ie[2]), 0.0, tilt * abs(w_ie[0])])   # (psi x w_ie)_N, _D
    gyro_ned = np.array([r[0], math.nan, r[2]])
    gyro_ned_sig = np.array([math.hypot(sr[0], coupling[0]), math.nan, math.hypot(sr[2], coupling[2])])
    accel_ned = np.array([math.nan, math.nan, s[2]])
    accel_ned_sig = np.array([math.nan, math.nan, ss[2]])
    n_b, e_b, d_b = c_nb
    gyro_body = np.full(3, math.nan)
    gyro_body_sig = np.full(3, math.nan)
    accel_body = np.full(3, math.nan)
    accel_body_sig = np.full(3, math.nan)
    for i in range(3):
        if abs(e_b[i]) <= AXIS_TOL:
            gyro_body[i] = n_b[i] * r[0] + d_b[i] * r[2]
            gyro_body_sig[i] = math.sqrt((n_b[i] * gyro_ned_sig[0]) ** 2 + (d_b[i] * gyro_ned_sig[2]) ** 2
                                         + (e_b[i] * pg) ** 2)
        if abs(e_b[i]) <= AXIS_TOL and abs(n_b[i]) <= AXIS_TOL:
            accel_body[i] = d_b[i] * s[2]
            accel_body_sig[i] = math.sqrt((d_b[i] * ss[2]) ** 2 + (n_b[i] ** 2 + e_b[i] ** 2) * pa ** 2)
    return RestBiases(gyro_ned, gyro_ned_sig, accel_ned, accel_ned_sig, gyro_body, gyro_body_sig, accel_body,
                      accel_body_sig, c_nb)
