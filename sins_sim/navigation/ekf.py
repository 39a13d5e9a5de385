"""Error-state (indirect, feedback) Kalman filter around the strapdown navigator.

The filter estimates the errors of :class:`~sins_sim.navigation.strapdown.StrapdownNavigator` and of its
inertial sensors, feeds them back after every measurement, and resets its error state to zero
(Groves 2013, sec. 14.1.1 closed-loop; Titterton & Weston 2004, ch. 13). The theory page
``docs/theory/kalman.md`` writes the equations out; this docstring is the summary the code follows.

.. autosummary::

   ImuNoise
   UnmodelledErrors
   FixErrorStates
   gauss_markov_discrete
   unmodelled_variance_increment
   NavState
   AidedNavigator
   Innovation
   error_dynamics
   process_noise_density
   discretize
   initial_covariance
   MEASUREMENTS
   make_measurement

State (15, every error "computed minus true")::

    x = [dr_N, dr_E, dr_D,  dv_N, dv_E, dv_D,  psi_N, psi_E, psi_D,  db_gx, db_gy, db_gz,  db_ax, db_ay, db_az]

``dr`` position error in NED metres, ``dr = ((lat_c - lat)(R_N + h), (lon_c - lon)(R_E + h) cos lat,
-(h_c - h))``; ``dv = v_c - v`` (m/s); ``psi`` the attitude error with ``C_nb_c = (I + [psi x]) C_nb``
(the project's convention: the error between the computed and the true navigation frame, Groves's
``delta psi`` and Benson's (1975) phi angle); ``db_g = b_g_est - b_g`` (rad/s) and ``db_a = b_a_est -
b_a`` (m/s^2), body axes, the errors of the bias estimates the navigator's increments are corrected with.
The block slices ``POS``, ``VEL``, ``ATT``, ``GYRO_BIAS``, ``ACCEL_BIAS`` and :data:`STATE_NAMES` are the
only place the layout is written; every matrix is filled by block, so further sensor states (scale
factors) append after ``ACCEL_BIAS`` with their own block and columns of ``F`` without moving these.

Error dynamics (Groves 2013, sec. 14.2.4, eq. 14.64-14.71, in NED metres instead of ``dL, dlambda, dh``;
Titterton & Weston 2004, sec. 12.3), at the navigator's own attitude ``C = C_nb``, specific force
``f^n``, velocity ``v`` and position; ``W_v``, ``W_r`` the derivatives of ``omega_en^n`` by ``v`` and by the
position, ``Z_r`` that of ``omega_ie^n``::

    dr'   = dv + F_rr dr                                           (transport-rate terms, zero at rest)
    dv'   = -[f^n x] psi - C db_a - [(2 omega_ie + omega_en) x] dv
            + [v x] ((2 Z_r + W_r) dr + W_v dv) + (dg/dr) dr + C w_a
    psi'  = -[omega_in x] psi - C db_g - W_v dv - (Z_r + W_r) dr + C w_g
    db'   = -db / tau + w_b                                        (first-order Gauss-Markov; 0 for a random walk)

with the corrected increments' errors ``-db + w``: a bias estimate that is too large makes the corrected
rate too small, hence the minus signs. ``dg/dr``: the normal gravity's change with height, ``-dgamma/dh``
on ``dr_D`` (about ``2 g / R``), and with latitude, ``(dgamma/dL) / (R_N + h)`` on ``dr_N`` (8e-9
m/s^2 per m at 45 deg), both on the down component; with this frame the Schuler loop closes through
``-W_v dv`` and no horizontal gravity term appears (Groves 2013, sec. 14.2.4). ``F_rr`` and ``W_r``
include the radii's change with latitude (terms of relative size ``e^2``, which Groves's model drops).

Discretisation over a propagation interval ``T`` (the navigator's quantities averaged over it: ``f^n``
from the velocity change, ``C`` from the mean quaternion): Taylor series of ``Phi = expm(F T)`` and of
van Loan's (1978) integral ``Q_d = int_0^T expm(F s) G Q G^T expm(F s)^T ds``::

    Phi = sum_{k=0..5} (F T)^k / k!
    Q_d = sum_{k=0..5} M_k T^(k+1) / (k+1)!,   M_0 = Q' = G Q G^T,   M_k = F M_(k-1) + M_(k-1) F^T

The chain ``db_g -> psi -> dv -> dr`` is nilpotent (three steps, the largest products ``g T^3 / 6``), so
five powers hold all of it and two more slow factors (a bias correlation time, the Earth or Schuler
rate, ``(omega T)^2 < 1e-5`` at ``T = 1`` s); the noise enters at the start of the chains on both sides
(the gyro noise reaches the position variance as ``g^2 S_g T^5 / 20``, the ``k = 4`` term). Both are
checked against ``scipy.linalg.expm`` of van Loan's block matrix in the tests (tails below 1e-9 of the
kept terms). Cost: ten 15 x 15 products per propagation. :class:`AidedNavigator` runs the propagation and the
Joseph update compiled (:mod:`sins_sim._kernels.ekf`, one call per block and per update); :func:`error_dynamics`
and :func:`discretize` here are the reference the tests hold the kernels to.

Fix-error states (optional, :class:`FixErrorStates`): states 15 on hold the aiding fixes' first-order
Gauss-Markov errors ``e = z - (true)`` (position NED, then velocity NED if modelled), ``e' = -e / tau + w``,
discrete ``e_(k+1) = exp(-T/tau) e_k + w_k``, ``var(w_k) = sigma^2 (1 - exp(-2 T/tau))`` (Gelb 1974,
sec. 3.8; Groves 2013, sec. 3.4.3; Brown & Hwang 2012, ch. 4), with the stationary ``sigma^2`` as their prior.
They enter a GNSS ``position`` (``velocity``) measurement as ``dz = H x - e + v``: ``H`` gains ``-I`` on their
columns and ``R`` holds the white noise only. They are not fed back (they are the receiver's error, not the
navigator's) and are carried by ``Phi`` between updates in closed loop too.

Sensor-error states (optional, :attr:`UnmodelledErrors.states`), after the fix-error states: the errors
``dK[i, j] = K_est[i, j] - K[i, j]`` of the estimated error matrices of the gyros and the accelerometers (the IMU
model ``u_meas = b + (I + K) u + w``, scale factors on the diagonal of ``K``, misalignments ``K[i, j]``, sensor
``i`` sensing body axis ``j``, off it; Groves 2013, sec. 4.4.6), per group ``gyro_scale_factor`` (3),
``gyro_misalignment`` (6), ``accel_scale_factor`` (3), ``accel_misalignment`` (6). The navigator integrates
``(I + K_est)^-1 (u_meas - b_est dt)``, whose error is ``-db - dK u`` to first order, so::

    psi' = ... - C (db_g + dK_g omega_ib^b),    dv' = ... - C (db_a + dK_a f^b)

(Groves 2013, sec. 14.2.4, the scale-factor and cross-coupling terms of the system model; Titterton & Weston
2004, sec. 12.3): the state ``dK[i, j]`` has the column ``-C[:, i] x_j`` on the attitude (gyros) or velocity
(accelerometers) rows, ``x`` the block's mean body rate or specific force from the running integrals of the raw
increments. Random constants (``F`` and ``Q'`` zero on their rows), prior the group's 1-sigma of
:class:`UnmodelledErrors`, whose process noise for that group is then off. Fed back like the biases
(``K_est -= dK``, the increments then corrected by the new ``(I + K_est)^-1``), then reset to zero.

Measurements (plug-ins, :data:`MEASUREMENTS`): each gives ``dz = h(x_c) - z`` (computed minus measured),
modelled as ``dz = H x + v``, ``v ~ N(0, R)``. Update in Joseph form (Bucy & Joseph 1968; Groves 2013,
eq. 3.58)::

    S = H P H^T + R,   K = P H^T S^-1,   x += K (dz - H x),   P = (I - K H) P (I - K H)^T + K R K^T

and the innovation ``nu = dz - H x``, its covariance ``S`` and ``NIS = nu^T S^-1 nu`` recorded.
Feedback (closed loop): position, velocity and attitude by
:meth:`StrapdownNavigator.apply_correction`, biases ``b_est -= db``, error matrices ``K_est -= dK``, then ``x = 0``
(the fix-error states excepted).

Observability at rest (zero velocity and known position; Britting 1971, Bar-Itzhack & Berman 1988). With
``f^n = (0, 0, -g)``, ``a = C db_a`` and ``e = C db_g`` (NED)::

    dv_N' = -g psi_E - a_N        psi_N' = -Omega sin(L) psi_E - e_N
    dv_E' =  g psi_N - a_E        psi_E' =  Omega sin(L) psi_N + Omega cos(L) psi_D - e_E
    dv_D' = -a_D                  psi_D' = -Omega cos(L) psi_E - e_D

An error that keeps ``dv = 0`` and ``dr = 0`` for all time is invisible; there are three such constant
directions: ``(psi_E, a_N, e_N, e_D) = d (1, -g, -Omega sin L, -Omega cos L)``,
``(psi_N, a_E, e_E) = d (1, g, Omega sin L)`` and ``(psi_D, e_E) = d (1, Omega cos L)``. Hence the
horizontal accelerometer biases are not separable from the tilts; the east gyro bias is not separable
from the heading, which converges to ``sigma_psi_D -> sigma_e_E / (Omega cos L)`` (plus the share
``Omega sin(L) sigma_a_E / g`` of the north tilt); the north and down gyro biases are observable up to
``Omega sigma_a_N / g`` (the down one slowly: it bends the east tilt, ``Omega cos(L) e_D t^2 / 2``,
minutes to hours); the vertical accelerometer bias is observable at once. In body axes these map
through ``C_nb``: for a level unit heading north, ``gyro_bias_y``, ``accel_bias_x`` and ``accel_bias_y``
are the unobservable ones.

References
----------
.. [1] P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd
   ed., Artech House, 2013, ch. 3 (Kalman filter, sec. 3.2.5 discretisation), ch. 14 (sec. 14.1 error-state
   and closed-loop, sec. 14.2.4 local-navigation-frame error model), ch. 16 (zero-velocity updates).
.. [2] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IEE, 2004,
   ch. 10 (alignment), ch. 12 (error equations), ch. 13 (aiding).
.. [3] C. F. van Loan, "Computing integrals involving the matrix exponential", IEEE Trans. Automatic
   Control 23(3), 395-404, 1978.
.. [4] R. S. Bucy, P. D. Joseph, *Filtering for Stochastic Processes with Applications to Guidance*,
   Interscience, 1968.
.. [5] J. W. Benson, "A comparison of two approaches to pure-inertial and Doppler-inertial error
   analysis", IEEE Trans. Aerosp. Electron. Syst. AES-11(4), 447-455, 1975.
.. [6] K. R. Britting, *Inertial Navigation Systems Analysis*, Wiley, 1971, ch. 9 (self-alignment).
.. [7] I. Y. Bar-Itzhack, N. Berman, "Control theoretic approach to inertial navigation systems", J.
   Guidance, Control, and Dynamics 11(3), 237-245, 1988.
"""

from __future__ import annotations

import abc
import functools
import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim import earth
from sins_sim._kernels import ekf as kekf
from sins_sim._kernels import strapdown as ksd
from sins_sim.units import DEG, DEG_PER_H, MICRO_G
from sins_sim.navigation.attitude import _increments
from sins_sim.navigation.strapdown import NavSolution, StrapdownNavigator

__all__ = [
    "N_STATES", "STATE_NAMES", "POS", "VEL", "ATT", "GYRO_BIAS", "ACCEL_BIAS", "BIASES", "HEADING", "BIAS_KEYS",
    "ImuNoise", "UnmodelledErrors", "FixErrorStates", "gauss_markov_discrete", "NavState", "Innovation",
    "AidedNavigator", "MEASUREMENTS", "make_measurement",
    "ZeroVelocity", "ZeroAngularRate", "Position", "Velocity", "Height",
    "error_dynamics", "process_noise_density", "discretize", "initial_covariance", "skew",
    "unmodelled_variance_increment", "SENSOR_ERROR_GROUPS", "MISALIGNMENT_PAIRS", "sensor_error_columns",
]

# --- state layout -------------------------------------------------------------------------------------------
#: Position error north, east, down (m).
POS = slice(0, 3)
#: Velocity error NED (m/s).
VEL = slice(3, 6)
#: Attitude error psi about north, east, down (rad), ``C_nb_c = (I + [psi x]) C_nb``.
ATT = slice(6, 9)
#: Error of the gyro bias estimate, body x, y, z (rad/s).
GYRO_BIAS = slice(9, 12)
#: Error of the accelerometer bias estimate, body x, y, z (m/s^2).
ACCEL_BIAS = slice(12, 15)
#: The six bias states (gyro xyz, accelerometer xyz), contiguous.
BIASES = slice(GYRO_BIAS.start, ACCEL_BIAS.stop)
#: Index of the heading error ``psi_D``.
HEADING = ATT.start + 2
#: Names of the states in order (unit in each name).
STATE_NAMES = (
    "dpos_n_m", "dpos_e_m", "dpos_d_m",
    "dv_n_m_s", "dv_e_m_s", "dv_d_m_s",
    "psi_n_rad", "psi_e_rad", "psi_d_rad",
    "dbias_gyro_x_rad_s", "dbias_gyro_y_rad_s", "dbias_gyro_z_rad_s",
    "dbias_accel_x_m_s2", "dbias_accel_y_m_s2", "dbias_accel_z_m_s2",
)
#: Number of states.
N_STATES = len(STATE_NAMES)
#: The sensor-error groups that can be filter states (:attr:`UnmodelledErrors.states`), in layout order.
SENSOR_ERROR_GROUPS = ("gyro_scale_factor", "gyro_misalignment", "accel_scale_factor", "accel_misalignment")
#: The off-diagonal elements ``(row, col)`` of an error matrix, in the order xy, xz, yx, yz, zx, zy (the sensor
#: model's ``misalignment_arcsec``: sensor ``row`` sensing body axis ``col``).
MISALIGNMENT_PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
#: Keys of the observability flags, in the order of the bias states (the AlignmentResult convention).
BIAS_KEYS = ("gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "accel_bias_x", "accel_bias_y", "accel_bias_z")

_I3 = np.eye(3)
#: Columns of the navigator's output rows that make a block row of :func:`kekf.propagate_block` (lat, h, v, q).
_BLOCK_ROW = np.array([ksd.OUT_LAT, ksd.OUT_H, *range(ksd.OUT_V, ksd.OUT_V + 3), *range(ksd.OUT_Q, ksd.OUT_Q + 4)])
#: The height aid of a navigator with ``vertical="free"`` (none).
_NO_AID = np.empty(0)


def skew(a) -> np.ndarray:
    """The cross-product matrix ``[a x]``, ``[a x] b = a x b``."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _vec3(field_name, value) -> np.ndarray:
    arr = v.finite_array("", field_name, value, ndim=1)
    if arr.shape != (3,):
        raise ValueError(f"{field_name}: must have shape (3,), got {arr.shape}")
    return arr.copy()


def _dcm(q) -> np.ndarray:
    """``C_nb`` of a unit quaternion (Titterton & Weston 2004, eq. 3.63; the scalar form of
    :func:`sins_sim.navigation.attitude.dcm_from_quat`, without its broadcasting overhead)."""
    q0, q1, q2, q3 = (float(x) for x in q)
    return np.array([[1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
                     [2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)],
                     [2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)]])


def _cross(a, b) -> np.ndarray:
    """``a x b`` of two 3-vectors (``np.cross`` costs ten times more on this size)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _wie(lat) -> np.ndarray:
    """Earth rate in NED, :func:`sins_sim.earth.earth_rate_ned` for one scalar latitude."""
    return earth.EARTH_RATE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])


def _wrap(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


# --- sensor noise ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImuNoise:
    """Sensor-error model of the filter, SI units in every name (the same on the three axes).

    Parameters
    ----------
    gyro_arw_rad_sqrt_s : float
        Angle random walk (rad/sqrt(s)), >= 0: the white rate noise density.
    accel_vrw_m_s_sqrt_s : float
        Velocity random walk (m/s/sqrt(s)), >= 0.
    gyro_bias_sigma_rad_s : float
        1-sigma of the gyro bias at the start (turn-on; rad/s), >= 0; with a finite ``gyro_bias_tau_s``
        also the stationary sigma of the Gauss-Markov process.
    accel_bias_sigma_m_s2 : float
        The same for the accelerometers (m/s^2).
    gyro_bias_tau_s : float
        Correlation time of a first-order Gauss-Markov gyro bias (s), > 0; ``inf`` (default) for a
        constant bias plus the random walk ``gyro_bias_rw_rad_s_sqrt_s``.
    accel_bias_tau_s : float
        The same for the accelerometers.
    gyro_bias_rw_rad_s_sqrt_s : float
        Rate random walk of the gyro bias (rad/s/sqrt(s)), >= 0; only with ``gyro_bias_tau_s = inf``.
    accel_bias_rw_m_s2_sqrt_s : float
        Random walk of the accelerometer bias (m/s^2/sqrt(s)), >= 0; only with ``accel_bias_tau_s = inf``.

    Notes
    -----
    Continuous white-noise densities (Groves 2013, sec. 14.2.6): ``S_g = gyro_arw^2``,
    ``S_a = accel_vrw^2``, bias driving noise ``2 sigma^2 / tau`` (Gauss-Markov) or ``rw^2`` (random walk).
    """

    gyro_arw_rad_sqrt_s: float
    accel_vrw_m_s_sqrt_s: float
    gyro_bias_sigma_rad_s: float
    accel_bias_sigma_m_s2: float
    gyro_bias_tau_s: float = math.inf
    accel_bias_tau_s: float = math.inf
    gyro_bias_rw_rad_s_sqrt_s: float = 0.0
    accel_bias_rw_m_s2_sqrt_s: float = 0.0

    def __post_init__(self):
        for name in ("gyro_arw_rad_sqrt_s", "accel_vrw_m_s_sqrt_s", "gyro_bias_sigma_rad_s",
                     "accel_bias_sigma_m_s2", "gyro_bias_rw_rad_s_sqrt_s", "accel_bias_rw_m_s2_sqrt_s"):
            object.__setattr__(self, name, v.non_negative("ImuNoise", name, getattr(self, name)))
        for name, rw in (("gyro_bias_tau_s", "gyro_bias_rw_rad_s_sqrt_s"),
                         ("accel_bias_tau_s", "accel_bias_rw_m_s2_sqrt_s")):
            tau = getattr(self, name)
            if isinstance(tau, bool) or not isinstance(tau, (int, float, np.floating, np.integer)) \
                    or math.isnan(tau) or tau <= 0.0:
                raise ValueError(f"ImuNoise.{name}: must be > 0 (inf for a constant bias), got {tau!r}")
            object.__setattr__(self, name, float(tau))
            if math.isfinite(tau) and getattr(self, rw) > 0.0:
                raise ValueError(f"ImuNoise.{rw}: must be 0 with a finite {name} (a Gauss-Markov bias has "
                                 f"no separate random walk), got {getattr(self, rw)!r}")

    @classmethod
    def from_datasheet(cls, gyro_arw_deg_sqrt_h, accel_vrw_ug_sqrt_hz, gyro_bias_deg_h, accel_bias_ug, *,
                       gyro_bias_tau_s=math.inf, accel_bias_tau_s=math.inf) -> ImuNoise:
        """The model from datasheet units: ARW in deg/sqrt(h), VRW in ug/sqrt(Hz), biases in deg/h and ug.

        ``1 deg/sqrt(h) = (pi/180) / 60 rad/sqrt(s)``; ``1 ug/sqrt(Hz) = 1e-6 g0 m/s/sqrt(s)`` (a white
        acceleration density in ug/sqrt(Hz) is the VRW in those units; IEEE Std 1293-1998, annex).

        Parameters
        ----------
        gyro_arw_deg_sqrt_h : float
            Angle random walk (deg/sqrt(h)).
        accel_vrw_ug_sqrt_hz : float
            Accelerometer white noise (ug/sqrt(Hz)).
        gyro_bias_deg_h : float
            Gyro bias 1-sigma (deg/h).
        accel_bias_ug : float
            Accelerometer bias 1-sigma (ug).
        gyro_bias_tau_s, accel_bias_tau_s : float
            Gauss-Markov correlation times (s); ``inf`` for constant biases.

        Returns
        -------
        ImuNoise

        Examples
        --------
        >>> n = ImuNoise.from_datasheet(0.003, 20.0, 0.01, 100.0)
        >>> round(n.gyro_arw_rad_sqrt_s * 1e7, 4), round(n.gyro_bias_sigma_rad_s * 1e8, 4)
        (8.7266, 4.8481)
        """
        return cls(v.non_negative("ImuNoise", "gyro_arw_deg_sqrt_h", gyro_arw_deg_sqrt_h) * DEG / 60.0,
                   v.non_negative("ImuNoise", "accel_vrw_ug_sqrt_hz", accel_vrw_ug_sqrt_hz) * MICRO_G,
                   v.non_negative("ImuNoise", "gyro_bias_deg_h", gyro_bias_deg_h) * DEG_PER_H,
                   v.non_negative("ImuNoise", "accel_bias_ug", accel_bias_ug) * MICRO_G,
                   gyro_bias_tau_s=gyro_bias_tau_s, accel_bias_tau_s=accel_bias_tau_s)

    def scaled(self, factor: float) -> ImuNoise:
        """The same model with every white-noise density (ARW, VRW, bias random walks) times ``factor``."""
        f = v.non_negative("ImuNoise.scaled", "factor", factor)
        return ImuNoise(self.gyro_arw_rad_sqrt_s * f, self.accel_vrw_m_s_sqrt_s * f, self.gyro_bias_sigma_rad_s,
                        self.accel_bias_sigma_m_s2, self.gyro_bias_tau_s, self.accel_bias_tau_s,
                        self.gyro_bias_rw_rad_s_sqrt_s * f, self.accel_bias_rw_m_s2_sqrt_s * f)

    def bias_variance_after(self, var0, t_s: float) -> np.ndarray:
        """Variance of the six bias states (gyro xyz, accel xyz) after ``t_s`` s with no measurement."""
        out = np.array(var0, dtype=np.float64)
        for sl, sigma, tau, rw in ((slice(0, 3), self.gyro_bias_sigma_rad_s, self.gyro_bias_tau_s,
                                    self.gyro_bias_rw_rad_s_sqrt_s),
                                   (slice(3, 6), self.accel_bias_sigma_m_s2, self.accel_bias_tau_s,
                                    self.accel_bias_rw_m_s2_sqrt_s)):
            if math.isfinite(tau):
                phi2 = math.exp(-2.0 * t_s / tau)
                out[sl] = phi2 * out[sl] + sigma * sigma * (1.0 - phi2)
            else:
                out[sl] = out[sl] + rw * rw * t_s
        return out


@dataclass(frozen=True)
class UnmodelledErrors:
    """Scale factors and misalignments: told to the filter as process noise per step, or (``states``) estimated.

    Parameters
    ----------
    gyro_scale_factor, gyro_misalignment_rad : float
        1-sigma of the gyros' scale-factor error (dimensionless) and of each misalignment (rad), >= 0.
    accel_scale_factor, accel_misalignment_rad : float
        The same for the accelerometers.
    accel_reference_b_m_s2 : array_like, shape (3,), or None
        The specific force (body, m/s^2) whose error the accelerometer bias states take up (in level flight
        mostly gravity); None: the mean of the first chunk the filter navigates.
    states : sequence of str
        The groups estimated as filter states (:data:`SENSOR_ERROR_GROUPS`; module docstring, "Sensor-error
        states"): their sigma is then the states' prior and their process noise is off (:attr:`variances`).

    Notes
    -----
    The model (a constant error matrix ``K``, ``sigma_S`` on its diagonal and ``sigma_M`` off it, on a body
    quantity ``x``, the rate or the specific force less its reference: the IMU error model
    ``omega_meas = b_g + (I + M_g) omega + w_g``, Groves 2013, sec. 4.4.6, and its place in the error
    equations, Titterton & Weston 2004, ch. 12; Groves 2013, ch. 14, inflates the system noise for unestimated
    states without a formula). The error ``K x`` integrates to ``K a(t)``, ``a`` the
    running integral of ``x`` since the start (the angle turned through; the velocity change less the
    reference's), with per body axis the variance::

        v_i(a) = sigma_S^2 a_i^2 + sigma_M^2 (|a|^2 - a_i^2)

    Each propagation step from ``a_0`` to ``a_1`` adds ``max(0, v_i(a_1 - o) - v_i(a_0 - o))`` to the attitude
    (gyros) or velocity (accelerometers) error variance, rotated by the step's mean ``C_nb``
    (:func:`unmodelled_variance_increment`; ``Q'`` gains ``C diag(d) C^T / T`` over the step). The origin
    ``o`` starts at 0 and restarts at ``a_0`` when a step heads back towards it (a turn back): the filter has
    measured and corrected part of the first leg's error by then, and the second leg's ``K (a - o)`` is new
    to it. Over a turn the steps add up to ``sigma^2 |a - o|^2``, the coherent error of the constant ``K`` (a
    constant rate ``omega`` about one axis for ``t``: ``sigma_S^2 omega^2 t^2``, step ``k`` adding
    ``sigma_S^2 omega^2 T^2 (2 k + 1)``); in cruise nothing is added, the turn's error stays in ``P`` as the
    constant it is. A white density ``sigma^2 omega^2 dt`` per step would instead give ``sigma^2 omega^2 T t``,
    short of the coherent growth by ``T / t``. Conservative for a turn back with no measurement in between
    (the two legs' errors cancel, their variances add) and for the horizontal misalignment terms of a heading
    change (their true sum is the chord ``2 sin(a/2)`` of the arc ``a``). The vibration's angles and velocities
    are bounded and oscillate: each half cycle adds the variance of its own amplitude, ``sigma^2 (2 A)^2``, far
    below the white noise for the rotor lines (0.3 arcmin: 3e-17 rad^2 per half cycle at 30 ppm).
    """

    gyro_scale_factor: float
    gyro_misalignment_rad: float
    accel_scale_factor: float
    accel_misalignment_rad: float
    accel_reference_b_m_s2: object = None
    states: tuple = ()

    def __post_init__(self):
        for name in ("gyro_scale_factor", "gyro_misalignment_rad", "accel_scale_factor", "accel_misalignment_rad"):
            object.__setattr__(self, name, v.non_negative("UnmodelledErrors", name, getattr(self, name)))
        if self.accel_reference_b_m_s2 is not None:
            object.__setattr__(self, "accel_reference_b_m_s2",
                               _vec3("accel_reference_b_m_s2", self.accel_reference_b_m_s2))
        states = (self.states,) if isinstance(self.states, str) else tuple(self.states)
        for name in states:
            if name not in SENSOR_ERROR_GROUPS:
                raise ValueError(f"UnmodelledErrors.states: {name!r} is not one of {', '.join(SENSOR_ERROR_GROUPS)}")
        if len(set(states)) != len(states):
            raise ValueError(f"UnmodelledErrors.states: each group at most once, got {list(states)}")
        # canonical order (the state layout does not depend on the order the groups are named in)
        object.__setattr__(self, "states", tuple(g for g in SENSOR_ERROR_GROUPS if g in states))

    @property
    def variances(self) -> np.ndarray:
        """``(sigma_S^2, sigma_M^2)`` of the gyros, then of the accelerometers (the kernel's ``unmod``), zero for a
        group estimated as states (:attr:`states`: its error is in ``F``, not in the process noise)."""
        sig = np.array([self.gyro_scale_factor, self.gyro_misalignment_rad, self.accel_scale_factor,
                        self.accel_misalignment_rad])
        return np.where([g in self.states for g in SENSOR_ERROR_GROUPS], 0.0, sig) ** 2

    @property
    def n_states(self) -> int:
        """Number of sensor-error states (3 per scale-factor group, 6 per misalignment group)."""
        return len(self.state_table()[0])

    def state_table(self):
        """The sensor-error states in layout order (module docstring, "Sensor-error states").

        Returns
        -------
        kind, row, col : ndarray of int64
            Per state: 0 gyro, 1 accelerometer; the element ``K[row, col]`` of that triad's error matrix it is
            (the scale factors on the diagonal, the misalignments off it in the order xy, xz, yx, yz, zx, zy).
        sigma : ndarray
            Its prior 1-sigma (the group's ``gyro_scale_factor`` ... ``accel_misalignment_rad``).
        names : tuple of str
            ``dsf_gyro_x``, ``dmis_gyro_xy``, ... (dimensionless; a misalignment in rad).
        """
        kind, row, col, sig, names = [], [], [], [], []
        sigmas = dict(zip(SENSOR_ERROR_GROUPS, (self.gyro_scale_factor, self.gyro_misalignment_rad,
                                                self.accel_scale_factor, self.accel_misalignment_rad)))
        for g in self.states:
            sensor, what = g.split("_", 1)
            pairs = [(i, i) for i in range(3)] if what == "scale_factor" else list(MISALIGNMENT_PAIRS)
            for i, j in pairs:
                kind.append(0 if sensor == "gyro" else 1)
                row.append(i)
                col.append(j)
                sig.append(sigmas[g])
                names.append(f"dsf_{sensor}_{'xyz'[i]}" if i == j else f"dmis_{sensor}_{'xyz'[i]}{'xyz'[j]}")
        return (np.array(kind, dtype=np.int64), np.array(row, dtype=np.int64), np.array(col, dtype=np.int64),
                np.array(sig, dtype=np.float64), tuple(names))


def gauss_markov_discrete(tau_s, sigma, t_s):
    """``(phi, q)`` of a first-order Gauss-Markov process over ``t_s``: ``phi = exp(-T/tau)``,
    ``q = sigma^2 (1 - exp(-2 T/tau))`` (Gelb 1974, sec. 3.8; Brown & Hwang 2012, sec. 4.2), elementwise.

    >>> phi, q = gauss_markov_discrete(300.0, 2.0, 300.0)
    >>> round(float(phi), 12), round(float(q), 12)
    (0.367879441171, 3.458658867254)
    """
    tau = np.asarray(tau_s, dtype=np.float64)
    return np.exp(-t_s / tau), np.asarray(sigma, dtype=np.float64) ** 2 * -np.expm1(-2.0 * t_s / tau)


@dataclass(frozen=True)
class FixErrorStates:
    """The aiding fixes' first-order Gauss-Markov errors as filter states (module docstring).

    Parameters
    ----------
    position_sigma_m : array_like, shape (3,)
        Stationary 1-sigma of the position fixes' Gauss-Markov error, NED (m), >= 0.
    position_tau_s : float
        Its correlation time (s), > 0.
    velocity_sigma_m_s : array_like, shape (3,), or None
        The velocity fixes' Gauss-Markov error, NED (m/s); None: no velocity states.
    velocity_tau_s : float or None
        Its correlation time (s), > 0 (with ``velocity_sigma_m_s``).
    """

    position_sigma_m: object
    position_tau_s: float
    velocity_sigma_m_s: object = None
    velocity_tau_s: object = None

    def __post_init__(self):
        o = "FixErrorStates"
        sig = _vec3("position_sigma_m", self.position_sigma_m)
        if np.any(sig < 0.0):
            raise ValueError(f"position_sigma_m: must be >= 0, got {sig.tolist()}")
        object.__setattr__(self, "position_sigma_m", sig)
        object.__setattr__(self, "position_tau_s", v.positive(o, "position_tau_s", self.position_tau_s))
        if (self.velocity_sigma_m_s is None) != (self.velocity_tau_s is None):
            raise ValueError("velocity_sigma_m_s, velocity_tau_s: give both or neither")
        if self.velocity_sigma_m_s is not None:
            sv = _vec3("velocity_sigma_m_s", self.velocity_sigma_m_s)
            if np.any(sv < 0.0):
                raise ValueError(f"velocity_sigma_m_s: must be >= 0, got {sv.tolist()}")
            object.__setattr__(self, "velocity_sigma_m_s", sv)
            object.__setattr__(self, "velocity_tau_s", v.positive(o, "velocity_tau_s", self.velocity_tau_s))

    @property
    def n_states(self) -> int:
        """3 (position) or 6 (position and velocity)."""
        return 3 if self.velocity_sigma_m_s is None else 6

    @property
    def tau_s(self) -> np.ndarray:
        """Correlation time of each state (s)."""
        t = [self.position_tau_s] * 3 + ([] if self.velocity_tau_s is None else [self.velocity_tau_s] * 3)
        return np.array(t, dtype=np.float64)

    @property
    def variance(self) -> np.ndarray:
        """Stationary variance of each state."""
        parts = [self.position_sigma_m] + ([] if self.velocity_sigma_m_s is None else [self.velocity_sigma_m_s])
        return np.concatenate(parts) ** 2

    def columns(self, name):
        """The state indices of measurement ``name`` (``position``, ``velocity``), or None."""
        if name == "position":
            return slice(N_STATES, N_STATES + 3)
        if name == "velocity" and self.velocity_sigma_m_s is not None:
            return slice(N_STATES + 3, N_STATES + 6)
        return None


def unmodelled_variance_increment(a0, a1, scale_sigma, misalignment_sigma, origin=(0.0, 0.0, 0.0)):
    """Per body axis the variance a step adds (:class:`UnmodelledErrors`), and the origin after it.

    The origin ``o`` restarts at ``a0`` when the step heads back towards it (``(a1 - a0) . (a0 - o) < 0``); then
    ``d_i = max(0, v_i(a1 - o) - v_i(a0 - o))`` with ``v_i(a) = sigma_S^2 a_i^2 + sigma_M^2 (|a|^2 - a_i^2)``.

    Parameters
    ----------
    a0, a1 : array_like, shape (3,)
        The running integral at the step's start and end (rad for gyros, m/s for accelerometers; body).
    scale_sigma, misalignment_sigma : float
        1-sigma of the scale factor and of each misalignment.
    origin : array_like, shape (3,)
        The origin before the step.

    Returns
    -------
    d : ndarray, shape (3,)
    origin : ndarray, shape (3,)

    Examples
    --------
    >>> d, o = unmodelled_variance_increment([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], 1e-3, 0.0)
    >>> d.tolist(), o.tolist()
    ([0.0, 0.0, 4e-06], [0.0, 0.0, 0.0])
    """
    a0 = np.asarray(a0, dtype=np.float64)
    a1 = np.asarray(a1, dtype=np.float64)
    o = np.asarray(origin, dtype=np.float64)
    if float((a1 - a0) @ (a0 - o)) < 0.0:
        o = a0.copy()

    def var(a):
        return scale_sigma ** 2 * a ** 2 + misalignment_sigma ** 2 * (float(a @ a) - a ** 2)

    return np.maximum(var(a1 - o) - var(a0 - o), 0.0), o


# --- navigation snapshot --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class NavState:
    """The computed navigation state a measurement is predicted from.

    Attributes
    ----------
    t_s : float
        Time since the navigator's start (s).
    lat_rad, lon_rad, h_m : float
        Computed position (rad, rad, m up).
    v_ned_m_s : ndarray, shape (3,)
        Computed velocity NED (m/s).
    q_nb : ndarray, shape (4,)
        Computed attitude, body to NED.
    gyro_bias_rad_s, accel_bias_m_s2 : ndarray, shape (3,)
        The bias estimates the increments are corrected with (body axes).
    """

    t_s: float
    lat_rad: float
    lon_rad: float
    h_m: float
    v_ned_m_s: np.ndarray
    q_nb: np.ndarray
    gyro_bias_rad_s: np.ndarray
    accel_bias_m_s2: np.ndarray

    @functools.cached_property
    def c_nb(self) -> np.ndarray:
        """``C_nb`` of :attr:`q_nb` (computed once per state: every measurement of an update reads it)."""
        return _dcm(self.q_nb)


def _d_earth_rate_d_rn(lat, h):
    """``d omega_ie^n / d dr_N`` (rad/s per m): ``Omega (-sin L, 0, -cos L) / (R_N + h)``."""
    r_n, _ = earth.radii(lat)
    return earth.EARTH_RATE_RAD_S * np.array([-math.sin(lat), 0.0, -math.cos(lat)]) / (r_n + h)


# --- measurements ---------------------------------------------------------------------------------------------


def _sigma_matrix(field_name, sigma, dim) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(sigma, dtype=np.float64))
    if arr.shape not in ((1,), (dim,)) or not np.all(np.isfinite(arr)) or np.any(arr <= 0.0):
        raise ValueError(f"{field_name}: must be one value or {dim} values, each finite and > 0, got {sigma!r}")
    return np.diag(np.broadcast_to(arr, (dim,)) ** 2)


class _Measurement(abc.ABC):
    """Base of the measurement plug-ins: ``dz = h(x_c) - z = H x + v``, ``v ~ N(0, R)``; a plug-in defines
    both abstract methods (a class that misses one cannot be instantiated)."""

    name = ""
    dim = 0

    @abc.abstractmethod
    def h_matrix(self, state: NavState) -> np.ndarray:
        """``H`` (dim x 15) at the navigator's state."""

    @abc.abstractmethod
    def innovation(self, state: NavState) -> np.ndarray:
        """``h(x_c) - z`` at the navigator's state."""

    def r_matrix(self) -> np.ndarray:
        """Measurement noise covariance ``R``."""
        return self._r


class Velocity(_Measurement):
    """A velocity measured at a point ``lever_arm_b_m`` from the IMU (Groves 2013, eq. 14.113 and 14.114).

    ``h(x_c) = v_c + C_c (omega_c x l) - omega_ie^n x (C_c l)``, ``omega_c = omega_gyro - b_g,est``.

    Parameters
    ----------
    v_ned_m_s : array_like, shape (3,)
        The measured velocity NED (m/s).
    sigma_m_s : float or array_like, shape (3,)
        Its 1-sigma (m/s), > 0.
    lever_arm_b_m : array_like, shape (3,)
        From the IMU to the measured point, body axes (m); zeros by default.
    gyro_rate_b_rad_s : array_like, shape (3,)
        The mean raw gyro rate over the interval (rad/s; :attr:`AidedNavigator.mean_gyro_rate_b_rad_s`);
        only read with a lever arm.
    """

    name = "velocity"
    dim = 3

    def __init__(self, v_ned_m_s, sigma_m_s, lever_arm_b_m=(0.0, 0.0, 0.0), gyro_rate_b_rad_s=(0.0, 0.0, 0.0)):
        self.z = _vec3("v_ned_m_s", v_ned_m_s)
        self._r = _sigma_matrix("sigma_m_s", sigma_m_s, 3)
        self.lever = _vec3("lever_arm_b_m", lever_arm_b_m)
        self.rate = _vec3("gyro_rate_b_rad_s", gyro_rate_b_rad_s)
        self._has_lever = bool(np.any(self.lever != 0.0))

    def _predict(self, state):
        vel = np.asarray(state.v_ned_m_s, dtype=np.float64)
        if not self._has_lever:
            return vel
        c = state.c_nb
        w = self.rate - state.gyro_bias_rad_s
        return vel + c @ _cross(w, self.lever) - _cross(_wie(state.lat_rad), c @ self.lever)

    def innovation(self, state: NavState) -> np.ndarray:
        """``dz = h(x_c) - z`` (m/s)."""
        return self._predict(state) - self.z

    def h_matrix(self, state: NavState) -> np.ndarray:
        """``H = [W_ie_r, I, -[(C (w x l)) x] + [omega_ie x][(C l) x], C [l x], 0]`` (zeros without a lever arm)."""
        h = np.zeros((3, N_STATES))
        h[:, VEL] = _I3
        if self._has_lever:
            c = state.c_nb
            w = self.rate - state.gyro_bias_rad_s
            cl = c @ self.lever
            wie = _wie(state.lat_rad)
            h[:, ATT] = -skew(c @ _cross(w, self.lever)) + skew(wie) @ skew(cl)
            h[:, GYRO_BIAS] = c @ skew(self.lever)
            h[:, 0] = skew(cl) @ _d_earth_rate_d_rn(state.lat_rad, state.h_m)
        return h


class ZeroVelocity(Velocity):
    """Zero-velocity update (ZUPT): the IMU is at rest, ``v = 0`` (Groves 2013, sec. 16.2.4).

    Parameters
    ----------
    sigma_m_s : float or array_like, shape (3,)
        1-sigma of the residual motion of the base (m/s), > 0.
    """

    name = "zero_velocity"

    def __init__(self, sigma_m_s):
        super().__init__(np.zeros(3), sigma_m_s)


class Position(_Measurement):
    """A position measured at a point ``lever_arm_b_m`` from the IMU (Groves 2013, eq. 14.110).

    ``dz`` in NED metres at the computed point:
    ``((lat_c - lat_z)(R_N + h_c), wrap(lon_c - lon_z)(R_E + h_c) cos lat_c, -(h_c - h_z)) + C_c l``.
    A known still position (zero position change at rest) is this with the start position.

    Parameters
    ----------
    lat_rad, lon_rad, h_m : float
        The measured position (rad, rad, m up).
    sigma_m : float or array_like, shape (3,)
        Its 1-sigma north, east, down (m), > 0.
    lever_arm_b_m : array_like, shape (3,)
        From the IMU to the measured point, body axes (m); zeros by default.
    """

    name = "position"
    dim = 3

    def __init__(self, lat_rad, lon_rad, h_m, sigma_m, lever_arm_b_m=(0.0, 0.0, 0.0)):
        self.lat = v.finite("", "lat_rad", lat_rad)
        self.lon = v.finite("", "lon_rad", lon_rad)
        self.h = v.finite("", "h_m", h_m)
        self._r = _sigma_matrix("sigma_m", sigma_m, self.dim)
        self.lever = _vec3("lever_arm_b_m", lever_arm_b_m)

    def _ned(self, state):
        r_n, r_e = earth.radii(state.lat_rad)
        d = np.array([(state.lat_rad - self.lat) * (r_n + state.h_m),
                      _wrap(state.lon_rad - self.lon) * (r_e + state.h_m) * math.cos(state.lat_rad),
                      -(state.h_m - self.h)])
        return d + state.c_nb @ self.lever

    def innovation(self, state: NavState) -> np.ndarray:
        """``dz`` (m, NED)."""
        return self._ned(state)

    def h_matrix(self, state: NavState) -> np.ndarray:
        """``H = [I, 0, -[(C l) x], 0, 0]``."""
        h = np.zeros((3, N_STATES))
        h[:, POS] = _I3
        h[:, ATT] = -skew(state.c_nb @ self.lever)
        return h


class Height(Position):
    """A height measured at a point ``lever_arm_b_m`` from the IMU: ``dz = (h_c - (C_c l)_D) - h_z``.

    Parameters
    ----------
    h_m : float
        The measured height (m up).
    sigma_m : float
        Its 1-sigma (m), > 0.
    lever_arm_b_m : array_like, shape (3,)
        From the IMU to the measured point, body axes (m); zeros by default.
    """

    name = "height"
    dim = 1

    def __init__(self, h_m, sigma_m, lever_arm_b_m=(0.0, 0.0, 0.0)):
        super().__init__(0.0, 0.0, h_m, sigma_m, lever_arm_b_m)

    def innovation(self, state: NavState) -> np.ndarray:
        """``dz`` (m, up)."""
        return np.array([state.h_m - (state.c_nb @ self.lever)[2] - self.h])

    def h_matrix(self, state: NavState) -> np.ndarray:
        """Minus the down row of :meth:`Position.h_matrix`."""
        return -super().h_matrix(state)[2:3]


class ZeroAngularRate(_Measurement):
    """At rest the corrected gyro rate is the Earth's rate in body axes (a zero angular rate w.r.t. the Earth).

    ``dz = (omega_gyro - b_g,est) - C_c^T omega_ie^n(lat_c)``; ``H = [-C^T Z_r, 0, -C^T [omega_ie x], -I, 0]``
    (``C_c^T = C^T (I - [psi x])``). It observes the gyro biases directly, with the gyro noise averaged
    over the interval (``sigma = ARW / sqrt(T)`` for white rate noise; Groves 2013, sec. 16.2.4 "zero
    angular rate update"). The noise it shares with the attitude propagation over the same interval is
    neglected (it is ``1/sqrt(n)`` of one sample's per axis).

    Parameters
    ----------
    gyro_rate_b_rad_s : array_like, shape (3,)
        Mean raw gyro rate over the interval (rad/s; :attr:`AidedNavigator.mean_gyro_rate_b_rad_s`).
    sigma_rad_s : float or array_like, shape (3,)
        1-sigma of that mean (rad/s), > 0.
    """

    name = "zero_angular_rate"
    dim = 3

    def __init__(self, gyro_rate_b_rad_s, sigma_rad_s):
        self.rate = _vec3("gyro_rate_b_rad_s", gyro_rate_b_rad_s)
        self._r = _sigma_matrix("sigma_rad_s", sigma_rad_s, 3)

    def innovation(self, state: NavState) -> np.ndarray:
        """``dz`` (rad/s, body axes)."""
        return self.rate - state.gyro_bias_rad_s - state.c_nb.T @ _wie(state.lat_rad)

    def h_matrix(self, state: NavState) -> np.ndarray:
        """``[-C^T Z_r, 0, -C^T [omega_ie x], -I, 0]``."""
        ct = state.c_nb.T
        h = np.zeros((3, N_STATES))
        h[:, 0] = -ct @ _d_earth_rate_d_rn(state.lat_rad, state.h_m)
        h[:, ATT] = -ct @ skew(_wie(state.lat_rad))
        h[:, GYRO_BIAS] = -_I3
        return h


#: The measurement plug-ins by name: ``name -> class`` (each with ``h_matrix(state)``, ``innovation(state)``,
#: ``r_matrix()``, ``dim``).
MEASUREMENTS = {cls.name: cls for cls in (ZeroVelocity, ZeroAngularRate, Position, Velocity, Height)}


def make_measurement(name, **kwargs):
    """A measurement plug-in by name (:data:`MEASUREMENTS`).

    Parameters
    ----------
    name : str
        One of :data:`MEASUREMENTS`.
    kwargs : keyword arguments
        The plug-in's constructor arguments.

    Returns
    -------
    object
        The measurement.

    Raises
    ------
    ValueError
        For an unknown name or an unknown keyword (the message names it and lists the allowed ones).
    """
    import inspect

    v.choice("", "measurement", name, MEASUREMENTS)
    cls = MEASUREMENTS[name]
    allowed = [p for p in inspect.signature(cls).parameters]
    for key in kwargs:
        if key not in allowed:
            raise ValueError(f"{name}.{key}: {v.unknown_key(key, allowed)}")
    return cls(**kwargs)


# --- error model ------------------------------------------------------------------------------------------------


def _rate_derivatives(lat, h, vel):
    """``W_v`` (d omega_en / d dv), ``W_r`` (d omega_en / d dr), ``Z_r`` (d omega_ie / d dr); Groves eq. 14.65-14.66."""
    r_n, r_e = earth.radii(lat)
    rn, re = r_n + h, r_e + h
    tl, cl = math.tan(lat), math.cos(lat)
    vn, ve = vel[0], vel[1]
    w_v = np.array([[0.0, 1.0 / re, 0.0], [-1.0 / rn, 0.0, 0.0], [0.0, -tl / re, 0.0]])
    w_r = np.zeros((3, 3))
    # d/dL, with the radii's own change (dR_E/dL, dR_N/dL = 3 R_N e^2 sin L cos L / (1 - e^2 sin^2 L)), per m north
    dre = _dre_dlat(lat)
    drn = 3.0 * r_n * earth.WGS84_E2 * math.sin(lat) * cl / (1.0 - earth.WGS84_E2 * math.sin(lat) ** 2)
    w_r[:, 0] = [-ve * dre / re ** 2, vn * drn / rn ** 2, -ve / (re * cl * cl) + ve * tl * dre / re ** 2]
    w_r[:, 0] /= rn
    w_r[:, 2] = [ve / re ** 2, -vn / rn ** 2, -ve * tl / re ** 2]   # d/d dr_D = -d/dh
    z_r = np.zeros((3, 3))
    z_r[:, 0] = _d_earth_rate_d_rn(lat, h)
    return w_v, w_r, z_r


def _dgamma(lat, h):
    """``(d gamma / dL, d gamma / dh)`` (m/s^2 per rad, s^-2) of :func:`sins_sim.earth.gravity_down`: NIMA
    TR8350.2 eq. 4-1 (Somigliana) times the height factor of eq. 4-3, differentiated."""
    s, c = math.sin(lat), math.cos(lat)
    s2 = s * s
    w = 1.0 - earth.WGS84_E2 * s2
    ge, k, a, fl = earth.GAMMA_EQUATOR_M_S2, earth.SOMIGLIANA_K, earth.WGS84_A_M, earth.WGS84_F
    g0 = ge * (1.0 + k * s2) / math.sqrt(w)
    hf = 1.0 - 2.0 / a * (1.0 + fl + earth.WGS84_M - 2.0 * fl * s2) * h + 3.0 * h * h / (a * a)
    dg0 = ge * s * c * (2.0 * k / math.sqrt(w) + (1.0 + k * s2) * earth.WGS84_E2 / w ** 1.5)
    dhf_dl = 8.0 * fl * s * c * h / a
    dhf_dh = -2.0 / a * (1.0 + fl + earth.WGS84_M - 2.0 * fl * s2) + 6.0 * h / (a * a)
    return dg0 * hf + g0 * dhf_dl, g0 * dhf_dh


def _dre_dlat(lat):
    """``d R_E / dL = R_E e^2 sin L cos L / (1 - e^2 sin^2 L)`` (m/rad), from :func:`sins_sim.earth.radii`."""
    s = math.sin(lat)
    w = 1.0 - earth.WGS84_E2 * s * s
    return earth.WGS84_A_M / math.sqrt(w) * earth.WGS84_E2 * s * math.cos(lat) / w


def error_dynamics(lat_rad, h_m, v_ned_m_s, c_nb, f_ned_m_s2, noise: ImuNoise) -> np.ndarray:
    """The continuous error-state matrix ``F`` (15 x 15; module docstring, Groves 2013 sec. 14.2.4).

    Parameters
    ----------
    lat_rad, h_m : float
        Computed latitude (rad) and height (m).
    v_ned_m_s : array_like, shape (3,)
        Computed velocity (m/s).
    c_nb : array_like, shape (3, 3)
        Computed ``C_nb``.
    f_ned_m_s2 : array_like, shape (3,)
        Specific force in NED (m/s^2).
    noise : ImuNoise
        For the bias correlation times.

    Returns
    -------
    ndarray, shape (15, 15)
    """
    lat = float(lat_rad)
    vel = np.asarray(v_ned_m_s, dtype=np.float64)
    c = np.asarray(c_nb, dtype=np.float64)
    r_n, r_e = earth.radii(lat)
    rn, re = r_n + h_m, r_e + h_m
    tl = math.tan(lat)
    vn, ve, vd = vel
    wie = _wie(lat)
    wen = np.array([ve / re, -vn / rn, -ve * tl / re])
    w_v, w_r, z_r = _rate_derivatives(lat, h_m, vel)
    f = np.zeros((N_STATES, N_STATES))
    # position (NED metres): d/dt of ((R_N+h) dL, (R_E+h) cos L dlambda, -dh)
    f[POS, VEL] = _I3
    f[0, 0], f[0, 2] = -vd / rn, vn / rn
    f[1, 0], f[1, 1], f[1, 2] = ve * tl / rn, -vd / re - vn * tl / rn, ve / re
    dre = _dre_dlat(lat)     # R_E varies with latitude: terms of relative size e^2 in dr_E' (none in dr_N')
    f[1, 0] -= ve * dre / (re * rn)
    f[1, 1] += vn * dre / (rn * re)
    # velocity: Groves eq. 14.67-14.68
    vx = skew(vel)
    f[VEL, POS] = vx @ (2.0 * z_r + w_r)
    dg_dl, dg_dh = _dgamma(lat, h_m)
    f[5, 0] += dg_dl / rn      # normal gravity varies with latitude (5e-3 g over 90 deg) and height
    f[5, 2] += -dg_dh
    f[VEL, VEL] = -skew(2.0 * wie + wen) + vx @ w_v
    f[VEL, ATT] = -skew(np.asarray(f_ned_m_s2, dtype=np.float64))
    f[VEL, ACCEL_BIAS] = -c
    # attitude: Groves eq. 14.64-14.66
    f[ATT, POS] = -(z_r + w_r)
    f[ATT, VEL] = -w_v
    f[ATT, ATT] = -skew(wie + wen)
    f[ATT, GYRO_BIAS] = -c
    # biases: first-order Gauss-Markov or constant + random walk
    if math.isfinite(noise.gyro_bias_tau_s):
        f[GYRO_BIAS, GYRO_BIAS] = -_I3 / noise.gyro_bias_tau_s
    if math.isfinite(noise.accel_bias_tau_s):
        f[ACCEL_BIAS, ACCEL_BIAS] = -_I3 / noise.accel_bias_tau_s
    return f


def sensor_error_columns(c_nb, omega_ib_b_rad_s, f_b_m_s2, kind, row, col) -> np.ndarray:
    """The columns of ``F`` of the sensor-error states (15 rows; module docstring, "Sensor-error states").

    A state ``dK[i, j]`` (the error of the estimate of element ``(i, j)`` of a triad's error matrix) makes the
    corrected rate (specific force) wrong by ``-dK[i, j] x_j`` on body axis ``i``, ``x`` the body rate ``omega_ib^b``
    (the specific force ``f^b``), so its column is ``-C[:, i] x_j`` on the attitude rows (gyros) or the velocity rows
    (accelerometers): ``psi' = ... - C (db_g + dK_g omega_ib^b)``, ``dv' = ... - C (db_a + dK_a f^b)`` (Groves
    2013, sec. 14.2.4 with the error model of sec. 4.4.6; Titterton & Weston 2004, sec. 12.3).

    Parameters
    ----------
    c_nb : array_like, shape (3, 3)
    omega_ib_b_rad_s, f_b_m_s2 : array_like, shape (3,)
        The block's mean body rate (rad/s) and specific force (m/s^2).
    kind, row, col : array_like of int, shape (m,)
        :meth:`UnmodelledErrors.state_table`.

    Returns
    -------
    ndarray, shape (15, m)
    """
    c = np.asarray(c_nb, dtype=np.float64)
    x = (np.asarray(omega_ib_b_rad_s, dtype=np.float64), np.asarray(f_b_m_s2, dtype=np.float64))
    out = np.zeros((N_STATES, len(kind)))
    for k, (kd, i, j) in enumerate(zip(kind, row, col)):
        rows = ATT if kd == 0 else VEL
        out[rows, k] = -c[:, i] * x[kd][j]
    return out


def process_noise_density(noise: ImuNoise) -> np.ndarray:
    """``Q' = G Q G^T`` (15 x 15, per second): white sensor noise into velocity and attitude, bias driving noise.

    The rate and specific-force noises enter through ``C_nb``; with the same density on the three axes
    ``C S I C^T = S I``, so ``Q'`` is diagonal (Groves 2013, eq. 14.80-14.82).

    Parameters
    ----------
    noise : ImuNoise
        The sensor-error model.

    Returns
    -------
    ndarray, shape (15, 15)
    """
    d = np.zeros(N_STATES)
    d[VEL] = noise.accel_vrw_m_s_sqrt_s ** 2
    d[ATT] = noise.gyro_arw_rad_sqrt_s ** 2
    for sl, sigma, tau, rw in ((GYRO_BIAS, noise.gyro_bias_sigma_rad_s, noise.gyro_bias_tau_s,
                                noise.gyro_bias_rw_rad_s_sqrt_s),
                               (ACCEL_BIAS, noise.accel_bias_sigma_m_s2, noise.accel_bias_tau_s,
                                noise.accel_bias_rw_m_s2_sqrt_s)):
        d[sl] = 2.0 * sigma * sigma / tau if math.isfinite(tau) else rw * rw
    return np.diag(d)


def discretize(f, q_density, t_s):
    """``(Phi, Q_d)`` over ``t_s``: Taylor series of ``expm(F T)`` and of van Loan's (1978) integral.

    ``Phi = sum_{k=0}^{5} (F T)^k / k!`` and ``Q_d = sum_{k=0}^{5} M_k T^(k+1) / (k+1)!`` with
    ``M_0 = Q'``, ``M_k = F M_(k-1) + M_(k-1) F^T`` (the expansion of
    ``int_0^T expm(F s) Q' expm(F s)^T ds``; ``M_k = sum_j C(k, j) F^j Q' F^T^(k-j)``). Five powers hold
    the nilpotent chain ``db_g -> psi -> dv -> dr`` (three steps) with two slow factors on it (a bias
    correlation time, the Earth rate); the white noise enters at the start of the chains on both sides
    (gyro noise reaches the position variance as ``g^2 S_g T^5 / 20``, the ``k = 4`` term).

    Parameters
    ----------
    f : ndarray, shape (n, n)
        Continuous ``F``.
    q_density : ndarray, shape (n, n)
        ``Q' = G Q G^T`` (per second).
    t_s : float
        Interval (s).

    Returns
    -------
    phi, q_d : ndarray, shape (n, n)
    """
    ft = f * t_s
    term = np.eye(f.shape[0])
    phi = term.copy()
    for k in range(1, _SERIES_ORDER + 1):
        term = term @ ft / k
        phi = phi + term
    m = np.asarray(q_density, dtype=np.float64)
    q_d = m * t_s
    coef = t_s
    for k in range(1, _SERIES_ORDER + 1):
        fm = f @ m
        m = fm + fm.T
        coef *= t_s / (k + 1)
        q_d = q_d + m * coef
    return phi, 0.5 * (q_d + q_d.T)


#: Highest power of ``F`` in the series of ``Phi`` and ``Q_d`` (:func:`discretize`).
_SERIES_ORDER = 5


def initial_covariance(pos_sigma_m, vel_sigma_m_s, tilt_sigma_rad, heading_sigma_rad, noise: ImuNoise) -> np.ndarray:
    """Diagonal ``P0``: the given sigmas, the biases' turn-on sigmas of ``noise``.

    Parameters
    ----------
    pos_sigma_m : float or array_like, shape (3,)
        Position 1-sigma NED (m), >= 0.
    vel_sigma_m_s : float or array_like, shape (3,)
        Velocity 1-sigma NED (m/s), >= 0.
    tilt_sigma_rad : float
        Tilt (psi north and east) 1-sigma (rad), >= 0.
    heading_sigma_rad : float
        Heading (psi down) 1-sigma (rad), >= 0.
    noise : ImuNoise
        For the bias sigmas.

    Returns
    -------
    ndarray, shape (15, 15)
    """
    d = np.zeros(N_STATES)
    for sl, name, val in ((POS, "pos_sigma_m", pos_sigma_m), (VEL, "vel_sigma_m_s", vel_sigma_m_s)):
        arr = np.broadcast_to(np.asarray(val, dtype=np.float64), (3,))
        if not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
            raise ValueError(f"{name}: must be finite and >= 0, got {val!r}")
        d[sl] = arr ** 2
    d[ATT.start] = d[ATT.start + 1] = v.non_negative("", "tilt_sigma_rad", tilt_sigma_rad) ** 2
    d[HEADING] = v.non_negative("", "heading_sigma_rad", heading_sigma_rad) ** 2
    d[GYRO_BIAS] = noise.gyro_bias_sigma_rad_s ** 2
    d[ACCEL_BIAS] = noise.accel_bias_sigma_m_s2 ** 2
    return np.diag(d)


# --- the closed loop --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Innovation:
    """One measurement's innovation record.

    Attributes
    ----------
    t_s : float
        Time of the update (s).
    name : str
        The measurement's name.
    innovation : ndarray, shape (dim,)
        ``nu = dz - H x`` (the measurement's units).
    s_matrix : ndarray, shape (dim, dim)
        Its covariance ``S = H P H^T + R``.
    nis : float
        ``nu^T S^-1 nu`` (chi-square with ``dim`` degrees of freedom for a consistent filter).
    """

    t_s: float
    name: str
    innovation: np.ndarray
    s_matrix: np.ndarray
    nis: float


class AidedNavigator:
    """A :class:`StrapdownNavigator` with an error-state Kalman filter in closed loop (module docstring).

    :meth:`process` feeds the navigator the increments corrected by the bias estimates
    (``dtheta - b_g dt``, ``dv - b_a dt``) and propagates the covariance in blocks of whole navigation
    updates of at most ``max_propagation_s``: over a block, ``F`` is evaluated once with the specific force
    ``f^n = (v_end - v_start)/T - g^n + (2 omega_ie + omega_en) x v`` (the navigator's own mean, from
    its velocity change: the navigation equation, Titterton & Weston 2004 ch. 3, solved for ``f``) and ``C_nb`` of the normalised mean quaternion, and
    ``Phi``, ``Q_d`` come from :func:`discretize`. :meth:`update` first propagates up to the current
    navigation update, then applies the measurements (stacked), and with ``feedback`` corrects the
    navigator and the biases and resets the error state to zero.

    Parameters
    ----------
    navigator : StrapdownNavigator
        The navigator to aid (``vertical="free"``: the filter models the free vertical channel; aid the
        height with :class:`Height` instead of the navigator's own loop).
    noise : ImuNoise
        Sensor-error model of the filter.
    p0 : array_like, shape (15, 15)
        Initial covariance (:func:`initial_covariance`).
    gyro_bias_rad_s, accel_bias_m_s2 : array_like, shape (3,)
        Initial bias estimates (body axes); zeros by default.
    max_propagation_s : float
        Longest covariance propagation step (s), > 0; rounded down to whole navigation updates (at
        least one).
    feedback : bool
        Closed loop (default). ``False`` keeps the navigator free and lets the error state accumulate
        (``x <- Phi x`` between updates): the open-loop filter, whose corrected solution is
        :meth:`corrected_state`.
    unmodelled : UnmodelledErrors or None
        Scale factors and misalignments: process noise per propagation block from the angle and velocity change
        the block adds (:class:`UnmodelledErrors`), and the groups of its ``states`` as sensor-error states after
        the fix-error states (module docstring); None: none.
    fix_errors : FixErrorStates or None
        The fixes' Gauss-Markov errors as states 15 on (module docstring); None: none. ``p0`` may be (15, 15) or
        cover the fix-error states only, the states it leaves out starting at their priors (the fix errors'
        stationary variance, the sensor errors' sigma squared), uncorrelated; or (n, n).
    """

    def __init__(self, navigator, noise, p0, *, gyro_bias_rad_s=(0.0, 0.0, 0.0), accel_bias_m_s2=(0.0, 0.0, 0.0),
                 max_propagation_s=1.0, feedback=True, unmodelled=None, fix_errors=None):
        if not isinstance(navigator, StrapdownNavigator):
            raise ValueError(f"navigator: must be a StrapdownNavigator, got {type(navigator).__name__}")
        if navigator.vertical != "free":
            raise ValueError(f"navigator: must have vertical='free' (the filter models the free channel; use "
                             f"the 'height' measurement), got vertical={navigator.vertical!r}")
        if not isinstance(noise, ImuNoise):
            raise ValueError(f"noise: must be an ImuNoise, got {type(noise).__name__}")
        if unmodelled is not None and not isinstance(unmodelled, UnmodelledErrors):
            raise ValueError(f"unmodelled: must be UnmodelledErrors or None, got {type(unmodelled).__name__}")
        if fix_errors is not None and not isinstance(fix_errors, FixErrorStates):
            raise ValueError(f"fix_errors: must be FixErrorStates or None, got {type(fix_errors).__name__}")
        n_fix = 0 if fix_errors is None else fix_errors.n_states
        kind, row, col, sens_sigma, _ = (np.zeros(0, np.int64),) * 3 + (np.zeros(0), ()) if unmodelled is None \
            else unmodelled.state_table()
        n = N_STATES + n_fix + kind.shape[0]
        p = v.finite_array("", "p0", p0, ndim=2)
        # the states p0 leaves out start at their priors, uncorrelated: the fix errors' stationary variance, the
        # sensor errors' sigma
        prior = np.concatenate([np.zeros(N_STATES), np.zeros(0) if fix_errors is None else fix_errors.variance,
                                sens_sigma ** 2])
        if p.shape[0] == p.shape[1] and p.shape[0] in (N_STATES, N_STATES + n_fix) and p.shape[0] < n:
            k = p.shape[0]
            p = np.block([[p, np.zeros((k, n - k))], [np.zeros((n - k, k)), np.diag(prior[k:])]])
        if p.shape != (n, n) or not np.allclose(p, p.T, rtol=0.0, atol=1e-12 * np.max(np.abs(p))) \
                or np.min(np.linalg.eigvalsh(p)) < -1e-12 * np.max(np.abs(p)):
            raise ValueError(f"p0: must be a symmetric positive semi-definite ({n}, {n}) matrix, "
                             f"got shape {p.shape}")
        self._n = n
        self._fix_errors = fix_errors
        # sensor-error states (UnmodelledErrors.states) after the fix errors: the table of F's columns, the estimated
        # error matrices of the gyros and accelerometers, and the inverses of (I + K) the increments are corrected by
        self._sens0 = N_STATES + n_fix
        self._sens = (kind, row, col)
        self._k_est = np.zeros((2, 3, 3))
        self._k_inv = np.stack([_I3, _I3])
        self._fix_tau = np.zeros(0) if fix_errors is None else fix_errors.tau_s
        self._fix_var = np.zeros(0) if fix_errors is None else fix_errors.variance
        self._nav = navigator
        self._noise = noise
        self._p = 0.5 * (p + p.T)
        self._x = np.zeros(n)
        self._bg = _vec3("gyro_bias_rad_s", gyro_bias_rad_s)
        self._ba = _vec3("accel_bias_m_s2", accel_bias_m_s2)
        big_t = navigator.update_period_s
        self._n_prop = max(1, int(math.floor(v.positive("", "max_propagation_s", max_propagation_s) / big_t
                                             * (1.0 + 1e-12))))
        self._feedback = bool(feedback)
        self._qc = np.zeros((n, n))
        self._qc[:N_STATES, :N_STATES] = process_noise_density(noise)
        self._unmod = unmodelled
        self._unmod_var = np.zeros(4) if unmodelled is None else unmodelled.variances
        self._f_ref = None if unmodelled is None else unmodelled.accel_reference_b_m_s2
        if self._f_ref is not None:
            self._f_ref = np.array(self._f_ref, dtype=np.float64)
        # running integrals at the last navigation update: raw angle (rad) and velocity less f_ref t (m/s), body
        self._acc = np.zeros(6)
        self._origin = np.zeros(6)     # their origins (UnmodelledErrors: restarted where the vehicle turns back)
        self._inv_tau = (1.0 / noise.gyro_bias_tau_s, 1.0 / noise.accel_bias_tau_s)   # 0.0 for inf
        self._prior_bias_var = np.diag(self._p)[BIASES].copy()
        self._records: list[Innovation] = []
        self._block_start = self._snapshot_row()
        self._block_n = 0          # navigation updates since the block start
        self._sum_dtheta = np.zeros(3)
        self._sum_n = 0
        self._pend_raw = (np.zeros((0, 3)), np.zeros((0, 3)))
        self._epoch_rate = np.full(3, np.nan)
        self._epoch_update = -1
        self._phi_acc = np.eye(n)     # product of the block transitions since the last propagate()
        self._last_correction = np.zeros(n)

    # --- state ----------------------------------------------------------------------------------------------

    @property
    def navigator(self) -> StrapdownNavigator:
        """The aided navigator."""
        return self._nav

    @property
    def n_states(self) -> int:
        """Number of states: 15, plus the fix-error states, plus the sensor-error states."""
        return self._n

    @property
    def sensor_error_slice(self) -> slice:
        """The sensor-error states' indices (:meth:`UnmodelledErrors.state_table`; empty without)."""
        return slice(self._sens0, self._n)

    @property
    def gyro_error_matrix(self) -> np.ndarray:
        """The estimated error matrix ``K_g`` of the gyros (scale factors on the diagonal, misalignments off it; the
        increments are corrected by ``(I + K_g)^-1``; zeros without the states; copy)."""
        return self._k_est[0].copy()

    @property
    def accel_error_matrix(self) -> np.ndarray:
        """The same for the accelerometers, ``K_a``."""
        return self._k_est[1].copy()

    @property
    def fix_errors(self):
        """The fix-error states' model (:class:`FixErrorStates`) or None."""
        return self._fix_errors

    @property
    def t_s(self) -> float:
        """Time of the last navigation update (s)."""
        return self._nav.n_updates * self._nav.update_period_s

    @property
    def x(self) -> np.ndarray:
        """Error-state estimate (copy; its first 15 entries zero after feedback)."""
        return self._x.copy()

    @property
    def p(self) -> np.ndarray:
        """Error-state covariance (copy)."""
        return self._p.copy()

    @property
    def gyro_bias_rad_s(self) -> np.ndarray:
        """Gyro bias estimate (body axes, rad/s; copy)."""
        return self._bg.copy()

    @property
    def accel_bias_m_s2(self) -> np.ndarray:
        """Accelerometer bias estimate (body axes, m/s^2; copy)."""
        return self._ba.copy()

    @property
    def unaided_bias_sigma(self) -> np.ndarray:
        """1-sigma the six bias states would have with no measurement (gyro xyz, accel xyz): the prior."""
        return np.sqrt(self._prior_bias_var)

    @property
    def innovations(self) -> list:
        """The :class:`Innovation` records so far (a copy of the list)."""
        return list(self._records)

    @property
    def mean_gyro_rate_b_rad_s(self) -> np.ndarray:
        """Mean raw gyro rate (rad/s, body) of the samples since the previous measurement epoch (NaN before any)."""
        self._roll_epoch()
        return self._epoch_rate.copy()

    def nav_state(self) -> NavState:
        """The computed state now (at the last navigation update)."""
        nav = self._nav
        return NavState(self.t_s, nav.lat_rad, nav.lon_rad, nav.h_m, nav.v_ned_m_s, nav.q_nb,
                        self._bg.copy(), self._ba.copy())

    def corrected_state(self) -> NavState:
        """The computed state with the current error estimate ``x`` removed (equals :meth:`nav_state` in
        closed loop; the open-loop filter's solution otherwise)."""
        s = self._nav.state_array()
        nav = StrapdownNavigator(s[ksd.ST_LAT], s[ksd.ST_LON], s[ksd.ST_H], s[ksd.ST_V:ksd.ST_V + 3],
                                 s[ksd.ST_Q:ksd.ST_Q + 4], self._nav.dt_s)
        nav.apply_correction(self._x[POS], self._x[VEL], self._x[ATT])
        return NavState(self.t_s, nav.lat_rad, nav.lon_rad, nav.h_m, nav.v_ned_m_s, nav.q_nb,
                        self._bg - self._x[GYRO_BIAS], self._ba - self._x[ACCEL_BIAS])

    def sigma(self) -> np.ndarray:
        """1-sigma of the states (sqrt of the covariance diagonal)."""
        return np.sqrt(np.maximum(np.diag(self._p), 0.0))

    # --- processing -----------------------------------------------------------------------------------------

    def _snapshot_row(self):
        """``(lat, h, v_N, v_E, v_D, q0..q3)`` of the navigator now and the running integrals of the raw angle and
        velocity (a block end, :func:`kekf.propagate_block`)."""
        s = self._nav.state_array()
        return np.concatenate([s[ksd.ST_LAT:ksd.ST_LAT + 1], s[ksd.ST_H:ksd.ST_H + 1], s[ksd.ST_V:ksd.ST_V + 3],
                               s[ksd.ST_Q:ksd.ST_Q + 4], self._acc])

    def _integrals(self, dth, dvel, pending, m):
        """The running integrals at the end of each of the ``m`` navigation updates this chunk completes (the
        chunk's first ``n_sub - pending`` samples complete the pending update), and carried on past them (compiled,
        :func:`kekf.running_integrals`; :meth:`_integrals_reference` is the numpy form, equal bit for bit)."""
        nav = self._nav
        if self._f_ref is None:
            self._f_ref = dvel.sum(axis=0) / (dvel.shape[0] * nav.dt_s)
        acc = np.empty((m, 6))
        if m:
            kekf.running_integrals(dth, dvel, self._acc, self._f_ref, nav.update_period_s, nav.n_sub, pending, acc)
            self._acc = acc[-1].copy()
        return acc

    def _integrals_reference(self, dth, dvel, pending, m):
        """:meth:`_integrals` in numpy (cumulative sums over the chunk)."""
        nav = self._nav
        if self._f_ref is None:
            self._f_ref = dvel.sum(axis=0) / (dvel.shape[0] * nav.dt_s)
        acc = np.empty((m, 6))
        if m:
            idx = (np.arange(m) + 1) * nav.n_sub - pending - 1
            t_row = (np.arange(m) + 1) * nav.update_period_s
            acc[:, :3] = self._acc[:3] + np.cumsum(dth, axis=0)[idx]
            acc[:, 3:] = self._acc[3:] + np.cumsum(dvel, axis=0)[idx] - np.outer(t_row, self._f_ref)
            self._acc = acc[-1].copy()
        return acc

    def process(self, dtheta, dv) -> NavSolution:
        """Navigate a chunk of increments with the bias estimates removed, propagating the covariance.

        Parameters
        ----------
        dtheta : array_like, shape (n, 3)
            Raw gyro angle increments (rad, body).
        dv : array_like, shape (n, 3)
            Raw velocity increments (m/s, body).

        Returns
        -------
        NavSolution
            The navigator's rows of this chunk (one per navigation update).
        """
        dth = _increments("dtheta", dtheta)
        dvel = _increments("dv", dv)
        if dvel.shape[0] != dth.shape[0]:
            raise ValueError(f"dv: must have {dth.shape[0]} rows (len(dtheta)), got {dvel.shape[0]}")
        return self._process_checked(dth, dvel)

    def _process_checked(self, dth, dvel) -> NavSolution:
        """:meth:`process` on checked increments (float64, finite, C-contiguous, shape (n, 3) each): the
        navigator's kernel directly (its ``vertical`` is ``free``: no height aid), one check per chunk in
        :class:`~sins_sim.navigation.aided.AidedRun`."""
        nav = self._nav
        dt = nav.dt_s
        # dth - b_g dt, dv - b_a dt and the gyro sum since the last epoch in one compiled pass (same values)
        dth_c, dv_c = np.empty_like(dth), np.empty_like(dvel)
        kekf.bias_corrected(dth, dvel, self._bg * dt, self._ba * dt, dth_c, dv_c, self._sum_dtheta)
        if self._n > self._sens0:       # estimated scale factors and misalignments: (I + K)^-1 (x - b dt), per triad
            kekf.triad_corrected(dth_c, self._k_inv[0])
            kekf.triad_corrected(dv_c, self._k_inv[1])
        self._sum_n += dth.shape[0]
        pending = nav.pending_samples
        out = nav._run(dth_c, dv_c, _NO_AID)
        m = out.shape[0]
        if self._unmod is not None and dth.shape[0]:
            if pending:      # the running integrals count whole updates: the pending samples join this chunk
                dth = np.concatenate([self._pend_raw[0], dth])
                dvel = np.concatenate([self._pend_raw[1], dvel])
                pending = 0
            acc = self._integrals(dth, dvel, pending, m)
            rest = dth.shape[0] - m * nav.n_sub
            self._pend_raw = (dth[dth.shape[0] - rest:].copy(), dvel[dvel.shape[0] - rest:].copy())
        else:
            acc = np.zeros((m, 6))
        sol = NavSolution(t_s=(nav.n_updates - m + 1 + np.arange(m)) * nav.update_period_s,
                          lat_rad=out[:, ksd.OUT_LAT].copy(), lon_rad=out[:, ksd.OUT_LON].copy(),
                          h_m=out[:, ksd.OUT_H].copy(), v_ned_m_s=out[:, ksd.OUT_V:ksd.OUT_V + 3].copy(),
                          q_nb=out[:, ksd.OUT_Q:ksd.OUT_Q + 4].copy())
        if m == 0:
            return sol
        # block ends inside this chunk: rows j with (block_n + j + 1) % n_prop == 0
        first = self._n_prop - self._block_n - 1
        ends = range(first, m, self._n_prop)
        if len(ends):
            rows = np.concatenate([out[first::self._n_prop][:, _BLOCK_ROW], acc[first::self._n_prop]], axis=1)
            for row in rows:
                self._propagate_block(row, self._n_prop)
        last = ends[-1] if len(ends) else -1
        if last >= 0:
            self._block_n = m - 1 - last
        else:
            self._block_n += m
        return sol

    def _propagate_block(self, end, n_updates):
        """One block (the compiled :func:`kekf.propagate_block`; the reference in numpy is
        :meth:`_propagate_block_reference`)."""
        t = n_updates * self._nav.update_period_s
        if self._n > self._sens0:
            kekf.propagate_block_states(self._block_start, end, t, self._inv_tau[0], self._inv_tau[1], self._qc,
                                        self._unmod_var, self._origin, self._p, self._phi_acc, self._x,
                                        not self._feedback, self._fix_tau, self._fix_var,
                                        np.zeros(3) if self._f_ref is None else self._f_ref, *self._sens)
        else:
            kekf.propagate_block(self._block_start, end, t, self._inv_tau[0], self._inv_tau[1], self._qc,
                                 self._unmod_var, self._origin, self._p, self._phi_acc, self._x, not self._feedback,
                                 self._fix_tau, self._fix_var)
        self._prior_bias_var = self._noise.bias_variance_after(self._prior_bias_var, t)
        self._block_start = end

    def _propagate_block_reference(self, end, n_updates):
        """:meth:`_propagate_block` in numpy from :func:`error_dynamics` and :func:`discretize` (the reference the
        tests hold the kernel to)."""
        s0, s1 = self._block_start, end
        lat0, h0, v0, q0 = s0[0], s0[1], s0[2:5], s0[5:9]
        lat1, h1, v1, q1 = s1[0], s1[1], s1[2:5], s1[5:9]
        t = n_updates * self._nav.update_period_s
        lat, h = 0.5 * (lat0 + lat1), 0.5 * (h0 + h1)
        vel = 0.5 * (v0 + v1)
        qm = q0 + (q1 if float(q0 @ q1) >= 0.0 else -q1)
        c = _dcm(qm / math.sqrt(float(qm @ qm)))
        r_n, r_e = earth.radii(lat)
        wie = _wie(lat)
        wen = np.array([vel[1] / (r_e + h), -vel[0] / (r_n + h), -vel[1] * math.tan(lat) / (r_e + h)])
        # f^n = v' - g^n + (2 omega_ie + omega_en) x v   (the navigation equation, Titterton & Weston 2004
        # ch. 3, solved for f; the mean over the block from the navigator's velocity change)
        f_n = (v1 - v0) / t + _cross(2.0 * wie + wen, vel)
        f_n[2] -= float(earth.gravity_down(lat, h))
        fm = error_dynamics(lat, h, vel, c, f_n, self._noise)
        qc = self._qc.copy()
        un = self._unmod
        if un is not None:       # the unmodelled errors' variance over the block (UnmodelledErrors), body to NED
            var = self._unmod_var
            for sl, a, vs, vm in ((ATT, slice(9, 12), var[0], var[1]), (VEL, slice(12, 15), var[2], var[3])):
                if vs == 0.0 and vm == 0.0:
                    continue
                o = slice(a.start - 9, a.stop - 9)
                d, self._origin[o] = unmodelled_variance_increment(s0[a], s1[a], math.sqrt(vs), math.sqrt(vm),
                                                                   self._origin[o])
                qc[sl, sl] += c @ np.diag(d) @ c.T / t
        n = self._n
        fn, qn = np.zeros((n, n)), np.zeros((n, n))
        fn[:N_STATES, :N_STATES], qn[:N_STATES, :N_STATES] = fm, qc[:N_STATES, :N_STATES]
        if n > self._sens0:      # the block's mean body rate and specific force from the running integrals
            w_b = (s1[9:12] - s0[9:12]) / t
            f_b = (s1[12:15] - s0[12:15]) / t + self._f_ref
            fn[:N_STATES, self._sens0:] = sensor_error_columns(c, w_b, f_b, *self._sens)
        phi, q_d = discretize(fn, qn, t)
        gm = np.arange(N_STATES, self._sens0)
        phi[gm, gm], q_d[gm, gm] = gauss_markov_discrete(self._fix_tau, np.sqrt(self._fix_var), t)
        p = phi @ self._p @ phi.T + q_d
        self._p = 0.5 * (p + p.T)
        self._phi_acc = phi @ self._phi_acc
        if not self._feedback:
            self._x = phi @ self._x
        else:
            self._x[gm] = phi[gm, gm] * self._x[gm]
        self._prior_bias_var = self._noise.bias_variance_after(self._prior_bias_var, t)
        self._block_start = end

    def _flush(self):
        """Propagate the covariance over the navigation updates since the last block end."""
        if self._block_n:
            self._propagate_block(self._snapshot_row(), self._block_n)
            self._block_n = 0

    def propagate(self) -> np.ndarray:
        """Propagate the covariance up to the current navigation update with no measurement.

        Returns
        -------
        ndarray, shape (n, n)
            The transition matrix ``Phi`` from the previous call (or the start) to now, the product of the
            block transitions in between (a smoother's input; Rauch, Tung & Striebel 1965).
        """
        self._flush()
        phi = self._phi_acc
        self._phi_acc = np.eye(self._n)
        return phi

    @property
    def last_correction(self) -> np.ndarray:
        """The last update's change of the error state (copy; zeros before any, and without feedback): its first 15
        entries the correction fed back, then the change of the fix-error estimates (not fed back), then that of
        the sensor-error states (fed back)."""
        return self._last_correction.copy()

    def _roll_epoch(self):
        n_upd = self._nav.n_updates
        if n_upd != self._epoch_update:
            if self._sum_n:
                self._epoch_rate = self._sum_dtheta / (self._sum_n * self._nav.dt_s)
            self._sum_dtheta = np.zeros(3)
            self._sum_n = 0
            self._epoch_update = n_upd

    def update(self, *measurements) -> list:
        """Apply measurements at the current navigation update (stacked into one update), then feed back.

        Parameters
        ----------
        *measurements : measurement plug-ins
            Instances of the classes of :data:`MEASUREMENTS` (or any object with ``dim``,
            ``h_matrix(state)``, ``innovation(state)``, ``r_matrix()``), independent of each other.

        Returns
        -------
        list of Innovation
            One record per measurement.

        Raises
        ------
        ValueError
            When samples are pending towards the next navigation update (measurements apply at update
            boundaries) or no measurement is given.
        """
        if not measurements:
            raise ValueError("measurements: give at least one measurement")
        self._begin_update()
        state = self.nav_state()
        hs, dzs, rs, dims = [], [], [], []
        for meas in measurements:
            hs.append(meas.h_matrix(state))
            dzs.append(meas.innovation(state))
            rs.append(meas.r_matrix())
            dims.append(meas.dim)
        h = np.vstack(hs) if len(hs) > 1 else np.ascontiguousarray(hs[0], dtype=np.float64)
        if self._n > N_STATES:        # the fix-error states' -I on the rows of the GNSS measurements they corrupt
            hn = np.zeros((h.shape[0], self._n))
            hn[:, :h.shape[1]] = h
            k0 = 0
            for meas, d in zip(measurements, dims):
                cols = None if self._fix_errors is None else self._fix_errors.columns(meas.name)
                if cols is not None:
                    hn[k0 + np.arange(3), np.arange(cols.start, cols.stop)] = -1.0
                k0 += d
            h = hn
        n = h.shape[0]
        r = np.zeros((n, n))
        k0 = 0
        for rm, d in zip(rs, dims):
            r[k0:k0 + d, k0:k0 + d] = rm
            k0 += d
        return self._update_stacked(h, np.concatenate(dzs).astype(np.float64, copy=False), r,
                                    [meas.name for meas in measurements], dims)

    def _begin_update(self):
        """Checks and the propagation up to now before an update (:meth:`update`)."""
        if self._nav.pending_samples:
            raise ValueError(f"update: measurements apply at navigation updates; {self._nav.pending_samples} "
                             f"input samples are pending (feed whole multiples of n_sub)")
        self._roll_epoch()
        self._flush()

    def _update_stacked(self, h, dz, r, names, dims) -> list:
        """The update of :meth:`update` from the stacked ``H``, ``dz`` and block-diagonal ``R`` (after
        :meth:`_begin_update`), with the records and the feedback."""
        # Joseph form, compiled (kekf.joseph_update; _joseph_reference is the numpy form it is tested against)
        self._x = self._x.copy()
        x_before = self._x.copy()
        nu, s = kekf.joseph_update(self._p, self._x, h, r, dz)
        self._change = self._x - x_before
        recs = []
        k0 = 0
        t = self.t_s
        nis = kekf.block_nis(s, nu, np.array(dims, dtype=np.int64))
        for name, d, nis_b in zip(names, dims, nis):
            sb = s[k0:k0 + d, k0:k0 + d]
            nb = nu[k0:k0 + d]
            rec = Innovation(t, name, nb.copy(), sb.copy(), float(nis_b))
            recs.append(rec)
            k0 += d
        self._records.extend(recs)
        if self._feedback:
            self._apply_feedback()
        return recs

    @staticmethod
    def _joseph_reference(p, x, h, r, dz):
        """The update of :func:`kekf.joseph_update` in numpy (Groves 2013, eq. 3.58): ``(p, x, nu, s)`` after it."""
        nu = dz - h @ x
        ph = p @ h.T
        s = h @ ph + r
        s = 0.5 * (s + s.T)
        gain = np.linalg.solve(s, ph.T).T
        ikh = np.eye(p.shape[0]) - gain @ h
        pn = ikh @ p @ ikh.T + gain @ r @ gain.T
        return 0.5 * (pn + pn.T), x + gain @ nu, nu, s

    def _apply_feedback(self):
        x = self._x
        self._last_correction = self._change
        if math.isfinite(float(x[:N_STATES].sum())):      # the checks of apply_correction, once
            kekf.correct_state(self._nav._state, x)       # apply_correction compiled (vertical free)
        else:
            self._nav.apply_correction(x[POS], x[VEL], x[ATT])      # raises, naming the part
        self._bg = self._bg - x[GYRO_BIAS]
        self._ba = self._ba - x[ACCEL_BIAS]
        self._x = x.copy()
        self._x[:N_STATES] = 0.0      # the fix-error states are the receiver's, not fed back
        if self._n > self._sens0:     # the scale factors and misalignments like the biases: K_est -= dK
            kekf.sensor_feedback(self._k_est, self._k_inv, x[self._sens0:], *self._sens)    # and (I + K_est)^-1
            self._x[self._sens0:] = 0.0
        self._block_start = self._snapshot_row()
