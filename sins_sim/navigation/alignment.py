"""Self-alignment without a filter: coarse (analytic) and inertial-frame (optimisation-based).

A logged strapdown run has no truth attitude: alignment finds it from the sensors while the base is at rest
(it may sway). Two methods, both returning :class:`~sins_sim.navigation.alignment_result.AlignmentResult`:

- :func:`align_coarse`: levelling from the mean specific force and gyrocompassing from the mean rate
  (TRIAD with gravity as the primary vector). Exact on a still base; on a swaying base the mean rate carries
  the sway's net rotation over the window, which does not average out of the Earth's rate (15 deg/h).
- :func:`align_inertial`: the inertial-frame (i0) alignment. The gyros track the body against the body frame
  at the start (held inertial), the specific force is integrated in that frame, and the result is compared with
  the apparent motion of gravity in the navigation frame at the start (held inertial), known in closed form
  from the latitude and ``Omega t``; the constant rotation between the two frames is Davenport's q-method over
  every velocity-integral observation (Wu, Wu, Hu and Hu 2011). Sway is tracked by the gyros and drops out.

Frames, units and conventions: body axes forward-right-down, navigation frame north-east-down (NED), ``q_nb``
Hamilton scalar first (body to NED). Increments are raw (rad and m/s per interval ``dt_s``, Earth rate and
gravity included). The attitude uncertainty ``sigma_rad`` is the 1-sigma of ``psi`` (north, east, down) with
``C_nb_est = (I + [psi x]) C_nb_true``.

Observability at rest (Groves 2013; Titterton and Weston 2004, sec. 10.2): a horizontal
accelerometer bias is inseparable from a tilt, and the east gyro bias from a heading error, so

``psi_N = -b_E / g``, ``psi_E = b_N / g``, ``psi_D = -eps_E / (Omega cos lat) - psi_N tan lat``

(``b`` and ``eps`` the accelerometer and gyro biases resolved in NED). The inertial method's end attitude is
tracked by the gyros from an estimate centred on the window, and carries half their drift over it about north
and down besides: ``psi_N += eps_N T / 2``, ``psi_D += eps_D T / 2`` (the east drift is the gyrocompass term).
Both methods report these bounds, combined in quadrature with the data's own scatter.

The bias is not constant over the window where the gyros have a rate random walk or a bias instability: the
gyrocompass then reads the window's *mean* east bias, ``psi_D = -mean(eps_E) / (Omega cos lat)`` (Titterton and
Weston 2004, sec. 10.2.2). Beside the fixed bias's prior, the mean's wander enters with
(:func:`mean_bias_wander_sigma`) ``var = K^2 T / 3`` for a random walk of density ``K`` started at the window's start
(``(1 / T^2) int int min(s, t) ds dt = T / 3``) and, for each first-order Gauss-Markov process of variance ``q`` and
correlation time ``tau`` (the bias instability as a sum of them), ``q f(T / tau)``, ``f(x) = 2 (x - 1 + e^-x) / x^2``
(the variance of the time average of an exponentially correlated process; Brown and Hwang 2012, ch. 2, the
time average of a Gauss-Markov process). The block means' scatter does not hold it: a random walk is correlated
over the whole window, and its block means scatter far less than their common mean wanders.

.. autosummary::

   align_coarse
   align_inertial

References
----------
.. [1] P. G. Savage, *Strapdown Analytics*, 2nd ed., Strapdown Associates, 2007, ch. 6 (initial alignment).
.. [2] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IEE, 2004,
   sec. 10.2 (alignment on a stationary platform).
.. [3] P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed.,
   Artech House, 2013, the sections on attitude initialization (levelling, gyrocompassing and their error
   limits) and on quasi-stationary alignment.
.. [4] M. Wu, Y. Wu, X. Hu, D. Hu, "Optimization-based alignment for inertial navigation systems: theory and
   algorithm", Aerospace Science and Technology 15(1), 1-17, 2011; see also Y. Wu, X. Pan,
   "Velocity/position integration formula, part I: application to in-flight coarse alignment", IEEE Trans.
   Aerospace and Electronic Systems 49(2), 2013.
.. [5] P. B. Davenport, "A vector approach to the algebra of rotations with applications", NASA TN D-4696,
   1968; M. D. Shuster, S. D. Oh, "Three-axis attitude determination from vector observations", J. Guidance
   and Control 4(1), 70-77, 1981 (TRIAD and the q-method).
.. [6] P. G. Savage, "Strapdown inertial navigation integration algorithm design, Part 2: Velocity and
   position algorithms", J. Guidance, Control, and Dynamics 21(2), 208-221, 1998 (rotation and sculling
   compensation of the velocity increments).
.. [7] H. Flyvbjerg, H. G. Petersen, "Error estimates on averages of correlated data", J. Chem. Phys. 91(1),
   461-466, 1989 (block means).
.. [8] K. S. Arun, T. S. Huang, S. D. Blostein, "Least-squares fitting of two 3-D point sets", IEEE Trans.
   Pattern Analysis and Machine Intelligence 9(5), 698-700, 1987 (centring frees the offset).
.. [9] S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and Control 1(3), 223-224, 1978.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from sins_sim import _validate as v
from sins_sim.earth import EARTH_RATE_RAD_S, MAX_ABS_LAT_DEG, gravity_down
from sins_sim.navigation.alignment_result import AlignmentResult
from sins_sim.navigation.attitude import (
    euler_from_quat,
    integrate_attitude,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    rotvec_from_quat,
)
from sins_sim.navigation.coning import parse_algorithm
from sins_sim.units import DEG

__all__ = ["MIN_WINDOW_S", "N_BLOCKS", "N_SUBWINDOWS", "align_coarse", "align_inertial", "mean_bias_wander_sigma"]

#: The shortest window either method accepts (s): a few seconds, below which not even the tilt is averaged.
MIN_WINDOW_S = 5.0
#: Blocks of the coarse method's block means (at most; fewer when a block would be shorter than
#: :data:`MIN_BLOCK_S`): ``K = 10`` leaves the standard error a sampling error of ``1 / sqrt(2 (K - 1))``, 24 %.
N_BLOCKS = 10
#: Sub-windows of the inertial method's scatter (at most, as :data:`N_BLOCKS`): fewer and longer than the coarse
#: method's blocks because velocity noise and sway in a sub-window fall as its length to the -3/2 and faster, so that
#: the white-noise scaling ``1 / sqrt(K)`` overstates them by ``K`` or more.
N_SUBWINDOWS = 5
#: The shortest block (s).
MIN_BLOCK_S = 2.5
#: A mean specific force further than this (relative) from normal gravity says the base was not at rest.
REST_FORCE_TOL = 0.01


# --- checks ---------------------------------------------------------------------------------------------


def _inputs(dtheta, dv, dt_s, lat_rad, gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2, history_rate_hz):
    """Validated ``(dtheta, dv, dt, lat, sigma_g, sigma_a, history_rate)``; one ValueError naming the argument."""
    dth = v.finite_array("", "dtheta", dtheta, ndim=2)
    if dth.shape[1] != 3:
        raise ValueError(f"dtheta: must have shape (N, 3), got {dth.shape}")
    dvel = v.finite_array("", "dv", dv, ndim=2)
    if dvel.shape != dth.shape:
        raise ValueError(f"dv: must have the shape of dtheta {dth.shape}, got {dvel.shape}")
    dt = v.positive("", "dt_s", dt_s)
    lat = v.finite("", "lat_rad", lat_rad)
    if abs(lat) > MAX_ABS_LAT_DEG * DEG:
        raise ValueError(f"lat_rad: |lat| must be <= {MAX_ABS_LAT_DEG} deg (gyrocompassing needs the Earth rate's "
                         f"horizontal part Omega cos(lat)), got {lat / DEG:.4g} deg")
    window = dth.shape[0] * dt
    if window < MIN_WINDOW_S:
        raise ValueError(f"dtheta: the window ({dth.shape[0]} increments of {dt:g} s = {window:.4g} s) must be at "
                         f"least {MIN_WINDOW_S:g} s long")
    sg = v.non_negative("", "gyro_bias_sigma_rad_s", gyro_bias_sigma_rad_s)
    sa = v.non_negative("", "accel_bias_sigma_m_s2", accel_bias_sigma_m_s2)
    hr = v.positive("", "history_rate_hz", history_rate_hz)
    return dth, dvel, dt, lat, sg, sa, hr


def _n_blocks(n: int, dt: float, most: int) -> int:
    """Blocks of at least :data:`MIN_BLOCK_S`, at most ``most``, at least 2."""
    return int(min(most, max(2, math.floor(n * dt / MIN_BLOCK_S))))


def _history_index(n: int, dt: float, rate_hz: float) -> np.ndarray:
    """Increment counts at the history times ``j / rate_hz`` (at least one increment), the last one always ``n``."""
    step = max(1, round(1.0 / (rate_hz * dt)))
    idx = np.arange(step, n + 1, step)
    if idx.size == 0 or idx[-1] != n:
        idx = np.append(idx, n)
    return idx


# --- rotations --------------------------------------------------------------------------------------------


def _quat_from_dcm(c) -> np.ndarray:
    """Unit quaternion (scalar first, ``q0 >= 0``) of a rotation matrix, Shepperd's method: the largest of
    ``4 q_i^2`` taken first (Shepperd 1978; the inverse of Titterton and Weston 2004, eq. 3.63)."""
    c = np.asarray(c, dtype=np.float64)
    tr = c[0, 0] + c[1, 1] + c[2, 2]
    cand = np.array([1.0 + tr, 1.0 + 2.0 * c[0, 0] - tr, 1.0 + 2.0 * c[1, 1] - tr, 1.0 + 2.0 * c[2, 2] - tr])
    i = int(np.argmax(cand))
    q = np.empty(4)
    q[i] = 0.5 * math.sqrt(cand[i])
    f = 0.25 / q[i]
    if i == 0:
        q[1], q[2], q[3] = (c[2, 1] - c[1, 2]) * f, (c[0, 2] - c[2, 0]) * f, (c[1, 0] - c[0, 1]) * f
    elif i == 1:
        q[0], q[2], q[3] = (c[2, 1] - c[1, 2]) * f, (c[0, 1] + c[1, 0]) * f, (c[0, 2] + c[2, 0]) * f
    elif i == 2:
        q[0], q[1], q[3] = (c[0, 2] - c[2, 0]) * f, (c[0, 1] + c[1, 0]) * f, (c[1, 2] + c[2, 1]) * f
    else:
        q[0], q[1], q[2] = (c[1, 0] - c[0, 1]) * f, (c[0, 2] + c[2, 0]) * f, (c[1, 2] + c[2, 1]) * f
    q /= math.sqrt(float(q @ q))
    return -q if q[0] < 0.0 else q


def _rotate(q, vec) -> np.ndarray:
    """``q (x) v (x) q*`` for unit quaternions ``q`` (..., 4) and vectors ``v`` (..., 3), broadcasting:
    ``v + 2 q0 (u x v) + 2 u x (u x v)`` with ``u`` the vector part (the Hamilton product written out)."""
    q = np.asarray(q, dtype=np.float64)
    u = q[..., 1:]
    t = 2.0 * np.cross(u, vec)
    return vec + q[..., :1] * t + np.cross(u, t)


def _triad(f_b, w_b) -> np.ndarray:
    """``C_nb`` from the specific force and the rate at rest, gravity first (TRIAD; Shuster and Oh 1981):
    down ``d = -f/|f|``, east ``e = d x w / |d x w|`` (the Earth rate has no east component), north ``e x d``;
    the rows of ``C_nb`` are ``n, e, d`` (Titterton and Weston 2004, sec. 10.2; Groves 2013, attitude initialization)."""
    d = -f_b / np.linalg.norm(f_b)
    e = np.cross(d, w_b)
    e /= np.linalg.norm(e)
    return np.stack([np.cross(e, d), e, d])


# --- the bounds both methods report ---------------------------------------------------------------------------


def mean_bias_wander_sigma(window_s: float, rrw_rad_s_sqrt_s: float = 0.0, gm_tau_c_s=(), gm_variance=()) -> float:
    """1-sigma of a gyro's bias wander averaged over a window of ``T = window_s`` (module docstring):
    ``sqrt(K^2 T / 3 + sum_i q_i f(T / tau_i))``, ``f(x) = 2 (x - 1 + e^-x) / x^2``.

    Parameters
    ----------
    window_s : float
        The window (s), > 0.
    rrw_rad_s_sqrt_s : float
        Rate random walk density ``K`` (rad/s/sqrt(s)), started at the window's start.
    gm_tau_c_s, gm_variance : sequence of float
        Correlation times (s) and stationary variances ((rad/s)^2) of the Gauss-Markov processes (a bias
        instability's sum).

    Examples
    --------
    >>> round(mean_bias_wander_sigma(300.0, 1e-8) / (1e-8 * (300.0 / 3.0) ** 0.5), 12)
    1.0
    >>> round(mean_bias_wander_sigma(1e-6, 0.0, [1.0], [4.0]), 5)    # T << tau: the process's own sigma
    2.0
    """
    t = v.positive("", "window_s", window_s)
    k = v.non_negative("", "rrw_rad_s_sqrt_s", rrw_rad_s_sqrt_s)
    tc = np.asarray(gm_tau_c_s, dtype=np.float64).ravel()
    q = np.asarray(gm_variance, dtype=np.float64).ravel()
    if tc.shape != q.shape or np.any(tc <= 0.0) or np.any(q < 0.0):
        raise ValueError("gm_tau_c_s, gm_variance: must be equal-length sequences of correlation times > 0 and "
                         "variances >= 0")
    x = t / tc
    # f(x) = 2 (x - 1 + e^-x) / x^2 = 2 (x + expm1(-x)) / x^2, its series 1 - x / 3 for small x
    f = np.where(x < 1e-4, 1.0 - x / 3.0, 2.0 * (x + np.expm1(-x)) / np.maximum(x, 1e-300) ** 2)
    return float(math.sqrt(k * k * t / 3.0 + float(np.sum(q * f))))


def _bias_bounds(lat: float, g: float, sigma_g: float, sigma_a: float) -> np.ndarray:
    """1-sigma ``psi`` (N, E, D) from the unobservable biases (module docstring; Groves 2013, attitude initialization):
    tilts ``sigma_a / g``, heading ``sqrt((sigma_g / (Omega cos lat))^2 + (tan lat sigma_a / g)^2)``; an isotropic
    per-axis body sigma has the same sigma in every NED component."""
    tilt = sigma_a / g
    heading = math.hypot(sigma_g / (EARTH_RATE_RAD_S * math.cos(lat)), math.tan(lat) * tilt)
    return np.array([tilt, tilt, heading])


def _scatter_notes(method: str, how: str, bound: np.ndarray, scatter: np.ndarray, window_s: float) -> list:
    """Notes where the data's scatter dominates the bias bound (heading, then tilt)."""
    notes = []
    if scatter[2] > bound[2]:
        notes.append(f"{method}: the heading scatter of the data ({scatter[2] / DEG:.3g} deg, {how}) dominates the "
                     f"east-gyro-bias bound ({bound[2] / DEG:.3g} deg): the base moved or the window "
                     f"({window_s:.4g} s) is too short" + (
                         f"; white noise alone would need about {window_s * (scatter[2] / bound[2]) ** 2:.3g} s"
                         if bound[2] > 0.0 else ""))
    if max(scatter[0], scatter[1]) > max(bound[0], bound[1]):
        notes.append(f"{method}: the tilt scatter of the data ({max(scatter[:2]) / DEG * 3600:.3g} arcsec, {how}) "
                     f"dominates the accelerometer-bias bound ({max(bound[:2]) / DEG * 3600:.3g} arcsec)")
    return notes


def _rest_note(method: str, f_mean_norm: float, g: float) -> list:
    rel = f_mean_norm / g - 1.0
    if abs(rel) > REST_FORCE_TOL:
        return [(f"{method}: the mean specific force is {f_mean_norm:.5g} m/s^2, {100 * rel:+.2g} % off normal gravity "
                f"({g:.5g} m/s^2): the base was not at rest, and the alignment assumes it was")]
    return []


def _settling(t, heading) -> float:
    """Peak-to-peak of the (unwrapped) heading over the last fifth of the window (rad)."""
    last = t >= t[-1] - 0.2 * t[-1]
    h = np.unwrap(heading[last])
    return float(h.max() - h.min())


# --- coarse -------------------------------------------------------------------------------------------------


def align_coarse(dtheta, dv, dt_s, lat_rad, *, gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2,
                 gyro_wander_sigma_rad_s=0.0, history_rate_hz=1.0) -> AlignmentResult:
    """Coarse alignment: levelling from the mean specific force, gyrocompassing from the mean rate.

    The attitude is the TRIAD of the window's mean specific force (down) and mean rate (whose horizontal part
    points north): ``d = -f/|f|``, ``e = d x w / |d x w|``, ``n = e x d`` (Titterton and Weston 2004,
    sec. 10.2; Savage 2007, ch. 6; Groves 2013, attitude initialization). On a still base it reaches the observability
    limit exactly: ``psi_N = -b_E / g``, ``psi_E = b_N / g``, ``psi_D = -eps_E / (Omega cos lat) - psi_N tan lat``.
    On a swaying base the mean rate holds the sway's net rotation over the window divided by its length, which at
    a few arcmin over minutes is a fraction of the Earth rate: the heading is off by degrees. The reported sigma
    then grows with the data's scatter.

    Parameters
    ----------
    dtheta, dv : array_like, shape (N, 3)
        Raw gyro angle increments (rad) and velocity increments (m/s), body axes forward-right-down, one per
        interval ``dt_s``; the base at rest (it may sway).
    dt_s : float
        Increment interval (s).
    lat_rad : float
        Geodetic latitude (rad), ``|lat| <= 89.5 deg``.
    gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2 : float
        1-sigma per-axis gyro (rad/s) and accelerometer (m/s^2) bias: the unobservable part that bounds the
        heading and the tilts.
    gyro_wander_sigma_rad_s : float
        1-sigma per axis of the gyro bias's wander averaged over this window (:func:`mean_bias_wander_sigma`: a rate
        random walk's ``K sqrt(T / 3)``, a bias instability's share), in quadrature with ``gyro_bias_sigma_rad_s``
        in the heading's bound; 0 leaves it out.
    history_rate_hz : float
        Rate of the convergence history (the estimate from the data up to each time).

    Returns
    -------
    AlignmentResult
        ``method="coarse"``; ``sigma_rad`` the bias bounds in quadrature with the standard error of the means by
        block means (``N_BLOCKS`` contiguous blocks; Flyvbjerg and Petersen 1989): ``SE = std(block means) /
        sqrt(K)``, which holds for noise correlated over less than a block and overstates a bounded oscillation's
        contribution (whose block means telescope) by about ``sqrt(K)``, an upper bound on a swaying base.

    Raises
    ------
    ValueError
        For wrong shapes, non-finite data, ``|lat|`` near 90 deg, a window shorter than :data:`MIN_WINDOW_S`, a
        negative sigma (the message names the argument).
    """
    dth, dvel, dt, lat, sg, sa, hr = _inputs(dtheta, dv, dt_s, lat_rad, gyro_bias_sigma_rad_s,
                                             accel_bias_sigma_m_s2, history_rate_hz)
    n = dth.shape[0]
    window = n * dt
    f_mean = dvel.sum(axis=0) / window
    w_mean = dth.sum(axis=0) / window
    c_nb = _triad(f_mean, w_mean)
    g = float(np.linalg.norm(f_mean))
    wander = v.non_negative("", "gyro_wander_sigma_rad_s", gyro_wander_sigma_rad_s)
    bound = _bias_bounds(lat, g, math.hypot(sg, wander), sa)

    # standard error of the means by K block means (Flyvbjerg and Petersen 1989), resolved in NED
    k = _n_blocks(n, dt, N_BLOCKS)
    edges = np.linspace(0, n, k + 1).round().astype(int)
    f_blk = np.stack([dvel[a:b].sum(axis=0) / ((b - a) * dt) for a, b in itertools.pairwise(edges)]) @ c_nb.T
    w_blk = np.stack([dth[a:b].sum(axis=0) / ((b - a) * dt) for a, b in itertools.pairwise(edges)]) @ c_nb.T
    se_f = f_blk.std(axis=0, ddof=1) / math.sqrt(k)
    se_w = w_blk.std(axis=0, ddof=1) / math.sqrt(k)
    # psi_N = -df_E / g, psi_E = df_N / g, psi_D = -dw_E / (Omega cos lat) - psi_N tan lat (module docstring)
    scatter = np.array([se_f[1] / g, se_f[0] / g,
                        math.hypot(se_w[1] / (EARTH_RATE_RAD_S * math.cos(lat)), math.tan(lat) * se_f[1] / g)])
    sigma = np.hypot(bound, scatter)

    # history: the same TRIAD on the means up to each time
    idx = _history_index(n, dt, hr)
    cum_f = np.cumsum(dvel, axis=0)[idx - 1]
    cum_w = np.cumsum(dth, axis=0)[idx - 1]
    q_hist = np.stack([_quat_from_dcm(_triad(cf, cw)) for cf, cw in zip(cum_f, cum_w)])
    eul = euler_from_quat(q_hist)
    t_hist = idx * dt
    notes = _rest_note("coarse", g, float(gravity_down(lat, 0.0))) + _scatter_notes(
        "coarse", f"block means over {k} blocks", bound, scatter, window)
    return AlignmentResult(
        method="coarse", q_nb=q_hist[-1], sigma_rad=sigma, duration_s=window,
        convergence={"t_s": t_hist, "roll_rad": eul[:, 0], "pitch_rad": eul[:, 1], "heading_rad": eul[:, 2]},
        settling_rad=_settling(t_hist, eul[:, 2]), notes=tuple(notes))


# --- inertial frame ---------------------------------------------------------------------------------------------


def _gravity_integral_n0(t, lat: float, g: float) -> np.ndarray:
    """``V^n0(t) = int_0^t C_n0_n(s) f^n ds`` (m/s), shape (len(t), 3): the specific force at rest
    ``f^n = (0, 0, -g)`` seen from the navigation frame at the start held inertial, in which the local frame turns
    at ``Omega`` about ``u = (cos lat, 0, -sin lat)``. With ``f_par = (u.f) u`` and ``f_perp = f - f_par``,
    ``C_n0_n(s) f = f_par + cos(Omega s) f_perp + sin(Omega s) u x f`` (Rodrigues), so
    ``V(t) = f_par t + sin(Omega t) / Omega f_perp + (1 - cos(Omega t)) / Omega u x f``
    (Wu et al. 2011, the reference velocity integral of the Earth-fixed base)."""
    u = np.array([math.cos(lat), 0.0, -math.sin(lat)])
    f = np.array([0.0, 0.0, -g])
    f_par = (u @ f) * u
    f_perp = f - f_par
    wt = EARTH_RATE_RAD_S * np.asarray(t, dtype=np.float64)[:, None]
    return (f_par * np.asarray(t)[:, None] + np.sin(wt) / EARTH_RATE_RAD_S * f_perp
            + (1.0 - np.cos(wt)) / EARTH_RATE_RAD_S * np.cross(u, f))


def _davenport(b_mat) -> np.ndarray:
    """The unit quaternion ``q`` (Hamilton, scalar first) of the rotation ``C`` that maximises
    ``sum_k r_k . C b_k`` (Wahba's problem) given ``B = sum_k r_k b_k^T``: Davenport's q-method, the eigenvector of
    the largest eigenvalue of ``K = [[tr B, z^T], [z, B + B^T - tr(B) I]]``, ``z = sum_k b_k x r_k``
    (Davenport 1968; Wu et al. 2011, the quaternion eigenvalue problem). Written for the Hamilton rotation
    ``C(q) b = (q0^2 - u.u) b + 2 (u.b) u + 2 q0 u x b``, for which ``r . C(q) b = q^T K q`` term by term."""
    z = np.array([b_mat[2, 1] - b_mat[1, 2], b_mat[0, 2] - b_mat[2, 0], b_mat[1, 0] - b_mat[0, 1]])
    tr = float(np.trace(b_mat))
    kmat = np.empty((4, 4))
    kmat[0, 0] = tr
    kmat[0, 1:] = z
    kmat[1:, 0] = z
    kmat[1:, 1:] = b_mat + b_mat.T - tr * np.eye(3)
    _, vecs = np.linalg.eigh(kmat)
    q = vecs[:, -1]
    return -q if q[0] < 0.0 else q


def _centred(b_mat, r_sum, b_sum, m: int) -> np.ndarray:
    """``B`` of the centred observations, ``sum_k (r_k - r_mean)(b_k - b_mean)^T = B - r_sum b_sum^T / m``: the
    least-squares rotation with a free constant offset ``V^n0 + c = C V^b0`` (Arun, Huang and Blostein 1987), which
    removes the unknown velocity of the sway at the start (and any constant velocity error) from the fit."""
    return b_mat - np.outer(r_sum, b_sum) / m


def _outer_sums(r, b, edges) -> np.ndarray:
    """``sum_k r_k b_k^T`` over each segment ``[edges[j], edges[j+1])``, shape (len(edges) - 1, 3, 3)."""
    return np.stack([r[a:e].T @ b[a:e] for a, e in itertools.pairwise(edges)])


def align_inertial(dtheta, dv, dt_s, lat_rad, h_m=0.0, *, gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2,
                   gyro_arw_rad_sqrt_s=0.0, gyro_wander_sigma_rad_s=0.0, history_rate_hz=1.0,
                   coning="two_sample") -> AlignmentResult:
    """Inertial-frame (i0) alignment by the optimisation-based method of Wu et al. (2011): robust to base sway.

    Equations, with ``n0`` the navigation frame at the start and ``b0`` the body frame at the start, both held
    inertial (Wu et al. 2011, the attitude decomposition and the velocity-integration formula):

    1. ``C_n(t)_b(t) = C_n(t)_n0 C_n0_b0 C_b0_b(t)``: only ``C_n0_b0`` (the attitude at the start) is unknown.
    2. ``C_b0_b(t)``: the gyros' coning-corrected attitude integration from the identity
       (:func:`~sins_sim.navigation.attitude.integrate_attitude`; Savage 1998, Part 1).
    3. ``V^b0(t) = sum_k C_b0_b(k-1) (dv_k + 1/2 dtheta_k x dv_k + 1/12 (dtheta_(k-1) x dv_k + dv_(k-1) x dtheta_k))``:
       the specific force integrated in ``b0`` with the rotation and two-sample sculling compensation
       (Savage 1998, Part 2).
    4. ``V^n0(t)``: the same integral of the specific force at rest, ``-g`` along the local down, in closed form
       from the latitude and ``Omega t`` (the local frame turns about the Earth's axis).
    5. ``V^n0(t_k) + c = C_n0_b0 V^b0(t_k)`` for every ``k``: Wahba's problem over all the observations, solved by
       Davenport's q-method (the largest eigenvector of ``K(B)``, ``B = sum_k V^n0_k (V^b0_k)^T``), on the
       observations centred on their mean, which frees the constant ``c``: the sway's velocity at the start, which
       the integrals otherwise carry as an error for the whole window (Arun, Huang and Blostein 1987).
    6. ``C_n(t)_n0``: the rotation by ``-Omega t`` about the Earth's axis ``(cos lat, 0, -sin lat)``.

    The body's sway is in ``C_b0_b(t)``, measured by the gyros, so it drops out; a translational sway adds only its
    bounded velocity to ``V^b0``, small against ``g t``.

    Parameters
    ----------
    dtheta, dv : array_like, shape (N, 3)
        Raw gyro angle increments (rad) and velocity increments (m/s), body axes forward-right-down, one per
        interval ``dt_s``; the base at rest (it may sway).
    dt_s : float
        Increment interval (s).
    lat_rad : float
        Geodetic latitude (rad), ``|lat| <= 89.5 deg``.
    h_m : float
        Height above the ellipsoid (m), for the magnitude of gravity.
    gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2 : float
        1-sigma per-axis gyro (rad/s) and accelerometer (m/s^2) bias (the unobservable part).
    gyro_arw_rad_sqrt_s : float
        The gyros' angle random walk (rad/sqrt(s)), optional: the north tilt of the end attitude carries the part
        of the tracked random walk the fit does not absorb, ``sqrt(13/35) N sqrt(T)``, which the sub-window scatter
        does not see (their fits share it); 0 leaves it out (about east the scatter holds it; about down it is
        about ``0.5 Omega T cos(lat)`` of the heading's random-walk scatter, under 1 % in quadrature for ``T <= 1 h``).
    gyro_wander_sigma_rad_s : float
        As :func:`align_coarse`: the mean bias wander over the window, in quadrature with ``gyro_bias_sigma_rad_s``
        in every bias bound (the gyrocompass term and the drift ``T / 2`` about north and down).
    history_rate_hz : float
        Rate of the convergence history.
    coning : str
        The coning correction of the attitude tracking (:data:`~sins_sim.navigation.coning.CONING_ALGORITHMS`).

    Returns
    -------
    AlignmentResult
        ``method="inertial"``, ``q_nb`` the attitude at the end of the window. ``sigma_rad``: the bias bounds of
        :func:`align_coarse`, with half the gyro drift over the window ``sigma_g T / 2`` about north and down (the
        fit centres the start attitude on the window: the least-squares share of a drift ``eps t`` that a constant
        rotation absorbs is ``eps T / 2``, and the tracking carries ``eps T`` to the end), in quadrature with the
        fit's own scatter, the standard deviation of the same fit on
        ``K`` disjoint sub-windows divided by ``sqrt(K)``: exact for angle random walk (whose heading error falls
        as ``1 / sqrt(T)``), an upper bound for velocity noise and sway (which fall faster). The history holds, at
        each time, the attitude then from the data up to then; ``settling_rad`` is the peak-to-peak over the last
        fifth of the window of the end attitude's heading as estimated from the data up to each time (the body's
        own measured motion removed).

    Raises
    ------
    ValueError
        As :func:`align_coarse`, and for a non-finite ``h_m`` or an unknown ``coning``.
    """
    dth, dvel, dt, lat, sg, sa, hr = _inputs(dtheta, dv, dt_s, lat_rad, gyro_bias_sigma_rad_s,
                                             accel_bias_sigma_m_s2, history_rate_hz)
    h = v.finite("", "h_m", h_m)
    arw = v.non_negative("", "gyro_arw_rad_sqrt_s", gyro_arw_rad_sqrt_s)
    sg = math.hypot(sg, v.non_negative("", "gyro_wander_sigma_rad_s", gyro_wander_sigma_rad_s))
    algo = parse_algorithm(coning, "coning")
    n = dth.shape[0]
    window = n * dt
    g = float(gravity_down(lat, h))

    # (2) body attitude against b0, (3) the specific force integrated in b0
    q_b0b = integrate_attitude(dth, algorithm=algo.value)
    prev_th = np.vstack([np.zeros(3), dth[:-1]])
    prev_v = np.vstack([np.zeros(3), dvel[:-1]])
    dv_b = dvel + 0.5 * np.cross(dth, dvel) + (np.cross(prev_th, dvel) + np.cross(prev_v, dth)) / 12.0
    vb0 = np.cumsum(_rotate(q_b0b[:-1], dv_b), axis=0)
    # (4) the reference integral in n0
    t = dt * np.arange(1, n + 1)
    vn0 = _gravity_integral_n0(t, lat, g)

    # (5) Davenport's q-method on the centred observations, cumulatively at the history times
    idx = _history_index(n, dt, hr)
    seg = np.concatenate([[0], idx])
    b_cum = np.cumsum(_outer_sums(vn0, vb0, seg), axis=0)
    r_cum = np.cumsum(np.add.reduceat(vn0, seg[:-1], axis=0), axis=0)
    v_cum = np.cumsum(np.add.reduceat(vb0, seg[:-1], axis=0), axis=0)
    q_n0b0 = np.stack([_davenport(_centred(bm, rs, vs, m)) for bm, rs, vs, m in zip(b_cum, r_cum, v_cum, idx)])
    axis = np.array([math.cos(lat), 0.0, -math.sin(lat)])
    t_hist = idx * dt
    # (6) and (1): the attitude at each history time, and the end attitude as estimated then
    q_nn0 = quat_from_rotvec(-EARTH_RATE_RAD_S * t_hist[:, None] * axis)
    q_hist = quat_multiply(quat_multiply(q_nn0, q_n0b0), q_b0b[idx])
    q_end_hist = quat_multiply(quat_multiply(q_nn0[-1], q_n0b0), q_b0b[n])
    eul = euler_from_quat(q_hist)
    q_end = q_hist[-1]

    # the fit's scatter: the same centred fit on K disjoint sub-windows (each frees its own offset)
    k = _n_blocks(n, dt, N_SUBWINDOWS)
    edges = np.linspace(0, n, k + 1).round().astype(int)
    psi_sub = []
    for a, e in itertools.pairwise(edges):
        q_j = _davenport(_centred(vn0[a:e].T @ vb0[a:e], vn0[a:e].sum(axis=0), vb0[a:e].sum(axis=0), e - a))
        # psi of the sub-window's end attitude against the full fit's, resolved in n(T)
        psi_sub.append(_rotate(q_nn0[-1], rotvec_from_quat(quat_multiply(q_j, quat_conjugate(q_n0b0[-1])))))
    scatter = np.std(np.array(psi_sub), axis=0, ddof=1) / math.sqrt(k)
    # the end attitude carries half the gyros' drift over the window about north and down (the fit centres the
    # initial attitude on the window; the east drift is the gyrocompass term): psi_N, psi_D += eps_(N, D) T / 2
    bound = np.hypot(_bias_bounds(lat, g, sg, sa), np.array([0.5, 0.0, 0.5]) * sg * window)
    # and the gyro random walk W(T) less the fit's share: about north the fit's tilt is the slope of g int W
    # against g t (with a free offset), whose share leaves int_0^1 dW(s) (3 s^2 - 2 s^3) (T = 1), variance 13/35
    bound[0] = math.hypot(bound[0], math.sqrt(13.0 / 35.0) * arw * math.sqrt(window))
    sigma = np.hypot(bound, scatter)

    # at rest the specific force is constant in body axes (in b0 it turns with the Earth, and its mean shortens)
    f_mean_norm = float(np.linalg.norm(dvel.sum(axis=0))) / window
    notes = _rest_note("inertial", f_mean_norm, g) + _scatter_notes(
        "inertial", f"fit on {k} sub-windows", bound, scatter, window)
    return AlignmentResult(
        method="inertial", q_nb=q_end, sigma_rad=sigma, duration_s=window,
        convergence={"t_s": t_hist, "roll_rad": eul[:, 0], "pitch_rad": eul[:, 1], "heading_rad": eul[:, 2]},
        settling_rad=_settling(t_hist, euler_from_quat(q_end_hist)[:, 2]), notes=tuple(notes))
