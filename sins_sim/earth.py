"""The Earth model of the navigation loop: WGS-84 ellipsoid, Earth rate, normal gravity.

Foundation layer (like :mod:`sins_sim.units`): numpy only, imported by the
trajectory truth (``models``), the strapdown mechanization (``navigation``)
and the kernels. Truth and navigation use this one model, so its
simplifications never show up as navigation error; they only limit how well
the simulated Earth resembles the real one.

Conventions (docs/theory/navigation.md): geodetic latitude ``lat``
and longitude ``lon`` in rad, height ``h`` in m above the ellipsoid;
navigation frame local-level north-east-down (NED).

Functions accept scalars or arrays and broadcast like numpy.

.. autosummary::

   radii
   earth_rate_ned
   transport_rate_ned
   gravity_down
   gravity_ned
   horizontal_error_m

References
----------
.. [1] NIMA TR8350.2, "Department of Defense World Geodetic System 1984",
   3rd ed., 2000: defining constants (table 3.1), Somigliana normal gravity
   (eq. 4-1) and its height expansion (eq. 4-3).
.. [2] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004, sec. 3.7 (radii of curvature,
   transport rate) and sec. 3.8 (gravity).
.. [3] P. G. Savage, *Strapdown Analytics*, 2nd ed., 2007, sec. 5.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "WGS84_A_M", "WGS84_F", "WGS84_B_M", "WGS84_E2", "EARTH_RATE_RAD_S", "WGS84_GM_M3_S2",
    "GAMMA_EQUATOR_M_S2", "SOMIGLIANA_K", "WGS84_M",
    "radii", "earth_rate_ned", "transport_rate_ned", "gravity_down", "gravity_ned", "horizontal_error_m",
    "schuler_rate_rad_s", "level_body_from_ned",
]

#: Semi-major axis (m), [1] table 3.1.
WGS84_A_M = 6378137.0
#: Flattening, [1] table 3.1.
WGS84_F = 1.0 / 298.257223563
#: Semi-minor axis (m).
WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)
#: First eccentricity squared, ``e^2 = f (2 - f)``.
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
#: Earth rate (rad/s), [1] table 3.1 (docs/theory/frames.md).
EARTH_RATE_RAD_S = 7.292115e-5
#: Earth's gravitational constant (m^3/s^2), [1] table 3.1.
WGS84_GM_M3_S2 = 3.986004418e14
#: Normal gravity at the equator (m/s^2), [1] eq. 4-1.
GAMMA_EQUATOR_M_S2 = 9.7803253359
#: Somigliana's constant k, [1] eq. 4-1.
SOMIGLIANA_K = 0.00193185265241
#: ``m = omega^2 a^2 b / GM``, [1] eq. 4-3.
WGS84_M = EARTH_RATE_RAD_S ** 2 * WGS84_A_M ** 2 * WGS84_B_M / WGS84_GM_M3_S2


def radii(lat):
    """Meridian and prime-vertical radii of curvature (m) at geodetic latitude ``lat`` (rad).

    ``R_N = a (1 - e^2) / (1 - e^2 sin^2 lat)^(3/2)`` (north-south),
    ``R_E = a / sqrt(1 - e^2 sin^2 lat)`` (east-west); [2] eq. 3.83-3.84.

    Returns
    -------
    r_n, r_e : float or ndarray
    """
    s2 = np.sin(lat) ** 2
    w = 1.0 - WGS84_E2 * s2
    r_e = WGS84_A_M / np.sqrt(w)
    r_n = r_e * (1.0 - WGS84_E2) / w
    return r_n, r_e


def earth_rate_ned(lat):
    """Earth rate in the NED frame (rad/s), ``Omega [cos lat, 0, -sin lat]``; shape ``(..., 3)``."""
    lat = np.asarray(lat, dtype=float)
    return EARTH_RATE_RAD_S * np.stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)], axis=-1)


def transport_rate_ned(lat, h, v_ned):
    """Transport rate (rate of NED w.r.t. the Earth) in NED (rad/s); [2] eq. 3.87.

    ``[v_E / (R_E + h), -v_N / (R_N + h), -v_E tan(lat) / (R_E + h)]``.
    ``v_ned`` has shape ``(..., 3)`` (m/s).
    """
    v_ned = np.asarray(v_ned, dtype=float)
    r_n, r_e = radii(lat)
    ve = v_ned[..., 1] / (r_e + h)
    return np.stack([ve, -v_ned[..., 0] / (r_n + h), -ve * np.tan(lat)], axis=-1)


def gravity_down(lat, h):
    """Normal gravity magnitude (m/s^2) at geodetic latitude ``lat`` (rad) and height ``h`` (m).

    Somigliana's closed form on the ellipsoid ([1] eq. 4-1),
    ``gamma = gamma_e (1 + k sin^2 lat) / sqrt(1 - e^2 sin^2 lat)``, times the
    second-order height expansion of [1] eq. 4-3,
    ``1 - (2/a)(1 + f + m - 2 f sin^2 lat) h + 3 h^2 / a^2``.
    It includes the centrifugal acceleration of the Earth's rotation (it is
    the gravity a plumb line at rest measures).
    """
    s2 = np.sin(lat) ** 2
    g0 = GAMMA_EQUATOR_M_S2 * (1.0 + SOMIGLIANA_K * s2) / np.sqrt(1.0 - WGS84_E2 * s2)
    return g0 * (1.0 - 2.0 / WGS84_A_M * (1.0 + WGS84_F + WGS84_M - 2.0 * WGS84_F * s2) * h
                 + 3.0 * h * h / WGS84_A_M ** 2)


def gravity_ned(lat, h):
    """Normal gravity vector in NED (m/s^2), shape ``(..., 3)``.

    Along the ellipsoid normal only: the normal field's small north
    component off the ellipsoid (about ``8.1e-9 h sin(2 lat)`` m/s^2 per m of
    height, under 1 ug below 1.2 km) is neglected, in truth and navigation
    alike.
    """
    g = np.asarray(gravity_down(lat, h), dtype=float)
    z = np.zeros_like(g)
    return np.stack([z, z, g], axis=-1)


def horizontal_error_m(lat_est, lon_est, lat_true, lon_true, h_true=0.0):
    """North and east position error (m) along the Earth's surface, and their norm.

    ``dN = (lat_est - lat_true)(R_N + h)``, ``dE = wrap(lon_est - lon_true) cos(lat)(R_E + h)``
    at the true position: exact to first order in the error (the relative
    error of a 10 km error is about 1e-3).

    Returns
    -------
    d_north, d_east, horizontal : float or ndarray (m)
    """
    r_n, r_e = radii(lat_true)
    dlon = (np.asarray(lon_est) - lon_true + math.pi) % (2.0 * math.pi) - math.pi
    dn = (np.asarray(lat_est) - lat_true) * (r_n + h_true)
    de = dlon * np.cos(lat_true) * (r_e + h_true)
    return dn, de, np.hypot(dn, de)


def schuler_rate_rad_s(lat=0.0, h=0.0):
    """Schuler frequency ``sqrt(g / R)`` (rad/s) with ``R = sqrt(R_N R_E)`` (period about 84.4 min)."""
    r_n, r_e = radii(lat)
    return np.sqrt(gravity_down(lat, h) / (np.sqrt(r_n * r_e) + h))

#: Largest |latitude| (deg) of a trajectory: the simulator navigates in a north-east-down frame, whose transport
#: rate has tan(lat) and sec(lat) terms (shared by the trajectory reader and the trajectory model).
MAX_ABS_LAT_DEG = 89.5


def level_body_from_ned(vec_ned, heading_rad: float) -> np.ndarray:
    """NED vectors (..., 3) in the body axes of a level vehicle heading ``heading_rad`` from north towards east: the
    local-level frame turned by the heading about down, ``(N cos h + E sin h, -N sin h + E cos h, D)``."""
    v = np.asarray(vec_ned, dtype=np.float64)
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return np.stack([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1], v[..., 2]], axis=-1)
