"""Strapdown inertial navigation in a local-level NED frame on the WGS-84 ellipsoid.

:class:`StrapdownNavigator` turns gyro angle increments and accelerometer
velocity increments (body frame, one pair per input sample) into latitude,
longitude, height, NED velocity and the attitude ``q_nb``. It is the
textbook north-pointing local-level mechanization (no wander angle) with the
two-rate structure of Savage (1998): coning and sculling sums accumulated at the input rate,
the navigation update every ``n_sub`` input samples.

.. autosummary::

   StrapdownNavigator
   NavSolution
   height_aid_gains
   SCULLING_ALGORITHMS
   VERTICAL_MODES

Frames and units (docs/theory/navigation.md): body axes are the
gyro/accelerometer sensitive axes; navigation frame north-east-down;
``q_nb`` Hamilton, scalar first, body to NED; ``lat``, ``lon`` geodetic in
rad; ``h`` in m above the ellipsoid, positive up; ``v_ned`` in m/s (``v_D``
positive down); increments in rad and m/s; times in s. The Earth is
:mod:`sins_sim.earth` (the same model the trajectory truth uses).

Equations (update ``m``, period ``T = n_sub dt``; every line names its
source; the kernel :mod:`sins_sim._kernels.strapdown` has the full list)

High rate, input sample ``l`` (Savage 1998 Parts 1 and 2)::

    beta_m += (1/2 alpha_{l-1} + c2 dtheta_{l-1} + c1 dtheta_{l-2}) x dtheta_l
    S_m    += (1/2 alpha_{l-1} + s2 dtheta_{l-1} + s1 dtheta_{l-2}) x dv_l
            + (1/2 upsilon_{l-1} + s2 dv_{l-1} + s1 dv_{l-2}) x dtheta_l
    alpha_m = sum dtheta_l,   upsilon_m = sum dv_l

``(c1, c2)`` from ``coning`` and ``(s1, s2)`` from ``sculling``: ``(0, 0)``
"none", ``(0, 1/12)`` "two_sample" (Savage 1998; with one sample per update
it is ``(1/12)(dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k)``, Ignagni 1996),
``(-1/60, 7/60)`` "three_sample" (Ignagni 1990 Algorithm E in
previous-sample form; the sculling coefficients equal the coning ones by
the duality of Ignagni 1998); "four_sample" adds ``dtheta_{l-3}`` (the
kernel keeps three previous increments, lag coefficients
``(113/840, -13/420, 1/280)``); coefficients given as an array (a
filter-tuned design, :func:`sins_sim.navigation.coning.tuned_coefficients`)
may differ per component.

Low rate (state at ``t_{m-1}`` extrapolated to ``t_{m-1/2}``,
``x_{m-1/2} = (3 x_{m-1} - x_{m-2}) / 2``, Savage 1998 Part 2)::

    zeta   = (omega_ie^n + omega_en^n) T                        Titterton & Weston 2004, sec. 3.7
    dV_n   = (I - 1/2 [zeta x]) C_nb[m-1] (upsilon + 1/2 alpha x upsilon + S)   Savage 1998 Part 2
    v_m    = v_{m-1} + dV_n + (g^n - (2 omega_ie^n + omega_en^n) x v) T         Savage 1998 Part 2
    q_nb,m = q(-zeta) (x) q_nb,m-1 (x) q(alpha + beta)            Savage 1998 Part 1
    lat, lon, h: trapezoidal in v, radii from sins_sim.earth.radii

with ``g^n = [0, 0, gamma(lat, h)]``, Somigliana's normal gravity with the
height correction (:func:`sins_sim.earth.gravity_down`).

Vertical channel. ``vertical="free"`` is pure inertial and **unstable**:
gravity decreases with height (``dg/dh = -2 g / R``), so a height error
grows like ``cosh(t / tau_v)`` with ``tau_v = sqrt(R / 2g)``, about 570 s
(Titterton & Weston 2004, ch. 3; Widnall & Sinha 1980). ``vertical=
"height_aid"`` closes the classical third-order loop of Widnall & Sinha
(1980) on the height error ``dh = h - h_aid``::

    dh/dt   = -v_D - k1 dh
    dv_D/dt = (mechanization) + k2 dh + a_c
    da_c/dt = k3 dh

whose error dynamics have the characteristic polynomial
``s^3 + k1 s^2 + (k2 + dg/dh) s + k3``; :func:`height_aid_gains` puts all
three roots at ``-1/tau`` (``tau = height_aid_tau_s``), the conventional
"critically damped" choice (Widnall & Sinha discuss it and derive
stochastically optimal alternatives)::

    k1 = 3 / tau,   k2 = 3 / tau^2 - dg/dh,   k3 = 1 / tau^3

A constant vertical accelerometer error ``b`` (down) then gives the height
error ``-b t^2 exp(-t/tau) / 2`` and ``a_c -> -b``.

Limits: latitude and longitude are singular at the poles (``tan lat``,
``1 / cos lat``); the navigator requires ``|lat0| < pi/2`` and is meant for
terrestrial latitudes. The first update extrapolates with zero-order hold
(no history yet); the coning/sculling corrections use ``dtheta_prev`` and
``dv_prev`` (zeros by default) for the samples before the first.

References
----------
.. [1] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: Attitude algorithms", J. Guidance, Control, and Dynamics
   21(1), 19-28, 1998.
.. [2] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 2: Velocity and position algorithms", J. Guidance, Control,
   and Dynamics 21(2), 208-221, 1998.
.. [3] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004, ch. 3 and 11.
.. [4] M. B. Ignagni, "Optimal strapdown attitude integration algorithms",
   J. Guidance, Control, and Dynamics 13(2), 363-369, 1990.
.. [5] M. B. Ignagni, "Efficient class of optimized coning compensation
   algorithms", J. Guidance, Control, and Dynamics 19(2), 424-429, 1996.
.. [6] M. B. Ignagni, "Duality of optimal strapdown sculling and coning
   compensation algorithms", Navigation (J. ION) 45(2), 85-95, 1998.
.. [7] W. S. Widnall, P. K. Sinha, "Optimizing the gains of the
   baro-inertial vertical channel", J. Guidance and Control 3(2), 172-178, 1980.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral

import numpy as np

from sins_sim import _validate as v
from sins_sim import earth
from sins_sim._kernels import nav as knav
from sins_sim._kernels import strapdown as ksd
from sins_sim.navigation.attitude import _increments, _unit_quat
from sins_sim.navigation.coning import CONING_ALGORITHMS, coefficient_matrix

__all__ = [
    "SCULLING_ALGORITHMS",
    "VERTICAL_MODES",
    "NavSolution",
    "StrapdownNavigator",
    "height_aid_gains",
]

#: Sculling compensations accepted by :class:`StrapdownNavigator` (same names and
#: coefficients as the coning algorithms, by duality; module docstring).
SCULLING_ALGORITHMS = CONING_ALGORITHMS
#: Name reported for a coning or sculling compensation given as coefficients (a filter-tuned design).
TUNED_NAME = "filter_tuned"
#: Vertical-channel modes: pure inertial (unstable) or the third-order height-aided loop.
VERTICAL_MODES = ("free", "height_aid")
#: The height-aiding time constant must span at least this many update periods
#: (the loop is integrated with one Euler step per update; ``T / tau <= 0.1``
#: keeps the discrete poles within 1 % of the continuous design).
MIN_TAU_UPDATES = 10.0
#: Height step (m) of the central difference for ``dg/dh``: exact for the
#: quadratic height expansion of :func:`sins_sim.earth.gravity_down`.
_DGDH_STEP_M = 100.0


@dataclass(frozen=True)
class NavSolution:
    """Navigation output, one row per navigation update.

    Attributes
    ----------
    t_s : ndarray, shape (M,)
        Time of each update since the navigator's start (s), ``k T``.
    lat_rad, lon_rad : ndarray, shape (M,)
        Geodetic latitude and longitude (rad); longitude in ``[-pi, pi)``.
    h_m : ndarray, shape (M,)
        Height above the WGS-84 ellipsoid (m, up).
    v_ned_m_s : ndarray, shape (M, 3)
        Velocity with respect to the Earth in NED (m/s).
    q_nb : ndarray, shape (M, 4)
        Attitude, body to NED (Hamilton, scalar first, unit norm).
    """

    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    v_ned_m_s: np.ndarray
    q_nb: np.ndarray

    def __len__(self) -> int:
        return int(self.t_s.shape[0])


def height_aid_gains(tau_s, lat_rad, h_m=0.0):
    """Gains of the third-order height-aided vertical loop, triple pole at ``-1/tau``.

    ``k1 = 3/tau``, ``k2 = 3/tau^2 - dg/dh``, ``k3 = 1/tau^3`` (module
    docstring; Widnall & Sinha 1980 for the loop), with ``dg/dh`` (about
    ``-2 g / R = -3.1e-6 s^-2``) of :func:`sins_sim.earth.gravity_down` at
    ``(lat_rad, h_m)``, so that the error dynamics
    ``s^3 + k1 s^2 + (k2 + dg/dh) s + k3`` equal ``(s + 1/tau)^3``.

    Parameters
    ----------
    tau_s : float
        Loop time constant (s), > 0.
    lat_rad : float
        Latitude (rad) at which ``dg/dh`` is evaluated.
    h_m : float
        Height (m) at which ``dg/dh`` is evaluated.

    Returns
    -------
    k1, k2, k3 : float
        Gains in 1/s, 1/s^2, 1/s^3.

    Examples
    --------
    >>> k1, k2, k3 = height_aid_gains(100.0, 0.0)
    >>> round(k1, 6), round(k2 * 1e4, 4), round(k3 * 1e6, 6)
    (0.03, 3.0309, 1.0)
    """
    tau = v.positive("", "tau_s", tau_s)
    lat = v.finite("", "lat_rad", lat_rad)
    h = v.finite("", "h_m", h_m)
    dgdh = _dg_dh(lat, h)
    return 3.0 / tau, 3.0 / tau ** 2 - dgdh, 1.0 / tau ** 3


def _dg_dh(lat: float, h: float) -> float:
    step = _DGDH_STEP_M
    return float(earth.gravity_down(lat, h + step) - earth.gravity_down(lat, h - step)) / (2.0 * step)


# --- validation -------------------------------------------------------------------


def _vector(field, value, n) -> np.ndarray:
    arr = v.finite_array("", field, value, ndim=1)
    if arr.shape != (n,):
        raise ValueError(f"{field}: must have shape ({n},), got {arr.shape}")
    return arr.copy()


def _prev_pair(field, value) -> np.ndarray:
    """``[x_(-3), x_(-2), x_(-1)]``; a (2, 3) input has ``x_(-3) = 0``."""
    out = np.zeros((3, 3))
    if value is None:
        return out
    arr = v.finite_array("", field, value, ndim=2)
    if arr.shape not in ((2, 3), (3, 3)):
        raise ValueError(f"{field}: must have shape (2, 3) ([x_(-2), x_(-1)]) or (3, 3), got {arr.shape}")
    out[3 - arr.shape[0]:] = arr
    return out


def _compensation(field, value):
    """``(name, (3, 3) coefficients)`` of a coning or sculling choice."""
    if isinstance(value, str):
        _name(field, value, CONING_ALGORITHMS)
        return value, coefficient_matrix(value, field)
    return TUNED_NAME, coefficient_matrix(value, field)


def _n_sub(value) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"n_sub: must be an integer >= 1, got {value!r}")
    if int(value) < 1:
        raise ValueError(f"n_sub: must be an integer >= 1, got {value!r}")
    return int(value)


def _name(field, value, allowed) -> str:
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(f"{field}: must be one of {sorted(allowed)}, got {value!r}")
    return value


class StrapdownNavigator:
    """Streaming strapdown navigator, local-level NED on WGS-84 (module docstring).

    Aligned to the truth at the start: the constructor takes the initial
    position, velocity and attitude. :meth:`process` takes chunks of
    increments of any sizes; the state (including partial coning/sculling
    sums and the increments before the chunk) is carried between calls, so
    chunked processing gives the same bits as one call.

    Parameters
    ----------
    lat0_rad : float
        Initial geodetic latitude (rad), ``|lat0_rad| < pi/2``.
    lon0_rad : float
        Initial longitude (rad); wrapped to ``[-pi, pi)``.
    h0_m : float
        Initial height above the ellipsoid (m, up).
    v0_ned_m_s : array_like, shape (3,)
        Initial velocity with respect to the Earth, NED (m/s).
    q0_nb : array_like, shape (4,)
        Initial attitude, body to NED (unit quaternion, scalar first; a norm
        within 1e-6 of one is renormalised).
    dt_s : float
        Input sample period (s), > 0: the interval each increment integrates over.
    coning : {"none", "two_sample", "three_sample", "four_sample"} or array_like
        Coning compensation of the attitude update (Savage 1998; Ignagni 1990),
        or its coefficients, shape (3,) or (3, 3) ``[component, lag - 1]``
        (:func:`sins_sim.navigation.coning.coefficient_matrix`).
    sculling : {"none", "two_sample", "three_sample", "four_sample"} or array_like
        Sculling compensation of the velocity update (Savage 1998; Ignagni 1998),
        or its coefficients, as ``coning``.
    n_sub : int
        Input samples per navigation update (>= 1); the update period is
        ``n_sub * dt_s`` and one output row comes per update.
    vertical : {"free", "height_aid"}
        Vertical channel: pure inertial (unstable, time constant about 570 s)
        or the third-order loop on ``h - h_aid`` (:func:`height_aid_gains`).
    height_aid_tau_s : float
        Time constant of the height-aided loop (s), at least 10 update
        periods; used only with ``vertical="height_aid"``.
    dtheta_prev : array_like, shape (2, 3) or (3, 3), optional
        The gyro increments before the first sample, ``[dtheta_(-2), dtheta_(-1)]``
        or ``[dtheta_(-3), dtheta_(-2), dtheta_(-1)]`` (rad); zeros by default.
    dv_prev : array_like, shape (2, 3) or (3, 3), optional
        The velocity increments before the first sample (m/s); zeros by default.

    Raises
    ------
    ValueError
        For any invalid argument; the message names it.

    Examples
    --------
    At rest at 45 deg N, level, heading north: ideal increments keep the
    solution at the start.

    >>> from sins_sim import earth
    >>> lat, dt = np.radians(45.0), 0.01
    >>> w_ib = earth.earth_rate_ned(lat)               # body = NED here
    >>> f_b = -earth.gravity_ned(lat, 0.0)
    >>> nav = StrapdownNavigator(lat, 0.0, 0.0, np.zeros(3), [1.0, 0, 0, 0], dt)
    >>> sol = nav.process(np.tile(w_ib * dt, (6000, 1)), np.tile(f_b * dt, (6000, 1)))
    >>> len(sol), bool(abs(sol.lat_rad[-1] - lat) < 1e-12), bool(np.all(np.abs(sol.v_ned_m_s) < 1e-10))
    (6000, True, True)
    """

    def __init__(self, lat0_rad, lon0_rad, h0_m, v0_ned_m_s, q0_nb, dt_s, *, coning="two_sample",
                 sculling="two_sample", n_sub=1, vertical="free", height_aid_tau_s=100.0,
                 dtheta_prev=None, dv_prev=None):
        lat0 = v.finite("", "lat0_rad", lat0_rad)
        if not abs(lat0) < 0.5 * math.pi:
            raise ValueError(f"lat0_rad: must satisfy |lat0_rad| < pi/2 (the NED mechanization is "
                             f"singular at the poles), got {lat0!r}")
        lon0 = v.finite("", "lon0_rad", lon0_rad)
        lon0 = (lon0 + math.pi) % (2.0 * math.pi) - math.pi
        h0 = v.finite("", "h0_m", h0_m)
        vel0 = _vector("v0_ned_m_s", v0_ned_m_s, 3)
        q0 = _unit_quat("q0_nb", q0_nb)
        self._dt = v.positive("", "dt_s", dt_s)
        self._coning, self._ccoef = _compensation("coning", coning)
        self._sculling, self._scoef = _compensation("sculling", sculling)
        self._n_sub = _n_sub(n_sub)
        self._vertical = _name("vertical", vertical, VERTICAL_MODES)
        self._tau = v.positive("", "height_aid_tau_s", height_aid_tau_s)
        big_t = self._n_sub * self._dt
        if self._vertical == "height_aid" and self._tau < MIN_TAU_UPDATES * big_t:
            raise ValueError(
                f"height_aid_tau_s: must be >= {MIN_TAU_UPDATES:g} update periods "
                f"({MIN_TAU_UPDATES:g} * n_sub * dt_s = {MIN_TAU_UPDATES * big_t!r} s), got {self._tau!r}")
        prev_dth = _prev_pair("dtheta_prev", dtheta_prev)
        prev_dv = _prev_pair("dv_prev", dv_prev)
        if self._vertical == "height_aid":
            self._gains = height_aid_gains(self._tau, lat0, h0)
        else:
            self._gains = (0.0, 0.0, 0.0)

        s = np.zeros(ksd.STATE_SIZE)
        s[ksd.ST_LAT] = lat0
        s[ksd.ST_LON] = lon0
        s[ksd.ST_H] = h0
        s[ksd.ST_V:ksd.ST_V + 3] = vel0
        s[ksd.ST_Q:ksd.ST_Q + 4] = q0
        s[ksd.ST_DTH3:ksd.ST_DTH3 + 3] = prev_dth[0]
        s[ksd.ST_DTH2:ksd.ST_DTH2 + 3] = prev_dth[1]
        s[ksd.ST_DTH1:ksd.ST_DTH1 + 3] = prev_dth[2]
        s[ksd.ST_DV3:ksd.ST_DV3 + 3] = prev_dv[0]
        s[ksd.ST_DV2:ksd.ST_DV2 + 3] = prev_dv[1]
        s[ksd.ST_DV1:ksd.ST_DV1 + 3] = prev_dv[2]
        # no history before the first update: the extrapolation starts as a zero-order hold
        s[ksd.ST_PREV_LAT] = lat0
        s[ksd.ST_PREV_H] = h0
        s[ksd.ST_PREV_V:ksd.ST_PREV_V + 3] = vel0
        self._state = s
        self._n_samples = 0
        self._n_updates = 0

    # --- configuration ----------------------------------------------------------

    @property
    def dt_s(self) -> float:
        """Input sample period (s)."""
        return self._dt

    @property
    def n_sub(self) -> int:
        """Input samples per navigation update."""
        return self._n_sub

    @property
    def update_period_s(self) -> float:
        """Navigation update period ``n_sub * dt_s`` (s)."""
        return self._n_sub * self._dt

    @property
    def coning(self) -> str:
        """Coning compensation name (``"filter_tuned"`` when given as coefficients)."""
        return self._coning

    @property
    def sculling(self) -> str:
        """Sculling compensation name (``"filter_tuned"`` when given as coefficients)."""
        return self._sculling

    @property
    def coning_coefficients(self) -> np.ndarray:
        """Coning coefficients ``[component, lag - 1]`` (copy)."""
        return self._ccoef.copy()

    @property
    def sculling_coefficients(self) -> np.ndarray:
        """Sculling coefficients ``[component, lag - 1]`` (copy)."""
        return self._scoef.copy()

    @property
    def vertical(self) -> str:
        """Vertical-channel mode."""
        return self._vertical

    @property
    def height_aid_tau_s(self) -> float:
        """Time constant of the height-aided loop (s)."""
        return self._tau

    @property
    def height_aid_gains(self) -> tuple:
        """``(k1, k2, k3)`` of the vertical loop (1/s, 1/s^2, 1/s^3); zeros when free."""
        return self._gains

    # --- state --------------------------------------------------------------------

    @property
    def lat_rad(self) -> float:
        """Current latitude (rad)."""
        return float(self._state[ksd.ST_LAT])

    @property
    def lon_rad(self) -> float:
        """Current longitude (rad), in ``[-pi, pi)``."""
        return float(self._state[ksd.ST_LON])

    @property
    def h_m(self) -> float:
        """Current height above the ellipsoid (m, up)."""
        return float(self._state[ksd.ST_H])

    @property
    def v_ned_m_s(self) -> np.ndarray:
        """Current NED velocity (m/s, copy)."""
        return self._state[ksd.ST_V:ksd.ST_V + 3].copy()

    @property
    def q_nb(self) -> np.ndarray:
        """Current attitude ``q_nb`` (copy)."""
        return self._state[ksd.ST_Q:ksd.ST_Q + 4].copy()

    @property
    def vertical_accel_correction_m_s2(self) -> float:
        """The vertical loop's acceleration correction ``a_c`` (m/s^2, down positive)."""
        return float(self._state[ksd.ST_ACC])

    @property
    def n_samples(self) -> int:
        """Input samples processed so far."""
        return self._n_samples

    @property
    def n_updates(self) -> int:
        """Navigation updates completed so far (the time is ``n_updates * update_period_s``)."""
        return self._n_updates

    @property
    def pending_samples(self) -> int:
        """Input samples accumulated towards the next update (``0 .. n_sub - 1``)."""
        return int(self._state[ksd.ST_COUNT])

    def state_array(self) -> np.ndarray:
        """A copy of the kernel state (layout ``sins_sim._kernels.strapdown.ST_*``)."""
        return self._state.copy()

    def apply_correction(self, dpos_ned_m=None, dv_ned_m_s=None, psi_ned_rad=None) -> None:
        """Subtract an estimated navigation error from the current state (the feedback of an aiding filter).

        The errors are "computed minus true", as the error-state filter of
        :mod:`sins_sim.navigation.ekf` defines them: position error in NED metres
        ``dr = ((lat_c - lat) (R_N + h), (lon_c - lon) (R_E + h) cos lat, -(h_c - h))``,
        velocity error ``dv = v_c - v``, attitude error ``psi`` with
        ``C_nb_c = (I + [psi x]) C_nb`` (the project's convention). The correction is their exact inverse
        at the current point::

            lat -= dr_N / (R_N + h),   lon -= dr_E / ((R_E + h) cos lat),   h += dr_D
            v   -= dv,                 q_nb <- q(-psi) (x) q_nb   (normalised)

        (radii of :func:`sins_sim.earth.radii` at the current latitude). The mid-interval extrapolation
        of the next update reads the state of the update before the last (``ST_PREV_*``): the same
        correction is applied to it, so the extrapolated rates see no step; likewise the vertical loop's
        height error. The increments before the correction and the partial coning/sculling sums of the
        current update are body-frame quantities and stay as they are.

        Parameters
        ----------
        dpos_ned_m : array_like, shape (3,), optional
            Position error north, east, down (m); none when omitted.
        dv_ned_m_s : array_like, shape (3,), optional
            Velocity error NED (m/s); none when omitted.
        psi_ned_rad : array_like, shape (3,), optional
            Attitude error ``psi`` about north, east, down (rad); none when omitted.

        Raises
        ------
        ValueError
            For a wrong shape or a non-finite value (the message names the argument).
        """
        s = self._state
        if dpos_ned_m is not None:
            dr = _vector("dpos_ned_m", dpos_ned_m, 3)
            lat, h = s[ksd.ST_LAT], s[ksd.ST_H]
            r_n, r_e = earth.radii(lat)
            dlat = dr[0] / (r_n + h)
            dlon = dr[1] / ((r_e + h) * math.cos(lat))
            s[ksd.ST_LAT] -= dlat
            s[ksd.ST_PREV_LAT] -= dlat
            s[ksd.ST_LON] = (s[ksd.ST_LON] - dlon + math.pi) % (2.0 * math.pi) - math.pi
            s[ksd.ST_H] += dr[2]
            s[ksd.ST_PREV_H] += dr[2]
            if self._vertical == "height_aid":
                s[ksd.ST_DH] += dr[2]
        if dv_ned_m_s is not None:
            dvel = _vector("dv_ned_m_s", dv_ned_m_s, 3)
            s[ksd.ST_V:ksd.ST_V + 3] -= dvel
            s[ksd.ST_PREV_V:ksd.ST_PREV_V + 3] -= dvel
        if psi_ned_rad is not None:
            psi = _vector("psi_ned_rad", psi_ned_rad, 3)
            qc = np.empty(4)
            q = np.empty(4)
            knav.rotvec_to_quat(-psi, qc)
            knav.quat_mul(qc, s[ksd.ST_Q:ksd.ST_Q + 4].copy(), q)
            s[ksd.ST_Q:ksd.ST_Q + 4] = q / math.sqrt(float(q @ q))

    # --- processing ---------------------------------------------------------------

    def process(self, dtheta, dv, h_aid=None) -> NavSolution:
        """Navigate through one chunk of increments.

        Parameters
        ----------
        dtheta : array_like, shape (n, 3)
            Gyro angle increments (rad, body frame), one per input sample of
            ``dt_s``; ``n`` may be 0.
        dv : array_like, shape (n, 3)
            Accelerometer velocity increments (m/s, body frame), same samples.
        h_aid : array_like, shape (n,), optional
            Aiding height (m, up) at the end of each input sample; required
            with ``vertical="height_aid"`` (only the samples that complete an
            update are read) and refused otherwise.

        Returns
        -------
        NavSolution
            One row per navigation update completed in this chunk
            (``(pending_samples + n) // n_sub`` rows).

        Raises
        ------
        ValueError
            For a wrong shape, a non-finite value, or ``h_aid`` missing or
            given against the vertical mode (the message names the argument).
        """
        dth = _increments("dtheta", dtheta)
        dvel = _increments("dv", dv)
        n = dth.shape[0]
        if dvel.shape[0] != n:
            raise ValueError(f"dv: must have {n} rows (len(dtheta)), got {dvel.shape[0]}")
        aided = self._vertical == "height_aid"
        if aided:
            if h_aid is None:
                raise ValueError("h_aid: required with vertical='height_aid' (aiding height per input "
                                 "sample, m), got None")
            ha = v.finite_array("", "h_aid", h_aid, ndim=1)
            if ha.shape[0] != n:
                raise ValueError(f"h_aid: must have shape ({n},) (one per input sample), got {ha.shape}")
            ha = np.ascontiguousarray(ha)
        else:
            if h_aid is not None:
                raise ValueError(f"h_aid: only used with vertical='height_aid', got an array with "
                                 f"vertical={self._vertical!r}")
            ha = np.empty(0)
        out = self._run(dth, dvel, ha)
        m = out.shape[0]
        t = (self._n_updates - m + 1 + np.arange(m)) * self.update_period_s
        return NavSolution(
            t_s=t,
            lat_rad=out[:, ksd.OUT_LAT].copy(),
            lon_rad=out[:, ksd.OUT_LON].copy(),
            h_m=out[:, ksd.OUT_H].copy(),
            v_ned_m_s=out[:, ksd.OUT_V:ksd.OUT_V + 3].copy(),
            q_nb=out[:, ksd.OUT_Q:ksd.OUT_Q + 4].copy(),
        )

    def _run(self, dth, dvel, ha) -> np.ndarray:
        """The kernel on checked inputs; returns its output rows (layout ``sins_sim._kernels.strapdown.OUT_*``).

        ``dth``, ``dvel``: float64 (n, 3), finite, C-contiguous; ``ha``: float64 (n,) with the
        height aid, else empty. The engine, which checks its increments itself, calls this
        directly; :meth:`process` checks and wraps.
        """
        n = dth.shape[0]
        m = (self.pending_samples + n) // self._n_sub
        out = np.empty((m, ksd.OUT_SIZE))
        k1, k2, k3 = self._gains
        written = ksd.strapdown_run(dth, dvel, ha, self._dt, self._n_sub, self._ccoef,
                                    self._scoef, self._vertical == "height_aid", k1, k2, k3, self._state, out)
        if written != m:  # pragma: no cover - the kernel and this count share one rule
            raise RuntimeError(f"strapdown kernel wrote {written} updates, expected {m}")
        self._n_samples += n
        self._n_updates += m
        return out
