"""Navigation consequence of an attitude error: the Schuler loop.

Model: the stationary, local-level (north-east-down) psi-angle error
equations of Titterton & Weston (2004, ch. 12, the Schuler oscillation and
the stationary INS error model; also Britting 1971),
spherical Earth of radius ``R = 6.371e6 m``, gravity ``g = 9.80665 m/s^2``,
vertical channel left out. The attitude error ``psi`` (rad) is defined by
``C_nb_est = (I + [psi x]) C_nb_true`` (the convention of
:func:`sins_sim.navigation.attitude.attitude_error`). With the vehicle at
rest the specific force is ``f_n = [0, 0, -g]`` and (``Omega_ie`` the Earth
rate, ``L`` the latitude)::

    d(dp_N)/dt = dv_N                       d(dp_E)/dt = dv_E
    d(dv_N)/dt = -g psi_E - 2 Omega_ie sin(L) dv_E
    d(dv_E)/dt =  g psi_N + 2 Omega_ie sin(L) dv_N
    d(psi)/dt  = eps_n - omega_ie x psi - d(omega_in)
    d(omega_in) = [dv_E / R - Omega_ie sin(L) dp_N / R,
                   -dv_N / R,
                   -dv_E tan(L) / R - Omega_ie cos(L) dp_N / R]

``-g psi_E`` is ``psi x f_n`` (a tilt leaks gravity into the horizontal
channel) and ``dv/R`` is the transport-rate error that levels the computed
frame back: together they make the Schuler loop, natural frequency
``w_s = sqrt(g/R)`` (period 84.4 min). ``eps_n`` is the gyro (or attitude
algorithm) drift in the navigation frame.

The attitude error given to :func:`position_error_from_attitude_error` is the
**free** error ``err(t) = psi(0) + int eps_n dt`` that the attitude
integration alone accumulates (for instance :func:`attitude_error` of a
coning-corrupted attitude against truth); the loop's own correction is the
extra state ``chi = psi - err``, so no derivative of ``err`` is needed.
The default ``earth_rate_rad_s = 0`` neglects Earth rate (then the latitude
has no effect and each horizontal channel is a pure Schuler oscillator,
``d2(dp_N)/dt2 + w_s^2 dp_N = -g err_E``); pass :data:`EARTH_RATE_RAD_S` to
keep the Coriolis and Earth-rate couplings.

Constant horizontal drift ``eps`` (rad/s) from rest, Earth rate neglected,
gives ``err = eps t`` and the closed form (Titterton & Weston 2004,
ch. 12)::

    dp(t) = R eps (t - sin(w_s t) / w_s)

in the horizontal direction perpendicular to the drift axis
(``dp_N = -R eps_E (...)``, ``dp_E = +R eps_N (...)``):
:func:`schuler_ramp_position_error`, :func:`equivalent_position_error_1h`.

References
----------
.. [1] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004, ch. 12.
.. [2] K. R. Britting, *Inertial Navigation Systems Analysis*, Wiley, 1971.
.. [3] C. F. Van Loan, "Computing integrals involving the matrix
   exponential", IEEE Trans. Autom. Control 23(3), 395-404, 1978 (the
   exact first-order-hold discretisation used here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.linalg import expm

from sins_sim import _validate as v
from sins_sim.units import HOUR

__all__ = [
    "GRAVITY_M_S2",
    "EARTH_RADIUS_M",
    "EARTH_RATE_RAD_S",
    "SCHULER_RAD_S",
    "NavigationError",
    "schuler_ramp_position_error",
    "equivalent_position_error_1h",
    "position_error_from_attitude_error",
    "strapdown_position_error",
]

GRAVITY_M_S2 = 9.80665
"""Gravity magnitude used by the error model (m/s^2, standard gravity)."""
EARTH_RADIUS_M = 6.371e6
"""Spherical Earth radius (m, mean radius)."""
EARTH_RATE_RAD_S = 7.292115e-5
"""Earth rotation rate (rad/s, WGS 84)."""
SCHULER_RAD_S = math.sqrt(GRAVITY_M_S2 / EARTH_RADIUS_M)
"""Schuler frequency ``w_s = sqrt(g/R)`` (rad/s); period ``2 pi / w_s`` = 5065 s = 84.4 min."""

# state layout of the error model
_PN, _PE, _VN, _VE, _CN, _CE, _CD = range(7)
_N_STATE = 7


@dataclass(frozen=True)
class NavigationError:
    """Horizontal navigation error driven by an attitude error.

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Times (s).
    position_m : ndarray, shape (N, 2)
        North and east position errors (m).
    velocity_m_s : ndarray, shape (N, 2)
        North and east velocity errors (m/s).
    tilt_rad : ndarray, shape (N, 3)
        Total attitude error ``psi`` (rad, N, E, D): the free error plus the
        Schuler-loop correction.
    """

    t_s: np.ndarray
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    tilt_rad: np.ndarray

    @property
    def horizontal_m(self) -> np.ndarray:
        """Horizontal position error magnitude (m), shape (N,)."""
        return np.hypot(self.position_m[:, 0], self.position_m[:, 1])


def schuler_ramp_position_error(t_s, drift_rad_s):
    """Position error of a constant horizontal drift through the Schuler loop (m).

    ``dp(t) = R eps (t - sin(w_s t) / w_s)``, ``w_s = sqrt(g/R)``: the
    response from rest of ``d2p/dt2 + w_s^2 p = g eps t`` (module docstring;
    Titterton & Weston 2004, ch. 12). Earth rate neglected. The error
    lies along the horizontal direction perpendicular to the drift axis
    (north error ``-dp`` for an east drift, east error ``+dp`` for a north drift).

    Parameters
    ----------
    t_s : array_like
        Time since the drift started (s).
    drift_rad_s : array_like
        Horizontal drift rate (rad/s); broadcasts against ``t_s``.

    Returns
    -------
    ndarray or float
        ``dp`` (m), the sign of ``drift_rad_s``.

    Examples
    --------
    >>> round(float(schuler_ramp_position_error(3600.0, 0.01 * np.pi / 180 / 3600)), 1)
    1353.4
    """
    t = np.asarray(t_s, dtype=np.float64)
    eps = np.asarray(drift_rad_s, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise ValueError("t_s: must be finite everywhere")
    if not np.all(np.isfinite(eps)):
        raise ValueError("drift_rad_s: must be finite everywhere")
    w = SCHULER_RAD_S
    out = EARTH_RADIUS_M * eps * (t - np.sin(w * t) / w)
    return out[()] if out.ndim == 0 else out


def equivalent_position_error_1h(drift_rad_s):
    """Position error (m) after 1 h of a constant horizontal gyro drift.

    ``R eps (3600 - sin(w_s 3600) / w_s)`` = ``eps * 2.792e10 m/(rad/s)``,
    i.e. about 1353 m (0.73 nmi) per 0.01 deg/h: the closed form of
    :func:`schuler_ramp_position_error` at ``t = 1 h`` (at 1 h the Schuler
    term adds 22 % to the ``R eps t`` a non-oscillating model would give).

    Parameters
    ----------
    drift_rad_s : array_like
        Horizontal drift rate (rad/s).

    Returns
    -------
    ndarray or float
        Position error (m), the sign of the drift.
    """
    return schuler_ramp_position_error(HOUR, drift_rad_s)


def _error_model(lat_rad: float, earth_rate_rad_s: float):
    """``A`` (7x7) and ``B`` (7x3) of ``dx/dt = A x + B err`` (module docstring)."""
    g, r = GRAVITY_M_S2, EARTH_RADIUS_M
    w = earth_rate_rad_s
    sl, cl, tl = math.sin(lat_rad), math.cos(lat_rad), math.tan(lat_rad)
    a = np.zeros((_N_STATE, _N_STATE))
    b = np.zeros((_N_STATE, 3))
    a[_PN, _VN] = 1.0
    a[_PE, _VE] = 1.0
    # dv_N' = -g psi_E - 2 W sinL dv_E,  psi = err + chi
    a[_VN, _CE] = -g
    b[_VN, 1] = -g
    a[_VN, _VE] = -2.0 * w * sl
    # dv_E' = g psi_N + 2 W sinL dv_N
    a[_VE, _CN] = g
    b[_VE, 0] = g
    a[_VE, _VN] = 2.0 * w * sl
    # chi' = -omega_ie x psi - d(omega_in)
    # -omega_ie x psi = [-W sinL psi_E, W sinL psi_N + W cosL psi_D, -W cosL psi_E]
    for row, col, coef in ((_CN, 1, -w * sl), (_CE, 0, w * sl), (_CE, 2, w * cl), (_CD, 1, -w * cl)):
        a[row, _CN + col] += coef
        b[row, col] += coef
    # -d(omega_in) = [-dv_E/R + W sinL dp_N/R, dv_N/R, dv_E tanL/R + W cosL dp_N/R]
    a[_CN, _VE] += -1.0 / r
    a[_CN, _PN] += w * sl / r
    a[_CE, _VN] += 1.0 / r
    a[_CD, _VE] += tl / r
    a[_CD, _PN] += w * cl / r
    return a, b


def _foh(a, b, h):
    """Exact discretisation over ``h`` with a linearly interpolated input (Van Loan 1978).

    ``expm([[A, B, 0], [0, 0, I/h], [0, 0, 0]] h) = [[Phi, G0, G1], ...]`` and
    ``x_{k+1} = Phi x_k + G0 u_k + G1 (u_{k+1} - u_k)``.
    """
    n, m = b.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n] = a
    big[:n, n : n + m] = b
    big[n : n + m, n + m :] = np.eye(m) / h
    e = expm(big * h)
    return e[:n, :n], e[:n, n : n + m], e[:n, n + m :]


def position_error_from_attitude_error(t_s, err_rad, lat_rad=0.0, *, earth_rate_rad_s=0.0) -> NavigationError:
    """Propagate a free attitude error through the Schuler loop.

    Solves the stationary local-level error model of the module docstring
    from zero position and velocity error, driven by the free attitude error
    ``err`` (rad, N-E-D components), taken as piecewise linear between the
    samples. The solution is exact for that input (first-order-hold
    discretisation by the matrix exponential, Van Loan 1978): a ramp
    ``err = eps t`` reproduces :func:`schuler_ramp_position_error` to
    rounding.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Strictly increasing times (s); uniform spacing is fastest.
    err_rad : array_like, shape (N, 3)
        Free attitude error (rad) about north, east, down, e.g.
        :func:`sins_sim.navigation.attitude.attitude_error` of the computed
        attitude against truth, with the navigation frame taken as NED.
    lat_rad : float
        Latitude (rad), ``|lat| < pi/2``; enters only through Earth rate.
    earth_rate_rad_s : float, keyword-only
        Earth rate (rad/s); 0 (default) neglects it, :data:`EARTH_RATE_RAD_S`
        keeps the Coriolis and Earth-rate couplings.

    Returns
    -------
    NavigationError

    Examples
    --------
    >>> t = np.arange(0.0, 3601.0, 10.0)
    >>> eps = 1e-7                                   # rad/s about east
    >>> err = np.column_stack([0 * t, eps * t, 0 * t])
    >>> ne = position_error_from_attitude_error(t, err)
    >>> bool(np.isclose(ne.position_m[-1, 0], -equivalent_position_error_1h(eps)))
    True
    """
    t = v.finite_array("", "t_s", t_s, ndim=1)
    err = v.finite_array("", "err_rad", err_rad, ndim=2)
    if err.shape != (t.shape[0], 3):
        raise ValueError(f"err_rad: must have shape ({t.shape[0]}, 3) (len(t_s), 3), got {err.shape}")
    if t.shape[0] == 0:
        raise ValueError("t_s: must not be empty")
    lat = v.finite("", "lat_rad", lat_rad)
    if abs(lat) >= 0.5 * math.pi:
        raise ValueError(f"lat_rad: must satisfy |lat| < pi/2, got {lat!r}")
    w = v.finite("", "earth_rate_rad_s", earth_rate_rad_s)
    hs = np.diff(t)
    if np.any(hs <= 0.0):
        raise ValueError("t_s: must be strictly increasing")

    a, b = _error_model(lat, w)
    n = t.shape[0]
    x = np.zeros((n, _N_STATE))
    if n > 1:
        uniform = bool(np.all(np.abs(hs - hs[0]) <= 1e-9 * hs[0]))
        cache = {}
        du = np.diff(err, axis=0)
        xk = np.zeros(_N_STATE)
        for k in range(n - 1):
            h = float(hs[0]) if uniform else float(hs[k])
            mats = cache.get(h)
            if mats is None:
                mats = cache[h] = _foh(a, b, h)
            phi, g0, g1 = mats
            xk = phi @ xk + g0 @ err[k] + g1 @ du[k]
            x[k + 1] = xk
    tilt = err + x[:, _CN : _CD + 1]
    return NavigationError(
        t_s=t.copy(),
        position_m=x[:, _PN : _PE + 1].copy(),
        velocity_m_s=x[:, _VN : _VE + 1].copy(),
        tilt_rad=tilt,
    )


def _rotate(q, vec):
    """``q (x) vec (x) q*`` for unit quaternions ``q`` (..., 4) and vectors (..., 3)."""
    q0 = q[..., :1]
    qv = q[..., 1:]
    t = 2.0 * np.cross(qv, vec)
    return vec + q0 * t + np.cross(qv, t)


def strapdown_position_error(t_s, q_est, q_true, f_body_true) -> np.ndarray:
    """Open-loop position error of resolving true specific force with a wrong attitude (m).

    ``df_n = C_nb_est f_b - C_nb_true f_b``; ``dv = int df_n dt``;
    ``dp = int dv dt`` (cumulative trapezoid, exact for piecewise-linear
    ``df_n`` in velocity and for linear ``dv`` in position). Gravity and the
    true motion cancel exactly because both solutions use the same truth
    position. There is no Schuler feedback (no transport-rate correction),
    so this is the short-time (``t << 84 min``) error, e.g.
    ``dp_N = -g psi_E t^2 / 2`` for a constant tilt of a level vehicle at rest.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Strictly increasing times (s).
    q_est, q_true : array_like, shape (N, 4)
        Computed and true ``q_nb`` at ``t_s`` (unit, scalar first).
    f_body_true : array_like, shape (N, 3)
        True specific force in the body frame (m/s^2) at ``t_s``.

    Returns
    -------
    ndarray, shape (N, 3)
        Position error in the navigation frame (m), zero at ``t_s[0]``.
    """
    t = v.finite_array("", "t_s", t_s, ndim=1)
    n = t.shape[0]
    if n == 0:
        raise ValueError("t_s: must not be empty")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("t_s: must be strictly increasing")
    arrays = {}
    for field, value, width in (("q_est", q_est, 4), ("q_true", q_true, 4), ("f_body_true", f_body_true, 3)):
        arr = v.finite_array("", field, value, ndim=2)
        if arr.shape != (n, width):
            raise ValueError(f"{field}: must have shape ({n}, {width}) (len(t_s), {width}), got {arr.shape}")
        arrays[field] = arr
    for field in ("q_est", "q_true"):
        norm = np.sqrt(np.sum(arrays[field] ** 2, axis=1))
        if np.any(np.abs(norm - 1.0) > 1e-6):
            raise ValueError(f"{field}: must hold unit quaternions (|q| = 1 +- 1e-06)")
    f = arrays["f_body_true"]
    df = _rotate(arrays["q_est"], f) - _rotate(arrays["q_true"], f)
    dv = cumulative_trapezoid(df, t, axis=0, initial=0.0)
    return cumulative_trapezoid(dv, t, axis=0, initial=0.0)
