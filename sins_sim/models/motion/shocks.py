"""Shock on the SINS block: a half-sine rate pulse about a fixed axis with optional decaying ringing.

Rate, gyro angles and attitude are closed forms (the rate stays along one
axis).

.. autosummary::

   Shock
"""

from __future__ import annotations

import math
from dataclasses import InitVar, dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.motion.base import _STATIC, Motion3D, _cos_diff, _set, _sin_diff, _unit_axis

__all__ = ["Shock"]


@dataclass(frozen=True)
class Shock(Motion3D):
    """A half-sine rate pulse about a fixed axis, optionally followed by decaying block ringing.

    With ``tau = t - start_s`` and ``T = duration_s``:

    * pulse, ``0 <= tau <= T``: ``omega = axis P sin(pi tau / T)``;
    * ringing, ``u = tau - T >= 0``: ``omega = axis R exp(-u/d) sin(2 pi f_r u)``
      (``R = ring_amplitude_rad_s``, ``f_r = ring_frequency_hz``,
      ``d = ring_decay_s``); it starts at zero rate, so the rate stays continuous.

    Parameters
    ----------
    axis : {'x', 'y', 'z', 0, 1, 2} or array_like (3,)
        Shock axis in body axes (normalised).
    peak_rate_rad_s : float
        Peak rate ``P`` of the half-sine (rad/s), signed.
    duration_s : float
        Pulse duration ``T`` (s), > 0.
    start_s : float
        Pulse start (s).
    ring_frequency_hz : float, optional
        Frequency of the ringing (Hz), > 0 (e.g. the 1.6 kHz block vibration
        the paper observed); required if ``ring_amplitude_rad_s != 0``.
    ring_amplitude_rad_s : float
        Amplitude of the ringing rate (rad/s).
    ring_decay_s : float
        Exponential time constant of the ringing (s), > 0 (default 2 ms: a
        setting, not a value from the paper).

    Notes
    -----
    Closed-form integrals (elementary): the pulse's angle is
    ``P T / pi (1 - cos(pi tau/T))``, ``2 P T / pi`` in all; the ringing's is
    ``R (w - exp(-u/d) (sin(w u)/d + w cos(w u))) / (w^2 + 1/d^2)`` with
    ``w = 2 pi f_r`` (integration by parts twice). The rate stays along
    ``axis``, so the attitude is the closed form ``q0 (x) exp(phi/2)``.
    """

    axis: InitVar[object] = "z"
    peak_rate_rad_s: float = 0.0
    duration_s: float = 1e-3
    start_s: float = 0.0
    ring_frequency_hz: float | None = None
    ring_amplitude_rad_s: float = 0.0
    ring_decay_s: float = 2e-3
    axis_vector: tuple = field(init=False, default=(0.0, 0.0, 1.0))

    def __post_init__(self, axis):
        o = "Shock"
        _set(self, "axis_vector", _unit_axis(o, "axis", axis))
        _set(self, "peak_rate_rad_s", v.finite(o, "peak_rate_rad_s", self.peak_rate_rad_s))
        _set(self, "duration_s", v.positive(o, "duration_s", self.duration_s))
        _set(self, "start_s", v.finite(o, "start_s", self.start_s))
        _set(self, "ring_amplitude_rad_s", v.finite(o, "ring_amplitude_rad_s", self.ring_amplitude_rad_s))
        _set(self, "ring_decay_s", v.positive(o, "ring_decay_s", self.ring_decay_s))
        if self.ring_frequency_hz is None:
            if self.ring_amplitude_rad_s != 0.0:
                raise ValueError(f"{o}.ring_frequency_hz: required when ring_amplitude_rad_s != 0")
        else:
            _set(self, "ring_frequency_hz", v.positive(o, "ring_frequency_hz", self.ring_frequency_hz))

    def _ringing(self):
        return self.ring_frequency_hz is not None and self.ring_amplitude_rad_s != 0.0

    def _rate(self, t):
        T = self.duration_s
        tau = t - self.start_s
        mag = np.where((tau >= 0.0) & (tau <= T), self.peak_rate_rad_s * np.sin(math.pi * tau / T), 0.0)
        if self._ringing():
            u = tau - T
            w = 2.0 * math.pi * self.ring_frequency_hz
            uc = np.maximum(u, 0.0)
            ring = self.ring_amplitude_rad_s * np.exp(-uc / self.ring_decay_s) * np.sin(w * uc)
            mag = mag + np.where(u > 0.0, ring, 0.0)
        return mag[:, None] * np.array(self.axis_vector)[None, :]

    def _ring_increment(self, ua, ub):
        """``integral_{ua}^{ub} R exp(-s/d) sin(w s) ds`` for ``0 <= ua, ub``, free of cancellation.

        With ``X(u) = lam sin(w u) + w cos(w u)`` (``lam = 1/d``) the antiderivative
        is ``-R exp(-lam u) X(u) / (w^2 + lam^2)``; the difference is written as
        ``exp(-lam ua) [(X(ua) - X(ub)) - expm1(-lam (ub - ua)) X(ub)]`` with the
        sine and cosine differences in product form.
        """
        w = 2.0 * math.pi * self.ring_frequency_hz
        lam = 1.0 / self.ring_decay_s
        du = ub - ua
        xa, xb, dx = w * ua, w * ub, w * du
        x_diff = -(lam * _sin_diff(xa, xb, dx) + w * _cos_diff(xa, xb, dx))  # X(ua) - X(ub)
        x_b = lam * np.sin(xb) + w * np.cos(xb)
        bracket = x_diff - np.expm1(-lam * du) * x_b
        return self.ring_amplitude_rad_s * np.exp(-lam * ua) * bracket / (w * w + lam * lam)

    def _increment(self, ta, tb):
        T = self.duration_s
        ua = np.clip(ta - self.start_s, 0.0, T)
        ub = np.clip(tb - self.start_s, 0.0, T)
        k = math.pi / T
        # P T/pi (cos(k ua) - cos(k ub))
        theta = -self.peak_rate_rad_s / k * _cos_diff(k * ua, k * ub, k * (ub - ua))
        if self._ringing():
            ra = np.maximum(ta - self.start_s - T, 0.0)
            rb = np.maximum(tb - self.start_s - T, 0.0)
            theta = theta + self._ring_increment(ra, rb)
        return theta[:, None] * np.array(self.axis_vector)[None, :]

    def _fixed_axis(self):
        if self.peak_rate_rad_s == 0.0 and not self._ringing():
            return _STATIC
        return np.array(self.axis_vector)

# ``axis`` is an init-only argument: its class-level default would hide the
# ``Motion3D.axis(i)`` method; the unit vector is kept as ``axis_vector``.
del Shock.axis
