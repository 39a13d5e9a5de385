"""The Earth's rate on a bench's gyros: a recording's ``site`` (latitude, orientation, table axis) made motion.

A gyro measures its body's angle with respect to inertial space, so a unit on a still bench reads the
Earth's rate, ``omega_ie^n = Omega (cos lat, 0, -sin lat)`` in north-east-down (Titterton & Weston,
"Strapdown Inertial Navigation Technology", 2nd ed., 2004, sec. 3.7; :func:`sins_sim.earth.earth_rate_ned`),
resolved in the unit's axes: ``omega_ie^b = C_nb^T omega_ie^n``. ``C_nb`` (body to NED) is the 3-2-1 sequence of
the site's heading, pitch and roll (Titterton & Weston sec. 3.6.3, Euler angles).

On a rate table turning by ``theta`` about the unit vector ``u`` (NED, fixed to the bench), the unit's
orientation is ``R(u, theta) C_nb0``, so (Rodrigues' formula of a rotation by ``theta`` about ``u``, Titterton &
Weston sec. 3.6.4) the Earth's rate about gyro axis ``e_i`` is

``w_i(theta) = e_i . C_nb0^T [p + q cos theta - (u x q) sin theta]``, ``p = (u . omega) u``, ``q = omega - p``,

and the table's own rate about ``e_i`` is ``theta' (C_nb0^T u)_i``: a recording's ``sins_angle`` of that axis
is ``theta (C_nb0^T u)_i``. The Earth's angle a gyro adds is the integral of ``w_i`` (exact for a still bench,
a constant rate; on a table evaluated on a fine grid, :class:`EarthRateMotion`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import CubicSpline

from sins_sim.earth import EARTH_RATE_RAD_S, earth_rate_ned
from sins_sim.io.recording import SITE_AXES
from sins_sim.models.motion import ConstantRateMotion
from sins_sim.models.motion.single_axis import _Motion
from sins_sim.units import DEG

__all__ = ["EARTH_RATE_RAD_S", "dcm_nb", "SiteGeometry", "EarthRateMotion", "earth_motions", "table_on_axes"]

#: Step (s) of the grid on which the Earth's angle under a moving table is integrated (trapezoid): the error of
#: the integral over ``T`` is ``T h^2 / 12 max|w''|``, ``|w''| <= Omega (|theta''| + theta'^2)``; a table sine of
#: 3 arcmin at 230 Hz (theta'' = 600 rad/s^2) over 20 s leaves 20 * 1e-8 / 12 * 7.3e-5 * 600 = 7e-10 rad.
EARTH_GRID_S = 1.0e-4


def dcm_nb(heading_rad: float, pitch_rad: float, roll_rad: float) -> np.ndarray:
    """Body-to-NED direction cosine matrix of the 3-2-1 (heading, pitch, roll) sequence.

    Titterton & Weston, 2nd ed., sec. 3.6.3: ``C_nb = R_z(psi) R_y(theta) R_x(phi)``, each ``R`` a right-handed
    turn about one axis (the project's 3-2-1 convention, ``sins_sim.navigation.attitude``).
    """
    cp, sp = math.cos(heading_rad), math.sin(heading_rad)
    ct, st = math.cos(pitch_rad), math.sin(pitch_rad)
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    rz = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[ct, 0.0, st], [0.0, 1.0, 0.0], [-st, 0.0, ct]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


class SiteGeometry:
    """A recording's ``meta.site`` as vectors in the unit's axes (table at zero).

    Parameters
    ----------
    site : dict
        ``{"latitude_deg":, "orientation_ned": {"heading_deg":, "pitch_deg":, "roll_deg":},
        "table_axis_ned": [n, e, d] (optional)}``, as :mod:`sins_sim.io.recording` checks it.

    Attributes
    ----------
    c_nb : ndarray (3, 3)
        Body to NED at the table's zero angle.
    earth_body : ndarray (3,)
        The Earth's rate in the unit's x, y, z axes, table at zero (rad/s).
    table_body : ndarray (3,) or None
        The table's axis in the unit's axes (a unit vector), or None when the site gives none.
    """

    def __init__(self, site: dict):
        ori = site["orientation_ned"]
        self.latitude_rad = float(site["latitude_deg"]) * DEG
        self.c_nb = dcm_nb(float(ori["heading_deg"]) * DEG, float(ori["pitch_deg"]) * DEG, float(ori["roll_deg"]) * DEG)
        self.omega_ned = earth_rate_ned(self.latitude_rad)
        self.earth_body = self.c_nb.T @ self.omega_ned
        u = site.get("table_axis_ned")
        self.u_ned = None if u is None else np.asarray(u, dtype=np.float64) / np.linalg.norm(u)
        self.table_body = None if self.u_ned is None else self.c_nb.T @ self.u_ned

    def rate_terms(self, axis: str) -> tuple:
        """``(a, b, s)`` of the Earth's rate ``a + b cos theta + s sin theta`` about gyro ``axis`` (rad/s)."""
        i = SITE_AXES.index(axis)
        if self.u_ned is None:
            return float(self.earth_body[i]), 0.0, 0.0
        p = float(self.u_ned @ self.omega_ned) * self.u_ned
        q = self.omega_ned - p
        c = self.c_nb.T
        return float((c @ p)[i]), float((c @ q)[i]), float(-(c @ np.cross(self.u_ned, q))[i])


class EarthRateMotion(_Motion):
    """The Earth's angle about one gyro axis under a table turning by ``theta(t)``, integrated from t = 0.

    ``rate(t) = a + b cos theta(t) + s sin theta(t)`` (exact at any ``t``); the angle is its integral on a
    grid of :data:`EARTH_GRID_S` over ``[0, t_end]`` (trapezoid, then a cubic spline through the grid),
    continued at the end rates outside.
    """

    def __init__(self, terms: tuple, theta, t_end: float):
        self.a, self.b, self.s = (float(x) for x in terms)
        self.theta = theta
        n = max(4, int(math.ceil(float(t_end) / EARTH_GRID_S)) + 1)
        self._t = np.linspace(0.0, max(float(t_end), 3.0 * EARTH_GRID_S), n)
        ang = cumulative_trapezoid(self._rate(self._t), self._t, initial=0.0)
        self._spline = CubicSpline(self._t, ang)
        self._ends = (float(ang[0]), float(ang[-1]))

    def _rate(self, t):
        th = self.theta.angle_rate(t)[0]
        return self.a + self.b * np.cos(th) + self.s * np.sin(th)

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        rate = self._rate(t)
        t0, t1 = self._t[0], self._t[-1]
        angle = self._spline(np.clip(t, t0, t1))
        angle = np.where(t < t0, self._ends[0] + rate * (t - t0), angle)
        angle = np.where(t > t1, self._ends[1] + rate * (t - t1), angle)
        return angle, rate


class _ScaledMotion(_Motion):
    """``k`` times another motion (a table's angle seen about a gyro axis at an angle to the table's)."""

    def __init__(self, base, k: float):
        self.base, self.k = base, float(k)

    def angle_rate(self, t):
        a, r = self.base.angle_rate(t)
        return self.k * a, self.k * r


def table_on_axes(site: dict, axes, theta) -> dict:
    """The table's angle about each gyro axis, ``theta (C_nb0^T u)_i``, for a table turning by ``theta``."""
    geo = SiteGeometry(site)
    if geo.table_body is None:
        raise ValueError("site.table_axis_ned: is required to turn a table under a unit placed by site")
    return {a: _ScaledMotion(theta, geo.table_body[SITE_AXES.index(a)]) for a in axes}


def earth_motions(site: dict, axes, t_end: float, table: dict | None = None) -> dict:
    """The Earth's angle about each gyro axis (axis -> motion) for a unit placed by ``site``.

    Parameters
    ----------
    site : dict
        A recording's ``meta.site``.
    axes : sequence of str
        Gyro axes (names of ``x, y, z``).
    t_end : float
        The span (s) the motions must cover exactly (beyond it they continue at their end rates).
    table : dict axis -> motion, or None
        The table's angle about each gyro axis (``sins_angle``), or None for a still bench. The table's own
        angle ``theta`` is recovered from them by least squares on the table axis:
        ``theta = sum_i t_i sins_i / sum_i t_i^2`` with ``t = C_nb0^T u``.

    Raises
    ------
    ValueError
        A moving table without ``site.table_axis_ned``, or one whose axis is perpendicular to every gyro axis
        recorded (its angle is then not in the recording).
    """
    geo = SiteGeometry(site)
    if table is None:
        return {a: ConstantRateMotion(float(geo.earth_body[SITE_AXES.index(a)])) for a in axes}
    if geo.table_body is None:
        raise ValueError("site.table_axis_ned: is required with a moving table (sins_angle): the Earth's rate on the "
                         "gyros turns with the table about that axis")
    w = np.array([geo.table_body[SITE_AXES.index(a)] for a in axes])
    norm = float(w @ w)
    if norm < 1.0e-6:
        raise ValueError(f"site.table_axis_ned: the table turns about an axis perpendicular to the recorded gyro "
                         f"axes {list(axes)}, so its angle is not in the recording")
    theta = _Combined([table[a] for a in axes], w / norm)
    return {a: EarthRateMotion(geo.rate_terms(a), theta, t_end) for a in axes}


class _Combined(_Motion):
    """``sum_i w_i m_i(t)``: the table's own angle from its angles about the gyro axes."""

    def __init__(self, parts, weights):
        self.parts, self.weights = list(parts), [float(x) for x in weights]

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        angle, rate = np.zeros_like(t), np.zeros_like(t)
        for m, w in zip(self.parts, self.weights):
            a, r = m.angle_rate(t)
            angle, rate = angle + w * a, rate + w * r
        return angle, rate
