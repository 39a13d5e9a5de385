"""Strapdown attitude kernels: quaternions and coning-corrected attitude update.

Conventions (as in Savage 1998 and Titterton & Weston 2004, ch. 3 and 11):

- quaternions are Hamilton, scalar first, ``q = [q0, q1, q2, q3]``;
- ``q_nb`` rotates body-frame vectors into the navigation frame,
  ``v_n = q_nb (x) v_b (x) q_nb*``;
- a rotation vector ``phi`` (rad) is the axis times the angle; its quaternion
  is ``q(phi) = [cos(|phi|/2), sin(|phi|/2) phi/|phi|]``;
- a body-frame rotation over one step composes on the right:
  ``q_nb[k] = q_nb[k-1] (x) q(phi_k)`` (Savage 1998; Titterton & Weston
  2004, ch. 11).

The rotation vector of step ``k`` is formed from the gyro angle increments
``dtheta_k`` (rad, body frame, integral of the body rate over the step) and
one or two previous increments (the "single-speed, previous-sample" coning
algorithms; Savage 1998 sec. "Coning algorithms"; Ignagni 1996)::

    algo 0 ("none"):         phi_k = dtheta_k
    algo 1 ("two_sample"):   phi_k = dtheta_k + (1/12) dtheta_{k-1} x dtheta_k
    algo 2 ("three_sample"): phi_k = dtheta_k - (1/60) dtheta_{k-2} x dtheta_k
                                              + (7/60) dtheta_{k-1} x dtheta_k
    algo 3 ("four_sample"):  phi_k = dtheta_k + (1/280) dtheta_{k-3} x dtheta_k
                                              - (13/420) dtheta_{k-2} x dtheta_k
                                              + (113/840) dtheta_{k-1} x dtheta_k

The 1/12 coefficient is Savage's single-sample-plus-previous-sample algorithm
(Savage 1998, Part 1; Savage, *Strapdown Analytics*, 2nd ed., 2007,
eq. 7.1.1.1.1-18 with one sample per update). The (-1/60, 7/60) pair is
Ignagni's optimal three-sample "Algorithm E" (Ignagni 1990: coefficients
9/20 for ``dtheta_1 x dtheta_3`` and 27/20 for the adjacent pairs) rewritten
for one increment per update: matching the two free coefficients to the
classical-cone Taylor series of the exact coning term (Miller 1983;
Ignagni 1990) term by term through ``(Omega h)^5`` gives
``2 c1 + c2 = 1/12`` and ``360 c1 + 60 c2 = 1``, i.e. ``c1 = -1/60``,
``c2 = 7/60``; equivalently ``3 c1 + 1/2 = 9/20`` and ``3 c2 + 1 = 27/20``,
the composition of three such updates reproducing Algorithm E (see
:mod:`sins_sim.navigation.coning` for the derivation and the residuals).
The four-sample coefficients ``(113/840, -13/420, 1/280)`` follow the same
way, matching through ``(Omega h)^7`` (Miller 1983's N-sample optimality
condition with ``N = 4``); their residual is the published four-sample term.

The kernels take the coefficients, not the names: a ``(3, 3)`` array whose
row ``i`` weights component ``i`` of ``dtheta_{k-1} x dtheta_k``,
``dtheta_{k-2} x dtheta_k`` and ``dtheta_{k-3} x dtheta_k`` (columns). Every
row is the same for the named algorithms; a filter-tuned design
(:func:`sins_sim.navigation.coning.tuned_coefficients`) differs per row,
because component ``i`` is formed from the two other axes, whose filters differ.

References
----------
.. [1] J. W. Bortz, "A new mathematical formulation for strapdown inertial
   navigation", IEEE Trans. Aerosp. Electron. Syst. AES-7(1), 61-66, 1971.
.. [2] R. B. Miller, "A new strapdown attitude algorithm", J. Guidance,
   Control, and Dynamics 6(4), 287-291, 1983.
.. [3] M. B. Ignagni, "Optimal strapdown attitude integration algorithms",
   J. Guidance, Control, and Dynamics 13(2), 363-369, 1990.
.. [4] M. B. Ignagni, "Efficient class of optimized coning compensation
   algorithms", J. Guidance, Control, and Dynamics 19(2), 424-429, 1996.
.. [5] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: Attitude algorithms", J. Guidance, Control, and Dynamics
   21(1), 19-28, 1998.
.. [6] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004.

Kernels never validate: the public wrappers (:mod:`sins_sim.navigation`) do.
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit

ALGO_NONE = 0
ALGO_TWO_SAMPLE = 1
ALGO_THREE_SAMPLE = 2
ALGO_FOUR_SAMPLE = 3
#: Previous increments the kernels keep (the longest algorithm's span minus one).
N_LAGS = 3

#: algo 1: coefficient of ``dtheta_{k-1} x dtheta_k`` (Savage 1998).
C_TWO_PREV1 = 1.0 / 12.0
#: algo 2: coefficient of ``dtheta_{k-2} x dtheta_k`` (Ignagni 1990 Alg. E, one increment per update).
C_THREE_PREV2 = -1.0 / 60.0
#: algo 2: coefficient of ``dtheta_{k-1} x dtheta_k``.
C_THREE_PREV1 = 7.0 / 60.0
#: algo 3: coefficients of ``dtheta_{k-1}``, ``dtheta_{k-2}``, ``dtheta_{k-3}`` ``x dtheta_k``
#: (module docstring; matched through ``(Omega h)^7``).
C_FOUR_PREV1 = 113.0 / 840.0
C_FOUR_PREV2 = -13.0 / 420.0
C_FOUR_PREV3 = 1.0 / 280.0

#: Below this ``|phi|^2`` (rad^2) the rotation-vector-to-quaternion map uses
#: its Taylor series; the first neglected terms are below 3e-23.
SMALL_ANGLE2 = 1e-6


@jit
def quat_mul(p, q, out):
    """Hamilton product ``out = p (x) q`` (scalar first).

    ``out = [p0 q0 - pv.qv, p0 qv + q0 pv + pv x qv]`` (Titterton & Weston
    2004, ch. 3). ``out`` may be the same array as ``p`` or ``q``.

    Parameters
    ----------
    p, q : ndarray, shape (4,), float64
        Quaternions, scalar first.
    out : ndarray, shape (4,), float64
        Written in full.
    """
    p0, p1, p2, p3 = p[0], p[1], p[2], p[3]
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    out[0] = p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3
    out[1] = p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2
    out[2] = p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1
    out[3] = p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0


@jit
def quat_to_dcm(q, c):
    """The direction cosine matrix of a unit quaternion (scalar first) into the 3x3 array ``c``: ``C_nb`` of
    ``q_nb`` (Titterton & Weston 2004, eq. 3.63)."""
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    c[0, 0] = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    c[0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    c[0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    c[1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    c[1, 1] = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    c[1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    c[2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    c[2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    c[2, 2] = 1.0 - 2.0 * (q1 * q1 + q2 * q2)


@jit
def rotvec_to_quat(phi, out):
    """Quaternion of the rotation vector ``phi`` (rad).

    ``q = [cos(|phi|/2), sin(|phi|/2)/|phi| * phi]`` (Savage 1998;
    Titterton & Weston 2004, ch. 11). For ``|phi|^2 < 1e-6`` the two
    coefficients come from their Taylor series in ``n2 = |phi|^2``::

        cos(|phi|/2)        = 1 - n2/8 + n2^2/384 - n2^3/46080
        sin(|phi|/2)/|phi|  = 1/2 - n2/48 + n2^2/3840 - n2^3/645120

    so no division by a vanishing norm occurs.

    Parameters
    ----------
    phi : ndarray, shape (3,), float64
        Rotation vector (rad).
    out : ndarray, shape (4,), float64
        Written in full.
    """
    n2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
    if n2 < SMALL_ANGLE2:
        c = 1.0 - n2 * (1.0 / 8.0 - n2 * (1.0 / 384.0 - n2 * (1.0 / 46080.0)))
        s = 0.5 - n2 * (1.0 / 48.0 - n2 * (1.0 / 3840.0 - n2 * (1.0 / 645120.0)))
    else:
        n = math.sqrt(n2)
        c = math.cos(0.5 * n)
        s = math.sin(0.5 * n) / n
    out[0] = c
    out[1] = s * phi[0]
    out[2] = s * phi[1]
    out[3] = s * phi[2]


@jit
def attitude_update(dtheta, q0, coef, prev, out_q):
    """Coning-corrected strapdown attitude update, one step per increment.

    For ``k = 0 .. N-1`` and each component ``i``::

        phi_k,i = dtheta_k,i + sum_{j=1..3} coef[i, j-1] (dtheta_{k-j} x dtheta_k)_i
        q_k     = normalise(q_{k-1} (x) q(phi_k)),      q_{-1} = q0

    with the rows of ``coef`` all ``(0, 0, 0)`` (none), ``(1/12, 0, 0)``
    (two-sample, Savage 1998), ``(7/60, -1/60, 0)`` (three-sample, Ignagni 1990
    Algorithm E, one increment per update), ``(113/840, -13/420, 1/280)``
    (four-sample) or a filter-tuned design (module docstring).
    ``q(phi)`` is :func:`rotvec_to_quat`; the product is :func:`quat_mul`.
    The renormalisation (division by the Euclidean norm) removes the
    rounding-driven norm drift and changes nothing else.

    Streaming: ``prev`` holds ``[dtheta_{-3}, dtheta_{-2}, dtheta_{-1}]`` on
    entry and is overwritten with the last three increments, so calling the
    kernel on consecutive chunks (feeding ``out_q[-1]`` back as ``q0``) gives
    the same bits as one call on the whole array.

    Parameters
    ----------
    dtheta : ndarray, shape (N, 3), float64
        Gyro angle increments (rad, body frame), one per update.
    q0 : ndarray, shape (4,), float64
        Attitude ``q_nb`` before the first increment (unit norm). Not written.
    coef : ndarray, shape (3, 3), float64
        ``coef[i, j - 1]``: weight of ``(dtheta_{k-j} x dtheta_k)_i``.
    prev : ndarray, shape (3, 3), float64
        ``prev[0] = dtheta_{k-3}``, ``prev[1] = dtheta_{k-2}``, ``prev[2] = dtheta_{k-1}``
        (rad); read and updated in place.
    out_q : ndarray, shape (N, 4), float64
        ``out_q[k]`` is the attitude after increment ``k``; written in full.
    """
    a0, a1, a2, a3 = q0[0], q0[1], q0[2], q0[3]
    l0, l1, l2 = prev[0, 0], prev[0, 1], prev[0, 2]  # dtheta_{k-3}
    m0, m1, m2 = prev[1, 0], prev[1, 1], prev[1, 2]  # dtheta_{k-2}
    p0, p1, p2 = prev[2, 0], prev[2, 1], prev[2, 2]  # dtheta_{k-1}
    phi = prev[0].copy()
    dq = q0.copy()
    for k in range(dtheta.shape[0]):
        d0, d1, d2 = dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]
        phi[0] = d0 + (coef[0, 0] * (p1 * d2 - p2 * d1) + coef[0, 1] * (m1 * d2 - m2 * d1)
                       + coef[0, 2] * (l1 * d2 - l2 * d1))
        phi[1] = d1 + (coef[1, 0] * (p2 * d0 - p0 * d2) + coef[1, 1] * (m2 * d0 - m0 * d2)
                       + coef[1, 2] * (l2 * d0 - l0 * d2))
        phi[2] = d2 + (coef[2, 0] * (p0 * d1 - p1 * d0) + coef[2, 1] * (m0 * d1 - m1 * d0)
                       + coef[2, 2] * (l0 * d1 - l1 * d0))
        rotvec_to_quat(phi, dq)
        b0, b1, b2, b3 = dq[0], dq[1], dq[2], dq[3]
        r0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
        r1 = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
        r2 = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
        r3 = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
        inv = 1.0 / math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
        a0 = r0 * inv
        a1 = r1 * inv
        a2 = r2 * inv
        a3 = r3 * inv
        out_q[k, 0] = a0
        out_q[k, 1] = a1
        out_q[k, 2] = a2
        out_q[k, 3] = a3
        l0, l1, l2 = m0, m1, m2
        m0, m1, m2 = p0, p1, p2
        p0, p1, p2 = d0, d1, d2
    prev[0, 0] = l0
    prev[0, 1] = l1
    prev[0, 2] = l2
    prev[1, 0] = m0
    prev[1, 1] = m1
    prev[1, 2] = m2
    prev[2, 0] = p0
    prev[2, 1] = p1
    prev[2, 2] = p2


@jit
def error_rotvec(p0, p1, p2, p3, t0, t1, t2, t3):
    """``rotvec(p (x) t*)`` (rad) of two unit quaternions: the attitude error of ``p`` against ``t``.

    The product taken with a non-negative scalar part, ``phi = 2 atan2(|qv|, q0) qv / |qv|``, and for
    ``|qv| < 1e-5`` the series ``(2/q0)(1 - |qv|^2 / (3 q0^2))`` (next term below 1e-20 relative).
    """
    r0, r1, r2, r3 = t0, -t1, -t2, -t3
    w = p0 * r0 - p1 * r1 - p2 * r2 - p3 * r3
    x = p0 * r1 + p1 * r0 + p2 * r3 - p3 * r2
    y = p0 * r2 - p1 * r3 + p2 * r0 + p3 * r1
    z = p0 * r3 + p1 * r2 - p2 * r1 + p3 * r0
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-5:
        f = (2.0 / w) * (1.0 - n * n / (3.0 * w * w))
    else:
        f = 2.0 * math.atan2(n, w) / n
    return f * x, f * y, f * z


@jit
def attitude_error_run(q_est, q_true, out):
    """``out[k] = rotvec(q_est[k] (x) q_true[k]*)`` (rad), the kernel of ``navigation.attitude_error``.

    Same formula as the numpy reference ``navigation.attitude.rotvec_from_quat``: the
    quaternion with ``q0 >= 0``, ``phi = 2 atan2(|qv|, q0) qv / |qv|``, and for
    ``|qv| < 1e-5`` the series ``(2/q0)(1 - |qv|^2 / (3 q0^2))``.
    """
    for k in range(q_est.shape[0]):
        x, y, z = error_rotvec(q_est[k, 0], q_est[k, 1], q_est[k, 2], q_est[k, 3],
                               q_true[k, 0], q_true[k, 1], q_true[k, 2], q_true[k, 3])
        out[k, 0] = x
        out[k, 1] = y
        out[k, 2] = z
