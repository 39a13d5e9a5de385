"""Rigid rotations of the SINS block about a fixed axis: at rest, steady rate, raised-cosine turn.

Each keeps its rate along one fixed axis, so gyro angles and attitude are
closed forms (``q0 (x) exp(phi/2)``; :class:`~sins_sim.models.motion.base.Motion3D`).

.. autosummary::

   Static
   ConstantRate
   Turn
"""

from __future__ import annotations

import math
from dataclasses import InitVar, dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.motion.base import _STATIC, Motion3D, _set, _sin_diff, _unit_axis, _vec3

__all__ = ["Static", "ConstantRate", "Turn"]


@dataclass(frozen=True)
class Static(Motion3D):
    """The block at rest: zero rate, zero gyro angles, constant attitude."""

    def _rate(self, t):
        return np.zeros((t.size, 3))

    def _increment(self, ta, tb):
        return np.zeros((ta.size, 3))

    def grid_angle_rate(self, i0: int, n: int, h: float):
        return np.zeros((n, 3), order="F"), np.zeros((n, 3), order="F")

    def _fixed_axis(self):
        return _STATIC


@dataclass(frozen=True)
class ConstantRate(Motion3D):
    """A steady rotation: ``omega_b = rate_rad_s`` (constant), ``phi = rate t``.

    Parameters
    ----------
    rate_rad_s : float or array_like (3,)
        Body rate (rad/s); a number applies to all three axes.

    Notes
    -----
    The attitude is the closed form ``q0 (x) exp(rate t / 2)`` (rotation about
    the fixed axis ``rate / |rate|``).
    """

    rate_rad_s: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        _set(self, "rate_rad_s", _vec3("ConstantRate", "rate_rad_s", self.rate_rad_s))

    def _rate(self, t):
        return np.broadcast_to(np.array(self.rate_rad_s), (t.size, 3)).copy()

    def _increment(self, ta, tb):
        return (tb - ta)[:, None] * np.array(self.rate_rad_s)[None, :]

    def _fixed_axis(self):
        r = np.array(self.rate_rad_s)
        n = float(np.linalg.norm(r))
        return _STATIC if n == 0.0 else r / n


@dataclass(frozen=True)
class Turn(Motion3D):
    """A turn by ``angle_rad`` about a fixed ``axis`` with a raised-cosine rate profile.

    ``omega_b(t) = axis * angle/T * (1 - cos(2 pi tau/T))`` for
    ``0 <= tau = t - start_s <= T`` (``T = duration_s``), zero before and
    after; rate and its derivative are continuous and the rate integrates to
    ``angle_rad`` over the turn.

    Parameters
    ----------
    axis : {'x', 'y', 'z', 0, 1, 2} or array_like (3,)
        Rotation axis in body axes (normalised).
    angle_rad : float
        Turn angle (rad), signed.
    duration_s : float
        Turn duration ``T`` (s), > 0.
    start_s : float
        Start of the turn (s).

    Notes
    -----
    Closed forms (elementary): ``theta(tau) = angle (tau/T - sin(2 pi tau/T) / (2 pi))``
    with ``tau`` clipped to ``[0, T]``; attitude ``q0 (x) exp(axis theta / 2)``.
    """

    axis: InitVar[object] = "z"
    angle_rad: float = 0.0
    duration_s: float = 1.0
    start_s: float = 0.0
    axis_vector: tuple = field(init=False, default=(0.0, 0.0, 1.0))

    def __post_init__(self, axis):
        _set(self, "axis_vector", _unit_axis("Turn", "axis", axis))
        _set(self, "angle_rad", v.finite("Turn", "angle_rad", self.angle_rad))
        _set(self, "duration_s", v.positive("Turn", "duration_s", self.duration_s))
        _set(self, "start_s", v.finite("Turn", "start_s", self.start_s))

    def _rate(self, t):
        tau = t - self.start_s
        inside = (tau >= 0.0) & (tau <= self.duration_s)
        mag = self.angle_rad / self.duration_s * (1.0 - np.cos(2.0 * math.pi * tau / self.duration_s))
        return np.where(inside, mag, 0.0)[:, None] * np.array(self.axis_vector)[None, :]

    def _increment(self, ta, tb):
        T = self.duration_s
        ua = np.clip(ta - self.start_s, 0.0, T)
        ub = np.clip(tb - self.start_s, 0.0, T)
        du = ub - ua
        k = 2.0 * math.pi / T
        theta = self.angle_rad * (du / T - _sin_diff(k * ua, k * ub, k * du) / (2.0 * math.pi))
        return theta[:, None] * np.array(self.axis_vector)[None, :]

    def _fixed_axis(self):
        return _STATIC if self.angle_rad == 0.0 else np.array(self.axis_vector)

# ``axis`` is an init-only argument: its class-level default would hide the
# ``Motion3D.axis(i)`` method; the unit vector is kept as ``axis_vector``.
del Turn.axis
