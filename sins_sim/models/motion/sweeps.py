"""Rate-table sweeps: a swept-sine (chirp) angle of the SINS block about a fixed axis, linear or log.

Rate, gyro angles and attitude are closed forms (the rate stays along one
axis).

.. autosummary::

   RateTableSweep
"""

from __future__ import annotations

import math
from dataclasses import InitVar, dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.motion.base import _STATIC, Motion3D, _set, _sin_diff, _unit_axis

__all__ = ["RateTableSweep"]


@dataclass(frozen=True)
class RateTableSweep(Motion3D):
    """A swept-sine (chirp) angle about a fixed axis, as a rate table produces it.

    ``theta(tau) = A sin(psi(tau))`` for ``0 <= tau = t - start_s <= D``,
    ``0`` before, held at ``A sin(psi(D))`` after; the rate is
    ``A psi'(tau) cos(psi(tau))`` inside and 0 outside (the angle is
    continuous, the rate steps at start and stop as on a real table that
    starts abruptly).

    * ``kind="linear"``: ``psi = 2 pi (f0 tau + (f1 - f0) tau^2 / (2 D))``;
    * ``kind="log"``: ``psi = 2 pi f0 (exp(k tau) - 1) / k``, ``k = ln(f1/f0)/D``
      (instantaneous frequency ``f0 exp(k tau)``).

    Parameters
    ----------
    axis : {'x', 'y', 'z', 0, 1, 2} or array_like (3,)
        Table axis in body axes (normalised).
    amplitude_rad : float
        Angle amplitude ``A`` (rad), >= 0.
    f_start_hz, f_stop_hz : float
        Start and stop frequency (Hz), > 0 (a down-sweep is allowed).
    duration_s : float
        Sweep duration ``D`` (s), > 0.
    start_s : float
        Sweep start (s).
    kind : {"linear", "log"}
        Frequency law.

    Notes
    -----
    Closed forms: the rate is the derivative of the angle (chain rule); the
    attitude is ``q0 (x) exp(phi/2)`` (fixed axis).
    """

    axis: InitVar[object] = "z"
    amplitude_rad: float = 0.0
    f_start_hz: float = 1.0
    f_stop_hz: float = 1.0
    duration_s: float = 1.0
    start_s: float = 0.0
    kind: str = "linear"
    axis_vector: tuple = field(init=False, default=(0.0, 0.0, 1.0))

    def __post_init__(self, axis):
        o = "RateTableSweep"
        _set(self, "axis_vector", _unit_axis(o, "axis", axis))
        _set(self, "amplitude_rad", v.non_negative(o, "amplitude_rad", self.amplitude_rad))
        _set(self, "f_start_hz", v.positive(o, "f_start_hz", self.f_start_hz))
        _set(self, "f_stop_hz", v.positive(o, "f_stop_hz", self.f_stop_hz))
        _set(self, "duration_s", v.positive(o, "duration_s", self.duration_s))
        _set(self, "start_s", v.finite(o, "start_s", self.start_s))
        v.choice(o, "kind", self.kind, {"linear", "log"})
        k = math.log(self.f_stop_hz / self.f_start_hz) / self.duration_s if self.kind == "log" else 0.0
        _set(self, "_k", k)

    def _psi(self, tau):
        f0, f1, D = self.f_start_hz, self.f_stop_hz, self.duration_s
        if self.kind == "linear":
            return 2.0 * math.pi * tau * (f0 + 0.5 * (f1 - f0) * tau / D)
        if self._k == 0.0:
            return 2.0 * math.pi * f0 * tau
        return 2.0 * math.pi * f0 * np.expm1(self._k * tau) / self._k

    def _dpsi(self, tau):
        f0, f1, D = self.f_start_hz, self.f_stop_hz, self.duration_s
        if self.kind == "linear":
            return 2.0 * math.pi * (f0 + (f1 - f0) * tau / D)
        return 2.0 * math.pi * f0 * np.exp(self._k * tau)

    def _rate(self, t):
        tau = t - self.start_s
        inside = (tau >= 0.0) & (tau <= self.duration_s)
        tc = np.clip(tau, 0.0, self.duration_s)
        mag = np.where(inside, self.amplitude_rad * self._dpsi(tc) * np.cos(self._psi(tc)), 0.0)
        return mag[:, None] * np.array(self.axis_vector)[None, :]

    def _increment(self, ta, tb):
        D = self.duration_s
        ua = np.clip(ta - self.start_s, 0.0, D)
        ub = np.clip(tb - self.start_s, 0.0, D)
        pa = self._psi(ua)
        pb = self._psi(ub)
        du = ub - ua
        f0, f1 = self.f_start_hz, self.f_stop_hz
        if self.kind == "linear":
            dpsi = 2.0 * math.pi * du * (f0 + 0.5 * (f1 - f0) * (ua + ub) / D)
        elif self._k == 0.0:
            dpsi = 2.0 * math.pi * f0 * du
        else:
            dpsi = 2.0 * math.pi * f0 * np.exp(self._k * ua) * np.expm1(self._k * du) / self._k
        theta = self.amplitude_rad * _sin_diff(pa, pb, dpsi)
        return theta[:, None] * np.array(self.axis_vector)[None, :]

    def _fixed_axis(self):
        return _STATIC if self.amplitude_rad == 0.0 else np.array(self.axis_vector)

# ``axis`` is an init-only argument: its class-level default would hide the
# ``Motion3D.axis(i)`` method; the unit vector is kept as ``axis_vector``.
del RateTableSweep.axis
