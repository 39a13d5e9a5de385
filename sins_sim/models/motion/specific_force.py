"""Ideal accelerometers on a block in purely angular motion: standard gravity and the body specific force.

.. autosummary::

   specific_force_body
"""

from __future__ import annotations

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.motion.base import Motion3D

__all__ = ["specific_force_body", "STANDARD_GRAVITY"]

STANDARD_GRAVITY = 9.80665
"""Standard gravity g0 (m/s^2), CGPM 1901."""


def specific_force_body(t, attitude_q, g: float = STANDARD_GRAVITY):
    """Ideal accelerometer output ``f_b = C_bn (0, 0, -g)`` of a block in purely angular motion.

    Parameters
    ----------
    t : array_like, 1-D
        Times (s).
    attitude_q : array_like (N, 4) or Motion3D
        Attitude ``q_nb`` at ``t`` (scalar first), or a motion whose
        :meth:`Motion3D.attitude` (from identity) is evaluated on ``t``.
    g : float
        Magnitude of gravity (m/s^2), >= 0.

    Returns
    -------
    ndarray, shape (N, 3)
        Specific force in body axes (m/s^2).

    Notes
    -----
    Assumptions: the navigation frame is local-level north-east-down at a
    fixed place; the accelerometers sit at the centre of rotation (no lever
    arm, hence no centripetal or tangential acceleration); the Earth's
    rotation and the transport rate are ignored; gravity is ``(0, 0, g)`` in
    NED, so the specific force ``a - g`` of a block at rest is ``(0, 0, -g)``.
    ``f_b = C_nb^T f_n`` with ``C_nb`` the rotation matrix of ``q_nb``; only
    its third row is needed. ``t`` is used only when ``attitude_q`` is a motion.
    """
    g = v.non_negative("specific_force_body", "g", g)
    t = v.finite_array("specific_force_body", "t", t)
    if isinstance(attitude_q, Motion3D):
        q = attitude_q.attitude(t)
    else:
        q = v.finite_array("specific_force_body", "attitude_q", attitude_q, ndim=2)
        if q.shape != (t.size, 4):
            raise ValueError(f"specific_force_body.attitude_q: must have shape ({t.size}, 4), got {q.shape}")
    q0, q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    row3 = np.stack((2.0 * (q1 * q3 - q0 * q2), 2.0 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3),
                    axis=-1)
    return -g * row3
