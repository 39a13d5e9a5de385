"""Single-axis SINS motion about one gyro's sensitive axis: angle and rate on a time grid.

A motion is anything with ``angle_rate(t) -> (angle_rad, rate_rad_s)`` for an
array of times ``t`` (s). Generated motions evaluate closed forms; recorded
motion is interpolated by a cubic spline (``SampledMotion``). The plant needs
both angle and rate at its grid points (``_kernels.plant``).
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from sins_sim import _validate as v

__all__ = ["StaticMotion", "SineMotion", "ConstantRateMotion", "SampledMotion", "CallableMotion", "SumMotion", "as_motion"]


class _Motion(abc.ABC):
    """Interface: ``angle_rate(t)`` gives angle (rad) and rate (rad/s) at times ``t`` (s)."""

    @abc.abstractmethod
    def angle_rate(self, t):
        """Angle and rate arrays at the times ``t``."""

    def __add__(self, other):
        return SumMotion((self, other))


@dataclass(frozen=True)
class StaticMotion(_Motion):
    """The block at rest (angle 0)."""

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        return np.zeros_like(t), np.zeros_like(t)


@dataclass(frozen=True)
class SineMotion(_Motion):
    """``phi(t) = A sin(2 pi f t + phase)`` (rad)."""

    amplitude_rad: float
    frequency_hz: float
    phase_rad: float = 0.0

    def __post_init__(self):
        v.non_negative("motion", "amplitude_rad", self.amplitude_rad)
        v.positive("motion", "frequency_hz", self.frequency_hz)
        v.finite("motion", "phase_rad", self.phase_rad)

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        w = 2.0 * math.pi * self.frequency_hz
        arg = w * t + self.phase_rad
        return self.amplitude_rad * np.sin(arg), self.amplitude_rad * w * np.cos(arg)


@dataclass(frozen=True)
class ConstantRateMotion(_Motion):
    """A steady rotation ``phi(t) = rate * t``."""

    rate_rad_s: float

    def __post_init__(self):
        v.finite("motion", "rate_rad_s", self.rate_rad_s)

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        return self.rate_rad_s * t, np.full_like(t, self.rate_rad_s)


class SampledMotion(_Motion):
    """Recorded angle samples, interpolated by a C2 cubic spline (rate = its derivative).

    ``angles[k]`` is the angle at ``t0 + k / fs_hz``; outside the record the
    angle is held at the end values with zero rate. The record must be
    band-limited well below ``fs_hz / 2`` (a recording's ``sins_angle``, sins_sim.io.recording).
    """

    def __init__(self, angles, fs_hz: float, t0: float = 0.0):
        self.fs_hz = v.positive("motion", "fs_hz", fs_hz)
        self.t0 = v.finite("motion", "t0", t0)
        angles = v.finite_array("motion", "angles", angles)
        if angles.size < 4:
            raise ValueError(f"motion.angles: needs at least 4 samples for a cubic spline, got {angles.size}")
        times = self.t0 + np.arange(angles.size) / self.fs_hz
        self._spline = CubicSpline(times, angles, bc_type="not-a-knot")
        self._t_end = times[-1]
        self._ends = (angles[0], angles[-1])

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        tc = np.clip(t, self.t0, self._t_end)
        angle = self._spline(tc)
        rate = self._spline(tc, 1)
        outside = (t < self.t0) | (t > self._t_end)
        rate = np.where(outside, 0.0, rate)
        return angle, rate


class CallableMotion(_Motion):
    """Wrap ``f(t) -> (angle, rate)`` given by the user (vectorised over t)."""

    def __init__(self, func):
        if not callable(func):
            raise ValueError(f"motion: must be callable returning (angle, rate), got {func!r}")
        self._func = func

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        angle, rate = self._func(t)
        angle = np.broadcast_to(np.asarray(angle, dtype=np.float64), t.shape)
        rate = np.broadcast_to(np.asarray(rate, dtype=np.float64), t.shape)
        if not (np.all(np.isfinite(angle)) and np.all(np.isfinite(rate))):
            raise ValueError("motion: the callable returned NaN or inf")
        return angle, rate


@dataclass(frozen=True)
class SumMotion(_Motion):
    """The sum of several motions."""

    parts: tuple

    def angle_rate(self, t):
        t = np.asarray(t, dtype=np.float64)
        angle = np.zeros_like(t)
        rate = np.zeros_like(t)
        for part in self.parts:
            a, r = part.angle_rate(t)
            angle = angle + a
            rate = rate + r
        return angle, rate


def as_motion(motion) -> _Motion:
    """Accept ``None`` (static), a motion object, or a callable ``t -> (angle, rate)``."""
    if motion is None:
        return StaticMotion()
    if hasattr(motion, "angle_rate"):
        return motion
    return CallableMotion(motion)
