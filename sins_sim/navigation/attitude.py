"""Coning-corrected strapdown attitude integration and attitude-error measures.

Frames and units: ``q_nb`` (Hamilton, scalar first) rotates body vectors into
the navigation frame, ``v_n = q_nb (x) v_b (x) q_nb*``; gyro angle increments
``dtheta`` are in rad, body frame, one per update period; rates in rad/s,
times in s. The attitude update is
``q_nb[k] = q_nb[k-1] (x) q(phi_k)`` with the coning-corrected rotation
vector ``phi_k`` of :class:`~sins_sim.navigation.coning.ConingAlgorithm`
(Savage 1998; Ignagni 1990; see :mod:`sins_sim._kernels.nav`).

.. autosummary::

    integrate_attitude
    AttitudeIntegrator
    attitude_error
    drift_rate
    quat_multiply
    quat_conjugate
    quat_from_rotvec
    rotvec_from_quat
    euler_from_quat

The numpy quaternion helpers here are the slow, obvious references (and the
tools for building truth in tests); the integration runs in the numba kernel.

References
----------
.. [1] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: Attitude algorithms", J. Guidance, Control, and Dynamics
   21(1), 19-28, 1998.
.. [2] M. B. Ignagni, "Optimal strapdown attitude integration algorithms",
   J. Guidance, Control, and Dynamics 13(2), 363-369, 1990.
.. [3] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004, ch. 3 and 11.
"""

from __future__ import annotations

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import nav as knav
from sins_sim.navigation.coning import (
    CONING_ALGORITHMS,
    ConingAlgorithm,
    algorithm_residual_drift,
    coefficient_matrix,
    coning_drift_closed_form,
    parse_algorithm,
)

__all__ = [
    "dcm_from_quat",
    "ConingAlgorithm",
    "CONING_ALGORITHMS",
    "integrate_attitude",
    "AttitudeIntegrator",
    "attitude_error",
    "drift_rate",
    "quat_multiply",
    "quat_conjugate",
    "quat_from_rotvec",
    "rotvec_from_quat",
    "euler_from_quat",
    "coning_drift_closed_form",
    "algorithm_residual_drift",
]

_IDENTITY = (1.0, 0.0, 0.0, 0.0)
#: Accepted deviation of an input quaternion's norm from 1 (it is then renormalised).
QUAT_NORM_TOL = 1e-6


# --- validation -------------------------------------------------------------------


def _increments(field, dtheta) -> np.ndarray:
    arr = v.finite_array("", field, dtheta, ndim=2)
    if arr.shape[1] != 3:
        raise ValueError(f"{field}: must have shape (N, 3), got {arr.shape}")
    return np.ascontiguousarray(arr)


def _unit_quat(field, q) -> np.ndarray:
    """A (4,) unit quaternion (renormalised copy)."""
    if q is None:
        return np.array(_IDENTITY)
    arr = v.finite_array("", field, q, ndim=1)
    if arr.shape != (4,):
        raise ValueError(f"{field}: must have shape (4,), got {arr.shape}")
    n = float(np.sqrt(np.sum(arr * arr)))
    if abs(n - 1.0) > QUAT_NORM_TOL:
        raise ValueError(f"{field}: must be a unit quaternion (|q| = 1 +- {QUAT_NORM_TOL:g}), got |q| = {n!r}")
    return arr / n


def _quat_array(field, q) -> np.ndarray:
    """(4,) or (N, 4) finite quaternions of unit norm."""
    arr = np.asarray(q, dtype=np.float64)
    if arr.ndim not in (1, 2) or arr.shape[-1] != 4:
        raise ValueError(f"{field}: must have shape (4,) or (N, 4), got {arr.shape}")
    arr = v.finite_array("", field, arr, ndim=arr.ndim)
    n = np.sqrt(np.sum(arr * arr, axis=-1))
    if np.any(np.abs(n - 1.0) > QUAT_NORM_TOL):
        raise ValueError(f"{field}: must hold unit quaternions (|q| = 1 +- {QUAT_NORM_TOL:g})")
    return arr


def _prev(field, dtheta_prev) -> np.ndarray:
    """``[dtheta_(-3), dtheta_(-2), dtheta_(-1)]``; a (2, 3) input has ``dtheta_(-3) = 0``."""
    out = np.zeros((3, 3))
    if dtheta_prev is None:
        return out
    arr = v.finite_array("", field, dtheta_prev, ndim=2)
    if arr.shape not in ((2, 3), (3, 3)):
        raise ValueError(f"{field}: must have shape (2, 3) ([dtheta_(-2), dtheta_(-1)]) or (3, 3), "
                         f"got {arr.shape}")
    out[3 - arr.shape[0]:] = arr
    return out


# --- numpy quaternion helpers ------------------------------------------------------


def quat_multiply(p, q) -> np.ndarray:
    """Hamilton product ``p (x) q`` (scalar first), broadcasting over leading axes.

    ``p (x) q = [p0 q0 - pv.qv, p0 qv + q0 pv + pv x qv]`` (Titterton & Weston
    2004, ch. 3).

    Parameters
    ----------
    p, q : array_like, shape (..., 4)

    Returns
    -------
    ndarray, shape (..., 4)

    Examples
    --------
    >>> quat_multiply([0, 1, 0, 0], [0, 0, 1, 0])  # i j = k
    array([0., 0., 0., 1.])
    """
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    p0, pv = p[..., :1], p[..., 1:]
    q0, qv = q[..., :1], q[..., 1:]
    s = p0 * q0 - np.sum(pv * qv, axis=-1, keepdims=True)
    vec = p0 * qv + q0 * pv + np.cross(pv, qv)
    return np.concatenate([s, vec], axis=-1)


def quat_conjugate(q) -> np.ndarray:
    """Conjugate ``[q0, -q1, -q2, -q3]`` (the inverse of a unit quaternion).

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q = np.array(q, dtype=np.float64)
    q[..., 1:] *= -1.0
    return q


def dcm_from_quat(q) -> np.ndarray:
    """Direction cosine matrices of unit quaternions (scalar first), ``v_n = C v_b`` for ``q = q_nb``
    (Titterton and Weston 2004, eq. 3.63), broadcasting over leading axes.

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    q0, q1, q2, q3 = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)], axis=-1),
        np.stack([2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)], axis=-1),
        np.stack([2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)], axis=-1),
    ], axis=-2)


def quat_from_rotvec(rotvec) -> np.ndarray:
    """Quaternion of a rotation vector (rad), broadcasting over leading axes.

    ``q = [cos(|phi|/2), sin(|phi|/2)/|phi| phi]`` (Savage 1998), with the
    Taylor series of :func:`sins_sim._kernels.nav.rotvec_to_quat` for
    ``|phi|^2 < 1e-6``.

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vector (rad).

    Returns
    -------
    ndarray, shape (..., 4)

    Examples
    --------
    >>> np.round(quat_from_rotvec([0.0, 0.0, np.pi]), 12)
    array([0., 0., 0., 1.])
    """
    phi = np.asarray(rotvec, dtype=np.float64)
    n2 = np.sum(phi * phi, axis=-1, keepdims=True)
    small = n2 < knav.SMALL_ANGLE2
    n = np.sqrt(np.where(small, 1.0, n2))
    c_big = np.cos(0.5 * n)
    s_big = np.sin(0.5 * n) / n
    c_small = 1.0 - n2 * (1.0 / 8.0 - n2 * (1.0 / 384.0 - n2 * (1.0 / 46080.0)))
    s_small = 0.5 - n2 * (1.0 / 48.0 - n2 * (1.0 / 3840.0 - n2 * (1.0 / 645120.0)))
    c = np.where(small, c_small, c_big)
    s = np.where(small, s_small, s_big)
    return np.concatenate([c, s * phi], axis=-1)


def rotvec_from_quat(q) -> np.ndarray:
    """Rotation vector (rad) of a unit quaternion, angle in ``[0, pi]``.

    ``q`` and ``-q`` give the same rotation; the one with ``q0 >= 0`` is used,
    then ``phi = 2 atan2(|qv|, q0) qv / |qv|``; for ``|qv| < 1e-5`` the factor
    is its series ``(2/q0)(1 - |qv|^2/(3 q0^2))`` (next term ~1e-21).

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    q = np.asarray(q, dtype=np.float64)
    sign = np.where(q[..., :1] < 0.0, -1.0, 1.0)
    w = sign * q[..., :1]
    vec = sign * q[..., 1:]
    n = np.sqrt(np.sum(vec * vec, axis=-1, keepdims=True))
    small = n < 1e-5
    n_safe = np.where(small, 1.0, n)
    w_safe = np.where(small, w, 1.0)
    big = 2.0 * np.arctan2(n, w) / n_safe
    series = (2.0 / w_safe) * (1.0 - n * n / (3.0 * w_safe * w_safe))
    return np.where(small, series, big) * vec


def euler_from_quat(q) -> np.ndarray:
    """Roll, pitch, yaw (rad) of ``q_nb``, aerospace z-y-x sequence.

    With ``C = C_nb(q)``: ``roll = atan2(C32, C33)``, ``pitch = -asin(C31)``,
    ``yaw = atan2(C21, C11)`` (Titterton & Weston 2004, ch. 3), i.e.
    ``C_nb = R_z(yaw) R_y(pitch) R_x(roll)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions.

    Returns
    -------
    ndarray, shape (..., 3)
        ``[roll, pitch, yaw]``, roll and yaw in ``(-pi, pi]``, pitch in ``[-pi/2, pi/2]``.
    """
    q = np.asarray(q, dtype=np.float64)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    c31 = 2.0 * (q1 * q3 - q0 * q2)
    c32 = 2.0 * (q2 * q3 + q0 * q1)
    c33 = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    c21 = 2.0 * (q1 * q2 + q0 * q3)
    c11 = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    roll = np.arctan2(c32, c33)
    pitch = -np.arcsin(np.clip(c31, -1.0, 1.0))
    yaw = np.arctan2(c21, c11)
    return np.stack([roll, pitch, yaw], axis=-1)


# --- integration -------------------------------------------------------------------


def integrate_attitude(dtheta, q0=None, algorithm="two_sample", dtheta_prev=None) -> np.ndarray:
    """Integrate gyro angle increments into the attitude ``q_nb``.

    ``q[k+1] = normalise(q[k] (x) q(phi_k))`` with ``phi_k`` from the chosen
    coning correction (:class:`ConingAlgorithm`; kernel
    :func:`sins_sim._kernels.nav.attitude_update`).

    Parameters
    ----------
    dtheta : array_like, shape (N, 3)
        Gyro angle increments (rad, body frame), one per update period.
    q0 : array_like, shape (4,), optional
        Initial ``q_nb`` (unit, scalar first); identity by default.
    algorithm : {"none", "two_sample", "three_sample", "four_sample"} or array_like
        Coning correction, or its coefficients (shape (3,) or (3, 3),
        :func:`sins_sim.navigation.coning.coefficient_matrix`).
    dtheta_prev : array_like, shape (2, 3) or (3, 3), optional
        The increments before ``dtheta[0]``, ``[dtheta_(-2), dtheta_(-1)]`` or
        ``[dtheta_(-3), dtheta_(-2), dtheta_(-1)]`` (rad); zeros by default.

    Returns
    -------
    ndarray, shape (N + 1, 4)
        ``q[0] = q0`` and ``q[k]`` the attitude after ``k`` increments.

    Raises
    ------
    ValueError
        For a wrong shape, a non-finite value, a non-unit ``q0`` or an unknown
        algorithm (the message names the argument).

    Examples
    --------
    >>> dth = np.tile([0.0, 0.0, 1e-3], (1000, 1))  # 1 rad about z in 1000 steps
    >>> q = integrate_attitude(dth)
    >>> np.allclose(q[-1], [np.cos(0.5), 0.0, 0.0, np.sin(0.5)], atol=1e-12)
    True
    """
    dth = _increments("dtheta", dtheta)
    q_init = _unit_quat("q0", q0)
    coef = coefficient_matrix(algorithm, "algorithm")
    prev = _prev("dtheta_prev", dtheta_prev)
    out = np.empty((dth.shape[0] + 1, 4))
    out[0] = q_init
    knav.attitude_update(dth, q_init, coef, prev, out[1:])
    return out


class AttitudeIntegrator:
    """Streaming attitude integrator: chunks in, attitudes out.

    Feeding the increments in chunks of any sizes gives bit-identical
    attitudes to :func:`integrate_attitude` on the whole array (the kernel
    carries the attitude and the last two increments between calls).

    Parameters
    ----------
    q0 : array_like, shape (4,), optional
        Initial ``q_nb`` (unit, scalar first); identity by default.
    algorithm : {"none", "two_sample", "three_sample", "four_sample"}
        Coning correction.
    dtheta_prev : array_like, shape (2, 3) or (3, 3), optional
        Increments before the first chunk (rad); zeros by default.

    Examples
    --------
    >>> integ = AttitudeIntegrator(algorithm="three_sample")
    >>> q_a = integ.process(np.full((5, 3), 1e-4))
    >>> q_b = integ.process(np.full((3, 3), 1e-4))
    >>> q_a.shape, q_b.shape
    ((5, 4), (3, 4))
    """

    def __init__(self, q0=None, algorithm="two_sample", dtheta_prev=None):
        self._algorithm = parse_algorithm(algorithm)
        self._coef = coefficient_matrix(self._algorithm)
        self._q = _unit_quat("q0", q0)
        self._prev = _prev("dtheta_prev", dtheta_prev)
        self._n = 0

    @property
    def algorithm(self) -> ConingAlgorithm:
        """The coning correction in use."""
        return self._algorithm

    @property
    def q(self) -> np.ndarray:
        """Current attitude ``q_nb`` (copy)."""
        return self._q.copy()

    @property
    def dtheta_prev(self) -> np.ndarray:
        """The last two increments ``[dtheta_(k-2), dtheta_(k-1)]`` (rad, copy)."""
        return self._prev[1:].copy()

    @property
    def n_processed(self) -> int:
        """Increments processed so far."""
        return self._n

    def process(self, dtheta) -> np.ndarray:
        """Integrate one chunk of increments.

        Parameters
        ----------
        dtheta : array_like, shape (n, 3)
            Gyro angle increments (rad, body frame); ``n`` may be 0.

        Returns
        -------
        ndarray, shape (n, 4)
            Attitude after each increment of the chunk.
        """
        dth = _increments("dtheta", dtheta)
        out = np.empty((dth.shape[0], 4))
        knav.attitude_update(dth, self._q, self._coef, self._prev, out)
        if dth.shape[0]:
            self._q = out[-1].copy()
        self._n += dth.shape[0]
        return out


# --- error measures ----------------------------------------------------------------


def attitude_error(q_est, q_true) -> np.ndarray:
    """Attitude error rotation vector in the navigation frame (rad).

    ``e = rotvec(q_est (x) q_true*)``, so that ``q_est = q(e) (x) q_true`` and,
    for small errors, ``C_nb_est = (I + [e x]) C_nb_true`` (Titterton & Weston
    2004, ch. 12, with the sign of ``e`` chosen so that a computed attitude
    rotated positively about an axis gives a positive component). The
    components are about the navigation x, y, z axes; for a local-level
    north-east-down frame they are the north and east tilts and the heading
    error (roll, pitch, yaw errors for a level vehicle heading north). The
    rotation vector is exact for any angle below pi, so a steadily growing
    error stays linear.

    Parameters
    ----------
    q_est, q_true : array_like, shape (N, 4) or (4,)
        Computed and true ``q_nb`` (unit, scalar first), same shape.

    Returns
    -------
    ndarray, shape (N, 3) or (3,)
    """
    qe = _quat_array("q_est", q_est)
    qt = _quat_array("q_true", q_true)
    if qe.shape != qt.shape:
        raise ValueError(f"q_true: must have the shape of q_est {qe.shape}, got {qt.shape}")
    if qe.ndim == 2:  # the engine's path: one kernel pass instead of numpy temporaries
        out = np.empty((qe.shape[0], 3))
        knav.attitude_error_run(np.ascontiguousarray(qe), np.ascontiguousarray(qt), out)
        return out
    return rotvec_from_quat(quat_multiply(qe, quat_conjugate(qt)))


def drift_rate(err, t) -> np.ndarray:
    """Least-squares slope of an error history (rad/s per column).

    Fits ``err_i(t) = a_i + b_i t`` by ordinary least squares,
    ``b_i = sum((t - mean t)(err_i - mean err_i)) / sum((t - mean t)^2)``.

    Parameters
    ----------
    err : array_like, shape (N,) or (N, M)
        Error history (rad), e.g. from :func:`attitude_error`.
    t : array_like, shape (N,)
        Times (s), not all equal.

    Returns
    -------
    ndarray, shape () or (M,)
        Slopes (rad/s).
    """
    e = np.asarray(err, dtype=np.float64)
    if e.ndim not in (1, 2):
        raise ValueError(f"err: must have shape (N,) or (N, M), got {e.shape}")
    e = v.finite_array("", "err", e, ndim=e.ndim)
    tt = v.finite_array("", "t", t, ndim=1)
    if tt.shape[0] != e.shape[0]:
        raise ValueError(f"t: must have {e.shape[0]} samples (len(err)), got {tt.shape[0]}")
    if tt.shape[0] < 2:
        raise ValueError(f"t: need at least 2 samples, got {tt.shape[0]}")
    tc = tt - tt.mean()
    ss = float(np.dot(tc, tc))
    if ss == 0.0:
        raise ValueError("t: must not be constant")
    ec = e - e.mean(axis=0)
    return np.tensordot(tc, ec, axes=(0, 0)) / ss
